"""Worst-case servo-tick latency (issue 17): Renderer.step over adversarial positions for
W and A-G on the paper's sinusoid, the levelled Dektak profile and band-limited noise, and
([x, y, z], a tenth of the calls: D and E cost up to 10^3 evaluations a call there) on the
egg-crate of the same A and l and on a gentle one (A = 0.1 mm, l = 2 mm), and on the gentle one
felt by a ball (Hermite patch tables: uniform at 0.5 times its bowls' radius, on graded axes at
0.95 times).

Positions: 1 nm to 1 km below the surface (log-uniform), at peaks, valleys and anywhere
between, far along the workspace, plus NaN/inf/huge values, wrong types and huge jumps.
Reports the maximum and the 99.999th percentile of the wall time of one call (Python call
included, timer cost subtracted) and the maximum counted work (texture evaluations, plus F's
presliding table steps). Then the call that did the most work is replayed 2,000 times from
the renderer state it met: the median of the replays is that worst input's own cost, free of
the scheduler's and the interpreter's jitter that dominates the single-call maximum.
"""

import argparse
import gc
import time
from pathlib import Path

import numpy as np

import haptex as hx

DEKTAK = Path(__file__).resolve().parents[2] / "shared" / "data" / "dektak-stylus-profile.csv"


def inputs(tex, n, rng):
    def along():  # within 3 mm, and for a tenth up to 900 m
        return np.concatenate([rng.uniform(-3e-3, 3e-3, n - n // 10), rng.uniform(-900.0, 900.0, n // 10)])

    x = along()
    if tex.dimension == 1:
        z = tex.height(x) - 10 ** rng.uniform(-9, 3, n)
        pts = list(zip(x.tolist(), z.tolist()))
        bad = [(float("nan"), 0.0), (0.0, float("inf")), (1e300, -1.0), "12", b"12", (1.0, 2.0, 3.0), {0: 1}, None]
    else:
        y = along()
        z = tex.height_at(np.column_stack([x, y])) - 10 ** rng.uniform(-9, 3, n)
        pts = list(zip(x.tolist(), y.tolist(), z.tolist()))
        bad = [(float("nan"), 0.0, 0.0), (0.0, 0.0, float("inf")), (1e300, 0.0, -1.0), "12", b"12", (1.0, 2.0), {0: 1},
               None]
    for i in range(0, n, max(1, n // 200)):
        pts[i] = bad[i % len(bad)]
    return pts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--calls", type=int, default=1_000_000, help="adversarial calls per algorithm and texture")
    ap.add_argument("--textures", default="", help="comma-separated names to run (default: all)")
    args = ap.parse_args()
    n = args.calls
    textures = {"sinusoid": hx.Sinusoid(0.8e-3, 1e-3), "noise": hx.BandLimitedNoise(1e-4, 0.5e-3, 5e-3, 1e-2, seed=3)}
    if DEKTAK.exists():
        textures["dektak"] = hx.SampledProfile.from_file(DEKTAK).leveled()
    textures["egg-crate"] = hx.SumOfGratings.egg_crate(0.8e-3, 1e-3)
    textures["gentle egg-crate"] = hx.SumOfGratings.egg_crate(0.1e-3, 2e-3)
    # felt maps (Hermite patch tables): the gentle egg-crate felt by a ball of 0.5 times its bowls'
    # radius (uniform, 144 a side) and of 0.95 times (graded axes, 578 a side, cells from 0.9 um)
    rho = (2e-3) ** 2 / (4 * np.pi**2 * 0.1e-3)
    felt = {"felt egg-crate 0.5 rho": 0.5, "felt egg-crate 0.95 rho (graded)": 0.95}
    if args.textures:
        wanted = args.textures.split(",")
        textures = {k: textures[k] for k in wanted if k in textures}
        felt = {k: v for k, v in felt.items() if k in wanted}
    for name, rel in felt.items():
        textures[name] = hx.SumOfGratings.egg_crate(0.1e-3, 2e-3).felt_by(rel * rho)
    probe = np.empty(10000)
    for i in range(probe.size):
        t0 = time.perf_counter_ns()
        probe[i] = time.perf_counter_ns() - t0
    timer = float(np.median(probe))
    print("| texture | algorithm | calls | max us | 99.999 % us | median us | max work | worst input, replayed: "
          "median us |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    rng = np.random.default_rng(2026)
    for name, tex in textures.items():
        m = n if tex.dimension == 1 else max(n // 10, 1)
        pts = inputs(tex, m, rng)
        flat = None if tex.dimension == 1 else hx.Flat(dimension=2)
        for letter in "WABCDEFG":
            r = hx.Renderer(hx.algorithm(letter, flat if letter == "W" else tex, 1000.0), max_force=5.0)
            step = r.step
            lat = np.empty(m)
            worst = (-1, None, None, None)
            # the C core's ticks (W, A, B, C, G) keep their state in C: one texture evaluation a
            # tick whatever the input, so the worst input is replayed from a reset renderer
            st, rs = (r._st, r._rs) if r._core is None else (np.zeros(0), np.zeros(0))
            gc.disable()
            for i, p in enumerate(pts):
                st0, rs0 = st.copy(), rs.copy()
                t0 = time.perf_counter_ns()
                step(p)
                lat[i] = time.perf_counter_ns() - t0
                if r.last_work > worst[0]:
                    worst = (r.last_work, p, st0, rs0)
            gc.enable()
            lat = (lat - timer) / 1e3
            replay = np.empty(2000)
            for k in range(replay.size):
                if r._core is not None:
                    r.reset()
                st[:], rs[:] = worst[2], worst[3]
                t0 = time.perf_counter_ns()
                step(worst[1])
                replay[k] = time.perf_counter_ns() - t0
            replay = (replay - timer) / 1e3
            print(f"| {name} | {letter} | {m} | {lat.max():.1f} | {np.percentile(lat, 99.999):.1f} | "
                  f"{np.median(lat):.2f} | {r.max_work} | {np.median(replay):.2f} |", flush=True)


if __name__ == "__main__":
    main()
