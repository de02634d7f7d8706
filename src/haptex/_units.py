"""Parsing of quantities written with units ("0.8mm", "2 kN/m") into SI floats, via pint."""

from __future__ import annotations

from functools import lru_cache

from ._validation import ParameterError


@lru_cache(maxsize=1)
def _registry():
    import pint

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
    ureg = _registry()
    cleaned = raw.replace("µ", "u").replace("μ", "u")
    try:
        q = ureg.Quantity(cleaned)
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


def _finite(value: float, raw: str, unit: str, name: str) -> float:
    if value != value or value in (float("inf"), float("-inf")):
        raise ParameterError(f"{name} = {raw!r} is not allowed: must be a finite quantity in {unit}")
    return value


def _example(unit: str) -> str:
    return {"m": "0.8mm", "N/m": "2 kN/m", "s": "100us", "N": "1.5 N", "m/s": "0.1 m/s"}.get(unit, f"1 {unit}")
