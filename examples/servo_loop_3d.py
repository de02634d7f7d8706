"""A haptex.Renderer in a 3-D servo loop at 1 kHz and 10 kHz, fed by a simulated 3-DOF device.

The device is haptex's serial-arm preset (a Phantom-style arm at its home pose: its 3x3
Cartesian mass and damping), held by a hand (a 300 N/m spring, 1 N s/m) dragged across an
egg-crate surface h = A sin(kx) sin(ky) (A = 0.3 mm, l = 2 mm) along a diagonal at 20 mm/s,
1.5 mm below it. Between ticks the arm moves exactly (zero-order hold, matrix exponential of
[p, v] under the held force). Each tick reads [x, y, z], asks the renderer for the force,
advances the device and waits for the next deadline. The loop reports the renderer's latency,
the ticks that missed their deadline, and the passivity observer's energy per axis; with
--passivity-control the controller (haptex.PassivityController) acts too.

Run:  python examples/servo_loop_3d.py [--algorithm B] [--seconds 1] [--rates 1000,10000]
                                       [--passivity-control 5]
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from scipy.linalg import expm

import haptex as hx


def device_step_matrices(M, B, K, C, T):
    """Exact ZOH update of [p, v] (6 states) driven by a held force: M dv/dt = f - K p - (B + C) v."""
    Minv = np.linalg.inv(M)
    F = np.zeros((9, 9))
    F[0:3, 3:6] = np.eye(3)
    F[3:6, 0:3] = -Minv @ K
    F[3:6, 3:6] = -Minv @ (B + C)
    F[3:6, 6:9] = Minv
    E = expm(F * T)
    return E[:6, :6], E[:6, 6:9]


def run(letter: str, rate: float, seconds: float, pc_damping: float | None) -> None:
    T = 1.0 / rate
    dev = hx.Device.serial_arm(period=T)
    tex = hx.SumOfGratings.egg_crate(0.3e-3, 2e-3)
    alg = hx.algorithm(letter, hx.Flat(dimension=2) if letter.upper() == "W" else tex, 1000.0)
    pc = None if pc_damping is None else hx.PassivityController(pc_damping)
    renderer = hx.Renderer(alg, max_force=dev.max_force, energy_monitor=True, passivity_controller=pc, period=T)
    K, C = 300.0 * np.eye(3), 1.0 * np.eye(3)
    Phi, Gam = device_step_matrices(dev.mass, dev.damping, K, C, T)
    speed, depth = 0.02, 1.5e-3
    direction = np.array([1.0, 1.0, 0.0]) / np.sqrt(2.0)
    state = np.array([0.0, 0.0, 0.5e-3, 0.0, 0.0, 0.0])
    n = int(seconds * rate)
    latency = np.empty(n)
    missed = 0
    deadline = time.perf_counter()
    for k in range(n):
        t0 = time.perf_counter()
        f = renderer.step((state[0], state[1], state[2]))
        latency[k] = time.perf_counter() - t0
        s = speed * k * T * direction + np.array([0.0, 0.0, -depth])
        state = Phi @ state + Gam @ (np.asarray(f) + K @ s + C @ (speed * direction))
        deadline += T
        now = time.perf_counter()
        if now > deadline:
            missed += 1
            deadline = now  # a late tick is simply late: no catching up
        while time.perf_counter() < deadline:
            pass
    ex, ey, ez = renderer.energy_per_axis
    print(f"algorithm {alg.letter} on the {dev.name} at {rate:.0f} Hz for {seconds:g} s: {n} ticks")
    print(f"  renderer.step latency: median {np.median(latency) * 1e6:.2f} us, 99th percentile "
          f"{np.percentile(latency, 99) * 1e6:.2f} us, max {latency.max() * 1e6:.1f} us")
    print(f"  missed deadlines: {missed} ({100 * missed / n:.2f} %); faults {renderer.faults}; clamps {renderer.clamps}")
    print(f"  passivity observer: E_x = {ex * 1e3:.4f} mJ, E_y = {ey * 1e3:.4f} mJ, E_z = {ez * 1e3:.4f} mJ"
          + (f"; controller active on {renderer.controller_active} ticks" if pc is not None else ""))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--algorithm", default="B")
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--rates", default="1000,10000")
    ap.add_argument("--passivity-control", type=float, default=None, help="largest added damping (N s/m)")
    args = ap.parse_args()
    for rate in (float(r) for r in args.rates.split(",")):
        run(args.algorithm, rate, args.seconds, args.passivity_control)


if __name__ == "__main__":
    main()
