"""Devices haptex drives: one small protocol, :class:`DeviceBackend`, and the backends.

A backend is opened, then sampled and commanded once per tick: :meth:`DeviceBackend.sample`
returns the handle's state (time s, position m, velocity m/s where the device gives one,
buttons), :meth:`DeviceBackend.command` sends the force (N) that acts until the next
command. The three concurrency models of the vendors' SDKs map onto it: user polling
(Force Dimension's DHD: ``sample`` reads, ``command`` writes), lock-step request/response
(Haply's Inverse Service: ``command`` sends the force and the reply is the next ``sample``)
and a vendor callback in the servo thread (OpenHaptics' scheduler: the callback runs one
``sample``/``command`` pair). The safety rules live above the backend, in
:class:`haptex.servo.ServoLoop`.

Backends in this version:

- ``simulated:PRESET`` (:class:`~haptex.backends.simulated.SimulatedBackend`): any preset of
  :mod:`haptex.catalogue` run by the exact sampled-data model with a hand;
- ``forcedimension[:PRESET]`` (:class:`~haptex.backends.forcedimension.ForceDimensionBackend`):
  Force Dimension's SDK through its binding ``forcedimension-core``, polled;
- ``openhaptics[:PRESET]`` (:class:`~haptex.backends.openhaptics.OpenHapticsBackend`): 3D
  Systems' HD API through ``pyOpenHaptics``, driven from HD's scheduler callback;
- ``haply[:ws://HOST:PORT]`` (:class:`~haptex.backends.haply.HaplyBackend`): an Inverse3 through
  the Inverse Service's WebSocket JSON, lock-step;
- ``haply-serial[:PORT]`` (:class:`~haptex.backends.haply_serial.HaplySerialBackend`): an
  Inverse3 on its USB serial port through Haply's hardware API, ``HaplyHardwareAPI``, lock-step.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from .._validation import ParameterError


class DeviceError(ParameterError):
    """A device, its SDK or its service cannot be used: one line naming what is missing and
    how to get it (the CLI prints it and exits with status 2, as for a bad parameter)."""


VENDOR_WORKSPACE = 1.0
"""m: a vendor device's reading farther than this from its origin is a sensor fault (chosen:
beyond any desktop device's reach; the presets' published workspaces are boxes, not radii)."""


def _force_to_send(force, dimension: int, max_force: float):
    """(what a backend's ``command`` sends for ``force``, the refusal it raises after sending it
    or None): the force (N) as floats of shape (dimension,), scaled along itself to
    ``max_force`` (N) where its magnitude is above it (as the devices' amplifiers clip; the servo
    loop clamps before it sends); zero where it is not ``dimension`` finite numbers, with the
    refusal naming it, so that a device never gets NaN nor keeps an earlier force past a refused
    one (the guide's rule for a force sent towards a device)."""
    try:
        f = np.asarray(force, dtype=np.float64)
    except (TypeError, ValueError):
        f = None
    if f is None or f.shape != (dimension,) or not np.all(np.isfinite(f)):
        shown = f.tolist() if f is not None and f.size <= 6 else force
        return np.zeros(dimension), ParameterError(
            f"force = {shown!r} is not allowed: must be {dimension} finite newtons (zero was sent instead; the servo "
            "loop never sends anything else)")
    norm = float(np.linalg.norm(f))
    if norm > max_force:
        f = f * (max_force / norm)
    return f, None


def model_as(backend, kind: str, key: str, period: float | None = None) -> None:
    """Model a vendor's 3-DOF device by a preset: set ``backend``'s preset, device (at the
    preset's period, or ``period`` s where the vendor's service sets its own), name
    (``KIND:PRESET``), dimension, period, max_force and workspace.

    Parameters
    ----------
    backend : DeviceBackend
        The backend whose model is set (its attributes are written).
    kind : str
        The backend's kind, the part of the name before the colon (``forcedimension``, ...).
    key : str
        A 3-DOF preset of ``haptex devices``.
    period : float, optional
        The servo period (s) where the vendor's service sets its own; default the preset's.

    Raises
    ------
    ParameterError
        For an unknown preset.
    DeviceError
        For a preset that is not 3-DOF.
    """
    from ..catalogue import preset

    p = preset(key)
    if p.dimension != 3:
        raise DeviceError(f"device = '{kind}:{key}' is not allowed: a {kind} device is 3-DOF, {p.key!r} is not")
    dev = p.device() if period is None else p.device().replace(period=period)
    backend.preset, backend.device, backend.name = p, dev, f"{kind}:{p.key}"
    backend.dimension, backend.period, backend.max_force = 3, dev.period, dev.max_force
    backend.workspace = VENDOR_WORKSPACE


PROBE_EXCHANGES = 20
"""Zero-force exchanges a lock-step backend makes when it is made, to measure the rate of the
device or service that paces it."""


def probed_period(stamps, spec: str) -> float:
    """The median interval (s) between a lock-step probe's answers, received at ``stamps`` (s).

    Parameters
    ----------
    stamps : array_like, shape (n,)
        The times (s, a monotonic clock) the probe's answers were received, n >= 2.
    spec : str
        The device's name, for the error.

    Returns
    -------
    float
        The median interval (s).

    Raises
    ------
    DeviceError
        If it is not 0.01 to 100 ms (``spec`` names the device).
    """
    period = float(np.median(np.diff(stamps)))
    if not 1e-5 <= period <= 0.1:
        raise DeviceError(f"device = {spec!r} answers every {period * 1e3:.3g} ms: a servo loop needs 0.01 to "
                          "100 ms")
    return period


def wait_until(due: float, clock, sleep, spin: float) -> None:
    """Return at ``clock() >= due`` (s): sleep until ``spin`` seconds before, then spin on the
    clock (a sleep alone overshoots by ~0.1 ms on this machine).

    Parameters
    ----------
    due : float
        The time to return at (s, on ``clock``).
    clock : callable
        A monotonic clock, ``clock() -> float`` (s).
    sleep : callable
        ``sleep(seconds)``, which may wake late.
    spin : float
        Seconds before ``due`` at which the sleep ends and the spin on the clock begins.
    """
    wait = due - clock()
    if wait > spin:
        sleep(wait - spin)
    while clock() < due:
        pass


PRIORITY = 80
"""The SCHED_FIFO priority the native servo thread asks for (chosen: above the kernel's
interrupt threads at 50, below the watchdogs at 99, as robot-control loops run; Linux
grants it with CAP_SYS_NICE or an rtprio limit in /etc/security/limits.conf, else the thread
runs at normal priority and ``haptex run`` says so in one line)."""
STALLED = 1.0
"""s: a native run whose tick count has not moved for this long is stopped as a fault."""


def wait_native(servo, name: str, on_tick=None, thread: bool = True) -> None:
    """Wait here while a native driver (the C servo thread, or a vendor's servo thread calling
    the C callback) runs ``servo`` (a ``haptex.core._ext.Servo``), calling ``on_tick(k,
    servo)`` about every 50 ms (a live dashboard: it reads counts, never blocks a tick).

    Parameters
    ----------
    servo : haptex.core._ext.Servo
        The servo whose native driver was started.
    name : str
        The device's name, for the messages.
    on_tick : callable, optional
        ``on_tick(k, servo)``: ``k`` the last tick commanded; ``servo.snapshot()`` gives that
        tick's (k, t, position, force), read through the thread's seqlock.
    thread : bool, optional
        The driver is the C core's servo thread (True: joined at its end, its device errors
        raised), not a vendor's thread calling the C callback.

    Raises
    ------
    KeyboardInterrupt
        On Ctrl-C, once the driver has sent zero force (within a tick; one second at most).
    DeviceError
        If the ticks stop for :data:`STALLED` s, or the device failed a read or a write
        (zero force sent, the thread ended).
    """
    seen, since, nap = -1, time.monotonic(), 1e-3
    try:
        while not servo.done:
            time.sleep(nap)
            nap = min(0.05, 2 * nap)  # (a short run that is not paced ends in milliseconds)
            if on_tick is not None:
                on_tick(servo.ticks - 1, servo)
            if servo.ticks != seen:
                seen, since = servo.ticks, time.monotonic()
            elif not servo.done and time.monotonic() - since > STALLED:
                servo.stop()
                raise DeviceError(f"device = {name!r}: the servo loop stopped ticking after {seen} ticks (the device "
                                  "or its driver stopped answering); zero force was requested")
    except KeyboardInterrupt:
        servo.stop()
        end = time.monotonic() + 1.0
        while not servo.done and time.monotonic() < end:
            time.sleep(0.001)
        raise
    finally:
        if thread and servo.done:
            servo.join()
    if thread:
        err = servo.timing()
        if err["io_error"]:
            which = "a position read" if err["io_error"] == 1 else "a force command"
            raise DeviceError(f"device = {name!r} stopped answering: {which} failed at tick {err['io_error_tick']}; "
                              "zero force was sent and the servo thread ended")


@dataclass(frozen=True)
class Sample:
    """One reading of the handle.

    Parameters
    ----------
    time : float
        Seconds since :meth:`DeviceBackend.open` (the backend's clock).
    position : ndarray, shape (d,)
        [x, z] or [x, y, z] (m), the device's Cartesian frame (z the wall's outward normal).
    velocity : ndarray, shape (d,), or None
        m/s, where the device reports one.
    buttons : int
        A bit per button pressed.
    """

    time: float
    position: np.ndarray
    velocity: np.ndarray | None = None
    buttons: int = 0


@runtime_checkable
class DeviceBackend(Protocol):
    """What haptex needs of a device.

    Parameters
    ----------
    *args, **kwargs
        None: a protocol, not a class to make; a backend is made by
        :func:`haptex.backends.open_backend`.

    Attributes
    ----------
    name : str
    dimension : int
        2 or 3 translational degrees of freedom.
    period : float
        The nominal servo period (s).
    max_force : float
        The largest force magnitude the device takes (N).
    workspace : float
        Radius of its workspace around the origin (m): a position farther is a fault.
    """

    name: str
    dimension: int
    period: float
    max_force: float
    workspace: float

    def open(self) -> None:
        """Connect, with zero force."""

    def close(self) -> None:
        """Zero force, then disconnect; safe to call twice."""

    def sample(self) -> Sample:
        """The handle's state now."""

    def command(self, force) -> None:
        """Send a force (N), shape (d,): it acts until the next command; above the backend's
        ``max_force`` it is scaled to it along itself (as the amplifiers clip).

        Parameters
        ----------
        force : array_like, shape (d,)
            The force (N), d the backend's dimension (2: [x, z], 3: [x, y, z]).

        Raises
        ------
        ParameterError
            If ``force`` is not d finite numbers: zero is sent first, so that the device never
            gets NaN nor keeps an earlier force past a refused one.
        """

    # A backend whose SDK calls back in its own servo thread also has
    # ``drive(tick, n_ticks)``: it runs ``n_ticks`` ticks, each calling ``tick(sample)`` inside
    # the callback and sending the force it returns, then returns with zero force sent
    # (KeyboardInterrupt included). :class:`haptex.servo.ServoLoop` uses it when present.
    # A backend with ``native = True`` also has ``drive_native(servo, core, n_ticks, on_tick,
    # priority)``: the C core runs the ticks (its own servo thread, or the vendor's) with no
    # Python and no GIL, and this thread waits (:func:`wait_native`).


def open_backend(spec: str, **options) -> DeviceBackend:
    """The backend a ``--device`` spec names, not yet opened.

    Parameters
    ----------
    spec : str
        ``simulated:PRESET`` (a preset of :func:`haptex.catalogue.presets`, e.g.
        ``simulated:falcon``); ``forcedimension[:PRESET]`` and ``openhaptics[:PRESET]`` (the
        first device the vendor's SDK finds, modelled by the preset its type or model names,
        or by PRESET); ``haply[:ws://HOST:PORT]`` (the Inverse Service, default
        ws://127.0.0.1:10001).
    **options
        Passed to the backend: :class:`~haptex.backends.simulated.SimulatedBackend`'s
        parameters; ``realtime`` for Force Dimension; ``device_name`` for OpenHaptics;
        ``preset`` and ``timeout`` for both Haply backends.

    Returns
    -------
    DeviceBackend
        The backend, closed: its ``open`` starts the exchange.

    Raises
    ------
    ParameterError
        For an unknown kind or preset, or an option the backend does not take.
    DeviceError
        If a vendor's package or SDK is missing or no device answers (one line saying
        what to install or check).
    """
    kind, _, address = str(spec).partition(":")
    if kind == "simulated":
        from .simulated import SimulatedBackend

        return SimulatedBackend(address or "point-mass", **options)
    if kind == "forcedimension":
        from .forcedimension import ForceDimensionBackend

        _only(spec, options, {"realtime"})
        return ForceDimensionBackend(address, **options)
    if kind == "openhaptics":
        from .openhaptics import OpenHapticsBackend

        _only(spec, options, {"device_name"})
        return OpenHapticsBackend(address, **options)
    if kind == "haply":
        from .haply import HaplyBackend

        _only(spec, options, {"preset", "timeout"})
        return HaplyBackend(address, **options)
    if kind == "haply-serial":
        from .haply_serial import HaplySerialBackend

        _only(spec, options, {"preset", "timeout"})
        return HaplySerialBackend(address, **options)
    raise ParameterError(f"device = {spec!r} is not allowed: must be 'simulated:PRESET' (a preset of 'haptex "
                         "devices', e.g. 'simulated:falcon'), 'forcedimension[:PRESET]', 'openhaptics[:PRESET]', "
                         "'haply[:ws://HOST:PORT]' or 'haply-serial[:PORT]'")


def _only(spec: str, options: dict, allowed: set) -> None:
    """Refuse options a backend does not take, by name."""
    extra = sorted(set(options) - allowed)
    if extra:
        raise ParameterError(f"{extra[0]} = {options[extra[0]]!r} is not allowed with device = {spec!r}: it "
                             f"takes {', '.join(sorted(allowed)) or 'no options'}")
