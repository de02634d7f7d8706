"""Haply's Inverse3 through the Inverse Service's WebSocket JSON (``pip install haptex[haply]``,
which brings the ``websockets`` client).

The concurrency model is lock-step request/response: the service sends the devices' state,
the client answers with its commands, and the next state follows. :meth:`HaplyBackend.sample`
waits for a state message and :meth:`HaplyBackend.command` answers it; the service paces the
loop.

The messages (as the Inverse Service sends and takes them; Isaac Lab's Haply device speaks the
same): a state message holds ``{"inverse3": [{"device_id": ID, "state": {"cursor_position":
{"x", "y", "z"}, "cursor_velocity": {...}}}], "wireless_verse_grip": [{"state": {"buttons":
{"a", "b", "c"}}}]}`` in metres and m/s; a command is ``{"inverse3": [{"device_id": ID,
"commands": {"set_cursor_force": {"values": {"x", "y", "z"}}}}]}`` in newtons. Positions and
forces pass unchanged (chosen: the service's frame is taken as haptex's, z up; check the sign
of z on the device before touching a wall, see README).

A message that is not JSON, or whose cursor position is missing or not finite, gives a sample
at NaN: the servo loop answers it with zero force (a fault), as any faulty reading.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np

from .._validation import fail
from . import PROBE_EXCHANGES, DeviceError, Sample, _force_to_send, model_as, probed_period

DEFAULT_ADDRESS = "ws://127.0.0.1:10001"
"""The Inverse Service's default WebSocket address."""
MAX_MESSAGE = 1 << 20
"""Bytes: the largest message taken from the service (a state message is a few hundred)."""
TIMEOUT = 1.0
"""s: the longest wait for the service's answer before the device counts as gone."""
BUTTONS = ("a", "b", "c")
"""The VerseGrip's buttons, bits 0, 1, 2 of :attr:`Sample.buttons`."""


def _client():
    try:
        from websockets.sync.client import connect
    except ModuleNotFoundError as exc:
        if exc.name is not None and not exc.name.startswith("websockets"):
            raise
        raise DeviceError("device = 'haply' is not available: the WebSocket client is not installed "
                          "(pip install 'haptex[haply]')") from None
    return connect


def _vector(d) -> np.ndarray:
    """[x, y, z] of a {"x", "y", "z"} object; NaN where it is not one."""
    try:
        v = np.array([float(d[k]) for k in ("x", "y", "z")])
    except (TypeError, KeyError, ValueError):
        return np.full(3, np.nan)
    return v


class HaplyBackend:
    """An Inverse3 through the Inverse Service, lock-step.

    Constructing it connects once to find the Inverse3 (its ``device_id``) and to measure the
    service's rate (the median interval of :data:`~haptex.backends.PROBE_EXCHANGES` zero-force
    exchanges: the backend's ``period``, and the modelled device's), then disconnects;
    :meth:`open` connects for the run.

    Parameters
    ----------
    address : str, optional
        The service's WebSocket URL, ``ws://HOST:PORT`` (default :data:`DEFAULT_ADDRESS`).
    preset : str, optional
        The preset of :func:`haptex.catalogue.presets` to model the device by (default
        ``inverse3``, whose every figure is chosen: see ``haptex devices show inverse3``).
    timeout : float, optional
        s, the longest wait for the service (default :data:`TIMEOUT`).

    Raises
    ------
    DeviceError
        If the client is not installed, no service answers at the address, it reports no
        Inverse3, or it answers slower than every 0.1 s.
    ParameterError
        For an address that is not a ws:// or wss:// URL, or an unknown preset.
    """

    def __init__(self, address: str = "", preset: str = "inverse3", timeout: float = TIMEOUT):
        self._connect = _client()
        self.address = address or DEFAULT_ADDRESS
        if not self.address.startswith(("ws://", "wss://")):
            raise fail("device", f"haply:{self.address}", "'haply[:ws://HOST:PORT]', the Inverse Service's address")
        if isinstance(timeout, bool) or not (isinstance(timeout, (int, float)) and 0 < timeout <= 60):
            raise fail("timeout", timeout, "a number of seconds in (0, 60]")
        self.timeout = float(timeout)
        model_as(self, "haply", preset)  # (a wrong preset refused before the probe)
        # the probe: the Inverse3's device_id, and the service's rate over a few zero-force
        # exchanges (it paces the loop: the watchdog's period is the one measured here)
        ws = self._dial()
        stamps = []
        try:
            first = self._receive(ws)
            stamps.append(time.perf_counter())
            found = first.get("inverse3") if isinstance(first, dict) else None
            if not isinstance(found, list) or not found or not isinstance(found[0], dict) or \
                    "device_id" not in found[0]:
                raise DeviceError(f"device = 'haply:{self.address}' reports no Inverse3: is it connected and on?")
            self.device_id = found[0]["device_id"]
            for _ in range(PROBE_EXCHANGES):
                self._send(ws, np.zeros(3))
                self._receive(ws)
                stamps.append(time.perf_counter())
        finally:
            ws.close()
        model_as(self, "haply", preset, probed_period(stamps, f"haply:{self.address}"))
        self.realtime = True
        self._ws = None

    def _dial(self):
        """A connection to the service (entered as the client's context manager: the form every
        websockets version since 13 takes without a warning); closed by ``.close()``."""
        try:
            return self._connect(self.address, open_timeout=self.timeout, max_size=MAX_MESSAGE,
                                 compression=None).__enter__()
        except (OSError, TimeoutError) as exc:
            raise DeviceError(f"device = 'haply:{self.address}' is not reachable: no Inverse Service answered "
                              f"({exc.__class__.__name__}); start Haply Hub or the Inverse Service") from None
        except Exception as exc:  # noqa: BLE001 -- the handshake failed: not a WebSocket service
            raise DeviceError(f"device = 'haply:{self.address}' is not reachable: {exc.__class__.__name__} in the "
                              "WebSocket handshake; is this the Inverse Service's address?") from None

    def _receive(self, ws):
        """The next message, parsed (None when it is not JSON)."""
        try:
            raw = ws.recv(timeout=self.timeout)
        except TimeoutError:
            raise DeviceError(f"device = {getattr(self, 'name', 'haply')!r} stopped answering: no message in "
                              f"{self.timeout:g} s") from None
        except Exception as exc:  # noqa: BLE001 -- the connection closed or broke
            raise DeviceError(f"device = {getattr(self, 'name', 'haply')!r} went away: "
                              f"{exc.__class__.__name__}") from None
        try:
            return json.loads(raw)
        except (ValueError, TypeError, RecursionError):
            return None

    def open(self) -> None:
        """Connect for the run; the first state message is the first sample."""
        self._ws = self._dial()
        self._t0 = time.perf_counter()

    def close(self) -> None:
        """Zero force, confirmed, then disconnect; safe to call twice. The zero is confirmed by
        the service's next state message (lock-step: it comes once the command is applied);
        without it, the service could still hold the last force when the connection drops."""
        if self._ws is None:
            return
        ws, self._ws = self._ws, None
        try:
            ws.send(self._message(np.zeros(3)))
            self._receive(ws)
        except Exception:  # noqa: BLE001 -- already gone: nothing to zero, or no confirmation in time
            pass
        finally:
            ws.close()

    def sample(self) -> Sample:
        """The Inverse3's state in the service's next message: position (m), velocity (m/s)
        when sent, the VerseGrip's buttons when one is there.

        Returns
        -------
        Sample
            Position (m) and velocity (m/s), each shape (3,), and the buttons.
        """
        if self._ws is None:
            raise DeviceError(f"device = {self.name!r} is not open: open it before sampling")
        msg = self._receive(self._ws)
        t = time.perf_counter() - self._t0
        p = v = np.full(3, np.nan)
        buttons = 0
        if isinstance(msg, dict):
            mine = [d for d in (msg.get("inverse3") or []) if isinstance(d, dict) and
                    d.get("device_id") == self.device_id]
            state = mine[0].get("state") if mine else None
            if isinstance(state, dict):
                p = _vector(state.get("cursor_position"))
                v = _vector(state.get("cursor_velocity"))
            grips = msg.get("wireless_verse_grip") or []
            grip = grips[0].get("state") if grips and isinstance(grips[0], dict) else None
            if isinstance(grip, dict) and isinstance(grip.get("buttons"), dict):
                buttons = sum(1 << i for i, k in enumerate(BUTTONS) if grip["buttons"].get(k) is True)
        return Sample(t, p, v if np.all(np.isfinite(v)) else None, buttons)

    def _message(self, f) -> str:
        x, y, z = (float(c) for c in f)
        if not all(math.isfinite(c) for c in (x, y, z)):  # (the servo loop never sends one)
            x = y = z = 0.0
        return json.dumps({"inverse3": [{"device_id": self.device_id,
                                         "commands": {"set_cursor_force": {"values": {"x": x, "y": y, "z": z}}}}]})

    def _send(self, ws, force) -> None:
        try:
            ws.send(self._message(force))
        except Exception as exc:  # noqa: BLE001 -- the connection closed or broke
            raise DeviceError(f"device = {getattr(self, 'name', 'haply')!r} went away: "
                              f"{exc.__class__.__name__}") from None

    def command(self, force) -> None:
        """Answer the last state with a force (N), shape (3,).

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
        if self._ws is None:
            return  # (closed: the service holds no force of ours)
        f, refused = _force_to_send(force, 3, self.max_force)
        self._send(self._ws, f)
        if refused is not None:
            raise refused
