"""Reference algorithms of the haptics libraries users know, in physical units, analysed by
haptex beside its own (issue 32): CHAI3D's normal map (:class:`Chai3dNormalMap`) and H3D/HAPI's
depth-map surface (:class:`HapiDepthMap`).

:class:`Chai3dNormalMap` is CHAI3D's normal-map texture on a triangle mesh, as its finger-proxy
algorithm computes it (CHAI3D 3.3, ``cAlgorithmFingerProxy::updateForce``, BSD licence; read
from its source, written here from that description):

1. the proxy rests on the mesh (a single contact, no friction: the closest point of the
   untextured mesh, for a probe inside it), and the spring force is F = kappa_0 (proxy - p);
2. F is split along the contact triangle's geometric normal n: F_n = (F . n) n, F_t = F - F_n;
3. the normal map, sampled at the contact's texture coordinates, gives a vector
   g = (g_x, g_y, g_z) in the texture's frame: an 8-bit map stores a unit normal as
   127.5 (1 + n), and CHAI3D decodes (c - 128) / 255, so g = n_tex / 2 up to the 8-bit
   rounding; haptex builds the map from the texture's own slopes s = grad_u h (m/m): n_tex =
   (-s_1, -s_2, 1) / sqrt(1 + ‖s‖^2), exactly (no 8-bit rounding);
4. (g_x, g_y) is carried onto the triangle through its texture-coordinate edges: with
   t_01, t_02 the unit directions of the triangle's edges in texture space, solve
   [t_01 t_02] c = level (g_x, g_y), then grad = c_1 e_01 / ‖e_01‖^2 + c_2 e_02 / ‖e_02‖^2
   + g_z n (e_01, e_02 the triangle's edges in space, m);
5. the new normal is grad / ‖grad‖ (turned over if it makes more than 1.57 rad with n), and
   the force is F_t + ‖F_n‖ new normal.

Step 4 divides a dimensionless slope by an edge length in metres: the perturbation's strength
is level / ‖e‖ relative to the normal's g_z, so the same texture feels twice as steep on a mesh
tessellated twice as finely, and half as steep on the same mesh drawn twice as large. The force
keeps the magnitude of the proxy's normal force and turns its direction: force shading (the
paper's G) on the proxy's plane, which haptex shows is not conservative.
"""

from __future__ import annotations

import numpy as np

from ._validation import ParameterError, fail, numbers, positive
from .objects import Mesh, ObjectAlgorithm
from .textures import Texture

__all__ = ["Chai3dNormalMap", "FLIP_ANGLE", "HapiDepthMap", "HAPI_MAX_ITERATIONS", "HAPI_EPSILON"]

FLIP_ANGLE = 1.57
"""rad: CHAI3D turns the new normal over when it makes more than this with the triangle's."""

JACOBIAN_STEP = 1e-9
"""m: the central differences of :meth:`Chai3dNormalMap.jacobian` (the model has no closed form
for it here). On a facet the force is smooth in p; where a stencil straddles a change of facet
the force jumps and the differences see the jump (1 nm apart), so a characteristic number over
a region measures those jumps (measured 1.0e5 at level 1e-3 on the 1,280-facet ball), not the
texture."""


class _AnalysisOnly:
    """The reference models' refusal of the C core: they run in Python for analysis only."""

    _renders_instead = ""
    """What renders in haptex instead (named in the refusal)."""

    def kernel_spec(self, *_):
        """Refused: a reference model runs in Python for analysis, never in the C core.

        Parameters
        ----------
        *_
            Ignored (the signature of :meth:`haptex.Algorithm.kernel_spec` and ``object_spec``).

        Raises
        ------
        ParameterError
            Always, naming the model and what renders instead.
        """
        raise ParameterError(f"{self!r} is not allowed in the renderer, the simulator or the export: it is a reference "
                             f"model for analysis ({self._renders_instead})")

    object_spec = kernel_spec


class Chai3dNormalMap(_AnalysisOnly, ObjectAlgorithm):
    """CHAI3D's normal-map texture on a mesh, in physical units (see the module docstring).

    Parameters
    ----------
    texture : Texture
        The height h(u) (m) the normal map is made from (its slopes, exactly), over the mesh's
        UV map in metres; a profile is extruded along u2.
    base : Mesh
        A closed triangle mesh with a UV map (:class:`haptex.objects.Mesh`, faceted).
    stiffness : float
        kappa_0 of the proxy's spring (N/m), > 0.
    level : float
        The material's texture level (CHAI3D's ``cMaterial::setTextureLevel``), > 0,
        dimensionless as CHAI3D uses it (it multiplies a slope that is then divided by an edge
        length in metres).

    Raises
    ------
    ParameterError
        If ``base`` is not a faceted :class:`~haptex.objects.Mesh`, or ``stiffness`` or
        ``level`` is not > 0.

    Notes
    -----
    Probe positions are [x, y, z] (m), forces (N). Inside is where the probe is under the
    untextured mesh (e < 0: the proxy is held on it); the analyses treat it as haptex's G on
    the object for their regions and breakpoints (the mesh's facets). It is an analysis model:
    the renderer, the simulator and the export refuse it.

    References
    ----------
    CHAI3D 3.3, src/forces/CAlgorithmFingerProxy.cpp (updateForce, the normal map's block),
    F. Conti et al., www.chai3d.org.
    """

    _renders_instead = "haptex's own algorithms render on objects"

    def __init__(self, texture: Texture, base: Mesh, stiffness: float, level: float = 1.0):
        if not isinstance(base, Mesh) or base._vn is not None:
            raise fail("base", base, "a faceted haptex.objects.Mesh (CHAI3D's normal map lives on a mesh's triangles)")
        super().__init__("G", texture, base, stiffness)
        self.level = positive("level", level, "")
        self.name = "CHAI3D normal map on a proxy"
        self.reference = "CHAI3D 3.3, cAlgorithmFingerProxy::updateForce (normal map); haptex.reference"

    def __repr__(self) -> str:
        return (f"Chai3dNormalMap({self.texture!r}, {self.base!r}, stiffness={self.stiffness:g}, "
                f"level={self.level:g})")

    def _object(self, p, jac: bool):
        shape = p.shape[:-1]
        flat = p.reshape(-1, 3)
        base = self.base
        foot, _, tid, _ = base._closest(flat)
        u, _, _, e, _, _ = base.local(flat)
        inside = e < 0.0
        F = self.stiffness * (foot - flat)  # the proxy's spring
        nf = base._normals[tid]
        Fn = np.einsum("ij,ij->i", F, nf)
        Ft = F - Fn[:, None] * nf
        s = self.texture.gradient(u)  # (N, 2): the physical slopes the map encodes
        g = np.concatenate([-s, np.ones((len(s), 1))], axis=1) / (2.0 * np.sqrt(1.0 + np.sum(s * s, axis=1)))[:, None]
        faces = base._faces[tid]
        tc = base.uv[faces]  # (N, 3, 2): the corners' texture coordinates (directions only matter)
        t01, t02 = tc[:, 1] - tc[:, 0], tc[:, 2] - tc[:, 0]
        t01 = t01 / np.linalg.norm(t01, axis=1, keepdims=True)
        t02 = t02 / np.linalg.norm(t02, axis=1, keepdims=True)
        M = np.stack([t01, t02], axis=-1)  # (N, 2, 2): columns the unit edge directions
        c = np.linalg.solve(M, self.level * g[:, :2, None])[..., 0]
        tri = base._tri[tid]
        e01, e02 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
        grad = (c[:, :1] * e01 / np.sum(e01 * e01, axis=1, keepdims=True)
                + c[:, 1:] * e02 / np.sum(e02 * e02, axis=1, keepdims=True) + g[:, 2:] * nf)
        new = grad / np.linalg.norm(grad, axis=1, keepdims=True)
        turn = np.einsum("ij,ij->i", new, nf) < np.cos(FLIP_ANGLE)
        new[turn] = -new[turn]
        f = np.where(inside[:, None], Ft + np.abs(Fn)[:, None] * new, 0.0).reshape(*shape, 3)
        if not jac:
            return f, None
        h = JACOBIAN_STEP
        cols = [(self._object(p + h * d, False)[0] - self._object(p - h * d, False)[0]) / (2 * h)
                for d in np.eye(3)]
        return f, np.stack(cols, axis=-1)

    def tilt(self, p) -> np.ndarray:
        """The angle (rad) between the force and the contact triangle's normal, shape (...):
        what the normal map does to the proxy's force (0 without it); NaN outside.

        Parameters
        ----------
        p : array_like, shape (..., 3)
            Probe positions (m).

        Returns
        -------
        numpy.ndarray, shape (...)
            The angle (rad), NaN outside.
        """
        p = self._positions(p)
        f = self.force(p)
        _, _, tid, _ = self.base._closest(p.reshape(-1, 3))
        nf = self.base._normals[tid].reshape(*p.shape[:-1], 3)
        cos = np.einsum("...j,...j->...", f, nf) / np.linalg.norm(f, axis=-1)
        with np.errstate(invalid="ignore"):
            return np.where(np.linalg.norm(f, axis=-1) > 0, np.arccos(np.clip(cos, -1.0, 1.0)), np.nan)



# -- H3D/HAPI's depth-map surface --------------------------------------------------------------

HAPI_MAX_ITERATIONS = 35
"""The simplex search's iteration cap: HAPIVariableDepthSurface's default ``max_iterations``
(published: HAPI's HAPIVariableDepthSurface.h, SenseGraphics, GPL)."""

HAPI_EPSILON = 1e-4
"""The simplex search's tolerance: HAPIVariableDepthSurface's default ``minimization_epsilon``
(published: the same header)."""


class HapiDepthMap(_AnalysisOnly):
    """H3D/HAPI's depth-map surface (``HAPIVariableDepthSurface`` without friction) on a plane or
    on an object's base, in physical units: a god-object found by a local derivative-free
    search, not a certified closest point.

    HAPI renders a depth map on a primitive (here the base offset to the texture's top, e = max
    h: a depth map sinks into the surface; on the plane z = max h) with its proxy-based renderer.
    While the probe is under the primitive the proxy w (surface coordinates, m) stays on it;
    each tick (read from HAPI's source, HAPIVariableDepthSurface.cpp, and written here from that
    description):

    1. in the local frame at the proxy, the probe's lateral offset is m = u(p) - w (on the
       plane u(p) = p_xy; on a base, the probe's surface coordinates, :mod:`haptex.objects`);
    2. a downhill simplex (Nelder & Mead) minimises the squared distance from the probe to the
       displaced surface's point over the lateral move v, f(v) = ‖S(w + v) - p‖^2, S(u) the
       point at offset h(u) along the base's normal at u (on the plane (u, h(u))), from the
       simplex {0, m, m/2 + (m_y, -m_x)/2}, for at most ``max_iterations`` iterations or until
       the relative spread of f over the simplex is below ``epsilon``;
    3. the proxy moves to w + v*, and the force is the spring kappa_0 (S(w) - p) where the probe
       is below the displaced surface at the proxy, e(p) < h(w) (zero above it, the contact with
       the primitive kept).

    The search starts where the proxy was and spans the probe's lateral offset: it finds a
    local minimum of the distance near the proxy, possibly not the closest point (haptex's D),
    and stops at the iteration cap wherever it is. Both are measured by :meth:`step`'s
    counters and analysed in tests/test_reference.py.

    Parameters
    ----------
    texture : Texture
        A surface h(x, y) (m); a profile is extruded along y.
    stiffness : float
        kappa_0 of the proxy's spring (N/m), > 0.
    base : haptex.objects.Base, optional
        The base the depth map is on: None (default) the plane, or a
        :class:`haptex.objects.Plane`, ``Cylinder`` or ``Sphere`` (a closed base needs the
        texture to fit it, as :func:`haptex.objects.object_algorithm`).
    max_iterations : int, optional
        Default :data:`HAPI_MAX_ITERATIONS` (HAPI's).
    epsilon : float, optional
        Default :data:`HAPI_EPSILON` (HAPI's): the simplex stops when 2 ‖f_max - f_min‖ /
        (‖f_max‖ + ‖f_min‖) is below it, the fractional tolerance of the textbook amoeba
        (Press et al., Numerical Recipes; H3DUtil's own implementation was not available to
        us, so its stopping rule and what counts as an iteration, here one reflection step,
        are chosen).

    Raises
    ------
    ParameterError
        For a texture that is not a haptex texture, a stiffness not > 0, ``max_iterations`` not
        a whole number >= 1, ``epsilon`` not > 0, or a base that is not a plane, cylinder or
        sphere or that the texture does not fit.

    Notes
    -----
    Positions [x, y, z] (m), forces (N). It is an analysis model with history: :meth:`step`
    one tick at a time, :meth:`reset` to forget the contact. The renderer, the simulator and
    the export do not take it.

    References
    ----------
    H3D API / HAPI 1.x, src/HAPIVariableDepthSurface.cpp (getProxyMovement, getForces) and
    include/HAPI/HAPIVariableDepthSurface.h, SenseGraphics AB, www.h3dapi.org; J. A. Nelder and
    R. Mead, "A simplex method for function minimization", Computer Journal 7, 1965, pp. 308–313.
    """

    _renders_instead = "haptex's own D and proxy render"

    letter = "HAPI"
    name = "HAPI depth-map surface (local simplex search)"
    dimension = 3

    def __init__(self, texture: Texture, stiffness: float, max_iterations: int = HAPI_MAX_ITERATIONS,
                 epsilon: float = HAPI_EPSILON, base=None):
        from ._validation import whole
        from .objects import Cylinder, Plane, Sphere
        from .surfaces import Extruded

        if not isinstance(texture, Texture):
            raise fail("texture", texture, "a haptex texture (a profile or a surface)")
        self.texture = Extruded(texture) if texture.dimension == 1 else texture
        self.stiffness = positive("stiffness", stiffness, "N/m")
        self.max_iterations = whole("max_iterations", max_iterations, 1, 10 ** 6, "simplex iterations")
        self.epsilon = positive("epsilon", epsilon, "")
        if base is not None and not isinstance(base, Plane | Cylinder | Sphere):
            raise fail("base", base, "None (the plane), or a haptex.objects Plane(), Cylinder(R) or Sphere(R)")
        if base is not None:
            base.check_texture(self.texture)
        self.base = None if isinstance(base, Plane) else base  # (the plane's own fast path)
        self.top = float(self.texture.height_range[1])
        self.reset()

    def __repr__(self) -> str:
        on = "" if self.base is None else f", base={self.base!r}"
        return (f"HapiDepthMap({self.texture!r}, stiffness={self.stiffness:g}, max_iterations={self.max_iterations}, "
                f"epsilon={self.epsilon:g}{on})")

    def reset(self) -> None:
        """No contact, no history; the counters cleared."""
        self.proxy_xy = None
        self.last_iterations = 0
        self.capped = 0
        self.evaluations = 0

    def _h(self, xy) -> float:
        self.evaluations += 1
        return float(self.texture.height_at(np.asarray(xy, dtype=float)[None, :])[0])

    def _surface(self, u, h=None) -> np.ndarray:
        """S(u) (m), shape (3,): the displaced surface's point at surface coordinates u (its
        height h(u) given, or evaluated)."""
        h = self._h(u) if h is None else h
        if self.base is None:
            return np.array([u[0], u[1], h])
        return self.base.point(np.asarray(u, dtype=float)[None, :], np.array([h]))[0]

    @property
    def contact_point(self) -> np.ndarray | None:
        """S(w): the displaced surface's point at the proxy (m), shape (3,), or None out of contact."""
        if self.proxy_xy is None:
            return None
        return self._surface(self.proxy_xy)

    def _simplex(self, w, p, up):
        """The local simplex search of step 2 from the proxy w toward the probe's coordinates
        up: the lateral move v* (m) and its iterations."""
        def f(v):
            d = self._surface(w + v) - p
            return float(d @ d)

        m = up - w
        half = 0.5 * m
        pts = np.array([[0.0, 0.0], m, half + np.array([half[1], -half[0]])])
        vals = np.array([f(v) for v in pts])
        it = 0
        while True:
            order = np.argsort(vals, kind="stable")
            pts, vals = pts[order], vals[order]
            lo, hi = vals[0], vals[-1]
            if 2.0 * abs(hi - lo) <= self.epsilon * (abs(hi) + abs(lo)) + 1e-300 or it >= self.max_iterations:
                break
            it += 1
            centroid = pts[:-1].mean(axis=0)
            r = centroid + (centroid - pts[-1])  # reflect the worst through the others' centroid
            fr = f(r)
            if fr < vals[0]:
                e = centroid + 2.0 * (centroid - pts[-1])  # expand
                fe = f(e)
                pts[-1], vals[-1] = (e, fe) if fe < fr else (r, fr)
            elif fr < vals[-2]:
                pts[-1], vals[-1] = r, fr
            else:
                c = centroid + 0.5 * (pts[-1] - centroid)  # contract towards the centroid
                fc = f(c)
                if fc < vals[-1]:
                    pts[-1], vals[-1] = c, fc
                else:  # shrink towards the best
                    pts[1:] = pts[0] + 0.5 * (pts[1:] - pts[0])
                    vals[1:] = [f(v) for v in pts[1:]]
        return pts[0], it

    def step(self, p) -> np.ndarray:
        """One tick: the force (N), shape (3,), at the probe position ``p`` (m), shape (3,).

        Parameters
        ----------
        p : array_like, shape (3,)
            The probe's position (m).

        Returns
        -------
        numpy.ndarray, shape (3,)
            The force (N).

        Raises
        ------
        ParameterError
            For a position that is not 3 finite coordinates.
        """
        p = numbers("p", p, "3 finite coordinates [x, y, z] (m)", copy=False).reshape(-1)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise fail("p", p.tolist(), "3 finite coordinates [x, y, z] (m)")
        self.last_iterations = 0
        if self.base is None:
            up, e = p[:2].copy(), p[2]
        else:
            local = self.base.local(p[None, :])
            up, e = local[0][0], float(local[3][0])
        if not e < self.top:  # above the primitive: no contact
            self.proxy_xy = None
            return np.zeros(3)
        if self.proxy_xy is None:  # contact starts where the probe crossed the primitive
            self.proxy_xy = up
        move, it = self._simplex(self.proxy_xy, p, up)
        self.last_iterations = it
        self.capped += it >= self.max_iterations
        self.proxy_xy = self.proxy_xy + move
        h = self._h(self.proxy_xy)
        if not e < h:  # above the depth at the proxy: no force
            return np.zeros(3)
        return self.stiffness * (self._surface(self.proxy_xy, h) - p)

