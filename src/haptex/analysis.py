"""Energy analysis of texture algorithms: characteristic numbers, path and loop work,
curl, continuity and measured conservativity (Campion & Hayward, Sections III–IV).

Analysis functions take an algorithm and return plain numbers or small frozen
dataclasses; they never plot.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy import integrate, ndimage, optimize

from ._validation import MAX_LENGTH, ParameterError, check_budget, check_count, fail, in_range, positions, positive, whole
from .algorithms import Algorithm
from .closest import closest_point
from .textures import Flat, Sinusoid, Texture

__all__ = [
    "CharacteristicNumber",
    "characteristic_number",
    "friction_bounds",
    "spectral_norm",
    "path_work",
    "loop_energy",
    "paper_loop",
    "curl",
    "Continuity",
    "continuity",
    "Conservativity",
    "conservativity",
    "Limit",
    "texture_limits",
    "PassivityCondition",
    "passivity_condition",
    "max_passive_stiffness",
]


# ------------------------------------------------------------------------------------
# characteristic number
# ------------------------------------------------------------------------------------
def spectral_norm(j) -> np.ndarray:
    """Largest singular value of 2x2 or 3x3 matrices.

    Parameters
    ----------
    j : array_like, shape (..., 2, 2) or (..., 3, 3)

    Returns
    -------
    ndarray, shape (...)
        sigma_max(J), in the units of J: for 2x2 in closed form,
        sqrt((|J|_F^2 + sqrt(|J|_F^4 - 4 det(J)^2)) / 2); for 3x3 by LAPACK's SVD.
    """
    j = np.asarray(j, dtype=np.float64)
    if j.shape[-2:] != (2, 2):
        return np.linalg.svd(j, compute_uv=False)[..., 0]
    fro2 = np.sum(j * j, axis=(-2, -1))
    det = j[..., 0, 0] * j[..., 1, 1] - j[..., 0, 1] * j[..., 1, 0]
    disc = np.sqrt(np.maximum(fro2 * fro2 - 4 * det * det, 0.0))
    return np.sqrt(0.5 * (fro2 + disc))


@dataclass(frozen=True)
class CharacteristicNumber:
    """Result of :func:`characteristic_number`.

    Attributes
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
        How the value was obtained, in one sentence.
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


MAX_ANALYSIS_STIFFNESS = 1e12
"""Largest kappa_0 (N/m) the analysis accepts: 10^4 times the stiffest wall a haptic device
renders, and far enough from overflow that energies kappa_0 d^2 and squared Jacobian
entries (kappa_0 M)^2 stay exact in double precision. It also bounds F's presliding
lateral stiffness mu kappa_0 d^z_max / d^x_max. The renderer and the simulator accept any
finite stiffness."""
MIN_ANALYSIS_STIFFNESS = 1e-6
"""Smallest kappa_0 (N/m) the analysis accepts, so that energies kappa_0 d^2 of nanometre
penetrations stay normal doubles (above 1e-300) and the conservativity tolerance
1e-9 kappa_0 L^2 means something."""
MAX_SLOPE = 1e4
"""Largest texture slope M the analysis accepts (a slope of 10^4 is a vertical wall to
within 0.006 degrees; Remark 2's sqrt(1 + M^2) squares it)."""
MAX_REGION_PERIODS = 1e3
"""Largest depth of the analysed region, in shortest texture periods; deeper regions
are refused rather than sampled at 64 grid cells per period."""


def check_analysis_scale(algorithm: Algorithm, max_penetration) -> float:
    """Validate ``max_penetration`` (m) and the algorithm's scale for a region analysis;
    returns ``max_penetration`` as a float. Called by every region analysis, and up front
    by :func:`haptex.tables.table_ii` and :func:`haptex.design.design` for all their
    algorithms, so nothing is computed before a bad parameter is refused.

    Raises
    ------
    ParameterError
        If the depth is not in (0, MAX_LENGTH], kappa_0 exceeds MAX_ANALYSIS_STIFFNESS,
        the texture is steeper than MAX_SLOPE, its shortest period or height range
        exceeds MAX_LENGTH, or the depth exceeds MAX_REGION_PERIODS shortest periods.
    """
    dmax = positive("max_penetration", max_penetration, "m")
    if dmax > MAX_LENGTH:
        raise fail("max_penetration", max_penetration, f"a depth in (0, {MAX_LENGTH:g}] m")
    k0 = algorithm.stiffness
    if not MIN_ANALYSIS_STIFFNESS <= k0 <= MAX_ANALYSIS_STIFFNESS:
        raise fail("stiffness", k0, f"in [{MIN_ANALYSIS_STIFFNESS:g}, {MAX_ANALYSIS_STIFFNESS:g}] N/m in the analysis "
                   "(energies kappa_0 d^2 must stay normal doubles); the renderer and simulator accept it")
    if algorithm.has_memory:  # F: its presliding range and lateral stiffness
        dxm = algorithm.presliding
        if dxm > MAX_LENGTH:
            raise fail("presliding", dxm, f"at most {MAX_LENGTH:g} m")
        dz = dmax if algorithm.max_penetration is None else min(dmax, algorithm.max_penetration)
        k_lat = algorithm.friction * k0 * (1 + algorithm.modulation_depth) * dz / dxm
        if k_lat > MAX_ANALYSIS_STIFFNESS:
            raise ParameterError(f"friction = {algorithm.friction:g} with presliding = {dxm:g} m is not allowed in "
                                 f"the analysis: F's presliding lateral stiffness mu kappa_0 (1 + A) d^z_max / "
                                 f"d^x_max = {k_lat:.3g} N/m exceeds {MAX_ANALYSIS_STIFFNESS:g} N/m")
    tex = algorithm.texture
    if isinstance(tex, Flat):  # the analysed region of a flat wall is 1 mm wide (_x_range)
        if dmax > MAX_REGION_PERIODS * 1e-3:
            raise fail("max_penetration", dmax, f"at most {MAX_REGION_PERIODS * 1e-3:g} m for a flat wall "
                       f"({MAX_REGION_PERIODS:g} times the 1 mm wide analysed region)")
        return dmax
    slope = tex.max_slope
    if not slope <= MAX_SLOPE:
        raise ParameterError(f"texture = {tex!r} is not allowed in the analysis: its max slope M = {slope:.3g} "
                             f"exceeds {MAX_SLOPE:g} (steeper than a vertical wall to 0.006 degrees; check the "
                             "amplitude, period or height unit)")
    lo, hi = tex.height_range
    ell = tex.shortest_period
    if not (ell <= MAX_LENGTH and hi - lo <= MAX_LENGTH):
        raise ParameterError(f"texture = {tex!r} is not allowed in the analysis: its shortest period {ell:g} m or "
                             f"height range {hi - lo:g} m exceeds {MAX_LENGTH:g} m")
    if dmax > MAX_REGION_PERIODS * ell:
        raise fail("max_penetration", dmax, f"at most {MAX_REGION_PERIODS:g} shortest texture periods "
                   f"({MAX_REGION_PERIODS * ell:g} m) for {tex!r}; or band-limit the texture (lowpass, --lowpass)")
    if hi - lo > MAX_REGION_PERIODS * ell:
        raise ParameterError(f"texture = {tex!r} is not allowed in the analysis: its height range {hi - lo:g} m spans "
                             f"more than {MAX_REGION_PERIODS:g} shortest periods ({MAX_REGION_PERIODS * ell:g} m); "
                             "check the amplitude or height unit, or band-limit it")
    return dmax


def checked_algorithms(letters, texture: Texture, stiffness: float, max_penetration: float, friction: float,
                       presliding: float) -> dict:
    """The algorithms of ``letters`` on one texture, each checked by :func:`check_analysis_scale`
    before anything is computed (Table II, ``design``).

    Parameters
    ----------
    letters : iterable of str
        Paper letters, W and A–G.
    texture : Texture
        Used by A–G (W has none).
    stiffness : float
        kappa_0 (N/m).
    max_penetration : float
        Depth of the analysed region (m); also F's d^z_max.
    friction, presliding : float
        F's mu and d^x_max (m).

    Returns
    -------
    dict
        Letter -> Algorithm, in the order given.

    Raises
    ------
    ParameterError
        If an algorithm cannot be built or is outside the analysis' scale.
    """
    from .algorithms import algorithm

    algs = {}
    for letter in letters:
        kw = {"friction": friction, "presliding": presliding, "max_penetration": max_penetration} if letter == "F" else {}
        algs[letter] = algorithm(letter, None if letter == "W" else texture, stiffness, **kw)
        check_analysis_scale(algs[letter], max_penetration)
    return algs


def _x_range(alg: Algorithm, x_range) -> tuple[float, float]:
    if alg.texture.dimension != 1:
        raise ParameterError(f"texture = {alg.texture!r} is a surface: this analysis takes profiles h(x) for now "
                             "(characteristic_number and the fields take surfaces)")
    if x_range is not None:
        try:
            a, b = (float(v) for v in x_range)
        except (TypeError, ValueError):
            raise fail("x_range", x_range, "a pair (x_min, x_max) of finite metres with x_min < x_max") from None
        if not (math.isfinite(a) and math.isfinite(b) and a < b):
            raise fail("x_range", x_range, "a pair (x_min, x_max) of finite metres with x_min < x_max")
        return a, b
    tex = alg.texture
    if isinstance(tex, Flat):
        return 0.0, 1e-3
    dom = getattr(tex, "domain", None)
    if dom is None:
        raise ParameterError(
            f"x_range = None is not allowed for the aperiodic texture {tex!r}: "
            "give x_range=(x_min, x_max) in metres"
        )
    return float(dom[0]), float(dom[1])


def _plane_ranges(alg: Algorithm, x_range) -> list[tuple[float, float]]:
    """The in-plane extent of the analysed region, one (min, max) in m per in-plane axis:
    [(x0, x1)] over a profile (:func:`_x_range`), [(x0, x1), (y0, y1)] over a surface (one
    periodic cell by default, or ``x_range = ((x0, x1), (y0, y1))``)."""
    tex = alg.texture
    if tex.dimension == 1:
        return [_x_range(alg, x_range)]
    allowed = "((x_min, x_max), (y_min, y_max)) in finite metres, each min < max"
    if x_range is None:
        if isinstance(tex, Flat):
            return [(0.0, 1e-3), (0.0, 1e-3)]
        if tex.domain is None:
            raise ParameterError(f"x_range = None is not allowed for the surface {tex!r}, which has no periodic "
                                 f"cell: give x_range={allowed}")
        return [tuple(float(v) for v in r) for r in tex.domain]
    try:
        (a, b), (c, d) = ((float(u), float(v)) for u, v in x_range)
    except (TypeError, ValueError):
        raise fail("x_range", x_range, allowed) from None
    if not all(math.isfinite(v) for v in (a, b, c, d)) or not (a < b and c < d):
        raise fail("x_range", x_range, allowed)
    return [(a, b), (c, d)]


def _region_points(alg: Algorithm, xt, depth):
    """Probe positions (..., k + 1) at in-plane positions xt (..., k) and depth (...) (m),
    for the 'vertical' (below h) and 'nominal' (below z = 0) kinds."""
    z = alg.texture.height_at(xt) - depth if alg.penetration_kind == "vertical" else -depth
    return np.concatenate([xt, np.broadcast_to(z, np.shape(depth))[..., None]], axis=-1)


def _region_point(alg: Algorithm, x, depth):
    """:func:`_region_points` over a profile, abscissae x of any shape (m)."""
    return _region_points(alg, np.asarray(x)[..., None], depth)


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
    result is the sup and not a grid sample.

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
        aperiodic texture, or the resolution is below (8, 4).

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
    """
    dmax = check_analysis_scale(algorithm, max_penetration)
    nx, nd = (int(v) for v in resolution)
    if nx < 8 or nd < 4:
        raise fail("resolution", resolution, "(n_x, n_depth) with n_x >= 8 and n_depth >= 4")
    ranges = _plane_ranges(algorithm, x_range)
    tex = algorithm.texture
    if tex.dimension == 2:  # a surface: a 3-D grid, kept to ~10^6 points (refinement does the rest)
        if algorithm.penetration_kind == "distance" or algorithm.has_memory:
            raise ParameterError(f"algorithm = {algorithm.letter!r} on a surface is not analysed yet")
        nd = max(4, nd // 4)
        counts = [int(min(max(32, math.ceil(32 * (b - a) / tex.shortest_period)), 256)) for a, b in ranges]
    else:
        counts = [nx]
        if not isinstance(tex, Flat):
            # at least 64 grid cells per shortest period, so every local maximum has its cell
            counts = [int(min(max(nx, math.ceil(64 * (ranges[0][1] - ranges[0][0]) / tex.shortest_period)), 8192))]
    k0 = algorithm.stiffness
    closed = _closed_form_q(algorithm)

    if algorithm.penetration_kind == "distance":
        return _q_distance(algorithm, dmax, *ranges[0], counts[0], nd, closed)
    if algorithm.has_memory:
        return _q_friction(algorithm, dmax, *ranges[0], counts[0], nd)

    axes = [np.linspace(a, b, n + 1) for (a, b), n in zip(ranges, counts)]
    ds = np.linspace(dmax / nd, dmax, nd)
    mesh = np.meshgrid(*axes, ds, indexing="ij")
    plane_pts = np.stack(mesh[:-1], axis=-1)
    norms = spectral_norm(algorithm.jacobian(_region_points(algorithm, plane_pts, mesh[-1]))) / k0
    steps = [(b - a) / n for (a, b), n in zip(ranges, counts)]
    dd = dmax / nd

    def neg_q(v):
        p = _region_points(algorithm, np.asarray(v[:-1])[None, :], np.array([v[-1]]))
        return -float(spectral_norm(algorithm.jacobian(p))[0]) / k0

    start = [r[0] for r in ranges] + [dmax]
    best, where_pt = -np.inf, tuple(start)
    for idx in _candidates(norms):
        ijk = np.unravel_index(idx, norms.shape)
        pt = [axes[a][ijk[a]] for a in range(len(axes))] + [ds[ijk[-1]]]
        bounds = [(max(r[0], v - h), min(r[1], v + h)) for r, v, h in zip(ranges, pt, steps)]
        bounds.append((max(dd * 1e-6, pt[-1] - dd), min(dmax, pt[-1] + dd)))
        val, found = _refine(neg_q, pt, norms[ijk], bounds)
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


def _refine(neg, start, value: float, bounds) -> tuple[float, tuple]:
    """Bounded L-BFGS-B maximisation from a grid point: (value, point), the grid's own if
    the refinement finds nothing larger."""
    r = optimize.minimize(neg, x0=list(start), method="L-BFGS-B", bounds=bounds,
                          options={"ftol": 1e-15, "gtol": 1e-12})
    if -r.fun > value:
        return -float(r.fun), tuple(float(v) for v in r.x)
    return float(value), tuple(float(v) for v in start)


def _candidates(values: np.ndarray, count: int = 8) -> np.ndarray:
    """Flat indices of the ``count`` largest local maxima of a 2-D or 3-D grid, best first."""
    finite = np.where(np.isfinite(values), values, -np.inf)
    peaks = (ndimage.maximum_filter(finite, size=3, mode="nearest") == finite) & np.isfinite(finite)
    labels, n = ndimage.label(peaks, structure=np.ones((3,) * values.ndim))
    if n == 0:
        return np.array([int(np.argmax(finite))])
    # one candidate per connected plateau of local maxima, so ties do not crowd out others
    pos = ndimage.maximum_position(finite, labels, index=np.arange(1, n + 1))
    idx = np.array([np.ravel_multi_index(q, finite.shape) for q in pos])
    order = np.argsort(finite.ravel()[idx])[::-1]
    return idx[order[:count]]


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
        |p^z| at which the bounds are evaluated (m), the paper's d^z_max.

    Returns
    -------
    dict
        ``bound_eq26``: ||[[2 mu p^z (1/d^x_max + pi A / l), 2 mu], [0, 1]]||_2;
        ``eq31_as_printed``: eq. 31 evaluated term by term as printed (its exponents such
        as (mu^4 p^z)^4 are kept, although they make it differ from the norm it bounds);
        ``eq31_corrected``: eq. 31 with the inner root replaced by the closed form of the
        2x2 singular value, which equals ``bound_eq26``.
    """
    mu = algorithm.friction
    dm = algorithm.presliding
    P = depth
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


PAPER_Q_F = 8.3
"""q_F reported in Section V-A (kappa_0 = 2000 N/m, l = 1 mm, A = 0.8, mu = 0.8,
d^x_max = d^z_max = 1 mm)."""


def _q_friction(alg, dmax, x0, x1, nx, nd) -> CharacteristicNumber:
    """Characteristic number of F: sup over x, depth, deflection and both phases."""
    k0 = alg.stiffness
    dm = alg.presliding
    depth_max = dmax
    nq = 33
    xs = np.linspace(x0, x1, nx + 1)
    ds = np.linspace(depth_max / nd, depth_max, nd)
    qs = np.linspace(-dm, dm, nq)
    best, arg = -np.inf, None
    for phase, defl in (("stick", qs), ("slip", np.array([-dm, dm]))):
        X, Dp, Q = np.meshgrid(xs, ds, defl, indexing="ij")
        P = np.stack([X, -Dp], axis=-1)
        norms = spectral_norm(alg.jacobian(P, Q, phase)) / k0
        flat = np.argsort(norms, axis=None)[-4:]
        for idx in flat:
            i, j, q = np.unravel_index(idx, norms.shape)

            def neg(v, phase=phase, q=q, defl=defl):
                dd = v[2] if phase == "stick" else defl[q]
                return -float(spectral_norm(alg.jacobian(np.array([[v[0], -v[1]]]), dd, phase))[0]) / k0

            dx, dd_ = (x1 - x0) / nx, depth_max / nd
            bounds = [(max(x0, xs[i] - dx), min(x1, xs[i] + dx)), (max(dd_ * 1e-6, ds[j] - dd_), min(depth_max, ds[j] + dd_)),
                      (-dm, dm) if phase == "stick" else (defl[q], defl[q])]
            val, v = _refine(neg, (xs[i], ds[j], defl[q]), norms[i, j, q], bounds)
            if val > best:
                best, arg = val, (*v, phase)
    bounds_paper = friction_bounds(alg, depth_max if alg.max_penetration is None else min(depth_max, alg.max_penetration))
    extra = {"phase": arg[3], "deflection": arg[2], **bounds_paper}
    note = (f"sup over x in [{x0:g}, {x1:g}] m, depth in (0, {depth_max:g}] m, deflection in "
            f"[-{dm:g}, {dm:g}] m, stick and slip; eq. 26 bound {bounds_paper['bound_eq26']:.4g}, "
            f"eq. 31 as printed {bounds_paper['eq31_as_printed']:.4g}")
    tex = alg.texture
    paper_case = (isinstance(tex, Sinusoid) and math.isclose(tex.period, 1e-3) and math.isclose(alg.friction, 0.8)
                  and math.isclose(dm, 1e-3) and math.isclose(depth_max, 1e-3)
                  and math.isclose(alg.modulation_depth, 0.8)
                  and (alg.max_penetration is None or alg.max_penetration >= depth_max))
    if paper_case:
        extra["paper_reported"] = PAPER_Q_F
        note += f"; Section V-A reports {PAPER_Q_F} for these parameters"
    return CharacteristicNumber("F", best, None, (arg[0], -arg[1]), dmax, note, None, extra)


def _normal_point(tex: Texture, t, r):
    """Probe positions at distance r (m) along the inward normal from (t, h(t))."""
    t = np.asarray(t, dtype=np.float64)
    s = tex.slope(t)
    g = 1.0 / np.sqrt(1.0 + s * s)
    return np.stack([t + r * s * g, tex.height(t) - r * g], axis=-1)


def _q_distance(alg, dmax, x0, x1, nx, nd, closed) -> CharacteristicNumber:
    """Characteristic number for D and E (penetration = distance to the textured surface).

    The region is parametrised by the closest boundary abscissa t and the distance r:
    p = (t, h(t)) + r n_in(t), kept only where (t, h(t)) is the unique closest point of p.
    """
    tex = alg.texture
    k0 = alg.stiffness
    ts = np.linspace(x0, x1, nx + 1)
    rs = np.linspace(dmax / nd, dmax, nd)
    T, R = np.meshgrid(ts, rs, indexing="ij")
    P = _normal_point(tex, T, R)

    def valid(points, r):
        cp = closest_point(tex, points)
        return (cp.distance >= r * (1 - 1e-9)) & ~cp.tie

    region = valid(P, R)
    norms = np.where(region, spectral_norm(alg.jacobian(P)) / k0, -np.inf)
    paper_value = None
    note = (f"grid {nx}x{nd} over closest-point x in [{x0:g}, {x1:g}] m and distance in (0, {dmax:g}] m, "
            "refined by L-BFGS-B")
    if alg.letter == "D":
        paper_value = float(np.max(np.where(region, spectral_norm(alg.jacobian(P, form="paper")) / k0, -np.inf)))
        focal = _unbounded_focus(tex, dmax, x0, x1)
        if focal is not None:
            rho, fx, fz = focal
            return CharacteristicNumber(
                letter="D",
                value=math.inf,
                closed_form=closed,
                where=(fx, fz),
                max_penetration=dmax,
                note=(
                    f"unbounded: ||J|| -> inf approaching the centre of curvature at depth {rho:.4g} m "
                    f"below a peak (< max_penetration {dmax:g} m); eq. 18 gives {paper_value:.6g}"
                ),
                paper_form_value=paper_value,
            )
    dt = (x1 - x0) / nx
    dr = dmax / nd

    def neg_q(v):
        p = _normal_point(tex, np.array([v[0]]), v[1])
        if not valid(p, v[1])[0]:
            return 0.0
        return -float(spectral_norm(alg.jacobian(p))[0]) / k0

    best, where_tr = -np.inf, (x0, dmax)
    for idx in _candidates(norms):
        i, j = np.unravel_index(idx, norms.shape)
        bounds = [(T[i, j] - dt, T[i, j] + dt), (max(dr * 1e-6, R[i, j] - dr), min(dmax, R[i, j] + dr))]
        val, pt = _refine(neg_q, (T[i, j], R[i, j]), norms[i, j], bounds)
        if val > best:
            best, where_tr = val, pt
    w = _normal_point(tex, np.array([where_tr[0]]), where_tr[1])[0]
    return CharacteristicNumber(alg.letter, best, closed, (float(w[0]), float(w[1])), dmax, note, paper_value)


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


# ------------------------------------------------------------------------------------
# path work and loop energies
# ------------------------------------------------------------------------------------
def _signed_depths(alg: Algorithm, pts: np.ndarray) -> list[np.ndarray]:
    """Functions whose sign changes mark kinks of the force along a path: the boundary
    and, with max_penetration, the clamp depth."""
    x, z = pts[..., 0], pts[..., 1]
    if alg.penetration_kind == "nominal":
        d = z
    else:
        d = z - alg.texture.height(x)
    out = [d]
    dm = getattr(alg, "max_penetration", None)
    if dm is not None:
        out.append(d + dm)
    return out


def _breakpoints(alg: Algorithm, a: np.ndarray, b: np.ndarray) -> list[float]:
    """Parameters u in (0, 1) where the segment a->b crosses the boundary or a clamp depth."""
    length = float(np.hypot(*(b - a)))
    tex = alg.texture
    scale = tex.shortest_period if not isinstance(tex, Flat) else length
    n = int(min(max(64, 64 * length / scale), 20000))
    u = np.linspace(0.0, 1.0, n + 1)
    pts = a + u[:, None] * (b - a)
    out: list[float] = []
    for k, vals in enumerate(_signed_depths(alg, pts)):
        sgn = np.sign(vals)
        out.extend(float(u[i]) for i in np.nonzero(sgn[1:-1] == 0)[0] + 1)  # a sample on the kink
        for i in np.nonzero(sgn[:-1] * sgn[1:] < 0)[0]:
            fn = lambda uu, k=k: float(_signed_depths(alg, (a + uu * (b - a))[None, :])[k][0])  # noqa: E731
            out.append(optimize.brentq(fn, u[i], u[i + 1], xtol=1e-16, rtol=1e-15))
    if alg.penetration_kind == "distance":
        out.extend(_closest_point_jumps(tex, a, b, u, pts, length / n))
    return sorted(out)


def _closest_point_jumps(tex: Texture, a, b, u, pts, spacing) -> list[float]:
    """Parameters where the closest boundary point jumps along the segment a->b (the
    probe crosses the medial axis, Remark 6), located by bisection to round-off (all
    brackets bisected together, one vectorised closest-point call per halving)."""
    cp = closest_point(tex, pts)
    inside = cp.distance > 0
    dt = np.abs(np.diff(cp.x))
    out = _tie_changes(tex, a, b, u, cp.tie)
    idx = np.nonzero((dt > 2 * spacing) & inside[:-1] & inside[1:])[0]
    per_u = 2 * spacing / (u[1] - u[0])  # the closest point's smooth motion allowed per unit of u
    slack = 1e-12 * tex.shortest_period
    lo, hi = u[idx].copy(), u[idx + 1].copy()
    t_lo, t_hi = cp.x[idx].copy(), cp.x[idx + 1].copy()
    for _ in range(8):  # a bracket may hold several jumps (a thin branch of the medial axis)
        if lo.size == 0:
            break
        lo0, hi0, t_lo0, t_hi0 = lo.copy(), hi.copy(), t_lo.copy(), t_hi.copy()
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            live = (lo < mid) & (mid < hi)
            if not live.any():
                break
            t_mid = closest_point(tex, a + mid[:, None] * (b - a)).x
            left = np.abs(t_mid - t_lo) >= np.abs(t_hi - t_mid)
            hi = np.where(live & left, mid, hi)
            t_hi = np.where(live & left, t_mid, t_hi)
            lo = np.where(live & ~left, mid, lo)
            t_lo = np.where(live & ~left, t_mid, t_lo)
        jump = np.abs(t_hi - t_lo) > per_u * (hi - lo) + slack
        out += (0.5 * (lo + hi))[jump].tolist()
        # what is left on either side of the jump found: another jump if the closest point
        # moved more there than smooth motion allows
        left_more = jump & (np.abs(t_lo - t_lo0) > per_u * (lo - lo0) + slack)
        right_more = jump & (np.abs(t_hi0 - t_hi) > per_u * (hi0 - hi) + slack)
        lo, hi = np.r_[lo0[left_more], hi[right_more]], np.r_[lo[left_more], hi0[right_more]]
        t_lo, t_hi = np.r_[t_lo0[left_more], t_hi[right_more]], np.r_[t_lo[left_more], t_hi0[right_more]]
    return out


def _tie_changes(tex: Texture, a, b, u, tie) -> list[float]:
    """Parameters where the segment enters or leaves the medial axis (a centre of
    curvature: the force is continuous there but not smooth), by bisection."""
    idx = np.nonzero(tie[:-1] != tie[1:])[0]
    if idx.size == 0:
        return []
    lo, hi = u[idx].copy(), u[idx + 1].copy()
    lo_tie = tie[idx].copy()
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        live = (lo < mid) & (mid < hi)
        if not live.any():
            break
        same = closest_point(tex, a + mid[:, None] * (b - a)).tie == lo_tie
        lo = np.where(live & same, mid, lo)
        hi = np.where(live & ~same, mid, hi)
    # the flag flips where the two minima are closer than the search can tell apart, a
    # little off the centre of curvature itself: solve p(u) = (t, h) + (1 + h'^2) (-h', 1) / h''
    # for (t, u) from there (Newton), and keep the exact crossing when it is close by
    out = []
    for u0 in 0.5 * (lo + hi):
        t0 = float(closest_point(tex, (a + u0 * (b - a))[None, :]).x[0])
        out.append(_focal_crossing(tex, a, b, t0, float(u0)))
    return out


def _focal_crossing(tex: Texture, a, b, t0: float, u0: float) -> float:
    """Parameter u where the segment a->b crosses the centre of curvature of the boundary
    near abscissa t0 (Newton on (t, u)); u0 if Newton does not converge nearby."""
    d = b - a
    t, u = t0, u0
    for _ in range(30):
        h, s, c = (float(f(np.array(t))) for f in (tex.height, tex.slope, tex.curvature))
        if c == 0.0:
            return u0
        q = 1.0 + s * s
        third = (float(tex.curvature(np.array(t + 1e-9 * tex.shortest_period))) - c) / (1e-9 * tex.shortest_period)
        res = np.array([t - s * q / c - (a[0] + u * d[0]), h + q / c - (a[1] + u * d[1])])
        # d/dt of the centre: x: 1 - (c q + 2 s^2 c) / c^2 + s q c' / c^2 ; z: s + 2 s c / c - q c' / c^2
        jx = 1.0 - (q + 2 * s * s) + s * q * third / (c * c)
        jz = s + 2 * s - q * third / (c * c)
        jac = np.array([[jx, -d[0]], [jz, -d[1]]])
        try:
            step = np.linalg.solve(jac, -res)
        except np.linalg.LinAlgError:
            return u0
        t += step[0]
        u += step[1]
        if abs(step[1]) <= 1e-15 and abs(step[0]) <= 1e-15 * tex.shortest_period:
            break
    ok = np.isfinite(u) and abs(u - u0) <= 1e-3 and abs(t - t0) <= 0.05 * tex.shortest_period
    return float(u) if ok else u0


_GL_NODES, _GL_WEIGHTS = np.polynomial.legendre.leggauss(16)


def _composite_gauss(fun, u0: float, u1: float, pieces: int) -> float:
    """Integral of a vectorised fun over [u0, u1]: 16-point Gauss–Legendre on ``pieces``
    equal sub-intervals, all nodes evaluated in one call."""
    edges = np.linspace(u0, u1, pieces + 1)
    half = 0.5 * np.diff(edges)
    mid = 0.5 * (edges[:-1] + edges[1:])
    nodes = (mid[:, None] + half[:, None] * _GL_NODES[None, :]).ravel()
    vals = fun(nodes).reshape(pieces, -1)
    return float(np.sum(half * (vals @ _GL_WEIGHTS)))


MAX_PATH_PIECES = 1_000_000
"""Most quadrature pieces (1/8 of the shortest period each, 16 to 512 force evaluations)
one :func:`path_work` call may integrate."""


def _check_path_size(algorithm: Algorithm, pts: np.ndarray) -> None:
    """Refuse a path whose quadrature would take absurdly long (a 1 km segment over a 1 mm
    texture is 8 million pieces)."""
    tex = algorithm.texture
    if isinstance(tex, Flat):
        return
    length = float(np.sum(np.hypot(*np.diff(pts, axis=0).T)))
    pieces = length / (tex.shortest_period / 8)
    check_count("path", f"a polyline {length:g} m long", pieces, MAX_PATH_PIECES,
                f"quadrature pieces of 1/8 of the shortest period {tex.shortest_period:g} m")


def path_work(algorithm: Algorithm, path, rtol: float = 1e-12) -> float:
    """Work done by the field on a probe moving along a polyline, W = integral f . dp (J).

    Parameters
    ----------
    algorithm : Algorithm
        The force field.
    path : array_like, shape (N, 2)
        Polyline vertices [x, z] (m), N >= 2. A closed loop repeats its first vertex
        at the end (see :func:`loop_energy`).
    rtol : float, optional
        Relative tolerance handed to the adaptive quadrature of each piece.

    Returns
    -------
    float
        Work (J); > 0 means the field generated energy (the paper's Delta E).

    Raises
    ------
    ParameterError
        If ``path`` is not of shape (N, 2) with N >= 2 finite vertices.

    Notes
    -----
    Each segment is split where the force has a kink or a jump: where it crosses the
    boundary (and the clamp depth of Remark 3), located by bracketing and Brent's method,
    and, for D and E, where the closest point jumps (the medial axis), located by
    bisection. The force is smooth on each piece, which is integrated by composite
    16-point Gauss–Legendre quadrature on sub-intervals of at most 1/8 of the shortest
    texture period, halved until two successive results agree to ``rtol``.
    """
    pts = positions(path, "path")
    if pts.ndim != 2 or pts.shape[0] < 2:
        raise ParameterError(f"path has shape {pts.shape}, which is not allowed: must be (N, 2) with N >= 2")
    rtol = in_range("rtol", rtol, 1e-15, 1e-2)
    _check_path_size(algorithm, pts)
    if getattr(algorithm, "has_memory", False):
        return algorithm.path_work(pts)
    total = 0.0
    tex = algorithm.texture
    for a, b in zip(pts[:-1], pts[1:]):
        delta = b - a
        length = float(np.hypot(*delta))
        if length == 0.0:
            continue
        cuts = [0.0, *_breakpoints(algorithm, a, b), 1.0]
        scale = algorithm.stiffness * length * length
        feature = tex.shortest_period if not isinstance(tex, Flat) else length

        def integrand(u, a=a, delta=delta):
            return algorithm.force(a + u[:, None] * delta) @ delta

        for u0, u1 in zip(cuts[:-1], cuts[1:]):
            if u1 <= u0:
                continue
            # composite Gauss–Legendre, sub-intervals of at most 1/8 of the shortest
            # period, doubled until two successive results agree to rtol
            pieces = max(1, int(math.ceil((u1 - u0) * length / (feature / 8))))
            val = _composite_gauss(integrand, u0, u1, pieces)
            done = False
            for _ in range(5):
                pieces *= 2
                finer = _composite_gauss(integrand, u0, u1, pieces)
                done = abs(finer - val) <= rtol * abs(finer) + 1e-15 * scale
                val = finer
                if done:
                    break
            if not done:
                # a weak singularity inside the piece (a centre of curvature on the path):
                # QUADPACK's extrapolating QAGS converges where plain refinement is slow
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", integrate.IntegrationWarning)
                    val = integrate.quad(lambda uu: float(integrand(np.array([uu]))[0]), u0, u1,
                                         epsabs=1e-15 * scale, epsrel=rtol, limit=400)[0]
            total += val
    return total


def loop_energy(algorithm: Algorithm, loop, rtol: float = 1e-12) -> float:
    """Energy generated by the field around a closed polygon (J), Delta E = closed-path work.

    Parameters
    ----------
    algorithm : Algorithm
    loop : array_like, shape (N, 2)
        Polygon vertices [x, z] (m); closed automatically if the last vertex differs
        from the first.
    rtol : float, optional
        Relative accuracy of the quadrature (see :func:`path_work`).

    Returns
    -------
    float
        > 0 means the field generated energy around the loop (not conservative).
    """
    pts = positions(loop, "loop")
    if pts.ndim != 2 or pts.shape[0] < 3:
        raise ParameterError(f"loop has shape {pts.shape}, which is not allowed: must be (N, 2) with N >= 3")
    if not np.array_equal(pts[0], pts[-1]):
        pts = np.vstack([pts, pts[:1]])
    return path_work(algorithm, pts, rtol=rtol)


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
        If the texture is not a Sinusoid (the paths are defined for one).
    """
    k0 = algorithm.stiffness
    letter = algorithm.letter
    if letter == "F":
        return _paper_loop_f(algorithm, depth)
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
    """Scalar curl of the planar field, df_z/dx - df_x/dz (N/m), shape (...).

    Zero everywhere inside for a gradient field (C, D, W); the paper reads
    non-conservativity off the Jacobian's asymmetry (Section IV-A-4).

    Parameters
    ----------
    p : array_like, shape (..., 2)
        Probe positions [x, z] (m).
    """
    j = algorithm.jacobian(p)
    return j[..., 1, 0] - j[..., 0, 1]


def _static_force(alg: Algorithm, p) -> np.ndarray:
    """Force over positions; for F in full slip (|d^x| = d^x_max), its largest lateral force."""
    if alg.has_memory:
        return alg.force(p, alg.presliding)
    return alg.force(p)


def _region_box(alg: Algorithm, max_penetration: float, x_range=None):
    x0, x1 = _x_range(alg, x_range)
    lo, hi = alg.texture.height_range
    return x0, x1, lo - max_penetration, hi


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


@dataclass(frozen=True)
class Conservativity:
    """Result of :func:`conservativity`.

    Attributes
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
    n : int
        Number of polygons.
    vertices : int
        Vertices per polygon (>= 3); the first is repeated at the end.
    max_penetration : float
        The box reaches this far (m) below the lowest valley.
    seed : int
        Seed of numpy's default generator (reproducible).

    Returns
    -------
    list of ndarray, each of shape (vertices + 1, 2), metres.
    """
    x0, x1, z0, z1 = _region_box(algorithm, check_analysis_scale(algorithm, max_penetration), x_range)
    rng = np.random.default_rng(seed)
    loops = []
    for _ in range(int(n)):
        v = np.column_stack([rng.uniform(x0, x1, vertices), rng.uniform(z0, z1, vertices)])
        loops.append(np.vstack([v, v[:1]]))
    return loops


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

    Returns
    -------
    Conservativity
    """
    n_random = whole("n_random", n_random, 1, 10_000, "random loops, each a path_work call")
    loops = random_loops(algorithm, n_random, 5, max_penetration, seed, x_range)
    # relative accuracy 1e-10 on each loop is far below the verdict's tolerance
    energies = tuple(loop_energy(algorithm, lp, rtol=1e-10) for lp in loops)
    x0, x1, z0, z1 = _region_box(algorithm, max_penetration, x_range)
    size = max(x1 - x0, z1 - z0)
    tol = 1e-9 * algorithm.stiffness * size * size
    try:
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


# ------------------------------------------------------------------------------------
# devices: the six texture-rendering limits and the passivity condition
# ------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Limit:
    """One inequality of Section II-B: ``lhs < rhs`` must hold.

    Attributes
    ----------
    name : str
    formula : str
        As evaluated (with the paper's printed form where it differs).
    lhs, rhs : float
        Both sides, in the units of ``unit``.
    unit : str
    passed : bool
    """

    name: str
    formula: str
    lhs: float
    rhs: float
    unit: str
    passed: bool


def texture_limits(texture: Texture, device, speed: float, stiffness: float, samples_per_period=5) -> list[Limit]:
    """The six necessary conditions of Section II-B for rendering a texture on a device.

    With l the texture's shortest period, M its Lipschitz bound (Remark 2: 2 pi A / l for
    a sinusoid), A_F = kappa_0 max|h| the force amplitude the texture produces at
    stiffness kappa_0, and alpha = beta = gamma = ``samples_per_period``:

    1. scanning velocity       alpha v T / l < 1
    2. low-speed reconstruction beta delta / l < 1
    3. high-speed reconstruction alpha delta / l < 1 (as printed)
    4. force reconstruction    gamma b < A_F (printed "gamma b / l < A", whose sides
       have different units; the force amplitude must span gamma force quanta)
    5. gain                    kappa_0 M < K_max (printed 2 pi A / l < A_0 with A the
       force amplitude: the force gradient 2 pi A_F / l = kappa_0 M), with K_max the
       device's largest stiffness (its ``max_stiffness``, else sigma_0(B) / (2T))
    6. structural              v / l < F_0

    Parameters
    ----------
    texture : Texture
    device : Device
    speed : float
        Scanning velocity v (m/s), > 0.
    stiffness : float
        kappa_0 (N/m) the texture is rendered with.
    samples_per_period : float or (float, float, float), optional
        alpha, beta, gamma ("typically 5 to 10"), default 5.

    Returns
    -------
    list of Limit
        In the paper's order.

    Raises
    ------
    ParameterError
        For a non-positive speed, stiffness or sample count.
    """
    v = positive("speed", speed, "m/s")
    k0 = positive("stiffness", stiffness, "N/m")
    spp = np.broadcast_to(np.asarray(samples_per_period, dtype=np.float64), (3,))
    for name, val in zip(("alpha", "beta", "gamma"), spp):
        positive(f"samples_per_period ({name})", val)
    alpha, beta, gamma = (float(v_) for v_ in spp)
    ell = float(texture.shortest_period)
    M = float(texture.max_slope)
    force_amp = k0 * float(texture.peak_magnitude)
    T = device.period
    delta = device.position_resolution
    b = device.force_resolution
    kmax = device.max_stiffness
    return [
        Limit("scanning velocity", "alpha v T / l < 1", alpha * v * T / ell, 1.0, "1", alpha * v * T / ell < 1),
        Limit("low-speed reconstruction", "beta delta / l < 1", beta * delta / ell, 1.0, "1", beta * delta / ell < 1),
        Limit("high-speed reconstruction", "alpha delta / l < 1", alpha * delta / ell, 1.0, "1", alpha * delta / ell < 1),
        Limit("force reconstruction", "gamma b < A_F (printed: gamma b / l < A)", gamma * b, force_amp, "N",
              gamma * b < force_amp),
        Limit("gain", "kappa_0 M < K_max (printed: 2 pi A / l < A_0)", k0 * M, kmax, "N/m", k0 * M < kmax),
        Limit("device structural", "v / l < F_0", v / ell, device.first_resonance, "Hz", v / ell < device.first_resonance),
    ]


@dataclass(frozen=True)
class PassivityCondition:
    """Result of :func:`passivity_condition` (Corollary 1, eq. 1).

    Attributes
    ----------
    holds : bool
        sup ||J||_2 <= sigma_0(B) / (2T) over the rendering region.
    sup_jacobian_norm : float
        kappa_0 q (N/m); inf when q is unbounded.
    limit : float
        sigma_0(B) / (2T) (N/m).
    margin : float
        limit / sup_jacobian_norm (> 1 when the condition holds with room to spare).
    characteristic_number : CharacteristicNumber
    """

    holds: bool
    sup_jacobian_norm: float
    limit: float
    margin: float
    characteristic_number: CharacteristicNumber


def passivity_condition(algorithm: Algorithm, device, max_penetration: float = 1e-3, x_range=None) -> PassivityCondition:
    """Corollary 1: is ||J_f||_2 <= sigma_0(B) / (2T) everywhere in the rendering region?

    Parameters
    ----------
    algorithm : Algorithm
    device : Device
        Its inside damping matrix B and sampling period T are used.
    max_penetration : float, optional
        Depth of the rendering region (m).
    x_range : (float, float), optional
        Abscissa range (m); the texture's domain by default.

    Returns
    -------
    PassivityCondition

    Notes
    -----
    A sufficient condition (eq. 1), derived from Theorem 1 of Miller, Colgate & Freeman
    [18]; the simulator shows how conservative it is for a given device.
    """
    q = characteristic_number(algorithm, max_penetration=max_penetration, x_range=x_range)
    sup = algorithm.stiffness * q.value
    lim = device.passivity_limit
    margin = lim / sup if sup > 0 else math.inf
    return PassivityCondition(bool(sup <= lim), float(sup), float(lim), float(margin), q)


def max_passive_stiffness(algorithm: Algorithm, device, max_penetration: float = 1e-3, x_range=None) -> float:
    """Largest nominal stiffness kappa_0 (N/m) that satisfies Corollary 1: sigma_0(B) / (2 T q).

    q is computed numerically for the algorithm's texture (it does not depend on
    kappa_0); 0 when q is unbounded (algorithm D below peaks sharper than the region's
    depth: use ``characteristic_number(...).paper_form_value`` for eq. 18's 1).

    Parameters
    ----------
    algorithm : Algorithm
    device : Device
    max_penetration : float, optional
        Depth of the rendering region (m).
    x_range : (float, float), optional
        Abscissa range (m).
    """
    q = characteristic_number(algorithm, max_penetration=max_penetration, x_range=x_range).value
    return 0.0 if math.isinf(q) else float(device.passivity_limit / q)
