"""Issues 33 and 35: the cost of an analysis is planned before it runs, from the analyses'
own plans (counted work, not timed)."""

import json

import numpy as np
import pytest

import haptex as hx
from haptex.analysis import characteristic
from haptex.analysis.characteristic import REGION_FIRST, characteristic_number, characteristic_points
from haptex.analysis.continuity import continuity, continuity_points
from haptex.cli import main
from haptex.explore import model

from .conftest import counting

SINE = hx.Sinusoid(0.8e-3, 1e-3)
EGG = hx.SumOfGratings.egg_crate(0.3e-3, 2e-3)


@pytest.mark.parametrize("letter, texture", [("A", SINE), ("D", SINE), ("A", EGG), ("D", EGG), ("F", EGG)])
def test_continuity_plan_counts_the_points_it_evaluates(monkeypatch, letter, texture):
    import sys

    mod = sys.modules["haptex.analysis.continuity"]
    monkeypatch.setattr(mod, "SLAB_POINTS", 1 << 40)  # one slab a grid: one evaluation a grid
    alg = hx.algorithm(letter, texture, 2000.0)
    plan = continuity_points(alg, 1e-3)
    sizes = counting(monkeypatch, mod, "_static_force")
    continuity(alg, 1e-3)
    assert sizes == plan


@pytest.mark.parametrize("letter, texture", [("A", SINE), ("G", SINE), ("A", EGG), ("C", EGG)])
def test_q_plan_counts_its_first_grid(monkeypatch, letter, texture):
    alg = hx.algorithm(letter, texture, 2000.0)
    plan = characteristic_points(alg, 1e-3)
    sizes = counting(monkeypatch, type(alg), "jacobian")
    characteristic_number(alg, 1e-3)
    assert sizes[0] == plan  # the grid; then the refinement's points: one, or a finite-difference
    # gradient's shifted points in one call (one a variable: the plane's and the depth)
    assert max(sizes[1:], default=1) <= texture.dimension + 1


def test_explorer_refuses_a_view_planned_past_its_budget_before_computing_it(monkeypatch):
    # the plan is made before anything runs: a budget below it refuses with one line naming
    # the algorithm and what to change, and q is never computed
    st = model.Settings()
    st.algorithm = "D"
    scene = model.build(st)
    seconds, n = model.view_cost(scene)
    assert n > 10_000 and seconds > 0
    monkeypatch.setattr(model, "MAX_VIEW_SECONDS", seconds / 100)
    called = []
    monkeypatch.setattr(characteristic, "characteristic_number", lambda *a, **k: called.append(1))
    with pytest.raises(hx.ParameterError, match="algorithm = 'D' .* not allowed"):
        model.views(scene)
    assert not called


def test_the_plans_time_is_the_works_not_the_machines_wait(monkeypatch):
    # The calibration is timed by the calling thread's CPU clock: a wait inside each chunk (here
    # 5 ms of sleep, as a niced process waits for the CPU beside busy ones) adds nothing. By the
    # wall clock it would add 5 ms / 64 probes = 78 us to each evaluation of A, whose own cost
    # is a few us (A's field is one NumPy expression); CI refused the explorer's view of D on the
    # default noise (planned 8.6 s idle) when the wall clock timed it past the 60 s budget.
    import time

    from haptex.analysis import cost

    alg = hx.algorithm("A", SINE, 2000.0)
    real = cost._static_force

    def waiting(a, p, *args, **kw):
        time.sleep(0.005)
        return real(a, p, *args, **kw)
    monkeypatch.setattr(cost, "_static_force", waiting)
    each = cost.evaluation_time(alg, 1e-3)
    assert 0 < each < 20e-6


def test_design_reports_its_plan_with_units(capsys):
    assert main(["design", "--texture", "sine:0.2mm,2mm", "--json", "--quiet"]) == 0
    est = json.loads(capsys.readouterr().out)["estimate"]
    assert est["units"] == {"seconds": "s", "peak_bytes": "B", "seconds_per_search": "s"}
    d, e = (hx.algorithm(L, hx.Sinusoid(0.2e-3, 2e-3), 2000.0) for L in "DE")
    # the continuity grids' searches are counted once (E reads D's), and q's are each one's
    # region's first batch (its grid's Jacobians at the feet need no search)
    first = [min(characteristic_points(a, 1e-3), REGION_FIRST) for a in (d, e)]
    assert est["searches"] == sum(continuity_points(d, 1e-3)) + sum(first)
    assert est["algorithms"]["E"]["evaluations"] == first[1] and est["algorithms"]["E"]["seconds"] > 0
    assert set(est["algorithms"]) == set("WABCDEFG")


def test_design_within_its_time_budget_leaves_out_the_costliest_and_says_so(capsys):
    # issue 67: design plans within a time budget (default 120 s of one core): beyond it the
    # costliest algorithms are left out one by one, each named with its planned time, and the
    # remedy named (a larger --time-budget) analyses them; with --algorithms given, a plan over
    # the budget is refused, naming the budget. The plan is design's own (haptex.analysis.cost);
    # the test holds the policy against it: what is left out is the costliest of the plan, the
    # rest fits
    from haptex.design import TIME_BUDGET, design

    assert TIME_BUDGET == 120.0
    tex, dev = hx.Sinusoid(0.2e-3, 2e-3), hx.Device.pantograph()

    class Planned(Exception):
        pass

    plan = {}

    def stop(est):
        plan.update(est)
        raise Planned

    with pytest.raises(Planned):
        design(tex, dev, 500.0, on_estimate=stop, time_budget=None)
    per = {L: v["seconds"] for L, v in plan["algorithms"].items()}
    costliest = max(per, key=per.get)
    budget = 0.9 * (plan["seconds"] - per[costliest]) + 0.1 * plan["seconds"]  # between the plan without it and with it
    assert main(["design", "--texture", "sine:0.2mm,2mm", "--stiffness", "500 N/m", "--time-budget", f"{budget}s",
                 "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    left = out["estimate"]["left_out"]
    assert costliest in left and left[costliest] > 0 and out["estimate"]["time_budget"] == pytest.approx(budget)
    assert {r["algorithm"] for r in out["rows"]} == set(per) - set(left)
    assert out["estimate"]["seconds"] <= budget and "--time-budget" in out["recommendation"]
    assert main(["design", "--texture", "sine:0.2mm,2mm", "--stiffness", "500 N/m", "--time-budget", f"{budget}s",
                 "--algorithms", ",".join(per), "--quiet"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "time_budget = " in err and "--time-budget" in err
    with pytest.raises(hx.ParameterError, match="time_budget = -1 is not allowed"):
        design(tex, dev, 500.0, time_budget=-1)


@pytest.mark.parametrize("letter, texture", [("A", SINE), ("D", SINE), pytest.param("D", EGG, marks=pytest.mark.long),
                                             ("F", EGG)])  # (D over the egg-crate, 3 s: .ci/run's long set)
def test_continuity_reads_the_coarser_grids_points_bit_for_bit(monkeypatch, letter, texture):
    # each finer grid evaluates only its new points and reads the others from the grid before
    # (a halved step from the same corner lands on them exactly), in slabs along x with only the
    # forces the next grid reads held (issue 58: a 1025 x 1025 map's grid needed 7.4 GB held
    # whole): the differences it reports, and where, equal those of every grid evaluated in full
    # and at once (the former code), to the last bit, whatever the slab (one row to the grid)
    import sys

    mod = sys.modules["haptex.analysis.continuity"]
    alg = hx.algorithm(letter, texture, 2000.0)
    fast = continuity(alg, 1e-3)

    def whole(a, axes, coarse, keep=True):
        F = mod._static_force(a, np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1))
        jumps = [np.linalg.norm(np.diff(F, axis=k), axis=-1) for k in range(len(axes))]
        k = int(np.argmax([float(d.max()) for d in jumps]))
        idx = np.unravel_index(int(np.argmax(jumps[k])), jumps[k].shape)
        return F, (k, float(jumps[k].max()), tuple(int(i) for i in idx))

    for slab in (1, 700):  # a row or less a slab; a few rows
        monkeypatch.setattr(mod, "SLAB_POINTS", slab)
        sliced = continuity(alg, 1e-3)
        assert sliced.max_differences == fast.max_differences and sliced.where == fast.where
    monkeypatch.setattr(mod, "_refined_forces", whole)
    full = continuity(alg, 1e-3)
    assert fast.max_differences == full.max_differences and fast.where == full.where
    assert fast.continuous == full.continuous


@pytest.mark.parametrize("letter", ["A", "D"])
def test_continuity_holds_only_the_forces_the_next_grid_reads(monkeypatch, letter):
    # Issue 58: "a map of a megabyte must not need gigabytes": a 1025 x 1025 map's finest grid
    # held whole took 7.4 GB (RSS). Now the last grid is streamed in slabs and a grid's forces
    # are held only for the next: the traced peak of the analysis stays within its plan
    # (peak_bytes, which the memory budget checks), and for A the plan is under 0.6 of what
    # the former whole-grid count took. A budget below the plan is refused by name, before any
    # work (the same plan, checked grid by grid).
    import tracemalloc

    from haptex._validation import ParameterError
    from haptex.analysis.continuity import grid_points, peak_bytes

    alg = hx.algorithm(letter, EGG, 2000.0)
    sizes = grid_points(alg, 1e-3)
    plan = peak_bytes(sizes)
    if letter == "A":
        assert plan < 0.6 * 12 * 8 * sizes[-1]
    continuity(alg, 1e-3)  # warm: what the texture caches once
    tracemalloc.start()
    try:
        continuity(alg, 1e-3)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak <= plan, (peak, plan)
    monkeypatch.setenv("HAPTEX_MEMORY_BUDGET", str(int(0.9 * plan)))
    with pytest.raises(ParameterError, match=r"^levels = 3 is not allowed: the .* grid of level 2 \(its forces "
                                             r"streamed"):
        continuity(alg, 1e-3)
