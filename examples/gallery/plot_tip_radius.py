"""
A measured scan as a ball feels it
==================================

The paper's probe is a point; a stylus ends in a ball. A ball of radius r follows the height
map dilated by the ball (:func:`haptex.probe.felt_by`): it bridges grooves narrower than its
contact allows, which removes exactly the steep, narrow features that drive the slope, and
with it q. Here the Bruker Dektak line scan of ``examples/data`` (1.5 mm, 9600 samples,
levelled) felt by balls of 0.1, 0.5 and 1 mm, with its largest slope M and algorithm A's
characteristic number q_A = sqrt(1 + M²) for each (Section IV-A).
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import haptex as hx

here = (Path(__file__) if "__file__" in globals() else Path.cwd() / "plot_tip_radius.py").parent.parent
level = hx.load_texture(here / "data" / "dektak-stylus-profile.csv").leveled()
x = level.x - level.x[0]

fig, ax = plt.subplots(figsize=(9, 3.6))
window = (x > 0.5e-3) & (x < 0.9e-3)
ax.plot(x[window] * 1e3, level.h[window] * 1e6, lw=0.6, color="0.5", label="measured (a point probe)")
print(f"point probe: M = {level.max_slope:.4f}, q_A = {np.hypot(1, level.max_slope):.5f}")
for r in (0.1e-3, 0.5e-3, 1.0e-3):
    felt = level.felt_by(r)  # (on its own grid: refined where the ball's path curves faster than the scan's)
    fx = felt.x - level.x[0]
    inside = (fx > 0.5e-3) & (fx < 0.9e-3)
    ax.plot(fx[inside] * 1e3, felt.h[inside] * 1e6, label=f"felt by a ball of r = {r * 1e3:g} mm")
    print(f"r = {r * 1e3:3.1f} mm: M = {felt.max_slope:.4f}, q_A = {np.hypot(1, felt.max_slope):.5f}")
ax.set_xlabel("x (mm)")
ax.set_ylabel("height (µm)")
ax.legend(fontsize=8)
fig.tight_layout()
