"""Force Dimension devices (omega, delta, sigma, lambda; the Novint Falcon where the SDK drives it)
through the vendor's Python binding, ``forcedimension-core`` (``pip install haptex[forcedimension]``),
which loads the Force Dimension SDK's ``libdrd`` (found through ``FDSDK``).

The SDK's concurrency model is user polling. :meth:`ForceDimensionBackend.drive_native` hands
``dhdGetPosition`` and ``dhdSetForce`` (their addresses in the library the binding loaded) to the
C core's native servo thread, which polls the device once a period with no Python and no GIL
(``hx_thread.c``). Outside it, :meth:`ForceDimensionBackend.sample` reads the handle
(``dhdGetPosition``, ``dhdGetLinearVelocity``, ``dhdGetButtonMask``) and
:meth:`ForceDimensionBackend.command` writes the force (``dhdSetForce``), paced on the clock by
this backend, as :class:`~haptex.backends.simulated.SimulatedBackend` does.

Frames and units: DHD's are SI (m, m/s, N) with x towards the user, y to the right and z up
(the SDK's user manual), right-handed; haptex's frame is the same (z the wall's outward
normal, up), so positions and forces pass unchanged.
"""

from __future__ import annotations

import ctypes
import sys
import time

import numpy as np

from . import PRIORITY, DeviceError, Sample, _force_to_send, model_as, wait_native, wait_until
from .simulated import SPIN

NATIVE_FUNCTIONS = ("dhdGetPosition", "dhdSetForce")
"""The DHD functions the native servo thread calls, by address: ``int dhdGetPosition(double *px,
double *py, double *pz, char ID)`` and ``int dhdSetForce(double fx, double fy, double fz, char
ID)`` (the SDK's dhdc.h)."""

DEVICE_TYPES = {33: "omega-3", 34: "omega-3", 35: "omega-3", 36: "omega-3", 37: "omega-3", 63: "delta-3",
                104: "sigma-7", 105: "sigma-7", 206: "sigma-7", 60: "falcon"}
"""DHD system types (``forcedimension_core.constants.DeviceType``) and the preset of
:mod:`haptex.catalogue` each is modelled by: the omega.6 and omega.7 by the omega.3 (the same
translational base), the sigma.3 by the sigma.7 (chosen; their translation stages differ in
detail). A type not listed needs its preset named: ``forcedimension:PRESET``."""


def _dhd():
    """The binding's ``dhd`` module, or one line saying what is missing and how to get it (what
    the binding writes to stderr as it loads libdrd, "Could not find libdrd. Is it installed?",
    held and quoted in that line: the command line's refusal is one line)."""
    import contextlib
    import io

    said = io.StringIO()
    try:
        with contextlib.redirect_stderr(said):
            import forcedimension_core  # noqa: F401 -- its import loads libdrd
            from forcedimension_core import dhd
    except ModuleNotFoundError as exc:
        if exc.name is not None and not exc.name.startswith("forcedimension_core"):
            raise
        raise DeviceError("device = 'forcedimension' is not available: the Force Dimension binding is not installed "
                          "(pip install 'haptex[forcedimension]')") from None
    except ImportError:  # the binding is there but found no libdrd
        words = " ".join(said.getvalue().split())[:200]
        raise DeviceError("device = 'forcedimension' is not available: the binding found no Force Dimension SDK "
                          f"(libdrd 3.16 or later{'; it said: ' + words if words else ''}); install the SDK and set "
                          "FDSDK to its folder") from None
    if said.getvalue().strip():  # (loaded, with a word on stderr: passed on as written)
        sys.stderr.write(said.getvalue())
    for name in ("open", "close", "getSystemType", "enableForce", "getPosition", "getLinearVelocity",
                 "getButtonMask", "setForce", "errorGetLastStr"):
        if not hasattr(dhd, name):
            raise DeviceError(f"device = 'forcedimension' is not available: forcedimension_core has no dhd.{name} "
                              "(a version this backend does not know; pip install 'haptex[forcedimension]')")
    return dhd


class ForceDimensionBackend:
    """A Force Dimension device, polled.

    Constructing it connects once to identify the device (its DHD system type, hence its
    preset: period, maximum force, resolution, model) and disconnects; :meth:`open`
    connects for the run with forces enabled and zero.

    Parameters
    ----------
    preset : str, optional
        The preset of :func:`haptex.catalogue.presets` to model the device by; default the
        one of its system type (:data:`DEVICE_TYPES`).
    realtime : bool, optional
        Pace the ticks at the preset's period (default); False runs as fast as the loop goes.
    clock, sleep : callable, optional
        Time source (s) and sleep function.

    Raises
    ------
    DeviceError
        If the binding or the SDK is missing, no device answers, or its type has no preset
        and none is named.
    ParameterError
        For an unknown preset.
    """

    def __init__(self, preset: str = "", realtime: bool = True, clock=time.perf_counter, sleep=time.sleep):
        self._dhd = dhd = _dhd()
        ident = dhd.open()
        if ident < 0:
            raise DeviceError(f"device = 'forcedimension' is not reachable: no Force Dimension device answered "
                              f"({dhd.errorGetLastStr()}); check its USB cable, power and permissions (udev rule)")
        try:
            kind = int(dhd.getSystemType(ident))
        finally:
            dhd.close(ident)
        key = preset or DEVICE_TYPES.get(kind)
        if key is None:
            raise DeviceError(f"device = 'forcedimension' has DHD system type {kind}, which has no preset: name one, "
                              "e.g. 'forcedimension:omega-3' (see 'haptex devices')")
        model_as(self, "forcedimension", key)
        self.system_type = kind
        self.realtime = bool(realtime)
        self._clock, self._sleep = clock, sleep
        self._id = None
        self._p, self._v = np.zeros(3), np.zeros(3)
        try:
            from forcedimension_core import runtime

            lib = runtime._libdhd
            self._native = [ctypes.cast(getattr(lib, n), ctypes.c_void_p).value for n in NATIVE_FUNCTIONS]
        except (ImportError, AttributeError):  # a binding that does not expose its library: the Python loop
            self._native = None
        self.native = self._native is not None
        """The C core's servo thread can drive it (:meth:`drive_native`)."""

    def open(self) -> None:
        """Connect, forces enabled and zero."""
        dhd = self._dhd
        ident = dhd.open()
        if ident < 0:
            raise DeviceError(f"device = {self.name!r} is not reachable: {dhd.errorGetLastStr()}")
        self._id = ident
        if dhd.setForce([0.0, 0.0, 0.0], ident) < 0 or dhd.enableForce(True, ident) < 0:
            err = dhd.errorGetLastStr()
            self.close()
            raise DeviceError(f"device = {self.name!r} refused its forces: {err}")
        self._k = 0
        self._t0 = self._clock()

    def close(self) -> None:
        """Zero force, forces disabled, disconnected; safe to call twice."""
        if self._id is None:
            return
        dhd, ident = self._dhd, self._id
        self._id = None
        try:
            dhd.setForce([0.0, 0.0, 0.0], ident)
            dhd.enableForce(False, ident)
        finally:
            dhd.close(ident)

    def sample(self) -> Sample:
        """The handle now (at this tick's time when real-time): position (m), velocity (m/s)
        as the SDK estimates it, buttons.

        Returns
        -------
        Sample
            Position (m) and velocity (m/s), each shape (3,), and the buttons.
        """
        if self._id is None:
            raise DeviceError(f"device = {self.name!r} is not open: open it before sampling")
        t = self._k * self.period
        if self.realtime:
            wait_until(self._t0 + t, self._clock, self._sleep, SPIN)
        dhd = self._dhd
        if dhd.getPosition(self._p, self._id) < 0 or dhd.getLinearVelocity(self._v, self._id) < 0:
            raise DeviceError(f"device = {self.name!r} stopped answering: {dhd.errorGetLastStr()}")
        return Sample(t, self._p.copy(), self._v.copy(), int(dhd.getButtonMask(self._id)))

    def command(self, force) -> None:
        """Send a force (N), shape (3,), held until the next command.

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
        if self._id is None:
            return  # (closed: nothing is energised)
        f, refused = _force_to_send(force, 3, self.max_force)
        if self._dhd.setForce([float(f[0]), float(f[1]), float(f[2])], self._id) < 0:
            raise DeviceError(f"device = {self.name!r} refused a force: {self._dhd.errorGetLastStr()}")
        self._k += 1
        if refused is not None:
            raise refused

    def drive_native(self, servo, core, n_ticks: int, on_tick=None, priority: int = PRIORITY,
                     keep_awake: bool = False) -> None:
        """Run ``n_ticks`` ticks in the C core's servo thread: ``dhdGetPosition``, the servo rules
        of ``servo`` (a ``haptex.core._ext.Servo``), the tick of ``core`` (a
        :class:`haptex.Renderer`'s core) and ``dhdSetForce``, in C with no GIL, once a period
        on the clock (as fast as it goes when not real-time). The thread sends zero force at
        its end; this thread waits (:func:`haptex.backends.wait_native`).

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
        DeviceError
            If the device is not open, or a DHD call fails during the run (zero force sent).
        """
        if self._id is None:
            raise DeviceError(f"device = {self.name!r} is not open: open it first")
        get_position, set_force = self._native
        servo.start(core, ("dhd", get_position, set_force, int(self._id)), int(n_ticks), self.realtime,
                    int(priority) if self.realtime else 0, self.realtime, SPIN, bool(keep_awake))
        wait_native(servo, self.name, on_tick)
