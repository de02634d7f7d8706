/*
 * Data-driven vibration: a set of ARMA models at operating points (tangential speed, normal
 * force), interpolated at the tick's operating point and driven by white noise (Romano &
 * Kuchenbecker, "Creating realistic virtual textures from contact acceleration data", IEEE
 * Trans. Haptics 5(2), 2012; Culbertson, Lopez Delgado & Kuchenbecker, "One hundred
 * data-driven haptic texture models and open-source methods for rendering on 3D objects",
 * IEEE Haptics Symposium 2014: the Penn Haptic Texture Toolkit, HaTT).
 *
 * One tick: the triangle of the set's triangulation holding the operating point (the last
 * one first, then every triangle: at most n_tri tests, counted), its barycentric weights, the
 * interpolated line spectral frequencies (LSF) of the AR and MA parts and the interpolated
 * variance and gain, the LSF turned into polynomial coefficients, one step of
 *
 *     y_n = -sum_{i=1..p} a_i y_{n-i} + gain * (e_n + sum_{i=1..q} b_i e_{n-i}),
 *     e_n ~ N(0, variance),
 *
 * with e_n from a counter-based generator (splitmix64 of seed and sample index, Box-Muller),
 * so that a run is reproducible and an exported renderer bit-identical. An operating point
 * outside the triangulation's hull is moved to the hull's closest point and counted; a
 * non-finite one gives 0 for that sample and is counted as a fault. No allocation.
 *
 * The set's layout (float64, checked by hx_vib_check): a header of HX_V_HEAD values, then
 * n_model rows of HX_V_ROW + p + q values (speed (m/s), force (N), variance ((m/s^2)^2),
 * gain, the AR part's p LSF (rad, ascending in (0, pi)), the MA part's q LSF), then the
 * n_tri triangles' 3 vertex indices (0-based, as doubles). A set with no triangles has its models
 * on one line, in order along it, and is interpolated along that polyline.
 */
#include "hx_core.h"

#include <math.h>
#include <stdint.h>

#define HX_V_PI 3.14159265358979323846

static int lsf_ok(const double *w, int n)
{
    int k;
    for (k = 0; k < n; k++) {
        if (!(w[k] > 0.0 && w[k] < HX_V_PI))
            return 0;
        if (k > 0 && !(w[k] > w[k - 1]))
            return 0;
    }
    return 1;
}

int hx_vib_check(const double *v, long nv)
{
    long n, ntri, p, q, row, k, i;
    if (v == 0 || nv < HX_V_HEAD)
        return HX_BAD_COEFFS;
    n = (long)v[HX_V_N];
    ntri = (long)v[HX_V_NTRI];
    p = (long)v[HX_V_P];
    q = (long)v[HX_V_Q];
    if ((double)n != v[HX_V_N] || (double)ntri != v[HX_V_NTRI] || (double)p != v[HX_V_P] || (double)q != v[HX_V_Q])
        return HX_BAD_COEFFS;
    if (n < 1 || ntri < 0 || p < 0 || q < 0 || p > HX_VIB_MAX_ORDER || q > HX_VIB_MAX_ORDER ||
        n > HX_VIB_MAX_MODELS || ntri > 2 * HX_VIB_MAX_MODELS)
        return HX_BAD_COEFFS;
    if (!(v[HX_V_FS] > 0.0 && isfinite(v[HX_V_FS])) || !(v[HX_V_SSCALE] > 0.0 && isfinite(v[HX_V_SSCALE])) ||
        !(v[HX_V_FSCALE] > 0.0 && isfinite(v[HX_V_FSCALE])))
        return HX_BAD_COEFFS;
    row = HX_V_ROW + p + q;
    if (nv != HX_V_HEAD + n * row + 3 * ntri)
        return HX_BAD_COEFFS;
    for (k = 0; k < n; k++) {
        const double *m = v + HX_V_HEAD + k * row;
        if (!isfinite(m[0]) || !isfinite(m[1]) || !(m[2] >= 0.0 && isfinite(m[2])) || !isfinite(m[3]))
            return HX_BAD_COEFFS;
        if (!lsf_ok(m + HX_V_ROW, (int)p) || !lsf_ok(m + HX_V_ROW + p, (int)q))
            return HX_BAD_COEFFS;
    }
    for (i = 0; i < 3 * ntri; i++) {
        double t = v[HX_V_HEAD + n * row + i];
        if (!(t >= 0.0 && t < (double)n) || t != floor(t))
            return HX_BAD_COEFFS;
    }
    return HX_OK;
}

/* cos(x) for x in [0, pi] (an LSF, a Box-Muller angle folded there) without the C library: sin
 * of t = pi/2 - x by its odd Taylor series to t^21 (truncation below |t|^23 / 23! = 1.3e-18 on
 * |t| <= pi/2): within 2.3e-16 of glibc's cos at 10^6 points of [0, pi], in 2/3 of its time,
 * and the same on every C library (the exported C's bit-identity with the renderer). */
static double cos_0pi(double x)
{
    const double t = 1.57079632679489661923 - x, t2 = t * t;
    double s = 1.0 / 51090942171709440000.0;
    s = s * t2 - 1.0 / 121645100408832000.0;
    s = s * t2 + 1.0 / 355687428096000.0;
    s = s * t2 - 1.0 / 1307674368000.0;
    s = s * t2 + 1.0 / 6227020800.0;
    s = s * t2 - 1.0 / 39916800.0;
    s = s * t2 + 1.0 / 362880.0;
    s = s * t2 - 1.0 / 5040.0;
    s = s * t2 + 1.0 / 120.0;
    s = s * t2 - 1.0 / 6.0;
    return t + t * (t2 * s);
}

/* The palindromic product prod_j (1 + c_j z^-1 + z^-2) of m factors (1 for none), into out[0..2m].
 * A palindrome of degree 2h is kept by its first half, o[0..h]; one factor is a pass over
 * that half into the other buffer (o[h + 1] = o[h - 1] by the symmetry, o[-1] = o[-2] = 0 the
 * padding): half the multiplications of the whole product, and no branch. */
static void pair_product(const double *c, int m, double *out) /* c_j = c[2 j] */
{
    double b0[HX_VIB_MAX_ORDER + 8], b1[HX_VIB_MAX_ORDER + 8];
    double *o = b0 + 2, *nw = b1 + 2, *t;
    int j, i, h = 0;
    b0[0] = b0[1] = b1[0] = b1[1] = 0.0;
    o[0] = 1.0;
    for (j = 0; j < m; j++) {
        const double cj = c[2 * j];
        o[h + 1] = h >= 1 ? o[h - 1] : 0.0;
        for (i = 0; i <= h + 1; i++)
            nw[i] = o[i] + cj * o[i - 1] + o[i - 2];
        t = o;
        o = nw;
        nw = t;
        h++;
    }
    for (i = 0; i <= h; i++)
        out[i] = out[2 * h - i] = o[i];
}

void hx_lsf_to_poly(const double *w, int order, double *a)
{
    /* P(z) = A(z) + z^-(p+1) A(1/z) and Q(z) = A(z) - z^-(p+1) A(1/z) have their roots on the
     * unit circle, interlaced: P's at w[0], w[2], ..., Q's at w[1], w[3], ...; P's trivial root
     * is z = -1 for an even order, Q's z = +1 (and z = -1 too for an odd order). A = (P + Q) / 2. */
    double c[HX_VIB_MAX_ORDER + 1], P[HX_VIB_MAX_ORDER + 3], Q[HX_VIB_MAX_ORDER + 3];
    int mp = (order + 1) / 2, mq = order / 2, k;
    for (k = 0; k < order; k++) /* the cosines first, off the products' chain of dependences */
        c[k] = -2.0 * cos_0pi(w[k]);
    c[order] = 0.0;             /* (read by no factor) */
    pair_product(c, mp, P);     /* P's factors, at w[0], w[2], ...: degree 2 mp */
    pair_product(c + 1, mq, Q); /* Q's, at w[1], w[3], ...: degree 2 mq */
    P[2 * mp + 1] = Q[2 * mq + 1] = Q[2 * mq + 2] = 0.0;
    if (order % 2 == 0) { /* P times (1 + z^-1), Q times (1 - z^-1), both of degree p + 1 */
        for (k = order; k >= 1; k--)
            a[k] = 0.5 * ((P[k] + P[k - 1]) + (Q[k] - Q[k - 1]));
    } else { /* Q times (1 - z^-2): degree p + 1 */
        for (k = order; k >= 2; k--)
            a[k] = 0.5 * (P[k] + (Q[k] - Q[k - 2]));
        a[1] = 0.5 * (P[1] + Q[1]);
    }
    a[0] = 1.0;
}

static uint64_t splitmix64(uint64_t x)
{
    x += 0x9E3779B97F4A7C15ull;
    x = (x ^ (x >> 30)) * 0xBF58476D1CE4E5B9ull;
    x = (x ^ (x >> 27)) * 0x94D049BB133111EBull;
    return x ^ (x >> 31);
}

double hx_normal(unsigned long long seed, unsigned long long index)
{
    /* Box-Muller on two uniforms in (0, 1] and [0, 1): the cosine branch only, one normal per index */
    uint64_t k = splitmix64(seed ^ splitmix64(2 * index));
    uint64_t m = splitmix64(seed ^ splitmix64(2 * index + 1));
    double u1 = ((double)(k >> 11) + 1.0) * (1.0 / 9007199254740992.0);
    double u2 = (double)(m >> 11) * (1.0 / 9007199254740992.0);
    return sqrt(-2.0 * log(u1)) * cos_0pi(2.0 * HX_V_PI * (u2 <= 0.5 ? u2 : 1.0 - u2)); /* cos(2 pi u) folded */
}

/* Barycentric weights of (u, w) in triangle t of the models whose (speed, force) stand every
 * row values from m (weights are invariant under the axes' scaling: no normalisation needed);
 * 1 when inside (to rounding). */
static int bary(const double *m, long row, const long *t, double u, double w, double *l)
{
    double x0 = m[t[0] * row], y0 = m[t[0] * row + 1], x1 = m[t[1] * row], y1 = m[t[1] * row + 1];
    double x2 = m[t[2] * row], y2 = m[t[2] * row + 1];
    double d = (y1 - y2) * (x0 - x2) + (x2 - x1) * (y0 - y2);
    const double tol = -1e-12;
    if (d == 0.0)
        return 0;
    l[0] = ((y1 - y2) * (u - x2) + (x2 - x1) * (w - y2)) / d;
    l[1] = ((y2 - y0) * (u - x2) + (x0 - x2) * (w - y2)) / d;
    l[2] = 1.0 - l[0] - l[1];
    return l[0] >= tol && l[1] >= tol && l[2] >= tol;
}

/* The closest point of segment (a, b) to (u, w): its parameter s in [0, 1] and squared distance. */
static double seg_closest(double ax, double ay, double bx, double by, double u, double w, double *s)
{
    double dx = bx - ax, dy = by - ay, L = dx * dx + dy * dy, t = 0.0, ex, ey;
    if (L > 0.0)
        t = ((u - ax) * dx + (w - ay) * dy) / L;
    t = t < 0.0 ? 0.0 : (t > 1.0 ? 1.0 : t);
    ex = ax + t * dx - u;
    ey = ay + t * dy - w;
    *s = t;
    return ex * ex + ey * ey;
}

/* The weights of the set's models at (speed, force); returns how many models carry weight
 * (1 to 3: idx, lam), and sets *clamped when the point was moved to the hull. */
static int weights(const double *v, hx_vib_state *st, double speed, double force, long idx[3], double lam[3],
                   int *clamped)
{
    long n = (long)v[HX_V_N], ntri = (long)v[HX_V_NTRI], p = (long)v[HX_V_P], q = (long)v[HX_V_Q];
    long row = HX_V_ROW + p + q, k, j, best = -1;
    const double *tri = v + HX_V_HEAD + n * row;
    double xs[HX_VIB_MAX_MODELS], ys[HX_VIB_MAX_MODELS]; /* normalised operating points */
    double u = speed / v[HX_V_SSCALE], w = force / v[HX_V_FSCALE], l[3], bestd = INFINITY;
    long t[3];
    *clamped = 0;
    if (n == 1) {
        idx[0] = 0;
        lam[0] = 1.0;
        return 1;
    }
    if (ntri > 0) {
        for (j = 0; j < ntri; j++) { /* the last triangle first, then the others in order */
            long tj = (j == 0) ? st->tri : (j <= st->tri ? j - 1 : j);
            st->work++;
            for (k = 0; k < 3; k++)
                t[k] = (long)tri[3 * tj + k];
            if (bary(v + HX_V_HEAD, row, t, speed, force, l)) {
                st->tri = tj;
                for (k = 0; k < 3; k++) {
                    idx[k] = t[k];
                    lam[k] = l[k] < 0.0 ? 0.0 : l[k];
                }
                return 3;
            }
        }
    }
    for (k = 0; k < n; k++) { /* off the hull, or a line: distances in the normalised plane */
        xs[k] = v[HX_V_HEAD + k * row] / v[HX_V_SSCALE];
        ys[k] = v[HX_V_HEAD + k * row + 1] / v[HX_V_FSCALE];
    }
    if (ntri == 0) { /* models on one line, in order along it: the closest point of the polyline */
        for (k = 0; k + 1 < n; k++) {
            double s, d2 = seg_closest(xs[k], ys[k], xs[k + 1], ys[k + 1], u, w, &s);
            st->work++;
            if (d2 < bestd) {
                bestd = d2;
                idx[0] = k;
                idx[1] = k + 1;
                lam[0] = 1.0 - s;
                lam[1] = s;
            }
        }
        *clamped = bestd > 1e-24; /* off the line: moved to it */
        return 2;
    }
    /* outside the hull: the closest point on any triangle's edges */
    for (j = 0; j < ntri; j++) {
        for (k = 0; k < 3; k++) {
            long a = (long)tri[3 * j + k], b = (long)tri[3 * j + (k + 1) % 3];
            double s, d2 = seg_closest(xs[a], ys[a], xs[b], ys[b], u, w, &s);
            st->work++;
            if (d2 < bestd) {
                bestd = d2;
                best = 3 * j + k;
                idx[0] = a;
                idx[1] = b;
                lam[0] = 1.0 - s;
                lam[1] = s;
            }
        }
    }
    st->tri = best / 3;
    *clamped = 1;
    return 2;
}

double hx_vib_step(const double *v, hx_vib_state *st, double speed, double force)
{
    long n = (long)v[HX_V_N], p = (long)v[HX_V_P], q = (long)v[HX_V_Q], row = HX_V_ROW + p + q, idx[3];
    double lam[3], lsf[2 * HX_VIB_MAX_ORDER], a[HX_VIB_MAX_ORDER + 3], b[HX_VIB_MAX_ORDER + 3];
    double var = 0.0, gain = 0.0, e, y;
    int m, k, i, clamped;
    (void)n;
    st->work = 0;
    if (!isfinite(speed) || !isfinite(force)) {
        st->faults++;
        return 0.0;
    }
    m = weights(v, st, speed, force, idx, lam, &clamped);
    st->clamped += clamped;
    for (k = 0; k < p + q; k++)
        lsf[k] = 0.0;
    for (i = 0; i < m; i++) {
        const double *r = v + HX_V_HEAD + idx[i] * row;
        var += lam[i] * r[2];
        gain += lam[i] * r[3];
        for (k = 0; k < p + q; k++)
            lsf[k] += lam[i] * r[HX_V_ROW + k];
    }
    hx_lsf_to_poly(lsf, (int)p, a);
    hx_lsf_to_poly(lsf + p, (int)q, b);
    e = sqrt(var) * hx_normal(st->seed, st->count++);
    y = e;
    for (k = 1; k <= q; k++)
        y += b[k] * st->e[k - 1];
    y *= gain;
    for (k = 1; k <= p; k++)
        y -= a[k] * st->y[k - 1];
    if (!isfinite(y)) { /* cannot happen with checked LSF (a stable, bounded filter); never passed on */
        st->faults++;
        y = 0.0;
    }
    for (k = (int)(p > q ? p : q) - 1; k >= 1; k--) { /* only the taps the set reads */
        st->y[k] = st->y[k - 1];
        st->e[k] = st->e[k - 1];
    }
    st->y[0] = y;
    st->e[0] = e;
    return y;
}

void hx_vib_reset(hx_vib_state *st, unsigned long long seed)
{
    int k;
    for (k = 0; k < HX_VIB_MAX_ORDER; k++)
        st->y[k] = st->e[k] = 0.0;
    st->seed = seed;
    st->count = 0;
    st->tri = 0;
    st->clamped = 0;
    st->faults = 0;
    st->work = 0;
}

/* ---- the channel: the set's step at the tick's operating point, as a force ------------ */

void hx_vib_channel_clear(hx_vib_channel *c)
{
    int i;
    hx_vib_reset(&c->vs, c->vs.seed);
    c->have = 0;
    for (i = 0; i < 3; i++)
        c->last[i] = c->v[i] = c->prev[i] = c->fprev[i] = 0.0;
    c->force = 0.0;
    c->tank = c->reserve;
    c->supplied = 0.0;
    c->dissipated = 0.0;
    c->cut = 0;
}

void hx_vib_channel_set_friction(hx_vib_channel *c, double mu, double v_threshold)
{
    c->mu = mu > 0.0 && v_threshold > 0.0 ? mu : 0.0;
    c->v_friction = v_threshold > 0.0 ? v_threshold : 0.0;
}

void hx_vib_channel_set(hx_vib_channel *c, const double *v, double mass, double gain, double tau,
                        unsigned long long seed, double budget, double reserve)
{
    c->set = v;
    c->mass = mass;
    c->gain = gain;
    c->tau = tau;
    c->period = v != 0 ? 1.0 / v[HX_V_FS] : 0.0;
    c->alpha = tau > 0.0 ? 1.0 - exp(-c->period / tau) : 1.0; /* set once, not every tick */
    c->budgeted = budget >= 0.0;
    c->budget = budget >= 0.0 ? budget : 0.0;
    c->reserve = reserve;
    c->vs.seed = seed;
    c->mu = 0.0;
    c->v_friction = 0.0;
    hx_vib_channel_clear(c);
}

long hx_vib_channel_tick(hx_vib_channel *c, const double p[3], double f[3])
{
    double T = c->period, a = c->alpha, speed, y;
    int i;
    c->force = 0.0;
    if (c->have) {
        /* the last tick's vibration force held over the displacement since: its work on the handle */
        double w = 0.0, wf = 0.0;
        for (i = 0; i < 3; i++) {
            w += c->prev[i] * (p[i] - c->last[i]);
            wf += c->fprev[i] * (p[i] - c->last[i]);
            c->v[i] += a * ((p[i] - c->last[i]) / T - c->v[i]);
        }
        if (isfinite(wf))
            c->dissipated -= wf;
        if (isfinite(w)) {
            c->supplied += w;
            if (c->budgeted) {
                c->tank += c->budget * T - w;
                if (c->tank > c->reserve)
                    c->tank = c->reserve;
            }
        }
    }
    for (i = 0; i < 3; i++) {
        c->last[i] = p[i];
        c->prev[i] = c->fprev[i] = 0.0;
    }
    speed = hypot(c->v[0], c->v[1]);
    if (!c->have || !(f[2] > 0.0) || !(speed > 0.0) || !isfinite(speed)) {
        c->have = 1;
        return 0;
    }
    if (c->mu > 0.0) { /* Coulomb above v_friction, viscous below it: continuous at v_friction */
        double ff = c->mu * f[2] * (speed < c->v_friction ? speed / c->v_friction : 1.0);
        c->fprev[0] = -ff * c->v[0] / speed;
        c->fprev[1] = -ff * c->v[1] / speed;
        f[0] += c->fprev[0];
        f[1] += c->fprev[1];
    }
    y = hx_vib_step(c->set, &c->vs, speed, f[2]);
    c->force = c->gain * c->mass * y;
    if (c->budgeted) {
        double spend = c->force * speed * T; /* its work over the next period, along the motion */
        if (spend > c->tank) {
            c->force = c->tank > 0.0 ? c->force * (c->tank / spend) : 0.0;
            c->cut++;
        }
    }
    c->prev[0] = c->force * c->v[0] / speed;
    c->prev[1] = c->force * c->v[1] / speed;
    f[0] += c->prev[0];
    f[1] += c->prev[1];
    return c->vs.work;
}
