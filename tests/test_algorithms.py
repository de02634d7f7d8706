"""Force fields W, A–E, G: analytic Jacobians against finite differences and against the
matrices printed in the paper (eqs. 7, 15, 18, 20), directions, clamping and bad input."""

import math
import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import haptex as hx

from .conftest import A, K0, L, textures

LETTERS = ["W", "A", "B", "C", "D", "E", "G"]


def make(letter, tex, **kw):
    return hx.algorithm(letter, None if letter == "W" else tex, K0, **kw)


def inside_point(alg, x, depth):
    """A probe at abscissa x and depth (m) as the algorithm measures penetration, roughly."""
    if alg.penetration_kind == "nominal":
        return np.array([x, -depth])
    return np.array([x, float(alg.texture.height(np.array([x]))[0]) - depth])


def fd_jacobian(alg, p, e):
    """Reference: central finite differences of the force, step e (m)."""
    j = np.empty((2, 2))
    for k in range(2):
        dp = np.zeros(2)
        dp[k] = e
        j[:, k] = (alg.force((p + dp)[None])[0] - alg.force((p - dp)[None])[0]) / (2 * e)
    return j


def d_is_smooth_at(alg, p, e):
    """True when D's closest point moves continuously around p (not on or next to the
    medial axis, not near a centre of curvature), so its force is differentiable there."""
    pts = np.array([p, p + [e, 0], p - [e, 0], p + [0, e], p - [0, e]])
    cp = hx.closest_point(alg.texture, pts)
    if cp.tie.any() or np.ptp(cp.x) > 1e3 * e:
        return False
    s = alg.texture.slope(cp.x[:1])[0]
    c = alg.texture.curvature(cp.x[:1])[0]
    return 1 + s * s + (cp.z[0] - p[1]) * c > 0.05 * (1 + s * s)


@pytest.mark.parametrize("letter", LETTERS)
@given(tex=textures(), u=st.floats(0, 1), depth=st.floats(2e-5, 1.2e-3))
def test_analytic_jacobian_matches_finite_differences(letter, tex, u, depth):
    alg = make(letter, tex)
    p = inside_point(alg, u * 2e-3, depth)
    e = 1e-9
    if alg.penetration_kind == "distance" and hx.closest_point(tex, p[None]).distance[0] < 1e-6:
        return
    if letter == "D" and not d_is_smooth_at(alg, p, e):
        return
    J = alg.jacobian(p[None])[0]
    scale = K0 * (1 + tex.max_slope**2 + depth * tex.max_curvature)
    if letter == "D":
        scale = max(scale, np.abs(J).max())
    np.testing.assert_allclose(J, fd_jacobian(alg, p, e), rtol=0, atol=2e-5 * scale)


@pytest.mark.parametrize("letter", ["B", "C", "G"])
@given(tex=textures(), u=st.floats(0, 1), depth=st.floats(2e-5, 1.8e-3))
def test_clamped_jacobian_matches_finite_differences(letter, tex, u, depth):
    alg = make(letter, tex, max_penetration=0.7e-3)
    p = inside_point(alg, u * 2e-3, depth)
    if abs(depth - 0.7e-3) < 1e-6:
        return
    scale = K0 * (1 + tex.max_slope**2 + depth * tex.max_curvature)
    np.testing.assert_allclose(alg.jacobian(p[None])[0], fd_jacobian(alg, p, 1e-9), rtol=0, atol=2e-5 * scale)


def random_inside(alg, n=50, seed=0, dmax=1e-3):
    rng = np.random.default_rng(seed)
    x = rng.uniform(0, 2 * L, n)
    d = rng.uniform(1e-5, dmax, n)
    return np.array([inside_point(alg, xi, di) for xi, di in zip(x, d)])


def test_A_jacobian_is_eq_7():
    alg = make("A", hx.Sinusoid(A, L))
    p = random_inside(alg)
    s = alg.texture.slope(p[:, 0])
    printed = -K0 * np.stack([np.stack([0 * s, 0 * s], -1), np.stack([-s, np.ones_like(s)], -1)], -2)
    np.testing.assert_allclose(alg.jacobian(p), printed, rtol=1e-14, atol=0)


def test_C_jacobian_is_eq_15():
    alg = make("C", hx.Sinusoid(A, L))
    p = random_inside(alg)
    x, z = p[:, 0], p[:, 1]
    s, c, d = alg.texture.slope(x), alg.texture.curvature(x), z - alg.texture.height(x)
    printed = -K0 * np.stack([np.stack([s * s - d * c, -s], -1), np.stack([-s, np.ones_like(s)], -1)], -2)
    np.testing.assert_allclose(alg.jacobian(p), printed, rtol=1e-12, atol=1e-9)


def test_D_paper_form_is_eq_18_and_norm_kappa0():
    alg = make("D", hx.Sinusoid(A, L))
    p = random_inside(alg)
    cp = hx.closest_point(alg.texture, p)
    s = alg.texture.slope(cp.x)
    printed = -K0 / (1 + s * s)[:, None, None] * np.stack(
        [np.stack([s * s, -s], -1), np.stack([-s, np.ones_like(s)], -1)], -2
    )
    Jp = alg.jacobian(p, form="paper")
    np.testing.assert_allclose(Jp, printed, rtol=1e-13, atol=1e-9)
    np.testing.assert_allclose(hx.spectral_norm(Jp), K0, rtol=1e-12)  # eq. 18: ||J_D|| = kappa_0


def test_D_exact_equals_eq_18_where_the_boundary_is_straight():
    # At an inflection point of the sinusoid (x = 0, h'' = 0) the curvature term vanishes,
    # so the exact Jacobian equals the paper's linearisation along the normal there.
    alg = make("D", hx.Sinusoid(A, L))
    s = 2 * np.pi * A / L
    n_in = np.array([s, -1.0]) / np.hypot(1, s)
    p = np.array([n_in * r for r in (1e-5, 1e-4)])
    np.testing.assert_allclose(alg.jacobian(p), alg.jacobian(p, form="paper"), rtol=1e-9, atol=1e-9)


def test_E_jacobian_is_minus_printed_eq_20_and_has_norm_kappa0():
    # eq. 19's printed sign pulls inward; haptex uses f_z = +kappa_0 d^min, so J = -(eq. 20).
    alg = make("E", hx.Sinusoid(A, L))
    p = random_inside(alg)
    cp = hx.closest_point(alg.texture, p)
    dx, dz = p[:, 0] - cp.x, p[:, 1] - cp.z
    printed = -K0 / cp.distance[:, None, None] * np.stack(
        [np.stack([0 * dx, 0 * dx], -1), np.stack([dx, dz], -1)], -2
    )
    np.testing.assert_allclose(alg.jacobian(p), -printed, rtol=1e-12, atol=1e-9)


@given(tex=textures(), u=st.floats(0, 1), depth=st.floats(1e-6, 1.5e-3))
def test_E_norm_is_kappa0_wherever_differentiable(tex, u, depth):
    # eq. 21
    alg = make("E", tex)
    p = inside_point(alg, u * 2e-3, depth)
    assert hx.spectral_norm(alg.jacobian(p[None]))[0] == pytest.approx(K0, rel=1e-12)


@pytest.mark.parametrize("letter", LETTERS)
def test_forces_push_out_and_vanish_outside(letter):
    tex = hx.Sinusoid(A, L)
    alg = make(letter, tex)
    p = random_inside(alg, 200, seed=3)
    f = alg.force(p)
    assert np.all(f[:, 1] > 0), "the normal component must push the probe out (+z)"
    if letter == "D":
        cp = hx.closest_point(tex, p)
        outward = np.column_stack([cp.x, cp.z]) - p
        assert np.all(np.einsum("ij,ij->i", f, outward) > 0)
    above = p.copy()
    above[:, 1] = A + 1e-4 if letter != "W" else 1e-4
    np.testing.assert_array_equal(alg.force(above), 0.0)
    np.testing.assert_array_equal(alg.jacobian(above), 0.0)


def test_force_magnitudes_at_known_points():
    # By hand from eqs. 6, 11, 14, 17, 19, 28, 30 at x = l/4 (peak, h' = 0), 0.3 mm below it.
    tex = hx.Sinusoid(A, L)
    p = np.array([[L / 4, A - 0.3e-3]])
    for letter in "ABC":
        np.testing.assert_allclose(make(letter, tex).force(p), [[0, K0 * 0.3e-3]], atol=1e-12)
    # D and E: deeper than the 32 um radius of curvature, the closest point is on a flank
    d = hx.closest_point(tex, p).distance[0]
    assert d < 0.3e-3
    np.testing.assert_allclose(make("E", tex).force(p), [[0, K0 * d]], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(make("D", tex).force(p)), K0 * d, rtol=1e-12)
    q = np.array([[L / 4, -0.3e-3]])
    np.testing.assert_allclose(make("G", tex).force(q), [[0, K0 * 0.3e-3]], atol=1e-12)
    np.testing.assert_allclose(make("W", tex).force(q), [[0, K0 * 0.3e-3]], atol=1e-12)


@pytest.mark.parametrize("letter", ["B", "C", "G"])
def test_max_penetration_clamps_only_the_lateral_component(letter):
    # Remark 3: the lateral component uses max(d, -d_max); the normal one does not.
    tex = hx.Sinusoid(A, L)
    alg = make(letter, tex, max_penetration=0.5e-3)
    x = 0.1e-3
    f1 = alg.force(inside_point(alg, x, 0.5e-3)[None])[0]
    f2 = alg.force(inside_point(alg, x, 1.0e-3)[None])[0]
    assert f2[0] == pytest.approx(f1[0], rel=1e-12)
    assert f2[1] == pytest.approx(2 * f1[1], rel=1e-12)
    free = make(letter, tex).force(inside_point(alg, x, 1.0e-3)[None])[0]
    assert free[0] == pytest.approx(2 * f1[0], rel=1e-12)


@pytest.mark.parametrize("letter", ["W", "C", "D"])
@given(tex=textures(), u=st.floats(0, 1), depth=st.floats(2e-5, 1e-3))
def test_potential_gradient_is_minus_force(letter, tex, u, depth):
    # f = -grad V with V = kappa_0 d^2 / 2 (eqs. 13, 16 with U = -V)
    alg = make(letter, tex)
    p = inside_point(alg, u * 2e-3, depth)
    e = 1e-9
    if letter == "D" and not d_is_smooth_at(alg, p, e):
        return
    grad = [(alg.potential((p + dp)[None])[0] - alg.potential((p - dp)[None])[0]) / (2 * e)
            for dp in (np.array([e, 0]), np.array([0, e]))]
    f = alg.force(p[None])[0]
    np.testing.assert_allclose(-np.array(grad), f, rtol=0, atol=1e-6 * K0 * 2e-3 * (1 + tex.max_slope))


def test_potential_of_a_non_gradient_field_raises():
    with pytest.raises(TypeError, match="not a gradient"):
        make("A", hx.Sinusoid(A, L)).potential([[0, -1e-4]])
    with pytest.raises(TypeError, match="not a gradient"):
        make("C", hx.Sinusoid(A, L), max_penetration=1e-3).potential([[0, -1e-4]])


def test_names_and_letters():
    tex = hx.Sinusoid(A, L)
    for letter in LETTERS:
        alg = hx.algorithm(letter.lower(), None if letter == "W" else tex, 1000.0)
        assert alg.letter == letter and alg.name and alg.stiffness == 1000.0
    assert hx.algorithm("A", tex, 1000).name == "grooved boundary, force normal to surface"


@pytest.mark.parametrize(
    "call, pattern",
    [
        (lambda t: hx.algorithm("H", t), r"^letter = 'H' is not allowed: must be one of W, A, B"),
        (lambda t: hx.algorithm("A", t, stiffness=0), r"^stiffness = 0 "),
        (lambda t: hx.algorithm("A", t, stiffness=-5), r"^stiffness = -5 "),
        (lambda t: hx.algorithm("A", t, stiffness=float("nan")), r"^stiffness = nan "),
        (lambda t: hx.algorithm("A"), r"^texture = None is not allowed for algorithm A"),
        (lambda t: hx.algorithm("W", t), r"texture = .* is not allowed for algorithm W"),
        (lambda t: hx.algorithm("A", t, max_penetration=1e-3), r"not allowed for algorithm A"),
        (lambda t: hx.algorithm("B", t, max_penetration=0), r"^max_penetration = 0 "),
        (lambda t: hx.algorithm("A", "sine"), r"^texture = 'sine' "),
        (lambda t: hx.algorithm("A", t).force([1.0, 2.0, 3.0]), r"^p has shape \(3,\)"),
        (lambda t: hx.algorithm("D", t).force([[0.0, np.inf]]), r"non-finite"),
        (lambda t: hx.algorithm("D", t).jacobian([[0.0, 0.0]], form="other"), r"^form = 'other'"),
    ],
)
def test_bad_input_names_the_parameter(call, pattern):
    with pytest.raises(hx.ParameterError, match=pattern):
        call(hx.Sinusoid(A, L))


def test_shapes_are_preserved():
    alg = make("B", hx.Sinusoid(A, L))
    p = np.zeros((3, 4, 2))
    p[..., 1] = -1e-4
    assert alg.force(p).shape == (3, 4, 2)
    assert alg.jacobian(p).shape == (3, 4, 2, 2)
    assert alg.force([0.0, -1e-4]).shape == (2,)


@pytest.mark.parametrize("letter", LETTERS)
def test_compiled_kernel_matches_vectorised_force(letter):
    # the C core's servo tick (the renderer's and the simulator's) from a fresh state against
    # the NumPy path, at random points in and out
    kw = {"max_penetration": 0.6e-3} if letter in "BCG" else {}
    alg = make(letter, hx.Sinusoid(A, L, phase=0.4), **kw)
    r = hx.Renderer(alg)
    rng = np.random.default_rng(5)
    p = np.column_stack([rng.uniform(-1e-3, 2e-3, 300), rng.uniform(-1.9e-3, 1e-3, 300)])
    ref = alg.force(p)
    # D and E: the tick's closest point (from the cell table) and the field's are each certified
    # to about 1e-15 m, so their forces agree to kappa_0 sqrt(1 + h'^2) 2e-15 m
    atol = 2e-15 * K0 * math.sqrt(1.0 + alg.texture.max_slope ** 2) if letter in "DE" else 1e-12
    for pi, fi in zip(p.tolist(), ref):
        r.reset()
        np.testing.assert_allclose(r.step(pi), fi, rtol=1e-12, atol=atol)


def test_compiled_F_kernel_follows_the_friction_state_along_a_path():
    from haptex import friction as fr

    alg = hx.algorithm("F", hx.Sinusoid(A, L), K0, max_penetration=0.8e-3)
    r = hx.Renderer(alg)
    t = np.linspace(0, 1, 2000)
    xs = 3e-3 * np.sin(7 * t) + 0.5e-3 * t
    zs = -0.5e-3 - 0.6e-3 * np.sin(3 * t) ** 2
    zs[900:950] = 1e-4  # leave the wall once: the state resets
    state = None
    for x, z in zip(xs, zs):
        got = r.step((float(x), float(z)))
        if z >= 0:
            state = None
            np.testing.assert_array_equal(got, [0.0, 0.0])
            continue
        state = alg.initial_state(x) if state is None else state
        d, state = fr.step(state, x)
        np.testing.assert_allclose(got, alg.force([[x, z]], d)[0], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("letter", ["W", "C", "D"])
def test_spring_energy_is_the_potential_where_there_is_one(letter):
    # Issue 10: Fig. 7 is judged on E - V with V = kappa_0 d^2 / 2 (d from Table I); for the
    # gradient fields that V is exactly their potential (eqs. 13, 16)
    alg = make(letter, None if letter == "W" else hx.Sinusoid(A, L))
    rng = np.random.default_rng(5)
    p = np.column_stack([rng.uniform(0, 2e-3, 50), rng.uniform(-2e-3, 1e-3, 50)])
    np.testing.assert_allclose(alg.spring_energy(p), alg.potential(p), rtol=1e-12, atol=0.0)


def test_a_s_spring_energy_is_its_vertical_stretch():
    # A stores kappa_0 (h(x) - z)^2 / 2 in its vertical spring (Table I), though its field has
    # no potential: at x = l/4 (a peak, h = A) and 0.3 mm below it, 2000 * (0.3e-3)^2 / 2 J
    alg = make("A", hx.Sinusoid(A, L))
    assert alg.spring_energy([[L / 4, A - 0.3e-3]])[0] == pytest.approx(0.5 * K0 * 0.3e-3**2, rel=1e-12)


def test_the_registry_says_what_each_letters_constructor_takes():
    # Algorithm.parameters is what the CLI, the explorer, sweeps and objects read to learn which
    # letter takes what: it must be exactly each class's keyword parameters besides the texture
    # and the stiffness, and W alone takes no texture
    import inspect

    from haptex.algorithms import ALGORITHMS, taking

    for letter, cls in ALGORITHMS.items():
        names = [n for n in inspect.signature(cls.__init__).parameters if n not in ("self", "texture", "stiffness")]
        assert tuple(names) == cls.parameters, letter
        assert cls.textured == (letter != "W")
    assert taking("max_penetration") == ["B", "C", "F", "G"]  # Remark 3's d^z_max
    assert taking("friction") == ["F"] and taking("damping") == ["W"]


def _rotation(rng):
    """A random 3-D rotation (the Q of a normal matrix's QR, its signs fixed)."""
    q, r = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.diag(r))


def test_the_spectral_norm_is_the_svds_largest_singular_value_on_every_kind_of_matrix():
    # q is the largest singular value of J / kappa_0 (eq. 5). spectral_norm computes a 3x3's in
    # closed form (Smith's trigonometric solution of J^T J's characteristic cubic), which loses
    # half its digits where the two largest singular values coincide. Truth: LAPACK's SVD
    # (numpy.linalg.svd), on random matrices from 1e-40 to 1e40 in their units and on the
    # degenerate ones built from their singular values: two largest equal and nearly equal
    # (1e-4 to 1e-14 apart), all three equal, rank one, rank two, 2x2 matrices too. With the
    # closed form everywhere (SPECTRAL_REFINE = 0) the two-largest-equal cases read 3.9e-9 off
    # (measured 2026-11-28): the test can fail.
    rng = np.random.default_rng(20261128)
    J = rng.normal(size=(20_000, 3, 3)) * 10.0 ** rng.uniform(-40, 40, size=(20_000, 1, 1))
    built = []
    for top in ([1.0, 1.0, 0.3], [1.0, 1.0, 1.0], [1.0, 0.0, 0.0], [1.0, 0.5, 0.0], [2.0, 2.0, 0.0]):
        built += [_rotation(rng) @ np.diag(top) @ _rotation(rng) for _ in range(50)]
    for gap in 10.0 ** -np.arange(4, 15):
        built += [_rotation(rng) @ np.diag([1.0, 1.0 - gap, 0.2]) @ _rotation(rng) for _ in range(20)]
    J = np.concatenate([J, 3e3 * np.array(built)])
    truth = np.linalg.svd(J, compute_uv=False)[:, 0]
    np.testing.assert_allclose(hx.spectral_norm(J), truth, rtol=1e-13)
    K = rng.normal(size=(5_000, 2, 2)) * 10.0 ** rng.uniform(-40, 40, size=(5_000, 1, 1))
    np.testing.assert_allclose(hx.spectral_norm(K), np.linalg.svd(K, compute_uv=False)[:, 0], rtol=1e-13)
    assert hx.spectral_norm(np.zeros((3, 3))) == 0.0
