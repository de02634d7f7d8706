"""The surface a probe of finite size feels: a texture dilated by a ball.

The paper's probe is a point. A stylus ends in a ball (a Phantom's of about a millimetre), a
knob or a finger pad is wider, and a ball of radius r cannot enter a groove narrower than its
contact allows: its centre follows the height map dilated by the ball,

    c(p) = max over |u| <= r of [ h(p + u) + sqrt(r² - |u|²) ],

and the surface it feels is c - r (a grey-scale morphological dilation with a non-flat
structuring element: Serra, "Image Analysis and Mathematical Morphology", 1982; the probe-tip
model of Villarrubia, J. Res. NIST 102(4), 1997). It removes exactly the steep, narrow
features that drive q up. On a profile, each grid point's contact is found over the grid's
offsets and refined on the texture itself, and the path's slope is the texture's at the contact
(the envelope theorem), so the felt profile keeps the kinks where the ball bridges a trough
(``kinks``); on an areal map likewise, each grid point's contact found over the grid's offsets
inside the disc and refined by Newton steps on the surface, the map the bicubic Hermite patches
through the heights and the contacts' gradients. An analytic texture is first sampled on a grid
fine against its shortest period and the ball (the grid is stated in the felt texture's
``source``).
"""

from __future__ import annotations

import math

import numpy as np

from ._validation import ParameterError, fail, nonnegative, not_a_texture, positive

MAX_DILATION_WORK = 2e9
"""Most (samples x footprint points) one dilation may cost (17 s and 0.8 GB measured here at the
cap, a 1024 x 1024 map under a ball covering 1,900 of its grid points, the contacts' refinement
included): beyond it the call is refused, naming a coarser spacing that fits."""

MAX_SAMPLES = 4_000_000
"""Most samples an analytic texture is sampled on before its dilation."""


def felt_by(texture, tip_radius: float, *, spacing: float | None = None):
    """The texture a ball of radius ``tip_radius`` feels: the map dilated by the ball, minus r.

    Parameters
    ----------
    texture : Texture
        A profile or a surface (sampled or analytic). A profile's felt texture is a
        :class:`~haptex.SampledProfile`, a surface's a :class:`~haptex.SampledSurface`.
    tip_radius : float
        The ball's radius r (m), >= 0; 0 is the paper's point probe and returns ``texture``
        itself.
    spacing : float, optional
        Grid spacing (m) on which an analytic texture is sampled; default the finer of a 256th
        of its shortest period and a 32nd of r (a 16th of each over a surface, and finer, by the
        factors ``haptex.surfaces.REFINE`` up to ``REFINE_SAMPLES`` samples, while some cell
        beside a kink cannot be branched or the map is steeper than the surface, and by
        ``REFINE_STEEP`` while every grid is steeper than the surface). A profile's grid, a
        sampled profile's own first (then its spline resampled), is halved while its segments'
        curvature at the grid points misses the path's by more than
        ``haptex.textures.PROFILE_CURVATURE_SLACK`` of the path's largest, or their largest
        misses the path's at a kink where that is its largest (each branch followed to where the
        ball touches both), within ``PROFILE_REFINE_SAMPLES`` (near the troughs' radius the path's
        curvature spikes, and B, C and G read it). A periodic surface's map is made on finer grids
        likewise (as much finer as the last miss says, and not steeper than the surface) while
        its curvature misses the path's by more than ``haptex.surfaces.CURVATURE_SLACK``,
        within ``CURVATURE_REFINE_SAMPLES``; where the ball bridges it (an analytic surface's)
        on grids halved, against the kinks' one-sided limits too. A sampled surface keeps its own grid unless
        that leaves such a cell or steepness (then its spline is resampled at those factors of
        its interval, within ``REFINE_SAMPLES``). With ``spacing`` given a sampled texture is resampled onto that
        grid by its own spline (what a refusal for work suggests for a fine map and a large
        ball; on a periodic profile or map the steps divide its period or cell, none finer than
        ``spacing``). At most the coarsest grid the texture has: 4 samples along a period (an
        analytic texture's period or its cell's shorter side, a periodic sampled texture's
        period), or from a bounded scan's first sample to its last along its shorter side.

    Returns
    -------
    Texture
        Heights (m) of the ball's lowest point where it rests on the texture: c(p) - r with
        c as above, on the grid; periodic when the texture is (its period or cell). Where
        the ball touches the texture everywhere (r below the troughs' radius of curvature)
        it is the texture's offset curve, lowered by r.

    Raises
    ------
    ParameterError
        If ``texture`` is not a texture, r is negative, not finite or past 1 km
        (:data:`haptex._validation.MAX_LENGTH`), larger than a non-periodic map's extent, the texture
        has no period and is not sampled, ``spacing`` is not > 0 or past the coarsest grid (the
        message names it), or the dilation would exceed :data:`MAX_DILATION_WORK` (the message
        names a spacing that fits).

    Notes
    -----
    On a profile the felt heights and slopes are exact at the grid's points (the contact refined
    by golden-section search on the texture, then by Newton on the contact condition, to the last
    bits: the slopes within 1e-12 of the offset curve's); between them the profile is
    the cubic through heights and slopes; an interval across which the contact runs faster than
    three intervals an interval is the quadratic between its end slopes, so the slope never
    leaves the contacts', and one holding a kink (where the ball bridges the profile: it curves
    more than the ball somewhere between the two contacts) is straight at its mean, the slope
    jumping at its ends as the path's does at the kink (``kinks`` lists each kink's place and
    slope jump). On an areal map the contact is refined by safeguarded Newton steps on the
    surface, the map is the bicubic Hermite interpolant through the heights and the contacts'
    gradients, and each grid edge across which the contact jumps has its slopes along it kept
    within the contacts' as on a profile (``kinks``: each such edge's midpoint and slope jump;
    none, and no cell branched, where r times the surface's ``max_curvature`` is at most 1: the
    ball then touches it everywhere).
    Where the ball bridges a bowl (a trough closed in every direction) the path has a cone's
    apex, which tensor-product patches cannot follow: a cell across which the contact jumps is
    the maximum of one Hermite patch per contact (``branched_cells``); where a cell cannot be
    (on rough maps felt by balls of a few samples, where a ball nests in a bowl on some grids)
    it keeps its single patch: steeper than the path over a bowl (q on the safe side), but on a
    rough map, where it bridges the path's V-shaped kink, flatter (a 64 x 64 map of 1 um
    samples felt by balls of 4 to 7 um: -4.5 to +0.2 %, a texture less active than felt where
    flatter; from 8 um every such cell is branched, within 0.05 %; the measured-surfaces
    guide). The map is made again on finer grids while some such cell is left or the map is
    steeper than the surface (``haptex.surfaces.REFINE``). On a map that ends at its
    edges a contact may lie on the map's rim, where the path's gradient is u / sqrt(r^2 - |u|^2)
    (u the contact's offset). The contact is refined from the grid's best offset: a map whose
    spline peaks between its samples (not resolved by its grid) is felt at that contact, below
    the continuous maximum. The measured-surfaces guide tabulates the errors against
    brute-force ball paths.
    """
    if not callable(getattr(texture, "felt_by", None)):  # (a Texture: this module sits below the textures)
        raise not_a_texture(texture)
    return texture.felt_by(tip_radius, spacing=spacing)


def _spacing(texture, r, spacing, per_period: int, per_radius: int) -> float:
    """A felt grid's spacing (m): ``spacing`` checked (> 0 and at most :func:`_coarsest_spacing`),
    or the default, the finer of a ``per_period``-th of the texture's shortest period and a
    ``per_radius``-th of the ball's radius ``r`` (m)."""
    if spacing is not None:
        v = positive("spacing", spacing, "m")
        most, why = _coarsest_spacing(texture)
        if v > most:
            raise fail("spacing", spacing, f"a length > 0 and at most {most:g} m ({why}; --tip-spacing at the command "
                       "line)")
        return v
    return min(texture.shortest_period / per_period, r / per_radius)


def _coarsest_spacing(texture) -> tuple[float, str]:
    """The coarsest spacing (m) a felt grid of ``texture`` takes, and what sets it: 4 samples
    along a period (an analytic texture's period or its cell's shorter side; a periodic sampled
    texture's period along each axis), or from a bounded scan's first sample to its last (3 steps
    along its shorter side): the fewest the felt grid is made of (``textures._resampled_axis``)."""
    if getattr(texture, "h", None) is None:  # (analytic: its period, or its cell)
        cell = getattr(texture, "cell", None) or (texture.period,)
        return min(cell) / 4, "4 samples along the texture's period"
    axes = [texture.x] + ([texture.y] if texture.dimension == 2 else [])
    if texture.periodic:
        return min(float(a[-1] - a[0] + (a[1] - a[0])) for a in axes) / 4, "4 samples along the map's period"
    return min(float(a[-1] - a[0]) for a in axes) / 3, "4 samples from the first sample to the last"


def _steps_text(steps) -> str:
    """A resampled grid's steps (m, one an axis) as a felt texture's ``source`` states them: to 4
    digits in um, in nm where each is below 10 nm (opdx-3.opdx felt by a 5 um ball: "0.1301 nm",
    not "0.0001301 um"); one value where the axes' agree, else "dx x dy"."""
    scale, unit = (1e9, "nm") if max(steps) < 1e-8 else (1e6, "um")
    said = [f"{d * scale:.4g}" for d in steps]
    return f"{said[0] if len(set(said)) == 1 else ' x '.join(said)} {unit}"


def _grid_contacts(h: np.ndarray, steps, r: float, periodic: bool):
    """Each sample's highest grid offset under a ball of radius r (m) on heights h (a profile's
    (n,) or a map's (nx, ny), grid steps ``steps`` (m) an axis): the maximum of
    h(p + u) + sqrt(r^2 - |u|^2) over the offsets u = k * steps inside the disc (wrapped on a
    periodic grid, the edge samples repeated beyond another), shape h.shape, and the maximising
    offset in samples, one array of h.shape an axis (the first offset in C order on a tie). By
    the C core (``hx_grid_dilation``, hx_felt.c), on its threads in blocks of rows. Refused past
    :data:`MAX_DILATION_WORK`."""
    from .core import _ext, in_slices

    half = [int(np.floor(r / d)) for d in steps]
    _check_work(h.size, steps, r, radius=False)  # (before the list is made; the callers name the remedies)
    offs = _footprint(r, steps)
    lift = np.array([np.sqrt(max(r * r - sum((a * d) ** 2 for a, d in zip(k, steps)), 0.0)) for k in offs])
    table = np.array(offs, dtype=np.int64).reshape(len(offs), len(steps))
    h2 = np.asarray(h, dtype=np.float64).reshape(h.shape[0], -1)  # (a profile: one column)
    half2 = half + [0] * (2 - len(half))
    hp = np.ascontiguousarray(np.pad(h2, [(m, m) for m in half2], mode="wrap" if periodic else "edge"))
    pairs = np.ascontiguousarray(np.column_stack([table, np.zeros((len(offs), 2 - len(steps)), dtype=np.int64)]))
    best = np.empty(h2.shape)
    which = np.empty(h2.shape, dtype=np.int32)  # the best offset's index in offs
    in_slices(lambda a, b: _ext.grid_dilation(hp[a:b + 2 * half2[0]], pairs, lift, half2[0], half2[1], best[a:b],
                                              which[a:b]), h2.shape[0], least=8)
    best, which = best.reshape(h.shape), which.reshape(h.shape)
    return best, [table[which, axis] for axis in range(len(steps))]


def _footprint(r: float, steps) -> list:
    """The grid offsets (tuples of samples, one an axis of ``steps``) inside a ball of radius r."""
    import itertools

    half = [int(np.floor(r / d)) for d in steps]
    return [k for k in itertools.product(*(range(-m, m + 1) for m in half))
            if sum((a * d) ** 2 for a, d in zip(k, steps)) <= r * r]


def _footprint_count(r: float, steps, stop: float = math.inf) -> tuple[int, bool]:
    """(``len(_footprint(r, steps))``, True), without making the list (the same inequality, the
    same float operations): a row of the last axis at a time, each row's count from its largest
    offset m (2 m + 1: (a d)^2 grows with |a|, rounding included), found from sqrt and corrected
    by the inequality itself; in constant memory where a row as an array held 2 GB for a ball of
    1 km on a sinusoid's grid (and 1.9 TiB was asked for at 1e9 m). Once the count passes
    ``stop`` it ends there, the rows taken from the ball's edge inwards: (a count above
    ``stop``, False), a lower bound."""
    half = [int(np.floor(r / d)) for d in steps]
    d = steps[-1]
    rows = range(-half[0], half[0] + 1) if len(steps) == 2 else (None,)  # (a map's rows, lazily; a profile's one)
    n = 0
    for i, a in enumerate(rows):
        lead = 0.0 if a is None else (a * steps[0]) ** 2
        if lead > r * r:
            continue
        m = min(half[-1], int(math.sqrt(max(r * r - lead, 0.0)) / d))
        while m >= 0 and lead + (m * d) ** 2 > r * r:
            m -= 1
        while m < half[-1] and lead + ((m + 1) * d) ** 2 <= r * r:
            m += 1
        n += 2 * m + 1 if m >= 0 else 0
        if n > stop and i < len(rows) - 1:
            return n, False
    return n, True


def _fits_work(samples: int, r: float, steps) -> bool:
    """Whether ``samples`` x the ball's grid points are within MAX_DILATION_WORK (counted no
    further than that needs)."""
    n, done = _footprint_count(r, steps, stop=MAX_DILATION_WORK / max(samples, 1))
    return done and float(samples) * n <= MAX_DILATION_WORK


def _check_work(samples: int, steps, r: float, *, grid_at=None, radius: bool = True, crop: bool = False,
                spacing: float | None = None, coarsest: float = math.inf) -> None:
    """Refuse a dilation of more than MAX_DILATION_WORK (``samples`` x the ball's grid points on
    a grid of ``steps``, m an axis, a ball of radius r, m), naming each remedy's bound as this
    count gives it, so that one taken exactly at its bound is not refused again (issue 67): with
    ``radius``, the largest radius on this grid; with ``crop``, the most samples a part of the map
    may keep (where a part that holds the ball can: each side at least r); with ``grid_at`` (a
    spacing S, m, -> (samples, steps) of the grid ``felt_by(r, spacing=S)`` makes), the finest
    spacing (``spacing``: the one this grid was made at, which a smaller radius keeps), up to
    ``coarsest`` (m; :func:`_coarsest_spacing`: none named past it, which is refused). Each
    bound is rounded to 3 significant digits on its safe side (in um below 1 mm, else mm, as the
    command line writes it; the same double in Python) and checked again."""
    footprint, exact = _footprint_count(r, steps, stop=MAX_DILATION_WORK)  # (exact where a crop may be named)
    work = float(samples) * float(footprint)
    if exact and work <= MAX_DILATION_WORK:
        return
    covers = f"{footprint}" if exact else f"more than {footprint}"
    ways = []
    if radius and samples <= MAX_DILATION_WORK:  # (a ball of one grid point fits)
        def fits(v):
            return _fits_work(samples, v, steps)

        value, text = _stated_length(_fitting_edge(fits, 0.0, r), up=False, fits=fits)  # (more points as r grows)
        if value > 0:
            ways.append(f"a radius of at most {text} on this grid (--tip-radius {text} or less at the command line, "
                        f"felt_by({value!r}{'' if spacing is None else f', spacing={spacing!r}'}) in Python)")
    if crop and exact:  # (a ball past the budget alone fits no part)
        most = int(MAX_DILATION_WORK // footprint)
        side = [int(r // d) + 2 for d in steps]  # (samples a side of the smallest part that holds the ball)
        if int(np.prod(side)) <= most:
            ways.append(f"a part of the map of at most {most:,} samples, each side at least {r * 1e6:.4g} um long "
                        "(--crop at the command line, crop= in load_texture)")
    if grid_at is not None:
        def fits(v):
            if not v <= coarsest:
                return False
            n, st = grid_at(v)
            return _fits_work(n, r, st)

        lo = float(max(steps))
        hi = min(lo * max(2.0, (work / MAX_DILATION_WORK) ** (1.0 / len(steps))), coarsest)
        for _ in range(60):  # (a bracket: the work falls as the spacing grows)
            if fits(hi) or hi >= coarsest:
                break
            if repr(grid_at(2 * hi)) == repr(grid_at(hi)):  # (the grid coarsens no further: its texture's own)
                break
            lo, hi = hi, min(2 * hi, coarsest)
        value = 0.0
        if lo < hi and fits(hi):  # (none where the grid's coarsest, its texture's own, still holds too many)
            value, text = _stated_length(_fitting_edge(fits, hi, lo), up=True, fits=fits)
        if value > 0:  # (0: none as the command line writes it, rounded up, within the coarsest)
            ways.append(f"a coarser grid (--tip-spacing {text} or more at the command line, felt_by(r, spacing=S) "
                        f"with S >= {value!r} m in Python)")
    remedy = "; ".join(ways) if ways else "a smaller radius"
    raise ParameterError(
        f"tip_radius = {r:g} is not allowed here: the ball covers {covers} grid points, {'' if exact else 'more than '}"
        f"{work:.3g} operations over {samples} samples, more than {MAX_DILATION_WORK:.3g}; {remedy}")


def _fitting_edge(fits, inside: float, outside: float, steps: int = 60) -> float:
    """Bisection between a value where ``fits`` holds (``inside``) and one where it does not
    (``outside``), either side of the other: the last value found where it holds."""
    for _ in range(steps):
        mid = 0.5 * (inside + outside)
        if fits(mid):
            inside = mid
        else:
            outside = mid
    return inside


def _check_ball_fits(texture, r: float) -> None:
    """Refuse a ball of radius r (m; a number >= 0 first) wider than a bounded sampled texture:
    a profile's length, a map's shorter side (on its cells' mean widths where its axes are
    graded), in :func:`_wider_than`'s words. Periodic and analytic textures have no extent."""
    r = nonnegative("tip_radius", r, "m")
    if getattr(texture, "periodic", True) or not hasattr(texture, "h"):  # (periodic, or analytic: no extent)
        return
    if hasattr(texture, "_regular"):  # a sampled map (haptex.surfaces is not imported here: it imports this)
        texture = texture._regular()
        extent, what = min(texture.x[-1] - texture.x[0], texture.y[-1] - texture.y[0]), "the map's shorter side"
    elif np.ndim(texture.h) == 1:
        extent, what = texture.x[-1] - texture.x[0], "the profile's length"
    else:
        return
    if r > extent:
        raise _wider_than(r, extent, what)


def _wider_than(r: float, extent: float, what: str) -> ParameterError:
    """The refusal of a ball of radius r (m) wider than a bounded map's ``extent`` (m; ``what``
    names it), its bound rounded down to 6 significant digits so that, taken as written, the
    radius is not refused again (issue 67: "0.0828491 mm" for a side of 0.08284907 mm was)."""
    value, text = _stated_length(extent, up=False, fits=lambda v: v <= extent, digits=6)
    return ParameterError(f"tip_radius = {r:g} is not allowed: must be at most {what}, {text} "
                          f"(tip_radius <= {value!r} in Python)")


def _stated_length(v: float, up: bool, fits, digits: int = 3) -> tuple[float, str]:
    """A length v (m) rounded up (or down) to ``digits`` significant digits as a user writes it:
    (the double, the command line's text in um below 1 mm, else mm), moved a last digit at a time
    further to its safe side until ``fits`` holds of the double (0.0 where it cannot;
    :func:`haptex._units.stated_number`)."""
    from ._units import stated_number

    if not v > 0:
        return 0.0, "0m"
    unit, exponent = ("um", -6) if v < 1e-3 else ("mm", -3)
    value, text = stated_number(v, up, fits, digits, exponent)
    return (value, text + unit) if value > 0 else (0.0, "0m")


def reliability_cutoff(texture, instrument_tip: float) -> float | None:
    """The length scale below which a measured map cannot be trusted, given the instrument's tip.

    A scanning probe (a stylus profilometer, an AFM) of tip radius R cannot follow features whose
    curvature is sharper than its own: below some scale the measured heights are the tip's shape,
    not the surface's. SurfaceTopography finds that scale from the map itself: the scale below
    which the scale-dependent curvature drops under -1 / (2 R) (its
    ``scanning_probe_reliability_cutoff``; L. Sanner, W. Nöhring, A. Thimons, T. Jacobs and
    L. Pastewka, "Scale-dependent roughness parameters for topography analysis", Applied Surface
    Science Advances 7, 100190, 2022). :func:`haptex.design` keeps the rendered texture above it.

    Parameters
    ----------
    texture : SampledProfile or SampledSurface
        A measured texture: heights (m) on a uniform grid (m).
    instrument_tip : float
        The measuring tip's radius R (m), finite and > 0.

    Returns
    -------
    float or None
        The scale (m); None where no scale of the map is affected.

    Raises
    ------
    ParameterError
        For a radius not finite and > 0, or a texture that was not measured (an analytic one has
        no instrument).
    """
    from SurfaceTopography import Topography, UniformLineScan

    if not callable(getattr(texture, "felt_by", None)):  # (a Texture: this module sits below the textures)
        raise not_a_texture(texture)
    r = positive("instrument_tip", instrument_tip, "m")
    if getattr(texture, "_knots", None) is not None:  # (a map on graded axes: at its cells' mean widths)
        texture = texture._regular()
    h = getattr(texture, "h", None)  # a measured texture's heights on its grid
    if h is not None and h.ndim == 1:
        dx = float(texture.x[1] - texture.x[0])
        topo = UniformLineScan(np.asarray(texture.h, dtype=np.float64), dx * texture.h.size,
                               periodic=bool(texture.periodic), unit="m")
    elif h is not None and h.ndim == 2:
        dx, dy = float(texture.x[1] - texture.x[0]), float(texture.y[1] - texture.y[0])
        nx, ny = texture.h.shape
        topo = Topography(np.asarray(texture.h, dtype=np.float64), (dx * nx, dy * ny),
                          periodic=bool(texture.periodic), unit="m")
    else:
        raise fail("instrument_tip", r, "given for a measured texture (SampledProfile or SampledSurface): "
                   f"{type(texture).__name__} was not measured by an instrument")
    cut = topo.scanning_probe_reliability_cutoff(r)
    return None if cut is None else float(cut)

