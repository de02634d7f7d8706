/*
 * The host side of the C core: what runs on the computer a device is plugged into, not in a
 * device's firmware (``haptex export`` does not ship these files).
 *
 * - hx_plant: a device preset held by a hand, advanced one servo period at a time by the exact
 *   sampled-data transition of haptex.simulate (the simulated device of ``haptex run``);
 * - hx_thread: the native servo thread, which samples a device, runs the servo rules
 *   (hx_servo) and a renderer's tick (hx_renderer), and commands the force, on a periodic
 *   clock, with no Python and no allocation on the tick.
 */
#ifndef HX_HOST_H
#define HX_HOST_H

#include "hx_core.h"

#include <stdint.h>

/* ---- the simulated device ------------------------------------------------------------ */

#define HX_PLANT_MAXSTATE 21 /* 5 d of the augmented dynamics plus 2 d of a structural mode, d <= 3 */
#define HX_PLANT_MAXDELAY 64 /* ticks of computation delay */

typedef struct {
    /* settings: the state x = [p, v, u, g, r (, p_h, v_h)] of haptex.simulate's augmented
     * dynamics, u the held force, g the hand's pull K s(t) + C ds/dt, r = dg/dt */
    int n;                  /* dimension d: 2 ([x, z]) or 3 ([x, y, z]) */
    int m;                  /* the state's size */
    int delay;              /* ticks between a command and the force acting */
    double period;          /* s */
    double resolution;      /* m: positions are read rounded to it (0: exact) */
    double max_force;       /* N: the amplifiers' limit (a larger command is scaled to it) */
    double phi[HX_PLANT_MAXSTATE * HX_PLANT_MAXSTATE]; /* the transition over a period, row-major */
    double K[9], C[9];      /* the hand's stiffness (N/m) and damping (N s/m), d x d row-major */
    double s0[3], sv[3];    /* the hand's set-point s(t) = s0 + sv t (m, m/s) */
    /* state */
    double x[HX_PLANT_MAXSTATE];
    double queue[HX_PLANT_MAXDELAY][3]; /* the forces in flight, oldest at head */
    int head;
    long k;                 /* periods advanced */
} hx_plant;

/* The handle at rest at height start (m) above the origin, nothing in flight. */
void hx_plant_reset(hx_plant *d, double start);

/* No force acting or in flight (the device released); the handle's motion is kept. */
void hx_plant_release(hx_plant *d);

/* The handle's position (m) as its encoder reads it, [x, y, z] (y = 0 in the plane). */
void hx_plant_read(const hx_plant *d, double p[3]);

/* Hold f (N, [x, y, z]) over the next period (after the delay) and advance one period:
 * 0, or -1 for a force that is not finite or a state that is no longer finite. */
int hx_plant_write(hx_plant *d, const double f[3]);

/* ---- Haply's Inverse3 over its serial port (hx_haply.c) ------------------------------- */

enum { HX_HAPLY_EWRITE = 1, HX_HAPLY_EREAD = 2, HX_HAPLY_ETIMEOUT = 3, HX_HAPLY_EGARBLED = 4 };

typedef struct {
    intptr_t fd;         /* the port, opened raw by the caller: a file descriptor; on Windows a HANDLE */
    double timeout;      /* s: the longest wait for an answer */
    double p[3], v[3];   /* the last answer's position (m) and velocity (m/s) */
    double sent[3];      /* the last force sent (N, as float32 rounded towards zero) */
    long exchanges;      /* force commands answered */
    int error;           /* the last failure (HX_HAPLY_E*), 0: none */
} hx_haply;

/* float32 of f rounded towards zero (0 for a non-finite f): never larger than asked. */
float hx_haply_f32(double f);
/* The wakeup: 0, its answer's 21 bytes after 0x0B in info; or HX_HAPLY_E*. */
int hx_haply_wakeup(hx_haply *h, double timeout, unsigned char info[21]);
/* One force command (N) and its answer, kept in p and v: 0 or HX_HAPLY_E* (also in error). */
int hx_haply_exchange(hx_haply *h, const double f[3]);
/* hx_io's read and write over an hx_haply (ctx): the last answer's position; an exchange. */
int hx_haply_read(void *ctx, double p[3]);
int hx_haply_write(void *ctx, const double f[3]);
/* Open the Inverse3's port for hx_haply: 0 and the port in *port, or HX_HAPLY_EREAD (errno,
 * or on Windows GetLastError, says why). POSIX: a terminal by its path ("/dev/ttyACM0"), raw
 * (cfmakeraw), buffers flushed, a file descriptor. Windows: a COM port by name ("COM3", or
 * "\\.\COM3" as it is), raw 8N1, no flow control, buffers purged, its HANDLE. hx_haply_close
 * closes it. */
int hx_haply_open(const char *name, intptr_t *port);
void hx_haply_close(intptr_t port);

/* ---- the native servo thread ---------------------------------------------------------- */

/* a device as the thread sees it: read the position (m, haptex's frame [x, y, z]) and write
 * the force (N); each returns 0, or nonzero when the device failed (the run stops) */
typedef struct {
    int (*read)(void *ctx, double p[3]);
    int (*write)(void *ctx, const double f[3]);
    void *ctx;
} hx_io;

#define HX_HIST_BINS 65536 /* tick-time histograms: 100 ns bins up to 6.5536 ms, then one bin */
#define HX_HIST_STEP 1e-7

/* what a driver counts beyond hx_servo: histograms of each tick's work and of the period's
 * jitter |dt - T| (dt the time between samples), their maxima, overruns */
typedef struct {
    unsigned int *work, *jitter; /* HX_HIST_BINS + 1 counts each, or NULL (not counted) */
    double work_max, jitter_max; /* s */
    long overruns;               /* ticks whose command left after the next tick was due */
} hx_ticks;

/* Count one tick: its work (s) and jitter (s, < 0: none, the first tick). */
void hx_ticks_count(hx_ticks *c, double work, double jitter);

/* The q-quantile (0 < q <= 1) of a histogram of hx_ticks (s, the upper edge of its bin);
 * 0 for an empty one. */
double hx_ticks_quantile(const unsigned int *hist, double q);

typedef struct hx_thread hx_thread;

/* What the dashboard reads without locking (a seqlock: consistent, or retried). */
typedef struct {
    long k;         /* ticks commanded */
    double t;       /* s: the tick's sample time */
    double p[3];    /* m */
    double f[3];    /* N, as sent */
} hx_snapshot;

struct hx_thread {
    /* settings */
    hx_servo *servo;
    hx_renderer *renderer;
    hx_io io;
    hx_ticks *ticks;
    long n_ticks;
    int paced;      /* 1: one tick a period on the clock; 0: as fast as it goes (tests, batch) */
    double spin;    /* s: sleep until this long before a tick is due, then read the clock until it is */
    int priority;   /* SCHED_FIFO priority to ask for (1-99; on Windows any > 0: time-critical), 0: a plain thread */
    int lock_memory;/* mlockall for the run, where allowed */
    int keep_awake; /* pin the thread to one core and keep that core busy below it (hx_thread.c) */
    /* results, written by the thread */
    volatile int stop, done;
    int fifo, locked;       /* what the thread got */
    int awake;              /* the core was kept awake (Linux or Windows, not Wine; 2 cores or more): its number + 1, else 0 */
    int io_error;           /* the device failed (read 1, write 2) */
    long io_error_tick;
    /* the seqlock */
    volatile unsigned long seq;
    hx_snapshot snap;
    /* the thread's handle and its companion's (pthread_t, kept opaque here) */
    unsigned char handle[64], companion[64];
    int started;
};

/* Start the thread (settings filled, results zero): 0, or an errno value (nothing running). */
int hx_thread_start(hx_thread *th);

/* Wait for the thread's end (it ends on its own after n_ticks or on stop). */
void hx_thread_join(hx_thread *th);

/* A consistent copy of the last tick's snapshot. */
void hx_thread_snapshot(const hx_thread *th, hx_snapshot *out);

/* monotonic clock (s) */
double hx_now(void);

#endif
