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
    return stub


HD_FROM_HAPTEX = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])
"""v_HD = R v_haptex: HD's x right, y up, z towards the user; haptex's z up, y away from the
user (OpenHaptics' programmer's guide for HD's frame)."""
