"""DFT321 and the fit of a model set to a recording."""

from __future__ import annotations

import dataclasses

import numpy as np

from .._validation import fail, numbers, positive, whole
from .lsf import MAX_ORDER
from .models import ArmaModel, ModelSet

# ---------------------------------------------------------------------------------------
# fitting from recordings
# ---------------------------------------------------------------------------------------


def dft321(acceleration, block: int | None = None) -> np.ndarray:
    """Reduce a three-axis acceleration to one axis, keeping its spectrum (DFT321).

    Parameters
    ----------
    acceleration : array_like, shape (n, 3)
        Acceleration (m/s²) along three orthogonal axes.
    block : int, optional
        Reduce the signal block by block, each of ``block`` samples: half-overlapping blocks
        under a square-root Hann window, each reduced on its own and overlap-added under the
        same window (weighted overlap-add: the squared windows sum to 1, so a signal along one
        fixed direction comes back unchanged and the power of two blocks of different
        directions is kept through their overlap). Default: the whole signal as one block. A
        recording whose direction of vibration changes from stroke to stroke is reduced block
        by block, as Landin et al. do over short windows: over the whole of it, each
        frequency's magnitude pools every stroke's and its phase is the sum's, which spreads
        one stroke's power over the others (:func:`fit` reduces over blocks of its windows'
        length).

    Returns
    -------
    numpy.ndarray, shape (n,)
        The signal whose DFT has, in each block and at each frequency, the magnitude
        sqrt(|A_x|² + |A_y|² + |A_z|²) and the phase of A_x + A_y + A_z (Landin, Romano,
        McMahan & Kuchenbecker, "Dimensional reduction of high-frequency accelerations for
        haptic rendering", EuroHaptics 2010): its power spectrum is the sum of the three axes'.

    Raises
    ------
    ParameterError
        If the array is not (n, 3) with n >= 2, not finite real numbers (a bool, text or a
        complex number is not one), or ``block`` is not an integer >= 4.
    """
    a = numbers("acceleration", acceleration, "an (n, 3) array of numbers (m/s^2)", copy=False)
    if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] < 2:
        raise fail("acceleration", f"shape {a.shape}", "an (n, 3) array (three axes, m/s^2)")
    if not np.all(np.isfinite(a)):
        raise fail("acceleration", "non-finite samples", "finite numbers (m/s^2)")
    n = a.shape[0]
    if block is None:
        return _dft321_rows(a[None])[0]
    block = whole("block", block, 4, what="samples")
    hop = min(int(block), n + n % 2) // 2
    L = 2 * hop
    w = np.sqrt(0.5 - 0.5 * np.cos(2 * np.pi * np.arange(L) / L))  # sqrt of the periodic Hann window
    k = -(-n // hop)  # blocks of hop samples holding the signal, then one on each side
    xp = np.zeros(((k + 2) * hop, 3))
    xp[hop : hop + n] = a
    frames = np.lib.stride_tricks.sliding_window_view(xp, L, axis=0)[::hop]  # (k + 1, 3, L)
    y = _dft321_rows(np.swapaxes(frames, 1, 2) * w[None, :, None]) * w  # (k + 1, L)
    out = np.zeros(xp.shape[0])
    out[: (k + 1) * hop] += y[:, :hop].ravel()
    out[hop : (k + 2) * hop] += y[:, hop:].ravel()
    return out[hop : hop + n]


def _dft321_rows(a: np.ndarray) -> np.ndarray:
    """DFT321 of each block: ``a`` of shape (k, m, 3) -> (k, m)."""
    spec = np.fft.rfft(a, axis=1)
    mag = np.sqrt(np.sum(np.abs(spec) ** 2, axis=2))
    phase = np.angle(spec.sum(axis=2))
    return np.fft.irfft(mag * np.exp(1j * phase), n=a.shape[1], axis=1)


@dataclasses.dataclass(frozen=True)
class FitReport:
    """What :func:`fit` did: the choices it made and what it kept.

    Parameters
    ----------
    order : tuple of int
        (p, q): the AR and MA orders.
    criterion : str
        How p was chosen ("BIC over the segments, p = 1 to max_order", or "given").
    segments : int
        Steady windows kept, of ``windows`` in the recording.
    windows : int
        Windows of ``segment`` seconds in the recording.
    cells : int
        Operating-point cells (one model each).
    sample_rate : float
        Rate (Hz) of the models.
    highpass : float
        Cut-off (Hz) of the high-pass that removed the hand's motion.
    axes : int, optional
        Axes of the recorded acceleration (3: reduced by :func:`dft321` over each window).
    notes : tuple of str, optional
        What the fit could not settle and what to do (the order at its cap).
    """

    order: tuple[int, int]
    criterion: str
    segments: int
    windows: int
    cells: int
    sample_rate: float
    highpass: float
    axes: int = 1
    notes: tuple[str, ...] = ()


def _recording_arrays(acceleration, speed, normal_force, sample_rate):
    """A recording's samples checked: (acceleration (n,) or (n, 3) m/s^2, speed (n,) m/s >= 0,
    normal force (n,) N, all finite; the rate > 0, Hz), as float arrays and the rate; refused
    naming the first that is not (:func:`fit` and :class:`~haptex.datadriven.Recording`)."""
    fs = positive("sample_rate", sample_rate, "Hz")
    acc = numbers("acceleration", acceleration, "an (n,) or (n, 3) array of numbers (m/s^2)", copy=False)
    if not (acc.ndim == 1 or (acc.ndim == 2 and acc.shape[1] == 3)) or acc.shape[0] < 1:
        raise fail("acceleration", f"shape {np.shape(acceleration)}", "an (n,) or (n, 3) array (m/s^2)")
    n = acc.shape[0]
    arrays = [acc]
    for nm, given in (("speed", speed), ("normal_force", normal_force)):
        arrays.append(numbers(nm, given, f"({n},): one number per sample of acceleration", copy=False))
    v, F = arrays[1:]
    for nm, arr, unit in (("acceleration", acc, "m/s^2"), ("speed", v, "m/s"), ("normal_force", F, "N")):
        if arr.shape[:1] != (n,) or (arr is not acc and arr.ndim != 1):
            raise fail(nm, f"shape {arr.shape}", f"({n},): one value per sample of acceleration")
        bad = ~np.isfinite(arr)
        if bad.ndim == 2:
            bad = bad.any(axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            raise fail(nm, f"{arr[k] if arr.ndim == 1 else arr[k].tolist()} at sample {k}", f"finite numbers ({unit})")
    if np.any(v < 0):
        k = int(np.argmax(v < 0))
        raise fail("speed", f"{v[k]:g} m/s at sample {k}", "speeds >= 0 (m/s; the tangential speed's magnitude): "
                   "for a signed velocity, its absolute value, or the positions instead (--column position=X[,Y]:UNIT, "
                   "read_recording's columns=['position=...'] in Python), whose derivative's magnitude is then taken")
    return acc, v, F, fs


def fit(acceleration, speed, normal_force, sample_rate: float, *, rate: float | None = None,
        order: int | None = None, ma_order: int = 0, max_order: int = 30, segment: float = 0.2,
        highpass: float = 20.0, steadiness: float = 0.2, min_speed: float = 0.005, min_force: float = 0.05,
        grid: int = 6, name: str = "") -> ModelSet:
    """Fit a model set to a recording of a tool dragged over a surface.

    Parameters
    ----------
    acceleration : array_like, shape (n,) or (n, 3)
        The tool's acceleration (m/s²); three axes are reduced to one by :func:`dft321` over
        each window of ``segment`` seconds (after the high-pass and the resampling), so that
        strokes in different directions are each reduced along their own.
    speed : array_like, shape (n,)
        Tangential speed (m/s), >= 0.
    normal_force : array_like, shape (n,)
        Normal force (N).
    sample_rate : float
        Rate (Hz) of the recording.
    rate : float, optional
        Rate (Hz) of the models (the renderer's servo rate); default ``sample_rate``. The
        recording is resampled (:func:`scipy.signal.resample_poly`).
    order : int, optional
        The AR order p; default: the p in 1..``max_order`` that minimises the Bayesian
        information criterion summed over the segments.
    ma_order : int, optional
        The MA order q (0: AR models, fitted by Yule-Walker, always stable; > 0: ARMA by
        :class:`statsmodels.tsa.arima.model.ARIMA`, stationary and invertible).
    max_order : int, optional
        Largest p tried when ``order`` is not given (<= :data:`MAX_ORDER`).
    segment : float, optional
        Length (s) of the windows in which the operating point is judged steady.
    highpass : float, optional
        Cut-off (Hz) of the 4th-order Butterworth high-pass (zero phase) that removes the
        hand's motion and keeps the texture band.
    steadiness : float, optional
        Largest relative standard deviation of speed and of force in a steady window.
    min_speed : float, optional
        Slowest mean speed (m/s) of a kept window (a tool at rest records no texture).
    min_force : float, optional
        Least mean normal force (N) of a kept window (out of contact below it).
    grid : int, optional
        Steady windows are pooled in ``grid`` x ``grid`` cells over their speed and force
        range, one model a cell (at the cell's mean operating point).
    name : str, optional
        The set's name.

    Returns
    -------
    ModelSet
        Its :attr:`~ModelSet.report` is the :class:`FitReport`.

    Raises
    ------
    ParameterError
        If the arrays disagree in length, hold NaN or an entry that is not a real number (a
        bool, text or a complex number), a speed is negative, the recording is too
        short for the order (fewer than 10 p samples in a cell) or has no steady window.

    Notes
    -----
    The steps of Romano & Kuchenbecker (2012) and Culbertson et al. (2014): one axis, the
    texture band, steady segments, one model per operating point, the set triangulated.
    The AR models are Yule-Walker's from each cell's pooled autocovariance, each stretch of
    signal tapered at its ends first (:data:`TAPER`); the autocovariance and Levinson-Durbin are
    statsmodels' (:func:`~statsmodels.tsa.stattools.acovf`,
    :func:`~statsmodels.tsa.stattools.levinson_durbin`).
    """
    from scipy.signal import butter, resample_poly, sosfiltfilt

    acc, v, F, fs = _recording_arrays(acceleration, speed, normal_force, sample_rate)
    n = acc.shape[0]
    out_fs = fs if rate is None else positive("rate", rate, "Hz")
    ma_order = whole("ma_order", ma_order, 0, MAX_ORDER)
    max_order = whole("max_order", max_order, 1, MAX_ORDER)
    order = None if order is None else whole("order", order, 1, MAX_ORDER)
    grid = whole("grid", grid, 1, 100, "cells a side")
    from .._validation import in_range, nonnegative

    in_range("steadiness", steadiness, 0.0, 1.0)
    nonnegative("min_speed", min_speed, "m/s")
    nonnegative("min_force", min_force, "N")
    hp = positive("highpass", highpass, "Hz")
    if hp >= out_fs / 2:
        raise fail("highpass", hp, f"below the models' Nyquist frequency, {out_fs / 2:g} Hz")
    seg = positive("segment", segment, "s")
    # the texture band, then the models' rate
    if n < 64:
        raise fail("acceleration", f"{n} samples", "a recording of at least 64 samples")
    raw_ms = float(np.mean(np.square(acc)))  # (the recording's own scale: what the high-pass leaves of a constant is rounding)
    acc = sosfiltfilt(butter(4, hp, "highpass", fs=fs, output="sos"), acc, axis=0)
    if out_fs != fs:
        from fractions import Fraction

        r = Fraction(out_fs / fs).limit_denominator(1000)
        if abs(float(r) - out_fs / fs) > 1e-6 * out_fs / fs:
            raise fail("rate", out_fs, f"a rate in a ratio of integers up to 1000 to {fs:g} Hz")
        t_in = np.arange(n) / fs
        acc = resample_poly(acc, r.numerator, r.denominator, axis=0)
        t_out = np.arange(acc.shape[0]) / out_fs
        v, F = np.interp(t_out, t_in, v), np.interp(t_out, t_in, F)
    w = int(round(seg * out_fs))
    if w < 16:
        raise fail("segment", seg, f"at least {16 / out_fs:g} s (16 samples at {out_fs:g} Hz)")
    nwin = acc.shape[0] // w
    if nwin < 1:
        raise fail("acceleration", f"{acc.shape[0] / out_fs:g} s", f"a recording longer than one segment ({seg:g} s)")
    if acc.ndim == 2:  # three axes: DFT321 over each window, where the stroke's direction holds
        acc = dft321(acc[: nwin * w], block=w)
    A = acc[: nwin * w].reshape(nwin, w)
    V = v[: nwin * w].reshape(nwin, w)
    FF = F[: nwin * w].reshape(nwin, w)
    mv, mf = V.mean(axis=1), FF.mean(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        steady = ((V.std(axis=1) <= steadiness * mv) & (FF.std(axis=1) <= steadiness * np.abs(mf))
                  & (mv >= min_speed) & (mf >= min_force))
    if not steady.any():
        raise fail("speed", f"no steady window of {seg:g} s (of {nwin})",
                   f"a recording with windows where speed >= {min_speed:g} m/s and force >= {min_force:g} N vary by "
                   f"at most {steadiness:.0%} (or a larger steadiness)")
    idx = np.flatnonzero(steady)
    gs, gf = _cells(mv[idx], grid), _cells(mf[idx], grid)
    held_v, held_f = _held(mv[idx], gs), _held(mf[idx], gf)
    cells = {}
    for k, c in zip(idx, zip(gs, gf)):
        cells.setdefault(c, []).append(k)
    groups = [np.array(ks) for ks in cells.values()]
    labels = list(cells)
    p_max = int(max_order if order is None else order)
    shortest = min(len(g) * w for g in groups)
    if shortest < 10 * p_max:
        raise fail("segment", seg, f"cells of at least {10 * p_max} samples for order {p_max} "
                   f"(the shortest has {shortest}): longer segments, a lower order or a coarser grid")
    from statsmodels.tsa.stattools import acovf, levinson_durbin

    from scipy.signal.windows import tukey

    notes = []
    sig = []  # innovation variance of each cell at orders 1..p_max
    for g in groups:
        # the cell's runs of consecutive windows, each one stretch of signal: the biased
        # autocovariance over a run (positive semi-definite, so Levinson's AR is stable), the
        # run tapered at its ends (TAPER) and normalised by the taper's energy; over single
        # windows it misplaced resonances near the unit circle
        ac, total, energy = np.zeros(p_max + 1), 0, 0.0
        for run in np.split(g, np.flatnonzero(np.diff(g) != 1) + 1):
            x = A[run].ravel()
            taper = tukey(x.size, TAPER)
            ac += acovf((x - x.mean()) * taper, adjusted=False, fft=True, nlag=p_max) * x.size
            total += x.size
            energy += float(np.sum(taper**2))
        # a still accelerometer (or one reading only gravity): no process to fit; what the
        # high-pass leaves of a constant is rounding, 1e-16 of it, and Levinson's recursion fitted
        # 30 poles to that (STILL, relative to the recording's mean square)
        if not ac[0] / energy > STILL * raw_ms:
            raise fail("acceleration", f"constant over the steady windows at {mv[g].mean():.3g} m/s, "
                       f"{mf[g].mean():.3g} N", "a vibration (an acceleration that varies) in every steady window: "
                       "is the acceleration column the accelerometer's?")
        _, _, _, s, phi = levinson_durbin(ac / energy, nlags=p_max, isacov=True)
        sig.append((np.asarray(s)[1:], np.asarray(phi), total))
    if order is None:
        bic = np.zeros(p_max)
        for s, _, m in sig:
            bic += m * np.log(np.maximum(s, 1e-300)) + np.arange(1, p_max + 1) * np.log(m)
        p = int(np.argmin(bic)) + 1
        crit = f"BIC summed over the cells, p = 1 to {p_max}"
        if p == p_max:
            notes.append(f"the order reached its cap (p = {p_max}): the information criterion still fell there, so "
                         "a higher order may fit better (max_order up to "
                         f"{MAX_ORDER}, --order); a high-pass at or inside the texture band (here {hp:g} Hz) is "
                         "itself a steep edge that takes many poles: a lower --highpass lowers the order")
    else:
        p = p_max
        crit = "given"
    models = []
    for (cv, cf), g, (s, phi, m) in zip(labels, groups, sig):
        # a held speed or force is the same for every model at it (the triangles then have no
        # slivers); otherwise the cell's own mean
        op_v = held_v.get(cv, float(mv[g].mean()))
        op_f = held_f.get(cf, float(mf[g].mean()))
        if ma_order == 0:
            ar = np.concatenate([[1.0], -phi[1 : p + 1, p]])  # statsmodels: column p holds order p's coefficients
            models.append(ArmaModel(ar, [1.0], float(s[p - 1]), 1.0, out_fs, op_v, op_f))
        else:
            models.append(_arma_cell(A[g], p, int(ma_order), out_fs, op_v, op_f))
    report = FitReport((p, int(ma_order)), crit, int(idx.size), int(nwin), len(models), out_fs, hp,
                       3 if np.ndim(acceleration) == 2 else 1, tuple(notes))
    s = ModelSet(models, name=name)
    s.report = report
    return s


STILL = 1e-18
"""A steady window's band-passed mean square at most this fraction of the recording's raw mean
square is no vibration (chosen: a constant 1 or 9.81 m/s^2 through the 20 Hz high-pass of a
2 s recording at 10 kHz leaves 6e-30 and 3e-29 of its mean square, measured; gravity read with
1 mm/s^2 of noise, 1e-8)."""


TAPER = 0.01
"""Fraction of each stretch of signal :func:`fit` tapers before its autocovariance: scipy's Tukey
(split-cosine) window, a half-cosine rise over 0.5 % of the stretch at each end (chosen; the
Yule-Walker estimator's leakage through a stretch's abrupt ends, which a taper removes: Percival
& Walden 1993, sec. 9.4). Measured on four 10 s strokes of known ARMA(4,1) processes with 1 %
sensor noise, one and three axes, three seeds (24 strokes, the truth by scipy.signal.freqz),
mean error over 20-450 Hz: recorded at 10 kHz, untapered up to 1.25 dB (two strokes past 1 dB;
+4.5 dB at 450 Hz, where the truth is 52 dB under its peak), tapered at most 0.59 dB; at 1 and
2.5 kHz at most 0.47 and 0.40 dB untapered, 0.38 and 0.32 dB tapered. On a stylus's band-limited
profile recorded at 2 kHz (eight profile seeds; the truth its flat height spectrum, at 13
wavenumbers 1-4 /mm) the height spectrum's error is 0.51 dB mean both ways, at most 1.46 dB
untapered and 1.32 dB tapered; tapering 10 % of each stretch made it 0.67 and 2.03 dB (a
brick-wall spectrum at BIC's cap, whose fit the untapered estimator's bias smooths)."""


def _cells(x: np.ndarray, grid: int) -> np.ndarray:
    """Cell labels of the windows' mean operating points ``x`` along one axis: in order of value,
    a new cell where the next value is more than half a grid width (the range / ``grid``) past the
    last, or a grid width past the cell's first. Equal-width cells for values spread over the
    range; one cell for each of a few discrete operating points (a window's mean scatters a
    little around each: a fixed grid's edge could fall among them and split one point in two)."""
    lo, hi = float(x.min()), float(x.max())
    if hi - lo <= 1e-9 * max(abs(hi), 1e-300):
        return np.zeros(x.size, dtype=int)
    width = (hi - lo) / grid
    order = np.argsort(x, kind="stable")
    xs = x[order]
    labels = np.empty(x.size, dtype=int)
    cell, first = 0, xs[0]
    for i, value in enumerate(xs):
        if i and (value - xs[i - 1] > 0.5 * width or value - first > width):
            cell, first = cell + 1, value
        labels[order[i]] = cell
    return labels


HELD = 0.02
"""Largest spread of a cell's window means, relative to their mean, for :func:`fit` to take its
speed (or force) as held: the models at it share one value, the mean over all its windows
(chosen: the windows of a held speed scatter by 0.01-0.3 % in haptex's scans; a hand's free
strokes spread over a cell's width, a tenth of the range or more)."""


def _held(x: np.ndarray, labels: np.ndarray) -> dict:
    """The cells of :func:`_cells` whose window means ``x`` lie within :data:`HELD` of their mean:
    {label: that mean}."""
    out = {}
    for c in np.unique(labels):
        v = x[labels == c]
        mean = float(v.mean())
        if float(v.max() - v.min()) <= HELD * abs(mean):
            out[int(c)] = mean
    return out


def _arma_cell(x: np.ndarray, p: int, q: int, fs: float, v: float, f: float) -> ArmaModel:
    import warnings

    from statsmodels.tsa.arima.model import ARIMA

    series = (x - x.mean(axis=1, keepdims=True)).ravel()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # statsmodels' convergence chatter; the result is checked below
        res = ARIMA(series, order=(p, 0, q), trend="n", enforce_stationarity=True, enforce_invertibility=True).fit()
    ar = np.concatenate([[1.0], -np.asarray(res.arparams)])
    ma = np.concatenate([[1.0], np.asarray(res.maparams)])
    return ArmaModel(ar, ma, float(res.params[-1]), 1.0, fs, v, f)


