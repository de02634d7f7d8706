"""``haptex export``: the C tick and its model for firmware."""

from __future__ import annotations

from pathlib import Path

import click

from .._specs import check_tip_spacing, object_from_spec, texture_from_spec as _texture_from_spec
from .._validation import ParameterError
from ._common import (
    Quantity, STABILISERS, _Spinner, _before_the_ball, _catalogued_device, _check_search_budget, _felt_options,
    _letter, _not_taken, _object_options, _reading_given, _reading_options, _stabiliser, _budget_needs_models,
    _vibration, _vibration_options)


@click.command()
@click.option("--algorithm", "letter", required=True, callback=_letter(), help="W or A-G.")
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
@_reading_options
@_object_options("A-G are exported there (D and E but on a faceted mesh: give --vertex-normals).")
@click.option("--passivity-control", type=Quantity("N*s/m"), default=None,
              help="Export a passivity observer/controller with this largest damping (needs --device).")
@click.option("--stabiliser", type=click.Choice(STABILISERS), default=None,
              help="Instead: energy bounding or passive set-position modulation, paid with the device's damping "
                   "(needs --device).")
@click.option("--device", "device_spec", default=None,
              help="With a stabiliser or a vibration: the device the firmware runs on (a preset of 'haptex devices' "
                   "or FILE.toml): its period, delay and damping; its mass along x for the vibration.")
@_vibration_options
@_felt_options("rendered")
@click.option("--out", "out", type=click.Path(file_okay=False, path_type=Path), required=True,
              help="Directory for haptex_texture.c, haptex_texture.h and the C core's files.")
@click.option("--target", type=click.Choice(["host", "cortex-m4", "cortex-m7"]), default="host", show_default=True,
              help="What the source is compiled for: the host's cc, or a Cortex-M4F or M7 (arm-none-eabi-gcc, the "
                   "hard-float ABI; a bare-metal start, memory map and example main.c written beside; built and its "
                   "flash and RAM reported when arm-none-eabi-gcc is installed).")
@click.option("--max-evaluations", type=int, default=None,
              help="D and E over a surface: the texture evaluations one tick's closest-point search may spend, 100 "
                   "to 10^9 (default 5,000, the renderer's: 1.5-2.5 ms on this project's PC over a measured map, "
                   "more on a microcontroller; set it from your board's measured tick); past it the tick uses the "
                   "best point found.")
@click.option("--quiet", is_flag=True, help="No progress display.")
def export(letter, texture_spec, stiffness, max_force, max_penetration, friction, presliding, stick_deflection,
           reading, object_spec, uv_scale, mesh_unit, box_uv, passivity_control, stabiliser, device_spec,
           vibration_models, vibration_budget, no_material_friction, tip_radius, tip_spacing, crop, out, target,
           max_evaluations, quiet):
    """C99 source of one algorithm on one texture, for device firmware (<math.h> only)."""
    from ..algorithms import ALGORITHMS, algorithm
    from ..export import TICK_FILES, build_defines, check_settings, export_c, firmware_command
    from ..objects import object_algorithm

    letter = str(letter).upper()
    takes = ALGORITHMS[letter].parameters if letter in ALGORITHMS else ()
    if letter in ALGORITHMS and not ALGORITHMS[letter].textured:
        if texture_spec is not None:
            raise ParameterError("--texture is not allowed with --algorithm W: the smooth wall has no texture")
        for flag, value in (("--tip-radius", tip_radius), ("--tip-spacing", tip_spacing), ("--crop", crop),
                            *((flag, True) for flag in _reading_given(click.get_current_context()))):
            if value:
                raise ParameterError(f"{flag} is not allowed with --algorithm W: the smooth wall has no texture")
        tex = None
    elif texture_spec is None:
        raise ParameterError(f"--texture is required with --algorithm {letter}: give a file, 'sine:...' or 'noise:...'")
    else:
        check_tip_spacing(tip_radius, tip_spacing)
        with _Spinner("reading the texture", quiet):  # (felt below, once every other setting is checked)
            tex = _texture_from_spec(texture_spec, **reading, crop=crop)
    params = {}
    for name, value in (("max_penetration", max_penetration), ("friction", friction), ("presliding", presliding),
                        ("stick_deflection", stick_deflection)):
        if value is not None:
            if name not in takes:
                raise _not_taken(name, letter)
            params[name] = value
    base = object_from_spec(object_spec, uv_scale, mesh_unit=mesh_unit, box_uv=box_uv)

    def exported(tex):  # (the algorithm on the texture, on its object where there is one)
        return (object_algorithm(letter, tex, base, stiffness, **params) if base is not None
                else algorithm(letter, tex, stiffness, **params))

    alg = exported(_before_the_ball(tex, tip_radius, base))  # (its settings refused before a ball rolls over it)
    dev = None
    if device_spec is not None:
        if passivity_control is None and stabiliser is None and vibration_models is None:
            raise ParameterError("--device is not allowed without --passivity-control, --stabiliser or --vibration: "
                                 "the exported tick reads nothing else of the device")
        from ..catalogue import did_you_mean, presets

        dev = _catalogued_device(device_spec, alg.dimension)
        if dev is None:
            raise ParameterError(f"device = {device_spec!r} is not allowed: must be a preset of 'haptex devices' "
                                 f"({', '.join(presets())}) or a TOML device file (FILE.toml)"
                                 + did_you_mean(device_spec))
    pc = period = None
    if passivity_control is not None or stabiliser is not None:
        if dev is None:
            raise ParameterError(f"--{'passivity-control' if stabiliser is None else 'stabiliser'} needs --device: the "
                                 "device's period, delay and damping set the stabiliser")
        pc, period = _stabiliser(passivity_control, stabiliser, dev, delay=dev.delay), dev.period
    _budget_needs_models(vibration_models, vibration_budget, no_material_friction)
    vib = {}
    if vibration_models is not None:
        if dev is None:
            raise ParameterError("--vibration needs --device: the device's mass along x turns the vibration's "
                                 "acceleration into force, and its servo rate must be the models'")
        vib = _vibration(vibration_models, dev.period, dev.mass[0, 0], vibration_budget, dev.name,
                         False if no_material_friction else None)
    check_settings(max_force, **({} if max_evaluations is None else {"max_evaluations": max_evaluations}),
                   target=target)
    _check_search_budget(max_evaluations, alg)
    if tip_radius:
        with _Spinner(f"rolling a ball of {tip_radius * 1e3:g} mm over the texture", quiet):
            tex = tex.felt_by(tip_radius, spacing=tip_spacing)
        alg = exported(tex)
    with _Spinner("writing the C source", quiet):
        h_path, c_path = export_c(alg, out, max_force, passivity_controller=pc, period=period, target=target,
                                  **({} if max_evaluations is None else {"max_evaluations": max_evaluations}), **vib)
    command = firmware_command(out, target, defines=build_defines(alg))
    click.echo(f"wrote {c_path}, {h_path} and the C core's {len(TICK_FILES)} files beside them"
               f"{'' if target == 'host' else ' (and startup.c, mps2.ld, main.c)'}: {alg!r}, max force "
               f"{max_force:g} N{'' if pc is None else ', ' + pc.label}{'' if not vib else ', a data-driven vibration'} "
               f"(build: {' '.join(command)})")
    if target != "host":
        _report_firmware(out, command, target)


def _report_firmware(out: Path, command: list, target: str) -> None:
    """Build a Cortex-M export with its example main when arm-none-eabi-gcc is installed, and
    report its flash and static RAM (arm-none-eabi-size); otherwise say how."""
    import shutil
    import subprocess

    if shutil.which(command[0]) is None or shutil.which("arm-none-eabi-size") is None:
        click.echo(f"{command[0]} is not installed (Debian: apt-get install gcc-arm-none-eabi "
                   "libnewlib-arm-none-eabi): not built")
        return
    args = [x for a in command for x in (sorted(str(p) for p in out.glob("*.c")) if a.endswith("*.c") else [a])]
    r = subprocess.run(args, capture_output=True, text=True)
    if r.returncode != 0:  # (the compiler's or linker's first error, not collect2's summary of it)
        lines = r.stderr.strip().splitlines() or ["?"]
        said = next((ln for ln in lines if ("error" in ln or "overflowed" in ln) and "collect2" not in ln), lines[-1])
        raise ParameterError(f"--target = {target!r} is not allowed here: the build failed ({said.strip()[:200]})")
    size = subprocess.run(["arm-none-eabi-size", str(out / "haptex.elf")], capture_output=True, text=True)
    text, data, bss = (int(v) for v in size.stdout.splitlines()[1].split()[:3])
    click.echo(f"built {out / 'haptex.elf'} for {target} with the example main: flash {text + data} bytes "
               f"(text + data), static RAM {data + bss} bytes (data + bss; the stack comes on top)")
