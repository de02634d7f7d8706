/*
 * The simulated device of haptex's backends (haptex.backends.simulated documents it): a preset
 * held by a hand, advanced one servo period at a time by haptex.simulate's exact transition of
 * the augmented dynamics (the transition matrix is computed in Python, once, and given here).
 * One implementation: the Python backend's sample and command call these, and so does the
 * native servo thread.
 */
#include "hx_host.h"

#include <math.h>
#include <string.h>

void hx_plant_reset(hx_plant *d, double start)
{
    int n = d->n;
    memset(d->x, 0, sizeof d->x);
    memset(d->queue, 0, sizeof d->queue);
    d->x[n - 1] = start;
    if (d->m > 5 * n) /* the handle side of a structural mode starts there too */
        d->x[6 * n - 1] = start;
    d->head = 0;
    d->k = 0;
}

void hx_plant_release(hx_plant *d)
{
    int i;
    memset(d->queue, 0, sizeof d->queue);
    for (i = 0; i < d->n; i++)
        d->x[2 * d->n + i] = 0.0;
}

void hx_plant_read(const hx_plant *d, double p[3])
{
    double q[3] = {0.0, 0.0, 0.0};
    int i, n = d->n;
    for (i = 0; i < n; i++) {
        q[i] = d->x[i];
        if (d->resolution > 0.0)
            q[i] = d->resolution * nearbyint(q[i] / d->resolution);
    }
    p[0] = q[0];
    p[1] = n == 3 ? q[1] : 0.0;
    p[2] = n == 3 ? q[2] : q[1];
}

int hx_plant_write(hx_plant *d, const double f_in[3])
{
    double f[3], u[3], s[3], z[HX_PLANT_MAXSTATE], mag;
    int i, j, n = d->n, m = d->m;
    if (!isfinite(f_in[0]) || !isfinite(f_in[1]) || !isfinite(f_in[2]))
        return -1;
    /* [x, y, z] to the plant's [x, z] or [x, y, z] */
    f[0] = f_in[0];
    f[1] = n == 3 ? f_in[1] : f_in[2];
    f[2] = n == 3 ? f_in[2] : 0.0;
    mag = 0.0;
    for (i = 0; i < n; i++)
        mag += f[i] * f[i];
    mag = sqrt(mag);
    if (mag > d->max_force * (1.0 + 1e-12)) /* the device's own limit, as real amplifiers clip */
        for (i = 0; i < n; i++)
            f[i] *= d->max_force / mag;
    if (d->delay > 0) { /* the force acting now is the one commanded delay ticks ago */
        memcpy(u, d->queue[d->head], sizeof u);
        memcpy(d->queue[d->head], f, sizeof f);
        d->head = (d->head + 1) % d->delay;
    } else {
        memcpy(u, f, sizeof u);
    }
    for (i = 0; i < n; i++)
        s[i] = d->s0[i] + d->sv[i] * ((double)d->k * d->period);
    for (i = 0; i < n; i++) {
        double g = 0.0;
        for (j = 0; j < n; j++)
            g += d->K[i * n + j] * s[j];
        for (j = 0; j < n; j++)
            g += d->C[i * n + j] * d->sv[j];
        d->x[2 * n + i] = u[i];
        d->x[3 * n + i] = g;
        g = 0.0;
        for (j = 0; j < n; j++)
            g += d->K[i * n + j] * d->sv[j];
        d->x[4 * n + i] = g;
    }
    for (i = 0; i < m; i++) {
        double acc = 0.0;
        for (j = 0; j < m; j++)
            acc += d->phi[i * m + j] * d->x[j];
        z[i] = acc;
    }
    memcpy(d->x, z, (size_t)m * sizeof z[0]);
    d->k++;
    for (i = 0; i < m; i++)
        if (!isfinite(d->x[i]))
            return -1;
    return 0;
}
