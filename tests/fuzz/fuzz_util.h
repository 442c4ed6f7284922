/* fuzz_util.h — the loaders under fuzzing take paths, so each input is
 * written to a file in a private directory (on /dev/shm when there is one)
 * and the real loader reads it back, exactly as the command would. */
#ifndef KF_FUZZ_UTIL_H
#define KF_FUZZ_UTIL_H

#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static char kf_fuzz_dir[256];

/* a per-process directory, made once */
static const char *kf_fuzz_workdir(void) {
    if (kf_fuzz_dir[0]) return kf_fuzz_dir;
    const char *base = access("/dev/shm", W_OK) == 0 ? "/dev/shm" : "/tmp";
    snprintf(kf_fuzz_dir, sizeof kf_fuzz_dir, "%s/kerf_fuzz_%d", base, (int)getpid());
    char cmd[320];
    snprintf(cmd, sizeof cmd, "mkdir -p '%s'", kf_fuzz_dir);
    if (system(cmd) != 0) abort();
    return kf_fuzz_dir;
}

/* write data to <workdir>/<name>; the path is returned in path */
static void kf_fuzz_write(const char *name, const uint8_t *data, size_t size, char *path, size_t pathlen) {
    snprintf(path, pathlen, "%s/%s", kf_fuzz_workdir(), name);
    FILE *f = fopen(path, "wb");
    if (!f) abort();
    if (size && fwrite(data, 1, size, f) != size) abort();
    if (fclose(f)) abort();
}

#endif
