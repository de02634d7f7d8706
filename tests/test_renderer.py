"""haptex.Renderer: the servo-tick path against the vectorised force, F's state against
path work, and the safety rules (non-finite, huge or malformed positions; max force)."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import haptex as hx

from .conftest import A, K0, L

SINE = hx.Sinusoid(A, L)
MEMORYLESS = ["W", "A", "B", "C", "D", "E", "G"]


def make(letter, **kw):
    return hx.algorithm(letter, None if letter == "W" else SINE, K0, **kw)


@pytest.mark.parametrize("letter", MEMORYLESS)
def test_step_equals_the_vectorised_force(letter):
    alg = make(letter)
    r = hx.Renderer(alg)
    rng = np.random.default_rng(11)
    p = np.column_stack([rng.uniform(-1e-3, 2e-3, 500), rng.uniform(-1.9e-3, 1e-3, 500)])
    ref = alg.force(p)
    got = np.array([r.step(pi) for pi in p])
    # D and E: the warm-started Newton stops within ~1e-15 m of the cold one's closest
    # point (certified in the cell table's Newton), i.e. kappa_0 * 1e-15 m of force per
    # coordinate, to which the cold search's own 1e-15 m adds; the others are the same arithmetic
    atol = K0 * 1e-14 if letter in "DE" else 1e-12
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=atol)
    # a plain tuple or list works as well as an array
    assert r.step((float(p[0, 0]), float(p[0, 1]))) == pytest.approx(tuple(ref[0]), rel=1e-12, abs=max(atol, 1e-12))


def test_D_warm_start_follows_a_trajectory_exactly():
    # consecutive positions of a scan: the warm-started search returns the same closest
    # points as the cold vectorised search (the global minimum is still certified)
    alg = make("D")
    r = hx.Renderer(alg)
    x = np.linspace(0, 3e-3, 3001)
    p = np.column_stack([x, SINE.height(x) - 0.4e-3 + 0.2e-3 * np.sin(40 * x / L)])
    got = np.array([r.step(pi) for pi in p])
    np.testing.assert_allclose(got, alg.force(p), rtol=1e-10, atol=K0 * 1e-14)


def test_F_renderer_energy_matches_path_work():
    # The passivity observer's -sum f . dp along a finely sampled path equals minus the
    # path work of F (which steps the same friction state) up to the sampling error of
    # the left Riemann sum, at most (sup|J| + kappa_0) * ds * length.
    alg = make("F", max_penetration=1e-3)
    path = np.array([[0.0, 1e-3], [0.0, -0.5e-3], [2.5e-3, -0.7e-3], [1.0e-3, -0.3e-3], [1.8e-3, -0.9e-3],
                     [1.8e-3, 1e-3]])
    seg = np.hypot(*np.diff(path, axis=0).T)
    pts = [path[0]]
    for a, b, s in zip(path[:-1], path[1:], seg):
        n = int(math.ceil(s / 1e-8))
        pts.extend(a + (b - a) * (np.arange(1, n + 1) / n)[:, None])
    r = hx.Renderer(alg, energy_monitor=True)
    for pt in pts:
        r.step(pt)
    ref = -hx.path_work(alg, path)
    assert r.energy == pytest.approx(ref, abs=10 * K0 * 1e-8 * seg.sum())
    assert r.adhesion is None  # left the wall at the end: state reset


def test_A_monitor_sees_the_loop_energy():
    # Fig. 3's loop for A: the texture supplies kappa_0 A^2 / 2, so the observer goes negative
    alg = make("A")
    path, expected, _ = hx.paper_loop(alg)
    r = hx.Renderer(alg, energy_monitor=True)
    for a, b in zip(path[:-1], path[1:]):
        for u in np.linspace(0, 1, 20001)[:-1]:
            r.step(a + u * (b - a))
    r.step(path[-1])
    assert r.energy == pytest.approx(-expected, rel=1e-3)


@pytest.mark.parametrize("letter", MEMORYLESS + ["F"])
@given(x=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.just(1e300), st.just(-1e300)),
       z=st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.floats(-2e-3, 1e-3)))
def test_never_raises_never_nonfinite_never_above_max_force(letter, x, z):
    r = hx.Renderer(make(letter), max_force=3.0)
    f = r.step([x, z])
    assert len(f) == 2 and all(math.isfinite(v) for v in f)
    assert math.hypot(*f) <= 3.0 * (1 + 1e-12)
    bad = not (math.isfinite(x) and math.isfinite(z)) or abs(x) > 1e3 or abs(z) > 1e3
    assert r.faults == (1 if bad else 0)
    if bad:
        assert f == (0.0, 0.0)


@pytest.mark.parametrize("p", [None, "ab", [1.0], [], [1.0, "x"], object(), {"x": 1}])
def test_malformed_positions_are_faults(p):
    r = hx.Renderer(make("A"))
    assert r.step(p) == (0.0, 0.0)
    assert r.faults == 1


def test_max_force_clamps_and_counts():
    r = hx.Renderer(make("W"), max_force=1.0)
    f = r.step([0.0, -2e-3])  # 4 N requested
    assert f == pytest.approx((0.0, 1.0))
    assert r.clamps == 1
    r.reset()
    assert r.clamps == 0 and r.faults == 0


def test_bad_construction():
    with pytest.raises(hx.ParameterError, match=r"^max_force = 0 "):
        hx.Renderer(make("A"), max_force=0)
    with pytest.raises(hx.ParameterError, match=r"^algorithm = "):
        hx.Renderer("A")


def test_a_numpy_row_is_the_tuple_and_anything_else_the_checked_path():
    """Issue 56: ``step`` reads a float64 row of the right length through the buffer protocol
    (contiguous, strided or read-only) exactly as a tuple of the same floats, and hands any
    other array (another dtype, shape or length) to the checked path, which answers as it did
    before: the same force, and a fault counted where the position is refused."""
    alg = make("A")
    fast, checked = hx.Renderer(alg, max_force=5.0), hx.Renderer(alg, max_force=5.0)
    rng = np.random.default_rng(5)
    grid = np.column_stack([rng.uniform(-1e-3, 2e-3, 200), np.zeros(200), rng.uniform(-1.9e-3, 1e-3, 200)])
    ro = grid[:, [0, 2]].copy()
    ro.flags.writeable = False
    for i in range(len(grid)):
        want = fast.step((float(grid[i, 0]), float(grid[i, 2])))
        assert fast.step(grid[i, ::2]) == want  # a strided view
        assert fast.step(ro[i]) == want  # read-only
        assert fast.step(np.ascontiguousarray(ro[i])) == want
    others = [np.array([1e-4, -2e-4], dtype=np.float32), np.array([0, 0]), np.array([True, False]),
              np.array([1e-4 + 0j, -2e-4]), np.array([[1e-4, -2e-4]]), np.array([1e-4, -2e-4, 0.0]),
              np.array([np.nan, 0.0]), np.array([2e3, 0.0]), np.array([1e-4, -2e-4]).astype(">f8")]
    for p in others:
        assert fast.step(p) == checked._step_checked(p)
    assert fast.faults == checked.faults >= 5  # complex, bool, 2-D, the wrong length, NaN, 2 km


def test_a_batch_of_positions_is_the_same_ticks_in_order():
    """Issue 56: step_many runs the rows through the C tick in order, state carried (F's
    friction is path dependent), exactly as step on each row; faulty rows give zero force and
    count; a wrong shape is one line."""
    alg = make("F")
    one, many = hx.Renderer(alg, max_force=5.0), hx.Renderer(alg, max_force=5.0)
    x = np.linspace(0, 3e-3, 500)
    p = np.column_stack([x, SINE.height(x) - 0.3e-3 + 0.1e-3 * np.sin(30 * x / L)])
    p[100] = [np.nan, 0.0]
    want = np.array([one.step(row) for row in p])
    got = many.step_many(p)
    assert np.array_equal(got, want) and many.faults == one.faults == 1
    assert np.array_equal(many.step_many(np.empty((0, 2))), np.empty((0, 2)))
    with pytest.raises(hx.ParameterError, match=r"points = 'shape \(3, 3\)"):
        many.step_many(np.zeros((3, 3)))
