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
                       RS_MAXF, RS_MAXWORK, RS_MONITOR, RS_WORK)
from ._kernels import render_step as _render_step
from ._validation import fail, optional_positive
from .algorithms import Algorithm

__all__ = ["Renderer", "WORKSPACE_LIMIT"]

_REAL = (int, float, np.integer, np.floating)

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
        optional_positive("max_force", max_force, "N")
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
        p : sequence of two real numbers
            Probe position [x, z] (m): a tuple, list or NumPy array of exactly two real
            (not boolean, not complex) numbers.

        Returns
        -------
        tuple of two floats
            Force [f_x, f_z] (N); (0.0, 0.0) for a faulty position: anything else than two
            finite real numbers within +-1 km (strings, bytes, dicts, complex numbers,
            booleans, three coordinates, ...), counted in :attr:`faults`.

        Notes
        -----
        Never raises, never returns NaN or a force above ``max_force``, and does a bounded
        amount of work for any input (:attr:`last_work`).
        """
        try:
            if isinstance(p, (str, bytes, bytearray, dict)) or len(p) != 2:
                raise TypeError
            x, z = p[0], p[1]
            if not (isinstance(x, _REAL) and isinstance(z, _REAL)) or isinstance(x, bool) or isinstance(z, bool):
                raise TypeError
            return _render_step(float(x), float(z), self._code, self._kind, self._coeffs, self._prm, self._aux,
                                self._st, self._rs)
        except Exception:  # a malformed p: never let it reach the motor loop
            self._rs[RS_FAULTS] += 1.0
            self._rs[RS_HAVE_LAST] = 0.0
            self._rs[RS_WORK] = 0.0
            return (0.0, 0.0)

    @property
    def last_work(self) -> int:
        """Work of the last :meth:`step`, bounded for any input: texture evaluations, plus
        F's presliding table steps (at most 11 + 60) in its smooth variant."""
        return int(self._rs[RS_WORK])

    @property
    def max_work(self) -> int:
        """Largest :attr:`last_work` since construction or :meth:`reset`."""
        return int(self._rs[RS_MAXWORK])

    def reset(self) -> None:
        """Clear the algorithm's state (friction, warm start), the energy monitor and the counters."""
        self._st[:] = 0.0
        for k in (RS_FAULTS, RS_CLAMPS, RS_HAVE_LAST, RS_LX, RS_LZ, RS_LFX, RS_LFZ, RS_EX, RS_EZ, RS_WORK, RS_MAXWORK):
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
