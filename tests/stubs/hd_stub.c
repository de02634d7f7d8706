/* A stand-in for OpenHaptics' libHD, built by haptex's tests: the vendor's own Python binding
 * (pyOpenHaptics) loads it as it would the SDK ("libHD.so", this library's soname), and every
 * frame reaches a device the test binds behind it (haptex's simulator, through two function
 * pointers). What a servo loop uses is real here, with the HD API's semantics:
 *
 * - hdStartScheduler starts a servo thread that runs the scheduled callbacks once a period
 *   (1 kHz, absolute deadlines on CLOCK_MONOTONIC); a callback returning HD_CALLBACK_DONE is
 *   removed; hdScheduleSynchronous waits until its callback has run in that thread;
 * - hdBeginFrame reads the device's state; hdEndFrame sends the force set in the frame (only
 *   while HD_FORCE_OUTPUT is enabled); hdStopScheduler ends the thread and the force output;
 * - units are the HD API's: millimetres, mm/s and newtons, x right, y up, z towards the user.
 */
#include <pthread.h>
#include <string.h>
#include <time.h>

typedef unsigned int HDenum, HHD, HDCallbackCode, HDerror;
typedef HDCallbackCode (*HDSchedulerCallback)(void *);
typedef struct { HDerror errorCode; int internalErrorCode; HHD hHD; } HDErrorInfo;
typedef void (*hxstub_read_fn)(double *state); /* p[3] (mm), v[3] (mm/s), buttons */
typedef void (*hxstub_write_fn)(const double *force);

#define HD_INVALID_HANDLE 0xFFFFFFFFu
#define HD_DEVICE_ERROR 0x0300
#define HD_INVALID_ENUM 0x0100
#define HD_INVALID_OPERATION 0x0103
#define HD_SCHEDULER_FULL 0x0501
#define HD_CURRENT_BUTTONS 0x2000
#define HD_CURRENT_POSITION 0x2050
#define HD_CURRENT_VELOCITY 0x2051
#define HD_CURRENT_TRANSFORM 0x2052
#define HD_NOMINAL_MAX_FORCE 0x2603
#define HD_CURRENT_FORCE 0x2700
#define HD_DEVICE_MODEL_TYPE 0x2501
#define HD_DEVICE_VENDOR 0x2503
#define HD_FORCE_OUTPUT 0x4000
#define SLOTS 16

static hxstub_read_fn rd;
static hxstub_write_fn wr;
static int present = 1, initialised = 0, output = 0, running = 0, in_frame = 0;
static HDerror error = 0;
static double state[7], force[3], max_force = 3.3;
static char model[64] = "Touch";
static long frames = 0, energised_after_stop = 0;
static pthread_t servo;
static pthread_mutex_t lock = PTHREAD_MUTEX_INITIALIZER;
static pthread_cond_t ran = PTHREAD_COND_INITIALIZER;
static HDSchedulerCallback slot[SLOTS];
static void *slot_data[SLOTS];
static int slot_sync[SLOTS], slot_done[SLOTS];

/* -- the test's side -- */
void hxstub_bind(hxstub_read_fn r, hxstub_write_fn w, const char *model_name, double nominal_max_force,
                 int device_present)
{
    rd = r;
    wr = w;
    strncpy(model, model_name, sizeof model - 1);
    max_force = nominal_max_force;
    present = device_present;
    initialised = output = in_frame = 0;
    error = 0;
    frames = energised_after_stop = 0;
    memset(force, 0, sizeof force);
}
/* A device in C behind the stub, for runs whose servo thread must not take the GIL: a point
 * mass m (kg) held by a hand, a spring kh (N/m) and damper bh (N s/m) to a rest point (mm, HD's
 * frame), moved by the force each frame sends, held over one 1 ms period (semi-implicit Euler
 * in 100 sub-steps). */
static double mass_m, mass_kh, mass_bh, mass_rest[3], mass_p[3], mass_v[3];
static void mass_read(double *st)
{
    int i;
    for (i = 0; i < 3; i++) {
        st[i] = mass_p[i];
        st[3 + i] = mass_v[i];
    }
    st[6] = 0.0;
}
static void mass_write(const double *f)
{
    int i, j;
    for (j = 0; j < 100; j++)
        for (i = 0; i < 3; i++) { /* SI inside: mm -> m and back */
            double a = (f[i] + mass_kh * (mass_rest[i] - mass_p[i]) * 1e-3 - mass_bh * mass_v[i] * 1e-3) / mass_m;
            mass_v[i] += 1e3 * a * 1e-5;
            mass_p[i] += mass_v[i] * 1e-5;
        }
}
void hxstub_bind_mass(double m, double kh, double bh, const double *rest_mm, const char *model_name,
                      double nominal_max_force)
{
    int i;
    mass_m = m;
    mass_kh = kh;
    mass_bh = bh;
    for (i = 0; i < 3; i++) {
        mass_rest[i] = mass_p[i] = rest_mm[i];
        mass_v[i] = 0.0;
    }
    hxstub_bind(mass_read, mass_write, model_name, nominal_max_force, 1);
}
void hxstub_mass_position(double *p_mm) { memcpy(p_mm, mass_p, sizeof mass_p); }
long hxstub_frames(void) { return frames; }
long hxstub_energised_after_stop(void) { return energised_after_stop; }
int hxstub_running(void) { return running; }
int hxstub_initialised(void) { return initialised; }

/* -- the SDK's -- */
HDErrorInfo hdGetError(void)
{
    HDErrorInfo e = {error, 0, 0};
    error = 0;
    return e;
}
HHD hdInitDevice(const char *name)
{
    (void)name;
    if (!present || rd == 0) {
        error = HD_DEVICE_ERROR;
        return HD_INVALID_HANDLE;
    }
    initialised = 1;
    return 0;
}
HHD hdGetCurrentDevice(void) { return 0; }
void hdMakeCurrentDevice(HHD h) { (void)h; }
void hdDisableDevice(HHD h)
{
    (void)h;
    initialised = 0;
}
void hdEnable(HDenum cap)
{
    if (cap == HD_FORCE_OUTPUT)
        output = 1;
    else
        error = HD_INVALID_ENUM;
}
void hdDisable(HDenum cap)
{
    if (cap == HD_FORCE_OUTPUT)
        output = 0;
}
const char *hdGetString(HDenum what)
{
    if (what == HD_DEVICE_MODEL_TYPE)
        return model;
    if (what == HD_DEVICE_VENDOR)
        return "3D Systems (haptex's stub)";
    error = HD_INVALID_ENUM;
    return "";
}
void hdBeginFrame(HHD h)
{
    (void)h;
    if (!initialised) {
        error = HD_INVALID_OPERATION;
        return;
    }
    rd(state);
    in_frame = 1;
}
void hdEndFrame(HHD h)
{
    double f[3] = {0.0, 0.0, 0.0};
    (void)h;
    if (!in_frame) {
        error = HD_INVALID_OPERATION;
        return;
    }
    if (output)
        memcpy(f, force, sizeof f);
    wr(f);
    frames++;
    in_frame = 0;
}
void hdGetDoublev(HDenum what, double *v)
{
    int i;
    switch (what) {
    case HD_CURRENT_POSITION:
        memcpy(v, state, 3 * sizeof(double));
        break;
    case HD_CURRENT_VELOCITY:
        memcpy(v, state + 3, 3 * sizeof(double));
        break;
    case HD_CURRENT_TRANSFORM: /* column-major 4 x 4: identity rotation, the position last */
        for (i = 0; i < 16; i++)
            v[i] = (i % 5 == 0) ? 1.0 : 0.0;
        memcpy(v + 12, state, 3 * sizeof(double));
        break;
    case HD_NOMINAL_MAX_FORCE:
        v[0] = max_force;
        break;
    case HD_CURRENT_FORCE:
        memcpy(v, force, sizeof force);
        break;
    default:
        error = HD_INVALID_ENUM;
    }
}
void hdGetIntegerv(HDenum what, int *v)
{
    if (what == HD_CURRENT_BUTTONS)
        v[0] = (int)state[6];
    else
        error = HD_INVALID_ENUM;
}
void hdSetDoublev(HDenum what, const double *v)
{
    if (what != HD_CURRENT_FORCE) {
        error = HD_INVALID_ENUM;
        return;
    }
    if (!in_frame) { /* HD: state is set inside a frame */
        error = HD_INVALID_OPERATION;
        return;
    }
    memcpy(force, v, sizeof force);
}

static void *servo_loop(void *arg)
{
    struct timespec due;
    (void)arg;
    clock_gettime(CLOCK_MONOTONIC, &due);
    for (;;) {
        int i;
        pthread_mutex_lock(&lock);
        if (!running) {
            pthread_mutex_unlock(&lock);
            break;
        }
        for (i = 0; i < SLOTS; i++) {
            HDSchedulerCallback cb = slot[i];
            void *data = slot_data[i];
            HDCallbackCode code;
            if (cb == 0)
                continue;
            pthread_mutex_unlock(&lock);
            code = cb(data);
            pthread_mutex_lock(&lock);
            if (code == 0 || slot_sync[i]) { /* HD_CALLBACK_DONE, or a synchronous call */
                slot[i] = 0;
                slot_done[i] = 1;
                pthread_cond_broadcast(&ran);
            }
        }
        pthread_mutex_unlock(&lock);
        due.tv_nsec += 1000000L;
        if (due.tv_nsec >= 1000000000L) {
            due.tv_nsec -= 1000000000L;
            due.tv_sec++;
        }
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, 0);
    }
    return 0;
}
void hdStartScheduler(void)
{
    pthread_mutex_lock(&lock);
    if (!running) {
        running = 1;
        pthread_create(&servo, 0, servo_loop, 0);
    }
    pthread_mutex_unlock(&lock);
}
void hdStopScheduler(void)
{
    int i;
    pthread_mutex_lock(&lock);
    if (!running) {
        pthread_mutex_unlock(&lock);
        return;
    }
    running = 0;
    pthread_mutex_unlock(&lock);
    pthread_join(servo, 0);
    if (force[0] != 0.0 || force[1] != 0.0 || force[2] != 0.0)
        energised_after_stop++;
    memset(force, 0, sizeof force);
    for (i = 0; i < SLOTS; i++)
        slot[i] = 0;
}
static int schedule(HDSchedulerCallback cb, void *data, int sync)
{
    int i;
    pthread_mutex_lock(&lock);
    for (i = 0; i < SLOTS && slot[i] != 0; i++)
        ;
    if (i == SLOTS || !running) {
        error = running ? HD_SCHEDULER_FULL : HD_INVALID_OPERATION;
        pthread_mutex_unlock(&lock);
        return -1;
    }
    slot[i] = cb;
    slot_data[i] = data;
    slot_sync[i] = sync;
    slot_done[i] = 0;
    if (sync)
        while (!slot_done[i] && running)
            pthread_cond_wait(&ran, &lock);
    pthread_mutex_unlock(&lock);
    return i;
}
unsigned long hdScheduleAsynchronous(HDSchedulerCallback cb, void *data, unsigned short priority)
{
    (void)priority;
    return (unsigned long)schedule(cb, data, 0);
}
void hdScheduleSynchronous(HDSchedulerCallback cb, void *data, unsigned short priority)
{
    (void)priority;
    schedule(cb, data, 1);
}
