"""
A budgeted vibration: felt, and within the energy you allow it
==============================================================

A data-driven vibration displayed as a force is an active source: here a handle of 200 g
(2 N·s/m) held by a light hand (1.5 N·s/m, 150 N/m) and pulled across texture A at 50 mm/s, 0.5 mm
inside the wall, with a vibration of five AR(4) models at 2 kHz layered on the tick
(``vibration_mass`` 0.2 kg). Unbudgeted it supplies energy to the hand steadily. With
``vibration_budget=B`` (W) the C tick spends only from an energy tank that B refills (its reserve
50 ms of B): the energy it supplies stays under B t + reserve, and the vibration keeps the share of
its power printed below. The handle's motion is integrated exactly (zero-order hold, scipy).
"""

import matplotlib.pyplot as plt
import numpy as np
from scipy.signal import cont2discrete

import haptex as hx
from haptex import datadriven as dd
from haptex.renderer import VIBRATION_RESERVE_TIME

FS, N = 2000.0, 8000


def ar(*poles):
    roots = [r * np.exp(s * 2j * np.pi * f0 / FS) for f0, r in poles for s in (1, -1)]
    return np.real(np.poly(roots))


models = dd.ModelSet([dd.ArmaModel(ar((f1, 0.96), (f2, 0.9)), [1.0, 0.4], var, 1.0, FS, v, f)
                      for f1, f2, var, v, f in [(60, 150, 1, 0.02, 0.5), (120, 300, 2, 0.1, 0.5),
                                                (80, 200, 3, 0.02, 2.0), (200, 500, 4, 0.1, 2.0),
                                                (100, 250, 2, 0.06, 1.2)]])
texture = hx.algorithm("A", hx.Sinusoid(0.05e-3, 2e-3), 2000.0)
M, B, K, b_hand, speed = 0.2, 2.0 + 1.5, 150.0, 1.5, 0.05
Ad, Bd, *_ = cont2discrete((np.array([[0, 1], [-K / M, -B / M]]), np.array([[0, 0], [1 / M, 1 / M]]), np.eye(2),
                            np.zeros((2, 2))), 1 / FS, method="zoh")


def scan(budget):
    r = hx.Renderer(texture, max_force=50.0, vibration=models, vibration_mass=0.2, vibration_gain=0.1, seed=3,
                    vibration_budget=budget)
    s, x, fv = np.array([0.0, speed]), np.empty(N), np.empty(N)
    for k in range(N):
        x[k] = s[0]
        f = r.step((s[0], -0.5e-3))
        fv[k] = f[0] - texture.force(np.array([[s[0], -0.5e-3]]))[0, 0]  # the vibration's part, along x
        s = Ad @ s + Bd @ np.array([f[0], K * speed * k / FS + b_hand * speed])
    return np.concatenate([[0.0], np.cumsum(fv[:-1] * np.diff(x))]), fv, r.vibration_cut


t = np.arange(N) / FS
free, fv_free, _ = scan(None)
rate = free[-1] / t[-1]
print(f"unbudgeted: {rate * 1e3:.3g} mW supplied on average, {np.sqrt(np.mean(fv_free**2)):.3g} N rms")
fig, ax = plt.subplots(figsize=(7, 4))
ax.plot(t, free * 1e3, "k", lw=1, label="unbudgeted")
for share in (0.5, 0.25, 0.1):
    budget = share * rate
    energy, fv, cut = scan(budget)
    kept = np.mean(fv**2) / np.mean(fv_free**2)
    print(f"budget {budget * 1e3:.3g} mW: {energy[-1] * 1e3:.3g} mJ supplied in {t[-1]:g} s (allowed "
          f"{(budget * t[-1] + budget * VIBRATION_RESERVE_TIME) * 1e3:.3g} mJ); power kept {kept:.0%}; "
          f"{cut} ticks cut")
    line, = ax.plot(t, energy * 1e3, lw=1, label=f"budget {budget * 1e3:.2g} mW: {kept:.0%} of the power kept")
    ax.plot(t, (budget * t + budget * VIBRATION_RESERVE_TIME) * 1e3, "--", color=line.get_color(), lw=0.8)
ax.set_xlabel("time (s)")
ax.set_ylabel("energy the vibration supplied (mJ)")
ax.set_title("a budgeted vibration stays under its budget (dashed)")
ax.legend(loc="upper left", fontsize=8)
fig.tight_layout()
