/* The replay's file I/O: stdio on the host (pil_io_host.c), ARM semihosting under QEMU
 * (pil_io_semihost.c; QEMU opens the files on the host, relative to its working directory). */
#ifndef LINSENSE_PIL_IO_H
#define LINSENSE_PIL_IO_H

#include <stddef.h>

/* a file handle (>= 0) or -1; mode "rb" or "wb" */
int pil_open(const char *path, const char *mode);
/* bytes read (0 at the end), or -1 */
long pil_read(int fd, void *buf, size_t n);
/* 0, or -1 when not everything was written */
int pil_write(int fd, const void *buf, size_t n);
int pil_close(int fd);
/* a line on the console */
void pil_log(const char *s);

#endif /* LINSENSE_PIL_IO_H */
