"""A real-time rendering path: one C call per servo tick.

A :class:`Renderer` holds an algorithm's model and state in the C core (F's adhesion point;
D's and E's last closest point, a warm start; the passivity observer and controller; the
counters) and turns one probe position into the force to command. It is meant to be called
from a device's servo loop at 1–10 kHz.
"""

from __future__ import annotations

import math

from dataclasses import dataclass

import numpy as np

from . import core as _core
from .core import WORKSPACE_LIMIT, _ext
from ._validation import fail, flag, numbers, optional_positive, positive, random_seed, whole
from .algorithms import Algorithm, checked_algorithm
from .closest import table_search_data

__all__ = ["Renderer", "Stabiliser", "PassivityController", "EnergyBounding", "PassiveSetPosition", "WORKSPACE_LIMIT",
           "MAX_EVALUATIONS", "VIBRATION_RESERVE_TIME", "tick_model"]

_REAL = (int, float, np.integer, np.floating)



MAX_OBSERVER_DELAY = int(_core._ext.PC_RING) - 1
"""Longest computation delay (ticks) the passivity observer pairs forces over."""


def stabiliser_period(passivity_controller, period) -> float | None:
    """The servo period (s) a tick with ``passivity_controller`` runs at, checked (the
    renderer's and the export's one rule): None without a period.

    Parameters
    ----------
    passivity_controller : Stabiliser or None
        The tick's stabiliser.
    period : float or None
        The servo period (s) it is given with, or None (then the stabiliser's own).

    Returns
    -------
    float or None
        The period (s), or None.

    Raises
    ------
    ParameterError
        For a ``passivity_controller`` that is not None or a :class:`Stabiliser`, one without a
        ``period``, or a period that is not > 0.
    """
    if passivity_controller is not None and not isinstance(passivity_controller, Stabiliser):
        raise fail("passivity_controller", passivity_controller,
                   "None or a haptex stabiliser (PassivityController, EnergyBounding, PassiveSetPosition)")
    if passivity_controller is not None and period is None:
        raise fail("period", period, "the servo period in s (> 0) with a passivity_controller")
    return None if period is None else positive("period", period, "s")


class Stabiliser:
    """A stabiliser of the servo loop, run by the C core on each tick beside the passivity
    observer: :class:`PassivityController` (Hannaford & Ryu), :class:`EnergyBounding` (after Kim
    & Ryu) or :class:`PassiveSetPosition` (after Lee & Huang). Every API that takes a
    ``passivity_controller`` takes any of them."""

    delay: int | None

    @property
    def mode(self) -> int:
        """The C core's code for it (``haptex.core._ext.STAB_*``)."""
        raise NotImplementedError

    @property
    def core_damping(self) -> float:
        """The damping the C core is given (N s/m): the controller's largest for
        :class:`PassivityController`, the device's physical damping for the others."""
        raise NotImplementedError

    @property
    def label(self) -> str:
        """A short name for tables and summaries."""
        raise NotImplementedError


def _delay(value):
    return None if value is None else whole("delay", value, 0, MAX_OBSERVER_DELAY,
                                             "ticks between sending a force and its acting")


@dataclass(frozen=True)
class PassivityController(Stabiliser):
    """A time-domain passivity observer and controller for a servo loop.

    The observer sums the energy the virtual environment absorbs, E = -sum f_{k-1-d} . dp_k,
    from the force that acted over each sample (sent d = ``delay`` ticks before it) and the
    displacement sensed (Hannaford & Ryu 2002). When E falls
    below a reference the controller adds a variable damper -alpha v (v the backward
    difference of the sensed positions) that dissipates the deficit within one sample,
    alpha = (E_ref - E) / (T ‖v‖^2), bounded by ``max_damping``.

    Parameters
    ----------
    max_damping : float
        Largest damping the controller may add (N s/m), > 0: what the device can render
        without going unstable itself (for a device with viscous damping b and sampling
        period T, a virtual damper is passive up to about b; Colgate & Schenkel 1997).
    delay : int, optional
        Ticks between sending a force and its acting on the device (its computation and
        communication delay), 0 to :data:`MAX_OBSERVER_DELAY`: the observer pairs each
        displacement with the force that acted over it, sent that many ticks before. A
        :class:`Renderer` takes it from here (default 0); :func:`haptex.simulate` from the
        simulated device (a different value here is refused).
    reference : {"zero", "stored"}
        ``"zero"`` (default): E_ref = 0, the observer of Hannaford & Ryu (2002): the
        environment may give back all it absorbed. ``"stored"``: E_ref = kappa_0 d^2 / 2, the
        energy still stored in the algorithm's virtual spring at its own penetration d
        (Table I): what the environment has absorbed must cover what it can still give back,
        so energy generated anywhere along a path is dissipated as it appears (a reference
        energy in the style of Ryu, Preusche, Hannaford & Hirzinger, 2005). It leaves no
        margin: on a resting wall the sensor's flicker alone makes it fire (on the Fig. 5
        device, 2 N spikes on 15 % of ticks), which is why it is not the default.

    Notes
    -----
    The observer starts, on its first tick, from the energy the spring stores where the
    probe starts (kappa_0 d^2 / 2: put in before it watched, and the environment may give it
    back). With a computation delay it pairs each displacement with the force that acted
    over it (``delay``); without that pairing, on the Fig. 5 device with one sample of
    delay, it counted energy absorbed while the port supplied it.

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
    reference: str = "zero"
    delay: int | None = None

    def __post_init__(self):
        object.__setattr__(self, "max_damping", positive("max_damping", self.max_damping, "N s/m"))
        if self.reference not in ("stored", "zero"):
            raise fail("reference", self.reference, 'one of "stored", "zero"')
        object.__setattr__(self, "delay", _delay(self.delay))

    @property
    def mode(self) -> int:
        """The C core's code: ``STAB_PC``, or ``STAB_PC_STORED`` for the stored-energy reference."""
        return int(_ext.STAB_PC_STORED if self.reference == "stored" else _ext.STAB_PC)

    @property
    def core_damping(self) -> float:
        """The controller's largest damping (N s/m), ``max_damping``."""
        return self.max_damping

    @property
    def label(self) -> str:
        """``passivity controller (B N s/m, REFERENCE reference)``."""
        return f"passivity controller ({self.max_damping:g} N s/m, {self.reference} reference)"


@dataclass(frozen=True)
class _PaidByTheDamper(Stabiliser):
    """A stabiliser paid with the device damper's dissipation (its damping b and the delay)."""

    damping: float
    delay: int | None = None
    _code = ""
    _name = ""

    def __post_init__(self):
        object.__setattr__(self, "damping", positive("damping", self.damping, "N s/m"))
        object.__setattr__(self, "delay", _delay(self.delay))

    @classmethod
    def for_device(cls, device, delay: int | None = None):
        """With the device's least damping in contact (``Device.min_damping``, the least
        singular value of its damping matrix). Raises ParameterError if that is 0 (nothing to
        pay with)."""
        return cls(device.min_damping, delay)

    @property
    def mode(self) -> int:
        return int(getattr(_ext, self._code))

    @property
    def core_damping(self) -> float:
        return self.damping

    @property
    def label(self) -> str:
        return f"{self._name} (b = {self.damping:.3g} N s/m)"


@dataclass(frozen=True)
class EnergyBounding(_PaidByTheDamper):
    """Energy bounding in the manner of Kim & Ryu: the energy the sampled force generates is
    bounded by what the device's own damping dissipates.

    The energy the port supplies over a sample is the force that acted over it (sent ``delay``
    ticks before) times the displacement sensed. It splits, tick by tick, into the virtual
    environment's own part, -f_k . dp_k (each force with the displacement it answered), and
    what the zero-order hold and the delay generate, -(f_k - f_acting) . dp_k. Two reservoirs
    hold them: the environment's (its absorbed energy, from the spring's stored energy at the
    start) and the hold's (credited with b ‖dp_k‖^2 / T, a lower bound on the device damper's
    dissipation over the sample, b v^2 integrated, by Cauchy-Schwarz). Both are linear in f_k .
    dp_k, so the force's component along the last displacement is moved just enough to keep
    both >= 0; the rest of the force is untouched. Their sum is the observer's energy plus the
    credit, so while both hold the port supplies no more than the device's damper dissipates.

    Parameters
    ----------
    damping : float
        The device's physical damping b at the handle in contact (N s/m), > 0: its least (for
        an anisotropic device, the least singular value of its damping matrix;
        :meth:`for_device`). Credit for damping the device does not have is credit for energy
        it cannot dissipate. The credit accrues only on ticks in contact (the algorithm's
        penetration > 0), so a device whose damper acts only in contact (the paper's
        pantograph energises its brakes inside, Section V-A) is credited correctly.
    delay : int, optional
        Ticks between sending a force and its acting (as :class:`PassivityController`).

    Raises
    ------
    ParameterError
        If ``damping`` is not > 0 or ``delay`` is not None or in [0, :data:`MAX_OBSERVER_DELAY`].

    Notes
    -----
    The force is held over the next sample, whose displacement is not known when it is
    chosen; when the hand moves the handle so that the held force supplies more than the
    damper dissipates, the reservoirs' sum can go below zero by at most T ‖f‖^2 / (4 b) in
    that sample, and both then recover before the force may supply energy again. The
    decomposition and the two reservoirs are haptex's discrete statement of Kim & Ryu's
    principle; their paper's own inequalities were not available to us.

    References
    ----------
    J.-P. Kim and J. Ryu, "Energy bounding algorithm based on passivity theorem for stable
    haptic interaction control", Proc. 12th Int. Symp. on Haptic Interfaces for Virtual
    Environment and Teleoperator Systems (HAPTICS), 2004, pp. 351–357; J.-P. Kim and J. Ryu,
    "Robustly stable haptic interaction control using an energy-bounding algorithm", Int. J.
    Robotics Research 29(6), 2010, pp. 666–679.
    """

    _code = "STAB_EBA"
    _name = "energy bounding"


@dataclass(frozen=True)
class PassiveSetPosition(_PaidByTheDamper):
    """Passive set-position modulation in the manner of Lee & Huang.

    The algorithm's force is read as a coupling spring of stiffness kappa_0 (the algorithm's)
    stretched from the handle to a set-position, f = kappa_0 (y - p). Each tick the
    set-position moves towards the handle, along f, no further than keeps the spring's energy
    ‖f‖^2 / (2 kappa_0) within a reservoir: the energy the port has absorbed (the passivity
    observer's, each force paired with the displacement it acted over under ``delay``) plus
    b ‖dp‖^2 / T a sample (a lower bound on what the device's damper dissipated). The force's
    direction is kept; only its magnitude is reduced, and only when the reservoir runs short.
    Without delay the reservoir is Lee & Huang's: it changes by the credit less kappa_0 ‖dp‖^2 / 2
    (the hold's share over a sample) less what moving the set-position stores in the spring.

    Parameters
    ----------
    damping : float
        The device's physical damping b at the handle in contact (N s/m), > 0, credited on
        ticks in contact (as :class:`EnergyBounding`; :meth:`for_device`).
    delay : int, optional
        Ticks between sending a force and its acting (as :class:`PassivityController`).

    Raises
    ------
    ParameterError
        If ``damping`` is not > 0 or ``delay`` is not None or in [0, :data:`MAX_OBSERVER_DELAY`].

    Notes
    -----
    Strictly passive (the port supplies at most the credit) when kappa_0 <= 2 b / T, where the
    credit covers the hold's share; above it the reservoir can run below zero by (kappa_0 / 2 -
    b / T) ‖dp‖^2 in a sample, and the force then shrinks to zero until it is repaid. A resting
    contact costs nothing (no motion, no change of stored energy). haptex's statement of the
    published scheme; the paper's own equations were not available to us.

    References
    ----------
    D. J. Lee and K. Huang, "Passive-set-position-modulation framework for interactive robotic
    systems", IEEE Trans. Robotics 26(2), 2010, pp. 354–369.
    """

    _code = "STAB_PSPM"
    _name = "passive set-position modulation"


def reads_search_budget(algorithm) -> bool:
    """Whether ``algorithm``'s tick reads a budget of texture evaluations (``max_evaluations``):
    D's and E's closest-point search over a surface on the plane or over an object's texture.
    Over a profile, or a profile extruded across y, the search is the profile's tree (with its
    cell table where the profile is periodic), bounded by its depth, and reads none; the other
    algorithms search nothing.

    Parameters
    ----------
    algorithm : Algorithm, ObjectAlgorithm or GodObject
        What is rendered.

    Returns
    -------
    bool
    """
    algorithm = checked_algorithm(algorithm, proxy=True)
    from .surfaces import Extruded

    if getattr(algorithm, "letter", "") not in ("D", "E"):
        return False
    if getattr(algorithm, "base", None) is not None:
        return True
    tex = getattr(algorithm, "texture", None)
    return tex is not None and tex.dimension == 2 and not isinstance(tex, Extruded)


def tick_model(algorithm: Algorithm, max_evaluations: int | None = None):
    """The arrays of one algorithm's servo tick in the C core, as :class:`Renderer` and
    ``haptex export`` hand them to it.

    Parameters
    ----------
    algorithm : Algorithm
        W or A-G over a profile or a surface.
    max_evaluations : int or None
        D and E over a surface: the tick's evaluation budget (aux[``G_BUDGET``]); None: none.

    Returns
    -------
    code : int
        The algorithm's code (``haptex.core._ext.ALG_*``).
    prm : ndarray, shape (N_PARAMS,)
        Its parameters (``P_*``; SI units).
    kind : int
        The texture kind (``TEXTURE_*``, ``SURFACE_*``).
    coeffs : ndarray, shape (rows, cols)
        The texture's coefficients.
    aux : ndarray, shape (n,)
        D's and E's search data (over a periodic profile, or a profile extruded from one, with
        the cell table :func:`haptex.closest.table_search_data`; over a surface with the
        budget), F's smooth presliding table, else empty.
    search_table : bool
        True when aux holds a cell table.
    """
    algorithm = checked_algorithm(algorithm, proxy=True)
    code, prm, kind, coeffs, aux = algorithm.kernel_spec()
    table = False
    if reads_search_budget(algorithm):  # (a copy: the texture's own constants stay unbudgeted, the analysis certifies)
        aux = aux.copy()
        aux[_ext.G_BUDGET] = 0.0 if max_evaluations is None else float(max_evaluations)
    elif algorithm.letter in ("D", "E"):  # (over a profile, or one extruded: its tree, with the cell table)
        from .surfaces import Extruded

        tex = algorithm.texture
        tabled = table_search_data(tex.profile if isinstance(tex, Extruded) else tex)
        table = tabled[_ext.A_TABLE] != 0.0
        aux = tabled
    return code, prm, kind, coeffs, np.require(aux, np.float64, ["C"]), bool(table)


MAX_EVALUATIONS = 5000
"""The default budget of texture evaluations for one tick's closest-point search (D, E over a
surface; chosen): about 12 times the paper's egg-crate's typical tick (410), about 0.3 ms here over
gratings; over a height map's patches each evaluation costs more, the budget 0.6-2.2 ms on a felt
egg-crate's maps (benchmarks/README.md, "Worst-case servo tick")."""


def evaluation_budget(max_evaluations):
    """``max_evaluations`` checked: None, or a whole number of texture evaluations in [100, 10^9].

    Parameters
    ----------
    max_evaluations : int or None
        The budget to check.

    Returns
    -------
    int or None
        The budget (texture evaluations a tick), or None.

    Raises
    ------
    ParameterError
        For anything else (a bool, a float, a number out of range), naming the parameter."""
    if max_evaluations is not None and not (isinstance(max_evaluations, int | np.integer)
                                            and not isinstance(max_evaluations, bool)
                                            and 100 <= max_evaluations <= 10**9):
        raise fail("max_evaluations", max_evaluations, "None or a whole number of texture evaluations in [100, 10^9]")
    return max_evaluations


VIBRATION_RESERVE_TIME = 0.05
"""s: the budgeted vibration's tank, by default, holds this long of its budget (chosen: a burst of
50 ms, a few cycles of the 100-400 Hz band of texture vibrations)."""



FRICTION_THRESHOLD = 0.005
"""Speed (m/s) below which a material's friction is viscous, in proportion to the speed
(chosen: 5 mm/s, below a hand's stroking speeds, so that a stroke meets the Coulomb friction
mu f_z; HaTT's published renderer switches at mu / 0.004 mm/s with a viscous slope of 0.004 mu f_z
per mm/s, which is mu^2 f_z at its threshold and mu f_z above it: a jump haptex does not copy)."""


def friction_settings(vibration, friction=None, threshold=FRICTION_THRESHOLD):
    """The material friction's (mu, threshold) for the C core, or None when off.

    Parameters
    ----------
    vibration : haptex.datadriven.ModelSet or None
        The vibration whose set carries the material's ``mu``.
    friction : bool or None
        On, off, or None: on when the set has a mu.
    threshold : float
        m/s, > 0.

    Returns
    -------
    tuple of float or None

    Raises
    ------
    ParameterError
        If friction is asked for without a vibration or with a set that has no mu, or the
        threshold is not > 0.
    """
    from ._validation import positive

    v_th = positive("friction_threshold", threshold, "m/s")
    mu = None if vibration is None else getattr(vibration, "mu", None)
    if friction is None:
        friction = mu is not None and mu > 0
    if not friction:
        return None
    if mu is None:
        raise fail("friction", friction, "given with a vibration whose model set has a mu (HaTT's <mu>): "
                   f"{'no vibration' if vibration is None else 'this set has none'}")
    return float(mu), v_th


def vibration_settings(vibration, vibration_mass=None, vibration_gain=1.0, velocity_filter=0.01, seed=0,
                       vibration_budget=None, vibration_reserve=None):
    """The data-driven vibration's settings as the C core takes them (``hx_render_set_vibration``),
    checked once for :class:`Renderer` and :func:`haptex.export.export_c`.

    Parameters
    ----------
    vibration, vibration_mass, vibration_gain, velocity_filter, seed, vibration_budget, vibration_reserve
        As :class:`Renderer`'s.

    Returns
    -------
    tuple or None
        (packed models, shape (n,); mass kg; gain; filter s; seed; budget W or None; reserve
        J), or None without a vibration.

    Raises
    ------
    ParameterError
        For a vibration that is not a model set, no mass, a negative gain, filter, budget or
        reserve, a seed outside [0, 2**64), or a budget or reserve without a vibration (or a
        reserve without a budget).
    """
    from ._validation import nonnegative, positive

    if vibration is None:
        if vibration_budget is not None or vibration_reserve is not None:
            raise fail("vibration_budget", vibration_budget, "given with a vibration (a haptex.datadriven.ModelSet)")
        return None
    from .datadriven import ModelSet

    if not isinstance(vibration, ModelSet):
        raise fail("vibration", vibration, "a haptex.datadriven.ModelSet (read_models, read_hatt or fit)")
    if vibration_mass is None:
        raise fail("vibration_mass", None, "a mass (kg) turning the vibration's acceleration into force, e.g. "
                   "the device's own: preset(NAME).device().mass[0, 0]")
    seed = random_seed("seed", seed)
    budget = None if vibration_budget is None else nonnegative("vibration_budget", vibration_budget, "W")
    if vibration_reserve is not None and budget is None:
        raise fail("vibration_reserve", vibration_reserve, "given with a vibration_budget (W), whose tank it is")
    reserve = (0.0 if budget is None else budget * VIBRATION_RESERVE_TIME) if vibration_reserve is None \
        else nonnegative("vibration_reserve", vibration_reserve, "J")
    return (vibration._packed, positive("vibration_mass", vibration_mass, "kg"),
            nonnegative("vibration_gain", vibration_gain), nonnegative("velocity_filter", velocity_filter, "s"),
            seed, budget, reserve)


def _within_limit(stiffness: float, limit: float | None) -> None:
    """Refuse a stiffness (N/m) above the run's ``limit`` before it reaches the tick
    (:meth:`Renderer.set_stiffness`, :meth:`Renderer.set_algorithm`)."""
    if limit is not None and not stiffness <= positive("limit", limit, "N/m"):
        raise fail("stiffness", f"{stiffness:g} N/m", f"at most {limit:g} N/m, the limit set for this run")


class Renderer:
    """Compiled force rendering for a servo loop, over a profile ([x, z]) or a surface
    ([x, y, z]).

    Parameters
    ----------
    algorithm : Algorithm
        W or A–G, from :func:`haptex.algorithm`; its texture's dimension sets the
        positions' (2 over a profile, 3 over a surface). Or a god-object over the plane or any
        base (:class:`haptex.proxy.GodObject`: its C tick, with history). Or A-G
        on an object (D and E but on a faceted mesh)
        (:func:`haptex.objects.object_algorithm`: a plane, cylinder, sphere or mesh, faceted or prism,
        positions [x, y, z]); on a mesh the tick finds the closest point through a
        bounding-volume hierarchy built here, exact, its nodes and triangles visited counted in
        :attr:`last_work`.
    max_force : float, optional
        Largest force magnitude to command (N); larger forces are scaled down to it and
        counted in :attr:`clamps`. ``None``: no limit.
    energy_monitor : bool, optional
        Keep the passivity observer of Hannaford & Ryu (2002): the running sum of
        -f . dp, exposed as :attr:`energy` (J). It decreases when the texture supplies
        energy to the hand. Implied by ``passivity_controller``.
    passivity_controller : Stabiliser, optional
        A stabiliser acting on the force each tick (:class:`PassivityController`,
        :class:`EnergyBounding` or :class:`PassiveSetPosition`); needs ``period``.
    period : float, optional
        The servo period T (s) at which :meth:`step` is called; required with a
        ``passivity_controller`` (its velocity estimate is dp / T).
    max_evaluations : int or None, optional
        D and E over a surface: the texture evaluations one tick's closest-point search may
        spend (default :data:`MAX_EVALUATIONS`, chosen: 5,000, about 0.3 ms on this project's
        machine over gratings, 0.6-2.2 ms over a felt map's patches). Past it the search ends with the best point found, not certified global,
        and the tick is counted in :attr:`cut`; a tick's work is then at most the budget plus
        250. ``None``: only the search's structural bound (2,048 cells; about 10^5
        evaluations measured 1 km under the paper's egg-crate).
    vibration : haptex.datadriven.ModelSet, optional
        Data-driven vibration layered on the texture (the C core's ``hx_vibration.c``): in
        contact and moving, ``vibration_mass`` x its acceleration (m/s²) along the tangential
        velocity, at the operating point (the tangential speed, filtered with time constant
        ``velocity_filter``; the algorithm's normal force f_z). :meth:`step` must then be
        called at the set's rate (its velocity estimate is dp times that rate).
    vibration_mass : float, optional
        Effective mass (kg) turning acceleration into force (HaTT's display on a Phantom);
        required with ``vibration`` (a device preset's mass along x:
        ``preset.device().mass[0, 0]``).
    vibration_gain : float, optional
        Factor on the vibration, >= 0 (:meth:`haptex.datadriven.VibrationEnergy.gain_for`
        gives the one that keeps its mean power within a budget).
    velocity_filter : float, optional
        Time constant (s) of the first-order filter on the tangential velocity, >= 0
        (chosen: 10 ms; 0: the raw difference).
    seed : int, optional
        Seed of the vibration's noise (the same seed, the same run).
    vibration_budget : float, optional
        W, >= 0: the **budgeted vibration**. The channel spends only from an energy tank that
        this power refills every tick, up to ``vibration_reserve``; the vibration's work on
        the sensed motion (its force held over each period) drains it, and a vibration force
        whose work over the next period, at the filtered speed, would exceed what the tank
        holds is scaled down to it (counted in :attr:`vibration_cut`). So the energy it
        supplies over any time t is at most ``vibration_budget`` t + ``vibration_reserve``,
        give or take one period's misprediction of the motion. Default None: no budget (the
        energy supplied is still counted, :attr:`vibration_supplied`). The energy-tank idea of
        passivity-based control (Franken, Stramigioli, Misra, Secchi & Macchelli, "Bilateral
        telemanipulation with time delays: a two-layer approach combining passivity and
        transparency", IEEE Trans. Robotics 27(4), 2011), here for a vibration channel.
    vibration_reserve : float, optional
        J, >= 0: the tank's size and its content at the start; default the budget over
        :data:`VIBRATION_RESERVE_TIME`.
    friction : bool, optional
        The material's kinetic friction beside the vibration, as HaTT's renderer applies it
        (Culbertson et al. 2014): mu f_z against the filtered tangential velocity, mu the model
        set's (HaTT's ``<mu>``), in proportion to the speed below ``friction_threshold`` (so
        continuous there). Default: on when the vibration's set has a mu, off otherwise; what
        it dissipates is :attr:`friction_dissipated`.
    friction_threshold : float, optional
        m/s, > 0: the speed below which the friction is viscous (default
        :data:`FRICTION_THRESHOLD`).

    Raises
    ------
    ParameterError
        If ``algorithm`` is not a haptex algorithm, ``max_force`` is not > 0,
        ``energy_monitor`` is not True or False, a controller is given without a period,
        ``max_evaluations`` is not None or in [100, 10^9], or a vibration is given without its
        mass or with a gain, filter, seed, budget or reserve out of range (or a budget without a
        vibration).

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
                 max_evaluations: int | None = MAX_EVALUATIONS, *, vibration=None, vibration_mass: float | None = None,
                 vibration_gain: float = 1.0, velocity_filter: float = 0.01, seed: int = 0,
                 vibration_budget: float | None = None, vibration_reserve: float | None = None,
                 friction: bool | None = None, friction_threshold: float = FRICTION_THRESHOLD):
        from .proxy import GodObject

        algorithm = checked_algorithm(algorithm, proxy=True)
        optional_positive("max_force", max_force, "N")
        T = stabiliser_period(passivity_controller, period)
        self.max_evaluations = evaluation_budget(max_evaluations)
        self.algorithm = algorithm
        self.passivity_controller = passivity_controller
        self.dimension = algorithm.dimension
        base = None
        if isinstance(algorithm, GodObject):  # the god-object (its own C tick), over the plane or a base
            if algorithm.base is None:
                code, prm, kind, coeffs, aux = algorithm.kernel_spec()
            else:
                code, prm, kind, coeffs, aux, base = algorithm.object_spec(self.max_evaluations)
            self._search_table = False
        elif getattr(algorithm, "base", None) is not None:  # a textured object (haptex.objects)
            code, prm, kind, coeffs, aux, base = algorithm.object_spec(self.max_evaluations)
            self._search_table = False
        else:
            code, prm, kind, coeffs, aux, self._search_table = tick_model(algorithm, max_evaluations)
        pc = passivity_controller
        self._core = _core._ext.Renderer(
            code, prm, kind, coeffs, aux, self.dimension, math.inf if max_force is None else float(max_force),
            WORKSPACE_LIMIT, flag("energy_monitor", energy_monitor), pc is not None,
            0.0 if pc is None else pc.core_damping,
            0 if pc is None else pc.mode, 0.0 if T is None else T, self._step_checked,
            0 if pc is None or pc.delay is None else pc.delay, base)
        self.step = self._core.step
        self.vibration = vibration
        settings = vibration_settings(vibration, vibration_mass, vibration_gain, velocity_filter, seed,
                                      vibration_budget, vibration_reserve)
        if settings is not None:
            self._core.set_vibration(*settings)
        self.friction = friction_settings(vibration, friction, friction_threshold)
        if self.friction is not None:
            self._core.set_friction(*self.friction)

    @property
    def vibration_force(self) -> float:
        """The vibration's force on the last tick (N, signed, along the tangential velocity); 0
        without a vibration, out of contact or at rest."""
        return self._core.vibration_force

    @property
    def vibration_supplied(self) -> float:
        """The vibration's work on the sensed motion so far (J): the sum of its force, held over
        each period, times the displacement; > 0 is energy supplied to the hand. 0 without a
        vibration."""
        return self._core.vibration_supplied

    @property
    def friction_dissipated(self) -> float:
        """The material friction's work on the sensed motion so far, negated (J, >= 0 while it
        opposes the motion): its force held over each period times the displacement since. 0
        without friction."""
        return self._core.friction_dissipated

    @property
    def vibration_cut(self) -> int:
        """Ticks whose vibration force the energy budget scaled down."""
        return self._core.vibration_cut

    @property
    def vibration_tank(self) -> float:
        """What the vibration's energy budget holds now (J)."""
        return self._core.vibration_tank

    def _tick(self, x, y, z):
        """(fx, fy, fz) (N) at floats (x, y, z) (m), fy = 0 over a profile."""
        return self._core.tick(x, y, z)

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
            self._core.fault()
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
        return self._core.last_work

    @property
    def cut(self) -> int:
        """Ticks since construction or :meth:`reset` whose closest-point search (D, E over a
        surface) its ``max_evaluations`` budget ended: their force used the best point found,
        not the certified closest point."""
        return self._core.cut

    @property
    def max_work(self) -> int:
        """Largest :attr:`last_work` since construction or :meth:`reset`."""
        return self._core.max_work

    def step_many(self, points) -> np.ndarray:
        """Forces for consecutive probe positions: one tick each, in order, in the C core's loop.

        Parameters
        ----------
        points : array_like, shape (n, dimension)
            Probe positions (m), real numbers: rows ``[x, z]`` over a profile, ``[x, y, z]``
            over a surface, as :meth:`step` takes one.

        Returns
        -------
        numpy.ndarray, shape (n, dimension)
            The forces (N) :meth:`step` would return for each row in turn, with its state
            (friction, warm starts, the observer, a vibration) carried from row to row; a row
            that is not finite within +-1 km gives zero force and is counted in :attr:`faults`.

        Raises
        ------
        ParameterError
            If ``points`` is not an (n, dimension) array of real numbers (a bool, text or a
            complex number anywhere in it is not one).

        Notes
        -----
        The loop runs with the GIL released (other Python threads go on).
        """
        allowed = f"an (n, {self.dimension}) array of real numbers (m)"
        arr = numbers("points", points, allowed, copy=False)  # (no bool, text or complex number in it)
        if arr.ndim != 2 or arr.shape[1] != self.dimension:
            raise fail("points", f"shape {arr.shape}", allowed)
        pts = np.ascontiguousarray(arr)
        out = np.empty_like(pts)
        self._core.run(pts, out)
        return out

    def set_stiffness(self, stiffness: float, limit: float | None = None) -> None:
        """Change the nominal stiffness kappa_0 while the renderer runs, between ticks.

        The parameter block of the C core's renderer: the value waits beside the model and
        the next tick takes it before it computes, never in the middle of one, whichever
        thread ticks (the native servo thread included); a second call before that tick
        replaces the first. Every force of W and A-G is proportional to kappa_0, so this
        scales the rendering; the observer and stabilisers read the new value from that tick.

        Parameters
        ----------
        stiffness : float
            kappa_0 (N/m), finite and > 0.
        limit : float, optional
            The largest stiffness the caller allows on this device (N/m): a larger one is
            refused before it reaches the tick (a change that would be unsafe mid-run).

        Raises
        ------
        ParameterError
            For a stiffness not finite and > 0, or above ``limit``.
        """
        k = positive("stiffness", stiffness, "N/m")
        _within_limit(k, limit)
        self._core.set_stiffness(k)

    def set_algorithm(self, algorithm: Algorithm, limit: float | None = None) -> None:
        """Change the texture or the algorithm while the renderer runs, between ticks.

        The parameter block of the C core's renderer, for a whole model: ``algorithm`` is
        packed (as this constructor packs one, with this renderer's evaluation budget) and
        waits beside the model; the next tick takes it before it computes, never in the middle
        of one, whichever thread ticks (the native servo thread included), and starts it with
        its state cleared (friction's adhesion point, the proxy's position, a closest-point
        warm start belong to the old model). The observer, the stabiliser, the vibration, the
        force ceiling and the servo rules go on. A second call before that tick replaces the
        first, which is never used; a stiffness waiting from :meth:`set_stiffness` gives way
        to the new model's own.

        Parameters
        ----------
        algorithm : Algorithm or haptex.proxy.GodObject
            Of this renderer's dimension: W or A-G on a texture or an object, or the
            god-object.
        limit : float, optional
            The largest stiffness the caller allows on this device (N/m): an algorithm whose
            kappa_0 is larger is refused before it reaches the tick (a change that would be
            unsafe mid-run).

        Raises
        ------
        ParameterError
            For an algorithm of another dimension, one the constructor refuses, or a
            stiffness above ``limit``.
        """
        if getattr(algorithm, "dimension", None) != self.dimension:
            raise fail("algorithm", algorithm, f"of this renderer's dimension ({self.dimension}-D)")
        _within_limit(float(getattr(algorithm, "stiffness", math.nan)), limit)
        packed = Renderer(algorithm, max_evaluations=self.max_evaluations)  # (its model's arrays, kept by the core)
        self._core.set_model(packed._core)
        self.algorithm = algorithm

    @property
    def algorithm_changes(self) -> int:
        """Models the ticks have taken from :meth:`set_algorithm`."""
        return self._core.model_changes

    @property
    def stiffness(self) -> float:
        """kappa_0 (N/m) the ticks use now (a :meth:`set_stiffness` waits for the next tick)."""
        return self._core.stiffness

    @property
    def stiffness_changes(self) -> int:
        """Stiffnesses the ticks have taken from :meth:`set_stiffness`."""
        return self._core.stiffness_changes

    def reset(self) -> None:
        """Clear the algorithm's state (friction, warm start), the observer, the controller and
        the counters."""
        self._core.reset()

    @property
    def faults(self) -> int:
        """Calls whose position was not finite numbers within +-1 km (zero force returned)."""
        return self._core.faults

    @property
    def clamps(self) -> int:
        """Calls whose force was scaled down to ``max_force``."""
        return self._core.clamps

    @property
    def energy(self) -> float:
        """Passivity observer: energy absorbed by the virtual environment so far (J);
        negative means the rendering has supplied energy. 0 without ``energy_monitor``."""
        return self._core.energy

    @property
    def energy_per_axis(self) -> tuple[float, ...]:
        """(E_x, E_z) or (E_x, E_y, E_z) of the passivity observer (J), the paper's Section
        V-B sums."""
        return self._core.energy_per_axis

    @property
    def controller_active(self) -> int:
        """Ticks on which the passivity controller added damping."""
        return self._core.controller_active

    @property
    def controller_damping(self) -> float:
        """The damping alpha the controller added on the last tick (N s/m), 0 if none."""
        return self._core.controller_damping

    @property
    def adhesion(self):
        """F's adhesion point while in contact (m): x over a profile, (x, y) over a surface,
        (u1, u2) in an object's surface coordinates; else None."""
        if self.algorithm.letter != "F":
            return None
        adh = self._core.adhesion
        if adh is None:
            return None
        return adh if self.dimension == 3 else adh[0]
