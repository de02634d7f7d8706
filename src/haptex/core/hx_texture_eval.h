/*
 * Texture evaluation, as HX_INLINE functions: compiled into every file of the core that
 * evaluates a texture (hx_texture.c's public functions, and the loops of hx_sim.c, where the
 * compiler inlines them into the loop). Written once, here. Layouts: see hx_texture.c.
 */
#ifndef HX_TEXTURE_EVAL_H
#define HX_TEXTURE_EVAL_H

#include "hx_core.h"

#include <math.h>
#include <stddef.h>

#define AT(t, r, k) ((t)->c[(long)(r) * (t)->cols + (k)])

/* The cell of a coordinate u measured in cells, 0 <= u <= n after a periodic reduction or a
 * clamp: an index in [0, n - 1] whatever round-off did to u (never an out-of-range cast). */
HX_INLINE long cell_of(double u, long n)
{
    if (!(u > 0.0))
        return 0;
    if (u >= (double)n)
        return n - 1;
    return (long)u;
}

/* ---- profiles ---------------------------------------------------------------------- */

HX_INLINE void fourier_eval(const hx_texture *t, double x, hx_height *o)
{
    long i, n = t->cols;
    for (i = 0; i < n; i++) {
        double a = AT(t, 0, i), k = AT(t, 1, i), arg = k * x + AT(t, 2, i);
        double sn = sin(arg), cs = cos(arg);
        o->h += a * sn;
        o->gx += a * k * cs;
        o->hxx -= a * k * k * sn;
    }
}

HX_INLINE void spline_eval(const hx_texture *t, double x, hx_height *o)
{
    long m = t->cols - 2, i;
    double x0 = AT(t, 0, m), dx = AT(t, 1, m), length = (double)m * dx, u = x - x0, s;
    double a3, a2, a1, a0;
    if (AT(t, 2, m) != 0.0) {
        u -= length * floor(u / length);
    } else if (u < 0.0) {
        o->h = AT(t, 0, m + 1) + AT(t, 1, m + 1) * u;
        o->gx = AT(t, 1, m + 1);
        return;
    } else if (u > length) {
        o->h = AT(t, 2, m + 1) + AT(t, 3, m + 1) * (u - length);
        o->gx = AT(t, 3, m + 1);
        return;
    }
    i = cell_of(u / dx, m);
    s = u - (double)i * dx;
    a3 = AT(t, 0, i);
    a2 = AT(t, 1, i);
    a1 = AT(t, 2, i);
    a0 = AT(t, 3, i);
    o->h = ((a3 * s + a2) * s + a1) * s + a0;
    o->gx = (3.0 * a3 * s + 2.0 * a2) * s + a1;
    o->hxx = 6.0 * a3 * s + 2.0 * a2;
}

/* ---- surfaces ---------------------------------------------------------------------- */

/* grating i's part of h and its derivatives, from the sine and cosine of its phase at the point */
HX_INLINE void hx__grating_add(const hx_texture *t, long i, double sn, double cs, hx_height *o)
{
    double a = AT(t, 0, i), kx = AT(t, 1, i), ky = AT(t, 2, i);
    o->h += a * sn;
    o->gx += a * kx * cs;
    o->gy += a * ky * cs;
    o->hxx -= a * kx * kx * sn;
    o->hxy -= a * kx * ky * sn;
    o->hyy -= a * ky * ky * sn;
}

HX_INLINE void gratings_eval(const hx_texture *t, double x, double y, hx_height *o)
{
    long i, n = t->cols;
    for (i = 0; i < n; i++) {
        double arg = AT(t, 1, i) * x + AT(t, 2, i) * y + AT(t, 3, i);
        hx__grating_add(t, i, sin(arg), cos(arg), o);
    }
}

/* The derivatives D[p][q] = d^(p+q) h / dx^p dy^q of the bicubic patch holding (x, y) clamped to
 * the map, for p + q <= order where (x, y) is inside it (order 0: h; 2: h and its first and
 * second derivatives), all 16 (p, q <= 3) where it is clamped (the tangent-plane extension reads
 * them); (*cx, *cy) receives the clamped point. The others are left unset. */
HX_INLINE void patch_derivs(const hx_texture *t, double x, double y, double D[4][4], double *cx, double *cy,
                            int order)
{
    const double *hd = t->c;
    double dx = hd[HX_PATCH_DX], dy = hd[HX_PATCH_DY];
    long nx = (long)hd[HX_PATCH_NX], ny = (long)hd[HX_PATCH_NY], i, j;
    double u = (x - hd[HX_PATCH_X0]) / dx, v = (y - hd[HX_PATCH_Y0]) / dy, s, tt;
    double S[4][4] = {{0}}, T[4][4] = {{0}}, sx = 1.0, sy;
    const double *c;
    int a, b, p, q;
    *cx = x;
    *cy = y;
    if (hd[HX_PATCH_PERIODIC] != 0.0) {
        u -= (double)nx * floor(u / (double)nx);
        v -= (double)ny * floor(v / (double)ny);
    } else {
        if (!(u >= 0.0 && u <= (double)nx)) {
            u = u < 0.0 ? 0.0 : (double)nx;
            *cx = hd[HX_PATCH_X0] + u * dx;
            order = 6;
        }
        if (!(v >= 0.0 && v <= (double)ny)) {
            v = v < 0.0 ? 0.0 : (double)ny;
            *cy = hd[HX_PATCH_Y0] + v * dy;
            order = 6;
        }
    }
    i = cell_of(u, nx);
    j = cell_of(v, ny);
    s = u - (double)i;
    tt = v - (double)j;
    /* S[p][a] = d^p/ds^p s^a, T[q][b] = d^q/dt^q t^b */
    S[0][0] = T[0][0] = 1.0;
    S[0][1] = s;
    S[0][2] = s * s;
    S[0][3] = s * s * s;
    S[1][1] = 1.0;
    S[1][2] = 2.0 * s;
    S[1][3] = 3.0 * s * s;
    S[2][2] = 2.0;
    S[2][3] = 6.0 * s;
    S[3][3] = 6.0;
    T[0][1] = tt;
    T[0][2] = tt * tt;
    T[0][3] = tt * tt * tt;
    T[1][1] = 1.0;
    T[1][2] = 2.0 * tt;
    T[1][3] = 3.0 * tt * tt;
    T[2][2] = 2.0;
    T[2][3] = 6.0 * tt;
    T[3][3] = 6.0;
    c = hd + HX_PATCH_DATA + 16 * (i * ny + j);
    for (p = 0; p < 4 && p <= order; p++) {
        double row[4];
        for (b = 0; b < 4; b++) {
            double acc = 0.0;
            for (a = p; a < 4; a++)
                acc += c[4 * a + b] * S[p][a];
            row[b] = acc;
        }
        sy = 1.0;
        for (q = 0; q < 4 && p + q <= order; q++) {
            double acc = 0.0;
            for (b = q; b < 4; b++)
                acc += row[b] * T[q][b];
            D[p][q] = acc / (sx * sy);
            sy *= dy;
        }
        sx *= dx;
    }
}

HX_INLINE void patches_eval(const hx_texture *t, double x, double y, hx_height *o)
{
    double D[4][4], cx, cy, ex, ey;
    int ox, oy;
    patch_derivs(t, x, y, D, &cx, &cy, 2);
    ex = x - cx;
    ey = y - cy;
    ox = ex != 0.0;
    oy = ey != 0.0;
    if (!ox && !oy) {
        o->h = D[0][0];
        o->gx = D[1][0];
        o->gy = D[0][1];
        o->hxx = D[2][0];
        o->hxy = D[1][1];
        o->hyy = D[0][2];
        return;
    }
    /* the tangent-plane extension: c moves with p along an axis that is not clamped */
    o->h = D[0][0] + D[1][0] * ex + D[0][1] * ey;
    o->gx = ox ? D[1][0] : D[1][0] + D[2][0] * ex + D[1][1] * ey;
    o->gy = oy ? D[0][1] : D[0][1] + D[1][1] * ex + D[0][2] * ey;
    o->hxx = ox ? 0.0 : D[2][0] + D[3][0] * ex + D[2][1] * ey;
    o->hyy = oy ? 0.0 : D[0][2] + D[1][2] * ex + D[0][3] * ey;
    o->hxy = (ox && oy) ? 0.0 : D[1][1] + (ox ? 0.0 : D[2][1] * ex) + (oy ? 0.0 : D[1][2] * ey);
}

HX_INLINE void hx__texture_eval(const hx_texture *t, double x, double y, hx_height *out)
{
    out->h = out->gx = out->gy = out->hxx = out->hxy = out->hyy = 0.0;
    switch (t->kind) {
    case HX_TEXTURE_FOURIER:
        fourier_eval(t, x, out);
        break;
    case HX_TEXTURE_SPLINE:
        spline_eval(t, x, out);
        break;
    case HX_SURFACE_GRATINGS:
        gratings_eval(t, x, y, out);
        break;
    case HX_SURFACE_PATCHES:
        patches_eval(t, x, y, out);
        break;
    default:
        break;
    }
}

HX_INLINE double hx__texture_height(const hx_texture *t, double x, double y)
{
    long i;
    double h = 0.0;
    hx_height o;
    switch (t->kind) {
    case HX_TEXTURE_FOURIER:
        for (i = 0; i < t->cols; i++)
            h += AT(t, 0, i) * sin(AT(t, 1, i) * x + AT(t, 2, i));
        return h;
    case HX_SURFACE_GRATINGS:
        for (i = 0; i < t->cols; i++)
            h += AT(t, 0, i) * sin(AT(t, 1, i) * x + AT(t, 2, i) * y + AT(t, 3, i));
        return h;
    case HX_TEXTURE_FLAT:
        return 0.0;
    case HX_SURFACE_PATCHES: { /* h alone inside the map; beyond it, the tangent plane's */
        double D[4][4], cx, cy;
        patch_derivs(t, x, y, D, &cx, &cy, 0);
        if (cx == x && cy == y)
            return D[0][0];
        return D[0][0] + D[1][0] * (x - cx) + D[0][1] * (y - cy);
    }
    default:
        hx__texture_eval(t, x, y, &o);
        return o.h;
    }
}

#endif
