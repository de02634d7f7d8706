/* The plain C loop the servo loops are compared against: a thread that wakes once a period
 * on absolute deadlines (CLOCK_MONOTONIC, as the HD stub's scheduler does) and does nothing
 * else. What it misses (a wake-up more than 1.5 periods after the previous one) is this
 * machine's floor: no servo loop on it can miss less.
 *
 *   cc -std=c99 -D_POSIX_C_SOURCE=200809L -O2 -o pace pace_reference.c && ./pace SECONDS RATE_HZ
 */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

int main(int argc, char **argv)
{
    double seconds = argc > 1 ? atof(argv[1]) : 60.0, rate = argc > 2 ? atof(argv[2]) : 1000.0;
    long n = (long)(seconds * rate), k, missed = 0, step = (long)(1e9 / rate);
    double last = 0.0, worst = 0.0;
    struct timespec due;
    clock_gettime(CLOCK_MONOTONIC, &due);
    for (k = 0; k < n; k++) {
        double t = now();
        if (k > 0) {
            if (t - last > 1.5 / rate)
                missed++;
            if (t - last > worst)
                worst = t - last;
        }
        last = t;
        due.tv_nsec += step;
        while (due.tv_nsec >= 1000000000L) {
            due.tv_nsec -= 1000000000L;
            due.tv_sec++;
        }
        clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &due, 0);
    }
    printf("%ld %ld %.6f\n", n, missed, worst);
    return 0;
}
