"""haptex's C core: the real-time code the library runs and exports.

The C99 sources beside this file (``hx_core.h``, ``hx_texture.c``, ``hx_forces.c``) are
compiled at install into :mod:`haptex.core._ext`. This module is the thin Python side: it
takes an :class:`haptex.Algorithm` (already validated when it was made) and hands its
kernel arrays (:meth:`haptex.Algorithm.kernel_spec`) to the C.

Implemented so far: texture evaluation of every kind, the memoryless fields W, A, B, C and G
(forces and Jacobians) over profiles and surfaces, each written once over the dimension;
presliding friction (F); and the servo tick (safety rules, passivity observer/controller,
saturation, counters) that :class:`haptex.Renderer` runs for W, A, B, C, F and G. The NumPy
fields of :mod:`haptex.algorithms` are the fields' oracle (tests/test_core.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._validation import ParameterError
from . import _ext

SOURCE_DIR = Path(__file__).parent
"""Where the core's C sources are (``haptex export`` copies them from here)."""

IN_CORE = frozenset("WABCG")
"""The letters whose memoryless fields (force and Jacobian, :func:`field`) the C core
evaluates (D and E follow with their closest-point searches; F has state, see below)."""

TICKS_IN_CORE = frozenset("WABCFG")
"""The letters whose servo tick (:class:`haptex.Renderer`) runs in the C core: the fields
above, and F with its presliding friction (sharp and smooth, isotropic in the plane)."""


def field(algorithm, p, jacobian: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
    """The force and Jacobian of ``algorithm`` at ``p``, evaluated by the C core.

    Parameters
    ----------
    algorithm : Algorithm
        One of W, A, B, C, G (:data:`IN_CORE`), over a profile or a surface.
    p : array_like, shape (..., 2) or (..., 3)
        Probe positions [x, z] over a profile, [x, y, z] over a surface (m).
    jacobian : bool, optional
        Also return the Jacobian (default True).

    Returns
    -------
    f : ndarray, shape (..., n)
        Force (N), as :meth:`haptex.Algorithm.force`.
    J : ndarray, shape (..., n, n) or None
        d f_i / d p_j (N/m), as :meth:`haptex.Algorithm.jacobian`.

    Raises
    ------
    ParameterError
        For an algorithm the core does not evaluate yet, or positions of the wrong shape or
        not finite (as the NumPy fields).
    """
    if algorithm.letter not in IN_CORE:
        raise ParameterError(f"algorithm = {algorithm.letter!r} is not allowed here: the C core evaluates "
                             f"{', '.join(sorted(IN_CORE))} so far")
    arr = algorithm._positions(p)
    code, prm, kind, coeffs, _ = algorithm.kernel_spec()
    n = arr.shape[-1]
    flat = np.ascontiguousarray(arr.reshape(-1, n), dtype=np.float64)
    f = np.empty_like(flat)
    j = np.empty((flat.shape[0], n, n)) if jacobian else None
    _ext.field(code, prm, kind, coeffs, flat, f, j)
    return f.reshape(arr.shape), (j.reshape(arr.shape + (n,)) if jacobian else None)


def texture_derivatives(texture, xy) -> np.ndarray:
    """h, h_x, h_y, h_xx, h_xy, h_yy of ``texture`` at in-plane points, by the C core.

    Parameters
    ----------
    texture : Texture
        Any texture with compiled data (:meth:`haptex.Texture.kernel_data`).
    xy : array_like, shape (..., 2)
        In-plane positions [x, y] (m); a profile ignores y.

    Returns
    -------
    ndarray, shape (..., 6)
        Height (m), gradient (m/m) and Hessian entries (1/m).
    """
    kind, coeffs = texture.kernel_data()
    pts = np.asarray(xy, dtype=np.float64)
    flat = np.ascontiguousarray(pts.reshape(-1, 2))
    out = np.empty((flat.shape[0], 6))
    _ext.texture(kind, np.ascontiguousarray(coeffs, dtype=np.float64), flat, out)
    return out.reshape(pts.shape[:-1] + (6,))
