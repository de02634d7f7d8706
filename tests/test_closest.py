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
