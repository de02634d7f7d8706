"""
Fine cells where the ball's path curves: a felt map on graded axes
===================================================================

A ball of radius r just inside a trough's radius of curvature rho follows the offset surface,
whose curvature there is kappa / (1 - r kappa): at 0.95 rho twenty times the trough's own, a
spike a few µm wide in the ball's position. q of B, C and G reads that largest curvature
(d_max kappa / (1 - r kappa) at a trough, eq. 11-15 with the path's Hessian). No uniform grid
within :data:`haptex.surfaces.CURVATURE_REFINE_SAMPLES` resolves it, so
:func:`haptex.probe.felt_by` makes the felt map once more on graded axes
(``SampledSurface(..., knots=(kx, ky))``): cells of about a µm where the path's curvature comes
within 2 % of its largest, growing away from there. Here the egg-crate (0.1 mm, cells of 2 mm)
felt at 0.95 times its bowls' radius: the cell widths along x, and q of C against the closed form.
"""

import math

import matplotlib.pyplot as plt
import numpy as np

import haptex as hx

amplitude, cell = 0.1e-3, 2e-3
egg = hx.SumOfGratings.egg_crate(amplitude, cell)
kappa = 4 * math.pi**2 * amplitude / cell**2  # the bowls' curvature (1/m)
r = 0.95 / kappa
felt = egg.felt_by(r)
kx, ky = felt.knots
print(f"{kx.size - 1} x {ky.size - 1} cells, from {np.diff(kx).min() * 1e6:.2f} to {np.diff(kx).max() * 1e6:.1f} um")

q = hx.characteristic_number(hx.algorithm("C", felt, 2000.0)).value
closed = 1e-3 * kappa / (1 - r * kappa)  # (d_max = 1 mm below the bowls' path)
print(f"q of C {q:.3f}, the path's closed form {closed:.3f} ({100 * (q / closed - 1):+.2f} %); "
      f"the map states {100 * felt.peak_miss:.2f} % (peak_miss)")

fig, ax = plt.subplots(figsize=(9, 3.4))
ax.semilogy(0.5 * (kx[1:] + kx[:-1]) * 1e3, np.diff(kx) * 1e6, ".", ms=2)
ax.set_xlabel("x (mm)")
ax.set_ylabel("cell width (µm)")
ax.set_title("the felt egg-crate's cells along x: finest at the bowls and the saddles' ridges")
fig.tight_layout()
