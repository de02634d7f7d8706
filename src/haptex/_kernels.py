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

import numba as nb
import numpy as np

TEXTURE_FLAT = 0
TEXTURE_FOURIER = 1
TEXTURE_SPLINE = 2

_JIT = dict(cache=True, fastmath=False, nogil=True)

MAX_CELLS = 4_000_000
"""Largest number of coarse cells one closest-point search may scan (a probe more than
about 10^6 texture periods deep); beyond it the search returns NaN."""


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
def closest_point(kind, coeffs, step, slope_bound, curv_bound, px, pz, t_guess):
    """Closest point abscissa t on the boundary z = h(x) to a point (px, pz) below it.

    The global minimiser of phi(t) = (t-px)^2 + (h(t)-pz)^2 lies within the current best
    distance R of px (R starts at the vertical depth dv = h(px) - pz, or at the distance
    to the point a warm start ``t_guess`` converges to, if that is smaller). [px - R,
    px + R] is cut into coarse cells of 8 ``step``; a cell is skipped when a rigorous
    lower bound of the distance over it, from the Lipschitz bound ``slope_bound`` of h
    and the bound ``curv_bound`` of |h''| (Taylor: h(t) lies within
    |h'(c)| w/2 + curv_bound w^2/8 of h(c) on a cell of width w centred on c), is not
    below R. Surviving cells are sampled every ``step`` (a fraction of the
    texture's shortest period); every sampled sign change of phi' from - to + is solved by
    safeguarded Newton, and the best sample is polished by bounded Newton too, so a
    minimum between two samples is not lost. Returns (t, distance, tie) where tie is 1
    when another, distinct local minimum lies at the same distance to 1e-9 relative (a
    point on the medial axis).
    """
    h0, _, _ = texture_eval(kind, coeffs, px)
    dv = h0 - pz
    if dv <= 0.0:
        return px, 0.0, 0
    best_t = px
    best_f = dv * dv  # the vertical point is on the boundary: a valid upper bound
    found = False
    second_f = math.inf
    if t_guess == t_guess:  # warm start (not NaN)
        tg = _polish(kind, coeffs, px, pz, t_guess, px - dv, px + dv)
        fg, gg, gpg = _dphi(kind, coeffs, px, pz, tg)
        if fg < best_f:
            best_f = fg
            best_t = tg
    radius = math.sqrt(best_f)
    fine = 8
    width = fine * step
    if 2.0 * radius / width > MAX_CELLS:
        return px, math.nan, 0  # absurdly deep for this texture: the caller reports it
    n_coarse = int(math.ceil(2.0 * radius / width))
    if n_coarse < 1:
        n_coarse = 1
    width = 2.0 * radius / n_coarse
    if width / fine > step:
        fine = int(math.ceil(width / step))
    dt = width / fine
    node_best_t = px
    node_best_f = math.inf
    for ci in range(n_coarse):
        a = px - radius + ci * width
        c = a + 0.5 * width
        hc, sc, _ = texture_eval(kind, coeffs, c)
        dx_lb = abs(c - px) - 0.5 * width
        if dx_lb < 0.0:
            dx_lb = 0.0
        spread = slope_bound * 0.5 * width
        taylor = abs(sc) * 0.5 * width + curv_bound * 0.125 * width * width
        if taylor < spread:
            spread = taylor
        dz_lb = abs(hc - pz) - spread
        if dz_lb < 0.0:
            dz_lb = 0.0
        if dx_lb * dx_lb + dz_lb * dz_lb >= best_f * (1.0 + 1e-12):
            continue
        t_prev = a
        f_prev, g_prev, _ = _dphi(kind, coeffs, px, pz, t_prev)
        if f_prev < node_best_f:
            node_best_f = f_prev
            node_best_t = t_prev
        for i in range(1, fine + 1):
            t_i = a + i * dt
            f_i, g_i, _ = _dphi(kind, coeffs, px, pz, t_i)
            if f_i < node_best_f:
                node_best_f = f_i
                node_best_t = t_i
            if g_prev <= 0.0 and g_i > 0.0:
                t = _refine_bracket(kind, coeffs, px, pz, t_prev, t_i)
                f, _, _ = _dphi(kind, coeffs, px, pz, t)
                if f < best_f:
                    if found and best_f < second_f and abs(t - best_t) > 0.5 * dt:
                        second_f = best_f
                    best_f = f
                    best_t = t
                    found = True
                elif found and f < second_f and abs(t - best_t) > 0.5 * dt:
                    second_f = f
            t_prev = t_i
            g_prev = g_i
    # safety net: polish the best sample (covers a min/max pair inside one cell)
    if node_best_f < math.inf:
        lo = node_best_t - dt
        hi = node_best_t + dt
        t = _polish(kind, coeffs, px, pz, node_best_t, lo, hi)
        f, _, _ = _dphi(kind, coeffs, px, pz, t)
        if not found or abs(t - best_t) > 0.5 * dt:
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


@nb.njit(parallel=True, cache=True, nogil=True)
def closest_points(kind, coeffs, step, slope_bound, curv_bound, px, pz, t_out, d_out, tie_out):
    """Vectorised :func:`closest_point` over flat arrays ``px``, ``pz`` (no warm start),
    in parallel over the cores."""
    for i in nb.prange(px.shape[0]):
        t, d, tie = closest_point(kind, coeffs, step, slope_bound, curv_bound, px[i], pz[i], math.nan)
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
# parameter vector layout (float64[9])
P_K0, P_DZMAX, P_MU, P_DXMAX, P_SCALE, P_ZSTICK, P_STEP, P_SLOPE, P_CURV = 0, 1, 2, 3, 4, 5, 6, 7, 8
N_PARAMS = 9
# state vector layout (float64[3]) for F: adhesion point, in-contact flag, last x
S_ADH, S_CONTACT, S_LASTX = 0, 1, 2
N_STATE = 3


@nb.njit(**_JIT)
def _clamp_depth(d, dzmax):
    """Lateral depth of Remark 3: max(d, -d_max) when d_max > 0 (d < 0 inside)."""
    if dzmax > 0.0 and d < -dzmax:
        return -dzmax
    return d


# presliding friction (Hayward & Armstrong 2000), used by haptex.friction and by F
@nb.njit(**_JIT)
def _alpha(a, d_max, z_stick):
    if a <= z_stick:
        return 0.0
    if a >= d_max:
        return 1.0
    return 0.5 + 0.5 * math.sin(math.pi * (a - 0.5 * (d_max + z_stick)) / (d_max - z_stick))


@nb.njit(**_JIT)
def _rate(d, direction, d_max, z_stick):
    """dd/dx for motion in ``direction`` (+1 or -1) at deflection d (smooth model)."""
    if d * direction <= 0.0:
        return 1.0  # |d| shrinks (or is zero): purely elastic
    return 1.0 - _alpha(abs(d), d_max, z_stick) * abs(d) / d_max


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


@nb.njit(**_JIT)
def presliding_step_smooth(deflection, dx, d_max, z_stick):
    """Compiled update of the smooth variant: integrate dd/dx over an increment dx.

    Parameters
    ----------
    deflection : float
        Deflection before the step (m).
    dx : float
        Displacement of the probe during the step (m).
    d_max, z_stick : float
        Model parameters (m), 0 <= z_stick < d_max.

    Returns
    -------
    float
        Deflection after the step (m), |d| <= d_max.
    """
    if dx == 0.0:
        return deflection
    direction = 1.0 if dx > 0.0 else -1.0
    h_max = (d_max - z_stick) / 64.0
    n = int(math.ceil(abs(dx) / h_max))
    if n < 1:
        n = 1
    h = dx / n
    d = deflection
    for _ in range(n):
        k1 = _rate(d, direction, d_max, z_stick)
        k2 = _rate(d + 0.5 * h * k1, direction, d_max, z_stick)
        k3 = _rate(d + 0.5 * h * k2, direction, d_max, z_stick)
        k4 = _rate(d + h * k3, direction, d_max, z_stick)
        d += h * (k1 + 2.0 * k2 + 2.0 * k3 + k4) / 6.0
        if d > d_max:
            d = d_max
        elif d < -d_max:
            d = -d_max
    return d


@nb.njit(**_JIT)
def _presliding(st, x, dxmax, zstick):
    """Advance F's friction state to x (see haptex.friction); returns the deflection."""
    if zstick < 0.0:
        d, st[S_ADH] = presliding_step(st[S_ADH], x, dxmax)
    else:
        d = presliding_step_smooth(st[S_LASTX] - st[S_ADH], x - st[S_LASTX], dxmax, zstick)
        st[S_ADH] = x - d
    st[S_LASTX] = x
    return d


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
    guess = st[S_ADH] if st[S_CONTACT] != 0.0 else math.nan
    t, dist, tie = closest_point(kind, coeffs, prm[P_STEP], prm[P_SLOPE], prm[P_CURV], x, z, guess)
    st[S_ADH] = t  # warm start of the next call (D and E keep the last closest point here)
    st[S_CONTACT] = 1.0
    if code == ALG_D:
        th, _, _ = texture_eval(kind, coeffs, t)
        return -k0 * (x - t), -k0 * (z - th)
    return 0.0, k0 * dist  # ALG_E


# --------------------------------------------------------------------------------------
# the simulator's compiled loop (haptex.simulate)
# --------------------------------------------------------------------------------------
_NZ = 10  # augmented state [p(2), v(2), u(2), g(2), r(2)]

# summary slots
(S_EX, S_EZ, S_DAMP, S_OP, S_KE0, S_KE, S_SAT, S_MAXPEN, S_MAXF, S_NSAMP, S_TAILSTART_E) = range(11)
N_SUMMARY = 12


@nb.njit(**_JIT)
def _half_quad2(A, v):
    """v' A v / 2 for a 2x2 matrix (kinetic energy with A = M)."""
    return 0.5 * (v[0] * (A[0, 0] * v[0] + A[0, 1] * v[1]) + v[1] * (A[1, 0] * v[0] + A[1, 1] * v[1]))


@nb.njit(**_JIT)
def _quad(W, z):
    acc = 0.0
    for i in range(_NZ):
        row = 0.0
        for j in range(_NZ):
            row += W[i, j] * z[j]
        acc += z[i] * row
    return acc


@nb.njit(**_JIT)
def _setpoint(ts, ps, vend, t, out):
    n = ts.shape[0]
    if t >= ts[n - 1]:
        dt = t - ts[n - 1]
        out[0] = ps[n - 1, 0] + vend[0] * dt
        out[1] = ps[n - 1, 1] + vend[1] * dt
        return
    if t <= ts[0]:
        out[0] = ps[0, 0]
        out[1] = ps[0, 1]
        return
    lo = 0
    hi = n - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if ts[mid] <= t:
            lo = mid
        else:
            hi = mid
    w = (t - ts[lo]) / (ts[hi] - ts[lo])
    out[0] = ps[lo, 0] + w * (ps[hi, 0] - ps[lo, 0])
    out[1] = ps[lo, 1] + w * (ps[hi, 1] - ps[lo, 1])


@nb.njit(**_JIT)
def run_one(code, kind, coeffs, prm, nominal, Phi, Wd, Wo, Bs, M, K, C, f0, sp_t, sp_p, vend, rest_len, kinematic,
         n_steps, T, delay, delta, fres, fmax, p0, v0, record_every, rec, summary, tail_start, tail_z):
    """One simulation; fills ``rec`` (n_rec, 12) if it has rows, ``summary`` and ``tail_z``.

    Record columns: t, px, pz, vx, vz, fx, fz, E_x, E_z, E_damping, W_operator, KE.
    """
    st = np.zeros(N_STATE)
    z = np.zeros(_NZ)
    p = p0.copy()
    v = v0.copy()
    buf = np.zeros((delay + 1, 2))
    s0 = np.zeros(2)
    s1 = np.zeros(2)
    ex = 0.0
    ez = 0.0
    ed = 0.0
    eo = 0.0
    sat = 0
    maxpen = 0.0
    maxf = 0.0
    ke0 = _half_quad2(M, v)
    ke_prev = ke0
    n_tail = tail_z.shape[0]
    tail_stride = max((n_steps - tail_start) // max(n_tail, 1), 1)
    e_tail = 0.0
    irec = 0
    nrec = rec.shape[0]
    for k in range(n_steps):
        t = k * T
        if kinematic:
            _setpoint(sp_t, sp_p, vend, t, p)
            _setpoint(sp_t, sp_p, vend, t + T, s1)
            v[0] = (s1[0] - p[0]) / T
            v[1] = (s1[1] - p[1]) / T
        # controller: sense, compute, quantise, saturate, delay
        if delta > 0.0:
            sx = delta * np.round(p[0] / delta)
            sz = delta * np.round(p[1] / delta)
        else:
            sx = p[0]
            sz = p[1]
        fx, fz = alg_force(code, sx, sz, kind, coeffs, prm, st)
        if fres > 0.0:
            fx = fres * np.round(fx / fres)
            fz = fres * np.round(fz / fres)
        mag = math.sqrt(fx * fx + fz * fz)
        if mag > fmax:
            fx *= fmax / mag
            fz *= fmax / mag
            sat += 1
        slot = k % (delay + 1)
        buf[slot, 0] = fx
        buf[slot, 1] = fz
        ux = buf[(k + 1) % (delay + 1), 0] if delay > 0 else fx
        uz = buf[(k + 1) % (delay + 1), 1] if delay > 0 else fz
        if delay > 0 and k < delay:
            ux = 0.0
            uz = 0.0
        # damping regime from the sensed position (brakes on inside the virtual object)
        if nominal:
            inside = sz < 0.0
            pen = -p[1]
        else:
            h, _, _ = texture_eval(kind, coeffs, sx)
            inside = sz < h
            if delta > 0.0:
                h, _, _ = texture_eval(kind, coeffs, p[0])
            pen = h - p[1]
        if pen > maxpen:
            maxpen = pen
        if mag > maxf:
            maxf = mag
        reg = 1 if inside else 0
        if kinematic:
            # prescribed motion: constant velocity over the sample; the operator supplies
            # whatever work keeps it on the path (so the energy balance closes by design)
            dpx = s1[0] - p[0]
            dpz = s1[1] - p[1]
            dd = 2.0 * T * _half_quad2(Bs[reg], v)
            ke_now = _half_quad2(M, v)
            if k == 0:
                ke0 = ke_now
                ke_prev = ke_now
            ed += dd
            eo += (ke_now - ke_prev) + dd - (ux * dpx + uz * dpz)
            ke_prev = ke_now
            ex -= ux * dpx
            ez -= uz * dpz
            p[0] = s1[0]
            p[1] = s1[1]
        else:
            # operator forcing over [t, t + T]: g(t + s) = g0 + r s
            _setpoint(sp_t, sp_p, vend, t, s0)
            _setpoint(sp_t, sp_p, vend, t + T, s1)
            sdx = (s1[0] - s0[0]) / T
            sdz = (s1[1] - s0[1]) / T
            g0x = K[0, 0] * s0[0] + K[0, 1] * s0[1] + C[0, 0] * sdx + C[0, 1] * sdz + f0[0]
            g0z = K[1, 0] * s0[0] + K[1, 1] * s0[1] + C[1, 0] * sdx + C[1, 1] * sdz + f0[1]
            if rest_len > 0.0:
                ax = p[0] - sp_p[0, 0]
                az = p[1] - sp_p[0, 1]
                nrm = math.sqrt(ax * ax + az * az)
                if nrm > 0.0:
                    g0x += K[0, 0] * rest_len * ax / nrm
                    g0z += K[1, 1] * rest_len * az / nrm
            z[0] = p[0]
            z[1] = p[1]
            z[2] = v[0]
            z[3] = v[1]
            z[4] = ux
            z[5] = uz
            z[6] = g0x
            z[7] = g0z
            z[8] = K[0, 0] * sdx + K[0, 1] * sdz
            z[9] = K[1, 0] * sdx + K[1, 1] * sdz
            ed += _quad(Wd[reg], z)
            eo += _quad(Wo[reg], z)
            P = Phi[reg]
            npx = 0.0
            npz = 0.0
            nvx = 0.0
            nvz = 0.0
            for j in range(_NZ):
                npx += P[0, j] * z[j]
                npz += P[1, j] * z[j]
                nvx += P[2, j] * z[j]
                nvz += P[3, j] * z[j]
            ex -= ux * (npx - p[0])
            ez -= uz * (npz - p[1])
            p[0] = npx
            p[1] = npz
            v[0] = nvx
            v[1] = nvz
        if k == tail_start:
            e_tail = ex + ez
        if k >= tail_start and n_tail > 0:
            j = (k - tail_start) // tail_stride
            if j < n_tail:
                tail_z[j] = p[1]
        if nrec > 0 and (k + 1) % record_every == 0 and irec < nrec:
            rec[irec, 0] = t + T
            rec[irec, 1] = p[0]
            rec[irec, 2] = p[1]
            rec[irec, 3] = v[0]
            rec[irec, 4] = v[1]
            rec[irec, 5] = ux
            rec[irec, 6] = uz
            rec[irec, 7] = ex
            rec[irec, 8] = ez
            rec[irec, 9] = ed
            rec[irec, 10] = eo
            rec[irec, 11] = _half_quad2(M, v)
            irec += 1
    summary[S_EX] = ex
    summary[S_EZ] = ez
    summary[S_DAMP] = ed
    summary[S_OP] = eo
    summary[S_KE0] = ke0
    summary[S_KE] = _half_quad2(M, v)
    summary[S_SAT] = sat
    summary[S_MAXPEN] = maxpen
    summary[S_MAXF] = maxf
    summary[S_NSAMP] = n_steps
    summary[S_TAILSTART_E] = e_tail


@nb.njit(parallel=True, cache=True)
def run_batch(code, kind, coeffs, prm, nominal, Phi, Wd, Wo, Bs, M, K, C, f0, sp_t, sp_p, vend, rest_len,
               kinematic, n_steps, T, delay, delta, fres, fmax, p0, v0, record_every, rec, summary, tail_start,
               tail_z):
    """Runs i = 0..N-1 of :func:`run_one` in parallel; every per-run array has a leading N axis."""
    for i in nb.prange(coeffs.shape[0]):
        run_one(code, kind, coeffs[i], prm[i], nominal, Phi[i], Wd[i], Wo[i], Bs[i], M[i], K[i], C[i], f0[i], sp_t,
             sp_p[i], vend[i], rest_len[i], kinematic, n_steps, T, delay[i], delta[i], fres[i], fmax[i], p0[i], v0[i],
             record_every, rec[i], summary[i], tail_start, tail_z[i])


# --------------------------------------------------------------------------------------
# the renderer's servo tick (haptex.Renderer)
# --------------------------------------------------------------------------------------
# renderer state slots (float64 array)
RS_MAXF, RS_FAULTS, RS_CLAMPS, RS_MONITOR, RS_HAVE_LAST, RS_LX, RS_LZ, RS_LFX, RS_LFZ, RS_EX, RS_EZ, RS_LIMIT = range(12)
N_RS = 12


@nb.njit(**_JIT)
def render_step(x, z, code, kind, coeffs, prm, st, rs):
    """Compiled servo-tick: validate, compute, clamp, count, observe energy."""
    if not (math.isfinite(x) and math.isfinite(z)) or abs(x) > rs[RS_LIMIT] or abs(z) > rs[RS_LIMIT]:
        rs[RS_FAULTS] += 1.0
        rs[RS_HAVE_LAST] = 0.0
        return 0.0, 0.0
    fx, fz = alg_force(code, x, z, kind, coeffs, prm, st)
    if not (math.isfinite(fx) and math.isfinite(fz)):
        rs[RS_FAULTS] += 1.0
        rs[RS_HAVE_LAST] = 0.0
        st[S_CONTACT] = 0.0
        return 0.0, 0.0
    mag = math.sqrt(fx * fx + fz * fz)
    if mag > rs[RS_MAXF]:
        s = rs[RS_MAXF] / mag
        fx *= s
        fz *= s
        rs[RS_CLAMPS] += 1.0
    if rs[RS_MONITOR] != 0.0:
        # passivity observer (Hannaford & Ryu 2002): energy absorbed by the environment,
        # the force held over the last period times the displacement it saw
        if rs[RS_HAVE_LAST] != 0.0:
            rs[RS_EX] -= rs[RS_LFX] * (x - rs[RS_LX])
            rs[RS_EZ] -= rs[RS_LFZ] * (z - rs[RS_LZ])
        rs[RS_LX] = x
        rs[RS_LZ] = z
        rs[RS_LFX] = fx
        rs[RS_LFZ] = fz
        rs[RS_HAVE_LAST] = 1.0
    return fx, fz
