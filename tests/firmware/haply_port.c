/* Haply's Inverse3 exchange over a Windows COM port (hx_haply.c's Win32 path: CreateFile, 8N1,
 * COMMTIMEOUTS), run under Wine by tests/test_firmware.py against the emulated Inverse3 of
 * tests/vendor_stubs.py on a pseudo-terminal that Wine maps to the COM port. Opens the port
 * named, wakes the device, sends n force commands (f = [0, 0, 0.1 k / n] N, k = 0..n-1, then
 * zero) and prints one line:
 *   wakeup_status device_id model exchanges x y z (m, the last answer) f_z_sent (N, the last
 *   force command before the zero) status (0: every exchange answered) */
#include "hx_host.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int main(int argc, char **argv)
{
    hx_haply h;
    unsigned char info[21];
    intptr_t port;
    int rc = 0, wake, k, n = argc > 2 ? atoi(argv[2]) : 10;
    double fz = 0.0;
    if (argc < 2 || hx_haply_open(argv[1], &port) != 0) {
        printf("-1 0 0 0 0 0 0 0 -1\n");
        return 1;
    }
    memset(&h, 0, sizeof h);
    h.fd = port;
    h.timeout = 1.0;
    wake = hx_haply_wakeup(&h, 2.0, info);
    for (k = 0; k < n && wake == 0 && rc == 0; k++) {
        double f[3] = {0.0, 0.0, 0.1 * (double)k / (double)n};
        rc = hx_haply_exchange(&h, f);
        fz = h.sent[2];
    }
    if (wake == 0 && rc == 0) {
        double zero[3] = {0.0, 0.0, 0.0};
        rc = hx_haply_exchange(&h, zero);
    }
    printf("%d %d %d %ld %.9g %.9g %.9g %.9g %d\n", wake, info[0] | (info[1] << 8), info[2], h.exchanges, h.p[0],
           h.p[1], h.p[2], fz, rc);
    hx_haply_close(port);
    return wake != 0 || rc != 0;
}
