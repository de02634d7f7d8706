"""
A force field over a sinusoid and its Jacobian's norm
=====================================================

Algorithms A, B and C over the paper's sinusoid: the force (N) inside the wall and ‖J‖₂/κ0
over the rendering region (penetration up to d^z_max = 1 mm below the textured boundary), whose
supremum is the characteristic number q. The Jacobians are analytic (the tests check them
against finite differences).
"""

import matplotlib.pyplot as plt
import numpy as np

import haptex as hx

tex = hx.Sinusoid(amplitude=0.8e-3, period=1e-3)
k0 = 2000.0
x = np.linspace(0, 1e-3, 121)
z = np.linspace(-1.0e-3, 0.8e-3, 109)
X, Z = np.meshgrid(x, z)
p = np.stack([X.ravel(), Z.ravel()], axis=-1)

fig, axes = plt.subplots(1, 3, figsize=(11, 3.6), sharey=True)
depth = 1e-3  # the rendering region: 0 < h(x) - z <= depth
region = (tex.height(p[:, 0]) - p[:, 1] > 0) & (tex.height(p[:, 0]) - p[:, 1] <= depth)
for ax, letter in zip(axes, "ABC"):
    alg = hx.algorithm(letter, tex, k0)
    gain = hx.spectral_norm(alg.jacobian(p)) / k0
    gain = np.where(region, gain, np.nan).reshape(X.shape)
    im = ax.pcolormesh(X * 1e3, Z * 1e3, gain, shading="auto", cmap="magma", vmin=0)
    s = slice(None, None, 12)
    f = alg.force(p).reshape(X.shape + (2,))
    ax.quiver(X[s, s] * 1e3, Z[s, s] * 1e3, f[s, s, 0], f[s, s, 1], color="w", width=0.006)
    ax.plot(x * 1e3, tex.height(x) * 1e3, "c", lw=1.5)
    q = hx.characteristic_number(alg)
    ax.set_title(f"{letter}: q = {'unbounded' if q.unbounded else format(q.value, '.4g')}")
    ax.set_xlabel("x (mm)")
    fig.colorbar(im, ax=ax, label="‖J‖₂/κ0")
    print(letter, "q =", q.value)
axes[0].set_ylabel("z (mm)")
fig.tight_layout()
