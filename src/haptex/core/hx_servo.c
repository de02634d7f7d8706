/*
 * The servo loop's safety rules around a device (haptex.servo documents them): faults give
 * zero force, a missed deadline gives zero force, forces engage only after a calm handle and
 * ramp in, never above the maximum. One implementation: haptex's Python loop calls it once a
 * tick, the native drivers call it from the vendor's servo thread, and `haptex export` ships it.
 */
#include "hx_core.h"

#include <math.h>
#include <string.h>

void hx_servo_init(hx_servo *s)
{
    s->k = s->calm = 0;
    s->engaged_at = -1;
    s->have_wall = s->late = 0;
    s->last_wall = s->tick_wall = 0.0;
    s->missed = s->faults = s->clamps = 0;
    s->max_sent = s->work_max = s->work_sum = 0.0;
    s->periods = 0;
    s->period_mean = s->period_m2 = 0.0;
    s->capacity = 0;
    s->rec_t = s->rec_p = s->rec_f = NULL;
    s->rec_e = NULL;
}

static double norm3(const double v[3]) { return hypot(hypot(v[0], v[1]), v[2]); }

int hx_servo_usable(const hx_servo *s, const double p[3])
{
    int i;
    for (i = 0; i < 3; i++)
        if (!isfinite(p[i]))
            return 0;
    return norm3(p) <= s->workspace;
}

void hx_servo_begin(hx_servo *s, double wall)
{
    s->late = 0;
    if (s->have_wall) {
        double dt = wall - s->last_wall, delta = dt - s->period_mean;
        s->periods++;
        s->period_mean += delta / (double)s->periods;
        s->period_m2 += delta * (dt - s->period_mean);
        s->late = s->realtime && dt > s->deadline * s->period;
    }
    s->have_wall = 1;
    s->last_wall = s->tick_wall = wall;
}

void hx_servo_command(hx_servo *s, double t, const double p[3], int fault, double f[3])
{
    double mag;
    int i;
    if (fault || !isfinite(f[0]) || !isfinite(f[1]) || !isfinite(f[2])) { /* rule 1 */
        s->faults++;
        f[0] = f[1] = f[2] = 0.0;
    }
    mag = norm3(f);
    if (s->engaged_at < 0) { /* rule 3: wait for a calm handle */
        s->calm = mag < s->engage_force ? s->calm + 1 : 0;
        if (s->calm >= s->engage_ticks)
            s->engaged_at = s->k;
        f[0] = f[1] = f[2] = 0.0;
    } else {
        double ramp = (double)(s->k - s->engaged_at + 1) / (double)s->ramp_ticks;
        if (ramp < 1.0)
            for (i = 0; i < 3; i++)
                f[i] *= ramp;
    }
    mag = norm3(f);
    if (mag > s->max_force) { /* rule 4, whatever computed the force */
        double r = s->max_force / mag;
        for (i = 0; i < 3; i++)
            f[i] *= r;
        s->clamps++;
        mag = norm3(f);
        if (mag > s->max_force) { /* (rounding: never above the maximum) */
            for (i = 0; i < 3; i++)
                f[i] = nextafter(f[i], 0.0);
            mag = norm3(f);
        }
    }
    if (s->late) { /* rule 2: the watchdog */
        s->missed++;
        f[0] = f[1] = f[2] = 0.0;
        mag = 0.0;
    }
    if (mag > s->max_sent)
        s->max_sent = mag;
    if (s->k < s->capacity) {
        long k = s->k;
        int j, c = 0;
        s->rec_t[k] = t;
        for (j = 0; j < 3; j++) {
            if (s->dim == 2 && j == 1)
                continue;
            s->rec_p[k * s->dim + c] = p[j];
            s->rec_f[k * s->dim + c] = f[j];
            c++;
        }
        s->rec_e[k] = s->engaged_at >= 0;
    }
    s->k++;
}

void hx_servo_end(hx_servo *s, double wall)
{
    double w = wall - s->tick_wall;
    if (w > s->work_max)
        s->work_max = w;
    s->work_sum += w;
}

void hx_servo_tick(hx_servo *s, hx_renderer *r, double wall, double t, const double p[3], double f[3])
{
    int fault = !hx_servo_usable(s, p);
    hx_servo_begin(s, wall);
    f[0] = f[1] = f[2] = 0.0;
    if (!fault)
        hx_render_step(r, p[0], p[1], p[2], f);
    hx_servo_command(s, t, p, fault, f);
}
