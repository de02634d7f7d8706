/*
 * haptex's real-time core: texture evaluation and the force fields of Campion & Hayward,
 * "On the Synthesis of Haptic Textures" (IEEE Trans. Robotics 24(3), 2008), in C99.
 *
 * One implementation, written once over the dimension: a position is always [x, y, z] (m);
 * a profile h(x) is the y-independent case of a surface h(x, y), and the 2-D entry points
 * map [x, z] to [x, 0, z]. The model (texture, algorithm, parameters) is constant during a
 * run; the per-loop state is mutable (the split of MuJoCo's mjModel / mjData).
 *
 * No allocation, no I/O, no global state: every function reads only the arrays its model
 * was checked against by hx_texture_check.
 */
#ifndef HX_CORE_H
#define HX_CORE_H

#ifdef __cplusplus
extern "C" {
#endif

/* inlined into every caller: a loop instantiated per letter inlines that letter's field */
#if defined(__GNUC__) || defined(__clang__)
#define HX_INLINE static inline __attribute__((always_inline))
#else
#define HX_INLINE static inline
#endif
/* a body that the compiler may keep out of line: a height map's bicubic patch evaluation (a
 * few hundred instructions, some 100-300 ns a point), which forced into every caller made
 * hx_closest.c, hx_forces.c and hx_sim.c take 7-9 s each to compile at -O2 (1.4-3.4 s so; the
 * extension's build 27 -> 9.5 s) for no measured gain (2026-11-29: 89-93 ns and 259-321 ns a
 * point on a uniform and a graded felt map either way) */
#define HX_INLINE_LARGE static inline

/* ---- atomics: gcc's and clang's __atomic builtins, or, under MSVC (which has none of them),
 * its Interlocked intrinsics on 32-bit words: each a full barrier, so acquire and release as
 * asked and more. HX_MSVC_ATOMICS is set for MSVC itself; defined by hand it builds the same
 * path with mingw-w64 or clang (the tests run it so under Wine). The flags it serves are int
 * and unsigned long words, 32 bits on Windows. ---- */
#if defined(_MSC_VER) && !defined(__clang__) && !defined(HX_MSVC_ATOMICS)
#define HX_MSVC_ATOMICS 1
#endif
#ifdef HX_MSVC_ATOMICS
#ifndef _WIN32
#error "HX_MSVC_ATOMICS: Windows' Interlocked intrinsics on 32-bit long"
#endif
#include <intrin.h>
#define HX_LOAD_ACQ(p) _InterlockedOr((volatile long *)(p), 0L)
#define HX_LOAD_RLX(p) HX_LOAD_ACQ(p)
#define HX_STORE_REL(p, v) ((void)_InterlockedExchange((volatile long *)(p), (long)(v)))
#define HX_STORE_RLX(p, v) HX_STORE_REL(p, v)
#define HX_CAS(p, expected, desired) hx__cas((volatile long *)(p), (expected), (desired))
#define HX_FENCE_REL() hx__fence()
#define HX_FENCE_ACQ() hx__fence()
/* a double read whole (an aligned 8-byte load is single-copy atomic on x64 and ARM64) */
#define HX_LOAD_DOUBLE_RLX(p, out) (*(out) = *(volatile const double *)(p))
static inline int hx__cas(volatile long *p, int *expected, int desired)
{
    long old = _InterlockedCompareExchange(p, (long)desired, (long)*expected);
    if (old == (long)*expected)
        return 1;
    *expected = (int)old;
    return 0;
}
static inline void hx__fence(void)
{
    volatile long f = 0;
    (void)_InterlockedExchange(&f, 0L);
}
#else
#define HX_LOAD_ACQ(p) __atomic_load_n((p), __ATOMIC_ACQUIRE)
#define HX_LOAD_RLX(p) __atomic_load_n((p), __ATOMIC_RELAXED)
#define HX_STORE_REL(p, v) __atomic_store_n((p), (v), __ATOMIC_RELEASE)
#define HX_STORE_RLX(p, v) __atomic_store_n((p), (v), __ATOMIC_RELAXED)
/* a strong compare-and-swap of *p from *expected to desired: 1, or 0 with *expected the value found */
#define HX_CAS(p, expected, desired) __atomic_compare_exchange_n((p), (expected), (desired), 0, __ATOMIC_ACQ_REL, \
                                                                 __ATOMIC_ACQUIRE)
#define HX_FENCE_REL() __atomic_thread_fence(__ATOMIC_RELEASE)
#define HX_FENCE_ACQ() __atomic_thread_fence(__ATOMIC_ACQUIRE)
#define HX_LOAD_DOUBLE_RLX(p, out) __atomic_load((p), (out), __ATOMIC_RELAXED)
#endif

/* ---- texture kinds (the layout of each kind's coefficients is in hx_texture.c) ---- */
enum {
    HX_TEXTURE_FLAT = 0,     /* h = 0 */
    HX_TEXTURE_FOURIER = 1,  /* profile: rows a (m), k (rad/m), phase (rad) */
    HX_TEXTURE_SPLINE = 2,   /* profile: uniform cubic spline, 4 rows */
    HX_SURFACE_GRATINGS = 3, /* surface: rows a (m), kx, ky (rad/m), phase (rad) */
    HX_SURFACE_PATCHES = 4,  /* surface: bicubic patches of a height map, 1 row */
    HX_N_KINDS = 5
};

/* ---- the paper's algorithms, in the order of its letters ---- */
enum {
    HX_ALG_W = 0, /* smooth wall, eq. 30 */
    HX_ALG_A = 1, /* grooved boundary, force normal to the surface, eq. 6-7 */
    HX_ALG_B = 2, /* grooved boundary, force normal to the groove, eq. 11 */
    HX_ALG_C = 3, /* change of height, eq. 13-15 */
    HX_ALG_D = 4, /* god-object, closest point, gradient */
    HX_ALG_E = 5, /* god-object, closest point, vertical */
    HX_ALG_F = 6, /* friction modulation with presliding */
    HX_ALG_G = 7, /* force shading, eq. 28 */
    HX_ALG_PROXY = 8, /* a god-object (Zilles & Salisbury 1995; Ruspini et al. 1997): not a letter of the
                       * paper; the proxy's longest descent step (m) in HX_P_DXMAX */
    HX_N_ALGS = 9
};

/* The god-object's descent: at most this many Newton steps a tick, each backtracked at most
 * HX_PROXY_HALVINGS times (haptex.proxy). */
enum { HX_PROXY_STEPS = 200, HX_PROXY_HALVINGS = 40 };

/* ---- the parameter vector of an algorithm (float64[HX_N_PARAMS]) ---- */
enum {
    HX_P_K0 = 0,    /* stiffness kappa_0 (N/m) */
    HX_P_DZMAX = 1, /* max penetration d^z_max of Remark 3 (m), < 0 when none */
    HX_P_MU = 2,    /* F: Coulomb coefficient; W: virtual damping B (N s/m) */
    HX_P_DXMAX = 3, /* F: presliding distance (m); W: servo period T (s) */
    HX_P_SCALE = 4, /* F: modulation scale (1/m) */
    HX_P_ZSTICK = 5,/* F: smooth presliding's stick limit (m), < 0 for the sharp model */
    HX_N_PARAMS = 6
};

/* ---- status codes ---- */
enum {
    HX_OK = 0,
    HX_BAD_KIND = -1,      /* unknown texture kind */
    HX_BAD_COEFFS = -2,    /* coefficients of the wrong shape or inconsistent header */
    HX_BAD_ALGORITHM = -3, /* unknown algorithm code */
    HX_NOT_IN_CORE = -4,   /* an algorithm the core does not evaluate (here) */
    HX_NO_MEMORY = -5      /* a binding could not allocate scratch */
};

/* a height map's patches (HX_SURFACE_PATCHES): the header, then 16 coefficients a cell.
 * HX_PATCH_JOINS: 0 where the patches are one C^2 spline; 1 where they are joined only
 * continuously across the patch lines (a Hermite map whose slopes jump there: a felt map's
 * kinks), so that a Taylor model of the height holds on a cell within one patch only; 2 as 1,
 * and some cells branched (HX_JOINS_BRANCHED): after the cells' coefficients, nx ny + 1 starts
 * (start[k], k = i ny + j, the count of extra patches before cell k's; start[nx ny] = E, their
 * total) and E extra patches of 16 coefficients; a branched cell's height is the largest of its
 * own patch's and its extra patches' there (a maximum of smooth branches: a felt map where
 * the ball's contact jumps inside the cell), its derivatives the largest's; at most
 * HX_MAX_BRANCHES patches a cell (12: a ball nesting in the egg-crate's bowls at 1.04 and 1.08
 * times their radius needs 9 to 11, where 8 left those cells single and the felt slope 2.0 and
 * 2.6 % steep; a branched piece's closest-point search, 2 n 40 + 2 C(n, 2) 30 + C(n, 3) 20
 * evaluation pairs at most, is then 9,320 where it was 3,440). No Taylor model holds on a
 * branched cell. */
enum { HX_JOINS_SPLINE = 0, HX_JOINS_HERMITE = 1, HX_JOINS_BRANCHED = 2, HX_MAX_BRANCHES = 12 };
/* A branched cell's patches tie at a point where their heights are within HX_BRANCH_TIE of its
 * height and the cell's widths (m; round-off is about 1e-16 of them); the tie is broken by their
 * heights HX_BRANCH_NUDGE of the way from the point to the cell's centre (chosen: far enough that
 * patches tangent along an edge differ there by their curvature, 1e-15 m on a 7 um cell, far
 * above round-off; near enough to be the limit from inside the cell) */
#define HX_BRANCH_TIE 1e-13
#define HX_BRANCH_NUDGE 1e-4
/* HX_PATCH_AXES: 0 where the cells are uniform (HX_PATCH_DX by HX_PATCH_DY); else graded axes
 * (rectilinear cells of their own widths), the column where the tail's nx + 1 x knots and then
 * ny + 1 y knots start, increasing, the first at X0 (Y0); the cells' coefficients are in each
 * cell's own local coordinates as on a uniform map, and DX, DY are the cells' mean widths.
 * After the knots each axis's bucket index, x's then y's: its count B (1 to 16 n + 16) and B
 * cells (whole numbers in [0, n - 1], nondecreasing), bucket b of the axis's B equal buckets
 * holding the cell that holds the bucket's start kn[0] + b (kn[n] - kn[0]) / B: a point's cell
 * is found by a bisection between its bucket's cell and the next bucket's, that bracket checked
 * against the knots first (a whole-axis bisection where it fails), so the index only saves
 * steps and any valid one gives the same cells.
 * HX_PATCH_TURN: the angle theta (rad, |theta| <= pi) by which the map's axes are turned from
 * the plane's: the map holds h_m(m) and the surface is h(p) = h_m(R(theta)^T p) (a felt map on
 * axes along a texture's gratings, haptex.SampledSurface.turn); 0 on a map along the plane's
 * axes. X0, Y0 and the knots are then in the map's frame; the closest-point search turns the
 * probe into it. */
enum {
    HX_PATCH_X0, HX_PATCH_Y0, HX_PATCH_DX, HX_PATCH_DY, HX_PATCH_NX, HX_PATCH_NY, HX_PATCH_PERIODIC, HX_PATCH_JOINS,
    HX_PATCH_AXES, HX_PATCH_TURN, HX_PATCH_DATA = 10
};

typedef struct {
    int kind;          /* HX_TEXTURE_* or HX_SURFACE_* */
    const double *c;   /* coefficients, row-major, rows x cols */
    long rows, cols;
} hx_texture;

/* ---- bases of textured objects (haptex.objects) ---- */
enum { HX_BASE_PLANE = 0, HX_BASE_CYLINDER = 1, HX_BASE_SPHERE = 2, HX_BASE_MESH = 3, HX_N_BASES = 4 };

/* A mesh's constants per triangle (HX_FACE values): its outward unit normal; M, the gradient
 * of its UV map on its plane (2 x 3, row-major: u = uv_0 + M (p - v_0) there); the UV of its
 * corners (3 x 2); the pseudo-normals of its sides (side k joins corners k and k + 1: the sum
 * of the two triangles' normals) and of its corners (angle-weighted; Baerentzen & Aanaes
 * 2005), 3 x 3 each; for the prism base, its corners' unit normals (3 x 3) and the triangle
 * across each side (3 indices, as doubles). */
enum {
    HX_FACE_N = 0, HX_FACE_M = 3, HX_FACE_UV = 9, HX_FACE_EDGE = 15, HX_FACE_VERTEX = 24, HX_FACE_VN = 33,
    HX_FACE_NEXT = 42, HX_FACE = 45
};

/* The prism base's solve: Newton steps in one prism, walks to a neighbour (haptex.objects.Mesh). */
enum { HX_PRISM_NEWTON = 8, HX_PRISM_WALKS = 32 };

/* The bounding-volume hierarchy's leaves hold at most this many triangles. */
enum { HX_BVH_LEAF = 4, HX_BVH_STACK = 128 };

/* A base surface the texture displaces along its normal (haptex.objects): a plane (z = 0), a
 * cylinder or a sphere of radius R with its top at the origin, or a closed triangle mesh with
 * its bounding-volume hierarchy (hx_bvh_build). */
typedef struct {
    int kind;            /* HX_BASE_* */
    double radius;       /* cylinder, sphere (m) */
    int prism;           /* mesh: the prism base swept along the corners' normals (else the closest point's) */
    long n_tri;          /* mesh: triangles */
    const double *tri;   /* n_tri x 9: the corners (m) */
    const double *face;  /* n_tri x HX_FACE */
    long n_node;
    const double *box;   /* n_node x 6: each node's box, lo then hi (m) */
    const long *node;    /* n_node x 2: an inner node's children, or a leaf's (-1 - first, count) in order */
    const long *order;   /* n_tri: triangle ids in the leaves' order */
} hx_base;

typedef struct {
    int code;                   /* HX_ALG_* */
    double prm[HX_N_PARAMS];    /* HX_P_* */
    hx_texture tex;
    const double *aux;          /* F's smooth presliding table (when HX_P_ZSTICK >= 0), else NULL */
    long naux;
    const hx_base *base;        /* NULL: the plane of the paper (every letter); else A, B, C, G on it */
} hx_model;

/* h and its derivatives at one point: h (m), gradient (m/m), Hessian (1/m) */
typedef struct {
    double h, gx, gy, hxx, hxy, hyy;
} hx_height;

/* Check that coefficients of shape rows x cols are a valid texture of this kind: every
 * later read stays inside the array. HX_OK, HX_BAD_KIND or HX_BAD_COEFFS. */
int hx_texture_check(int kind, const double *c, long rows, long cols);

/* h, grad h and the Hessian at (x, y); a profile ignores y (its y-derivatives are 0). */
void hx_texture_eval(const hx_texture *t, double x, double y, hx_height *out);

/* h alone at (x, y): no derivative's cosine where only the height is needed. */
double hx_texture_height(const hx_texture *t, double x, double y);

/* Check a model: its texture, its algorithm code, and F's presliding table (when smooth).
 * HX_OK or an HX_BAD_* code. */
int hx_model_check(const hx_model *m);

/* hx_model_check, its texture's coefficients taken as checked when texture_checked is not 0 (the
 * Python binding's copies checked once, haptex.core._ext.checked). */
int hx__model_check(const hx_model *m, int texture_checked);

/* The memoryless field of algorithm m->code at p = [x, y, z] (m): the force f (N) and, when
 * jac is not NULL, the Jacobian jac[3 * i + j] = d f_i / d p_j (N/m), row-major 3 x 3; both
 * zero outside the wall. Returns HX_OK, or HX_NOT_IN_CORE for D, E and F (not yet in C). */
int hx_field(const hx_model *m, const double p[3], double f[3], double jac[9]);

/* ---- presliding (F) ------------------------------------------------------------- */

/* The smooth model's travel table (haptex.friction.smooth_table), in units of d_max: the
 * header [n, ln r, dv, beta] from HX_T_N, then X_j (n values) and dX/dj (n values) from
 * HX_T_DATA, at e_j = r exp(-j dv), r = 1 - z_stick / d_max. */
enum { HX_T_N, HX_T_LOGR, HX_T_DV, HX_T_BETA, HX_T_DATA = 8 };

/* Check F's smooth presliding table (haptex.friction.smooth_table) of n_tab values. */
int hx_presliding_table_check(const double *tab, long n_tab);

/* The smooth model's exact flow: the deflection (m) after the probe moved by dx (m) from
 * deflection `deflection`; adds its table steps to *work (at most 11 + 60). */
double hx_smooth_flow(double deflection, double dx, double d_max, double z_stick, const double *tab, long *work);

/* One step of isotropic presliding in the tangent plane: the deflection d (m) after the
 * in-plane displacement dp (m); z_stick < 0 for the sharp model (tab unused). */
void hx_presliding_plane(double d[2], const double dp[2], double d_max, double z_stick, const double *tab,
                         long *work);

/* ---- closest points (D, E) -------------------------------------------------------- */

/* The search data of a profile (haptex.closest.search_data): a header, then the bound tree,
 * lo[i] = aux[HX_A_TREE + i] and hi[i] = aux[HX_A_TREE + 2 n_leaf + i], i = 1 .. 2 n_leaf - 1;
 * where o = aux[HX_A_LEAFC] is not 0, bounds of h'' over each leaf j = 0 .. n_leaf - 1,
 * aux[o + j] <= h'' <= aux[o + n_leaf + j] (a spline profile's). */
enum { HX_CP_VERTICAL, HX_CP_PERIODIC, HX_CP_FINITE, HX_CP_OPEN };
enum {
    HX_A_MODE, HX_A_START, HX_A_PERIOD, HX_A_TREELEN, HX_A_NLEAF, HX_A_STEP, HX_A_SLOPE, HX_A_CURV, HX_A_HMIN,
    HX_A_TMIN, HX_A_WCAP, HX_A_X0, HX_A_XE, HX_A_HL, HX_A_SL, HX_A_HR, HX_A_SR, HX_A_TIE, HX_A_JERK, HX_A_TABLE,
    HX_A_LEAFC, HX_A_TREE
};

typedef struct {
    double t, y;     /* the closest point's in-plane coordinates (m) */
    double distance; /* its distance to the probe (m); 0 outside the wall */
    int tie;         /* another local minimum at the same distance to the tie tolerance */
    long work;       /* texture evaluations */
    int cut;         /* the evaluation budget ended the search: the best point found, not certified */
} hx_closest;

/* A periodic profile's cell table, from aux[HX_A_TABLE] (haptex.closest.table_search_data): the
 * header HX_TB_*, then per cell (row-major, x fastest) the index in aux of its first piece and
 * its number of pieces (-1: search the tree), then the pieces of HX_PIECE values (lo, hi, kind,
 * m, G): lo and hi relative to the start of the cell's period (m); kind 0 on a piece certified
 * convex for every probe of the cell, with a lower bound m of g' and an upper bound G of |g''|
 * over it (g = phi' / 2), kind 1 on a piece to scan. At most HX_TABLE_MAXP pieces a cell. */
enum { HX_TB_X0, HX_TB_PERIOD, HX_TB_W, HX_TB_NX, HX_TB_Z0, HX_TB_NZ, HX_TB_CELLS };
enum { HX_PIECE = 5, HX_TABLE_MAXP = 16 };

/* Bounds of a profile h over n_leaf leaves of `width` from `start` (the bound tree's leaves):
 * each leaf sampled at n_sub + 1 points; where h' changes sign between two samples the extremum
 * is located by bracketed Newton, elsewhere h is bounded by the larger of the two cubic floors
 * from the interval's ends (jerk bounds |h'''|). Fills lo[i], hi[i]; returns the abscissa of the
 * lowest height found, that height in *best_h. */
double hx_leaf_bounds(const hx_texture *tex, double start, double width, long n_leaf, long n_sub, double jerk,
                      double *lo, double *hi, double *best_h);

/* The pieces of one cell [cx - w/2, cx + w/2] x [zlo, zhi] of a periodic profile's cell table
 * into row (HX_PIECE x HX_TABLE_MAXP values, lo and hi relative to x0), from the profile's search
 * data aux without a table: the window |t - cx| <= U + 2 r (U a distance from the centre to the
 * boundary, r the half-diagonal: the distance is 1-Lipschitz) cut in dyadic intervals, each
 * dropped (out of reach, or strictly concave for every probe), certified convex, or halved down
 * to w / 8 and kept to scan. Returns their number, 0 for a cell above the boundary, or
 * HX_TABLE_MAXP + 1 as soon as there are more. */
long hx_table_cell(const hx_texture *tex, const double *aux, double x0, double w, double cx, double zlo, double zhi,
                   double *row);

/* Check a profile's search data of naux values: every read of the search stays inside it. */
int hx_closest_aux_check(const double *aux, long naux);

/* The closest point of the profile's boundary to (px, pz) below it, given the vertical depth
 * dv = h(px) - pz (m; <= 0: outside, the probe itself), warm-started from t_guess (NaN: none).
 * Certified global to the tie tolerance aux[HX_A_TIE]. */
hx_closest hx_closest_profile(const hx_texture *tex, const double *aux, double px, double pz, double dv,
                              double t_guess);

/* The constants of a surface's search (haptex.closest.surface_search_data): lowest and
 * highest height (m), sup |grad h|, sup ||H|| (1/m), the leaf half-width (m), the tie
 * tolerance (m); rigorous bounds for the Taylor bound (||H||_2, |grad h|, the third
 * derivatives; over a map, inside it) and the convexity certificate (gratings, periodic maps;
 * 0 otherwise); the evaluation budget of one search (0: none but the structure's, MAX_NODES
 * cells); a non-periodic map's edge bounds. */
enum {
    HX_G_HMIN, HX_G_SLOPE, HX_G_CURV, HX_G_LEAF, HX_G_TIE, HX_G_HMAX, HX_G_CONVEX, HX_G_JERK, HX_G_SLOPE_BOUND,
    HX_G_CURV_BOUND, HX_G_BUDGET, HX_G_EDGE, HX_G_PYRAMID = HX_G_EDGE + 28, HX_N_GAUX
};
/* A height map's bounds pyramid (optional: aux[HX_G_PYRAMID] values from aux[HX_N_GAUX], 0 for
 * none): a header of HX_PY_HEAD values
 * (the map's patches nx, ny; the base level's block of 2^s patches a side; the number of
 * levels L; 0 levels: none), then level l = 0 .. L - 1 with blocks of 2^(s + l) patches a side,
 * ceil(nx / 2^(s + l)) x ceil(ny / 2^(s + l)) of them (row-major in x), HX_PY_N values each:
 * rigorous min h, max h, sup |grad h|, sup ||H||_2, the third derivatives' norm over the
 * block (haptex.SampledSurface.bounds_pyramid). The search bounds a cell inside the map by the
 * blocks that cover it, instead of the map's global bounds. */
enum { HX_PY_NX, HX_PY_NY, HX_PY_SHIFT, HX_PY_LEVELS, HX_PY_HEAD };
enum { HX_PY_HMIN, HX_PY_HMAX, HX_PY_SLOPE, HX_PY_CURV, HX_PY_JERK, HX_PY_N };
/* A non-periodic height map's edges beyond which h = H(t) + G(t) e (the tangent-plane
 * extension: e >= 0 the distance beyond the edge, t along it): HX_N_E bounds each, for the
 * edges x = x0, x = x1, y = y0, y = y1 in this order from aux[HX_G_EDGE]: |d^(p+q) h / dn^p dt^q|
 * at the edge for (p, q) = (1, 0), (0, 1), (1, 1), (0, 2), (1, 2), (0, 3), (1, 3), n the
 * outward normal's axis (haptex.SampledSurface.edge_bounds). */
enum { HX_E_N, HX_E_T, HX_E_NT, HX_E_TT, HX_E_NTT, HX_E_TTT, HX_E_NTTT, HX_N_E };

/* The strong-convexity certificate (gratings, periodic maps): Newton answers first where phi / 2
 * is certified HX_CONVEX_MIN-strongly convex on the whole plane, in at most HX_CONVEX_EVALS
 * texture evaluations, then the branch and bound. */
#define HX_CONVEX_MIN 0.05
enum { HX_CONVEX_EVALS = 16 };

/* Check a surface's search constants (HX_N_GAUX values, and the bounds pyramid after them
 * when naux > HX_N_GAUX): every read of the search stays inside naux values. */
int hx_surface_aux_check(const double *aux, long naux);

/* The closest point of the surface (a sum of gratings or a height map's patches) to the probe
 * (px, py, pz), warm-started from (gx0, gy0) (NaN: none). Certified global to aux[HX_G_TIE]
 * by Taylor bounds (aux[HX_G_JERK] > 0): over a height map with edges on both sides of them,
 * cells cut at the edge lines (aux[HX_G_EDGE...] bound the extension beyond); over a map
 * joined only continuously (HX_PATCH_JOINS), within one patch, cells cut at its lines. Bounded work
 * (past it, leaves refined by projected Newton: not certified), counted. */
hx_closest hx_closest_surface(const hx_texture *tex, const double *aux, double px, double py, double pz, double gx0,
                              double gy0);

/* ---- the servo tick ------------------------------------------------------------- */

/* An algorithm's state in a servo loop (mutable; zero it to start). */
typedef struct {
    int contact;   /* W: a previous sample exists; F: in contact (its adhesion point is set) */
    double last_z; /* W: the previous sensed p^z (m) */
    double adh[2]; /* F: the adhesion point in the plane (m) */
    double last[2];/* F: the previous in-plane position (m) */
    double pen;    /* the penetration of the last tick (Table I's, >= 0, m) */
    double h;      /* the height under the probe the last tick evaluated (m), NaN if none */
    long work;     /* texture evaluations of the last tick (on a mesh: plus nodes and triangles visited) */
    int cut;       /* the last tick's closest-point search was ended by its budget */
    long tri;      /* on a mesh: the last tick's closest triangle (its warm start) */
} hx_state;

/* F's presliding state stepped to the coordinates q (m: the plane's (x, y), an object's u):
 * contact starts with the adhesion point at q; the step from the last coordinates (less `turn`,
 * the period of a closed coordinate, across its seam; 0: none) moves the deflection d = q - w by
 * the presliding model (hx_presliding_plane, eq. 24); d returned, the adhesion point and the last
 * coordinates updated. */
HX_INLINE void hx__presliding_step(const hx_model *m, hx_state *s, const double q[2], double turn, double d[2])
{
    double dp[2];
    if (!s->contact) {
        s->contact = 1;
        s->adh[0] = s->last[0] = q[0];
        s->adh[1] = s->last[1] = q[1];
    }
    d[0] = s->last[0] - s->adh[0];
    d[1] = s->last[1] - s->adh[1];
    dp[0] = q[0] - s->last[0];
    dp[1] = q[1] - s->last[1];
    if (turn > 0.0) {
        if (dp[0] > 0.5 * turn)
            dp[0] -= turn;
        else if (dp[0] < -0.5 * turn)
            dp[0] += turn;
    }
    hx_presliding_plane(d, dp, m->prm[HX_P_DXMAX], m->prm[HX_P_ZSTICK], m->aux, &s->work);
    s->adh[0] = q[0] - d[0];
    s->adh[1] = q[1] - d[1];
    s->last[0] = q[0];
    s->last[1] = q[1];
}

/* Where the god-object's descent starts: the proxy's coordinates in contact (s->contact 1), the
 * last free foot (2), else the probe's own foot. */
HX_INLINE void hx__proxy_start(const hx_state *s, const double foot[2], double u[2])
{
    const double *from = s->contact == 1 ? s->adh : (s->contact == 2 ? s->last : foot);
    u[0] = from[0];
    u[1] = from[1];
}

/* Whether the core's tick takes algorithm `code` on base b: A, B, C, F, G and the proxy on every
 * base, D and E on the analytic ones and on the prism mesh (a faceted mesh's textured surface is
 * not a patch over u: not written). */
HX_INLINE int hx__on_base(int code, const hx_base *b)
{
    return code == HX_ALG_A || code == HX_ALG_B || code == HX_ALG_C || code == HX_ALG_F || code == HX_ALG_G ||
           code == HX_ALG_PROXY || ((code == HX_ALG_D || code == HX_ALG_E) && (b->kind != HX_BASE_MESH || b->prism));
}

/* F's friction gain -mu kappa_0 d_z (1 - scale h) / d^x_max (eq. 22), d_z the depth clamped at
 * d^z_max (Remark 3): the friction force is this times the deflection. */
HX_INLINE double hx__friction_gain(const hx_model *m, double depth, double h)
{
    if (m->prm[HX_P_DZMAX] > 0.0 && depth > m->prm[HX_P_DZMAX])
        depth = m->prm[HX_P_DZMAX];
    return -m->prm[HX_P_MU] * m->prm[HX_P_K0] * depth * (1.0 - m->prm[HX_P_SCALE] * h) / m->prm[HX_P_DXMAX];
}

/* The force of one servo tick (N) at p (m): the field, plus W's virtual damper
 * (Colgate & Schenkel 1997), or F's presliding friction, from the state; updates the state.
 * HX_OK or HX_NOT_IN_CORE (D, E). */
int hx_tick_force(const hx_model *m, hx_state *s, const double p[3], double f[3]);

/* Forces the passivity observer remembers: a computation delay of up to HX_PC_RING - 1 ticks. */
#define HX_PC_RING 17

/* The stabilisers (hx_passivity.mode): the time-domain passivity controller of Hannaford &
 * Ryu (2002) with a zero reference, or with the energy stored at the algorithm's penetration
 * as reference (Ryu et al. 2005); energy bounding after Kim & Ryu (2004); passive
 * set-position modulation after Lee & Huang (2010). */
#define HX_STAB_PC 0
#define HX_STAB_PC_STORED 1
#define HX_STAB_EBA 2
#define HX_STAB_PSPM 3
#define HX_N_STAB 4

/* The passivity observer over [x, y, z] and a stabiliser acting on what it sees. */
typedef struct {
    int on;           /* the stabiliser acts (else observe only) */
    int mode;         /* HX_STAB_* */
    int delay;        /* ticks between sending a force and its acting on the device, 0..HX_PC_RING-1 */
    double bmax;      /* PC: the largest damping it adds; EBA, PSPM: the device's physical damping b
                       * whose dissipation, at least b |dp|^2 / T a sample, pays for energy (N s/m) */
    double T;         /* servo period (s) */
    double E;         /* energy the virtual environment absorbed at the port (J) */
    double e_axis[3]; /* E per axis (J) */
    double credit;    /* EBA, PSPM: the dissipation credited so far, sum b |dp|^2 / T over the
                       * ticks in contact (penetration > 0) (J) */
    double alpha;     /* PC: damping added on the last tick (N s/m); EBA, PSPM: the force removed (N) */
    long active;      /* ticks on which the stabiliser changed the force */
    int have;         /* last[] holds the previous tick's sensed position */
    long sent;        /* forces sent (zero on a fault) since the start */
    double last[3];
    double hist[HX_PC_RING][3]; /* the forces sent, tick sent % HX_PC_RING */
} hx_passivity;

/* Observe the energy of the force that acted over the last sample (sent delay ticks before
 * it) over the displacement sensed since; then, when on, the stabiliser of `mode` changes f
 * in place: PC adds the damping -alpha v that covers a deficit below its reference, alpha <=
 * bmax; EBA scales f so that the observer's energy plus the credit covers the most that f and
 * the forces still in flight can generate, T |f|^2 / (4 b) each; PSPM scales f so that a
 * coupling spring of stiffness k0 holding it stores no more than the observer's energy plus
 * the credit. Call hx_passivity_sent with the force actually sent, or hx_passivity_skip when a
 * fault sends none. */
void hx_passivity_tick(hx_passivity *pc, const double p[3], double f[3], double k0, double pen);
void hx_passivity_sent(hx_passivity *pc, const double p[3], const double f[3]);
void hx_passivity_skip(hx_passivity *pc);

/* Scale f down to magnitude fmax without overflow (infinite components: their directions
 * kept); 1 when it scaled, 0 otherwise. NaN in, NaN out (the caller counts a fault). */
int hx_saturate(double f[3], double fmax);

/* ---- data-driven vibration (hx_vibration.c): ARMA models over (speed, force) ---- */
enum { HX_VIB_MAX_ORDER = 64, HX_VIB_MAX_MODELS = 512 };
enum {
    HX_V_N = 0, HX_V_NTRI = 1, HX_V_P = 2, HX_V_Q = 3, HX_V_FS = 4, /* models, triangles, orders, rate (Hz) */
    HX_V_SSCALE = 5, HX_V_FSCALE = 6, /* speed (m/s) and force (N) scales of the triangulation */
    HX_V_HEAD = 8,
    HX_V_ROW = 4 /* a model's row: speed, force, variance, gain, then its p + q LSF */
};
typedef struct {
    double y[HX_VIB_MAX_ORDER]; /* past outputs (m/s^2), most recent first */
    double e[HX_VIB_MAX_ORDER]; /* past noise samples */
    unsigned long long seed, count; /* the generator's seed and the next sample's index */
    long tri;     /* the triangle of the last tick (the first one tested) */
    long clamped; /* ticks whose operating point was moved to the hull */
    long faults;  /* ticks with a non-finite operating point (0 returned) */
    long work;    /* triangles and edges tested on the last tick */
} hx_vib_state;
int hx_vib_check(const double *v, long nv);
void hx_vib_reset(hx_vib_state *st, unsigned long long seed);
double hx_vib_step(const double *v, hx_vib_state *st, double speed, double force);
void hx_lsf_to_poly(const double *w, int order, double *a);
double hx_normal(unsigned long long seed, unsigned long long index);

/* The vibration channel of a tick (the renderer's and the simulator's): model set `set` (or
 * NULL), in contact, gain * mass * y_n along the direction of the tangential velocity, the
 * operating point the filtered tangential speed (first order, time constant tau) and the
 * algorithm's normal force f_z; the tick's period is the set's (1 / its rate).
 * Its energy budget, a tank: when budgeted, `budget` W refill it every tick up to `reserve` J,
 * the vibration's work on the sensed motion drains it, and a vibration force whose work over the
 * next period (at the filtered speed) would exceed what it holds is scaled down to it (`cut`
 * counts those ticks); what the vibration supplied is `supplied` either way. */
typedef struct {
    const double *set;
    double mass, gain, tau; /* kg, 1, s */
    double period, alpha;   /* the set's period (s), the speed filter's gain a tick (1 - exp(-T / tau)) */
    hx_vib_state vs;
    double last[3], v[3]; /* the last position (m), the filtered velocity (m/s) */
    int have;             /* last holds a position */
    double force;         /* the vibration's force on the last tick (N, signed along its direction) */
    int budgeted;
    double budget, reserve, tank; /* W, J, J */
    double supplied;              /* J: sum of the vibration force . dp (> 0: supplied) */
    double prev[3];               /* the vibration force of the last tick (N) */
    long cut;
    /* the material's kinetic friction (HaTT's renderer beside its vibration): mu f_z against the
     * filtered tangential velocity, viscous (in proportion to the speed) below v_friction;
     * mu = 0: none. Its force held over each period times the displacement since is summed,
     * negated, in dissipated (J, >= 0 for a friction that opposes the motion) */
    double mu, v_friction;
    double dissipated;
    double fprev[3];
} hx_vib_channel;
/* Set the channel (v hx_vib_check'd and kept by the caller; NULL: none) and clear its state. */
void hx_vib_channel_set(hx_vib_channel *c, const double *v, double mass, double gain, double tau,
                        unsigned long long seed, double budget, double reserve);
/* Turn the material's friction on (mu > 0, v_threshold > 0 m/s) or off (mu = 0), after
 * hx_vib_channel_set (which turns it off). */
void hx_vib_channel_set_friction(hx_vib_channel *c, double mu, double v_threshold);
/* Its state back to its start: the noise from its seed, the tank full, the sums zero. */
void hx_vib_channel_clear(hx_vib_channel *c);
/* One tick at the sensed position p (m): adds the vibration's force to f (N; f[2] is the
 * algorithm's normal force); returns the triangles and edges its search tested. */
long hx_vib_channel_tick(hx_vib_channel *c, const double p[3], double f[3]);

/* A renderer: one model, its state, the safety rules and the counters. */
typedef struct {
    hx_model model;
    double max_force; /* N, +inf for none */
    double limit;     /* workspace: |coordinate| beyond it is a fault (m) */
    int monitor;      /* keep the passivity observer */
    hx_state st;
    hx_passivity pc;
    long faults, clamps, work, max_work, cut; /* cut: ticks whose search its budget ended */
    /* data-driven vibration layered on the texture (hx_vibration.c): vib.set == NULL for none */
    hx_vib_channel vib;
    /* the parameter block: a stiffness written by another thread (hx_render_set_stiffness)
     * waits here and is taken at the start of the next tick, never in the middle of one */
    double k0_next;  /* N/m, plain: the flag below says who may touch it */
    int k0_pending;  /* 0 none waits, 1 k0_next waits, 2 a writer or the tick holds it (atomic) */
    long k0_changes; /* stiffnesses taken */
    /* and a whole model (another texture or algorithm, hx_render_set_model): 0 none waits,
     * 1 model_next waits, 2 the tick is copying it (atomic) */
    hx_model model_next;
    int model_pending;
    long model_changes; /* models taken */
} hx_renderer;

/* Hand the renderer a new stiffness kappa_0 (N/m, finite and > 0: the caller checks) from any
 * thread; the next tick takes it before it computes (lock-free: an atomic flag over the value,
 * a later call before that tick replaces it). */
void hx_render_set_stiffness(hx_renderer *r, double k0);

/* Hand the renderer a new model m (hx_model_check'd; its arrays kept alive by the caller until
 * a later model has replaced it) from any one thread; the next tick takes it before it computes,
 * with the algorithm's state cleared (its friction, contact and warm start belong to the old
 * model), the observer, the stabiliser and the vibration going on. A model still waiting is
 * withdrawn (returns 1: it was never used) or, while a tick copies it, waited for (a copy's
 * time); returns 0 when the last model handed was taken or none was waiting. A stiffness still
 * waiting is withdrawn: m's own is the one. */
int hx_render_set_model(hx_renderer *r, const hx_model *m);

/* One servo tick at (x, y, z) (m; y is 0 over a profile): the force to command (N), never
 * NaN, never above max_force; zero for a position not finite or beyond the limit, or a
 * non-finite force (counted in faults, the observer's memory and the contact reset). */
void hx_render_step(hx_renderer *r, double x, double y, double z, double f[3]);

/* Clear the state, the observer and controller's sums and the counters (settings kept). */
void hx_render_reset(hx_renderer *r);
/* The data-driven vibration of model set v (hx_vib_check'd, kept by the caller; NULL: none), its
 * force vib_gain * mass * y_n (mass kg, gain >= 0), the operating point's filter tau (s), the noise
 * from seed; budget W (< 0: unbudgeted) refilling a tank of reserve J; its state cleared. */
void hx_render_set_vibration(hx_renderer *r, const double *v, double mass, double gain, double tau,
                             unsigned long long seed, double budget, double reserve);

/* ---- textured objects (hx_object.c) ------------------------------------------------- */

/* Check a base: its kind, a radius in (0, inf), a mesh's arrays (every node's children and
 * leaves inside them). HX_OK or HX_BAD_COEFFS. */
int hx_base_check(const hx_base *b);

/* Build the hierarchy of n triangles tri (n x 9, m) by median splits along the longest axis
 * of their centroids, into arrays of at least n (order), 2 n x 6 (box), 2 n x 2 (node) values;
 * returns the number of nodes (at most 2 n - 1), its depth at most log2(n) + 2. */
long hx_bvh_build(const double *tri, long n, long *order, double *box, long *node);

/* The closest point of the mesh to p (m): its triangle, barycentric coordinates and squared
 * distance (m^2), starting from triangle warm (its distance bounds the search; -1: none).
 * Exact (the hierarchy's boxes bound every triangle). Returns the nodes and triangles visited. */
long hx_mesh_closest(const hx_base *b, const double p[3], long warm, long *tri, double bary[3], double *dist2);

/* The base's coordinates at p (m): the surface coordinates u (m) and their Jacobian ju (2 x 3,
 * row-major), the signed offset e along the outward normal (m, < 0 inside) and that normal n
 * (the gradient of e). On a mesh: the closest point's (its triangle's normal inside it, turning
 * around an edge or a vertex, signed by their pseudo-normals), warm-started from *tri, which
 * receives the closest triangle; *work receives the nodes and triangles visited. HX_OK, or
 * HX_BAD_COEFFS where the coordinates are undefined (a cylinder's axis, a sphere's poles'
 * axis). */
int hx_base_local(const hx_base *b, const double p[3], long *tri, double u[2], double ju[6], double *e, double n[3],
                  long *work);

/* The force (N) of A, B, C or G of model m on its base m->base at p (m), as haptex.objects'
 * fields (pen = h(u) - e; A: kappa_0 pen n, B: kappa_0 pen nu, C: -kappa_0 pen grad pen, G:
 * -kappa_0 e nu for e < 0, nu = -grad pen / |grad pen|); the state's pen, h, tri and work.
 * HX_OK, HX_NOT_IN_CORE for another letter, HX_BAD_COEFFS where the base's coordinates are
 * undefined. */
int hx_object_force(const hx_model *m, hx_state *s, const double p[3], double f[3]);

/* ---- the servo loop's safety rules (haptex.servo) --------------------------------- */

/* A servo loop around a device: its settings, its state, its counts and an optional trace.
 * Positions and forces are [x, y, z] (y = 0 in the plane); the trace keeps dim columns. */
typedef struct {
    /* settings (set before the first tick) */
    int dim;             /* 2 ([x, z]) or 3 ([x, y, z]) */
    double period;       /* the servo period T (s) */
    double workspace;    /* m: a sample farther than this from the origin is a fault */
    double max_force;    /* N: the loop's own ceiling, whatever computed the force */
    double engage_force; /* N: forces engage once the computed force stayed below this ... */
    long engage_ticks;   /* ... for this many ticks in a row */
    long ramp_ticks;     /* then ramp in linearly over this many ticks */
    double deadline;     /* periods: a sample later than this after the previous one is missed */
    int realtime;        /* the backend paces the loop: deadlines are judged */
    /* state */
    long k;              /* ticks commanded */
    long calm;           /* ticks in a row below engage_force, before engaging */
    long engaged_at;     /* the tick forces engaged at, -1 before */
    int have_wall, late;
    double last_wall, tick_wall; /* s: the previous tick's start, this tick's start */
    /* counts */
    long missed, faults, clamps;
    double max_sent;     /* N: the largest force commanded */
    double work_max, work_sum;      /* s: the loop's own time a tick, sample to command */
    long periods;
    double period_mean, period_m2;  /* s, s^2: the time between samples (Welford's sums) */
    /* the trace: NULL for none, else capacity rows of t (s), p (m), f (N, as sent), engaged */
    long capacity;
    double *rec_t, *rec_p, *rec_f;
    unsigned char *rec_e;
} hx_servo;

/* Zero the state, the counts and the trace pointers; the settings are set by the caller. */
void hx_servo_init(hx_servo *s);

/* Rule 1 on a sample: 1 when p (m) is finite and within the workspace, else 0. */
int hx_servo_usable(const hx_servo *s, const double p[3]);

/* Start a tick at wall-clock time wall (s, any monotonic origin): the period since the
 * previous tick is counted, and the tick is late when it exceeds deadline periods. */
void hx_servo_begin(hx_servo *s, double wall);

/* Rules 1-4 on the force f computed for the sample (t (s), p (m)); fault: the sample or its
 * computation failed (zero, counted). f becomes the force to command: zero before engaging,
 * ramped in, never above max_force, zero on a late tick; never NaN. Counts the tick and keeps
 * it in the trace. */
void hx_servo_command(hx_servo *s, double t, const double p[3], int fault, double f[3]);

/* End the tick begun at hx_servo_begin at wall-clock time wall (s): its own time counted. */
void hx_servo_end(hx_servo *s, double wall);

/* One tick of a renderer under the rules: begin at wall, rule 1 on p, hx_render_step, the
 * rules on its force into f (end it with hx_servo_end). */
void hx_servo_tick(hx_servo *s, hx_renderer *r, double wall, double t, const double p[3], double f[3]);

/* ---- the simulator's lean loop ----------------------------------------------------- */

/* the decoupled per-axis coefficients of one sample, per damping regime and axis: p+ = p +
 * PV v + PW w, v+ = VV v + VW w (w the held force, N), the damping's dissipation CVV v^2 +
 * CVW v w + CWW w^2 (J) */
enum { HX_F_PV, HX_F_PW, HX_F_VV, HX_F_VW, HX_F_CVV, HX_F_CVW, HX_F_CWW, HX_N_FAST };

/* the summary of a run (haptex.simulate reads it) */
enum {
    HX_S_EX, HX_S_EZ, HX_S_DAMP, HX_S_OP, HX_S_KE0, HX_S_KE, HX_S_SAT, HX_S_MAXPEN, HX_S_NSAMP,
    HX_S_TAILSTART_E, HX_S_DIVERGED, HX_S_DIVERGED_WHAT, HX_S_FRIC, HX_S_STUCK, HX_S_EY, HX_S_PC_ACTIVE,
    HX_S_PC_ENERGY, HX_S_VIB_SUPPLIED, HX_S_VIB_CUT, HX_S_VIB_CLAMPED, HX_N_SUMMARY
};

/* what became non-finite first in a diverged run */
enum { HX_DIVERGED_POSITION = 1, HX_DIVERGED_VELOCITY, HX_DIVERGED_FORCE, HX_DIVERGED_ENERGY };

/* One run of the lean loop: its inputs (read) and outputs (written). */
typedef struct {
    int dim;                 /* 2: [x, z]; 3: [x, y, z] */
    int nominal;             /* the algorithm's penetration is p^z (W, F, G), else z < h */
    const double *fast;      /* [2][dim][HX_N_FAST]: outside, inside the wall */
    const double *mass;      /* dim x dim (kg), for the kinetic energy */
    const double *f0;        /* the constant push (N), dim */
    const double *p0, *v0;   /* the start (m, m/s), dim */
    long n_steps;
    double period;           /* T (s) */
    long record_every, n_rec;
    double *rec;             /* n_rec x (4 dim + 4): t, p, v, u, E per axis, E_damp, E_op, KE */
    double *summary;         /* HX_N_SUMMARY */
    long tail_start, n_tail;
    double *tail;            /* dim x n_tail: the positions sampled over the tail */
} hx_lean_run;

/* Run the lean loop of model m. HX_OK; HX_BAD_COEFFS or HX_NOT_IN_CORE (D, E) before any
 * sample. Stops, flagged in the summary, at the first non-finite state. */
int hx_run_lean(const hx_model *m, const hx_lean_run *r);

/* Remove from the tail u (m samples, `stride` doubles apart) its mean and least-squares
 * straight line (steady sliding or drift is not an oscillation), in place, and return half
 * the peak-to-peak of the detrended tail in its first and second halves: the amplitudes of
 * the oscillation verdict (haptex.simulate). */
void hx_tail_amplitudes(double *u, long m, long stride, double *a1, double *a2);

/* One run of the general loop: its inputs (read) and outputs (written). */
typedef struct {
    int dim;                 /* n: 2 ([x, z]) or 3 ([x, y, z]) */
    long nz;                 /* the augmented state's size: 5 n, or 7 n with a structural mode */
    int nominal;             /* the damping regime from p^z (W, F, G), else from z < h */
    int kinematic;           /* the operator prescribes the motion (a path) */
    int pc_on, pc_mode;      /* the stabiliser acts, which one (HX_STAB_*) */
    const double *Phi, *Wd, *Wo; /* [2][nz][nz]: the sample's exact map, the damping's and the
                              * operator's energy forms, outside and inside the wall */
    const double *Bs, *Binv; /* [2][n][n]: the damping matrix, the inverse of the held force's
                              * map to the end velocity (Coulomb friction) */
    const double *fast;      /* [2][n][HX_N_FAST] for a diagonal device pushed by a constant force, else NULL */
    const double *mass;      /* n x n (kg): the motor side's with a structural mode */
    const double *modal;     /* [2][n][n]: the handle's mass M_h and the mode's stiffness K_s, or NULL */
    const double *K, *C;     /* n x n: the operator's stiffness (N/m) and damping (N s/m) */
    const double *f0;        /* the operator's constant force (N), n */
    const double *sp_t, *sp_p; /* the set-point path: times (s), n_setpoints; points (m), n_setpoints x n */
    long n_setpoints;
    const double *vend;      /* the set-point's velocity after its last point (m/s), n */
    double rest_len;         /* an elastic band's rest length (m), 0 for none */
    long n_steps;
    double period;           /* T (s) */
    long delay;              /* samples of computation delay */
    double delta, fres, fmax, fc; /* encoder resolution (m), force resolution (N), max force (N), Coulomb (N) */
    double pc_bmax;          /* PC: its largest damping; EBA, PSPM: the device's damping (N s/m) */
    const double *p0, *v0;   /* the start (m, m/s), n */
    long record_every, n_rec;
    double *rec;             /* n_rec x (4 n + 4) */
    double *summary;         /* HX_N_SUMMARY */
    long tail_start, n_tail;
    double *tail;            /* n x n_tail */
    double *delay_buffer;    /* scratch of (delay + 1) x n */
    hx_vib_channel *vib;     /* a data-driven vibration on the controller's tick (its set's rate the
                              * period's; cleared at the start), or NULL */
} hx_general_run;

/* Run the general loop of model m. HX_OK, or HX_BAD_COEFFS before any sample. Stops, flagged
 * in the summary, at the first non-finite state. */
int hx_run_general(const hx_model *m, const hx_general_run *r);
/* a free rigid handle under a program of held forces, in windows (haptex.identify's model): each
 * step's zero-order-hold coefficients at c + (its index) * c_step (0: one set for every step; n *
 * HX_N_FAST: each step its own, a log's ticks of their own lengths) */
void hx_free_run(long n, const double *c, long c_step, double fc, long windows, long steps, const double *force,
                 double *p0, double *v0, double *pos);

/* The ball's contacts on texture t (haptex.surfaces' felt maps; hx_felt.c): for each of n centres
 * P (n x 2, m) the offset U (n x 2, m, refined in place) that maximises g(u) = H(P + u) +
 * sqrt(r^2 - |u|^2) within the box [lo, hi] (n x 2) and the disc |u| <= rim, by at most `steps`
 * safeguarded Newton steps (a step kept only where it raises g, halved while longer than tol,
 * m; a coordinate at its bound held there while the ascent points out), g there into G (n). */
void hx_contact_ascent(const hx_texture *t, long n, const double *P, double *U, const double *lo, const double *hi,
                       double r, double rim, double tol, int steps, double *G);
/* The grid dilation by a ball's cap (hx_felt.c): for each of n0 x n1 samples (row-major) the largest
 * hp[sample + offset] + lift[k] over the n_off offsets offs (n_off x 2 grid steps, each within
 * [-half0, half0] x [-half1, half1]) of heights hp padded by half0 rows and half1 columns a side
 * (row length p1 = n1 + 2 half1), into best, and the first offset that reaches it into which. */
void hx_grid_dilation(const double *hp, long p1, long n0, long n1, long half0, long half1, const long long *offs,
                      const double *lift, long n_off, double *best, int *which);


#ifdef __cplusplus
}
#endif
#endif
