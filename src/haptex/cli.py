"""The ``haptex`` command.

Every bad input ends as one line on stderr (``haptex: error: ...``) and exit status 2.
"""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import click

from ._specs import object_from_spec, quantity as _q, split_spec as _split_spec, texture_from_spec as _texture_from_spec
from ._validation import ParameterError
from .core import blas_held_to_one_thread as _core_blas_held
from .tables import PAPER_PARAMETERS


class Quantity(click.ParamType):
    """A click parameter written with a unit ("0.8mm", "2 kN/m"), converted to SI."""

    name = "quantity"

    def __init__(self, unit: str):
        self.unit = unit

    def convert(self, value, param, ctx):
        if isinstance(value, float):
            return value
        pname = param.name if param is not None else "value"
        try:
            return _q(value, self.unit, pname)
        except ParameterError as exc:
            self.fail(str(exc), param, ctx)


def _paper_options(func):
    opts = [
        click.option("--stiffness", type=Quantity("N/m"), default=PAPER_PARAMETERS["stiffness"],
                     show_default="2000 N/m", help="Nominal wall stiffness kappa_0, e.g. '2 kN/m'."),
        click.option("--amplitude", type=Quantity("m"), default=PAPER_PARAMETERS["amplitude"],
                     show_default="0.8mm", help="Texture amplitude A, e.g. '0.8mm'."),
        click.option("--period", type=Quantity("m"), default=PAPER_PARAMETERS["period"],
                     show_default="1mm", help="Texture spatial period l, e.g. '1mm'."),
        click.option("--max-penetration", type=Quantity("m"), default=PAPER_PARAMETERS["max_penetration"],
                     show_default="1mm", help="d^z_max: the depth of the analysed region; in a simulation, "
                     "Remark 3's clamp of F (this default) and of B, C and G (only when given)."),
        click.option("--friction", type=Quantity("dimensionless"), default=PAPER_PARAMETERS["friction"],
                     show_default="0.8", help="Algorithm F's friction coefficient mu."),
        click.option("--presliding", type=Quantity("m"), default=PAPER_PARAMETERS["presliding"],
                     show_default="1mm", help="Algorithm F's presliding range d^x_max."),
    ]
    for opt in reversed(opts):
        func = opt(func)
    return func


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="haptex")
def cli():
    """haptex: haptic texture synthesis and energy analysis (Campion & Hayward)."""


@cli.command()
@_paper_options
@click.option("--surface", type=click.Choice(["egg-crate"]), default=None,
              help="Table II in 3-D over the areal texture A sin(2 pi x / l) sin(2 pi y / l) (W, A, B, C, F, G).")
@click.option("--json", "as_json", is_flag=True, help="Print the table as JSON.")
@click.option("--quiet", is_flag=True, help="No progress display.")
def table(stiffness, amplitude, period, max_penetration, friction, presliding, surface, as_json, quiet):
    """Table II: characteristic number, loop energy, conservativity, continuity."""
    with _Steps(6 if surface else 8, "Table II", quiet or as_json) as step:
        data = _table(stiffness, amplitude, period, max_penetration, friction, presliding, progress=step,
                      surface=surface)
    if as_json:
        click.echo(json.dumps(_jsonable(data), indent=2))
    else:
        _print_table(data)


@cli.command()
@_paper_options
@click.option("--out", "out", type=click.Path(path_type=Path), default=Path("haptex-report"),
              show_default=True, help="Directory the report is written into.")
@click.option("--quick", is_flag=True, help="Smaller grids and shorter runs (what the test suite runs).")
@click.option("--force", is_flag=True, help="Write into an existing directory that is not a haptex report.")
def reproduce(stiffness, amplitude, period, max_penetration, friction, presliding, out, quick, force):
    """Recompute the paper's tables and experiments; write DIR/index.html, summary.json and PNGs.

    The Table II options change Table II only; the experiments use the paper's conditions.
    """
    import time as _time

    from . import report

    report.check_output(out, force)
    params = dict(stiffness=stiffness, amplitude=amplitude, period=period, max_penetration=max_penetration,
                  friction=friction, presliding=presliding)
    t0 = _time.perf_counter()
    with _Spinner("starting", quiet=False, echo=True) as step:
        data = report.compute(quick=quick, progress=step, table_params=params)
        step("figures and report")
        elapsed = _time.perf_counter() - t0
        report.write_report(data, out, force=force, elapsed=elapsed)
    _print_table(data["table_ii"])
    n_ok = sum(c["verdict"] == "matches" for c in data["claims"])
    click.echo(f"{len(data['claims'])} claims: {n_ok} match, {len(data['claims']) - n_ok} differ"
               + (" (quick run: smaller grids and shorter runs, verdicts may differ from a full run)" if quick else ""))
    for c in data["claims"]:
        if c["verdict"] == "differs":
            click.echo(f"  differs  {c['id']:8} {c['claim']}: paper {c['paper']}; haptex {c['ours']}")
    click.echo(f"wrote {out / 'index.html'} and {out / 'summary.json'} in {_time.perf_counter() - t0:.1f} s")


def _parse_point(text: str, name: str, d: int = 2):
    parts = [p for p in str(text).replace(";", ",").split(",")]
    if len(parts) != d:
        what = {2: "two lengths 'x,z', e.g. '0,-20mm'", 3: "three lengths 'x,y,z', e.g. '0,0,-20mm'",
                4: "four lengths 'x0,x1,y0,y1', e.g. '0,0.3mm,0,0.3mm'"}[d]
        raise ParameterError(f"{name} = {text!r} is not allowed: must be {what}")
    return [_q(p.strip(), "m", name) for p in parts]


def _parse_path(text: str, d: int = 2):
    pts = [_parse_point(v, "path", d) for v in str(text).split(";") if v.strip()]
    if len(pts) < 2:
        raise ParameterError(f"path = {text!r} is not allowed: must be at least two points "
                             + ("'x,z;x,z;...'" if d == 2 else "'x,y,z;x,y,z;...'"))
    return pts


def _felt_options(verb: str):
    """``--crop`` and ``--tip-radius``, the same for every command that takes a measured texture
    (design, export, run); ``verb`` says what the command does with the texture it feels."""
    def deco(func):
        func = click.option("--tip-radius", type=Quantity("m"), default=0.0, show_default="0: a point probe",
                            help="Radius of the ball the texture is touched with, e.g. '0.5mm': the texture it feels "
                                 f"(the map dilated by the ball) is {verb}.")(func)
        return click.option("--crop", default=None,
                            help="The part of a measured file kept: 'auto' (the largest part without undefined "
                                 "points) or 'X0,X1' (a line scan) / 'X0,X1,Y0,Y1' (a map), each with its unit, e.g. "
                                 "'0.1mm,0.9mm,0,0.5mm'.")(func)
    return deco


def _object_options(what: str):
    """``--object`` and ``--uv-scale``, the same for every command that takes an object (design,
    export, run); ``what`` says which letters the command takes there and what it does with them."""
    def deco(func):
        func = click.option("--uv-scale", type=Quantity("m"), default=None,
                            help="With a mesh: metres per unit of its texture coordinates, e.g. '10mm'.")(func)
        return click.option("--object", "object_spec", default=None,
                            help="The texture on an object instead of a plane: 'sphere:RADIUS', 'cylinder:RADIUS' "
                                 "(axis along y), 'plane', or a closed triangle mesh FILE (OBJ, STL, PLY, glTF, ... "
                                 f"with texture coordinates; --uv-scale). {what}")(func)
    return deco


def _device_options(func):
    """One device syntax for every command: --device pantograph|point-mass with its
    parameters as options (or the shorthand 'point-mass:MASS,DAMPING,PERIOD[,RESOLUTION]')."""
    opts = [
        click.option("--device", "device_spec", default=None, show_default="pantograph over a profile, point-mass "
                     "(3-DOF) over a surface",
                     help="'pantograph' or 'point-mass' (parameters below), the shorthand "
                          "'point-mass:MASS,DAMPING,PERIOD[,RESOLUTION]', the generic 3-DOF linkages 'serial-arm' "
                          "and 'delta' (over a surface), a product preset of 'haptex devices' (touch, falcon, "
                          "omega-3, ...; over a profile seen in its x-z plane), or a TOML device file (FILE.toml; "
                          "see haptex.device_from_file)."),
        click.option("--joint-damping", type=Quantity("N*m*s"), default=4.7e-3, show_default="4.7 mN*m*s",
                     help="pantograph: joint damping inside the wall."),
        click.option("--mass", type=Quantity("kg"), default=0.1, show_default="0.1 kg", help="point-mass: mass."),
        click.option("--damping", type=Quantity("N*s/m"), default=0.5, show_default="0.5 N*s/m",
                     help="point-mass: damping."),
        click.option("--sampling-period", type=Quantity("s"), default=1e-4, show_default="100 us", help="T."),
        click.option("--delay", type=int, default=0, show_default=True, help="Whole samples of latency."),
    ]
    for opt in reversed(opts):
        func = opt(func)
    return func


STABILISERS = ("energy-bounding", "set-position")
"""The stabilisers ``--stabiliser`` names (the passivity controller has ``--passivity-control``)."""


def _stabiliser(passivity_control, stabiliser, dev, delay=None):
    """The stabiliser of ``--passivity-control`` or ``--stabiliser`` (one at a time), or None."""
    from .renderer import EnergyBounding, PassiveSetPosition, PassivityController

    if passivity_control is not None and stabiliser is not None:
        raise ParameterError(f"stabiliser = {stabiliser} is not allowed with --passivity-control: one stabiliser at a "
                             "time")
    if passivity_control is not None:
        return PassivityController(passivity_control, delay=delay)
    if stabiliser is None:
        return None
    if not dev.min_damping > 0:
        raise ParameterError(f"stabiliser = {stabiliser} is not allowed on {dev.name}: its damping is 0, and "
                             "the stabiliser pays only with the device's own dissipation")
    cls = EnergyBounding if stabiliser == "energy-bounding" else PassiveSetPosition
    return cls.for_device(dev, delay)


def _catalogued_device(spec: str, dimension: int, delay: int = 0):
    """The device of a preset of 'haptex devices' (with ``delay`` whole periods of computation
    delay) or a TOML device file (FILE.toml), or None for any other spec."""
    from .catalogue import presets
    from .devices import device_from_file

    if str(spec).lower().endswith(".toml"):
        return device_from_file(spec)
    if spec in presets():
        return presets()[spec].device(delay=delay, dimension=dimension)
    return None


def _build_device(ctx, spec: str, joint_damping, mass, damping, sampling_period, delay, dimension: int = 2):
    """The device an invocation describes, refusing parameters of the other preset; a
    point mass is built with ``dimension`` axes (3 for a surface)."""
    from .devices import Device

    if spec is None:  # the default: the paper's planar pantograph, or over a surface a 3-DOF point mass
        spec = "pantograph" if dimension == 2 else "point-mass"
    if str(spec).lower().endswith(".toml"):
        _refuse_unused(ctx, {"*": {"joint_damping", "mass", "damping", "sampling_period", "delay"}}, spec,
                       "--device", owner="*", what="write it in the device file")
        return _catalogued_device(spec, dimension)
    kind, _, rest = str(spec).partition(":")
    if kind in ("serial-arm", "delta") and not rest:
        if dimension != 3:
            raise ParameterError(f"--device {kind} is not allowed over a profile: it is a 3-DOF device; simulate it "
                                 "over a surface (--surface) or use the pantograph or a point mass")
        _refuse_unused(ctx, {"*": {"joint_damping", "mass", "damping", "sampling_period"}}, kind, "--device",
                       owner="*", what="the preset gives it (write a TOML device file to change it)")
        return Device.serial_arm(delay=delay) if kind == "serial-arm" else Device.delta(delay=delay)
    if kind == "pantograph" and dimension != 2:
        raise ParameterError("--device pantograph is not allowed with a surface: the pantograph is planar; use "
                             "--device point-mass (built 3-DOF) or a TOML device file with dimension = 3")
    if kind == "pantograph":
        _refuse_unused(ctx, {"point-mass": {"mass", "damping"}}, kind, "--device")
        jd = _q(rest, "N*m*s", "joint_damping") if rest else joint_damping
        return Device.pantograph(joint_damping=jd, period=sampling_period, delay=delay)
    if kind == "point-mass":
        _refuse_unused(ctx, {"pantograph": {"joint_damping"}}, kind, "--device")
        if not rest:
            return Device.point_mass(mass, damping, sampling_period, delay=delay, dimension=dimension)
        _refuse_unused(ctx, {"*": {"mass", "damping", "sampling_period"}}, spec, "--device", owner="*",
                       what="the shorthand already gives it")
        vals = _split_spec(rest, "device", "point-mass", (3, 4))
        delta = _q(vals[3], "m", "position_resolution") if len(vals) == 4 else 0.0
        return Device.point_mass(_q(vals[0], "kg", "mass"), _q(vals[1], "N*s/m", "damping"),
                                 _q(vals[2], "s", "period"), position_resolution=delta, delay=delay,
                                 dimension=dimension)
    from .catalogue import presets

    if kind in presets() and not rest:
        _refuse_unused(ctx, {"*": {"joint_damping", "mass", "damping", "sampling_period"}}, kind, "--device",
                       owner="*", what="the preset gives it (write a TOML device file to change it)")
        return _catalogued_device(kind, dimension, delay)
    raise ParameterError(f"device = {spec!r} is not allowed: must be 'pantograph', 'point-mass', "
                         "'point-mass:MASS,DAMPING,PERIOD[,RESOLUTION]', 'serial-arm', 'delta', a preset of "
                         f"'haptex devices' ({', '.join(presets())}) or a TOML device file (FILE.toml)")


def _sim_common(func):
    opts = [
        click.option("--algorithm", "letter", default="A", show_default=True, help="W or A-G."),
        _paper_options,
        _device_options,
        click.option("--duration", type=Quantity("s"), default=2.0, show_default="2 s"),
        click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
                     help="Write a figure (PNG, SVG, PDF, ...)."),
        click.option("--save", type=click.Path(dir_okay=False, path_type=Path), default=None,
                     help="Write the time series to a .csv (with a header of units) or .npz file."),
        click.option("--surface", "surface_spec", default=None,
                     help="Simulate in 3-D over a surface: 'egg-crate:AMPLITUDE,PERIOD' or "
                          "'grating:AMPLITUDE,PERIOD[,DIRECTION]' (a 3-DOF device: point-mass, serial-arm, delta)."),
        click.option("--passivity-control", type=Quantity("N*s/m"), default=None,
                     help="Add a passivity observer/controller with this largest damping, e.g. '20 N*s/m'."),
        click.option("--stabiliser", type=click.Choice(STABILISERS), default=None,
                     help="Instead: energy bounding (after Kim & Ryu) or passive set-position modulation (after Lee "
                          "& Huang), paid with the device's own damping."),
        click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON."),
        click.option("--quiet", is_flag=True, help="No progress display."),
        click.pass_context,
    ]
    for opt in reversed(opts):
        func = opt(func)
    return func


@cli.group()
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
              surface_spec=None,
              passivity_control=None, stabiliser=None, band_stiffness=100.0, anchor="0,-30mm", angle=10.0,
              hand_stiffness=300.0,
              hand_damping=1.0, velocity=0.01, depth=1e-3, path_text=None, speed=1e-3, hand_name=None):
    from . import operators as ops
    from .algorithms import ALGORITHMS, algorithm
    from .renderer import PassivityController
    from .simulate import simulate as run
    from .textures import Flat, Sinusoid

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
        tex = _texture_from_spec(surface_spec, None, None, None, False, None, None, False)
        if tex.dimension != 2:
            raise ParameterError(f"surface = {surface_spec!r} is not allowed: must be 'egg-crate:AMPLITUDE,PERIOD' or "
                                 "'grating:AMPLITUDE,PERIOD[,DIRECTION]'")
        d = 3
        alg = algorithm(letter, tex if textured else Flat(dimension=2), stiffness, **params)
    else:
        alg = algorithm(letter, Sinusoid(amplitude, period) if textured else None, stiffness, **params)
    dev = _build_device(ctx, device_spec, joint_damping, mass, damping, sampling_period, delay, dimension=d)
    pc = _stabiliser(passivity_control, stabiliser, dev)
    start = None
    if mode == "thrust":
        if not -80.0 <= angle <= 80.0:
            raise ParameterError(f"angle = {angle:g} is not allowed: must be within +-80 degrees of the normal")
        ax, az = _parse_point(anchor, "anchor")
        a = [ax + az * math.tan(math.radians(angle)), az]
        op = ops.ElasticBand(band_stiffness, a if d == 2 else [a[0], 0.0, a[1]])
        start = [0.0, 1e-3] if d == 2 else [0.0, 0.0, 1e-3]
    elif mode == "scan" and hand_name is not None:
        from .catalogue import hand as _hand

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
        op = ops.ScanningHand(hand_stiffness, hand_damping, velocity=velocity, depth=depth, dimension=d)
        start = [0.0] * d
    else:
        if path_text is None:
            raise ParameterError("path = None is not allowed in path mode: give --path 'x,z;x,z;...' "
                                 "('x,y,z;...' over a surface)")
        op = ops.KinematicPath(_parse_path(path_text, d), speed)
    with _Spinner(f"simulating {duration:g} s at T = {dev.period:g} s", quiet or as_json):
        res = run(alg, dev, op, duration, initial_position=start,
                  record_every=max(1, int(round(duration / dev.period / 20000))), passivity_controller=pc)
    osc = res.oscillation
    units = {"stiffness": "N/m", "sampling_period": "s", "duration": "s", "energy_x": "J", "energy_z": "J",
             "damping_energy": "J", "operator_work": "J", "kinetic_energy": "J", "friction_energy": "J", "energy_y": "J",
             "passivity_control": "N*s/m", "passivity_control_samples": "samples", "observed_energy": "J",
             "energy_balance_error": "1 (relative)", "max_penetration": "m", "saturations": "samples",
             "amplitude": "m", "frequency": "Hz", "energy_per_cycle": "J", "angle": "degree",
             "buzz_db": "dB above the detection threshold", "buzz_frequency": "Hz"}
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
    if mode == "thrust":
        summary["angle"] = angle
    if save is not None:
        _save_trace(res, save)
        summary["save"] = str(save)
    if plot is not None:
        from .plotting import plot_simulation

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
    for a, b in rows:
        t.add_row(a, b)
    Console().print(_fitted(t))


class _Steps:
    """A rich progress bar over the eight algorithms on stderr, with the time elapsed and an
    estimate of the time left, shown on a terminal only and never with --json or --quiet;
    used as ``with _Steps(n, quiet) as step: f(progress=step)``."""

    def __init__(self, total: int, title: str, quiet: bool):
        from rich.console import Console

        self.console = Console(stderr=True)
        self.show = self.console.is_terminal and not quiet
        self.total, self.title = total, title
        self.weights = {}

    def __enter__(self):
        if not self.show:
            return lambda letter: None
        from rich.progress import (BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn,
                                   TimeRemainingColumn)

        # the time left is rich's estimate from the steps done so far (steps differ: D and E
        # over a measured map take longest), shown once a step has ended
        self.bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                            TextColumn("left"), TimeRemainingColumn(), console=self.console, transient=True)
        self.bar.__enter__()
        self.task = self.bar.add_task(self.title, total=self.total)
        self.started = None

        def step(letter):
            if self.started is not None:
                self.bar.advance(self.task, self.weights.get(self.started, 1.0))
            self.started = letter
            what = f"algorithm {letter}" if len(letter) == 1 else letter
            self.bar.update(self.task, description=f"{self.title}: {what}")
        return step

    def weigh(self, weights: dict) -> None:
        """Steps of unequal length: each step's share of the bar (its estimated seconds),
        the steps not named 1 s each."""
        if not self.show:
            return
        self.weights = dict(weights)
        done = self.bar.tasks[0].completed
        rest = self.total - done - (1 if self.started is not None else 0)
        self.bar.update(self.task, total=done + 1 + sum(self.weights.values()) + max(0, rest - len(self.weights)))

    def __exit__(self, *exc):
        if self.show:
            self.bar.__exit__(*exc)
        return False


class _Spinner:
    """A rich spinner with the elapsed time on stderr for work whose length is unknown (a
    compiled simulation, reading a file), shown on a terminal only and never with --json or
    --quiet: ``with _Spinner("simulating", quiet) as say: ...; say("next step")``. Off a
    terminal, ``echo=True`` prints each step as a line instead."""

    def __init__(self, text: str, quiet: bool, echo: bool = False):
        from rich.console import Console

        self.console = Console(stderr=True)
        self.text, self.quiet, self.echo = text, quiet, echo

    def __enter__(self):
        from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

        self.prog = Progress(SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(),
                             console=self.console, transient=True,
                             disable=self.quiet or not self.console.is_terminal)
        self.prog.__enter__()
        self.task = self.prog.add_task(self.text, total=None)

        def say(text):
            self.prog.update(self.task, description=text)
            if self.echo and not self.quiet and not self.console.is_terminal:
                self.console.print(f"haptex: {text}")
        return say

    def __exit__(self, *exc):
        self.prog.__exit__(*exc)
        return False


def _given_for_letter(ctx, letter: str, names) -> set:
    """The options of ``names`` (keyword parameters of :func:`haptex.algorithm`) given on the
    command line; one that the letter's algorithm does not take (the registry's
    :attr:`haptex.algorithms.Algorithm.parameters`) is refused in one line, naming the letters
    that take it. An unknown letter is left to :func:`haptex.algorithm` to refuse."""
    from click.core import ParameterSource

    from .algorithms import ALGORITHMS

    key = str(letter).strip().upper()
    given = {n for n in names if ctx.get_parameter_source(n) == ParameterSource.COMMANDLINE}
    for name in sorted(given):
        if key in ALGORITHMS and name not in ALGORITHMS[key].parameters:
            raise _not_taken(name, key)
    return given


def _not_taken(name: str, letter: str) -> ParameterError:
    """The one-line refusal of the option for keyword parameter ``name`` with a letter that does
    not take it, naming the letters that do (the registry)."""
    from .algorithms import taking

    return ParameterError(f"--{name.replace('_', '-')} is not allowed with --algorithm {letter}: it applies to "
                          f"{', '.join(taking(name))}")


def _refuse_unused(ctx, groups: dict, chosen: str, by: str = "mode", owner: str | None = None,
                   what: str | None = None) -> None:
    """Refuse, in one line, an option given on the command line that the choice ``chosen``
    does not use: ``groups`` maps each choice to the options only it uses (or, with
    ``owner``, the options that choice ``owner`` cannot take; ``what`` says why)."""
    from click.core import ParameterSource

    for key, names in groups.items():
        relevant = (key != chosen) if owner is None else (key == owner)
        if not relevant:
            continue
        for name in sorted(names):
            if ctx.get_parameter_source(name) == ParameterSource.COMMANDLINE:
                flag = "--" + ("path" if name == "path_text" else name.replace("_", "-"))
                where = f"{by} {chosen}" if by != "mode" else f"the {chosen} mode"
                why = what or (f"it applies to {key} only" if owner is None else "it applies to textured algorithms only")
                raise ParameterError(f"{flag} is not allowed with {where}: {why}")


def _save_columns(d: int) -> list[tuple[str, str]]:
    """(name, SI unit) of the saved trace's columns, in the plane (d = 2) or in space (3)."""
    axes = "xz" if d == 2 else "xyz"
    return ([("time", "s")] + [(a, "m") for a in axes] + [(f"v{a}", "m/s") for a in axes]
            + [(f"f{a}", "N") for a in axes] + [(f"energy_{a}", "J") for a in axes]
            + [("damping_energy", "J"), ("operator_work", "J"), ("kinetic_energy", "J")])


def _check_save_path(save: Path) -> None:
    if save.suffix.lower() not in (".csv", ".npz"):
        raise ParameterError(f"save = {str(save)!r} is not allowed: must end in .csv or .npz")
    parent = save.parent if str(save.parent) else Path(".")
    if not parent.is_dir():
        raise ParameterError(f"save = {str(save)!r} is not allowed: the directory {str(parent)!r} does not exist")


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


def _check_plot_path(plot: Path) -> None:
    """Refuse, before computing, a figure path matplotlib cannot write."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    formats = sorted(FigureCanvasAgg(Figure()).get_supported_filetypes())
    suffix = plot.suffix.lower().lstrip(".")
    if suffix not in formats:
        raise ParameterError(f"plot = {str(plot)!r} is not allowed: its extension must name a figure format "
                             f"({', '.join(formats)})")
    parent = plot.parent if str(plot.parent) else Path(".")
    if not parent.is_dir():
        raise ParameterError(f"plot = {str(plot)!r} is not allowed: the directory {str(parent)!r} does not exist")


@cli.command()
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
@click.option("--spacing", type=Quantity("m"), default=None,
              help="Sample spacing when the file does not state it, e.g. '0.5um'.")
@click.option("--x-unit", default=None, help="Unit of the file's x column when it does not state it.")
@click.option("--height-unit", default=None, help="Unit of the file's heights when it does not state it.")
@click.option("--level", is_flag=True, help="Remove the profile's best-fit line.")
@click.option("--lowpass", type=Quantity("m"), default=None, help="Band-limit the profile to this shortest period.")
@click.option("--scale", default=None, help="'LENGTH_FACTOR,HEIGHT_FACTOR' to stretch the profile.")
@click.option("--periodic", is_flag=True, help="Close the profile into a periodic texture.")
@click.option("--window", default=None, help="'X0,X1' abscissa window to analyse (default: one period or the whole "
              "profile); over a surface 'X0,X1,Y0,Y1' (default: one periodic cell or the whole map).")
@click.option("--fill-undefined", is_flag=True,
              help="Fill a measured file's undefined (NaN) heights by interpolation instead of refusing the file.")
@_felt_options("analysed")
@click.option("--raw", is_flag=True,
              help="Analyse the measured samples as they are, not band-limited to what the device renders.")
@click.option("--hand", default="light-touch", show_default=True,
              help="The hand gripping the handle for the stable limits: a hand of 'haptex devices' (none, "
                   "light-touch, firm-grip).")
@_object_options("A, B, C, F and G are analysed there (D and E with --algorithms, but on a faceted mesh).")
@click.option("--algorithms", default=None,
              help="The algorithms to analyse, e.g. 'A,F' (default: every one defined for the texture; on an object "
                   "A, B, C, F, G: D and E, about 10 s each, on request).")
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
           max_penetration, spacing, x_unit, height_unit, level, lowpass, scale, periodic, window, fill_undefined, crop,
           tip_radius, raw, object_spec, uv_scale, vertex_normals, algorithms, hand, report_dir, force, as_json, quiet):
    """Which algorithm, how stiff, will it be passive, can the device render it?

    A measured texture is band-limited to the shortest period the device renders at the
    speed (the four period limits of Section II-B) and analysed as rendered; --raw analyses
    the samples as they are."""
    from .catalogue import hand as _hand
    from .design import design as run_design

    hand = _hand(hand)  # a misspelt hand before the texture is read
    with _Spinner("reading the texture", quiet or as_json):
        tex = _texture_from_spec(texture_spec, spacing, x_unit, height_unit, level, lowpass, scale, periodic,
                                 fill_undefined, crop)
    if raw and not hasattr(tex, "band_limited"):
        raise ParameterError(f"--raw is not allowed with the synthetic texture {texture_spec!r}: it applies to measured "
                             "textures read from a file")
    felt = None
    if tip_radius:
        with _Spinner(f"rolling a ball of {tip_radius * 1e3:g} mm over the texture", quiet or as_json):
            point = tex
            tex = tex.felt_by(tip_radius)
        felt = {"tip_radius": tip_radius, "max_slope_point_probe": float(point.max_slope),
                "max_slope_felt": float(tex.max_slope), "source": tex.source}
    base = object_from_spec(object_spec, uv_scale, vertex_normals)
    dev = _build_device(ctx, device_spec, joint_damping, mass, damping, sampling_period, delay,
                        3 if base is not None else tex.dimension + 1)
    x_range = None
    if window and tex.dimension == 1:
        x_range = _parse_point(window, "window")
    elif window:
        x0, x1, y0, y1 = _parse_point(window, "window", 4)
        x_range = ((x0, x1), (y0, y1))
    if report_dir is not None:
        from .report import check_output

        if base is not None:
            raise ParameterError("--report is not allowed with --object yet: the design report draws fields in the "
                                 "x-z plane of a profile; use --json for an object")
        if tex.dimension != 1:
            raise ParameterError("--report is not allowed with a surface yet: the design report draws fields in the "
                                 "x-z plane of a profile; use --json for a surface")
        check_output(report_dir, force)  # before the minutes of analysis
    elif force:
        raise ParameterError("--force is not allowed without --report: it applies to the report directory")
    steps = _Steps(9, "design", quiet or as_json)

    def announce(est):
        if not (quiet or as_json):
            searches = (f"; D and E: {est['searches']:.3g} closest-point searches at "
                        f"{est['seconds_per_search'] * 1e6:.3g} us" if est["searches"] else "")
            click.echo(f"estimate: at least {est['seconds']:.3g} s of analysis and {est['peak_bytes'] / 2**20:.3g} MiB "
                       f"for its largest grid{searches}", err=True)
        steps.weigh({L: v["seconds"] for L, v in est["algorithms"].items()})

    with steps as step:
        data = run_design(tex, dev, stiffness, speed=speed, max_penetration=max_penetration, x_range=x_range,
                          progress=step, band_limit=not raw, hand=hand, on_estimate=announce, base=base,
                          algorithms=None if algorithms is None else [v for v in algorithms.split(",") if v.strip()])
    if report_dir is not None:
        from .design import rendered_texture
        from .report import write_design_report

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
    bl = data["band_limit"]
    rn = bl["raw"]
    if bl["sampled"]:
        dom = "" if rn["dominant_period"] is None else f", dominant period {rn['dominant_period'] * 1e3:.4g} mm"
        console.print(f"measured {data['texture']}: {bl['samples']['raw']} samples, RMS {rn['rms'] * 1e6:.4g} um{dom}, "
                      f"M = {rn['max_slope']:.4g}, max curvature {rn['max_curvature']:.4g} 1/m")
    names = bl["set_by"]
    by = names[0] + " limit" if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1] + " limits"
    cut = f"the device renders periods >= {bl['cutoff'] * 1e3:.4g} mm at {speed:g} m/s (set by the {by})"
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
                  f"{r['max_passive_stiffness']:.4g}", f"{r['max_stable_stiffness']:.4g}",
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


@cli.command()
@click.option("--algorithm", "letter", required=True, help="W or A-G.")
@click.option("--texture", "texture_spec", default=None,
              help="FILE, 'sine:AMPLITUDE,PERIOD', 'sum:A1,L1;A2,L2' or 'noise:RMS,SHORTEST,LONGEST,LENGTH[,SEED]' "
                   "(not for W).")
@click.option("--stiffness", type=Quantity("N/m"), required=True, help="kappa_0, e.g. '2 kN/m'.")
@click.option("--max-force", type=Quantity("N"), required=True, help="Force saturation, e.g. '5 N'.")
@click.option("--max-penetration", type=Quantity("m"), default=None, help="B, C, G, F: d^z_max (Remark 3).")
@click.option("--friction", type=Quantity("dimensionless"), default=None, help="F: mu (default 0.8).")
@click.option("--presliding", type=Quantity("m"), default=None, help="F: d^x_max (default 1 mm).")
@click.option("--stick-deflection", type=Quantity("m"), default=None,
              help="F: the smooth presliding model's elastic range z_stick (default: the sharp model).")
@click.option("--spacing", type=Quantity("m"), default=None, help="Sample spacing when the file does not state it.")
@click.option("--x-unit", default=None, help="Unit of the file's x column when it does not state it.")
@click.option("--height-unit", default=None, help="Unit of the file's heights when it does not state it.")
@click.option("--level", is_flag=True, help="Remove the profile's best-fit line.")
@click.option("--lowpass", type=Quantity("m"), default=None, help="Band-limit the profile to this shortest period.")
@click.option("--periodic", is_flag=True, help="Close the profile into a periodic texture.")
@_object_options("A-G are exported there (D and E but on a faceted mesh: give --vertex-normals).")
@click.option("--passivity-control", type=Quantity("N*s/m"), default=None,
              help="Export a passivity observer/controller with this largest damping (needs --device).")
@click.option("--stabiliser", type=click.Choice(STABILISERS), default=None,
              help="Instead: energy bounding or passive set-position modulation, paid with the device's damping "
                   "(needs --device).")
@click.option("--device", "device_spec", default=None,
              help="With a stabiliser: the device the firmware runs on (a preset of 'haptex devices' or FILE.toml): "
                   "its period, delay and damping.")
@_felt_options("rendered")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Directory for haptex_texture.c, haptex_texture.h and the C core's files.")
@click.option("--quiet", is_flag=True, help="No progress display.")
def export(letter, texture_spec, stiffness, max_force, max_penetration, friction, presliding, stick_deflection,
           spacing, x_unit, height_unit, level, lowpass, periodic, object_spec, uv_scale, passivity_control, stabiliser,
           device_spec, tip_radius, crop, out, quiet):
    """C99 source of one algorithm on one texture, for device firmware (<math.h> only)."""
    from .algorithms import ALGORITHMS, algorithm
    from .export import TICK_FILES, export_c
    from .objects import object_algorithm

    letter = str(letter).upper()
    takes = ALGORITHMS[letter].parameters if letter in ALGORITHMS else ()
    if letter in ALGORITHMS and not ALGORITHMS[letter].textured:
        if texture_spec is not None:
            raise ParameterError("--texture is not allowed with --algorithm W: the smooth wall has no texture")
        for flag, value in (("--tip-radius", tip_radius), ("--crop", crop)):
            if value:
                raise ParameterError(f"{flag} is not allowed with --algorithm W: the smooth wall has no texture")
        tex = None
    elif texture_spec is None:
        raise ParameterError(f"--texture is required with --algorithm {letter}: give a file, 'sine:...' or 'noise:...'")
    else:
        with _Spinner("reading the texture", quiet):
            tex = _texture_from_spec(texture_spec, spacing, x_unit, height_unit, level, lowpass, None, periodic,
                                     crop=crop, tip_radius=tip_radius)
    params = {}
    for name, value in (("max_penetration", max_penetration), ("friction", friction), ("presliding", presliding),
                        ("stick_deflection", stick_deflection)):
        if value is not None:
            if name not in takes:
                raise _not_taken(name, letter)
            params[name] = value
    base = object_from_spec(object_spec, uv_scale)
    if base is not None:
        alg = object_algorithm(letter, tex, base, stiffness, **params)
    else:
        alg = algorithm(letter, tex, stiffness, **params)
    pc = period = None
    if passivity_control is not None or stabiliser is not None:
        if device_spec is None:
            raise ParameterError(f"--{'passivity-control' if stabiliser is None else 'stabiliser'} needs --device: the "
                                 "device's period, delay and damping set the stabiliser")
        from .catalogue import presets

        dev = _catalogued_device(device_spec, alg.dimension)
        if dev is None:
            raise ParameterError(f"device = {device_spec!r} is not allowed: must be a preset of 'haptex devices' "
                                 f"({', '.join(presets())}) or a TOML device file (FILE.toml)")
        pc, period = _stabiliser(passivity_control, stabiliser, dev, delay=dev.delay), dev.period
    elif device_spec is not None:
        raise ParameterError("--device is not allowed without --passivity-control or --stabiliser: the exported "
                             "tick reads nothing else of the device")
    with _Spinner("writing the C source", quiet):
        h_path, c_path = export_c(alg, out, max_force, passivity_controller=pc, period=period)
    click.echo(f"wrote {c_path}, {h_path} and the C core's {len(TICK_FILES)} files beside them: {alg!r}, max force "
               f"{max_force:g} N{'' if pc is None else ', ' + pc.label} (build: cc -std=c99 -O2 {out}/*.c -lm)")


@cli.command()
@click.argument("spec", type=click.Path(path_type=Path))
@click.option("--out", "out", type=click.Path(path_type=Path), required=True,
              help="The Zarr store (a directory); rerunning the same SPEC into it resumes.")
@click.option("--scheduler", default=None, help="A running Dask scheduler, tcp://HOST:PORT (default: a local cluster).")
@click.option("--workers", type=int, default=None, help="Workers of the local cluster (default: one process a core; 1: in this process, "
                   "using every core).")
@click.option("--quiet", is_flag=True, help="No progress display.")
def sweep(spec, out, scheduler, workers, quiet):
    """A stability atlas: every run of SPEC (TOML or YAML) on Dask, into a Zarr store."""
    import time as _time

    from .atlas import SweepSpec
    from .atlas import sweep as run_sweep

    if scheduler is not None and workers is not None:
        raise ParameterError("--workers is not allowed with --scheduler: the cluster at the scheduler has its workers")
    parsed = SweepSpec.from_file(spec)
    t0 = _time.perf_counter()
    ds = run_sweep(parsed, out, scheduler=scheduler, workers=workers, progress=not quiet)
    n = parsed.runs
    click.echo(f"{out}: {n} runs ({' x '.join(f'{a.name} {a.values.size}' for a in parsed.axes)}), "
               f"{ds.attrs['blocks_computed']} blocks computed and {ds.attrs['blocks_skipped']} already done, in "
               f"{_time.perf_counter() - t0:.1f} s; {int(ds['unstable'].sum())} unstable (limit cycle, growing or "
               f"diverged), {int(ds['oscillating'].sum())} oscillating")


@cli.command("run")
@click.option("--device", "device_spec", required=True,
              help="'simulated:PRESET' (a preset of 'haptex devices', e.g. 'simulated:falcon'); "
                   "'forcedimension[:PRESET]' (Force Dimension's SDK, pip install 'haptex[forcedimension]'); "
                   "'openhaptics[:PRESET]' (OpenHaptics, pip install 'haptex[openhaptics]'); "
                   "'haply[:ws://HOST:PORT]' (the Inverse Service, pip install 'haptex[haply]'); "
                   "'haply-serial[:PORT]' (Haply's hardware API on a serial port, pip install "
                   "'haptex[haply-serial]').")
@click.option("--texture", "texture_spec", default="sine:0.2mm,2mm", show_default=True,
              help="A texture spec as for design (a profile is extruded across y on a 3-DOF device).")
@click.option("--algorithm", "letter", default="A", show_default=True,
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
@_felt_options("rendered")
@click.option("--record", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the run log (time, position, force, engaged) to FILE.csv (the columns of the file formats "
                   "page, read by 'haptex identify') or FILE.npz.")
@click.option("--vibration", "vibration_models", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="A data-driven vibration layered on the texture (haptex's JSON or HaTT's XML, at the device's "
                   "servo rate): the device's mass along x times its acceleration, along the motion.")
@click.option("--vibration-budget", type=Quantity("W"), default=None,
              help="With --vibration: the power it may supply, spent from an energy tank in the tick (e.g. '2 mW').")
@click.option("--find-limit", "find_limit_run", is_flag=True,
              help="Instead of a texture: a smooth wall whose stiffness rises by 10% every 0.5 s while the handle "
                   "rests on it, stopped (force zero) at the first step that oscillates; from --stiffness when "
                   "given, else a quarter of the predicted stable limit with --hand, up to four times that limit.")
@click.option("--identify", "identify_run", is_flag=True,
              help="Instead of a texture: the identification program (steps and a chirp along x at 20% of the "
                   "device's max force, a 50 N/m centering spring), the handle free; needs --record.")
@click.option("--json", "as_json", is_flag=True, help="Print the summary as JSON.")
@click.option("--quiet", is_flag=True, help="No live dashboard.")
@_core_blas_held  # BLAS in the set-up (a preset's matrices, a slope bound) wakes no worker to spin beside the loop
def run_device(device_spec, texture_spec, letter, stiffness, max_force, duration, passivity_control, stabiliser, hand,
               speed, fast, object_spec, uv_scale, tip_radius, crop, record, vibration_models, vibration_budget,
               find_limit_run, identify_run, as_json, quiet):
    """Render one texture on one device, with the safety rules of haptex.servo and a live dashboard."""
    import numpy as np

    from .algorithms import algorithm
    from .backends import open_backend
    from .renderer import Renderer
    from .servo import ServoLoop, analyse_trace
    from .surfaces import Extruded

    if record is not None and record.suffix.lower() not in (".npz", ".csv"):
        raise ParameterError(f"record = {str(record)!r} is not allowed: must end in .csv or .npz")
    if record is not None and not (record.parent if str(record.parent) else Path(".")).is_dir():
        raise ParameterError(f"record = {str(record)!r} is not allowed: its directory does not exist")
    ctx = click.get_current_context()
    if find_limit_run:
        if identify_run:
            raise ParameterError("--find-limit is not allowed with --identify: one program a run")
        given = [n for n in ("texture_spec", "letter", "passivity_control", "stabiliser", "object_spec", "tip_radius",
                             "crop", "speed", "duration", "vibration_models", "vibration_budget")
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
                                     "object_spec", "tip_radius", "crop", "speed", "vibration_models",
                                     "vibration_budget")
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
    options = ({"hand": hand, "speed": speed, "realtime": not fast} if kind == "simulated"
               else {"realtime": not fast} if kind == "forcedimension" else {})
    backend = open_backend(device_spec, **options)
    dev = backend.device
    fmax = backend.max_force if max_force is None else max_force
    if not fmax <= backend.max_force:
        raise ParameterError(f"max_force = {fmax:g} N is not allowed: at most the device's {backend.max_force:g} N")
    if identify_run:  # no texture: the program instead, the handle free
        from .identification import FRACTION, IdentificationProgram

        if not math.isfinite(fmax):
            raise ParameterError(f"--identify is not allowed on {backend.name} without --max-force: the program "
                                 "is a share of the largest force")
        program = IdentificationProgram(backend.dimension, dev.period, duration, FRACTION * fmax)
        return _identification_run(backend, program, fmax, duration, record, as_json)
    tex = None
    letter = letter.upper()
    if letter != "W":
        tex = _texture_from_spec(texture_spec, None, None, None, False, None, None, False, crop=crop,
                                 tip_radius=tip_radius)
        if tex.dimension == 1 and backend.dimension == 3:
            tex = Extruded(tex)
        elif tex.dimension == 2 and backend.dimension == 2:
            raise ParameterError(f"texture = {texture_spec!r} is not allowed on {backend.name}: a surface needs a "
                                 "3-DOF device")
    elif backend.dimension == 3:
        from .textures import Flat

        tex = Flat(dimension=2)
    base = object_from_spec(object_spec, uv_scale)
    if base is not None:
        from .objects import object_algorithm

        if backend.dimension != 3:
            raise ParameterError(f"--object is not allowed on {backend.name}: an object needs a 3-DOF device")
        if letter == "PROXY":
            from .proxy import GodObject

            alg = GodObject(tex, stiffness, base)
        else:
            alg = object_algorithm(letter, tex, base, stiffness)
    elif letter == "PROXY":
        from .proxy import GodObject

        alg = GodObject(tex, stiffness)
    else:
        alg = algorithm(letter, tex, stiffness)
    pc = _stabiliser(passivity_control, stabiliser, dev, delay=dev.delay)

    vib = {}
    if vibration_budget is not None and vibration_models is None:
        raise ParameterError("--vibration-budget is not allowed without --vibration MODELS: it is the vibration's")
    if vibration_models is not None:
        from .datadriven import read_models

        models = read_models(vibration_models)
        if abs(models.sample_rate * dev.period - 1.0) > 1e-6:
            raise ParameterError(f"vibration = {str(vibration_models)!r} is not allowed on {backend.name}: its models "
                                 f"run at {models.sample_rate:g} Hz, the device's servo at {1 / dev.period:g} Hz (fit "
                                 f"them at that rate: haptex fit RECORDING --rate '{1 / dev.period:g} Hz')")
        # the device's own mass along x turns acceleration into force (a simulated device's has the hand's added)
        own = backend.preset.device() if kind == "simulated" else dev
        vib = {"vibration": models, "vibration_mass": float(own.mass[0, 0]), "vibration_budget": vibration_budget}
    renderer = Renderer(alg, max_force=fmax if math.isfinite(fmax) else None, energy_monitor=True,
                        passivity_controller=pc, period=dev.period, **vib)
    loop = ServoLoop(backend, renderer, max_force=fmax if math.isfinite(fmax) else None)
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
               "memory_locked": stats.memory_locked,
               "interrupted": stats.interrupted, "regime": verdict["regime"], "oscillating": osc.oscillating,
               "amplitude": osc.amplitude, "frequency": osc.frequency,
               "stabiliser": None if pc is None else pc.label,
               "stabiliser_ticks": 0 if pc is None else renderer.controller_active,
               # (None: no component above the encoder's floor, nothing to judge)
               "buzz_db": None if verdict["buzz"] is None or verdict["buzz"].margin_db == -math.inf
               else verdict["buzz"].margin_db,
               "buzz_frequency": None if verdict["buzz"] is None or verdict["buzz"].margin_db == -math.inf
               else verdict["buzz"].frequency,
               **({"vibration_supplied": renderer.vibration_supplied, "vibration_cut": renderer.vibration_cut,
                   "vibration_budget": vibration_budget} if vib else {}),
               "units": {"stiffness": "N/m", "max_force": "N", "duration": "s", "engaged_at": "s",
                         "amplitude": "m", "frequency": "Hz",
                         "max_force_sent": "N", "energy_observed": "J", **{f"energy_{a}": "J" for a in axes},
                         "tick_max": "s", "tick_mean": "s", "tick_p999": "s", "period_mean": "s",
                         "period_std": "s", "jitter_max": "s", "jitter_p999": "s",
                         "stabiliser_ticks": "ticks", "buzz_db": "dB above the detection threshold",
                         "buzz_frequency": "Hz", "vibration_supplied": "J", "vibration_cut": "ticks",
                         "vibration_budget": "W"}}
    if record is not None:
        _write_record(record, trace, dev.period)
    if stats.driver == "native thread" and loop.priority and not stats.fifo and getattr(backend, "realtime", True):
        click.echo("notice: the servo thread ran at normal priority: SCHED_FIFO needs CAP_SYS_NICE or a real-time "
                   "limit (ulimit -r, /etc/security/limits.conf)", err=True)
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
               + ("; interrupted (forces zeroed)" if stats.interrupted else ""))
    if record is not None:
        click.echo(f"trace: {record}")


def _write_record(record: Path, trace: dict, period: float) -> None:
    """The run's log: CSV (haptex.identify.LOG_COLUMNS) or the trace's arrays in .npz."""
    import numpy as np

    if record.suffix.lower() == ".csv":
        from .identification import write_log

        write_log(record, trace["time"], trace["position"], trace["force"], trace["engaged"])
    else:
        np.savez(record, **trace, period=period, units=np.array(["s", "m", "N", "1"]))


def _find_limit_run(device_spec, start, max_force, hand, fast, record, as_json, quiet) -> None:
    """``haptex run --find-limit``: the stiffness ladder on the device (haptex.limits.find_limit)."""
    from .backends import open_backend
    from .catalogue import hand as _hand, hands
    from .limits import FIND_RATIO, FIND_SPAN, FIND_STEP, SIM_PUSH, find_limit, wall_limits

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
    fmax = backend.max_force if max_force is None else max_force
    if not fmax <= backend.max_force:
        raise ParameterError(f"max_force = {fmax:g} N is not allowed: at most the device's {backend.max_force:g} N")
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
            buzz = "" if step["buzz_db"] is None else f", buzz {step['buzz_db']:+.1f} dB at {step['buzz_frequency']:.4g} Hz"
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
    from .servo import ServoLoop

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


@cli.command("identify")
@click.argument("log", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Device file to write (TOML, usable as --device FILE.toml).")
@click.option("--axis", type=click.Choice(["x", "y", "z", "all"]), default="x", show_default=True,
              help="The log's axes fitted (the identification run excites x).")
@click.option("--max-delay", type=click.IntRange(0, 1000), default=10, show_default=True,
              help="Largest delay searched (whole periods).")
@click.option("--json", "as_json", is_flag=True, help="Print the figures as JSON.")
def identify_command(log, out, axis, max_delay, as_json):
    """Fit a device model (mass, damping, Coulomb friction, encoder step, delay) to a run log."""
    from .identification import AXES, identify, read_log

    if not (out.parent if str(out.parent) else Path(".")).is_dir():
        raise ParameterError(f"out = {str(out)!r} is not allowed: its directory does not exist")
    lg = read_log(log)
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
    if as_json:
        click.echo(json.dumps(_jsonable({**res.to_dict(), "device_file": str(out)}), indent=2))
        return
    click.echo(res.report())
    click.echo(f"device file: {out} (use it as --device {out})")


@cli.command("fit")
@click.argument("recording", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Model file to write (haptex's JSON).")
@click.option("--sample-rate", type=Quantity("Hz"), default=None,
              help="The recording's rate, e.g. '10 kHz', when it has no time_s column.")
@click.option("--rate", type=Quantity("Hz"), default=None, show_default="the recording's",
              help="The models' rate: the renderer's servo rate, e.g. '1 kHz'.")
@click.option("--order", type=int, default=None, show_default="chosen by BIC", help="AR order p.")
@click.option("--ma-order", type=int, default=0, show_default=True, help="MA order q (0: AR models).")
@click.option("--segment", type=Quantity("s"), default=0.2, show_default="0.2 s",
              help="Windows in which speed and force are judged steady.")
@click.option("--highpass", type=Quantity("Hz"), default=20.0, show_default="20 Hz",
              help="Cut-off of the high-pass that removes the hand's motion.")
def fit_cmd(recording, out, sample_rate, rate, order, ma_order, segment, highpass):
    """Fit ARMA vibration models over (speed, force) to a recording (CSV: time_s, acc_m_s2 or
    acc_x/y/z_m_s2, speed_m_s, force_n), and write them."""
    from .datadriven import read_recording

    if not out.parent.is_dir():
        raise ParameterError(f"--out = '{out}' is not allowed: must be a file in an existing folder")
    rec = read_recording(recording, sample_rate=sample_rate)
    models = rec.fit(rate=rate, order=order, ma_order=ma_order, segment=segment, highpass=highpass,
                     name=recording.stem)
    models.write(out)
    r = models.report
    click.echo(f"{len(models.models)} ARMA{r.order} models at {r.sample_rate:g} Hz from {r.segments} steady windows "
               f"of {r.windows} (order: {r.criterion}); written to {out}")


@cli.command()
@click.argument("models", type=click.Path(dir_okay=False, path_type=Path))
@click.option("--speed", type=Quantity("m/s"), required=True, help="Tangential speed, e.g. '50 mm/s'.")
@click.option("--force", type=Quantity("N"), required=True, help="Normal force, e.g. '1 N'.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the spectrum's figure (PNG or SVG).")
@click.option("--device", "device_spec", default=None,
              help="A preset of 'haptex devices' (or FILE.toml) to display the vibration on, as a force "
                   "(its mass x the acceleration, along x): the power it supplies at the port is reported.")
@click.option("--hand", default="light-touch", show_default=True,
              help="With --device: the hand holding the handle (none, light-touch, firm-grip).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of text.")
def vibration(models, speed, force, plot, device_spec, hand, as_json):
    """The vibration a model set gives at one speed and force: the interpolated model, its
    power and its spectrum (HaTT's XML or haptex's JSON); with --device, the energy it
    supplies at the device's port."""
    import numpy as np

    from .catalogue import hand as _hand
    from .datadriven import port_energy, read_models

    if plot is not None:
        _check_plot_path(plot)
    grip = _hand(hand)
    dev = None
    if device_spec is not None:
        dev = _catalogued_device(device_spec, 2)
        if dev is None:
            raise ParameterError(f"--device = {device_spec!r} is not allowed: must be a preset of 'haptex devices' or "
                                 "a device file FILE.toml")
    s = read_models(models)
    idx, lam, clamped = s.weights(speed, force)
    m = s.model_at(speed, force)
    f = np.linspace(0.0, s.sample_rate / 2, 512)
    psd = m.psd(f)
    rms = math.sqrt(m.output_variance())
    peak = float(f[int(np.argmax(psd))])
    port = None if dev is None else port_energy(m, dev, None if grip.key == "none" else grip)
    if as_json:
        click.echo(json.dumps({"models": str(models), "speed": speed, "force": force, "order": list(m.order),
                               "weights": [{"model": int(i) + 1, "weight": float(w)} for i, w in zip(idx, lam)],
                               "clamped_to_hull": clamped, "rms_acceleration": rms, "peak_frequency": peak, "sample_rate": s.sample_rate,
                               "port": None if port is None else {"device": device_spec, "hand": grip.key,
                                                                  **dataclasses.asdict(port)},
                               "units": {"speed": "m/s", "force": "N", "rms_acceleration": "m/s^2",
                                         "peak_frequency": "Hz", "sample_rate": "Hz", "power": "W", "to_hand": "W",
                                         "to_device": "W", "rms_force": "N", "effective_mass": "kg",
                                         "period": "s"}}, indent=2))
    else:
        import shutil
        import textwrap

        width = shutil.get_terminal_size((80, 24)).columns
        echo = lambda text: click.echo(textwrap.fill(text, width, subsequent_indent="  "))  # noqa: E731
        echo(repr(s))
        where = " (outside the hull: its closest point)" if clamped else ""
        echo(f"at {speed * 1e3:g} mm/s, {force:g} N{where}: ARMA{m.order}, weights "
             + ", ".join(f"model {int(i) + 1}: {w:.3f}" for i, w in zip(idx, lam)))
        echo(f"rms acceleration {rms:.4g} m/s^2; spectrum's peak at {peak:.4g} Hz")
        if port is not None:
            echo(f"on {device_spec} held by the hand {grip.key!r}: {port.rms_force:.3g} N rms "
                 f"({port.effective_mass:.3g} kg x the acceleration) supplies {port.power * 1e3:.3g} mW at the "
                 f"port ({port.to_hand * 1e3:.3g} mW into the hand, {port.to_device * 1e3:.3g} mW into the "
                 "device's damping)")
    if plot is not None:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(6, 3.5))
        ax.semilogy(f[1:], psd[1:])
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel("PSD ((m/s²)²/Hz)")
        ax.set_title(f"{s.name or models.name}: {speed * 1e3:g} mm/s, {force:g} N")
        fig.tight_layout()
        fig.savefig(plot)
        plt.close(fig)


@cli.command()
@click.option("--port", type=int, default=5006, show_default=True, help="TCP port (0: any free port).")
@click.option("--no-browser", is_flag=True, help="Do not open the page in a browser.")
def explore(port, no_browser):
    """Explore a texture's force field, gain, curl, loop energies and scans in the browser.

    Serves http://127.0.0.1:PORT/ until interrupted (Ctrl-C)."""
    from .explore import serve

    serve(port, open_browser=not no_browser,
          announce=lambda url: click.echo(f"haptex explore: serving {url} (Ctrl-C to stop)"))


@cli.group()
def atlas():
    """Read a stability atlas written by haptex sweep."""


@atlas.command("plot")
@click.argument("store", type=click.Path(path_type=Path))
@click.option("--x", "x", required=True, help="Dimension along the horizontal axis, e.g. stiffness.")
@click.option("--y", "y", required=True, help="Dimension along the vertical axis, e.g. damping.")
@click.option("--select", "selects", multiple=True, help="NAME=VALUE fixing another dimension (nearest value; "
              "with its unit for a quantity, e.g. delay=1 or damping='0.5 N*s/m').")
@click.option("--out", "out", type=click.Path(dir_okay=False, path_type=Path), default=Path("atlas.png"),
              show_default=True, help="Figure file (PNG, SVG, PDF, ...).")
def atlas_plot(store, x, y, selects, out):
    """Heat maps of verdict and energy rate over two dimensions, with the analytic limit."""
    from .atlas import open_atlas
    from .plotting import plot_atlas
    from .simulate import SWEEP_UNITS

    _check_plot_path(out)
    ds = open_atlas(store)
    where = {}
    for item in selects:
        name, sep, value = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise ParameterError(f"select = {item!r} is not allowed: must be NAME=VALUE, e.g. delay=0")
        if name == "algorithm":
            where[name] = value.strip().upper()
        elif name == "delay":
            where[name] = float(_q(value, "dimensionless", "select delay"))
        elif name in SWEEP_UNITS:
            where[name] = _q(value, SWEEP_UNITS[name], f"select {name}")
        else:
            raise ParameterError(f"select {name!r} is not allowed: the atlas's dimensions are {', '.join(ds.sizes)}")
    path = plot_atlas(ds, x, y, where, out)
    click.echo(f"wrote {path}")


def _fitted(table, width: int | None = None):
    """``table`` laid out to keep every word whole in the terminal's width (issue 57: at 80
    columns names and numbers were cut to '…'): each column gets at least its longest word,
    header included, and at most its longest cell; the room between is shared in proportion to
    what each column would still take; text wraps at spaces. The caption is printed below as a
    paragraph (a caption wider than the table lost its ends). A table whose words alone are wider
    than the terminal keeps them whole and is wider."""
    from rich.console import Console, Group
    from rich.padding import Padding
    from rich.text import Text

    width = Console().width if width is None else width
    lows, highs = [], []
    for col in table.columns:
        cells = [str(cell) for cell in col.cells]
        low = max((len(w) for text in (str(col.header), *cells) for w in text.split()), default=1)
        lows.append(low)
        highs.append(max([low, *(len(text) for text in cells)]))
    n = len(lows)
    table.collapse_padding, table.pad_edge = True, False  # one space between columns, none at the edges
    _, right, _, left = Padding.unpack(table.padding)
    rules = (2 if table.box and table.show_edge else 0) + (n - 1 if table.box else 0)  # (rich counts them)
    room = width - (n - 1) * max(left, right) - rules
    spare, wanted = room - sum(lows), sum(h - lo for lo, h in zip(lows, highs))
    if spare >= wanted:
        widths = highs
    else:
        widths = [lo + (h - lo) * max(spare, 0) // max(wanted, 1) for lo, h in zip(lows, highs)]
    for col, w in zip(table.columns, widths):
        col.width = w
        col.no_wrap = False
        col.overflow = "fold"
    caption, table.caption = table.caption, None
    return Group(table, Text(str(caption))) if caption else table


def _limits_table(wall: dict, title: str):
    """A rich table of :func:`haptex.limits.wall_limits`'s ``as_dict()``."""
    from rich import box
    from rich.table import Table

    t = Table(title=title, box=box.SIMPLE_HEAD,
              caption=f"passive_stiffness {wall['passive_stiffness']:.4g} N/m; stable_stiffness "
                      f"{wall['stable_stiffness']:.4g} N/m with the hand {wall['hand']!r}; {wall['note']}")
    for col in ("limit", "kind", "N/m", "condition", "source"):
        t.add_column(col)
    for lim in wall["limits"]:
        t.add_row(lim["name"], lim["kind"], "n/a" if lim["value"] is None else f"{lim['value']:.4g}",
                  lim["formula"], lim["source"])
    return _fitted(t)


@cli.group(invoke_without_command=True)
@click.option("--wide", is_flag=True, help="Also the product's name and description (a wide terminal).")
@click.pass_context
def devices(ctx, wide):
    """The device presets, with their sources and wall limits ('haptex devices show NAME')."""
    if ctx.invoked_subcommand is not None:
        return
    from rich import box
    from rich.console import Console
    from rich.table import Table

    from .catalogue import DEFAULT_HAND, presets
    from .limits import wall_limits

    t = Table(title="device presets", box=box.SIMPLE_HEAD,
              caption=f"passive: Colgate & Schenkel or Abbott & Okamura; stable: closed loop with the hand "
                      f"{DEFAULT_HAND!r}; rated: the manufacturer's (or CHAI3D's) figure, reported only. "
                      "'haptex devices show NAME' for every number and its source; --wide adds each product's name.")
    columns = ("name", "DOF", "rate (Hz)", "max force (N)", "passive (N/m)", "stable (N/m)", "rated (N/m)")
    for col in columns + (("device",) if wide else ()):
        t.add_column(col)
    for key, p in presets().items():
        dev = p.device()
        w = wall_limits(dev, DEFAULT_HAND, preset=p)
        t.add_row(key, str(p.dimension), f"{1 / dev.period:g}", f"{dev.max_force:g}", f"{w.passive:.0f}",
                  f"{w.stable:.0f}", "-" if p.rated_stiffness is None else f"{p.rated_stiffness:.0f}",
                  *((p.label,) if wide else ()))
    Console().print(_fitted(t))


@devices.command("show")
@click.argument("name")
@click.option("--hand", default="light-touch", show_default=True, help="none, light-touch or firm-grip.")
@click.option("--delay", type=int, default=0, show_default=True, help="Whole samples of computation delay.")
@click.option("--virtual-damping", type=Quantity("N*s/m"), default=0.0, show_default="0 N*s/m",
              help="The wall's damper B_v.")
@click.option("--json", "as_json", is_flag=True)
def devices_show(name, hand, delay, virtual_damping, as_json):
    """One preset: every number with its status and source, and the wall limits side by side."""
    from .catalogue import hand as _hand, preset
    from .limits import wall_limits

    p = preset(name)
    h = _hand(hand)
    dev = p.device(delay=delay)
    w = wall_limits(dev, h, virtual_damping, preset=p, simulated=True)
    if as_json:
        out = {"preset": p.key, "label": p.label, "model": p.model, "dimension": p.dimension, "delay": delay,
               "virtual_damping": virtual_damping, **w.as_dict(),
               "parameters": {k: f.as_dict() for k, f in p.figures.items()},
               "hand_parameters": {k: f.as_dict() for k, f in h.figures.items()},
               "device": {"mass": dev.mass.tolist(), "damping": dev.damping.tolist(), "period": dev.period,
                          "position_resolution": dev.position_resolution, "max_force": dev.max_force,
                          "coulomb_friction": dev.coulomb_friction, "delay": dev.delay,
                          "units": {"mass": "kg", "damping": "N*s/m", "period": "s", "position_resolution": "m",
                                    "max_force": "N", "coulomb_friction": "N", "delay": "samples"}}}
        click.echo(json.dumps(_jsonable(out), indent=2))
        return
    from rich import box
    from rich.console import Console
    from rich.table import Table

    from .catalogue import sources

    console = Console()
    t = Table(title=f"{p.key}: {p.label} ({p.model}, {p.dimension} DOF)", box=box.SIMPLE_HEAD)
    for col in ("parameter", "value", "status", "source or reason"):
        t.add_column(col)
    for k, f in p.figures.items():
        t.add_row(k, f.written, f.status, f.source if f.status != "chosen" else f.note)
    console.print(_fitted(t))
    console.print(f"hand {h.key!r}: {h.label}; {h.mass:g} kg, {h.damping:g} N s/m, {h.stiffness:g} N/m")
    console.print(_limits_table(w.as_dict(), f"wall limits (delay {delay}, B_v {virtual_damping:g} N s/m)"))
    cited = sorted({f.source for f in (*p.figures.values(), *h.figures.values()) if f.source})
    for key in cited:
        console.print(f"[{key}] {sources()[key]}")


def _table(stiffness, amplitude, period, max_penetration, friction, presliding, progress=None, surface=None):
    from .tables import table_ii

    return table_ii(stiffness, amplitude, period, max_penetration, friction=friction, presliding=presliding,
                    progress=progress, surface=surface)


def _fmt_q(row) -> str:
    v = row["characteristic_number"]
    return "unbounded" if math.isinf(v) else f"{v:.4g}"


def _print_table(data) -> None:
    import numpy as np
    from rich import box
    from rich.console import Console
    from rich.table import Table

    p = data["parameters"]
    where = " in 3-D, egg-crate" if p["texture"].startswith("SumOfGratings") else ""
    t = Table(
        title=(f"Table II{where}: kappa_0 = {p['stiffness']:g} N/m, A = {p['amplitude'] * 1e3:g} mm, "
               f"l = {p['period'] * 1e3:g} mm, depth {p['max_penetration'] * 1e3:g} mm"),
        box=box.SIMPLE_HEAD, caption="ours / paper; closed forms in --json",
    )
    for col in ("alg.", "q", "paper q", "loop energy (J)", "conservative", "continuous"):
        t.add_column(col)
    for r in data["rows"]:
        t.add_row(
            r["algorithm"],
            _fmt_q(r),
            r["paper"]["characteristic_number"],
            f"{r['loop_energy']:.4g}",
            ("yes" if r["conservative"] else ("almost" if r.get("almost_conservative") else "no"))
            + " / " + r["paper"]["conservative"],
            ("yes" if r["continuous"] else "no") + " / " + r["paper"]["continuous"],
        )
    console = Console()
    console.print(_fitted(t))
    for r in data["rows"]:
        ex = r.get("characteristic_number_extra") or {}
        if "bound_eq26" in ex:
            paper = ex.get("paper_reported")
            q = r["characteristic_number"]
            verdict = (f"paper reports {paper}: {'agrees' if math.isclose(q, paper, rel_tol=0.05) else 'differs'}"
                       if paper is not None else "no value reported by the paper for these parameters")
            d = float(np.linalg.norm(ex["deflection"]))  # a number over a profile, a vector over a surface
            console.print(
                f"{r['algorithm']}: q numeric {q:.4g} ({ex['phase']}, |d| = {d * 1e3:.3g} mm); "
                f"eq. 26 bound {ex['bound_eq26']:.4g}; eq. 31 as printed {ex['eq31_as_printed']:.4g}; {verdict}"
            )


def _jsonable(obj):
    """JSON-ready copy of results (non-finite floats as strings); see haptex.report.jsonable."""
    from .report import jsonable

    return jsonable(obj)


def _one_line(exc: click.ClickException) -> str:
    """A usage error in one line plus a hint: click's message, or for a group called without
    its command (click raised the whole help as the error) the commands it has; then where
    the help is."""
    ctx = getattr(exc, "ctx", None)
    path = ctx.command_path if ctx is not None else "haptex"
    msg = exc.format_message()
    if ctx is not None and isinstance(ctx.command, click.Group) and msg.lstrip().startswith("Usage:"):
        msg = f"{path} needs a command: {', '.join(ctx.command.list_commands(ctx))}"
    msg = " ".join(msg.split())
    return msg + (f" (see '{path} --help')" if isinstance(exc, click.UsageError) else "")


def main(argv=None) -> int:
    """Entry point of the ``haptex`` console script; returns the exit status. Warnings are
    held until the command ends: shown after a result, dropped before an error's one line
    (a warning printed above it read as a second error: issue 33)."""
    import warnings

    held = []

    def hold(message, category, filename, lineno, file=None, line=None):
        if len(held) < MAX_HELD_WARNINGS:  # bounded: `haptex explore` may run for days
            held.append((message, category, filename, lineno))

    with warnings.catch_warnings():  # the filters in force are kept; showwarning is restored on exit
        warnings.showwarning = hold
        status = _run(argv)
    if status == 0:
        for w in held:
            warnings.showwarning(*w)
    return status


MAX_HELD_WARNINGS = 100
"""Most warnings held until a command ends (the rest are dropped)."""


def _run(argv) -> int:
    try:
        cli.main(args=argv, prog_name="haptex", standalone_mode=False)
    except click.exceptions.Exit as exc:
        return exc.exit_code
    except click.exceptions.Abort:
        click.echo("haptex: aborted", err=True)
        return 1
    except click.ClickException as exc:
        click.echo(f"haptex: error: {_one_line(exc)}", err=True)
        return 2
    except ParameterError as exc:  # one line, whatever text of the user's the message quotes
        click.echo("haptex: error: " + str(exc).replace("\r", "\\r").replace("\n", "\\n"), err=True)
        return 2
    except OSError as exc:  # the file system refused: still one line, never a traceback
        click.echo(f"haptex: error: {exc.strerror or exc}: {exc.filename or ''}".rstrip(": "), err=True)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
