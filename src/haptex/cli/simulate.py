"""``haptex simulate thrust|scan|path``: one sampled-data run of a device and an operator."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click

from .._specs import texture_from_spec as _texture_from_spec
from .._validation import ParameterError, nonnegative
from ._common import (
    Quantity, STABILISERS, _Spinner, _build_device, _check_plot_path, _check_save_path, _device_options,
    _fitted, _given_for_letter, _jsonable, _letter, _paper_options, _parse_path, _parse_point, _refuse_unused,
    _budget_needs_models, _stabiliser, _vibration, _vibration_options_no_friction)


def _sim_common(func):
    opts = [
        click.option("--algorithm", "letter", default="A", show_default=True, callback=_letter(), help="W or A-G."),
        _paper_options,
        _device_options,
        click.option("--duration", type=Quantity("s"), default=2.0, show_default="2 s"),
        click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
                     help="Write a figure (PNG, SVG, PDF, ...)."),
        click.option("--save", type=click.Path(dir_okay=False, path_type=Path), default=None,
                     help="Write the time series to a .csv (with a header of units) or .npz file."),
        click.option("--record-every", type=int, default=None,
                     help="Keep one step in N of the time series --save and --plot write (the verdicts read "
                          "every step of the run's tail whatever N).",
                     show_default="one in round(steps / 20,000): about 20,000 rows at most"),
        click.option("--surface", "surface_spec", default=None,
                     help="Simulate in 3-D over a surface: 'egg-crate:AMPLITUDE,PERIOD' or "
                          "'grating:AMPLITUDE,PERIOD[,DIRECTION]' (a 3-DOF device: point-mass, serial-arm, delta)."),
        click.option("--passivity-control", type=Quantity("N*s/m"), default=None,
                     help="Add a passivity observer/controller with this largest damping, e.g. '20 N*s/m'."),
        click.option("--stabiliser", type=click.Choice(STABILISERS), default=None,
                     help="Instead: energy bounding (after Kim & Ryu) or passive set-position modulation (after Lee "
                          "& Huang), paid with the device's own damping."),
        _vibration_options_no_friction,
        click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON."),
        click.option("--quiet", is_flag=True, help="No progress display."),
        click.pass_context,
    ]
    for opt in reversed(opts):
        func = opt(func)
    return func


@click.group()
def simulate():
    """Simulate a device in closed loop with an algorithm: thrust (Fig. 5), scan (Figs. 6, 7) or path."""


@simulate.command()
@_sim_common
@click.option("--band-stiffness", type=Quantity("N/m"), default=100.0, show_default="100 N/m", help="Band stiffness.")
@click.option("--anchor", default="0,-30mm", show_default=True, help="Band anchor 'x,z' before --angle.")
@click.option("--angle", type=Quantity("degree"), default=10.0, show_default="10 degree",
              help="The band pulls this far off the normal (the anchor moves back by depth x tan(angle)), so the "
                   "texture is felt, as in Fig. 5.")
def thrust(ctx, **kw):
    """Push into the wall with an elastic band (Fig. 5)."""
    _simulate(ctx, "thrust", **kw)


@simulate.command()
@_sim_common
@click.option("--hand-stiffness", type=Quantity("N/m"), default=300.0, show_default="300 N/m", help="Hand stiffness.")
@click.option("--hand-damping", type=Quantity("N*s/m"), default=1.0, show_default="1 N*s/m", help="Hand damping.")
@click.option("--velocity", type=Quantity("m/s"), default=0.01, show_default="10 mm/s", help="Set-point speed.")
@click.option("--depth", type=Quantity("m"), default=1e-3, show_default="1mm", help="Set-point depth.")
@click.option("--hand", "hand_name", default=None,
              help="A hand of 'haptex devices' (light-touch, firm-grip) instead of --hand-stiffness and "
                   "--hand-damping: its spring and damper drag the handle and its mass moves with it.")
def scan(ctx, **kw):
    """Stroke along the texture with a hand impedance (Figs. 6, 7)."""
    _simulate(ctx, "scan", **kw)


@simulate.command()
@_sim_common
@click.option("--path", "path_text", required=True, help="Vertices 'x,z;x,z;...' (units required, 0 excepted).")
@click.option("--speed", type=Quantity("m/s"), default=1e-3, show_default="1 mm/s", help="Speed along the path.")
def path(ctx, **kw):
    """Drive the handle along a polyline (an infinitely stiff hand): loop energies in closed loop."""
    _simulate(ctx, "path", **kw)


def _simulate(ctx, mode, letter, stiffness, amplitude, period, max_penetration, friction, presliding, device_spec,
              joint_damping, mass, damping, sampling_period, delay, duration, plot, save, as_json, quiet=False,
              surface_spec=None, record_every=None,
              passivity_control=None, stabiliser=None, band_stiffness=100.0, anchor="0,-30mm", angle=10.0,
              hand_stiffness=300.0,
              hand_damping=1.0, velocity=0.01, depth=1e-3, path_text=None, speed=1e-3, hand_name=None,
              vibration_models=None, vibration_budget=None):
    from .. import operators as ops
    from ..algorithms import ALGORITHMS, algorithm
    from ..renderer import PassivityController
    from ..simulate import simulate as run
    from ..textures import Flat, Sinusoid

    given = _given_for_letter(ctx, letter, ("friction", "presliding", "max_penetration"))
    if str(letter).upper() == "W":
        _refuse_unused(ctx, {"*": {"amplitude", "period"}}, "W", "--algorithm", owner="*")
    if plot is not None:
        _check_plot_path(plot)
    if save is not None:
        _check_save_path(save)
    letter = letter.upper()
    # F takes its friction, presliding and d^z_max (the paper's 1 mm by default); B, C and G their
    # d^z_max (Remark 3) when it is given, else none (unclamped, as haptex.algorithm makes them)
    takes = getattr(ALGORITHMS.get(letter), "parameters", ())
    textured = getattr(ALGORITHMS.get(letter), "textured", True)  # (an unknown letter: haptex.algorithm refuses it)
    options = (("friction", friction), ("presliding", presliding), ("max_penetration", max_penetration))
    params = {k: v for k, v in options if k in given or ("friction" in takes and k in takes)}
    d = 2
    if surface_spec is not None:
        _refuse_unused(ctx, {"*": {"amplitude", "period"}}, repr(surface_spec), "--surface", owner="*",
                       what="the surface spec gives the texture")
        if str(surface_spec).partition(":")[0].strip() not in ("egg-crate", "grating"):  # (a file: run reads it)
            raise ParameterError(f"surface = {surface_spec!r} is not allowed: must be 'egg-crate:AMPLITUDE,PERIOD' or "
                                 "'grating:AMPLITUDE,PERIOD[,DIRECTION]' (a measured file is rendered on a simulated "
                                 "device by 'haptex run --device simulated:PRESET --texture FILE')")
        tex = _texture_from_spec(surface_spec)
        if tex.dimension != 2:
            raise ParameterError(f"surface = {surface_spec!r} is not allowed: must be 'egg-crate:AMPLITUDE,PERIOD' or "
                                 "'grating:AMPLITUDE,PERIOD[,DIRECTION]'")
        d = 3
        alg = algorithm(letter, tex if textured else Flat(dimension=2), stiffness, **params)
    else:
        alg = algorithm(letter, Sinusoid(amplitude, period) if textured else None, stiffness, **params)
    dev = _build_device(ctx, device_spec, joint_damping, mass, damping, sampling_period, delay, dimension=d)
    pc = _stabiliser(passivity_control, stabiliser, dev)
    _budget_needs_models(vibration_models, vibration_budget)
    # the vibration's mass: the device's own along x (a hand's mass, attached below, is not the display's)
    vib = {} if vibration_models is None else _vibration(vibration_models, dev.period, dev.mass[0, 0],
                                                         vibration_budget, dev.name)
    start = None
    if mode == "thrust":
        if not -80.0 <= angle <= 80.0:
            raise ParameterError(f"angle = {angle:g} is not allowed: must be within +-80 degrees of the normal")
        ax, az = _parse_point(anchor, "anchor")
        a = [ax + az * math.tan(math.radians(angle)), az]
        op = ops.ElasticBand(band_stiffness, a if d == 2 else [a[0], 0.0, a[1]])
        start = [0.0, 1e-3] if d == 2 else [0.0, 0.0, 1e-3]
    elif mode == "scan" and hand_name is not None:
        from ..catalogue import hand as _hand

        _refuse_unused(ctx, {"*": {"hand_stiffness", "hand_damping"}}, hand_name, "--hand", owner="*",
                       what="the hand model gives it")
        h = _hand(hand_name)
        if h.none:
            raise ParameterError(f"hand = {hand_name!r} is not allowed in scan mode: a scan needs a hand that drags "
                                 "the handle (light-touch, firm-grip)")
        dev = h.attach(dev)
        op = h.operator(depth=depth, velocity=velocity, dimension=d)
        start = [0.0] * d
    elif mode == "scan":
        # (the operator takes matrices, and refuses one not positive semi-definite: a scalar here)
        op = ops.ScanningHand(nonnegative("hand_stiffness", hand_stiffness, "N/m"),
                              nonnegative("hand_damping", hand_damping, "N*s/m"), velocity=velocity, depth=depth,
                              dimension=d)
        start = [0.0] * d
    else:
        if path_text is None:
            raise ParameterError("path = None is not allowed in path mode: give --path 'x,z;x,z;...' "
                                 "('x,y,z;...' over a surface)")
        op = ops.KinematicPath(_parse_path(path_text, d), speed)
    # the time series kept (--save, --plot): about 20,000 rows at most unless --record-every says
    every = max(1, int(round(duration / dev.period / 20000))) if record_every is None else record_every
    with _Spinner(f"simulating {duration:g} s at T = {dev.period:g} s", quiet or as_json):
        res = run(alg, dev, op, duration, initial_position=start,
                  record_every=every, passivity_controller=pc, **vib)
    osc = res.oscillation
    units = {"stiffness": "N/m", "sampling_period": "s", "duration": "s", "energy_x": "J", "energy_z": "J",
             "damping_energy": "J", "operator_work": "J", "kinetic_energy": "J", "friction_energy": "J", "energy_y": "J",
             "passivity_control": "N*s/m", "passivity_control_samples": "samples", "observed_energy": "J",
             "energy_balance_error": "1 (relative)", "max_penetration": "m", "saturations": "samples",
             "amplitude": "m", "frequency": "Hz", "energy_per_cycle": "J", "angle": "degree",
             "buzz_db": "dB above the detection threshold", "buzz_frequency": "Hz", "vibration_supplied": "J",
             "vibration_power": "W", "vibration_budget": "W", "vibration_cut": "samples",
             "vibration_clamped": "samples", "vibration_mass": "kg"}
    summary = {"units": units, "mode": mode, "algorithm": letter, "stiffness": stiffness, "device": dev.name,
               "sampling_period": dev.period, "duration": duration, **res.totals,
               "energy_balance_error": res.energy_balance_error, "max_penetration": res.max_penetration,
               "saturations": res.saturations, "oscillating": osc.oscillating, "regime": res.regime,
               "oscillation_axis": osc.axis,
               "amplitude": osc.amplitude, "frequency": osc.frequency, "energy_per_cycle": osc.energy_per_cycle,
               "dimension": d}
    bz = res.buzz
    if bz is not None:
        summary["buzz_db"], summary["buzz_frequency"] = bz.margin_db, bz.frequency
    if surface_spec is not None:
        summary["surface"] = surface_spec
    if pc is not None:
        summary["stabiliser"] = pc.label
        if isinstance(pc, PassivityController):
            summary["passivity_control"] = pc.max_damping
        summary["passivity_control_samples"] = res.passivity_control_samples
        summary["observed_energy"] = res.observed_energy  # the observer's count; the port's: energy_x + energy_z
    if vib:
        summary.update(vibration=str(vibration_models), vibration_mass=vib["vibration_mass"],
                       vibration_supplied=res.vibration_supplied, vibration_power=res.vibration_supplied / duration,
                       vibration_cut=res.vibration_cut, vibration_clamped=res.vibration_clamped,
                       vibration_budget=vibration_budget)
    if mode == "thrust":
        summary["angle"] = angle
    summary["record_every"] = every
    units["record_every"] = "steps"
    if save is not None:
        _save_trace(res, save)
        summary["save"] = str(save)
    if plot is not None:
        from ..plotting import plot_simulation

        try:
            plot_simulation(res, plot, f"{mode}: algorithm {letter}, kappa_0 = {stiffness:g} N/m")
        except OSError as exc:
            raise ParameterError(f"plot = {str(plot)!r} is not allowed: cannot write it ({exc.strerror})") from None
        summary["plot"] = str(plot)
    if as_json:
        click.echo(json.dumps(_jsonable(summary), indent=2))
        return
    from rich.console import Console
    from rich.table import Table

    t = Table(title=f"simulate {mode}: algorithm {letter} on the {dev.name}, {duration:g} s at T = {dev.period:g} s")
    t.add_column("quantity")
    t.add_column("value")
    rows = [("E_x = -Σ f_x Δx (J)", f"{res.totals['energy_x']:.4g}")]
    if d == 3:
        rows.append(("E_y = -Σ f_y Δy (J)", f"{res.totals['energy_y']:.4g}"))
    rows += [("E_z = -Σ f_z Δz (J)", f"{res.totals['energy_z']:.4g}"),
            ("dissipated by damping (J)", f"{res.totals['damping_energy']:.4g}"),
            ("operator work (J)", f"{res.totals['operator_work']:.4g}"),
            ("energy balance error (relative)", f"{res.energy_balance_error:.2g}"),
            ("max penetration (mm)", f"{res.max_penetration * 1e3:.4g}"), ("saturations", str(res.saturations)),
            ("oscillating", "yes" if osc.oscillating else "no"), ("regime", res.regime),
            ("tail amplitude (mm) / frequency (Hz)", f"{osc.amplitude * 1e3:.3g} / {osc.frequency:.4g}"),
            ("energy supplied per cycle (J)", f"{osc.energy_per_cycle:.3g}")]
    if vib:
        rows += [("vibration: supplied (J) / mean power (mW)",
                  f"{res.vibration_supplied:.3g} / {res.vibration_supplied / duration * 1e3:.3g}"),
                 ("vibration: samples cut by its budget / off its models",
                  f"{res.vibration_cut} / {res.vibration_clamped}")]
    if (save is not None or plot is not None) and every > 1:
        rows.append(("time series written (--save, --plot)",
                     f"one step in {every} ({1 / (every * dev.period):.4g} Hz; --record-every 1 keeps all)"))
    for a, b in rows:
        t.add_row(a, b)
    Console().print(_fitted(t))


def _save_columns(d: int) -> list[tuple[str, str]]:
    """(name, SI unit) of the saved trace's columns, in the plane (d = 2) or in space (3)."""
    axes = "xz" if d == 2 else "xyz"
    return ([("time", "s")] + [(a, "m") for a in axes] + [(f"v{a}", "m/s") for a in axes]
            + [(f"f{a}", "N") for a in axes] + [(f"energy_{a}", "J") for a in axes]
            + [("damping_energy", "J"), ("operator_work", "J"), ("kinetic_energy", "J")])


def _save_trace(res, save: Path) -> None:
    """The recorded time series, one row per recorded sample, SI units in the header."""
    import numpy as np

    names = _save_columns(res.dimension)
    cols = ([res.time] + list(res.position.T) + list(res.velocity.T) + list(res.force.T)
            + list(res.energy_per_axis.T) + [res.damping_energy, res.operator_work, res.kinetic_energy])
    try:
        if save.suffix.lower() == ".npz":
            np.savez_compressed(save, **{n: c for (n, _), c in zip(names, cols)},
                                units=np.array([u for _, u in names]))
        else:
            header = ",".join(f"{n} ({u})" for n, u in names)
            np.savetxt(save, np.column_stack(cols), delimiter=",", header=header, comments="", fmt="%.17g")
    except OSError as exc:
        raise ParameterError(f"save = {str(save)!r} is not allowed: cannot write it ({exc.strerror})") from None
