"""Your device, identified: its model fitted from a logged run (``haptex.identify``).

A run log holds, at each servo tick, the time, the sensed position and the force commanded
(:data:`LOG_COLUMNS`; ``haptex run --record FILE.csv`` writes it). :func:`identify` fits the
device model haptex simulates to it: a rigid handle of mass m and viscous damping b on each
axis, isotropic Coulomb friction f_c (a sampled Karnopp model), the force held over each
period (zero-order hold; each tick's own interval where the log's times say so,
:data:`TICK_TOLERANCE`) and applied ``delay`` whole periods after it was commanded, the
positions read on an encoder's lattice of step delta.

The method is output-error identification over windows (Ljung, *System Identification:
Theory for the User*, 2nd ed., 1999, Sections 4.2 and 7.3, the output-error model; the
windows are the multiple-shooting of Bock's parameter estimation, each window's initial
position and velocity estimated with the device's figures, and each window's simulated end
matched to the next one's start, :data:`CONTINUITY`): the model's positions, simulated
by the C core's exact sampled-data step (the core's ``free_run``: on one axis the exact
continuous-time stick-slip, each period split where the velocity reaches zero; on two or three
axes the sampled Karnopp step of the simulator's general loop), are fitted to the logged ones
by ``scipy.optimize.least_squares``; one standard deviation of each figure from the Jacobian at
the optimum: the larger of the Gauss-Newton covariance's, s^2 (J^T J)^-1, and the
window-clustered sandwich's (the residuals of one window may be correlated in any way). The
delay is the whole number of periods whose fit leaves the smallest residual: every delay from 0 to ``max_delay`` is fitted
to its own optimum on :data:`SCREEN_WINDOWS` windows spread over the log, from
:data:`SCREEN_STARTS` (an equation-error regression's figures, the positions' Savitzky-Golay
derivatives), and the best is fitted on every window; the runner-up's residual is reported.
The encoder step is the lattice the positions lie on (the greatest common step of their
increments), when they lie on one. What the log cannot tell (a motion over too few encoder
steps, two delays that fit alike) is reported as not determined.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import NamedTuple

import numpy as np

from ._validation import ParameterError, a_path, fail, numbers, positive, random_seed, whole
from .catalogue import checked_device

LOG_COLUMNS = {
    "time_s": "the tick's time (s), increasing at the servo period",
    "x_m": "sensed position along x (m)",
    "y_m": "sensed position along y (m), 3-D logs",
    "z_m": "sensed position along z (m), 2-D and 3-D logs",
    "fx_n": "force commanded along x (N), as sent to the device",
    "fy_n": "force commanded along y (N), 3-D logs",
    "fz_n": "force commanded along z (N), 2-D and 3-D logs",
    "engaged": "1 where the servo's forces were engaged, else 0 (optional)",
}
"""The run log's CSV columns (a header row names them; SI units, in the names)."""
AXES = {1: "x", 2: "xz", 3: "xyz"}
"""The axes a log of each dimension has (a planar device's plane is x-z, as haptex's)."""
WINDOW = 0.2
"""Length of one output-error window (s, chosen): long enough that the mass and damping
shape the motion (0.2 s is 200 samples at 1 kHz), short enough that the model's error does
not accumulate over the whole log."""
LONG_WINDOW = 1.0
"""The longer window (s, chosen) :func:`identify` also fits when the damping's relative
deviation at :data:`WINDOW` passes :data:`LONG_WINDOW_TRIGGER`: a handle whose time constant m/b
is seconds long (500 g, 0.1 N·s/m: 5 s) loses little speed to its damping inside 0.2 s, and on a
60 µm encoder's log the damping came back 24-29 % high at 0.2 s, -1.6 to +1.0 % at 1 s."""
LONG_WINDOW_TRIGGER = 0.05
"""The damping's relative standard deviation at :data:`WINDOW` above which :func:`identify`
also fits :data:`LONG_WINDOW` and keeps the fit whose damping is the better determined (chosen:
at 2 % the default window was the better one, 12 % the worse)."""
LONG_WINDOW_RMS = 0.25
"""On an encoder's log, :func:`identify` keeps the :data:`LONG_WINDOW` fit when its residual RMS
is within this fraction above the larger of the :data:`WINDOW` fit's and the rounding's
(delta/sqrt(12)) (chosen: on the independent simulator's 60 µm logs the long windows read
1.0-1.1 times the rounding, the short ones 0.9-1.0, fitting the rounding with their many free
starts; a long fit stopped far from the positions read 3 mm, a model that drifts over a second
would read more). The lattice's rounding is a function of the motion shared by every window, so
the short windows' deviations (clustered by window) miss it: on one 500 g, 3 N·s/m, 0.2 N, 60 µm oracle trajectory
rounded at ten lattice offsets, the damping spread over -5.4..+14.7 % at 0.2 s (sd 6.6 %, each
fit reporting 0.4-4.9 %) and -0.2..+4.4 % at 1 s (sd 1.8 %)."""
MIN_WINDOWS = 5
"""Fewest windows a log must fill (so 1 s at the default window)."""
TICK_TOLERANCE = 0.5
"""Largest relative departure of a tick's interval from the log's period (the intervals' median)
for it to count as a tick (chosen: a loop without a real-time clock, whose ticks come 0.5 to
1.5 periods apart). Each such interval is modelled as it was logged, the force held over it (a
loop's jitter; with each period taken as the median instead, intervals drawn within +-9 % moved
the independent simulator's figures by up to 0.3 % (mass), 2.0 % (damping) and 0.14 %
(friction)). A longer or shorter one *strays*: a missed tick, or samples the logger dropped while
the loop ran on, which no model of the log can tell apart, so no output-error window spans it
and the windows between them are fitted as any others."""
MAX_DELAY = 10
"""Largest delay searched (periods, chosen: haptic devices' computation delays are 0-2)."""
MIN_STEPS = 20
"""Fewest encoder steps the motion must span for mass, damping, friction and delay to be told
(chosen: over fewer, the rounding is the motion)."""
DELAY_MARGIN = 0.01
"""Least relative difference between the best delay's residual and the runner-up's for the
delay to count as determined (chosen)."""
DELAY_FLOOR_MARGIN = 0.05
"""On an encoder's log, least difference between the runner-up delay's residual RMS and the
best one's, as a fraction of the rounding's delta/sqrt(12), for the delay to count as determined
(chosen: where both fit to the rounding, 1 % of the residual is no evidence. On the independent
simulator's 60 µm logs of a 500 g, 3 N·s/m, 0.2 N handle under forces below 20 Hz, delays 1 and
0 read e.g. 17.7 and 17.9 µm for a rounding of 17.3 µm: delay 1 for 0 was returned as
determined with a figure 8.5-10.2 deviations off on three program seeds of seven (which ones
moved with the number of BLAS threads); now undetermined, within 1.0-1.3. Over the issue's 96
60 µm and 7.5 µm logs of two seeds it also says undetermined, the delay still exact, for 6 logs
of the 500 g handles with friction: four below 20 Hz, two with delay 4 under steps and a chirp)."""
DELAY_RECHECK = 0.1
"""On an encoder's log whose runner-up delay screened within this fraction of the best one's
residual, the best and its neighbours are compared again on :data:`LONG_WINDOW` windows
(chosen: there the screening's residuals of delays 0 and 1 came within 1.6 % where the 1 s
windows tell them by 8 %; a clearly determined delay, e.g. 17 against 65 µm, costs no refit)."""
SCREEN_WINDOWS = 8
"""Windows (spread over the log) on which every delay of the range is fitted before the best
are fitted on all (chosen: 2.4 s at the default window, enough to rank the delays)."""
SCREEN_STARTS = (1.0, 0.1)
"""Factors on the equation error's damping from which each delay's screening fit starts (chosen:
on closed-loop logs with friction the equation error's damping is 2-6 times the truth)."""
SCREEN_REACH = 2
"""The delays on each side of the best screened one fitted again from its figures (chosen)."""
SCREEN_NFEV = 40
"""Most residual evaluations of one screening fit (chosen: ranking needs no last digit)."""
MAX_SAMPLES = 2_000_000
"""Most samples identified at once (chosen: 33 min at 1 kHz; least squares holds a few
copies of them)."""
CONTINUITY = 3.0
"""Weight of the matching conditions between contiguous output-error windows (Bock's multiple
shooting: each window's end state, simulated, against the next window's estimated start; the
position in the residuals' units, the velocity times the window's length). Chosen: on the
independent simulator's 96 logs of the issue's range (seeds 1 and 2) 95 and 95 meet every
goal, without it 94 and 94; at 1, 94 and 94; the 500 g, 3 N·s/m, 0.2 N handle on a 60 µm
encoder below 20 Hz: damping +6.6 % and the delay one off without it, +0.2 % and the delay
right at 3 (at 0.3 on seed 2: +2.4 % and one off); the 5 s time constant there +5.1 % without,
+5.9 % at 3 (within 0.1 of its deviations)."""
TOLD = 3.0
"""A handle's mass or damping (on any axis) closer to zero than this many of its standard
deviations is said not determined, with its bound: the log does not tell it from none (chosen:
three deviations, the tests' own bar for an honest deviation. On the independent simulator's
60 µm logs of a 500 g handle damped by 0.1 N·s/m, a 5 s time constant, under forces below
20 Hz, delays 0 and 1 fit alike on six program seeds of eight and their dampings differ by
about half of it: deviations of 34-57 % of the damping, which came back -0.2 to +6.1 % off)."""
CELL_MARGIN = 2.0
"""On an encoder's log the delay is told by the encoder's cells (:func:`_cells_delay`) where the
best delay's cost (its fit's summed squared distances from the cells) is this many times below
every other's (chosen: on the independent simulator's 60 µm logs at 4 kHz, 500 g handles with
0.2 N of friction and 1 µm of noise, the truth's cost lay 2.6 to 8.2 times below the next one's,
where least squares on the positions fitted delays 0 to 10 alike)."""
MAX_DENSE_FIT = 1_000_000
"""Most Jacobian entries (rows x figures) for which an output-error fit solves its steps densely
(scipy's exact trust region); a larger one uses lsmr (chosen: the final fit of a 10 s log at
4 kHz on 0.2 s windows, 40,000 x 101, took 7.0 s dense and 0.35 s by lsmr)."""
MAX_CELL_DENSE = 10_000_000
"""Most Jacobian entries (rows x figures) for which the cells' fit solves its steps densely
(scipy's exact trust region: 6-16 evaluations, 0.4-0.8 s on a 10 s log at 4 kHz, where lsmr
took its 200 without converging); a larger log's fit uses lsmr (chosen: 80 MB)."""
CELL_DEVIATION_ROWS = 5
"""Positions per fitted parameter (the figures and every window's start) that must lie outside
their encoder cells at the cells' fit's optimum for its residuals to give the figures'
deviations (:func:`_cells_fit`; chosen): with fewer the cost is flat inside the cells, in some
directions or all, and the deviations stay least squares'. Measured on the independent
simulator's 60 µm logs of 10 s: with 1 µm of noise 146 positions left their cells at 1 kHz and
454 at 4 kHz (21 parameters); without noise, 1."""
CELL_PROBE = 0.3
"""Where no position leaves its cell at the cells' fit's optimum (a noise-free encoder) and a
mass or damping's least-squares deviation would leave it not determined (:data:`TOLD`), it is
held this fraction below and above its figure and the rest refitted to the cells; where both
leave a position outside its cell (by more than three times the optimum's largest distance, and
a thousandth of a step), every figure that keeps the positions in their cells lies within it,
and its deviation is this fraction of it over :data:`TOLD` (chosen: below 1 / TOLD, so such a
figure is told; at 4 kHz a 500 g, 0.1 N·s/m handle under random forces held at 0.7 and 1.3
times its damping left positions 1.0 µm outside their 60 µm cells, at 0.9 and 1.1 times 0.35 µm)."""
PLAUSIBLE_MASS = (1e-3, 20.0)
"""The masses (kg) of haptic handles, widely (chosen: from a pantograph's few grams to the
kilograms of an admittance-controlled arm); an identified mass outside is noted, most often a
position or force read in the wrong unit (a factor of 1000)."""


@dataclass(frozen=True)
class RunLog:
    """A run log read from a file (:func:`read_log`).

    Parameters
    ----------
    time : numpy.ndarray, shape (n,)
        s.
    position : numpy.ndarray, shape (n, d)
        m, axes :data:`AXES` [d].
    force : numpy.ndarray, shape (n, d)
        N, as commanded.
    engaged : numpy.ndarray of bool, shape (n,) or None
        Where the servo's forces were engaged, when the log says.
    path : str
        The file.
    ignored : tuple of str, optional
        The file's columns no quantity was read from.
    """

    time: np.ndarray
    position: np.ndarray
    force: np.ndarray
    engaged: np.ndarray | None
    path: str
    ignored: tuple = ()


def _columns(d: int) -> list[str]:
    axes = AXES[d]
    return ["time_s"] + [f"{a}_m" for a in axes] + [f"f{a}_n" for a in axes]


def write_log(path, time, position, force, engaged=None) -> Path:
    """Write a run log (CSV, :data:`LOG_COLUMNS`, 17 significant digits: exact round trip).

    Parameters
    ----------
    path : str or os.PathLike
    time : array_like, shape (n,)
        s.
    position, force : array_like, shape (n,) or (n, d), d in 1..3
        m and N.
    engaged : array_like of bool, shape (n,), optional

    Returns
    -------
    pathlib.Path

    Raises
    ------
    ParameterError
        For a ``path`` that is not a path (a str or os.PathLike, PEP 519), arrays of
        different lengths or a dimension other than 1-3.
    """
    out = a_path("path", path, "a run log's path")
    t, p, f = _shaped(time, position, force)
    cols = _columns(p.shape[1])
    data = [t[:, None], p, f]
    if engaged is not None:
        cols.append("engaged")
        data.append(np.asarray(engaged, dtype=np.float64).reshape(-1, 1))
    np.savetxt(out, np.hstack(data), delimiter=",", header=",".join(cols), comments="", fmt="%.17g")
    return out


LOG_QUANTITIES = {"time": "s", "position": "m", "force": "N", "engaged": "1"}
"""The quantities a run log's columns may be named for (``--column QUANTITY=COLS:UNIT``), with
their SI units: ``position`` and ``force`` one to three columns each, in the same order of
axes (x; x, z; or x, y, z), ``engaged`` optional."""


def read_log(path, columns=None) -> RunLog:
    """Read a run log: haptex's (CSV with a header of :data:`LOG_COLUMNS`, or the ``.npz`` that
    ``haptex run --record FILE.npz`` writes), or another program's, its columns named.

    Parameters
    ----------
    path : str or os.PathLike
        CSV (a header row), NPZ, HDF5 or MATLAB .mat (:func:`haptex._columns.read_table`).
    columns : sequence of str, optional
        Column specs ``QUANTITY=COL[,COL...][:UNIT]`` (:data:`LOG_QUANTITIES`), e.g.
        ``["position=px,py,pz:mm", "force=fx,fy,fz:N", "time=t:ms"]`` for a CHAI3D or
        vendor-SDK loop's log. A quantity not given is taken from haptex's own names when the
        file has them; the file's other columns are ignored and listed in ``RunLog.ignored``.

    Returns
    -------
    RunLog

    Raises
    ------
    ParameterError
        If ``path`` is not a path (a str or os.PathLike, PEP 519), the file is missing or too
        large for the memory budget, a named column is missing
        (the file's columns are listed), time, position or force is missing, position and
        force have different numbers of axes, or a value is not a finite number.
    """
    from ._columns import read_table, take

    table = read_table(path, "run log")
    axes = next((AXES[d] for d in (3, 2, 1) if all(f"{a}_m" in table for a in AXES[d])), None)
    own = {"time": ("time_s",) if "time_s" in table else ("time",),
           "position": tuple(f"{a}_m" for a in axes) if axes else ("position",),
           "force": tuple(f"f{a}_n" for a in axes) if axes else ("force",), "engaged": ("engaged",)}
    got, ignored = take(table, columns, LOG_QUANTITIES, own, "run log")
    for q in ("time", "position", "force"):
        if q not in got:
            raise fail("log", str(path), f"a {q} column: haptex's (time_s; x_m ... with fx_n ...) or named with "
                       f"--column {q}=COLUMN[:UNIT]")
    if got["position"].shape[1] not in (1, 2, 3) or got["force"].shape[1] != got["position"].shape[1]:
        raise fail("--column", f"{got['position'].shape[1]} position and {got['force'].shape[1]} force columns",
                   "one to three positions and as many forces, in the same order of axes")
    eng = got["engaged"][:, 0].astype(bool) if "engaged" in got else None
    return RunLog(got["time"][:, 0], got["position"], got["force"], eng, str(path), tuple(ignored))


@dataclass(frozen=True)
class Identification:
    """A device model fitted to a run log (:func:`identify`).

    Parameters
    ----------
    device : haptex.Device
        The identified device: ``mass`` and ``damping`` (diagonal, one figure an axis),
        ``coulomb_friction``, ``position_resolution``, ``delay`` (periods) and ``period``.
    uncertainty : dict
        One standard deviation of each of ``mass``, ``damping`` (kg and N s/m: the axes'
        largest), ``coulomb_friction`` (N), ``position_resolution`` (m), ``delay`` (0: a
        whole number, chosen by the residual; see ``delay_residuals``) and ``period`` (s,
        the ticks' jitter).
    axes : dict
        ``mass`` and ``damping`` an axis (kg, N s/m), with their standard deviations
        (``mass_sd``, ``damping_sd``); ``delay_ties``, the delays the log cannot tell from the
        chosen one (the chosen first), and ``delay_spread``, the largest difference of their
        fits' figures from the chosen one's (masses, dampings, friction; 0 without ties).
    residual_rms : float
        RMS difference of the model's positions from the logged ones (m).
    delay_residuals : dict
        Residual RMS (m) of the fit at each delay of the range, each at its own optimum on the
        same :data:`SCREEN_WINDOWS` windows (the chosen delay's and the runner-up's on every
        window are in ``notes``).
    samples : int
    windows : int
    source : str
        The log's path, or ``"arrays"``.
    notes : list of str
        What the fit noticed (an axis without a lattice, least squares stopped early, the
        runner-up delay's residual).
    undetermined : dict
        The figures the log cannot tell (``mass``, ``damping``, ``coulomb_friction``,
        ``delay``), each with why: the motion spans fewer than :data:`MIN_STEPS` steps of the
        encoder, or two delays' residuals differ by less than :data:`DELAY_MARGIN` (on an
        encoder's log, or by less than :data:`DELAY_FLOOR_MARGIN` of the rounding), or a mass or
        damping lies within :data:`TOLD` of its deviations of zero, or the force does not move the
        fitted mass by the positions' resolution. Their numbers are the fit's, not to be relied
        on (the device file says so in a comment).
    sources : dict
        Where ``mass``, ``damping`` and ``coulomb_friction`` came from in the log: the windows
        (and their seconds) carrying half of each one's information (its squared Jacobian
        column, window by window) and the band holding 10-90 % of the force's power there.
    trace : dict
        The fitted windows' ``time`` (s), ``measured`` and ``model`` positions (m) of the
        first axis, shape (windows x samples,), for a plot (``haptex identify --plot``).
    """

    device: object
    uncertainty: dict
    axes: dict
    residual_rms: float
    delay_residuals: dict
    samples: int
    windows: int
    source: str = "arrays"
    notes: list = field(default_factory=list)
    undetermined: dict = field(default_factory=dict)
    sources: dict = field(default_factory=dict)
    trace: dict = field(default_factory=dict, repr=False)

    def to_dict(self) -> dict:
        """JSON-ready figures, SI units, each with its standard deviation.

        Returns
        -------
        dict
            Each figure (SI units) with its standard deviation, the figures not determined
            and why, and the notes.
        """
        dev = self.device
        return {"source": self.source, "samples": self.samples, "windows": self.windows,
                "period_s": dev.period, "delay_periods": dev.delay,
                "mass_kg": self.axes["mass"], "damping_n_s_m": self.axes["damping"],
                "mass_sd_kg": self.axes["mass_sd"], "damping_sd_n_s_m": self.axes["damping_sd"],
                "coulomb_friction_n": dev.coulomb_friction,
                "coulomb_friction_sd_n": self.uncertainty["coulomb_friction"],
                "position_resolution_m": dev.position_resolution,
                "position_resolution_sd_m": self.uncertainty["position_resolution"],
                "residual_rms_m": self.residual_rms,
                "delay_residuals_m": {str(k): v for k, v in self.delay_residuals.items()}, "notes": list(self.notes),
                "not_determined": dict(self.undetermined), "sources": dict(self.sources)}

    def to_toml(self, path=None) -> str:
        """The identified device as a TOML device file (:func:`haptex.catalogue.device_from_file`'s
        format, usable wherever a preset is: ``--device FILE.toml``), each figure with its
        standard deviation and the log it came from in a comment; written to ``path`` when given.

        Parameters
        ----------
        path : str or os.PathLike, optional
            The file to write.

        Returns
        -------
        str
            The file's text.
        """
        dev = self.device
        d = dev.dimension

        def q(v, unit):
            return f'"{v:.6g} {unit}"'

        def matrix(vals, unit):
            if d == 1 or len(set(np.round(vals, 12))) == 1:
                return q(vals[0], unit)
            rows = [[q(vals[i], unit) if i == j else f'"0 {unit}"' for j in range(d)] for i in range(d)]
            return "[" + ", ".join("[" + ", ".join(r) + "]" for r in rows) + "]"

        ax = self.axes
        sd = ", ".join(f"{a} {s:.2g}" for a, s in zip(AXES[len(ax['mass'])], ax["mass_sd"]))
        sdb = ", ".join(f"{a} {s:.2g}" for a, s in zip(AXES[len(ax['damping'])], ax["damping_sd"]))
        u = self.uncertainty
        lines = [
            f"# status = identified, from the run log {self.source} ({self.samples} samples, {self.windows} windows)",
            "# by haptex.identify (output-error identification); one standard deviation after each figure",
            'preset = "custom"',
            f'name = "identified from {Path(self.source).name}"',
            f"dimension = {max(d, 2)}",
            f"mass = {matrix(ax['mass'], 'kg')}  # identified; sd (kg): {sd}",
            f"damping = {matrix(ax['damping'], 'N*s/m')}  # identified; sd (N*s/m): {sdb}",
            f"period = {q(dev.period, 's')}  # identified: the ticks' median interval; jitter sd {u['period']:.2g} s",
            f"delay = {dev.delay}  # identified: whole periods, the smallest residual of those tried",
            f"coulomb_friction = {q(dev.coulomb_friction, 'N')}  # identified; sd {u['coulomb_friction']:.2g} N",
            f"position_resolution = {q(dev.position_resolution, 'm')}  # identified: the positions' lattice; "
            f"sd {u['position_resolution']:.2g} m",
        ]
        lines.extend(f"# {name.replace('_', ' ')}: not determined, not to be relied on: {why}"
                     for name, why in self.undetermined.items())
        text = "\n".join(lines) + "\n"
        if path is not None:
            a_path("path", path, "a TOML device file's path").write_text(text, encoding="utf-8")
        return text

    def report(self) -> str:
        """A plain-text summary, one figure a line with its standard deviation.

        Returns
        -------
        str
            The summary, lines separated by newlines.
        """
        dev, ax, u = self.device, self.axes, self.uncertainty
        out = [f"identified from {self.source}: {self.samples} samples at {1 / dev.period:g} Hz, "
               f"{self.windows} windows of output error"]
        for a, m, sm, b, sb in zip(AXES[len(ax["mass"])], ax["mass"], ax["mass_sd"], ax["damping"], ax["damping_sd"]):
            out.append(f"  {a}: mass {m * 1e3:.4g} ± {sm * 1e3:.2g} g, damping {b:.4g} ± {sb:.2g} N*s/m")
        out.append(f"  Coulomb friction {dev.coulomb_friction * 1e3:.4g} ± {u['coulomb_friction'] * 1e3:.2g} mN")
        out.extend(f"    {name.replace('_', ' ')}: {src}" for name, src in self.sources.items())
        res = dev.position_resolution
        out.append(f"  encoder step {res * 1e6:.4g} ± {u['position_resolution'] * 1e6:.2g} µm" if res > 0 else
                   "  encoder step: none found (the positions lie on no lattice)")
        tried = ", ".join(f"{k}: {v * 1e6:.3g} µm" for k, v in sorted(self.delay_residuals.items()))
        out.append(f"  delay {dev.delay} periods (residual RMS by delay: {tried})")
        out.append(f"  residual RMS {self.residual_rms * 1e6:.3g} µm")
        out.extend(f"  {name.replace('_', ' ')}: not determined ({why})" for name, why in self.undetermined.items())
        out.extend(f"  note: {n}" for n in self.notes)
        return "\n".join(out)


def _shaped(time, position, force):
    """(time (n,), position (n, d), force (n, d)) as float64, one axis made a column; refused
    unless the shapes agree and d is 1-3, or an entry is not a real number (a bool, text or a
    complex number: :func:`~haptex._validation.numbers`)."""
    t, p, f = (numbers(name, v, f"an array of numbers ({unit})", copy=False)
               for name, v, unit in (("time", time, "s"), ("position", position, "m"), ("force", force, "N")))
    p = p[:, None] if p.ndim == 1 else p
    f = f[:, None] if f.ndim == 1 else f
    if t.ndim != 1 or p.ndim != 2 or p.shape[1] not in AXES or f.shape != p.shape or len(t) != len(p):
        raise fail("position", f"shape {p.shape} with force {f.shape} and time {t.shape}",
                   "(n,) or (n, d) positions (m) and forces (N) of one shape, d in 1..3, with n times (s)")
    return t, p, f


def _checked(time, position, force):
    t, p, f = _shaped(time, position, force)
    if len(t) > MAX_SAMPLES:
        raise fail("time", f"{len(t)} samples", f"at most {MAX_SAMPLES} (identify a part of the log)")
    for name, a in (("time", t), ("position", p), ("force", f)):
        bad = np.flatnonzero(~np.isfinite(a.reshape(len(a), -1)).all(axis=1))
        if bad.size:
            raise fail(name, f"{a.reshape(len(a), -1)[bad[0]].tolist()} at sample {bad[0]}",
                       "finite numbers in every sample (cut the log before it)")
    dt = np.diff(t)
    if dt.size and dt.min() <= 0:
        k = int(np.argmin(dt))
        raise fail("time", f"{t[k + 1]:g} s after {t[k]:g} s at sample {k + 1}", "increasing")
    return t, p, f


def _lattice(p: np.ndarray) -> tuple[float, float]:
    """(step, its standard deviation) of the lattice the positions of one axis lie on, or
    (0, 0) when they lie on none (a continuous or noisy sensor)."""
    inc = np.abs(np.diff(p))
    scale = max(float(np.max(np.abs(p))), 1e-300)
    nz = inc[inc > 1e-9 * scale]
    if nz.size < 10:
        return 0.0, 0.0
    d0 = float(np.min(nz))
    k = np.round(nz / d0)
    if np.max(np.abs(nz / d0 - k)) > 0.01:
        return 0.0, 0.0
    step = float(np.sum(nz * k) / np.sum(k * k))
    # the residual is rounding in the log (17 digits: none), so the spread is from the positions' magnitude
    sd = float(np.std(nz - k * step) / math.sqrt(np.sum(k * k) / nz.size) / math.sqrt(nz.size))
    return step, sd


def _derivatives(p: np.ndarray, T: float) -> tuple[np.ndarray, np.ndarray]:
    """Velocity and acceleration of each axis by a Savitzky-Golay filter (cubic, 21 ms)."""
    from scipy.signal import savgol_filter

    w = max(7, 2 * round(0.0105 / T) + 1)
    w = min(w, (len(p) // 2) * 2 - 1)
    v = savgol_filter(p, w, 3, deriv=1, delta=T, axis=0)
    a = savgol_filter(p, w, 3, deriv=2, delta=T, axis=0)
    return v, a


def _equation_error(p, f, T, max_delay):
    """For each delay: least-squares m, b, f_c an axis from u(k - D) = m a + b v + f_c sign(v),
    and the residual; the delay with the smallest residual first."""
    v, a = _derivatives(p, T)
    n, d = p.shape
    out = {}
    for D in range(max_delay + 1):
        rows = slice(D + 20, n - 20)
        res, est = 0.0, []
        for j in range(d):
            u = f[rows.start - D:rows.stop - D, j]
            vj, aj = v[rows, j], a[rows, j]
            X = np.column_stack([aj, vj, np.sign(vj)])
            coef, *_ = np.linalg.lstsq(X, u, rcond=None)
            res += float(np.sum((X @ coef - u) ** 2))
            est.append(coef)
        out[D] = (res, np.array(est))
    return out, v


def _period(t: np.ndarray) -> tuple[float, np.ndarray]:
    """A log's period (s), the median of its intervals, and which intervals stray from it by
    more than :data:`TICK_TOLERANCE` of it: (T, stray (n - 1,) bool)."""
    dt = np.diff(t)
    T = float(np.median(dt))
    return T, np.abs(dt - T) > TICK_TOLERANCE * T


class _Ticks(NamedTuple):
    """A log's ticks where they are not one period each (:func:`_ticks`)."""

    intervals: np.ndarray | None  # (n - 1,) s, each tick's own; None: every one the period
    stray: np.ndarray | None  # (n - 1,) bool, the intervals no window spans; None: none
    reach: int  # the largest delay searched (the windows every delay holds alike)


def _ticks(dt: np.ndarray, T: float, stray: np.ndarray, max_delay: int) -> _Ticks | None:
    """A log's intervals ``dt`` (n - 1,) as :func:`_fit` takes them, with the period ``T`` and
    the strays :func:`_period` found: each interval its own where they differ from the period by
    more than rounding (1e-9 of it), the strays marked; None where every interval is the period."""
    uneven = bool(np.any(np.abs(dt[~stray] - T) > 1e-9 * T))
    if not uneven and not stray.any():
        return None
    return _Ticks(dt if uneven else None, stray if stray.any() else None, max_delay)


def _clear(stray: np.ndarray | None, n: int, H: int, reach: int) -> np.ndarray:
    """Which windows j of the regular grid (samples D + H j onwards, D <= ``reach``) span no
    stray interval, for every delay up to ``reach`` alike (so that their fits compare): window j
    is kept when the intervals H j .. H j + H + reach - 1 (its forces, commanded up to ``reach``
    ticks before, its H steps and the one to the next window's start) hold none. (n // H,) bool."""
    W = max(n // H, 0)
    if stray is None or not stray.any():
        return np.ones(W, dtype=bool)
    cum = np.concatenate([[0], np.cumsum(stray, dtype=np.int64)])
    lo = H * np.arange(W)
    hi = np.minimum(lo + H + reach, stray.size)
    return cum[hi] - cum[np.minimum(lo, stray.size)] == 0


def _starts(n: int, D: int, H: int, every: int = 1, ticks: _Ticks | None = None) -> np.ndarray:
    """The first samples of a fit's windows of H samples at delay D: every ``every``-th of the
    regular grid D + H j, those spanning a stray interval of ``ticks`` (:class:`_Ticks`) left
    out (:func:`_clear`)."""
    j = np.arange((n - D) // H)[::every]
    if ticks is not None and ticks.stray is not None:
        j = j[_clear(ticks.stray, n, H, ticks.reach)[j]]
    return D + H * j


def _fit(p, f, T, D, H, init, res_sd, every: int = 1, max_nfev: int = 100, lsmr_tol: float = 1e-8,
         continuity: float | None = None, band: float | None = None, dense_limit: int = MAX_DENSE_FIT,
         hold: tuple[int, float] | None = None, ticks: _Ticks | None = None):
    """Output-error fit at delay D over every ``every``-th window: (least-squares result, windows);
    contiguous windows matched by ``continuity`` (default :data:`CONTINUITY`), the matching rows
    left out of the result's residuals and Jacobian (the deviations are the windows' own). With
    ``band`` (in the residuals' units) each position's residual is its distance outside
    [measured - band, measured + band], an encoder's cell (:func:`_cells_fit`), and the result
    carries ``errors``, the positions' own residuals at its optimum. Steps are solved densely up
    to ``dense_limit`` Jacobian entries. ``hold`` (index, value) holds one figure at a nonzero value.
    ``ticks`` (:class:`_Ticks`): each step held over its own interval, and windows spanning a
    stray interval left out (:func:`_starts`); the result's ``starts`` are the windows' first
    samples."""
    from scipy.optimize import least_squares
    from scipy.sparse import diags

    residual, jac, x0, (lo, hi), scale, W, nl = _problem(p, f, T, D, H, init, res_sd, every, continuity, ticks)
    if hold is not None:  # (a band of 1e-9 of it: least squares needs lo < hi)
        k, value = hold
        x0[k], lo[k], hi[k] = value, value * (1.0 - 1e-9), value * (1.0 + 1e-9)
    d = p.shape[1]
    rows = W * H * d
    fun, fun_jac = residual, jac
    if band is not None:
        def fun(x):
            e = residual(x)
            return np.concatenate([np.sign(e[:rows]) * np.maximum(np.abs(e[:rows]) - band, 0.0), e[rows:]])

        def fun_jac(x):
            e = residual(x)  # (then jac reuses this evaluation)
            return diags(np.concatenate([(np.abs(e[:rows]) > band).astype(float), np.ones(e.size - rows)])) @ jac(x)
    # lsmr's tolerances tightened from scipy's 1e-6: with its default the steps were short of
    # Gauss-Newton's and the fit stopped early (the independent simulator's 7.5 µm encoder log:
    # damping +0.73 %, at 1e-8 +0.09 %; a 4 kHz log: 8.4 s, at 1e-8 2.8 s and exact)
    # a small problem's steps solved exactly, by scipy's SVD of the dense Jacobian (the screening's
    # 8 windows: 6,400 x 19 at 4 kHz, its 22 fits 7.0 s by lsmr, 3.8 s so; the refits from the
    # best converge in 20 evaluations where lsmr's stopped at 40); a large one's by lsmr
    dense = (W * H + 2 * nl) * d * x0.size <= dense_limit
    opts = {"tr_solver": "exact", "jac": lambda x: fun_jac(x).toarray()} if dense else {
        "tr_solver": "lsmr", "jac": fun_jac, "tr_options": {"atol": lsmr_tol, "btol": lsmr_tol}}
    try:
        sol = least_squares(fun, x0, bounds=(lo, hi), x_scale=scale, method="trf",
                            xtol=1e-8, ftol=1e-8, max_nfev=max_nfev, **opts)
    except ValueError:  # (a step the matching made non-finite: a handle barely moving, stuck by its
        if not nl:      # friction over 2 encoder steps; the windows alone, as before them)
            raise
        return _fit(p, f, T, D, H, init, res_sd, every, max_nfev, lsmr_tol, 0.0, band, dense_limit, hold, ticks)
    sol.starts = _starts(p.shape[0], D, H, every, ticks)
    if band is not None:
        sol.errors = residual(sol.x)[:rows]
    if nl:
        sol.fun = sol.fun[:rows]
        sol.jac = sol.jac[:rows]
    return sol, W


def _problem(p, f, T, D, H, init, res_sd, every: int = 1, continuity: float | None = None,
             ticks: _Ticks | None = None):
    """:func:`_fit`'s least-squares problem: (residual, jac, x0, (lo, hi), x_scale, windows,
    matched pairs); x is the figures (masses, dampings, friction), then every window's start
    position and velocity; the windows :func:`_starts`', each step held over its own interval
    where ``ticks`` has them (the last sample's, past the log, the period)."""
    from scipy.sparse import csc_matrix

    from .core import _ext
    from .simulate import _axis_coefficients

    n, d = p.shape
    starts = _starts(n, D, H, every, ticks)
    W = starts.size
    idx = starts[:, None] + np.arange(H)[None, :]
    meas = p[idx]  # (W, H, d)
    force = np.ascontiguousarray(f[idx - D])  # u(k) = f(k - D)
    v_est = init["v"]
    m0, b0, fc0 = init["m"], init["b"], init["fc"]
    x0 = np.concatenate([m0, b0, [fc0], p[starts].ravel(), v_est[starts].ravel()])
    ng = 2 * d + 1
    lo = np.concatenate([np.full(d, 1e-6), np.zeros(d), [0.0], np.full(2 * W * d, -np.inf)])
    hi = np.full(x0.size, np.inf)
    x0 = np.clip(x0, lo, hi)
    x0[:d] = np.maximum(x0[:d], 1e-3)
    pos = np.empty((W, H, d))
    # (each step's own period, where the ticks have them: the interval after its sample; the
    # coefficients computed once a distinct interval, a logger's clock rounding them to a few)
    step_T = step_of = None
    if ticks is not None and ticks.intervals is not None:
        step_T, step_of = np.unique(np.append(ticks.intervals, T)[idx], return_inverse=True)
        step_T, step_of = step_T[:, None], step_of.reshape(W, H)

    ends = {}
    lam_c = CONTINUITY if continuity is None else continuity
    link = np.flatnonzero(np.diff(starts) == H) if lam_c > 0 else np.zeros(0, dtype=int)  # (contiguous pairs)

    coef = {}  # (the last masses and dampings' step coefficients: a Jacobian's start columns reuse them)

    def model(x):
        key = x[:2 * d].tobytes()
        if coef.get("key") != key:
            c = _axis_coefficients(x[:d], x[d:2 * d], T if step_T is None else step_T)
            coef["key"], coef["c"] = key, np.ascontiguousarray(c if step_of is None else c[step_of])
        c = coef["c"]
        p0 = x[ng:ng + W * d].reshape(W, d).copy()  # (free_run ends them at the windows' end states)
        v0 = x[ng + W * d:].reshape(W, d).copy()
        _ext.free_run(c, float(x[2 * d]), force, p0, v0, pos)
        ends["p"], ends["v"] = p0, v0
        return pos

    last = {}

    def residual(x):
        r = ((model(x) - meas) / res_sd).ravel()
        if link.size:
            ps = x[ng:ng + W * d].reshape(W, d)
            vs = x[ng + W * d:].reshape(W, d)
            dp = (ends["p"][link] - ps[link + 1]) / res_sd
            dv = (ends["v"][link] - vs[link + 1]) * (H * T) / res_sd
            r = np.concatenate([r, lam_c * dp.ravel(), lam_c * dv.ravel()])
        last["x"], last["r"] = x.copy(), r
        return r

    nl = link.size
    R = W * H * d + 2 * nl * d
    # the Jacobian by forward differences, as scipy's (steps sqrt(eps) max(1, |x|), signed), in
    # 2 d + 1 + 2 d simulations: each global figure alone, then one axis of every window's start
    # position (or velocity) at once (a window's rows and end depend on its own start only); the
    # matching rows from the windows' simulated ends, and their -1 on the next window's start
    # exactly. Its pattern is fixed, so the sparse matrix is laid out once (scipy's sparse
    # differences re-derived it at every Jacobian: at 4 kHz, two thirds of the fit's time)
    rw = np.arange(W * H * d).reshape(W, H * d)  # (each window's rows)
    glob_rows = np.tile(np.arange(R), ng)
    glob_cols = np.repeat(np.arange(ng), R)
    blk_rows, blk_cols = [], []  # (the start columns' entries, in the order jac() fills them)
    lk_w = {int(w): k for k, w in enumerate(link)}  # (window -> its link to the next)
    lk_next = {int(w) + 1: k for k, w in enumerate(link)}
    for kind in range(2):  # 0: start positions, 1: start velocities
        for a in range(d):
            for w in range(W):
                col = ng + kind * W * d + w * d + a
                blk_rows.append(rw[w])
                blk_cols.append(np.full(H * d, col))
                if w in lk_w:  # (this window's end against the next one's start: dp then dv rows)
                    k = lk_w[w]
                    blk_rows.append(W * H * d + k * d + np.arange(d))
                    blk_rows.append(W * H * d + nl * d + k * d + np.arange(d))
                    blk_cols.append(np.full(2 * d, col))
                if w in lk_next:  # (the previous window's end against this start: exactly -1)
                    k = lk_next[w]
                    blk_rows.append(np.array([W * H * d + kind * nl * d + k * d + a]))
                    blk_cols.append(np.array([col]))
    rows = np.concatenate([glob_rows, *blk_rows])
    cols = np.concatenate([glob_cols, *blk_cols])
    order = np.lexsort((rows, cols))  # (CSC: column-major, rows sorted within)
    indptr = np.searchsorted(cols[order], np.arange(x0.size + 1))
    eps = np.finfo(float).eps ** 0.5

    def jac(x):
        if "x" in last and np.array_equal(last["x"], x):  # (least squares evaluated x just before)
            r0 = last["r"]
            model(x)
        else:
            r0 = residual(x)
        pos0, pe0, ve0 = pos.copy(), ends["p"].copy(), ends["v"].copy()
        h_all = eps * np.where(x >= 0, 1.0, -1.0) * np.maximum(1.0, np.abs(x))
        h_all = (x + h_all) - x
        gcols = []
        for j in range(ng):
            xj = x.copy()
            xj[j] += h_all[j]
            gcols.append((residual(xj) - r0) / h_all[j])
        vals = [np.concatenate(gcols)]
        for kind in range(2):
            for a in range(d):
                sel = ng + kind * W * d + np.arange(W) * d + a
                xj = x.copy()
                xj[sel] += h_all[sel]
                model(xj)
                hw = h_all[sel]
                dpos = ((pos - pos0) / res_sd).reshape(W, H * d) / hw[:, None]
                dpe = (ends["p"] - pe0) / hw[:, None]
                dve = (ends["v"] - ve0) / hw[:, None]
                for w in range(W):
                    vals.append(dpos[w])
                    if w in lk_w:
                        vals.append(lam_c * dpe[w] / res_sd)
                        vals.append(lam_c * dve[w] * (H * T) / res_sd)
                    if w in lk_next:
                        vals.append(np.array([-lam_c * (1.0 if kind == 0 else H * T) / res_sd]))
        last.clear()  # (the model's buffers now hold a perturbed run)
        data = np.concatenate(vals)[order]
        return csc_matrix((data, rows[order], indptr), shape=(R, x0.size))

    scale = np.concatenate([np.maximum(np.abs(x0[:ng]), 1e-3), np.full(W * d, res_sd),
                            np.full(W * d, max(res_sd / T / H, 1e-6))])
    return residual, jac, x0, (lo, hi), scale, W, nl


def identify(*, time, position, force, max_delay: int = MAX_DELAY, window: float | None = None,
             position_resolution: float | None = None, source: str = "arrays") -> Identification:
    """Fit the device model haptex simulates to a run log (see the module docstring).

    Parameters
    ----------
    time : array_like, shape (n,)
        The ticks' times (s), increasing; the period is their median interval, and each
        tick's force is held over its own interval. An interval more than
        :data:`TICK_TOLERANCE` off the period (a missed tick, or samples not logged) is spanned
        by no window: the windows between such intervals are fitted, and a note says how many
        there were.
    position : array_like, shape (n,) or (n, d), d in 1..3
        Sensed positions (m), axes :data:`AXES` [d].
    force : array_like, shape of ``position``
        Forces commanded at each tick (N), as sent: the excitation must move the handle on
        every axis, through zero velocity (the friction) and over the band the mass and
        damping shape (``haptex run --identify``'s program, or :func:`excitation`).
    max_delay : int, optional
        Largest delay searched (periods), default :data:`MAX_DELAY`.
    window : float, optional
        Output-error window (s). Default None: :data:`WINDOW`, and also :data:`LONG_WINDOW`
        (where the log holds :data:`MIN_WINDOWS` of them) on an encoder's log, or when the
        damping's relative deviation passes :data:`LONG_WINDOW_TRIGGER`. On an encoder's log the
        long windows are kept where their residual is within :data:`LONG_WINDOW_RMS` of the
        rounding's (and the delay compared again on them, see :data:`DELAY_RECHECK`); otherwise
        the fit whose damping is the better determined. A note says which.
    position_resolution : float, optional
        The encoder's step (m) when known; default None: found from the positions' lattice
        (0 when they lie on none).
    source : str, optional
        Where the log came from (the identification says so).

    Returns
    -------
    Identification

    Raises
    ------
    ParameterError
        For arrays of different shapes, an entry that is not a real number (a bool, text or a
        complex number), a non-finite value (naming the column and sample),
        times that do not increase (equal times are read as a clock coarser than the period's
        where they are one, :func:`_coarse_clock`, and refused where it moves by more than two
        of its steps between two samples or a stamp strays from the line), intervals off the
        period (:data:`TICK_TOLERANCE`) so many
        that fewer than :data:`MIN_WINDOWS` windows lie between them, a log shorter than
        :data:`MIN_WINDOWS` windows,
        a constant force or position on an axis (nothing to identify), or settings out of
        range.

    Notes
    -----
    Verified on logs of an independent simulator (the motion in closed form over each held
    period in plain Python, continuous-time Coulomb friction, closed-loop centering, steps and a
    chirp to 0.2 f_s or band-limited random forces, 1 and 4 kHz, delays 0-4: mass and friction
    within 0.1 %, damping within 4.4 %, the delay and encoder step exact; noise-free continuous
    logs to 1e-8), on logs simulated by
    haptex's own sampled-data model (within 0.2 %), and on logs of ``haptex run --identify``
    on the simulated backend, whose exact transition is computed independently (scipy's expm):
    ``tests/test_identify.py``.
    """
    if not isinstance(source, str):
        raise fail("source", source, "a str (where the log came from, as the device file names it)")
    _encoder_step(position_resolution)  # (checked before the log is)
    time, clock = _coarse_clock(time)
    r = _identify(time=time, position=position, force=force, max_delay=max_delay, window=window,
                  position_resolution=position_resolution, source=source, delay=None)
    r = _told(r)
    return r if clock is None else dataclasses.replace(r, notes=[clock, *r.notes])


COARSE_CLOCK_RATIO = 0.9
"""How much shorter than the least step of a log's clock its period (the least-squares line's slope
through its times) must be for its equal times to be read as a clock coarser than the loop
(:func:`_coarse_clock`; chosen: a log of one period whose row is repeated once in n samples has a
line's period (1 - 1/n) steps, and is refused as times that do not increase)."""

COARSE_CLOCK_SLACK = 1.5
"""How far (in the clock's steps) a stamp of a clock coarser than its loop's period may lie from
the least-squares line through the stamps over the sample index before the log is refused
(:func:`_coarse_clock`; chosen: a clock that reads its last whole tick puts each stamp within
one step below the loop's own time, within half a step either side of the line)."""


def _coarse_clock(time):
    """A log's times where the clock that stamped them is coarser than the loop's period (runs of
    equal times, then a step of the clock's resolution: a 4 kHz loop in whole milliseconds, a
    1 kHz loop by Windows' 64 Hz system tick): each tick one period, the least-squares line
    through the stamps over the sample index, and a note that says so; (times, None) where the
    times hold no equal neighbours (or are not a log's: :func:`_checked` refuses them).

    Raises
    ------
    ParameterError
        Where the clock moves by more than two of its steps between two samples, or a stamp lies
        more than :data:`COARSE_CLOCK_SLACK` steps off the line (the loop stalled or samples went
        unlogged: a clock that cannot tell the ticks apart cannot tell which ticks a gap held).
    """
    try:
        t = np.asarray(time, dtype=float)
    except (TypeError, ValueError):
        return time, None
    if t.ndim != 1 or t.size < 3 or not np.all(np.isfinite(t)):
        return time, None
    dt = np.diff(t)
    if dt.min() < 0 or not np.any(dt == 0) or not np.any(dt > 0):
        return time, None
    step = float(np.min(dt[dt > 0]))  # (the clock's resolution: its least step)
    k = np.arange(t.size, dtype=float)
    T, t0 = np.polyfit(k, t, 1)
    if not 0 < T < COARSE_CLOCK_RATIO * step:  # (equal times from something else: a repeated row, refused
        return time, None  # as not increasing; with one in n samples the line's period is (1 - 1/n) steps)
    clock = f"a clock that steps by {step:.3g} s, coarser than its period ({T:.3g} s)"
    gaps = np.flatnonzero(dt > 2.5 * step)
    off = np.abs(t - (t0 + T * k))
    if gaps.size or off.max() > COARSE_CLOCK_SLACK * step:
        j = int(gaps[0]) + 1 if gaps.size else int(np.argmax(off > COARSE_CLOCK_SLACK * step))
        raise fail("time", f"{t[j] - t[j - 1]:.3g} s after {t[j - 1]:.6g} s at sample {j}",
                   f"times from a clock finer than the loop's period (a microsecond clock): these are from {clock}, "
                   "which cannot tell which ticks a gap held")
    note = (f"the log's times are from {clock}: each tick is taken as one period, the least-squares line's "
            "slope through the times over the sample index (the loop's jitter cannot be seen)")
    return t0 + T * k, note


def _told(r: Identification) -> Identification:
    """``r`` with each mass or damping closer to zero than :data:`TOLD` of its deviations said
    not determined (on the axes where it is; the others' figures stand), with its bound and
    what would tell it."""
    ax, T = r.axes, r.device.period
    names = AXES[len(ax["mass"])]
    tau = _time_constant(r)
    remedy = {"mass": "faster force changes (the mass shows above the corner frequency b/(2 pi m), "
                      f"{1 / (2 * math.pi * tau):.3g} Hz here)",
              "damping": f"a longer log with slow force changes (the damping shows below b/(2 pi m), "
                         f"{1 / (2 * math.pi * tau):.3g} Hz here; {r.samples * T:.3g} s logged)"}
    unit = {"mass": "kg", "damping": "N*s/m"}
    out = dict(r.undetermined)
    for name in ("mass", "damping"):
        if name in out:
            continue
        loose = [(a, v, s) for a, v, s in zip(names, ax[name], ax[name + "_sd"]) if not abs(v) > TOLD * s]
        if not loose:
            continue
        told = ", ".join(f"{a} {v:.3g} ± {s:.2g} {unit[name]} ({100 * s / max(abs(v), 1e-300):.0f} %)"
                         for a, v, s in loose)
        why = f"{told}: within {TOLD:g} deviations of zero, the log does not tell it from none"
        if "delay" in out:
            why += " (its fit moves with the delay the log cannot tell)"
        out[name] = f"{why}; {remedy[name]} would tell it"
    return r if out == r.undetermined else dataclasses.replace(r, undetermined=out)


def _encoder_step(position_resolution) -> float | None:
    """``identify``'s ``position_resolution`` checked: None, or a finite number >= 0 (m)."""
    if position_resolution is None:
        return None
    try:
        delta = float(position_resolution) if not isinstance(position_resolution, bool) else math.nan
    except (TypeError, ValueError):
        delta = math.nan
    if not (math.isfinite(delta) and delta >= 0):
        raise fail("position_resolution", position_resolution, "None or a finite number >= 0 (m)")
    return delta


def _identify(*, time, position, force, max_delay, window, position_resolution, source, delay, start=None):
    """:func:`identify`, with ``delay`` (an int, or a tuple of them) fitted instead of the
    screened range, and ``start`` (an :class:`Identification`) the screening's start instead of
    the equation error's."""
    if window is None:
        kw = dict(time=time, position=position, force=force, max_delay=max_delay,
                  position_resolution=position_resolution, source=source)
        first = _identify(window=WINDOW, delay=None, **kw)
        rel = _damping_spread(first)
        T = first.device.period
        quantized = first.device.position_resolution > 0
        if not (quantized or rel > LONG_WINDOW_TRIGGER) or "damping" in first.undetermined:
            return first  # (a motion over too few encoder steps is not helped by longer windows)
        tc, pc, fc_ = _checked(time, position, force)
        stray = _period(tc)[1]  # (the period: the first fit's, the same median)
        ticks = _ticks(np.diff(tc), T, stray, max_delay)
        if _clear(stray, first.samples - max_delay, round(LONG_WINDOW / T), max_delay).sum() < MIN_WINDOWS:
            return first  # (fewer long windows than a fit needs, between the strays or in all)
        # the first fit's figures are the start (from the equation error's, a light handle's long
        # windows under random forces stopped at 3 mm of residual, the damping at its bound 0;
        # a long fit that does not follow the positions is not kept, below). The delay is the
        # first fit's (searched on the short windows, where it shows best); on an encoder's log
        # whose runner-up delay screened within DELAY_RECHECK, it and its neighbours are
        # compared again on the long windows, where the short windows' free starts fit the
        # rounding instead (a 500 g, 3 N·s/m, 0.2 N handle on 60 µm: delays 0 and 1 at 15.6 and
        # 15.2 µm on 0.2 s windows, 15.2 and 16.5 µm on 1 s windows; the truth 0)
        D1 = first.device.delay
        screen = sorted(first.delay_residuals.values())
        near = len(screen) > 1 and screen[1] < (1.0 + DELAY_RECHECK) * screen[0]
        delays = tuple(range(max(D1 - 1, 0), min(D1 + 1, max_delay) + 1)) if quantized and near else D1
        told, cells_note = None, None
        delay_notes = [n for n in first.notes if n.startswith("delay ")]
        if quantized:
            # an encoder's log: the delay is the one whose fit keeps the motion in the cells the
            # positions were rounded in (at 4 kHz on a 60 µm encoder, least squares on the
            # positions fitted delays 0 to 10 alike, and preferred 0 on 1 s windows for a true 4)
            # (a delay the screening told clearly, its runner-up more than DELAY_RECHECK behind, is
            # not walked: its cells' fit gives the figures)
            walk = near or "delay" in first.undetermined
            ranked, costs, decisive, fits = _cells_delay(pc, fc_, T, first, max_delay, walk, ticks)
            how = (f"{LONG_WINDOW:g} s windows fitted to each position's distance from its "
                   f"{first.device.position_resolution * 1e6:.3g} µm encoder cell: cost {costs[ranked[0]]:.3g} at "
                   f"delay {ranked[0]}")
            if len(ranked) > 1:
                how += f", the runner-up, delay {ranked[1]}, {costs[ranked[1]]:.3g}"
            if not walk:  # (the screening's delay: no note of the cells' own)
                told = delays = D1
            elif decisive:
                told = delays = ranked[0]
                cells_note = f"delay {told} periods: told by the encoder's cells ({how})"
            else:
                cells_note = (f"the encoder's cells do not tell the delay either ({how}, less than {CELL_MARGIN:g} "
                              "times apart)")
        second = _identify(window=LONG_WINDOW, delay=delays, start=first, **kw)
        if told is not None:  # (the cells' verdict on the delay, the screening's residuals kept)
            second = dataclasses.replace(second, delay_residuals=first.delay_residuals,
                                         notes=[*filter(None, [cells_note]), *delay_notes, *second.notes])
        elif isinstance(delays, tuple):  # (its own verdict on the delay, and its note)
            second = dataclasses.replace(second, delay_residuals=first.delay_residuals)
        else:
            second = dataclasses.replace(second, delay_residuals=first.delay_residuals, undetermined={
                **{k: v for k, v in first.undetermined.items() if k == "delay"}, **second.undetermined},
                notes=delay_notes + second.notes)
        if cells_note is not None and told is None:
            second.notes.append(cells_note)
        rel2 = _damping_spread(second)
        floor = max(first.residual_rms, first.device.position_resolution / math.sqrt(12.0))
        follows = second.residual_rms <= (1.0 + LONG_WINDOW_RMS) * floor
        if quantized:
            keep = second if follows else first
            if keep is first and told is not None and (first.device.delay != told or "delay" in first.undetermined):
                # (the short windows at the delay the cells told)
                keep = _identify(window=WINDOW, delay=told, start=first, **kw)
                keep = dataclasses.replace(keep, delay_residuals=first.delay_residuals,
                                           notes=[*filter(None, [cells_note]), *delay_notes, *keep.notes])
            why = (f"on an encoder's log the long windows are kept where they follow the positions to the "
                   f"rounding (residual RMS {second.residual_rms * 1e6:.3g} µm at {LONG_WINDOW:g} s, "
                   f"{first.residual_rms * 1e6:.3g} µm at {WINDOW:g} s, the rounding's "
                   f"{first.device.position_resolution / math.sqrt(12.0) * 1e6:.3g} µm): a short window's free "
                   "start absorbs the rounding into the damping")
        else:
            keep = second if rel2 < rel else first
            why = (f"the damping's relative deviation was {rel:.2g} at {WINDOW:g} s and {rel2:.2g} at "
                   f"{LONG_WINDOW:g} s (the time constant m/b, {_time_constant(keep):.3g} s, is long beside a "
                   "short window)")
        keep.notes.append(f"window {LONG_WINDOW if keep is second else WINDOW:g} s: {why}")
        if keep is second and "delay" in first.undetermined and "delay" in second.undetermined:
            # (the long windows compared the first fit's delay and its neighbours; the delays the
            # short windows could not tell apart may reach further: their fits' spread is kept)
            keep = _widened(second, first.axes["delay_spread"])
            if isinstance(delays, tuple):  # (the long windows' own verdict named only their delays)
                alike = _delay_list(sorted(set(first.axes["delay_ties"]) | {second.device.delay}))
                keep = dataclasses.replace(keep, undetermined={**keep.undetermined, "delay": (
                    f"delays {alike} fit alike on {WINDOW:g} s windows, and {second.device.delay} the best of "
                    f"{_delay_list(delays)} on {LONG_WINDOW:g} s windows by too little: the excitation has no "
                    "power where the delay shows (add faster force changes); each figure's deviation includes the "
                    "differences between their fits")})
        if told is not None:
            keep = _with_cells_figures(keep, fits[told], tc, pc, _cells_probe(pc, fc_, T, first, max_delay, told,
                                                                             fits[told].figures, ticks))
        return keep
    t, p, f = _checked(time, position, force)
    max_delay = whole("max_delay", max_delay, 0, 1000)
    window = positive("window", window, "s")
    n, d = p.shape
    if n < 3:
        raise fail("time", f"{n} samples", f"at least {MIN_WINDOWS} windows of {window:g} s")
    dt = np.diff(t)
    T, stray = _period(t)
    H = max(20, int(round(window / T)))
    if n - max_delay < MIN_WINDOWS * H:
        raise fail("time", f"{n} samples ({n * T:.3g} s)",
                   f"at least {MIN_WINDOWS} windows of {H} samples after the delay searched ({max_delay}): "
                   f"{(MIN_WINDOWS * H + max_delay) * T:.3g} s")
    ticks = _ticks(dt, T, stray, max_delay)
    clear = _clear(stray, n - max_delay, H, max_delay)  # (the windows every delay holds)
    if clear.sum() < MIN_WINDOWS:
        k = int(np.flatnonzero(stray)[0])
        count = int(stray.sum())
        raise fail("time", f"{count} interval{'s' * (count != 1)} off the period",
                   f"ticks at one period (the median, {T:.3g} s, within {100 * TICK_TOLERANCE:g} %) over at least "
                   f"{MIN_WINDOWS} windows of {H} samples between the intervals off it (the first {dt[k]:.3g} s, at "
                   f"sample {k + 1}); {int(clear.sum())} are: log a longer run, or one whose loop keeps its period")
    for name, a in (("force", f), ("position", p)):
        flat = [AXES[d][j] for j in range(d) if np.ptp(a[:, j]) == 0]
        if flat:
            raise fail(name, f"constant along {flat[0]}", "a signal that varies on every axis (nothing to identify "
                       "on a still axis: excite it, e.g. with haptex run --identify)")
    notes = []
    if ticks is not None and ticks.intervals is not None:
        jitter = float(np.max(np.abs(dt[~stray] - T)))
        notes.append(f"the ticks' intervals depart from the period by up to {jitter:.3g} s "
                     f"({100 * jitter / T:.2g} %): each force is held over its own interval")
    if ticks is not None and ticks.stray is not None:
        k, count = int(np.flatnonzero(stray)[0]), int(stray.sum())
        notes.append(f"{count} interval{'s stray' if count != 1 else ' strays'} more than {100 * TICK_TOLERANCE:g} % "
                     "from the period "
                     f"(missed ticks, or samples not logged; the first {dt[k]:.3g} s, at sample {k + 1}): the "
                     f"{window:g} s windows lie between them, {int(clear.sum())} of {clear.size}")
    if position_resolution is None:
        steps = [_lattice(p[:, j]) for j in range(d)]
        delta = max(s[0] for s in steps)
        delta_sd = max(s[1] for s in steps)
        if any(s[0] == 0 for s in steps) and delta > 0:
            notes.append("the positions of some axes lie on no lattice; the step is the others'")
        elif len({round(s[0], 15) for s in steps}) > 1:
            notes.append("the axes' steps differ: " + ", ".join(f"{a} {s[0]:.4g} m" for a, s in zip(AXES[d], steps))
                         + "; the largest is kept")
    else:
        delta = _encoder_step(position_resolution)
        delta_sd = 0.0
    ee, v = _equation_error(p, f, T, max_delay)
    res_sd = max(delta / math.sqrt(12.0), 1e-6)  # the residuals' scale (m): the rounding, or 1 µm
    # Every delay of the range is fitted to its own optimum on a subset of the windows (the same
    # for every delay, so their residuals compare), each from SCREEN_STARTS: the equation error's
    # figures with its damping scaled (closed-loop logs bias the equation error's damping several
    # times over, and from there the output error stops in a local minimum). The delay with the
    # least screened residual is then fitted on every window from its screened optimum.
    W_all = int(clear.sum())  # (the windows between stray intervals)
    every = max(1, W_all // SCREEN_WINDOWS)
    span = float(np.max(np.ptp(p, axis=0))) / delta if delta > 0 else math.inf
    if delay is None and span < MIN_STEPS:
        # a motion over too few encoder steps tells no delay (nor the rest, said below): the
        # screening's fits of every delay are skipped, the equation error's best delay is fitted
        delay = min(ee, key=lambda k: ee[k][0])
    screened = {}
    delays = range(max_delay + 1) if delay is None else (delay,) if isinstance(delay, int) else delay
    for D in (() if start is not None and len(delays) == 1 else delays):  # (one delay from a fit: no screening)
        coef = ee[D][1]
        best = None
        if start is None:
            inits = [{"m": np.maximum(coef[:, 0], 1e-3), "b": np.maximum(coef[:, 1], 0.0) * k,
                      "fc": float(max(np.mean(coef[:, 2]), 0.0)), "v": v} for k in SCREEN_STARTS]
        else:
            inits = [{"m": np.array(start.axes["mass"]), "b": np.array(start.axes["damping"]),
                      "fc": float(start.device.coulomb_friction), "v": v}]
        for init in inits:
            sol, W = _fit(p, f, T, D, H, init, res_sd, every, SCREEN_NFEV, 1e-6, ticks=ticks)  # ranking: scipy's
            if best is None or sol.cost < best.cost:
                best = sol
        screened[D] = best
    # the delays beside the best fitted again from the best one's figures: from the equation
    # error's, a delay's fit can stop far from its optimum (a 50 g handle with 0.1 N·s/m under
    # random forces: the true delay's screened residual 1.4 mm where its optimum is 1 µm, and the
    # delay one period off). Repeated from each new best (a neighbour so refitted may reach a
    # better basin and pass the best, which is then fitted again from it: at 4 kHz, a 500 g,
    # 0.1 N·s/m, 0.2 N handle's delays all stopped near 0.38 N·s/m, delay 1 refitted reached 1 µm
    # and the true delay 0, not refitted from there, was left at 3 µm; from it, 0.03 µm)
    refitted = set()
    while len(screened) > 1:
        D0 = min(screened, key=lambda k: screened[k].cost)
        if D0 in refitted:
            break
        refitted.add(D0)
        xb = screened[D0].x
        init = {"m": xb[:d], "b": xb[d:2 * d], "fc": float(xb[2 * d]), "v": v}
        for D in range(max(D0 - SCREEN_REACH, 0), min(D0 + SCREEN_REACH, max_delay) + 1):
            if D != D0 and D in screened:
                sol, W = _fit(p, f, T, D, H, init, res_sd, every, SCREEN_NFEV, ticks=ticks)
                if sol.cost < screened[D].cost:
                    screened[D] = sol
    screen_rms = {D: float(np.sqrt(np.mean(sol.fun ** 2))) * res_sd for D, sol in screened.items()}
    ranked = sorted(screen_rms, key=screen_rms.get) or list(delays)
    D = ranked[0]
    runner = ranked[1] if len(ranked) > 1 else None
    x0 = screened[D].x if screened else np.concatenate([start.axes["mass"], start.axes["damping"],
                                                         [start.device.coulomb_friction]])
    sol, W = _fit(p, f, T, D, H, {"m": x0[:d], "b": x0[d:2 * d], "fc": float(x0[2 * d]), "v": v}, res_sd,
                  ticks=ticks)
    rms = {D: float(np.sqrt(np.mean(sol.fun ** 2))) * res_sd}
    x = sol.x
    ng = 2 * d + 1
    J = sol.jac.toarray() if hasattr(sol.jac, "toarray") else np.asarray(sol.jac)
    sd = _deviations(J, sol.fun, W, ng, sol.fun.size - x.size)
    # the delays the log cannot tell from the best: within DELAY_MARGIN of its residual, or on an
    # encoder's log within DELAY_FLOOR_MARGIN of the rounding. Each figure's deviation spans every
    # one of their fits (at 4 kHz on a 60 um encoder a 500 g, 3 N·s/m handle's delays 0 to 10
    # screened within 0.25 um of each other, 15.75-15.99 um; spanning the runner-up's fit alone
    # left the truth's mass, at delay 4, 3.8 deviations off)
    def alike(k):
        return (screen_rms[k] < screen_rms[D] * (1.0 + DELAY_MARGIN)
                or (delta > 0 and screen_rms[k] - screen_rms[D] < DELAY_FLOOR_MARGIN * delta / math.sqrt(12.0)))

    ties = sorted(k for k in ranked[1:] if alike(k))
    tied = bool(ties)
    close = tied and all(screen_rms[k] < screen_rms[D] * (1.0 + DELAY_MARGIN) for k in ties)
    spread = np.zeros(ng)
    for k in ties:
        spread = np.maximum(spread, np.abs(screened[k].x[:ng] - screened[D].x[:ng]))
    if tied:  # a delay the log cannot tell: each figure's deviation spans the tied delays' fits too
        sd = np.hypot(sd, spread)
    m, b, fc = x[:d], x[d:2 * d], float(x[2 * d])
    if not sol.success:
        notes.append(f"least squares stopped: {sol.message}")
    dev = _device(m, b, fc, T, D, delta, source)
    if d == 1:
        notes.append("a one-axis log: the device's second axis copies the first")
    unc = {"mass": float(np.max(sd[:d])), "damping": float(np.max(sd[d:2 * d])), "coulomb_friction": float(sd[2 * d]),
           "position_resolution": delta_sd, "delay": 0.0, "period": float(np.std(dt[~stray]))}
    axes = {"mass": m.tolist(), "damping": b.tolist(), "mass_sd": sd[:d].tolist(), "damping_sd": sd[d:2 * d].tolist(),
            "delay_spread": spread.tolist(), "delay_ties": [D, *ties]}
    undetermined = {}
    if runner is not None:
        notes.append(f"delay {D} periods: residual RMS {screen_rms[D] * 1e6:.3g} µm on the screening windows "
                     f"({int(clear[::every].sum())} of {window:g} s); the "
                     f"runner-up, delay {runner}, {screen_rms[runner] * 1e6:.3g} µm")
        if tied:
            how = (f"within {100 * DELAY_MARGIN:g} % of each other" if close else
                   f"to the rounding ({delta / math.sqrt(12.0) * 1e6:.3g} µm), less than "
                   f"{100 * DELAY_FLOOR_MARGIN:g} % of it apart")
            undetermined["delay"] = (f"delays {D} and {_delay_list(ties)} fit {how}: the "
                                     "excitation has no power where the delay shows (add faster force changes); "
                                     "each figure's deviation includes the differences between their fits")
    # the force's own share of the motion: over a window, a force of the log's RMS moves the
    # fitted mass by about F t^2 / 2m; below the positions' resolution the motion is not the
    # force's (the mass is then only a lower bound, and the rest with it: a force column that is
    # not this axis's). A unit read wrong scales motion and figures alike: the mass's range says it
    moved = float(np.sqrt(np.mean(f ** 2))) * (H * T) ** 2 / (2.0 * float(np.max(m)))
    floor = max(float(rms[D]), delta / math.sqrt(12.0))
    if moved < floor:
        why = (f"the force moves the fitted mass ({float(np.max(m)):.3g} kg) by about {moved:.2g} m over a "
               f"{H * T:g} s window, less than the positions' resolution ({floor:.2g} m): the motion is not "
               "the force's (is the force column the one commanded to this axis?)")
        for name in ("mass", "damping", "coulomb_friction"):
            undetermined.setdefault(name, why)
    elif not PLAUSIBLE_MASS[0] <= float(np.max(m)) <= PLAUSIBLE_MASS[1]:
        notes.append(f"a mass of {float(np.max(m)):.3g} kg is far from a haptic handle's ({PLAUSIBLE_MASS[0] * 1e3:g} g "
                     f"to {PLAUSIBLE_MASS[1]:g} kg): are the position and force in the units the log was written in? "
                     "(name them with --column, e.g. position=px:mm)")
    if span < MIN_STEPS:
        why = (f"the motion spans {span:.0f} encoder steps of {delta * 1e6:.3g} µm, fewer than {MIN_STEPS}: "
               "a larger force (or a finer encoder) moves the handle over more of them")
        for name in ("mass", "damping", "coulomb_friction", "delay"):
            undetermined.setdefault(name, why)
    # where each figure came from: the windows carrying half of its information (the squared
    # Jacobian column, window by window) and the band holding 10-90 % of the force's power there
    idx = sol.starts[:, None] + np.arange(H)[None, :]  # the full fit's windows
    sources = {}
    for name, col in (("mass", 0), ("damping", d), ("coulomb_friction", 2 * d)):
        info = np.sum(J[:, col].reshape(W, H * d) ** 2, axis=1)
        if not np.any(info > 0):
            continue
        order = np.argsort(info, kind="stable")[::-1]
        top = np.sort(order[:int(np.searchsorted(np.cumsum(info[order]) / np.sum(info), 0.5)) + 1])
        u = f[idx[top] - D, 0].ravel()
        spec = np.abs(np.fft.rfft(u - u.mean())) ** 2
        freq = np.fft.rfftfreq(u.size, T)
        cum = np.cumsum(spec) / max(np.sum(spec), 1e-300)
        lo, hi = freq[int(np.searchsorted(cum, 0.1))], freq[min(int(np.searchsorted(cum, 0.9)), freq.size - 1)]
        sources[name] = (f"half its information from {len(top)} of {W} windows, {t[idx[top[0], 0]] - t[0]:.3g}-"
                         f"{t[idx[top[-1], -1]] - t[0]:.3g} s, force band {lo:.3g}-{hi:.3g} Hz")
    model = p[idx] + sol.fun.reshape(W, H, d) * res_sd
    trace = {"time": t[idx].ravel(), "measured": p[idx][..., 0].ravel(), "model": model[..., 0].ravel()}
    return Identification(dev, unc, axes, rms[D], screen_rms, n, W, source, notes, undetermined, sources, trace)


def _deviations(J, r, W: int, ng: int, dof: int) -> np.ndarray:
    """The standard deviations (ng,) of a fit's first ``ng`` parameters, from its Jacobian ``J``
    (rows, parameters) and residuals ``r`` (rows,) over ``W`` windows of equal rows, with ``dof``
    degrees of freedom (the residuals that carry information less the parameters): the larger of
    the Gauss-Newton and the window-clustered sandwich deviations. Serves least squares on the
    positions and the encoder cells' fit alike (an M-estimator's asymptotic covariance is the
    same sandwich, its residuals and Jacobian the cells' own: Huber, Proc. 5th Berkeley Symp.
    1, 1967)."""
    dof = max(dof, 1)
    # the residuals of one window are correlated (an encoder's rounding error persists while the
    # handle moves slowly): the variance is inflated by (1 + rho) / (1 - rho), rho their lag-1
    # autocorrelation along the windows (the effective sample size of an AR(1) error)
    e = r.reshape(W, -1, (ng - 1) // 2)  # (windows, samples, axes)
    rho = float(np.sum(e[:, 1:] * e[:, :-1]) / max(np.sum(e * e), 1e-300))
    rho = min(max(rho, 0.0), 0.99)
    s2 = float(np.sum(r ** 2)) / dof * (1 + rho) / (1 - rho)
    # Each standard deviation is the larger of two: the Gauss-Newton one above, and the
    # window-clustered sandwich (Huber-White; Cameron & Miller 2015, J. Human Resources 50(2)),
    # (J^T J)^-1 (sum_w J_w^T r_w r_w^T J_w) (J^T J)^-1, which holds whatever the correlation of
    # the residuals within a window (an encoder's rounding error is a function of the motion,
    # not an AR(1) noise). On the independent simulator's logs every figure's error is within
    # 2 of either (seeds 1-3); on noise-free logs the Gauss-Newton one is the larger.
    try:
        size = np.linalg.norm(J, axis=0)
        size[size == 0] = 1.0
        Jn = J / size  # columns of one scale: pinv's cut-off must not drop the figures' own directions
        bread = np.linalg.pinv(Jn.T @ Jn) / np.outer(size, size)
        scores = np.einsum("wri,wr->wi", J.reshape(W, -1, J.shape[1]), r.reshape(W, -1))
        sandwich = bread @ (scores.T @ scores * (W / max(W - 1, 1))) @ bread
        # over few windows the clustered variance is itself uncertain (10 clusters on 1 s
        # windows: by about a quarter): read with Student's t of W - 1 degrees of freedom, as
        # Cameron & Miller's few-cluster inference does, scaled so that 3 deviations keep their
        # normal coverage (t_9 at 99.87 %: 1.36 times; t_48: 1.05)
        from scipy.stats import norm, t as student

        few = float(student.ppf(norm.cdf(3.0), max(W - 1, 1)) / 3.0)
        sd = np.sqrt(np.maximum(np.maximum(np.diag(bread)[:ng] * s2, np.diag(sandwich)[:ng] * few ** 2), 0.0))
    except np.linalg.LinAlgError:  # pragma: no cover (pinv converges on any finite matrix)
        sd = np.full(ng, np.nan)
    return sd


def _device(m, b, fc: float, T: float, D: int, delta: float, source: str):
    """The :class:`~haptex.Device` of fitted figures (masses and dampings an axis, kg and N s/m;
    friction N; period s; delay periods; encoder step m); a one-axis log's second axis copies the
    first. Raises ParameterError naming the log where the figures are no device's."""
    from .devices import Device

    d = len(m)
    dim = max(d, 2)
    mass = np.diag(np.resize(m, dim)) if d > 1 else float(m[0])
    damp = np.diag(np.resize(b, dim)) if d > 1 else float(b[0])
    try:
        return Device(mass=mass, damping=damp, period=T, delay=D, position_resolution=delta, coulomb_friction=fc,
                      name=f"identified from {Path(source).name}", dimension=dim)
    except ParameterError as exc:
        raise ParameterError(f"log = {source!r} is not allowed: the fitted model is not a device ({exc})") from None


class _CellsFit(NamedTuple):
    """:func:`_cells_fit`'s result."""

    cost: float  # summed squared distances outside the cells, in the rounding's units
    figures: np.ndarray  # (2 d + 1,) masses, dampings, friction
    model: np.ndarray  # (W, H, d) the model's positions over the windows (m)
    idx: np.ndarray  # (W, H) their sample indices
    sd: np.ndarray | None  # (2 d + 1,) the figures' deviations, None where too few left their cells
    outside: int  # positions outside their cells
    beyond: float  # the largest distance of a position outside its cell (m; negative: all inside)


def _cells_fit(p, f, T, D, H, init, delta, hold=None, ticks=None) -> _CellsFit:
    """The output-error fit at delay D on windows of H samples whose residual is each simulated
    position's distance from its encoder cell, [measured - delta/2, measured + delta/2] (zero
    inside it), with the figures' deviations where at least :data:`CELL_DEVIATION_ROWS`
    positions a parameter left their cells (:class:`_CellsFit`). A rounded position says the handle was in that cell,
    which least squares on the positions reads as 17 µm of noise on a 60 µm encoder; a wrong
    delay cannot keep the motion in every cell (set-membership identification: Milanese &
    Vicino, Automatica 27(6), 1991). ``hold`` and ``ticks`` as :func:`_fit`'s."""
    res_sd = delta / math.sqrt(12.0)
    # (half a cell in the residuals' units)
    sol, W = _fit(p, f, T, D, H, init, res_sd, band=0.5 * delta / res_sd, dense_limit=MAX_CELL_DENSE, hold=hold,
                  ticks=ticks)
    e = sol.errors.reshape(W, H, p.shape[1]) * res_sd
    idx = sol.starts[:, None] + np.arange(H)[None, :]
    ng = 2 * p.shape[1] + 1
    # the figures' deviations, the M-estimator's own (:func:`_deviations` on the positions that
    # left their cells: the measurement noise's share), where enough positions left them to tell
    outside = int(np.count_nonzero(sol.fun))
    sd = None
    if outside >= CELL_DEVIATION_ROWS * sol.x.size:
        J = sol.jac.toarray() if hasattr(sol.jac, "toarray") else np.asarray(sol.jac)
        sd = _deviations(J, sol.fun, W, ng, outside - sol.x.size)
    return _CellsFit(2.0 * float(sol.cost), sol.x[:ng], p[idx] + e, idx, sd, outside,
                     float(np.max(np.abs(e))) - 0.5 * delta)


def _with_cells_figures(r: "Identification", fit, t, p, probe=None) -> "Identification":
    """``r`` with its mass, damping and friction those of the cells' fit ``fit`` (as
    :class:`_CellsFit`, at ``r``'s delay) and its trace and residual that fit's over
    times ``t`` and positions ``p``; the deviations the cells' fit's own where it has them (else
    least squares': inside the cells the cost is flat and gives none, or, for a mass or damping
    least squares' would leave not determined, :data:`CELL_PROBE`'s bound where ``probe(index,
    value)``, the largest distance (m) of a position outside its cell with that figure held,
    finds one), said in a note."""
    x, model, idx, sd, outside = fit.figures, fit.model, fit.idx, fit.sd, fit.outside
    d = len(r.axes["mass"])
    m, b, fc = x[:d], x[d:2 * d], float(x[2 * d])
    dev = _device(m, b, fc, r.device.period, r.device.delay, r.device.position_resolution, r.source)
    unit = {"mass": "kg", "damping": "N·s/m"}
    was = ", ".join(f"{k} {', '.join(f'{v:.4g}' for v in r.axes[k])} {unit[k]}" for k in ("mass", "damping"))
    axes, unc = {**r.axes, "mass": m.tolist(), "damping": b.tolist()}, r.uncertainty
    if sd is None:
        how = (f"their deviations are least squares' ({outside} positions left their cells at the cells' optimum, "
               f"fewer than {CELL_DEVIATION_ROWS} a parameter: inside the cells the cost is flat and tells none)")
        delta = r.device.position_resolution
        tol = max(3.0 * fit.beyond, 1e-3 * delta)
        for name, off in (("mass", 0), ("damping", d)):
            for a in range(d):
                v = float(x[off + a])
                if probe is None or not 0 < v <= TOLD * r.axes[name + "_sd"][a]:
                    continue
                out = min(probe(off + a, v * (1.0 + sgn * CELL_PROBE)) for sgn in (-1.0, 1.0))
                held = f"; the {name} held {100 * CELL_PROBE:g} % below and above its figure"
                if out > tol:
                    axes[name + "_sd"] = [*axes[name + "_sd"]]
                    axes[name + "_sd"][a] = CELL_PROBE * v / TOLD
                    how += (f"{held} leaves positions {out * 1e6:.2g} µm or more outside their cells: every {name} "
                            f"that keeps them in lies within it, its deviation {100 * CELL_PROBE / TOLD:.3g} % of it")
                else:
                    how += f"{held} keeps them within {max(out, 0.0) * 1e6:.2g} µm of their cells: not bounded"
        unc = {**unc, "mass": float(np.max(axes["mass_sd"])), "damping": float(np.max(axes["damping_sd"]))}
    else:
        how = (f"their deviations the cells' own (the {outside} positions that left their cells, read as an "
               "M-estimator's: least squares' were " + ", ".join(
                   f"{k} {', '.join(f'{v:.2g}' for v in r.axes[k + '_sd'])} {unit[k]}" for k in ("mass", "damping"))
               + f", friction {r.uncertainty['coulomb_friction']:.2g} N)")
        axes.update(mass_sd=sd[:d].tolist(), damping_sd=sd[d:2 * d].tolist())
        unc = {**unc, "mass": float(np.max(sd[:d])), "damping": float(np.max(sd[d:2 * d])),
               "coulomb_friction": float(sd[2 * d])}
    note = (f"mass, damping and friction: the cells' fit at delay {r.device.delay} (least squares on the positions "
            f"read {was}, friction {r.device.coulomb_friction:.4g} N); {how}")
    trace = {"time": t[idx].ravel(), "measured": p[idx][..., 0].ravel(), "model": model[..., 0].ravel()}
    return dataclasses.replace(r, device=dev, axes=axes, uncertainty=unc,
                               residual_rms=float(np.sqrt(np.mean((model - p[idx]) ** 2))), trace=trace,
                               notes=[*r.notes, note])


def _cells_probe(p, f, T, first: "Identification", max_delay: int, D: int, x, ticks: _Ticks | None = None):
    """``probe(index, value)`` for :func:`_with_cells_figures`: the largest distance (m) of a
    position outside its encoder cell when the cells' fit at delay D is refitted from figures
    ``x`` with figure ``index`` held at ``value`` (the data cut at the first call: most logs
    never call it); ``ticks`` as :func:`_cells_data` takes them."""
    data = []

    def probe(k, value):
        if not data:
            pd, fd, H, init, cut = _cells_data(p, f, T, first, max_delay, ticks)
            d = p.shape[1]
            data.extend([pd, fd, H, {**init, "m": x[:d], "b": x[d:2 * d], "fc": float(x[2 * d])}, cut])
        pd, fd, H, init, cut = data
        delta = first.device.position_resolution
        return _cells_fit(pd, fd, T, D, H, init, delta, hold=(k, value), ticks=cut).beyond

    return probe


def _cells_data(p, f, T, first: "Identification", max_delay: int, ticks: _Ticks | None = None):
    """The cells' fits' data: (positions, forces) cut to the :data:`LONG_WINDOW` windows that
    every delay up to ``max_delay`` holds, the window's samples, the fits' start (``first``'s
    figures, the velocities estimated) and the log's ``ticks`` (:class:`_Ticks`) cut alike."""
    H = int(round(LONG_WINDOW / T))
    W = (p.shape[0] - max_delay) // H
    p, f = p[:max_delay + W * H], f[:max_delay + W * H]
    v, _ = _derivatives(p, T)
    init = {"m": np.array(first.axes["mass"]), "b": np.array(first.axes["damping"]),
            "fc": float(first.device.coulomb_friction), "v": v}
    if ticks is not None:
        cut = p.shape[0] - 1
        ticks = _Ticks(None if ticks.intervals is None else ticks.intervals[:cut],
                       None if ticks.stray is None else ticks.stray[:cut], ticks.reach)
    return p, f, H, init, ticks


def _cells_delay(p, f, T, first: "Identification", max_delay: int, walk: bool = True,
                 ticks: _Ticks | None = None):
    """The delay an encoder's log tells by its cells: each delay's :func:`_cells_fit` on
    :data:`LONG_WINDOW` windows (the same number for every delay) from ``first``'s figures,
    starting at ``first``'s delay and its neighbours and walking towards the least cost until
    both of its neighbours are fitted (the cost falls towards the truth's delay on every side:
    on a 4 kHz log of :data:`CELL_MARGIN`'s, truth 4, 128, 56, 19, 4.4, 1.7, 4.8, 20 at delays
    0-6). Returns (delays by cost, {delay: cost}, told, {delay: its fit}), told when the best's
    cost is :data:`CELL_MARGIN` times below every other's, each fit a :class:`_CellsFit`.
    Without ``walk`` only ``first``'s delay is fitted (told: its screening told it); ``stray``
    as :func:`_cells_data` takes it."""
    p, f, H, init, ticks = _cells_data(p, f, T, first, max_delay, ticks)  # (W windows at every delay)
    delta = first.device.position_resolution
    D1 = first.device.delay
    todo = {k for k in ((D1 - 1, D1, D1 + 1) if walk else (D1,)) if 0 <= k <= max_delay}
    costs, fits = {}, {}
    while walk or not costs:
        for k in sorted(todo - costs.keys()):
            fits[k] = _cells_fit(p, f, T, k, H, init, delta, ticks=ticks)
            costs[k] = fits[k].cost
        best = min(costs, key=costs.get)
        todo = {k for k in (best - 1, best + 1) if 0 <= k <= max_delay} - costs.keys()
        if not todo or not walk:
            break
    ranked = sorted(costs, key=costs.get)
    told = len(ranked) == 1 or costs[ranked[1]] > CELL_MARGIN * costs[ranked[0]]
    return ranked, costs, told, fits


def _widened(r: Identification, spread) -> Identification:
    """``r`` with each figure's deviation widened (in quadrature) by ``spread`` (2 d + 1,: the
    masses, the dampings, the friction), the differences between fits of delays the log cannot
    tell apart."""
    d = len(r.axes["mass"])
    s = np.asarray(spread, dtype=float)
    msd = np.hypot(r.axes["mass_sd"], s[:d])
    bsd = np.hypot(r.axes["damping_sd"], s[d:2 * d])
    fsd = float(np.hypot(r.uncertainty["coulomb_friction"], s[2 * d]))
    axes = {**r.axes, "mass_sd": msd.tolist(), "damping_sd": bsd.tolist(),
            "delay_spread": np.maximum(r.axes["delay_spread"], s).tolist()}
    unc = {**r.uncertainty, "mass": float(np.max(msd)), "damping": float(np.max(bsd)), "coulomb_friction": fsd}
    return dataclasses.replace(r, axes=axes, uncertainty=unc)


def _delay_list(ks) -> str:
    """Whole numbers (sorted) written as runs: [1, 2, 3, 5] -> '1-3, 5'."""
    runs = []
    for k in ks:
        if runs and k == runs[-1][1] + 1:
            runs[-1][1] = k
        else:
            runs.append([k, k])
    return ", ".join(f"{a}" if a == b else f"{a}-{b}" for a, b in runs)


def _damping_spread(r: Identification) -> float:
    """The largest relative standard deviation of an identification's damping over its axes."""
    return max(sd / max(b, 1e-12) for b, sd in zip(r.axes["damping"], r.axes["damping_sd"]))


def _time_constant(r: Identification) -> float:
    """The longest m/b (s) over an identification's axes."""
    return max(m / max(b, 1e-12) for m, b in zip(r.axes["mass"], r.axes["damping"]))


def identify_log(path, **options) -> Identification:
    """:func:`identify` on a log file (:func:`read_log`); the samples where the servo had not
    engaged its forces are kept (their force, zero, was sent too).

    Parameters
    ----------
    path : str or os.PathLike
        A run log (CSV or .npz).
    **options
        :func:`identify`'s ``max_delay``, ``window`` and ``position_resolution``.

    Returns
    -------
    Identification

    Raises
    ------
    ParameterError
        As :func:`read_log` and :func:`identify`.
    """
    log = read_log(path)
    return identify(time=log.time, position=log.position, force=log.force, source=log.path, **options)


def excitation(period: float, duration: float = 10.0, amplitude: float = 1.0, seed: int = 0) -> np.ndarray:
    """A free-space force program for identification: steps of random sign and length (0.05-0.3 s,
    half the amplitude) plus a logarithmic chirp from 2 to 50 Hz (half the amplitude), on one axis.

    Parameters
    ----------
    period : float
        Servo period (s).
    duration : float, optional
        s, default 10.
    amplitude : float, optional
        Largest force (N), default 1; choose a stated fraction of the device's maximum.
    seed : int, optional

    Returns
    -------
    numpy.ndarray, shape (n,)
        N, one a tick (n = duration / period).

    Raises
    ------
    ParameterError
        For a non-positive period, duration or amplitude, or a seed that is not numpy's
        default_rng's (a whole number from 0 to 2^64 - 1).
    """
    from scipy.signal import chirp

    T = positive("period", period, "s")
    n = int(round(positive("duration", duration, "s") / T))
    A = positive("amplitude", amplitude, "N")
    rng = np.random.default_rng(random_seed("seed", seed))
    t = np.arange(n) * T
    steps = np.empty(n)
    k = 0
    sign = 1.0
    while k < n:
        length = int(rng.uniform(0.05, 0.3) / T)
        steps[k:k + length] = sign
        sign = -sign if rng.random() < 0.8 else sign
        k += max(length, 1)
    return 0.5 * A * steps + 0.5 * A * chirp(t, 2.0, max(t[-1], T), 50.0, method="logarithmic")


CENTERING = (50.0, 5.0)
"""Stiffness (N/m) and damping (N s/m) of the spring-damper that keeps a free handle in its
workspace during an identification run, pulling the sensed position to where it started
(chosen: at 50 N/m a 1 N force moves the handle 2 cm; 5 N s/m damps a 0.2 kg handle on it at a
damping ratio of 0.8, so the chirp's low end does not ring it up. Its force is logged with the
rest: the identification reads the force sent, whatever made it)."""


def simulated_log(device, duration: float = 10.0, amplitude: float = 1.0, noise: float = 0.0, seed: int = 0):
    """The log of an identification run (:class:`IdentificationProgram`) on a model device: the
    program's force on the sensed position, applied ``device.delay`` ticks later and held over
    the period, the handle free (no wall, no hand) with its Coulomb friction, the positions read
    on the encoder's lattice (after Gaussian ``noise``). The first axis only: a one-axis log.

    The motion is the C core's (``free_run``, one period at a time: the step of
    :func:`identify`'s model, the Coulomb step of :func:`haptex.simulate`'s general loop).

    Parameters
    ----------
    device : haptex.Device
        Rigid; its first axis's mass and damping are used.
    duration : float, optional
        s, default 10 (after :data:`QUIET` s of rest).
    amplitude : float, optional
        The program's largest force (N), default 1.
    noise : float, optional
        Standard deviation of the position sensor's noise (m), default 0.
    seed : int, optional
        The program's steps and the noise.

    Returns
    -------
    (time, position, force) : numpy.ndarray, each of shape (n,)
        s, m, N (the force as commanded).

    Raises
    ------
    ParameterError
        For a device with a structural mode, a negative noise, or as :func:`excitation`.
    """
    device = checked_device(device)
    from ._validation import nonnegative
    from .core import _ext
    from .simulate import _axis_coefficients

    if device.structural_mode:
        raise fail("device", device.name, "a rigid device (the identification's model has no structural mode)")
    sigma = nonnegative("noise", noise, "m")
    T, D, delta = device.period, device.delay, device.position_resolution
    program = IdentificationProgram(1, T, duration, amplitude, seed)  # (seed checked there, by excitation)
    c = np.ascontiguousarray(_axis_coefficients(device.mass[0, 0], device.damping[0, 0], T).reshape(1, -1))
    rng = np.random.default_rng((int(seed) + 1) % 2**64)  # (the noise's stream: the next seed)
    n = program.program.size
    pos, force = np.empty(n), np.empty(n)
    p0, v0 = np.zeros((1, 1)), np.zeros((1, 1))
    queue = [0.0] * D
    one, held = np.empty((1, 1, 1)), np.zeros((1, 1, 1))
    for k in range(n):
        x = p0[0, 0] + (sigma * rng.standard_normal() if sigma else 0.0)
        sensed = delta * round(x / delta) if delta > 0 else x
        cmd = float(program.step(np.array([sensed]))[0])
        pos[k], force[k] = sensed, cmd
        queue.append(cmd)
        held[0, 0, 0] = queue.pop(0)
        _ext.free_run(c, float(device.coulomb_friction), held, p0, v0, one)  # p0, v0: the state a period on
    return np.arange(n) * T, pos, force


VELOCITY_SPAN = 10
"""Ticks the centering damper's velocity is differenced over (chosen: an encoder step over 10
ticks, not one, so that the damper's force carries a tenth of the rounding; at one tick that
rounding, fed back, biased the fitted damping by 23 % at 4 kHz, the error-in-variables of
closed-loop identification)."""
QUIET = 0.3
"""Seconds of zero program force at the start of an identification run (chosen: the servo
engages its forces after 50 ms below 0.5 N and ramps them in over 0.2 s)."""
FRACTION = 0.2
"""The share of the device's largest force the identification program uses (chosen: a light
hold; a Falcon's 8.9 N gives 1.8 N)."""


class IdentificationProgram:
    """The force program of an identification run, as a renderer the servo loop calls
    (``haptex run --identify``): :func:`excitation` along x after :data:`QUIET` s of rest,
    plus the :data:`CENTERING` spring to the first sensed position on every axis (which
    keeps a free handle in the workspace); the log records the force as sent.

    Parameters
    ----------
    dimension : int
        The device's (2 or 3).
    period : float
        s.
    duration : float
        s.
    amplitude : float
        N, the program's largest force (:data:`FRACTION` of the device's maximum).
    seed : int, optional

    Raises
    ------
    ParameterError
        As :func:`excitation`.
    """

    def __init__(self, dimension: int, period: float, duration: float, amplitude: float, seed: int = 0):
        quiet = int(round(QUIET / period))
        self.program = np.concatenate([np.zeros(quiet), excitation(period, duration, amplitude, seed)])
        self.dimension = int(dimension)
        self.period = float(period)
        self.clamps = 0
        self._k = 0
        self._home = None
        self._past = None

    def step(self, position):
        """The force to command for the sensed position.

        Parameters
        ----------
        position : array_like, shape (dimension,)
            m.

        Returns
        -------
        numpy.ndarray, shape (dimension,)
            N.
        """
        p = np.asarray(position, dtype=np.float64)
        if self._home is None:
            self._home = p.copy()
            self._past = np.tile(p, (VELOCITY_SPAN, 1))
        kc, bc = CENTERING
        v = (p - self._past[self._k % VELOCITY_SPAN]) / (VELOCITY_SPAN * self.period)
        self._past[self._k % VELOCITY_SPAN] = p
        f = -kc * (p - self._home) - bc * v
        f[0] += self.program[min(self._k, self.program.size - 1)] if self._k < self.program.size else 0.0
        self._k += 1
        return f
