/* dir_lock.c — one kerf run per output directory (see dir_lock.h). */
#include "dir_lock.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "atomic_file.h"

/* "pid started" as a holder writes it; an empty file names nobody */
static void read_holder(int fd, kf_dir_lock_holder *h) {
    char buf[128] = "";
    memset(h, 0, sizeof *h);
    ssize_t n = pread(fd, buf, sizeof buf - 1, 0);
    if (n <= 0) return;
    buf[n] = 0;
    char *end;
    h->pid = strtol(buf, &end, 10);
    if (end == buf || h->pid <= 0) {
        h->pid = 0;
        return;
    }
    while (*end == ' ') end++;
    snprintf(h->started, sizeof h->started, "%.*s", (int)strcspn(end, "\n"), end);
}

static int write_holder(int fd) {
    char buf[128], when[64];
    time_t now = time(NULL);
    struct tm tm;
    strftime(when, sizeof when, "%Y-%m-%d %H:%M:%S", localtime_r(&now, &tm));
    int n = snprintf(buf, sizeof buf, "%ld %s\n", (long)getpid(), when);
    if (ftruncate(fd, 0) != 0 || pwrite(fd, buf, (size_t)n, 0) != n) return -1;
    return fsync(fd);
}

int kf_dir_lock_take(const char *dir, kf_dir_lock *l, kf_dir_lock_holder *other, kf_dir_lock_holder *stale) {
    l->fd = -1;
    memset(other, 0, sizeof *other);
    memset(stale, 0, sizeof *stale);
    if (snprintf(l->path, sizeof l->path, "%s/.kerf.lock", dir) >= (int)sizeof l->path) {
        errno = ENAMETOOLONG;
        return -1;
    }
    if (kf_mkdirs(dir)) return -1;
    int fd = open(l->path, O_RDWR | O_CREAT | O_CLOEXEC, 0644);
    if (fd < 0) return -1;
    /* the file is never removed, so every run locks the same inode */
    if (flock(fd, LOCK_EX | LOCK_NB) != 0) {
        int e = errno;
        if (e == EWOULDBLOCK) read_holder(fd, other);
        close(fd);
        errno = e;
        return e == EWOULDBLOCK ? 1 : -1;
    }
    /* locked: a pid still written there belongs to a run that never released it */
    read_holder(fd, stale);
    if (write_holder(fd)) {
        int e = errno;
        close(fd);
        errno = e;
        return -1;
    }
    l->fd = fd;
    return 0;
}

void kf_dir_lock_release(kf_dir_lock *l) {
    if (l->fd < 0) return;
    if (ftruncate(l->fd, 0) == 0) fsync(l->fd);
    close(l->fd); /* drops the flock */
    l->fd = -1;
}

/* "x.kfc.tmp-1234": what kf_atomic_open, the PNG writer and the VDB bridge leave when killed */
static int is_temporary(const char *name) {
    const char *t = strstr(name, ".tmp-");
    if (!t || t == name) return 0;
    t += 5;
    if (!*t) return 0;
    for (; *t; t++)
        if (*t < '0' || *t > '9') return 0;
    return 1;
}

static int sweep(const char *dir, int depth, int *count, char *first, size_t firstlen) {
    DIR *d = opendir(dir);
    if (!d) return 0;
    struct dirent *e;
    char path[4600];
    while ((e = readdir(d)) != NULL) {
        if (!strcmp(e->d_name, ".") || !strcmp(e->d_name, "..")) continue;
        if (snprintf(path, sizeof path, "%s/%s", dir, e->d_name) >= (int)sizeof path) continue;
        struct stat st;
        if (lstat(path, &st) != 0) continue;
        if (S_ISDIR(st.st_mode) && depth > 0) sweep(path, depth - 1, count, first, firstlen);
        else if (S_ISREG(st.st_mode) && is_temporary(e->d_name) && unlink(path) == 0) {
            if (*count == 0 && first) snprintf(first, firstlen, "%s", path);
            (*count)++;
        }
    }
    closedir(d);
    return 0;
}

int kf_dir_remove_temporaries(const char *dir, char *first, size_t firstlen) {
    int count = 0;
    if (first && firstlen) first[0] = 0;
    sweep(dir, 1, &count, first, firstlen);
    return count;
}
