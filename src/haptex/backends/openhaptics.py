"""3D Systems devices (Touch, Phantom Premium) through OpenHaptics' HD API and its Python binding
``pyOpenHaptics`` (``pip install haptex[openhaptics]``), which loads ``libHD.so``.

The SDK's concurrency model is a callback in its servo thread: HD's scheduler calls an
asynchronous callback once a tick (1 kHz), between ``hdBeginFrame`` and ``hdEndFrame``.
:meth:`OpenHapticsBackend.drive_native` schedules the C core's own callback
(``hd_servo_callback`` in ``haptex/core/_ext.c``): it reads the position, runs the servo rules
and the renderer's tick and sets the force in C, with no Python and no GIL in HD's thread;
it is handed HD's functions by address from the binding's loaded library.
:meth:`OpenHapticsBackend.drive` is the Python callback, for a renderer that is not a
:class:`haptex.Renderer` (it takes the GIL each tick). Both are measured in ``benchmarks/``.
Outside them, ``sample`` and ``command`` run one synchronous callback each.

Frames and units: HD reports millimetres with x to the right, y up and z towards the user;
haptex's frame has z up (the wall's outward normal), so p_haptex = (x, -z, y)_HD / 1000 (m),
right-handed, and a force (N) maps the same way.

The binding's ``enable_force`` and error check print to stdout; this backend silences them
(a ``--json`` summary stays clean) and reads the error code with the binding's
``_get_error``.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import threading
import time

import numpy as np

from . import DeviceError, Sample, _force_to_send, model_as, wait_native

MODELS = (("premium 1.5", "premium-1-5"), ("touch", "touch"), ("omni", "touch"))
"""Substrings of HD's model string (``HD_DEVICE_MODEL_TYPE``, lower case) and the preset each
is modelled by, the first that matches: the Phantom Omni by the Touch, its successor (chosen).
A model not listed needs its preset named: ``openhaptics:PRESET``."""

HD_INVALID_HANDLE = 0xFFFFFFFF
"""hdInitDevice's answer when no device is there (OpenHaptics' hdDefines.h)."""
HD_CURRENT_VELOCITY = 0x2051
"""hdGetDoublev's code for the handle's velocity (mm/s; hdDefines.h)."""
HD_MAX_SCHEDULER_PRIORITY = 0xFFFF
"""The servo callbacks' priority (hdDefines.h: the highest)."""
NATIVE_FUNCTIONS = ("hdBeginFrame", "hdEndFrame", "hdGetDoublev", "hdSetDoublev")
"""The HD functions the native callback calls, by address, in this order."""


def _hd():
    """The binding's ``hd`` and ``hd_callback`` modules, or one line saying what is missing."""
    try:
        from pyOpenHaptics import hd, hd_callback
    except ModuleNotFoundError as exc:
        if exc.name is not None and not exc.name.startswith("pyOpenHaptics"):
            raise
        raise DeviceError("device = 'openhaptics' is not available: the OpenHaptics binding is not installed "
                          "(pip install 'haptex[openhaptics]')") from None
    except OSError:  # the binding is there but its CDLL("libHD.so") failed
        raise DeviceError("device = 'openhaptics' is not available: libHD.so was not found; install OpenHaptics "
                          "and the Touch device driver (3D Systems) and add their lib folder to "
                          "LD_LIBRARY_PATH") from None
    for mod, name in ((hd, "init_device"), (hd, "begin_frame"), (hd, "end_frame"), (hd, "get_transform"),
                      (hd, "set_force"), (hd, "get_buttons"), (hd, "start_scheduler"), (hd, "stop_scheduler"),
                      (hd, "close_device"), (hd, "get_model"), (hd, "enable_force"), (hd, "_get_error"),
                      (hd, "_get_doublev"), (hd_callback, "hdAsyncSheduler"), (hd_callback, "hdSyncSheduler")):
        if not hasattr(mod, name):
            raise DeviceError(f"device = 'openhaptics' is not available: pyOpenHaptics has no {name} (a version "
                              "this backend does not know; pip install 'haptex[openhaptics]')")
    return hd, hd_callback


def _quiet(fn, *args):
    """``fn(*args)`` with the binding's prints to stdout dropped."""
    with contextlib.redirect_stdout(io.StringIO()):
        return fn(*args)


class OpenHapticsBackend:
    """An OpenHaptics device, driven from HD's scheduler callback.

    Constructing it initialises the device once to read its model (hence its preset:
    period, maximum force, resolution, kinematics) and releases it; :meth:`open`
    initialises it for the run, forces enabled, and starts the scheduler.

    Parameters
    ----------
    preset : str, optional
        The preset of :func:`haptex.catalogue.presets` to model the device by; default the
        one its model string names (:data:`MODELS`).
    device_name : str, optional
        The device's name in the OpenHaptics configuration (Touch Setup), default
        ``"Default Device"``.

    Raises
    ------
    DeviceError
        If the binding or libHD is missing, no device answers, or its model has no preset
        and none is named.
    ParameterError
        For an unknown preset.
    """

    def __init__(self, preset: str = "", device_name: str = "Default Device"):
        self._hd, self._cb = _hd()
        self.device_name = str(device_name)
        h = self._init()
        try:
            model = str(self._hd.get_model())
        finally:
            self._hd.close_device(h)
        key = preset or next((k for sub, k in MODELS if sub in model.lower()), None)
        if key is None:
            raise DeviceError(f"device = 'openhaptics' is a {model!r}, which has no preset: name one, e.g. "
                              "'openhaptics:touch' (see 'haptex devices')")
        model_as(self, "openhaptics", key)
        self.model = model
        self.realtime = True
        self._h = None
        self._running = False
        self._t0 = 0.0
        self._last = np.zeros(3)
        self._keep = []  # the ctypes callbacks in HD's hands: alive until close
        lib = getattr(self._hd, "_lib_hd", None)  # (the binding's CDLL: the native driver's functions)
        self._native = None if lib is None or not all(hasattr(lib, n) for n in NATIVE_FUNCTIONS) else lib
        self.native = self._native is not None

    def _init(self) -> int:
        h = _quiet(self._hd.init_device, self.device_name)
        err = self._hd._get_error().errorCode
        if h is None or h == HD_INVALID_HANDLE or err:
            raise DeviceError(f"device = 'openhaptics' is not reachable: hdInitDevice({self.device_name!r}) failed "
                              f"(HD error 0x{err:x}); check the device's connection, Touch Setup and permissions")
        return int(h)

    # -- inside a frame (HD's servo thread) --
    def _read(self) -> Sample:
        m = self._hd.get_transform()
        p = np.array([m[3][0], -m[3][2], m[3][1]]) * 1e-3
        try:
            u = self._hd._get_doublev(HD_CURRENT_VELOCITY, ctypes.c_double * 3)
            v = np.array([u[0], -u[2], u[1]]) * 1e-3
        except Exception:  # noqa: BLE001 -- a device without a velocity estimate: position only
            v = None
        return Sample(time.perf_counter() - self._t0, p, v, int(self._hd.get_buttons()))

    def _write(self, force) -> None:
        f = np.asarray(force, dtype=np.float64).reshape(3)
        self._hd.set_force([float(f[0]), float(f[2]), float(-f[1])])

    def open(self) -> None:
        """Initialise the device, forces enabled and zero, and start HD's scheduler."""
        self._h = self._init()
        _quiet(self._hd.enable_force)
        self._hd.start_scheduler()
        err = self._hd._get_error().errorCode
        if err:
            self.close()
            raise DeviceError(f"device = {self.name!r}: HD's scheduler did not start (HD error 0x{err:x})")
        self._running = True
        self._t0 = time.perf_counter()
        self.command(np.zeros(3))

    def close(self) -> None:
        """Stop the scheduler (HD stops the motors' output with it) and release the device;
        safe to call twice."""
        if self._h is None:
            return
        h, self._h = self._h, None
        try:
            if self._running:
                self._running = False
                self._hd.stop_scheduler()
        finally:
            self._hd.close_device(h)
            self._keep.clear()

    def _callback(self, body, after=None):
        """An HD callback running ``body()`` in a frame: ``body`` returns (force, done); the
        force is sent, the frame ended, and on done ``after()`` is called and the callback
        ends. An exception in ``body`` sends zero and ends it. Returns (callback, failures)."""
        hd = self._hd
        failures: list = []

        @ctypes.CFUNCTYPE(ctypes.c_uint, ctypes.POINTER(ctypes.c_void_p))
        def cb(_data):
            hd.begin_frame(self._h)
            try:
                f, done = body()
            except BaseException as exc:  # noqa: BLE001 -- zero force this frame, then stop
                f, done = np.zeros(3), True
                failures.append(exc)
            self._write(f)
            hd.end_frame(self._h)
            if done and after is not None:
                after()
            return 0 if done else 1  # HD_CALLBACK_DONE / HD_CALLBACK_CONTINUE

        self._keep.append(cb)
        return cb, failures

    def _sync(self, body):
        if self._h is None or not self._running:
            raise DeviceError(f"device = {self.name!r} is not open: open it first")
        cb, failed = self._callback(body)
        self._cb.hdSyncSheduler(cb)
        if failed:
            raise DeviceError(f"device = {self.name!r}: a synchronous call failed ({failed[0]!r})")

    def sample(self) -> Sample:
        """The handle now, read in one synchronous callback (the force held unchanged).

        Returns
        -------
        Sample
            Position (m) and velocity (m/s), each shape (3,), and the buttons.
        """
        out = []

        def body():
            out.append(self._read())
            return self._last, True

        self._sync(body)
        return out[0]

    def command(self, force) -> None:
        """Send a force (N), shape (3,), in one synchronous callback; nothing when closed
        (HD's output stops with its scheduler).

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
        f, refused = _force_to_send(force, 3, self.max_force)
        self._last = f
        if self._h is not None and self._running:
            self._sync(lambda: (f, True))
        if refused is not None:
            raise refused

    def drive(self, tick, n_ticks: int) -> None:
        """Run ``n_ticks`` ticks in HD's scheduler, each ``tick(sample) -> force`` inside the
        callback's frame; the callback after the last (or after Ctrl-C, or after an exception in
        ``tick``) sends zero force and ends. Waits for it here.

        Parameters
        ----------
        tick : callable
            ``tick(sample) -> force``: the sample (:class:`haptex.backends.Sample`) in, the force
            (N), shape (3,), out.
        n_ticks : int
            Ticks to run.

        Raises
        ------
        KeyboardInterrupt
            On Ctrl-C, once the zero force is sent (within one tick, or one second at most).
        """
        done = threading.Event()
        state = {"k": 0, "stop": False}
        zero = np.zeros(3)

        def body():
            if state["stop"] or state["k"] >= n_ticks:
                return zero, True
            f = tick(self._read())  # (an exception: zero force, the callback ends, raised below)
            state["k"] += 1
            return f, False

        cb, failures = self._callback(body, after=done.set)
        self._cb.hdAsyncSheduler(cb)
        try:
            while not done.wait(0.05):
                pass
        except KeyboardInterrupt:
            state["stop"] = True
            done.wait(1.0)
            raise
        self._last = zero
        if failures:
            raise failures[0]

    def drive_native(self, servo, core, n_ticks: int, on_tick=None, priority: int = 0) -> None:
        """Run ``n_ticks`` ticks of the C core's callback in HD's scheduler: the sample, the
        servo rules of ``servo`` (a ``haptex.core._ext.Servo``) and the tick of ``core`` (a
        :class:`haptex.Renderer`'s core) in C, with no GIL. The callback after the last (or
        after :meth:`stop <haptex.core._ext.Servo.stop>`) sends zero force and ends. This
        thread waits, calling ``on_tick(k, servo)`` every 50 ms (:func:`haptex.backends.wait_native`).
        ``priority`` is not used: HD's scheduler sets its own thread's.

        Parameters
        ----------
        servo : haptex.core._ext.Servo
            The servo rules' state (``haptex.servo``).
        core : object
            A :class:`haptex.Renderer`'s core.
        n_ticks : int
            Ticks to run.
        on_tick : callable, optional
            ``on_tick(k, servo)``, called from Python every 50 ms while the ticks run (the
            dashboard; :func:`haptex.backends.wait_native`).
        priority : int, optional
            Unused by HD's scheduler, which sets its own (the other backends' argument).

        Raises
        ------
        KeyboardInterrupt
            On Ctrl-C, once the callback has sent zero force (within a tick; one second at most).
        DeviceError
            If the device is not open, or HD's scheduler stops calling for
            :data:`haptex.backends.STALLED` s.
        """
        if self._h is None or not self._running:
            raise DeviceError(f"device = {self.name!r} is not open: open it first")
        lib = self._native
        fns = [ctypes.cast(getattr(lib, n), ctypes.c_void_p).value for n in NATIVE_FUNCTIONS]
        cb, data = servo.hd_callback(core, *fns, self._h, int(n_ticks), self._t0)
        self._keep.append(servo)  # (HD holds its address until close)
        lib.hdScheduleAsynchronous(ctypes.c_void_p(cb), ctypes.c_void_p(data),
                                   ctypes.c_ushort(HD_MAX_SCHEDULER_PRIORITY))
        wait_native(servo, self.name, on_tick, thread=False)
        self._last = np.zeros(3)
