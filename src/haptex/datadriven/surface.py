"""A surface from a recording, and a geometric texture as the vibration a follower records."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from .._validation import fail, numbers, positive, random_seed
from .models import ModelSet
from ..textures import checked_texture

# ---------------------------------------------------------------------------------------
# a surface from a recording
# ---------------------------------------------------------------------------------------

SURFACE_BAND = (40.0, 450.0)
"""The vibration band (Hz) :func:`height_spectrum` reads by default (chosen: from twice
:func:`fit`'s 20 Hz high-pass, where that zero-phase filter takes under 0.04 dB, to the HaTT
papers' 450 Hz)."""
MAX_SURFACE_SAMPLES = 1 << 24
"""Most samples :func:`surface_from` synthesises (a 16 M-sample profile, 128 MiB)."""


def height_spectrum(models: ModelSet, wavenumber, *, band=SURFACE_BAND) -> np.ndarray:
    """The height spectrum of the surface whose scanning would give the models' vibration.

    A point following a profile h(x) at speed v has the acceleration a(t) = v² h''(vt),
    whose one-sided power spectral density is S_a(f) = (2 pi f)^4 S_h(f / v) / v, S_h the
    profile's one-sided height spectrum over the wavenumber k (cycles/m). Each model at a
    speed v > 0 thus gives S_h(k) = v S_a(k v) / (2 pi k v)^4 where k v lies in ``band``.
    The models that cover k are combined by their geometric mean (each AR estimate scatters
    about the truth; the least of them, tried first, sat 1.5-5 dB low on a known profile).
    Noise in the recording adds power where the vibration is weak: trust the band where it
    dominates the sensor's floor.

    Parameters
    ----------
    models : ModelSet
        Fitted or read models; their forces are not used (a point follower's vibration does not
        depend on how hard it presses).
    wavenumber : array_like, shape (n,)
        Spatial frequencies k (cycles/m), > 0.
    band : (float, float), optional
        The vibration band (Hz) trusted, within (0, sample_rate / 2]; default
        :data:`SURFACE_BAND`.

    Returns
    -------
    numpy.ndarray, shape (n,)
        S_h(k) (m² per cycle/m, i.e. m³; its integral over k is the height's variance); NaN
        where no model's band covers k.

    Raises
    ------
    ParameterError
        If a wavenumber is not positive and finite, the band is outside (0, sample_rate / 2],
        or no model has a positive speed.
    """
    k = numbers("wavenumber", wavenumber, "finite spatial frequencies > 0 (cycles/m)", copy=False)
    if not np.all(np.isfinite(k) & (k > 0)):
        raise fail("wavenumber", wavenumber, "finite spatial frequencies > 0 (cycles/m)")
    lo, hi = (float(b) for b in band)
    fs = models.sample_rate
    if not 0 < lo < hi <= fs / 2:
        raise fail("band", band, f"(low, high) with 0 < low < high <= {fs / 2:g} Hz, the models' Nyquist frequency")
    moving = [m for m in models.models if m.speed > 0]
    if not moving:
        raise fail("models", models, "a model set with at least one model at a speed > 0")
    logs, count = np.zeros(k.shape), np.zeros(k.shape)
    for m in moving:
        f = k * m.speed
        inside = (f >= lo) & (f <= hi)
        if inside.any():
            sh = m.speed * m.psd(f[inside]) / (2 * np.pi * f[inside]) ** 4
            logs[inside] += np.log(np.maximum(sh, 1e-300))
            count[inside] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, np.exp(logs / np.maximum(count, 1)), np.nan)


def surface_from(models: ModelSet, length: float, spacing: float | None = None, *, band=SURFACE_BAND,
                 seed: int = 0, areal: bool = False):
    """A profile whose scanning gives the models' vibration: the data-driven texture as a
    geometric one, which the conservative algorithms render passively.

    The profile's height spectrum is :func:`height_spectrum` on the harmonics of 1/length
    (zero where no model covers them: the recording says nothing there), with independent
    phases uniform in [0, 2 pi) from ``numpy.random.default_rng(seed)``; its amplitudes are
    exact, sqrt(2 S_h(k) / length) a harmonic, so its variance is the spectrum's integral.
    A point following it at any speed v has the acceleration spectrum
    (2 pi f)^4 S_h(f / v) / v: the speed scales the vibration, which interpolating models
    between speeds does not do (compare them at speeds held out of the fit).

    Parameters
    ----------
    models : ModelSet
        The vibration models (fitted from a recording or read).
    length : float
        The profile's length (m), periodic over it; its longest wavelength.
    spacing : float, optional
        Sample spacing (m); default a tenth of the shortest wavelength the models cover
        (the slowest model's speed over the band's top; chosen so that the profile's spline
        gives h'' within a few per cent there).
    band : (float, float), optional
        As :func:`height_spectrum`.
    seed : int, optional
        Seed of the phases.
    areal : bool, optional
        An isotropic surface on the square cell ``length`` x ``length`` instead (chosen: a
        recording along one line cannot show how the surface varies across it; the models,
        like HaTT's, are the same in every direction). Its 2-D spectrum is the isotropic one
        whose lines along x have, averaged over the lines, the profile's spectrum: a line of
        an isotropic surface also collects the oblique components of shorter wavelengths, so
        the radial spectrum is found by non-negative least squares
        (:func:`scipy.optimize.nnls`, relative errors) over the harmonics the models cover;
        exact amplitudes and uniform phases, as the profile's.

    Returns
    -------
    SampledProfile or SampledSurface
        Periodic over ``length`` (and across it when ``areal``), heights in m.

    Raises
    ------
    ParameterError
        For a non-positive length or spacing, more than :data:`MAX_SURFACE_SAMPLES` samples
        (an areal surface: more than :data:`MAX_AREAL_SIDE` a side), a spectrum that no model
        covers at any harmonic, a seed that is not numpy's default_rng's (a whole number from 0
        to 2^64 - 1), or as :func:`height_spectrum`.
    """
    from ..textures import SampledProfile

    L = positive("length", length, "m")
    seed = random_seed("seed", seed)
    moving = [m.speed for m in models.models if m.speed > 0]
    if not moving:
        raise fail("models", models, "a model set with at least one model at a speed > 0")
    dx = min(moving) / float(band[1]) / 10 if spacing is None else positive("spacing", spacing, "m")
    n = int(math.ceil(L / dx))
    if areal and n > MAX_AREAL_SIDE:
        raise fail("spacing", dx, f"at least {L / MAX_AREAL_SIDE:.3g} m for a {L:g} m square surface (at most "
                                  f"{MAX_AREAL_SIDE} samples a side), or a shorter length")
    if n > MAX_SURFACE_SAMPLES:
        raise fail("spacing", dx, f"at least {L / MAX_SURFACE_SAMPLES:.3g} m for a {L:g} m profile (at most "
                                  f"{MAX_SURFACE_SAMPLES} samples)")
    n += n % 2
    k = np.arange(1, n // 2) / L
    sh = height_spectrum(models, k, band=band)
    covered = np.isfinite(sh)
    if not covered.any():
        raise fail("length", L, f"a profile whose harmonics of 1/length reach the band the models cover "
                                f"({band[0]:g}-{band[1]:g} Hz at {min(moving):g}-{max(moving):g} m/s)")
    if areal:
        return _isotropic_surface(np.where(covered, sh / L, np.nan), n, L, seed,
                                  f"surface from {models.name or 'a model set'} ({band[0]:g}-{band[1]:g} Hz, isotropic)")
    amp = np.where(covered, np.sqrt(2 * np.nan_to_num(sh) / L), 0.0)
    phase = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, k.size)
    spec = np.zeros(n // 2 + 1, dtype=complex)
    spec[1:n // 2] = 0.5 * n * amp * np.exp(1j * phase)
    h = np.fft.irfft(spec, n)
    x = np.arange(n) * (L / n)
    return SampledProfile(x, h, periodic=True, source=f"surface from {models.name or 'a model set'} "
                                                      f"({band[0]:g}-{band[1]:g} Hz)")


MAX_AREAL_SIDE = 1024
"""Most samples a side of :func:`surface_from`'s areal surface (8 MiB of heights)."""


def _isotropic_radial(line: np.ndarray) -> np.ndarray:
    """The radial spectrum g (variance a 2-D harmonic, at integer radii 1..m) of the isotropic
    surface whose lines along x hold ``line`` (variance a harmonic i = 1..m, NaN where nothing
    is asked). A line at i
    collects every (i, j): line[i] = sum_j g(sqrt(i^2 + j^2)), g linear between integer radii."""
    from scipy.optimize import nnls

    m = line.size
    asked = np.isfinite(line) & (line > 0)
    top = int(np.flatnonzero(asked).max()) + 1  # no radius beyond the highest harmonic asked
    i, j = np.meshgrid(np.arange(1, m + 1), np.arange(-m, m + 1), indexing="ij")
    rho = np.hypot(i, j)
    inside = rho <= top
    r0 = np.floor(rho[inside]).astype(int)
    t = rho[inside] - r0
    M = np.zeros((m, top))
    rows = (i[inside] - 1)
    np.add.at(M, (rows, r0 - 1), 1.0 - t)
    more = (t > 0) & (r0 < top)
    np.add.at(M, (rows[more], r0[more]), t[more])
    A = M[asked] / line[asked][:, None]
    g, _ = nnls(A, np.ones(int(asked.sum())), maxiter=50 * top)
    return np.concatenate([g, np.zeros(m - top)])


def _isotropic_surface(line: np.ndarray, n: int, L: float, seed: int, source: str):
    """A periodic n x n map on the cell L x L whose lines along x have, on average, the per-harmonic
    variances ``line`` (i = 1..n/2 - 1): its radial spectrum by :func:`_isotropic_radial`, exact
    amplitudes, phases uniform in [0, 2 pi) from ``seed``."""
    from ..surfaces import SampledSurface

    m = n // 2 - 1
    g = _isotropic_radial(line[:m])
    iy = np.fft.fftfreq(n, 1.0 / n)  # the y harmonics, signed
    ix = np.arange(n // 2 + 1)
    rho = np.hypot(iy[:, None], ix[None, :])
    r0 = np.floor(rho).astype(int)
    t = rho - r0
    gg = np.concatenate([[0.0], g, [0.0, 0.0]])  # radius 0 and beyond m: nothing
    r0c = np.minimum(r0, m + 1)
    V = (1.0 - t) * gg[r0c] + t * gg[np.minimum(r0c + 1, m + 1)]
    V[:, 0] = 0.0  # (the pure-y column and the Nyquist ones: no line along x sees them)
    V[:, n // 2] = 0.0
    V[n // 2, :] = 0.0
    V[rho > m] = 0.0
    phase = np.random.default_rng(seed).uniform(0.0, 2 * np.pi, V.shape)
    Z = 0.5 * n * n * np.sqrt(2.0 * V) * np.exp(1j * phase)
    h = np.fft.irfft2(Z, s=(n, n)).T  # [x, y]
    x = np.arange(n) * (L / n)
    return SampledSurface(x, x.copy(), h, periodic=True, source=source)


# ---------------------------------------------------------------------------------------
# a geometric texture as a vibration: what a point following it records
# ---------------------------------------------------------------------------------------

VIBRATION_BAND = (20.0, 450.0)
"""Hz: the band of the HaTT papers' spectra (:func:`spectral_difference`'s default)."""
MAX_FOLLOWER_SAMPLES = 1 << 20
"""Most height samples :func:`follower_vibration` reads along x (8 MiB)."""


@dataclasses.dataclass(frozen=True)
class FollowerVibration:
    """The vibration a point following a texture along x at a constant speed records.

    Parameters
    ----------
    speed : float
        The scan's speed (m/s).
    band : tuple of float
        (low, high): the vibration band (Hz).
    rms : float
        RMS acceleration in the band (m/s²): a = v² h''(v t).
    wavelengths : tuple of float
        (v / high, v / low): the texture's wavelengths (m) the band holds at this speed.
    covered : tuple of float or None
        The part of the band (Hz) the texture's sampled extent resolves (a wavelength up to
        the span analysed, down to two samples); None when it resolves none of it.
    share : float
        The share of the texture's height variance in the band (0-1).
    peak_frequency : float or None
        The frequency (Hz) of the in-band component furthest above the hand's vibrotactile
        detection threshold; None without one.
    margin_db : float or None
        20 log10(displacement amplitude / :func:`haptex.perception.detection_threshold`) there
        (dB; > 0: above threshold, for a tip that follows the surface rigidly).
    """

    speed: float
    band: tuple
    rms: float
    wavelengths: tuple
    covered: tuple | None
    share: float
    peak_frequency: float | None
    margin_db: float | None

    def as_dict(self) -> dict:
        """The figures as a JSON-ready dict (SI units).

        Returns
        -------
        dict
        """
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in dataclasses.asdict(self).items()}


FOLLOWER_LINES = 16
"""Lines along x, evenly across its domain in y, over which :func:`follower_vibration` averages a
surface's spectrum when no line is named (chosen)."""


def _line_spectrum(texture, y) -> tuple[np.ndarray, np.ndarray, float, bool]:
    """(wavenumbers 1/m, peak amplitudes m, the span analysed m, exact) of the heights along x:
    a sum of sinusoids' own lines, else a periodogram of its samples over its domain (a
    surface's averaged over :data:`FOLLOWER_LINES` lines across it, or on the line ``y``)."""
    from scipy.signal import periodogram

    if getattr(texture, "periods", None) is not None and texture.dimension == 1:
        k = 1.0 / np.atleast_1d(np.asarray(texture.periods, dtype=float))
        a = np.abs(np.atleast_1d(np.asarray(texture.amplitudes, dtype=float)))
        return k, a, math.inf, True
    dom = texture.domain
    if dom is None:
        raise fail("texture", repr(texture), "a texture with a domain (a sampled texture or a periodic one)")
    (x0, x1) = dom if texture.dimension == 1 else dom[0]
    span = float(x1 - x0)
    short = float(texture.shortest_period) if texture.shortest_period else span / 1024
    n = int(min(MAX_FOLLOWER_SAMPLES, max(4096, math.ceil(8 * span / short))))
    periodic = bool(getattr(texture, "periodic", True))  # (an analytic texture's domain is a period)
    x = x0 + span * np.arange(n) / n if periodic else np.linspace(x0, x1, n)
    if texture.dimension == 1:
        rows = [texture.height(x)]
    else:
        (y0, y1) = dom[1]
        ys = [float(y)] if y is not None else list(y0 + (y1 - y0) * (np.arange(FOLLOWER_LINES) + 0.5) / FOLLOWER_LINES)
        rows = [texture.height_at(np.column_stack([x, np.full(n, yi)])) for yi in ys]
    dx = x[1] - x[0]
    p = 0.0
    for h in rows:
        k, pr = periodogram(h, fs=1.0 / dx, window="boxcar" if periodic else "hann",
                            detrend="constant" if periodic else "linear", scaling="spectrum")
        p = p + pr / len(rows)
    return k[1:], np.sqrt(2.0 * p[1:]), span, False


def follower_vibration(texture, speed: float, *, band=VIBRATION_BAND, y: float | None = None) -> FollowerVibration:
    """The vibration a point following ``texture`` along x at ``speed`` records, in a band.

    A geometric texture in the data-driven language: a tip that follows h(x) at speed v has
    the acceleration a(t) = v² h''(v t), each height component of wavenumber k (1/m) and peak
    amplitude A a vibration at f = v k of amplitude (2 pi f)² A. Its displacement is A, which
    :func:`haptex.perception.detection_threshold` says whether a hand feels.

    Parameters
    ----------
    texture : Texture
        A profile, or a surface read along x; a sum of sinusoids by its own lines, any other
        over its domain (one period, or the sampled range), by a periodogram of its heights
        (:func:`scipy.signal.periodogram`: a Hann window and a linear detrend unless it is
        periodic).
    speed : float
        m/s, > 0.
    band : tuple of float, optional
        (low, high) in Hz, 0 < low < high.
    y : float, optional
        On a surface, the line along x read (m); default the average over
        :data:`FOLLOWER_LINES` lines evenly across its domain in y.

    Returns
    -------
    FollowerVibration

    Raises
    ------
    ParameterError
        For a speed that is not > 0, a band that is not (low, high) with 0 < low < high, or a
        texture without a domain (an aperiodic sum over a surface).
    """
    texture = checked_texture(texture)
    from ..perception import detection_threshold

    v = positive("speed", speed, "m/s")
    lo, hi = (float(b) for b in band)
    if not 0 < lo < hi or not math.isfinite(hi):
        raise fail("band", band, "(low, high) in Hz with 0 < low < high")
    k, a, span, exact = _line_spectrum(texture, y)
    f = v * k
    inside = (f >= lo) & (f <= hi) & (a > 1e-15 * max(float(a.max(initial=0.0)), 1e-300))
    acc = (2 * np.pi * f[inside]) ** 2 * a[inside]
    total = float(np.sum(a**2))
    covered = None
    if exact:
        covered = (lo, hi)
    else:
        dx = span / max(1, k.size * 2)
        c_lo, c_hi = max(lo, v / span), min(hi, v / (2 * dx))
        covered = (c_lo, c_hi) if c_lo < c_hi else None
    peak = margin = None
    if inside.any():
        m = 20 * np.log10(a[inside] / detection_threshold(f[inside]))
        i = int(np.argmax(m))
        peak, margin = float(f[inside][i]), float(m[i])
    return FollowerVibration(v, (lo, hi), float(np.sqrt(np.sum(acc**2) / 2)), (v / hi, v / lo), covered,
                             float(np.sum(a[inside] ** 2) / total) if total > 0 else 0.0, peak, margin)


