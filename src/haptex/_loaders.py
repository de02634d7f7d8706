"""Readers of measured topography: line scans and areal height maps (private; used by
``SampledProfile.from_file``, ``SampledSurface.from_file`` and ``load_texture``).

Every instrument format is read by SurfaceTopography (ContactEngineering, MIT licence),
which knows some 40 of them. haptex keeps two readers of its own, each where
SurfaceTopography fails on files our users and tests have:

- MATLAB ``.mat``: SurfaceTopography's reader skips variables that are not numeric arrays
  without saying so (a struct, a cell array, a sparse matrix, text) and keeps the real part
  of a complex array; ours refuses each of these by name (scipy.io.loadmat).
- Text columns SurfaceTopography does not recognise (a stray word in a data row, a comment
  line, more than three columns), a chosen column, UTF-8 text that starts with a byte
  order mark (SurfaceTopography 1.27 drops that first row without saying so), and one column
  of numbers written with decimal commas (SurfaceTopography's readers split "0,3456" into x
  and height), a table of four or more named columns (a profilometer's "Counter,
  Altitude (um), Encoder1 (um), ...", which SurfaceTopography's matrix reader took for a map),
  and two columns named with their units ("x (um),h (nm)", whose units its XYZ reader reads
  past): ours reads them, or names the line that is wrong.

Units and sample spacing are taken from the file when it states them and otherwise
required from the caller; nothing is guessed. Every error is one line naming the file.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ._columns import _number, decimal_comma, first_line as _first_line
from ._columns import mat_numbers as _mat_samples
from ._units import parse_quantity
from ._validation import ParameterError, a_path, check_budget

_UNIT_WORDS = {
    "um": "um", "µm": "um", "μm": "um", "micrometer": "um", "micrometre": "um", "micron": "um", "microns": "um",
    "nm": "nm", "nanometer": "nm", "nanometre": "nm", "mm": "mm", "millimeter": "mm", "millimetre": "mm",
    "m": "m", "meter": "m", "metre": "m", "a": "angstrom", "å": "angstrom", "angstrom": "angstrom",
}


def _unit_factor(unit: str, name: str, where: str) -> float:
    """Metres per unit of a length unit written in a file or by the user."""
    text = str(unit).strip()
    key = text.lower()
    if key in _UNIT_WORDS:
        text = _UNIT_WORDS[key]
    try:
        return parse_quantity(f"1 {text}", "m", name)
    except ParameterError:
        raise ParameterError(f"{name} = {unit!r} is not allowed ({where}): must be a length unit such as "
                             "'um', 'nm', 'mm' or 'm'") from None


def _hint(name: str, example: str) -> str:
    """How to give a missing value, in both of haptex's syntaxes."""
    return _hints([(name, example)])


_COMMAND_LINE_HINT = re.compile(r"--[a-z][a-z-]*(?: [^\s,;()]+)?(?: --[a-z][a-z-]*(?: [^\s,;()]+)?)* at the command "
                                r"line, (.*?) in Python")


def remedy_in(message: str, where: str) -> str:
    """A refusal whose remedies are written for the command line and Python (:func:`_hints`:
    "--spacing 0.5um at the command line, spacing='0.5um' in Python") with them written for
    another front end that takes the same keys: "spacing = '0.5um' ``where``" (a sweep SPEC's
    [algorithm], the explorer's file boxes), each key = value as TOML writes it; an option given
    for the command line alone ("--object sphere:20.05mm at the command line") or named alone
    ("takes 32 x 15 samples: --crop 0,31um,9um,23um", "add --fill-undefined") as its key too."""
    def keys(m):
        text = re.sub(r"\b(\w+)=", r"\1 = ", m.group(1)).replace("= True", "= true").replace("= False", "= false")
        return f"{text} {where}"

    text = _COMMAND_LINE_HINT.sub(keys, message)
    # (an option with its value for the command line alone: a closed object's radius)
    text = re.sub(r"--([a-z][a-z-]*) ([^\s;()]*[^\s;(),]) at the command line",
                  lambda m: f"{m.group(1).replace('-', '_')} = '{m.group(2)}' {where}", text)
    # (an option named alone: a flag, or one with its value, as the crop's bounds after "takes N samples:")
    text = re.sub(r"--(fill-undefined|level|periodic)\b", lambda m: f"{m.group(1).replace('-', '_')} = true", text)
    return re.sub(r"--([a-z][a-z-]*) ([^\s;()]*[^\s;(),])", lambda m: f"{m.group(1).replace('-', '_')} = "
                  f"'{m.group(2)}'", text)


def _hints(pairs) -> str:
    """How to give missing values (name, example), in both of haptex's syntaxes, once each."""
    cli = " ".join(f"--{n.replace('_', '-')} {e}" for n, e in pairs)
    py = ", ".join(f"{n}='{e}'" for n, e in pairs)
    return f"{cli} at the command line, {py} in Python"


def _spacing(spacing, where: str) -> float:
    if isinstance(spacing, str):
        v = parse_quantity(spacing, "m", "spacing")
    else:
        try:
            v = float(spacing)
        except (TypeError, ValueError):
            raise ParameterError(f"spacing = {spacing!r} is not allowed ({where}): must be a length > 0") from None
    if not (math.isfinite(v) and v > 0):
        raise ParameterError(f"spacing = {spacing!r} is not allowed ({where}): must be a length > 0")
    return v


TEXT_BYTES_FACTOR = 40
"""Bytes of memory a file takes per byte while it is parsed (measured on text: a 10^7-line,
80 MB CSV peaked at 3.3 GB); binary formats take less, and are held to the same bound."""


def _archive(path: Path, raw: bytes) -> str | None:
    """What an archive holds and how to unpack it, or None for a file that is not one: gzip
    (RFC 1952's magic bytes 1f 8b) and ZIP (PKWARE's local file header "PK\\x03\\x04"), whose
    members neither SurfaceTopography's readers (but X3P's own, tried before) nor the text reader
    open."""
    if raw[:2] == b"\x1f\x8b":
        return f"a gzip-compressed file: unpack it (gunzip -k {path}) and give the file inside"
    if raw[:4] == b"PK\x03\x04":
        import zipfile

        try:
            with zipfile.ZipFile(path) as archive:
                names = [i.filename for i in archive.infolist()[:MAX_ZIP_MEMBERS + 1] if not i.is_dir()]
        except (zipfile.BadZipFile, OSError, ValueError):
            return "a damaged ZIP archive: unpack it with your archive tool and give one of its files"
        shown = ", ".join(names[:5]) + (", ..." if len(names) > 5 else "")
        return (f"a ZIP archive of {len(names)} file{'s' * (len(names) != 1)} ({shown}): unpack it "
                f"(unzip {path}) and give one of its files")
    return None


def _read_text(path: Path, why: str | None = None) -> str:
    raw = path.read_bytes()
    archive = _archive(path, raw)
    if archive is not None:
        raise ParameterError(f"{path}: {archive}")
    if b"\x00" in raw[:4096]:
        if why is not None:
            raise ParameterError(f"{path}: {why}, and it is not text either (NUL bytes); see SurfaceTopography's "
                                 "list of formats, or export the data as text columns")
        raise ParameterError(f"{path}: the file is not readable text (NUL bytes: binary or UTF-16); "
                             "export it as UTF-8 or Latin-1 text")
    try:
        text = raw.decode("utf-8-sig")  # a byte-order mark is not part of the first row
    except UnicodeDecodeError:
        text = raw.decode("latin-1")  # Dektak exports: the micro sign is byte 0xB5
    return text.replace("\r\n", "\n").replace("\r", "\n")


ST_BYTES_PER_SAMPLE = 400
"""Bytes of memory per sample while a file's samples are read, turned into a spline and
band-limited by ``design`` (the reader's masked heights and positions, our copy in metres,
the spline's coefficients and knots, the low-pass and the resampled copy): measured peaks of
339 bytes a sample on a line scan of 10^6 samples and 293 on one of 5 x 10^7, 195 on a
1024 x 1024 map; used to refuse a file too large for memory before its data are read (a
4096 x 4096 map needs 6.7 GB)."""
MAX_ZIP_MEMBERS = 10_000
"""Most members a zip container (X3P) may list."""
ZIP_DATA_BYTES_FACTOR = 4
"""Bytes of memory a zip member's decompressed binary byte takes while it is read (the
inflated bytes and the array made from them, with room to spare)."""


@dataclass(frozen=True)
class Reading:
    """What a file holds, in metres.

    Attributes
    ----------
    x : ndarray, shape (nx,)
        Positions along the scan (m), strictly increasing.
    y : ndarray, shape (ny,), or None
        Row positions (m) of an areal map; None for a line scan.
    h : ndarray, shape (nx,) or (nx, ny)
        Heights (m), finite.
    source : str
        The file's name.
    reader : str
        Which reader read it (``SurfaceTopography: <format>`` or ``haptex: <format>``).
    filled : int
        How many undefined (NaN) samples were filled by interpolation (0 unless asked).
    instrument_tip : float or None
        The measuring tip's radius (m) where the file states it, else None.
    """

    x: np.ndarray
    y: np.ndarray | None
    h: np.ndarray
    source: str
    reader: str
    filled: int = 0
    instrument_tip: float | None = None

    @property
    def areal(self) -> bool:
        return self.y is not None


def read_topography(path, *, spacing=None, x_unit=None, height_unit=None, variable=None, x_column=0,
                    height_column=1, fill_undefined=False, crop=None) -> Reading:
    """Read a line scan or an areal map from a file; see ``SampledProfile.from_file`` and, for
    ``crop``, :func:`crop_region`."""
    crop = _checked_crop(crop)
    p = a_path("path", path, "a topography file's path")
    if p.is_dir():
        raise ParameterError(f"path = {str(p)!r} is not allowed: it is a directory, not a topography file")
    if not p.exists():
        raise ParameterError(f"path = {str(p)!r} is not allowed: no such file")
    if not p.is_file():
        raise ParameterError(f"path = {str(p)!r} is not allowed: not a regular file")
    if p.stat().st_size == 0:
        raise ParameterError(f"{p}: the file is empty")
    check_budget("path", str(p), TEXT_BYTES_FACTOR * p.stat().st_size, "reading this file")
    _check_zip(p)
    if p.suffix.lower() == ".mat":
        return _cropped(p, _load_mat(p, spacing, height_unit, variable, x_unit), crop)
    with open(p, "rb") as fh:
        bom = fh.read(3) == b"\xef\xbb\xbf"
    head = _text_head(p)  # (read once: which of the text readers below takes the file)
    if (x_column, height_column) != (0, 1) or bom or (head is not None and _decimal_comma_column(head)):
        if variable is not None:  # (not ignored: these columns are chosen by x_column and height_column)
            raise ParameterError(f"variable = {variable!r} is not allowed: {p} is read as text columns, chosen by "
                                 "x_column and height_column in Python")
        return _cropped(p, _read_text_columns(p, spacing, x_unit, height_unit, x_column, height_column, None), crop)
    names = _named_columns(head)
    if names is not None:  # (a table of named columns: SurfaceTopography's matrix reader read it as a map)
        return _cropped(p, _read_named_columns(p, names, spacing, x_unit, height_unit, variable), crop)
    stated = _named_units(head, p)
    if stated is not None:  # (x and height named with their units: SurfaceTopography's XYZ reader reads past them)
        for name, given, unit, what in (("x_unit", x_unit, stated[0], "positions'"),
                                        ("height_unit", height_unit, stated[1], "heights'")):
            if given is not None and _unit_factor(given, name, str(p)) != _unit_factor(unit, name, str(p)):
                raise ParameterError(f"{name} = {given!r} is not allowed: {p} states its {what} unit ({unit}), "
                                     "which is used")
        if variable is not None:
            raise ParameterError(f"variable = {variable!r} is not allowed: {p} holds one profile, x and height")
        return _cropped(p, _read_text_columns(p, spacing, stated[0], stated[1], 0, 1, None), crop)
    reader, why = _open(p)
    if reader is None:
        return _cropped(p, _read_text_columns(p, spacing, x_unit, height_unit, x_column, height_column, why), crop)
    return _read_st(p, reader, spacing, x_unit, height_unit, variable, fill_undefined, crop)


def _text_head(p: Path) -> list | None:
    """The whole lines of the first TEXT_PROBE bytes of ``p`` (UTF-8, undecodable bytes
    replaced), or None where they are not text (a NUL byte)."""
    with open(p, "rb") as fh:
        head = fh.read(TEXT_PROBE)
    if b"\0" in head:
        return None
    lines = head.decode("utf-8", errors="replace").split("\n")
    return lines[:-1] if len(head) == TEXT_PROBE else lines


NAMED_COLUMNS = 4
"""The fewest named columns a text table (a header row of names above rows of numbers) has that is
read by its columns (:func:`_named_columns`) rather than by SurfaceTopography, whose XYZ reader
takes two or three columns as x, (y,) height and whose plain-text matrix reader took a
profilometer's "Counter, Altitude (um), Encoder1 (um), Encoder2 (um), Row number" for a map five
samples wide."""


def _header_row(head):
    """(delimiter, names, first row's cells) of a text file's head (:func:`_text_head`'s lines):
    its first two lines that are neither blank nor comments, parted by the first of a tab, a
    semicolon or a comma the first holds (names may hold spaces; None: runs of whitespace);
    None where it has fewer than two such lines."""
    lines = [ln.strip() for ln in head or []]
    lines = [ln for ln in lines if ln and not ln.startswith(("#", "%"))]
    if len(lines) < 2:
        return None
    delimiter = next((d for d in ("\t", ";", ",") if d in lines[0]), None)
    names, row = ([c.strip() for c in ln.split(delimiter)] for ln in lines[:2])
    return delimiter, names, row


def _named_columns(head) -> list | None:
    """The names of a text table's columns (a header row of names, none a number, above a row of
    as many numbers: :data:`NAMED_COLUMNS` at least), from a file's head (:func:`_header_row`);
    None for any other file."""
    found = _header_row(head)
    if found is None:
        return None
    _, names, row = found
    while names and not names[-1]:  # (a row that ends in its delimiter)
        names.pop()
        row = row[:-1] if row and not row[-1] else row
    if len(names) < NAMED_COLUMNS or len(row) != len(names) or not all(names):
        return None
    return names if not any(_number(c) for c in names) and all(_number(c) for c in row) else None


_UNIT_IN_NAME = re.compile(r"[(\[]\s*([^()\[\]]+?)\s*[)\]]\s*$")


def _unit_in_name(name: str, p: Path) -> str | None:
    """The length unit a column's name ends with ("Altitude (um)", "z [nm]"), or None where it
    names none (or none of length)."""
    found = _UNIT_IN_NAME.search(name)
    if not found:
        return None
    try:
        _unit_factor(found.group(1), "unit", str(p))
    except ParameterError:
        return None
    return found.group(1)


def _named_units(head, p: Path) -> tuple | None:
    """(x unit, height unit) of a text file of two columns each named with its length unit ("x
    (um),h (nm)", "X [mm];Z [um]", parted by a comma, semicolon or tab), from its head
    (:func:`_header_row`); None for any other file."""
    found = _header_row(head)
    if found is None or found[0] is None:
        return None
    _, names, row = found
    if len(names) != 2 or len(row) != 2 or not all(_number(c) for c in row):
        return None
    units = [_unit_in_name(n, p) for n in names]
    return tuple(units) if all(units) else None


def _read_named_columns(p: Path, names, spacing, x_unit, height_unit, variable) -> Reading:
    """A text table of named columns (:func:`_named_columns`) as a line scan: the heights the
    column ``variable`` names (by name or index), in the unit the caller gives or else the one its
    name states ("Altitude (um)", "z [nm]"), the positions from ``spacing``."""
    if variable is None:
        listed = ", ".join(f"{k} {n}" for k, n in enumerate(names))
        raise ParameterError(f"{p}: a table of {len(names)} named columns ({listed}): choose the heights' column by "
                             f"its name or its index, {_hint('variable', '1')}")
    k = _channel_index(p, names, variable)
    if x_unit is not None:
        raise ParameterError(f"x_unit = {x_unit!r} is not allowed: {p}'s positions are its samples' order; give the "
                             "sample spacing")
    if height_unit is None:
        height_unit = _unit_in_name(names[k], p)
    r = _read_text_columns(p, spacing, None, height_unit, None, k, None)
    return Reading(r.x, None, r.h, f"{p.name}, column {names[k]}", "haptex: text columns")


def _open(p: Path):
    """(SurfaceTopography reader, None), or (None, why) when it recognises no format. The
    readers' own log records (igor2 logs an ERROR with 1 KB of the file's bytes when it
    tries a file that is not Igor's) are silenced: the caller's one line says why."""
    import logging

    logging.disable(logging.ERROR)
    try:
        return _open_quietly(p)
    finally:
        logging.disable(logging.NOTSET)


def _open_quietly(p: Path):
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from SurfaceTopography import open_topography
        from SurfaceTopography.Exceptions import CannotDetectFileFormat

        from SurfaceTopography.IO import readers

        # the readers that claim the file's extension first: detection alone tries readers in
        # a fixed order, and its text reader read a 4096 x 4096 X3P's 128 MB as lines for
        # 37 s before the X3P reader was tried (0.1 s by extension)
        # (but not the extensions of its plain-text matrix reader, .txt, .asc, .dat: there its
        # detection tries the XYZ reader of x, y, height rows first, and the matrix reader read
        # such rows as a map three samples wide)
        suffix = p.suffix.lower().lstrip(".")
        text = {e for r in readers if r.format() == "asc" for e in (r.file_extensions() or [])}
        for r in readers if suffix not in text else ():
            if suffix and suffix in (r.file_extensions() or []):
                try:
                    return open_topography(str(p), format=r.format()), None
                except MemoryError:
                    raise
                except Exception:  # noqa: BLE001 - detection below tries every reader and says why
                    pass
        try:
            return open_topography(str(p)), None
        except CannotDetectFileFormat:
            return None, "SurfaceTopography recognises none of its formats in it"
        except MemoryError:
            raise ParameterError(f"{p}: reading it ran out of memory; the file is too large") from None
        except Exception as exc:  # a reader that recognised the file and then failed: corrupt or truncated
            return None, f"SurfaceTopography cannot read it ({_first_line(exc)})"


def _read_text_columns(p: Path, spacing, x_unit, height_unit, x_column, height_column, why) -> Reading:
    try:
        text = _read_text(p, why)
    except OSError as exc:
        raise ParameterError(f"{p}: cannot read it ({exc.strerror})") from None
    x, h = _load_columns(p, text.split("\n"), spacing, x_unit, height_unit, x_column, height_column)
    return Reading(x, None, h, p.name, "haptex: text columns")


def _channel_index(p: Path, names: list, variable) -> int:
    """The index of the channel ``variable`` names among an instrument file's channels ``names``:
    a name held once, or an index (a whole number; two channels may share a name, as a trace and
    a retrace 'Height')."""
    v = str(variable).strip()
    if v.isdigit() and int(v) < len(names):
        return int(v)
    which = [i for i, n in enumerate(names) if n == v]
    if len(which) == 1:
        return which[0]
    if which:
        raise ParameterError(f"variable = {variable!r} is not allowed: {p} holds {len(which)} channels named {v!r} "
                             f"({', '.join(map(str, which[:-1]))} and {which[-1]}): choose one by its index, "
                             f"{_hint('variable', str(which[0]))}")
    raise ParameterError(f"variable = {variable!r} is not allowed: {p} holds the channels {names}: give one's name or "
                         f"its index, 0 to {len(names) - 1}")


def _read_st(p: Path, reader, spacing, x_unit, height_unit, variable, fill_undefined, crop=None) -> Reading:
    import warnings

    fmt = type(reader).name()
    channels = reader.channels
    if not channels:
        raise ParameterError(f"{p}: the {fmt} file holds no height data")
    if variable is None:
        ch = reader.default_channel
    else:
        ch = channels[_channel_index(p, [c.name for c in channels], variable)]
    shape = tuple(int(n) for n in ch.nb_grid_pts)
    count = int(np.prod(shape))
    check_budget("path", str(p), ST_BYTES_PER_SAMPLE * count, f"a {' x '.join(map(str, shape))} {fmt} map")
    unit = ch.unit
    if isinstance(unit, (tuple, list)):
        unit = unit[0]
    stated = unit is not None
    for name, given in (("x_unit", x_unit), ("height_unit", height_unit)):
        if stated and given is not None:
            raise ParameterError(f"{name} = {given!r} is not allowed: {p} states its unit ({unit}), which is used")
    if spacing is not None and ch.physical_sizes is not None:  # (its positions, with or without their unit)
        raise ParameterError(f"spacing = {spacing!r} is not allowed: {p} states its "
                             f"{'physical size' if stated else 'positions'}, which are used; leave the spacing out")
    sizes = ch.physical_sizes
    if sizes is None and x_unit is not None:
        raise ParameterError(f"x_unit = {x_unit!r} is not allowed: {p} has no positions; give the sample spacing")
    missing = []
    if not stated and height_unit is None:
        missing.append(("height_unit", "um"))
    if sizes is None and spacing is None:
        missing.append(("spacing", "0.5um"))
    elif sizes is not None and not stated and x_unit is None:
        missing.append(("x_unit", "um"))
    if missing:
        raise ParameterError(f"{p} ({fmt}) does not state its " + " or ".join(
            {"height_unit": "height unit", "spacing": "sample spacing", "x_unit": "lateral unit"}[n] for n, _ in missing)
            + ": give " + _hints(missing))
    hf = _unit_factor(unit if stated else height_unit, "unit" if stated else "height_unit", str(p))
    xf = hf if stated else (None if x_unit is None else _unit_factor(x_unit, "x_unit", str(p)))
    step = None if sizes is not None else _spacing(spacing, str(p))
    kw = {} if sizes is not None else {"physical_sizes": tuple(float(n) for n in shape)}
    if not stated:
        kw["unit"] = "m"  # a placeholder: the numbers are scaled by the caller's units below
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            topo = reader.topography(channel_index=ch.index, **kw)
            heights = np.ma.getdata(topo.heights()).astype(np.float64)
            mask = np.ma.getmaskarray(topo.heights())
    except MemoryError:
        raise ParameterError(f"{p}: reading it ran out of memory; the file is too large") from None
    except Exception as exc:  # truncated or corrupt data after a valid header
        raise ParameterError(f"{p}: SurfaceTopography's {fmt} reader cannot read it ({_first_line(exc)})") from None
    mask = mask | ~np.isfinite(heights)
    tip = _stated_tip(p, getattr(topo, "info", {}) or {})
    if not mask.any() and crop is None:
        mask = None
    h = heights * hf
    line = heights.ndim == 1 or min(heights.shape) == 1
    if line:
        h = h.ravel()
        mask = None if mask is None else mask.ravel()
        n = h.size
        if step is not None:
            x = step * np.arange(n)
        elif getattr(topo, "is_uniform", True):
            size = float(np.ravel(sizes)[int(np.argmax(shape))]) if heights.ndim == 2 else float(np.ravel(sizes)[0])
            x = (size / n) * np.arange(n) * xf
        else:
            x = _rounded_uniform(np.asarray(topo.positions(), dtype=np.float64)) * xf
        y = None
    elif step is not None:
        x, y = step * np.arange(h.shape[0]), step * np.arange(h.shape[1])
    else:
        (sx, sy) = (float(s) for s in sizes)
        x = (sx / h.shape[0]) * np.arange(h.shape[0]) * xf
        y = (sy / h.shape[1]) * np.arange(h.shape[1]) * xf
    source = p.name if variable is None else f"{p.name}, channel {ch.index} ({ch.name})"  # (the one chosen)
    if crop is not None:
        x, y, h, mask, source = _apply_crop(p, x, y, h, mask, crop, fill_undefined, source)
    undefined = 0 if mask is None else int(mask.sum())
    if undefined and not fill_undefined:
        first = np.unravel_index(int(np.argmax(mask.ravel())), mask.shape)
        where = f"sample {first[0]}" if h.ndim == 1 else f"sample {tuple(int(v) for v in first)}"
        auto = _auto_note(x, y, mask)
        raise ParameterError(
            f"{p}: {undefined} of {mask.size} heights are undefined (NaN: the instrument lost them), the first at "
            f"{where}; crop to the measured part ({auto}), or fill them by interpolation (--fill-undefined at the "
            "command line, fill_undefined=True in Python)")
    if undefined == h.size:
        raise ParameterError(f"{p}: every height is undefined (NaN); there is nothing to fill from")
    if y is None:
        if undefined:
            x, h, source = _fill_line(p, x, h, mask, source)
        _check(p, x, h)
        return Reading(x, None, h, source, f"SurfaceTopography: {fmt}", undefined, tip)
    if undefined:
        x, y, h, source = _fill_map(p, x, y, h, mask, source)
    return Reading(x, y, h, source, f"SurfaceTopography: {fmt}", undefined, tip)


def _stated_tip(p: Path, info: dict) -> float | None:
    """The measuring tip's radius (m) a file states (SurfaceTopography's
    ``info['instrument']['parameters']['tip_radius']``), None where it states none or none that
    is a finite length > 0."""
    try:
        tip = info["instrument"]["parameters"]["tip_radius"]
        r = float(tip["value"]) * _unit_factor(str(tip["unit"]), "tip_radius", str(p))
    except (KeyError, TypeError, ValueError, ParameterError):
        return None
    return r if np.isfinite(r) and r > 0 else None


CROP_AUTO = "auto"
"""``crop="auto"``: the largest measured part (see :func:`crop_region`)."""


def _checked_crop(crop):
    """``crop`` as None, "auto" or a tuple of 2 or 4 finite floats (m), or ParameterError."""
    if crop is None or (isinstance(crop, str) and crop.strip().lower() == CROP_AUTO):
        return None if crop is None else CROP_AUTO
    try:
        values = tuple(float(v) for v in crop)
    except (TypeError, ValueError):
        raise ParameterError(f"crop = {crop!r} is not allowed: must be 'auto', (x0, x1) for a line scan or "
                             "(x0, x1, y0, y1) for a map, in metres") from None
    if len(values) not in (2, 4) or not all(np.isfinite(values)):
        raise ParameterError(f"crop = {crop!r} is not allowed: must be 'auto', (x0, x1) for a line scan or "
                             "(x0, x1, y0, y1) for a map, finite, in metres")
    if values[1] <= values[0] or (len(values) == 4 and values[3] <= values[2]):
        raise ParameterError(f"crop = {crop!r} is not allowed: each range must be increasing (x0 < x1, y0 < y1)")
    return values


def _largest_run(ok: np.ndarray) -> tuple[int, int]:
    """The longest run of True in a 1-D mask: [start, stop)."""
    best, start = (0, 0), None
    for i, v in enumerate(np.append(ok, False)):
        if v and start is None:
            start = i
        elif not v and start is not None:
            if i - start > best[1] - best[0]:
                best = (start, i)
            start = None
    return best


def largest_rectangle(ok: np.ndarray) -> tuple[int, int, int, int]:
    """The largest axis-aligned rectangle of True in a 2-D mask, as index ranges
    ``(i0, i1, j0, j1)`` (stops exclusive): the standard maximal-rectangle algorithm, each row
    a histogram of the columns' runs of True ending there, its largest rectangle found with a
    stack; O(rows x columns) time and O(columns) memory.

    Raises
    ------
    ParameterError
        If ``ok`` is not 2-D.
    """
    ok = np.asarray(ok, dtype=bool)
    if ok.ndim != 2:
        raise ParameterError(f"mask of shape {ok.shape} is not allowed: must be 2-D")
    heights = np.zeros(ok.shape[1] + 1, dtype=np.int64)  # a zero sentinel at the end
    best, best_area = (0, 0, 0, 0), 0
    for i in range(ok.shape[0]):
        heights[:-1] = np.where(ok[i], heights[:-1] + 1, 0)
        stack = []
        for j, hj in enumerate(heights):
            start = j
            while stack and stack[-1][1] >= hj:
                s_j, s_h = stack.pop()
                if s_h * (j - s_j) > best_area:
                    best_area, best = s_h * (j - s_j), (i - s_h + 1, i + 1, s_j, j)
                start = s_j
            stack.append((start, hj))
    return best


def crop_region(x, y, mask, crop):
    """The index ranges a crop keeps: ``(slice,)`` for a line scan, ``(slice, slice)`` for a map.

    ``crop="auto"`` takes the largest measured part: a line's longest run of defined samples,
    a map's largest axis-aligned rectangle without undefined points (:func:`largest_rectangle`).
    Bounds ``(x0, x1)`` or ``(x0, x1, y0, y1)`` (m) keep the samples within them.

    Raises
    ------
    ParameterError
        For bounds of the wrong count, outside the data, or holding fewer than 4 samples a side.
    """
    areal = y is not None
    if crop == CROP_AUTO:
        ok = np.ones(np.shape(x) if not areal else (len(x), len(y)), dtype=bool) if mask is None else ~mask
        if not areal:
            i0, i1 = _largest_run(ok)
            return (slice(i0, i1),)
        i0, i1, j0, j1 = largest_rectangle(ok)
        return slice(i0, i1), slice(j0, j1)
    need = 4 if areal else 2
    if len(crop) != need:
        raise ParameterError(f"crop = {crop!r} is not allowed: a {'map' if areal else 'line scan'} is cropped by "
                             f"{'(x0, x1, y0, y1)' if areal else '(x0, x1)'} in metres, or 'auto'")
    out = []
    for axis, pos, (a, b) in (("x", x, crop[:2]), ("y", y, crop[2:])) if areal else (("x", x, crop[:2]),):
        lo, hi = float(pos[0]), float(pos[-1])
        if b < lo or a > hi:
            raise ParameterError(f"crop = {tuple(crop)!r} is not allowed: {axis} in [{a:g}, {b:g}] m lies outside the "
                                 f"data's {axis} in [{lo:g}, {hi:g}] m")
        keep = np.flatnonzero((pos >= a) & (pos <= b))
        if keep.size < 4:
            raise ParameterError(f"crop = {tuple(crop)!r} is not allowed: it keeps {keep.size} samples along {axis}; "
                                 "at least 4 are needed")
        out.append(slice(int(keep[0]), int(keep[-1]) + 1))
    return tuple(out)


def _extent(x, y, region) -> str:
    """A crop region in the units people read (mm or µm), as ``--crop`` takes it."""
    def fmt(v):
        return "0" if v == 0 else f"{v * 1e3:.6g}mm" if abs(v) >= 1e-3 else f"{v * 1e6:.6g}um"
    parts = [x[region[0]][0], x[region[0]][-1]]
    if y is not None:
        parts += [y[region[1]][0], y[region[1]][-1]]
    return ",".join(fmt(float(v)) for v in parts)


def _auto_note(x, y, mask) -> str:
    region = crop_region(x, y, mask, CROP_AUTO)
    n = [r.stop - r.start for r in region]
    if min(n) < 4:
        return "no measured part of 4 samples a side lies without undefined points"
    return (f"--crop auto at the command line, crop='auto' in Python, takes {' x '.join(map(str, n))} samples: "
            f"--crop {_extent(x, y, region)}")


def _apply_crop(p: Path, x, y, h, mask, crop, fill_undefined, name=None):
    """The reading cropped; bounds given by hand must hold no undefined point unless they are
    to be filled (the first is named). ``name``: the source before the crop (default the file's
    name)."""
    region = crop_region(x, y, mask, crop)
    if min(r.stop - r.start for r in region) < 4:
        raise ParameterError(f"{p}: crop = 'auto' finds no measured part of at least 4 samples a side")
    x = x[region[0]]
    y = None if y is None else y[region[1]]
    h = h[region]
    mask = None if mask is None else mask[region]
    if mask is not None and mask.any() and crop != CROP_AUTO and not fill_undefined:
        first = tuple(int(v) + r.start for v, r in zip(np.unravel_index(int(np.argmax(mask.ravel())), mask.shape),
                                                      region))
        raise ParameterError(f"crop = {tuple(crop)!r} is not allowed: it holds {int(mask.sum())} undefined heights, the "
                             f"first at sample {first[0] if len(first) == 1 else first}; crop within the measured part "
                             f"({_auto_note(x, y, mask)}) or add --fill-undefined")
    size = " x ".join(str(r.stop - r.start) for r in region)
    return (x, y, h, mask,
            f"{name or p.name} (cropped to {size} samples: {_extent(x, y, tuple(slice(None) for _ in region))})")


def _cropped(p: Path, reading: Reading, crop) -> Reading:
    """A reading of haptex's own readers (MAT, text columns: no undefined points) cropped."""
    if crop is None:
        return reading
    x, y, h, _, source = _apply_crop(p, reading.x, reading.y, reading.h, None, crop, False, reading.source)
    if y is None:
        _check(p, x, h)
    return Reading(x, y, h, source, reading.reader, reading.filled, reading.instrument_tip)


def _filled_note(p: Path, total: int, cropped: str, filled: int, source: str | None = None) -> str:
    """The texture's source, saying what cropping and filling did (shown wherever the texture is)."""
    parts = ([f"{cropped} with no measured point cropped"] if cropped else []) + (
        [f"{filled} undefined samples ({100 * filled / total:.3g} %) filled by interpolation"] if filled else [])
    base = source if source and source != p.name else p.name
    return f"{base} ({'; '.join(parts)})"


def _fill_line(p: Path, x, h, mask, source: str | None = None):
    """A line scan's undefined samples: those before its first and after its last measured
    sample are cropped (nothing measured lies beyond them to interpolate from), the others
    interpolated linearly in x between their measured neighbours (any reader, uniform or not)."""
    ok = np.flatnonzero(~mask)
    if ok.size < 4:
        raise ParameterError(f"{p}: only {ok.size} heights are defined; at least 4 are needed")
    keep = slice(ok[0], ok[-1] + 1)
    cropped = mask.size - (ok[-1] + 1 - ok[0])
    x, h, mask = x[keep], h[keep].copy(), mask[keep]
    h[mask] = np.interp(x[mask], x[~mask], h[~mask])
    return x, h, _filled_note(p, x.size + cropped, f"{cropped} samples at the ends" if cropped else "",
                              int(mask.sum()), source)


def _fill_map(p: Path, x, y, h, mask, source: str | None = None):
    """An areal map's undefined samples: whole rows and columns at its edges with no measured
    point are cropped; every other undefined sample must lie inside the measured region (a
    measured sample on both sides along its row and along its column) and is filled by
    SurfaceTopography's harmonic interpolation; one outside it would be extrapolated, which
    is refused (issue 35: an FRT map 30 % undefined was extrapolated to 4.6 times its RMS)."""
    import warnings

    from SurfaceTopography import Topography

    total, shape = mask.size, mask.shape
    rows = np.flatnonzero(~mask.all(axis=1))
    cols = np.flatnonzero(~mask.all(axis=0))
    x, y = x[rows[0]:rows[-1] + 1], y[cols[0]:cols[-1] + 1]
    h, mask = h[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1].copy(), mask[rows[0]:rows[-1] + 1, cols[0]:cols[-1] + 1]
    lost = shape[0] - mask.shape[0] + shape[1] - mask.shape[1]
    cropped = f"{lost} edge rows and columns ({total - mask.size} samples)" if lost else ""
    if min(mask.shape) < 4:
        raise ParameterError(f"{p}: its measured region is {mask.shape[0]} x {mask.shape[1]} samples; a height map "
                             "needs at least 4 x 4")

    def inside(m, axis):  # a measured sample before and after, along the axis
        seen = np.logical_or.accumulate(~m, axis=axis)
        after = np.flip(np.logical_or.accumulate(np.flip(~m, axis), axis=axis), axis)
        return seen & after

    outside = mask & ~(inside(mask, 0) & inside(mask, 1))
    if outside.any():
        i, j = (int(v) for v in np.argwhere(outside)[0])
        raise ParameterError(
            f"{p}: {int(outside.sum())} of its undefined heights lie outside the measured region (no measured sample "
            f"beyond them along a row or a column, the first at sample ({i + rows[0]}, {j + cols[0]})): filling them "
            f"would extrapolate; crop to the measured part first ({_auto_note(x, y, mask)})")
    filled = int(mask.sum())
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            topo = Topography(np.ma.masked_array(h, mask), (h.shape[0] * (x[1] - x[0]), h.shape[1] * (y[1] - y[0])),
                              unit="m")
            h = np.ma.getdata(topo.interpolate_undefined_data().heights()).astype(np.float64)
    except Exception as exc:
        raise ParameterError(f"{p}: its undefined heights cannot be filled ({_first_line(exc)})") from None
    return x, y, h, _filled_note(p, total, cropped, filled, source)


def _rounded_uniform(x: np.ndarray) -> np.ndarray:
    """A non-uniform line scan's positions, made uniform when they are a uniform grid
    rounded on output: every position a whole multiple of a power of ten q (the printed
    resolution) and a grid a + b i within q/2 of every position (the minimax line through
    (i, x_i), a linear programme). A Dektak CSV prints its lateral positions to 0.1 um at
    1500 um / 9600 samples. Otherwise the positions are returned as they are (the profile
    is then resampled by its spline)."""
    from scipy.optimize import linprog

    n = x.size
    if n < 2 or not np.all(np.isfinite(x)) or not np.all(np.diff(x) > 0):
        return x
    span = x[-1] - x[0]
    for k in range(15, -16, -1):  # the largest power of ten every position is a multiple of
        q = 10.0 ** k
        r = x / q
        if q <= span and np.max(np.abs(r - np.rint(r))) <= 1e-6:
            break
    else:
        return x
    i = np.arange(n, dtype=np.float64) / (n - 1)  # scaled for the solver
    ones = np.ones(n)
    # minimise t subject to |x_i - a - b i| <= t, variables (a, b, t)
    A = np.block([[-ones[:, None], -i[:, None], -ones[:, None]], [ones[:, None], i[:, None], -ones[:, None]]])
    res = linprog([0.0, 0.0, 1.0], A_ub=A, b_ub=np.r_[-x, x], bounds=[(None, None)] * 3, method="highs")
    if not res.success or res.x[2] > 0.5 * q * (1 + 1e-6):
        return x
    a, b, _ = res.x
    return a + b * i



def _check(p: Path, x, h, lines_of=None):
    bad = np.nonzero(~np.isfinite(h))[0]
    if bad.size:
        where = f"line {lines_of[bad[0]]}" if lines_of is not None else f"sample {bad[0]}"
        raise ParameterError(f"{p}, {where}: the height is not a finite number (NaN or inf)")
    if x is not None:
        d = np.diff(x)
        bad = np.nonzero(~(d > 0))[0]
        if bad.size:
            i = bad[0] + 1
            where = f"line {lines_of[i]}" if lines_of is not None else f"sample {i}"
            raise ParameterError(f"{p}, {where}: x = {x[i]:g} does not increase (previous {x[i - 1]:g})")
    if h.size < 4:
        raise ParameterError(f"{p}: {h.size} samples, which is not allowed: at least 4 are needed")


def _cells(s: str) -> list[str]:
    """A text line's cells: parted by commas, semicolons, tabs or spaces; where the line is
    parted by semicolons, tabs or spaces and every cell holding a comma is a number written with
    a decimal comma (a German or French locale's export: "0,0005;0,000063"), that comma is read
    as the decimal mark. Quoted cells (RFC 4180: '"0.5","1.2"', or '"0,5","1,2"' where the
    comma is the decimal mark) are read by Python's csv module, parted by the semicolon, tab or
    comma found outside the quotes; a comma inside a quoted number is its decimal mark."""
    if '"' in s:
        import csv

        outside = re.sub(r'"[^"]*"', "", s)
        delimiter = next((d for d in (";", "\t", ",") if d in outside), ",")
        cells = [c.strip() for c in next(csv.reader([s], delimiter=delimiter, skipinitialspace=True))]
        return [c.replace(",", ".") if decimal_comma(c) else c for c in cells if c]
    parts = [c for c in re.split(r"[;\t ]+", s) if c != ""]
    commas = [c for c in parts if "," in c]
    if len(parts) > 1 and commas and all(decimal_comma(c) for c in commas):
        return [c.replace(",", ".") for c in parts]
    return [c for c in re.split(r"[,;\t ]+", s) if c != ""]


TEXT_PROBE = 1 << 16
"""How many bytes of a text file :func:`read_topography` reads once (:func:`_text_head`) to tell one
column of decimal-comma numbers from x, height pairs parted by commas (:func:`_decimal_comma_column`),
a table of named columns (:func:`_named_columns`) and two columns named with their units
(:func:`_named_units`) before it chooses a reader (chosen: some
thousand lines; the reader it chooses reads the whole file and decides again)."""


def _decimal_comma_column(lines) -> bool:
    """Whether a text file's data lines (``lines``, after any header) are one column of numbers
    written with a decimal comma ("0,3456", "-1,3e-06": a German or French locale's export of one
    column), not x, height pairs of whole numbers parted by a comma ("0,1", "1,2"): every data
    line one such cell, and fewer than half of the whole parts before the commas larger than the
    one before (a profile's positions increase; heights go up and down, or keep one whole part)."""
    whole, quoted = [], False
    for line in lines:
        s = line.strip()
        if not s or s.startswith(("#", "%")):
            continue
        if len(s) > 2 and s[0] == s[-1] == '"' and s.count('"') == 2:  # (one quoted cell: its comma is no delimiter)
            s, quoted = s[1:-1], True
        if not decimal_comma(s):
            if whole:
                return False
            try:
                float(s)
            except ValueError:
                continue  # (a header line before the data)
            return False
        whole.append(float(s.split(",")[0].lstrip("+-") or "0") * (-1.0 if s.startswith("-") else 1.0))
    rises = sum(b > a for a, b in zip(whole, whole[1:]))
    return len(whole) >= 2 and (quoted or 2 * rises < len(whole) - 1)


def _load_columns(p: Path, lines, spacing, x_unit, height_unit, x_column, height_column):
    rows, line_no = [], []
    one = _decimal_comma_column(lines)  # (one column of decimal-comma numbers, not x, height pairs)
    for i, line in enumerate(lines):
        s = line.strip()
        if not s or s.startswith(("#", "%")):
            continue
        cells = [s.replace(",", ".")] if one and decimal_comma(s) else _cells(s)  # (a quoted one: _cells')
        try:
            vals = [float(c) for c in cells]
        except ValueError:
            if rows:
                raise ParameterError(f"{p}, line {i + 1}: {s[:60]!r} is not numbers") from None
            continue  # header lines before the data
        rows.append(vals)
        line_no.append(i + 1)
    if not rows:
        raise ParameterError(f"{p}: no numeric data found")
    width = min(len(r) for r in rows)
    if width == 1:  # a single column can only be the heights
        x_column, height_column = None, 0
    hc = height_column if x_column is not None else (height_column if width > 1 else 0)
    if hc >= width or (x_column is not None and x_column >= width):
        raise ParameterError(f"{p}: columns x_column = {x_column}, height_column = {height_column} are not allowed: "
                             f"the data has {width} column(s)")
    if height_unit is None:
        raise ParameterError(f"{p}: the file does not state its height unit: give it, {_hint('height_unit', 'um')}")
    hf = _unit_factor(height_unit, "height_unit", str(p))
    h = np.array([r[hc] for r in rows]) * hf
    if x_column is None or width == 1:
        if spacing is None:
            raise ParameterError(f"{p}: the file gives no abscissa: give the sample spacing, {_hint('spacing', '0.5um')}")
        x = _spacing(spacing, str(p)) * np.arange(h.size)
        _check(p, None, h, line_no)
        return x, h
    if spacing is not None:  # (not silently ignored: the file's own positions are used)
        raise ParameterError(f"spacing = {spacing!r} is not allowed: {p} gives its positions (column {x_column}), "
                             "which are used; leave the spacing out")
    if x_unit is None:
        raise ParameterError(f"{p}: the file does not state its x unit: give it, {_hint('x_unit', 'um')}")
    x = np.array([r[x_column] for r in rows]) * _unit_factor(x_unit, "x_unit", str(p))
    _check(p, x, h, line_no)
    return x, h


def _check_zip(p: Path) -> None:
    """Refuse, from its central directory and before anything is inflated, a zip container
    (X3P: ``main.xml`` and the binary data) whose members decompress past the memory
    budget: text members at :data:`TEXT_BYTES_FACTOR` bytes a byte (the XML is parsed),
    binary ones at :data:`ZIP_DATA_BYTES_FACTOR` (the samples are then counted against
    :data:`ST_BYTES_PER_SAMPLE` from the header, before they are read). A 3.2 MB X3P
    whose ``main.xml`` is 3 GB of spaces drove ``design`` past 6 GB (issue 33). Python's
    zipfile never inflates a member past the size its directory declares, so the sum is a
    bound, not a guess."""
    import zipfile

    with open(p, "rb") as fh:
        if fh.read(4) != b"PK\x03\x04":
            return
    try:
        with zipfile.ZipFile(p) as z:
            infos = z.infolist()
    except (zipfile.BadZipFile, OSError, ValueError) as exc:
        raise ParameterError(f"{p}: not a readable zip container ({_first_line(exc)})") from None
    if len(infos) > MAX_ZIP_MEMBERS:
        raise ParameterError(f"{p}: lists {len(infos)} members, more than the {MAX_ZIP_MEMBERS} a topography container may")
    text = sum(i.file_size for i in infos if i.filename.lower().endswith((".xml", ".txt", ".json", ".csv", ".ini")))
    binary = sum(i.file_size for i in infos) - text
    check_budget("path", str(p), TEXT_BYTES_FACTOR * text + ZIP_DATA_BYTES_FACTOR * binary,
                 f"its contents ({text / 2**20:.4g} MiB of text and {binary / 2**20:.4g} MiB of data once decompressed)")


def _load_mat(p: Path, spacing, height_unit, variable, x_unit) -> Reading:
    from scipy.io import loadmat

    count = _mat_samples(p)
    check_budget("path", str(p), ST_BYTES_PER_SAMPLE * count, f"its {count:.3g} numbers")
    try:
        data = loadmat(p)
    except MemoryError:
        raise ParameterError(f"{p}: reading it ran out of memory; the file is too large") from None
    except Exception as exc:  # scipy raises several kinds for unreadable files
        raise ParameterError(f"{p}: not a readable MATLAB file ({_first_line(exc)})") from None
    names = [k for k in data if not k.startswith("__")]
    source = p.name if variable is None else f"{p.name}, variable {variable}"  # (the one chosen)
    if variable is None:
        if len(names) != 1:
            raise ParameterError(f"{p}: holds variables {names}: choose one, {_hint('variable', names[0])}")
        variable = names[0]
    if variable not in data:
        raise ParameterError(f"variable = {variable!r} is not allowed: {p} holds {names}")
    arr = np.atleast_1d(_mat_array(p, variable, data[variable]))
    if arr.ndim > 2:
        raise ParameterError(f"{p}: variable {variable!r} has shape {data[variable].shape}: a profile must be a "
                             "vector and a height map a matrix")
    if x_unit is not None:
        raise ParameterError(f"x_unit = {x_unit!r} is not allowed: {p} has no positions; give the sample spacing")
    examples = {"spacing": "0.5um", "height_unit": "mm"}
    missing = [n for n, v in (("spacing", spacing), ("height_unit", height_unit)) if v is None]
    if missing:
        raise ParameterError(f"{p} does not state its sample spacing or height unit: give "
                             + _hints([(m, examples[m]) for m in missing]))
    h = arr * _unit_factor(height_unit, "height_unit", str(p))
    step = _spacing(spacing, str(p))
    if h.ndim == 2:  # a MATLAB matrix: rows are y, columns x (as an image), h[i, j] at (x_i, y_j)
        h = np.ascontiguousarray(h.T)
        bad = np.argwhere(~np.isfinite(h))
        if bad.size:
            raise ParameterError(f"{p}: {bad.shape[0]} of {h.size} heights are not finite numbers (NaN or inf), "
                                 f"the first at sample {tuple(int(v) for v in bad[0])}")
        return Reading(step * np.arange(h.shape[0]), step * np.arange(h.shape[1]), h, source, "haptex: MATLAB")
    _check(p, None, h)
    return Reading(step * np.arange(h.size), None, h, source, "haptex: MATLAB")


def _mat_array(p: Path, variable: str, value) -> np.ndarray:
    """The MATLAB variable as float64, squeezed (a vector or a matrix), if it is a real
    numeric array; anything else is refused."""
    import scipy.sparse

    what = None
    if scipy.sparse.issparse(value):
        what = "a sparse matrix"
    elif not isinstance(value, np.ndarray):
        what = f"a {type(value).__name__}"
    elif value.dtype.names:
        what = f"a struct with fields {list(value.dtype.names)}"
    elif value.dtype.kind == "O":
        what = "a cell array"
    elif value.dtype.kind in "US":
        what = "text"
    elif value.dtype.kind == "c":
        what = "complex (its imaginary part would be lost)"
    elif value.dtype.kind not in "iuf":
        what = f"of type {value.dtype} (logical or other)"
    if what is not None:
        raise ParameterError(f"{p}: variable {variable!r} is {what}, which is not allowed: "
                             "a profile must be a real numeric vector, a height map a real numeric matrix")
    return value.astype(np.float64).squeeze()

