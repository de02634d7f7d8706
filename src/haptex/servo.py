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

The rules are one C function of a sample (``hx_servo.c`` in the C core, which ``haptex
export`` ships too), run once a tick by one of four drivers:

- the C core's **native servo thread** (``drive_native`` of the simulated and Force Dimension
  backends; ``hx_thread.c``): a POSIX thread woken on an absolute deadline of the monotonic
  clock once a period, at SCHED_FIFO priority :data:`haptex.backends.PRIORITY` with its memory
  locked where the user's rights allow (a plain thread otherwise, said in
  :attr:`ServoStats.fifo`), that samples the device, runs the rules and the renderer's tick
  and commands the force with no Python and no GIL. Python reads its last tick through a
  seqlock (``Servo.snapshot``) and its counts, never blocking it;
- the vendor's servo thread calling the C callback (``drive_native`` of OpenHaptics, HD's
  scheduler), likewise without Python;
- a vendor callback in the backend's own servo thread (``drive``), which calls the same
  tick from Python inside the callback, taking the GIL;
- this thread's loop (``sample``, the rules, ``command``), for the lock-step backends (Haply's
  Inverse Service and serial port) and for a renderer that is not a :class:`~haptex.Renderer`:
  one call into C a tick.

Every driver counts the same figures (:class:`ServoStats`): late samples (the watchdog's
missed ticks), overruns, the worst and 99.9th percentile of each tick's work and of the
period's jitter. Measured per backend, idle and under load, in ``benchmarks/run_backends.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ._validation import check_budget, fail, flag, positive, whole
from .backends import PRIORITY, Sample
from . import core as _core
from .core import _ext
from .algorithms import checked_algorithm

ENGAGE_FORCE = 0.5
"""N: the force below which the loop may engage (chosen: a light touch)."""
ENGAGE_TICKS = 50
"""Ticks in a row below ENGAGE_FORCE before engaging (chosen: 50 ms at 1 kHz)."""
RAMP_TICKS = 200
"""Ticks over which forces are ramped in once engaged (chosen: 0.2 s at 1 kHz)."""
DEADLINE = 1.5
"""A sample later than this many periods after the previous one is a missed deadline."""


SEARCH_SHARE = 0.5
"""The share of the servo period D's and E's closest-point search over a surface may take in
``haptex run`` (chosen: the rest for the device's exchange, the rules and the clock's jitter)."""

SEARCH_PROBES = 32
"""Ticks :func:`evaluation_seconds` times: a 4 x 8 grid over the texture (chosen: about 80 ms
over a measured map at the default budget, before the run)."""

SEARCH_DEPTHS = 4
"""Depths :func:`search_budget` measures an evaluation's cost at, the handle's deepest and each a
tenth of the last (chosen: the cost varies with the depth, 0.31-0.56 us an evaluation over
mi-1.mi felt by a 2 um ball between 1 um and 18 mm on this project's machine); the largest is
taken."""


def evaluation_seconds(renderer, depth: float) -> float:
    """The cost of one texture evaluation in ``renderer``'s closest-point search on this
    machine, measured: :data:`SEARCH_PROBES` ticks at ``depth`` below the texture's lowest
    point (where the search is widest), on a grid over a sampled map's extent (else over four of
    the texture's shortest periods), their time over the evaluations they counted
    (:attr:`haptex.Renderer.last_work`).

    Parameters
    ----------
    renderer : Renderer
        D or E over a surface (the renderer's state is spent: make a new one for the run).
    depth : float
        Depth (m, > 0) of the probes below the texture's lowest point: the deepest the handle
        goes, e.g. the device's force over the stiffness.

    Returns
    -------
    float
        Seconds an evaluation (s), the ticks' wall time over their work.

    Raises
    ------
    ParameterError
        If ``depth`` is not a finite length > 0.
    """
    import time

    depth = positive("depth", depth, "m")
    tex = renderer.algorithm.texture
    lo = tex.height_range[0]
    if hasattr(tex, "y"):
        xs, ys = (np.linspace(float(a[0]), float(a[-1]), n) for a, n in ((tex.x, 4), (tex.y, 8)))
    else:
        xs, ys = (np.linspace(0.0, 4 * tex.shortest_period, n) for n in (4, 8))
    pts = [(float(x), float(y), lo - depth) for x in xs for y in ys]
    work, start = 0, time.perf_counter()
    for p in pts:
        renderer.step(p)
        work += renderer.last_work
    return (time.perf_counter() - start) / max(work, 1)


def budgeted_search(algorithm) -> bool:
    """Whether ``algorithm``'s tick is one :func:`search_budget` measures: D or E over a surface on
    the plane (a profile's search is bounded by its tree; an object's keeps the renderer's default
    budget, :data:`haptex.renderer.MAX_EVALUATIONS`).

    Parameters
    ----------
    algorithm : Algorithm or GodObject
        What is rendered.

    Returns
    -------
    bool
    """
    algorithm = checked_algorithm(algorithm, proxy=True)
    from .renderer import reads_search_budget

    return reads_search_budget(algorithm) and getattr(algorithm, "base", None) is None


def search_budget(algorithm, period: float, depth: float) -> tuple[int | None, float | None]:
    """The closest-point search's budget of texture evaluations a tick that fits
    :data:`SEARCH_SHARE` of the servo ``period``, from :func:`evaluation_seconds` on this machine,
    its largest at :data:`SEARCH_DEPTHS` depths from ``depth`` down (``haptex run``'s default ``--max-evaluations``; the renderer's own default,
    :data:`haptex.renderer.MAX_EVALUATIONS`, is at most that much; at least 100, the renderer's
    smallest, where even that takes longer).

    Parameters
    ----------
    algorithm : Algorithm
        The algorithm rendered.
    period : float
        The servo period (s, > 0).
    depth : float
        The deepest the handle goes below the texture (m, > 0), as :func:`evaluation_seconds`.

    Returns
    -------
    (int or None, float or None)
        (the budget, the seconds an evaluation measured) for D or E over a surface on the
        plane; (None, None) for every other algorithm (no budgeted search: a profile's is
        bounded by its tree).

    Raises
    ------
    ParameterError
        If ``period`` or ``depth`` is not a finite value > 0.
    """
    algorithm = checked_algorithm(algorithm, proxy=True)
    from .renderer import MAX_EVALUATIONS, Renderer

    period = positive("period", period, "s")
    if not budgeted_search(algorithm):
        return None, None
    depth = positive("depth", depth, "m")
    renderer = Renderer(algorithm)
    seconds = 0.0
    for k in range(SEARCH_DEPTHS):  # (an evaluation's cost varies with the depth: 0.31-0.56 us over a felt map)
        renderer.reset()
        seconds = max(seconds, evaluation_seconds(renderer, depth * 10.0 ** -k))
    return max(100, min(MAX_EVALUATIONS, int(SEARCH_SHARE * period / seconds))), seconds


@dataclass
class ServoStats:
    """What a run did, counted.

    Parameters
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
    tick_p999 : float
        The 99.9th percentile of a tick's work (s, to 100 ns).
    jitter_seconds : tuple of float
        Worst and 99.9th percentile of |dt - T| (s), dt the time between samples.
    overruns : int
        Ticks whose force left after the next tick was due (native thread only: the Python
        drivers' late samples are in ``missed``).
    driver : str
        ``native thread``, ``native callback``, ``vendor callback`` or ``python loop``.
    fifo, memory_locked : bool
        The native thread ran at SCHED_FIFO, with its memory locked (what it was granted).
    awake_core : int or None
        The core the native thread was pinned to and kept awake (``keep_awake``), or None.
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
    tick_p999: float = 0.0
    jitter_seconds: tuple = (0.0, 0.0)
    overruns: int = 0
    driver: str = "python loop"
    fifo: bool = False
    memory_locked: bool = False
    awake_core: int | None = None


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
    native : bool, optional
        Use the backend's native driver (the C core's servo thread, or the C tick in the
        vendor's servo thread) when it has one and the renderer is a :class:`~haptex.Renderer`
        (default True); False runs the Python loop or callback instead (for comparison).
    priority : int, optional
        The SCHED_FIFO priority the native servo thread asks for, 1-99, or 0 for a plain
        thread; default :data:`haptex.backends.PRIORITY`.
    keep_awake : bool, optional
        Pin the native servo thread to one core and keep that core from halting: a companion
        thread spins there at SCHED_OTHER and nice 19, below every other task, until the run
        ends (Linux, two cores or more; chosen off by default: it spends that core's whole
        time). On a virtual machine an idle virtual CPU halts and is woken late for the next
        tick; this is what Linux's ``idle=poll`` does for a whole machine. Measured on this
        project's 2-core VM: benchmarks/README.md, "The native servo thread".

    Raises
    ------
    ParameterError
        For a renderer of another dimension, a maximum above the backend's, or settings out
        of range.
    """

    def __init__(self, backend, renderer, max_force: float | None = None, engage_force: float = ENGAGE_FORCE,
                 engage_ticks: int = ENGAGE_TICKS, ramp_ticks: int = RAMP_TICKS, deadline: float = DEADLINE,
                 native: bool = True, priority: int = PRIORITY, keep_awake: bool = False):
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
        self.native = native = flag("native", native)
        self.priority = whole("priority", priority, 0, 99)
        keep_awake = flag("keep_awake", keep_awake)
        if keep_awake and not (native and getattr(backend, "native", False) and getattr(backend, "drive", None) is None):
            raise fail("keep_awake", keep_awake, "a backend whose servo loop is the C core's own thread (simulated, "
                       "Force Dimension, Haply's serial port) with native=True; OpenHaptics' scheduler owns its thread, "
                       "and a Python loop cannot be kept on one core")
        self.keep_awake = keep_awake

    @_core.blas_held_to_one_thread  # no BLAS worker spins beside the servo loop
    def run(self, duration: float, record: bool = True, on_tick=None) -> tuple[ServoStats, dict]:
        """Run for ``duration`` seconds of the backend's clock.

        Parameters
        ----------
        duration : float
            s, > 0.
        record : bool, optional
            Keep the trace: ``time`` (s), ``position`` (m), ``force`` (N, as sent) and
            ``engaged`` per tick (57 bytes a tick in 3-D, allocated before the run starts).
        on_tick : callable, optional
            Called as ``on_tick(k, counts)`` every tick of a Python driver, and about every
            50 ms while a native driver runs (a live dashboard); ``counts`` has the attributes
            ``ticks``, ``missed``, ``faults``, ``engaged_at`` and ``max_force_sent`` of
            :class:`ServoStats`, live, and ``stop()``, which ends the run with zero force from
            the next tick (every driver). The trace so far is :attr:`trace`'s rows up to
            ``counts.ticks``.

        Returns
        -------
        (ServoStats, dict)
            The counts and the trace (empty arrays without ``record``).

        Raises
        ------
        ParameterError
            For a duration that is not > 0, or whose trace would not fit in the memory budget
            (:func:`haptex._validation.memory_budget`).
        """
        T = self.backend.period
        # (a duration within 1e-9 of a whole number of periods is that many: 0.3 s / 1 ms is 300)
        n_ticks = max(1, int(math.ceil(positive("duration", duration, "s") / T - 1e-9)))
        d = self.backend.dimension
        zero = np.zeros(d)
        n_rec = n_ticks if record else 0
        check_budget("duration", duration, n_rec * (8 + 16 * d + 1), "the run's trace")
        trace = {"time": np.zeros(n_rec), "position": np.zeros((n_rec, d)), "force": np.zeros((n_rec, d)),
                 "engaged": np.zeros(n_rec, dtype=bool)}
        for a in trace.values():  # written once now: no page is first touched by a tick
            a.fill(0)
        self.trace = trace  # (read while it runs by on_tick, up to servo.ticks: haptex.limits.find_limit)
        servo = _ext.Servo(d, T, float(self.backend.workspace), float(self.max_force), float(self.engage_force),
                           self.engage_ticks, self.ramp_ticks, float(self.deadline), self.backend_realtime(),
                           *((trace["time"], trace["position"], trace["force"], trace["engaged"]) if record else ()))
        core = getattr(self.renderer, "_core", None)
        step = core if isinstance(core, _ext.Renderer) else self.renderer.step
        st = ServoStats()
        native = self.backend.drive_native if self.native and step is core and getattr(self.backend, "native",
                                                                                        False) else None
        if self.keep_awake and native is None:
            raise fail("keep_awake", True, "a haptex.Renderer, whose C core the native thread runs (this renderer's "
                       "ticks run in Python)")

        def tick(s: Sample):
            """Rules 1-4 on one sample, in C: the force to command (the backend sends it)."""
            f = servo.tick(s.time, s.position, step)
            if on_tick is not None:
                on_tick(servo.ticks - 1, servo)
            return f

        self.backend.open()
        drive = getattr(self.backend, "drive", None)
        st.driver = ("native callback" if drive is not None else "native thread") if native is not None else (
            "vendor callback" if drive is not None else "python loop")
        try:
            if native is not None:  # the C core's servo thread, or the vendor's, runs the C tick: no GIL
                if self.keep_awake:
                    native(servo, core, n_ticks, on_tick, priority=self.priority, keep_awake=True)
                else:
                    native(servo, core, n_ticks, on_tick, priority=self.priority)
            elif drive is not None:  # a vendor callback in the servo thread runs each tick
                drive(tick, n_ticks)
            else:  # lock-step, or a renderer in Python: this thread runs each tick
                for _ in range(n_ticks):
                    self.backend.command(tick(self.backend.sample()))
                    if servo.stopping:  # asked by on_tick (servo.stop()): zero force next, below
                        break
        except KeyboardInterrupt:
            st.interrupted = True
        finally:  # rule 5: zero force on every exit path
            try:
                self.backend.command(zero)
            finally:
                self.backend.close()
        st.ticks, st.missed, st.faults = servo.ticks, servo.missed, servo.faults
        st.clamps = servo.clamps + self.renderer.clamps
        st.engaged_at, st.max_force_sent = servo.engaged_at, servo.max_force_sent
        st.tick_seconds = [servo.work_max, servo.work_mean]
        timing = servo.timing()
        st.tick_p999 = timing["work_p999"]
        st.jitter_seconds = (timing["jitter_max"], timing["jitter_p999"])
        st.overruns = timing["overruns"]
        st.fifo, st.memory_locked = timing["fifo"], timing["locked"]
        st.awake_core = timing["awake"] - 1 if timing["awake"] else None
        if servo.periods:
            st.period_seconds = (servo.period_mean, servo.period_std)
        n = min(st.ticks, n_rec)
        return st, {key: value[:n] for key, value in trace.items()}

    def backend_realtime(self) -> bool:
        """Whether the backend paces the loop (the watchdog judges deadlines only then).

        Returns
        -------
        bool
            True when the backend paces the loop.
        """
        return bool(getattr(self.backend, "realtime", True))


REST_STEPS = 0.75
"""Encoder steps of half peak-to-peak motion (rebuilt, :func:`haptex.perception.dequantise`) below
which :func:`analyse_trace` counts a handle at rest (chosen: the rebuilt motion of a dither over
two, three, four levels has 0, 1/2, 1 step; 3/4 lies between, so no verdict flips on one count)."""
TAIL_FRACTION = 0.4
"""The share of a trace whose motion :func:`analyse_trace` judges (as :func:`haptex.simulate`)."""


def analyse_trace(trace: dict, period: float, resolution: float = 0.0, texture_periods=(),
                  speed: float | None = None) -> dict:
    """A trace of :meth:`ServoLoop.run` analysed as a simulated run: energies, oscillation, buzz.

    The verdicts read the handle's motion, not the encoder's staircase: the sensed positions are
    first rid of it (:func:`haptex.perception.dequantise`), so a hand sliding at v over an
    encoder of step delta is not a vibration at v / delta. Buzz counts no component of half a
    step or less (the encoder cannot show it); the oscillation verdict counts a motion as
    moving above :data:`REST_STEPS` steps (the encoder reads it over at least four levels), and
    as sustained when its two halves' amplitudes differ by at most half a step beyond the
    simulator's tolerance (they are multiples of half a step). The
    texture's own rates, the scan speed over its periods and their harmonics, are the texture,
    not an oscillation of the loop nor buzz.

    Parameters
    ----------
    trace : dict
        ``position`` (m) and ``force`` (N), shape (n, d), one row a tick.
    period : float
        The servo period (s).
    resolution : float, optional
        The position sensor's step (m); 0 for exact positions.
    texture_periods : sequence of float, optional
        The rendered texture's spatial periods (m) where it has a line spectrum
        (``texture.periods``); empty otherwise.
    speed : float, optional
        The hand's speed over the texture (m/s) when known (a simulated hand); default the
        median tangential speed of the judged motion (the positions' axes but the last).

    Returns
    -------
    dict
        ``energy`` per axis (J): -sum f_k . (p_{k+1} - p_k), what the rendering absorbed from
        the sensed motion under the force sent (< 0: it supplied energy); ``oscillation``
        (:class:`haptex.Oscillation` of the last :data:`TAIL_FRACTION` of the trace, the
        simulator's own verdict, its rest threshold :data:`REST_STEPS` sensor steps) and its
        ``regime`` (:func:`haptex.simulate.regime`; ``oscillation.oscillating`` exactly when
        the regime is a limit cycle or growth);
        ``buzz`` (:class:`haptex.perception.Buzz` of the same tail against the hand's
        detection threshold, its floor half the sensor's step; None for fewer than 16 ticks or
        a non-finite position); ``texture_rates`` (Hz) left out of both; ``speed`` (m/s) they
        were computed with.

    Raises
    ------
    ParameterError
        For a non-positive period, a negative resolution, a speed not finite and >= 0, or
        texture periods not finite and > 0.
    """
    from ._validation import nonnegative
    from .perception import buzz, dequantise
    from .simulate import _oscillation, regime

    T = positive("period", period, "s")
    delta = nonnegative("resolution", resolution, "m")
    # a motion the encoder reads over at least four levels: the rebuilt motion's half peak-to-peak
    # is a multiple of half a step, so 3/4 of one lies between its values (no verdict flips on a count)
    threshold = max(REST_STEPS * delta, 1e-7)
    periods = np.atleast_1d(np.asarray(texture_periods, dtype=np.float64))
    if periods.size and not np.all(np.isfinite(periods) & (periods > 0)):
        raise fail("texture_periods", periods.tolist(), "finite periods > 0 (m)")
    p = np.asarray(trace["position"], dtype=np.float64)
    f = np.asarray(trace["force"], dtype=np.float64)
    n, d = p.shape
    de = -f[:-1] * np.diff(p, axis=0) if n > 1 else np.zeros((0, d))
    start = int(n * (1 - TAIL_FRACTION))
    tail_energy = float(np.sum(de[start:])) if n > 1 else 0.0
    finite = bool(np.all(np.isfinite(p)))
    tail = dequantise(p[start:], delta) if finite else p[start:]
    if speed is None:
        v = np.diff(tail[:, :-1], axis=0) / T if finite and tail.shape[0] > 1 and d > 1 else np.zeros((0, 1))
        speed = float(np.median(np.linalg.norm(v, axis=1))) if v.shape[0] else 0.0
    else:
        speed = nonnegative("speed", speed, "m/s")
    rates = tuple(float(speed / lam) for lam in periods) if speed > 0 else ()
    osc = _oscillation(tail, (n - start) * T, tail_energy, threshold, rates, slack=0.5 * delta)
    main = getattr(osc, osc.axis)
    reg = str(regime([osc.decay_ratio], [osc.amplitude], [threshold], [osc.cycles],
                     [False if main is None else main.texture_driven], [not finite], slack=0.5 * delta)[0])
    bz = None
    if tail.shape[0] >= 16 and finite:
        bz = buzz(tail, T, exclude=rates, floor=0.5 * delta)
    return {"energy": de.sum(axis=0), "oscillation": osc, "regime": reg, "buzz": bz, "texture_rates": rates,
            "speed": speed}
