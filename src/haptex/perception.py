"""Perceptible vibration ("buzz"): the handle's vibration spectrum against the hand's
vibrotactile detection threshold.

A rendering can be passive, even decaying by the oscillation verdict, and still buzz: a
vibration of a few encoder counts at 100-300 Hz is far above what a hand holding a handle
detects there. :func:`buzz` compares the amplitude spectrum of the handle's displacement with a
detection threshold curve and reports how far above it the largest component is.

The threshold curve (:func:`detection_threshold`), displacement peak amplitude (m) against
frequency, each number marked:

* **Shape below the minimum, published**: flat up to 40 Hz, then falling 12 dB per octave to the
  minimum (R. T. Verrillo, "Effect of contactor area on the vibrotactile threshold", J. Acoust.
  Soc. Am. 35, 1963, pp. 1962–1966, on the thenar eminence with contactors of 2.9 cm² or more, as
  G. A. Gescheider and R. T. Verrillo report it in "Vibrotactile frequency characteristics as
  determined by adaptation and masking procedures", in D. R. Kenshalo (ed.), Sensory Functions of
  the Skin of Humans, Plenum, 1979).
  12 dB per octave in displacement is a constant acceleration.
* **The minimum, published**: between 150 and 200 Hz (175 Hz taken) for a cylinder grasped in
  the hand, the case of a device's handle, with thresholds below 0.01 um in some subjects (A. J.
  Brisben, S. S. Hsiao and K. O. Johnson, "Detection of vibration transmitted through an object
  grasped in the hand", J. Neurophysiology 81(4), 1999, pp. 1548–1558). 0.01 um is taken as the
  level: the most sensitive hands, so the verdict errs towards flagging.
* **Above the minimum, chosen**: rising 12 dB per octave (the U-shaped curve's upper side,
  whose slope our sources do not give; chosen symmetric).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ._validation import fail, numbers, positive

__all__ = ["THRESHOLD", "detection_threshold", "Buzz", "buzz", "dequantise"]

THRESHOLD = {
    "minimum": 1e-8,  # m peak: Brisben et al. 1999, "< 0.01 um in some subjects" (published)
    "minimum_frequency": 175.0,  # Hz: Brisben et al. 1999, minimum between 150 and 200 Hz (published)
    "flat_below": 40.0,  # Hz: Verrillo 1963 (published)
    "slope_below_db_per_octave": 12.0,  # Verrillo 1963 (published)
    "slope_above_db_per_octave": 12.0,  # chosen (not in our sources)
}
"""The detection threshold curve's figures (module docstring for their sources)."""

LOWEST_FREQUENCY = 20.0
"""Hz: components below are the hand's own motion and the scan, not vibration (chosen)."""


def detection_threshold(frequency) -> np.ndarray:
    """The vibrotactile detection threshold of a hand grasping a handle.

    Parameters
    ----------
    frequency : array_like
        Hz, > 0.

    Returns
    -------
    ndarray
        Peak displacement amplitude (m) at threshold, the shape of ``frequency``: the curve of
        the module docstring, T = T_min (f_min / max(f, 40 Hz))^2 below f_min (12 dB per
        octave) and T_min (f / f_min)^2 above it.

    Raises
    ------
    ParameterError
        For a frequency that is not finite and > 0.
    """
    f = numbers("frequency", frequency, "finite frequencies > 0 (Hz)")
    if not np.all(np.isfinite(f) & (f > 0)):
        raise fail("frequency", f.tolist() if f.size < 8 else "an array", "finite frequencies > 0 (Hz)")
    t = THRESHOLD
    fm, tm = t["minimum_frequency"], t["minimum"]
    below = tm * (fm / np.maximum(f, t["flat_below"])) ** (t["slope_below_db_per_octave"] / (20 * np.log10(2)))
    above = tm * (f / fm) ** (t["slope_above_db_per_octave"] / (20 * np.log10(2)))
    return np.where(f <= fm, below, above)


@dataclass(frozen=True)
class Buzz:
    """The buzz verdict of a handle's motion.

    Parameters
    ----------
    perceptible : bool
        Some component from :data:`LOWEST_FREQUENCY` to the Nyquist frequency, not at a
        harmonic of the texture's own rates, is above the detection threshold.
    margin_db : float
        20 log10(amplitude / threshold) of the component furthest above (or nearest below) it
        (dB); -inf without motion.
    frequency : float
        That component's frequency (Hz); 0 without one.
    amplitude : float
        Its peak displacement amplitude (m), on its axis.
    axis : int
        Its axis (0: x, last: the normal).
    floor : float
        The smallest amplitude the positions can show (m): components at or below it were not
        judged (0 for exact positions; half an encoder step for sensed ones).
    """

    perceptible: bool
    margin_db: float
    frequency: float
    amplitude: float
    axis: int
    floor: float = 0.0


def dequantise(position, resolution: float) -> np.ndarray:
    """The motion behind an encoder's staircase, rebuilt from its transitions.

    A position read on a lattice of step ``resolution`` changes only when the true position
    crosses the boundary between two levels; at each change the true position is, to within
    the tick, the mid-level between the two readings. The positions returned interpolate
    linearly through those crossing points (placed half a tick before the reading that shows
    them) and hold the first and last ones flat: a constant velocity is returned as the
    straight line it is, where the staircase adds a sawtooth at v / resolution and its
    harmonics that no hand feels. This is the fixed-position principle of velocity estimation
    from encoders (the time between transitions, not the count per tick: R. H. Brown, S. C.
    Schneider and M. G. Mulligan, "Analysis of algorithms for velocity estimation from
    discrete position versus time data", IEEE Trans. Industrial Electronics 39(1), 1992).
    Motion within one step (a dither between two levels) returns as the mid-level: it is below
    what the encoder resolves.

    Parameters
    ----------
    position : array_like, shape (n, d)
        Sensed positions (m), one row a tick.
    resolution : float
        The encoder's step (m), >= 0; 0 returns the positions unchanged (exact positions).

    Returns
    -------
    ndarray, shape (n, d)
        m.

    Raises
    ------
    ParameterError
        For positions that are not a finite (n, d) array, or a resolution not finite and >= 0.
    """
    from ._validation import nonnegative

    delta = nonnegative("resolution", resolution, "m")
    p = numbers("position", position, "an (n, d) array of positions (m)", copy=False)
    if p.ndim != 2:
        raise fail("position", f"an array of shape {p.shape}", "shape (n, d)")
    if not np.all(np.isfinite(p)):
        raise fail("position", "an array with non-finite values", "finite positions (m)")
    if delta == 0 or p.shape[0] < 2:
        return p.copy()
    out = np.empty_like(p)
    k = np.arange(p.shape[0], dtype=np.float64)
    for a in range(p.shape[1]):
        u = p[:, a]
        moved = np.flatnonzero(u[1:] != u[:-1]) + 1  # the ticks whose reading changed
        if moved.size == 0:
            out[:, a] = u
            continue
        out[:, a] = np.interp(k, moved - 0.5, 0.5 * (u[moved] + u[moved - 1]))
    return out


def buzz(position, period: float, exclude=(), floor: float = 0.0) -> Buzz:
    """How far above the hand's detection threshold the handle vibrates.

    Parameters
    ----------
    position : array_like, shape (n, d)
        Handle positions (m) sampled every ``period``; n >= 16.
    period : float
        s, > 0.
    exclude : sequence of float, optional
        Rates (Hz), each finite and > 0, the rendering is meant to have (a scan crossing the
        texture's periods): every harmonic of them, +-1.5 bins, is the texture, not buzz (None:
        none).
    floor : float, optional
        m, >= 0: components of at most this amplitude are not judged, as the positions cannot
        show them (for sensed positions, half the encoder's step after :func:`dequantise`;
        default 0, exact positions).

    Returns
    -------
    Buzz

    Raises
    ------
    ParameterError
        For fewer than 16 positions, positions that are not finite numbers, a period not > 0,
        an excluded rate not finite and > 0, or a floor not finite and >= 0.

    Notes
    -----
    Each axis is detrended (least squares line) and Hann-windowed; a component's peak
    amplitude is 2 |X_k| / sum(w), exact for a sinusoid at a bin. The frequency resolution is
    1 / (n T): a run of 1 s resolves 1 Hz.
    """
    from ._validation import nonnegative

    T = positive("period", period, "s")
    floor = nonnegative("floor", floor, "m")
    p = numbers("position", position, "positions (m), shape (n, d) with n >= 16 samples")
    if p.ndim != 2 or p.shape[0] < 16:
        raise fail("position", f"an array of shape {p.shape}", "shape (n, d) with n >= 16 samples")
    if not np.all(np.isfinite(p)):
        raise fail("position", "an array with non-finite values", "finite positions (m)")
    rates = np.atleast_1d(numbers("exclude", () if exclude is None else exclude, "rates (Hz), each finite and > 0"))
    if not np.all(np.isfinite(rates) & (rates > 0)):
        raise fail("exclude", exclude, "rates (Hz), each finite and > 0")
    n = p.shape[0]
    t = np.arange(n) - 0.5 * (n - 1)
    slope = (t @ (p - p.mean(axis=0))) / (t @ t)
    u = p - p.mean(axis=0) - np.outer(t, slope)
    w = np.hanning(n)
    amp = 2.0 * np.abs(np.fft.rfft(u * w[:, None], axis=0)) / w.sum()
    freq = np.fft.rfftfreq(n, T)
    keep = freq >= LOWEST_FREQUENCY
    res = 1.0 / (n * T)
    for rate in rates:
        h = np.maximum(np.round(freq / rate), 1.0)  # the nearest harmonic of each bin
        keep &= np.abs(freq - h * rate) > 1.5 * res
    if not np.any(keep):
        return Buzz(False, -np.inf, 0.0, 0.0, p.shape[1] - 1, floor)
    thr = detection_threshold(freq[keep])
    a_keep = amp[keep]
    with np.errstate(divide="ignore"):
        margin = np.where(a_keep > floor, 20 * np.log10(a_keep / thr[:, None]), -np.inf)
    k, a = np.unravel_index(int(np.argmax(margin)), margin.shape)
    m = float(margin[k, a])
    if m == -np.inf:
        return Buzz(False, -np.inf, 0.0, 0.0, p.shape[1] - 1, floor)
    return Buzz(bool(m > 0), m, float(freq[keep][k]), float(a_keep[k, a]), int(a), floor)
