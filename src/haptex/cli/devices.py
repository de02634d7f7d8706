"""``haptex devices``: the presets, their sources and wall limits."""

from __future__ import annotations

import json

import click

from ._common import Quantity, _fitted, _jsonable, _limits_table


@click.group(invoke_without_command=True)
@click.option("--wide", is_flag=True, help="Also each product's name, in a second table.")
@click.pass_context
def devices(ctx, wide):
    """The device presets, with their sources and wall limits ('haptex devices show NAME')."""
    if ctx.invoked_subcommand is not None:
        return
    from rich import box
    from rich.console import Console
    from rich.table import Table

    from ..catalogue import DEFAULT_HAND, presets
    from ..limits import wall_limits

    t = Table(title="device presets", box=box.SIMPLE_HEAD,
              caption=f"passive: Colgate & Schenkel or Abbott & Okamura; encoder: 2 f_c / delta, what the encoder step "
                      f"and the friction allow (Abbott & Okamura); stable: closed loop with the hand {DEFAULT_HAND!r}; "
                      "rated: the manufacturer's (or CHAI3D's) figure, reported only; its grip: the hand damping at "
                      f"which the rated figure is the exact limit (the hand {DEFAULT_HAND!r}'s mass and stiffness). "
                      "'haptex devices show NAME' for every number and its source; --wide adds each product's "
                      "name below. Every preset is 3-D but the one marked 2D.")
    columns = ("name", "rate (Hz)", "max force (N)", "passive (N/m)", "encoder (N/m)", "stable (N/m)",
               "rated (N/m)", "its grip (N s/m)")
    for col in columns:
        t.add_column(col)
    for key, p in presets().items():
        dev = p.device()
        w = wall_limits(dev, DEFAULT_HAND, preset=p)
        enc = next((lim.value for lim in w.limits if lim.key == "encoder"), None)
        grip = w.rated_hand_damping
        t.add_row(f"{key} ({p.dimension}D)" if p.dimension != 3 else key, f"{1 / dev.period:g}", f"{dev.max_force:g}", f"{w.passive:.0f}",
                  "-" if enc is None else f"{enc:.0f}", f"{w.stable:.0f}",
                  "-" if p.rated_stiffness is None else f"{p.rated_stiffness:.0f}",
                  "-" if grip is None else f"{grip:.2g}")
    Console().print(_fitted(t))
    if wide:
        names = Table(title="the products", box=box.SIMPLE_HEAD)
        for col in ("name", "device"):
            names.add_column(col)
        for key, p in presets().items():
            names.add_row(key, p.label)
        Console().print(_fitted(names))


@devices.command("show")
@click.argument("name")
@click.option("--hand", default="light-touch", show_default=True, help="none, light-touch or firm-grip.")
@click.option("--delay", type=int, default=0, show_default=True, help="Whole samples of computation delay.")
@click.option("--virtual-damping", type=Quantity("N*s/m"), default=0.0, show_default="0 N*s/m",
              help="The wall's damper B_v.")
@click.option("--json", "as_json", is_flag=True)
def devices_show(name, hand, delay, virtual_damping, as_json):
    """One preset: every number with its status and source, and the wall limits side by side."""
    from ..catalogue import hand as _hand, preset
    from ..limits import wall_limits

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

    from ..catalogue import sources

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
