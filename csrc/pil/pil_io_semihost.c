/* pil_io.h on the Cortex-M4F under QEMU: ARM semihosting (BKPT 0xAB; operation in r0, the address of
 * its argument block in r1, the result in r0). QEMU runs with -semihosting-config
 * enable=on,target=native: the files are the host's. */
#include <stdint.h>
#include <string.h>

#include "pil_io.h"

#define SYS_OPEN 0x01u
#define SYS_CLOSE 0x02u
#define SYS_WRITE0 0x04u
#define SYS_WRITE 0x05u
#define SYS_READ 0x06u

int32_t pil_semihost(uint32_t op, const void *arg);

int32_t pil_semihost(uint32_t op, const void *arg)
{
    register uint32_t r0 __asm__("r0") = op;
    register const void *r1 __asm__("r1") = arg;
    __asm__ volatile("bkpt 0xab" : "+r"(r0) : "r"(r1) : "memory");
    return (int32_t)r0;
}

int pil_open(const char *path, const char *mode)
{
    /* ISO C fopen modes as semihosting numbers: "rb" 1, "wb" 5 */
    uint32_t a[3];
    a[0] = (uint32_t)(uintptr_t)path;
    a[1] = mode[0] == 'w' ? 5u : 1u;
    a[2] = (uint32_t)strlen(path);
    return (int)pil_semihost(SYS_OPEN, a);
}

long pil_read(int fd, void *buf, size_t n)
{
    uint32_t a[3];
    int32_t left;
    a[0] = (uint32_t)fd;
    a[1] = (uint32_t)(uintptr_t)buf;
    a[2] = (uint32_t)n;
    left = pil_semihost(SYS_READ, a); /* the bytes NOT read */
    return left < 0 || (size_t)left > n ? -1 : (long)(n - (size_t)left);
}

int pil_write(int fd, const void *buf, size_t n)
{
    uint32_t a[3];
    a[0] = (uint32_t)fd;
    a[1] = (uint32_t)(uintptr_t)buf;
    a[2] = (uint32_t)n;
    return pil_semihost(SYS_WRITE, a) == 0 ? 0 : -1;
}

int pil_close(int fd)
{
    uint32_t a[1];
    a[0] = (uint32_t)fd;
    return pil_semihost(SYS_CLOSE, a) == 0 ? 0 : -1;
}

void pil_log(const char *s)
{
    pil_semihost(SYS_WRITE0, s);
    pil_semihost(SYS_WRITE0, "\n");
}
