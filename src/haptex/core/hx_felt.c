/*
 * The surface a ball feels (haptex.probe.felt_by, haptex.surfaces): each grid point's contact,
 * the offset u from the ball's centre p at which the ball of radius r touches the texture H,
 * the maximiser of
 *
 *     g(u) = H(p + u) + sqrt(r^2 - |u|^2)
 *
 * over a box of offsets and the disc |u| <= rim (the centre path c(p) = max g: a grey-scale
 * dilation by the ball; Villarrubia, J. Res. NIST 102(4), 1997): first over the grid's offsets
 * (hx_grid_dilation), then refined on the texture itself (hx_contact_ascent). Analysis only: not
 * a servo tick's (``haptex export`` does not ship this file).
 */
#include "hx_core.h"

#include <math.h>

/* the 2-norm of the symmetric 2 x 2 matrix [[a, b], [b, c]]: |a + c| / 2 + sqrt(((a - c) / 2)^2 + b^2) */
static double sym_norm(double a, double b, double c)
{
    return 0.5 * fabs(a + c) + hypot(0.5 * (a - c), b);
}

/* the candidate offset u + s clipped to the box [lo, hi] (min(max(v, lo), hi), as NumPy's clip: hi where a box
 * cut by a map's edge has lo > hi) and pulled onto the disc |u| <= rim */
static void candidate(const double *u, const double *s, const double *lo, const double *hi, double rim, double *c)
{
    double norm;
    int k;
    for (k = 0; k < 2; k++) {
        double v = u[k] + s[k];
        double m = v < lo[k] ? lo[k] : v;
        c[k] = m > hi[k] ? hi[k] : m;
    }
    norm = sqrt(c[0] * c[0] + c[1] * c[1]);
    if (norm > rim) {
        double f = rim / (norm > 1e-300 ? norm : 1e-300);
        c[0] *= f;
        c[1] *= f;
    }
}

/* g at offset c from p */
static double lifted(const hx_texture *t, const double *p, const double *c, double r)
{
    hx_height hh;
    double left = r * r - (c[0] * c[0] + c[1] * c[1]);
    hx_texture_eval(t, p[0] + c[0], p[1] + c[1], &hh);
    return hh.h + sqrt(left > 0.0 ? left : 0.0);
}

void hx_contact_ascent(const hx_texture *t, long n, const double *P, double *U, const double *lo, const double *hi,
                       double r, double rim, double tol, int steps, double *G)
{
    long i;
    for (i = 0; i < n; i++) {
        const double *p = P + 2 * i, *l = lo + 2 * i, *h = hi + 2 * i;
        double *u = U + 2 * i, g = 0.0;
        int it;
        for (it = 0; it < steps; it++) {
            hx_height d;
            double left, s2, sq, w, g0, g1, h00, h01, h11, scale, a, b, c, least, shift, det, st[2];
            double moved = 0.0;
            int held0, held1, half;
            hx_texture_eval(t, p[0] + u[0], p[1] + u[1], &d);
            left = r * r - (u[0] * u[0] + u[1] * u[1]);
            s2 = left > (r - rim) * r ? left : (r - rim) * r;
            sq = sqrt(s2);
            if (it == 0)
                g = d.h + sqrt(left > 0.0 ? left : 0.0);
            g0 = d.gx - u[0] / sq;
            g1 = d.gy - u[1] / sq;
            w = 1.0 / (s2 * sq);
            /* g's Hessian: H's minus the sphere cap's (I / sq + u u^T / sq^3) */
            h00 = d.hxx - (1.0 / sq + u[0] * u[0] * w);
            h01 = d.hxy - u[0] * u[1] * w;
            h11 = d.hyy - (1.0 / sq + u[1] * u[1] * w);
            /* ascent on the concave part: -Hessian shifted to positive definite where it is not */
            scale = sym_norm(h00, h01, h11);
            a = -h00;
            b = -h01;
            c = -h11;
            least = 0.5 * (a + c) - hypot(0.5 * (a - c), b);
            shift = least > 1e-12 * scale ? 0.0 : fabs(least) + 1e-6 * scale + 1e-300;
            a += shift;
            c += shift;
            det = a * c - b * b;
            st[0] = (c * g0 - b * g1) / det;
            st[1] = (a * g1 - b * g0) / det;
            /* a coordinate held at its bound by an ascent that points out of the box stays there,
             * the other stepped by its own curvature (projected Newton) */
            {
                double e0 = 1e-9 * (h[0] - l[0] > 1e-300 ? h[0] - l[0] : 1e-300);
                double e1 = 1e-9 * (h[1] - l[1] > 1e-300 ? h[1] - l[1] : 1e-300);
                held0 = (u[0] <= l[0] + e0 && g0 < 0.0) || (u[0] >= h[0] - e0 && g0 > 0.0);
                held1 = (u[1] <= l[1] + e1 && g1 < 0.0) || (u[1] >= h[1] - e1 && g1 > 0.0);
            }
            if (held1 && !held0) {
                double k = -h00, curv = k > 1e-12 * scale ? k : fabs(k) + 1e-6 * scale + 1e-300;
                st[0] = g0 / curv;
                st[1] = 0.0;
            } else if (held0 && !held1) {
                double k = -h11, curv = k > 1e-12 * scale ? k : fabs(k) + 1e-6 * scale + 1e-300;
                st[1] = g1 / curv;
                st[0] = 0.0;
            } else if (held0 && held1) {
                st[0] = st[1] = 0.0;
            }
            /* backtracking: only a step that raises g, inside the box and the disc; halved while
             * longer than tol */
            for (half = 0; half < 6; half++) {
                double cand[2], gc;
                candidate(u, st, l, h, rim, cand);
                gc = lifted(t, p, cand, r);
                if (gc > g) {
                    double d0 = cand[0] - u[0], d1 = cand[1] - u[1];
                    moved = sqrt(d0 * d0 + d1 * d1);
                    u[0] = cand[0];
                    u[1] = cand[1];
                    g = gc;
                    break;
                }
                if (!(st[0] * st[0] + st[1] * st[1] > tol * tol))
                    break;
                st[0] *= 0.5;
                st[1] *= 0.5;
            }
            if (!(moved > tol))
                break;
        }
        G[i] = g;
    }
}

void hx_grid_dilation(const double *hp, long p1, long n0, long n1, long half0, long half1, const long long *offs,
                      const double *lift, long n_off, double *best, int *which)
{
    long i, j, k;
    for (i = 0; i < n0; i++) { /* a row at a time, the offsets in their order (the first that reaches the maximum
                                * kept), each along the row (contiguous) */
        double *b = best + i * n1;
        int *w = which + i * n1;
        for (j = 0; j < n1; j++) {
            b[j] = -HUGE_VAL;
            w[j] = 0;
        }
        for (k = 0; k < n_off; k++) {
            const double *row = hp + (i + half0 + (long)offs[2 * k]) * p1 + half1 + (long)offs[2 * k + 1];
            double l = lift[k];
            for (j = 0; j < n1; j++) { /* (branch-free: the compiler's vector loop) */
                double v = row[j] + l;
                int up = v > b[j];
                b[j] = up ? v : b[j];
                w[j] = up ? (int)k : w[j];
            }
        }
    }
}
