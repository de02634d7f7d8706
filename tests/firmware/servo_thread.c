/* The native servo thread (hx_thread.c) on a Windows host, run under Wine by
 * tests/test_firmware.py: an exported texture's renderer under the servo rules (hx_servo.c), on
 * the thread, paced at the period given (s) for the ticks given, at time-critical priority, the
 * core kept awake where there are two; the device a handle stroking 0.2 mm inside the wall.
 * Meanwhile this thread reads the thread's snapshots (the seqlock) and, halfway, halves the
 * stiffness (the renderer's hand-over to the tick): the core's atomics in use, gcc's builtins or
 * MSVC's Interlocked intrinsics (built with -DHX_MSVC_ATOMICS). Prints one line of figures:
 *   ticks reads writes missed overruns fifo awake work_max_s jitter_p99_s last_force_n max_sent_n
 *   elapsed_s snapshots torn stiffness_changes stiffness_after */
#include "haptex_texture.h"
#include "hx_host.h"

#include <math.h>
#include <stdio.h>
#ifdef _WIN32
#include <windows.h>
#endif
#include <stdlib.h>
#include <string.h>

static long n_read, n_write;
static double last[3];

static int dev_read(void *ctx, double p[3])
{
    (void)ctx;
    p[0] = 1e-3 * sin(0.01 * (double)n_read);
    p[1] = 0.0;
    p[2] = -0.2e-3;
    n_read++;
    return 0;
}

static int dev_write(void *ctx, const double f[3])
{
    (void)ctx;
    memcpy(last, f, sizeof last);
    n_write++;
    return 0;
}

int main(int argc, char **argv)
{
    static haptex_state st;
    static unsigned int work[HX_HIST_BINS + 1], jitter[HX_HIST_BINS + 1];
    static hx_thread th;
    hx_servo s;
    hx_ticks ticks;
    double t0, period = argc > 1 ? atof(argv[1]) : 1e-3;
    long n = argc > 2 ? atol(argv[2]) : 1000;
    double spin = argc > 3 ? atof(argv[3]) : 0.2 * period;
    int awake = argc > 4 ? atoi(argv[4]) : 1, halved = 0;
    long snapshots = 0, torn = 0, last_k = 0;
    double k0;
    if (haptex_init(&st) != 0)
        return 2;
    k0 = st.r.model.prm[HX_P_K0];
    memset(&s, 0, sizeof s);
    s.dim = HAPTEX_DIMENSION;
    s.period = period;
    s.workspace = HAPTEX_WORKSPACE;
    s.max_force = HAPTEX_MAX_FORCE;
    s.engage_force = HAPTEX_MAX_FORCE; /* engaged at once: the stroke starts inside the wall */
    s.engage_ticks = 1;
    s.ramp_ticks = 1;
    s.deadline = 1.5;
    hx_servo_init(&s);
    s.realtime = 1;
    memset(&ticks, 0, sizeof ticks);
    ticks.work = work;
    ticks.jitter = jitter;
    memset(&th, 0, sizeof th);
    th.servo = &s;
    th.renderer = &st.r;
    th.io.read = dev_read;
    th.io.write = dev_write;
    th.io.ctx = NULL;
    th.ticks = &ticks;
    th.n_ticks = n;
    th.paced = 1;
    th.spin = spin;
    th.priority = 1;
    th.keep_awake = awake;
    t0 = hx_now();
    if (hx_thread_start(&th) != 0)
        return 3;
    while (!HX_LOAD_ACQ(&th.done)) { /* snapshots whole (their tick counts never go back), a hand-over halfway */
        hx_snapshot snap;
        hx_thread_snapshot(&th, &snap);
        torn += snap.k < last_k;
        last_k = snap.k;
        snapshots++;
        if (!halved && snap.k > n / 2) {
            hx_render_set_stiffness(&st.r, 0.5 * k0);
            halved = 1;
        }
#ifdef _WIN32
        Sleep(20); /* (Wine runs every thread at one priority: read each 1 ms, 126 of 2000 deadlines were missed) */
#endif
    }
    hx_thread_join(&th);
    t0 = hx_now() - t0;
    printf("%ld %ld %ld %ld %ld %d %d %.9g %.9g %.17g %.17g %.9g %ld %ld %ld %.17g\n", s.k, n_read, n_write, s.missed,
           ticks.overruns, th.fifo, th.awake, ticks.work_max, hx_ticks_quantile(jitter, 0.99),
           sqrt(last[0] * last[0] + last[1] * last[1] + last[2] * last[2]), s.max_sent, t0, snapshots, torn,
           st.r.k0_changes, st.r.model.prm[HX_P_K0]);
    return 0;
}
