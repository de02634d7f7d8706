"""Bounded maximisation from a grid's best points: the one refinement every sup in haptex uses
(q's, :mod:`haptex.analysis.characteristic`; a surface's steepest slope and largest curvature,
:meth:`haptex.surfaces.Surface._sup`)."""

from __future__ import annotations

import numpy as np


def refine(neg, start, value, bounds, ftol: float = 1e-15, gtol: float = 1e-12) -> tuple[float, tuple]:
    """Bounded L-BFGS-B maximisation from a grid point: (value, point), the grid's own if
    the refinement finds nothing larger (``value`` None: the start's own, computed here).
    ``neg`` maps points (n, d) to the negated quantity (n,), row by row; L-BFGS-B's
    finite-difference gradient evaluates its d shifted points in one call of it (SciPy's
    ``workers``, a map-like callable: the values of one call a point to rounding, numpy's
    vector loops and their scalar tails differing in the last bit, for a d-th of the Python
    overhead). ``ftol`` and ``gtol`` are L-BFGS-B's (SciPy's ``minimize`` options)."""
    from scipy import optimize

    start = np.asarray(start, dtype=np.float64)
    free = np.array([lo != hi for lo, hi in bounds])  # (the fixed held here, as minimize would drop them)
    base = np.array([v if f else lo for v, f, (lo, hi) in zip(start, free, bounds)])

    def full(v):  # (n, free variables) -> (n, d)
        out = np.repeat(base[None, :], len(v), axis=0)
        out[:, free] = v
        return out

    def one(v):
        return float(neg(full(np.asarray(v, dtype=np.float64)[None, :]))[0])

    def shifted(_fun, points):  # (map(_fun, points): each row's value as ``one`` computes it, to rounding)
        return [float(v) for v in neg(full(np.array(list(points), dtype=np.float64)))]

    if value is None:
        value = -one(start[free])
    r = optimize.minimize(one, x0=start[free], method="L-BFGS-B", bounds=[b for b, f in zip(bounds, free) if f],
                          options={"ftol": ftol, "gtol": gtol, "workers": shifted})
    if -r.fun > value:
        return -float(r.fun), tuple(float(v) for v in full(r.x[None, :])[0])
    return float(value), tuple(float(v) for v in start)
