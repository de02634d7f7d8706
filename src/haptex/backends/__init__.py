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

Backends in this version: ``simulated:PRESET`` (:class:`~haptex.backends.simulated.SimulatedBackend`,
any preset of :mod:`haptex.catalogue` run by the exact sampled-data model with a hand).
The vendors' backends (OpenHaptics, Force Dimension, Haply) are not written yet: naming one
is refused in one line that says so.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from .._validation import ParameterError


@dataclass(frozen=True)
class Sample:
    """One reading of the handle.

    Attributes
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
        """Send a force (N), shape (d,): it acts until the next command."""


VENDOR_BACKENDS = {"openhaptics": "openhaptics", "forcedimension": "forcedimension", "haply": "haply"}
"""Vendors' backends and the pip extra each will need (not written yet)."""


def open_backend(spec: str, **options) -> DeviceBackend:
    """The backend a ``--device`` spec names, not yet opened.

    Parameters
    ----------
    spec : str
        ``simulated:PRESET`` (a preset of :func:`haptex.catalogue.presets`, e.g.
        ``simulated:falcon``).
    **options
        Passed to the backend (:class:`~haptex.backends.simulated.SimulatedBackend`'s).

    Raises
    ------
    ParameterError
        For an unknown kind or preset, or a vendor's backend (not in this version).
    """
    kind, _, address = str(spec).partition(":")
    if kind == "simulated":
        from .simulated import SimulatedBackend

        return SimulatedBackend(address or "point-mass", **options)
    if kind in VENDOR_BACKENDS:
        raise ParameterError(f"device = {spec!r} is not allowed in this version: the {kind} backend is not written "
                             f"yet (issue 34; it will need 'pip install haptex[{VENDOR_BACKENDS[kind]}]'); use "
                             "'simulated:PRESET', e.g. 'simulated:falcon'")
    raise ParameterError(f"device = {spec!r} is not allowed: must be 'simulated:PRESET' (a preset of 'haptex "
                         "devices', e.g. 'simulated:falcon')")
