/* A bare-metal start for QEMU's mps2-an386 (Cortex-M4F) and mps2-an500 (Cortex-M7): the vector
 * table, .data copied and .bss zeroed, the FPU enabled, main called, and its status returned to
 * the host by semihosting (SYS_EXIT_EXTENDED). Output by semihosting SYS_WRITE0. */
#include <stdint.h>

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;
int main(void);

static int semihost(int op, void *arg)
{
    register int r0 __asm__("r0") = op;
    register void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return r0;
}

void hx_fw_write(const char *s) { semihost(0x04, (void *)s); }

void hx_fw_exit(int status)
{
    uint32_t args[2] = {0x20026u, (uint32_t)status}; /* ADP_Stopped_ApplicationExit */
    semihost(0x20, args);
    for (;;) {
    }
}

void Reset_Handler(void)
{
    uint32_t *src = &_sidata, *dst = &_sdata;
    while (dst < &_edata)
        *dst++ = *src++;
    for (dst = &_sbss; dst < &_ebss;)
        *dst++ = 0;
    *(volatile uint32_t *)0xE000ED88u |= 0xFu << 20; /* CPACR: CP10 and CP11 full access (the FPU) */
    __asm__ volatile("dsb\n\tisb");
    hx_fw_exit(main());
}

static void Fault_Handler(void) { hx_fw_write("fault\n"); hx_fw_exit(99); }

__attribute__((section(".vectors"), used)) void (*const vectors[16])(void) = {
    (void (*)(void))(&_estack), Reset_Handler, Fault_Handler, Fault_Handler, Fault_Handler, Fault_Handler,
    Fault_Handler, 0, 0, 0, 0, Fault_Handler, Fault_Handler, 0, Fault_Handler, Fault_Handler};
