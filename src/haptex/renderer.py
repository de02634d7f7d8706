"""A real-time rendering path: one compiled call per servo tick.

A :class:`Renderer` holds an algorithm's compiled kernel and its state (F's adhesion
point; D's and E's last closest point, a warm start) and turns one probe position into
the force to command. It is meant to be called from a device's servo loop at 1–10 kHz.
"""

from __future__ import annotations

import math

import numpy as np

from . import _kernels
from ._kernels import (N_RS, RS_CLAMPS, RS_EX, RS_EZ, RS_FAULTS, RS_HAVE_LAST, RS_LFX, RS_LFZ, RS_LIMIT, RS_LX, RS_LZ,
                       RS_MAXF, RS_MONITOR)
from ._kernels import render_step as _render_step
from ._validation import fail
from .algorithms import Algorithm

__all__ = ["Renderer", "WORKSPACE_LIMIT"]

WORKSPACE_LIMIT = 1e3
"""Positions with a coordinate beyond +-1 km (m) are treated as faults (zero force)."""

class Renderer:
    """Compiled force rendering for a servo loop.

    Parameters
    ----------
    algorithm : Algorithm
        W or A–G, from :func:`haptex.algorithm`.
    max_force : float, optional
        Largest force magnitude to command (N); larger forces are scaled down to it and
        counted in :attr:`clamps`. ``None``: no limit.
    energy_monitor : bool, optional
        Keep the passivity observer of Hannaford & Ryu (2002): the running sum of
        -f . dp, exposed as :attr:`energy` (J). It decreases when the texture supplies
        energy to the hand.

    Raises
    ------
    ParameterError
        If ``algorithm`` is not a haptex algorithm or ``max_force`` is not > 0.

    Notes
    -----
    ``step`` never raises and never returns a non-finite force: a position that is not
    two finite numbers within +-1 km returns zero force and is counted in
    :attr:`faults`. One renderer per device; it keeps state between calls and is **not
    thread-safe** — call it from one thread (the servo thread) only.

    References
    ----------
    B. Hannaford and J.-H. Ryu, "Time-domain passivity control of haptic interfaces",
    IEEE Trans. Robotics and Automation 18(1), 2002, pp. 1–10.
    """

    def __init__(self, algorithm: Algorithm, max_force: float | None = None, energy_monitor: bool = False):
        if not isinstance(algorithm, Algorithm):
            raise fail("algorithm", algorithm, "a haptex algorithm (haptex.algorithm(...))")
        if max_force is not None:
            mf = float(max_force) if not isinstance(max_force, bool) else -1.0
            if not mf > 0 or math.isnan(mf):
                raise fail("max_force", max_force, "a force > 0 N, or None for no limit")
        self.algorithm = algorithm
        code, prm, kind, coeffs, aux = algorithm.kernel_spec()
        self._code = int(code)
        self._kind = int(kind)
        self._coeffs = np.ascontiguousarray(coeffs, dtype=np.float64)
        self._prm = np.ascontiguousarray(prm, dtype=np.float64)
        self._aux = np.ascontiguousarray(aux, dtype=np.float64)
        self._st = np.zeros(_kernels.N_STATE)
        self._rs = np.zeros(N_RS)
        self._rs[RS_MAXF] = math.inf if max_force is None else float(max_force)
        self._rs[RS_MONITOR] = 1.0 if energy_monitor else 0.0
        self._rs[RS_LIMIT] = WORKSPACE_LIMIT
        # compile (or load from the cache) now, not in the servo loop
        _render_step(0.0, 1.0, self._code, self._kind, self._coeffs, self._prm, self._aux, self._st, self._rs)
        self.reset()

    def step(self, p):
        """Force to command for one probe position.

        Parameters
        ----------
        p : sequence of two floats
            Probe position [x, z] (m).

        Returns
        -------
        tuple of two floats
            Force [f_x, f_z] (N); (0.0, 0.0) for a faulty position.
        """
        try:
            return _render_step(float(p[0]), float(p[1]), self._code, self._kind, self._coeffs, self._prm,
                                self._aux, self._st, self._rs)
        except Exception:  # a malformed p: never let it reach the motor loop
            self._rs[RS_FAULTS] += 1.0
            self._rs[RS_HAVE_LAST] = 0.0
            return (0.0, 0.0)

    def reset(self) -> None:
        """Clear the algorithm's state (friction, warm start), the energy monitor and the counters."""
        self._st[:] = 0.0
        for k in (RS_FAULTS, RS_CLAMPS, RS_HAVE_LAST, RS_LX, RS_LZ, RS_LFX, RS_LFZ, RS_EX, RS_EZ):
            self._rs[k] = 0.0

    @property
    def faults(self) -> int:
        """Calls whose position was not two finite numbers within +-1 km (zero force returned)."""
        return int(self._rs[RS_FAULTS])

    @property
    def clamps(self) -> int:
        """Calls whose force was scaled down to ``max_force``."""
        return int(self._rs[RS_CLAMPS])

    @property
    def energy(self) -> float:
        """Passivity observer: energy absorbed by the virtual environment so far (J);
        negative means the rendering has supplied energy. 0 without ``energy_monitor``."""
        return float(self._rs[RS_EX] + self._rs[RS_EZ])

    @property
    def energy_per_axis(self) -> tuple[float, float]:
        """(E_x, E_z) of the passivity observer (J), the paper's Section V-B sums."""
        return float(self._rs[RS_EX]), float(self._rs[RS_EZ])

    @property
    def adhesion(self) -> float | None:
        """F's adhesion point (m) while in contact, else None."""
        if self.algorithm.letter != "F" or self._st[_kernels.S_CONTACT] == 0.0:
            return None
        return float(self._st[_kernels.S_ADH])
