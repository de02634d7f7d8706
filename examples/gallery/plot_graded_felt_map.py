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
within 2 % of its largest, fine across the spike only (along each axis as the largest
curvature's direction says: the spike runs from each bowl along its troughs' lines, and needs
no fine cells along them), growing away from there. Here the egg-crate (0.1 mm, cells of 2 mm)
felt at 0.95 times its bowls' radius. Its gratings run at +-45 degrees, and so do its saddles'
ridges, where the spike runs: the map is made on axes along them (``felt.turn``, pi/4), so that
the ridges run along its cells' sides. The cell widths along the map's first axis, and q of C
and D against their closed forms.
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

print(f"the map's axes turned {math.degrees(felt.turn):g} deg from the plane's; its convex_miss "
      f"{100 * felt.convex_miss:.3f} % (what D reads: d_max / (R - d_max), R = 1 / kappa + r at the crests, "
      f"eq. 18, is {1e-3 / (1 / kappa + r - 1e-3):.4f} on the path)")

fig, ax = plt.subplots(figsize=(9, 3.4))
ax.semilogy(0.5 * (kx[1:] + kx[:-1]) * 1e3, np.diff(kx) * 1e6, ".", ms=2)
ax.set_xlabel("along the map's first axis, turned 45 degrees from x (mm)")
ax.set_ylabel("cell width (µm)")
ax.set_title("the felt egg-crate's cells along the map's first axis: finest across the bowls")
fig.tight_layout()
