"""Input validation shared by every public entry point.

Every error raised for bad input is a :class:`ParameterError` (a ``ValueError``) whose
message names the parameter, the value received and what is allowed, so that the CLI
can print it as one line.
"""

from __future__ import annotations

import contextlib
import itertools
import math
import os
import re
import reprlib

import numpy as np


MAX_LENGTH = 1e3
"""Largest length (m) haptex accepts for a texture's heights and abscissae, a period or an
analysed depth: a kilometre is far beyond any haptic workspace, and at 1e3 m a double
still resolves 1e-13 m."""


class ParameterError(ValueError):
    """A parameter has a value that is not allowed.

    The message always names the parameter, the value received and the allowed range,
    e.g. ``"stiffness = -1.0 is not allowed: must be a finite number > 0 (N/m)"``.
    """


def _fmt(value) -> str:
    if isinstance(value, float | np.floating):
        return f"{float(value):g}"
    # a list or tuple by its first items (a long one's whole repr cost seconds); numpy's repr
    # of an array is summarised already, and breaks its rows, which are joined on one line
    text = _SHORT.repr(value) if isinstance(value, list | tuple) else repr(value)
    text = re.sub(r"\n\s*", " ", text)
    return text if len(text) <= 60 else text[:57] + "..."


_SHORT = reprlib.Repr()  # (its keyword arguments are Python 3.12's)
_SHORT.maxlevel, _SHORT.maxlist, _SHORT.maxtuple, _SHORT.maxstring, _SHORT.maxother = 4, 8, 8, 60, 60


def fail(name: str, value, allowed: str) -> ParameterError:
    """Build the standard error for parameter ``name``."""
    return ParameterError(f"{name} = {_fmt(value)} is not allowed: must be {allowed}")


def not_an_algorithm(value, proxy: bool = False) -> ParameterError:
    """The refusal of ``value`` where an algorithm is taken (with ``proxy``, or a god-object):
    what was given, and the call that makes an algorithm of a texture (its force field, and every
    analysis of the paper, is an algorithm's: Table I). One text for
    :func:`haptex.algorithms.checked_algorithm` and the core's :func:`haptex.core.field`, which
    sits below the algorithms."""
    return fail("algorithm", value, "a haptex algorithm" + (" or a haptex.proxy.GodObject" if proxy else "")
                + " (a texture has a force field only once an algorithm renders it: haptex.algorithm('A', texture, "
                "2000.0), its letter one of W, A-G, its stiffness in N/m)")


def not_a_texture(value, name: str = "texture") -> ParameterError:
    """The refusal of ``value`` where a texture is taken: what makes one (a class of
    :mod:`haptex.textures` or :mod:`haptex.surfaces` in SI units, or a measured file read by
    :func:`haptex.load_texture`). One text for :func:`haptex.textures.checked_texture` and
    :mod:`haptex.probe`, which sits below the textures."""
    return fail(name, value, "a haptex Texture (a profile or a surface in metres, e.g. haptex.Sinusoid(0.8e-3, 1e-3); "
                             "haptex.load_texture(PATH) for a measured file)")


def a_path(name: str, value, what: str = "a file's path"):
    """``value`` as a :class:`pathlib.Path`, refused naming ``name`` unless it is a str or an
    os.PathLike (PEP 519's contract for a path; pathlib's own TypeError named no parameter).
    ``what`` says what the path is of, e.g. "a topography file's path"."""
    from pathlib import Path

    if not isinstance(value, str | os.PathLike):
        raise fail(name, value, f"{what} (a str or pathlib.Path)")
    return Path(os.fspath(value))


def out_file(name: str, path):
    """``path`` as a :class:`pathlib.Path` to write, refused (naming ``name``) unless its folder
    exists."""
    out = a_path(name, path)
    if not out.parent.is_dir():
        raise fail(name, str(out), "a file in an existing folder")
    return out


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


def positive_or_inf(name: str, value, unit: str = "") -> float:
    """Return ``value`` as float if it is a real number > 0 or +inf (no limit), else raise."""
    allowed = f"a number > 0{_u(unit)}, or inf for no limit"
    v = _real(name, value, allowed)
    if not v > 0:  # also NaN
        raise fail(name, value, allowed)
    return v


def whole(name: str, value, lo: int = 0, hi: int | None = None, what: str = "") -> int:
    """Return ``value`` as int if it is a whole number in [lo, hi] (an int, a numpy integer or a
    float with no fraction such as 2.0; not 2.5, a bool or text such as '2'), else raise
    ParameterError."""
    allowed = f"a whole number >= {lo}" + ("" if hi is None else f" and <= {hi}") + (f" ({what})" if what else "")
    if isinstance(value, bool | np.bool_ | str | bytes):
        raise fail(name, value, allowed)
    if isinstance(value, int | np.integer):  # exact, however large
        v = int(value)
        if not (v >= lo and (hi is None or v <= hi)):
            raise fail(name, value, allowed)
        return v
    try:
        f = float(value)
        ok = f.is_integer() and f >= lo and (hi is None or f <= hi)
    except (TypeError, ValueError, OverflowError):
        raise fail(name, value, allowed) from None
    if not ok:
        raise fail(name, value, allowed)
    return int(f)


def flag(name: str, value) -> bool:
    """``value`` as a bool, refused naming ``name`` unless it is one (a string such as 'no', a
    number or NaN would be taken for True or False by Python's truth test)."""
    if isinstance(value, bool | np.bool_):
        return bool(value)
    raise fail(name, value, "True or False")


def random_seed(name: str, value) -> int:
    """``value`` as a seed of numpy's default_rng: a whole number from 0 to 2^64 - 1, refused
    naming ``name`` otherwise (booleans too)."""
    return whole(name, value, 0, 2**64 - 1, "numpy's default_rng seed")


def scale_factors(length_factor, height_factor, longest: float, highest: float) -> tuple[float, float]:
    """(length factor, height factor) of a sampled texture's ``scaled``: the first > 0, the
    second finite, each at most :data:`MAX_LENGTH` over the texture's largest |position|
    ``longest`` or |height| ``highest`` (m), where its samples must lie; refused naming the
    factor otherwise (not the scaled samples, which the user never gave)."""
    lf = positive("length_factor", length_factor)
    if longest > 0 and lf * longest > MAX_LENGTH:
        raise fail("length_factor", length_factor, f"> 0 and at most {MAX_LENGTH / longest:.6g} (the texture's "
                   f"positions, up to {longest:g} m, within +-{MAX_LENGTH:g} m)")
    hf = _scalar("height_factor", height_factor, "a finite number")
    if highest > 0 and abs(hf) * highest > MAX_LENGTH:
        raise fail("height_factor", height_factor, f"a number of size at most {MAX_LENGTH / highest:.6g} (the "
                   f"texture's heights, up to {highest:g} m, within +-{MAX_LENGTH:g} m)")
    return lf, hf


@contextlib.contextmanager
def renamed(outer: str, *inner: str, note: str = ""):
    """A refusal of a value the caller handed on under another name, said under the name its user
    gave it by: a ParameterError inside whose message begins ``INNER = `` (one of ``inner``) is
    raised again as ``OUTER = ...`` (``note``, with ``{inner}`` for the name replaced, appended):
    e.g. a preset's ``pose``, a device constructor's ``working_point``."""
    try:
        yield
    except ParameterError as e:
        said = str(e)
        for name in inner:
            if said.startswith(f"{name} = "):
                raise ParameterError(f"{outer}{said[len(name):]}{note.format(inner=name)}") from None
        raise


def optional_positive(name: str, value, unit: str = "") -> float | None:
    """``None`` passes through; anything else must be finite and > 0."""
    return None if value is None else positive(name, value, unit)


def numbers(name: str, value, allowed: str, copy: bool = True) -> np.ndarray:
    """``value`` as a float64 array of its shape, refused naming ``name`` (``allowed`` saying
    what is) where it is not real numbers: text, None, a complex number (numpy's astype keeps
    its real part), or a bool anywhere in it, Python's or numpy's (numpy takes True for 1 once
    it sits among numbers, where every scalar of haptex refuses a bool, :func:`_real`).
    Finiteness and ranges are the caller's. With ``copy=False`` a float64 array given is
    returned itself (for positions read and not kept).

    Raises
    ------
    ParameterError
        If ``value`` is not numbers, as above.
    """
    try:
        raw = np.asarray(value)
    except (TypeError, ValueError):  # (ragged nesting)
        raise fail(name, value, allowed) from None
    kind = raw.dtype.kind
    if kind in "bcUSV" or ((kind == "O" or not isinstance(value, np.ndarray))  # (an array's dtype says the rest)
                           and _holds_a_non_number(value if kind != "O" else raw.ravel().tolist())):
        raise fail(name, value, allowed)  # (before numpy's cast, which would warn of what it drops)
    try:
        return raw.astype(np.float64, copy=copy)
    except (TypeError, ValueError):  # (an object that is not a number)
        raise fail(name, value, allowed) from None


def _holds_a_non_number(value) -> bool:
    """Whether a bool, None, text or a complex number sits in ``value``'s nested lists and
    tuples or an object array's elements (an array's own dtype tells the rest: numpy keeps no
    trace of a bool it converted, casts None to NaN, and parses an object array's text). Read a
    level at a time by the types present (a list of 1,000 rows: about 0.1 ms, what numpy's own
    conversion of it costs again)."""
    level = [value]
    while level:
        kinds = set(map(type, level))
        if any(issubclass(k, _NON_NUMBERS) for k in kinds):
            return True
        nested = sum(issubclass(k, _SEQUENCE_TYPES) for k in kinds)
        if not nested:
            return False
        level = list(itertools.chain.from_iterable(
            level if nested == len(kinds) else (v for v in level if isinstance(v, _SEQUENCE_TYPES))))
    return False


_NON_NUMBERS = (bool, np.bool_, type(None), str, bytes, complex, np.complexfloating)
_SEQUENCE_TYPES = (list, tuple)


def matrix2(name: str, value, what: str = "2x2 matrix", dim: int = 2) -> np.ndarray:
    """A dim x dim float64 matrix (2x2 by default) from a scalar (times the identity:
    isotropic) or a dim x dim array.

    Raises
    ------
    ParameterError
        If the value is neither (a bool is neither, nor a matrix holding one: :func:`numbers`),
        or holds a non-finite entry.
    """
    arr = numbers(name, value, f"a scalar or a {what}")
    if arr.ndim == 0:
        arr = float(arr) * np.eye(dim)
    if arr.shape != (dim, dim) or not np.all(np.isfinite(arr)):
        raise fail(name, arr.tolist(), f"a finite scalar or a finite {what}")  # a list: one line
    return arr


def positions(p, name: str = "p", dim: int = 2) -> np.ndarray:
    """Return probe positions as a float64 array of shape (..., dim).

    ``dim`` is 2 ([x, z], over a profile h(x)) or 3 ([x, y, z], over a surface h(x, y)).

    Raises
    ------
    ParameterError
        If the last axis is not of length ``dim`` (a profile given 3-D positions, or a
        surface given 2-D ones), or a coordinate is not a finite real number (a bool, text or
        a complex number is not one: :func:`numbers`).
    """
    what = "[x, z]" if dim == 2 else "[x, y, z]"
    arr = numbers(name, p, f"an array of shape (..., {dim}) of finite positions {what} in metres", copy=False)
    if arr.ndim == 0 or arr.shape[-1] != dim:
        over = "a profile h(x)" if dim == 2 else "a surface h(x, y)"
        raise ParameterError(
            f"{name} has shape {arr.shape}, which is not allowed: must be (..., {dim}) = {what} in metres "
            f"over {over}"
        )
    if not np.all(np.isfinite(arr)):
        bad = arr[~np.isfinite(arr).all(axis=-1)][0]
        raise ParameterError(
            f"{name} contains the non-finite position {bad.tolist()}, which is not allowed: "
            "every coordinate must be a finite number of metres"
        )
    return arr


def _real(name: str, value, allowed: str) -> float:
    """``value`` as a float (booleans, Python's or numpy's, and non-numbers refused; inf and
    NaN pass)."""
    if isinstance(value, bool | np.bool_):
        raise fail(name, value, allowed)
    try:
        return float(value)
    except (TypeError, ValueError):
        raise fail(name, value, allowed) from None


def _scalar(name: str, value, allowed: str) -> float:
    v = _real(name, value, allowed)
    if not math.isfinite(v):
        raise fail(name, value, allowed)
    return v


def _u(unit: str) -> str:
    return f" ({unit})" if unit else ""


def memory_budget() -> int:
    """Bytes one haptex call may allocate: ``HAPTEX_MEMORY_BUDGET`` (bytes) if set, else a
    quarter of the machine's physical memory (6 GiB on a 24 GiB machine)."""
    env = os.environ.get("HAPTEX_MEMORY_BUDGET")
    if env:
        text = env.strip()
        try:
            value = float(text) if len(text) <= 30 else math.nan
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and 2**16 <= value <= 2**60):
            raise ParameterError(f"HAPTEX_MEMORY_BUDGET = {text[:30]!r} is not allowed: must be a number of bytes "
                                 "in [2^16, 2^60], e.g. 4e9")
        return int(value)
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 4
    except (ValueError, OSError, AttributeError):  # pragma: no cover - non-POSIX
        return 4 * 1024**3


def check_budget(name: str, value, need_bytes: float, what: str) -> None:
    """Refuse, in one line naming ``name`` and its value, a computation whose estimated
    allocation ``need_bytes`` exceeds :func:`memory_budget`."""
    budget = memory_budget()
    if not need_bytes <= budget:
        raise ParameterError(
            f"{name} = {_fmt(value)} is not allowed: {what} would need {need_bytes / 2**30:.3g} GiB, over the "
            f"memory budget of {budget / 2**30:.3g} GiB (set HAPTEX_MEMORY_BUDGET to change it)")


def check_count(name: str, value, count: float, limit: float, what: str) -> None:
    """Refuse an absurd amount of work: ``count`` items of ``what`` above ``limit``."""
    if not count <= limit:
        raise ParameterError(f"{name} = {_fmt(value)} is not allowed: it asks for {count:.3g} {what}, more than "
                             f"{limit:.3g}")
