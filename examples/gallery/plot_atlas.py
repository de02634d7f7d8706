"""
A stability atlas
=================

The smooth wall W on a 0.1 kg point mass at T = 100 µs pushed into the wall by 1 N, swept over
stiffness × the device's damping (600 runs of 1 s, :func:`haptex.sweep` on Dask with one local
worker). The sampled wall goes unstable beyond the closed-loop-pole limit of
:func:`haptex.critical_stiffness` (about 2b/T, Colgate & Schenkel 1997), drawn dashed; the energy
the environment supplies shows where it turns active first.
"""

import matplotlib.pyplot as plt
import numpy as np

import haptex as hx
from haptex.atlas import analytic_boundary

spec = {
    "duration": "1 s",
    "algorithm": {"letter": "W"},
    "device": {"preset": "point-mass", "mass": "0.1 kg", "damping": "0.5 N*s/m", "period": "100 us"},
    "operator": {"kind": "push", "force": "1 N"},
    "axes": {"stiffness": "0.5-20 kN/m, 30 log steps", "damping": "0.1-1 N*s/m, 20 steps"},
}
ds = hx.sweep(spec, workers=1)
print(ds)

# %%
# Where the loop grows, and the energy the sampled wall supplies per second.
k = ds["stiffness"].values
b = ds["damping"].values
boundary = analytic_boundary(ds, "stiffness", "damping", {})
fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
axes[0].pcolormesh(k / 1e3, b, ds["unstable"].transpose("damping", "stiffness").values, shading="auto",
                   cmap="Reds", vmin=0, vmax=1.5)
axes[0].set_title("unstable (red)")
rate = (ds["energy_rate_x"] + ds["energy_rate_z"]).transpose("damping", "stiffness").values
lim = np.nanmax(np.abs(rate)) or 1.0
im = axes[1].pcolormesh(k / 1e3, b, rate, shading="auto", cmap="RdBu_r", vmin=-lim, vmax=lim)
axes[1].set_title("energy supplied by the environment (W)")
fig.colorbar(im, ax=axes[1])
for ax in axes:
    if boundary is not None:
        ax.plot(np.asarray(boundary) / 1e3, b, "k--", lw=1.5, label="critical stiffness")
    ax.set_xscale("log")
    ax.set_xlabel("stiffness (kN/m)")
axes[0].set_ylabel("device damping (N s/m)")
axes[0].legend(fontsize=8, loc="upper left")
fig.tight_layout()
