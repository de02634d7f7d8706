"""haptex's C core: the real-time code the library runs.

The C99 sources beside this file (``hx_core.h`` and the ``hx_*.c`` / ``hx_*.h`` files) are
compiled at install into :mod:`haptex.core._ext`. This module is the thin Python side: it
takes an :class:`haptex.Algorithm` (already validated when it was made) and hands its
kernel arrays (:meth:`haptex.Algorithm.kernel_spec`) to the C, cutting batches into slices
run on threads (the C releases the GIL).

In the core: texture evaluation of every kind; the memoryless fields W, A, B, C and G with
their Jacobians (:func:`field`); every letter's servo tick, with D's and E's closest-point
searches over profiles and surfaces and F's presliding (:class:`haptex.Renderer`); the
simulator's lean and general loops (:func:`haptex.simulate`, :func:`haptex.simulate_batch`).
The builders of D's and E's search data over profiles too (the bound tree's leaf bounds, the
cell table), and ``haptex export`` copies these files. The NumPy fields of
:mod:`haptex.algorithms` are the fields' oracle (tests/test_core.py).
"""

from __future__ import annotations

import functools
import os
import threading
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from .._validation import ParameterError, fail, not_an_algorithm, whole
from . import _ext

__all__ = ["SOURCE_DIR", "IN_CORE", "WORKSPACE_LIMIT", "field", "texture_derivatives", "threads", "num_threads", "blas_held_to_one_thread",
           "expm", "in_slices", "closest_profile_points", "closest_surface_points"]

SOURCE_DIR = Path(__file__).parent
"""Where the core's C sources are (``haptex export`` copies them from here)."""

WORKSPACE_LIMIT = 1e3
"""Positions with a coordinate beyond +-1 km (m) are faults of the tick (zero force): the
renderer's and the god-object's (re-exported as :data:`haptex.renderer.WORKSPACE_LIMIT`)."""

IN_CORE = frozenset("WABCG")
"""The letters whose memoryless fields (force and Jacobian, :func:`field`) the C core
evaluates (D and E need their closest-point searches, F its presliding state: their forces
come from the servo tick, :class:`haptex.Renderer`)."""


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
    if not callable(getattr(algorithm, "kernel_spec", None)):  # (an algorithm or a god-object: the core packs either)
        raise not_an_algorithm(algorithm, proxy=True)
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
    coeffs = np.ascontiguousarray(coeffs, dtype=np.float64)
    in_slices(lambda lo, hi: _ext.texture(kind, coeffs, flat[lo:hi], out[lo:hi]), flat.shape[0], least=1 << 14)
    return out.reshape(pts.shape[:-1] + (6,))


_LOCAL = threading.local()


@contextmanager
def threads(n: int):
    """Within the block, the C core's batch loops called from this thread use ``n`` threads
    (a Dask worker's task: its share of the machine's cores), whatever ``HAPTEX_NUM_THREADS``.

    Parameters
    ----------
    n : int
        Threads the C core's batch loops use within the block, 1 to 1024.

    Raises
    ------
    ParameterError
        If ``n`` is not a whole number from 1 to 1024.
    """
    n = whole("threads", n, 1, 1024)
    old = getattr(_LOCAL, "threads", None)
    _LOCAL.threads = n
    try:
        yield
    finally:
        _LOCAL.threads = old


def num_threads() -> int:
    """Threads of the C core's batch loops: set by :func:`threads` for the calling thread, else
    ``HAPTEX_NUM_THREADS`` (a whole number >= 1), by default every core of the machine.

    Returns
    -------
    int
        Threads (>= 1).

    Raises
    ------
    ParameterError
        If ``HAPTEX_NUM_THREADS`` is set to anything but a whole number from 1 to 1024.
    """
    local = getattr(_LOCAL, "threads", None)
    if local is not None:
        return local
    raw = os.environ.get("HAPTEX_NUM_THREADS")
    if raw is None:
        return _CPUS
    try:
        n = int(raw)
    except ValueError:
        n = 0
    if not 1 <= n <= 1024:
        raise fail("HAPTEX_NUM_THREADS", raw, "a whole number from 1 to 1024")
    return n


_CPUS = max(1, os.cpu_count() or 1)
"""The machine's cores, read once (os.cpu_count costs microseconds a call)."""
SLICES_PER_THREAD = 8
"""Slices a batch is cut into per thread, handed to the threads as they come free: a probe's
cost varies a hundredfold over a region (a closest point 1 um or 1 mm deep), and one slice
per thread left a core idle for up to a third of a design run."""


_BLAS = {"controller": None, "depth": 0, "limiter": None}
_BLAS_LOCK = threading.Lock()


@contextmanager
def _blas_held_to_one_thread():
    """While haptex's C loops run on threads, BLAS's own threads are held to one (threadpoolctl):
    OpenBLAS's idle workers spin for a while after each call, and on 2 cores they took 22 % of
    a simulate_batch's CPU from its loops (perf). Nested and concurrent uses share one limit,
    lifted when the last ends.

    The controller sees only the libraries loaded when it is made, so scipy.linalg (whose
    OpenBLAS is not numpy's, and whose LU solve inside ``expm`` starts OpenBLAS's threads even
    on 4 x 4 matrices) is loaded first: made before it, the limit missed that library, and its
    spinning workers took 20-30 % of simulate_batch's rate on 2 cores (perf, gdb on exec_blas)."""
    with _BLAS_LOCK:
        if _BLAS["depth"] == 0:
            if _BLAS["controller"] is None:
                import scipy.linalg  # noqa: F401  (its BLAS loaded before the controller looks)
                from threadpoolctl import ThreadpoolController

                _BLAS["controller"] = ThreadpoolController()
            _BLAS["limiter"] = _BLAS["controller"].limit(limits=1, user_api="blas")
        _BLAS["depth"] += 1
    try:
        yield
    finally:
        with _BLAS_LOCK:
            _BLAS["depth"] -= 1
            if _BLAS["depth"] == 0:
                _BLAS["limiter"].restore_original_limits()
                _BLAS["limiter"] = None


def blas_held_to_one_thread(fn):
    """Decorator: ``fn`` runs with BLAS held to one thread (:func:`_blas_held_to_one_thread`):
    for entry points whose set-up calls BLAS on small matrices just before their C loops run
    on threads (OpenBLAS's workers would spin through the loops: measured 17-21 % of
    simulate_batch's rate on 2 cores).

    Parameters
    ----------
    fn : callable
        The function wrapped.

    Returns
    -------
    callable
        ``fn`` wrapped: the same signature and result.
    """

    @functools.wraps(fn)
    def held(*args, **kwargs):
        with _blas_held_to_one_thread():
            return fn(*args, **kwargs)

    return held


def expm(a: np.ndarray) -> np.ndarray:
    """The matrix exponential e^A (scipy.linalg.expm) with BLAS held to one thread.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        A square matrix (haptex's: the continuous-time dynamics times the sampling period,
        n from 2 to 14).

    Returns
    -------
    ndarray, shape (n, n)

    Notes
    -----
    scipy's expm solves its Pade system by OpenBLAS's LU (getrs), which hands even a 4 x 4
    solve to OpenBLAS's worker threads; they then spin for about 0.1 s (measured: 0.10 s of CPU
    on the other core after a simulated backend was made), beside a servo loop about to start
    or C loops about to run on every core. Every exact discretisation in haptex (the
    simulator's, the devices' limits, the simulated backend's) goes through here.
    """
    from scipy.linalg import expm as _expm

    with _blas_held_to_one_thread():
        return _expm(a)


def in_slices(fn, n: int, threads: int | None = None, least: int = 1024, per_thread: int | None = None) -> None:
    """Call ``fn(lo, hi)`` over contiguous slices of range(n), on up to :func:`num_threads`
    threads (the C releases the GIL); slices of at least ``least`` items (one thread below),
    up to ``per_thread`` (default ``SLICES_PER_THREAD``) a thread, taken by the threads as they
    come free; BLAS held to one thread meanwhile.

    Parameters
    ----------
    fn : callable
        ``fn(lo, hi)``: the work on items lo to hi - 1 (it releases the GIL in C).
    n : int
        The number of items.
    threads : int, optional
        Most threads; default :func:`num_threads`.
    least : int, optional
        Fewest items a slice (below it one thread does all).
    per_thread : int, optional
        Slices a thread (their count is threads x per_thread).
    """
    threads = num_threads() if threads is None else threads
    per_thread = SLICES_PER_THREAD if per_thread is None else per_thread
    parts = max(1, min(threads * per_thread, n // max(least, 1)))
    if parts == 1 or threads == 1:
        fn(0, n)
        return
    cuts = np.linspace(0, n, parts + 1).astype(int)
    with _blas_held_to_one_thread(), ThreadPoolExecutor(min(threads, parts)) as pool:
        list(pool.map(fn, cuts[:-1], cuts[1:]))


def closest_profile_points(kind: int, coeffs: np.ndarray, aux: np.ndarray, px, pz):
    """Closest points of a profile's boundary to probes (px, pz) (m) by the C core
    (:func:`haptex.closest.closest_point` over a profile reads this).

    Parameters
    ----------
    kind, coeffs : int, ndarray
        The profile's kernel data (:meth:`haptex.Texture.kernel_data`).
    aux : ndarray, shape (k,)
        Its search data (:func:`haptex.closest.search_data`).
    px, pz : array_like, shape (N,)
        Probe positions (m).

    Returns
    -------
    t, distance : ndarray, shape (N,)
        The closest point's abscissa and its distance (m), 0 outside the wall.
    tie, work : ndarray of int64, shape (N,)
        1 where another local minimum lies at the same distance (the medial axis); the
        texture evaluations spent.
    """
    px = np.ascontiguousarray(px, dtype=np.float64)
    pz = np.ascontiguousarray(pz, dtype=np.float64)
    coeffs = np.ascontiguousarray(coeffs, dtype=np.float64)
    aux = np.ascontiguousarray(aux, dtype=np.float64)
    n = px.shape[0]
    t, d = np.empty(n), np.empty(n)
    tie, work = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)

    def run(lo, hi):
        _ext.closest_profile(kind, coeffs, aux, px[lo:hi], pz[lo:hi], t[lo:hi], d[lo:hi], tie[lo:hi], work[lo:hi])

    in_slices(run, n, least=256)
    return t, d, tie, work


def closest_surface_points(kind: int, coeffs: np.ndarray, aux: np.ndarray, px, py, pz):
    """Closest points of a surface (a sum of gratings or a height map) to probes (px, py, pz)
    (m) by the C core (:func:`haptex.closest.closest_point` over a surface reads this).

    Parameters
    ----------
    kind, coeffs : int, ndarray
        The surface's kernel data (:meth:`haptex.Texture.kernel_data`).
    aux : ndarray, shape (N_GAUX,)
        Its search constants (:func:`haptex.closest.surface_search_data`).
    px, py, pz : array_like, shape (N,)
        Probe positions (m).

    Returns
    -------
    tx, ty, distance : ndarray, shape (N,)
        The closest point's in-plane coordinates and its distance (m), 0 outside the wall.
    tie, work : ndarray of int64, shape (N,)
        1 where another local minimum lies at the same distance; the texture evaluations spent.
    """
    px, py, pz = (np.ascontiguousarray(a, dtype=np.float64) for a in (px, py, pz))
    coeffs = np.ascontiguousarray(coeffs, dtype=np.float64)
    aux = np.ascontiguousarray(aux, dtype=np.float64)
    n = px.shape[0]
    tx, ty, d = np.empty(n), np.empty(n), np.empty(n)
    tie, work = np.empty(n, dtype=np.int64), np.empty(n, dtype=np.int64)

    def run(lo, hi):
        _ext.closest_surface(kind, coeffs, aux, px[lo:hi], py[lo:hi], pz[lo:hi], tx[lo:hi], ty[lo:hi], d[lo:hi],
                             tie[lo:hi], work[lo:hi])

    in_slices(run, n, least=64)
    return tx, ty, d, tie, work
