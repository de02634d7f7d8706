"""The servo loop around a device backend, with the safety rules of careful SDK-based programs.

Per tick: sample the handle, compute the force with a :class:`~haptex.Renderer` (the C core's
tick), and command it through these rules, in order:

1. **Faults give zero force.** A sample that is not finite or lies beyond the backend's
   workspace, an exception in the tick, or a force that is not finite: the tick commands
   zero (the renderer counts its own faults and answers them with zero too).
2. **A missed deadline gives zero force** (the watchdog): a sample that arrives more than
   ``deadline`` periods after the previous one commands zero on that tick.
3. **No kick at start-up** (engagement): forces are held at zero until the computed force has
   stayed below ``engage_force`` for ``engage_ticks`` ticks in a row (a handle that starts
   inside a wall is not thrown out of it), then ramped linearly from zero over
   ``ramp_ticks`` ticks.
4. **Never above the device's maximum**: the renderer saturates to it, and the loop checks
   again before sending.
5. **Zero force on every exit**: the end of the run, an exception, Ctrl-C: the last command
   is zero, then the backend is closed.

The rules are one function of a sample, run once a tick by one of two drivers: this
thread's loop (``sample``, the rules, ``command``) for polling and lock-step backends, or the
backend's own servo thread for a backend with ``drive`` (a vendor callback, OpenHaptics'
scheduler), which calls it inside its callback. The rules run in Python (about 30-50 us a
tick on this machine with the simulated backend); the C tick inside them does not hold the
GIL.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ._validation import fail, positive, whole
from .backends import Sample

ENGAGE_FORCE = 0.5
"""N: the force below which the loop may engage (chosen: a light touch)."""
ENGAGE_TICKS = 50
"""Ticks in a row below ENGAGE_FORCE before engaging (chosen: 50 ms at 1 kHz)."""
RAMP_TICKS = 200
"""Ticks over which forces are ramped in once engaged (chosen: 0.2 s at 1 kHz)."""
DEADLINE = 1.5
"""A sample later than this many periods after the previous one is a missed deadline."""


@dataclass
class ServoStats:
    """What a run did, counted.

    Attributes
    ----------
    ticks : int
    missed : int
        Samples later than the deadline (each answered with zero force).
    faults : int
        Ticks answered with zero force for a fault (sample, tick or force).
    clamps : int
        Ticks whose force the renderer scaled to the maximum.
    engaged_at : int or None
        The tick forces were engaged at (None: never).
    max_force_sent : float
        N.
    tick_seconds : list of float
        Worst and mean time of the loop's own work a tick (s), sample to command.
    period_seconds : tuple of float
        Mean and standard deviation of the time between samples (s): rate and jitter.
    interrupted : bool
        The run ended on Ctrl-C (forces zeroed, trace kept).
    """

    ticks: int = 0
    missed: int = 0
    faults: int = 0
    clamps: int = 0
    engaged_at: int | None = None
    max_force_sent: float = 0.0
    tick_seconds: list = field(default_factory=lambda: [0.0, 0.0])
    period_seconds: tuple = (0.0, 0.0)
    interrupted: bool = False


class ServoLoop:
    """One renderer on one backend under the safety rules of the module docstring.

    Parameters
    ----------
    backend : DeviceBackend
        Not yet opened; :meth:`run` opens and closes it.
    renderer : Renderer
        Of the backend's dimension.
    max_force : float, optional
        N, at most the backend's; default the backend's.
    engage_force, engage_ticks, ramp_ticks, deadline : optional
        The engagement and watchdog settings (defaults :data:`ENGAGE_FORCE` N,
        :data:`ENGAGE_TICKS`, :data:`RAMP_TICKS`, :data:`DEADLINE` periods).

    Raises
    ------
    ParameterError
        For a renderer of another dimension, a maximum above the backend's, or settings out
        of range.
    """

    def __init__(self, backend, renderer, max_force: float | None = None, engage_force: float = ENGAGE_FORCE,
                 engage_ticks: int = ENGAGE_TICKS, ramp_ticks: int = RAMP_TICKS, deadline: float = DEADLINE):
        if renderer.dimension != backend.dimension:
            raise fail("renderer", f"{renderer.dimension}-D", f"of the device's dimension ({backend.dimension}-D)")
        self.max_force = backend.max_force if max_force is None else positive("max_force", max_force, "N")
        if self.max_force > backend.max_force:
            raise fail("max_force", self.max_force, f"at most the device's {backend.max_force:g} N")
        self.backend, self.renderer = backend, renderer
        self.engage_force = positive("engage_force", engage_force, "N")
        self.engage_ticks = whole("engage_ticks", engage_ticks, 1, 10**6)
        self.ramp_ticks = whole("ramp_ticks", ramp_ticks, 1, 10**6)
        self.deadline = positive("deadline", deadline, "periods")
        if self.deadline < 1.0:
            raise fail("deadline", deadline, ">= 1 period")

    def run(self, duration: float, record: bool = True, on_tick=None) -> tuple[ServoStats, dict]:
        """Run for ``duration`` seconds of the backend's clock.

        Parameters
        ----------
        duration : float
            s, > 0.
        record : bool, optional
            Keep the trace: ``time`` (s), ``position`` (m), ``force`` (N, as sent) and
            ``engaged`` per tick.
        on_tick : callable, optional
            Called as ``on_tick(k, stats)`` every tick (a live dashboard).

        Returns
        -------
        (ServoStats, dict)
            The counts and the trace (empty arrays without ``record``).
        """
        T = self.backend.period
        # (a duration within 1e-9 of a whole number of periods is that many: 0.3 s / 1 ms is 300)
        n_ticks = max(1, int(math.ceil(positive("duration", duration, "s") / T - 1e-9)))
        d = self.backend.dimension
        zero = np.zeros(d)
        st = ServoStats()
        rec_t, rec_p, rec_f, rec_e = [], [], [], []
        state = {"k": 0, "calm": 0, "ramp_from": None, "last_wall": None, "work_max": 0.0, "work_sum": 0.0}
        periods = []
        realtime = self.backend_realtime()

        def tick(s: Sample) -> np.ndarray:
            """Rules 1-4 on one sample: the force to command (the backend sends it)."""
            k = state["k"]
            t0 = time.perf_counter()
            last = state["last_wall"]
            if last is not None:
                periods.append(t0 - last)
            late = last is not None and realtime and t0 - last > self.deadline * T
            state["last_wall"] = t0
            p = np.asarray(s.position, dtype=np.float64)
            f = zero
            if p.shape != (d,) or not np.all(np.isfinite(p)) or np.linalg.norm(p) > self.backend.workspace:
                st.faults += 1
            else:
                try:
                    f = np.asarray(self.renderer.step(p), dtype=np.float64)
                except Exception:  # noqa: BLE001 -- any failure of the tick is a fault: zero force
                    st.faults += 1
                    f = zero
                if f.shape != (d,) or not np.all(np.isfinite(f)):
                    st.faults += 1
                    f = zero
            mag = float(np.linalg.norm(f))
            if st.engaged_at is None:  # rule 3: wait for a calm handle
                state["calm"] = state["calm"] + 1 if mag < self.engage_force else 0
                if state["calm"] >= self.engage_ticks:
                    st.engaged_at = state["ramp_from"] = k
                f = zero
            else:
                f = f * min(1.0, (k - state["ramp_from"] + 1) / self.ramp_ticks)
            mag = float(np.linalg.norm(f))
            if mag > self.max_force:  # rule 4, whatever the renderer did
                f = f * (self.max_force / mag)
                st.clamps += 1
            if late:  # rule 2: the watchdog
                st.missed += 1
                f = zero
            st.max_force_sent = max(st.max_force_sent, float(np.linalg.norm(f)))
            w = time.perf_counter() - t0
            state["work_max"], state["work_sum"] = max(state["work_max"], w), state["work_sum"] + w
            st.ticks += 1
            state["k"] = k + 1
            if record:
                rec_t.append(s.time)
                rec_p.append(p.copy() if p.shape == (d,) else np.full(d, np.nan))
                rec_f.append(f)
                rec_e.append(st.engaged_at is not None)
            if on_tick is not None:
                on_tick(k, st)
            return f

        self.backend.open()
        try:
            drive = getattr(self.backend, "drive", None)
            if drive is not None:  # a vendor callback in the servo thread runs each tick
                drive(tick, n_ticks)
            else:  # polling and lock-step: this thread runs each tick
                for _ in range(n_ticks):
                    self.backend.command(tick(self.backend.sample()))
        except KeyboardInterrupt:
            st.interrupted = True
        finally:  # rule 5: zero force on every exit path
            try:
                self.backend.command(zero)
            finally:
                self.backend.close()
        st.clamps += self.renderer.clamps
        st.tick_seconds = [state["work_max"], state["work_sum"] / max(st.ticks, 1)]
        if periods:
            st.period_seconds = (float(np.mean(periods)), float(np.std(periods)))
        trace = {"time": np.asarray(rec_t), "position": np.asarray(rec_p).reshape(-1, d),
                 "force": np.asarray(rec_f).reshape(-1, d), "engaged": np.asarray(rec_e, dtype=bool)}
        return st, trace

    def backend_realtime(self) -> bool:
        """Whether the backend paces the loop (the watchdog judges deadlines only then)."""
        return bool(getattr(self.backend, "realtime", True))


TAIL_FRACTION = 0.4
"""The share of a trace whose motion :func:`analyse_trace` judges (as :func:`haptex.simulate`)."""


def analyse_trace(trace: dict, period: float, resolution: float = 0.0) -> dict:
    """A trace of :meth:`ServoLoop.run` analysed as a simulated run: energies and oscillation.

    Parameters
    ----------
    trace : dict
        ``position`` (m) and ``force`` (N), shape (n, d), one row a tick.
    period : float
        The servo period (s).
    resolution : float, optional
        The position sensor's resolution (m): motion below it counts as rest.

    Returns
    -------
    dict
        ``energy`` per axis (J): -sum f_k . (p_{k+1} - p_k), what the rendering absorbed from
        the sensed motion under the force sent (< 0: it supplied energy); ``oscillation``
        (:class:`haptex.Oscillation` of the last :data:`TAIL_FRACTION` of the trace, the
        simulator's own verdict) and its ``regime`` (:func:`haptex.simulate.regime`).

    Raises
    ------
    ParameterError
        For a non-positive period or a negative resolution.
    """
    from ._validation import nonnegative
    from .simulate import _oscillation, regime

    T = positive("period", period, "s")
    threshold = max(nonnegative("resolution", resolution, "m"), 1e-7)
    p = np.asarray(trace["position"], dtype=np.float64)
    f = np.asarray(trace["force"], dtype=np.float64)
    n, d = p.shape
    de = -f[:-1] * np.diff(p, axis=0) if n > 1 else np.zeros((0, d))
    start = int(n * (1 - TAIL_FRACTION))
    tail_energy = float(np.sum(de[start:])) if n > 1 else 0.0
    osc = _oscillation(p[start:], (n - start) * T, tail_energy, threshold)
    reg = regime([osc.decay_ratio], [osc.amplitude], [threshold], [osc.cycles], [False],
                 [not np.all(np.isfinite(p))])[0]
    return {"energy": de.sum(axis=0), "oscillation": osc, "regime": str(reg)}
