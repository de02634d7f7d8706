"""Identification's time (issue 65: a 10 s log identified in < 10 s on one core): `haptex.identify`
on 10 s logs of haptex's own sampled-data simulation (`identification.simulated_log`: timing needs
no independent truth; the figures' accuracy is the tests' and the identification guide's), at 1
and 4 kHz, with and without an encoder, and a handle whose time constant asks for the second, 1 s
window fit; BLAS held to one thread. Best of 3, one identification at a time.

Run:  python benchmarks/run_identify.py
Reported in benchmarks/README.md; never part of the test run.
"""

from __future__ import annotations

import os

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")  # one core: before numpy is imported
os.environ.setdefault("OMP_NUM_THREADS", "1")

import time  # noqa: E402

import haptex as hx  # noqa: E402
from haptex import identification as I  # noqa: E402

CASES = [  # (label, Device parameters)
    ("120 g, 0.8 N s/m, 50 mN, 20 um, 1 kHz, delay 1",
     dict(mass=0.12, damping=0.8, period=1e-3, delay=1, position_resolution=20e-6, coulomb_friction=0.05)),
    ("300 g, 2 N s/m, 0.2 N, 63.5 um, 1 kHz, delay 0",
     dict(mass=0.3, damping=2.0, period=1e-3, delay=0, position_resolution=63.5e-6, coulomb_friction=0.2)),
    ("50 g, 0.4 N s/m, 10 mN, 5 um, 4 kHz, delay 2",
     dict(mass=0.05, damping=0.4, period=0.25e-3, delay=2, position_resolution=5e-6, coulomb_friction=0.01)),
    ("50 g, 0.1 N s/m, 0.2 N, 60 um, 4 kHz, delay 4 (the sweep's slowest)",
     dict(mass=0.05, damping=0.1, period=0.25e-3, delay=4, position_resolution=60e-6, coulomb_friction=0.2)),
    ("120 g, 0.8 N s/m, 50 mN, continuous, 1 kHz, delay 3",
     dict(mass=0.12, damping=0.8, period=1e-3, delay=3, position_resolution=0.0, coulomb_friction=0.05)),
    ("500 g, 0.1 N s/m, 0.2 N, 60 um, 1 kHz, delay 1 (5 s time constant)",
     dict(mass=0.5, damping=0.1, period=1e-3, delay=1, position_resolution=60e-6, coulomb_friction=0.2)),
]


def main() -> None:
    print(f"{'device (10 s log)':66} {'s, best of 3':>12}  windows  note")
    for label, kw in CASES:
        t, p, f = I.simulated_log(hx.Device(**kw), 10.0, 1.0, seed=1)
        best, r = float("inf"), None
        for _ in range(3):
            t0 = time.perf_counter()
            r = I.identify(time=t, position=p, force=f)
            best = min(best, time.perf_counter() - t0)
        second = any(n.startswith("window ") for n in r.notes)
        print(f"{label:66} {best:12.2f}  {r.windows:7d}  {'two fits (1 s windows kept)' if second else ''}")


if __name__ == "__main__":
    main()
