"""Sampled-data simulation of a haptic device in closed loop with a texture algorithm,
measuring energy the way the paper's experiments do (Section V).

Every sampling period T the controller reads the (quantised) handle position, computes
the algorithm's force, quantises and saturates it, and holds it (zero-order hold, after
``delay`` samples) while the handle moves. Between samples the handle, its damping and
the operator's springs and dampers form a linear system that is integrated exactly with
the matrix exponential of an augmented system; the energy dissipated by the damping and
the operator's work over each interval are exact quadratic forms of the state at the
sampling instant (Van Loan's integrals, computed once with scipy's expm).

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
from scipy.linalg import expm

from ._kernels import (_NZ, _NZ_MODE, DIVERGED_ENERGY, DIVERGED_FORCE, DIVERGED_POSITION, DIVERGED_VELOCITY, N_SUMMARY, S_DAMP,
                       S_DIVERGED, S_DIVERGED_WHAT, S_EX, S_EZ, S_FRIC, S_KE, S_KE0, S_MAXPEN, S_NSAMP, S_OP, S_SAT,
                       S_TAILSTART_E)
from ._kernels import run_batch as _run_batch
from ._kernels import run_one as _run
from ._validation import ParameterError, fail, nonnegative, positions, positive, whole
from .algorithms import Algorithm
from .devices import Device
from .operators import Operator

__all__ = ["SimulationResult", "Oscillation", "simulate", "simulate_batch", "MEMORY_BUDGET", "SimulationWarning",
           "BALANCE_TOLERANCE"]

BALANCE_TOLERANCE = 1e-6
"""Relative energy-balance error above which a result is flagged (exact runs close to ~1e-12)."""

_DIVERGED_NAMES = {DIVERGED_POSITION: "position", DIVERGED_VELOCITY: "velocity", DIVERGED_FORCE: "force",
                   DIVERGED_ENERGY: "energy"}


class SimulationWarning(RuntimeWarning):
    """A simulation diverged (a non-finite state) or its energy balance does not close."""

MEMORY_BUDGET = 2 * 1024**3
"""Largest time-series allocation (bytes) :func:`simulate` accepts: 2 GiB (96 bytes a
recorded sample). Longer runs must record every n-th sample (``record_every``)."""

_BYTES_PER_SAMPLE = 12 * 8


# --------------------------------------------------------------------------------------
# exact discretisation
# --------------------------------------------------------------------------------------
def _augmented(M: np.ndarray, B: np.ndarray, K: np.ndarray, C: np.ndarray, mode=None) -> np.ndarray:
    """F of dz/dt = F z for z = [p, v, u, g, r]: M dv/dt = u + g - K p - (B + C) v,
    du/dt = 0, dg/dt = r, dr/dt = 0.

    With ``mode`` = (M_m, M_h, K_s, C_s), z = [p, v, u, g, r, p_h, v_h]: the command u, the
    damping B and the sensing act on the motor side (p, v), the operator on the handle
    side: M_m dv/dt = u - B v - K_s (p - p_h) - C_s (v - v_h) and
    M_h dv_h/dt = g - K p_h - C v_h + K_s (p - p_h) + C_s (v - v_h)."""
    if mode is None:
        Minv = np.linalg.inv(M)
        F = np.zeros((_NZ, _NZ))
        F[0:2, 2:4] = np.eye(2)
        F[2:4, 0:2] = -Minv @ K
        F[2:4, 2:4] = -Minv @ (B + C)
        F[2:4, 4:6] = Minv
        F[2:4, 6:8] = Minv
        F[6:8, 8:10] = np.eye(2)
        return F
    Mm, Mh, Ks, Cs = mode
    mi, hi = np.linalg.inv(Mm), np.linalg.inv(Mh)
    F = np.zeros((_NZ_MODE, _NZ_MODE))
    F[0:2, 2:4] = np.eye(2)
    F[2:4, 0:2] = -mi @ Ks
    F[2:4, 2:4] = -mi @ (B + Cs)
    F[2:4, 4:6] = mi
    F[2:4, 10:12] = mi @ Ks
    F[2:4, 12:14] = mi @ Cs
    F[6:8, 8:10] = np.eye(2)
    F[10:12, 12:14] = np.eye(2)
    F[12:14, 10:12] = -hi @ (K + Ks)
    F[12:14, 12:14] = -hi @ (C + Cs)
    F[12:14, 6:8] = hi
    F[12:14, 0:2] = hi @ Ks
    F[12:14, 2:4] = hi @ Cs
    return F


def _van_loan(F: np.ndarray, Q: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """(Phi, W): Phi = e^{F T} and W = int_0^T e^{F' s} Q e^{F s} ds (Van Loan 1978)."""
    n = F.shape[0]
    big = np.zeros((2 * n, 2 * n))
    big[:n, :n] = -F.T
    big[:n, n:] = Q
    big[n:, n:] = F
    E = expm(big * T)
    Phi = E[n:, n:]
    W = Phi.T @ E[:n, n:]
    return Phi, 0.5 * (W + W.T)


def _discretise(device: Device, op: Operator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per damping regime (0 outside, 1 inside): Phi (2, n, n), W_damping, W_operator, with
    n = 10, or 14 for a device with a structural mode (see :func:`_augmented`)."""
    T = device.period
    K, C = op.stiffness, op.damping
    mode = device.mode_matrices() if device.structural_mode else None
    n = _NZ if mode is None else _NZ_MODE
    p_op, v_op = (slice(0, 2), slice(2, 4)) if mode is None else (slice(10, 12), slice(12, 14))
    Qop = np.zeros((n, n))  # the operator's power v' (g - K p - C v) on the body it holds
    Qop[v_op, p_op] = -0.5 * K
    Qop[p_op, v_op] = -0.5 * K.T
    Qop[v_op, v_op] = -0.5 * (C + C.T)
    Qop[v_op, 6:8] = 0.5 * np.eye(2)
    Qop[6:8, v_op] = 0.5 * np.eye(2)
    Phi = np.empty((2, n, n))
    Wd = np.empty((2, n, n))
    Wo = np.empty((2, n, n))
    for reg, B in enumerate((device.damping_outside, device.damping)):
        F = _augmented(device.mass, B, K, C, mode)
        Qd = np.zeros((n, n))  # dissipation: v' B v, and the mode's damper on v - v_h
        Qd[2:4, 2:4] = B
        if mode is not None:
            Cs = mode[3]
            Qd[2:4, 2:4] += Cs
            Qd[12:14, 12:14] = Cs
            Qd[2:4, 12:14] = -Cs
            Qd[12:14, 2:4] = -Cs
        Phi[reg], Wd[reg] = _van_loan(F, Qd, T)
        _, Wo[reg] = _van_loan(F, Qop, T)
    return Phi, Wd, Wo


def _mass_inputs(device: Device) -> tuple[np.ndarray, np.ndarray]:
    """(M, modal) for the compiled loop: the whole mass and no modal data for a rigid
    device; the motor side and [M_h, K_s] with a structural mode."""
    if not device.structural_mode:
        return device.mass, np.zeros((0, 2, 2))
    Mm, Mh, Ks, _ = device.mode_matrices()
    return Mm, np.stack([Mh, Ks])


# --------------------------------------------------------------------------------------
# results
# --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class AxisOscillation:
    """The oscillation verdict on one axis of the tail of a run.

    Attributes
    ----------
    oscillating : bool
        True when the half peak-to-peak motion along this axis in the second half of the
        tail, after removing the tail's straight-line trend (steady sliding or drift), is
        above the threshold and at least 0.9 times that of the first half (sustained or
        growing), over at least 3 cycles.
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

    Attributes
    ----------
    oscillating : bool
        True when either axis oscillates (:class:`AxisOscillation`): a lateral limit cycle
        counts as much as one along the normal.
    axis : str
        ``"x"`` or ``"z"``: the axis reported in ``amplitude``, ``decay_ratio`` and
        ``frequency`` — the oscillating one with the larger amplitude, else the larger.
    amplitude, decay_ratio, frequency : float
        That axis's figures (m, 1, Hz).
    energy_per_cycle : float
        Net energy the environment supplied per cycle of that axis's frequency in the tail
        (J): minus the change of E_x + E_z divided by the number of cycles; > 0 feeds it.
    threshold : float
        Amplitude below which motion counts as rest (m): the larger of the encoder's
        position resolution and 1e-7 m.
    x, z : AxisOscillation
        The verdict on each axis.
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


def _axis_oscillation(u: np.ndarray, tail_duration: float, threshold: float, texture_freqs=()) -> AxisOscillation:
    n = u.size
    t = np.arange(n, dtype=np.float64)
    u = u - np.polyval(np.polyfit(t, u, 1), t)  # steady sliding or drift is not an oscillation
    a1 = 0.5 * float(np.ptp(u[: n // 2]))
    a2 = 0.5 * float(np.ptp(u[n // 2:]))
    ratio = a2 / a1 if a1 > 0 else (math.inf if a2 > 0 else 0.0)
    spec = np.abs(np.fft.rfft((u - u.mean()) * np.hanning(n))) ** 2
    spec[0] = 0.0
    freq = float(np.argmax(spec) / tail_duration) if spec.max() > 0 else 0.0
    if not a2 > threshold:
        freq = 0.0
    osc = bool(a2 > threshold and ratio >= 0.9 and freq * tail_duration >= 3)
    driven = osc and any(abs(freq - n * ft) <= 1.5 / tail_duration for ft in texture_freqs for n in (1, 2, 3))
    return AxisOscillation(osc and not driven, a2, float(ratio), freq, bool(driven))


def _oscillation(tail: np.ndarray, tail_duration: float, e_env_tail: float, threshold: float,
                 texture_freqs=()) -> Oscillation:
    """Verdict from the tail positions ``tail`` (n, 2) [x, z] sampled evenly over ``tail_duration``
    (s); ``texture_freqs`` (Hz) are the rates at which a scan crosses the texture's periods."""
    tail = np.asarray(tail, dtype=np.float64)
    if tail.shape[0] < 8 or tail_duration <= 0:
        rest = AxisOscillation(False, 0.0, 0.0, 0.0)
        return Oscillation(False, 0.0, 0.0, 0.0, 0.0, threshold, "z", rest, rest)
    ax = {name: _axis_oscillation(tail[:, i], tail_duration, threshold, texture_freqs) for i, name in enumerate("xz")}
    key = max("zx", key=lambda k: (ax[k].oscillating, ax[k].amplitude))
    main = ax[key]
    cycles = main.frequency * tail_duration
    per_cycle = -e_env_tail / cycles if cycles > 0 else 0.0
    return Oscillation(ax["x"].oscillating or ax["z"].oscillating, main.amplitude, main.decay_ratio, main.frequency,
                       float(per_cycle), threshold, key, ax["x"], ax["z"])


@dataclass(frozen=True)
class SimulationResult:
    """Time series and energy figures of one simulation.

    Arrays have one row per recorded sample (every ``record_every`` samples), at the end
    of each sampling interval.

    Attributes
    ----------
    time : ndarray, shape (n,)
        s.
    position, velocity : ndarray, shape (n, 2)
        Handle position [x, z] (m) and velocity (m/s).
    force : ndarray, shape (n, 2)
        Force command applied over the interval ending at ``time`` (N).
    energy_x, energy_z : ndarray, shape (n,)
        Energy absorbed by the virtual environment, E_x = -sum f_x dp^x and
        E_z = -sum f_z dp^z (J), the sums of Section V-B; decreasing means the
        environment supplies energy.
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
        Verdict on the last ``tail_fraction`` of the run.
    totals : dict
        Final E_x, E_z, damping, operator work, kinetic energy and the energy dissipated by
        the device's Coulomb friction (``friction_energy``) (J).
    diverged_at : int or None
        The sample (1-based) at which a position, velocity, force or energy became
        non-finite; the run stopped there and its series end before it. None if it did not.
    diverged_quantity : str or None
        Which: ``"position"``, ``"velocity"``, ``"force"`` or ``"energy"``.
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
        W_command = -(E_x + E_z), divided by the largest of those terms in magnitude.
        Round-off only (about 1e-12) when the simulation is exact.
        """
        t = self.totals
        w_cmd = -(t["energy_x"] + t["energy_z"])
        e_fr = t.get("friction_energy", 0.0)
        err = (t["kinetic_energy"] - self.initial_kinetic_energy) - (w_cmd + t["operator_work"] - t["damping_energy"]
                                                                     - e_fr)
        scale = max(abs(w_cmd), abs(t["operator_work"]), abs(t["damping_energy"]), abs(t["kinetic_energy"]),
                    abs(self.initial_kinetic_energy), abs(e_fr), 1e-300)
        return abs(err) / scale if math.isfinite(err) else math.inf


# --------------------------------------------------------------------------------------
# public entry points
# --------------------------------------------------------------------------------------
def _prepare(algorithm, device, operator, duration, initial_position, initial_velocity):
    if not isinstance(algorithm, Algorithm):
        raise fail("algorithm", algorithm, "a haptex algorithm (haptex.algorithm(...))")
    if not isinstance(device, Device):
        raise fail("device", device, "a haptex.Device")
    if device.dimension != 2:
        raise ParameterError(f"device = {device.name!r} with dimension = {device.dimension} is not allowed here: the "
                             "simulator takes planar devices (dimension 2) for now; 3-DOF devices are analysed "
                             "(passivity_condition, max_passive_stiffness)")
    if not isinstance(operator, Operator):
        raise fail("operator", operator, "an operator from haptex.operators")
    n_steps = _n_steps(duration, device.period)
    if n_steps < 1:
        raise fail("duration", duration, f"at least one sampling period ({device.period:g} s)")
    if operator.kinematic:
        p0 = operator.setpoint_points[0].copy() if initial_position is None else _point("initial_position", initial_position)
    else:
        p0 = np.zeros(2) if initial_position is None else _point("initial_position", initial_position)
    v0 = np.zeros(2) if initial_velocity is None else _point("initial_velocity", initial_velocity)
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


def _point(name, value):
    arr = positions(value, name)
    if arr.shape != (2,):
        raise fail(name, value, "two finite numbers [x, z]")
    return arr.copy()


MAX_DAMPING_RATIO = 15.0
"""Largest (damping x sampling period / mass) the exact discretisation accepts: beyond it the
handle's velocity decays by more than e^-15 within one sample and the Van Loan energy
integrals cancel catastrophically (measured balance error: 2e-12 at 10, 2e-7 at 20, 1.0 at 40)."""


def _check_conditioning(device: Device, operator: Operator) -> None:
    """Refuse a device/operator pair whose exact discretisation is ill-conditioned."""
    minv = np.linalg.inv(device.mass)
    worst = 0.0
    for b in (device.damping, device.damping_outside):
        eig = np.linalg.eigvals(minv @ (b + operator.damping)) * device.period
        worst = max(worst, float(np.max(np.abs(eig))))
    if not worst <= MAX_DAMPING_RATIO:
        raise ParameterError(
            f"damping x period / mass = {worst:.3g} is not allowed: must be <= {MAX_DAMPING_RATIO:g} (the handle's "
            f"velocity would decay by e^-{worst:.3g} within one sample and the exact discretisation loses its "
            f"precision); use a larger mass, a smaller damping or a shorter sampling period")


def _kernel_inputs(algorithm, device, operator, memo: dict | None = None):
    """Everything the compiled loop reads for one run. ``memo`` shares the discretisation
    (six 20x20 matrix exponentials) between runs whose device and operator are the same
    objects, as in sweeps of algorithm parameters."""
    code, prm, kind, coeffs, aux = algorithm.kernel_spec()
    if device.structural_mode and operator.kinematic:
        raise ParameterError(f"operator = KinematicPath is not allowed with the structural mode of {device.name}: "
                             "a prescribed path fixes one body and leaves the mode undefined; use a hand or a band")
    T_alg = getattr(algorithm, "period", None)
    if T_alg is not None and not math.isclose(T_alg, device.period, rel_tol=1e-12):
        raise ParameterError(f"period = {T_alg:g} s of {algorithm!r} is not allowed on {device.name}: its virtual "
                             f"damper's backward difference must use the device's sampling period {device.period:g} s")
    _check_conditioning(device, operator)
    key = (id(device), id(operator))
    if memo is None or key not in memo:
        disc = _discretise(device, operator)
        if memo is not None:
            memo[key] = disc
    else:
        disc = memo[key]
    Phi, Wd, Wo = disc
    Bs = np.stack([device.damping_outside, device.damping])
    nominal = algorithm.penetration_kind == "nominal"
    return code, prm, kind, coeffs, aux, nominal, Phi, Wd, Wo, Bs


def simulate(algorithm: Algorithm, device: Device, operator: Operator, duration: float, initial_position=None,
             initial_velocity=None, record_every: int = 1, tail_fraction: float = 0.4) -> SimulationResult:
    """Simulate a device in closed loop with an algorithm, driven by an operator.

    Parameters
    ----------
    algorithm : Algorithm
        Any of W, A–G (:func:`haptex.algorithm`).
    device : Device
        The sampled-data device.
    operator : Operator
        From :mod:`haptex.operators`.
    duration : float
        Simulated time (s); rounded to whole sampling periods.
    initial_position : array_like, shape (2,), optional
        [x, z] (m); default [0, 0] (the start of the path for a KinematicPath).
    initial_velocity : array_like, shape (2,), optional
        m/s; default zero.
    record_every : int, optional
        Record one sample in this many (>= 1).
    tail_fraction : float, optional
        Fraction of the run, at its end, on which the oscillation verdict is decided.

    Returns
    -------
    SimulationResult

    Raises
    ------
    ParameterError
        For invalid inputs, or a recording that would exceed :data:`MEMORY_BUDGET`
        (2 GiB; 96 bytes a recorded sample) — record fewer samples with ``record_every``.
    """
    n_steps, p0, v0 = _prepare(algorithm, device, operator, duration, initial_position, initial_velocity)
    if isinstance(record_every, bool) or int(record_every) != record_every or record_every < 1:
        raise fail("record_every", record_every, "a whole number >= 1")
    record_every = int(record_every)
    if not 0 < tail_fraction <= 1:
        raise fail("tail_fraction", tail_fraction, "a number in (0, 1]")
    n_rec = n_steps // record_every
    if n_rec * _BYTES_PER_SAMPLE > MEMORY_BUDGET:
        raise ParameterError(
            f"duration = {duration:g} s is not allowed with record_every = {record_every}: recording "
            f"{n_rec} samples needs {n_rec * _BYTES_PER_SAMPLE / 2**30:.1f} GiB, over the 2 GiB budget; "
            f"use record_every >= {math.ceil(n_steps * _BYTES_PER_SAMPLE / MEMORY_BUDGET)}"
        )
    code, prm, kind, coeffs, aux, nominal, Phi, Wd, Wo, Bs = _kernel_inputs(algorithm, device, operator)
    rec = np.zeros((n_rec, 12))
    summary = np.zeros(N_SUMMARY)
    tail_start = int(n_steps * (1 - tail_fraction))
    tail_z = np.zeros((min(n_steps - tail_start, 65536), 2))
    _run(code, kind, coeffs, prm, aux, nominal, Phi, Wd, Wo, Bs, *_mass_inputs(device), operator.stiffness,
         operator.damping,
         operator.force, operator.setpoint_times, operator.setpoint_points, operator.final_velocity,
         operator.rest_length, operator.kinematic, n_steps, device.period, device.delay, device.position_resolution,
         device.force_resolution, device.max_force, device.coulomb_friction, p0, v0, record_every, rec, summary,
         tail_start, tail_z)
    result = _result(rec, summary, tail_z, (n_steps - tail_start) * device.period, device,
                     _texture_frequencies(algorithm, operator))
    _warn_health([result])
    return result


def _warn_health(results) -> None:
    """One SimulationWarning for runs that diverged or whose energy balance does not close."""
    div = [i for i, r in enumerate(results) if r.diverged]
    bad = [i for i, r in enumerate(results) if not r.diverged and r.energy_balance_error > BALANCE_TOLERANCE]
    if div:
        r = results[div[0]]
        where = "" if len(results) == 1 else f"run {div[0]} of {len(results)} ({len(div)} in all) "
        warnings.warn(f"the simulation {where}diverged: its {r.diverged_quantity} became non-finite at sample "
                      f"{r.diverged_at}; it stopped there", SimulationWarning, stacklevel=3)
    if bad:
        r = results[bad[0]]
        where = "" if len(results) == 1 else f"of run {bad[0]} of {len(results)} ({len(bad)} in all) "
        warnings.warn(f"the energy balance {where}closes only to {r.energy_balance_error:.2g} relative, above "
                      f"{BALANCE_TOLERANCE:g}: the discretisation is ill-conditioned for these parameters",
                      SimulationWarning, stacklevel=3)


def _texture_frequencies(algorithm, operator) -> tuple:
    """Rates (Hz) at which a constant-velocity scan crosses the texture's periods, v / l_k; empty
    for other operators and for textures without a line spectrum (measured profiles)."""
    periods = getattr(algorithm.texture, "periods", None)
    v = abs(float(operator.final_velocity[0]))
    if periods is None or operator.kinematic or operator.setpoint_times.size != 1 or v == 0.0:
        return ()
    return tuple(float(v / p) for p in np.atleast_1d(periods))


def _result(rec, summary, tail_z, tail_duration, device, texture_freqs=()) -> SimulationResult:
    diverged = int(summary[S_DIVERGED]) or None
    if diverged is not None:  # rows are written in order and their time is > 0
        rec = rec[:int(np.count_nonzero(rec[:, 0]))]
    e_env_tail = summary[S_EX] + summary[S_EZ] - summary[S_TAILSTART_E]
    osc = _oscillation(tail_z, tail_duration, e_env_tail, max(device.position_resolution, 1e-7), texture_freqs)
    totals = {"energy_x": float(summary[S_EX]), "energy_z": float(summary[S_EZ]),
              "damping_energy": float(summary[S_DAMP]), "operator_work": float(summary[S_OP]),
              "kinetic_energy": float(summary[S_KE]), "friction_energy": float(summary[S_FRIC])}
    return SimulationResult(
        time=rec[:, 0], position=rec[:, 1:3], velocity=rec[:, 3:5], force=rec[:, 5:7], energy_x=rec[:, 7],
        energy_z=rec[:, 8], damping_energy=rec[:, 9], operator_work=rec[:, 10], kinetic_energy=rec[:, 11],
        initial_kinetic_energy=float(summary[S_KE0]), saturations=int(summary[S_SAT]),
        max_penetration=float(summary[S_MAXPEN]), oscillation=osc, totals=totals, diverged_at=diverged,
        diverged_quantity=None if diverged is None else _DIVERGED_NAMES[int(summary[S_DIVERGED_WHAT])])


_ALGORITHM_KEYS = ("stiffness", "amplitude", "texture_period", "friction", "presliding", "modulation_depth",
                   "max_penetration")
_DEVICE_KEYS = ("mass", "damping", "damping_outside", "delay", "position_resolution", "force_resolution", "coulomb_friction",
                "max_force")
_OPERATOR_KEYS = ("push_x", "push_z", "band_stiffness", "anchor_x", "anchor_z", "hand_stiffness", "hand_damping",
                  "depth", "velocity")
_START_KEYS = ("initial_x", "initial_z")
SWEEP_KEYS = _ALGORITHM_KEYS + _DEVICE_KEYS + _OPERATOR_KEYS + _START_KEYS
"""Parameters :func:`simulate_batch` can sweep (SI units)."""


@dataclass(frozen=True)
class BatchResult:
    """Per-run summaries of :func:`simulate_batch`; every array has shape (N,).

    Attributes
    ----------
    parameters : dict of ndarray
        The swept values, broadcast to N runs.
    energy_x, energy_z : ndarray
        Final E_x, E_z (J).
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
        kw = {}
        if algorithm.letter in ("B", "C", "G", "F"):
            kw["max_penetration"] = values.get("max_penetration", algorithm.max_penetration)
        elif "max_penetration" in values:
            raise ParameterError(f"max_penetration is not allowed in a sweep of algorithm {algorithm.letter}")
        if algorithm.letter == "F":
            kw.update(friction=values.get("friction", algorithm.friction),
                      presliding=values.get("presliding", algorithm.presliding),
                      modulation_depth=values.get("modulation_depth", algorithm.modulation_depth),
                      stick_deflection=algorithm.stick_deflection)
        elif any(k in values for k in ("friction", "presliding", "modulation_depth")):
            raise ParameterError(f"friction parameters are not allowed in a sweep of algorithm {algorithm.letter}")
        algorithm = make(algorithm.letter, None if algorithm.letter == "W" else tex,
                         values.get("stiffness", algorithm.stiffness), **kw)
    dv = {k: values[k] for k in _DEVICE_KEYS if k in values}
    if "delay" in dv:
        dv["delay"] = whole("delay", dv["delay"], 0, 10_000, "sampling periods")
    if dv:
        device = device.replace(**dv)
    ov = {k: values[k] for k in _OPERATOR_KEYS if k in values}
    if ov:
        K, C, f = operator.stiffness.copy(), operator.damping.copy(), operator.force.copy()
        pts = operator.setpoint_points.copy()
        vend = operator.final_velocity.copy()
        if "push_x" in ov or "push_z" in ov:
            f = np.array([ov.get("push_x", f[0]), ov.get("push_z", f[1])])
        if "band_stiffness" in ov:
            K = positive("band_stiffness", ov["band_stiffness"], "N/m") * np.eye(2)
        if "hand_stiffness" in ov:
            K = positive("hand_stiffness", ov["hand_stiffness"], "N/m") * np.eye(2)
        if "hand_damping" in ov:
            C = nonnegative("hand_damping", ov["hand_damping"], "N s/m") * np.eye(2)
        if "anchor_x" in ov or "anchor_z" in ov:
            pts[0] = [ov.get("anchor_x", pts[0, 0]), ov.get("anchor_z", pts[0, 1])]
        depth = operator.depth
        if "depth" in ov:
            depth = nonnegative("depth", ov["depth"], "m")
            pts[:, 1] += operator.depth - depth
        if "velocity" in ov:
            vend = np.array([float(ov["velocity"]), 0.0])
        operator = Operator(stiffness=K, damping=C, force=f, setpoint_times=operator.setpoint_times,
                            setpoint_points=pts, final_velocity=vend, rest_length=operator.rest_length,
                            kinematic=operator.kinematic, depth=depth)
    return algorithm, device, operator


def simulate_batch(algorithm: Algorithm, device: Device, operator: Operator, duration: float, initial_position=None,
                   initial_velocity=None, record: bool = False, record_every: int = 1, tail_fraction: float = 0.4,
                   progress: bool | None = None, **sweep) -> BatchResult:
    """Run many simulations that differ in some parameters, in one parallel compiled loop.

    Parameters
    ----------
    algorithm, device, operator, duration, initial_position, initial_velocity
        As for :func:`simulate`; they give the values of everything not swept.
    record : bool, optional
        Keep every run's time series (memory: N x samples x 96 bytes, within the 2 GiB
        budget); default False, summaries only.
    record_every, tail_fraction
        As for :func:`simulate`.
    progress : bool, optional
        Show a progress bar; default: when the batch has more than 5e7 samples in all.
    **sweep : array_like, shape (N,) or scalar
        Parameters to vary, each broadcast to N runs; names from :data:`SWEEP_KEYS`:
        algorithm ``stiffness``, ``amplitude``, ``texture_period``, ``friction``,
        ``presliding``, ``modulation_depth``, ``max_penetration``; device ``mass``,
        ``damping``, ``damping_outside``, ``delay``, ``position_resolution``,
        ``force_resolution``, ``coulomb_friction``, ``max_force``; operator ``push_x``, ``push_z``,
        ``band_stiffness``, ``anchor_x``, ``anchor_z``, ``hand_stiffness``,
        ``hand_damping``, ``depth``, ``velocity``; and ``initial_x``, ``initial_z``.

    Returns
    -------
    BatchResult

    Raises
    ------
    ParameterError
        For an unknown sweep name, arrays that do not broadcast, or any invalid value
        (checked for every run before anything runs).
    """
    unknown = sorted(set(sweep) - set(SWEEP_KEYS))
    if unknown:
        raise ParameterError(f"sweep parameters {unknown} are not allowed: choose from {', '.join(SWEEP_KEYS)}")
    n_steps, p0, v0 = _prepare(algorithm, device, operator, duration, initial_position, initial_velocity)
    try:
        arrays = np.broadcast_arrays(*[np.atleast_1d(np.asarray(v, dtype=np.float64)) for v in sweep.values()]) if sweep else []
    except ValueError:
        raise ParameterError("the sweep arrays are not allowed: their shapes do not broadcast to one length N") from None
    values = {k: a.ravel() for k, a in zip(sweep, arrays)}
    N = len(next(iter(values.values()))) if values else 1
    for k, a in values.items():
        if not np.all(np.isfinite(a)):
            raise fail(k, a.tolist(), "finite values")
    n_rec = n_steps // int(record_every) if record else 0
    if N * n_rec * _BYTES_PER_SAMPLE > MEMORY_BUDGET:
        raise ParameterError(f"record = True is not allowed here: {N} runs x {n_rec} samples need more than the 2 GiB budget")
    runs = [_rebuild(algorithm, device, operator, {k: float(a[i]) for k, a in values.items()}) for i in range(N)]
    letters = {a.letter for a, _, _ in runs}
    shapes = {a.kernel_spec()[3].shape for a, _, _ in runs}
    periods = {d.period for _, d, _ in runs}
    if len(letters) != 1 or len(shapes) != 1 or len(periods) != 1:
        raise ParameterError("the runs of a batch must share the algorithm letter, texture shape and sampling period")
    memo: dict = {}
    specs = [_kernel_inputs(a, d, o, memo) for a, d, o in runs]
    code, kind, nominal = specs[0][0], specs[0][2], specs[0][5]
    st = lambda j: np.ascontiguousarray(np.stack([s[j] for s in specs]))  # noqa: E731
    prm, coeffs, Phi, Wd, Wo, Bs = st(1), st(3), st(6), st(7), st(8), st(9)
    n_aux = max(s[4].size for s in specs)  # bound trees of different sizes: pad (the header says the size)
    aux = np.zeros((N, n_aux))
    for i, s in enumerate(specs):
        aux[i, :s[4].size] = s[4]
    dev = [d for _, d, _ in runs]
    ops = [o for _, _, o in runs]
    if len({d.structural_mode for d in dev}) != 1:
        raise ParameterError("the runs of a batch must all have a structural mode or all be rigid")
    M = np.stack([_mass_inputs(d)[0] for d in dev])
    modal = np.stack([_mass_inputs(d)[1] for d in dev])
    K = np.stack([o.stiffness for o in ops])
    C = np.stack([o.damping for o in ops])
    f0 = np.stack([o.force for o in ops])
    sp_p = np.stack([o.setpoint_points for o in ops])
    vend = np.stack([o.final_velocity for o in ops])
    rest = np.array([o.rest_length for o in ops])
    delay = np.array([d.delay for d in dev], dtype=np.int64)
    delta = np.array([d.position_resolution for d in dev])
    fres = np.array([d.force_resolution for d in dev])
    fmax = np.array([d.max_force for d in dev])
    fc = np.array([d.coulomb_friction for d in dev])
    P0 = np.tile(p0, (N, 1))
    if "initial_x" in values:
        P0[:, 0] = values["initial_x"]
    if "initial_z" in values:
        P0[:, 1] = values["initial_z"]
    V0 = np.tile(v0, (N, 1))
    rec = np.zeros((N, n_rec, 12))
    summary = np.zeros((N, N_SUMMARY))
    tail_start = int(n_steps * (1 - tail_fraction))
    tail_z = np.zeros((N, min(n_steps - tail_start, 8192), 2))
    T = dev[0].period
    # (value, True if it has one row per run)
    args = [(code, False), (kind, False), (coeffs, True), (prm, True), (aux, True), (nominal, False), (Phi, True), (Wd, True),
            (Wo, True), (Bs, True), (M, True), (modal, True), (K, True), (C, True), (f0, True),
            (ops[0].setpoint_times, False),
            (sp_p, True), (vend, True), (rest, True), (ops[0].kinematic, False), (n_steps, False), (T, False),
            (delay, True), (delta, True), (fres, True), (fmax, True), (fc, True), (P0, True), (V0, True),
            (int(record_every), False), (rec, True), (summary, True), (tail_start, False), (tail_z, True)]
    show = (N * n_steps > 5e7) if progress is None else bool(progress)
    bar = _progress(show, N)
    for idx in np.array_split(np.arange(N), min(N, 20) if show else 1):
        if idx.size:
            lo, hi = idx[0], idx[-1] + 1
            _run_batch(*[a[lo:hi] if per_run else a for a, per_run in args])
            bar(idx.size)
    bar(None)
    results = [_result(rec[i], summary[i], tail_z[i], (n_steps - tail_start) * T, dev[i],
                       _texture_frequencies(a, o)) for i, (a, _, o) in enumerate(runs)]
    _warn_health(results)
    col = lambda f: np.array([f(r) for r in results])  # noqa: E731
    return BatchResult(
        parameters=values,
        energy_x=summary[:, S_EX].copy(), energy_z=summary[:, S_EZ].copy(), damping_energy=summary[:, S_DAMP].copy(),
        operator_work=summary[:, S_OP].copy(), kinetic_energy=summary[:, S_KE].copy(),
        energy_balance_error=col(lambda r: r.energy_balance_error), oscillating=col(lambda r: r.oscillating),
        amplitude=col(lambda r: r.oscillation.amplitude), frequency=col(lambda r: r.oscillation.frequency),
        energy_per_cycle=col(lambda r: r.oscillation.energy_per_cycle),
        max_penetration=summary[:, S_MAXPEN].copy(), saturations=summary[:, S_SAT].astype(np.int64),
        diverged_at=summary[:, S_DIVERGED].astype(np.int64), runs=results if record else None)


def _progress(show: bool, total: int):
    """A rich progress bar advanced by the returned callable; ``None`` closes it."""
    if not show:
        return lambda n: None
    from rich.progress import Progress

    prog = Progress(transient=True)
    prog.start()
    task = prog.add_task("simulating", total=total)

    def advance(n):
        if n is None:
            prog.stop()
        else:
            prog.advance(task, n)

    return advance
