/* pil_io.h on the host: stdio. */
#include <stdio.h>

#include "pil_io.h"

#define PIL_MAX_FILES 8
static FILE *files[PIL_MAX_FILES];

int pil_open(const char *path, const char *mode)
{
    int fd;
    for (fd = 0; fd < PIL_MAX_FILES; fd++) {
        if (files[fd] == NULL) {
            files[fd] = fopen(path, mode);
            return files[fd] == NULL ? -1 : fd;
        }
    }
    return -1;
}

long pil_read(int fd, void *buf, size_t n)
{
    size_t got = fread(buf, 1, n, files[fd]);
    return ferror(files[fd]) ? -1 : (long)got;
}

int pil_write(int fd, const void *buf, size_t n)
{
    return fwrite(buf, 1, n, files[fd]) == n ? 0 : -1;
}

int pil_close(int fd)
{
    int r = fclose(files[fd]);
    files[fd] = NULL;
    return r == 0 ? 0 : -1;
}

void pil_log(const char *s)
{
    fputs(s, stdout);
    fputc('\n', stdout);
}
