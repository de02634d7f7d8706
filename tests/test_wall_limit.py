"""Issue 55: detectors that measure what a hand feels (the encoder's staircase is not a
vibration, the texture's own rate is not an oscillation, regime and oscillating agree), and the
wall limit found on the device (haptex run --find-limit), checked against the simulator's own
limit for the same hand."""

import json

import numpy as np
import pytest

import haptex as hx
from haptex.backends.simulated import SimulatedBackend
from haptex.cli import main
from haptex.limits import SIM_PUSH, find_limit, stiffness_ladder, wall_limits
from haptex.perception import buzz, dequantise
from haptex.servo import ServoLoop, analyse_trace
from haptex.simulate import UNSTABLE

T = 1e-3


def _quantise(x, delta):
    return delta * np.round(x / delta)


@pytest.mark.parametrize("speed", [7e-3, 11e-3, 23e-3])  # (not a whole step a tick: a staircase)
@pytest.mark.parametrize("delta", [10e-6, 63.5e-6])
def test_a_slide_read_through_an_encoder_is_a_line_not_a_buzz(speed, delta):
    # a hand sliding at constant speed, read on a lattice of step delta (the Falcon's 63.5 um,
    # a finer 10 um): the raw staircase's sawtooth at v / delta is far above the hand's
    # detection threshold (its fundamental delta / pi, against 0.01 um: Brisben et al. 1999);
    # rebuilt from its transitions the motion is the line to within the tick's v T / 2, and no
    # component is left above half a step (the floor)
    t = np.arange(2000) * T
    true = np.column_stack([speed * t, np.zeros_like(t)])
    sensed = _quantise(true + 1e-7, delta)
    raw = buzz(sensed, T)
    assert raw.perceptible and raw.margin_db > 20.0
    rebuilt = dequantise(sensed, delta)
    inner = slice(200, 1800)
    assert np.max(np.abs(rebuilt[inner, 0] - true[inner, 0])) <= 0.5 * speed * T + 1e-9
    felt = buzz(rebuilt, T, floor=0.5 * delta)
    assert not felt.perceptible and felt.margin_db == -np.inf


def test_a_vibration_larger_than_the_step_is_still_seen():
    # a 150 Hz vibration of 5 encoder steps (Falcon, 63.5 um) on top of a slide: the rebuilt
    # motion keeps it at its frequency and amplitude (within a step), far above threshold
    delta, t = 63.5e-6, np.arange(2000) * T
    true = np.column_stack([0.01 * t, 5 * delta * np.sin(2 * np.pi * 150.0 * t)])
    b = buzz(dequantise(_quantise(true, delta), delta), T, floor=0.5 * delta)
    assert b.perceptible and abs(b.frequency - 150.0) <= 1.0 and b.axis == 1
    assert abs(b.amplitude - 5 * delta) <= delta


def test_dequantise_refuses_bad_input():
    with pytest.raises(hx.ParameterError, match="resolution"):
        dequantise(np.zeros((4, 2)), -1.0)
    with pytest.raises(hx.ParameterError, match="position"):
        dequantise(np.full((4, 2), np.nan), 1e-6)


@pytest.mark.parametrize("stiffness", [100.0, 500.0, 2000.0])
def test_the_simulated_falcon_scanning_the_default_texture_does_not_buzz_at_its_encoder(stiffness):
    # the report: on the simulated Falcon (encoder 63.5 um) a hand scanning the default
    # texture (0.2 mm, 2 mm) at 10 mm/s gave buzz 64.29 dB at 157.5 Hz (= v / delta) for every
    # stiffness, and 'oscillating' at 5 Hz (= v / l, the texture's own rate) whatever the regime.
    # All three are below the Falcon's limit with the light-touch hand (haptex.wall_limits).
    assert stiffness < wall_limits(hx.catalogue.preset("falcon").device(), "light-touch").stable
    b = SimulatedBackend("falcon", realtime=False)
    r = hx.Renderer(hx.algorithm("A", hx.surfaces.Extruded(hx.Sinusoid(0.2e-3, 2e-3)), stiffness))
    _, trace = ServoLoop(b, r).run(3.0)
    v = analyse_trace(trace, b.period, b.device.position_resolution, [2e-3], speed=0.01)
    assert v["texture_rates"] == (5.0,)
    assert not v["oscillation"].oscillating and v["regime"] not in UNSTABLE
    bz = v["buzz"]
    assert bz.floor == pytest.approx(0.5 * 63.5e-6)
    assert not (bz.perceptible and abs(bz.frequency - 157.5) < 2.0), bz


def test_regime_and_oscillating_never_disagree():
    # over the pantograph's wall from 0.3 to 2 times its limit with the light-touch hand, the
    # trace's regime is a limit cycle or growth exactly when 'oscillating' says so (simulator
    # and device verdicts alike); and the simulator's batch, over the same stiffnesses
    dev = hx.catalogue.preset("pantograph").device()
    limit = wall_limits(dev, "light-touch")["hand"].value
    seen = set()
    for factor in (0.3, 0.6, 0.9, 1.1, 1.5, 2.0):
        b = SimulatedBackend("pantograph", realtime=False)
        _, trace = ServoLoop(b, hx.Renderer(hx.algorithm("W", None, factor * limit))).run(1.5)
        v = analyse_trace(trace, b.period, b.device.position_resolution)
        assert v["oscillation"].oscillating == (v["regime"] in ("limit cycle", "growing")), (factor, v["regime"])
        seen.add(v["oscillation"].oscillating)
    assert seen == {True, False}  # both verdicts were met
    hand = hx.catalogue.hand("light-touch")
    ks = limit * np.geomspace(0.3, 2.0, 12)
    res = hx.simulate_batch(hx.algorithm("W", None, ks[0]), hand.attach(dev),
                            hand.operator(depth=SIM_PUSH / hand.stiffness, dimension=2), 1.0,
                            initial_position=np.zeros(2), stiffness=ks)
    assert np.array_equal(res.oscillating, np.isin(res.regime, ["limit cycle", "growing"]))


def test_the_ladder():
    ks = stiffness_ladder(100.0, 1000.0, 1.1)
    assert ks[0] == 100.0 and ks[-1] <= 1000.0 < ks[-1] * 1.1 and np.allclose(ks[1:] / ks[:-1], 1.1)
    with pytest.raises(hx.ParameterError, match="ratio"):
        stiffness_ladder(100.0, 1000.0, 1.0)
    with pytest.raises(hx.ParameterError, match="stop"):
        stiffness_ladder(100.0, 10.0)


def test_the_stiffness_changes_between_ticks():
    # the renderer's parameter block: a stiffness handed over is taken by the next tick, whole
    r = hx.Renderer(hx.algorithm("W", None, 1000.0))
    assert r.step((0.0, -1e-3))[1] == pytest.approx(1.0)
    r.set_stiffness(3000.0)
    assert r.stiffness == 1000.0 and r.stiffness_changes == 0  # waiting for the tick
    assert r.step((0.0, -1e-3))[1] == pytest.approx(3.0) and r.stiffness == 3000.0 and r.stiffness_changes == 1
    with pytest.raises(hx.ParameterError, match="stiffness"):
        r.set_stiffness(5000.0, limit=4000.0)
    with pytest.raises(hx.ParameterError, match="stiffness"):
        r.set_stiffness(float("nan"))


@pytest.mark.parametrize("preset, step", [("falcon", 0.5), ("falcon", 1.0), ("pantograph", 0.5)])
def test_find_limit_on_the_simulated_device_agrees_with_the_simulator(preset, step):
    # the goal: --find-limit on the simulated device ends within 10 % of the simulator's
    # stable limit for the same hand: the exact boundary of the same sampled loop (device, the
    # light-touch hand, zero-order hold, delay: haptex.wall_limits' "hand"; the simulated
    # device has no Coulomb friction, the one nonlinearity of haptex.simulate it lacks). Never
    # past the first oscillating step; no force acting at the end. Measured: the Falcon
    # (3,063 N/m) oscillates at 3,198 (0.5 s steps) and 3,518 (1 s), the pantograph (38,484)
    # at 36,535.
    hand = hx.catalogue.hand("light-touch")
    dev = hx.catalogue.preset(preset).device()
    exact = wall_limits(dev, hand)["hand"].value
    b = SimulatedBackend(preset, speed=0.0, press=SIM_PUSH / hand.stiffness, realtime=False)
    res = find_limit(b, exact / 4, exact * 4, step_duration=step, native=False)
    assert res.reason == "oscillation" and res.clean is not None
    assert res.oscillating == pytest.approx(res.clean * 1.1)
    assert abs(res.clean / exact - 1.0) <= 0.10 or abs(res.oscillating / exact - 1.0) <= 0.10, \
        (res.clean, res.oscillating, exact)
    ks = [s["stiffness"] for s in res.steps]
    assert np.all(np.diff(ks) > 0) and ks[-1] == res.oscillating  # nothing stiffer was ever sent
    assert all(not s["oscillating"] for s in res.steps[:-1]) and res.steps[-1]["oscillating"]
    d = b.dimension
    assert np.all(np.asarray(b.state)[2 * d:3 * d] == 0.0)  # no force acting once closed


def test_haptex_run_find_limit(capsys):
    assert main(["run", "--device", "simulated:pantograph", "--find-limit", "--fast", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["program"] == "find-limit" and out["reason"] == "oscillation"
    assert out["clean_stiffness"] < out["oscillating_stiffness"] and out["units"]["clean_stiffness"] == "N/m"
    assert 0.5 < out["oscillating_stiffness"] / out["predicted_stable"] < 2.0
    assert main(["run", "--device", "simulated:falcon", "--find-limit", "--texture", "sine:0.2mm,2mm"]) == 2
    assert "--texture is not allowed with --find-limit" in capsys.readouterr().err
    assert main(["run", "--device", "simulated:falcon", "--find-limit", "--hand", "none"]) == 2
    assert "hand = 'none' is not allowed" in capsys.readouterr().err
