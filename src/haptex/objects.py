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

On the plane (u = (x, y), e = z) these are the library's A, B, C and G exactly. Each base sits
with its top at the origin, outward normal +z there and u = 0 at the top, so a textured sphere
or cylinder of radius R tends to the textured plane near the origin as R grows.

Jacobians are analytic, by the chain rule through u and e: with s = grad_u h and H its
Hessian, grad pen = Ju^T s - n and hess pen = Ju^T H Ju + sum_k s_k hess u_k - hess e (Ju the
2 x 3 Jacobian of u); d nu / dp = -(I - nu nu^T) hess pen / |grad pen|.

Not yet here (issue 32's later steps): D and E (the closest point on the textured object),
F, the proxy algorithm, triangle meshes, the C core's tick over objects.
"""

from __future__ import annotations

import math

import numpy as np

from ._validation import ParameterError, fail, positions, positive
from .algorithms import Algorithm, algorithm
from .surfaces import Extruded, Surface
from .textures import Texture

__all__ = ["Base", "Plane", "Cylinder", "Sphere", "ObjectAlgorithm", "object_algorithm", "OBJECT_LETTERS"]

OBJECT_LETTERS = ("A", "B", "C", "G")
"""The algorithms defined over a curved base so far (penetration along the base's normal)."""

MAX_RADIUS = 1e3
"""Largest base radius accepted (m): 1 km, the library's workspace scale."""


def _atan2_derivs(a, ga, ha, b, gb, hb):
    """atan2(a, b), its gradient (..., 3) and Hessian (..., 3, 3) from those of a and b."""
    r2 = a * a + b * b
    g = (b[..., None] * ga - a[..., None] * gb) / r2[..., None]
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

    def local(self, p):
        """Local coordinates of probes ``p`` (..., 3) (m).

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
        ``e`` (...) (m)."""
        raise NotImplementedError

    def check_texture(self, texture: Surface) -> None:
        """Raise ParameterError where the texture does not fit on the base (see subclasses)."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}()" if math.isinf(self.radius) else f"{type(self).__name__}({self.radius:g})"


class Plane(Base):
    """The plane z = 0: u = (x, y), e = z (today's textured wall, exactly)."""

    name = "plane"

    def local(self, p):
        shape = p.shape[:-1]
        Ju = np.zeros((*shape, 2, 3))
        Ju[..., 0, 0] = Ju[..., 1, 1] = 1.0
        n = np.zeros((*shape, 3))
        n[..., 2] = 1.0
        return p[..., :2].copy(), Ju, np.zeros((*shape, 2, 3, 3)), p[..., 2].copy(), n, np.zeros((*shape, 3, 3))

    def point(self, u, e):
        u = np.asarray(u, dtype=float)
        e = np.broadcast_to(np.asarray(e, dtype=float), u.shape[:-1])
        return np.concatenate([u, e[..., None]], axis=-1)


def _closed_period_check(base, texture: Surface, length: float) -> None:
    """The texture must be periodic along u1 with a period that divides the base's closed
    length (no seam): else a ParameterError naming the radius and the nearest that fits."""
    cell = texture.cell
    if cell is None:
        raise ParameterError(f"texture = {texture!r} is not allowed on {base!r}: a closed base needs a texture "
                             f"periodic along u1 (its {length:.6g} m circumference would leave a seam)")
    period = float(cell[0])
    if period > length * (1 + 1e-12):
        raise ParameterError(f"texture = {texture!r} is not allowed on {base!r}: its period along u1, "
                             f"{period:.6g} m, is longer than the base's circumference {length:.6g} m")
    turns = length / period
    if abs(turns - round(turns)) > 1e-9 * turns:
        fit = round(turns) * period / (2 * math.pi)
        raise fail("radius", base.radius, f"a radius whose circumference holds a whole number of the texture's "
                   f"{period:.6g} m periods along u1 (no seam), e.g. {fit:.9g} m")


class Cylinder(Base):
    """A circular cylinder of radius R (m) whose axis is parallel to y through (0, 0, -R):
    u1 = R phi (arc length around the axis, phi = atan2(x, z + R), 0 at the top), u2 = y,
    e = rho - R (rho the distance from the axis). Developable: u is arc length on the base,
    so the texture keeps its periods there.

    Raises
    ------
    ParameterError
        If the radius is not in (0, MAX_RADIUS] m.
    """

    name = "cylinder"

    def __init__(self, radius: float):
        self.radius = positive("radius", radius, "m")
        if self.radius > MAX_RADIUS:
            raise fail("radius", radius, f"at most {MAX_RADIUS:g} m")

    def local(self, p):
        R = self.radius
        x, y, z = p[..., 0], p[..., 1], p[..., 2] + R
        shape = p.shape[:-1]
        rho = np.hypot(x, z)
        if np.any(rho == 0.0):
            raise ParameterError("p is not allowed on the cylinder's axis (its normal is undefined there)")
        ex, ez = np.zeros((*shape, 3)), np.zeros((*shape, 3))
        ex[..., 0] = ez[..., 2] = 1.0
        zero = np.zeros((*shape, 3, 3))
        phi, gphi, hphi = _atan2_derivs(x, ex, zero, z, ez, zero)
        n = np.zeros((*shape, 3))
        n[..., 0], n[..., 2] = x / rho, z / rho
        pxz = np.zeros((*shape, 3, 3))
        pxz[..., 0, 0] = pxz[..., 2, 2] = 1.0
        He = (pxz - n[..., :, None] * n[..., None, :]) / rho[..., None, None]
        u = np.stack([R * phi, y], axis=-1)
        Ju = np.zeros((*shape, 2, 3))
        Ju[..., 0, :] = R * gphi
        Ju[..., 1, 1] = 1.0
        Hu = np.zeros((*shape, 2, 3, 3))
        Hu[..., 0, :, :] = R * hphi
        return u, Ju, Hu, rho - R, n, He

    def point(self, u, e):
        u = np.asarray(u, dtype=float)
        e = np.asarray(e, dtype=float)
        phi = u[..., 0] / self.radius
        rho = self.radius + e
        return np.stack(np.broadcast_arrays(rho * np.sin(phi), u[..., 1], rho * np.cos(phi) - self.radius), axis=-1)

    def check_texture(self, texture: Surface) -> None:
        """The texture's period along u1 must divide the circumference 2 pi R."""
        _closed_period_check(self, texture, 2 * math.pi * self.radius)


class Sphere(Base):
    """A sphere of radius R (m) centred at (0, 0, -R), in equirectangular coordinates about the
    great circle y = 0: u1 = R phi (phi = atan2(x, z + R), the longitude, 0 at the top),
    u2 = R lambda (lambda the latitude from that circle), e = r - R. u is arc length along that
    great circle and along the meridians; along u1 a texture is stretched by 1 / cos(lambda)
    off it (a sphere has no isometric chart), by under 0.5 % within 0.1 R of the top.

    Raises
    ------
    ParameterError
        If the radius is not in (0, MAX_RADIUS] m.
    """

    name = "sphere"

    def __init__(self, radius: float):
        self.radius = positive("radius", radius, "m")
        if self.radius > MAX_RADIUS:
            raise fail("radius", radius, f"at most {MAX_RADIUS:g} m")

    def local(self, p):
        R = self.radius
        x, y, z = p[..., 0], p[..., 1], p[..., 2] + R
        shape = p.shape[:-1]
        rho = np.hypot(x, z)
        if np.any(rho == 0.0):
            raise ParameterError("p is not allowed on the sphere's axis through its poles (y axis): the "
                                 "equirectangular coordinates are singular there")
        r = np.sqrt(rho * rho + y * y)
        eye = np.broadcast_to(np.eye(3), (*shape, 3, 3))
        ex, ey, ez = (np.broadcast_to(np.eye(3)[k], (*shape, 3)) for k in range(3))
        zero = np.zeros((*shape, 3, 3))
        phi, gphi, hphi = _atan2_derivs(x, ex, zero, z, ez, zero)
        m = np.zeros((*shape, 3))  # grad rho
        m[..., 0], m[..., 2] = x / rho, z / rho
        pxz = eye.copy()
        pxz[..., 1, 1] = 0.0
        hrho = (pxz - m[..., :, None] * m[..., None, :]) / rho[..., None, None]
        lam, glam, hlam = _atan2_derivs(y, ey, zero, rho, m, hrho)
        n = np.stack([x, y, z], axis=-1) / r[..., None]
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

    def check_texture(self, texture: Surface) -> None:
        """The texture's period along u1 must divide the equator's length 2 pi R, and its
        extent along u2 stays within the latitudes +-pi R / 2 (the poles) by construction."""
        _closed_period_check(self, texture, 2 * math.pi * self.radius)


class ObjectAlgorithm(Algorithm):
    """One of A, B, C, G over a textured object (see the module's docstring for the fields).

    Probe positions are [x, y, z] (m); forces (N) and Jacobians (N/m) are in that frame.
    ``texture`` is the height h(u) (a surface over u; a profile is extruded along u2).
    :func:`haptex.characteristic_number` takes it like a plane algorithm: its grid is laid
    in (u, depth) over one texture cell and mapped onto the object by :meth:`region_points`.
    :func:`haptex.analysis.work.loop_energy` takes any closed path on or inside the object.
    (:func:`haptex.continuity` and :func:`haptex.conservativity` still lay their boxes in
    Cartesian coordinates: a slab at the base's top, which lies in the object's shell only for
    a radius much larger than the cell.)
    """

    surfaces = True
    penetration_kind = "vertical"

    def __init__(self, letter: str, texture: Texture, base: Base, stiffness: float):
        if letter not in OBJECT_LETTERS:
            raise fail("algorithm", letter, f"one of {', '.join(OBJECT_LETTERS)} on an object so far (D, E, F and the "
                       "proxy algorithm over objects are not written yet)")
        if not isinstance(base, Base):
            raise fail("base", base, "a haptex.objects base: Plane(), Cylinder(R) or Sphere(R)")
        if texture.dimension == 1:
            texture = Extruded(texture)
        base.check_texture(texture)
        super().__init__(texture, stiffness)
        self.letter = letter
        self.base = base
        plane = algorithm(letter, texture, stiffness)
        self.name = plane.name
        self.reference = plane.reference + "; on a base: haptex.objects"
        self.penetration_kind = plane.penetration_kind
        self.is_gradient = letter == "C"

    def __repr__(self) -> str:
        return f"object_algorithm({self.letter!r}, {self.texture!r}, {self.base!r}, stiffness={self.stiffness:g})"

    @property
    def dimension(self) -> int:
        return 3

    def _positions(self, p) -> np.ndarray:
        return positions(p, dim=3)

    def region_points(self, ut, depth):
        """Probe positions (..., 3) (m) at surface coordinates ``ut`` (..., 2) and penetration
        ``depth`` (...) (m), measured as the algorithm measures it: below the textured surface
        along the base's normal (A, B, C) or below the base (G)."""
        ut = np.asarray(ut, dtype=float)
        depth = np.asarray(depth, dtype=float)
        e = (self.texture.height_at(ut) - depth) if self.penetration_kind == "vertical" else -depth
        return self.base.point(ut, e)

    def penetration(self, p) -> np.ndarray:
        """h(u) - e (A, B, C) or -e (G) where positive, else 0 (m), shape (...)."""
        arr = self._positions(p)
        u, _, _, e, _, _ = self.base.local(arr)
        pen = -e if self.penetration_kind == "nominal" else self.texture.height_at(u) - e
        return np.maximum(pen, 0.0)

    def force(self, p) -> np.ndarray:
        return self._object(self._positions(p), False)[0]

    def jacobian(self, p) -> np.ndarray:
        return self._object(self._positions(p), True)[1]

    def force_and_jacobian(self, p):
        return self._object(self._positions(p), True)

    def _object(self, p, jac: bool):
        k = self.stiffness
        u, Ju, Hu, e, n, He = self.base.local(p)
        tex = self.texture
        h = tex.height_at(u)
        s = tex.gradient(u)
        pen = h - e
        gpen = np.einsum("...ki,...k->...i", Ju, s) - n
        inside = (pen > 0) if self.penetration_kind == "vertical" else (e < 0)
        f = np.zeros(p.shape)
        J = np.zeros((*p.shape, 3)) if jac else None
        hpen = None
        if jac or self.letter in ("B", "G"):
            H = tex.hessian(u)
            hpen = (np.einsum("...ki,...kl,...lj->...ij", Ju, H, Ju) + np.einsum("...k,...kij->...ij", s, Hu) - He)
        L = self.letter
        if L == "A":
            f = (k * pen)[..., None] * n
            if jac:
                J = k * (n[..., :, None] * gpen[..., None, :] + pen[..., None, None] * He)
        elif L == "C":
            f = -(k * pen)[..., None] * gpen
            if jac:
                J = -k * (gpen[..., :, None] * gpen[..., None, :] + pen[..., None, None] * hpen)
        else:  # B, G: the textured surface's normal nu = -grad pen / |grad pen|
            gn = np.linalg.norm(gpen, axis=-1)
            nu = -gpen / gn[..., None]
            scale = pen if L == "B" else -e
            f = (k * scale)[..., None] * nu
            if jac:
                eye = np.eye(3)
                dnu = -(eye - nu[..., :, None] * nu[..., None, :]) @ hpen / gn[..., None, None]
                dscale = gpen if L == "B" else -n
                J = k * (nu[..., :, None] * dscale[..., None, :] + scale[..., None, None] * dnu)
        f = np.where(inside[..., None], f, 0.0)
        if jac:
            J = np.where(inside[..., None, None], J, 0.0)
        return f, J

    def potential(self, p):
        """C's stored energy kappa_0 pen^2 / 2 inside, 0 outside (J), shape (...).

        Raises
        ------
        TypeError
            For A, B and G (not gradient fields).
        """
        if self.letter != "C":
            raise TypeError(f"algorithm {self.letter} on an object is not a gradient field: it has no potential")
        return 0.5 * self.stiffness * self.penetration(p) ** 2

    def kernel_spec(self):
        raise ParameterError(f"{self!r} is not allowed in the renderer, simulator or export yet: the C core's tick "
                             "over objects is issue 32's next step")


def object_algorithm(letter: str, texture: Texture, base: Base, stiffness: float) -> ObjectAlgorithm:
    """Algorithm ``letter`` (A, B, C or G) rendering ``texture`` on ``base``.

    Parameters
    ----------
    letter : {"A", "B", "C", "G"}
    texture : Texture
        Height h(u) over the base's surface coordinates u (m): a surface, or a profile
        (extruded along u2).
    base : Base
        :class:`Plane`, :class:`Cylinder` or :class:`Sphere`.
    stiffness : float
        kappa_0 (N/m).

    Returns
    -------
    ObjectAlgorithm

    Raises
    ------
    ParameterError
        For another letter, a non-positive stiffness, or a texture that does not fit a closed
        base (not periodic along u1, a period longer than its circumference, or one that
        leaves a seam: the nearest radius without one is named).
    """
    return ObjectAlgorithm(letter, texture, base, stiffness)
