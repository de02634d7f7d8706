"""Issue 34 (first part): the backend protocol, the simulated backend, the servo loop's safety
rules and `haptex run`. The rules (haptex.servo's docstring) are the issue's: forces never
NaN, never above the maximum, zero within one tick of any fault and on every exit; no kick
at start-up; a watchdog on missed deadlines."""

import json
import time

import numpy as np
import pytest

import haptex as hx
from haptex.backends import DeviceBackend, Sample, open_backend
from haptex.backends.simulated import SimulatedBackend
from haptex.cli import main
from haptex.servo import ServoLoop

SINE = hx.Sinusoid(0.2e-3, 2e-3)


class Scripted:
    """A simulated backend with faults injected at chosen ticks; records every command."""

    def __init__(self, inner, nan_at=(), far_at=(), late_at=(), interrupt_at=None, command_fails_at=None):
        self.inner = inner
        self.name, self.dimension, self.period = inner.name, inner.dimension, inner.period
        self.max_force, self.workspace, self.realtime = inner.max_force, inner.workspace, inner.realtime
        self.nan_at, self.far_at, self.late_at = set(nan_at), set(far_at), set(late_at)
        self.interrupt_at, self.command_fails_at = interrupt_at, command_fails_at
        self.commands, self.closed, self.k = [], False, 0

    def open(self):
        self.inner.open()

    def close(self):
        self.closed = True
        self.inner.close()

    def sample(self):
        if self.k == self.interrupt_at:
            raise KeyboardInterrupt
        if self.k in self.late_at:
            time.sleep(5 * self.period)
        s = self.inner.sample()
        p = s.position.copy()
        if self.k in self.nan_at:
            p[0] = np.nan
        if self.k in self.far_at:
            p[-1] = 10.0
        return Sample(s.time, p, s.velocity, 0)

    def command(self, force):
        self.commands.append(np.array(force, dtype=float))
        if self.k == self.command_fails_at:
            self.k += 1
            raise OSError("the device went away")
        self.inner.command(force)
        self.k += 1


def _loop(backend, stiffness=2000.0, letter="A", **kw):
    tex = hx.Extruded(SINE) if backend.dimension == 3 else SINE
    r = hx.Renderer(hx.algorithm(letter, tex, stiffness), max_force=backend.max_force, energy_monitor=True)
    return ServoLoop(backend, r, **kw)


def test_the_simulated_backend_is_a_device_backend():
    b = open_backend("simulated:falcon", realtime=False)
    assert isinstance(b, DeviceBackend) and isinstance(b, SimulatedBackend)
    assert (b.dimension, b.period, b.max_force) == (3, 1e-3, 8.9)  # the preset's published figures
    b.open()
    s = b.sample()
    assert s.position.shape == (3,) and s.position[-1] == pytest.approx(5e-3, abs=b.device.position_resolution)
    # a held force accelerates the free handle as its mass says: dz = f T^2 / (2 m) from rest
    # (the hand's pull over one tick is second order in T: below 2 % here)
    b.command(np.array([0.0, 0.0, 0.0]))
    z0 = b.state[2]
    b2 = open_backend("simulated:falcon", realtime=False)
    b2.open()
    b2.sample()
    b2.command(np.array([0.0, 0.0, 1.0]))
    m = b.device.mass[2, 2]
    assert b2.state[2] - z0 == pytest.approx(1.0 * b.period ** 2 / (2 * m), rel=0.02)


def test_forces_are_finite_bounded_and_zero_on_every_fault():
    inner = SimulatedBackend("falcon", realtime=False)
    faults = {300, 301, 650}
    b = Scripted(inner, nan_at={300, 301}, far_at={650})
    stats, trace = _loop(b, ramp_ticks=20).run(1.0)
    f = np.array(b.commands)
    assert np.all(np.isfinite(f))
    assert np.all(np.linalg.norm(f, axis=1) <= b.max_force * (1 + 1e-12))
    for k in faults:  # the faulty tick itself commands zero
        assert np.all(f[k] == 0.0), k
    assert stats.faults == 3
    assert np.all(f[-1] == 0.0) and b.closed  # and the run ends on zero force


def test_no_kick_when_the_handle_starts_inside_the_wall():
    # the handle starts 3 mm inside a 2 kN/m wall and the hand presses it 5 mm in: the computed
    # force (6-10 N) never falls below the engagement threshold, so nothing is ever sent; a
    # handle that starts above the wall engages at once, then ramps
    inner = SimulatedBackend("omega-3", press=5e-3, start=-3e-3, realtime=False)
    b = Scripted(inner)
    stats, _ = _loop(b, stiffness=2000.0).run(1.0)
    assert stats.engaged_at is None and np.all(np.array(b.commands) == 0.0)
    b = Scripted(SimulatedBackend("omega-3", press=1e-4, realtime=False))
    loop = _loop(b, stiffness=500.0, ramp_ticks=400)
    stats, trace = loop.run(2.0)
    k0 = stats.engaged_at
    assert k0 is not None and np.all(trace["force"][:k0] == 0.0)
    sent = np.linalg.norm(trace["force"], axis=1)
    ramp = np.minimum(1.0, (np.arange(len(sent)) - k0 + 1) / 400)
    assert np.all(sent[k0:] <= ramp[k0:] * b.max_force + 1e-12)
    assert sent.max() > 0


def test_the_watchdog_zeroes_a_late_tick():
    b = Scripted(SimulatedBackend("touch", realtime=True), late_at={400})
    stats, _ = _loop(b, stiffness=300.0).run(0.6)
    assert stats.missed >= 1
    assert np.all(b.commands[400] == 0.0)


def test_zero_force_on_ctrl_c_and_on_a_failing_device():
    b = Scripted(SimulatedBackend("touch", realtime=False), interrupt_at=250)
    stats, trace = _loop(b).run(1.0)
    assert stats.interrupted and b.closed and np.all(b.commands[-1] == 0.0) and len(trace["time"]) == 250
    b = Scripted(SimulatedBackend("touch", realtime=False), command_fails_at=120)
    with pytest.raises(OSError):
        _loop(b).run(1.0)
    assert b.closed and np.all(b.commands[-1] == 0.0)


def test_haptex_run_on_the_simulated_falcon(tmp_path, capsys):
    rec = tmp_path / "trace.npz"
    assert main(["run", "--device", "simulated:falcon", "--duration", "1s", "--fast", "--json",
                 "--record", str(rec)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["ticks"] == 1000 and out["faults"] == 0 and out["max_force_sent"] <= 8.9
    assert out["units"]["energy_observed"] == "J"
    data = np.load(rec)
    assert data["position"].shape == (1000, 3) and data["force"].shape == (1000, 3)
    assert np.all(np.isfinite(data["force"]))
    for spec, what in (("haply-serial:/no/such/ttyACM0", "no such port"), ("haply:ws://127.0.0.1:1", "not reachable"),
                       ("haply:http://x", "Inverse Service's address"), ("simulated:phantom", "one of"),
                       ("usb:0", "simulated:PRESET")):
        assert main(["run", "--device", spec, "--duration", "0.1s"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and what in err, err
    # options a device does not take are refused by name
    assert main(["run", "--device", "haply:ws://127.0.0.1:1", "--fast"]) == 2
    assert "--fast is not allowed with --device haply" in capsys.readouterr().err
    assert main(["run", "--device", "openhaptics", "--hand", "firm-grip"]) == 2
    assert "--hand is not allowed with --device openhaptics" in capsys.readouterr().err
    for spec in ("openhaptics", "haply:ws://127.0.0.1:1"):  # no thread of the C core's to keep awake there
        assert main(["run", "--device", spec, "--keep-awake"]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and f"--keep-awake is not allowed with --device {spec}" in err, err
    assert main(["run", "--device", "simulated:falcon", "--find-limit", "--keep-awake"]) == 2
    assert "--keep-awake is not allowed with --find-limit" in capsys.readouterr().err


def test_a_trace_is_judged_as_a_simulated_run():
    # W on the simulated pantograph held by the light-touch hand: its closed-loop limit is
    # 38 kN/m (haptex.wall_limits); the loop's trace, analysed by the simulator's own verdict,
    # decays at 0.45 and 0.55 of it and is unstable from 1.7 to 3 times it. (At 1.5 the
    # encoder, 10 um, reads the motion over three levels only: rebuilt from its transitions it
    # is 5 um, under the verdict's rest threshold of 3/4 of a step; issue 55. The raw reading,
    # 1 step against a threshold of 1 step, was a knife-edge.)
    from haptex.servo import analyse_trace
    from haptex.simulate import UNSTABLE

    limit = hx.wall_limits(hx.catalogue.preset("pantograph").device(), "light-touch")["hand"].value
    for factor, unstable in ((0.45, False), (0.55, False), (1.7, True), (2.0, True), (3.0, True)):
        b = SimulatedBackend("pantograph", realtime=False)
        r = hx.Renderer(hx.algorithm("W", None, factor * limit), energy_monitor=True)
        stats, trace = ServoLoop(b, r).run(2.0)
        v = analyse_trace(trace, b.period, b.device.position_resolution)
        assert (v["regime"] in UNSTABLE) is unstable, (factor, v["regime"])
        assert v["energy"].shape == (2,) and np.all(np.isfinite(v["energy"]))


def test_haptex_run_renders_a_texture_on_an_object(tmp_path, capsys):
    # issue 32: the egg-crate on a sphere of 40 periods round, its top at the origin, on the
    # simulated Falcon pressed 1 mm in by the light-touch hand: the Renderer's C tick over the
    # object, the same rules; the forces sent push out (+z at the top) and stay under the maximum
    rec = tmp_path / "trace.npz"
    assert main(["run", "--device", "simulated:falcon", "--texture", "egg-crate:0.2mm,2mm", "--object",
                 "sphere:12.7323954mm", "--duration", "1s", "--fast", "--json", "--record", str(rec)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["object"].startswith("Sphere(") and out["ticks"] == 1000 and out["faults"] == 0
    data = np.load(rec)
    f, k0 = data["force"], int(round(out["engaged_at"] / 1e-3))
    assert np.all(np.isfinite(f)) and f[k0:, 2].mean() > 0.0 and out["max_force_sent"] <= 8.9
    assert main(["run", "--device", "simulated:pantograph", "--object", "sphere:12.7323954mm", "--duration",
                 "0.1s"]) == 2
    assert "3-DOF" in capsys.readouterr().err


def test_haptex_run_renders_the_god_object(capsys):
    # issue 32: --algorithm proxy runs the god-object's C tick (haptex.proxy.GodObject) on the
    # simulated Falcon under the same rules: the hand pressed 1 mm in, forces pushing out
    assert main(["run", "--device", "simulated:falcon", "--algorithm", "proxy", "--duration", "1s", "--fast",
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["algorithm"] == "PROXY" and out["ticks"] == 1000 and out["faults"] == 0
    assert 0.0 < out["max_force_sent"] <= 8.9 and out["engaged_at"] is not None
    # over a sphere the proxy's tick is the C core's too (Gauss-Newton on its closed form)
    assert main(["run", "--device", "simulated:falcon", "--algorithm", "proxy", "--object", "sphere:12.7323954mm",
                 "--duration", "0.3s", "--fast", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["object"].startswith("Sphere") and out["faults"] == 0 and 0.0 < out["max_force_sent"] <= 8.9


def test_haptex_run_renders_the_proxy_over_a_mesh(tmp_path, capsys):
    # over a mesh the proxy's tick is the C core's too (Gauss-Newton through the UV map): the
    # hand pressed in on the 80-facet ball, no fault, the forces within the Falcon's 8.9 N
    from .test_objects import _ball_obj

    path, scale = _ball_obj(tmp_path, subdivisions=1)
    assert main(["run", "--device", "simulated:falcon", "--algorithm", "proxy", "--object", str(path),
                 "--uv-scale", f"{scale} m", "--duration", "0.3s", "--fast", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["object"].startswith("Mesh") and out["faults"] == 0 and 0.0 < out["max_force_sent"] <= 8.9




def test_no_blas_worker_is_woken_by_a_runs_set_up(monkeypatch, capsys):
    # a BLAS call with OpenBLAS's workers on wakes them, and they spin for 0.1 s on the other core
    # (measured after making a simulated backend, and a D, E or F renderer over the egg-crate:
    # a surface's slope bound by L-BFGS-B), beside a servo loop about to start. `haptex run` holds
    # BLAS to one thread through its set-up and loop; a surface's slope bound holds it wherever it
    # is made. Checked with BLAS set to two threads, every L-BFGS-B solve and the renderer's
    # construction recording the threads BLAS had.
    import scipy.optimize
    from threadpoolctl import threadpool_info, threadpool_limits

    import haptex.renderer

    def blas():
        return max(i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas")

    seen = []
    minimize, init = scipy.optimize.minimize, haptex.renderer.Renderer.__init__

    def recording(*a, **k):
        seen.append(("minimize", blas()))
        return minimize(*a, **k)

    def made(self, *a, **k):
        seen.append(("renderer", blas()))
        return init(self, *a, **k)

    monkeypatch.setattr(scipy.optimize, "minimize", recording)
    monkeypatch.setattr(haptex.renderer.Renderer, "__init__", made)
    with threadpool_limits(limits=2, user_api="blas"):
        assert blas() == 2
        hx.algorithm("F", hx.SumOfGratings.egg_crate(0.2e-3, 2e-3), 2000.0, friction=0.5, presliding=1e-4)
        assert main(["run", "--device", "simulated:falcon", "--texture", "egg-crate:0.3mm,3mm", "--algorithm", "D",
                     "--duration", "0.05s", "--fast", "--json"]) == 0
        assert blas() == 2  # (lifted again afterwards)
    capsys.readouterr()
    kinds = {k for k, _ in seen}
    assert kinds == {"minimize", "renderer"} and {n for _, n in seen} == {1}, seen


def test_d_and_e_in_haptex_run_search_within_half_the_devices_period(monkeypatch, capsys):
    # D's closest-point search over a measured map spent up to the default 5,000 texture
    # evaluations a tick (renderer.MAX_EVALUATIONS), 2.35 ms a tick on this project's machine
    # over x3p-2.x3p 0.1 mm deep (0.47 us an evaluation): on the Falcon's 1 ms period, haptex
    # run missed 577 deadlines of 1,000. Now its budget is what half the period holds at the
    # cost of an evaluation measured before the run (haptex.servo.evaluation_seconds): with
    # that cost set to 1 us (a bound on counted work, not a timing), the Falcon's 1 ms holds
    # 500, the run's largest tick is at most 500 + 250 evaluations (the renderer's stated
    # bound: the budget plus the search's last cell) and the ticks it cut are counted
    from haptex import servo

    from .conftest import DATA

    if not (DATA / "mi-1.mi").exists():
        pytest.skip("../shared/data is not beside this checkout")
    monkeypatch.setattr(servo, "evaluation_seconds", lambda renderer, depth: 1e-6)
    assert main(["run", "--device", "simulated:falcon", "--texture", str(DATA / "mi-1.mi"), "--algorithm", "D",
                 "--duration", "0.3s", "--fast", "--json", "--quiet"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["search_budget"] == 500 and out["search_evaluation_seconds"] == 1e-6
    assert 0 < out["search_max_work"] <= 750 and out["search_cut"] > 0, out
    # given by hand: taken as given (within the renderer's [100, 10^9]); refused outside it
    assert main(["run", "--device", "simulated:falcon", "--texture", str(DATA / "mi-1.mi"), "--algorithm", "D",
                 "--duration", "0.1s", "--fast", "--json", "--quiet", "--max-evaluations", "200"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["search_budget"] == 200 and out["search_max_work"] <= 450
    assert main(["run", "--device", "simulated:falcon", "--algorithm", "D", "--max-evaluations", "50",
                 "--duration", "0.1s", "--fast", "--quiet"]) == 2
    assert "--max-evaluations 50 is not allowed" in capsys.readouterr().err
    # over a profile extruded across y the tick searches the profile's tree (tick_model gives it the
    # cell table, no budget): the run stated "at most 711 evaluations a tick (measured ...)", a
    # budget nothing applied; now it states none, and one given by hand is refused
    from haptex.core import _ext
    from haptex.renderer import tick_model

    extruded = hx.algorithm("D", hx.Extruded(hx.Sinusoid(1e-4, 2e-3)), 1e3)
    assert tick_model(extruded, 500)[4][_ext.G_BUDGET] != 500.0  # (the tree's data: no budget written)
    assert main(["run", "--device", "simulated:falcon", "--algorithm", "D", "--duration", "0.1s", "--fast",
                 "--json", "--quiet"]) == 0
    assert "search_budget" not in {k for k, v in json.loads(capsys.readouterr().out).items() if k != "units"}
