"""haptex's benchmark suite, one command: python benchmarks/run.py

1. analysis: force and jacobian on 10^6 positions and characteristic_number at default
   resolution, per algorithm (the paper's Section V-A parameters), over the paper's
   sinusoid (2-D) and over the egg-crate A sin(kx) sin(ky) at the same A and l (3-D);
2. renderer: Renderer.step latency from Python and of the compiled kernel, against plain C
   (benchmarks/run_renderer.py);
3. simulator: simulate_batch samples per second against plain C, N = 1 and 1000
   (benchmarks/run_sim.py);
4. worst: the maximum Renderer.step latency and work over 10^6 adversarial positions per
   algorithm and profile, 10^5 per surface (benchmarks/run_worst.py);
5. export: ns per call of the C99 tick `haptex export` generates (benchmarks/run_export.py);
6. design: `haptex design` on the raw Dektak scan against the paper's sinusoid, and design()
   on a 10^6-sample profile and a 1024 x 1024 map (benchmarks/run_design.py);
7. atlas: `haptex.sweep` on Dask with 1 and 2 workers, the overhead per task, the largest
   sweep (benchmarks/run_atlas.py);
8. explore: the explorer's recompute per algorithm, and the browser's round trip from a
   control change to the new view (Chromium; benchmarks/run_explore.py);
9. core: the C core's cost per call across its binding (C API against ctypes) and the
   throughput of its fields against the NumPy fields (benchmarks/run_core.py);
10. backends: the servo loop on every backend, missed deadlines and the tick's time, the
   vendors' bindings on stubs of their libraries (benchmarks/run_backends.py; 60 s each);
11. objects: the servo tick over textured objects, up to a 327,680-triangle mesh
   (benchmarks/run_objects.py);
12. vibration: the data-driven vibration in the tick (benchmarks/run_vibration.py);
13. identify: haptex.identify on 10 s logs, one core (benchmarks/run_identify.py).

Options: --only {analysis,renderer,simulator,worst,export,design,atlas,explore,core,backends,objects,vibration,
identify}, --points N,
--json
(analysis only).
Never part of the test run; results are reported in benchmarks/README.md. Sections 2 and
3 need gcc.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import platform
import re
import sys
import time

import numpy as np

import haptex as hx

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))


def best_of(fn, repeat=3):
    times = []
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


SECTIONS = (
    ("renderer", "renderer"),
    ("simulator", "simulator"),
    ("worst", "worst-case servo tick (10^6 adversarial calls per algorithm and profile, 10^5 per surface)"),
    ("export", "exported C tick"),
    ("design", "design on raw measured data"),
    ("atlas", "stability atlas on Dask"),
    ("explore", "explorer: recompute and browser round trip"),
    ("core", "the C core: binding and fields"),
    ("backends", "the servo loop on every backend"),
    ("objects", "the servo tick over textured objects"),
    ("vibration", "the data-driven vibration in the tick"),
    ("identify", "identification of a device from a 10 s log"),
)
"""Sections 2-13 in their order: (--only name, heading); each a module benchmarks/run_NAME.py
(the simulator's: run_sim.py) with a main()."""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--points", type=int, default=1_000_000)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--only", choices=["analysis", *(name for name, _ in SECTIONS)])
    args = ap.parse_args()
    if args.only in (None, "analysis"):
        analysis(args)
    for name, heading in SECTIONS:
        if args.only in (None, name) and not args.json:
            module = importlib.import_module(f"run_{name}" if name != "simulator" else "run_sim")
            print(f"\n# {heading}")
            sys.argv = sys.argv[:1]  # (each section's own defaults)
            module.main()

def analysis(args) -> None:

    tex = hx.Sinusoid(0.8e-3, 1e-3)
    rng = np.random.default_rng(0)
    n = args.points
    # positions over one period, from 0.2 mm above the peaks to 1 mm below the valleys
    p = np.column_stack([rng.uniform(0, 1e-3, n), rng.uniform(-1.8e-3, 1.0e-3, n)])
    # warm the search data (built once per texture) before timing
    hx.algorithm("D", tex, 2000).force(p[:10])
    rows = []
    for letter in "WABCDEFG":
        alg = hx.algorithm(letter, None if letter == "W" else tex, 2000.0)
        t_f = best_of(lambda: alg.force(p))
        t_j = best_of(lambda: alg.jacobian(p))
        t_q = best_of(lambda: hx.characteristic_number(alg), repeat=1)
        rows.append({"algorithm": letter, "force_s": t_f, "jacobian_s": t_j, "characteristic_number_s": t_q,
                     "force_Mpts_per_s": n / t_f / 1e6, "jacobian_Mpts_per_s": n / t_j / 1e6})
    machine = {"python": platform.python_version(), "machine": platform.machine(),
               "processor": platform.processor() or platform.machine(), "numpy": np.__version__}
    if args.json:
        print(json.dumps({"points": n, "machine": machine, "rows": rows}, indent=2))
        return
    print(f"# analysis: {n} positions; {machine}")
    print(f"{'alg':4} {'force (s)':>10} {'jacobian (s)':>13} {'q (s)':>8}")
    for r in rows:
        print(f"{r['algorithm']:4} {r['force_s']:10.3f} {r['jacobian_s']:13.3f} {r['characteristic_number_s']:8.2f}")
    # 3-D: the egg-crate, positions over one cell from 0.2 mm above the peaks to 1 mm below
    egg = hx.SumOfGratings.egg_crate(0.8e-3, 1e-3)
    p3 = np.column_stack([rng.uniform(0, 1e-3, n), rng.uniform(0, 1e-3, n), rng.uniform(-1.8e-3, 1.0e-3, n)])
    print("# analysis in 3-D over the egg-crate")
    print(f"{'alg':4} {'force (s)':>10} {'jacobian (s)':>13} {'q (s)':>8}")
    hx.algorithm("D", egg, 2000.0).force(p3[:10])  # compile the surface search
    for letter in "WABCDEFG":
        alg = hx.algorithm(letter, hx.Flat(2) if letter == "W" else egg, 2000.0)
        t_f = best_of(lambda: alg.force(p3))
        t_j = best_of(lambda: alg.jacobian(p3))
        t_q = best_of(lambda: hx.characteristic_number(alg), repeat=1)
        print(f"{letter:4} {t_f:10.3f} {t_j:13.3f} {t_q:8.2f}")
    # the closest point on a surface: time per point per core (both cores run the search)
    cores = hx.core.num_threads()

    def closest(tex, q, what):
        hx.closest_point(tex, q[:10])  # (compiles the search data)
        t = best_of(lambda: hx.closest_point(tex, q), repeat=1)
        work = hx.closest_point(tex, q[:100_000]).work
        print(f"closest point on the {what}, 0 to 1 mm deep: {t / len(q) * cores * 1e6:.2f} us per point per core "
              f"({cores} cores), {work.mean():.0f} evaluations a point on average, {work.max()} at most")

    for name, surf in (("grating (A = 0.8 mm, l = 1 mm, 0.3 rad)", hx.Grating(0.8e-3, 1e-3, 0.3)), ("egg-crate", egg)):
        xy = rng.uniform(0, 1e-3, (n, 2))
        closest(surf, np.column_stack([xy, surf.height_at(xy) - rng.uniform(0.0, 1e-3, n)]), name)
    # a felt profile refined for its curvature: the sinusoid (0.1 mm at 2 mm) felt by a ball of
    # 0.99 times its troughs' radius, 262,144 samples, its leaves certified convex or scanned
    rho = 2e-3**2 / (4 * np.pi**2 * 0.1e-3)
    felt = hx.Sinusoid(0.1e-3, 2e-3).felt_by(0.99 * rho)
    x = rng.uniform(0, 2e-3, n // 10)
    closest(felt, np.column_stack([x, felt.height(x) - rng.uniform(0.0, 1e-3, x.size)]),
            f"sinusoid felt by a ball of 0.99 rho ({felt.x.size} samples)")
    # a felt map on axes turned along its gratings: the egg-crate (0.1 mm at 2 mm) felt by a ball
    # of 0.95 times its bowls' radius, on graded axes turned 45 degrees (PATCH_TURN)
    felt = hx.SumOfGratings.egg_crate(0.1e-3, 2e-3).felt_by(0.95 * rho)
    xy = rng.uniform(0, 2e-3, (n // 10, 2))
    closest(felt, np.column_stack([xy, felt.height_at(xy) - rng.uniform(0.0, 1e-3, xy.shape[0])]),
            f"egg-crate felt by a ball of 0.95 rho ({felt.x.size} x {felt.y.size} samples on axes turned "
            f"{np.degrees(felt.turn):g} deg)")
    t_turned = best_of(lambda: hx.core.texture_derivatives(felt, xy))
    t_frame = best_of(lambda: hx.core.texture_derivatives(felt._frame, xy))
    print(f"  its heights, gradients and Hessians: {t_turned / xy.shape[0] * 1e9:.0f} ns a point, "
          f"{t_frame / xy.shape[0] * 1e9:.0f} on its own axes unturned")
    # q of D there: the grid's Jacobians at its feet, the region searched where ||J|| is largest
    alg = hx.algorithm("D", felt, 2000.0)
    t0 = time.perf_counter()
    q = hx.characteristic_number(alg)
    searched = re.search(r"the foot's uniqueness [^)]*", q.note).group(0)
    print(f"  q of D on it: {q.value:.6f} in {time.perf_counter() - t0:.1f} s ({searched})")
    # B's, C's and G's Jacobians there: h, grad h and the Hessian from one evaluation of the
    # patches (Texture._jet), against the three calls they made before 2026-12-01
    p3 = np.column_stack([xy, felt.height_at(xy) - rng.uniform(0.0, 1e-3, xy.shape[0])])
    t_jets = [best_of(lambda: hx.algorithm(k, felt, 2000.0).jacobian(p3)) for k in "BCG"]
    t_one = best_of(lambda: felt._jet(xy))
    t_three = best_of(lambda: (felt.height_at(xy), felt.gradient(xy), felt.hessian(xy)))
    print(f"  B's, C's and G's Jacobians on it: {', '.join(f'{t * 1e3:.1f}' for t in t_jets)} ms for "
          f"{xy.shape[0]} points (h, grad h and the Hessian {t_one * 1e3:.1f} ms in one evaluation, "
          f"{t_three * 1e3:.1f} ms in three)")

if __name__ == "__main__":
    main()
