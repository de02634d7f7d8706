"""
Identifying a device from a logged run
======================================

``haptex run --identify`` then ``haptex identify`` in Python: the identification program (steps
and a chirp along x, a centering spring) on a model device whose figures we know, the log of
sensed positions and forces sent, and the device model fitted to it by output-error
identification (:func:`haptex.identify`). The device: 120 g, 0.8 N·s/m, 50 mN of Coulomb
friction, a 20 µm encoder step and one period of delay at 1 kHz.
"""

import matplotlib.pyplot as plt

import haptex as hx
from haptex.identification import simulated_log

true = hx.Device(mass=0.12, damping=0.8, period=1e-3, delay=1, position_resolution=20e-6, coulomb_friction=0.05)
t, p, f = simulated_log(true, duration=10.0, amplitude=1.0)
result = hx.identify(time=t, position=p, force=f)
print(result.report())

dev = result.device
for name, got, ref in [("mass (g)", dev.mass[0, 0] * 1e3, 120), ("damping (N*s/m)", dev.damping[0, 0], 0.8),
                       ("Coulomb friction (mN)", dev.coulomb_friction * 1e3, 50),
                       ("encoder step (um)", dev.position_resolution * 1e6, 20), ("delay (periods)", dev.delay, 1)]:
    print(f"{name:>22}: identified {got:.4g}, true {ref:g}")

fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(7, 4.5))
a1.plot(t, f, lw=0.6)
a1.set_ylabel("force sent (N)")
a2.plot(t, p * 1e3, lw=0.8)
a2.set_ylabel("sensed x (mm)")
a2.set_xlabel("time (s)")
a1.set_title("an identification run: the program plus the centering spring")
fig.tight_layout()
