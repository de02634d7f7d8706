/*
 * The force fields and the servo tick's force, as HX_INLINE functions: compiled into
 * hx_forces.c (the public hx_field and hx_tick_force) and into hx_sim.c's loops, where a
 * loop instantiated for one letter inlines its field. Written once, here.
 */
#ifndef HX_FIELDS_H
#define HX_FIELDS_H

#include "hx_core.h"
#include "hx_texture_eval.h"

#include <math.h>
#include <stddef.h>

typedef struct {
    double pen, h;
} field_out;
typedef void (*field_fn)(const hx_model *m, const double p[3], double f[3], double jac[9], field_out *o);

HX_INLINE void zero(double f[3], double jac[9])
{
    int i;
    f[0] = f[1] = f[2] = 0.0;
    if (jac)
        for (i = 0; i < 9; i++)
            jac[i] = 0.0;
}

/* d_l of Remark 3 and whether it follows d */
HX_INLINE double lateral(const hx_model *m, double d, int *follows)
{
    double dm = m->prm[HX_P_DZMAX];
    if (dm >= 0.0 && !(d > -dm)) {
        *follows = 0;
        return -dm;
    }
    *follows = 1;
    return d;
}

/* W, eq. 30: f = (0, 0, -kappa_0 p^z) inside; J = diag(0, 0, -kappa_0). (The virtual damper
 * of Colgate & Schenkel acts in the servo loop, not in the static field.) */
HX_INLINE void field_w(const hx_model *m, const double p[3], double f[3], double jac[9], field_out *o)
{
    double k = m->prm[HX_P_K0];
    o->pen = p[2] < 0.0 ? -p[2] : 0.0;
    if (p[2] >= 0.0)
        return;
    f[2] = -k * p[2];
    if (jac)
        jac[8] = -k;
}

/* A, eq. 6-7: f = (0, 0, -kappa_0 d); the last row of J is kappa_0 (s_x, s_y, -1). */
HX_INLINE void field_a(const hx_model *m, const double p[3], double f[3], double jac[9], field_out *o)
{
    double k = m->prm[HX_P_K0], d;
    hx_height t;
    if (jac) {
        hx__texture_eval(&m->tex, p[0], p[1], &t);
    } else {
        t.h = hx__texture_height(&m->tex, p[0], p[1]);
        t.gx = t.gy = 0.0;
    }
    d = p[2] - t.h;
    o->h = t.h;
    o->pen = d < 0.0 ? -d : 0.0;
    if (!(d < 0.0))
        return;
    f[2] = -k * d;
    if (jac) {
        jac[6] = k * t.gx;
        jac[7] = k * t.gy;
        jac[8] = -k;
    }
}

/* g P H, row-major 2 x 2 */
HX_INLINE void normal_derivative(const hx_height *t, double g, double out[4])
{
    double g2 = g * g, sx = t->gx, sy = t->gy;
    double p00 = g2 * (1.0 + sy * sy), p11 = g2 * (1.0 + sx * sx), p01 = -g2 * sx * sy;
    out[0] = g * (p00 * t->hxx + p01 * t->hxy);
    out[1] = g * (p00 * t->hxy + p01 * t->hyy);
    out[2] = g * (p01 * t->hxx + p11 * t->hxy);
    out[3] = g * (p01 * t->hxy + p11 * t->hyy);
}

/* The force along the textured normal n = (-s, 1) g at depth d < 0 (B: the vertical
 * penetration d = p^z - h, so that grad d = (-s, 1); G: d = p^z), f = -kappa_0 d n with the
 * lateral part at d_l (Remark 3), and its Jacobian
 *   in-plane block kappa_0 (d_l g P H - grooved lat s s^T), in-plane column kappa_0 lat s,
 *   last row kappa_0 (grooved g s + d g^3 H s, -g), lat = g where d_l follows d. */
HX_INLINE void normal_field(const hx_model *m, const hx_height *t, double d, int grooved, double f[3], double jac[9])
{
    double k = m->prm[HX_P_K0], dl, g, lat, gph[4], s[2];
    int follows, i, j;
    s[0] = t->gx;
    s[1] = t->gy;
    g = 1.0 / sqrt(1.0 + s[0] * s[0] + s[1] * s[1]);
    dl = lateral(m, d, &follows);
    f[0] = k * dl * s[0] * g; /* (the order of the numba kernels: the same rounding) */
    f[1] = k * dl * s[1] * g;
    f[2] = -k * d * g;
    if (!jac)
        return;
    lat = follows ? g : 0.0;
    normal_derivative(t, g, gph);
    for (i = 0; i < 2; i++) {
        for (j = 0; j < 2; j++)
            jac[3 * i + j] = k * ((grooved ? -lat * s[i] * s[j] : 0.0) + dl * gph[2 * i + j]);
        jac[3 * i + 2] = k * lat * s[i];
    }
    jac[6] = k * ((grooved ? g * s[0] : 0.0) + d * g * g * g * (t->hxx * s[0] + t->hxy * s[1]));
    jac[7] = k * ((grooved ? g * s[1] : 0.0) + d * g * g * g * (t->hxy * s[0] + t->hyy * s[1]));
    jac[8] = -k * g;
}

/* B, eq. 11: f = -kappa_0 d n with the lateral part at d_l;
 * J = kappa_0 [[-lat s s^T + d_l g P H, lat s], [g s^T + d g^3 (H s)^T, -g]], lat = g where
 * d_l follows d, else 0. */
HX_INLINE void field_b(const hx_model *m, const double p[3], double f[3], double jac[9], field_out *o)
{
    double d;
    hx_height t;
    hx__texture_eval(&m->tex, p[0], p[1], &t);
    d = p[2] - t.h;
    o->h = t.h;
    o->pen = d < 0.0 ? -d : 0.0;
    if (d < 0.0)
        normal_field(m, &t, d, 1, f, jac);
}

/* C, eq. 13-15: f = kappa_0 (d_l s_x, d_l s_y, -d), the gradient of -kappa_0 d^2 / 2 when
 * unclamped; J = kappa_0 [[-lat s s^T + d_l H, lat s], [s^T, -1]], lat = 1 where d_l follows d. */
HX_INLINE void field_c(const hx_model *m, const double p[3], double f[3], double jac[9], field_out *o)
{
    double k = m->prm[HX_P_K0], d, dl, lat, s[2], hs[4];
    int follows, i, j;
    hx_height t;
    hx__texture_eval(&m->tex, p[0], p[1], &t);
    d = p[2] - t.h;
    o->h = t.h;
    o->pen = d < 0.0 ? -d : 0.0;
    if (!(d < 0.0))
        return;
    s[0] = t.gx;
    s[1] = t.gy;
    dl = lateral(m, d, &follows);
    f[0] = k * dl * s[0];
    f[1] = k * dl * s[1];
    f[2] = -k * d;
    if (!jac)
        return;
    lat = follows ? 1.0 : 0.0;
    hs[0] = t.hxx;
    hs[1] = hs[2] = t.hxy;
    hs[3] = t.hyy;
    for (i = 0; i < 2; i++) {
        for (j = 0; j < 2; j++)
            jac[3 * i + j] = k * (-lat * s[i] * s[j] + dl * hs[2 * i + j]);
        jac[3 * i + 2] = k * lat * s[i];
        jac[6 + i] = k * s[i];
    }
    jac[8] = -k;
}

/* G, eq. 28: f = -kappa_0 p^z n with the lateral part at max(p^z, -d^z_max);
 * J = kappa_0 [[d_l g P H, lat s], [p^z g^3 (H s)^T, -g]], lat = g where d_l follows p^z. */
HX_INLINE void field_g(const hx_model *m, const double p[3], double f[3], double jac[9], field_out *o)
{
    hx_height t;
    o->pen = p[2] < 0.0 ? -p[2] : 0.0;
    if (!(p[2] < 0.0))
        return;
    hx__texture_eval(&m->tex, p[0], p[1], &t);
    o->h = t.h;
    normal_field(m, &t, p[2], 0, f, jac);
}

/* The letters in the order of HX_ALG_*; NULL: not a memoryless field (D, E, F, the proxy). */
static const field_fn FIELDS[HX_N_ALGS] = {field_w, field_a, field_b, field_c, NULL, NULL, NULL, field_g, NULL};

/* F, eq. 26-27 with presliding (eq. 24): the normal force -kappa_0 p^z and the friction
 * force -mu kappa_0 d_z (1 - scale h) d / d^x_max in the plane, d the presliding deflection
 * and d_z the depth, clamped at d^z_max (Remark 3). Contact starts with zero deflection;
 * leaving the wall resets it. */
HX_INLINE void tick_f(const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    double k = m->prm[HX_P_K0], d[2], h, c;
    s->pen = p[2] < 0.0 ? -p[2] : 0.0;
    if (!(p[2] < 0.0)) {
        s->contact = 0;
        return;
    }
    hx__presliding_step(m, s, p, 0.0, d);
    h = hx__texture_height(&m->tex, p[0], p[1]);
    s->h = h;
    c = hx__friction_gain(m, -p[2], h);
    f[0] = c * d[0];
    f[1] = c * d[1];
    f[2] = -k * p[2];
}

/* D and E over a profile (or a profile extruded along y): the closest point of the boundary
 * (hx_closest_profile), warm-started from the last one moved on by its last step when that
 * step was under a thousandth of the shortest period; D pulls the probe towards it, E pushes
 * along z by the distance (eq. 16-19, physical sign). */
HX_INLINE void tick_de(const int code, const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    double k = m->prm[HX_P_K0], h = hx__texture_height(&m->tex, p[0], p[1]), d = p[2] - h, guess = NAN;
    hx_closest c;
    s->h = h;
    s->pen = d < 0.0 ? -d : 0.0;
    if (!(d < 0.0))
        return;
    if (s->contact) {
        guess = s->adh[0];
        if (s->contact == 2 && fabs(guess - s->last[0]) < 1e6 * m->aux[HX_A_TIE])
            guess += guess - s->last[0];
    }
    c = hx_closest_profile(&m->tex, m->aux, p[0], p[2], -d, guess);
    s->contact = s->contact ? 2 : 1;
    s->last[0] = s->adh[0];
    s->adh[0] = c.t;
    s->work = c.work;
    s->pen = c.distance;
    if (code == HX_ALG_D) {
        f[0] = -k * (p[0] - c.t);
        f[1] = -k * (p[1] - p[1]);
        f[2] = -k * (p[2] - hx__texture_height(&m->tex, c.t, 0.0));
    } else {
        f[2] = k * c.distance;
    }
}

/* D and E over a sum of gratings or a height map: the closest point of the surface
 * (hx_closest_surface), warm-started from the last one moved on by its last step when that
 * step was under a thousandth of the shortest wavelength. */
HX_INLINE void tick_de_surface(const int code, const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    double k = m->prm[HX_P_K0], h = hx__texture_height(&m->tex, p[0], p[1]), d = p[2] - h, gx = NAN, gy = NAN;
    hx_closest c;
    s->h = h;
    s->pen = d < 0.0 ? -d : 0.0;
    if (!(d < 0.0))
        return;
    if (s->contact) {
        gx = s->adh[0];
        gy = s->adh[1];
        if (s->contact == 2) {
            double sx = gx - s->last[0], sy = gy - s->last[1];
            if (fabs(sx) + fabs(sy) < 1e6 * m->aux[HX_G_TIE]) {
                gx += sx;
                gy += sy;
            }
        }
    }
    c = hx_closest_surface(&m->tex, m->aux, p[0], p[1], p[2], gx, gy);
    s->contact = s->contact ? 2 : 1;
    s->last[0] = s->adh[0];
    s->last[1] = s->adh[1];
    s->adh[0] = c.t;
    s->adh[1] = c.y;
    s->work = c.work + 1;
    s->cut = c.cut;
    s->pen = c.distance;
    if (code == HX_ALG_D) {
        f[0] = -k * (p[0] - c.t);
        f[1] = -k * (p[1] - c.y);
        f[2] = -k * (p[2] - hx__texture_height(&m->tex, c.t, c.y));
    } else {
        f[2] = k * c.distance;
    }
}

/* phi(u) = |u - p_xy|^2 + (h(u) - p_z)^2: the squared distance from the probe to the boundary's
 * point above u (one texture evaluation, counted) */
HX_INLINE double proxy_phi(const hx_model *m, const double u[2], const double p[3], long *work)
{
    double dz = hx__texture_height(&m->tex, u[0], u[1]) - p[2];
    (*work)++;
    return (u[0] - p[0]) * (u[0] - p[0]) + (u[1] - p[1]) * (u[1] - p[1]) + dz * dz;
}

/* The god-object (haptex.proxy.GodObject, over the plane): a point kept on the boundary that
 * follows the probe with history. Inside (p_z < h at the probe's own foot) the proxy's surface
 * coordinates u slide from where they were (the last free foot, or the foot, when contact
 * starts) to the local minimum of phi reached by damped Newton steps (at most HX_P_DXMAX long,
 * each backtracked until phi decreases; a step that is not a descent direction falls back to
 * the scaled gradient); the force is the spring kappa_0 (S(u) - p), S(u) = (u, h(u)). State:
 * contact 1 in contact (u in adh), 2 free with the last foot in last, 0 no history. */
HX_INLINE void tick_proxy(const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    double k = m->prm[HX_P_K0], lmax = m->prm[HX_P_DXMAX], u[2], phi;
    hx_height t;
    int it;
    long work = 1;
    double h0 = hx__texture_height(&m->tex, p[0], p[1]);
    s->h = h0;
    s->pen = 0.0;
    if (!(p[2] < h0)) { /* outside at its own foot: free, the foot kept for the next contact */
        s->contact = 2;
        s->last[0] = p[0];
        s->last[1] = p[1];
        s->work = work;
        return;
    }
    hx__proxy_start(s, p, u);
    phi = proxy_phi(m, u, p, &work);
    for (it = 0; it < HX_PROXY_STEPS; it++) {
        double dz, g0, g1, a, b, c, det, st[2], n, v[2], pv;
        int j;
        hx__texture_eval(&m->tex, u[0], u[1], &t);
        work++;
        dz = t.h - p[2];
        g0 = (u[0] - p[0]) + dz * t.gx;
        g1 = (u[1] - p[1]) + dz * t.gy;
        a = 1.0 + t.gx * t.gx + dz * t.hxx; /* the Hessian of phi / 2 */
        b = t.gx * t.gy + dz * t.hxy;
        c = 1.0 + t.gy * t.gy + dz * t.hyy;
        det = a * c - b * b;
        st[0] = det != 0.0 ? -(c * g0 - b * g1) / det : 0.0;
        st[1] = det != 0.0 ? -(a * g1 - b * g0) / det : 0.0;
        if (!(det != 0.0) || !(g0 * st[0] + g1 * st[1] < 0.0) || !isfinite(st[0]) || !isfinite(st[1])) {
            double sc = 1.0 + t.gx * t.gx + t.gy * t.gy; /* not a descent direction: the scaled gradient */
            st[0] = -g0 / sc;
            st[1] = -g1 / sc;
        }
        n = hypot(st[0], st[1]);
        if (n > lmax) {
            st[0] *= lmax / n;
            st[1] *= lmax / n;
        }
        for (j = 0; j < HX_PROXY_HALVINGS; j++) { /* backtrack until phi decreases */
            v[0] = u[0] + st[0];
            v[1] = u[1] + st[1];
            pv = proxy_phi(m, v, p, &work);
            if (pv <= phi)
                break;
            st[0] *= 0.5;
            st[1] *= 0.5;
        }
        if (j == HX_PROXY_HALVINGS)
            break;
        u[0] = v[0];
        u[1] = v[1];
        phi = pv;
        if (hypot(st[0], st[1]) <= 1e-15 + 1e-12 * hypot(u[0], u[1]))
            break;
    }
    s->contact = 1;
    s->adh[0] = u[0];
    s->adh[1] = u[1];
    s->work = work;
    s->pen = sqrt(phi); /* (s->h stays the height under the probe, h0) */
    f[0] = k * (u[0] - p[0]);
    f[1] = k * (u[1] - p[1]);
    f[2] = k * (hx__texture_height(&m->tex, u[0], u[1]) - p[2]);
}

/* A memoryless field's tick: the field, with its penetration and height kept in the state. */
HX_INLINE void tick_field(field_fn fn, const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    field_out o = {0.0, NAN};
    fn(m, p, f, NULL, &o);
    s->pen = o.pen;
    s->h = o.h;
}

/* W with Colgate & Schenkel's virtual damper B (HX_P_MU) over the servo period T (HX_P_DXMAX):
 * the backward difference of the sensed p^z, from the second sample on. */
HX_INLINE void tick_w(const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    double b = m->prm[HX_P_MU];
    tick_field(field_w, m, s, p, f);
    if (p[2] < 0.0 && b != 0.0 && s->contact)
        f[2] -= b * (p[2] - s->last_z) / m->prm[HX_P_DXMAX];
    s->last_z = p[2];
    s->contact = 1;
}

/* D and E: over a profile (the cell table or tree, hx_closest_profile) or over a surface (the
 * certified quadtree, hx_closest_surface), by the texture's kind */
HX_INLINE void tick_de_any(const int code, const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    if (m->tex.kind == HX_SURFACE_GRATINGS || m->tex.kind == HX_SURFACE_PATCHES)
        tick_de_surface(code, m, s, p, f);
    else
        tick_de(code, m, s, p, f);
}

/* A, B and C's ticks (their fields), D's and E's (the closest point): one line each */
#define HX_TICK_BY(name, call)                                                                               \
    HX_INLINE void name(const hx_model *m, hx_state *s, const double p[3], double f[3])                        \
    {                                                                                                        \
        call;                                                                                                \
    }
HX_TICK_BY(tick_a, tick_field(field_a, m, s, p, f))
HX_TICK_BY(tick_b, tick_field(field_b, m, s, p, f))
HX_TICK_BY(tick_c, tick_field(field_c, m, s, p, f))
HX_TICK_BY(tick_d, tick_de_any(HX_ALG_D, m, s, p, f))
HX_TICK_BY(tick_e, tick_de_any(HX_ALG_E, m, s, p, f))

/* G: force shading's field; leaving the wall ends the contact */
HX_INLINE void tick_g(const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    tick_field(field_g, m, s, p, f);
    if (!(p[2] < 0.0))
        s->contact = 0;
}

typedef void (*tick_fn)(const hx_model *m, hx_state *s, const double p[3], double f[3]);
/* An export for one algorithm (haptex export compiles with -DHX_ONLY_ALG=<its HX_ALG_* value>)
 * keeps only that letter's tick in the table below; the others are NULL, never compiled, and the
 * closest-point searches, presliding tables and proxy they alone reach are dropped by the
 * linker's garbage collection of sections. Without it, every letter's. */
#if defined(HX_ONLY_ALG) && HX_ONLY_ALG != 0
#define HX_TICK_0 NULL
#else
#define HX_TICK_0 tick_w
#endif
#if defined(HX_ONLY_ALG) && HX_ONLY_ALG != 1
#define HX_TICK_1 NULL
#else
#define HX_TICK_1 tick_a
#endif
#if defined(HX_ONLY_ALG) && HX_ONLY_ALG != 2
#define HX_TICK_2 NULL
#else
#define HX_TICK_2 tick_b
#endif
#if defined(HX_ONLY_ALG) && HX_ONLY_ALG != 3
#define HX_TICK_3 NULL
#else
#define HX_TICK_3 tick_c
#endif
#if defined(HX_ONLY_ALG) && HX_ONLY_ALG != 4
#define HX_TICK_4 NULL
#else
#define HX_TICK_4 tick_d
#endif
#if defined(HX_ONLY_ALG) && HX_ONLY_ALG != 5
#define HX_TICK_5 NULL
#else
#define HX_TICK_5 tick_e
#endif
#if defined(HX_ONLY_ALG) && HX_ONLY_ALG != 6
#define HX_TICK_6 NULL
#else
#define HX_TICK_6 tick_f
#endif
#if defined(HX_ONLY_ALG) && HX_ONLY_ALG != 7
#define HX_TICK_7 NULL
#else
#define HX_TICK_7 tick_g
#endif
#if defined(HX_ONLY_ALG) && HX_ONLY_ALG != 8
#define HX_TICK_8 NULL
#else
#define HX_TICK_8 tick_proxy
#endif
/* A servo tick's force, one function a letter in the order of HX_ALG_* (and the proxy), all of
 * one signature: the one table the tick dispatches through (a loop instantiated for one letter
 * indexes it with a constant, and the compiler inlines that letter's tick). */
static const tick_fn TICKS[HX_N_ALGS] = {HX_TICK_0, HX_TICK_1, HX_TICK_2, HX_TICK_3, HX_TICK_4, HX_TICK_5,
                                         HX_TICK_6, HX_TICK_7, HX_TICK_8};

/* The tick's force for algorithm `code` (a constant where a caller instantiates a loop per
 * letter, code otherwise). */
HX_INLINE int hx__tick_force_of(const int code, const hx_model *m, hx_state *s, const double p[3],
                                    double f[3])
{
    zero(f, NULL);
    s->work = 1;
    s->cut = 0;
    s->h = NAN;
    if (code < 0 || code >= HX_N_ALGS)
        return HX_NOT_IN_CORE;
#ifdef HX_ONLY_ALG
    if (TICKS[code] == NULL) /* another letter than the export's */
        return HX_NOT_IN_CORE;
#endif
    TICKS[code](m, s, p, f);
    return HX_OK;
}

HX_INLINE int hx__tick_force(const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    return hx__tick_force_of(m->code, m, s, p, f);
}

#endif
