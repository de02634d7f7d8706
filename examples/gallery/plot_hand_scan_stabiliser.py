"""
A hand scanning on a device preset, with and without a stabiliser
=================================================================

The Force Dimension omega.3 preset (4 kHz; its x-z plane over a profile) held by the
light-touch hand of :func:`haptex.catalogue.hands`, whose spring presses 1 mm below the surface
while it moves along x at 20 mm/s, over a sinusoid of 0.4 mm and 2 mm rendered by algorithm B at
3 kN/m, with one sample of computation delay. B is not conservative: it supplies energy to the hand
at this stiffness. The same run with a passivity observer/controller (Hannaford & Ryu 2002) and
with energy bounding (Kim & Ryu 2004): the energy the texture supplied at the port, per axis
(E = −Σ f·dp; a fall is energy supplied to the hand).
"""

import matplotlib.pyplot as plt

import haptex as hx
from haptex.catalogue import hand, preset

device = preset("omega-3").device(delay=1, dimension=2)
grip = hand("light-touch")
held = grip.attach(device)
operator = grip.operator(depth=1e-3, velocity=0.02)
alg = hx.algorithm("B", hx.Sinusoid(0.4e-3, 2e-3), 3000.0)
print(f"q_B = {hx.characteristic_number(alg).value:.3g}; the device's period {device.period * 1e6:.0f} µs")

runs = {
    "no stabiliser": None,
    "passivity controller": hx.PassivityController(max_damping=20.0),
    "energy bounding": hx.EnergyBounding.for_device(device),
}
fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharex=True)
for label, stabiliser in runs.items():
    res = hx.simulate(alg, held, operator, 1.0, passivity_controller=stabiliser)
    supplied = -(res.totals["energy_x"] + res.totals["energy_z"])
    print(f"{label:22s} energy supplied at the port over 1 s: {supplied * 1e3:7.3f} mJ")
    axes[0].plot(res.time, res.energy_x * 1e3, label=label)
    axes[1].plot(res.time, res.energy_z * 1e3, label=label)
for ax, axis in zip(axes, "xz"):
    ax.set_xlabel("t (s)")
    ax.set_ylabel(f"E_{axis} (mJ)")
    ax.set_title(f"energy absorbed along {axis}")
axes[0].legend(fontsize=8)
fig.tight_layout()
