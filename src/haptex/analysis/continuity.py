"""Continuity of a force field over the rendering region (Table II's last column)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validation import check_budget, whole
from ..algorithms import Algorithm
from ..textures import Flat
from ._region import _region_box, _static_force, check_analysis_scale


@dataclass(frozen=True)
class Continuity:
    """Result of :func:`continuity`.

    Attributes
    ----------
    continuous : bool
        True when the largest force difference between grid neighbours shrinks with
        the grid spacing (order > 0.5), i.e. the field has no jump in the region.
    spacings : tuple of float
        Grid spacings (m), coarse to fine.
    max_differences : tuple of float
        Largest |f(p_i) - f(p_j)| between neighbours (N) at each spacing.
    order : float
        Fitted exponent of max_difference ~ spacing^order: about 1 for a Lipschitz
        field, about 0 for a field with a jump.
    where : tuple of float
        Midpoint [x, z] (m) of the largest difference on the finest grid.
    """

    continuous: bool
    spacings: tuple
    max_differences: tuple
    order: float
    where: tuple


def continuity(algorithm: Algorithm, max_penetration: float = 1e-3, x_range=None, levels: int = 4,
               base: int = 32) -> Continuity:
    """Measure whether the force field jumps, by grid refinement.

    On successively halved grids covering one texture period and the wall down to
    ``max_penetration`` below the lowest valley (plus the boundary), the largest force
    difference between horizontal or vertical neighbours is computed. For a continuous
    (Lipschitz) field it shrinks in proportion to the spacing; across a jump (algorithm D
    below the peaks of a sinusoid, Remark 6) it does not.

    Parameters
    ----------
    algorithm : Algorithm
    max_penetration : float, optional
        Depth of the region below the lowest valley (m), default 1 mm.
    x_range : (float, float), optional
        Abscissa interval (m); one texture period by default.
    levels : int, optional
        Number of grids (>= 3).
    base : int, optional
        Number of cells per period on the coarsest grid (>= 8).

    Returns
    -------
    Continuity

    Raises
    ------
    ParameterError
        If a parameter is out of range.
    """
    dmax = check_analysis_scale(algorithm, max_penetration)
    levels = whole("levels", levels, 3, 12, "grid refinements; level k has (base 2^k)^2 points")
    base = whole("base", base, 8, 4096)
    x0, x1, z0, z1 = _region_box(algorithm, dmax, x_range)
    z1 = z1 + 0.05 * (x1 - x0)
    if not isinstance(algorithm.texture, Flat):
        # resolve the texture: at least 4 coarse cells per shortest period
        base = int(min(max(int(base), math.ceil(4 * (x1 - x0) / algorithm.texture.shortest_period)), 2048))
    spacings, diffs = [], []
    where = (math.nan, math.nan)
    for lev in range(int(levels)):
        n = int(base) * 2**lev
        hstep = (x1 - x0) / n
        nz = int(math.ceil((z1 - z0) / hstep))
        # positions, forces and their differences: about 12 float64 a grid point
        check_budget("levels", levels, 12 * 8 * (n + 1) * (nz + 1), f"the {n + 1} x {nz + 1} grid of level {lev}")
        xs = x0 + hstep * np.arange(n + 1)
        zs = z0 + hstep * np.arange(nz + 1)
        X, Z = np.meshgrid(xs, zs, indexing="ij")
        F = _static_force(algorithm, np.stack([X, Z], axis=-1))
        dxf = np.linalg.norm(F[1:, :] - F[:-1, :], axis=-1)
        dzf = np.linalg.norm(F[:, 1:] - F[:, :-1], axis=-1)
        mx, mz = float(dxf.max()), float(dzf.max())
        spacings.append(hstep)
        diffs.append(max(mx, mz))
        if mx >= mz:
            i, j = np.unravel_index(int(np.argmax(dxf)), dxf.shape)
            where = (float(xs[i] + hstep / 2), float(zs[j]))
        else:
            i, j = np.unravel_index(int(np.argmax(dzf)), dzf.shape)
            where = (float(xs[i]), float(zs[j] + hstep / 2))
    d = np.asarray(diffs)
    if np.all(d == 0):
        order = math.inf
    else:
        order = float(np.polyfit(np.log(spacings), np.log(np.maximum(d, 1e-300)), 1)[0])
    return Continuity(order > 0.5, tuple(spacings), tuple(diffs), order, where)
