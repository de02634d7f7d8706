"""A virtual wall's stiffness limits on a device, all of them side by side.

Passivity (the wall supplies no energy to any operator) and stability (the closed loop
with a given operator does not oscillate or diverge) are different questions with
different answers. A passive wall is stable with every passive operator; a stable wall
need not be passive. Diolaiti, Niemeyer, Barbagli & Salisbury ("Stability of haptic
rendering: discretization, quantization, time delay, and Coulomb effects", IEEE Trans.
Robotics 22(2), 2006) show the region between: stiffnesses above the passivity bound at
which the device with its hand is still stable, because the hand's damping and the
device's Coulomb friction dissipate what the sampled wall generates. There the verdict
holds for the hand it was computed with only: a lighter grip, a longer delay or a
different operator can turn it into a limit cycle.

Every limit is along the wall's normal (the device's last axis), with the apparent mass
m = 1 / (M^-1)_zz (the other axes free) and the damping b = B_zz inside the wall.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ._validation import fail, nonnegative, numbers, positive
from .catalogue import DEFAULT_HAND, Hand, Preset, checked_device, hand as _hand
from .devices import Device, critical_stiffness
from .algorithms import checked_algorithm

DIOLAITI_NOTE = ("between the passive and the stable limit the wall is stable with this hand but not passive "
                 "(Diolaiti et al., IEEE Trans. Robotics 22(2), 2006): the hand's damping and the device's friction "
                 "absorb what the sampled wall generates; a lighter grip, a longer delay or another operator can "
                 "turn it into a limit cycle")


@dataclass(frozen=True)
class WallLimit:
    """One limit on a virtual wall's stiffness.

    Parameters
    ----------
    key : str
        ``corollary_1``, ``colgate_schenkel``, ``abbott_okamura``, ``encoder``, ``gil``,
        ``device``, ``hand``, ``rigid``, ``rated`` or ``simulated``.
    kind : str
        ``passive`` (sufficient for passivity), ``stable`` (the closed loop's boundary)
        or ``rated`` (the manufacturer's figure, reported only).
    value : float or None
        The largest stiffness (N/m); None where the limit does not apply (its reason in
        ``assumes``).
    name : str
        What it is, in a few words.
    formula : str
        The condition, in the notation of its source.
    source : str
        Where it comes from.
    assumes : str
        What it takes for granted.
    """

    key: str
    kind: str
    value: float | None
    name: str
    formula: str
    source: str
    assumes: str

    def as_dict(self) -> dict:
        return {"key": self.key, "kind": self.kind, "value": self.value, "unit": "N/m", "name": self.name,
                "formula": self.formula, "source": self.source, "assumes": self.assumes}


@dataclass(frozen=True)
class WallLimits:
    """Every limit of :func:`wall_limits`, and the two that answer the user.

    Parameters
    ----------
    limits : list of WallLimit
    passive : float
        ``passive_stiffness`` (N/m): the largest passive stiffness of a linear wall:
        Abbott & Okamura's necessary and sufficient condition with the device's Coulomb
        friction and quantisation, Colgate & Schenkel's with exact positions.
    stable : float
        ``stable_stiffness`` (N/m): the exact boundary of the sampled closed loop with the
        hand (with the device alone for the hand ``none``); with ``simulated``, the smaller
        of that and the simulated limit (quantisation without friction can lower it).
    hand : Hand
    rated_ratio : float or None
        The exact stable limit with the hand (the ``hand`` row) over the preset's rated
        figure (None without one).
    rated_hand_damping : float or None
        The hand damping (N s/m) at which the rated figure is the exact stable limit
        (:func:`rated_hand_damping`), the hand's mass and stiffness kept (the default hand's
        for the hand ``none``).
    """

    limits: list
    passive: float
    stable: float
    hand: Hand
    rated_ratio: float | None = None
    rated_hand_damping: float | None = None

    def __getitem__(self, key: str) -> WallLimit:
        for lim in self.limits:
            if lim.key == key:
                return lim
        raise KeyError(key)

    def as_dict(self) -> dict:
        return {"passive_stiffness": self.passive, "stable_stiffness": self.stable, "hand": self.hand.key,
                "rated_ratio": self.rated_ratio, "rated_hand_damping": self.rated_hand_damping,
                "limits": [lim.as_dict() for lim in self.limits], "note": DIOLAITI_NOTE,
                "units": {"passive_stiffness": "N/m", "stable_stiffness": "N/m", "rated_hand_damping": "N*s/m"}}


def normal_axis(device: Device) -> tuple[float, float, float | None]:
    """(m, b, m_handle): the apparent mass (kg), damping (N s/m) and handle-side mass of
    the structural mode (kg, or None) along the wall's normal, the other axes free.

    Parameters
    ----------
    device : Device
        The device; the wall's normal is its last axis (z).

    Returns
    -------
    tuple of (float, float, float or None)
        (m (kg), b (N s/m), m_handle (kg) or None).
    """
    device = checked_device(device)
    m = 1.0 / float(np.linalg.inv(device.mass)[-1, -1])
    b = float(device.damping[-1, -1])
    mh = None if device.handle_mass is None else 1.0 / float(np.linalg.inv(device.handle_mass)[-1, -1])
    return m, b, mh


def wall_limits(device: Device, hand=DEFAULT_HAND, virtual_damping: float = 0.0,
                preset: Preset | None = None, simulated: bool = False) -> WallLimits:
    """The limits on a virtual wall's stiffness (N/m) on a device, side by side.

    Parameters
    ----------
    device : Device
        Any device; the wall's normal is its last axis.
    hand : str or Hand, optional
        The hand gripping the handle (:func:`haptex.catalogue.hands`); default
        :data:`~haptex.catalogue.DEFAULT_HAND`. ``"none"``: the device alone.
    virtual_damping : float, optional
        B_v (N s/m), the wall's damper: it costs passivity (Colgate & Schenkel) and buys
        stability (Gil et al.).
    preset : Preset, optional
        The device's preset, whose rated stiffness is reported beside (never used).
    simulated : bool, optional
        Also ``simulated``: the wall simulated with the hand, nonlinear effects included
        (:func:`simulated_wall_limit`; a fraction of a second).

    Returns
    -------
    WallLimits
        With, in order: ``corollary_1`` sigma_0(B) / (2T) (the paper's eq. (1), for any
        texture field: passive); ``colgate_schenkel`` 2 (b - B_v) / T (passive, linear
        wall; Colgate & Schenkel, "Passivity of a class of sampled-data systems: application
        to haptic interfaces", J. Robotic Systems 14(1), 1997); ``abbott_okamura`` the
        smaller of that and 2 f_c / delta with Coulomb friction f_c and position
        quantisation delta (J. J. Abbott and A. M. Okamura, "Effects of position
        quantization and sampling rate on virtual-wall passivity", IEEE Trans. Robotics
        21(5), 2005: necessary and sufficient, its two conditions the two ways the wall
        turns active, instability and active tactile sensations; 0 with quantisation and
        no friction, None with exact positions); ``encoder`` 2 f_c / delta alone (with
        quantisation: what the encoder step and the friction set, the viscous damping apart);
        ``gil`` (b + B_v) / (T (1/2 + d)) (stable, the device alone, its mass large against
        bT; J. J. Gil, A. Avello, A. Rubio and J. Florez, "Stability analysis of a 1 DOF
        haptic interface using the Routh-Hurwitz criterion", IEEE Trans. Control Systems
        Technology 12(4), 2004); ``device`` the exact boundary of the sampled loop, the
        device alone (:func:`~haptex.critical_stiffness`: ZOH, delay, virtual damper,
        structural mode); ``hand`` the same with the hand; ``rigid`` the same without the
        structural mode (a device with one: what the mode changes); ``rated`` the
        manufacturer's figure when ``preset`` has one, with the prediction's ratio to it and
        the hand damping it implies (:func:`rated_hand_damping`) in its ``assumes``.

    Raises
    ------
    ParameterError
        For an unknown hand or a negative virtual damping.
    """
    device = checked_device(device)
    h = _hand(hand)
    bv = nonnegative("virtual_damping", virtual_damping, "N s/m")
    m, b, mh = normal_axis(device)
    T, d = device.period, device.delay
    fc, delta = device.coulomb_friction, device.position_resolution
    mode = {}
    if device.structural_mode:
        mode = {"handle_mass": mh, "first_resonance": device.first_resonance,
                "mode_damping_ratio": device.mode_damping_ratio}
    delay_note = "" if d == 0 else f"; derived without computation delay (the device has {d})"
    cs = max(0.0, 2 * (b - bv) / T)
    limits = [
        WallLimit("corollary_1", "passive", device.passivity_limit, "passive, any texture field (Corollary 1)",
                  "||J_f||_2 <= sigma_0(B) / (2T)", "Campion & Hayward, eq. (1)",
                  "viscous damping only; every direction of the damping matrix" + delay_note),
        WallLimit("colgate_schenkel", "passive", cs, "passive, linear wall (viscous damping)",
                  "b > K T / 2 + |B_v|", "Colgate & Schenkel 1997", "viscous damping only" + delay_note),
    ]
    if delta > 0:
        ao = min(cs, 2 * fc / delta)
        why = (f"Coulomb friction {fc:g} N and quantisation {delta:g} m; necessary and sufficient for the 1-DOF "
               "wall" + delay_note)
        if fc == 0:
            why = f"quantisation {delta:g} m without Coulomb friction: no stiffness is passive" + delay_note
    else:
        ao, why = None, "not applicable: exact positions (no quantisation), Colgate & Schenkel's condition holds"
    limits.append(WallLimit("abbott_okamura", "passive", ao, "passive, linear wall (friction and quantisation)",
                            "b > K T / 2 + |B_v| and K <= 2 f_c / delta", "Abbott & Okamura 2005", why))
    if delta > 0:
        limits.append(WallLimit("encoder", "passive", 2 * fc / delta, "passive against the encoder step (friction)",
                                "K <= 2 f_c / delta", "Abbott & Okamura 2005",
                                f"the energy a {delta * 1e6:.3g} um encoder step supplies dissipated by {fc:g} N of "
                                "Coulomb friction; the second half of the row above, the device's own (viscous "
                                "damping and hand apart)"))
    limits.append(WallLimit("gil", "stable", (b + bv) / (T * (0.5 + d)), "stable, device alone (closed form)",
                            "K < (b + B_v) / (T/2 + t_d)", "Gil et al. 2004",
                            "rigid device, mass large against b T; no hand"))
    alone = critical_stiffness(m, b, T, d, virtual_damping=bv, **mode)
    limits.append(WallLimit("device", "stable", alone, "stable, device alone (exact)",
                            "largest closed-loop eigenvalue modulus < 1", "haptex.critical_stiffness (ZOH, delay)",
                            f"apparent mass {m:.4g} kg, damping {b:.4g} N s/m along the normal; no hand, "
                            "no friction or quantisation (linear)"))
    with_hand = alone if h.none else critical_stiffness(m, b, T, d, virtual_damping=bv, hand=h.impedance, **mode)
    limits.append(WallLimit("hand", "stable", with_hand, f"stable, with the hand {h.key!r} (exact)",
                            "largest closed-loop eigenvalue modulus < 1", "haptex.critical_stiffness (ZOH, delay, hand)",
                            f"hand {h.mass:g} kg, {h.damping:g} N s/m, {h.stiffness:g} N/m gripping the handle; linear"))
    if mode:
        rigid = critical_stiffness(m, b, T, d, virtual_damping=bv, hand=None if h.none else h.impedance)
        limits.append(WallLimit("rigid", "stable", rigid, f"stable, with the hand {h.key!r}, the device rigid",
                                "largest closed-loop eigenvalue modulus < 1",
                                "haptex.critical_stiffness (ZOH, delay, hand)",
                                f"the structural mode at {device.first_resonance:g} Hz left out: the row above against "
                                "this one is what the mode changes (Gil, Puerto, Diaz & Sanchez, IROS 2010)"))
    ratio = implied = None
    if preset is not None and preset.rated_stiffness is not None:
        fig = preset.figures.get("rated_stiffness") or preset.figures["chai3d_stiffness"]
        rated = preset.rated_stiffness
        ratio = with_hand / rated
        grip = _hand(DEFAULT_HAND) if h.none else h
        implied = rated_hand_damping(m, b, T, d, rated, grip, virtual_damping=bv, **mode)
        said = (f"{fig.note or 'as published'}; the hand {h.key!r} predicts {ratio:.2g} times the figure; the "
                f"figure is the exact limit with the hand {grip.key!r} at a damping of "
                + ("any (the device alone reaches it)" if implied == 0 else
                   "none up to 1000 N s/m" if implied is None else f"{implied:.2g} N s/m"))
        if preset.rated_gap:
            said += f"; {preset.rated_gap}"
        limits.append(WallLimit("rated", "rated", rated, "the manufacturer's figure (reported only)",
                                "-", fig.as_dict()["source"] or "", said))
    stable = with_hand
    if simulated and not h.none:
        k, step = simulated_wall_limit(device, h, with_hand, virtual_damping)
        stable = min(stable, k)
        limits.append(WallLimit("simulated", "stable", k, f"stable, with the hand {h.key!r} (simulated)",
                                "no limit cycle, growth or divergence",
                                "haptex.simulate_batch (the C simulator)",
                                f"the hand pressing with {SIM_PUSH:g} N for {SIM_DURATION:g} s; Coulomb friction, "
                                f"quantisation, saturation and delay included; a grid {step:.3g} times apart"))
    passive = cs if ao is None else ao
    return WallLimits(limits, passive, stable, h, ratio, implied)


RATED_RATIO = 2.0
"""The factor within which a predicted wall limit should meet a preset's rated figure
(issue 55's goal); a preset outside it says why (``Preset.rated_gap``)."""
MAX_HAND_DAMPING = 1e3
"""The largest hand damping :func:`rated_hand_damping` searches (N s/m, chosen: about 150
times the firm grip's)."""


def rated_hand_damping(mass: float, damping: float, period: float, delay: int, rated: float, hand=DEFAULT_HAND,
                       virtual_damping: float = 0.0, **mode) -> float | None:
    """The hand damping at which a rated stiffness is the exact stable limit: the hand a
    manufacturer's figure implies.

    Manufacturers publish a stiffness without the hand it assumes. Keeping ``hand``'s mass
    and stiffness, this is the damping b_h (N s/m) for which the exact boundary of the
    sampled loop (:func:`~haptex.critical_stiffness`, ZOH, delay, structural mode) equals
    ``rated``: the figure read as a grip.

    Parameters
    ----------
    mass, damping : float
        The device's apparent mass (kg) and viscous damping (N s/m) along the wall's normal.
    period : float
        T (s).
    delay : int
        Whole samples of latency.
    rated : float
        The rated stiffness (N/m), > 0.
    hand : str or Hand, optional
        The grip whose mass and stiffness are kept; default
        :data:`~haptex.catalogue.DEFAULT_HAND`.
    virtual_damping : float, optional
        B_v (N s/m), the wall's damper.
    **mode
        ``handle_mass``, ``first_resonance``, ``mode_damping_ratio`` of a structural mode.

    Returns
    -------
    float or None
        b_h (N s/m); 0.0 when the device with the hand's mass and stiffness alone reaches
        ``rated``; None when no damping up to :data:`MAX_HAND_DAMPING` does.

    Raises
    ------
    ParameterError
        For a rated stiffness that is not positive, or an unknown hand.
    """
    from scipy.optimize import brentq

    positive("rated", rated, "N/m")
    h = _hand(hand)

    def gap(bh: float) -> float:
        k = critical_stiffness(mass, damping, period, delay, virtual_damping=virtual_damping,
                               hand=(h.mass, bh, h.stiffness), **mode)
        return math.log(k / rated) if k > 0 else -math.inf

    if gap(0.0) >= 0:
        return 0.0
    if gap(MAX_HAND_DAMPING) < 0:
        return None
    return float(brentq(gap, 0.0, MAX_HAND_DAMPING, xtol=1e-6, rtol=1e-6))


SIM_PUSH = 1.0
"""The force the hand presses with in :func:`simulated_wall_limit` (N, chosen: a typical
exploring force); its set-point is SIM_PUSH / k_h below the wall."""
SIM_DURATION = 1.0
"""Length of each run of :func:`simulated_wall_limit` (s, chosen)."""
SIM_GRID = 41
"""Stiffnesses of :func:`simulated_wall_limit`'s grid, from a quarter to four times the guess."""


def simulated_wall_limit(device: Device, hand, guess: float, virtual_damping: float = 0.0) -> tuple[float, float]:
    """The smallest stiffness (N/m) at which a virtual wall held by a hand is unstable in the
    simulator, nonlinear effects included (Coulomb friction, quantisation, saturation, delay,
    the structural mode), and the grid's ratio.

    W (with the virtual damper ``virtual_damping``) on ``device`` with the hand's mass
    attached, its spring and damper pressing with :data:`SIM_PUSH`, for
    :data:`SIM_DURATION` s from rest at the surface, over :data:`SIM_GRID` stiffnesses
    spaced geometrically from guess / 4 to 4 guess; a run is unstable when its regime is a
    limit cycle, growth or divergence (:data:`haptex.simulate.UNSTABLE`).

    Parameters
    ----------
    device : Device
        The device.
    hand : Hand
        The hand holding it (:func:`haptex.catalogue.hand`).
    guess : float
        A stiffness (N/m) near the limit (the analytic one): the grid spans guess / 4 to 4 guess.
    virtual_damping : float, optional
        W's virtual damper (N s/m).

    Returns
    -------
    (float, float)
        The stiffness (N/m; inf when none on the grid is unstable) and the ratio between
        neighbouring stiffnesses of the grid.
    """
    device = checked_device(device)
    from .algorithms import algorithm
    from .catalogue import hand as _hand
    from .simulate import UNSTABLE, simulate_batch
    from .textures import Flat

    h = _hand(hand)
    dev = h.attach(device)
    d = dev.dimension
    ks = np.geomspace(0.25 * guess, 4.0 * guess, SIM_GRID)
    alg = algorithm("W", Flat(dimension=2) if d == 3 else None, float(ks[0]), damping=virtual_damping,
                    period=dev.period)
    res = simulate_batch(alg, dev, h.operator(depth=SIM_PUSH / h.stiffness, dimension=d), SIM_DURATION,
                         initial_position=np.zeros(d), stiffness=ks)
    bad = np.flatnonzero(np.isin(res.regime, list(UNSTABLE)))
    return (float(ks[bad[0]]) if bad.size else math.inf), float(ks[1] / ks[0])


def stiffness_at(limit: float, q: float) -> float:
    """The largest nominal stiffness kappa_0 (N/m) a texture with characteristic number q
    renders within a wall limit (N/m): limit / q (the paper's gain limit, Section II-B);
    0 for an infinite q.

    Parameters
    ----------
    limit : float
        The wall limit (N/m).
    q : float
        The texture's characteristic number (>= 1, or inf).

    Returns
    -------
    float
        limit / q (N/m); 0 for an infinite q.
    """
    if math.isinf(q):
        return 0.0
    return math.inf if q <= 0 else limit / q


def clean_stiffness(algorithm, device, operator, rates, stiffness, duration: float = 2.0,
                    initial_position=None) -> list:
    """The largest stiffness a rendering can have without buzz, at each update rate.

    The question Choi & Tan asked of their users ("Perceived instability of virtual haptic
    texture", Presence 13(4), 2004, and its sequels): how stiff a texture can be before it buzzes,
    and how that limit moves with the servo rate. Here the hand is a model and the verdict is
    :func:`haptex.perception.buzz` on the exact sampled-data simulation: for each rate the device's period is
    1 / rate (everything else kept), and each candidate stiffness is simulated for ``duration``.
    A run that diverges counts as buzzing.

    Parameters
    ----------
    algorithm : Algorithm
        The rendering; each candidate stiffness replaces its kappa_0 (a
        :func:`haptex.simulate_batch` sweep, every sample recorded).
    device : Device
        With the hand's mass attached where a hand holds it (:meth:`haptex.catalogue.Hand.attach`).
    operator : Operator
        The hand's action (a :class:`haptex.operators.ScanningHand` for a stroke).
    rates : sequence of float
        Servo rates (Hz), > 0.
    stiffness : sequence of float
        Candidate stiffnesses kappa_0 (N/m), > 0, ascending.
    duration : float, optional
        s, > 0; the verdict reads the second half of each run.
    initial_position : array_like, optional
        As :func:`haptex.simulate`.

    Returns
    -------
    list of dict
        Per rate: ``rate`` (Hz), ``clean`` (the largest candidate below the first that buzzes,
        N/m; None when the smallest buzzes), ``buzzing`` (the first that buzzes, or None),
        ``margin_db`` (list, one per candidate) and ``frequency`` (Hz, list).

    Raises
    ------
    ParameterError
        For a rate or stiffness not finite and > 0, candidates not ascending, or what
        :func:`haptex.simulate` refuses.
    """
    algorithm = checked_algorithm(algorithm)
    device = checked_device(device)
    from .simulate import simulate_batch

    ks = numbers("stiffness", stiffness, "finite stiffnesses > 0 (N/m), ascending")
    if ks.ndim != 1 or ks.size == 0 or not np.all(np.isfinite(ks) & (ks > 0)) or np.any(np.diff(ks) <= 0):
        raise fail("stiffness", ks.tolist() if ks.size < 8 else "an array", "finite stiffnesses > 0 (N/m), ascending")
    out = []
    for rate in np.atleast_1d(numbers("rate", rates, "servo rates > 0 (Hz)")):
        rate = positive("rate", float(rate), "Hz")
        dev = device.replace(period=1.0 / rate)
        batch = simulate_batch(algorithm, dev, operator, duration, initial_position=initial_position, stiffness=ks,
                               record=True, record_every=1, progress=False)
        margins, freqs = [], []
        for res in batch.runs:
            b = res.buzz
            margins.append(float("inf") if b is None else b.margin_db)
            freqs.append(0.0 if b is None else b.frequency)
        loud = [i for i, m in enumerate(margins) if m > 0]
        first = loud[0] if loud else None
        clean = None if first == 0 else float(ks[(ks.size if first is None else first) - 1])
        out.append({"rate": rate, "clean": clean, "buzzing": None if first is None else float(ks[first]),
                    "margin_db": margins, "frequency": freqs})
    return out


# --------------------------------------------------------------------------------------
# the wall limit found on the device
# --------------------------------------------------------------------------------------
FIND_RATIO = 1.1
"""Ratio between neighbouring stiffnesses of :func:`find_limit`'s ladder (chosen: the limit is
then bracketed within 10 %)."""
FIND_STEP = 0.5
"""Seconds each stiffness of :func:`find_limit` is held (chosen: the verdict reads its last
:data:`haptex.servo.TAIL_FRACTION`, 0.2 s, 200 ticks at 1 kHz: three cycles down to 15 Hz)."""
FIND_SPAN = 4.0
"""By default :func:`find_limit` climbs from the predicted stable limit over this factor to
that limit times it (chosen, as :func:`simulated_wall_limit`'s grid)."""


@dataclass(frozen=True)
class LimitSearch:
    """What :func:`find_limit` found on a device.

    Parameters
    ----------
    clean : float or None
        The largest stiffness (N/m) held without oscillating: the step before the first that
        oscillated, or the ladder's last; None when the first step oscillated.
    oscillating : float or None
        The first stiffness (N/m) whose step oscillated (the run stopped there); None when
        none did.
    reason : str
        Why the run ended: ``oscillation``, ``ladder end`` (no step oscillated),
        ``interrupted`` (Ctrl-C) or ``not engaged`` (the forces never engaged: nothing rested
        on the wall).
    steps : list of dict
        One per step held: ``stiffness`` (N/m), ``start`` (s), ``regime``, ``oscillating``,
        ``amplitude`` (m), ``frequency`` (Hz), ``buzz_db`` (dB above the hand's detection
        threshold, None when nothing above the encoder's floor moved), ``buzz_frequency``
        (Hz).
    stopped_at : float or None
        The time the run was stopped at (s), None at the ladder's end.
    stats : haptex.servo.ServoStats
        The run's counts (zero force sent at its end, as on every exit).
    trace : dict
        ``time``, ``position``, ``force``, ``engaged`` per tick (:meth:`haptex.servo.ServoLoop.run`).
    """

    clean: float | None
    oscillating: float | None
    reason: str
    steps: list
    stopped_at: float | None
    stats: object
    trace: dict

    def as_dict(self) -> dict:
        """The search as JSON-ready data, with a ``units`` table (``haptex run --find-limit --json``).

        Returns
        -------
        dict
            The search's steps and verdicts, with a ``units`` table.
        """
        return {"clean_stiffness": self.clean, "oscillating_stiffness": self.oscillating, "reason": self.reason,
                "stopped_at": self.stopped_at, "steps": self.steps,
                "units": {"clean_stiffness": "N/m", "oscillating_stiffness": "N/m", "stopped_at": "s",
                          "stiffness": "N/m", "start": "s", "amplitude": "m", "frequency": "Hz",
                          "buzz_db": "dB above the detection threshold", "buzz_frequency": "Hz"}}


def stiffness_ladder(start: float, stop: float, ratio: float = FIND_RATIO) -> np.ndarray:
    """The stiffnesses :func:`find_limit` climbs: start, start r, start r^2, ... up to stop (N/m).

    Parameters
    ----------
    start, stop : float
        The first stiffness and the largest allowed (N/m), finite and > 0.
    ratio : float, optional
        r, between neighbouring steps, in (1, 2]; default :data:`FIND_RATIO`.

    Returns
    -------
    ndarray, shape (n,)
        N/m, ascending, the last at most ``stop``.

    Raises
    ------
    ParameterError
        For a start or stop not finite and > 0, a stop below the start, a ratio not in
        (1, 2], or more than 200 steps.
    """
    k0 = positive("start", start, "N/m")
    k1 = positive("stop", stop, "N/m")
    r = positive("ratio", ratio)
    if not 1.0 < r <= 2.0:
        raise fail("ratio", r, "in (1, 2]: the bracket a step leaves around the limit")
    if k1 < k0:
        raise fail("stop", f"{k1:g} N/m", f"at least the start, {k0:g} N/m")
    n = int(math.floor(math.log(k1 / k0) / math.log(r) + 1e-9)) + 1
    if n > 200:
        raise fail("ratio", r, f"a ladder of at most 200 steps from {k0:g} to {k1:g} N/m (this one has {n}): "
                   "a larger ratio or a narrower span")
    return k0 * r ** np.arange(n)


def find_limit(backend, start: float, stop: float, ratio: float = FIND_RATIO, step_duration: float = FIND_STEP,
               max_force: float | None = None, native: bool = True, on_step=None) -> LimitSearch:
    """Find the stiffest virtual wall a device holds without oscillating, on the device.

    A smooth wall W (z < 0 inside) is rendered while the user rests the handle on it; its
    stiffness rises in steps (:func:`stiffness_ladder`), each held ``step_duration`` s and
    handed to the running tick between ticks (:meth:`haptex.Renderer.set_stiffness`).
    Each step is judged on its last :data:`haptex.servo.TAIL_FRACTION` by the detectors of
    :func:`haptex.servo.analyse_trace` (the handle's motion with the encoder's staircase
    removed): at the first step whose regime is a limit cycle, growth or divergence the run
    is stopped, the force zero from the next tick (the servo's rule 5), and the step before
    it is the answer. Every step's buzz is reported beside. The servo's safety rules hold
    throughout (engagement, the maximum force, the watchdog, zero force on every exit). The
    steps start once the forces are engaged and ramped in.

    The question every user of a new device asks ("how stiff can my wall be"), answered as
    they answer it by hand, raising the stiffness until it buzzes, but with the verdict
    measured and the force cut within a tick. The result holds for the grip the user had:
    the hand is part of the loop (:func:`wall_limits`, Diolaiti et al. 2006).

    Parameters
    ----------
    backend : DeviceBackend
        Not yet opened (:func:`haptex.backends.open_backend`); the run opens and closes it.
    start, stop : float
        The ladder's first and largest stiffness (N/m); no stiffness above ``stop`` is ever
        sent.
    ratio : float, optional
        Between neighbouring steps, in (1, 2]; default :data:`FIND_RATIO`.
    step_duration : float, optional
        s a step is held, at least 0.1 s; default :data:`FIND_STEP`.
    max_force : float, optional
        N, at most the device's; default the device's.
    native : bool, optional
        Run the native servo thread where the backend has one (default; the steps then change
        on the first check after their time, about every 50 ms, and each step's start is the
        tick that took it); False runs the Python loop, whose steps change at their tick.
    on_step : callable, optional
        Called as ``on_step(step)`` with each step's dict as it is judged (a progress display).

    Returns
    -------
    LimitSearch

    Raises
    ------
    ParameterError
        For a ladder or durations out of range (:func:`stiffness_ladder`).
    DeviceError
        If the device stops answering (zero force sent first).
    """
    from .algorithms import algorithm
    from .renderer import Renderer
    from .servo import ServoLoop, analyse_trace
    from .textures import Flat

    ladder = stiffness_ladder(start, stop, ratio)
    tau = positive("step_duration", step_duration, "s")
    if tau < 0.1:
        raise fail("step_duration", f"{tau:g} s", "at least 0.1 s: a step's verdict needs cycles to read")
    d, T = backend.dimension, backend.period
    n_step = int(round(tau / T))
    alg = algorithm("W", Flat(dimension=2) if d == 3 else None, float(ladder[0]))
    renderer = Renderer(alg, max_force=max_force)
    # engaged on the first tick outside the wall (the user starts with the handle lifted; inside
    # it, the servo's rule 3 still waits), then ramped in as ever; the native thread only where
    # the clock paces it (run as fast as it goes, its ticks would outrun the steps' checks)
    native = native and bool(getattr(backend, "realtime", True))
    loop = ServoLoop(backend, renderer, max_force=max_force, native=native, engage_ticks=1)
    resolution = float(getattr(backend.device, "position_resolution", 0.0) or 0.0)
    state = {"i": 0, "from": None, "reason": None, "oscillating": None, "stopped": None}
    steps: list = []

    def watch(k, servo):
        if state["reason"] is not None or servo.engaged_at is None:
            return
        if state["from"] is None:  # the first step: once the forces are ramped in
            state["from"] = servo.engaged_at + loop.ramp_ticks
        lo = state["from"]
        if k + 1 - lo < n_step:
            return
        window = {name: loop.trace[name][lo:k + 1] for name in ("position", "force")}
        v = analyse_trace(window, T, resolution, speed=0.0)
        b = v["buzz"]
        osc = v["oscillation"]
        step = {"stiffness": float(ladder[state["i"]]), "start": lo * T, "regime": v["regime"],
                "oscillating": bool(osc.oscillating or v["regime"] == "diverged"), "amplitude": osc.amplitude,
                "frequency": osc.frequency, "buzz_db": None if b is None or b.margin_db == -math.inf else b.margin_db,
                "buzz_frequency": None if b is None or b.margin_db == -math.inf else b.frequency}
        steps.append(step)
        if on_step is not None:
            on_step(step)
        if step["oscillating"]:
            servo.stop()  # zero force from the next tick: rule 5
            state.update(reason="oscillation", oscillating=step["stiffness"], stopped=(k + 1) * T)
        elif state["i"] + 1 == ladder.size:
            servo.stop()
            state.update(reason="ladder end")
        else:
            state["i"] += 1
            renderer.set_stiffness(float(ladder[state["i"]]), limit=float(ladder[-1]))
            state["from"] = k + 1

    # the ladder's time, the engagement (the handle let down onto the wall) and a margin
    duration = (ladder.size + 1) * n_step * T + (loop.engage_ticks + loop.ramp_ticks) * T + 5.0
    stats, trace = loop.run(duration, on_tick=watch)
    reason = "interrupted" if stats.interrupted else state["reason"] or ("not engaged" if stats.engaged_at is None
                                                                           else "ladder end")
    clean = None
    judged = [s for s in steps if not s["oscillating"]]
    if judged:
        clean = judged[-1]["stiffness"]
    return LimitSearch(clean, state["oscillating"], reason, steps, state["stopped"], stats, trace)
