"""Tables as rigs write them: columns named by the user, with their units, from CSV, NPZ,
HDF5, MATLAB MAT-files, NI TDMS or LabVIEW Measurement Files.

A recording (:func:`haptex.datadriven.read_recording`) or a run log
(:func:`haptex.identification.read_log`) written by another program has its own column names,
its own units and columns haptex has no use for. A *column spec* names, for one quantity, the
file's columns and their unit::

    position=px,py,pz:mm     force=fz:N     time=t:ms     acceleration=az:g

The columns are read, converted to SI (pint; ``g`` for an acceleration is standard gravity), and
every other column is ignored and listed, never refused.
"""

from __future__ import annotations

import dataclasses
import math
import re
import warnings
import zipfile
from pathlib import Path

import numpy as np

from ._validation import ParameterError, a_path, check_budget, fail

G = 9.80665
"""Standard gravity (m/s²): the unit ``g`` of an acceleration column."""

TABLE_SUFFIXES = {".csv": "CSV", ".txt": "CSV", ".npz": "NPZ", ".h5": "HDF5", ".hdf5": "HDF5", ".hdf": "HDF5",
                  ".mat": "MAT", ".tdms": "TDMS", ".lvm": "LVM"}
"""The file kinds :func:`read_table` reads, by suffix (anything else is read as CSV)."""


@dataclasses.dataclass(frozen=True)
class ColumnSpec:
    """One quantity's columns in a file and the factor that takes them to SI.

    Parameters
    ----------
    quantity : str
        What they hold (``position``, ``force``, ``time``, ...).
    columns : tuple of str
        The file's column names (a CSV header's, an NPZ key, an HDF5 dataset's path).
    unit : str
        Their unit as written (``mm``, ``N``, ``ms``, ``g``).
    factor : float
        SI value of one ``unit``.
    stated : bool, optional
        Whether the user wrote the unit (else it is the quantity's SI unit, and the file's own
        unit for the columns, where it states one, is taken instead: :func:`take`).
    """

    quantity: str
    columns: tuple[str, ...]
    unit: str
    factor: float
    stated: bool = True


class Table(dict):
    """:func:`read_table`'s columns, ``{name: float64 array}``, with ``units``: the unit the file
    states for a column (a CSV's units row, a TDMS channel's ``unit_string``, an LVM channel's
    ``Y_Unit_Label``, an HDF5 dataset's ``units`` or ``unit`` attribute), by column name."""

    def __init__(self, columns=(), units=None):
        super().__init__(columns)
        self.units = dict(units or {})


def unit_factor(unit: str, si: str, name: str) -> float:
    """The SI value of one ``unit`` of a quantity whose SI unit is ``si``.

    Parameters
    ----------
    unit : str
        The unit as written, e.g. ``"mm"``, ``"ms"``, ``"g"``, or one step of a board's reading
        with its unit, e.g. ``"2.5um"`` (an encoder's count), ``"0.02 N"`` (a DAC's step).
    si : str
        The quantity's SI unit, e.g. ``"m"``, ``"s"``, ``"m/s^2"``.
    name : str
        The parameter named in an error.

    Returns
    -------
    float

    Raises
    ------
    ParameterError
        If the unit is not one pint knows, or not of the quantity's dimension.
    """
    from ._units import parse_quantity

    u = unit.strip()
    if u == "g" and si == "m/s^2":
        return G
    step = re.fullmatch(r"([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*g", u)
    if step and si == "m/s^2":  # (an accelerometer's step in standard gravities: "0.001 g")
        return float(step.group(1)) * G
    if si == "1":  # a pure number (a flag, a count): no unit to convert
        if u not in ("", "1"):
            raise fail(name, u, "no unit (a pure number)")
        return 1.0
    # a unit written with its step ("2.5um": one count of an encoder) is that quantity
    return parse_quantity(u if re.match(r"[+-]?(\d|\.\d)", u) else f"1 {u}", si, name)


def parse_column(spec: str, quantities: dict, name: str = "--column") -> ColumnSpec:
    """Parse ``QUANTITY=COL[,COL...][:UNIT]`` (e.g. ``position=px,py,pz:mm``).

    Parameters
    ----------
    spec : str
        The spec as the user wrote it; the unit defaults to the quantity's SI unit (and, in
        :func:`take`, to the unit the file states for the columns, where it states one).
    quantities : dict
        The quantities allowed, each with its SI unit (``{"position": "m", ...}``).
    name : str, optional
        The parameter named in an error.

    Returns
    -------
    ColumnSpec

    Raises
    ------
    ParameterError
        If the spec has no ``=``, names an unknown quantity, no column, or a unit of another
        dimension.
    """
    text = str(spec).strip()
    if "=" not in text:
        raise fail(name, text, "QUANTITY=COLUMN[,COLUMN...][:UNIT], e.g. 'position=px,py:mm', with QUANTITY one of "
                   + ", ".join(quantities))
    q, rest = (s.strip() for s in text.split("=", 1))
    if q not in quantities:
        raise fail(name, text, "a quantity among " + ", ".join(quantities))
    cols, unit = (rest.rsplit(":", 1) if ":" in rest else (rest, quantities[q]))
    columns = tuple(c.strip() for c in cols.split(",") if c.strip())
    if not columns:
        raise fail(name, text, f"at least one column after '{q}='")
    return ColumnSpec(q, columns, unit.strip(), unit_factor(unit, quantities[q], f"{name} {q}"), ":" in rest)


def first_line(exc: BaseException) -> str:
    """A library's exception as the part of a one-line refusal that says why: its text on one
    line (its type's name where it has none), at most 160 characters."""
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 160 else text[:157] + "..."


def _library_read(p: Path, what: str, kind: str, read):
    """``read()``, a library's reader of file ``p``, its failures refused in one line: out of
    memory, or "a readable ``kind``" with the library's reason."""
    try:
        return read()
    except MemoryError:
        raise fail("path", str(p), f"a {what} that fits in memory") from None
    except Exception as exc:  # noqa: BLE001 - the libraries raise several kinds for an unreadable file
        raise fail("path", str(p), f"a readable {kind} ({first_line(exc)})") from None


def mat_numbers(p: Path) -> int:
    """The number of numbers a MATLAB v5 file's variables hold, from each variable's dimensions
    (for a compressed variable, the first 128 bytes of its zlib stream are inflated, nothing
    more), which the measured surfaces' reader and :func:`read_table` check against the memory
    budget before loadmat reads anything: scipy inflates a whole variable even to list it
    (``whosmat``), and a 389 KB file of 5 x 10^7 compressed zeros took 15 GB through ``design``.
    0 when the file is not a v5 MAT file (loadmat then says what it is)."""
    import struct
    import zlib

    total = 0
    with open(p, "rb") as fh:
        header = fh.read(128)
        if len(header) < 128 or header[126:128] not in (b"IM", b"MI"):
            return 0
        e = "<" if header[126:128] == b"IM" else ">"
        if struct.unpack(e + "H", header[124:126])[0] != 0x0100:  # 0x0200: v7.3, an HDF5 file that loadmat refuses
            return 0
        for _ in range(100_000):
            tag = fh.read(8)
            if len(tag) < 8:
                break
            typ, nbytes = struct.unpack(e + "II", tag)
            if typ >> 16:  # a small data element: its data sit in the tag
                continue
            start = fh.tell()
            if typ == 15:  # miCOMPRESSED: a zlib stream holding a miMATRIX
                inflate = zlib.decompressobj()
                head = b""
                while len(head) < 128:
                    chunk = fh.read(min(4096, start + nbytes - fh.tell()))
                    if not chunk:
                        break
                    try:
                        head += inflate.decompress(chunk, 128 - len(head))
                    except zlib.error:
                        return 0  # loadmat names the corruption
            elif typ == 14:  # miMATRIX, uncompressed
                head = tag + fh.read(min(nbytes, 120))
            else:
                head = b""
            if len(head) >= 40 and struct.unpack(e + "I", head[:4])[0] == 14:
                # miMATRIX: array flags (16 bytes), then the dimensions: an int32 element
                dtyp, dbytes = struct.unpack(e + "II", head[24:32])
                if dtyp >> 16:  # one dimension packed in the tag
                    count = max(struct.unpack(e + "i", head[28:32])[0], 0)
                else:
                    n = min(dbytes // 4, (len(head) - 32) // 4)
                    dims = struct.unpack(e + f"{n}i", head[32:32 + 4 * n])
                    count = math.prod(max(d, 0) for d in dims)
                total += count
            fh.seek(start + nbytes + ((-nbytes) % 8 if typ != 15 else 0))
    return total


def read_table(path, what: str) -> Table:
    """Every column of a table file: ``{name: float64 array of shape (n,) or (n, k)}``, and the
    units the file states (:class:`Table`).

    Parameters
    ----------
    path : str or os.PathLike
        A delimited-text file (comma, tab, semicolon or whitespace, ``CSV_DELIMITERS``;
        '#' lines before its header row skipped) with a header row naming its columns, an
        ``.npz`` (each array a column, a 2-D one (n, k) a group of k), an HDF5 file (``.h5``,
        ``.hdf5``; each dataset by its path, read with h5py), a MATLAB ``.mat`` file (v5, or
        v7.3 as HDF5; each numeric variable a column), an NI TDMS file (``.tdms``, read with
        npTDMS: each channel as ``group/channel``, and ``group/time`` where the group's
        channels are waveforms of one timing) or a LabVIEW Measurement File (``.lvm``, read with
        lvm_read: each channel by its name, ``X_Value`` the times). A 1 x n array (MATLAB's row
        vector) is the column of n, and a k x n array with k < n (channels as rows) its
        transpose, n rows of k. Columns may differ in length (a file's groups at other
        rates); those a quantity takes may not (:func:`take`).
    what : str
        What the file is (named in errors).

    Returns
    -------
    Table

    Raises
    ------
    ParameterError
        If the file is missing, larger than the memory budget allows, not of its kind, or holds
        a value that is not a number.
    """
    p = a_path("path", path, f"a {what}'s path")
    if not p.is_file():
        raise fail("path", str(path), f"an existing {what} (CSV, NPZ, HDF5, MAT, TDMS or LVM)")
    kind = TABLE_SUFFIXES.get(p.suffix.lower(), "CSV")
    if kind == "NPZ":
        out, need = {}, 0.0
        try:
            with np.load(p, allow_pickle=False) as z:
                members = set(z.zip.namelist())
                for k in z.files:
                    # (each array's size from its header, before it is read: a small file may
                    # hold a huge compressed array; numpy names a member k.npy, or k as written)
                    with z.zip.open(k + ".npy" if k + ".npy" in members else k) as fh:
                        version = np.lib.format.read_magic(fh)
                        head = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                                else np.lib.format.read_array_header_2_0)
                        shape = head(fh)[0]
                    need += 8.0 * float(np.prod(shape, dtype=float))  # (all its arrays together)
                    check_budget("path", str(path), need, f"reading this {what}")
                    out[k] = np.asarray(z[k], dtype=float)
        except ParameterError:
            raise
        except (ValueError, OSError, EOFError, KeyError, zipfile.BadZipFile) as exc:
            raise fail("path", str(path), f"a readable .npz of numbers ({exc})") from None
    elif kind == "HDF5":
        out = _read_hdf5(p, what)
    elif kind == "MAT":
        out = _read_mat(p, what)
    elif kind == "TDMS":
        out = _read_tdms(p, what)
    elif kind == "LVM":
        out = _read_lvm(p, what)
    else:
        out = _read_csv(p, what)
    # MATLAB's vectors are 1 x n rows (save(), and h5py's reading of a v7.3 file): a column of n;
    # and its signals k x n, channels as rows ([ax; ay; az]): a table has more samples than
    # channels, so a 2-D array with fewer rows than columns is read as its transpose
    units = getattr(out, "units", {})
    out = {k: (v[0] if v.shape[0] == 1 else v.T) if np.ndim(v) == 2 and v.shape[0] < v.shape[1] else v
           for k, v in out.items()}
    out = Table({k: v for k, v in out.items() if np.ndim(v) in (1, 2)}, units)
    if not out:
        raise fail("path", str(path), f"a {what} with named columns")
    return out


CSV_DELIMITERS = (",", "\t", ";")
"""The delimiters a delimited-text table may use, the first found in its header row taken (RFC
4180's comma; tab-separated values, IANA's text/tab-separated-values; the semicolon of
spreadsheets where the comma is the decimal mark); with none of them, runs of whitespace."""


_DECIMAL_COMMA = re.compile(r"[+-]?\d*,\d+(?:[eE][+-]?\d+)?")


_FLAGS = {"true": 1.0, "false": 0.0}
"""A flag's cell written as a word (pandas' to_csv writes a bool column True and False): its number."""


def decimal_comma(cell: str) -> bool:
    """Whether a text cell is a number written with a comma for its decimal mark ("0,0005",
    "-1,5e-3": a German or French locale's export), which the text readers then read as one."""
    return _DECIMAL_COMMA.fullmatch(cell.strip()) is not None


def _number(cell: str) -> bool:
    """Whether a text cell is a number (a decimal comma's too) or a flag word."""
    c = cell.strip()
    if c.lower() in _FLAGS or decimal_comma(c):
        return True
    try:
        float(c)
    except ValueError:
        return False
    return True


def _read_csv(p: Path, what: str) -> Table:
    """A delimited-text table: '#' lines and blank lines before its header row skipped, the
    header's delimiter (CSV_DELIMITERS, else whitespace) for every row, '#' comments ignored; a
    row of units below the header (no cell a number: "[s];[mm];[N]", as DAQ programs export)
    gives the columns' units (brackets or parentheses around a unit dropped). Cells may be
    quoted (RFC 4180: '"0.5","1.2"'); a comma inside a quoted number is its decimal mark."""
    import csv

    def split(row: str) -> list:
        return next(csv.reader([row.strip("\r\n")], delimiter=delimiter)) if delimiter else row.split()

    check_budget("path", str(p), 4.0 * p.stat().st_size, f"reading this {what}")  # text to float64, copies
    skipped, line = 0, ""
    with p.open("r", encoding="utf-8-sig", errors="replace") as fh:  # (a byte-order mark is not the first name's)
        for line in fh:
            if line.strip() and not line.lstrip().startswith("#"):
                break
            skipped += 1
        else:
            raise fail("path", str(p), f"a {what} with a header row naming its columns (none found: the file "
                                       "is empty, or comments and blank lines only)")
        delimiter = next((d for d in CSV_DELIMITERS if d in line), None)
        below, first, units_row = 0, "", None
        for row in fh:
            below += 1
            if not row.strip() or row.lstrip().startswith("#"):
                continue
            if units_row is None and not any(_number(c) for c in split(row) if c.strip()):
                units_row, skipped, below = row, skipped + below, 0  # (the data start after it)
                continue
            first = row
            break
    fields = split(line)
    header = [h.strip() for h in fields]
    while len(header) > 1 and not header[-1]:  # (rows that end in their delimiter: no column after it)
        header.pop()
    if len(set(header)) != len(header) or not all(header):
        raise fail("path", str(p), f"a {what} whose header row names each column once")
    # cells parted by anything but commas whose commas are decimal marks (a German or French
    # locale's export: "0,000023;0,8457"): read with the comma as the decimal mark; a flag written
    # True or False (pandas' to_csv of a bool column): 1 or 0
    cells = split(first)
    comma = (delimiter != "," or '"' in first) and any(decimal_comma(c) for c in cells)  # (quoted: its own mark)
    flags = any(c.strip().lower() in _FLAGS for c in cells)

    def cell(c: str) -> float:
        c = c.strip()
        flag = _FLAGS.get(c.lower())
        return flag if flag is not None else float(c.replace(",", ".") if comma else c)

    try:
        with warnings.catch_warnings():  # (a header alone: said below, not warned)
            warnings.simplefilter("ignore", UserWarning)
            data = np.loadtxt(p, delimiter=delimiter, skiprows=skipped + 1, comments="#", ndmin=2, quotechar='"',
                              converters=cell if comma or flags else None,
                              usecols=range(len(header)) if len(fields) > len(header) else None)
    except ValueError as exc:
        raise fail("path", str(p), f"numbers in every row ({str(exc).splitlines()[0]})") from None
    if data.shape[0] == 0:
        raise fail("path", str(p), f"a {what} with rows of numbers below its header (it has none)")
    if data.shape[1] != len(header):
        raise fail("path", str(p), f"{len(header)} values a row, as its header")
    units = {}
    if units_row is not None:
        given = split(units_row)
        for h, u in zip(header, given):
            u = re.sub(r"^[\[(](.*)[\])]$", r"\1", u.strip()).strip()
            if u:
                units[h] = u
    return Table({h: data[:, k] for k, h in enumerate(header)}, units)


def _read_mat(p: Path, what: str) -> dict:
    """A MATLAB MAT-file's numeric variables, each a column (a matrix a group): a v7.3 file is
    HDF5 behind a 512-byte header (:func:`_read_hdf5`); a v5 one is counted before it is read
    (:func:`mat_numbers`), then read by scipy's loadmat. Text, cells and structs are not columns."""
    with open(p, "rb") as fh:
        fh.seek(512)
        if fh.read(8) == b"\x89HDF\r\n\x1a\n":  # (v7.3: the HDF5 signature after MATLAB's 512-byte header)
            return _read_hdf5(p, what)
    from scipy.io import loadmat

    count = mat_numbers(p)
    check_budget("path", str(p), 16.0 * count, f"reading this {what} ({count:.3g} numbers)")
    data = _library_read(p, what, "MATLAB file", lambda: loadmat(p))
    return {k: np.asarray(v, dtype=float) for k, v in data.items()
            if not k.startswith("__") and isinstance(v, np.ndarray) and v.dtype.kind in "biuf"
            and v.ndim in (1, 2)}


TDMS_BYTES_FACTOR = 3.0
"""Bytes of memory a TDMS file's byte takes while it is read (its raw data as float64, and a
copy): the budget's count before reading."""
LVM_BYTES_FACTOR = 12.0
"""Bytes of memory a LabVIEW Measurement File's byte takes while lvm_read reads it (each row's
cells as Python strings, then floats, before the array): the budget's count before reading
(measured: 6.9 on a 15.3 MB file of four columns, 400,000 rows; chosen with room to spare)."""


def _read_tdms(p: Path, what: str) -> dict:
    """An NI TDMS file's numeric channels (npTDMS), each as ``group/channel``; a group whose
    channels are waveforms of one timing (the same wf_start_offset, wf_increment and length:
    NI's waveform properties) also has ``group/time``, their times (s), unless it has a
    channel named so."""
    from nptdms import TdmsFile

    check_budget("path", str(p), TDMS_BYTES_FACTOR * p.stat().st_size, f"reading this {what}")
    tdms = _library_read(p, what, "TDMS file", lambda: TdmsFile.read(p))
    out = Table()
    for group in tdms.groups():
        timing = set()
        for ch in group.channels():
            data = ch[:]
            if not (isinstance(data, np.ndarray) and data.dtype.kind in "biuf" and data.ndim == 1):
                continue  # (strings, timestamps, DAQmx raw scalers' data without scaling)
            out[f"{group.name}/{ch.name}"] = np.asarray(data, dtype=float)
            props = ch.properties
            if str(props.get("unit_string", "")).strip():
                out.units[f"{group.name}/{ch.name}"] = str(props["unit_string"]).strip()
            timing.add((props.get("wf_start_offset"), props.get("wf_increment"), len(data))
                       if "wf_increment" in props else None)
        name = f"{group.name}/time"
        if len(timing) == 1 and None not in timing and name not in out:
            start, step, n = timing.pop()
            out[name] = float(start or 0.0) + float(step) * np.arange(n)
            out.units[name] = "s"
    return out


def _read_lvm(p: Path, what: str) -> dict:
    """A LabVIEW Measurement File's channels (lvm_read, its cache not written), each by its
    name, ``X_Value`` their times: the file's own x column, or X0 + k Delta_X from the segment
    header where it has none (X_Columns No), or where each channel has its own and they agree.
    The segments of one set of channels (a loop's calls of Write To Measurement File) are one
    table, in order. A Comment column (text a row, NI's last column) is no channel."""
    import lvm_read

    check_budget("path", str(p), LVM_BYTES_FACTOR * p.stat().st_size, f"reading this {what}")
    lvm = _library_read(p, what, "LabVIEW Measurement File",
                        lambda: lvm_read.read(str(p), read_from_pickle=False, dump_file=False))
    parts, names, units = [], None, {}
    for k in range(int(lvm.get("Segments", 0))):
        seg = lvm[k]
        named = list(seg["Channel names"])
        cols = [c for c in named if c != "Comment"]
        data = np.asarray(seg["data"], dtype=float).reshape(len(seg["data"]), -1)
        if data.shape[1] == len(named) != len(cols):  # (rows with their Comment column's text: NaN to lvm_read)
            data = data[:, [j for j, c in enumerate(named) if c != "Comment"]]
        if data.shape[1] != len(cols):
            raise fail("path", str(p), f"a LabVIEW Measurement File whose rows hold its {len(cols)} channels "
                       f"(segment {k + 1}'s hold {data.shape[1]})")
        table = {}
        # (a segment header's values stand over the data's columns after the first, which is
        # the x column's, or an empty one with X_Columns No, whose columns are its channels)
        labels = [str(u).strip() for u in np.atleast_1d(seg.get("Y_Unit_Label", []))]
        for c, u in zip(cols[1:] if cols and cols[0] == "X_Value" else cols, labels):
            if u and c != "X_Value":
                units[c] = u
        if all(str(x).strip() == "Time" for x in np.atleast_1d(seg.get("X_Dimension", [])) if str(x).strip()):
            units["X_Value"] = "s"
        xs = [data[:, j] for j, c in enumerate(cols) if c == "X_Value"]
        for j, c in enumerate(cols):
            if c != "X_Value":
                table[c] = data[:, j]
        if xs and all(np.array_equal(x, xs[0], equal_nan=True) for x in xs):
            table["X_Value"] = xs[0]
        elif not xs:  # (X_Columns No: the times from the segment header, when its channels share them)
            x0 = {float(v) for v in np.atleast_1d(seg.get("X0", [])) if np.isfinite(v)}
            dx = {float(v) for v in np.atleast_1d(seg.get("Delta_X", [])) if np.isfinite(v)}
            if len(x0) == 1 and len(dx) == 1:
                table["X_Value"] = x0.pop() + dx.pop() * np.arange(data.shape[0])
        if names is not None and list(table) != names:
            raise fail("path", str(p), f"a LabVIEW Measurement File whose segments hold the same channels "
                       f"(segment 1: {', '.join(names)}; segment {k + 1}: {', '.join(table)})")
        names = list(table)
        parts.append(table)
    if not parts:
        raise fail("path", str(p), "a LabVIEW Measurement File with data (it has no segment)")
    return Table({c: np.concatenate([t[c] for t in parts]) for c in names}, units)


def _read_hdf5(p: Path, what: str) -> dict:
    try:
        import h5py
    except ImportError:  # pragma: no cover (a dependency)
        raise fail("path", str(p), "CSV or NPZ: reading HDF5 needs h5py (pip install h5py)") from None
    out, need = Table(), [0.0]
    try:
        with h5py.File(p, "r") as f:
            def visit(name, obj):
                if isinstance(obj, h5py.Dataset) and obj.dtype.kind in "biuf" and obj.ndim in (1, 2):
                    need[0] += 8.0 * obj.size  # (all its datasets together)
                    check_budget("path", str(p), need[0], f"reading this {what}")
                    out[name] = np.asarray(obj[...], dtype=float)
                    unit = obj.attrs.get("units", obj.attrs.get("unit"))
                    if isinstance(unit, bytes):
                        unit = unit.decode("utf-8", "replace")
                    if isinstance(unit, str) and unit.strip():
                        out.units[name] = unit.strip()

            f.visititems(visit)
    except OSError as exc:
        raise fail("path", str(p), f"a readable HDF5 file ({exc})") from None
    return out


def _with_file_unit(s: ColumnSpec, said: set, si: str) -> ColumnSpec:
    """``s`` with the unit its file states for its columns (``said``, one or more units as
    written) where ``s`` gives none; ``s`` itself where it gives the same (or a scale for a unit
    of another dimension: a sensor's volts as newtons); refused where they disagree."""
    spec = f"{s.quantity}={','.join(s.columns)}"
    if len(said) > 1:
        raise fail("--column", spec, f"columns of one unit (the file states {', '.join(sorted(said))}): name them "
                   "in separate quantities, or convert the file")
    unit = said.pop()
    # (as files write them: LabVIEW's "Newtons", a superscript's "m/s²")
    written = unit.replace("²", "^2").replace("³", "^3")
    written = written.lower() if re.fullmatch(r"[A-Z][a-z]{2,}", written) else written
    try:
        factor = unit_factor(written, si, "unit")
    except ParameterError:  # (not a unit of the quantity: a raw reading, volts or counts)
        if s.stated:
            return s
        raise fail("--column", spec, f"a unit of {si}: the file states {unit}, so give the reading's scale, "
                   f"--column {spec}:UNIT (one {unit} in {si}, e.g. a sensor's gain)") from None
    if not s.stated:
        return dataclasses.replace(s, unit=unit, factor=factor, stated=True)
    if abs(s.factor - factor) > 1e-9 * abs(factor):
        raise fail("--column", f"{spec}:{s.unit}", f"the unit the file states for {', '.join(s.columns)}, {unit} "
                   "(leave the unit out to take it)")
    return s


def take(table: dict, columns, quantities: dict, defaults: dict, what: str) -> tuple[dict, list]:
    """The quantities the user's column specs name, or haptex's own names where the user named
    none and the file has them, in SI, and the columns left over.

    Parameters
    ----------
    table : dict
        :func:`read_table`'s columns.
    columns : sequence of str or None
        The user's specs ``QUANTITY=COL[,COL...][:UNIT]`` (:func:`parse_column`), each quantity
        once.
    quantities : dict
        The quantities allowed, each with its SI unit.
    defaults : dict
        For a quantity, haptex's own column names (in SI), taken when the user named none for
        it and the table has them all.
    what : str
        What the file is (named in errors).

    Returns
    -------
    values : dict
        ``{quantity: float64 array of shape (n, k)}``, each column times its spec's factor.
    ignored : list of str
        The table's columns no spec names, in the file's order.

    Raises
    ------
    ParameterError
        If a spec is malformed or names a quantity twice, names a column the table does not
        have (the table's columns are listed), gives a unit the file contradicts, gives none for
        a column the file states in a unit of another dimension, takes columns of different
        lengths, or holds a value that is not finite.
    """
    specs = [parse_column(c, quantities) for c in (columns or ())]
    named = {s.quantity for s in specs}
    if len(named) != len(specs):
        raise fail("--column", [s.quantity for s in specs], "each quantity once")
    specs += [ColumnSpec(q, cols, quantities[q], 1.0) for q, cols in defaults.items()
              if q not in named and all(c in table for c in cols)]
    values, used, rows = {}, set(), {}
    stated_units = getattr(table, "units", {})
    for i, s in enumerate(specs):
        said = {stated_units[c] for c in s.columns if c in stated_units}
        if said:  # (the file states the columns' unit: taken where the spec gives none, checked where it does)
            s = specs[i] = _with_file_unit(s, said, quantities[s.quantity])
    for s in specs:
        parts = []
        for c in s.columns:
            if c not in table:
                have = ", ".join(list(table)[:12]) + (", ..." if len(table) > 12 else "")
                raise fail("--column", f"{s.quantity}={c}", f"a column of the {what}: {have}")
            v = np.asarray(table[c], dtype=float)
            rows.setdefault(len(v), c)
            if len(rows) > 1:  # (columns of a file's groups at other rates)
                (n, first), (m, other) = rows.items()
                raise fail("--column", f"{s.quantity}={c}", f"columns of one length: {other} has {m} rows, {first} "
                           f"{n} (the file's groups at other rates: take the quantities from one)")
            parts.append(v.reshape(len(v), -1))
            used.add(c)
        arr = np.concatenate(parts, axis=1) * s.factor
        bad = ~np.isfinite(arr)
        if bad.any():
            k = int(np.argmax(bad.any(axis=1)))
            raise ParameterError(f"{s.quantity} = {arr[k].tolist()} at row {k} is not allowed: must be finite numbers "
                                 f"(columns {', '.join(s.columns)})")
        values[s.quantity] = arr
    return values, [c for c in table if c not in used]
