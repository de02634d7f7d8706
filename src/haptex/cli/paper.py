"""``haptex table`` and ``haptex reproduce``: the paper's Table II and every result of it."""

from __future__ import annotations

import json
import math
from pathlib import Path

import click

from ._common import _Spinner, _Steps, _fitted, _jsonable, _paper_options


@click.command()
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


@click.command()
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

    from .. import report

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


def _table(stiffness, amplitude, period, max_penetration, friction, presliding, progress=None, surface=None):
    from ..tables import table_ii

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
