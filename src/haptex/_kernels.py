"""Numba-compiled scalar kernels (private).

No validation, no allocation in the inner loops, no I/O: the Python wrappers in the public
modules validate and convert inputs once and call these. The tests compare each kernel with
a plain-Python/NumPy twin: texture evaluation with the texture methods, the closest point
with a brute-force search, ``alg_force`` with the vectorised ``force``, the presliding
step with :func:`haptex.friction.step` and an ODE solver; the simulator loop is checked by
its exact zero-order hold against closed forms and by its energy balance.

Everything compiled that calls something else compiled lives in this one file: numba's
on-disk cache is invalidated per source file, so a kernel in another module would keep a
stale copy of a callee edited here.

Texture encoding shared by all kernels
--------------------------------------
``kind`` selects the representation and ``coeffs`` holds its numbers:

* ``TEXTURE_FLAT`` (0): h = 0 (no texture, e.g. algorithm W); ``coeffs`` is ignored.
* ``TEXTURE_FOURIER`` (1): ``coeffs`` has shape (3, n): amplitudes a_k (m), wavenumbers
  k_k = 2*pi/l_k (rad/m) and phases phi_k (rad); h(x) = sum a_k sin(k_k x + phi_k).
* ``TEXTURE_SPLINE`` (2): a uniformly sampled cubic spline with m intervals; ``coeffs``
  has shape (4, m + 2): columns 0..m-1 hold the polynomial coefficients of each interval
  (highest power first, in the local abscissa t = x - x_i, as scipy's CubicSpline.c);
  column m holds [x0, dx, periodic (0 or 1), m]; column m + 1 holds [h, h'] at the left
  end and [h, h'] at the right end, used to extend a non-periodic profile linearly.
"""

from __future__ import annotations

import math
import os

import numba as nb
import numpy as np

if "NUMBA_THREADING_LAYER" not in os.environ:
    # GNU OpenMP, numba's default layer where it is installed, kills or hangs the workers of a
    # fork-based multiprocessing pool (or Dask) started after a parallel kernel ran: ask for a
    # fork-safe layer (TBB if installed, else numba's workqueue). A user's explicit choice wins.
    nb.config.THREADING_LAYER = "forksafe"

# the codes of the textures, the letters and the parameter slots are the C core's (one
# definition, in core/hx_core.h), read here while these kernels are being ported to it
from .core._ext import (ALG_A, ALG_B, ALG_C, ALG_D, ALG_E, ALG_F, ALG_G, ALG_W,  # noqa: E402, F401
                        N_PARAMS, P_DXMAX, P_DZMAX, P_K0, P_MU, P_SCALE, P_ZSTICK, SURFACE_GRATINGS,
                        SURFACE_PATCHES, TEXTURE_FLAT, TEXTURE_FOURIER, TEXTURE_SPLINE)  # noqa: F401

_JIT = dict(cache=True, fastmath=False, nogil=True)

@nb.njit(**_JIT)
def _spline_eval(coeffs, x):
    """Uniform cubic spline (see ``TEXTURE_SPLINE``): (h, h', h'')."""
    m = coeffs.shape[1] - 2
    x0 = coeffs[0, m]
    dx = coeffs[1, m]
    periodic = coeffs[2, m] != 0.0
    length = m * dx
    u = x - x0
    if periodic:
        u = u - length * math.floor(u / length)
    elif u < 0.0:
        return coeffs[0, m + 1] + coeffs[1, m + 1] * u, coeffs[1, m + 1], 0.0
    elif u > length:
        return coeffs[2, m + 1] + coeffs[3, m + 1] * (u - length), coeffs[3, m + 1], 0.0
    i = int(u / dx)
    if i >= m:
        i = m - 1
    elif i < 0:
        i = 0
    t = u - i * dx
    a3 = coeffs[0, i]
    a2 = coeffs[1, i]
    a1 = coeffs[2, i]
    a0 = coeffs[3, i]
    return ((a3 * t + a2) * t + a1) * t + a0, (3.0 * a3 * t + 2.0 * a2) * t + a1, 6.0 * a3 * t + 2.0 * a2


@nb.njit(**_JIT)
def texture_eval(kind, coeffs, x):
    """Return (h, h', h'') at abscissa ``x`` (m, m/m, 1/m)."""
    h = 0.0
    s = 0.0
    c = 0.0
    if kind == TEXTURE_SPLINE:
        return _spline_eval(coeffs, x)
    if kind == TEXTURE_FOURIER:
        for i in range(coeffs.shape[1]):
            a = coeffs[0, i]
            k = coeffs[1, i]
            arg = k * x + coeffs[2, i]
            sn = math.sin(arg)
            cs = math.cos(arg)
            h += a * sn
            s += a * k * cs
            c -= a * k * k * sn
    return h, s, c


@nb.njit(inline="always", **_JIT)
def texture_height(kind, coeffs, x):
    """h at abscissa ``x`` (m) alone: :func:`texture_eval`'s first value, without the
    derivatives' cosines where only the height is needed (A, D, E, F, the damping regime)."""
    if kind == TEXTURE_FOURIER:
        h = 0.0
        for i in range(coeffs.shape[1]):
            h += coeffs[0, i] * math.sin(coeffs[1, i] * x + coeffs[2, i])
        return h
    return texture_eval(kind, coeffs, x)[0]


# ----------------------------------------------------------------------------------------
# Closest point on the textured boundary (algorithms D and E): a bounded branch and bound.
# ----------------------------------------------------------------------------------------
# The search reads a per-texture float64 array ``aux`` built once by
# haptex.closest.search_data: a header, then a binary tree (heap order, node 1 the root) of
# rigorous lower/upper bounds of h over dyadic sub-intervals of a "core" interval (one
# period of a periodic texture, the sampled range of a non-periodic profile).
# the modes CP_* and the header's slots A_* are the C core's (hx_core.h)
from .core._ext import (A_CURV, A_HL, A_HMIN, A_HR, A_JERK, A_MODE, A_NLEAF, A_PERIOD, A_SL,  # noqa: E402, F401
                        A_SLOPE, A_SR, A_START, A_STEP, A_TABLE, A_TIE, A_TMIN, A_TREE, A_TREELEN, A_WCAP, A_X0,
                        A_XE, CP_FINITE, CP_OPEN, CP_PERIODIC, CP_VERTICAL)  # noqa: F401
"""aux[A_TABLE] is the offset in ``aux`` of a cell table (:func:`build_cell_table`), 0 for none."""
"""lo[i] is aux[A_TREE + i] and hi[i] is aux[A_TREE + 2 n_leaf + i], i = 1 .. 2 n_leaf - 1."""
MAX_LEAVES = 1 << 22
"""Largest bound tree (leaves) a texture may ask for: 2^22 leaves are 128 MiB of bounds."""
OPEN_LEAVES = 4096
"""An aperiodic Fourier sum is searched within +-OPEN_LEAVES leaves of the probe's abscissa."""
# scratch slots of the search (inside the algorithm state array, from S_SEARCH on)
B_F, B_T, B_SECOND, B_FOUND, B_WORK, B_SAMPLE = range(6)
B_STACK = 8
STACK_DEPTH = 64
N_SEARCH = B_STACK + STACK_DEPTH


@nb.njit(**_JIT)
def _dphi(kind, coeffs, px, pz, t):
    """phi(t) = (t-px)^2 + (h(t)-pz)^2, g = phi'/2 and g' = phi''/2."""
    h, s, c = texture_eval(kind, coeffs, t)
    dz = h - pz
    g = (t - px) + dz * s
    gp = 1.0 + s * s + dz * c
    return (t - px) * (t - px) + dz * dz, g, gp


@nb.njit(**_JIT)
def _refine_bracket(kind, coeffs, px, pz, a, b):
    """Root of g = phi'/2 in [a, b] where g(a) <= 0 < g(b): safeguarded Newton (at most
    60 iterations). Returns (t, iterations)."""
    lo = a
    hi = b
    t = 0.5 * (a + b)
    it = 0
    for it in range(1, 61):
        _, g, gp = _dphi(kind, coeffs, px, pz, t)
        if g > 0.0:
            hi = t
        else:
            lo = t
        tn = t - g / gp if gp > 0.0 else 0.5 * (lo + hi)
        if not (lo < tn < hi):
            tn = 0.5 * (lo + hi)
        if abs(tn - t) <= 1e-15 * (1.0 + abs(t)) or hi - lo <= 1e-16 * (1.0 + abs(t)):
            return tn, it
        t = tn
    return t, it


@nb.njit(**_JIT)
def _polish(kind, coeffs, px, pz, t, a, b):
    """Newton iterations on phi'/2 from t, kept inside [a, b] (at most 30). Returns (t, iterations)."""
    it = 0
    for it in range(1, 31):
        _, g, gp = _dphi(kind, coeffs, px, pz, t)
        if gp <= 0.0:
            return t, it
        tn = min(max(t - g / gp, a), b)
        if abs(tn - t) <= 1e-15 * (1.0 + abs(t)):
            return tn, it
        t = tn
    return t, it


@nb.njit(**_JIT)
def _bound(bs, t, f):
    """A boundary point (t, f): an upper bound of the minimum, not a certified local minimum."""
    if f < bs[B_F]:
        bs[B_F] = f
        bs[B_T] = t


@nb.njit(**_JIT)
def _offer(bs, t, f, sep):
    """A refined local minimum (t, f): keep the best and the best runner-up more than
    ``sep`` away from it (for the medial-axis tie)."""
    if f < bs[B_F]:
        if bs[B_FOUND] != 0.0 and bs[B_F] < bs[B_SECOND] and abs(t - bs[B_T]) > sep:
            bs[B_SECOND] = bs[B_F]
        bs[B_F] = f
        bs[B_T] = t
        bs[B_FOUND] = 1.0
    elif bs[B_FOUND] != 0.0 and f < bs[B_SECOND] and abs(t - bs[B_T]) > sep:
        bs[B_SECOND] = f


@nb.njit(**_JIT)
def _pair_possible(aux, g0, g1, gp0, gp1, dz, dt):
    """False when phi provably has no local minimum in a sample interval other than the
    one a - to + sign change of g = phi'/2 reveals: phi is convex on it (g' > 0), or g
    cannot reach zero there. |g''| = |3 h' h'' + (h - pz) h'''| <= G2, with |h - pz| <= dz."""
    g2 = 3.0 * aux[A_SLOPE] * aux[A_CURV] + dz * aux[A_JERK]
    if min(gp0, gp1) - g2 * dt > 0.0:
        return False
    if (g0 > 0.0) == (g1 > 0.0):
        return abs(g0) + abs(g1) <= (max(abs(gp0), abs(gp1)) + g2 * dt) * dt
    return True


@nb.njit(**_JIT)
def _refine_and_offer(kind, coeffs, px, pz, a, b, sep, bs):
    """Refine the minimum of phi bracketed by a - to + sign change of g on [a, b] and offer
    it (:func:`_offer`); returns the work spent."""
    t, it = _refine_bracket(kind, coeffs, px, pz, a, b)
    f, _, _ = _dphi(kind, coeffs, px, pz, t)
    _offer(bs, t, f, sep)
    return it + 1


@nb.njit(**_JIT)
def _scan_interval(kind, coeffs, px, pz, a, b, f_a, g_a, n, bs, best):
    """Sample [a, b] at n + 1 points (the first is given), refine every - to + sign change of
    g; ``best`` = [t, f] of the best sample is updated. Returns the work spent."""
    work = 0
    dt = (b - a) / n
    t_prev = a
    g_prev = g_a
    for k in range(1, n + 1):
        t_k = b if k == n else a + k * dt
        f_k, g_k, _ = _dphi(kind, coeffs, px, pz, t_k)
        work += 1
        if f_k < best[1]:
            best[0] = t_k
            best[1] = f_k
        if g_prev <= 0.0 and g_k > 0.0:
            work += _refine_and_offer(kind, coeffs, px, pz, t_prev, t_k, 0.5 * dt, bs)
        t_prev = t_k
        g_prev = g_k
    return work


@nb.njit(**_JIT)
def _scan_leaf(kind, coeffs, aux, px, pz, u, w, bs):
    """Sample g = phi'/2 on [u, u + w] every <= aux[A_STEP], refine every - to + sign
    change, and polish the best sample. A sample interval on which a minimum could hide
    (:func:`_pair_possible`, e.g. two minima near a centre of curvature) is sampled again
    16 times finer, so a minimum between two samples is not lost."""
    n = int(math.ceil(w / aux[A_STEP]))
    if n < 2:
        n = 2
    dt = w / n
    best = bs[B_SAMPLE:B_SAMPLE + 2]
    f_prev, g_prev, gp_prev = _dphi(kind, coeffs, px, pz, u)
    best[0] = u
    best[1] = f_prev
    work = 1
    t_prev = u
    for i in range(1, n + 1):
        t_i = u + w if i == n else u + i * dt
        f_i, g_i, gp_i = _dphi(kind, coeffs, px, pz, t_i)
        work += 1
        if f_i < best[1]:
            best[0] = t_i
            best[1] = f_i
        dz = math.sqrt(max(f_prev, f_i)) + aux[A_SLOPE] * dt
        if _pair_possible(aux, g_prev, g_i, gp_prev, gp_i, dz, dt):
            work += _scan_interval(kind, coeffs, px, pz, t_prev, t_i, f_prev, g_prev, 16, bs, best)
        elif g_prev <= 0.0 and g_i > 0.0:
            work += _refine_and_offer(kind, coeffs, px, pz, t_prev, t_i, 0.5 * dt, bs)
        t_prev = t_i
        f_prev = f_i
        g_prev = g_i
        gp_prev = gp_i
    t, it = _polish(kind, coeffs, px, pz, best[0], max(u, best[0] - dt), min(u + w, best[0] + dt))
    f, g, _ = _dphi(kind, coeffs, px, pz, t)
    work += it + 1
    if abs(g) <= 1e-9 * math.sqrt(f) or f < bs[B_F]:  # a stationary point, or simply better
        _offer(bs, t, f, 0.5 * dt)
    bs[B_WORK] += work


@nb.njit(**_JIT)
def _box_lb(px, pz, u, w, lo, hi):
    """Squared distance from (px, pz) to the box [u, u + w] x [lo, hi]: a lower bound of the
    squared distance to the boundary over that interval."""
    dx = max(0.0, u - px, px - (u + w))
    dz = max(0.0, lo - pz, pz - hi)
    return dx * dx + dz * dz


@nb.njit(**_JIT)
def _descend(kind, coeffs, aux, px, pz, root_u, root_w, n_leaf, table, bs):
    """Depth-first branch and bound over the implicit binary tree on [root_u, root_u + root_w]
    with ``n_leaf`` leaves: a node is pruned when a lower bound of the distance over it is not
    below the best distance so far; a surviving leaf is scanned. Node bounds come from the
    table in ``aux`` or, without one (``table`` False), from a Taylor bound at the centre."""
    nl = int(aux[A_NLEAF])
    bs[B_STACK] = 1.0
    sp = 1
    while sp > 0:
        sp -= 1
        i = int(bs[B_STACK + sp])
        level = 0
        j = i
        while j > 1:
            j >>= 1
            level += 1
        first = 1 << level
        w = root_w / first
        u = root_u + (i - first) * w
        if table:
            lo = aux[A_TREE + i]
            hi = aux[A_TREE + 2 * nl + i]
        else:
            hc, sc, _ = texture_eval(kind, coeffs, u + 0.5 * w)
            bs[B_WORK] += 1.0
            spread = min(aux[A_SLOPE] * 0.5 * w, abs(sc) * 0.5 * w + aux[A_CURV] * 0.125 * w * w)
            lo = hc - spread
            hi = hc + spread
        reach = math.sqrt(bs[B_F]) + aux[A_TIE]
        if _box_lb(px, pz, u, w, lo, hi) > reach * reach:
            continue
        if i >= n_leaf:
            _scan_leaf(kind, coeffs, aux, px, pz, u, w, bs)
            continue
        # the child with the smaller lower bound is popped first (a greedy dive towards the
        # closest leaf, so that the best distance, and with it the pruning, tightens early)
        first_left = px < u + 0.5 * w
        if table:
            hw = 0.5 * w
            lb_l = _box_lb(px, pz, u, hw, aux[A_TREE + 2 * i], aux[A_TREE + 2 * nl + 2 * i])
            lb_r = _box_lb(px, pz, u + hw, hw, aux[A_TREE + 2 * i + 1], aux[A_TREE + 2 * nl + 2 * i + 1])
            first_left = lb_l <= lb_r
        if first_left:
            bs[B_STACK + sp] = 2 * i + 1
            bs[B_STACK + sp + 1] = 2 * i
        else:
            bs[B_STACK + sp] = 2 * i
            bs[B_STACK + sp + 1] = 2 * i + 1
        sp += 2


@nb.njit(**_JIT)
def _ray(kind, coeffs, px, pz, t_end, h_end, s_end, left, bs):
    """Closest point of the straight extension of a non-periodic profile (exact)."""
    t = (px + s_end * (pz - h_end + s_end * t_end)) / (1.0 + s_end * s_end)
    clamped = (left and t > t_end) or (not left and t < t_end)
    if clamped:
        t = t_end
    f, _, _ = _dphi(kind, coeffs, px, pz, t)
    bs[B_WORK] += 1.0
    if clamped:
        _bound(bs, t, f)
    else:
        _offer(bs, t, f, 0.0)


@nb.njit(**_JIT)
def _tree_search(kind, coeffs, aux, px, pz, t_guess, mode, bs):
    """The bounded branch and bound of :func:`closest_point` over the bound tree, from the
    vertical point already in ``bs``: the warm start, the bounds of the texture's mode, the tree."""
    if t_guess == t_guess:
        r = math.sqrt(bs[B_F])  # the vertical depth: the closest point is within it of px
        tg, it = _polish(kind, coeffs, px, pz, t_guess, px - r, px + r)
        f, _, _ = _dphi(kind, coeffs, px, pz, tg)
        bs[B_WORK] += it + 1
        _bound(bs, tg, f)
    nl = int(aux[A_NLEAF])
    if mode == CP_PERIODIC:
        period = aux[A_PERIOD]
        tv = aux[A_TMIN] + period * math.floor((px - aux[A_TMIN]) / period + 0.5)
        f, _, _ = _dphi(kind, coeffs, px, pz, tv)
        bs[B_WORK] += 1.0
        _bound(bs, tv, f)
        # beyond W of px every boundary point is farther than the best: its height is >= hmin
        below = max(aux[A_HMIN] - pz, 0.0)
        half = math.sqrt(max(bs[B_F] - below * below, 0.0)) * (1.0 + 1e-9)
        start = aux[A_START]
        k_lo = math.floor((px - half - start) / period)
        k_hi = math.floor((px + half - start) / period)
        k = k_lo
        while k <= k_hi:
            _descend(kind, coeffs, aux, px, pz, start + k * period, aux[A_TREELEN], nl, True, bs)
            k += 1.0
    elif mode == CP_FINITE:
        f, _, _ = _dphi(kind, coeffs, px, pz, aux[A_TMIN])
        bs[B_WORK] += 1.0
        _bound(bs, aux[A_TMIN], f)
        _ray(kind, coeffs, px, pz, aux[A_X0], aux[A_HL], aux[A_SL], True, bs)
        _ray(kind, coeffs, px, pz, aux[A_XE], aux[A_HR], aux[A_SR], False, bs)
        _descend(kind, coeffs, aux, px, pz, aux[A_START], aux[A_TREELEN], nl, True, bs)
    else:  # CP_OPEN: an aperiodic sum, searched on a window capped at A_WCAP
        below = max(aux[A_HMIN] - pz, 0.0)
        half = min(math.sqrt(max(bs[B_F] - below * below, 0.0)) * (1.0 + 1e-9), aux[A_WCAP])
        leaf = 8.0 * aux[A_STEP]
        n = 1
        while n * leaf < 2.0 * half:
            n *= 2
        _descend(kind, coeffs, aux, px, pz, px - 0.5 * n * leaf, n * leaf, n, False, bs)


@nb.njit(**_JIT)
def closest_point(kind, coeffs, aux, px, pz, t_guess, bs):
    """Closest point abscissa t on the boundary z = h(x) to a point (px, pz) below it.

    Bounded branch and bound (see :func:`haptex.closest.closest_point` for the argument):
    upper bounds from the vertical point, a warm start ``t_guess`` (NaN for none), the
    nearest global minimum of h and the straight extensions of a finite profile; then the
    bound tree prunes every part of the boundary that cannot be closer. ``bs`` is scratch
    of length N_SEARCH. Returns (t, distance, tie, work): tie is 1 when another, distinct
    local minimum lies at the same distance to aux[A_TIE] + 1e-9 times the distance
    (the medial axis), work the number of texture evaluations spent.
    """
    return closest_point_below(kind, coeffs, aux, px, pz, texture_height(kind, coeffs, px) - pz, t_guess, bs)


@nb.njit(**_JIT)
def closest_point_below(kind, coeffs, aux, px, pz, dv, t_guess, bs):
    """:func:`closest_point` given the vertical depth dv = h(px) - pz (m) the caller has
    already evaluated."""
    if dv <= 0.0:
        return px, 0.0, 0, 1
    bs[B_F] = dv * dv
    bs[B_T] = px
    bs[B_SECOND] = math.inf
    bs[B_FOUND] = 0.0
    bs[B_WORK] = 1.0
    mode = int(aux[A_MODE])
    if mode == CP_VERTICAL:  # flat: the vertical point is the closest
        return px, dv, 0, 1
    if aux[A_TABLE] == 0.0 or not _table_search(kind, coeffs, aux, px, pz, t_guess, bs):
        _tree_search(kind, coeffs, aux, px, pz, t_guess, mode, bs)
    best_f = bs[B_F]
    second = bs[B_SECOND]
    tie = 0
    if second < math.inf and math.sqrt(second) - math.sqrt(best_f) <= min(aux[A_TIE], 1e-9 * math.sqrt(best_f)):
        tie = 1
    return bs[B_T], math.sqrt(best_f), tie, int(bs[B_WORK])


@nb.njit(parallel=True, cache=True, nogil=True)
def closest_points(kind, coeffs, aux, px, pz, t_out, d_out, tie_out, work_out):
    """Vectorised :func:`closest_point` over flat arrays ``px``, ``pz`` (no warm start),
    in parallel over the cores."""
    for i in nb.prange(px.shape[0]):
        bs = np.empty(N_SEARCH)
        t, d, tie, work = closest_point(kind, coeffs, aux, px[i], pz[i], math.nan, bs)
        t_out[i] = t
        d_out[i] = d
        tie_out[i] = tie
        work_out[i] = work


# ----------------------------------------------------------------------------------------
# The cell table: the closest-point search of a servo tick in constant work (D and E over a
# periodic profile). Probe positions are cut into square cells of side w in (x mod period,
# z); for each cell, built once, the few pieces of the boundary that can hold the closest
# point of *any* probe in it, each certified either convex (one Newton solve) or not (scanned).
# ----------------------------------------------------------------------------------------
T_X0, T_PERIOD, T_W, T_NX, T_Z0, T_NZ = range(6)
T_CELLS = 6
"""Table layout from aux[A_TABLE]: the header T_*, then per cell (row-major, x fastest) the
index in ``aux`` of its first piece and its number of pieces (-1: search the tree), then the
pieces (lo, hi, kind, m, G): lo and hi relative to the start of the cell's period (m); on a
convex piece, a lower bound m of g' and an upper bound G of |g''| over it for every probe of
the cell, g = phi'/2 (m/m, 1/m)."""
PIECE = 5
PIECE_NEWTON, PIECE_SCAN = 0.0, 1.0
TABLE_FINE = 8
"""A cell's pieces are built from intervals of at most its width / TABLE_FINE."""
TABLE_TOP = 32
"""The first cut of a cell's search window when its pieces are built (then halved as needed)."""
TABLE_MAXP = 16
"""Most pieces a cell may hold; a cell that would need more is searched by the tree."""


@nb.njit(inline="always", **_JIT)
def _convex_min(kind, coeffs, px, pz, lo, hi, m, G, t0, bs):
    """Minimum of phi over [lo, hi] where g = phi'/2 has g' >= m > 0 and |g''| <= G: Newton
    from t0 inside a bracket, an end evaluated only when a step leaves the piece. The Newton
    step tn from t is returned as soon as its error is certified below 1e-15 (1 + |t|) m
    (|t - t*| <= |g(t)| / m and |tn - t*| <= G / (2 g'(t)) (t - t*)^2), or the step itself is
    that small (the tree's criterion, :func:`_refine_bracket`; where m is small, rounding in g
    can keep the certificate out of reach). Returns (t, f), and adds the work to bs[B_WORK]."""
    a = lo
    b = hi
    a_known = False
    b_known = False
    t = min(max(t0, lo), hi)
    work = 0
    for _ in range(64):
        h, s, c = texture_eval(kind, coeffs, t)
        dz = h - pz
        g = (t - px) + dz * s
        gp = 1.0 + s * s + dz * c
        work += 1
        if g > 0.0:
            b = t
            b_known = True
        else:
            a = t
            a_known = True
        tn = t - g / gp if gp > 0.0 else 0.5 * (a + b)
        e = g / m
        if lo <= tn <= hi and (G / (2.0 * gp) * e * e <= 1e-15 * (1.0 + abs(t)) or abs(tn - t) <= 1e-15 * (1.0 + abs(t))):
            bs[B_WORK] += work
            u = tn - t  # h(tn) by Taylor: its error, A_JERK |u|^3 / 6, is far below rounding here
            dz = h + u * (s + 0.5 * u * c) - pz
            return tn, (tn - px) * (tn - px) + dz * dz
        if tn <= a or tn >= b:
            if tn <= a and not a_known:  # the minimum may be the piece's left end
                fa, ga, _ = _dphi(kind, coeffs, px, pz, lo)
                work += 1
                if ga >= 0.0:
                    bs[B_WORK] += work
                    return lo, fa
                a_known = True
            elif tn >= b and not b_known:
                fb, gb, _ = _dphi(kind, coeffs, px, pz, hi)
                work += 1
                if gb <= 0.0:
                    bs[B_WORK] += work
                    return hi, fb
                b_known = True
            tn = 0.5 * (a + b)
        t = tn
        if b - a <= 1e-16 * (1.0 + abs(t)):
            break
    t = min(max(t, lo), hi)
    f, _, _ = _dphi(kind, coeffs, px, pz, t)
    bs[B_WORK] += work + 1
    return t, f


@nb.njit(inline="always", **_JIT)
def _table_search(kind, coeffs, aux, px, pz, t_guess, bs):
    """The closest point from the cell table at aux[A_TABLE] (see ``T_CELLS``): minimise phi on
    each of the cell's pieces (Newton on a convex one, :func:`_scan_leaf` on the others) and
    offer each minimum. False, with nothing done, when the probe is outside the table or its
    cell has too many pieces: the caller then searches the tree."""
    o = int(aux[A_TABLE])
    w = aux[o + T_W]
    nx = int(aux[o + T_NX])
    jz = math.floor((pz - aux[o + T_Z0]) / w)
    if not (0.0 <= jz < aux[o + T_NZ]):
        return False
    period = aux[o + T_PERIOD]
    base = aux[o + T_X0] + period * math.floor((px - aux[o + T_X0]) / period)
    ix = int((px - base) / w)
    ix = min(max(ix, 0), nx - 1)
    c = o + T_CELLS + 2 * (int(jz) * nx + ix)
    n = int(aux[c + 1])
    if n < 0:
        return False
    first = int(aux[c])
    guess = t_guess if t_guess == t_guess else px
    sep = w / TABLE_FINE
    for k in range(n):
        q = first + PIECE * k
        lo = base + aux[q]
        hi = base + aux[q + 1]
        if aux[q + 2] == PIECE_NEWTON:
            t, f = _convex_min(kind, coeffs, px, pz, lo, hi, aux[q + 3], aux[q + 4], guess, bs)
            _offer(bs, t, f, sep)
        else:
            _scan_leaf(kind, coeffs, aux, px, pz, lo, hi - lo, bs)
    return True


@nb.njit(**_JIT)
def _cell_pieces(kind, coeffs, aux, period, x0, w, cx, zlo, zhi, row):
    """The pieces of one cell (see :func:`build_cell_table`) into ``row``; returns their number,
    TABLE_MAXP + 1 as soon as there are more than TABLE_MAXP. ``aux`` is the search data
    without a table."""
    S = aux[A_SLOPE]
    C = aux[A_CURV]
    J = aux[A_JERK]
    L = math.sqrt(1.0 + S * S)
    r = 0.5 * w * math.sqrt(2.0) * (1.0 + 1e-9) + 1e-9 * w
    cz = 0.5 * (zlo + zhi)
    hc = texture_height(kind, coeffs, cx)
    if zlo > hc + S * 0.5 * w + 1e-9 * w:  # the whole cell is above the boundary: no probe of it searches
        return 0
    tmin = aux[A_TMIN]
    U = abs(hc - cz)
    tv = tmin + period * math.floor((cx - tmin) / period + 0.5)
    U = min(U, math.hypot(tv - cx, texture_height(kind, coeffs, tv) - cz))
    if cz < hc:  # the centre's own distance, from the bound tree
        _, dc, _, _ = closest_point(kind, coeffs, aux, cx, cz, math.nan, np.empty(N_SEARCH))
        U = min(U, dc)
    else:  # the best of a few boundary points
        for k in range(TABLE_TOP + 1):
            t = cx - U + 2.0 * U * k / TABLE_TOP
            U = min(U, math.hypot(t - cx, texture_height(kind, coeffs, t) - cz))
    reach = U + 2.0 * r
    R = reach
    # dyadic intervals of the window [cx - R, cx + R]: TABLE_TOP at level 0, the finest (at most
    # w / TABLE_FINE wide) at level nlev; interval (l, i) covers the finest ones i 2^(nlev - l)
    # to (i + 1) 2^(nlev - l) - 1, of width dt each
    nlev = 0
    while 2.0 * R / (TABLE_TOP << nlev) > w / TABLE_FINE:
        nlev += 1
    dt = 2.0 * R / (TABLE_TOP << nlev)
    # depth-first, left first (pieces come in increasing t); an entry: level, index, then
    # (d, h, h', h'') at its left and right ends
    stk = np.empty((TABLE_TOP + 2 * nlev + 2, 10))
    sp = 0
    hb, sb, cb = texture_eval(kind, coeffs, cx + R)
    db = math.hypot(R, hb - cz)
    for k in range(TABLE_TOP - 1, -1, -1):
        ta = cx - R + (k << nlev) * dt
        ha, sa, ca = texture_eval(kind, coeffs, ta)
        da = math.hypot(ta - cx, ha - cz)
        e = stk[sp]
        e[0] = 0.0
        e[1] = k
        e[2], e[3], e[4], e[5] = da, ha, sa, ca
        e[6], e[7], e[8], e[9] = db, hb, sb, cb
        sp += 1
        db, hb, sb, cb = da, ha, sa, ca
    npc = 0
    cur = -1.0  # kind of the open piece, -1 none
    last = -2  # the last finest index in the open piece
    while sp > 0:
        sp -= 1
        e = stk[sp]
        lev = int(e[0])
        idx = int(e[1])
        da, ha, sa, ca = e[2], e[3], e[4], e[5]
        db, hb, sb, cb = e[6], e[7], e[8], e[9]
        span = 1 << (nlev - lev)
        width = span * dt
        if 0.5 * (da + db - L * width) > reach:  # no point of it within reach of the centre
            continue
        # classified at most a cell wide (wider, the bounds m and G of a piece would be loose)
        qa0 = 1.0 + sa * sa + (ha - zlo) * ca
        qa1 = 1.0 + sa * sa + (ha - zhi) * ca
        qb0 = 1.0 + sb * sb + (hb - zlo) * cb
        qb1 = 1.0 + sb * sb + (hb - zhi) * cb
        G = 3.0 * S * C + (max(abs(ha - zlo), abs(ha - zhi)) + S * width) * J
        qmin = 0.5 * (min(qa0, qa1) + min(qb0, qb1) - G * width)
        if width <= w and qmin > 0.0:
            cls = PIECE_NEWTON
        elif width <= w and 0.5 * (max(qa0, qa1) + max(qb0, qb1) + G * width) < 0.0:
            continue  # strictly concave: no minimum inside; its ends belong to its neighbours
        elif lev < nlev:  # undecided or too wide: split at the midpoint
            tm = cx - R + (2 * idx + 1) * (span // 2) * dt
            hm, sm, cm = texture_eval(kind, coeffs, tm)
            dm = math.hypot(tm - cx, hm - cz)
            f = stk[sp + 1]
            f[0] = lev + 1
            f[1] = 2 * idx
            f[2], f[3], f[4], f[5] = da, ha, sa, ca
            f[6], f[7], f[8], f[9] = dm, hm, sm, cm
            e[0] = lev + 1
            e[1] = 2 * idx + 1
            e[2], e[3], e[4], e[5] = dm, hm, sm, cm
            sp += 2
            continue
        else:
            cls = PIECE_SCAN
        first = idx * span
        ta = cx - R + first * dt
        tb = cx - R + (first + span) * dt
        if cls == cur and first == last + 1:  # extend the open piece
            q = PIECE * (npc - 1)
            row[q + 1] = tb - x0
            row[q + 3] = min(row[q + 3], qmin)
            row[q + 4] = max(row[q + 4], G)
        else:
            npc += 1
            if npc > TABLE_MAXP:  # too many: the cell's probes search the tree (and so stops the work here)
                return npc
            q = PIECE * (npc - 1)
            row[q] = ta - x0
            row[q + 1] = tb - x0
            row[q + 2] = cls
            row[q + 3] = qmin
            row[q + 4] = G
            cur = cls
        last = first + span - 1
    return npc


@nb.njit(parallel=True, cache=True, nogil=True)
def build_cell_table(kind, coeffs, aux, x0, w, nx, zlo, hmax, count, out):
    """One row of cells of the table: count[i] (-1: more than TABLE_MAXP) and out[i] (shape
    (nx, PIECE TABLE_MAXP)) the pieces (lo, hi, kind, m, G) of the cell [x0 + i w, x0 + (i+1) w]
    x [zlo, zlo + w], lo and hi relative to x0 (see ``T_CELLS``).

    With c the cell's centre and r its half-diagonal, every probe p in it has d(p) <= U + r, U
    any distance from c to a boundary point (the distance is 1-Lipschitz), so its closest point
    is within U + 2 r of c (U: c's distance from the bound tree when c is below the boundary).
    The window |t - c_x| <= U + 2 r is cut in dyadic intervals. An interval is dropped when it
    cannot come that close (between samples the distance to c changes by at most
    sqrt(1 + sup h'^2) per unit of t); it is *convex* when g' = phi''/2 = 1 + h'^2 + (h - p_z) h''
    > 0 on it for every p_z of the cell (linear in p_z: checked at both ends; between samples its
    t-derivative is at most 3 sup|h'| sup|h''| + |h - p_z| A_JERK); dropped when < 0 there
    (strictly concave: no minimum inside, its ends belong to its neighbours); else halved, down
    to w / TABLE_FINE, where it is kept to be scanned. Consecutive kept intervals of one kind
    are merged into a piece.
    """
    period = aux[A_PERIOD]
    for i in nb.prange(nx):
        count[i] = 0.0
        if zlo > hmax:  # every probe of the cell is above the boundary
            continue
        n = _cell_pieces(kind, coeffs, aux, period, x0, w, x0 + (i + 0.5) * w, zlo, zlo + w, out[i])
        count[i] = n if n <= TABLE_MAXP else -1.0


@nb.njit(**_JIT)
def _cubic_floor(h, d1, d2, jerk, s):
    """min over u in [0, s] of h + d1 u + d2 u^2/2 - jerk u^3/6: a lower bound of a function
    with value h, slope d1 and curvature d2 at u = 0 and |third derivative| <= jerk."""
    best = min(h, h + s * (d1 + s * (0.5 * d2 - s * jerk / 6.0)))
    if jerk > 0.0:
        disc = d2 * d2 + 2.0 * jerk * d1
        if disc >= 0.0:
            for u in ((d2 + math.sqrt(disc)) / jerk, (d2 - math.sqrt(disc)) / jerk):
                if 0.0 < u < s:
                    best = min(best, h + u * (d1 + u * (0.5 * d2 - u * jerk / 6.0)))
    return best


@nb.njit(**_JIT)
def fourier_leaf_bounds(coeffs, start, width, n_leaf, n_sub, jerk, lo, hi):
    """Bounds of a Fourier-series h over ``n_leaf`` leaves of ``width`` from ``start``.

    Each leaf is sampled at ``n_sub`` + 1 points (spacing s). Where h' changes sign between
    two samples the extremum is located by bracketed Newton and its value taken (one
    extremum per sign change: s is 1/64 of the shortest period). Elsewhere h is bounded
    by the larger of the two third-order Taylor floors from the interval's ends (``jerk``
    bounds the third derivative), which is the smaller end value wherever h is monotone.
    Fills lo[i], hi[i] (leaf i) and returns (t, h) of the smallest height found.
    """
    s = width / n_sub
    best_t = start
    best_h = math.inf
    for i in range(n_leaf):
        u = start + i * width
        h0, d0, c0 = texture_eval(TEXTURE_FOURIER, coeffs, u)
        l = h0
        m = h0
        if h0 < best_h:
            best_h = h0
            best_t = u
        for k in range(1, n_sub + 1):
            t1 = u + k * s
            h1, d1, c1 = texture_eval(TEXTURE_FOURIER, coeffs, t1)
            l = min(l, h1)
            m = max(m, h1)
            if h1 < best_h:
                best_h = h1
                best_t = t1
            if (d0 < 0.0) != (d1 < 0.0):
                a = t1 - s
                b = t1
                neg_at_a = d0 < 0.0
                t = 0.5 * (a + b)
                for _ in range(80):
                    _, dd, cc = texture_eval(TEXTURE_FOURIER, coeffs, t)
                    if (dd < 0.0) == neg_at_a:
                        a = t
                    else:
                        b = t
                    tn = t - dd / cc if cc != 0.0 else 0.5 * (a + b)
                    if not (min(a, b) < tn < max(a, b)):
                        tn = 0.5 * (a + b)
                    if abs(tn - t) <= 1e-16 * (1.0 + abs(t)):
                        t = tn
                        break
                    t = tn
                he, _, _ = texture_eval(TEXTURE_FOURIER, coeffs, t)
                l = min(l, he)
                m = max(m, he)
                if he < best_h:
                    best_h = he
                    best_t = t
            else:
                floor = max(_cubic_floor(h0, d0, c0, jerk, s), _cubic_floor(h1, -d1, c1, jerk, s))
                ceil = -max(_cubic_floor(-h0, -d0, -c0, jerk, s), _cubic_floor(-h1, d1, -c1, jerk, s))
                l = min(l, floor)
                m = max(m, ceil)
            h0 = h1
            d0 = d1
            c0 = c1
        lo[i] = l
        hi[i] = m
    return best_t, best_h


def empty_coeffs() -> np.ndarray:
    """Coefficient array for ``TEXTURE_FLAT``."""
    return np.zeros((3, 0), dtype=np.float64)


# ----------------------------------------------------------------------------------------
# Algorithm force kernels: one scalar entry point for every letter, dispatched by code.
# ----------------------------------------------------------------------------------------
# ALG_* and the parameter vector's layout P_* (float64[N_PARAMS]): the C core's, imported above
# state vector layout: F's adhesion point (D, E over a profile: the last closest point, a
# warm start), in-contact flag, last x, the work (texture evaluations) of the last call; over
# a surface F's adhesion y and last y; the height h under the probe that the last call
# evaluated (NaN if it did not) and the algorithm's penetration there (>= 0, Table I); then
# the closest-point search's scratch (a profile's, or a surface's quadtree stack)
S_ADH, S_CONTACT, S_LASTX, S_WORK, S_ADHY, S_LASTY, S_H, S_PEN = range(8)
S_SEARCH = 8
N_STATE = S_SEARCH + max(N_SEARCH, 4 + 3 * 512)


@nb.njit(**_JIT)
def _clamp_depth(d, dzmax):
    """Lateral depth of Remark 3: max(d, -d_max) when d_max > 0 (d < 0 inside)."""
    if dzmax > 0.0 and d < -dzmax:
        return -dzmax
    return d


# presliding friction (Hayward & Armstrong 2000), used by haptex.friction and by F
@nb.njit(**_JIT)
def presliding_step(adhesion, x, d_max):
    """Compiled scalar update of the sharp presliding model (eq. 24).

    Parameters
    ----------
    adhesion : float
        Adhesion point w before the step (m).
    x : float
        New position (m).
    d_max : float
        Maximum presliding deflection (m), > 0.

    Returns
    -------
    (deflection, adhesion) : (float, float)
        The deflection d = x - w after the step (m) and the new adhesion point (m).
    """
    d = x - adhesion
    if d > d_max:
        return d_max, x - d_max
    if d < -d_max:
        return -d_max, x + d_max
    return d, adhesion


# table of the smooth presliding model (built by haptex.friction.smooth_table), in units of
# d_max: X(e) = distance travelled from the start of the ramp (|d| = z_stick) to e = 1 - |d|/d_max,
# tabulated with its derivative at e_j = r exp(-j dv), r = 1 - z_stick/d_max
from .core._ext import T_BETA, T_DATA, T_DV, T_LOGR, T_N  # noqa: E402  (the C core's layout)


@nb.njit(**_JIT)
def _hermite(tab, j, th):
    """X at node j + th (0 <= th <= 1) and dX/dth, cubic Hermite."""
    n = int(tab[T_N])
    x0 = tab[T_DATA + j]
    x1 = tab[T_DATA + j + 1]
    m0 = tab[T_DATA + n + j]
    m1 = tab[T_DATA + n + j + 1]
    t2 = th * th
    t3 = t2 * th
    val = (2 * t3 - 3 * t2 + 1) * x0 + (t3 - 2 * t2 + th) * m0 + (-2 * t3 + 3 * t2) * x1 + (t3 - t2) * m1
    der = (6 * t2 - 6 * th) * x0 + (3 * t2 - 4 * th + 1) * m0 + (-6 * t2 + 6 * th) * x1 + (3 * t2 - 2 * th) * m1
    return val, der


@nb.njit(**_JIT)
def presliding_step_smooth(deflection, dx, d_max, z_stick, tab):
    """Compiled update of the smooth variant: the exact flow of dd/dx over an increment dx.

    Parameters
    ----------
    deflection : float
        Deflection before the step (m).
    dx : float
        Displacement of the probe during the step (m).
    d_max, z_stick : float
        Model parameters (m), 0 <= z_stick < d_max.
    tab : ndarray
        The model's travel table (:func:`haptex.friction.smooth_table`).

    Returns
    -------
    float
        Deflection after the step (m), |d| <= d_max.

    Notes
    -----
    Bounded work for any dx: the elastic part is exact; along the ramp the travel
    X(e) = int de / rate is tabulated once (cubic Hermite, relative error < 1e-10) and
    inverted by bisection-safeguarded Newton (at most 60 iterations); below the table's
    last node (e < 1e-16 r) the flow of rate = e + (pi e / 2r)^2 is used in closed form.
    """
    return _smooth_flow(deflection, dx, d_max, z_stick, tab)[0]


@nb.njit(**_JIT)
def _smooth_flow(deflection, dx, d_max, z_stick, tab):
    """:func:`presliding_step_smooth` and its work: (deflection, table steps), where a table
    step is one node comparison of the bisection or one Hermite evaluation of the Newton
    inversion (at most 11 + 60 with the 2,048-node table)."""
    if dx == 0.0:
        return deflection, 0
    s = 1.0 if dx > 0.0 else -1.0
    a = deflection * s  # deflection along the motion
    rem = abs(dx)
    if a < z_stick:  # purely elastic until |d| = z_stick in the direction of motion
        if a + rem <= z_stick:
            return s * (a + rem), 0
        rem -= z_stick - a
        a = z_stick
    r = 1.0 - z_stick / d_max
    e = 1.0 - a / d_max
    if e <= 0.0:
        return s * d_max, 0
    n = int(tab[T_N])
    dv = tab[T_DV]
    logr = tab[T_LOGR]
    travel = rem / d_max
    jl = (logr - math.log(e)) / dv  # continuous node index of e
    work = 0
    if jl < n - 1:
        j0 = int(jl)
        if j0 < 0:
            j0 = 0
        x_start, _ = _hermite(tab, j0, jl - j0)
        target = x_start + travel
        if target < tab[T_DATA + n - 1]:
            lo = j0
            hi = n - 1
            while hi - lo > 1:  # the node interval holding the target
                work += 1
                mid = (lo + hi) // 2
                if tab[T_DATA + mid] <= target:
                    lo = mid
                else:
                    hi = mid
            a_th = 0.0
            b_th = 1.0
            th = 0.5
            for _ in range(60):
                work += 1
                val, der = _hermite(tab, lo, th)
                if val < target:
                    a_th = th
                else:
                    b_th = th
                tn = th - (val - target) / der if der > 0.0 else 0.5 * (a_th + b_th)
                if not (a_th <= tn <= b_th):
                    tn = 0.5 * (a_th + b_th)
                if abs(tn - th) <= 1e-15:
                    th = tn
                    break
                th = tn
            e = r * math.exp(-(lo + th) * dv)
            return s * d_max * (1.0 - e), work
        travel = target - tab[T_DATA + n - 1]
        e = r * math.exp(-(n - 1) * dv)
    # tail: de/dx = -(e + beta e^2), exact logistic flow
    beta = tab[T_BETA]
    g = (1.0 / e + beta) * math.exp(travel) - beta
    e = 1.0 / g if g < math.inf else 0.0
    return s * d_max * (1.0 - e), work


@nb.njit(**_JIT)
def _presliding(st, x, dxmax, zstick, tab):
    """Advance F's friction state to x (see haptex.friction); returns the deflection and
    adds the table steps of the smooth variant to st[S_WORK]."""
    if zstick < 0.0:
        d, st[S_ADH] = presliding_step(st[S_ADH], x, dxmax)
    else:
        d, work = _smooth_flow(st[S_LASTX] - st[S_ADH], x - st[S_LASTX], dxmax, zstick, tab)
        st[S_ADH] = x - d
        st[S_WORK] += work
    st[S_LASTX] = x
    return d


@nb.njit(inline="always", **_JIT)
def _warm_guess(st, aux):
    """D's and E's warm start over a profile: the last closest point st[S_ADH], moved on by
    its last step (st[S_LASTX] the one before) when that step was under a thousandth of the
    shortest period; NaN before the first contact. Only a guess: the search certifies the
    global minimum whatever it is."""
    if st[S_CONTACT] == 0.0:
        return math.nan
    t = st[S_ADH]
    if st[S_CONTACT] == 2.0:
        step = t - st[S_LASTX]
        if abs(step) < 1e6 * aux[A_TIE]:  # A_TIE is 1e-9 of the shortest period
            t += step
    return t


@nb.njit(inline="always", **_JIT)
def _keep_guess(st, t):
    """Record the closest point t for :func:`_warm_guess` (contact 1: one point, 2: two)."""
    st[S_CONTACT] = 2.0 if st[S_CONTACT] != 0.0 else 1.0
    st[S_LASTX] = st[S_ADH]
    st[S_ADH] = t


@nb.njit(inline="always", **_JIT)
def alg_force(code, x, z, kind, coeffs, prm, aux, st):
    """Force (fx, fz) in N of algorithm ``code`` at the probe position (x, z) in m.

    Mirrors the vectorised ``force`` of :mod:`haptex.algorithms` (the tests compare them).
    ``aux`` is the closest-point search data (D, E) or the smooth presliding table (F).
    ``st`` (length N_STATE) is the algorithm's state, updated in place: F's friction state
    (contact starts with zero deflection, leaving the wall resets it), D's and E's warm
    start, and st[S_WORK], the work this call spent: texture evaluations, plus F's
    presliding table steps.
    """
    k0 = prm[P_K0]
    st[S_WORK] = 1.0
    st[S_H] = math.nan
    st[S_PEN] = max(-z, 0.0)
    if code == ALG_W:  # prm[P_MU] is W's virtual damping B, prm[P_DXMAX] its servo period T
        fz = 0.0
        if z < 0.0:
            fz = -k0 * z
            if prm[P_MU] != 0.0 and st[S_CONTACT] != 0.0:
                fz -= prm[P_MU] * (z - st[S_LASTX]) / prm[P_DXMAX]
        st[S_LASTX] = z  # the previous sensed p^z, for the backward difference
        st[S_CONTACT] = 1.0
        return 0.0, fz
    if code == ALG_F or code == ALG_G:
        if z >= 0.0:
            st[S_CONTACT] = 0.0
            return 0.0, 0.0
        if code == ALG_G:
            h, s, c = texture_eval(kind, coeffs, x)
            st[S_H] = h
            g = 1.0 / math.sqrt(1.0 + s * s)
            dl = _clamp_depth(z, prm[P_DZMAX])
            return k0 * dl * s * g, -k0 * z * g
        if st[S_CONTACT] == 0.0:
            st[S_CONTACT] = 1.0
            st[S_ADH] = x
            st[S_LASTX] = x
        d = _presliding(st, x, prm[P_DXMAX], prm[P_ZSTICK], aux)
        h = texture_height(kind, coeffs, x)
        st[S_H] = h
        depth = -z
        if prm[P_DZMAX] > 0.0 and depth > prm[P_DZMAX]:
            depth = prm[P_DZMAX]
        m = 1.0 - prm[P_SCALE] * h
        return -prm[P_MU] * k0 * depth * m * d / prm[P_DXMAX], -k0 * z
    if code == ALG_B or code == ALG_C:
        h, s, c = texture_eval(kind, coeffs, x)
    else:
        h = texture_height(kind, coeffs, x)
        s = 0.0
    st[S_H] = h
    d = z - h
    st[S_PEN] = max(-d, 0.0)
    if d >= 0.0:
        return 0.0, 0.0
    if code == ALG_A:
        return 0.0, -k0 * d
    if code == ALG_B:
        g = 1.0 / math.sqrt(1.0 + s * s)
        return k0 * _clamp_depth(d, prm[P_DZMAX]) * s * g, -k0 * d * g
    if code == ALG_C:
        return k0 * _clamp_depth(d, prm[P_DZMAX]) * s, -k0 * d
    t, dist, tie, work = closest_point_below(kind, coeffs, aux, x, z, -d, _warm_guess(st, aux), st[S_SEARCH:])
    _keep_guess(st, t)
    st[S_WORK] = work
    st[S_PEN] = dist
    if code == ALG_D:
        return -k0 * (x - t), -k0 * (z - texture_height(kind, coeffs, t))
    return 0.0, k0 * dist  # ALG_E


# ----------------------------------------------------------------------------------------
# Closest point on a surface z = h(x, y) of gratings (D and E over surfaces): branch and
# bound over a quadtree of cells, Taylor bounds of h on each cell.
# ----------------------------------------------------------------------------------------
# ``gcoeffs`` has shape (4, n): amplitudes a (m), wave-vector components kx, ky (rad/m),
# phases (rad); h = sum a sin(kx x + ky y + phase). ``gaux``: the search's constants.
# the search constants' slots G_* are the C core's (hx_core.h)
from .core._ext import (G_CONVEX, G_CURV, G_CURV_BOUND, G_HMAX, G_HMIN, G_JERK, G_LEAF,  # noqa: E402, F401
                        G_BUDGET, G_EDGE, G_SLOPE, G_SLOPE_BOUND, G_TIE, N_E, N_GAUX)  # noqa: F401
# SURFACE_GRATINGS, SURFACE_PATCHES: the C core's, imported above
"""Surface kinds of the search: a sum of gratings (``sc`` of shape (4, n): a, kx, ky, phase)
or bicubic patches (``sc`` of shape (1, 8 + 16 n): the header PATCH_* then, per cell in row-major
order (i along x), the 16 coefficients c[a, b] of s^a t^b, s and t the cell's local
coordinates in [0, 1])."""
(PATCH_X0, PATCH_Y0, PATCH_DX, PATCH_DY, PATCH_NX, PATCH_NY, PATCH_PERIODIC) = range(7)
PATCH_DATA = 8
SURF_STACK = 512
"""Cells the quadtree search may hold pending (depth-first: 3 per level; far above need)."""
MAX_SURF_LEAVES = 1 << 16
"""Most leaves one surface search may refine (its work bound: each leaf a local Newton)."""
MAX_SURF_NODES = 1 << 11
"""Most cells one surface search may examine by its Taylor model; beyond, cells are leaves
(not certified). Searches use at most about 400 on the paper's egg-crate 0-1 mm deep; probes
hundreds of metres deep, where the Taylor bound is useless, hit it (about 19,000 evaluations
then, against 627,000 at 2^16)."""


@nb.njit(**_JIT)
def grating_eval(gc, x, y):
    """(h, h_x, h_y, h_xx, h_xy, h_yy) of a sum of gratings at (x, y)."""
    h = 0.0
    gx = 0.0
    gy = 0.0
    hxx = 0.0
    hxy = 0.0
    hyy = 0.0
    for i in range(gc.shape[1]):
        a = gc[0, i]
        kx = gc[1, i]
        ky = gc[2, i]
        arg = kx * x + ky * y + gc[3, i]
        sn = math.sin(arg)
        cs = math.cos(arg)
        h += a * sn
        gx += a * kx * cs
        gy += a * ky * cs
        hxx -= a * kx * kx * sn
        hxy -= a * kx * ky * sn
        hyy -= a * ky * ky * sn
    return h, gx, gy, hxx, hxy, hyy


@nb.njit(**_JIT)
def _patch_derivs(sc, x, y):
    """All derivatives d^(a+b) h / dx^a dy^b, a, b <= 3, of the bicubic patch holding (x, y)
    (clamped to the map), as a 4 x 4 array, and the clamped point."""
    hd = sc[0]
    dx = hd[PATCH_DX]
    dy = hd[PATCH_DY]
    nx = int(hd[PATCH_NX])
    ny = int(hd[PATCH_NY])
    u = (x - hd[PATCH_X0]) / dx
    v = (y - hd[PATCH_Y0]) / dy
    cx = x  # the nearest point of the map: p itself unless clamped
    cy = y
    if hd[PATCH_PERIODIC] != 0.0:
        u = u - nx * math.floor(u / nx)
        v = v - ny * math.floor(v / ny)
    else:
        if u < 0.0 or u > nx:
            u = min(max(u, 0.0), float(nx))
            cx = hd[PATCH_X0] + u * dx
        if v < 0.0 or v > ny:
            v = min(max(v, 0.0), float(ny))
            cy = hd[PATCH_Y0] + v * dy
    i = min(int(u), nx - 1)
    j = min(int(v), ny - 1)
    s_ = u - i
    t_ = v - j
    base = PATCH_DATA + 16 * (i * ny + j)
    out = np.zeros((4, 4))
    # d^p/ds^p d^q/dt^q of sum c[a, b] s^a t^b, scaled to x and y by dx^-p dy^-q
    for a in range(4):
        for b in range(4):
            c = sc[0, base + 4 * a + b]
            if c == 0.0:
                continue
            for pd in range(a + 1):
                fa = 1.0
                for k in range(pd):
                    fa *= a - k
                sa = s_ ** (a - pd)
                for qd in range(b + 1):
                    fb = 1.0
                    for k in range(qd):
                        fb *= b - k
                    out[pd, qd] += c * fa * fb * sa * t_ ** (b - qd)
    for pd in range(4):
        for qd in range(4):
            out[pd, qd] /= dx ** pd * dy ** qd
    return out, cx, cy


@nb.njit(**_JIT)
def patch_eval(sc, x, y):
    """(h, h_x, h_y, h_xx, h_xy, h_yy) of a bicubic height map at (x, y): the spline inside;
    outside a non-periodic map its tangent-plane extension h(c) + grad h(c) . (p - c), c the
    nearest point of the map (as haptex.SampledSurface evaluates it)."""
    D, cx, cy = _patch_derivs(sc, x, y)
    dx = x - cx
    dy = y - cy
    if dx == 0.0 and dy == 0.0:
        return D[0, 0], D[1, 0], D[0, 1], D[2, 0], D[1, 1], D[0, 2]
    ox = dx != 0.0
    oy = dy != 0.0
    h = D[0, 0] + D[1, 0] * dx + D[0, 1] * dy
    gx = D[1, 0] if ox else D[1, 0] + D[2, 0] * dx + D[1, 1] * dy
    gy = D[0, 1] if oy else D[0, 1] + D[1, 1] * dx + D[0, 2] * dy
    hxx = 0.0 if ox else D[2, 0] + D[3, 0] * dx + D[2, 1] * dy
    hyy = 0.0 if oy else D[0, 2] + D[1, 2] * dx + D[0, 3] * dy
    m = int(ox) + int(oy)
    hxy = D[1, 1] + D[2, 1] * dx + D[1, 2] * dy if m == 0 else (D[1, 1] if m == 1 else 0.0)
    return h, gx, gy, hxx, hxy, hyy


@nb.njit(**_JIT)
def surf_eval(kind, sc, x, y):
    """(h, h_x, h_y, h_xx, h_xy, h_yy) of a surface of kind SURFACE_GRATINGS or SURFACE_PATCHES."""
    if kind == SURFACE_PATCHES:
        return patch_eval(sc, x, y)
    return grating_eval(sc, x, y)


@nb.njit(**_JIT)
def _patch_range(sc, gaux, cx, cy, w):
    """Rigorous (min h, max h) over a square cell of a height map: outside a non-periodic map
    the extension moves at most sup |grad h| per metre beyond the map's range."""
    hd = sc[0]
    if hd[PATCH_PERIODIC] != 0.0:
        return gaux[G_HMIN], gaux[G_HMAX]
    x0 = hd[PATCH_X0]
    y0 = hd[PATCH_Y0]
    x1 = x0 + hd[PATCH_NX] * hd[PATCH_DX]
    y1 = y0 + hd[PATCH_NY] * hd[PATCH_DY]
    ox = max(0.0, x0 - (cx - w), (cx + w) - x1)
    oy = max(0.0, y0 - (cy - w), (cy + w) - y1)
    out = math.sqrt(ox * ox + oy * oy) * gaux[G_SLOPE]
    return gaux[G_HMIN] - out, gaux[G_HMAX] + out


@nb.njit(**_JIT)
def _grating_range(gc, cx, cy, w):
    """Rigorous (min h, max h) over the square cell of centre (cx, cy) and half-width w: the
    exact range of each grating's sine over its phase interval, summed."""
    lo = 0.0
    hi = 0.0
    for i in range(gc.shape[1]):
        a = gc[0, i]
        kx = gc[1, i]
        ky = gc[2, i]
        arg = kx * cx + ky * cy + gc[3, i]
        delta = w * (abs(kx) + abs(ky))
        if delta >= math.pi:
            lo -= a
            hi += a
            continue
        s0 = math.sin(arg - delta)
        s1 = math.sin(arg + delta)
        tlo = min(s0, s1)
        thi = max(s0, s1)
        # a crest (pi/2 + 2 pi m) or a trough (-pi/2 + 2 pi m) inside the interval
        if math.floor((arg + delta - 0.5 * math.pi) / (2 * math.pi)) > math.floor((arg - delta - 0.5 * math.pi) / (2 * math.pi)):
            thi = 1.0
        if math.floor((arg + delta + 0.5 * math.pi) / (2 * math.pi)) > math.floor((arg - delta + 0.5 * math.pi) / (2 * math.pi)):
            tlo = -1.0
        lo += a * tlo
        hi += a * thi
    return lo, hi


@nb.njit(**_JIT)
def _surf_newton(kind, gc, px, py, pz, tx, ty, x0, x1, y0, y1):
    """Projected Newton on phi/2 = (|t - p_xy|^2 + (h(t) - pz)^2) / 2 from (tx, ty), kept in the
    cell [x0, x1] x [y0, y1] and monotone: a step that raises phi (beyond its rounding, 1e-12
    relative, with a smaller gradient) is halved from the last point that did not. Where the
    Hessian Q of phi / 2 is not positive definite, the step solves (Q + mu I) s = -grad with
    Q's least eigenvalue mirrored (mu = -2 lambda_min), at most a quarter of the cell long.
    At most 40 texture evaluations. Returns (tx, ty, phi, evaluations, stationary): the last
    accepted point; stationary when |grad phi / 2| <= 1e-9 sqrt(phi) there (not a minimum
    pinned to the cell's edge)."""
    ox = tx
    oy = ty
    of = math.inf
    og = math.inf
    sx = 0.0
    sy = 0.0
    it = 0
    for it in range(1, 41):
        h, gx, gy, hxx, hxy, hyy = surf_eval(kind, gc, tx, ty)
        e = h - pz
        f = (tx - px) ** 2 + (ty - py) ** 2 + e * e
        g0 = (tx - px) + e * gx
        g1 = (ty - py) + e * gy
        gn = math.sqrt(g0 * g0 + g1 * g1)
        # uphill (or not finite): half the step from the last accepted point; at the minimum,
        # where phi only rounds, a smaller gradient is progress
        if not (f <= of or (f <= of * (1.0 + 1e-12) and gn < og)):
            sx *= 0.5
            sy *= 0.5
            if abs(sx) <= 1e-15 * (1.0 + abs(ox)) and abs(sy) <= 1e-15 * (1.0 + abs(oy)):
                break
            tx = min(max(ox + sx, x0), x1)
            ty = min(max(oy + sy, y0), y1)
            continue
        ox = tx
        oy = ty
        of = f
        og = gn
        a = 1.0 + gx * gx + e * hxx
        b = gx * gy + e * hxy
        c = 1.0 + gy * gy + e * hyy
        det = a * c - b * b
        if a > 0.0 and det > 0.0:
            sx = -(c * g0 - b * g1) / det
            sy = -(a * g1 - b * g0) / det
        else:  # not convex here: Newton on Q + mu I, its least eigenvalue mirrored (|Q|)
            if og == 0.0:
                break
            lam = 0.5 * (a + c) - math.sqrt(0.25 * (a - c) ** 2 + b * b)
            mu = max(-2.0 * lam, 1e-6 * (abs(a) + abs(c)) + 1e-300)
            a += mu
            c += mu
            det = a * c - b * b
            sx = -(c * g0 - b * g1) / det
            sy = -(a * g1 - b * g0) / det
            cap = 0.25 * min(x1 - x0, y1 - y0) / (math.sqrt(sx * sx + sy * sy) + 1e-300)
            if cap < 1.0:
                sx *= cap
                sy *= cap
        nx = min(max(tx + sx, x0), x1)
        ny = min(max(ty + sy, y0), y1)
        sx = nx - tx  # the projected step, halved from here if it goes uphill
        sy = ny - ty
        if abs(sx) <= 1e-15 * (1.0 + abs(tx)) and abs(sy) <= 1e-15 * (1.0 + abs(ty)):
            break
        tx = nx
        ty = ny
    # a stationary point of phi (not a minimum pinned to the cell's edge): |grad phi/2| ~ 0
    stationary = og <= 1e-9 * math.sqrt(of) + 1e-300
    return ox, oy, of, it, stationary



@nb.njit(inline="always", **_JIT)
def _edge_qp(g, a, w):
    """min over s in [-w, w] of g s + a s^2 / 2, and its argmin."""
    if a > 0.0 and abs(g) < a * w:
        s = -g / a
        return 0.5 * g * s, s
    return 0.5 * a * w * w - abs(g) * w, (-w if g > 0.0 else w)


@nb.njit(**_JIT)
def _box_qp(g0, g1, a, b, c, w):
    """The exact minimum over the square |u_x|, |u_y| <= w of q(u) = g.u + u^T [[a, b], [b, c]]
    u / 2 (any symmetric matrix), and its argmin: the interior stationary point when the
    matrix is positive definite and the point inside, else the least of the four edges' 1-D
    minima. Returns (q_min, u_x, u_y)."""
    det = a * c - b * b
    if a > 0.0 and det > 0.0:
        sx = -(c * g0 - b * g1) / det
        sy = -(a * g1 - b * g0) / det
        if abs(sx) <= w and abs(sy) <= w:
            return 0.5 * (g0 * sx + g1 * sy), sx, sy
    best = math.inf
    bx = 0.0
    by = 0.0
    for sgn in (-1.0, 1.0):
        v, s = _edge_qp(g1 + b * sgn * w, c, w)  # the edge u_x = sgn w
        v += sgn * w * g0 + 0.5 * a * w * w
        if v < best:
            best = v
            bx = sgn * w
            by = s
        v, s = _edge_qp(g0 + b * sgn * w, a, w)  # the edge u_y = sgn w
        v += sgn * w * g1 + 0.5 * c * w * w
        if v < best:
            best = v
            bx = s
            by = sgn * w
    return best, bx, by


CONVEX_MIN = 0.05
"""Least certified strong convexity of phi / 2 for :func:`convex_closest_point` to be tried."""
CONVEX_EVALS = 16
"""Most texture evaluations :func:`convex_closest_point` spends before giving up."""


@nb.njit(**_JIT)
def convex_closest_point(kind, gc, gaux, px, py, pz, tx, ty):
    """The closest point of z = h(x, y) to p by Newton, certified by global strong convexity.

    With phi(t) = |t - p_xy|^2 + (h(t) - pz)^2, the Hessian of phi / 2 is I + grad h grad h^T
    + e H with e = h(t) - pz, so its least eigenvalue is at least m = 1 - E C for every t, where
    |e| <= E = max(G_HMAX - pz, pz - G_HMIN) and C = G_CONVEX bounds ||H||_2 (a sum of
    gratings' ``curvature_bound``; 0 when no rigorous bound is kept). When
    m >= CONVEX_MIN (the probe is closer to every point of the surface than its least radius of
    curvature, roughly), phi / 2 is m-strongly convex on the whole plane: it has one stationary
    point, the global minimum, and |t - t*| <= |grad phi / 2| / m anywhere (Boyd &
    Vandenberghe 2004, 9.1.2). Newton from (tx, ty) (p_xy when not finite), the step halved
    while neither phi nor |grad phi| decreases, stops when |t - t*| <= 1e-15 (1 + |t|) is
    certified.

    Returns (tx, ty, phi, evaluations, certified); not certified (m too small, or more than
    CONVEX_EVALS evaluations) means: search the surface instead.
    """
    cb = gaux[G_CONVEX]
    e_max = max(gaux[G_HMAX] - pz, pz - gaux[G_HMIN])
    m = 1.0 - e_max * cb
    if cb <= 0.0 or not (m >= CONVEX_MIN):
        return tx, ty, math.inf, 0, False
    if not (math.isfinite(tx) and math.isfinite(ty)):
        tx = px
        ty = py
    h, hx, hy, hxx, hxy, hyy = surf_eval(kind, gc, tx, ty)
    ev = 1
    e = h - pz
    f = (tx - px) ** 2 + (ty - py) ** 2 + e * e
    g0 = (tx - px) + e * hx
    g1 = (ty - py) + e * hy
    gn = math.sqrt(g0 * g0 + g1 * g1)
    while ev < CONVEX_EVALS:
        if gn <= 1e-15 * (1.0 + math.hypot(tx, ty)) * m:
            return tx, ty, f, ev, True
        a = 1.0 + hx * hx + e * hxx
        b = hx * hy + e * hxy
        c = 1.0 + hy * hy + e * hyy
        det = a * c - b * b  # >= m^2 > 0 by the bound, up to rounding
        sx = -(c * g0 - b * g1) / det
        sy = -(a * g1 - b * g0) / det
        while ev < CONVEX_EVALS:
            nx = tx + sx
            ny = ty + sy
            h, hx, hy, hxx, hxy, hyy = surf_eval(kind, gc, nx, ny)
            ev += 1
            e = h - pz
            fn = (nx - px) ** 2 + (ny - py) ** 2 + e * e
            g0 = (nx - px) + e * hx
            g1 = (ny - py) + e * hy
            gm = math.sqrt(g0 * g0 + g1 * g1)
            if fn <= f or gm < gn:  # phi or its gradient decreases (phi is rounding near its minimum)
                tx = nx
                ty = ny
                f = fn
                gn = gm
                break
            sx *= 0.5
            sy *= 0.5
        else:
            break
    return tx, ty, f, ev, False


@nb.njit(inline="always", **_JIT)
def _offer_point(bf, btx, bty, second, found, tx, ty, f, stationary, sep):
    """A surface search's candidate (tx, ty) with phi = f: the new best, or the runner-up kept
    for ties (a stationary point farther than sep from a stationary best). ``found``: the best
    is a stationary point of phi, or one lies within sep of it at the same phi to rounding.
    Returns the updated (bf, btx, bty, second, found)."""
    far = (tx - btx) ** 2 + (ty - bty) ** 2 > sep * sep
    if f < bf:
        if found and bf < second and far:
            second = bf
        return f, tx, ty, second, stationary
    if stationary and not far and f <= bf * (1.0 + 1e-12):
        found = True  # the best's own local minimum, equal to rounding
    elif stationary and found and f < second and far:
        second = f
    return bf, btx, bty, second, found


@nb.njit(inline="always", **_JIT)
def _cell_reach(model, bf, second, btx, bty, cx, cy, r, sep, tie_eps):
    """The distance a surface search's cell (centre (cx, cy), half-diagonal r) must come within
    to be searched: d - tie_eps, d = sqrt(bf) the best distance so far; d + tie_eps for a cell
    wholly farther than sep from the best point (btx, bty) while no runner-up within tie_eps
    of d is known (``second``: its phi), and everywhere without the Taylor bound (``model``
    False). Returns (far, reach)."""
    d = math.sqrt(bf)
    far = not model or (second > (d + tie_eps) ** 2 and (cx - btx) ** 2 + (cy - bty) ** 2 > (sep + r) ** 2)
    return far, (d + tie_eps if far else max(d - tie_eps, 0.0))


@nb.njit(**_JIT)
def _basin_radius(kind, gc, gaux, px, py, pz, tx, ty, f):
    """Radius rho of a disc around the surface search's best point (tx, ty), phi = f, on which
    phi >= (sqrt(f) - G_TIE)^2, the search's goal: a cell inside it needs no search.

    By Taylor at t with the cubic remainder, phi / 2 (t + v) >= f / 2 - |g| s + lambda s^2 / 2
    - L s^3 / 6 for |v| = s <= rho (g, lambda the gradient and least eigenvalue of the
    Hessian Q of phi / 2 at t; L bounds the derivative of Q over the disc as in
    :func:`surface_closest_point`, from rigorous bounds of |grad h|, ||H||_2 and the third
    derivatives). The disc holds when |g| rho + max(0, rho^2 (L rho / 6 - lambda / 2)) <=
    tol = sqrt(f) G_TIE - G_TIE^2 / 2: up to rho = 3 lambda / L by the quadratic growth, and
    at least a radius of about (6 tol / L)^(1/3) whatever lambda (a degenerate minimum,
    lambda ~ 0, which a cubic bound alone would refine down to rounding). Returns 0.0 where
    none is certified (one texture evaluation).
    """
    jerk = gaux[G_JERK]
    cb = gaux[G_CURV_BOUND]
    sb = gaux[G_SLOPE_BOUND]
    tie = gaux[G_TIE]
    h, gx, gy, hxx, hxy, hyy = surf_eval(kind, gc, tx, ty)
    e = h - pz
    a = 1.0 + gx * gx + e * hxx
    b = gx * gy + e * hxy
    c = 1.0 + gy * gy + e * hyy
    lam = 0.5 * (a + c) - math.hypot(0.5 * (a - c), b)
    gn = math.hypot((tx - px) + e * gx, (ty - py) + e * gy)
    tol = math.sqrt(f) * tie - 0.5 * tie * tie
    if not (jerk > 0.0 and tol > 0.0 and math.isfinite(lam)):
        return 0.0
    hn = 0.5 * abs(hxx + hyy) + math.hypot(0.5 * (hxx - hyy), hxy)
    sn = math.hypot(gx, gy)
    l0 = 3.0 * sn * hn + abs(e) * jerk + 1e-300
    rho = max(3.0 * max(lam, 0.0) / l0, (6.0 * tol / l0) ** (1.0 / 3.0))
    for _ in range(60):
        cl = min(cb, hn + jerk * rho)
        sl = min(sb, sn + cl * rho)
        lip = 3.0 * sl * cl + (abs(e) + sl * rho) * jerk
        if gn * rho + max(0.0, rho * rho * (lip * rho / 6.0 - 0.5 * lam)) <= tol:
            return rho
        rho *= 0.75
    return 0.0


@nb.njit(**_JIT)
def surface_closest_point(kind, gc, gaux, px, py, pz, gx0, gy0, best):
    """Closest point (tx, ty) of z = h(x, y) to p = (px, py, pz) below it.

    First, :func:`convex_closest_point` from the guess (gx0, gy0) (NaN: none): where it
    certifies the minimum, that is the answer. Otherwise branch and bound over a quadtree of
    the square of half-width W around p_xy (W from the vertical distance and the lowest
    height, as in the 1-D search), its bound first set by Newton from p_xy and from the guess.
    A cell (centre c, half-width w, half-diagonal r) is pruned when a lower bound of phi
    = |t - p_xy|^2 + (h(t) - p_z)^2 over it reaches the goal:

    - the box bound: the distance from p to the box [cell] x [h bounds], the bounds the
      tighter of h(c) +- min(M r, |grad h(c)| r + sup||H|| r^2 / 2) (M and sup||H|| the
      rigorous G_SLOPE_BOUND and G_CURV_BOUND where G_JERK > 0) and the sum of each
      grating's exact range over the cell;
    - the Taylor bound (when G_JERK > 0, a sum of gratings): phi(c) + 2 min over the cell of
      the quadratic model g.u + u^T Q u / 2 (:func:`_box_qp`; g and Q the gradient and Hessian
      of phi / 2 at c) - L r^3 / 3, where L = 3 S C + (|h(c) - p_z| + S r) J bounds the
      derivative of Q = I + grad h grad h^T + (h - p_z) H over the cell, so that phi / 2 is
      at least its quadratic model less L |u|^3 / 6. J = G_JERK bounds the third
      derivatives; C = min(G_CURV_BOUND, ||H(c)||_2 + J r) and S = min(G_SLOPE_BOUND,
      |grad h(c)| + C r) bound ||H||_2 and |grad h| over the cell (rigorous: H is J-, grad h
      C-Lipschitz);
    - the basin disc (when G_JERK > 0 and the best is a stationary point t*): by the same
      Taylor bound centred at t*, phi reaches the goal on a disc around t* (up to radius
      3 lambda_min(Q(t*)) / L, and to the tie tolerance even at a degenerate minimum:
      :func:`_basin_radius`); a cell inside it is pruned unevaluated. This replaces the
      tower of ever smaller cells around the minimum.

    Each grating's exact range over the cell (a tighter box bound, two sines a grating) is
    computed only for cells the cheaper bounds leave.

    The goal is (d - G_TIE)^2, d the best distance so far; for a cell wholly farther than
    four leaves from the best point while no runner-up within G_TIE of d is known,
    (d + G_TIE)^2 (ties on the medial axis). Where the model's least point in a cell is below the best (or, in such a
    far cell, within G_TIE of it), Newton polishes it to its local minimum, which becomes the
    best or the runner-up. The result is the global closest point to G_TIE in distance: no
    point of the surface is closer than d - G_TIE. Without G_JERK (height maps), cells of
    half-width <= G_LEAF are leaves refined by projected Newton from the best of six samples
    (their centre, their quarters' centres, p_xy clamped into them): not certified.

    Work is bounded: at most MAX_SURF_NODES cells by the model, MAX_SURF_LEAVES leaves,
    SURF_STACK pending cells; beyond, cells are leaves. ``best`` is scratch of length 4 + 3 *
    SURF_STACK. Returns (tx, ty, distance, tie, work): tie is 1 when a second local minimum
    farther than four leaves away lies at the same distance to G_TIE (the medial axis).
    """
    h0 = surf_eval(kind, gc, px, py)[0]
    dv = h0 - pz
    if dv <= 0.0:
        return px, py, 0.0, 0, 1
    tx, ty, f, ev, ok = convex_closest_point(kind, gc, gaux, px, py, pz, gx0, gy0)
    if ok:
        return tx, ty, math.sqrt(f), 0, 1 + ev
    bf = dv * dv
    btx = px
    bty = py
    second = math.inf
    found = False
    work = 1 + ev
    leaf = gaux[G_LEAF]
    sep = 4.0 * leaf
    tie_eps = gaux[G_TIE]
    # a first upper bound from the local minima nearest the vertical point and the guess
    # (Newton from each; the guess only when it lies in the search window)
    below = max(gaux[G_HMIN] - pz, 0.0)
    half = math.sqrt(max(bf - below * below, 0.0)) * (1.0 + 1e-9) + 1e-300
    x0 = px - half
    x1 = px + half
    y0 = py - half
    y1 = py + half
    guess = math.isfinite(gx0) and math.isfinite(gy0) and abs(gx0 - px) < half and abs(gy0 - py) < half
    for start in range(2 if guess else 1):
        sx = px if start == 0 else gx0
        sy = py if start == 0 else gy0
        tx, ty, f, it, stat = _surf_newton(kind, gc, px, py, pz, sx, sy, x0, x1, y0, y1)
        work += it
        bf, btx, bty, second, found = _offer_point(bf, btx, bty, second, found, tx, ty, f, stat, sep)
    if not found:  # Newton may end on the minimum with its iterations spent: certify it stationary
        tx, ty, f, it, stat = _surf_newton(kind, gc, px, py, pz, btx, bty, x0, x1, y0, y1)
        work += it
        bf, btx, bty, second, found = _offer_point(bf, btx, bty, second, found, tx, ty, f, stat, sep)
    jerk = gaux[G_JERK]
    sb = gaux[G_SLOPE_BOUND]
    model = jerk > 0.0
    # the box bound with the rigorous sup |grad h| and sup ||H|| where they are kept
    slope = sb if model else gaux[G_SLOPE]
    curv = gaux[G_CURV_BOUND] if model else gaux[G_CURV]
    cb = gaux[G_CURV_BOUND]
    rb = 0.0  # a disc around the best point with phi >= the goal (_basin_radius)
    rbx = math.nan
    rby = math.nan
    stack = best  # (cx, cy, w) triples from index 4
    stack[4] = px
    stack[5] = py
    stack[6] = half
    sp = 1
    leaves = 0
    nodes = 0
    while sp > 0:
        sp -= 1
        cx = stack[4 + 3 * sp]
        cy = stack[5 + 3 * sp]
        w = stack[6 + 3 * sp]
        r = w * math.sqrt(2.0)
        if model and found and (btx != rbx or bty != rby):
            rb = _basin_radius(kind, gc, gaux, px, py, pz, btx, bty, bf)
            rbx = btx
            rby = bty
            work += 1
        if rb > 0.0 and btx == rbx and bty == rby and math.sqrt((cx - rbx) ** 2 + (cy - rby) ** 2) + r <= rb:
            continue
        h, gx, gy, hxx, hxy, hyy = surf_eval(kind, gc, cx, cy)
        work += 1
        spread = min(slope * r, math.sqrt(gx * gx + gy * gy) * r + 0.5 * curv * r * r)
        ranged = kind == SURFACE_PATCHES
        if ranged:
            glo, ghi = _patch_range(gc, gaux, cx, cy, w)
            if glo < gaux[G_HMIN] or ghi > gaux[G_HMAX]:  # beyond the map: the extension's bound only
                spread = math.inf
            lo = max(h - spread, glo)
            hi = min(h + spread, ghi)
        else:  # each grating's exact range later, where the cheaper bounds leave the cell
            lo = h - spread
            hi = h + spread
        dxy = max(0.0, abs(px - cx) - w) ** 2 + max(0.0, abs(py - cy) - w) ** 2
        far, reach = _cell_reach(model, bf, second, btx, bty, cx, cy, r, sep, tie_eps)
        if dxy + max(0.0, lo - pz, pz - hi) ** 2 > reach * reach:
            continue
        if model:
            nodes += 1
            e = h - pz
            g0 = (cx - px) + e * gx
            g1 = (cy - py) + e * gy
            qmin, ux, uy = _box_qp(g0, g1, 1.0 + gx * gx + e * hxx, gx * gy + e * hxy, 1.0 + gy * gy + e * hyy, w)
            # sup ||H||_2 and sup |grad h| over the cell, from their values at c
            cl = min(cb, 0.5 * abs(hxx + hyy) + math.sqrt(0.25 * (hxx - hyy) ** 2 + hxy * hxy) + jerk * r)
            sl = min(sb, math.sqrt(gx * gx + gy * gy) + cl * r)
            lb = (cx - px) ** 2 + (cy - py) ** 2 + e * e + 2.0 * qmin - (3.0 * sl * cl + (abs(e) + sl * r) * jerk) * r * r * r / 3.0
            if lb > reach * reach:
                continue
        if not ranged:
            glo, ghi = _grating_range(gc, cx, cy, w)
            if dxy + max(0.0, max(lo, glo) - pz, pz - min(hi, ghi)) ** 2 > reach * reach:
                continue
        if model:
            # the model's least point: polished to its local minimum when it is below the best
            # (in a far cell, within G_TIE above it)
            sx = cx + ux
            sy = cy + uy
            ez = _height3_only(kind, gc, sx, sy) - pz
            fs = (sx - px) ** 2 + (sy - py) ** 2 + ez * ez
            work += 1
            if fs < bf or (far and fs <= reach * reach):
                tx, ty, f, it, stat = _surf_newton(kind, gc, px, py, pz, sx, sy, x0, x1, y0, y1)
                work += it  # (monotone from the model's point: f <= fs)
                bf, btx, bty, second, found = _offer_point(bf, btx, bty, second, found, tx, ty, f, stat, sep)
                far, reach = _cell_reach(model, bf, second, btx, bty, cx, cy, r, sep, tie_eps)
                if lb > reach * reach:
                    continue
            # (rounding would stop the halving)
            leafy = nodes >= MAX_SURF_NODES or w <= max(1e-9 * leaf, 1e-15 * (abs(cx) + abs(cy)))
        else:
            leafy = w <= leaf or leaves >= MAX_SURF_LEAVES
        if leafy or sp + 4 > SURF_STACK:
            # a leaf: projected Newton from the best of its centre, its four quarter centres and
            # p_xy clamped into it
            sx = min(max(px, cx - w), cx + w)
            sy = min(max(py, cy - w), cy + w)
            fs = (sx - px) ** 2 + (sy - py) ** 2 + (surf_eval(kind, gc, sx, sy)[0] - pz) ** 2
            for q in range(5):
                qx = cx if q == 0 else cx + (0.5 * w if (q & 1) else -0.5 * w)
                qy = cy if q == 0 else cy + (0.5 * w if (q & 2) else -0.5 * w)
                fq = (qx - px) ** 2 + (qy - py) ** 2 + (surf_eval(kind, gc, qx, qy)[0] - pz) ** 2
                if fq < fs:
                    fs = fq
                    sx = qx
                    sy = qy
            work += 6
            leaves += 1
            tx, ty, f, it, inner = _surf_newton(kind, gc, px, py, pz, sx, sy, cx - w, cx + w, cy - w, cy + w)
            work += it
            bf, btx, bty, second, found = _offer_point(bf, btx, bty, second, found, tx, ty, f, inner, sep)
            continue
        hw = 0.5 * w
        # the four children, the one holding p_xy's quadrant last (popped first)
        for k in range(4):
            qx = cx + (hw if (k & 1) else -hw)
            qy = cy + (hw if (k & 2) else -hw)
            if (qx > cx) == (px > cx) and (qy > cy) == (py > cy):
                continue
            stack[4 + 3 * sp] = qx
            stack[5 + 3 * sp] = qy
            stack[6 + 3 * sp] = hw
            sp += 1
        stack[4 + 3 * sp] = cx + (hw if px > cx else -hw)
        stack[5 + 3 * sp] = cy + (hw if py > cy else -hw)
        stack[6 + 3 * sp] = hw
        sp += 1
    d = math.sqrt(bf)
    tie = 0
    if second < math.inf and math.sqrt(second) - d <= max(tie_eps, 1e-9 * d):
        tie = 1
    return btx, bty, d, tie, work


@nb.njit(parallel=True, cache=True, nogil=True)
def surface_closest_points(kind, gc, gaux, px, py, pz, tx_out, ty_out, d_out, tie_out, work_out):
    """Vectorised :func:`surface_closest_point` over flat arrays, in parallel."""
    for i in nb.prange(px.shape[0]):
        scratch = np.empty(4 + 3 * SURF_STACK + 3)
        tx, ty, d, tie, work = surface_closest_point(kind, gc, gaux, px[i], py[i], pz[i], math.nan, math.nan, scratch)
        tx_out[i] = tx
        ty_out[i] = ty
        d_out[i] = d
        tie_out[i] = tie
        work_out[i] = work


assert N_STATE >= S_SEARCH + 4 + 3 * SURF_STACK  # the state holds a surface search's stack


# ----------------------------------------------------------------------------------------
# Algorithm forces over a surface (positions [x, y, z]): alg_force written for 3-D
# ----------------------------------------------------------------------------------------
@nb.njit(**_JIT)
def _height3(kind, coeffs, x, y):
    """(h, h_x, h_y) at (x, y): a surface (SURFACE_GRATINGS, SURFACE_PATCHES), or a profile
    h(x) extruded along y (the profile kinds of :func:`texture_eval`; TEXTURE_FLAT for W)."""
    if kind == SURFACE_GRATINGS or kind == SURFACE_PATCHES:
        h, gx, gy, _, _, _ = surf_eval(kind, coeffs, x, y)
        return h, gx, gy
    h, s, _ = texture_eval(kind, coeffs, x)
    return h, s, 0.0


@nb.njit(inline="always", **_JIT)
def _height3_only(kind, coeffs, x, y):
    """h at (x, y) alone (see :func:`_height3`): no derivatives' cosines for a sum of gratings."""
    if kind == SURFACE_GRATINGS:
        h = 0.0
        for i in range(coeffs.shape[1]):
            h += coeffs[0, i] * math.sin(coeffs[1, i] * x + coeffs[2, i] * y + coeffs[3, i])
        return h
    if kind == SURFACE_PATCHES:
        return patch_eval(coeffs, x, y)[0]
    return texture_height(kind, coeffs, x)


@nb.njit(**_JIT)
def presliding_plane(dx, dy, ddx, ddy, d_max, z_stick, tab):
    """One step of isotropic presliding in the tangent plane (F over a surface).

    (dx, dy) is the deflection before the step (m), (ddx, ddy) the probe's in-plane
    displacement (m); z_stick < 0 selects the sharp model (the play operator: d + dp kept in
    the disk |d| <= d_max), else the smooth model along the deflection's direction u (the
    displacement's if d = 0), elastic across it. Returns (dx, dy, table steps). The compiled
    body of :func:`haptex.friction.step_plane`.
    """
    work = 0
    if z_stick < 0.0:
        nx = dx + ddx
        ny = dy + ddy
    else:
        r = math.hypot(dx, dy)
        if r > 0.0:
            ux = dx / r
            uy = dy / r
        else:
            n = math.hypot(ddx, ddy)
            if n == 0.0:
                return dx, dy, 0
            ux = ddx / n
            uy = ddy / n
        a = ux * ddx + uy * ddy
        radial, work = _smooth_flow(r, a, d_max, z_stick, tab)
        nx = radial * ux + (ddx - a * ux)
        ny = radial * uy + (ddy - a * uy)
    size = math.hypot(nx, ny)
    if size > d_max:
        nx *= d_max / size
        ny *= d_max / size
    return nx, ny, work


@nb.njit(inline="always", **_JIT)
def _warm_guess3(st, aux):
    """D's and E's warm start over a surface: the last closest point (st[S_ADH], st[S_ADHY])
    moved on by its last step (from st[S_LASTX], st[S_LASTY]) when that step was under a
    thousandth of the shortest wavelength; NaN before the first contact.
    Only a guess: the search certifies its answer whatever it is."""
    if st[S_CONTACT] == 0.0:
        return math.nan, math.nan
    tx = st[S_ADH]
    ty = st[S_ADHY]
    if st[S_CONTACT] == 2.0:
        sx = tx - st[S_LASTX]
        sy = ty - st[S_LASTY]
        if abs(sx) + abs(sy) < 1e6 * aux[G_TIE]:  # G_TIE is 1e-9 of the shortest wavelength
            tx += sx
            ty += sy
    return tx, ty


@nb.njit(inline="always", **_JIT)
def _keep_guess3(st, tx, ty):
    """Record the closest point (tx, ty) for :func:`_warm_guess3`."""
    st[S_CONTACT] = 2.0 if st[S_CONTACT] != 0.0 else 1.0
    st[S_LASTX] = st[S_ADH]
    st[S_LASTY] = st[S_ADHY]
    st[S_ADH] = tx
    st[S_ADHY] = ty


@nb.njit(inline="always", **_JIT)
def alg_force3(code, x, y, z, kind, coeffs, prm, aux, st):
    """Force (fx, fy, fz) in N of algorithm ``code`` at [x, y, z] (m) over a surface.

    The 3-D twin of :func:`alg_force` (same parameters and state; the tests compare it with
    the vectorised fields): ``kind`` is a surface kind, or a profile kind for an extruded
    profile. D and E search the closest point on a surface with
    :func:`surface_closest_point` (``aux`` its constants G_*), on an extruded profile with
    the profile's search (``aux`` its bound tree, y unchanged). F's presliding is isotropic
    in the plane (:func:`presliding_plane`).
    """
    k0 = prm[P_K0]
    st[S_WORK] = 1.0
    st[S_H] = math.nan
    st[S_PEN] = max(-z, 0.0)
    if code == ALG_W:
        fz = 0.0
        if z < 0.0:
            fz = -k0 * z
            if prm[P_MU] != 0.0 and st[S_CONTACT] != 0.0:
                fz -= prm[P_MU] * (z - st[S_LASTX]) / prm[P_DXMAX]
        st[S_LASTX] = z
        st[S_CONTACT] = 1.0
        return 0.0, 0.0, fz
    if code == ALG_F or code == ALG_G:
        if z >= 0.0:
            st[S_CONTACT] = 0.0
            return 0.0, 0.0, 0.0
        if code == ALG_G:
            h, gx, gy = _height3(kind, coeffs, x, y)
            st[S_H] = h
            g = 1.0 / math.sqrt(1.0 + gx * gx + gy * gy)
            dl = _clamp_depth(z, prm[P_DZMAX])
            return k0 * dl * gx * g, k0 * dl * gy * g, -k0 * z * g
        if st[S_CONTACT] == 0.0:
            st[S_CONTACT] = 1.0
            st[S_ADH] = x
            st[S_ADHY] = y
            st[S_LASTX] = x
            st[S_LASTY] = y
        dx, dy, work = presliding_plane(st[S_LASTX] - st[S_ADH], st[S_LASTY] - st[S_ADHY], x - st[S_LASTX],
                                        y - st[S_LASTY], prm[P_DXMAX], prm[P_ZSTICK], aux)
        st[S_WORK] += work
        st[S_ADH] = x - dx
        st[S_ADHY] = y - dy
        st[S_LASTX] = x
        st[S_LASTY] = y
        h = _height3_only(kind, coeffs, x, y)
        st[S_H] = h
        depth = -z
        if prm[P_DZMAX] > 0.0 and depth > prm[P_DZMAX]:
            depth = prm[P_DZMAX]
        c = -prm[P_MU] * k0 * depth * (1.0 - prm[P_SCALE] * h) / prm[P_DXMAX]
        return c * dx, c * dy, -k0 * z
    if code == ALG_B or code == ALG_C:
        h, gx, gy = _height3(kind, coeffs, x, y)
    else:
        h = _height3_only(kind, coeffs, x, y)
        gx = gy = 0.0
    st[S_H] = h
    d = z - h
    st[S_PEN] = max(-d, 0.0)
    if d >= 0.0:
        return 0.0, 0.0, 0.0
    if code == ALG_A:
        return 0.0, 0.0, -k0 * d
    if code == ALG_B:
        g = 1.0 / math.sqrt(1.0 + gx * gx + gy * gy)
        dl = _clamp_depth(d, prm[P_DZMAX])
        return k0 * dl * gx * g, k0 * dl * gy * g, -k0 * d * g
    if code == ALG_C:
        dl = _clamp_depth(d, prm[P_DZMAX])
        return k0 * dl * gx, k0 * dl * gy, -k0 * d
    if kind == SURFACE_GRATINGS or kind == SURFACE_PATCHES:
        gx0, gy0 = _warm_guess3(st, aux)
        tx, ty, dist, _, work = surface_closest_point(kind, coeffs, aux, x, y, z, gx0, gy0, st[S_SEARCH:])
        _keep_guess3(st, tx, ty)
        th = _height3_only(kind, coeffs, tx, ty)
        work += 1
    else:  # an extruded profile: the profile's search in the plane y = const
        tx, dist, _, work = closest_point_below(kind, coeffs, aux, x, z, -d, _warm_guess(st, aux), st[S_SEARCH:])
        _keep_guess(st, tx)
        ty = y
        th = texture_height(kind, coeffs, tx)
    st[S_WORK] = work
    st[S_PEN] = dist
    if code == ALG_D:
        return -k0 * (x - tx), -k0 * (y - ty), -k0 * (z - th)
    return 0.0, 0.0, k0 * dist  # ALG_E


@nb.njit(**_JIT)
def force_at(n, code, p, kind, coeffs, prm, aux, st, f):
    """f[:n] = the force (N) of algorithm ``code`` at p[:n] (m): n = 2 over a profile
    ([x, z], :func:`alg_force`), n = 3 over a surface ([x, y, z], :func:`alg_force3`)."""
    if n == 2:
        fx, fz = alg_force(code, p[0], p[1], kind, coeffs, prm, aux, st)
        f[0] = fx
        f[1] = fz
    else:
        fx, fy, fz = alg_force3(code, p[0], p[1], p[2], kind, coeffs, prm, aux, st)
        f[0] = fx
        f[1] = fy
        f[2] = fz


@nb.njit(**_JIT)
def height_under(n, kind, coeffs, p):
    """h under the probe p[:n] (m): h(x) over a profile, h(x, y) over a surface."""
    if n == 2:
        return texture_height(kind, coeffs, p[0])
    return _height3_only(kind, coeffs, p[0], p[1])


@nb.njit(**_JIT)
def saturate_vec(f, n, fmax):
    """Scale f[:n] in place down to magnitude ``fmax`` without overflow (hypot, and the
    direction of infinite components kept); returns True when it scaled f down. NaN in,
    NaN out (the caller counts a fault)."""
    if fmax == math.inf:
        return False
    infinite = False
    nan = False
    for i in range(n):
        if math.isinf(f[i]):
            infinite = True
        elif f[i] != f[i]:
            nan = True
    if infinite:
        if nan:
            return False
        cnt = 0.0
        for i in range(n):
            if math.isinf(f[i]):
                cnt += 1.0
        r = fmax / math.sqrt(cnt)
        for i in range(n):
            f[i] = math.copysign(r, f[i]) if math.isinf(f[i]) else 0.0
        return True
    mag = 0.0
    for i in range(n):
        mag = math.hypot(mag, f[i])
    if mag > fmax:
        r = fmax / mag
        for i in range(n):
            f[i] *= r
        return True
    return False


# ----------------------------------------------------------------------------------------
# Passivity observer and controller (Hannaford & Ryu 2002), shared by the renderer and the
# simulator: one array ``pc`` per loop.
# ----------------------------------------------------------------------------------------
(PC_ON, PC_BMAX, PC_REF, PC_T, PC_E, PC_HAVE, PC_ACTIVE, PC_DISSIPATED, PC_ALPHA) = range(9)
PC_LAST, PC_LASTF, PC_EAX = 10, 13, 16  # last sensed position, last force sent, E per axis (3 each)
N_PC = PC_EAX + 3
PC_REF_ZERO, PC_REF_STORED = 0.0, 1.0


@nb.njit(**_JIT)
def passivity_tick(pc, n, p, f, k0, pen):
    """Observe, then control, one servo tick (impedance causality, a velocity-sensing device).

    Observer: pc[PC_E] += -f_{k-1} . (p_k - p_{k-1}), the energy the virtual environment has
    absorbed (J), from the force sent last tick and the displacement sensed since (Hannaford
    & Ryu 2002, eq. 7). Controller (when pc[PC_ON]): if E falls below the reference
    (0, or with PC_REF_STORED the energy kappa_0 pen^2 / 2 still stored in the virtual
    spring, so that what the rendering gives back is never more than it took: reference
    energy following in the style of Ryu, Preusche, Hannaford & Hirzinger 2005), add the
    damping force -alpha v, v = (p_k - p_{k-1}) / T, with alpha = (E_ref - E) / (T |v|^2)
    bounded by pc[PC_BMAX] (N s/m). Modifies f[:n] in place; the caller saturates and then
    calls :func:`passivity_sent` with the force actually sent.
    """
    pc[PC_ALPHA] = 0.0
    if pc[PC_HAVE] == 0.0:
        return
    v2 = 0.0
    for i in range(n):
        dp = p[i] - pc[PC_LAST + i]
        de = pc[PC_LASTF + i] * dp
        pc[PC_E] -= de
        pc[PC_EAX + i] -= de
        v2 += dp * dp
    if pc[PC_ON] == 0.0:
        return
    ref = 0.5 * k0 * pen * pen if pc[PC_REF] == PC_REF_STORED else 0.0
    deficit = ref - pc[PC_E]
    if deficit > 0.0 and v2 > 0.0:
        T = pc[PC_T]
        alpha = deficit * T / v2  # (E_ref - E) / (T |v|^2) with v = dp / T
        if alpha > pc[PC_BMAX]:
            alpha = pc[PC_BMAX]
        for i in range(n):
            f[i] -= alpha * (p[i] - pc[PC_LAST + i]) / T
        pc[PC_ALPHA] = alpha
        pc[PC_ACTIVE] += 1.0


@nb.njit(**_JIT)
def passivity_sent(pc, n, p, f):
    """Remember the sensed position and the force sent this tick (for the next observation)."""
    for i in range(n):
        pc[PC_LAST + i] = p[i]
        pc[PC_LASTF + i] = f[i]
    pc[PC_HAVE] = 1.0


# ----------------------------------------------------------------------------------------
# the simulator's compiled loop (haptex.simulate): positions of n = 2 ([x, z]) or 3 ([x, y, z])
# ----------------------------------------------------------------------------------------
# summary slots
# the summary's slots S_*, DIVERGED_* (what became non-finite first in a diverged simulation,
# summary[S_DIVERGED_WHAT]) and the fast path's coefficients F_*: the C core's (hx_core.h)
from .core._ext import (DIVERGED_ENERGY, DIVERGED_FORCE, DIVERGED_POSITION, DIVERGED_VELOCITY,  # noqa: E402, F401
                        F_CVV, F_CVW, F_CWW, F_PV, F_PW, F_VV, F_VW, N_FAST, N_SUMMARY, S_DAMP, S_DIVERGED,
                        S_DIVERGED_WHAT, S_EX, S_EY, S_EZ, S_FRIC, S_KE, S_KE0, S_MAXPEN, S_NSAMP, S_OP,
                        S_PC_ACTIVE, S_SAT, S_STUCK, S_TAILSTART_E)  # noqa: F401
# per-axis coefficients of the decoupled fast path, per damping regime: p+ = p + a_pv v +
# a_pw w, v+ = a_vv v + a_vw w (w the force held over the sample, N), and the energy the
# damping dissipates over it, c_vv v^2 + c_vw v w + c_ww w^2 (J)


@nb.njit(**_JIT)
def _quad(W, z, n):
    """z' W z over the first n entries: the Van Loan energy forms (n = n_z) and, halved, the
    kinetic energy 1/2 v' M v (n the dimension)."""
    acc = 0.0
    for i in range(n):
        row = 0.0
        for j in range(n):
            row += W[i, j] * z[j]
        acc += z[i] * row
    return acc


@nb.njit(**_JIT)
def _setpoint(ts, ps, vend, t, out):
    """The operator's set-point s(t) into out[:n] (m): the polyline (ts, ps), then vend."""
    m = ts.shape[0]
    n = ps.shape[1]
    if t >= ts[m - 1]:
        dt = t - ts[m - 1]
        for i in range(n):
            out[i] = ps[m - 1, i] + vend[i] * dt
        return
    if t <= ts[0]:
        for i in range(n):
            out[i] = ps[0, i]
        return
    lo = 0
    hi = m - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ts[mid] <= t:
            lo = mid
        else:
            hi = mid
    w = (t - ts[lo]) / (ts[hi] - ts[lo])
    for i in range(n):
        out[i] = ps[lo, i] + w * (ps[hi, i] - ps[lo, i])


@nb.njit(**_JIT)
def _row_dot(P, i, z):
    """Row i of the sample's exact map times the augmented state: one entry of P z."""
    acc = 0.0
    for j in range(z.shape[0]):
        acc += P[i, j] * z[j]
    return acc


@nb.njit(**_JIT)
def _mech_energy(M, modal, v, ph, vh, p, n):
    """Kinetic energy of the device, plus the structural mode's elastic energy (J): with
    ``modal`` = [M_h, K_s] (a two-mass device, M the motor side) 1/2 v'Mv + 1/2 vh'M_h vh +
    1/2 (p - ph)' K_s (p - ph); 1/2 v'Mv for a rigid one (modal empty)."""
    e = 0.5 * _quad(M, v, n)
    if modal.shape[0] == 2:
        e += 0.5 * _quad(modal[0], vh, n)
        for i in range(n):
            for j in range(n):
                e += 0.5 * (p[i] - ph[i]) * modal[1, i, j] * (p[j] - ph[j])
    return e


@nb.njit(**_JIT)
def _diverged(p, v, u, e, ed, eo, n):
    """Which of position, velocity, force, energy (DIVERGED_*) is non-finite first; 0 if
    none is (a sum of finite terms that overflowed)."""
    for i in range(n):
        if not math.isfinite(p[i]):
            return DIVERGED_POSITION
    for i in range(n):
        if not math.isfinite(v[i]):
            return DIVERGED_VELOCITY
    for i in range(n):
        if not math.isfinite(u[i]):
            return DIVERGED_FORCE
    for i in range(n):
        if not math.isfinite(e[i]):
            return DIVERGED_ENERGY
    return 0 if math.isfinite(ed) and math.isfinite(eo) else DIVERGED_ENERGY


@nb.njit(**_JIT)
def _coulomb(a, Binv, v, fc, n, out):
    """The handle's Coulomb friction force over one sample, held like the command (a sampled
    Karnopp model), into out[:n]; returns True when the handle ends the sample at rest.

    ``a`` is the velocity the sample would end with without friction and ``Binv`` the
    inverse of the sample's map from a held force to that velocity, so f* = -Binv a is the
    constant force that stops the handle. If |f*| <= fc the handle is held by stiction
    (friction = f*). Else it slides: friction fc opposes the velocity at the start of the
    sample, or, from rest, the net applied force (the direction of f*).
    """
    nrm = 0.0
    for i in range(n):
        acc = 0.0
        for j in range(n):
            acc -= Binv[i, j] * a[j]
        out[i] = acc
        nrm += acc * acc
    nrm = math.sqrt(nrm)
    if nrm <= fc:
        return True
    sp = 0.0
    for i in range(n):
        sp += v[i] * v[i]
    sp = math.sqrt(sp)
    if sp > 0.0:
        for i in range(n):
            out[i] = -fc * v[i] / sp
    else:
        for i in range(n):
            out[i] = fc * out[i] / nrm
    return False


@nb.njit(**_JIT)
def run_one(code, kind, coeffs, prm, aux, nominal, Phi, Wd, Wo, Bs, Binv, fast, M, modal, K, C, f0, sp_t, sp_p, vend,
            rest_len, kinematic, n_steps, T, delay, delta, fres, fmax, fc, pc_on, pc_bmax, pc_ref, p0, v0,
            record_every, rec, summary, tail_start, tail_p, dims):
    """One simulation of n = len(dims) axes (``dims`` a tuple of n zeros: its length is a
    compile-time constant, so each dimension gets its own compiled loop with the per-axis
    loops unrolled); fills ``rec`` (n_rec, 4 n + 4) if it has rows,
    ``summary`` and ``tail_p`` (n, n_tail): the position sampled evenly over the tail, one
    contiguous row an axis (the verdicts read each axis's row without a copy).

    Record columns: t, p (n), v (n), f (n), the per-axis environment energies E_i (n),
    E_damping, W_operator, KE. The run stops at the first sample whose position, velocity,
    force or energy is not finite: summary[S_DIVERGED] is then that sample's number
    (1-based) and summary[S_DIVERGED_WHAT] says which quantity (DIVERGED_*); both are 0
    otherwise.

    The sample is integrated exactly: by the augmented transition ``Phi`` (n_z = 5 n, or
    7 n with a structural mode) and the Van Loan quadratic forms ``Wd`` and ``Wo``; or, when
    ``fast`` has rows (a diagonal device with no structural mode, pushed by a constant
    force), axis by axis with the closed forms ``fast`` (2, n, N_FAST), the operator's work
    being f0 . dp. A structural mode (``modal`` = [M_h, K_s]) adds the handle side
    [p_h, v_h], which the operator drives; positions, the tail and the records are the motor
    side's, which the encoder senses and the command drives.

    ``fc`` (N) is the handle's isotropic Coulomb friction, sampled (see
    :func:`_coulomb`); summary[S_FRIC] is the energy it dissipated (J) and
    summary[S_STUCK] the number of samples that ended at rest by stiction. With ``pc_on``
    the passivity controller (:func:`passivity_tick`) acts on the sensed positions;
    summary[S_PC_ACTIVE] counts the samples it acted on.
    """
    n = len(dims)
    st = np.zeros(N_STATE)
    nz = Phi.shape[1]
    mode = modal.shape[0] == 2
    use_fast = fast.shape[0] > 0
    z = np.zeros(nz)
    p = p0.copy()
    v = v0.copy()
    ph = p0.copy()  # the handle side starts with the motor side: the mode at rest
    vh = v0.copy()
    sense = np.zeros(n)
    f = np.zeros(n)
    u = np.zeros(n)
    g = np.zeros(n)
    r = np.zeros(n)
    a = np.zeros(n)
    ff = np.zeros(n)
    newp = np.zeros(n)
    newv = np.zeros(n)
    e = np.zeros(n)
    buf = np.zeros((delay + 1, n))
    s0 = np.zeros(n)
    s1 = np.zeros(n)
    pc = np.zeros(N_PC)
    pc[PC_ON] = 1.0 if pc_on else 0.0
    pc[PC_BMAX] = pc_bmax
    pc[PC_REF] = pc_ref
    pc[PC_T] = T
    k0 = prm[P_K0]
    ed = 0.0
    eo = 0.0
    sat = 0
    maxpen = 0.0
    ke0 = _mech_energy(M, modal, v, ph, vh, p, n)
    ke_prev = ke0
    n_tail = tail_p.shape[1]
    tail_stride = max((n_steps - tail_start) // max(n_tail, 1), 1)
    e_tail = 0.0
    efr = 0.0
    stuck = 0
    irec = 0
    nrec = rec.shape[0]
    next_rec = record_every if nrec > 0 else -1  # the next sample number (1-based) to record
    itail = 0
    next_tail = tail_start if n_tail > 0 else -1
    last = n - 1
    for k in range(n_steps):
        t = k * T
        if kinematic:
            _setpoint(sp_t, sp_p, vend, t, p)
            _setpoint(sp_t, sp_p, vend, t + T, s1)
            for i in range(n):
                v[i] = (s1[i] - p[i]) / T
        # controller: sense, compute, (passivity control), quantise, saturate, delay
        for i in range(n):
            sense[i] = delta * np.round(p[i] / delta) if delta > 0.0 else p[i]
        if n == 2:  # (n is a compile-time constant here: one branch is compiled away)
            f[0], f[1] = alg_force(code, sense[0], sense[1], kind, coeffs, prm, aux, st)
        else:
            f[0], f[1], f[2] = alg_force3(code, sense[0], sense[1], sense[2], kind, coeffs, prm, aux, st)
        if pc_on:
            passivity_tick(pc, n, sense, f, k0, st[S_PEN])
        if fres > 0.0:
            for i in range(n):
                f[i] = fres * np.round(f[i] / fres)
        if saturate_vec(f, n, fmax):
            sat += 1
        if pc_on:
            passivity_sent(pc, n, sense, f)
        if delay == 0:
            for i in range(n):
                u[i] = f[i]
        else:
            slot = k % (delay + 1)
            nxt = (k + 1) % (delay + 1)
            for i in range(n):
                buf[slot, i] = f[i]
                u[i] = buf[nxt, i] if k >= delay else 0.0
        # damping regime from the sensed position (brakes on inside the virtual object)
        if nominal:
            inside = sense[last] < 0.0
            pen = -p[last]
        else:
            h = st[S_H]
            if h != h:
                h = height_under(n, kind, coeffs, sense)
            inside = sense[last] < h
            if delta > 0.0:
                h = height_under(n, kind, coeffs, p)
            pen = h - p[last]
        if pen > maxpen:
            maxpen = pen
        reg = 1 if inside else 0
        if kinematic:
            # prescribed motion: constant velocity over the sample; the operator supplies
            # whatever work keeps it on the path (so the energy balance closes by design)
            dd = T * _quad(Bs[reg], v, n)
            ke_now = 0.5 * _quad(M, v, n)
            if k == 0:
                ke0 = ke_now
                ke_prev = ke_now
            ed += dd
            step2 = 0.0
            work = 0.0
            for i in range(n):
                dp = s1[i] - p[i]
                step2 += dp * dp
                work += u[i] * dp
                e[i] -= u[i] * dp
                p[i] = s1[i]
            dfr = fc * math.sqrt(step2)  # prescribed sliding: friction opposes each step
            efr += dfr
            eo += (ke_now - ke_prev) + dd + dfr - work
            ke_prev = ke_now
        else:
            if use_fast:  # a constant push: g = f0, no ramp
                for i in range(n):
                    g[i] = f0[i]
                    a[i] = fast[reg, i, F_VV] * v[i] + fast[reg, i, F_VW] * (u[i] + g[i])
            else:
                # operator forcing over [t, t + T]: g(t + s) = g0 + r s
                _setpoint(sp_t, sp_p, vend, t, s0)
                _setpoint(sp_t, sp_p, vend, t + T, s1)
                for i in range(n):
                    acc = f0[i]
                    racc = 0.0
                    for j in range(n):
                        sd = (s1[j] - s0[j]) / T
                        acc += K[i, j] * s0[j] + C[i, j] * sd
                        racc += K[i, j] * sd
                    g[i] = acc
                    r[i] = racc
                if rest_len > 0.0:
                    nrm = 0.0
                    for i in range(n):
                        d_i = (ph[i] if mode else p[i]) - sp_p[0, i]
                        nrm += d_i * d_i
                    nrm = math.sqrt(nrm)
                    if nrm > 0.0:
                        for i in range(n):
                            g[i] += K[i, i] * rest_len * ((ph[i] if mode else p[i]) - sp_p[0, i]) / nrm
                for i in range(n):
                    z[i] = p[i]
                    z[n + i] = v[i]
                    z[2 * n + i] = u[i]
                    z[3 * n + i] = g[i]
                    z[4 * n + i] = r[i]
                    if mode:
                        z[5 * n + i] = ph[i]
                        z[6 * n + i] = vh[i]
                for i in range(n):
                    a[i] = _row_dot(Phi[reg], n + i, z)
            rest = False
            held = False
            for i in range(n):
                ff[i] = 0.0
            if fc > 0.0:
                rest = _coulomb(a, Binv[reg], v, fc, n, ff)
                if rest:
                    stuck += 1
                    # at rest and held by stiction: the friction force follows the applied
                    # force within the sample, so the handle does not move at all
                    held = not mode  # a mode keeps the handle moving
                    for i in range(n):
                        if v[i] != 0.0:
                            held = False
            for i in range(n):
                newp[i] = p[i]
                newv[i] = 0.0
            if not held:
                if use_fast:
                    for i in range(n):
                        w = u[i] + g[i] + ff[i]
                        newp[i] = p[i] + fast[reg, i, F_PV] * v[i] + fast[reg, i, F_PW] * w
                        newv[i] = fast[reg, i, F_VV] * v[i] + fast[reg, i, F_VW] * w
                        ed += v[i] * (fast[reg, i, F_CVV] * v[i] + fast[reg, i, F_CVW] * w) + fast[reg, i, F_CWW] * w * w
                        eo += g[i] * (newp[i] - p[i])
                else:
                    for i in range(n):
                        z[2 * n + i] = u[i] + ff[i]
                    P = Phi[reg]
                    ed += _quad(Wd[reg], z, nz)
                    eo += _quad(Wo[reg], z, nz)
                    for i in range(n):
                        newp[i] = _row_dot(P, i, z)
                        newv[i] = _row_dot(P, n + i, z)
                    if mode:  # the handle side of the structural mode
                        for i in range(n):
                            ph[i] = _row_dot(P, 5 * n + i, z)
                            vh[i] = _row_dot(P, 6 * n + i, z)
            for i in range(n):
                dp = newp[i] - p[i]
                e[i] -= u[i] * dp
                efr -= ff[i] * dp
                p[i] = newp[i]
                v[i] = 0.0 if (fc > 0.0 and rest) else newv[i]  # stiction: at rest exactly
        what = 0
        check = ed + eo  # one test a sample: a non-finite term makes the sum non-finite
        for i in range(n):
            check += p[i] + v[i] + u[i] + e[i]
        if not math.isfinite(check):
            what = _diverged(p, v, u, e, ed, eo, n)
        if what != 0:
            summary[S_DIVERGED] = k + 1
            summary[S_DIVERGED_WHAT] = what
            n_steps = k + 1
            break
        if k == tail_start:
            e_tail = 0.0
            for i in range(n):
                e_tail += e[i]
        if k == next_tail:  # every tail_stride-th sample of the tail (no division per sample)
            if itail < n_tail:
                for i in range(n):
                    tail_p[i, itail] = p[i]
                itail += 1
                next_tail += tail_stride
        if k + 1 == next_rec:
            next_rec += record_every
            rec[irec, 0] = t + T
            for i in range(n):
                rec[irec, 1 + i] = p[i]
                rec[irec, 1 + n + i] = v[i]
                rec[irec, 1 + 2 * n + i] = u[i]
                rec[irec, 1 + 3 * n + i] = e[i]
            rec[irec, 1 + 4 * n] = ed
            rec[irec, 2 + 4 * n] = eo
            rec[irec, 3 + 4 * n] = _mech_energy(M, modal, v, ph, vh, p, n)
            irec += 1
            if irec == nrec:
                next_rec = -1
    summary[S_EX] = e[0]
    summary[S_EZ] = e[n - 1]
    summary[S_EY] = e[1] if n == 3 else 0.0
    summary[S_DAMP] = ed
    summary[S_OP] = eo
    summary[S_KE0] = ke0
    summary[S_KE] = _mech_energy(M, modal, v, ph, vh, p, n)
    summary[S_SAT] = sat
    summary[S_MAXPEN] = maxpen
    summary[S_NSAMP] = n_steps
    summary[S_TAILSTART_E] = e_tail
    summary[S_FRIC] = efr
    summary[S_STUCK] = stuck
    summary[S_PC_ACTIVE] = pc[PC_ACTIVE]


@nb.njit(inline="always", **_JIT)
def _axis_zoh(c, p, v, u, g):
    """One axis of the decoupled fast path over one sample (``c`` = fast[regime, axis]):
    (p+, v+, damping energy of the sample), the held force being u + g."""
    w = u + g
    return (p + c[F_PV] * v + c[F_PW] * w, c[F_VV] * v + c[F_VW] * w,
            v * (c[F_CVV] * v + c[F_CVW] * w) + c[F_CWW] * w * w)


@nb.njit(**_JIT)
def run_lean(code, kind, coeffs, prm, aux, nominal, fast, M, f0, n_steps, T, p0, v0, record_every, rec, summary,
             tail_start, tail_p, dims):
    """:func:`run_one` without its optional machinery (see :func:`_lean_loop`). The loop is
    compiled three times: for W and A with the algorithm a constant, so that their force
    compiles to a few instructions (A's dispatch and state writes cost 25 % in 2-D,
    measured), and for any algorithm."""
    if code == ALG_A:
        _lean_loop(ALG_A, kind, coeffs, prm, aux, nominal, fast, M, f0, n_steps, T, p0, v0, record_every, rec,
                   summary, tail_start, tail_p, dims)
    elif code == ALG_W:
        _lean_loop(ALG_W, kind, coeffs, prm, aux, nominal, fast, M, f0, n_steps, T, p0, v0, record_every, rec,
                   summary, tail_start, tail_p, dims)
    else:
        _lean_loop(code, kind, coeffs, prm, aux, nominal, fast, M, f0, n_steps, T, p0, v0, record_every, rec,
                   summary, tail_start, tail_p, dims)


@nb.njit(inline="always", **_JIT)
def _lean_loop(code, kind, coeffs, prm, aux, nominal, fast, M, f0, n_steps, T, p0, v0, record_every, rec, summary,
               tail_start, tail_p, dims):
    """:func:`run_one` for the case with none of its optional machinery: a rigid device with
    diagonal mass and damping (the decoupled closed forms ``fast``), pushed by the constant
    force ``f0``, with no delay, position quantisation, force resolution, saturation, Coulomb
    friction, passivity controller or kinematic operator (the caller checks; see
    :func:`haptex.simulate._lean`). Same inputs and outputs, the same arithmetic in the same
    order (the results are equal), with the state in scalars rather than arrays: the state's
    loop-carried chain then stays in registers (2.3x faster in 2-D, measured)."""
    n = len(dims)
    three = n == 3  # a compile-time constant
    st = np.zeros(N_STATE)
    scratch = np.zeros(n)
    x = p0[0]
    y = p0[1] if three else 0.0
    z = p0[n - 1]
    vx = v0[0]
    vy = v0[1] if three else 0.0
    vz = v0[n - 1]
    gx = f0[0]
    gy = f0[1] if three else 0.0
    gz = f0[n - 1]
    ux = 0.0
    uy = 0.0
    uz = 0.0
    ex = 0.0
    ey = 0.0
    ez = 0.0
    ed = 0.0
    eo = 0.0
    maxpen = 0.0
    ke0 = 0.5 * _quad(M, v0, n)
    n_tail = tail_p.shape[1]
    tail_stride = max((n_steps - tail_start) // max(n_tail, 1), 1)
    e_tail = 0.0
    irec = 0
    nrec = rec.shape[0]
    next_rec = record_every if nrec > 0 else -1
    itail = 0
    next_tail = tail_start if n_tail > 0 else -1
    for k in range(n_steps):
        if three:
            ux, uy, uz = alg_force3(code, x, y, z, kind, coeffs, prm, aux, st)
        else:
            ux, uz = alg_force(code, x, z, kind, coeffs, prm, aux, st)
        if nominal:
            inside = z < 0.0
            pen = -z
        else:
            h = st[S_H]
            if h != h:
                scratch[0] = x
                scratch[n - 1] = z
                if three:
                    scratch[1] = y
                h = height_under(n, kind, coeffs, scratch)
            inside = z < h
            pen = h - z
        if pen > maxpen:
            maxpen = pen
        reg = 1 if inside else 0
        nx, nvx, dx = _axis_zoh(fast[reg, 0], x, vx, ux, gx)
        ed += dx
        eo += gx * (nx - x)
        if three:
            ny, nvy, dy = _axis_zoh(fast[reg, 1], y, vy, uy, gy)
            ed += dy
            eo += gy * (ny - y)
        nz, nvz, dz = _axis_zoh(fast[reg, n - 1], z, vz, uz, gz)
        ed += dz
        eo += gz * (nz - z)
        ex -= ux * (nx - x)
        x = nx
        vx = nvx
        if three:
            ey -= uy * (ny - y)
            y = ny
            vy = nvy
        ez -= uz * (nz - z)
        z = nz
        vz = nvz
        if not math.isfinite(ed + eo + x + vx + ux + ex + y + vy + uy + ey + z + vz + uz + ez):
            pp = np.array([x, y, z])
            vv = np.array([vx, vy, vz])
            uu = np.array([ux, uy, uz])
            ee = np.array([ex, ey, ez])
            if not three:
                pp[1], vv[1], uu[1], ee[1] = z, vz, uz, ez
            what = _diverged(pp, vv, uu, ee, ed, eo, n)
            if what != 0:
                summary[S_DIVERGED] = k + 1
                summary[S_DIVERGED_WHAT] = what
                n_steps = k + 1
                break
        if k == tail_start:
            e_tail = ex + ey + ez if three else ex + ez
        if k == next_tail:
            if itail < n_tail:
                tail_p[0, itail] = x
                if three:
                    tail_p[1, itail] = y
                tail_p[n - 1, itail] = z
                itail += 1
                next_tail += tail_stride
        if k + 1 == next_rec:
            next_rec += record_every
            rec[irec, 0] = k * T + T
            row = ((x, vx, ux, ex), (y, vy, uy, ey), (z, vz, uz, ez))
            for i in range(n):
                a = 2 if (i == n - 1) else i
                rec[irec, 1 + i] = row[a][0]
                rec[irec, 1 + n + i] = row[a][1]
                rec[irec, 1 + 2 * n + i] = row[a][2]
                rec[irec, 1 + 3 * n + i] = row[a][3]
                scratch[i] = row[a][1]
            rec[irec, 1 + 4 * n] = ed
            rec[irec, 2 + 4 * n] = eo
            rec[irec, 3 + 4 * n] = 0.5 * _quad(M, scratch, n)
            irec += 1
            if irec == nrec:
                next_rec = -1
    summary[S_EX] = ex
    summary[S_EZ] = ez
    summary[S_EY] = ey
    summary[S_DAMP] = ed
    summary[S_OP] = eo
    summary[S_KE0] = ke0
    scratch[0] = vx
    scratch[n - 1] = vz
    if three:
        scratch[1] = vy
    summary[S_KE] = 0.5 * _quad(M, scratch, n)
    summary[S_SAT] = 0
    summary[S_MAXPEN] = maxpen
    summary[S_NSAMP] = n_steps
    summary[S_TAILSTART_E] = e_tail
    summary[S_FRIC] = 0.0
    summary[S_STUCK] = 0
    summary[S_PC_ACTIVE] = 0.0


@nb.njit(parallel=True, cache=True, nogil=True)
def run_batch(code, kind, coeffs, prm, aux, nominal, Phi, Wd, Wo, Bs, Binv, fast, M, modal, K, C, f0, sp_t, sp_p, vend,
              rest_len, kinematic, n_steps, T, delay, delta, fres, fmax, fc, pc_on, pc_bmax, pc_ref, p0, v0,
              record_every, rec, summary, tail_start, tail_p, dims, lean):
    """Runs i = 0..N-1 of :func:`run_one` in parallel; every per-run array has a leading N axis.
    ``lean`` = (1,) takes :func:`run_lean` instead (its length is a compile-time constant)."""
    for i in nb.prange(coeffs.shape[0]):
        if len(lean) == 1:
            run_lean(code, kind, coeffs[i], prm[i], aux[i], nominal, fast[i], M[i], f0[i], n_steps, T, p0[i], v0[i],
                     record_every, rec[i], summary[i], tail_start, tail_p[i], dims)
            continue
        run_one(code, kind, coeffs[i], prm[i], aux[i], nominal, Phi[i], Wd[i], Wo[i], Bs[i], Binv[i], fast[i], M[i],
                modal[i], K[i], C[i], f0[i], sp_t, sp_p[i], vend[i], rest_len[i], kinematic, n_steps, T, delay[i],
                delta[i], fres[i], fmax[i], fc[i], pc_on, pc_bmax[i], pc_ref, p0[i], v0[i], record_every, rec[i],
                summary[i], tail_start, tail_p[i], dims)


# ----------------------------------------------------------------------------------------
# the renderer's servo tick (haptex.Renderer)
# ----------------------------------------------------------------------------------------
# renderer state slots (float64 array)
(RS_MAXF, RS_FAULTS, RS_CLAMPS, RS_MONITOR, RS_LIMIT, RS_WORK, RS_MAXWORK, RS_DIM) = range(8)
N_RS = 8


# the renderer's one array (a single argument to unbox per call): a header (algorithm code,
# texture kind, the coefficients' rows and columns, the search data's length), the algorithm's
# parameters, the renderer's slots, the passivity observer/controller, scratch, the algorithm's
# state, then the texture's coefficients and the search data or table
H_CODE, H_KIND, H_ROWS, H_COLS, H_NAUX = range(5)
R_PRM = 8
R_RS = R_PRM + N_PARAMS
R_PC = R_RS + N_RS
R_BUF = R_PC + N_PC
R_ST = R_BUF + 6
R_DATA = R_ST + N_STATE


@nb.njit(**_JIT)
def render_step(x, y, z, mem):
    """Compiled servo tick: validate, compute, control passivity, clamp, count, observe.

    (x, y, z) is the probe position (m); y is ignored over a profile (rs[RS_DIM] = 2).
    ``mem`` holds the header H_* from 0, then from R_PRM, R_RS, R_PC, R_BUF, R_ST and R_DATA:
    the algorithm's parameters, the renderer's slots RS_*, the passivity observer/
    controller's state (:func:`passivity_tick`; observing only unless PC_ON), scratch of 6,
    the algorithm's state, and the texture's coefficients (rows x columns, row-major) followed
    by the search data or table. Returns (fx, fy, fz) (N), fy = 0 over a profile. A position
    with a non-finite coordinate or one beyond rs[RS_LIMIT] returns zero force and counts a
    fault, as does a non-finite force. rs[RS_WORK] is the work (texture evaluations) of this
    call and rs[RS_MAXWORK] the largest so far.
    """
    code = int(mem[H_CODE])
    kind = int(mem[H_KIND])
    rows = int(mem[H_ROWS])
    cols = int(mem[H_COLS])
    coeffs = mem[R_DATA:R_DATA + rows * cols].reshape((rows, cols))
    aux = mem[R_DATA + rows * cols:R_DATA + rows * cols + int(mem[H_NAUX])]
    prm = mem[R_PRM:R_RS]
    rs = mem[R_RS:R_PC]
    pc = mem[R_PC:R_BUF]
    buf = mem[R_BUF:R_ST]
    st = mem[R_ST:R_DATA]
    rs[RS_WORK] = 0.0
    n = int(rs[RS_DIM])
    lim = rs[RS_LIMIT]
    if (not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)) or abs(x) > lim or abs(y) > lim
            or abs(z) > lim):
        rs[RS_FAULTS] += 1.0
        pc[PC_HAVE] = 0.0
        return 0.0, 0.0, 0.0
    p = buf[:3]
    f = buf[3:]
    p[0] = x
    p[1] = z if n == 2 else y
    p[2] = z
    force_at(n, code, p, kind, coeffs, prm, aux, st, f)
    rs[RS_WORK] = st[S_WORK]
    if st[S_WORK] > rs[RS_MAXWORK]:
        rs[RS_MAXWORK] = st[S_WORK]
    if rs[RS_MONITOR] != 0.0:
        passivity_tick(pc, n, p, f, prm[P_K0], st[S_PEN])
    clamped = saturate_vec(f, n, rs[RS_MAXF])
    for i in range(n):
        if not math.isfinite(f[i]):
            rs[RS_FAULTS] += 1.0
            pc[PC_HAVE] = 0.0
            st[S_CONTACT] = 0.0
            return 0.0, 0.0, 0.0
    if clamped:
        rs[RS_CLAMPS] += 1.0
    if rs[RS_MONITOR] != 0.0:
        passivity_sent(pc, n, p, f)
    if n == 2:
        return f[0], 0.0, f[1]
    return f[0], f[1], f[2]


@nb.njit(parallel=True, cache=True, nogil=True)
def tail_amplitudes(u, a1, a2):
    """Remove from each row of ``u`` (N, m), in place, its mean and least-squares straight
    line (steady sliding or drift is not an oscillation), and write half the peak-to-peak of
    the detrended row in its first and second halves into a1 and a2 (shape (N,)): the
    amplitudes of the oscillation verdict (:func:`haptex.simulate._axis_verdicts`). The rows
    may be a strided view (one axis of the simulator's tail, (N, d, m)): nothing is copied."""
    N, m = u.shape
    tm = 0.5 * (m - 1)
    stt = 0.0
    for j in range(m):
        stt += (j - tm) * (j - tm)
    for r in nb.prange(N):
        mean = 0.0
        for j in range(m):
            mean += u[r, j]
        mean /= m
        sty = 0.0
        for j in range(m):
            sty += (j - tm) * (u[r, j] - mean)
        slope = sty / stt if stt > 0.0 else 0.0
        lo1 = math.inf
        hi1 = -math.inf
        lo2 = math.inf
        hi2 = -math.inf
        for j in range(m):
            w = u[r, j] - mean - slope * (j - tm)
            u[r, j] = w
            if j < m // 2:
                lo1 = min(lo1, w)
                hi1 = max(hi1, w)
            else:
                lo2 = min(lo2, w)
                hi2 = max(hi2, w)
        a1[r] = 0.5 * (hi1 - lo1) if m // 2 > 0 else 0.0
        a2[r] = 0.5 * (hi2 - lo2)
