/* cli.h — the `kerf` command's shared pieces: options, loading a shot into
 * a scene, and the commands. Only cli/ prints progress or decides exit codes:
 * 0 success, 1 the run failed (numerical trouble, I/O), 2 bad usage or input. */
#ifndef KF_CLI_H
#define KF_CLI_H

#include "../io/dir_lock.h"
#include "../scene/build.h"
#include "../shot/shot.h"

#define KF_EXIT_OK 0
#define KF_EXIT_FAIL 1
#define KF_EXIT_USAGE 2

typedef struct kf_cli_opts {
    const char *shot;      /* the shot file */
    const char *sets[128]; /* --set a.b=v, in order */
    int nsets;
    const char *quality;    /* --quality preview|final */
    const char *frames;     /* --frames A-B */
    const char *out;        /* --out DIR: replaces output.dir */
    int resume;             /* --resume */
    int force;              /* --force: simulate even when the cache is current */
    int threads;            /* --threads N (0: the shot's) */
    int quiet;              /* --quiet */
    int help;               /* --help */
    const char *wedges[16]; /* --wedge KEY=V1,V2,... (kerf run, kerf farm submit), in order */
    int nwedges;
    /* set by the farm's sim task, never by options: simulate only (the farm's
     * array tasks surface and render), and hear of each frame of [first, last]
     * whose checkpoint is durably on disk, cached frames included */
    int sim_only;
    void (*frame_ready)(void *ctx, int frame);
    void *frame_ctx;
    /* set by `kerf run` over several MPI ranks: seed only this rank's part */
    int rank_part;
} kf_cli_opts;

/* Parse argv (after the command word). Returns 0, or 2 with a message. */
int kf_cli_parse(const char *cmd, int argc, char **argv, kf_cli_opts *o);

/* Load and validate the shot, then seed the scene: every problem is printed
 * as file:line:col with the line echoed. Returns 0, or 2 (nothing touched). */
int kf_cli_load(const kf_cli_opts *o, kf_shot **shot, kf_scene *sc, kf_build_stats *stats);

/* What every command does first: parse, answer --help, load the shot and
 * seed its scene. *shot is NULL when the command is already done (help
 * printed, or an error reported): return the value then. */
int kf_cli_start(const char *cmd, int argc, char **argv, kf_cli_opts *o, kf_shot **shot, kf_scene *sc,
                 kf_build_stats *stats);

/* Lock the shot's output directory (the first frame's) for this run and
 * remove the temporaries a killed run left there. Returns 0, or 1 with a
 * message (another live run holds it: its pid is named). Release with
 * kf_dir_lock_release; a kill releases it too, and the next run says so. */
int kf_cli_claim_output(const kf_cli_opts *o, const kf_shot *shot, kf_dir_lock *lock);

int kf_cmd_run(int argc, char **argv);
/* `kerf run` after its options are parsed: load, claim the output, simulate,
 * surface and render (cmd_run.c) */
int kf_cli_run(const kf_cli_opts *o);
/* A version directory holds one experiment: when a checkpoint of the shot's
 * range in it was made from other inputs AND the directory was simulated
 * with other command-line values (--set, --quality; <dir>/.kerf-values),
 * say so (naming the next free version) and return 1: the run would replace
 * another experiment. The same values with other inputs (the shot file, a
 * mesh or kerf changed) return 0: the cache simulates again, as always.
 * --force returns 0 (the run replaces them). */
int kf_cli_version_taken(const kf_cli_opts *o, const kf_shot *shot);
/* 1 when frame f's image is current: its checkpoint from these inputs, its
 * surface and image newer than what they were made from, under the same
 * surface and render settings (cmd_stages.c) */
int kf_cli_frame_current(const kf_cli_opts *o, const kf_shot *shot, int f);
int kf_cmd_surface(int argc, char **argv);
int kf_cmd_render(int argc, char **argv);
int kf_cmd_turntable(int argc, char **argv);
/* surface and/or render the shot's frames after simulation, skipping
 * outputs newer than their inputs (cmd_stages.c) */
int kf_cli_post(const kf_cli_opts *o, const kf_shot *shot, kf_scene *sc, int do_surface, int do_render);
int kf_cmd_check(int argc, char **argv);
int kf_cmd_info(int argc, char **argv);
int kf_cmd_view(int argc, char **argv); /* cmd_view.c: the web page of src/view */
void kf_cli_usage(FILE *f, const char *cmd);

#endif
