"""Textures on objects: a base surface (plane, cylinder, sphere) displaced along its normal by
a texture's height, and the algorithms A, B, C and G over it (issue 32, first step).

A base gives every probe position p three local coordinates: the surface coordinates
u = (u1, u2) of its foot on the base, in metres, and its signed offset e along the base's
outward normal (m; e < 0 inside the base). The textured object is the set where

    pen(p) = h(u(p)) - e(p) > 0,

h the texture's height (m) at u: the texture displaces the base along its normal, in physical
units. Its zero level set is the textured surface, and -grad pen / |grad pen| is that surface's
unit normal (the normal of the level set through p), so the paper's letters carry over with
no approximation of the base:

* A (force normal to the nominal surface, eq. 6): f = kappa_0 pen n, n = grad e the base's
  normal;
* B (force normal to the groove, eq. 11): f = kappa_0 pen nu, nu = -grad pen / |grad pen|;
* C (change of height, eq. 13-14): f = -grad U, U = kappa_0 pen^2 / 2 (a gradient on any base:
  its loop work vanishes on every closed path);
* G (force shading, eq. 28): f = -kappa_0 e nu for e < 0 (penetration of the nominal surface).

With ``max_penetration`` (d^z_max, Remark 3) B, C and G clamp their scale s (pen, or -e for G)
at d^z_max in the texture's part of the force only: writing grad pen = a - n, a = Ju^T s the
texture's part, f = kappa_0 (s n - min(s, d^z_max) a), divided by |grad pen| for B and G; on the
plane a is the lateral part [s_x, s_y, 0], so this is the paper's clamp of the lateral force
exactly. C is then no longer a gradient.

On the plane (u = (x, y), e = z) these are the library's A, B, C and G exactly. Each base sits
with its top at the origin, outward normal +z there and u = 0 at the top, so a textured sphere
or cylinder of radius R tends to the textured plane near the origin as R grows.

Jacobians are analytic, by the chain rule through u and e: with s = grad_u h and H its
Hessian, grad pen = Ju^T s - n and hess pen = Ju^T H Ju + sum_k s_k hess u_k - hess e (Ju the
2 x 3 Jacobian of u); d nu / dp = -(I - nu nu^T) hess pen / |grad pen|.

A triangle mesh (:class:`Mesh`, read by trimesh) is a base whose coordinates are the closest
point's (flat facets, the normal turning around edges and vertices), or, given vertex normals,
those of the prisms swept along them (continuous across edges).

The C core's servo tick (:class:`haptex.Renderer`) takes A, B, C, F and G on every base
(hx_object.c): the same coordinates in closed form, on a faceted mesh the exact closest point
through a bounding-volume hierarchy built once, on the prism mesh the Newton solve in the prism
from there (the analysis path here queries the same
hierarchy, :class:`Mesh`). F is the base as a flat wall, kappa_0 |e| n inside (e < 0), with the
presliding friction of eq. 22-24 in the surface coordinates u (the local tangent plane to first
order), its force J_u^T f_u; it has memory: its force and Jacobian are given at a deflection and
phase (stick, slip; eq. 23 and 26 through the surface coordinates), its loop work with the state
stepped by the C tick (:meth:`ObjectAlgorithm.path_work`), and the region analyses take every
letter (:data:`OBJECT_LETTERS`).
D and E on a plane, cylinder or sphere take the closest point of the textured object S(u) = P(u,
h(u)): Gauss-Newton from the probe's foot and the last closest point, then a branch and bound
over the surface coordinates that can hold a nearer point (a band the base's geometry bounds),
cells pruned by a second-order lower bound of |S(u) - p|^2 (the texture's rigorous slope and
curvature bounds, the base's radius) or by its Taylor bound about the cell's centre (the exact
gradient and Hessian there, the third derivatives bounded through the texture's jerk bound),
cells of the plane search's leaf size polished by Gauss-Newton and Newton; never farther than an
exhaustive grid (tested), equal in distance to the plane's certified search on Plane().
:meth:`ObjectAlgorithm.force` runs the same C search. Their Jacobians come from the
closest-point projection's derivative T (I + r K)^-1 T^T at the closest point c (r the distance,
T a basis of the tangent plane, K = T^T hess pen T / |grad pen| the shape operator of the level
set pen = 0, which holds the base's curvature with the texture's): D's kappa_0 (dc/dp - I),
symmetric (D is -grad kappa_0 r^2 / 2 on any base, eq. 16), unbounded towards a centre of
curvature (:meth:`ObjectAlgorithm.focal_points`); E's kappa_0 (n (p - c)^T / r + r hess e). On
Plane() both are the plane's exactly (tested).

The reference models of CHAI3D (on meshes) and HAPI (on the plane and on these bases) are
:mod:`haptex.reference`.

D and E on a mesh with vertex normals (the prism base, continuous across its triangles) take
the closest point of S(u) = sum_k lam_k(u) (v_k + h(u) N_k) on the triangle whose UV triangle
holds u: Gauss-Newton through the UV map from the foot and the last closest point, then every
prism the hierarchy's boxes (inflated by max |h|) leave within reach, each by a branch and bound
over its UV triangle cut in four (a cell pruned by the distance to its flat triangle less max
|h|, then by the second-order bound from the triangle's own constants, then by the Taylor bound
about the cell's centre with its exact Hessian), leaves polished by Gauss-Newton and Newton; never
farther than a dense grid of S (tested). A faceted mesh's textured surface is not a patch over u
(its wedges at the edges and corners): D and E are refused there.

Not yet here (issue 32's later steps): a C^1 mesh base. (:func:`haptex.simulate`,
:func:`haptex.simulate_batch` and ``haptex sweep`` run objects; ``haptex export`` writes the
renderer's tick; ``haptex explore`` shows spheres, cylinders and uploaded meshes with q on their
surface.)
"""

from __future__ import annotations

import math

import numpy as np

from ._units import parse_quantity
from ._validation import ParameterError, fail, numbers, positions, positive
from .algorithms import ALGORITHMS, Algorithm, algorithm
from .core import _ext, in_slices
from .surfaces import Extruded, SumOfGratings, Surface
from .textures import Texture, checked_texture

__all__ = ["Base", "Plane", "Cylinder", "Sphere", "Mesh", "ObjectAlgorithm", "object_algorithm", "OBJECT_LETTERS",
           "OBJECT_DESIGN_LETTERS", "OBJECT_TICK_LETTERS"]

OBJECT_LETTERS = ("A", "B", "C", "D", "E", "F", "G")
"""The letters on objects with their fields' analyses (q, continuity, loop work); D and E on a
plane, cylinder, sphere or prism mesh; F at a deflection and phase, its loop work with its state
stepped."""

OBJECT_DESIGN_LETTERS = ("A", "B", "C", "F", "G")
"""The letters ``haptex design`` analyses on an object by default and ``haptex explore`` takes
there: D and E are left out (chosen; ``design --algorithms D,E`` asks for them) because their
every field value is a closest-point search over the object, 0.1-0.3 ms a point in the C core,
which makes a design's continuity grids take about 10 s a letter."""

OBJECT_TICK_LETTERS = ("A", "B", "C", "D", "E", "F", "G")
"""The letters the C core renders on objects: F (with memory) too, its static field given its
deflection (:meth:`ObjectAlgorithm.force`), and D and E (the closest point of the textured
object) on a plane, cylinder, sphere or prism mesh (a mesh with vertex normals)."""

MAX_RADIUS = 1e3
"""Largest base radius accepted (m): 1 km, the library's workspace scale."""


def _atan2_derivs(a, ga, ha, b, gb, hb):
    """atan2(a, b), its gradient (..., 3) and Hessian (..., 3, 3) from those of a and b (None
    for the Hessian when ha is None: the forces need none)."""
    r2 = a * a + b * b
    g = (b[..., None] * ga - a[..., None] * gb) / r2[..., None]
    if ha is None:
        return np.arctan2(a, b), g, None
    num_h = (gb[..., :, None] * ga[..., None, :] - ga[..., :, None] * gb[..., None, :]
             + b[..., None, None] * ha - a[..., None, None] * hb)
    # d/dp of (b ga - a gb) is gb ga^T + b ha - ga gb^T - a hb (rows: the component, columns: d/dp_j)
    num_h = np.swapaxes(num_h, -1, -2)
    dr2 = 2.0 * (a[..., None] * ga + b[..., None] * gb)
    h = num_h / r2[..., None, None] - g[..., :, None] * dr2[..., None, :] / r2[..., None, None]
    return np.arctan2(a, b), g, h


class Base:
    """A base surface: local coordinates (u, e) of probe positions and their derivatives.

    Subclasses give :meth:`local`; :meth:`point` is its inverse (the probe at surface
    coordinates u and offset e).
    """

    name = "base"
    radius = math.inf

    def local(self, p, hessian: bool = True):
        """Local coordinates of probes ``p`` (..., 3) (m).

        With ``hessian`` False the analytic bases give None for Hu and He (the forces need
        only u, Ju, e and n; a mesh gives them all the same).

        Parameters
        ----------
        p : array_like, shape (..., 3)
            Probe positions (m).
        hessian : bool, optional
            Also Hu and He (None from the analytic bases when False).

        Returns
        -------
        u : ndarray, shape (..., 2)
            Surface coordinates of the foot on the base (m).
        Ju : ndarray, shape (..., 2, 3)
            du / dp (m/m).
        Hu : ndarray, shape (..., 2, 3, 3)
            Hessians of u1 and u2 (1/m).
        e : ndarray, shape (...)
            Signed offset along the outward normal (m), < 0 inside the base.
        n : ndarray, shape (..., 3)
            grad e: the base's outward unit normal at the foot.
        He : ndarray, shape (..., 3, 3)
            Hessian of e (1/m).
        """
        raise NotImplementedError

    def point(self, u, e):
        """The probe position (..., 3) (m) at surface coordinates ``u`` (..., 2) and offset
        ``e`` (...) (m).

        Parameters
        ----------
        u : array_like, shape (..., 2)
            Surface coordinates (m).
        e : array_like, shape (...)
            Offset along the base's outward normal (m).

        Returns
        -------
        numpy.ndarray, shape (..., 3)
            Probe positions (m).
        """
        raise NotImplementedError

    def check_texture(self, texture: Surface) -> None:
        """Raise ParameterError where the texture does not fit on the base (see subclasses).

        Parameters
        ----------
        texture : Surface
            The texture to lay on the base.
        """

    def surface_range(self, texture: Surface):
        """The surface coordinates ((u1_0, u1_1), (u2_0, u2_1)) (m) over which the analyses lay
        the texture's cell on this base, or None where it is the texture's own cell (every
        surface coordinate lies on the base: the analytic bases; see :class:`Mesh`).

        Parameters
        ----------
        texture : Surface
            The texture laid on the base.

        Returns
        -------
        list of (float, float) or None
        """
        return None

    def kinks(self, a, b, u, pts) -> list:
        """Parameters t in (0, 1) where the segment a -> b (sampled at parameters u, points
        pts) crosses from one smooth piece of the base's coordinates to another: none on the
        analytic bases.

        Parameters
        ----------
        a : array_like, shape (3,)
            The segment's start (m).
        b : array_like, shape (3,)
            Its end (m).
        u : ndarray, shape (k,)
            The parameters in [0, 1] at which it was sampled.
        pts : ndarray, shape (k, 3)
            The samples a + u (b - a) (m).

        Returns
        -------
        list of float
            Parameters t in (0, 1), ascending; empty on the analytic bases.
        """
        return []

    core_kind = -1
    """The base's kind in the C core (``haptex.core._ext.BASE_*``); -1: none."""

    def core_arrays(self):
        """The base's arrays for the C core: (kind, radius (m), tri, face, prism), tri and face
        empty and prism False but for a mesh (:meth:`Mesh.core_arrays`); ``haptex export``
        writes them as tables.

        Returns
        -------
        tuple
            (kind (int), radius (m), tri (F, 9) (m), face (F, FACE), prism (bool)).

        Raises
        ------
        ParameterError
            For a base the C core does not evaluate.
        """
        if self.core_kind < 0:
            raise fail("base", self, "a base the C core evaluates: Plane(), Cylinder(R), Sphere(R) or a Mesh")
        return (self.core_kind, 0.0 if math.isinf(self.radius) else float(self.radius), np.zeros((0, 9)),
                np.zeros((0, _ext.FACE)), False)

    def core_spec(self):
        """The base in the C core (a ``haptex.core._ext.Base``: a mesh's arrays copied and its
        bounding-volume hierarchy built once, then shared by every renderer and simulation of
        it), from :meth:`core_arrays`.

        Returns
        -------
        haptex.core._ext.Base
            The base in the C core, shared by every tick over it.

        Raises
        ------
        ParameterError
            As :meth:`core_arrays`.
        """
        core = self.__dict__.get("_core_base")
        if core is None:
            core = self.__dict__["_core_base"] = _ext.Base(*self.core_arrays())
        return core

    def __getstate__(self):
        """Pickled without the C core's copy (rebuilt where it is next needed)."""
        return {k: v for k, v in self.__dict__.items() if k != "_core_base"}

    def __repr__(self) -> str:
        return f"{type(self).__name__}()" if math.isinf(self.radius) else f"{type(self).__name__}({self.radius:g})"


class Plane(Base):
    """The plane z = 0: u = (x, y), e = z (today's textured wall, exactly)."""

    name = "plane"
    core_kind = _ext.BASE_PLANE

    def local(self, p, hessian: bool = True):
        shape = p.shape[:-1]
        Ju = np.zeros((*shape, 2, 3))
        Ju[..., 0, 0] = Ju[..., 1, 1] = 1.0
        n = np.zeros((*shape, 3))
        n[..., 2] = 1.0
        if not hessian:
            return p[..., :2].copy(), Ju, None, p[..., 2].copy(), n, None
        return p[..., :2].copy(), Ju, np.zeros((*shape, 2, 3, 3)), p[..., 2].copy(), n, np.zeros((*shape, 3, 3))

    def point(self, u, e):
        u = np.asarray(u, dtype=float)
        e = np.broadcast_to(np.asarray(e, dtype=float), u.shape[:-1])
        return np.concatenate([u, e[..., None]], axis=-1)


SEAM_TOLERANCE = 1e-6
"""A closed base's circumference may differ from a whole number of the texture's periods along
u1 by this fraction of a period: the seam then shifts the texture by at most that much (a radius
typed to 9 significant digits passes)."""


def _closed_period_check(base, texture: Surface, length: float) -> None:
    """The texture must be periodic along u1 with a period that divides the base's closed
    length to SEAM_TOLERANCE of a period (no seam): else a ParameterError naming the radius and
    the nearest that fits."""
    cell = texture.cell
    if cell is None:
        raise ParameterError(f"texture = {texture!r} is not allowed on {base!r}: a closed base needs a texture "
                             f"periodic along u1 (its {length:.6g} m circumference would leave a seam); close a "
                             "measured one into a periodic texture (--periodic at the command line, periodic=True in "
                             "Python)")
    period = float(cell[0])
    kind = type(base).__name__.lower()

    def typed(radius):  # (as --object takes it)
        return f"--object {kind}:{radius * 1e3:.12g}mm at the command line"

    if period > length * (1 + 1e-12):
        fit = period / (2 * math.pi)
        raise ParameterError(f"texture = {texture!r} is not allowed on {base!r}: its period along u1, "
                             f"{period:.6g} m, is longer than the base's circumference {length:.6g} m; a radius of "
                             f"{fit:.12g} m holds one period ({typed(fit)})")
    turns = length / period
    if abs(turns - round(turns)) > SEAM_TOLERANCE:
        fit = round(turns) * period / (2 * math.pi)
        raise fail("radius", base.radius, f"a radius whose circumference holds a whole number of the texture's "
                   f"{period:.6g} m periods along u1 (no seam), e.g. {fit:.12g} m ({typed(fit)})")


class _Round(Base):
    """A base of radius R (m) closed along u1 (cylinder, sphere): the radius checked, and the
    texture's period along u1 checked against the circumference 2 pi R.

    Raises
    ------
    ParameterError
        If the radius is not in (0, MAX_RADIUS] m.
    """

    def __init__(self, radius: float):
        self.radius = positive("radius", radius, "m")
        if self.radius > MAX_RADIUS:
            raise fail("radius", radius, f"at most {MAX_RADIUS:g} m")

    def check_texture(self, texture: Surface) -> None:
        """The texture's period along u1 must divide the circumference 2 pi R (to
        SEAM_TOLERANCE of a period)."""
        _closed_period_check(self, texture, 2 * math.pi * self.radius)

    def _around(self, p, where, hessian: bool = True):
        """x, y, z about the axis through (0, 0, -R) parallel to y; rho = hypot(x, z); the
        angle phi = atan2(x, z) round that axis with its gradient and Hessian (None without
        ``hessian``). Raises ParameterError on the axis (``where`` names it)."""
        x, y, z = p[..., 0], p[..., 1], p[..., 2] + self.radius
        rho = np.hypot(x, z)
        if np.any(rho == 0.0):
            raise ParameterError(f"p is not allowed on {where}")
        # phi = atan2(x, z): grad (z, 0, -x) / rho^2; Hessian -2xz, 2xz (xx, zz) and x^2 - z^2 (xz) / rho^4
        shape = p.shape[:-1]
        r2 = rho * rho
        g = np.zeros((*shape, 3))
        g[..., 0], g[..., 2] = z / r2, -x / r2
        h = None
        if hessian:
            h = np.zeros((*shape, 3, 3))
            r4 = r2 * r2
            h[..., 0, 0] = -2.0 * x * z / r4
            h[..., 2, 2] = -h[..., 0, 0]
            h[..., 0, 2] = h[..., 2, 0] = (x * x - z * z) / r4
        return x, y, z, rho, np.arctan2(x, z), g, h


class Cylinder(_Round):
    """A circular cylinder of radius R (m) whose axis is parallel to y through (0, 0, -R):
    u1 = R phi (arc length around the axis, phi = atan2(x, z + R), 0 at the top), u2 = y,
    e = rho - R (rho the distance from the axis). Developable: u is arc length on the base,
    so the texture keeps its periods there. The radius and the texture are checked as
    :class:`_Round` says.

    Parameters
    ----------
    radius : float
        R (m), > 0.
    """

    name = "cylinder"
    core_kind = _ext.BASE_CYLINDER

    def local(self, p, hessian: bool = True):
        R = self.radius
        shape = p.shape[:-1]
        x, y, z, rho, phi, gphi, hphi = self._around(p, "the cylinder's axis (its normal is undefined there)",
                                                     hessian)
        n = np.zeros((*shape, 3))
        n[..., 0], n[..., 2] = x / rho, z / rho
        u = np.stack([R * phi, y], axis=-1)
        Ju = np.zeros((*shape, 2, 3))
        Ju[..., 0, :] = R * gphi
        Ju[..., 1, 1] = 1.0
        if not hessian:
            return u, Ju, None, rho - R, n, None
        pxz = np.zeros((*shape, 3, 3))
        pxz[..., 0, 0] = pxz[..., 2, 2] = 1.0
        He = (pxz - n[..., :, None] * n[..., None, :]) / rho[..., None, None]
        Hu = np.zeros((*shape, 2, 3, 3))
        Hu[..., 0, :, :] = R * hphi
        return u, Ju, Hu, rho - R, n, He

    def point(self, u, e):
        u = np.asarray(u, dtype=float)
        e = np.asarray(e, dtype=float)
        phi = u[..., 0] / self.radius
        rho = self.radius + e
        return np.stack(np.broadcast_arrays(rho * np.sin(phi), u[..., 1], rho * np.cos(phi) - self.radius), axis=-1)



class Sphere(_Round):
    """A sphere of radius R (m) centred at (0, 0, -R), in equirectangular coordinates about the
    great circle y = 0: u1 = R phi (phi = atan2(x, z + R), the longitude, 0 at the top),
    u2 = R lambda (lambda the latitude from that circle), e = r - R. u is arc length along that
    great circle and along the meridians; along u1 a texture is stretched by 1 / cos(lambda)
    off it (a sphere has no isometric chart), by under 0.5 % within 0.1 R of the top. The
    radius and the texture (its period along the equator) are checked as :class:`_Round` says.

    Parameters
    ----------
    radius : float
        R (m), > 0.
    """

    name = "sphere"
    core_kind = _ext.BASE_SPHERE

    def local(self, p, hessian: bool = True):
        R = self.radius
        shape = p.shape[:-1]
        x, y, z, rho, phi, gphi, hphi = self._around(p, "the sphere's axis through its poles (y axis): the "
                                                        "equirectangular coordinates are singular there", hessian)
        r = np.sqrt(rho * rho + y * y)
        ey = np.broadcast_to(np.eye(3)[1], (*shape, 3))
        m = np.zeros((*shape, 3))  # grad rho
        m[..., 0], m[..., 2] = x / rho, z / rho
        n = np.stack([x, y, z], axis=-1) / r[..., None]
        if not hessian:
            lam, glam, _ = _atan2_derivs(y, ey, None, rho, m, None)
            return (np.stack([R * phi, R * lam], axis=-1), np.stack([R * gphi, R * glam], axis=-2), None, r - R, n,
                    None)
        eye = np.broadcast_to(np.eye(3), (*shape, 3, 3))
        zero = np.zeros((*shape, 3, 3))
        pxz = eye.copy()
        pxz[..., 1, 1] = 0.0
        hrho = (pxz - m[..., :, None] * m[..., None, :]) / rho[..., None, None]
        lam, glam, hlam = _atan2_derivs(y, ey, zero, rho, m, hrho)
        He = (eye - n[..., :, None] * n[..., None, :]) / r[..., None, None]
        u = np.stack([R * phi, R * lam], axis=-1)
        Ju = np.stack([R * gphi, R * glam], axis=-2)
        Hu = np.stack([R * hphi, R * hlam], axis=-3)
        return u, Ju, Hu, r - R, n, He

    def point(self, u, e):
        u = np.asarray(u, dtype=float)
        e = np.asarray(e, dtype=float)
        phi, lam = u[..., 0] / self.radius, u[..., 1] / self.radius
        r = self.radius + e
        return np.stack(np.broadcast_arrays(r * np.cos(lam) * np.sin(phi), r * np.sin(lam),
                                            r * np.cos(lam) * np.cos(phi) - self.radius), axis=-1)



MAX_TRIANGLES = 2_000_000
"""Largest mesh accepted (triangles)."""

LOCAL_CACHE_MIN = 10_000
LOCAL_CACHE_BYTES = 256 * 2**20
"""A mesh keeps its local coordinates of point sets of at least LOCAL_CACHE_MIN points, the
latest up to LOCAL_CACHE_BYTES: the analyses of A, B, C and G lay the same grids."""


def _box_projection(mesh):
    """(the mesh with each triangle's vertices its own, their UV map (3F, 2) (m)) by box
    projection: a triangle's coordinates on the plane across its normal's largest axis k, the
    axes k + 1 and k + 2 (mod 3), the first negated where the normal points to -k; each of the six
    (axis, side) charts moved along u1 to lie apart from the others by the mesh's largest extent."""
    import trimesh

    tri = np.asarray(mesh.vertices, dtype=float)[np.asarray(mesh.faces)]  # (F, 3, 3)
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    rows = np.arange(len(tri))
    axis = np.argmax(np.abs(n), axis=1)
    sign = np.where(n[rows, axis] >= 0, 1.0, -1.0)
    u1 = sign[:, None] * tri[rows[:, None], np.arange(3)[None, :], ((axis + 1) % 3)[:, None]]  # (F, 3)
    u2 = tri[rows[:, None], np.arange(3)[None, :], ((axis + 2) % 3)[:, None]]
    chart = 2 * axis + (sign < 0)
    gap = float(np.max(np.ptp(tri.reshape(-1, 3), axis=0)))
    for c in np.unique(chart):
        u1[chart == c] += c * 3 * gap - u1[chart == c].min()
    out = trimesh.Trimesh(tri.reshape(-1, 3), np.arange(3 * len(tri)).reshape(-1, 3), process=False)
    return out, np.stack([u1, u2], -1).reshape(-1, 2)


CHART_SQUARE_POINTS = 17
"""Points a side at which a square of surface coordinates is checked to lie in a mesh's UV map
(:meth:`Mesh.surface_range`; chosen: a chart's gap narrower than a 16th of the texture's cell
may pass between them)."""

CHART_CANDIDATES = 2048
"""How many of a mesh's UV triangles (the largest first) centre the squares tried for the
texture's cell (:meth:`Mesh.surface_range`; chosen)."""


class Mesh(Base):
    """A closed triangle mesh (read with trimesh) with a UV map in metres; its closest points
    come from the C core's bounding-volume hierarchy (exact; :class:`haptex.Renderer` ticks
    through the same search).

    The base's coordinates are those of the closest point on the mesh: e is the signed
    distance to it (positive outside, the sign by the angle-weighted pseudo-normal of the
    closest feature, Baerentzen & Aanaes 2005), n its gradient, and u the UV map (per vertex,
    linear on each triangle) at the closest point. Where that point is inside a triangle, n
    is the triangle's normal and u is affine in p; on an edge or at a vertex n turns around
    it (a cylinder or a sphere of radius |e|) and u follows the edge or stays at the vertex.
    So a texture on a mesh feels the mesh's facets: the analysis measures it.

    Parameters
    ----------
    mesh : trimesh.Trimesh or str or pathlib.Path
        The mesh, or a file trimesh reads (OBJ, STL, PLY, glTF, ...).
    uv : array_like, shape (n_vertices, 2), or "box", optional
        Surface coordinates of the vertices (m). Default: the file's texture coordinates
        times ``uv_scale``. ``"box"``: a box projection for a mesh without them (a CAD part's
        STL): each triangle's coordinates on the plane across its normal's largest axis (the
        other two axes in cyclic order, the first mirrored on the faces turned to the axis's
        negative side, so that the texture reads unmirrored from outside), in metres; the six
        sides' charts laid apart, the triangles' vertices split between them. The texture's
        heights jump across the edges where a face's largest axis changes (its seams).
    uv_scale : float, optional
        Metres per unit of the file's texture coordinates (required with them).
    unit : float or str, optional
        Metres per unit of the mesh's vertex coordinates, or the unit itself ("mm" for a CAD
        part's STL, which states none): default 1, the coordinates read as metres (glTF's own
        unit; OBJ, STL and PLY state none). ``--mesh-unit`` at the command line.
    normals : None, "vertex" or array_like of shape (n_vertices, 3), optional
        None (default): the closest point's coordinates above. ``"vertex"`` (trimesh's
        vertex normals, on the vertices merged across UV seams) or given unit normals: a
        smooth base instead, each triangle swept along its vertices' normals into a prism
        (p = sum_k b_k (v_k + e N_k), b the barycentric coordinates, e the offset; Phong's
        interpolation of normals made a coordinate system, as in shell maps, Porumbescu et
        al. 2005): u = sum_k b_k uv_k and e are then continuous across the edges (no pen / |e|
        growth of q beside them), but their gradients jump across the prisms' faces, so the
        forces jump there by amounts first order in the facet size.

    Raises
    ------
    ParameterError
        If ``mesh`` is neither a trimesh.Trimesh nor a path (a str or os.PathLike, PEP 519),
        the file is not a mesh trimesh reads or would take more than the memory budget; if
        the mesh is not closed or not manifold (an edge not shared by exactly two triangles:
        the first such triangle is named), has a degenerate triangle (named), more than
        MAX_TRIANGLES triangles, or no UV map; or if ``uv`` has the wrong shape or a non-finite
        value, or is given with ``uv_scale`` (which scales the file's coordinates only).
    """

    name = "mesh"
    core_kind = _ext.BASE_MESH

    def __init__(self, mesh, uv=None, uv_scale: float | None = None, normals=None, unit=1.0):
        import trimesh

        if not isinstance(mesh, trimesh.Trimesh):
            from ._validation import a_path, check_budget

            path = a_path("mesh", mesh, "a trimesh.Trimesh or a mesh file's path")
            if path.is_file():  # (a text mesh's arrays take about 20 x its bytes, with the queries')
                check_budget("mesh", str(mesh), 20.0 * path.stat().st_size, "reading this mesh")
            try:
                mesh = trimesh.load(str(mesh), force="mesh", process=False)
            except Exception as exc:  # (trimesh raises many kinds on a bad file)
                raise fail("mesh", str(mesh), f"a mesh file trimesh reads ({type(exc).__name__}: {exc})") from None
        factor = unit
        if isinstance(unit, str):
            try:
                factor = parse_quantity(f"1 {unit.strip()}", "m", "unit") if unit.strip()[:1].isalpha() else None
            except ParameterError:
                factor = None
            if factor is None:
                raise fail("unit", unit, "the unit of the mesh's coordinates, a length such as 'mm', 'um', 'in' or "
                           "'m' (--mesh-unit at the command line), or metres per unit as a number in Python")
        factor = positive("unit", factor, "m per unit of the mesh's coordinates")
        if factor != 1.0:  # (the file's coordinates in another unit: its vertices in metres)
            mesh = mesh.copy()
            mesh.apply_scale(factor)
        faces = np.asarray(mesh.faces)
        if not 1 <= len(faces) <= MAX_TRIANGLES:
            raise fail("mesh", f"{len(faces)} triangles", f"1 to {MAX_TRIANGLES} triangles")
        if uv is not None and uv_scale is not None:
            raise fail("uv_scale", uv_scale, "None where uv is given (its coordinates are in metres already)")
        if isinstance(uv, str):
            if uv != "box":
                raise fail("uv", uv, "'box' (a box projection) or the vertices' coordinates, n_vertices x 2 (m)")
            mesh, uv = _box_projection(mesh)
            faces = np.asarray(mesh.faces)
        if uv is None:
            file_uv = getattr(mesh.visual, "uv", None)
            if file_uv is None:
                raise fail("uv", None, "a UV map: the mesh has no texture coordinates (a box projection, --box-uv "
                           "at the command line, uv='box' in Python; or unwrap it in a modelling tool, Blender's Smart "
                           "UV Project for one, and export it as OBJ, PLY or glTF with them)")
            if uv_scale is None:
                raise fail("uv_scale", None, "metres per unit of the mesh's texture coordinates")
            uv = np.asarray(file_uv, dtype=float) * positive("uv_scale", uv_scale, "m")
        self._uv_scale = None if uv_scale is None else float(uv_scale)  # (a refusal's remedy names it)
        uv = numbers("uv", uv, f"surface coordinates (m), shape ({len(mesh.vertices)}, 2)", copy=False)
        if uv.shape != (len(mesh.vertices), 2) or not np.all(np.isfinite(uv)):
            raise fail("uv", f"shape {uv.shape}", f"finite surface coordinates (m), shape ({len(mesh.vertices)}, 2)")
        # closed and manifold on the positions (vertices split at UV seams are merged for this)
        merged = trimesh.Trimesh(mesh.vertices, faces, process=False)
        merged.merge_vertices(merge_tex=True, merge_norm=True)
        edges = np.sort(merged.faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1)
        _, inverse, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
        bad = np.flatnonzero(counts[inverse.ravel()] != 2)
        if bad.size:
            raise fail("mesh", f"triangle {bad[0] // 3}", "a closed manifold mesh: every edge shared by exactly two "
                       f"triangles ({bad.size} edge sides are not, the first on triangle {bad[0] // 3})")
        tri = np.asarray(mesh.vertices, dtype=float)[faces]
        cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
        area2 = np.linalg.norm(cross, axis=1)
        scale = np.max(np.ptp(np.asarray(mesh.vertices), axis=0))
        degenerate = np.flatnonzero(~(area2 > 1e-12 * scale * scale))
        if degenerate.size:
            raise fail("mesh", f"triangle {degenerate[0]}", "triangles of non-zero area (a degenerate one has its "
                       "normal undefined)")
        self.mesh = mesh
        self.uv = uv
        self._tri = tri
        # closest points by the C core's bounding-volume hierarchy (the core's Base, built when
        # first needed), exact: trimesh's query is not (its absolute tolerances returned edge points
        # 66 um away on a 1 cm sphere, and on a unit-scaled copy of an 81,920-triangle sphere still
        # a farther triangle for 5 probes in 600, 37 nm farther); the renderer's tick runs the same search
        self._normals = cross / area2[:, None]
        if np.sum(area2 * np.einsum("ij,ij->i", self._normals, tri[:, 0])) < 0:  # (6 x volume < 0: inward)
            self._normals = -self._normals
        # UV's gradient on each triangle's plane: M (v_k - v_0) = uv_k - uv_0, M n = 0
        d = np.stack([tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0], self._normals], axis=-1)  # (F, 3, 3)
        duv = np.stack([uv[faces[:, 1]] - uv[faces[:, 0]], uv[faces[:, 2]] - uv[faces[:, 0]],
                        np.zeros((len(faces), 2))], axis=-1)  # (F, 2, 3)
        self._M = duv @ np.linalg.inv(d)
        self._faces = faces
        self._pseudo = self._pseudo_normals(merged)
        # each edge's two triangles (every edge has two: checked above), by side of a triangle
        inverse = inverse.ravel()
        order = np.argsort(inverse, kind="stable")
        self._edge_faces = (order // 3).reshape(-1, 2)
        self._side_edge = inverse.reshape(-1, 3)
        self._vn = None
        if normals is not None:
            if isinstance(normals, str):
                if normals != "vertex":
                    raise fail("normals", normals, "'vertex' or an array of vertex normals")
                vn = np.asarray(merged.vertex_normals, dtype=float)[self._vmap]  # (F, 3, 3): merged across seams
                if np.sum(np.einsum("fkj,fj->fk", vn, self._normals) > 0) < vn.shape[0] * 1.5:
                    vn = -vn  # (trimesh's follow the winding: oriented outward like the triangles')
            else:
                arr = numbers("normals", normals, "'vertex' or an array of vertex normals", copy=False)
                if arr.shape != (len(mesh.vertices), 3) or not np.all(np.isfinite(arr)) or np.any(
                        np.linalg.norm(arr, axis=1) == 0.0):
                    raise fail("normals", f"shape {arr.shape}", f"'vertex' or finite non-zero normals, shape "
                               f"({len(mesh.vertices)}, 3)")
                vn = arr[faces]
            vn = vn / np.linalg.norm(vn, axis=-1, keepdims=True)
            if np.any(np.einsum("fkj,fj->fk", vn, self._normals) <= 0.0):
                bad = int(np.flatnonzero(np.any(np.einsum("fkj,fj->fk", vn, self._normals) <= 0.0, axis=1))[0])
                raise fail("normals", f"triangle {bad}", "outward vertex normals within 90 degrees of each of "
                           "their triangles' normals (a prism swept along them must not fold)")
            self._vn = vn
        self.radius = math.inf

    def _pseudo_normals(self, merged):
        """Angle-weighted normals of the merged vertices (for the sign of e where the closest
        point is a vertex; an edge's is the sum of its two triangles' normals); sets _vmap, the
        triangles' merged vertex ids."""
        tri = self._tri
        ang = np.empty((len(tri), 3))
        for k in range(3):
            a, b = tri[:, (k + 1) % 3] - tri[:, k], tri[:, (k + 2) % 3] - tri[:, k]
            ang[:, k] = np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))
        vn = np.zeros((len(merged.vertices), 3))
        for k in range(3):
            np.add.at(vn, merged.faces[:, k], ang[:, k, None] * self._normals)
        self._vmap = merged.faces
        return vn

    def __repr__(self) -> str:
        ext = np.ptp(self._tri.reshape(-1, 3), axis=0) * 1e3
        return f"Mesh({len(self._faces)} triangles, {ext[0]:.4g} x {ext[1]:.4g} x {ext[2]:.4g} mm)"

    def core_arrays(self):
        """The mesh's arrays for the C core: (kind, 0, tri, face, prism), tri (F, 9) the
        corners (m), face (F, ``haptex.core._ext.FACE``) each triangle's constants (its normal,
        its UV map's gradient M, its corners' UV, its sides' and corners' pseudo-normals, its
        corners' unit normals, the triangle across each side: ``HX_FACE_*`` in hx_core.h), and
        prism: the prism base swept along the vertex normals (else the closest point's). The
        core builds the bounding-volume hierarchy (:meth:`core_spec`).

        Returns
        -------
        tuple
            (kind (int), 0.0, tri (F, 9) (m), face (F, FACE), prism (bool)).

        Raises
        ------
        ParameterError
            For a mesh whose arrays would exceed the memory budget.
        """
        return self._arrays()

    def _arrays(self):
        from ._validation import check_budget

        F = len(self._faces)
        check_budget("mesh", f"{F} triangles", F * (2 * (9 + _ext.FACE) + 16) * 8.0, "the renderer's copy of it")
        face = np.empty((F, _ext.FACE))
        face[:, _ext.FACE_N:_ext.FACE_N + 3] = self._normals
        face[:, _ext.FACE_M:_ext.FACE_M + 6] = self._M.reshape(F, 6)
        face[:, _ext.FACE_UV:_ext.FACE_UV + 6] = self.uv[self._faces].reshape(F, 6)
        for side in range(3):  # side k joins corners k and k + 1: its two triangles' normals summed
            pair = self._edge_faces[self._side_edge[:, side]]
            at = _ext.FACE_EDGE + 3 * side
            face[:, at:at + 3] = self._normals[pair[:, 0]] + self._normals[pair[:, 1]]
        face[:, _ext.FACE_VERTEX:_ext.FACE_VERTEX + 9] = self._pseudo[self._vmap].reshape(F, 9)
        vn = self._vn if self._vn is not None else np.repeat(self._normals[:, None, :], 3, axis=1)
        face[:, _ext.FACE_VN:_ext.FACE_VN + 9] = vn.reshape(F, 9)
        for side in range(3):  # the triangle across each side
            pair = self._edge_faces[self._side_edge[:, side]]
            face[:, _ext.FACE_NEXT + side] = np.where(pair[:, 0] == np.arange(F), pair[:, 1], pair[:, 0])
        return (self.core_kind, 0.0, np.ascontiguousarray(self._tri.reshape(F, 9)), face, self._vn is not None)

    def _closest(self, flat):
        """(foot, dist, triangle, barycentric) of the closest points of flat (N, 3) (m): exact,
        by the C core's hierarchy (hx_mesh_closest), on the analysis's threads."""
        tree = self.__dict__.get("_core_base")
        if tree is None:  # (the prism mesh too: its solve starts from the closest point)
            tree = self.__dict__["_core_base"] = _ext.Base(*self._arrays())
        n = len(flat)
        flat = np.ascontiguousarray(flat, dtype=np.float64)
        tid, bary, d2 = np.zeros(n, dtype=np.int64), np.zeros((n, 3)), np.zeros(n)
        in_slices(lambda a, b: tree.closest(flat[a:b], tid[a:b], bary[a:b], d2[a:b]), n)
        foot = np.einsum("nk,nkj->nj", bary, self._tri[tid])
        return foot, np.sqrt(d2), tid, bary

    def _feature(self, flat):
        """Which smooth piece each point's coordinates are on: its closest triangle, and which of
        the triangle's corners carry weight (all three: inside it; two: an edge; one: a vertex)."""
        if self._vn is not None:  # (the prism holding the point: the map is smooth inside one)
            return self._solve_prism(flat)[0]
        _, dist, tid, bary = self._closest(flat)
        mask = (bary > 1e-9) @ np.array([1, 2, 4])
        return tid * 8 + np.where(dist == 0.0, 7, mask)

    def kinks(self, a, b, u, pts) -> list:
        """Parameters where the segment a -> b passes from one triangle's (face, edge or vertex)
        region to another's, where the base's normal turns (a jump of the force between two
        facets' regions, a kink between a facet and its edge's): the samples' pieces compared,
        each change bisected to round-off (60 halvings, all together).

        Parameters
        ----------
        a : array_like, shape (3,)
            The segment's start (m).
        b : array_like, shape (3,)
            Its end (m).
        u : ndarray, shape (k,)
            The parameters in [0, 1] at which it was sampled.
        pts : ndarray, shape (k, 3)
            The samples a + u (b - a) (m).

        Returns
        -------
        list of float
            Parameters t in (0, 1), ascending.
        """
        key = self._feature(np.asarray(pts, dtype=float))
        idx = np.flatnonzero(key[:-1] != key[1:])
        lo, hi = u[idx].astype(float), u[idx + 1].astype(float)
        k_lo = key[idx]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            live = (lo < mid) & (mid < hi)
            if not live.any():
                break
            same = self._feature(a + mid[:, None] * (b - a)) == k_lo
            lo = np.where(live & same, mid, lo)
            hi = np.where(live & ~same, mid, hi)
        return (0.5 * (lo + hi)).tolist()

    def local(self, p, hessian: bool = True):
        shape = p.shape[:-1]
        flat = p.reshape(-1, 3)
        key = None
        if flat.shape[0] >= LOCAL_CACHE_MIN:  # the analyses evaluate A, B, C, G on the same grids
            import hashlib

            key = hashlib.blake2b(flat.tobytes(), digest_size=16).digest()
            hit = self.__dict__.setdefault("_local_cache", {}).get(key)
            if hit is not None:
                return tuple(v.copy().reshape(*shape, *v.shape[1:]) for v in hit)
        out = self._local(flat)
        if key is not None and sum(v.nbytes for v in out) <= LOCAL_CACHE_BYTES:
            cache = self.__dict__["_local_cache"]
            while cache and sum(v.nbytes for vs in cache.values() for v in vs) > LOCAL_CACHE_BYTES // 2:
                cache.pop(next(iter(cache)))
            cache[key] = tuple(v.copy() for v in out)
        return tuple(v.reshape(*shape, *v.shape[1:]) for v in out)

    def _local(self, flat):
        if self._vn is not None:
            return self._local_smooth(flat)[:6]
        foot, dist, tid, bary = self._closest(flat)
        tri = self._tri[tid]
        tol = 1e-9
        nf = self._normals[tid]
        uvf = self.uv[self._faces[tid]]  # (N, 3, 2)
        u = np.einsum("nk,nkj->nj", bary, uvf)
        w = flat - foot
        n_out = np.zeros_like(flat)
        Ju = np.zeros((len(flat), 2, 3))
        He = np.zeros((len(flat), 3, 3))
        e = np.einsum("ij,ij->i", w, nf)
        face = np.all(bary > tol, axis=1) | (dist == 0.0)
        n_out[face] = nf[face]
        Ju[face] = self._M[tid[face]]
        rest = np.flatnonzero(~face)
        if rest.size:  # on an edge (two corners carry weight) or at a vertex (one)
            ti, wr, dr = tid[rest], w[rest], dist[rest]
            weight = bary[rest] > tol
            on_edge = weight.sum(axis=1) >= 2
            first = np.argmax(weight, axis=1)  # the edge's corners first < second
            second = np.where((first == 0) & weight[:, 1], 1, 2)
            side = np.where(second == first + 1, first, 2)  # sides (0, 1), (1, 2), (2, 0)
            pair = self._edge_faces[self._side_edge[ti, side]]  # the edge's two triangles
            edge_normal = self._normals[pair[:, 0]] + self._normals[pair[:, 1]]
            corner = np.argmax(bary[rest], axis=1)
            vertex_normal = self._pseudo[self._vmap[ti, corner]]
            pseudo = np.where(on_edge[:, None], edge_normal, vertex_normal)
            sign = np.where(np.einsum("ij,ij->i", wr, pseudo) >= 0, 1.0, -1.0)
            va, vb = tri[rest, first], tri[rest, second]
            dv = vb - va
            dd = np.einsum("ij,ij->i", dv, dv)
            dhat = dv / np.sqrt(dd)[:, None]
            perp = np.eye(3) - np.where(on_edge[:, None, None], dhat[:, :, None] * dhat[:, None, :], 0.0)
            duv = uvf[rest, second] - uvf[rest, first]
            Ju[rest] = np.where(on_edge[:, None, None], duv[:, :, None] * dv[:, None, :] / dd[:, None, None], 0.0)
            ww = wr / dr[:, None]
            e[rest] = sign * dr
            n_out[rest] = sign[:, None] * ww
            He[rest] = sign[:, None, None] * (perp - ww[:, :, None] * ww[:, None, :]) / dr[:, None, None]
        return u, Ju, np.zeros((len(flat), 2, 3, 3)), e, n_out, He

    def _prism(self, tid, b, e):
        """The prism map's pieces on triangles tid (N,) at barycentric b (N, 3) and offset e (N,):
        A = dp / d(b1, b2, e) (N, 3, 3) and the derivatives of its columns (N, 3)."""
        v, vn = self._tri[tid], self._vn[tid]
        dn1, dn2 = vn[:, 1] - vn[:, 0], vn[:, 2] - vn[:, 0]
        c1 = v[:, 1] - v[:, 0] + e[:, None] * dn1
        c2 = v[:, 2] - v[:, 0] + e[:, None] * dn2
        c3 = vn[:, 0] + b[:, 1, None] * dn1 + b[:, 2, None] * dn2
        return np.stack([c1, c2, c3], axis=-1), dn1, dn2

    def _solve_prism(self, flat):
        """(triangle, b, e) with p = sum_k b_k (v_k + e N_k), b in the triangle: Newton on
        (b1, b2, e) from the closest point's, walking to the neighbour across the edge whose
        barycentric coordinate goes most negative (at most 32 walks)."""
        _, dist, tid, bary = self._closest(flat)
        e = np.einsum("ij,ij->i", flat - np.einsum("nk,nkj->nj", bary, self._tri[tid]), self._normals[tid])
        b = bary.copy()
        act = np.arange(len(flat))  # the points still solving (walked to another triangle)
        for _ in range(32):
            ta, ba, ea, pa = tid[act], b[act], e[act], flat[act]
            for _ in range(8):
                pos = np.einsum("nk,nkj->nj", ba, self._tri[ta] + ea[:, None, None] * self._vn[ta])
                A, _, _ = self._prism(ta, ba, ea)
                step = np.linalg.solve(A, (pa - pos)[..., None])[..., 0]
                ba[:, 1] += step[:, 0]
                ba[:, 2] += step[:, 1]
                ba[:, 0] = 1.0 - ba[:, 1] - ba[:, 2]
                ea = ea + step[:, 2]
            b[act], e[act] = ba, ea
            worst = np.argmin(ba, axis=1)
            out = ba[np.arange(len(ba)), worst] < -1e-12
            if not out.any():
                break
            side = (worst[out] + 1) % 3  # the side opposite corner k joins corners k+1, k+2
            moved = act[out]
            pair = self._edge_faces[self._side_edge[tid[moved], side]]
            tid[moved] = np.where(pair[:, 0] == tid[moved], pair[:, 1], pair[:, 0])
            b[moved] = 1.0 / 3.0  # from the new triangle's centre, at the same offset
            act = moved
        return tid, b, e

    def _local_smooth(self, flat):
        tid, b, e = self._solve_prism(flat)
        A, dn1, dn2 = self._prism(tid, b, e)
        G = np.linalg.inv(A)  # rows: grad b1, grad b2, grad e
        uvf = self.uv[self._faces[tid]]
        duv = np.stack([uvf[:, 1] - uvf[:, 0], uvf[:, 2] - uvf[:, 0]], axis=-1)  # (N, 2, 2): du / d(b1, b2)
        u = np.einsum("nk,nkj->nj", b, uvf)
        Ju = duv @ G[:, :2, :]
        # dA / dp_j = dA/de ge_j + dA/db1 gb1_j + dA/db2 gb2_j; d G / dp_j = -G (dA/dp_j) G
        zero = np.zeros_like(dn1)
        dA_de = np.stack([dn1, dn2, zero], axis=-1)
        dA_db1 = np.stack([zero, zero, dn1], axis=-1)
        dA_db2 = np.stack([zero, zero, dn2], axis=-1)
        dA = (dA_de[:, None] * G[:, 2, :, None, None] + dA_db1[:, None] * G[:, 0, :, None, None]
              + dA_db2[:, None] * G[:, 1, :, None, None])  # (N, j, 3, 3)
        dG = -np.einsum("nab,njbc,ncd->njad", G, dA, G)  # (N, j, row, col)
        H = np.swapaxes(dG, 1, 2)  # (N, row, j, col): Hessian of unknown row
        Hu = np.einsum("nka,najc->nkjc", duv, H[:, :2])
        return u, Ju, Hu, e, G[:, 2, :], H[:, 2], tid

    def check_texture(self, texture: Surface) -> None:
        """The texture's heights must stay under half the mesh's smallest extent: past it the
        surface displaced along the normal passes through the object (a mesh read in another
        unit than its file's: a CAD part's STL in millimetres read as metres is 1,000 times too
        large, one in metres read as millimetres 1,000 times too small).

        Parameters
        ----------
        texture : Surface
            The texture to lay on the mesh.
        """
        lo, hi = texture.height_range
        reach = max(abs(float(lo)), abs(float(hi)))
        half = 0.5 * float(np.min(np.ptp(self._tri.reshape(-1, 3), axis=0)))
        if not reach < half:
            raise fail("texture", f"heights up to {reach * 1e3:.3g} mm on {self!r}", f"heights under half the "
                       f"mesh's smallest extent ({half * 1e3:.3g} mm): the mesh's coordinates in their own unit "
                       "(--mesh-unit mm at the command line, unit='mm' in Python, for a file in millimetres), or a "
                       "lower texture")

    def _uv_locate(self, flat):
        """(found (n,), triangles (n,), barycentric (n, 2)) of surface coordinates flat (n, 2)
        (m): the triangle whose UV triangle holds each, among the 32 whose centres are nearest."""
        from scipy.spatial import cKDTree

        if "_uv_tree" not in self.__dict__:
            self._uvf = self.uv[self._faces]  # (F, 3, 2)
            self._uv_tree = cKDTree(self._uvf.mean(axis=1))
        uvf = self._uvf
        k = min(32, len(self._faces))
        _, cand = self._uv_tree.query(flat, k=k)
        cand = np.asarray(cand).reshape(len(flat), k)
        found = np.zeros(len(flat), dtype=bool)
        face = np.zeros(len(flat), dtype=np.int64)
        bary = np.zeros((len(flat), 2))
        for c in range(k):
            if found.all():
                break
            f = cand[:, c]
            a, b, cc = uvf[f, 0], uvf[f, 1], uvf[f, 2]
            m = np.stack([b - a, cc - a], axis=-1)  # (N, 2, 2)
            det = np.linalg.det(m)
            ok = (~found) & (np.abs(det) > 0)
            lam = np.zeros((len(flat), 2))
            lam[ok] = np.linalg.solve(m[ok], (flat[ok] - a[ok])[..., None])[..., 0]
            inside = ok & (lam[:, 0] >= -1e-12) & (lam[:, 1] >= -1e-12) & (lam.sum(axis=1) <= 1 + 1e-12)
            face[inside], bary[inside] = f[inside], lam[inside]
            found |= inside
        return found, face, bary

    def _square_fits(self, origins, size, k=CHART_SQUARE_POINTS) -> np.ndarray:
        """Which squares [o, o + size] (origins (c, 2), size (2,), m) lie in the UV map, on a
        k x k grid of their points (c,) bool."""
        out = np.zeros(len(origins), dtype=bool)
        for g in (np.linspace(0.0, 1.0, 3), np.linspace(0.0, 1.0, k)):  # (its corners first: most fail there)
            live = np.flatnonzero(out) if g.size > 3 else np.arange(len(origins))
            if live.size == 0:
                break
            grid = np.stack(np.meshgrid(g, g, indexing="ij"), -1).reshape(-1, 2) * size  # (g^2, 2)
            pts = origins[live, None, :] + grid[None]
            out[live] = self._uv_locate(pts.reshape(-1, 2))[0].reshape(len(live), -1).all(axis=1)
        return out

    def _chart_square(self, size):
        """The origin (2,) (m) of a square of ``size`` (2,) (m) inside the UV map, centred on one
        of its triangles' centres, the largest triangles' first (CHART_CANDIDATES of them); None
        where none holds it."""
        uvf = self.uv[self._faces]
        e1, e2 = uvf[:, 1] - uvf[:, 0], uvf[:, 2] - uvf[:, 0]
        area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
        order = np.argsort(-area, kind="stable")[:CHART_CANDIDATES]
        origins = uvf[order].mean(axis=1) - 0.5 * np.asarray(size)
        for lo in range(0, len(origins), 256):
            fits = self._square_fits(origins[lo:lo + 256], np.asarray(size))
            if fits.any():
                return origins[lo + int(np.argmax(fits))]
        return None

    def surface_range(self, texture: Surface):
        """Where the analyses lay the texture's cell on this mesh: its own cell where the UV map
        holds it (a map that covers its square, a sphere's), else a square of the cell's size
        inside one chart of the UV map (a modelled object's atlas, its charts apart), centred
        on one of its triangles' centres.

        Parameters
        ----------
        texture : Surface
            The texture laid on the mesh (with a cell: an aperiodic one's region is given).

        Returns
        -------
        list of (float, float) or None
            ((u1_0, u1_1), (u2_0, u2_1)) (m), or None (the texture's own cell).

        Raises
        ------
        ParameterError
            Where no chart holds one cell: naming the UV scale at which one would (the largest
            square a chart holds, found by bisection on its size).
        """
        dom = getattr(texture, "domain", None)
        if dom is None or texture.dimension != 2:
            return None
        (a, b), (c, d) = ((float(lo), float(hi)) for lo, hi in dom)
        size = np.array([b - a, d - c])
        if self._square_fits(np.array([[a, c]]), size)[0]:
            return None
        found = self._chart_square(size)
        if found is not None:
            return [(float(found[0]), float(found[0] + size[0])), (float(found[1]), float(found[1] + size[1]))]
        lo, hi = 0.0, 1.0  # (the fraction of the cell a chart holds: lo fits, hi does not)
        for _ in range(12):
            mid = 0.5 * (lo + hi) if lo > 0 else hi / 4
            if self._chart_square(size * mid) is not None:
                lo = mid
            else:
                hi = mid
            if lo > 0 and hi - lo < 0.02 * lo:
                break
        cell = f"{size[0] * 1e3:.3g} x {size[1] * 1e3:.3g} mm"
        if lo == 0:
            raise fail("mesh", "its UV map", f"charts that hold the texture's cell ({cell}), or a square of "
                       f"{hi:.2g} of its size at least")
        if self._uv_scale is None:
            raise fail("uv", "its charts", f"a UV map one of whose charts holds the texture's cell ({cell}): this "
                       f"one's hold {lo:.3g} of it; scale it by {1 / lo:.3g} or more")
        need = math.ceil(self._uv_scale / lo * 1e4) / 1e4  # (m, rounded up to 0.1 mm)
        raise fail("uv_scale", f"{self._uv_scale * 1e3:g} mm", f"one at which a chart of the mesh's UV map holds the "
                   f"texture's cell ({cell}; at this one the largest holds {lo:.3g} of it): --uv-scale "
                   f"{need * 1e3:g}mm at the command line, uv_scale={need:g} in Python, or more")

    def point(self, u, e):
        """The probe at surface coordinates u and offset e: the point of the triangle whose UV
        triangle holds u, moved e along that triangle's normal (with vertex normals: along the
        normal interpolated there, sum_k b_k (v_k + e N_k)).

        Parameters
        ----------
        u : array_like, shape (..., 2)
            Surface coordinates (m, the UV map's times ``uv_scale``).
        e : array_like, shape (...)
            Offset along the normal (m).

        Returns
        -------
        numpy.ndarray, shape (..., 3)
            Probe positions (m).

        Raises
        ------
        ParameterError
            Where no triangle's UV triangle holds u.
        """
        u = np.asarray(u, dtype=float)
        e = np.broadcast_to(np.asarray(e, dtype=float), u.shape[:-1])
        flat = u.reshape(-1, 2)
        found, f, lam = self._uv_locate(flat)
        out = np.full((len(flat), 3), np.nan)
        t = self._tri[f[found]]
        ef = e.reshape(-1)[found]
        if self._vn is not None:
            t = t + ef[:, None, None] * self._vn[f[found]]
            out[found] = t[:, 0] + lam[found, :1] * (t[:, 1] - t[:, 0]) + lam[found, 1:] * (t[:, 2] - t[:, 0])
        else:
            out[found] = (t[:, 0] + lam[found, :1] * (t[:, 1] - t[:, 0]) + lam[found, 1:] * (t[:, 2] - t[:, 0])
                          + ef[:, None] * self._normals[f[found]])
        if not np.all(found):
            bad = flat[np.flatnonzero(~found)[0]]
            raise fail("u", bad.tolist(), "surface coordinates inside the mesh's UV map")
        return out.reshape(*u.shape[:-1], 3)


def _tangents(nu):
    """An orthonormal basis (..., 3, 2) of the plane orthogonal to unit vectors nu (..., 3): the
    coordinate axis least aligned with nu made orthogonal to it, and nu x that."""
    axis = np.eye(3)[np.argmin(np.abs(nu), axis=-1)]
    t1 = axis - np.sum(axis * nu, axis=-1)[..., None] * nu
    t1 /= np.linalg.norm(t1, axis=-1)[..., None]
    return np.stack([t1, np.cross(nu, t1)], axis=-1)


class ObjectAlgorithm(Algorithm):
    """One of A-G over a textured object (see the module's docstring for the fields; D and E on
    a plane, cylinder, sphere or prism mesh).

    Probe positions are [x, y, z] (m); forces (N) and Jacobians (N/m) are in that frame.
    ``texture`` is the height h(u) (a surface over u; a profile is extruded along u2).
    The region analyses take it like a plane algorithm: :func:`haptex.characteristic_number`
    lays its grid in (u, depth) over one texture cell and maps it onto the object by
    :meth:`region_points`; :func:`haptex.continuity` its grids and
    :func:`haptex.conservativity` its random polygons' vertices in (u1, u2, e), mapped by
    :meth:`to_cartesian` (a polygon's sides are straight in space).
    :func:`haptex.analysis.work.loop_energy` takes any closed path on or inside the object.
    D's and E's region is laid by the closest point and the distance to it (the depth along the
    textured surface's inward normal at S(u)); q of D is ``inf`` when a centre of curvature lies
    within the depth analysed.

    Parameters
    ----------
    letter : str
        A, B, C, D, E, F or G (:data:`OBJECT_TICK_LETTERS`).
    texture : Texture
        The height h(u) (m): a surface over u, or a profile (extruded along u2).
    base : Base
        :class:`Plane`, :class:`Cylinder`, :class:`Sphere` or :class:`Mesh`.
    stiffness : float
        kappa_0 (N/m).
    **params
        The letter's own parameters, as :func:`haptex.algorithm` takes them (``max_penetration``
        for B, C, F, G; ``friction``, ``presliding``, ... for F).
    """

    surfaces = True
    penetration_kind = "vertical"

    def __init__(self, letter: str, texture: Texture, base: Base, stiffness: float, **params):
        texture = checked_texture(texture)
        if letter not in OBJECT_TICK_LETTERS:
            raise fail("letter", letter, f"one of {', '.join(OBJECT_TICK_LETTERS)} on an object so far (D, E and "
                       "the proxy algorithm over objects are not written yet)")
        if params and not getattr(ALGORITHMS.get(letter), "parameters", ()):  # (the registry)
            takers = "; ".join(f"{L} takes {', '.join(c.parameters)}" for L, c in ALGORITHMS.items()
                               if c.textured and c.parameters)
            raise fail("params", sorted(params), f"none for {letter} on an object ({takers})")
        if not isinstance(base, Base):
            raise fail("base", base, "a haptex.objects base: Plane(), Cylinder(R), Sphere(R) or Mesh(...)")
        if letter in "DE" and isinstance(base, Mesh) and base._vn is None:
            raise fail("base", base, f"a plane, cylinder, sphere or a mesh with vertex normals for {letter} (the "
                       "closest point of a textured faceted mesh is not written: give Mesh(..., normals='vertex'))")
        if letter in "DE" and texture.dimension == 1:  # a Fourier profile as gratings along u1 (the surface search)
            from .textures import SumOfSinusoids

            if not isinstance(texture, SumOfSinusoids):
                raise fail("texture", texture, f"a surface, or a Fourier profile, for {letter} on an object (its "
                           "closest-point search is the surface's)")
            texture = SumOfGratings(texture.amplitudes, texture.periods, np.zeros_like(texture.amplitudes),
                                    texture.phases)
        if texture.dimension == 1:
            texture = Extruded(texture)
        if letter in "DE" and getattr(texture, "_gradients", None) is not None:
            raise fail("texture", texture, f"a spline height map or a sum of gratings for {letter} on an object (a "
                       "Hermite map, a felt map's, is joined only continuously across its patch lines, which the "
                       "object's closest-point bounds do not allow: felt_by applies on the plane)")
        base.check_texture(texture)
        plane = algorithm(letter, texture, stiffness, **params)
        super().__init__(texture, stiffness, getattr(plane, "max_penetration", None))
        self.letter = letter
        self.base = base
        self.name = plane.name
        self.reference = plane.reference + "; on a base: haptex.objects"
        self.penetration_kind = plane.penetration_kind
        self.is_gradient = letter == "D" or (letter == "C" and self.max_penetration is None)
        # (D and E keep the last closest point in the tick, a warm start only: their fields are memoryless)
        self.has_memory = letter == "F"
        self._plane = plane
        self._params = dict(params)
        if letter == "F":  # (the analyses read F's parameters off the algorithm, as on the plane)
            self.friction, self.presliding = plane.friction, plane.presliding
            self.modulation_depth, self.stick_deflection = plane.modulation_depth, plane.stick_deflection
            self.modulation_max_slope = plane.modulation_max_slope  # (1/m, over u)

    def __repr__(self) -> str:
        extra = "".join(f", {k}={v!r}" for k, v in sorted(self._params.items()))
        return (f"object_algorithm({self.letter!r}, {self.texture!r}, {self.base!r}, stiffness={self.stiffness:g}"
                f"{extra})")

    @property
    def dimension(self) -> int:
        """3: probe positions and forces are [x, y, z]."""
        return 3

    def _positions(self, p) -> np.ndarray:
        return positions(p, dim=3)

    @property
    def surface_range(self):
        """Where the analyses lay the texture's cell on the base: ((u1_0, u1_1), (u2_0, u2_1))
        (m), or None for the texture's own cell (:meth:`Base.surface_range`; on a mesh whose UV
        atlas holds no cell at its origin, a square inside a chart). Found when an analysis
        first asks (rendering, export and a servo loop need none: a texture renders over small
        charts too).

        Raises
        ------
        ParameterError
            Where no chart of a mesh's UV map holds one cell (:meth:`Mesh.surface_range`).
        """
        if "_surface_range" not in self.__dict__:
            self.__dict__["_surface_range"] = self.base.surface_range(self.texture)
        return self.__dict__["_surface_range"]

    def region_points(self, ut, depth):
        """Probe positions (..., 3) (m) at surface coordinates ``ut`` (..., 2) and penetration
        ``depth`` (...) (m), measured as the algorithm measures it: below the textured surface
        along the base's normal (A, B, C) or below the base (G).

        Parameters
        ----------
        ut : array_like, shape (..., 2)
            Surface coordinates (m).
        depth : array_like, shape (...)
            Penetration (m), >= 0.

        Returns
        -------
        numpy.ndarray, shape (..., 3)
            Probe positions (m).
        """
        ut = np.asarray(ut, dtype=float)
        depth = np.asarray(depth, dtype=float)
        if self.penetration_kind == "distance":  # D, E: along the textured surface's inward normal at S(u)
            S = self.base.point(ut, self.texture.height_at(ut))
            g = self._level_set(S, False)[1]
            return S + (depth / np.linalg.norm(g, axis=-1))[..., None] * g
        e = (self.texture.height_at(ut) - depth) if self.penetration_kind == "vertical" else -depth
        return self.base.point(ut, e)

    def focal_points(self, ut):
        """D's focal points below the textured surface: where its Jacobian is unbounded.

        At S(u) the closest-point projection's derivative is T (I + r K)^-1 T^T (see
        :meth:`jacobian`), K the level set's shape operator; it is singular at the distance
        rho = 1 / |kappa| below a point whose principal curvature kappa < 0 (convex up, a peak
        of the texture or the base's own convexity), the centre of curvature.

        Parameters
        ----------
        ut : array_like, shape (..., 2)
            Surface coordinates (m).

        Returns
        -------
        rho : ndarray, shape (...)
            The least such distance (m); inf where the surface is nowhere convex up.
        points : ndarray, shape (..., 3)
            The centres of curvature S(u) + rho nu (m), nu the inward unit normal (NaN where
            rho is inf).
        """
        ut = np.asarray(ut, dtype=float)
        S = self.base.point(ut, self.texture.height_at(ut))
        _, g, H, *_ = self._level_set(S, True)
        gn = np.linalg.norm(g, axis=-1)
        nu = g / gn[..., None]
        T = _tangents(nu)
        kappa = np.linalg.eigvalsh(np.swapaxes(T, -1, -2) @ H @ T) / gn[..., None]
        with np.errstate(divide="ignore"):
            rho = np.where(kappa < 0, -1.0 / np.where(kappa < 0, kappa, -1.0), np.inf).min(axis=-1)
        return rho, S + np.where(np.isfinite(rho), rho, np.nan)[..., None] * nu

    def to_cartesian(self, q):
        """Probe positions (..., 3) (m) at plane coordinates ``q`` = [u1, u2, e] (..., 3) (m):
        the point at surface coordinates u and offset e along the base's normal. The region
        analyses lay their grids and random loops in these coordinates (the plane's are
        [x, y, z]) and evaluate the field at the points this gives.

        Parameters
        ----------
        q : array_like, shape (..., 3)
            Plane coordinates [u1, u2, e] (m).

        Returns
        -------
        numpy.ndarray, shape (..., 3)
            Probe positions (m).
        """
        q = np.asarray(q, dtype=float)
        return self.base.point(q[..., :2], q[..., 2])

    def signed_depth(self, p) -> np.ndarray:
        """e - h(u) (A, B, C) or e (G) (m), shape (...): negative inside, its zeros the wall's
        boundary (where the force has a kink: the loop-work quadrature splits its pieces there).

        Parameters
        ----------
        p : array_like, shape (..., 3)
            Probe positions (m).

        Returns
        -------
        numpy.ndarray, shape (...)
            The signed depth (m), negative inside.
        """
        u, _, _, e, _, _ = self.base.local(self._positions(p), False)
        return e if self.penetration_kind == "nominal" else e - self.texture.height_at(u)

    def penetration(self, p) -> np.ndarray:
        """h(u) - e (A, B, C), -e (G) or the distance to the closest point of the textured
        object (D, E) where positive, else 0 (m), shape (...).

        Parameters
        ----------
        p : array_like, shape (..., 3)
            Probe positions (m).

        Returns
        -------
        numpy.ndarray, shape (...)
            The penetration (m), >= 0.
        """
        if self.penetration_kind == "distance":
            return self.closest_points(p)[1]
        return np.maximum(-self.signed_depth(p), 0.0)

    def kinks(self, a, b, u, pts) -> list:
        """Where the segment a -> b passes between smooth pieces of the base (a mesh's facets,
        edges and vertices): breakpoints for the loop-work quadrature.

        Parameters
        ----------
        a : array_like, shape (3,)
            The segment's start (m).
        b : array_like, shape (3,)
            Its end (m).
        u : ndarray, shape (k,)
            The parameters in [0, 1] at which it was sampled.
        pts : ndarray, shape (k, 3)
            The samples a + u (b - a) (m).

        Returns
        -------
        list of float
            Parameters t in (0, 1) of the segment, ascending.
        """
        return self.base.kinks(a, b, u, pts)

    def force(self, p, deflection=0.0) -> np.ndarray:
        """The force (N), shape (..., 3), at positions p (..., 3) (m).

        For F, ``deflection`` is the presliding deflection d = u - w in the surface coordinates
        (m), broadcastable to (..., 2), |d| <= d_max (a scalar: along u1): the wall's normal
        force kappa_0 |e| n inside (e < 0) plus J_u^T f_u, f_u = -mu kappa_0 z_c (1 - h~(u)) d /
        d_max (eq. 22 in the local tangent plane; the C core's tick, which steps d, is tested
        against this). The other letters take no deflection.

        Parameters
        ----------
        p : array_like, shape (..., 3)
            Probe positions (m).
        deflection : float or array_like, shape (..., 2), optional
            F's presliding deflection d = u - w (m), |d| <= d_max; a scalar is along u1.

        Returns
        -------
        numpy.ndarray, shape (..., 3)
            The force (N).

        Raises
        ------
        ParameterError
            For malformed positions, or a deflection given to another letter or out of range.
        """
        if self.letter == "F":
            return self._friction(self._positions(p), deflection)[0]
        if not (np.isscalar(deflection) and deflection == 0.0):
            raise fail("deflection", deflection, f"none for {self.letter} (only F has a presliding deflection)")
        return self._object(self._positions(p), False)[0]

    def _friction(self, p, deflection, phase=None):
        """F's force (..., 3) at a deflection d in the surface coordinates and, with ``phase``,
        its Jacobian (..., 3, 3) (else None). With depth = -e, z_c = min(depth, d^z_max), m =
        1 - h~(u), c = -mu kappa_0 z_c m / d_max and D = dd/du (I in stick, I - v v^T in slip, v =
        d / |d|): f = kappa_0 depth n + J_u^T c d, and

            J = kappa_0 (depth hess e - n n^T) + c sum_k d_k hess u_k + J_u^T d grad c^T
                + c J_u^T D J_u,

        grad c = -mu kappa_0 (m grad z_c - z_c grad h~) / d_max, grad z_c = -n where depth <
        d^z_max (else 0), grad h~ = J_u^T grad_u h~ (eq. 23 and 26 in the local tangent plane; on
        the plane, the paper's)."""
        F = self._plane
        k = self.stiffness
        u, Ju, Hu, e, n, He = self.base.local(p, phase is not None)
        d = F._deflection(deflection, e.shape)
        inside = e < 0
        depth = -e
        zc = depth if F.max_penetration is None else np.minimum(depth, F.max_penetration)
        m = 1.0 - F._scale * self.texture.height_at(u)
        c = -F.friction * k * zc * m / F.presliding
        f = (k * depth)[..., None] * n + np.einsum("...ki,...k->...i", Ju, c[..., None] * d)
        f = np.where(inside[..., None], f, 0.0)
        if phase is None:
            return f, None
        if phase not in ("stick", "slip"):
            raise fail("phase", phase, 'one of "stick", "slip"')
        eye = np.broadcast_to(np.eye(2), d.shape + (2,))
        if phase == "stick":
            D = eye
        else:
            size = np.linalg.norm(d, axis=-1)
            v = np.divide(d, size[..., None], out=np.zeros_like(d), where=size[..., None] > 0)
            D = np.where((size > 0)[..., None, None], eye - v[..., :, None] * v[..., None, :], 0.0)
        follows = np.ones_like(inside) if F.max_penetration is None else depth < F.max_penetration
        gzc = np.where(follows[..., None], -n, 0.0)
        gmod = F._scale * np.einsum("...ki,...k->...i", Ju, self.texture.gradient(u))  # grad h~
        gc = -F.friction * k * (m[..., None] * gzc - zc[..., None] * gmod) / F.presliding
        Jud = np.einsum("...ki,...k->...i", Ju, d)
        J = (k * (depth[..., None, None] * He - n[..., :, None] * n[..., None, :])
             + c[..., None, None] * np.einsum("...k,...kij->...ij", d, Hu)
             + Jud[..., :, None] * gc[..., None, :]
             + c[..., None, None] * np.einsum("...ki,...kl,...lj->...ij", Ju, D, Ju))
        return f, np.where(inside[..., None, None], J, 0.0)

    def path_work(self, pts, steps: int = 4000) -> float:
        """F's work (J) along a polyline of shape (N, 3) (m), its friction state stepped.

        Each side is cut into ``steps`` equal sub-steps and the C core's tick gives the force
        at each point (the presliding deflection stepped by the surface coordinates' change,
        from rest where the path enters the object and reset where it leaves, as in the servo
        loop); the work sum f . dp by the trapezoidal rule (first order in the sub-step where
        the deflection turns, as :meth:`haptex.algorithms.FrictionModulated.path_work` over a
        surface).

        Parameters
        ----------
        pts : array_like, shape (N, 3)
            The polyline's vertices (m).
        steps : int, optional
            Sub-steps a side.

        Returns
        -------
        float
            The work (J) the force does on the probe along the polyline.

        Raises
        ------
        ParameterError
            For a letter other than F, or vertices that are not finite positions of shape
            (N, 3).
        """
        if self.letter != "F":
            raise fail("algorithm", self.letter, "F for a path's work with its friction state (the other letters "
                       "are fields: haptex.analysis.work.path_work)")
        pts = positions(pts, "pts", 3)
        if pts.ndim != 2:
            raise fail("pts", f"shape {pts.shape}", "(N, 3) vertices of a polyline (m)")
        us = np.linspace(0.0, 1.0, steps + 1)[1:]
        path = np.concatenate([pts[:1]] + [a + us[:, None] * (b - a) for a, b in zip(pts[:-1], pts[1:])])
        f = np.empty_like(path)
        self._core(self.letter).run(np.ascontiguousarray(path), f)
        dp = np.diff(path, axis=0)
        return float(np.sum(0.5 * (f[1:] + f[:-1]) * dp))

    def _core(self, letter: str):
        """A C core renderer of this object's tick for ``letter`` (D's, for E's closest points),
        without the renderer's safety rules (no force limit): the analysis reads the field."""
        _, prm, kind, coeffs, aux, base = self.object_spec()
        return _ext.Renderer(getattr(_ext, f"ALG_{letter}"), prm, kind, coeffs, aux, 3, np.inf, 1e3, False, False,
                             0.0, 0, 0.0, lambda q: (0.0, 0.0, 0.0), 0, base)

    def closest_points(self, p):
        """D's and E's closest point of the textured object and its distance, at positions p.

        The C core's search (hx_object.c, the renderer's tick run over the points in C:
        Gauss-Newton from the probe's foot, then a branch and bound over the surface coordinates
        that can hold a nearer point; on a prism mesh over each prism within reach), the same
        the servo tick runs.

        Parameters
        ----------
        p : array_like, shape (..., 3)
            Probe positions (m).

        Returns
        -------
        closest : ndarray, shape (..., 3)
            The closest point S(u*) of the textured object (m) where the probe is inside it
            (pen > 0 at its foot); p itself outside.
        distance : ndarray, shape (...)
            |S(u*) - p| (m) inside, 0 outside.

        Raises
        ------
        ParameterError
            For a letter other than D and E, or malformed positions.
        """
        if self.letter not in "DE":
            raise fail("algorithm", self.letter, "D or E for closest points (the other letters measure along the "
                       "base's normal)")
        p = self._positions(p)
        flat = np.ascontiguousarray(p.reshape(-1, 3), dtype=np.float64)
        f = np.empty_like(flat)  # (E's search is D's: the closest point)

        def run(lo, hi):  # (a renderer a slice, on the threads: each warm-starts from its last point)
            self._core("D").run(flat[lo:hi], f[lo:hi])

        in_slices(run, len(flat), least=64)
        f = f.reshape(p.shape)
        return p + f / self.stiffness, np.linalg.norm(f, axis=-1) / self.stiffness

    def _distance(self, p, jac: bool):
        """D's or E's force (..., 3) and, with ``jac``, Jacobian (..., 3, 3) (else None).

        D: f = kappa_0 (c - p), c the closest point at distance r; E: f = kappa_0 r n, n the
        base's normal at p. With nu the textured surface's inward unit normal at c (grad pen /
        |grad pen|), T an orthonormal basis of its tangent plane and K = T^T hess pen T /
        |grad pen| (the shape operator of the level set pen = 0), dc/dp = T (I + r K)^-1 T^T
        (the closest-point projection's derivative; on the plane it is V G^-1 V^T of
        :class:`haptex.algorithms.GodObjectGradient`): J_D = kappa_0 (dc/dp - I), and J_E =
        kappa_0 (n (p - c)^T / r + r hess e) (eq. 20-21 with the base's turning normal).
        """
        k = self.stiffness
        c, r = self.closest_points(p)
        inside = r > 0
        if self.letter == "D":
            f = k * (c - p)
        else:
            _, _, _, _, n, He = self.base.local(p)
            f = (k * r)[..., None] * n
        if not jac:
            return f, None
        J = np.zeros(p.shape + (3,))
        if not np.any(inside):
            return f, J
        pi, ci, ri = p[inside], c[inside], r[inside]
        if self.letter == "D":
            _, g, H, *_ = self._level_set(ci, True)
            gn = np.linalg.norm(g, axis=-1)
            T = _tangents(g / gn[:, None])
            A = np.eye(2) + (ri / gn)[:, None, None] * (np.swapaxes(T, -1, -2) @ H @ T)
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
                adj = np.stack([np.stack([A[:, 1, 1], -A[:, 0, 1]], -1), np.stack([-A[:, 1, 0], A[:, 0, 0]], -1)], -2)
                dc = T @ (adj / det[:, None, None]) @ np.swapaxes(T, -1, -2)
            J[inside] = k * (dc - np.eye(3))
        else:
            n, He = n[inside], He[inside]
            J[inside] = k * (n[:, :, None] * ((pi - ci) / ri[:, None])[:, None, :] + ri[:, None, None] * He)
        return f, J

    def jacobian(self, p, deflection=0.0, phase: str = "stick") -> np.ndarray:
        """The Jacobian (N/m), shape (..., 3, 3), at positions p (..., 3) (m): by the chain rule
        through u(p) and e(p) (A, B, C, G), from the closest-point projection's derivative (D,
        E; see the module's docstring), at a presliding deflection and phase (F, as
        :meth:`haptex.algorithms.FrictionModulated.jacobian`, in the surface coordinates); 0
        outside the object. D's is unbounded at a centre of curvature (:meth:`focal_points`)
        and undefined where two closest points tie.

        Parameters
        ----------
        p : array_like, shape (..., 3)
            Probe positions (m).
        deflection : float or array_like, shape (..., 2), optional
            F's presliding deflection (m).
        phase : {"stick", "slip"}, optional
            F's phase (eq. 24).

        Returns
        -------
        numpy.ndarray, shape (..., 3, 3)
            dF/dp (N/m).

        Raises
        ------
        ParameterError
            For malformed positions, a deflection out of range, a phase other than "stick" and
            "slip", or a deflection or phase given to a letter other than F.
        """
        if self.letter == "F":
            return self._friction(self._positions(p), deflection, phase)[1]
        if not (np.isscalar(deflection) and deflection == 0.0):
            raise fail("deflection", deflection, f"none for {self.letter} (only F has a presliding deflection)")
        if phase != "stick":
            raise fail("phase", phase, f"none for {self.letter} (only F has a friction phase)")
        return self._object(self._positions(p), True)[1]

    def force_and_jacobian(self, p):
        if self.letter == "F":
            raise fail("algorithm", "F", "A-E or G for a force and Jacobian without a deflection (F's: jacobian(p, "
                       "deflection, phase))")
        return self._object(self._positions(p), True)

    def _level_set(self, p, hessian: bool):
        """pen = h(u) - e at positions p (..., 3), its gradient (..., 3) and, if ``hessian``, its
        Hessian (..., 3, 3) (else None) by the chain rule through the base's u(p) and e(p);
        and the base's e and n = grad e there."""
        u, Ju, Hu, e, n, He = self.base.local(p, hessian)
        tex = self.texture
        hu, s, hess_u = tex._jet(u, hessian)
        pen = hu - e
        gpen = np.einsum("...ki,...k->...i", Ju, s) - n
        hpen = None
        if hessian:
            hpen = (np.einsum("...ki,...kl,...lj->...ij", Ju, hess_u, Ju)
                    + np.einsum("...k,...kij->...ij", s, Hu) - He)
        return pen, gpen, hpen, e, n, He

    def _object(self, p, jac: bool):
        L = self.letter
        if L in "DE":
            return self._distance(p, jac)
        k = self.stiffness
        pen, gpen, hpen, e, n, He = self._level_set(p, jac)
        inside = (pen > 0) if self.penetration_kind == "vertical" else (e < 0)
        J = None
        if L == "A":
            f = (k * pen)[..., None] * n
            if jac:
                J = k * (n[..., :, None] * gpen[..., None, :] + pen[..., None, None] * He)
        else:  # B, C, G: f = kappa_0 (s n - s_l a) (/ |grad pen| for B and G: along the textured normal)
            # a = J_u^T grad h, the texture's part of grad pen = a - n; s = pen (B, C) or -e (G), and
            # s_l = min(s, d^z_max) in the texture's part (Remark 3 on the base: the plane's lateral part)
            a = gpen + n
            scale, dscale = (-e, -n) if L == "G" else (pen, gpen)
            dm = self.max_penetration
            sl = scale if dm is None else np.minimum(scale, dm)
            follows = True if dm is None else (scale < dm)[..., None, None]
            v = scale[..., None] * n - sl[..., None] * a
            if jac:
                dv = (n[..., :, None] * dscale[..., None, :] + scale[..., None, None] * He
                      - np.where(follows, a[..., :, None] * dscale[..., None, :], 0.0)
                      - sl[..., None, None] * (hpen + He))
            if L == "C":
                f = k * v
                if jac:
                    J = k * dv
            else:
                gn = np.linalg.norm(gpen, axis=-1)[..., None]
                f = k * v / gn
                if jac:
                    hg = np.einsum("...ij,...j->...i", hpen, gpen)
                    J = k * (dv / gn[..., None] - v[..., :, None] * hg[..., None, :] / gn[..., None] ** 3)
        f = np.where(inside[..., None], f, 0.0)
        if jac:
            J = np.where(inside[..., None, None], J, 0.0)
        return f, J

    def potential(self, p):
        """C's and D's stored energy kappa_0 pen^2 / 2 inside, 0 outside (J), shape (...) (pen
        D's distance to the closest point: eq. 16 on the object).

        Parameters
        ----------
        p : array_like, shape (..., 3)
            Probe positions (m).

        Returns
        -------
        numpy.ndarray, shape (...)
            The stored energy (J).

        Raises
        ------
        TypeError
            For A, B, E, F and G, and C with ``max_penetration`` (not gradient fields).
        """
        if not self.is_gradient:
            raise TypeError(f"algorithm {self.letter} on an object is not a gradient field: it has no potential")
        return 0.5 * self.stiffness * self.penetration(p) ** 2

    def kernel_spec(self):
        raise ParameterError(f"{self!r} is not allowed here yet: the C core's tick over objects runs in "
                             "haptex.Renderer, haptex.simulate, haptex.simulate_batch and haptex export so far")

    def object_spec(self, max_evaluations: int | None = None):
        """The arrays of this algorithm's servo tick in the C core (:class:`haptex.Renderer`):
        the plane algorithm's (code, prm, kind, coeffs, aux; :meth:`haptex.Algorithm.kernel_spec`)
        and the base's (:meth:`Base.core_spec`). For D and E, ``max_evaluations`` is the
        closest-point search's budget a tick (None: only its cell bound).

        Parameters
        ----------
        max_evaluations : int, optional
            D's and E's closest-point search budget (texture evaluations a tick); default the
            renderer's.

        Returns
        -------
        tuple
            The plane algorithm's (code, prm, kind, coeffs, aux) and the base's
            :class:`haptex.core._ext.Base`.
        """
        code, prm, kind, coeffs, aux = self._plane.kernel_spec()
        if self.letter in "DE" and max_evaluations is not None:
            from .core import _ext

            aux = np.array(aux, dtype=np.float64)
            aux[_ext.G_BUDGET] = float(max_evaluations)
        return code, prm, kind, coeffs, aux, self.base.core_spec()


def object_algorithm(letter: str, texture: Texture, base: Base, stiffness: float, **params) -> ObjectAlgorithm:
    """Algorithm ``letter`` (A-G) rendering ``texture`` on ``base``.

    Parameters
    ----------
    letter : {"A", "B", "C", "D", "E", "F", "G"}
        D and E (a plane, cylinder, sphere or prism mesh; a surface or Fourier-profile
        texture) take the closest point of the textured object, in the C core. F renders in the C core (its
        presliding friction in the surface coordinates, the local
        tangent plane; :meth:`ObjectAlgorithm.force` gives its static force at a deflection);
        the region analyses take every letter (:data:`OBJECT_LETTERS`).
    texture : Texture
        Height h(u) over the base's surface coordinates u (m): a surface, or a profile
        (extruded along u2).
    base : Base
        :class:`Plane`, :class:`Cylinder`, :class:`Sphere` or :class:`Mesh`.
    stiffness : float
        kappa_0 (N/m).
    **params
        B's, C's and G's: ``max_penetration`` (d^z_max, m: the texture's part of the force is
        clamped at that depth, Remark 3 on the base). F's: ``friction``, ``presliding``,
        ``modulation_depth``, ``max_penetration``, ``stick_deflection``
        (:class:`haptex.algorithms.FrictionModulated`). None for A, D and E.

    Returns
    -------
    ObjectAlgorithm

    Raises
    ------
    ParameterError
        For another letter, a non-positive stiffness, parameters the letter does not take, or
        a texture that does not fit a closed
        base (not periodic along u1, a period longer than its circumference, or one that
        leaves a seam: the nearest radius without one is named).
    """
    return ObjectAlgorithm(letter, texture, base, stiffness, **params)


# the bases' own local and point, and the object algorithm's force_and_jacobian and
# kernel_spec, say what their parents' say (numpydoc reads an object's own docstring)
for _cls in (Plane, Cylinder, Sphere, Mesh):
    for _name in ("local", "point"):
        _f = _cls.__dict__.get(_name)
        if _f is not None and not _f.__doc__:
            _f.__doc__ = getattr(Base, _name).__doc__
for _name in ("force_and_jacobian", "kernel_spec"):
    _f = ObjectAlgorithm.__dict__.get(_name)
    if _f is not None and not _f.__doc__:
        _f.__doc__ = getattr(Algorithm, _name).__doc__
del _cls, _name, _f
