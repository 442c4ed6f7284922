/* slurm.h — Slurm's client commands, run as child processes (no library:
 * the commands are what every Slurm install has, of any version). */
#ifndef KF_SLURM_H
#define KF_SLURM_H

#include <stddef.h>

/* Run argv (searched on PATH) and collect what it prints (stdout and stderr)
 * into out. Returns its exit status, 127 when it could not be started. */
int kf_slurm_cmd(const char *const *argv, char *out, size_t n);

/* 0 when sbatch exists and the controller answers; else -1 and why. */
int kf_slurm_check(char *why, size_t n);

/* sbatch --parsable ...: the job id, or -1 with sbatch's words in err. */
long kf_slurm_submit(const char *const *argv, char *err, size_t n);

/* let a held array task start (scontrol release <job>_<index>) */
void kf_slurm_release(long job, int index);

/* scancel the jobs (only the pending tasks of them when pending_only) */
void kf_slurm_cancel(const long *jobs, int n, int pending_only);

/* One line of squeue: a job (the array's id for an array task), its state
 * (PENDING, RUNNING, COMPLETED, FAILED, CANCELLED, ...) and how many tasks
 * the line stands for. */
typedef struct kf_slurm_task {
    long job;
    char state[64];
    int count;
} kf_slurm_task;

/* every job the controller knows; the count, or -1 when squeue fails */
int kf_slurm_queue(kf_slurm_task *t, int max);

#endif
