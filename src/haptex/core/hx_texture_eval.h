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

/* a bicubic patch's value sum c[a][b] s^a t^b from the powers ps[a] = s^a, pt[b] = t^b */
HX_INLINE double patch_value(const double *c, const double ps[4], const double pt[4])
{
    double v = 0.0;
    int a, b;
    for (a = 0; a < 4; a++) {
        double row = 0.0;
        for (b = 0; b < 4; b++)
            row += c[4 * a + b] * pt[b];
        v += row * ps[a];
    }
    return v;
}

/* The derivatives D[p][q] = d^(p+q) h / dx^p dy^q, p + q <= order, of the bicubic patch c at
 * its local coordinates (s, tt) (cells dx by dy) */
HX_INLINE void patch_poly(const double *c, double s, double tt, double dx, double dy, int order, double D[4][4])
{
    double S[4][4] = {{0}}, T[4][4] = {{0}}, sx = 1.0, sy;
    int a, b, p, q;
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

/* h, its gradient and Hessian from a patch's derivatives D (patch_poly's, order 2) */
HX_INLINE void patch_height(double D[4][4], hx_height *o)
{
    o->h = D[0][0];
    o->gx = D[1][0];
    o->gy = D[0][1];
    o->hxx = D[2][0];
    o->hxy = D[1][1];
    o->hyy = D[0][2];
}

/* A branched cell's patches (HX_JOINS_BRANCHED): its own and its extra ones into pp (at most
 * HX_MAX_BRANCHES), their number; 1 (its own) in any other map's cell k = i ny + j */
HX_INLINE int cell_branches(const double *hd, long nx, long ny, long i, long j, const double **pp)
{
    long k = i * ny + j, e, e0, e1;
    int n = 1;
    pp[0] = hd + HX_PATCH_DATA + 16 * k;
    if (hd[HX_PATCH_JOINS] != (double)HX_JOINS_BRANCHED)
        return 1;
    e0 = (long)hd[HX_PATCH_DATA + 16 * nx * ny + k];
    e1 = (long)hd[HX_PATCH_DATA + 16 * nx * ny + k + 1];
    for (e = e0; e < e1 && n < HX_MAX_BRANCHES; e++)
        pp[n++] = hd + HX_PATCH_DATA + 16 * nx * ny + nx * ny + 1 + 16 * e;
    return n;
}

/* A patch map's axis a (0: x, 1: y): its n + 1 knots where graded (HX_PATCH_AXES), else NULL */
HX_INLINE const double *patch_knots(const double *hd, int a)
{
    long off = (long)hd[HX_PATCH_AXES];
    return off > 0 ? hd + off + (a == 0 ? 0 : (long)hd[HX_PATCH_NX] + 1) : NULL;
}

/* The width of cell k along axis a (k a whole number of cells, as patch_cells counts them:
 * wrapped if the map is periodic, else clamped to it) */
HX_INLINE double patch_width(const double *hd, int a, double k)
{
    const double *kn = patch_knots(hd, a);
    long n = (long)hd[HX_PATCH_NX + a], i;
    if (kn == NULL)
        return hd[HX_PATCH_DX + a];
    if (hd[HX_PATCH_PERIODIC] != 0.0)
        k -= (double)n * floor(k / (double)n);
    i = cell_of(k, n); /* (never an out-of-range cast, NaN included) */
    return kn[i + 1] - kn[i];
}

/* A graded axis a's bucket index (after the knots, hx_core.h): its B cells into *nb */
HX_INLINE const double *patch_index(const double *hd, int a, long *nb)
{
    const double *p = hd + (long)hd[HX_PATCH_AXES] + (long)hd[HX_PATCH_NX] + (long)hd[HX_PATCH_NY] + 2;
    if (a == 1)
        p += 1 + (long)p[0];
    *nb = (long)p[0];
    return p + 1;
}

/* A position x along axis a in cells: f with floor(f) its cell, counted on through a periodic
 * map's periods (n cells each) and beyond a map's edges (at the edge cells' widths), and
 * f - floor(f) its local coordinate in that cell; (x - origin) / step on a uniform axis. A
 * graded axis's cell is found by bisection of its knots within the bracket its bucket index
 * gives (one step where each bucket is no wider than the narrowest cell), else of them all: at
 * most log2(n) + 1 steps. */
HX_INLINE double patch_cells(const double *hd, int a, double x)
{
    const double *kn = patch_knots(hd, a);
    long n = (long)hd[HX_PATCH_NX + a], lo = 0, hi, per = 0;
    double r, len;
    if (kn == NULL)
        return (x - hd[HX_PATCH_X0 + a]) / hd[HX_PATCH_DX + a];
    r = x - kn[0];
    len = kn[n] - kn[0];
    if (!isfinite(r))
        return r;
    if (hd[HX_PATCH_PERIODIC] != 0.0) {
        double p = floor(r / len);
        if (!(fabs(p) < 1e15))
            return r / len * (double)n;
        r -= p * len;
        per = (long)p;
        if (r >= len) { /* (round-off) */
            r -= len;
            per++;
        }
        if (r < 0.0)
            r = 0.0;
    } else if (r < 0.0) {
        return r / (kn[1] - kn[0]);
    } else if (r >= len) {
        return (double)n + (r - len) / (kn[n] - kn[n - 1]);
    }
    { /* the bracket [ix[b], ix[b + 1] + 1] of r's bucket b, if it holds r; else the whole axis */
        long nb;
        const double *ix = patch_index(hd, a, &nb);
        double u = r / len * (double)nb;
        long b = u < (double)nb ? (long)u : nb - 1, l0 = (long)ix[b], h0 = b + 1 < nb ? (long)ix[b + 1] + 1 : n;
        if (kn[l0] - kn[0] <= r && r < kn[h0] - kn[0]) {
            lo = l0;
            hi = h0;
        } else {
            hi = n;
        }
    }
    while (hi - lo > 1) { /* kn[lo] - kn[0] <= r < kn[hi] - kn[0] */
        long mid = (lo + hi) / 2;
        if (kn[mid] - kn[0] <= r)
            lo = mid;
        else
            hi = mid;
    }
    return (double)per * (double)n + (double)lo + (r - (kn[lo] - kn[0])) / (kn[lo + 1] - kn[lo]);
}

/* The position of f cells along axis a (patch_cells' inverse) */
HX_INLINE double patch_at(const double *hd, int a, double f)
{
    const double *kn = patch_knots(hd, a);
    long n = (long)hd[HX_PATCH_NX + a], k;
    double p = 0.0;
    if (kn == NULL)
        return hd[HX_PATCH_X0 + a] + f * hd[HX_PATCH_DX + a];
    if (!isfinite(f))
        return f;
    if (hd[HX_PATCH_PERIODIC] != 0.0) {
        p = floor(f / (double)n);
        f -= p * (double)n;
    } else if (f < 0.0) {
        return kn[0] + f * (kn[1] - kn[0]);
    } else if (f > (double)n) {
        return kn[n] + (f - (double)n) * (kn[n] - kn[n - 1]);
    }
    k = cell_of(f, n);
    return kn[k] + p * (kn[n] - kn[0]) + (f - (double)k) * (kn[k + 1] - kn[k]);
}

/* The cell holding the map's point (x, y) (wrapped if periodic, else clamped to the map: then
 * *cx, *cy the clamped point), the local coordinates in it and its widths (*wx, *wy) */
HX_INLINE void patch_locate(const double *hd, double x, double y, long *i, long *j, double *s, double *tt, double *cx,
                            double *cy, int *clamped, double *wx, double *wy)
{
    long nx = (long)hd[HX_PATCH_NX], ny = (long)hd[HX_PATCH_NY];
    double u = patch_cells(hd, 0, x), v = patch_cells(hd, 1, y);
    *cx = x;
    *cy = y;
    *clamped = 0;
    if (hd[HX_PATCH_PERIODIC] != 0.0) {
        u -= (double)nx * floor(u / (double)nx);
        v -= (double)ny * floor(v / (double)ny);
    } else {
        if (!(u >= 0.0 && u <= (double)nx)) {
            u = u < 0.0 ? 0.0 : (double)nx;
            *cx = patch_at(hd, 0, u);
            *clamped = 1;
        }
        if (!(v >= 0.0 && v <= (double)ny)) {
            v = v < 0.0 ? 0.0 : (double)ny;
            *cy = patch_at(hd, 1, v);
            *clamped = 1;
        }
    }
    *i = cell_of(u, nx);
    *j = cell_of(v, ny);
    *s = u - (double)*i;
    *tt = v - (double)*j;
    *wx = patch_width(hd, 0, (double)*i);
    *wy = patch_width(hd, 1, (double)*j);
}

/* The derivatives D[p][q] = d^(p+q) h / dx^p dy^q of the bicubic patch holding (x, y) clamped to
 * the map, for p + q <= order where (x, y) is inside it (order 0: h; 2: h and its first and
 * second derivatives), all 16 (p, q <= 3) where it is clamped (the tangent-plane extension reads
 * them); (*cx, *cy) receives the clamped point. The others are left unset. In a branched cell
 * (HX_JOINS_BRANCHED) the patch is the highest of the cell's there; of patches that tie there
 * to round-off (HX_BRANCH_TIE of the height and the cell's widths: on the cell's edge, where a
 * branch a neighbour passed it meets its own, and at a node on a crease), the highest at the
 * point HX_BRANCH_NUDGE of the way to the cell's centre, so that the derivatives on the cell's
 * edges and corners are the limits from inside it (the first on a tie there too). */
HX_INLINE_LARGE void patch_derivs(const hx_texture *t, double x, double y, double D[4][4], double *cx, double *cy,
                            int order)
{
    const double *hd = t->c, *pp[HX_MAX_BRANCHES], *c;
    long nx = (long)hd[HX_PATCH_NX], ny = (long)hd[HX_PATCH_NY], i, j;
    double s, tt, wx, wy;
    int clamped, n, k;
    patch_locate(hd, x, y, &i, &j, &s, &tt, cx, cy, &clamped, &wx, &wy);
    if (clamped)
        order = 6;
    n = cell_branches(hd, nx, ny, i, j, pp);
    c = pp[0];
    if (n > 1) { /* a branched cell: the highest of its patches */
        double ps[4] = {1.0, s, s * s, s * s * s}, pt[4] = {1.0, tt, tt * tt, tt * tt * tt};
        double v[HX_MAX_BRANCHES], top = 0.0, tol, in, best = 0.0;
        int tied = 0;
        for (k = 0; k < n; k++) {
            v[k] = patch_value(pp[k], ps, pt);
            if (k == 0 || v[k] > top) {
                top = v[k];
                c = pp[k];
            }
        }
        tol = HX_BRANCH_TIE * (fabs(top) + wx + wy);
        for (k = 0; k < n; k++)
            tied += v[k] >= top - tol;
        if (tied > 1) { /* (s, tt) nudged toward the cell's centre */
            double si = s + HX_BRANCH_NUDGE * (0.5 - s), ti = tt + HX_BRANCH_NUDGE * (0.5 - tt);
            double qs[4] = {1.0, si, si * si, si * si * si}, qt[4] = {1.0, ti, ti * ti, ti * ti * ti};
            c = NULL;
            for (k = 0; k < n; k++) {
                if (v[k] < top - tol)
                    continue;
                in = patch_value(pp[k], qs, qt);
                if (c == NULL || in > best) {
                    best = in;
                    c = pp[k];
                }
            }
        }
    }
    patch_poly(c, s, tt, wx, wy, order, D);
}

HX_INLINE_LARGE void patches_eval(const hx_texture *t, double x, double y, hx_height *o)
{
    double D[4][4], cx, cy, ex, ey;
    int ox, oy;
    patch_derivs(t, x, y, D, &cx, &cy, 2);
    ex = x - cx;
    ey = y - cy;
    ox = ex != 0.0;
    oy = ey != 0.0;
    if (!ox && !oy) {
        patch_height(D, o);
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

/* h and its derivatives in the texture's own frame: a patch map's (its cells' axes) where the
 * map is turned (HX_PATCH_TURN); hx__texture_eval turns the plane's point into it. */
HX_INLINE void hx__frame_eval(const hx_texture *t, double x, double y, hx_height *out)
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

/* h alone in the texture's own frame (as hx__frame_eval) */
HX_INLINE double hx__frame_height(const hx_texture *t, double x, double y)
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
        hx__frame_eval(t, x, y, &o);
        return o.h;
    }
}

/* A patch map's turn theta (rad, HX_PATCH_TURN), 0 for every other kind: the map's axes are
 * the plane's turned by theta, a point p of the plane is at m = R(theta)^T p on the map */
HX_INLINE double hx__turn(const hx_texture *t)
{
    return t->kind == HX_SURFACE_PATCHES ? t->c[HX_PATCH_TURN] : 0.0;
}

/* The point p = (x, y) of the plane on a map turned by th: m = R(th)^T p in (*mx, *my), and R's
 * cosine and sine in (*cs, *sn) (the way back: p = R m) */
HX_INLINE void hx__to_frame(double th, double x, double y, double *mx, double *my, double *cs, double *sn)
{
    *cs = cos(th);
    *sn = sin(th);
    *mx = *cs * x + *sn * y;
    *my = *cs * y - *sn * x;
}

/* h, its gradient and Hessian at (x, y) of the plane: on a turned map h(p) = h_m(R^T p), so
 * grad h = R grad h_m and H = R H_m R^T */
HX_INLINE void hx__texture_eval(const hx_texture *t, double x, double y, hx_height *out)
{
    double th = hx__turn(t), mx, my, cs, sn, cc, ss, cn;
    hx_height m;
    if (th == 0.0) {
        hx__frame_eval(t, x, y, out);
        return;
    }
    hx__to_frame(th, x, y, &mx, &my, &cs, &sn);
    hx__frame_eval(t, mx, my, &m);
    cc = cs * cs;
    ss = sn * sn;
    cn = cs * sn;
    out->h = m.h;
    out->gx = cs * m.gx - sn * m.gy;
    out->gy = sn * m.gx + cs * m.gy;
    out->hxx = cc * m.hxx - 2.0 * cn * m.hxy + ss * m.hyy;
    out->hxy = cn * (m.hxx - m.hyy) + (cc - ss) * m.hxy;
    out->hyy = ss * m.hxx + 2.0 * cn * m.hxy + cc * m.hyy;
}

/* h alone at (x, y) of the plane (as hx__texture_eval) */
HX_INLINE double hx__texture_height(const hx_texture *t, double x, double y)
{
    double th = hx__turn(t), mx, my, cs, sn;
    if (th == 0.0)
        return hx__frame_height(t, x, y);
    hx__to_frame(th, x, y, &mx, &my, &cs, &sn);
    return hx__frame_height(t, mx, my);
}

#endif
