"""
A surface from a vibration recording, against the models at held-out speeds
===========================================================================

The data-driven language (ARMA models interpolated between recorded speeds, HaTT) and the
geometric one (a height map) meet here. A stylus follows a band-limited random profile
(wavelengths 0.2 to 2 mm, 5 µm RMS: the truth) at four speeds; its acceleration, with an
accelerometer's white noise, is fitted by :func:`haptex.datadriven.fit`. Each model's
spectrum, divided by (2πf)⁴ and scaled by the speed, is the profile's height spectrum
(:func:`haptex.datadriven.height_spectrum`), and :func:`haptex.datadriven.surface_from`
synthesises a profile with it: a texture the conservative algorithms render passively. At a
speed held out of the fit the surface's vibration slides with the speed, as the recording's
does; the interpolated models do not.
"""

import matplotlib.pyplot as plt
import numpy as np
import scipy.signal as sg

import haptex as hx
from haptex import datadriven as dd

FS = 2000.0
truth = hx.BandLimitedNoise(5e-6, 0.2e-3, 2e-3, length=0.25, seed=3)


def scan(profile, v, sensor=0, seconds=2.0):
    """A point's vertical acceleration a = v² h''(vt) (m/s²) plus the sensor's noise."""
    t = np.arange(int(seconds * FS)) / FS
    return v**2 * profile.curvature(v * t) + np.random.default_rng([sensor, int(v * 1e4)]).normal(0, 0.05, t.size)


fitted = [0.02, 0.04, 0.08, 0.12]  # m/s
parts = [scan(truth, v) for v in fitted]
models = dd.Recording(np.concatenate(parts), np.concatenate([np.full(p.size, v) for v, p in zip(fitted, parts)]),
                      np.full(sum(p.size for p in parts), 1.0), FS).fit()
surface = dd.surface_from(models, 0.25, seed=1)
print(surface)

fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 3.8))
k = np.geomspace(300, 2e4, 300)
ax0.loglog(k, dd.height_spectrum(models, k), label="from the models")
flat = (5e-6) ** 2 / (1 / 0.2e-3 - 1 / 2e-3)
ax0.loglog([500, 500, 5000, 5000], [1e-22, flat, flat, 1e-22], "k--", lw=0.8, label="truth")
ax0.set_ylim(1e-19, 1e-13)
ax0.set_xlabel("wavenumber k (cycles/m)")
ax0.set_ylabel("height spectrum S_h (m³)")
ax0.legend(fontsize=8)

v = 0.06  # held out: between 40 and 80 mm/s
recorded = scan(truth, v)
felt = scan(surface, v, sensor=1)
interpolated = models.synthesize(v, 1.0, recorded.size / FS, seed=1)
for sig, label in ((recorded, "recording"), (felt, "surface scanned"), (interpolated, "models interpolated")):
    f, p = sg.welch(sig, FS, nperseg=400)
    ax1.semilogy(f, p, label=label)
band = (500 * v * 1.25, 5000 * v / 1.25)  # inside the truth's band at this speed
ax1.axvspan(*band, color="0.9")
ax1.set_xlim(0, 450)
ax1.set_xlabel("frequency (Hz)")
ax1.set_ylabel("PSD ((m/s²)²/Hz)")
ax1.set_title(f"{v * 1e3:.0f} mm/s, held out: surface {dd.spectral_difference(recorded, felt, FS, band=band):.1f} dB, "
              f"models {dd.spectral_difference(recorded, interpolated, FS, band=band):.1f} dB", fontsize=9)
ax1.legend(fontsize=8)
fig.tight_layout()

# %%
# The same models as an isotropic areal surface (``areal=True``): an 8 mm square map whose lines
# along x (and, isotropic, along y) have on average the profile's spectrum, for the 3-D algorithms.
areal = dd.surface_from(models, 8e-3, 10e-6, areal=True, seed=1)
print(f"areal: {areal.h.shape[0]} x {areal.h.shape[1]} samples, {areal.h.std() * 1e6:.3g} um RMS; a tip at "
      f"{v * 1e3:.0f} mm/s records {dd.follower_vibration(areal, v).rms:.3g} m/s² rms in 20-450 Hz "
      f"(the profile: {dd.follower_vibration(surface, v).rms:.3g})")
fig2, ax = plt.subplots(figsize=(4.5, 4))
image = ax.imshow(areal.h.T * 1e6, origin="lower", extent=[0, 8, 0, 8], cmap="viridis")
fig2.colorbar(image, label="h (µm)")
ax.set_xlabel("x (mm)")
ax.set_ylabel("y (mm)")
ax.set_title("an isotropic surface from the recording", fontsize=9)
fig2.tight_layout()
