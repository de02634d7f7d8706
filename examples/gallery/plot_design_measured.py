"""
Design for a measured file
==========================

A Bruker Dektak stylus scan (1.5 mm long, 9,600 samples; SurfaceTopography's test corpus, MIT
licence) loaded straight from the instrument's file, levelled (its 16 µm tilt removed), band-limited to 20 µm and felt
as a 15 mm texture with its heights ×1000 (``haptex design --level --lowpass 20um --scale 10,1000``). Then
:func:`haptex.design.design` on the paper's pantograph at 500 N/m and 20 mm/s: the device renders
no period shorter than its cut-off (Section II-B), so the scan is band-limited to it before q,
passivity, conservativity and continuity are computed for each algorithm, and one is
recommended. D and E, whose closest-point searches take most of the time (17 s for E here), and F,
whose presliding loops take 7 s, are left out of this example; ``haptex design`` analyses them by
default.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import haptex as hx
from haptex.design import design, rendered_texture

here = (Path(__file__) if "__file__" in globals() else Path.cwd() / "plot_design_measured.py").parent.parent
measured = hx.load_texture(here / "data" / "dektak-stylus-profile.csv").leveled().lowpass(20e-6).scaled(10.0, 1000.0)
device = hx.Device.pantograph()
speed = 0.02  # m/s
result = design(measured, device, stiffness=500.0, speed=speed, algorithms="WABCG")

print(f"cut-off period {result['band_limit']['cutoff'] * 1e3:.3g} mm, set by {result['band_limit']['set_by']}")
print(f"{'alg.':5}{'q':>10}{'max passive (N/m)':>20}{'conservative':>14}{'continuous':>12}")
for row in result["rows"]:
    q = "unbounded" if row["q"] is None or not np.isfinite(row["q"]) else f"{row['q']:.4g}"
    print(f"{row['algorithm']:5}{q:>10}{row['max_passive_stiffness']:>20.4g}{str(row['conservative']):>14}"
          f"{str(row['continuous']):>12}")
print("recommendation:", result["recommendation"])

# %%
# The scan as measured and as the device renders it.
raw, rendered = measured, rendered_texture(measured, device, speed=speed)
x = np.linspace(*rendered.domain, 3000)
fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 5.5))
ax1.plot(raw.x * 1e3, raw.h * 1e3, lw=2.5, color="0.7", label=f"measured, levelled ({raw.x.size} samples)")
ax1.plot(x * 1e3, rendered.height(x) * 1e3, lw=1.0, label=f"rendered ({rendered.x.size} samples)")
ax1.set_xlabel("x (mm)")
ax1.set_ylabel("height as felt (mm)")
ax1.legend(fontsize=8)
letters = [r["algorithm"] for r in result["rows"]]
passive = [r["max_passive_stiffness"] for r in result["rows"]]
ax2.bar(letters, passive, color=["C2" if r["passive_at_stiffness"] else "C3" for r in result["rows"]])
ax2.axhline(500.0, color="k", ls="--", lw=1, label="the 500 N/m asked for")
ax2.set_yscale("log")
ax2.set_ylabel("largest passive stiffness (N/m)")
ax2.legend(fontsize=8)
fig.tight_layout()
