"""Input validation shared by every public entry point.

Every error raised for bad input is a :class:`ParameterError` (a ``ValueError``) whose
message names the parameter, the value received and what is allowed, so that the CLI
can print it as one line.
"""

from __future__ import annotations

import math

import numpy as np


class ParameterError(ValueError):
    """A parameter has a value that is not allowed.

    The message always names the parameter, the value received and the allowed range,
    e.g. ``"stiffness = -1.0 is not allowed: must be a finite number > 0 (N/m)"``.
    """


def _fmt(value) -> str:
    if isinstance(value, float | np.floating):
        return f"{float(value):g}"
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def fail(name: str, value, allowed: str) -> ParameterError:
    """Build the standard error for parameter ``name``."""
    return ParameterError(f"{name} = {_fmt(value)} is not allowed: must be {allowed}")


def positive(name: str, value, unit: str = "") -> float:
    """Return ``value`` as float if it is finite and > 0, else raise ParameterError."""
    v = _scalar(name, value, f"a finite number > 0{_u(unit)}")
    if not v > 0:
        raise fail(name, value, f"a finite number > 0{_u(unit)}")
    return v


def nonnegative(name: str, value, unit: str = "") -> float:
    """Return ``value`` as float if it is finite and >= 0, else raise ParameterError."""
    v = _scalar(name, value, f"a finite number >= 0{_u(unit)}")
    if not v >= 0:
        raise fail(name, value, f"a finite number >= 0{_u(unit)}")
    return v


def finite(name: str, value, unit: str = "") -> float:
    """Return ``value`` as float if it is finite, else raise ParameterError."""
    return _scalar(name, value, f"a finite number{_u(unit)}")


def in_range(name: str, value, lo: float, hi: float, unit: str = "") -> float:
    """Return ``value`` as float if lo <= value <= hi, else raise ParameterError."""
    allowed = f"a finite number in [{lo:g}, {hi:g}]{_u(unit)}"
    v = _scalar(name, value, allowed)
    if not lo <= v <= hi:
        raise fail(name, value, allowed)
    return v


def optional_positive(name: str, value, unit: str = "") -> float | None:
    """``None`` passes through; anything else must be finite and > 0."""
    return None if value is None else positive(name, value, unit)


def matrix2(name: str, value, what: str = "2x2 matrix") -> np.ndarray:
    """A 2x2 float64 matrix from a scalar (times the identity: isotropic) or a 2x2 array.

    Raises
    ------
    ParameterError
        If the value is neither, or holds a non-finite entry.
    """
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise fail(name, value, f"a scalar or a {what}") from None
    if arr.ndim == 0:
        arr = float(arr) * np.eye(2)
    if arr.shape != (2, 2) or not np.all(np.isfinite(arr)):
        raise fail(name, value, f"a finite scalar or a finite {what}")
    return arr


def positions(p, name: str = "p") -> np.ndarray:
    """Return probe positions as a float64 array of shape (..., 2).

    Raises
    ------
    ParameterError
        If the last axis is not of length 2 or a coordinate is not finite.
    """
    try:
        arr = np.asarray(p, dtype=np.float64)
    except (TypeError, ValueError):
        raise fail(name, p, "an array of shape (..., 2) of finite positions [x, z] in metres") from None
    if arr.ndim == 0 or arr.shape[-1] != 2:
        raise ParameterError(
            f"{name} has shape {arr.shape}, which is not allowed: must be (..., 2) = [x, z] in metres"
        )
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr).all(axis=-1)][0]
        raise ParameterError(
            f"{name} contains the non-finite position {bad.tolist()}, which is not allowed: "
            "every coordinate must be a finite number of metres"
        )
    return arr


def _scalar(name: str, value, allowed: str) -> float:
    if isinstance(value, bool):
        raise fail(name, value, allowed)
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise fail(name, value, allowed) from None
    if not math.isfinite(v):
        raise fail(name, value, allowed)
    return v


def _u(unit: str) -> str:
    return f" ({unit})" if unit else ""
