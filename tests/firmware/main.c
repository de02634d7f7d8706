/* The exported tick along a stroke (stroke.h, written by tests/test_firmware.py), each force
 * printed as the hexadecimal bits of its doubles by semihosting: the host compares them with
 * haptex.Renderer's to the bit pattern's value. */
#include "haptex_texture.h"
#include "stroke.h"
#include <stdint.h>
#include <string.h>

void hx_fw_write(const char *s);

static void hex(double v, char *out)
{
    uint64_t b;
    int i;
    memcpy(&b, &v, sizeof b);
    for (i = 15; i >= 0; i--) {
        out[i] = "0123456789abcdef"[b & 15u];
        b >>= 4;
    }
}

int main(void)
{
    static haptex_state s;
    char line[3 * 17 + 1];
    int k, j;
    if (haptex_init(&s) != 0)
        return 2;
    for (k = 0; k < STROKE_N; k++) {
        double f[3] = {0.0, 0.0, 0.0};
        (void)haptex_step(&s, stroke[k], f);
        for (j = 0; j < HAPTEX_DIMENSION; j++) {
            hex(f[j], line + 17 * j);
            line[17 * j + 16] = j + 1 < HAPTEX_DIMENSION ? ' ' : '\n';
        }
        line[17 * HAPTEX_DIMENSION] = 0;
        hx_fw_write(line);
    }
    return 0;
}
