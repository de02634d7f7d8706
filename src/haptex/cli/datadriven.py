"""``haptex fit`` and ``haptex vibration``: data-driven vibration models."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import click

from .._validation import ParameterError
from ._common import Quantity, _catalogued_device, _check_plot_path


@click.command("fit")
@click.argument("recording", type=click.Path(dir_okay=False, path_type=Path))
@click.option("-o", "--out", type=click.Path(dir_okay=False, path_type=Path), required=True,
              help="Model file to write: haptex's JSON, or HaTT's XML layout for a name ending .xml.")
@click.option("--sample-rate", type=Quantity("Hz"), default=None,
              help="The recording's rate, e.g. '10 kHz', when it has no time_s column, or where its "
                   "samples were taken at one rate and only their times scatter (a host's stamps).")
@click.option("--rate", type=Quantity("Hz"), default=None, show_default="the recording's",
              help="The models' rate: the renderer's servo rate, e.g. '1 kHz'.")
@click.option("--order", type=int, default=None, show_default="chosen by BIC", help="AR order p.")
@click.option("--ma-order", type=int, default=0, show_default=True, help="MA order q (0: AR models).")
@click.option("--segment", type=Quantity("s"), default=0.2, show_default="0.2 s",
              help="Windows in which speed and force are judged steady.")
@click.option("--highpass", type=Quantity("Hz"), default=20.0, show_default="20 Hz",
              help="Cut-off of the high-pass that removes the hand's motion.")
@click.option("--column", "columns", multiple=True, metavar="QUANTITY=COL[,COL...][:UNIT]",
              help="The recording's own columns for a quantity (acceleration, force, speed, position, time), "
                   "e.g. 'acceleration=az:g', 'position=x,y:mm' (the speed is then derived), 'time=t:ms'; a "
                   "board's step as the unit for raw counts, e.g. 'acceleration=az:0.001 g'; without a unit, the "
                   "one the file states (a units row, TDMS, LVM or HDF5 metadata), else SI. "
                   "Repeat for each; other columns are ignored and listed.")
@click.option("--speed", type=Quantity("m/s"), default=None,
              help="The tangential speed throughout, e.g. '40 mm/s', for a recording taken at one speed "
                   "with no speed or position column.")
@click.option("--force", type=Quantity("N"), default=None,
              help="The normal force throughout, e.g. '500 mN', for a recording taken at one force with no "
                   "force column.")
def fit_cmd(recording, out, sample_rate, rate, order, ma_order, segment, highpass, columns, speed, force):
    """Fit ARMA vibration models over (speed, force) to a recording (CSV, NPZ, HDF5, .mat, TDMS or
    LVM: haptex's columns time_s, acc_m_s2 or acc_x/y/z_m_s2, speed_m_s, force_n, or the rig's
    own with --column), and write them."""
    from ..datadriven import read_recording

    if not out.parent.is_dir():
        raise ParameterError(f"--out = '{out}' is not allowed: must be a file in an existing folder")
    rec = read_recording(recording, sample_rate=sample_rate, columns=columns, speed=speed, normal_force=force)
    if rec.ignored:
        click.echo(f"ignored columns: {', '.join(rec.ignored)}")
    if rec.speed_source != "given":
        click.echo(f"speed: {rec.speed_source}")
    models = rec.fit(rate=rate, order=order, ma_order=ma_order, segment=segment, highpass=highpass,
                     name=recording.stem)
    if out.suffix.lower() == ".xml":
        from ..datadriven import write_hatt

        write_hatt(models, out)
    else:
        models.write(out)
    r = models.report
    click.echo(f"{len(models.models)} ARMA{r.order} model{'s' * (len(models.models) != 1)} at {r.sample_rate:g} Hz "
               f"from {r.segments} steady windows "
               f"of {r.windows} (order: {r.criterion}); written to {out}")
    for note in r.notes:
        click.echo(f"note: {note}")


@click.command()
@click.argument("models", nargs=-1, required=True, type=click.Path(path_type=Path))
@click.option("--speed", type=Quantity("m/s"), default=None,
              help="Tangential speed, e.g. '50 mm/s' (default: half the set's largest).")
@click.option("--force", type=Quantity("N"), default=None,
              help="Normal force, e.g. '1 N' (default: half the set's largest).")
@click.option("--check", is_flag=True,
              help="Check each set: interpolated models stable at --points random operating points (their AR "
                   "roots), and 20 s of synthesis at the middle point against the model's rms.")
@click.option("--points", type=int, default=1000, show_default=True, help="With --check: operating points drawn.")
@click.option("--plot", type=click.Path(dir_okay=False, path_type=Path), default=None,
              help="Write the spectrum's figure (PNG or SVG).")
@click.option("--device", "device_spec", default=None,
              help="A preset of 'haptex devices' (or FILE.toml) to display the vibration on, as a force "
                   "(its mass x the acceleration, along x): the power it supplies at the port is reported.")
@click.option("--hand", default="light-touch", show_default=True,
              help="With --device: the hand holding the handle (none, light-touch, firm-grip).")
@click.option("--json", "as_json", is_flag=True, help="Print JSON instead of text.")
def vibration(models, speed, force, check, points, plot, device_spec, hand, as_json):
    """The vibration a model set gives at one speed and force: the interpolated model, its
    power and its spectrum (HaTT's XML or haptex's JSON); with --device, the energy it
    supplies at the device's port. Given several files or a folder (HaTT's library), one line
    each: material, models, triangles, speed and force range, rms at the operating point."""
    files = _model_files(models)
    if len(files) != 1 or models[0].is_dir() or check:
        # (--check reads each set on its own, one line each, as for a folder: no spectrum, no port)
        why = ("--check: run it without --check for one set's spectrum and power" if check and len(files) == 1
               and not models[0].is_dir() else f"{len(files)} model files: give one file")
        for name, given in (("--plot", plot), ("--device", device_spec)):
            if given is not None:
                raise ParameterError(f"{name} is not allowed with {why}")
        _library(files, speed, force, check, points, as_json)
        return
    models = files[0]
    if speed is None or force is None:
        from ..datadriven import read_models

        s = read_models(models)
        speed = float(s.speeds.max()) / 2 if speed is None else speed
        force = float(s.forces.max()) / 2 if force is None else force
    import numpy as np

    from ..catalogue import hand as _hand
    from ..datadriven import port_energy, read_models

    if plot is not None:
        _check_plot_path(plot)
    grip = _hand(hand)
    dev = None
    if device_spec is not None:
        dev = _catalogued_device(device_spec, 2)
        if dev is None:
            from ..catalogue import did_you_mean, presets

            raise ParameterError(f"--device = {device_spec!r} is not allowed: must be a preset of 'haptex devices' "
                                 f"({', '.join(presets())}) or a device file FILE.toml" + did_you_mean(device_spec))
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


def _model_files(paths) -> list[Path]:
    out = []
    for p in paths:
        if p.is_dir():
            found = sorted(q for q in p.iterdir() if q.suffix.lower() in (".xml", ".json") and q.is_file())
            if not found:
                raise ParameterError(f"MODELS = '{p}' is not allowed: must be a model file or a folder holding "
                                     "model files (*.xml: HaTT's; *.json: haptex's)")
            out += found
        elif p.is_file():
            out.append(p)
        else:
            raise ParameterError(f"MODELS = '{p}' is not allowed: must be an existing model file or folder")
    return out


def _library(files, speed, force, check, points, as_json) -> None:
    """One line a model set; a refused file is one line too, and the exit status is then 2."""
    import time

    from ..datadriven import check_models, read_models

    if check and not 1 <= points <= 10**6:
        raise ParameterError(f"--points = {points} is not allowed: must be an integer in [1, 1000000]")
    rows, refused = [], 0
    t0 = time.perf_counter()
    for f in files:
        try:
            s = read_models(f)
        except ParameterError as exc:
            refused += 1
            rows.append({"file": str(f), "error": str(exc)})
            if not as_json:
                click.echo(f"{f.name}: refused: {exc}")
            continue
        v = float(s.speeds.max()) / 2 if speed is None else speed
        fo = float(s.forces.max()) / 2 if force is None else force
        rms = math.sqrt(s.model_at(v, fo).output_variance())
        row = {"file": str(f), "material": s.name, "models": len(s.models), "triangles": len(s.triangles),
               "order": list(s.models[0].order), "sample_rate": s.sample_rate,
               "speed_range": [float(s.speeds.min()), float(s.speeds.max())],
               "force_range": [float(s.forces.min()), float(s.forces.max())], "mu": s.mu,
               "at": [v, fo], "rms_acceleration": rms}
        line = (f"{s.name}: {len(s.models)} models, {len(s.triangles)} triangles, ARMA{s.models[0].order} at "
                f"{s.sample_rate:g} Hz, {s.speeds.min() * 1e3:.0f}-{s.speeds.max() * 1e3:.0f} mm/s, "
                f"{s.forces.min():.2g}-{s.forces.max():.3g} N" + ("" if s.mu is None else f", mu {s.mu:.3g}")
                + f"; {rms:.3g} m/s^2 rms at {v * 1e3:.0f} mm/s, {fo:.3g} N")
        if check:
            c = check_models(s, points=points)
            row["check"] = {"points": c.points, "unstable": c.unstable, "max_root": c.max_root,
                            "rms_model": c.rms_model, "rms_synthesis": c.rms_synthesis, "seconds": c.seconds}
            line += (f"; {c.points - c.unstable} of {c.points} points stable (largest AR root {c.max_root:.4f}); "
                     f"{c.seconds:g} s of synthesis at the middle {100 * c.rms_error:+.1f} % of the model's rms")
            refused += c.unstable > 0
        rows.append(row)
        if not as_json:
            click.echo(line)
    took = time.perf_counter() - t0
    if as_json:
        click.echo(json.dumps({"sets": rows, "refused": refused, "seconds": took,
                               "units": {"speed_range": "m/s", "force_range": "N", "at": "m/s, N",
                                         "rms_acceleration": "m/s^2", "sample_rate": "Hz"}}, indent=2))
    else:
        click.echo(f"{len(files) - refused} of {len(files)} model files read"
                   + (" and checked" if check else "") + f" in {took:.1f} s")
    if refused:
        raise click.exceptions.Exit(2)
