"""Haply's Inverse3 through its serial hardware API: the vendor's package ``HaplyHardwareAPI``
(``pip install 'haptex[haply-serial]'``) over the device's USB serial port, without the
Inverse Service.

The concurrency model is lock-step request/response, paced by the device: each force command
(``Inverse3.end_effector_force``) is answered with the device's state, position (m) and
velocity (m/s). :meth:`HaplySerialBackend.command` sends the force and keeps the answer;
:meth:`HaplySerialBackend.sample` returns it. The device's rate is measured when the backend
is made, as the Inverse Service's is.

The run itself, :meth:`HaplySerialBackend.drive_native`, goes through the C core's native servo
thread (``hx_thread.c``), which speaks the same exchanges on the port itself (``hx_haply.c``):
the package lets go of the port, the C core opens it raw (``hx_haply_open``: a POSIX terminal
by its path, a Windows COM port by name, one function for both), wakes the device, and each
tick's force command and its answer are one exchange in C with no Python and no GIL, paced by
the device's answers. The package stays the backend's way in and out (the wakeup's info, the
probe of the rate, :meth:`~HaplySerialBackend.open` and :meth:`~HaplySerialBackend.close`).

The package, as it behaves over a pseudo-terminal (version 0.1.13, C++ library 0.2.8; Haply
does not publish the wire format, so this is what the package itself sends and accepts,
probed here, not a specification):

- the wakeup (``device_wakeup_dict``) sends the byte 0x0A; the device answers 0x0B, then the
  device id (uint16), model number, hardware and firmware versions (uint8 each) and a 16-byte
  UUID, little-endian;
- a force command sends 0x2A and three float32 (N); the device answers 0x2B and six float32:
  position, then velocity;
- until a wakeup has been answered, the package sends zero whatever force it is given;
- an answer that does not come within the read timeout is **not an error**: the package
  prints a line on stderr and returns zeros (for the wakeup, whatever was in memory), and a
  port that cannot be opened is reported the same way. So this backend checks the port itself
  before handing it to the package, and times every exchange: one that took the whole timeout
  is the device gone (:class:`~haptex.backends.DeviceError`).

Forces travel as float32: each component is rounded towards zero, so the force sent is never
larger than the one asked. Positions and forces pass unchanged between frames (chosen, as for
the Inverse Service: the device's frame is taken as haptex's, z up; check the sign of z on the
device before touching a wall, see README).
"""

from __future__ import annotations

import contextlib
import os
import tempfile
import time

import numpy as np

from .._validation import fail
from . import PRIORITY, PROBE_EXCHANGES, DeviceError, Sample, _force_to_send, model_as, probed_period, wait_native

PACKAGE_VERSION = "0.1.13"
"""The least HaplyHardwareAPI version taken (the first with ``set_read_timeout``)."""
TIMEOUT = 0.1
"""s: the longest wait for a force command's answer before the device counts as gone (chosen:
100 periods of the Inverse3's 1 kHz. The package's exchange over a pseudo-terminal here takes
about 25 µs, but this 2-core VM stalls a thread now and then: at 20 ms one 20-s benchmark run in
three ended on an emulator's stall, and a plain C loop doing nothing once waited 36 ms)."""
WAKEUP_TIMEOUT = 1.0
"""s: the longest wait for the wakeup's answer (chosen: a device just plugged in may be slow)."""
NAMES = ("SerialStream", "Inverse3", "detect_inverse3s")
METHODS = ("set_read_timeout", "device_wakeup_dict", "end_effector_force")


def _package():
    """The vendor's module, or one line saying what is missing and how to get it."""
    try:
        import HaplyHardwareAPI as H
    except ModuleNotFoundError as exc:
        if exc.name is not None and exc.name != "HaplyHardwareAPI":
            raise
        raise DeviceError("device = 'haply-serial' is not available: Haply's hardware API is not installed "
                          "(pip install 'haptex[haply-serial]')") from None
    missing = [n for n in NAMES if not hasattr(H, n)] + \
        [f"Inverse3.{n}" for n in METHODS if hasattr(H, "Inverse3") and not hasattr(H.Inverse3, n)]
    if missing:
        from importlib.metadata import PackageNotFoundError, version

        try:
            have = version("HaplyHardwareAPI")
        except PackageNotFoundError:
            have = "(of no known version)"
        raise DeviceError(f"device = 'haply-serial' is not available: HaplyHardwareAPI {have} has no {missing[0]} "
                          f"(this backend needs "
                          f"{PACKAGE_VERSION} or later; pip install 'haptex[haply-serial]')")
    return H


@contextlib.contextmanager
def _vendor_stderr():
    """Hold what the package's C++ library prints on the process's stderr (its timeouts and
    failed opens): the caller's error says it in one line instead."""
    try:
        fd = os.dup(2)
    except OSError:  # (no stderr to hold)
        yield
        return
    with tempfile.TemporaryFile() as held:
        os.dup2(held.fileno(), 2)
        try:
            yield
        finally:
            os.dup2(fd, 2)
            os.close(fd)


def _check_port(port: str) -> None:
    """Refuse a port the package would fail on silently: missing, not permitted, not a
    terminal (one line each, naming what to check)."""
    if os.name != "posix":
        return
    if not os.path.exists(port):
        raise DeviceError(f"device = 'haply-serial:{port}' is not reachable: no such port; is the Inverse3 plugged "
                          "in? ('haply-serial' alone takes the first Inverse3 the package finds)")
    try:
        fd = os.open(port, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
    except PermissionError:
        raise DeviceError(f"device = 'haply-serial:{port}' is not reachable: permission denied; add your user to "
                          "the 'dialout' group (then log in again)") from None
    except OSError as exc:
        raise DeviceError(f"device = 'haply-serial:{port}' is not reachable: {exc.strerror}") from None
    try:
        if not os.isatty(fd):
            raise DeviceError(f"device = 'haply-serial:{port}' is not allowed: it is not a serial port")
    finally:
        os.close(fd)


def _float32_towards_zero(force) -> list:
    """[x, y, z] as float32 values no larger in magnitude than ``force``'s (N)."""
    f = np.asarray(force, dtype=np.float64).reshape(3)
    if not np.all(np.isfinite(f)):  # (the servo loop never sends one)
        f = np.zeros(3)
    g = f.astype(np.float32)
    over = np.abs(g.astype(np.float64)) > np.abs(f)
    g[over] = np.nextafter(g[over], np.float32(0.0))
    return [float(c) for c in g]


class HaplySerialBackend:
    """An Inverse3 on a serial port through Haply's hardware API, lock-step.

    Constructing it opens the port once: the wakeup (the device's id, model, hardware and
    firmware versions) and :data:`~haptex.backends.PROBE_EXCHANGES` zero-force exchanges,
    whose median interval is the backend's ``period`` and the modelled device's; then it
    closes the port. :meth:`open` opens it for the run.

    Parameters
    ----------
    port : str, optional
        The serial port (e.g. ``/dev/ttyACM0``); default the first Inverse3 the package
        detects.
    preset : str, optional
        The preset of :func:`haptex.catalogue.presets` to model the device by (default
        ``inverse3``, whose every figure is chosen: see ``haptex devices show inverse3``).
    timeout : float, optional
        s, the longest wait for a force command's answer (default :data:`TIMEOUT`).

    Raises
    ------
    DeviceError
        If the package is missing or too old, no Inverse3 is detected, the port is missing,
        not permitted or not a serial port, the device does not answer the wakeup within
        :data:`WAKEUP_TIMEOUT`, or answers force commands slower than every 0.1 s.
    ParameterError
        For a timeout that is not in (0, 1] s, or an unknown preset.
    """

    def __init__(self, port: str = "", preset: str = "inverse3", timeout: float = TIMEOUT):
        self._H = H = _package()
        if isinstance(timeout, bool) or not (isinstance(timeout, (int, float)) and 0 < timeout <= 1):
            raise fail("timeout", timeout, "a number of seconds in (0, 1]")
        self.timeout = float(timeout)
        if not port:
            with _vendor_stderr():
                found = list(H.detect_inverse3s())
            if not found:
                raise DeviceError("device = 'haply-serial' is not reachable: no Inverse3 found on a serial port; is it "
                                  "plugged in and on? Or name its port, 'haply-serial:/dev/ttyACM0'")
            port = str(found[0])
        self.port = port
        model_as(self, "haply-serial", preset)  # (a wrong preset refused before the port is touched)
        _check_port(port)
        with _vendor_stderr():
            self._connect()
            try:
                stamps = [time.perf_counter()]
                for _ in range(PROBE_EXCHANGES):
                    self._exchange([0.0, 0.0, 0.0])
                    stamps.append(time.perf_counter())
            finally:
                self._disconnect()
        model_as(self, "haply-serial", preset, probed_period(stamps, f"haply-serial:{port}"))
        self.realtime = True
        self._last = None
        self.native = True
        """The C core's servo thread can drive it (:meth:`drive_native`): the port opened by the
        core's ``hx_haply_open`` on every host (POSIX terminals; Windows COM ports)."""

    def _connect(self) -> None:
        """Open the port and wake the device up (the package sends forces only after that)."""
        H = self._H
        self._stream = H.SerialStream(self.port)
        self._dev = H.Inverse3(self._stream)
        self._dev.set_read_timeout(WAKEUP_TIMEOUT)
        t = time.perf_counter()
        info = self._dev.device_wakeup_dict()
        if time.perf_counter() - t >= WAKEUP_TIMEOUT:
            self._disconnect()
            raise DeviceError(f"device = 'haply-serial:{self.port}' is not reachable: no Inverse3 answered the "
                              f"wakeup in {WAKEUP_TIMEOUT:g} s; is it on, and is this its port?")
        self.info = {k: (str(v) if k == "device_id_ext" else v) for k, v in dict(info).items()}
        self._dev.set_read_timeout(self.timeout)
        self._t0 = time.perf_counter()

    def _disconnect(self) -> None:
        self._dev = self._stream = None  # (the package closes the port with its last reference)

    def _exchange(self, force) -> None:
        """One force command and its answer, kept as the next sample."""
        t = time.perf_counter()
        try:
            p, v = self._dev.end_effector_force(force)
        except Exception as exc:  # noqa: BLE001 -- the package failed: the device is gone
            raise DeviceError(f"device = {self.name!r} went away: {exc.__class__.__name__}") from None
        now = time.perf_counter()
        if now - t >= self.timeout:
            raise DeviceError(f"device = {self.name!r} stopped answering: no answer in {self.timeout * 1e3:g} ms")
        self._last = Sample(now - self._t0, np.array(p, dtype=np.float64), np.array(v, dtype=np.float64))

    def open(self) -> None:
        """Open the port for the run, wake the device, and read its state with zero force."""
        with _vendor_stderr():
            self._connect()
            try:
                self._exchange([0.0, 0.0, 0.0])
            except DeviceError:
                self._disconnect()
                raise

    def close(self) -> None:
        """Zero force, confirmed by the device's answer, then close the port; safe to call
        twice."""
        if self._dev is None:
            return
        try:
            with _vendor_stderr():
                self._exchange([0.0, 0.0, 0.0])
        except DeviceError:  # already gone: nothing to zero, or no confirmation in time
            pass
        finally:
            self._disconnect()

    def drive_native(self, servo, core, n_ticks: int, on_tick=None, priority: int = PRIORITY,
                     keep_awake: bool = False) -> None:
        """Run ``n_ticks`` ticks in the C core's servo thread, which speaks the Inverse3's serial
        exchanges itself (``hx_haply.c``): the package lets go of the port, the core opens it
        raw (``hx_haply_open``: a POSIX terminal by its path, or a Windows COM port by name), the
        device woken and its state read with zero force, then each tick's force command
        (float32, rounded towards zero) and its answer are one exchange in C with no GIL, paced
        by the device's answers. The thread sends zero force at its end; this thread waits
        (:func:`haptex.backends.wait_native`).

        Parameters
        ----------
        servo : haptex.core._ext.Servo
            The rules, their counts and the trace (:class:`haptex.servo.ServoLoop` makes it).
        core : haptex.core._ext.Renderer
            The renderer's C core (``Renderer._core``), of dimension 3.
        n_ticks : int
            Ticks to run.
        on_tick : callable, optional
            The dashboard, ``on_tick(k, servo)`` about every 50 ms.
        priority : int, optional
            The SCHED_FIFO priority to ask for (0: a plain thread; any other value asks on
            Windows for time-critical priority, on macOS for the time-constraint policy),
            default :data:`haptex.backends.PRIORITY`.
        keep_awake : bool, optional
            Pin the thread to one core and keep that core from halting with a companion
            thread spinning below it (:class:`haptex.servo.ServoLoop`'s ``keep_awake``);
            default False.

        Raises
        ------
        KeyboardInterrupt
            On Ctrl-C, once the thread has sent zero force.
        DeviceError
            If the device is not open, the port cannot be reopened, the device does not answer
            the wakeup or a force command within the timeout, or answers with another message
            (zero force sent, the thread ended; one line naming which).
        """
        from ..core import _ext

        if self._dev is None:
            raise DeviceError(f"device = {self.name!r} is not open: open it first")
        self._disconnect()  # (the package closes the port with its last reference)
        try:
            port = _ext.haply_open(self.port)
        except OSError as exc:
            raise DeviceError(f"device = {self.name!r} went away: {self.port} cannot be reopened "
                              f"({exc.strerror or exc})") from None
        try:
            try:
                _ext.haply_wakeup(port, WAKEUP_TIMEOUT)
                servo.start(core, ("haply", port, self.timeout), int(n_ticks), False, int(priority), True, 0.0,
                            bool(keep_awake))
            except OSError as exc:
                why = exc.args[-1] if exc.args else exc
                raise DeviceError(f"device = {self.name!r} stopped answering: {why}; no force was sent") from None
            try:
                wait_native(servo, self.name, on_tick)
            except DeviceError as exc:
                timing = servo.timing()
                why = timing["device_error"]
                if not why:
                    raise
                if why == "no answer within the timeout":
                    why = f"no answer in {self.timeout * 1e3:g} ms"
                raise DeviceError(f"device = {self.name!r} stopped answering: {why} (at tick "
                                  f"{timing['io_error_tick']}); zero force was sent and the servo thread ended") \
                    from exc
        finally:
            servo.stop()  # (the thread has ended here, but for a Ctrl-C it outlived: never close its port under it)
            servo.join()
            _ext.haply_close(port)

    def sample(self) -> Sample:
        """The Inverse3's state in its last answer: position (m), velocity (m/s).

        Returns
        -------
        Sample
            Position (m) and velocity (m/s), each shape (3,).
        """
        if self._dev is None:
            raise DeviceError(f"device = {self.name!r} is not open: open it before sampling")
        return self._last

    def command(self, force) -> None:
        """Send a force (N), shape (3,), as float32 rounded towards zero; the answer is the next
        sample.

        Parameters
        ----------
        force : array_like, shape (3,)
            The force (N), in haptex's frame [x, y, z].

        Raises
        ------
        ParameterError
            If ``force`` is not 3 finite numbers (N): zero is sent first. Above the device's
            ``max_force`` it is scaled to it along itself.
        """
        if self._dev is None:
            return  # (closed: the device holds no force of ours)
        f, refused = _force_to_send(force, 3, self.max_force)
        self._exchange(_float32_towards_zero(f))
        if refused is not None:
            raise refused
