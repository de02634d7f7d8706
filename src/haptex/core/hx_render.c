/*
 * The servo tick: the renderer's safety rules, the passivity observer/controller and the
 * force saturation, over [x, y, z] (a profile's tick has y = 0 and f_y = 0, which leaves
 * every sum and magnitude below the same as in 2-D).
 */
#include "hx_core.h"

#include <math.h>
#include <string.h>

/* the force that acted over the last sample: sent delay ticks before the last one (none
 * before it arrived) */
static const double *acting(const hx_passivity *pc)
{
    static const double none[3] = {0.0, 0.0, 0.0};
    return pc->sent > pc->delay ? pc->hist[(pc->sent - 1 - pc->delay) % HX_PC_RING] : none;
}

static double dot3(const double *a, const double *b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* Hannaford & Ryu (2002): the damping -alpha v, v = dq / T, that dissipates within one sample
 * the deficit of the observer's energy below the reference, alpha <= bmax */
static void controller_pc(hx_passivity *pc, const double dq[3], double v2, double f[3], double k0, double pen)
{
    double ref = pc->mode == HX_STAB_PC_STORED ? 0.5 * k0 * pen * pen : 0.0, deficit = ref - pc->E;
    int i;
    if (deficit > 0.0 && v2 > 0.0) {
        double alpha = deficit * pc->T / v2; /* (E_ref - E) / (T |v|^2) */
        if (alpha > pc->bmax)
            alpha = pc->bmax;
        for (i = 0; i < 3; i++)
            f[i] -= alpha * dq[i] / pc->T;
        pc->alpha = alpha;
        pc->active++;
    }
}

/* Energy bounding after Kim & Ryu (2004): the energy a held force f can generate over one
 * sample beyond what the device's damper b dissipates in it is at most
 * max over dp of (f . dp - b |dp|^2 / T) = T |f|^2 / (4 b). The reservoir (the energy the port
 * absorbed, the observer's E, plus the damper's credit) must cover that worst case for every
 * force that has still to act: the new one and the `delay` sent before it, so |f| is scaled
 * down to what is left. By induction the reservoir then never goes below zero in contact. */
static void controller_eba(hx_passivity *pc, double f[3])
{
    double budget = pc->E + pc->credit, m2 = dot3(f, f), cap2;
    long j;
    for (j = 0; j < pc->delay && j < pc->sent; j++) {
        const double *g = pc->hist[(pc->sent - 1 - j) % HX_PC_RING];
        budget -= pc->T * dot3(g, g) / (4.0 * pc->bmax);
    }
    cap2 = budget > 0.0 ? 4.0 * pc->bmax * budget / pc->T : 0.0;
    if (m2 > cap2) {
        double scale = sqrt(cap2 / m2);
        int i;
        for (i = 0; i < 3; i++)
            f[i] *= scale;
        pc->alpha = (1.0 - scale) * sqrt(m2);
        pc->active++;
    }
}

/* Passive set-position modulation after Lee & Huang (2010): the force is a coupling spring of
 * stiffness k0 stretched from the device to a set-position, which moves (towards the device,
 * along f) no further than keeps the spring's energy |f|^2 / (2 k0) within the reservoir: the
 * energy the port absorbed (the observer's E) plus the device's dissipation (credit). */
static void controller_pspm(hx_passivity *pc, double f[3], double k0)
{
    double budget = pc->E + pc->credit, cap2 = budget > 0.0 ? 2.0 * k0 * budget : 0.0, m2 = dot3(f, f);
    int i;
    if (m2 > cap2) {
        double scale = sqrt(cap2 / m2);
        for (i = 0; i < 3; i++)
            f[i] *= scale;
        pc->alpha = (1.0 - scale) * sqrt(m2);
        pc->active++;
    }
}

void hx_passivity_tick(hx_passivity *pc, const double p[3], double f[3], double k0, double pen)
{
    double v2 = 0.0, dq[3];
    const double *fa;
    int i;
    pc->alpha = 0.0;
    if (!pc->have) {
        /* the first tick: the environment already holds what its spring stores where the probe
         * starts (put in before the observer watched), and may give it back */
        if (pc->sent == 0)
            pc->E = 0.5 * k0 * pen * pen;
        if (pc->on && pc->mode == HX_STAB_PSPM)
            controller_pspm(pc, f, k0);
        else if (pc->on && pc->mode == HX_STAB_EBA)
            controller_eba(pc, f);
        return;
    }
    /* Hannaford & Ryu (2002), eq. 7: the energy absorbed over the last sample is the force
     * that acted over it times the displacement sensed since; with a computation delay d the
     * force that acted is the one sent d ticks before the last */
    fa = acting(pc);
    for (i = 0; i < 3; i++) {
        double de;
        dq[i] = p[i] - pc->last[i];
        de = fa[i] * dq[i];
        pc->E -= de;
        pc->e_axis[i] -= de;
        v2 += dq[i] * dq[i];
    }
    if ((pc->mode == HX_STAB_EBA || pc->mode == HX_STAB_PSPM) && pen > 0.0)
        pc->credit += pc->bmax * v2 / pc->T; /* in contact, where the damper acts: at most the work
                                              * of b v over the sample (Cauchy-Schwarz) */
    if (!pc->on)
        return;
    switch (pc->mode) {
    case HX_STAB_EBA:
        controller_eba(pc, f);
        break;
    case HX_STAB_PSPM:
        controller_pspm(pc, f, k0);
        break;
    default:
        controller_pc(pc, dq, v2, f, k0, pen);
    }
}

void hx_passivity_sent(hx_passivity *pc, const double p[3], const double f[3])
{
    double *h = pc->hist[pc->sent % HX_PC_RING];
    int i;
    for (i = 0; i < 3; i++) {
        pc->last[i] = p[i];
        h[i] = f[i];
    }
    pc->sent++;
    pc->have = 1;
}

void hx_passivity_skip(hx_passivity *pc)
{
    double *h = pc->hist[pc->sent % HX_PC_RING];
    h[0] = h[1] = h[2] = 0.0;
    pc->sent++;
    pc->have = 0;
}

int hx_saturate(double f[3], double fmax)
{
    int i, infinite = 0, nan = 0;
    double mag = 0.0;
    if (isinf(fmax))
        return 0;
    for (i = 0; i < 3; i++) {
        if (isinf(f[i]))
            infinite++;
        else if (isnan(f[i]))
            nan = 1;
    }
    if (infinite) {
        double r;
        if (nan)
            return 0;
        r = fmax / sqrt((double)infinite);
        for (i = 0; i < 3; i++)
            f[i] = isinf(f[i]) ? copysign(r, f[i]) : 0.0;
        return 1;
    }
    for (i = 0; i < 3; i++)
        mag = hypot(mag, f[i]);
    if (mag > fmax) {
        double r = fmax / mag;
        for (i = 0; i < 3; i++)
            f[i] *= r;
        return 1;
    }
    return 0;
}

static int outside(double v, double limit) { return !isfinite(v) || fabs(v) > limit; }

void hx_render_step(hx_renderer *r, double x, double y, double z, double f[3])
{
    double p[3];
    int i, clamped;
    f[0] = f[1] = f[2] = 0.0;
    r->work = 0;
    /* between ticks only; a plain load first, so a tick without a change pays no locked exchange */
    if (HX_LOAD_ACQ(&r->model_pending) == 1) {
        int one = 1;
        if (HX_CAS(&r->model_pending, &one, 2)) {
            r->model = r->model_next;
            memset(&r->st, 0, sizeof r->st);
            r->model_changes++;
            HX_STORE_REL(&r->model_pending, 0);
        }
    }
    if (HX_LOAD_ACQ(&r->k0_pending) == 1) {
        int one = 1; /* 1 -> 2 (the tick copies it) -> 0; a writer never writes k0_next at 2 */
        if (HX_CAS(&r->k0_pending, &one, 2)) {
            r->model.prm[HX_P_K0] = r->k0_next;
            r->k0_changes++;
            HX_STORE_REL(&r->k0_pending, 0);
        }
    }
    if (outside(x, r->limit) || outside(y, r->limit) || outside(z, r->limit)) {
        r->faults++;
        hx_passivity_skip(&r->pc);
        return;
    }
    p[0] = x;
    p[1] = y;
    p[2] = z;
    if (hx_tick_force(&r->model, &r->st, p, f) != HX_OK) {
        r->faults++;
        hx_passivity_skip(&r->pc);
        f[0] = f[1] = f[2] = 0.0;
        return;
    }
    r->work = r->st.work;
    if (r->st.cut)
        r->cut++;
    if (r->vib.set != 0)
        r->work += hx_vib_channel_tick(&r->vib, p, f);
    if (r->work > r->max_work)
        r->max_work = r->work;
    if (r->monitor)
        hx_passivity_tick(&r->pc, p, f, r->model.prm[HX_P_K0], r->st.pen);
    clamped = hx_saturate(f, r->max_force);
    for (i = 0; i < 3; i++) {
        if (!isfinite(f[i])) {
            r->faults++;
            hx_passivity_skip(&r->pc);
            r->st.contact = 0;
            f[0] = f[1] = f[2] = 0.0;
            return;
        }
    }
    if (clamped)
        r->clamps++;
    if (r->monitor)
        hx_passivity_sent(&r->pc, p, f);
}

/* the writer's side of k0_pending: claim it (0 or 1 -> 2, waiting while a tick copies at 2),
 * so that k0_next is written by no one else and read by no tick meanwhile; the flag is an int
 * (32-bit atomics: every target has them, where a double's 64-bit ones are missing on
 * Cortex-M). On a single-core microcontroller the tick runs in an interrupt over the writer:
 * it finds 2 and takes the value at the next tick; the writer never waits on the tick there,
 * since the tick's own 2 is over before the writer runs again. */
static void k0_claim(hx_renderer *r)
{
    for (;;) {
        int v = HX_LOAD_ACQ(&r->k0_pending);
        if (v != 2 && HX_CAS(&r->k0_pending, &v, 2))
            return;
    }
}

void hx_render_set_stiffness(hx_renderer *r, double k0)
{
    k0_claim(r);
    r->k0_next = k0;
    HX_STORE_REL(&r->k0_pending, 1);
}

int hx_render_set_model(hx_renderer *r, const hx_model *m)
{
    int withdrawn = 0;
    for (;;) {
        int v = HX_LOAD_ACQ(&r->model_pending), one = 1;
        if (v == 0)
            break;
        if (v == 1 && HX_CAS(&r->model_pending, &one, 0)) {
            withdrawn = 1; /* never taken: no tick reads it */
            break;
        }
        /* 2: a tick is copying it (a struct's copy): wait */
    }
    r->model_next = *m;
    k0_claim(r);
    HX_STORE_REL(&r->k0_pending, 0); /* the model's own stiffness, not a waiting one */
    HX_STORE_REL(&r->model_pending, 1);
    return withdrawn;
}

void hx_render_set_vibration(hx_renderer *r, const double *v, double mass, double gain, double tau,
                             unsigned long long seed, double budget, double reserve)
{
    hx_vib_channel_set(&r->vib, v, mass, gain, tau, seed, budget, reserve);
}

void hx_render_reset(hx_renderer *r)
{
    hx_passivity keep = r->pc;
    memset(&r->st, 0, sizeof r->st);
    memset(&r->pc, 0, sizeof r->pc);
    r->pc.on = keep.on;
    r->pc.mode = keep.mode;
    r->pc.bmax = keep.bmax;
    r->pc.T = keep.T;
    r->pc.delay = keep.delay;
    r->faults = r->clamps = r->work = r->max_work = r->cut = 0;
    hx_vib_channel_clear(&r->vib);
}
