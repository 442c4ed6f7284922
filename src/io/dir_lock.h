/* dir_lock.h — one kerf run per output directory.
 *
 * A run holds an exclusive flock on <dir>/.kerf.lock for as long as it
 * writes there; the file names the holder (pid, start time). The kernel
 * drops the flock when the holder dies, however it dies, so a lock file that
 * still names a pid but is not locked was left by a run that was killed or
 * crashed: that is a stale lock, taken over and reported. A run that ends
 * normally empties the file. */
#ifndef KF_DIR_LOCK_H
#define KF_DIR_LOCK_H

#include <stddef.h>

typedef struct kf_dir_lock {
    int fd;          /* -1: not held */
    char path[4200]; /* <dir>/.kerf.lock */
} kf_dir_lock;

typedef struct kf_dir_lock_holder {
    long pid;         /* 0: none named */
    char started[64]; /* as the holder wrote it, "" if unknown */
} kf_dir_lock_holder;

/* Create dir (mkdir -p) and lock it. Returns
 *    0  locked; *stale names a run that died holding it (pid 0: none),
 *    1  another live run holds it: *other names it,
 *   -1  the lock file cannot be made (errno set). */
int kf_dir_lock_take(const char *dir, kf_dir_lock *l, kf_dir_lock_holder *other, kf_dir_lock_holder *stale);

/* Empty the lock file and drop the lock (a no-op when not held). */
void kf_dir_lock_release(kf_dir_lock *l);

/* Remove "<name>.tmp-<digits>" files, the temporaries of atomic writes, in
 * dir and its subdirectories one level down: only call it holding the lock,
 * when no other run can be writing them. Returns how many were removed; the
 * first one's path goes to first (when not NULL). */
int kf_dir_remove_temporaries(const char *dir, char *first, size_t firstlen);

#endif
