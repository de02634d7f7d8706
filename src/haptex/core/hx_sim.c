/*
 * The sampled-data simulator's lean loop: a rigid device with diagonal mass and damping
 * integrated exactly axis by axis over each zero-order-held sample (the decoupled closed
 * forms haptex.simulate._fast_coefficients computes), pushed by a constant force, with none
 * of the general loop's optional machinery (delay, quantisation, force resolution,
 * saturation, Coulomb friction, passivity controller, kinematic operator). Energy
 * accounting: the environment's work per axis, the damping's dissipation, the operator's
 * work, the kinetic energy; the oscillation tail; divergence detection.
 */
#include "hx_core.h"
#include "hx_fields.h"

#include <math.h>
#include <string.h>

/* the per-axis coefficients of one damping regime, c[HX_F_*] */
static void axis_zoh(const double *c, double p, double v, double u, double g, double *np, double *nv, double *de)
{
    double w = u + g;
    *np = p + c[HX_F_PV] * v + c[HX_F_PW] * w;
    *nv = c[HX_F_VV] * v + c[HX_F_VW] * w;
    *de = v * (c[HX_F_CVV] * v + c[HX_F_CVW] * w) + c[HX_F_CWW] * w * w;
}

static double quad(const double *M, const double *v, int n)
{
    double acc = 0.0;
    int i, j;
    for (i = 0; i < n; i++) {
        double row = 0.0;
        for (j = 0; j < n; j++)
            row += M[n * i + j] * v[j];
        acc += v[i] * row;
    }
    return acc;
}

static int diverged(const double *p, const double *v, const double *u, const double *e, double ed, double eo, int n)
{
    int i;
    for (i = 0; i < n; i++)
        if (!isfinite(p[i]))
            return HX_DIVERGED_POSITION;
    for (i = 0; i < n; i++)
        if (!isfinite(v[i]))
            return HX_DIVERGED_VELOCITY;
    for (i = 0; i < n; i++)
        if (!isfinite(u[i]))
            return HX_DIVERGED_FORCE;
    for (i = 0; i < n; i++)
        if (!isfinite(e[i]))
            return HX_DIVERGED_ENERGY;
    return isfinite(ed) && isfinite(eo) ? 0 : HX_DIVERGED_ENERGY;
}

/* The loop, instantiated below once per letter and dimension with ``code`` and ``n`` constants,
 * so that the compiler inlines that letter's field into it and drops the other dimension's
 * branches (numba's loop was compiled likewise). */
HX_INLINE int lean_loop(const hx_model *m, const hx_lean_run *r, const int code, const int n)
{
    const int three = n == 3, nominal = r->nominal;
    const double *fast = r->fast; /* [2][n][HX_N_FAST] */
    hx_state st;
    double x = r->p0[0], y = three ? r->p0[1] : 0.0, z = r->p0[n - 1];
    double vx = r->v0[0], vy = three ? r->v0[1] : 0.0, vz = r->v0[n - 1];
    double gx = r->f0[0], gy = three ? r->f0[1] : 0.0, gz = r->f0[n - 1];
    double ux = 0.0, uy = 0.0, uz = 0.0, ex = 0.0, ey = 0.0, ez = 0.0, ed = 0.0, eo = 0.0, maxpen = 0.0;
    double ke0, e_tail = 0.0, vel[3], *summary = r->summary;
    long n_steps = r->n_steps, k, irec = 0, itail = 0;
    long n_tail = r->n_tail, tail_stride, next_rec, next_tail;
    memset(&st, 0, sizeof st);
    ke0 = 0.5 * quad(r->mass, r->v0, n);
    tail_stride = (n_steps - r->tail_start) / (n_tail > 1 ? n_tail : 1);
    if (tail_stride < 1)
        tail_stride = 1;
    next_rec = r->n_rec > 0 ? r->record_every : -1;
    next_tail = n_tail > 0 ? r->tail_start : -1;
    for (k = 0; k < n_steps; k++) {
        double p[3], f[3], h, pen, nx, nvx, dx, ny = 0.0, nvy = 0.0, dy, nz, nvz, dz;
        int inside, reg;
        p[0] = x;
        p[1] = y;
        p[2] = z;
        hx__tick_force_of(code, m, &st, p, f);
        ux = f[0];
        uy = f[1];
        uz = f[2];
        if (nominal) {
            inside = z < 0.0;
            pen = -z;
        } else {
            h = st.h;
            if (h != h)
                h = hx_texture_height(&m->tex, x, y);
            inside = z < h;
            pen = h - z;
        }
        if (pen > maxpen)
            maxpen = pen;
        reg = inside ? 1 : 0;
        axis_zoh(fast + (reg * n + 0) * HX_N_FAST, x, vx, ux, gx, &nx, &nvx, &dx);
        ed += dx;
        eo += gx * (nx - x);
        if (three) {
            axis_zoh(fast + (reg * n + 1) * HX_N_FAST, y, vy, uy, gy, &ny, &nvy, &dy);
            ed += dy;
            eo += gy * (ny - y);
        }
        axis_zoh(fast + (reg * n + n - 1) * HX_N_FAST, z, vz, uz, gz, &nz, &nvz, &dz);
        ed += dz;
        eo += gz * (nz - z);
        ex -= ux * (nx - x);
        x = nx;
        vx = nvx;
        if (three) {
            ey -= uy * (ny - y);
            y = ny;
            vy = nvy;
        }
        ez -= uz * (nz - z);
        z = nz;
        vz = nvz;
        /* a non-finite state makes this sum NaN or infinite; summed as a tree, not a chain of
         * 14 dependent additions (a chain measured as the loop's largest cost) */
        if (!isfinite(((ed + eo) + (x + vx)) + ((ux + ex) + (y + vy)) + (((uy + ey) + (z + vz)) + (uz + ez)))) {
            double pp[3] = {x, y, z}, vv[3] = {vx, vy, vz}, uu[3] = {ux, uy, uz}, ee[3] = {ex, ey, ez};
            int what;
            if (!three) {
                pp[1] = z;
                vv[1] = vz;
                uu[1] = uz;
                ee[1] = ez;
            }
            what = diverged(pp, vv, uu, ee, ed, eo, n);
            if (what != 0) {
                summary[HX_S_DIVERGED] = (double)(k + 1);
                summary[HX_S_DIVERGED_WHAT] = what;
                n_steps = k + 1;
                break;
            }
        }
        if (k == r->tail_start)
            e_tail = three ? ex + ey + ez : ex + ez;
        if (k == next_tail) {
            if (itail < n_tail) {
                r->tail[itail] = x;
                if (three)
                    r->tail[n_tail + itail] = y;
                r->tail[(n - 1) * n_tail + itail] = z;
                itail++;
                next_tail += tail_stride;
            }
        }
        if (k + 1 == next_rec) {
            double row[3][4] = {{x, vx, ux, ex}, {y, vy, uy, ey}, {z, vz, uz, ez}};
            double *out = r->rec + irec * (4 * n + 4);
            int i;
            next_rec += r->record_every;
            out[0] = (double)k * r->period + r->period;
            for (i = 0; i < n; i++) {
                int a = i == n - 1 ? 2 : i;
                out[1 + i] = row[a][0];
                out[1 + n + i] = row[a][1];
                out[1 + 2 * n + i] = row[a][2];
                out[1 + 3 * n + i] = row[a][3];
                vel[i] = row[a][1];
            }
            out[1 + 4 * n] = ed;
            out[2 + 4 * n] = eo;
            out[3 + 4 * n] = 0.5 * quad(r->mass, vel, n);
            irec++;
            if (irec == r->n_rec)
                next_rec = -1;
        }
    }
    summary[HX_S_EX] = ex;
    summary[HX_S_EZ] = ez;
    summary[HX_S_EY] = ey;
    summary[HX_S_DAMP] = ed;
    summary[HX_S_OP] = eo;
    summary[HX_S_KE0] = ke0;
    vel[0] = vx;
    vel[n - 1] = vz;
    if (three)
        vel[1] = vy;
    summary[HX_S_KE] = 0.5 * quad(r->mass, vel, n);
    summary[HX_S_SAT] = 0.0;
    summary[HX_S_MAXPEN] = maxpen;
    summary[HX_S_NSAMP] = (double)n_steps;
    summary[HX_S_TAILSTART_E] = e_tail;
    summary[HX_S_FRIC] = 0.0;
    summary[HX_S_STUCK] = 0.0;
    summary[HX_S_PC_ACTIVE] = 0.0;
    return HX_OK;
}

typedef int (*lean_fn)(const hx_model *m, const hx_lean_run *r);
#define HX_LEAN(name, code, n) \
    static int name(const hx_model *m, const hx_lean_run *r) { return lean_loop(m, r, code, n); }
HX_LEAN(lean_w2, HX_ALG_W, 2)
HX_LEAN(lean_a2, HX_ALG_A, 2)
HX_LEAN(lean_b2, HX_ALG_B, 2)
HX_LEAN(lean_c2, HX_ALG_C, 2)
HX_LEAN(lean_f2, HX_ALG_F, 2)
HX_LEAN(lean_g2, HX_ALG_G, 2)
HX_LEAN(lean_d2, HX_ALG_D, 2)
HX_LEAN(lean_e2, HX_ALG_E, 2)
HX_LEAN(lean_w3, HX_ALG_W, 3)
HX_LEAN(lean_a3, HX_ALG_A, 3)
HX_LEAN(lean_b3, HX_ALG_B, 3)
HX_LEAN(lean_c3, HX_ALG_C, 3)
HX_LEAN(lean_f3, HX_ALG_F, 3)
HX_LEAN(lean_g3, HX_ALG_G, 3)
HX_LEAN(lean_d3, HX_ALG_D, 3)
HX_LEAN(lean_e3, HX_ALG_E, 3)

/* The letters in the order of HX_ALG_*, per dimension. */
static const lean_fn LEANS[2][HX_N_ALGS] = {
    {lean_w2, lean_a2, lean_b2, lean_c2, lean_d2, lean_e2, lean_f2, lean_g2},
    {lean_w3, lean_a3, lean_b3, lean_c3, lean_d3, lean_e3, lean_f3, lean_g3},
};

int hx_run_lean(const hx_model *m, const hx_lean_run *r)
{
    lean_fn fn;
    if (hx_model_check(m) != HX_OK || (r->dim != 2 && r->dim != 3))
        return HX_BAD_COEFFS;
    fn = LEANS[r->dim - 2][m->code];
    return fn(m, r);
}
