"""Maps of a force field over a vertical section of the rendering region: the force, the
local gain ||J||_2 / kappa_0 (whose sup is the characteristic number q, Section IV-A-1) and
the curl (the Jacobian's asymmetry, Section IV-A-4), on one grid. Used by the static
figures (:mod:`haptex.plotting`) and by the browser explorer (:mod:`haptex.explore`), so
that both show the same numbers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import ParameterError, fail, finite, positive
from ..algorithms import Algorithm, checked_algorithm
from .characteristic import spectral_norm
from .work import curl_of_jacobian

#: Largest grid a map computes (points per axis): a 2-D D or E map costs about 2 us a point.
MAX_MAP_POINTS = 1001


@dataclass(frozen=True)
class FieldMap:
    """A field sampled on a grid over the vertical section y = ``y`` (x right, z up).

    Parameters
    ----------
    x : ndarray, shape (nx,)
        Abscissae (m).
    z : ndarray, shape (nz,)
        Heights (m); z < h(x) is inside the textured wall.
    y : float or None
        The section's ordinate over a surface (m); None over a profile.
    force : ndarray, shape (nz, nx, 2)
        In-plane force [f_x, f_z] (N). For F, at presliding deflection ``deflection``.
    gain : ndarray, shape (nz, nx)
        ||J(p)||_2 / kappa_0 (dimensionless, the full 2 x 2 or 3 x 3 Jacobian) inside the
        rendering region (penetration in (0, max_penetration], as the algorithm measures
        it), NaN outside it: the region whose sup is q.
    curl : ndarray, shape (nz, nx)
        In-plane curl df_z/dx - df_x/dz (N/m); zero for a gradient field. Over a surface
        this is minus the y component of the curl vector.
    penetration : ndarray, shape (nz, nx)
        The algorithm's penetration (m).
    """

    x: np.ndarray
    z: np.ndarray
    y: float | None
    force: np.ndarray
    gain: np.ndarray
    curl: np.ndarray
    penetration: np.ndarray


def default_window(texture, x_range=None) -> tuple[float, float]:
    """The abscissa window a map shows: ``x_range`` if given, else one texture period from 0
    (1 mm for a texture without one).

    Parameters
    ----------
    texture : Texture or None
        The texture mapped.
    x_range : (float, float), optional
        The window (m), taken as it is.

    Returns
    -------
    (float, float)
        The window (m).
    """
    if x_range is not None:
        return float(x_range[0]), float(x_range[1])
    period = getattr(texture, "period", None) if texture is not None else None
    return 0.0, float(period) if period else 1e-3


def field_map(algorithm: Algorithm, x_range=None, z_range=None, n=(61, 61), max_penetration: float = 1e-3,
              y: float = 0.0, deflection: float | None = None) -> FieldMap:
    """Sample an algorithm's force, gain and curl over a grid of one vertical section.

    Parameters
    ----------
    algorithm : Algorithm
        Any of W, A–G, over a profile (positions [x, z]) or a surface ([x, y, z]).
    x_range : (float, float), optional
        Abscissa window (m); default :func:`default_window`.
    z_range : (float, float), optional
        Height window (m); default from d_max below the lowest valley to 10 % of the
        window's width above the highest peak.
    n : int or (int, int)
        Grid points along x and z, each in [2, ``MAX_MAP_POINTS``].
    max_penetration : float
        d_max (m), the depth of the rendering region the gain is shown over.
    y : float
        The section's ordinate over a surface (m); ignored over a profile (must be 0).
    deflection : float, optional
        F's presliding deflection d^x (m); default d^x_max (full slip to the right, as in
        Fig. 2). Only F takes it.

    Returns
    -------
    FieldMap

    Raises
    ------
    ParameterError
        If a window is empty or not finite, a grid size is out of range, ``y`` is given
        over a profile, or ``deflection`` is given to an algorithm other than F.
    """
    algorithm = checked_algorithm(algorithm)
    tex = algorithm.texture
    nx, nz = (n, n) if np.ndim(n) == 0 else n
    for name, v in (("n", nx), ("n", nz)):
        if not (isinstance(v, (int, np.integer)) and 2 <= v <= MAX_MAP_POINTS):
            raise fail(name, v, f"a whole number of grid points in [2, {MAX_MAP_POINTS}]")
    dmax = positive("max_penetration", max_penetration, "m")
    x0, x1 = default_window(tex, x_range)
    lo, hi = tex.height_range if tex is not None else (0.0, 0.0)
    z0, z1 = (lo - dmax, hi + 0.1 * (x1 - x0)) if z_range is None else (float(z_range[0]), float(z_range[1]))
    for name, (a, b) in (("x_range", (x0, x1)), ("z_range", (z0, z1))):
        if not (np.isfinite(a) and np.isfinite(b) and a < b):
            raise fail(name, (a, b), "a finite window (low, high) with low < high, in metres")
    d = algorithm.dimension
    if d == 2 and y != 0.0:
        raise fail("y", y, "0 over a profile (a section ordinate applies to a surface)")
    y = finite("y", y, "m")
    x = np.linspace(x0, x1, nx)
    z = np.linspace(z0, z1, nz)
    X, Z = np.meshgrid(x, z)
    P = np.stack([X, Z], -1) if d == 2 else np.stack([X, np.full_like(X, y), Z], -1)
    if algorithm.has_memory:
        state = algorithm.presliding if deflection is None else finite("deflection", deflection, "m")
        force = algorithm.force(P, state)
        jac = algorithm.jacobian(P, state)
    elif deflection is not None:
        raise ParameterError(f"deflection = {deflection!r} is not allowed for algorithm {algorithm.letter}: "
                             "only F has a presliding state")
    else:
        force, jac = algorithm.force_and_jacobian(P)
    plane = [0, d - 1]
    gain = spectral_norm(jac) / algorithm.stiffness
    depth = algorithm.penetration(P)
    region = (depth > 0) & (depth <= dmax * (1 + 1e-9))
    c = curl_of_jacobian(jac)
    in_plane_curl = c if d == 2 else -c[..., 1]
    return FieldMap(x=x, z=z, y=None if d == 2 else y, force=force[..., plane],
                    gain=np.where(region, gain, np.nan), curl=in_plane_curl, penetration=depth)


__all__ = ["FieldMap", "field_map", "default_window", "MAX_MAP_POINTS"]
