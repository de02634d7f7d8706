"""
Data-driven vibration: fitted from a scan, interpolated between speeds
======================================================================

The field's second texture language (Romano & Kuchenbecker 2012; HaTT, Culbertson et al.
2014): a tool's vibration recorded at steady speeds and forces, one ARMA model each, the
models interpolated at the speed and force of the moment. Here the recording is haptex's
own, with a known truth: a stylus following a band-limited random profile (wavelengths 0.2 to
2 mm, 5 µm RMS) at four speeds, its vertical acceleration a = v² h''(vt) sampled at 2 kHz
with an accelerometer's white noise (0.05 m/s² RMS, as an ADXL-class sensor at this rate).
:func:`haptex.datadriven.fit` fits one AR model a speed (the order by BIC); the set then
synthesises the vibration at two speeds held out of the fit, and its spectrum is compared with
the scan's at those speeds (the mean absolute difference in dB over 20–450 Hz, the HaTT
papers' measure).
"""

import functools

import matplotlib.pyplot as plt
import numpy as np
import scipy.signal as sg

import haptex as hx
from haptex import datadriven as dd

FS = 2000.0  # Hz: the models' rate
profile = hx.BandLimitedNoise(5e-6, 0.2e-3, 2e-3, length=0.5, seed=3)


@functools.cache
def scan(speed, seconds=4.0):
    """The stylus's vertical acceleration (m/s²) along the profile at a steady speed (m/s)."""
    t = np.arange(int(seconds * FS)) / FS
    sensor = np.random.default_rng(int(speed * 1e4)).normal(0.0, 0.05, t.size)
    return speed**2 * profile.curvature(speed * t) + sensor  # exact: a finite difference loses 6 dB at 450 Hz


fitted_speeds = [0.02, 0.04, 0.08, 0.12]  # m/s
held_out = [0.06, 0.10]
force = 1.0  # N: one force (the set is a line, interpolated along it)
parts = [scan(v) for v in fitted_speeds]
recording = dd.Recording(np.concatenate(parts), np.concatenate([np.full(p.size, v) for v, p in zip(fitted_speeds, parts)]),
                         np.full(sum(p.size for p in parts), force), FS)
models = recording.fit()
print(models)
print(models.report)

fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
for ax, v in zip(axes, [0.08, 0.06]):
    rec = scan(v)
    syn = models.synthesize(v, force, rec.size / FS, seed=1)
    f, p_rec = sg.welch(rec, FS, nperseg=400)
    _, p_syn = sg.welch(syn, FS, nperseg=400)
    ax.semilogy(f, p_rec, label="scan")
    ax.semilogy(f, p_syn, label="synthesis")
    ax.semilogy(f, models.model_at(v, force).psd(f), "k--", lw=0.8, label="model")
    kind = "fitted" if v in fitted_speeds else "held out"
    ax.set_title(f"{v * 1e3:.0f} mm/s ({kind}): {dd.spectral_difference(rec, syn, FS):.1f} dB")
    ax.set_xlabel("frequency (Hz)")
axes[0].set_ylabel("PSD ((m/s²)²/Hz)")
axes[0].legend(fontsize=8)
fig.tight_layout()

for v in fitted_speeds + held_out:
    rec = scan(v)
    syn = models.synthesize(v, force, rec.size / FS, seed=1)
    kind = "fitted  " if v in fitted_speeds else "held out"
    print(f"{v * 1e3:5.0f} mm/s {kind}: spectral difference {dd.spectral_difference(rec, syn, FS):4.1f} dB, "
          f"rms {np.std(syn):.3g} m/s² against the scan's {np.std(rec):.3g}")
