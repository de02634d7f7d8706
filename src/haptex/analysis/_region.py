"""The analysed region and the analysis' scale guards: which probe positions an analysis
searches, and the checks every region analysis makes before computing."""

from __future__ import annotations

import math

import numpy as np

from .._validation import MAX_LENGTH, ParameterError, fail, positive
from ..algorithms import Algorithm
from ..textures import Flat, Texture


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
        from ..probe import _stated_length

        # (the bound rounded down to 6 digits, so that taken as written it is not refused again:
        # "0.00015625 m" for mi-1.mi felt by a 5 um ball was, 2026-11-30)
        value, text = _stated_length(MAX_REGION_PERIODS * ell, up=False, digits=6,
                                     fits=lambda v: v <= MAX_REGION_PERIODS * ell)
        raise fail("max_penetration", dmax, f"at most {MAX_REGION_PERIODS:g} shortest periods of {tex!r}, {text} "
                   f"(--max-penetration {text} or less; max_penetration <= {value!r} in Python); or band-limit "
                   "the texture (design does unless --raw, band_limit=False; lowpass() in Python, --lowpass for "
                   "a line scan)")
    if hi - lo > MAX_REGION_PERIODS * ell:
        raise ParameterError(f"texture = {tex!r} is not allowed in the analysis: its height range {hi - lo:g} m spans "
                             f"more than {MAX_REGION_PERIODS:g} shortest periods ({MAX_REGION_PERIODS * ell:g} m); "
                             "check the amplitude or height unit, or band-limit it")
    return dmax


def checked_algorithms(letters, texture: Texture, stiffness: float, max_penetration: float, friction: float,
                       presliding: float, base=None) -> dict:
    """The algorithms of ``letters`` on one texture, each checked by :func:`check_analysis_scale`
    before anything is computed (Table II, ``design``), on the plane or on ``base``.

    Parameters
    ----------
    letters : iterable of str
        Paper letters, W and A–G.
    texture : Texture
        Used by A–G; W gets the flat surface of the same dimension.
    stiffness : float
        kappa_0 (N/m).
    max_penetration : float
        Depth of the analysed region (m); also F's d^z_max.
    friction, presliding : float
        F's mu and d^x_max (m).
    base : haptex.objects.Base, optional
        Build each letter over this base (:func:`haptex.objects.object_algorithm`, A-G) instead
        of the plane.

    Returns
    -------
    dict
        Letter -> Algorithm, in the order given.

    Raises
    ------
    ParameterError
        If an algorithm cannot be built or is outside the analysis' scale.
    """
    from ..algorithms import ALGORITHMS, algorithm

    algs = {}
    for letter in letters:
        cls = ALGORITHMS.get(str(letter).strip().upper())  # (the registry; an unknown letter: algorithm() refuses it)
        kw = {}
        if cls is not None and "friction" in cls.parameters:
            kw = {"friction": friction, "presliding": presliding, "max_penetration": max_penetration}
        if base is not None:
            from ..objects import object_algorithm

            algs[letter] = object_algorithm(letter, texture, base, stiffness, **kw)
        else:
            algs[letter] = algorithm(letter, texture if cls is None or cls.textured else Flat(texture.dimension),
                                     stiffness, **kw)
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
    own = getattr(alg, "surface_range", None)  # (an object's: its texture's cell where its base has it)
    if x_range is None and own is not None:
        return [tuple(float(v) for v in r) for r in own]
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
    for the 'vertical' (below h) and 'nominal' (below z = 0) kinds; over an object
    (:class:`haptex.objects.ObjectAlgorithm`) xt are surface coordinates mapped onto it."""
    if hasattr(alg, "region_points"):
        return alg.region_points(xt, depth)
    z = alg.texture.height_at(xt) - depth if alg.penetration_kind == "vertical" else -depth
    return np.concatenate([xt, np.broadcast_to(z, np.shape(depth))[..., None]], axis=-1)


def _static_force(alg: Algorithm, p) -> np.ndarray:
    """Force over positions; for F in full slip (|d^x| = d^x_max), its largest lateral force.
    Over an object the positions are its plane coordinates [u1, u2, e] (see
    :meth:`haptex.objects.ObjectAlgorithm.to_cartesian`): the region's grids are laid there."""
    if hasattr(alg, "to_cartesian"):
        p = alg.to_cartesian(p)
    if alg.has_memory:
        return alg.force(p, alg.presliding)
    return alg.force(p)


def _region_box(alg: Algorithm, max_penetration: float, x_range=None) -> list[tuple[float, float]]:
    """The box of the analysed region, one (min, max) in m per coordinate of a probe
    position: the in-plane ranges (:func:`_plane_ranges`), then z from ``max_penetration``
    below the lowest valley to the highest peak."""
    lo, hi = alg.texture.height_range
    return [*_plane_ranges(alg, x_range), (lo - max_penetration, hi)]
