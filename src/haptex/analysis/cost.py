"""What an analysis will cost, before it runs: the field evaluations its grids plan
(counted, from the analyses' own plans) times the time one evaluation takes over the
rendering region (measured on a few hundred random probes there, in CPU time of the calling
thread: the plan is the work's, not the machine's load at the moment it is made; a niced worker
beside two busy processes timed 7-20 times slower by the wall clock, and was refused work it
would have been given idle).

The grids dominate: :func:`~haptex.analysis.continuity` and the first search of
:func:`~haptex.analysis.characteristic_number`. The refinement of q's best cells and the
random loops of :func:`~haptex.analysis.conservativity` are not counted, so the estimate
counts the grids' work at one thread's CPU time an evaluation. For D and E, q's grid costs a
Jacobian at each point's foot (no search: the Jacobian's time less the force's) and the
closest-point searches of its region's first batch (``REGION_FIRST`` of its points, where
||J|| is largest; more where the region's edge or few maxima need them). The searches of D
and E run on every core, so on a multi-core machine the wall time can be shorter than planned
(a 1025 x 1025 map: 75 s planned, 41 s taken on 2 cores); the uncounted work can make it
longer.
"""

from __future__ import annotations

import functools
import time
from dataclasses import dataclass

import numpy as np

from .._validation import random_seed
from ..algorithms import Algorithm, checked_algorithm
from ._region import _region_box, _static_force, check_analysis_scale
from .characteristic import REGION_FIRST, characteristic_points
from .continuity import continuity_points, grid_points, peak_bytes

CALIBRATION_PROBES = {"direct": 256, "distance": 2048}
"""Random probes timed to measure one evaluation's cost (chosen: a few ms for a direct
field; about 0.1 s of closest-point searches, whose cost varies from probe to probe by
two orders of magnitude)."""
CALIBRATION_SECONDS = 0.25
"""Most CPU time the timing takes (s, chosen): on a texture whose searches cost milliseconds it stops
early, timing fewer probes, so that planning stays cheap beside what it plans."""
CHUNK = 64
"""Probes evaluated at once while timing."""
WARM_UP = 8
"""Probes evaluated first, untimed: they build what the texture caches once."""


@dataclass(frozen=True)
class Cost:
    """The planned cost of analysing one algorithm.

    Parameters
    ----------
    letter : str
    evaluations : int
        Field evaluations the grids plan (q's first search and the continuity grids; for D and
        E the closest-point searches: the continuity grids' and q's region's first batch).
    seconds_each : float
        Mean measured CPU time of one evaluation over the region on one thread (s), forces
        and Jacobians.
    seconds : float
        ``evaluations * seconds_each`` (s): a floor (the refinement and loops not counted).
    peak_bytes : int
        Memory of the largest grid (bytes).
    searches : bool
        Each evaluation is a closest-point search (D, E).
    """

    letter: str
    evaluations: int
    seconds_each: float
    seconds: float
    peak_bytes: int
    searches: bool


def evaluation_time(algorithm: Algorithm, max_penetration: float = 1e-3, x_range=None,
                    probes: int | None = None, seed: int = 0, jacobian: bool = False) -> float:
    """Seconds per field evaluation over the rendering region: ``probes`` random positions
    (default :data:`CALIBRATION_PROBES`) in its box (in-plane window, depth down to ``max_penetration`` below the lowest valley),
    evaluated in chunks of :data:`CHUNK` on the calling thread, timed by that thread's CPU
    clock (:func:`time.thread_time`), so that the figure does not grow with the machine's
    other load; on an idle machine it equals the wall-clock time.

    Parameters
    ----------
    algorithm : Algorithm
        Any of W, A-G.
    max_penetration : float, optional
        Depth of the rendering region below the lowest valley (m), default 1 mm.
    x_range : (float, float), optional
        The region along x (m) instead of one period (or the texture's domain).
    probes : int, optional
        Random positions evaluated (default :data:`CALIBRATION_PROBES`).
    seed : int, optional
        Seed of the positions.
    jacobian : bool, optional
        Time the force and its Jacobian instead of the force alone.

    Returns
    -------
    float
        Seconds per evaluation.

    Raises
    ------
    ParameterError
        As the analyses (region too large, stiffness out of range), or a seed that is not
        numpy's default_rng's (a whole number from 0 to 2^64 - 1).
    """
    algorithm = checked_algorithm(algorithm)
    seed = random_seed("seed", seed)
    dmax = check_analysis_scale(algorithm, max_penetration)
    box = _region_box(algorithm, dmax, x_range)
    if probes is None:
        probes = CALIBRATION_PROBES["distance" if algorithm.penetration_kind == "distance" else "direct"]
    rng = np.random.default_rng(seed)
    p = np.stack([rng.uniform(a, b, probes + WARM_UP) for a, b in box], -1)
    if not jacobian:
        fn = functools.partial(_static_force, algorithm)
    elif algorithm.has_memory and algorithm.penetration_kind != "distance":  # F, at a full-slip deflection
        def fn(q):
            d = np.full(q.shape[:-1], algorithm.presliding) if q.shape[-1] == 2 else np.stack(
                [np.full(q.shape[:-1], algorithm.presliding), np.zeros(q.shape[:-1])], -1)
            return algorithm.jacobian(q, d)
    else:
        fn = algorithm.jacobian
    fn(p[:WARM_UP])  # the texture's one-time data (patches, search bounds) built
    half = probes // 2
    rates = []
    for lo in (WARM_UP, WARM_UP + half):  # two halves, the faster kept (the first may pay for caches)
        done, t = 0, time.thread_time()
        while done < half:  # in chunks, until the half is done or its CPU time is spent
            step = min(CHUNK, half - done)
            fn(p[lo + done:lo + done + step])
            done += step
            if time.thread_time() - t > CALIBRATION_SECONDS / 2:
                break
        rates.append((time.thread_time() - t) / done)
    return min(rates)


def analysis_cost(algorithm: Algorithm, max_penetration: float = 1e-3, x_range=None, seconds_each=None,
                  continuity: bool = True) -> Cost:
    """The planned cost of q and continuity for one algorithm (see the module docstring).

    Parameters
    ----------
    algorithm : Algorithm
    max_penetration : float, optional
        Depth of the region (m).
    x_range : optional
        The analysed window, as the analyses take it.
    seconds_each : float or (float, float), optional
        A measured evaluation time to reuse (s), or the force's and the Jacobian's; default
        :func:`evaluation_time`'s.
    continuity : bool, optional
        Count the continuity grids (False where another algorithm's searches are read: E
        reads the closest points D searched on the same grids).

    Returns
    -------
    Cost

    Raises
    ------
    ParameterError
        As the analyses.
    """
    algorithm = checked_algorithm(algorithm)
    cont = continuity_points(algorithm, max_penetration, x_range) if continuity else []
    q = characteristic_points(algorithm, max_penetration, x_range)
    if seconds_each is None:
        each = evaluation_time(algorithm, max_penetration, x_range)
        each_j = evaluation_time(algorithm, max_penetration, x_range, jacobian=True)
    elif np.ndim(seconds_each):
        each, each_j = (float(v) for v in seconds_each)
    else:
        each = each_j = float(seconds_each)
    if algorithm.penetration_kind == "distance":  # q's grid: Jacobians at the feet, the region's searches
        searched = min(q, REGION_FIRST)
        n = int(sum(cont) + searched)
        seconds = sum(cont) * each + searched * each_j + q * max(each_j - each, 0.0)
    else:
        n = int(sum(cont) + q)
        seconds = sum(cont) * each + q * each_j
    return Cost(algorithm.letter, n, seconds / n, seconds,
                peak_bytes(grid_points(algorithm, max_penetration, x_range)),
                algorithm.penetration_kind == "distance")
