/*
 * The closest point on a profile's boundary z = h(x) to a probe below it (algorithms D and
 * E): a bounded branch and bound over a tree of rigorous height bounds built once per
 * texture (haptex.closest.search_data), with upper bounds from the vertical point, a warm
 * start, the texture's lowest point and the straight extensions of a finite profile.
 *
 * phi(t) = (t - px)^2 + (h(t) - pz)^2 is minimised; g = phi'/2, g' = phi''/2. A node of the
 * tree (a dyadic sub-interval with bounds lo <= h <= hi) is pruned when the box
 * [interval] x [lo, hi] is farther than the best distance (plus the tie tolerance); a leaf
 * is scanned every A_STEP for sign changes of g, each refined by safeguarded Newton, and an
 * interval on which two minima could hide (|g''| bounded from A_SLOPE, A_CURV, A_JERK) is
 * sampled 16 times finer; a leaf on which phi is certified convex for the probe (from bounds
 * of h'' over each leaf, a spline profile's) is not scanned: Newton finds its one minimum.
 * Over a periodic profile a servo tick first reads a cell table
 * (haptex.closest.table_search_data), the same certified answer in a few evaluations. Work
 * (texture evaluations) is counted.
 */
#include "hx_core.h"
#include "hx_texture_eval.h"

#include <math.h>
#include <stddef.h>
#include <stdint.h>

enum { STACK_DEPTH = 64 };

typedef struct {
    double f, t, second; /* the best phi and its abscissa; the best runner-up's phi */
    int found;           /* the best is a refined local minimum */
    long work;
    double sample[2];    /* a leaf's best sample (t, phi) */
    int64_t stack[STACK_DEPTH]; /* heap indices of the tree's nodes: past 2^31 on an open window */
} search;

typedef struct {
    const hx_texture *tex;
    const double *aux;
    double px, pz;
} problem;

static void dphi(const problem *q, double t, double *f, double *g, double *gp)
{
    hx_height e;
    double dz;
    hx__texture_eval(q->tex, t, 0.0, &e);
    dz = e.h - q->pz;
    *g = (t - q->px) + dz * e.gx;
    *gp = 1.0 + e.gx * e.gx + dz * e.hxx;
    *f = (t - q->px) * (t - q->px) + dz * dz;
}

/* root of g in [a, b] where g(a) <= 0 < g(b): safeguarded Newton, at most 60 iterations */
static double refine_bracket(const problem *q, double a, double b, long *it_out)
{
    double lo = a, hi = b, t = 0.5 * (a + b), f, g, gp, tn;
    long it;
    for (it = 1; it <= 60; it++) {
        dphi(q, t, &f, &g, &gp);
        if (g > 0.0)
            hi = t;
        else
            lo = t;
        tn = gp > 0.0 ? t - g / gp : 0.5 * (lo + hi);
        if (!(lo < tn && tn < hi))
            tn = 0.5 * (lo + hi);
        if (fabs(tn - t) <= 1e-15 * (1.0 + fabs(t)) || hi - lo <= 1e-16 * (1.0 + fabs(t))) {
            *it_out = it;
            return tn;
        }
        t = tn;
    }
    *it_out = 60;
    return t;
}

/* Newton on g from t, kept inside [a, b], at most 30 iterations */
static double polish(const problem *q, double t, double a, double b, long *it_out)
{
    double f, g, gp, tn;
    long it;
    for (it = 1; it <= 30; it++) {
        dphi(q, t, &f, &g, &gp);
        if (gp <= 0.0) {
            *it_out = it;
            return t;
        }
        tn = fmin(fmax(t - g / gp, a), b);
        if (fabs(tn - t) <= 1e-15 * (1.0 + fabs(t))) {
            *it_out = it;
            return tn;
        }
        t = tn;
    }
    *it_out = 30;
    return t;
}

/* a boundary point: an upper bound of the minimum, not a certified local minimum */
static void bound(search *s, double t, double f)
{
    if (f < s->f) {
        s->f = f;
        s->t = t;
    }
}

/* a refined local minimum: keep the best, and the best runner-up more than sep away */
static void offer(search *s, double t, double f, double sep)
{
    if (f < s->f) {
        if (s->found && s->f < s->second && fabs(t - s->t) > sep)
            s->second = s->f;
        s->f = f;
        s->t = t;
        s->found = 1;
    } else if (s->found && f < s->second && fabs(t - s->t) > sep) {
        s->second = f;
    }
}

/* 0 when phi provably has no local minimum in a sample interval other than the one a - to +
 * sign change of g reveals: |g''| = |3 h' h'' + (h - pz) h'''| <= G2 with |h - pz| <= dz */
static int pair_possible(const double *aux, double g0, double g1, double gp0, double gp1, double dz, double dt)
{
    double g2 = 3.0 * aux[HX_A_SLOPE] * aux[HX_A_CURV] + dz * aux[HX_A_JERK];
    if (fmin(gp0, gp1) - g2 * dt > 0.0)
        return 0;
    if ((g0 > 0.0) == (g1 > 0.0))
        return fabs(g0) + fabs(g1) <= (fmax(fabs(gp0), fabs(gp1)) + g2 * dt) * dt;
    return 1;
}

static long refine_and_offer(const problem *q, double a, double b, double sep, search *s)
{
    long it;
    double t = refine_bracket(q, a, b, &it), f, g, gp;
    dphi(q, t, &f, &g, &gp);
    offer(s, t, f, sep);
    return it + 1;
}

static long scan_interval(const problem *q, double a, double b, double g_a, int n, search *s, double best[2])
{
    long work = 0;
    double dt = (b - a) / n, t_prev = a, g_prev = g_a;
    int k;
    for (k = 1; k <= n; k++) {
        double t_k = k == n ? b : a + k * dt, f_k, g_k, gp_k;
        dphi(q, t_k, &f_k, &g_k, &gp_k);
        work++;
        if (f_k < best[1]) {
            best[0] = t_k;
            best[1] = f_k;
        }
        if (g_prev <= 0.0 && g_k > 0.0)
            work += refine_and_offer(q, t_prev, t_k, 0.5 * dt, s);
        t_prev = t_k;
        g_prev = g_k;
    }
    return work;
}

/* a leaf on which phi is certified convex for this probe: g' = 1 + h'^2 + (h - pz) h'' > 0 from
 * the tree's bounds of h (lo, hi) and the leaf's bounds of h'' (aux[HX_A_LEAFC]); then phi has
 * at most one minimum on it, a root of g found by safeguarded Newton, or an end. 0: not
 * certified (or no bounds of h''), the leaf is to be scanned */
static int convex_leaf(const problem *q, int64_t leaf, double u, double w, double lo, double hi, search *s)
{
    const double *aux = q->aux;
    double off = aux[HX_A_LEAFC], nl = aux[HX_A_NLEAF], c_lo, c_hi, e_lo = lo - q->pz, e_hi = hi - q->pz, least;
    double f0, g0, f1, g1, gp;
    if (off == 0.0 || leaf < 0)
        return 0;
    c_lo = aux[(int64_t)off + leaf];
    c_hi = aux[(int64_t)off + (int64_t)nl + leaf];
    least = fmin(fmin(e_lo * c_lo, e_lo * c_hi), fmin(e_hi * c_lo, e_hi * c_hi));
    if (!(1.0 + least > 1e-3)) /* (NaN where a bound is infinite: not certified) */
        return 0;
    dphi(q, u, &f0, &g0, &gp);
    dphi(q, u + w, &f1, &g1, &gp);
    s->work += 2;
    if (g0 > 0.0 && g1 <= 0.0) /* (g increases on a convex leaf: rounding, scanned) */
        return 0;
    if (g0 <= 0.0 && g1 > 0.0)
        s->work += refine_and_offer(q, u, u + w, 0.5 * aux[HX_A_STEP], s);
    else if ((g0 > 0.0 ? f0 : f1) < s->f) /* the least point is an end */
        offer(s, g0 > 0.0 ? u : u + w, g0 > 0.0 ? f0 : f1, 0.5 * aux[HX_A_STEP]);
    return 1;
}

static void scan_leaf(const problem *q, double u, double w, search *s)
{
    const double *aux = q->aux;
    double steps = ceil(w / aux[HX_A_STEP]), dt, f_prev, g_prev, gp_prev, t_prev = u, t, f, g, gp;
    long n = steps < 2.0 || !(steps == steps) ? 2 : (steps > 1e6 ? 1000000 : (long)steps), i, it, work = 1;
    double *best = s->sample;
    dt = w / (double)n;
    dphi(q, u, &f_prev, &g_prev, &gp_prev);
    best[0] = u;
    best[1] = f_prev;
    for (i = 1; i <= n; i++) {
        double t_i = i == n ? u + w : u + (double)i * dt, f_i, g_i, gp_i, dz;
        dphi(q, t_i, &f_i, &g_i, &gp_i);
        work++;
        if (f_i < best[1]) {
            best[0] = t_i;
            best[1] = f_i;
        }
        dz = sqrt(fmax(f_prev, f_i)) + aux[HX_A_SLOPE] * dt;
        if (pair_possible(aux, g_prev, g_i, gp_prev, gp_i, dz, dt))
            work += scan_interval(q, t_prev, t_i, g_prev, 16, s, best);
        else if (g_prev <= 0.0 && g_i > 0.0)
            work += refine_and_offer(q, t_prev, t_i, 0.5 * dt, s);
        t_prev = t_i;
        f_prev = f_i;
        g_prev = g_i;
        gp_prev = gp_i;
    }
    t = polish(q, best[0], fmax(u, best[0] - dt), fmin(u + w, best[0] + dt), &it);
    dphi(q, t, &f, &g, &gp);
    work += it + 1;
    if (fabs(g) <= 1e-9 * sqrt(f) || f < s->f) /* a stationary point, or simply better */
        offer(s, t, f, 0.5 * dt);
    s->work += work;
}

static double box_lb(double px, double pz, double u, double w, double lo, double hi)
{
    double dx = fmax(0.0, fmax(u - px, px - (u + w))), dz = fmax(0.0, fmax(lo - pz, pz - hi));
    return dx * dx + dz * dz;
}

/* depth-first branch and bound over the implicit binary tree on [root_u, root_u + root_w]
 * with n_leaf leaves; node bounds from the tree in aux (table) or a Taylor bound */
static void descend(const problem *q, double root_u, double root_w, int64_t n_leaf, int table, search *s)
{
    const double *aux = q->aux;
    int64_t nl = (int64_t)aux[HX_A_NLEAF];
    int sp = 1;
    s->stack[0] = 1;
    while (sp > 0) {
        int64_t i = s->stack[--sp], j = i, first;
        int level = 0, first_left;
        double w, u, lo, hi, reach;
        while (j > 1) {
            j >>= 1;
            level++;
        }
        first = (int64_t)1 << level;
        w = root_w / (double)first;
        u = root_u + (double)(i - first) * w;
        if (table) {
            lo = aux[HX_A_TREE + i];
            hi = aux[HX_A_TREE + 2 * nl + i];
        } else {
            hx_height e;
            double spread;
            hx__texture_eval(q->tex, u + 0.5 * w, 0.0, &e);
            s->work++;
            spread = fmin(aux[HX_A_SLOPE] * 0.5 * w, fabs(e.gx) * 0.5 * w + aux[HX_A_CURV] * 0.125 * w * w);
            lo = e.h - spread;
            hi = e.h + spread;
        }
        reach = sqrt(s->f) + aux[HX_A_TIE];
        if (box_lb(q->px, q->pz, u, w, lo, hi) > reach * reach)
            continue;
        if (i >= n_leaf || sp + 2 > STACK_DEPTH) {
            if (!(table && i >= n_leaf && convex_leaf(q, i - n_leaf, u, w, lo, hi, s)))
                scan_leaf(q, u, w, s);
            continue;
        }
        /* the child with the smaller lower bound is popped first */
        first_left = q->px < u + 0.5 * w;
        if (table) {
            double hw = 0.5 * w;
            double lb_l = box_lb(q->px, q->pz, u, hw, aux[HX_A_TREE + 2 * i], aux[HX_A_TREE + 2 * nl + 2 * i]);
            double lb_r = box_lb(q->px, q->pz, u + hw, hw, aux[HX_A_TREE + 2 * i + 1],
                                 aux[HX_A_TREE + 2 * nl + 2 * i + 1]);
            first_left = lb_l <= lb_r;
        }
        s->stack[sp] = first_left ? 2 * i + 1 : 2 * i;
        s->stack[sp + 1] = first_left ? 2 * i : 2 * i + 1;
        sp += 2;
    }
}

/* the closest point of the straight extension of a non-periodic profile (exact) */
static void ray(const problem *q, double t_end, double h_end, double s_end, int left, search *s)
{
    double t = (q->px + s_end * (q->pz - h_end + s_end * t_end)) / (1.0 + s_end * s_end), f, g, gp;
    int clamped = (left && t > t_end) || (!left && t < t_end);
    if (clamped)
        t = t_end;
    dphi(q, t, &f, &g, &gp);
    s->work++;
    if (clamped)
        bound(s, t, f);
    else
        offer(s, t, f, 0.0);
}

static void tree_search(const problem *q, double t_guess, int mode, search *s)
{
    const double *aux = q->aux;
    int64_t nl = (int64_t)aux[HX_A_NLEAF];
    double f, g, gp;
    if (t_guess == t_guess) {
        double r = sqrt(s->f), tg;
        long it;
        tg = polish(q, t_guess, q->px - r, q->px + r, &it);
        dphi(q, tg, &f, &g, &gp);
        s->work += it + 1;
        bound(s, tg, f);
    }
    if (mode == HX_CP_PERIODIC) {
        double period = aux[HX_A_PERIOD], start = aux[HX_A_START], below, half, k, k_lo, k_hi;
        double tv = aux[HX_A_TMIN] + period * floor((q->px - aux[HX_A_TMIN]) / period + 0.5);
        dphi(q, tv, &f, &g, &gp);
        s->work++;
        bound(s, tv, f);
        /* beyond half of px every boundary point is farther than the best: its height is >= hmin */
        below = fmax(aux[HX_A_HMIN] - q->pz, 0.0);
        half = sqrt(fmax(s->f - below * below, 0.0)) * (1.0 + 1e-9);
        k_lo = floor((q->px - half - start) / period);
        k_hi = floor((q->px + half - start) / period);
        for (k = k_lo; k <= k_hi; k += 1.0)
            descend(q, start + k * period, aux[HX_A_TREELEN], nl, 1, s);
    } else if (mode == HX_CP_FINITE) {
        dphi(q, aux[HX_A_TMIN], &f, &g, &gp);
        s->work++;
        bound(s, aux[HX_A_TMIN], f);
        ray(q, aux[HX_A_X0], aux[HX_A_HL], aux[HX_A_SL], 1, s);
        ray(q, aux[HX_A_XE], aux[HX_A_HR], aux[HX_A_SR], 0, s);
        descend(q, aux[HX_A_START], aux[HX_A_TREELEN], nl, 1, s);
    } else { /* HX_CP_OPEN: an aperiodic sum, searched on a window capped at A_WCAP */
        double below = fmax(aux[HX_A_HMIN] - q->pz, 0.0);
        double half = fmin(sqrt(fmax(s->f - below * below, 0.0)) * (1.0 + 1e-9), aux[HX_A_WCAP]);
        double leaf = 8.0 * aux[HX_A_STEP];
        int64_t n = 1; /* up to 2^40 leaves: 64 bits on every target (long has 32 on LLP64 and Cortex-M) */
        while ((double)n * leaf < 2.0 * half && n < ((int64_t)1 << 40))
            n *= 2;
        descend(q, q->px - 0.5 * (double)n * leaf, (double)n * leaf, n, 0, s);
    }
}

/* ---- the cell table: a servo tick's search in a few evaluations (periodic profiles) ---- */

/* Table layout from aux[HX_A_TABLE] (haptex.closest.table_search_data): the header T_*, then
 * per cell (row-major, x fastest) the index in aux of its first piece and its number of
 * pieces (-1: search the tree), then the pieces (lo, hi, kind, m, G): lo and hi relative to
 * the start of the cell's period (m); on a convex piece a lower bound m of g' and an upper
 * bound G of |g''| over it for every probe of the cell. */
enum { T_X0 = HX_TB_X0, T_PERIOD = HX_TB_PERIOD, T_W = HX_TB_W, T_NX = HX_TB_NX, T_Z0 = HX_TB_Z0, T_NZ = HX_TB_NZ,
       T_CELLS = HX_TB_CELLS };
enum { PIECE = HX_PIECE, TABLE_FINE = 8, TABLE_TOP = 32, TABLE_MAXP = HX_TABLE_MAXP };
#define PIECE_NEWTON 0.0
#define PIECE_SCAN 1.0

/* the minimum of phi over [lo, hi] where g' >= m > 0 and |g''| <= G: Newton from t0 inside a
 * bracket, an end evaluated only when a step leaves the piece; its error certified below
 * 1e-15 (1 + |t|) m, or the step itself that small */
static void convex_min(const problem *q, double lo, double hi, double m, double G, double t0, search *s,
                       double *t_out, double *f_out)
{
    double a = lo, b = hi, t = fmin(fmax(t0, lo), hi), f, g, gp;
    int a_known = 0, b_known = 0, it;
    long work = 0;
    for (it = 0; it < 64; it++) {
        hx_height e;
        double dz, tn, err;
        hx__texture_eval(q->tex, t, 0.0, &e);
        dz = e.h - q->pz;
        g = (t - q->px) + dz * e.gx;
        gp = 1.0 + e.gx * e.gx + dz * e.hxx;
        work++;
        if (g > 0.0) {
            b = t;
            b_known = 1;
        } else {
            a = t;
            a_known = 1;
        }
        tn = gp > 0.0 ? t - g / gp : 0.5 * (a + b);
        err = g / m;
        if (lo <= tn && tn <= hi &&
            (G / (2.0 * gp) * err * err <= 1e-15 * (1.0 + fabs(t)) || fabs(tn - t) <= 1e-15 * (1.0 + fabs(t)))) {
            double u = tn - t; /* h(tn) by Taylor: its error, A_JERK |u|^3 / 6, is far below rounding */
            s->work += work;
            dz = e.h + u * (e.gx + 0.5 * u * e.hxx) - q->pz;
            *t_out = tn;
            *f_out = (tn - q->px) * (tn - q->px) + dz * dz;
            return;
        }
        if (tn <= a || tn >= b) {
            if (tn <= a && !a_known) { /* the minimum may be the piece's left end */
                double fa, ga, gpa;
                dphi(q, lo, &fa, &ga, &gpa);
                work++;
                if (ga >= 0.0) {
                    s->work += work;
                    *t_out = lo;
                    *f_out = fa;
                    return;
                }
                a_known = 1;
            } else if (tn >= b && !b_known) {
                double fb, gb, gpb;
                dphi(q, hi, &fb, &gb, &gpb);
                work++;
                if (gb <= 0.0) {
                    s->work += work;
                    *t_out = hi;
                    *f_out = fb;
                    return;
                }
                b_known = 1;
            }
            tn = 0.5 * (a + b);
        }
        t = tn;
        if (b - a <= 1e-16 * (1.0 + fabs(t)))
            break;
    }
    t = fmin(fmax(t, lo), hi);
    dphi(q, t, &f, &g, &gp);
    s->work += work + 1;
    *t_out = t;
    *f_out = f;
}

/* the closest point from the cell table: minimise phi on each of the cell's pieces and
 * offer each minimum; 0, with nothing done, when the probe is outside the table or its cell
 * has too many pieces (the caller then searches the tree) */
static int table_search(const problem *q, double t_guess, search *s)
{
    const double *aux = q->aux;
    long o = (long)aux[HX_A_TABLE], nx = (long)aux[o + T_NX], ix, c, n, first, k;
    double w = aux[o + T_W], jz = floor((q->pz - aux[o + T_Z0]) / w), period, base, u, guess, sep;
    if (!(jz >= 0.0 && jz < aux[o + T_NZ]))
        return 0;
    period = aux[o + T_PERIOD];
    base = aux[o + T_X0] + period * floor((q->px - aux[o + T_X0]) / period);
    u = (q->px - base) / w;
    ix = u > 0.0 ? (u < (double)(nx - 1) ? (long)u : nx - 1) : 0;
    c = o + T_CELLS + 2 * ((long)jz * nx + ix);
    n = (long)aux[c + 1];
    if (n < 0)
        return 0;
    first = (long)aux[c];
    guess = t_guess == t_guess ? t_guess : q->px;
    sep = w / TABLE_FINE;
    for (k = 0; k < n; k++) {
        long p = first + PIECE * k;
        double lo = base + aux[p], hi = base + aux[p + 1];
        if (aux[p + 2] == PIECE_NEWTON) {
            double t, f;
            convex_min(q, lo, hi, aux[p + 3], aux[p + 4], guess, s, &t, &f);
            offer(s, t, f, sep);
        } else {
            scan_leaf(q, lo, hi - lo, s);
        }
    }
    return 1;
}

/* the table's layout against the array: every cell's pieces inside it */
static int table_check(const double *aux, long naux)
{
    double off = aux[HX_A_TABLE], nx, nz;
    long o, cells, i;
    if (off == 0.0)
        return HX_OK;
    if (!(off >= HX_A_TREE && off == floor(off) && off + T_CELLS <= (double)naux) || aux[HX_A_MODE] != HX_CP_PERIODIC)
        return HX_BAD_COEFFS;
    o = (long)off;
    nx = aux[o + T_NX];
    nz = aux[o + T_NZ];
    if (!(nx >= 1.0 && nz >= 1.0 && nx == floor(nx) && nz == floor(nz) && nx * nz <= 1e8) || !(aux[o + T_W] > 0.0) ||
        !(aux[o + T_PERIOD] > 0.0) || !isfinite(aux[o + T_X0]) || !isfinite(aux[o + T_Z0]))
        return HX_BAD_COEFFS;
    cells = (long)nx * (long)nz;
    if ((double)o + T_CELLS + 2.0 * (double)cells > (double)naux)
        return HX_BAD_COEFFS;
    for (i = 0; i < cells; i++) {
        double first = aux[o + T_CELLS + 2 * i], n = aux[o + T_CELLS + 2 * i + 1];
        if (n < 0.0)
            continue;
        if (!(n == floor(n) && first == floor(first) && first >= 0.0 && first + PIECE * n <= (double)naux))
            return HX_BAD_COEFFS;
    }
    return HX_OK;
}

int hx_closest_aux_check(const double *aux, long naux)
{
    double mode, nl, leafc;
    if (aux == NULL || naux < HX_A_TREE)
        return HX_BAD_COEFFS;
    mode = aux[HX_A_MODE];
    if (!(mode == HX_CP_VERTICAL || mode == HX_CP_PERIODIC || mode == HX_CP_FINITE || mode == HX_CP_OPEN))
        return HX_BAD_COEFFS;
    if (mode == HX_CP_VERTICAL)
        return HX_OK;
    if (!(aux[HX_A_STEP] > 0.0) || !isfinite(aux[HX_A_TIE]) || !isfinite(aux[HX_A_SLOPE]))
        return HX_BAD_COEFFS;
    if (mode == HX_CP_OPEN)
        return isfinite(aux[HX_A_WCAP]) && aux[HX_A_WCAP] >= 0.0 ? HX_OK : HX_BAD_COEFFS;
    nl = aux[HX_A_NLEAF];
    if (!(nl >= 1.0 && nl <= (double)(1L << 22) && nl == floor(nl)) || (double)naux < HX_A_TREE + 4.0 * nl)
        return HX_BAD_COEFFS;
    leafc = aux[HX_A_LEAFC]; /* the leaves' bounds of h'': after the tree, inside the array */
    if (leafc != 0.0 && !(leafc >= HX_A_TREE + 4.0 * nl && leafc == floor(leafc) && leafc + 2.0 * nl <= (double)naux))
        return HX_BAD_COEFFS;
    if (!(aux[HX_A_TREELEN] > 0.0) || !isfinite(aux[HX_A_START]) ||
        (mode == HX_CP_PERIODIC && !(aux[HX_A_PERIOD] > 0.0 && isfinite(aux[HX_A_PERIOD]))))
        return HX_BAD_COEFFS;
    return table_check(aux, naux);
}

hx_closest hx_closest_profile(const hx_texture *tex, const double *aux, double px, double pz, double dv,
                              double t_guess)
{
    hx_closest out;
    search s;
    problem q;
    int mode = (int)aux[HX_A_MODE];
    out.t = px;
    out.y = 0.0;
    out.distance = 0.0;
    out.tie = 0;
    out.work = 1;
    out.cut = 0;
    if (!(dv > 0.0))
        return out;
    out.distance = dv;
    if (mode == HX_CP_VERTICAL) /* flat: the vertical point is the closest */
        return out;
    s.f = dv * dv;
    s.t = px;
    s.second = HUGE_VAL;
    s.found = 0;
    s.work = 1;
    q.tex = tex;
    q.aux = aux;
    q.px = px;
    q.pz = pz;
    if (aux[HX_A_TABLE] == 0.0 || !table_search(&q, t_guess, &s))
        tree_search(&q, t_guess, mode, &s);
    out.t = s.t;
    out.distance = sqrt(s.f);
    out.tie = s.second < HUGE_VAL && sqrt(s.second) - sqrt(s.f) <= fmin(aux[HX_A_TIE], 1e-9 * sqrt(s.f));
    out.work = s.work;
    return out;
}

/* ---- the builders of the search data (haptex.closest) ---------------------------------- */

/* min over u in [0, s] of h + d1 u + d2 u^2 / 2 - jerk u^3 / 6: a lower bound of a function with
 * value h, slope d1 and curvature d2 at u = 0 and |third derivative| <= jerk */
static double cubic_floor(double h, double d1, double d2, double jerk, double s)
{
    double best = fmin(h, h + s * (d1 + s * (0.5 * d2 - s * jerk / 6.0))), disc;
    int k;
    if (!(jerk > 0.0))
        return best;
    disc = d2 * d2 + 2.0 * jerk * d1;
    if (disc < 0.0)
        return best;
    for (k = 0; k < 2; k++) {
        double u = (d2 + (k ? -1.0 : 1.0) * sqrt(disc)) / jerk;
        if (0.0 < u && u < s)
            best = fmin(best, h + u * (d1 + u * (0.5 * d2 - u * jerk / 6.0)));
    }
    return best;
}

double hx_leaf_bounds(const hx_texture *tex, double start, double width, long n_leaf, long n_sub, double jerk,
                      double *lo, double *hi, double *best_h)
{
    double s = width / (double)n_sub, best_t = start;
    long i, k;
    *best_h = HUGE_VAL;
    for (i = 0; i < n_leaf; i++) {
        double u = start + (double)i * width, l, m;
        hx_height e0, e1;
        hx__texture_eval(tex, u, 0.0, &e0);
        l = m = e0.h;
        if (e0.h < *best_h) {
            *best_h = e0.h;
            best_t = u;
        }
        for (k = 1; k <= n_sub; k++) {
            double t1 = u + (double)k * s;
            hx__texture_eval(tex, t1, 0.0, &e1);
            l = fmin(l, e1.h);
            m = fmax(m, e1.h);
            if (e1.h < *best_h) {
                *best_h = e1.h;
                best_t = t1;
            }
            if ((e0.gx < 0.0) != (e1.gx < 0.0)) { /* an extremum inside: bracketed Newton on h' */
                double a = t1 - s, b = t1, t = 0.5 * (a + b), he;
                int neg_at_a = e0.gx < 0.0, it;
                for (it = 0; it < 80; it++) {
                    hx_height e;
                    double tn;
                    hx__texture_eval(tex, t, 0.0, &e);
                    if ((e.gx < 0.0) == neg_at_a)
                        a = t;
                    else
                        b = t;
                    tn = e.hxx != 0.0 ? t - e.gx / e.hxx : 0.5 * (a + b);
                    if (!(fmin(a, b) < tn && tn < fmax(a, b)))
                        tn = 0.5 * (a + b);
                    if (fabs(tn - t) <= 1e-16 * (1.0 + fabs(t))) {
                        t = tn;
                        break;
                    }
                    t = tn;
                }
                he = hx__texture_height(tex, t, 0.0);
                l = fmin(l, he);
                m = fmax(m, he);
                if (he < *best_h) {
                    *best_h = he;
                    best_t = t;
                }
            } else { /* monotone: the larger of the two cubic floors from the ends */
                double fl = fmax(cubic_floor(e0.h, e0.gx, e0.hxx, jerk, s), cubic_floor(e1.h, -e1.gx, e1.hxx, jerk, s));
                double ce = -fmax(cubic_floor(-e0.h, -e0.gx, -e0.hxx, jerk, s),
                                  cubic_floor(-e1.h, e1.gx, -e1.hxx, jerk, s));
                l = fmin(l, fl);
                m = fmax(m, ce);
            }
            e0 = e1;
        }
        lo[i] = l;
        hi[i] = m;
    }
    return best_t;
}

/* one entry of a cell's depth-first stack: level, index, then (d, h, h', h'') at both ends */
typedef struct {
    int lev;
    long idx;
    double d[2], h[2], s[2], c[2];
} tb_entry;

long hx_table_cell(const hx_texture *tex, const double *aux, double x0, double w, double cx, double zlo, double zhi,
                   double *row)
{
    enum { MAX_LEVELS = 24 }; /* 32 << 24 intervals: the indices fit a 32-bit long (LLP64); past it the
                                  * finest intervals stay wider than w / TABLE_FINE and are scanned */
    tb_entry stk[TABLE_TOP + MAX_LEVELS + 2];
    double S = aux[HX_A_SLOPE], C = aux[HX_A_CURV], J = aux[HX_A_JERK], L = sqrt(1.0 + S * S);
    double r = 0.5 * w * sqrt(2.0) * (1.0 + 1e-9) + 1e-9 * w, cz = 0.5 * (zlo + zhi);
    double hc = hx__texture_height(tex, cx, 0.0), period = aux[HX_A_PERIOD], tmin = aux[HX_A_TMIN];
    double U, tv, reach, R, dt, cur = -1.0;
    long npc = 0, last = -2, k;
    int nlev = 0, sp = 0;
    if (zlo > hc + S * 0.5 * w + 1e-9 * w) /* the whole cell is above the boundary: no probe of it searches */
        return 0;
    U = fabs(hc - cz);
    tv = tmin + period * floor((cx - tmin) / period + 0.5);
    U = fmin(U, hypot(tv - cx, hx__texture_height(tex, tv, 0.0) - cz));
    if (cz < hc) { /* the centre's own distance, from the bound tree */
        hx_closest c = hx_closest_profile(tex, aux, cx, cz, hc - cz, NAN);
        U = fmin(U, c.distance);
    } else { /* the best of a few boundary points */
        for (k = 0; k <= TABLE_TOP; k++) {
            double t = cx - U + 2.0 * U * (double)k / TABLE_TOP;
            U = fmin(U, hypot(t - cx, hx__texture_height(tex, t, 0.0) - cz));
        }
    }
    reach = U + 2.0 * r;
    R = reach;
    /* dyadic intervals of the window [cx - R, cx + R]: TABLE_TOP at level 0, the finest (at most
     * w / TABLE_FINE wide) at level nlev; interval (l, i) covers the finest ones i 2^(nlev - l) to
     * (i + 1) 2^(nlev - l) - 1, of width dt each */
    while (nlev < MAX_LEVELS && 2.0 * R / ((double)TABLE_TOP * ldexp(1.0, nlev)) > w / TABLE_FINE)
        nlev++;
    dt = 2.0 * R / ((double)TABLE_TOP * ldexp(1.0, nlev));
    { /* the top level, pushed right to left so that the leftmost is popped first */
        hx_height eb;
        double db, hb, sb, cb;
        hx__texture_eval(tex, cx + R, 0.0, &eb);
        db = hypot(R, eb.h - cz), hb = eb.h, sb = eb.gx, cb = eb.hxx;
        for (k = TABLE_TOP - 1; k >= 0; k--) {
            hx_height ea;
            double ta = cx - R + (double)(k << nlev) * dt, da;
            tb_entry *e = &stk[sp++];
            hx__texture_eval(tex, ta, 0.0, &ea);
            da = hypot(ta - cx, ea.h - cz);
            e->lev = 0;
            e->idx = k;
            e->d[0] = da, e->h[0] = ea.h, e->s[0] = ea.gx, e->c[0] = ea.hxx;
            e->d[1] = db, e->h[1] = hb, e->s[1] = sb, e->c[1] = cb;
            db = da, hb = ea.h, sb = ea.gx, cb = ea.hxx;
        }
    }
    while (sp > 0) {
        tb_entry *e = &stk[--sp];
        long span = 1L << (nlev - e->lev), first;
        double width = (double)span * dt, qa0, qa1, qb0, qb1, G, qmin, cls, ta, tb;
        if (0.5 * (e->d[0] + e->d[1] - L * width) > reach) /* no point of it within reach of the centre */
            continue;
        /* classified at most a cell wide (wider, the bounds m and G of a piece would be loose) */
        qa0 = 1.0 + e->s[0] * e->s[0] + (e->h[0] - zlo) * e->c[0];
        qa1 = 1.0 + e->s[0] * e->s[0] + (e->h[0] - zhi) * e->c[0];
        qb0 = 1.0 + e->s[1] * e->s[1] + (e->h[1] - zlo) * e->c[1];
        qb1 = 1.0 + e->s[1] * e->s[1] + (e->h[1] - zhi) * e->c[1];
        G = 3.0 * S * C + (fmax(fabs(e->h[0] - zlo), fabs(e->h[0] - zhi)) + S * width) * J;
        qmin = 0.5 * (fmin(qa0, qa1) + fmin(qb0, qb1) - G * width);
        if (width <= w && qmin > 0.0) {
            cls = PIECE_NEWTON;
        } else if (width <= w && 0.5 * (fmax(qa0, qa1) + fmax(qb0, qb1) + G * width) < 0.0) {
            continue; /* strictly concave: no minimum inside; its ends belong to its neighbours */
        } else if (e->lev < nlev) { /* undecided or too wide: split at the midpoint */
            double tm = cx - R + (double)(2 * e->idx + 1) * (double)(span / 2) * dt, dm;
            hx_height em;
            tb_entry *f = &stk[sp + 1];
            hx__texture_eval(tex, tm, 0.0, &em);
            dm = hypot(tm - cx, em.h - cz);
            *f = *e; /* the left half, on top: popped first */
            f->lev = e->lev + 1;
            f->idx = 2 * e->idx;
            f->d[1] = dm, f->h[1] = em.h, f->s[1] = em.gx, f->c[1] = em.hxx;
            e->lev = e->lev + 1;
            e->idx = 2 * e->idx + 1;
            e->d[0] = dm, e->h[0] = em.h, e->s[0] = em.gx, e->c[0] = em.hxx;
            sp += 2;
            continue;
        } else {
            cls = PIECE_SCAN;
        }
        first = e->idx * span;
        ta = cx - R + (double)first * dt;
        tb = cx - R + (double)(first + span) * dt;
        if (cls == cur && first == last + 1) { /* extend the open piece */
            double *q = row + PIECE * (npc - 1);
            q[1] = tb - x0;
            q[3] = fmin(q[3], qmin);
            q[4] = fmax(q[4], G);
        } else {
            double *q;
            npc++;
            if (npc > TABLE_MAXP) /* too many: the cell's probes search the tree */
                return npc;
            q = row + PIECE * (npc - 1);
            q[0] = ta - x0;
            q[1] = tb - x0;
            q[2] = cls;
            q[3] = qmin;
            q[4] = G;
            cur = cls;
        }
        last = first + span - 1;
    }
    return npc;
}
