"""Readers of measured height profiles (private; used by SampledProfile.from_file).

Every error names the file, and the line where there is one. Units and sample spacing are
taken from the file when it states them and otherwise required from the caller; nothing
is guessed.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np

from ._units import parse_quantity
from ._validation import ParameterError, check_budget

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
    return f"--{name.replace('_', '-')} {example} at the command line, {name}='{example}' in Python"


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
"""Bytes of memory a text profile takes per byte of file while it is parsed (measured: a
10^7-line, 80 MB CSV peaked at 3.3 GB)."""


def _read_text(path: Path) -> str:
    check_budget("path", str(path), TEXT_BYTES_FACTOR * path.stat().st_size, "reading this text file")
    raw = path.read_bytes()
    if b"\x00" in raw[:4096]:
        raise ParameterError(f"{path}: the file is not readable text (NUL bytes: binary or UTF-16); "
                             "export it as UTF-8 or Latin-1 text")
    try:
        text = raw.decode("utf-8-sig")  # a byte-order mark is not part of the first row
    except UnicodeDecodeError:
        text = raw.decode("latin-1")  # Dektak exports: the micro sign is byte 0xB5
    return text.replace("\r\n", "\n").replace("\r", "\n")


def load_profile(path, *, spacing=None, x_unit=None, height_unit=None, variable=None, x_column=0, height_column=1):
    """Read (x, h) in metres from a file; returns (x, h, shortest_period or None, source)."""
    p = Path(path)
    if p.is_dir():
        raise ParameterError(f"path = {str(p)!r} is not allowed: it is a directory, not a profile file")
    if not p.exists():
        raise ParameterError(f"path = {str(p)!r} is not allowed: no such file")
    if not p.is_file():
        raise ParameterError(f"path = {str(p)!r} is not allowed: not a regular file")
    if p.suffix.lower() == ".mat":
        return _load_mat(p, spacing, height_unit, variable) + (None, p.name)
    try:
        text = _read_text(p)
    except OSError as exc:
        raise ParameterError(f"{p}: cannot read it ({exc.strerror})") from None
    lines = text.split("\n")
    if any(line.strip().lower().startswith("scan data") for line in lines[:400]):
        x, h = _load_dektak(p, lines)
    else:
        x, h = _load_columns(p, lines, spacing, x_unit, height_unit, x_column, height_column)
    return x, h, None, p.name


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


def _load_dektak(p: Path, lines):
    res_um = None
    start = None
    for i, line in enumerate(lines):
        cells = [c.strip() for c in line.split(",")]
        if cells[0].lower() == "resolution" and len(cells) > 1:
            m = re.match(r"([0-9.eE+-]+)\s*([^/\s]+)\s*/\s*sample", cells[1])
            if m:
                try:
                    value = float(m.group(1))
                except ValueError:
                    raise ParameterError(f"{p}, line {i + 1}: resolution {cells[1]!r} is not a number per sample") from None
                if not (math.isfinite(value) and value > 0):
                    raise ParameterError(f"{p}, line {i + 1}: resolution {cells[1]!r} is not allowed: "
                                         "must be a finite length > 0 per sample")
                res_um = value * _unit_factor(m.group(2), "resolution unit", f"{p}, line {i + 1}")
        if line.strip().lower().startswith("scan data"):
            start = i + 1
            break
    while start < len(lines) and not lines[start].strip():
        start += 1
    if start >= len(lines):
        raise ParameterError(f"{p}: 'Scan Data' is followed by no column header")
    header = [c.strip() for c in lines[start].split(",")]
    units = []
    for col in header[:2]:
        words = col.split()
        if len(words) < 2:
            raise ParameterError(f"{p}, line {start + 1}: column header {col!r} states no unit")
        units.append(_unit_factor(words[-1], "unit", f"{p}, line {start + 1}"))
    xs, hs, line_no = [], [], []
    for j in range(start + 1, len(lines)):
        cells = [c.strip() for c in lines[j].split(",")]
        if not cells[0]:
            continue
        try:
            xs.append(float(cells[0]))
            hs.append(float(cells[1]))
        except ValueError:
            raise ParameterError(f"{p}, line {j + 1}: {lines[j][:60]!r} is not two numbers") from None
        except IndexError:
            raise ParameterError(f"{p}, line {j + 1}: {lines[j][:60]!r} has one column: Dektak 'Scan Data' "
                                 "needs two (lateral position, height)") from None
        line_no.append(j + 1)
    x = np.array(xs) * units[0]
    h = np.array(hs) * units[1]
    _check(p, x, h, line_no)
    if res_um is not None:
        # the lateral column is rounded (0.1 um); the stated resolution is the true spacing
        uniform = x[0] + res_um * np.arange(x.size)
        if abs(uniform[-1] - x[-1]) > 0.01 * (x[-1] - x[0]):
            raise ParameterError(f"{p}: the stated resolution {res_um:g} m/sample disagrees with the lateral "
                                 f"column ({x.size} samples over {x[-1] - x[0]:g} m)")
        x = uniform
    return x, h


def _load_columns(p: Path, lines, spacing, x_unit, height_unit, x_column, height_column):
    rows, line_no = [], []
    for i, line in enumerate(lines):
        s = line.strip()
        if not s or s.startswith(("#", "%")):
            continue
        cells = [c for c in re.split(r"[,;\t ]+", s) if c != ""]
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
    if x_unit is None:
        raise ParameterError(f"{p}: the file does not state its x unit: give it, {_hint('x_unit', 'um')}")
    x = np.array([r[x_column] for r in rows]) * _unit_factor(x_unit, "x_unit", str(p))
    _check(p, x, h, line_no)
    return x, h


def _load_mat(p: Path, spacing, height_unit, variable):
    from scipy.io import loadmat

    try:
        data = loadmat(p)
    except Exception as exc:  # scipy raises several kinds for unreadable files
        raise ParameterError(f"{p}: not a readable MATLAB file ({exc})") from None
    names = [k for k in data if not k.startswith("__")]
    if variable is None:
        if len(names) != 1:
            raise ParameterError(f"{p}: holds variables {names}: pass variable=... to choose one")
        variable = names[0]
    if variable not in data:
        raise ParameterError(f"variable = {variable!r} is not allowed: {p} holds {names}")
    arr = _mat_vector(p, variable, data[variable])
    if arr.ndim != 1:
        raise ParameterError(f"{p}: variable {variable!r} has shape {data[variable].shape}: a profile must be a vector")
    examples = {"spacing": "0.5um", "height_unit": "mm"}
    missing = [n for n, v in (("spacing", spacing), ("height_unit", height_unit)) if v is None]
    if missing:
        raise ParameterError(f"{p} does not state its sample spacing or height unit: give "
                             + " and ".join(_hint(m, examples[m]) for m in missing))
    h = arr * _unit_factor(height_unit, "height_unit", str(p))
    _check(p, None, h)
    x = _spacing(spacing, str(p)) * np.arange(h.size)
    return x, h


def _mat_vector(p: Path, variable: str, value) -> np.ndarray:
    """The MATLAB variable as float64 if it is a real numeric array; anything else is refused."""
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
                             "a profile must be a real numeric vector")
    return value.astype(np.float64).squeeze()
