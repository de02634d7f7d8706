"""The characteristic number q = sup ||J||_2 / kappa_0 over the rendering region (eq. 5),
with its closed forms and F's presliding bounds (Campion & Hayward, Sections III-IV)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np

from .._maximise import refine as _refine
from .._validation import fail, nonnegative, whole
from ..algorithms import Algorithm, checked_algorithm
from ..closest import ClosestPoint, closest_point
from ..textures import Flat, Sinusoid, Texture
from ._region import _plane_ranges, _region_points, check_analysis_scale


# ------------------------------------------------------------------------------------
# characteristic number
# ------------------------------------------------------------------------------------
SURFACE_GRID_PER_PERIOD = {"direct": 32, "distance": 8}


MAX_RESOLUTION = (8192, 1024)
"""The largest ``resolution`` of :func:`characteristic_number`'s first grid (chosen: n_x as many
cells as a profile's grid ever takes, 64 a shortest period up to 8,192; n_depth 16 times the
default's 64)."""


def _q_plan(algorithm: Algorithm, x_range, resolution) -> tuple[list, list[int], int]:
    """(in-plane ranges (m), cells per in-plane axis, depth samples) of the grid
    :func:`characteristic_number` searches first (F's and D's and E's searches over a surface
    adapt it further)."""
    allowed = (f"a pair (n_x, n_depth) of whole numbers, 8 <= n_x <= {MAX_RESOLUTION[0]} and 4 <= n_depth <= "
               f"{MAX_RESOLUTION[1]}")
    try:
        nx, nd = resolution
        nx, nd = whole("resolution", nx, 8, MAX_RESOLUTION[0]), whole("resolution", nd, 4, MAX_RESOLUTION[1])
    except (TypeError, ValueError):  # (not a pair, or a ParameterError naming one of its numbers)
        raise fail("resolution", resolution, allowed) from None
    ranges = _plane_ranges(algorithm, x_range)
    tex = algorithm.texture
    if tex.dimension == 2:  # a surface: a 3-D grid, kept to ~10^6 points (refinement does the rest)
        # D and E: every point a closest-point search, and ||J|| monotone along each normal
        nd = max(4, nd // (8 if algorithm.penetration_kind == "distance" else 4))
        per = SURFACE_GRID_PER_PERIOD["distance" if algorithm.penetration_kind == "distance" else "direct"]
        counts = [int(min(max(32, math.ceil(per * (b - a) / tex.shortest_period)), 256)) for a, b in ranges]
    else:
        counts = [nx]
        if not isinstance(tex, Flat):
            # at least 64 grid cells per shortest period, so every local maximum has its cell
            counts = [int(min(max(nx, math.ceil(64 * (ranges[0][1] - ranges[0][0]) / tex.shortest_period)), 8192))]
    return ranges, counts, nd


def _friction_plan(alg, ranges, counts, nd) -> tuple[list[int], int, int, int]:
    """(plane cells, depth samples, deflection angles, radii) of F's grid over a surface
    (angles and radii unused over a profile: 33 stick deflections and 2 slips)."""
    n_ang, n_rad = 16, 5
    if len(ranges) == 2 and math.prod(c + 1 for c in counts) * nd * (1 + (n_rad - 1) * n_ang) > F_SURFACE_GRID_POINTS:
        # a map many periods wide: coarser depth and deflection samples (the refinement
        # polishes all five variables), then a coarser plane grid, not below 4 cells a period
        nd, n_ang, n_rad = max(4, nd // 2), 8, 3
        per_point = nd * (1 + (n_rad - 1) * n_ang)
        shrink = math.sqrt(F_SURFACE_GRID_POINTS / per_point / math.prod(c + 1 for c in counts))
        floor = [math.ceil(4 * (b - a) / alg.texture.shortest_period) for a, b in ranges]
        counts = [max(16, f, min(c, int(c * shrink))) for c, f in zip(counts, floor)]
    return counts, nd, n_ang, n_rad


def characteristic_points(algorithm: Algorithm, max_penetration: float = 1e-3, x_range=None,
                          resolution=(256, 64)) -> int:
    """Field evaluations of the grid :func:`characteristic_number` searches first (its plan,
    not run; the refinement of the best cells adds a few hundred): what its cost follows. For D
    and E these are Jacobians at each point's foot, with a closest-point search only where the
    region can change q (at least :data:`REGION_FIRST` of them).

    Parameters
    ----------
    algorithm : Algorithm
        Any of W, A-G.
    max_penetration : float, optional
        Depth of the rendering region below the lowest valley (m), default 1 mm.
    x_range : (float, float), optional
        The region along x (m) instead of one period (or the texture's domain).
    resolution : (int, int), optional
        The search grid's points along x and z.

    Returns
    -------
    int
        Field evaluations.

    Raises
    ------
    ParameterError
        As :func:`characteristic_number`.
    """
    algorithm = checked_algorithm(algorithm)
    check_analysis_scale(algorithm, max_penetration)
    ranges, counts, nd = _q_plan(algorithm, x_range, resolution)
    if algorithm.has_memory and algorithm.penetration_kind != "distance":  # F: a deflection per grid point too
        if algorithm.texture.dimension == 2:
            counts = [max(16, c // 2) for c in counts]
        counts, nd, n_ang, n_rad = _friction_plan(algorithm, ranges, counts, nd)
        per = 35 if len(ranges) == 1 else 1 + (n_rad - 1) * n_ang + n_ang  # stick and slip deflections
        return math.prod(c + 1 for c in counts) * nd * per
    return math.prod(c + 1 for c in counts) * nd
"""Grid cells per shortest texture period along x and y of q's search grid over a surface
(at least 32 a side, at most 256), before the refinement: 32 for fields evaluated directly;
8 for D and E, whose norm varies with the boundary's curvature, which a texture band-limited
to that period holds on no shorter scale (chosen when every grid point was a closest-point
search, 5-90 us a point over a bicubic height map, growing with the depth: over the 14 x 10
cut-off periods of a MetroPro map, 32 made 1.06 million searches; now each point is a
Jacobian at its foot and only the region's best points are searched, :func:`_region_candidates`)."""


def spectral_norm(j) -> np.ndarray:
    """Largest singular value of 2x2 or 3x3 matrices.

    Parameters
    ----------
    j : array_like, shape (..., 2, 2) or (..., 3, 3)

    Returns
    -------
    ndarray, shape (...)
        sigma_max(J), in the units of J: for 2x2 in closed form,
        sqrt((‖J‖_F^2 + sqrt(‖J‖_F^4 - 4 det(J)^2)) / 2); for 3x3 as the square root of the
        largest eigenvalue of J^T J in closed form (the trigonometric solution of its
        characteristic cubic; O. K. Smith, "Eigenvalues of a symmetric 3 x 3 matrix",
        Commun. ACM 4(4), 1961). Where the two largest eigenvalues nearly coincide (the cubic's
        cosine within SPECTRAL_REFINE of -1, where the closed form keeps only about half the
        digits), where J is zero or past about 1e50 or 1e-50 in its units, it is LAPACK's
        symmetric solver's instead. Within a few ulp of the SVD's either way
        (``tests/test_algorithms.py``).

    Raises
    ------
    ParameterError
        If ``j`` is not an array of that shape (numbers).
    numpy.linalg.LinAlgError
        Where a 3x3 J holds a NaN (LAPACK's solver does not converge).
    """
    given = j
    try:
        j = np.asarray(j, dtype=np.float64)
    except (TypeError, ValueError):
        j = None
    if j is None or j.shape[-2:] not in ((2, 2), (3, 3)):
        raise fail("j", f"an array of shape {j.shape}" if j is not None and j.ndim else given,
                   "an array of shape (..., 2, 2) or (..., 3, 3) (Jacobians, as Algorithm.jacobian returns them)")
    if j.shape[-2:] == (2, 2):
        fro2 = np.sum(j * j, axis=(-2, -1))
        det = j[..., 0, 0] * j[..., 1, 1] - j[..., 0, 1] * j[..., 1, 0]
        disc = np.sqrt(np.maximum(fro2 * fro2 - 4 * det * det, 0.0))
        return np.sqrt(0.5 * (fro2 + disc))
    with np.errstate(all="ignore"):  # (out of range or not finite: LAPACK's below)
        c0, c1, c2 = ([j[..., 0, k], j[..., 1, k], j[..., 2, k]] for k in range(3))  # (J's columns)
        a00, a11, a22 = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] for x in (c0, c1, c2))
        a01, a02, a12 = (x[0] * y[0] + x[1] * y[1] + x[2] * y[2] for x, y in ((c0, c1), (c0, c2), (c1, c2)))
        mean = (a00 + a11 + a22) / 3
        b00, b11, b22 = a00 - mean, a11 - mean, a22 - mean
        p = np.sqrt((b00 * b00 + b11 * b11 + b22 * b22 + 2 * (a01 * a01 + a02 * a02 + a12 * a12)) / 6)
        det = b00 * (b11 * b22 - a12 * a12) - a01 * (a01 * b22 - a12 * a02) + a02 * (a01 * a12 - b11 * a02)
        c = np.clip(0.5 * det / (p * p * p), -1.0, 1.0)
        lam = mean + 2 * p * np.cos(np.arccos(c) / 3)
    # (LAPACK's where the closed form is not sound: two largest nearly equal, the cosine's slope
    # unbounded there; p^3 past the doubles' range, J above about 1e50 or below 1e-50 in its
    # units, zero included; and any entry not finite, which LAPACK refuses as it always did)
    other = ~((c > -1.0 + SPECTRAL_REFINE) & (p > 1e-100) & (p < 1e100))
    if np.any(other):
        lam = np.array(lam, dtype=np.float64, copy=True)
        lam[other] = np.linalg.eigvalsh(np.swapaxes(j[other], -1, -2) @ j[other])[..., -1]
    return np.sqrt(np.maximum(lam, 0.0))


SPECTRAL_REFINE = 1e-6
"""How near -1 the cosine of :func:`spectral_norm`'s closed form may come before its 3x3
matrices' largest eigenvalue is LAPACK's instead: there an error of eps in the cosine moves
the eigenvalue by about eps / (3 sqrt(2 delta)) of its scale, delta the distance from -1
(chosen: 1e-6 keeps that below 3e-14)."""


@dataclass(frozen=True)
class CharacteristicNumber:
    """Result of :func:`characteristic_number`.

    Parameters
    ----------
    letter : str
        Algorithm letter.
    value : float
        Numeric q = sup ||J||_2 / kappa_0 over the rendering region (eq. 5); ``inf``
        when the sup is unbounded (algorithm D below peaks whose radius of curvature is
        within the region).
    closed_form : float or None
        The paper's value where it gives one: A, eq. 10 (with 2 pi A / l replaced by the
        Lipschitz bound M for other textures, Remark 2); D, 1 (eq. 18); E, 1 (eq. 21);
        W, 1 (eq. 30). ``None`` for B, C, G ("no closed form", Table II).
    where : tuple of float
        Probe position [x, z] (m) attaining the sup (the centre of curvature for an
        unbounded D).
    max_penetration : float
        Depth bound of the region searched (m).
    note : str
        How the value was obtained, in one sentence; on a texture felt by a ball whose
        curvature misses the ball path's by more than 1 % where q reads it (its ``peak_miss``
        or ``curvature_miss`` for B, C and G, its ``convex_miss`` for D), by how much, and how
        far q on the path may then be.
    paper_form_value : float or None
        For D only: the sup of the eq. 18 (flat-boundary) Jacobian, which is 1.
    extra : dict
        For F: ``phase`` and ``deflection`` (m) at the sup, ``bound_eq26`` (the norm of
        the matrix of eq. 26 over kappa_0), ``eq31_as_printed`` (Appendix I's expression
        evaluated literally), ``paper_reported`` (8.3, Section V-A) and the parameters
        those were evaluated with.
    """

    letter: str
    value: float
    closed_form: float | None
    where: tuple[float, float]
    max_penetration: float
    note: str = ""
    paper_form_value: float | None = None
    extra: dict = field(default_factory=dict)

    def __float__(self) -> float:
        return float(self.value)

    @property
    def unbounded(self) -> bool:
        """True when the sup is infinite."""
        return math.isinf(self.value)


def _closed_form_q(alg: Algorithm) -> float | None:
    if alg.letter == "A":
        return math.sqrt(1.0 + alg.texture.max_slope**2)
    if alg.letter in ("D", "E", "W"):
        return 1.0
    return None


def characteristic_number(
    algorithm: Algorithm,
    max_penetration: float = 1e-3,
    x_range=None,
    resolution: tuple[int, int] = (256, 64),
) -> CharacteristicNumber:
    """Characteristic number q = sup ||J_f||_2 / kappa_0 of an algorithm (eq. 5).

    The sup is taken over probe positions inside the wall whose penetration, measured
    the way the algorithm measures it (Table I), lies in (0, ``max_penetration``], and
    whose abscissa spans one texture period (or ``x_range``). A grid of
    ``resolution = (n_x, n_depth)`` points is searched first, then the best grid points
    are refined by bounded quasi-Newton maximisation inside their grid cells, so the
    result is the sup and not a grid sample. For an algorithm that reads the slope (B, C, G:
    its Jacobian reads h'') over a sampled profile the refinement also starts from the best of
    both ends of every interval, where its spline's h'' (linear on each) peaks, at the
    shallowest and the deepest depth (these Jacobians are affine in the depth, so their norms
    peak at its ends: :func:`_node_starts`); over a sampled map the refinement also starts
    from the map's own steepest points (:meth:`~haptex.SampledSurface.steepest_points`, within
    one sample interval), since a map finer than the plane grid may peak within a sample.

    Parameters
    ----------
    algorithm : Algorithm
        A memoryless algorithm (W, A–E, G).
    max_penetration : float, optional
        Depth bound d_max (m), default 1 mm (the paper's d^z_max).
    x_range : (float, float), optional
        Abscissa interval (m); required for an aperiodic texture.
    resolution : (int, int), optional
        Grid size along x and along depth.

    Returns
    -------
    CharacteristicNumber

    Raises
    ------
    ParameterError
        If ``max_penetration`` <= 0, ``x_range`` is malformed or missing for an
        aperiodic texture, or the resolution is not a pair of whole numbers from (8, 4) to
        :data:`MAX_RESOLUTION`.

    Notes
    -----
    For D the exact Jacobian (including the boundary's curvature) is
    -kappa_0 (I - v v^T / D) with v = [1, h'] and D = 1 + h'^2 + (h - p^z) h''; its norm
    is kappa_0 max(1, (1 + h'^2) / D - 1), which grows without bound as the probe
    approaches the centre of curvature below a peak (D -> 0). When the smallest radius
    of curvature of a convex-up part of the boundary is shallower than
    ``max_penetration`` (for the paper's sinusoid, l^2 / (4 pi^2 A) = 32 um), the sup is
    therefore infinite; ``value`` is ``inf`` and ``where`` is that centre of curvature.
    The paper's value 1 is the sup of the flat-boundary linearisation eq. 18, reported
    in ``paper_form_value``.

    Examples
    --------
    Algorithm A's closed form sqrt(1 + (2 pi A / l)^2) (Section IV-A):

    >>> q = hx.characteristic_number(hx.algorithm("A", hx.Sinusoid(0.8e-3, 1e-3), 2000.0))
    >>> round(q.value, 4), round(q.closed_form, 4)
    (5.1251, 5.1251)
    """
    algorithm = checked_algorithm(algorithm)
    return _stated_miss(_searched_q(algorithm, max_penetration, x_range, resolution), algorithm.texture)


def _stated_miss(q: CharacteristicNumber, tex) -> CharacteristicNumber:
    """``q`` with its note saying, on a felt texture whose refinement stopped short of its
    slack (1 %, ``haptex.surfaces.CURVATURE_SLACK``), by how much the texture's curvature misses
    the ball path's where ``q`` reads it: the largest (``peak_miss``, or a profile's
    ``curvature_miss``) for B, C and G, which read it (eqs. 11, 14, 28), q on the path about as
    far, or, where the texture's largest is short of the path's largest found (its
    ``path_curvature``, a lower bound of the path's sup), their ratio, q on the path as many
    times this one or more; the most convex (``convex_miss``) for D, q = d_max / (R - d_max) below a convex point of
    radius R (eq. 18), on the path about ``convex_miss`` (1 + q) from it."""
    from ..algorithms import ALGORITHMS
    from ..surfaces import CURVATURE_SLACK, _shortfall

    if q.letter in ALGORITHMS and ALGORITHMS[q.letter].reads_slope:  # (B, C, G: the registry's)
        name = "peak_miss" if getattr(tex, "peak_miss", None) is not None else "curvature_miss"
        said = "largest"
    elif q.letter == "D":
        name, said = "convex_miss", "most convex"
    else:
        return q
    miss = getattr(tex, name, None)
    if miss is None or not miss > CURVATURE_SLACK:
        return q
    top = getattr(tex, "path_curvature", None) if q.letter != "D" else None
    ratio = _shortfall(top, float(tex.max_curvature)) if top is not None else None
    if ratio is not None:  # (short of the path's: a ratio, which a fraction < 1 hides)
        off = (f", short of it: the path's largest found is {ratio:.3g} times the felt texture's, and q on the "
               "ball's path may be as many times this one or more")
    elif q.letter != "D":
        off = "; q on the ball's path may differ from this one by about as much"
    elif math.isfinite(q.value):
        off = f"; q on the ball's path may differ from this one by about {miss * (1 + q.value):.3g} of it"
    else:
        off = ""
    return replace(q, note=f"{q.note}; the felt texture's {said} curvature misses the ball path's by "
                            f"{miss:.3g} of it ({name}){off}")


def _searched_q(algorithm, max_penetration, x_range, resolution) -> CharacteristicNumber:
    """:func:`characteristic_number`'s search, its arguments as there."""
    dmax = check_analysis_scale(algorithm, max_penetration)
    ranges, counts, nd = _q_plan(algorithm, x_range, resolution)
    tex = algorithm.texture
    k0 = algorithm.stiffness
    closed = _closed_form_q(algorithm)

    on_object = hasattr(algorithm, "region_points")
    if algorithm.penetration_kind == "distance" and not on_object:
        if tex.dimension == 2:
            return _q_distance_surface(algorithm, dmax, ranges, counts, nd, closed, x_range, resolution)
        return _q_distance(algorithm, dmax, *ranges[0], counts[0], nd, closed)
    if algorithm.has_memory:
        if tex.dimension == 2:  # a 5-D search (x, y, depth, deflection): a coarser plane grid
            counts = [max(16, c // 2) for c in counts]
        return _q_friction(algorithm, dmax, ranges, counts, nd)

    axes = [np.linspace(a, b, n + 1) for (a, b), n in zip(ranges, counts)]
    ds = np.linspace(dmax / nd, dmax, nd)
    mesh = np.meshgrid(*axes, ds, indexing="ij")
    plane_pts = np.stack(mesh[:-1], axis=-1)
    if on_object and algorithm.letter == "D":
        focus = _object_focus(algorithm, plane_pts[..., 0, :], dmax)
        if focus is not None:
            rho, point = focus
            return CharacteristicNumber(
                "D", math.inf, closed, tuple(float(v) for v in point), dmax,
                f"unbounded: ||J|| -> inf approaching the centre of curvature at {rho:.4g} m below a convex-up "
                f"point of the textured object (< max_penetration {dmax:g} m)")
    norms = spectral_norm(algorithm.jacobian(_region_points(algorithm, plane_pts, mesh[-1]))) / k0
    dd = dmax / nd

    def neg_q(v):  # (k, d): the plane's coordinates and the depth a row
        p = _region_points(algorithm, v[:, :-1], v[:, -1])
        return -spectral_norm(algorithm.jacobian(p)) / k0

    start = [r[0] for r in ranges] + [dmax]
    best, where_pt = -np.inf, tuple(start)
    for idx in _candidates(norms):
        ijk = np.unravel_index(idx, norms.shape)
        pt = [axes[a][ijk[a]] for a in range(len(axes))] + [ds[ijk[-1]]]
        bounds = [(ax[max(i - 1, 0)], ax[min(i + 1, ax.size - 1)]) for ax, i in zip(axes, ijk)]
        bounds.append((max(dd * 1e-6, pt[-1] - dd), min(dmax, pt[-1] + dd)))
        val, found = _refine(neg_q, pt, norms[ijk], bounds)
        if val > best:
            best, where_pt = val, found
    # a sampled map finer than the plane grid may peak within a sample (a felt map beside its
    # kinks, a bump one sample wide): the refinement starts from its own steepest points too,
    # at the shallowest and the deepest depth, within one sample interval and one depth step
    steepest = getattr(tex, "steepest_points", None)
    if steepest is not None and tex.dimension == 2 and not on_object:
        step = (tex.dx, tex.dy)
        for p in steepest():
            if not all(a <= v <= b for v, (a, b) in zip(p, ranges)):
                continue
            for depth in (ds[0], dmax):
                pt = [float(p[0]), float(p[1]), float(depth)]
                bounds = [(v - e, v + e) for v, e in zip(pt[:2], step)]
                bounds.append((max(dd * 1e-6, depth - dd), min(dmax, depth + dd)))
                val, found = _refine(neg_q, pt, None, bounds)
                if val > best:
                    best, where_pt = val, found
    # (a profile's algorithm that reads the slope reads h'' too; on an object a profile is
    # Extruded, a surface)
    if tex.dimension == 1 and getattr(algorithm, "reads_slope", True):
        for pt, value, step in _node_starts(algorithm, ranges[0], (ds[0], dmax)):
            a, b = ranges[0]
            bounds = [(max(a, pt[0] - step), min(b, pt[0] + step)),
                      (max(dd * 1e-6, pt[1] - dd), min(dmax, pt[1] + dd))]
            val, found = _refine(neg_q, pt, value, bounds)
            if val > best:
                best, where_pt = val, found
    where = _region_points(algorithm, np.array(where_pt[:-1])[None, :], np.array([where_pt[-1]]))[0]
    grid = "x".join(str(n) for n in counts + [nd])
    extent = " and ".join(f"{name} in [{a:g}, {b:g}] m" for name, (a, b) in zip("xy", ranges))
    return CharacteristicNumber(
        letter=algorithm.letter,
        value=best,
        closed_form=closed,
        where=tuple(float(v) for v in where),
        max_penetration=dmax,
        note=f"grid {grid} over {extent} and depth in (0, {dmax:g}] m, refined by L-BFGS-B",
    )


NODE_STARTS = 8
"""How many of a sampled profile's interval ends start q's refinement (chosen: as many as the
plane grid's own local maxima, :func:`_candidates`)."""


def _node_starts(algorithm, x_range, depths, count: int = NODE_STARTS, chunk: int = 1 << 16) -> list:
    """The ``count`` best starts (x, depth) (m) of q's refinement among the ends of a sampled
    profile's intervals (each node just either side, in x_range, repeated by its period) at the
    two depths given: [((x, depth), ||J|| / kappa_0 there, the interval (m)), ...], best first;
    empty for a texture without nodes. A cubic segment's h'' is linear, so B's, C's and G's
    Jacobians (made of h' and h'', affine in the depth) peak at an interval's end and at the
    depth range's ends: one sample wide where a felt profile follows a spike of the path's
    curvature (the two-tone at 1.05 times its troughs' radius: the uniform grid's 8,192 points
    and their refinement read q of C 303 where the segments reach 444). Evaluated ``chunk``
    points at a time: memory of a chunk whatever the profile's length."""
    tex = algorithm.texture
    nodes = getattr(tex, "x", None)
    if nodes is None or nodes.size < 2:
        return []
    a, b = (float(v) for v in x_range)
    step = float(nodes[1] - nodes[0])
    eps = 1e-9 * step
    period = getattr(tex, "period", None)
    if period:
        k = np.arange(math.floor((a - nodes[-1]) / period), math.ceil((b - nodes[0]) / period) + 1)
        nodes = (nodes[None, :] + period * k[:, None]).ravel()
    ends = np.concatenate([nodes + eps, nodes - eps])
    ends = ends[(ends > a) & (ends < b)]
    k0 = algorithm.stiffness
    best = []  # (value, x, depth)
    for depth in depths:
        for i in range(0, ends.size, chunk):
            e = ends[i:i + chunk]
            v = spectral_norm(algorithm.jacobian(_region_points(algorithm, e[:, None], np.full(e.size, depth)))) / k0
            top = np.argsort(np.where(np.isfinite(v), v, -np.inf), kind="stable")[-count:]
            best += [(float(v[j]), float(e[j]), float(depth)) for j in top]
    best.sort(reverse=True)
    return [((x, d), v, step) for v, x, d in best[:count]]


def _object_focus(alg, ut, dmax: float):
    """D over an object: (rho, centre) of the nearest centre of curvature within ``dmax``
    below the textured surface over the grid ``ut`` (n1, n2, 2) of surface coordinates whose
    surface point is still the closest point there (D's Jacobian is unbounded approaching it);
    None if there is none. rho is minimised from the grid's local minima within a grid step."""
    rho = alg.focal_points(ut)[0]
    steps = [float(ut[1, 0, 0] - ut[0, 0, 0]), float(ut[0, 1, 1] - ut[0, 0, 1])]

    def rho_at(v):  # (a finite stand-in where nothing is convex up, for the minimiser)
        r = float(alg.focal_points(np.asarray(v)[None, :])[0][0])
        return r if math.isfinite(r) else 1.0

    from scipy import optimize

    for idx in _candidates(-rho):
        i, j = np.unravel_index(idx, rho.shape)
        if not rho[i, j] <= 2.0 * dmax:  # (candidates come nearest first)
            break
        start = ut[i, j]
        r = optimize.minimize(rho_at, x0=start, method="L-BFGS-B",
                              bounds=[(v - h, v + h) for v, h in zip(start, steps)])
        u_min = r.x if r.fun < rho[i, j] else start
        value, point = alg.focal_points(u_min[None, :])
        if value[0] <= dmax and alg.closest_points(point)[1][0] >= value[0] * (1 - 1e-6):
            return float(value[0]), point[0]
    return None


def _candidates(values: np.ndarray, count: int = 8) -> np.ndarray:
    """Flat indices of the ``count`` largest local maxima of a 2-D or 3-D grid, best first."""
    from scipy import ndimage

    finite = np.where(np.isfinite(values), values, -np.inf)
    peaks = (ndimage.maximum_filter(finite, size=3, mode="nearest") == finite) & np.isfinite(finite)
    labels, n = ndimage.label(peaks, structure=np.ones((3,) * values.ndim))
    if n == 0:
        return np.array([int(np.argmax(finite))])
    # one candidate per connected plateau of local maxima (its points equal), so ties do not
    # crowd out others: its first point in C order (ndimage.maximum_position's choice among
    # equal points follows numpy's argsort, whose order of ties depends on the CPU)
    at = np.flatnonzero(labels)
    _, first = np.unique(labels.ravel()[at], return_index=True)
    idx = at[first]
    order = np.argsort(-finite.ravel()[idx], kind="stable")  # (equal maxima in the grid's order)
    return idx[order[:count]]


REGION_FIRST = 512
"""Grid points whose region D's and E's q decides first (closest-point searches), where ||J|| at
the foot is largest (:func:`_region_candidates`; chosen: on the felt egg-crate at 0.5 and 0.95
times its bowls' radius and a sampled one, the best 8 maxima settled within them)."""


def _region_candidates(values: np.ndarray, unique, count: int = 8, first: int = REGION_FIRST):
    """:func:`_candidates` of ``values`` where ``unique`` holds (the region), deciding
    ``unique`` only where it can change them. A point is a local maximum of the region's grid
    when it is in the region and no neighbour in the region is larger, so a point with a larger
    neighbour known to be in the region can never be one: it is left undecided. The others are
    decided in decreasing order of their values, in batches that double from ``first``, each
    with its larger neighbours (so that a decided point's standing is final), until ``count``
    maxima are settled and every point still open is smaller than the last of them (or no
    point is open). D's and E's region (the foot its unique closest point) costs a
    closest-point search a point; ||J|| at the foot costs none.

    Parameters
    ----------
    values : ndarray, shape (n_1, ..., n_k)
        ||J|| / kappa_0 at each grid point's foot; NaN and inf (a centre of curvature) are
        never maxima, and decided only if no point of the region is found otherwise.
    unique : callable
        ``unique(idx)``: bool array, shape (len(idx),), for flat indices ``idx`` into ``values``.
    count : int, optional
        How many maxima (:func:`_candidates`' ``count``).
    first : int, optional
        The first batch's size.

    Returns
    -------
    candidates : ndarray of int
        Flat indices, best first: ``_candidates(np.where(region, values, -inf), count)`` with
        every point decided.
    region : ndarray of bool, shape of ``values``
        True where a point was decided and is in the region (some point is, if any is).
    checked : int
        The points decided.
    """
    from scipy import ndimage

    shape = values.shape
    key = np.where(np.isfinite(values), values, -np.inf)
    decided = np.zeros(shape, dtype=bool)
    region = np.zeros(shape, dtype=bool)
    masked = np.full(shape, -np.inf)
    checked, batch = 0, first
    while True:
        # open: undecided, finite, and no larger neighbour known to be in the region
        blocked = ndimage.maximum_filter(masked, size=3, mode="constant", cval=-np.inf) > key
        open_ = ~decided & np.isfinite(key) & ~blocked
        cands = _candidates(masked, count)
        if region.any() or decided.all():
            if cands.size >= count and np.isfinite(masked.ravel()[cands[-1]]):
                open_ &= key >= masked.ravel()[cands[-1]]
            if not open_.any():
                return cands, region, checked
        if not open_.any():  # (no point of the region yet: the rest decides whether it has one)
            open_ = ~decided
        pick = np.flatnonzero(open_)
        pick = pick[np.argsort(-key.ravel()[pick], kind="stable")[:batch]]
        chosen = np.zeros(shape, dtype=bool)
        chosen.ravel()[pick] = True
        # with their larger undecided neighbours: a chosen point's standing is then final
        least = ndimage.minimum_filter(np.where(chosen, key, np.inf), size=3, mode="constant", cval=np.inf)
        chosen |= ~decided & (key > least)
        idx = np.flatnonzero(chosen)
        on = np.asarray(unique(idx), dtype=bool)
        decided.ravel()[idx] = True
        region.ravel()[idx] = on
        masked.ravel()[idx[on]] = key.ravel()[idx[on]]
        checked += idx.size
        batch *= 2


MAX_FRICTION_DEPTH = 1.0
"""The largest ``depth`` (m) :func:`friction_bounds` takes (chosen: a thousand times the paper's
d^z_max; eq. 31 as printed holds (mu^4 p^z)^4 terms, which overflow a double past about 1e75 m)."""


def friction_bounds(algorithm, depth: float) -> dict:
    """The paper's bounds on q_F: eq. 26's matrix norm and Appendix I's eq. 31 as printed.

    Both are evaluated with the paper's reading of F: A the dimensionless modulation depth
    (h in [0, 1]), l the texture period (the shortest period for other textures; for them
    2 pi A / l is replaced by the modulation's Lipschitz bound, Remark 2), p^z = ``depth``.

    Parameters
    ----------
    algorithm : Algorithm
        Algorithm F.
    depth : float
        ‖p^z‖ at which the bounds are evaluated (m), the paper's d^z_max.

    Returns
    -------
    dict
        ``bound_eq26``: ||[[2 mu p^z (1/d^x_max + pi A / l), 2 mu], [0, 1]]||_2;
        ``eq31_as_printed``: eq. 31 evaluated term by term as printed (its exponents such
        as (mu^4 p^z)^4 are kept, although they make it differ from the norm it bounds);
        ``eq31_corrected``: eq. 31 with the inner root replaced by the closed form of the
        2x2 singular value, which equals ``bound_eq26``.

    Raises
    ------
    ParameterError
        If ``algorithm`` is not one, or ``depth`` is not a number from 0 to
        :data:`MAX_FRICTION_DEPTH`.
    """
    algorithm = checked_algorithm(algorithm)
    mu = algorithm.friction
    dm = algorithm.presliding
    P = nonnegative("depth", depth, "m")
    if P > MAX_FRICTION_DEPTH:
        raise fail("depth", depth, f"at most {MAX_FRICTION_DEPTH:g} m (MAX_FRICTION_DEPTH)")
    K = 0.5 * algorithm.modulation_max_slope  # pi A / l for h~ = A sin(2 pi x / l)
    a = 2 * mu * P * (1 / dm + K)
    b = 2 * mu
    eq26 = float(spectral_norm(np.array([[a, b], [0.0, 1.0]])))
    r = K * dm
    D = dm
    outer = 4 * (mu * P) ** 2 + 8 * (mu * P) ** 2 * r + 4 * (mu * P * r) ** 2 + 4 * (mu * D) ** 2 + D**2
    inner = (16 * (mu**4 * P) ** 4 + 32 * mu**2 * (mu**2 * D * P) ** 2 + 64 * (mu * P) ** 4 * r + D**4
             + 96 * (mu * P) ** 4 * r**2 + 64 * (mu * P) ** 4 * r**3 + 64 * mu**4 * D**3 * P**2 * K
             - 16 * D**3 * (mu * P) ** 2 * K + 16 * (mu * P * r) ** 4 + 32 * (mu**4 * D) ** 4 * (P * K) ** 2
             - 8 * D**4 * (mu * P * K) ** 2 + 16 * (mu * D) ** 4 + 8 * mu**2 * D**4 - 8 * (mu * P * D) ** 2)
    eq31 = math.sqrt(2) / (2 * D) * math.sqrt(outer + math.sqrt(inner)) if inner >= 0 else math.nan
    s2 = outer / D**2
    corrected = math.sqrt(0.5 * (s2 + math.sqrt(max(s2 * s2 - 4 * a * a, 0.0))))
    return {"bound_eq26": eq26, "eq31_as_printed": eq31, "eq31_corrected": corrected,
            "evaluated_with": {"mu": mu, "presliding": dm, "p_z": P, "pi_A_over_l": K}}


F_SURFACE_GRID_POINTS = 2**20
"""Most points (position x depth x deflection) of q_F's stick grid over a surface before its
depth and deflection samples are thinned (16 -> 8 depths, 65 -> 17 deflections) and its
plane grid with them (chosen: over the 14 x 10 cut-off periods of a MetroPro map the full
grid held 13 million Jacobians, 66 s; a periodic cell of a few periods stays under it)."""

F_GRID_CHUNK = 2**20
"""Grid points of q_F whose Jacobians are held at once (about 50 MB)."""

PAPER_Q_F = 8.3
"""q_F reported in Section V-A (kappa_0 = 2000 N/m, l = 1 mm, A = 0.8, mu = 0.8,
d^x_max = d^z_max = 1 mm)."""


def _q_friction(alg, dmax, ranges, counts, nd) -> CharacteristicNumber:
    """Characteristic number of F: sup over the in-plane position, depth, deflection and
    both phases. Over a surface the deflection is a vector in the disk ‖d‖ <= d^x_max
    (stick: magnitudes and directions; slip: directions at d^x_max)."""
    k0 = alg.stiffness
    dm = alg.presliding
    depth_max = dmax
    k = len(ranges)
    counts, nd, n_ang, n_rad = _friction_plan(alg, ranges, counts, nd)
    axes = [np.linspace(a, b, n + 1) for (a, b), n in zip(ranges, counts)]
    steps = [(b - a) / n for (a, b), n in zip(ranges, counts)]
    ds = np.linspace(depth_max / nd, depth_max, nd)
    dd_ = depth_max / nd
    if k == 1:
        stick = np.linspace(-dm, dm, 33)[:, None]
        slip = np.array([[-dm], [dm]])
    else:
        ang = np.linspace(0.0, 2 * np.pi, n_ang, endpoint=False)
        rad = np.linspace(0.0, dm, n_rad)
        stick = np.concatenate([[[0.0, 0.0]], (rad[1:, None, None] * np.stack([np.cos(ang), np.sin(ang)], -1)).reshape(-1, 2)])
        slip = dm * np.stack([np.cos(ang), np.sin(ang)], -1)

    def jac(xt, depth, d, phase):
        return alg.jacobian(_region_points(alg, xt, depth), d[..., 0] if k == 1 else d, phase)

    def deflection(w, phase):
        """The deflection of the refinement's last variables: d itself over a profile; over
        a surface polar (r, angle), r fixed at d^x_max in slip."""
        if k == 1:
            return np.asarray(w)
        return w[..., :1] * np.stack([np.cos(w[..., 1]), np.sin(w[..., 1])], -1)

    def top(defl, phase, n_best=4):
        """The ``n_best`` largest norms of the grid and their indices, evaluated in slabs of
        the first axis of at most :data:`F_GRID_CHUNK` points (the whole grid of a 1 m line
        scan, 4000 cut-off periods, held 6.7e7 Jacobians: 3.4 GB; the same sup now)."""
        shape = (*(a.size for a in axes), ds.size, len(defl))
        rows = max(1, F_GRID_CHUNK // math.prod(shape[1:]))
        vals, where = [], []
        for i0 in range(0, shape[0], rows):
            mesh = np.meshgrid(axes[0][i0:i0 + rows], *axes[1:], ds, np.arange(len(defl)), indexing="ij")
            xt = np.stack(mesh[:k], -1)
            norms = spectral_norm(jac(xt, mesh[k], defl[mesh[k + 1]], phase)) / k0
            for idx in np.argsort(norms, axis=None, kind="stable")[-n_best:]:
                ijk = np.unravel_index(idx, norms.shape)
                vals.append(float(norms[ijk]))
                where.append((ijk[0] + i0, *ijk[1:]))
        order = np.argsort(vals, kind="stable")[-n_best:]
        return [(vals[i], where[i]) for i in order]

    best, arg = -np.inf, None
    for phase, defl in (("stick", stick), ("slip", slip)):
        for value, ijk in top(defl, phase):
            pt = [axes[a][ijk[a]] for a in range(k)] + [ds[ijk[k]]]
            d0 = defl[ijk[k + 1]]

            def neg(v, phase=phase):  # (n, k + 1 + deflection's variables)
                d = deflection(v[:, k + 1:], phase)
                return -spectral_norm(jac(v[:, :k], v[:, k], d, phase)) / k0

            bounds = [(max(r[0], v - h), min(r[1], v + h)) for r, v, h in zip(ranges, pt, steps)]
            bounds.append((max(dd_ * 1e-6, pt[k] - dd_), min(depth_max, pt[k] + dd_)))
            if k == 1:
                w0 = [float(d0[0])]
                bounds.append((-dm, dm) if phase == "stick" else (w0[0], w0[0]))
            else:
                r0, a0 = float(np.linalg.norm(d0)), math.atan2(d0[1], d0[0])
                w0 = [r0, a0]
                bounds += [(0.0, dm) if phase == "stick" else (dm, dm), (a0 - np.pi / 8, a0 + np.pi / 8)]
            val, v = _refine(neg, (*pt, *w0), value, bounds)
            if val > best:
                best, arg = val, (v[:k], v[k], deflection(np.asarray(v[k + 1:]), phase), phase)
    x0, x1 = ranges[0]
    bounds_paper = friction_bounds(alg, depth_max if alg.max_penetration is None else min(depth_max, alg.max_penetration))
    deflection = float(arg[2][0]) if k == 1 else [float(v) for v in arg[2]]
    extra = {"phase": arg[3], "deflection": deflection, **bounds_paper}
    extent = " and ".join(f"{name} in [{a:g}, {b:g}] m" for name, (a, b) in zip("xy", ranges))
    note = (f"sup over {extent}, depth in (0, {depth_max:g}] m, deflection "
            + (f"in [-{dm:g}, {dm:g}] m" if k == 1 else f"in the disk |d| <= {dm:g} m")
            + f", stick and slip; eq. 26 bound {bounds_paper['bound_eq26']:.4g}, "
            f"eq. 31 as printed {bounds_paper['eq31_as_printed']:.4g}")
    tex = alg.texture
    paper_case = (isinstance(tex, Sinusoid) and math.isclose(tex.period, 1e-3) and math.isclose(alg.friction, 0.8)
                  and math.isclose(dm, 1e-3) and math.isclose(depth_max, 1e-3)
                  and math.isclose(alg.modulation_depth, 0.8)
                  and (alg.max_penetration is None or alg.max_penetration >= depth_max))
    if paper_case:
        extra["paper_reported"] = PAPER_Q_F
        note += f"; Section V-A reports {PAPER_Q_F} for these parameters"
    where = _region_points(alg, np.asarray(arg[0], dtype=float)[None, :], np.array([float(arg[1])]))[0]
    return CharacteristicNumber("F", best, None, tuple(float(v) for v in where), dmax, note, None, extra)


def _normal_point(tex: Texture, t, r):
    """Probe positions at distance r (m) along the inward normal from (t, h(t))."""
    t = np.asarray(t, dtype=np.float64)
    s = tex.slope(t)
    g = 1.0 / np.sqrt(1.0 + s * s)
    return np.stack([t + r * s * g, tex.height(t) - r * g], axis=-1)


def _unique_foot(tex: Texture, points, r):
    """True where the probe positions ``points`` (normal points at distance r, m) have the
    point they were built from as their unique closest point: the distance is r and there
    is no tie (the region where D's and E's Jacobians are defined)."""
    cp = closest_point(tex, points)
    return (cp.distance >= r * (1 - 1e-9)) & ~cp.tie


def _on_region(alg, points, r):
    """-||J|| / kappa_0 (n,) of D or E at the normal points ``points`` (n, 2 or 3) at distances
    r (n,) (m), 0 where their foot is not their unique closest point (:func:`_unique_foot`),
    where the Jacobian is not evaluated (undefined there, a centre of curvature's NaN)."""
    out = np.zeros(len(points))
    on = _unique_foot(alg.texture, points, r)
    if np.any(on):
        out[on] = -spectral_norm(alg.jacobian(points[on])) / alg.stiffness
    return out


def _norms_on_region(alg, points, foot: ClosestPoint, shape):
    """||J|| / kappa_0 of D or E on a grid of normal points (``points``, shape (n, k + 1), built
    from the feet ``foot`` at the distances ``foot.distance``), -inf off the region (the foot
    not the unique closest point) and where the region was not decided: a closest-point search
    only where :func:`_region_candidates` needs one. Returns (norms of ``shape``, the
    refinement's candidates (flat indices, best first), whether the region has a point, points
    decided)."""
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # (a centre of curvature's)
        values = (spectral_norm(alg.jacobian_at_closest(points, foot)) / alg.stiffness).reshape(shape)
    r = foot.distance

    def unique(idx):
        return _unique_foot(alg.texture, points[idx], r[idx])

    cands, region, checked = _region_candidates(values, unique)
    return np.where(region & np.isfinite(values), values, -np.inf), cands, bool(region.any()), checked


def _searched(checked: int, size: int) -> str:
    """The note's account of the region's searches."""
    if checked == size:
        return "the foot's uniqueness searched at every point"
    return f"the foot's uniqueness searched at {checked:,} of its {size:,} points, where ||J|| can be largest"


def _q_distance(alg, dmax, x0, x1, nx, nd, closed) -> CharacteristicNumber:
    """Characteristic number for D and E (penetration = distance to the textured surface).

    The region is parametrised by the closest boundary abscissa t and the distance r:
    p = (t, h(t)) + r n_in(t), kept only where (t, h(t)) is the unique closest point of p.
    """
    tex = alg.texture
    ts = np.linspace(x0, x1, nx + 1)
    rs = np.linspace(dmax / nd, dmax, nd)
    T, R = np.meshgrid(ts, rs, indexing="ij")
    P = _normal_point(tex, T, R)
    if alg.letter == "D":
        focal = _unbounded_focus(tex, dmax, x0, x1)
        if focal is not None:
            # (eq. 18's Jacobian is -kappa_0 n n^T inside the wall: its norm is kappa_0 wherever
            # the region has a point, and the points just above this focus are in it)
            rho, fx, fz = focal
            return CharacteristicNumber(
                letter="D",
                value=math.inf,
                closed_form=closed,
                where=(fx, fz),
                max_penetration=dmax,
                note=(
                    f"unbounded: ||J|| -> inf approaching the centre of curvature at depth {rho:.4g} m "
                    f"below a peak (< max_penetration {dmax:g} m); eq. 18 gives 1"
                ),
                paper_form_value=1.0,
            )
    foot = ClosestPoint(x=T.ravel(), z=tex.height(T).ravel(), distance=R.ravel(), tie=np.zeros(R.size, dtype=bool),
                        work=np.zeros(R.size, dtype=np.int64))
    norms, cands, some, checked = _norms_on_region(alg, P.reshape(-1, 2), foot, R.shape)
    note = (f"grid {nx}x{nd} over closest-point x in [{x0:g}, {x1:g}] m and distance in (0, {dmax:g}] m "
            f"({_searched(checked, R.size)}), refined by L-BFGS-B")
    # eq. 18's Jacobian is -kappa_0 n n^T inside the wall: its norm is kappa_0 wherever the
    # region has a point
    paper_value = (1.0 if some else -math.inf) if alg.letter == "D" else None
    dt = (x1 - x0) / nx
    dr = dmax / nd

    def neg_q(v):  # (n, 2): t and r a row; 0 off the region (its Jacobian not evaluated there)
        return _on_region(alg, _normal_point(tex, v[:, 0], v[:, 1]), v[:, 1])

    best, where_tr = -np.inf, (x0, dmax)
    for idx in cands:
        i, j = np.unravel_index(idx, norms.shape)
        bounds = [(T[i, j] - dt, T[i, j] + dt), (max(dr * 1e-6, R[i, j] - dr), min(dmax, R[i, j] + dr))]
        val, pt = _refine(neg_q, (T[i, j], R[i, j]), norms[i, j], bounds)
        if val > best:
            best, where_tr = val, pt
    w = _normal_point(tex, np.array([where_tr[0]]), where_tr[1])[0]
    return CharacteristicNumber(alg.letter, best, closed, (float(w[0]), float(w[1])), dmax, note, paper_value)


def _surface_normal_point(tex, t, r):
    """p = (t, h(t)) + r n_in(t) over a surface: t of shape (..., 2), r (...) (m)."""
    s = tex.gradient(t)
    w = np.sqrt(1.0 + np.sum(s * s, axis=-1))
    return np.concatenate([t + (r / w)[..., None] * s, (tex.height_at(t) - r / w)[..., None]], axis=-1)


def _q_distance_surface(alg, dmax, ranges, counts, nd, closed, x_range, resolution) -> CharacteristicNumber:
    """Characteristic number of D and E over a surface: the region parametrised by the
    closest point t and the distance r, p = (t, h(t)) + r n_in(t), kept where t is the unique
    closest point of p. D is unbounded when a focal point (a centre of curvature 1/‖kappa‖
    below a convex-up point, kappa a principal curvature) lies within max_penetration; on
    ``Extruded(profile)`` the profile's q (the same Jacobians, embedded)."""
    from ..algorithms import algorithm as make
    from ..surfaces import Extruded

    tex = alg.texture
    k0 = alg.stiffness
    if isinstance(tex, Extruded):
        xr = None if x_range is None else tuple(_plane_ranges(alg, x_range)[0])
        q = characteristic_number(make(alg.letter, tex.profile, k0), dmax, xr, resolution)
        y = 0.5 * sum(_plane_ranges(alg, x_range)[1])
        return CharacteristicNumber(q.letter, q.value, q.closed_form, (q.where[0], y, q.where[1]), dmax,
                                    q.note + " (the extruded profile's, at any y)", q.paper_form_value, q.extra)
    axes = [np.linspace(a, b, n + 1) for (a, b), n in zip(ranges, counts)]
    rs = np.linspace(dmax / nd, dmax, nd)
    X, Y, R = np.meshgrid(*axes, rs, indexing="ij")
    T = np.stack([X, Y], -1)
    P = _surface_normal_point(tex, T, R)

    if alg.letter == "D":
        # principal curvatures of the graph: H v = kappa W (I + s s^T) v, W = sqrt(1 + |s|^2)
        t = T[..., 0, :]
        _, s_, hess = tex._jet(t)
        w = np.sqrt(1.0 + np.sum(s_ * s_, axis=-1))
        metric = np.eye(2) + s_[..., :, None] * s_[..., None, :]
        kappa = np.linalg.eigvals(np.linalg.solve(metric, hess)).real / w[..., None]
        focal = np.where(kappa < 0, -1.0 / np.where(kappa < 0, kappa, -1.0), np.inf).min(axis=-1)  # 1/‖kappa‖
        for idx in np.argsort(focal, axis=None, kind="stable")[:8]:
            rho = float(focal.ravel()[idx])
            if not rho <= dmax:
                break
            i, j = np.unravel_index(idx, focal.shape)
            fp = _surface_normal_point(tex, t[i, j][None, :], np.array([rho]))
            if closest_point(tex, fp).distance[0] >= rho * (1 - 1e-6):
                # (eq. 18 gives 1 wherever the region has a point: those just above this focus)
                return CharacteristicNumber(
                    "D", math.inf, closed, tuple(float(v) for v in fp[0]), dmax,
                    f"unbounded: ||J|| -> inf approaching the centre of curvature at depth {rho:.4g} m below a "
                    f"convex-up point (< max_penetration {dmax:g} m); eq. 18 gives 1", 1.0)
    foot = ClosestPoint(x=X.ravel(), y=Y.ravel(), z=tex.height_at(T).ravel(), distance=R.ravel(),
                        tie=np.zeros(R.size, dtype=bool), work=np.zeros(R.size, dtype=np.int64))
    norms, cands, some, checked = _norms_on_region(alg, P.reshape(-1, 3), foot, R.shape)
    note = (f"grid {counts[0]}x{counts[1]}x{nd} over the closest point's (x, y) and the distance in (0, {dmax:g}] m "
            f"({_searched(checked, R.size)}), refined by L-BFGS-B")
    # eq. 18's Jacobian is -kappa_0 n n^T inside the wall, n the unit normal at the closest
    # point: its norm is kappa_0 wherever the region has a point
    paper_value = (1.0 if some else -math.inf) if alg.letter == "D" else None
    steps = [(b - a) / n for (a, b), n in zip(ranges, counts)]
    dr = dmax / nd

    def neg_q(v):  # (n, 3): the foot's x, y and r a row; 0 off the region (its Jacobian not evaluated there)
        return _on_region(alg, _surface_normal_point(tex, v[:, :2], v[:, 2]), v[:, 2])

    best, where_v = -np.inf, (ranges[0][0], ranges[1][0], dmax)
    for idx in cands:
        i, j, m = np.unravel_index(idx, norms.shape)
        pt = (X[i, j, m], Y[i, j, m], R[i, j, m])
        bounds = [(pt[0] - steps[0], pt[0] + steps[0]), (pt[1] - steps[1], pt[1] + steps[1]),
                  (max(dr * 1e-6, pt[2] - dr), min(dmax, pt[2] + dr))]
        val, found = _refine(neg_q, pt, norms[i, j, m], bounds)
        if val > best:
            best, where_v = val, found
    w_ = _surface_normal_point(tex, np.array([where_v[:2]]), np.array([where_v[2]]))[0]
    return CharacteristicNumber(alg.letter, best, closed, tuple(float(v) for v in w_), dmax, note, paper_value)


def _unbounded_focus(tex: Texture, dmax: float, x0: float, x1: float):
    """Smallest radius of curvature rho of the convex-up boundary (h'' < 0) in [x0, x1]
    and its centre of curvature, if rho < dmax and the boundary point is the closest
    point of the points just above that centre; else None."""
    if isinstance(tex, Flat):
        return None
    xs = np.linspace(x0, x1, 4097)
    s = tex.slope(xs)
    c = tex.curvature(xs)
    with np.errstate(divide="ignore", over="ignore"):  # where c = 0 or is subnormal, rho is inf
        rho = np.where(c < 0, (1 + s * s) ** 1.5 / np.abs(c), np.inf)
    i = int(np.argmin(rho))
    if not np.isfinite(rho[i]):
        return None

    def rho_at(t):
        cc = float(tex.curvature(np.array([t]))[0])
        ss = float(tex.slope(np.array([t]))[0])
        return (1 + ss * ss) ** 1.5 / abs(cc) if cc < 0 else np.inf

    dxs = xs[1] - xs[0]
    from scipy import optimize

    r = optimize.minimize_scalar(rho_at, bounds=(xs[i] - dxs, xs[i] + dxs), method="bounded",
                                 options={"xatol": 1e-14})
    t = float(r.x)
    rmin = float(r.fun)
    if not rmin < dmax:
        return None
    s_t = float(tex.slope(np.array([t]))[0])
    g = 1.0 / math.sqrt(1 + s_t * s_t)
    h_t = float(tex.height(np.array([t]))[0])
    fx, fz = t + rmin * s_t * g, h_t - rmin * g
    # check that the boundary point t is the closest point just above the focus
    probe = np.array([[t + 0.999 * rmin * s_t * g, h_t - 0.999 * rmin * g]])
    cp = closest_point(tex, probe)
    if abs(cp.distance[0] - 0.999 * rmin) > 1e-9 * rmin + 1e-15:
        return None
    return rmin, fx, fz
