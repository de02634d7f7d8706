"""Work of a field along a path and around loops, the paper's Fig. 3 loops, the curl, and
measured conservativity (Campion & Hayward, Section III)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .._validation import (ParameterError, check_count, fail, in_range, nonnegative, positions, positive, random_seed,
                           whole)
from ..algorithms import Algorithm, _breakpoints, checked_algorithm
from ..textures import Flat, Sinusoid, Texture
from ._region import _region_box, check_analysis_scale


# ------------------------------------------------------------------------------------
# path work and loop energies
# ------------------------------------------------------------------------------------
_GL_RULES = {n: np.polynomial.legendre.leggauss(n) for n in (2, 16)}


def _gauss_pieces(fun, a: np.ndarray, b: np.ndarray, nodes: int = 16) -> np.ndarray:
    """Integrals (k,) of a vectorised fun over the pieces [a, b] (k,): ``nodes``-point
    Gauss–Legendre (2 or 16) on each, all nodes evaluated in one call."""
    x, w = _GL_RULES[nodes]
    half = 0.5 * (b - a)
    mid = 0.5 * (a + b)
    return half * (fun((mid[:, None] + half[:, None] * x[None, :]).ravel()).reshape(a.size, -1) @ w)


MAX_HALVINGS = 20
"""Most times a quadrature piece is halved (a weak singularity inside it, such as a centre of
curvature on the path, where D's and E's closest point runs fast; a medial-axis crossing that the
segment's cuts missed) before its two halves' sum is taken as it is (chosen: a piece of 1/8 of
the shortest period is then 1/1,048,576 of it; its error estimate, h^1.5 at a weak
singularity, fallen by 2^30)."""

WORK_FACTOR = 64
"""The most evaluations :func:`_adaptive_gauss` spends on halving, as a multiple of its first
pass's (chosen: what doubling every piece five times cost, before 2026-11-28; as QUADPACK's
``limit`` bounds its subintervals): the pieces with the largest error estimates are halved
first, and once the budget is spent the rest are taken as they are. Where the integrand's own
round-off stops the estimates from falling (D on an object, whose closest-point search leaves
3e-8 of the work whatever the piece), the work stays bounded: a loop round a sphere took
368,000 evaluations (9.9 s) with only a cap on the pieces halved at once, 32,144 (1.3 s) so."""

NARROW_PIECE = 1e-4
"""A smooth part of a path narrower than this fraction of the shortest period (chosen: 12.5 nm
on a texture band-limited to 0.125 mm) is integrated by 2-point Gauss–Legendre, halved as the
others while its estimate misses: between the thousands of medial-axis crossings that D's and
E's closest points make a few nm apart below a band-limited trough (measured: 2,400 on one
1 mm segment of a random loop), the force is all but constant."""


def _adaptive_gauss(fun, a: np.ndarray, b: np.ndarray, tol: float, nodes: int = 16,
                    coarse: np.ndarray | None = None) -> float:
    """Integral of a vectorised fun over the pieces [a, b] (k,) within about ``tol`` (J):
    ``nodes``-point Gauss–Legendre on each piece and on its two halves, the difference the
    piece's error estimate; the pieces whose estimate exceeds their share of tol (by width) are
    halved again, all of a level in one call, until the estimates left sum within what the
    accepted pieces left of tol (globally adaptive, as QUADPACK's QAGS, but level by level and
    vectorised). The pieces with the largest estimates are halved first, within ``WORK_FACTOR``
    times the first pass's evaluations and ``MAX_HALVINGS`` halvings; the rest are then taken as
    they are. ``coarse``: the pieces' integrals by the rule, when they are known."""
    if a.size == 0:
        return 0.0
    coarse = _gauss_pieces(fun, a, b, nodes) if coarse is None else coarse
    total, spent, width = 0.0, 0.0, float(np.sum(b - a))
    budget = WORK_FACTOR * a.size // 2  # (pieces to halve, each halving 2 nodes evaluations)
    for _ in range(MAX_HALVINGS):
        m = 0.5 * (a + b)
        halves = _gauss_pieces(fun, np.concatenate([a, m]), np.concatenate([m, b]), nodes)
        budget -= a.size
        left, right = halves[:a.size], halves[a.size:]
        fine = left + right
        err = np.abs(fine - coarse)
        if spent + float(err.sum()) <= tol:
            break
        ok = err <= tol * (b - a) / width
        most = max(budget // 2, 0)  # (the halves of the pieces halved now are halved next)
        if np.count_nonzero(~ok) > most:
            ok[np.argsort(np.where(ok, -np.inf, err), kind="stable")[:err.size - most]] = True
        total += float(fine[ok].sum())
        spent += float(err[ok].sum())
        a, b = np.concatenate([a[~ok], m[~ok]]), np.concatenate([m[~ok], b[~ok]])
        coarse = np.concatenate([left[~ok], right[~ok]])
        fine = fine[~ok]
        if a.size == 0:
            break
    return total + float(fine.sum())


MAX_PATH_PIECES = 1_000_000
"""Most quadrature pieces (1/8 of the shortest period each; 48 force evaluations at least, and
with the halvings' budget, ``WORK_FACTOR``, 16 (1 + 64) at most on average) one
:func:`path_work` call may integrate."""


def _check_path_size(algorithm: Algorithm, pts: np.ndarray) -> None:
    """Refuse a path whose quadrature would take absurdly long (a 1 km segment over a 1 mm
    texture is 8 million pieces)."""
    tex = algorithm.texture
    if isinstance(tex, Flat):
        return
    length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=-1)))
    pieces = length / (tex.shortest_period / 8)
    check_count("path", f"a polyline {length:g} m long", pieces, MAX_PATH_PIECES,
                f"quadrature pieces of 1/8 of the shortest period {tex.shortest_period:g} m")


def path_work(algorithm: Algorithm, path, rtol: float = 1e-12, atol: float = 0.0) -> float:
    """Work done by the field on a probe moving along a polyline, W = integral f . dp (J).

    Parameters
    ----------
    algorithm : Algorithm
        The force field.
    path : array_like, shape (N, 2) or (N, 3)
        Polyline vertices [x, z] over a profile, [x, y, z] over a surface (m), N >= 2. A
        closed loop repeats its first vertex at the end (see :func:`loop_energy`).
    rtol : float, optional
        Relative tolerance: each segment's work is integrated within ``rtol`` times itself.
    atol : float, optional
        Absolute tolerance of the whole path's work (J), >= 0, shared among its segments by
        length; each segment is integrated within the largest of its share, ``rtol`` times its
        work and 1e-15 kappa_0 L^2 (L its length).

    Returns
    -------
    float
        Work (J); > 0 means the field generated energy (the paper's Delta E).

    Raises
    ------
    ParameterError
        If ``path`` is not of shape (N, dimension) with N >= 2 finite vertices.

    Notes
    -----
    Each segment is split where the force has a kink or a jump: where it crosses the
    boundary (and the clamp depth of Remark 3), located by bracketing and Brent's method,
    and, for D and E, where the closest point jumps (the medial axis), located by
    bisection. The force is smooth on each piece, which is integrated by composite
    16-point Gauss–Legendre quadrature on sub-intervals of at most 1/8 of the shortest
    texture period (parts narrower than ``NARROW_PIECE`` of it by the 2-point rule), each
    compared with the sum over its two halves; the sub-intervals whose difference passes
    their share of the tolerance are halved again until the differences left fit in it, at
    most ``MAX_HALVINGS`` times (a centre of curvature on the path, where D's and E's closest
    point runs fast, is a weak singularity).

    Examples
    --------
    Around the paper's Fig. 3 loop, algorithm A supplies kappa_0 A^2 / 2:

    >>> alg = hx.algorithm("A", hx.Sinusoid(0.8e-3, 1e-3), 2000.0)
    >>> round(hx.path_work(alg, hx.paper_loop(alg)[0]), 8)
    0.00064
    """
    algorithm = checked_algorithm(algorithm)
    n = algorithm.dimension
    pts = positions(path, "path", dim=n)
    if pts.ndim != 2 or pts.shape[0] < 2:
        raise ParameterError(f"path has shape {pts.shape}, which is not allowed: must be (N, {n}) with N >= 2")
    rtol = in_range("rtol", rtol, 1e-15, 1e-2)
    atol = nonnegative("atol", atol, "J")
    _check_path_size(algorithm, pts)
    if getattr(algorithm, "has_memory", False):
        return algorithm.path_work(pts)
    total = 0.0
    tex = algorithm.texture
    total_length = float(np.sum(np.linalg.norm(np.diff(pts, axis=0), axis=-1)))
    for a, b in zip(pts[:-1], pts[1:]):
        delta = b - a
        length = float(np.linalg.norm(delta))
        if length == 0.0:
            continue
        cuts = [0.0, *_breakpoints(algorithm, a, b), 1.0]
        scale = algorithm.stiffness * length * length
        feature = tex.shortest_period if not isinstance(tex, Flat) else length

        def integrand(u, a=a, delta=delta):
            return algorithm.force(a + u[:, None] * delta) @ delta

        # composite Gauss–Legendre on pieces of at most 1/8 of the shortest period between
        # the cuts, the narrow parts by the 2-point rule; the pieces that miss their share of
        # the segment's tolerance halved (_adaptive_gauss)
        u0, u1 = np.asarray(cuts[:-1]), np.asarray(cuts[1:])
        keep = u1 > u0
        u0, u1 = u0[keep], u1[keep]
        narrow = (u1 - u0) * length < NARROW_PIECE * feature
        counts = np.where(narrow, 1, np.maximum(1, np.ceil((u1 - u0) * length / (feature / 8)))).astype(np.int64)
        edges = [np.linspace(lo, hi, k + 1) for lo, hi, k in zip(u0, u1, counts)]
        cut, ends = np.concatenate([e[:-1] for e in edges]), np.concatenate([e[1:] for e in edges])
        small = np.repeat(narrow, counts)
        first = _gauss_pieces(integrand, cut[~small], ends[~small])  # (the segment's work, roughly)
        tol = max(atol * length / total_length, rtol * abs(float(first.sum())), 1e-15 * scale)
        part = float(np.sum(ends[small] - cut[small]))  # (the narrow parts' share of the tolerance, u is 0-1)
        total += _adaptive_gauss(integrand, cut[small], ends[small], tol * part, nodes=2)
        total += _adaptive_gauss(integrand, cut[~small], ends[~small], tol * (1.0 - part), coarse=first)
    return total


def loop_energy(algorithm: Algorithm, loop, rtol: float = 1e-12, atol: float = 0.0) -> float:
    """Energy generated by the field around a closed polygon (J), Delta E = closed-path work.

    Parameters
    ----------
    algorithm : Algorithm
    loop : array_like, shape (N, 2) or (N, 3)
        Polygon vertices [x, z] over a profile, [x, y, z] over a surface (m); closed
        automatically if the last vertex differs from the first.
    rtol : float, optional
        Relative accuracy of the quadrature (see :func:`path_work`).
    atol : float, optional
        Absolute accuracy of the loop's energy (J), >= 0 (see :func:`path_work`).

    Returns
    -------
    float
        > 0 means the field generated energy around the loop (not conservative).
    """
    algorithm = checked_algorithm(algorithm)
    n = algorithm.dimension
    pts = positions(loop, "loop", dim=n)
    if pts.ndim != 2 or pts.shape[0] < 3:
        raise ParameterError(f"loop has shape {pts.shape}, which is not allowed: must be (N, {n}) with N >= 3")
    if not np.array_equal(pts[0], pts[-1]):
        pts = np.vstack([pts, pts[:1]])
    return path_work(algorithm, pts, rtol=rtol, atol=atol)


def _sinusoid_geometry(tex: Texture) -> tuple[float, float, float]:
    """(A, l, x_shift) such that h(x + x_shift) = A sin(2 pi x / l) for a Sinusoid."""
    if isinstance(tex, Sinusoid):
        return tex.amplitude, tex.period, -tex.phases[0] * tex.period / (2 * np.pi)
    raise ParameterError(
        f"texture = {tex!r} is not allowed here: the Fig. 3 loops are defined for a Sinusoid"
    )


def paper_loop(algorithm: Algorithm, depth: float | None = None) -> tuple[np.ndarray, float | None, str]:
    """The closed path of Fig. 3 for an algorithm, and the paper's value of its energy.

    Parameters
    ----------
    algorithm : Algorithm
        W, A–E or G on a :class:`~haptex.textures.Sinusoid` (W: none needed).
    depth : float, optional
        The depth a (m) of the eq. 29 path used for G and W; default 0.5 mm.

    Returns
    -------
    path : ndarray, shape (5, 2)
        Closed polygon [x, z] (m).
    expected : float or None
        The closed-form loop energy (J): A, kappa_0 A^2 / 2 (Section IV-A-4); B, eq. 12;
        C, D, W: 0; G: eq. 29's Delta E_2, which for h = A sin(2 pi x / l) integrates to
        kappa_0 a l arctan(2 pi A / l) / pi; E: ``None`` (the paper only says > 0).
    source : str
        Where the path and value come from.

    Raises
    ------
    ParameterError
        If the texture is not a Sinusoid (the paths are defined for one), or a ``depth`` is
        given for A-E (their path has none) or is not a length > 0.

    Examples
    --------
    >>> alg = hx.algorithm("A", hx.Sinusoid(0.8e-3, 1e-3), 2000.0)
    >>> path, expected, source = hx.paper_loop(alg)
    >>> path.shape, expected  # the Fig. 3 rectangle; kappa_0 A^2 / 2 (J)
    ((5, 2), 0.00064)
    """
    algorithm = checked_algorithm(algorithm)
    k0 = algorithm.stiffness
    letter = algorithm.letter
    if letter == "F":
        return _paper_loop_f(algorithm, depth)
    if letter not in ("G", "W") and depth is not None:  # (A-E's Fig. 3 rectangle has none)
        raise fail("depth", depth, f"None for {letter} (the Fig. 3 path of A-E has no depth; the eq. 29 path of G "
                                   "and W, and F's loop, take one)")
    if letter in ("G", "W"):
        a = 0.5e-3 if depth is None else positive("depth", depth, "m")
        if letter == "W":
            A, l, x_s = 0.0, 1e-3, 0.0
        else:
            A, l, x_s = _sinusoid_geometry(algorithm.texture)
        path = np.array([[l / 4, a], [l / 4, -a], [3 * l / 4, -a], [3 * l / 4, a], [l / 4, a]])
        path[:, 0] += x_s
        expected = 0.0 if letter == "W" else k0 * a * l * math.atan(2 * math.pi * A / l) / math.pi
        return path, expected, "eq. 29 path, a = %g m" % a
    A, l, x_s = _sinusoid_geometry(algorithm.texture)
    path = np.array([[0.0, 0.0], [l / 4, 0.0], [l / 4, A], [0.0, A], [0.0, 0.0]])
    path[:, 0] += x_s
    expected: float | None
    if letter == "A":
        expected = 0.5 * k0 * A * A
    elif letter == "B":
        expected = 0.5 * k0 * A * A + k0 * l * l / (4 * math.pi**2) * (1 - math.sqrt((l * l + 4 * A * A * math.pi**2) / (l * l)))
    elif letter in ("C", "D"):
        expected = 0.0
    else:
        expected = None
    return path, expected, "Fig. 3 path (0,0)->(l/4,0)->(l/4,A)->(0,A)->(0,0)"


def _paper_loop_f(alg, a: float | None):
    """Eq. 27's path for F and its energy derived from eq. 22 along it."""
    dz = alg.max_penetration if alg.max_penetration is not None else 1e-3
    dm = alg.presliding
    a = 1e-3 * dz if a is None else positive("depth", a, "m")
    if not a < dz:
        raise fail("depth", a, f"a depth below d^z_max = {dz:g} m")
    path = np.array([[0.0, dz], [0.0, -a], [dm, -a], [dm, -dz], [0.0, -dz], [0.0, dz]])
    # The lateral work is mu kappa_0 (dz - a)/dm * integral_0^dm m(x) x dx (stick both ways).
    tex = alg.texture
    if alg._scale == 0.0:
        integral = dm * dm / 2
    elif isinstance(tex, Sinusoid):
        k = 2 * math.pi / tex.period
        ph = tex.phases[0]
        sx = math.sin(k * dm + ph) / k**2 - dm * math.cos(k * dm + ph) / k - math.sin(ph) / k**2
        integral = dm * dm / 2 - alg._scale * tex.amplitude * sx
    else:
        return path, None, "eq. 27 path, a = %g m" % a
    expected = alg.friction * alg.stiffness * (dz - a) / dm * integral
    return path, expected, "eq. 27 path, a = %g m (eq. 27: kappa_0 mu d^z_max d^x_max / 2 as a -> 0, A = 0)" % a


# ------------------------------------------------------------------------------------
# curl, continuity, conservativity
# ------------------------------------------------------------------------------------
def curl(algorithm: Algorithm, p) -> np.ndarray:
    """Curl of the field (N/m): over a profile the scalar df_z/dx - df_x/dz, shape (...);
    over a surface the vector curl f = [df_z/dy - df_y/dz, df_x/dz - df_z/dx,
    df_y/dx - df_x/dy], shape (..., 3). (On ``Extruded(profile)`` its y component is
    minus the profile's scalar curl: the x-z plane seen from +y.)

    Zero everywhere inside for a gradient field (C, D, W); the paper reads
    non-conservativity off the Jacobian's asymmetry (Section IV-A-4).

    Parameters
    ----------
    algorithm : Algorithm
        The field.
    p : array_like, shape (..., 2) or (..., 3)
        Probe positions [x, z] or [x, y, z] (m).

    Returns
    -------
    numpy.ndarray
        Shape (...) over a profile, (..., 3) over a surface (N/m).
    """
    algorithm = checked_algorithm(algorithm)
    return curl_of_jacobian(algorithm.jacobian(p))


def curl_of_jacobian(j: np.ndarray) -> np.ndarray:
    """The curl of a field from its Jacobian, as :func:`curl` returns it.

    Parameters
    ----------
    j : numpy.ndarray, shape (..., 2, 2) or (..., 3, 3)
        The Jacobian (N/m).

    Returns
    -------
    numpy.ndarray
        A scalar in the plane, shape (...); a vector in space, shape (..., 3) (N/m).
    """
    if j.shape[-1] == 2:
        return j[..., 1, 0] - j[..., 0, 1]
    return np.stack([j[..., 2, 1] - j[..., 1, 2], j[..., 0, 2] - j[..., 2, 0], j[..., 1, 0] - j[..., 0, 1]], -1)


@dataclass(frozen=True)
class Conservativity:
    """Result of :func:`conservativity`.

    Parameters
    ----------
    conservative : bool
        True when every loop energy is zero to ``tolerance``.
    paper_loop_energy : float
        Energy around the algorithm's Fig. 3 path (J), or NaN when the texture is not a
        Sinusoid.
    random_loop_energies : tuple of float
        Energies around random closed polygons in the wall (J).
    tolerance : float
        Quadrature accuracy used as the zero threshold (J).
    almost : bool or None
        For F only ("almost conservative", Table II): True when every loop energy stays
        below its stick-phase bound in ``loop_bounds``; None for memoryless fields.
    loop_bounds : tuple of float
        For F: the most a loop can generate (J), n_runs mu kappa_0 (1 + depth) d^z d^x_max / 2,
        with n_runs the number of monotone runs of x around the loop: energy is generated
        only in stick, at most the lateral spring's energy mu kappa_0 |p^z| m d_max^2 / 2
        per run (Section IV-F-4, eq. 27).
    """

    conservative: bool
    paper_loop_energy: float
    random_loop_energies: tuple = field(default=())
    tolerance: float = 0.0
    almost: bool | None = None
    loop_bounds: tuple = field(default=())

    @property
    def max_abs_energy(self) -> float:
        """Largest |loop energy| among all loops tried (J)."""
        vals = [abs(v) for v in self.random_loop_energies]
        if not math.isnan(self.paper_loop_energy):
            vals.append(abs(self.paper_loop_energy))
        return max(vals) if vals else 0.0


def random_loops(algorithm: Algorithm, n: int = 6, vertices: int = 5, max_penetration: float = 1e-3,
                 seed: int = 0, x_range=None) -> list[np.ndarray]:
    """Random closed polygons in the box spanned by one period and the wall's depth.

    Parameters
    ----------
    algorithm : Algorithm
        The field whose region (one period, the wall's depth) the polygons lie in.
    n : int
        Number of polygons.
    vertices : int
        Vertices per polygon (>= 3); the first is repeated at the end.
    max_penetration : float
        The box reaches this far (m) below the lowest valley.
    seed : int
        Seed of numpy's default generator (reproducible).
    x_range : (float, float), optional
        The region along x (m) instead of one period (or the texture's domain).

    Returns
    -------
    list of ndarray, each of shape (vertices + 1, dimension), metres: [x, z] over a
    profile, [x, y, z] (polygons in space) over a surface.

    Raises
    ------
    ParameterError
        If ``n`` is not a whole number from 1 to 10,000, ``vertices`` from 3 to 10,000,
        ``seed`` not a whole number >= 0, or the region is malformed (``max_penetration``,
        ``x_range``).

    Notes
    -----
    Over a region wider than ``LOOP_SPAN_PERIODS`` shortest texture periods (a long
    measured profile), each polygon is drawn in a window of that width placed at random in
    the region: conservativity is local, and a loop's cost grows with the periods it
    crosses, so a 1 m profile costs what a short one does.
    """
    algorithm = checked_algorithm(algorithm)
    n = whole("n", n, 1, 10_000, "random loops")
    vertices = whole("vertices", vertices, 3, 10_000, "a polygon's vertices")
    rng = np.random.default_rng(random_seed("seed", seed))
    box = _region_box(algorithm, check_analysis_scale(algorithm, max_penetration), x_range)
    span = LOOP_SPAN_PERIODS * float(algorithm.texture.shortest_period)
    loops = []
    for _ in range(n):
        cols = []
        for k, (a, b) in enumerate(box):
            if k < len(box) - 1 and b - a > span:  # an in-plane axis wider than the window
                a = rng.uniform(a, b - span)
                b = a + span
            cols.append(rng.uniform(a, b, vertices))
        v = np.column_stack(cols)
        if hasattr(algorithm, "to_cartesian"):  # an object: vertices drawn in its plane coordinates
            v = algorithm.to_cartesian(v)
        loops.append(np.vstack([v, v[:1]]))
    return loops


LOOP_SPAN_PERIODS = 16
"""Width, in shortest texture periods, of the window a random loop is drawn in (see
:func:`random_loops`)."""


def conservativity(algorithm: Algorithm, max_penetration: float = 1e-3, n_random: int = 6, seed: int = 0,
                   x_range=None) -> Conservativity:
    """Measure conservativity: loop energies on the Fig. 3 path and on random polygons.

    A field is reported conservative when every loop energy is zero to the quadrature
    accuracy, taken as 1e-9 kappa_0 L^2 where L is the size of the region (the paper's
    Section III-C: a system is conservative iff the work around any cycle is zero).

    Parameters
    ----------
    algorithm : Algorithm
    max_penetration : float, optional
        Depth of the region explored by the random loops (m), default 1 mm.
    n_random : int, optional
        Number of random closed polygons, default 6.
    seed : int, optional
        Seed of the random polygons.
    x_range : (float, float), optional
        The region along x (m) instead of one period (or the texture's domain).

    Returns
    -------
    Conservativity
    """
    algorithm = checked_algorithm(algorithm)
    n_random = whole("n_random", n_random, 1, 10_000, "random loops, each a path_work call")
    loops = random_loops(algorithm, n_random, 5, max_penetration, seed, x_range)
    box = _region_box(algorithm, max_penetration, x_range)
    span = LOOP_SPAN_PERIODS * float(algorithm.texture.shortest_period)
    size = max(min(b - a, span) if k < len(box) - 1 else b - a for k, (a, b) in enumerate(box))  # a loop's box
    tol = 1e-9 * algorithm.stiffness * size * size
    # each loop's quadrature within 1e-3 of the verdict's tolerance, or within a relative 1e-10
    energies = tuple(loop_energy(algorithm, lp, rtol=1e-10, atol=1e-3 * tol) for lp in loops)
    try:
        if hasattr(algorithm, "to_cartesian"):  # (the Fig. 3 path is drawn on a plane)
            raise ParameterError("no paper loop on an object")
        path, _, _ = paper_loop(algorithm)
        e_paper = path_work(algorithm, path)
    except ParameterError:
        e_paper = math.nan
    vals = [abs(e) for e in energies] + ([] if math.isnan(e_paper) else [abs(e_paper)])
    almost, bounds = None, ()
    if algorithm.has_memory:
        dz = max_penetration if algorithm.max_penetration is None else min(max_penetration, algorithm.max_penetration)
        per_run = 0.5 * algorithm.friction * algorithm.stiffness * (1 + algorithm.modulation_depth) * dz * algorithm.presliding
        bounds = tuple(_monotone_runs(lp) * per_run for lp in loops)
        almost = all(e <= b * (1 + 1e-9) + tol for e, b in zip(energies, bounds))
    return Conservativity(all(v <= tol for v in vals), e_paper, energies, tol, almost, bounds)


def _monotone_runs(loop: np.ndarray) -> int:
    """Number of maximal runs of a closed polygon along which x is monotone."""
    dx = np.diff(loop[:, 0])
    sgn = np.sign(dx[dx != 0])
    if sgn.size == 0:
        return 0
    changes = int(np.count_nonzero(sgn != np.roll(sgn, 1)))
    return max(changes, 1)
