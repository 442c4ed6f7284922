/* main.c — the `kerf` command: dispatch and help.
 *
 * Exit codes: 0 success, 1 the run failed (numerical trouble, I/O), 2 bad
 * usage or bad input (nothing simulated, no output touched). */
#include <stdio.h>
#include <string.h>

#include "../dist/dist.h"
#include "../scene/budget.h"
#include "../farm/farm.h"
#include "cli.h"

void kf_cli_usage(FILE *f, const char *cmd) {
    if (!cmd || !strcmp(cmd, "kerf")) {
        fprintf(f, "usage: kerf <command> [options]\n"
                   "\n"
                   "commands:\n"
                   "  run <shot.yaml>     simulate, surface (OpenVDB) and render (PNG) the shot's frames\n"
                   "  surface <shot.yaml> level sets from the checkpoints: <dir>/surface/<name>.vdb\n"
                   "  render <shot.yaml>  PNG images from the .vdb surfaces: <dir>/images/<name>.png\n"
                   "  turntable <shot.yaml> --frame N --frames K\n"
                   "                      K views orbiting frame N (end exclusive: the sequence loops)\n"
                   "  farm submit|status|cancel <shot.yaml>\n"
                   "                      the shot (and its wedges) as Slurm jobs: kerf farm --help\n"
                   "  check <shot.yaml>   validate the shot (all problems at once) and seed it; simulate nothing\n"
                   "  info <shot.yaml>    what the shot compiles to: particles, grid, materials, memory, substeps\n"
                   "  view <shot.yaml | dir> [--port N]\n"
                   "                      a local web page: play the frames, compare versions, plot the frame\n"
                   "                      records, edit keys and re-run at preview quality\n"
                   "  help [shot|run|check|info|view]\n"
                   "                      this text; `kerf help shot` lists every shot-file key\n"
                   "\n"
                   "exit codes: 0 ok, 1 the run failed (numerical trouble, I/O), 2 bad usage or bad shot\n");
        return;
    }
    fprintf(f, "usage: kerf %s <shot.yaml>%s [options]\n\noptions:\n", cmd,
            !strcmp(cmd, "turntable") ? " --frame N --frames K" : "");
    fprintf(f, "  --set KEY=VALUE     override a shot value, checked like the file (repeatable):\n"
               "                      --set materials.jelly.E=2e3 --set objects.cube.velocity=[0,-2,0]\n"
               "  --quality Q         final (as written) or preview (dx doubled, images at half size,\n"
               "                      render.quality preview: no anti-aliasing, a smaller shadow map)\n"
               "  --frames A-B        only these frames of the shot's range (or one frame: --frames 1010)\n"
               "  --threads N         worker threads (default: all cores)\n");
    if (strcmp(cmd, "check") && strcmp(cmd, "info"))
        fprintf(f, "  --out DIR           output directory template instead of output.dir (relative to the\n"
                   "                      current directory)\n"
                   "  --force             redo outputs even when they are current; go past the budget guard\n");
    else fprintf(f, "  --force             go past the budget guard\n");
    fprintf(f,
            "                      (a shot whose estimate, made before seeding, needs more memory than\n"
            "                      this machine has or more than %.0f substeps a frame is refused)\n",
            KF_BUDGET_SUBSTEPS_PER_FRAME);
    if (!strcmp(cmd, "run"))
        fprintf(f, "  --wedge KEY=V1,V2   run the shot once per value, each into <dir>/w01, w02, ... and end\n"
                   "                      with <dir>/contact_sheet.png (repeatable: every combination)\n");
    if (!strcmp(cmd, "run"))
        fprintf(f, "  --resume            continue after the last good checkpoint of an interrupted run\n"
                   "  --quiet             no progress output\n"
                   "\nA terminal gets a live progress bar with ETA; a log gets one line per frame with\n"
                   "particles, grid blocks, substeps, max CFL, ms per stage and warnings.\n"
                   "Outputs per frame under <dir>: particles/<name>.ply, checkpoints/<name>.kfc,\n"
                   "surface/<name>.vdb (level set `surface`, or `surface_<group>` per material/object),\n"
                   "images/<name>.png. When every requested frame is cached from the same inputs (shot\n"
                   "values that affect the simulation, mesh file contents, the kerf build), nothing is\n"
                   "simulated; surfaces and images newer than their inputs are kept.\n"
                   "\n`mpirun -np N kerf run <shot.yaml>` runs one simulation over N MPI ranks: each holds the\n"
                   "particles of its slab of grid blocks, rank 0 writes the same files a one-rank run writes\n"
                   "(bit for bit), and checkpoints resume on any rank count. Not over several ranks yet: rigid\n"
                   "bodies, the implicit integrator, contact between objects (sim.contact: off runs).\n");
    fprintf(f, "  --help              this text\n");
}

static int dispatch(int argc, char **argv);

/* Under a launcher (mpirun -np N, or srun in a farm's sim job) the ranks run
 * one simulation together; only `kerf run` and the farm's sim task (a run
 * that also releases the frames' held jobs, from rank 0) know how. Without
 * one, or with one rank, nothing changes. */
static int runs_over_ranks(int argc, char **argv) {
    if (argc >= 2 && !strcmp(argv[1], "run")) return 1;
    return argc >= 4 && !strcmp(argv[1], "farm") && !strcmp(argv[2], "task") && !strcmp(argv[3], "sim");
}

int main(int argc, char **argv) {
    int ranks = kf_dist_init(&argc, &argv), rc;
    if (ranks > 1 && !runs_over_ranks(argc, argv)) {
        if (kf_dist_rank() == 0)
            fprintf(stderr,
                    "kerf: only `kerf run` runs over several MPI ranks (%d here); run `kerf %s` without mpirun\n",
                    ranks, argc > 1 ? argv[1] : "");
        rc = KF_EXIT_USAGE;
    } else rc = dispatch(argc, argv);
    kf_dist_finalize();
    return rc;
}

static int dispatch(int argc, char **argv) {
    if (argc < 2) {
        kf_cli_usage(stderr, NULL);
        return KF_EXIT_USAGE;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "run")) return kf_cmd_run(argc - 2, argv + 2);
    if (!strcmp(cmd, "check")) return kf_cmd_check(argc - 2, argv + 2);
    if (!strcmp(cmd, "info")) return kf_cmd_info(argc - 2, argv + 2);
    if (!strcmp(cmd, "surface")) return kf_cmd_surface(argc - 2, argv + 2);
    if (!strcmp(cmd, "render")) return kf_cmd_render(argc - 2, argv + 2);
    if (!strcmp(cmd, "turntable")) return kf_cmd_turntable(argc - 2, argv + 2);
    if (!strcmp(cmd, "view")) return kf_cmd_view(argc - 2, argv + 2);
    if (!strcmp(cmd, "farm")) return kf_cmd_farm(argc - 2, argv + 2);
    if (!strcmp(cmd, "help") || !strcmp(cmd, "--help") || !strcmp(cmd, "-h")) {
        const char *topic = argc > 2 ? argv[2] : NULL;
        if (topic && !strcmp(topic, "shot")) kf_shot_help(stdout);
        else if (topic && !strcmp(topic, "view")) return kf_cmd_view(1, (char *[]){"--help", NULL});
        else if (topic && (!strcmp(topic, "run") || !strcmp(topic, "check") || !strcmp(topic, "info") ||
                           !strcmp(topic, "surface") || !strcmp(topic, "render") || !strcmp(topic, "turntable")))
            kf_cli_usage(stdout, topic);
        else if (topic) {
            fprintf(stderr, "kerf help: no topic '%s' (shot, run, check, info, surface, render, turntable, view)\n",
                    topic);
            return KF_EXIT_USAGE;
        } else kf_cli_usage(stdout, NULL);
        return KF_EXIT_OK;
    }
    if (!strcmp(cmd, "--version")) {
        printf("kerf %s\n", KERF_VERSION);
        return KF_EXIT_OK;
    }
    fprintf(stderr, "kerf: unknown command '%s' (see kerf help)\n", cmd);
    return KF_EXIT_USAGE;
}
