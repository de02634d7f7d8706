"""Closest point on the textured boundary z = h(x), used by algorithms D and E.

The search is compiled (:func:`haptex._kernels.closest_point`); this module validates,
flattens and calls it. The reference it is tested against is a brute-force dense search.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import _kernels
from ._validation import ParameterError, positions
from .textures import Texture


@dataclass(frozen=True)
class ClosestPoint:
    """Closest boundary points for an array of probe positions.

    Attributes
    ----------
    x : ndarray, shape (...)
        Abscissa p_h^x of the closest point (m); equal to the probe's x where the probe
        is not below the boundary.
    z : ndarray, shape (...)
        Height p_h^z = h(p_h^x) of the closest point (m).
    distance : ndarray, shape (...)
        Minimum distance d^min = |p - p_h| (m); 0 where the probe is not below the
        boundary.
    tie : ndarray of bool, shape (...)
        True where a second, distinct boundary point lies at the same distance to
        1e-9 relative: the probe is on the medial axis (e.g. below a peak of a sinusoid
        deeper than its radius of curvature), where algorithm D's force jumps (Remark 6).
    """

    x: np.ndarray
    z: np.ndarray
    distance: np.ndarray
    tie: np.ndarray


def closest_point(texture: Texture, p) -> ClosestPoint:
    """Closest point on the boundary z = h(x) to each probe position below it.

    Parameters
    ----------
    texture : Texture
        The height profile h (m).
    p : array_like, shape (..., 2)
        Probe positions [x, z] (m).

    Returns
    -------
    ClosestPoint
        Arrays of shape (...) (see :class:`ClosestPoint`).

    Raises
    ------
    ParameterError
        If ``p`` is not of shape (..., 2) or holds a non-finite coordinate.

    Notes
    -----
    For a probe at vertical depth d_v = h(p^x) - p^z > 0 the global minimiser of
    |p - (t, h(t))| lies in [p^x - d_v, p^x + d_v]. That interval is cut into cells; a
    cell is skipped when a rigorous lower bound of the distance over it (from the
    texture's Lipschitz bound M) is not below the best distance so far; the others are
    sampled every 1/64 of the shortest texture period, every local minimum of the squared
    distance is refined by safeguarded (bracketed) Newton iterations, the best sample is
    polished by bounded Newton, and the smallest distance wins. This is the god-object projection of
    Zilles & Salisbury (1995) [28] restricted to a height profile.
    """
    arr = positions(p)
    shape = arr.shape[:-1]
    flat = arr.reshape(-1, 2)
    kind, coeffs = texture.kernel_data()
    n = flat.shape[0]
    t = np.empty(n)
    d = np.empty(n)
    tie = np.empty(n, dtype=np.int64)
    _kernels.closest_points(
        kind,
        coeffs,
        float(texture.closest_point_step),
        float(texture.max_slope),
        float(texture.max_curvature),
        np.ascontiguousarray(flat[:, 0]),
        np.ascontiguousarray(flat[:, 1]),
        t,
        d,
        tie,
    )
    if np.isnan(d).any():
        bad = flat[np.isnan(d)][0]
        raise ParameterError(
            f"p = {bad.tolist()} is not allowed: it is too deep below the texture for the closest-point "
            f"search (more than about {_kernels.MAX_CELLS * 8 * texture.closest_point_step / 2:g} m)"
        )
    return ClosestPoint(
        x=t.reshape(shape),
        z=texture.height(t).reshape(shape),
        distance=d.reshape(shape),
        tie=(tie != 0).reshape(shape),
    )
