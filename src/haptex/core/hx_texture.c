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
 *   HX_SURFACE_PATCHES   1 x (10 + 16 nx ny): header [x0, y0, dx, dy, nx, ny, periodic, joins, axes,
 *                        turn],
 *                        then per cell (i along x, row-major: cell (i, j) at 16 (i ny + j))
 *                        the coefficients c[a][b] of s^a t^b, s, t in [0, 1] the cell's
 *                        local coordinates. Outside a non-periodic map, the tangent-plane
 *                        extension h(c) + grad h(c) . (p - c), c the nearest point of the map.
 *                        joins (HX_PATCH_JOINS): 0 for a C^2 spline, 1 for patches joined only
 *                        continuously across their lines (a Hermite map, a felt map's kinks),
 *                        2 as 1 with branched cells: then nx ny + 1 starts and the extra
 *                        patches follow (hx_core.h, HX_JOINS_BRANCHED). axes
 *                        (HX_PATCH_AXES): 0 for uniform cells dx by dy; for graded axes the
 *                        column where nx + 1 x knots and ny + 1 y knots follow all that,
 *                        then each axis's bucket index (hx_core.h).
 *                        turn (HX_PATCH_TURN): the map's axes turned from the plane's
 *                        (rad, |turn| <= pi; 0 along them).
 */
#include "hx_core.h"
#include "hx_texture_eval.h"

#include <math.h>
#include <stddef.h>

static int finite_positive(double v) { return isfinite(v) && v > 0.0; }

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
        double nx, ny, body;
        int a;
        if (rows != 1 || cols < HX_PATCH_DATA)
            return HX_BAD_COEFFS;
        nx = c[HX_PATCH_NX];
        ny = c[HX_PATCH_NY];
        if (!isfinite(c[HX_PATCH_X0]) || !isfinite(c[HX_PATCH_Y0]) || !finite_positive(c[HX_PATCH_DX]) ||
            !finite_positive(c[HX_PATCH_DY]) || !is_count(nx, 1e9) || !is_count(ny, 1e9) ||
            !(fabs(c[HX_PATCH_TURN]) <= 3.14159265358979323846))
            return HX_BAD_COEFFS;
        for (i = 0; i < HX_PATCH_DATA; i++)
            if (!isfinite(c[i]))
                return HX_BAD_COEFFS;
        body = 16.0 * nx * ny; /* the columns after the header but a graded map's knots */
        if (c[HX_PATCH_JOINS] == (double)HX_JOINS_BRANCHED) { /* the starts: 0, nondecreasing, E at the end */
            const double *st = c + HX_PATCH_DATA + 16 * (long)nx * (long)ny;
            long n = (long)nx * (long)ny, k;
            if ((double)(cols - HX_PATCH_DATA) < 16.0 * nx * ny + nx * ny + 1.0 || st[0] != 0.0)
                return HX_BAD_COEFFS;
            for (k = 0; k < n; k++)
                if (!(st[k + 1] >= st[k] && st[k + 1] - st[k] <= HX_MAX_BRANCHES - 1 && st[k + 1] == floor(st[k + 1])))
                    return HX_BAD_COEFFS;
            body += nx * ny + 1.0 + 16.0 * st[n];
        } else if (c[HX_PATCH_JOINS] != (double)HX_JOINS_SPLINE && c[HX_PATCH_JOINS] != (double)HX_JOINS_HERMITE) {
            return HX_BAD_COEFFS;
        }
        if (c[HX_PATCH_AXES] == 0.0)
            return (double)(cols - HX_PATCH_DATA) == body ? HX_OK : HX_BAD_COEFFS;
        /* graded axes: the knots right after the body, each axis's increasing from its origin,
         * then each axis's bucket index: B in [1, 16 n + 16] and B cells, whole, nondecreasing */
        if (c[HX_PATCH_AXES] != (double)HX_PATCH_DATA + body || (double)cols < c[HX_PATCH_AXES] + nx + ny + 4.0)
            return HX_BAD_COEFFS;
        {
            long at = (long)c[HX_PATCH_AXES] + (long)nx + (long)ny + 2;
            for (a = 0; a < 2; a++) {
                const double *kn = c + (long)c[HX_PATCH_AXES] + (a == 0 ? 0 : (long)nx + 1), *ix;
                long n = (long)(a == 0 ? nx : ny), k, nb;
                if (kn[0] != c[HX_PATCH_X0 + a])
                    return HX_BAD_COEFFS;
                for (k = 0; k < n; k++)
                    if (!(kn[k + 1] > kn[k]) || !isfinite(kn[k + 1]))
                        return HX_BAD_COEFFS;
                if (at >= cols || !is_count(c[at], 16.0 * (double)n + 16.0) || (double)(cols - at - 1) < c[at])
                    return HX_BAD_COEFFS;
                nb = (long)c[at];
                ix = c + at + 1;
                for (k = 0; k < nb; k++)
                    if (!(ix[k] >= (k == 0 ? 0.0 : ix[k - 1]) && ix[k] <= (double)(n - 1) && ix[k] == floor(ix[k])))
                        return HX_BAD_COEFFS;
                at += 1 + nb;
            }
            return at == cols ? HX_OK : HX_BAD_COEFFS;
        }
    }
    default:
        return HX_BAD_KIND;
    }
}

/* ---- the public entry points (the inline bodies are in hx_texture_eval.h) ---- */

void hx_texture_eval(const hx_texture *t, double x, double y, hx_height *out) { hx__texture_eval(t, x, y, out); }

double hx_texture_height(const hx_texture *t, double x, double y) { return hx__texture_height(t, x, y); }
