/* An example main for a bare-metal board (haptex export --target cortex-m4|cortex-m7): the servo
 * tick called at the device's rate, the texture's force written to the motors. The device's side
 * is yours: replace hx_board_position and hx_board_force (weak here: a handle at rest 0.2 mm
 * inside the wall, the force discarded) and call hx_board_tick from your timer interrupt at the
 * rate the texture was exported for. As it stands it runs 1000 ticks and returns the faults
 * counted (startup.c hands the status to a debugger or QEMU by semihosting). */
#include "haptex_texture.h"

static haptex_state state;

__attribute__((weak)) void hx_board_position(double p[HAPTEX_DIMENSION])
{
    int i;
    for (i = 0; i < HAPTEX_DIMENSION; i++)
        p[i] = 0.0;
    p[HAPTEX_DIMENSION - 1] = -0.2e-3; /* z: 0.2 mm inside the wall */
}

__attribute__((weak)) void hx_board_force(const double f[HAPTEX_DIMENSION]) { (void)f; }

/* one servo tick: sense, compute (never NaN, never above HAPTEX_MAX_FORCE, zero on a fault), command */
void hx_board_tick(void)
{
    double p[HAPTEX_DIMENSION], f[HAPTEX_DIMENSION];
    hx_board_position(p);
    (void)haptex_step(&state, p, f);
    hx_board_force(f);
}

int main(void)
{
    int k;
    if (haptex_init(&state) != 0)
        return 2;
    for (k = 0; k < 1000; k++) /* on a board: enable the timer interrupt that calls hx_board_tick instead */
        hx_board_tick();
    return (int)haptex_faults(&state);
}
