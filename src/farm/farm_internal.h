/* farm_internal.h — what the farm's files share: its options, the record a
 * submission leaves in <dir>/farm/, and the commands. */
#ifndef KF_FARM_INTERNAL_H
#define KF_FARM_INTERNAL_H

#include "farm.h"

/* the options of `kerf farm ...`: kerf run's, plus the farm's own */
typedef struct kf_farm_opts {
    kf_cli_opts o;
    int ranks;             /* --ranks N: MPI ranks of the sim job */
    int chunk;             /* --chunk K: frames per surface/render task */
    const char *partition; /* --partition P */
    long release_job;      /* tasks: --release-job J, the surface array the sim releases */
    int argc;              /* the arguments after the subcommand, as given */
    char **argv;
} kf_farm_opts;

int kf_farm_parse(const char *cmd, int argc, char **argv, kf_farm_opts *f);

/* <dir>/farm of these options (base shot loaded by the caller) */
int kf_farm_dir(const kf_cli_opts *o, const kf_shot *shot, char *dir, size_t n);

/* the file that lists this directory's submissions, one farm dir a line */
#define KF_FARM_REGISTRY ".kerf-farm"

int kf_farm_submit(kf_farm_opts *f);
int kf_farm_status(kf_farm_opts *f, int cancel);
int kf_farm_task(const char *step, kf_farm_opts *f);

/* frames of [shot->first, shot->last] whose checkpoint is from the shot's
 * inputs / whose surface is current / whose image is current */
void kf_farm_frames_done(const kf_cli_opts *o, const kf_shot *shot, int *sim, int *surf, int *img);

#endif
