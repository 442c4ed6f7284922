/* farm.c — `kerf farm`: its usage, its options, and the dispatch to submit,
 * status, cancel and the tasks that the jobs run. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "farm_internal.h"

static void usage(FILE *f) {
    fprintf(f, "usage: kerf farm submit <shot.yaml> [--wedge KEY=V1,V2,...]... [--ranks N] [--chunk K]\n"
               "                        [--partition P] [--frames A-B] [--set KEY=VALUE]... [--quality Q] [--out DIR]\n"
               "       kerf farm status [<shot.yaml> [the same options]]\n"
               "       kerf farm cancel [<shot.yaml> [the same options]]\n"
               "\n"
               "submit: the shot as Slurm jobs, one set per wedge (<shot>_w<NN>_<step>):\n"
               "  sim      one job; it resumes from the last checkpoint made from the same inputs\n"
               "  surface  array tasks of K frames (--chunk, default 1); a task is released the moment its\n"
               "           frames' checkpoints are on disk, while the sim goes on\n"
               "  render   array tasks, task i after surface task i\n"
               "  sheet    with --wedge: the contact sheet <dir>/contact_sheet.png once every wedge is rendered\n"
               "  Frames whose images are current are not submitted again. A failed surface or render task\n"
               "  is retried once; a failed or cancelled sim cancels the tasks still waiting on it.\n"
               "  Array index = frame - first frame. Logs: <dir>/farm/logs/. The sim job gets --threads N cores\n"
               "  (default 1), each task one. --ranks N > 1 runs the sim as one srun step of N MPI ranks.\n"
               "status: each job's state, frames done, ETA and failures (with the failed task's log)\n"
               "cancel: cancels the jobs that submission made, and nothing else\n"
               "Without a shot, status and cancel act on every submission made from this directory\n"
               "(listed in ./" KF_FARM_REGISTRY ").\n"
               "Slurm: the client commands on PATH, SLURM_CONF as usual. Without a reachable Slurm the\n"
               "commands say so and exit 2, submitting nothing.\n");
}

int kf_farm_parse(const char *cmd, int argc, char **argv, kf_farm_opts *f) {
    memset(f, 0, sizeof *f);
    f->ranks = 1;
    f->chunk = 1;
    f->argc = argc;
    f->argv = argv;
    /* the farm's own options come out; the rest are kerf run's */
    char **rest = calloc((size_t)argc + 1, sizeof *rest);
    if (!rest) return KF_EXIT_FAIL;
    int n = 0;
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        int is_ranks = !strcmp(a, "--ranks"), is_chunk = !strcmp(a, "--chunk"), is_part = !strcmp(a, "--partition"),
            is_rel = !strcmp(a, "--release-job");
        if (!(is_ranks || is_chunk || is_part || is_rel)) {
            rest[n++] = argv[i];
            continue;
        }
        if (i + 1 >= argc) {
            fprintf(stderr, "kerf %s: %s needs a value\n", cmd, a);
            free(rest);
            return KF_EXIT_USAGE;
        }
        const char *v = argv[++i];
        char *end;
        errno = 0;
        long x = strtol(v, &end, 10);
        int bad = errno || *end || end == v;
        if (is_part) f->partition = v;
        else if (is_rel && !bad && x > 0) f->release_job = x;
        else if (is_ranks && !bad && x >= 1 && x <= 4096) f->ranks = (int)x;
        else if (is_chunk && !bad && x >= 1 && x <= 1000) f->chunk = (int)x;
        else {
            fprintf(stderr, "kerf %s: %s wants %s, got '%s'\n", cmd, a,
                    is_ranks   ? "an integer in [1, 4096]"
                    : is_chunk ? "an integer in [1, 1000]"
                               : "a job id",
                    v);
            free(rest);
            return KF_EXIT_USAGE;
        }
    }
    int rc = kf_cli_parse(cmd, n, rest, &f->o);
    free(rest); /* the options point into argv, not into rest */
    return rc;
}

int kf_farm_dir(const kf_cli_opts *o, const kf_shot *shot, char *dir, size_t n) {
    char base[2048];
    if (kf_farm_base_dir(o, shot, base, sizeof base)) return -1;
    return snprintf(dir, n, "%s/farm", base) >= (int)n ? -1 : 0;
}

int kf_cmd_farm(int argc, char **argv) {
    const char *sub = argc > 0 ? argv[0] : NULL;
    if (!sub || !strcmp(sub, "--help") || !strcmp(sub, "-h") || !strcmp(sub, "help")) {
        usage(sub ? stdout : stderr);
        return sub ? KF_EXIT_OK : KF_EXIT_USAGE;
    }
    kf_farm_opts f;
    int is_task = !strcmp(sub, "task");
    const char *step = is_task && argc > 1 ? argv[1] : NULL;
    int skip = is_task ? 2 : 1;
    if (strcmp(sub, "submit") && strcmp(sub, "status") && strcmp(sub, "cancel") && !is_task) {
        fprintf(stderr, "kerf farm: no subcommand '%s' (submit, status, cancel; see kerf farm --help)\n", sub);
        return KF_EXIT_USAGE;
    }
    if (is_task && !step) {
        fprintf(stderr, "kerf farm task: which step? (sim, surface, render, sheet)\n");
        return KF_EXIT_USAGE;
    }
    /* status and cancel may be given no shot: every submission from here */
    int no_shot = argc == 1 && (!strcmp(sub, "status") || !strcmp(sub, "cancel"));
    if (no_shot) {
        memset(&f, 0, sizeof f);
        return kf_farm_status(&f, !strcmp(sub, "cancel"));
    }
    int rc = kf_farm_parse("farm submit", argc - skip, argv + skip, &f);
    if (rc) return rc;
    if (f.o.help) {
        usage(stdout);
        return KF_EXIT_OK;
    }
    if (!strcmp(sub, "submit")) return kf_farm_submit(&f);
    if (is_task) return kf_farm_task(step, &f);
    return kf_farm_status(&f, !strcmp(sub, "cancel"));
}
