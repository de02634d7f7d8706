"""Stubs of the vendors' native libraries, built here, with haptex's simulator behind them.

The vendors' own Python bindings (forcedimension-core, pyOpenHaptics) are installed from PyPI
and load these in place of the SDKs' libraries, as they would the real ones:

- ``libdrd.so.3.16.0`` (Force Dimension) under ``FDSDK/lib/release/lin-<machine>-gcc``, found
  by forcedimension-core through ``FDSDK``. The binding sets the signature of every DHD and
  DRD function at import, so each one it names and ``stubs/dhd_stub.c`` does not define is
  generated here as a function that fails (NOT_IMPLEMENTED).
- ``libHD.so`` (OpenHaptics), loaded first with RTLD_GLOBAL so that pyOpenHaptics'
  ``CDLL("libHD.so")`` finds it by its soname.

The device behind each stub is :class:`haptex.backends.simulated.SimulatedBackend` (a preset
held by a hand, not paced: the stub's caller paces), seen in the vendor's units and frame.
"""

from __future__ import annotations

import ctypes
import importlib.util
import math
import os
import platform
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np

STUBS = Path(__file__).parent / "stubs"
CALLBACK = ctypes.CFUNCTYPE(None, ctypes.POINTER(ctypes.c_double))


def compiler() -> str | None:
    return shutil.which("cc") or shutil.which("gcc")


def _defined(c_source: str) -> set[str]:
    return set(re.findall(r"^[A-Za-z][\w \*]*?\b(dhd\w+|drd\w+)\(", c_source, flags=re.M))


def build_dhd(folder: Path) -> Path:
    """Build the DHD stub as the SDK's layout under ``folder`` (the value for FDSDK); returns
    the library's path."""
    spec = importlib.util.find_spec("forcedimension_core")
    pkg = Path(spec.origin).parent
    named = set()
    for f in pkg.rglob("*.py"):
        named |= set(re.findall(r"_lib(?:dhd|drd)\.((?:dhd|drd)\w+)", f.read_text()))
    src = (STUBS / "dhd_stub.c").read_text()
    missing = sorted(named - _defined(src))
    gen = folder / "dhd_generated.c"
    folder.mkdir(parents=True, exist_ok=True)
    gen.write_text("int hxstub_unsupported(void);\n" +
                   "".join(f"int {n}(void) {{ return hxstub_unsupported(); }}\n" for n in missing))
    lib = folder / "lib" / "release" / f"lin-{platform.machine()}-gcc" / "libdrd.so.3.16.0"
    lib.parent.mkdir(parents=True, exist_ok=True)
    subprocess.run([compiler(), "-std=c99", "-O2", "-fPIC", "-shared", "-o", str(lib), str(STUBS / "dhd_stub.c"),
                    str(gen)], check=True, capture_output=True)
    return lib


def build_hd(folder: Path) -> Path:
    """Build the HD stub (soname libHD.so) in ``folder``; returns the library's path."""
    folder.mkdir(parents=True, exist_ok=True)
    lib = folder / "libHD.so"
    subprocess.run([compiler(), "-std=c99", "-D_POSIX_C_SOURCE=200809L", "-O2", "-fPIC", "-shared", "-pthread",
                    "-Wl,-soname,libHD.so", "-o", str(lib), str(STUBS / "hd_stub.c")], check=True,
                   capture_output=True)
    return lib


class Behind:
    """A simulated preset as the device behind a stub: the stub reads its state and writes its
    force through two C callbacks, in the vendor's units (``scale`` per metre) and frame
    (``R`` maps haptex's axes to the vendor's: v_vendor = R v_haptex)."""

    def __init__(self, sim, R=np.eye(3), scale=1.0):
        self.sim, self.R, self.scale = sim, np.asarray(R, dtype=float), float(scale)
        self.forces = []  # what reached the motors, haptex's frame (N)
        self.read = CALLBACK(self._read)
        self.write = CALLBACK(self._write)
        sim.open()

    def _read(self, st):
        self.truth = self.sim.state[:3].copy()  # the handle's true position at the reading (m)
        s = self.sim.sample()
        p = self.R @ s.position * self.scale
        v = self.R @ (np.zeros(3) if s.velocity is None else s.velocity) * self.scale
        for i in range(3):
            st[i], st[3 + i] = p[i], v[i]
        st[6] = 0.0

    def _write(self, f):
        fh = self.R.T @ np.array([f[0], f[1], f[2]])
        self.forces.append(fh)
        self.sim.command(fh)


def load_dhd(fdsdk: Path):
    """Point forcedimension-core at the stub and load it; returns the stub's ctypes handle."""
    os.environ["FDSDK"] = str(fdsdk)
    lib = next((fdsdk / "lib" / "release").glob("*/libdrd.so.*"))
    stub = ctypes.CDLL(str(lib))
    stub.hxstub_bind.argtypes = [CALLBACK, CALLBACK, ctypes.c_int, ctypes.c_int]
    stub.hxstub_bind_mass.argtypes = [ctypes.c_double, ctypes.c_double, ctypes.c_double, ctypes.c_double,
                                      ctypes.POINTER(ctypes.c_double), ctypes.c_int]
    stub.hxstub_faults.argtypes = [ctypes.c_long, ctypes.c_long, ctypes.c_double]
    stub.hxstub_applied.argtypes = [ctypes.POINTER(ctypes.c_double)]
    stub.hxstub_writes.restype = stub.hxstub_energised_after_close.restype = ctypes.c_long
    return stub


def load_hd(lib: Path):
    """Load the HD stub globally (pyOpenHaptics then finds it by name); returns its handle."""
    stub = ctypes.CDLL(str(lib), mode=ctypes.RTLD_GLOBAL)
    stub.hxstub_bind.argtypes = [CALLBACK, CALLBACK, ctypes.c_char_p, ctypes.c_double, ctypes.c_int]
    stub.hxstub_frames.restype = stub.hxstub_energised_after_stop.restype = ctypes.c_long
    stub.hxstub_bind_mass.argtypes = [ctypes.c_double, ctypes.c_double, ctypes.c_double,
                                      ctypes.POINTER(ctypes.c_double), ctypes.c_char_p, ctypes.c_double]
    stub.hxstub_mass_position.argtypes = [ctypes.POINTER(ctypes.c_double)]
    return stub


HD_FROM_HAPTEX = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
"""v_HD = R v_haptex: HD's x right, y up, z towards the user; haptex's z up, y away from the
user (OpenHaptics' programmer's guide for HD's frame)."""


def _paced(due: float) -> float:
    """Wait, in sleeps of at most 0.2 ms, until ``time.perf_counter() >= due``; returns the
    time it returns at (s): an emulator's clock, one message a period."""
    import time

    while time.perf_counter() < due:
        time.sleep(min(2e-4, max(0.0, due - time.perf_counter())))
    return time.perf_counter()


class InverseService:
    """An emulator of Haply's Inverse Service on 127.0.0.1 (a free port): one Inverse3, the
    device behind it a simulated preset, lock-step at 1 kHz: at each tick it sends the state
    (m, m/s), waits for the client's command (N) and advances the device one period under it
    (zero when the answer is not a force for this device). Messages as
    haptex.backends.haply's docstring gives them.

    ``garble`` maps a tick to a message sent instead of that tick's state (hostile input), or to
    None: the service closes the connection there.
    A client that disconnects leaves the last force it commanded applied (the worst case: what
    the real service does then is not documented here), counted in ``energised_after_close``."""

    DEVICE_ID = "inverse3-emulated"
    PERIOD = 1e-3

    def __init__(self, sim, garble=None, grip=True, velocity=True):
        import threading

        from websockets.sync.server import serve

        self.sim, self.garble, self.grip, self.velocity = sim, dict(garble or {}), grip, velocity
        self.steps = max(1, round(self.PERIOD / sim.period))
        sim.open()
        self.forces, self.connections, self.energised_after_close, self.connected = [], 0, 0, False
        self._server = serve(self._session, "127.0.0.1", 0, compression=None)
        self.address = f"ws://127.0.0.1:{self._server.socket.getsockname()[1]}"
        self._thread = threading.Thread(target=self._server.serve_forever, daemon=True)
        self._thread.start()

    def _state(self, k):
        import json

        if k in self.garble:
            return self.garble[k]
        self.truth = self.sim.state[:3].copy()  # the handle's true position at the reading (m)
        s = self.sim.sample()
        v = np.zeros(3) if s.velocity is None else s.velocity
        state = {"cursor_position": dict(zip("xyz", map(float, s.position)))}
        if self.velocity:
            state["cursor_velocity"] = dict(zip("xyz", map(float, v)))
        msg = {"inverse3": [{"device_id": self.DEVICE_ID, "state": state}]}
        if self.grip:
            msg["wireless_verse_grip"] = [{"device_id": "grip", "state": {"buttons": {"a": False, "b": True,
                                                                                    "c": False}}}]
        return json.dumps(msg)

    def _session(self, ws):
        import json

        self.connections += 1
        self.connected = True
        applied = np.zeros(3)
        sent, k = -math.inf, 0
        try:
            while True:
                sent = _paced(sent + self.PERIOD)  # (a period after the last state, late or not: no bursts)
                message = self._state(k)
                if message is None:
                    break
                ws.send(message)
                try:
                    answer = json.loads(ws.recv(timeout=2.0))
                    cmd = answer["inverse3"][0]
                    vals = cmd["commands"]["set_cursor_force"]["values"]
                    f = np.array([float(vals[a]) for a in "xyz"]) if cmd["device_id"] == self.DEVICE_ID else 0 * applied
                except (ValueError, KeyError, TypeError, IndexError):
                    f = np.zeros(3)
                applied = f
                self.forces.append(f)
                for _ in range(self.steps):  # the force held over the service's period
                    self.sim.command(f)
                k += 1
        except Exception as exc:  # noqa: BLE001 -- the client closed: the session ends
            self.ended = exc
        finally:
            if np.any(applied != 0.0):
                self.energised_after_close += 1
            self.connected = False

    def stop(self):
        self._server.shutdown()


class InverseSerial:
    """An emulator of an Inverse3 on a serial port: a pseudo-terminal whose far end answers
    Haply's hardware API (HaplyHardwareAPI) as haptex.backends.haply_serial's docstring gives
    the exchanges: the wakeup 0x0A answered with 0x0B and the device's info; a force command
    0x2A + 3 float32 (N) answered, a period after the previous answer, with 0x2B + position (m)
    and velocity (m/s) as 6 float32, the device behind it a simulated preset advanced one period
    under the force (lock-step at 1 kHz, like :class:`InverseService`).

    ``garble`` maps a force command's index (counted over the emulator's life) to bytes sent
    instead of that command's answer (hostile input), or to None: no answer at all (a device
    gone). A client that closes the port leaves the last force applied (the worst case),
    counted in ``energised_after_close``."""

    PERIOD = 1e-3
    INFO = (0x1234, 7, 3, 12)  # device id, model number, hardware and firmware versions (chosen)
    UUID = bytes(range(16))

    def __init__(self, sim, garble=None):
        import pty
        import threading
        import tty

        self.sim, self.garble = sim, dict(garble or {})
        self.steps = max(1, round(self.PERIOD / sim.period))
        sim.open()
        self.forces, self.wakeups, self.commands, self.energised_after_close = [], 0, 0, 0
        self.applied = np.zeros(3)
        self._open, self._sent = False, -math.inf
        self._master, slave = pty.openpty()
        tty.setraw(slave)
        self.port = os.ttyname(slave)
        os.close(slave)  # (the backend opens the port by its path; EIO on the master: no one has it open)
        self._running = True
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    @property
    def connected(self) -> bool:
        return self._open

    def _answer(self, payload: bytes) -> None:
        self._sent = _paced(self._sent + self.PERIOD)  # (a period after the last answer, late or not: no bursts)
        os.write(self._master, payload)

    def _serve(self) -> None:
        import select
        import struct
        import time

        buf, idle = b"", 1e-3
        while self._running:
            r, _, _ = select.select([self._master], [], [], 0.01)
            if not r:
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:  # EIO: the port is closed at the other end (polled ever less often, to 50 ms)
                if self._open and np.any(self.applied != 0.0):
                    self.energised_after_close += 1
                self._open, buf = False, b""
                time.sleep(idle)
                idle = min(0.05, 2 * idle)
                continue
            self._open, idle = True, 1e-3
            buf += data
            while buf:
                if buf[0] == 0x0A:
                    buf = buf[1:]
                    self.wakeups += 1
                    self._answer(b"\x0b" + struct.pack("<HBBB", *self.INFO) + self.UUID)
                elif buf[0] == 0x2A:
                    if len(buf) < 13:
                        break
                    f = np.array(struct.unpack("<3f", buf[1:13]), dtype=np.float64)
                    buf = buf[13:]
                    k, self.commands = self.commands, self.commands + 1
                    self.applied = f
                    self.forces.append(f)
                    for _ in range(self.steps):  # the force held over the device's period
                        self.sim.command(f)
                    if k in self.garble:
                        if self.garble[k] is not None:
                            self._answer(self.garble[k])
                        continue
                    self.truth = self.sim.state[:3].copy()  # the handle's true position at the reading (m)
                    s = self.sim.sample()
                    v = np.zeros(3) if s.velocity is None else s.velocity
                    self.answered = np.asarray(s.position, dtype=np.float64)  # (the last state sent, as sent)
                    self._answer(b"\x2b" + struct.pack("<6f", *s.position, *v))
                else:  # not a request this emulator knows: dropped
                    buf = buf[1:]

    def stop(self) -> None:
        self._running = False
        self._thread.join()
        os.close(self._master)
