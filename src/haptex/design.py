"""The design question: for a texture and a device, which algorithm, how stiff, will it be
passive, will the device even reproduce the texture?"""

from __future__ import annotations

import math

import numpy as np

from ._validation import ParameterError, fail, positive
from .algorithms import ALGORITHMS
from .analysis import (characteristic_number, checked_algorithms, conservativity, continuity, paper_loop, rendering_cutoff,
                       texture_limits)
from .analysis.passivity import SAMPLES_PER_PERIOD
from .catalogue import DEFAULT_HAND, checked_device, presets
from .devices import Device
from .limits import stiffness_at, wall_limits
from .surfaces import _symmetric_2x2_norm
from .textures import Texture, checked_texture

LETTERS = "".join(ALGORITHMS)
TIME_BUDGET = 120.0
"""The planned analysis time (s, one core's, :mod:`haptex.analysis.cost`'s estimate) within which
:func:`design` analyses by default (chosen: with the reading and band-limiting, a result within
the 180 s issue 67 asks of every instrument file); beyond it the costliest algorithms are left
out, and said."""
MIN_CUTOFF_PERIODS = 2.0
"""A measured texture must span at least this many cut-off periods l_c along every axis to
be analysed as rendered (chosen: two, so that a rendered period is told from a tilt)."""


def _chosen(algorithms, defined, default, where: str) -> list[str]:
    """The letters to analyse, in ``defined``'s order: ``default`` for None, else those given
    (each one of ``defined``, the algorithms defined ``where``)."""
    if algorithms is None:
        return [L for L in defined if L in default]
    given = [str(v).strip().upper() for v in algorithms]
    if not given or any(v not in defined for v in given):
        raise fail("algorithms", ",".join(given) or algorithms, f"one or more of {', '.join(defined)} (the algorithms "
                   f"defined {where})")
    return [L for L in defined if L in given]


def design(texture: Texture, device: Device, stiffness: float, speed: float = 0.1, max_penetration: float = 1e-3,
           samples_per_period=SAMPLES_PER_PERIOD, friction: float = 0.8, presliding: float = 1e-3, n_loops: int = 4,
           x_range=None, progress=None, band_limit: bool = True, hand=DEFAULT_HAND, on_estimate=None,
           base=None, algorithms=None, instrument_tip: float | None = None,
           reliability_cutoff: float | None = None, time_budget: float | None = TIME_BUDGET) -> dict:
    """Analyse every algorithm for one texture on one device and recommend.

    Parameters
    ----------
    texture : Texture
        Any profile (Sinusoid, SumOfSinusoids, BandLimitedNoise, SampledProfile) or surface
        (SumOfGratings, BandLimitedNoise2D, SampledSurface, Extruded); the algorithms defined
        for it are analysed (``algorithms``).
    device : Device
        Of the texture's dimension plus one (3-DOF over a surface).
    stiffness : float
        The nominal stiffness kappa_0 the user wants (N/m).
    speed : float, optional
        Scanning speed (m/s) for the rendering limits.
    max_penetration : float, optional
        Depth of the rendering region (m); also F's d^z_max.
    samples_per_period : float, optional
        alpha, beta, gamma of Section II-B (default
        :data:`haptex.analysis.passivity.SAMPLES_PER_PERIOD`, 5).
    friction, presliding : float, optional
        F's mu and d^x_max (m).
    n_loops : int, optional
        Random closed polygons per algorithm for the conservativity measurement.
    x_range : (float, float), optional
        Abscissa window analysed (m); default the texture's domain (one period, or the
        sampled range of a measured profile). A window keeps long profiles quick.
    progress : callable, optional
        Called with each step's name before it runs ("band-limiting", then each
        algorithm's letter): a progress display.
    band_limit : bool, optional
        Analyse what the device renders (default): a sampled texture (SampledProfile,
        SampledSurface) holding periods shorter than the device's cut-off l_c
        (:func:`~haptex.analysis.rendering_cutoff`: the four period limits of Section II-B
        at ``speed``) is low-passed to l_c and resampled to 32 samples per l_c (a map to 16)
        (``band_limited``) before any analysis. False analyses the raw samples (slow, and
        often refused: a raw scan's Nyquist period makes the rendering region thousands
        of periods deep). Analytic textures are analysed as they are; the limits table
        says whether their shortest period is rendered.
    hand : str or Hand, optional
        The hand gripping the handle for the stable limits (:func:`haptex.catalogue.hands`;
        default :data:`~haptex.catalogue.DEFAULT_HAND`, ``"none"`` for the device alone).
    on_estimate : callable, optional
        Called once, after band-limiting and before any analysis, with the ``estimate``
        below: a command line prints it.
    base : haptex.objects.Base, optional
        Render the texture on an object (:mod:`haptex.objects`: a plane, cylinder, sphere or
        triangle mesh) instead of a plane: A, B, C, F and G by default (``algorithms``) are
        analysed there, their grids and loops laid in the base's coordinates (u1, u2, e). The
        device must be 3-DOF; a profile is extruded along u2.
    algorithms : iterable of str, optional
        The letters to analyse (e.g. "DE" or ["A", "F"]), in the library's order. Default:
        every letter defined for the texture on the plane; on an object A, B, C, F and G
        (:data:`haptex.objects.OBJECT_DESIGN_LETTERS`), and D and E on request (not on a
        faceted mesh) (each of their field values is a closest-point search over the
        object: about 10 s a letter at 1 mm).

    instrument_tip : float, optional
        The radius (m) of the tip that measured a sampled texture: below its reliability
        cutoff (:func:`haptex.probe.reliability_cutoff`) the map is the tip's shape, so the
        rendered texture holds no shorter period (the cutoff is one more bound of the band
        limit, ``instrument tip``). Default the file's own, where it gives one
        (``texture.instrument_tip``), else none.
    reliability_cutoff : float, optional
        That scale (m) itself, computed by the caller on the map as measured
        (:func:`haptex.probe.reliability_cutoff`), as it must be when ``texture`` is a tip's
        felt surface of it (``haptex design --tip-radius --instrument-tip``); the tip is then
        only reported.
    time_budget : float or None, optional
        The planned analysis time (s, one core's) allowed, default :data:`TIME_BUDGET`; None
        for no limit. When the plan of the default algorithms exceeds it, the costliest are
        left out one by one until it fits (``estimate["left_out"]``: each one's planned
        seconds, said in the recommendation); with ``algorithms`` given, a plan over it is
        refused.

    Returns
    -------
    dict
        ``units`` (the SI unit of every number below), ``texture``, ``device``, ``stiffness``, ``limits`` (list of dicts),
        ``wall_stability_limit`` (the sampled wall's critical stiffness along the normal
        from the closed-loop poles, the device alone, N/m), ``wall_limits`` (every limit of
        :func:`haptex.limits.wall_limits` with the hand, ``passive_stiffness`` and
        ``stable_stiffness``, and the manufacturer's figure beside, never an input),
        ``rows`` (per algorithm: ``q``, ``max_passive_stiffness`` (Corollary 1 / q),
        ``max_stable_stiffness`` (the wall's stable limit with the hand / q: the local
        stiffness q kappa_0 kept below it, a linearisation), ``passive_at_stiffness``,
        ``stable_at_stiffness``, ``conservative``,
        ``almost_conservative``, ``max_abs_loop_energy``, ``continuous``, ``q_where``: the
        probe position [x, z] (m) attaining q) and
        ``recommendation`` (text) with ``recommended`` (letters), and ``band_limit``: the
        cut-off ``cutoff`` (m), the limit(s) ``set_by`` it, each limit's ``bounds`` (m),
        whether it was ``applied`` (and the texture ``filtered``, not only resampled),
        ``samples`` raw and rendered, ``instrument_tip`` (m, or None) and its
        ``reliability_cutoff`` (m, or None), and ``raw``: the given
        texture's own numbers (shortest period, max slope, max curvature, height range, and
        for sampled textures its RMS height, dominant period and the RMS the cut-off
        removes). The other numbers are those of the rendered texture. ``estimate``: the
        planned cost (:mod:`haptex.analysis.cost`): ``seconds`` (the grids only, at one core's time an evaluation),
        ``peak_bytes``, ``searches`` (closest-point searches of D and E: the continuity grids'
        once, E reads D's, and each one's q region's first batch), ``seconds_per_search`` and
        per algorithm ``evaluations`` and ``seconds``;
        ``time_budget`` (s) and ``left_out`` (letter: planned seconds).
        ``vibration``: the rendered texture in the data-driven language, what a tip following it
        along x at ``speed`` records in 20-450 Hz
        (:meth:`haptex.datadriven.FollowerVibration.as_dict`), or ``unavailable`` with why.

    Raises
    ------
    ParameterError
        For invalid parameters, a device of the wrong dimension, a texture that does not fit
        the base (:func:`haptex.objects.object_algorithm`), ``algorithms`` naming one not
        defined there, a ``time_budget`` that is not > 0, or ``algorithms`` given whose plan
        exceeds ``time_budget`` (naming each one's seconds).
    """
    texture = checked_texture(texture)
    device = checked_device(device)
    if time_budget is not None:
        time_budget = positive("time_budget", time_budget, "s")
    if base is not None and device.dimension != 3:
        raise ParameterError(f"device = {device.name!r} with dimension = {device.dimension} is not allowed on an "
                             "object: it needs a 3-DOF device")
    if base is None and device.dimension != texture.dimension + 1:
        raise ParameterError(f"device = {device.name!r} with dimension = {device.dimension} is not allowed for "
                             f"{texture!r}: a {'surface needs a 3-DOF' if texture.dimension == 2 else 'profile needs a planar'}"
                             " device")
    wall = wall_limits(device, hand, preset=presets().get(device.details.get("preset")))
    if progress is not None:
        progress("band-limiting")
    given = texture
    texture, band = _band_limited(texture, device, speed, samples_per_period, band_limit, instrument_tip,
                                  reliability_cutoff, max_penetration)
    if x_range is not None:
        _check_window(given, x_range)  # the scan or map as measured, whose extent the user knows
    if base is None:
        defined = [L for L in LETTERS if texture.dimension == 1 or ALGORITHMS[L].surfaces]
        letters = _chosen(algorithms, defined, defined, "for this texture")
    else:
        from .objects import OBJECT_DESIGN_LETTERS, OBJECT_LETTERS, Mesh

        defined = [L for L in OBJECT_LETTERS if not (L in "DE" and isinstance(base, Mesh) and base._vn is None)]
        letters = _chosen(algorithms, defined, OBJECT_DESIGN_LETTERS, f"on {base!r}")
    algs = checked_algorithms(letters, texture, stiffness, max_penetration, friction, presliding, base=base)
    estimate = _estimate(algs, max_penetration, x_range)
    left_out = {}
    if time_budget is not None and estimate["seconds"] > time_budget:
        costs = ", ".join(f"{L} {v['seconds']:.3g} s" for L, v in estimate["algorithms"].items())
        if algorithms is not None:
            raise fail("time_budget", f"{time_budget:g} s", f"at least the plan of the algorithms asked for, "
                       f"{estimate['seconds']:.3g} s ({costs}): give a larger --time-budget (time_budget=), or "
                       "fewer --algorithms")
        while estimate["seconds"] > time_budget and len(algs) > 1:
            # the costliest first (E's planned time counts the continuity grids' searches once D is out)
            worst = max(estimate["algorithms"], key=lambda L: estimate["algorithms"][L]["seconds"])
            left_out[worst] = estimate["algorithms"][worst]["seconds"]
            del algs[worst]
            estimate = _estimate(algs, max_penetration, x_range)
        if estimate["seconds"] > time_budget:
            raise fail("time_budget", f"{time_budget:g} s", f"at least the cheapest algorithm's plan, "
                       f"{estimate['seconds']:.3g} s ({costs}): give a larger --time-budget (time_budget=)")
    estimate["time_budget"] = time_budget
    estimate["left_out"] = left_out
    if on_estimate is not None:
        on_estimate(estimate)
    rows = []
    for L, alg in algs.items():
        if progress is not None:
            progress(L)
        xr = None if L == "W" else x_range
        q = characteristic_number(alg, max_penetration=max_penetration, x_range=xr)
        kmax = stiffness_at(device.passivity_limit, q.value)
        kstable = stiffness_at(wall.stable, q.value)
        cons = conservativity(alg, max_penetration=max_penetration, n_random=n_loops, x_range=xr)
        cont = continuity(alg, max_penetration=max_penetration, levels=3, x_range=xr)
        # D's q unbounded is certified by a focal point within the depth analysed, its own closest
        # point: below it the closest point is two, and the force's direction jumps across the
        # medial axis (Remark 6), however much finer than the grids the map's features are
        continuous = cont.continuous and not (L == "D" and math.isinf(q.value))
        try:
            path = None if base is not None else paper_loop(alg)[0]  # (on a plane only)
        except Exception:  # the Fig. 3 paths are defined for sinusoids only
            path = None
        rows.append({
            "algorithm": L, "name": alg.name, "q": q.value, "q_note": q.note, "q_where": list(q.where),
            "max_passive_stiffness": kmax, "passive_at_stiffness": bool(stiffness <= kmax),
            "max_stable_stiffness": kstable, "stable_at_stiffness": bool(stiffness <= kstable),
            "conservative": cons.conservative, "almost_conservative": cons.almost,
            "max_abs_loop_energy": max((abs(e) for e in cons.random_loop_energies), default=0.0),
            "continuous": continuous, "has_paper_loop": path is not None,
        })
    wall_limit = wall["device"].value
    limits = texture_limits(texture, device, speed, stiffness, samples_per_period)
    from .datadriven import follower_vibration

    try:  # the rendered texture in the data-driven language: what a tip following it records
        vibration = follower_vibration(texture, speed).as_dict()
    except ParameterError as exc:
        vibration = {"unavailable": str(exc)}
    textured = [r for r in rows if r["algorithm"] != "W"]
    good = [r["algorithm"] for r in textured if r["passive_at_stiffness"] and r["conservative"] and r["continuous"]]
    fair = [r["algorithm"] for r in textured if r["passive_at_stiffness"] and r["continuous"]
            and (r["conservative"] or r["almost_conservative"]) and r["algorithm"] not in good]
    text = []
    if good:
        text.append(f"passive (Corollary 1), conservative and continuous at {stiffness:g} N/m: {', '.join(good)}")
    if fair:
        text.append(f"passive and almost conservative (dissipative friction): {', '.join(fair)}")
    softer = [r for r in textured if r["conservative"] and r["continuous"] and not r["passive_at_stiffness"]]
    never = [r["algorithm"] for r in softer if not r["max_passive_stiffness"] > 0]  # (q unbounded: Corollary 1)
    softer = [r for r in softer if r["max_passive_stiffness"] > 0]
    if not good and not fair and not softer:
        text.append(f"no textured algorithm is passive, conservative and continuous at {stiffness:g} N/m")
    elif not good:
        text.append(f"none is passive, conservative and continuous at {stiffness:g} N/m")
    if softer:
        text.append("conservative and continuous if the stiffness is lowered: " + ", ".join(
            f"{r['algorithm']} up to {_at_most(r['max_passive_stiffness'])} N/m" for r in softer))
        held = [r["algorithm"] for r in softer if r["stable_at_stiffness"]]
        if held and not wall.hand.none:
            text.append(f"stable but not passive at {stiffness:g} N/m with the hand {wall.hand.key!r}: "
                        f"{', '.join(held)} (its damping holds the loop; another grip may not)")
    if never:
        text.append("conservative and continuous on the grids checked but passive at no stiffness: "
                    f"{', '.join(never)} (q unbounded)")
    if left_out:
        text.append(f"left out for the time budget of {time_budget:g} s: " + ", ".join(
            f"{L} (planned {v:.3g} s)" for L, v in left_out.items())
            # (a quarter more than the plan: its evaluation times are measured, and vary)
            + f"; --time-budget {_nice(1.25 * (time_budget + sum(left_out.values())), True)}s analyses them")
    failed = [lim.name for lim in limits if not lim.passed]
    if failed:
        text.append("the device cannot reproduce this texture faithfully: " + ", ".join(failed) + " limit(s) violated")
    return {
        "units": {"cutoff": "m", "bounds": "m", "instrument_tip": "m", "reliability_cutoff": "m", "rms": "m",
                  "rms_removed": "m", "dominant_period": "m",
                  "stiffness": "N/m", "speed": "m/s", "max_penetration": "m", "friction": "1", "presliding": "m",
                  "x_range": "m", "passivity_limit": "N/m", "wall_stability_limit": "N/m", "shortest_period": "m",
                  "max_slope": "1", "max_curvature": "1/m", "height_range": "m", "q": "1", "q_where": "m",
                  "max_passive_stiffness": "N/m", "max_stable_stiffness": "N/m", "max_abs_loop_energy": "J",
                  "limits": "each limit's 'unit'", "wall_limits": "N/m", "time_budget": "s", "left_out": "s",
                  "vibration": "speed m/s, band Hz, rms m/s^2, wavelengths m, covered Hz, share 1, "
                               "peak_frequency Hz, margin_db dB"},
        "texture": repr(given), "rendered_texture": repr(texture), "device": device.name, "stiffness": stiffness, "speed": speed,
        "max_penetration": max_penetration, "friction": friction, "presliding": presliding,
        "x_range": None if x_range is None else np.asarray(x_range, dtype=float).tolist(),
        "passivity_limit": device.passivity_limit,
        "wall_stability_limit": wall_limit, "wall_limits": wall.as_dict(),
        "texture_numbers": {"shortest_period": texture.shortest_period, "max_slope": texture.max_slope,
                            "max_curvature": texture.max_curvature, "height_range": list(texture.height_range)},
        "limits": [{"name": lim.name, "formula": lim.formula, "lhs": lim.lhs, "rhs": lim.rhs, "unit": lim.unit,
                    "passed": lim.passed} for lim in limits],
        "rows": rows, "recommended": good + fair, "recommendation": "; ".join(text), "band_limit": band,
        "estimate": estimate, "object": None if base is None else repr(base), "vibration": vibration,
    }


def _estimate(algs: dict, max_penetration: float, x_range) -> dict:
    """The planned cost of :func:`design`'s analyses (see its ``estimate``)."""
    from .analysis.cost import analysis_cost

    per, searched, each_search = {}, 0, 0.0
    for L, alg in algs.items():
        xr = None if L == "W" else x_range
        # (E reads the closest points D searched on the continuity grids)
        shared = alg.penetration_kind == "distance" and searched
        c = analysis_cost(alg, max_penetration, xr, continuity=not shared)
        if c.searches:
            searched += c.evaluations
            each_search = each_search or c.seconds_each
        per[L] = {"evaluations": c.evaluations, "seconds": c.seconds, "peak_bytes": c.peak_bytes}
    return {"seconds": sum(v["seconds"] for v in per.values()),
            "peak_bytes": max((v["peak_bytes"] for v in per.values()), default=0),
            "searches": searched, "seconds_per_search": each_search, "algorithms": per,
            "units": {"seconds": "s", "peak_bytes": "B", "seconds_per_search": "s"}}


def _rendered(texture: Texture, cutoff: float, band_limit: bool = True):
    """(rendered, filtered): the texture low-passed to ``cutoff`` when it holds shorter
    periods (filtered), then resampled (rendered); the texture itself for analytic
    textures or ``band_limit=False``."""
    if not (band_limit and hasattr(texture, "band_limited")):
        return texture, texture
    filtered = texture.lowpass(cutoff) if cutoff > texture.shortest_period else texture
    return filtered.band_limited(cutoff), filtered  # resampling only: filtered is band-limited


def rendered_texture(texture: Texture, device: Device, speed: float = 0.1, samples_per_period=SAMPLES_PER_PERIOD,
                     band_limit: bool = True) -> Texture:
    """The texture :func:`design` analyses: a sampled texture band-limited to the device's
    cut-off at ``speed`` and resampled (see ``band_limit`` there); the texture itself
    otherwise.

    Parameters
    ----------
    texture : Texture
        The texture (a sampled one is band-limited; another is returned as is).
    device : Device
        The device it is rendered on (its cut-off period at ``speed``).
    speed : float, optional
        Scanning speed (m/s), > 0.
    samples_per_period : float, optional
        Samples a cut-off period the scanning-velocity limit asks for (the paper's alpha;
        default :data:`haptex.analysis.passivity.SAMPLES_PER_PERIOD`, 5).
    band_limit : bool, optional
        False: the texture as given.

    Returns
    -------
    Texture
        The band-limited, resampled texture, or ``texture`` itself.

    Raises
    ------
    ParameterError
        For a non-positive speed or sample count.
    """
    texture = checked_texture(texture)
    device = checked_device(device)
    return _rendered(texture, rendering_cutoff(device, speed, samples_per_period).period, band_limit)[0]


def _check_span(texture: Texture, device: Device, speed: float = 0.1, max_penetration: float | None = None,
               samples_per_period=SAMPLES_PER_PERIOD, instrument_tip: float | None = None,
               reliability_cutoff: float | None = None) -> None:
    """Refuse a measured texture too short for what ``device`` renders at ``speed``, as
    :func:`design` does when it band-limits it, before anything costly is made of it (the
    command line's ``--tip-radius``: a ball on a bounded map feels a map of the same extent).

    Parameters
    ----------
    texture : Texture
        A measured profile or map (one with ``band_limited``); any other is not checked.
    device, speed, max_penetration, samples_per_period, instrument_tip, reliability_cutoff
        As :func:`design`'s (m/s, m, samples, m, m).

    Raises
    ------
    ParameterError
        If an axis of the texture spans less than ``MIN_CUTOFF_PERIODS`` of the shortest period
        the device renders, l_c (Section II-B's limits), naming a magnification and, where the
        speed sets l_c, a slower scan (with the depth analysed at it).
    """
    if hasattr(texture, "band_limited"):
        cut = _cutoff(texture, device, speed, samples_per_period, instrument_tip, reliability_cutoff)[0]
        _check_renderable(texture, device, speed, cut, max_penetration)


def _cutoff(texture: Texture, device: Device, speed: float, samples_per_period, instrument_tip, reliable):
    """(The rendering cut-off, with the instrument tip's bound where there is one; that bound, m,
    or None; the instrument tip's radius taken, m, or None)."""
    cut = rendering_cutoff(device, speed, samples_per_period)
    tip = getattr(texture, "instrument_tip", None) if instrument_tip is None else instrument_tip
    if reliable is not None:
        reliable = positive("reliability_cutoff", reliable, "m")
    elif tip is not None:
        from .probe import reliability_cutoff

        reliable = reliability_cutoff(texture, tip)
    if reliable is not None:  # one more bound: the map is the tip's shape below it
        from .analysis.passivity import Cutoff

        cut = Cutoff.from_bounds({**cut.bounds, "instrument tip": reliable})
    return cut, reliable, tip


def _band_limited(texture: Texture, device: Device, speed: float, samples_per_period, band_limit: bool,
                  instrument_tip: float | None = None, reliable: float | None = None,
                  max_penetration: float | None = None):
    """The texture the device renders, and what band-limiting did (see :func:`design`)."""
    cut, reliable, tip = _cutoff(texture, device, speed, samples_per_period, instrument_tip, reliable)
    sampled = hasattr(texture, "band_limited")
    if sampled and band_limit:
        _check_renderable(texture, device, speed, cut, max_penetration)
    rendered, filtered = _rendered(texture, cut.period, band_limit)
    if rendered is texture:  # analysed as given: its spline's numbers are needed anyway
        raw = {"shortest_period": texture.shortest_period, "max_slope": texture.max_slope,
               "max_curvature": texture.max_curvature, "height_range": list(texture.height_range)}
    else:  # not analysed: the samples' own numbers, at a cost that follows the file, not the spline's sups
        raw = {"shortest_period": texture.shortest_period, **_sample_numbers(texture)}
    if sampled:
        # RMS and what the cut-off removes, both of the levelled samples (least-squares line or
        # plane removed): a tilt is neither texture nor removed by a low-pass (issue 35: the
        # removed RMS exceeded the RMS of two tilted line scans)
        levelled = texture.leveled()
        raw["rms"] = float(np.std(levelled.h))
        spec = levelled.spectrum()
        amp = spec[-1].copy()
        amp.flat[0] = 0.0  # not the mean
        k = np.unravel_index(int(np.argmax(amp)), amp.shape)
        freq = abs(spec[0][k[0]]) if amp.ndim == 1 else float(np.hypot(spec[0][k[0]], spec[1][k[1]]))
        raw["dominant_period"] = float(1.0 / freq) if freq > 0 else None
        raw["rms_removed"] = (float(np.std(levelled.h - levelled.lowpass(cut.period).h))
                              if filtered is not texture else 0.0)
    return rendered, {
        "cutoff": cut.period, "set_by": list(cut.set_by), "bounds": dict(cut.bounds),
        "applied": rendered is not texture, "filtered": filtered is not texture, "requested": bool(band_limit),
        "sampled": sampled, "instrument_tip": tip, "reliability_cutoff": reliable,
        "samples": {"raw": int(texture.h.size) if sampled else None,
                    "rendered": int(rendered.h.size) if sampled else None},
        "raw": raw,
    }


def _spans(texture) -> list[tuple[str, float]]:
    """(axis, length in m) of a sampled texture's measured extent, per in-plane axis."""
    dom = texture.domain
    if texture.dimension == 1:
        return [("x", dom[1] - dom[0])]
    return [(a, hi - lo) for a, (lo, hi) in zip("xy", dom)]


def _nice(v: float, up: bool) -> str:
    """v > 0 rounded up (or down) to two significant digits as written on a command line, never
    on the wrong side of v as the text reads back (:func:`haptex._units.stated_number`)."""
    from ._units import stated_number

    return stated_number(v, up, (lambda w: w >= v) if up else (lambda w: w <= v), 2)[1]


def _at_most(v: float, digits: int = 3) -> str:
    """v > 0 rounded down to ``digits`` significant digits as written on a command line ("1310"
    for 1,315.8), within v as the text reads back (:func:`haptex._units.stated_number`): a bound
    a user takes as written is then within it (issue 67: "C up to 1.32e+03 N/m" for 1,315.8 N/m
    was refused again at 1320)."""
    from ._units import stated_number

    return stated_number(v, False, lambda w: w <= v, digits)[1]


def _check_renderable(texture, device: Device, speed: float, cut, max_penetration: float | None = None) -> None:
    """Refuse, in one line that says what to change, a measured texture shorter than the
    device's cut-off period l_c along an axis. A scan's longest period is its length: one
    shorter than l_c holds no period the device renders (band-limiting leaves it flat, and
    every verdict on it would be about nothing: issue 35's 50 um OPDx scan), and one shorter
    than ``MIN_CUTOFF_PERIODS`` l_c holds at most one such period, which no analysis can tell
    from a tilt or a bow of the instrument. The remedies named are complete: a slower scan
    lowers l_c, and with it the deepest region the analysis takes (``MAX_REGION_PERIODS``
    shortest periods), so the depth that works at that speed is named with it."""
    lc = cut.period
    # (a span at the bound, within rounding, passes: the remedies below name their bound, and one
    # taken exactly at it, e.g. a 20 um map at the 0.02 m/s named for it, must not be refused
    # again for 20 um < 2 x 10.000000000000002 um: 37 of 56 maps of 5-60 um were, before)
    short = [(a, n) for a, n in _spans(texture) if n < MIN_CUTOFF_PERIODS * lc * (1.0 - 1e-9)]
    if not short:
        return
    axis, n = min(short, key=lambda t: t[1])
    by = " and ".join(cut.set_by)
    what = "scan" if texture.dimension == 1 else "map"
    need = MIN_CUTOFF_PERIODS * lc
    hints = [f"feel it magnified (--scale F,H with F >= {_nice(need / n, True)}; scaled(...) in Python)"]
    by_speed = ("scanning velocity", "device structural")  # the limits proportional to the speed
    fixed = max((b for name, b in cut.bounds.items() if name not in by_speed), default=0.0)
    if set(cut.set_by) <= set(by_speed) and MIN_CUTOFF_PERIODS * fixed < n:  # a slower scan lowers l_c enough
        from .analysis._region import MAX_REGION_PERIODS

        v = float(_nice(speed * n / need, False))
        deepest = MAX_REGION_PERIODS * lc * v / speed  # the analysis's depth bound at the l_c of speed v
        slower = f"--speed {v:g} m/s or less"
        if max_penetration is not None and max_penetration > deepest:
            slower = (f"--speed {v:g} m/s with --max-penetration {_nice(deepest * 1e3, False)}mm or less, "
                      f"the deepest region analysed being {MAX_REGION_PERIODS:g} of the shortest periods")
        hints.append(f"scan it slower ({slower})")
    raise ParameterError(
        f"texture = {texture.source or repr(texture)!r} is not allowed on {device.name} at {speed:g} m/s: the {what} "
        f"spans {n * 1e6:.4g} um along {axis}, less than {MIN_CUTOFF_PERIODS:g} of the shortest period the device "
        f"renders, l_c = {lc * 1e6:.4g} um (set by the {by} limit), so it holds at most one period the device renders; "
        + ", or ".join(hints) + "; --raw analyses the samples as measured")


def _sample_numbers(texture) -> dict:
    """A sampled texture's max slope (1), max curvature (1/m) and height range (m) from its
    samples by central differences (numpy.gradient; at the samples' own positions on graded
    axes): what the instrument measured, in time linear in the samples. The spline through them
    (what ``--raw`` analyses) may be steeper between samples; the rendered texture's numbers are
    its spline's sups."""
    h = texture.h
    steps = [texture.dx] if h.ndim == 1 else [texture.dx, texture.dy]
    if getattr(texture, "_knots", None) is not None:  # (a map on graded axes: its samples' own positions)
        steps = [texture.x, texture.y]
    g = np.gradient(h, *steps) if h.ndim == 2 else [np.gradient(h, steps[0])]
    slope = np.sqrt(sum(gi * gi for gi in g))
    if h.ndim == 1:
        curv = np.abs(np.gradient(g[0], steps[0]))
    else:
        hxx, hxy = np.gradient(g[0], *steps)
        hyy = np.gradient(g[1], steps[1], axis=1)
        curv = _symmetric_2x2_norm(hxx, hxy, hyy)
    return {"max_slope": float(slope.max()), "max_curvature": float(curv.max()),
            "height_range": [float(h.min()), float(h.max())]}


def _check_window(texture, x_range) -> None:
    """A window over a measured (non-periodic) scan or map must lie inside it: beyond it the
    texture is only the extension of its edge, which nobody measured."""
    from ._validation import fail

    if texture.dimension == 1:
        try:
            x0, x1 = (float(v) for v in x_range)
        except (TypeError, ValueError):
            raise fail("x_range", x_range, "(x0, x1) in metres") from None
        if getattr(texture, "periodic", True) or getattr(texture, "x", None) is None:
            return
        a, b = float(texture.x[0]), float(texture.x[-1])
        tol = float(texture.x[1] - texture.x[0])  # a sample spacing: '0 mm' where the first sample is at 3 nm
        if not (a - tol <= x0 < x1 <= b + tol):
            raise fail("window", f"{x0:g},{x1:g} m", f"an interval inside the measured scan, x in [{a:g}, {b:g}] m, "
                       "with x0 < x1")
        return
    try:
        (x0, x1), (y0, y1) = ((float(a), float(b)) for a, b in x_range)
    except (TypeError, ValueError):
        raise fail("x_range", x_range, "((x0, x1), (y0, y1)) in metres") from None
    dom = texture.domain
    if getattr(texture, "periodic", True) or dom is None:
        return
    (a, b), (c, d) = dom
    tol = 1e-9 * max(b - a, d - c)
    if not (a - tol <= x0 < x1 <= b + tol and c - tol <= y0 < y1 <= d + tol):
        raise fail("window", f"{x0:g},{x1:g},{y0:g},{y1:g} m", f"a rectangle inside the measured map, x in "
                   f"[{a:g}, {b:g}] m and y in [{c:g}, {d:g}] m, with x0 < x1 and y0 < y1")
