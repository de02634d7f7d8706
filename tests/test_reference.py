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
