"""Simulator speed, two comparisons, each measured in one run:

1. the fast path (issue 12): simulate_batch on 1000 runs x 10^4 samples of algorithm A on a
   point mass (m = 0.1 kg, b = 0.5 N s/m, T = 0.1 ms) pushed into the texture by 1 N, in 2-D
   (the paper's sinusoid) and 3-D (the egg-crate), against a plain one-thread C loop doing the
   same physics (benchmarks/fast_reference.c) and against NumPy vectorised over the runs;
2. the general path: a scanning hand on the pantograph, algorithms A and D, N = 1 and 1000,
   against a C loop doing the same work with the 10x10 transition (benchmarks/sim_reference.c).

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
from haptex import core
from haptex.operators import ConstantForce, ScanningHand

simulate_module = __import__("sys").modules["haptex.simulate"]

HERE = os.path.dirname(os.path.abspath(__file__))


def c_reference(alg, dev, op, n_steps, n_runs, workdir, exe, render=False):
    code, prm, kind, coeffs, aux = alg.kernel_spec()
    tex = alg.texture
    Phi, Wd, Wo, _ = simulate_module._discretise(dev, op)
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


def build_reference(tmp, name="sim_reference"):
    """Compile a C reference with gcc -O2; returns the executable's path."""
    gcc = shutil.which("gcc")
    if gcc is None:
        raise SystemExit("gcc is needed for the C reference")
    exe = os.path.join(tmp, name)
    subprocess.run([gcc, "-O2", "-o", exe, os.path.join(HERE, f"{name}.c"), "-lm"], check=True)
    return exe


def fast_case(d):
    """(algorithm, device, operator) of the fast-path benchmark in d = 2 or 3 dimensions."""
    A, L = 0.8e-3, 1e-3
    tex = hx.Sinusoid(A, L) if d == 2 else hx.SumOfGratings.egg_crate(A, L)
    dev = hx.Device.point_mass(dimension=d)
    op = ConstantForce([0.0, -1.0] if d == 2 else [0.0, 0.0, -1.0])
    return hx.algorithm("A", tex, 2000.0), dev, op


def fast_c(d, n_steps, n_runs, workdir, exe):
    alg, dev, op = fast_case(d)
    _, _, kind, coeffs, _ = alg.kernel_spec()
    co = coeffs[:3] if d == 2 else coeffs  # amplitudes, wave-vector components, phases
    path = os.path.join(workdir, f"fast_{d}.bin")
    with open(path, "wb") as fh:
        np.array([d, co.shape[1], n_steps, n_runs], dtype=np.int64).tofile(fh)
        np.r_[alg.stiffness, op.force, co.ravel(), simulate_module._fast_coefficients(dev, op).ravel()].tofile(fh)
    out = subprocess.run([exe, path], capture_output=True, text=True, check=True).stdout
    return float(out.split()[1])


def fast_numpy(d, n_steps, n_runs):
    """The same physics in NumPy, vectorised over the runs (what a user writes in ten lines)."""
    alg, dev, op = fast_case(d)
    _, _, _, co, _ = alg.kernel_spec()
    c = simulate_module._fast_coefficients(dev, op)  # (2, d, 7)
    a, kv, ph = co[0], co[1:d], co[d]
    k0, f0 = alg.stiffness, op.force
    p = np.zeros((n_runs, d))
    v = np.zeros((n_runs, d))
    e = np.zeros((n_runs, d))
    ed = np.zeros(n_runs)
    t = time.perf_counter()
    for _ in range(n_steps):
        h = np.sin(p[:, :d - 1] @ kv + ph) @ a
        pen = p[:, -1] - h
        inside = pen < 0
        f = np.zeros((n_runs, d))
        f[:, -1] = np.where(inside, -k0 * pen, 0.0)
        cc = c[inside.astype(np.intp)]  # (N, d, 7)
        w = f + f0
        dp = cc[..., 0] * v + cc[..., 1] * w
        ed += np.sum(v * (cc[..., 4] * v + cc[..., 5] * w) + cc[..., 6] * w * w, axis=1)
        e -= f * dp
        v = cc[..., 2] * v + cc[..., 3] * w
        p += dp
    return n_steps * n_runs / (time.perf_counter() - t)


def fast_haptex(d, n_steps, n_runs):
    alg, dev, op = fast_case(d)
    hx.simulate_batch(alg, dev, op, 10 * dev.period, stiffness=[alg.stiffness] * 2)  # compile / load cache
    t = time.perf_counter()
    # n_runs distinct stiffnesses around the paper's (a sweep: every run is built, none is shared)
    hx.simulate_batch(alg, dev, op, n_steps * dev.period, stiffness=alg.stiffness * np.linspace(0.75, 1.25, n_runs),
                      progress=False)
    return n_steps * n_runs / (time.perf_counter() - t)


def haptex_rate(alg, dev, op, n_steps, n_runs):
    duration = n_steps * dev.period
    hx.simulate_batch(alg, dev, op, 10 * dev.period, stiffness=[alg.stiffness])  # compile / load cache
    t = time.perf_counter()
    hx.simulate_batch(alg, dev, op, duration, stiffness=np.full(n_runs, alg.stiffness), progress=False)
    return n_steps * n_runs / (time.perf_counter() - t)


def setup_share(n_runs=4000, n_steps=10_000):
    """Issue 30's per-run set-up against a 10^4-sample run: simulate_batch over n_runs distinct
    stiffnesses (A, point mass, constant push) for 10 samples (set-up and verdicts dominate) and
    for n_steps samples, on one thread; returns (set-up us a run, run us, share)."""
    from haptex import core

    tex = hx.Sinusoid(0.8e-3, 1e-3)
    alg, dev = hx.algorithm("A", tex, 2000.0), hx.Device.point_mass()
    op = ConstantForce([0.0, -1.0])
    k = np.linspace(500.0, 5000.0, n_runs)
    with core.threads(1):
        hx.simulate_batch(alg, dev, op, 10 * dev.period, stiffness=k[:10], progress=False)
        short = min(_timed(lambda: hx.simulate_batch(alg, dev, op, 10 * dev.period, stiffness=k, progress=False))
                    for _ in range(3))
        full = min(_timed(lambda: hx.simulate_batch(alg, dev, op, n_steps * dev.period, stiffness=k[:200],
                                                     progress=False)) for _ in range(3))
    setup, run = short / n_runs * 1e6, full / 200 * 1e6
    return setup, run, setup / run


def setup_by_key(n_runs=1000):
    """Per-run set-up (us) of a sweep of each key over n_runs distinct values, 10 samples a run,
    one thread: on the lean loop (A, point mass, constant push), the general loop (the same with
    a delay of one sample) and a scanning hand. Returns {case: {key: us}}."""
    from haptex import core

    tex = hx.Sinusoid(0.8e-3, 1e-3)
    alg = hx.algorithm("A", tex, 2000.0)
    n = n_runs
    keys = {"stiffness": np.linspace(500, 5000, n), "mass": np.linspace(0.05, 0.2, n),
            "damping": np.linspace(0.1, 1.0, n), "max_force": np.linspace(1, 10, n),
            "position_resolution": np.linspace(1e-7, 1e-5, n), "coulomb_friction": np.linspace(0, 0.1, n),
            "push_x": np.linspace(0, 0.5, n), "amplitude": np.linspace(0.1e-3, 1e-3, n),
            "hand_stiffness": np.linspace(100, 500, n)}
    cases = {"lean": (hx.Device.point_mass(), ConstantForce([0.0, -1.0])),
             "general (delay 1)": (hx.Device.point_mass().replace(delay=1), ConstantForce([0.0, -1.0])),
             "scanning hand": (hx.Device.point_mass(), ScanningHand(300.0, 1.0, velocity=0.01, depth=1e-3))}
    out = {}
    with core.threads(1):
        for case, (dev, op) in cases.items():
            out[case] = {}
            for key, vals in keys.items():
                if key == "hand_stiffness" and case != "scanning hand":
                    continue
                run = lambda v: hx.simulate_batch(alg, dev, op, 10 * dev.period, progress=False, **{key: v})  # noqa: E731
                run(vals[:10])
                out[case][key] = min(_timed(lambda: run(vals)) for _ in range(2)) / n * 1e6
    return out


def _timed(fn):
    t = time.perf_counter()
    fn()
    return time.perf_counter() - t


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--steps-single", type=int, default=2_000_000)
    ap.add_argument("--steps-batch", type=int, default=4_000)
    args = ap.parse_args()
    tex = hx.Sinusoid(0.8e-3, 1e-3)
    dev = hx.Device.pantograph(joint_damping=4.0e-3)
    op = ScanningHand(300.0, 1.0, velocity=0.01, depth=1e-3)
    with tempfile.TemporaryDirectory() as tmp:
        fexe = build_reference(tmp, "fast_reference")
        print("fast path: A, point mass, constant push, 1000 runs x 10^4 samples (samples/s)")
        print(f"{'d':2} {'haptex':>10} {'1 thread':>10} {'C -O2 (1 thread)':>17} {'NumPy':>10} {'haptex/C':>9} "
              f"{'1 thread/C':>11} {'haptex/NumPy':>13}")
        for d in (2, 3):
            h = max(fast_haptex(d, 10_000, 1000) for _ in range(3))
            with core.threads(1):
                h1 = max(fast_haptex(d, 10_000, 1000) for _ in range(3))
            c = max(fast_c(d, 10_000, 1000, tmp, fexe) for _ in range(3))
            npy = fast_numpy(d, 10_000, 1000)
            print(f"{d:2d} {h:10.3g} {h1:10.3g} {c:17.3g} {npy:10.3g} {h / c:9.2f} {h1 / c:11.2f} {h / npy:13.2f}")
        print()
        exe = build_reference(tmp)
        print(f"{'alg':4} {'N':>5} {'steps':>8} {'haptex (samples/s)':>19} {'C -O2 (samples/s)':>18} {'ratio':>6}")
        for letter in "AD":
            alg = hx.algorithm(letter, tex, 2000.0)
            for n_runs, n_steps in ((1, args.steps_single), (1000, args.steps_batch)):
                h = haptex_rate(alg, dev, op, n_steps, n_runs)
                c = c_reference(alg, dev, op, n_steps, n_runs, tmp, exe)
                print(f"{letter:4} {n_runs:5d} {n_steps:8d} {h:19.3g} {c:18.3g} {h / c:6.2f}")
    setup, run, share = setup_share()
    print(f"per-run set-up (4000 distinct stiffnesses, 10 samples, one thread): {setup:.1f} us; a 10^4-sample run: "
          f"{run:.0f} us; set-up / run = {100 * share:.2f} %")
    for case, row in setup_by_key().items():
        print(f"per-run set-up by swept key, {case} (1000 distinct values, us a run): "
              + ", ".join(f"{k} {v:.1f}" for k, v in row.items()))
    print(f"cores: {os.cpu_count()} (simulate_batch runs in parallel over them; the C loop uses one)")


if __name__ == "__main__":
    main()
