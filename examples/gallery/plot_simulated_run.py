"""
A run on the simulated device
=============================

``haptex run --device simulated:falcon`` in Python: the Novint Falcon preset held by the
light-touch hand, whose set-point presses 1 mm below the surface and moves along x at 10 mm/s,
behind the same backend protocol and servo loop as a real device (the safety rules: faults,
watchdog, engagement ramp, max force, zero force at every exit). Here the loop runs as fast as
it can (``realtime=False``) instead of at the device's 1 kHz, so the example takes a fraction of
its simulated time; a real device is paced by its own clock.
"""

import matplotlib.pyplot as plt

import haptex as hx
from haptex.backends import open_backend
from haptex.servo import ServoLoop, analyse_trace
from haptex.surfaces import Extruded

backend = open_backend("simulated:falcon", hand="light-touch", speed=0.01, realtime=False)
texture = Extruded(hx.Sinusoid(0.2e-3, 2e-3))  # the profile extruded across y: the Falcon is 3-DOF
renderer = hx.Renderer(hx.algorithm("A", texture, 500.0), max_force=backend.max_force, energy_monitor=True,
                       period=backend.device.period)
stats, trace = ServoLoop(backend, renderer).run(2.0)
summary = analyse_trace(trace, backend.device.period)
print(f"{stats.ticks} ticks, {stats.missed} late, {stats.faults} faults, {stats.clamps} clamps; forces engaged at tick "
      f"{stats.engaged_at}; largest force sent {stats.max_force_sent:.3f} N")
print("the run's regime:", summary["regime"])

# %%
t = trace["time"] - trace["time"][0]
fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 5), sharex=True)
ax1.plot(t, trace["position"][:, 0] * 1e3, label="x")
ax1.plot(t, trace["position"][:, 2] * 1e3, label="z")
ax1.set_ylabel("handle position (mm)")
ax1.legend(fontsize=8)
ax2.plot(t, trace["force"][:, 0], label="f_x")
ax2.plot(t, trace["force"][:, 2], label="f_z")
ax2.set_ylabel("force sent (N)")
ax2.set_xlabel("t (s)")
ax2.legend(fontsize=8)
ax1.set_title(f"simulated Falcon: {stats.ticks} ticks, {stats.faults} faults")
fig.tight_layout()
