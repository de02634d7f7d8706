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
 *
 * Windows (_WIN32, built with mingw-w64): the same loop on a thread of _beginthreadex at
 * THREAD_PRIORITY_TIME_CRITICAL where asked (priority > 0; "fifo" reports it), the deadlines on
 * QueryPerformanceCounter, the sleep on a high-resolution waitable timer
 * (CREATE_WAITABLE_TIMER_HIGH_RESOLUTION, Windows 10 1803 and later; a plain waitable timer,
 * ~1-15.6 ms coarse, where it is missing) before the same spin on the clock; the companion at
 * THREAD_PRIORITY_IDLE on the last core of the process's affinity. No memory is locked there
 * (VirtualLock locks a range, not a process): "locked" stays 0. macOS (no clock_nanosleep):
 * a relative nanosleep to the same absolute deadline, THREAD_TIME_CONSTRAINT_POLICY where a
 * priority is asked ("fifo" reports it), no affinity and no companion; compiled for x86-64 and
 * arm64 macOS by zig's clang in the tests, never run.
 */
#define _GNU_SOURCE
#include "hx_host.h"

#include <errno.h>
#include <math.h>
#include <string.h>
#ifdef _WIN32
#include <windows.h>
#include <process.h>
#ifndef CREATE_WAITABLE_TIMER_HIGH_RESOLUTION
#define CREATE_WAITABLE_TIMER_HIGH_RESOLUTION 0x00000002
#endif
#else
#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>
#if defined(__APPLE__) || defined(HX_NO_CLOCK_NANOSLEEP)
#define HX_RELATIVE_SLEEP 1 /* macOS has no clock_nanosleep */
#endif
#endif
#ifdef __linux__
#include <sys/resource.h>
#include <sys/syscall.h>
#endif
#ifdef __APPLE__
#include <mach/mach.h>
#include <mach/mach_time.h>
#include <mach/thread_policy.h>
#endif

#ifdef _WIN32
typedef HANDLE hx_os_thread;
#else
typedef pthread_t hx_os_thread;
#endif
/* the threads' handles live in hx_thread's opaque bytes */
typedef char hx_thread_fits[sizeof(hx_os_thread) <= sizeof(((hx_thread *)0)->handle) ? 1 : -1];

#ifdef _WIN32
static double qpc_period(void)
{
    static double period = 0.0; /* s a count; the frequency is fixed at boot */
    if (period == 0.0) {
        LARGE_INTEGER f;
        QueryPerformanceFrequency(&f);
        period = 1.0 / (double)f.QuadPart;
    }
    return period;
}

double hx_now(void)
{
    LARGE_INTEGER c;
    QueryPerformanceCounter(&c);
    return (double)c.QuadPart * qpc_period();
}
#else
double hx_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}
#endif

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
    HX_STORE_RLX(&th->seq, th->seq + 1);
    HX_FENCE_REL();
    th->snap.k = th->servo->k;
    th->snap.t = t;
    memcpy(th->snap.p, p, 3 * sizeof p[0]);
    memcpy(th->snap.f, f, 3 * sizeof f[0]);
    HX_STORE_REL(&th->seq, th->seq + 1);
}

void hx_thread_snapshot(const hx_thread *th, hx_snapshot *out)
{
    unsigned long a, b;
    do {
        a = HX_LOAD_ACQ(&th->seq);
        memcpy(out, (const void *)&th->snap, sizeof *out);
        HX_FENCE_ACQ();
        b = HX_LOAD_RLX(&th->seq);
    } while ((a & 1UL) || a != b);
}

/* ---- deadlines: absolute times on hx_now's clock ------------------------------------- */

#ifdef _WIN32
typedef struct {
    LONGLONG c; /* performance-counter counts */
} hx_due;

static void due_start(hx_due *d)
{
    LARGE_INTEGER c;
    QueryPerformanceCounter(&c);
    d->c = c.QuadPart;
}

static void due_add(hx_due *d, double s) { d->c += (LONGLONG)llround(s / qpc_period()); }

static double due_seconds(const hx_due *d) { return (double)d->c * qpc_period(); }
#else
typedef struct timespec hx_due;

static void due_start(hx_due *d) { clock_gettime(CLOCK_MONOTONIC, d); }

static void due_add(hx_due *ts, double s)
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

static double due_seconds(const hx_due *ts) { return (double)ts->tv_sec + 1e-9 * (double)ts->tv_nsec; }
#endif

/* Sleep until spin seconds before the deadline, then read the clock until it is due. */
static void due_wait(const hx_due *d, double spin, void *timer)
{
#ifdef _WIN32
    double left = due_seconds(d) - spin - hx_now();
    if (left > 0.0 && timer != NULL) {
        LARGE_INTEGER rel;
        rel.QuadPart = -(LONGLONG)(left * 1e7); /* 100 ns units; negative: relative to now */
        if (rel.QuadPart < 0 && SetWaitableTimer((HANDLE)timer, &rel, 0, NULL, NULL, FALSE))
            WaitForSingleObject((HANDLE)timer, INFINITE);
    }
#elif defined(HX_RELATIVE_SLEEP)
    double left = due_seconds(d) - spin - hx_now();
    (void)timer;
    if (left > 0.0) {
        struct timespec rel;
        rel.tv_sec = (time_t)left;
        rel.tv_nsec = (long)((left - (double)rel.tv_sec) * 1e9);
        while (nanosleep(&rel, &rel) == -1 && errno == EINTR)
            ;
    }
#else
    hx_due early = *d;
    (void)timer;
    due_add(&early, -spin);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &early, NULL) == EINTR)
        ;
#endif
    while (hx_now() < due_seconds(d)) /* the last spin seconds on the clock */
        ;
}

/* ---- the loop --------------------------------------------------------------------------- */

static void run(hx_thread *th)
{
    hx_servo *s = th->servo;
    const double T = s->period, zero[3] = {0.0, 0.0, 0.0};
    double p[3], f[3], prev = -1.0;
    hx_due due;
    void *timer = NULL;
    long k;
#ifdef _WIN32
    if (th->paced) {
        timer = CreateWaitableTimerExW(NULL, NULL, CREATE_WAITABLE_TIMER_HIGH_RESOLUTION, TIMER_ALL_ACCESS);
        if (timer == NULL) /* before Windows 10 1803 */
            timer = CreateWaitableTimerW(NULL, TRUE, NULL);
    }
#else
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
#endif
    due_start(&due);
    for (k = 0; k < th->n_ticks && !th->stop; k++) {
        double wake, end, due_s;
        if (k > 0) {
            due_add(&due, T);
            if (th->paced)
                due_wait(&due, th->spin, timer);
        }
        due_s = due_seconds(&due);
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
            due_add(&due, (double)(behind - 1) * T);
        }
    }
    th->io.write(th->io.ctx, zero); /* zero force on every exit: the end, stop, a failed device */
#ifdef _WIN32
    if (timer != NULL)
        CloseHandle((HANDLE)timer);
#else
    if (th->locked)
        munlockall();
#endif
    HX_STORE_REL(&th->done, 1);
}

static void reset(hx_thread *th)
{
    th->stop = th->done = 0;
    th->fifo = th->locked = th->io_error = th->awake = 0;
    th->io_error_tick = -1;
    th->seq = 0;
    memset(&th->snap, 0, sizeof th->snap);
}

#ifdef _WIN32
static unsigned __stdcall loop(void *arg)
{
    run(arg);
    return 0;
}

static unsigned __stdcall companion(void *arg)
{
    /* below everything on its core (THREAD_PRIORITY_IDLE): any other thread there runs first */
    hx_thread *th = arg;
    while (!HX_LOAD_ACQ(&th->done) && !th->stop)
        YieldProcessor();
    return 0;
}

/* The last core of the process's affinity, when it has two or more; -1 for none, and under
 * Wine (its ntdll exports wine_get_version), which runs every thread at Linux's one ordinary
 * priority: an idle companion there competes with the servo thread for the core (measured at
 * 1 kHz: 40-90 overruns in 3000 ticks with it, 4 without) instead of yielding to it. */
static int awake_core(void)
{
    DWORD_PTR mine, all;
    HMODULE ntdll = GetModuleHandleA("ntdll.dll");
    int c, n = 0, last = -1;
    if (ntdll != NULL && GetProcAddress(ntdll, "wine_get_version") != NULL)
        return -1;
    if (!GetProcessAffinityMask(GetCurrentProcess(), &mine, &all))
        return -1;
    for (c = 0; c < (int)(8 * sizeof mine); c++)
        if ((mine >> c) & 1u) {
            n++;
            last = c;
        }
    return n >= 2 ? last : -1;
}

int hx_thread_start(hx_thread *th)
{
    HANDLE *tid = (HANDLE *)(void *)th->handle, *cid = (HANDLE *)(void *)th->companion;
    int core = -1;
    reset(th);
    if (th->keep_awake)
        core = awake_core();
    *tid = (HANDLE)_beginthreadex(NULL, 0, loop, th, CREATE_SUSPENDED, NULL);
    if (*tid == NULL)
        return EAGAIN;
    if (core >= 0 && SetThreadAffinityMask(*tid, (DWORD_PTR)1 << core) == 0)
        core = -1;
    if (th->priority > 0) /* time-critical where the process may (its class caps it otherwise) */
        th->fifo = SetThreadPriority(*tid, THREAD_PRIORITY_TIME_CRITICAL) != 0;
    th->started = 1;
    if (core >= 0) {
        *cid = (HANDLE)_beginthreadex(NULL, 0, companion, th, CREATE_SUSPENDED, NULL);
        if (*cid != NULL) {
            SetThreadAffinityMask(*cid, (DWORD_PTR)1 << core);
            SetThreadPriority(*cid, THREAD_PRIORITY_IDLE);
            th->awake = core + 1;
            ResumeThread(*cid);
        }
    }
    ResumeThread(*tid);
    return 0;
}

void hx_thread_join(hx_thread *th)
{
    if (th->started) {
        HANDLE tid = *(HANDLE *)(void *)th->handle;
        WaitForSingleObject(tid, INFINITE);
        CloseHandle(tid);
        if (th->awake) { /* the companion ends once the loop is done */
            HANDLE cid = *(HANDLE *)(void *)th->companion;
            WaitForSingleObject(cid, INFINITE);
            CloseHandle(cid);
        }
    }
    th->started = 0;
}
#else
static void *loop(void *arg)
{
    run(arg);
    return NULL;
}

#ifdef __linux__
static void *companion(void *arg)
{
    /* below everything on its core: any other task there runs first, the servo thread at once */
    hx_thread *th = arg;
    setpriority(PRIO_PROCESS, (id_t)syscall(SYS_gettid), 19);
    while (!HX_LOAD_ACQ(&th->done) && !th->stop)
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

#ifdef __APPLE__
/* macOS's real-time threads: THREAD_TIME_CONSTRAINT_POLICY (Apple's Kernel Programming Guide,
 * "Mach Scheduling and Thread Interfaces"), each period of the servo's (mach absolute time
 * units) with half of it as the computation the scheduler guarantees (chosen: the tick takes
 * microseconds, the device's exchange the rest), due within the period, preemptible. 1 if the
 * kernel took it. */
static int time_constraint(pthread_t tid, double period)
{
    mach_timebase_info_data_t tb;
    thread_time_constraint_policy_data_t p;
    double units;
    if (mach_timebase_info(&tb) != KERN_SUCCESS || tb.numer == 0 || !(period > 0.0 && period < 1.0))
        return 0;
    units = 1e9 * (double)tb.denom / (double)tb.numer; /* mach units a second */
    p.period = (uint32_t)(period * units);
    p.computation = (uint32_t)(0.5 * period * units);
    p.constraint = p.period;
    p.preemptible = 1;
    return thread_policy_set(pthread_mach_thread_np(tid), THREAD_TIME_CONSTRAINT_POLICY, (thread_policy_t)&p,
                             THREAD_TIME_CONSTRAINT_POLICY_COUNT) == KERN_SUCCESS;
}
#endif

int hx_thread_start(hx_thread *th)
{
    pthread_t *tid = (pthread_t *)(void *)th->handle;
    pthread_attr_t attr;
    int rc = -1, core = -1;
    reset(th);
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
#ifdef __APPLE__
    if (th->priority > 0) { /* a plain thread, then the time-constraint policy (macOS's real-time) */
        rc = pthread_create(tid, &attr, loop, th);
        th->fifo = rc == 0 && time_constraint(*tid, th->servo->period);
    }
#else
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
#endif
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
#endif
