"""Closest point on z = h(x) (algorithms D and E) against a brute-force dense search."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.optimize import minimize_scalar

import haptex as hx

from .conftest import A, L, textures


def brute_force_distance(tex, px, pz, n=200_001):
    """Reference: dense search of |p - (t, h(t))| over [px - dv, px + dv] (dv the vertical
    depth bounds the minimum distance), then bounded refinement around the best sample."""
    dv = float(tex.height(np.array([px]))[0]) - pz
    t = np.linspace(px - dv, px + dv, n)
    d2 = (t - px) ** 2 + (tex.height(t) - pz) ** 2
    i = int(np.argmin(d2))
    dt = t[1] - t[0]
    r = minimize_scalar(lambda u: (u - px) ** 2 + (float(tex.height(np.array([u]))[0]) - pz) ** 2,
                        bounds=(t[i] - dt, t[i] + dt), method="bounded", options={"xatol": 1e-15})
    return math.sqrt(min(float(r.fun), float(d2[i])))


def test_random_inside_points_agree_with_brute_force_to_1e_9_m():
    tex = hx.Sinusoid(A, L)
    rng = np.random.default_rng(1)
    x = rng.uniform(0, L, 60)
    depth = rng.uniform(1e-6, 1.5e-3, 60)
    p = np.column_stack([x, tex.height(x) - depth])
    cp = hx.closest_point(tex, p)
    for (px, pz), d in zip(p, cp.distance):
        assert abs(d - brute_force_distance(tex, px, pz)) < 1e-9


def test_deep_points_below_a_peak_where_two_closest_points_compete():
    # Below the peak at x = l/4, deeper than the radius of curvature l^2/(4 pi^2 A) = 32 um,
    # the two flanks are equally close (Remark 6); slightly off-axis one of them wins.
    tex = hx.Sinusoid(A, L)
    for dx in (0.0, 1e-9, -1e-9, 1e-6, -3e-6):
        for depth in (0.05e-3, 0.3e-3, 0.9e-3, 1.6e-3):
            px, pz = L / 4 + dx, A - depth
            d = hx.closest_point(tex, [[px, pz]]).distance[0]
            assert abs(d - brute_force_distance(tex, px, pz)) < 1e-9
    on_axis = hx.closest_point(tex, [[L / 4, A - 0.5e-3]])
    assert on_axis.tie[0]
    assert not hx.closest_point(tex, [[L / 4, A - 10e-6]]).tie[0]  # above the centre of curvature


def test_on_a_felt_profile_refined_for_its_curvature_the_closest_point_is_the_brute_forces():
    # A felt profile refined for its curvature (issue 67) carries its first grid's band on up to
    # 2^12 times its samples, cubic pieces whose second derivatives jump at their nodes and kinks
    # where the ball bridges a trough; the search groups its intervals into leaves of up to half
    # that band's shortest period, scanned at every node. Reference: the dense search above on the
    # profile's own heights (the two-tone profile, 0.1 mm at 2 mm and 30 um at 0.5 mm, under a ball
    # twice its troughs' radius: 32,768 samples, 4 kinks), 60 probes to 1.2 mm deep
    tex = hx.SumOfSinusoids([0.1e-3, 0.03e-3], [2e-3, 0.5e-3], [0.0, 1.0])
    xs = np.linspace(0, 2e-3, 40001)
    felt = tex.felt_by(2.0 / float(np.max(np.abs(np.gradient(tex.slope(xs), xs)))))
    assert felt.x.size >= 8 * 2e-3 / felt.shortest_period and len(felt.kinks) > 0  # (leaves of several intervals)
    rng = np.random.default_rng(3)
    x = np.concatenate([rng.uniform(0, 2e-3, 56), felt.kinks[:, 0]])
    p = np.column_stack([x, felt.height(x) - rng.uniform(1e-6, 1.2e-3, x.size)])
    cp = hx.closest_point(felt, p)
    for (px, pz), d in zip(p, cp.distance):
        assert abs(d - brute_force_distance(felt, px, pz)) < 1e-9


def test_near_its_troughs_radius_a_felt_profiles_closest_point_is_the_brute_forces_in_bounded_work():
    # The sinusoid (0.2 mm at 2 mm) felt by a ball of 0.99 times its troughs' radius is refined
    # to 262,144 samples (the path's curvature a spike 0.5 um wide), its leaves 1,024 intervals
    # of its first grid's band: each surviving leaf was scanned at every node, 16,139 texture
    # evaluations a probe on average over D's q grid (96,690 at most), and q of D on such a
    # profile (the 0.1 mm sinusoid, test_probe.py) took 620 s (2026-11-28). A leaf on which the squared distance is certified convex for the probe
    # (phi'' / 2 = 1 + h'^2 + (h - p^z) h'' > 0 from its bounds of h and h'') holds at most one
    # minimum, found by Newton from its ends. Reference: the dense search above on the profile's
    # own heights, 48 probes to 1.2 mm deep (8 of them below the crest, about its centre of
    # curvature, 1.008 mm deep, where the leaves are not certified)
    rho = 2e-3**2 / (4 * math.pi**2 * 0.2e-3)
    felt = hx.Sinusoid(0.2e-3, 2e-3).felt_by(0.99 * rho)
    assert felt.x.size >= 2**18  # (the refined profile the statement is for)
    rng = np.random.default_rng(5)
    x = np.concatenate([rng.uniform(0, 2e-3, 40), 0.5e-3 + rng.uniform(-2e-6, 2e-6, 8)])
    depth = np.concatenate([rng.uniform(1e-6, 1.2e-3, 40), rng.uniform(0.9e-3, 1.1e-3, 8)])
    p = np.column_stack([x, felt.height(x) - depth])
    cp = hx.closest_point(felt, p)
    for (px, pz), d in zip(p, cp.distance):
        assert abs(d - brute_force_distance(felt, px, pz)) < 1e-9
    assert np.mean(cp.work) <= 1000  # (a bound on counted work: 22,870 on these probes before, 634 now)


@given(textures(), st.floats(0, 1), st.floats(1e-6, 1.2e-3))
def test_any_texture_agrees_with_brute_force(tex, u, depth):
    px = u * 2e-3
    pz = float(tex.height(np.array([px]))[0]) - depth
    cp = hx.closest_point(tex, [[px, pz]])
    assert abs(cp.distance[0] - brute_force_distance(tex, px, pz)) < 1e-9
    # the returned point is on the boundary and at the returned distance
    assert cp.z[0] == pytest.approx(float(tex.height(cp.x)[0]), abs=1e-18)
    assert math.hypot(px - cp.x[0], pz - cp.z[0]) == pytest.approx(cp.distance[0], rel=1e-12)


def test_points_outside_have_zero_distance():
    tex = hx.Sinusoid(A, L)
    cp = hx.closest_point(tex, [[0.0, 1e-6], [L / 4, A + 1e-3]])
    np.testing.assert_array_equal(cp.distance, [0.0, 0.0])


def test_bad_positions():
    tex = hx.Sinusoid(A, L)
    with pytest.raises(hx.ParameterError, match=r"shape \(3,\)"):
        hx.closest_point(tex, [0.0, 1.0, 2.0])
    with pytest.raises(hx.ParameterError, match="non-finite"):
        hx.closest_point(tex, [[np.nan, 0.0]])


def _periodic_spline():
    """A periodic sampled profile: two harmonics and a fixed noise, 256 samples over 2 mm."""
    x = np.arange(256) * (2e-3 / 256)
    noise = np.random.default_rng(2).standard_normal(256)
    h = 0.2e-3 * np.sin(2 * np.pi * x / 1e-3) + 0.05e-3 * np.cos(3 * np.pi * x / 1e-3 + 0.3) + 0.02e-3 * noise
    return hx.SampledProfile(x, h, periodic=True)


# the sinusoid and the measured-like spline in the contributor's loop, the sum in .ci/run's long set (1 s)
@pytest.mark.parametrize("name", ["sine", pytest.param("sum", marks=pytest.mark.long), "spline"])
def test_the_cell_table_finds_the_trees_closest_point(name):
    # The renderer's cell table (haptex.closest.table_search_data) must give the global closest
    # point that the bound tree gives (itself checked against brute force above), on probes
    # spread over the whole table (one cell is 1/64 of the shortest period) and beyond it;
    # cold starts, as the vectorised search runs them
    from haptex import core
    from haptex.closest import search_data, table_search_data
    from haptex.core import _ext as K

    tex = {"sine": hx.Sinusoid(A, L), "sum": hx.SumOfSinusoids([0.3e-3, 0.1e-3], [1e-3, 0.25e-3], [0.0, 1.0]),
           "spline": _periodic_spline()}[name]
    tree, table = search_data(tex), table_search_data(tex)
    o = int(table[K.A_TABLE])
    assert o == tree.size and tree[K.A_TABLE] == 0.0  # the table is appended to the tree's data
    assert np.array_equal(np.delete(table[:o], K.A_TABLE), np.delete(tree, K.A_TABLE))
    z0, z1 = table[o + K.TB_Z0], tex.height_range[1]
    rng = np.random.default_rng(7)
    n = 40_000
    px = rng.uniform(-3e-3, 3e-3, n)
    pz = np.concatenate([rng.uniform(z0, z1, n - 2000), rng.uniform(z0 - 2e-3, z0, 2000)])  # 5 % below it
    kind, coeffs = tex.kernel_data()
    res = []
    for aux in (tree, table):
        res.append(core.closest_profile_points(kind, coeffs, aux, px, pz))
    (t0, d0, tie0, w0), (t1, d1, tie1, w1) = res
    np.testing.assert_array_equal(tie1, tie0)
    # both are certified within about 1e-15 m of the true closest point
    assert np.all(np.abs(d1 - d0) <= 1e-12 * d0 + 1e-18)
    assert np.all((np.abs(t1 - t0) <= 3e-15) | (tie0 != 0))
    below = d0 > 0
    assert below.sum() > n / 2
    # and it does so with less work: a Newton solve on one or two certified pieces instead
    # of a branch and bound (medians measured: 5 against 19, 5 against 32, 17 against 81)
    assert np.median(w1[below]) <= np.median(w0[below]) / 3


def test_a_renderer_ticking_along_a_scan_reads_the_table_in_a_few_evaluations():
    # D over the paper's sinusoid (the renderer benchmark's stroke: 10 mm/s, 10 kHz, 0.4 mm
    # deep): the vertical depth, then Newton from the extrapolated last closest point,
    # accepted once its error is certified below 1e-15 m: 1 + 1..3 evaluations a tick off the
    # medial axis; near it, two pieces are searched (at most 9 evaluations here)
    tex = hx.Sinusoid(A, L)
    alg = hx.algorithm("D", tex, 2000.0)
    r = hx.Renderer(alg)
    assert r.search_table and not hx.Renderer(hx.algorithm("D", hx.SumOfGratings.egg_crate(A, L), 2000.0)).search_table
    x = np.arange(20_000) * 1e-6
    z = tex.height(x) - 0.4e-3
    work = []
    for p in zip(x.tolist(), z.tolist()):
        r.step(p)
        work.append(r.last_work)
    work = np.array(work)
    assert np.median(work) <= 4 and np.mean(work <= 4) > 0.9 and work.max() <= 9  # measured: 3, 94 %, 9
    np.testing.assert_allclose(np.array([r.step(p) for p in zip(x[:200].tolist(), z[:200].tolist())]),
                               alg.force(np.column_stack([x[:200], z[:200]])), rtol=1e-10, atol=2000.0 * 1e-14)


def test_a_surfaces_closest_points_for_a_large_grid_are_kept_and_read_back_unchanged():
    """D and E search the same grids of probes (q, continuity): the second search of the same
    >= CACHE_MIN_PROBES probes reads the first's answer (the same arrays, bit for bit), and a
    caller writing into what it got does not change what the next one reads."""
    from haptex import closest as C

    tex = hx.SumOfGratings.egg_crate(0.1e-3, 2e-3)
    rng = np.random.default_rng(5)
    p = np.column_stack([rng.uniform(0, 4e-3, C.CACHE_MIN_PROBES), rng.uniform(0, 4e-3, C.CACHE_MIN_PROBES),
                         rng.uniform(-1e-3, 0, C.CACHE_MIN_PROBES)])
    first = C.closest_point(tex, p)
    calls = []
    real = C._core.closest_surface_points
    C._core.closest_surface_points = lambda *a: calls.append(1) or real(*a)
    try:
        first.x[:] = np.nan  # a caller's own copy
        again = C.closest_point(tex, p)
        other = C.closest_point(tex, p + [0, 0, -1e-4])  # other probes: searched
    finally:
        C._core.closest_surface_points = real
    assert len(calls) == 1 and np.all(np.isfinite(again.x))
    fresh = C.closest_point(hx.SumOfGratings.egg_crate(0.1e-3, 2e-3), p)
    for name in ("x", "y", "z", "distance", "tie", "work"):
        np.testing.assert_array_equal(getattr(again, name), getattr(fresh, name))
    assert not np.array_equal(other.distance, again.distance)
