"""
A vibration in the simulator: what the stabilisers leave of it
==============================================================

The wall W at the Falcon preset's rated stiffness, stroked at 30 mm/s by the light-touch hand,
with a data-driven vibration layered on the tick (``simulate(..., vibration=...)``: the C core's
vibration channel, the one the ``Renderer`` runs). The handle's acceleration along the stroke is
what the hand feels; its spectrum without a stabiliser, under energy bounding and passive
set-position modulation, and with a budgeted vibration instead. The printed figures are each
run's vibration power at the port and the felt power kept (the data-driven guide's table has
every stabiliser).
"""

import matplotlib.pyplot as plt
import numpy as np
from scipy.signal import welch

import haptex as hx
from haptex.catalogue import hand, preset
from haptex.experiments import vibration_models

pre = preset("falcon")
own = pre.device(dimension=2)
h = hand("light-touch")
dev, op = h.attach(own), h.operator(depth=2e-3, velocity=0.03)
wall = hx.algorithm("W", None, pre.rated_stiffness)
models = vibration_models()
fs, duration = 1 / dev.period, 3.0


def felt(**kw):
    r = hx.simulate(wall, dev, op, duration, initial_position=[0.0, -1e-3], vibration=models,
                    vibration_mass=own.mass[0, 0], **kw)
    a = np.diff(r.velocity[:, 0]) * fs  # the handle's acceleration along the stroke (m/s^2)
    f, p = welch(a[int(fs):], fs, nperseg=100)  # after the stroke's first second
    return r, f, p


runs = {"no stabiliser": felt()}
ref = runs["no stabiliser"]
runs["energy bounding"] = felt(passivity_controller=hx.EnergyBounding.for_device(dev))
runs["set-position modulation"] = felt(passivity_controller=hx.PassiveSetPosition.for_device(dev))
runs["budget: half its net power"] = felt(vibration_budget=0.5 * ref[0].vibration_supplied / duration)
band = (ref[1] >= 20) & (ref[1] <= 450)
fig, ax = plt.subplots(figsize=(7, 4))
for name, (r, f, p) in runs.items():
    kept = p[band].sum() / ref[2][band].sum()
    print(f"{name}: the vibration supplied {r.vibration_supplied / duration * 1e3:.3g} mW at the port; "
          f"felt power {kept:.1%} of the unstabilised run's")
    ax.semilogy(f[1:], p[1:], lw=1, label=f"{name} ({kept:.0%})")
ax.axvspan(20, 450, color="0.93", zorder=0)
ax.set_xlabel("frequency (Hz)")
ax.set_ylabel("felt acceleration PSD ((m/s²)²/Hz)")
ax.set_title("the vibration on the Falcon: what each stabiliser leaves (20-450 Hz shaded)")
ax.legend(fontsize=8)
fig.tight_layout()
