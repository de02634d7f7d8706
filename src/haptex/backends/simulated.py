"""A device preset run by the exact sampled-data model, one tick at a time: the backend that
works on any machine (``haptex run --device simulated:falcon``).

The device itself is the C core's ``hx_plant`` (one implementation): :meth:`SimulatedBackend.sample`
and :meth:`~SimulatedBackend.command` call it from Python, and
:meth:`~SimulatedBackend.drive_native` hands it to the C core's native servo thread."""

from __future__ import annotations

import time

import numpy as np

from .._validation import fail, finite, nonnegative
from ..core import _ext
from . import PRIORITY, Sample, _force_to_send, wait_native, wait_until

SPIN = 3e-4
"""Seconds before a tick the real-time backend stops sleeping and spins on the clock (chosen:
above the overshoot of time.sleep on this machine, 0.05-0.2 ms)."""


class SimulatedBackend:
    """A preset of :mod:`haptex.catalogue` held by a hand, integrated between ticks by the
    simulator's exact transition (:func:`haptex.simulate`'s augmented dynamics: the held
    force, the hand's moving set-point, a structural mode where the preset has one).

    Between commands the handle obeys M dv/dt = f + K_h (s(t) - p) + C_h (ds/dt - v) - B v, with M and B
    the preset's Cartesian mass and damping at its home pose (plus the hand's mass), K_h and
    C_h the hand's stiffness and damping, and s(t) the hand's set-point, ``press`` (m) below
    the surface and moving along x at ``speed`` (m/s); the handle starts at rest at height
    ``start`` above the origin. The
    force f is held over each period (zero-order hold) and acts ``delay`` ticks after it is
    commanded (the preset's computation delay); positions are read rounded to the preset's
    resolution. Coulomb friction and the brakes' switching at the wall are not modelled here
    (the backend does not know the wall; the simulator, :func:`haptex.simulate`, has them).

    Parameters
    ----------
    preset : str
        A preset of :func:`haptex.catalogue.presets`.
    hand : str, optional
        A hand of :func:`haptex.catalogue.hands`; default light-touch; ``none`` leaves the
        handle free (an identification run, ``haptex run --identify``).
    press : float, optional
        Depth of the hand's set-point below the surface (m), default 1 mm.
    speed : float, optional
        The set-point's speed along x (m/s), default 10 mm/s.
    start : float, optional
        The handle's height at rest when opened (m): default 5 mm above the surface;
        negative starts it inside the wall.
    realtime : bool, optional
        Wait for the clock: each :meth:`sample` returns at its tick's time (a real device's
        pace), and the native servo thread ticks once a period. False runs as fast as the loop
        goes (tests, batch use).
    clock, sleep : callable, optional
        Time source (s) and sleep function, for tests.

    Raises
    ------
    ParameterError
        For an unknown preset or hand, a negative press, or a non-finite speed or start.
    """

    def __init__(self, preset: str, hand: str = "light-touch", press: float = 1e-3, speed: float = 0.01,
                 realtime: bool = True, clock=time.perf_counter, sleep=time.sleep, start: float = 5e-3):
        from ..catalogue import hand as _hand, preset as _preset

        p = _preset(preset)
        h = _hand(hand)
        dev = h.attach(p.device())
        self.name = f"simulated:{p.key}"
        self.preset, self.hand, self.device = p, h, dev
        self.dimension = dev.dimension
        self.period = dev.period
        self.max_force = dev.max_force
        self.workspace = 1.0  # m: far beyond any desktop device's reach (chosen)
        self.press = nonnegative("press", press, "m")
        self.speed = finite("speed", speed, "m/s")
        self.start = finite("start", start, "m")
        self.realtime = bool(realtime)
        self._clock, self._sleep = clock, sleep
        n = self.dimension
        # the simulator's own augmented dynamics (haptex.simulate): state [p, v, u, g, r] (and the
        # handle side [p_h, v_h] of a structural mode), u the held command, g the hand's pull
        # K s(t) + C ds/dt, r = dg/dt: exact over a period for the set-point's linear motion
        from ..core import expm
        from ..simulate import _augmented

        op = h.operator(depth=self.press, velocity=self.speed, dimension=n)
        mode = dev.mode_matrices() if dev.structural_mode else None
        F = _augmented(dev.mass, dev.damping, op.stiffness, op.damping, mode)
        # the hand's set-point s(t) = s(0) + (ds/dt) t: the scan at constant speed
        K, C = (np.ascontiguousarray(a, dtype=np.float64) for a in (op.stiffness, op.damping))
        s0 = np.ascontiguousarray(op.setpoint(0.0), dtype=np.float64)
        self._plant = _ext.Plant(np.ascontiguousarray(expm(F * self.period)), K, C, s0,
                                 np.ascontiguousarray(op.final_velocity, dtype=np.float64), n, int(dev.delay),
                                 float(self.period), float(dev.position_resolution), float(self.max_force))
        self._open = False
        self.native = True
        """The C core's servo thread can drive it (:meth:`drive_native`)."""

    @property
    def state(self) -> np.ndarray:
        """The simulated device's state (SI), shape (5 d,) or (7 d,): [p, v, u, g, r] of
        :func:`haptex.simulate`'s augmented dynamics (u the force acting, g the hand's pull),
        then the handle side [p_h, v_h] of a structural mode."""
        return np.array(self._plant.state)

    def open(self) -> None:
        """Start with the handle at rest at height ``start`` above the origin, no force in flight."""
        self._plant.reset(self.start)
        self._last = None
        self._t0 = self._clock()
        self._open = True

    def close(self) -> None:
        """Zero force (nothing is in flight afterwards)."""
        if self._open:
            self._plant.release()
        self._open = False

    def sample(self) -> Sample:
        """The handle's state at this tick, read through the preset's encoder.

        Returns
        -------
        Sample
            Position (m, on the encoder's lattice) and velocity (m/s), each shape (d,).
        """
        if not self._open:
            raise fail("device", self.name, "opened before it is sampled")
        t = self._plant.k * self.period
        if self.realtime:
            wait_until(self._t0 + t, self._clock, self._sleep, SPIN)
        p = np.array(self._plant.read())
        v = None if self._last is None else (p - self._last) / self.period
        self._last = p
        return Sample(t, p, v, 0)

    def command(self, force) -> None:
        """Hold ``force`` (N) over the next period (after the preset's delay) and advance; a
        force above the device's maximum is scaled to it, as real amplifiers clip.

        Parameters
        ----------
        force : array_like, shape (3,)
            The force (N), in haptex's frame [x, y, z].

        Raises
        ------
        ParameterError
            If ``force`` is not ``dimension`` finite numbers (N): zero is sent first. Above the device's
            ``max_force`` it is scaled to it along itself.
        """
        if not self._open:
            raise fail("device", self.name, "opened before it is commanded")
        f, refused = _force_to_send(force, self.dimension, self.max_force)
        try:
            self._plant.write(f)
        except ValueError:
            raise fail("device", self.name, "a finite state") from None
        if refused is not None:
            raise refused

    def drive_native(self, servo, core, n_ticks: int, on_tick=None, priority: int = PRIORITY,
                     keep_awake: bool = False) -> None:
        """Run ``n_ticks`` ticks in the C core's servo thread: the device, the servo rules of
        ``servo`` (a ``haptex.core._ext.Servo``) and the tick of ``core`` (a
        :class:`haptex.Renderer`'s core) in C, with no GIL, once a period on the clock (or as
        fast as it goes when not real-time). The thread sends zero force at its end; this
        thread waits (:func:`haptex.backends.wait_native`).

        Parameters
        ----------
        servo : haptex.core._ext.Servo
            The rules, their counts and the trace (:class:`haptex.servo.ServoLoop` makes it).
        core : haptex.core._ext.Renderer
            The renderer's C core (``Renderer._core``), of the device's dimension.
        n_ticks : int
            Ticks to run.
        on_tick : callable, optional
            The dashboard, ``on_tick(k, servo)`` about every 50 ms.
        priority : int, optional
            The SCHED_FIFO priority to ask for (0: a plain thread), default
            :data:`haptex.backends.PRIORITY`; not asked when not real-time.
        keep_awake : bool, optional
            Pin the thread to one core and keep that core from halting with a companion
            thread spinning below it (:class:`haptex.servo.ServoLoop`'s ``keep_awake``);
            default False.

        Raises
        ------
        KeyboardInterrupt
            On Ctrl-C, once the thread has sent zero force.
        """
        if not self._open:
            raise fail("device", self.name, "opened before it is driven")
        servo.start(core, self._plant, int(n_ticks), self.realtime, int(priority) if self.realtime else 0,
                    self.realtime, SPIN, bool(keep_awake))
        wait_native(servo, self.name, on_tick)
