"""Parsing of quantities written with units ("0.8mm", "2 kN/m") into SI floats, via pint."""

from __future__ import annotations

import math
import re
import threading
from decimal import Decimal
from functools import lru_cache

from ._validation import ParameterError


_REGISTRY_LOCK = threading.Lock()


@lru_cache(maxsize=1)
def _registry():
    # built once per process (~0.3 s of pure Python): threads that ask for it together (the
    # explorer's sessions) wait for the first instead of each building one
    import pint

    with _REGISTRY_LOCK:
        return _registry_built(pint)


@lru_cache(maxsize=1)
def _registry_built(pint):
    return pint.UnitRegistry()


def parse_quantity(text: str, unit: str, name: str, require_unit: bool = False) -> float:
    """Convert ``text`` (e.g. ``"0.8mm"``, ``"2 kN/m"``, ``"1e-3"``) to a float in ``unit``.

    A bare number is taken to be in ``unit`` already (SI), unless ``require_unit``: then a
    bare number other than zero is refused (the command line's rule: "0.8" for a length is
    far more often a forgotten "mm" than 0.8 m). ``µ`` and ``u`` both mean micro.

    Parameters
    ----------
    text : str
        The quantity as a user wrote it.
    unit : str
        The SI unit the result is expressed in, e.g. ``"m"`` or ``"N/m"``.
    name : str
        Parameter name used in error messages.

    Returns
    -------
    float

    Raises
    ------
    ParameterError
        If the text is not a number with a unit of the right dimension, is not finite, or
        (with ``require_unit``) is a bare nonzero number.
    """
    import pint

    raw = str(text).strip()
    try:
        value = float(raw)
    except ValueError:
        pass
    else:
        if require_unit and value != 0.0:
            raise ParameterError(f"{name} = {raw!r} is not allowed: a number without a unit; write the unit, "
                                 f"e.g. '{raw} {unit}' or '{_example(unit)}'")
        return _finite(value, raw, unit, name)
    number, unit_text = _split(raw, unit, name)
    ureg = _registry()
    try:
        q = ureg.Quantity(number, ureg.parse_units(unit_text)) if unit_text else ureg.Quantity(number)
        value = float(q.to(unit).magnitude)
        # pint multiplies by the prefix's factor (100 * 1e-6 = 9.999999999999999e-05); a
        # decimal quantity means the decimal number: keep 15 significant digits, within
        # 5e-16 relative of pint's result, so that '100 us' is the double 1e-4
        value = float(f"{value:.15g}")
    except pint.DimensionalityError:
        raise ParameterError(
            f"{name} = {raw!r} is not allowed: its unit is not convertible to {unit}"
        ) from None
    except Exception:  # pint raises many kinds of parse errors
        raise ParameterError(
            f"{name} = {raw!r} is not allowed: must be a number with a unit convertible to {unit} "
            f"(e.g. '{_example(unit)}')"
        ) from None
    return _finite(value, raw, unit, name)


MAX_QUANTITY_LENGTH = 80
"""Longest quantity text accepted (characters): a number of up to 17 significant digits with
an exponent, and a compound unit such as 'mN*m*s' or 'N*s/m', fit many times over."""

_NUMBER = r"[+-]?(?:\d{1,40}(?:\.\d{0,40})?|\.\d{1,40})(?:[eE][+-]?\d{1,4})?"
_WORD = r"[A-Za-zµμΩ°_]{1,20}(?:\s*(?:\^|\*\*)\s*[+-]?\d{1,2})?"
_UNIT = rf"\(?\s*{_WORD}(?:\s*[*/·]?\s*\(?\s*{_WORD}\s*\)?)*\s*\)?"
_QUANTITY = re.compile(rf"\s*({_NUMBER})\s*({_UNIT})?\s*")


def _split(raw: str, unit: str, name: str) -> tuple[float, str]:
    """(number, unit text) of a quantity, by a grammar: a decimal number (at most 40 digits
    either side of the point, an exponent of at most 4 digits) and a unit made of unit names
    joined by '*', '/', '·' or spaces, each with an integer power of at most 2 digits. Pint
    sees only the unit names, never an expression: '9**9**9 N/m' (which pint evaluates, for
    minutes) and a megabyte of digits (parsed in quadratic time) are refused at once."""
    allowed = f"a number with a unit convertible to {unit} (e.g. '{_example(unit)}')"
    if len(raw) > MAX_QUANTITY_LENGTH:
        raise ParameterError(f"{name} = {raw[:30]!r}... ({len(raw)} characters) is not allowed: must be {allowed}, "
                             f"at most {MAX_QUANTITY_LENGTH} characters")
    m = _QUANTITY.fullmatch(raw)
    if m is None:
        raise ParameterError(f"{name} = {raw!r} is not allowed: must be {allowed}")
    return float(m.group(1)), (m.group(2) or "").replace("µ", "u").replace("μ", "u").replace("·", "*")


QUANTITY_RANGES = {
    "m": (1e-12, 1e3), "m/s": (1e-9, 1e3), "s": (1e-9, 1e7), "N/m": (1e-6, 1e12), "N*s/m": (1e-9, 1e7),
    "kg": (1e-9, 1e6), "N": (1e-9, 1e6), "kg*m^2": (1e-15, 1e3), "radian": (1e-12, 1e6), "dimensionless": (1e-12, 1e6),
}
"""The magnitudes a parsed quantity may have, by SI unit (0 is always allowed; the
parameter's own check then says whether it may be 0 or negative). Chosen wide: a picometre
(below any instrument's resolution) to a kilometre (the renderer's workspace bound), a
nanosecond to 10^7 s, 1 uN/m to 1 TN/m. Outside them a value parses but overflows or
underflows later (1e308 m or 1e-320 m as a period ended in tracebacks: issue 33), so it is
refused here, naming the parameter."""


def _finite(value: float, raw: str, unit: str, name: str) -> float:
    if value != value or value in (float("inf"), float("-inf")):
        raise ParameterError(f"{name} = {raw!r} is not allowed: must be a finite quantity in {unit}")
    lo, hi = QUANTITY_RANGES.get(unit, (1e-100, 1e100))
    if value != 0.0 and not lo <= abs(value) <= hi:
        raise ParameterError(f"{name} = {raw!r} is not allowed: must be 0 or of magnitude {lo:g} to {hi:g} {unit}")
    return value


def _example(unit: str) -> str:
    return {"m": "0.8mm", "N/m": "2 kN/m", "s": "100us", "N": "1.5 N", "m/s": "0.1 m/s"}.get(unit, f"1 {unit}")


def stated_number(v: float, up: bool, fits, digits: int = 3, exponent: int = 0) -> tuple[float, str]:
    """A bound v > 0 as a refusal or a recommendation states it: in units of 10^exponent, rounded
    up (or down) to ``digits`` significant digits, then moved a last digit at a time further to
    its safe side until ``fits`` holds of the double the text denotes, so that a user who takes it
    as written is not refused again: (that double, the text); (0.0, "0") where it cannot."""
    if not v > 0:
        return 0.0, "0"
    scale = 10.0 ** exponent
    e = 10.0 ** (math.floor(math.log10(v / scale)) - digits + 1)
    k = math.ceil(v / scale / e - 1e-9) if up else math.floor(v / scale / e + 1e-9)
    for _ in range(1000):
        if k <= 0:
            return 0.0, "0"
        text = f"{k * e:.{digits + 3}g}"
        value = float(Decimal(text).scaleb(exponent))  # (the decimal's nearest double, as parse_quantity reads it)
        if fits(value):
            return value, text
        k += 1 if up else -1
    return 0.0, "0"
