"""Sampled-data haptic devices: mass and damping at the handle, sampling period, delay,
resolutions and force limit; presets for a point mass and a five-bar pantograph.

The virtual plane's axes [x, z] are the device's Cartesian axes at the handle: x along
the surface, z along the wall's outward normal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ._validation import MAX_LENGTH, ParameterError, fail, matrix2, nonnegative, numbers, positive, positive_or_inf, whole


MAX_PERIOD = 1.0
"""The longest sampling period (s) a :class:`Device` takes and :func:`critical_stiffness`
analyses (chosen: a haptic device's servo loop runs at 100 Hz or faster, so a second is past
any device's period)."""


def _period(value) -> float:
    """A sampling period (s): > 0 and at most :data:`MAX_PERIOD`, refused naming ``period``."""
    T = positive("period", value, "s")
    if T > MAX_PERIOD:
        raise fail("period", value, f"a number > 0 and at most {MAX_PERIOD:g} s")
    return T


def _matrix(name: str, value, allow_zero: bool, dim: int = 2) -> np.ndarray:
    """A dim x dim symmetric matrix from a scalar (isotropic) or an array; checks definiteness."""
    arr = matrix2(name, value, f"{dim}x{dim} symmetric matrix", dim)
    if not np.all(np.abs(arr - arr.T) <= 1e-12 * np.abs(arr.T)):  # np.allclose(rtol=1e-12, atol=0), finite entries
        raise fail(name, arr.tolist(), f"a symmetric {dim}x{dim} matrix")
    eig = np.linalg.eigvalsh(arr)
    if not definite(eig.min(), eig.max(), allow_zero):
        raise fail(name, arr.tolist(), "positive semi-definite (no negative damping)" if allow_zero else
                   "positive definite")
    return arr


def definite(lowest, highest, allow_zero: bool):
    """Whether a symmetric matrix is a mass or a damping matrix, from its extreme eigenvalues.

    Parameters
    ----------
    lowest, highest : float or array_like
        Its smallest and largest eigenvalues (kg or N s/m), elementwise over arrays (an
        isotropic matrix v I has both equal to v).
    allow_zero : bool
        False for a mass (positive definite); True for a damping (positive semi-definite, to
        a round-off of 1e-12 of the largest eigenvalue).

    Returns
    -------
    bool or ndarray of bool
        The shape of ``lowest`` broadcast with ``highest``.
    """
    lowest = np.asarray(lowest)
    if allow_zero:
        return lowest >= -1e-12 * np.maximum(1.0, np.abs(highest))
    return lowest > 0


SCALAR_FIELDS = ("delay", "position_resolution", "force_resolution", "max_force", "coulomb_friction")
"""The device's scalar fields that only the simulator's loops read, per run (a sweep packs them)."""


def scalar_field(name: str, value):
    """One of :data:`SCALAR_FIELDS` checked as a :class:`Device` checks it: ``delay`` a whole
    number of sampling periods in [0, 10000]; a resolution 0 (ideal) or >= 1e-15 (m or N: finer
    than any sensor is a typo, and x / delta overflows); ``max_force`` > 0 or inf (N);
    ``coulomb_friction`` >= 0 (N). Returns the value (int for the delay, else float).

    Parameters
    ----------
    name : str
        One of :data:`SCALAR_FIELDS`.
    value : float or int
        Its value (SI units; periods for the delay).

    Returns
    -------
    float or int
        The value, checked: ``delay`` an int (sampling periods), the others floats in SI units.

    Raises
    ------
    ParameterError
        Naming the field, its value and what is allowed.
    """
    if name == "delay":
        return whole("delay", value, 0, 10_000, "sampling periods")
    if name == "max_force":
        return positive_or_inf("max_force", value, "N")
    unit = "m" if name == "position_resolution" else "N"
    v = nonnegative(name, value, unit)
    if name != "coulomb_friction" and 0.0 < v < 1e-15:
        raise fail(name, v, f"0 (ideal) or >= 1e-15 {unit}")
    return v


@dataclass(frozen=True)
class Device:
    """A sampled-data haptic device: planar 2-DOF ([x, z]) or 3-DOF ([x, y, z]).

    Parameters
    ----------
    mass : float or array_like, shape (2, 2) or (3, 3)
        Mass matrix M at the handle (kg), symmetric positive definite; a scalar means
        isotropic (of ``dimension``).
    damping : float or array_like, shape (2, 2) or (3, 3)
        Viscous damping matrix B at the handle (N s/m) while the handle is inside the
        virtual object; symmetric positive semi-definite.
    period : float
        Sampling period T (s), > 0 and at most 1 s (as :func:`critical_stiffness` takes it).
    delay : int, optional
        Whole sampling periods between reading a position and applying the force it
        produced; 0 means the force computed from the position sampled at kT is held over
        [kT, (k+1)T).
    position_resolution : float, optional
        delta (m): the controller sees positions rounded to multiples of delta; 0 = exact.
    force_resolution : float, optional
        b (N): commands are rounded to multiples of b per axis; 0 = exact.
    max_force : float, optional
        Largest command magnitude (N); larger commands are scaled down to it and counted.
    damping_outside : float or array_like, shape (2, 2), optional
        Damping while the handle is outside the virtual object (N s/m); defaults to
        ``damping``. The paper energises its eddy-current brakes only inside (Section V-A).
    first_resonance : float, optional
        F0 (Hz), the first structural mode (Section II); inf if not modelled.
    mode_damping_ratio : float, optional
        zeta > 0 of the first structural mode. When given (and ``first_resonance`` is
        finite) the device is simulated as two masses: the motor side M - M_h, where the
        command acts, the encoder senses, and the viscous damping and Coulomb friction act,
        joined to the handle side ``handle_mass`` M_h, which the operator holds, by a
        spring K_s = w^2 (M_m^-1 + M_h^-1)^-1 and a damper 2 zeta w (M_m^-1 + M_h^-1)^-1,
        w = 2 pi F0: the relative motion rings at F0 with damping ratio zeta. Default None:
        a rigid device. The sensing is collocated with the actuation (encoders on the
        motor shafts, as on the pantograph), non-collocated with the hand.
    handle_mass : float or array_like, shape (2, 2), optional
        M_h (kg), the handle-side inertia of the two-mass model; required with
        ``mode_damping_ratio``; M - M_h must stay positive definite.
    coulomb_friction : float, optional
        f_c (N), the handle's isotropic Coulomb friction with stiction, default 0. The
        simulator holds it over each sample like the command (a sampled Karnopp model,
        the C core's simulator loop, ``hx_sim.c``): the handle sticks while the friction needed to
        stop it within the sample is at most f_c, else slides against f_c. Its dissipation
        enters the energy balance. Abbott & Okamura (IEEE Trans. Robotics 21(5), 2005)
        tie the wall's passivity to it through the encoder resolution.
    stiffness_limit : float, optional
        The largest stiffness the device renders stably (N/m), if measured; default
        (None) the passivity bound sigma_0(B) / (2T) of Corollary 1 (see
        :attr:`max_stiffness`).
    name : str, optional
        A label for reports.
    dimension : int, optional
        2 (planar, positions [x, z]) or 3 (positions [x, y, z]); default: that of the
        matrices given, 2 when all are scalars. A 3-DOF device is analysed (Corollary 1
        with a 3x3 damping matrix), simulated and rendered over surfaces.
    details : dict, optional
        What a preset's model was built from (link lengths, rotor inertias, ...), for
        reports; not compared.

    Raises
    ------
    ParameterError
        For a non-symmetric or non-positive-definite mass, negative damping, a mass or damping
        given as a bool, T not in (0, 1] s, a negative or non-integer delay, negative
        resolutions, force limit or Coulomb friction.

    Notes
    -----
    Between samples the handle obeys M dv/dt = f_cmd + f_operator - B v; the simulator
    integrates it exactly (see :mod:`haptex.simulate`).
    """

    mass: np.ndarray
    damping: np.ndarray
    period: float
    delay: int = 0
    position_resolution: float = 0.0
    force_resolution: float = 0.0
    max_force: float = math.inf
    damping_outside: np.ndarray | None = None
    first_resonance: float = math.inf
    coulomb_friction: float = 0.0
    mode_damping_ratio: float | None = None
    handle_mass: np.ndarray | None = None
    name: str = "device"
    stiffness_limit: float | None = None
    details: dict = field(default_factory=dict, compare=False)
    dimension: int | None = None

    def __post_init__(self):
        dims = {np.ndim(v) and np.shape(v)[0] for v in (self.mass, self.damping, self.damping_outside,
                                                          self.handle_mass) if v is not None} - {0}
        if self.dimension is not None:
            dim = whole("dimension", self.dimension, 2, 3, "(2: planar [x, z], 3: [x, y, z])")
        elif len(dims) == 1 and dims <= {2, 3}:
            dim = int(next(iter(dims)))
        else:
            dim = 2
        object.__setattr__(self, "dimension", dim)
        object.__setattr__(self, "mass", _matrix("mass", self.mass, allow_zero=False, dim=dim))
        object.__setattr__(self, "damping", _matrix("damping", self.damping, allow_zero=True, dim=dim))
        out = self.damping if self.damping_outside is None else self.damping_outside
        object.__setattr__(self, "damping_outside", _matrix("damping_outside", out, allow_zero=True, dim=dim))
        object.__setattr__(self, "period", _period(self.period))
        for name in SCALAR_FIELDS:
            object.__setattr__(self, name, scalar_field(name, getattr(self, name)))
        object.__setattr__(self, "first_resonance", positive_or_inf("first_resonance", self.first_resonance, "Hz"))
        if self.handle_mass is not None:
            object.__setattr__(self, "handle_mass", _matrix("handle_mass", self.handle_mass, allow_zero=False, dim=dim))
        if self.mode_damping_ratio is not None:
            zeta = positive("mode_damping_ratio", self.mode_damping_ratio)
            object.__setattr__(self, "mode_damping_ratio", zeta)
            nyquist = 0.5 / self.period
            if not self.first_resonance < nyquist:
                raise fail("first_resonance", self.first_resonance,
                           f"below the Nyquist frequency {nyquist:g} Hz of T = {self.period:g} s for a simulated "
                           "structural mode (mode_damping_ratio given)")
            if self.handle_mass is None:
                raise ParameterError(f"handle_mass = None is not allowed with mode_damping_ratio = {zeta:g}: the "
                                     "two-mass model needs the handle-side inertia (kg)")
            if np.linalg.eigvalsh(self.mass - self.handle_mass).min() <= 0:
                raise fail("handle_mass", self.handle_mass.tolist(),
                           f"smaller than the device's mass {self.mass.tolist()} (the motor side M - M_h must "
                           "stay positive definite)")
        if self.stiffness_limit is not None:
            object.__setattr__(self, "stiffness_limit", positive("stiffness_limit", self.stiffness_limit, "N/m"))

    # -- derived numbers ---------------------------------------------------------------
    @property
    def structural_mode(self) -> bool:
        """True when the device is simulated as two masses (see ``mode_damping_ratio``)."""
        return self.mode_damping_ratio is not None

    def mode_matrices(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(M_m, M_h, K_s, C_s) of the two-mass model: motor- and handle-side masses (kg),
        the mode's stiffness (N/m) and damping (N s/m) matrices, each shape (n, n),
        n = :attr:`dimension`.

        Returns
        -------
        tuple of numpy.ndarray
            (M_m, M_h, K_s, C_s), each shape (n, n): kg, kg, N/m, N s/m.

        Raises
        ------
        ParameterError
            If the device has no structural mode.
        """
        if not self.structural_mode:
            raise ParameterError("mode_damping_ratio = None is not allowed here: the device is rigid")
        Mh = self.handle_mass
        Mm = self.mass - Mh
        red = np.linalg.inv(np.linalg.inv(Mm) + np.linalg.inv(Mh))
        w = 2 * math.pi * self.first_resonance
        Ks = w * w * red
        Cs = 2 * self.mode_damping_ratio * w * red
        return Mm, Mh, 0.5 * (Ks + Ks.T), 0.5 * (Cs + Cs.T)

    @property
    def min_damping(self) -> float:
        """sigma_0(B): the smallest singular value of the inside damping matrix (N s/m)."""
        return float(np.linalg.svd(self.damping, compute_uv=False).min())

    @property
    def passivity_limit(self) -> float:
        """sigma_0(B) / (2 T) (N/m): the bound on ||J||_2 of Corollary 1 (eq. 1)."""
        return self.min_damping / (2 * self.period)

    @property
    def max_stiffness(self) -> float:
        """A_0 of Section II-B (N/m): ``stiffness_limit`` if given, else sigma_0(B) / (2T)."""
        return self.passivity_limit if self.stiffness_limit is None else self.stiffness_limit

    def replace(self, **changes) -> Device:
        """A copy with some parameters changed (validated again).

        Parameters
        ----------
        **changes
            Constructor parameters (``mass``, ``damping``, ``period``, ``delay``, ...) and their
            new values, in SI units.

        Returns
        -------
        Device
            The new device.
        """
        fields = {k: getattr(self, k) for k in ("mass", "damping", "period", "delay", "position_resolution",
                                                "force_resolution", "max_force", "first_resonance",
                                                "coulomb_friction", "mode_damping_ratio", "handle_mass", "name",
                                                "stiffness_limit", "dimension")}
        fields["damping_outside"] = None if np.array_equal(self.damping_outside, self.damping) else self.damping_outside
        if "damping" in changes and "damping_outside" not in changes and fields["damping_outside"] is None:
            fields["damping_outside"] = None
        details = changes.pop("details", self.details)
        fields.update(changes)
        return Device(**fields, details=details)

    def planar(self) -> Device:
        """A 3-DOF device seen in its x-z plane ([x, z], for profiles), y left free.

        With y free (no force along it), the handle's in-plane acceleration is the x-z block
        of M^-1 times the force: the planar mass is M_p = ((M^-1)_xz)^-1; the damping's
        power for in-plane velocities is the x-z block of B. A 2-DOF device is returned as
        is.

        Returns
        -------
        Device
            Of dimension 2, with the same period, delay, resolutions, limits and friction.
        """
        if self.dimension == 2:
            return self
        ix = np.ix_([0, 2], [0, 2])

        def mass(M):
            return None if M is None else np.linalg.inv(np.linalg.inv(M)[ix])

        changes = {"mass": mass(self.mass), "damping": self.damping[ix], "damping_outside": self.damping_outside[ix],
                   "handle_mass": mass(self.handle_mass), "dimension": 2, "details": {**self.details, "planar": True}}
        return self.replace(**changes)

    # -- presets -----------------------------------------------------------------------
    @classmethod
    def point_mass(cls, mass: float = 0.1, damping: float = 0.5, period: float = 1e-4, **kw) -> Device:
        """An isotropic point mass.

        Parameters
        ----------
        mass : float
            kg (default 0.1 kg, a light handle).
        damping : float
            N s/m (default 0.5).
        period : float
            s (default 1e-4, the paper's 10 kHz).
        **kw
            Any other :class:`Device` parameter.
        """
        return cls(mass=mass, damping=damping, period=period, name=kw.pop("name", "point mass"), **kw)

    @classmethod
    def pantograph(cls, joint_damping: float = 4.7e-3, joint_damping_outside: float = 0.0, period: float = 1e-4,
                   position_resolution: float = 10e-6, link_proximal: float = 0.10, link_distal: float = 0.14,
                   base: float = 0.05, rotor_inertia: float = 1.4e-5, link_mass: float = 0.02,
                   handle_mass: float = 0.02, working_point=(0.0, 0.15), **kw) -> Device:
        """A five-bar planar pantograph, its Cartesian mass and damping at a working point.

        Two motors at (-base/2, 0) and (+base/2, 0) drive proximal links of length
        ``link_proximal``; distal links of length ``link_distal`` meet at the handle. With
        J = d p / d theta the linkage Jacobian at the handle's working point,

            M_x = J^-T diag(I_1, I_2) J^-1 + m_h I,     B_x = J^-T B_theta J^-1,

        with I_j = rotor inertia + link_mass * link_proximal^2 / 3 (a uniform rod about
        the motor axis) and m_h = handle_mass + link_mass (the two distal links lumped
        half each at the handle, the other halves at the elbows and ignored).

        Parameters
        ----------
        joint_damping : float
            Damping of each motor joint while inside the virtual object (N m s/rad); the
            paper uses 4.7e-3 (Section V-A) and 4.0e-3 (V-B, V-C) from eddy-current brakes.
        joint_damping_outside : float
            Joint damping outside (N m s/rad); 0: the brakes are off outside (V-A).
        period : float
            T (s), default 1e-4 (the paper's 10 kHz).
        position_resolution : float
            delta (m), default 10 um (Section V: better than 15 um).
        link_proximal, link_distal, base : float
            Link lengths and motor separation (m).
        rotor_inertia : float
            kg m^2 per motor.
        link_mass, handle_mass : float
            kg.
        working_point : (float, float)
            Handle position (m) in the linkage frame where the matrices are evaluated.
        **kw
            Other :class:`Device` parameters (delay, force_resolution, max_force, ...);
            ``first_resonance`` defaults to 400 Hz, the 3 dB flat band the paper reports
            for its device (Section V), and ``handle_mass`` to m_h I: with
            ``mode_damping_ratio`` the linkage becomes two masses, the motors' reflected
            inertia J^-T diag(I_1, I_2) J^-1 on one side and the handle on the other.

        Notes
        -----
        The defaults are documented, plausible values, not the published drawings of the
        paper's device (the Pantograph Mk-II of Campion, Wang & Hayward, IROS 2005, ref.
        [33]): 10 cm and 14 cm links on motors 5 cm apart give a workspace of about
        10 x 15 cm around the working point; 1.4e-5 kg m^2 is the rotor inertia of a
        40 mm graphite-brush DC motor of the kind used in direct-drive haptic devices;
        20 g aluminium links. At the default working point M_x is about 0.05 kg and
        sigma_0(B_x) / (2T) about 2.1 kN/m for 4.7 mN m s: just above the
        kappa_0 = 2 kN/m that the paper finds passive for W (Section V-A).

        Raises
        ------
        ParameterError
            For non-positive lengths or masses, or a working point the linkage cannot reach.
        """
        a1 = positive("link_proximal", link_proximal, "m")
        a2 = positive("link_distal", link_distal, "m")
        d = nonnegative("base", base, "m")
        for name, value in (("link_proximal", a1), ("link_distal", a2), ("base", d)):
            if value > MAX_LENGTH:
                raise fail(name, value, f"a length of at most {MAX_LENGTH:g} m (far beyond any haptic workspace)")
        inertia = positive("rotor_inertia", rotor_inertia, "kg m^2")
        ml = nonnegative("link_mass", link_mass, "kg")
        mh = positive("handle_mass", handle_mass, "kg")
        bj = nonnegative("joint_damping", joint_damping, "N m s/rad")
        bj_out = nonnegative("joint_damping_outside", joint_damping_outside, "N m s/rad")
        J, angles = five_bar_jacobian(a1, a2, d, working_point)  # (which names a working point that is not one)
        p = np.asarray(working_point, dtype=np.float64)
        I_j = inertia + ml * a1 * a1 / 3
        M, B = _cartesian(J, I_j * np.eye(2), bj * np.eye(2), mh + ml)
        _, B_out = _cartesian(J, I_j * np.eye(2), bj_out * np.eye(2), mh + ml)
        details = {"link_proximal": a1, "link_distal": a2, "base": d, "rotor_inertia": inertia,
                   "link_mass": ml, "handle_mass": mh, "joint_damping": bj, "joint_damping_outside": bj_out,
                   "working_point": p.tolist(), "joint_angles": angles.tolist(), "jacobian": J.tolist()}
        kw.setdefault("first_resonance", 400.0)
        kw.setdefault("handle_mass", (mh + ml) * np.eye(2))  # the handle side of a structural mode
        return cls(mass=M, damping=B, damping_outside=B_out, period=period, position_resolution=position_resolution,
                   name=kw.pop("name", "pantograph"), details=details, **kw)

    @classmethod
    def serial_arm(cls, link_upper: float = 0.14, link_fore: float = 0.14, joint_inertia=(1.0e-3, 6.5e-4, 6.5e-4),
                   tip_mass: float = 0.02, joint_damping: float = 2e-4, joint_angles=(0.0, 0.0, 0.0),
                   period: float = 1e-3, position_resolution: float = 30e-6, max_force: float = 8.5,
                   coulomb_friction: float = 0.04, stiffness_limit: float = 3500.0, **kw) -> Device:
        """A serial 3-DOF arm in the style of the Phantom Premium 1.0 / Touch, its Cartesian
        mass and damping at a configuration.

        Kinematics (base yaw theta_1, shoulder theta_2, elbow theta_3 measured from the base
        as on the Phantom's parallelogram drive; x lateral, y away from the base, z up, the
        virtual surface's normal), r = l_1 cos theta_2 + l_2 sin theta_3:

            p = [r sin theta_1, r cos theta_1, l_1 sin theta_2 - l_2 cos theta_3],

        and with J = dp/dtheta (:func:`serial_arm_kinematics`)
        M_x = J^-T diag(I) J^-1 + m_tip I, B_x = J^-T (b I) J^-1: the inertia depends on the
        configuration.

        Parameters
        ----------
        link_upper, link_fore : float
            l_1, l_2 (m).
        joint_inertia : (float, float, float)
            Inertia about each joint axis, motor and cable drive reflected (kg m^2).
        tip_mass : float
            Gimbal and stylus (kg).
        joint_damping : float
            Viscous damping of each joint (N m s/rad).
        joint_angles : (float, float, float)
            The configuration (rad) where the matrices are evaluated; default the home pose
            (upper arm horizontal, forearm down), where they are diagonal.
        period, position_resolution, max_force, coulomb_friction, stiffness_limit : float
            Device parameters (s, m, N, N, N/m); the defaults are the Phantom Premium 1.0's
            published ones (below).
        **kw
            Other :class:`Device` parameters (delay, force_resolution, first_resonance, ...).

        Notes
        -----
        Published (SensAble Technologies, PHANTOM Premium 1.0 specifications): nominal
        position resolution 0.03 mm, maximum force 8.5 N, stiffness 3.5 N/mm, backdrive
        friction 0.04 N, apparent mass at the tip < 75 g, workspace 25 x 18 x 13 cm, and the
        1 kHz servo rate of its OpenHaptics/GHOST loop. Chosen (plausible, not published):
        14 cm links, the joint inertias (which give 53-71 g of apparent mass at home, inside
        the published bound) and the joint damping. Identification of a Premium 1.5:
        M. C. Cavusoglu, D. Feygin and F. Tendick, "A critical study of the mechanical and
        electrical properties of the PHANToM haptic interface and improvements for high
        performance control", Presence 11(6), 2002. For a Geomagic Touch use its published
        0.055 mm, 3.3 N, 1.02-2.31 N/mm, 0.26 N backdrive friction and about 45 g.

        Raises
        ------
        ParameterError
            For non-positive lengths or inertias, or a singular configuration.
        """
        l1 = positive("link_upper", link_upper, "m")
        l2 = positive("link_fore", link_fore, "m")
        I = np.array([positive(f"joint_inertia[{i}]", v, "kg m^2") for i, v in enumerate(_triple("joint_inertia", joint_inertia))])
        mt = nonnegative("tip_mass", tip_mass, "kg")
        bj = nonnegative("joint_damping", joint_damping, "N m s/rad")
        q = np.array(_triple("joint_angles", joint_angles), dtype=np.float64)
        p, J = serial_arm_kinematics(l1, l2, q)
        M, B = _cartesian(J, np.diag(I), bj * np.eye(3), mt)
        details = {"link_upper": l1, "link_fore": l2, "joint_inertia": I.tolist(), "tip_mass": mt,
                   "joint_damping": bj, "joint_angles": q.tolist(), "position": p.tolist(), "jacobian": J.tolist()}
        return cls(mass=M, damping=B, period=period, position_resolution=position_resolution, max_force=max_force,
                   coulomb_friction=coulomb_friction, stiffness_limit=stiffness_limit,
                   name=kw.pop("name", "serial arm"), details=details, **kw)

    @classmethod
    def delta(cls, base_radius: float = 0.06, effector_radius: float = 0.02, link_upper: float = 0.10,
              link_fore: float = 0.13, joint_inertia: float = 4e-5, effector_mass: float = 0.06,
              joint_damping: float = 5e-5, working_point=(0.0, 0.0, -0.12), period: float = 1e-3,
              position_resolution: float = 60e-6, max_force: float = 8.9, **kw) -> Device:
        """A 3-DOF delta in the style of the Novint Falcon / Force Dimension delta, its
        Cartesian mass and damping at a working point.

        Three motors at 0, 120 and 240 degrees on a circle of radius R (the base, at z = 0,
        z up) swing upper arms of length a in vertical planes; parallelogram forearms of
        length b join them to an effector of radius r that stays parallel to the base. Arm
        i's constraint |p + r u_i - e_i(theta_i)| = b gives, differentiated, the Jacobian
        J = A^-1 diag((p + r u_i - e_i) . de_i/dtheta_i) (:func:`delta_kinematics`), and
        M_x = J^-T (I_j I) J^-1 + m_e I, B_x = J^-T (b_j I) J^-1. At the centre of the
        workspace the three-fold symmetry makes M_x and B_x diagonal with equal x and y
        entries.

        Parameters
        ----------
        base_radius, effector_radius, link_upper, link_fore : float
            R, r, a, b (m).
        joint_inertia : float
            Inertia of each motor and upper arm about its axis (kg m^2).
        effector_mass : float
            Effector, grip and the forearms' share (kg).
        joint_damping : float
            N m s/rad per joint.
        working_point : (float, float, float)
            The effector's position (m) where the matrices are evaluated, below the base.
        period, position_resolution, max_force : float
            s, m, N; the defaults are the Falcon's published figures (below).
        **kw
            Other :class:`Device` parameters.

        Notes
        -----
        Published (Novint Falcon specifications): 4 x 4 x 4 inch (10 cm) workspace, more
        than 2 lb (8.9 N) of force, position resolution better than 400 dpi (0.0635 mm,
        60 um taken), a 1 kHz servo loop over USB. Chosen (plausible, not published): the
        link lengths and radii (which give a workspace of about that size around the default
        working point), the inertias, masses and damping. S. Martin and N. Hillier,
        "Characterisation of the Novint Falcon haptic device for application as a robot
        manipulator", ACRA 2009, measure its kinematics. The Force Dimension delta.3 and
        omega.3 share the architecture with larger forces (12-20 N) and finer resolution
        (< 0.01-0.02 mm).

        Raises
        ------
        ParameterError
            For non-positive dimensions or a working point the arms cannot reach.
        """
        R = positive("base_radius", base_radius, "m")
        r = nonnegative("effector_radius", effector_radius, "m")
        a = positive("link_upper", link_upper, "m")
        b = positive("link_fore", link_fore, "m")
        Ij = positive("joint_inertia", joint_inertia, "kg m^2")
        me = nonnegative("effector_mass", effector_mass, "kg")
        bj = nonnegative("joint_damping", joint_damping, "N m s/rad")
        p = np.array(_triple("working_point", working_point), dtype=np.float64)
        J, angles = delta_kinematics(R, r, a, b, p)
        M, B = _cartesian(J, Ij * np.eye(3), bj * np.eye(3), me)
        details = {"base_radius": R, "effector_radius": r, "link_upper": a, "link_fore": b, "joint_inertia": Ij,
                   "effector_mass": me, "joint_damping": bj, "working_point": p.tolist(),
                   "joint_angles": angles.tolist(), "jacobian": J.tolist()}
        return cls(mass=M, damping=B, period=period, position_resolution=position_resolution, max_force=max_force,
                   name=kw.pop("name", "delta"), details=details, **kw)



def _triple(name: str, value) -> tuple[float, float, float]:
    arr = numbers(name, value, "three finite numbers")
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise fail(name, value, "three finite numbers")
    return tuple(float(v) for v in arr)


def _cartesian(J: np.ndarray, M_joint: np.ndarray, B_joint: np.ndarray, m_end: float):
    """(M_x, B_x) = (J^-T M_q J^-1 + m I, J^-T B_q J^-1), symmetrised: joint-space inertia
    and damping seen at the handle through the Jacobian J = dp/dq."""
    Jinv = np.linalg.inv(J)
    M = Jinv.T @ M_joint @ Jinv + m_end * np.eye(J.shape[0])
    B = Jinv.T @ B_joint @ Jinv
    return 0.5 * (M + M.T), 0.5 * (B + B.T)


def _closed_chain_jacobian(ends: np.ndarray, elbows: np.ndarray, delbows: np.ndarray) -> np.ndarray:
    """J = dp/dtheta of a parallel linkage whose i-th distal link keeps |ends_i - elbows_i|
    constant, ends_i moving rigidly with p and elbow i with motor angle theta_i:
    (ends_i - elbows_i) . dp = (ends_i - elbows_i) . de_i/dtheta_i dtheta_i, so
    J = A^-1 diag(a_i . de_i/dtheta_i) with A's rows a_i = ends_i - elbows_i."""
    A = ends - elbows
    return np.linalg.solve(A, np.diag(np.einsum("ij,ij->i", A, delbows)))


def serial_arm_kinematics(l1: float, l2: float, q) -> tuple[np.ndarray, np.ndarray]:
    """Forward kinematics of :meth:`Device.serial_arm`: the handle position p (m), shape (3,),
    and J = dp/dq (m/rad), shape (3, 3), at joint angles q (rad).

    Parameters
    ----------
    l1 : float
        Upper-arm length (m).
    l2 : float
        Forearm length (m).
    q : array_like, shape (3,)
        Joint angles (rad): base yaw, shoulder, elbow.

    Returns
    -------
    tuple of numpy.ndarray
        p (m), shape (3,), and J = dp/dq (m/rad), shape (3, 3).

    Raises
    ------
    ParameterError
        At a singular configuration (r = 0, or the arm stretched: cos theta_2 cos theta_3 +
        sin theta_2 sin theta_3 = 0, i.e. theta_2 - theta_3 = +-pi/2).
    """
    t1, t2, t3 = (float(v) for v in q)
    r = l1 * math.cos(t2) + l2 * math.sin(t3)
    p = np.array([r * math.sin(t1), r * math.cos(t1), l1 * math.sin(t2) - l2 * math.cos(t3)])
    J = np.array([[r * math.cos(t1), -l1 * math.sin(t2) * math.sin(t1), l2 * math.cos(t3) * math.sin(t1)],
                  [-r * math.sin(t1), -l1 * math.sin(t2) * math.cos(t1), l2 * math.cos(t3) * math.cos(t1)],
                  [0.0, l1 * math.cos(t2), l2 * math.sin(t3)]])
    if abs(np.linalg.det(J)) < 1e-9 * (l1 + l2) ** 3:
        raise fail("joint_angles", [t1, t2, t3], "a non-singular configuration (r > 0, the arm not stretched)")
    return p, J


def delta_kinematics(R: float, r: float, a: float, b: float, p) -> tuple[np.ndarray, np.ndarray]:
    """Jacobian dp/dtheta (m/rad), shape (3, 3), and motor angles (rad) of the delta of
    :meth:`Device.delta` at effector position p (m): arm i at azimuth phi_i = 2 pi i / 3,
    its elbow e_i = (R + a cos theta_i) u_i - a sin theta_i z (theta_i > 0 down), its forearm
    end p + r u_i.

    Parameters
    ----------
    R : float
        Base radius (m): the motors' distance from the axis.
    r : float
        Effector radius (m): the forearms' ends' distance from the effector's centre.
    a : float
        Upper-arm length (m).
    b : float
        Forearm length (m).
    p : array_like, shape (3,)
        Effector position (m).

    Returns
    -------
    tuple of numpy.ndarray
        J = dp/dtheta (m/rad), shape (3, 3), and the motor angles theta (rad), shape (3,).

    Raises
    ------
    ParameterError
        If p is not three finite real numbers, or an arm cannot reach it (named
        ``working_point``, as :meth:`Device.delta` takes it).
    """
    from scipy.optimize import brentq

    p = np.array(_triple("working_point", p))
    angles = np.empty(3)
    ends = np.empty((3, 3))
    elbows = np.empty((3, 3))
    delbows = np.empty((3, 3))
    z = np.array([0.0, 0.0, 1.0])
    for i in range(3):
        phi = 2 * math.pi * i / 3
        u = np.array([math.cos(phi), math.sin(phi), 0.0])
        end = p + r * u

        def gap(th, u=u, end=end):
            e = (R + a * math.cos(th)) * u - a * math.sin(th) * z
            return float(np.dot(end - e, end - e)) - b * b

        grid = np.linspace(-math.pi / 2, math.pi / 2, 181)
        vals = [gap(t) for t in grid]
        roots = [brentq(gap, grid[j], grid[j + 1], xtol=1e-15) for j in range(180) if vals[j] * vals[j + 1] < 0]
        if not roots:
            raise ParameterError(f"working_point = {p.tolist()} is not allowed: arm {i + 1} of the delta cannot reach "
                                 f"it with links {a:g} m and {b:g} m")
        th = max(roots, key=lambda t: math.cos(t))  # the elbow out, the upper arm nearest the horizontal
        angles[i] = th
        ends[i] = end
        elbows[i] = (R + a * math.cos(th)) * u - a * math.sin(th) * z
        delbows[i] = -a * math.sin(th) * u - a * math.cos(th) * z
    return _closed_chain_jacobian(ends, elbows, delbows), angles


def five_bar_jacobian(a1: float, a2: float, base: float, p) -> tuple[np.ndarray, np.ndarray]:
    """Jacobian d p / d theta (m/rad) of a symmetric five-bar linkage at handle position p.

    Parameters
    ----------
    a1, a2 : float
        Proximal and distal link lengths (m).
    base : float
        Distance between the two motor axes (m), placed at (-base/2, 0) and (base/2, 0).
    p : array_like, shape (2,)
        Handle position (m).

    Returns
    -------
    J : ndarray, shape (2, 2)
        Column j is the handle velocity per unit angular velocity of motor j.
    angles : ndarray, shape (2,)
        Motor angles (rad) of the elbows-out assembly.

    Raises
    ------
    ParameterError
        If p is not a finite position of shape (2,), or the linkage cannot reach it.

    Notes
    -----
    Each distal link keeps |p - e_j| = a2, so (p - e_j) . dp = (p - e_j) . de_j/dtheta_j
    dtheta_j; J = A^-1 diag((p - e_j) . de_j/dtheta_j) with A's rows (p - e_j)^T.
    """
    allowed = "a handle position [x, y] in metres, shape (2,), finite"
    given, p = p, numbers("working_point", p, allowed)
    if p.shape != (2,) or not np.isfinite(p).all():
        raise fail("working_point", p.tolist() if p.size <= 6 else given, allowed)
    bases = np.array([[-base / 2, 0.0], [base / 2, 0.0]])
    angles = np.empty(2)
    elbows = np.empty((2, 2))
    for j, b in enumerate(bases):
        r = p - b
        L = math.hypot(*r)
        if not (abs(a1 - a2) < L < a1 + a2):
            raise ParameterError(
                f"working_point = {p.tolist()} is not allowed: motor {j + 1} cannot reach it with links "
                f"{a1:g} m and {a2:g} m"
            )
        # angle at the motor between r and the proximal link (law of cosines)
        gam = math.acos((a1 * a1 + L * L - a2 * a2) / (2 * a1 * L))
        phi = math.atan2(r[1], r[0])
        th = phi + gam if j == 0 else phi - gam  # elbows out
        angles[j] = th
        elbows[j] = b + a1 * np.array([math.cos(th), math.sin(th)])
    de = a1 * np.column_stack([-np.sin(angles), np.cos(angles)])
    return _closed_chain_jacobian(np.tile(p, (2, 1)), elbows, de), angles


MAX_ANALYSED_DELAY = 1_000
"""The longest delay (sampling periods) whose closed loop :func:`critical_stiffness` analyses
(chosen: its eigenvalues are those of a matrix of delay + 3 rows, found by bisection; 26 s at
1,000 on this project's 2-core machine, hours at the 10,000 a :class:`Device` takes, which the
simulator runs in a ring buffer)."""


def critical_stiffness(mass: float, damping: float, period: float, delay: int = 0, *, handle_mass: float | None = None,
                       first_resonance: float | None = None, mode_damping_ratio: float | None = None,
                       virtual_damping: float = 0.0, hand=None) -> float:
    """Largest stable stiffness of a virtual wall on a sampled mass-damper (1 DOF), from the
    closed-loop poles.

    The device 1 / (m s^2 + b s), or the two-mass model of :class:`Device` (``mass`` the
    total, the viscous damping and the command on the motor side, the handle on the other
    side of the mode), is discretised exactly with a zero-order hold. The controller
    commands u_k = -kappa y_k - B_v (y_k - y_{k-1}) / T from the (motor-side) position y,
    applied ``delay`` samples later. With ``hand`` = (m_h, b_h, k_h) a hand grips the
    handle: its mass and damping move with the handle and its stiffness pulls it towards a
    fixed set-point. The returned kappa is where the largest eigenvalue of the discretised
    closed loop reaches the unit circle: the exact stability boundary of the linear sampled
    system (the boundary Gil et al., IEEE Trans. Control Systems Technology 12(4), 2004,
    and Hulin et al., IROS 2006, chart). For small bT/m, no delay and no virtual damping it
    tends to Colgate &
    Schenkel's 2b/T ("Passivity of a class of sampled-data systems", 1997); with delay d it
    is near Gil et al.'s (b + B_v) / (T (1/2 + d)).

    Parameters
    ----------
    mass : float
        m (kg), > 0: the device's apparent mass along the wall's normal.
    damping : float
        b (N s/m), >= 0: its viscous damping.
    period : float
        T (s), > 0.
    delay : int
        Whole samples of latency, >= 0.
    handle_mass, first_resonance, mode_damping_ratio : float, optional
        The structural mode (kg, Hz, 1), all three or none (see :class:`Device`).
    virtual_damping : float, optional
        B_v (N s/m), >= 0: the wall's damper (backward difference of the sensed position).
    hand : (float, float, float), optional
        (m_h kg, b_h N s/m, k_h N/m), each >= 0: a linear hand (e.g. ``Hand.impedance``).

    Returns
    -------
    float
        Critical stiffness (N/m); 0.0 when no positive stiffness is stable (no damping at
        all, or a virtual damper the sampled loop cannot hold).

    Raises
    ------
    ParameterError
        For a non-positive mass, a period not in (0, 1] s, negative damping or damping past
        1e100 m / T (the discretisation overflows), a delay not a whole number from 0 to
        :data:`MAX_ANALYSED_DELAY`, or an incomplete or out-of-range structural mode or hand.

    Examples
    --------
    A 0.1 kg point mass with 0.5 N s/m of damping sampled at 10 kHz: the wall's limit is close to
    Colgate & Schenkel's 2 b / T = 10 kN/m:

    >>> round(hx.critical_stiffness(mass=0.1, damping=0.5, period=1e-4))
    10001
    """
    m = positive("mass", mass, "kg")
    b = nonnegative("damping", damping, "N s/m")
    T = _period(period)
    if b * T / m > 1e100:  # (e^{A T}'s entries overflow: scipy's expm returns NaN)
        raise fail("damping", damping, f"at most {1e100 * m / T:g} N s/m for this mass and period (b T / m <= 1e100)")
    d = whole("delay", delay, 0, MAX_ANALYSED_DELAY, "sampling periods of latency")
    bv = nonnegative("virtual_damping", virtual_damping, "N s/m")
    if hand is None:
        hm = hb = hk = 0.0
    else:
        try:
            hm, hb, hk = (float(v) for v in hand)
        except (TypeError, ValueError):
            raise fail("hand", hand, "(mass kg, damping N s/m, stiffness N/m)") from None
        hm, hb, hk = (nonnegative(n, v, u) for n, v, u in (("hand mass", hm, "kg"), ("hand damping", hb, "N s/m"),
                                                          ("hand stiffness", hk, "N/m")))
    if b + hb + bv == 0.0:
        return 0.0  # an undamped mass under a sampled spring is unstable at every stiffness
    mode = (handle_mass, first_resonance, mode_damping_ratio)
    if any(v is not None for v in mode):
        if any(v is None for v in mode):
            raise ParameterError("handle_mass, first_resonance and mode_damping_ratio are allowed only together: "
                                 "the two-mass model needs all three")
        A, Bu = _two_mass_plant(m, b, T, *mode, hm, hb, hk)
    else:
        M = m + hm
        A = np.array([[0.0, 1.0], [-hk / M, -(b + hb) / M]])
        Bu = np.array([0.0, 1.0 / M])
    Phi, Gam = _zoh(A, Bu, T)
    n = A.shape[0]
    size = n + 1 + d  # plant, the last sensed position, the commands in flight

    def radius(k):
        L = np.zeros((size, size))
        L[:n, :n] = Phi
        u_row = np.zeros(size)
        u_row[0] = -(k + bv / T)  # the position sensed now (x_0: the motor side)
        u_row[n] = bv / T
        if d == 0:
            L[:n] += np.outer(Gam, u_row)
        else:
            L[:n, n + d] = Gam  # the oldest command in flight is applied
            L[n + 1] = u_row
            for j in range(2, d + 1):
                L[n + j, n + j - 1] = 1.0
        L[n, 0] = 1.0
        return float(np.abs(np.linalg.eigvals(L)).max()) - 1.0

    return _stability_edge(radius, 2 * (b + hb + bv) / T)


def _zoh(A: np.ndarray, Bu: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """(Phi, Gamma): the exact zero-order-hold discretisation of dx/dt = A x + Bu u."""
    from .core import expm

    n = A.shape[0]
    big = np.zeros((n + 1, n + 1))
    big[:n, :n] = A
    big[:n, n] = Bu
    E = expm(big * T)
    return E[:n, :n], E[:n, n]


def _two_mass_plant(m, b, T, handle_mass, first_resonance, zeta, hm, hb, hk):
    """(A, Bu) of the two-mass device, state [x_m, v_m, x_h, v_h]; the hand (hm, hb, hk) on
    the handle side."""
    mh = positive("handle_mass", handle_mass, "kg")
    if not mh < m:
        raise fail("handle_mass", handle_mass, f"below the total mass {m:g} kg")
    f0 = positive("first_resonance", first_resonance, "Hz")
    if not f0 < 0.5 / T:
        raise fail("first_resonance", f0, f"below the Nyquist frequency {0.5 / T:g} Hz")
    zeta = positive("mode_damping_ratio", zeta)
    mm = m - mh
    red = mm * mh / m
    w = 2 * math.pi * f0
    ks, cs = w * w * red, 2 * zeta * w * red  # the device's mode, whoever holds it
    mh_t = mh + hm
    A = np.array([[0.0, 1.0, 0.0, 0.0],
                  [-ks / mm, -(b + cs) / mm, ks / mm, cs / mm],
                  [0.0, 0.0, 0.0, 1.0],
                  [ks / mh_t, cs / mh_t, -(ks + hk) / mh_t, -(cs + hb) / mh_t]])
    return A, np.array([0.0, 1.0 / mm, 0.0, 0.0])  # the command acts on the motor side


def _stability_edge(radius, guess: float) -> float:
    """The stiffness where ``radius`` (the closed loop's largest eigenvalue modulus minus 1)
    crosses zero: bracketed by doubling and halving from ``guess`` (N/m), then Brent's
    method; 0.0 when even a vanishing stiffness is unstable, inf when none up to 1e12 times the
    guess is unstable."""
    from scipy.optimize import brentq

    hi = guess
    while radius(hi) < 0:
        hi *= 2
        if hi > 1e12 * guess:  # (no sampled loop of a mass stays stable that far: a guard)
            return math.inf
    lo = hi
    while radius(lo) >= 0:
        lo /= 2
        if lo < 1e-9 * guess:
            return 0.0
    return brentq(radius, lo, hi, xtol=1e-12 * hi, rtol=1e-13)
