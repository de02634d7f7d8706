/*
 * The sampled-data simulator's lean loop: a rigid device with diagonal mass and damping
 * integrated exactly axis by axis over each zero-order-held sample (the decoupled closed
 * forms haptex.simulate._fast_coefficients computes), pushed by a constant force, with none
 * of the general loop's optional machinery (delay, quantisation, force resolution,
 * saturation, Coulomb friction, passivity controller, kinematic operator). Energy
 * accounting: the environment's work per axis, the damping's dissipation, the operator's
 * work, the kinetic energy; the oscillation tail; divergence detection. And the general loop
 * (hx_run_general): the augmented exact transition over each sample (Van Loan's quadratic
 * forms for the energies), delay, position quantisation, force resolution, saturation, the
 * handle's Coulomb friction (a sampled Karnopp model), a structural mode, the passivity
 * controller, and operators that push, pull through a spring-damper or move on a path.
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

/* v' M v over the first n entries (M row-major n x n): the kinetic energy (halved) and the
 * Van Loan energy forms */
static double quad(const double *M, const double *v, long n)
{
    double acc = 0.0;
    long i, j;
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

/* Samples between the lean loop's finiteness checks. A non-finite position, velocity or energy
 * stays non-finite (NaN and infinity propagate through the zero-order hold and the sums), so a
 * check at a block's end sees any divergence inside it; the block is then run again from its
 * checkpoint with a check every sample, which stops at the first non-finite sample exactly as a
 * check every sample would (the same operations in the same order). */
#define HX_CHECK_BLOCK 64

/* the lean loop's state at a block's start (its checkpoint) */
typedef struct {
    double x, y, z, vx, vy, vz, ux, uy, uz, ex, ey, ez, ed, eo, maxpen, e_tail;
    long k, irec, itail, next_rec, next_tail;
    hx_state st;
} lean_ckpt;

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
    {
    lean_ckpt ck;
    int replay = 0;  /* running a block again from its checkpoint, checking every sample */
    long irec_hi = 0, itail_hi = 0; /* what the block's first pass wrote, to clear past a stop */
    memset(&ck, 0, sizeof ck); /* (set at k = 0, before any use) */
    for (k = 0; k < n_steps; k++) {
        double p[3], f[3], h, pen, nx, nvx, dx, ny = 0.0, nvy = 0.0, dy, nz, nvz, dz;
        int inside, reg;
        if (!replay && k % HX_CHECK_BLOCK == 0) {
            ck.x = x; ck.y = y; ck.z = z; ck.vx = vx; ck.vy = vy; ck.vz = vz;
            ck.ux = ux; ck.uy = uy; ck.uz = uz; ck.ex = ex; ck.ey = ey; ck.ez = ez;
            ck.ed = ed; ck.eo = eo; ck.maxpen = maxpen; ck.e_tail = e_tail;
            ck.k = k; ck.irec = irec; ck.itail = itail; ck.next_rec = next_rec; ck.next_tail = next_tail;
            ck.st = st;
        }
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
         * 14 dependent additions (a chain measured as the loop's largest cost); on a replay
         * every sample, else at a block's end (HX_CHECK_BLOCK) */
        if (!replay && ((k + 1) % HX_CHECK_BLOCK == 0 || k + 1 == n_steps) &&
            !isfinite(((ed + eo) + (x + vx)) + ((ux + ex) + (y + vy)) + (((uy + ey) + (z + vz)) + (uz + ez)))) {
            /* a divergence in this block: run it again from its checkpoint, checking each sample
             * (the first pass's records past its start are rewritten or cleared) */
            irec_hi = irec;
            itail_hi = itail;
            x = ck.x; y = ck.y; z = ck.z; vx = ck.vx; vy = ck.vy; vz = ck.vz;
            ux = ck.ux; uy = ck.uy; uz = ck.uz; ex = ck.ex; ey = ck.ey; ez = ck.ez;
            ed = ck.ed; eo = ck.eo; maxpen = ck.maxpen; e_tail = ck.e_tail;
            irec = ck.irec; itail = ck.itail; next_rec = ck.next_rec; next_tail = ck.next_tail;
            st = ck.st;
            k = ck.k - 1;
            replay = 1;
            continue;
        }
        if (replay && !isfinite(((ed + eo) + (x + vx)) + ((ux + ex) + (y + vy)) + (((uy + ey) + (z + vz)) + (uz + ez)))) {
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
                long j, a;
                summary[HX_S_DIVERGED] = (double)(k + 1);
                summary[HX_S_DIVERGED_WHAT] = what;
                n_steps = k + 1;
                for (j = irec; j < irec_hi; j++) /* rows the first pass wrote past the stop */
                    memset(r->rec + j * (4 * n + 4), 0, (size_t)(4 * n + 4) * sizeof(double));
                for (j = itail; j < itail_hi; j++)
                    for (a = 0; a < n; a++)
                        r->tail[a * n_tail + j] = 0.0;
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
        if (replay && (k + 1) % HX_CHECK_BLOCK == 0)
            replay = 0; /* a replayed block with no divergence: its sum overflowed from finite
                         * values (as a check every sample would let pass too) */
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
    summary[HX_S_PC_ENERGY] = 0.0;
    summary[HX_S_VIB_SUPPLIED] = summary[HX_S_VIB_CUT] = summary[HX_S_VIB_CLAMPED] = 0.0;
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
    {lean_w2, lean_a2, lean_b2, lean_c2, lean_d2, lean_e2, lean_f2, lean_g2, NULL},
    {lean_w3, lean_a3, lean_b3, lean_c3, lean_d3, lean_e3, lean_f3, lean_g3, NULL},
};

int hx_run_lean(const hx_model *m, const hx_lean_run *r)
{
    lean_fn fn;
    if (hx_model_check(m) != HX_OK || (r->dim != 2 && r->dim != 3))
        return HX_BAD_COEFFS;
    fn = LEANS[r->dim - 2][m->code];
    return fn != NULL ? fn(m, r) : HX_NOT_IN_CORE; /* (the proxy: the general loop, or none) */
}

/* ---- the general loop ---------------------------------------------------------------- */

static double row_dot(const double *P, long i, const double *z, long nz)
{
    double acc = 0.0;
    long j;
    for (j = 0; j < nz; j++)
        acc += P[nz * i + j] * z[j];
    return acc;
}

/* the operator's set-point s(t) (m): the polyline (ts, ps), then vend (m/s) */
static void setpoint(const hx_general_run *r, double t, double *out)
{
    long m = r->n_setpoints, lo = 0, hi = m - 1, i, n = r->dim;
    const double *ts = r->sp_t, *ps = r->sp_p;
    if (t >= ts[m - 1]) {
        double dt = t - ts[m - 1];
        for (i = 0; i < n; i++)
            out[i] = ps[(m - 1) * n + i] + r->vend[i] * dt;
        return;
    }
    if (t <= ts[0]) {
        for (i = 0; i < n; i++)
            out[i] = ps[i];
        return;
    }
    while (hi - lo > 1) {
        long mid = (lo + hi) / 2;
        if (ts[mid] <= t)
            lo = mid;
        else
            hi = mid;
    }
    {
        double w = (t - ts[lo]) / (ts[hi] - ts[lo]);
        for (i = 0; i < n; i++)
            out[i] = ps[lo * n + i] + w * (ps[hi * n + i] - ps[lo * n + i]);
    }
}

/* kinetic energy, plus the structural mode's (J) */
static double mech_energy(const hx_general_run *r, const double *v, const double *ph, const double *vh,
                          const double *p)
{
    long n = r->dim, i, j;
    double e = 0.5 * quad(r->mass, v, n);
    if (r->modal != NULL) {
        e += 0.5 * quad(r->modal, vh, n);
        for (i = 0; i < n; i++)
            for (j = 0; j < n; j++)
                e += 0.5 * (p[i] - ph[i]) * r->modal[n * n + n * i + j] * (p[j] - ph[j]);
    }
    return e;
}

/* the handle's Coulomb friction over one sample (a sampled Karnopp model) into out; 1 when the
 * handle ends the sample at rest by stiction */
static int coulomb(const double *a, const double *Binv, const double *v, double fc, long n, double *out)
{
    double nrm = 0.0, sp = 0.0;
    long i, j;
    for (i = 0; i < n; i++) {
        double acc = 0.0;
        for (j = 0; j < n; j++)
            acc -= Binv[n * i + j] * a[j];
        out[i] = acc;
        nrm += acc * acc;
    }
    nrm = sqrt(nrm);
    if (nrm <= fc)
        return 1;
    for (i = 0; i < n; i++)
        sp += v[i] * v[i];
    sp = sqrt(sp);
    if (sp > 0.0) {
        for (i = 0; i < n; i++)
            out[i] = -fc * v[i] / sp;
    } else {
        for (i = 0; i < n; i++)
            out[i] = fc * out[i] / nrm;
    }
    return 0;
}

int hx_run_general(const hx_model *m, const hx_general_run *r)
{
    enum { MAXN = 3, MAXZ = 21 };
    const long n = r->dim, nz = r->nz, last = n - 1;
    const int mode = r->modal != NULL, use_fast = r->fast != NULL;
    hx_state st;
    hx_passivity pc;
    double z[MAXZ] = {0}, p[MAXN], v[MAXN], ph[MAXN], vh[MAXN], sense[MAXN] = {0}, f[MAXN] = {0}, u[MAXN] = {0};
    double g[MAXN] = {0}, rr[MAXN] = {0}, a[MAXN] = {0}, ff[MAXN] = {0}, newp[MAXN], newv[MAXN], e[MAXN] = {0};
    double s0[MAXN] = {0}, s1[MAXN] = {0}, ed = 0.0, eo = 0.0, maxpen = 0.0, ke0, ke_prev, e_tail = 0.0, efr = 0.0;
    double *buf = r->delay_buffer, *summary = r->summary;
    long n_steps = r->n_steps, k, i, j, sat = 0, stuck = 0, irec = 0, itail = 0, n_tail = r->n_tail;
    long tail_stride, next_rec, next_tail, delay = r->delay;
    if (hx_model_check(m) != HX_OK || (n != 2 && n != 3) || nz > MAXZ || nz < 5 * n)
        return HX_BAD_COEFFS;
    memset(&st, 0, sizeof st);
    memset(&pc, 0, sizeof pc);
    pc.on = r->pc_on;
    pc.bmax = r->pc_bmax;
    pc.mode = r->pc_mode;
    pc.T = r->period;
    pc.delay = delay < HX_PC_RING ? (int)delay : HX_PC_RING - 1; /* (the Python side refuses longer) */
    for (i = 0; i < n; i++) {
        p[i] = ph[i] = r->p0[i];
        v[i] = vh[i] = r->v0[i];
    }
    for (i = 0; i < (delay + 1) * n; i++)
        buf[i] = 0.0;
    if (r->vib != NULL)
        hx_vib_channel_clear(r->vib);
    ke0 = mech_energy(r, v, ph, vh, p);
    ke_prev = ke0;
    tail_stride = (n_steps - r->tail_start) / (n_tail > 1 ? n_tail : 1);
    if (tail_stride < 1)
        tail_stride = 1;
    next_rec = r->n_rec > 0 ? r->record_every : -1;
    next_tail = n_tail > 0 ? r->tail_start : -1;
    for (k = 0; k < n_steps; k++) {
        double t = (double)k * r->period, q3[3], f3[3], pen, check;
        int inside, reg, rest = 0, held = 0, what = 0;
        const double *P;
        if (r->kinematic) {
            setpoint(r, t, p);
            setpoint(r, t + r->period, s1);
            for (i = 0; i < n; i++)
                v[i] = (s1[i] - p[i]) / r->period;
        }
        /* controller: sense, compute, (passivity control), quantise, saturate, delay */
        for (i = 0; i < n; i++)
            sense[i] = r->delta > 0.0 ? r->delta * nearbyint(p[i] / r->delta) : p[i];
        q3[0] = sense[0];
        q3[1] = n == 3 ? sense[1] : 0.0;
        q3[2] = sense[last];
        hx_tick_force(m, &st, q3, f3);
        if (r->vib != NULL)
            hx_vib_channel_tick(r->vib, q3, f3);
        if (r->pc_on)
            hx_passivity_tick(&pc, q3, f3, m->prm[HX_P_K0], st.pen);
        if (r->fres > 0.0)
            for (i = 0; i < 3; i++)
                f3[i] = r->fres * nearbyint(f3[i] / r->fres);
        if (hx_saturate(f3, r->fmax))
            sat++;
        if (r->pc_on)
            hx_passivity_sent(&pc, q3, f3);
        f[0] = f3[0];
        if (n == 3)
            f[1] = f3[1];
        f[last] = f3[2];
        if (delay == 0) {
            for (i = 0; i < n; i++)
                u[i] = f[i];
        } else {
            long slot = k % (delay + 1), nxt = (k + 1) % (delay + 1);
            for (i = 0; i < n; i++) {
                buf[slot * n + i] = f[i];
                u[i] = k >= delay ? buf[nxt * n + i] : 0.0;
            }
        }
        /* damping regime from the sensed position (brakes on inside the virtual object) */
        if (m->base != NULL) { /* an object: its tick's penetration, at the true position too */
            inside = st.pen > 0.0;
            pen = st.pen;
            if (r->delta > 0.0) {
                hx_state at = st;
                double pt[3], ft[3];
                pt[0] = p[0];
                pt[1] = n == 3 ? p[1] : 0.0;
                pt[2] = p[last];
                hx_object_force(m, &at, pt, ft);
                pen = at.pen;
            }
        } else if (r->nominal) {
            inside = sense[last] < 0.0;
            pen = -p[last];
        } else {
            double h = st.h;
            if (h != h)
                h = hx_texture_height(&m->tex, sense[0], n == 3 ? sense[1] : 0.0);
            inside = sense[last] < h;
            if (r->delta > 0.0)
                h = hx_texture_height(&m->tex, p[0], n == 3 ? p[1] : 0.0);
            pen = h - p[last];
        }
        if (pen > maxpen)
            maxpen = pen;
        reg = inside ? 1 : 0;
        if (r->kinematic) {
            /* prescribed motion: the operator supplies whatever work keeps it on the path */
            double dd = r->period * quad(r->Bs + reg * n * n, v, n), ke_now = 0.5 * quad(r->mass, v, n);
            double step2 = 0.0, work = 0.0, dfr;
            if (k == 0) {
                ke0 = ke_now;
                ke_prev = ke_now;
            }
            ed += dd;
            for (i = 0; i < n; i++) {
                double dp = s1[i] - p[i];
                step2 += dp * dp;
                work += u[i] * dp;
                e[i] -= u[i] * dp;
                p[i] = s1[i];
            }
            dfr = r->fc * sqrt(step2);
            efr += dfr;
            eo += (ke_now - ke_prev) + dd + dfr - work;
            ke_prev = ke_now;
        } else {
            const double *fast = r->fast;
            if (use_fast) {
                for (i = 0; i < n; i++) {
                    const double *c = fast + (reg * n + i) * HX_N_FAST;
                    g[i] = r->f0[i];
                    a[i] = c[HX_F_VV] * v[i] + c[HX_F_VW] * (u[i] + g[i]);
                }
            } else {
                setpoint(r, t, s0);
                setpoint(r, t + r->period, s1);
                for (i = 0; i < n; i++) {
                    double acc = r->f0[i], racc = 0.0;
                    for (j = 0; j < n; j++) {
                        double sd = (s1[j] - s0[j]) / r->period;
                        acc += r->K[n * i + j] * s0[j] + r->C[n * i + j] * sd;
                        racc += r->K[n * i + j] * sd;
                    }
                    g[i] = acc;
                    rr[i] = racc;
                }
                if (r->rest_len > 0.0) {
                    double nrm = 0.0;
                    for (i = 0; i < n; i++) {
                        double d_i = (mode ? ph[i] : p[i]) - r->sp_p[i];
                        nrm += d_i * d_i;
                    }
                    nrm = sqrt(nrm);
                    if (nrm > 0.0)
                        for (i = 0; i < n; i++)
                            g[i] += r->K[n * i + i] * r->rest_len * ((mode ? ph[i] : p[i]) - r->sp_p[i]) / nrm;
                }
                for (i = 0; i < n; i++) {
                    z[i] = p[i];
                    z[n + i] = v[i];
                    z[2 * n + i] = u[i];
                    z[3 * n + i] = g[i];
                    z[4 * n + i] = rr[i];
                    if (mode) {
                        z[5 * n + i] = ph[i];
                        z[6 * n + i] = vh[i];
                    }
                }
                for (i = 0; i < n; i++)
                    a[i] = row_dot(r->Phi + reg * nz * nz, n + i, z, nz);
            }
            for (i = 0; i < n; i++)
                ff[i] = 0.0;
            if (r->fc > 0.0) {
                rest = coulomb(a, r->Binv + reg * n * n, v, r->fc, n, ff);
                if (rest) {
                    stuck++;
                    /* at rest and held by stiction: the handle does not move at all */
                    held = !mode;
                    for (i = 0; i < n; i++)
                        if (v[i] != 0.0)
                            held = 0;
                }
            }
            for (i = 0; i < n; i++) {
                newp[i] = p[i];
                newv[i] = 0.0;
            }
            if (!held) {
                if (use_fast) {
                    for (i = 0; i < n; i++) {
                        const double *c = fast + (reg * n + i) * HX_N_FAST;
                        double w = u[i] + g[i] + ff[i];
                        newp[i] = p[i] + c[HX_F_PV] * v[i] + c[HX_F_PW] * w;
                        newv[i] = c[HX_F_VV] * v[i] + c[HX_F_VW] * w;
                        ed += v[i] * (c[HX_F_CVV] * v[i] + c[HX_F_CVW] * w) + c[HX_F_CWW] * w * w;
                        eo += g[i] * (newp[i] - p[i]);
                    }
                } else {
                    for (i = 0; i < n; i++)
                        z[2 * n + i] = u[i] + ff[i];
                    P = r->Phi + reg * nz * nz;
                    ed += quad(r->Wd + reg * nz * nz, z, nz);
                    eo += quad(r->Wo + reg * nz * nz, z, nz);
                    for (i = 0; i < n; i++) {
                        newp[i] = row_dot(P, i, z, nz);
                        newv[i] = row_dot(P, n + i, z, nz);
                    }
                    if (mode)
                        for (i = 0; i < n; i++) {
                            ph[i] = row_dot(P, 5 * n + i, z, nz);
                            vh[i] = row_dot(P, 6 * n + i, z, nz);
                        }
                }
            }
            for (i = 0; i < n; i++) {
                double dp = newp[i] - p[i];
                e[i] -= u[i] * dp;
                efr -= ff[i] * dp;
                p[i] = newp[i];
                v[i] = (r->fc > 0.0 && rest) ? 0.0 : newv[i]; /* stiction: at rest exactly */
            }
        }
        check = ed + eo; /* one test a sample: a non-finite term makes the sum non-finite */
        for (i = 0; i < n; i++)
            check += p[i] + v[i] + u[i] + e[i];
        if (!isfinite(check))
            what = diverged(p, v, u, e, ed, eo, (int)n);
        if (what != 0) {
            summary[HX_S_DIVERGED] = (double)(k + 1);
            summary[HX_S_DIVERGED_WHAT] = what;
            n_steps = k + 1;
            break;
        }
        if (k == r->tail_start) {
            e_tail = 0.0;
            for (i = 0; i < n; i++)
                e_tail += e[i];
        }
        if (k == next_tail) {
            if (itail < n_tail) {
                for (i = 0; i < n; i++)
                    r->tail[i * n_tail + itail] = p[i];
                itail++;
                next_tail += tail_stride;
            }
        }
        if (k + 1 == next_rec) {
            double *out = r->rec + irec * (4 * n + 4);
            next_rec += r->record_every;
            out[0] = t + r->period;
            for (i = 0; i < n; i++) {
                out[1 + i] = p[i];
                out[1 + n + i] = v[i];
                out[1 + 2 * n + i] = u[i];
                out[1 + 3 * n + i] = e[i];
            }
            out[1 + 4 * n] = ed;
            out[2 + 4 * n] = eo;
            out[3 + 4 * n] = mech_energy(r, v, ph, vh, p);
            irec++;
            if (irec == r->n_rec)
                next_rec = -1;
        }
    }
    summary[HX_S_EX] = e[0];
    summary[HX_S_EZ] = e[n - 1];
    summary[HX_S_EY] = n == 3 ? e[1] : 0.0;
    summary[HX_S_DAMP] = ed;
    summary[HX_S_OP] = eo;
    summary[HX_S_KE0] = ke0;
    summary[HX_S_KE] = mech_energy(r, v, ph, vh, p);
    summary[HX_S_SAT] = (double)sat;
    summary[HX_S_MAXPEN] = maxpen;
    summary[HX_S_NSAMP] = (double)n_steps;
    summary[HX_S_TAILSTART_E] = e_tail;
    summary[HX_S_FRIC] = efr;
    summary[HX_S_STUCK] = (double)stuck;
    summary[HX_S_PC_ACTIVE] = (double)pc.active;
    summary[HX_S_PC_ENERGY] = pc.E;
    summary[HX_S_VIB_SUPPLIED] = r->vib != NULL ? r->vib->supplied : 0.0;
    summary[HX_S_VIB_CUT] = r->vib != NULL ? (double)r->vib->cut : 0.0;
    summary[HX_S_VIB_CLAMPED] = r->vib != NULL ? (double)r->vib->vs.clamped : 0.0;
    return HX_OK;
}

/* ---- the oscillation verdict's amplitudes --------------------------------------------- */

void hx_tail_amplitudes(double *u, long m, long stride, double *a1, double *a2)
{
    /* least squares on j - tm: sum (j - tm)^2 = m (m^2 - 1) / 12 in closed form, and the
     * centred sums in one pass; the detrending and the halves' extremes in a second (plain
     * comparisons, which skip a NaN as fmin/fmax do and, unlike them, need no library call) */
    double tm = 0.5 * (double)(m - 1), md = (double)m, stt = md * (md * md - 1.0) / 12.0;
    double su = 0.0, sju = 0.0, mean, sty, slope;
    double lo1 = HUGE_VAL, hi1 = -HUGE_VAL, lo2 = HUGE_VAL, hi2 = -HUGE_VAL;
    long j, half = m / 2;
    if (m <= 0) {
        *a1 = *a2 = 0.0;
        return;
    }
    for (j = 0; j < m; j++) {
        double x = u[j * stride];
        su += x;
        sju += ((double)j - tm) * x;
    }
    mean = su / md;
    sty = sju; /* sum (j - tm) (u_j - mean) = sum (j - tm) u_j, as sum (j - tm) = 0 */
    slope = stt > 0.0 ? sty / stt : 0.0;
    for (j = 0; j < half; j++) {
        double w = u[j * stride] - mean - slope * ((double)j - tm);
        u[j * stride] = w;
        lo1 = w < lo1 ? w : lo1;
        hi1 = w > hi1 ? w : hi1;
    }
    for (j = half; j < m; j++) {
        double w = u[j * stride] - mean - slope * ((double)j - tm);
        u[j * stride] = w;
        lo2 = w < lo2 ? w : lo2;
        hi2 = w > hi2 ? w : hi2;
    }
    *a1 = half > 0 ? 0.5 * (hi1 - lo1) : 0.0;
    *a2 = 0.5 * (hi2 - lo2);
}

/* A free rigid handle (no wall, no hand) under a program of held forces, in windows: the
 * identification's model (haptex.identify). Each axis is the exact zero-order hold of
 * m dv/dt = w - b v (axis_zoh, coefficients c[HX_N_FAST] an axis, diagonal mass and
 * damping), with the isotropic Coulomb friction of the general loop (coulomb: a sampled
 * Karnopp model; at rest and held by stiction the handle does not move). Window k starts at
 * p0[k], v0[k] (n values each) and runs `steps` samples under force[k][s] (n values a
 * sample, already delayed by the caller); pos[k][s] is the position read at sample s (the
 * start of its hold), so pos[k][0] = p0[k]; p0[k] and v0[k] end as the window's state after
 * its last sample (a caller steps on from there). */
/* m dv/dt = w - b v from (p, v) over a time tau, in closed form (lam = b / m; lam = 0: no damping) */
static void slide(double m, double lam, double w, double tau, double *p, double *v)
{
    if (lam > 0.0) {
        double vinf = w / (lam * m), e = exp(-lam * tau);
        *p += vinf * tau + (*v - vinf) * (-expm1(-lam * tau)) / lam;
        *v = vinf + (*v - vinf) * e;
    } else {
        *p += *v * tau + 0.5 * w / m * tau * tau;
        *v += w / m * tau;
    }
}

/* One axis over one period T under the held force u with Coulomb friction fc, exactly: the
 * period is split where the velocity reaches zero (in closed form), where the handle sticks
 * if |u| <= fc and otherwise slides on the other way (continuous-time Coulomb friction, the
 * model of a real handle; the sampled Karnopp model of coulomb() keeps the friction's sign
 * over the whole period, a velocity error of up to 2 fc T / m at each reversal) */
static void coulomb_exact_1d(double m, double lam, double T, double fc, double u, double *p, double *v)
{
    double left = T;
    int piece;
    for (piece = 0; piece < 3 && left > 0.0; piece++) {
        double s, w, tau = left;
        if (*v == 0.0) {
            if (fabs(u) <= fc)
                return; /* held by stiction */
            s = u > 0.0 ? 1.0 : -1.0;
        } else {
            s = *v > 0.0 ? 1.0 : -1.0;
        }
        w = u - fc * s;
        if (s * w < 0.0) { /* decelerating: the velocity reaches zero at tau0 */
            double tau0;
            if (lam > 0.0) {
                double vinf = w / (lam * m);
                tau0 = log((*v - vinf) / (-vinf)) / lam;
            } else {
                tau0 = -*v * m / w;
            }
            if (tau0 < left) {
                slide(m, lam, w, tau0, p, v);
                *v = 0.0;
                left -= tau0;
                continue;
            }
        }
        slide(m, lam, w, tau, p, v);
        left = 0.0;
    }
}

void hx_free_run(long n, const double *c, long c_step, double fc, long windows, long steps, const double *force,
                 double *p0, double *v0, double *pos)
{
    /* step k * steps + s's coefficients at c + (k * steps + s) * c_step: one set for every step
     * (c_step 0), or each step its own (c_step n * HX_N_FAST: a log's ticks of their own lengths) */
    if (n == 1 && fc > 0.0) {
        /* one axis: the exact stick-slip step; m, b and T from the axis's coefficients
         * (VW / PV = 1 / m, VV = exp(-b T / m), PV = T g1(b T / m), g1(x) = (1 - e^-x) / x) */
        long k, s;
        double m = 0.0, T = 0.0, lam = 0.0;
        for (k = 0; k < windows; k++) {
            double p = p0[k], v = v0[k];
            for (s = 0; s < steps; s++) {
                if (c_step != 0 || (k == 0 && s == 0)) { /* (decoded once where every step shares them) */
                    const double *cs = c + (k * steps + s) * c_step;
                    double x = -log(cs[HX_F_VV]);
                    double g1 = x > 1e-8 ? -expm1(-x) / x : 1.0 - 0.5 * x;
                    m = cs[HX_F_PV] / cs[HX_F_VW];
                    T = cs[HX_F_PV] / g1;
                    lam = x / T;
                }
                pos[k * steps + s] = p;
                coulomb_exact_1d(m, lam, T, fc, force[k * steps + s], &p, &v);
            }
            p0[k] = p;
            v0[k] = v;
        }
        return;
    }
    {
        double Binv[9], a[3], ff[3], p[3], v[3], np_, nv, de;
        long k, s, i, j;
        for (k = 0; k < windows; k++) {
            for (i = 0; i < n; i++) {
                p[i] = p0[k * n + i];
                v[i] = v0[k * n + i];
            }
            for (s = 0; s < steps; s++) {
                const double *u = force + (k * steps + s) * n;
                const double *cs = c + (k * steps + s) * c_step;
                int rest = 0, held = 0;
                if (c_step != 0 || (k == 0 && s == 0))
                    for (i = 0; i < n; i++)
                        for (j = 0; j < n; j++)
                            Binv[n * i + j] = i == j ? 1.0 / cs[i * HX_N_FAST + HX_F_VW] : 0.0;
                for (i = 0; i < n; i++) {
                    pos[(k * steps + s) * n + i] = p[i];
                    a[i] = cs[i * HX_N_FAST + HX_F_VV] * v[i] + cs[i * HX_N_FAST + HX_F_VW] * u[i];
                    ff[i] = 0.0;
                }
                if (fc > 0.0) {
                    rest = coulomb(a, Binv, v, fc, n, ff);
                    held = rest;
                    for (i = 0; i < n; i++)
                        if (v[i] != 0.0)
                            held = 0;
                }
                for (i = 0; i < n; i++) {
                    if (held)
                        continue;
                    axis_zoh(cs + i * HX_N_FAST, p[i], v[i], u[i], ff[i], &np_, &nv, &de);
                    p[i] = np_;
                    v[i] = rest ? 0.0 : nv;
                }
                if (held)
                    for (i = 0; i < n; i++)
                        v[i] = 0.0;
            }
            for (i = 0; i < n; i++) {
                p0[k * n + i] = p[i];
                v0[k * n + i] = v[i];
            }
        }
    }
}
