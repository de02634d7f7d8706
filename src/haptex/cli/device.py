"""``haptex run`` (a texture, the identification program or the wall-limit ladder on a device) and
``haptex identify`` (a device model fitted to a run log)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click

from .._specs import check_tip_spacing, object_from_spec, texture_from_spec as _texture_from_spec
from .._validation import ParameterError, positive
from ..core import blas_held_to_one_thread as _core_blas_held
from ._common import (READING, Quantity, STABILISERS, _Spinner, _before_the_ball, _budget_needs_models,
                      _check_plot_path, _check_search_budget, _felt_options, _jsonable, _letter, _object_options,
                      _reading_options, _stabiliser, _vibration, _vibration_options)


@click.command("run")
@click.option("--device", "device_spec", required=True,
              help="'simulated:PRESET' (a preset of 'haptex devices', e.g. 'simulated:falcon'); "
                   "'forcedimension[:PRESET]' (Force Dimension's SDK, pip install 'haptex[forcedimension]'); "
                   "'openhaptics[:PRESET]' (OpenHaptics, pip install 'haptex[openhaptics]'); "
                   "'haply[:ws://HOST:PORT]' (the Inverse Service, pip install 'haptex[haply]'); "
                   "'haply-serial[:PORT]' (Haply's hardware API on a serial port, pip install "
                   "'haptex[haply-serial]').")
@click.option("--texture", "texture_spec", default="sine:0.2mm,2mm", show_default=True,
              help="A texture spec as for design (a profile is extruded across y on a 3-DOF device).")
@click.option("--algorithm", "letter", default="A", show_default=True, callback=_letter(proxy=True),
              help="W or A-G, or 'proxy': a god-object (haptex.proxy.GodObject, with history).")
@click.option("--stiffness", type=Quantity("N/m"), default=500.0, show_default="500 N/m", help="kappa_0.")
@click.option("--max-force", type=Quantity("N"), default=None, help="At most the device's (default: the device's).")
@click.option("--duration", type=Quantity("s"), default=5.0, show_default="5 s")
@click.option("--passivity-control", type=Quantity("N*s/m"), default=None,
              help="A passivity observer/controller with this largest damping (its delay: the device's).")
@click.option("--stabiliser", type=click.Choice(STABILISERS), default=None,
              help="Instead: energy bounding or passive set-position modulation, paid with the device's damping.")
@click.option("--hand", default="light-touch", show_default=True, help="simulated: the hand holding the handle.")
@click.option("--speed", type=Quantity("m/s"), default=0.01, show_default="10 mm/s",
              help="simulated: the hand's speed along x.")
@click.option("--fast", is_flag=True, help="simulated, forcedimension: run as fast as the loop goes, not at the "
              "device's rate.")
@_object_options("A-G and the proxy are rendered there on a 3-DOF device (D and E but on a faceted mesh: give "
                 "--vertex-normals), the object's top at the origin of its frame.")
@_reading_options
@_felt_options("rendered")
@click.option("--record", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the run log (time, position, force, engaged) to FILE.csv (the columns of the file formats "
                   "page, read by 'haptex identify') or FILE.npz.")
@click.option("--max-evaluations", type=int, default=None,
              help="D and E over a surface: the texture evaluations one tick's closest-point search may spend, 100 "
                   "to 10^9 (default: what half the device's period holds, measured on this machine before the "
                   "run); past it the tick uses the best point found and is counted as cut.")
@_vibration_options
@click.option("--find-limit", "find_limit_run", is_flag=True,
              help="Instead of a texture: a smooth wall whose stiffness rises by 10% every 0.5 s while the handle "
                   "rests on it, stopped (force zero) at the first step that oscillates; from --stiffness when "
                   "given, else a quarter of the predicted stable limit with --hand, up to four times that limit.")
@click.option("--identify", "identify_run", is_flag=True,
              help="Instead of a texture: the identification program (steps and a chirp along x at 20% of the "
                   "device's max force, a 50 N/m centering spring), the handle free; needs --record.")
@click.option("--keep-awake", is_flag=True,
              help="simulated, forcedimension, haply-serial: pin the native servo thread to one core and keep that "
                   "core from halting (a thread spinning there below every other task; it spends the core): fewer "
                   "late ticks on a virtual machine or a CPU with deep idle states.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@click.option("--quiet", is_flag=True, help="No live dashboard.")
@_core_blas_held  # BLAS in the set-up (a preset's matrices, a slope bound) wakes no worker to spin beside the loop
def run_device(device_spec, texture_spec, letter, stiffness, max_force, duration, passivity_control, stabiliser, hand,
               speed, fast, object_spec, uv_scale, mesh_unit, box_uv, reading, tip_radius, tip_spacing, crop, record,
               max_evaluations, vibration_models, vibration_budget, no_material_friction, find_limit_run, identify_run, keep_awake,
               as_json, quiet):
    """Render one texture on one device, with the safety rules of haptex.servo and a live dashboard."""

    from ..algorithms import algorithm
    from ..backends import open_backend
    from ..renderer import Renderer
    from ..servo import ServoLoop, analyse_trace
    from ..surfaces import Extruded

    if record is not None and record.suffix.lower() not in (".npz", ".csv"):
        raise ParameterError(f"record = {str(record)!r} is not allowed: must end in .csv or .npz")
    if record is not None and not (record.parent if str(record.parent) else Path(".")).is_dir():
        raise ParameterError(f"record = {str(record)!r} is not allowed: its directory does not exist")
    ctx = click.get_current_context()
    if find_limit_run:
        if identify_run:
            raise ParameterError("--find-limit is not allowed with --identify: one program a run")
        given = [n for n in ("texture_spec", "letter", "passivity_control", "stabiliser", "object_spec", "tip_radius",
                             "tip_spacing", "crop", "speed", "duration", "vibration_models", "vibration_budget",
                             "no_material_friction", "keep_awake", "max_evaluations")
                 if ctx.get_parameter_source(n) == click.core.ParameterSource.COMMANDLINE]
        if given:
            opt = next(o for o in ctx.command.params if o.name == given[0]).opts[-1]
            raise ParameterError(f"{opt} is not allowed with --find-limit: the run is a smooth wall, its stiffness "
                                 "in steps, the handle resting on it, as long as the steps take")
        start = stiffness if ctx.get_parameter_source("stiffness") == click.core.ParameterSource.COMMANDLINE else None
        return _find_limit_run(device_spec, start, max_force, hand, fast, record, as_json, quiet)
    if identify_run:
        if record is None:
            raise ParameterError("--identify is not allowed without --record FILE.csv: the run's log is what "
                                 "'haptex identify' reads")
        texture_given = [n for n in ("texture_spec", "letter", "stiffness", "passivity_control", "stabiliser",
                                     "object_spec", "tip_radius", "tip_spacing", "crop", *READING, "speed",
                                     "vibration_models", "vibration_budget", "no_material_friction", "keep_awake",
                                     "max_evaluations")
                         if ctx.get_parameter_source(n) == click.core.ParameterSource.COMMANDLINE]
        if texture_given:
            opt = next(o for o in ctx.command.params if o.name == texture_given[0]).opts[-1]
            raise ParameterError(f"{opt} is not allowed with --identify: the identification run renders no "
                                 "texture (the handle is free)")
        if ctx.get_parameter_source("hand") != click.core.ParameterSource.COMMANDLINE:
            hand = "none"  # the handle free: the log then describes the device alone
    kind = str(device_spec).partition(":")[0]
    given = {n for n in ("hand", "speed", "fast")
             if ctx.get_parameter_source(n) == click.core.ParameterSource.COMMANDLINE}
    vendors = ("openhaptics", "haply", "haply-serial")  # (another kind's own error comes first)
    for name in sorted(given - {"fast"} if kind == "forcedimension" else given if kind in vendors else ()):
        which = "simulated devices" if name != "fast" else "simulated and Force Dimension devices"
        raise ParameterError(f"--{name} is not allowed with --device {device_spec}: it applies to {which} only")
    if keep_awake and kind not in ("simulated", "forcedimension", "haply-serial"):
        raise ParameterError(f"--keep-awake is not allowed with --device {device_spec}: it keeps the core of the C "
                             "core's own servo thread awake (simulated, forcedimension, haply-serial); OpenHaptics' "
                             "scheduler owns its thread, and Haply's service is driven from Python")
    options = ({"hand": hand, "speed": speed, "realtime": not fast} if kind == "simulated"
               else {"realtime": not fast} if kind == "forcedimension" else {})
    backend = open_backend(device_spec, **options)
    dev = backend.device
    fmax = _max_force(backend, max_force)
    if identify_run:  # no texture: the program instead, the handle free
        from ..identification import FRACTION, IdentificationProgram

        if not math.isfinite(fmax):
            raise ParameterError(f"--identify is not allowed on {backend.name} without --max-force: the program "
                                 "is a share of the largest force")
        program = IdentificationProgram(backend.dimension, dev.period, duration, FRACTION * fmax)
        return _identification_run(backend, program, fmax, duration, record, as_json)
    tex = None
    letter = letter.upper()
    if letter == "W":  # (as export refuses them: the smooth wall has no texture, and nothing is ignored)
        given = [n for n in ("texture_spec", "tip_radius", "tip_spacing", "crop", *READING)
                 if ctx.get_parameter_source(n) == click.core.ParameterSource.COMMANDLINE]
        if given:
            opt = next(o for o in ctx.command.params if o.name == given[0]).opts[-1]
            raise ParameterError(f"{opt} is not allowed with --algorithm W: the smooth wall has no texture")
        if backend.dimension == 3:
            from ..textures import Flat

            tex = Flat(dimension=2)
    else:
        check_tip_spacing(tip_radius, tip_spacing)  # (the ball rolls below, once every other setting is checked)
        tex = _texture_from_spec(texture_spec, **reading, crop=crop)
        if tex.dimension == 2 and backend.dimension == 2:
            raise ParameterError(f"texture = {texture_spec!r} is not allowed on {backend.name}: a surface needs a "
                                 "3-DOF device")
    base = object_from_spec(object_spec, uv_scale, mesh_unit=mesh_unit, box_uv=box_uv)
    if base is not None and backend.dimension != 3:
        raise ParameterError(f"--object is not allowed on {backend.name}: an object needs a 3-DOF device")

    def rendered(tex):  # (the algorithm on the texture as the device renders it: a profile extruded on a 3-DOF one)
        if tex is not None and tex.dimension == 1 and backend.dimension == 3:
            tex = Extruded(tex)
        if base is not None:
            from ..objects import object_algorithm
            from ..proxy import GodObject

            return GodObject(tex, stiffness, base) if letter == "PROXY" else object_algorithm(letter, tex, base,
                                                                                              stiffness)
        if letter == "PROXY":
            from ..proxy import GodObject

            return GodObject(tex, stiffness)
        return algorithm(letter, tex, stiffness)

    alg = rendered(_before_the_ball(tex, tip_radius if letter != "W" else None, base))  # (checked before the ball)
    pc = _stabiliser(passivity_control, stabiliser, dev, delay=dev.delay)

    vib = {}
    _budget_needs_models(vibration_models, vibration_budget, no_material_friction)
    if vibration_models is not None:
        # the device's own mass along x turns acceleration into force (a simulated device's has the hand's added)
        own = backend.preset.device() if kind == "simulated" else dev
        vib = _vibration(vibration_models, dev.period, own.mass[0, 0], vibration_budget, backend.name,
                         False if no_material_friction else None)
    from ..renderer import MAX_EVALUATIONS, evaluation_budget
    from ..servo import SEARCH_SHARE, budgeted_search, search_budget

    evaluation_budget(max_evaluations)
    _check_search_budget(max_evaluations, alg)
    positive("duration", duration, "s")
    if tip_radius and letter != "W":
        with _Spinner(f"rolling a ball of {tip_radius * 1e3:g} mm over the texture", quiet or as_json):
            tex = tex.felt_by(tip_radius, spacing=tip_spacing)
        alg = rendered(tex)
    tex = getattr(alg, "texture", tex)  # (what is rendered: a profile's extrusion on a 3-DOF device)
    seconds = None
    if max_evaluations is None:  # (D and E over a surface: what half the period holds here; else the default)
        reach = fmax / stiffness if math.isfinite(fmax) and stiffness > 0 else 1e-3
        max_evaluations, seconds = search_budget(alg, dev.period, reach)
        if max_evaluations is None:
            max_evaluations = MAX_EVALUATIONS
    searched = budgeted_search(alg)
    renderer = Renderer(alg, max_force=fmax if math.isfinite(fmax) else None, energy_monitor=True,
                        passivity_controller=pc, period=dev.period, max_evaluations=max_evaluations, **vib)
    loop = ServoLoop(backend, renderer, max_force=fmax if math.isfinite(fmax) else None, keep_awake=keep_awake)
    live = None
    if not (quiet or as_json):
        from rich.console import Console
        from rich.live import Live

        console = Console(stderr=True)
        if console.is_terminal:
            live = Live(console=console, refresh_per_second=4, transient=True)
    every = max(1, int(0.1 / dev.period))
    shown = [-every]

    def show(k, st):  # (every tick from a Python driver, every 50 ms from a native one)
        if live is not None and k - shown[0] >= every:
            shown[0] = k
            live.update(f"{backend.name}  t {k * dev.period:6.2f} s  ticks {st.ticks}  missed {st.missed}  faults "
                        f"{st.faults}  engaged {'yes' if st.engaged_at is not None else 'no'}  energy observed "
                        f"{renderer.energy:+.3g} J  max force sent {st.max_force_sent:.3g} N")
    if live is not None:
        with live:
            stats, trace = loop.run(duration, on_tick=show)
    else:
        stats, trace = loop.run(duration)
    periods = getattr(getattr(tex, "profile", tex), "periods", None) if tex is not None else None
    verdict = analyse_trace(trace, dev.period, dev.position_resolution, () if periods is None else periods,
                            speed=abs(backend.speed) if kind == "simulated" else None)
    per_axis, osc = verdict["energy"], verdict["oscillation"]
    axes = "xz" if backend.dimension == 2 else "xyz"
    summary = {"device": backend.name, "algorithm": letter, "object": None if base is None else repr(base),
               "stiffness": stiffness, "max_force": fmax,
               "duration": stats.ticks * dev.period, "ticks": stats.ticks, "missed_deadlines": stats.missed,
               "faults": stats.faults, "clamps": stats.clamps,
               "engaged_at": None if stats.engaged_at is None else stats.engaged_at * dev.period,
               "max_force_sent": stats.max_force_sent, "energy_observed": renderer.energy,
               **{f"energy_{a}": float(e) for a, e in zip(axes, per_axis)},
               "tick_max": stats.tick_seconds[0], "tick_mean": stats.tick_seconds[1], "tick_p999": stats.tick_p999,
               "period_mean": stats.period_seconds[0], "period_std": stats.period_seconds[1],
               "jitter_max": stats.jitter_seconds[0], "jitter_p999": stats.jitter_seconds[1],
               "overruns": stats.overruns, "driver": stats.driver, "fifo": stats.fifo,
               "memory_locked": stats.memory_locked, "awake_core": stats.awake_core,
               "interrupted": stats.interrupted, "regime": verdict["regime"], "oscillating": osc.oscillating,
               "amplitude": osc.amplitude, "frequency": osc.frequency,
               "stabiliser": None if pc is None else pc.label,
               **({"search_budget": max_evaluations, "search_evaluation_seconds": seconds,
                   "search_max_work": renderer.max_work, "search_cut": renderer.cut} if searched else {}),
               "stabiliser_ticks": 0 if pc is None else renderer.controller_active,
               # (None: no component above the encoder's floor, nothing to judge)
               "buzz_db": None if verdict["buzz"] is None or verdict["buzz"].margin_db == -math.inf
               else verdict["buzz"].margin_db,
               "buzz_frequency": None if verdict["buzz"] is None or verdict["buzz"].margin_db == -math.inf
               else verdict["buzz"].frequency,
               **({"vibration_supplied": renderer.vibration_supplied, "vibration_cut": renderer.vibration_cut,
                   "vibration_budget": vibration_budget,
                   "friction_mu": None if renderer.friction is None else renderer.friction[0],
                   "friction_dissipated": renderer.friction_dissipated} if vib else {}),
               "units": {"stiffness": "N/m", "max_force": "N", "duration": "s", "engaged_at": "s",
                         "amplitude": "m", "frequency": "Hz",
                         "max_force_sent": "N", "energy_observed": "J", **{f"energy_{a}": "J" for a in axes},
                         "tick_max": "s", "tick_mean": "s", "tick_p999": "s", "period_mean": "s",
                         "period_std": "s", "jitter_max": "s", "jitter_p999": "s",
                         "stabiliser_ticks": "ticks", "buzz_db": "dB above the detection threshold",
                         "buzz_frequency": "Hz", "vibration_supplied": "J", "vibration_cut": "ticks",
                         "search_budget": "evaluations", "search_evaluation_seconds": "s",
                         "search_max_work": "evaluations", "search_cut": "ticks",
                         "vibration_budget": "W", "friction_mu": "1", "friction_dissipated": "J"}}
    if record is not None:
        _write_record(record, trace, dev.period)
    if stats.driver == "native thread" and loop.priority and not stats.fifo and getattr(backend, "realtime", True):
        click.echo("notice: the servo thread ran at normal priority: SCHED_FIFO needs CAP_SYS_NICE or a real-time "
                   "limit (ulimit -r, /etc/security/limits.conf)", err=True)
    if keep_awake and stats.awake_core is None:
        click.echo("notice: the servo thread's core was not kept awake: it needs Linux and two cores or more",
                   err=True)
    if as_json:
        click.echo(json.dumps(_jsonable(summary), indent=2))
        return
    click.echo(f"{backend.name}: {stats.ticks} ticks ({summary['duration']:.3g} s), {stats.missed} missed deadlines, "
               f"{stats.faults} faults, {stats.clamps} clamps; forces engaged at "
               f"{'never' if stats.engaged_at is None else format(summary['engaged_at'], '.3g') + ' s'}; "
               f"largest force sent {stats.max_force_sent:.3g} N; energy observed {renderer.energy:+.3g} J; "
               f"{verdict['regime']}; tick "
               f"{stats.tick_seconds[1] * 1e6:.3g} us mean, {stats.tick_p999 * 1e6:.3g} us at 99.9 %, "
               f"{stats.tick_seconds[0] * 1e6:.3g} us worst; jitter {stats.jitter_seconds[0] * 1e6:.3g} us worst; "
               f"{stats.driver}{' at SCHED_FIFO' if stats.fifo else ''}"
               f"{f', core {stats.awake_core} kept awake' if stats.awake_core is not None else ''}"
               + ("; interrupted (forces zeroed)" if stats.interrupted else ""))
    if searched:
        how = ("given" if seconds is None else
               f"{SEARCH_SHARE:.0%} of the {dev.period * 1e3:.3g} ms period at {seconds * 1e6:.3g} us an evaluation, "
               "measured before the run")
        click.echo(f"{letter}'s closest-point search: at most {max_evaluations:,} evaluations a tick ({how}); "
                   f"largest tick {renderer.max_work:,}; {renderer.cut} ticks cut (the best point found, not the "
                   "certified closest)")
    if vib:
        fr = ("no material friction" if renderer.friction is None else
              f"the material's friction (mu {renderer.friction[0]:.3g}) dissipated {renderer.friction_dissipated:.3g} J")
        click.echo(f"vibration: supplied {renderer.vibration_supplied:+.3g} J; {fr}")
    if record is not None:
        click.echo(f"trace: {record}")


def _max_force(backend, max_force) -> float:
    """The largest force a run sends (N): --max-force, at most the device's; default the device's."""
    fmax = backend.max_force if max_force is None else max_force
    if not fmax <= backend.max_force:
        raise ParameterError(f"max_force = {fmax:g} N is not allowed: at most the device's {backend.max_force:g} N")
    return fmax


def _write_record(record: Path, trace: dict, period: float) -> None:
    """The run's log: CSV (haptex.identify.LOG_COLUMNS) or the trace's arrays in .npz."""
    import numpy as np

    if record.suffix.lower() == ".csv":
        from ..identification import write_log

        write_log(record, trace["time"], trace["position"], trace["force"], trace["engaged"])
    else:
        np.savez(record, **trace, period=period, units=np.array(["s", "m", "N", "1"]))


def _find_limit_run(device_spec, start, max_force, hand, fast, record, as_json, quiet) -> None:
    """``haptex run --find-limit``: the stiffness ladder on the device (haptex.limits.find_limit)."""
    from ..backends import open_backend
    from ..catalogue import hand as _hand, hands
    from ..limits import FIND_RATIO, FIND_SPAN, FIND_STEP, SIM_PUSH, find_limit, wall_limits

    kind = str(device_spec).partition(":")[0]
    h = _hand(hand)
    if kind == "simulated":  # the hand rests on the wall: pressing with SIM_PUSH, not scanning
        if h.none:
            raise ParameterError("hand = 'none' is not allowed with --find-limit on a simulated device: a hand rests "
                                 "the handle on the wall (" + ", ".join(k for k in hands() if k != "none") + ")")
        backend = open_backend(device_spec, hand=hand, speed=0.0, press=SIM_PUSH / h.stiffness, realtime=not fast)
    else:
        backend = open_backend(device_spec, **({"realtime": not fast} if kind == "forcedimension" else {}))
    dev = backend.device
    fmax = _max_force(backend, max_force)
    # the predicted limit with the hand (the simulated device's mass has the hand's attached: its preset's has not)
    predicted = wall_limits(backend.preset.device() if kind == "simulated" else dev, h).stable
    k0 = predicted / FIND_SPAN if start is None else start
    top = predicted * FIND_SPAN if start is None else max(predicted * FIND_SPAN, start * FIND_RATIO ** 10)
    if not quiet and not as_json:
        click.echo(f"{backend.name}: lift the handle above the wall (z > 0), then rest it on the wall; the stiffness "
                   f"rises from {k0:.4g} to at most {top:.4g} N/m, by {FIND_RATIO:g}x every "
                   f"{FIND_STEP:g} s (Ctrl-C stops with zero force)", err=True)

    def show(step):
        if not quiet and not as_json:
            buzz = ("" if step["buzz_db"] is None
                    else f", buzz {step['buzz_db']:+.1f} dB at {step['buzz_frequency']:.4g} Hz")
            click.echo(f"  {step['stiffness']:9.4g} N/m  {step['regime']}{buzz}", err=True)
    res = find_limit(backend, k0, top, max_force=fmax if math.isfinite(fmax) else None, on_step=show)
    if record is not None:
        _write_record(record, res.trace, backend.period)
    summary = {"device": backend.name, "program": "find-limit", "hand": h.key, "predicted_stable": predicted,
               **res.as_dict(), "ticks": res.stats.ticks, "missed_deadlines": res.stats.missed,
               "faults": res.stats.faults, "max_force_sent": res.stats.max_force_sent, "driver": res.stats.driver,
               "overruns": res.stats.overruns}
    summary["units"] = {**summary["units"], "predicted_stable": "N/m", "max_force_sent": "N"}
    if as_json:
        click.echo(json.dumps(_jsonable(summary), indent=2))
        return
    found = ("no step was held: the forces never engaged (start with the handle above the wall)"
             if res.reason == "not engaged" else
             f"the first step oscillated ({res.oscillating:.4g} N/m): start lower with --stiffness"
             if res.clean is None else
             f"clean up to {res.clean:.4g} N/m" + ("" if res.oscillating is None else
                                                   f", oscillating at {res.oscillating:.4g} N/m"))
    click.echo(f"{backend.name}: {found}; {len(res.steps)} steps, ended by {res.reason}; predicted stable limit "
               f"with the hand {h.key!r}: {predicted:.4g} N/m; largest force sent {res.stats.max_force_sent:.3g} N, "
               f"{res.stats.missed} missed deadlines, {res.stats.faults} faults; force zero at the end")
    if record is not None:
        click.echo(f"trace: {record}")


def _identification_run(backend, program, fmax: float, duration: float, record: Path, as_json: bool) -> None:
    """``haptex run --identify``: the program under the servo's rules (zero force at every exit),
    the log written."""
    from ..servo import ServoLoop

    loop = ServoLoop(backend, program, max_force=fmax)
    stats, trace = loop.run(duration)
    _write_record(record, trace, backend.period)
    summary = {"device": backend.name, "program": "identification", "amplitude": program.program.max(),
               "duration": stats.ticks * backend.period, "ticks": stats.ticks, "missed_deadlines": stats.missed,
               "faults": stats.faults, "max_force_sent": stats.max_force_sent, "log": str(record),
               "interrupted": stats.interrupted,
               "units": {"amplitude": "N", "duration": "s", "max_force_sent": "N"}}
    if as_json:
        click.echo(json.dumps(_jsonable(summary), indent=2))
        return
    click.echo(f"{backend.name}: identification run, {stats.ticks} ticks ({summary['duration']:.3g} s), "
               f"{stats.missed} missed deadlines, {stats.faults} faults; largest force sent "
               f"{stats.max_force_sent:.3g} N" + ("; interrupted (forces zeroed)" if stats.interrupted else ""))
    click.echo(f"log: {record} (next: haptex identify {record} -o mydevice.toml)")


@click.command("identify")
@click.argument("log", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Device file to write (TOML, usable as --device FILE.toml).")
@click.option("--axis", type=click.Choice(["x", "y", "z", "all"]), default="x", show_default=True,
              help="The log's axes fitted (the identification run excites x).")
@click.option("--max-delay", type=click.IntRange(0, 1000), default=10, show_default=True,
              help="Largest delay searched (whole periods).")
@click.option("--json", "as_json", is_flag=True, help="Print the figures as JSON.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write a figure (PNG or SVG) of the measured and the model's positions and their residual.")
@click.option("--column", "columns", multiple=True, metavar="QUANTITY=COL[,COL...][:UNIT]",
              help="The log's own columns for a quantity (time, position, force, engaged), e.g. "
                   "'position=px,py,pz:mm', 'force=fx,fy,fz:N', 'time=t:ms'; a board's step as the unit for "
                   "raw counts, e.g. 'position=enc:2.5um'; without a unit, the one the file states (a units row, "
                   "TDMS, LVM or HDF5 metadata), else SI. Repeat for each; other columns are ignored and listed.")
def identify_command(log, out, axis, max_delay, as_json, plot, columns):
    """Fit a device model (mass, damping, Coulomb friction, encoder step, delay) to a run log
    (haptex's CSV or NPZ, or another program's CSV, NPZ, HDF5, .mat, TDMS or LVM with its columns
    named by --column)."""
    from ..identification import AXES, identify, read_log

    if out.suffix.lower() != ".toml":  # (what --device FILE.toml reads: another name would be refused there)
        raise ParameterError(f"out = {str(out)!r} is not allowed: must end in .toml, the device file --device "
                             f"reads (-o {out.with_suffix('.toml')})")
    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise ParameterError(f"out = {str(out)!r} is not allowed: its directory does not exist")
    if plot is not None:
        _check_plot_path(plot)
    lg = read_log(log, columns)
    if lg.ignored and not as_json:
        click.echo(f"ignored columns: {', '.join(lg.ignored)}")
    d = lg.position.shape[1]
    if axis == "all":
        cols = list(range(d))
    elif axis not in AXES[d]:
        raise ParameterError(f"axis = {axis!r} is not allowed: the log's axes are {', '.join(AXES[d])} (or all)")
    else:
        cols = [AXES[d].index(axis)]
    res = identify(time=lg.time, position=lg.position[:, cols], force=lg.force[:, cols], max_delay=max_delay,
                   source=str(log))
    res.to_toml(out)
    if plot is not None:
        _plot_identification(res, plot)
    if as_json:
        click.echo(json.dumps(_jsonable({**res.to_dict(), "device_file": str(out)}), indent=2))
        return
    click.echo(res.report())
    click.echo(f"device file: {out} (use it as --device {out})")


def _plot_identification(res, path: Path) -> None:
    """The measured and the model's positions over the fitted windows, and their residual."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tr = res.trace
    t, meas, model = tr["time"], tr["measured"], tr["model"]
    fig, (ax, rx) = plt.subplots(2, 1, figsize=(8, 5), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    ax.plot(t, meas * 1e3, ".", ms=1.5, color="0.3", label="measured")
    ax.plot(t, model * 1e3, "-", lw=0.8, color="C0", label="model (each window from its own start)")
    ax.set_ylabel("position (mm)")
    ax.legend(loc="upper right", fontsize=8)
    rx.plot(t, (model - meas) * 1e6, "-", lw=0.6, color="C3")
    step = res.device.position_resolution
    if step > 0:
        rx.axhline(step / 2 * 1e6, color="0.6", lw=0.6, ls="--")
        rx.axhline(-step / 2 * 1e6, color="0.6", lw=0.6, ls="--")
    rx.set_ylabel("residual (µm)")
    rx.set_xlabel("time (s)")
    ax.set_title(f"{Path(res.source).name}: residual RMS {res.residual_rms * 1e6:.3g} µm"
                 f"{'' if step <= 0 else f', encoder step {step * 1e6:.3g} µm (dashed: half of it)'}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
