/*
 * The closest point on a surface z = h(x, y) to a probe below it (D and E over a sum of
 * gratings or a height map's bicubic patches): Newton where phi / 2 is certified strongly
 * convex on the whole plane, else a branch and bound over a quadtree of the square around
 * the probe, cells pruned by box bounds of h, and over gratings by a Taylor bound of phi and
 * a basin disc around the best stationary point (rigorous bounds of |grad h|, ||H|| and the
 * third derivatives kept in aux). phi(t) = |t - p_xy|^2 + (h(t) - p_z)^2. The result over
 * gratings and over a periodic height map is certified global to G_TIE in distance; over a
 * map with edges, cells wholly inside it are searched with the same Taylor bounds (the bicubic
 * spline is C^2 there, with the patches' rigorous bounds in aux), while cells reaching past an
 * edge (where the tangent-plane extension is only C^1) are searched to leaves of one sample
 * interval refined by projected Newton (not certified). A branched cell of a felt map (the
 * largest of several patches, HX_JOINS_BRANCHED) is searched whole, once its piece lies within
 * it, along its creases (branched_piece: not certified). Work is bounded (at most MAX_NODES
 * cells by the model, MAX_LEAVES leaves, STACK pending cells) and counted.
 */
#include "hx_core.h"
#include "hx_texture_eval.h"

#include <math.h>
#include <stddef.h>

enum { STACK = 512, MAX_LEAVES = 1 << 16, MAX_NODES = 1 << 11, CONVEX_EVALS = HX_CONVEX_EVALS };
#define CONVEX_MIN HX_CONVEX_MIN
#define M_PI_VALUE 3.14159265358979323846

enum { PY_MAX_LEVELS = 40, PY_SPAN = 2 };

/* fmax and fmin as C99 defines them (a NaN argument yields the other; on a tie these return the
 * second, the same value but for a zero's sign, which nothing here reads), inlined: without
 * -ffinite-math-only GCC calls libm's for each, 2-7 % of the search's time (perf, 2026-11-29) */
static inline double max2(double a, double b) { return (a > b || isnan(b)) ? a : b; }
static inline double min2(double a, double b) { return (a < b || isnan(b)) ? a : b; }

/* i wrapped into [0, n) (a periodic map's cell), without a division where it is there already */
static long wrap_index(long i, long n)
{
    long r;
    if (i >= 0 && i < n)
        return i;
    r = i % n;
    return r < 0 ? r + n : r;
}

/* a height map's bounds pyramid (HX_PY_*): its data, the level offsets in it; levels 0: none */
typedef struct {
    const double *d;
    long nx, ny, shift, levels, off[PY_MAX_LEVELS];
    int periodic;
} pyramid_t;

/* the last interval [lo, hi] along each axis whose ends were counted in cells (patch_cells, a
 * bisection of a graded axis's knots), and those counts: a cell's pyramid bounds, patch test and
 * split read the same two intervals (they took half the search's time on a graded felt map) */
typedef struct {
    double lo[2], hi[2], f0[2], f1[2];
    int set[2];
} spanmemo;

typedef struct {
    const hx_texture *tex;
    const double *g; /* aux: HX_G_* */
    double px, py, pz;
    pyramid_t pyr;
    const double *branch; /* NULL; else h is this one patch of a branched cell, origin (bx0, by0), widths bw, bh */
    double bx0, by0, bw, bh;
    spanmemo *memo; /* (the search's own, written through the const problem) */
} sproblem;

static long blocks(long n, long k) { return (n + (1L << k) - 1) >> k; }

static long floor_shift(long i, long k) { return i >= 0 ? i >> k : -((-i - 1) >> k) - 1; }

/* the pyramid of aux (checked by hx_surface_aux_check) for this texture's patches, else none */
static void pyramid_init(sproblem *q)
{
    const double *a = q->g + HX_N_GAUX, *c = q->tex->c;
    pyramid_t *P = &q->pyr;
    long l, o = HX_PY_HEAD;
    P->levels = 0;
    P->periodic = 0;
    if (q->tex->kind != HX_SURFACE_PATCHES || !(q->g[HX_G_PYRAMID] > 0.0) || a[HX_PY_NX] != c[HX_PATCH_NX] ||
        a[HX_PY_NY] != c[HX_PATCH_NY])
        return;
    P->d = a;
    P->nx = (long)a[HX_PY_NX];
    P->ny = (long)a[HX_PY_NY];
    P->shift = (long)a[HX_PY_SHIFT];
    P->periodic = c[HX_PATCH_PERIODIC] != 0.0;
    for (l = 0; l < (long)a[HX_PY_LEVELS]; l++) {
        P->off[l] = o;
        o += HX_PY_N * blocks(P->nx, P->shift + l) * blocks(P->ny, P->shift + l);
    }
    P->levels = l;
}

/* the patch indices [*a, *b] the interval [lo, hi] meets along the axis ax of the map hd (n
 * patches): wrapped later if periodic (0 when it covers them all), else clamped; 0 if none. An
 * end within 1e-12 of a sample interval of a patch boundary is taken at it: the bound misses at
 * most slope 1e-12 d of height there, far below the search's tolerance G_TIE = 1e-9 of the
 * shortest wavelength (> 2 d). */
static void span_cells(const sproblem *q, int ax, double lo, double hi, double *f0, double *f1)
{
    spanmemo *m = q->memo;
    if (m->set[ax] && m->lo[ax] == lo && m->hi[ax] == hi) {
        *f0 = m->f0[ax];
        *f1 = m->f1[ax];
        return;
    }
    *f0 = patch_cells(q->tex->c, ax, lo) + 1e-12;
    *f1 = patch_cells(q->tex->c, ax, hi) - 1e-12;
    m->lo[ax] = lo;
    m->hi[ax] = hi;
    m->f0[ax] = *f0;
    m->f1[ax] = *f1;
    m->set[ax] = 1;
}

static int patch_span(const sproblem *q, double lo, double hi, int ax, long n, int periodic, long *a, long *b)
{
    double f0, f1;
    span_cells(q, ax, lo, hi, &f0, &f1);
    if (!(f0 > -1e15 && f1 < 1e15))
        return 0;
    *a = (long)floor(f0);
    *b = (long)ceil(f1) - 1;
    if (*b < *a)
        *b = *a;
    if (periodic)
        return *b - *a + 1 < n;
    *a = *a < 0 ? 0 : (*a > n - 1 ? n - 1 : *a);
    *b = *b < 0 ? 0 : (*b > n - 1 ? n - 1 : *b);
    return 1;
}

/* Rigorous bounds (HX_PY_*) over the cell [cx -+ wx] x [cy -+ wy] from the pyramid's blocks
 * that cover it (the finest level where it meets at most PY_SPAN + 1 a side); 0 where there is
 * no pyramid, the cell covers a periodic map's whole period or a block read is not a bound (the
 * global bounds then). A cell of
 * a non-periodic map must lie inside the map (its patches clamped). */
static int pyramid_bounds(const sproblem *q, double cx, double cy, double wx, double wy, double v[HX_PY_N])
{
    const pyramid_t *P = &q->pyr;
    long ia, ib, ja, jb, l, k, nby, i, j;
    if (P->levels == 0 ||
        !patch_span(q, cx - wx, cx + wx, 0, P->nx, P->periodic, &ia, &ib) ||
        !patch_span(q, cy - wy, cy + wy, 1, P->ny, P->periodic, &ja, &jb))
        return 0;
    for (l = 0; l < P->levels; l++) {
        k = P->shift + l;
        if (floor_shift(ib, k) - floor_shift(ia, k) <= PY_SPAN && floor_shift(jb, k) - floor_shift(ja, k) <= PY_SPAN)
            break;
    }
    if (l == P->levels)
        return 0;
    k = P->shift + l;
    nby = blocks(P->ny, k);
    v[HX_PY_HMIN] = HUGE_VAL;
    v[HX_PY_HMAX] = v[HX_PY_SLOPE] = v[HX_PY_CURV] = v[HX_PY_JERK] = -HUGE_VAL;
    for (i = ia; i <= ib;) {
        long wi = P->periodic ? wrap_index(i, P->nx) : i, bi = wi >> k;
        for (j = ja; j <= jb;) {
            long wj = P->periodic ? wrap_index(j, P->ny) : j, bj = wj >> k, m;
            const double *b = P->d + P->off[l] + HX_PY_N * (bi * nby + bj);
            if (!(b[HX_PY_HMIN] <= b[HX_PY_HMAX] && b[HX_PY_SLOPE] >= 0.0 && b[HX_PY_CURV] >= 0.0 &&
                  b[HX_PY_JERK] >= 0.0))
                return 0; /* (a block that is not a bound, NaN included: the global bounds) */
            v[HX_PY_HMIN] = min2(v[HX_PY_HMIN], b[HX_PY_HMIN]);
            for (m = HX_PY_HMAX; m < HX_PY_N; m++)
                v[m] = max2(v[m], b[m]);
            j += (((bj + 1) << k) < P->ny ? ((bj + 1) << k) : P->ny) - wj;
        }
        i += (((bi + 1) << k) < P->nx ? ((bi + 1) << k) : P->nx) - wi;
    }
    return 1;
}

/* h's derivatives at (x, y) on the patch c of the cell whose origin is (ox, oy) and widths w, v
 * (the patch's polynomial, wherever (x, y) lies) */
static void branch_at(const double *c, double ox, double oy, double w, double v, double x, double y, hx_height *e)
{
    double D[4][4];
    patch_poly(c, (x - ox) / w, (y - oy) / v, w, v, 2, D);
    patch_height(D, e);
}

static void surf(const sproblem *q, double x, double y, hx_height *e)
{
    if (q->branch != NULL)
        branch_at(q->branch, q->bx0, q->by0, q->bw, q->bh, x, y, e);
    else
        hx__frame_eval(q->tex, x, y, e);
}

/* phi(t) at t = (tx, ty) with h's derivatives there in *e, h(t) - p_z in *dz and grad phi / 2
 * in (*g0, *g1) */
static double phi_at(const sproblem *q, double tx, double ty, hx_height *e, double *dz, double *g0, double *g1)
{
    surf(q, tx, ty, e);
    *dz = e->h - q->pz;
    *g0 = (tx - q->px) + *dz * e->gx;
    *g1 = (ty - q->py) + *dz * e->gy;
    return (tx - q->px) * (tx - q->px) + (ty - q->py) * (ty - q->py) + *dz * *dz;
}

/* a height map's sampled rectangle [b[0], b[2]] x [b[1], b[3]] (its patch header) */
static void map_box(const hx_texture *t, double b[4])
{
    b[0] = t->c[0];
    b[1] = t->c[1];
    b[2] = patch_at(t->c, 0, t->c[HX_PATCH_NX]);
    b[3] = patch_at(t->c, 1, t->c[HX_PATCH_NY]);
}

/* how far the rectangle [cx -+ wx] x [cy -+ wy] reaches beyond the map's box b (0 inside) */
static double beyond_box(const double b[4], double cx, double cy, double wx, double wy)
{
    double ox = max2(0.0, max2(b[0] - (cx - wx), (cx + wx) - b[2]));
    double oy = max2(0.0, max2(b[1] - (cy - wy), (cy + wy) - b[3]));
    return sqrt(ox * ox + oy * oy);
}

/* (min h, max h) over a cell [cx -+ wx] x [cy -+ wy] of a height map, and in *beyond how far the
 * cell reaches past a non-periodic map's edges (0 inside): from pr, the pyramid's bounds over
 * the patches the cell's footprint clamped to the map meets, where it has them, else from the
 * map's range and slope. Beyond the edges the map goes on as its edge's tangent plane, whose
 * value at a point is the value at the point clamped to the map (in those patches) plus its
 * normal slope (at most their slope bound) times the distance beyond. */
static void patch_range(const sproblem *q, double cx, double cy, double wx, double wy, const double *pr,
                        double *lo, double *hi, double *beyond)
{
    const double *g = q->g;
    double box[4], slope = pr != NULL ? pr[HX_PY_SLOPE] : g[HX_G_SLOPE];
    *lo = pr != NULL ? pr[HX_PY_HMIN] : g[HX_G_HMIN];
    *hi = pr != NULL ? pr[HX_PY_HMAX] : g[HX_G_HMAX];
    *beyond = 0.0;
    if (q->tex->c[6] != 0.0)
        return;
    map_box(q->tex, box);
    *beyond = beyond_box(box, cx, cy, wx, wy);
    *lo -= *beyond * slope;
    *hi += *beyond * slope;
}

/* the distance from (cx, cy) inward to the edge of a non-periodic height map (negative
 * outside it); HUGE_VAL where the surface's Taylor model holds everywhere (gratings, a
 * periodic map). Outside a non-periodic map the tangent-plane extension is only C^1 and its
 * curvature grows with the distance, so the model's bounds (G_JERK, G_CURV_BOUND) hold only on
 * discs and squares wholly inside. */
static double model_margin(const sproblem *q, double cx, double cy)
{
    double b[4];
    if (q->tex->kind != HX_SURFACE_PATCHES || q->tex->c[6] != 0.0)
        return HUGE_VAL;
    map_box(q->tex, b);
    return min2(min2(cx - b[0], b[2] - cx), min2(cy - b[1], b[3] - cy));
}

/* a height map joined only continuously across its patch lines (HX_PATCH_JOINS: a Hermite map
 * whose slopes jump there): its Taylor model holds on a cell within one patch, not across */
static int joined(const sproblem *q) { return q->tex->kind == HX_SURFACE_PATCHES && q->tex->c[HX_PATCH_JOINS] != 0.0; }

/* the patch line along axis ax of the map hd (the patch grid continued beyond a map's edges)
 * strictly inside [lo, hi] nearest its middle in cells, NAN where [lo, hi] lies within one patch
 * (its ends within 1e-12 of a cell of a line taken at it, as patch_span) */
static double patch_line(const sproblem *q, double lo, double hi, int ax)
{
    double f0, f1, m;
    span_cells(q, ax, lo, hi, &f0, &f1);
    if (!(f0 > -1e15 && f1 < 1e15) || floor(f0) + 1.0 >= f1)
        return NAN;
    m = min2(max2(floor(0.5 * (f0 + f1) + 0.5), floor(f0) + 1.0), ceil(f1) - 1.0);
    return patch_at(q->tex->c, ax, m);
}

/* whether the patch holding (x, y) (clamped to the map, wrapped if periodic) is a branched
 * cell (HX_JOINS_BRANCHED: a maximum of patches, with creases inside); 0 on any other map */
static int branched_at(const sproblem *q, double x, double y)
{
    const double *hd = q->tex->c, *pp[HX_MAX_BRANCHES];
    long i, j;
    double s, t, cx, cy, w, v;
    int clamped;
    if (q->tex->kind != HX_SURFACE_PATCHES || hd[HX_PATCH_JOINS] != (double)HX_JOINS_BRANCHED)
        return 0;
    if (!(isfinite(x) && isfinite(y)))
        return 1;
    patch_locate(hd, x, y, &i, &j, &s, &t, &cx, &cy, &clamped, &w, &v);
    return cell_branches(hd, (long)hd[HX_PATCH_NX], (long)hd[HX_PATCH_NY], i, j, pp) > 1;
}

/* whether the cell [cx -+ wx] x [cy -+ wy] of a height map crosses none of its patch lines */
static int one_patch(const sproblem *q, double cx, double cy, double wx, double wy)
{
    return isnan(patch_line(q, cx - wx, cx + wx, 0)) && isnan(patch_line(q, cy - wy, cy + wy, 1));
}

/* whether the Taylor model may hold on the cell [cx -+ wx] x [cy -+ wy]: within one patch of a
 * joined map, and that patch not branched (always, for any other surface) */
static int within_patch(const sproblem *q, double cx, double cy, double wx, double wy)
{
    if (!joined(q))
        return 1;
    return one_patch(q, cx, cy, wx, wy) && !branched_at(q, cx, cy);
}

/* the distance from (x, y) to the nearest patch line of a joined map (HUGE_VAL for any other
 * surface): a disc of that radius lies within the point's patch; 0 in a branched patch */
static double patch_room(const sproblem *q, double x, double y)
{
    const double *hd = q->tex->c;
    double u, v, iu, iv;
    if (!joined(q))
        return HUGE_VAL;
    if (branched_at(q, x, y))
        return 0.0;
    u = patch_cells(hd, 0, x);
    v = patch_cells(hd, 1, y);
    iu = floor(u);
    iv = floor(v);
    u -= iu;
    v -= iv;
    return min2(min2(u, 1.0 - u) * patch_width(hd, 0, iu), min2(v, 1.0 - v) * patch_width(hd, 1, iv));
}

/* The half-width of the square around the probe that holds every point closer than d: a
 * point at lateral distance rho must have rho^2 + (h - p_z)^2 < d^2, and h >= G_HMIN over
 * gratings and a map; beyond a map's edges its tangent-plane extension descends at most at
 * the edges' normal slope B (aux[HX_G_EDGE...]) over the distance beyond, which is at most
 * rho - m (m the probe's distance inside the map, negative beyond it): h - p_z >= below0 -
 * B max(0, rho - m),
 * below0 = G_HMIN - p_z. The largest rho that allows it (a convex quadratic in rho once past
 * m, rho alone once the bound is spent). bf = d^2. */
static double root_half(const sproblem *q, double bf)
{
    const double *hd = q->tex->c, *g = q->g;
    double below0 = g[HX_G_HMIN] - q->pz, r0, d, m, bx, by, B, c, disc, best, r2;
    r0 = sqrt(max2(bf - max2(below0, 0.0) * max2(below0, 0.0), 0.0));
    if (q->tex->kind != HX_SURFACE_PATCHES || hd[6] != 0.0 || below0 <= 0.0)
        return r0;
    bx = max2(g[HX_G_EDGE + HX_E_N], g[HX_G_EDGE + HX_N_E + HX_E_N]);
    by = max2(g[HX_G_EDGE + 2 * HX_N_E + HX_E_N], g[HX_G_EDGE + 3 * HX_N_E + HX_E_N]);
    B = hypot(bx, by); /* (a corner's plane descends at most at hypot of the two) */
    if (!(B > 0.0))
        return r0;
    d = sqrt(bf);
    m = model_margin(q, q->px, q->py);
    if (m < 0.0) { /* a probe beyond the map: m = minus its distance from it */
        double box[4];
        map_box(q->tex, box);
        m = -beyond_box(box, q->px, q->py, 0.0, 0.0);
    }
    best = max2(0.0, min2(r0, m));
    /* past m: (1 + B^2) rho^2 - 2 B c rho + c^2 - d^2 <= 0, c = below0 + B m, while rho <= m + below0 / B */
    c = below0 + B * m;
    disc = bf * (1.0 + B * B) - c * c;
    if (disc >= 0.0) {
        r2 = (B * c + sqrt(disc)) / (1.0 + B * B);
        if (r2 >= max2(m, 0.0))
            best = max2(best, min2(r2, m + below0 / B));
    }
    if (m + below0 / B <= d) /* beyond that the bound is spent: rho < d */
        best = d;
    return best;
}

/* where [lo, hi] lies against the interval [a, b]: 0 inside, 1 below a, 2 above b, -1 across an
 * end (by more than rounding: a piece cut at an end, its centre and half-width recomputed, may
 * reach past it by an ulp) */
static int side(double lo, double hi, double a, double b)
{
    double tol = 1e-12 * (fabs(lo) + fabs(hi));
    if (lo >= a - tol && hi <= b + tol)
        return 0;
    if (hi <= a + tol)
        return 1;
    if (lo >= b - tol)
        return 2;
    return -1;
}

/* The Taylor model's bounds on the cell [cx -+ wx] x [cy -+ wy]: sup |grad h| in *sb, sup
 * ||H||_2 in *cb and the third derivatives' norm in *jk. Over gratings and a periodic map the
 * global bounds (aux), or the pyramid's pv where the cell has one. Over a map with edges, by
 * region: inside, the patches' bounds (the pyramid's where it has one); in an
 * edge's strip, where h = H(t) + G(t) e (e the distance beyond the edge, t along it), the
 * strip's bounds at the cell's largest e (aux[HX_G_EDGE...], HX_E_*); in a corner's quadrant a
 * plane. Returns 0 for a cell across an edge's line, where the extension is only C^1 (no
 * model: the caller splits it there). */
static int cell_bounds(const sproblem *q, double cx, double cy, double wx, double wy, const double *pv,
                       const double *pr, double *sb, double *cb, double *jk)
{
    const double *g = q->g, *E;
    double b[4], x0, y0, x1, y1, e, t, tt, j3;
    int rx, ry;
    if (pv != NULL) { /* a cell inside the map (or periodic): its blocks' bounds */
        *sb = pv[HX_PY_SLOPE];
        *cb = pv[HX_PY_CURV];
        *jk = max2(pv[HX_PY_JERK], 1e-300); /* (as aux's: on the Taylor bounds' path) */
        return 1;
    }
    *sb = g[HX_G_SLOPE_BOUND];
    *cb = g[HX_G_CURV_BOUND];
    *jk = g[HX_G_JERK];
    if (q->tex->kind != HX_SURFACE_PATCHES || q->tex->c[6] != 0.0)
        return 1;
    map_box(q->tex, b);
    x0 = b[0];
    y0 = b[1];
    x1 = b[2];
    y1 = b[3];
    rx = side(cx - wx, cx + wx, x0, x1);
    ry = side(cy - wy, cy + wy, y0, y1);
    if (rx < 0 || ry < 0)
        return 0;
    if (rx == 0 && ry == 0)
        return 1;
    if (rx > 0 && ry > 0) { /* a corner: the plane of the corner's tangent */
        *sb = hypot(g[HX_G_EDGE + (rx - 1) * HX_N_E + HX_E_N], g[HX_G_EDGE + (1 + ry) * HX_N_E + HX_E_N]);
        if (pr != NULL) /* (its gradient is the corner patch's there) */
            *sb = min2(*sb, pr[HX_PY_SLOPE]);
        *cb = *jk = 0.0;
        return 1;
    }
    if (rx > 0) {
        E = g + HX_G_EDGE + (rx - 1) * HX_N_E;
        e = rx == 1 ? x0 - (cx - wx) : (cx + wx) - x1;
    } else {
        E = g + HX_G_EDGE + (1 + ry) * HX_N_E;
        e = ry == 1 ? y0 - (cy - wy) : (cy + wy) - y1;
    }
    {
        /* the edge's derivatives on the cell's stretch of it: the whole edge's (E), or those of
         * the patches along that stretch (pr: their slope bounds the first derivatives, their
         * curvature the second, their jerk the third; the fourth, d^4 h / dn dt^3, from E) */
        double n1 = E[HX_E_N], t1 = E[HX_E_T], nt = E[HX_E_NT], t2 = E[HX_E_TT], nt2 = E[HX_E_NTT];
        double t3 = E[HX_E_TTT];
        if (pr != NULL) {
            n1 = min2(n1, pr[HX_PY_SLOPE]);
            t1 = min2(t1, pr[HX_PY_SLOPE]);
            nt = min2(nt, pr[HX_PY_CURV]);
            t2 = min2(t2, pr[HX_PY_CURV]);
            nt2 = min2(nt2, pr[HX_PY_JERK]);
            t3 = min2(t3, pr[HX_PY_JERK]);
        }
        t = t1 + nt * e;
        tt = t2 + nt2 * e;
        j3 = t3 + E[HX_E_NTTT] * e;
        *sb = hypot(n1, t);
        *cb = 0.5 * tt + sqrt(0.25 * tt * tt + nt * nt);
        *jk = sqrt(3.0 * nt2 * nt2 + j3 * j3);
    }
    return 1;
}

/* Add grating a sin(phase)'s exact range over a cell to [*lo, *hi]: the phase at the cell's
 * centre has sine sn and cosine cs and moves by at most delta over the cell (cd, sd: delta's
 * cosine and sine). For delta < pi, sin(phase -+ delta) by the angle sums, and a crest within
 * delta of the phase when the distance to it, whose cosine is sn, is at most delta (a trough
 * likewise with -sn). */
static void grating_piece(double a, double sn, double cs, double delta, double cd, double sd, double *lo, double *hi)
{
    double s0, s1, tlo, thi;
    if (delta >= M_PI_VALUE) {
        *lo -= fabs(a);
        *hi += fabs(a);
        return;
    }
    s0 = sn * cd - cs * sd;
    s1 = sn * cd + cs * sd;
    tlo = min2(s0, s1);
    thi = max2(s0, s1);
    if (sn >= cd)
        thi = 1.0;
    if (-sn >= cd)
        tlo = -1.0;
    *lo += a >= 0.0 ? a * tlo : a * thi;
    *hi += a >= 0.0 ? a * thi : a * tlo;
}

/* rigorous (min h, max h) over the square cell: each grating's exact range, summed */
static void grating_range(const sproblem *q, double cx, double cy, double w, double *lo_out, double *hi_out)
{
    const hx_texture *t = q->tex;
    long i, n = t->cols;
    double lo = 0.0, hi = 0.0;
    for (i = 0; i < n; i++) {
        double kx = t->c[n + i], ky = t->c[2 * n + i], arg = kx * cx + ky * cy + t->c[3 * n + i];
        double delta = w * (fabs(kx) + fabs(ky));
        grating_piece(t->c[i], sin(arg), cos(arg), delta, cos(delta), sin(delta), &lo, &hi);
    }
    *lo_out = lo;
    *hi_out = hi;
}

/* A sum of at most ROT_GRATINGS gratings is searched without a sine or cosine a cell: a cell's
 * sines and cosines of the gratings' phases at its centre come from its parent's by the
 * angle-sum formulas (the quadtree's cells are squares, a child's centre its parent's moved by
 * (+-w, +-w), w the child's half-width, so a phase moves by w (+-k_x +- k_y)), and each
 * grating's range over the cell from them and the sine and cosine of w (|k_x| + |k_y|). The
 * search is depth first, so the pending cells of one depth are the children of the last cell
 * split one depth up: rot_t keeps that cell for each depth, and each depth's steps (their sines
 * and cosines, computed once a search). A chain of rotations from the root, which is evaluated,
 * adds a few units of rounding a depth: measured against sin and cos of the phase computed at
 * each cell's centre, at most 9.4e-14 over the benchmarks' stroke on the paper's egg-crate
 * (20,000 ticks, 13 depths, phases to 125 rad, where a unit of the phase's own rounding is
 * 1.4e-14) and 4.0e-14 over 4,000 random probes of each of five sums of gratings; in h, at most
 * 4.0e-17 m, against a tie tolerance G_TIE of 1e-9 of the shortest wavelength (7e-13 m there).
 * The distances found there were those of the search that evaluated every cell (and started
 * from the vertical point's square) to 5.2e-18 m; the points too, but where two are tied
 * within G_TIE (the stroke runs on the diagonal, a mirror line of the egg-crate, where either
 * of two is the closest). */
enum { ROT_GRATINGS = 4, ROT_LEVELS = 64 };

typedef struct {
    int on;
    double w[ROT_LEVELS];                     /* the depth's half-width; 0: its steps not yet computed */
    double step[ROT_LEVELS][ROT_GRATINGS][6]; /* cos, sin of w (k_x + k_y), w (k_x - k_y), w (|k_x| + |k_y|) */
    double sc[ROT_LEVELS][2 * ROT_GRATINGS];  /* the last cell split at the depth: sin, cos at its centre */
    double cx[ROT_LEVELS], cy[ROT_LEVELS];
    int split[ROT_LEVELS];                    /* whether a cell was split at the depth */
} rot_t;

/* the cell at depth L < ROT_LEVELS (half-width w, centre (cx, cy)): h and its derivatives at the
 * centre in *e and the phases' sines and cosines in sc, from its parent's where it has one (else
 * evaluated: the root) */
static void rot_cell(const sproblem *q, rot_t *R, int L, double cx, double cy, double w, hx_height *e, double *sc)
{
    const hx_texture *t = q->tex;
    long i, n = t->cols;
    e->h = e->gx = e->gy = e->hxx = e->hxy = e->hyy = 0.0;
    if (R->w[L] != w) {
        for (i = 0; i < n; i++) {
            double kx = AT(t, 1, i), ky = AT(t, 2, i), *st = R->step[L][i];
            st[0] = cos(w * (kx + ky));
            st[1] = sin(w * (kx + ky));
            st[2] = cos(w * (kx - ky));
            st[3] = sin(w * (kx - ky));
            st[4] = cos(w * (fabs(kx) + fabs(ky)));
            st[5] = sin(w * (fabs(kx) + fabs(ky)));
        }
        R->w[L] = w;
    }
    if (L > 0 && R->split[L - 1]) {
        const double *p = R->sc[L - 1];
        double sx = cx > R->cx[L - 1] ? 1.0 : -1.0, sy = cy > R->cy[L - 1] ? 1.0 : -1.0;
        for (i = 0; i < n; i++) {
            const double *st = R->step[L][i];
            double c = sx == sy ? st[0] : st[2], s = sx * (sx == sy ? st[1] : st[3]);
            sc[2 * i] = p[2 * i] * c + p[2 * i + 1] * s;
            sc[2 * i + 1] = p[2 * i + 1] * c - p[2 * i] * s;
            hx__grating_add(t, i, sc[2 * i], sc[2 * i + 1], e);
        }
        return;
    }
    for (i = 0; i < n; i++) {
        double arg = AT(t, 1, i) * cx + AT(t, 2, i) * cy + AT(t, 3, i);
        sc[2 * i] = sin(arg);
        sc[2 * i + 1] = cos(arg);
        hx__grating_add(t, i, sc[2 * i], sc[2 * i + 1], e);
    }
}

/* (min h, max h) over the square cell at depth L from its phases' sines and cosines sc at its
 * centre: each grating's exact range (grating_piece), summed, as grating_range */
static void rot_range(const hx_texture *t, const rot_t *R, int L, const double *sc, double *lo_out, double *hi_out)
{
    long i, n = t->cols;
    double lo = 0.0, hi = 0.0;
    for (i = 0; i < n; i++) {
        const double *st = R->step[L][i];
        grating_piece(AT(t, 0, i), sc[2 * i], sc[2 * i + 1], R->w[L] * (fabs(AT(t, 1, i)) + fabs(AT(t, 2, i))), st[4],
                      st[5], &lo, &hi);
    }
    *lo_out = lo;
    *hi_out = hi;
}

/* projected Newton on phi / 2 from (tx, ty), kept in the cell [x0, x1] x [y0, y1] and
 * monotone (a step that raises phi beyond its rounding, with a smaller gradient, is halved
 * from the last point that did not); where the Hessian Q of phi / 2 is not positive definite
 * the step solves (Q + mu I) s = -grad with Q's least eigenvalue mirrored, at most a quarter
 * of the cell long. At most 40 evaluations. The last accepted point; stationary when
 * |grad phi / 2| <= 1e-9 sqrt(phi) there. */
typedef struct {
    double tx, ty, f;
    long it;
    int stationary;
} newton_out;

static newton_out surf_newton(const sproblem *q, double tx, double ty, double x0, double x1, double y0, double y1)
{
    double ox = tx, oy = ty, of = HUGE_VAL, og = HUGE_VAL, sx = 0.0, sy = 0.0;
    long it = 0;
    newton_out out;
    for (it = 1; it <= 40; it++) {
        hx_height e;
        double dz, f, g0, g1, gn, a, b, c, det, nx, ny;
        f = phi_at(q, tx, ty, &e, &dz, &g0, &g1);
        gn = sqrt(g0 * g0 + g1 * g1);
        if (!(f <= of || (f <= of * (1.0 + 1e-12) && gn < og))) {
            sx *= 0.5;
            sy *= 0.5;
            if (fabs(sx) <= 1e-15 * (1.0 + fabs(ox)) && fabs(sy) <= 1e-15 * (1.0 + fabs(oy)))
                break;
            tx = min2(max2(ox + sx, x0), x1);
            ty = min2(max2(oy + sy, y0), y1);
            continue;
        }
        ox = tx;
        oy = ty;
        of = f;
        og = gn;
        a = 1.0 + e.gx * e.gx + dz * e.hxx;
        b = e.gx * e.gy + dz * e.hxy;
        c = 1.0 + e.gy * e.gy + dz * e.hyy;
        det = a * c - b * b;
        if (a > 0.0 && det > 0.0) {
            sx = -(c * g0 - b * g1) / det;
            sy = -(a * g1 - b * g0) / det;
        } else { /* not convex here: Newton on Q + mu I, its least eigenvalue mirrored */
            double lam, mu, cap;
            if (og == 0.0)
                break;
            lam = 0.5 * (a + c) - sqrt(0.25 * (a - c) * (a - c) + b * b);
            mu = max2(-2.0 * lam, 1e-6 * (fabs(a) + fabs(c)) + 1e-300);
            a += mu;
            c += mu;
            det = a * c - b * b;
            sx = -(c * g0 - b * g1) / det;
            sy = -(a * g1 - b * g0) / det;
            cap = 0.25 * min2(x1 - x0, y1 - y0) / (sqrt(sx * sx + sy * sy) + 1e-300);
            if (cap < 1.0) {
                sx *= cap;
                sy *= cap;
            }
        }
        nx = min2(max2(tx + sx, x0), x1);
        ny = min2(max2(ty + sy, y0), y1);
        sx = nx - tx;
        sy = ny - ty;
        if (fabs(sx) <= 1e-15 * (1.0 + fabs(tx)) && fabs(sy) <= 1e-15 * (1.0 + fabs(ty)))
            break;
        tx = nx;
        ty = ny;
    }
    if (it > 40)
        it = 40;
    out.tx = ox;
    out.ty = oy;
    out.f = of;
    out.it = it;
    out.stationary = og <= 1e-9 * sqrt(of) + 1e-300;
    return out;
}

/* min over s in [-w, w] of g s + a s^2 / 2, and its argmin */
static double edge_qp(double g, double a, double w, double *s_out)
{
    if (a > 0.0 && fabs(g) < a * w) {
        double s = -g / a;
        *s_out = s;
        return 0.5 * g * s;
    }
    *s_out = g > 0.0 ? -w : w;
    return 0.5 * a * w * w - fabs(g) * w;
}

/* the exact minimum over the box |u_x| <= wx, |u_y| <= wy of g.u + u^T [[a, b], [b, c]] u / 2 */
static double box_qp(double g0, double g1, double a, double b, double c, double wx, double wy, double *ux,
                     double *uy)
{
    double det = a * c - b * b, best = HUGE_VAL, bx = 0.0, by = 0.0;
    int k;
    if (a > 0.0 && det > 0.0) {
        double sx = -(c * g0 - b * g1) / det, sy = -(a * g1 - b * g0) / det;
        if (fabs(sx) <= wx && fabs(sy) <= wy) {
            *ux = sx;
            *uy = sy;
            return 0.5 * (g0 * sx + g1 * sy);
        }
    }
    for (k = 0; k < 2; k++) {
        double sgn = k == 0 ? -1.0 : 1.0, s, v;
        v = edge_qp(g1 + b * sgn * wx, c, wy, &s); /* the edge u_x = sgn wx */
        v += sgn * wx * g0 + 0.5 * a * wx * wx;
        if (v < best) {
            best = v;
            bx = sgn * wx;
            by = s;
        }
        v = edge_qp(g0 + b * sgn * wy, a, wx, &s); /* the edge u_y = sgn wy */
        v += sgn * wy * g1 + 0.5 * c * wy * wy;
        if (v < best) {
            best = v;
            bx = s;
            by = sgn * wy;
        }
    }
    *ux = bx;
    *uy = by;
    return best;
}

/* the closest point by Newton, certified by global strong convexity of phi / 2 (its Hessian's
 * least eigenvalue >= 1 - E C everywhere, E bounding |h - pz| and C = G_CONVEX ||H||_2) */
static int convex_closest(const sproblem *q, double tx, double ty, double *tx_out, double *ty_out, double *f_out,
                          long *ev_out)
{
    const double *g = q->g;
    double cb = g[HX_G_CONVEX], e_max = max2(g[HX_G_HMAX] - q->pz, q->pz - g[HX_G_HMIN]), m = 1.0 - e_max * cb;
    double dz, f, g0, g1, gn;
    long ev = 1;
    hx_height e;
    *ev_out = 0;
    if (cb <= 0.0 || !(m >= CONVEX_MIN))
        return 0;
    if (!(isfinite(tx) && isfinite(ty))) {
        tx = q->px;
        ty = q->py;
    }
    f = phi_at(q, tx, ty, &e, &dz, &g0, &g1);
    gn = sqrt(g0 * g0 + g1 * g1);
    while (ev < CONVEX_EVALS) {
        double a, b, c, det, sx, sy;
        int moved = 0;
        if (gn <= 1e-15 * (1.0 + hypot(tx, ty)) * m) {
            *tx_out = tx;
            *ty_out = ty;
            *f_out = f;
            *ev_out = ev;
            return 1;
        }
        a = 1.0 + e.gx * e.gx + dz * e.hxx;
        b = e.gx * e.gy + dz * e.hxy;
        c = 1.0 + e.gy * e.gy + dz * e.hyy;
        det = a * c - b * b;
        sx = -(c * g0 - b * g1) / det;
        sy = -(a * g1 - b * g0) / det;
        while (ev < CONVEX_EVALS) {
            double nx = tx + sx, ny = ty + sy, fn, gm, ndz, ng0, ng1;
            hx_height en;
            fn = phi_at(q, nx, ny, &en, &ndz, &ng0, &ng1);
            ev++;
            gm = sqrt(ng0 * ng0 + ng1 * ng1);
            if (fn <= f || gm < gn) {
                tx = nx;
                ty = ny;
                f = fn;
                gn = gm;
                e = en;
                dz = ndz;
                g0 = ng0;
                g1 = ng1;
                moved = 1;
                break;
            }
            sx *= 0.5;
            sy *= 0.5;
        }
        if (!moved)
            break;
    }
    *tx_out = tx;
    *ty_out = ty;
    *f_out = f;
    *ev_out = ev;
    return 0;
}

/* the search's best point, its runner-up (for ties on the medial axis) */
typedef struct {
    double bf, btx, bty, second;
    int found;
} best_t;

/* a candidate (tx, ty) with phi = f: the new best, or the runner-up kept for ties (a
 * stationary point farther than sep from a stationary best) */
static void offer_point(best_t *b, double tx, double ty, double f, int stationary, double sep)
{
    int far = (tx - b->btx) * (tx - b->btx) + (ty - b->bty) * (ty - b->bty) > sep * sep;
    if (f < b->bf) {
        if (b->found && b->bf < b->second && far)
            b->second = b->bf;
        b->bf = f;
        b->btx = tx;
        b->bty = ty;
        b->found = stationary;
        return;
    }
    if (stationary && !far && f <= b->bf * (1.0 + 1e-12))
        b->found = 1; /* the best's own local minimum, equal to rounding */
    else if (stationary && b->found && f < b->second && far)
        b->second = f;
}

/* the distance a cell (centre c, half-diagonal r) must come within to be searched */
static double cell_reach(int model, const best_t *b, double cx, double cy, double r, double sep, double tie,
                         int *far_out)
{
    double d = sqrt(b->bf);
    int far = !model || (b->second > (d + tie) * (d + tie) &&
                         (cx - b->btx) * (cx - b->btx) + (cy - b->bty) * (cy - b->bty) > (sep + r) * (sep + r));
    *far_out = far;
    return far ? d + tie : max2(d - tie, 0.0);
}

/* radius of a disc around the best point on which phi >= (sqrt(f) - G_TIE)^2 (the search's
 * goal) by the Taylor bound with the cubic remainder; 0 where none is certified */
static double basin_radius(const sproblem *q, double tx, double ty, double f)
{
    const double *g = q->g;
    double jerk = g[HX_G_JERK], cb = g[HX_G_CURV_BOUND], sb = g[HX_G_SLOPE_BOUND], tie = g[HX_G_TIE];
    double dz, a, b, c, lam, gn, tol, hn, sn, l0, rho, room, cap = HUGE_VAL, pv[HX_PY_N];
    int k;
    hx_height e;
    surf(q, tx, ty, &e);
    dz = e.h - q->pz;
    a = 1.0 + e.gx * e.gx + dz * e.hxx;
    b = e.gx * e.gy + dz * e.hxy;
    c = 1.0 + e.gy * e.gy + dz * e.hyy;
    lam = 0.5 * (a + c) - hypot(0.5 * (a - c), b);
    gn = hypot((tx - q->px) + dz * e.gx, (ty - q->py) + dz * e.gy);
    tol = sqrt(f) * tie - 0.5 * tie * tie;
    if (!(jerk > 0.0 && tol > 0.0 && isfinite(lam)))
        return 0.0;
    hn = 0.5 * fabs(e.hxx + e.hyy) + hypot(0.5 * (e.hxx - e.hyy), e.hxy);
    sn = hypot(e.gx, e.gy);
    room = patch_room(q, tx, ty); /* (a joined map: the disc within the best point's patch) */
    if (!(room > 0.0))
        return 0.0;
    l0 = 3.0 * sn * hn + fabs(dz) * jerk + 1e-300;
    rho = max2(3.0 * max2(lam, 0.0) / l0, pow(6.0 * tol / l0, 1.0 / 3.0));
    /* the pyramid's bounds on a square of 4 such radii around t (inside the map): the disc is
     * then sought within it, from its own jerk */
    if (q->pyr.levels > 0 && (q->pyr.periodic || model_margin(q, tx, ty) >= 4.0 * rho) &&
        pyramid_bounds(q, tx, ty, 4.0 * rho, 4.0 * rho, pv)) {
        cap = 4.0 * rho;
        jerk = max2(pv[HX_PY_JERK], 1e-300);
        cb = pv[HX_PY_CURV];
        sb = pv[HX_PY_SLOPE];
        l0 = 3.0 * sn * hn + fabs(dz) * jerk + 1e-300;
        rho = min2(cap, max2(3.0 * max2(lam, 0.0) / l0, pow(6.0 * tol / l0, 1.0 / 3.0)));
    }
    rho = min2(rho, room);
    for (k = 0; k < 60; k++) {
        double cl = min2(cb, hn + jerk * rho), sl = min2(sb, sn + cl * rho);
        double lip = 3.0 * sl * cl + (fabs(dz) + sl * rho) * jerk;
        if (gn * rho + max2(0.0, rho * rho * (lip * rho / 6.0 - 0.5 * lam)) <= tol)
            return rho;
        rho *= 0.75;
    }
    return 0.0;
}

/* phi at (tx, ty) on the map itself (a branched cell's highest patch), offered as a candidate */
static void offer_map_point(const sproblem *q, best_t *b, double tx, double ty, int stationary, double sep)
{
    hx_height e;
    double dz, g0, g1, f = phi_at(q, tx, ty, &e, &dz, &g0, &g1);
    offer_point(b, tx, ty, f, stationary, sep);
}

/* The closest point in a piece [x0, x1] x [y0, y1] of one branched cell, where h is the
 * largest of n <= HX_MAX_BRANCHES smooth patches f_a, so phi has creases where two are equal:
 * each patch's own projected Newton (surf_newton on phi_a) from the piece's point nearest the
 * probe and from its centre; then on each pair's crease f_a = f_b sequential quadratic steps
 * on phi_a / 2 (its Hessian as surf_newton's, mirrored where not positive definite; the crease
 * linearised), from either patch's point; then where three patches meet (a bowl's apex) Newton
 * on f_a = f_b = f_c. Every point reached is a candidate with its phi on the map itself: the
 * least is offered. Not certified (a local search, as a leaf's); bounded: at most
 * 2 n 40 + 2 C(n, 2) 30 + C(n, 3) 20 evaluation pairs. Returns the evaluations spent. */
static long branched_piece(const sproblem *q, double x0, double x1, double y0, double y1, best_t *b, double sep)
{
    const double *hd = q->tex->c, *pp[HX_MAX_BRANCHES];
    double dx, dy, s, t, cx, cy, ox, oy, pts[HX_MAX_BRANCHES][2];
    double mx = 0.5 * (x0 + x1), my = 0.5 * (y0 + y1), room = min2(x1 - x0, y1 - y0);
    long i, j, work = 0;
    int clamped, n, a, c, d, k, it;
    sproblem one = *q;
    patch_locate(hd, mx, my, &i, &j, &s, &t, &cx, &cy, &clamped, &dx, &dy);
    n = cell_branches(hd, (long)hd[HX_PATCH_NX], (long)hd[HX_PATCH_NY], i, j, pp);
    ox = mx - s * dx; /* the cell's origin in the piece's own period */
    oy = my - t * dy;
    one.branch = NULL;
    one.bx0 = ox;
    one.by0 = oy;
    one.bw = dx;
    one.bh = dy;
    for (a = 0; a < n; a++) {
        double bf = HUGE_VAL;
        one.branch = pp[a];
        for (k = 0; k < 2; k++) {
            double sx = k == 0 ? min2(max2(q->px, x0), x1) : mx, sy = k == 0 ? min2(max2(q->py, y0), y1) : my;
            newton_out r = surf_newton(&one, sx, sy, x0, x1, y0, y1);
            work += r.it + 1;
            offer_map_point(q, b, r.tx, r.ty, 0, sep);
            if (r.f < bf) {
                bf = r.f;
                pts[a][0] = r.tx;
                pts[a][1] = r.ty;
            }
        }
    }
    for (a = 0; a < n; a++)
        for (c = a + 1; c < n; c++)
            for (k = 0; k < 2; k++) { /* the crease f_a = f_c: min phi_a / 2 subject to g = f_a - f_c = 0 */
                double tx = pts[k == 0 ? a : c][0], ty = pts[k == 0 ? a : c][1];
                for (it = 0; it < 30; it++) {
                    hx_height ea, ec;
                    double dz, g, nx_, ny_, g0, g1, A, B, C, lam, mu, det, h0, h1, u0, u1, nn, ng, step_x, step_y;
                    branch_at(pp[a], ox, oy, dx, dy, tx, ty, &ea);
                    branch_at(pp[c], ox, oy, dx, dy, tx, ty, &ec);
                    work += 2;
                    dz = ea.h - q->pz;
                    g = ea.h - ec.h;
                    nx_ = ea.gx - ec.gx;
                    ny_ = ea.gy - ec.gy;
                    g0 = (tx - q->px) + dz * ea.gx;
                    g1 = (ty - q->py) + dz * ea.gy;
                    A = 1.0 + ea.gx * ea.gx + dz * ea.hxx;
                    B = ea.gx * ea.gy + dz * ea.hxy;
                    C = 1.0 + ea.gy * ea.gy + dz * ea.hyy;
                    lam = 0.5 * (A + C) - sqrt(0.25 * (A - C) * (A - C) + B * B);
                    if (!(lam > 1e-9 * (fabs(A) + fabs(C)))) {
                        mu = max2(-2.0 * lam, 1e-6 * (fabs(A) + fabs(C)) + 1e-300);
                        A += mu;
                        C += mu;
                    }
                    det = A * C - B * B;
                    if (!(det > 0.0) || !(nx_ * nx_ + ny_ * ny_ > 0.0))
                        break;
                    /* H^-1 grad and H^-1 n: step = -H^-1 (grad + mu n), n . step = -g */
                    h0 = (C * g0 - B * g1) / det;
                    h1 = (A * g1 - B * g0) / det;
                    u0 = (C * nx_ - B * ny_) / det;
                    u1 = (A * ny_ - B * nx_) / det;
                    nn = nx_ * u0 + ny_ * u1;
                    ng = nx_ * h0 + ny_ * h1;
                    mu = (g - ng) / nn;
                    step_x = -(h0 + mu * u0);
                    step_y = -(h1 + mu * u1);
                    {
                        double len = sqrt(step_x * step_x + step_y * step_y), cap = 0.5 * room / (len + 1e-300);
                        double nxt = min2(max2(tx + (cap < 1.0 ? cap : 1.0) * step_x, x0), x1);
                        double nyt = min2(max2(ty + (cap < 1.0 ? cap : 1.0) * step_y, y0), y1);
                        int done = fabs(nxt - tx) <= 1e-13 * room && fabs(nyt - ty) <= 1e-13 * room;
                        tx = nxt;
                        ty = nyt;
                        if (done)
                            break;
                    }
                }
                offer_map_point(q, b, tx, ty, 0, sep);
                work++;
            }
    for (a = 0; a < n; a++) /* where three meet: f_a = f_c = f_d */
        for (c = a + 1; c < n; c++)
            for (d = c + 1; d < n; d++) {
                double tx = mx, ty = my;
                for (it = 0; it < 20; it++) {
                    hx_height ea, ec, ed;
                    double r0, r1, j00, j01, j10, j11, det, sx, sy, nxt, nyt;
                    branch_at(pp[a], ox, oy, dx, dy, tx, ty, &ea);
                    branch_at(pp[c], ox, oy, dx, dy, tx, ty, &ec);
                    branch_at(pp[d], ox, oy, dx, dy, tx, ty, &ed);
                    work += 3;
                    r0 = ea.h - ec.h;
                    r1 = ea.h - ed.h;
                    j00 = ea.gx - ec.gx;
                    j01 = ea.gy - ec.gy;
                    j10 = ea.gx - ed.gx;
                    j11 = ea.gy - ed.gy;
                    det = j00 * j11 - j01 * j10;
                    if (!(fabs(det) > 0.0))
                        break;
                    sx = -(j11 * r0 - j01 * r1) / det;
                    sy = -(j00 * r1 - j10 * r0) / det;
                    nxt = min2(max2(tx + sx, x0), x1);
                    nyt = min2(max2(ty + sy, y0), y1);
                    if (fabs(nxt - tx) <= 1e-13 * room && fabs(nyt - ty) <= 1e-13 * room)
                        break;
                    tx = nxt;
                    ty = nyt;
                }
                offer_map_point(q, b, tx, ty, 0, sep);
                work++;
            }
    return work;
}

/* The children of the cell [cx -+ wx] x [cy -+ wy] into out (4 values each: centre, half-widths),
 * their number returned: its quadrants, or its halves across the longer side when one side is
 * over twice the other (a cell cut at a map's edge); the child holding p_xy last (popped first). */
static int split_cell(double cx, double cy, double wx, double wy, double px, double py, double *out)
{
    int nx = wy > 2.0 * wx ? 1 : 2, ny = wx > 2.0 * wy ? 1 : 2, i, j, n = 0, last = -1;
    double hx = nx == 2 ? 0.5 * wx : wx, hy = ny == 2 ? 0.5 * wy : wy;
    for (j = 0; j < ny; j++)
        for (i = 0; i < nx; i++) {
            double qx = nx == 2 ? cx + (i ? hx : -hx) : cx, qy = ny == 2 ? cy + (j ? hy : -hy) : cy;
            if ((nx == 1 || (qx > cx) == (px > cx)) && (ny == 1 || (qy > cy) == (py > cy))) {
                last = 2 * i + j;
                continue;
            }
            out[4 * n] = qx;
            out[4 * n + 1] = qy;
            out[4 * n + 2] = hx;
            out[4 * n + 3] = hy;
            n++;
        }
    if (last >= 0) {
        out[4 * n] = nx == 2 ? cx + ((last >> 1) ? hx : -hx) : cx;
        out[4 * n + 1] = ny == 2 ? cy + ((last & 1) ? hy : -hy) : cy;
        out[4 * n + 2] = hx;
        out[4 * n + 3] = hy;
        n++;
    }
    return n;
}

/* the cut of [lo, hi] at the first of a, b inside it (by more than rounding, as side()): the
 * pieces' bounds in cut[], their number (1: no cut) */
static int cut_at(double lo, double hi, double a, double b, double *cut)
{
    double tol = 1e-12 * (fabs(lo) + fabs(hi));
    double c = lo < a - tol && a + tol < hi ? a : (lo < b - tol && b + tol < hi ? b : NAN);
    cut[0] = lo;
    if (isnan(c)) {
        cut[1] = hi;
        return 1;
    }
    cut[1] = c;
    cut[2] = hi;
    return 2;
}

/* The pieces of a cell across a non-periodic map's edge lines, cut there (each then on one
 * side of that line), or else across a joined map's patch lines, cut at the one nearest its
 * middle along each axis, into out; their number. */
static int split_at_edges(const sproblem *q, double cx, double cy, double wx, double wy, double *out)
{
    double b[4], xs[3], ys[3];
    int nx = 1, ny = 1, i, j, n = 0;
    if (q->tex->c[HX_PATCH_PERIODIC] == 0.0) {
        map_box(q->tex, b);
        nx = cut_at(cx - wx, cx + wx, b[0], b[2], xs);
        ny = cut_at(cy - wy, cy + wy, b[1], b[3], ys);
    }
    if (nx == 1 && ny == 1 && joined(q)) { /* then a joined map's patch lines, nearest the middle */
        double lx = patch_line(q, cx - wx, cx + wx, 0);
        double ly = patch_line(q, cy - wy, cy + wy, 1);
        nx = cut_at(cx - wx, cx + wx, lx, NAN, xs);
        ny = cut_at(cy - wy, cy + wy, ly, NAN, ys);
    }
    if (nx == 1 && ny == 1) /* (nothing to cut at: quadrants) */
        return split_cell(cx, cy, wx, wy, q->px, q->py, out);
    for (i = 0; i < nx; i++)
        for (j = 0; j < ny; j++) {
            out[4 * n] = 0.5 * (xs[i] + xs[i + 1]);
            out[4 * n + 1] = 0.5 * (ys[j] + ys[j + 1]);
            out[4 * n + 2] = 0.5 * (xs[i + 1] - xs[i]);
            out[4 * n + 3] = 0.5 * (ys[j + 1] - ys[j]);
            n++;
        }
    return n;
}

/* the bounds pyramid after aux's constants: its header and its size against naux, in O(levels)
 * (a search checks each block it reads: see pyramid_bounds) */
static int pyramid_check(const double *aux, long naux)
{
    double n = aux[HX_G_PYRAMID], size = HX_PY_HEAD;
    const double *a = aux + HX_N_GAUX;
    long l;
    int i;
    if (n == 0.0)
        return HX_OK;
    if (!(n >= HX_PY_HEAD && n == floor(n) && (double)HX_N_GAUX + n <= (double)naux))
        return HX_BAD_COEFFS;
    for (i = 0; i < HX_PY_HEAD; i++)
        if (!(a[i] == floor(a[i]) && a[i] >= 0.0 && a[i] <= 1e9))
            return HX_BAD_COEFFS;
    if (!(a[HX_PY_NX] >= 1.0 && a[HX_PY_NY] >= 1.0 && a[HX_PY_SHIFT] <= 30.0 && a[HX_PY_LEVELS] >= 1.0 &&
          a[HX_PY_LEVELS] <= PY_MAX_LEVELS))
        return HX_BAD_COEFFS;
    for (l = 0; l < (long)a[HX_PY_LEVELS]; l++) {
        long k = (long)a[HX_PY_SHIFT] + l;
        if (k > 40)
            return HX_BAD_COEFFS;
        size += (double)HX_PY_N * (double)blocks((long)a[HX_PY_NX], k) * (double)blocks((long)a[HX_PY_NY], k);
    }
    return size == n ? HX_OK : HX_BAD_COEFFS;
}

int hx_surface_aux_check(const double *aux, long naux)
{
    int i;
    if (aux == NULL || naux < HX_N_GAUX)
        return HX_BAD_COEFFS;
    for (i = 0; i < HX_N_GAUX; i++)
        if (!isfinite(aux[i]))
            return HX_BAD_COEFFS;
    if (!(aux[HX_G_LEAF] > 0.0) || !(aux[HX_G_TIE] >= 0.0) || aux[HX_G_HMIN] > aux[HX_G_HMAX] ||
        !(aux[HX_G_BUDGET] >= 0.0))
        return HX_BAD_COEFFS;
    return pyramid_check(aux, naux);
}

/* the search in the surface's own frame (a turned map's: hx__frame_eval) */
static hx_closest closest_in_frame(const hx_texture *tex, const double *aux, double px, double py, double pz,
                                   double gx0, double gy0)
{
    sproblem q;
    spanmemo memo;
    hx_closest out;
    best_t b;
    hx_height e0;
    double dv, tx, ty, f, leaf, sep, tie_eps, half, x0, x1, y0, y1, cb, jerk, sb;
    double rb = 0.0, rbx = NAN, rby = NAN, stack[4 * STACK], d;
    long work, ev, leaves = 0, nodes = 0;
    int guess, start, model, ranged, sp, depth[STACK];
    rot_t rot;
    q.tex = tex;
    q.g = aux;
    q.px = px;
    q.py = py;
    q.pz = pz;
    q.pyr.levels = 0;
    q.pyr.periodic = 0;
    q.branch = NULL;
    q.bx0 = q.by0 = 0.0;
    q.bw = q.bh = 1.0;
    memo.set[0] = memo.set[1] = 0;
    q.memo = &memo;
    surf(&q, px, py, &e0);
    dv = e0.h - pz;
    out.t = px;
    out.y = py;
    out.distance = 0.0;
    out.tie = 0;
    out.work = 1;
    out.cut = 0;
    if (dv <= 0.0)
        return out;
    if (convex_closest(&q, gx0, gy0, &tx, &ty, &f, &ev)) {
        out.t = tx;
        out.y = ty;
        out.distance = sqrt(f);
        out.work = 1 + ev;
        return out;
    }
    b.bf = dv * dv;
    b.btx = px;
    b.bty = py;
    b.second = HUGE_VAL;
    b.found = 0;
    work = 1 + ev;
    leaf = aux[HX_G_LEAF];
    sep = 4.0 * leaf;
    tie_eps = aux[HX_G_TIE];
    /* a first upper bound from the local minima nearest the vertical point and the guess */
    half = root_half(&q, b.bf) * (1.0 + 1e-9) + 1e-300;
    x0 = px - half;
    x1 = px + half;
    y0 = py - half;
    y1 = py + half;
    guess = isfinite(gx0) && isfinite(gy0) && fabs(gx0 - px) < half && fabs(gy0 - py) < half;
    for (start = 0; start < (guess ? 2 : 1); start++) {
        newton_out n = surf_newton(&q, start == 0 ? px : gx0, start == 0 ? py : gy0, x0, x1, y0, y1);
        work += n.it;
        offer_point(&b, n.tx, n.ty, n.f, n.stationary, sep);
    }
    if (!b.found) { /* Newton may end on the minimum with its iterations spent: certify it stationary */
        newton_out n = surf_newton(&q, b.btx, b.bty, x0, x1, y0, y1);
        work += n.it;
        offer_point(&b, n.tx, n.ty, n.f, n.stationary, sep);
    }
    pyramid_init(&q);
    jerk = aux[HX_G_JERK];
    sb = aux[HX_G_SLOPE_BOUND];
    model = jerk > 0.0;
    cb = aux[HX_G_CURV_BOUND];
    ranged = tex->kind == HX_SURFACE_PATCHES;
    rot.on = tex->kind == HX_SURFACE_GRATINGS && tex->cols <= ROT_GRATINGS;
    if (rot.on) {
        int l;
        for (l = 0; l < ROT_LEVELS; l++) {
            rot.w[l] = 0.0;
            rot.split[l] = 0;
        }
    }
    stack[0] = px;
    stack[1] = py;
    /* the root: the square that holds every point within G_TIE of the best distance found so far
     * (the vertical point's square above, for Newton's box) */
    d = sqrt(b.bf) + tie_eps;
    stack[2] = stack[3] = min2(half, root_half(&q, d * d) * (1.0 + 1e-9) + 1e-300);
    depth[0] = 0;
    sp = 1;
    while (sp > 0) {
        double cx, cy, wx, wy, w, r, spread, lo, hi, dxy, reach, lb = 0.0, ux = 0.0, uy = 0.0;
        double glo = -HUGE_VAL, ghi = HUGE_VAL, beyond = 0.0, sc[2 * ROT_GRATINGS];
        double csb = sb, ccb = cb, cj = jerk, pvb[HX_PY_N];
        const double *pv;
        int far, leafy, cm, kids, have, L, rotated;
        hx_height e;
        if (aux[HX_G_BUDGET] > 0.0 && (double)work >= aux[HX_G_BUDGET]) { /* the budget is spent: the best so far */
            out.cut = 1;
            break;
        }
        sp--;
        cx = stack[4 * sp];
        cy = stack[4 * sp + 1];
        wx = stack[4 * sp + 2];
        wy = stack[4 * sp + 3];
        L = depth[sp];
        rotated = rot.on && L < ROT_LEVELS;
        w = max2(wx, wy);
        r = wx == wy ? wx * sqrt(2.0) : sqrt(wx * wx + wy * wy); /* the half-diagonal */
        if (model && b.found && (b.btx != rbx || b.bty != rby)) {
            double inner = model_margin(&q, b.btx, b.bty);
            rb = inner > 0.0 ? min2(basin_radius(&q, b.btx, b.bty, b.bf), inner) : 0.0;
            rbx = b.btx;
            rby = b.bty;
            work++;
        }
        if (rb > 0.0 && b.btx == rbx && b.bty == rby && sqrt((cx - rbx) * (cx - rbx) + (cy - rby) * (cy - rby)) + r <= rb)
            continue;
        dxy = max2(0.0, fabs(px - cx) - wx) * max2(0.0, fabs(px - cx) - wx) +
              max2(0.0, fabs(py - cy) - wy) * max2(0.0, fabs(py - cy) - wy);
        reach = cell_reach(model, &b, cx, cy, r, sep, tie_eps, &far);
        if (dxy > reach * reach)
            continue; /* too far across alone: no evaluation */
        /* the pyramid's bounds: for the model over a periodic map or a cell wholly inside a map
         * with edges; for the height range over any cell */
        have = ranged && pyramid_bounds(&q, cx, cy, wx, wy, pvb); /* (the footprint clamped to the map) */
        pv = have && (q.pyr.periodic || model_margin(&q, cx, cy) >= w) ? pvb : NULL;
        cm = model && within_patch(&q, cx, cy, wx, wy) &&
             cell_bounds(&q, cx, cy, wx, wy, pv, have ? pvb : NULL, &csb, &ccb, &cj); /* the model holds on this cell */
        if (model && !cm) /* (a cell across a map's edge or a joined map's patch line: counted with */
            nodes++;      /* the model's cells, so bounded) */
        if (ranged) { /* the cell's height range first: a cell too far by it costs no evaluation */
            double gap;
            patch_range(&q, cx, cy, wx, wy, have ? pvb : NULL, &glo, &ghi, &beyond);
            gap = max2(0.0, max2(glo - pz, pz - ghi));
            if (dxy + gap * gap > reach * reach)
                continue;
        }
        if (rotated)
            rot_cell(&q, &rot, L, cx, cy, w, &e, sc);
        else
            surf(&q, cx, cy, &e);
        work++;
        spread = cm ? min2(csb * r, sqrt(e.gx * e.gx + e.gy * e.gy) * r + 0.5 * ccb * r * r)
                    : min2(aux[HX_G_SLOPE] * r, sqrt(e.gx * e.gx + e.gy * e.gy) * r + 0.5 * aux[HX_G_CURV] * r * r);
        if (ranged) {
            /* beyond the map without the model: the extension's bound only */
            if (!cm && beyond > 0.0)
                spread = HUGE_VAL;
            lo = max2(e.h - spread, glo);
            hi = min2(e.h + spread, ghi);
        } else { /* each grating's exact range later, where the cheaper bounds leave the cell */
            lo = e.h - spread;
            hi = e.h + spread;
        }
        {
            double gap = max2(0.0, max2(lo - pz, pz - hi));
            if (dxy + gap * gap > reach * reach)
                continue;
        }
        if (model && !cm && joined(&q) && model_margin(&q, cx, cy) >= w && one_patch(&q, cx, cy, wx, wy) &&
            branched_at(&q, cx, cy)) {
            /* a piece of one branched cell inside the map: searched along its creases, not split */
            work += branched_piece(&q, cx - wx, cx + wx, cy - wy, cy + wy, &b, sep);
            continue;
        }
        if (cm) {
            double dz = e.h - pz, g0 = (cx - px) + dz * e.gx, g1 = (cy - py) + dz * e.gy, qmin, cl, sl;
            nodes++;
            qmin = box_qp(g0, g1, 1.0 + e.gx * e.gx + dz * e.hxx, e.gx * e.gy + dz * e.hxy,
                          1.0 + e.gy * e.gy + dz * e.hyy, wx, wy, &ux, &uy);
            /* sup ||H||_2 and sup |grad h| over the cell, from their values at c */
            cl = min2(ccb, 0.5 * fabs(e.hxx + e.hyy) + sqrt(0.25 * (e.hxx - e.hyy) * (e.hxx - e.hyy) + e.hxy * e.hxy) +
                               cj * r);
            sl = min2(csb, sqrt(e.gx * e.gx + e.gy * e.gy) + cl * r);
            lb = (cx - px) * (cx - px) + (cy - py) * (cy - py) + dz * dz + 2.0 * qmin -
                 (3.0 * sl * cl + (fabs(dz) + sl * r) * cj) * r * r * r / 3.0;
            if (lb > reach * reach)
                continue;
        }
        if (!ranged) {
            double gap;
            if (rotated)
                rot_range(tex, &rot, L, sc, &glo, &ghi);
            else
                grating_range(&q, cx, cy, w, &glo, &ghi);
            gap = max2(0.0, max2(max2(lo, glo) - pz, pz - min2(hi, ghi)));
            if (dxy + gap * gap > reach * reach)
                continue;
        }
        if (cm) {
            /* the model's least point: polished to its local minimum when it is below the best
             * (in a far cell, within G_TIE above it) */
            double sx = cx + ux, sy = cy + uy, ez = hx__frame_height(tex, sx, sy) - pz;
            double fs = (sx - px) * (sx - px) + (sy - py) * (sy - py) + ez * ez;
            work++;
            if (fs < b.bf || (far && fs <= reach * reach)) {
                newton_out n = surf_newton(&q, sx, sy, x0, x1, y0, y1);
                work += n.it;
                offer_point(&b, n.tx, n.ty, n.f, n.stationary, sep);
                reach = cell_reach(model, &b, cx, cy, r, sep, tie_eps, &far);
                if (lb > reach * reach)
                    continue;
            }
        }
        if (model) /* (a cell across a map's edge or a joined map's patch line is split there, below) */
            leafy = nodes >= MAX_NODES || w <= max2(1e-9 * leaf, 1e-15 * (fabs(cx) + fabs(cy)));
        else
            leafy = w <= leaf || leaves >= MAX_LEAVES;
        if (leafy || sp + 4 > STACK) {
            /* a leaf: projected Newton from the best of its centre, its four quarter centres and
             * p_xy clamped into it */
            double sx = min2(max2(px, cx - wx), cx + wx), sy = min2(max2(py, cy - wy), cy + wy), fs, dzs;
            newton_out n;
            int qd;
            dzs = hx__frame_height(tex, sx, sy) - pz;
            fs = (sx - px) * (sx - px) + (sy - py) * (sy - py) + dzs * dzs;
            for (qd = 0; qd < 5; qd++) {
                double qx = qd == 0 ? cx : cx + ((qd & 1) ? 0.5 * wx : -0.5 * wx);
                double qy = qd == 0 ? cy : cy + ((qd & 2) ? 0.5 * wy : -0.5 * wy);
                double dq = hx__frame_height(tex, qx, qy) - pz;
                double fq = (qx - px) * (qx - px) + (qy - py) * (qy - py) + dq * dq;
                if (fq < fs) {
                    fs = fq;
                    sx = qx;
                    sy = qy;
                }
            }
            work += 6;
            leaves++;
            n = surf_newton(&q, sx, sy, cx - wx, cx + wx, cy - wy, cy + wy);
            work += n.it;
            offer_point(&b, n.tx, n.ty, n.f, n.stationary, sep);
            continue;
        }
        kids = model && !cm ? split_at_edges(&q, cx, cy, wx, wy, stack + 4 * sp)
                            : split_cell(cx, cy, wx, wy, px, py, stack + 4 * sp);
        if (rotated) { /* the parent of the kids, for rot_cell */
            int i;
            for (i = 0; i < 2 * ROT_GRATINGS && i < 2 * tex->cols; i++)
                rot.sc[L][i] = sc[i];
            rot.cx[L] = cx;
            rot.cy[L] = cy;
            rot.split[L] = 1;
        }
        for (; kids > 0; kids--)
            depth[sp++] = L + 1;
    }
    d = sqrt(b.bf);
    out.t = b.btx;
    out.y = b.bty;
    out.distance = d;
    out.tie = b.second < HUGE_VAL && sqrt(b.second) - d <= max2(tie_eps, 1e-9 * d);
    out.work = work;
    return out;
}

hx_closest hx_closest_surface(const hx_texture *tex, const double *aux, double px, double py, double pz, double gx0,
                              double gy0)
{
    /* a turned map (HX_PATCH_TURN): the probe and the guess turned into the map's frame, m = R^T
     * p, and the closest point back, p = R m (the distance is the same in either frame) */
    double th = hx__turn(tex), cs, sn, mx, my, gx, gy;
    hx_closest out;
    if (th == 0.0)
        return closest_in_frame(tex, aux, px, py, pz, gx0, gy0);
    hx__to_frame(th, gx0, gy0, &gx, &gy, &cs, &sn);
    hx__to_frame(th, px, py, &mx, &my, &cs, &sn);
    out = closest_in_frame(tex, aux, mx, my, pz, gx, gy);
    mx = out.t;
    my = out.y;
    out.t = cs * mx - sn * my;
    out.y = sn * mx + cs * my;
    return out;
}
