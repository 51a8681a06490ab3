/* Start-up of the replay on the Cortex-M4F (QEMU's mps2-an386): the vector table (the initial stack
 * pointer and the reset handler; every other exception parks in a loop), .data copied from flash,
 * .bss cleared, the FPU enabled (CPACR: full access to CP10 and CP11) before any float instruction,
 * main, and the exit status to QEMU (semihosting SYS_EXIT: ADP_Stopped_ApplicationExit for 0,
 * ADP_Stopped_RunTimeErrorUnknown otherwise). FPSCR keeps its reset value: round to nearest, no
 * flush-to-zero, no default NaN (docs/firmware.md). */
#include <stdint.h>
#include <string.h>

int main(void);
int32_t pil_semihost(uint32_t op, const void *arg);
void pil_reset(void);
void pil_trap(void);

extern uint32_t _sidata, _sdata, _edata, _sbss, _ebss, _estack;

void pil_trap(void)
{
    pil_semihost(0x18u, (const void *)(uintptr_t)0x20023u); /* ADP_Stopped_RunTimeErrorUnknown */
    for (;;) {
    }
}

void pil_reset(void)
{
    volatile uint32_t *const cpacr = (volatile uint32_t *)0xE000ED88u;
    uint32_t *src = &_sidata, *dst;
    for (dst = &_sdata; dst < &_edata;) {
        *dst++ = *src++;
    }
    for (dst = &_sbss; dst < &_ebss;) {
        *dst++ = 0u;
    }
    *cpacr |= 0xFu << 20;
    __asm__ volatile("dsb\n\tisb" ::: "memory");
    {
        /* SYS_EXIT's argument on AArch32 is the reason code itself (not a block) */
        uint32_t reason = main() == 0 ? 0x20026u : 0x20023u;
        pil_semihost(0x18u, (const void *)(uintptr_t)reason);
    }
    for (;;) {
    }
}

__attribute__((section(".isr_vector"), used)) static void (*const vectors[16])(void) = {
    (void (*)(void))(uintptr_t)&_estack, pil_reset, pil_trap, pil_trap, pil_trap, pil_trap, pil_trap, 0, 0, 0, 0,
    pil_trap, pil_trap, 0, pil_trap, pil_trap,
};
