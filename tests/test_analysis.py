"""Characteristic numbers, loop energies, curl, continuity and conservativity against the
paper's closed forms (eqs. 10, 12, 29), Table II and brute-force references."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import haptex as hx

from .conftest import A, K0, L, counting, textures

SINE = hx.Sinusoid(A, L)


def alg(letter, tex=SINE, **kw):
    return hx.algorithm(letter, None if letter == "W" else tex, K0, **kw)


# -- characteristic numbers ------------------------------------------------------------
def test_q_A_is_eq_10_and_the_paper_reports_5_1():
    q = hx.characteristic_number(alg("A"))
    assert q.value == pytest.approx(math.sqrt(1 + (2 * math.pi * A / L) ** 2), rel=1e-9)
    assert q.closed_form == pytest.approx(q.value, rel=1e-9)
    assert round(q.value, 1) == 5.1  # Section V-A: q_A = 5.1
    assert math.cos(2 * math.pi * q.where[0] / L) ** 2 == pytest.approx(1.0, abs=1e-9)  # p^x = 0 mod l/2


@given(textures())
def test_q_A_of_a_sum_of_sinusoids_uses_the_lipschitz_bound(tex):
    # Remark 2: 2 pi A / l is replaced by M = sup |h'|
    q = hx.characteristic_number(alg("A", tex))
    assert q.value == pytest.approx(math.sqrt(1 + tex.max_slope**2), rel=1e-7)


def test_q_W_and_E_are_one():
    assert float(hx.characteristic_number(alg("W"))) == pytest.approx(1.0, abs=1e-12)
    e = hx.characteristic_number(alg("E"))
    assert e.value == pytest.approx(1.0, abs=1e-9) and e.closed_form == 1.0  # eq. 21


def dense_sup(a, dmax=1e-3, nx=2001, nd=401):
    """Reference: a dense grid over one period and depth (0, dmax]."""
    x = np.linspace(0, L, nx)
    d = np.linspace(dmax / nd, dmax, nd)
    X, D = np.meshgrid(x, d, indexing="ij")
    Z = (a.texture.height(X) - D) if a.penetration_kind == "vertical" else -D
    return float(hx.spectral_norm(a.jacobian(np.stack([X, Z], -1))).max()) / K0


@pytest.mark.parametrize("letter", ["B", "C", "G"])
def test_q_without_closed_form_is_the_sup_not_a_grid_sample(letter):
    q = hx.characteristic_number(alg(letter))
    ref = dense_sup(alg(letter))
    assert q.closed_form is None  # Table II: "No closed-form"
    assert q.value >= ref * (1 - 1e-12)
    assert q.value == pytest.approx(ref, rel=1e-4)
    # a coarse grid must not lose the sup either: refinement recovers it
    coarse = hx.characteristic_number(alg(letter), resolution=(16, 4))
    assert coarse.value == pytest.approx(q.value, rel=1e-6)


def test_q_grows_with_max_penetration_for_coupled_algorithms():
    # Remark 3: the characteristic number of B, C, G depends on the penetration
    for letter in "BCG":
        q1 = hx.characteristic_number(alg(letter), max_penetration=0.2e-3).value
        q2 = hx.characteristic_number(alg(letter), max_penetration=1e-3).value
        assert q2 > q1


def test_q_D_is_unbounded_at_the_centre_of_curvature_below_each_peak():
    q = hx.characteristic_number(alg("D"))
    rho = L**2 / (4 * math.pi**2 * A)  # radius of curvature at the peak, 31.7 um
    assert q.unbounded and math.isinf(float(q))
    assert q.where[0] == pytest.approx(L / 4, abs=1e-9)
    assert q.where[1] == pytest.approx(A - rho, abs=1e-9)
    assert q.closed_form == 1.0 and q.paper_form_value == pytest.approx(1.0, rel=1e-9)  # eq. 18
    # approaching the focus from above, ||J||/kappa_0 = (r/rho)/(1 - r/rho) exactly (s = 0)
    d = alg("D")
    for frac in (0.5, 0.9, 0.99, 0.999):
        p = np.array([[L / 4, A - frac * rho]])
        norm = hx.spectral_norm(d.jacobian(p))[0] / K0
        assert norm == pytest.approx(frac / (1 - frac), rel=1e-6)


def test_q_D_is_bounded_when_the_curvature_is_gentle():
    # A = 20 um, l = 1 mm: radius of curvature rho = l^2/(4 pi^2 A) = 1.27 mm > 1 mm, so the
    # sup is finite. Directly below a peak at depth r, ||J||/kappa_0 = (r/rho)/(1 - r/rho)
    # (s = 0 in the exact Jacobian), largest at r = 1 mm: 3.74. A dense grid agrees.
    amp = 20e-6
    tex = hx.Sinusoid(amp, 1e-3)
    q = hx.characteristic_number(alg("D", tex))
    rho = L**2 / (4 * math.pi**2 * amp)
    assert math.isfinite(q.value)
    assert q.value == pytest.approx((1e-3 / rho) / (1 - 1e-3 / rho), rel=1e-3)
    x = np.linspace(0, L, 801)
    z = np.linspace(-amp - 1e-3, amp, 801)
    P = np.stack(np.meshgrid(x, z, indexing="ij"), -1)
    cp = hx.closest_point(tex, P)
    ok = (cp.distance > 0) & (cp.distance <= 1e-3)
    ref = float(hx.spectral_norm(alg("D", tex).jacobian(P))[ok].max()) / K0
    assert q.value >= ref * (1 - 1e-9)


# -- loop energies (Fig. 3) ------------------------------------------------------------
def test_loop_A_is_half_kappa0_A_squared():
    path, expected, _ = hx.paper_loop(alg("A"))
    np.testing.assert_allclose(path, [[0, 0], [L / 4, 0], [L / 4, A], [0, A], [0, 0]])
    assert expected == pytest.approx(0.5 * K0 * A * A)
    assert hx.path_work(alg("A"), path) == pytest.approx(0.5 * K0 * A * A, rel=1e-6)


def test_loop_B_is_eq_12():
    path, _, _ = hx.paper_loop(alg("B"))
    eq12 = K0 * A**2 / 2 + K0 * L**2 / (4 * math.pi**2) * (1 - math.sqrt((L**2 + 4 * A**2 * math.pi**2) / L**2))
    assert hx.path_work(alg("B"), path) == pytest.approx(eq12, rel=1e-6)
    assert eq12 == pytest.approx(4.3102e-4, rel=1e-4)


def test_loop_E_is_positive():
    path, expected, _ = hx.paper_loop(alg("E"))
    assert expected is None
    assert hx.path_work(alg("E"), path) > 1e-5  # Section IV-E-4: Delta E > 0


def test_loop_G_equals_the_work_along_its_bottom_segment():
    # eq. 29: -k a^2/2 + dE2 + k a^2/2 + 0 = dE2, and for h = A sin the bottom segment's work
    # integrates to kappa_0 a l arctan(2 pi A / l) / pi
    a = 0.5e-3
    path, expected, _ = hx.paper_loop(alg("G"), depth=a)
    loop = hx.path_work(alg("G"), path)
    bottom = hx.path_work(alg("G"), path[1:3])
    assert loop == pytest.approx(bottom, rel=1e-9)
    assert loop == pytest.approx(K0 * a * L * math.atan(2 * math.pi * A / L) / math.pi, rel=1e-6)
    assert expected == pytest.approx(loop, rel=1e-6)
    assert hx.path_work(alg("G"), path[0:2]) == pytest.approx(-0.5 * K0 * a * a, rel=1e-9)


@pytest.mark.parametrize("letter", ["C", "D", "W"])
def test_paper_loop_is_zero_for_gradient_fields(letter):
    path, expected, _ = hx.paper_loop(alg(letter))
    assert expected == 0.0
    assert abs(hx.path_work(alg(letter), path)) < 1e-12 * K0 * L * L


@pytest.mark.parametrize("letter", ["C", "W", "D"])
@given(tex=textures(max_components=2), seed=st.integers(0, 2**32 - 1))
def test_random_closed_polygons_do_no_work_in_gradient_fields(letter, tex, seed):
    a = alg(letter, tex)
    for loop in hx.random_loops(a, n=1, vertices=4, seed=seed):
        assert abs(hx.loop_energy(a, loop)) < 1e-9 * K0 * (2e-3) ** 2


def test_path_work_equals_potential_drop_for_gradient_fields():
    # W = V(start) - V(end) along an open path that enters and leaves the wall
    path = np.array([[0.1e-3, 1e-3], [0.3e-3, -0.7e-3], [0.9e-3, -0.2e-3], [1.3e-3, -1.1e-3]])
    for letter in "CDW":
        a = alg(letter)
        V = a.potential(path[[0, -1]])
        assert hx.path_work(a, path) == pytest.approx(V[0] - V[1], rel=1e-8)


def test_stokes_theorem_links_curl_and_loop_energy_for_A():
    # For A the curl is kappa_0 h'(x); over a rectangle inside the wall the loop energy is
    # the integral of the curl: kappa_0 (z1 - z0)(h(x1) - h(x0)).
    a = alg("A")
    x0, x1, z0, z1 = 0.05e-3, 0.2e-3, -1.2e-3, -0.9e-3
    rect = np.array([[x0, z0], [x1, z0], [x1, z1], [x0, z1], [x0, z0]])
    expected = K0 * (z1 - z0) * float(SINE.height(np.array([x1]))[0] - SINE.height(np.array([x0]))[0])
    assert hx.path_work(a, rect) == pytest.approx(expected, rel=1e-8)
    p = np.array([[0.1e-3, -1e-3]])
    assert hx.curl(a, p)[0] == pytest.approx(K0 * float(SINE.slope(p[:, 0])[0]), rel=1e-12)


@pytest.mark.parametrize("letter", ["C", "W"])
def test_curl_vanishes_for_gradient_fields(letter):
    rng = np.random.default_rng(0)
    p = np.column_stack([rng.uniform(0, L, 100), rng.uniform(-1.8e-3, -0.81e-3, 100)])
    np.testing.assert_allclose(hx.curl(alg(letter), p), 0.0, atol=1e-9 * K0)


def test_path_work_rejects_bad_paths():
    with pytest.raises(hx.ParameterError, match=r"^path has shape"):
        hx.path_work(alg("A"), [[0.0, 0.0]])
    with pytest.raises(hx.ParameterError, match="non-finite"):
        hx.path_work(alg("A"), [[0.0, 0.0], [np.nan, 0.0]])


# -- continuity and conservativity (Table II) ---------------------------------------------
@pytest.mark.parametrize("letter, continuous", [("W", True), ("A", True), ("B", True), ("C", True),
                                                ("D", False), ("E", True), ("G", True)])
def test_continuity_matches_table_II(letter, continuous):
    c = hx.continuity(alg(letter))
    assert c.continuous is continuous
    if letter == "D":
        # Remark 6: the jump is below the maxima of the sinusoid (x = l/4)
        assert c.where[0] == pytest.approx(L / 4, abs=2 * c.spacings[-1])
        assert c.order < 0.1
    else:
        assert c.order > 0.8


@pytest.mark.parametrize("letter, conservative", [("W", True), ("A", False), ("B", False), ("C", True),
                                                  ("D", True), ("E", False), ("G", False)])
def test_conservativity_matches_table_II(letter, conservative):
    c = hx.conservativity(alg(letter))
    assert c.conservative is conservative


def test_bad_analysis_input():
    with pytest.raises(hx.ParameterError, match=r"^max_penetration = 0 "):
        hx.characteristic_number(alg("A"), max_penetration=0)
    with pytest.raises(hx.ParameterError, match=r"^x_range = "):
        hx.characteristic_number(alg("A"), x_range=(1e-3, 0))
    aperiodic = hx.SumOfSinusoids([1e-4, 1e-4], [1e-3, math.sqrt(2) * 1e-3])
    with pytest.raises(hx.ParameterError, match="x_range = None is not allowed for the aperiodic"):
        hx.characteristic_number(alg("A", aperiodic))
    assert hx.characteristic_number(alg("A", aperiodic), x_range=(0, 5e-3)).value > 1
    with pytest.raises(hx.ParameterError, match="Fig. 3 loops are defined for a Sinusoid"):
        hx.paper_loop(alg("A", aperiodic))


@pytest.mark.parametrize("depth", [0.2e-3, 0.5e-3, 1.5e-3])
def test_G_is_neutral_along_a_constant_depth_over_a_period(depth):
    # Issue 10's explanation of Fig. 6: G's lateral force is kappa_0 d h' / sqrt(1 + h'^2) at a
    # constant depth d, and h' = (2 pi A / l) cos(2 pi x / l) integrates to zero over a period
    # with that odd weighting (by hand), so G neither supplies nor absorbs energy at constant
    # depth; its Fig. 6 generation needs the depth to co-vary with the slope.
    alg = hx.algorithm("G", hx.Sinusoid(A, L), K0)
    w = hx.path_work(alg, [[0.1e-3, -depth], [0.1e-3 + L, -depth]])
    assert abs(w) <= 1e-12 * K0 * A * L
    # and a depth that follows the slope is not neutral: down the rising flank, up the falling one
    x = np.linspace(0.0, L, 401)
    path = np.column_stack([x, -depth - 0.2e-3 * np.cos(2 * np.pi * x / L)])
    assert abs(hx.path_work(alg, path)) > 1e-3 * K0 * A * L


def test_q_D_is_one_down_to_half_the_radius_of_curvature_below_the_peaks():
    # Below a peak h' = 0 and D = 1 - depth / rho (rho = l^2 / (4 pi^2 A), the radius of
    # curvature), so the exact gain max(1, 1/D - 1) of D stays 1 while depth <= rho / 2
    # (by hand): eq. 18's q_D = 1 holds there, and only there.
    alg = hx.algorithm("D", hx.Sinusoid(A, L), K0)
    rho = L**2 / (4 * math.pi**2 * A)
    assert hx.characteristic_number(alg, max_penetration=0.98 * rho / 2).value == pytest.approx(1.0, abs=1e-6)
    deeper = hx.characteristic_number(alg, max_penetration=1.02 * rho / 2).value
    assert deeper == pytest.approx(1 / (1 - 1.02 / 2) - 1, rel=1e-3)  # 1/D - 1 at the deepest point


def test_D_path_work_finds_two_medial_axis_crossings_in_one_sample_interval():
    # Found by hypothesis (test_random_closed_polygons_do_no_work_in_gradient_fields): this
    # segment crosses a thin branch of the medial axis twice within 2.2 um (closest point
    # 2.98 -> 2.11 -> 1.08 mm), inside one of path_work's 16 um sampling intervals; only one
    # jump was located and the loop of a gradient field (eq. 16) "generated" 3.3e-6 J.
    tex = hx.SumOfSinusoids([0.0001193662073189215, 0.0004133064354502457], [1e-3, 4e-3], [4.203125, 5.0])
    a = hx.algorithm("D", tex, K0)
    loop = np.array([[1.04644854e-03, -2.95560960e-04], [1.19396457e-03, -3.69411755e-05],
                     [3.25690296e-03, -1.12541409e-03], [3.67663769e-04, -1.39267959e-03],
                     [1.04644854e-03, -2.95560960e-04]])
    assert abs(hx.loop_energy(a, loop)) < 1e-12 * K0 * (2e-3) ** 2


@pytest.fixture(scope="module")
def felt_rendered():
    """What `haptex design --texture sine:0.2mm,2mm --tip-radius 0.532mm` analyses on an omega-3:
    the sinusoid felt by the ball, band-limited to the device's 0.125 mm cut-off (512 samples)."""
    from haptex.design import _rendered

    return _rendered(hx.Sinusoid(0.2e-3, 2e-3).felt_by(0.532e-3), 0.125e-3)[0]


def test_a_loop_below_a_band_limited_trough_is_integrated_in_bounded_work(felt_rendered, monkeypatch):
    # D's force is the gradient of -k0 d^2 / 2 (eq. 17, d the distance to the closest point), so
    # its energy around any loop is zero (Section III-C): the truth, the closed form. Below the
    # felt sinusoid's trough, band-limited as design renders it, the first random loop (5
    # segments) was cut 5,215 times, thousands of the cuts a few nm apart: near a centre of
    # curvature the closest point runs fast (1 / (1 - d kappa) times the probe), and the jump
    # test took any motion past 1e-12 of the period in a bisected bracket for a jump, each found
    # one splitting its bracket again (260,952 closest-point searches for the cuts); path_work
    # integrated each part between the cuts by 16-point Gauss-Legendre on pieces of 1/8 of the
    # period and doubled every piece of a part until two sums agreed: 315,728 force evaluations
    # for this loop (312,752 more searches), 1.27 million for conservativity's four (34 s), and
    # `haptex design` on this texture took 71 s where its estimate said 9 s (2026-11-28). Now only
    # the pieces whose error estimate misses their share are halved, parts narrower than 1e-4 of
    # the period take the 2-point rule, and a jump moves the closest point by more than 1e-9 of
    # the period (a smaller one is a non-smooth point the halving closes in on): 77,696 force
    # evaluations, 80,066 closest-point searches (74,720 of them the force's, 5,346 the cuts')
    a = hx.algorithm("D", felt_rendered, K0)
    evaluations = counting(monkeypatch, type(a), "force")
    searches = counting(monkeypatch, hx.algorithms, "closest_point")  # (the force's and the cuts')
    loop = hx.random_loops(a, 4, 5, 1e-3, 0)[0]
    tol = 1e-9 * K0 * (16 * felt_rendered.shortest_period) ** 2  # (conservativity's verdict)
    assert abs(hx.loop_energy(a, loop, rtol=1e-10, atol=1e-3 * tol)) <= 1e-3 * tol
    assert sum(evaluations) <= 160_000
    assert sum(searches) <= 150_000


@pytest.mark.parametrize("letter", ["B", "E"])
def test_path_work_is_quadpacks_integral_of_the_force(felt_rendered, letter):
    # The work along each segment of a random loop against QUADPACK's (scipy.integrate.quad,
    # adaptive Gauss-Kronrod, no code shared with path_work's) integral of the same force along
    # it, given the same cuts (where the closest point jumps, for E) and the spline's knots
    # (its third derivative jumps there: quad over a part holding hundreds of them missed by
    # 6e-9 of the work where it claimed 1e-12), within ten times path_work's rtol: B and E are not
    # gradient fields (Table II), so no closed form holds for them
    from scipy import integrate

    from haptex.algorithms import _breakpoints

    a = hx.algorithm(letter, felt_rendered, K0)
    loop = hx.random_loops(a, 4, 5, 1e-3, 0)[3]
    checked = 0
    for p, q in zip(loop[:-1], loop[1:]):
        cuts = [0.0, *_breakpoints(a, p, q), 1.0]
        if len(cuts) > 40:
            continue  # (quad, one point a call, would take minutes)
        d = q - p
        if d[0] != 0:
            knots = (felt_rendered.x - p[0]) / d[0]
            cuts = sorted([*cuts, *knots[(knots > 0) & (knots < 1)]])
        truth = sum(integrate.quad(lambda u: float(a.force((p + u * d)[None])[0] @ d), u0, u1,
                                   epsabs=1e-16, epsrel=1e-12, limit=500)[0]
                    for u0, u1 in zip(cuts[:-1], cuts[1:]) if u1 > u0)
        got = hx.path_work(a, [p, q], rtol=1e-10)
        assert got == pytest.approx(truth, rel=1e-9, abs=1e-15 * K0 * float(d @ d))
        checked += 1
    assert checked >= 3


def _peaks_by_definition(values, count=8):
    """The ``count`` largest local maxima of a grid, one per plateau (connected equal maxima,
    its first point in C order), best first: scipy.ndimage's maximum filter over 3 x ... x 3
    neighbourhoods (edges repeated), its labels and positions, as the candidates' definition
    states (no haptex code); -inf and NaN are never maxima."""
    from scipy import ndimage

    v = np.where(np.isfinite(values), values, -np.inf)
    peak = (ndimage.maximum_filter(v, size=3, mode="nearest") == v) & np.isfinite(v)
    labels, n = ndimage.label(peak, structure=np.ones((3,) * v.ndim))
    if n == 0:
        return [int(np.argmax(v))]
    # (each plateau's first point in C order, by a loop over the plateaus: ndimage.maximum_position's
    # choice among equal maxima with an array of labels follows numpy's argsort, whose order of
    # ties depends on the CPU's SIMD sort: (3, 19, 3) before (3, 18, 2) on an AVX-512 EPYC,
    # 2026-11-30, the reverse on the machine this test was written on)
    flat, lab = v.ravel(), labels.ravel()
    first = []
    for k in range(1, n + 1):
        members = np.flatnonzero(lab == k)
        first.append(int(members[flat[members] == flat[members].max()][0]))
    return sorted(first, key=lambda i: -flat[i])[:count]


@pytest.mark.parametrize("shape", [(40, 9), (24, 20, 6)])
def test_the_region_is_searched_only_as_far_as_its_best_points_need(shape):
    # D and E's Jacobians hold where a grid point's foot is its unique closest point (the
    # region), and q's refinement starts from the best local maxima of ||J|| there. Each
    # uniqueness costs a closest-point search (150,152 of them, 55 s, on the felt egg-crate at
    # 0.95 rho, 2026-11-29): the analysis now decides it in decreasing order of ||J|| at the
    # foot, only until the best maxima are settled. Truth: the definition (the local maxima of
    # ||J|| where the foot is unique, every point decided, scipy.ndimage), on random grids with
    # ties (values rounded to 0.1 or 0.5: plateaus), NaN and inf (centres of curvature: never
    # maxima), and regions of 0 to 100 % of the points
    from haptex.analysis.characteristic import _region_candidates

    rng = np.random.default_rng(11)
    for trial in range(30):
        values = np.round(rng.normal(size=shape) * [1e8, 10, 2][trial % 3]) / [1e8, 10, 2][trial % 3]
        values.ravel()[rng.integers(0, values.size, 5)] = rng.choice([np.nan, np.inf], 5)
        unique = rng.random(shape) < [0.0, 0.05, 0.5, 0.9, 1.0][trial % 5]
        asked = []

        def decide(idx):
            asked.append(len(idx))
            return unique.ravel()[idx]

        got, region, checked = _region_candidates(values, decide)
        assert list(got) == _peaks_by_definition(np.where(unique, values, -np.inf)), trial
        assert checked == sum(asked) <= values.size
        assert not np.any(region & ~unique) and region.any() == unique.any()  # (a point of it, if any)
    # a smooth field whose every foot is unique, with 12 maxima: its best 8 settle in the first
    # batch (512 of 40,000 points); with 4 maxima, proving there is no fifth takes nearly every
    # point's region (the analysis then costs what it did)
    g = np.stack(np.meshgrid(*[np.linspace(0, 6, n) for n in (200, 200)], indexing="ij"))
    for f, most in ((2, 512), (1, 40_000)):
        smooth = np.sin(f * g[0]) * np.cos(f * g[1]) + 0.01 * g[0]
        got, _, checked = _region_candidates(smooth, lambda idx: np.ones(len(idx), bool))
        assert list(got) == _peaks_by_definition(smooth) and checked <= most


_TAKE_AN_ALGORITHM = [  # (module, function, a GodObject too): every public function whose first parameter is an algorithm
    ("haptex.analysis.characteristic", "characteristic_number", False),
    ("haptex.analysis.characteristic", "characteristic_points", False),
    ("haptex.analysis.characteristic", "friction_bounds", False),
    ("haptex.analysis.continuity", "continuity", False), ("haptex.analysis.continuity", "continuity_points", False),
    ("haptex.analysis.continuity", "grid_points", False), ("haptex.analysis.cost", "evaluation_time", False),
    ("haptex.analysis.cost", "analysis_cost", False), ("haptex.analysis.maps", "field_map", False),
    ("haptex.analysis.passivity", "passivity_condition", False),
    ("haptex.analysis.passivity", "max_passive_stiffness", False), ("haptex.analysis.work", "path_work", False),
    ("haptex.analysis.work", "loop_energy", False), ("haptex.analysis.work", "paper_loop", False),
    ("haptex.analysis.work", "curl", False), ("haptex.analysis.work", "random_loops", False),
    ("haptex.analysis.work", "conservativity", False), ("haptex.core", "field", True),
    ("haptex.limits", "clean_stiffness", False), ("haptex.renderer", "Renderer", True),
    ("haptex.simulate", "simulate", True), ("haptex.simulate", "simulate_batch", True),
    ("haptex.export", "export_c", True), ("haptex.export", "build_defines", True),
    ("haptex.renderer", "reads_search_budget", True), ("haptex.renderer", "tick_model", True),
    ("haptex.servo", "budgeted_search", True), ("haptex.servo", "search_budget", True),
    ("haptex.algorithms", "checked_algorithm", False),
]


def _first_alone(module, name):
    """(the public function ``module.name``, None for each of its required arguments after the
    first): a call that reaches its first argument's check and no other."""
    import importlib
    import inspect

    fn = getattr(importlib.import_module(module), name)
    params = list(inspect.signature(fn).parameters.values())[1:]
    return fn, [None] * sum(p.default is inspect.Parameter.empty for p in params)


@pytest.mark.parametrize("module, name, proxy", _TAKE_AN_ALGORITHM)
def test_a_texture_given_for_an_algorithm_is_refused_naming_the_algorithm_that_renders_it(module, name, proxy):
    # A newcomer's hx.characteristic_number(texture) (q of "the texture") raised "AttributeError:
    # 'Sinusoid' object has no attribute 'stiffness'"; max_passive_stiffness said a pantograph
    # "is not allowed ... a profile needs a planar device" (2026-12-01). Truth: each function's
    # documented first parameter, an algorithm (haptex.algorithm(letter, texture, stiffness),
    # eq. 5's q and the paper's analyses are an algorithm's, not a texture's); the list above is
    # checked against the package's public functions whose first parameter is named so
    import inspect

    fn, others = _first_alone(module, name)
    assert list(inspect.signature(fn).parameters)[0] == "algorithm"
    tex = hx.Sinusoid(0.2e-3, 2e-3)
    with pytest.raises(hx.ParameterError) as e:
        fn(tex, *others)
    said = str(e.value)
    assert said.startswith(f"algorithm = {tex!r} is not allowed: must be a haptex algorithm"), said
    assert "haptex.algorithm('A', texture, 2000.0)" in said, said
    assert ("GodObject" in said) == proxy, said


def test_every_public_function_that_takes_an_algorithm_first_is_checked_above():
    # (the list above is every one: a function added later is refused here until it is listed)
    from .conftest import public_api

    found = {(m, n) for m, n, _, params in public_api() if params[:1] == ["algorithm"]}
    assert found == {(m, n) for m, n, _ in _TAKE_AN_ALGORITHM}


def _device_takers():
    """(name, call taking the device) of every public function whose ``device`` must be a
    haptex.Device, each with its other arguments valid."""
    from haptex import design, identification, limits
    from haptex.analysis import passivity
    from haptex.datadriven import ArmaModel, energy

    tex = hx.Sinusoid(0.2e-3, 2e-3)
    alg = hx.algorithm("A", tex, 2000.0)
    model = ArmaModel(np.array([1.0, -0.5]), np.array([1.0]), 1e-4, 1.0, 10_000.0)
    return [("texture_limits", lambda d: passivity.texture_limits(tex, d, 0.1, 2000.0)),
            ("rendering_cutoff", lambda d: passivity.rendering_cutoff(d, 0.1)),
            ("passivity_condition", lambda d: passivity.passivity_condition(alg, d)),
            ("max_passive_stiffness", lambda d: passivity.max_passive_stiffness(alg, d)),
            ("design", lambda d: design.design(tex, d, 2000.0)),
            ("rendered_texture", lambda d: design.rendered_texture(tex, d, 0.1)),
            ("simulated_log", lambda d: identification.simulated_log(d, 0.1)),
            ("normal_axis", lambda d: limits.normal_axis(d)),
            ("wall_limits", lambda d: limits.wall_limits(d)),
            ("simulated_wall_limit", lambda d: limits.simulated_wall_limit(d, "light-touch", 1000.0)),
            ("clean_stiffness", lambda d: limits.clean_stiffness(alg, d, None, [1000.0], [1000.0])),
            ("simulate", lambda d: hx.simulate(alg, d, None, 0.1)),
            ("simulate_batch", lambda d: hx.simulate_batch(alg, d, None, 0.1)),
            ("port_energy", lambda d: energy.port_energy(model, d))]


@pytest.mark.parametrize("typed, meant", [("touch", "touch"), ("omega.3", "omega-3"), ("kuka", None)])
@pytest.mark.parametrize("case", range(len(_device_takers())))
def test_a_device_given_by_its_name_is_refused_naming_the_call_that_makes_it(case, typed, meant):
    # A researcher's hx.max_passive_stiffness(alg, "touch") raised "AttributeError: 'str' object
    # has no attribute 'dimension'" (design, wall_limits, rendering_cutoff, simulated_log: the
    # same, each its own attribute; 2026-12-01). Truth: each function's documented parameter, a
    # haptex.Device, which a preset of `haptex devices` makes with
    # haptex.catalogue.preset(NAME).device()
    name, call = _device_takers()[case]
    with pytest.raises(hx.ParameterError) as e:
        call(typed)
    said = str(e.value)
    assert said.startswith(f"device = {typed!r} is not allowed: must be a haptex.Device"), (name, said)
    if meant is not None:
        assert f"haptex.catalogue.preset({meant!r}).device()" in said, (name, said)
    else:
        assert "haptex.catalogue.preset(" in said and "'kuka'" not in said.split("must be")[1], (name, said)


_TAKE_A_TEXTURE = [("haptex.analysis.passivity", "texture_limits"), ("haptex.closest", "closest_point"),
                   ("haptex.closest", "search_data"), ("haptex.closest", "table_search_data"),
                   ("haptex.closest", "surface_search_data"), ("haptex.datadriven", "follower_vibration"),
                   ("haptex.design", "design"), ("haptex.design", "rendered_texture"), ("haptex.probe", "felt_by"),
                   ("haptex.probe", "reliability_cutoff"), ("haptex.proxy", "loop_work"), ("haptex", "algorithm"),
                   ("haptex", "Algorithm"), ("haptex.algorithms", "ForceShading")]


@pytest.mark.parametrize("module, name", _TAKE_A_TEXTURE)
def test_a_texture_written_as_the_command_line_writes_it_is_refused_naming_the_class_that_makes_it(module, name):
    # hx.design("sine:0.2mm,2mm", device, 2000.0) raised "AttributeError: 'str' object has no
    # attribute 'dimension'", texture_limits "... 'shortest_period'" (2026-12-01). Truth: each
    # function's documented parameter, a haptex Texture (SI units: the command line's specs
    # with their units are the command line's); haptex.algorithm('A', texture) as the first of
    # them (its letter first)
    fn, others = _first_alone(module, name)
    spec = "sine:0.2mm,2mm"
    args = ["A", spec] if name == "algorithm" else [spec] + others
    with pytest.raises(hx.ParameterError) as e:
        fn(*args)
    said = str(e.value)
    assert said.startswith(f"texture = {spec!r} is not allowed: must be a haptex Texture"), said
    assert "haptex.Sinusoid(0.8e-3, 1e-3)" in said and "haptex.load_texture(PATH)" in said, said
