"""
The wall limit, found on the device
===================================

``haptex run --find-limit`` in Python: a smooth wall whose stiffness rises by 10 % every 0.5 s
while the light-touch hand rests the simulated Falcon's handle on it, pressing with 1 N. Each
step is judged by the run's detectors (the handle's motion rebuilt from the encoder's 63.5 µm
staircase); at the first step that oscillates the run stops, force zero from the next tick
(:func:`haptex.limits.find_limit`). The exact boundary of the same sampled loop with that hand,
:func:`haptex.wall_limits`, is drawn beside.
"""

import matplotlib.pyplot as plt
import numpy as np

import haptex as hx
from haptex.backends.simulated import SimulatedBackend
from haptex.limits import SIM_PUSH, find_limit

hand = hx.catalogue.hand("light-touch")
exact = hx.wall_limits(hx.catalogue.preset("falcon").device(), hand)["hand"].value
backend = SimulatedBackend("falcon", speed=0.0, press=SIM_PUSH / hand.stiffness, realtime=False)
res = find_limit(backend, exact / 4, exact * 4)
print(f"clean up to {res.clean:.0f} N/m, oscillating at {res.oscillating:.0f} N/m; exact limit {exact:.0f} N/m")
for step in res.steps[-3:]:
    print(f"  {step['stiffness']:7.0f} N/m: {step['regime']}")

t, z = res.trace["time"], res.trace["position"][:, 2]
fig, (a1, a2) = plt.subplots(2, 1, sharex=True, figsize=(7, 4.5))
a1.step([s["start"] for s in res.steps], [s["stiffness"] for s in res.steps], where="post")
a1.axhline(exact, color="k", ls="--", lw=0.8, label="exact limit with the hand")
a1.set_ylabel("stiffness (N/m)")
a1.legend(loc="upper left")
a2.plot(t, z * 1e3, lw=0.6)
a2.set_ylabel("sensed z (mm)")
a2.set_xlabel("time (s)")
a2.set_ylim(np.percentile(z, 1) * 1e3 * 1.5, 0.2)
a1.set_title("find-limit on the simulated Falcon: the run stops at the first oscillating step")
fig.tight_layout()
