"""Numba-compiled scalar kernels (private).

No validation, no allocation in the inner loops, no I/O: the Python wrappers in the public
modules validate and convert inputs once and call these. Every kernel here has a plain
NumPy counterpart that the tests compare it with (the texture methods, and a brute-force
closest-point search).

Texture encoding shared by all kernels
--------------------------------------
``kind`` selects the representation and ``coeffs`` holds its numbers:

* ``TEXTURE_FLAT`` (0): h = 0 (no texture, e.g. algorithm W); ``coeffs`` is ignored.
* ``TEXTURE_FOURIER`` (1): ``coeffs`` has shape (3, n): amplitudes a_k (m), wavenumbers
  k_k = 2*pi/l_k (rad/m) and phases phi_k (rad); h(x) = sum a_k sin(k_k x + phi_k).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

TEXTURE_FLAT = 0
TEXTURE_FOURIER = 1

_JIT = dict(cache=True, fastmath=False, nogil=True)


@nb.njit(**_JIT)
def texture_eval(kind, coeffs, x):
    """Return (h, h', h'') at abscissa ``x`` (m, m/m, 1/m)."""
    h = 0.0
    s = 0.0
    c = 0.0
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


@nb.njit(**_JIT)
def _dphi(kind, coeffs, px, pz, t):
    """Half the derivative of the squared distance phi(t) = (t-px)^2 + (h(t)-pz)^2 and
    half its second derivative, plus phi itself."""
    h, s, c = texture_eval(kind, coeffs, t)
    dz = h - pz
    g = (t - px) + dz * s
    gp = 1.0 + s * s + dz * c
    return (t - px) * (t - px) + dz * dz, g, gp


@nb.njit(**_JIT)
def _refine_bracket(kind, coeffs, px, pz, a, b):
    """Root of g = phi'/2 in [a, b] where g(a) <= 0 <= g(b): safeguarded Newton."""
    lo = a
    hi = b
    t = 0.5 * (a + b)
    for _ in range(100):
        _, g, gp = _dphi(kind, coeffs, px, pz, t)
        if g > 0.0:
            hi = t
        else:
            lo = t
        if gp > 0.0:
            tn = t - g / gp
        else:
            tn = 0.5 * (lo + hi)
        if not (lo < tn < hi):
            tn = 0.5 * (lo + hi)
        if abs(tn - t) <= 1e-15 * (1.0 + abs(t)) or hi - lo <= 1e-16 * (1.0 + abs(t)):
            t = tn
            break
        t = tn
    return t


@nb.njit(**_JIT)
def _golden(kind, coeffs, px, pz, a, b):
    """Golden-section minimisation of phi on [a, b]; returns (t, phi)."""
    r = 0.6180339887498949
    c = b - r * (b - a)
    d = a + r * (b - a)
    fc, _, _ = _dphi(kind, coeffs, px, pz, c)
    fd, _, _ = _dphi(kind, coeffs, px, pz, d)
    for _ in range(80):
        if fc < fd:
            b = d
            d = c
            fd = fc
            c = b - r * (b - a)
            fc, _, _ = _dphi(kind, coeffs, px, pz, c)
        else:
            a = c
            c = d
            fc = fd
            d = a + r * (b - a)
            fd, _, _ = _dphi(kind, coeffs, px, pz, d)
    t = 0.5 * (a + b)
    f, _, _ = _dphi(kind, coeffs, px, pz, t)
    return t, f


@nb.njit(**_JIT)
def _polish(kind, coeffs, px, pz, t, a, b):
    """Newton iterations on phi'/2 from t, kept inside [a, b]."""
    for _ in range(60):
        _, g, gp = _dphi(kind, coeffs, px, pz, t)
        if gp <= 0.0:
            break
        tn = min(max(t - g / gp, a), b)
        if abs(tn - t) <= 1e-15 * (1.0 + abs(t)):
            return tn
        t = tn
    return t


@nb.njit(**_JIT)
def closest_point(kind, coeffs, step, px, pz):
    """Closest point abscissa t on the boundary z = h(x) to a point (px, pz) below it.

    The global minimiser of phi(t) = (t-px)^2 + (h(t)-pz)^2 lies in
    [px - dv, px + dv] with dv = h(px) - pz (the vertical distance bounds the minimum
    distance). That interval is sampled every ``step`` (a fraction of the texture's
    shortest period); every sampled sign change of phi' from - to + is solved by
    safeguarded Newton, and the best sample is also refined by golden section in its two
    neighbouring cells, so that a minimum between two samples is not lost. Returns
    (t, distance, number_of_near_ties) where the last counts other local minima whose
    distance is within 1e-9 relative of the best (a point on the medial axis).
    """
    h0, _, _ = texture_eval(kind, coeffs, px)
    dv = h0 - pz
    if dv <= 0.0:
        return px, 0.0, 0
    n = int(math.ceil(2.0 * dv / step))
    if n < 8:
        n = 8
    dt = 2.0 * dv / n
    best_t = px
    best_f = math.inf
    found = False
    second_f = math.inf
    t_prev = px - dv
    f_prev, g_prev, _ = _dphi(kind, coeffs, px, pz, t_prev)
    node_best_i = 0
    node_best_f = f_prev
    for i in range(1, n + 1):
        t_i = px - dv + i * dt
        f_i, g_i, _ = _dphi(kind, coeffs, px, pz, t_i)
        if f_i < node_best_f:
            node_best_f = f_i
            node_best_i = i
        if g_prev <= 0.0 and g_i > 0.0:
            t = _refine_bracket(kind, coeffs, px, pz, t_prev, t_i)
            f, _, _ = _dphi(kind, coeffs, px, pz, t)
            if f < best_f:
                if found and best_f < second_f and abs(t - best_t) > 0.5 * dt:
                    second_f = best_f
                best_f = f
                best_t = t
                found = True
            elif f < second_f and abs(t - best_t) > 0.5 * dt:
                second_f = f
        t_prev = t_i
        g_prev = g_i
    # safety net: refine around the best sample (covers a min/max pair inside one cell)
    a = px - dv + max(node_best_i - 1, 0) * dt
    b = px - dv + min(node_best_i + 1, n) * dt
    t, f = _golden(kind, coeffs, px, pz, a, b)
    if not found or abs(t - best_t) > 0.5 * dt:
        # a minimum that no bracket caught: polish it to full precision with Newton
        t = _polish(kind, coeffs, px, pz, t, a, b)
        f, _, _ = _dphi(kind, coeffs, px, pz, t)
        if f < best_f:
            if found and best_f < second_f:
                second_f = best_f
            best_f = f
            best_t = t
        elif found and f < second_f:
            second_f = f
    ties = 0
    if second_f < math.inf and math.sqrt(second_f) - math.sqrt(best_f) <= 1e-9 * math.sqrt(best_f):
        ties = 1
    return best_t, math.sqrt(best_f), ties


@nb.njit(**_JIT)
def closest_points(kind, coeffs, step, px, pz, t_out, d_out, tie_out):
    """Vectorised :func:`closest_point` over flat arrays ``px``, ``pz`` (inside points)."""
    for i in range(px.shape[0]):
        t, d, tie = closest_point(kind, coeffs, step, px[i], pz[i])
        t_out[i] = t
        d_out[i] = d
        tie_out[i] = tie


def empty_coeffs() -> np.ndarray:
    """Coefficient array for ``TEXTURE_FLAT``."""
    return np.zeros((3, 0), dtype=np.float64)


# ----------------------------------------------------------------------------------------
# Algorithm force kernels: one scalar entry point for every letter, dispatched by code.
# ----------------------------------------------------------------------------------------
ALG_W, ALG_A, ALG_B, ALG_C, ALG_D, ALG_E, ALG_F, ALG_G = 0, 1, 2, 3, 4, 5, 6, 7
# parameter vector layout (float64[8])
P_K0, P_DZMAX, P_MU, P_DXMAX, P_SCALE, P_ZSTICK, P_STEP = 0, 1, 2, 3, 4, 5, 6
N_PARAMS = 8
# state vector layout (float64[3]) for F: adhesion point, in-contact flag, last x
S_ADH, S_CONTACT, S_LASTX = 0, 1, 2
N_STATE = 3


@nb.njit(**_JIT)
def _clamp_depth(d, dzmax):
    """Lateral depth of Remark 3: max(d, -d_max) when d_max > 0 (d < 0 inside)."""
    if dzmax > 0.0 and d < -dzmax:
        return -dzmax
    return d


@nb.njit(**_JIT)
def _presliding(st, x, dxmax, zstick):
    """Advance F's friction state to x; returns the deflection."""
    if zstick < 0.0:
        d = x - st[S_ADH]
        if d > dxmax:
            d = dxmax
            st[S_ADH] = x - dxmax
        elif d < -dxmax:
            d = -dxmax
            st[S_ADH] = x + dxmax
        st[S_LASTX] = x
        return d
    d0 = st[S_LASTX] - st[S_ADH]
    dx = x - st[S_LASTX]
    d = d0
    if dx != 0.0:
        direction = 1.0 if dx > 0.0 else -1.0
        n = int(math.ceil(abs(dx) / ((dxmax - zstick) / 64.0)))
        if n < 1:
            n = 1
        h = dx / n
        for _ in range(n):
            k1 = _smooth_rate(d, direction, dxmax, zstick)
            k2 = _smooth_rate(d + 0.5 * h * k1, direction, dxmax, zstick)
            k3 = _smooth_rate(d + 0.5 * h * k2, direction, dxmax, zstick)
            k4 = _smooth_rate(d + h * k3, direction, dxmax, zstick)
            d += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
            if d > dxmax:
                d = dxmax
            elif d < -dxmax:
                d = -dxmax
    st[S_ADH] = x - d
    st[S_LASTX] = x
    return d


@nb.njit(**_JIT)
def _smooth_rate(d, direction, dxmax, zstick):
    if d * direction <= 0.0:
        return 1.0
    a = abs(d)
    if a <= zstick:
        alpha = 0.0
    elif a >= dxmax:
        alpha = 1.0
    else:
        alpha = 0.5 + 0.5 * math.sin(math.pi * (a - 0.5 * (dxmax + zstick)) / (dxmax - zstick))
    return 1.0 - alpha * a / dxmax


@nb.njit(**_JIT)
def alg_force(code, x, z, kind, coeffs, prm, st):
    """Force (fx, fz) in N of algorithm ``code`` at the probe position (x, z) in m.

    Mirrors the vectorised ``force`` of :mod:`haptex.algorithms` (the tests compare them).
    ``st`` is F's friction state (updated in place: contact starts with zero deflection,
    leaving the wall resets it); other algorithms ignore it.
    """
    k0 = prm[P_K0]
    if code == ALG_W:
        if z < 0.0:
            return 0.0, -k0 * z
        return 0.0, 0.0
    if code == ALG_F or code == ALG_G:
        if z >= 0.0:
            st[S_CONTACT] = 0.0
            return 0.0, 0.0
        if code == ALG_G:
            h, s, c = texture_eval(kind, coeffs, x)
            g = 1.0 / math.sqrt(1.0 + s * s)
            dl = _clamp_depth(z, prm[P_DZMAX])
            return k0 * dl * s * g, -k0 * z * g
        if st[S_CONTACT] == 0.0:
            st[S_CONTACT] = 1.0
            st[S_ADH] = x
            st[S_LASTX] = x
        d = _presliding(st, x, prm[P_DXMAX], prm[P_ZSTICK])
        h, s, c = texture_eval(kind, coeffs, x)
        depth = -z
        if prm[P_DZMAX] > 0.0 and depth > prm[P_DZMAX]:
            depth = prm[P_DZMAX]
        m = 1.0 - prm[P_SCALE] * h
        return -prm[P_MU] * k0 * depth * m * d / prm[P_DXMAX], -k0 * z
    h, s, c = texture_eval(kind, coeffs, x)
    d = z - h
    if d >= 0.0:
        return 0.0, 0.0
    if code == ALG_A:
        return 0.0, -k0 * d
    if code == ALG_B:
        g = 1.0 / math.sqrt(1.0 + s * s)
        return k0 * _clamp_depth(d, prm[P_DZMAX]) * s * g, -k0 * d * g
    if code == ALG_C:
        return k0 * _clamp_depth(d, prm[P_DZMAX]) * s, -k0 * d
    t, dist, tie = closest_point(kind, coeffs, prm[P_STEP], x, z)
    if code == ALG_D:
        th, _, _ = texture_eval(kind, coeffs, t)
        return -k0 * (x - t), -k0 * (z - th)
    return 0.0, k0 * dist  # ALG_E
