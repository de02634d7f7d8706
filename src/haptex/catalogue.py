"""Device and hand presets, every number with its status and source.

The numbers live in one data file, ``haptex/data/devices.toml``: each is *published* (a
manufacturer's specifications sheet or a paper, named), *identified* (measured on the
device in a paper, named) or *chosen* (not published, or not available to this project,
with the reason). A manufacturer's recommended stiffness (``rated_stiffness``, and CHAI3D's
device table) is reported beside haptex's limits, never used as an input.

Kinematic presets get their Cartesian mass and damping from the linkage at a pose
(:meth:`Device.serial_arm`, :meth:`Device.delta`, :meth:`Device.pantograph`): the inertia
varies with the pose. Their joint inertias and dampings are scaled so that the home pose
shows the preset's apparent mass and damping (the mean of the diagonal of M_x and B_x).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache

import numpy as np

from ._validation import ParameterError, a_path, fail, renamed, whole
from .devices import Device

STATUSES = ("published", "identified", "chosen")
"""What a preset's number is: stated by its source, measured on the device by its source,
or chosen by haptex (with the reason)."""
DEFAULT_HAND = "light-touch"
"""The hand assumed by the stable limits when none is named: the least stabilising grip
that still holds a stylus (chosen)."""
MODELS = ("point-mass", "serial-arm", "delta", "pantograph")

_UNITS = {  # figure: SI unit (None: text)
    "workspace": None, "period": "s", "max_force": "N", "continuous_force": "N", "position_resolution": "m",
    "apparent_mass": "kg", "damping": "N*s/m", "coulomb_friction": "N", "link_upper": "m", "link_fore": "m",
    "rated_stiffness": "N/m", "chai3d_stiffness": "N/m", "rated_damping": "N*s/m", "joint_damping": "N*m*s",
    "first_resonance": "Hz", "mass": "kg", "stiffness": "N/m",
}
TIP_SHARE = 0.2
"""Share of a serial arm's apparent mass at the tip (gimbal and stylus), the rest reflected
from the joints (chosen: not published)."""
EFFECTOR_SHARE = 0.3
"""Share of a delta's apparent mass in its effector, grip and forearms, the rest reflected
from the motors and upper arms (chosen: not published)."""


@dataclass(frozen=True)
class Figure:
    """One number of a preset or hand.

    Parameters
    ----------
    name : str
        The parameter (``period``, ``max_force``, ...).
    value : float or str
        In SI units (``unit``), or text (the workspace).
    unit : str or None
        The SI unit; None for text.
    status : str
        One of :data:`STATUSES`.
    source : str or None
        Key of the source in :func:`sources` (published and identified numbers).
    note : str
        Why a chosen number was chosen, or what the source's figure means.
    also : str or None
        A second source giving the same or a nearby figure.
    written : str
        The value as written in the data file, with its unit.
    """

    name: str
    value: float | str
    unit: str | None
    status: str
    source: str | None = None
    note: str = ""
    also: str | None = None
    written: str = ""

    def as_dict(self) -> dict:
        """The figure as JSON-ready data, with its source's full reference.

        Returns
        -------
        dict
            Value (SI), unit, status (published, identified or chosen) and the source's full
            reference.
        """
        src = sources()
        return {"value": self.value, "unit": self.unit, "written": self.written, "status": self.status,
                "source": src.get(self.source) if self.source else None,
                "also": src.get(self.also) if self.also else None, "note": self.note}


@dataclass(frozen=True)
class Hand:
    """A hand gripping the handle: a linear mass-damper-spring (1 DOF per axis, isotropic).

    Parameters
    ----------
    key, label : str
        Its name in :func:`hands` and a description.
    mass : float
        m_h (kg) moving with the handle.
    damping : float
        b_h (N s/m).
    stiffness : float
        k_h (N/m) towards the hand's set-point.
    figures : dict of str to Figure
        The three numbers with their sources.
    """

    key: str
    label: str
    mass: float
    damping: float
    stiffness: float
    figures: dict = field(default_factory=dict, compare=False)

    @property
    def impedance(self) -> tuple[float, float, float]:
        """(m_h kg, b_h N s/m, k_h N/m), the ``hand`` of :func:`~haptex.critical_stiffness`."""
        return (self.mass, self.damping, self.stiffness)

    @property
    def none(self) -> bool:
        """True for the empty hand (the device alone)."""
        return self.mass == 0 and self.damping == 0 and self.stiffness == 0

    def attach(self, device: Device) -> Device:
        """The device with the hand's mass moving with the handle (on every axis; on the
        handle side of a structural mode): what the simulator moves when this hand holds
        it. The hand's damping and stiffness act through :meth:`operator`.

        Parameters
        ----------
        device : Device
            The device the hand holds.

        Returns
        -------
        Device
            Named "DEVICE + HAND".
        """
        eye = np.eye(device.dimension)
        changes = {"mass": device.mass + self.mass * eye, "name": f"{device.name} + {self.key}"}
        if device.handle_mass is not None:
            changes["handle_mass"] = device.handle_mass + self.mass * eye
        return device.replace(**changes)

    def operator(self, depth: float = 0.0, velocity: float = 0.0, dimension: int = 2):
        """The hand's spring and damper towards its set-point: a
        :func:`~haptex.operators.ScanningHand` pressing ``depth`` (m) below the surface and
        moving along x at ``velocity`` (m/s); use it with :meth:`attach`.

        Parameters
        ----------
        depth : float, optional
            How far (m, >= 0) below the surface the set-point presses.
        velocity : float, optional
            The set-point's speed along x (m/s).
        dimension : int, optional
            2 ([x, z]) or 3 ([x, y, z]).

        Returns
        -------
        Operator
            A :func:`~haptex.operators.ScanningHand` with this hand's stiffness (N/m) and
            damping (N s/m).

        Raises
        ------
        ParameterError
            For a negative depth or a non-finite velocity.
        """
        from .operators import ScanningHand

        return ScanningHand(self.stiffness, self.damping, velocity=velocity, depth=depth, dimension=dimension)


def _named_pose():
    """A pose refused by the device's constructor, under the name the preset takes it by:
    ``pose`` (the constructors' ``working_point`` or ``joint_angles``, which a user of
    :meth:`Preset.device` never wrote)."""
    return renamed("pose", "working_point", "joint_angles", note=" (the device's {inner})")


@dataclass(frozen=True)
class Preset:
    """A device preset: its sourced figures and the :class:`Device` they make.

    Parameters
    ----------
    key, label : str
        Its name in :func:`presets` and the product's name.
    model : str
        One of :data:`MODELS`: how the Cartesian mass and damping are modelled.
    figures : dict of str to Figure
        Every number, with its status and source.
    rated_gap : str
        Why the predicted wall limit sits more than
        :data:`haptex.limits.RATED_RATIO` times from the rated figure ("" when it does not).
    """

    key: str
    label: str
    model: str
    figures: dict = field(default_factory=dict, compare=False)
    rated_gap: str = ""

    def value(self, name: str, default=None):
        """A figure's value in SI units, or ``default`` when the preset has none.

        Parameters
        ----------
        name : str
            The figure's name, as the preset's table has it (e.g. ``max_force``, ``damping``).
        default : optional
            What to return when the preset gives no such figure.

        Returns
        -------
        float or object
            The figure's value (SI units), or ``default``.

        Raises
        ------
        ParameterError
            For a name no preset can have (a misspelling: the names a device file may give).
        """
        if name not in _UNITS:
            raise fail("name", name, "a figure's name: " + ", ".join(_UNITS))
        f = self.figures.get(name)
        return default if f is None else f.value

    @property
    def dimension(self) -> int:
        """Degrees of freedom of the handle's translation (2: planar, 3)."""
        return 2 if self.model == "pantograph" else 3

    @property
    def rated_stiffness(self) -> float | None:
        """The manufacturer's stiffness figure (N/m), or CHAI3D's when the manufacturer's
        is missing; None when neither is published. Reported, never an input."""
        return self.value("rated_stiffness", self.value("chai3d_stiffness"))

    def device(self, delay: int = 0, pose=None, dimension: int | None = None) -> Device:
        """The device at a pose.

        Parameters
        ----------
        delay : int, optional
            Whole sampling periods of computation delay (the presets' own: 0).
        pose : array_like, optional
            Joint angles (rad, 3: serial arm) or the handle's position (m: delta, 3;
            pantograph, 2) where the mass and damping are evaluated; default the home pose.
        dimension : int, optional
            3 (default for 3-DOF devices) or 2: the device in its x-z plane
            (:meth:`Device.planar`), for profiles.

        Returns
        -------
        Device
            Named after the preset, with ``details["preset"]``.

        Raises
        ------
        ParameterError
            For a pose the linkage cannot reach, a pose given to a point mass, a dimension
            the device does not have, or an invalid delay.
        """
        v = self.value
        common = {"period": v("period"), "position_resolution": v("position_resolution", 0.0),
                  "max_force": v("max_force", math.inf), "coulomb_friction": v("coulomb_friction", 0.0),
                  "delay": delay}
        if self.model == "point-mass":
            if pose is not None:
                raise fail("pose", pose, f"None for {self.key!r}: a point mass has no kinematics")
            dim = 3 if dimension is None else dimension
            dev = Device.point_mass(mass=v("apparent_mass"), damping=v("damping"), dimension=dim, name=self.key,
                                    **common)
        elif self.model == "pantograph":
            if dimension not in (None, 2):
                raise fail("dimension", dimension, f"2 for {self.key!r}: a planar device")
            kw = {"working_point": pose} if pose is not None else {}
            with _named_pose():
                dev = Device.pantograph(joint_damping=v("joint_damping"),
                                        first_resonance=v("first_resonance", math.inf), name=self.key, **common, **kw)
        else:
            with _named_pose():
                dev = self._linkage(common, pose)
            if dimension == 2:
                dev = dev.planar()
            elif dimension not in (None, 3):
                raise fail("dimension", dimension, f"2 or 3 for {self.key!r}")
        return dev.replace(details={**dev.details, "preset": self.key})

    def _linkage(self, common: dict, pose) -> Device:
        """A serial arm or a delta whose home pose shows the preset's apparent mass and damping."""
        m_app, b_app = self.value("apparent_mass"), self.value("damping")
        if self.model == "serial-arm":
            shape = np.array([1.0e-3, 6.5e-4, 6.5e-4])  # the base joint heavier (chosen ratios)
            geo = {"link_upper": self.value("link_upper"), "link_fore": self.value("link_fore")}
            unit = Device.serial_arm(joint_inertia=shape, tip_mass=0.0, joint_damping=1.0, stiffness_limit=None,
                                     max_force=math.inf, coulomb_friction=0.0, **geo)
            k = (1 - TIP_SHARE) * m_app / _mean_diag(unit.mass)
            jd = b_app / _mean_diag(unit.damping)
            kw = {"joint_angles": pose} if pose is not None else {}
            return Device.serial_arm(joint_inertia=k * shape, tip_mass=TIP_SHARE * m_app, joint_damping=jd,
                                     stiffness_limit=None, name=self.key, **geo, **common, **kw)
        unit = Device.delta(joint_inertia=1.0, effector_mass=0.0, joint_damping=1.0, max_force=math.inf)
        k = (1 - EFFECTOR_SHARE) * m_app / _mean_diag(unit.mass)
        jd = b_app / _mean_diag(unit.damping)
        kw = {"working_point": pose} if pose is not None else {}
        return Device.delta(joint_inertia=k, effector_mass=EFFECTOR_SHARE * m_app, joint_damping=jd, name=self.key,
                            **common, **kw)

    def as_dict(self) -> dict:
        """The preset as JSON-ready data: every figure with its unit, status and source.

        Returns
        -------
        dict
            The preset's name, kind and figures, each with its value (SI), unit, status and
            source.
        """
        return {"key": self.key, "label": self.label, "model": self.model, "dimension": self.dimension,
                "figures": {k: f.as_dict() for k, f in self.figures.items()}}


def _mean_diag(M: np.ndarray) -> float:
    return float(np.trace(M) / M.shape[0])


@lru_cache(maxsize=1)
def _data() -> dict:
    import tomllib
    from importlib.resources import files

    return tomllib.loads(files("haptex").joinpath("data/devices.toml").read_text(encoding="utf-8"))


def sources() -> dict[str, str]:
    """Every source the presets cite: key to full reference.

    Returns
    -------
    dict of str to str
        Each source's key and its full reference.
    """
    return dict(_data()["sources"])


def _figures(table: dict, where: str) -> dict[str, Figure]:
    from ._units import parse_quantity

    out = {}
    for name, spec in table.items():
        if name in ("label", "model", "rated_gap"):
            continue
        if name not in _UNITS:
            raise ParameterError(f"{where}: figure {name!r} is not allowed: allowed are " + ", ".join(_UNITS))
        status = spec.get("status")
        if status not in STATUSES:
            raise fail(f"{where}: {name}.status", status, "one of " + ", ".join(STATUSES))
        if status != "chosen" and spec.get("source") not in _data()["sources"]:
            raise fail(f"{where}: {name}.source", spec.get("source"), "a key of [sources] for a "
                       f"{status} figure")
        if status == "chosen" and not spec.get("note"):
            raise ParameterError(f"{where}: {name} is chosen without a note: say why")
        unit = _UNITS[name]
        written = spec["value"]
        value = written if unit is None else parse_quantity(written, unit, f"{where}: {name}", require_unit=True)
        out[name] = Figure(name, value, unit, status, spec.get("source"), spec.get("note", ""), spec.get("also"),
                           written)
    return out


@lru_cache(maxsize=1)
def presets() -> dict[str, Preset]:
    """Every device preset, by key (``touch``, ``premium-1-5``, ``falcon``, ``omega-3``,
    ``delta-3``, ``sigma-7``, ``inverse3``, ``pantograph``, ``point-mass``)."""
    out = {}
    for key, table in _data()["presets"].items():
        if table.get("model") not in MODELS:
            raise fail(f"preset {key!r}: model", table.get("model"), "one of " + ", ".join(MODELS))
        out[key] = Preset(key, table["label"], table["model"], _figures(table, f"preset {key!r}"),
                          table.get("rated_gap", ""))
    return out


@lru_cache(maxsize=1)
def hands() -> dict[str, Hand]:
    """Every hand model, by key (``none``, ``light-touch``, ``firm-grip``)."""
    out = {}
    for key, table in _data()["hands"].items():
        figs = _figures(table, f"hand {key!r}")
        out[key] = Hand(key, table["label"], figs["mass"].value, figs["damping"].value, figs["stiffness"].value, figs)
    return out


def preset(name: str) -> Preset:
    """The preset called ``name``.

    Parameters
    ----------
    name : str
        A preset of ``haptex devices`` (``touch``, ``falcon``, ``omega-3``, ...).

    Returns
    -------
    Preset
        The preset.

    Raises
    ------
    ParameterError
        For a name that is not a preset, listing the ones that are.
    """
    table = presets()
    if not isinstance(name, str) or name not in table:
        raise fail("device", name, "one of " + ", ".join(table) + (did_you_mean(name) if isinstance(name, str) else ""))
    return table[name]


def checked_device(device) -> Device:
    """``device`` as given where it is a :class:`~haptex.Device`, else a refusal naming the call
    that makes one: the first check of every public function that takes a device.

    Parameters
    ----------
    device : Device
        The device (a preset's: ``haptex.catalogue.preset("touch").device()``).

    Returns
    -------
    Device
        ``device`` itself.

    Raises
    ------
    ParameterError
        For anything else: for a preset's name (or a product's, :func:`meant`) the call that
        makes that preset's device, ``haptex.catalogue.preset('touch').device()``; otherwise the
        call with a preset's name in it, and where the presets are listed.
    """
    if isinstance(device, Device):
        return device
    keys = ([device] if isinstance(device, str) and device in presets() else
            meant(device) if isinstance(device, str) else [])
    made = " or ".join(f"haptex.catalogue.preset({k!r}).device()" for k in keys) or \
        "haptex.catalogue.preset(NAME).device(), NAME a preset of haptex.catalogue.presets()"
    raise fail("device", device, f"a haptex.Device ({made}; .device(dimension=2) over a profile: its x-z plane)")


def meant(name: str) -> list[str]:
    """The presets a device name that is not one of their keys may mean, from the products'
    names (:attr:`Preset.label`): a key or a word of a label equal to ``name`` once both are
    lower case and without punctuation ("Touch", "omega.3", "omega3", "geomagic", "haply"; words
    of three characters or more, "the" aside), or that starts the name or that the name starts,
    four characters at least ("falcon3d", "novint-falcon"). "phantom" names two products: the
    PHANTOM Omni (now the Touch) and the PHANTOM Premium 1.5.

    Parameters
    ----------
    name : str
        A device as a user wrote it.

    Returns
    -------
    list of str
        The keys of the presets it may mean, in :func:`presets`' order; empty where none.
    """
    import re

    def bare(text):
        return re.sub(r"[^a-z0-9]", "", str(text).lower())

    typed = bare(name)
    if not typed:
        return []
    hits = []
    for key, p in presets().items():
        words = {w for w in (bare(w) for w in re.split(r"[\s(),]+", p.label)) if len(w) >= 3 and w != "the"}
        words.add(bare(key))
        if typed in words or any(len(w) >= 4 and (typed.startswith(w) or w.startswith(typed)) and len(typed) >= 4
                                 for w in words if not w.isdigit()):
            hits.append(key)
    return hits


def did_you_mean(name: str) -> str:
    """A refusal's remedy for a device name that is not a preset: the presets :func:`meant` finds.

    Parameters
    ----------
    name : str
        A device as a user wrote it.

    Returns
    -------
    str
        `` (did you mean 'touch' or 'premium-1-5'?)`` for "phantom"; "" where :func:`meant` finds
        no preset.
    """
    keys = meant(name)
    return f" (did you mean {' or '.join(repr(k) for k in keys)}?)" if keys else ""


def hand(name) -> Hand:
    """The hand called ``name`` (a :class:`Hand` is returned as is; None is ``none``).

    Parameters
    ----------
    name : str, Hand or None
        A hand of ``haptex devices`` (``none``, ``light-touch``, ``firm-grip``), a :class:`Hand`
        (returned as is) or None (``none``).

    Returns
    -------
    Hand
        The hand.

    Raises
    ------
    ParameterError
        For a name that is not a hand (or anything but a name, a Hand or None), listing the
        ones that are.
    """
    if isinstance(name, Hand):
        return name
    table = hands()
    if name is None:
        return table["none"]
    if not isinstance(name, str) or name not in table:
        raise fail("hand", name, "one of " + ", ".join(table) + " (or a haptex.catalogue.Hand)")
    return table[name]


def custom_hand(mass: float, damping: float, stiffness: float, name: str = "custom") -> Hand:
    """A hand of your own identification.

    Parameters
    ----------
    mass : float
        kg, in [0, 10] (a whole arm is a few kg).
    damping : float
        N s/m, in [0, 1000].
    stiffness : float
        N/m, in [0, 1e5].
    name : str, optional
        Its name in tables and device names.

    Returns
    -------
    Hand
        The hand (mass kg, damping N s/m, stiffness N/m), described as of your identification.

    Raises
    ------
    ParameterError
        For a value outside its physical range, naming it.
    """
    from ._validation import in_range

    m = in_range("hand mass", mass, 0.0, 10.0, "kg")
    b = in_range("hand damping", damping, 0.0, 1000.0, "N s/m")
    k = in_range("hand stiffness", stiffness, 0.0, 1e5, "N/m")
    return Hand(name, "a hand of the user's identification", m, b, k)


# -- device files ---------------------------------------------------------------------
_FILE_KEYS = {  # key: (SI unit, kind) -- kind: q quantity, m quantity or 2x2 matrix, i whole, x number, s text, p point
    "preset": (None, "s"), "name": (None, "s"),
    "mass": ("kg", "m"), "damping": ("N*s/m", "m"), "damping_outside": ("N*s/m", "m"), "period": ("s", "q"),
    "delay": (None, "i"), "position_resolution": ("m", "q"), "force_resolution": ("N", "q"),
    "max_force": ("N", "q"), "first_resonance": ("Hz", "q"), "coulomb_friction": ("N", "q"),
    "mode_damping_ratio": (None, "x"), "handle_mass": ("kg", "m"), "stiffness_limit": ("N/m", "q"),
    "joint_damping": ("N*m*s", "q"), "joint_damping_outside": ("N*m*s", "q"), "link_proximal": ("m", "q"),
    "link_distal": ("m", "q"), "base": ("m", "q"), "rotor_inertia": ("kg*m^2", "q"), "link_mass": ("kg", "q"),
    "working_point": ("m", "p"), "dimension": (None, "i"),
}
_PANTOGRAPH_ONLY = {"joint_damping", "joint_damping_outside", "link_proximal", "link_distal", "base",
                    "rotor_inertia", "link_mass", "working_point"}
_PRESETS = ("point-mass", "pantograph", "custom")
MAX_DEVICE_FILE = 1 << 20
"""Largest device file read (bytes): a device is a few lines."""


def device_from_file(path) -> Device:
    """A device described in a TOML file, every dimensional value with its unit.

    Parameters
    ----------
    path : str or Path
        A TOML file, e.g.::

            preset = "pantograph"          # or "point-mass", "custom" (give mass and damping), or a
                                           # product of haptex.catalogue.presets() ("falcon", ...)
            name = "our pantograph"
            joint_damping = "4.0 mN*m*s"   # pantograph: per joint, inside the wall
            period = "100 us"
            delay = 1                      # whole sampling periods
            coulomb_friction = "20 mN"
            first_resonance = "400 Hz"
            mode_damping_ratio = 0.05

        Quantities are strings with a unit ("50 g", "0.5 N*s/m"), the command line's rule:
        a bare number is refused unless it is 0. ``mass``, ``damping``, ``damping_outside``
        and ``handle_mass`` may be 2x2 tables of such strings. ``delay`` is a whole number,
        ``mode_damping_ratio`` a plain number, ``working_point`` (pantograph) a pair of
        lengths. Every other :class:`Device` and :meth:`Device.pantograph` parameter is
        accepted under its Python name. With a product preset (``"touch"``, ``"falcon"``,
        ...) the keys given replace the preset's figures (your unit's measured friction,
        say); ``mass`` and ``damping`` replace the Cartesian matrices at the home pose.

    Returns
    -------
    Device

    Raises
    ------
    ParameterError
        If ``path`` is not a path (a str or os.PathLike, PEP 519), the file is missing, too
        large, not TOML, names an unknown key (or a pantograph
        key for another preset), or a value is missing its unit, has the wrong dimension or
        is out of range (the :class:`Device` checks).
    """
    import tomllib

    p = a_path("device", path, "a TOML device file's path")
    if not p.is_file():
        raise ParameterError(f"device = {str(path)!r} is not allowed: "
                             f"{'a directory' if p.is_dir() else 'no such file'} (a TOML device file)")
    if p.stat().st_size > MAX_DEVICE_FILE:
        raise fail("device", str(path), f"a TOML device file of at most {MAX_DEVICE_FILE} bytes")
    try:
        spec = tomllib.loads(p.read_text(encoding="utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise ParameterError(f"device = {str(path)!r} is not allowed: not a TOML file ({exc})") from None
    if not isinstance(spec, dict):
        raise ParameterError(f"device = {str(path)!r} is not allowed: a TOML table of device keys")
    return _device_from_table(spec, f"device file {str(path)!r}")


def _device_from_table(spec: dict, where: str) -> Device:
    """The device a table of :func:`device_from_file`'s keys describes (``where`` names it
    in errors: a device file, a sweep SPEC's [device] table)."""
    from ._units import parse_quantity

    if not isinstance(spec, dict):
        raise fail(where, spec, "a table of device keys (preset, mass, damping, period, ...)")
    spec = dict(spec)
    unknown = sorted(set(spec) - set(_FILE_KEYS))
    if unknown:
        raise ParameterError(f"{where}: key {unknown[0]!r} is not allowed: allowed keys are "
                             + ", ".join(_FILE_KEYS))
    preset = spec.pop("preset", "custom")
    products = [k for k in presets() if k not in _PRESETS]
    if preset not in _PRESETS and preset not in products:
        raise fail(f"{where}: preset", preset, "one of " + ", ".join(repr(s) for s in (*_PRESETS, *products)))
    if preset != "pantograph":
        extra = sorted(set(spec) & _PANTOGRAPH_ONLY)
        if extra:
            raise ParameterError(f"{where}: key {extra[0]!r} is not allowed with preset = "
                                 f"{preset!r}: it belongs to the pantograph preset")
    if preset == "custom" and not {"mass", "damping", "period"} <= set(spec):
        missing = sorted({"mass", "damping", "period"} - set(spec))
        raise ParameterError(f"{where}: key {missing[0]!r} is missing: a custom device needs "
                             "mass, damping and period (or preset = 'point-mass' or 'pantograph')")

    def quantity(key, value, unit):
        if isinstance(value, bool) or not isinstance(value, str | int | float):
            raise fail(f"{where}: {key}", value, f"a quantity in {unit} written as a string, "
                       "e.g. '50 g'")
        return parse_quantity(str(value), unit, f"{where}: {key}", require_unit=True)

    kw = {}
    for key, value in spec.items():
        unit, kind = _FILE_KEYS[key]
        if kind == "s":
            if not isinstance(value, str):
                raise fail(f"{where}: {key}", value, "a string")
            kw[key] = value
        elif kind == "i":
            kw[key] = value if isinstance(value, int) and not isinstance(value, bool) else whole(f"{where}: {key}", value, 0)
        elif kind == "x":
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise fail(f"{where}: {key}", value, "a plain number")
            kw[key] = float(value)
        elif kind == "q":
            kw[key] = quantity(key, value, unit)
        elif kind == "p" or (kind == "m" and isinstance(value, list)):
            rows = value if kind == "m" else [value]
            size = 2 if kind == "p" else len(rows) if isinstance(rows, list) else 0
            if not isinstance(rows, list) or len(rows) != (1 if kind == "p" else size) or size not in (2, 3) or any(
                    not isinstance(r, list) or len(r) != size for r in rows):
                raise fail(f"{where}: {key}", value,
                           "a pair of quantities" if kind == "p" else "a quantity or a 2x2 or 3x3 table of quantities")
            arr = np.array([[quantity(key, v, unit) for v in r] for r in rows])
            if kind == "m" and arr.shape[0] != arr.shape[1]:
                raise fail(f"{where}: {key}", value, "a square table of quantities")
            kw[key] = arr[0] if kind == "p" else arr
        else:
            kw[key] = quantity(key, value, unit)
    if preset in products:  # a product preset, with the user's own figures over its chosen ones
        base = presets()[preset].device(delay=kw.pop("delay", 0), dimension=kw.pop("dimension", None))
        return base.replace(**kw)
    if preset == "pantograph":
        return Device.pantograph(**kw)
    if preset == "point-mass":
        return Device.point_mass(**kw)
    return Device(**kw)
