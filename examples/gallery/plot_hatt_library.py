"""
A HaTT model file: written, read back, checked, rendered with its friction
==========================================================================

The Penn Haptic Texture Toolkit (Culbertson, Lopez Delgado & Kuchenbecker 2014) publishes 100
materials as ``Models_<material>.xml``: ARMA vibration models at recorded (speed, force)
points, their Delaunay triangles (one ``<tri>`` element each) and the material's kinetic
friction coefficient ``mu``. Its licence forbids redistribution, so haptex ships none, and
this example makes its own file in the same layout: a set fitted to a stroke of known spectra
at three speeds and two forces, written by :func:`haptex.datadriven.write_hatt` (as a user
hands haptex's models to HaTT's renderer). The rest is what a user runs on the toolkit's own
folder (``build/XML/``): read it (:func:`~haptex.datadriven.read_hatt`), check that the
interpolated models are stable everywhere and synthesise their power
(:func:`~haptex.datadriven.check_models`, ``haptex vibration FOLDER --check``), and render a
stroke with the vibration *and* the material's friction, whose dissipated energy is
mu f_z times the path (Coulomb friction's work, its closed form).
"""

import tempfile
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
import scipy.signal as sg

import haptex as hx
from haptex import datadriven as dd

FS = 1000.0  # Hz: HaTT's models' rate, and the servo's
rng = np.random.default_rng(0)

# %%
# A recording with a known truth: at each (speed, force) an AR(4) process from scipy's
# lfilter whose two resonances rise with speed and whose power rises with force, 4 s each.
points = [(v, f) for v in (0.03, 0.08, 0.15) for f in (0.5, 2.0)]
acc, speed, force = [], [], []
for v, f in points:
    poles = [0.97 * np.exp(2j * np.pi * (60 + 1000 * v) / FS), 0.9 * np.exp(2j * np.pi * (150 + 1500 * v) / FS)]
    a = np.real(np.poly(poles + [np.conj(p) for p in poles]))
    n = int(4 * FS)
    acc.append(sg.lfilter([1.0], a, rng.normal(scale=0.5 * f, size=n + 500))[500:])
    speed.append(np.full(n, v))
    force.append(np.full(n, f))
# (the high-pass at 5 Hz, below the lowest resonance, 90 Hz: at the default 20 Hz its steep
# edge sits in that resonance's skirt and BIC climbs to its cap, 30, for these AR(4) processes)
models = dd.fit(np.concatenate(acc), np.concatenate(speed), np.concatenate(force), FS, grid=3, highpass=5.0,
                name="Known stroke")
models.mu = 0.35  # the material's kinetic friction coefficient (chosen for the example)
folder = Path(tempfile.mkdtemp())
path = dd.write_hatt(models, folder / "Models_Known stroke.xml")
print(path.name, f"{path.stat().st_size / 1e3:.1f} kB:")
print("\n".join(path.read_text().splitlines()[:16]), "\n   ...")

# %%
# Read back as HaTT's own files are read (speeds from mm/s, 1-based triangles, its mu), and
# checked: 10^4 random operating points in the set's range, each interpolated model's AR roots
# inside the unit circle (numpy's roots), and 20 s of synthesis at the middle point against
# the model's rms from its impulse response.
hatt = dd.read_hatt(path)
print(hatt, "mu =", hatt.mu)
check = dd.check_models(hatt, points=10_000)
print(f"{check.unstable} unstable of {check.points} (largest root {check.max_root:.4f}); synthesis rms "
      f"{check.rms_synthesis:.3g} m/s² against the model's {check.rms_model:.3g}")

# %%
# Rendered on a wall of 2 kN/m pressed 0.5 mm (f_z = 1 N) and stroked at 50 mm/s for 2 s:
# HaTT's friction, -mu f_z along the motion (viscous below 5 mm/s), beside the vibration.
alg = hx.algorithm("W", None, 2000.0)
r = hx.Renderer(alg, max_force=10.0, vibration=hatt, vibration_mass=0.1)
x = 0.05 * np.arange(int(2 * FS)) / FS
f = np.array([r.step((xi, -0.5e-3)) for xi in x])
print(f"friction dissipated {r.friction_dissipated * 1e3:.2f} mJ; mu f_z x path = "
      f"{hatt.mu * 1.0 * (x[-1] - x[0]) * 1e3:.2f} mJ")

fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 3.8))
ax0.triplot(hatt.speeds * 1e3, hatt.forces, hatt.triangles, color="0.6", lw=0.8)
ax0.plot(hatt.speeds * 1e3, hatt.forces, "o", color="C0")
ax0.set_xlabel("speed (mm/s)")
ax0.set_ylabel("normal force (N)")
ax0.set_title(f"{len(hatt.models)} models, {len(hatt.triangles)} triangles")
t = np.arange(x.size) / FS
ax1.plot(t, f[:, 0], lw=0.6, label="tangential (friction + vibration)")
ax1.plot(t, f[:, 1], lw=0.8, label="normal (the wall)")
ax1.set_xlabel("time (s)")
ax1.set_ylabel("force (N)")
ax1.legend(fontsize=8)
fig.tight_layout()
