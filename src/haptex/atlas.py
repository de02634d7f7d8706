"""Stability atlases: parameter sweeps of the compiled batch simulator on Dask, stored as
Zarr through xarray, resumable and deterministic (issue 14).

A sweep SPEC (TOML or YAML) names the fixed parts (algorithm and texture, device, operator,
duration) and the axes to sweep. The ``[algorithm]`` table may put the texture on an object:
``object = "sphere:RADIUS"``, ``"cylinder:RADIUS"``, ``"plane"`` or a mesh file (with
``uv_scale``), for A, B, C, G on a 3-DOF device (:mod:`haptex.objects`). The grid of runs (the Cartesian product of the axes) is cut
into blocks; each block is one call of :func:`haptex.simulate_batch` on its runs, and one
Dask task computes one block or, when the blocks are small and many, a few consecutive ones
(:data:`TASK_SAMPLES`); the client writes each block into the Zarr store as its task finishes,
then marks it done. Rerunning the same SPEC into the same store skips the blocks marked done; a store
written by another SPEC is refused. Runs are deterministic (no randomness), so a block
recomputed after a lost worker is bit for bit the same.

Example SPEC (``examples/sweeps/wall.toml``)::

    duration = "1 s"

    [algorithm]
    letter = "W"

    [device]                     # the keys of a TOML device file (haptex.device_from_file)
    preset = "point-mass"
    mass = "0.1 kg"
    damping = "0.5 N*s/m"
    period = "100 us"

    [operator]
    kind = "push"                # a constant force into the surface ('band', 'hand', or 'grip':
    force = "1 N"                # hand = "light-touch", depth = "1 mm", velocity = "10 mm/s")

    [axes]                       # in this order: the Dataset's dimensions
    stiffness = "0.5-20 kN/m, 60 log steps"
    damping = "0.1-1 N*s/m, 10 steps"
    delay = [0, 1]
"""

from __future__ import annotations

import functools
import itertools
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._specs import READING_KEYS
from ._units import parse_quantity
from ._validation import ParameterError, a_path, check_budget, fail, whole

MAX_RUNS = 10**9
"""Largest number of runs one sweep may hold (the grid's product)."""
MAX_SPEC_BYTES = 1 << 20
DEFAULT_BLOCK = 512
"""Runs per task by default."""
MAX_BLOCKS = 10**6
"""Most blocks a sweep may be cut into (each is a task's unit and a Zarr chunk: about 300
bytes of bookkeeping a block)."""

_TOP_KEYS = ("duration", "block", "algorithm", "device", "operator", "axes", "initial_position")
_OPERATORS = {"push": ("force",), "band": ("stiffness", "anchor"), "hand": ("stiffness", "damping", "velocity", "depth"),
              "grip": ("hand", "velocity", "depth")}
_ALG_QUANTITIES = {"stiffness": "N/m", "friction": "dimensionless", "presliding": "m", "max_penetration": "m"}
_RANGE = re.compile(r"^\s*(?P<a>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?:–|—|-|\.\.|to)\s*"
                    r"(?P<b>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)\s*(?P<unit>[^,]*?)\s*,\s*(?P<n>\d{1,15})\s*"
                    r"(?P<log>log\s+)?steps?\s*$")


@dataclass(frozen=True)
class Axis:
    """One swept parameter.

    Parameters
    ----------
    name : str
        A key of :data:`haptex.simulate.SWEEP_KEYS`, or ``algorithm`` (letters).
    values : ndarray, shape (n,)
        SI values (float; whole samples for ``delay``), or letters for ``algorithm``.
    unit : str
    """

    name: str
    values: np.ndarray
    unit: str


MAX_SPEC_DEPTH = 16
"""Deepest nesting of tables and lists a SPEC may have (far more than a SPEC needs)."""


def _check_yaml_events(path, events) -> None:
    """Refuse, before anything is built, a YAML SPEC with anchors or aliases (a 1 KB alias
    bomb expands to gigabytes: issue 33) or nested deeper than ``MAX_SPEC_DEPTH``."""
    import yaml

    depth = 0
    for ev in events:
        if isinstance(ev, yaml.AliasEvent) or getattr(ev, "anchor", None):
            raise ParameterError(f"spec = {str(path)!r} is not allowed: it uses YAML anchors or aliases ('&' or '*'), "
                                 "which a SPEC does not need; write each value out")
        if isinstance(ev, (yaml.MappingStartEvent, yaml.SequenceStartEvent)):
            depth += 1
            if depth > MAX_SPEC_DEPTH:
                raise ParameterError(f"spec = {str(path)!r} is not allowed: nested deeper than {MAX_SPEC_DEPTH} levels")
        elif isinstance(ev, (yaml.MappingEndEvent, yaml.SequenceEndEvent)):
            depth -= 1


@dataclass(frozen=True)
class SweepSpec:
    """A parsed SPEC: what is fixed, what is swept, and how the runs are cut into tasks.

    Parameters
    ----------
    mapping : dict
        The SPEC as read (its canonical JSON identifies the store it may write into).
    axes : tuple of Axis
        In the SPEC's order: the Dataset's dimensions.
    block : tuple of int
        Runs per task along each axis (a block of the grid; 1 along ``algorithm``).
    duration : float
        Simulated time per run (s).
    """

    mapping: dict
    axes: tuple
    block: tuple
    duration: float

    @property
    def shape(self) -> tuple:
        return tuple(a.values.size for a in self.axes)

    @property
    def runs(self) -> int:
        return int(np.prod(self.shape, dtype=np.int64))

    @property
    def canonical(self) -> str:
        """The SPEC's identity: its JSON with sorted keys, except the axes, whose order is
        the Dataset's dimensions."""
        m = dict(self.mapping, axes=[[k, v] for k, v in self.mapping["axes"].items()])
        return json.dumps(m, sort_keys=True, separators=(",", ":"))

    def blocks(self) -> list[tuple[slice, ...]]:
        """Every task's block as slices into the grid, in C order.

        Returns
        -------
        list of tuple of slice
            One tuple of slices (one a grid dimension) per task, in C order.
        """
        starts = [range(0, n, b) for n, b in zip(self.shape, self.block)]
        return [tuple(slice(i, min(i + b, n)) for i, b, n in zip(idx, self.block, self.shape))
                for idx in itertools.product(*starts)]

    @classmethod
    def from_file(cls, path) -> SweepSpec:
        """Read a SPEC from a ``.toml``, ``.yaml`` or ``.yml`` file.

        Parameters
        ----------
        path : str or os.PathLike
            The SPEC file (``.toml``, ``.yaml`` or ``.yml``).

        Raises
        ------
        ParameterError
            If the file is missing, too large, not TOML/YAML, or the SPEC is invalid
            (see :meth:`from_mapping`).
        """
        p = a_path("spec", path, "a TOML or YAML SPEC file's path")
        if not p.is_file():
            raise ParameterError(f"spec = {str(path)!r} is not allowed: {'a directory' if p.is_dir() else 'no such file'}")
        if p.stat().st_size > MAX_SPEC_BYTES:
            raise fail("spec", str(path), f"a SPEC file of at most {MAX_SPEC_BYTES} bytes")
        text = p.read_text(encoding="utf-8", errors="replace")
        if p.suffix.lower() == ".toml":
            import tomllib

            try:
                data = tomllib.loads(text)
            except tomllib.TOMLDecodeError as exc:
                raise ParameterError(f"spec = {str(path)!r} is not allowed: not a TOML file ({exc})") from None
        elif p.suffix.lower() in (".yaml", ".yml"):
            import yaml

            try:
                _check_yaml_events(path, yaml.parse(text, Loader=yaml.SafeLoader))
                data = yaml.safe_load(text)
            except yaml.YAMLError as exc:
                raise ParameterError(f"spec = {str(path)!r} is not allowed: not a YAML file "
                                     f"({' '.join(str(exc).split())})") from None
        else:
            raise fail("spec", str(path), "a .toml, .yaml or .yml file")
        if not isinstance(data, dict):
            raise fail("spec", str(path), "a table of keys (TOML or YAML)")
        return cls.from_mapping(data)

    @classmethod
    def from_mapping(cls, data: dict) -> SweepSpec:
        """Validate a SPEC given as a mapping (what TOML or YAML gives).

        Parameters
        ----------
        data : dict
            The SPEC's keys and values, as TOML or YAML gives them (the atlases guide lists them).

        Raises
        ------
        ParameterError
            Naming the key for an unknown key, an axis with no values, an unknown swept
            parameter, a unit that does not fit the parameter, more than ``MAX_RUNS`` runs,
            or invalid fixed parts (built once here, before any task).
        """
        unknown = sorted(set(data) - set(_TOP_KEYS))
        if unknown:
            raise ParameterError(f"spec key {unknown[0]!r} is not allowed: allowed keys are {', '.join(_TOP_KEYS)}")
        for key in ("duration", "axes", "device", "operator"):
            if key not in data:
                raise ParameterError(f"spec key {key!r} is missing")
        duration = _quantity("duration", data["duration"], "s")
        if not duration > 0:
            raise fail("duration", data["duration"], "a duration > 0")
        axes_table = data["axes"]
        if not isinstance(axes_table, dict) or not axes_table:
            raise fail("axes", axes_table, "a table of at least one swept parameter")
        # the grid's size from the SPEC's text, before any axis is expanded (an axis of 10^12
        # steps would allocate 7 TiB in np.geomspace: issue 33)
        steps = [_axis_steps(value) for value in axes_table.values()]
        runs = math.prod(steps)
        if runs > MAX_RUNS:
            raise fail("axes", " x ".join(map(str, steps)), f"at most {MAX_RUNS:.0e} runs in all")
        check_budget("axes", " x ".join(map(str, steps)), runs * _RUN_BYTES,
                     f"the atlas's {runs:.3g} runs ({_RUN_BYTES} bytes a run in memory)")
        axes = tuple(_axis(name, value) for name, value in axes_table.items())
        shape = [a.values.size for a in axes]
        block_runs = whole("block", data.get("block", DEFAULT_BLOCK), 1, 10**7, "runs per task")
        block = [1] * len(axes)
        prod = 1
        for i in range(len(axes) - 1, -1, -1):
            if axes[i].name == "algorithm":
                break
            n = shape[i]
            if prod * n <= block_runs:
                block[i] = n
                prod *= n
                continue
            block[i] = max(1, block_runs // prod)
            break
        n_blocks = math.prod(-(-n // b) for n, b in zip(shape, block))
        if n_blocks > MAX_BLOCKS:
            raise fail("block", block_runs, f"a block size that cuts the {runs:.3g} runs into at most {MAX_BLOCKS:.0e} "
                       f"blocks (it gives {n_blocks:.3g})")
        spec = cls(dict(data), axes, tuple(block), duration)
        letters = next((a.values for a in axes if a.name == "algorithm"), None)
        for L in ([None] if letters is None else letters):  # every fixed part, checked before any task
            spec._check_axes(spec.build(letter=None if L is None else str(L)))
        return spec

    def _check_axes(self, built) -> None:
        """Each swept value's range checked here, not first in a Dask task (where the error
        came after a worker's traceback: issue 33): every axis's least and greatest value
        applied alone to the fixed parts, as the run that sweeps them rebuilds them (the
        checks are ranges, so the extremes stand for the axis)."""
        from .simulate import _rebuild

        alg, device, op, _ = built
        for a in self.axes:
            if a.name == "algorithm" or a.name.startswith("initial_"):
                continue
            for v in {float(a.values.min()), float(a.values.max())}:
                try:
                    _rebuild(alg, device, op, {a.name: v})
                except ParameterError as exc:
                    msg = str(exc)
                    raise ParameterError(f"axes.{msg}" if msg.startswith(f"{a.name} ") else f"axes.{a.name}: {msg}") \
                        from None

    def build(self, letter: str | None = None):
        """(algorithm, device, operator, initial_position) of the fixed parts.

        Parameters
        ----------
        letter : str, optional
            An algorithm's letter (W, A-G) to build instead of the SPEC's own (the atlas's
            ``letter`` axis); default the SPEC's.

        Returns
        -------
        tuple
            (algorithm, device, operator, initial_position): an :class:`~haptex.Algorithm`,
            a :class:`~haptex.Device`, an :class:`~haptex.operators.Operator` and the start
            position (m), shape (d,).
        """
        from .algorithms import algorithm
        from ._loaders import remedy_in
        from .catalogue import _device_from_table

        alg_table = self.mapping.get("algorithm", {})
        if not isinstance(alg_table, dict):
            raise fail("algorithm", alg_table, "a table with 'letter' (W, A-G), 'texture' and the parameters")
        alg_table = dict(alg_table)
        L = letter or alg_table.pop("letter", None)
        alg_table.pop("letter", None)
        if L is None:
            raise ParameterError("algorithm.letter is missing: give it, or sweep 'algorithm' in [axes]")
        texture_spec = alg_table.pop("texture", None)
        object_spec = alg_table.pop("object", None)
        uv_scale = alg_table.pop("uv_scale", None)
        reading = {key: _reading_value(key, alg_table.pop(key)) for key in READING_KEYS if key in alg_table}
        params = {}
        for key, value in alg_table.items():
            if key not in _ALG_QUANTITIES:
                raise ParameterError(f"algorithm key {key!r} is not allowed: allowed keys are letter, texture, "
                                     "object, uv_scale, " + ", ".join([*_ALG_QUANTITIES, *READING_KEYS]))
            params[key] = _quantity(f"algorithm.{key}", value, _ALG_QUANTITIES[key])
        swept = {a.name for a in self.axes}
        if "stiffness" not in params and "stiffness" not in swept:
            raise ParameterError("algorithm.stiffness is missing: give it (e.g. '2 kN/m') or sweep 'stiffness' in [axes]")
        stiffness = params.pop("stiffness", 2000.0)  # a swept stiffness replaces it in every run
        texture = None
        if str(L).upper() != "W":
            if texture_spec is None:
                raise ParameterError(f"algorithm.texture is missing: algorithm {L} needs one, e.g. 'sine:0.8mm,1mm'")
            from ._specs import texture_from_spec

            try:
                texture = texture_from_spec(str(texture_spec), **reading)
            except ParameterError as exc:  # (a loader's remedy in the SPEC's words, not the command line's)
                raise ParameterError(remedy_in(str(exc), "in the SPEC's [algorithm]")) from None
        elif texture_spec is not None or reading:
            key = "texture" if texture_spec is not None else next(iter(reading))
            raise ParameterError(f"algorithm.{key} is not allowed with letter W: the smooth wall has no texture")
        if not isinstance(self.mapping["device"], dict):
            raise fail("device", self.mapping["device"], "a table: preset = '...' and the device's keys")
        device = _device_from_table(dict(self.mapping["device"]), "spec [device]")
        if texture is None and device.dimension == 3:
            from .textures import Flat

            texture = Flat(dimension=2)  # the wall under a 3-DOF device: the plane z = 0
        if object_spec is not None:  # a textured object (haptex.objects): A, B, C, G, a 3-DOF device
            from ._specs import object_from_spec
            from .objects import object_algorithm

            if params:
                raise ParameterError(f"algorithm.{next(iter(params))} is not allowed with algorithm.object: on an "
                                     "object the algorithms take a stiffness only")
            if device.dimension != 3:
                raise ParameterError("algorithm.object is not allowed on a planar device: an object needs a 3-DOF "
                                     "device")
            scale = None if uv_scale is None else _quantity("algorithm.uv_scale", uv_scale, "m")
            try:
                alg = object_algorithm(str(L), texture, object_from_spec(str(object_spec), scale), stiffness)
            except ParameterError as exc:  # (a seam's radius as algorithm.object takes it)
                raise ParameterError(remedy_in(str(exc), "in the SPEC's [algorithm]")) from None
        elif uv_scale is not None:
            raise ParameterError("algorithm.uv_scale is not allowed without algorithm.object: it scales a mesh's "
                                 "texture coordinates")
        else:
            alg = algorithm(str(L), texture, stiffness, **params)
        op = _operator(self.mapping["operator"], device.dimension)
        if self.mapping["operator"].get("kind") == "grip":
            device = _grip(self.mapping["operator"]).attach(device)  # the hand's mass moves with the handle
        start = self.mapping.get("initial_position")
        if start is not None and (not isinstance(start, list) or len(start) != device.dimension):
            raise fail("initial_position", start, f"a list of {device.dimension} lengths, e.g. ['0 mm', '1 mm']")
        p0 = None if start is None else np.array([_quantity("initial_position", v, "m") for v in start])
        return alg, device, op, p0


def _reading_value(key: str, value):
    """A reading key of the SPEC's [algorithm] (:data:`haptex._specs.READING_KEYS`) checked: a
    quantity in SI, a flag true or false, or text."""
    kind = READING_KEYS[key]
    if kind is bool:
        if not isinstance(value, bool):
            raise fail(f"algorithm.{key}", value, "true or false")
        return value
    if kind is str:
        if isinstance(value, bool) or not isinstance(value, str | int):
            raise fail(f"algorithm.{key}", value, "a text, e.g. 'um'" if key.endswith("unit") else "a text")
        return str(value)
    return _quantity(f"algorithm.{key}", value, kind)


def _quantity(name: str, value, unit: str) -> float:
    if isinstance(value, bool):
        raise fail(name, value, f"a quantity in {unit}")
    if unit == "dimensionless":
        if isinstance(value, int | float):
            return float(value)
        return parse_quantity(str(value), unit, name)
    if isinstance(value, int | float) and value != 0:
        raise fail(name, value, f"a quantity with its unit, e.g. '{1:g} {unit}' (a bare number is refused)")
    return parse_quantity(str(value), unit, name, require_unit=True)


def _axis_steps(value) -> int:
    """How many values an axis written as ``value`` holds, read from its text alone (a
    list's length, a range's step count; 1 for anything :func:`_axis` will refuse)."""
    if isinstance(value, list):
        return len(value)
    m = _RANGE.match(value) if isinstance(value, str) else None
    return int(m["n"]) if m else 1


def _axis(name: str, value) -> Axis:
    from .simulate import SWEEP_KEYS, SWEEP_UNITS

    if name == "algorithm":
        letters = value if isinstance(value, list) else None
        if not letters:
            raise fail("axes.algorithm", value, "a list of letters, e.g. ['A', 'C']")
        from .algorithms import ALGORITHMS

        bad = [v for v in letters if str(v).upper() not in ALGORITHMS]
        if bad:
            raise fail("axes.algorithm", bad[0], "letters W, A-G")
        return Axis("algorithm", np.array([str(v).upper() for v in letters], dtype=object), "")
    if name not in SWEEP_KEYS:
        shown = f"axes.{name}" if str(name).isidentifier() else f"axes[{str(name)[:40]!r}]"
        raise ParameterError(f"{shown} is not allowed: a swept parameter must be algorithm or one of "
                             + ", ".join(SWEEP_KEYS))
    unit = SWEEP_UNITS[name]
    label = f"axes.{name}"
    if isinstance(value, list):
        if not value:
            raise fail(label, value, "at least one value")
        if name == "delay":
            vals = np.array([whole(label, v, 0, 10_000) for v in value], dtype=np.float64)
        else:
            vals = np.array([_quantity(label, v, unit) for v in value])
    elif isinstance(value, str):
        m = _RANGE.match(value)
        if not m:
            raise fail(label, value, f"a list, or a range such as '0.5-20 {unit if unit != 'dimensionless' else ''}, "
                       "60 log steps'".replace(" ,", ","))
        n = int(m["n"])
        if n < 1:
            raise fail(label, value, "at least one step")
        u = m["unit"].strip()
        if name == "delay":
            if u not in ("", "samples", "sample"):
                raise fail(label, value, "whole samples")
            a, b = float(m["a"]), float(m["b"])
            vals = np.unique(np.rint(np.linspace(a, b, n)))
        else:
            if not u and unit != "dimensionless":
                raise fail(label, value, f"a range with its unit, e.g. '0.5-20 kN/m, 60 log steps' ({unit})")
            a = parse_quantity(f"{m['a']} {u}", unit, label)
            b = parse_quantity(f"{m['b']} {u}", unit, label)
            if m["log"]:
                if not (a > 0 and b > 0):
                    raise fail(label, value, "a log range of positive values")
                vals = np.geomspace(a, b, n)
            else:
                vals = np.linspace(a, b, n)
    else:
        raise fail(label, value, "a list of values, or a range string such as '0.5-20 kN/m, 60 log steps'")
    if not np.all(np.isfinite(vals)):
        raise fail(label, value, "finite values")
    return Axis(name, vals, "samples" if name == "delay" else unit)


def _grip(table):
    """The hand model an operator table of kind 'grip' names (not 'none': a grip holds)."""
    from .catalogue import hand

    h = hand(table["hand"] if isinstance(table["hand"], str) else repr(table["hand"]))
    if h.none:
        raise fail("operator.hand", table["hand"], "a hand that holds the handle (light-touch, firm-grip)")
    return h


def _operator(table, dimension: int):
    from . import operators as ops

    if not isinstance(table, dict):
        raise fail("operator", table, "a table with kind = 'push', 'band', 'hand' or 'grip'")
    table = dict(table)
    kind = table.pop("kind", None)
    if kind not in _OPERATORS:
        raise fail("operator.kind", kind, "'push' (a constant force into the surface), 'band', 'hand' or 'grip' (a hand "
                   "model of haptex.catalogue)")
    unknown = sorted(set(table) - set(_OPERATORS[kind]))
    if unknown:
        raise ParameterError(f"operator key {unknown[0]!r} is not allowed with kind = {kind!r}: allowed keys are "
                             + ", ".join(_OPERATORS[kind]))
    missing = [k for k in _OPERATORS[kind] if k not in table]
    if missing:
        raise ParameterError(f"operator.{missing[0]} is missing: kind = {kind!r} needs " + ", ".join(_OPERATORS[kind]))
    if kind == "push":
        f = _quantity("operator.force", table["force"], "N")
        return ops.ConstantForce([0.0] * (dimension - 1) + [-f])
    if kind == "band":
        anchor = table["anchor"]
        if not isinstance(anchor, list) or len(anchor) != dimension:
            raise fail("operator.anchor", anchor, f"a list of {dimension} lengths")
        return ops.ElasticBand(_quantity("operator.stiffness", table["stiffness"], "N/m"),
                               [_quantity("operator.anchor", v, "m") for v in anchor])
    if kind == "grip":  # a hand model: its spring and damper here, its mass on the device (_grip)
        return _grip(table).operator(depth=_quantity("operator.depth", table["depth"], "m"),
                                     velocity=_quantity("operator.velocity", table["velocity"], "m/s"),
                                     dimension=dimension)
    return ops.ScanningHand(_quantity("operator.stiffness", table["stiffness"], "N/m"),
                            _quantity("operator.damping", table["damping"], "N*s/m"),
                            velocity=_quantity("operator.velocity", table["velocity"], "m/s"),
                            depth=_quantity("operator.depth", table["depth"], "m"), dimension=dimension)


# -- the task and the Dataset --------------------------------------------------------------
def _variables(dimension: int) -> dict:
    """name: (unit, dtype, fill, description) of every per-run variable of an atlas."""
    from .simulate import REGIMES

    axes = "xz" if dimension == 2 else "xyz"
    out = {"oscillating": ("1", "bool", False, "the run oscillates on some axis (Oscillation verdict)")}
    for a in axes:
        out[f"oscillating_{a}"] = ("1", "bool", False, f"the verdict along {a}")
    out |= {"growing": ("1", "bool", False, "the motion grows over the tail (decay_ratio > 1, above the rest "
                                            "threshold)"),
            "regime": ("1", "int8", -1, "the run's regime (haptex.simulate.regime): " + ", ".join(
                f"{i} {name}" for i, name in enumerate(REGIMES))),
            "unstable": ("1", "bool", False, "the loop is unstable: regime limit cycle, growing or diverged"),
            "tail_amplitude": ("m", "float64", np.nan, "tail amplitude of the oscillating (or largest) axis"),
            "tail_frequency": ("Hz", "float64", np.nan, "its frequency"),
            "decay_ratio": ("1", "float64", np.nan, "amplitude of the tail's second half over its first")}
    for a in axes:
        out[f"energy_rate_{a}"] = ("W", "float64", np.nan,
                                   f"energy the environment supplies along {a} per second: -E_{a} / duration")
    out |= {"deepest_penetration": ("m", "float64", np.nan, "deepest penetration into the surface"),
            "saturations": ("samples", "int64", -1, "samples at the force limit"),
            "energy_balance_error": ("1", "float64", np.nan, "relative closure of the energy balance"),
            "diverged_at": ("samples", "int64", -1, "sample at which the run became non-finite, 0 if never")}
    return out


_RUN_BYTES = 2 * (sum(np.dtype(v[1]).itemsize for v in _variables(3).values()) + 1)
"""Bytes of memory a run of an atlas costs at most: its variables in space and ``done``,
twice (the results as computed and the Dataset returned)."""


@functools.lru_cache(maxsize=8)
def _parsed(key: str) -> SweepSpec:
    """The SPEC of a task, parsed (units, axes, checks) once per worker process."""
    return SweepSpec.from_mapping(json.loads(key))


@functools.lru_cache(maxsize=64)
def _built(key: str, letter: str | None):
    """The fixed parts of a task, built once per worker process and algorithm: the same
    objects :meth:`SweepSpec.build` gives (deterministic), without a task paying pint's
    parsing again (about 3 ms of a 10^5-sample block's 11 ms)."""
    return _parsed(key).build(letter=letter)


TASK_SAMPLES = 2_000_000
"""Simulated samples a Dask task aims at, gathering consecutive blocks when theirs are fewer:
a task costs Dask about 1.7 ms on this project's 2-core machine whatever it does (40 no-op
tasks, one in-process worker), against about 0.1 s of simulation for 2e6 samples. Dask's own
advice is tasks of 100 ms or more ("Dask best practices: avoid very small tasks"). The blocks
(the store's chunks, the unit of resume) keep their size; a sweep still has at least four tasks
a worker thread, so that the workers share it and a lost worker costs little: fewer blocks than
that are cut into parts of their runs (:func:`_tasks`), assembled again before a block is
written."""
PART_SAMPLES = 200_000
"""The fewest samples a part of a block holds when blocks are cut for the workers (chosen:
about 10 ms of simulation here, six times a task's cost to Dask)."""


def _tasks(todo: list, block_samples: int, threads: int, block_runs: int = 1) -> list[list]:
    """The blocks ``todo`` (indices, in order) as tasks of (block, part, parts) items: gathered
    into tasks of about :data:`TASK_SAMPLES` samples (``block_samples`` a block), at least 4
    tasks a worker thread (``threads`` in the cluster); when there are fewer blocks than that,
    each cut into parts of its ``block_runs`` runs, of at least :data:`PART_SAMPLES` samples."""
    want = 4 * max(threads, 1)
    if len(todo) < want:
        parts = max(1, min(-(-want // max(len(todo), 1)), block_runs,
                           int(block_samples // max(PART_SAMPLES, 1))))
        return [[(i, j, parts)] for i in todo for j in range(parts)]
    k = max(1, min(-(-TASK_SAMPLES // max(block_samples, 1)), len(todo) // want))
    return [[(i, 0, 1) for i in todo[n:n + k]] for n in range(0, len(todo), k)]


def _run_blocks(spec_mapping: dict, items: list, threads: int | None = None) -> list[dict]:
    """One task: :func:`_run_block` on each (block, part, parts) of ``items``, in order, the C
    core's batch loops on ``threads`` threads (None: :func:`haptex.core.num_threads`)."""
    from . import core

    if threads is None:
        return [_run_block(spec_mapping, *item) for item in items]
    with core.threads(max(1, int(threads))):
        return [_run_block(spec_mapping, *item) for item in items]


def _assemble(block: tuple, pieces: list) -> dict:
    """A block's variables, shaped as the block, from its parts' flat arrays, in order."""
    shape = tuple(s.stop - s.start for s in block)
    return {k: np.concatenate([p[k] for p in pieces]).reshape(shape) for k in pieces[0]}


def _run_block(spec_mapping: dict, block: tuple, part: int = 0, parts: int = 1) -> dict:
    """Part ``part`` of ``parts`` of one block (its runs in grid order, cut evenly): simulate
    them; returns the variables as flat arrays (:func:`_assemble` shapes a block)."""
    from .simulate import REGIMES, simulate_batch

    if isinstance(spec_mapping, SweepSpec):
        spec_mapping = spec_mapping.mapping
    key = json.dumps(spec_mapping)  # insertion order kept: the axes' order is the grid's
    spec = _parsed(key)
    grids = np.meshgrid(*[a.values[s] for a, s in zip(spec.axes, block)], indexing="ij")
    runs = np.array_split(np.arange(grids[0].size), parts)[part]
    values = {a.name: g.ravel()[runs] for a, g in zip(spec.axes, grids)}
    letter = values.pop("algorithm", None)
    alg, device, op, p0 = _built(key, None if letter is None else str(letter[0]))
    res = simulate_batch(alg, device, op, spec.duration, initial_position=p0, progress=False, **values)
    d = device.dimension
    axes = "xz" if d == 2 else "xyz"
    out = {"oscillating": res.oscillating, "growing": res.growing, "decay_ratio": res.decay_ratio,
           "regime": np.array([REGIMES.index(r) for r in res.regime], dtype=np.int8), "unstable": res.unstable,
           "tail_amplitude": res.amplitude, "tail_frequency": res.frequency,
           "deepest_penetration": res.max_penetration, "saturations": res.saturations,
           "energy_balance_error": res.energy_balance_error, "diverged_at": res.diverged_at}
    energies = {"x": res.energy_x, "z": res.energy_z, "y": res.energy_y}
    for i, a in enumerate(axes):
        out[f"oscillating_{a}"] = res.oscillating_axes[:, i]
        out[f"energy_rate_{a}"] = -energies[a] / spec.duration
    return {k: np.asarray(v).ravel() for k, v in out.items()}


def _template(spec: SweepSpec, dimension: int, lazy: bool = True):
    """The atlas before any run: fill values, lazily (dask, for the store's metadata) or as
    one NumPy array per variable (in memory)."""
    import dask.array as da
    import xarray as xr

    dims = [a.name for a in spec.axes]
    coords = {a.name: (a.name, a.values, {"units": a.unit}) for a in spec.axes}
    full = (lambda fill, dtype: da.full(spec.shape, fill, dtype=dtype, chunks=spec.block)) if lazy else (
        lambda fill, dtype: np.full(spec.shape, fill, dtype=dtype))
    data = {}
    for name, (unit, dtype, fill, desc) in _variables(dimension).items():
        data[name] = (dims, full(fill, dtype), {"units": unit, "description": desc})
    data["done"] = (dims, full(False, bool), {"description": "the run's block was computed and written"})
    return xr.Dataset(data, coords=coords, attrs={"haptex_spec": spec.canonical, "duration_s": spec.duration,
                                                  "made_by": "haptex sweep"})


def sweep(spec, out=None, *, scheduler: str | None = None, workers: int | None = None, progress: bool = False,
          on_block=None):
    """Run a stability atlas: every run of a SPEC, on Dask, into a Zarr store.

    Parameters
    ----------
    spec : SweepSpec, dict, str or Path
        A SPEC (see the module's docstring), as parsed, as a mapping, or a TOML/YAML file.
    out : str or Path, optional
        The Zarr store (a directory). Blocks already marked done there are skipped (a
        resumed sweep); a store written by another SPEC is refused. Without ``out`` the
        Dataset is kept in memory only.
    scheduler : str, optional
        Address of a running Dask scheduler (``tcp://host:port``); default a
        ``LocalCluster`` on this machine.
    workers : int, optional
        Workers of the local cluster: by default one process a core; 1 runs in this
        process, its compiled batches on every core (the least overhead a task).
    progress : bool, optional
        A rich progress bar of runs done.
    on_block : callable, optional
        Called with the number of blocks written so far after each (for progress and tests).

    Returns
    -------
    xarray.Dataset
        One dimension per axis (with its coordinate and unit); the variables of
        :func:`_variables`; ``attrs["blocks_computed"]`` and ``attrs["blocks_skipped"]``
        of this call.

    Raises
    ------
    ParameterError
        For a SPEC or ``out`` that is not a path (a str or os.PathLike, PEP 519), an invalid
        SPEC (or one whose atlas would exceed the memory budget), a store
        written by another SPEC or being written by another sweep (its lock), too many
        local workers for the memory budget, or a scheduler that is not ``tcp://HOST:PORT``
        or does not answer (within 5 s to connect, 10 s to start the handshake).
    """
    if not isinstance(spec, SweepSpec):
        spec = SweepSpec.from_mapping(spec) if isinstance(spec, dict) else SweepSpec.from_file(spec)
    fixed_device = spec.build(letter=str(spec.axes[0].values[0]) if spec.axes[0].name == "algorithm" else None)[1]
    dimension = fixed_device.dimension
    if scheduler is None:  # workers and address checked before any store is made
        _local_workers(workers)
    else:
        _scheduler_address(scheduler)
    blocks = spec.blocks()
    store = None if out is None else a_path("out", out, "a Zarr store's path")
    lock = None if store is None else _lock(store)
    try:
        done_blocks = set() if store is None else _open_store(store, spec, dimension, blocks)
        results = {} if store is None else None
        todo = [i for i in range(len(blocks)) if i not in done_blocks]
        computed = 0
        if todo:
            arrays = None if store is None else _store_arrays(store, dimension)
            client, cluster, threads = _client(scheduler, workers)
            bar = _bar(progress, spec.runs, sum(_size(blocks[i]) for i in done_blocks))
            try:
                from dask.distributed import as_completed

                n_threads = sum(client.nthreads().values()) or 1
                steps = round(spec.duration / fixed_device.period)  # samples a run
                largest = max(_size(blocks[i]) for i in todo)
                groups = _tasks(todo, largest * steps, n_threads, largest)
                futures = {client.submit(_run_blocks, spec.mapping, [(blocks[i], j, n) for i, j, n in g], threads,
                                         pure=True, retries=3): g for g in groups}
                pending: dict = {}
                for fut in as_completed(futures):
                    for (i, j, n), piece in zip(futures[fut], fut.result()):
                        pending.setdefault(i, [None] * n)[j] = piece
                        if any(p is None for p in pending[i]):
                            continue
                        data = _assemble(blocks[i], pending.pop(i))
                        if store is None:
                            results[i] = data
                        else:
                            _write(arrays, blocks[i], data)
                        computed += 1
                        bar(_size(blocks[i]))
                        if on_block is not None:
                            on_block(computed)
            finally:
                bar(None)
                client.close()
                if cluster is not None:
                    cluster.close()
        if store is None:
            ds = _template(spec, dimension, lazy=False)
            for i, data in results.items():
                for k, v in data.items():
                    ds[k].values[blocks[i]] = v
                ds["done"].values[blocks[i]] = True
        else:
            ds = open_atlas(store)
    finally:
        if lock is not None:
            lock.release()
    ds.attrs["blocks_computed"] = computed
    ds.attrs["blocks_skipped"] = len(done_blocks)
    return ds


def _lock(store: Path):
    """The store's lock (``STORE.lock`` beside it, held by this process until the sweep
    ends; the operating system releases it if the process dies): one writer per atlas. Two
    sweeps of different SPECs started 0.2 s apart into one new store both exited 0 and left
    it labelled with one SPEC and holding the other's data (issue 33); now the second is
    refused in one line."""
    from filelock import FileLock, Timeout

    lock = FileLock(str(store.parent / (store.name + ".lock")))
    try:
        lock.acquire(timeout=0)
    except Timeout:
        raise ParameterError(f"out = {str(store)!r} is not allowed: another haptex sweep is writing it (it holds "
                             f"{lock.lock_file}); wait for it to end, or give another store") from None
    except OSError as exc:
        raise ParameterError(f"out = {str(store)!r} is not allowed: its lock file cannot be made "
                             f"({' '.join(str(exc).split())[:100]})") from None
    return lock


def _open_store(store: Path, spec: SweepSpec, dimension: int, blocks: list) -> set:
    """The indices of the blocks already done in ``store`` (a resumed sweep), after checking
    that the store's label is this SPEC's; a new store is made with the label (written with
    the metadata, before any block). Called with the store's lock held.

    Raises
    ------
    ParameterError
        For a store that is not a haptex atlas, was written by another SPEC or version, or
        whose ``done`` chunks cannot be read.
    """
    import warnings

    import xarray as xr

    if not store.exists():
        with warnings.catch_warnings():  # zarr 3 flags its string dtype (the algorithm letters) as unstable
            warnings.filterwarnings("ignore", message=".*does not have a Zarr V3 specification.*")
            _template(spec, dimension).to_zarr(store, mode="w", compute=False, consolidated=False)
        return set()
    try:
        old = xr.open_zarr(store, consolidated=False)
    except Exception as exc:  # noqa: BLE001 - any reader error is one line
        raise ParameterError(f"out = {str(store)!r} is not allowed: it exists and is not a haptex atlas "
                             f"({' '.join(str(exc).split())[:120]})") from None
    if old.attrs.get("haptex_spec") != spec.canonical:
        raise ParameterError(f"out = {str(store)!r} is not allowed: it was written by another SPEC; give a new "
                             "store, or the SPEC that wrote it to resume")
    missing = sorted((set(_variables(dimension)) | {"done"}) - set(old.data_vars))
    if missing:
        raise ParameterError(f"out = {str(store)!r} is not allowed: it lacks the variables {missing} (written by "
                             "another version of haptex); give a new store")
    try:
        done = np.asarray(old["done"].values, dtype=bool)
    except Exception as exc:  # noqa: BLE001 - a corrupt chunk
        raise ParameterError(f"out = {str(store)!r} is not allowed: its 'done' marks cannot be read "
                             f"({' '.join(str(exc).split())[:120]}); give a new store") from None
    if done.shape != spec.shape:
        raise ParameterError(f"out = {str(store)!r} is not allowed: its grid is {done.shape}, the SPEC's "
                             f"{spec.shape}; give a new store")
    return {i for i, b in enumerate(blocks) if bool(done[b].all())}


def _size(block) -> int:
    return int(np.prod([s.stop - s.start for s in block]))


def _store_arrays(store: Path, dimension: int) -> dict:
    """The store's Zarr arrays a sweep writes (its variables and ``done``), opened once."""
    import zarr

    group = zarr.open_group(str(store), mode="r+")
    return {k: group[k] for k in (*_variables(dimension), "done")}


def _write(arrays: dict, block: tuple, data: dict) -> None:
    """Write one block's variables, then (a second write) mark it done: into the store's Zarr
    arrays directly (:func:`_store_arrays`; xarray made the store with their dtypes, fill
    values and attributes, and reads it). Through xarray's region writes a block cost 58-115 ms
    of the client's CPU here, the store's metadata read and checked again each time."""
    for k, v in data.items():
        arrays[k][block] = v
    arrays["done"][block] = np.ones(tuple(s.stop - s.start for s in block), dtype=bool)


def _local_workers(workers) -> int:
    """The number of local worker processes: ``workers``, or one a core; refused above 1024
    or when their memory (:data:`WORKER_BYTES` each) exceeds the budget."""
    import os

    n = (os.cpu_count() or 1) if workers is None else whole("workers", workers, 1, 1024)
    check_budget("workers", n, n * WORKER_BYTES, f"{n} local worker processes (about {WORKER_BYTES / 2**20:.0f} MiB each)")
    return n


def _client(scheduler: str | None, workers: int | None):
    """(client, local cluster or None, the C core's threads per task)."""
    import logging
    import os

    from dask.distributed import Client, LocalCluster

    if scheduler is not None:
        return _remote(scheduler), None, None
    import dask

    cores = os.cpu_count() or 1
    n = _local_workers(workers)
    # The blocks are alike and independent: the scheduler hands them all out at once
    # (worker saturation "inf"), so that a worker never waits a round trip for its next
    # block; work stealing still rebalances, and a lost worker's blocks are recomputed.
    # A single worker runs in this process (no pickling, no process round trip: about 2 ms a
    # task instead of 3-5) and its C batches use every core; more workers are
    # processes, each with its share of the cores (the default, one a core: the fastest
    # on large sweeps, where the client's Zarr writes then take no core from a worker).
    with dask.config.set({"distributed.scheduler.worker-saturation": "inf"}):
        where = {"host": "127.0.0.1"} if n > 1 else {}  # one worker: in-process transport, no socket
        cluster = LocalCluster(n_workers=n, threads_per_worker=1, processes=n > 1, dashboard_address="127.0.0.1:0",
                               silence_logs=logging.ERROR, **where)
    return Client(cluster), cluster, max(1, cores // n)


WORKER_BYTES = 512 * 2**20
"""Memory a local worker process is counted at (chosen): a measured 110 MB at rest after a
batch (haptex, SciPy, Dask; 231 MB while numba was loaded, before issue 30), with room for a
block's arrays and Dask's buffers."""
SCHEDULER_TIMEOUT = 10.0
"""Seconds a remote scheduler has to start Dask's handshake once connected (connect: 5 s)."""
_SCHEDULER = re.compile(r"tcp://(?P<host>[A-Za-z0-9.-]{1,253}|\[[0-9A-Fa-f:.]{2,45}\]):(?P<port>\d{1,5})")


def _scheduler_address(scheduler):
    """``scheduler``'s host and port (a regex match), or one line saying what is allowed."""
    m = _SCHEDULER.fullmatch(scheduler) if isinstance(scheduler, str) else None
    if not m or not 0 < int(m["port"]) < 65536:
        raise fail("scheduler", str(scheduler)[:80], "a Dask scheduler's address tcp://HOST:PORT")
    return m


def _remote(scheduler: str):
    """A client of the Dask scheduler at ``scheduler`` (``tcp://HOST:PORT``), or one line
    saying why not: another scheme (``tls://`` needs certificates, ``ucx://`` a UCX build,
    neither configured by haptex), nothing listening within 5 s, or a peer that accepts and
    stays silent. A Dask scheduler writes its handshake as soon as it accepts (64 bytes
    within 0.3 ms, measured); Dask's client has no deadline on that read and waited past
    5 minutes on a silent peer (issue 33), so the handshake's first byte is awaited here
    first, for at most :data:`SCHEDULER_TIMEOUT` seconds."""
    import socket

    from dask.distributed import Client

    m = _scheduler_address(scheduler)
    try:
        with socket.create_connection((m["host"].strip("[]"), int(m["port"])), timeout=5) as sock:
            sock.settimeout(SCHEDULER_TIMEOUT)
            if not sock.recv(1):
                raise OSError("it closed the connection")
        return Client(scheduler, timeout="5s")
    except TimeoutError:
        why = "it accepted the connection but sent no handshake"
    except (OSError, ValueError) as exc:
        why = " ".join(str(exc).split())[:100] or type(exc).__name__
    raise ParameterError(f"scheduler = {scheduler!r} is not allowed: no Dask scheduler answered there within "
                         f"{SCHEDULER_TIMEOUT:g} s ({why})")


def _bar(show: bool, total: int, done: int):
    """The progress of a sweep on stderr, in runs done (on a terminal only)."""
    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, TextColumn, TimeElapsedColumn

    from .simulate import _progress

    console = Console(stderr=True)
    return _progress(show and console.is_terminal, total, "runs", done,
                     (TextColumn("sweep: runs"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn()), console)


# -- reading an atlas back -------------------------------------------------------------------
def open_atlas(path):
    """An atlas written by :func:`sweep`, loaded into memory.

    Parameters
    ----------
    path : str or os.PathLike
        The Zarr store ``haptex sweep --out`` wrote.

    Returns
    -------
    xarray.Dataset
        The atlas: one variable a recorded figure over the sweep's dimensions, each coordinate
        with its ``units`` attribute.

    Raises
    ------
    ParameterError
        If ``path`` is not a path (a str or os.PathLike, PEP 519) or not a Zarr store written
        by haptex sweep.
    """
    import xarray as xr

    p = a_path("atlas", path, "a Zarr store's path")
    if not p.exists():
        raise ParameterError(f"atlas = {str(path)!r} is not allowed: no such store")
    try:
        ds = xr.open_zarr(p, consolidated=False)
    except Exception as exc:  # noqa: BLE001 - any reader error is one line
        raise ParameterError(f"atlas = {str(path)!r} is not allowed: not a Zarr store "
                             f"({' '.join(str(exc).split())[:120]})") from None
    label = ds.attrs.get("haptex_spec")
    try:
        stored = json.loads(label) if isinstance(label, str) and len(label) <= MAX_SPEC_BYTES else None
    except ValueError:
        stored = None
    if not (isinstance(stored, dict) and isinstance(stored.get("axes"), list)):
        raise ParameterError(f"atlas = {str(path)!r} is not allowed: not written by haptex sweep (its "
                             "'haptex_spec' label is " + ("missing" if label is None else "not a SPEC") + ")")
    check_budget("atlas", str(path), ds.nbytes, "loading the atlas")
    try:
        return ds.load()
    except Exception as exc:  # noqa: BLE001 - a corrupt chunk
        raise ParameterError(f"atlas = {str(path)!r} is not allowed: a chunk cannot be read "
                             f"({' '.join(str(exc).split())[:120]})") from None


def select(ds, x: str, y: str, where: dict):
    """The 2-D slice (y, x) of an atlas: every other dimension fixed by ``where`` (name:
    value, the nearest coordinate) or of length 1.

    Parameters
    ----------
    ds : xarray.Dataset
        An atlas (:func:`open_atlas`).
    x : str
        The dimension along the slice's columns.
    y : str
        The dimension along the slice's rows.
    where : dict
        Every other dimension of length > 1, name: value (the nearest coordinate is taken).

    Returns
    -------
    xarray.Dataset
        The slice, dimensions (y, x).

    Raises
    ------
    ParameterError
        For an unknown dimension, x = y, or a dimension left free.
    """
    dims = list(ds.sizes)
    for name in (x, y, *where):
        if name not in dims:
            raise ParameterError(f"{name!r} is not allowed: the atlas's dimensions are {', '.join(dims)}")
    if x == y:
        raise ParameterError(f"x = y = {x!r} is not allowed: choose two different dimensions")
    free = [d for d in dims if d not in (x, y) and d not in where and ds.sizes[d] > 1]
    if free:
        raise ParameterError(f"{free[0]!r} is left free: fix it with --select {free[0]}=VALUE "
                             f"(values: {', '.join(f'{v:g}' if not isinstance(v, str) else v for v in ds[free[0]].values[:6])}"
                             f"{', ...' if ds.sizes[free[0]] > 6 else ''})")
    sel = {}
    for name, value in where.items():
        coord = ds[name].values
        if not np.issubdtype(coord.dtype, np.number):
            if value not in coord:
                raise fail(f"select {name}", value, "one of " + ", ".join(coord))
            sel[name] = value
        else:
            sel[name] = coord[int(np.argmin(np.abs(coord - float(value))))]
    out = ds.sel(sel)
    rest = [d for d in out.dims if d not in (x, y)]
    return out.isel({d: 0 for d in rest}).transpose(y, x)


def analytic_boundary(ds, x: str, y: str, where: dict) -> np.ndarray | None:
    """Where the analytic stability or passivity limit lies along ``x`` = stiffness, for
    each y coordinate (N/m), or None when no closed form applies.

    W: the sampled wall's exact limit (:func:`haptex.critical_stiffness`, the closed-loop
    poles of the ZOH spring-mass-damper along the normal, with the device's delay); a
    textured algorithm: the passivity bound kappa_0 q = sigma_0(B) / (2T) (Corollary 1,
    eq. 1), i.e. kappa = sigma_0(B) / (2 T q) with q the characteristic number of the run's
    texture (no delay). Every parameter on the y axis or in ``where`` is applied to the
    SPEC's algorithm and device as the sweep does (``simulate_batch``'s rebuilding).

    Parameters
    ----------
    ds : xarray.Dataset
        An atlas (:func:`open_atlas`).
    x : str
        The dimension along the plot's x axis: the limit is drawn only when it is ``stiffness``.
    y : str
        The dimension along the plot's y axis (its coordinates are the rows of the result).
    where : dict
        The other dimensions' values (name: value), as :func:`select` takes them.

    Returns
    -------
    numpy.ndarray, shape (n_y,), or None
        The limiting stiffness (N/m) at each y coordinate; None where no closed form applies.
    """
    if x != "stiffness":
        return None
    from .analysis import characteristic_number
    from .devices import critical_stiffness
    from .simulate import _rebuild

    stored = json.loads(ds.attrs["haptex_spec"])  # checked by open_atlas
    try:
        spec = SweepSpec.from_mapping(dict(stored, axes=dict(stored["axes"])))  # the axes, in order
    except ParameterError:
        raise
    except (TypeError, ValueError, AttributeError) as exc:
        raise ParameterError(f"the atlas's 'haptex_spec' label is not allowed: not a SPEC ({exc})") from None
    out = []
    for yv in ds[y].values:
        params = dict(where) | {y: yv}
        letter = params.pop("algorithm", None)
        alg, device, op, _ = spec.build(letter=None if letter is None else str(letter))
        alg, device, _ = _rebuild(alg, device, op, {k: float(v) for k, v in params.items()})
        if alg.letter == "W":
            m, b = float(device.mass[-1, -1]), float(device.damping[-1, -1])
            out.append(critical_stiffness(m, b, device.period, device.delay) if b > 0 else np.nan)
        else:
            q = characteristic_number(alg).value
            out.append(device.passivity_limit / q if (q > 0 and device.delay == 0) else np.nan)
    return np.array(out)
