"""Algorithm F and its presliding friction (Hayward & Armstrong [32]): eq. 24's stick and
slip, the C core's against eq. 24 as written and against an ODE solver, rate
independence, eq. 22's field and Jacobian, eq. 27's loop energy, dissipation in slip,
the characteristic number against eq. 26 and Appendix I, and bad input."""

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.integrate import solve_ivp

import haptex as hx
from haptex import friction as fr

from .conftest import A, K0, L, textures

DM = 1e-3  # d^x_max = d^z_max = 1 mm, Section V-A
MU = 0.8


def F(tex=None, **kw):
    return hx.algorithm("F", hx.Sinusoid(A, L) if tex is None else tex, K0, **kw)


# -- the presliding model ------------------------------------------------------------------
def test_stick_then_slip_as_eq_24():
    s = fr.PreslidingState.at(0.0, DM)
    d, s = fr.step(s, 0.4e-3)
    assert d == pytest.approx(0.4e-3) and s.adhesion == 0.0  # stick: w stays, dd/dx = 1
    d, s = fr.step(s, 2.5e-3)
    assert d == DM and s.adhesion == pytest.approx(1.5e-3)  # slip: |d| = d_max, w dragged
    d2, s = fr.step(s, 3.0e-3)
    assert d2 == DM  # dd/dx = 0 in slip
    d, s = fr.step(s, 2.0e-3)
    assert d == pytest.approx(0.0, abs=1e-18)  # reversal: stick again, elastic recovery
    assert fr.phase_of(DM, DM) == "slip" and fr.phase_of(0.999 * DM, DM) == "stick"


@given(st.lists(st.floats(-5e-3, 5e-3), min_size=1, max_size=200))
def test_the_sharp_model_is_eq_24_as_written(xs):
    # Truth: eq. 24 (Hayward & Armstrong's sharp presliding model) written out here, nothing of
    # haptex's: the adhesion point w stays while |x - w| <= d_max, else it is dragged to x -+
    # d_max; d = x - w. Both of haptex's entry points (the state update the algorithms use and
    # the C core's step) follow it along any path, to the rounding of x - (x - w) (they compared
    # with each other before, the first a plain-Python twin of the second)
    s = fr.PreslidingState.at(0.0, DM)
    w = w_core = 0.0
    for x in xs:
        if x - w > DM:
            w = x - DM
        elif x - w < -DM:
            w = x + DM
        d, s = fr.step(s, x)
        d_core, w_core = fr.presliding_step(w_core, x, DM)
        for dd, ww in ((d, s.adhesion), (d_core, w_core)):
            assert abs(dd) <= DM
            assert dd == pytest.approx(x - w, abs=1e-18) and ww == pytest.approx(w, abs=1e-18)


def test_smooth_variant_matches_an_ode_solver():
    # Reference: dd/dx = 1 - alpha(d)|d|/d_max while |d| grows (Dupont et al. 2002),
    # integrated by scipy's adaptive RK45 at rtol 1e-11.
    zs = 0.4e-3

    def rate(x, d):
        a = abs(d[0])
        alpha = 0.0 if a <= zs else (1.0 if a >= DM else 0.5 + 0.5 * math.sin(math.pi * (a - (DM + zs) / 2) / (DM - zs)))
        return [1.0 - alpha * a / DM]

    ref = solve_ivp(rate, [0.0, 3e-3], [0.0], rtol=1e-11, atol=1e-16, dense_output=True)
    s = fr.PreslidingState.at(0.0, DM, zs)
    for x in np.linspace(0.1e-3, 3e-3, 30):
        d, s = fr.step(s, x)
        assert d == pytest.approx(ref.sol(x)[0], rel=1e-9)
    assert 0.95 * DM < d < DM  # approaches d_max smoothly, never beyond
    d, s = fr.step(s, 2.5e-3)  # back by 0.5 mm: elastic
    assert d == pytest.approx(ref.sol(3e-3)[0] - 0.5e-3, rel=1e-9)


@pytest.mark.parametrize("stick", [None, 0.3e-3])
def test_rate_independence(stick):
    # The same path traced at two speeds (200 vs 20000 samples between the same turning
    # points) gives the same deflection at the turning points: the model is time-free.
    turns = np.array([0.0, 1.7e-3, 0.9e-3, 2.2e-3, -0.4e-3, 0.3e-3])

    def trace(n):
        s = fr.PreslidingState.at(0.0, DM, stick)
        out = []
        for a, b in zip(turns[:-1], turns[1:]):
            for x in np.linspace(a, b, n)[1:]:
                d, s = fr.step(s, float(x))
            out.append(d)
        return np.array(out)

    np.testing.assert_allclose(trace(200), trace(20000), rtol=0, atol=1e-12 * DM if stick is None else 1e-9 * DM)


# -- the field (eq. 22) ----------------------------------------------------------------------
def test_force_is_eq_22_with_the_dissipative_sign():
    alg = F()
    x, z, d = 0.1e-3, -0.6e-3, 0.7e-3
    h_tilde = 0.8 * math.sin(2 * math.pi * x / L)  # normalised to peak 1, depth 0.8
    f = alg.force([[x, z]], d)[0]
    assert f[0] == pytest.approx(-MU * K0 * 0.6e-3 * (1 - h_tilde) * d / DM, rel=1e-12)
    assert f[1] == pytest.approx(K0 * 0.6e-3, rel=1e-12)
    assert f[0] * d < 0  # opposes the deflection
    assert alg.force([[x, 1e-5]], d).tolist() == [[0.0, 0.0]]


def test_modulation_depth_and_normalisation():
    # h~ = depth * h / max|h|: the amplitude of the texture does not matter, only its shape
    f1 = F(hx.Sinusoid(0.8e-3, L)).force([[0.25e-3, -1e-3]], DM)[0, 0]
    f2 = F(hx.Sinusoid(5e-6, L)).force([[0.25e-3, -1e-3]], DM)[0, 0]
    assert f1 == pytest.approx(f2, rel=1e-12)
    assert f1 == pytest.approx(-MU * K0 * 1e-3 * (1 - 0.8), rel=1e-12)  # at a peak: 1 - 0.8
    flat = F(hx.Sinusoid(0.0, L)).force([[0.25e-3, -1e-3]], DM)[0, 0]
    assert flat == pytest.approx(-MU * K0 * 1e-3, rel=1e-12)  # zero texture: plain Coulomb


def test_max_penetration_clamps_the_lateral_term():
    alg = F(max_penetration=0.5e-3)
    f = alg.force([[0.0, -0.5e-3], [0.0, -1.5e-3]], DM)
    assert f[1, 0] == pytest.approx(f[0, 0], rel=1e-12)
    assert f[1, 1] == pytest.approx(3 * f[0, 1], rel=1e-12)


@pytest.mark.parametrize("phase", ["stick", "slip"])
@given(tex=textures(), u=st.floats(0, 1), depth=st.floats(1e-5, 1.5e-3), q=st.floats(-0.99, 0.99))
def test_jacobian_matches_finite_differences(phase, tex, u, depth, q):
    # In stick the deflection follows x (d = x - w); in slip it stays at +-d_max.
    alg = F(tex, max_penetration=1e-3)
    if abs(depth - 1e-3) < 1e-8:
        return
    p = np.array([u * 2e-3, -depth])
    d0 = q * DM if phase == "stick" else math.copysign(DM, q)
    e = 1e-10
    J = alg.jacobian(p[None], d0, phase)[0]
    fd = np.empty((2, 2))
    for k in range(2):
        dp = np.zeros(2)
        dp[k] = e
        dd = e if (phase == "stick" and k == 0) else 0.0
        fd[:, k] = (alg.force((p + dp)[None], d0 + dd)[0] - alg.force((p - dp)[None], d0 - dd)[0]) / (2 * e)
    np.testing.assert_allclose(J, fd, rtol=0, atol=1e-5 * K0 * (1 + tex.max_slope * DM / tex.peak_magnitude))


def test_jacobian_entries_within_eqs_25_and_26():
    # Eq. 26 (stick) and eq. 25 (slip) bound each entry of J_F over x and d at p^z = d^z_max.
    alg = F()
    x = np.linspace(0, L, 401)
    for phase, defl in (("stick", np.linspace(-DM, DM, 41)), ("slip", np.array([-DM, DM]))):
        X, Q = np.meshgrid(x, defl, indexing="ij")
        P = np.stack([X, np.full_like(X, -DM)], -1)
        J = alg.jacobian(P, Q, phase) / K0
        pa = 0.8  # the paper's A (dimensionless) with l = 1 mm
        jxx = 2 * MU * DM * (1 / DM + math.pi * pa / L) if phase == "stick" else 2 * math.pi * MU * DM * pa / L
        assert np.abs(J[..., 0, 0]).max() <= jxx * (1 + 1e-12)
        assert np.abs(J[..., 0, 1]).max() <= 2 * MU * (1 + 1e-12)
        np.testing.assert_array_equal(J[..., 1, 0], 0.0)
        np.testing.assert_allclose(J[..., 1, 1], -1.0)


# -- energy ----------------------------------------------------------------------------------
@pytest.mark.parametrize("a", [1e-4, 1e-6])
def test_eq_27_loop_energy(a):
    # A = 0, path (0, above)->(0,-a)->(d^x_max,-a)->(d^x_max,-d^z_max)->(0,-d^z_max)->(0, above):
    # stick both ways, so Delta E = kappa_0 mu d^x_max (d^z_max - a) / 2 -> eq. 27 as a -> 0.
    alg = F(hx.Sinusoid(0.0, L), max_penetration=DM)
    path, expected, _ = hx.paper_loop(alg, depth=a)
    work = hx.path_work(alg, path)
    assert work == pytest.approx(K0 * MU * DM * (DM - a) / 2, rel=1e-9)
    assert expected == pytest.approx(work, rel=1e-9)
    assert work == pytest.approx(K0 * MU * DM * DM / 2, rel=2 * a / DM)  # eq. 27


def test_eq_27_path_with_the_paper_texture():
    # With h~ = 0.8 sin(2 pi x / l) and d^x_max = l the lateral work becomes
    # mu kappa_0 (d^z - a)/d_max * (d_max^2/2 + 0.8 l^2 / (2 pi)) (integrating eq. 22 by hand).
    alg = F(max_penetration=DM)
    a = 1e-6
    path, expected, _ = hx.paper_loop(alg, depth=a)
    by_hand = MU * K0 * (DM - a) / DM * (DM**2 / 2 + 0.8 * L**2 / (2 * math.pi))
    assert hx.path_work(alg, path) == pytest.approx(by_hand, rel=1e-9)
    assert expected == pytest.approx(by_hand, rel=1e-12)


@given(tex=textures(), depths=st.lists(st.floats(0.05e-3, 1.5e-3), min_size=2, max_size=8),
       steps=st.lists(st.floats(0.05e-3, 2e-3), min_size=8, max_size=8))
def test_sliding_always_dissipates(tex, depths, steps):
    # Once slipping in +x (after 1.5 d^x_max of travel), any continuation that keeps x
    # increasing stays in slip; along it the friction does negative work at any depth
    # profile (Section IV-F-4). The friction work is F's work minus the wall's (W), since
    # F's normal component is the smooth wall's.
    alg, wall = F(tex), hx.algorithm("W", None, K0)
    prefix = [[0.0, 1e-3], [0.0, -depths[0]], [1.5 * DM, -depths[0]]]
    cont = list(prefix)
    x = 1.5 * DM
    for dep, dx in zip(depths[1:], steps):
        x += dx
        cont.append([x, -dep])

    def friction_work(pts):
        return hx.path_work(alg, np.array(pts)) - hx.path_work(wall, np.array(pts))

    assert friction_work(cont) - friction_work(prefix) < 0


def test_slip_segment_work_is_minus_coulomb_force_times_distance():
    # Flat texture, already slipping, depth 0.5 mm, 3 mm of slip: W = -mu kappa_0 |z| * 3 mm,
    # plus the stick loading at the start: -mu kappa_0 |z| d_max / 2.
    alg = F(hx.Sinusoid(0.0, L))
    path = np.array([[0.0, 1e-3], [0.0, -0.5e-3], [4e-3, -0.5e-3]])
    wall = -0.5 * K0 * 0.5e-3**2
    expected = wall - MU * K0 * 0.5e-3 * (DM / 2 + 3e-3)
    assert hx.path_work(alg, path) == pytest.approx(expected, rel=1e-9)


# -- analysis --------------------------------------------------------------------------------
def test_characteristic_number_is_the_sup_and_below_the_eq_26_bound():
    alg = F()
    q = hx.characteristic_number(alg)
    # reference: dense grid at p^z = -d^z_max (the lateral gain grows with depth), stick
    x = np.linspace(0, L, 2001)
    defl = np.linspace(-DM, DM, 401)
    X, Q = np.meshgrid(x, defl, indexing="ij")
    P = np.stack([X, np.full_like(X, -DM)], -1)
    ref = float(hx.spectral_norm(alg.jacobian(P, Q, "stick")).max()) / K0
    assert q.value >= ref * (1 - 1e-12)
    assert q.value == pytest.approx(ref, rel=1e-4)
    assert q.extra["phase"] == "stick" and abs(q.extra["deflection"]) == pytest.approx(DM)
    # eq. 26 is an upper bound (Appendix I); evaluated by hand: ||[[5.621, 1.6], [0, 1]]||
    a = 2 * MU * DM * (1 / DM + math.pi * 0.8 / L)
    eq26 = float(hx.spectral_norm(np.array([[a, 2 * MU], [0, 1]])))
    assert q.extra["bound_eq26"] == pytest.approx(eq26, rel=1e-12)
    assert q.extra["bound_eq26"] == pytest.approx(5.851, abs=1e-3)
    assert q.value < q.extra["bound_eq26"]
    assert q.extra["eq31_corrected"] == pytest.approx(eq26, rel=1e-12)
    assert q.extra["paper_reported"] == 8.3  # Section V-A
    assert math.isfinite(q.extra["eq31_as_printed"])


def test_characteristic_number_grows_with_the_clamp_depth():
    # Section IV-F-3: the lateral gain depends on p^z, which d^z_max bounds
    q1 = hx.characteristic_number(F(), max_penetration=0.2e-3).value
    q2 = hx.characteristic_number(F(), max_penetration=1e-3).value
    assert q2 > q1 > 1


def test_table_II_row_for_F():
    data = hx.table_ii(letters=["F"])
    row = data["rows"][0]
    assert row["almost_conservative"] is True and row["conservative"] is False  # Table II: "Almost"
    assert row["continuous"] is True  # "If h continuous"
    assert row["agrees_with_paper"]["characteristic_number"] is False  # 4.96 vs 8.3, reported
    assert row["characteristic_number_extra"]["paper_reported"] == 8.3


@pytest.mark.parametrize(
    "kwargs, pattern",
    [
        (dict(friction=-0.1), r"^friction = -0.1 is not allowed"),
        (dict(presliding=0.0), r"^presliding = 0 is not allowed"),
        (dict(modulation_depth=1.5), r"^modulation_depth = 1.5 is not allowed: must be a finite number in \[0, 1\]"),
        (dict(modulation_depth=-0.1), r"^modulation_depth = -0.1"),
        (dict(stick_deflection=2e-3), r"^stick_deflection = 0.002 is not allowed"),
        (dict(max_penetration=-1.0), r"^max_penetration = -1"),
    ],
)
def test_bad_parameters(kwargs, pattern):
    with pytest.raises(hx.ParameterError, match=pattern):
        F(**kwargs)


def test_bad_static_arguments():
    alg = F()
    with pytest.raises(hx.ParameterError, match=r"^deflection = 0.002 is not allowed"):
        alg.force([[0.0, -1e-4]], 2e-3)
    with pytest.raises(hx.ParameterError, match=r"^phase = 'glide'"):
        alg.jacobian([[0.0, -1e-4]], 0.0, "glide")
    with pytest.raises(hx.ParameterError, match=r"^x = nan"):
        fr.step(fr.PreslidingState.at(0.0), float("nan"))
