/* outdir.c — claim a shot's output directory before writing into it: one run
 * per directory (io/dir_lock.h), and the temporaries a killed run left
 * behind swept away, since under the lock no other run can be writing them. */
#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "../io/atomic_file.h"
#include "cli.h"
#include "../pipeline/stages.h"

int kf_cli_claim_output(const kf_cli_opts *o, const kf_shot *shot, kf_dir_lock *lock) {
    kf_frame_paths fp;
    lock->fd = -1;
    if (kf_frame_paths_make(shot, o->out, shot->first, &fp)) {
        fprintf(stderr, "kerf: %s: the output directory's path is too long\n", shot->name);
        return KF_EXIT_FAIL;
    }
    kf_dir_lock_holder other, stale;
    int rc = kf_dir_lock_take(fp.dir, lock, &other, &stale);
    if (rc == 1) {
        fprintf(stderr,
                "kerf: %s/ is in use by another kerf run (pid %ld, started %s); wait for it to end or stop it "
                "(kill %ld)\n",
                fp.dir, other.pid, other.started[0] ? other.started : "at an unknown time", other.pid);
        return KF_EXIT_FAIL;
    }
    if (rc < 0) {
        fprintf(stderr, "kerf: %s/: cannot lock the output directory: %s\n", fp.dir, kf_io_reason(errno));
        return KF_EXIT_FAIL;
    }
    if (stale.pid)
        fprintf(stderr,
                "kerf: %s/: the run before (pid %ld, started %s) ended without releasing its lock (killed or "
                "crashed); taking the lock over\n",
                fp.dir, stale.pid, stale.started[0] ? stale.started : "at an unknown time");
    char first[4200];
    int swept = kf_dir_remove_temporaries(fp.dir, first, sizeof first);
    if (swept)
        fprintf(stderr, "kerf: %s/: removed %d temporary file%s left by an interrupted write (%s%s)\n", fp.dir, swept,
                swept == 1 ? "" : "s", first, swept > 1 ? ", ..." : "");
    return KF_EXIT_OK;
}
