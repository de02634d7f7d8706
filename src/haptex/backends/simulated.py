"""A device preset run by the exact sampled-data model, one tick at a time: the backend that
works on any machine (``haptex run --device simulated:falcon``)."""

from __future__ import annotations

import time

import numpy as np

from .._validation import fail, finite, nonnegative
from . import Sample, wait_until

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
        pace). False runs as fast as the loop goes (tests, batch use).
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

        self._op = h.operator(depth=self.press, velocity=self.speed, dimension=n)
        mode = dev.mode_matrices() if dev.structural_mode else None
        F = _augmented(dev.mass, dev.damping, self._op.stiffness, self._op.damping, mode)
        self._Phi = expm(F * self.period)
        self._open = False

    def open(self) -> None:
        """Start with the handle at rest at height ``start`` above the origin, no force in flight."""
        n = self.dimension
        self._x = np.zeros(self._Phi.shape[0])
        self._x[n - 1] = self.start
        if self._x.size > 5 * n:  # the handle side of a structural mode starts there too
            self._x[6 * n - 1] = self.start
        self._k = 0
        self._queue = [np.zeros(n) for _ in range(self.device.delay)]
        self._last = None
        self._t0 = self._clock()
        self._open = True

    def close(self) -> None:
        """Zero force (nothing is in flight afterwards)."""
        if self._open:
            self._queue = [np.zeros(self.dimension) for _ in self._queue]
        self._open = False

    def sample(self) -> Sample:
        """The handle's state at this tick, read through the preset's encoder."""
        if not self._open:
            raise fail("device", self.name, "opened before it is sampled")
        t = self._k * self.period
        if self.realtime:
            wait_until(self._t0 + t, self._clock, self._sleep, SPIN)
        n = self.dimension
        p = self._x[:n].copy()
        d = self.device.position_resolution
        if d > 0:
            p = d * np.round(p / d)
        v = None if self._last is None else (p - self._last) / self.period
        self._last = p
        return Sample(t, p, v, 0)

    def command(self, force) -> None:
        """Hold ``force`` (N) over the next period (after the preset's delay) and advance."""
        if not self._open:
            raise fail("device", self.name, "opened before it is commanded")
        f = np.asarray(force, dtype=np.float64).reshape(self.dimension)
        if not np.all(np.isfinite(f)):
            raise fail("force", f.tolist(), "finite newtons (the servo loop never sends anything else)")
        mag = float(np.linalg.norm(f))
        if mag > self.max_force * (1 + 1e-12):  # the device's own limit, as real amplifiers clip
            f = f * (self.max_force / mag)
        if self._queue:
            self._queue.append(f)
            f = self._queue.pop(0)
        n, op = self.dimension, self._op
        sv = op.final_velocity
        self._x[2 * n:3 * n] = f
        self._x[3 * n:4 * n] = op.stiffness @ op.setpoint(self._k * self.period) + op.damping @ sv
        self._x[4 * n:5 * n] = op.stiffness @ sv
        self._x = self._Phi @ self._x
        self._k += 1
        if not np.all(np.isfinite(self._x)):
            raise fail("device", self.name, "a finite state")
