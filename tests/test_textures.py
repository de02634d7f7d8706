"""Textures: closed forms of the sinusoid, the sums' Lipschitz bound (Remark 2), the
compiled evaluation against NumPy, and bad input."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import haptex as hx
from haptex import core

from .conftest import A, L, textures


def test_sinusoid_height_slope_curvature_closed_forms():
    # h = A sin(2 pi x / l + phase) and its derivatives, by hand.
    tex = hx.Sinusoid(A, L, phase=0.3)
    x = np.linspace(-2e-3, 3e-3, 101)
    w = 2 * np.pi / L
    np.testing.assert_allclose(tex.height(x), A * np.sin(w * x + 0.3), rtol=0, atol=1e-18)
    np.testing.assert_allclose(tex.slope(x), A * w * np.cos(w * x + 0.3), rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(tex.curvature(x), -A * w * w * np.sin(w * x + 0.3), rtol=1e-12, atol=1e-9)


def test_sinusoid_max_slope_is_two_pi_a_over_l():
    # Remark 2 / eq. 10: M = 2 pi A / l; at the paper's parameters 5.0265.
    tex = hx.Sinusoid(A, L)
    assert tex.max_slope == pytest.approx(2 * math.pi * A / L, rel=1e-15)
    assert tex.max_slope == pytest.approx(5.0265, abs=1e-4)
    assert tex.max_curvature == pytest.approx(4 * math.pi**2 * A / L**2, rel=1e-15)


def test_sum_of_sinusoids_max_slope_is_the_true_sup():
    # h = a1 sin(2 pi x/l) + a2 sin(4 pi x/l): sup |h'| by a 10^6-point dense search.
    tex = hx.SumOfSinusoids([0.3e-3, 0.2e-3], [1e-3, 0.5e-3], [0.0, 1.0])
    assert tex.period == pytest.approx(1e-3, rel=1e-12)
    x = np.linspace(0, 1e-3, 1_000_001)
    dense = np.abs(tex.slope(x)).max()
    assert tex.max_slope_is_exact
    assert tex.max_slope == pytest.approx(dense, rel=1e-9)
    # and strictly below the triangle-inequality bound
    assert tex.max_slope < 2 * math.pi * (0.3e-3 / 1e-3 + 0.2e-3 / 0.5e-3)


def test_incommensurate_periods_give_the_triangle_bound():
    tex = hx.SumOfSinusoids([1e-4, 1e-4], [1e-3, math.sqrt(2) * 1e-3])
    assert tex.period is None
    assert not tex.max_slope_is_exact
    assert tex.max_slope == pytest.approx(2 * math.pi * 1e-4 * (1 / 1e-3 + 1 / (math.sqrt(2) * 1e-3)), rel=1e-12)


@pytest.mark.parametrize("periodic", [False, True])
def test_a_sampled_profile_is_scipys_cubic_spline_and_straight_beyond_its_ends(periodic):
    # A sampled profile is the cubic spline through its samples (scipy's CubicSpline: not-a-knot,
    # or periodic over its period), beyond its ends on an open profile the straight lines by its
    # end heights and slopes (h'' = 0 there); one position at a time as in an array, inside, on
    # the ends and beyond both. Truth: scipy.interpolate.CubicSpline on the same samples
    from scipy.interpolate import CubicSpline

    rng = np.random.default_rng(3)
    x = np.linspace(0.0, 1e-3, 41)
    h = 1e-6 * np.sin(7e3 * x) + 1e-7 * rng.standard_normal(x.size)
    tex = hx.SampledProfile(x, h, periodic=periodic)
    if periodic:
        dx = x[1] - x[0]
        ref = CubicSpline(np.r_[x, x[-1] + dx], np.r_[h, h[0]], bc_type="periodic")
        period = x[-1] + dx - x[0]
    else:
        ref = CubicSpline(x, h, bc_type="not-a-knot")
    xs = np.r_[rng.uniform(-0.4e-3, 1.4e-3, 200), x[0], x[-1], x[17], -1e-9, 1e-3 + 1e-9]
    for order, fun in enumerate((tex.height, tex.slope, tex.curvature)):
        if periodic:
            want = ref(x[0] + np.mod(xs - x[0], period), order)
        else:
            inside = np.clip(xs, x[0], x[-1])
            d = xs - inside  # (beyond an end: the straight line by its height and slope)
            want = ref(inside, order) + (ref(inside, 1) * d if order == 0 else 0.0)
            want = np.where((d != 0) & (order == 2), 0.0, want)
        scale = [1e-6, 1e-2, 1e2][order]  # (the profile's height, slope and curvature sizes)
        got = fun(xs)
        np.testing.assert_allclose(got, want, rtol=1e-9, atol=1e-9 * scale)
        one = np.array([fun(v) for v in xs])  # (a position at a time: the same numbers, to the bit)
        assert np.array_equal(one, got)
        assert np.shape(fun(xs[0])) == () and fun(xs[:204].reshape(6, -1)).shape == (6, 34)


@given(textures(), st.lists(st.floats(-5e-3, 5e-3), min_size=1, max_size=20))
def test_compiled_texture_matches_numpy(tex, xs):
    for x in xs:
        h, s, _, c, _, _ = core.texture_derivatives(tex, [x, 0.0])
        assert h == pytest.approx(float(tex.height(np.array([x]))[0]), rel=1e-12, abs=1e-18)
        assert s == pytest.approx(float(tex.slope(np.array([x]))[0]), rel=1e-12, abs=1e-14)
        assert c == pytest.approx(float(tex.curvature(np.array([x]))[0]), rel=1e-12, abs=1e-9)


@given(textures())
def test_slope_and_curvature_are_derivatives(tex):
    # central differences of h and h' (reference: calculus), step 1e-4 of the shortest period
    x = np.linspace(0, 3e-3, 37)
    e = tex.shortest_period * 1e-4
    fd_s = (tex.height(x + e) - tex.height(x - e)) / (2 * e)
    fd_c = (tex.slope(x + e) - tex.slope(x - e)) / (2 * e)
    np.testing.assert_allclose(tex.slope(x), fd_s, rtol=0, atol=1e-6 * (1 + tex.max_slope))
    np.testing.assert_allclose(tex.curvature(x), fd_c, rtol=0, atol=1e-6 * tex.max_curvature + 1e-9)


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(amplitude=-1e-3, period=1e-3), "amplitude"),
        (dict(amplitude=1e-3, period=0.0), "period"),
        (dict(amplitude=1e-3, period=-1e-3), "period"),
        (dict(amplitude=float("nan"), period=1e-3), "amplitude"),
        (dict(amplitude=1e-3, period=float("inf")), "period"),
        (dict(amplitude=1e-3, period=1e-3, phase=float("nan")), "phase"),
    ],
)
def test_sinusoid_bad_input_names_the_parameter(kwargs, name):
    with pytest.raises(hx.ParameterError, match=rf"^{name} = "):
        hx.Sinusoid(**kwargs)


def test_sum_bad_input():
    with pytest.raises(hx.ParameterError, match="same length"):
        hx.SumOfSinusoids([1e-4, 1e-4], [1e-3])
    with pytest.raises(hx.ParameterError, match=r"amplitudes\[1\]"):
        hx.SumOfSinusoids([1e-4, -1e-4], [1e-3, 2e-3])
    with pytest.raises(hx.ParameterError, match="periods"):
        hx.SumOfSinusoids([1e-4], [np.nan])
    with pytest.raises(ValueError):  # ParameterError is a ValueError
        hx.SumOfSinusoids([], [])
