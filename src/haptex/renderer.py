"""A real-time rendering path: one C call per servo tick.

A :class:`Renderer` holds an algorithm's model and state in the C core (F's adhesion point;
D's and E's last closest point, a warm start; the passivity observer and controller; the
counters) and turns one probe position into the force to command. It is meant to be called
from a device's servo loop at 1–10 kHz.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from dataclasses import dataclass

from . import _kernels
from . import core as _core
from ._kernels import (PC_ACTIVE, PC_ALPHA, PC_BMAX, PC_E, PC_EAX, PC_HAVE, PC_ON, PC_REF, PC_REF_STORED,
                       PC_REF_ZERO, PC_T, RS_CLAMPS, RS_DIM, RS_FAULTS, RS_LIMIT, RS_MAXF, RS_MAXWORK, RS_MONITOR,
                       RS_WORK)
from ._kernels import render_step as _render_step
from ._validation import fail, optional_positive, positive
from .algorithms import Algorithm
from .closest import table_search_data

__all__ = ["Renderer", "PassivityController", "WORKSPACE_LIMIT"]

_REAL = (int, float, np.integer, np.floating)

WORKSPACE_LIMIT = 1e3
"""Positions with a coordinate beyond +-1 km (m) are treated as faults (zero force)."""


@dataclass(frozen=True)
class PassivityController:
    """A time-domain passivity observer and controller for a servo loop.

    The observer sums the energy the virtual environment absorbs, E = -sum f_{k-1} . dp_k,
    from the force sent and the displacement sensed (Hannaford & Ryu 2002). When E falls
    below a reference the controller adds a variable damper -alpha v (v the backward
    difference of the sensed positions) that dissipates the deficit within one sample,
    alpha = (E_ref - E) / (T |v|^2), bounded by ``max_damping``.

    Parameters
    ----------
    max_damping : float
        Largest damping the controller may add (N s/m), > 0: what the device can render
        without going unstable itself (for a device with viscous damping b and sampling
        period T, a virtual damper is passive up to about b; Colgate & Schenkel 1997).
    reference : {"stored", "zero"}
        ``"zero"``: E_ref = 0, the observer of Hannaford & Ryu (2002): the environment may
        give back all it absorbed. ``"stored"`` (default): E_ref = kappa_0 d^2 / 2, the energy
        still stored in the algorithm's virtual spring at its own penetration d (Table I):
        what the environment has absorbed must cover what it can still give back, so energy
        generated anywhere along a path (a non-conservative field, the zero-order hold) is
        dissipated as it appears — a reference energy in the style of Ryu, Preusche,
        Hannaford & Hirzinger (2005).

    Raises
    ------
    ParameterError
        If ``max_damping`` is not > 0 or ``reference`` is not one of the two.

    References
    ----------
    B. Hannaford and J.-H. Ryu, "Time-domain passivity control of haptic interfaces", IEEE
    Trans. Robotics and Automation 18(1), 2002, pp. 1–10.
    J.-H. Ryu, C. Preusche, B. Hannaford and G. Hirzinger, "Time domain passivity control
    with reference energy following", IEEE Trans. Control Systems Technology 13(5), 2005,
    pp. 737–742.
    """

    max_damping: float
    reference: str = "stored"

    def __post_init__(self):
        object.__setattr__(self, "max_damping", positive("max_damping", self.max_damping, "N s/m"))
        if self.reference not in ("stored", "zero"):
            raise fail("reference", self.reference, 'one of "stored", "zero"')


def _tick_search_data(algorithm: Algorithm, aux: np.ndarray) -> np.ndarray:
    """D's and E's search data with the cell table a tick reads over a profile (the tree
    alone over a surface); other algorithms' ``aux`` unchanged."""
    if algorithm.letter not in ("D", "E"):
        return aux
    from .surfaces import Extruded

    tex = algorithm.texture
    if tex.dimension == 1:
        return table_search_data(tex)
    if isinstance(tex, Extruded):
        return table_search_data(tex.profile)
    return aux


def _fast_step(renderer: "Renderer"):
    """:meth:`Renderer.step` for a servo loop: a tuple or list of plain floats goes straight to
    the compiled tick, through its compiled entry point (numba's type dispatch skipped: the
    argument types are known), with no attribute lookup; anything else takes the checked path.
    About 0.2 us less a call than the checked path on the benchmark machine."""
    mem = renderer._mem
    checked = renderer._step_checked
    args = (0.0, 0.0, 0.0, mem)
    try:
        tick = _render_step.overloads[tuple(numba.typeof(a) for a in args)].entry_point
    except (AttributeError, KeyError):  # numba does not expose it: dispatch as usual
        tick = _render_step
    if renderer.dimension == 2:
        def step(p):
            if type(p) is tuple or type(p) is list:
                if len(p) == 2:
                    x, z = p
                    if type(x) is float and type(z) is float:
                        fx, _, fz = tick(x, 0.0, z, mem)
                        return fx, fz
            return checked(p)
    else:
        def step(p):
            if type(p) is tuple or type(p) is list:
                if len(p) == 3:
                    x, y, z = p
                    if type(x) is float and type(y) is float and type(z) is float:
                        return tick(x, y, z, mem)
            return checked(p)
    step.__doc__ = Renderer.step.__doc__
    return step


MAX_EVALUATIONS = 5000
"""The default budget of texture evaluations for one tick's closest-point search (D, E over a
surface; chosen): about 12 times the paper's egg-crate's typical tick (410), about 0.3 ms here."""


class Renderer:
    """Compiled force rendering for a servo loop, over a profile ([x, z]) or a surface
    ([x, y, z]).

    Parameters
    ----------
    algorithm : Algorithm
        W or A–G, from :func:`haptex.algorithm`; its texture's dimension sets the
        positions' (2 over a profile, 3 over a surface).
    max_force : float, optional
        Largest force magnitude to command (N); larger forces are scaled down to it and
        counted in :attr:`clamps`. ``None``: no limit.
    energy_monitor : bool, optional
        Keep the passivity observer of Hannaford & Ryu (2002): the running sum of
        -f . dp, exposed as :attr:`energy` (J). It decreases when the texture supplies
        energy to the hand. Implied by ``passivity_controller``.
    passivity_controller : PassivityController, optional
        Add the passivity controller's damping to the force (:class:`PassivityController`);
        needs ``period``.
    period : float, optional
        The servo period T (s) at which :meth:`step` is called; required with a
        ``passivity_controller`` (its velocity estimate is dp / T).
    max_evaluations : int or None, optional
        D and E over a surface: the texture evaluations one tick's closest-point search may
        spend (default :data:`MAX_EVALUATIONS`, chosen: 5,000, about 0.3 ms on this project's
        machine). Past it the search ends with the best point found, not certified global,
        and the tick is counted in :attr:`cut`; a tick's work is then at most the budget plus
        250. ``None``: only the search's structural bound (2,048 cells; about 10^5
        evaluations measured 1 km under the paper's egg-crate).

    Raises
    ------
    ParameterError
        If ``algorithm`` is not a haptex algorithm, ``max_force`` is not > 0, a controller
        is given without a period, or ``max_evaluations`` is not None or in [100, 10^9].

    Notes
    -----
    ``step`` never raises and never returns a non-finite force: a position that is not
    finite numbers within +-1 km returns zero force and is counted in :attr:`faults`.
    One renderer per device; it keeps state between calls and is **not thread-safe** —
    call it from one thread (the servo thread) only.

    References
    ----------
    B. Hannaford and J.-H. Ryu, "Time-domain passivity control of haptic interfaces",
    IEEE Trans. Robotics and Automation 18(1), 2002, pp. 1–10.
    """

    def __init__(self, algorithm: Algorithm, max_force: float | None = None, energy_monitor: bool = False,
                 passivity_controller: PassivityController | None = None, period: float | None = None,
                 max_evaluations: int | None = MAX_EVALUATIONS):
        if not isinstance(algorithm, Algorithm):
            raise fail("algorithm", algorithm, "a haptex algorithm (haptex.algorithm(...))")
        optional_positive("max_force", max_force, "N")
        if passivity_controller is not None and not isinstance(passivity_controller, PassivityController):
            raise fail("passivity_controller", passivity_controller, "None or a haptex.PassivityController")
        if passivity_controller is not None and period is None:
            raise fail("period", period, "the servo period in s (> 0) with a passivity_controller")
        T = None if period is None else positive("period", period, "s")
        if max_evaluations is not None and not (isinstance(max_evaluations, int | np.integer)
                                                and not isinstance(max_evaluations, bool)
                                                and 100 <= max_evaluations <= 10**9):
            raise fail("max_evaluations", max_evaluations, "None or a whole number of texture evaluations in "
                       "[100, 10^9]")
        self.max_evaluations = max_evaluations
        self.algorithm = algorithm
        self.passivity_controller = passivity_controller
        self.dimension = algorithm.dimension
        code, prm, kind, coeffs, aux = algorithm.kernel_spec()
        self._core = None
        if _core.tick_in_core(algorithm):  # the C core's tick: every letter
            # (the numba tick below is kept only as the C tick's oracle in tests/test_core.py,
            # which selects it by emptying core.TICKS_IN_CORE; it goes with haptex._kernels)
            pc = passivity_controller
            tabled = _tick_search_data(algorithm, aux)
            self._search_table = tabled is not aux and tabled[_kernels.A_TABLE] != 0.0
            if code in (_kernels.ALG_D, _kernels.ALG_E) and kind in (_kernels.SURFACE_GRATINGS, _kernels.SURFACE_PATCHES):
                tabled = tabled.copy()  # (the texture's own constants stay unbudgeted: the analysis certifies)
                tabled[_kernels.G_BUDGET] = 0.0 if max_evaluations is None else float(max_evaluations)
            self._core = _core._ext.Renderer(
                code, prm, kind, coeffs, np.require(tabled, np.float64, ["C"]), self.dimension,
                math.inf if max_force is None else float(max_force), WORKSPACE_LIMIT, bool(energy_monitor),
                pc is not None, 0.0 if pc is None else pc.max_damping, pc is not None and pc.reference == "stored",
                0.0 if T is None else T, self._step_checked)
            self.step = self._core.step
            return
        tabled = _tick_search_data(algorithm, aux)
        self._search_table = tabled is not aux and tabled[_kernels.A_TABLE] != 0.0
        aux = tabled
        K = _kernels
        # one array for the kernel (one argument to unbox a call); views of it for Python
        self._mem = np.zeros(K.R_DATA + coeffs.size + aux.size)
        self._mem[[K.H_CODE, K.H_KIND, K.H_ROWS, K.H_COLS, K.H_NAUX]] = (code, kind, *coeffs.shape, aux.size)
        self._mem[K.R_DATA:K.R_DATA + coeffs.size] = coeffs.ravel()
        self._mem[K.R_DATA + coeffs.size:] = aux
        self._prm = self._mem[K.R_PRM:K.R_RS]
        self._rs = self._mem[K.R_RS:K.R_PC]
        self._pc = self._mem[K.R_PC:K.R_BUF]
        self._st = self._mem[K.R_ST:K.R_DATA]
        self._prm[:] = prm
        self._rs[RS_MAXF] = math.inf if max_force is None else float(max_force)
        self._rs[RS_MONITOR] = 1.0 if (energy_monitor or passivity_controller is not None) else 0.0
        self._rs[RS_LIMIT] = WORKSPACE_LIMIT
        self._rs[RS_DIM] = self.dimension
        if passivity_controller is not None:
            self._pc[PC_ON] = 1.0
            self._pc[PC_BMAX] = passivity_controller.max_damping
            self._pc[PC_REF] = PC_REF_STORED if passivity_controller.reference == "stored" else PC_REF_ZERO
            self._pc[PC_T] = T
        # compile (or load from the cache) now, not in the servo loop
        self._tick(0.0, 0.0, 1.0)
        self.reset()
        self.step = _fast_step(self)

    def _tick(self, x, y, z):
        """(fx, fy, fz) (N) at floats (x, y, z) (m), fy = 0 over a profile."""
        if self._core is not None:
            return self._core.tick(x, y, z)
        return _render_step(x, y, z, self._mem)

    def step(self, p):
        """Force to command for one probe position.

        Parameters
        ----------
        p : sequence of two or three real numbers
            Probe position (m): [x, z] over a profile, [x, y, z] over a surface; a tuple,
            list or NumPy array of exactly :attr:`dimension` real (not boolean, not
            complex) numbers.

        Returns
        -------
        tuple of floats
            Force [f_x, f_z] or [f_x, f_y, f_z] (N); zeros for a faulty position: anything
            else than finite real numbers within +-1 km (strings, bytes, dicts, complex
            numbers, booleans, the wrong number of coordinates, ...), counted in
            :attr:`faults`.

        Notes
        -----
        Never raises, never returns NaN or a force above ``max_force``, and does a bounded
        amount of work for any input (:attr:`last_work`).
        """
        return self._step_checked(p)  # an instance's own ``step`` (_fast_step) comes first

    def _step_checked(self, p):
        try:
            tp = type(p)
            if tp is not tuple and tp is not list:  # a tuple or a list: unpacking checks the length
                if isinstance(p, (str, bytes, bytearray, dict)) or len(p) != self.dimension:
                    raise TypeError
            if self.dimension == 2:
                x, z = p
                if type(x) is not float or type(z) is not float:  # plain floats need no further check
                    if (not (isinstance(x, _REAL) and isinstance(z, _REAL)) or isinstance(x, bool)
                            or isinstance(z, bool)):
                        raise TypeError
                    x, z = float(x), float(z)
                fx, _, fz = self._tick(x, 0.0, z)
                return fx, fz
            x, y, z = p
            if type(x) is not float or type(y) is not float or type(z) is not float:
                if not all(isinstance(c, _REAL) and not isinstance(c, bool) for c in (x, y, z)):
                    raise TypeError
                x, y, z = float(x), float(y), float(z)
            return self._tick(x, y, z)
        except Exception:  # a malformed p: never let it reach the motor loop
            if self._core is not None:
                self._core.fault()
                return (0.0,) * self.dimension
            self._rs[RS_FAULTS] += 1.0
            self._pc[PC_HAVE] = 0.0
            self._rs[RS_WORK] = 0.0
            return (0.0,) * self.dimension

    @property
    def search_table(self) -> bool:
        """True when D's or E's closest point is found from a cell table
        (:func:`haptex.closest.table_search_data`: periodic profiles and profiles extruded
        from them), False when every tick searches the bound tree."""
        return self._search_table

    @property
    def last_work(self) -> int:
        """Work of the last :meth:`step`, bounded for any input: texture evaluations, plus
        F's presliding table steps (at most 11 + 60) in its smooth variant."""
        return self._core.last_work if self._core is not None else int(self._rs[RS_WORK])

    @property
    def cut(self) -> int:
        """Ticks since construction or :meth:`reset` whose closest-point search (D, E over a
        surface) its ``max_evaluations`` budget ended: their force used the best point found,
        not the certified closest point."""
        return self._core.cut if self._core is not None else 0

    @property
    def max_work(self) -> int:
        """Largest :attr:`last_work` since construction or :meth:`reset`."""
        return self._core.max_work if self._core is not None else int(self._rs[RS_MAXWORK])

    def reset(self) -> None:
        """Clear the algorithm's state (friction, warm start), the observer, the controller and
        the counters."""
        if self._core is not None:
            self._core.reset()
            return
        self._st[:] = 0.0
        for k in (RS_FAULTS, RS_CLAMPS, RS_WORK, RS_MAXWORK):
            self._rs[k] = 0.0
        on, bmax, ref, T = (self._pc[k] for k in (PC_ON, PC_BMAX, PC_REF, PC_T))
        self._pc[:] = 0.0
        self._pc[PC_ON], self._pc[PC_BMAX], self._pc[PC_REF], self._pc[PC_T] = on, bmax, ref, T

    @property
    def faults(self) -> int:
        """Calls whose position was not finite numbers within +-1 km (zero force returned)."""
        return self._core.faults if self._core is not None else int(self._rs[RS_FAULTS])

    @property
    def clamps(self) -> int:
        """Calls whose force was scaled down to ``max_force``."""
        return self._core.clamps if self._core is not None else int(self._rs[RS_CLAMPS])

    @property
    def energy(self) -> float:
        """Passivity observer: energy absorbed by the virtual environment so far (J);
        negative means the rendering has supplied energy. 0 without ``energy_monitor``."""
        return self._core.energy if self._core is not None else float(self._pc[PC_E])

    @property
    def energy_per_axis(self) -> tuple[float, ...]:
        """(E_x, E_z) or (E_x, E_y, E_z) of the passivity observer (J), the paper's Section
        V-B sums."""
        if self._core is not None:
            return self._core.energy_per_axis
        return tuple(float(self._pc[PC_EAX + i]) for i in range(self.dimension))

    @property
    def controller_active(self) -> int:
        """Ticks on which the passivity controller added damping."""
        return self._core.controller_active if self._core is not None else int(self._pc[PC_ACTIVE])

    @property
    def controller_damping(self) -> float:
        """The damping alpha the controller added on the last tick (N s/m), 0 if none."""
        return self._core.controller_damping if self._core is not None else float(self._pc[PC_ALPHA])

    @property
    def adhesion(self):
        """F's adhesion point while in contact (m): x over a profile, (x, y) over a surface;
        else None."""
        if self.algorithm.letter != "F":
            return None
        if self._core is not None:
            adh = self._core.adhesion
            if adh is None:
                return None
            return adh if self.dimension == 3 else adh[0]
        if self._st[_kernels.S_CONTACT] == 0.0:
            return None
        if self.dimension == 3:
            return float(self._st[_kernels.S_ADH]), float(self._st[_kernels.S_ADHY])
        return float(self._st[_kernels.S_ADH])
