/*
 * An Inverse3 in C behind a pseudo-terminal, for the backends benchmark (benchmarks/
 * run_backends.py): the exchanges of haptex.backends.haply_serial's docstring (the wakeup 0x0A
 * answered with 0x0B and the device's info; a force command 0x2A + 3 float32 answered with 0x2B
 * + position and velocity as 6 float32, little-endian), each answer sent a period after the
 * previous one on an absolute deadline of the monotonic clock (lock-step at the device's rate).
 * The device behind it: a 0.1 kg mass held by a 200 N/m, 2 N s/m hand 1 mm inside the wall
 * (the DHD and HD stubs' "device in C"), advanced one period under each force.
 *
 * Usage: inverse3_stub [PERIOD_S]. Prints the port's path on its first line, then serves until
 * killed. Little-endian hosts only (the benchmark's).
 */
#define _XOPEN_SOURCE 700
#define _DEFAULT_SOURCE
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

static double p[3] = {0.0, 0.0, -1e-3}, v[3], rest[3] = {0.0, 0.0, -1e-3};
static const double M = 0.1, KH = 200.0, BH = 2.0;

static void advance(const float *f, double T)
{
    int i, j;
    double h = T / 100.0;
    for (j = 0; j < 100; j++)
        for (i = 0; i < 3; i++) {
            double a = ((double)f[i] + KH * (rest[i] - p[i]) - BH * v[i]) / M;
            v[i] += a * h;
            p[i] += v[i] * h;
        }
}

static void add(struct timespec *t, double s)
{
    long ns = (long)(s * 1e9);
    t->tv_sec += ns / 1000000000L;
    t->tv_nsec += ns % 1000000000L;
    if (t->tv_nsec >= 1000000000L) {
        t->tv_sec++;
        t->tv_nsec -= 1000000000L;
    }
}

static int read_all(int fd, unsigned char *b, size_t n)
{
    while (n > 0) {
        ssize_t r = read(fd, b, n);
        if (r <= 0)
            return -1;
        b += r;
        n -= (size_t)r;
    }
    return 0;
}

int main(int argc, char **argv)
{
    double T = argc > 1 ? atof(argv[1]) : 1e-3;
    int fd = posix_openpt(O_RDWR | O_NOCTTY), slave;
    struct termios tio;
    struct timespec due, now;
    unsigned char c, cmd[12], out[25];
    if (fd < 0 || grantpt(fd) || unlockpt(fd))
        return 1;
    /* raw on the far end, kept open by this process so that the port exists between clients */
    slave = open(ptsname(fd), O_RDWR | O_NOCTTY);
    if (slave < 0 || tcgetattr(slave, &tio))
        return 1;
    cfmakeraw(&tio);
    tcsetattr(slave, TCSANOW, &tio);
    printf("%s\n", ptsname(fd));
    fflush(stdout);
    clock_gettime(CLOCK_MONOTONIC, &due);
    for (;;) {
        if (read(fd, &c, 1) != 1) {
            usleep(1000); /* no client: wait for one */
            continue;
        }
        clock_gettime(CLOCK_MONOTONIC, &now);
        add(&due, T); /* a period after the last answer, or now if that is past */
        if (due.tv_sec < now.tv_sec || (due.tv_sec == now.tv_sec && due.tv_nsec < now.tv_nsec))
            due = now;
        if (c == 0x0A) {
            unsigned char info[22] = {0x0B, 0x34, 0x12, 7, 3, 12};
            clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, NULL);
            if (write(fd, info, sizeof info) != (ssize_t)sizeof info)
                return 1;
        } else if (c == 0x2A) {
            float f[3], s[6];
            int i;
            if (read_all(fd, cmd, sizeof cmd))
                continue;
            memcpy(f, cmd, sizeof f);
            advance(f, T);
            for (i = 0; i < 3; i++) {
                s[i] = (float)p[i];
                s[3 + i] = (float)v[i];
            }
            out[0] = 0x2B;
            memcpy(out + 1, s, sizeof s);
            clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, NULL);
            if (write(fd, out, sizeof out) != (ssize_t)sizeof out)
                return 1;
        }
    }
}
