"""A haptex.Renderer in a 10 kHz servo loop fed by a simulated device.

The device is a 2-DOF point mass (50 g, 0.5 N s/m) pushed into a textured wall by a
hand (a 300 N/m spring dragged along the surface at 20 mm/s); between ticks it moves
exactly (zero-order hold, matrix exponential). The loop runs in real time: each tick
reads the position, asks the renderer for the force, advances the device, then waits for
the next 100 us deadline. It reports the renderer's latency, the ticks that missed their
deadline, and the passivity observer's energy per axis.

Run:  python examples/servo_loop.py [--algorithm F] [--seconds 2] [--rate 10000]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.linalg import expm

import haptex as hx


def device_step_matrices(mass, damping, hand_k, T):
    """Exact ZOH update of [x, z, vx, vz] driven by a held force (command + hand)."""
    F = np.zeros((6, 6))
    F[0:2, 2:4] = np.eye(2)
    F[2:4, 0:2] = -hand_k / mass * np.eye(2)
    F[2:4, 2:4] = -damping / mass * np.eye(2)
    F[2:4, 4:6] = np.eye(2) / mass
    E = expm(F * T)
    return E[:4, :4], E[:4, 4:6]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--algorithm", default="F")
    ap.add_argument("--seconds", type=float, default=2.0)
    ap.add_argument("--rate", type=float, default=10_000.0)
    args = ap.parse_args()

    T = 1.0 / args.rate
    tex = hx.Sinusoid(0.8e-3, 2e-3)
    alg = hx.algorithm(args.algorithm, None if args.algorithm.upper() == "W" else tex, 1000.0)
    renderer = hx.Renderer(alg, max_force=5.0, energy_monitor=True)
    hand_k, depth, speed = 300.0, 2e-3, 0.02
    Phi, Gam = device_step_matrices(0.05, 0.5, hand_k, T)
    state = np.array([0.0, 0.5e-3, 0.0, 0.0])
    n = int(args.seconds * args.rate)
    latency = np.empty(n)
    missed = 0
    deadline = time.perf_counter()
    for k in range(n):
        t0 = time.perf_counter()
        f = renderer.step((state[0], state[1]))
        latency[k] = time.perf_counter() - t0
        setpoint = np.array([speed * k * T, -depth])
        state = Phi @ state + Gam @ (np.asarray(f) + hand_k * setpoint)
        deadline += T
        now = time.perf_counter()
        if now > deadline:
            missed += 1
            deadline = now  # do not try to catch up: a late tick is simply late
        while time.perf_counter() < deadline:
            pass
    ex, ez = renderer.energy_per_axis
    print(f"algorithm {alg.letter} ({alg.name}) at {args.rate:.0f} Hz for {args.seconds:g} s: {n} ticks")
    print(f"renderer.step latency: median {np.median(latency) * 1e6:.2f} us, 99th percentile "
          f"{np.percentile(latency, 99) * 1e6:.2f} us, max {latency.max() * 1e6:.1f} us")
    print(f"missed deadlines: {missed} ({100 * missed / n:.2f} %); faults {renderer.faults}; clamps {renderer.clamps}")
    print(f"passivity observer: E_x = {ex * 1e3:.3f} mJ, E_z = {ez * 1e3:.3f} mJ "
          "(negative: the texture supplied energy)")


if __name__ == "__main__":
    main()
