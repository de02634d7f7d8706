"""Issue 32: the reference algorithms of the libraries users know, analysed by haptex beside its
own. CHAI3D's normal-map texture (haptex.reference.Chai3dNormalMap, from CHAI3D 3.3's
cAlgorithmFingerProxy::updateForce) on trimesh's icosphere with the egg-crate."""

from __future__ import annotations

import numpy as np
import pytest

import haptex as hx
from haptex._validation import ParameterError
from haptex.analysis.work import loop_energy
from haptex.objects import Sphere, object_algorithm
from haptex.reference import Chai3dNormalMap
from haptex.textures import Flat

from .test_object_core import EGG, K0, R, _icosphere


def _probes():
    """400 probes 0.1-0.6 mm under the sphere's surface within 2 mm of its top."""
    rng = np.random.default_rng(0)
    return Sphere(R).point(rng.uniform(-2e-3, 2e-3, (400, 2)), -rng.uniform(0.1e-3, 0.6e-3, 400))


def test_without_relief_it_is_the_proxys_spring():
    # a flat texture's map is (0, 0, 1/2) everywhere: the new normal is the triangle's, and the
    # force is the proxy's spring kappa_0 (proxy - p), the proxy the closest point of the mesh
    _, base = _icosphere(3)
    p = _probes()
    f = Chai3dNormalMap(Flat(dimension=2), base, K0, level=0.01).force(p)
    foot = base._closest(p)[0]
    np.testing.assert_allclose(f, K0 * (foot - p), rtol=0, atol=1e-12 * K0 * 1e-3)


def test_the_felt_slope_depends_on_the_tessellation_and_the_level_not_on_the_texture_alone():
    # the map's slope is divided by the triangle's edge lengths (m): with each subdivision of the
    # icosphere (edges halved) the force's tilt from the facet's normal doubles (measured median
    # tan 0.235, 0.469, 0.945 at level 1e-3), and it is proportional to the level; haptex's B on
    # the same meshes tilts by the texture's own slope, the same on every mesh (0.446, 0.447, 0.445)
    p = _probes()
    chai, own = [], []
    for sub in (3, 4, 5):
        _, base = _icosphere(sub)
        face = np.all(base._closest(p)[3] > 1e-9, axis=1)  # (inside a facet: the proxy's force is normal)
        t1 = np.tan(Chai3dNormalMap(EGG, base, K0, level=1e-3).tilt(p))[face]
        t10 = np.tan(Chai3dNormalMap(EGG, base, K0, level=1e-2).tilt(p))[face]
        np.testing.assert_allclose(t10, 10 * t1, rtol=1e-9)
        chai.append(np.median(t1))
        fb = object_algorithm("B", EGG, base, K0).force(p)
        n = base.local(p)[4]
        ok = np.linalg.norm(fb, axis=1) > 0
        own.append(np.median(np.tan(np.arccos(np.clip(np.einsum("ij,ij->i", fb[ok], n[ok])
                                                      / np.linalg.norm(fb[ok], axis=1), -1, 1)))))
    assert all(1.8 <= b / a <= 2.2 for a, b in zip(chai, chai[1:])), chai
    assert all(abs(b / a - 1) <= 0.02 for a, b in zip(own, own[1:])), own


def test_it_is_not_conservative_where_haptexs_c_is():
    # a 0.4 mm square loop 0.3 mm under one facet of the 1,280-triangle icosphere (every point's
    # closest triangle the same): C, a gradient, does no work around it (1e-20 J), CHAI3D's
    # normal-mapped force does (measured 0.97 uJ at level 1e-3, 35 uJ at 1e-2), reversed with the
    # loop: the proxy keeps the normal force's magnitude and turns its direction (force shading)
    _, base = _icosphere(3)
    t = base._closest(np.array([[0.0, 0.0, -0.3e-3]]))[2][0]
    tri, nf = base._tri[t], base._normals[t]
    a = (tri[1] - tri[0]) / np.linalg.norm(tri[1] - tri[0])
    b = np.cross(nf, a)
    loop = np.array([tri.mean(axis=0) + 0.2e-3 * (x * a + y * b) - 0.3e-3 * nf
                     for x, y in ((-1, -1), (1, -1), (1, 1), (-1, 1))])
    assert set(base._closest(loop)[2].tolist()) == {t}
    assert abs(loop_energy(object_algorithm("C", EGG, base, K0), loop)) < 1e-15
    for level, least in ((1e-3, 5e-7), (1e-2, 1e-5)):
        e = loop_energy(Chai3dNormalMap(EGG, base, K0, level=level), loop)
        assert abs(e) > least and loop_energy(Chai3dNormalMap(EGG, base, K0, level=level), loop[::-1]) == \
            pytest.approx(-e, rel=1e-9)


def test_it_is_an_analysis_model_refused_where_it_would_run_as_another():
    _, base = _icosphere(2)
    c = Chai3dNormalMap(EGG, base, K0, level=1e-3)
    with pytest.raises(ParameterError, match="reference model"):
        hx.Renderer(c)
    with pytest.raises(ParameterError, match="level"):
        Chai3dNormalMap(EGG, base, K0, level=0.0)
    with pytest.raises(ParameterError, match="base"):
        Chai3dNormalMap(EGG, Sphere(R), K0)


# -- H3D/HAPI's depth-map surface ---------------------------------------------------------------

def _hapi_stroke():
    """A 4 mm stroke along x, 0.25 mm under the egg-crate's mean (0.2 mm high, 2 mm period)."""
    t = np.linspace(0.0, 1.0, 2001)
    return np.column_stack([4e-3 * t, np.full(t.size, 0.3e-3), np.full(t.size, -0.25e-3)])


def test_hapi_defaults_are_hapis():
    # HAPIVariableDepthSurface.h: max_iterations = 35, minimization_epsilon = 1e-4
    from haptex.reference import HAPI_EPSILON, HAPI_MAX_ITERATIONS, HapiDepthMap

    assert (HAPI_MAX_ITERATIONS, HAPI_EPSILON) == (35, 1e-4)
    hp = HapiDepthMap(hx.SumOfGratings.egg_crate(0.2e-3, 2e-3), 2000.0)
    assert (hp.max_iterations, hp.epsilon) == (35, 1e-4)
    for bad in (dict(max_iterations=0), dict(epsilon=0.0), dict(stiffness=-1.0)):
        with pytest.raises(hx.ParameterError, match=f"^{next(iter(bad))} = "):
            HapiDepthMap(hx.SumOfGratings.egg_crate(0.2e-3, 2e-3), **({"stiffness": 2000.0} | bad))


@pytest.mark.long  # 4 s: HAPI's reference algorithm in pure Python, not haptex's tick (was -m slow, run by nothing)
def test_hapis_local_search_stops_short_of_the_closest_point():
    # Its simplex stops at a relative spread of 1e-4 in the squared distance: along the stroke
    # its contact point is off the certified closest point (haptex's D, hx_closest.c) by 1.2 um
    # (median), more than 1 um on 58 % of the ticks (measured), and never nearer the probe than
    # the certified one (the certificate's check). Searched to 1e-12 with 2,000 iterations it
    # reaches D's point on all but 1 tick in 2,001 (a basin change it follows one tick late).
    from haptex.closest import closest_point
    from haptex.reference import HapiDepthMap

    egg = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)
    pts = _hapi_stroke()
    cp = closest_point(egg, pts)
    closest = np.column_stack([cp.x, cp.y, cp.z])
    for eps, iters, share in ((1e-4, 35, (0.3, 0.9)), (1e-12, 2000, (0.0, 0.002))):
        hp = HapiDepthMap(egg, 2000.0, iters, eps)
        contact = []
        for p in pts:
            hp.step(p)
            contact.append(hp.contact_point)
        contact = np.array(contact)
        off = np.linalg.norm(contact - closest, axis=1)
        assert share[0] <= np.mean(off > 1e-6) <= share[1], (eps, np.mean(off > 1e-6))
        assert np.all(np.linalg.norm(contact - pts, axis=1) >= cp.distance - 1e-12)


@pytest.mark.long  # 4 s: HAPI's reference algorithm in pure Python, not haptex's tick (was -m slow, run by nothing)
def test_hapis_tolerance_makes_its_loops_dissipative():
    # Around a 1.2 x 0.8 mm rectangle 0.25 mm deep, lap after lap, the proxy that stops early
    # lags behind and drags: its force does -0.7 to -1.7 uJ a lap (measured; -0.4 uJ at 0.1 mm
    # deep); searched to 1e-12 it does under 0.05 uJ after the first lap, and D's force,
    # conservative where the closest point is unique, 1e-14 J
    from haptex.closest import closest_point
    from haptex.reference import HapiDepthMap

    egg = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)
    corners = np.array([[0, 0], [1.2e-3, 0], [1.2e-3, 0.8e-3], [0, 0.8e-3], [0, 0]]) + [0.2e-3, 0.1e-3]
    for z in (-0.25e-3,):
        s = np.arange(250) / 250
        loop = np.vstack([np.column_stack([a + np.outer(s, b - a), np.full(250, z)])
                          for a, b in zip(corners[:-1], corners[1:])])
        loop = np.vstack([loop, loop[:1]])

        def laps(model, n=2):
            for zz in np.linspace(0.3e-3, z, 50):  # in from above
                model.step([loop[0, 0], loop[0, 1], zz])
            out = []
            for _ in range(n):
                f = np.array([model.step(p) for p in loop])
                out.append(float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(loop, axis=0))))
            return np.array(out)

        default = laps(HapiDepthMap(egg, 2000.0))
        tight = laps(HapiDepthMap(egg, 2000.0, 2000, 1e-12))
        assert np.all(default < -0.2e-6), default
        assert np.all(np.abs(tight[1:]) < 0.05e-6), tight
        cp = closest_point(egg, loop)
        fd = 2000.0 * (np.column_stack([cp.x, cp.y, cp.z]) - loop)
        assert abs(float(np.sum(0.5 * (fd[1:] + fd[:-1]) * np.diff(loop, axis=0)))) < 1e-12


@pytest.mark.long  # 4 s: HAPI's reference algorithm in pure Python, not haptex's tick (was -m slow, run by nothing)
def test_hapi_on_a_sphere_stops_short_and_drags_as_on_the_plane():
    # HAPI's depth map on an object's base (the proxy in the base's surface coordinates, the
    # simplex over S(u) = P(u, h(u))): Plane() is the plane model tick for tick; on a sphere of
    # 40 periods round, 0.25 mm under the mean along u1, its contact point is off the certified
    # closest point of the textured sphere (haptex's D on the object) by more than 1 um on most
    # ticks (measured 80 %, 1.9 um median) and never nearer the probe; searched to 1e-12 with
    # 2,000 iterations it reaches D's point (1 tick in 600 off, a basin change followed a tick
    # late). Round a 1.2 x 0.8 mm rectangle of surface coordinates its force does -1.1 and -1.6
    # uJ a lap (measured) where D's does 1e-11 J
    from haptex.objects import Plane, Sphere, object_algorithm
    from haptex.reference import HapiDepthMap

    egg = hx.SumOfGratings.egg_crate(0.2e-3, 2e-3)
    pts = _hapi_stroke()[:400]
    flat, on_plane = HapiDepthMap(egg, 2000.0), HapiDepthMap(egg, 2000.0, base=Plane())
    assert all(np.array_equal(flat.step(p), on_plane.step(p)) for p in pts)
    base = Sphere(40 * 2e-3 / (2 * np.pi))
    t = np.linspace(0.0, 0.6, 400)
    probes = base.point(np.column_stack([4e-3 * t, np.full(t.size, 0.3e-3)]), np.full(t.size, -0.25e-3))
    c, r = object_algorithm("D", egg, base, 2000.0).closest_points(probes)
    for eps, iters, share in ((1e-4, 35, (0.5, 0.95)), (1e-12, 2000, (0.0, 0.01))):
        hp = HapiDepthMap(egg, 2000.0, iters, eps, base=base)
        contact = []
        for p in probes:
            hp.step(p)
            contact.append(hp.contact_point)
        contact = np.array(contact)
        assert share[0] <= np.mean(np.linalg.norm(contact - c, axis=1) > 1e-6) <= share[1], eps
        assert np.all(np.linalg.norm(contact - probes, axis=1) >= r - 1e-12)
    corners = np.array([[0, 0], [1.2e-3, 0], [1.2e-3, 0.8e-3], [0, 0.8e-3], [0, 0]]) + [0.2e-3, 0.1e-3]
    s = np.arange(250) / 250
    uv = np.vstack([a + np.outer(s, b - a) for a, b in zip(corners[:-1], corners[1:])])
    loop = base.point(np.vstack([uv, uv[:1]]), np.full(len(uv) + 1, -0.25e-3))
    hp = HapiDepthMap(egg, 2000.0, base=base)
    for e in np.linspace(0.3e-3, -0.25e-3, 50):  # in from above
        hp.step(base.point(uv[:1], np.array([e]))[0])
    for _ in range(2):
        f = np.array([hp.step(p) for p in loop])
        assert float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(loop, axis=0))) < -0.5e-6
    fd = object_algorithm("D", egg, base, 2000.0).force(loop)
    assert abs(float(np.sum(0.5 * (fd[1:] + fd[:-1]) * np.diff(loop, axis=0)))) < 1e-9
    with pytest.raises(ParameterError, match="^base = "):
        HapiDepthMap(egg, 2000.0, base="sphere")
