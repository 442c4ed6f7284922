/* atomic_file.h — durable output: write to a temporary name, fsync, rename.
 *
 * A crash or a kill never leaves a half-written frame under the final name:
 * readers see either the previous file or the complete new one. */
#ifndef KF_ATOMIC_FILE_H
#define KF_ATOMIC_FILE_H

#include <stdio.h>

typedef struct kf_atomic_file {
    FILE *f;
    char path[4096];
    char tmp[4200];
} kf_atomic_file;

/* Open path.tmp-<pid> for writing. Returns 0 or -1 (errno set). */
int kf_atomic_open(kf_atomic_file *a, const char *path);
/* Flush, fsync, rename over path. Returns 0, or -1 and removes the temporary. */
int kf_atomic_commit(kf_atomic_file *a);
/* Abandon: close and remove the temporary. */
void kf_atomic_abort(kf_atomic_file *a);

/* An errno as a message: a full disk (ENOSPC, EDQUOT) reads "no space left on
 * the device (disk full)", anything else strerror's words. */
const char *kf_io_reason(int e);

/* mkdir -p. Returns 0 or -1. */
int kf_mkdirs(const char *dir);

#endif
