/*
 * Fuzz driver of the C core under AddressSanitizer and UndefinedBehaviorSanitizer
 * (tests/test_core.py compiles and runs it). Every coefficient array is allocated to its
 * exact size on the heap, so a read one element past it is reported. It checks:
 *   - hx_texture_check refuses arrays shorter than their header claims (and then nothing
 *     reads them), and accepts the well-formed ones;
 *   - every field at adversarial positions (huge, tiny, subnormal, exactly on cell edges and
 *     map ends, far outside the map) reads only its arrays, and gives finite forces and
 *     Jacobians for positions within +-1 km (the renderer's workspace limit);
 *   - the servo tick (hx_render_step) with W's damper, F's sharp presliding, the passivity controller and a max
 *     force of 5 N over the same positions and NaN/infinite ones: every force finite and at
 *     most 5 N, exactly the malformed positions counted as faults;
 *   - the search-data builders (hx_leaf_bounds, hx_table_cell; fuzz_builders below).
 * Prints "ok <evaluations>" and exits 0, else prints the failure and exits 1.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hx_core.h"

static unsigned long long rng = 88172645463325252ULL;

static double uniform(void)
{
    rng ^= rng << 13;
    rng ^= rng >> 7;
    rng ^= rng << 17;
    return (double)(rng >> 11) / 9007199254740992.0;
}

static double position(int i)
{
    static const double special[] = {0.0, -0.0, 1e-320, -1e-320, 1e-3, 8e-3, 8e-3 + 1e-19, -1e-3, 1e3, -1e3,
                                     999.999999, 2e-3, 1.6666666666666667e-4, 7.999999999999999e-3};
    if (i % 3 == 0)
        return special[(unsigned)(uniform() * 14.0) % 14];
    if (i % 3 == 1)
        return (uniform() - 0.5) * 2e3;
    return (uniform() - 0.25) * 12e-3;
}

static double *fourier(long *rows, long *cols, int surface)
{
    long n = 3, i, r = surface ? 4 : 3;
    double *c = malloc(sizeof(double) * (size_t)(r * n));
    for (i = 0; i < n; i++) {
        c[i] = 1e-4 * (1.0 + uniform());
        c[n + i] = 6283.0 * (1.0 + 3.0 * uniform());
        c[2 * n + i] = surface ? 3000.0 * uniform() : uniform();
        if (surface)
            c[3 * n + i] = uniform();
    }
    *rows = r;
    *cols = n;
    return c;
}

static double *spline(long m, int periodic, long *rows, long *cols)
{
    long k = m + 2, i;
    double *c = malloc(sizeof(double) * (size_t)(4 * k));
    for (i = 0; i < 4 * k; i++)
        c[i] = 1e-4 * (uniform() - 0.5);
    c[m] = 0.0;                  /* x0 */
    c[k + m] = 8e-3 / (double)m; /* dx */
    c[2 * k + m] = periodic;
    c[3 * k + m] = (double)m;
    *rows = 4;
    *cols = k;
    return c;
}

/* a patches header: an 8 mm square of nx x ny cells */
static void patch_header(double *c, long nx, long ny, int periodic, int joins)
{
    c[0] = 0.0;
    c[1] = 0.0;
    c[2] = 8e-3 / (double)nx;
    c[3] = 8e-3 / (double)ny;
    c[4] = (double)nx;
    c[5] = (double)ny;
    c[6] = periodic;
    c[7] = (double)joins;
    c[HX_PATCH_AXES] = 0.0; /* uniform cells */
    c[HX_PATCH_TURN] = 0.0; /* along the plane's axes */
}

static double *patches(long nx, long ny, int periodic, long cells, long *rows, long *cols)
{
    long k = HX_PATCH_DATA + 16 * cells, i;
    double *c = malloc(sizeof(double) * (size_t)k);
    patch_header(c, nx, ny, periodic, HX_JOINS_SPLINE);
    for (i = HX_PATCH_DATA; i < k; i++)
        c[i] = 1e-4 * (uniform() - 0.5);
    *rows = 1;
    *cols = k;
    return c;
}

/* A Hermite map on graded axes (HX_PATCH_AXES): nx x ny random cells whose widths grow by 1.5
 * a cell from 1 um, each axis's bucket index of 3 n buckets random cells (valid, nondecreasing:
 * a hint the core checks, mostly wrong); bad 1: a knot that does not increase; bad 2: the axes'
 * column one off; bad 3: an index entry past the last cell */
static double *graded(long nx, long ny, int periodic, int bad, long *rows, long *cols)
{
    long body = HX_PATCH_DATA + 16 * nx * ny, i, a, at;
    double *c, w;
    *cols = body + nx + 1 + ny + 1 + 2 + 3 * nx + 3 * ny;
    *rows = 1;
    c = malloc(sizeof(double) * (size_t)*cols);
    patch_header(c, nx, ny, periodic, HX_JOINS_HERMITE);
    c[HX_PATCH_AXES] = (double)(body + (bad == 2));
    for (i = HX_PATCH_DATA; i < body; i++)
        c[i] = 1e-4 * (uniform() - 0.5);
    c[body] = c[body + nx + 1] = 0.0;
    for (i = 0, w = 1e-6; i < nx; i++, w *= 1.5)
        c[body + i + 1] = c[body + i] + w;
    for (i = 0, w = 1e-6; i < ny; i++, w *= 1.5)
        c[body + nx + 1 + i + 1] = c[body + nx + 1 + i] + w;
    c[2] = c[body + nx] / (double)nx;
    c[3] = c[body + nx + 1 + ny] / (double)ny;
    for (a = 0, at = body + nx + ny + 2; a < 2; a++) {
        long n = a == 0 ? nx : ny;
        double cell = 0.0;
        c[at] = (double)(3 * n);
        for (i = 0; i < 3 * n; i++) {
            if (uniform() < 0.4 && cell < (double)(n - 1))
                cell += 1.0;
            c[at + 1 + i] = cell;
        }
        at += 1 + 3 * n;
    }
    if (bad == 1)
        c[body + 3] = c[body + 2];
    if (bad == 3)
        c[body + nx + ny + 3] = (double)nx;
    return c;
}

/* A branched map (HX_JOINS_BRANCHED, hx_core.h): nx x ny random cells, every third cell with
 * extra random patches (1 to HX_MAX_BRANCHES - 1 of them, so some cells are a maximum of up to
 * HX_MAX_BRANCHES patches); bad 1: a start that decreases; bad 2: a cell with HX_MAX_BRANCHES
 * extra patches (one too many) */
static double *branched(long nx, long ny, int periodic, int bad, long *rows, long *cols)
{
    long n = nx * ny, e = 0, k, i, extra[64];
    double *c;
    for (k = 0; k < n; k++) {
        extra[k] = k % 3 == 0 ? 1 + k % (HX_MAX_BRANCHES - 1) : 0;
        if (bad == 2 && k == 3)
            extra[k] = HX_MAX_BRANCHES;
        e += extra[k];
    }
    *cols = HX_PATCH_DATA + 16 * n + n + 1 + 16 * e;
    *rows = 1;
    c = malloc(sizeof(double) * (size_t)*cols);
    patch_header(c, nx, ny, periodic, HX_JOINS_BRANCHED);
    for (i = HX_PATCH_DATA; i < HX_PATCH_DATA + 16 * n; i++)
        c[i] = 1e-4 * (uniform() - 0.5);
    c[HX_PATCH_DATA + 16 * n] = 0.0;
    for (k = 0; k < n; k++)
        c[HX_PATCH_DATA + 16 * n + k + 1] = c[HX_PATCH_DATA + 16 * n + k] + (double)extra[k];
    if (bad == 1)
        c[HX_PATCH_DATA + 16 * n + 2] = c[HX_PATCH_DATA + 16 * n + 1] - 1.0;
    for (i = HX_PATCH_DATA + 16 * n + n + 1; i < *cols; i++)
        c[i] = 1e-4 * (uniform() - 0.5);
    return c;
}

/* The search-data builders over a random two-harmonic Fourier profile, one period of 2 mm
 * (harmonics of 2 mm and 0.5 mm): hx_leaf_bounds' lo and hi bound h at 64 random points of
 * every leaf; a bound tree and header are assembled from them as haptex.closest does, checked by
 * hx_closest_aux_check; hx_table_cell on cells from far below the texture to above it returns
 * at most HX_TABLE_MAXP + 1 and writes only its row (a heap array of exactly HX_PIECE x
 * HX_TABLE_MAXP values), every piece ordered and within the search window. */
static int fuzz_builders(long *evaluations)
{
    enum { NL = 64, NSUB = 8 };
    const double period = 2e-3, width = period / NL;
    double c[6], lo[NL], hi[NL], best_h, tmin, *aux, *row;
    long naux = HX_A_TREE + 4 * NL, i, k, cell;
    hx_texture t;
    c[0] = 3e-4 * (0.5 + uniform());
    c[1] = 1e-4 * (0.5 + uniform());
    c[2] = 2.0 * 3.141592653589793 / period;
    c[3] = 4.0 * c[2];
    c[4] = 6.3 * uniform();
    c[5] = 6.3 * uniform();
    t.kind = HX_TEXTURE_FOURIER;
    t.c = c;
    t.rows = 3;
    t.cols = 2;
    if (hx_texture_check(t.kind, t.c, t.rows, t.cols) != HX_OK) {
        printf("builders: the texture was refused\n");
        return 1;
    }
    {
        double jerk = c[0] * pow(c[2], 3) + c[1] * pow(c[3], 3);
        tmin = hx_leaf_bounds(&t, 0.0, width, NL, NSUB, jerk, lo, hi, &best_h);
        for (i = 0; i < NL; i++)
            for (k = 0; k < 64; k++) {
                double x = (double)i * width + uniform() * width, h = hx_texture_height(&t, x, 0.0);
                (*evaluations)++;
                if (!(lo[i] - 1e-15 <= h && h <= hi[i] + 1e-15)) {
                    printf("builders: leaf %ld bounds [%g, %g] miss h(%g) = %g\n", i, lo[i], hi[i], x, h);
                    return 1;
                }
            }
        aux = calloc((size_t)naux, sizeof(double));
        aux[HX_A_MODE] = HX_CP_PERIODIC;
        aux[HX_A_PERIOD] = aux[HX_A_TREELEN] = period;
        aux[HX_A_NLEAF] = NL;
        aux[HX_A_STEP] = period / 4.0 / 64.0;
        aux[HX_A_SLOPE] = c[0] * c[2] + c[1] * c[3];
        aux[HX_A_CURV] = c[0] * c[2] * c[2] + c[1] * c[3] * c[3];
        aux[HX_A_JERK] = jerk;
        aux[HX_A_TIE] = 1e-9 * period / 4.0;
        aux[HX_A_TMIN] = tmin;
        for (i = 0; i < 2 * NL; i++) { /* heap-ordered min / max tree, leaves from NL */
            aux[HX_A_TREE + i] = HUGE_VAL;
            aux[HX_A_TREE + 2 * NL + i] = -HUGE_VAL;
        }
        for (i = 0; i < NL; i++) {
            aux[HX_A_TREE + NL + i] = lo[i];
            aux[HX_A_TREE + 3 * NL + i] = hi[i];
        }
        for (i = NL - 1; i >= 1; i--) {
            aux[HX_A_TREE + i] = fmin(aux[HX_A_TREE + 2 * i], aux[HX_A_TREE + 2 * i + 1]);
            aux[HX_A_TREE + 2 * NL + i] = fmax(aux[HX_A_TREE + 2 * NL + 2 * i], aux[HX_A_TREE + 2 * NL + 2 * i + 1]);
        }
        aux[HX_A_HMIN] = aux[HX_A_TREE + 1];
    }
    if (hx_closest_aux_check(aux, naux) != HX_OK) {
        printf("builders: the assembled search data was refused\n");
        free(aux);
        return 1;
    }
    { /* the leaves' bounds of h'' (a spline profile's, aux[HX_A_LEAFC]): refused outside the array
       * or inside the tree; any values, NaN and infinities too, read only within it */
        double *more = calloc((size_t)(naux + 2 * NL), sizeof(double)), odd[] = {NAN, HUGE_VAL, -HUGE_VAL, 0.0};
        const double bad[] = {1.0, (double)HX_A_TREE + 4.0 * NL - 1.0, (double)naux + 0.5, (double)naux + 1.0};
        memcpy(more, aux, sizeof(double) * (size_t)naux);
        for (i = 0; i < 4; i++) {
            more[HX_A_LEAFC] = bad[i];
            if (hx_closest_aux_check(more, naux + 2 * NL) == HX_OK) {
                printf("builders: leaf bounds at %g accepted\n", bad[i]);
                free(more);
                free(aux);
                return 1;
            }
        }
        more[HX_A_LEAFC] = (double)naux;
        for (i = 0; i < 2 * NL; i++)
            more[naux + i] = uniform() < 0.1 ? odd[i % 4] : 1e5 * (uniform() - 0.5);
        if (hx_closest_aux_check(more, naux + 2 * NL) != HX_OK) {
            printf("builders: leaf bounds after the tree refused\n");
            free(more);
            free(aux);
            return 1;
        }
        for (k = 0; k < 2000; k++) {
            double px = (uniform() - 0.5) * 3.0 * period, pz = (uniform() - 0.8) * 6e-3;
            hx_closest r = hx_closest_profile(&t, more, px, pz, hx_texture_height(&t, px, 0.0) - pz, NAN);
            *evaluations += r.work;
            if (!(r.distance >= 0.0) || !isfinite(r.t)) {
                printf("builders: closest point of (%g, %g) = %g at %g\n", px, pz, r.distance, r.t);
                free(more);
                free(aux);
                return 1;
            }
        }
        free(more);
    }
    row = malloc(sizeof(double) * HX_PIECE * HX_TABLE_MAXP);
    for (cell = 0; cell < 4000; cell++) {
        double w = period / 128.0 * (cell % 7 == 0 ? 16.0 : 1.0), cx = (uniform() - 0.5) * 3.0 * period;
        double zlo = (uniform() - 0.8) * 6e-3, x0 = floor(cx / period) * period;
        long n = hx_table_cell(&t, aux, x0, w, cx, zlo, zlo + w, row);
        (*evaluations)++;
        if (n < 0 || n > HX_TABLE_MAXP + 1) {
            printf("builders: cell (%g, %g) gave %ld pieces\n", cx, zlo, n);
            return 1;
        }
        for (k = 0; k < (n <= HX_TABLE_MAXP ? n : 0); k++) {
            const double *q = row + HX_PIECE * k;
            if (!(q[0] < q[1]) || !(q[2] == 0.0 || q[2] == 1.0) || !isfinite(q[3]) || !isfinite(q[4])) {
                printf("builders: cell (%g, %g) piece %ld = [%g, %g] kind %g\n", cx, zlo, k, q[0], q[1], q[2]);
                return 1;
            }
        }
    }
    free(row);
    free(aux);
    return 0;
}

/* An octahedron of half-diagonal 5 mm centred at (0, 0, -5 mm): 8 triangles, its hierarchy
 * built by hx_bvh_build into arrays of exactly the documented sizes. */
static const double OCTA_V[6][3] = {{5e-3, 0, -5e-3}, {-5e-3, 0, -5e-3}, {0, 5e-3, -5e-3},
                                    {0, -5e-3, -5e-3}, {0, 0, 0}, {0, 0, -10e-3}};
static const int OCTA_F[8][3] = {{0, 2, 4}, {2, 1, 4}, {1, 3, 4}, {3, 0, 4},
                                 {2, 0, 5}, {1, 2, 5}, {3, 1, 5}, {0, 3, 5}};

/* A-G and the proxy where defined on the plane, a cylinder, a sphere and the octahedron (faceted
 * and prism; the proxy's walk through its UV map too), ticked at adversarial
 * positions (NaN, infinities, +-1 km, the round bases' axes): never NaN, never above the
 * maximum, at least the expected faults. */
static int fuzz_objects(const hx_model *m0, long *evaluations, int scale)
{
    int kind, code, i, j, k;
    long n = 8, n_node;
    double *tri = malloc(sizeof(double) * 9 * (size_t)n), *face = malloc(sizeof(double) * HX_FACE * (size_t)n);
    double *box = malloc(sizeof(double) * 12 * (size_t)n);
    long *node = malloc(sizeof(long) * 4 * (size_t)n), *order = malloc(sizeof(long) * (size_t)n);
    hx_base b;
    for (i = 0; i < n; i++) {
        double e1[3], e2[3], nn[3], len;
        for (k = 0; k < 3; k++)
            for (j = 0; j < 3; j++)
                tri[9 * i + 3 * k + j] = OCTA_V[OCTA_F[i][k]][j];
        for (j = 0; j < 3; j++) {
            e1[j] = tri[9 * i + 3 + j] - tri[9 * i + j];
            e2[j] = tri[9 * i + 6 + j] - tri[9 * i + j];
        }
        nn[0] = e1[1] * e2[2] - e1[2] * e2[1];
        nn[1] = e1[2] * e2[0] - e1[0] * e2[2];
        nn[2] = e1[0] * e2[1] - e1[1] * e2[0];
        len = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
        for (j = 0; j < HX_FACE; j++)
            face[HX_FACE * i + j] = 0.0;
        for (j = 0; j < 3; j++) /* the normal; its sides' and corners' pseudo-normals the same */
            face[HX_FACE * i + HX_FACE_N + j] = nn[j] / len;
        for (k = 0; k < 6; k++)
            for (j = 0; j < 3; j++)
                face[HX_FACE * i + HX_FACE_EDGE + 3 * k + j] = nn[j] / len;
        face[HX_FACE * i + HX_FACE_M] = 1.0; /* u1 = x - x0 on every face (any finite map) */
        for (k = 0; k < 3; k++) /* the corners' UV: their (x, y) (the two pyramids' charts overlap) */
            for (j = 0; j < 2; j++)
                face[HX_FACE * i + HX_FACE_UV + 2 * k + j] = OCTA_V[OCTA_F[i][k]][j];
        for (k = 0; k < 3; k++) /* the prism base's corner normals: the octahedron's vertices' directions */
            for (j = 0; j < 3; j++)
                face[HX_FACE * i + HX_FACE_VN + 3 * k + j] = (OCTA_V[OCTA_F[i][k]][j] - (j == 2 ? -5e-3 : 0.0)) / 5e-3;
        for (k = 0; k < 3; k++) { /* the triangle across side k (corners k, k + 1) */
            int a = OCTA_F[i][k], c = OCTA_F[i][(k + 1) % 3], t;
            for (t = 0; t < n; t++) {
                int m2, hits = 0;
                for (m2 = 0; m2 < 3; m2++)
                    hits += OCTA_F[t][m2] == a || OCTA_F[t][m2] == c;
                if (t != i && hits == 2)
                    face[HX_FACE * i + HX_FACE_NEXT + k] = (double)t;
            }
        }
    }
    n_node = hx_bvh_build(tri, n, order, box, node);
    for (kind = 0; kind <= HX_N_BASES; kind++) { /* (HX_N_BASES: the mesh again, as the prism base) */
        memset(&b, 0, sizeof b);
        b.kind = kind < HX_N_BASES ? kind : HX_BASE_MESH;
        b.prism = kind == HX_N_BASES;
        b.radius = 5e-3;
        if (b.kind == HX_BASE_MESH) {
            b.n_tri = n;
            b.tri = tri;
            b.face = face;
            b.n_node = n_node;
            b.box = box;
            b.node = node;
            b.order = order;
        }
        for (code = 0; code < HX_N_ALGS; code++) {
            hx_renderer r;
            long faults_expected = 0;
            int surface = m0->tex.kind == HX_SURFACE_GRATINGS || m0->tex.kind == HX_SURFACE_PATCHES;
            int defined = code == HX_ALG_A || code == HX_ALG_B || code == HX_ALG_C || code == HX_ALG_G ||
                          code == HX_ALG_F || code == HX_ALG_PROXY ||
                          ((code == HX_ALG_D || code == HX_ALG_E) && (b.kind != HX_BASE_MESH || b.prism) && surface);
            /* D and E's search constants over an object: bounds that need not hold for this
             * texture (the search then is not certified, but must stay finite, bounded and in
             * bounds), a budget of 2,000 evaluations */
            double gaux[HX_N_GAUX];
            memset(gaux, 0, sizeof gaux);
            gaux[HX_G_HMIN] = -1e-3, gaux[HX_G_HMAX] = 1e-3;
            gaux[HX_G_SLOPE] = gaux[HX_G_SLOPE_BOUND] = 10.0;
            gaux[HX_G_CURV] = gaux[HX_G_CURV_BOUND] = 1e4;
            gaux[HX_G_JERK] = 1e8, gaux[HX_G_LEAF] = 5e-5, gaux[HX_G_TIE] = 1e-12, gaux[HX_G_BUDGET] = 2000.0;
            memset(&r, 0, sizeof r);
            r.model = *m0;
            r.model.code = code;
            r.model.base = &b;
            r.model.prm[HX_P_DXMAX] = 1e-4; /* F's presliding, the proxy's longest step */
            r.model.prm[HX_P_MU] = 0.5;
            r.model.prm[HX_P_SCALE] = 0.5;
            if (code == HX_ALG_D || code == HX_ALG_E) {
                r.model.aux = gaux;
                r.model.naux = HX_N_GAUX;
            }
            r.max_force = 5.0;
            r.limit = 1e3;
            if ((hx_model_check(&r.model) == HX_OK) != defined) {
                printf("base %d code %d: the check gave %d\n", kind, code, hx_model_check(&r.model));
                return 1;
            }
            if (!defined)
                continue;
            /* (D and E on the prism mesh: fewer ticks, each up to its budget of 2,000 evaluations
             * over several prisms, the slowest under the sanitizers) */
            for (i = 0; i < ((code == HX_ALG_D || code == HX_ALG_E) && b.kind == HX_BASE_MESH ? 600 : 2000) * scale; i++) {
                double f[3], p[3];
                p[0] = position(i) * 1e-2;
                p[1] = position(i + 1) * 1e-2;
                p[2] = position(i + 2) * 1e-2 - (i % 7 == 0 ? 5e-3 : 0.0);
                if (i % 11 == 0) /* on the round bases' axes */
                    p[0] = 0.0, p[2] = -5e-3;
                if (i % 97 == 0)
                    p[i % 3] = i % 2 ? NAN : -INFINITY;
                if (i % 89 == 0)
                    p[i % 3] = 2e3;
                for (j = 0; j < 3; j++)
                    if (!isfinite(p[j]) || fabs(p[j]) > r.limit) {
                        faults_expected++;
                        break;
                    }
                hx_render_step(&r, p[0], p[1], p[2], f);
                (*evaluations)++;
                if (!isfinite(f[0]) || !isfinite(f[1]) || !isfinite(f[2]) ||
                    sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) > 5.0 * (1.0 + 1e-15)) {
                    printf("base %d code %d: tick force (%g, %g, %g)\n", kind, code, f[0], f[1], f[2]);
                    return 1;
                }
            }
            if (r.faults < faults_expected) {
                printf("base %d code %d: %ld faults, expected at least %ld\n", kind, code, r.faults, faults_expected);
                return 1;
            }
        }
    }
    free(tri);
    free(face);
    free(box);
    free(node);
    free(order);
    return 0;
}

/* argv[1]: a multiple of the default counts (the slow suite runs 5x) */
int main(int argc, char **argv)
{
    long evaluations = 0;
    int variant, code, i, j, scale = argc > 1 ? atoi(argv[1]) : 1;
    if (scale < 1 || scale > 100) {
        printf("scale %d: give 1 to 100\n", scale);
        return 2;
    }
    for (variant = 0; variant < 20; variant++) {
        long rows = 0, cols = 0;
        int kind, expect = HX_OK;
        double *c;
        hx_model m;
        switch (variant) {
        case 0: kind = HX_TEXTURE_FOURIER; c = fourier(&rows, &cols, 0); break;
        case 1: kind = HX_SURFACE_GRATINGS; c = fourier(&rows, &cols, 1); break;
        case 2: kind = HX_TEXTURE_SPLINE; c = spline(17, 0, &rows, &cols); break;
        case 3: kind = HX_TEXTURE_SPLINE; c = spline(1, 1, &rows, &cols); break;
        case 4: kind = HX_SURFACE_PATCHES; c = patches(7, 5, 0, 35, &rows, &cols); break;
        case 5: kind = HX_SURFACE_PATCHES; c = patches(1, 1, 1, 1, &rows, &cols); break;
        case 6: kind = HX_SURFACE_PATCHES; c = patches(7, 5, 0, 34, &rows, &cols); expect = HX_BAD_COEFFS; break;
        case 7: kind = HX_TEXTURE_SPLINE; c = spline(17, 0, &rows, &cols); cols -= 1; expect = HX_BAD_COEFFS; break;
        case 9: kind = HX_SURFACE_PATCHES; c = branched(7, 5, 0, 0, &rows, &cols); break;
        case 10: kind = HX_SURFACE_PATCHES; c = branched(7, 5, 0, 1, &rows, &cols); expect = HX_BAD_COEFFS; break;
        case 11: kind = HX_SURFACE_PATCHES; c = branched(7, 5, 0, 2, &rows, &cols); expect = HX_BAD_COEFFS; break;
        case 12: kind = HX_SURFACE_PATCHES; c = graded(7, 5, 0, 0, &rows, &cols); break;
        case 13: kind = HX_SURFACE_PATCHES; c = graded(6, 9, 1, 0, &rows, &cols); break;
        case 14: kind = HX_SURFACE_PATCHES; c = graded(7, 5, 0, 1, &rows, &cols); expect = HX_BAD_COEFFS; break;
        case 15: kind = HX_SURFACE_PATCHES; c = graded(7, 5, 0, 2, &rows, &cols); expect = HX_BAD_COEFFS; break;
        /* a map on turned axes (HX_PATCH_TURN), and turns refused: NaN, past pi */
        case 16: kind = HX_SURFACE_PATCHES; c = graded(6, 9, 1, 0, &rows, &cols); c[HX_PATCH_TURN] = 0.7; break;
        case 17: kind = HX_SURFACE_PATCHES; c = patches(7, 5, 0, 35, &rows, &cols); c[HX_PATCH_TURN] = NAN;
            expect = HX_BAD_COEFFS; break;
        case 18: kind = HX_SURFACE_PATCHES; c = patches(7, 5, 0, 35, &rows, &cols); c[HX_PATCH_TURN] = -3.2;
            expect = HX_BAD_COEFFS; break;
        case 19: kind = HX_SURFACE_PATCHES; c = graded(7, 5, 0, 3, &rows, &cols); expect = HX_BAD_COEFFS; break;
        default: kind = HX_TEXTURE_FLAT; c = NULL; break;
        }
        m.tex.kind = kind;
        m.base = NULL; /* the plane; the objects' bases below */
        m.aux = NULL; /* D and E's search data and F's smooth table: none here */
        m.naux = 0;
        m.tex.c = c;
        m.tex.rows = rows;
        m.tex.cols = cols;
        for (i = 0; i < HX_N_PARAMS; i++)
            m.prm[i] = -1.0;
        m.prm[HX_P_K0] = 2000.0;
        m.code = HX_ALG_A;
        if (hx_model_check(&m) != expect) {
            printf("variant %d: check gave %d, expected %d\n", variant, hx_model_check(&m), expect);
            return 1;
        }
        if (expect != HX_OK) {
            free(c);
            continue;
        }
        for (code = 0; code < HX_N_ALGS; code++) {
            m.code = code;
            m.prm[HX_P_DZMAX] = code % 2 ? 5e-4 : -1.0;
            for (i = 0; i < 8000 * scale; i++) {
                double p[3], f[3], jac[9];
                int rc;
                p[0] = position(i);
                p[1] = position(i + 1);
                p[2] = position(i + 2) * (i % 5 == 0 ? 1.0 : 1e-3);
                rc = hx_field(&m, p, f, i % 2 ? jac : NULL);
                evaluations++;
                if (rc == HX_NOT_IN_CORE)
                    break;
                if (rc != HX_OK) {
                    printf("variant %d code %d: rc %d\n", variant, code, rc);
                    return 1;
                }
                for (j = 0; j < 9; j++) {
                    if ((j < 3 && !isfinite(f[j])) || ((i % 2) && !isfinite(jac[j]))) {
                        printf("variant %d code %d: non-finite at (%g, %g, %g)\n", variant, code, p[0], p[1], p[2]);
                        return 1;
                    }
                }
            }
        }
        /* the servo tick over the same positions, with NaN and infinities too: never NaN,
         * never above max force, faults counted */
        for (code = 0; code < HX_N_ALGS; code++) {
            hx_renderer r;
            long faults_expected = 0;
            memset(&r, 0, sizeof r);
            r.model = m;
            r.model.code = code;
            r.model.prm[HX_P_MU] = code == HX_ALG_W ? 3.0 : 0.8; /* W's damper B; F's Coulomb mu */
            r.model.prm[HX_P_DXMAX] = 1e-3;
            r.max_force = 5.0;
            r.limit = 1e3;
            r.monitor = 1;
            r.pc.on = 1;
            r.pc.mode = code % HX_N_STAB;
            r.pc.bmax = 5.0;
            r.pc.T = 1e-3;
            /* D and E need their search data, built in Python (tests/test_core.py runs them
             * through the binding): here the model check refuses them, as the binding does */
            if (code == HX_ALG_D || code == HX_ALG_E) {
                if (hx_model_check(&r.model) == HX_OK) {
                    printf("variant %d code %d: a model without search data passed the check\n", variant, code);
                    return 1;
                }
                continue;
            }
            for (i = 0; i < 8000 * scale; i++) {
                double f[3], p[3];
                p[0] = position(i);
                p[1] = position(i + 1);
                p[2] = position(i + 2) * (i % 5 == 0 ? 1.0 : 1e-3);
                if (i % 97 == 0)
                    p[i % 3] = i % 2 ? NAN : -INFINITY;
                for (j = 0; j < 3; j++)
                    if (!isfinite(p[j]) || fabs(p[j]) > r.limit) {
                        faults_expected++;
                        break;
                    }
                hx_render_step(&r, p[0], p[1], p[2], f);
                evaluations++;
                if (!isfinite(f[0]) || !isfinite(f[1]) || !isfinite(f[2]) ||
                    sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]) > 5.0 * (1.0 + 1e-15)) {
                    printf("variant %d code %d: tick force (%g, %g, %g)\n", variant, code, f[0], f[1], f[2]);
                    return 1;
                }
            }
            if (r.faults != faults_expected) {
                printf("variant %d code %d: %ld faults, expected %ld\n", variant, code, r.faults, faults_expected);
                return 1;
            }
        }
        if (expect == HX_OK && fuzz_objects(&m, &evaluations, scale))
            return 1;
        free(c);
    }
    if (fuzz_builders(&evaluations))
        return 1;
    printf("ok %ld\n", evaluations);
    return 0;
}
