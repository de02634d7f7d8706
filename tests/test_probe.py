"""haptex.probe: the texture a ball of radius r feels (the map dilated by the ball, minus r).

References: the ball's centre path c(x) = max_|u|<=r [h(x + u) + sqrt(r^2 - u^2)] (grey-scale
dilation by a non-flat ball: Serra 1982; Villarrubia, J. Res. NIST 102(4), 1997), checked
against its definition by dense sampling of u; below the troughs' radius of curvature
l^2 / (4 pi^2 A) the ball touches everywhere and the felt profile is the offset curve
(x - r h' / sqrt(1 + h'^2), h + r / sqrt(1 + h'^2) - r); far above it the ball rests on the
crests only and the felt slope is at most (l/2) / sqrt(r^2 - l^2/4), so that q_A =
sqrt(1 + M^2) (Section IV-A) follows that closed form.
"""

import math
from functools import partial

import numpy as np
import pytest
from scipy.optimize import minimize

import haptex as hx
from haptex import ParameterError
from haptex.analysis.characteristic import characteristic_points

from .conftest import DEKTAK, needs_data

A, L = 0.1e-3, 2e-3  # a sinusoid whose troughs have a 1.01 mm radius of curvature
SINE = hx.Sinusoid(A, L)


def _by_hand(*values):
    """A denser point of a neighbourhood whose ends and hardest point .ci/run's long set runs:
    marked ``slow`` (run by hand, ``python -m pytest -q -n 2 -m slow``, at each stop), so that
    .ci/run keeps nearer its 600 s (these 56 cases were about 410 s of its long set's test time)."""
    return pytest.param(*values, marks=pytest.mark.slow)


def _centre_path(tex, x, r, n=400_001):
    u = np.linspace(-r, r, n)
    return np.array([np.max(tex.height(xi + u) + np.sqrt(np.maximum(r * r - u * u, 0.0))) - r for xi in x])


@pytest.mark.parametrize("periodic", [True, False])
@pytest.mark.parametrize("shape, steps, r", [((40, 33), (1e-6, 1.3e-6), 4.1e-6), ((257,), (1e-6,), 9.5e-6),
                                             ((64, 64), (1e-6, 1e-6), 1e-6)])
def test_the_grid_dilation_is_scipys_grey_dilation_by_the_balls_cap(shape, steps, r, periodic):
    # Every felt texture starts from each sample's best grid offset under the ball
    # (probe._grid_contacts): max over the offsets u in the disc of h(p + u) + sqrt(r^2 - |u|^2).
    # Truth: scipy.ndimage.grey_dilation with the disc as footprint and the cap as a non-flat
    # structuring element (Serra's grey-scale dilation), wrapped on a periodic grid, the edge
    # samples repeated beyond a bounded one ('nearest'); the cap written here from the grid
    # (its rounding a few ulps from the one haptex computes). The offsets it names reach that
    # maximum. On a random map, a random profile and a ball of one grid step.
    from scipy import ndimage

    from haptex.probe import _grid_contacts

    h = np.random.default_rng(2).normal(0.0, 1e-6, shape)
    best, offsets = _grid_contacts(h, steps, r, periodic)
    axes = np.meshgrid(*(np.arange(-int(r // d), int(r // d) + 1) * d for d in steps), indexing="ij")
    left = r * r - sum(a * a for a in axes)
    cap = np.sqrt(np.maximum(left, 0.0))
    truth = ndimage.grey_dilation(h, footprint=left >= 0, structure=cap, mode="wrap" if periodic else "nearest")
    ulps = 8 * np.spacing(np.max(np.abs(truth)))
    assert np.max(np.abs(best - truth)) <= ulps
    idx = np.indices(shape)
    at = tuple((i + k) % n if periodic else np.clip(i + k, 0, n - 1) for i, k, n in zip(idx, offsets, shape))
    reached = h[at] + np.sqrt(np.maximum(r * r - sum((k * d) ** 2 for k, d in zip(offsets, steps)), 0.0))
    assert np.max(np.abs(reached - truth)) <= ulps


@pytest.mark.parametrize("r", [0.3e-3, 0.5e-3, 0.9e-3, 3e-3])
def test_the_felt_profile_is_the_balls_centre_path_on_its_grid(r):
    felt = SINE.felt_by(r)
    step = max(7, felt.x.size // 200)  # (about 200 of its grid points at most: 8,192 at 0.9 mm)
    x = felt.x[::step]
    # on the grid, the discrete maximum over offsets k dx misses the continuous one by at most
    # (dx/2)^2 / 2 times the curvature of h(x + u) + sqrt(r^2 - u^2) in u, <= max|h''| + 1/r
    bound = felt.dx**2 / 8 * ((2 * math.pi / L) ** 2 * A + 1 / r) + 1e-12
    assert np.max(np.abs(felt.h[::step] - _centre_path(SINE, x, r))) <= bound


def test_below_the_troughs_curvature_the_felt_profile_is_the_offset_curve():
    r = 0.5e-3
    assert r < L**2 / (4 * math.pi**2 * A)
    s = np.linspace(0, L, 2001)
    h, hp = SINE.height(s), SINE.slope(s)
    g = 1 / np.sqrt(1 + hp**2)
    xo, zo = s - r * hp * g, h + r * g - r
    felt = SINE.felt_by(r)
    # the grid's discrete maximum (as above), and as much again for the spline between its points
    bound = 2 * felt.dx**2 / 8 * ((2 * math.pi / L) ** 2 * A + 1 / r)
    np.testing.assert_allclose(felt.height(xo), zo, rtol=0, atol=bound)
    assert felt.max_slope == pytest.approx(SINE.max_slope, rel=1e-3)  # the offset curve keeps the normals


@pytest.mark.long
def test_near_the_troughs_radius_the_felt_profiles_node_slopes_are_the_offset_curves_to_the_last_bits():
    # Below the troughs' radius rho the path is the offset curve (do Carmo, the parallel curve):
    # the node at x has its contact p where x = p - r h'(p) / sqrt(1 + h'(p)^2), and its slope is
    # h'(p). Truth: that equation solved by scipy's brentq to 1e-18 m at every 64th node of the
    # sinusoid felt at 0.99 rho (262,144 samples of 7.6 nm). The contacts were golden-section
    # maxima of the ball's height, good to about sqrt(eps) of its flat top (u to 1e-11 m): node
    # slopes off by up to 2.0e-8, which the cubic pieces read as curvature 2.8 % off at the crests
    # over 7.6 nm intervals (2026-11-28). (Where the contact runs more than three intervals an
    # interval, beside the troughs, a segment's slope runs linearly between its ends' with the
    # interval's mean instead: those nodes are left out, 62 of the 4,096 here.) ~5 s
    from scipy.optimize import brentq

    k = 2 * math.pi / L
    r = 0.99 / (A * k * k)
    felt = SINE.felt_by(r)
    assert felt.x.size >= 2**18
    xs = felt.x[::64]

    def contact(x):
        return brentq(lambda p: p - r * A * k * math.cos(k * p) / math.hypot(1.0, A * k * math.cos(k * p)) - x,
                      x - 2 * r, x + 2 * r, xtol=1e-18, rtol=1e-15)

    p = np.array([[contact(x + d * felt.dx) for d in (-1, 0, 1)] for x in xs])
    slow = np.all(np.abs(np.diff(p, axis=1)) <= 3 * felt.dx, axis=1)
    assert 0.95 * xs.size < slow.sum() < xs.size  # (the fast ones beside the troughs)
    truth = A * k * np.cos(k * p[:, 1])
    assert np.max(np.abs(felt.slope(xs) - truth)[slow]) <= 1e-12


@pytest.mark.parametrize("rel_r", [0.8, 0.9, 0.95, 0.99, 1.01, 1.05, 1.2, 2.0])
def test_the_felt_profile_names_a_kink_only_where_the_ball_bridges_a_trough(rel_r):
    # a ball narrower than a trough's radius of curvature rho = l^2 / (4 pi^2 A) touches it
    # everywhere (the path is the offset curve, smooth); a wider one bridges it, its path kinked
    # once a period, at the trough (x = 3 l / 4, by symmetry). Bridging needs the surface between
    # the two contacts to curve more than the ball somewhere (r kappa > 1: where the ball is
    # tangent from above at both ends, the gap closes only past such a point), so below rho no
    # kink. Near rho the contact runs 1 / (1 - r kappa) times as fast as the ball, more than three
    # intervals an interval, and the felt profile named 6 to 8 kinks a period at 0.8 to 1.05 rho,
    # where design then said the ball bridges troughs (2026-11-27's sixth session)
    sine = hx.Sinusoid(0.2e-3, 2e-3)
    rho = (2e-3) ** 2 / (4 * math.pi**2 * 0.2e-3)
    felt = sine.felt_by(rel_r * rho)
    if rel_r < 1:
        assert felt.kinks.shape == (0, 2)
    else:
        assert felt.kinks[:, 0] == pytest.approx([1.5e-3], abs=felt.x[1] - felt.x[0])


@pytest.mark.parametrize("r", [4e-3, 6e-3, 10e-3])
def test_a_ball_on_the_crests_lowers_q_a_as_the_closed_form_says(r):
    # a ball resting on two crests as points would have the slope m at the trough between them;
    # the crests are rounded, so the contact slides down their flanks and the path is flatter:
    # m bounds it, and the brute-force path gives it (stop 62 asserted q = sqrt(1 + m^2) within
    # 1 %, which its spline's overshoot beside the kink met: 1.028 for a true 1.020 at 4 mm)
    felt = SINE.felt_by(r)
    m = (L / 2) / math.sqrt(r * r - L * L / 4)
    h, hp = _sines([A], [L], [0.0])
    truth = float(np.max(np.abs(_brute_slopes(h, hp, np.linspace(L / 2, 3 * L / 4, 101), r))))
    q = hx.characteristic_number(hx.algorithm("A", felt, 2000.0)).value
    q0 = hx.characteristic_number(hx.algorithm("A", SINE, 2000.0)).value
    assert q == pytest.approx(math.sqrt(1 + truth**2), rel=0.01) and q <= math.sqrt(1 + m * m) and q < q0


def _sines(amps, periods, phases):
    """A sum of sinusoids by numpy alone: (h, h') as functions, and its shortest period."""
    a, l, ph = (np.asarray(v, dtype=float)[:, None] for v in (amps, periods, phases))
    h = lambda x: np.sum(a * np.sin(2 * np.pi * np.atleast_1d(x)[None] / l + ph), axis=0)  # noqa: E731
    hp = lambda x: np.sum(a * 2 * np.pi / l * np.cos(2 * np.pi * np.atleast_1d(x)[None] / l + ph), axis=0)  # noqa: E731
    return h, hp


def _brute_slopes(h, hp, x, r, n=20001):
    """The ball's centre path's slope at each x by brute force: the arg-max u* of
    h(x + u) + sqrt(r^2 - u^2) over n offsets refined by a second pass 1000 times finer, and
    the slope there, h'(x + u*) (the envelope theorem: the path's slope is the contact's)."""
    out = np.empty(x.size)
    u = np.linspace(-r, r, n)
    ball = np.sqrt(np.maximum(r * r - u * u, 0.0))
    for i, xi in enumerate(x):
        k = int(np.argmax(h(xi + u) + ball))
        lo, hi = u[max(k - 1, 0)], u[min(k + 1, n - 1)]
        v = np.linspace(lo, hi, 1001)
        j = int(np.argmax(h(xi + v) + np.sqrt(np.maximum(r * r - v * v, 0.0))))
        out[i] = hp(xi + v[j])[0]
    return out


FELT_CASES = [  # (amplitudes, periods, phases, period); radii in units of the troughs' curvature radius
    ((0.2e-3,), (2e-3,), (0.0,), 2e-3),  # issue 67's: r = 1 mm read a slope of 0.853 for 0.625
    ((0.1e-3, 0.03e-3), (2e-3, 0.5e-3), (0.0, 1.0), 2e-3),  # two-tone
    ((0.05e-3, 0.04e-3, 0.02e-3, 0.015e-3), (4e-3, 2e-3, 1e-3, 0.8e-3), (0.3, 2.0, 4.1, 5.5), 4e-3),  # random phases
]


# the issue's sinusoid at radii 0.5 and 2 (a ball inside the troughs' curvature and one
# bridging them) in the contributor's loop; the two-tone and four-tone profiles and radii 0.1
# and 1 in .ci/run's long set (0.5-1.7 s each), radius 1 on the sinusoid and the four-tone
# profile by hand (3-4 s each)
@pytest.mark.parametrize("case, rel_r", [
    pytest.param(case, rel_r, marks=[] if case == 0 and rel_r in (0.5, 2.0) else
                 [pytest.mark.slow] if case != 1 and rel_r == 1.0 else [pytest.mark.long])
    for case in range(len(FELT_CASES)) for rel_r in (0.1, 0.5, 1.0, 2.0)])
def test_the_felt_slopes_are_the_contact_points_slopes(case, rel_r):
    # issue 67: the felt surface's steepest slope within 1 % of the brute-force ball path's and
    # never above the surface's own; q of algorithm A (sqrt(1 + M^2), Section IV-A) within 1 %
    amps, periods, phases, period = FELT_CASES[case]
    h, hp = _sines(amps, periods, phases)
    xs = np.linspace(0, period, 40001)
    own = float(np.max(np.abs(hp(xs))))
    kappa = float(np.max(np.abs(np.gradient(hp(xs), xs))))  # the sharpest curvature, 1 / the troughs' radius
    r = rel_r / kappa
    tex = hx.SumOfSinusoids(amps, periods, phases)
    felt = tex.felt_by(r)
    xb = np.linspace(0, period, 1201)
    truth = float(np.max(np.abs(_brute_slopes(h, hp, xb, r))))
    assert felt.max_slope <= own * (1 + 1e-6)  # (the cubic between exact slopes: O(dx^2) above them)
    assert felt.max_slope == pytest.approx(truth, rel=0.01)
    q = hx.characteristic_number(hx.algorithm("A", felt, 2000.0)).value
    assert q == pytest.approx(math.sqrt(1 + truth**2), rel=0.01)


def _norm2x2(cols):
    """The largest singular value of [[a, b], [c, e]] in closed form (its two columns given, each
    of shape (..., 2)), the largest over all the leading indices."""
    (a, c), (b, e) = (np.moveaxis(v, -1, 0) for v in cols)
    t, det = a * a + b * b + c * c + e * e, a * e - b * c
    return float(np.sqrt(0.5 * (t + np.sqrt(np.maximum(t * t - 4 * det * det, 0.0)))).max())


def _vertical_q(h1, h2, d):
    """q = sup ||J||_2 / k0 of A, B, C and G over a profile's slopes h1 and second derivatives h2
    (shape (n,)) and penetrations d (shape (k,), m), from the paper's Jacobians: A [[0, 0], [-h',
    1]] (eq. 7); B -k0 d^z n(h') (eq. 11) differentiated; C eq. 15; G -k0 p^z n(h') (eq. 28)
    differentiated, p^z = -d. Returns {letter: q}."""
    d = np.asarray(d, dtype=float)[None, :]
    S, C2 = np.asarray(h1, dtype=float)[:, None] + 0 * d, np.asarray(h2, dtype=float)[:, None] + 0 * d
    nrm = np.sqrt(1 + S * S)
    N, dN = np.stack([-S / nrm, 1 / nrm], -1), np.stack([-C2 / nrm**3, -S * C2 / nrm**3], -1)
    one, zero = np.ones_like(S), np.zeros_like(S)
    return {"A": _norm2x2([np.stack([zero, -S], -1), np.stack([zero, one], -1)]),
            "B": _norm2x2([N * -S[..., None] - d[..., None] * dN, N]),
            "C": _norm2x2([np.stack([S * S + d * C2, -S], -1), np.stack([-S, one], -1)]),
            "G": _norm2x2([-d[..., None] * dN, N])}


def _path_q(amps, periods, phases, period, r, dmax=1e-3, n=2000, m=20001):
    """q = sup ||J||_2 / k0 of A-G on the ball's centre path over a sum of sinusoids (one period),
    from the paper's Jacobians with the path's h', h'' (nothing of haptex's). The path by brute
    force: at n points of a period the arg-max u* of h(x + u) + sqrt(r^2 - u^2) over m offsets,
    refined 2000 times finer and polished by Newton steps on h'(x + u) = u / sqrt(r^2 - u^2);
    h' = h'(x + u*) (the envelope theorem) and, differentiating that condition, the path's
    h'' = h''(s) phi' / (phi' - h''(s)), s = x + u*, phi' = r^2 / (r^2 - u*^2)^(3/2) (the sup of
    B, C, G over the smooth parts, the kinks aside: there their forces jump, the test above),
    with each side's limit at every place the contact jumps (bisected 40 times): beside a kink
    the path's curvature is largest at the kink, a sup no sample attains.
    Over penetrations d in (0, dmax]: A, B, C, G by :func:`_vertical_q`; D: the centre of
    curvature below the path's sharpest crest, radius R, gives d / (R - d) at depth d, infinite
    where R <= dmax (the crest of a symmetric path is the closest point down to its centre; 1 at
    least, eq. 18); E 1 (eq. 21); F eq. 23 as haptex reads it (algorithm F's docstring: h~ = 0.8
    h / max|h|, mu = 0.8, d^x_max = 1 mm, stick |d^x| <= d^x_max with dd^x/dp^x = 1, slip
    d^x = +-d^x_max with 0). The 2 x 2 norms in closed form. Returns {letter: q}."""
    a, k, ph = (np.asarray(v, dtype=float) for v in (amps, 2 * np.pi / np.asarray(periods, dtype=float), phases))

    def H(x, order=0):  # the sum's height (order 0), slope (1) or second derivative (2), any shape
        x = np.asarray(x, dtype=float)[..., None]
        return np.sum(a * k**order * np.sin(k * x + ph + order * np.pi / 2), axis=-1)

    H1, H2 = (lambda x: H(x, 1)), (lambda x: H(x, 2))
    u = np.linspace(-r, r, m)

    def over(c, g):  # H(c_i + g_j), (c.size, g.size): the angle addition (_sines_over)
        return _sines_over(a, k[:, None], ph, c[:, None], g[:, None])

    def argmax(c, g, lift):  # the arg-max over g of H(c_i + g) + lift_i, in blocks of 200 points c
        lift = np.broadcast_to(lift, (c.size, g.size))
        return np.concatenate([np.argmax(over(c[i:i + 200], g) + lift[i:i + 200], axis=1) for i in range(0, c.size, 200)])

    def contact(x):  # the arg-max offsets u* (shape of x)
        j = argmax(x, u, np.sqrt(np.maximum(r * r - u * u, 0.0)))
        base, t = u[np.maximum(j - 1, 0)], np.linspace(0, 2, 4001) * (u[1] - u[0])  # (each point's own offsets:
        fine = base[:, None] + t[None]  # its base and a grid t shared by all)
        us = fine[np.arange(x.size), argmax(x + base, t, np.sqrt(np.maximum(r * r - fine**2, 0.0)))]
        for _ in range(5):
            w = np.sqrt(r * r - us * us)
            us = us - (H1(x + us) - us / w) / (H2(x + us) - r * r / w**3)
        return us

    x = np.arange(n) * (period / n)
    us = contact(x)
    # the path's one-sided limits at each kink (where the contact jumps: the sup of B's, C's, G's
    # Jacobians beside a kink is there, not attained): the jump's place bisected 40 times
    jumps = np.flatnonzero(np.abs(np.diff(x + us)) > 0.02 * r)
    if jumps.size:
        lo, hi, ulo, uhi = x[jumps], x[jumps + 1], us[jumps], us[jumps + 1]
        for _ in range(40):
            mid = 0.5 * (lo + hi)
            um = contact(mid)
            left = np.abs(mid + um - (lo + ulo)) < np.abs(mid + um - (hi + uhi))
            lo, ulo = np.where(left, mid, lo), np.where(left, um, ulo)
            hi, uhi = np.where(left, hi, mid), np.where(left, uhi, um)
        x, us = np.concatenate([x, lo, hi]), np.concatenate([us, ulo, uhi])
    w = np.sqrt(r * r - us * us)
    hp, h1, phi = H(x + us) + w - r, H1(x + us), r * r / w**3
    h2 = H2(x + us) * phi / (phi - H2(x + us))
    out = dict(_vertical_q(h1, h2, np.linspace(dmax / 200, dmax, 200)), E=1.0)
    radius = float(np.min(np.where(h2 < 0, (1 + h1**2) ** 1.5 / np.maximum(-h2, 1e-300), np.inf)))
    out["D"] = math.inf if radius <= dmax else max(1.0, dmax / (radius - dmax))
    ht, ht1 = 0.8 * hp / np.abs(hp).max(), 0.8 * h1 / np.abs(hp).max()
    zz = np.linspace(dmax / 32, dmax, 32)
    best = 0.0
    for stick, defl in ((1.0, np.linspace(-1e-3, 1e-3, 33)), (0.0, np.array([-1e-3, 1e-3]))):
        i, Z, Dx = np.meshgrid(np.arange(x.size), zz, defl, indexing="ij")
        J00 = -0.8 * Z * ((1 - ht[i]) * stick - Dx * ht1[i]) / 1e-3
        J01 = 0.8 * (1 - ht[i]) * Dx / 1e-3
        best = max(best, _norm2x2([np.stack([J00, 0 * J00], -1), np.stack([J01, -np.ones_like(J00)], -1)]))
    out["F"] = best
    return out


@pytest.mark.long
@pytest.mark.parametrize("case, rel_r, letters", [
    _by_hand(0, 0.5, "ABCDEFG"), _by_hand(0, 2.0, "ABCDEFG"), (0, 0.9, "BCG"), (0, 0.95, "BCG"), _by_hand(0, 1.05, "BCDEFG"),
    (0, 1.2, "BCG"), (1, 0.9, "BCG"), _by_hand(1, 1.05, "BCG"), (1, 1.2, "BCG"), _by_hand(1, 2.0, "ABCDFG"),
    _by_hand(2, 1.05, "BCG"), _by_hand(2, 1.2, "BCDEFG"), (2, 2.0, "ABCDFG")])
def test_q_of_every_algorithm_on_the_felt_profile_is_the_paths(case, rel_r, letters):
    # issue 67's goal: q of every algorithm on the felt surface within 1 % of q on the brute-force
    # ball path (the paper's Jacobians with the path's h' and h'', _path_q), on the sinusoid, the
    # two- and the four-tone profiles, r in units of their troughs' radius rho. Near rho the path's
    # curvature, kappa / (1 - r kappa), spikes over a few um, and on the default grid (7.8 um on
    # the sinusoid) q of B, C and G read -19 and -51 % at 0.9 and 0.95 rho, -1.1 % at 1.2 rho; and
    # across a kink the interval's ramp (its slope running from one branch's to the other's) read
    # the jump over an interval as curvature: the two-tone at 2 rho +12,500 %, the four-tone at
    # 1.2 and 2 rho +2,278 and +639 % (2026-11-27's sixth session). Then the grid was halved while
    # the segments' curvature missed the path's (PROFILE_CURVATURE_SLACK) and a kink's interval
    # made straight. With the oracle's limits at the kinks (2026-11-27's seventh session) the
    # two-tone at 2 rho read B, C, G -9.6, -12.6, -9.9 % (its path's curvature largest at its kinks,
    # the grid refined only by the curvature at its points): now refined while the kinks' limit
    # exceeds the segments' largest curvature, -0.14, -0.49, -0.15 %. At 1.05 rho (B, C) the
    # sinusoid read -1.05 and -1.04 %, the two-tone -8.8 and -9.2 %, the four-tone -7.5 %; at
    # 1.2 rho the two-tone B -2.45 %, the four-tone C -1.7 %, all on 32,768 samples at most
    # (2026-11-28: the finer grids' contacts now followed from the coarser ones' in work that grows
    # with the grid, PROFILE_REFINE_SAMPLES 524,288; q's search starts from the best interval
    # ends of any sampled profile, where the four-tone at 1.2 rho on 81,920 samples, past the old
    # search's 65,536 nodes, read C -3.1 %; the segments beside a kink take its one-sided limit;
    # each point's two best peaks polished): now within 0.03 % at 1.05 and 1.2 rho. A, D, E, F
    # within 0.2 % wherever measured (D infinite at 0.5 rho on the sinusoid, as on the path: the
    # felt crests' centre of curvature within the 1 mm depth; on the two-tone at 2 rho D's search
    # took 112 s on the 32,768 samples, a closest-point leaf an interval: 46 s with leaves of half
    # the first grid's shortest period, test_closest.py; 3.1 s with leaves certified convex solved
    # by Newton, 2026-11-28). D, E, F near rho (2026-11-28): the sinusoid at 1.05 rho +0.001, 0.000,
    # 0.000 % (65,536 samples, 5 s each), the four-tone at 1.2 rho 0.000, 0.000, +0.012 % (run
    # here); at 0.9 rho and on the two-tone at 1.05 rho D infinite as on the path, E and F within
    # 0.001 %. 5-90 s a case
    amps, periods, phases, period = FELT_CASES[case]
    _, hp = _sines(amps, periods, phases)
    xs = np.linspace(0, period, 40001)
    r = rel_r / float(np.max(np.abs(np.gradient(hp(xs), xs))))  # (in units of the troughs' radius)
    truth = _path_q(amps, periods, phases, period, r)
    felt = hx.SumOfSinusoids(amps, periods, phases).felt_by(r)
    for letter in letters:
        q = hx.characteristic_number(hx.algorithm(letter, felt, 2000.0)).value
        assert q == pytest.approx(truth[letter], rel=0.01), letter


@pytest.mark.long
@pytest.mark.parametrize("case, rel_r", [_by_hand(1, 1.05), (2, 1.02)])
def test_a_felt_profiles_curvature_miss_bounds_its_q(case, rel_r):
    # Where the profile's refinement for curvature reaches PROFILE_REFINE_SAMPLES short of its
    # slack, the profile says by how much (curvature_miss, a fraction of the path's largest
    # curvature), and q of B, C and G is within about that much of the path's. Truth: _path_q,
    # the brute-force oracle. Measured (2026-11-28): q of C on the two-tone at 1.05 rho -0.01 %
    # for a miss of 1.17 % (524,288 samples), on the four-tone at 1.02 rho +0.00 % for 3.4 %
    # (327,680; the next halving past PROFILE_REFINE_SAMPLES; -6.70 % for 6.70 % before the
    # segments beside its kink took the kink's limit). With the cap at 32,768 the sinusoid at 1.05
    # rho and the two-tone at 1.05 and 1.2 rho read -1.04, -9.22, -2.44 % for misses of 1.05,
    # 16.9 and 2.45 %; now within 0.03 % (the test above). The miss is the segments' ends'
    # against the path's at the grid points, where a cubic's second derivative converges as the
    # interval, its sup as its square
    amps, periods, phases, period = FELT_CASES[case]
    _, hp = _sines(amps, periods, phases)
    xs = np.linspace(0, period, 40001)
    r = rel_r / float(np.max(np.abs(np.gradient(hp(xs), xs))))
    truth = _path_q(amps, periods, phases, period, r)["C"]
    felt = hx.SumOfSinusoids(amps, periods, phases).felt_by(r)
    q = hx.characteristic_number(hx.algorithm("C", felt, 2000.0)).value
    assert felt.curvature_miss > 0.01  # (these are the cases the refinement does not meet)
    assert abs(q / truth - 1) <= felt.curvature_miss + 0.005


@pytest.mark.parametrize("rel_r", [0.95, 0.99])
def test_a_felt_profiles_convex_miss_bounds_its_most_convex_curvature(rel_r):
    # q of D reads the path's most convex curvature 1 / R (eq. 18: d_max / (R - d_max) below it;
    # a profile whose most convex curvature is m times more than the path's reads q off by m (1 +
    # q)). Closed form: the sinusoid's path is the offset curve below its troughs' radius rho, its
    # most convex point the crest's offset, curvature kappa / (1 + r kappa), kappa = 1 / rho (do
    # Carmo, the parallel curve). Measured (2026-11-28): the felt profile's most convex curvature
    # +0.14 % at 0.95 rho (16,384 samples), +2.82 % at 0.99 rho (262,144), where its
    # curvature_miss (what B, C, G read) says 0.96 and 0.72 %, and q of D read 1.034 for the
    # path's 1 (d_max / (R - d_max) = 0.984: D's q is 1 at least) in a 620 s search; refined by
    # it to 524,288 samples the miss grew, 6.5 % (not kept). The profile states it (convex_miss).
    # That miss was the contacts' (golden-section maxima, slopes off by up to 1.7e-8: the test
    # above), over intervals of 7.6 nm; with the contacts polished by Newton, +0.000 % and
    # +0.007 % (the same grids)
    r = rel_r * L**2 / (4 * math.pi**2 * A)
    felt = SINE.felt_by(r)
    truth = (4 * math.pi**2 * A / L**2) / (1 + r * 4 * math.pi**2 * A / L**2)
    xs = np.linspace(0.0, L, 8 * felt.x.size, endpoint=False)
    own = max(0.0, -float(np.min(felt.curvature(xs))))
    assert felt.convex_miss is not None
    assert abs(own / truth - 1) <= felt.convex_miss + 1e-4
    assert abs(own / truth - 1) <= 1e-3  # (+2.82 % at 0.99 rho before)


@pytest.mark.long
@pytest.mark.parametrize("rel_r", [0.95, 0.99])
def test_near_its_troughs_radius_q_of_d_on_a_felt_profile_is_the_paths(rel_r):
    # The case above, q of D itself (issue 67's goal: within 1 % of the path's). On the path
    # d_max / (R - d_max) below its crests, R = rho + r: 1.0256 at 0.95 rho, 0.984 at 0.99, so
    # 1 (eq. 18's floor). Truth: _path_q, the brute-force oracle. At 0.99 rho the felt profile's
    # most convex curvature was 2.82 % high (the contacts' golden-section error, above) and D's
    # search (8,193 x 64 closest points a grid, 262,144 samples) took 620 s to read 1.034
    # (2026-11-28): each surviving leaf of 1,024 intervals was scanned at every node. Now a leaf
    # on which the squared distance is certified convex is solved by Newton (hx_closest.c,
    # test_closest.py) and the grid's closest points are found once, not three times: 11 s (1.045
    # on the old contacts); with the contacts polished, 1.00000 in 6 s, and 1.02484 at 0.95 rho
    # (-0.07 %; 1.0279 in 46 s before). ~15 s
    r = rel_r * L**2 / (4 * math.pi**2 * A)
    truth = _path_q((A,), (L,), (0.0,), L, r)["D"]
    assert truth == pytest.approx(max(1.0, 1e-3 / (L**2 / (4 * math.pi**2 * A) + r - 1e-3)), rel=1e-4)
    felt = SINE.felt_by(r)
    q = hx.characteristic_number(hx.algorithm("D", felt, 2000.0)).value
    assert q == pytest.approx(truth, rel=0.01)


def _brute_argmax_2d(h, pts, r, n=61, refinements=2, side=None, away=None):
    """The arg-max u* (k, 2) of h(p + u) + sqrt(r^2 - |u|^2) over offsets u at each in-plane point
    p of pts (k, 2), by brute force: over an n x n grid of offsets in the disc, then
    ``refinements`` times over a 21 x 21 grid around the best (each a tenth of the last's span);
    given ``side``, only offsets with p + u on the square [0, side]^2 (a map that ends at its
    edges); given ``away`` (k, 2), only offsets more than 3 grid steps from each point's (the best
    elsewhere: a rival branch). Points in batches, an offset outside the disc or the map -inf (the
    first of equal maxima kept, as a loop over the points would). h is a numpy function of (m, 2)
    points; nothing of haptex's. Where h is a sum of gratings (:func:`_with_sines`), its values
    over each stage's grid of offsets, shared by every point about its centre, are two matrix
    products (:func:`_over_offsets`)."""
    pts = np.asarray(pts, dtype=float).reshape(-1, 2)
    out = np.empty((len(pts), 2))
    g1 = np.linspace(-r, r, n)
    U = np.stack(np.meshgrid(g1, g1, indexing="ij"), -1).reshape(-1, 2)
    U = U[np.sum(U * U, axis=1) <= r * r]
    ball = np.sqrt(np.maximum(r * r - np.sum(U * U, axis=1), 0.0))
    batch = max(1, 2_000_000 // U.shape[0])
    for lo in range(0, len(pts), batch):
        p = pts[lo:lo + batch, None, :]
        u, step = np.broadcast_to(U, (p.shape[0],) + U.shape), 2 * r / (n - 1)
        centre, grid = p[:, 0, :], U  # (u = centre - p + grid: the stage's offsets about each point's centre)
        for stage in range(refinements + 1):
            q = p + u if side is not None or not hasattr(h, "sines") else None
            val = _over_offsets(h, centre, grid, q)
            if stage == 0:  # (U: in the disc)
                val += ball
            else:
                uu = np.sum(u * u, axis=2)
                val += np.sqrt(np.maximum(r * r - uu, 0.0))
                val[uu > r * r] = -np.inf
            if side is not None:
                val[np.any((q < 0) | (q > side), axis=2)] = -np.inf
            if away is not None and stage == 0:
                near = np.sum((u - away[lo:lo + batch, None, :]) ** 2, axis=2) <= (3 * step) ** 2
                val[near] = -np.inf
            best = u[np.arange(u.shape[0]), np.argmax(val, axis=1)]
            g = np.linspace(-step, step, 21)
            grid = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
            u = best[:, None, :] + grid[None]
            centre = p[:, 0, :] + best
            step /= 10
        out[lo:lo + batch] = best
    return out


def _over_offsets(h, centre, grid, q):
    """h at the points centre (k, 2) + grid (m, 2), shape (k, m): where h is a sum of
    gratings sum_j a_j sin(k_j . p + ph_j) (its ``sines``, :func:`_with_sines`), by the angle
    addition sin(A + B) = sin A cos B + cos A sin B with A = k_j . centre + ph_j and B = k_j .
    grid, two (k, J) x (J, m) products (the k m J sines of evaluating h at q were 60-80 % of the
    oracle's time); otherwise h itself at q, those points (k, m, 2)."""
    sines = getattr(h, "sines", None)
    if sines is None:
        return h(q.reshape(-1, 2)).reshape(q.shape[:2])
    return _sines_over(*sines, centre, grid)


def _sines_over(a, k, ph, centre, grid):
    """sum_j a_j sin(k_j . (c + g) + ph_j) at every centre c (n, d) plus every offset g (m, d),
    shape (n, m), for wave vectors k (J, d): by the angle addition, sin(A + B) = sin A cos B +
    cos A sin B with A = k_j . c + ph_j and B = k_j . g, two (n, J) x (J, m) products."""
    A, B = centre @ k.T + ph, grid @ k.T
    return (a * np.sin(A)) @ np.cos(B).T + (a * np.cos(A)) @ np.sin(B).T


def _with_sines(h, a, k, ph):
    """h (a numpy function of (m, 2) points) with its ``sines`` (a (J,), k (J, 2) in rad/m, ph
    (J,)): h = sum_j a_j sin(k_j . p + ph_j), checked at 1,000 points of its 2 mm cell to 1e-12 of
    its amplitude (a product of sines written as two gratings: sin x sin y = (cos(x - y) - cos(x +
    y)) / 2, the cosines a quarter turn on)."""
    a, k, ph = (np.asarray(v, dtype=float) for v in (a, k, ph))
    P = np.random.default_rng(0).uniform(0.0, 2e-3, (1000, 2))
    assert np.max(np.abs(h(P) - np.sum(a * np.sin(P @ k.T + ph), axis=1))) <= 1e-12 * np.sum(np.abs(a))
    h.sines = (a, k, ph)
    return h


def _brute_contacts_2d(h, pts, r, n=61):
    """The ball's contact offsets u* (k, 2) at each in-plane point of pts (k, 2), by brute force
    (:func:`_brute_argmax_2d`: an n x n grid of offsets in the disc, refined twice on 21 x 21
    grids around its best, each a tenth of the last's span). h is a numpy function of (m, 2)
    points; nothing of haptex's."""
    return _brute_argmax_2d(h, pts, r, n)


def _brute_gradients_2d(h, grad, pts, r, n=61):
    """The ball's centre path's gradient at each in-plane point of pts (k, 2), by brute force:
    grad h at the contact of :func:`_brute_contacts_2d` (the envelope theorem: the path's normal
    is the contact's). h and grad are numpy functions of (m, 2) points."""
    return grad(pts + _brute_contacts_2d(h, pts, r, n))


def _path_max_slope_2d(h, grad, cell, r, n=41):
    """The steepest slope of the ball's centre path over a periodic cell, by brute force: the
    gradients' norm on an n x n grid of the cell, then on a grid a twentieth as wide around each
    of its three steepest points (the sup sits beside a kink, where the path is steepest)."""
    xs, ys = (np.arange(n) * (c / n) for c in cell)
    P = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
    s = np.linalg.norm(_brute_gradients_2d(h, grad, P, r), axis=1)
    best = float(s.max())
    for k in np.argsort(s)[-3:]:
        g = np.linspace(-cell[0] / n, cell[0] / n, 11)
        Q = P[k] + np.stack(np.meshgrid(g, g * cell[1] / cell[0], indexing="ij"), -1).reshape(-1, 2)
        best = max(best, float(np.linalg.norm(_brute_gradients_2d(h, grad, Q, r), axis=1).max()))
    return best


AREAL_CASES = {  # (surface, numpy h and grad h, cell, the troughs' curvature radius (m))
    "grating": (hx.Grating(0.2e-3, 2e-3),
                _with_sines(lambda p: 0.2e-3 * np.sin(2 * np.pi * p[:, 0] / 2e-3), [0.2e-3], [(2 * np.pi / 2e-3, 0.0)],
                            [0.0]),
                lambda p: np.column_stack([0.2e-3 * 2 * np.pi / 2e-3 * np.cos(2 * np.pi * p[:, 0] / 2e-3),
                                           np.zeros(len(p))]),
                (2e-3, 2e-3), (2e-3) ** 2 / (4 * math.pi**2 * 0.2e-3)),
    "egg-crate": (hx.SumOfGratings.egg_crate(0.1e-3, 2e-3),
                  _with_sines(lambda p: 0.1e-3 * np.sin(np.pi * p[:, 0] / 1e-3) * np.sin(np.pi * p[:, 1] / 1e-3),
                              [0.05e-3, -0.05e-3], np.pi / 1e-3 * np.array([(1.0, -1.0), (1.0, 1.0)]), [np.pi / 2] * 2),
                  lambda p: 0.1e-3 * np.pi / 1e-3 * np.column_stack(
                      [np.cos(np.pi * p[:, 0] / 1e-3) * np.sin(np.pi * p[:, 1] / 1e-3),
                       np.sin(np.pi * p[:, 0] / 1e-3) * np.cos(np.pi * p[:, 1] / 1e-3)]),
                  (2e-3, 2e-3), (2e-3) ** 2 / (4 * math.pi**2 * 0.1e-3)),
}
# a random areal map: six gratings periodic on a 2 mm cell (wave vectors 2 pi (m, n) / 2 mm),
# amplitudes 40 to 5 um, phases drawn once; its troughs are neither umbilic nor cylindrical
_RANDOM_MN = np.array([(1, 0), (0, 1), (1, 1), (2, -1), (1, 2), (3, 1)])
_RANDOM_K = 2 * np.pi * _RANDOM_MN / 2e-3
_RANDOM_A = np.array([40e-6, 30e-6, 20e-6, 12e-6, 10e-6, 5e-6])
_RANDOM_PH = np.array([0.3, 2.0, 4.1, 5.5, 1.1, 3.3])


def _gratings_tightest_radius(n=401, a=_RANDOM_A, k=_RANDOM_K, ph=_RANDOM_PH):
    """The tightest radius of curvature of a sum of gratings a sin(k . p + ph) periodic on the 2
    mm cell (the random map's by default: 0.640 mm), 1 / sup |kappa| over its principal
    curvatures (the eigenvalues of (I + g g^T)^-1 H / sqrt(1 + |g|^2)) on an n x n grid of its
    cell, from the analytic gradient and Hessian (numpy alone)."""
    g1 = np.linspace(0, 2e-3, n)
    P = np.stack(np.meshgrid(g1, g1, indexing="ij"), -1).reshape(-1, 2)
    arg = P @ k.T + ph
    g = np.cos(arg) @ (a[:, None] * k)
    H = np.einsum("pk,k,ki,kj->pij", -np.sin(arg), a, k, k)
    return float(1 / np.abs(_principal_curvatures(g, H)).max())


def _principal_curvatures(g, H):
    """The principal curvatures (k, 2) (1/m) of a height field with gradients g (k, 2) and
    Hessians H (k, 2, 2): the eigenvalues of the shape operator (I + g g^T)^-1 H / sqrt(1 +
    |g|^2) (do Carmo, Differential Geometry of Curves and Surfaces, sec. 3-3)."""
    w = np.sqrt(1 + np.sum(g * g, axis=1))
    return np.linalg.eigvals(np.linalg.solve(np.eye(2) + g[:, :, None] * g[:, None, :], H)).real / w[:, None]


AREAL_CASES["random"] = (
    hx.SumOfGratings(_RANDOM_A, 2 * np.pi / np.linalg.norm(_RANDOM_K, axis=1), np.arctan2(_RANDOM_K[:, 1], _RANDOM_K[:, 0]),
                     _RANDOM_PH),
    _with_sines(lambda p: np.sum(_RANDOM_A * np.sin(p @ _RANDOM_K.T + _RANDOM_PH), axis=1), _RANDOM_A, _RANDOM_K,
                _RANDOM_PH),
    lambda p: np.cos(p @ _RANDOM_K.T + _RANDOM_PH) @ (_RANDOM_A[:, None] * _RANDOM_K),
    (2e-3, 2e-3), None)  # (rho: _gratings_tightest_radius, computed where a test needs it)
# two gratings whose wave vectors meet at 63 deg (2 pi (1, 0) and 2 pi (1, 2) / 2 mm), 40 and 30
# um: its troughs are neither umbilic nor along the axes, its tightest radius 0.633 mm
_TWO_K = 2 * np.pi * np.array([(1, 0), (1, 2)]) / 2e-3
_TWO_A, _TWO_PH = np.array([40e-6, 30e-6]), np.array([0.4, 1.7])
AREAL_CASES["two-grating"] = (
    hx.SumOfGratings(_TWO_A, 2 * np.pi / np.linalg.norm(_TWO_K, axis=1), np.arctan2(_TWO_K[:, 1], _TWO_K[:, 0]), _TWO_PH),
    _with_sines(lambda p: np.sum(_TWO_A * np.sin(p @ _TWO_K.T + _TWO_PH), axis=1), _TWO_A, _TWO_K, _TWO_PH),
    lambda p: np.cos(p @ _TWO_K.T + _TWO_PH) @ (_TWO_A[:, None] * _TWO_K),
    (2e-3, 2e-3), None)
_TIGHTEST = {"random": _gratings_tightest_radius,
             "two-grating": lambda: _gratings_tightest_radius(a=_TWO_A, k=_TWO_K, ph=_TWO_PH)}


def _felt_case(shared, name, r):
    """AREAL_CASES[name]'s texture felt by a ball of radius r (m), made once in a test run and
    read by every test that asks for the same (name, r) (conftest's ``shared``: each a copy as
    ``felt_by`` returned it). The maps several tests read cost seconds each."""
    return shared(f"felt {name} r={r!r}", lambda: AREAL_CASES[name][0].felt_by(r))


ANGLES = np.linspace(0.0, 2 * np.pi, 120, endpoint=False)


def _areal_path_q(h, grad, cell, r, dmax=1e-3, n=41, letters="BCDFG"):
    """q = sup ||J||_2 / k0 of B, C, D, F and G on the ball's centre path over a periodic cell,
    from the fields' definitions with nothing of haptex's. Below the surface's tightest radius
    one contact everywhere, the path smooth; above it (the ball bridging: r times the largest
    principal curvature at the most concave points below at least 1) the contacts are the higher
    of the brute force's best and its best more than 3 of its grid steps away, each polished, and
    the nested grids below close in on the kinks' one-sided limits (B, C, G checked against
    :func:`_path_q` on the grating; F's max|h| holds below the radius only): at each point p the
    contact offset u by brute force
    (:func:`_brute_contacts_2d`), polished by Newton steps on grad h(p + u) = u / s, s = sqrt(r^2
    - |u|^2); the path's gradient grad h(p + u) (the envelope theorem) and its Hessian, from
    differentiating that condition, A (B - A)^-1 B, A = h's Hessian at the contact (central
    differences of the analytic gradient, 1e-7 m) and B = I / s + u u^T / s^3 the sphere's. With
    g the gradient, n = (-g, 1) / sqrt(1 + |g|^2), depth t = -d^z in [0, dmax] (each Jacobian is
    affine in t, its norm convex: the sup is at t = 0 or dmax): B f = -k0 d^z n (eq. 11 over a
    surface), J = -k0 (n (-g, 1)^T + d^z dn); C f = -k0 d^z (-g, 1) (eq. 14), J = -k0 ((-g, 1)
    (-g, 1)^T + d^z [[-Hs, 0], [0, 0]]); G f = -k0 p^z n (eq. 28), J = -k0 (n e_z^T + p^z dn),
    p^z = d^z = -t; dn = [dn/dg Hs, 0]; D d / (R - d) at depth d <= dmax below the path's most
    convex point (R its smallest principal radius of curvature, eq. 18's Jacobian with the
    boundary's curvature), infinite where R <= dmax, 1 at least; F (when in ``letters``) eq. 22
    over a surface with the path's heights and gradient (the comment below), max|h| the
    surface's own (below rho the path's extremes). The sup over an n x n grid of the cell, then five times on
    11 x 11 grids about each of the three largest points (one interval wide, then a fifth of the
    last: near the troughs' radius the contact runs 1 / (1 - r kappa) times as fast as the ball,
    and the path's curvature spikes over a few um).
    Returns {letter: q}."""
    def hess(q, e=1e-7):
        cols = [(grad(q + e * np.array(v)) - grad(q - e * np.array(v))) / (2 * e) for v in ((1.0, 0.0), (0.0, 1.0))]
        H = np.stack(cols, -1)
        return 0.5 * (H + np.swapaxes(H, -1, -2))

    def polish(P, u):
        for _ in range(5):  # Newton on grad h(p + u) - u / s = 0 (the ascent's stationary point)
            s = np.sqrt(r * r - np.sum(u * u, axis=1))
            B = np.eye(2) / s[:, None, None] + u[:, :, None] * u[:, None, :] / (s**3)[:, None, None]
            u = u - np.linalg.solve(hess(P + u) - B, (grad(P + u) - u / s[:, None])[..., None])[..., 0]
        return u

    def q_at(P):
        # the brute force's best polished; where the ball can bridge (r times the surface's
        # largest principal curvature at least 1), also its best more than 3 of its grid steps
        # away (a rival branch, where two compete: within a few hundred nm of a crease the
        # grid's own error picks the lower one), the higher of the two stationary points
        u = polish(P, _brute_contacts_2d(h, P, r))
        if bridging:
            with np.errstate(invalid="ignore"):
                v = polish(P, _brute_argmax_2d(h, P, r, away=u))
                lift = [h(P + w) + np.sqrt(r * r - np.sum(w * w, axis=1)) for w in (u, v)]
            u = np.where((lift[1] > lift[0])[:, None], v, u)
        s = np.sqrt(r * r - np.sum(u * u, axis=1))
        A = hess(P + u)
        B = np.eye(2) / s[:, None, None] + u[:, :, None] * u[:, None, :] / (s**3)[:, None, None]
        Hs = A @ np.linalg.solve(B - A, B)
        g = grad(P + u)
        w = np.sqrt(1 + np.sum(g * g, axis=1))
        nn = np.column_stack([-g, np.ones(len(g))]) / w[:, None]
        dn_dg = np.concatenate([-np.eye(2)[None] / w[:, None, None] + g[:, :, None] * g[:, None, :] / (w**3)[:, None, None],
                                -g[:, None, :] / (w**3)[:, None, None]], axis=1)  # (k, 3, 2)
        dn = np.concatenate([dn_dg @ Hs, np.zeros((len(g), 3, 1))], axis=2)
        m = np.column_stack([-g, np.ones(len(g))])
        ez = np.zeros_like(m)
        ez[:, 2] = 1.0
        # D (eq. 17-18): d / (R - d) at depth d below the path's most convex point, R its
        # smallest principal radius there (the curvatures: eigenvalues of (I + g g^T)^-1 Hs / w);
        # infinite where R <= dmax (its focal point within reach); 1 at least
        conv = np.maximum(0.0, -_principal_curvatures(g, Hs).min(axis=1))
        radius = np.where(conv > 0, 1 / np.maximum(conv, 1e-300), np.inf)
        out = {"D": np.where(radius <= dmax, np.inf, np.maximum(1.0, dmax / np.maximum(radius - dmax, 1e-300)))}
        # F (eq. 22 over a surface as haptex's docstring reads it: f_t = -mu k0 t m d / d^x_max, m = 1
        # - h~, h~ = 0.8 h / max|h| on the path's heights): J_tt = -mu t (m D - d grad h~^T) /
        # d^x_max, J_tz = mu m d / d^x_max, J_zz = -1 (over k0), D = I in stick and I - e e^T in
        # slip (e = d / |d|); affine in d and in t, so its norm's sup over the disc |d| <= d^x_max
        # is on the circle, at t = 0 or dmax: 120 directions
        mod = 1 - 0.8 * (h(P + u) + s - r) / peak
        gm = 0.8 * g / peak
        e = np.stack([np.cos(ANGLES), np.sin(ANGLES)], -1)  # (a, 2)
        dvec = 1e-3 * e
        for slip in (False, True) if "F" in letters else ():
            Dm = np.eye(2) - (e[:, :, None] * e[:, None, :] if slip else 0.0)  # (a, 2, 2) or (2, 2)
            for t in (0.0, dmax):
                J = np.zeros((len(g), len(e), 3, 3))
                J[..., :2, :2] = -0.8 * t / 1e-3 * (mod[:, None, None, None] * Dm - dvec[None, :, :, None] * gm[:, None, None, :])
                J[..., :2, 2] = 0.8 * mod[:, None, None] * dvec[None] / 1e-3
                J[..., 2, 2] = -1.0
                top = np.sqrt(np.linalg.eigvalsh(np.swapaxes(J, -1, -2) @ J)[..., -1]).max(axis=1)
                out["F"] = np.maximum(out.get("F", 0.0), top)
        for t in (0.0, dmax):
            dz = -t
            Hz = np.zeros((len(g), 3, 3))
            Hz[:, :2, :2] = -Hs
            J = {"B": nn[:, :, None] * m[:, None, :] + dz * dn, "C": m[:, :, None] * m[:, None, :] + dz * Hz,
                 "G": nn[:, :, None] * ez[:, None, :] + dz * dn}
            for k, v in J.items():
                out[k] = np.maximum(out.get(k, 0.0), np.linalg.norm(v, ord=2, axis=(1, 2)))
        return out

    xs, ys = (np.arange(n) * (c / n) for c in cell)
    P = np.stack(np.meshgrid(xs, ys, indexing="ij"), -1).reshape(-1, 2)
    # F's max|h| on the path: below the troughs' radius the ball rests on each crest and in each
    # trough's bottom, so the path's extremes are the surface's, found from the grid's by scipy
    hv = h(P)
    peak = max(abs(minimize(lambda v, sg=sg: sg * h(np.asarray(v)[None])[0], P[int(np.argmin(sg * hv))],
                            method="Nelder-Mead", options={"xatol": 1e-12, "fatol": 1e-16}).fun) for sg in (-1.0, 1.0))
    seen = {}  # (the letters' largest points often coincide: each nested grid evaluated once)
    # the spike of the path's curvature sits above the surface's most curved trough, a few um
    # wide across it: where the troughs are not umbilic (a ridge along the trough's line) the
    # grid can step over it (a sum of two gratings at 63 deg at 0.99 rho read q of C 109.2 on
    # 41 x 41 and 157.9 on 161 x 161, where d_max kappa / (1 - r kappa) is 157.9), so the nested
    # grids start from the ball's centres over the surface's most concave points too: the
    # principal curvatures on a 201 x 201 grid of the cell (the Hessian by central differences
    # of grad), the best 3 polished by scipy's Nelder-Mead, the centre p = s - r g / sqrt(1 +
    # |g|^2) whose contact is s (the contact condition inverted)
    S = np.stack(np.meshgrid(*(np.arange(201) * (c / 201) for c in cell), indexing="ij"), -1).reshape(-1, 2)

    def concave(q):
        return _principal_curvatures(grad(q), hess(q)).max(axis=1)

    tops = [minimize(lambda v: -concave(np.asarray(v)[None])[0], S[i], method="Nelder-Mead",
                     options={"xatol": 1e-12, "fatol": 1e-9}).x for i in np.argsort(concave(S))[-3:]]
    bridging = r * float(concave(np.array(tops)).max()) >= 1.0
    vals = q_at(P)
    best = {k: float(v.max()) for k, v in vals.items()}
    gs = grad(np.array(tops))
    above = np.array(tops) - r * gs / np.sqrt(1 + np.sum(gs * gs, axis=1))[:, None]
    for k, v in vals.items():
        for centre in [P[i] for i in np.argsort(v)[-3:]] + list(above):
            half = np.array(cell) / n
            for _ in range(5):
                key = (centre.tobytes(), half.tobytes())
                if key not in seen:
                    g = np.linspace(-1.0, 1.0, 11)
                    Q = centre + np.stack(np.meshgrid(g * half[0], g * half[1], indexing="ij"), -1).reshape(-1, 2)
                    seen[key] = (Q, q_at(Q))
                Q, vq = seen[key][0], seen[key][1][k]
                centre, half = Q[int(np.argmax(vq))], half / 5
                best[k] = max(best[k], float(vq.max()))
    return best


# the issue's case in the contributor's loop; the egg-crate below its troughs' radius and the
# grating inside it in .ci/run's long set (2 s each)
@pytest.mark.parametrize("name,rel_r", [("grating", 1.98), pytest.param("egg-crate", 0.5, marks=pytest.mark.long),
                                        pytest.param("grating", 0.5, marks=pytest.mark.long)])
def test_the_felt_maps_slopes_are_the_contact_points_slopes(name, rel_r):
    # issue 67 on areal maps: the felt map's steepest slope within 1 % of the brute-force ball
    # path's (numpy on the analytic heights) and never above the surface's own; q of A
    # (sqrt(1 + M^2), Section IV-A) within 1 %. Grating(0.2 mm, 2 mm) under a 1 mm ball (1.98
    # times its troughs' 0.51 mm radius) read 0.851 for the path's 0.625 with the spline
    # through the dilated heights; the Hermite map through the contacts' gradients reads 0.6252.
    tex, h, grad, cell, rho = AREAL_CASES[name]
    r = rel_r * rho
    felt = tex.felt_by(r)
    truth = _path_max_slope_2d(h, grad, cell, r)
    assert felt.max_slope <= tex.max_slope * (1 + 1e-6)
    assert felt.max_slope == pytest.approx(truth, rel=0.01)
    q = hx.characteristic_number(hx.algorithm("A", felt, 2000.0)).value
    assert q == pytest.approx(math.sqrt(1 + truth**2), rel=0.01)


@pytest.mark.parametrize("name", ["random", "two-grating", "egg-crate"])
def test_the_cores_contact_ascent_reaches_scipys_maximum_of_the_balls_lift(name):
    # Every felt map's contacts come from the C core's ascent (hx_contact_ascent, hx_felt.c): the
    # offset u maximising g(u) = h(p + u) + sqrt(r^2 - |u|^2) in a box and the disc. Truth:
    # scipy's L-BFGS-B on the same g with the test's numpy heights and gradients (nothing of
    # haptex's), from the same start, within the same box: the whole disc's box (the ball at
    # 0.8 of the surface's tightest radius: g concave, one maximum), then a box that stops 1 to
    # 3 um short of that maximum along x (the constrained maximum on its wall: the core holds
    # that coordinate there and steps the other alone).
    from haptex.surfaces import _refine_contacts

    tex, h, grad, cell, rho = AREAL_CASES[name]
    r = 0.8 * (rho or _TIGHTEST[name]())
    rng = np.random.default_rng(7)
    P = rng.uniform(0.0, cell[0], (40, 2))
    g = grad(P)
    start = r * g / np.sqrt(1 + np.sum(g * g, axis=1))[:, None]  # (the smooth contact from p's own slope)

    def lift(u, p):
        s = math.sqrt(r * r - u @ u)
        return -(h((p + u)[None])[0] + s), -(grad((p + u)[None])[0] - u / s)

    def scipys(x0, lo, hi):
        out = []
        for k in range(len(P)):
            res = minimize(lift, x0[k], args=(P[k],), jac=True, method="L-BFGS-B", bounds=list(zip(lo[k], hi[k])),
                           options={"ftol": 1e-15, "gtol": 1e-13, "maxiter": 500})
            out.append((res.x, -res.fun))
        return np.array([o[0] for o in out]), np.array([o[1] for o in out])

    wide = np.full_like(start, 0.7 * r)
    want, top = scipys(start, -wide, wide)
    u, lifted = _refine_contacts(tex, P, start, -wide, wide, r, r * (1 - 1e-9), 1e-12)
    assert np.max(np.abs(u - want)) < 1e-9  # (m; the contacts move ~0.1 mm over the cell)
    assert np.max(np.abs(lifted - top)) < 1e-12
    lo, hi = -wide.copy(), wide.copy()
    lo[:, 0] = want[:, 0] + rng.uniform(1e-6, 3e-6, len(P))  # (the maximum 1-3 um outside the box along x)
    start_in = np.clip(start, lo + 1e-7, hi)
    want_box, top_box = scipys(start_in, lo, hi)
    u, lifted = _refine_contacts(tex, P, start_in, lo, hi, r, r * (1 - 1e-9), 1e-12)
    assert np.all(want_box[:, 0] == lo[:, 0])  # (scipy's maximum on the wall, as built)
    assert np.max(np.abs(u - want_box)) < 1e-9
    assert np.max(np.abs(lifted - top_box)) < 1e-12
    assert np.all(top_box < top)  # (the box cost height)


def test_on_axes_turned_to_its_gratings_the_felt_egg_crate_is_the_ball_paths():
    # The egg-crate's gratings run at +-45 degrees, its saddles' ridges along them: a tensor
    # patch on the plane's axes meets a ridge across its diagonal, and near the bowls' radius the
    # map's curvature there missed the path's (0.95 rho: convex_miss 176 %, q of D 58.5 for the
    # path's 1.025). So felt_by makes the map on axes along the gratings (felt_turn = pi / 4)
    # and the C core turns each point into them (PATCH_TURN: the height there, the gradient R g
    # and Hessian R H R^T back). Truth: the brute-force ball path (numpy on the analytic
    # heights: its height max h(p + u) + sqrt(r^2 - |u|^2) - r, its gradient the contact's), and
    # the map's Hessian against numpy's central differences of its own gradient (the definition;
    # a Hessian turned the wrong way round, R^T H R, fails it: 2.5e3 1/m off, measured)
    tex, h, grad, cell, rho = AREAL_CASES["egg-crate"]
    r = 0.5 * rho
    felt = tex.felt_by(r)
    assert tex.felt_turn == pytest.approx(math.pi / 4) and felt.turn == tex.felt_turn
    assert felt.cell == pytest.approx(cell) and felt.domain == ((0.0, cell[0]), (0.0, cell[1]))
    rng = np.random.default_rng(5)
    P = rng.uniform(0, 2e-3, (60, 2))
    u = _brute_contacts_2d(h, P, r)
    path = h(P + u) + np.sqrt(r * r - np.sum(u * u, axis=1)) - r
    np.testing.assert_allclose(felt.height_at(P), path, rtol=0, atol=1e-9)
    np.testing.assert_allclose(felt.gradient(P), grad(P + u), rtol=0, atol=1e-3)
    e = 1e-9
    fd = np.stack([(felt.gradient(P + [e, 0]) - felt.gradient(P - [e, 0])) / (2 * e),
                   (felt.gradient(P + [0, e]) - felt.gradient(P - [0, e])) / (2 * e)], -1)
    np.testing.assert_allclose(felt.hessian(P), fd, rtol=1e-5, atol=0.05)
    # and its report of places is the plane's: its kinks none (below the bowls' radius), and
    # among its steepest points (those of the sups of its slope and curvature) one where the
    # path's slope is its max_slope (measured: 0.314159 for 0.314158; at the points as the map's
    # own axes give them, unturned, 0.3112, 0.94 % short)
    assert felt.kinks.shape == (0, 3)
    s = felt.steepest_points()
    assert np.linalg.norm(grad(s + _brute_contacts_2d(h, s, r)), axis=1).max() == pytest.approx(felt.max_slope,
                                                                                                 rel=1e-3)


@pytest.mark.parametrize("name,rel_r", [("grating", 0.9), pytest.param("egg-crate", 0.9, marks=pytest.mark.long),
                                        pytest.param("egg-crate", 0.8, marks=pytest.mark.long),
                                        pytest.param("egg-crate", 0.95, marks=pytest.mark.long)])
def test_below_every_troughs_radius_the_felt_map_names_no_kink(name, rel_r, shared):
    # A ball bridges a surface only where its section between the two contacts curves more than
    # the ball's (a circle of radius at most r tangent from above at both): below the surface's
    # tightest radius of curvature (1 / sup ||H||) it touches everywhere and its path is the
    # offset surface, smooth, as on a profile. The felt maps named kinks wherever the contact ran
    # faster than three intervals, and branched the cells there, so that design said "the ball
    # bridges troughs" and "rests on several sides of a bowl": the grating at 0.9 times its
    # troughs' radius 142 kinks (a grating has no bowls), the egg-crate at 0.8, 0.9, 0.95 times
    # 24, 344, 264 kinks and 256, 328, 274 branched cells (2026-11-27). Truth: that
    # geometry, and the brute-force path's steepest slope (numpy on the analytic heights)
    tex, h, grad, cell, rho = AREAL_CASES[name]
    felt = _felt_case(shared, name, rel_r * rho)
    assert len(felt.kinks) == 0 and felt.branched_cells == 0
    truth = _path_max_slope_2d(h, grad, cell, rel_r * rho)
    assert felt.max_slope == pytest.approx(truth, rel=0.01)
    assert felt.max_slope <= tex.max_slope * (1 + hx.surfaces.STEEP_SLACK)


def test_a_felt_map_refined_for_its_curvature_carries_its_first_grids_band():
    # Refining a felt map for its curvature (surfaces._curvature_refined) adds samples of the same
    # ball path, not a shorter wavelength: by definition the map still holds the band of the grid
    # it was made on (here the egg-crate at 0.5 rho, made on 31.25 um and refined to 15.6 um), and
    # so do its analyses' grids. The refined map had taken its own Nyquist period, 31 um for 62.5:
    # q of F's plane grid went from 129 x 129 to 257 x 257 points, 2.3 to 9.0 million Jacobians
    # (24.8 s for 2.2 s on the analytic egg-crate), and at 0.88 rho, on 576 x 576 samples, 1,153
    # x 1,153 (565 s), past F_SURFACE_GRID_POINTS by the floor of 4 cells a period (2026-11-27).
    # Truth: the same map made on the first grid unrefined (spacing given: no refinement; the
    # default's, r / 16, on the map's axes, turned along the egg-crate's gratings: 45 cells over
    # their sqrt(2) mm period)
    tex, _, _, _, rho = AREAL_CASES["egg-crate"]
    felt = tex.felt_by(0.5 * rho)
    first = tex.felt_by(0.5 * rho, spacing=0.5 * rho / 16)
    assert felt.x.size > first.x.size  # (refined)
    assert felt.shortest_period == first.shortest_period
    for letter in "BFE":
        assert (characteristic_points(hx.algorithm(letter, felt, 2000.0))
                == characteristic_points(hx.algorithm(letter, first, 2000.0))), letter


@pytest.mark.parametrize("name,rel_r,letters", [("egg-crate", 0.5, "BCG")] + [
    pytest.param(n, v, ls, marks=pytest.mark.long)
    for n, v, ls in [("grating", 0.95, "BCFG"), ("random", 0.9, "BCG"), ("egg-crate", 0.995, "BCG"),
                     ("egg-crate", 0.5, "DEF")]] + [  # (every letter on a map in the long set)
    _by_hand(n, v, ls)  # (the denser points, 0.3 to 0.995 rho on four maps)
    for n, v, ls in [("egg-crate", 0.3, "BCG"), ("egg-crate", 0.8, "BCG"),
                     ("egg-crate", 0.88, "BCFG"), ("grating", 0.5, "BCG"), ("grating", 0.9, "BCG"),
                     ("random", 0.5, "BCDEFG"), ("random", 0.8, "BCG"), ("egg-crate", 0.9, "BCG"),
                     ("egg-crate", 0.95, "BCG"), ("random", 0.95, "BCDG"), ("egg-crate", 0.99, "BCG"),
                     ("two-grating", 0.95, "BC"), ("two-grating", 0.98, "BC"), ("two-grating", 0.985, "BC"),
                     ("two-grating", 0.99, "BC"), ("two-grating", 0.995, "BC")]])
def test_q_of_every_algorithm_on_a_felt_map_below_the_troughs_radius_is_the_paths(name, rel_r, letters, shared):
    # issue 67's goal on areal maps: q of every algorithm on the felt surface within 1 % of q on
    # the brute-force ball path. B, C and G read the path's Hessian, which below the troughs'
    # radius rho is kappa / (1 - r kappa) at a trough (the offset surface's), a spike a few um
    # wide in the ball's position near rho; D its most convex curvature, kappa / (1 + r kappa)
    # at a crest. Truth: _areal_path_q (brute-force contacts, the path's Hessian from
    # differentiating the contact condition, the fields' Jacobians), itself checked against the
    # closed forms (the egg-crate's bowls and crests are umbilic, the grating's lines curve
    # across only): q of C = d_max kappa / (1 - r kappa) at a trough, q of D = d_max / (R -
    # d_max) below a crest of radius R = rho + r (infinite on the grating, R <= 1 mm); E is 1
    # (eq. 21). The felt maps (Hermite patches through the path's heights, gradients and twists
    # on REFINE's grids) read q of C on the egg-crate at 0.5, 0.8, 0.9, 0.95 rho +0.70, +3.8, -19,
    # -64 %, on the grating at 0.9 rho +2.5 %, q of D on the egg-crate at 0.5 rho +2.2 %
    # (2026-11-27's eighth session); now refined for the path's curvature (CURVATURE_SLACK):
    # C on the egg-crate +0.18, +0.12, +0.32, +0.67 % at 0.5, 0.8, 0.85, 0.88 rho, on the grating
    # +0.17, +0.73, +0.50, +0.29 % at 0.5, 0.8, 0.9, 0.95; D +0.26, +0.31 % at 0.3, 0.5 rho (0.5
    # run here; +0.51 % at 0.8, its search 144 s on the 640 x 640 map). The egg-crate at 0.9,
    # 0.92, 0.95 rho read C +1.1, +2.0, +4.2 % on grids doubled to 544-576 a side, the next past
    # the 640 x 640 cap; now each grid as much finer as the last miss says (the h^2 law,
    # surfaces._refined_sizes) within 768 x 768: +0.65 % at 0.9 (768 a side, run here), +0.39 %
    # at 0.88 (768), +0.18 % at 0.8 (528); 0.95 rho read +3.29 % on 760, now on graded axes
    # (surfaces._graded_refined: cells from 0.92 um where the path's curvature is within 2 % of
    # its largest, the bowls and the saddles' diagonal ridges) +0.51 % on 578 x 578 (run here;
    # failed before, 2026-11-28's second session). F reads
    # the path's heights and gradient (eq. 22, its modulation): within 0.02 % at 0.5, 0.88, 0.95
    # rho, where the analytic surfaces' own read -5.1 and -4.4 % at 0.5 (the test can fail); its
    # search took 565 s on the 576 x 576 map before the refined map kept its first grid's band
    # (the test above), now 4.7 s. The random map (six gratings, rho = 1 / its sup |kappa|, 0.64
    # mm): B, C, G +0.50, +0.61, +0.50 % at 0.5 rho, +0.24, +0.26, +0.24 % at 0.8; D +0.67 %, E,
    # F within 0.05 % at 0.5. At 0.9 and 0.95 rho read +0.90, +1.31, +0.90 % and +0.49,
    # +0.78, +0.49 % until q's search also started from the map's own steepest points (eleventh
    # session: its 256-cell plane grid had stepped over the maps' sharpest curvature), then B, C,
    # G +2.11, +1.87, +2.11 % and +2.67, +2.50, +2.67 % (448 and 424 a side, doubled grids); now
    # +0.76, +0.69, +0.76 % at 0.9 (768 a side, run here) and +0.31, +0.26, +0.31 % at 0.8 (504).
    # 0.95 rho read +3.34, +3.22, +3.34 % on 768 (+3.83 % on 640, +2.89 % on 848: not
    # monotone, the spike narrower than a cell); on graded axes +0.72, +0.70, +0.72 % on 338 x
    # 371 (run here; failed before). At 0.99 rho C read +3.96 % on graded axes of 697 x 697
    # (2026-11-29: the finest cells spanned the 85 um where the spike in the curvature across
    # each trough's line runs along it); with the finest cells only across the spike (their
    # width along each axis 1 / |e_a| times the finest, e the largest curvature's direction),
    # +0.85 % on 357 x 357 (surfaces._hot_intervals; run here, failed before); 0.95 rho then
    # +0.62 % on 276 x 276 and the random map +0.31 % on 350 x 364 (B +0.32 %). On two gratings
    # at 63 deg (troughs neither umbilic nor along the axes) at 0.95 rho, B and C +0.6 % on 762 x
    # 386 graded (run here; the oracle read -3 % there, -31 % at 0.99, until its nested grids
    # also started above the surface's most concave points, 2026-11-29). Not met on it at 0.98
    # and 0.99 rho: -3.4 and -24 % (the kept maps' peak_miss 20 and 15 %: their nodes and
    # centres sample the spike below its top). Tried: CURVATURE_REFINE_SAMPLES at 1,280 x 1,280
    # read the egg-crate at 0.9, 0.92, 0.95 rho +0.30, +0.61, +2.1 %, 21-24 s and up to 1.4 GB a
    # map; not kept, since design analyses the map band-limited to what the device renders, where
    # it cost that for nothing and left D and E out of the default time budget (768 a side: 7-9 s,
    # 610 MB). Above rho: the test below. D takes 29-31 s on the egg-crate's map at 0.5 rho (its
    # closest-point searches; E 1.0 s), 144 a side now (128 before: 144 the first grid within the
    # slack not steeper than the surface, surfaces.FELT_STEEP_TOLERANCE). Two gratings at 0.98 and
    # 0.985 rho read C -3.4 and +2.8 % (stated by the maps), 0.99 +0.45 % (2026-11-29): the graded
    # axes' finest cells went where the uniform map's nodes sampled the path's curvature within 2 % of
    # its top, but along a ridge at an angle to the axes the nodes fall on its flanks by turns, and
    # the fine band had gaps where the path is within 1 % of its top. Now also where contacts on a
    # grid of the surface see it (surfaces._hot_intervals; the spike is 1 / (1 - r kappa) times wider
    # in the contact than in the ball's position), graded maps up to 1,024 x 1,024 nodes: +0.91,
    # +0.72, +0.84 % (875 x 475, 949 x 552, 1,037 x 634; run here, 0.98 and 0.985 failed before,
    # 2026-11-29, later), 0.995 +1.78 % (1,127 x 778). Most of those nodes were the convex cells
    # (where the path is within 2 % of its most convex, D's), at the uniform grid's step (1.85 um,
    # refined for the troughs' spike) over 1 mm of a 2 mm axis; now as wide as the h^2 law says the
    # crest needs (surfaces._hot_intervals), up to 3 steps: +0.69, +0.79, +0.87, +0.98 % (510 x 338,
    # 581 x 410, 673 x 496, 946 x 848; 0.995 run here, failed before; 0.95 +0.80 % on 406 x 245 for
    # +0.55 % on 750 x 374), and the random map at 0.95 rho C +0.68 %, D +0.004 % (290 x 281; +0.31
    # and +0.0015 % on 350 x 364 with the convex cells at the uniform step; D run here). With the
    # graded axes also fine about the path's climbed tops where its spike runs across an axis
    # (surfaces._top_intervals: cells a tenth of the spike's half-width there, 46 and 9.5 nm at
    # the saddles), C on the egg-crate at 0.99 and 0.995 rho +0.62 and +0.73 % on 359 and 374 a
    # side (+0.85 and +0.89 % on 357 and 450 before, 2026-11-30; 0.995 run here), at 0.95 +0.61 %
    # on 276 (0.999: the test below). 10-90 s a case
    tex, h, grad, cell, rho = AREAL_CASES[name]
    r = rel_r * (rho or _TIGHTEST[name]())
    truth = _areal_path_q(h, grad, cell, r, letters=letters)
    if rho is not None:  # (the egg-crate's and grating's closed forms)
        assert truth["C"] == pytest.approx(max(1.0, 1e-3 / rho / (1 - rel_r)), rel=1e-4)  # the oracle at its troughs
        R = rho + r  # (the crests' radius, offset by the ball)
        assert truth["D"] == (math.inf if R <= 1e-3 else pytest.approx(max(1.0, 1e-3 / (R - 1e-3)), rel=1e-4))
    elif name == "two-grating":  # (its tightest trough nearly level: d_max kappa / (1 - r kappa) there;
        kappa = 1 / _TIGHTEST[name]()  # the path 0.09 % above it at 0.99 rho, 0.18 % at 0.995)
        assert truth["C"] == pytest.approx(1e-3 * kappa / (1 - r * kappa),
                                           rel=1e-3 if rel_r < 0.995 else 2.5e-3)
    felt = _felt_case(shared, name, r)
    for letter in letters:
        q = hx.characteristic_number(hx.algorithm(letter, felt, 2000.0)).value
        assert q == pytest.approx(truth.get(letter, 1.0), rel=0.01), letter


@pytest.mark.long
@pytest.mark.parametrize("name,rel_r", [_by_hand("grating", 2.0), _by_hand("egg-crate", 2.0), _by_hand("grating", 1.2),
                                        ("egg-crate", 1.2), _by_hand("egg-crate", 1.1), ("two-grating", 1.2)])
def test_q_on_a_felt_map_above_the_troughs_radius_is_the_paths(name, rel_r, shared):
    # issue 67's goal above the troughs' radius rho, where the ball bridges them: the path has
    # kinks (lines on the grating, the bowls' apexes on the egg-crate) and its curvature is
    # largest beside them, a one-sided limit; _areal_path_q's contacts are the brute force's
    # (the higher branch wherever two compete) and its nested grids close in on that limit. It is
    # checked here against the profile's oracle with the kinks' limits bisected (_path_q) on the
    # grating, an extruded sinusoid (measured: within 0.02 % at 1.2 and 2 rho). q of B, C, G on
    # the felt maps at 2 rho within 0.02 % (2026-11-27); nearer rho the grating at 1.2 rho read
    # +32 % (53 x 53), the egg-crate at 1.2 and 1.5 rho +650 and +5.9 % (27 and 23 a side). Now
    # the map is refined for its curvature as below rho, against the kinks' one-sided limits too
    # (surfaces._bridged_refined), and a node beside a kink keeps its own contact's twist:
    # measured (2026-11-27, tenth session) C on the grating at 1.1, 1.2, 1.5 rho -0.62, -0.44,
    # +0.37 % (928 x 58, 424 x 53, 86 x 43), the egg-crate at 1.2, 1.5, 3 rho +0.38 (+0.43 with
    # q's search from the map's steepest points, eleventh session), -0.04,
    # -0.04 % (216, 92, 46 a side); the egg-crate at 1.1 rho -13.7 % (58 a side; +134 % before),
    # where 44 % of the branches followed to the corners of its finer grids ran past the box that
    # keeps a contact on its branch (near a fold the contact runs 1 / (1 - r kappa) times as fast
    # as the ball): followed again by continuation (surfaces._continued_contacts), -0.28 % on
    # 464 x 464 (2026-11-27, eleventh session). Not met: the egg-crate at 1.05 rho, +3.26 % on
    # 304 a side (the map's curvature_miss 3.47 %; -5.06 % on 38 a side with every corner's
    # continuation in as many steps as the farthest source's). That +3.26 % was one node's
    # reading of a neighbour's branch where two patches tie (-19,367 1/m; see
    # test_at_its_nodes_a_felt_map_reads_a_limit_from_beside_them); with ties broken inside the
    # cell (2026-11-29) its grids from 38 to 608 a side state misses of 4.9, 25.9, 14.3, 12.1,
    # 6.7 % (q of C -5.03, -12.15, -6.68 % on 38, 304, 608) and the 38 is kept: the branch's
    # limit at the crease, near its fold, is not what cubic patches converge to as h^2. Two
    # gratings at 63 deg at 1.2 times their tightest radius (a crease along each trough of the
    # 30 um grating, at an angle to both axes, the hidden branch's fold 2.55 um past it) read q
    # of B, C, G +54, +54, +55 % (688 x 352, stated 56.5 %; 2026-11-30): in a cell the crease
    # crosses near a corner, the branch seen there is a patch through corners where it is hidden
    # near its fold (curvature 80,000 1/m and more) or gone (a tangent plane), 12,100 1/m in a
    # 46 nm sliver for the path's 7,800. With those corners from the branch's own grid
    # neighbour's second-order Taylor polynomial (surfaces._branch_patches' fold, tried where the
    # first way misses): +0.05, -0.02, +0.05 % (688 x 352, stated 1.05 %; failed before). The
    # oracle there took the lower branch within ~300 nm of the crease (the brute force's grid
    # error), reading C 7.99 for 7.85, until its rival branch was polished too. 20-70 s a case
    tex, h, grad, cell, rho = AREAL_CASES[name]
    rho = rho or _TIGHTEST[name]()
    truth = _areal_path_q(h, grad, cell, rel_r * rho, letters="BCG")
    if name == "grating":
        line = _path_q((0.2e-3,), (2e-3,), (0.0,), 2e-3, rel_r * rho)
        for letter in "BCG":
            assert truth[letter] == pytest.approx(line[letter], rel=1e-3), letter
    felt = _felt_case(shared, name, rel_r * rho)
    assert len(felt.kinks) > 0  # (the ball bridges)
    for letter in "BCG":
        q = hx.characteristic_number(hx.algorithm(letter, felt, 2000.0)).value
        assert q == pytest.approx(truth[letter], rel=0.01), letter


@pytest.mark.long
@pytest.mark.parametrize("name,rel_r", [("egg-crate", 0.95), _by_hand("egg-crate", 1.02), _by_hand("egg-crate", 1.03),
                                        _by_hand("egg-crate", 1.05), _by_hand("egg-crate", 1.065), _by_hand("egg-crate", 1.08),
                                        _by_hand("random", 0.95)])
def test_a_felt_maps_curvature_miss_bounds_its_q(name, rel_r, capsys, shared):
    # Where the refinement for curvature stops short of its slack (at its cap, or where finer
    # grids did worse), the map says by how much (curvature_miss, a fraction of the path's
    # largest curvature; peak_miss the part of it the largest can see), and q of B, C and G,
    # which read the largest, is then within about peak_miss of the path's. Truth:
    # _areal_path_q, the brute-force oracle. At 0.95 rho the maps are now on graded axes: q of C
    # +0.51 and +0.70 % (2026-11-28's second session), their curvature_miss 8.9 and 3.9 %, where
    # the curvature along the egg-crate saddles' ridges between the finest cells is short, but
    # not at the sup. Measured (2026-11-27,
    # eleventh session): q of C +4.18, +3.26, +2.50 % where the maps said 4.18, 3.47 and 10.7 %
    # (the egg-crate's bowls at 0.9 and 1.2 times +1.10 and +0.43 % for 1.10 and 0.53 %, the
    # random map at 0.9 +1.87 % for 2.21 %); with the grids refined by the h^2 law within 768 x
    # 768 (2026-11-28) +3.29 and +3.22 % at 0.95 where the maps say 3.29 and 4.74 %, +0.65 and
    # +0.69 % at 0.9 for 0.65 and 0.79 %. design reports it (JSON) and prints it where it passes
    # CURVATURE_SLACK and design analyses the felt texture itself; not where it analyses it
    # band-limited to the device's cut-off (0.125 mm for the omega.3 at 0.1 m/s: the spike is a
    # few um wide). Measured: q of B and C on the band-limited texture 5.2954 from the map
    # refined to 760 a side (its miss 3.3 %), 5.3101 from the felt map on 128 a side, 5.388 on 64:
    # 0.28 % apart where the message said 3.3 % (2026-11-28). Just above the egg-crate's bowls'
    # radius the maps miss the path by far more (issue 67's goal not met there: q of C -54, -12,
    # -5, -5, +19, -21, -19, +23 % at 1.03, 1.04, 1.05, 1.06, 1.065, 1.07, 1.075, 1.08 times,
    # 2026-12-01), and say so: 1.03, 1.065 and 1.08 here, the largest short and over
    tex, h, grad, cell, rho = AREAL_CASES[name]
    r = rel_r * (rho or _TIGHTEST[name]())
    felt = _felt_case(shared, name, r)
    truth = _areal_path_q(h, grad, cell, r, letters="C")["C"]
    said = hx.characteristic_number(hx.algorithm("C", felt, 2000.0))
    q = said.value
    assert felt.curvature_miss is not None and felt.peak_miss <= felt.curvature_miss
    if (name, rel_r) != ("egg-crate", 1.02):
        assert abs(q / truth - 1) <= felt.peak_miss + 0.005
    if felt.peak_miss > 0.01:  # (and q's note says so: on the egg-crate at 1.05 rho, 4.88 %; 3.47 % before 2026-11-29)
        assert f"misses the ball path's by {felt.peak_miss:.3g} of it (peak_miss)" in said.note
    # Where the map's largest curvature is short of the path's largest found (path_curvature,
    # its samples: a lower bound of the path's sup), a fraction under 1 hides how far: just above
    # the egg-crate's bowls' radius, at 1.02 times, the map's largest is 98.2 % short of the
    # path's found, and the note said q on the path "may differ from this one by about as much"
    # where the oracle's q of C is 22,000 times the map's (1.67e6 for 75.8; 2026-12-01). The note
    # gives the ratio now, q on the path that many times the map's or more: the oracle's at least
    # that (within 0.5 %); 1.0534 at 1.05 times for the oracle's 1.0529, 56.2 at 1.02
    if felt.peak_miss > 0.01 and felt.max_curvature < felt.path_curvature:
        factor = felt.path_curvature / felt.max_curvature
        assert truth / q >= factor * (1 - 0.005)
        assert f"the path's largest found is {factor:.3g} times the felt texture's" in said.note
    if (name, rel_r) == ("egg-crate", 1.02):  # design says it too, where it analyses the felt texture itself
        from haptex.cli import main

        assert main(["design", "--texture", "egg-crate:0.1mm,2mm", "--device", "omega-3", "--tip-radius",
                     f"{r * 1e3:.17g}mm", "--algorithms", "C", "--speed", "0.001m/s", "--quiet"]) == 0
        out = " ".join(capsys.readouterr().out.split())
        assert "felt texture is analysed below" in out  # (at 1 mm/s the device renders its 0.065 mm periods)
        assert (f"the path's largest found is {felt.path_curvature / felt.max_curvature:.3g} times the felt "
                "texture's, so B's, C's and G's q on the ideal path may be as many times the q below or more") in out
        assert "creases of kinks end" not in out  # (none: the test above)
    if (name, rel_r) == ("egg-crate", 0.95):
        import json

        from haptex.cli import main

        args = ["design", "--texture", "egg-crate:0.1mm,2mm", "--device", "omega-3", "--tip-radius",
                f"{r * 1e3:.17g}mm", "--algorithms", "A"]  # (the same ball: its graded axes follow r)
        assert main(args + ["--json", "--quiet"]) == 0
        said = json.loads(capsys.readouterr().out)
        assert said["felt_by_tip"]["curvature_miss"] == pytest.approx(felt.curvature_miss, rel=1e-3)
        assert said["felt_by_tip"]["peak_miss"] == pytest.approx(felt.peak_miss, rel=1e-3)
        assert said["felt_by_tip"]["convex_miss"] == pytest.approx(felt.convex_miss, rel=1e-3)
        assert said["felt_by_tip"]["path_curvature"] == pytest.approx(felt.path_curvature, rel=1e-3)
        assert said["felt_by_tip"]["turn"] == pytest.approx(math.pi / 4)  # (its map on axes along the gratings)
        # (the cut-off far longer than the spike, a few um wide: 20 times the 760 grid's step)
        assert said["band_limit"]["applied"] and said["band_limit"]["cutoff"] > 20 * 2e-3 / 760
        assert main(args + ["--quiet"]) == 0
        out = " ".join(capsys.readouterr().out.split())
        assert "felt by a ball of r" in out
        assert "the felt map's cells run along the texture's gratings, turned 45 deg from x" in out
        assert "the felt texture's curvature misses" not in out  # (not in the band-limited texture it analyses)


def _q_of_c_and_the_paths(name, rel_r, closed=1e-3):
    """(q of C on the felt map, q of C on the brute-force ball path, the felt map) of an
    AREAL_CASES texture at rel_r times its tightest radius rho, the path's (_areal_path_q)
    asserted within ``closed`` (relative) of its closed form at that trough, d_max kappa / (1 -
    r kappa) (the egg-crate's bowls umbilic, the two gratings' tightest trough nearly level:
    the path's 0.09 % above it at 0.99 times, 0.18 % at 0.995, measured 2026-11-29)."""
    tex, h, grad, cell, rho = AREAL_CASES[name]
    rho = rho or _TIGHTEST[name]()
    truth = _areal_path_q(h, grad, cell, rel_r * rho, letters="C")["C"]
    assert truth == pytest.approx(1e-3 / rho / (1 - rel_r), rel=closed)
    felt = tex.felt_by(rel_r * rho)
    return hx.characteristic_number(hx.algorithm("C", felt, 2000.0)).value, truth, felt


@pytest.mark.long
def test_within_a_thousandth_of_the_bowls_radius_q_on_the_felt_map_is_the_paths():
    # issue 67's goal at 0.999 times the egg-crate's bowls' radius, where the path's curvature
    # spike is 1,000 times the bowls' own: at the saddles of the map's turned cell only about 10
    # nm wide across the troughs' lines (half its top 10 nm from it), about 400 nm at the bowls.
    # The refinement kept, before 2026-11-30, the graded map 424 x 424 with cells from 15 nm:
    # +1.76 % (its peak_miss 1.75 %; the code before 2026-11-29 kept one at -32.6 %), finer graded
    # maps overshooting more (+4.1 % with cells from 9 nm), as a cubic patch's curvature, linear
    # across a cell, cannot follow a spike narrower than two cells. The graded axes are now also
    # fine about each of the path's climbed tops (surfaces._top_intervals: a tenth of the spike's
    # half-width there, where the spike runs across an axis): the first graded map, 448 x 448
    # with cells from 1 nm, meets the slack, q of C +0.38 % (measured 2026-11-30; the bound
    # asserted is the issue's 1 %). Truth: _areal_path_q, checked against its closed form d_max
    # kappa / (1 - r kappa) at the troughs (within 1e-3 there; 1.6e-5 measured). ~25 s
    q, truth, felt = _q_of_c_and_the_paths("egg-crate", 0.999)
    assert min(np.diff(felt.knots[0]).min(), np.diff(felt.knots[1]).min()) < 5e-9  # (the premise: cells finer than the spike)
    assert q == pytest.approx(truth, rel=0.01)
    assert felt.peak_miss <= 0.01


@pytest.mark.long
@pytest.mark.parametrize("rel_r,closed", [_by_hand(0.9975, 4e-3), (0.999, 1e-2)])
def test_where_the_spike_runs_at_an_angle_to_the_axes_the_stated_peak_miss_is_qs(rel_r, closed):
    # On two gratings at 63 deg at 0.98 times their tightest radius the path's curvature spike
    # runs at an angle to both axes: no map within the cap meets the slack (uniform or graded),
    # and the kept one's q of C is short of the path's. The map says by how much (peak_miss, the
    # part of its curvature miss q of B, C, G read), against the path's largest curvature: taken
    # at its nodes and cells' centres alone, which sample the spike below its top, it said 20.4 %
    # where q of C read -3.4 % (a centre on the spike's flank counted as near the largest), and at
    # 0.99 times 15.3 % where q read -23.8 % (2026-11-29). The path's largest is climbed from its
    # largest samples now, and the maps are ranked by what they state: at 0.98 the same map
    # states 3.4 %; at 0.99 a graded map is kept that meets the slack (the q test above). Over
    # the neighbourhood: at 0.995 times a uniform 832 x 416 map was kept that stated 40 % where q
    # read -49 % (each map stated against its own climbed top, which on a graded map 2 % short
    # of the path's stopped under its own largest; the least curvature miss ranked before the
    # least peak miss); at 0.985 -11 % (stated 11 %). Truth: _areal_path_q (nested grids above
    # the most concave points), asserted within 4e-3 and 1e-2 of the closed form d_max kappa /
    # (1 - r kappa) at the tightest trough (nearly level: the path above it by 0.36 % at 0.9975 and
    # 0.90 % at 0.999, measured 2026-11-29). Since the graded axes' fine band follows the ridge
    # where contacts see it (2026-11-29, later), 0.98 to 0.995 rho meet the slack (the q test
    # above); at 0.9975 and 0.999 none does: stated 2.60 and 28.7 % for q's +2.34 and -28.7 %
    q, truth, felt = _q_of_c_and_the_paths("two-grating", rel_r, closed)
    assert felt.peak_miss > 0.01  # (the premise: no map met the slack)
    assert abs(abs(q / truth - 1) - felt.peak_miss) <= 0.005, (q / truth - 1, felt.peak_miss)


@pytest.mark.long
def test_a_felt_maps_convex_miss_bounds_q_of_d():
    # q of D reads the path's most convex curvature 1 / R (eq. 18: d_max / (R - d_max) below
    # it): a map whose most convex curvature is m times more than the path's reads q off by
    # m (1 + q), q its own. On the egg-crate the path's most convex points are its crests and
    # its saddles, where the concave spike kappa / (1 - r kappa) crosses the convex direction:
    # at 0.9 times the bowls' radius the refined map (768 a side) reads 535.3 1/m at a saddle
    # against the path's 519.5, q of D +6.52 % (+3.07 % at 0.88 times; 2026-11-28), its
    # convex_miss 3.0 % (1.4 %) where its curvature_miss (what B, C, G read) says 0.65 %
    # (0.39 %); at 0.8 times +0.75 % (528 a side; its convex miss 0.37 %), on the random map
    # at 0.9 times +0.00 % (its crests away from the spikes; 0.10 %). The map states that miss
    # (convex_miss), design's JSON carries it (the test above). The egg-crate's own map is now
    # on axes along its gratings, where the miss is 0.001 % (the test below it); here with a
    # grating along x of 1 nm (1e-5 of its amplitude: q moves by about that), whose wave vector
    # is off those axes, so that its map stays on the plane's. Truth: _areal_path_q on the
    # egg-crate, D's closed form d_max / (R - d_max), R = rho + r at the crests (asserted). ~55 s
    egg, h, grad, cell, rho = AREAL_CASES["egg-crate"]
    tex = hx.SumOfGratings(np.r_[egg.amplitudes, 1e-9], np.r_[egg.periods, 2e-3], np.r_[egg.directions, 0.0],
                           np.r_[egg.phases, 0.0])
    assert tex.felt_turn == 0.0 and egg.felt_turn == pytest.approx(math.pi / 4)
    r = 0.9 * rho
    truth = _areal_path_q(h, grad, cell, r, letters="D")["D"]
    assert truth == pytest.approx(1e-3 / (rho + r - 1e-3), rel=1e-4)
    felt = tex.felt_by(r)
    said = hx.characteristic_number(hx.algorithm("D", felt, 2000.0))
    q = said.value
    assert abs(q / truth - 1) > 0.01  # (the case the statement is for: the test can fail)
    assert felt.convex_miss is not None and felt.convex_miss > felt.curvature_miss
    assert abs(q / truth - 1) <= felt.convex_miss * (1 + q) + 0.005
    # (and q's note says by how much, and how far q on the path may then be: here 3.0 % of the
    # most convex curvature, so about 0.03 (1 + q) of q)
    assert f"misses the ball path's by {felt.convex_miss:.3g} of it (convex_miss)" in said.note
    assert f"by about {felt.convex_miss * (1 + q):.3g} of it" in said.note


@pytest.mark.long
@pytest.mark.parametrize("rel_r", [0.95])
def test_on_axes_along_its_gratings_q_of_d_on_the_felt_egg_crate_is_the_paths(rel_r, shared):
    # issue 67's goal for D on the egg-crate near its bowls' radius: q of D, d_max / (R - d_max)
    # below the path's most convex point of radius R (eq. 18), within 1 % of the path's. On the
    # plane's axes the map's most convex curvature, at the saddles where the concave spike
    # kappa / (1 - r kappa) crosses the convex direction diagonally through its cells, read
    # +6.52 % at 0.9 rho and 58.5 for 1.025 at 0.95 (convex_miss 3.0 and 176 %, 2026-11-28).
    # On axes along the gratings (felt_turn) the ridges run along the cells' sides. Truth: D's
    # closed form at the crests, R = rho + r (the egg-crate's crests are umbilic, of radius rho;
    # the oracle _areal_path_q reads the same, asserted in the test above). Measured
    # (2026-11-29): +0.000 and +0.003 % at 0.9 and 0.95 (1.080963 and 1.024872 for 1.080961 and
    # 1.024839); 0.9 not run here (136 s). ~80-210 s
    tex, h, grad, cell, rho = AREAL_CASES["egg-crate"]
    r = rel_r * rho
    truth = 1e-3 / (rho + r - 1e-3)
    felt = _felt_case(shared, "egg-crate", r)
    assert felt.turn == pytest.approx(math.pi / 4)
    assert felt.convex_miss < 0.01
    said = hx.characteristic_number(hx.algorithm("D", felt, 2000.0))
    assert said.value == pytest.approx(truth, rel=0.01)
    assert "convex_miss" not in said.note


@pytest.mark.long
def test_just_above_the_troughs_radius_a_felt_grating_kinks_only_at_its_troughs():
    # A ball bridges a surface between two contacts only where the section through them curves
    # more than the ball (a circle of radius at most r tangent from above at both). Just above
    # the troughs' radius rho the contact also runs fast beside each trough (1 / (1 - r kappa)
    # times the ball), more than BRANCH_JUMP intervals an interval on a fine grid, where the path
    # is smooth; the felt grating at 1.1 rho, refined to 928 x 58, named 812 kinks on 14 lines
    # 1,486-1,514 um, each cell there branched (2026-11-27). Truth: the geometry, the grating
    # h = A sin(2 pi x / l) bridged only across its trough line x = 3 l / 4 = 1.5 mm, once a row
    tex, _, _, _, rho = AREAL_CASES["grating"]
    felt = tex.felt_by(1.1 * rho)
    assert len(felt.kinks) == felt.y.size
    assert np.all(np.abs(felt.kinks[:, 0] - 1.5e-3) <= 0.5 * felt.dx + 1e-12)  # (the kinked edge holds it)


@pytest.mark.long
@pytest.mark.parametrize("rel_r", [_by_hand(1.2), 1.5])
def test_a_felt_map_names_where_a_crease_ends(rel_r, monkeypatch, capsys, shared):
    # A crease (a line of kinks, where two branches of the contact tie) can end inside the map:
    # there the two branches merge at a fold and the path's curvature grows without bound, so q
    # of B, C and G on the ball's ideal path is unbounded near it (stop 87's random map). Truth:
    # a grating whose amplitude fades along its lines, A (1 + cos(2 pi y / L_y) / 2) sin(2 pi x
    # / l) (three gratings, numpy's identity), bridged by a ball of r = rel_r / (A k^2) only where
    # its trough's radius 1 / (A w(y) k^2) is below r: along x = 3 l / 4, for |y| < y* =
    # L_y acos(2 (1 / rel_r - 1)) / (2 pi) (the section's curvature alone; the surface's own
    # curvature along y, at most 4 % of that across, moves the end by less than an interval).
    # So one crease a cell, two ends, at (3 l / 4, +-y*); the grating's and the egg-crate's
    # creases (lines and rings) end nowhere. Measured: ends at y = 2.377 mm for y* = 2.433 mm at
    # 1.2, 2.871 for 2.929 mm at 1.5 (27 x 106 and 22 x 85 a cell)
    A, l, Ly = 0.1e-3, 2e-3, 8e-3
    k, kp = 2 * np.pi / l, 2 * np.pi / Ly
    slant = 2 * np.pi / math.hypot(k, kp)
    tex = hx.SumOfGratings([A, A / 4, A / 4], [l, slant, slant], [0.0, math.atan2(kp, k), math.atan2(-kp, k)])
    xy = np.random.default_rng(3).uniform(0, 8e-3, (50, 2))  # (the three gratings are the faded one)
    np.testing.assert_allclose(tex.height_at(xy), A * (1 + np.cos(kp * xy[:, 1]) / 2) * np.sin(k * xy[:, 0]),
                               atol=1e-12 * A)
    felt = tex.felt_by(rel_r / (A * k * k))
    ends = felt.crease_ends
    ystar = Ly * math.acos(2 * (1 / rel_r - 1)) / (2 * np.pi)
    assert ends.shape == (2, 2)
    assert np.all(np.abs(ends[:, 0] - 0.75 * l) <= felt.dx)
    assert np.sort(np.abs((ends[:, 1] + Ly / 2) % Ly - Ly / 2)) == pytest.approx([ystar, ystar], abs=2 * felt.dy)
    for name in ("grating", "egg-crate"):
        closed = _felt_case(shared, name, rel_r * AREAL_CASES[name][4])
        assert len(closed.kinks) > 0 and closed.crease_ends.shape == (0, 2)
    if rel_r == 1.2:  # design names them (the faded grating given in place of a spec's texture)
        import importlib
        import json

        from haptex.cli import main

        monkeypatch.setattr(importlib.import_module("haptex.cli.design"), "_texture_from_spec", lambda *a, **kw: tex)
        args = ["design", "--texture", "egg-crate:0.1mm,2mm", "--device", "omega-3", "--tip-radius",
                f"{rel_r / (A * k * k) * 1e3:.6f}mm", "--algorithms", "A"]
        assert main(args + ["--json", "--quiet"]) == 0
        said = json.loads(capsys.readouterr().out)["felt_by_tip"]
        assert said["crease_end_count"] == 2 and said["crease_ends"][0]["x"] == pytest.approx(0.75 * l, abs=felt.dx)
        assert main(args + ["--quiet"]) == 0
        assert "creases of kinks end at 2 places inside the map" in " ".join(capsys.readouterr().out.split())


@pytest.mark.long
@pytest.mark.parametrize("rel_r", [1.01, 1.015, _by_hand(1.02), _by_hand(1.03), 1.05, _by_hand(1.07)])
def test_just_above_its_bowls_radius_the_egg_crates_creases_end_nowhere(rel_r, shared):
    # Just above the egg-crate's bowls' radius rho the ball bridges each bowl and each saddle's
    # concave direction (its curvature there 1 / rho too): its creases run along the diagonals
    # from bowl to saddle to bowl, where they meet, and end nowhere, so the ideal path's
    # curvature is bounded and design must not say that q of B, C and G is unbounded. Truth, by
    # brute force (numpy alone): at centres on the diagonal from the bowl at (1.5, 0.5) mm to the
    # saddle at (2, 1) mm, a hair off it, the ball's highest contact on a 4 um lattice of its
    # disc and that contact's mirror image in the diagonal (the other branch, by symmetry) lie
    # more than 10 lattice steps apart all the way (no end, where they would merge; measured: at
    # least 20, 29, 45, 91, 164 and 221 um at 1.01, 1.015, 1.02, 1.03, 1.05 and 1.07 rho, on a 1
    # um lattice below 1.02, 4 um above). The felt maps named
    # 16, 8 and 4 crease ends over the 2 mm cell at 1.02, 1.03, 1.05 rho (2026-12-01; 108 at 1.01):
    # cells with a single kinked edge where a diagonal crease passes through a grid node on its way
    # to the meeting point (another kinked edge ending at the cell's corner); then still 20 and 10
    # at 1.01 and 1.015 (2026-12-01, later), where the crease's two contacts part by less than
    # BRANCH_JUMP's 3 intervals near the bowls, or along a chord at an angle to the diagonal
    # (two grid points' contacts, not one ball's) whose own section the ball does not bridge, so
    # that some of its edges are no kinks (surfaces._ending). 5 s a case
    tex, h, grad, cell, rho = AREAL_CASES["egg-crate"]
    r = rel_r * rho
    step = 1e-6 if rel_r < 1.02 else 4e-6
    g = np.arange(-r, r + step / 2, step)
    U = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    U = U[np.sum(U * U, axis=1) < r * r]
    cap = np.sqrt(r * r - np.sum(U * U, axis=1))
    bowl = np.array([1.5e-3, 0.5e-3])
    assert h(bowl[None])[0] == pytest.approx(-0.1e-3)
    for d in np.linspace(0.05, 0.95, 7) * math.hypot(0.5e-3, 0.5e-3):
        p = bowl + d * np.array([1.0, 1.0]) / math.sqrt(2) + [1e-7, -1e-7]
        c = p + U[np.argmax(h(p + U) + cap)] - bowl
        assert math.hypot(c[0] - c[1], c[1] - c[0]) > 10 * step, d
    felt = _felt_case(shared, "egg-crate", r)
    assert len(felt.kinks) > 0
    assert felt.crease_ends.shape == (0, 2), felt.crease_ends


@pytest.mark.long
def test_on_a_measured_map_the_ring_where_the_ball_leaves_an_asperity_ends_nowhere():
    # metropro-1.dat (the instrument's file) felt by a 5 um ball: two kinked edges, where the ball
    # leaves the asperity it pivots on (its highest sample within 4 intervals of them) for the
    # ground around it. Truth by brute force (the ball's highest contact on a 0.04 um lattice of
    # its disc, the map's own spline the only thing of haptex's; scipy's connected components):
    # at centres a quarter interval apart about the asperity, those joined to the centre above
    # its top by steps whose contacts move by an interval at most (the contact followed
    # continuously) are a closed patch where the ball pivots on the top, not reaching the
    # window's edge: wherever the ball leaves it the contact jumps (by about two intervals), a
    # ring of kinks that ends nowhere. The felt map named 4 crease ends there (2026-12-01: the
    # ring's other edges part by under BRANCH_JUMP's 3 intervals, so only two were kinks); 6 s
    from pathlib import Path

    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    tex = hx.load_texture(Path(__file__).parents[1] / "examples" / "data" / "metropro-1.dat")
    r, dx = 5e-6, float(tex.x[1] - tex.x[0])
    felt = tex.felt_by(r)
    assert len(felt.kinks) == 2
    i0, j0 = np.round((felt.kinks[:, :2].mean(axis=0) - [tex.x[0], tex.y[0]]) / dx).astype(int)
    a, b = np.unravel_index(np.argmax(tex.h[i0 - 4:i0 + 5, j0 - 4:j0 + 5]), (9, 9))
    top = np.array([tex.x[i0 - 4 + a], tex.y[j0 - 4 + b]])
    g = np.arange(-r, r, 0.04e-6)
    U = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    U = U[np.sum(U * U, axis=1) < r * r]
    cap = np.sqrt(r * r - np.sum(U * U, axis=1))
    s = np.arange(-4, 4.01, 0.25) * dx
    C = np.array([[p + U[np.argmax(tex.height_at(p + U) + cap)] for p in top + np.stack([np.full_like(s, sx), s], -1)]
                  for sx in s])
    n = len(s)
    idx = np.arange(n * n).reshape(n, n)
    pairs = [(idx[:-1], idx[1:], np.linalg.norm(np.diff(C, axis=0), axis=-1)),
             (idx[:, :-1], idx[:, 1:], np.linalg.norm(np.diff(C, axis=1), axis=-1))]
    a_, b_ = (np.concatenate([p[k][p[2] <= dx].ravel() for p in pairs]) for k in (0, 1))
    _, label = connected_components(coo_matrix((np.ones(a_.size), (a_, b_)), shape=(n * n, n * n)), directed=False)
    patch = (label == label[idx[n // 2, n // 2]]).reshape(n, n)
    assert np.linalg.norm(C[n // 2, n // 2] - top) < 0.1 * dx  # (the ball above the top rests on it)
    assert 20 <= patch.sum() and not (patch[[0, -1]].any() or patch[:, [0, -1]].any())  # (closed)
    assert felt.crease_ends.shape == (0, 2), felt.crease_ends


@pytest.mark.parametrize("rel_r", [2.0, pytest.param(1.5, marks=pytest.mark.long)])
def test_where_the_ball_bridges_a_bowl_the_felt_map_is_the_paths(rel_r):
    # issue 67's last case: over a bowl (the egg-crate's troughs) wider than the ball's
    # curvature the ball rests on the bowl's rim, on one side or another, and the path has an
    # apex whose slope is the same in every direction around it; no tensor-product patch on the
    # grid follows it (at a corner whose two edges both rise at slope M the patch's gradient is
    # (M, M)): the single Hermite patch read 0.381 for the brute-force path's 0.302 at r = 2 rho,
    # its heights 6.2 um off inside the bowls. A cell across which the contact jumps is the
    # maximum of one patch a contact (JOINS_BRANCHED): slope (and q, at 1.5 rho) within 1 % of
    # the brute-force path's (numpy on the analytic heights; measured +0.19 % at 2 rho, +0.005 %
    # at 1.5 rho, where the first grid, 23 points a period, now branches; +0.05 % before, on the
    # finer grid it needed), and
    # at r = 2 rho the heights at 200 points inside the bowls between the dense dilation's (its
    # 201 x 201 offsets) and that plus its grid's miss, (du / 2)^2 / 2 (sup ||H|| + 1 / r)
    # (measured -0.005 to +0.100 um; the miss 0.152 um)
    tex, h, grad, cell, rho = AREAL_CASES["egg-crate"]
    r = rel_r * rho
    felt = tex.felt_by(r)
    truth = _path_max_slope_2d(h, grad, cell, r)
    # (every cell beside a kink branched, none left with its single patch: 88 of them)
    assert felt.patches()[0, hx.core._ext.PATCH_JOINS] == hx.core._ext.JOINS_BRANCHED
    assert felt.branched_cells > 0 and hx.surfaces._single_kink_cells(felt) == 0
    # (the path's steepest is the surface's own here, 0.3142 at 1.5 rho: the branches' cubic
    # Hermite error may pass it by up to STEEP_SLACK, which the construction checks)
    assert felt.max_slope <= tex.max_slope * (1 + hx.surfaces.STEEP_SLACK)
    assert felt.max_slope == pytest.approx(truth, rel=0.01)
    if rel_r != 2.0:  # (q on a branched map, 1.7 s, in the long set's case; the loop's has the heights)
        q = hx.characteristic_number(hx.algorithm("A", felt, 2000.0)).value
        assert q == pytest.approx(math.sqrt(1 + truth**2), rel=0.01)
    if rel_r == 2.0:
        rng = np.random.default_rng(7)
        bowls = np.array([[0.5e-3, 1.5e-3], [1.5e-3, 0.5e-3]])[rng.integers(0, 2, 200)]
        pts = bowls + rng.uniform(-0.25e-3, 0.25e-3, (200, 2))
        ref = _dense_dilation(tex, pts, r, n=201)
        miss = (2 * r / 200) ** 2 / 4 * (tex.max_curvature + 1 / r)
        got = felt.height_at(pts)
        assert np.all(got >= ref - 0.02e-6) and np.all(got <= ref + miss), (np.min(got - ref), np.max(got - ref))


def _bounded_path_max_slope(h, side, r, n=41):
    """The steepest slope of the ball's centre path over the square map [0, side]^2 of a surface
    that ends at its edges, by brute force: at each point of an n x n grid (and then of an
    11 x 11 grid a twentieth as wide around each of its four steepest), the arg-max u* of
    h(p + u) + sqrt(r^2 - |u|^2) over offsets in the disc with p + u on the map (a 61 x 61 grid,
    refined three times on 21 x 21 grids a tenth as wide each), and the path's gradient
    u* / sqrt(r^2 - |u*|^2) (the envelope theorem: the map's edge does not move with p, so this
    holds where the ball rests on the map's rim as well as inside, where it is grad h). numpy
    on the analytic heights; nothing of haptex's."""
    def slopes(pts):
        best = _brute_argmax_2d(h, pts, r, 61, refinements=3, side=side)
        return np.linalg.norm(best, axis=1) / np.sqrt(r * r - np.sum(best * best, axis=1))

    g = np.linspace(0, side, n)
    P = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    s = slopes(P)
    best = float(s.max())
    for k in np.argsort(s)[-4:]:
        w = np.linspace(-side / (n - 1), side / (n - 1), 11)
        Q = np.clip(P[k] + np.stack(np.meshgrid(w, w, indexing="ij"), -1).reshape(-1, 2), 0.0, side)
        best = max(best, float(slopes(Q).max()))
    return best


def _sampled_egg_crate(n, periodic):
    """The egg-crate of AREAL_CASES sampled by numpy over 4 mm, n x n: ending at its edges
    (samples at both) or periodic (n samples a cell)."""
    xs = np.linspace(0.0, 4e-3, n) if not periodic else np.arange(n) * (4e-3 / n)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    h = AREAL_CASES["egg-crate"][1](np.column_stack([X.ravel(), Y.ravel()])).reshape(X.shape)
    return hx.SampledSurface(xs, xs, h, periodic=periodic)


@pytest.mark.parametrize("r", [2e-3, 0.1e-3, pytest.param(1.5e-3, marks=pytest.mark.long),
                               pytest.param(0.3e-3, marks=pytest.mark.long)])
def test_on_a_map_that_ends_at_its_edges_the_felt_bowls_are_the_paths(r):
    # issue 67 on a measured map's terms: the egg-crate's heights sampled 61 x 61 over 4 mm and
    # ending there (not periodic), its bowls' radius of curvature rho = 1.01 mm, felt by balls of
    # 1.5 and 2 mm. Near the map's edges the ball rests on its rim (its contact on the
    # rectangle's edge, where the path's gradient is u / sqrt(r^2 - |u|^2), not grad h) and the
    # branches that follow such contacts stalled short of them; a grid point's own search could
    # also keep the lower of two rim contacts. Every cell then kept its single patch: 0.4152 at
    # 2 mm, 0.4407 at 1.5 mm for the brute-force path's 0.3039 and 0.3141. The felt map's
    # steepest slope within 1 % of the brute-force path's (numpy on the analytic heights, with
    # the contacts on the map), and never above the surface's own (0.1 pi) by more than 0.1 %.
    # Balls of 0.1 and 0.3 mm, inside the bowls' radius, pass from resting on the map's rim to
    # resting inside it near the edges, where the path's curvature jumps: with the rim's true
    # gradients the cubics through them overshot, 0.3315 and 0.3226 (their edges there are now
    # moved as a kink's)
    side, h = 4e-3, AREAL_CASES["egg-crate"][1]
    felt = _sampled_egg_crate(61, periodic=False).felt_by(r)
    truth = _bounded_path_max_slope(h, side, r)
    if r > 1e-3:
        assert felt.branched_cells > 400  # (of the map's 3600: around every bowl)
    assert felt.max_slope <= 0.1e-3 * math.pi / 1e-3 * (1 + 1e-3)
    assert felt.max_slope == pytest.approx(truth, rel=0.01)


@pytest.mark.parametrize("r", [1.2e-3, pytest.param(1.1e-3, marks=pytest.mark.long),
                               pytest.param(1.3e-3, marks=pytest.mark.long),
                               pytest.param(1.0e-3, marks=pytest.mark.long)])
def test_on_a_map_that_ends_at_its_edges_a_nesting_ball_feels_the_paths_slope(r):
    # the bounded egg-crate map of the test above felt by balls that nest in its bowls (1.1-1.3
    # times their 1.01 mm radius), against the same brute-force path (numpy, contacts on the map).
    # Where the ball passes from the map's rim to its inside, the edge's slopes were moved as a
    # kink's (stop 74) also beside cells the contact jumps across: their branches, through the
    # contacts' own slopes, then parted from those edges, and the continuity check unbranched
    # every cell of the map's one cluster: 0.3605, 0.4120, 0.4196 at 1.1, 1.2, 1.3 mm for the
    # path's 0.3140 (+15 to +34 %). Then +2.89, +3.15, +1.25 % (on the map's own grid):
    # at a bowl's bottom, the apex of a cone, each contact on the ring the ball rests on is a
    # branch that is there at two of its cell's four corners only, and at the other two its
    # patch took its source's tangent plane (up to 6 intervals away), whose heights the corners'
    # slopes do not join: the cubic between them reached 0.3236 where the path's steepest is
    # 0.3141. Such a corner now takes the branch's tangent plane one grid step toward its
    # source, where it is there: +0.35, +0.34, +0.48 %. At 1.0 mm, the bowls' radius, +1.09 %
    # (few cells branched), then +1.35 % (all branched, the rough maps' changes): where that
    # plane stood above the path at the corner it kept its slope, crossing the path there; it
    # takes the path's own height and gradient there now: -0.04 %. Within 1 % of the path
    # (issue 67's goal) and never steeper than the surface (0.1 pi) by more than the
    # construction's STEEP_SLACK
    side, h = 4e-3, AREAL_CASES["egg-crate"][1]
    surface = _sampled_egg_crate(61, periodic=False)
    felt = surface.felt_by(r)
    truth = _bounded_path_max_slope(h, side, r)
    if r * surface.max_curvature <= 1.0:  # (1 mm, inside the map's tightest radius, 1.0096 mm: no kink)
        assert len(felt.kinks) == 0 and felt.branched_cells == 0
    else:
        assert felt.branched_cells > 400
    assert felt.max_slope <= 0.1e-3 * math.pi / 1e-3 * (1 + hx.surfaces.STEEP_SLACK)
    assert felt.max_slope == pytest.approx(truth, rel=0.01)


@pytest.mark.long
@pytest.mark.parametrize("r", [1.02e-3, _by_hand(1.05e-3), _by_hand(1.07e-3)])
def test_just_past_its_bowls_radius_a_measured_maps_felt_slope_is_the_paths(r):
    # the bounded egg-crate map and brute-force path of the test above, at 1.01 to 1.06 times the
    # bowls' radius, where the ball nests in them on some grids and not on others. On the map's
    # own grid (61 x 61) few cells could be branched and the felt map read +4.60, +5.37, +9.68 %,
    # steeper than the surface itself (0.1 pi) by 4.6 to 9.6 %: a measured map kept its grid,
    # where an analytic surface's felt map is made again on finer grids of it (REFINE) until no
    # cell beside a kink is left single and it is not steeper than the surface. The map's
    # spline, the surface as defined, resampled: 0.8, 0.65, 0.5 of its interval read +1.93,
    # +0.02, +0.02 % at 1.02 mm; +9.63, +0.03, +3.05 % at 1.05; +8.67, +2.42, +0.00 % at 1.07
    # (at 1.2 mm, +26.9 and +18.5 % at 0.8 and 0.65, each steeper than the surface and leaving
    # single cells: a grid the choice refuses). Within 1 % of the path (issue 67's goal) and not
    # steeper than the surface by more than the construction's STEEP_SLACK
    side, h = 4e-3, AREAL_CASES["egg-crate"][1]
    felt = _sampled_egg_crate(61, periodic=False).felt_by(r)
    truth = _bounded_path_max_slope(h, side, r)
    assert felt.max_slope <= 0.1e-3 * math.pi / 1e-3 * (1 + hx.surfaces.STEEP_SLACK)
    assert felt.max_slope == pytest.approx(truth, rel=0.01)

def test_a_felt_maps_steepest_slope_is_the_sup_of_its_patches_beside_its_kinks():
    # max_slope is sup ||grad h|| over the map (its definition): never below the gradient's norm
    # at any point of it, here numpy's maximum over 16 x 16 points a sample interval. On the
    # egg-crate sampled 60 x 60 over its 4 mm cell (periodic) felt by a 1.2 mm ball, its bowls
    # are branched cells, the highest of several patches; a steep patch is the highest in a
    # sliver beside a crease, which the sup's four points an interval stepped over: 0.3152
    # where the map reaches 0.3236 (issue 67: the felt map read 0.3 % steep where it is 3 %)
    felt = _sampled_egg_crate(60, periodic=True).felt_by(1.2e-3)
    assert felt.branched_cells > 0
    g = np.arange(0.0, 4e-3, (4e-3 / 60) / 16)
    dense = float(np.linalg.norm(felt.gradient(np.stack(np.meshgrid(g, g, indexing="ij"), -1)), axis=-1).max())
    assert dense <= felt.max_slope <= 1.005 * dense


@pytest.mark.parametrize("rel_r", [1.2, _by_hand(1.0), pytest.param(1.1, marks=pytest.mark.long),
                                   pytest.param(1.3, marks=pytest.mark.long),
                                   _by_hand(1.02),
                                   pytest.param(1.17, marks=pytest.mark.long),
                                   _by_hand(1.09),
                                   _by_hand(1.04),
                                   _by_hand(1.08),
                                   _by_hand(1.18)])
def test_where_the_ball_nests_in_a_bowl_the_felt_map_is_refined_until_it_branches(rel_r, shared):
    # issue 67, from 1.05 to 1.3 bowl radii: the ball nests in the bowl, and on the default grid
    # (r / 16) the branches of some cells jumped between the bowl's sides or outnumbered what a
    # cell holds; those cells kept their single patches, whose apex is too steep: 0.3551 at 1.1
    # rho, 0.3834 at 1.2, 0.3981 at 1.3 for the path's 0.3141. Whether a cell beside a kink is
    # branched depends on where the grid's points fall (at 1.2 rho: 58 points a period branched,
    # 51 and 100 did not), so an analytic surface's felt map is made again on finer grids
    # (REFINE) until every such cell is and the map is no steeper than the surface (the path's
    # slope is a contact's; its sup sampled densely beside the kinks). Slope within 1 % of the
    # brute-force path's (numpy on the analytic heights; measured +0.01 % at 1.0, 1.02, 1.1 and
    # 1.2 rho, +0.00 % at 1.17, +0.36 % at 1.3). At 1.0 and 1.02 rho (the bowl's focal point)
    # stop 75 kept a grid whose cells all branched, +1.42 and +2.46 %; at 1.17 one whose apex
    # patches reach +3.3 % in slivers its sup stepped over (read +0.3 %). At 1.09 no grid
    # branched (+11.5 %, stop 80 found why: a contact's twist near the focal radius, 3.2e5 1/m,
    # and branches passed between neighbours out of reach); at 1.04 and 1.08 some cells hold 9
    # to 11 branches, more than the 8 a cell held before stop 80 (+2.0 and +2.6 %), and at 1.18
    # +1.2 %; measured with 12 a cell: +0.04, +0.02, +0.17 and +0.01 %
    tex, h, grad, cell, rho = AREAL_CASES["egg-crate"]
    felt = _felt_case(shared, "egg-crate", rel_r * rho)
    truth = _path_max_slope_2d(h, grad, cell, rel_r * rho)
    assert felt.branched_cells > 0 or rel_r < 1.05  # (at the focal point a grid of single patches, none steep)
    assert felt.max_slope == pytest.approx(truth, rel=0.01)
    given = tex.felt_by(rel_r * rho, spacing=0.1e-3)  # (a spacing given is the grid, not refined:
    # whole cells of at most 0.1 mm over the map's cell, at 1.0 rho, where the ball touches
    # everywhere, on axes along the gratings: sqrt(2) mm, 15 cells)
    assert given.x[1] - given.x[0] == pytest.approx(math.sqrt(2) * 1e-3 / 15 if given.turn else 0.1e-3)
    assert (given.turn != 0) == (rel_r == 1.0)


def _rough_map(m=64, dx=1e-6):
    """(the generator after it, heights (m, m)): isotropic band-limited noise, 2 um rms, wavelengths
    >= 10 um, on a periodic grid of dx; numpy's FFT alone."""
    rng = np.random.default_rng(0)
    k = np.fft.fftfreq(m, dx)
    K = np.hypot(k[:, None], k[None, :])
    spec = (rng.standard_normal((m, m)) + 1j * rng.standard_normal((m, m))) * (K <= 1 / 10e-6) * (K > 0)
    hn = np.fft.ifft2(spec).real
    return rng, hn * (2e-6 / hn.std())


def _periodic_map_path_max_slope(hn, dx, r, sub=4, top=60, levels=5, keep=12):
    """The steepest slope of a ball's centre path over a periodic map, by brute force: the map is
    scipy's periodic bicubic interpolant of its samples (make_interp_spline, as the surface is
    defined). (1) At every point p of a lattice of dx/sub, the arg-max u of H(p + u) +
    sqrt(r^2 - |u|^2) over the offsets of the same lattice in the disc (numpy, the heights on
    the lattice evaluated once). (2) At the ``top`` steepest of those points, the lattice's local
    maxima close enough to its maximum that they may be the highest anywhere the zoom below
    goes (the contacts a point nearby may rest on), each refined by Newton ascent on the
    interpolant (numpy, its derivatives from scipy), then ``levels`` times: on a 9 x 9 grid of
    points p around each of the ``keep`` steepest so far (half-width dx/sub, a quarter of that
    each level), each of those contacts followed by the same ascent, the highest stationary one
    (grad H(p + u) = u / sqrt(r^2 - |u|^2) to 1e-7) the contact, its slope grad H's norm there
    (the envelope theorem); a point where an ascent that did not settle rose higher than every
    stationary one is left out. The path's steepest slope
    lies on a crease (where two contacts are equally high), which a lattice steps over: a
    lattice alone (the last stop's brute force) read the 10 um ball's 1.4278 where the path
    reaches 1.4575. (3) The steepest point found is checked by a lattice of dx/40 over the whole
    disc: none of its points stands higher than the contact (to 1e-9 dx; the contact is the
    ball's, not one of a lower branch's). Nothing of haptex's."""
    from scipy import ndimage
    from scipy.interpolate import NdBSpline, make_interp_spline

    m = hn.shape[0]
    L = m * dx
    xe = np.r_[np.arange(m) * dx, L]
    he = np.pad(hn, ((0, 1), (0, 1)), mode="wrap")
    bx = make_interp_spline(xe, he, k=3, bc_type="periodic", axis=0)
    by = make_interp_spline(xe, bx.c, k=3, bc_type="periodic", axis=1)
    spl = NdBSpline((bx.t, by.t), np.moveaxis(by.c, 0, 1), 3)
    h = dx / sub
    g = np.arange(m * sub) * h
    F = spl(np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)).reshape(m * sub, m * sub)
    R = int(r / h)
    a = np.arange(-R, R + 1)
    A, B = np.meshgrid(a, a, indexing="ij")
    disc = A * A + B * B < (r / h) ** 2
    lift = np.sqrt(np.maximum(r * r - (A * A + B * B) * h * h, 0.0))
    best = np.full(F.shape, -np.inf)
    arg = np.zeros(F.shape + (2,))
    for ia, ib in zip(A[disc], B[disc]):
        v = np.roll(F, (-ia, -ib), (0, 1)) + lift[ia + R, ib + R]
        up = v > best
        best[up] = v[up]
        arg[up] = (ia * h, ib * h)
    slope = np.linalg.norm(arg, axis=-1) / np.sqrt(r * r - np.sum(arg**2, axis=-1))

    def derivs(q):
        q = np.mod(q, L)
        return [spl(q, nu=nu) for nu in ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))]

    def ascend(P, U):  # Newton ascent of H(P + U) + sqrt(r^2 - |U|^2), backtracking inside the disc
        U = U.copy()
        act = np.arange(len(U))  # (the points still moving)
        for _ in range(30):
            Pa, Ua = P[act], U[act]
            d = derivs(Pa + Ua)
            s2 = r * r - np.sum(Ua * Ua, 1)
            s = np.sqrt(s2)
            gv = d[0] + s
            g0, g1 = d[1] - Ua[:, 0] / s, d[2] - Ua[:, 1] / s
            w = 1 / (s2 * s)
            a_ = -(d[3] - 1 / s - Ua[:, 0] ** 2 * w)  # (minus the Hessian of H plus the sphere's cap)
            b_ = -(d[4] - Ua[:, 0] * Ua[:, 1] * w)
            c_ = -(d[5] - 1 / s - Ua[:, 1] ** 2 * w)
            low = 0.5 * (a_ + c_) - np.hypot(0.5 * (a_ - c_), b_)
            shift = np.where(low > 0, 0.0, 1e-3 / r - low)  # (where not concave: a gradient step)
            a_, c_ = a_ + shift, c_ + shift
            det = a_ * c_ - b_ * b_
            st = np.column_stack([(c_ * g0 - b_ * g1) / det, (a_ * g1 - b_ * g0) / det])
            todo = np.arange(act.size)  # (backtracking: only steps that raise it, inside the disc)
            moved = np.zeros(act.size)
            for _half in range(20):
                Un = Ua[todo] + st[todo]
                inside = np.sum(Un * Un, 1) < r * r * (1 - 1e-12)
                gn = np.full(todo.size, -np.inf)
                gn[inside] = spl(np.mod(Pa[todo][inside] + Un[inside], L)) + np.sqrt(r * r - np.sum(Un[inside] ** 2, 1))
                ok = gn >= gv[todo]
                U[act[todo[ok]]] = Un[ok]
                moved[todo[ok]] = np.linalg.norm(st[todo[ok]], axis=1)
                todo = todo[~ok]
                if todo.size == 0:
                    break
                st[todo] *= 0.5
            act = act[moved > 1e-13 * r]
            if act.size == 0:
                break
        d = derivs(P + U)
        s = np.sqrt(r * r - np.sum(U * U, 1))
        return U, d[0] + s, np.hypot(d[1] - U[:, 0] / s, d[2] - U[:, 1] / s), np.hypot(d[1], d[2])

    # a point of the zoom below lies within D = h sqrt(2) 4/3 of its lattice point, where each
    # contact's height moves by at most its slope times D: the contacts kept are those within
    # 2 M D of the highest there, and the lattice's own error, M bounding the surface's slope
    M = 1.1 * float(np.max(np.hypot(*np.gradient(F, h))))
    window = 2 * M * h * math.sqrt(2) * 4 / 3 + 2 * (M + 1) * h
    pts = []
    for idx in np.argsort(slope.ravel())[::-1][:top]:
        i, j = np.unravel_index(idx, F.shape)
        vals = np.where(disc, F[(i + A) % F.shape[0], (j + B) % F.shape[1]] + lift, -np.inf)
        peak = (vals == ndimage.maximum_filter(vals, 3, mode="constant", cval=-np.inf)) & (vals > vals.max() - window)
        pts.append((np.array([i * h, j * h]), np.column_stack([A[peak], B[peak]]) * h))
    out, at, w = 0.0, None, h
    o = np.linspace(-1.0, 1.0, 9)
    O = np.stack(np.meshgrid(o, o, indexing="ij"), -1).reshape(-1, 2)
    for _level in range(levels):
        P = np.concatenate([p + w * O for p, us in pts for _u in us])
        U0 = np.concatenate([u - w * O for _p, us in pts for u in us])
        which = np.concatenate([k * len(O) + np.arange(len(O)) for k, (_p, us) in enumerate(pts) for _u in us])
        with np.errstate(invalid="ignore", divide="ignore"):
            U, val, res, sl = ascend(P, U0)
        val = np.where(np.isnan(val), -np.inf, val)
        ids, inv = np.unique(which, return_inverse=True)
        reach = np.full(ids.size, -np.inf)  # (an ascent that stalls still rose that high: a contact higher
        np.maximum.at(reach, inv, val)      # than every stationary one there, unresolved, rules the point out)
        val = np.where(res < 1e-7, val, -np.inf)  # (stationary: a contact)
        top_val = np.full(ids.size, -np.inf)
        np.maximum.at(top_val, inv, val)
        mine = np.isfinite(val) & (val >= top_val[inv]) & (top_val[inv] >= reach[inv])
        steep = np.full(ids.size, -np.inf)
        np.maximum.at(steep, inv, np.where(mine, sl, -np.inf))
        order = np.argsort(steep)[::-1][:keep]
        if steep[order[0]] > out:
            k = np.nonzero(mine & (inv == order[0]))[0][0]
            out, at = float(steep[order[0]]), (P[k], val[k])
        pts = []
        for b in order:
            us = []
            for u in U[inv == b]:  # (every contact, stationary or not: a lost one is a higher one missed)
                if all(np.linalg.norm(u - v) > 1e-3 * h for v in us):
                    us.append(u)
            pts.append((P[inv == b][0], np.array(us)))
        w /= 4
    # (3) the contact of the steepest point is the highest of the whole disc on a finer lattice
    f = dx / 40
    n = int(r / f)
    q = np.arange(-n, n + 1) * f
    Q = np.stack(np.meshgrid(q, q, indexing="ij"), -1).reshape(-1, 2)
    Q = Q[np.sum(Q * Q, 1) < r * r]
    assert np.max(spl(np.mod(at[0] + Q, L)) + np.sqrt(r * r - np.sum(Q * Q, 1))) <= at[1] + 1e-9 * dx
    return out


@pytest.mark.long
@pytest.mark.parametrize("r", [_by_hand(0.5e-6), _by_hand(0.8e-6), _by_hand(0.85e-6), 0.9e-6])
def test_a_ball_inside_every_trough_of_a_rough_map_feels_the_maps_own_slopes(r):
    # issue 67's lower radii (0.1 times the troughs' radius and up) on the rough map of the tests
    # below: a ball whose radius is below every trough's radius of curvature touches the map
    # everywhere, its centre path is the offset surface, and the path's slope at p is the map's
    # at the contact, every point of the map a contact: the path's steepest slope is the map's.
    # Both from scipy's periodic bicubic interpolant of the samples (the surface as defined),
    # on a lattice of 1/16 of a sample: its largest principal curvature 1.09e6 1/m (the tightest
    # trough's radius 0.91 um), its steepest slope 2.663. (The brute-force path of the tests below
    # needs r / (dx / sub) offsets a radius: at 0.5 um and sub 4, two, and it read 1.55, the felt
    # map +71.7 % against it; at sub 16, 2.643.) Measured: +0.39 % at 0.5 um, +0.12 % at 0.8
    # (above the map's own slope by the Hermite patches' error, within STEEP_SLACK). At 0.85 and
    # 0.9 um, just below the tightest trough's radius, +4.28 and +6.55 % on the map's own grid and
    # on every grid of REFINE (the contact runs 14 and 65 times as fast as the ball there, and a
    # cubic through exact slopes a sample apart overshoots); at 0.25 of its interval
    # (REFINE_STEEP, made while every grid is steeper than the surface) +0.00 %
    from scipy.interpolate import NdBSpline, make_interp_spline

    _, hn = _rough_map()
    m, dx = hn.shape[0], 1e-6
    xe = np.r_[np.arange(m) * dx, m * dx]
    he = np.pad(hn, ((0, 1), (0, 1)), mode="wrap")
    bx = make_interp_spline(xe, he, k=3, bc_type="periodic", axis=0)
    by = make_interp_spline(xe, bx.c, k=3, bc_type="periodic", axis=1)
    spl = NdBSpline((bx.t, by.t), np.moveaxis(by.c, 0, 1), 3)
    g = np.arange(m * 16) * (dx / 16)
    P = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    hxx, hxy, hyy = (spl(P, nu=nu) for nu in ((2, 0), (1, 1), (0, 2)))
    tightest = np.max(0.5 * (hxx + hyy) + np.hypot(0.5 * (hxx - hyy), hxy))
    assert r * tightest < 1.0  # (inside every trough)
    steepest = np.max(np.hypot(spl(P, nu=(1, 0)), spl(P, nu=(0, 1))))
    felt = hx.SampledSurface(np.arange(m) * dx, np.arange(m) * dx, hn, periodic=True).felt_by(r)
    assert felt.max_slope == pytest.approx(steepest, rel=0.01)
    assert felt.max_slope <= steepest * (1 + hx.surfaces.STEEP_SLACK)

@pytest.mark.long
@pytest.mark.parametrize("r", [5e-6, _by_hand(7e-6)])
def test_on_a_rough_map_the_felt_maps_steepest_slope_is_near_the_paths(r):
    # issue 67's random areal maps, not met: the rough periodic map of the test below (band-limited
    # noise, 2 um rms, wavelengths >= 10 um, 1 um samples) felt by balls of 4 to 24 samples,
    # against a brute-force ball path on scipy's interpolant of the same samples. Few of the
    # cells beside kinks branch from 4 to 7 um (2-14 of 600-800, on the map's own grid and on
    # each finer grid of its spline the refinement tries; all from 8 um, the test below), and
    # the single patches err either way: where they bridge the path's V-shaped kinks flatter
    # than its sides (its steepest slope is on a crease), where they bridge a bowl steeper.
    # Measured (felt against path): 4 um -1.00 %, 4.5 +0.22, 5 -1.51, 5.5 -3.69, 6 -2.41,
    # 7 -4.54 %; from 8 to 24 um within 0.05 % (8 um read -7.44 % on the map's own grid, before
    # 2026-11-27's fifth session; 10 and 12 um -6.70 and +4.18 % before its fourth, 16 um
    # -2.59 % before stop 80); the goal is 1 %. (Stop 76's brute force, a lattice of dx/4
    # refined at its steepest points, stepped over the creases: it read the path up to 2.1 %
    # flat, and these as -5.83 % at 8 um, -4.76 % at 10.) Asserted: within 7 %, at two radii (the
    # brute force takes 0.8-2 s there)
    _, hn = _rough_map()
    x = np.arange(hn.shape[0]) * 1e-6
    felt = hx.SampledSurface(x, x, hn, periodic=True).felt_by(r)
    assert felt.max_slope == pytest.approx(_periodic_map_path_max_slope(hn, 1e-6, r), rel=0.07)


@pytest.mark.long
@pytest.mark.parametrize("r", [8e-6, _by_hand(10e-6), _by_hand(12e-6), _by_hand(16e-6)])
def test_on_a_rough_map_where_every_cell_beside_a_kink_branches_the_felt_slope_is_the_paths(r):
    # issue 67's goal (1 %) on the rough periodic map of the test above, at radii where the felt
    # map branches every cell beside its kinks, against the same brute-force path on scipy's
    # interpolant (1-6 s). At 16 um, -0.002 % (stop 77 measured -2.59 %, with 8 branches a cell
    # and a reach of 4; stop 80's 12 and 6 branch it all). At 10 and 12 um no cell branched,
    # -6.70 and +4.18 %: cells whose branches tie at the 5 x 5 points kept them all (13 to 17,
    # past MAX_BRANCHES), copies of one contact that differ where it is not were taken as one,
    # and cells that are no candidates (their corners' contacts close) did not meet their
    # branched neighbours along a crease; each unbranched its whole cluster. Measured since:
    # -0.05 and +0.01 %. At 8 um the map's own grid branched none (one cell of 14 branches, past
    # MAX_BRANCHES, in the map's one cluster), -7.44 %; its spline resampled at 0.65 um (the
    # refinement the analytic surfaces had) branches all 1,243: +0.00 %
    _, hn = _rough_map()
    x = np.arange(hn.shape[0]) * 1e-6
    felt = hx.SampledSurface(x, x, hn, periodic=True).felt_by(r)
    assert hx.surfaces._single_kink_cells(felt) == 0
    assert felt.max_slope == pytest.approx(_periodic_map_path_max_slope(hn, 1e-6, r), rel=0.01)


def test_a_felt_map_is_continuous_and_never_steeper_than_its_surface():
    # the ball's centre path is continuous and its slope is a contact's (the envelope theorem):
    # on a rough periodic map (band-limited noise, 2 um rms above 10 um, 1 um samples) felt by
    # balls of 3 to 10 samples, where contacts jump between asperities all over it, the felt map
    # has the same height on either side of every patch line (to 1e-12 m; its slope x 2e-13 m
    # is 1e-12 m), a branched cell's highest patch included, and no slope above the surface's
    # own at 4 points a sample interval. At 3 samples the map's own grid read 3.16 for the
    # surface's 2.66 (a ball of 3 samples leaves the path's kinks between every pair of samples);
    # its spline resampled at 0.65 um (the refinement, 2026-11-27's fifth session) reads 2.661
    rng, hn = _rough_map()
    m = hn.shape[0]
    x = np.arange(m) * 1e-6
    rough = hx.SampledSurface(x, x, hn, periodic=True)
    K_ = hx.core._ext
    branched = 0
    for r in (3e-6, 5e-6, 10e-6):
        felt = rough.felt_by(r)
        branched += felt.patches()[0, K_.PATCH_JOINS] == K_.JOINS_BRANCHED
        on_x = np.column_stack([x[rng.integers(0, m, 400)], rng.uniform(0, m * 1e-6, 400)])
        on_y = on_x[:, ::-1]
        for on, eps in ((on_x, np.array([1e-13, 0.0])), (on_y, np.array([0.0, 1e-13]))):
            np.testing.assert_allclose(felt.height_at(on - eps), felt.height_at(on + eps), rtol=0, atol=1e-12)
        g = np.stack(np.meshgrid(np.arange(4 * m) * 0.25e-6, np.arange(4 * m) * 0.25e-6, indexing="ij"), -1)
        assert np.max(np.linalg.norm(felt.gradient(g), axis=-1)) <= rough.max_slope * (1 + 1e-6)
    assert branched  # (some cells are branched: the check reads them)


@pytest.mark.parametrize("rel_r", [1.5, pytest.param(1.05, marks=pytest.mark.long)])
def test_at_its_nodes_a_felt_map_reads_a_limit_from_beside_them(rel_r, shared):
    # By definition a felt map the ball bridges is, in a branched cell, the highest of the cell's
    # patches: at a grid node (where q's searches and grid-aligned probes read it) its second
    # derivatives are the limit from some direction, the cell's piece on that side. Truth: the
    # map's own values 1e-7 of a cell away along 16 directions (angles not along the axes or the
    # diagonals, where the egg-crate's creases run through nodes). Before (2026-11-29): patches
    # that tie at a node (a branch a neighbour passed the cell, meeting its own along the edge)
    # were taken in their order, and 18 nodes at 1.5 rho read none of the 16 limits (up to 1.34
    # 1/m off, of the map's largest 395), 59 at 1.2 rho (27 1/m), 92 at 1.05 rho (the map kept
    # then, 304 a side: one such node read -19,367 1/m where its neighbours' cells read at most
    # 10,988 and the path's branches 11,907, and made q of C +3.26 %; 16 nodes, up to 4,942 1/m
    # off, on the 38-a-side map kept for r one ulp away). Now a tie is broken inside the cell
    # (hx_texture_eval.h, HX_BRANCH_NUDGE): none; 1.5 rho 4 s, 1.05 rho 20 s
    felt = _felt_case(shared, "egg-crate", rel_r * AREAL_CASES["egg-crate"][4])
    assert felt.branched_cells > 0  # (the ball bridges the bowls: some cells are branched)
    X, Y = np.meshgrid(felt.x, felt.y, indexing="ij")
    p = np.stack([X.ravel(), Y.ravel()], -1)
    at = felt._derivatives(p)[:, 3:]  # (h_xx, h_xy, h_yy)
    angles = (np.arange(16) + 0.37) * 2 * np.pi / 16
    off = np.min([np.abs(at - felt._derivatives(p + 1e-7 * felt.dx * np.array([np.cos(a), np.sin(a)]))[:, 3:]
                         ).max(-1) for a in angles], axis=0)
    largest = np.abs(at).max()
    assert np.count_nonzero(off > 1e-3 * largest) == 0, (p[np.argmax(off)], off.max(), largest)


def test_a_point_probe_is_the_texture_itself_and_bad_radii_are_refused():
    assert SINE.felt_by(0.0) is SINE
    for bad in (-1e-3, math.nan, math.inf):
        with pytest.raises(ParameterError, match="tip_radius"):
            SINE.felt_by(bad)
    prof = hx.SampledProfile(np.arange(100) * 1e-6, np.zeros(100))
    with pytest.raises(ParameterError, match=r"tip_radius = 0.001 is not allowed: must be at most the profile's length"):
        prof.felt_by(1e-3)


def test_at_the_command_line_a_bad_tip_radius_is_named_as_typed(capsys, tmp_path):
    # issue 67's bad input: a tip radius negative, NaN or larger than the map's extent gives one
    # line naming --tip-radius, its value and the allowed range, exit status 2. The library's
    # refusals name its parameter in SI ("tip_radius = 0.0001 is not allowed: must be at most the
    # map's shorter side, 0.0199219 mm"); at the command line the option and its value are as the
    # user typed them. Truth: the issue's wording, the values typed here
    from haptex.cli import main

    path = tmp_path / "map.npy"  # (a 63 um map, 1 um samples)
    np.save(path, np.zeros((64, 64)))
    npy = ["--texture", str(path), "--spacing", "1um", "--height-unit", "um"]
    cases = [(["--texture", "sine:0.1mm,2mm", "--tip-radius", "-1mm"], "--tip-radius -1mm is not allowed: must be"),
             (["--texture", "sine:0.1mm,2mm", "--tip-radius=nan mm"], "--tip-radius"),
             ([*npy, "--tip-radius", "0.1mm"],
              "--tip-radius 0.1mm is not allowed: must be at most the map's shorter side, 63um")]
    for args, said in cases:
        assert main(["design", *args, "--quiet"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and err.startswith("haptex: error: ") and said in err, err
    assert main(["design", *npy, "--tip-radius", "10um", "--tip-spacing", "-1um", "--quiet"]) == 2
    assert "--tip-spacing -1um is not allowed: must be a finite number > 0 (m)" in capsys.readouterr().err


def test_a_tip_radius_refused_for_the_maps_extent_is_felt_at_the_bound_it_names():
    # issue 67: every remedy a refusal names gives a result taken exactly at its bound. A ball
    # wider than a map that ends at its edges is refused naming "at most the map's shorter side,
    # 0.0828491 mm" (x3p-2.x3p, whose side is 0.08284907488 mm): the bound rounded to nearest, so
    # taken as written it was refused again there, on mi-1.mi and on metropro-1.dat. Walked over
    # maps and profiles whose extents are 39 samples of 1 + k / 7 um (k = 0..13: extents that
    # round up and down) and, where ../shared/data is beside the checkout, the real ones. Truth:
    # the refusal's definition, r at most the extent (numpy's x[-1] - x[0])
    import re

    from haptex._units import parse_quantity

    real = []
    if DEKTAK.exists():
        real = [hx.load_texture(DEKTAK.parent / f) for f in ("x3p-2.x3p", "mi-1.mi", "di-1.di", "metropro-1.dat")]
        real.append(hx.load_texture(DEKTAK))
    synthetic = []
    for k in range(14):
        x = np.arange(40) * (1 + k / 7) * 1e-6
        synthetic.append(hx.SampledSurface(x, x[:30] * 1.3, 1e-9 * np.sin(x / x[-1])[:, None] * np.ones(30)))
        synthetic.append(hx.SampledProfile(x, 1e-9 * np.sin(x / x[-1])))
    for tex in real + synthetic:
        axes = (tex.x, tex.y) if tex.dimension == 2 else (tex.x,)
        extent = min(a[-1] - a[0] for a in axes)
        with pytest.raises(ParameterError) as refused:
            tex.felt_by(2 * extent)
        msg = str(refused.value)
        cli = re.search(r"must be at most the (?:map's shorter side|profile's length), (\S+) \(", msg)
        py = re.search(r"tip_radius <= ([0-9.e+-]+) in Python", msg)
        assert cli and py, msg
        bound = parse_quantity(cli.group(1), "m", "tip_radius", require_unit=True)
        assert bound == float(py.group(1)) and extent * (1 - 1e-5) <= bound <= extent, msg
        if tex in synthetic:
            tex.felt_by(bound)  # (felt, within its work)
        else:  # (the real maps' radius at their extent may be past the work: refused for that, not again for this)
            try:
                tex.felt_by(bound)
            except ParameterError as again:
                assert "is not allowed here: the ball covers" in str(again), str(again)


def _dense_dilation(surf, pts, r, n=161):
    """c(p) - r at each point (k, 2) by brute force: the maximum of h(p + u) + sqrt(r^2 - |u|^2)
    over the offsets of an n x n grid inside the disc, h the surface's own heights."""
    g = np.linspace(-r, r, n)
    U = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2)
    U = U[np.sum(U * U, axis=1) <= r * r]
    ball = np.sqrt(np.maximum(r * r - np.sum(U * U, axis=1), 0.0))
    return np.array([np.max(surf.height_at(p + U) + ball) for p in pts]) - r


def _grid_dilation(surf, xs, ys, r, du):
    """c(p) - r (nx, ny) at the nodes of a periodic grid xs, ys (its cell nx dx by ny dy) by brute
    force: the maximum of h(p + u) + sqrt(r^2 - |u|^2) over the offsets u in the disc of a grid
    whose steps (sx, sy), at most du, divide the nodes' (dx / kx, dy / ky), h the surface's own
    heights sampled once on that finer grid over the cell. Returns it and (sx, sy)."""
    dx, dy = xs[1] - xs[0], ys[1] - ys[0]
    kx, ky = math.ceil(dx / du), math.ceil(dy / du)
    sx, sy = dx / kx, dy / ky
    Nx, Ny = xs.size * kx, ys.size * ky
    fine = np.stack(np.meshgrid(xs[0] + np.arange(Nx) * sx, ys[0] + np.arange(Ny) * sy, indexing="ij"), -1)
    hf = surf.height_at(fine)
    I, J = np.arange(xs.size) * kx, np.arange(ys.size) * ky
    out = np.full((xs.size, ys.size), -np.inf)
    for a in range(-int(r / sx), int(r / sx) + 1):
        rows = hf[(I + a) % Nx]
        for b in range(-int(r / sy), int(r / sy) + 1):
            u2 = (a * sx) ** 2 + (b * sy) ** 2
            if u2 <= r * r:
                np.maximum(out, rows[:, (J + b) % Ny] + math.sqrt(r * r - u2), out=out)
    return out - r, (sx, sy)


def test_a_surface_is_dilated_as_its_definition_says():
    # c(p) = max over |u| <= r of h(p + u) + sqrt(r^2 - |u|^2): at least the maximum over the
    # grid's own offsets (the ball resting on the samples), at most the dense brute force's over
    # the map's spline (plus that grid's miss, (du/2)^2 / 2 (sup ||H|| + 1/r)). A white-noise map
    # (its spline peaks between samples) lies between the two: the contact is refined from the
    # grid's best offset (up to 3.3 um below the continuous maximum here, 5 um rms); a smooth
    # map is the continuous maximum itself. The felt map's grid is the map's own or, where that
    # leaves cells beside kinks single, the map's spline resampled finer (here 8.28 x 8.04 um
    # steps, not the map's 10 x 15 um): both bounds are taken on the felt map's own grid, the heights there
    # the map's spline's (the surface as defined)
    rng = np.random.default_rng(3)
    x, y = np.arange(24) * 10e-6, np.arange(30) * 15e-6
    h = rng.normal(size=(24, 30)) * 5e-6
    surf = hx.SampledSurface(x, y, h, periodic=True)
    r = 40e-6
    felt = surf.felt_by(r)
    fx, fy = felt.x, felt.y
    P = np.stack(np.meshgrid(fx, fy, indexing="ij"), -1)
    hf = surf.height_at(P)
    ref = np.full_like(hf, -np.inf)
    da, db = fx[1] - fx[0], fy[1] - fy[0]
    for a in range(-int(r / da), int(r / da) + 1):
        for b in range(-int(r / db), int(r / db) + 1):
            u2 = (a * da) ** 2 + (b * db) ** 2
            if u2 <= r * r:
                ref = np.maximum(ref, np.roll(hf, (-a, -b), axis=(0, 1)) + math.sqrt(r * r - u2) - r)
    assert np.all(felt.h >= ref - 1e-18)
    dense, (sx, sy) = _grid_dilation(surf, fx, fy, r, 2 * r / 160)
    miss = (sx * sx + sy * sy) / 8 * (surf.max_curvature + 1 / r)
    assert np.all(felt.h <= dense + miss)
    xs = np.arange(32) * (2e-3 / 32)
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    smooth = hx.SampledSurface(xs, xs, 0.1e-3 * np.sin(np.pi * X / 1e-3) * np.sin(np.pi * Y / 1e-3), periodic=True)
    felt = smooth.felt_by(0.5e-3)  # (on its own grid: refined for the path's curvature, finer than the map's)
    P = np.stack(np.meshgrid(felt.x, felt.y, indexing="ij"), -1).reshape(-1, 2)
    pick = slice(None, None, max(1, P.shape[0] // 150))
    miss = (1e-3 / 160) ** 2 / 4 * (smooth.max_curvature + 1 / 0.5e-3)
    np.testing.assert_allclose(felt.h.ravel()[pick], _dense_dilation(smooth, P[pick], 0.5e-3), rtol=0, atol=miss)
    egg = hx.SumOfGratings.egg_crate(0.1e-3, 2e-3).felt_by(0.5e-3)
    assert egg.max_slope < hx.SumOfGratings.egg_crate(0.1e-3, 2e-3).max_slope * 1.01


def test_a_felt_textures_source_states_its_grid_in_a_readable_unit():
    # a felt texture's source states the grid it was resampled on, as the spacing given (its
    # definition): in um, and in nm below 10 nm, where opdx-3.opdx felt by a 5 um ball, refined
    # to 128 points a sample (0.13 nm), read "resampled at 0.0001301 um" (2026-11-30)
    x = np.arange(400) * 20e-9
    prof = hx.SampledProfile(x, 5e-9 * np.sin(2 * np.pi * x / 1e-6))
    assert "resampled at 4 nm felt by" in prof.felt_by(0.2e-6, spacing=4e-9).source
    assert "resampled at 0.04 um felt by" in prof.felt_by(0.2e-6, spacing=40e-9).source
    surf = hx.SampledSurface(x[:40], x[:40], 5e-9 * np.sin(2 * np.pi * x[:40] / 1e-6)[:, None] * np.ones(40))
    assert "resampled at 5 nm felt by" in surf.felt_by(0.2e-6, spacing=5e-9).source


def test_a_measured_stylus_scan_felt_by_a_phantom_ball():
    # the Dektak scan of examples/data (1.5 mm, 9600 samples): a 0.5 mm ball bridges its fine
    # roughness; the felt slope falls, and never exceeds the point probe's anywhere
    from pathlib import Path

    level = hx.load_texture(Path(__file__).parents[1] / "examples" / "data" / "dektak-stylus-profile.csv").leveled()
    felt = level.felt_by(0.5e-3)
    # the ball's lowest point never goes below the surface (at the felt grid's points: refined
    # where the path's curvature is not resolved, the map's spline resampled)
    assert np.all(felt.h >= level.height(felt.x) - 1e-15)
    assert felt.max_slope < 0.5 * level.max_slope


def test_at_a_bounded_profiles_end_the_felt_path_is_the_balls_pivoting_on_its_last_point():
    # a bounded profile (1.3 periods of a sinusoid, ending on a rise): the ball's contact stays on
    # the sampled range, so within r of its end the ball pivots on the last point and its path
    # is that point's circle, its slope (s - x) / sqrt(r^2 - (s - x)^2) (the envelope theorem
    # for a constrained maximum), not the surface's slope at s. Truth: the maximum over 400,001
    # offsets confined to the range, of the profile's own spline, and that slope at its arg-max.
    # 2026-11-28: the felt slope there was the surface's (here 0.12165 where the path's is
    # 0.12135; at the Dektak scan's end under a 0.5 mm ball 0.0097 where it is 1e-5, the last
    # segments curving 12e6 1/m, and the profile said its curvature missed the path's by 581,000 %)
    x = np.linspace(0.0, 2.6e-3, 1301)
    tex = hx.SampledProfile(x, 0.05e-3 * np.sin(2 * np.pi * x / 2e-3 - 1.2))
    r = 0.2e-3
    felt = tex.felt_by(r)
    lo, hi = tex.domain
    pts = np.linspace(hi - 1.5 * r, hi, 31)
    u = np.linspace(-r, r, 400_001)
    for xi in pts:
        v = u[(xi + u >= lo) & (xi + u <= hi)]
        g = tex.height(xi + v) + np.sqrt(r * r - v * v)
        k = int(np.argmax(g))
        assert felt.height(xi) == pytest.approx(g[k] - r, abs=1e-12)
        assert felt.slope(xi) == pytest.approx(v[k] / math.sqrt(r * r - v[k] ** 2), abs=2e-4)
    assert felt.curvature_miss <= 0.01


@pytest.mark.long
def test_a_measured_stylus_scan_felt_by_a_ball_is_its_centre_path_beside_every_kink():
    # the Dektak scan (9,600 samples of fine roughness) felt by a 0.5 mm ball, refined for its
    # curvature; where the ball bridges a valley the contact jumps between two near-tied
    # branches (their heights 0.06 nm apart): at the grid points beside its kinks the felt
    # heights are the ball's centre path by brute force (_centre_path: the maximum over 400,001
    # offsets, nothing of haptex's but the scan's own spline). Never below it (the brute force is
    # a discrete maximum, at most the continuous one), above it by at most (du/2)^2 / 2 (max|h''|
    # + 1/r), du its offsets' step. 2026-11-28: with each finer grid's contacts followed from
    # the coarser one's, a point that fell on a coarser grid's point kept that point's contact,
    # and one beside a kink at 393.9 um read 0.064 nm low, its chord's slope 0.038 where the
    # path's is 0.025 either side
    from pathlib import Path

    level = hx.load_texture(Path(__file__).parents[1] / "examples" / "data" / "dektak-stylus-profile.csv").leveled()
    r = 0.5e-3
    felt = level.felt_by(r)
    assert felt.kinks.shape[0] > 100
    i = np.round((felt.kinks[::5, 0] - felt.x[0]) / felt.dx - 0.5).astype(int)
    nodes = np.unique(np.clip(np.concatenate([i, i + 1]), 0, felt.x.size - 1))
    du = 2 * r / 400_000
    bound = (du / 2) ** 2 / 2 * (level.max_curvature + 1 / r)
    brute = _centre_path(level, felt.x[nodes], r)
    assert np.all(felt.h[nodes] >= brute - 1e-14)
    assert np.all(felt.h[nodes] <= brute + bound + 1e-14)


def test_at_a_kink_of_the_felt_path_b_c_and_g_forces_jump_and_d_and_e_do_not():
    # where the ball bridges a trough its path has a kink (a slope jump from -s to +s, s from the
    # brute-force path): by the paper's fields B's force -k0 d^z n (eq. 11) jumps by
    # k0 |d^z| |n(s) - n(-s)|, C's -k0 [-d^z h', d^z] (eq. 14) by k0 |d^z| 2 s, G's -k0 p^z n
    # (eq. 28) by k0 |p^z| |n(s) - n(-s)|; A's (d^z alone) and F's do not, and nor do D's and
    # E's (eqs. 17, 19): below a V-shaped kink the closest point is the kink's vertex itself, so
    # that D's force is -k0 (p - vertex) and E's magnitude the distance to it, both continuous.
    # design said "D and E see a discontinuity there" (2026-11-27's sixth session: wrong)
    r, k0 = 1e-3, 2000.0
    felt = hx.Sinusoid(0.2e-3, 2e-3).felt_by(r)
    assert felt.kinks[:, 0] == pytest.approx([1.5e-3], abs=felt.x[1] - felt.x[0])  # (the trough, 3l/4)
    h, hp = _sines([0.2e-3], [2e-3], [0.0])
    s = abs(_brute_slopes(h, hp, np.array([1.5e-3 + 1e-9]), r)[0])  # (the path's slope beside the crease)
    vertex = np.array([1.5e-3, _centre_path(hx.Sinusoid(0.2e-3, 2e-3), np.array([1.5e-3]), r)[0]])
    dn = 2 * s / math.sqrt(1 + s * s)  # |n(s) - n(-s)|, n = [-h', 1] / sqrt(1 + h'^2)
    xs = np.linspace(1.5e-3 - 20e-6, 1.5e-3 + 20e-6, 401)
    for depth in (0.2e-3, 0.5e-3):
        P = np.column_stack([xs, np.full(xs.size, vertex[1] - depth)])
        for letter, jump in (("B", k0 * depth * dn), ("C", k0 * depth * 2 * s),
                             ("G", k0 * abs(vertex[1] - depth) * dn), ("A", 0.0), ("D", 0.0), ("E", 0.0)):
            f = hx.algorithm(letter, felt, k0).force(P)
            steps = np.linalg.norm(np.diff(f, axis=0), axis=1)
            # (a continuous field moves by at most k0 q |dx| a step: 2000 N/m x 0.1 um x q, q < 2 here)
            assert steps.max() == pytest.approx(jump, rel=0.01, abs=4e-4), letter
            # (what design's kink report and q's search read: the registry says which jump)
            assert hx.algorithms.ALGORITHMS[letter].reads_slope == (jump > 0), letter
        # below the vertex D's force is the definition's, -k0 (p - vertex)
        below = np.array([[1.5e-3, vertex[1] - depth]])
        assert hx.algorithm("D", felt, k0).force(below)[0] == pytest.approx(-k0 * (below[0] - vertex), rel=1e-3)


def test_design_takes_a_tip_radius_at_the_command_line():
    import json

    from click.testing import CliRunner

    from haptex.cli import cli, main

    r = CliRunner().invoke(cli, ["design", "--texture", "sine:0.1mm,2mm", "--device", "omega-3", "--tip-radius", "5mm",
                                 "--algorithms", "A", "--json", "--quiet"])
    assert r.exit_code == 0, r.output
    felt = json.loads(r.stdout)["felt_by_tip"]
    assert felt["tip_radius"] == 5e-3 and felt["max_slope_felt"] < felt["max_slope_point_probe"]
    # the ball (5 mm) bridges each trough (at 1.5 mm, the sine's period 2 mm): one kink, its slope
    # jump twice the path's slope there (symmetric branches), which the brute-force path gives
    assert felt["kink_count"] == 1 and felt["kinks"][0]["x"] == pytest.approx(1.5e-3, abs=2e-5)
    assert felt["branched_cells"] == felt["single_patch_cells"] == 0  # (a profile has no cells)
    h, hp = _sines([0.1e-3], [2e-3], [0.0])
    side = abs(_brute_slopes(h, hp, np.array([1.5e-3 - 1e-7]), 5e-3)[0])
    assert felt["kinks"][0]["slope_jump"] == pytest.approx(2 * side, rel=0.01)
    # the report names the algorithms whose forces jump at a kink (the test above)
    r = CliRunner().invoke(cli, ["design", "--texture", "sine:0.1mm,2mm", "--device", "omega-3", "--tip-radius", "5mm",
                                 "--algorithms", "A", "--quiet"])
    said = " ".join(r.output.split())
    assert "B's, C's and G's forces jump there" in said and "D and E" not in said
    assert main(["design", "--texture", "sine:0.1mm,2mm", "--tip-radius", "0.5"]) == 2  # a radius needs its unit


@pytest.mark.long  # (4 s of analysis)
def test_design_says_how_many_cells_beside_kinks_keep_a_single_patch(capsys):
    # just past the egg-crate's bowls' radius (1.007 times it: at the radius itself, 1.013 mm,
    # this test's until 2026-11-27, the ball touches the bowls everywhere and no kink is named
    # now) no grid branches the bowls' cells (1.09 times it, this test's radius before stop 80,
    # and 1.04 branch now): design says how many cells beside kinks keep their single patch and
    # that their slopes may be off, where it used to name only the kinks and the branched cells
    import json

    from haptex.cli import main

    args = ["design", "--texture", "egg-crate:0.1mm,2mm", "--device", "omega-3", "--tip-radius", "1.02mm",
            "--algorithms", "A"]
    assert main(args + ["--json", "--quiet"]) == 0
    felt = json.loads(capsys.readouterr().out)["felt_by_tip"]
    assert felt["kink_count"] > 0 and felt["branched_cells"] == 0 and felt["single_patch_cells"] > 0
    assert main(args + ["--quiet"]) == 0
    out = " ".join(capsys.readouterr().out.split())
    assert f"{felt['single_patch_cells']} cells beside kinks keep a single patch" in out


@needs_data
def test_a_map_too_short_for_the_device_is_refused_before_the_ball_rolls(capsys, monkeypatch):
    # x3p-2.x3p (82.85 um a side) on the point mass at 0.1 m/s: shorter than 2 of the shortest
    # period it renders (l_c = 50 um), with or without a ball, since a ball on a bounded map
    # feels a map of the same extent. With --tip-radius 5um the refusal came after the ball had
    # rolled (a felt map of 650 x 650 samples, 6 s and 0.8 GB); every other refusal of the
    # options (--report with a map) likewise. Now both come first: no felt_by call (counted),
    # and the refusal is the one the map as measured gets.
    from haptex.cli import main

    calls = []
    felt_by = hx.SampledSurface.felt_by
    monkeypatch.setattr(hx.SampledSurface, "felt_by", lambda self, *a, **k: calls.append(a) or felt_by(self, *a, **k))
    path = str(DEKTAK.parent / "x3p-2.x3p")
    assert main(["design", "--texture", path, "--quiet"]) == 2
    plain = capsys.readouterr().err
    assert "spans 82.85 um along x, less than 2 of the shortest period" in plain and plain.count("\n") == 1
    assert main(["design", "--texture", path, "--tip-radius", "5um", "--quiet"]) == 2
    assert capsys.readouterr().err == plain and calls == []
    assert main(["design", "--texture", path, "--tip-radius", "5um", "--speed", "0.08m/s", "--report",
                 "never-written", "--quiet"]) == 2
    assert "--report is not allowed with a surface yet" in capsys.readouterr().err and calls == []


def test_an_export_with_a_ball_refuses_its_other_settings_before_the_ball_rolls(capsys, monkeypatch, tmp_path):
    # haptex export --tip-radius rolled the ball first (x3p-2.x3p under 5 um: 5-6 s) and only then
    # refused a negative --max-force, an unknown --target, a --max-evaluations out of range, a
    # negative --stiffness or a --device with nothing that reads it. Each is refused with the
    # ball not rolled (felt_by calls counted: none), in one line naming the option as typed.
    from haptex.cli import main

    calls = []
    felt_by = hx.Texture.felt_by
    monkeypatch.setattr(hx.Texture, "felt_by", lambda self, *a, **k: calls.append(a) or felt_by(self, *a, **k))
    path = tmp_path / "map.npy"
    np.save(path, np.zeros((64, 64)))
    base = ["export", "--algorithm", "A", "--texture", str(path), "--spacing", "1um", "--height-unit", "um",
            "--tip-radius", "5um", "--stiffness", "1kN/m", "--max-force", "3N", "--out", str(tmp_path / "out"),
            "--quiet"]
    for extra, said in ((["--max-force", "-1N"], "--max-force -1N is not allowed"),
                        (["--target", "cortex-m9"], "--target"),
                        (["--max-evaluations", "5"], "--max-evaluations 5 is not allowed"),
                        (["--stiffness", "-5N/m"], "--stiffness -5N/m is not allowed"),
                        (["--device", "falcon"], "--device is not allowed without --passivity-control")):
        assert main(base + extra) in (2,), extra
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and said in err and calls == [], (extra, err, calls)
    assert not (tmp_path / "out").exists()
    assert main(base) == 0 and len(calls) == 1  # (and the ball rolls once for an export that is made)
    # haptex run likewise (--stiffness, --passivity-control, --duration were refused after 5 s of
    # rolling on x3p-2.x3p; the passivity controller's refusal named its Python parameter,
    # max_damping): none rolls the ball, and each names the option as typed
    calls.clear()
    run = ["run", "--device", "simulated:falcon", "--texture", "sine:0.1mm,2mm", "--tip-radius", "0.5mm", "--quiet",
           "--fast", "--duration", "0.05s"]
    for extra, said in ((["--stiffness", "-5N/m"], "--stiffness -5N/m is not allowed"),
                        (["--passivity-control", "-1N*s/m"], "--passivity-control -1N*s/m is not allowed"),
                        (["--duration", "-1s"], "--duration -1s is not allowed")):
        assert main(run + extra) == 2, extra
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and said in err and calls == [], (extra, err, calls)
    assert main(run) == 0 and len(calls) == 1


def test_with_a_ball_f_reads_the_felt_maps_heights_and_not_the_maps_as_read(monkeypatch, tmp_path):
    # haptex export and run with F and --tip-radius built F on the map as read to check their
    # settings before the ball rolled: its max|h| and steepest slope (eq. 22's h~ = h / max|h|),
    # sups over the map's patches, for a modulation the felt map replaces (x3p-2.x3p, 650 x 650,
    # felt by a 2 um ball at --tip-spacing 0.536um: the export 5.0 s, 4.6 s without them; the
    # ball's construction reads the map's largest curvature itself). Counted: the map as read
    # has neither computed (its cached properties unset) after an export and a run, and the felt
    # map's F is what is exported
    import importlib

    from haptex.cli import main

    read = []  # (the textures the commands read)

    def reading(spec, *a, _f, **k):
        read.append(_f(spec, *a, **k))
        return read[-1]

    for name in ("haptex.cli.export", "haptex.cli.device"):
        mod = importlib.import_module(name)
        monkeypatch.setattr(mod, "_texture_from_spec", partial(reading, _f=mod._texture_from_spec))
    path = tmp_path / "map.npy"
    np.save(path, 20 * np.sin(np.arange(48)[:, None] / 3) * np.cos(np.arange(48)[None, :] / 4))
    given = ["--texture", str(path), "--spacing", "5um", "--height-unit", "nm", "--tip-radius", "20um",
             "--tip-spacing", "7um", "--quiet"]
    assert main(["export", "--algorithm", "F", "--stiffness", "1kN/m", "--max-force", "3N", "--out",
                 str(tmp_path / "out"), *given]) == 0
    assert main(["run", "--device", "simulated:falcon", "--algorithm", "F", "--fast", "--duration", "0.05s",
                 *given]) == 0
    assert len(read) == 2
    for tex in read:
        assert not {"height_range", "max_slope"} & set(vars(tex)), sorted(vars(tex))
    assert "felt by a ball of r = 0.02 mm" in (tmp_path / "out" / "haptex_texture.c").read_text()


def test_export_and_run_take_the_tip_radius_too(tmp_path):
    # the felt texture is what the exported tick renders (its source names the ball), and a run
    # on the simulated device takes it; the smooth wall has no texture to feel
    from haptex.cli import main

    out = tmp_path / "fw"
    assert main(["export", "--algorithm", "A", "--texture", "sine:0.1mm,2mm", "--stiffness", "1 kN/m", "--max-force",
                 "5 N", "--tip-radius", "5mm", "--out", str(out), "--quiet"]) == 0
    assert "felt by a ball of r = 5 mm" in (out / "haptex_texture.c").read_text()
    assert main(["export", "--algorithm", "W", "--stiffness", "1 kN/m", "--max-force", "5 N", "--tip-radius", "1mm",
                 "--out", str(tmp_path / "w")]) == 2
    assert main(["run", "--device", "simulated:falcon", "--duration", "0.2s", "--fast", "--tip-radius", "0.5mm",
                 "--json", "--quiet"]) == 0


def test_a_ball_too_wide_for_a_fine_map_names_a_spacing_that_works(monkeypatch):
    # the cap on a dilation's work (2e9 operations, 13 s here) lowered to 1e7 for the test: 200 x
    # 200 samples 1 um apart under a 30 um ball (2,821 footprint points, 1.1e8 operations) are
    # refused, and the spacing the refusal names resamples the map by its spline within the cap
    # (here at twice the bound: this rough map at the bound itself, 1.85 um, takes 18 s to feel;
    # the bound taken exactly: test_every_bound_a_refusal_for_work_names_is_a_result_taken_exactly)
    import re

    import haptex.probe

    monkeypatch.setattr(haptex.probe, "MAX_DILATION_WORK", 1e7)
    rng = np.random.default_rng(0)
    x = np.arange(200) * 1e-6
    surf = hx.SampledSurface(x, x, rng.normal(size=(200, 200)) * 1e-7)
    with pytest.raises(ParameterError, match=r"tip_radius = 3e-05 is not allowed here: .* spacing=S\) with S >= ") as e:
        surf.felt_by(30e-6)
    s = float(re.search(r"S >= ([0-9.e+-]+) m", str(e.value)).group(1))
    felt = surf.felt_by(30e-6, spacing=s * 2)
    assert felt.x[1] - felt.x[0] == pytest.approx(s * 2) and "resampled" in felt.source


def _ball_points(r, steps):
    """The grid offsets k * steps (m an axis) inside a ball of radius r (m), counted by numpy:
    a dilation's work a sample (Serra's structuring element on the grid)."""
    axes = [np.arange(-int(r // d) - 1, int(r // d) + 2) * d for d in steps]
    grid = np.meshgrid(*axes, indexing="ij")
    return int(np.count_nonzero(sum(g * g for g in grid) <= r * r))


def _named_bounds(msg):
    """The bounds a refusal for work names, each as the command line and Python take it (m)."""
    import re

    from haptex._units import parse_quantity

    out = {}
    for key, cli, py in (("radius", r"--tip-radius (\S+) or less", r"felt_by\(([0-9.e+-]+)\)"),
                         ("spacing", r"--tip-spacing (\S+) or more", r"spacing=S\) with S >= ([0-9.e+-]+) m")):
        a, b = re.search(cli, msg), re.search(py, msg)
        if a or b:
            assert a and b, msg
            out[key] = parse_quantity(a.group(1), "m", key, require_unit=True)
            assert out[key] == float(b.group(1)), msg  # (the two syntaxes name one double)
    crop = re.search(r"at most ([0-9,]+) samples", msg)
    if crop:
        out["samples"] = int(crop.group(1).replace(",", ""))
    return out


@pytest.mark.parametrize("periodic", [False, True])
def test_every_bound_a_refusal_for_work_names_is_a_result_taken_exactly(monkeypatch, periodic):
    # issue 67: every remedy a refusal names gives a result taken exactly at the bound it
    # states. A ball too wide for a map's grid was refused naming "a smaller radius, a cropped
    # map, or a coarser grid: felt_by(r, spacing=S) with S >= 2.2e-06 m" (metropro-1.dat under a
    # 0.1 mm ball): no bound for the radius or the crop, a spacing 1.4 times the smallest that
    # fits (the work goes as S^-4 on a map, the bound was (work / cap)^(1/2)), and no option at
    # the command line that takes it. Truth: the refusal's definition, the samples times the
    # ball's grid points (numpy's count, _ball_points) against the cap, lowered here to 2e6;
    # walked over a neighbourhood of maps (50-130 samples a side, 1 and 1.5 um apart) and radii
    # (12-40 um): each bound taken exactly gives a felt map, within the cap, and is the largest
    # (the smallest spacing) to its 3 significant digits: 1.5 % past it is over the cap
    import haptex.probe

    cap = 2e6
    monkeypatch.setattr(haptex.probe, "MAX_DILATION_WORK", cap)
    for n, m, d, r in ((50, 60, 1e-6, 40e-6), (80, 70, 1e-6, 25e-6), (130, 90, 1.5e-6, 30e-6), (100, 100, 1e-6, 12e-6)):
        x, y = np.arange(n) * d, np.arange(m) * d
        h = 2e-8 * np.sin(2 * np.pi * x / (n * d))[:, None] * np.cos(2 * np.pi * y / (m * d))[None, :]
        surf = hx.SampledSurface(x, y, h, periodic=periodic)
        assert n * m * _ball_points(r, (d, d)) > cap
        with pytest.raises(ParameterError) as refused:
            surf.felt_by(r)
        msg = str(refused.value)
        assert msg.startswith(f"tip_radius = {r:g} is not allowed here"), msg
        said = _named_bounds(msg)
        a = int(r // d) + 2  # (the fewest samples a side of a part that holds the ball: r within each side)
        croppable = not periodic and a * a * _ball_points(r, (d, d)) <= cap
        assert set(said) == {"radius", "spacing"} | ({"samples"} if croppable else set()), msg
        R = said["radius"]
        assert n * m * _ball_points(R, (d, d)) <= cap < n * m * _ball_points(R * 1.015, (d, d))
        assert surf.felt_by(R).x.size == n
        S = said["spacing"]
        felt = surf.felt_by(r, spacing=S)
        steps = (felt.x[1] - felt.x[0], felt.y[1] - felt.y[0])
        assert min(steps) >= S * (1 - 1e-12) and felt.x.size * felt.y.size * _ball_points(r, steps) <= cap
        with pytest.raises(ParameterError, match="is not allowed here"):
            surf.felt_by(r, spacing=S / 1.015)
        if croppable:  # (a part of the map within it, each side holding the ball)
            N = said["samples"]
            assert N * _ball_points(r, (d, d)) <= cap < (N + 1) * _ball_points(r, (d, d))
            b = min(m, N // a)
            assert b >= a
            assert hx.SampledSurface(x[:a], y[:b], h[:a, :b]).felt_by(r).y.size == b


@needs_data
@pytest.mark.long  # (a design at each bound: 18 s)
def test_at_the_command_line_each_bound_a_refusal_for_work_names_gives_a_design(capsys):
    # metropro-1.dat (640 x 480 samples 1.1 um apart) under a 0.1 mm ball: 26,045 grid points a
    # sample, 8e9 operations, past the cap (2e9). The one line named "felt_by(r, spacing=S) with
    # S >= 2.2e-06 m", which no option of the command line took. Now it names --tip-radius and
    # --tip-spacing bounds; each taken exactly as written gives a design (exit 0). Truth: the
    # refusal's definition, numpy's count of the ball's grid points (_ball_points) times the
    # samples within the cap, and 1.5 % past each bound beyond it
    import json
    import re

    from haptex.cli import main

    path = str(DEKTAK.parent / "metropro-1.dat")
    base = ["design", "--texture", path, "--algorithms", "A", "--quiet"]
    assert main(base + ["--tip-radius", "0.1mm"]) == 2
    msg = capsys.readouterr().err
    assert msg.count("\n") == 1 and msg.startswith("haptex: error: --tip-radius 0.1mm is not allowed here")
    radius = re.search(r"--tip-radius (\S+) or less", msg).group(1)
    spacing = re.search(r"--tip-spacing (\S+) or more", msg).group(1)
    tex = hx.load_texture(path)
    n, d = tex.x.size * tex.y.size, (tex.x[1] - tex.x[0], tex.y[1] - tex.y[0])
    R, S = _named_bounds(msg)["radius"], _named_bounds(msg)["spacing"]
    assert n * _ball_points(R, d) <= 2e9 < n * _ball_points(R * 1.015, d)
    for bound in (S, S / 1.015):
        gx, gy = (int(math.floor((a[-1] - a[0]) / bound)) + 1 for a in (tex.x, tex.y))  # (the resampled grid)
        assert (gx * gy * _ball_points(1e-4, (bound, bound)) <= 2e9) == (bound == S)
    assert main(base + ["--tip-radius", radius]) == 0
    capsys.readouterr()
    assert main(base + ["--tip-radius", "0.1mm", "--tip-spacing", spacing, "--json"]) == 0
    said = json.loads(capsys.readouterr().out)["felt_by_tip"]
    assert said["tip_radius"] == 1e-4 and f"resampled at {spacing[:-2]} um" in said["source"]
    assert main(["design", "--texture", "sine:0.1mm,2mm", "--tip-spacing", "1um", "--quiet"]) == 2  # (no ball)
    assert "--tip-spacing is not allowed without --tip-radius" in capsys.readouterr().err


def test_a_periodic_map_resampled_for_a_ball_keeps_its_cell():
    # a periodic map's felt texture is periodic on the map's own cell (its definition: the ball
    # rolls on the same periodic surface). Resampled at a spacing that does not divide the cell,
    # 0.65 um over 64 um, the felt map took 98 steps of exactly 0.65 um: a cell of 63.7 um, its
    # period 0.3 um short. Its steps now divide the cell, none finer than the spacing asked (so
    # that a spacing a refusal for work names is no more work)
    _, hn = _rough_map()
    x = np.arange(hn.shape[0]) * 1e-6
    surf = hx.SampledSurface(x, x, hn, periodic=True)
    felt = surf.felt_by(10e-6, spacing=0.65e-6)
    assert felt.periodic and felt.cell == pytest.approx(surf.cell, rel=1e-12)
    assert np.all(np.diff(felt.x) >= 0.65e-6 * (1 - 1e-12)) and felt.x.size == 98


def test_a_periodic_profile_resampled_for_a_ball_keeps_its_period():
    # as the map above, on a profile: 1,000 samples of 1 um closed into a 1 mm period, resampled
    # at 0.65 um, took 1,538 steps of exactly 0.65 um, a period of 0.9997 mm
    rng = np.random.default_rng(4)
    x = np.arange(1000) * 1e-6
    prof = hx.SampledProfile(x, rng.normal(size=1000) * 1e-7, periodic=True)
    felt = prof.felt_by(5e-6, spacing=0.65e-6)
    assert felt.periodic and felt.period == pytest.approx(prof.period, rel=1e-12)
    assert np.all(np.diff(felt.x) >= 0.65e-6 * (1 - 1e-12)) and felt.x.size == 1538


def test_a_dilation_too_large_for_an_analytic_surface_is_refused_before_it_is_sampled(monkeypatch):
    # the work (samples x the ball's grid points) is known from the spacing and the radius: a
    # rough analytic surface felt by a 5 um ball (1600 x 1600 samples, 797 points) took 39 s to
    # be refused, the texture evaluated at 2.56 million points first. Here, with the cap lowered
    # to 1e5, the refusal comes with the texture never evaluated
    import haptex.probe

    monkeypatch.setattr(haptex.probe, "MAX_DILATION_WORK", 1e5)
    tex = hx.SumOfGratings.egg_crate(0.1e-3, 2e-3)

    def never(*args, **kwargs):
        raise AssertionError("the texture was sampled before the work was checked")

    monkeypatch.setattr(tex, "height_at", never)
    with pytest.raises(ParameterError, match=r"^tip_radius = 0.0005 is not allowed here: .* spacing=S\) with S >= "):
        tex.felt_by(0.5e-3)


# ---- the instrument's own tip (issue 58) ----------------------------------------------
def _sine_map(A, period, n=4096, periods=8):
    x = np.arange(n) * (periods * period / n)
    return hx.SampledProfile(x, A * np.sin(2 * np.pi * x / period), periodic=True)


def test_a_tip_finer_than_the_crests_leaves_the_map_reliable_and_a_blunt_one_does_not():
    # a sinusoid of amplitude A and period l has its sharpest curvature 4 pi^2 A / l^2 at the
    # crests and troughs: a tip whose radius is well below that curvature radius follows it and
    # leaves no scale unreliable (SurfaceTopography's analysis, Sanner et al. 2022: curvature
    # against -1/(2R)); one well above it does, the cutoff growing with the radius (measured:
    # 295, 323, 344 um at 5, 10, 20 times the curvature radius: beyond the 200 um period, the
    # whole sinusoid is then the tip's shape)
    from haptex.probe import reliability_cutoff

    A, period = 10e-6, 200e-6
    rho = period**2 / (4 * math.pi**2 * A)  # 101 um
    tex = _sine_map(A, period)
    for f in (0.05, 0.1, 0.2):
        assert reliability_cutoff(tex, f * rho) is None, f
    cuts = [reliability_cutoff(tex, f * rho) for f in (5.0, 10.0, 20.0)]
    assert all(c is not None and 0 < c < 8 * period for c in cuts) and cuts[0] < cuts[1] < cuts[2], cuts
    with pytest.raises(ParameterError, match="instrument_tip"):
        reliability_cutoff(tex, 0.0)
    with pytest.raises(ParameterError, match="instrument_tip"):
        reliability_cutoff(hx.Sinusoid(A, period), 1e-6)


def test_design_renders_nothing_finer_than_the_instruments_reliability():
    # design on a measured profile with a blunt instrument: the reliability cutoff joins the band
    # limit's bounds, and where it is the largest it sets the cut-off, the rendered texture holding
    # no shorter period; a sharp instrument changes nothing
    from haptex.design import design
    from haptex.probe import reliability_cutoff

    A, period = 0.1e-3, 1e-3
    x = np.arange(8192) * (8e-3 / 8192)
    tex = hx.SampledProfile(x, A * np.sin(2 * np.pi * x / period) + 5e-6 * np.sin(2 * np.pi * x / 0.05e-3))
    dev = hx.catalogue.preset("pantograph").device()
    plain = design(tex, dev, 1000.0, speed=0.01, algorithms="A")["band_limit"]
    blunt = 0.05
    rc = reliability_cutoff(tex, blunt)
    assert rc is not None and rc > plain["cutoff"]
    got = design(tex, dev, 1000.0, speed=0.01, algorithms="A", instrument_tip=blunt)
    band = got["band_limit"]
    assert band["set_by"] == ["instrument tip"] and band["cutoff"] == pytest.approx(rc)
    assert band["instrument_tip"] == blunt and band["reliability_cutoff"] == pytest.approx(rc)
    assert got["texture_numbers"]["shortest_period"] >= rc * (1 - 1e-9)
    sharp = design(tex, dev, 1000.0, speed=0.01, algorithms="A", instrument_tip=1e-9)["band_limit"]
    assert sharp["cutoff"] == plain["cutoff"] and sharp["reliability_cutoff"] is None


@needs_data
def test_the_dektak_file_states_its_stylus_and_design_reports_it(capsys):
    # the Dektak scan's header gives its stylus radius, 2.5 um (../shared/data/README.md): read,
    # reported, and its reliability cutoff (1.6 um, SurfaceTopography's) far below any device's
    from haptex.cli import main

    tex = hx.load_texture(str(DEKTAK))
    assert tex.instrument_tip == pytest.approx(2.5e-6)
    assert main(["design", "--texture", str(DEKTAK), "--device", "falcon", "--algorithms", "A", "--level"]) == 0
    out = capsys.readouterr().out
    assert "measured with a tip of r = 2.5 um (the file states it)" in out and "below 1.5" in out
    assert main(["design", "--texture", str(DEKTAK), "--device", "falcon", "--instrument-tip", "0um"]) == 2
    assert "--instrument-tip 0um is not allowed" in capsys.readouterr().err  # (the option as typed)
    assert main(["design", "--texture", "sine:0.2mm,2mm", "--device", "pantograph", "--instrument-tip", "2um"]) == 2
    assert "--instrument-tip is not allowed with the synthetic texture" in capsys.readouterr().err
