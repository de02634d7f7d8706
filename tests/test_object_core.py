"""Issue 32: the C core's tick over textured objects (hx_object.c) against the NumPy fields of
haptex.objects (the oracle), the mesh's bounding-volume hierarchy against brute force, and the
simulator over objects."""

from __future__ import annotations

import math

import numpy as np
import pytest

import haptex as hx
from haptex._validation import ParameterError
from haptex.objects import Cylinder, Mesh, Plane, Sphere, object_algorithm

A, L, K0 = 0.2e-3, 2e-3, 2000.0
EGG = hx.SumOfGratings.egg_crate(A, L)  # the paper's egg-crate scale: 0.2 mm high, 2 mm period
R = 40 * L / (2 * math.pi)  # 40 periods around: no seam


def _probes(n, seed=0):
    rng = np.random.default_rng(seed)
    return np.column_stack([rng.uniform(-L, L, n), rng.uniform(-L, L, n), rng.uniform(-0.8e-3, 0.2e-3, n)])


def _icosphere(subdivisions):
    """trimesh's icosphere of radius R, tilted off the y axis and centred at (0, 0, -R) like
    Sphere(R), with the analytic sphere's (u1, u2) as its UV map (as tests/test_objects.py)."""
    import trimesh

    m = trimesh.creation.icosphere(subdivisions=subdivisions, radius=R)
    m.apply_transform(trimesh.transformations.rotation_matrix(0.1234, [1.0, 0.3, 0.0]))
    m.apply_translation([0.0, 0.0, -R])
    return m, Mesh(m, uv=Sphere(R).local(np.asarray(m.vertices))[0])


def _ticks(alg, p):
    """The C tick's forces (N) at every row of p, in order (Renderer.run: one C loop)."""
    r = hx.Renderer(alg)
    f = np.zeros_like(p)
    r._core.run(np.ascontiguousarray(p), f)
    return f, r


@pytest.mark.parametrize("base", [Plane(), Cylinder(R), Sphere(R)], ids=["plane", "cylinder", "sphere"])
@pytest.mark.parametrize("letter, params", [("A", {}), ("B", {}), ("C", {}), ("G", {}),
                                            ("B", {"max_penetration": 0.3e-3}), ("C", {"max_penetration": 0.3e-3}),
                                            ("G", {"max_penetration": 0.3e-3})],
                         ids=["A", "B", "C", "G", "B-clamped", "C-clamped", "G-clamped"])
def test_the_c_tick_on_an_analytic_base_is_the_numpy_field(base, letter, params):
    # 10^4 probes within a period of the top, 0.8 mm deep to 0.2 mm above: the closed-form
    # coordinates (u, e, n, du/dp) in C give haptex.objects' fields to rounding, with d^z_max
    # (0.3 mm, Remark 3 on the base) as without
    p = _probes(10_000)
    alg = object_algorithm(letter, EGG, base, K0, **params)
    f, r = _ticks(alg, p)
    ref = alg.force(p)
    assert np.max(np.abs(ref)) > 1.0  # (in contact: forces of newtons)
    np.testing.assert_allclose(f, ref, rtol=0, atol=1e-12 * K0 * 1e-3)
    assert r.faults == 0


@pytest.mark.parametrize("letter", ["A", "B", "C", "G"])
def test_the_c_tick_on_a_mesh_is_the_numpy_field(letter):
    # on trimesh's icosphere (5,120 triangles) the tick finds the closest point through the
    # hierarchy, warm-started from the last tick's triangle; where the field is continuous
    # (the six probes 1 nm around p have p's closest triangle) it equals the NumPy field
    _, base = _icosphere(4)
    p = _probes(3000, seed=1)
    alg = object_algorithm(letter, EGG, base, K0)
    f, r = _ticks(alg, p)
    tid = [base._closest(p + s * 1e-9 * d)[2] for d in np.eye(3) for s in (-1, 1)]
    same = np.all([t == base._closest(p)[2] for t in tid], axis=0)
    assert same.sum() > 2900
    np.testing.assert_allclose(f[same], alg.force(p)[same], rtol=0, atol=1e-12 * K0 * 1e-3)
    assert 0 < r.max_work <= 200


def _brute_force_distance(tri, q):
    """The least distance from q (3,) to every triangle of tri (n, 3, 3), each by trimesh's
    closest point on a triangle (on a unit-sized copy: its tolerances are absolute)."""
    import trimesh

    scale = np.ptp(tri.reshape(-1, 3), axis=0).max()
    cp = trimesh.triangles.closest_point(tri / scale, np.repeat(q[None] / scale, len(tri), axis=0))
    return float(np.min(np.linalg.norm(cp - q / scale, axis=1)) * scale)


def test_the_hierarchy_finds_the_closest_triangle_exactly():
    # 400 probes (near the surface, deep inside, 1 m away, on vertices, at the centre) against
    # every triangle of a 1,280-triangle icosphere: never a farther triangle than the nearest
    m, base = _icosphere(3)
    tri = base._tri
    rng = np.random.default_rng(7)
    q = np.concatenate([_probes(300, seed=3), rng.normal(size=(50, 3)) * R * 0.5 + [0, 0, -R],
                        rng.normal(size=(20, 3)), np.asarray(m.vertices)[:20], [[0.0, 0.0, -R]] * 10])
    tree = base.core_spec()
    assert tree.triangles == len(tri) and tree.nodes <= 2 * len(tri) - 1
    tid, bary, d2 = np.zeros(len(q), dtype=np.int64), np.zeros((len(q), 3)), np.zeros(len(q))
    work = tree.closest(q, tid, bary, d2)
    assert np.all(np.abs(bary.sum(axis=1) - 1.0) < 1e-12) and np.all(bary >= 0.0)
    for i in range(len(q)):
        best = _brute_force_distance(tri, q[i])
        assert math.sqrt(d2[i]) <= best * (1 + 1e-12) + 1e-18, (i, math.sqrt(d2[i]), best)
        foot = bary[i] @ tri[tid[i]]
        assert abs(np.linalg.norm(q[i] - foot) - math.sqrt(d2[i])) <= 1e-12 * R
    assert work <= len(q) * (tree.nodes + len(tri))  # (the structural bound: every node and triangle once)


def test_a_tick_over_a_large_mesh_does_bounded_counted_work():
    # 81,920 triangles: along a stroke of 10^4 ticks 0.3 mm deep the tick visits at most a few
    # hundred nodes and triangles (the goal's 10^5-triangle scale; its time is benchmarked)
    _, base = _icosphere(6)
    s = np.linspace(-5e-3, 5e-3, 10_000)
    p = np.column_stack([s, 0.3e-3 * np.sin(500 * s), np.full_like(s, -0.3e-3)])
    f, r = _ticks(object_algorithm("A", EGG, base, K0), p)
    assert np.all(np.isfinite(f)) and r.faults == 0 and f[:, 2].mean() > 0.0
    assert r.max_work <= 400, r.max_work


def test_where_the_coordinates_are_undefined_the_tick_is_a_fault_with_zero_force():
    # on the cylinder's axis its normal is undefined: zero force, counted, never NaN
    r = hx.Renderer(object_algorithm("A", EGG, Cylinder(R), K0))
    assert r.step((0.0, 1e-3, -R)) == (0.0, 0.0, 0.0) and r.faults == 1
    assert r.step((0.0, 0.0, -0.1e-3)) != (0.0, 0.0, 0.0) and r.faults == 1


@pytest.mark.parametrize("letter", ["A", "B", "C", "G"])
def test_the_c_tick_on_the_prism_mesh_is_the_numpy_field(letter):
    # the prism base (each triangle swept along its vertices' normals, Mesh(normals="vertex")),
    # B, C and G clamped at d^z_max = 0.3 mm: the C tick's Newton solve in the prism, walking
    # across sides, against the NumPy one on 3,000 probes (measured 1.7e-15 N); its work stays within a few dozen visits
    m, base = _icosphere(4)
    smooth = Mesh(m, uv=base.uv, normals="vertex")
    p = _probes(3000, seed=2)
    alg = object_algorithm(letter, EGG, smooth, K0, **({} if letter == "A" else {"max_penetration": 0.3e-3}))
    f, r = _ticks(alg, p)
    np.testing.assert_allclose(f, alg.force(p), rtol=0, atol=1e-12 * K0 * 1e-3)
    assert r.faults == 0 and 0 < r.max_work <= 200


# -- the simulator over objects -----------------------------------------------------------------
def _hand():
    from haptex.operators import ScanningHand

    return ScanningHand(300.0, 3.0, velocity=0.01, depth=0.5e-3, dimension=3)  # 10 mm/s, 0.5 mm in


@pytest.mark.parametrize("letter", ["A", "B", "C", "G"])
def test_simulate_on_the_plane_base_is_the_plane_simulation(letter):
    # the same exact sampled-data loop with the object's tick: on Plane() the library's (to
    # rounding of the fields, 1e-15 N), the trajectories to 1e-12 m
    dev, start = hx.Device.point_mass(dimension=3), [0.3e-3, 0.2e-3, 0.1e-3]
    flat = hx.simulate(hx.algorithm(letter, EGG, K0), dev, _hand(), 0.2, initial_position=start)
    obj = hx.simulate(object_algorithm(letter, EGG, Plane(), K0), dev, _hand(), 0.2, initial_position=start)
    np.testing.assert_allclose(obj.position, flat.position, rtol=0, atol=1e-12)
    assert obj.energy_balance_ok and obj.max_penetration == pytest.approx(flat.max_penetration, rel=1e-9)


def test_simulate_on_a_sphere_tends_to_the_plane_as_its_radius_grows():
    # a hand scanning 3 mm across the top of a sphere: the surface sags s^2 / (2 R) below the
    # plane's at distance s from the top, so the runs differ by O(1 / R): measured 3.1e-4, 3.0e-5
    # and 3.0e-6 m for R = 12.7 mm, 127 mm, 1.27 m (the sag at 3 mm: 3.5e-4, 3.5e-5, 3.5e-6 m);
    # the energy balance closes on every base, and on a 5,120-triangle mesh of the smallest
    dev = hx.Device.point_mass(dimension=3)
    flat = hx.simulate(object_algorithm("A", EGG, Plane(), K0), dev, _hand(), 0.3)
    travel = np.abs(flat.position[:, 0]).max()
    diffs = []
    for radius in (R, 10 * R, 100 * R):
        res = hx.simulate(object_algorithm("A", EGG, Sphere(radius), K0), dev, _hand(), 0.3)
        assert res.energy_balance_ok and not res.diverged
        diffs.append(np.abs(res.position - flat.position).max())
        assert diffs[-1] <= 1.5 * travel ** 2 / (2 * radius), (radius, diffs[-1])
    assert all(8 <= a / b <= 12 for a, b in zip(diffs, diffs[1:])), diffs
    _, mesh = _icosphere(4)
    res = hx.simulate(object_algorithm("A", EGG, mesh, K0), dev, _hand(), 0.3)
    assert res.energy_balance_ok and np.all(np.isfinite(res.position))


def test_simulate_over_an_object_on_a_device_with_an_encoder_and_a_delay():
    # the general loop's quantised sensing and delay: the Falcon preset (its encoder, its delay,
    # its maximum force), the egg-crate on a sphere; finite, balanced, never above the maximum
    dev = hx.catalogue.preset("falcon").device()
    res = hx.simulate(object_algorithm("B", EGG, Sphere(R), K0), dev, _hand(), 0.3)
    assert res.energy_balance_ok and np.all(np.isfinite(res.position))
    assert np.linalg.norm(res.force, axis=1).max() <= dev.max_force * (1 + 1e-12)
    assert dev.position_resolution > 0 and res.max_penetration > 0.0


def test_simulate_batch_over_an_object_is_simulate_run_by_run():
    # the batch shares the object's base between its runs (the mesh's hierarchy built once):
    # four stiffnesses on a 5,120-triangle mesh, each run equal to its own simulate() and
    # judged the same; an algorithm parameter other than the stiffness is refused by name
    _, mesh = _icosphere(4)
    alg = object_algorithm("A", EGG, mesh, K0)
    dev = hx.Device.point_mass(dimension=3)
    ks = [500.0, 1000.0, 2000.0, 4000.0]
    batch = hx.simulate_batch(alg, dev, _hand(), 0.2, stiffness=ks, record=True, record_every=10)
    for i, k in enumerate(ks):
        one = hx.simulate(object_algorithm("A", EGG, mesh, k), dev, _hand(), 0.2, record_every=10)
        np.testing.assert_allclose(batch.runs[i].position, one.position, rtol=0, atol=1e-12)
        assert batch.regime[i] == one.regime and batch.max_penetration[i] == pytest.approx(one.max_penetration)
    with pytest.raises(ParameterError, match="max_penetration is not allowed in a sweep"):
        hx.simulate_batch(alg, dev, _hand(), 0.01, max_penetration=[1e-3, 2e-3])


def test_a_mesh_pickles_without_its_c_copy_and_gives_the_same_forces():
    # (Dask and process pools pickle algorithms: the core's Base is rebuilt where next needed)
    import pickle

    _, base = _icosphere(3)
    alg = object_algorithm("B", EGG, base, K0)
    p = _probes(200, seed=4)
    f = alg.force(p)
    again = pickle.loads(pickle.dumps(alg))
    assert "_core_base" not in again.base.__dict__
    np.testing.assert_array_equal(again.force(p), f)
    np.testing.assert_array_equal(_ticks(again, p)[0], _ticks(alg, p)[0])


# -- F on objects: presliding friction in the local tangent plane ------------------------------

F_PARAMS = dict(friction=0.5, presliding=0.2e-3)


def _stroke(base, u1_centre, n=801):
    """A wavy stroke across the surface coordinates, 0.5 mm below the base (inside F's wall)."""
    t = np.linspace(-3e-3, 3e-3, n)
    ut = np.column_stack([u1_centre + t, 0.3e-3 * np.sin(t * 2000.0)])
    return base.point(ut, np.full(n, -0.5e-3))


@pytest.mark.parametrize("base", [Plane(), Sphere(R), Cylinder(R)], ids=repr)
def test_f_on_a_base_is_its_static_field_at_the_ticks_deflection(base):
    # the C tick steps F's presliding state (the adhesion point in the surface coordinates); at
    # each tick its force equals the NumPy field at the deflection d = u - w it holds, to 1e-12
    # N, and |d| never exceeds d_max (eq. 24), across the seam of the closed bases too (the
    # stroke crosses u1 = pi R there)
    alg = object_algorithm("F", EGG, base, K0, **F_PARAMS)
    r = hx.Renderer(alg)
    centre = 0.0 if isinstance(base, Plane) else math.pi * R
    worst, slid = 0.0, 0.0
    for p in _stroke(base, centre):
        f = np.array(r.step(p))
        d = base.local(p[None])[0][0] - np.array(r.adhesion)
        if not isinstance(base, Plane):
            d[0] = (d[0] + math.pi * R) % (2 * math.pi * R) - math.pi * R
        assert np.linalg.norm(d) <= F_PARAMS["presliding"] * (1 + 1e-12)
        slid = max(slid, np.linalg.norm(d))
        worst = max(worst, np.abs(f - alg.force(p, deflection=d)).max())
    assert worst <= 1e-12 and slid == pytest.approx(F_PARAMS["presliding"])


def test_f_on_the_plane_base_is_the_papers_f():
    # Plane() is the paper's plane: the same forces as F over the surface, bit for bit up to
    # rounding, along a stroke in and out of the wall
    a = hx.Renderer(object_algorithm("F", EGG, Plane(), K0, **F_PARAMS))
    b = hx.Renderer(hx.algorithm("F", EGG, K0, **F_PARAMS))
    t = np.linspace(0.0, 1.0, 2001)
    pts = np.column_stack([4e-3 * np.sin(2 * np.pi * 2 * t), 2e-3 * np.cos(2 * np.pi * 3 * t),
                           -0.6e-3 * np.sin(2 * np.pi * 5 * t)])
    for p in pts:
        np.testing.assert_allclose(a.step(p), b.step(p), rtol=0, atol=1e-12)


@pytest.mark.parametrize("base", [Sphere(R), Cylinder(R)], ids=repr)
def test_f_sliding_on_a_curved_base_dissipates(base):
    # Section IV-F-4: sliding is dissipative. Round a closed loop in the surface coordinates at
    # constant depth under the base (so the wall's normal force does no work): the friction
    # absorbs energy on every lap, at least mu kappa_0 z (1 - depth) (perimeter - 4 d_max) in
    # slip; the observer's energy grows lap after lap
    alg = object_algorithm("F", EGG, base, K0, **F_PARAMS)
    r = hx.Renderer(alg, energy_monitor=True)
    s = np.linspace(0.0, 2 * np.pi, 2001)[:-1]
    loop = base.point(np.column_stack([2e-3 * np.cos(s), 2e-3 * np.sin(s)]), np.full(s.size, -0.5e-3))
    laps = []
    for _ in range(3):
        for p in loop:
            r.step(p)
        laps.append(r.energy)
    per_lap = np.diff([0.0] + laps)
    floor = 0.5 * K0 * 0.5e-3 * (1 - 0.8) * (2 * np.pi * 2e-3 * 0.9 - 4 * F_PARAMS["presliding"])
    assert np.all(per_lap[1:] > floor), (per_lap, floor)


def test_simulate_f_on_a_sphere_balances_its_energy():
    # the general loop with F's state on a sphere: a hand scanning across it, the energy balance
    # closed (the friction's work in the environment's energies) and the run finite
    dev = hx.Device.point_mass(dimension=3)
    res = hx.simulate(object_algorithm("F", EGG, Sphere(R), K0, **F_PARAMS), dev, _hand(), 0.3)
    assert res.energy_balance_ok and not res.diverged and res.max_penetration > 0.0
    assert res.totals["energy_x"] + res.totals["energy_y"] > 0.0  # the sliding absorbed energy


# -- D and E on objects: the closest point of the textured object ------------------------------

def _deep_probes(base, n, seed):
    """n probes under the egg-crate on the base: random surface coordinates, 0 to 0.8 mm deep
    (vertically), where D and E act."""
    rng = np.random.default_rng(seed)
    ut = np.column_stack([rng.uniform(-3e-3, 3e-3, n), rng.uniform(-3e-3, 3e-3, n)])
    return base.point(ut, EGG.height_at(ut) - rng.uniform(0.0, 0.8e-3, n))


def _brute_distance(base, p):
    """The least distance from p to the textured object over a 241 x 241 grid of surface
    coordinates, 10 um apart, around p's own (the oracle: slow, exhaustive)."""
    u0 = base.local(p[None])[0][0]
    g = np.linspace(-1.2e-3, 1.2e-3, 241)
    U = np.stack(np.meshgrid(u0[0] + g, u0[1] + g, indexing="ij"), -1).reshape(-1, 2)
    return float(np.min(np.linalg.norm(base.point(U, EGG.height_at(U)) - p, axis=1)))


@pytest.mark.parametrize("base", [Sphere(R), Cylinder(R)], ids=repr)
def test_d_and_e_on_a_curved_base_find_the_closest_point(base):
    # the C core's search over the object (Gauss-Newton from the foot, then a branch and bound
    # over the surface coordinates with second-order lower bounds, leaves polished): on 150
    # random probes up to 0.8 mm deep its distance (E's force / kappa_0) is never more than an
    # exhaustive 10 um grid's (it is less, by up to 1.2 um, where the grid misses the minimum),
    # and D's force points from the probe to a point of the object at that distance
    pts = _deep_probes(base, 150, 7)
    d = np.linalg.norm(object_algorithm("E", EGG, base, K0).force(pts), axis=1) / K0
    brute = np.array([_brute_distance(base, p) for p in pts])
    assert np.all(d <= brute + 1e-12), (d - brute).max()
    fd = object_algorithm("D", EGG, base, K0).force(pts)
    q = pts + fd / K0  # D's point on the object
    u, _, _, e, _, _ = base.local(q)
    np.testing.assert_allclose(e, EGG.height_at(u), rtol=0, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(q - pts, axis=1), d, rtol=0, atol=1e-12)


def test_d_and_e_on_the_plane_base_are_the_papers():
    # Plane() is the plane: E's distance is the plane's certified one to 1e-12 m on 2,000 probes;
    # D's points agree to 2e-8 m where the distance is flat around its minimum (3e-5 N measured)
    rng = np.random.default_rng(1)
    pts = np.column_stack([rng.uniform(-2e-3, 2e-3, 2000), rng.uniform(-2e-3, 2e-3, 2000),
                           rng.uniform(-0.8e-3, 0.2e-3, 2000)])
    e_obj = object_algorithm("E", EGG, Plane(), K0).force(pts)
    np.testing.assert_allclose(e_obj, hx.algorithm("E", EGG, K0).force(pts), rtol=0, atol=K0 * 1e-12)
    d_obj = object_algorithm("D", EGG, Plane(), K0).force(pts)
    np.testing.assert_allclose(d_obj, hx.algorithm("D", EGG, K0).force(pts), rtol=0, atol=K0 * 2e-8)


def test_d_on_a_sphere_in_the_renderer_does_bounded_counted_work():
    # the renderer's budget (max_evaluations) bounds a tick's work; ticks it ends are counted in
    # `cut`; along a stroke in and out of the object the forces are finite and within max_force,
    # and the simulator runs it with its energy balance closed
    base = Sphere(R)
    r = hx.Renderer(object_algorithm("D", EGG, base, K0), max_force=5.0, max_evaluations=2000)
    t = np.linspace(0.0, 1.0, 801)
    pts = base.point(np.column_stack([6e-3 * np.sin(2 * np.pi * t), 2e-3 * np.cos(4 * np.pi * t)]),
                     -0.5e-3 * np.sin(10 * np.pi * t))
    work = []
    for p in pts:
        f = np.array(r.step(p))
        assert np.all(np.isfinite(f)) and np.linalg.norm(f) <= 5.0 * (1 + 1e-12)
        if np.any(f):
            work.append(r.last_work)
    # (past the budget: the cell's leaf polish and the final one, each Gauss-Newton's 200 steps of
    # up to 41 evaluations and Newton's 1 + 8 x 4)
    assert r.max_work <= 2000 + 2 * (200 * 41 + 33) and r.faults == 0
    # the search's second-order (Taylor) bound prunes the cells around the minimum: a tick in
    # contact takes a median 431 evaluations, 11 of 399 ended by the budget (1,107 and 55 with
    # the first-order bound alone)
    assert len(work) > 300 and np.median(work) <= 700 and r.cut <= 25
    res = hx.simulate(object_algorithm("E", EGG, base, K0), hx.Device.point_mass(dimension=3), _hand(), 0.1)
    assert res.energy_balance_ok and res.max_penetration > 0.0


def test_d_and_e_on_objects_refuse_what_they_cannot_search():
    _, mesh = _icosphere(2)
    with pytest.raises(ParameterError, match="^base = .*textured faceted mesh is not written: give Mesh"):
        object_algorithm("D", EGG, mesh, K0)
    x = np.linspace(0.0, 2 * math.pi * R, 801)
    measured = hx.SampledProfile(x, A * np.sin(2 * math.pi * x / L) ** 3, periodic=True)
    with pytest.raises(ParameterError, match="^texture = "):
        object_algorithm("E", measured, Sphere(R), K0)
    # a Fourier profile is taken as gratings along u1: the same heights
    a = object_algorithm("E", hx.Sinusoid(A, L), Sphere(R), K0)
    u = np.array([[0.3e-3, 0.1e-3], [1.1e-3, -0.4e-3]])
    np.testing.assert_allclose(a.texture.height_at(u), hx.Sinusoid(A, L).height(u[:, 0]), rtol=0, atol=1e-18)


def test_d_and_e_on_a_prism_mesh_find_the_closest_point():
    # D and E on a mesh swept along its vertex normals (1,280 prisms round the sphere's R): the
    # C core's search (the prisms the hierarchy's inflated boxes leave, each by a branch and bound
    # over its UV triangle with second-order bounds, leaves polished through the UV map) never
    # gives a point farther than a dense 20 um grid of S(u) around the probe (it is nearer, by up
    # to 1.3 um, where the grid misses the minimum: measured on 100 probes), its point lies on the
    # textured surface, and E's force is kappa_0 r along the base's normal at the probe
    m, faceted = _icosphere(3)
    mesh = Mesh(m, uv=faceted.uv, normals="vertex")
    d, e = object_algorithm("D", EGG, mesh, K0), object_algorithm("E", EGG, mesh, K0)
    rng = np.random.default_rng(3)
    u0, depth = rng.uniform(-3e-3, 3e-3, (40, 2)), rng.uniform(0.0, 0.8e-3, 40)
    pts = mesh.point(u0, EGG.height_at(u0) - depth)
    c, r = d.closest_points(pts)
    g = np.linspace(-1.2e-3, 1.2e-3, 121)
    for p, u, dist in zip(pts, u0, r):
        U = np.stack(np.meshgrid(u[0] + g, u[1] + g, indexing="ij"), -1).reshape(-1, 2)
        assert dist <= np.min(np.linalg.norm(mesh.point(U, EGG.height_at(U)) - p, axis=1)) + 1e-12
    uc, _, _, ec, _, _ = mesh.local(c)
    np.testing.assert_allclose(ec, EGG.height_at(uc), rtol=0, atol=1e-12)
    np.testing.assert_allclose(d.force(pts), K0 * (c - pts), rtol=0, atol=1e-9)
    n = mesh.local(pts)[4]
    np.testing.assert_allclose(e.force(pts), K0 * r[:, None] * n, rtol=0, atol=1e-9)
    rd = hx.Renderer(d, max_force=5.0, max_evaluations=3000)
    for p in pts:
        f = np.array(rd.step(p))
        assert np.all(np.isfinite(f)) and np.linalg.norm(f) <= 5.0 * (1 + 1e-12)
    # (the budget is checked before each cell: a tick may pass it by one cell's leaf polish,
    # Gauss-Newton's 200 steps of up to 41 evaluations and Newton's 1 + 8 x 4)
    assert rd.faults == 0 and rd.max_work <= 3000 + 200 * 41 + 33

