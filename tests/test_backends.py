"""Issue 34: one contract for every device backend, run against the simulated backend and
against each vendor's own Python binding (forcedimension-core, pyOpenHaptics from PyPI) driving
a stub of the vendor's native library built here (tests/stubs, tests/vendor_stubs.py), with
haptex's simulator as the device behind it.

The contract is the issue's: units, signs and frames; no kick at start-up and the engagement
ramp; the watchdog; forces never NaN, never above the maximum, zero within one tick of a fault
and on every exit path (the end, Ctrl-C, an exception), with the motors left unenergised. Rates
and tick times are measured by benchmarks/run_backends.py, not asserted here.
"""

import _thread
import ctypes
import json
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import haptex as hx
from haptex.backends import DeviceBackend, DeviceError, open_backend
from haptex.backends.simulated import SimulatedBackend
from haptex.cli import main
from haptex.servo import ServoLoop

from . import vendor_stubs as vs

SINE = hx.Extruded(hx.Sinusoid(0.2e-3, 2e-3))
KINDS = ["simulated", "forcedimension", "openhaptics", "openhaptics-python", "haply", "haply-serial"]
"""openhaptics: the C core's native callback in HD's thread; openhaptics-python: the Python one."""
RUN_KINDS = [pytest.param(k, marks=pytest.mark.long) if k in ("openhaptics-python", "haply") else k for k in KINDS]
"""KINDS for the whole runs in real time (0.4-1 s each): the Python callback's and the Haply
service's twins of the native ones in .ci/run's long set."""
VENDORS = ["forcedimension", "openhaptics", "haply", "haply-serial"]
PRESET = {"simulated": "omega-3", "forcedimension": "omega-3", "openhaptics": "touch", "openhaptics-python": "touch",
          "haply": "inverse3", "haply-serial": "inverse3"}

needs_cc = pytest.mark.skipif(vs.compiler() is None, reason="no C compiler to build the vendors' stubs")


@pytest.fixture(scope="module")
def stubs(tmp_path_factory):
    """The two stubs, built and loaded once per process (the bindings load them at import)."""
    if vs.compiler() is None:
        pytest.skip("no C compiler to build the vendors' stubs")
    root = tmp_path_factory.mktemp("vendor-sdks")
    vs.build_dhd(root / "fdsdk")
    dhd = vs.load_dhd(root / "fdsdk")
    hd = vs.load_hd(vs.build_hd(root / "hd"))
    return {"forcedimension": dhd, "openhaptics": hd}


class Rig:
    """A backend of one kind on a simulated preset, and what reached the device's motors."""

    def __init__(self, kind, stubs, start=5e-3, press=1e-3, speed=0.01, realtime=False, garble=None):
        preset = PRESET[kind]
        python_callback = kind == "openhaptics-python"
        kind = self.kind = "openhaptics" if python_callback else kind
        self.sim = SimulatedBackend(preset, press=press, speed=speed, start=start, realtime=False)
        if kind == "simulated":
            self.sim.realtime = realtime
            self.backend, self.behind = self.sim, None
            return
        if kind == "haply":
            self.behind = vs.InverseService(self.sim, garble=garble)
            self.backend = open_backend("haply:" + self.behind.address)
            return
        if kind == "haply-serial":
            pytest.importorskip("HaplyHardwareAPI", reason="Haply's package has wheels for a few platforms only")
            self.behind = vs.InverseSerial(self.sim, garble=garble)
            # (the Inverse Service's 1 s: the default 0.1 s is tested below, a loaded machine may stall that long)
            self.backend = open_backend("haply-serial:" + self.behind.port, timeout=1.0)
            return
        stub = stubs[kind]
        if kind == "forcedimension":
            self.behind = vs.Behind(self.sim)
            stub.hxstub_bind(self.behind.read, self.behind.write, 33, 1)  # DHD_DEVICE_OMEGA3
            self.backend = open_backend("forcedimension", realtime=realtime)
        else:
            self.behind = vs.Behind(self.sim, vs.HD_FROM_HAPTEX, 1e3)
            stub.hxstub_bind(self.behind.read, self.behind.write, b"Touch", 3.3, 1)
            self.backend = open_backend("openhaptics")
            assert self.backend.native
            self.backend.native = not python_callback
        self.stub = stub

    def motors(self) -> np.ndarray:
        """Every force that reached the device (N, haptex's frame), one a tick."""
        if self.kind == "haply" and self.backend._ws is None:
            self._ended()
        return np.array(self.behind.forces) if self.behind is not None else None

    def _ended(self) -> None:
        for _ in range(100):  # (the emulator's session ends in its own thread)
            if not self.behind.connected:
                break
            time.sleep(0.01)

    def energised(self) -> bool:
        """Whether the device was left with a force after the run (the vendor stubs count a
        close or a scheduler stop with a force applied)."""
        if self.kind == "forcedimension":
            return self.stub.hxstub_energised_after_close() > 0 or self.stub.hxstub_opened() != 0
        if self.kind == "openhaptics":
            return self.stub.hxstub_energised_after_stop() > 0 or self.stub.hxstub_running() != 0
        if self.kind.startswith("haply"):
            self._ended()
            return self.behind.energised_after_close > 0 or self.behind.connected
        return bool(np.any(self.sim.state[6:9] != 0.0))  # the held force of the simulated device


def _loop(backend, stiffness=500.0, renderer=None, **kw):
    r = renderer or hx.Renderer(hx.algorithm("A", SINE, stiffness), max_force=backend.max_force, energy_monitor=True)
    return ServoLoop(backend, r, **kw)


@pytest.mark.parametrize("kind", KINDS)
def test_a_backend_is_a_device_backend_with_its_presets_figures(kind, stubs):
    rig = Rig(kind, stubs)
    b = rig.backend
    assert isinstance(b, DeviceBackend) and b.dimension == 3
    p = hx.catalogue.preset(PRESET[kind])
    assert b.max_force == p.value("max_force")
    if kind.startswith("haply"):  # the service or device paces the loop: its rate is measured
        # (the emulators' states come at least 1 ms apart, by construction; later on a loaded machine)
        assert b.period >= 0.999e-3 and b.device.period == b.period
    else:
        assert b.period == p.value("period")
    assert b.device.details["preset"] == p.key


@needs_cc
@pytest.mark.parametrize("kind", VENDORS)
def test_units_signs_and_frames(kind, stubs):
    # the backend reads the simulator's own position (m, haptex's frame: z up) through the
    # vendor's units and frame, and a force commanded along each axis reaches the device along
    # that axis, in newtons
    rig = Rig(kind, stubs, start=5e-3, press=0.0, speed=0.0)
    b = rig.backend
    res = rig.sim.device.position_resolution
    b.open()
    try:
        s = b.sample()
        assert s.position[2] > 4e-3  # the handle starts 5 mm above the surface: +z is up
        for axis in range(3):
            f = np.zeros(3)
            f[axis] = 0.25 * (axis + 1)
            b.command(f)
            s = b.sample()  # (lock-step: the next state comes once the force is applied)
            assert np.allclose(rig.motors()[-1], f, atol=1e-12)
            truth = rig.behind.truth
            assert np.allclose(s.position, truth, atol=res + 1e-12), (s.position, truth)
    finally:
        b.command(np.zeros(3))
        b.close()
    assert not rig.energised()


@needs_cc
@pytest.mark.parametrize("kind", RUN_KINDS)
def test_a_run_pushes_out_of_the_wall_and_ends_unenergised(kind, stubs):
    # the hand presses the handle 1 mm below the surface: the forces sent are finite, at most
    # the device's maximum, push out of the wall (+z on average once engaged), reach the motors
    # as sent, and the run ends with zero force and the device released
    rig = Rig(kind, stubs)
    stats, trace = _loop(rig.backend).run(600 * rig.backend.period)  # (in ticks: a service sets its own rate)
    f = trace["force"]
    assert stats.ticks == len(f) and stats.engaged_at is not None and stats.faults == 0
    assert np.all(np.isfinite(f)) and np.all(np.linalg.norm(f, axis=1) <= rig.backend.max_force * (1 + 1e-12))
    assert f[stats.engaged_at:, 2].mean() > 0.0 and trace["position"][:, 2].min() < 0.0  # in contact, pushed out
    if rig.behind is not None:
        m = rig.motors()
        # every tick's force reached the device (DHD: one write a tick plus the zero writes at open
        # and close; HD: one frame a tick plus the synchronous zero frames)
        if kind == "haply-serial":  # float32 on the wire: each force as sent to 2^-23 relative, never larger
            d = np.abs(m[None, :, :] - f[:, None, :])
            near = np.all((d <= 2.0 ** -23 * np.abs(f[:, None, :])) & (np.abs(m[None]) <= np.abs(f[:, None])), axis=2)
            assert near.any(axis=1).all() and np.all(m[-1] == 0.0)
        else:
            sent = {tuple(x) for x in f}
            assert {tuple(x) for x in m} >= sent and np.all(m[-1] == 0.0)
    assert not rig.energised()


@needs_cc
@pytest.mark.parametrize("kind", RUN_KINDS)
def test_no_kick_when_the_handle_starts_inside_the_wall(kind, stubs):
    # 3 mm inside a 2 kN/m wall, pressed 5 mm in: the computed force (6-10 N) never falls below
    # the engagement threshold, so nothing but zero ever reaches the motors
    rig = Rig(kind, stubs, start=-3e-3, press=5e-3)
    stats, trace = _loop(rig.backend, stiffness=2000.0).run(400 * rig.backend.period)
    assert stats.engaged_at is None and np.all(trace["force"] == 0.0)
    if rig.behind is not None:
        assert np.all(rig.motors() == 0.0)
    assert not rig.energised()


@needs_cc
@pytest.mark.parametrize("kind", RUN_KINDS)
def test_the_engagement_ramp(kind, stubs):
    rig = Rig(kind, stubs, press=1e-4)
    stats, trace = _loop(rig.backend, ramp_ticks=300).run(800 * rig.backend.period)
    k0 = stats.engaged_at
    sent = np.linalg.norm(trace["force"], axis=1)
    ramp = np.minimum(1.0, (np.arange(len(sent)) - k0 + 1) / 300)
    assert k0 is not None and np.all(sent[:k0] == 0.0)
    assert np.all(sent[k0:] <= ramp[k0:] * rig.backend.max_force + 1e-12) and sent.max() > 0


class Faulty:
    """A renderer that returns NaN at some ticks, 1e6 N at others, raises at others, and
    stalls for 6 periods at one (the next tick is late)."""

    def __init__(self, inner, period, nan_at=(), huge_at=(), raise_at=(), stall_at=None):
        self.inner, self.period, self.k = inner, period, 0
        self.nan_at, self.huge_at, self.raise_at, self.stall_at = set(nan_at), set(huge_at), set(raise_at), stall_at
        self.dimension, self.clamps = inner.dimension, 0

    def step(self, p):
        k, self.k = self.k, self.k + 1
        f = self.inner.step(p)
        if k == self.stall_at:
            import time

            time.sleep(6 * self.period)
        if k in self.raise_at:
            raise RuntimeError("the tick failed")
        if k in self.nan_at:
            return np.full(3, np.nan)
        if k in self.huge_at:
            return np.array([0.0, 0.0, 1e6])
        return f


@needs_cc
@pytest.mark.parametrize("kind", KINDS)
def test_faults_give_zero_force_within_the_tick_and_the_maximum_holds(kind, stubs):
    rig = Rig(kind, stubs, realtime=True)
    b = rig.backend
    inner = hx.Renderer(hx.algorithm("A", SINE, 500.0), energy_monitor=True)
    r = Faulty(inner, b.period, nan_at={120, 121}, raise_at={160}, huge_at={200})
    # (no watchdog here: a tick late on a loaded machine would send zero for its own reason)
    stats, trace = _loop(b, renderer=r, ramp_ticks=10, engage_ticks=5, deadline=1e6).run(300 * b.period)
    f = trace["force"]
    for k in (120, 121, 160):  # the faulty tick itself sends zero
        assert np.all(f[k] == 0.0), k
    assert stats.faults == 3
    assert np.linalg.norm(f[200]) == pytest.approx(b.max_force)  # clamped, not passed on
    assert np.all(np.isfinite(f)) and np.all(np.linalg.norm(f, axis=1) <= b.max_force * (1 + 1e-12))
    assert not rig.energised()


@needs_cc
@pytest.mark.parametrize("kind", KINDS)
def test_the_watchdog_zeroes_a_late_tick(kind, stubs):
    # the tick stalls for 6 periods once: the next sample comes late and its tick sends zero
    rig = Rig(kind, stubs, realtime=True)
    b = rig.backend
    r = Faulty(hx.Renderer(hx.algorithm("A", SINE, 500.0)), b.period, stall_at=150)
    stats, trace = _loop(b, renderer=r, ramp_ticks=10, engage_ticks=5).run(300 * b.period)
    assert stats.missed >= 1 and np.all(trace["force"][151] == 0.0)
    assert not rig.energised()


class CtrlC:
    """The renderer, with a Ctrl-C at tick ``at`` (``_thread.interrupt_main``: what the terminal's
    SIGINT does, delivered to the main thread: there at once with a polling backend, or where it
    waits for the vendor's servo thread)."""

    def __init__(self, at):
        self.inner, self.at, self.k = hx.Renderer(hx.algorithm("A", SINE, 500.0)), at, 0
        self.dimension, self.clamps = 3, 0

    def step(self, p):
        self.k += 1
        if self.k == self.at:
            _thread.interrupt_main()
        return self.inner.step(p)


@needs_cc
@pytest.mark.parametrize("kind", KINDS)
def test_ctrl_c_zeroes_the_force_keeps_the_trace_and_releases_the_device(kind, stubs):
    rig = Rig(kind, stubs, realtime=True)
    # (a shell that starts the tests in the background leaves SIGINT ignored, and then
    # interrupt_main does nothing: Python's own handler is put back for this test)
    old = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        stats, trace = _loop(rig.backend, renderer=CtrlC(250)).run(5000 * rig.backend.period)
    finally:
        signal.signal(signal.SIGINT, old)
    # polling: the tick it lands in is the last; a servo thread runs on until the waiting main
    # thread wakes (within 0.05 s), then sends zero within a tick
    late = 0 if not kind.startswith("openhaptics") else int(0.06 / rig.backend.period)
    assert stats.interrupted and 249 <= stats.ticks <= 250 + late, stats.ticks
    assert len(trace["time"]) == stats.ticks
    if rig.behind is not None:
        assert np.all(rig.motors()[-1] == 0.0)
    assert not rig.energised()


@needs_cc
@pytest.mark.parametrize("kind", ["forcedimension", "openhaptics"])
def test_no_device_is_one_line_naming_what_to_check(kind, stubs):
    sim = SimulatedBackend(PRESET[kind], realtime=False)
    behind = vs.Behind(sim)
    if kind == "forcedimension":
        stubs[kind].hxstub_bind(behind.read, behind.write, 33, 0)
    else:
        stubs[kind].hxstub_bind(behind.read, behind.write, b"Touch", 3.3, 0)
    with pytest.raises(DeviceError, match="not reachable") as e:
        open_backend(kind)
    assert "\n" not in str(e.value)


@needs_cc
def test_a_device_type_without_a_preset_asks_for_one(stubs):
    behind = vs.Behind(SimulatedBackend("omega-3", realtime=False))
    stubs["forcedimension"].hxstub_bind(behind.read, behind.write, 91, 1)  # DHD_DEVICE_CUSTOM
    with pytest.raises(DeviceError, match="type 91, which has no preset.*forcedimension:omega-3"):
        open_backend("forcedimension")
    b = open_backend("forcedimension:omega-3")  # named: modelled by it
    assert b.name == "forcedimension:omega-3"
    stubs["openhaptics"].hxstub_bind(behind.read, behind.write, b"Phantom Desktop", 7.9, 1)
    with pytest.raises(DeviceError, match="'Phantom Desktop', which has no preset"):
        open_backend("openhaptics")


@needs_cc
def test_haptex_run_on_a_force_dimension_device_through_its_sdk(stubs, capsys, tmp_path):
    behind = vs.Behind(SimulatedBackend("omega-3", realtime=False))
    stubs["forcedimension"].hxstub_bind(behind.read, behind.write, 33, 1)
    rec = tmp_path / "trace.npz"
    assert main(["run", "--device", "forcedimension", "--duration", "0.5s", "--json", "--record", str(rec)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["device"] == "forcedimension:omega-3" and out["ticks"] == 2000 and out["max_force_sent"] <= 12.0
    assert np.load(rec)["force"].shape == (2000, 3)
    assert stubs["forcedimension"].hxstub_energised_after_close() == 0


def _fresh_python(code: str, env_drop=("FDSDK", "FORCEDIM_SDK")) -> subprocess.CompletedProcess:
    import os

    env = {k: v for k, v in os.environ.items() if k not in env_drop}
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)


@pytest.mark.long  # (.ci/run's long set: five fresh interpreters)
def test_a_missing_sdk_or_binding_is_one_line_naming_what_to_install():
    # a fresh Python without the SDKs' libraries (the bindings are installed: pyproject's test extra)
    r = _fresh_python("from haptex.cli import main; import sys; sys.exit(main(['run', '--device', 'forcedimension']))")
    assert r.returncode == 2 and "FDSDK" in r.stderr and r.stderr.count("\n") == 1, r.stderr
    # (forcedimension-core writes "Could not find libdrd. Is it installed?" to stderr as it
    # loads, a line before haptex's (2026-12-01): its words are now in haptex's one line)
    assert "it said: Could not find libdrd" in r.stderr, r.stderr
    r = _fresh_python("from haptex.cli import main; import sys; sys.exit(main(['run', '--device', 'openhaptics']))")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "libHD.so" in r.stderr, r.stderr
    # and without the bindings: the extra to install is named
    code = ("import sys; sys.modules['{m}'] = None\n"
            "from haptex.cli import main; sys.exit(main(['run', '--device', '{k}']))")
    for m, k in (("forcedimension_core", "forcedimension"), ("pyOpenHaptics", "openhaptics"),
                 ("HaplyHardwareAPI", "haply-serial")):
        r = _fresh_python(code.format(m=m, k=k))
        assert r.returncode == 2 and f"pip install 'haptex[{k}]'" in r.stderr and r.stderr.count("\n") == 1, r.stderr


def test_a_service_that_closes_during_the_probe_is_one_line():
    # the emulator answers the first state, then its every next message is not a state but the
    # end of the connection: the probe's send or receive fails, in one line
    sim = SimulatedBackend("inverse3", realtime=False)
    service = vs.InverseService(sim, garble={k: None for k in range(1, 30)})
    with pytest.raises(DeviceError, match="went away|stopped answering") as e:
        open_backend("haply:" + service.address)
    assert "\n" not in str(e.value)
    with pytest.raises(hx.ParameterError, match="timeout"):
        open_backend("haply:" + service.address, timeout=True)


def test_options_a_backend_does_not_take_are_refused_by_name():
    with pytest.raises(hx.ParameterError, match="hand = 'firm-grip' is not allowed with device = 'openhaptics'"):
        open_backend("openhaptics", hand="firm-grip")


def test_hostile_messages_from_the_inverse_service_are_faults_answered_with_zero_force():
    # what a service sends is input: text that is not JSON, a position that is NaN or missing, a
    # message of another shape; each is a faulty sample (zero force that tick), the run goes on
    bad = {400: "not json", 401: '{"inverse3": [{"device_id": "inverse3-emulated", "state": '
                                 '{"cursor_position": {"x": NaN, "y": 0, "z": 0}}}]}',
           402: '{"inverse3": [{"device_id": "inverse3-emulated", "state": {}}]}', 403: "[]",
           404: '{"inverse3": [{"device_id": "someone-else", "state": {"cursor_position": {"x": 0, "y": 0, "z": 0}}}]}'}
    # (the probe's 21 messages come first: the run's ticks are counted from its own session)
    rig = Rig("haply", None, garble=bad)
    stats, trace = _loop(rig.backend).run(600 * rig.backend.period)
    assert stats.faults == 5 and stats.ticks == 600
    assert np.all(trace["force"][400:405] == 0.0) and np.all(np.isnan(trace["position"][400:405]).any(axis=1))
    assert not rig.energised()


def test_an_inverse_service_without_an_inverse3_or_past_the_message_limit_is_refused():
    sim = SimulatedBackend("inverse3", realtime=False)
    with pytest.raises(DeviceError, match="reports no Inverse3"):
        open_backend("haply:" + vs.InverseService(sim, garble={0: '{"inverse3": []}'}).address)
    # a message past the 1 MiB limit closes the connection: the device is gone, in one line
    huge = '{"inverse3": [{"device_id": "x", "pad": "' + "x" * (1 << 20) + '"}]}'
    with pytest.raises(DeviceError, match="went away") as e:
        service = vs.InverseService(SimulatedBackend("inverse3", realtime=False), garble={0: huge})
        open_backend("haply:" + service.address)
    assert "\n" not in str(e.value)


def test_a_device_without_velocity_runs_on_positions():
    # the bad input: a device that reports no velocity. The Inverse Service's message
    # without cursor_velocity gives samples without one; the rules need only positions
    sim = SimulatedBackend("inverse3", realtime=False)
    service = vs.InverseService(sim, velocity=False)
    b = open_backend("haply:" + service.address)
    b.open()
    try:
        s = b.sample()
        assert s.velocity is None and np.all(np.isfinite(s.position))
        b.command(np.zeros(3))
    finally:
        b.close()
    b = open_backend("haply:" + service.address)
    stats, trace = _loop(b).run(300 * b.period)
    assert stats.faults == 0 and stats.ticks == 300


def _inverse_serial(garble=None):
    pytest.importorskip("HaplyHardwareAPI", reason="Haply's package has wheels for a few platforms only")
    return vs.InverseSerial(SimulatedBackend("inverse3", realtime=False), garble=garble)


def test_the_inverse3s_wakeup_comes_through_haplys_own_package():
    # the id, model number, versions and UUID the emulator sends are what the vendor's package
    # reads (the exchange in haptex.backends.haply_serial's docstring); the rate is measured
    import uuid

    emu = _inverse_serial()
    b = open_backend("haply-serial:" + emu.port, timeout=1.0)
    assert b.info == {"device_id": 0x1234, "device_model_number": 7, "hardware_version": 3, "firmware_version": 12,
                      "device_id_ext": str(uuid.UUID(bytes=bytes(range(16))))}
    assert emu.wakeups == 1 and emu.commands == 20 and b.period >= 0.999e-3 and b.name == "haply-serial:inverse3"
    assert np.all(np.array(emu.forces) == 0.0)  # the probe commands nothing
    emu.stop()


@pytest.mark.long  # (.ci/run's long set: four 0.5 s no-answer timeouts and five 600-tick runs in real time)
def test_hostile_answers_on_the_serial_port_are_faults_or_a_device_gone():
    import struct

    # the 20 exchanges of the probe and the open's come first: tick k's command is exchange 21 + k,
    # and its answer is tick k + 1's sample
    nan, inf = float("nan"), float("inf")
    bad = {420: b"\x2b" + struct.pack("<6f", nan, 0, 0, 0, 0, 0), 421: b"\x2b" + struct.pack("<6f", 0, 0, inf, 0, 0, 0)}
    emu = _inverse_serial(garble=bad)
    b = open_backend("haply-serial:" + emu.port, timeout=1.0)
    stats, trace = _loop(b).run(600 * b.period)
    assert stats.driver == "native thread" and stats.faults == 2 and stats.ticks == 600
    assert np.all(trace["force"][400:402] == 0.0) and not np.all(np.isfinite(trace["position"][400:402]))
    assert emu.energised_after_close == 0 and np.all(emu.forces[-1] == 0.0)
    # an answer with another header, or none: the native thread (hx_haply.c) names which, the
    # Python loop (through the package, which times out and returns zeros) calls the device gone;
    # in one line, naming the timeout taken, and the run's last command is still zero. (Each
    # opened with a 0.5 s timeout: the emulator answers from a Python thread, which a loaded
    # machine under `-n 2` has stalled past the 100 ms default at the open and at tick 45; below
    # the 1 s in which a run whose ticks stop is called stalled, haptex.backends.STALLED.)
    for answer, native, what in ((b"\x0a" + bytes(24), True, r"an answer that is not the device's state \(at "
                                  r"tick 299\); zero force"), (None, True, r"no answer in 500 ms \(at tick 299\)"),
                                 (b"\x0a" + bytes(24), False, "no answer in 500 ms"), (None, False, "no answer in 500 ms")):
        emu = _inverse_serial(garble={321: answer})
        b = open_backend("haply-serial:" + emu.port, timeout=0.5)
        with pytest.raises(DeviceError, match="stopped answering: " + what) as e:
            _loop(b, native=native).run(600 * b.period)
        assert "\n" not in str(e.value)
        for _ in range(100):  # (the emulator reads the port in its own thread: the last command may
            if not emu.connected:  # still be on its way when the run returns; it has arrived by the close)
                break
            time.sleep(0.01)
        assert np.all(emu.forces[-1] == 0.0) and emu.energised_after_close == 0 and not emu.connected


def test_the_native_thread_speaks_the_inverse3s_serial_exchanges():
    # issue 56: the C core's thread (hx_haply.c) drives the emulated Inverse3 lock-step, paced by
    # its answers: every tick's force reached the device as float32 rounded towards zero (never
    # larger), the wall engaged and pushed back, and the thread's last command was zero. (Not
    # compared with the Python loop's trace: the native run wakes the device on its own raw port,
    # one exchange more, so the device's state is a period further on.)
    emu = _inverse_serial()
    b = open_backend("haply-serial:" + emu.port, timeout=1.0)
    stats, trace = _loop(b, engage_ticks=5, engage_force=0.5, ramp_ticks=10).run(400 * b.period)
    assert stats.driver == "native thread" and stats.ticks == 400 and stats.faults == 0
    sent, f = np.array(emu.forces[-401:-1]), trace["force"]  # the run's 400 commands, before the closing zero
    assert np.all(np.abs(sent) <= np.abs(f)) and np.all(np.abs(sent - f) <= 2.0 ** -23 * np.abs(f))
    assert stats.engaged_at is not None and f[stats.engaged_at + 20:, 2].mean() > 0.0
    assert np.all(emu.forces[-1] == 0.0) and emu.energised_after_close == 0
    emu.stop()


@pytest.mark.skipif(not os.path.exists("/dev/ptmx"), reason="no pseudo-terminals")
def test_the_core_opens_the_serial_port_raw_as_posix_defines_raw(tmp_path):
    # issue 66: the native thread's port is opened by the core itself (hx_haply_open), the one
    # function its Windows build runs under Wine on a COM port. Raw as POSIX's termios defines it
    # (the tty module's setraw clears the same translation, echo and canonical bits): every byte
    # value crosses unchanged (a cooked terminal turns CR into LF and would eat 0x03 and 0x7F);
    # a path that is not a terminal is the system's ENOTTY, a missing one ENOENT.
    import errno
    import pty
    import termios

    from haptex.core import _ext

    master, slave = pty.openpty()
    try:
        port = _ext.haply_open(os.ttyname(slave))
        try:
            iflag, oflag, cflag, lflag, _, _, cc = termios.tcgetattr(port)
            assert not iflag & (termios.ICRNL | termios.INLCR | termios.IGNCR | termios.ISTRIP | termios.IXON)
            assert not oflag & termios.OPOST and not lflag & (termios.ECHO | termios.ICANON | termios.ISIG)
            assert cflag & termios.CSIZE == termios.CS8 and not cflag & termios.PARENB
            assert (cc[termios.VMIN], cc[termios.VTIME]) == (1, 0)
            sent = bytes(range(256))
            os.write(master, sent)
            got = b""
            while len(got) < len(sent):
                got += os.read(port, len(sent) - len(got))
            assert got == sent
        finally:
            _ext.haply_close(port)
    finally:
        os.close(master)
        os.close(slave)
    (tmp_path / "file").write_text("")
    with pytest.raises(OSError) as e:
        _ext.haply_open(str(tmp_path / "file"))
    assert e.value.errno == errno.ENOTTY
    with pytest.raises(OSError) as e:
        _ext.haply_open(str(tmp_path / "nothing"))
    assert e.value.errno == errno.ENOENT


@pytest.mark.long  # (.ci/run's long set: waits out the 1 s wakeup of a silent port)
def test_a_wrong_serial_port_is_one_line_naming_what_to_check(tmp_path, capfd, monkeypatch):
    import os
    import pty

    H = pytest.importorskip("HaplyHardwareAPI", reason="Haply's package has wheels for a few platforms only")
    (tmp_path / "file").write_text("")
    master, slave = pty.openpty()  # a serial port with nothing behind it
    cases = [(str(tmp_path / "nothing"), "no such port"), (str(tmp_path / "file"), "not a serial port"),
             (os.ttyname(slave), "no Inverse3 answered the wakeup in 1 s")]
    for port, what in cases:
        with pytest.raises(DeviceError, match=what) as e:
            open_backend("haply-serial:" + port)
        assert "\n" not in str(e.value)
    assert "[err]" not in capfd.readouterr().err  # the package's own complaints are held
    os.close(master)
    os.close(slave)
    monkeypatch.setattr(H, "detect_inverse3s", lambda: [])
    with pytest.raises(DeviceError, match="no Inverse3 found on a serial port.*'haply-serial:/dev/ttyACM0'"):
        open_backend("haply-serial")
    with pytest.raises(hx.ParameterError, match="timeout = 5 is not allowed"):
        open_backend("haply-serial:/dev/null", timeout=5)


def test_forces_cross_the_serial_port_as_float32_never_larger():
    # float32 rounds 1/3 N up in x and down in z; the device gets each component no larger than asked
    emu = _inverse_serial()
    b = open_backend("haply-serial:" + emu.port, timeout=1.0)
    b.open()
    try:
        asked = np.array([1 / 3, -1 / 3, 2 / 3])
        b.command(asked)
        got = emu.forces[-1]
        assert np.all(np.abs(got) <= np.abs(asked)) and np.all(np.abs(got - asked) <= 2.0 ** -23 * np.abs(asked))
        assert np.any(np.float32(asked).astype(float) != got)  # (rounding to nearest would be larger here)
    finally:
        b.close()
    assert np.all(emu.forces[-1] == 0.0) and emu.energised_after_close == 0
    emu.stop()


def test_haptex_run_on_an_inverse3_through_haplys_serial_package(capsys, tmp_path):
    emu = _inverse_serial()
    rec = tmp_path / "trace.npz"
    assert main(["run", "--device", "haply-serial:" + emu.port, "--duration", "0.3s", "--json",
                 "--record", str(rec)]) == 0
    out = json.loads(capsys.readouterr().out)
    p = hx.catalogue.preset("inverse3")
    assert out["device"] == "haply-serial:inverse3" and np.load(rec)["force"].shape == (out["ticks"], 3)
    assert out["faults"] == 0 and out["max_force_sent"] <= p.value("max_force")
    assert np.all(emu.forces[-1] == 0.0)
    emu.stop()


def test_a_binding_of_another_version_is_named_in_one_line(monkeypatch):
    # a forcedimension_core whose dhd lacks a function the backend calls, or a pyOpenHaptics
    # without one: refused before any device is touched, naming what is missing and the extra
    import types

    fake = types.ModuleType("forcedimension_core")
    fake.dhd = types.SimpleNamespace(open=lambda: 0)
    monkeypatch.setitem(sys.modules, "forcedimension_core", fake)
    monkeypatch.setitem(sys.modules, "forcedimension_core.dhd", fake.dhd)
    with pytest.raises(DeviceError, match=r"forcedimension_core has no dhd\.close .*haptex\[forcedimension\]") as e:
        open_backend("forcedimension")
    assert "\n" not in str(e.value)
    oh = types.ModuleType("pyOpenHaptics")
    oh.hd, oh.hd_callback = types.SimpleNamespace(init_device=lambda name: 0), types.SimpleNamespace()
    monkeypatch.setitem(sys.modules, "pyOpenHaptics", oh)
    monkeypatch.setitem(sys.modules, "pyOpenHaptics.hd", oh.hd)
    monkeypatch.setitem(sys.modules, "pyOpenHaptics.hd_callback", oh.hd_callback)
    with pytest.raises(DeviceError, match=r"pyOpenHaptics has no begin_frame .*haptex\[openhaptics\]"):
        open_backend("openhaptics")
    # a HaplyHardwareAPI before 0.1.13 (no read timeout: a silent device would look like one at the origin)
    hh = types.ModuleType("HaplyHardwareAPI")
    hh.SerialStream, hh.detect_inverse3s = object, list
    hh.Inverse3 = type("Inverse3", (), {"device_wakeup_dict": None, "end_effector_force": None})
    monkeypatch.setitem(sys.modules, "HaplyHardwareAPI", hh)
    with pytest.raises(DeviceError, match=r"HaplyHardwareAPI \S+ has no Inverse3.set_read_timeout .*0\.1\.13 or later; "
                       r"pip install 'haptex\[haply-serial\]'"):
        open_backend("haply-serial:/dev/ttyACM0")


def _hold_the_gil(after: float, hold: float) -> threading.Thread:
    """A thread that, ``after`` s from now, keeps the GIL for ``hold`` s: pure-Python work with
    a switch interval longer than that (no other Python thread runs meanwhile)."""
    def work():
        time.sleep(after)
        old = sys.getswitchinterval()
        sys.setswitchinterval(10.0)
        try:
            end = time.perf_counter() + hold
            while time.perf_counter() < end:
                pass
        finally:
            sys.setswitchinterval(old)

    t = threading.Thread(target=work, daemon=True)
    t.start()
    return t


@needs_cc
@pytest.mark.parametrize("native", [True, False])
def test_the_native_openhaptics_tick_needs_no_gil(native, stubs):
    # the C core's callback runs in HD's servo thread without Python: while another thread
    # holds the GIL for 0.3 s, it keeps ticking at 1 kHz; the Python callback waits for the GIL
    # (one gap of about 0.3 s between samples). The device behind the stub is in C here (a
    # 0.1 kg mass held by a 200 N/m, 2 N s/m hand 1 mm inside the wall), so nothing else in the
    # servo thread needs Python.
    stub = stubs["openhaptics"]
    stub.hxstub_bind_mass(0.1, 200.0, 2.0, (ctypes.c_double * 3)(0.0, -1.0, 0.0), b"Touch", 3.3)
    b = open_backend("openhaptics")
    b.native = native
    loop = ServoLoop(b, hx.Renderer(hx.algorithm("A", SINE, 500.0), max_force=b.max_force), engage_force=1.0,
                     engage_ticks=5, ramp_ticks=10)
    holder = _hold_the_gil(0.3, 0.3)
    stats, trace = loop.run(1.0)
    holder.join()
    gap = np.diff(trace["time"]).max()
    if native:
        assert gap < 0.1 and stats.ticks == 1000, (gap, stats.ticks)
    else:
        assert gap > 0.2, gap
    # the physics went through C both ways: engaged, pushed out of the wall (+z), never above the maximum
    f = trace["force"]
    assert stats.engaged_at is not None and f[stats.engaged_at + 20:, 2].mean() > 0.0
    assert np.all(np.linalg.norm(f, axis=1) <= b.max_force * (1 + 1e-12))
    assert stub.hxstub_energised_after_stop() == 0 and stub.hxstub_running() == 0


# ---- the C core's native servo thread (issue 56) ----

@pytest.mark.parametrize("preset", ["omega-3", "falcon", "touch"])
def test_the_native_thread_runs_the_same_ticks_as_the_python_loop(preset):
    # the same device (the C core's hx_plant), the same rules and the same renderer's tick, once
    # from the C thread and once from Python's loop: the same trace to the bit (not paced:
    # nothing depends on the clock); the three presets span 1 and 4 kHz, delays 0-1, encoders
    sim = SimulatedBackend(preset, realtime=False)
    traces = []
    for native in (True, False):
        r = hx.Renderer(hx.algorithm("A", SINE, 500.0), max_force=sim.max_force)
        stats, trace = ServoLoop(sim, r, native=native).run(800 * sim.period)
        assert stats.driver == ("native thread" if native else "python loop")
        traces.append((stats, trace))
    (a, ta), (b, tb) = traces
    assert a.ticks == b.ticks == 800 and a.engaged_at == b.engaged_at is not None
    for key in ("time", "position", "force", "engaged"):
        assert np.array_equal(ta[key], tb[key]), key
    assert ta["force"][a.engaged_at:, 2].mean() > 0.0  # (in contact: the comparison is not of zeros)


@pytest.mark.long  # (.ci/run's long set: a 2 s real-time run)
def test_a_stalled_python_side_never_delays_the_native_thread():
    # while a Python thread holds the GIL for 0.3 s (a dashboard, a plot, a collection), the
    # native thread keeps its 1 kHz: the largest gap between samples stays far below the
    # stall; the Python loop on the same device waits for the GIL (a gap of about 0.3 s)
    gaps = {}
    for native in (True, False):
        sim = SimulatedBackend("falcon", realtime=True)
        loop = ServoLoop(sim, hx.Renderer(hx.algorithm("A", SINE, 500.0), max_force=sim.max_force), native=native)
        holder = _hold_the_gil(0.3, 0.3)
        stats, trace = loop.run(1.0)
        holder.join()
        gaps[native] = np.diff(trace["time"]).max(), stats
    gap, stats = gaps[True]
    # (a tick's time is its schedule's, k T: its wall-clock gaps are counted in the jitter)
    assert stats.ticks == 1000 and stats.jitter_seconds[0] < 0.1, stats.jitter_seconds
    assert gaps[False][1].jitter_seconds[0] > 0.2, gaps[False][1].jitter_seconds
    assert stats.fifo in (True, False) and stats.tick_p999 <= stats.tick_seconds[0] + 1e-12


@pytest.mark.long  # (.ci/run's long set: a 1 s real-time run)
def test_a_dashboard_that_stalls_does_not_stall_the_native_thread():
    # the live dashboard's callback (on_tick) takes 0.3 s holding the GIL once: the thread
    # runs on; its ticks reach the callback through the counts and the seqlock's snapshot
    sim = SimulatedBackend("falcon", realtime=True)
    seen = []

    def on_tick(k, servo):
        seen.append(servo.snapshot())
        if len(seen) == 3:
            end = time.perf_counter() + 0.3
            while time.perf_counter() < end:
                pass

    stats, trace = ServoLoop(sim, hx.Renderer(hx.algorithm("A", SINE, 500.0))).run(1.0, on_tick=on_tick)
    assert stats.ticks == 1000 and stats.jitter_seconds[0] < 0.1, stats.jitter_seconds
    ks = [s[0] for s in seen]
    assert ks == sorted(ks) and ks[-1] > 0
    for k, t, p, f in seen:  # each snapshot is one tick's, whole: its time and force as traced
        if 0 < k <= len(trace["time"]):
            assert t == trace["time"][k - 1] and tuple(trace["force"][k - 1]) == f


def _threads() -> dict:
    """This process's threads: {tid: the cores it may run on}."""
    out = {}
    for tid in os.listdir("/proc/self/task"):
        try:
            out[int(tid)] = frozenset(os.sched_getaffinity(int(tid)))
        except OSError:  # (ended meanwhile)
            pass
    return out


def _thread_names(tids) -> dict:
    """{tid: its name (/proc's comm)} for a failure's message."""
    out = {}
    for tid in tids:
        try:
            with open(f"/proc/self/task/{tid}/comm") as fh:
                out[tid] = fh.read().strip()
        except OSError:
            out[tid] = "(ended)"
    return out


@pytest.mark.skipif(not sys.platform.startswith("linux") or len(os.sched_getaffinity(0)) < 2,
                    reason="keeping a core awake needs Linux and two cores")
def test_keep_awake_pins_the_thread_and_a_companion_to_one_core_and_leaves_nothing_running():
    # keep_awake (issue 56): while the run goes, two new threads (the servo thread and its
    # spinning companion) are pinned to the same single core, the last of the process's; the
    # run's ticks are the plain run's to the bit but for the watchdog's zeros (below), and
    # when it returns both threads have ended
    before = _threads()
    during = []

    def on_tick(k, servo):
        if not during:
            during.append({t: c for t, c in _threads().items() if t not in before})

    traces = []
    for awake in (True, False):
        sim = SimulatedBackend("falcon", realtime=awake)  # (paced when kept awake: the dashboard is called)
        r = hx.Renderer(hx.algorithm("A", SINE, 500.0), max_force=sim.max_force)
        stats, trace = ServoLoop(sim, r, keep_awake=awake).run(400 * sim.period, on_tick=on_tick if awake else None)
        traces.append((stats, trace))
    (a, ta), (b, tb) = traces
    core = max(os.sched_getaffinity(0))
    assert a.awake_core == core and b.awake_core is None
    # the run's two threads are the new ones pinned to that core (a thread another test left
    # running may start one of its own meanwhile, with the process's whole affinity: not the
    # run's; one of five full runs of the suite failed here, cause not kept: named now)
    new = during[0]
    pinned = {t for t, c in new.items() if c == frozenset({core})}
    assert len(pinned) == 2, (new, _thread_names(new))
    assert not (set(_threads()) - set(before)) & pinned  # both ended with the run
    assert a.ticks == b.ticks == 400 and a.engaged_at == b.engaged_at is not None
    # the simulated device runs the same ticks, to the bit, until a sample of the paced run comes
    # late and the watchdog answers it with zero force (rule 2), as on a loaded machine: a
    # fresh-clone run beside other work failed here on the position (2026-11-27's sixth session)
    n = len(tb["engaged"])
    differ = np.flatnonzero(np.any(np.reshape(ta["position"], (n, -1)) != np.reshape(tb["position"], (n, -1)), axis=1)
                            | np.any(np.reshape(ta["force"], (n, -1)) != np.reshape(tb["force"], (n, -1)), axis=1)
                            | (np.asarray(ta["engaged"]) != np.asarray(tb["engaged"])))
    if differ.size:
        k = int(differ[0])
        assert a.missed > 0 and not np.any(np.reshape(ta["force"], (n, -1))[k]), (k, a.missed)


@pytest.mark.parametrize("case", ["python renderer", "python loop", "openhaptics"])
def test_keep_awake_is_refused_where_no_native_thread_runs(case, stubs):
    # nothing is silently ignored: a Python renderer, native=False, or OpenHaptics' own
    # scheduler has no thread of the C core's to keep on a core
    class PythonRenderer:  # a renderer whose tick is Python's
        dimension, clamps = 3, 0

        def step(self, p):
            return (0.0, 0.0, 0.0)

    backend = Rig("openhaptics", stubs).backend if case == "openhaptics" else SimulatedBackend("falcon", realtime=False)
    renderer = PythonRenderer() if case == "python renderer" else hx.Renderer(hx.algorithm("A", SINE, 500.0))
    with pytest.raises(hx.ParameterError, match=r"^keep_awake = True is not allowed: must be a "):
        ServoLoop(backend, renderer, native=case != "python loop", keep_awake=True).run(0.01)


def test_a_texture_changed_mid_run_is_taken_between_two_ticks_of_the_native_thread():
    # Renderer.set_algorithm (issue 56's parameter block, a whole model): the dashboard hands
    # the native thread another algorithm and texture once, about 0.4 s in; every force sent
    # after the ramp is, to the bit, the first renderer's at that tick's position up to one
    # tick and the second's from it on (both stateless: A and B), and the renderer took it once
    sim = SimulatedBackend("falcon", realtime=True)
    first, second = hx.algorithm("A", SINE, 500.0), hx.algorithm("B", hx.Extruded(hx.Sinusoid(0.3e-3, 1e-3)), 800.0)
    r = hx.Renderer(first, max_force=sim.max_force)

    def on_tick(k, servo):
        if k > 400 and r.algorithm is first:
            r.set_algorithm(second, limit=1000.0)

    loop = ServoLoop(sim, r)
    stats, trace = loop.run(1.0, on_tick=on_tick)
    assert stats.driver == "native thread" and r.algorithm_changes == 1 and r.stiffness == 800.0
    start = stats.engaged_at + loop.ramp_ticks + 1
    ra, rb = hx.Renderer(first, max_force=sim.max_force), hx.Renderer(second, max_force=sim.max_force)
    which = []  # at every tick where the two renderers differ: whose force was sent (a, b or neither)
    for k in range(start, stats.ticks):
        p, sent = tuple(trace["position"][k]), trace["force"][k].tolist()
        fa, fb = list(ra.step(p)), list(rb.step(p))
        if fa != fb and any(sent):  # (a zero sent: the watchdog's answer to a late sample)
            which.append("a" if sent == fa else "b" if sent == fb else "?")
    text = "".join(which)
    assert "?" not in text and text.count("a") > 20 and text.count("b") > 20, text
    assert text == "a" * text.count("a") + "b" * text.count("b"), text  # one change, between two ticks


def test_an_unsafe_or_mismatched_algorithm_is_refused_before_it_reaches_the_tick():
    r = hx.Renderer(hx.algorithm("A", SINE, 500.0))
    with pytest.raises(hx.ParameterError, match=r"^stiffness = '5000 N/m' is not allowed: must be at most 1000 N/m"):
        r.set_algorithm(hx.algorithm("A", SINE, 5000.0), limit=1000.0)
    with pytest.raises(hx.ParameterError, match=r"^algorithm = .* is not allowed: must be of this renderer's dimension"):
        r.set_algorithm(hx.algorithm("A", hx.Sinusoid(0.2e-3, 2e-3), 500.0))
    assert r.step((0.0, 0.0, -1e-4)) == hx.Renderer(hx.algorithm("A", SINE, 500.0)).step((0.0, 0.0, -1e-4))
    assert r.algorithm_changes == 0


@needs_cc
def test_the_native_force_dimension_thread_needs_no_gil(stubs):
    # DHD's functions called from the C core's thread by address: the device behind the stub in
    # C too (a 0.1 kg mass held 1 mm inside the wall by a 200 N/m, 2 N s/m hand), so nothing
    # in the thread needs Python; it keeps ticking while the GIL is held for 0.3 s
    stub = stubs["forcedimension"]
    stub.hxstub_bind_mass(0.1, 200.0, 2.0, 1e-3, (ctypes.c_double * 3)(0.0, 0.0, -1e-3), 33)
    b = open_backend("forcedimension:falcon")
    assert b.native
    loop = ServoLoop(b, hx.Renderer(hx.algorithm("A", SINE, 500.0), max_force=b.max_force), engage_force=1.0,
                     engage_ticks=5, ramp_ticks=10)
    holder = _hold_the_gil(0.3, 0.3)
    stats, trace = loop.run(1.0)
    holder.join()
    assert stats.driver == "native thread" and stats.ticks == 1000 and stats.jitter_seconds[0] < 0.1
    f = trace["force"]
    assert stats.engaged_at is not None and f[stats.engaged_at + 20:, 2].mean() > 0.0
    assert np.all(np.linalg.norm(f, axis=1) <= b.max_force * (1 + 1e-12))
    assert stub.hxstub_energised_after_close() == 0 and stub.hxstub_opened() == 0


@needs_cc
def test_a_device_that_stops_answering_stops_the_native_thread_with_zero_force(stubs):
    stub = stubs["forcedimension"]
    stub.hxstub_bind_mass(0.1, 200.0, 2.0, 1e-3, (ctypes.c_double * 3)(0.0, 0.0, -1e-3), 33)
    stub.hxstub_faults(300, -1, 0.0)  # unplugged after 300 forces (the zero of open is one)
    b = open_backend("forcedimension:falcon", realtime=False)
    with pytest.raises(DeviceError, match=r"stopped answering: a position read failed at tick 299; zero force") as e:
        _loop(b).run(1.0)
    assert "\n" not in str(e.value)
    assert stub.hxstub_energised_after_close() == 0 and stub.hxstub_opened() == 0


@needs_cc
def test_the_native_watchdog_zeroes_the_tick_after_a_slow_device(stubs):
    # one read takes 6 periods: the next sample is late, and its tick sends zero (rule 2)
    stub = stubs["forcedimension"]
    stub.hxstub_bind_mass(0.1, 200.0, 2.0, 1e-3, (ctypes.c_double * 3)(0.0, 0.0, -1e-3), 33)
    b = open_backend("forcedimension:falcon")
    stub.hxstub_faults(-1, 151, 6 * b.period)  # tick 150's read (after open's zero and 150 forces)
    stats, trace = _loop(b, ramp_ticks=10, engage_ticks=5, engage_force=1.0).run(300 * b.period)
    f = np.linalg.norm(trace["force"], axis=1)
    assert stats.missed >= 1 and stats.overruns >= 1 and stats.jitter_seconds[0] >= 4 * b.period
    assert f[150] > 0.0 and f[151] == 0.0  # the tick after the slow read
    assert stub.hxstub_energised_after_close() == 0


def test_a_priority_out_of_range_is_refused_by_name():
    sim = SimulatedBackend("falcon", realtime=False)
    with pytest.raises(hx.ParameterError, match="priority = 120 is not allowed"):
        ServoLoop(sim, hx.Renderer(hx.algorithm("A", SINE, 500.0)), priority=120)


@needs_cc
@pytest.mark.parametrize("kind", KINDS)
def test_a_force_commanded_directly_is_never_nan_never_over_the_maximum_and_a_bad_one_zeroes_the_device(kind, stubs):
    # The guide's rule for a force sent towards a device (never NaN, never above its maximum,
    # zero within one tick of any fault) held in the servo loop, which clamps before it sends;
    # a user's own loop calling backend.command() directly got numpy's ValueError for text or a
    # wrong shape (the device kept its last force), and on Force Dimension's and OpenHaptics'
    # backends NaN and 1e3 N went to the vendor's SDK as given. Now each backend sends a force
    # above the maximum scaled to it (as the simulated backend, and amplifiers, clip), and for
    # a force that is not 3 finite numbers sends zero, then refuses it naming `force`.
    rig = Rig(kind, stubs)
    b = rig.backend
    b.open()
    try:
        sent = []
        for force in ([0.5, 0.0, 0.0], [1e3, 0.0, 0.0], [np.nan, 0.0, 0.0], "nonsense", [1.0, 2.0], None):
            b.sample()
            bad = not (isinstance(force, list) and len(force) == 3 and np.all(np.isfinite(force)))
            if bad:
                with pytest.raises(hx.ParameterError, match=r"^force = "):
                    b.command(force)
            else:
                b.command(force)
            sent.append(bad)
        b.sample()
    finally:
        b.close()
    motors = rig.motors() if rig.behind is not None else None
    if motors is None:  # (the simulated device: its held force after each command is its own)
        return
    assert np.all(np.isfinite(motors)) and np.all(np.linalg.norm(motors, axis=1) <= b.max_force * (1 + 1e-6))
    assert np.linalg.norm(motors, axis=1).max() == pytest.approx(b.max_force, rel=1e-6)  # (the 1 kN, scaled)
    assert np.all(motors[-1] == 0.0)  # (the last command refused: zero sent before the refusal)
