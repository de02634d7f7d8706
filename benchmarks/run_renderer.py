"""Renderer latency per algorithm: Renderer.step called from Python (median and 99th
percentile of single calls from a tuple; the median from a row of a NumPy array), the C core's tick alone (mean per call in a C loop), and the same force arithmetic in plain C (gcc -O2) for A and D; over the paper's
sinusoid ([x, z]), over the egg-crate of the same A and l ([x, y, z], a diagonal scan) and
over a gentle egg-crate (A = 0.1 mm, l = 2 mm: the probe stays within its least radius of
curvature, where D's and E's closest point is certified by convexity).

Run:  python benchmarks/run_renderer.py [--calls 100000]
Reported in benchmarks/README.md; never part of the test run.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time

import numpy as np

import haptex as hx

try:
    from run_sim import build_reference, c_reference
except ImportError:  # run from the repository root
    from benchmarks.run_sim import build_reference, c_reference


def trajectory(tex, letter, n):
    """A 10 mm/s scan sampled at 10 kHz (1 um a call), 0.4 mm inside the wall: along x over a
    profile, along the diagonal over a surface. Returns x, y, z (m)."""
    s = np.arange(n) * 1e-6
    if tex.dimension == 1:
        x, y = s, np.zeros(n)
        h = tex.height(x)
    else:
        x = y = s / math.sqrt(2.0)
        h = tex.height_at(np.column_stack([x, y]))
    z = (-0.4e-3 + 0 * s) if letter in "WFG" else h - 0.4e-3
    return x, y, z


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
        for name, tex in (("sinusoid", hx.Sinusoid(0.8e-3, 1e-3)), ("egg-crate", hx.SumOfGratings.egg_crate(0.8e-3, 1e-3)),
                          ("gentle egg-crate", hx.SumOfGratings.egg_crate(0.1e-3, 2e-3))):
            d = tex.dimension + 1
            for letter in "WABCDEFG":
                base = None if d == 2 else hx.Flat(dimension=2)
                alg = hx.algorithm(letter, base if letter == "W" else tex, 2000.0)
                r = hx.Renderer(alg, max_force=10.0, energy_monitor=True)
                xs, ys, zs = trajectory(tex, letter, n)
                pts = list(zip(xs.tolist(), zs.tolist())) if d == 2 else list(zip(xs.tolist(), ys.tolist(), zs.tolist()))
                lat = np.empty(n)
                step = r.step
                for i, p in enumerate(pts):
                    t0 = time.perf_counter_ns()
                    step(p)
                    lat[i] = time.perf_counter_ns() - t0
                lat -= timer
                r.reset()
                arr = np.ascontiguousarray(np.array(pts, dtype=float))  # the C core's tick, looped in C
                lat_np = np.empty(n)  # the same positions as rows of a NumPy array (the buffer path)
                for i in range(n):
                    row = arr[i]
                    t0 = time.perf_counter_ns()
                    step(row)
                    lat_np[i] = time.perf_counter_ns() - t0
                lat_np -= timer
                r.reset()
                out = np.empty_like(arr)
                t0 = time.perf_counter()
                r._core.run(arr, out)
                kern = (time.perf_counter() - t0) / n * 1e9
                c_ns = math.nan
                if letter in "AD" and d == 2:
                    dev = hx.Device.point_mass()
                    c_ns = c_reference(alg, dev, hx.operators.ConstantForce([0.0, 0.0]), n, 1, tmp, exe, render=True)
                rows.append((name, letter, np.median(lat) / 1e3, np.percentile(lat, 99) / 1e3, np.median(lat_np) / 1e3, kern,
                             c_ns))
    print(f"timer overhead subtracted: {timer:.0f} ns")
    print(f"{'texture':17} {'alg':4} {'step median (us)':>17} {'step p99 (us)':>14} {'NumPy row (us)':>15} "
          f"{'kernel (ns/call)':>17} {'C -O2 (ns/call)':>16}")
    for name, letter, med, p99, med_np, kern, c_ns in rows:
        c_txt = "" if math.isnan(c_ns) else f"{c_ns:16.0f}"
        print(f"{name:17} {letter:4} {med:17.2f} {p99:14.2f} {med_np:15.2f} {kern:17.0f} {c_txt}")


if __name__ == "__main__":
    main()
