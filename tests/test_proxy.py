"""Issue 32: a god-object (proxy) algorithm after Zilles & Salisbury (1995) / Ruspini et al.
(1997), stated as a different algorithm from the paper's D: it tracks a local minimum of the
distance with history. The facts tested: on a flat wall it is the wall W; where the closest
point is unique and reached without crossing a fold it is D; below a peak it has hysteresis
(D's jump, Remark 6 of Campion & Hayward, becomes path dependence, the force continuous along
the path); around a loop through that region it absorbs energy in both directions, where D
(the gradient of kappa0 d^2/2, a continuous potential) does none."""

import numpy as np
import pytest

import haptex as hx
from haptex.proxy import GodObject, loop_work

A, L, K = 0.8e-3, 1e-3, 2000.0  # the paper's Section V-A parameters
SINE = hx.Sinusoid(A, L)
PEAK = L / 4


def test_on_a_flat_wall_the_proxy_is_the_wall():
    rng = np.random.default_rng(0)
    for d, flat in ((2, hx.Flat()), (3, hx.Flat(dimension=2))):
        g, w = GodObject(flat, K), hx.algorithm("W", None if d == 2 else flat, K)
        for p in np.column_stack([rng.uniform(-1e-3, 1e-3, (50, d - 1)), rng.uniform(-1e-3, 1e-3, 50)]):
            assert np.allclose(g.step(p), w.force(p[None])[0], rtol=1e-12, atol=1e-15)


# (depths under the least radius of curvature of the boundary, 1 / (A k^2): 32 um for the
# paper's sinusoid, 0.34 mm for the egg-crate, where the closest point is unique)
@pytest.mark.parametrize("tex, depth", [(SINE, 2e-5), (hx.SumOfGratings.egg_crate(0.3e-3, 2e-3), 1e-4)])
def test_where_the_closest_point_is_reached_without_a_fold_the_proxy_is_d(tex, depth):
    # a probe that enters from above and goes straight down: its proxy descends to the local
    # minimum of distance it started in, the closest point D pulls to
    rng = np.random.default_rng(1)
    d = tex.dimension + 1
    D = hx.algorithm("D", tex, K)
    for _ in range(20):
        xy = rng.uniform(0, 2e-3, d - 1)
        h = float(tex.height_at(xy[None])[0])
        g = GodObject(tex, K)
        g.step(np.append(xy, h + 1e-5))
        for z in np.linspace(h - 1e-6, h - depth, 20):
            f = g.step(np.append(xy, z))
        assert np.allclose(f, D.force(np.append(xy, z)[None])[0], rtol=1e-9, atol=1e-12 * K)


def _sweep(xs, depth):
    g = GodObject(SINE, K)
    g.step([xs[0], A + 1e-4])  # from above the wall, then along z = A - depth
    return np.array([g.step([x, A - depth]) for x in xs])


def test_below_a_peak_the_proxy_has_hysteresis_where_d_jumps():
    # 1.2 mm below the crest, 0.05 mm right of it: D pulls to the right flank (the closest
    # point); a proxy that came from the left is still on the left flank (its local minimum
    # of distance is still there), one that came from the right is where D is
    xs = np.linspace(PEAK - 0.3e-3, PEAK + 0.3e-3, 601)
    right, left = _sweep(xs, 1.2e-3), _sweep(xs[::-1], 1.2e-3)[::-1]
    i = np.searchsorted(xs, PEAK + 0.05e-3)
    D = hx.algorithm("D", SINE, K).force(np.array([[xs[i], A - 1.2e-3]]))[0]
    assert np.allclose(left[i], D, rtol=1e-9)
    assert right[i][0] < 0 < D[0]  # pulled back to the left flank
    # along each 1 um step of the sweep the proxy's force changes by under 0.01 N: it stays on
    # its flank across the crest line, where D's jumps by over 1 N
    Dall = hx.algorithm("D", SINE, K).force(np.column_stack([xs, np.full_like(xs, A - 1.2e-3)]))
    assert np.max(np.linalg.norm(np.diff(Dall, axis=0), axis=1)) > 1.0
    for f in (right, left):
        assert np.max(np.linalg.norm(np.diff(f, axis=0), axis=1)) < 0.01


def test_around_a_loop_through_the_fold_the_proxy_absorbs_energy_both_ways_and_d_none():
    loop = np.array([[PEAK - 0.3e-3, A + 0.1e-3], [PEAK - 0.3e-3, A - 1.2e-3], [PEAK + 0.3e-3, A - 1.2e-3],
                     [PEAK + 0.3e-3, A + 0.1e-3]])
    D = hx.algorithm("D", SINE, K)
    for path in (loop, loop[::-1]):
        r = loop_work(SINE, K, path)
        assert r["work"] < -1e-4  # J: absorbed (the spring's energy, held away from D's point, is
        # dropped when the probe leaves the wall and the proxy rejoins it)
        assert r["away_from_closest"] > 1e-4  # m: it was held away from D's point
        assert abs(hx.loop_energy(D, np.vstack([path, path[:1]]))) < 1e-12  # D is conservative
    shallow = np.array([[0.0, A + 0.1e-3], [0.0, -A - 0.05e-3], [0.2e-3, -A - 0.05e-3], [0.2e-3, A + 0.1e-3]])
    r = loop_work(SINE, K, shallow)  # around the valley: no fold, the proxy is D and does no work
    assert abs(r["work"]) < 1e-9 and r["away_from_closest"] < 1e-9


def test_bad_input_is_refused_by_name():
    with pytest.raises(hx.ParameterError, match="stiffness"):
        GodObject(SINE, -1.0)
    with pytest.raises(hx.ParameterError, match="texture"):
        GodObject("sine", K)
    with pytest.raises(hx.ParameterError, match="p = "):
        GodObject(SINE, K).step([0.0, np.nan])
    with pytest.raises(hx.ParameterError, match="path"):
        loop_work(SINE, K, [[0.0, -1e-3], [1e-3, -1e-3], [1e-3, 1e-3]])  # starts inside
    from haptex.objects import Sphere

    with pytest.raises(hx.ParameterError, match="base"):
        GodObject(SINE, K, Sphere(0.1))  # a profile on a curved base
    with pytest.raises(hx.ParameterError, match="base"):
        GodObject(EGG, K, "sphere")


EGG = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)


def _pressed(g, xy, depth, above=1e-5, n=30):
    """The force after pressing straight in from `above` the base to `depth` below it."""
    for z in np.linspace(above, -depth, n):
        f = g.step(np.array([xy[0], xy[1], z]))
    return f


def test_over_the_plane_base_the_proxy_is_the_planar_one():
    from haptex.objects import Plane

    rng = np.random.default_rng(2)
    for _ in range(5):
        xy = rng.uniform(0, 2e-3, 2)
        f0 = _pressed(GodObject(EGG, K), xy, 3e-4)
        f1 = _pressed(GodObject(EGG, K, Plane()), xy, 3e-4)
        # (to 1e-7 of the force: over a base, S's Jacobian is taken by central differences)
        assert np.linalg.norm(f1 - f0) < 1e-7 * np.linalg.norm(f0)


def test_on_a_sphere_the_proxy_lies_on_the_textured_surface_and_tends_to_the_planes_as_d_over_r():
    from haptex.objects import Sphere

    xy = (0.3e-3, 0.2e-3)
    flat = _pressed(GodObject(EGG, K), xy, 3e-4)
    errors = []
    for n_periods in (40, 4000):  # R = 12.7 mm and 1.27 m: the seam takes whole periods
        base = Sphere(n_periods * 2e-3 / (2 * np.pi))
        g = GodObject(EGG, K, base)
        f = _pressed(g, xy, 3e-4)
        q = g.proxy
        u, _, _, e, _, _ = base.local(q[None])
        assert abs(e[0] - EGG.height_at(u)[0]) < 1e-12  # m: on the textured surface
        # a local minimum of distance: the spring is normal to the surface there
        eps = 1e-9
        uq = g.surface_coordinates
        tangents = [(g._surface(uq + eps * d) - g._surface(uq - eps * d)) / (2 * eps) for d in np.eye(2)]
        assert max(abs(f @ t) / (np.linalg.norm(f) * np.linalg.norm(t)) for t in tangents) < 1e-5
        errors.append(np.linalg.norm(f - flat) / np.linalg.norm(flat))
    assert errors[1] < 1e-3 and 50 < errors[0] / errors[1] < 200  # O(d/R): 100 x radius, ~100 x closer
    # and the loop work over the sphere, along a loop pressed in and out across a crest
    r = loop_work(EGG, K, [[0.2e-3, 0.5e-3, 3e-4], [0.2e-3, 0.5e-3, -4e-4], [0.8e-3, 0.5e-3, -4e-4],
                           [0.8e-3, 0.5e-3, 3e-4]], base=Sphere(4000 * 2e-3 / (2 * np.pi)))
    flat = loop_work(EGG, K, [[0.2e-3, 0.5e-3, 3e-4], [0.2e-3, 0.5e-3, -4e-4], [0.8e-3, 0.5e-3, -4e-4],
                              [0.8e-3, 0.5e-3, 3e-4]])
    # both absorb (measured -12.1 and -14.0 uJ at R = 1.27 m: they differ by far more than d/R,
    # which is not explained yet; only the sign is asserted)
    assert r["work"] < -1e-6 and flat["work"] < -1e-6


@pytest.mark.parametrize("tex", [SINE, EGG], ids=["sine", "egg"])
def test_the_renderer_runs_the_god_objects_c_tick_with_bounded_counted_work(tex):
    # the same C tick as GodObject.step, in the servo loop's Renderer (its safety rules around
    # it): along a stroke in and out of the wall the forces are the god-object's, never above the
    # maximum, and a tick's work is within the descent's structural bound (200 Newton steps, each
    # backtracked at most 40 times, one texture evaluation each, and the tick's two)
    from haptex.core import _ext

    g, ref = GodObject(tex, K), GodObject(tex, K)
    r = hx.Renderer(g, max_force=50.0)
    t = np.linspace(0.0, 1.0, 4001)
    x, y, z = 3e-3 * np.sin(2 * np.pi * 3 * t), 1e-3 * np.sin(2 * np.pi * 5 * t), -1e-3 * np.sin(2 * np.pi * 2 * t)
    pts = np.column_stack([x, y, z] if g.dimension == 3 else [x, z])
    f = np.array([r.step(tuple(q)) for q in pts.tolist()])
    np.testing.assert_array_equal(f, np.array([ref.step(q) for q in pts]))
    assert np.abs(f).max() > 1.0 and np.linalg.norm(f, axis=1).max() <= 50.0 * (1 + 1e-12)
    assert 0 < r.max_work <= 3 + _ext.PROXY_STEPS * (1 + _ext.PROXY_HALVINGS)


def test_the_simulator_runs_the_god_object():
    # the exact sampled-data loop with the proxy's C tick (the general loop): on the paper-style
    # gentle sinusoid (0.2 mm, 2 mm) scanned 1 mm deep by Section V-B's hand the closest point is
    # unique along the run, so the proxy is D's point and the run is D's to 1e-9 m (measured
    # 7e-12 m); the energy balance closes; a batch over stiffnesses is simulate run by run
    from haptex.operators import ScanningHand

    gentle = hx.Sinusoid(0.2e-3, 2e-3)
    dev, op = hx.Device.point_mass(), ScanningHand(300.0, 1.0, velocity=0.01, depth=1e-3)
    proxy = hx.simulate(GodObject(gentle, K), dev, op, 1.0)
    d = hx.simulate(hx.algorithm("D", gentle, K), dev, op, 1.0)
    assert proxy.energy_balance_ok and proxy.max_penetration > 1e-4
    np.testing.assert_allclose(proxy.position, d.position, rtol=0, atol=1e-9)
    batch = hx.simulate_batch(GodObject(gentle, K), dev, op, 0.3, stiffness=[1000.0, 4000.0], record=True)
    for i, k in enumerate([1000.0, 4000.0]):
        one = hx.simulate(GodObject(gentle, k), dev, op, 0.3)
        np.testing.assert_array_equal(batch.runs[i].position, one.position)


# the sphere in the contributor's loop, the plane and the cylinder in .ci/run's long set (1.5-1.9 s each)
@pytest.mark.parametrize("base_name", [pytest.param("plane", marks=pytest.mark.long), "sphere",
                                       pytest.param("cylinder", marks=pytest.mark.long)])
def test_the_c_proxy_on_an_analytic_base_follows_the_python_descent(base_name):
    # over a plane, cylinder or sphere base the god-object's tick is the C core's (Gauss-Newton
    # on the surface's Jacobian in closed form); the Python descent (central differences, the
    # analysis path over meshes) reaches the same local minima: along a stroke in and out of the
    # object, back and forth, the forces agree to 1e-6 N (measured 1.7e-7 N) out of about 1 N
    import math

    from haptex.objects import Cylinder, Plane, Sphere

    R = 40 * 2e-3 / (2 * math.pi)
    base = {"plane": Plane(), "sphere": Sphere(R), "cylinder": Cylinder(R)}[base_name]
    egg = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)
    c = GodObject(egg, 2000.0, base)
    py = GodObject(egg, 2000.0, base)
    py._core = None  # its Python descent
    assert c.in_core and c._core is not None
    t = np.linspace(0.0, 1.0, 601)  # (601 ticks: the Python descent takes 2 ms a tick)
    pts = base.point(np.column_stack([4e-3 * np.sin(2 * np.pi * 2 * t), 2e-3 * np.cos(2 * np.pi * 3 * t)]),
                     -0.5e-3 * np.sin(2 * np.pi * 5 * t))
    worst, biggest = 0.0, 0.0
    for p in pts:
        a, b = c.step(p), py.step(p)
        worst, biggest = max(worst, float(np.abs(a - b).max())), max(biggest, float(np.abs(a).max()))
    assert worst <= 1e-6 and biggest > 0.5
    c.step(base.point(np.array([[0.3e-3, 0.2e-3]]), np.array([-0.3e-3]))[0])  # pressed in: in contact
    u = c.surface_coordinates
    assert u is not None
    if base_name == "sphere":  # the proxy sits on the object: |S(u)| from the centre is R + h(u)
        q = c.proxy + np.array([0.0, 0.0, R])
        assert np.linalg.norm(q) == pytest.approx(R + float(egg.height_at(u[None])[0]), abs=1e-12)


def test_the_proxy_on_a_sphere_runs_in_the_renderer_and_the_simulator():
    # the same C tick in haptex.Renderer (its work counted, bounded by the descent's steps) and
    # in the simulator's general loop (the energy balance closed); over a mesh too
    import math

    from haptex.objects import Mesh, Sphere
    from haptex.operators import ScanningHand

    R = 40 * 2e-3 / (2 * math.pi)
    egg = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)
    g = GodObject(egg, 2000.0, Sphere(R))
    r = hx.Renderer(g, max_force=5.0)
    f = r.step([0.0, 0.0, -0.3e-3])
    assert f[2] > 0.0 and 1 <= r.last_work <= 1 + 200 * 41
    res = hx.simulate(g, hx.Device.point_mass(dimension=3),
                      ScanningHand(300.0, 3.0, velocity=0.01, depth=0.5e-3, dimension=3), 0.3)
    assert res.energy_balance_ok and res.max_penetration > 0.0
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=2, radius=R)
    m.apply_transform(trimesh.transformations.rotation_matrix(0.1234, [1.0, 0.3, 0.0]))  # poles off the y axis
    m.apply_translation([0.0, 0.0, -R])
    mesh = Mesh(m, uv=Sphere(R).local(np.asarray(m.vertices))[0])
    gm = GodObject(egg, 2000.0, mesh)
    assert gm.in_core
    rm = hx.Renderer(gm, max_force=5.0)
    f = rm.step(mesh.point(np.array([[0.3e-3, 0.2e-3]]), np.array([-0.3e-3]))[0])
    assert 0.0 < np.linalg.norm(f) <= 5.0 and rm.faults == 0 and rm.last_work >= 1
    res = hx.simulate(gm, hx.Device.point_mass(dimension=3),
                      ScanningHand(300.0, 3.0, velocity=0.01, depth=0.5e-3, dimension=3), 0.3)
    assert res.energy_balance_ok and res.max_penetration > 0.0


@pytest.mark.parametrize("normals", [pytest.param(None, marks=pytest.mark.long), "vertex"], ids=["faceted", "prism"])
def test_the_c_proxy_on_a_mesh_follows_the_python_descent(normals):  # (faceted, 3 s: .ci/run's long set)
    # over a mesh the C tick descends through the UV map (the triangle holding u found by a walk
    # across sides, S and dS/du affine in u there); the Python descent (central differences over
    # Mesh.point) is its oracle. Along a stroke in and out of a 1,280-facet ball, back and forth:
    # on the prism base (S smooth within the prisms, continuous across them) the forces agree to
    # 1e-6 N (measured 2.3e-8 N); on the faceted base S(u) has creases along the UV edges where
    # the two descents can stop at different points of one (measured on 1 tick in 601 along the
    # whole stroke, of which this is the first 40 %: 2.7e-3 N, the C's point 3e-5 relatively
    # farther, the next tick equal again). 18 us a GodObject.step
    # in C against 11-14 ms in Python (measured)
    import math

    import trimesh

    from haptex.objects import Mesh, Sphere

    R = 40 * 2e-3 / (2 * math.pi)
    egg = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)
    m = trimesh.creation.icosphere(subdivisions=3, radius=R)
    m.apply_transform(trimesh.transformations.rotation_matrix(0.1234, [1.0, 0.3, 0.0]))
    m.apply_translation([0.0, 0.0, -R])
    mesh = Mesh(m, uv=Sphere(R).local(np.asarray(m.vertices))[0], normals=normals)
    c, py = GodObject(egg, 2000.0, mesh), GodObject(egg, 2000.0, mesh)
    py._core = None
    t = np.linspace(0.0, 0.4, 241)  # (the Python oracle takes 11-14 ms a tick)
    pts = mesh.point(np.column_stack([4e-3 * np.sin(2 * np.pi * 2 * t), 2e-3 * np.cos(2 * np.pi * 3 * t)]),
                     -0.5e-3 * np.sin(2 * np.pi * 5 * t))
    fc = [c.step(p) for p in pts]
    diff = np.array([float(np.abs(a - py.step(p)).max()) for a, p in zip(fc, pts)])
    if normals == "vertex":
        assert diff.max() <= 1e-6
    else:
        assert np.mean(diff > 1e-6) <= 0.01 and diff.max() <= 5e-3
    assert np.abs(fc).max() > 0.5  # (in contact: forces of newtons)
