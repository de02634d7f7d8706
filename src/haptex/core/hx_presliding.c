/*
 * Presliding friction (Hayward & Armstrong, "A new computational model of friction applied
 * to haptic rendering", 2000) for algorithm F: the sharp model (eq. 24 of Campion & Hayward,
 * the play operator) and the smooth one (Dupont et al. 2002's breakaway function), isotropic
 * in the tangent plane; a profile is the y-independent case.
 *
 * The smooth model's travel table (haptex.friction.smooth_table), in units of d_max:
 * header [n, ln r, dv, beta, 0, 0, 0, 0], then X_j (n values) and dX/dj (n values) at
 * e_j = r exp(-j dv), r = 1 - z_stick / d_max, X(e) the travel from the start of the ramp.
 */
#include "hx_core.h"

#include <math.h>
#include <stddef.h>

enum { T_N = HX_T_N, T_LOGR = HX_T_LOGR, T_DV = HX_T_DV, T_BETA = HX_T_BETA, T_DATA = HX_T_DATA };

int hx_presliding_table_check(const double *tab, long n_tab)
{
    double n;
    if (tab == NULL || n_tab < T_DATA)
        return HX_BAD_COEFFS;
    n = tab[T_N];
    if (!(n >= 2.0 && n <= 1e7 && n == floor(n)) || (double)n_tab < T_DATA + 2.0 * n)
        return HX_BAD_COEFFS;
    if (!isfinite(tab[T_LOGR]) || !(tab[T_DV] > 0.0) || !isfinite(tab[T_DV]) || !isfinite(tab[T_BETA]))
        return HX_BAD_COEFFS;
    return HX_OK;
}

/* X at node j + th (0 <= th <= 1) and dX/dth, cubic Hermite */
static void hermite(const double *tab, long j, double th, double *val, double *der)
{
    long n = (long)tab[T_N];
    double x0 = tab[T_DATA + j], x1 = tab[T_DATA + j + 1], m0 = tab[T_DATA + n + j], m1 = tab[T_DATA + n + j + 1];
    double t2 = th * th, t3 = t2 * th;
    *val = (2 * t3 - 3 * t2 + 1) * x0 + (t3 - 2 * t2 + th) * m0 + (-2 * t3 + 3 * t2) * x1 + (t3 - t2) * m1;
    *der = (6 * t2 - 6 * th) * x0 + (3 * t2 - 4 * th + 1) * m0 + (-6 * t2 + 6 * th) * x1 + (3 * t2 - 2 * th) * m1;
}

double hx_smooth_flow(double deflection, double dx, double d_max, double z_stick, const double *tab, long *work)
{
    double s, a, rem, r, e, dv, logr, travel, jl, beta, g;
    long n;
    if (dx == 0.0)
        return deflection;
    s = dx > 0.0 ? 1.0 : -1.0;
    a = deflection * s; /* the deflection along the motion */
    rem = fabs(dx);
    if (a < z_stick) { /* purely elastic until |d| = z_stick in the direction of motion */
        if (a + rem <= z_stick)
            return s * (a + rem);
        rem -= z_stick - a;
        a = z_stick;
    }
    r = 1.0 - z_stick / d_max;
    e = 1.0 - a / d_max;
    if (e <= 0.0)
        return s * d_max;
    n = (long)tab[T_N];
    dv = tab[T_DV];
    logr = tab[T_LOGR];
    travel = rem / d_max;
    jl = (logr - log(e)) / dv; /* continuous node index of e */
    if (jl < (double)(n - 1)) {
        long j0 = jl > 0.0 ? (long)jl : 0;
        double x_start, der, target;
        hermite(tab, j0, jl - (double)j0, &x_start, &der);
        target = x_start + travel;
        if (target < tab[T_DATA + n - 1]) {
            long lo = j0, hi = n - 1;
            double a_th = 0.0, b_th = 1.0, th = 0.5;
            int it;
            while (hi - lo > 1) { /* the node interval holding the target */
                long mid = (lo + hi) / 2;
                (*work)++;
                if (tab[T_DATA + mid] <= target)
                    lo = mid;
                else
                    hi = mid;
            }
            for (it = 0; it < 60; it++) { /* Newton safeguarded by bisection */
                double val, tn;
                (*work)++;
                hermite(tab, lo, th, &val, &der);
                if (val < target)
                    a_th = th;
                else
                    b_th = th;
                tn = der > 0.0 ? th - (val - target) / der : 0.5 * (a_th + b_th);
                if (!(a_th <= tn && tn <= b_th))
                    tn = 0.5 * (a_th + b_th);
                if (fabs(tn - th) <= 1e-15) {
                    th = tn;
                    break;
                }
                th = tn;
            }
            e = r * exp(-((double)lo + th) * dv);
            return s * d_max * (1.0 - e);
        }
        travel = target - tab[T_DATA + n - 1];
        e = r * exp(-(double)(n - 1) * dv);
    }
    /* the tail: de/dx = -(e + beta e^2), the exact logistic flow */
    beta = tab[T_BETA];
    g = (1.0 / e + beta) * exp(travel) - beta;
    e = g < HUGE_VAL ? 1.0 / g : 0.0;
    return s * d_max * (1.0 - e);
}

void hx_presliding_plane(double d[2], const double dp[2], double d_max, double z_stick, const double *tab,
                         long *work)
{
    double nx, ny, size;
    if (z_stick < 0.0) { /* sharp: the play operator, d + dp kept in the disk |d| <= d_max */
        nx = d[0] + dp[0];
        ny = d[1] + dp[1];
    } else { /* smooth along the deflection's direction (the motion's if d = 0), elastic across */
        double r = hypot(d[0], d[1]), ux, uy, a, radial;
        if (r > 0.0) {
            ux = d[0] / r;
            uy = d[1] / r;
        } else {
            double m = hypot(dp[0], dp[1]);
            if (m == 0.0)
                return;
            ux = dp[0] / m;
            uy = dp[1] / m;
        }
        a = ux * dp[0] + uy * dp[1];
        radial = hx_smooth_flow(r, a, d_max, z_stick, tab, work);
        nx = radial * ux + (dp[0] - a * ux);
        ny = radial * uy + (dp[1] - a * uy);
    }
    size = hypot(nx, ny);
    if (size > d_max) {
        if (ny == 0.0) { /* along a line (a profile): exactly +-d_max, eq. 24 */
            nx = copysign(d_max, nx);
        } else {
            nx *= d_max / size;
            ny *= d_max / size;
        }
    }
    d[0] = nx;
    d[1] = ny;
}
