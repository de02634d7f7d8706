/*
 * Texture evaluation: the height h(x, y) and its derivatives, for every texture kind.
 *
 * Coefficient layouts (row-major, rows x cols):
 *   HX_TEXTURE_FLAT      any (ignored); h = 0.
 *   HX_TEXTURE_FOURIER   3 x n: amplitudes a_i (m), wavenumbers k_i = 2 pi / l_i (rad/m),
 *                        phases (rad); h(x) = sum a_i sin(k_i x + phase_i).
 *   HX_TEXTURE_SPLINE    4 x (m + 2): columns 0..m-1 the cubic coefficients of each of m
 *                        uniform intervals (highest power first, in t = x - x_i, as scipy's
 *                        CubicSpline.c); column m = [x0, dx, periodic (0/1), m]; column
 *                        m + 1 = [h, h'] at the left end and [h, h'] at the right end, the
 *                        linear extension of a non-periodic profile.
 *   HX_SURFACE_GRATINGS  4 x n: amplitudes (m), kx, ky (rad/m), phases (rad);
 *                        h(x, y) = sum a_i sin(kx_i x + ky_i y + phase_i).
 *   HX_SURFACE_PATCHES   1 x (8 + 16 nx ny): header [x0, y0, dx, dy, nx, ny, periodic, 0],
 *                        then per cell (i along x, row-major: cell (i, j) at 16 (i ny + j))
 *                        the coefficients c[a][b] of s^a t^b, s, t in [0, 1] the cell's
 *                        local coordinates. Outside a non-periodic map, the tangent-plane
 *                        extension h(c) + grad h(c) . (p - c), c the nearest point of the map.
 */
#include "hx_core.h"

#include <math.h>
#include <stddef.h>

#define AT(t, r, k) ((t)->c[(long)(r) * (t)->cols + (k)])

enum { PATCH_X0, PATCH_Y0, PATCH_DX, PATCH_DY, PATCH_NX, PATCH_NY, PATCH_PERIODIC, PATCH_DATA = 8 };

static int finite_positive(double v) { return isfinite(v) && v > 0.0; }

/* The cell of a coordinate u measured in cells, 0 <= u <= n after a periodic reduction or a
 * clamp: an index in [0, n - 1] whatever round-off did to u (never an out-of-range cast). */
static long cell_of(double u, long n)
{
    if (!(u > 0.0))
        return 0;
    if (u >= (double)n)
        return n - 1;
    return (long)u;
}

static int is_count(double v, double most)
{
    return isfinite(v) && v >= 1.0 && v <= most && v == floor(v);
}

int hx_texture_check(int kind, const double *c, long rows, long cols)
{
    long i;
    if (kind < 0 || kind >= HX_N_KINDS)
        return HX_BAD_KIND;
    if (kind == HX_TEXTURE_FLAT)
        return HX_OK;
    if (c == NULL || rows < 0 || cols < 0)
        return HX_BAD_COEFFS;
    switch (kind) {
    case HX_TEXTURE_FOURIER:
        return rows == 3 ? HX_OK : HX_BAD_COEFFS;
    case HX_SURFACE_GRATINGS:
        return rows == 4 ? HX_OK : HX_BAD_COEFFS;
    case HX_TEXTURE_SPLINE: {
        long m = cols - 2;
        if (rows != 4 || m < 1)
            return HX_BAD_COEFFS;
        /* the header column must describe exactly these m intervals */
        if (!isfinite(c[m]) || !finite_positive(c[cols + m]) || c[3 * cols + m] != (double)m)
            return HX_BAD_COEFFS;
        return HX_OK;
    }
    case HX_SURFACE_PATCHES: {
        double nx, ny;
        if (rows != 1 || cols < PATCH_DATA)
            return HX_BAD_COEFFS;
        nx = c[PATCH_NX];
        ny = c[PATCH_NY];
        if (!isfinite(c[PATCH_X0]) || !isfinite(c[PATCH_Y0]) || !finite_positive(c[PATCH_DX]) ||
            !finite_positive(c[PATCH_DY]) || !is_count(nx, 1e9) || !is_count(ny, 1e9))
            return HX_BAD_COEFFS;
        if ((double)(cols - PATCH_DATA) != 16.0 * nx * ny)
            return HX_BAD_COEFFS;
        for (i = 0; i < PATCH_DATA; i++)
            if (!isfinite(c[i]))
                return HX_BAD_COEFFS;
        return HX_OK;
    }
    default:
        return HX_BAD_KIND;
    }
}

/* ---- profiles ---------------------------------------------------------------------- */

static void fourier_eval(const hx_texture *t, double x, hx_height *o)
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

static void spline_eval(const hx_texture *t, double x, hx_height *o)
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

static void gratings_eval(const hx_texture *t, double x, double y, hx_height *o)
{
    long i, n = t->cols;
    for (i = 0; i < n; i++) {
        double a = AT(t, 0, i), kx = AT(t, 1, i), ky = AT(t, 2, i);
        double arg = kx * x + ky * y + AT(t, 3, i), sn = sin(arg), cs = cos(arg);
        o->h += a * sn;
        o->gx += a * kx * cs;
        o->gy += a * ky * cs;
        o->hxx -= a * kx * kx * sn;
        o->hxy -= a * kx * ky * sn;
        o->hyy -= a * ky * ky * sn;
    }
}

/* All derivatives D[p][q] = d^(p+q) h / dx^p dy^q, p, q <= 3, of the bicubic patch holding
 * (x, y) clamped to the map; (*cx, *cy) receives the clamped point. */
static void patch_derivs(const hx_texture *t, double x, double y, double D[4][4], double *cx, double *cy)
{
    const double *hd = t->c;
    double dx = hd[PATCH_DX], dy = hd[PATCH_DY];
    long nx = (long)hd[PATCH_NX], ny = (long)hd[PATCH_NY], i, j;
    double u = (x - hd[PATCH_X0]) / dx, v = (y - hd[PATCH_Y0]) / dy, s, tt;
    double S[4][4] = {{0}}, T[4][4] = {{0}}, sx = 1.0, sy;
    const double *c;
    int a, b, p, q;
    *cx = x;
    *cy = y;
    if (hd[PATCH_PERIODIC] != 0.0) {
        u -= (double)nx * floor(u / (double)nx);
        v -= (double)ny * floor(v / (double)ny);
    } else {
        if (!(u >= 0.0 && u <= (double)nx)) {
            u = u < 0.0 ? 0.0 : (double)nx;
            *cx = hd[PATCH_X0] + u * dx;
        }
        if (!(v >= 0.0 && v <= (double)ny)) {
            v = v < 0.0 ? 0.0 : (double)ny;
            *cy = hd[PATCH_Y0] + v * dy;
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
    c = hd + PATCH_DATA + 16 * (i * ny + j);
    for (p = 0; p < 4; p++) {
        double row[4];
        for (b = 0; b < 4; b++) {
            double acc = 0.0;
            for (a = p; a < 4; a++)
                acc += c[4 * a + b] * S[p][a];
            row[b] = acc;
        }
        sy = 1.0;
        for (q = 0; q < 4; q++) {
            double acc = 0.0;
            for (b = q; b < 4; b++)
                acc += row[b] * T[q][b];
            D[p][q] = acc / (sx * sy);
            sy *= dy;
        }
        sx *= dx;
    }
}

static void patches_eval(const hx_texture *t, double x, double y, hx_height *o)
{
    double D[4][4], cx, cy, ex, ey;
    int ox, oy;
    patch_derivs(t, x, y, D, &cx, &cy);
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

void hx_texture_eval(const hx_texture *t, double x, double y, hx_height *out)
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

double hx_texture_height(const hx_texture *t, double x, double y)
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
    default:
        hx_texture_eval(t, x, y, &o);
        return o.h;
    }
}
