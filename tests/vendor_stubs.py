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
        self.truth = self.sim._x[:3].copy()  # the handle's true position at the reading (m)
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
        self.truth = self.sim._x[:3].copy()  # the handle's true position at the reading (m)
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
        import time

        self.connections += 1
        self.connected = True
        applied = np.zeros(3)
        sent, k = -math.inf, 0
        try:
            while True:
                due = sent + self.PERIOD  # (a period after the last state, late or not: no bursts)
                while time.perf_counter() < due:
                    time.sleep(min(2e-4, max(0.0, due - time.perf_counter())))
                sent = time.perf_counter()
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
