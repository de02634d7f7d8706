"""
The native servo thread against a Python loop
=============================================

``haptex run`` drives the simulated device (and Force Dimension's SDK) from the C core's own
servo thread: it wakes once a period on the monotonic clock, samples the device, runs the
safety rules and the renderer's tick and commands the force with no Python and no GIL. Here the
simulated Falcon runs 1 s at its 1 kHz both ways, first alone, then while another Python thread
holds the GIL for 0.3 s (what a plot, a garbage collection or a busy dashboard does). The Python
loop waits for the GIL; the native thread does not. The figures are this machine's at the time
the page was built (a virtual machine without a real-time kernel: its own idle C loop misses
some deadlines too; see the performance page).
"""

import sys
import threading
import time

import matplotlib.pyplot as plt
import numpy as np

import haptex as hx
from haptex.backends.simulated import SimulatedBackend
from haptex.servo import ServoLoop
from haptex.surfaces import Extruded

texture = Extruded(hx.Sinusoid(0.2e-3, 2e-3))


def hold_the_gil(after: float, hold: float) -> threading.Thread:
    """A thread that keeps the GIL for ``hold`` s, ``after`` s from now (pure-Python work with a
    switch interval longer than the hold)."""

    def work():
        time.sleep(after)
        old = sys.getswitchinterval()
        sys.setswitchinterval(10.0)
        try:
            end = time.perf_counter() + hold
            while time.perf_counter() < end:
                pass
        finally:
            sys.setswitchinterval(old)

    t = threading.Thread(target=work, daemon=True)
    t.start()
    return t


rows = []
for busy in (False, True):
    for native in (True, False):
        backend = SimulatedBackend("falcon", realtime=True)  # paced at the preset's 1 kHz
        renderer = hx.Renderer(hx.algorithm("A", texture, 500.0), max_force=backend.max_force)
        holder = hold_the_gil(0.3, 0.3) if busy else None
        stats, trace = ServoLoop(backend, renderer, native=native).run(1.0, record=False)
        if holder is not None:
            holder.join()
        rows.append((("GIL held 0.3 s" if busy else "alone"), stats))
        print(f"{rows[-1][0]:15} {stats.driver:14} missed {stats.missed:4d} of {stats.ticks}, jitter "
              f"{stats.jitter_seconds[1] * 1e6:8.1f} us at 99.9 %, {stats.jitter_seconds[0] * 1e6:9.1f} us worst; "
              f"tick {stats.tick_p999 * 1e6:5.1f} us at 99.9 %{'; SCHED_FIFO' if stats.fifo else ''}")

# %%
fig, ax = plt.subplots(figsize=(7, 3.6))
labels = [f"{when}\n{st.driver}" for when, st in rows]
worst = np.array([st.jitter_seconds[0] for _, st in rows]) * 1e3
p999 = np.array([st.jitter_seconds[1] for _, st in rows]) * 1e3
x = np.arange(len(rows))
ax.bar(x - 0.2, p999, 0.4, label="99.9th percentile")
ax.bar(x + 0.2, worst, 0.4, label="worst")
ax.axhline(0.5, color="k", lw=0.8, ls="--")
ax.text(len(rows) - 0.5, 0.55, "the watchdog's bound (0.5 period)", ha="right", fontsize=8)
ax.set_yscale("log")
ax.set_xticks(x, labels, fontsize=8)
ax.set_ylabel("period jitter |dt - T| (ms)")
ax.set_title("simulated Falcon at 1 kHz, 1 s a bar pair")
ax.legend(fontsize=8)
fig.tight_layout()

# %%
# Keeping the core awake
# ----------------------
# Between two ticks an idle core halts, and on a virtual machine the host wakes it late for the
# next one. ``keep_awake=True`` (``haptex run --keep-awake``) pins the native thread to one core
# and spins a companion there below it, so that the core never halts, at the cost of that
# core's time. One second each way, alternated; ``awake_core`` says which core was kept.

for awake in (False, True, False, True):
    backend = SimulatedBackend("falcon", realtime=True)
    renderer = hx.Renderer(hx.algorithm("A", texture, 500.0), max_force=backend.max_force)
    stats, _ = ServoLoop(backend, renderer, keep_awake=awake).run(1.0, record=False)
    print(f"keep_awake={awake!s:5}  missed {stats.missed:2d} of {stats.ticks}, jitter "
          f"{stats.jitter_seconds[1] * 1e6:7.1f} us at 99.9 %, {stats.jitter_seconds[0] * 1e6:8.1f} us worst; "
          f"core kept awake: {stats.awake_core}")
