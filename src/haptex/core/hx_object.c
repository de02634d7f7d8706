/*
 * Textured objects (haptex.objects): a base surface displaced along its normal by the
 * texture's height, and A, B, C, G on it. The base gives each probe position its surface
 * coordinates u (m), their Jacobian, its signed offset e along the outward normal and that
 * normal: in closed form on the plane, the cylinder and the sphere; on a triangle mesh from
 * the closest point, found exactly through a bounding-volume hierarchy. The NumPy fields of
 * haptex.objects are the oracle (tests/test_object_core.py).
 */
#include "hx_core.h"

#include <math.h>
#include <stddef.h>

static double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

static void sub3(double *out, const double *a, const double *b)
{
    out[0] = a[0] - b[0];
    out[1] = a[1] - b[1];
    out[2] = a[2] - b[2];
}

/* ---- the hierarchy ------------------------------------------------------------------ */

static double centroid(const double *tri, long t, int axis)
{
    const double *v = tri + 9 * t;
    return v[axis] + v[3 + axis] + v[6 + axis];
}

/* Reorder a[0 .. n) so that a[k] has the k-th smallest centroid along axis, none smaller
 * after it, none larger before it (Hoare's selection, median-of-three pivots). */
static void select_kth(const double *tri, long *a, long n, long k, int axis)
{
    long lo = 0, hi = n - 1;
    while (hi > lo) {
        double x = centroid(tri, a[lo], axis), y = centroid(tri, a[(lo + hi) / 2], axis),
               z = centroid(tri, a[hi], axis), pivot;
        long i = lo, j = hi;
        pivot = x < y ? (y < z ? y : (x < z ? z : x)) : (x < z ? x : (y < z ? z : y));
        while (i <= j) {
            while (centroid(tri, a[i], axis) < pivot)
                i++;
            while (centroid(tri, a[j], axis) > pivot)
                j--;
            if (i <= j) {
                long t = a[i];
                a[i] = a[j];
                a[j] = t;
                i++;
                j--;
            }
        }
        if (k <= j)
            hi = j;
        else if (k >= i)
            lo = i;
        else
            break;
    }
}

static long build(const double *tri, long *order, double *box, long *node, long first, long count, long *n_node)
{
    long id = (*n_node)++, i, mid;
    double lo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, hi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    double clo[3] = {HUGE_VAL, HUGE_VAL, HUGE_VAL}, chi[3] = {-HUGE_VAL, -HUGE_VAL, -HUGE_VAL};
    int axis = 0, j, c;
    for (i = first; i < first + count; i++) {
        const double *v = tri + 9 * order[i];
        for (j = 0; j < 3; j++) {
            double cj = centroid(tri, order[i], j);
            for (c = 0; c < 3; c++) {
                if (v[3 * c + j] < lo[j])
                    lo[j] = v[3 * c + j];
                if (v[3 * c + j] > hi[j])
                    hi[j] = v[3 * c + j];
            }
            if (cj < clo[j])
                clo[j] = cj;
            if (cj > chi[j])
                chi[j] = cj;
        }
    }
    for (j = 0; j < 3; j++) {
        box[6 * id + j] = lo[j];
        box[6 * id + 3 + j] = hi[j];
    }
    if (count <= HX_BVH_LEAF) {
        node[2 * id] = -1 - first;
        node[2 * id + 1] = count;
        return id;
    }
    for (j = 1; j < 3; j++)
        if (chi[j] - clo[j] > chi[axis] - clo[axis])
            axis = j;
    mid = count / 2;
    select_kth(tri, order + first, count, mid, axis);
    node[2 * id] = build(tri, order, box, node, first, mid, n_node);
    node[2 * id + 1] = build(tri, order, box, node, first + mid, count - mid, n_node);
    return id;
}

long hx_bvh_build(const double *tri, long n, long *order, double *box, long *node)
{
    long i, n_node = 0;
    for (i = 0; i < n; i++)
        order[i] = i;
    if (n > 0)
        build(tri, order, box, node, 0, n, &n_node);
    return n_node;
}

/* the depth below node id (1 for a leaf), or -1 for a node out of order (children must come
 * after their parent: no cycle) or a leaf outside the order array */
static long depth(const hx_base *b, long id)
{
    long l = b->node[2 * id], r = b->node[2 * id + 1], dl, dr;
    if (l < 0) {
        long first = -1 - l;
        return first < b->n_tri && r >= 1 && r <= HX_BVH_LEAF && r <= b->n_tri - first ? 1 : -1;
    }
    if (l <= id || r <= id || l >= b->n_node || r >= b->n_node)
        return -1;
    dl = depth(b, l);
    dr = dl < 0 || dl > HX_BVH_STACK ? -1 : depth(b, r);
    if (dl < 0 || dr < 0)
        return -1;
    return 1 + (dl > dr ? dl : dr);
}

int hx_base_check(const hx_base *b)
{
    long i;
    if (b->kind < 0 || b->kind >= HX_N_BASES)
        return HX_BAD_COEFFS;
    if (b->kind == HX_BASE_CYLINDER || b->kind == HX_BASE_SPHERE)
        return b->radius > 0.0 && isfinite(b->radius) ? HX_OK : HX_BAD_COEFFS;
    if (b->kind != HX_BASE_MESH)
        return HX_OK;
    if (b->n_tri < 1 || b->n_node < 1 || b->n_node > 2 * b->n_tri || b->tri == 0 || b->face == 0 || b->box == 0 ||
        b->node == 0 || b->order == 0)
        return HX_BAD_COEFFS;
    for (i = 0; i < b->n_tri; i++)
        if (b->order[i] < 0 || b->order[i] >= b->n_tri)
            return HX_BAD_COEFFS;
    i = depth(b, 0);
    return i > 0 && i <= HX_BVH_STACK / 2 ? HX_OK : HX_BAD_COEFFS;
}

/* ---- closest points on a mesh --------------------------------------------------------- */

/* The closest point of triangle t (9 values) to p: its barycentric coordinates b, exactly 0
 * on the sides it is not inside of (the Voronoi regions of the corners, sides and face). */
static void closest_on_triangle(const double *t, const double p[3], double b[3])
{
    double ab[3], ac[3], ap[3], bp[3], cp[3], d1, d2, d3, d4, d5, d6, va, vb, vc, v, w;
    sub3(ab, t + 3, t);
    sub3(ac, t + 6, t);
    sub3(ap, p, t);
    d1 = dot3(ab, ap);
    d2 = dot3(ac, ap);
    b[0] = b[1] = b[2] = 0.0;
    if (d1 <= 0.0 && d2 <= 0.0) { /* corner 0 */
        b[0] = 1.0;
        return;
    }
    sub3(bp, p, t + 3);
    d3 = dot3(ab, bp);
    d4 = dot3(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) { /* corner 1 */
        b[1] = 1.0;
        return;
    }
    vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) { /* side 0-1 */
        v = d1 / (d1 - d3);
        b[0] = 1.0 - v;
        b[1] = v;
        return;
    }
    sub3(cp, p, t + 6);
    d5 = dot3(ab, cp);
    d6 = dot3(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) { /* corner 2 */
        b[2] = 1.0;
        return;
    }
    vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) { /* side 0-2 */
        w = d2 / (d2 - d6);
        b[0] = 1.0 - w;
        b[2] = w;
        return;
    }
    va = d3 * d6 - d5 * d4;
    if (va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0) { /* side 1-2 */
        w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        b[1] = 1.0 - w;
        b[2] = w;
        return;
    }
    v = vb / (va + vb + vc); /* inside the face */
    w = vc / (va + vb + vc);
    b[0] = 1.0 - v - w;
    b[1] = v;
    b[2] = w;
}

static double point_distance2(const double *t, const double b[3], const double p[3], double foot[3])
{
    double d2 = 0.0;
    int i;
    for (i = 0; i < 3; i++) {
        foot[i] = b[0] * t[i] + b[1] * t[3 + i] + b[2] * t[6 + i];
        d2 += (p[i] - foot[i]) * (p[i] - foot[i]);
    }
    return d2;
}

static double box_distance2(const double *box, const double p[3])
{
    double d2 = 0.0;
    int i;
    for (i = 0; i < 3; i++) {
        double d = box[i] - p[i];
        if (d < 0.0)
            d = p[i] - box[3 + i];
        if (d > 0.0)
            d2 += d * d;
    }
    return d2;
}

long hx_mesh_closest(const hx_base *b, const double p[3], long warm, long *tri, double bary[3], double *dist2)
{
    long stack[HX_BVH_STACK], top = 0, work = 0, best_t = -1, i;
    double best = HUGE_VAL, bb[3], foot[3];
    if (warm >= 0 && warm < b->n_tri) {
        closest_on_triangle(b->tri + 9 * warm, p, bary);
        best = point_distance2(b->tri + 9 * warm, bary, p, foot);
        best_t = warm;
        work++;
    }
    stack[top++] = 0;
    while (top > 0) {
        long id = stack[--top], l = b->node[2 * id], r = b->node[2 * id + 1];
        work++;
        if (l < 0) {
            for (i = -1 - l; i < -1 - l + r; i++) {
                long t = b->order[i];
                double d2;
                if (t == best_t)
                    continue;
                closest_on_triangle(b->tri + 9 * t, p, bb);
                d2 = point_distance2(b->tri + 9 * t, bb, p, foot);
                work++;
                if (d2 < best) {
                    best = d2;
                    best_t = t;
                    bary[0] = bb[0];
                    bary[1] = bb[1];
                    bary[2] = bb[2];
                }
            }
        } else { /* the nearer child is searched first: pushed last */
            double dl = box_distance2(b->box + 6 * l, p), dr = box_distance2(b->box + 6 * r, p);
            long near = dl <= dr ? l : r, far = dl <= dr ? r : l;
            double dn = dl <= dr ? dl : dr, df = dl <= dr ? dr : dl;
            if (df < best)
                stack[top++] = far;
            if (dn < best)
                stack[top++] = near;
        }
    }
    *tri = best_t;
    *dist2 = best;
    return work;
}

/* ---- the bases' coordinates ------------------------------------------------------------- */

#define FACE_TOL 1e-9 /* a barycentric coordinate above this carries weight (haptex.objects.Mesh) */

static int mesh_local(const hx_base *b, const double p[3], long *tri, double u[2], double ju[6], double *e, double n[3],
                      long *work)
{
    double bary[3], d2, foot[3], w[3], dist;
    const double *t, *fc;
    long id;
    int i, k, weight = 0, corners[3], nw = 0;
    *work = hx_mesh_closest(b, p, *tri, &id, bary, &d2);
    *tri = id;
    t = b->tri + 9 * id;
    fc = b->face + HX_FACE * id;
    point_distance2(t, bary, p, foot);
    sub3(w, p, foot);
    dist = sqrt(d2);
    for (i = 0; i < 2; i++)
        u[i] = bary[0] * fc[HX_FACE_UV + i] + bary[1] * fc[HX_FACE_UV + 2 + i] + bary[2] * fc[HX_FACE_UV + 4 + i];
    for (k = 0; k < 3; k++)
        if (bary[k] > FACE_TOL) {
            weight |= 1 << k;
            corners[nw++] = k;
        }
    if (weight == 7 || dist == 0.0) { /* inside the face: its normal, UV affine in p */
        for (i = 0; i < 3; i++)
            n[i] = fc[HX_FACE_N + i];
        for (i = 0; i < 6; i++)
            ju[i] = fc[HX_FACE_M + i];
        *e = dot3(w, n);
        return HX_OK;
    }
    {
        const double *pseudo;
        double s;
        for (i = 0; i < 6; i++)
            ju[i] = 0.0;
        if (nw >= 2) { /* on a side: corners first < second; u follows the side */
            int first = corners[0], second = corners[1], side = second == first + 1 ? first : 2;
            double dv[3], duv[2], dd;
            pseudo = fc + HX_FACE_EDGE + 3 * side;
            sub3(dv, t + 3 * second, t + 3 * first);
            dd = dot3(dv, dv);
            for (i = 0; i < 2; i++)
                duv[i] = fc[HX_FACE_UV + 2 * second + i] - fc[HX_FACE_UV + 2 * first + i];
            for (i = 0; i < 2; i++)
                for (k = 0; k < 3; k++)
                    ju[3 * i + k] = duv[i] * dv[k] / dd;
        } else { /* at a corner: u stays there */
            int corner = bary[0] >= bary[1] ? (bary[0] >= bary[2] ? 0 : 2) : (bary[1] >= bary[2] ? 1 : 2);
            pseudo = fc + HX_FACE_VERTEX + 3 * corner;
        }
        s = dot3(w, pseudo) >= 0.0 ? 1.0 : -1.0;
        *e = s * dist;
        for (i = 0; i < 3; i++)
            n[i] = s * w[i] / dist;
    }
    return HX_OK;
}

/* The prism map's residual r = p - sum_k b_k (v_k + e N_k) and the inverse G of its Jacobian
 * A = dp / d(b1, b2, e) (rows of G: grad b1, grad b2, grad e) at (b, e); 0 where A is singular. */
static int prism_inverse(const double *v, const double *vn, const double bb[3], double ee, const double p[3],
                         double r[3], double G[9])
{
    double A[9], det;
    int i, j;
    for (i = 0; i < 3; i++) {
        double pos = 0.0;
        for (j = 0; j < 3; j++)
            pos += bb[j] * (v[3 * j + i] + ee * vn[3 * j + i]);
        r[i] = p[i] - pos;
        A[3 * i + 0] = v[3 + i] - v[i] + ee * (vn[3 + i] - vn[i]);
        A[3 * i + 1] = v[6 + i] - v[i] + ee * (vn[6 + i] - vn[i]);
        A[3 * i + 2] = vn[i] + bb[1] * (vn[3 + i] - vn[i]) + bb[2] * (vn[6 + i] - vn[i]);
    }
    G[0] = A[4] * A[8] - A[5] * A[7]; /* the adjugate, then over the determinant */
    G[1] = A[2] * A[7] - A[1] * A[8];
    G[2] = A[1] * A[5] - A[2] * A[4];
    G[3] = A[5] * A[6] - A[3] * A[8];
    G[4] = A[0] * A[8] - A[2] * A[6];
    G[5] = A[2] * A[3] - A[0] * A[5];
    G[6] = A[3] * A[7] - A[4] * A[6];
    G[7] = A[1] * A[6] - A[0] * A[7];
    G[8] = A[0] * A[4] - A[1] * A[3];
    det = A[0] * G[0] + A[1] * G[3] + A[2] * G[6];
    if (!(det != 0.0) || !isfinite(det))
        return 0;
    for (i = 0; i < 9; i++)
        G[i] /= det;
    return 1;
}

/* The prism base (haptex.objects.Mesh with vertex normals): p = sum_k b_k (v_k + e N_k), solved
 * for (b1, b2, e) by HX_PRISM_NEWTON Newton steps from the closest point's, walking to the
 * neighbour across the side opposite the most negative barycentric coordinate (at most
 * HX_PRISM_WALKS walks); u = sum_k b_k uv_k, and the rows of the inverse of dp / d(b1, b2, e)
 * at the solution give grad b1, grad b2 and n = grad e. HX_BAD_COEFFS where the map is
 * singular. */
static int prism_local(const hx_base *b, const double p[3], long *tri, double u[2], double ju[6], double *e, double n[3],
                       long *work)
{
    double bary[3], d2, foot[3], bb[3], ee, G[9], r[3];
    const double *v, *vn, *uv, *nf;
    long id;
    int walk, it, i, j;
    *work = hx_mesh_closest(b, p, *tri, &id, bary, &d2);
    point_distance2(b->tri + 9 * id, bary, p, foot);
    nf = b->face + HX_FACE * id + HX_FACE_N;
    ee = (p[0] - foot[0]) * nf[0] + (p[1] - foot[1]) * nf[1] + (p[2] - foot[2]) * nf[2];
    for (i = 0; i < 3; i++)
        bb[i] = bary[i];
    for (walk = 0; walk < HX_PRISM_WALKS; walk++) {
        int worst = 0;
        v = b->tri + 9 * id;
        vn = b->face + HX_FACE * id + HX_FACE_VN;
        for (it = 0; it < HX_PRISM_NEWTON; it++) {
            if (!prism_inverse(v, vn, bb, ee, p, r, G))
                return HX_BAD_COEFFS;
            bb[1] += G[0] * r[0] + G[1] * r[1] + G[2] * r[2];
            bb[2] += G[3] * r[0] + G[4] * r[1] + G[5] * r[2];
            bb[0] = 1.0 - bb[1] - bb[2];
            ee += G[6] * r[0] + G[7] * r[1] + G[8] * r[2];
        }
        for (i = 1; i < 3; i++)
            if (bb[i] < bb[worst])
                worst = i;
        if (!(bb[worst] < -1e-12))
            break;
        /* the side opposite corner k joins corners k + 1 and k + 2: side (k + 1) % 3 */
        id = (long)b->face[HX_FACE * id + HX_FACE_NEXT + (worst + 1) % 3];
        if (id < 0 || id >= b->n_tri)
            return HX_BAD_COEFFS;
        bb[0] = bb[1] = bb[2] = 1.0 / 3.0; /* from the new triangle's centre, at the same offset */
        (*work)++;
    }
    v = b->tri + 9 * id;
    vn = b->face + HX_FACE * id + HX_FACE_VN;
    if (!prism_inverse(v, vn, bb, ee, p, r, G)) /* (at the solution) */
        return HX_BAD_COEFFS;
    uv = b->face + HX_FACE * id + HX_FACE_UV;
    for (i = 0; i < 2; i++) {
        double d1 = uv[2 + i] - uv[i], d2u = uv[4 + i] - uv[i]; /* du_i / db1, du_i / db2 */
        u[i] = bb[0] * uv[i] + bb[1] * uv[2 + i] + bb[2] * uv[4 + i];
        for (j = 0; j < 3; j++)
            ju[3 * i + j] = d1 * G[j] + d2u * G[3 + j];
    }
    for (j = 0; j < 3; j++)
        n[j] = G[6 + j];
    *e = ee;
    *tri = id;
    return HX_OK;
}

int hx_base_local(const hx_base *b, const double p[3], long *tri, double u[2], double ju[6], double *e, double n[3],
                  long *work)
{
    double R = b->radius, x = p[0], y = p[1], z = p[2] + R, rho, r;
    int i;
    *work = 0;
    for (i = 0; i < 6; i++)
        ju[i] = 0.0;
    switch (b->kind) {
    case HX_BASE_PLANE: /* u = (x, y), e = z */
        u[0] = p[0];
        u[1] = p[1];
        ju[0] = ju[4] = 1.0;
        *e = p[2];
        n[0] = n[1] = 0.0;
        n[2] = 1.0;
        return HX_OK;
    case HX_BASE_CYLINDER: /* axis along y through (0, 0, -R): u = (R phi, y), phi = atan2(x, z + R) */
        rho = hypot(x, z);
        if (rho == 0.0)
            return HX_BAD_COEFFS;
        u[0] = R * atan2(x, z);
        u[1] = y;
        ju[0] = R * z / (rho * rho);
        ju[2] = -R * x / (rho * rho);
        ju[4] = 1.0;
        *e = rho - R;
        n[0] = x / rho;
        n[1] = 0.0;
        n[2] = z / rho;
        return HX_OK;
    case HX_BASE_SPHERE: /* centre (0, 0, -R): u = (R phi, R lambda), lambda = atan2(y, rho) */
        rho = hypot(x, z);
        if (rho == 0.0)
            return HX_BAD_COEFFS;
        r = sqrt(rho * rho + y * y);
        u[0] = R * atan2(x, z);
        u[1] = R * atan2(y, rho);
        ju[0] = R * z / (rho * rho);
        ju[2] = -R * x / (rho * rho);
        ju[3] = -R * y * x / (rho * r * r);
        ju[4] = R * rho / (r * r);
        ju[5] = -R * y * z / (rho * r * r);
        *e = r - R;
        n[0] = x / r;
        n[1] = y / r;
        n[2] = z / r;
        return HX_OK;
    case HX_BASE_MESH:
        return b->prism ? prism_local(b, p, tri, u, ju, e, n, work) : mesh_local(b, p, tri, u, ju, e, n, work);
    default:
        return HX_BAD_COEFFS;
    }
}

/* ---- the letters on a base ------------------------------------------------------------- */

/* one letter's force from the base's normal n, the offset e, the penetration pen = h - e and
 * its gradient gp, inside the wall (kappa_0 = k) */
/* A, B, C, G on a base: f = kappa_0 (s n - s_l a), divided by |a - n| = |grad pen| for B and G
 * (along the textured surface's normal), kappa_0 s n for A. n is the base's normal, a = J_u^T
 * grad h the texture's part of grad pen = a - n, s the scale (pen, or -e for G) and s_l = min(s,
 * d^z_max) (Remark 3 on the base: on the plane a is the lateral part and this is the paper's clamp). */
typedef void (*object_fn)(double k, double s, double sl, const double n[3], const double a[3], double f[3]);

static void object_a(double k, double s, double sl, const double n[3], const double a[3], double f[3])
{
    int i;
    (void)sl;
    (void)a;
    for (i = 0; i < 3; i++)
        f[i] = k * s * n[i];
}

static void object_c(double k, double s, double sl, const double n[3], const double a[3], double f[3])
{
    int i;
    for (i = 0; i < 3; i++)
        f[i] = k * (s * n[i] - sl * a[i]);
}

static void object_bg(double k, double s, double sl, const double n[3], const double a[3], double f[3])
{
    double gp[3], g;
    int i;
    for (i = 0; i < 3; i++)
        gp[i] = a[i] - n[i];
    g = sqrt(dot3(gp, gp));
    for (i = 0; i < 3; i++)
        f[i] = g > 0.0 ? k * (s * n[i] - sl * a[i]) / g : 0.0;
}


/* F on a base: the flat base as the wall (its normal force kappa_0 |e| n inside, e < 0, as
 * -kappa_0 p^z on the plane) and the presliding friction of eq. 22-24 in the surface
 * coordinates u (m), which are the local tangent plane's to first order: the adhesion point
 * in u (s->adh), the deflection d = u - w, the tangential force f_u = -mu kappa_0 z_c (1 - h~)
 * d / d_max mapped to space by J_u^T (J_u = du/dp, rows in ju), so that f_u . du is its work.
 * On a cylinder or sphere u1 wraps at +-pi R: a step across the seam is unwrapped. On a mesh
 * u is the UV map's: across a UV seam the step is what the map says (the deflection stays
 * within d_max, as in any slip). */
static int object_f(const hx_model *m, hx_state *s, const double u[2], const double ju[6], double e,
                    const double n[3], double h, double f[3])
{
    double k = m->prm[HX_P_K0], d[2], c, turn = 0.0;
    int i;
    s->pen = e < 0.0 ? -e : 0.0;
    if (!(e < 0.0)) {
        s->contact = 0;
        return HX_OK;
    }
    if (m->base->kind == HX_BASE_CYLINDER || m->base->kind == HX_BASE_SPHERE)
        turn = 6.283185307179586 * m->base->radius; /* 2 pi R: u1 wraps */
    hx__presliding_step(m, s, u, turn, d);
    c = hx__friction_gain(m, -e, h);
    for (i = 0; i < 3; i++)
        f[i] = -k * e * n[i] + ju[i] * c * d[0] + ju[3 + i] * c * d[1];
    return HX_OK;
}

/* S(u) = the point at surface coordinates u and offset e = h(u) on an analytic base, and its
 * Jacobian dS/du (3 x 2, column j in js[j * 3 .. j * 3 + 2]) from the base's closed forms:
 * dS/du_j = dP/du_j + n dh/du_j; the texture's values there in *tout when given. 0 on a mesh (no
 * closed form: not in the core). */
static int analytic_surface_h(const hx_base *b, const hx_texture *tex, const double u[2], double S[3], double js[6],
                              long *work, hx_height *tout)
{
    double R = b->radius, phi, lam, r, sp, cp, sl, cl, n[3], dp[6];
    hx_height t;
    int i;
    hx_texture_eval(tex, u[0], u[1], &t);
    (*work)++;
    switch (b->kind) {
    case HX_BASE_PLANE:
        S[0] = u[0];
        S[1] = u[1];
        S[2] = t.h;
        n[0] = n[1] = 0.0;
        n[2] = 1.0;
        dp[0] = 1.0, dp[1] = 0.0, dp[2] = 0.0, dp[3] = 0.0, dp[4] = 1.0, dp[5] = 0.0;
        break;
    case HX_BASE_CYLINDER: /* ((R + e) sin phi, u2, (R + e) cos phi - R), phi = u1 / R */
        phi = u[0] / R;
        r = R + t.h;
        sp = sin(phi);
        cp = cos(phi);
        S[0] = r * sp;
        S[1] = u[1];
        S[2] = r * cp - R;
        n[0] = sp, n[1] = 0.0, n[2] = cp;
        dp[0] = r / R * cp, dp[1] = 0.0, dp[2] = -r / R * sp;
        dp[3] = 0.0, dp[4] = 1.0, dp[5] = 0.0;
        break;
    case HX_BASE_SPHERE: /* r (cos lam sin phi, sin lam, cos lam cos phi) - (0, 0, R), phi = u1 / R, lam = u2 / R */
        phi = u[0] / R;
        lam = u[1] / R;
        r = R + t.h;
        sp = sin(phi);
        cp = cos(phi);
        sl = sin(lam);
        cl = cos(lam);
        n[0] = cl * sp, n[1] = sl, n[2] = cl * cp;
        for (i = 0; i < 3; i++)
            S[i] = r * n[i];
        S[2] -= R;
        dp[0] = r / R * cl * cp, dp[1] = 0.0, dp[2] = -r / R * cl * sp;
        dp[3] = -r / R * sl * sp, dp[4] = r / R * cl, dp[5] = -r / R * sl * cp;
        break;
    default:
        return 0;
    }
    for (i = 0; i < 3; i++) {
        js[i] = dp[i] + n[i] * t.gx;
        js[3 + i] = dp[3 + i] + n[i] * t.gy;
    }
    if (tout)
        *tout = t;
    return 1;
}

/* analytic_surface_h without the texture's values */
static int analytic_surface(const hx_base *b, const hx_texture *tex, const double u[2], double S[3], double js[6],
                            long *work)
{
    return analytic_surface_h(b, tex, u, S, js, work, NULL);
}

/* The barycentric coordinates of u in triangle t's UV triangle (its affine extension outside)
 * and their gradients in u (dlam[2 k + j] = d lam_k / d u_j); 0 for a degenerate UV triangle. */
static int uv_barycentric(const hx_base *b, long t, const double u[2], double lam[3], double dlam[6])
{
    const double *uv = b->face + HX_FACE * t + HX_FACE_UV;
    double a0 = uv[2] - uv[0], a1 = uv[4] - uv[0], b0 = uv[3] - uv[1], b1 = uv[5] - uv[1];
    double det = a0 * b1 - a1 * b0, r0 = u[0] - uv[0], r1 = u[1] - uv[1];
    if (!(det != 0.0) || !isfinite(det))
        return 0;
    lam[1] = (r0 * b1 - a1 * r1) / det;
    lam[2] = (a0 * r1 - b0 * r0) / det;
    lam[0] = 1.0 - lam[1] - lam[2];
    dlam[2] = b1 / det, dlam[3] = -a1 / det;
    dlam[4] = -b0 / det, dlam[5] = a0 / det;
    dlam[0] = -dlam[2] - dlam[4], dlam[1] = -dlam[3] - dlam[5];
    return 1;
}

/* Steps the walk to the triangle whose UV triangle holds u may take (a proxy moves a little a
 * tick: its walks are short; a UV seam or the map's edge ends one). */
#define HX_UV_WALKS 64

/* The triangle of a mesh whose UV triangle holds u, walked from *t across the side beyond which
 * u's barycentric coordinates put it (the triangle across, HX_FACE_NEXT), at most HX_UV_WALKS
 * steps; its barycentric coordinates in lam and their gradients in u (dlam[2 k + j] = d lam_k /
 * d u_j). 0 where the walk ends outside (a UV seam, the map's edge: the neighbour in space is
 * elsewhere in UV) or at a degenerate UV triangle. */
static int uv_locate(const hx_base *b, const double u[2], long *t, double lam[3], double dlam[6], long *work)
{
    long id = *t;
    int step;
    for (step = 0; step < HX_UV_WALKS; step++) {
        double worst = -1e-12;
        long next;
        int k, side = 0;
        (*work)++;
        if (!uv_barycentric(b, id, u, lam, dlam))
            return 0;
        for (k = 0; k < 3; k++)
            if (lam[k] < worst) {
                worst = lam[k];
                side = (k + 1) % 3; /* the side opposite corner k joins corners k + 1 and k + 2 */
            }
        if (worst == -1e-12) {
            *t = id;
            return 1;
        }
        next = (long)b->face[HX_FACE * id + HX_FACE_NEXT + side];
        if (next < 0 || next >= b->n_tri)
            return 0;
        id = next;
    }
    return 0;
}

/* S(u) and dS/du on triangle t of a mesh (its affine extension in u): the point at offset h(u)
 * along the triangle's normal, or on the prism base along the corners' normals interpolated,
 * sum_k lam_k (v_k + h N_k) (haptex.objects.Mesh.point); the texture's values and the normal
 * interpolated there in *eo and no when given. 0 for a degenerate UV triangle. */
static int mesh_patch_h(const hx_base *b, const hx_texture *tex, long t, const double u[2], double S[3], double js[6],
                        long *work, hx_height *eo, double no[3])
{
    double lam[3], dlam[6], nn[3] = {0.0, 0.0, 0.0};
    const double *v = b->tri + 9 * t, *fc = b->face + HX_FACE * t;
    hx_height e;
    int i, k, j;
    if (!uv_barycentric(b, t, u, lam, dlam))
        return 0;
    hx_texture_eval(tex, u[0], u[1], &e);
    (*work)++;
    for (i = 0; i < 3; i++) {
        S[i] = 0.0;
        js[i] = js[3 + i] = 0.0;
        for (k = 0; k < 3; k++) {
            double nk = b->prism ? fc[HX_FACE_VN + 3 * k + i] : fc[HX_FACE_N + i], vk = v[3 * k + i] + e.h * nk;
            S[i] += lam[k] * vk;
            nn[i] += lam[k] * nk;
            for (j = 0; j < 2; j++)
                js[3 * j + i] += dlam[2 * k + j] * vk;
        }
        js[i] += nn[i] * e.gx;
        js[3 + i] += nn[i] * e.gy;
    }
    if (eo) {
        *eo = e;
        for (i = 0; i < 3; i++)
            no[i] = nn[i];
    }
    return 1;
}

/* mesh_patch_h without the texture's values and the normal */
static int mesh_patch(const hx_base *b, const hx_texture *tex, long t, const double u[2], double S[3], double js[6],
                      long *work)
{
    return mesh_patch_h(b, tex, t, u, S, js, work, NULL, NULL);
}

/* S(u) on a mesh and its Jacobian dS/du (as analytic_surface): mesh_patch on the triangle whose
 * UV triangle holds u (uv_locate from *hint, updated). 0 where no triangle holds u. */
static int mesh_surface(const hx_base *b, const hx_texture *tex, const double u[2], double S[3], double js[6],
                        long *hint, long *work)
{
    double lam[3], dlam[6];
    long id = *hint >= 0 && *hint < b->n_tri ? *hint : 0;
    if (!uv_locate(b, u, &id, lam, dlam, work))
        return 0;
    *hint = id;
    return mesh_patch(b, tex, id, u, S, js, work);
}

/* S(u) and dS/du on any base: in closed form on an analytic one, through the UV map on a mesh
 * (*hint: the triangle to walk from, updated). */
static int surface_at(const hx_model *m, const double u[2], double S[3], double js[6], long *hint, long *work)
{
    if (m->base->kind == HX_BASE_MESH)
        return mesh_surface(m->base, &m->tex, u, S, js, hint, work);
    return analytic_surface(m->base, &m->tex, u, S, js, work);
}

static double sq_dist(const double a[3], const double b[3])
{
    return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
}

/* Gauss-Newton on |S(u) - p|^2 from u on any base (S by surface_at; *hint: a mesh's triangle to
 * walk from, updated): steps at most lmax long, halved until the distance decreases
 * (HX_PROXY_HALVINGS at most; a step off a mesh's UV map counts as no decrease), HX_PROXY_STEPS
 * of them at most; u, S and phi = |S(u) - p|^2 set, the evaluations counted. 0 where S is not
 * defined at the start (off a mesh's UV map). */
static int descend(const hx_model *m, const double p[3], double lmax, double u[2], double S[3], double *phi,
                   long *hint, long *work)
{
    double js[6];
    int it, i;
    if (!surface_at(m, u, S, js, hint, work))
        return 0;
    *phi = sq_dist(S, p);
    for (it = 0; it < HX_PROXY_STEPS; it++) {
        double r[3], a = 0.0, b = 0.0, c = 0.0, g0 = 0.0, g1 = 0.0, det, st[2], nrm, v[2], Sv[3], jv[6], pv = 0.0;
        int j;
        for (i = 0; i < 3; i++) {
            r[i] = S[i] - p[i];
            a += js[i] * js[i];
            b += js[i] * js[3 + i];
            c += js[3 + i] * js[3 + i];
            g0 += js[i] * r[i];
            g1 += js[3 + i] * r[i];
        }
        det = a * c - b * b; /* J^T J, positive definite where the base is regular */
        if (!(det > 0.0))
            break;
        st[0] = -(c * g0 - b * g1) / det;
        st[1] = -(a * g1 - b * g0) / det;
        nrm = hypot(st[0], st[1]);
        if (!isfinite(nrm))
            break;
        if (nrm > lmax) {
            st[0] *= lmax / nrm;
            st[1] *= lmax / nrm;
        }
        for (j = 0; j < HX_PROXY_HALVINGS; j++) { /* halve until the distance decreases */
            long h2 = *hint;
            v[0] = u[0] + st[0];
            v[1] = u[1] + st[1];
            if (surface_at(m, v, Sv, jv, &h2, work)) {
                pv = sq_dist(Sv, p);
                if (pv <= *phi) {
                    *hint = h2;
                    break;
                }
            }
            st[0] *= 0.5;
            st[1] *= 0.5;
        }
        if (j == HX_PROXY_HALVINGS)
            break;
        u[0] = v[0];
        u[1] = v[1];
        for (i = 0; i < 3; i++)
            S[i] = Sv[i];
        for (i = 0; i < 6; i++)
            js[i] = jv[i];
        *phi = pv;
        if (hypot(st[0], st[1]) <= 1e-15 + 1e-12 * hypot(u[0], u[1]))
            break;
    }
    return 1;
}

/* The god-object over a base (haptex.proxy.GodObject with a base): inside (e < h(u) at the
 * probe's own coordinates) the proxy's surface coordinates slide from where they were (the last
 * contact's, else the last free foot's, else the foot's) to the local minimum of |S(u) - p|^2
 * reached by Gauss-Newton steps on S's Jacobian (descend: at most HX_P_DXMAX long; on a mesh S
 * through its UV map, mesh_surface); the force is the spring kappa_0 (S(u) - p). Where a mesh's
 * UV map does not hold the proxy's coordinates (a seam) the descent restarts from the foot; where
 * it cannot, the tick is a fault (zero force). State as over the plane: contact 1 in contact (u
 * in adh), 2 free (the foot in last), 0 no history. */
static int object_proxy(const hx_model *m, hx_state *s, const double p[3], const double foot[2], double e, double h,
                        double f[3])
{
    double k = m->prm[HX_P_K0], u[2], S[3], phi;
    long work = s->work, hint = s->tri; /* (on a mesh: the UV walk starts at the probe's closest triangle) */
    int i;
    s->pen = 0.0;
    if (!(e < h)) {
        s->contact = 2;
        s->last[0] = foot[0];
        s->last[1] = foot[1];
        return HX_OK;
    }
    hx__proxy_start(s, foot, u);
    if (!descend(m, p, m->prm[HX_P_DXMAX], u, S, &phi, &hint, &work)) {
        /* (on a mesh, where the UV map does not hold the proxy's coordinates: a seam) */
        u[0] = foot[0], u[1] = foot[1];
        hint = s->tri;
        if (!descend(m, p, m->prm[HX_P_DXMAX], u, S, &phi, &hint, &work)) {
            s->work = work;
            return HX_BAD_COEFFS; /* (a fault: zero force, as where the coordinates are undefined) */
        }
    }
    s->contact = 1;
    s->adh[0] = u[0];
    s->adh[1] = u[1];
    s->work = work;
    s->pen = sqrt(phi);
    for (i = 0; i < 3; i++)
        f[i] = k * (S[i] - p[i]);
    return HX_OK;
}

/* Cells the closest-point search over an analytic base may hold at once and visit in all. */
#define HX_OBJ_STACK 512
#define HX_OBJ_CELLS 20000

typedef struct {
    double c[2], half[2];
} obj_cell;

/* The u-rectangle that holds every point of the textured object within distance d of p:
 * |S(u) - p| >= 2 r sin(theta / 2), theta the angle at the base's axis or centre between S(u)
 * and p, r the least of their radii (R + h_min, and p's own), so theta <= 2 asin(d / (2 r)); on a
 * sphere a latitude band of that half-width and, unless it reaches a pole, the longitudes
 * asin(sin theta / cos lambda_p) either side; the plane's |u - p_xy| <= d. */
static void search_region(const hx_base *b, const double p[3], const double up[2], double hmin, double d,
                          double lo[2], double hi[2])
{
    double R = b->radius, x = p[0], y = p[1], z = p[2] + R, rp, rmin, th;
    if (b->kind == HX_BASE_PLANE) {
        lo[0] = up[0] - d, hi[0] = up[0] + d;
        lo[1] = up[1] - d, hi[1] = up[1] + d;
        return;
    }
    rp = b->kind == HX_BASE_CYLINDER ? hypot(x, z) : sqrt(x * x + y * y + z * z);
    rmin = R + hmin < rp ? R + hmin : rp;
    th = rmin > 0.0 && d < 2.0 * rmin ? 2.0 * asin(d / (2.0 * rmin)) : 3.141592653589793;
    if (b->kind == HX_BASE_CYLINDER) {
        lo[0] = up[0] - R * th, hi[0] = up[0] + R * th;
        lo[1] = up[1] - d, hi[1] = up[1] + d;
        return;
    }
    {
        double lam = up[1] / R, la = lam - th, lb = lam + th, dphi;
        if (la < -1.5707963267948966)
            la = -1.5707963267948966;
        if (lb > 1.5707963267948966)
            lb = 1.5707963267948966;
        if (fabs(lam) + th < 1.5707963267948966 && sin(th) < cos(lam))
            dphi = asin(sin(th) / cos(lam));
        else
            dphi = 3.141592653589793;
        lo[0] = up[0] - R * dphi, hi[0] = up[0] + R * dphi;
        lo[1] = R * la, hi[1] = R * lb;
    }
}

/* S's second derivatives at u on an analytic base (s2: d2S/du1^2, d2S/du1 du2, d2S/du2^2, 3
 * values each) from the texture's values t there: S = (R + h) w - R e_z with w the unit radial
 * (the plane: S = (u, h), w = e_z), so S_ij = h_ij w + h_i w_j + h_j w_i + (R + h) w_ij. */
static void analytic_second(const hx_base *b, const double u[2], const hx_height *t, double s2[9])
{
    double R = b->radius, w[3] = {0.0, 0.0, 1.0}, w1[3] = {0.0, 0.0, 0.0}, w2[3] = {0.0, 0.0, 0.0};
    double w11[3] = {0.0, 0.0, 0.0}, w12[3] = {0.0, 0.0, 0.0}, w22[3] = {0.0, 0.0, 0.0}, r = 0.0;
    double sp, cp, sl, cl, R2;
    int i;
    if (b->kind == HX_BASE_CYLINDER) {
        sp = sin(u[0] / R), cp = cos(u[0] / R), R2 = R * R, r = R + t->h;
        w[0] = sp, w[1] = 0.0, w[2] = cp;
        w1[0] = cp / R, w1[2] = -sp / R;
        w11[0] = -sp / R2, w11[2] = -cp / R2;
    } else if (b->kind == HX_BASE_SPHERE) {
        sp = sin(u[0] / R), cp = cos(u[0] / R), sl = sin(u[1] / R), cl = cos(u[1] / R), R2 = R * R;
        r = R + t->h;
        w[0] = cl * sp, w[1] = sl, w[2] = cl * cp;
        w1[0] = cl * cp / R, w1[2] = -cl * sp / R;
        w2[0] = -sl * sp / R, w2[1] = cl / R, w2[2] = -sl * cp / R;
        w11[0] = -cl * sp / R2, w11[2] = -cl * cp / R2;
        w12[0] = -sl * cp / R2, w12[2] = sl * sp / R2;
        for (i = 0; i < 3; i++)
            w22[i] = -w[i] / R2;
    }
    for (i = 0; i < 3; i++) {
        s2[i] = t->hxx * w[i] + 2.0 * t->gx * w1[i] + r * w11[i];
        s2[3 + i] = t->hxy * w[i] + t->gx * w2[i] + t->gy * w1[i] + r * w12[i];
        s2[6 + i] = t->hyy * w[i] + 2.0 * t->gy * w2[i] + r * w22[i];
    }
}

/* The least of q(d) = g.d + d^T H d / 2 over the box |d1| <= a, |d2| <= b (H symmetric: h11,
 * h12, h22): the interior minimum when H is positive definite and it lies inside, else the least
 * over the four sides (each a quadratic in one variable: its ends and its stationary point). */
static double box_quadratic_min(double g1, double g2, double h11, double h12, double h22, double a, double b)
{
    double best = HUGE_VAL, det = h11 * h22 - h12 * h12, s, x, y, v;
    int side, k;
    if (h11 > 0.0 && det > 0.0) {
        x = -(h22 * g1 - h12 * g2) / det;
        y = -(h11 * g2 - h12 * g1) / det;
        if (fabs(x) <= a && fabs(y) <= b)
            return g1 * x + g2 * y + 0.5 * (h11 * x * x + 2.0 * h12 * x * y + h22 * y * y);
    }
    for (side = 0; side < 4; side++) {
        for (k = 0; k < 3; k++) {
            s = side & 1 ? 1.0 : -1.0;
            if (side < 2) { /* d1 = s a, d2 free in [-b, b] */
                x = s * a;
                y = k == 0 ? -b : (k == 1 ? b : (h22 > 0.0 ? fmax(-b, fmin(b, -(g2 + h12 * x) / h22)) : b));
            } else { /* d2 = s b */
                y = s * b;
                x = k == 0 ? -a : (k == 1 ? a : (h11 > 0.0 ? fmax(-a, fmin(a, -(g1 + h12 * y) / h11)) : a));
            }
            v = g1 * x + g2 * y + 0.5 * (h11 * x * x + 2.0 * h12 * x * y + h22 * y * y);
            if (v < best)
                best = v;
        }
    }
    return best;
}

/* Whether a cell of half-diagonal rho about c holds nothing nearer than the best (phi_best =
 * its squared distance) to the tie tolerance: phi(c) - |grad phi(c)| rho - H rho^2 / 2 bounds
 * phi = |S(u) - p|^2 over the cell from below, H = 2 (lc^2 + (|S(c) - p| + lc rho) K2) >=
 * ||Hess phi|| there (lc >= ||dS/du||, K2 >= ||d2S/du2|| over the cell). */
static int cell_pruned(double phic, double g0, double g1, double rho, double lc, double K2, double phi_best,
                       double tie)
{
    double H = 2.0 * (lc * lc + (sqrt(phic) + lc * rho) * K2), gtie = sqrt(phi_best) - tie;
    return gtie <= 0.0 || phic - hypot(g0, g1) * rho - 0.5 * H * rho * rho >= gtie * gtie;
}

/* phi = |S(u) - p|^2's gradient g = 2 J^T r and Hessian h = 2 (J^T J + sum_k r_k d2S_k) (h11, h12,
 * h22) at u, from S, J (js) and S's second derivatives (s2) there; r = S - p. */
static void phi_derivatives(const double S[3], const double js[6], const double s2[9], const double p[3],
                            double g[2], double h[3])
{
    int i;
    g[0] = g[1] = h[0] = h[1] = h[2] = 0.0;
    for (i = 0; i < 3; i++) {
        double r = S[i] - p[i];
        g[0] += 2.0 * js[i] * r;
        g[1] += 2.0 * js[3 + i] * r;
        h[0] += 2.0 * (js[i] * js[i] + r * s2[i]);
        h[1] += 2.0 * (js[i] * js[3 + i] + r * s2[3 + i]);
        h[2] += 2.0 * (js[3 + i] * js[3 + i] + r * s2[6 + i]);
    }
}

/* S(u), dS/du and S's second derivatives (s2: d2S/du1^2, d2S/du1 du2, d2S/du2^2) on a smooth
 * piece of the object: on an analytic base (t unused), or on triangle t of a prism mesh, u
 * inside its UV triangle; 0 where not (newton's steps stop there). */
typedef int (*piece_fn)(const hx_model *m, long t, const double u[2], double S[3], double js[6], double s2[9],
                        long *work);

static int analytic_piece(const hx_model *m, long t, const double u[2], double S[3], double js[6], double s2[9],
                          long *work)
{
    hx_height e;
    (void)t;
    if (!analytic_surface_h(m->base, &m->tex, u, S, js, work, &e))
        return 0;
    analytic_second(m->base, u, &e, s2);
    return 1;
}

/* On a prism, S = V(u) + h(u) N(u) with V and N affine: d2S_ij = h_ij N + h_i N_j + h_j N_i, N_j
 * = G_N's column j = sum_k N_k d lam_k / du_j. */
static int prism_piece(const hx_model *m, long t, const double u[2], double S[3], double js[6], double s2[9],
                       long *work)
{
    const hx_base *b = m->base;
    const double *fc = b->face + HX_FACE * t;
    double lam[3], dlam[6], nn[3], gn[6];
    hx_height e;
    int i, j, k;
    if (!uv_barycentric(b, t, u, lam, dlam) || lam[0] < -1e-12 || lam[1] < -1e-12 || lam[2] < -1e-12 ||
        !mesh_patch_h(b, &m->tex, t, u, S, js, work, &e, nn))
        return 0;
    for (j = 0; j < 2; j++)
        for (i = 0; i < 3; i++) {
            gn[3 * j + i] = 0.0;
            for (k = 0; k < 3; k++)
                gn[3 * j + i] += dlam[2 * k + j] * (b->prism ? fc[HX_FACE_VN + 3 * k + i] : 0.0);
        }
    for (i = 0; i < 3; i++) {
        s2[i] = e.hxx * nn[i] + 2.0 * e.gx * gn[i];
        s2[3 + i] = e.hxy * nn[i] + e.gx * gn[3 + i] + e.gy * gn[i];
        s2[6 + i] = e.hyy * nn[i] + 2.0 * e.gy * gn[3 + i];
    }
    return 1;
}

/* Newton on phi = |S(u) - p|^2 from u on one smooth piece (piece: exact second derivatives
 * there), *phi its value at u: at most 8 steps, each at most lmax and halved (up to 4 times)
 * until phi decreases; it stops where the Hessian is not positive definite, the step vanishes
 * or leaves the piece. Gauss-Newton alone (descend) converges slowly where the distance is flat
 * around its minimum (towards a centre of curvature: J^T J over-estimates the Hessian there). */
static void newton(const hx_model *m, const double p[3], piece_fn piece, long t, double lmax, double u[2],
                   double *phi, long *work)
{
    double S[3], js[6], s2[9];
    int it, k, i;
    if (!piece(m, t, u, S, js, s2, work))
        return;
    for (it = 0; it < 8; it++) {
        double g[2], h[3], det, st[2], nrm;
        phi_derivatives(S, js, s2, p, g, h);
        det = h[0] * h[2] - h[1] * h[1];
        if (!(h[0] > 0.0 && det > 0.0))
            return;
        st[0] = -(h[2] * g[0] - h[1] * g[1]) / det;
        st[1] = -(h[0] * g[1] - h[1] * g[0]) / det;
        nrm = hypot(st[0], st[1]);
        if (!(isfinite(nrm) && nrm > 1e-16 * (fabs(u[0]) + fabs(u[1]) + 1e-300)))
            return;
        if (nrm > lmax) {
            st[0] *= lmax / nrm;
            st[1] *= lmax / nrm;
        }
        for (k = 0; k < 4; k++) {
            double w[2], Sw[3], jw[6], s2w[9], pw;
            w[0] = u[0] + st[0], w[1] = u[1] + st[1];
            if (!piece(m, t, w, Sw, jw, s2w, work))
                return;
            pw = sq_dist(Sw, p);
            if (pw < *phi) {
                u[0] = w[0], u[1] = w[1];
                *phi = pw;
                for (i = 0; i < 3; i++)
                    S[i] = Sw[i];
                for (i = 0; i < 6; i++)
                    js[i] = jw[i];
                for (i = 0; i < 9; i++)
                    s2[i] = s2w[i];
                break;
            }
            st[0] *= 0.5;
            st[1] *= 0.5;
        }
        if (k == 4)
            return;
    }
}

/* Gauss-Newton from `start` (steps at most lmax), then Newton; the point it reaches replaces the
 * best (ubest, its squared distance *phi) when nearer, or as near with `ties`. */
static void polish(const hx_model *m, const double p[3], double lmax, const double start[2], int ties, double *phi,
                   double ubest[2], long *work)
{
    double v[2], Sv[3], pv;
    long hint = 0; /* (an analytic base: no triangle) */
    v[0] = start[0], v[1] = start[1];
    if (!descend(m, p, lmax, v, Sv, &pv, &hint, work))
        return;
    newton(m, p, analytic_piece, 0, lmax, v, &pv, work);
    if (pv < *phi || (ties && pv == *phi)) {
        *phi = pv;
        ubest[0] = v[0], ubest[1] = v[1];
    }
}

/* The closest point of the textured object S(u) = P(u, h(u)) (an analytic base) to a probe p
 * inside it, whose foot has coordinates up:
 * Gauss-Newton from the foot and from the last closest point (guess, NaN: none) gives the best
 * so far; then a branch and bound over the u-rectangle that can hold anything nearer
 * (search_region) prunes a cell of half-diagonal rho when phi(c) - |grad phi(c)| rho - H rho^2
 * / 2, a lower bound of phi = |S(u) - p|^2 over it (H >= ||Hess phi||: 2 (L^2 + (|S(c) - p| +
 * L rho) K2), L >= ||dS/du||, K2 >= the second derivatives' norm, from the texture's rigorous
 * slope and curvature bounds and the base's radius), reaches the best phi less the tie
 * tolerance (aux[HX_G_TIE] in distance), or when the second-order bound does: phi(c) plus the
 * least over the cell of g.d + d^T H(c) d / 2 (phi's exact gradient and Hessian at c) less the
 * third derivatives' bound times rho^3 / 6 (K3, from the texture's jerk bound: the Taylor bound
 * of the plane search, which prunes the cells around the minimum the first cannot); cells whose
 * half-diagonal is below the leaf size are polished from their centre by Gauss-Newton and then
 * Newton (aux[HX_G_LEAF], the plane search's leaf; Newton converges where the distance is flat
 * around its minimum, towards a centre of curvature, where Gauss-Newton crawls). Work:
 * the evaluations, at most HX_OBJ_CELLS cells and the budget aux[HX_G_BUDGET] (> 0; cut past
 * either: the best point found, not certified). Returns the point's coordinates, its distance
 * and the work. */
static hx_closest object_closest(const hx_model *m, const double p[3], const double up[2], const double guess[2],
                                 double ubest[2])
{
    const double *aux = m->aux;
    const hx_base *b = m->base;
    double R = b->kind == HX_BASE_PLANE ? HUGE_VAL : b->radius, hmin = aux[HX_G_HMIN], hmax = aux[HX_G_HMAX];
    double M = aux[HX_G_SLOPE_BOUND] > 0.0 ? aux[HX_G_SLOPE_BOUND] : aux[HX_G_SLOPE];
    double C = aux[HX_G_CURV_BOUND] > 0.0 ? aux[HX_G_CURV_BOUND] : aux[HX_G_CURV];
    double tie = aux[HX_G_TIE], leaf = aux[HX_G_LEAF], lmax = 4.0 * leaf, budget = aux[HX_G_BUDGET], scale, L, K2;
    double K3;
    double phi, S[3], lo[2], hi[2];
    double u[2];
    long work = 0, visited = 0, hint = 0; /* (an analytic base: no triangle) */
    int top = 0, i, j, n0[2];
    obj_cell stack[HX_OBJ_STACK];
    hx_closest out;
    out.tie = 0;
    out.cut = 0;
    /* |dP/du| <= (R + h_max) / R per column, |n grad h| <= M: L bounds ||dS/du||_2 by its
     * columns' norms; the second derivatives: n's and P's turning (1 / R), h's curvature */
    scale = isinf(R) ? 1.0 : (R + (hmax > 0.0 ? hmax : 0.0)) / R;
    L = 1.4142135623730951 * (scale + M);
    K2 = 2.0 * (C + (isinf(R) ? 0.0 : (2.0 * M + scale) / R));
    /* the third derivatives along a unit direction in u: S = (R + h) w - R e_z, each partial
     * derivative of the unit radial w in (phi, lambda) has norm <= 1, so its k-th along a unit
     * u-direction is at most 2^(k/2) / R^k, and |S3| <= |h3| + 3 sqrt(2) |h2| / R + 6 |h1| / R^2 +
     * 2 sqrt(2) (R + h) / R^3 (hk: h's k-th derivative along it, bounded by the texture's jerk,
     * curvature and slope bounds; the cylinder's and the plane's are smaller); K3 is twice that,
     * as K2 is for the second; 0 (no second-order pruning) without the texture's jerk bound */
    K3 = aux[HX_G_JERK] > 0.0 ? 2.0 * aux[HX_G_JERK] : 0.0;
    if (K3 > 0.0 && !isinf(R))
        K3 += 2.0 * (4.242640687119285 * C / R + (6.0 * M + 2.8284271247461903 * scale) / (R * R));
    u[0] = up[0];
    u[1] = up[1];
    descend(m, p, lmax, u, S, &phi, &hint, &work);
    ubest[0] = u[0], ubest[1] = u[1];
    if (guess[0] == guess[0])
        polish(m, p, lmax, guess, 0, &phi, ubest, &work);
    search_region(b, p, up, hmin, sqrt(phi), lo, hi);
    /* the first cells: about a quarter of the leaf scale's 16 times, at most 16 x 16 */
    for (j = 0; j < 2; j++) { /* (clamped as a double: a span of a kilometre over a leaf is no int) */
        double cells = ceil((hi[j] - lo[j]) / (16.0 * leaf));
        n0[j] = cells >= 16.0 ? 16 : (cells >= 1.0 ? (int)cells : 1);
    }
    for (i = 0; i < n0[0]; i++)
        for (j = 0; j < n0[1] && top < HX_OBJ_STACK; j++) {
            obj_cell *c = &stack[top++];
            c->half[0] = 0.5 * (hi[0] - lo[0]) / n0[0];
            c->half[1] = 0.5 * (hi[1] - lo[1]) / n0[1];
            c->c[0] = lo[0] + (2 * i + 1) * c->half[0];
            c->c[1] = lo[1] + (2 * j + 1) * c->half[1];
        }
    while (top > 0) {
        obj_cell c = stack[--top];
        double Sc[3], js[6], s2[9], g[2], h[3], rho, phic;
        if (++visited > HX_OBJ_CELLS || (budget > 0.0 && (double)work > budget)) {
            out.cut = 1; /* the best point found, not certified */
            break;
        }
        analytic_piece(m, 0, c.c, Sc, js, s2, &work);
        phi_derivatives(Sc, js, s2, p, g, h);
        phic = sq_dist(Sc, p);
        if (phic < phi) {
            phi = phic;
            ubest[0] = c.c[0], ubest[1] = c.c[1];
        }
        rho = hypot(c.half[0], c.half[1]);
        {
            /* ||dS/du|| over the cell: at its centre (Frobenius, >= the 2-norm) plus the
             * second derivatives' bound over the half-diagonal, at most the global L */
            double jf = 0.0, lc;
            for (i = 0; i < 6; i++)
                jf += js[i] * js[i];
            lc = sqrt(jf) + 2.0 * K2 * rho;
            if (lc > L)
                lc = L;
            if (cell_pruned(phic, g[0], g[1], rho, lc, K2, phi, tie))
                continue; /* nothing in it nearer than the best, to the tie tolerance */
            if (K3 > 0.0 && phi > tie * tie) {
                /* the second-order bound: phi(c + d) >= phi(c) + g.d + d^T H d / 2 - B |d|^3 / 6
                 * with H phi's Hessian at c (2 (J^T J + sum_k r_k d2S_k/du2), exact) and B >= the
                 * third derivative of phi along any unit direction over the cell, 2 (3 S1.S2 +
                 * r.S3) (S1, S2, S3 S's along it): B = 2 (3 lc K2 + (|r(c)| + lc rho) K3); the
                 * quadratic's least over the cell's box */
                double B = 2.0 * (3.0 * lc * K2 + (sqrt(phic) + lc * rho) * K3), gt = sqrt(phi) - tie;
                if (phic + box_quadratic_min(g[0], g[1], h[0], h[1], h[2], c.half[0], c.half[1]) -
                        B * rho * rho * rho / 6.0 >=
                    gt * gt)
                    continue; /* likewise, by the second-order bound */
            }
        }
        if (rho <= leaf || top + 4 > HX_OBJ_STACK) {
            polish(m, p, c.half[0] + c.half[1], c.c, 0, &phi, ubest, &work);
            if (rho > leaf)
                out.cut = 1; /* (the stack was full: not subdivided) */
            continue;
        }
        for (i = 0; i < 2; i++)
            for (j = 0; j < 2; j++) {
                obj_cell *d = &stack[top++];
                d->half[0] = 0.5 * c.half[0];
                d->half[1] = 0.5 * c.half[1];
                d->c[0] = c.c[0] + (i ? 0.5 : -0.5) * c.half[0];
                d->c[1] = c.c[1] + (j ? 0.5 : -0.5) * c.half[1];
            }
    }
    polish(m, p, lmax, ubest, 1, &phi, ubest, &work); /* the best cell centre polished (start read first) */
    out.t = ubest[0];
    out.y = ubest[1];
    out.distance = sqrt(phi);
    out.work = work;
    return out;
}

/* Sub-triangles of one triangle's UV domain the textured mesh's search may hold at once. */
#define HX_MESH_STACK 256

typedef struct {
    double c[6]; /* its UV corners (m) */
} uv_cell;

/* The closest point of a textured prism mesh (haptex.objects.Mesh with vertex normals) to a
 * probe p inside it, whose foot has coordinates up on triangle *tri: Gauss-Newton through the UV
 * map from the foot and from the last closest point (guess, NaN: none) gives the best so far;
 * then every triangle whose prism can hold a nearer point (the hierarchy's boxes inflated by
 * max |h|: the patch sum_k lam_k (v_k + h N_k) lies within |h| of the flat triangle) is searched
 * by a branch and bound over its UV triangle, cut in four at the midpoints: a cell of
 * circumradius rho about its centroid c is pruned when phi(c) - |grad phi(c)| rho - H rho^2 / 2,
 * a lower bound of phi = |S(u) - p|^2 over it (H >= ||Hess phi||: 2 (L^2 + (|S(c) - p| + L rho)
 * K2), L >= ||dS/du|| and K2 >= ||d2S/du2|| over the triangle: S is affine in u but for h, so
 * d2S = 2 sym(G_N grad h) + N hess h, G_N = sum_k N_k grad lam_k), reaches the best phi less the
 * tie tolerance, or when the second-order bound over the cell's disc does (phi's exact Hessian at
 * c, the third derivatives bounded by the texture's jerk and curvature bounds: as on the analytic
 * bases); cells smaller than the leaf are polished by Gauss-Newton and Newton in the triangle
 * the descent ends on (newton over prism_piece). Work: the evaluations,
 * at most HX_OBJ_CELLS cells and the budget (cut past either: the best point found). Returns the
 * point's coordinates (ubest), its triangle (*tri), its distance and the work. */
static hx_closest mesh_closest_textured(const hx_model *m, const double p[3], const double up[2],
                                        const double guess[2], long *tri, double ubest[2])
{
    const double *aux = m->aux;
    const hx_base *b = m->base;
    double M = aux[HX_G_SLOPE_BOUND] > 0.0 ? aux[HX_G_SLOPE_BOUND] : aux[HX_G_SLOPE];
    double C = aux[HX_G_CURV_BOUND] > 0.0 ? aux[HX_G_CURV_BOUND] : aux[HX_G_CURV];
    double delta = fmax(fabs(aux[HX_G_HMIN]), fabs(aux[HX_G_HMAX])), tie = aux[HX_G_TIE], leaf = aux[HX_G_LEAF];
    double budget = aux[HX_G_BUDGET], phi = HUGE_VAL, S[3], u[2];
    long work = 0, visited = 0, stack[HX_BVH_STACK], top = 0, hint, best_tri = *tri;
    hx_closest out;
    out.tie = 0;
    out.cut = 0;
    ubest[0] = up[0], ubest[1] = up[1];
    { /* the descents: an upper bound */
        int start;
        for (start = 0; start < 2; start++) {
            double pv;
            if (start == 1 && !(guess[0] == guess[0]))
                break;
            u[0] = start ? guess[0] : up[0];
            u[1] = start ? guess[1] : up[1];
            hint = *tri;
            if (descend(m, p, 4.0 * leaf, u, S, &pv, &hint, &work) && pv < phi) {
                phi = pv;
                ubest[0] = u[0], ubest[1] = u[1];
                best_tri = hint;
            }
        }
    }
    stack[top++] = 0;
    while (top > 0 && !out.cut) {
        long id = stack[--top], l = b->node[2 * id], r = b->node[2 * id + 1], i;
        double reach = sqrt(phi) + delta;
        work++;
        if (l >= 0) {
            if (top + 2 <= HX_BVH_STACK) {
                if (box_distance2(b->box + 6 * l, p) < reach * reach)
                    stack[top++] = l;
                if (box_distance2(b->box + 6 * r, p) < reach * reach)
                    stack[top++] = r;
            }
            continue;
        }
        for (i = -1 - l; i < -1 - l + r && !out.cut; i++) {
            long t = b->order[i];
            const double *fc = b->face + HX_FACE * t, *v = b->tri + 9 * t;
            double bb[3], foot[3], lam[3], dlam[6], L = 0.0, gn = 0.0, K2, K3, flat;
            int sp = 0, k, j, q;
            uv_cell cells[HX_MESH_STACK];
            closest_on_triangle(v, p, bb);
            flat = sqrt(point_distance2(v, bb, p, foot)) - delta;
            work++;
            if (flat > 0.0 && flat * flat >= phi)
                continue; /* its prism lies farther than the best */
            if (!uv_barycentric(b, t, fc + HX_FACE_UV, lam, dlam))
                continue; /* (a degenerate UV triangle holds no surface coordinates) */
            /* L >= ||dS/du||_2 over the triangle (Frobenius norms): the corners' moves, the
             * normals' turning times |h| <= delta, and |grad h| <= M; G_N's norm gn */
            for (j = 0; j < 2; j++)
                for (q = 0; q < 3; q++) {
                    double ev = 0.0, nv = 0.0;
                    for (k = 0; k < 3; k++) {
                        double nk = b->prism ? fc[HX_FACE_VN + 3 * k + q] : fc[HX_FACE_N + q];
                        ev += dlam[2 * k + j] * v[3 * k + q];
                        nv += dlam[2 * k + j] * nk;
                    }
                    L += ev * ev;
                    gn += nv * nv;
                }
            gn = sqrt(gn);
            L = sqrt(L) + delta * gn + M;
            K2 = 2.0 * gn * M + C;
            /* S = V(u) + h(u) N(u), V and N affine on the triangle (|N| <= 1 inside it): along a
             * unit direction S2 = h'' N + 2 h' N' (K2) and S3 = h''' N + 3 h'' N': |S3| <= jerk +
             * 3 C gn; 0 (no second-order pruning) without the texture's jerk bound */
            K3 = aux[HX_G_JERK] > 0.0 ? aux[HX_G_JERK] + 3.0 * C * gn : 0.0;
            for (k = 0; k < 6; k++)
                cells[0].c[k] = fc[HX_FACE_UV + k];
            sp = 1;
            while (sp > 0) {
                uv_cell c = cells[--sp];
                double cu[2], Sc[3], js[6], s2[9], g[2], h[3], rho = 0.0, phic, gtie;
                if (++visited > HX_OBJ_CELLS || (budget > 0.0 && (double)work > budget)) {
                    out.cut = 1;
                    break;
                }
                cu[0] = (c.c[0] + c.c[2] + c.c[4]) / 3.0;
                cu[1] = (c.c[1] + c.c[3] + c.c[5]) / 3.0;
                for (k = 0; k < 3; k++)
                    rho = fmax(rho, hypot(c.c[2 * k] - cu[0], c.c[2 * k + 1] - cu[1]));
                { /* first, without evaluating the texture: the cell's patch lies within delta of
                   * the flat triangle its UV corners map to */
                    double ft[9], fb[3], ff[3], fd;
                    for (k = 0; k < 3; k++) {
                        uv_barycentric(b, t, c.c + 2 * k, lam, dlam);
                        for (q = 0; q < 3; q++)
                            ft[3 * k + q] = lam[0] * v[q] + lam[1] * v[3 + q] + lam[2] * v[6 + q];
                    }
                    closest_on_triangle(ft, p, fb);
                    fd = sqrt(point_distance2(ft, fb, p, ff)) - delta;
                    gtie = sqrt(phi) - tie;
                    if (gtie <= 0.0 || (fd > 0.0 && fd * fd >= gtie * gtie))
                        continue;
                }
                if (!prism_piece(m, t, cu, Sc, js, s2, &work))
                    break;
                phi_derivatives(Sc, js, s2, p, g, h);
                phic = sq_dist(Sc, p);
                if (phic < phi) {
                    phi = phic;
                    ubest[0] = cu[0], ubest[1] = cu[1];
                    best_tri = t;
                }
                if (cell_pruned(phic, g[0], g[1], rho, L, K2, phi, tie))
                    continue; /* nothing in it nearer than the best, to the tie tolerance */
                if (K3 > 0.0) {
                    /* the second-order bound over the cell's disc of radius rho: phi(c + d) >= phi(c)
                     * + g.d + d^T H d / 2 - B rho^3 / 6, H phi's exact Hessian at c (2 (J^T J + sum_k
                     * r_k d2S_k), d2S_ij = h_ij N + h_i N_j + h_j N_i), B = 2 (3 L K2 + (|r(c)| + L
                     * rho) K3) >= the third derivative of phi along any direction; the quadratic's
                     * least over the disc from H's least eigenvalue */
                    double lmin = 0.5 * (h[0] + h[2]) - hypot(0.5 * (h[0] - h[2]), h[1]), gl = hypot(g[0], g[1]);
                    double ql, B;
                    if (lmin > 0.0 && gl <= lmin * rho)
                        ql = -0.5 * gl * gl / lmin;
                    else
                        ql = -gl * rho + 0.5 * lmin * rho * rho;
                    B = 2.0 * (3.0 * L * K2 + (sqrt(phic) + L * rho) * K3);
                    gtie = sqrt(phi) - tie; /* (phi may have just fallen to phic) */
                    if (phic + ql - B * rho * rho * rho / 6.0 >= gtie * gtie)
                        continue; /* likewise, by the second-order bound */
                }
                if (rho <= leaf || sp + 4 > HX_MESH_STACK) {
                    double w[2], Sw[3], pw = HUGE_VAL;
                    long h2 = t;
                    w[0] = cu[0], w[1] = cu[1];
                    if (descend(m, p, rho, w, Sw, &pw, &h2, &work))
                        newton(m, p, prism_piece, h2, rho, w, &pw, &work);
                    if (pw < phi) {
                        phi = pw;
                        ubest[0] = w[0], ubest[1] = w[1];
                        best_tri = h2;
                    }
                    if (rho > leaf)
                        out.cut = 1; /* (the stack was full: not subdivided) */
                    continue;
                }
                { /* the four sub-triangles: the corners' and the midpoints' */
                    double mid[6];
                    for (k = 0; k < 3; k++) {
                        mid[2 * k] = 0.5 * (c.c[2 * k] + c.c[(2 * k + 2) % 6]);
                        mid[2 * k + 1] = 0.5 * (c.c[2 * k + 1] + c.c[(2 * k + 3) % 6]);
                    }
                    for (k = 0; k < 3; k++) { /* corner k with the midpoints of its two sides */
                        uv_cell *d = &cells[sp++];
                        d->c[0] = c.c[2 * k], d->c[1] = c.c[2 * k + 1];
                        d->c[2] = mid[2 * k], d->c[3] = mid[2 * k + 1];
                        d->c[4] = mid[(2 * k + 4) % 6], d->c[5] = mid[(2 * k + 5) % 6];
                    }
                    for (k = 0; k < 6; k++)
                        cells[sp].c[k] = mid[k];
                    sp++;
                }
            }
        }
    }
    *tri = best_tri;
    out.t = ubest[0];
    out.y = ubest[1];
    out.distance = sqrt(phi);
    out.work = work;
    return out;
}

/* D and E over an analytic base or a prism mesh: inside (e < h(u) at the probe's foot), the
 * closest point of the textured object (object_closest, mesh_closest_textured; warm-started from
 * the last one, s->adh); where a mesh's search finds no point, a fault (zero force); D
 * pulls the probe to it, kappa_0 (S(u*) - p); E pushes along the base's normal at the probe by
 * the distance, kappa_0 |S(u*) - p| n. */
static int object_de(const hx_model *m, hx_state *s, const double p[3], const double up[2], double e, double h,
                     const double n[3], double f[3])
{
    double k = m->prm[HX_P_K0], guess[2], ub[2], S[3], js[6];
    long work = s->work, tri = s->tri;
    hx_closest c;
    int i;
    s->pen = 0.0;
    if (!(e < h)) {
        s->contact = 0;
        return HX_OK;
    }
    guess[0] = s->contact ? s->adh[0] : NAN;
    guess[1] = s->contact ? s->adh[1] : NAN;
    if (m->base->kind == HX_BASE_MESH) {
        c = mesh_closest_textured(m, p, up, guess, &tri, ub);
        if (!(c.distance < HUGE_VAL))
            return HX_BAD_COEFFS; /* (no point found: a fault, zero force) */
    } else {
        c = object_closest(m, p, up, guess, ub);
    }
    s->contact = 1;
    s->adh[0] = ub[0];
    s->adh[1] = ub[1];
    s->work = work + c.work;
    s->cut = c.cut;
    s->pen = c.distance;
    if (m->code == HX_ALG_D) {
        if (m->base->kind == HX_BASE_MESH)
            mesh_patch(m->base, &m->tex, tri, ub, S, js, &s->work);
        else
            analytic_surface(m->base, &m->tex, ub, S, js, &s->work);
        for (i = 0; i < 3; i++)
            f[i] = k * (S[i] - p[i]);
    } else {
        for (i = 0; i < 3; i++)
            f[i] = k * c.distance * n[i];
    }
    return HX_OK;
}

/* Where the probe is on its base: the base's coordinates u (m), the rows of du/dp (ju), the
 * signed distance e to the base along its normal n (m, < 0 inside), and the texture at u. */
typedef struct {
    double u[2], ju[6], e, n[3];
    hx_height t;
} object_at;

/* A memoryless field on a base (A, B, C, G): inside, the field's force from the penetration
 * (G: the base's depth -e; the others h(u) - e), its lateral depth (clamped at d^z_max,
 * Remark 3) and the texture's gradient mapped to space (a = J_u^T grad h). */
static int object_field(object_fn fn, int by_base, const hx_model *m, hx_state *s, const object_at *at, double f[3])
{
    double pen = at->t.h - at->e, a[3], dm = m->prm[HX_P_DZMAX];
    int i;
    if (!(by_base ? at->e < 0.0 : pen > 0.0))
        return HX_OK;
    s->pen = by_base ? -at->e : pen;
    for (i = 0; i < 3; i++)
        a[i] = at->ju[i] * at->t.gx + at->ju[3 + i] * at->t.gy;
    fn(m->prm[HX_P_K0], s->pen, dm >= 0.0 && !(s->pen < dm) ? dm : s->pen, at->n, a, f);
    return HX_OK;
}

typedef int (*object_tick_fn)(const hx_model *m, hx_state *s, const double p[3], const object_at *at, double f[3]);

/* A, B, C and G's ticks on a base: the field function of each, and whether the depth is the base's (G) */
#define HX_OBJECT_FIELD_TICK(name, fn, by_base)                                                              \
    static int name(const hx_model *m, hx_state *s, const double p[3], const object_at *at, double f[3])     \
    {                                                                                                        \
        (void)p;                                                                                             \
        return object_field(fn, by_base, m, s, at, f);                                                       \
    }
HX_OBJECT_FIELD_TICK(object_tick_a, object_a, 0)
HX_OBJECT_FIELD_TICK(object_tick_b, object_bg, 0)
HX_OBJECT_FIELD_TICK(object_tick_c, object_c, 0)
HX_OBJECT_FIELD_TICK(object_tick_g, object_bg, 1)

static int object_tick_de(const hx_model *m, hx_state *s, const double p[3], const object_at *at, double f[3])
{
    return object_de(m, s, p, at->u, at->e, at->t.h, at->n, f);
}

static int object_tick_f(const hx_model *m, hx_state *s, const double p[3], const object_at *at, double f[3])
{
    (void)p;
    return object_f(m, s, at->u, at->ju, at->e, at->n, at->t.h, f);
}

static int object_tick_proxy(const hx_model *m, hx_state *s, const double p[3], const object_at *at, double f[3])
{
    return object_proxy(m, s, p, at->u, at->e, at->t.h, f);
}

/* A tick on a base, one function a letter in the order of HX_ALG_* (and the proxy), all of one
 * signature (W has none on objects: hx__on_base refuses it first). */
static const object_tick_fn OBJECT_TICKS[HX_N_ALGS] = {NULL, object_tick_a, object_tick_b, object_tick_c,
                                                       object_tick_de, object_tick_de, object_tick_f, object_tick_g,
                                                       object_tick_proxy};

int hx_object_force(const hx_model *m, hx_state *s, const double p[3], double f[3])
{
    object_at at;
    long tri = s->tri, work = 0;
    int rc;
    f[0] = f[1] = f[2] = 0.0;
    s->pen = 0.0;
    if (!hx__on_base(m->code, m->base) || OBJECT_TICKS[m->code] == NULL)
        return HX_NOT_IN_CORE;
    rc = hx_base_local(m->base, p, &tri, at.u, at.ju, &at.e, at.n, &work);
    s->work = work;
    if (rc != HX_OK)
        return rc;
    s->tri = tri;
    hx_texture_eval(&m->tex, at.u[0], at.u[1], &at.t);
    s->work += 1;
    s->h = at.t.h;
    return OBJECT_TICKS[m->code](m, s, p, &at, f);
}
