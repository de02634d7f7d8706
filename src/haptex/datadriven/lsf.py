"""Line spectral frequencies: an AR or MA polynomial to its LSF and back (Soong & Juang 1984)."""

from __future__ import annotations


import numpy as np

from .._validation import fail

MAX_ORDER = 64
"""Largest AR or MA order the C core's tick takes (``HX_VIB_MAX_ORDER``)."""

# ---------------------------------------------------------------------------------------
# line spectral frequencies
# ---------------------------------------------------------------------------------------


def poly_to_lsf(a) -> np.ndarray:
    """Line spectral frequencies of a minimum-phase polynomial.

    Parameters
    ----------
    a : array_like, shape (p + 1,)
        Polynomial ``[1, a_1, ..., a_p]`` in z⁻¹ (the AR or MA part of a model), its roots
        strictly inside the unit circle.

    Returns
    -------
    numpy.ndarray, shape (p,)
        The angles (rad) of the roots of P(z) = A(z) + z^-(p+1) A(1/z) and
        Q(z) = A(z) - z^-(p+1) A(1/z) on the unit circle, ascending in (0, π), their
        trivial roots at z = ±1 left out (Itakura 1975; Soong & Juang, ICASSP 1984).

    Raises
    ------
    ParameterError
        If ``a`` does not start with 1, is not finite, or is not minimum phase (its LSF
        would not interlace, and an interpolation of them would not be stable).

    Notes
    -----
    Our own routine (the roots of P and Q by :func:`numpy.roots`): the one Python package
    with one, ``spectrum``, builds a C extension from source for it. Its inverse,
    :func:`lsf_to_poly`, is the C core's.
    """
    a = np.asarray(a, dtype=float)
    if a.ndim != 1 or a.size < 1 or not np.all(np.isfinite(a)) or a[0] != 1.0:
        raise fail("a", a, "a finite polynomial [1, a_1, ..., a_p] (the leading coefficient 1)")
    p = a.size - 1
    if p == 0:
        return np.empty(0)
    if np.max(np.abs(np.roots(a))) >= 1.0:
        raise fail("a", a, "minimum phase (every root inside the unit circle): a stable AR part or an invertible MA part")
    ext = np.concatenate([a, [0.0]])
    w = []
    for poly in (ext + ext[::-1], ext - ext[::-1]):
        ang = np.angle(np.roots(poly))
        w.append(ang[(ang > 1e-12) & (ang < np.pi - 1e-12)])
    w = np.sort(np.concatenate(w))
    if w.size != p or np.any(np.diff(w) <= 0):
        raise fail("a", a, "a polynomial whose line spectral frequencies are distinct (roots well inside the unit circle)")
    return w


def lsf_to_poly(w) -> np.ndarray:
    """Polynomial of ascending line spectral frequencies (the C core's ``hx_lsf_to_poly``).

    Parameters
    ----------
    w : array_like, shape (p,)
        Line spectral frequencies (rad), strictly ascending in (0, π), p <= :data:`MAX_ORDER`.

    Returns
    -------
    numpy.ndarray, shape (p + 1,)
        ``[1, a_1, ..., a_p]``: minimum phase whenever ``w`` ascends (Soong & Juang 1984).

    Raises
    ------
    ParameterError
        If ``w`` does not ascend strictly within (0, π) or is longer than :data:`MAX_ORDER`.
    """
    from ..core import _ext

    w = np.ascontiguousarray(w, dtype=float)
    if w.ndim != 1 or w.size > MAX_ORDER or not np.all((w > 0) & (w < np.pi)) or np.any(np.diff(w) <= 0):
        raise fail("w", w, f"at most {MAX_ORDER} frequencies ascending strictly in (0, pi) rad")
    a = np.empty(w.size + 1)
    _ext.lsf_to_poly(w, a)
    return a


