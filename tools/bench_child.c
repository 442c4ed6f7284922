/* bench_child.c — see bench_child.h. */
#include "bench_child.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

double bench_peak_mb(void) {
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss / 1024.0;
}

int bench_in_child(bench_child_fn fn, const void *ctx, void *result, size_t size, int *status) {
    memset(result, 0, size);
    *status = -1;
    int fd[2];
    if (pipe(fd)) return -1;
    /* nothing buffered twice: the child inherits the parent's stdio buffers */
    fflush(NULL);
    pid_t pid = fork();
    if (pid == 0) {
        close(fd[0]);
        void *mine = calloc(1, size);
        if (!mine) _exit(1);
        fn(ctx, mine);
        ssize_t w = write(fd[1], mine, size);
        _exit(w == (ssize_t)size ? 0 : 1);
    }
    close(fd[1]);
    ssize_t got = pid > 0 ? read(fd[0], result, size) : -1;
    close(fd[0]);
    if (pid > 0) waitpid(pid, status, 0);
    if (got != (ssize_t)size) {
        memset(result, 0, size);
        return -1;
    }
    return 0;
}
