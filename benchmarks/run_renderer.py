"""Renderer latency per algorithm: Renderer.step called from Python (median and 99th
percentile of single calls), the compiled kernel alone (mean per call in a compiled
loop), and the same force arithmetic in plain C (gcc -O2) for A and D.

Run:  python benchmarks/run_renderer.py [--calls 100000]
Reported in benchmarks/README.md; never part of the test run.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time

import numba as nb
import numpy as np

import haptex as hx
from haptex import _kernels

try:
    from run_sim import build_reference, c_reference
except ImportError:  # run from the repository root
    from benchmarks.run_sim import build_reference, c_reference


@nb.njit(cache=True)
def _kernel_loop(xs, zs, code, kind, coeffs, prm, aux, st, rs):
    acc = 0.0
    for i in range(xs.shape[0]):
        fx, fz = _kernels.render_step(xs[i], zs[i], code, kind, coeffs, prm, aux, st, rs)
        acc += fx + fz
    return acc


def trajectory(tex, letter, n):
    """A 10 mm/s scan sampled at 10 kHz (1 um a call), 0.4 mm inside the wall."""
    x = np.arange(n) * 1e-6
    z = (-0.4e-3 + 0 * x) if letter in "WFG" else tex.height(x) - 0.4e-3
    return x, z


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--calls", type=int, default=100_000)
    args = ap.parse_args()
    n = args.calls
    tex = hx.Sinusoid(0.8e-3, 1e-3)
    # cost of the timer itself, subtracted from single-call timings
    probe = np.empty(10000)
    for i in range(probe.size):
        t0 = time.perf_counter_ns()
        probe[i] = time.perf_counter_ns() - t0
    timer = float(np.median(probe))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        exe = build_reference(tmp)
        for letter in "WABCDEFG":
            alg = hx.algorithm(letter, None if letter == "W" else tex, 2000.0)
            r = hx.Renderer(alg, max_force=10.0, energy_monitor=True)
            xs, zs = trajectory(tex, letter, n)
            pts = list(zip(xs.tolist(), zs.tolist()))
            lat = np.empty(n)
            step = r.step
            for i, p in enumerate(pts):
                t0 = time.perf_counter_ns()
                step(p)
                lat[i] = time.perf_counter_ns() - t0
            lat -= timer
            r.reset()
            _kernel_loop(xs[:10], zs[:10], r._code, r._kind, r._coeffs, r._prm, r._aux, r._st, r._rs)
            r.reset()
            t0 = time.perf_counter()
            _kernel_loop(xs, zs, r._code, r._kind, r._coeffs, r._prm, r._aux, r._st, r._rs)
            kern = (time.perf_counter() - t0) / n * 1e9
            c_ns = math.nan
            if letter in "AD":
                dev = hx.Device.point_mass()
                c_ns = c_reference(alg, dev, hx.operators.ConstantForce([0.0, 0.0]), n, 1, tmp, exe, render=True)
            rows.append((letter, np.median(lat) / 1e3, np.percentile(lat, 99) / 1e3, kern, c_ns))
    print(f"timer overhead subtracted: {timer:.0f} ns")
    print(f"{'alg':4} {'step median (us)':>17} {'step p99 (us)':>14} {'kernel (ns/call)':>17} {'C -O2 (ns/call)':>16}")
    for letter, med, p99, kern, c_ns in rows:
        c_txt = "" if math.isnan(c_ns) else f"{c_ns:16.0f}"
        print(f"{letter:4} {med:17.2f} {p99:14.2f} {kern:17.0f} {c_txt}")


if __name__ == "__main__":
    main()
