"""Texture and quantity specs as people write them ("sine:0.8mm,1mm", "2 kN/m"), parsed
into haptex objects: one parser for the command line, the sweep SPEC files and the
browser explorer."""

from __future__ import annotations

import difflib
import re
from pathlib import Path

from ._units import parse_quantity
from ._validation import ParameterError, renamed

TEXTURE_KINDS = {"sine": "AMPLITUDE,PERIOD", "sum": "A1,L1;A2,L2", "noise": "RMS,SHORTEST,LONGEST,LENGTH[,SEED]",
                 "egg-crate": "AMPLITUDE,PERIOD", "grating": "AMPLITUDE,PERIOD[,DIRECTION]"}
"""The kinds of texture a spec names (``KIND:VALUES``, :func:`texture_from_spec`), each with its
values as ``--help`` writes them."""
_KINDS_TEXT = ", ".join(f"'{k}:{v}'" for k, v in TEXTURE_KINDS.items())
_KIND_ALIASES = {"sinusoid": "sine", "sin": "sine", "sinus": "sine", "sumofsinusoids": "sum", "sines": "sum",
                 "bandlimitednoise": "noise", "eggcrate": "egg-crate"}
"""Names a newcomer writes for a kind: the Python classes' (``Sinusoid``, ``SumOfSinusoids``,
``BandLimitedNoise``), without the hyphen (``eggcrate``, ``egg_crate``), a short form."""


def _exists(spec: str) -> bool:
    """Whether a file or folder has the name ``spec`` (False where the system cannot say: a name
    too long for it, or one holding a NUL)."""
    try:
        return Path(spec).exists()
    except (OSError, ValueError):
        return False


def _neither(spec: str, kind: str, rest: str) -> str:
    """The refusal of a texture spec that is neither a file nor ``KIND:VALUES`` of a known kind:
    what it lacks, every kind with its values, and the spec as meant where its kind reads as a
    misspelt one (its case, an alias, or difflib's closest kind of the same first letter at a ratio
    of 0.6 or more), with the values as typed."""
    looks = re.fullmatch(r"[A-Za-z][A-Za-z_-]+", kind) is not None and ":" in spec  # (not a drive letter, C:)
    if kind in TEXTURE_KINDS:
        why = f"'{kind}' needs its values, '{kind}:{TEXTURE_KINDS[kind]}'"
    elif looks:
        why = f"no file has that name and '{kind}' is not a kind of texture"
    else:
        why = "no such file"
    shown = repr(spec) if len(spec) <= 120 else repr(spec[:120]) + "..."
    said = f"texture = {shown} is not allowed: {why}; must be {_KINDS_TEXT} or a topography file's path"
    if looks and kind not in TEXTURE_KINDS and rest:
        key = kind.lower().replace("_", "-")
        meant = _KIND_ALIASES.get(key.replace("-", ""), key if key in TEXTURE_KINDS else None)
        close = difflib.get_close_matches(key, [k for k in TEXTURE_KINDS if k[0] == key[0]], n=1, cutoff=0.6)
        meant = meant or (close[0] if close else None)
        if meant is not None:
            said += f" (did you mean {meant + ':' + rest!r}?)" if len(rest) <= 80 else f" (did you mean '{meant}:...'?)"
    return said


def quantity(text, unit: str, name: str) -> float:
    """A quantity as the command line takes it: a unit is required unless the value is 0
    or the quantity is dimensionless."""
    return parse_quantity(text, unit, name, require_unit=unit != "dimensionless")


def split_spec(text: str, name: str, kind: str, count: tuple[int, int]):
    """The comma-separated values of ``kind:text``, refused unless there are ``count[0]``
    to ``count[1]`` of them."""
    parts = [v.strip() for v in text.split(",")] if text else []
    if not count[0] <= len(parts) <= count[1]:
        raise ParameterError(f"{name} = {kind + ':' + text!r} is not allowed: {kind} takes {count[0]}"
                             + (f" to {count[1]}" if count[1] != count[0] else "") + " comma-separated values")
    return parts


def check_tip_spacing(tip_radius, tip_spacing) -> None:
    """Refuse a felt map's spacing that is not a finite length > 0 (m), or given without the ball
    it is for (``--tip-spacing`` without ``--tip-radius``: nothing is felt, and a spacing would
    be silently ignored)."""
    from ._validation import positive

    if tip_spacing is not None:
        positive("tip_spacing", tip_spacing, "m")
    if tip_spacing is not None and not tip_radius:
        raise ParameterError(f"--tip-spacing is not allowed without --tip-radius: it is the grid of the map a ball "
                             f"feels (got {tip_spacing:g} m and no ball)")


READING_KEYS = {"spacing": "m", "x_unit": str, "height_unit": str, "variable": str, "level": bool, "lowpass": "m",
                "scale": str, "periodic": bool, "fill_undefined": bool, "crop": str}
""":func:`texture_from_spec`'s keywords that say how a measured file is read, each with a
quantity's SI unit or its value's type: the command line's ``--spacing``, ... (``--crop`` with
the ball's options) and a sweep SPEC's [algorithm] keys."""


def texture_from_spec(spec: str, spacing=None, x_unit=None, height_unit=None, level=False, lowpass=None, scale=None,
                       periodic=False, fill_undefined=False, crop=None, variable=None):
    """The texture a spec names.

    Parameters
    ----------
    spec : str
        ``sine:AMPLITUDE,PERIOD`` (:class:`~haptex.Sinusoid`), ``sum:A1,L1;A2,L2;...``
        (:class:`~haptex.SumOfSinusoids`), ``noise:RMS,SHORTEST,LONGEST,LENGTH[,SEED]``
        (:class:`~haptex.BandLimitedNoise`), ``egg-crate:AMPLITUDE,PERIOD`` and
        ``grating:AMPLITUDE,PERIOD[,DIRECTION]`` (surfaces), each length with its unit
        ("0.8mm"); anything else is a file read by :func:`haptex.load_texture`.
    spacing, x_unit, height_unit, periodic, fill_undefined, variable
        As :func:`haptex.load_texture` takes them; files only.
    crop : str, optional
        ``"auto"`` or ``"X0,X1"`` / ``"X0,X1,Y0,Y1"``, each length with its unit (files only).
    level : bool
        Remove the least-squares line (files only).
    lowpass : float, optional
        Low-pass cut-off period (m) (files only).
    scale : str, optional
        ``"LENGTH_FACTOR,HEIGHT_FACTOR"`` (files only).

    Returns
    -------
    Texture

    Raises
    ------
    ParameterError
        If a value is missing, has no unit or the wrong one, is out of range, a file
        option is given with a synthetic texture, or the file cannot be read.
    """
    from .surfaces import load_texture
    from .textures import BandLimitedNoise, Sinusoid, SumOfSinusoids

    if not str(spec).strip():  # (an empty path is the working folder, which no reader takes)
        raise ParameterError(f"texture = {spec!r} is not allowed: must be {_KINDS_TEXT} or a topography file's path")
    kind, _, rest = spec.partition(":")
    if not (kind in TEXTURE_KINDS and rest) and not _exists(spec):
        raise ParameterError(_neither(spec, kind, rest))
    if kind in TEXTURE_KINDS and rest:
        given = [flag for flag, v in (("--spacing", spacing), ("--x-unit", x_unit), ("--height-unit", height_unit),
                                      ("--level", level), ("--lowpass", lowpass), ("--scale", scale),
                                      ("--periodic", periodic), ("--fill-undefined", fill_undefined),
                                      ("--crop", crop), ("--variable", variable))
                 if v not in (None, False)]
        if given:
            raise ParameterError(f"{given[0]} is not allowed with the synthetic texture {kind + ':' + rest!r}: "
                                 f"{', '.join(given)} appl{'ies' if len(given) == 1 else 'y'} to measured profiles read from "
                                 "a file")
    if kind == "sine" and rest:
        a, ell = split_spec(rest, "texture", "sine", (2, 2))
        return Sinusoid(quantity(a, "m", "amplitude"), quantity(ell, "m", "period"))
    if kind == "sum" and rest:
        terms = [split_spec(t.strip(), "texture", "sum", (2, 2)) for t in rest.split(";")]
        return SumOfSinusoids([quantity(a, "m", f"amplitude {i + 1}") for i, (a, _) in enumerate(terms)],
                              [quantity(ell, "m", f"period {i + 1}") for i, (_, ell) in enumerate(terms)])
    if kind == "egg-crate" and rest:
        from .surfaces import SumOfGratings

        a, ell = split_spec(rest, "texture", "egg-crate", (2, 2))
        return SumOfGratings.egg_crate(quantity(a, "m", "amplitude"), quantity(ell, "m", "period"))
    if kind == "grating" and rest:
        from .surfaces import Grating

        vals = split_spec(rest, "texture", "grating", (2, 3))
        direction = quantity(vals[2], "radian", "direction") if len(vals) == 3 else 0.0
        return Grating(quantity(vals[0], "m", "amplitude"), quantity(vals[1], "m", "period"), direction)
    if kind == "noise" and rest:
        vals = split_spec(rest, "texture", "noise", (4, 5))
        names = ["rms", "shortest_period", "longest_period", "length"]
        q = [quantity(v, "m", n) for v, n in zip(vals[:4], names)]
        seed = 0
        if len(vals) == 5:
            if not re.fullmatch(r"\d{1,20}", vals[4]):
                raise ParameterError(f"seed = {vals[4][:30]!r}{'...' if len(vals[4]) > 30 else ''} is not allowed: "
                                     "must be a whole number in [0, 2^64)")
            seed = int(vals[4])
        return BandLimitedNoise(*q, seed=seed)
    if crop is not None and str(crop).strip().lower() != "auto":
        parts = [v.strip() for v in str(crop).split(",")]
        if len(parts) not in (2, 4):
            raise ParameterError(f"crop = {str(crop)[:80]!r} is not allowed: give 'auto', X0,X1 (a line scan) or "
                                 "X0,X1,Y0,Y1 (a map), each length with its unit, e.g. 0.1mm,0.9mm")
        crop = tuple(quantity(v, "m", "crop") for v in parts)
    prof = load_texture(spec, spacing=spacing, x_unit=x_unit, height_unit=height_unit, variable=variable,
                        periodic=periodic, fill_undefined=fill_undefined, crop=crop)
    tip = prof.instrument_tip  # (the file's own tip: still the map's after levelling or a low-pass, not a scaling)
    if level:
        prof = prof.leveled()
    if lowpass is not None:
        with renamed("lowpass", "shortest_period"):  # (the option the user typed, not the method's parameter)
            prof = prof.lowpass(lowpass)
    prof.instrument_tip = tip
    if scale is not None:
        lf, hf = split_spec(scale, "scale", "scale", (2, 2))
        try:
            lf, hf = float(lf), float(hf)
        except ValueError:
            raise ParameterError(f"scale = {scale!r} is not allowed: must be 'length_factor,height_factor', two "
                                 "numbers") from None
        try:
            prof = prof.scaled(lf, hf)
        except ParameterError as exc:  # (the factor's own reason: a length factor not > 0, ...)
            raise ParameterError(f"scale = {scale!r} is not allowed: {exc}") from None
    return prof


def object_from_spec(spec, uv_scale=None, vertex_normals: bool = False, files: bool = True, mesh_unit=None,
                     box_uv: bool = False):
    """The base of an object spec (None for None): 'plane', 'sphere:RADIUS', 'cylinder:RADIUS'
    (RADIUS with its unit), or a closed triangle mesh file (with ``uv_scale``, metres per unit
    of its texture coordinates, ``mesh_unit`` its vertices' unit, ``box_uv`` for a box projection
    where it has none, and ``vertex_normals`` for the prism base); ``files=False``
    refuses files (the explorer).

    Raises
    ------
    ParameterError
        For anything else, a radius without its unit or out of range, a mesh that does not
        read, or ``uv_scale`` / ``vertex_normals`` where they do not apply, naming the option.
    """
    from pathlib import Path

    from .objects import Cylinder, Mesh, Plane, Sphere

    # (the options a mesh alone takes, each given or not, and why)
    mesh_only = [(option, why) for option, given, why in (
        ("--uv-scale", uv_scale is not None, "it scales a mesh's texture coordinates"),
        ("--vertex-normals", vertex_normals, "it applies to a mesh"),
        ("--mesh-unit", mesh_unit is not None, "it is a mesh file's unit"),
        ("--box-uv", box_uv, "it lays a texture on a mesh")) if given]
    if spec is None:
        if mesh_only:
            raise ParameterError(f"{mesh_only[0][0]} is not allowed without --object: {mesh_only[0][1]}")
        return None
    kind, _, arg = str(spec).partition(":")
    kind = kind.strip().lower()
    if mesh_only and kind in ("plane", "sphere", "cylinder"):
        raise ParameterError(f"{mesh_only[0][0]} is not allowed with --object {spec!r}: {mesh_only[0][1]}")
    if kind == "plane" and not arg:
        return Plane()
    if kind in ("sphere", "cylinder"):
        radius = parse_quantity(arg, "m", "object", require_unit=True)
        return (Sphere if kind == "sphere" else Cylinder)(radius)
    allowed = "'plane', 'sphere:RADIUS', 'cylinder:RADIUS'" + (" or an existing mesh file" if files else "")
    path = Path(str(spec))
    if not files or not path.is_file():
        raise ParameterError(f"object = {str(spec)[:80]!r} is not allowed: must be {allowed}")
    if box_uv and uv_scale is not None:
        raise ParameterError("--uv-scale is not allowed with --box-uv: the box projection's coordinates are in metres")
    return Mesh(path, uv="box" if box_uv else None, uv_scale=uv_scale, normals="vertex" if vertex_normals else None,
                unit=1.0 if mesh_unit is None else mesh_unit)
