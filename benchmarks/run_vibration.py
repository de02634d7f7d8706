"""The data-driven vibration's cost in the servo tick (issue 54): the C core's tick looped in C
(Renderer's batch loop) for algorithm A on the paper's sinusoid, without and with a model set
layered on it, per model order, against the plain C reference loop of run_sim (gcc -O2), all
in one run; and ModelSet.synthesize alone (the set's step, no texture).

Run:  python benchmarks/run_vibration.py [--calls 200000]
Reported in benchmarks/README.md; never part of the test run.
"""

from __future__ import annotations

import argparse
import math
import tempfile
import time

import numpy as np

import haptex as hx
from haptex import datadriven as dd

try:
    from run_sim import build_reference, c_reference
except ImportError:  # run from the repository root
    from benchmarks.run_sim import build_reference, c_reference

FS = 1000.0


def model_set(p: int) -> dd.ModelSet:
    """Nine AR(p) models on a 3 x 3 grid of 20-100 mm/s and 0.5-2 N (resonances spread over the band)."""
    models = []
    for i, s in enumerate((0.02, 0.06, 0.10)):
        for j, f in enumerate((0.5, 1.2, 2.0)):
            roots = []
            for k in range(p // 2):
                z = (0.85 + 0.005 * k) * np.exp(2j * np.pi * (30 + 22 * k + 3 * i + 2 * j) / FS)
                roots += [z, np.conj(z)]
            if p % 2:
                roots.append(0.5)
            models.append(dd.ArmaModel(np.real(np.poly(roots)), [1.0], 1.0 + i + j, 1.0, FS, s, f))
    return dd.ModelSet(models)


def kernel_ns(r: hx.Renderer, pts: np.ndarray, repeat: int = 5) -> float:
    out = np.empty_like(pts)
    best = math.inf
    for _ in range(repeat):
        r.reset()
        t0 = time.perf_counter()
        r._core.run(pts, out)
        best = min(best, time.perf_counter() - t0)
    return best / len(pts) * 1e9


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--calls", type=int, default=200_000)
    n = ap.parse_args().calls
    alg = hx.algorithm("A", hx.Sinusoid(0.8e-3, 1e-3), 2000.0)
    x = np.arange(n) * 0.05 / FS  # 50 mm/s at 1 kHz, 0.6 mm inside the wall: f_z = 1.2 N, inside the set's hull
    pts = np.ascontiguousarray(np.column_stack([x, alg.texture.height(x) - 0.6e-3]))
    with tempfile.TemporaryDirectory() as tmp:
        exe = build_reference(tmp)
        c_ns = c_reference(alg, hx.Device.point_mass(), hx.operators.ConstantForce([0.0, 0.0]), n, 1, tmp, exe,
                           render=True)
    plain = kernel_ns(hx.Renderer(alg, max_force=10.0), pts)
    print(f"plain C reference loop (gcc -O2, A's force): {c_ns:6.0f} ns a tick")
    print(f"haptex tick, A alone:                        {plain:6.0f} ns a tick")
    print(f"{'AR order':>8} {'tick with vibration (ns)':>25} {'added (ns)':>11} {'synthesize alone (ns/sample)':>29}")
    for p in (4, 10, 20, 40):
        models = model_set(p)
        r = hx.Renderer(alg, max_force=10.0, vibration=models, vibration_mass=0.1, seed=1)
        with_v = kernel_ns(r, pts)
        t0 = time.perf_counter()
        models.synthesize(0.05, 1.0, n / FS, seed=1)
        syn = (time.perf_counter() - t0) / n * 1e9
        print(f"{p:8d} {with_v:25.0f} {with_v - plain:11.0f} {syn:29.0f}")


if __name__ == "__main__":
    main()
