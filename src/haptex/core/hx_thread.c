/*
 * The native servo thread (haptex.servo documents the rules it runs): a POSIX thread that
 * wakes on an absolute deadline of CLOCK_MONOTONIC once a period (clock_nanosleep until spin
 * seconds before it, then the clock read until it is due: a sleep alone wakes up to ~0.3 ms late
 * on a machine without a real-time kernel), samples
 * the device, runs the servo rules and the renderer's tick (hx_servo_tick), commands the
 * force, counts its own time, and publishes the tick to a seqlock that Python reads without
 * ever blocking it. It runs at SCHED_FIFO with its memory locked where the user's rights allow
 * (and says what it got); it allocates nothing on the tick and never touches Python.
 *
 * A tick that ends after the next one was due is an overrun: the schedule skips the periods
 * already past (no burst of catch-up ticks), and the next sample, late, is answered with zero
 * force by the watchdog (hx_servo's rule 2). Zero force is commanded on every exit: the end,
 * stop, a failed device.
 *
 * Keeping the core awake (keep_awake, Linux): on a virtual machine an idle virtual CPU halts,
 * and the host wakes it for the next tick late (this project's 2-core VM: a plain C loop misses
 * 0.1-0.6 % of 1-4 kHz deadlines idle, fewer under load, where no CPU halts). Then the servo
 * thread is pinned to the last core of its affinity and a companion thread, pinned to the same
 * core at SCHED_OTHER and nice 19, spins there below it until the run ends: the core never halts
 * (what Linux's idle=poll does for a whole machine), and the FIFO thread preempts the companion
 * at once. It costs that core's whole time, as a haptic loop that spins does (CHAI3D's).
 */
#define _GNU_SOURCE
#include "hx_host.h"

#include <errno.h>
#include <math.h>
#include <pthread.h>
#include <sched.h>
#include <string.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>
#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#endif

/* the threads' handles live in hx_thread's opaque bytes */
typedef char hx_pthread_fits[sizeof(pthread_t) <= sizeof(((hx_thread *)0)->handle) ? 1 : -1];

double hx_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

void hx_ticks_count(hx_ticks *c, double work, double jitter)
{
    long b;
    if (work > c->work_max)
        c->work_max = work;
    if (c->work != NULL) {
        b = work < 0.0 ? 0 : (long)(work / HX_HIST_STEP);
        c->work[b < HX_HIST_BINS ? b : HX_HIST_BINS]++;
    }
    if (jitter < 0.0)
        return;
    if (jitter > c->jitter_max)
        c->jitter_max = jitter;
    if (c->jitter != NULL) {
        b = (long)(jitter / HX_HIST_STEP);
        c->jitter[b < HX_HIST_BINS ? b : HX_HIST_BINS]++;
    }
}

double hx_ticks_quantile(const unsigned int *hist, double q)
{
    double total = 0.0, need, acc = 0.0;
    long b;
    if (hist == NULL)
        return 0.0;
    for (b = 0; b <= HX_HIST_BINS; b++)
        total += hist[b];
    if (total <= 0.0)
        return 0.0;
    need = q * total;
    for (b = 0; b <= HX_HIST_BINS; b++) {
        acc += hist[b];
        if (acc >= need)
            break;
    }
    if (b > HX_HIST_BINS)
        b = HX_HIST_BINS;
    return (double)(b + 1) * HX_HIST_STEP;
}

static void publish(hx_thread *th, double t, const double p[3], const double f[3])
{
    /* seqlock: odd while writing; the reader retries on odd or changed */
    __atomic_store_n(&th->seq, th->seq + 1, __ATOMIC_RELAXED);
    __atomic_thread_fence(__ATOMIC_RELEASE);
    th->snap.k = th->servo->k;
    th->snap.t = t;
    memcpy(th->snap.p, p, 3 * sizeof p[0]);
    memcpy(th->snap.f, f, 3 * sizeof f[0]);
    __atomic_store_n(&th->seq, th->seq + 1, __ATOMIC_RELEASE);
}

void hx_thread_snapshot(const hx_thread *th, hx_snapshot *out)
{
    unsigned long a, b;
    do {
        a = __atomic_load_n(&th->seq, __ATOMIC_ACQUIRE);
        memcpy(out, (const void *)&th->snap, sizeof *out);
        __atomic_thread_fence(__ATOMIC_ACQUIRE);
        b = __atomic_load_n(&th->seq, __ATOMIC_RELAXED);
    } while ((a & 1UL) || a != b);
}

static void add(struct timespec *ts, double s)
{
    long ns = (long)llround(s * 1e9);
    ts->tv_sec += ns / 1000000000L;
    ts->tv_nsec += ns % 1000000000L;
    if (ts->tv_nsec >= 1000000000L) {
        ts->tv_sec++;
        ts->tv_nsec -= 1000000000L;
    } else if (ts->tv_nsec < 0) {
        ts->tv_sec--;
        ts->tv_nsec += 1000000000L;
    }
}

static double seconds(const struct timespec *ts) { return (double)ts->tv_sec + 1e-9 * (double)ts->tv_nsec; }

static void *loop(void *arg)
{
    hx_thread *th = arg;
    hx_servo *s = th->servo;
    const double T = s->period, zero[3] = {0.0, 0.0, 0.0};
    double p[3], f[3], prev = -1.0;
    struct timespec due;
    long k;
    if (th->lock_memory) {
        /* the pages the process has, and those it touches from now on, stay in memory; on
         * fault only: the untouched reservations of a Python process (hundreds of MB of
         * thread stacks and arenas) are not made resident for it */
        int flags = MCL_CURRENT | MCL_FUTURE;
#ifdef MCL_ONFAULT
        flags |= MCL_ONFAULT;
#endif
        th->locked = mlockall(flags) == 0;
    }
    clock_gettime(CLOCK_MONOTONIC, &due);
    for (k = 0; k < th->n_ticks && !th->stop; k++) {
        double wake, end, due_s;
        if (k > 0) {
            add(&due, T);
            if (th->paced) {
                struct timespec early = due;
                add(&early, -th->spin);
                while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &early, NULL) == EINTR)
                    ;
                while (hx_now() < seconds(&due)) /* the last spin seconds on the clock */
                    ;
            }
        }
        due_s = seconds(&due);
        wake = hx_now();
        if (th->io.read(th->io.ctx, p)) {
            th->io_error = 1;
            th->io_error_tick = k;
            break;
        }
        hx_servo_tick(s, th->renderer, wake, (double)k * T, p, f);
        if (th->io.write(th->io.ctx, f)) {
            th->io_error = 2;
            th->io_error_tick = k;
            break;
        }
        end = hx_now();
        hx_servo_end(s, end);
        hx_ticks_count(th->ticks, end - wake, prev < 0.0 ? -1.0 : fabs(wake - prev - T));
        prev = wake;
        publish(th, (double)k * T, p, f);
        if (th->paced && end > due_s + T) { /* an overrun: skip the periods already past */
            long behind = (long)floor((end - due_s) / T);
            th->ticks->overruns++;
            add(&due, (double)(behind - 1) * T);
        }
    }
    th->io.write(th->io.ctx, zero); /* zero force on every exit: the end, stop, a failed device */
    if (th->locked)
        munlockall();
    __atomic_store_n(&th->done, 1, __ATOMIC_RELEASE);
    return NULL;
}

#ifdef __linux__
static void *companion(void *arg)
{
    /* below everything on its core: any other task there runs first, the servo thread at once */
    hx_thread *th = arg;
    setpriority(PRIO_PROCESS, (id_t)syscall(SYS_gettid), 19);
    while (!__atomic_load_n(&th->done, __ATOMIC_ACQUIRE) && !th->stop)
#if defined(__x86_64__) || defined(__i386__)
        __builtin_ia32_pause();
#else
        ;
#endif
    return NULL;
}

/* The core to keep awake: the last of this thread's affinity, when it has two or more (with
 * one, the companion would take the time of everything else); -1 for none. */
static int awake_core(void)
{
    cpu_set_t set;
    int c, n = 0, last = -1;
    if (sched_getaffinity(0, sizeof set, &set) != 0)
        return -1;
    for (c = 0; c < CPU_SETSIZE; c++)
        if (CPU_ISSET((size_t)c, &set)) {
            n++;
            last = c;
        }
    return n >= 2 ? last : -1;
}
#endif

int hx_thread_start(hx_thread *th)
{
    pthread_t *tid = (pthread_t *)(void *)th->handle;
    pthread_attr_t attr;
    int rc = -1, core = -1;
    th->stop = th->done = 0;
    th->fifo = th->locked = th->io_error = th->awake = 0;
    th->io_error_tick = -1;
    th->seq = 0;
    memset(&th->snap, 0, sizeof th->snap);
#ifdef __linux__
    if (th->keep_awake)
        core = awake_core();
#endif
    if (pthread_attr_init(&attr) != 0)
        return EAGAIN;
#ifdef __linux__
    if (core >= 0) { /* pinned to the core its companion keeps awake */
        cpu_set_t one;
        CPU_ZERO(&one);
        CPU_SET((size_t)core, &one);
        if (pthread_attr_setaffinity_np(&attr, sizeof one, &one) != 0)
            core = -1;
    }
#endif
    if (th->priority > 0) { /* a real-time thread, where allowed */
        struct sched_param sp;
        sp.sched_priority = th->priority;
        if (pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED) == 0 &&
            pthread_attr_setschedpolicy(&attr, SCHED_FIFO) == 0 && pthread_attr_setschedparam(&attr, &sp) == 0)
            rc = pthread_create(tid, &attr, loop, th);
        th->fifo = rc == 0;
        if (rc != 0) /* refused (EPERM without the rights): a plain thread, still pinned */
            pthread_attr_setinheritsched(&attr, PTHREAD_INHERIT_SCHED);
    }
    if (rc != 0) /* refused, or not asked: a plain thread */
        rc = pthread_create(tid, &attr, loop, th);
    pthread_attr_destroy(&attr);
    th->started = rc == 0;
    (void)core;
#ifdef __linux__
    if (rc == 0 && core >= 0 && pthread_attr_init(&attr) == 0) {
        cpu_set_t one;
        struct sched_param sp;
        sp.sched_priority = 0;
        CPU_ZERO(&one);
        CPU_SET((size_t)core, &one);
        /* SCHED_OTHER whatever the caller's policy: a real-time spinner would starve the core */
        if (pthread_attr_setinheritsched(&attr, PTHREAD_EXPLICIT_SCHED) == 0 &&
            pthread_attr_setschedpolicy(&attr, SCHED_OTHER) == 0 && pthread_attr_setschedparam(&attr, &sp) == 0 &&
            pthread_attr_setaffinity_np(&attr, sizeof one, &one) == 0 &&
            pthread_create((pthread_t *)(void *)th->companion, &attr, companion, th) == 0)
            th->awake = core + 1;
        pthread_attr_destroy(&attr);
    }
#endif
    return rc;
}

void hx_thread_join(hx_thread *th)
{
    if (th->started) {
        pthread_join(*(pthread_t *)(void *)th->handle, NULL);
        if (th->awake) /* the companion ends once the loop is done */
            pthread_join(*(pthread_t *)(void *)th->companion, NULL);
    }
    th->started = 0;
}
