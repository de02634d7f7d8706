"""``haptex sweep`` and ``haptex atlas``: stability atlases on Dask into Zarr, and their plots."""

from __future__ import annotations

from pathlib import Path

import click

from .._specs import quantity as _q
from .._validation import ParameterError
from ._common import _check_plot_path


@click.command()
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

    from ..atlas import SweepSpec
    from ..atlas import sweep as run_sweep

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


@click.group()
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
    from ..atlas import open_atlas
    from ..plotting import plot_atlas
    from ..simulate import SWEEP_UNITS

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
