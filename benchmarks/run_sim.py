"""Simulator speed: haptex.simulate_batch against a plain C loop (gcc -O2) doing the same
work (benchmarks/sim_reference.c), for algorithms A and D, N = 1 and N = 1000 runs.

Run:  python benchmarks/run_sim.py [--steps-single 2000000] [--steps-batch 4000]
Needs gcc. Reported in benchmarks/README.md; never part of the test run.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import tempfile
import time

import numpy as np

import haptex as hx
from haptex.operators import ScanningHand
from haptex.simulate import _discretise

HERE = os.path.dirname(os.path.abspath(__file__))


def c_reference(alg, dev, op, n_steps, n_runs, workdir, exe, render=False):
    code, prm, kind, coeffs, aux = alg.kernel_spec()
    tex = alg.texture
    Phi, Wd, Wo = _discretise(dev, op)
    path = os.path.join(workdir, f"in_{alg.letter}_{n_runs}.bin")
    with open(path, "wb") as fh:
        np.array([code, coeffs.shape[1], n_steps, n_runs], dtype=np.int64).tofile(fh)
        coeffs.astype(np.float64).tofile(fh)
        sc = np.r_[prm[0], tex.shortest_period / 64.0, dev.period, op.stiffness.ravel(), op.damping.ravel(), op.setpoint_points[0],
                   op.final_velocity, [0.0, 0.0], tex.max_slope, tex.max_curvature]
        sc.astype(np.float64).tofile(fh)
        for m in (Phi, Wd, Wo):
            np.ascontiguousarray(m, dtype=np.float64).tofile(fh)
    out = subprocess.run([exe, path] + (["render"] if render else []), capture_output=True, text=True,
                         check=True).stdout
    return float(out.split()[1])


def build_reference(tmp):
    """Compile the C reference with gcc -O2; returns the executable's path."""
    gcc = shutil.which("gcc")
    if gcc is None:
        raise SystemExit("gcc is needed for the C reference")
    exe = os.path.join(tmp, "sim_reference")
    subprocess.run([gcc, "-O2", "-o", exe, os.path.join(HERE, "sim_reference.c"), "-lm"], check=True)
    return exe


def haptex_rate(alg, dev, op, n_steps, n_runs):
    duration = n_steps * dev.period
    hx.simulate_batch(alg, dev, op, 10 * dev.period, stiffness=[alg.stiffness])  # compile / load cache
    t = time.perf_counter()
    hx.simulate_batch(alg, dev, op, duration, stiffness=np.full(n_runs, alg.stiffness), progress=False)
    return n_steps * n_runs / (time.perf_counter() - t)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps-single", type=int, default=2_000_000)
    ap.add_argument("--steps-batch", type=int, default=4_000)
    args = ap.parse_args()
    tex = hx.Sinusoid(0.8e-3, 1e-3)
    dev = hx.Device.pantograph(joint_damping=4.0e-3)
    op = ScanningHand(300.0, 1.0, velocity=0.01, depth=1e-3)
    with tempfile.TemporaryDirectory() as tmp:
        exe = build_reference(tmp)
        print(f"{'alg':4} {'N':>5} {'steps':>8} {'haptex (samples/s)':>19} {'C -O2 (samples/s)':>18} {'ratio':>6}")
        for letter in "AD":
            alg = hx.algorithm(letter, tex, 2000.0)
            for n_runs, n_steps in ((1, args.steps_single), (1000, args.steps_batch)):
                h = haptex_rate(alg, dev, op, n_steps, n_runs)
                c = c_reference(alg, dev, op, n_steps, n_runs, tmp, exe)
                print(f"{letter:4} {n_runs:5d} {n_steps:8d} {h:19.3g} {c:18.3g} {h / c:6.2f}")
    print(f"cores: {os.cpu_count()} (simulate_batch runs in parallel over them; the C loop uses one)")


if __name__ == "__main__":
    main()
