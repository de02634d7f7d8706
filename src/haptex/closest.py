"""Closest point on the textured boundary z = h(x) or z = h(x, y), used by algorithms D and E.

The search is the C core's (``hx_closest_profile``, ``hx_closest_surface``); this module
builds, once per texture, the data it reads (:func:`search_data`: a tree of height bounds;
:func:`table_search_data`: a periodic profile's cell table; :func:`surface_search_data`: a
surface's constants), validates, flattens and calls it. The reference it is tested against
is a brute-force dense search.
"""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from . import core as _core
from .core import _ext as K
from ._validation import ParameterError, positions
from .textures import SampledProfile, SumOfSinusoids, Texture, checked_texture

__all__ = ["ClosestPoint", "closest_point", "search_data", "table_search_data"]

MAX_LEAVES = 1 << 22
"""Largest bound tree (leaves) a texture may ask for: 2^22 leaves are 128 MiB of bounds (the C
core's check, ``hx_closest_aux_check``, allows no more)."""
OPEN_LEAVES = 4096
"""An aperiodic Fourier sum is searched within +-OPEN_LEAVES leaves of the probe's abscissa."""
FOURIER_WORK_LIMIT = 4e9
"""Largest number of harmonic evaluations :func:`search_data` may spend on a Fourier texture."""
TABLE_CELL_DIVISOR = 64
"""A cell table's cells are squares of side shortest period / TABLE_CELL_DIVISOR (or larger,
see ``TABLE_MAX_CELLS``)."""
TABLE_MAX_CELLS = 1 << 18
"""Most cells a cell table may hold (a few MiB); a larger table gets larger cells."""


@dataclass(frozen=True)
class ClosestPoint:
    """Closest boundary points for an array of probe positions.

    Parameters
    ----------
    x : ndarray, shape (...)
        Abscissa p_h^x of the closest point (m); equal to the probe's x where the probe
        is not below the boundary.
    z : ndarray, shape (...)
        Height p_h^z = h(p_h^x) of the closest point (m).
    distance : ndarray, shape (...)
        Minimum distance d^min = |p - p_h| (m); 0 where the probe is not below the
        boundary.
    tie : ndarray of bool, shape (...)
        True where a second, distinct boundary point lies at the same distance to
        1e-9 relative: the probe is on the medial axis (e.g. below a peak of a sinusoid
        deeper than its radius of curvature), where algorithm D's force jumps (Remark 6).
    work : ndarray of int, shape (...)
        Texture evaluations each search spent (bounded for any position; see Notes of
        :func:`closest_point`).
    y : ndarray, shape (...), or None
        Over a surface, the ordinate p_h^y of the closest point (m); None over a profile.
    """

    x: np.ndarray
    z: np.ndarray
    distance: np.ndarray
    tie: np.ndarray
    work: np.ndarray
    y: np.ndarray | None = None

    def select(self, where) -> ClosestPoint:
        """The closest points at the positions ``where`` selects (a boolean mask or an index
        over the probe positions' shape).

        Parameters
        ----------
        where : array_like of bool or int
            A boolean mask over the probe positions' shape, or an index into it.

        Returns
        -------
        ClosestPoint
            The selected closest points, each array indexed by ``where``.
        """
        return ClosestPoint(x=self.x[where], z=self.z[where], distance=self.distance[where], tie=self.tie[where],
                            work=self.work[where], y=None if self.y is None else self.y[where])

    @property
    def point(self) -> np.ndarray:
        """The closest points p_h as [x, z] or [x, y, z] (m), shape (..., 2) or (..., 3)."""
        coords = [self.x, self.z] if self.y is None else [self.x, self.y, self.z]
        return np.stack(coords, axis=-1)


def closest_point(texture: Texture, p) -> ClosestPoint:
    """Closest point on the boundary z = h(x) to each probe position below it.

    Parameters
    ----------
    texture : Texture
        The height profile h(x) or surface h(x, y) (m): a profile, a sum of gratings, a
        sampled height map or an extruded profile.
    p : array_like, shape (..., 2) or (..., 3)
        Probe positions [x, z] over a profile, [x, y, z] over a surface (m).

    Returns
    -------
    ClosestPoint
        Arrays of shape (...) (see :class:`ClosestPoint`).

    Raises
    ------
    ParameterError
        If ``p`` is not of shape (..., 2) or holds a non-finite coordinate, or if the
        texture's bound tree would exceed its limits (see :func:`search_data`).

    Notes
    -----
    Branch and bound over a tree of rigorous height bounds, the god-object projection of
    Zilles & Salisbury (1995) [28] restricted to a height profile. For a probe p at
    vertical depth d_v = h(p^x) - p^z > 0:

    1. Upper bounds of the minimum distance: the vertical point, the nearest global
       minimum of h (periodic textures), the straight extensions of a finite profile
       (closed form).
    2. Window: every boundary point has height >= min h, so a point farther than
       W = sqrt(best^2 - (min h - p^z)^2) horizontally cannot be closer. Below min h the
       nearest global minimum makes W <= half a period at *any* depth; above it
       W <= d_v <= the height range. The work is therefore bounded by the texture, not by
       the depth: far below the texture the answer is, as it must be, within the height
       range of the nearest deepest valley.
    3. The window is covered by the bound tree's roots (one per period); a node is pruned
       when the distance to the box [node interval] x [min h, max h over it] is not below
       the best distance. Over a sampled profile a leaf holds whole intervals, at most
       :data:`LEAF_INTERVALS` and half its shortest period, and its bounds of h'' too: where
       they certify phi''/2 = 1 + h'^2 + (h - p^z) h'' > 0 on a surviving leaf, phi has at
       most one minimum there, found by safeguarded Newton from its ends. Any other
       surviving leaf (1/8 of the shortest period over a sum of sinusoids) is sampled every
       1/64 of the shortest period (at every node of a spline), every - to + sign change of
       phi' is refined by safeguarded Newton and the best sample is polished.

    An aperiodic sum of sinusoids (incommensurate periods) has no tree: it is searched
    on the fly within +-2048 leaves of p^x, exact to that depth and, deeper, within the
    texture's height range (2 sum a_k) of the true distance.

    Over a surface the same argument runs on a quadtree
    (``hx_closest_surface``): the square of half-width
    sqrt(best^2 - (min h - p^z)^2) around p_xy is cut into cells, pruned by bounds of h over
    each (Taylor bounds from sup |grad h| and sup ||H||; for gratings also each grating's
    exact range; beyond a non-periodic height map the extension's). Over a sum of gratings a
    second bound prunes too: phi at least its quadratic model at the cell's centre, minimised
    exactly over the cell, less a cubic term from rigorous bounds of |grad h|, ||H|| and the
    third derivatives; where the model's least point is below the best, Newton polishes it to
    its local minimum. The result is certified: no point of the surface is closer than the
    returned distance less 1e-9 of the shortest wavelength. Over a height map the same Taylor
    bounds come from the bicubic patches (:attr:`haptex.SampledSurface.derivative_bounds`),
    and beyond a non-periodic map's edges from the extension's
    (:attr:`haptex.SampledSurface.edge_bounds`), cells cut at the edge lines: certified too.
    Where phi / 2 is certified strongly convex on the whole plane (a sum of gratings or a
    periodic map, a probe within the least radius of curvature, roughly), Newton answers first
    and is exact to 1e-15 m. Over ``Extruded(profile)`` the profile's search is exact and
    p_h^y = p^y.
    """
    texture = checked_texture(texture)
    if texture.dimension == 2:
        return _closest_point_surface(texture, p)
    arr = positions(p)
    shape = arr.shape[:-1]
    flat = arr.reshape(-1, 2)
    kind, coeffs = texture.kernel_data()
    aux = search_data(texture)
    t, d, tie, work = _core.closest_profile_points(kind, coeffs, aux, flat[:, 0], flat[:, 1])
    return ClosestPoint(
        x=t.reshape(shape),
        z=texture.height(t).reshape(shape),
        distance=d.reshape(shape),
        tie=(tie != 0).reshape(shape),
        work=work.reshape(shape),
    )


def search_data(texture: Texture) -> np.ndarray:
    """The closest-point search's data for a texture (built once, cached on the texture).

    Parameters
    ----------
    texture : Texture
        A profile (a sum of sinusoids or a sampled profile).

    Returns
    -------
    ndarray, shape (n,)
        Header (``haptex.core._ext.A_*``) and the bound tree: lower and upper bounds of h (m)
        over the 2 n_leaf - 1 dyadic sub-intervals of the core interval; over a sampled
        profile then lower and upper bounds of h'' (1/m) over each leaf (from
        aux[``A_LEAFC``], infinite where h' jumps inside a leaf).

    Raises
    ------
    ParameterError
        If the tree would need more than :data:`MAX_LEAVES` leaves (a texture whose
        period holds more than 500,000 shortest periods) or more than
        ``FOURIER_WORK_LIMIT`` harmonic evaluations to build.
    """
    texture = checked_texture(texture)
    cached = texture.__dict__.get("_search_data")
    if cached is not None:
        return cached
    aux = _build(texture)
    texture.__dict__["_search_data"] = aux
    return aux


def table_search_data(texture: Texture) -> np.ndarray:
    """:func:`search_data` with a cell table appended: the closest-point search of a servo tick
    in a few texture evaluations (built once, cached on the texture).

    The probe positions [x mod period, z] from min h - (2 (max h - min h) + 2 shortest
    period) up to max h are cut into square cells (side: shortest period / 64, or larger to
    stay within ``TABLE_MAX_CELLS``). For each cell the table holds the few pieces of the
    boundary that can contain the closest point of *any* probe in the cell, found with the
    1-Lipschitz bound of the distance, each certified either convex for every probe of the
    cell (a Newton solve finds its minimum) or not (it is scanned as a leaf of the tree)
    (the C core's ``hx_table_cell``, rows built on :func:`haptex.core.num_threads` threads). A
    probe outside the table, or in a cell needing more than ``TABLE_MAXP`` (16) pieces, is
    searched by the tree: the result is the same global closest point either way, only the
    work differs.

    Parameters
    ----------
    texture : Texture
        A profile (the table is built for periodic ones).

    Returns
    -------
    ndarray, shape (n,)
        The search data with aux[``A_TABLE``] the offset of the table (0: no table,
        for textures other than periodic profiles).

    Raises
    ------
    ParameterError
        As :func:`search_data`.
    """
    texture = checked_texture(texture)
    cached = texture.__dict__.get("_table_search_data")
    if cached is not None:
        return cached
    aux = search_data(texture)
    if int(aux[K.A_MODE]) != K.CP_PERIODIC:
        texture.__dict__["_table_search_data"] = aux
        return aux
    nl = int(aux[K.A_NLEAF])
    hmin, hmax = float(aux[K.A_TREE + 1]), float(aux[K.A_TREE + 2 * nl + 1])  # the tree's root bounds
    period, shortest = float(aux[K.A_PERIOD]), texture.shortest_period
    z0 = hmin - 2.0 * (hmax - hmin) - 2.0 * shortest
    w = shortest / TABLE_CELL_DIVISOR
    while True:
        nx = math.ceil(period / w - 1e-9)
        nz = math.ceil((hmax - z0) / (period / nx))
        if nx * nz <= TABLE_MAX_CELLS:
            break
        w *= 1.25
    w = period / nx
    kind, coeffs = texture.kernel_data()
    coeffs = np.ascontiguousarray(coeffs, dtype=np.float64)
    x0 = float(aux[K.A_START])

    def row(j):  # one row of cells a task: a row's scratch, not the whole table's (the C releases the GIL)
        count = np.empty(nx)
        out = np.empty((nx, K.PIECE * K.TABLE_MAXP))
        K.table_cells(kind, coeffs, aux, x0, w, 0, z0 + j * w, hmax, count, out)
        n = count.astype(np.int64)
        return n, out.reshape(nx, K.TABLE_MAXP, K.PIECE)[np.arange(K.TABLE_MAXP)[None, :] < n[:, None]]

    threads = min(_core.num_threads(), nz)
    if threads > 1:
        with ThreadPoolExecutor(threads) as pool:
            built = list(pool.map(row, range(nz)))
    else:
        built = [row(j) for j in range(nz)]
    counts, rows = [b[0] for b in built], [b[1] for b in built]
    count = np.concatenate(counts)
    used = np.maximum(count, 0)
    off = aux.size
    first = off + K.TB_CELLS + 2 * nx * nz + K.PIECE * (np.cumsum(used) - used)
    head = np.zeros(K.TB_CELLS)
    head[[K.TB_X0, K.TB_PERIOD, K.TB_W, K.TB_NX, K.TB_Z0, K.TB_NZ]] = aux[K.A_START], period, w, nx, z0, nz
    table = np.concatenate([aux, head, np.column_stack([first, count]).ravel(), np.concatenate(rows).ravel()])
    table[K.A_TABLE] = off
    texture.__dict__["_table_search_data"] = table
    return table


def _header(texture: Texture) -> np.ndarray:
    head = np.zeros(K.A_TREE)
    head[K.A_TIE] = 1e-9 * texture.shortest_period  # medial-axis ties: a distance scale of the texture
    head[K.A_SLOPE] = texture.max_slope
    head[K.A_CURV] = texture.max_curvature
    if isinstance(texture, SampledProfile):  # h''' is 6 a3 on each interval
        head[K.A_JERK] = float(np.max(np.abs(6.0 * texture._coeffs[0, :texture._m])))
    elif isinstance(texture, SumOfSinusoids):
        head[K.A_JERK] = float(np.sum(texture.amplitudes * texture._coeffs[1] ** 3))
    return head


def _build(texture: Texture) -> np.ndarray:
    if texture.max_slope == 0.0:
        head = _header(texture)
        head[K.A_MODE] = K.CP_VERTICAL
        return head
    if isinstance(texture, SampledProfile):
        return _spline_tree(texture)
    if isinstance(texture, SumOfSinusoids):
        if texture.period is None:
            head = _header(texture)
            step = texture.shortest_period / 64.0
            head[K.A_MODE] = K.CP_OPEN
            head[K.A_STEP] = step
            head[K.A_HMIN] = -float(np.sum(texture.amplitudes))
            head[K.A_WCAP] = OPEN_LEAVES / 2 * 8.0 * step
            return head
        return _fourier_tree(texture)
    raise ParameterError(f"texture = {texture!r} is not allowed: D and E need a haptex texture")


def _leaves_for(count: float, what: str) -> int:
    if not count <= MAX_LEAVES:
        raise ParameterError(
            f"{what} needs {count:.3g} closest-point leaves, which is not allowed: at most "
            f"{MAX_LEAVES} (use a shorter period or a longer shortest period)")
    n = 1
    while n < count:
        n *= 2
    return n


def _tree(head: np.ndarray, lo_leaf: np.ndarray, hi_leaf: np.ndarray, n_leaf: int) -> np.ndarray:
    """Header + heap-ordered min/max tree over n_leaf leaves (empty leaves: +inf / -inf)."""
    lo = np.full(2 * n_leaf, np.inf)
    hi = np.full(2 * n_leaf, -np.inf)
    lo[n_leaf:n_leaf + lo_leaf.size] = lo_leaf
    hi[n_leaf:n_leaf + hi_leaf.size] = hi_leaf
    level = n_leaf
    while level > 1:
        half = level // 2
        lo[half:level] = np.minimum(lo[level:2 * level:2], lo[level + 1:2 * level:2])
        hi[half:level] = np.maximum(hi[level:2 * level:2], hi[level + 1:2 * level:2])
        level = half
    head[K.A_NLEAF] = n_leaf
    head[K.A_HMIN] = lo[1]
    return np.ascontiguousarray(np.concatenate([head, lo, hi]))


def _fourier_tree(tex: SumOfSinusoids) -> np.ndarray:
    period = float(tex.period)
    shortest = tex.shortest_period
    n_leaf = _leaves_for(math.ceil(8 * period / shortest - 1e-9), f"texture = {tex!r}")
    n_harm = tex.amplitudes.size
    if n_leaf * 9 * n_harm > FOURIER_WORK_LIMIT:
        raise ParameterError(
            f"texture = {tex!r} is not allowed for D and E: bounding it takes {n_leaf * 9 * n_harm:.3g} harmonic "
            f"evaluations, more than {FOURIER_WORK_LIMIT:.0e} (fewer harmonics or a shorter period)")
    width = period / n_leaf
    lo = np.empty(n_leaf)
    hi = np.empty(n_leaf)
    head = _header(tex)
    tmin, _ = K.leaf_bounds(K.TEXTURE_FOURIER, np.ascontiguousarray(tex._coeffs, dtype=np.float64), 0.0, width, 8,
                            float(head[K.A_JERK]), lo, hi)
    pad = 1e-13 * float(np.sum(tex.amplitudes))
    head[K.A_MODE] = K.CP_PERIODIC
    head[K.A_START] = 0.0
    head[K.A_PERIOD] = period
    head[K.A_TREELEN] = period
    head[K.A_STEP] = shortest / 64.0
    head[K.A_TMIN] = tmin
    return _tree(head, lo - pad, hi + pad, n_leaf)


#: The most intervals of a spline profile a leaf of its closest-point tree holds. A leaf on which
#: the squared distance is certified convex costs a Newton solve whatever its length; one that
#: is not (about a crest's centre of curvature) is scanned at every node. Measured on the sinusoid
#: (0.2 mm at 2 mm) felt by a ball of 0.99 times its troughs' radius (262,144 samples), over D's
#: q grid (1,025 x 64 probes): at most 8, 32, 128, 1,024 intervals a leaf, 459, 264, 201, 314
#: evaluations a probe on average, 10,424, 16,042, 32,619, 36,218 at most (16,139 on average
#: before leaves were certified convex; 2026-11-28)
LEAF_INTERVALS = 32


def _spline_tree(prof: SampledProfile) -> np.ndarray:
    c = prof._coeffs
    m, dx = prof._m, prof.dx
    a3, a2, a1, a0 = c[0, :m], c[1, :m], c[2, :m], c[3, :m]
    vals = [a0, ((a3 * dx + a2) * dx + a1) * dx + a0]  # the interval's ends
    # interior extrema: roots of 3 a3 t^2 + 2 a2 t + a1 in (0, dx)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        qa, qb, qc = 3 * a3, 2 * a2, a1
        disc = qb * qb - 4 * qa * qc
        sq = np.sqrt(np.maximum(disc, 0.0))
        roots = [((-qb + sq) / (2 * qa), (qa != 0) & (disc >= 0)),
                 ((-qb - sq) / (2 * qa), (qa != 0) & (disc >= 0)),
                 (-qc / qb, (qa == 0) & (qb != 0))]
        for r, valid in roots:
            ok = valid & np.isfinite(r) & (r > 0) & (r < dx)
            r = np.where(ok, r, 0.0)
            vals.append(np.where(ok, ((a3 * r + a2) * r + a1) * r + a0, a0))
    lo_leaf = np.minimum.reduce(vals)
    hi_leaf = np.maximum.reduce(vals)
    # h'' = 6 a3 t + 2 a2 on each interval, its bounds at the interval's ends; a leaf where h'
    # jumps between two of its intervals (beside a felt profile's kink) has none
    c_start, c_end = 2 * a2, 6 * a3 * dx + 2 * a2
    c_lo, c_hi = np.minimum(c_start, c_end), np.maximum(c_start, c_end)
    s_end, s_next = (3 * a3 * dx + 2 * a2) * dx + a1, np.roll(a1, -1)
    jump = ~(np.abs(s_end - s_next) <= 1e-9 * (np.abs(s_end) + np.abs(s_next)) + 1e-15)
    # a leaf holds k intervals, up to half the shortest period and LEAF_INTERVALS (a felt profile
    # refined for its curvature keeps its first grid's band on up to 2^12 times its samples: a
    # leaf an interval made D's search 112 s on the two-tone at 2 rho, 32,768 samples; 46 s),
    # scanned at every node (A_STEP dx, or k dx / 8 below 8 intervals a leaf) unless phi is
    # certified convex on it: between two samples one cubic piece, whose |g''| the header bounds
    # (a felt profile's h'' jumps at its nodes)
    k = 1
    while m % (2 * k) == 0 and 2 * k * dx <= 0.5 * prof.shortest_period * (1 + 1e-9) and 2 * k <= LEAF_INTERVALS:
        k *= 2
    starts = np.arange(0, m, k)
    lo_leaf = np.minimum.reduceat(lo_leaf, starts)
    hi_leaf = np.maximum.reduceat(hi_leaf, starts)
    c_lo, c_hi = np.minimum.reduceat(c_lo, starts), np.maximum.reduceat(c_hi, starts)
    inner = jump.copy()
    inner[k - 1::k] = False  # (a jump at a leaf's end: each side is one leaf's own)
    kinked = np.logical_or.reduceat(inner, starts)
    c_pad = 1e-9 * (np.abs(c_lo) + np.abs(c_hi)) + 1e-300
    c_lo, c_hi = np.where(kinked, -np.inf, c_lo - c_pad), np.where(kinked, np.inf, c_hi + c_pad)
    pad = 1e-13 * float(np.max(np.abs(prof.h)) + 1e-300)
    n_leaf = _leaves_for(m // k, f"texture = {prof!r}")
    head = _header(prof)
    head[K.A_START] = prof.x[0]
    head[K.A_TREELEN] = n_leaf * k * dx
    head[K.A_STEP] = dx if k >= 8 else k * dx / 8.0
    i = int(np.argmin(lo_leaf))
    t_grid = prof.x[0] + i * k * dx + np.linspace(0.0, k * dx, 65)
    head[K.A_TMIN] = float(t_grid[np.argmin(prof.height(t_grid))])
    if prof.periodic:
        head[K.A_MODE] = K.CP_PERIODIC
        head[K.A_PERIOD] = m * dx
    else:
        head[K.A_MODE] = K.CP_FINITE
        head[K.A_X0] = prof.x[0]
        head[K.A_XE] = prof.x[0] + m * dx
        head[K.A_HL], head[K.A_SL], head[K.A_HR], head[K.A_SR] = c[:, m + 1]
    aux = _tree(head, lo_leaf - pad, hi_leaf + pad, n_leaf)
    aux[K.A_LEAFC] = aux.size  # the leaves' bounds of h'' (hx_closest.c: a leaf certified convex is not scanned)
    free = np.full(n_leaf - c_lo.size, np.inf)
    return np.concatenate([aux, c_lo, -free, c_hi, free])


def _closest_point_surface(texture: Texture, p) -> ClosestPoint:
    from .surfaces import Extruded, SampledSurface, SumOfGratings

    arr = positions(p, dim=3)
    shape = arr.shape[:-1]
    if isinstance(texture, Extruded):
        cp = closest_point(texture.profile, arr[..., [0, 2]])
        return ClosestPoint(x=cp.x, z=cp.z, distance=cp.distance, tie=cp.tie, work=cp.work, y=arr[..., 1].copy())
    if not isinstance(texture, SumOfGratings | SampledSurface):
        raise ParameterError(f"texture = {texture!r} is not allowed for D and E: the closest point is searched on "
                             "profiles, sums of gratings, height maps and extruded profiles")
    flat = np.ascontiguousarray(arr.reshape(-1, 3), dtype=np.float64)
    key = None
    if flat.shape[0] >= CACHE_MIN_PROBES:
        import hashlib

        key = hashlib.blake2b(flat.tobytes(), digest_size=16).digest()
        hit = texture.__dict__.setdefault("_closest_cache", {}).get(key)
        if hit is not None:  # (copies: a caller may write into what it gets)
            return ClosestPoint(**{k: v.copy().reshape(shape) for k, v in hit.items()})
    kind, gc, gaux = surface_search_data(texture)
    tx, ty, d, tie, work = _core.closest_surface_points(kind, gc, gaux, flat[:, 0], flat[:, 1], flat[:, 2])
    out = {"x": tx, "z": texture.height_at(np.stack([tx, ty], -1)), "distance": d, "tie": tie != 0, "work": work,
           "y": ty}
    size = 41 * flat.shape[0]  # bytes kept: five float64 arrays and a bool one
    if key is not None and size <= CACHE_BYTES:
        cache = texture.__dict__["_closest_cache"]
        while cache and sum(41 * v["x"].size for v in cache.values()) + size > CACHE_BYTES:
            cache.pop(next(iter(cache)))  # the oldest first
        cache[key] = {k: v.copy() for k, v in out.items()}
    return ClosestPoint(**{k: v.reshape(shape) for k, v in out.items()})


CACHE_MIN_PROBES = 10_000
CACHE_BYTES = 256 * 2**20
"""Closest points over a surface for one set of at least CACHE_MIN_PROBES probes are kept on
the texture, the latest sets up to CACHE_BYTES in all: D and E search the same grids of
probes in an analysis (continuity's; q's region is searched only where it can change q, each
algorithm's own points), and E's are then read, not searched."""


def surface_search_data(texture) -> tuple[int, np.ndarray, np.ndarray]:
    """The compiled surface search's data: the surface kind, its coefficients (a sum of
    gratings: shape (4, n) = amplitudes (m), k_x, k_y (rad/m), phases (rad); a height map: its
    bicubic patches, :meth:`haptex.SampledSurface.patches`), and the constants
    ``G_*`` of :mod:`haptex.core._ext` (lowest and highest height, sup ‖grad h‖, sup ‖H‖, leaf half-width,
    tie tolerance 1e-9 of the shortest wavelength; over a sum of gratings, rigorous bounds
    for the strong-convexity certificate (Newton first) and the search's Taylor
    bound: ``curvature_bound`` >= ||H||_2, sum a ‖k‖ >= ‖grad h‖ and sum a ‖k‖^3 >= the third
    derivatives' norm; over a height map the patches' bounds
    :attr:`haptex.SampledSurface.derivative_bounds`, which hold inside the map: the C search
    applies them to cells wholly inside, block by block from
    :meth:`haptex.SampledSurface.bounds_pyramid` (appended after the ``N_GAUX`` constants, their
    number in ``G_PYRAMID``), and the convexity certificate only to a periodic spline map; over
    a Hermite map (a felt map: ``PATCH_JOINS``) the bounds hold within each patch, no convexity
    certificate, and where its slopes jump (``kinks``) no curvature bound across the lines).
    Cached on the texture.

    Parameters
    ----------
    texture : Surface
        A sum of gratings or a height map (:class:`haptex.SampledSurface`).

    Returns
    -------
    tuple of (int, numpy.ndarray, numpy.ndarray)
        (kind, coefficients, auxiliary data) as the C search reads them; the auxiliary array's
        slots are ``haptex.core._ext.G_*``.
    """
    texture = checked_texture(texture)
    from .surfaces import SampledSurface

    cached = texture.__dict__.get("_surface_search")
    if cached is not None:
        return cached
    kind, gc = texture.kernel_data()
    if isinstance(texture, SampledSurface):
        leaf = max(texture.dx, texture.dy)  # one sample interval: a bicubic patch
    else:
        leaf = texture.shortest_period / LEAF_DIVISOR
    gaux = np.zeros(K.N_GAUX)
    gaux[K.G_HMIN], gaux[K.G_HMAX] = texture.height_range
    gaux[K.G_SLOPE] = texture.max_slope
    gaux[K.G_CURV] = texture.max_curvature
    gaux[K.G_LEAF] = leaf
    gaux[K.G_TIE] = 1e-9 * texture.shortest_period
    if kind == K.SURFACE_GRATINGS:  # rigorous bounds: the convexity certificate's and the Taylor bound's
        k = np.hypot(gc[1], gc[2])
        a = np.abs(gc[0])
        gaux[K.G_CONVEX] = gaux[K.G_CURV_BOUND] = texture.curvature_bound
        gaux[K.G_SLOPE_BOUND] = float(np.sum(a * k))
        gaux[K.G_JERK] = float(np.sum(a * k ** 3))
    else:  # a height map: the patches' rigorous bounds, valid inside the map (everywhere if periodic)
        gaux[K.G_SLOPE_BOUND], gaux[K.G_CURV_BOUND], gaux[K.G_JERK] = texture.derivative_bounds
        joins = texture.patches()[0, K.PATCH_JOINS]
        hermite = joins != K.JOINS_SPLINE  # bounds within each patch only
        if hermite and (texture.kinks.size or joins == K.JOINS_BRANCHED):
            # (slopes that jump: no curvature bounds a cell across a kink or a branched cell)
            gaux[K.G_CURV] = 1e300  # (aux must be finite: the spread S r is then the bound)
        if texture.periodic:  # the convexity certificate needs the bound on the whole plane (a spline's)
            gaux[K.G_CONVEX] = 0.0 if hermite else gaux[K.G_CURV_BOUND]
        else:  # and beyond the edges, the tangent-plane extension's
            gaux[K.G_EDGE:K.G_EDGE + 4 * K.N_E] = texture.edge_bounds.ravel()
        # (a plane has no third derivative: a tiny J keeps it on the Taylor bounds' path)
        gaux[K.G_JERK] = max(gaux[K.G_JERK], 1e-300)
        pyramid = texture.bounds_pyramid()  # the same bounds block by block, for cells inside the map
        gaux[K.G_PYRAMID] = pyramid.size
        gaux = np.concatenate([gaux, pyramid])
    texture.__dict__["_surface_search"] = (kind, gc, gaux)
    return kind, gc, gaux


LEAF_DIVISOR = 16
"""A surface search's leaves are cells of half-width shortest wavelength / LEAF_DIVISOR."""
