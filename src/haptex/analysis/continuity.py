"""Continuity of a force field over the rendering region (Table II's last column)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .._validation import check_budget, whole
from ..algorithms import Algorithm, checked_algorithm
from ..textures import Flat
from ._region import _region_box, _static_force, check_analysis_scale


@dataclass(frozen=True)
class Continuity:
    """Result of :func:`continuity`.

    Parameters
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
        Midpoint [x, z] or [x, y, z] (m) of the largest difference on the finest grid.
    """

    continuous: bool
    spacings: tuple
    max_differences: tuple
    order: float
    where: tuple


def continuity(algorithm: Algorithm, max_penetration: float = 1e-3, x_range=None, levels: int | None = None,
               base: int | None = None) -> Continuity:
    """Measure whether the force field jumps, by grid refinement.

    On successively halved grids covering one texture period (a periodic cell over a
    surface) and the wall down to ``max_penetration`` below the lowest valley (plus the
    boundary), the largest force difference between neighbours along any axis is
    computed. For a continuous
    (Lipschitz) field it shrinks in proportion to the spacing; across a jump (algorithm D
    below the peaks of a sinusoid, Remark 6) it does not.

    Parameters
    ----------
    algorithm : Algorithm
    max_penetration : float, optional
        Depth of the region below the lowest valley (m), default 1 mm.
    x_range : (float, float) or ((float, float), (float, float)), optional
        Abscissa interval (m), or the in-plane rectangle over a surface; one texture
        period (cell) by default.
    levels : int, optional
        Number of grids (>= 3); default 4 over a profile, 3 over a surface (whose grids
        are 3-D).
    base : int, optional
        Number of cells per period on the coarsest grid (>= 8); default 32, and 16 for D
        and E over a surface (each grid point a closest-point search).

    Returns
    -------
    Continuity

    Raises
    ------
    ParameterError
        If a parameter is out of range.
    """
    algorithm = checked_algorithm(algorithm)
    box, steps0, levels = _plan(algorithm, max_penetration, x_range, levels, base)
    spacings, diffs = [], []
    where = (math.nan,) * len(box)
    F = None
    previous = 0
    for lev in range(levels):
        steps = [s / 2**lev for s in steps0]
        counts = [int(math.ceil((b - a) / s)) for (a, b), s in zip(box, steps)]
        n = math.prod(c + 1 for c in counts)
        keep = lev < levels - 1  # the next grid reads this one's forces; the last is streamed
        slab = min(n, max(SLAB_POINTS, n // (counts[0] + 1)))  # a slab holds one row at least
        check_budget("levels", levels, _held_bytes(n, previous, keep, slab),
                     f"the {' x '.join(str(c + 1) for c in counts)} grid of level {lev}"
                     + ("" if keep else f" (its forces streamed, the {previous:.3g} points "
                                        "of the grid before held)"))
        axes = [a + s * np.arange(c + 1) for (a, _), s, c in zip(box, steps, counts)]
        F, (k, jump, idx) = _refined_forces(algorithm, axes, F, keep)
        previous = n
        spacings.append(steps[0])
        diffs.append(jump)
        where = tuple(float(axes[a][idx[a]] + (steps[a] / 2 if a == k else 0.0)) for a in range(len(box)))
    d = np.asarray(diffs)
    if np.all(d == 0):
        order = math.inf
    else:
        order = float(np.polyfit(np.log(spacings), np.log(np.maximum(d, 1e-300)), 1)[0])
    return Continuity(order > 0.5, tuple(spacings), tuple(diffs), order, where)


SLAB_POINTS = 1 << 18
"""Grid points a slab of :func:`continuity`'s grid holds at most (chosen: its positions,
forces, differences and the field's own temporaries, some 50 MiB: :data:`SLAB_POINT_BYTES`)."""
SLAB_POINT_BYTES = 24 * 8
"""The memory a slab's point may take (B): about 24 float64 a point, the closest-point
search's temporaries included (measured on D over a 1025 x 1025 map: 7.4 GB for a grid held
whole whose 12 float64 a point were counted as 5.2 GiB)."""
FORCE_BYTES = 3 * 8
"""The memory of a grid point's force held for the next grid (B)."""


def peak_bytes(sizes) -> int:
    """The most memory (B) :func:`continuity` takes over grids of ``sizes`` points, coarse to
    fine (:func:`grid_points`): the forces of a grid held for the next one, those of the grid
    before, and one slab; the last grid is streamed. (A grid whose rows across x exceed
    :data:`SLAB_POINTS` takes a row a slab: :func:`continuity` checks that larger slab.)

    Parameters
    ----------
    sizes : sequence of int
        The grids' point counts, coarse to fine.
    """
    last = len(sizes) - 1
    return int(max((_held_bytes(n, sizes[i - 1] if i else 0, i < last, min(n, SLAB_POINTS))
                    for i, n in enumerate(sizes)), default=0))


def _held_bytes(n: int, previous: int, keep: bool, slab: int) -> int:
    """The memory (B) of one grid of ``n`` points: its forces when ``keep`` (the next grid reads
    them), the ``previous`` grid's forces it reads, and a slab of ``slab`` points."""
    return FORCE_BYTES * (n * keep + previous) + SLAB_POINT_BYTES * slab


def _refined_forces(algorithm: Algorithm, axes, coarse, keep: bool = True):
    """The static force on the grid of ``axes`` (shape (n_0, ..., n_k, dim), N; None unless
    ``keep``) and its largest neighbour difference (axis, value in N, index of the pair's first
    point), evaluated in slabs along the first axis of at most :data:`SLAB_POINTS` points, so
    that only the forces kept take memory in proportion to the grid. Its points of even index
    on every axis are the points of the grid before, halved steps from the same corner, bit for
    bit (a step halved is exact): their forces are read from ``coarse`` (the force on that grid,
    or None) and only the new points are evaluated, 7/8 of a 3-D grid. The difference and its
    place are those of the whole grid: the first largest in C order, axis by axis."""
    n0 = len(axes[0])
    plane = math.prod(len(a) for a in axes[1:])
    rows = max(1, SLAB_POINTS // max(plane, 1))
    F = None
    best = [(-1.0, None)] * len(axes)  # (value, index) per axis
    last = None  # the forces of the row before the slab
    for i0 in range(0, n0, rows):
        i1 = min(n0, i0 + rows)
        P = np.stack(np.meshgrid(axes[0][i0:i1], *axes[1:], indexing="ij"), axis=-1)
        if coarse is None:
            Fs = _static_force(algorithm, P)
        else:
            even = (slice(i0 % 2, None, 2),) + tuple(slice(0, None, 2) for _ in axes[1:])
            fresh = np.ones(P.shape[:-1], dtype=bool)
            fresh[even] = False
            Fs = np.empty(P.shape[:-1] + coarse.shape[-1:])
            shape = fresh[even].shape
            first = (i0 + i0 % 2) // 2
            Fs[even] = coarse[(slice(first, first + shape[0]),) + tuple(slice(0, m) for m in shape[1:])]
            Fs[fresh] = _static_force(algorithm, P[fresh])
        del P
        for k in range(len(axes)):
            if k == 0 and last is not None:  # the pair across the slab's edge comes first in C order
                _better(best, 0, np.linalg.norm(Fs[:1] - last, axis=-1), i0 - 1)
            if Fs.shape[k] > 1:
                jumps = np.linalg.norm(np.diff(Fs, axis=k), axis=-1)
                _better(best, k, jumps, i0)
        last = Fs[-1].copy()
        if keep:
            if F is None:
                F = np.empty((n0,) + Fs.shape[1:])
            F[i0:i1] = Fs
    k = int(np.argmax([v for v, _ in best]))
    return F, (k, float(best[k][0]), best[k][1])


def _better(best: list, k: int, jumps: np.ndarray, row: int) -> None:
    """Keep in ``best[k]`` the larger of it and the first largest of ``jumps``, whose first
    axis starts at the grid's row ``row``."""
    i = int(np.argmax(jumps))
    v = float(jumps.flat[i])
    if v > best[k][0]:
        idx = np.unravel_index(i, jumps.shape)
        best[k] = (v, (row + int(idx[0]),) + tuple(int(j) for j in idx[1:]))


def _plan(algorithm: Algorithm, max_penetration: float, x_range, levels, base):
    """(box, coarsest steps, levels) of :func:`continuity`'s grids (see its parameters)."""
    dmax = check_analysis_scale(algorithm, max_penetration)
    surface = algorithm.dimension == 3
    levels = (3 if surface else 4) if levels is None else levels
    if base is None:  # the closest-point search (D, E) costs ~10 us a point: coarser 3-D grids
        base = 16 if surface and algorithm.penetration_kind == "distance" else 32
    levels = whole("levels", levels, 3, 12, "grid refinements; level k has (base 2^k)^2 points")
    base = whole("base", base, 8, 4096)
    box = _region_box(algorithm, dmax, x_range)
    (x0, x1), (z0, z1) = box[0], box[-1]
    z1 = z1 + min(0.05 * (x1 - x0), dmax)  # the boundary and a margin outside, on the wall's scale
    box[-1] = (z0, z1)
    tex = algorithm.texture
    if not isinstance(tex, Flat):
        # resolve the texture: at least 4 coarse cells per shortest period (2 for D and E over a
        # surface, each point a closest-point search: 8 on the finest of 3 levels)
        per = 2 if surface and algorithm.penetration_kind == "distance" else 4
        base = int(min(max(int(base), math.ceil(per * (x1 - x0) / tex.shortest_period)), 256 if surface else 2048))
    return box, _coarse_steps(algorithm, box, (x1 - x0) / int(base), int(levels), dmax), int(levels)


def continuity_points(algorithm: Algorithm, max_penetration: float = 1e-3, x_range=None, levels: int | None = None,
                      base: int | None = None) -> list[int]:
    """The number of field evaluations :func:`continuity` makes on each grid, coarse to fine
    (the same plan, not run): what its cost follows. A finer grid evaluates only its points
    that the grid before does not have; the largest grid holds ``grid_points(...)[-1]``.

    Parameters
    ----------
    algorithm : Algorithm
        Any of W, A-G.
    max_penetration : float, optional
        Depth of the rendering region below the lowest valley (m), default 1 mm.
    x_range : (float, float), optional
        The region along x (m) instead of one period (or the texture's domain).
    levels : int, optional
        Grids, coarse to fine (default :func:`continuity`'s).
    base : int, optional
        The coarsest grid's points a side (default :func:`continuity`'s).

    Returns
    -------
    list of int
        Evaluations on each grid.

    Raises
    ------
    ParameterError
        As :func:`continuity`.
    """
    algorithm = checked_algorithm(algorithm)
    sizes = grid_points(algorithm, max_penetration, x_range, levels, base)
    box, steps0, levels = _plan(algorithm, max_penetration, x_range, levels, base)
    evens = [math.prod(int(math.ceil((b - a) / (s / 2**lev))) // 2 + 1 for (a, b), s in zip(box, steps0))
             for lev in range(1, levels)]
    return [sizes[0]] + [n - e for n, e in zip(sizes[1:], evens)]


def grid_points(algorithm: Algorithm, max_penetration: float = 1e-3, x_range=None, levels: int | None = None,
                base: int | None = None) -> list[int]:
    """The number of points of each grid of :func:`continuity`, coarse to fine (the same plan,
    not run): what its memory follows.

    Parameters
    ----------
    algorithm : Algorithm
        Any of W, A-G.
    max_penetration : float, optional
        Depth of the rendering region below the lowest valley (m), default 1 mm.
    x_range : (float, float), optional
        The region along x (m) instead of one period (or the texture's domain).
    levels : int, optional
        Grids, coarse to fine (default :func:`continuity`'s).
    base : int, optional
        The coarsest grid's points a side (default :func:`continuity`'s).

    Returns
    -------
    list of int
        Points of each grid.

    Raises
    ------
    ParameterError
        As :func:`continuity`.
    """
    algorithm = checked_algorithm(algorithm)
    box, steps0, levels = _plan(algorithm, max_penetration, x_range, levels, base)
    return [math.prod(int(math.ceil((b - a) / (s / 2**lev))) + 1 for (a, b), s in zip(box, steps0))
            for lev in range(levels)]


MIN_AXIS_CELLS = 8
"""Fewest grid cells along any axis of the coarsest grid: a step longer than the region is
deep cannot see a Lipschitz field's differences shrink (W over a 10 um deep region on a
31 um grid was measured 'not continuous')."""
MAX_GRID_POINTS = {"direct": 2**19, "distance": 2**17}
"""Most points of the finest grid over a surface, for fields evaluated directly (about
4 us a point on a bicubic height map) and through a closest-point search (D, E: tens of
us a point); chosen so that one continuity test takes seconds. Past it the grid is
coarsened along the depth only (the in-plane steps resolve the texture)."""


def _coarse_steps(algorithm: Algorithm, box, hstep: float, levels: int, depth: float) -> list[float]:
    """The coarsest grid's step along each axis of ``box`` (m): ``hstep`` everywhere (a
    square grid), but at most 1/``MIN_AXIS_CELLS`` of each extent and, in depth, of the
    wall's ``depth`` (m; the field varies on that scale inside it), and over a surface the
    depth step lengthened until the finest grid holds at most ``MAX_GRID_POINTS`` points
    (the field is Lipschitz in depth on the texture's scale, not the grid's; a jump is seen
    across in-plane neighbours too)."""
    extents = [b - a for a, b in box]
    steps = [min(hstep, e / MIN_AXIS_CELLS) for e in extents]
    steps[-1] = min(steps[-1], depth / MIN_AXIS_CELLS)
    if algorithm.dimension == 3:
        fine = 2 ** (levels - 1)
        plane = math.prod(math.ceil(e / s) * fine + 1 for e, s in zip(extents[:-1], steps[:-1]))
        cap = MAX_GRID_POINTS["distance" if algorithm.penetration_kind == "distance" else "direct"]
        cells = max(MIN_AXIS_CELLS, cap // plane // fine)
        steps[-1] = max(steps[-1], min(extents[-1], depth) / cells)
    return steps
