"""A god-object (proxy) on a textured wall, after Zilles & Salisbury (1995) and Ruspini, Kolarov
& Khatib (1997): a different algorithm from the paper's D.

D (Campion & Hayward, Table I) pulls the probe towards the **closest** point of the textured
boundary: a static field, which jumps where the closest point does (Remark 6). A god-object is
a point kept on or above the boundary that follows the probe **with history**: while the probe
is inside, the proxy slides on the boundary to the nearest point it can reach by moving
downhill in distance from where it was, and the force is the spring κ0 (proxy − probe). Below
a peak it stays on the flank it came from until that flank's local minimum of distance
disappears, then slides to the other: its force is continuous along any path, but it depends
on the path (issue 32), so its energy is analysed along paths, not as a field
(:func:`loop_work`).

What is modelled: the proxy's surface coordinate u (m) is the local minimum of
φ(u) = ‖S(u) − p‖² reached by a damped descent from the last one (steps at most a sixteenth of
the texture's shortest period, each decreasing φ), S(u) = (u, h(u)) on a plane, or the textured
object's point ``base.point(u, h(u))`` over a curved base of :mod:`haptex.objects`; contact
starts at the probe's foot where it crosses the boundary and ends when the probe is outside the
boundary at its own foot. Friction on the proxy (Ruspini's) is not modelled.

Over the plane the tick is the C core's (``tick_proxy`` in hx_fields.h: Newton steps on φ with
the texture's Hessian, at most 200 of them, each backtracked at most 40 times; its texture
evaluations counted): :meth:`GodObject.step` runs it, and :class:`haptex.Renderer`,
:func:`haptex.simulate` and :func:`haptex.simulate_batch` (the general loop) and ``haptex
export`` take a GodObject like an algorithm. Over a cylinder, a sphere or a mesh the tick is the
C core's too (``object_proxy`` in hx_object.c: Gauss-Newton on the surface's Jacobian, in closed
form on the analytic bases, through the UV map on a mesh: the triangle holding u found by a walk
across the triangles' sides from the probe's closest one, the point and its Jacobian affine in u
there; the same bounds). The Python descent (Gauss-Newton on the base's point map by central
differences) is its oracle (``_core = None``).
"""

from __future__ import annotations

import numpy as np

from ._validation import fail, numbers, positive
from .textures import Texture, checked_texture

MAX_STEPS = 200
"""Newton steps of one tick's descent at most (chosen; a tick's probe moves a few µm)."""
STEP_FRACTION = 1 / 16
"""Longest descent step, as a fraction of the texture's shortest period (chosen: keeps the
descent in the basin it starts in, the god-object's locality)."""


class GodObject:
    """A god-object on a texture's boundary z = h(x) (a profile) or h(x, y) (a surface).

    Parameters
    ----------
    texture : Texture
        A profile or a surface (heights in m).
    stiffness : float
        κ0 (N/m) of the spring between the proxy and the probe.
    base : haptex.objects.Base, optional
        A base the surface texture displaces along its normal (a cylinder, a sphere, a
        mesh); default the plane z = 0. Positions are then [x, y, z] (m).

    Raises
    ------
    ParameterError
        For a texture that is not a :class:`~haptex.textures.Texture`, a stiffness that is
        not a finite positive number, or a base with a profile or a texture it does not take.
    """

    def __init__(self, texture: Texture, stiffness: float, base=None):
        if not isinstance(texture, Texture):
            raise fail("texture", texture, "a haptex texture (a profile or a surface)")
        self.texture = texture
        self.stiffness = positive("stiffness", stiffness, "N/m")
        self.dimension = texture.dimension + 1
        self.base = base
        if base is not None:
            from .objects import Base

            if not isinstance(base, Base) or texture.dimension != 2:
                raise fail("base", base, "a base of haptex.objects, with a surface texture (u1, u2)")
            base.check_texture(texture)
        self._max_step = STEP_FRACTION * float(texture.shortest_period)
        self._core = None
        if self.in_core:  # the C core's tick
            from .core import WORKSPACE_LIMIT, _ext

            code, prm, kind, coeffs, aux, core_base = (self.kernel_spec() + (None,)) if base is None \
                else self.object_spec()
            self._core = _ext.Renderer(code, prm, kind, coeffs, aux, self.dimension, np.inf, WORKSPACE_LIMIT, False,
                                       False, 0.0, 0, 0.0, lambda p: (0.0,) * self.dimension, 0, core_base)
        self.reset()

    @property
    def in_core(self) -> bool:
        """Its tick is the C core's (over the plane and every base)."""
        return True

    letter = "proxy"
    name = "god-object (proxy)"
    surfaces = True
    penetration_kind = "distance"

    def kernel_spec(self):
        """What the C core's tick reads (as :meth:`haptex.Algorithm.kernel_spec`): the code
        ``ALG_PROXY``, the parameters (κ0 in ``P_K0``, the longest descent step in ``P_DXMAX``),
        the texture's kernel data, no auxiliary data.

        Returns
        -------
        tuple
            (code, prm, kind, coeffs, aux) as :meth:`haptex.Algorithm.kernel_spec` returns
            them.

        Raises
        ------
        ParameterError
            Over a base (:meth:`object_spec`).
        """
        if self.base is not None:
            raise fail("base", self.base, "None for the plane's proxy tick (over a base: object_spec)")
        return self._spec()

    def _spec(self):
        from .core import _ext

        prm = np.full(_ext.N_PARAMS, -1.0)
        prm[_ext.P_K0], prm[_ext.P_DXMAX] = self.stiffness, self._max_step
        kind, coeffs = self.texture.kernel_data()
        return (_ext.ALG_PROXY, prm, kind, np.require(coeffs, np.float64, ["C"]), np.zeros(1))

    def object_spec(self, max_evaluations=None):
        """Over a base (``max_evaluations``: unused, the descent is bounded by its steps): the
        arrays of :meth:`kernel_spec` and the base's (:meth:`haptex.objects.Base.core_spec`), as
        :meth:`haptex.objects.ObjectAlgorithm.object_spec`.
        The C core's proxy over a base descends by Gauss-Newton on the surface's Jacobian (in
        closed form, or through a mesh's UV map; this class's Python descent, by central
        differences, is its oracle).

        Parameters
        ----------
        max_evaluations : int, optional
            Unused (the descent is bounded by its steps); the argument of
            :meth:`haptex.objects.ObjectAlgorithm.object_spec`.

        Returns
        -------
        tuple
            The arrays of :meth:`kernel_spec` and the base's :class:`haptex.core._ext.Base`.

        Raises
        ------
        ParameterError
            Without a base.
        """
        if self.base is None:
            raise fail("base", self.base, "a base of haptex.objects for the C core's proxy over an object")
        return self._spec() + (self.base.core_spec(),)

    def reset(self) -> None:
        """Out of contact, no history."""
        self._u = None
        self._free = None
        if self._core is not None:
            self._core.reset()

    @property
    def surface_coordinates(self) -> np.ndarray | None:
        """The proxy's surface coordinates u (m), shape (d - 1,): x over a profile, (x, y) over a
        surface, (u1, u2) on a base; None out of contact."""
        if self._core is not None:
            u = self._core.adhesion
            return None if u is None else np.array(u[:self.dimension - 1], dtype=float)
        return None if self._u is None else np.array(self._u, dtype=float)

    @property
    def proxy(self) -> np.ndarray | None:
        """The proxy's position on the boundary (m), shape (d,), or None out of contact."""
        u = self.surface_coordinates
        if u is None:
            return None
        return self._surface(u)

    def _h(self, u) -> float:
        return float(self.texture.height_at(np.asarray(u, dtype=float)[None, :])[0])

    def _surface(self, u) -> np.ndarray:
        """S(u): the textured boundary's point at surface coordinates u (m)."""
        return self._surfaces(np.asarray(u, dtype=float)[None, :])[0]

    def _surfaces(self, U) -> np.ndarray:
        """S at the surface coordinates U (k, 2) (m), one evaluation of the texture and the base:
        shape (k, 3)."""
        h = self.texture.height_at(U)
        if self.base is None:
            return np.column_stack([U, h])
        return self.base.point(U, h)

    def _foot(self, p):
        """(u, inside) of the probe: its surface coordinates and whether it is inside."""
        if self.base is None:
            return p[:-1].copy(), p[-1] < self._h(p[:-1])
        u, _, _, e, _, _ = self.base.local(p[None, :])
        return u[0], e[0] < self._h(u[0])

    def _descend_object(self, u, p) -> np.ndarray:
        """The local minimum of ‖S(u) - p‖^2 over a curved base reached from u: Gauss-Newton
        on S's Jacobian by central differences (1e-7 of the shortest period), backtracked."""
        eps = 1e-7 * float(self.texture.shortest_period)
        r = self._surface(u) - p
        phi = float(r @ r)
        for _ in range(MAX_STEPS):
            S = self._surfaces(u + eps * np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]))
            J = np.column_stack([(S[0] - S[1]) / (2 * eps), (S[2] - S[3]) / (2 * eps)])
            s = -np.linalg.lstsq(J, r, rcond=None)[0]
            n = float(np.linalg.norm(s))
            if n > self._max_step:
                s *= self._max_step / n
            for _ in range(40):
                v = u + s
                rv = self._surface(v) - p
                if float(rv @ rv) <= phi:
                    break
                s = 0.5 * s
            else:
                return u
            u, r, phi = v, rv, float(rv @ rv)
            if float(np.linalg.norm(s)) <= 1e-15 + 1e-12 * float(np.linalg.norm(u)):
                return u
        return u

    def step(self, p) -> np.ndarray:
        """One tick: the force (N), shape (d,), at the probe position ``p`` (m), shape (d,).

        Parameters
        ----------
        p : array_like, shape (d,)
            The probe's position (m).

        Returns
        -------
        numpy.ndarray, shape (d,)
            The force (N).

        Raises
        ------
        ParameterError
            For a position of another shape or not finite.
        """
        p = numbers("p", p, f"{self.dimension} finite coordinates (m)", copy=False).reshape(-1)
        if p.shape != (self.dimension,) or not np.all(np.isfinite(p)):
            raise fail("p", p.tolist(), f"{self.dimension} finite coordinates (m)")
        if self._core is not None:  # the C core's tick
            f = self._core.tick(float(p[0]), float(p[1]) if self.dimension == 3 else 0.0, float(p[-1]))
            return np.array([f[0], f[1], f[2]] if self.dimension == 3 else [f[0], f[2]])
        foot, inside = self._foot(p)
        if not inside:  # outside the boundary at its own foot: free
            self._u, self._free = None, foot
            return np.zeros(self.dimension)
        start = self._u if self._u is not None else (self._free if self._free is not None else foot)
        self._u = self._descend_object(np.array(start, dtype=float), p)
        return self.stiffness * (self.proxy - p)


def loop_work(texture: Texture, stiffness: float, path, step: float | None = None, start_outside: bool = True,
              base=None) -> dict:
    """The work the god-object's force does on the hand along a closed path (J): the trapezoid
    sum of f · dp over the path sampled every ``step``, from a fresh proxy.

    Parameters
    ----------
    texture : Texture
    stiffness : float
        κ0 (N/m).
    path : array_like, shape (n, d)
        Vertices (m) of a closed polyline (the first is appended at the end); the proxy's
        history is what the path gives it, from its first vertex.
    step : float, optional
        Sample spacing along the path (m); default 1/400 of the texture's shortest period.
    start_outside : bool, optional
        Require the first vertex outside the boundary (default): the proxy's history then
        starts with no contact, as a hand's does.
    base : haptex.objects.Base, optional
        The textured object's base (see :class:`GodObject`); default the plane.

    Returns
    -------
    dict
        ``work`` (J; negative: the environment absorbed energy), ``samples``, and
        ``away_from_closest``: the longest distance between the proxy and the closest point
        of the boundary over the path (m; 0 where the proxy is D's point; None over a curved
        base, where D is not written yet).

    Raises
    ------
    ParameterError
        For a path of another dimension, fewer than 3 vertices, a start inside the wall, or a
        step that is not positive.
    """
    texture = checked_texture(texture)
    g = GodObject(texture, stiffness, base)
    v = numbers("path", path, f"at least 3 finite vertices of {g.dimension} coordinates (m)", copy=False)
    if v.ndim != 2 or v.shape[1] != g.dimension or len(v) < 3 or not np.all(np.isfinite(v)):
        raise fail("path", np.shape(v), f"at least 3 finite vertices of {g.dimension} coordinates (m)")
    if start_outside and g._foot(v[0])[1]:
        raise fail("path", v[0].tolist(), "a first vertex outside the boundary (start_outside)")
    h = float(step) if step is not None else float(texture.shortest_period) / 400
    if not h > 0:
        raise fail("step", step, "a positive length (m)")
    v = np.vstack([v, v[:1]])
    pts = [v[0]]
    for a, b in zip(v[:-1], v[1:]):
        n = max(1, int(np.ceil(np.linalg.norm(b - a) / h)))
        pts.extend(a + (b - a) * (np.arange(1, n + 1) / n)[:, None])
    pts = np.array(pts)
    f = np.array([g.step(q) for q in pts])
    work = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(pts, axis=0)))
    if base is not None:
        return {"work": work, "samples": len(pts), "away_from_closest": None}
    from .closest import closest_point

    inside = f.any(axis=1)
    gap = 0.0
    if inside.any():
        cp = closest_point(texture, pts[inside])
        foot = np.column_stack([cp.x] + ([cp.y] if g.dimension == 3 else []) + [cp.z])
        proxy = pts[inside] + f[inside] / stiffness
        gap = float(np.max(np.linalg.norm(proxy - foot, axis=1)))
    return {"work": work, "samples": len(pts), "away_from_closest": gap}
