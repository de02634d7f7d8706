"""Sampled-data simulation of a haptic device in closed loop with a texture algorithm,
measuring energy the way the paper's experiments do (Section V).

Every sampling period T the controller reads the (quantised) handle position, computes
the algorithm's force, quantises and saturates it, and holds it (zero-order hold, after
``delay`` samples) while the handle moves. Between samples the handle, its damping and
the operator's springs and dampers form a linear system that is integrated exactly with
the matrix exponential of an augmented system; the energy dissipated by the damping and
the operator's work over each interval are exact quadratic forms of the state at the
sampling instant (Van Loan's integrals, computed once with scipy's expm, haptex.core.expm).

References
----------
C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE Trans.
Automatic Control 23(3), 1978, pp. 395–404.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from . import core as _core
from .core._ext import (DIVERGED_ENERGY, DIVERGED_FORCE, DIVERGED_POSITION, DIVERGED_VELOCITY, N_FAST, N_SUMMARY,
                        P_K0, S_DAMP, S_DIVERGED, S_DIVERGED_WHAT, S_EX, S_EY, S_EZ, S_FRIC, S_KE, S_KE0, S_MAXPEN, S_OP,
                        S_PC_ACTIVE, S_PC_ENERGY, S_SAT, S_TAILSTART_E, S_VIB_CLAMPED, S_VIB_CUT,
                        S_VIB_SUPPLIED)
from ._validation import ParameterError, fail, nonnegative, positions, positive, whole
from .algorithms import Algorithm, checked_algorithm
from .catalogue import checked_device
from .devices import SCALAR_FIELDS, Device, _matrix, definite, scalar_field
from .operators import Operator
from .renderer import Stabiliser

__all__ = ["SimulationResult", "Oscillation", "simulate", "simulate_batch", "MEMORY_BUDGET", "SimulationWarning",
           "BALANCE_TOLERANCE", "REGIMES", "UNSTABLE", "regime"]

BALANCE_TOLERANCE = 1e-6
"""Relative energy-balance error above which a result is flagged (exact runs close to ~1e-12)."""

_DIVERGED_NAMES = {DIVERGED_POSITION: "position", DIVERGED_VELOCITY: "velocity", DIVERGED_FORCE: "force",
                   DIVERGED_ENERGY: "energy"}


class SimulationWarning(RuntimeWarning):
    """A simulation diverged (a non-finite state) or its energy balance does not close."""

MEMORY_BUDGET = 2 * 1024**3
"""Largest time-series allocation (bytes) :func:`simulate` accepts: 2 GiB (96 bytes a
recorded sample in the plane, 128 in space). Longer runs must record every n-th sample
(``record_every``)."""
TAIL_SAMPLES = 65536
"""Most steps of a run's tail (the verdict's stretch, :func:`simulate`'s ``tail_fraction``): a
longer run is judged on its last TAIL_SAMPLES steps, every one of them, so that a motion up to
the servo's Nyquist frequency is seen as it is (6.55 s at 10 kHz, 65.5 s at 1 kHz: at least 3
cycles, MIN_CYCLES, of any motion above 0.46 and 0.046 Hz). Before, such a tail was sampled
every k-th step over k times this many (k the integer part of the ratio) and its spectrum read
as if it spanned the whole tail: a 20 s scan at the texture's 10 Hz read 8.25 Hz and "limit
cycle", a 2,500 s one at 1 kHz aliased 50 Hz to 16.4 Hz (tests/test_simulate.py)."""


def _tail_start(n_steps: int, tail_fraction: float) -> int:
    """The step a run's tail starts at: the last ``tail_fraction`` of its ``n_steps`` steps, at
    most its last TAIL_SAMPLES (the C loops then record each of its steps: the stride they take,
    the tail's steps over its buffer's length, is 1)."""
    return max(int(n_steps * (1 - tail_fraction)), n_steps - TAIL_SAMPLES)


TAIL_BLOCK = 16 * 1024**2
"""Bytes of tail positions a batch holds at once (its runs go in blocks that reuse the buffer):
the memory stays bounded for any number of runs, and pages are not faulted in afresh per run."""


# --------------------------------------------------------------------------------------
# exact discretisation
# --------------------------------------------------------------------------------------
def _augmented(M: np.ndarray, B: np.ndarray, K: np.ndarray, C: np.ndarray, mode=None) -> np.ndarray:
    """F of dz/dt = F z for z = [p, v, u, g, r] (n entries each, n = 2 or 3):
    M dv/dt = u + g - K p - (B + C) v, du/dt = 0, dg/dt = r, dr/dt = 0.

    With ``mode`` = (M_m, M_h, K_s, C_s), z = [p, v, u, g, r, p_h, v_h]: the command u, the
    damping B and the sensing act on the motor side (p, v), the operator on the handle
    side: M_m dv/dt = u - B v - K_s (p - p_h) - C_s (v - v_h) and
    M_h dv_h/dt = g - K p_h - C v_h + K_s (p - p_h) + C_s (v - v_h)."""
    n = M.shape[0]
    eye = np.eye(n)
    P, V, U, G, R, PH, VH = (slice(i * n, (i + 1) * n) for i in range(7))
    F = np.zeros((5 * n, 5 * n) if mode is None else (7 * n, 7 * n))
    F[P, V] = eye
    F[G, R] = eye
    if mode is None:
        Minv = np.linalg.inv(M)
        F[V, P] = -Minv @ K
        F[V, V] = -Minv @ (B + C)
        F[V, U] = Minv
        F[V, G] = Minv
        return F
    Mm, Mh, Ks, Cs = mode
    mi, hi = np.linalg.inv(Mm), np.linalg.inv(Mh)
    F[V, P] = -mi @ Ks
    F[V, V] = -mi @ (B + Cs)
    F[V, U] = mi
    F[V, PH] = mi @ Ks
    F[V, VH] = mi @ Cs
    F[PH, VH] = eye
    F[VH, PH] = -hi @ (K + Ks)
    F[VH, VH] = -hi @ (C + Cs)
    F[VH, G] = hi
    F[VH, P] = hi @ Ks
    F[VH, V] = hi @ Cs
    return F


def _van_loan(F: np.ndarray, Q: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """(Phi, W): Phi = e^{F T} and W = int_0^T e^{F' s} Q e^{F s} ds (Van Loan 1978)."""
    n = F.shape[0]
    big = np.zeros((2 * n, 2 * n))
    big[:n, :n] = -F.T
    big[:n, n:] = Q
    big[n:, n:] = F
    E = _core.expm(big * T)
    Phi = E[n:, n:]
    W = Phi.T @ E[:n, n:]
    return Phi, 0.5 * (W + W.T)


def _discretise(device: Device, op: Operator) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per damping regime (0 outside, 1 inside): Phi (2, n_z, n_z), W_damping, W_operator,
    with n_z = 5 n, or 7 n for a device with a structural mode (see :func:`_augmented`), and
    the inverse of Phi's block from a held force to the end velocity (2, n, n), which the
    sampled Coulomb friction reads."""
    T = device.period
    n = device.dimension
    K, C = op.stiffness, op.damping
    mode = device.mode_matrices() if device.structural_mode else None
    nz = 5 * n if mode is None else 7 * n
    V, U = slice(n, 2 * n), slice(2 * n, 3 * n)
    p_op, v_op = (slice(0, n), V) if mode is None else (slice(5 * n, 6 * n), slice(6 * n, 7 * n))
    G = slice(3 * n, 4 * n)
    Qop = np.zeros((nz, nz))  # the operator's power v' (g - K p - C v) on the body it holds
    Qop[v_op, p_op] = -0.5 * K
    Qop[p_op, v_op] = -0.5 * K.T
    Qop[v_op, v_op] = -0.5 * (C + C.T)
    Qop[v_op, G] = 0.5 * np.eye(n)
    Qop[G, v_op] = 0.5 * np.eye(n)
    Phi, Wd, Wo = (np.empty((2, nz, nz)) for _ in range(3))
    Binv = np.empty((2, n, n))
    for reg, B in enumerate((device.damping_outside, device.damping)):
        if reg == 1 and np.array_equal(B, device.damping_outside):  # one regime (most devices): made once
            Phi[1], Wd[1], Wo[1], Binv[1] = Phi[0], Wd[0], Wo[0], Binv[0]
            break
        F = _augmented(device.mass, B, K, C, mode)
        Qd = np.zeros((nz, nz))  # dissipation: v' B v, and the mode's damper on v - v_h
        Qd[V, V] = B
        if mode is not None:
            Cs, VH = mode[3], slice(6 * n, 7 * n)
            Qd[V, V] += Cs
            Qd[VH, VH] = Cs
            Qd[V, VH] = -Cs
            Qd[VH, V] = -Cs
        Phi[reg], Wd[reg] = _van_loan(F, Qd, T)
        _, Wo[reg] = _van_loan(F, Qop, T)
        Binv[reg] = np.linalg.inv(Phi[reg][V, U])
    return Phi, Wd, Wo, Binv


def _diagonal(A: np.ndarray) -> bool:
    """Diagonal to round-off: off-diagonal entries at most 1e-13 of the largest entry (the
    Cartesian matrices of a symmetric linkage at its centre carry ~1e-17 of noise there)."""
    return bool(np.all(np.abs(A - np.diag(np.diag(A))) <= 1e-13 * np.abs(A).max()))


_SERIES_BELOW = 0.5
"""x below which the fast path's g-functions are summed from their Taylor series."""
_SERIES = np.array([[1.0 / math.factorial(k + 1), 1.0 / math.factorial(k + 2),
                     (2.0 ** (k + 2) - 2.0) / math.factorial(k + 3), 1.0 / math.factorial(k + 1)] for k in range(20)])
"""Their series' coefficients, row k that of (-x)^k in g1(x), g2(x), g3(x) and of (-2x)^k in
g1(2x); 20 terms: the first left out is below 2^20 / 21! < 3e-14 of the sum's first term."""


def _g_functions(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(g1(x), g2(x), g3(x), g1(2x)) for x = b T / m >= 0, elementwise:
    g1 = (1 - e^-x) / x, g2 = (x - 1 + e^-x) / x^2, g3 = (1 - 2 g1(x) + g1(2x)) / x^2, each
    continuous at 0 (1, 1/2, 1/3); below x = 0.5 by their Taylor series (Horner's rule,
    elementwise, so a value does not depend on the array it sits in), where the closed forms
    cancel (g3 loses half its digits at x = 1e-4); above, by expm1."""
    x = np.asarray(x, dtype=np.float64)
    small = x < _SERIES_BELOW
    xs = np.where(small, x, 0.0)[..., None]
    step = np.concatenate([np.broadcast_to(-xs, xs.shape[:-1] + (3,)), -2.0 * xs], axis=-1)
    series = np.zeros(step.shape)
    for row in _SERIES[::-1]:
        series = series * step + row
    xl = np.where(small, 1.0, x)
    g1 = -np.expm1(-xl) / xl
    g12 = -np.expm1(-2.0 * xl) / (2.0 * xl)
    closed = (g1, (xl + np.expm1(-xl)) / (xl * xl), (1.0 - 2.0 * g1 + g12) / (xl * xl), g12)
    return tuple(np.where(small, series[..., j], closed[j]) for j in range(4))


def _axis_coefficients(m, b, T) -> np.ndarray:
    """The exact zero-order hold of the 1-DOF mass-damper m dv/dt = w - b v over a period T
    under a held force w, elementwise over arrays ``m`` (kg, > 0), ``b`` (N s/m, >= 0) and ``T``
    (s, > 0; a float, or an array: each step's own period): shape broadcast(m, b, T) + (N_FAST,),
    in the C core's order (HX_F_*)

    p+ = p + PV v + PW w,  v+ = VV v + VW w,  int_0^T b v^2 dt = CVV v^2 + CVW v w + CWW w^2,

    in closed form with x = b T / m: VV = e^-x, PV = T g1(x), VW = T g1(x) / m,
    PW = T^2 g2(x) / m, CVV = b T g1(2x), CVW = T x g1(x)^2, CWW = T^2 x g3(x) / m
    (:func:`_g_functions`; at b = 0 the undamped mass: PW = T^2 / 2m, no dissipation). They
    are the Van Loan integrals of the general path on one axis (tests compare the two)."""
    m, b, T = np.broadcast_arrays(np.asarray(m, dtype=np.float64), np.asarray(b, dtype=np.float64),
                                  np.asarray(T, dtype=np.float64))
    x = b * T / m
    g1, g2, g3, g12 = _g_functions(x)
    ext = _core._ext
    out = np.empty(m.shape + (N_FAST,))
    out[..., ext.F_PV] = T * g1
    out[..., ext.F_PW] = T * T * g2 / m
    out[..., ext.F_VV] = np.exp(-x)
    out[..., ext.F_VW] = T * g1 / m
    out[..., ext.F_CVV] = b * T * g12
    out[..., ext.F_CVW] = T * x * g1 * g1
    out[..., ext.F_CWW] = T * T * x * g3 / m
    return out


def _fast_path(device: Device, op: Operator) -> bool:
    """Whether a run takes the decoupled fast path: a rigid device with diagonal mass and
    damping matrices pushed by a constant force."""
    return not (device.structural_mode or not op.constant_push or op.rest_length > 0
                or not all(_diagonal(A) for A in (device.mass, device.damping, device.damping_outside)))


def _fast_coefficients(device: Device, op: Operator) -> np.ndarray:
    """The decoupled fast path's per-axis closed forms, shape (2, n, N_FAST) (see
    the C core's ``hx_run_general``), for a rigid device with diagonal mass and damping
    matrices pushed by a constant force; shape (0, n, N_FAST) otherwise (the general path).

    Each axis is the 1-DOF mass-damper m dv/dt = w - b v under a held force w
    (:func:`_axis_coefficients`), regime 0 with the damping outside the wall, 1 inside."""
    n = device.dimension
    if not _fast_path(device, op):
        return np.zeros((0, n, N_FAST))
    m = np.diag(device.mass)
    return _axis_coefficients(m, np.stack([np.diag(device.damping_outside), np.diag(device.damping)]), device.period)


def _fast_binv(fast: np.ndarray) -> np.ndarray:
    """The inverse of the held force's map to the end velocity, which the general loop's Coulomb
    friction reads, on the fast path: diagonal, 1 / VW an axis; ``fast`` (..., d, N_FAST) gives
    (..., d, d)."""
    return (1.0 / fast[..., _core._ext.F_VW])[..., None] * np.eye(fast.shape[-2])


def _lean(fast: np.ndarray, kinematic: bool, pc_on: bool, delay, delta, fres, fmax, fc) -> tuple:
    """``(1,)`` when every run can take the C core's lean loop (``hx_run_lean``): the decoupled fast
    path (``fast`` has rows) with none of the machinery that loop leaves out (a kinematic
    operator, the passivity controller, delay, position quantisation, force resolution,
    saturation, Coulomb friction); ``()`` otherwise (the general loop, ``hx_run_general``)."""
    off = (fast.shape[-3] > 0 and not kinematic and not pc_on and np.all(np.asarray(delay) == 0)
           and np.all(np.asarray(delta) == 0.0) and np.all(np.asarray(fres) == 0.0)
           and np.all(np.asarray(fmax) == math.inf) and np.all(np.asarray(fc) == 0.0))
    return (1,) if off else ()


def _core_lean(code, kind, nominal, n_steps, T, record_every, tail_start, prm, coeffs, aux, fast, M, f0, P0, V0,
               rec, summary, tail, threads: int = 1, after=None) -> None:
    """Runs of the lean loop in the C core (:func:`haptex.core._ext.run_lean`): every per-run
    array has a leading run axis; the runs are cut into contiguous slices run on ``threads``
    threads (:func:`haptex.core.in_slices`), the GIL released. ``after(lo, hi)``, if given, is
    called in the same thread once a slice's runs are done (the slice's verdicts)."""
    per_run = [np.ascontiguousarray(a, dtype=np.float64) for a in (prm, coeffs, aux, fast, M, f0, P0, V0)]
    outs = (rec, summary, tail)  # written in place: already contiguous float64 (made here)
    N = per_run[0].shape[0]

    def one(lo, hi):
        _core._ext.run_lean(code, kind, nominal, n_steps, T, record_every, tail_start,
                            *(a[lo:hi] for a in per_run), *(a[lo:hi] for a in outs))
        if after is not None:
            after(lo, hi)

    # two slices a thread: the lean loop's runs cost the same (the same samples, the same
    # arithmetic), and each slice's verdicts cost some Python of their own
    _core.in_slices(one, N, threads, least=1, per_thread=2)


def _core_general(code, kind, nominal, kinematic, pc_on, pc_ref, n_steps, T, record_every, tail_start, sp_t, prm,
                  coeffs, aux, Phi, Wd, Wo, Bs, Binv, fast, M, modal, K, C, f0, sp_p, vend, rest, delay, delta, fres,
                  fmax, fc, pcb, P0, V0, rec, summary, tail, threads: int = 1, base=None, after=None,
                  vibration=None) -> None:
    """Runs of the general loop in the C core (:func:`haptex.core._ext.run_general`): every
    per-run array has a leading run axis (``sp_t`` is shared); the runs are cut into
    contiguous slices run on ``threads`` threads (:func:`haptex.core.in_slices`), the GIL
    released. ``base``: an object's base (``haptex.core._ext.Base``) shared by the runs, or None.
    ``after(lo, hi)``, if given, is called in the same thread once a slice's runs are done.
    ``vibration``: :func:`haptex.renderer.vibration_settings`'s tuple, or None; each run's channel
    starts from its seed."""
    f64 = lambda a: np.ascontiguousarray(a, dtype=np.float64)  # noqa: E731
    per_run = [f64(a) for a in (prm, coeffs, aux, Phi, Wd, Wo, Bs, Binv, fast, M, modal, K, C, f0, sp_p, vend, rest)]
    per_run.append(np.ascontiguousarray(delay, dtype=np.int64))
    per_run += [f64(a) for a in (delta, fres, fmax, fc, pcb, P0, V0)]
    outs = (rec, summary, tail)
    N = per_run[0].shape[0]

    def one(lo, hi):
        _core._ext.run_general(code, kind, bool(nominal), bool(kinematic), bool(pc_on), int(pc_ref),
                               int(n_steps), float(T), int(record_every), int(tail_start), f64(sp_t),
                               *(a[lo:hi] for a in per_run), *(a[lo:hi] for a in outs), base, vibration)
        if after is not None:
            after(lo, hi)

    _core.in_slices(one, N, threads, least=1)


def _mass_inputs(device: Device) -> tuple[np.ndarray, np.ndarray]:
    """(M, modal) for the compiled loop: the whole mass and no modal data for a rigid
    device; the motor side and [M_h, K_s] with a structural mode."""
    n = device.dimension
    if not device.structural_mode:
        return device.mass, np.zeros((0, n, n))
    Mm, Mh, Ks, _ = device.mode_matrices()
    return Mm, np.stack([Mh, Ks])


# --------------------------------------------------------------------------------------
# results
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class AxisOscillation:
    """The oscillation verdict on one axis of the tail of a run.

    Parameters
    ----------
    oscillating : bool
        True when the half peak-to-peak motion along this axis in the second half of the
        tail, after removing the tail's straight-line trend (steady sliding or drift), is
        above the threshold and at least 1 - :data:`REGIME_TOLERANCE` times that of the
        first half (sustained or growing), over at least :data:`MIN_CYCLES` cycles, and not
        the texture traversed: exactly when the axis's regime (:func:`regime`) is a limit
        cycle or growth, so the two never disagree.
    amplitude : float
        Half the detrended peak-to-peak motion in the second half of the tail (m).
    decay_ratio : float
        Amplitude of the second half over that of the first half.
    frequency : float
        Dominant frequency (Hz), from a Hann-windowed periodogram of the detrended motion;
        0 when the amplitude is below the threshold (motion at rest has no frequency).
    texture_driven : bool
        True when a sustained motion is the texture traversed during a scan (its frequency
        within 1.5 periodogram bins of n v / l, n = 1..3, for a texture period l): not an
        oscillation of the device, so ``oscillating`` is False.
    """

    oscillating: bool
    amplitude: float
    decay_ratio: float
    frequency: float
    texture_driven: bool = False


@dataclass(frozen=True)
class Oscillation:
    """Verdict on the last part of a run, on both axes: sustained limit cycle or decaying
    transient.

    Parameters
    ----------
    oscillating : bool
        True when any axis oscillates (:class:`AxisOscillation`): a lateral limit cycle
        counts as much as one along the normal.
    axis : str
        ``"x"``, ``"y"`` (3-D) or ``"z"``: the axis reported in ``amplitude``,
        ``decay_ratio`` and ``frequency`` — the oscillating one with the larger amplitude,
        else the larger.
    amplitude, decay_ratio, frequency : float
        That axis's figures (m, 1, Hz).
    energy_per_cycle : float
        Net energy the environment supplied per cycle of that axis's frequency in the tail
        (J): minus the change of the summed per-axis energies divided by the number of
        cycles; > 0 feeds it.
    threshold : float
        Amplitude below which motion counts as rest (m): the larger of the encoder's
        position resolution and 1e-7 m.
    x, z : AxisOscillation
        The verdict on each axis.
    y : AxisOscillation or None
        The verdict along y in 3-D; None in the plane.
    cycles : float
        Cycles of that axis's frequency in the tail (0 at rest).
    """

    oscillating: bool
    amplitude: float
    decay_ratio: float
    frequency: float
    energy_per_cycle: float
    threshold: float
    axis: str = "z"
    x: AxisOscillation | None = None
    z: AxisOscillation | None = None
    y: AxisOscillation | None = None
    cycles: float = 0.0


REGIMES = ("decaying", "settling", "driven", "limit cycle", "growing", "diverged")
"""The regime of a run, from its tail (:func:`regime`), in the order of their codes 0-5."""
MIN_CYCLES = 3
"""Cycles a sustained motion must show in the tail to be an oscillation (as ``oscillating``)."""
UNSTABLE = frozenset(("limit cycle", "growing", "diverged"))
"""The regimes of an unstable loop: the motion does not die out by itself."""
REGIME_TOLERANCE = 2e-3
"""|decay ratio - 1| within which a sustained motion is a limit cycle (chosen). An unstable wall
bounces off its one-sided contact into a bounded cycle whose decay ratio sits near 1, while the
stable runs decay (measured over the shipped wall atlas, examples/sweeps/wall.toml, its 2 s
tails read at every step, 2026-12-02: its 114 limit cycles 0.9991-1.0020, the growing runs from
1.0020, the 760 stable runs' largest 0.9947; 0.9957 when its tails were read every other step,
the same 760 stable)."""


def regime(decay_ratio, amplitude, threshold, cycles, driven, diverged, slack=0.0):
    """The regime of runs from their tail verdicts, elementwise.

    Parameters
    ----------
    decay_ratio, amplitude, threshold, cycles : array_like, shape (N,)
        The main axis's decay ratio (1), its amplitude in the tail's second half and the rest
        threshold (m), the cycles of its frequency in the tail (:class:`Oscillation`).
    driven : array_like of bool, shape (N,)
        The main axis's sustained motion is the texture traversed during a scan.
    diverged : array_like of bool, shape (N,)
        The run became non-finite.
    slack : float or array_like, optional
        m, >= 0: how much the two halves' amplitudes may differ beyond the tolerance and still
        count as sustained (and must differ by more to count as growth): half a sensor step for
        sensed positions, whose amplitudes are multiples of it (default 0, exact positions).

    Returns
    -------
    ndarray of str, shape (N,)
        ``"diverged"``; else ``"decaying"`` at rest (amplitude at most the threshold) or with a
        decay ratio below 1 - :data:`REGIME_TOLERANCE`; ``"settling"`` for motion of fewer than
        :data:`MIN_CYCLES` cycles in the tail (a transient still under way: no oscillation to
        judge, a longer run will tell); ``"driven"`` for sustained motion at the texture's rate
        (the scan's response, even while it still grows: a loop's instability has a frequency
        of its own);
        ``"growing"`` above 1 + the tolerance; else ``"limit cycle"``. :data:`UNSTABLE` names
        the unstable ones.
    """
    ratio = np.asarray(decay_ratio, dtype=np.float64)
    a2 = np.asarray(amplitude, dtype=np.float64)
    moving = a2 > np.asarray(threshold, dtype=np.float64)
    sustained, growing = _sustained(a2, ratio, slack)
    out = np.full(ratio.shape, "limit cycle", dtype=object)
    out[growing] = "growing"
    out[moving & (np.asarray(cycles, dtype=np.float64) < MIN_CYCLES)] = "settling"
    out[~moving | ~sustained] = "decaying"
    # at the texture's own rate: the scan's response, settling or not (a loop's instability has its own frequency)
    out[moving & np.asarray(driven, dtype=bool)] = "driven"
    out[np.asarray(diverged, dtype=bool)] = "diverged"
    return out.astype(str)


def _sustained(a2, ratio, slack=0.0):
    """(sustained, growing) of motions whose tail's second half has amplitude ``a2`` and ratio
    ``ratio`` to the first: within :data:`REGIME_TOLERANCE` (and ``slack`` m) of the first, or
    above it by more."""
    slack = np.asarray(slack, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        a1 = np.where(ratio > 0, a2 / np.where(ratio > 0, ratio, 1.0), 0.0)
    a1 = np.where(np.isfinite(ratio), a1, 0.0)
    sustained = (ratio >= 1.0 - REGIME_TOLERANCE) | (a2 + slack >= a1 * (1.0 - REGIME_TOLERANCE))
    growing = (ratio > 1.0 + REGIME_TOLERANCE) & (a2 - slack > a1 * (1.0 + REGIME_TOLERANCE))
    return sustained, growing


def _axis_verdicts(u: np.ndarray, tail_duration: float, threshold: np.ndarray, texture_freqs: np.ndarray,
                   threads: int | None = None, slack=0.0):
    """The verdict of :class:`AxisOscillation` on N runs at once.

    ``u`` (N, m) is one axis's tail, sampled evenly over ``tail_duration`` (s), detrended in
    place (a view of the simulator's own tail: nothing is copied); ``threshold``
    (N,) in m; ``texture_freqs`` (N, k) the texture rates of each run (Hz, NaN-padded).
    Returns arrays (N,): oscillating, amplitude, decay ratio, frequency, texture driven.
    The detrending and the half amplitudes are the C core's ``hx_tail_amplitudes`` (on
    ``threads`` threads, default all); the spectrum is taken only for the runs that move."""
    N, n = u.shape
    a1 = np.empty(N)
    a2 = np.empty(N)
    _core.in_slices(lambda lo, hi: _core._ext.tail_amplitudes(u[lo:hi], a1[lo:hi], a2[lo:hi]), N, threads,
                    least=max(1, (1 << 16) // max(n, 1)))  # (on the batch's threads: the GIL released)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.where(a1 > 0, a2 / np.where(a1 > 0, a1, 1.0), np.where(a2 > 0, np.inf, 0.0))
    moving = np.flatnonzero(a2 > threshold)
    freq = np.zeros(N)
    if moving.size:
        import scipy.fft

        window = np.hanning(n)
        step = max(1, (1 << 16) // n)  # blocks of 512 KiB: their temporaries are reused, not faulted in afresh
        for lo in range(0, moving.size, step):
            rows = moving[lo:lo + step]
            spec = np.abs(scipy.fft.rfft(u[rows] * window, axis=1))  # the peak of |X| is the periodogram's
            spec[:, 0] = 0.0
            peak = np.argmax(spec, axis=1)
            freq[rows] = np.where(spec[np.arange(rows.size), peak] > 0, peak / tail_duration, 0.0)
    # the regime's own thresholds (regime()): sustained within its tolerance, MIN_CYCLES cycles
    osc = (a2 > threshold) & _sustained(a2, ratio, slack)[0] & (freq * tail_duration >= MIN_CYCLES)
    driven = np.zeros_like(osc)
    if texture_freqs.shape[1]:
        harmonics = texture_freqs[:, :, None] * np.arange(1, 4)
        with np.errstate(invalid="ignore"):
            near = np.abs(freq[:, None, None] - harmonics) <= 1.5 / tail_duration
        driven = osc & np.any(near, axis=(1, 2))
    return osc & ~driven, a2, ratio, freq, driven


def _oscillation_table(tail: np.ndarray, tail_duration: float, e_env_tail: np.ndarray, threshold: np.ndarray,
                       texture_freqs: np.ndarray, threads: int | None = None, slack=0.0) -> dict:
    """Verdicts of N runs, as arrays: from their tail positions ``tail`` (N, d, m) [x, (y,) z]
    sampled evenly over ``tail_duration`` (s); ``e_env_tail`` (N,) the change of the summed
    environment energies over the tail (J); ``threshold`` (N,) m; ``texture_freqs`` (N, k)
    the rates (Hz, NaN-padded) at which a scan crosses the texture's periods; ``threads``
    for the C core's part (default all).

    Returns a dict: ``axes`` (the axis names), per axis name a tuple of (N,) arrays
    (oscillating, amplitude, decay ratio, frequency, texture driven); and (N,) arrays
    ``axis`` (the index into ``axes`` of the main axis: the oscillating one of largest
    amplitude, z first among equals, then y, then x), ``oscillating`` (any axis),
    ``cycles``, ``energy_per_cycle``, ``threshold``. :func:`_oscillations` makes the objects."""
    N, d, m = tail.shape
    names = "xz" if d == 2 else "xyz"
    threshold = np.asarray(threshold, dtype=np.float64)
    if m < 8 or tail_duration <= 0:
        z, f = np.zeros(N), np.zeros(N, dtype=bool)
        cols = {name: (f, z, z, z, f) for name in names}
    else:
        cols = {name: _axis_verdicts(tail[:, i, :], tail_duration, threshold, texture_freqs, threads, slack)
                for i, name in enumerate(names)}
    order = names[::-1]  # z first among equals, then y, then x (as max over this order)
    best = np.full(N, len(names) - 1)
    b_osc, b_amp = cols[order[0]][0].copy(), cols[order[0]][1].copy()
    for name in order[1:]:
        osc, amp = cols[name][0], cols[name][1]
        better = (osc & ~b_osc) | ((osc == b_osc) & (amp > b_amp))
        best[better] = names.index(name)
        b_osc, b_amp = np.where(better, osc, b_osc), np.where(better, amp, b_amp)
    pick = lambda j: np.choose(best, [cols[name][j] for name in names])  # noqa: E731
    cycles = pick(3) * tail_duration if m >= 8 and tail_duration > 0 else np.zeros(N)
    with np.errstate(divide="ignore", invalid="ignore"):
        per_cycle = np.where(cycles > 0, -np.asarray(e_env_tail, dtype=np.float64) / np.where(cycles > 0, cycles, 1.0),
                             0.0)
    return {"axes": names, **cols, "axis": best, "oscillating": np.any([cols[n][0] for n in names], axis=0),
            "amplitude": pick(1), "decay_ratio": pick(2), "frequency": pick(3), "driven": pick(4),
            "cycles": cycles, "energy_per_cycle": per_cycle, "threshold": threshold}


def _oscillations(tail: np.ndarray, tail_duration: float, e_env_tail: np.ndarray, threshold: np.ndarray,
                  texture_freqs: np.ndarray, slack=0.0) -> list[Oscillation]:
    """The :class:`Oscillation` of each of N runs (see :func:`_oscillation_table`)."""
    return _oscillation_objects(_oscillation_table(tail, tail_duration, e_env_tail, threshold, texture_freqs,
                                                   slack=slack))


def _oscillation_objects(t: dict, rows=None) -> list[Oscillation]:
    """The :class:`Oscillation` objects of a table's runs (all, or ``rows``)."""
    names = t["axes"]
    out = []
    for r in range(t["axis"].size) if rows is None else rows:
        ax = {name: AxisOscillation(bool(t[name][0][r]), float(t[name][1][r]), float(t[name][2][r]),
                                    float(t[name][3][r]), bool(t[name][4][r])) for name in names}
        main = ax[names[int(t["axis"][r])]]
        out.append(Oscillation(bool(t["oscillating"][r]), main.amplitude, main.decay_ratio, main.frequency,
                               float(t["energy_per_cycle"][r]), float(t["threshold"][r]), names[int(t["axis"][r])],
                               ax["x"], ax["z"], ax.get("y"), float(t["cycles"][r])))
    return out


def _oscillation(tail: np.ndarray, tail_duration: float, e_env_tail: float, threshold: float,
                 texture_freqs=(), slack: float = 0.0) -> Oscillation:
    """The verdict of one run from its tail positions (m, d) (see :func:`_oscillations`)."""
    tail = np.array(np.asarray(tail, dtype=np.float64).T)  # detrended in place: a copy, (d, m)
    freqs = np.asarray(texture_freqs, dtype=np.float64).reshape(1, -1)
    return _oscillations(tail[None], tail_duration, np.array([e_env_tail]), np.array([threshold]), freqs, slack)[0]


def _balance_error(ke, ke0, w_cmd, w_op, e_damp, e_fr):
    """Relative closure of the energy balance (KE_end - KE_0) - (W_command + W_operator -
    E_damping - E_friction) over the largest of its terms; arrays or floats."""
    err = (ke - ke0) - (w_cmd + w_op - e_damp - e_fr)
    scale = np.maximum.reduce([np.abs(w_cmd), np.abs(w_op), np.abs(e_damp), np.abs(ke), np.abs(ke0), np.abs(e_fr),
                               np.full(np.shape(err), 1e-300)])
    with np.errstate(invalid="ignore"):
        return np.where(np.isfinite(err), np.abs(err) / scale, np.inf)


@dataclass(frozen=True)
class SimulationResult:
    """Time series and energy figures of one simulation.

    Arrays have one row per recorded sample (every ``record_every`` samples), at the end
    of each sampling interval.

    Parameters
    ----------
    time : ndarray, shape (n,)
        s.
    position, velocity : ndarray, shape (n, d)
        Handle position [x, z] (d = 2) or [x, y, z] (d = 3) (m) and velocity (m/s).
    force : ndarray, shape (n, d)
        Force command applied over the interval ending at ``time`` (N).
    energy_x, energy_z : ndarray, shape (n,)
        Energy absorbed by the virtual environment, E_x = -sum f_x dp^x and
        E_z = -sum f_z dp^z (J), the sums of Section V-B; decreasing means the
        environment supplies energy.
    energy_y : ndarray, shape (n,), or None
        E_y in 3-D (J); None in the plane.
    damping_energy : ndarray, shape (n,)
        Energy dissipated by the device's viscous damping (J), exact.
    operator_work : ndarray, shape (n,)
        Work done by the operator on the handle (J), exact.
    kinetic_energy : ndarray, shape (n,)
        1/2 v' M v (J).
    initial_kinetic_energy : float
        J.
    saturations : int
        Number of samples whose command exceeded ``max_force`` and was scaled down.
    max_penetration : float
        Largest penetration of the handle below the textured (or nominal) surface (m).
    oscillation : Oscillation
        Verdict on the last ``tail_fraction`` of the run, at most its last
        :data:`TAIL_SAMPLES` steps, each of them.
    totals : dict
        Final E_x, (E_y,) E_z, damping, operator work, kinetic energy and the energy
        dissipated by the device's Coulomb friction (``friction_energy``) (J).
    diverged_at : int or None
        The sample (1-based) at which a position, velocity, force or energy became
        non-finite; the run stopped there and its series end before it. None if it did not.
    diverged_quantity : str or None
        Which: ``"position"``, ``"velocity"``, ``"force"`` or ``"energy"``.
    passivity_control_samples : int
        Samples on which the passivity controller added damping (0 without one).
    observed_energy : float
        The energy the passivity observer counted as absorbed by the virtual environment
        over the run (J; 0 without a controller), from sensed positions and the forces it
        paired with them; the port's true energy is ``totals`` ``energy_x`` + ``energy_z``
        (+ ``energy_y``), from the exact motion under the forces that acted.
    texture_rates : tuple of float
        Rates (Hz) at which a constant-velocity scan crosses the texture's periods (empty
        otherwise): motion there is the texture, not buzz.
    vibration_supplied : float
        With a data-driven vibration: its work on the sensed motion (J, > 0: supplied at the
        port; the vibration force held over each period times the sensed displacement), the
        share of the port's energy that is the vibration's; 0 without one.
    vibration_cut : int
        Samples whose vibration force the energy budget scaled down (0 without a budget).
    vibration_clamped : int
        Samples whose operating point (speed, force) lay outside the model set's hull and was
        moved to it.
    tail_position : ndarray, shape (m, d), or None
        Where the recording holds one sample in several (``record_every`` > 1): the positions
        of the verdict's tail at every step (m; each axis less its least-squares line), what
        :attr:`buzz` reads; None where ``position`` holds every step.
    tail_period : float
        The time between ``tail_position``'s rows (s): the device's period; 0 without them.
    """

    time: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    force: np.ndarray
    energy_x: np.ndarray
    energy_z: np.ndarray
    damping_energy: np.ndarray
    operator_work: np.ndarray
    kinetic_energy: np.ndarray
    initial_kinetic_energy: float
    saturations: int
    max_penetration: float
    oscillation: Oscillation
    totals: dict = field(default_factory=dict)
    diverged_at: int | None = None
    diverged_quantity: str | None = None
    energy_y: np.ndarray | None = None
    passivity_control_samples: int = 0
    observed_energy: float = 0.0
    texture_rates: tuple = ()
    vibration_supplied: float = 0.0
    vibration_cut: int = 0
    vibration_clamped: int = 0
    tail_position: np.ndarray | None = None
    tail_period: float = 0.0

    @property
    def buzz(self):
        """Whether the handle's vibration is perceptible: its displacement spectrum over the
        second half of the run against the hand's vibrotactile detection threshold, the
        texture's own rates (:attr:`texture_rates`) excepted (:func:`haptex.perception.buzz`),
        up to the servo's Nyquist frequency. Where the recording holds one sample in several
        (``record_every`` > 1), over the run's tail at every step instead
        (:attr:`tail_position`): the recorded series folds what lies above its own Nyquist
        frequency into its band (a scan at the texture's 700 Hz recorded at 1 kHz read a
        perceptible buzz at 300 Hz). None when fewer than 32 samples are recorded (16 in the
        tail) or the run diverged."""
        from .perception import buzz

        if self.diverged:
            return None
        if self.tail_position is not None:
            if self.tail_position.shape[0] < 16:
                return None
            return buzz(self.tail_position, self.tail_period, exclude=self.texture_rates)
        n = self.time.size
        if n < 32:
            return None
        half = self.position[n // 2:]
        return buzz(half, float(self.time[1] - self.time[0]), exclude=self.texture_rates)

    @property
    def dimension(self) -> int:
        """2 (positions [x, z]) or 3 ([x, y, z])."""
        return int(self.position.shape[1])

    @property
    def regime(self) -> str:
        """The run's regime (:func:`regime`): "decaying", "settling", "driven", "limit cycle",
        "growing" or "diverged". With a data-driven vibration that acted, sustained motion is
        "driven": the vibration is a broadband source the tail cannot be told apart from (judge
        the loop's own stability without it)."""
        o = self.oscillation
        main = getattr(o, o.axis, None)
        return str(regime([o.decay_ratio], [o.amplitude], [o.threshold], [o.cycles],
                          [bool(main is not None and main.texture_driven) or self.vibration_supplied != 0.0],
                          [self.diverged_at is not None])[0])

    @property
    def energy_per_axis(self) -> np.ndarray:
        """[E_x, (E_y,) E_z] (J), shape (n, d)."""
        cols = [self.energy_x] + ([self.energy_y] if self.energy_y is not None else []) + [self.energy_z]
        return np.column_stack(cols)

    @property
    def diverged(self) -> bool:
        """True when the run stopped on a non-finite state (see :attr:`diverged_at`)."""
        return self.diverged_at is not None

    @property
    def energy_balance_ok(self) -> bool:
        """True when the run did not diverge and its balance closes to :data:`BALANCE_TOLERANCE`."""
        return not self.diverged and self.energy_balance_error <= BALANCE_TOLERANCE

    @property
    def oscillating(self) -> bool:
        """Shortcut for ``oscillation.oscillating``."""
        return self.oscillation.oscillating

    @property
    def energy_balance_error(self) -> float:
        """Relative closure of the energy balance at the end of the run.

        (KE_end - KE_0) - (W_command + W_operator - E_damping - E_friction), with
        W_command = -(E_x + (E_y +) E_z), divided by the largest of those terms in magnitude.
        Round-off only (about 1e-12) when the simulation is exact.
        """
        t = self.totals
        w_cmd = -(t["energy_x"] + t.get("energy_y", 0.0) + t["energy_z"])
        return float(_balance_error(t["kinetic_energy"], self.initial_kinetic_energy, w_cmd, t["operator_work"],
                                    t["damping_energy"], t.get("friction_energy", 0.0)))


# --------------------------------------------------------------------------------------
# public entry points
# --------------------------------------------------------------------------------------
def _prepare(algorithm, device, operator, duration, initial_position, initial_velocity):
    device = checked_device(device)  # (the algorithm is checked by the entry points, simulate and simulate_batch)
    if not isinstance(operator, Operator):
        raise fail("operator", operator, "an operator from haptex.operators")
    d = algorithm.dimension
    over = "a profile h(x), positions [x, z]" if d == 2 else "a surface h(x, y), positions [x, y, z]"
    if device.dimension != d:
        raise ParameterError(f"device = {device.name!r} with dimension = {device.dimension} is not allowed with "
                             f"{algorithm!r}: the texture is {over}, so the device needs dimension = {d} "
                             f"({d}x{d} mass and damping)")
    if operator.dimension != d:
        raise ParameterError(f"operator of dimension {operator.dimension} is not allowed with {algorithm!r}: the "
                             f"texture is {over}, so forces, anchors and paths need {d} coordinates")
    n_steps = _n_steps(duration, device.period)
    if n_steps < 1:
        raise fail("duration", duration, f"at least one sampling period ({device.period:g} s)")
    if operator.kinematic:
        p0 = operator.setpoint_points[0].copy() if initial_position is None else _point("initial_position",
                                                                                        initial_position, d)
    else:
        p0 = np.zeros(d) if initial_position is None else _point("initial_position", initial_position, d)
    v0 = np.zeros(d) if initial_velocity is None else _point("initial_velocity", initial_velocity, d)
    return n_steps, p0, v0


MAX_STEPS = 10**9
"""Most sampling periods one run may take: 2 to 3 minutes of the compiled simulator on one
core (benchmarks/README.md); longer runs are refused, not started."""


def _n_steps(duration, period: float) -> int:
    dur = positive("duration", duration, "s")
    n = dur / period
    if not n <= MAX_STEPS:
        raise fail("duration", duration, f"at most {MAX_STEPS:.0e} sampling periods of {period:g} s "
                   f"({MAX_STEPS * period:g} s); it asks for {n:.3g}")
    return int(round(n))


def _point(name, value, d: int):
    arr = positions(value, name, dim=d)
    if arr.shape != (d,):
        raise fail(name, value, "two finite numbers [x, z]" if d == 2 else "three finite numbers [x, y, z]")
    return arr.copy()


MAX_DAMPING_RATIO = 15.0
"""Largest (damping x sampling period / mass) the exact discretisation accepts: beyond it the
handle's velocity decays by more than e^-15 within one sample and the Van Loan energy
integrals cancel catastrophically (measured balance error: 2e-12 at 10, 2e-7 at 20, 1.0 at 40)."""


def _check_conditioning(device: Device, operator: Operator) -> None:
    """Refuse a device/operator pair whose exact discretisation is ill-conditioned."""
    minv = np.linalg.inv(device.mass)
    worst = 0.0
    same = np.array_equal(device.damping, device.damping_outside)
    for b in (device.damping,) if same else (device.damping, device.damping_outside):
        eig = np.linalg.eigvals(minv @ (b + operator.damping)) * device.period
        worst = max(worst, float(np.max(np.abs(eig))))
    _check_damping_ratio(worst)


def _check_damping_ratio(worst: float) -> None:
    """Refuse the largest |eigenvalue| of M^-1 (B + C) T above :data:`MAX_DAMPING_RATIO`."""
    if not worst <= MAX_DAMPING_RATIO:
        raise ParameterError(
            f"damping x period / mass = {worst:.3g} is not allowed: must be <= {MAX_DAMPING_RATIO:g} (the handle's "
            f"velocity would decay by e^-{worst:.3g} within one sample and the exact discretisation loses its "
            f"precision); use a larger mass, a smaller damping or a shorter sampling period")


def _discretisation_key(device: Device, operator: Operator) -> tuple:
    """What the discretisation of a run (:func:`_discretise`, :func:`_fast_coefficients`,
    :func:`_check_conditioning`) reads of its device and operator: runs with equal keys share it."""
    arrays = (device.mass, device.damping, device.damping_outside, operator.stiffness, operator.damping)
    mode = (device.handle_mass.tobytes() if device.handle_mass is not None else None, device.first_resonance,
            device.mode_damping_ratio)
    return (device.dimension, tuple(np.asarray(a, dtype=np.float64).tobytes() for a in arrays), device.period, mode,
            operator.constant_push, operator.rest_length)


def _kernel_inputs(algorithm, device, operator, memo: dict | None = None):
    """Everything the compiled loop reads for one run. ``memo`` shares the discretisation
    (the matrix exponentials) between runs whose devices and operators have the same dynamics
    (:func:`_discretisation_key`), as in sweeps of algorithm parameters or of an operator's
    set-point."""
    base = None
    if getattr(algorithm, "base", None) is not None:  # a textured object (haptex.objects): A, B, C, G on its base
        code, prm, kind, coeffs, aux, base = algorithm.object_spec()
    else:
        code, prm, kind, coeffs, aux = algorithm.kernel_spec()
    if device.structural_mode and operator.kinematic:
        raise ParameterError(f"operator = KinematicPath is not allowed with the structural mode of {device.name}: "
                             "a prescribed path fixes one body and leaves the mode undefined; use a hand or a band")
    T_alg = getattr(algorithm, "period", None)
    if T_alg is not None and not math.isclose(T_alg, device.period, rel_tol=1e-12):
        raise ParameterError(f"period = {T_alg:g} s of {algorithm!r} is not allowed on {device.name}: its virtual "
                             f"damper's backward difference must use the device's sampling period {device.period:g} s")
    same = (id(device), id(operator))  # the same objects (sweeps of the algorithm's keys): no key to make
    key = memo[same] if memo is not None and same in memo else _discretisation_key(device, operator)
    if memo is not None:
        memo[same] = key  # (the objects stay alive in the batch's runs: their ids are not reused)
    if memo is None or key not in memo:
        _check_conditioning(device, operator)
        fast = _fast_coefficients(device, operator)
        if fast.shape[0]:
            # the fast path: both loops read only its per-axis closed forms, and the general loop's
            # Coulomb friction the inverse of the held force's map to the end velocity, diagonal
            # (1 / VW); the augmented transition and its energy forms are not made (4 matrix
            # exponentials a distinct device)
            nz = 5 * device.dimension
            zeros = np.zeros((2, nz, nz))
            disc = (zeros, zeros, zeros, _fast_binv(fast), fast)
        else:
            disc = _discretise(device, operator) + (fast,)
        if memo is not None:
            memo[key] = disc
    else:
        disc = memo[key]
    Phi, Wd, Wo, Binv, fast = disc
    Bs = np.stack([device.damping_outside, device.damping])
    nominal = algorithm.penetration_kind == "nominal"
    return code, prm, kind, coeffs, aux, nominal, Phi, Wd, Wo, Bs, Binv, fast, base


def _controller(pc: Stabiliser | None) -> tuple[bool, float, int]:
    """(on, its damping N s/m, its mode) of the C loop."""
    if pc is None:
        return False, 0.0, 0
    if not isinstance(pc, Stabiliser):
        raise fail("passivity_controller", pc, "None or a haptex stabiliser (PassivityController, EnergyBounding, "
                   "PassiveSetPosition)")
    return True, pc.core_damping, pc.mode


def _observer_delay(pc: Stabiliser | None, delays) -> None:
    """Refuse a controller whose observer cannot pair the simulated device's delay: one stated
    otherwise, or longer than it remembers (the simulated observer knows the device's)."""
    if pc is None:
        return
    from .renderer import MAX_OBSERVER_DELAY

    delays = np.atleast_1d(np.asarray(delays, dtype=np.int64))
    if pc.delay is not None and np.any(delays != pc.delay):
        raise fail("passivity_controller.delay", pc.delay, f"None or the simulated device's delay "
                   f"({', '.join(str(d) for d in np.unique(delays)[:4])}): the simulated observer pairs forces "
                   "over the device's own delay")
    if delays.max() > MAX_OBSERVER_DELAY:
        raise fail("delay", int(delays.max()), f"at most {MAX_OBSERVER_DELAY} samples with a passivity controller "
                   "(the forces its observer remembers)")



def _vibration_inputs(device: Device, vibration, vibration_mass, vibration_gain, velocity_filter, seed,
                      vibration_budget, vibration_reserve):
    """The data-driven vibration's settings for the C loop (``renderer.vibration_settings``, the
    Renderer's own check); None without one. The models must run at the device's servo rate:
    the channel's tick is one sample of the set."""
    from .datadriven import require_servo_rate
    from .renderer import vibration_settings

    if getattr(vibration, "sample_rate", None) is not None:  # (anything else is vibration_settings' to refuse)
        require_servo_rate(vibration, device.period, "vibration", f"a model set at {vibration.sample_rate:g} Hz")
    return vibration_settings(vibration, vibration_mass, vibration_gain, velocity_filter, seed, vibration_budget,
                              vibration_reserve)


@_core.blas_held_to_one_thread
def simulate(algorithm: Algorithm, device: Device, operator: Operator, duration: float, initial_position=None,
             initial_velocity=None, record_every: int = 1, tail_fraction: float = 0.4,
             passivity_controller: Stabiliser | None = None, *, vibration=None, vibration_mass: float | None = None,
             vibration_gain: float = 1.0, velocity_filter: float = 0.01, seed: int = 0,
             vibration_budget: float | None = None, vibration_reserve: float | None = None) -> SimulationResult:
    """Simulate a device in closed loop with an algorithm, driven by an operator.

    In the plane (a profile h(x), positions [x, z]) or in space (a surface h(x, y),
    positions [x, y, z]): the algorithm's texture, the device and the operator must agree.

    Parameters
    ----------
    algorithm : Algorithm
        Any of W, A–G (:func:`haptex.algorithm`); or A, B, C, G on a textured object
        (:func:`haptex.objects.object_algorithm`, [x, y, z]): the general loop with the object's
        tick (hx_object.c), its damping regime and penetration from the tick's (h(u) - e, or -e
        for G); or a god-object over the plane, a cylinder or a sphere
        (:class:`haptex.proxy.GodObject`, the general loop with its C tick, its penetration the
        distance to the proxy).
    device : Device
        The sampled-data device, of the algorithm's dimension.
    operator : Operator
        From :mod:`haptex.operators`, of the algorithm's dimension.
    duration : float
        Simulated time (s); rounded to whole sampling periods.
    initial_position : array_like, shape (d,), optional
        [x, z] or [x, y, z] (m); default the origin (the start of the path for a
        KinematicPath).
    initial_velocity : array_like, shape (d,), optional
        m/s; default zero.
    record_every : int, optional
        Record one sample in this many: a whole number from 1 to the run's number of samples.
    tail_fraction : float, optional
        Fraction of the run, at its end, on which the oscillation verdict is decided (at most
        its last :data:`TAIL_SAMPLES` steps: every step of it is read, so that no motion below
        the servo's Nyquist frequency is aliased).
    passivity_controller : Stabiliser, optional
        A stabiliser in the loop, acting on the sensed positions like the
        :class:`haptex.Renderer`: :class:`haptex.PassivityController` (Hannaford & Ryu 2002),
        :class:`haptex.EnergyBounding` (after Kim & Ryu 2004) or
        :class:`haptex.PassiveSetPosition` (after Lee & Huang 2010); default none.
    vibration : haptex.datadriven.ModelSet, optional
        A data-driven vibration on the controller's tick, the C core's channel that
        :class:`haptex.Renderer` runs (``hx_vibration.c``): in contact and moving,
        ``vibration_mass`` x its acceleration (m/s²) along the filtered tangential velocity,
        at the operating point (that speed, the algorithm's normal force f_z), before the
        stabiliser, quantisation and saturation. Its models must run at the device's servo
        rate. Its work at the port is :attr:`SimulationResult.vibration_supplied`.
    vibration_mass : float, optional
        kg, required with ``vibration``: the mass turning its acceleration into force (HaTT's
        display on a Phantom: the handle's; a preset's own, ``preset(NAME).device().mass[0, 0]``,
        not that of the device with a hand attached).
    vibration_gain, velocity_filter, seed, vibration_budget, vibration_reserve
        As :class:`haptex.Renderer`'s: a factor >= 0, the speed filter's time constant (s),
        the noise's seed (the same seed, the same run), and the budgeted vibration's power (W)
        and tank (J).

    Returns
    -------
    SimulationResult

    Raises
    ------
    ParameterError
        For invalid inputs, dimensions that disagree, a vibration whose models do not run at
        the device's servo rate, or a recording that would exceed :data:`MEMORY_BUDGET`
        (2 GiB; 96 bytes a recorded sample in the plane, 128 in space) — record fewer
        samples with ``record_every``.

    Notes
    -----
    A rigid device with diagonal mass and damping matrices pushed by a constant force is
    integrated axis by axis (:func:`_fast_coefficients`), everything else by the augmented
    transition and Van Loan's quadratic forms; both are exact, and the energy balance closes
    to round-off on both.
    """
    algorithm = checked_algorithm(algorithm, proxy=True)
    n_steps, p0, v0 = _prepare(algorithm, device, operator, duration, initial_position, initial_velocity)
    record_every = whole("record_every", record_every, 1, max(1, n_steps), "samples: the run's at most")
    if not 0 < tail_fraction <= 1:
        raise fail("tail_fraction", tail_fraction, "a number in (0, 1]")
    pc_on, pc_b, pc_ref = _controller(passivity_controller)
    _observer_delay(passivity_controller, device.delay)
    vib = _vibration_inputs(device, vibration, vibration_mass, vibration_gain, velocity_filter, seed,
                            vibration_budget, vibration_reserve)
    d = p0.size
    width = 4 * d + 4
    n_rec = n_steps // record_every
    if n_rec * width * 8 > MEMORY_BUDGET:
        raise ParameterError(
            f"duration = {duration:g} s is not allowed with record_every = {record_every}: recording "
            f"{n_rec} samples needs {n_rec * width * 8 / 2**30:.1f} GiB, over the 2 GiB budget; "
            f"use record_every >= {math.ceil(n_steps * width * 8 / MEMORY_BUDGET)}"
        )
    code, prm, kind, coeffs, aux, nominal, Phi, Wd, Wo, Bs, Binv, fast, base = _kernel_inputs(algorithm, device,
                                                                                               operator)
    rec = np.zeros((n_rec, width))
    summary = np.zeros(N_SUMMARY)
    tail_start = _tail_start(n_steps, tail_fraction)
    tail = np.zeros((d, n_steps - tail_start))
    if base is None and code != _core._ext.ALG_PROXY and vib is None and _lean(
            fast, operator.kinematic, pc_on, device.delay, device.position_resolution, device.force_resolution,
            device.max_force, device.coulomb_friction):  # (the proxy, objects, a vibration: the general loop)
        _core_lean(code, kind, nominal, n_steps, device.period, record_every, tail_start, prm[None], coeffs[None],
                   aux[None], fast[None], device.mass[None], np.asarray(operator.force)[None], p0[None], v0[None],
                   rec[None], summary[None], tail[None])
    else:
        M, modal = _mass_inputs(device)
        one = lambda a: np.asarray(a)[None]  # noqa: E731
        _core_general(code, kind, nominal, operator.kinematic, pc_on, pc_ref, n_steps, device.period, record_every,
                      tail_start, operator.setpoint_times, one(prm), one(coeffs), one(aux), one(Phi), one(Wd), one(Wo),
                      one(Bs), one(Binv), one(fast), one(M), one(modal), one(operator.stiffness),
                      one(operator.damping), one(operator.force), one(operator.setpoint_points),
                      one(operator.final_velocity), one(operator.rest_length), one(device.delay),
                      one(device.position_resolution), one(device.force_resolution), one(device.max_force),
                      one(device.coulomb_friction), one(pc_b), one(p0), one(v0), rec[None], summary[None], tail[None],
                      base=base, vibration=vib)
    rates = _texture_frequencies(algorithm, operator)
    osc = _oscillations(tail[None], (n_steps - tail_start) * device.period, _tail_energy(summary[None]),
                        np.array([_threshold(device.position_resolution)]), _frequency_table([rates]))
    result = _result(rec, summary, osc[0], rates, np.ascontiguousarray(tail.T) if record_every > 1 else None,
                     device.period)
    _warn_health([result])
    return result


def _threshold(position_resolution):
    """Amplitude below which motion counts as rest (m), elementwise: the encoder's resolution
    ``position_resolution`` (m), >= 0.1 um."""
    return np.maximum(position_resolution, 1e-7)


def _tail_energy(summary: np.ndarray) -> np.ndarray:
    """Change of the summed environment energies over the tail (J), per run."""
    return summary[:, S_EX] + summary[:, S_EY] + summary[:, S_EZ] - summary[:, S_TAILSTART_E]


def _frequency_table(freqs: list) -> np.ndarray:
    """Per-run texture rates (Hz) as an (N, k) array, NaN-padded."""
    k = max((len(f) for f in freqs), default=0)
    out = np.full((len(freqs), k), np.nan)
    for i, f in enumerate(freqs):
        out[i, :len(f)] = f
    return out


def _warn_health(results) -> None:
    """One SimulationWarning for runs that diverged or whose energy balance does not close."""
    _warn_arrays(np.array([r.diverged_at or 0 for r in results]),
                 np.array([r.energy_balance_error for r in results]),
                 [r.diverged_quantity for r in results], stacklevel=4)


def _warn_arrays(diverged_at: np.ndarray, balance: np.ndarray, quantities, stacklevel: int) -> None:
    """One SimulationWarning for the runs that diverged, one for balances that do not close;
    ``stacklevel`` points at the user's call."""
    div = np.flatnonzero(diverged_at)
    bad = np.flatnonzero((diverged_at == 0) & (balance > BALANCE_TOLERANCE))
    n = diverged_at.size
    if div.size:
        i = int(div[0])
        where = "" if n == 1 else f"run {i} of {n} ({div.size} in all) "
        warnings.warn(f"the simulation {where}diverged: its {quantities[i]} became non-finite at sample "
                      f"{int(diverged_at[i])}; it stopped there", SimulationWarning, stacklevel=stacklevel)
    if bad.size:
        i = int(bad[0])
        where = "" if n == 1 else f"run {i} of {n} ({bad.size} in all) "
        warnings.warn(f"the energy balance of the simulation {where}closes to {balance[i]:.2g} relative, above "
                      f"{BALANCE_TOLERANCE:g}: the discretisation is ill-conditioned for these parameters",
                      SimulationWarning, stacklevel=stacklevel)


def _scan_speed(algorithm, operator) -> float | None:
    """|v| (m/s) of a constant-velocity scan over a profile with a line spectrum, else None."""
    v = abs(float(operator.final_velocity[0]))
    if (getattr(algorithm.texture, "periods", None) is None or algorithm.dimension != 2 or operator.kinematic
            or operator.setpoint_times.size != 1 or v == 0.0):
        return None
    return v


def _texture_frequencies(algorithm, operator) -> tuple:
    """Rates (Hz) at which a constant-velocity scan crosses the texture's periods, v / l_k; empty
    for other operators and for textures without a line spectrum (measured profiles, surfaces)."""
    v = _scan_speed(algorithm, operator)
    if v is None:
        return ()
    return tuple(float(v / p) for p in np.atleast_1d(algorithm.texture.periods))


def _result(rec, summary, osc: Oscillation, texture_rates: tuple = (), tail=None,
            period: float = 0.0) -> SimulationResult:
    """One run's result from its recorded rows, its summary and verdict; ``tail`` (m, d) its
    tail at every step, kept where the recording skips steps (``period`` s apart), else None."""
    d = (rec.shape[1] - 4) // 4
    diverged = int(summary[S_DIVERGED]) or None
    if diverged is not None:  # rows are written in order and their time is > 0
        rec = rec[:int(np.count_nonzero(rec[:, 0]))]
    totals = {"energy_x": float(summary[S_EX]), "energy_z": float(summary[S_EZ]),
              "damping_energy": float(summary[S_DAMP]), "operator_work": float(summary[S_OP]),
              "kinetic_energy": float(summary[S_KE]), "friction_energy": float(summary[S_FRIC])}
    if d == 3:
        totals["energy_y"] = float(summary[S_EY])
    E = 1 + 3 * d
    return SimulationResult(
        time=rec[:, 0], position=rec[:, 1:1 + d], velocity=rec[:, 1 + d:1 + 2 * d], force=rec[:, 1 + 2 * d:E],
        energy_x=rec[:, E], energy_z=rec[:, E + d - 1], damping_energy=rec[:, 1 + 4 * d],
        operator_work=rec[:, 2 + 4 * d], kinetic_energy=rec[:, 3 + 4 * d],
        initial_kinetic_energy=float(summary[S_KE0]), saturations=int(summary[S_SAT]),
        max_penetration=float(summary[S_MAXPEN]), oscillation=osc, totals=totals, diverged_at=diverged,
        diverged_quantity=None if diverged is None else _DIVERGED_NAMES[int(summary[S_DIVERGED_WHAT])],
        energy_y=rec[:, E + 1] if d == 3 else None, passivity_control_samples=int(summary[S_PC_ACTIVE]),
        observed_energy=float(summary[S_PC_ENERGY]), texture_rates=tuple(texture_rates),
        vibration_supplied=float(summary[S_VIB_SUPPLIED]), vibration_cut=int(summary[S_VIB_CUT]),
        vibration_clamped=int(summary[S_VIB_CLAMPED]), tail_position=tail,
        tail_period=float(period) if tail is not None else 0.0)


_ALGORITHM_KEYS = ("stiffness", "amplitude", "texture_period", "friction", "presliding", "modulation_depth",
                   "max_penetration")
_DEVICE_KEYS = ("mass", "damping", "damping_outside", "delay", "position_resolution", "force_resolution", "coulomb_friction",
                "max_force")
_OPERATOR_KEYS = ("push_x", "push_y", "push_z", "band_stiffness", "anchor_x", "anchor_y", "anchor_z", "hand_stiffness",
                  "hand_damping", "depth", "velocity")
_START_KEYS = ("initial_x", "initial_y", "initial_z")
SWEEP_KEYS = _ALGORITHM_KEYS + _DEVICE_KEYS + _OPERATOR_KEYS + _START_KEYS
"""Parameters :func:`simulate_batch` can sweep (SI units)."""
SWEEP_UNITS = {"stiffness": "N/m", "amplitude": "m", "texture_period": "m", "friction": "dimensionless",
               "presliding": "m", "modulation_depth": "dimensionless", "max_penetration": "m", "mass": "kg",
               "damping": "N*s/m", "damping_outside": "N*s/m", "delay": "samples", "position_resolution": "m",
               "force_resolution": "N", "coulomb_friction": "N", "max_force": "N", "push_x": "N", "push_y": "N",
               "push_z": "N", "band_stiffness": "N/m", "anchor_x": "m", "anchor_y": "m", "anchor_z": "m",
               "hand_stiffness": "N/m", "hand_damping": "N*s/m", "depth": "m", "velocity": "m/s", "initial_x": "m",
               "initial_y": "m", "initial_z": "m"}
"""The SI unit of each of :data:`SWEEP_KEYS` (``delay`` in whole samples)."""


@dataclass(frozen=True)
class BatchResult:
    """Per-run summaries of :func:`simulate_batch`; every array has shape (N,).

    Parameters
    ----------
    parameters : dict of ndarray
        The swept values, broadcast to N runs.
    energy_x, energy_z : ndarray
        Final E_x, E_z (J).
    energy_y : ndarray or None
        Final E_y (J) in 3-D; None in the plane.
    damping_energy, operator_work, kinetic_energy : ndarray
        Final values (J).
    energy_balance_error : ndarray
        Relative closure of each run's energy balance.
    oscillating : ndarray of bool
    amplitude, frequency, energy_per_cycle : ndarray
        The oscillation verdict's numbers (m, Hz, J).
    max_penetration : ndarray
        m.
    saturations : ndarray of int
    diverged_at : ndarray of int
        Sample (1-based) at which each run became non-finite and stopped; 0 if it did not.
    runs : list of SimulationResult or None
        Full time series, only with ``record=True``.
    passivity_control_samples : ndarray of int
        Samples on which the passivity controller acted, per run.
    observed_energy : ndarray
        The passivity observer's energy absorbed per run (J; 0 without a controller): see
        :attr:`SimulationResult.observed_energy`.
    oscillating_axes : ndarray of bool, shape (N, d)
        The verdict per axis, [x, z] in the plane, [x, y, z] in space.
    decay_ratio : ndarray
        Amplitude of the tail's second half over its first, on the main axis.
    growing : ndarray of bool
        The motion grows: decay ratio > 1 with an amplitude above the rest threshold, not
        at the rate the texture drives (an unstable loop, before any limit cycle).
    regime : ndarray of str
        Each run's regime (:func:`regime`): "decaying", "settling", "driven", "limit cycle",
        "growing" or "diverged"; an unstable loop is one of :data:`UNSTABLE`, whichever its decay
        ratio's last digits (``growing`` alone flips between a bounded cycle's 0.9999 and
        1.0001).
    vibration_supplied : ndarray of float
        With a data-driven vibration: its work on the sensed motion per run (J); zeros without.
    vibration_cut : ndarray of int
        Samples whose vibration the energy budget scaled down, per run.
    """

    parameters: dict
    energy_x: np.ndarray
    energy_z: np.ndarray
    damping_energy: np.ndarray
    operator_work: np.ndarray
    kinetic_energy: np.ndarray
    energy_balance_error: np.ndarray
    oscillating: np.ndarray
    amplitude: np.ndarray
    frequency: np.ndarray
    energy_per_cycle: np.ndarray
    max_penetration: np.ndarray
    saturations: np.ndarray
    diverged_at: np.ndarray
    runs: list | None = None
    energy_y: np.ndarray | None = None
    passivity_control_samples: np.ndarray | None = None
    observed_energy: np.ndarray | None = None
    oscillating_axes: np.ndarray | None = None
    decay_ratio: np.ndarray | None = None
    growing: np.ndarray | None = None
    regime: np.ndarray | None = None
    vibration_supplied: np.ndarray | None = None
    vibration_cut: np.ndarray | None = None

    @property
    def unstable(self) -> np.ndarray:
        """True where the run's regime is one of :data:`UNSTABLE`, shape (N,)."""
        return np.isin(self.regime, list(UNSTABLE))


def _plane_keys(d: int, keys) -> None:
    """Refuse the sweep keys of a y axis over a profile (d = 2)."""
    if d == 2 and ("push_y" in keys or "anchor_y" in keys):
        raise ParameterError("push_y and anchor_y are not allowed in the plane (a profile): they sweep 3-D operators")


def _rebuild(algorithm: Algorithm, device: Device, operator: Operator, values: dict):
    """The algorithm, device and operator of one run of a sweep."""
    from .algorithms import algorithm as make
    from .textures import Sinusoid

    if any(k in values for k in _ALGORITHM_KEYS):
        tex = algorithm.texture
        if "amplitude" in values or "texture_period" in values:
            if not isinstance(tex, Sinusoid):
                raise ParameterError("amplitude and texture_period sweeps are not allowed for a texture that is not a Sinusoid")
            tex = Sinusoid(values.get("amplitude", tex.amplitude), values.get("texture_period", tex.period), tex.phases[0])
        takes = type(algorithm).parameters  # (the registry: haptex.algorithms.Algorithm.parameters)
        if "max_penetration" in values and "max_penetration" not in takes:
            raise ParameterError(f"max_penetration is not allowed in a sweep of algorithm {algorithm.letter}")
        if any(k in values and k not in takes for k in ("friction", "presliding", "modulation_depth")):
            raise ParameterError(f"friction parameters are not allowed in a sweep of algorithm {algorithm.letter}")
        kw = {k: values.get(k, getattr(algorithm, k)) for k in takes}  # (W keeps its virtual damper)
        algorithm = make(algorithm.letter, tex, values.get("stiffness", algorithm.stiffness), **kw)
    dv = {k: values[k] for k in _DEVICE_KEYS if k in values}
    if "delay" in dv:
        dv["delay"] = whole("delay", dv["delay"], 0, 10_000, "sampling periods")
    if dv:
        device = device.replace(**dv)
    ov = {k: values[k] for k in _OPERATOR_KEYS if k in values}
    if ov:
        d = operator.dimension
        _plane_keys(d, ov)
        K, C, f = operator.stiffness.copy(), operator.damping.copy(), operator.force.copy()
        pts = operator.setpoint_points.copy()
        vend = operator.final_velocity.copy()
        for axis, i in (("x", 0), ("y", 1), ("z", d - 1)):
            if f"push_{axis}" in ov:
                f[i] = ov[f"push_{axis}"]
            if f"anchor_{axis}" in ov:
                pts[0, i] = ov[f"anchor_{axis}"]
        if "band_stiffness" in ov:
            K = positive("band_stiffness", ov["band_stiffness"], "N/m") * np.eye(d)
        if "hand_stiffness" in ov:
            K = positive("hand_stiffness", ov["hand_stiffness"], "N/m") * np.eye(d)
        if "hand_damping" in ov:
            C = nonnegative("hand_damping", ov["hand_damping"], "N s/m") * np.eye(d)
        depth = operator.depth
        if "depth" in ov:
            depth = nonnegative("depth", ov["depth"], "m")
            pts[:, -1] += operator.depth - depth
        if "velocity" in ov:
            vend = np.zeros(d)
            vend[0] = float(ov["velocity"])
        operator = Operator(stiffness=K, damping=C, force=f, setpoint_times=operator.setpoint_times,
                            setpoint_points=pts, final_velocity=vend, rest_length=operator.rest_length,
                            kinematic=operator.kinematic, depth=depth)
    return algorithm, device, operator


_PACKED_KEYS = SCALAR_FIELDS + ("push_x", "push_y", "push_z")
"""Sweep keys every batch packs per run, lean or general: the device's scalar fields (its
delay, resolutions, force limit and Coulomb friction) and the constant push, which only the
loops read (no device or operator is built for them, no discretisation made again)."""


def _packed_scalars(values: dict) -> dict:
    """The swept :data:`_PACKED_KEYS`, each checked as the device checks it
    (:func:`haptex.devices.scalar_field`, once per distinct value)."""
    out = {}
    for key in _PACKED_KEYS:
        if key in values:
            if key in SCALAR_FIELDS:
                for v in np.unique(values[key]):
                    scalar_field(key, float(v))
            out[key] = values[key].astype(np.int64) if key == "delay" else values[key]
    return out


_PACKED_TEXTURE_KEYS = ("amplitude", "texture_period")
"""A Sinusoid's keys a batch of A, B, C or G packs per run: the C core reads their texture only
through its coefficients (amplitude, wavenumber, phase), and nothing else of theirs depends on it."""


def _packed_texture(algorithm, values: dict):
    """The Sinusoid's coefficients per run, shape (N, 3, 1), of a sweep of its amplitude (m)
    and period (m) under A, B, C or G, made for all runs at once as the Sinusoid makes them;
    None otherwise (another texture or letter: each value built). A bad value is refused with
    the error the Sinusoid itself gives it."""
    from .textures import Sinusoid

    if (not any(k in values for k in _PACKED_TEXTURE_KEYS) or type(algorithm.texture) is not Sinusoid
            or algorithm.letter not in ("A", "B", "C", "G") or getattr(algorithm, "base", None) is not None):
        return None
    tex = algorithm.texture
    amp = values.get("amplitude", np.full(len(next(iter(values.values()))), tex.amplitude))
    per = values.get("texture_period", np.full(amp.shape, tex.period))
    Sinusoid(float(amp.min()), float(per.min()), tex.phases[0])  # its checks are lower bounds: the least of each
    return tex.coefficients(amp[:, None], per[:, None], tex.phases[0])


_PACKED_DEVICE_KEYS = ("mass", "damping", "damping_outside")
"""Device keys a batch on the fast path packs per run (the mass and the damping set only its
per-axis closed forms and its mass and damping matrices), as the stiffness is packed into the
parameter vector."""


def _packed_device(device: Device, operator: Operator, values: dict):
    """(M, Bs, Binv, fast) per run of a sweep of the mass and the damping (isotropic values, kg
    and N s/m) of a rigid device with diagonal matrices pushed by a constant force (the fast
    path, on the lean loop or the general one), made for all runs at once: M (N, d, d); Bs and
    Binv (N, 2, d, d), the damping outside and inside the wall and the inverse of the held
    force's map to the end velocity (diagonal: 1 / VW); fast (N, 2, d, N_FAST). None where the
    runs must be built one by one (another key of the device or operator swept, a structural
    mode, another operator). A bad value is refused with the error the device itself gives it."""
    swept = set(values) - {"stiffness", *_START_KEYS, *_ALGORITHM_KEYS, *_PACKED_KEYS}
    if not swept & set(_PACKED_DEVICE_KEYS) or swept - set(_PACKED_DEVICE_KEYS) or not _fast_path(device, operator):
        return None
    d, T = device.dimension, device.period
    N = len(next(iter(values.values())))
    axes = lambda A: np.tile(np.diag(A), (N, 1))  # noqa: E731
    m, b_in, b_out = axes(device.mass), axes(device.damping), axes(device.damping_outside)
    for key in _PACKED_DEVICE_KEYS:
        if key in values:
            v = values[key]
            bad = ~definite(v, v, key != "mass")  # (the device's own rule, isotropic: both eigenvalues v)
            if np.any(bad):
                _matrix(key, float(v[bad][0]), key != "mass", d)  # raises the device's own error
    if "mass" in values:
        m[:] = values["mass"][:, None]
    if "damping" in values:
        b_in[:] = values["damping"][:, None]
        if "damping_outside" not in values and np.array_equal(device.damping_outside, device.damping):
            b_out = b_in  # (Device.replace: the outside damping follows the damping it equalled)
    if "damping_outside" in values:
        b_out[:] = values["damping_outside"][:, None]
    # |eig(M^-1 (B + C))| T with M and B diagonal and C = 0 (a constant push): b / m an axis
    _check_damping_ratio(float((np.maximum(np.abs(b_in), np.abs(b_out)) * T / m).max()))  # (the worst run's)
    eye = np.eye(d)
    b = np.stack([b_out, b_in], axis=1)  # (N, 2, d)
    fast = _axis_coefficients(m[:, None, :], b, T)
    return m[:, :, None] * eye, b[..., None] * eye, _fast_binv(fast), fast


@_core.blas_held_to_one_thread
def simulate_batch(algorithm: Algorithm, device: Device, operator: Operator, duration: float, initial_position=None,
                   initial_velocity=None, record: bool = False, record_every: int = 1, tail_fraction: float = 0.4,
                   progress: bool | None = None, passivity_controller: Stabiliser | None = None,
                   vibration=None, vibration_mass: float | None = None, vibration_gain: float = 1.0,
                   velocity_filter: float = 0.01, seed: int = 0, vibration_budget: float | None = None,
                   vibration_reserve: float | None = None, **sweep) -> BatchResult:
    """Run many simulations that differ in some parameters, in one parallel compiled loop.

    Parameters
    ----------
    algorithm, device, operator, duration, initial_position, initial_velocity
        As for :func:`simulate`; they give the values of everything not swept. A textured
        object (:func:`haptex.objects.object_algorithm`) runs in the general loop, its base
        shared by every run; of the algorithm's parameters only ``stiffness`` is swept there.
    record : bool, optional
        Keep every run's time series (memory: N x samples x 96 bytes in the plane, 128 in
        space, within the 2 GiB budget); default False, summaries only.
    record_every, tail_fraction, passivity_controller
        As for :func:`simulate`.
    vibration, vibration_mass, vibration_gain, velocity_filter, seed, vibration_budget, vibration_reserve
        As for :func:`simulate`: the same data-driven vibration on every run, each run's noise
        from ``seed`` (the general loop; the channel's work per run in
        :attr:`BatchResult.vibration_supplied`).
    progress : bool, optional
        Show a progress bar; default: when the batch has more than 5e7 samples in all.
    **sweep : array_like, shape (N,) or scalar
        Parameters to vary, each broadcast to N runs; names from :data:`SWEEP_KEYS`:
        algorithm ``stiffness``, ``amplitude``, ``texture_period``, ``friction``,
        ``presliding``, ``modulation_depth``, ``max_penetration``; device ``mass``,
        ``damping``, ``damping_outside``, ``delay``, ``position_resolution``,
        ``force_resolution``, ``coulomb_friction``, ``max_force``; operator ``push_x``,
        ``push_y``, ``push_z``, ``band_stiffness``, ``anchor_x``, ``anchor_y``, ``anchor_z``,
        ``hand_stiffness``, ``hand_damping``, ``depth``, ``velocity``; and ``initial_x``,
        ``initial_y``, ``initial_z`` (the y keys in 3-D only).

    Returns
    -------
    BatchResult

    Raises
    ------
    ParameterError
        For an unknown sweep name, arrays that do not broadcast, or any invalid value
        (checked for every run before anything runs).

    Notes
    -----
    The per-run summaries, oscillation verdicts included, are computed for all runs at once
    (vectorised over the runs), so a batch of short runs is not dominated by Python. Runs are
    built once per distinct combination of the swept values other than those packed per run
    without building anything: the start; the stiffness (into the parameter vector); the
    device's delay, resolutions, force limit and Coulomb friction and the push; a Sinusoid's
    amplitude and period under A, B, C and G (as its coefficients); and, on the fast path (a
    rigid diagonal device under a constant push), the mass and the damping, as their per-axis
    closed forms. A sweep of 1,000 values of any of these costs 1-6 us a run besides
    the loop (a 10^4-sample run of the lean loop takes about 190 us on one thread here), where
    building a device a value cost 0.3-0.7 ms; runs with the same dynamics share one
    discretisation.
    """
    algorithm = checked_algorithm(algorithm, proxy=True)
    unknown = sorted(set(sweep) - set(SWEEP_KEYS))
    if unknown:
        raise ParameterError(f"sweep parameters {unknown} are not allowed: choose from {', '.join(SWEEP_KEYS)}")
    n_steps, p0, v0 = _prepare(algorithm, device, operator, duration, initial_position, initial_velocity)
    record_every = whole("record_every", record_every, 1, max(1, n_steps), "samples: the run's at most")
    d = p0.size
    if d == 2 and "initial_y" in sweep:
        raise ParameterError("initial_y is not allowed in the plane (a profile): it sweeps 3-D starts")
    pc_on, pc_b, pc_ref = _controller(passivity_controller)
    vib = _vibration_inputs(device, vibration, vibration_mass, vibration_gain, velocity_filter, seed,
                            vibration_budget, vibration_reserve)
    try:
        arrays = np.broadcast_arrays(*[np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in sweep.values()]) if sweep else []
    except ValueError:
        raise ParameterError("the sweep arrays are not allowed: their shapes do not broadcast to one length N") from None
    values = {k: a.ravel() for k, a in zip(sweep, arrays)}
    N = len(next(iter(values.values()))) if values else 1
    for k, a in values.items():
        if not np.all(np.isfinite(a)):
            raise fail(k, a.tolist(), "finite values")
    width = 4 * d + 4
    n_rec = n_steps // record_every if record else 0
    if N * n_rec * width * 8 > MEMORY_BUDGET:
        raise ParameterError(f"record = True is not allowed here: {N} runs x {n_rec} samples need more than the 2 GiB budget")
    # the stiffness only sets the parameter vector's P_K0: packed into it after the runs are built
    # (a wall atlas sweeps it over thousands of values), its first bad value refused as the
    # algorithm would refuse it (the values are finite: checked above)
    stiffness = values.get("stiffness")
    if stiffness is not None and not np.all(stiffness > 0.0):
        positive("stiffness", float(stiffness[~(stiffness > 0.0)][0]), "N/m")
    # packed per run, nothing built a value: the device's scalar fields and the push
    # (_packed_scalars), the mass and damping on the fast path (_packed_device), a Sinusoid's
    # amplitude and period under A, B, C and G (_packed_texture)
    _plane_keys(d, values)
    scalars = _packed_scalars(values)
    dense = _packed_device(device, operator, values) if values else None
    sine = _packed_texture(algorithm, values) if values else None  # a Sinusoid's coefficients per run
    # runs that differ only in their start, stiffness and packed keys share everything else:
    # build each distinct run once
    keys = [k for k in values if not k.startswith("initial_") and k != "stiffness" and k not in scalars
            and not (dense is not None and k in _PACKED_DEVICE_KEYS)
            and not (sine is not None and k in _PACKED_TEXTURE_KEYS)]
    if keys:
        _, first, inverse = np.unique(np.column_stack([values[k] for k in keys]), axis=0, return_index=True,
                                      return_inverse=True)
        inverse = inverse.ravel()
    else:
        first, inverse = np.zeros(1, dtype=np.intp), np.zeros(N, dtype=np.intp)
    if getattr(algorithm, "base", None) is not None:  # a textured object: its algorithm is not rebuilt
        swept = sorted(k for k in values if k in _ALGORITHM_KEYS and k != "stiffness")
        if swept:
            raise ParameterError(f"{swept[0]} is not allowed in a sweep of {algorithm!r}: on an object only the "
                                 "stiffness, the device and the operator are swept")
    runs = [_rebuild(algorithm, device, operator, {k: float(values[k][i]) for k in keys}) for i in first]
    letters = {a.letter for a, _, _ in runs}
    periods = {d_.period for _, d_, _ in runs}
    memo: dict = {}
    specs = [_kernel_inputs(a, d_, o, memo) for a, d_, o in runs]
    base = specs[0][12]  # a textured object's base, shared by every run (the general loop takes it)
    if len(letters) != 1 or len({s[3].shape for s in specs}) != 1 or len(periods) != 1:
        raise ParameterError("the runs of a batch must share the algorithm letter, texture shape and sampling period")
    code, kind, nominal = specs[0][0], specs[0][2], specs[0][5]
    st = lambda j: np.ascontiguousarray(np.stack([s[j] for s in specs])[inverse])  # noqa: E731
    prm, coeffs = st(1), st(3)
    if stiffness is not None:
        prm[:, P_K0] = stiffness
    if sine is not None:
        coeffs = sine
    fast = st(11) if len({s[11].shape[0] for s in specs}) == 1 else np.zeros((N, 0, d, N_FAST))
    n_aux = max(s[4].size for s in specs)  # bound trees of different sizes: pad (the header says the size)
    aux = np.zeros((len(specs), n_aux))
    for i, s in enumerate(specs):
        aux[i, :s[4].size] = s[4]
    aux = aux[inverse]
    dev = [d_ for _, d_, _ in runs]
    ops = [o for _, _, o in runs]
    if len({d_.structural_mode for d_ in dev}) != 1:
        raise ParameterError("the runs of a batch must all have a structural mode or all be rigid")
    by_run = lambda items, **kw: np.ascontiguousarray(np.asarray(items, **kw)[inverse])  # noqa: E731
    M = by_run([_mass_inputs(d_)[0] for d_ in dev])
    f0 = by_run([o.force for o in ops])
    for axis, i in (("x", 0), ("y", 1), ("z", d - 1)):
        if f"push_{axis}" in scalars:
            f0[:, i] = scalars[f"push_{axis}"]
    fields = {name: scalars[name] if name in scalars else by_run([getattr(d_, name) for d_ in dev],
                                                                  dtype=np.int64 if name == "delay" else np.float64)
              for name in SCALAR_FIELDS}
    delay, delta, fres, fmax, fc = (np.ascontiguousarray(fields[name]) for name in SCALAR_FIELDS)
    _observer_delay(passivity_controller, delay)
    pcb = np.full(N, pc_b)
    P0 = np.tile(p0, (N, 1))
    for axis, i in (("x", 0), ("y", 1), ("z", d - 1)):
        if f"initial_{axis}" in values:
            P0[:, i] = values[f"initial_{axis}"]
    V0 = np.tile(v0, (N, 1))
    rec = np.zeros((N, n_rec, width))
    summary = np.zeros((N, N_SUMMARY))
    tail_start = _tail_start(n_steps, tail_fraction)
    m_tail = n_steps - tail_start
    per_block = max(1, TAIL_BLOCK // (d * m_tail * 8))  # runs a block: the tail buffer is reused between blocks
    tail = np.zeros((min(N, per_block), d, m_tail))
    # recorded one sample in several, each run's tail at every step is kept for its buzz (SimulationResult.buzz)
    kept = None
    if record and record_every > 1:
        if N * (n_rec * width + m_tail * d) * 8 > MEMORY_BUDGET:
            raise ParameterError(f"record = True is not allowed here: {N} runs x {n_rec} samples and their tails of "
                                 f"{m_tail} steps need more than the 2 GiB budget")
        kept = np.empty((N, m_tail, d))
    T = dev[0].period
    thresholds = _threshold(delta)
    rates = [_texture_frequencies(a, o) for a, _, o in runs]  # per distinct run
    freqs = _frequency_table(rates)[inverse]
    if sine is not None and "texture_period" in values and freqs.shape[1]:  # a scan: v / l per run
        speed = np.array([_scan_speed(a, o) for a, _, o in runs])[inverse]
        freqs[:, 0] = speed / values["texture_period"]
    # the lean loop where none of its omitted machinery is used, else the general one (both C),
    # whose per-run matrices are made only then (N copies of 2 x 10 x 10 maps and forms)
    in_core = base is None and code != _core._ext.ALG_PROXY and vib is None and bool(
        _lean(fast, ops[0].kinematic, pc_on, delay, delta, fres, fmax, fc))
    if dense is not None:  # (the base's Phi, Wd, Wo are not made on the fast path: _kernel_inputs)
        M, fast = (np.ascontiguousarray(dense[j]) for j in (0, 3))
    if not in_core:
        Phi, Wd, Wo, Bs, Binv = st(6), st(7), st(8), st(9), st(10)
        modal = by_run([_mass_inputs(d_)[1] for d_ in dev])
        K = by_run([o.stiffness for o in ops])
        C = by_run([o.damping for o in ops])
        sp_p = by_run([o.setpoint_points for o in ops])
        vend = by_run([o.final_velocity for o in ops])
        rest = by_run([o.rest_length for o in ops])
        if dense is not None:
            Bs, Binv = (np.ascontiguousarray(dense[j]) for j in (1, 2))
    threads = _core.num_threads()
    show = (N * n_steps > 5e7) if progress is None else bool(progress)
    bar = _progress(show, N)
    tables = []
    for idx in np.array_split(np.arange(N), max(-(-N // per_block), min(N, 20) if show else 1)):
        if idx.size:
            lo, hi = idx[0], idx[-1] + 1
            block = tail[:hi - lo]
            if lo:
                block.fill(0.0)  # a run that diverges leaves the rest of its tail as it found it
            parts = {}

            def verdicts(a, b, lo=lo, block=block):  # a slice's verdicts, in its worker thread once its runs are done
                rows = slice(lo + a, lo + b)
                parts[a] = _oscillation_table(block[a:b], (n_steps - tail_start) * T, _tail_energy(summary[rows]),
                                              thresholds[rows], freqs[rows], threads=1)

            if in_core:
                _core_lean(code, kind, nominal, n_steps, T, int(record_every), tail_start, prm[lo:hi], coeffs[lo:hi],
                           aux[lo:hi], fast[lo:hi], M[lo:hi], f0[lo:hi], P0[lo:hi], V0[lo:hi], rec[lo:hi],
                           summary[lo:hi], block, threads, after=verdicts)
            else:
                _core_general(code, kind, nominal, ops[0].kinematic, pc_on, pc_ref, n_steps, T, int(record_every),
                              tail_start, ops[0].setpoint_times, prm[lo:hi], coeffs[lo:hi], aux[lo:hi], Phi[lo:hi],
                              Wd[lo:hi], Wo[lo:hi], Bs[lo:hi], Binv[lo:hi], fast[lo:hi], M[lo:hi], modal[lo:hi],
                              K[lo:hi], C[lo:hi], f0[lo:hi], sp_p[lo:hi], vend[lo:hi], rest[lo:hi], delay[lo:hi],
                              delta[lo:hi], fres[lo:hi], fmax[lo:hi], fc[lo:hi], pcb[lo:hi], P0[lo:hi], V0[lo:hi],
                              rec[lo:hi], summary[lo:hi], block, threads, base=base, after=verdicts,
                              vibration=vib)
            tables += [parts[a] for a in sorted(parts)]
            if kept is not None:
                kept[lo:hi] = np.swapaxes(block, 1, 2)
            bar(idx.size)
    bar(None)
    w_cmd = -(summary[:, S_EX] + summary[:, S_EY] + summary[:, S_EZ])
    balance = _balance_error(summary[:, S_KE], summary[:, S_KE0], w_cmd, summary[:, S_OP], summary[:, S_DAMP],
                             summary[:, S_FRIC])
    diverged_at = summary[:, S_DIVERGED].astype(np.int64)
    _warn_arrays(diverged_at, balance, [_DIVERGED_NAMES.get(int(w)) for w in summary[:, S_DIVERGED_WHAT]],
                 stacklevel=3)
    # the verdicts as arrays (per-run objects only for the recorded runs)
    t = {k: (tables[0][k] if k == "axes" else
             tuple(np.concatenate([tb[k][j] for tb in tables]) for j in range(5)) if k in tables[0]["axes"] else
             np.concatenate([tb[k] for tb in tables])) for k in tables[0]}
    return BatchResult(
        parameters=values,
        energy_x=summary[:, S_EX].copy(), energy_z=summary[:, S_EZ].copy(), damping_energy=summary[:, S_DAMP].copy(),
        operator_work=summary[:, S_OP].copy(), kinetic_energy=summary[:, S_KE].copy(),
        energy_balance_error=balance, oscillating=t["oscillating"].astype(bool),
        amplitude=t["amplitude"].astype(float), frequency=t["frequency"].astype(float),
        energy_per_cycle=t["energy_per_cycle"].astype(float),
        max_penetration=summary[:, S_MAXPEN].copy(), saturations=summary[:, S_SAT].astype(np.int64),
        diverged_at=diverged_at,
        runs=[_result(rec[i], summary[i], o, tuple(float(f) for f in freqs[i] if f == f),
                      None if kept is None else kept[i], T)
              for i, o in enumerate(_oscillation_objects(t))]
        if record else None,
        energy_y=summary[:, S_EY].copy() if d == 3 else None,
        passivity_control_samples=summary[:, S_PC_ACTIVE].astype(np.int64),
        observed_energy=summary[:, S_PC_ENERGY].copy(),
        oscillating_axes=np.column_stack([t[a][0] for a in ("xz" if d == 2 else "xyz")]).astype(bool).reshape(N, d),
        decay_ratio=t["decay_ratio"].astype(float),
        growing=(t["decay_ratio"] > 1.0) & (t["amplitude"] > t["threshold"]) & ~t["driven"].astype(bool),
        regime=regime(t["decay_ratio"], t["amplitude"], t["threshold"], t["cycles"],
                      t["driven"].astype(bool) | (summary[:, S_VIB_SUPPLIED] != 0.0), diverged_at > 0),
        vibration_supplied=summary[:, S_VIB_SUPPLIED].copy(), vibration_cut=summary[:, S_VIB_CUT].astype(np.int64))


def _progress(show: bool, total: int, description: str = "simulating", completed: int = 0, columns=(),
              console=None):
    """A rich progress bar advanced by the returned callable; ``None`` closes it. ``columns``
    and ``console`` as rich's ``Progress`` takes them (default: its columns, on stdout)."""
    if not show:
        return lambda n: None
    from rich.progress import Progress

    prog = Progress(*columns, transient=True, console=console)
    prog.start()
    task = prog.add_task(description, total=total, completed=completed)

    def advance(n):
        if n is None:
            prog.stop()
        else:
            prog.advance(task, n)

    return advance
