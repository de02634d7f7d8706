"""Issue 17's fuzz suite, bounded in time (HAPTEX_HYPOTHESIS_EXAMPLES, default 40 examples
per property): the command line over generated bad arguments, the loaders over corrupted
files, the renderer over adversarial positions.

The properties are the library's promises (README, "Bounded worst case" and "Bad input"):
a bad argument is one line on stderr and exit status 2, never a traceback and never a
numpy warning on the terminal; a corrupt file is a ParameterError or a valid profile;
a servo tick never raises, never returns NaN or more than max_force, and its work is
bounded by the texture, not the position.
"""

import contextlib
import io
import math
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import haptex as hx
from haptex.cli import main

from .conftest import DEKTAK, needs_data
from .test_cli import unknown_options_named
from .test_realtime import NOISE, NOISE_TABLE, SINE, WORK_BOUND

# ---------------------------------------------------------------------------------------
# the command line
# ---------------------------------------------------------------------------------------

UNITS = ["", "m", "mm", "um", "nm", "N/m", "kN/m", "s", "ms", "kg", "N", "furlong", "parsec", "K", "%", "1/m",
         "m/s", "N*s/m", "µm", "Å"]


def _number_text():
    mantissa = st.one_of(st.integers(-999, 999).map(str), st.floats(allow_nan=True, allow_infinity=True).map(repr),
                         st.sampled_from(["nan", "inf", "-inf", "1e308", "1e-320", "0", "-0", "1_000", "0x10", "", "."]))
    exponent = st.one_of(st.just(""), st.integers(-330, 330).map(lambda e: f"e{e}"))
    return st.tuples(mantissa, exponent, st.sampled_from(["", " "]), st.sampled_from(UNITS)).map(lambda t: "".join(t))


values = st.one_of(_number_text(), st.text(max_size=12))

# options of `simulate thrust` whose valid values keep a 5 ms run cheap
SIMULATE_OPTIONS = ["--stiffness", "--amplitude", "--period", "--max-penetration", "--friction", "--presliding",
                    "--joint-damping", "--sampling-period", "--band-stiffness", "--anchor", "--algorithm",
                    "--delay", "--mass", "--damping"]
TABLE_OPTIONS = ["--stiffness", "--amplitude", "--period", "--max-penetration", "--friction", "--presliding"]


def run_main(args):
    """(exit status, stderr lines, numpy RuntimeWarnings) of the CLI run in this process."""
    err = io.StringIO()
    with warnings.catch_warnings(record=True) as caught, contextlib.redirect_stderr(err), \
            contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("always")
        status = main(args)  # an exception here is a traceback at the terminal: the test fails
    runtime = [w for w in caught if issubclass(w.category, RuntimeWarning)]
    return status, err.getvalue().strip().splitlines(), runtime


def check_cli(args):
    status, lines, runtime = run_main(args)
    assert status in (0, 2), (args, status, lines)
    if status == 2:
        assert len(lines) == 1 and lines[0].startswith("haptex: error: "), (args, lines)
        assert not unknown_options_named(args, lines[0]), (args, lines)
    assert not runtime, (args, [str(w.message) for w in runtime])


@given(st.lists(st.tuples(st.sampled_from(SIMULATE_OPTIONS), values), min_size=1, max_size=3))
def test_cli_simulate_with_generated_arguments(opts):
    args = ["simulate", "thrust", "--duration", "5ms", "--json"]
    for name, value in opts:
        args += [name, value]
    check_cli(args)


@settings(max_examples=20)  # a valid draw computes all of Table II (about a second)
@given(st.sampled_from(TABLE_OPTIONS), values)
def test_cli_table_with_generated_arguments(name, value):
    check_cli(["table", "--json", name, value])


@given(st.one_of(
    st.tuples(st.just("sine"), values, values).map(lambda t: f"{t[0]}:{t[1]},{t[2]}"),
    st.tuples(st.just("noise"), values, values, values, values, st.text(max_size=30))
    .map(lambda t: f"noise:{t[1]},{t[2]},{t[3]},{t[4]},{t[5]}"),
    st.text(max_size=20)))
def test_cli_design_texture_specs_that_cannot_be_read(spec):
    # a malformed specification or a path that does not exist: refused before any analysis
    # (a valid sine: draw would run the whole design, so valid-looking draws are skipped)
    args = ["design", "--texture", spec, "--stiffness", "0 N/m"]  # 0 N/m keeps valid textures from computing
    check_cli(args)


# ---------------------------------------------------------------------------------------
# the loaders
# ---------------------------------------------------------------------------------------

def _load(data: bytes, suffix: str, **kw):
    with tempfile.TemporaryDirectory() as d:
        p = Path(d) / f"fuzz{suffix}"
        p.write_bytes(data)
        try:
            prof = hx.SampledProfile.from_file(p, **kw)
        except hx.ParameterError as exc:
            assert "\n" not in str(exc)
            return None
    assert np.all(np.isfinite(prof.h)) and np.all(np.diff(prof.x) > 0)  # what loads is a valid profile
    assert np.all(np.abs(prof.h) <= hx._validation.MAX_LENGTH)
    return prof


edits = st.lists(st.tuples(st.sampled_from(["cut", "flip", "insert", "delete_line", "replace_line"]),
                           st.floats(0, 1), st.binary(min_size=1, max_size=12)), min_size=1, max_size=4)


def _corrupt(raw: bytes, ops) -> bytes:
    for op, where, junk in ops:
        i = int(where * len(raw))
        if op == "cut":
            raw = raw[:i]
        elif op == "flip":
            raw = raw[:i] + junk + raw[i + len(junk):]
        elif op == "insert":
            raw = raw[:i] + junk + raw[i:]
        else:
            lines = raw.split(b"\n")
            j = min(int(where * len(lines)), len(lines) - 1)
            lines[j:j + 1] = [] if op == "delete_line" else [junk]
            raw = b"\n".join(lines)
    return raw


@needs_data
@given(edits)
def test_a_corrupted_dektak_file_is_one_line_or_a_valid_profile(ops):
    # the real export's header and first 300 rows (enough for every parser branch)
    raw = b"\n".join(DEKTAK.read_bytes().split(b"\n")[:340])
    _load(_corrupt(raw, ops), ".csv")


@given(edits)
def test_a_corrupted_column_file_is_one_line_or_a_valid_profile(ops):
    raw = "\n".join(f"{i * 0.5:.1f},{math.sin(i / 3):.5f}" for i in range(60)).encode()
    _load(_corrupt(raw, ops), ".txt", x_unit="um", height_unit="um")


@given(edits)
def test_a_corrupted_mat_file_is_one_line_or_a_valid_profile(ops):
    from scipy.io import savemat

    buf = io.BytesIO()
    savemat(buf, {"h": np.sin(np.arange(60) / 3.0)})
    _load(_corrupt(buf.getvalue(), ops), ".mat", spacing="0.5um", height_unit="um")


mat_values = st.one_of(
    st.sampled_from(["int8", "uint16", "int32", "uint64", "float32", "float64", "complex128", "bool"]).flatmap(
        lambda dt: st.lists(st.integers(0, 100), min_size=0, max_size=12).map(lambda v: np.array(v).astype(dt))),
    st.text(max_size=8),
    st.just({"a": np.arange(5.0)}),
    st.just(np.array([np.arange(5.0), np.arange(3.0)], dtype=object)),
    st.just(np.ones((3, 4))),
)


@given(mat_values)
def test_any_matlab_variable_is_one_line_or_a_real_vector(value):
    from scipy.io import savemat

    buf = io.BytesIO()
    savemat(buf, {"h": value})
    prof = _load(buf.getvalue(), ".mat", spacing="1um", height_unit="um")
    if prof is not None:  # only real numeric vectors of 4 or more samples load, unchanged
        arr = np.asarray(value)
        # scipy's savemat stores a bool array as uint8 without MATLAB's logical flag
        assert arr.dtype.kind in "iufb" and arr.size >= 4
        assert np.allclose(prof.h, arr.astype(float).ravel() * 1e-6)


# ---------------------------------------------------------------------------------------
# the renderer
# ---------------------------------------------------------------------------------------

coordinate = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(-2e-3, 2e-3),
    st.floats(1e-320, 1e-300),
    st.sampled_from([0.0, -0.0, 5e-324, 1e-3, -0.8e-3, 0.25e-3, -1e3, 1e3]),
)
position = st.one_of(
    st.tuples(coordinate, coordinate),
    st.tuples(coordinate, coordinate).map(np.array),
    st.sampled_from(["12", b"12", None, 3.0, (1.0,), (1.0, 2.0, 3.0), {0: 1.0, 1: 2.0}, (1j, 0.0), (True, 0.0)]),
)

RENDERERS = {}


def renderer(letter, texture_name):
    key = (letter, texture_name)
    if key not in RENDERERS:
        tex = {"sine": SINE, "noise": NOISE}.get(texture_name) or hx.SampledProfile.from_file(DEKTAK).leveled()
        RENDERERS[key] = hx.Renderer(hx.algorithm(letter, None if letter == "W" else tex, 2000.0), max_force=5.0)
    return RENDERERS[key]


def _fuzz_cases():
    """(letter, texture) for every algorithm on the three textures. The noise texture's D and E
    share one cell table (3 s to build, cached on the texture): they run in .ci/run's long set,
    beside test_realtime's D and E on it (one worker, NOISE_TABLE: built once)."""
    for name in ("sine", "noise", "dektak"):
        for letter in "WABCDEFG":
            marks = [needs_data] if name == "dektak" else []
            if name == "noise" and letter in "DE":
                marks += [pytest.mark.long, pytest.mark.xdist_group(NOISE_TABLE)]
            yield pytest.param(letter, name, marks=marks, id=f"{letter}-{name}")


@pytest.mark.parametrize("letter, texture_name", list(_fuzz_cases()))
@settings(max_examples=15)
@given(st.lists(position, min_size=1, max_size=40))
def test_the_renderer_never_raises_never_nan_never_over_max_and_bounded_work(letter, texture_name, positions):
    r = renderer(letter, texture_name)
    for p in positions:
        fx, fz = r.step(p)
        assert math.isfinite(fx) and math.isfinite(fz)
        assert math.hypot(fx, fz) <= 5.0 * (1 + 1e-12)
        assert r.last_work <= WORK_BOUND
