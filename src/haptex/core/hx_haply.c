/*
 * Haply's Inverse3 over its serial port, for the native servo thread (hx_thread): the
 * exchanges haptex.backends.haply_serial documents, as Haply's own package (HaplyHardwareAPI)
 * sends and accepts them (probed over a pseudo-terminal: Haply does not publish the format):
 *
 *   wakeup:         0x0A                      -> 0x0B, id (uint16), model, hardware, firmware
 *                                                (uint8 each), a 16-byte UUID
 *   force command:  0x2A, f_x, f_y, f_z (float32, N) -> 0x2B, position (3 float32, m),
 *                                                        velocity (3 float32, m/s)
 *
 * little-endian. Lock-step: each command is answered with the device's state, so a tick's
 * write is one exchange and its next read is that answer. An answer that does not come within
 * the timeout, or that starts with another byte, fails the exchange (the thread then stops and
 * commands zero); a state that is not finite is passed on (the servo's rules count the fault
 * and send zero). Forces are rounded towards zero to float32 (never larger than asked). The
 * port is the caller's (opened raw, by hx_haply_open or its own way); nothing here allocates.
 *
 * hx_haply_open opens the port the same way on every host: on POSIX a terminal device by its
 * path, raw (cfmakeraw: 8 bits, no parity, no echo or translation; the tty module's setraw does
 * the same), buffers flushed; on Windows a COM port's HANDLE (CreateFile, 8N1, no flow control,
 * buffers purged), whose writes are by WriteFile, reads by ReadFile under COMMTIMEOUTS that
 * return at the first byte there is or after the time left to the deadline (the same deadline
 * as poll's).
 */
#define _GNU_SOURCE
#include "hx_host.h"

#include <errno.h>
#include <math.h>
#include <stdint.h>
#include <string.h>
#ifdef _WIN32
#include <windows.h>
#else
#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>
#endif

enum { HX_HAPLY_WAKE = 0x0A, HX_HAPLY_AWAKE = 0x0B, HX_HAPLY_FORCE = 0x2A, HX_HAPLY_STATE = 0x2B };

/* 4 bytes copied in little-endian order (the wire's): reversed on a big-endian host */
static void copy_le32(unsigned char *dst, const unsigned char *src)
{
    const uint16_t one = 1;
    int k, little = *(const unsigned char *)&one == 1;
    for (k = 0; k < 4; k++)
        dst[k] = src[little ? k : 3 - k];
}

static void put_f32(unsigned char *out, float v)
{
    unsigned char b[4];
    memcpy(b, &v, 4);
    copy_le32(out, b);
}

static float get_f32(const unsigned char *in)
{
    unsigned char b[4];
    float v;
    copy_le32(b, in);
    memcpy(&v, b, 4);
    return v;
}

float hx_haply_f32(double f)
{
    float g;
    if (!isfinite(f))
        return 0.0f;
    g = (float)f;
    if (fabs((double)g) > fabs(f))
        g = nextafterf(g, 0.0f);
    return g;
}

#ifdef _WIN32
/* write all n bytes, or fail */
static int send_all(intptr_t port, const unsigned char *b, size_t n)
{
    while (n > 0) {
        DWORD w = 0;
        if (!WriteFile((HANDLE)port, b, (DWORD)n, &w, NULL) || w == 0)
            return HX_HAPLY_EWRITE;
        b += w;
        n -= (size_t)w;
    }
    return 0;
}

/* read exactly n bytes before the deadline (monotonic s), or fail */
static int recv_all(intptr_t port, unsigned char *b, size_t n, double deadline)
{
    while (n > 0) {
        double left = deadline - hx_now();
        COMMTIMEOUTS to;
        DWORD got = 0;
        if (left <= 0.0)
            return HX_HAPLY_ETIMEOUT;
        memset(&to, 0, sizeof to);
        to.ReadIntervalTimeout = MAXDWORD; /* with the multiplier MAXDWORD: return at the first byte */
        to.ReadTotalTimeoutMultiplier = MAXDWORD;
        to.ReadTotalTimeoutConstant = (DWORD)ceil(left * 1e3);
        if (!SetCommTimeouts((HANDLE)port, &to) || !ReadFile((HANDLE)port, b, (DWORD)n, &got, NULL))
            return HX_HAPLY_EREAD;
        b += got; /* (none: the deadline is checked above) */
        n -= (size_t)got;
    }
    return 0;
}

int hx_haply_open(const char *name, intptr_t *port)
{
    char path[64];
    HANDLE h;
    DCB dcb;
    /* COM10 and above need the device namespace; it serves COM1-9 as well (a name that already
     * carries it is taken as it is) */
    if (strlen(name) + 5 > sizeof path)
        return HX_HAPLY_EREAD;
    path[0] = '\0';
    if (strncmp(name, "\\\\.\\", 4) != 0)
        strcpy(path, "\\\\.\\");
    strcat(path, name);
    h = CreateFileA(path, GENERIC_READ | GENERIC_WRITE, 0, NULL, OPEN_EXISTING, 0, NULL);
    if (h == INVALID_HANDLE_VALUE)
        return HX_HAPLY_EREAD;
    memset(&dcb, 0, sizeof dcb);
    dcb.DCBlength = sizeof dcb;
    if (!GetCommState(h, &dcb)) {
        CloseHandle(h);
        return HX_HAPLY_EREAD;
    }
    dcb.BaudRate = CBR_115200; /* (a USB CDC port ignores it) */
    dcb.ByteSize = 8;
    dcb.Parity = NOPARITY;
    dcb.StopBits = ONESTOPBIT;
    dcb.fBinary = TRUE;
    dcb.fOutxCtsFlow = dcb.fOutxDsrFlow = FALSE;
    dcb.fOutX = dcb.fInX = FALSE;
    dcb.fDtrControl = DTR_CONTROL_ENABLE;
    dcb.fRtsControl = RTS_CONTROL_ENABLE;
    if (!SetCommState(h, &dcb)) {
        CloseHandle(h);
        return HX_HAPLY_EREAD;
    }
    PurgeComm(h, PURGE_RXCLEAR | PURGE_TXCLEAR);
    *port = (intptr_t)h;
    return 0;
}

void hx_haply_close(intptr_t port) { CloseHandle((HANDLE)port); }
#else
int hx_haply_open(const char *name, intptr_t *port)
{
    struct termios t;
    int fd = open(name, O_RDWR | O_NOCTTY | O_CLOEXEC);
    if (fd < 0)
        return HX_HAPLY_EREAD;
    if (tcgetattr(fd, &t) != 0) { /* (not a terminal: ENOTTY) */
        int e = errno;
        close(fd);
        errno = e;
        return HX_HAPLY_EREAD;
    }
    cfmakeraw(&t); /* 8 bits, no parity, no echo, no translation: the wire's bytes as they are */
    t.c_cc[VMIN] = 1;
    t.c_cc[VTIME] = 0;
    if (tcsetattr(fd, TCSANOW, &t) != 0 || tcflush(fd, TCIOFLUSH) != 0) {
        int e = errno;
        close(fd);
        errno = e;
        return HX_HAPLY_EREAD;
    }
    *port = (intptr_t)fd;
    return 0;
}

void hx_haply_close(intptr_t port) { close((int)port); }

/* write all n bytes, or fail */
static int send_all(intptr_t port, const unsigned char *b, size_t n)
{
    int fd = (int)port;
    while (n > 0) {
        ssize_t w = write(fd, b, n);
        if (w < 0) {
            if (errno == EINTR || errno == EAGAIN)
                continue;
            return HX_HAPLY_EWRITE;
        }
        b += w;
        n -= (size_t)w;
    }
    return 0;
}

/* read exactly n bytes before the deadline (monotonic s), or fail */
static int recv_all(intptr_t port, unsigned char *b, size_t n, double deadline)
{
    int fd = (int)port;
    while (n > 0) {
        struct pollfd pfd;
        double left = deadline - hx_now();
        ssize_t r;
        int rc;
        if (left <= 0.0)
            return HX_HAPLY_ETIMEOUT;
        pfd.fd = fd;
        pfd.events = POLLIN;
        pfd.revents = 0;
        rc = poll(&pfd, 1, (int)ceil(left * 1e3));
        if (rc < 0) {
            if (errno == EINTR)
                continue;
            return HX_HAPLY_EREAD;
        }
        if (rc == 0)
            continue; /* (the deadline is checked above) */
        if (pfd.revents & (POLLERR | POLLNVAL))
            return HX_HAPLY_EREAD;
        r = read(fd, b, n);
        if (r < 0) {
            if (errno == EINTR || errno == EAGAIN)
                continue;
            return HX_HAPLY_EREAD;
        }
        if (r == 0) { /* hung up: nothing more will come */
            if (pfd.revents & POLLHUP)
                return HX_HAPLY_EREAD;
            continue;
        }
        b += r;
        n -= (size_t)r;
    }
    return 0;
}
#endif

int hx_haply_wakeup(hx_haply *h, double timeout, unsigned char info[21])
{
    unsigned char wake = HX_HAPLY_WAKE, head;
    int rc = send_all(h->fd, &wake, 1);
    double deadline = hx_now() + timeout;
    if (rc != 0)
        return rc;
    if ((rc = recv_all(h->fd, &head, 1, deadline)) != 0)
        return rc;
    if (head != HX_HAPLY_AWAKE)
        return HX_HAPLY_EGARBLED;
    return recv_all(h->fd, info, 21, deadline);
}

int hx_haply_exchange(hx_haply *h, const double f[3])
{
    unsigned char cmd[13], ans[25];
    int i, rc;
    double deadline;
    cmd[0] = HX_HAPLY_FORCE;
    for (i = 0; i < 3; i++) {
        float g = hx_haply_f32(f[i]);
        h->sent[i] = (double)g;
        put_f32(cmd + 1 + 4 * i, g);
    }
    if ((rc = send_all(h->fd, cmd, sizeof cmd)) != 0)
        return h->error = rc;
    deadline = hx_now() + h->timeout;
    if ((rc = recv_all(h->fd, ans, 1, deadline)) != 0)
        return h->error = rc;
    if (ans[0] != HX_HAPLY_STATE)
        return h->error = HX_HAPLY_EGARBLED;
    if ((rc = recv_all(h->fd, ans + 1, 24, deadline)) != 0)
        return h->error = rc;
    for (i = 0; i < 3; i++) {
        h->p[i] = (double)get_f32(ans + 1 + 4 * i);
        h->v[i] = (double)get_f32(ans + 13 + 4 * i);
    }
    h->exchanges++; /* (a non-finite state is passed on: the servo's rules count it a fault, zero force) */
    return 0;
}

int hx_haply_read(void *ctx, double p[3])
{
    hx_haply *h = ctx;
    memcpy(p, h->p, sizeof h->p);
    return h->exchanges > 0 ? 0 : HX_HAPLY_EREAD; /* (a state must have been answered) */
}

int hx_haply_write(void *ctx, const double f[3]) { return hx_haply_exchange(ctx, f); }
