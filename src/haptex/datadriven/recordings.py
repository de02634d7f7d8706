"""Recordings, read as the rig wrote them, and the spectral difference."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from .._validation import fail, numbers, out_file, positive
from .fitting import fit
from .models import ModelSet

# ---------------------------------------------------------------------------------------
# recordings
# ---------------------------------------------------------------------------------------

RECORDING_COLUMNS = {
    "time_s": "time (s), uniformly sampled (to within TIME_SLACK of an interval); or give the sample rate",
    "acc_m_s2": "acceleration along one axis (m/s²); or the three columns acc_x_m_s2, acc_y_m_s2, acc_z_m_s2",
    "speed_m_s": "tangential speed (m/s), >= 0",
    "force_n": "normal force (N)",
}
"""The columns of a recording's CSV file (header row, one sample a row)."""


@dataclasses.dataclass(frozen=True, eq=False)
class Recording:
    """A tool's acceleration, speed and normal force, sampled together.

    Parameters
    ----------
    acceleration : numpy.ndarray, shape (n,) or (n, 3)
        Acceleration (m/s²).
    speed : numpy.ndarray, shape (n,)
        Tangential speed (m/s).
    normal_force : numpy.ndarray, shape (n,)
        Normal force (N).
    sample_rate : float
        Rate (Hz).
    ignored : tuple of str, optional
        The file's columns no quantity was read from (:func:`read_recording`).
    speed_source : str, optional
        Where the speed came from: ``"given"`` (a speed column or array), or the positions'
        derivative and its filter.

    Raises
    ------
    ParameterError
        If a field is not of its shape, holds a value that is not a finite real number (a
        bool, text or a complex number is not one), a speed is
        negative or the rate is not > 0 (as :func:`fit` refuses them).
    """

    acceleration: np.ndarray
    speed: np.ndarray
    normal_force: np.ndarray
    sample_rate: float
    ignored: tuple = ()
    speed_source: str = "given"

    def __post_init__(self):
        from .fitting import _recording_arrays

        acc, v, F, fs = _recording_arrays(self.acceleration, self.speed, self.normal_force, self.sample_rate)
        for name, value in (("acceleration", acc), ("speed", v), ("normal_force", F), ("sample_rate", fs)):
            object.__setattr__(self, name, value)

    def fit(self, **kwargs) -> ModelSet:
        """Fit a model set to this recording.

        Parameters
        ----------
        **kwargs
            :func:`fit`'s keyword arguments (``rate``, ``order``, ``ma_order``, ...).

        Returns
        -------
        ModelSet
        """
        return fit(self.acceleration, self.speed, self.normal_force, self.sample_rate, **kwargs)

    def write(self, path) -> Path:
        """Write the recording as CSV with :data:`RECORDING_COLUMNS` (17 significant digits).

        Parameters
        ----------
        path : str or os.PathLike
            The file (``.csv``); its folder must exist.

        Returns
        -------
        pathlib.Path

        Raises
        ------
        ParameterError
            If the folder does not exist.
        """
        path = out_file("path", path)
        a = np.asarray(self.acceleration)
        acc_cols = ["acc_m_s2"] if a.ndim == 1 else ["acc_x_m_s2", "acc_y_m_s2", "acc_z_m_s2"]
        t = np.arange(len(self.speed)) / self.sample_rate
        data = np.column_stack([t, a.reshape(len(t), -1), self.speed, self.normal_force])
        np.savetxt(path, data, delimiter=",", fmt="%.17g", header=",".join(["time_s", *acc_cols, "speed_m_s", "force_n"]),
                   comments="")
        return path


RECORDING_QUANTITIES = {"time": "s", "acceleration": "m/s^2", "speed": "m/s", "force": "N", "position": "m"}
"""The quantities a recording's columns may be named for (``--column QUANTITY=COLS:UNIT``), with
their SI units: ``acceleration`` one or three columns, ``force`` the normal force, ``speed``
the tangential speed, or ``position`` one to three columns along the surface (the speed is then
derived: :data:`SPEED_FILTER`), ``time`` (else a sample rate)."""

TIME_SLACK = 0.25
"""How far (a fraction of the sample interval) a recording's time may lie from uniform times
before the file is refused (chosen): a time column is written to a fixed number of decimals (at
44.1 kHz to the microsecond its steps read 22 or 23 us, 0.04 of an interval off) or stamped by a
jittery clock, and its samples are still uniform; a dropped or repeated sample moves the rest by
a whole interval, half of it at least from any line through them all. The rate is the
least-squares line's through the times."""


STATED_TIME_SLACK = 0.5
"""How far (a fraction of the sample interval) a recording's time may lie from uniform times where
its rate is given beside them (``sample_rate``, ``--sample-rate``): the samples are then taken at
that rate and the times' scatter is their stamps' (a host's arrival times; chosen: beyond half an
interval a stamp is nearer another sample's time)."""

STATED_RATE_SLACK = 1e-3
"""How far (relative) a rate given beside a recording's times may be from theirs, the inverse slope
of their least-squares line, before it is refused as another recording's (chosen: a crystal's
tolerance is some 50 ppm)."""


def _uniform_rate(t: np.ndarray, stated: float | None = None) -> float:
    """The rate (Hz) of a recording's times t (n,), s: increasing, each within TIME_SLACK of an
    interval of the least-squares line through them (the rate its slope's inverse); with a rate
    ``stated`` (Hz), that rate, where it is within STATED_RATE_SLACK of the line's and each time
    within STATED_TIME_SLACK of it. Raises ParameterError naming the first sample that is not
    after the one before, the one farthest off that line, or the stated rate and the line's."""
    n = t.size
    if n < 2:
        raise fail("time", f"{n} sample", "uniformly sampled times (s), increasing: two at least")
    dt = np.diff(t)
    back = np.flatnonzero(~(dt > 0))
    if back.size:
        i = int(back[0]) + 1
        raise fail("time", f"sample {i} ({t[i]:.9g} s) not after the one before",
                   "increasing times (s), one a sample")
    k = np.arange(n, dtype=np.float64)
    slope, start = np.polyfit(k, t, 1)
    fs = 1.0 / float(slope)
    if stated is not None and abs(fs - stated) > STATED_RATE_SLACK * fs:
        raise fail("sample_rate", stated, f"the rate of the file's times, {fs:.6g} Hz (their least-squares line), "
                   f"within {STATED_RATE_SLACK:.1%}, or left out (None in Python)")
    off = (t - (start + slope * k)) / slope
    i = int(np.argmax(np.abs(off)))
    slack = TIME_SLACK if stated is None else STATED_TIME_SLACK
    if abs(off[i]) > slack:
        rate = ("" if stated is not None else
                f"; or, where the samples were taken at one rate and only their times scatter (a host's stamps), "
                f"that rate: --sample-rate {fs:.6g} Hz at the command line, sample_rate={fs:.6g} in Python (times "
                f"then within {STATED_TIME_SLACK:g} of an interval)")
        raise fail("time", f"sample {i}: {off[i]:+.2f} of an interval off uniform times",
                   f"times within {slack:g} of an interval of uniform ones (their rounding or a clock's jitter "
                   "below it; a dropped or repeated sample moves the rest by one), or the file resampled to a "
                   f"uniform rate first{rate}")
    return fs if stated is None else float(stated)


SPEED_FILTER = (0.021, 3)
"""The Savitzky-Golay filter (window in s, polynomial order) whose first derivative of the
positions gives the speed when a recording has positions and no speed (chosen: 21 ms, cubic,
as the identification's derivatives; it passes the hand's motion, < 10 Hz, within 0.1 %)."""


def read_recording(path, *, sample_rate: float | None = None, columns=None, speed: float | None = None,
                   normal_force: float | None = None) -> Recording:
    """Read a recording: CSV, NPZ, HDF5, MATLAB .mat, TDMS or LVM, with haptex's names or the rig's.

    Parameters
    ----------
    path : str or os.PathLike
        A CSV file with a header row naming its columns (any order), an ``.npz``, an HDF5
        file (``.h5``/``.hdf5``), a MATLAB ``.mat`` (v5 or v7.3), an NI ``.tdms`` or a
        LabVIEW ``.lvm``: :func:`haptex._columns.read_table`.
    sample_rate : float, optional
        Rate (Hz), when the file has no time column; or beside its times, where the samples
        were taken at one rate and only their times scatter (a host's stamps, up to
        :data:`STATED_TIME_SLACK` of an interval): within :data:`STATED_RATE_SLACK` of theirs.
    columns : sequence of str, optional
        Column specs ``QUANTITY=COL[,COL...][:UNIT]`` (:data:`RECORDING_QUANTITIES`), e.g.
        ``["acceleration=az:g", "force=fz:N", "position=x,y:mm", "time=t:ms"]``. A quantity
        not given is taken from haptex's own names (:data:`RECORDING_COLUMNS`) when the file
        has them. Columns named by neither are ignored and listed in ``Recording.ignored``.
    speed : float, optional
        The tangential speed (m/s, > 0) throughout, for a recording taken at one speed (a scan
        rig's stage) that has no speed or position column (``--speed`` at the command line).
    normal_force : float, optional
        The normal force (N, > 0) throughout, for a recording taken at one force that has no
        force column (``--force`` at the command line).

    Returns
    -------
    Recording

    Raises
    ------
    ParameterError
        If ``path`` is not a path (a str or os.PathLike, PEP 519), the file is missing or
        larger than the memory budget allows, a named column is
        missing (the file's columns are listed), a quantity is missing (acceleration, force,
        and speed or position) or given twice (a column and ``speed`` or ``normal_force``), a
        given speed or force is not a positive number, a value is not a finite number, the times do not increase or
        one lies more than :data:`TIME_SLACK` of an interval from uniform times (a dropped or
        repeated sample), or neither times nor a sample rate are given.

    Notes
    -----
    Without a speed, the speed along the surface is the norm of the positions' first
    derivative by a Savitzky-Golay filter (:data:`SPEED_FILTER`; Savitzky & Golay, Anal. Chem.
    36(8), 1964), computed on the recording's own samples.
    """
    from scipy.signal import savgol_filter

    from .._columns import read_table, take

    table = read_table(path, "recording")
    own = {"time": ("time_s",), "speed": ("speed_m_s",), "force": ("force_n",)}
    own["acceleration"] = (("acc_m_s2",) if "acc_m_s2" in table else
                           ("acc_x_m_s2", "acc_y_m_s2", "acc_z_m_s2"))
    got, ignored = take(table, columns, RECORDING_QUANTITIES, own, "recording")
    n = len(next(iter(got.values()))) if got else 0
    for name, q, option, unit, value in (("speed", "speed", "--speed", "m/s", speed),
                                         ("normal_force", "force", "--force", "N", normal_force)):
        if value is None:
            continue
        value = positive(name, value, unit)
        has = [k for k in ((q, "position") if q == "speed" else (q,)) if k in got]
        if has:
            raise fail(name, value, f"left out ({option} at the command line) where the recording has a {has[0]} "
                       f"column: give its column or the {q}, not both")
        if got:
            got[q] = np.full((n, 1), value)
    for q in ("acceleration", "force"):
        if q not in got:
            mine = "acc_m_s2" if q == "acceleration" else own[q][0]
            raise fail("column", f"{q} missing", f"--column {q}=COLUMN[:UNIT], or haptex's {mine} "
                       f"({RECORDING_COLUMNS[mine]})" + (", or the force throughout (--force 0.5N at the command "
                                                         "line, normal_force=0.5 in Python)" if q == "force" else ""))
    if "speed" not in got and "position" not in got:
        raise fail("column", "speed missing", "--column speed=COLUMN[:UNIT] or --column position=X[,Y]:UNIT "
                   "(the speed is then derived), or haptex's speed_m_s, or the speed throughout (--speed 40mm/s "
                   "at the command line, speed=0.04 in Python)")
    acc, force = got["acceleration"], got["force"]
    if acc.shape[1] not in (1, 3):
        raise fail("--column", f"acceleration with {acc.shape[1]} columns", "one column or three (x, y, z)")
    if force.shape[1] != 1:
        raise fail("--column", f"force with {force.shape[1]} columns", "one column: the normal force")
    if "time" in got:
        fs = _uniform_rate(got["time"][:, 0], None if sample_rate is None else positive("sample_rate", sample_rate,
                                                                                        "Hz"))
    elif sample_rate is None:
        times = [c for c in ignored if c == "X_Value" or c.lower().rsplit("/", 1)[-1] in ("time", "time_s", "t")]
        raise fail("sample_rate", None, "a rate (Hz) for a recording without a time column (--sample-rate at the "
                   "command line)" + (f", or the file's times named: --column time={times[0]}:s" if times else ""))
    else:
        fs = positive("sample_rate", sample_rate, "Hz")
    if "speed" in got:
        source = "given" if speed is None else f"{speed:g} m/s throughout, as given"
        speed = got["speed"][:, 0]
    else:
        pos = got["position"]
        window = max(5, 2 * int(round(SPEED_FILTER[0] * fs / 2)) + 1)
        if window > len(pos):
            raise fail("position", f"{len(pos)} samples", f"at least {window} samples to derive the speed")
        vel = savgol_filter(pos, window, SPEED_FILTER[1], deriv=1, delta=1.0 / fs, axis=0)
        speed = np.sqrt(np.sum(vel * vel, axis=1))
        source = (f"the positions' derivative ({pos.shape[1]} axes; Savitzky-Golay, {window} samples, "
                  f"order {SPEED_FILTER[1]})")
    return Recording(acc[:, 0] if acc.shape[1] == 1 else acc, speed, force[:, 0], fs, tuple(ignored), source)


def spectral_difference(recorded, synthesized, sample_rate: float, band=(20.0, 450.0)) -> float:
    """Mean absolute difference (dB) of two signals' power spectra over a band.

    Parameters
    ----------
    recorded, synthesized : array_like, shape (n,) and (m,)
        Accelerations (m/s²) at ``sample_rate``.
    sample_rate : float
        Rate (Hz).
    band : tuple of float, optional
        (low, high) frequencies (Hz) compared.

    Returns
    -------
    float
        mean over the band of |10 log10(P_synth / P_rec)| (dB), each spectrum estimated by
        :func:`scipy.signal.welch` (Hann windows of 0.1 s or the signal, half overlapping):
        the spectral measure of the HaTT papers (Culbertson et al. 2014).

    Raises
    ------
    ParameterError
        If the band is not within (0, sample_rate / 2) or a signal is shorter than 64 samples.
    """
    from scipy.signal import welch

    fs = positive("sample_rate", sample_rate, "Hz")
    lo, hi = (float(b) for b in band)
    if not 0 < lo < hi <= fs / 2:
        raise fail("band", band, f"(low, high) with 0 < low < high <= {fs / 2:g} Hz")
    x, y = (numbers(name, v, "a signal: an array of numbers", copy=False)
            for name, v in (("recorded", recorded), ("synthesized", synthesized)))
    if x.size < 64 or y.size < 64:
        raise fail("recorded", f"{min(x.size, y.size)} samples", "signals of at least 64 samples")
    nper = int(min(max(64, round(0.1 * fs)), x.size, y.size))
    f, px = welch(x, fs, nperseg=nper)
    _, py = welch(y, fs, nperseg=nper)
    sel = (f >= lo) & (f <= hi)
    return float(np.mean(np.abs(10 * np.log10(np.maximum(py[sel], 1e-300) / np.maximum(px[sel], 1e-300)))))


