"""``haptex design``: which algorithm, how stiff, for a texture on a device."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click

from .._specs import check_tip_spacing, object_from_spec, texture_from_spec as _texture_from_spec
from .._validation import ParameterError
from ..design import TIME_BUDGET
from ..surfaces import CURVATURE_SLACK
from ..textures import PROFILE_CURVATURE_SLACK
from ..tables import PAPER_PARAMETERS
from ._common import (
    Quantity, _Spinner, _Steps, _build_device, _device_options, _felt_options, _fitted, _jsonable,
    _limits_table, _object_options, _parse_point, _reading_options)


LONG_ANALYSIS = 180.0
"""An analysis planned longer than this (s, chosen: three minutes) is told how long it takes
without D and E, whose closest-point searches dominate on large maps."""


@click.command()
@click.option("--texture", "texture_spec", required=True,
              help="FILE (a line scan or an areal map in any format SurfaceTopography reads: Dektak, X3P, SDF, "
                   "Gwyddion, Zygo, Wyko, Keyence, NPY, text, ...; or .mat), 'sine:AMPLITUDE,PERIOD', "
                   "'sum:A1,L1;A2,L2', 'noise:RMS,SHORTEST,LONGEST,LENGTH[,SEED]', "
                   "or a surface: 'egg-crate:AMPLITUDE,PERIOD', 'grating:AMPLITUDE,PERIOD[,DIRECTION]'.")
@_device_options
@click.option("--stiffness", type=Quantity("N/m"), default=PAPER_PARAMETERS["stiffness"], show_default="2000 N/m",
              help="The stiffness you want to render at.")
@click.option("--speed", type=Quantity("m/s"), default=0.1, show_default="0.1 m/s", help="Scanning speed.")
@click.option("--max-penetration", type=Quantity("m"), default=1e-3, show_default="1mm", help="Rendering depth.")
@_reading_options
@click.option("--window", default=None, help="'X0,X1' abscissa window to analyse (default: one period or the whole "
              "profile); over a surface 'X0,X1,Y0,Y1' (default: one periodic cell or the whole map).")
@_felt_options("analysed")
@click.option("--instrument-tip", type=Quantity("m"), default=None,
              help="Radius of the tip that measured the file, e.g. '2um': the map is not trusted below its "
                   "reliability cutoff (SurfaceTopography), and the rendered texture holds nothing shorter.")
@click.option("--raw", is_flag=True,
              help="Analyse the measured samples as they are, not band-limited to what the device renders.")
@click.option("--hand", default="light-touch", show_default=True,
              help="The hand gripping the handle for the stable limits: a hand of 'haptex devices' (none, "
                   "light-touch, firm-grip).")
@_object_options("A, B, C, F and G are analysed there (D and E with --algorithms, but on a faceted mesh).")
@click.option("--algorithms", default=None,
              help="The algorithms to analyse, e.g. 'A,F' (default: every one defined for the texture; on an object "
                   "A, B, C, F, G: D and E, about 10 s each, on request).")
@click.option("--time-budget", type=Quantity("s"), default=TIME_BUDGET, show_default=f"{TIME_BUDGET:g} s",
              help="The planned analysis time (one core's) allowed: beyond it the costliest algorithms are left "
                   "out and named with their planned time (with --algorithms, a plan over it is refused).")
@click.option("--vertex-normals", is_flag=True,
              help="With a mesh: a smooth base swept along its vertex normals (default: the closest point's "
                   "coordinates, whose normal turns around each edge).")
@click.option("--report", "report_dir", type=click.Path(path_type=Path), default=None,
              help="Also write an HTML report (force fields, q maps, limits, recommendation) into this directory.")
@click.option("--force", is_flag=True, help="With --report: write into an existing directory that is not a haptex report.")
@click.option("--json", "as_json", is_flag=True)
@click.option("--quiet", is_flag=True, help="No progress display.")
@click.pass_context
def design(ctx, texture_spec, device_spec, joint_damping, mass, damping, sampling_period, delay, stiffness, speed,
           max_penetration, reading, window, crop, tip_radius, tip_spacing, instrument_tip, raw, object_spec, uv_scale,
           mesh_unit, box_uv, vertex_normals, algorithms, time_budget, hand, report_dir, force, as_json, quiet):
    """Which algorithm, how stiff, will it be passive, can the device render it?

    A measured texture is band-limited to the shortest period the device renders at the
    speed (the four period limits of Section II-B) and analysed as rendered; --raw analyses
    the samples as they are."""
    from ..catalogue import hand as _hand
    from ..design import design as run_design

    hand = _hand(hand)  # a misspelt hand before the texture is read
    check_tip_spacing(tip_radius, tip_spacing)
    with _Spinner("reading the texture", quiet or as_json):
        tex = _texture_from_spec(texture_spec, **reading, crop=crop)
    if raw and not hasattr(tex, "band_limited"):
        raise ParameterError(f"--raw is not allowed with the synthetic texture {texture_spec!r}: it applies to measured "
                             "textures read from a file")
    reliable = None
    if instrument_tip is None:
        instrument_tip = tex.instrument_tip  # the file's own, where it states one
    if instrument_tip is not None and not hasattr(tex, "band_limited"):
        raise ParameterError(f"--instrument-tip is not allowed with the synthetic texture {texture_spec!r}: it "
                             "applies to measured textures read from a file")
    if instrument_tip is not None and tip_radius:  # on the map as measured, before the ball rolls (else design's)
        from ..probe import reliability_cutoff

        reliable = reliability_cutoff(tex, instrument_tip)
    base = object_from_spec(object_spec, uv_scale, vertex_normals, mesh_unit=mesh_unit, box_uv=box_uv)
    dev = _build_device(ctx, device_spec, joint_damping, mass, damping, sampling_period, delay,
                        3 if base is not None else tex.dimension + 1)
    x_range = None
    if window is not None and tex.dimension == 1:  # (an empty one is refused, not ignored)
        x_range = _parse_point(window, "window", what="two abscissae 'x0,x1', e.g. '0,2mm'")
    elif window is not None:
        x0, x1, y0, y1 = _parse_point(window, "window", 4)
        x_range = ((x0, x1), (y0, y1))
    if report_dir is not None:
        from ..report import check_output

        if base is not None:
            raise ParameterError("--report is not allowed with --object yet: the design report draws fields in the "
                                 "x-z plane of a profile; use --json for an object")
        if tex.dimension != 1:
            raise ParameterError("--report is not allowed with a surface yet: the design report draws fields in the "
                                 "x-z plane of a profile; use --json for a surface")
        check_output(report_dir, force)  # before the minutes of analysis
    elif force:
        raise ParameterError("--force is not allowed without --report: it applies to the report directory")
    if tip_radius and not raw and base is None:  # (a ball on a bounded map feels one of the same extent)
        from ..design import _check_span
        from ..probe import _check_ball_fits

        _check_ball_fits(tex, tip_radius)  # (the ball's own refusal first: it holds at every speed)
        _check_span(tex, dev, speed, max_penetration, instrument_tip=instrument_tip, reliability_cutoff=reliable)
    felt = None
    if tip_radius:
        with _Spinner(f"rolling a ball of {tip_radius * 1e3:g} mm over the texture", quiet or as_json):
            point = tex
            tex = tex.felt_by(tip_radius, spacing=tip_spacing)
        import numpy as np

        kinks = np.asarray(getattr(tex, "kinks", np.zeros((0, 2))))
        kinks = kinks[np.argsort(-np.abs(kinks[:, -1]), kind="stable")] if kinks.shape[1] == 3 else kinks
        names = ("x", "slope_jump") if kinks.shape[1] == 2 else ("x", "y", "slope_jump")  # (a map's: the largest first)
        felt = {"tip_radius": tip_radius, "max_slope_point_probe": float(point.max_slope),
                "max_slope_felt": float(tex.max_slope), "source": tex.source,
                "kinks": [dict(zip(names, map(float, k))) for k in kinks[:100]],
                "kink_count": int(len(kinks)), "branched_cells": int(getattr(tex, "branched_cells", 0)),
                "single_patch_cells": _single_patch_cells(tex), "turn": float(getattr(tex, "turn", 0.0))}
        for key in ("curvature_miss", "peak_miss", "convex_miss", "path_curvature"):
            miss = getattr(tex, key, None)
            felt[key] = None if miss is None else float(miss)
        felt["max_curvature_felt"] = float(tex.max_curvature) if felt["path_curvature"] is not None else None
        ends = np.asarray(getattr(tex, "crease_ends", np.zeros((0, 2))))
        felt.update(crease_end_count=int(len(ends)), crease_ends=[{"x": float(a), "y": float(b)} for a, b in ends[:100]])
    steps = _Steps(9, "design", quiet or as_json)

    def announce(est):
        if not (quiet or as_json):
            searches = (f"; D and E: {est['searches']:.3g} closest-point searches at "
                        f"{est['seconds_per_search'] * 1e6:.3g} us" if est["searches"] else "")
            others = {L: v["seconds"] for L, v in est["algorithms"].items() if L not in "DE"}
            if est["searches"] and est["seconds"] > LONG_ANALYSIS and others:
                searches += (f"; without D and E, about {sum(others.values()):.3g} s "
                             f"(--algorithms {','.join(others)})")
            click.echo(f"estimate: {est['seconds']:.3g} s of analysis (one core's time) and {est['peak_bytes'] / 2**20:.3g} MiB "
                       f"for its largest grid{searches}", err=True)
            if est["left_out"]:
                click.echo(f"left out for the time budget of {est['time_budget']:g} s: " + ", ".join(
                    f"{L} (planned {v:.3g} s)" for L, v in est["left_out"].items()) + " (--time-budget)", err=True)
        steps.weigh({L: v["seconds"] for L, v in est["algorithms"].items()})

    with steps as step:
        data = run_design(tex, dev, stiffness, speed=speed, max_penetration=max_penetration, x_range=x_range,
                          progress=step, band_limit=not raw, hand=hand, on_estimate=announce, base=base,
                          algorithms=None if algorithms is None else [v for v in algorithms.split(",") if v.strip()],
                          instrument_tip=instrument_tip, reliability_cutoff=reliable, time_budget=time_budget)
    if report_dir is not None:
        from ..design import rendered_texture
        from ..report import write_design_report

        write_design_report(data, rendered_texture(tex, dev, speed, band_limit=not raw), report_dir, force)
    if as_json:
        click.echo(json.dumps(_jsonable(dict(data, felt_by_tip=felt)), indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    console = Console()
    if felt is not None:
        console.print(f"felt by a ball of r = {tip_radius * 1e3:g} mm: M = {felt['max_slope_point_probe']:.4g} for a point "
                      f"probe, {felt['max_slope_felt']:.4g} felt; the felt texture is analysed below")
        if felt["turn"]:
            console.print(f"the felt map's cells run along the texture's gratings, turned {math.degrees(felt['turn']):.4g} "
                          "deg from x (its curvature's ridges along their sides; SampledSurface.turn)")
        if felt["kink_count"]:
            worst = max(felt["kinks"], key=lambda k: abs(k["slope_jump"]))
            console.print(f"the ball bridges troughs: {felt['kink_count']} kink{'s' if felt['kink_count'] != 1 else ''} of "
                          f"its path (slope jumps; {_letters(True)} forces jump there, {_letters(False)} do not), the "
                          f"largest {worst['slope_jump']:+.3g} at x = {worst['x'] * 1e3:.4g} mm"
                          + (f", y = {worst['y'] * 1e3:.4g} mm" if "y" in worst else ""))
        # (the miss is the felt texture's, near spikes of its curvature a few um wide: where design
        # analyses it band-limited and resampled, they are not in what it analyses)
        if (not data["band_limit"]["applied"] and felt["curvature_miss"] is not None
                and felt["curvature_miss"] > min(CURVATURE_SLACK, PROFILE_CURVATURE_SLACK)):
            from ..surfaces import _shortfall

            ratio = _shortfall(felt["path_curvature"], felt["max_curvature_felt"] or 0.0)
            off = (f"the path's largest found is {ratio:.3g} times the felt texture's, so {_letters(True)} q on "
                   "the ideal path may be as many times the q below or more" if ratio is not None
                   else f"{_letters(True)} q below may be off by about as much, either way")
            console.print(f"the felt texture's curvature misses the ball path's by up to {felt['curvature_miss']:.1%} of its "
                          f"largest (its refinement stopped at its cap or where a finer grid did worse): {off}")
        if felt["crease_end_count"]:
            n, first = felt["crease_end_count"], felt["crease_ends"][0]
            console.print(f"creases of kinks end at {n} place{'s' if n != 1 else ''} inside the map, the first "
                          f"in the cell at x = {first['x'] * 1e3:.4g} mm, y = {first['y'] * 1e3:.4g} mm: there the ball's "
                          f"two contacts merge and its path curves without bound, so {_letters(True)} q on the ideal "
                          "path is unbounded near it; the q below is the felt map's, as rendered")
        if felt["branched_cells"]:
            console.print(f"where it rests on several sides of a bowl, {felt['branched_cells']} cells are the highest of "
                          "one patch per contact (branched)")
        if felt["single_patch_cells"]:
            n = felt["single_patch_cells"]
            console.print(f"{n} cell{'s' if n != 1 else ''} beside kinks keep{'s' if n == 1 else ''} a single patch (no "
                          "branches could be made there): the felt slopes there may differ from the ball's path "
                          "either way (measured -4.5 to +0.2 % on a rough map felt by a ball of 4 to 7 samples; "
                          "the measured-surfaces guide)")
    bl = data["band_limit"]
    rn = bl["raw"]
    if bl["sampled"]:
        dom = "" if rn["dominant_period"] is None else f", dominant period {rn['dominant_period'] * 1e3:.4g} mm"
        console.print(f"measured {data['texture']}: {bl['samples']['raw']} samples, RMS {rn['rms'] * 1e6:.4g} um{dom}, "
                      f"M = {rn['max_slope']:.4g}, max curvature {rn['max_curvature']:.4g} 1/m")
    names = bl["set_by"]
    by = names[0] + " limit" if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1] + " limits"
    cut = f"the device renders periods >= {bl['cutoff'] * 1e3:.4g} mm at {speed:g} m/s (set by the {by})"
    if instrument_tip is not None:
        rc = bl["reliability_cutoff"]
        console.print(f"measured with a tip of r = {instrument_tip * 1e6:g} um"
                      f"{' (the file states it)' if instrument_tip == tex.instrument_tip else ''}: " + (
            "no scale of the map is affected (SurfaceTopography's reliability analysis)" if rc is None else
            f"the map is the tip's shape below {rc * 1e6:.4g} um (SurfaceTopography's reliability cutoff); the "
            "rendered texture holds nothing shorter"))
    n_out = bl["samples"]["rendered"]
    if bl["filtered"]:
        console.print(f"{cut}: band-limited to it ({rn['rms_removed'] * 1e6:.3g} um RMS removed) and resampled to "
                      f"{n_out} samples; analysed as rendered (--raw: as measured)")
    elif bl["applied"]:
        console.print(f"{cut}: the texture holds no shorter period (its shortest: "
                      f"{rn['shortest_period'] * 1e3:.4g} mm); resampled to {n_out} samples")
    elif bl["sampled"] and not bl["requested"]:
        console.print(f"{cut}; --raw: analysed as measured, not as rendered")
    else:
        console.print(cut)
    tn = data["texture_numbers"]
    console.print(f"{'rendered ' if bl['applied'] else ''}texture {data['rendered_texture']}: shortest period {tn['shortest_period'] * 1e3:.4g} mm, "
                  f"M = {tn['max_slope']:.4g}, heights {tn['height_range'][0] * 1e3:.4g} to {tn['height_range'][1] * 1e3:.4g} mm")
    vib = data["vibration"]
    if "unavailable" not in vib:
        lo, hi = vib["band"]
        text = (f"as a vibration (a tip following it at {speed:g} m/s; {lo:g}-{hi:g} Hz, wavelengths "
                f"{vib['wavelengths'][0] * 1e3:.3g}-{vib['wavelengths'][1] * 1e3:.3g} mm): {vib['rms']:.3g} m/s² rms, "
                f"{vib['share']:.0%} of its height variance")
        if vib["covered"] is None:
            text += "; its extent resolves none of the band"
        elif tuple(vib["covered"]) != (lo, hi):
            text += f"; its extent resolves {vib['covered'][0]:.3g}-{vib['covered'][1]:.3g} Hz"
        if vib["margin_db"] is not None:
            text += (f"; strongest {abs(vib['margin_db']):.3g} dB {'above' if vib['margin_db'] >= 0 else 'below'} "
                     f"the hand's detection threshold, at {vib['peak_frequency']:.4g} Hz")
        console.print(text)
    from rich import box

    console.print(_limits_table(data["wall_limits"], f"wall limits on {data['device']}"))

    if data["object"] is not None:
        console.print(f"on the object {data['object']} (A, B, C, G: penetration along its normal)")
    t = Table(title=f"at {stiffness:g} N/m", box=box.SIMPLE_HEAD,
              caption="max passive: Corollary 1 / q; max stable: the wall's stable limit with the hand / q; "
                      "cons.: conservative; cont.: continuous")
    for col in ("alg.", "q", "max passive (N/m)", "max stable (N/m)", "passive", "cons.", "max |loop| (J)", "cont."):
        t.add_column(col)
    for r in data["rows"]:
        t.add_row(r["algorithm"], "unbounded" if math.isinf(r["q"]) else f"{r['q']:.4g}",
                  _bound(r["max_passive_stiffness"]), _bound(r["max_stable_stiffness"]),
                  "yes" if r["passive_at_stiffness"] else "no",
                  "yes" if r["conservative"] else ("almost" if r["almost_conservative"] else "no"),
                  f"{r['max_abs_loop_energy']:.3g}", "yes" if r["continuous"] else "no")
    console.print(_fitted(t))
    lt = Table(title="rendering limits (Section II-B)", box=box.SIMPLE_HEAD)
    for col in ("limit", "condition", "value", "bound", "ok"):
        lt.add_column(col)
    for lim in data["limits"]:
        unit = "" if lim["unit"] == "1" else " " + lim["unit"]
        lt.add_row(lim["name"], lim["formula"], f"{lim['lhs']:.4g}{unit}", f"{lim['rhs']:.4g}{unit}",
                   "yes" if lim["passed"] else "NO")
    console.print(_fitted(lt))
    console.print("recommendation: " + data["recommendation"])
    if report_dir is not None:
        console.print(f"report: {report_dir / 'index.html'}")


def _single_patch_cells(tex) -> int:
    """How many cells of a felt map beside its kinks keep a single patch (0 for a profile: its
    kinked intervals' quadratics keep the contacts' slopes)."""
    if getattr(tex, "dimension", 1) != 2 or not len(getattr(tex, "kinks", ())):
        return 0
    from ..surfaces import _single_kink_cells

    return int(_single_kink_cells(tex))


def _letters(reads_slope: bool) -> str:
    """The textured algorithms whose force reads the slope (or not), as the kink report names
    them: "B's, C's and G's" (``Algorithm.reads_slope``)."""
    from ..algorithms import ALGORITHMS

    names = [f"{k}'s" for k in sorted(ALGORITHMS) if ALGORITHMS[k].textured and ALGORITHMS[k].reads_slope == reads_slope]
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def _bound(v: float) -> str:
    """A largest stiffness (N/m) at 4 digits rounded down, so that one taken from the table as
    written is within it (0 and inf as they are)."""
    from ..design import _at_most

    return f"{float(_at_most(v, 4)):.4g}" if 0.0 < v < math.inf else f"{v:.4g}"
