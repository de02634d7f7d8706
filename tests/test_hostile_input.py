"""Issue 33's pinned cases of hostile input: files that decompress to far more than their
size (a MAT file of compressed zeros, an X3P whose main.xml is mostly spaces) are refused
from their headers, before anything is inflated, in one line naming the file; a map past
the memory budget is refused from its header; q_F holds its grid in bounded slabs; values
that would overflow later are refused where they are parsed; usage errors and warnings
never make more than one line. The atlas's cases (SPEC size, lock, scheduler, SPEC fuzz)
are in test_atlas.py, the explorer's in test_explore_fuzz.py, the exported C's in
test_export.py."""

import contextlib
import math
import struct
import subprocess
import sys
import tracemalloc
import zipfile
import zlib
from pathlib import Path

import numpy as np
import pytest
import scipy.io

import haptex as hx
from haptex._loaders import ST_BYTES_PER_SAMPLE, _mat_samples
from .conftest import needs_data

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "data"


def _mat_of_zeros(path: Path, n: int) -> None:
    """A MATLAB v5 file holding one compressed double column of ``n`` zeros, written by
    streaming through zlib (the test never holds the column): the layout of the MAT-file
    format (MathWorks, "MAT-File Format", v5: a 128-byte header, then a miCOMPRESSED
    element whose zlib stream is a miMATRIX with array flags, dimensions, name and data)."""
    name = b"h"
    sub = [struct.pack("<II", 6, 8) + struct.pack("<II", 6, 0),  # array flags: mxDOUBLE_CLASS
           struct.pack("<II", 5, 8) + struct.pack("<ii", n, 1),  # dimensions n x 1
           struct.pack("<HH", 1, len(name)) + name.ljust(4, b"\0"),  # small element: the name
           struct.pack("<II", 9, 8 * n)]  # miDOUBLE, then 8 n bytes of data
    head = b"".join(sub)
    comp = zlib.compressobj(9)
    body = [comp.compress(struct.pack("<II", 14, len(head) + 8 * n) + head)]
    block = bytes(1 << 20)
    for i in range(0, 8 * n, len(block)):
        body.append(comp.compress(block[:min(len(block), 8 * n - i)]))
    body.append(comp.flush())
    data = b"".join(body)
    header = b"MATLAB 5.0 MAT-file, written by haptex's tests".ljust(116, b" ") + bytes(8) + struct.pack("<H", 0x0100) + b"IM"
    path.write_bytes(header + struct.pack("<II", 15, len(data)) + data)


def test_a_mat_file_of_compressed_zeros_is_refused_before_it_is_inflated(tmp_path):
    """Issue 33: a 389 KB .mat of 5e7 compressed zeros drove design past 6 GB (15 GB
    measured here before the fix)."""
    f = tmp_path / "zeros.mat"
    _mat_of_zeros(f, 50_000_000)
    assert f.stat().st_size < 1_000_000
    assert scipy.io.whosmat(f.as_posix())[0][1] == (50_000_000, 1)  # scipy reads our file as we meant it
    tracemalloc.start()
    with pytest.raises(hx.ParameterError, match=r"^path = .* is not allowed: its 5e\+07 numbers would need .* GiB, "
                                                r"over the memory budget"):
        hx.load_texture(f, spacing=1e-6, height_unit="um")
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20e6  # refused from the header: 400 MB were never inflated


def test_the_mat_count_is_what_scipy_lists(tmp_path):
    """The header scan against scipy's own listing, compressed and not, several variables."""
    for compress in (False, True):
        f = tmp_path / f"m{compress}.mat"
        scipy.io.savemat(f, {"a": np.zeros((3, 4)), "b": np.ones(7), "c": np.arange(5.0)[None, :]},
                         do_compression=compress)
        listed = sum(int(np.prod(shape)) for _, shape, _ in scipy.io.whosmat(f.as_posix()))
        assert _mat_samples(f) == listed == 24
    assert _mat_samples(EXAMPLES / "grooves-4mm-profile.mat") == 8000  # the shipped scan: 8000 x 1


def test_an_x3p_whose_xml_inflates_is_refused_from_its_directory(tmp_path, monkeypatch):
    """Issue 33: a 3.2 MB X3P whose main.xml is 3 GB of spaces drove design past 6 GB. Here
    main.xml carries 20 MB of spaces and the budget is 256 MiB (20 MB x 40 bytes a parsed
    byte = 800 MB), so the case runs in a second; the rule is the same."""
    from SurfaceTopography import Topography

    good = tmp_path / "good.x3p"
    Topography(np.random.default_rng(0).normal(size=(64, 64)) * 1e-6, (64e-6, 64e-6), unit="m").to_x3p(str(good))
    bad = tmp_path / "bad.x3p"
    with zipfile.ZipFile(good) as src, zipfile.ZipFile(bad, "w", zipfile.ZIP_DEFLATED) as dst:
        for info in src.infolist():
            data = src.read(info.filename)
            if info.filename.endswith("main.xml"):
                data = data + b" " * 20_000_000
            dst.writestr(info.filename, data)
    assert bad.stat().st_size < 200_000
    monkeypatch.setenv("HAPTEX_MEMORY_BUDGET", str(256 * 2**20))
    assert hx.load_texture(good).h.shape == (64, 64)  # the same file without its padding reads
    with pytest.raises(hx.ParameterError, match=r"^path = .* is not allowed: its contents \(19.0\d MiB of text and "
                                                r"0.03\d* MiB of data once decompressed\) would need"):
        hx.load_texture(bad)


@pytest.mark.long  # (.ci/run's long set: writes a 4096 x 4096 map, 128 MB)
def test_a_map_past_the_budget_is_refused_from_its_header_at_the_cli(tmp_path):
    """Issue 35's goal: a 4096 x 4096 map is refused or done within the memory budget. At
    the measured 400 bytes a sample it would need 6.7 GB: refused in one line, exit 2,
    before its heights are read."""
    from SurfaceTopography import Topography

    f = tmp_path / "big.x3p"
    Topography(np.zeros((4096, 4096)), (4.096e-3, 4.096e-3), unit="m").to_x3p(str(f))
    r = subprocess.run([sys.executable, "-m", "haptex", "design", "--texture", str(f)], capture_output=True, text=True,
                       timeout=120, env={**__import__("os").environ, "HAPTEX_MEMORY_BUDGET": str(6 * 2**30)})
    assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, r.stderr[-500:]
    assert "a 4096 x 4096 " in r.stderr and "(X3P) map would need 6.25 GiB, over the memory budget of 6 GiB" in r.stderr
    assert 4096 * 4096 * ST_BYTES_PER_SAMPLE > 6 * 2**30


@pytest.mark.long  # (.ci/run's long set: a slab's memory bound shows only on a long profile: 3.5e6 Jacobians, 5 s)
def test_q_of_f_over_a_long_profile_holds_its_grid_in_slabs():
    """q_F's sup over a profile 200 periods long: its grid (about 3.5e6 Jacobians) is
    evaluated in slabs of 2^20 points; the sup is the same as over one period of the same
    sinusoid (a periodic texture's sup does not grow with its length), to the refinement's
    tolerance, and the peak memory stays under 400 MB (the whole grid held 3.4 GB for a
    1 m scan, so 0.7 GB for this one)."""
    from haptex.analysis.characteristic import characteristic_number

    tex = hx.Sinusoid(0.2e-3, 1e-3)
    alg = hx.algorithm("F", tex, 2000.0, friction=0.5, presliding=1e-3, max_penetration=1e-3)
    one = characteristic_number(alg, max_penetration=1e-3, x_range=(0.0, 1e-3)).value
    tracemalloc.start()
    long = characteristic_number(alg, max_penetration=1e-3, x_range=(0.0, 0.2)).value
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert long == pytest.approx(one, rel=1e-3)
    assert peak < 400e6


DEKTAK_EX = str(EXAMPLES / "dektak-stylus-profile.csv")


@pytest.mark.parametrize("args, name", [
    # issue 33's inputs that parsed and overflowed later (each ended in a traceback, exit 1)
    (["design", "--texture", "sine:0.8mm,1e308m"], "period"),
    (["design", "--texture", "sine:0.8mm,1e-320m"], "period"),
    (["design", "--texture", "sine:1e-320m,1mm"], "amplitude"),
    (["design", "--texture", DEKTAK_EX, "--speed", "1e308 m/s"], "speed"),
    (["design", "--texture", DEKTAK_EX, "--max-penetration", "1e-320m"], "max_penetration"),
    (["design", "--texture", DEKTAK_EX, "--lowpass", "1e300m"], "lowpass"),
    (["design", "--texture", DEKTAK_EX, "--window", "0m,1e-320m"], "window"),
    (["table", "--amplitude", "1e-320m"], "amplitude"),
    (["simulate", "thrust", "--algorithm", "W", "--duration", "1e308s"], "duration"),
    # in range, but past what the data hold: a window beyond the scan (a cut-off longer than it:
    # test_a_low_pass_the_measured_file_refuses_is_named_as_the_user_typed_it, as --lowpass)
    (["design", "--texture", DEKTAK_EX, "--window", "0mm,1m"], "window"),
])
def test_values_that_would_overflow_are_refused_where_they_are_parsed(args, name, capsys):
    from haptex.cli import main

    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    assert f"{name} = " in err and "is not allowed" in err, err


@pytest.mark.parametrize("text, unit", [("1e-12 m", "m"), ("1 km", "m"), ("10 GN/m", "N/m"), ("1 ns", "s"),
                                        ("0 m", "m"), ("-0.5 mm", "m")])
def test_the_ranges_admit_what_users_write(text, unit):
    """The edges of QUANTITY_RANGES (a picometre to a kilometre, ...) and 0 parse; a hair
    beyond them does not."""
    from haptex._units import QUANTITY_RANGES, parse_quantity

    v = parse_quantity(text, unit, "x")
    lo, hi = QUANTITY_RANGES[unit]
    assert v == 0 or lo <= abs(v) <= hi
    if v != 0:
        with pytest.raises(hx.ParameterError, match=r"^x = .* is not allowed: must be 0 or of magnitude"):
            parse_quantity(f"{abs(v) * (1.01 if abs(v) == hi else 0.99 if abs(v) == lo else 1e30)} {unit}", unit, "x")


def test_threads_parsing_their_first_quantity_together_build_one_unit_registry(monkeypatch):
    """The explorer's sessions each compute in their own thread; pint's registry costs ~0.3 s
    of pure Python (holding the GIL against the server's event loop), so threads that ask for
    it together wait for one build (a stall of 1.2-1.4 s per eight new sessions was measured
    with py-spy when each built its own)."""
    import threading

    import pint

    from haptex import _units

    built = []
    real_init = pint.UnitRegistry.__init__

    def counting_init(self, *args, **kwargs):
        built.append(threading.current_thread().name)
        real_init(self, *args, **kwargs)

    monkeypatch.setattr(pint.UnitRegistry, "__init__", counting_init)
    _units._registry.cache_clear()
    _units._registry_built.cache_clear()
    try:
        barrier = threading.Barrier(4)
        out = []

        def parse():
            barrier.wait()
            out.append(_units.parse_quantity("2 kN/m", "N/m", "stiffness"))

        threads = [threading.Thread(target=parse) for _ in range(4)]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
    finally:
        _units._registry.cache_clear()
        _units._registry_built.cache_clear()
    assert out == [2000.0] * 4
    assert len(built) == 1, built


@pytest.mark.parametrize("args, expected", [
    (["simulate"], "haptex: error: haptex simulate needs a command: path, scan, thrust (see 'haptex simulate --help')"),
    (["atlas"], "haptex: error: haptex atlas needs a command: plot (see 'haptex atlas --help')"),
    (["design"], "haptex: error: Missing option '--texture'. (see 'haptex design --help')"),
])
def test_usage_errors_are_one_line_and_a_hint(args, expected, capsys):
    """Issue 33: a group called without its command printed its whole help as the error."""
    from haptex.cli import main

    assert main(args) == 2
    assert capsys.readouterr().err.strip() == expected


def test_a_warning_never_precedes_the_one_line_error(monkeypatch, capsys):
    """Warnings raised on the way to an error are dropped; after a result they are shown."""
    import warnings

    import haptex.cli as cli

    def warns_then(status):
        def run(argv):
            warnings.warn("overflow encountered in multiply", RuntimeWarning)
            if status:
                print("haptex: error: x = 1 is not allowed", file=sys.stderr)
            return status
        return run

    monkeypatch.setattr(cli, "_run", warns_then(2))
    with warnings.catch_warnings(record=True) as shown:
        assert cli.main([]) == 2
    assert capsys.readouterr().err.strip() == "haptex: error: x = 1 is not allowed" and not shown
    monkeypatch.setattr(cli, "_run", warns_then(0))
    with pytest.warns(RuntimeWarning, match="overflow encountered in multiply"):
        assert cli.main([]) == 0


def test_a_mat_v73_file_is_not_scanned_as_v5(tmp_path):
    """A MATLAB v7.3 file is HDF5 behind the same 128-byte header (version 0x0200): its
    bytes are not v5 tags, so the scan counts nothing and loadmat's own refusal is the line
    (not a count read from HDF5 bytes)."""
    import h5py

    raw = tmp_path / "raw.h5"
    with h5py.File(raw, "w", userblock_size=512) as f:
        f["z"] = np.zeros(10)
    data = bytearray(raw.read_bytes())
    data[:128] = b"MATLAB 7.3 MAT-file".ljust(116, b" ") + bytes(8) + struct.pack("<H", 0x0200) + b"IM"
    f73 = tmp_path / "v73.mat"
    f73.write_bytes(bytes(data))
    assert _mat_samples(f73) == 0
    with pytest.raises(hx.ParameterError, match=r"v73.mat: not a readable MATLAB file \(.*v7.3"):
        hx.load_texture(f73, spacing=1e-6, height_unit="um")


def test_a_subnormal_amplitude_under_f_is_refused_by_name():
    """Issue 33: a subnormal amplitude ended in "non-finite position [nan, nan]" under F
    (its modulation h~ = h / max|h| overflowed). A normal one, however small, and a flat
    texture are analysed."""
    with pytest.raises(hx.ParameterError, match=r"^texture = Sinusoid\(amplitude=9.99989e-321.* is not allowed: must "
                                                r"be a texture whose peak height F can normalise"):
        hx.algorithm("F", hx.Sinusoid(1e-320, 1e-3), 2000.0)
    for a in (1e-300, 0.0):
        alg = hx.algorithm("F", hx.Sinusoid(a, 1e-3), 2000.0, max_penetration=1e-3)
        assert np.isfinite(hx.characteristic_number(alg, max_penetration=1e-3).value)


def test_an_npz_log_is_refused_from_its_headers_and_a_broken_one_in_one_line(tmp_path, capsys):
    # a run log or recording as NPZ (issue 65's rig logs): numpy's .npy header (NEP 1: magic,
    # version, a header dict with 'shape') declares 2e9 doubles in a 20 kB member of compressed
    # zeros; read array by array, the file would inflate to 16 GB before the budget saw it. And
    # a file named .npz that is no zip ended in zipfile's traceback with exit status 1.
    from haptex.cli import main

    head = np.lib.format
    hdr = __import__("io").BytesIO()
    head.write_array_header_1_0(hdr, {"descr": "<f8", "fortran_order": False, "shape": (2_000_000_000,)})
    with zipfile.ZipFile(tmp_path / "bomb.npz", "w", zipfile.ZIP_DEFLATED) as z:
        with z.open("time_s.npy", "w", force_zip64=True) as fh:
            fh.write(hdr.getvalue() + bytes(1 << 22))  # (the rest never read)
    (tmp_path / "broken.npz").write_bytes(b"PK\x03\x04 not a zip archive")
    tracemalloc.start()
    assert main(["identify", str(tmp_path / "bomb.npz"), "-o", str(tmp_path / "d.toml")]) == 2
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert main(["identify", str(tmp_path / "broken.npz"), "-o", str(tmp_path / "d.toml")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 2 and "14.9 GiB" in err[0] and "not a zip file" in err[1]
    assert peak < 50e6  # (bytes: the header, not the array)
    # a member written without numpy's .npy suffix is an array numpy reads (its name as written):
    # read too, not refused by the header check
    from haptex._columns import read_table

    arr = __import__("io").BytesIO()
    head.write_array(arr, np.arange(3.0))
    with zipfile.ZipFile(tmp_path / "plain.npz", "w") as z:
        z.writestr("time_s", arr.getvalue())
    assert np.array_equal(read_table(tmp_path / "plain.npz", "run log")["time_s"], np.arange(3.0))


def _a_path_taken(module, name):
    """(the public function ``module.name``, the call that gives it ``v`` for its path and
    what a valid call gives for the rest): its path is the first parameter, or ``out`` after an
    algorithm (export_c: the algorithm the README's first example renders) or a model set."""
    import importlib

    fn = getattr(importlib.import_module(module), name)
    if name == "export_c":
        alg = hx.algorithm("A", hx.Sinusoid(0.2e-3, 2e-3), 2000.0)
        return lambda v: fn(alg, v, 5.0)
    if name == "write_hatt":
        from haptex.datadriven import ModelSet

        return lambda v: fn(ModelSet.__new__(ModelSet), v)
    extra = {"write_log": ([0.0, 1e-3], [0.0, 0.0], [0.0, 0.0]), "placed_mesh": (1e-3, None),
             "firmware_command": ("cortex-m4",), "check_output": (False,), "sweep": ()}
    return lambda v: fn(v, *extra.get(name, ()))


_TAKE_A_PATH = [("haptex.surfaces", "load_texture", "path"), ("haptex.atlas", "open_atlas", "atlas"),
                ("haptex.atlas", "sweep", "spec"), ("haptex.catalogue", "device_from_file", "device"),
                ("haptex.datadriven", "read_hatt", "path"), ("haptex.datadriven", "read_models", "path"),
                ("haptex.datadriven", "write_hatt", "path"), ("haptex.datadriven", "read_recording", "path"),
                ("haptex.identification", "read_log", "path"), ("haptex.identification", "write_log", "path"),
                ("haptex.identification", "identify_log", "path"), ("haptex.explore.model", "placed_mesh", "path"),
                ("haptex.export", "export_c", "out"), ("haptex.export", "firmware_command", "out"),
                ("haptex.report", "check_output", "out")]


@pytest.mark.parametrize("module, name, said", _TAKE_A_PATH)
@pytest.mark.parametrize("value", [3.5, None, ["a.txt"]])
def test_a_path_given_as_anything_but_a_path_is_refused_naming_it(module, name, said, value):
    # hx.load_texture(3.5) raised Python's "TypeError: expected str, bytes or os.PathLike object,
    # not float" from pathlib, with no name of the parameter (2026-12-01's sweep of the public
    # functions with a number, None and a list for every argument). Truth: each function's
    # documented parameter, a file's path (str or os.PathLike, os.fspath's contract: PEP 519);
    # the name is the one its missing file is refused with
    with pytest.raises(hx.ParameterError) as e:
        _a_path_taken(module, name)(value)
    said_ = str(e.value)
    assert said_.startswith(f"{said} = ") and "'s path (a str or pathlib.Path)" in said_, said_


def test_every_public_function_that_takes_a_path_is_checked_above():
    # the list above is every public function of the package with a parameter named path or
    # out that is a file's or a folder's (found by walking the package; analysis.work's path
    # and operators.KinematicPath's are a probe's path, the plots' path is written last, by plotting._finish)
    import inspect

    from .conftest import public_api

    found = {(m, n) for m, n, f, params in public_api()
             if inspect.isfunction(f) and {"path", "out"} & set(params[:2])
             and m not in ("haptex.plotting", "haptex.analysis.work", "haptex.operators")}
    assert found - {("haptex.report", "write_report")} == {(m, n) for m, n, _ in _TAKE_A_PATH}


@pytest.mark.parametrize("value", [3.5, "nonsense", [1.0, 2.0, 3.0], [[0.0, 0.1]], None])
def test_a_handle_position_of_another_shape_is_refused_as_such_not_as_out_of_reach(value):
    # five_bar_jacobian(0.1, 0.1, 0.05, 3.5) said "working_point = 3.5 is not allowed: motor 1
    # cannot reach it", "nonsense" raised numpy's "could not convert string to float". Truth:
    # its documented p, an array of shape (2,) in metres (Hayward's pantograph's handle
    # position [x, y])
    with pytest.raises(hx.ParameterError) as e:
        hx.devices.five_bar_jacobian(0.1, 0.1, 0.05, value)
    assert str(e.value).startswith("working_point = ") and "a handle position [x, y] in metres" in str(e.value)


@pytest.mark.parametrize("value", [3.5, "nonsense", [1.0, 2.0], None, [[1.0, 2.0]]])
def test_a_jacobian_of_another_shape_is_refused_naming_the_shapes_taken(value):
    # spectral_norm(3.5) raised numpy's AxisError ("axis -1 is out of bounds for array of
    # dimension 0"), [[1, 2]] returned a number for a 1 x 2 matrix. Truth: its documented j,
    # shape (..., 2, 2) or (..., 3, 3)
    from haptex.analysis.characteristic import spectral_norm

    with pytest.raises(hx.ParameterError) as e:
        spectral_norm(value)
    assert str(e.value).startswith("j = ") and "(..., 2, 2) or (..., 3, 3)" in str(e.value), str(e.value)


@contextlib.contextmanager
def _within(seconds: float, what: str):
    """Raise TimeoutError naming ``what`` if the block runs past ``seconds`` (SIGALRM; a call
    that would run on is a failure, not a hung suite)."""
    import signal

    def late(*_):
        raise TimeoutError(f"{what} still running after {seconds:g} s")

    old = signal.signal(signal.SIGALRM, late)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, old)


def _sweep_calls():
    """Valid calls of the public API, each a function of one argument's value (the parameter
    named by the case): the cheap ones the README's examples make."""
    from haptex.operators import ConstantForce

    sine = hx.Sinusoid(0.2e-3, 2e-3)
    a = hx.algorithm("A", sine, 2000.0)
    f = hx.algorithm("F", sine, 2000.0)
    dev = hx.Device.point_mass(0.1, 0.5, 1e-3)
    x = np.linspace(0.0, 4e-3, 401)
    h = 1e-4 * np.sin(2 * np.pi * x / 1e-3)
    xs = np.linspace(0.0, 2e-3, 17)
    hs = 1e-4 * np.sin(2 * np.pi * xs[:, None] / 1e-3) * np.sin(2 * np.pi * xs[None, :] / 1e-3)
    return {
        "resolution": lambda v: hx.characteristic_number(a, x_range=(0.0, 2e-3), resolution=v),
        "seed": lambda v: hx.conservativity(a, n_random=2, seed=v, x_range=(0.0, 2e-3)),
        "random_loops.seed": lambda v: hx.random_loops(a, n=2, seed=v),
        "n": lambda v: hx.random_loops(a, n=v),
        "vertices": lambda v: hx.random_loops(a, n=2, vertices=v),
        "delay": lambda v: hx.critical_stiffness(0.1, 0.5, 1e-3, delay=v),
        "damping": lambda v: hx.critical_stiffness(0.1, v, 1e-3),
        "period": lambda v: hx.critical_stiffness(0.1, 0.5, v),
        "depth": lambda v: hx.friction_bounds(f, v),
        "paper_loop.depth": lambda v: hx.paper_loop(a, depth=v),
        "record_every": lambda v: hx.simulate(a, dev, ConstantForce([0.0, -1.0]), 0.01, initial_position=[0.0, 0.0],
                                              record_every=v),
        "letters": lambda v: hx.table_ii(letters=v),
        "samples_per_period": lambda v: hx.texture_limits(sine, dev, 0.1, 2000.0, samples_per_period=v),
        "hand": lambda v: hx.wall_limits(dev, hand=v),
        "slopes": lambda v: hx.SampledProfile(x, h, slopes=v),
        "periodic": lambda v: hx.SampledProfile(x, h, periodic=v),
        "SampledSurface.periodic": lambda v: hx.SampledSurface(xs, xs, hs, periodic=v),
        "energy_monitor": lambda v: hx.Renderer(a, max_force=5.0, energy_monitor=v),
        "simulate_batch.record_every": lambda v: hx.simulate_batch(a, dev, ConstantForce([0.0, -1.0]), 0.01,
                                                                   initial_position=[0.0, 0.0], record=True,
                                                                   record_every=v),
        "load_texture.spacing": lambda v: hx.load_texture(EXAMPLES / "dektak-stylus-profile.csv", spacing=v),
        "load_texture.periodic": lambda v: hx.load_texture(EXAMPLES / "dektak-stylus-profile.csv", periodic=v),
        "time": lambda v: hx.identify(time=v, position=np.zeros(100), force=np.zeros(100)),
        "position": lambda v: hx.identify(time=np.arange(100) * 1e-3, position=v, force=np.zeros(100)),
        "position_resolution": lambda v: hx.identify(time=np.arange(100) * 1e-3, position=np.zeros(100),
                                                     force=np.zeros(100), position_resolution=v),
        "source": lambda v: hx.identify(time=np.arange(100) * 1e-3, position=np.zeros(100), force=np.zeros(100),
                                        source=v),
        "preset.device": lambda v: hx.catalogue.preset(v),
    }


_SWEPT = [("resolution", v) for v in ("nonsense", 3.5, (1e9, 64), (256, 10**9), (256.5, 64), (256,))] + [
    (p, v) for p in ("seed", "random_loops.seed") for v in ("nonsense", -1, 2.5, [1.0, 2.0], True)] + [
    ("n", v) for v in ("nonsense", math.nan, math.inf, 1e300, 10**9, -1.0, 0)] + [
    ("vertices", v) for v in ("nonsense", -1.0, 10**9, 0, 2.5)] + [
    ("delay", v) for v in ("nonsense", math.nan, math.inf, [1.0, 2.0], 1e300, 10**9, True)] + [
    ("damping", 1e300), ("period", 1e300)] + [
    ("depth", v) for v in ("nonsense", [1.0, 2.0], 1e300, -1.0, math.nan, math.inf)] + [
    ("paper_loop.depth", 0.5e-3)] + [
    (p, v) for p in ("record_every", "simulate_batch.record_every")
    for v in ("nonsense", math.nan, math.inf, [1.0, 2.0], 1e300, 0, 2.5)] + [
    ("load_texture.spacing", v) for v in ("nonsense", "0.5um", 1e-6)] + [
    ("letters", v) for v in (-1.0, [1.0, 2.0], True, 0)] + [
    ("samples_per_period", v) for v in ("nonsense", [1.0, 2.0], True, 1e300)] + [
    ("hand", [1.0, 2.0]), ("slopes", "nonsense"), ("time", "nonsense"), ("position", "nonsense"),
    ("position_resolution", "nonsense"), ("position_resolution", [1.0, 2.0]), ("source", 3.5), ("source", None),
    ("preset.device", [1.0, 2.0])] + [
    (p, v) for p in ("periodic", "SampledSurface.periodic", "energy_monitor", "load_texture.periodic")
    for v in ("nonsense", 1.0, [1.0], math.nan)]


@pytest.mark.parametrize("param, value", _SWEPT)
def test_a_value_of_another_kind_or_out_of_range_is_refused_naming_its_parameter(param, value):
    # A sweep of the public API's parameters (2026-12-01: 38 valid calls, each argument in
    # turn given "nonsense", -1, NaN, inf, a list, True, 1e300, 10^9 and 0) found these raising
    # Python's or numpy's errors (TypeError, ValueError, OverflowError, LinAlgError, a
    # 'float' object is not iterable), running out of memory (critical_stiffness's delay and
    # random_loops's vertices at 10^9) or running on (random_loops's n at 10^9), or taken
    # silently: a boolean flag given a string, a depth paper_loop does not use for A, a
    # spacing for a file that gives its positions (the dektak CSV's). Truth:
    # each parameter as its docstring states it (its kind, its range); a refusal names it
    with _within(20.0, f"{param} = {value!r}"), pytest.raises(hx.ParameterError) as e:
        _sweep_calls()[param](value)
    name = param.split(".")[-1]
    assert str(e.value).startswith(f"{name} "), str(e.value)


def test_a_spacing_given_for_a_file_of_positions_without_their_unit_is_refused(tmp_path):
    # a plain two-column text file (x, h) without units: SurfaceTopography's reader takes its
    # positions (x_unit gives their unit); a spacing given beside them was silently ignored
    # (2026-12-01). Truth: the file's own first column, read back
    path = tmp_path / "scan.txt"
    x = np.arange(64) * 1e-6
    np.savetxt(path, np.column_stack([x, 1e-7 * np.sin(x / 1e-5)]))
    t = hx.load_texture(path, x_unit="m", height_unit="m")
    assert t.dx == pytest.approx(1e-6)
    with pytest.raises(hx.ParameterError, match=r"^spacing = '2um' is not allowed: .* states its positions"):
        hx.load_texture(path, spacing="2um", x_unit="m", height_unit="m")


@pytest.mark.parametrize("make, r", [(lambda: hx.Sinusoid(0.2e-3, 2e-3), 1e9), (lambda: hx.Sinusoid(0.2e-3, 2e-3), 1e300),
                                     (lambda: hx.SumOfGratings.egg_crate(0.1e-3, 2e-3), 1e9),
                                     (lambda: hx.SumOfGratings.egg_crate(0.1e-3, 2e-3), 1e3)])
def test_a_ball_of_any_size_is_refused_in_bounded_memory_and_time(make, r):
    # felt_by(1e9) on a sinusoid ran out of memory counting the ball's grid points (numpy's
    # arange of 2.6e14 offsets, "Unable to allocate 1.86 TiB"), 1e300 raised numpy's "Maximum
    # allowed size exceeded", and at 1e3 m the count held 2 GB (2026-12-01's sweep). Truth: the
    # work bound the refusal states (MAX_DILATION_WORK, samples x the ball's grid points), here
    # past it by orders of magnitude; tracemalloc's peak and a 20 s alarm bound the refusal
    tex = make()
    tracemalloc.start()
    try:
        with _within(20.0, f"felt_by({r})"), pytest.raises(hx.ParameterError) as e:
            tex.felt_by(r)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert str(e.value).startswith(f"tip_radius = {r:g} is not allowed"), str(e.value)
    assert peak < 200e6  # (bytes)


def _one_model_set():
    import haptex.datadriven as dd

    ar = np.real(np.poly([0.9 * np.exp(0.3j), 0.9 * np.exp(-0.3j)]))  # (a stable AR(2): poles inside the unit circle)
    return dd.ModelSet([dd.ArmaModel(ar, [1.0], 1.0, 1.0, 10_000.0, 0.05, 1.0)])


def _seed_takers(tmp_path):
    """Every public function or class that takes a ``seed``, called with ``seed=s`` (each its
    cheapest valid call)."""
    import haptex.datadriven as dd
    from haptex.analysis.cost import evaluation_time
    from haptex.export import export_c
    from haptex.identification import IdentificationProgram, excitation, simulated_log
    from haptex.operators import ConstantForce
    from haptex.renderer import vibration_settings

    models = _one_model_set()
    wall = hx.algorithm("A", hx.Sinusoid(1e-4, 1e-3), 1e3)
    device = hx.Device.point_mass(0.1, 0.5, 1e-4)  # (the models' rate, 10 kHz)
    vib = {"vibration": models, "vibration_mass": 0.1}
    return {"ModelSet.synthesize": lambda s: models.synthesize(0.05, 1.0, 0.01, seed=s),
            "check_models": lambda s: dd.check_models(models, points=1, seconds=1.5, seed=s),
            "surface_from": lambda s: dd.surface_from(models, 0.01, seed=s),
            "vibration_settings": lambda s: vibration_settings(models, 0.1, seed=s),
            "Renderer": lambda s: hx.Renderer(wall, max_force=10.0, seed=s, **vib),
            "simulate": lambda s: hx.simulate(wall, device, ConstantForce([0.0, -1.0]), 0.005, seed=s, **vib),
            "simulate_batch": lambda s: hx.simulate_batch(wall, device, ConstantForce([0.0, -1.0]), 0.005, seed=s,
                                                          **vib),
            "export_c": lambda s: export_c(wall, tmp_path / "out", 10.0, seed=s, **vib),
            "BandLimitedNoise": lambda s: hx.BandLimitedNoise(1e-5, 1e-3, 1e-2, 2e-2, seed=s),
            "BandLimitedNoise2D": lambda s: hx.BandLimitedNoise2D(1e-5, 1e-3, 1e-2, 2e-2, seed=s),
            "random_loops": lambda s: hx.random_loops(wall, 1, seed=s),
            "conservativity": lambda s: hx.conservativity(wall, n_random=1, seed=s),
            "evaluation_time": lambda s: evaluation_time(wall, probes=8, seed=s),
            "excitation": lambda s: excitation(1e-3, 0.01, seed=s),
            "simulated_log": lambda s: simulated_log(device, 0.01, seed=s),
            "IdentificationProgram": lambda s: IdentificationProgram(1, 1e-3, 0.01, 1.0, seed=s)}


@pytest.mark.parametrize("taker", sorted(_seed_takers(Path("."))))
@pytest.mark.parametrize("value, taken", [(0, True), (np.uint64(2**64 - 1), True), (np.int32(7), True), (7.0, True),
                                          (2**64, False), (-1, False), (7.5, False), (True, False), (np.True_, False),
                                          ("7", False), (None, False)])
def test_every_seed_is_numpys_default_rng_seed_and_nothing_else(taker, value, taken, tmp_path):
    # A seed is numpy's default_rng's: any whole number from 0 to 2^64 - 1 (numpy's SeedSequence
    # takes exactly those as a single entropy value; NumPy's Random Generator docs), whether an
    # int or a numpy integer; a bool, a fraction, a string or None (fresh entropy: not the same
    # run twice) is refused naming `seed`. Before: the renderer's vibration refused numpy's
    # uint64, check_models passed anything to default_rng (its own errors, or True taken as 1).
    call = _seed_takers(tmp_path)[taker]
    if taken:
        call(value)
    else:
        with pytest.raises(hx.ParameterError, match=r"^seed = "):
            call(value)


def test_every_public_seed_is_checked_above():
    # the list above is every public function and class with a `seed` parameter (found by
    # walking the package), so that a new one is checked as these are
    from .conftest import public_api

    takers = {n for n in _seed_takers(Path("."))}
    missing = sorted(f"{m}.{n}" for m, n, _, params in public_api() if "seed" in params and n not in takers)
    assert not missing, missing


def _whole_takers():
    import haptex.datadriven as dd
    from haptex import core

    models = _one_model_set()

    def threads(n):
        with core.threads(n):
            pass

    rng = np.random.default_rng(1)
    a = rng.normal(size=(64, 3))
    return {("block", 4, None): lambda v: dd.dft321(a, block=v),
            ("points", 1, 10**6): lambda v: dd.check_models(models, points=v, seconds=1.5),
            ("threads", 1, 1024): threads}


@pytest.mark.parametrize("key", sorted(_whole_takers(), key=str))
@pytest.mark.parametrize("kind", ["int", "numpy", "float", "low", "high", "fraction", "bool", "text"])
def test_every_count_takes_whole_numbers_of_any_kind_in_its_range(key, kind):
    # A count (samples a block, points, threads) is a whole number in its stated range, given as
    # an int, a numpy integer or a float with no fraction (as every count of haptex takes it,
    # _validation.whole); a fraction, a bool or text is refused naming the parameter.
    name, lo, hi = key
    value = {"int": lo, "numpy": np.int64(lo), "float": float(lo), "low": lo - 1,
             "high": (hi + 1) if hi is not None else None, "fraction": lo + 0.5, "bool": True, "text": str(lo)}[kind]
    if value is None:
        return
    call = _whole_takers()[key]
    if kind in ("int", "numpy", "float"):
        call(value)
    else:
        with pytest.raises(hx.ParameterError, match=rf"^{name} = "):
            call(value)


@pytest.mark.parametrize("param", ["native", "keep_awake"])
@pytest.mark.parametrize("value, taken", [(np.True_, True), (np.False_, True), (False, True), (1, False),
                                          ("no", False), (None, False)])
def test_a_servo_loops_switches_take_numpys_booleans_as_every_switch_does(param, value, taken):
    # A switch is a bool, Python's or numpy's (as every other switch of haptex takes it,
    # _validation.flag: e.g. a value read from an array); 1, 'no' or None refused naming it.
    # Before: the servo loop alone refused numpy's np.True_.
    from haptex.backends.simulated import SimulatedBackend
    from haptex.servo import ServoLoop

    backend = SimulatedBackend("omega-3", realtime=False)
    renderer = hx.Renderer(hx.algorithm("A", hx.Grating(1e-4, 1e-3), 500.0), max_force=backend.max_force)
    kw = {param: value}
    if taken:
        ServoLoop(backend, renderer, **kw)
    else:
        with pytest.raises(hx.ParameterError, match=rf"^{param} = "):
            ServoLoop(backend, renderer, **kw)


def _felt_spacing_cases():
    """(texture, the coarsest spacing (m) its felt grid can take, by its definition): 4 samples a
    period of an analytic texture (its period, its cell's shorter side) or of a periodic sampled
    one; 4 samples from a bounded scan's first to its last (3 steps)."""
    from haptex.surfaces import SampledSurface
    from haptex.textures import SampledProfile

    x = np.linspace(0.0, 2e-3, 201)
    g = np.linspace(0.0, 1e-3, 65)
    G = 1e-5 * np.sin(2 * np.pi * g[:, None] / 5e-4) * np.cos(2 * np.pi * g[None, :] / 5e-4)
    return {"Sinusoid": (hx.Sinusoid(2e-4, 2e-3), 2e-3 / 4),
            "SampledProfile": (SampledProfile(x, 1e-5 * np.sin(2 * np.pi * x / 1e-3)), 2e-3 / 3),
            "periodic SampledProfile": (SampledProfile(x[:-1], 1e-5 * np.sin(2 * np.pi * x[:-1] / 1e-3), periodic=True),
                                        2e-3 / 4),
            "Grating": (hx.Grating(1e-4, 1e-3), 1e-3 / 4),
            "SampledSurface": (SampledSurface(g, g, G), 1e-3 / 3)}


@pytest.mark.parametrize("name", sorted(_felt_spacing_cases()))
def test_a_felt_grids_spacing_is_taken_up_to_the_coarsest_grid_and_refused_past_it(name):
    # felt_by(r, spacing=S) resamples the texture at S (the remedies of a refusal for work name
    # "S or more"): S past the coarsest grid the texture has (4 samples, definitions above) was
    # taken and failed inside (numpy's IndexError on a sinusoid; on a scan, its grid's second
    # point, beyond the scan, refused as a sample "beyond +-1000 m", naming x[1]) or made a finer
    # grid than asked on a periodic scan. Now refused naming spacing and the coarsest it takes,
    # and that bound gives a felt texture.
    texture, coarsest = _felt_spacing_cases()[name]
    r = 5e-5
    felt = texture.felt_by(r, spacing=coarsest)
    assert np.isfinite(felt.height(0.0) if texture.dimension == 1 else felt.height_at(np.zeros((1, 2)))).all()
    with pytest.raises(hx.ParameterError, match=r"^spacing = ") as e:
        texture.felt_by(r, spacing=coarsest * 1.01)
    assert f"at most {coarsest:g} m" in str(e.value)


@pytest.mark.parametrize("kind", ["profile", "surface"])
@pytest.mark.parametrize("which", ["length_factor", "height_factor"])
def test_a_scale_factor_is_refused_by_name_past_the_lengths_haptex_takes(kind, which):
    # A sample must lie within +-MAX_LENGTH = 1000 m (haptex._validation, "check the unit"): a
    # factor that scales a texture's abscissae or heights past it was refused naming the
    # scaled samples (x[1], h[2], h), which the user never gave. Now the factor is named, with the
    # largest it takes for this texture (max |x| or max |h| times it at most 1000 m), and that
    # largest is taken.
    from haptex._validation import MAX_LENGTH
    from haptex.surfaces import SampledSurface
    from haptex.textures import SampledProfile

    x = np.linspace(1e-3, 3e-3, 101)
    tex = (SampledProfile(x, 2e-5 * np.sin(2 * np.pi * x / 1e-3)) if kind == "profile" else
           SampledSurface(x, x, 2e-5 * np.sin(2 * np.pi * x[:, None] / 1e-3) * np.ones(x.size)))
    h = tex.h
    largest = MAX_LENGTH / (3e-3 if which == "length_factor" else float(np.abs(h).max()))
    kw = {which: largest * (1 - 1e-12)}
    tex.scaled(**kw)
    with pytest.raises(hx.ParameterError, match=rf"^{which} = ") as e:
        tex.scaled(**{which: largest * 1.01})
    assert f"at most {largest:.6g}" in str(e.value)


def test_a_maps_cut_off_longer_than_the_map_is_refused_as_a_scans_is():
    # SampledProfile.lowpass refuses a cut-off longer than the scan ("a longer cut-off leaves no
    # period of the scan"); SampledSurface.lowpass took one and raised numpy's LinAlgError
    # (Singular matrix) at 1e9 m, from scipy's filter at a cut-off near zero. Now refused as the
    # scan's, naming shortest_period and the map's shorter side, which is taken.
    from haptex.surfaces import SampledSurface

    x, y = np.linspace(0.0, 2e-3, 201), np.linspace(0.0, 1e-3, 101)
    s = SampledSurface(x, y, 2e-5 * np.sin(2 * np.pi * x[:, None] / 1e-3) * np.cos(2 * np.pi * y[None, :] / 5e-4))
    assert np.isfinite(s.lowpass(1e-3).h).all() and np.isfinite(s.band_limited(1e-3).h).all()
    for bad in (1.01e-3, 1e9):
        for call in (s.lowpass, s.band_limited):
            with pytest.raises(hx.ParameterError, match=r"^shortest_period = ") as e:
                call(bad)
            assert "at most the map's shorter side, 0.001 m" in str(e.value)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf, "nonsense", None])
def test_a_scans_height_at_a_position_that_is_not_a_number_is_refused_by_name(value):
    # SampledProfile.height(x) at NaN raised "cannot convert float NaN to integer", at inf
    # OverflowError, at 'nonsense' numpy's ValueError: x is named now, as every position is.
    from haptex.textures import SampledProfile

    x = np.linspace(0.0, 2e-3, 201)
    prof = SampledProfile(x, 1e-5 * np.sin(2 * np.pi * x / 1e-3))
    for method in (prof.height, prof.slope, prof.curvature):
        with pytest.raises(hx.ParameterError, match=r"^x = "):
            method(value)
        with pytest.raises(hx.ParameterError, match=r"^x = "):
            method(np.array([1e-3, value], dtype=object) if isinstance(value, str) or value is None
                   else np.array([1e-3, value]))
    assert prof.height(np.array([0.25e-3, 0.5e-3])) == pytest.approx([1e-5, 0.0], abs=1e-9)  # (sin at pi / 2, pi)


_JUNK = {"nonsense": "nonsense", "list": [1, 2], "True": True, "None": None, "nan": math.nan, "inf": math.inf}


@pytest.mark.parametrize("field", ["acceleration", "speed", "normal_force", "sample_rate"])
@pytest.mark.parametrize("junk", sorted(_JUNK))
def test_a_recording_is_checked_when_it_is_made(field, junk):
    # A Recording holds n samples of acceleration (n,) or (n, 3), speed and normal force (n,),
    # finite, at a rate > 0 (its docstring): made with anything else it was kept, and failed
    # later (fit's refusal, or write's numpy error), or never (write wrote it). Now refused
    # naming the field, as fit refuses it.
    import haptex.datadriven as dd

    rng = np.random.default_rng(0)
    kw = {"acceleration": rng.normal(size=(2000, 3)), "speed": np.full(2000, 0.05), "normal_force": np.full(2000, 1.0),
          "sample_rate": 1e4}
    dd.Recording(**kw)
    kw[field] = [[1.0, 2.0]] if (field, junk) == ("acceleration", "list") else _JUNK[junk]  # ([1, 2]: two samples)
    with pytest.raises(hx.ParameterError, match=rf"^{field} = "):
        dd.Recording(**kw)


@pytest.mark.parametrize("field, junks", [("ar", ["nonsense", "list", "None"]), ("ma", ["nonsense", "None"]),
                                          ("variance", ["nonsense", "list", "True", "None", "nan", "inf"]),
                                          ("gain", ["nonsense", "list", "True", "None", "nan", "inf"]),
                                          ("speed", ["nonsense", "list", "True", "None", "inf"]),
                                          ("force", ["nonsense", "list", "True", "None", "inf"])])
def test_an_arma_models_fields_that_are_not_numbers_are_refused_by_name(field, junks):
    # ArmaModel's fields: polynomials, a variance >= 0, a finite gain, a rate > 0 and the
    # operating point's speed and force (finite, >= 0; NaN: not stated, the default). Text, a
    # list, a bool or None raised Python's ValueError or TypeError from float(); a negative or
    # infinite speed or force was kept. Now refused naming the field.
    import haptex.datadriven as dd

    ar = np.real(np.poly([0.9 * np.exp(0.3j), 0.9 * np.exp(-0.3j)]))
    kw = {"ar": ar, "ma": np.array([1.0]), "variance": 1.0, "gain": 1.0, "sample_rate": 1e4, "speed": 0.05,
          "force": 1.0}
    dd.ArmaModel(**kw)
    dd.ArmaModel(**{**kw, "speed": math.nan, "force": math.nan})  # (not stated)
    bad = dict(_JUNK, negative=-1.0)
    for junk in junks + (["negative"] if field in ("speed", "force", "variance") else []):
        with pytest.raises(hx.ParameterError, match=rf"^{field} = "):
            dd.ArmaModel(**{**kw, field: bad[junk]})


@pytest.mark.parametrize("pose", ["nonsense", [1.0, 1.0, 1.0, 1.0], [1e3, 1e3]])
@pytest.mark.parametrize("key", ["omega-3", "pantograph", "touch"])
def test_a_presets_pose_is_refused_by_the_name_it_is_given_by(key, pose):
    # Preset.device(pose=...) hands the pose to the device's constructor as its working_point
    # or joint_angles: refused, the message named those (which its user never wrote), and on
    # the pantograph a pose that is not numbers raised numpy's ValueError. Now `pose` is named.
    from haptex import catalogue

    with pytest.raises(hx.ParameterError, match=r"^pose = "):
        catalogue.preset(key).device(pose=pose)


def test_a_line_of_a_map_is_taken_within_its_rows_and_refused_beyond_them():
    # SampledSurface.line(y) beyond a bounded map's rows returned its tangent-plane extension
    # as if measured (and at 1e9 m refused the extrapolated heights, naming h[1]); a line is
    # the map's own now: y within its rows (both ends taken), refused naming y beyond them. A
    # periodic map's rows repeat: any y, as its period wraps it (the line at y + its cell's
    # side is the line at y).
    from haptex.surfaces import SampledSurface

    x = np.linspace(0.0, 2e-3, 41)
    h = 2e-5 * np.sin(2 * np.pi * x[:, None] / 1e-3) * np.cos(2 * np.pi * x[None, :] / 1e-3)
    s = SampledSurface(x, x, h)
    assert s.line(y=0.0).h == pytest.approx(h[:, 0], abs=1e-12)
    assert s.line(y=2e-3).h == pytest.approx(h[:, -1], abs=1e-12)
    for bad in (-1e-9, 2e-3 + 1e-9, -1.0, 1e9):
        with pytest.raises(hx.ParameterError, match=r"^y = ") as e:
            s.line(y=bad)
        assert "0 to 0.002 m" in str(e.value)
    p = SampledSurface(x[:-1], x[:-1], h[:-1, :-1], periodic=True)
    assert p.line(y=0.5e-3 + 2e-3).h == pytest.approx(p.line(y=0.5e-3).h, abs=1e-12)


@pytest.mark.parametrize("texture", ["sine:0.2mm,2mm", 3.5, None])
def test_an_object_algorithm_names_a_texture_that_is_not_one_and_its_letter_as_algorithm_does(texture):
    # object_algorithm(letter, texture, base, stiffness) raised Python's AttributeError ("'str'
    # object has no attribute 'dimension'") for a texture that is not one, and named a bad
    # letter `algorithm` where haptex.algorithm names it `letter`; now both as algorithm does.
    from haptex import objects

    sphere = objects.Sphere(0.0499746521309)  # (a whole number of the grating's 1 mm periods round it)
    with pytest.raises(hx.ParameterError, match=r"^texture = "):
        hx.object_algorithm("A", texture, sphere, 1e3)
    with pytest.raises(hx.ParameterError, match=r"^letter = "):
        hx.object_algorithm("Z", hx.Grating(1e-4, 1e-3), sphere, 1e3)


@pytest.mark.parametrize("make, name", [(lambda v: hx.Device.point_mass(mass=v), "mass"),
                                        (lambda v: hx.Device.point_mass(damping=v), "damping"),
                                        (lambda v: hx.operators.ScanningHand(v, 1.0, velocity=0.02), "stiffness"),
                                        (lambda v: hx.operators.ScanningHand(300.0, v, velocity=0.02), "damping")])
def test_a_mass_damping_or_stiffness_given_as_a_bool_is_refused(make, name):
    # A mass, damping or stiffness is a scalar (isotropic) or a matrix of numbers
    # (_validation.matrix2): True was taken as 1 kg, 1 N s/m or 1 N/m (numpy converts it), where
    # every scalar of haptex refuses a bool (_validation._real).
    with pytest.raises(hx.ParameterError, match=rf"^{name} = "):
        make(True)


def _threshold(frequency):
    from haptex.perception import detection_threshold

    return detection_threshold(frequency)


@pytest.mark.parametrize("make, name", [(lambda v: hx.Device.point_mass(mass=[[v, 0.0], [0.0, 1.0]]), "mass"),
                                        (lambda v: hx.Device.point_mass(damping=np.array([[2.0, 0.0], [0.0, v]],
                                                                                          dtype=object)), "damping"),
                                        (lambda v: _threshold([[100.0, v]]), "frequency"),
                                        (lambda v: _threshold(np.array([[100.0], [v]], dtype=object)), "frequency"),
                                        (lambda v: hx.Sinusoid(1e-4, 1e-3, phase=v), "phase")])
def test_a_bool_inside_a_matrix_or_an_array_of_numbers_is_refused(make, name):
    # A matrix's entry or an array's number given as a bool (Python's or numpy's): numpy takes
    # True for 1 (1 kg, 1 N s/m, 1 Hz) once it sits among numbers, where every scalar of haptex
    # refuses a bool (_validation._real); the top-level bool was refused, the bool inside a row
    # was not (matrix2 and perception's own check each looked at the outer value only), and a
    # scalar took numpy's bool (np.True_ is not Python's). Truth: that rule, one implementation
    # for arrays (_validation.numbers); an object array of numbers is numbers
    for flag in (True, np.True_):
        with pytest.raises(hx.ParameterError, match=rf"^{name} = "):
            make(flag)
    make(1.0)  # (the same value as a number: taken)


@pytest.mark.parametrize("make, name", [(lambda v: hx.Device.point_mass(mass=[[v, 0.0], [0.0, 1.0]]), "mass"),
                                        (lambda v: _threshold([100.0, v]), "frequency"),
                                        (lambda v: _threshold(np.array([50.0, v])), "frequency")])
def test_a_complex_number_among_numbers_is_refused_not_cut_to_its_real_part(make, name):
    # numpy's astype(float) keeps a complex number's real part (with a warning): perception's
    # check took 100 + 5j Hz as 100 Hz; a matrix, read through the same rule since, is held to it
    # too (it took 1 + 1j kg as 1 kg between the two commits). A number here is real
    # (_validation.numbers)
    with pytest.raises(hx.ParameterError, match=rf"^{name} = "):
        make(100.0 + 5j)
    make(100.0)


def _identify(time=None, position=None, force=None):
    # a logged run's arrays (a mass pushed by a sine, 2,000 samples at 1 kHz): the entry at
    # 0.5 s replaced (0.5 is its time, so that the number itself is taken); no delay searched
    # (1.1 s a call with the default search, 0.06 s without)
    t = np.arange(2000) * 1e-3
    f = np.sin(2 * np.pi * 5 * t)
    p = np.cumsum(np.cumsum(f)) * 1e-6
    arrays = [a.tolist() for a in (t, p, f)]
    for k, v in enumerate((time, position, force)):
        if v is not None:
            arrays[k][500] = v
    return hx.identify(time=arrays[0], position=arrays[1], force=arrays[2], max_delay=0)


def _fit(acceleration=None, speed=None, normal_force=None):
    # a recording's arrays (2,000 samples at 10 kHz): one entry replaced
    from haptex.datadriven import fit

    rng = np.random.default_rng(0)
    arrays = [rng.normal(size=2000).tolist(), [0.1] * 2000, [1.0] * 2000]
    for k, v in enumerate((acceleration, speed, normal_force)):
        if v is not None:
            arrays[k][100] = v
    return fit(*arrays, sample_rate=10_000.0)


def _dft321(acceleration):
    from haptex.datadriven import dft321

    return dft321(acceleration)


def _sampled_profile(v):
    h = [0.0] * 50
    h[7] = v
    return hx.SampledProfile(np.linspace(0.0, 1e-2, 50), h)


def _sampled_surface(v):
    h = np.zeros((8, 8), dtype=object)
    h[3, 4] = v
    return hx.SampledSurface(np.linspace(0.0, 1e-3, 8), np.linspace(0.0, 1e-3, 8), h.tolist())


_MAP = hx.SampledSurface(np.linspace(0.0, 1e-3, 8), np.linspace(0.0, 1e-3, 8), np.zeros((8, 8)))


@pytest.mark.parametrize("make, name", [
    (lambda v: hx.algorithm("A", hx.Sinusoid(1e-4, 1e-3), 2000.0).force([[v, -2e-4]]), "p"),
    (lambda v: hx.algorithm("B", hx.Sinusoid(1e-4, 1e-3), 2000.0).jacobian([[0.0, -2e-4], [v, -2e-4]]), "p"),
    (lambda v: hx.algorithm("A", _MAP, 2000.0).force([[1e-4, 2e-4, v]]), "p"),
    (lambda v: _MAP.height_at([[v, 2e-4]]), "xy"),
    (lambda v: hx.SumOfSinusoids([3e-4, v], [1e-3, 2.5e-4]), "amplitudes"),
    (lambda v: hx.SumOfSinusoids([3e-4, 1e-4], [1e-3, 2.5e-4], [0.0, v]), "phases"),
    (lambda v: hx.SumOfGratings([1e-4, 1e-4], [1e-3, v], [0.0, 1.0]), "periods"),
    (_sampled_profile, "h"),
    (_sampled_surface, "h"),
    (lambda v: hx.Renderer(hx.algorithm("A", hx.Sinusoid(1e-4, 1e-3), 2000.0)).step_many([[0.0, 1e-3], [v, 1e-3]]),
     "points"),
    (lambda v: _identify(time=v), "time"), (lambda v: _identify(position=v), "position"),
    (lambda v: _identify(force=v), "force"),
    (lambda v: _fit(acceleration=v), "acceleration"), (lambda v: _fit(speed=v), "speed"),
    (lambda v: _fit(normal_force=v), "normal_force"),
    (lambda v: _dft321([[v, 0.0, 0.0]] + [[0.0, 0.0, 0.0]] * 63), "acceleration")])
def test_positions_and_samples_holding_a_bool_text_or_a_complex_number_are_refused(make, name):
    # Positions (every field's force and Jacobian, a map's heights at points), a sum of
    # sinusoids' or gratings' parameters and a sampled profile's or map's heights went through
    # numpy's float cast, which takes True for 1 (1 m, 1 rad), parses text ("0.5"), keeps a
    # complex array's real part (with a warning) and raises a bare TypeError for a complex
    # number in a list: a position of True metres was felt. Truth:
    # haptex's rule for arrays of numbers (_validation.numbers; the scalars' since long), here
    # at every public array of lengths; the same value as a number is taken.
    for bad in (True, np.True_, 0.5 + 1j, "0.5"):
        with pytest.raises(hx.ParameterError, match=rf"^{name}\b"):
            make(bad)
    make(0.5)


def _arma():
    from haptex.datadriven import ArmaModel, ModelSet

    return ModelSet([ArmaModel([1.0, -0.5], [1.0], 1.0, 1.0, 10_000.0, 0.1, 1.0)])


def _mesh():
    import trimesh

    return trimesh.creation.icosphere(subdivisions=1, radius=0.05)


def _f_algorithm():
    return hx.algorithm("F", hx.Sinusoid(1e-4, 1e-3), 2000.0)


@pytest.mark.parametrize("make, name, good", [
    (lambda v: hx.Device.pantograph(working_point=[0.0, v]), "working_point", 0.15),
    (lambda v: hx.Device.delta(working_point=[0.0, v, -0.12]), "working_point", 0.0),
    (lambda v: __import__("haptex.devices", fromlist=["x"]).delta_kinematics(0.06, 0.02, 0.10, 0.13, [0.0, v, -0.12]),
     "working_point", 0.0),
    (lambda v: __import__("haptex.perception", fromlist=["x"]).dequantise([[0.0, 0.0], [v, 0.0]], 1e-5),
     "position", 0.5),
    (lambda v: __import__("haptex.limits", fromlist=["x"]).clean_stiffness(
        hx.algorithm("A", hx.Sinusoid(1e-4, 1e-3), 2000.0), hx.Device.point_mass(),
        hx.operators.ConstantForce([0.0, -1.0]), [1000.0], [100.0, v]), "stiffness", None),
    (lambda v: _f_algorithm().force([[0.0, -1e-4]], deflection=[v]), "deflection", 1e-5),
    (lambda v: _f_algorithm().modulation([0.0, v]), "x", 0.5),
    (lambda v: __import__("haptex.friction", fromlist=["x"]).step_plane([0.0, v], [1e-5, 0.0], 1e-4),
     "deflection", 1e-5),
    (lambda v: __import__("haptex.friction", fromlist=["x"]).step_plane([0.0, 0.0], [v, 0.0], 1e-4),
     "displacement", 1e-5),
    (lambda v: hx.objects.Mesh(_mesh(), uv=np.full((len(_mesh().vertices), 2), v, dtype=object)), "uv", None),
    (lambda v: hx.objects.Mesh(_mesh(), uv=_mesh().vertices[:, :2],
                               normals=np.full((len(_mesh().vertices), 3), v, dtype=object)), "normals", None),
    (lambda v: _arma().models[0].psd([10.0, v]), "frequency", 0.5),
    (lambda v: _arma().synthesize([0.1, v], [1.0, 1.0]), "speed", 0.5),
    (lambda v: _arma().synthesize([0.1, 0.1], [1.0, v]), "force", 0.5),
    (lambda v: __import__("haptex.datadriven", fromlist=["x"]).height_spectrum(_arma(), [1e3, v]),
     "wavenumber", 0.5),
    (lambda v: __import__("haptex.datadriven", fromlist=["x"]).spectral_difference([v] + [0.0] * 99, [0.0] * 100,
                                                                                     1000.0), "recorded", 0.5),
    (lambda v: __import__("haptex.proxy", fromlist=["x"]).GodObject(hx.Sinusoid(1e-4, 1e-3), 2000.0).step(
        [0.0, v]), "p", 0.5),
    (lambda v: __import__("haptex.proxy", fromlist=["x"]).loop_work(hx.Sinusoid(1e-4, 1e-3), 2000.0,
                                                                    [[0.0, 1e-3], [1e-3, v], [2e-3, 1e-3]]),
     "path", 1e-3),
    (lambda v: __import__("haptex.objects", fromlist=["x"]).object_algorithm(
        "F", hx.SumOfGratings.egg_crate(1e-4, 2e-3), hx.objects.Plane(), 2000.0).path_work(
        [[0.0, 0.0, -1e-4], [v, 0.0, -1e-4]]), "pts", 1e-3)])
def test_every_other_public_array_holding_a_bool_text_or_a_complex_number_is_refused(make, name, good):
    # The rest of the public arrays (devices' working points, dequantised positions, F's
    # deflection and modulation, the presliding step, a mesh's UV map and normals, an ARMA
    # model's frequencies, speeds and forces, a recording's signals, the god-object's probe and
    # paths): numpy's float cast took True for 1, parsed text and raised a bare TypeError for a
    # complex number in a list (17 of these 19). Truth: haptex's rule for arrays of numbers (_validation.numbers); the same
    # value as a number is taken where the call is light enough to make (good), and it is the
    # value the text and the complex number's real part spell
    for bad in (True, np.True_, complex(0.5 if good is None else good, 1.0), str(0.5 if good is None else good)):
        with pytest.raises(hx.ParameterError, match=rf"^{name}\b"):
            make(bad)
    if good is not None:
        make(good)


@pytest.mark.parametrize("make, start", [
    (lambda: hx.Device.point_mass(mass=np.array([[1.0, 0.0], [0.0, 1j]])), "mass = array([[1.+0.j, 0.+0.j], [0.+0.j"),
    (lambda: hx.Renderer(hx.algorithm("A", hx.Sinusoid(1e-4, 1e-3), 2000.0)).step_many(np.zeros((5, 2), dtype=complex)),
     "points = array([[0.+0.j, 0.+0.j], [0.+0.j")])
def test_an_array_refused_is_named_on_one_line(make, start):
    # numpy's repr of an array breaks its rows over lines: a complex mass matrix's error spanned
    # two (README, "Bad input": one line, naming the value); now its rows follow on one line
    with pytest.raises(hx.ParameterError) as err:
        make()
    assert str(err.value).startswith(start) and "\n" not in str(err.value)


def test_a_long_list_refused_is_named_by_its_first_items_in_bounded_work():
    # An error names the value it refuses: a list of a million positions holding a bool was
    # written out whole (its repr, 24 MB) and then cut to 60 characters, 3 s for one line.
    # Truth: the work counted as the items' own reprs made; the message shows the first ones
    from haptex._validation import fail

    class Item:
        made = 0

        def __repr__(self):
            Item.made += 1
            return "0.5"

    err = fail("p", [[Item(), Item()] for _ in range(50_000)], "positions")
    assert Item.made <= 16 and str(err).startswith("p = [[0.5, 0.5], [0.5, 0.5], ")


@pytest.mark.parametrize("field, value", [("link_proximal", 1e9), ("link_distal", 1e4), ("base", 1e300)])
def test_a_pantographs_link_past_a_kilometre_is_refused_by_name(field, value):
    # A link or base length past MAX_LENGTH (1 km: "far beyond any haptic workspace") was taken
    # and the pantograph then refused its working point as out of reach, naming working_point.
    with pytest.raises(hx.ParameterError, match=rf"^{field} = "):
        hx.Device.pantograph(**{field: value})


@pytest.mark.parametrize("period", [1.5, 1e300])
def test_a_devices_sampling_period_past_a_second_is_refused_as_the_analyses_refuse_it(period):
    # critical_stiffness takes a period > 0 and at most 1 s; a Device took 1e300 s, which every
    # analysis of it then refused. Now the Device refuses it, naming period; 1 s is taken.
    hx.Device.point_mass(period=1.0)
    with pytest.raises(hx.ParameterError, match=r"^period = "):
        hx.Device.point_mass(period=period)


@pytest.mark.parametrize("exclude", ["nonsense", [-1.0], [math.nan], [math.inf], [0.0], True, [50.0, True]])
def test_buzz_refuses_an_excluded_rate_that_is_not_a_rate(exclude):
    # buzz(position, period, exclude): the rates (Hz) the rendering is meant to have, whose
    # harmonics are not buzz. A rate that is not finite and > 0 was skipped silently (a typo'd
    # exclusion judged the texture's own vibration as buzz), text raised numpy's ValueError.
    from haptex.perception import buzz

    t = np.arange(400) * 1e-3
    p = np.column_stack([1e-3 * np.sin(2 * np.pi * 50 * t), np.zeros(400)])
    assert buzz(p, 1e-3, exclude=[50.0]).amplitude < buzz(p, 1e-3).amplitude  # (the 50 Hz excluded: the premise)
    assert buzz(p, 1e-3, exclude=None).amplitude == buzz(p, 1e-3).amplitude  # (None: none, as documented)
    with pytest.raises(hx.ParameterError, match=r"^exclude = "):
        buzz(p, 1e-3, exclude=exclude)


@pytest.mark.parametrize("value, name", [("nonsense", "position"), ([["a", "b"]] * 20, "position")])
def test_buzz_names_positions_that_are_not_numbers(value, name):
    from haptex.perception import buzz

    with pytest.raises(hx.ParameterError, match=rf"^{name} = "):
        buzz(value, 1e-3)


@pytest.mark.parametrize("frequency", ["nonsense", True, [100.0, None]])
def test_the_detection_threshold_names_a_frequency_that_is_not_one(frequency):
    # detection_threshold(frequency): finite frequencies > 0 (Hz); text raised numpy's
    # ValueError, True was taken as 1 Hz.
    from haptex.perception import detection_threshold

    with pytest.raises(hx.ParameterError, match=r"^frequency = "):
        detection_threshold(frequency)


@needs_data
@pytest.mark.parametrize("lowpass", ["1m", "0.1um"])
def test_a_low_pass_the_measured_file_refuses_is_named_as_the_user_typed_it(lowpass, capsys):
    # design --lowpass on a file: a cut-off past the scan's length (or below its Nyquist period)
    # was refused naming `shortest_period`, the parameter of SampledProfile.lowpass that the
    # command line's user never typed (and a test above pinned that name). Now as --lowpass,
    # one line, status 2.
    from haptex.cli import main

    from .conftest import DEKTAK

    assert main(["design", "--texture", str(DEKTAK), "--device", "omega-3", "--lowpass", lowpass, "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "lowpass" in err and "shortest_period" not in err, err
