"""The servo loop on every backend (issues 34 and 56): missed deadlines and the tick's own time,
idle and under load.

Each backend renders algorithm A over the paper-style sinusoid extruded across y (0.2 mm, 2 mm,
500 N/m) for SECONDS (default 60) with the light-touch hand pressing 1 mm in, through
haptex.servo.ServoLoop (the safety rules in C, hx_servo.c):

- simulated: simulated:falcon at 1 kHz in the C core's native servo thread (hx_thread.c: the
  device, the rules and the tick in C, no GIL); simulated-python: the same from Python's loop;
- forcedimension: a stub of libdrd built by the tests (tests/stubs/dhd_stub.c) whose
  dhdGetPosition and dhdSetForce the native servo thread calls by address at the omega.3's
  4 kHz, haptex's simulator behind the stub (reached through ctypes callbacks, which take the
  GIL); forcedimension-c-device: the same with a device in C behind the stub (a 0.1 kg mass
  held by a 200 N/m, 2 N s/m hand 1 mm inside): nothing in the servo thread touches Python;
  forcedimension-python: the vendor's binding (forcedimension-core) polled from Python's loop,
  the simulator behind;
- openhaptics: the vendor's binding (pyOpenHaptics) on a stub of libHD whose scheduler thread
  calls the C core's native callback at 1 kHz (sample, rules and tick in C, no GIL), haptex's
  simulator behind the stub (reached through ctypes callbacks, which take the GIL);
- openhaptics-c-device: the same with a device in C behind the stub (a 0.1 kg mass held by a
  200 N/m, 2 N s/m hand 1 mm inside): nothing in the servo thread touches Python;
- openhaptics-python: the Python callback in HD's thread (takes the GIL each tick), the
  simulator behind;
- haply: the Inverse Service's WebSocket JSON against the emulator of tests/vendor_stubs.py
  (1 kHz lock-step; the emulator is Python in the same process, so it competes for the GIL);
- haply-process: the same emulator in a process of its own, as the real service is: what the
  backend's lock-step loop does alone in its process;
- haply-serial: the C core's native servo thread speaking the Inverse3's serial exchanges itself
  (hx_haply.c) on a pseudo-terminal whose far end is the serial emulator of
  tests/vendor_stubs.py (1 kHz lock-step, Python in the same process: the device's answers take
  the GIL there, not in the servo thread);
- haply-serial-process: the same emulator in a process of its own, as a device is;
- haply-serial-c-device: the native thread against an Inverse3 in C behind the pseudo-terminal
  (tests/stubs/inverse3_stub.c, its own process: a 0.1 kg mass held by a 200 N/m, 2 N s/m hand
  1 mm inside, each answer a period after the last on the monotonic clock, at SCHED_FIFO where
  allowed: a device is hardware the host's load does not slow): nothing on either side of the
  port is Python;
- haply-serial-python: Haply's own package (HaplyHardwareAPI) from Python's loop, the emulator in
  its own process.

A deadline is missed when a sample comes more than 1.5 periods after the previous one. The
first rows are the plain C loop of benchmarks/pace_reference.c (a thread waking at 1 and 4 kHz
and doing nothing else), run for as long: what this machine misses with no work at all.
Columns: the rate, ticks, missed deadlines, overruns (native thread: a tick's force sent after
the next was due), the period's jitter |dt - T| at 99.9 % and worst, the tick's work at 99.9 %
and worst, and the driver (native thread, with F when it got SCHED_FIFO).

--load runs every row under load: a process spinning on every core (nice 0) and, in this
process, a Python thread allocating and freeing 6.4 MB a round (the garbage a plot or a
browser session makes), started before the rows and stopped after.

--keep-awake runs the rows of the C core's own servo thread (simulated, forcedimension,
forcedimension-c-device, haply-serial*, not -python) with ServoLoop(keep_awake=True): the thread
pinned to the last core, a companion spinning below it there so that the core never halts
(driver "thread F+awake").

--every instead runs the simulated backend on every preset (at the preset's own rate: 1, 4 or
10 kHz) with every algorithm, W, A-G and the god-object proxy, for --seconds each (default 10
there), between two runs of the plain C loop at 1 kHz.
Options: --seconds S, --only KIND[,KIND], --load, --keep-awake, --every [--presets A,B]. Needs a C compiler for the two stubs and the
reference.
"""

from __future__ import annotations

import argparse
import ctypes
import subprocess
import sys
import tempfile
from pathlib import Path

import haptex as hx
from haptex.backends import open_backend
from haptex.backends.simulated import SimulatedBackend
from haptex.servo import ServoLoop

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from tests import vendor_stubs as vs  # noqa: E402

SINE = hx.Extruded(hx.Sinusoid(0.2e-3, 2e-3))
KINDS = ["simulated", "simulated-python", "forcedimension", "forcedimension-c-device", "forcedimension-python",
         "openhaptics", "openhaptics-c-device", "openhaptics-python", "haply", "haply-process", "haply-serial",
         "haply-serial-process", "haply-serial-c-device", "haply-serial-python"]


def backend(kind: str, root: Path, stubs: dict):
    if kind.startswith("simulated"):
        return open_backend("simulated:falcon"), None
    if kind == "forcedimension-c-device":
        stubs["dhd"].hxstub_bind_mass(0.1, 200.0, 2.0, 2.5e-4, (ctypes.c_double * 3)(0.0, 0.0, -1e-3), 33)
        return open_backend("forcedimension"), None
    if kind.startswith("forcedimension"):
        behind = vs.Behind(SimulatedBackend("omega-3", realtime=False))
        stubs["dhd"].hxstub_bind(behind.read, behind.write, 33, 1)
        return open_backend("forcedimension"), behind
    if kind == "openhaptics-c-device":
        stubs["hd"].hxstub_bind_mass(0.1, 200.0, 2.0, (ctypes.c_double * 3)(0.0, -1.0, 0.0), b"Touch", 3.3)
        return open_backend("openhaptics"), None
    if kind.startswith("openhaptics"):
        behind = vs.Behind(SimulatedBackend("touch", realtime=False), vs.HD_FROM_HAPTEX, 1e3)
        stubs["hd"].hxstub_bind(behind.read, behind.write, b"Touch", 3.3, 1)
        b = open_backend("openhaptics")
        b.native = kind == "openhaptics"
        return b, behind
    if kind == "haply-serial-c-device":  # the Inverse3 in C, its port on its first line
        exe = root / "inverse3"
        subprocess.run([vs.compiler(), "-std=c99", "-O2", "-o", str(exe), str(Path(__file__).resolve().parents[1] / "tests"
                        / "stubs" / "inverse3_stub.c")], check=True)
        proc = subprocess.Popen([str(exe)], stdout=subprocess.PIPE, text=True)
        try:  # a device is its own hardware, which the host's load does not slow: the stub at SCHED_FIFO
            import os

            os.sched_setscheduler(proc.pid, os.SCHED_FIFO, os.sched_param(70))
        except (AttributeError, PermissionError, OSError):
            print("(the Inverse3 stub runs at normal priority: SCHED_FIFO was refused)", flush=True)
        return open_backend("haply-serial:" + proc.stdout.readline().strip()), proc
    if kind.endswith("-process") or kind == "haply-serial-python":  # the emulator in its own process: its address
        emulator, where, spec = (("InverseSerial", "port", "haply-serial:") if kind.startswith("haply-serial") else
                                 ("InverseService", "address", "haply:"))
        code = ("import sys, time; sys.path.insert(0, %r); from tests import vendor_stubs as vs; "
                "from haptex.backends.simulated import SimulatedBackend; "
                "s = vs.%s(SimulatedBackend('inverse3', realtime=False)); print(s.%s, flush=True); "
                "time.sleep(3600)") % (str(Path(__file__).resolve().parents[1]), emulator, where)
        proc = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, text=True)
        return open_backend(spec + proc.stdout.readline().strip()), proc
    if kind == "haply-serial":
        emulator = vs.InverseSerial(SimulatedBackend("inverse3", realtime=False))
        return open_backend("haply-serial:" + emulator.port), emulator
    service = vs.InverseService(SimulatedBackend("inverse3", realtime=False))
    return open_backend("haply:" + service.address), service


def plain_loop(folder: Path, seconds: float, rate: float = 1000.0) -> str:
    """The row of the plain C loop at ``rate`` Hz for ``seconds``."""
    pace = folder / "pace"
    if not pace.exists():
        subprocess.run([vs.compiler(), "-std=c99", "-D_POSIX_C_SOURCE=200809L", "-O2", "-o", str(pace),
                        str(Path(__file__).with_name("pace_reference.c"))], check=True)
    n, missed, worst = subprocess.run([str(pace), str(seconds), str(rate)], capture_output=True, text=True,
                                      check=True).stdout.split()
    return (f"{'plain C loop':21} {'pace_reference.c':28} {rate:6.0f}/s {int(n):7d} {int(missed):6d} "
            f"({100 * int(missed) / int(n):5.3f} %) {'':>9} {'':>10} {'':>11}  (worst period "
            f"{float(worst) * 1e3:.2f} ms)")


class Load:
    """A process spinning on every core and a Python thread allocating in this one."""

    def __enter__(self):
        import os
        import threading

        self.hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(os.cpu_count() or 1)]
        self.running = True

        def churn():
            while self.running:
                junk = [bytearray(1 << 16) for _ in range(100)]
                del junk

        self.thread = threading.Thread(target=churn, daemon=True)
        self.thread.start()
        return self

    def __exit__(self, *exc):
        self.running = False
        self.thread.join()
        for h in self.hogs:
            h.kill()
            h.wait()


def row(kind: str, b, st) -> str:
    """One backend's row: rate, ticks, missed, overruns, jitter and work at 99.9 % and worst, driver."""
    share = 100 * st.missed / max(st.ticks, 1)
    driver = {"native thread": "thread", "native callback": "C callback", "vendor callback": "Py callback",
              "python loop": "Python"}[st.driver] + (" F" if st.fifo else "") + (
              "+awake" if st.awake_core is not None else "")
    return (f"{kind:24} {1 / b.period:6.0f}/s {st.ticks:7d} {st.missed:6d} ({share:6.3f} %) {st.overruns:5d} "
            f"{st.jitter_seconds[1] * 1e6:8.1f} {st.jitter_seconds[0] * 1e6:8.0f} {st.tick_p999 * 1e6:7.1f} "
            f"{st.tick_seconds[0] * 1e6:7.0f}  {driver}")


HEADER = (f"{'kind':24} {'rate':>8} {'ticks':>7} {'missed':>16} {'over':>5} {'jit99.9':>8} {'jit max':>8} "
          f"{'tick99.9':>7} {'tick max':>7}  driver   (times in us)")


def every(seconds: float, only: str | None = None) -> None:
    """Every preset (or those of the comma-separated ``only``) x every algorithm on the simulated
    backend (the light-touch hand, 1 mm in)."""
    import math

    from haptex.catalogue import presets
    from haptex.proxy import GodObject
    from haptex.textures import Flat

    with tempfile.TemporaryDirectory() as tmp:
        print(f"{'preset / algorithm':21} {'backend':28} {'rate':>7} {'ticks':>7} {'missed':>14} {'period σ':>9} "
              f"{'tick mean':>10} {'tick worst':>11}")
        print(plain_loop(Path(tmp), seconds))
        total = [0, 0]
        for key in presets():
            if only and key not in only.split(","):
                continue
            b = open_backend(f"simulated:{key}")
            tex = hx.Sinusoid(0.2e-3, 2e-3) if b.dimension == 2 else SINE
            for letter in ("W", *"ABCDEFG", "proxy"):
                if letter == "W":
                    alg = hx.algorithm("W", None if b.dimension == 2 else Flat(dimension=2), 500.0)
                elif letter == "proxy":
                    alg = GodObject(tex, 500.0)
                else:
                    alg = hx.algorithm(letter, tex, 500.0)
                r = hx.Renderer(alg, max_force=b.max_force if math.isfinite(b.max_force) else None,
                                energy_monitor=True)
                st, _ = ServoLoop(b, r).run(seconds, record=False)
                total[0] += st.missed
                total[1] += st.ticks
                print(f"{key + ' ' + letter:21} {b.name:28} {1 / b.period:6.0f}/s {st.ticks:7d} {st.missed:6d} "
                      f"({100 * st.missed / st.ticks:5.3f} %) {st.period_seconds[1] * 1e6:7.0f} us "
                      f"{st.tick_seconds[1] * 1e6:7.1f} us {st.tick_seconds[0] * 1e6:8.0f} us", flush=True)
        print(f"{'all':21} {'':28} {'':>7} {total[1]:7d} {total[0]:6d} ({100 * total[0] / total[1]:5.3f} %)")
        print(plain_loop(Path(tmp), seconds))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--seconds", type=float, default=None)
    ap.add_argument("--only", help="comma-separated kinds: " + ", ".join(KINDS))
    ap.add_argument("--load", action="store_true", help="every row under load (see above)")
    ap.add_argument("--keep-awake", action="store_true", help="the native thread's rows with keep_awake (see above)")
    ap.add_argument("--every", action="store_true")
    ap.add_argument("--presets", help="with --every: these presets only (comma-separated)")
    args = ap.parse_args()
    if args.every:
        every(args.seconds or 10.0, args.presets)
        return
    args.seconds = args.seconds or 60.0
    import contextlib

    kinds = args.only.split(",") if args.only else KINDS
    unknown = sorted(set(kinds) - set(KINDS))
    if unknown:
        ap.error(f"--only {unknown[0]!r} is not a kind: {', '.join(KINDS)}")
    with tempfile.TemporaryDirectory() as tmp, (Load() if args.load else contextlib.nullcontext()):
        root = Path(tmp)
        vs.build_dhd(root / "fdsdk")
        stubs = {"dhd": vs.load_dhd(root / "fdsdk"), "hd": vs.load_hd(vs.build_hd(root / "hd"))}
        print(f"{'under load' if args.load else 'idle'}: {args.seconds:g} s a row"
              f"{', the native thread keeping its core awake' if args.keep_awake else ''}", flush=True)
        print(HEADER)
        for rate in (1000.0, 4000.0):
            print(plain_loop(root, args.seconds, rate), flush=True)
        for kind in kinds:
            b, behind = backend(kind, root, stubs)
            r = hx.Renderer(hx.algorithm("A", SINE, 500.0), max_force=b.max_force, energy_monitor=True)
            native = not kind.endswith("-python") or kind.startswith("openhaptics")
            awake = args.keep_awake and native and kind.startswith(("simulated", "forcedimension", "haply-serial"))
            try:
                st, _ = ServoLoop(b, r, native=native, keep_awake=awake).run(args.seconds, record=False)
            finally:
                if isinstance(behind, subprocess.Popen):
                    behind.kill()
            print(row(kind, b, st), flush=True)


if __name__ == "__main__":
    main()
