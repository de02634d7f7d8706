"""Issues 33 and 35: the cost of an analysis is planned before it runs, from the analyses'
own plans (counted work, not timed)."""

import json

import numpy as np
import pytest

import haptex as hx
from haptex.analysis import characteristic
from haptex.analysis.characteristic import characteristic_number, characteristic_points
from haptex.analysis.continuity import continuity, continuity_points
from haptex.cli import main
from haptex.explore import model

SINE = hx.Sinusoid(0.8e-3, 1e-3)
EGG = hx.SumOfGratings.egg_crate(0.3e-3, 2e-3)


def _counting(monkeypatch, module, name):
    sizes = []
    real = getattr(module, name)

    def counted(alg, p, *a, **k):
        sizes.append(int(np.prod(np.shape(p)[:-1])))
        return real(alg, p, *a, **k)
    monkeypatch.setattr(module, name, counted)
    return sizes


@pytest.mark.parametrize("letter, texture", [("A", SINE), ("D", SINE), ("A", EGG), ("D", EGG), ("F", EGG)])
def test_continuity_plan_counts_the_points_it_evaluates(monkeypatch, letter, texture):
    import sys

    mod = sys.modules["haptex.analysis.continuity"]
    alg = hx.algorithm(letter, texture, 2000.0)
    plan = continuity_points(alg, 1e-3)
    sizes = _counting(monkeypatch, mod, "_static_force")
    continuity(alg, 1e-3)
    assert sizes == plan


@pytest.mark.parametrize("letter, texture", [("A", SINE), ("G", SINE), ("A", EGG), ("C", EGG)])
def test_q_plan_counts_its_first_grid(monkeypatch, letter, texture):
    alg = hx.algorithm(letter, texture, 2000.0)
    plan = characteristic_points(alg, 1e-3)
    sizes = []
    real = type(alg).jacobian

    def counted(self, p, *a, **k):
        sizes.append(int(np.prod(np.shape(p)[:-1])))
        return real(self, p, *a, **k)
    monkeypatch.setattr(type(alg), "jacobian", counted)
    characteristic_number(alg, 1e-3)
    assert sizes[0] == plan  # the grid; then the refinement's single points
    assert max(sizes[1:], default=1) == 1


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
    alg = hx.algorithm("D", hx.Sinusoid(0.2e-3, 2e-3), 2000.0)
    # D's searches are counted once (E reads them), and they are D's plan
    assert est["searches"] == sum(continuity_points(alg, 1e-3)) + characteristic_points(alg, 1e-3)
    assert est["algorithms"]["E"]["seconds"] == 0.0
    assert set(est["algorithms"]) == set("WABCDEFG")


@pytest.mark.parametrize("letter, texture", [("A", SINE), ("D", SINE), ("D", EGG), ("F", EGG)])
def test_continuity_reads_the_coarser_grids_points_bit_for_bit(monkeypatch, letter, texture):
    # each finer grid evaluates only its new points and reads the others from the grid before
    # (a halved step from the same corner lands on them exactly): the differences it reports
    # equal those of every grid evaluated in full (the former code), to the last bit
    import sys

    mod = sys.modules["haptex.analysis.continuity"]
    alg = hx.algorithm(letter, texture, 2000.0)
    fast = continuity(alg, 1e-3)
    monkeypatch.setattr(mod, "_refined_forces", lambda a, axes, coarse: mod._static_force(
        a, np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1)))
    full = continuity(alg, 1e-3)
    assert fast.max_differences == full.max_differences and fast.where == full.where
    assert fast.continuous == full.continuous
