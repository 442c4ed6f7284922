/* main.c — the `kerf` command.
 *
 * Exit codes: 0 success, 1 the run failed (numerical trouble, I/O), 2 bad
 * usage or bad input. Only this directory prints progress or calls exit(). */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../core/timer.h"
#include "../io/atomic_file.h"
#include "../io/points_ply.h"
#include "../kerf.h"
#include "../scene/builtin.h"

static void usage(FILE *f) {
    fprintf(f,
            "usage: kerf <command> [options]\n"
            "\n"
            "commands:\n"
            "  run      simulate the built-in demo scene and write its frames\n"
            "  help     this text\n"
            "\n"
            "run options:\n"
            "  --frames N      frames to simulate (default: the scene's, 24)\n"
            "  --res N         grid cells across the box (default 64)\n"
            "  --out DIR       output directory (default out/demo)\n"
            "  --quiet         no progress output\n"
            "\n"
            "exit codes: 0 ok, 1 the run failed, 2 bad usage\n");
}

static int parse_int(const char *s, int lo, int hi, int *out) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || *end || end == s || v < lo || v > hi) return -1;
    *out = (int)v;
    return 0;
}

static void fmt_eta(char *buf, size_t n, double seconds) {
    int s = (int)(seconds + 0.5);
    if (s >= 3600) snprintf(buf, n, "%dh%02dm", s / 3600, s / 60 % 60);
    else snprintf(buf, n, "%dm%02ds", s / 60, s % 60);
}

static int cmd_run(int argc, char **argv) {
    int frames = 0, res = 64, quiet = 0;
    const char *out = "out/demo";
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i];
        const char *val = i + 1 < argc ? argv[i + 1] : NULL;
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) {
            usage(stdout);
            return 0;
        } else if (!strcmp(a, "--frames") && val) {
            if (parse_int(val, 1, 1000000, &frames)) return fprintf(stderr, "kerf: --frames wants a positive integer, got '%s'\n", val), 2;
            i++;
        } else if (!strcmp(a, "--res") && val) {
            if (parse_int(val, 8, 4096, &res)) return fprintf(stderr, "kerf: --res wants an integer in [8, 4096], got '%s'\n", val), 2;
            i++;
        } else if (!strcmp(a, "--out") && val) {
            out = val;
            i++;
        } else if (!strcmp(a, "--quiet")) {
            quiet = 1;
        } else {
            fprintf(stderr, "kerf: run: unknown option '%s' (see kerf help)\n", a);
            return 2;
        }
    }

    char err[512];
    kf_scene sc;
    if (kf_scene_demo(&sc, res, err, sizeof err)) {
        fprintf(stderr, "kerf: %s\n", err);
        return 1;
    }
    if (frames == 0) frames = sc.frames;
    if (kf_mkdirs(out)) {
        fprintf(stderr, "kerf: %s: cannot create directory: %s\n", out, strerror(errno));
        kf_scene_free(&sc);
        return 1;
    }
    int tty = isatty(fileno(stderr));
    if (!quiet)
        fprintf(stderr, "kerf %s: %s, %zu particles, dx %.4g m, %d frames at %g fps -> %s/\n", KERF_VERSION, sc.name,
                kf_state_count(sc.state), kf_model_sim(sc.model)->dx, frames, sc.fps, out);

    double start = kf_now_ms();
    int rc = 0;
    for (int f = 1; f <= frames; f++) {
        kf_step_stats st = {0};
        char msg[512];
        double t0 = kf_now_ms();
        if (kf_advance(sc.model, sc.state, 1.0 / sc.fps, &st, msg, sizeof msg)) {
            if (tty && !quiet) fputc('\n', stderr);
            fprintf(stderr, "kerf: frame %d: %s\n", f, msg);
            rc = 1;
            break;
        }
        double frame_ms = kf_now_ms() - t0;
        char path[4096];
        snprintf(path, sizeof path, "%s/%s.%04d.ply", out, sc.name, f);
        if (kf_write_points_ply(path, sc.state, err, sizeof err)) {
            fprintf(stderr, "kerf: %s\n", err);
            rc = 1;
            break;
        }
        if (quiet) continue;
        double elapsed = (kf_now_ms() - start) / 1e3;
        char eta[32];
        fmt_eta(eta, sizeof eta, elapsed / f * (frames - f));
        double mps = st.particle_steps / (frame_ms * 1e3);
        if (tty) {
            /* a live status line on a terminal */
            int width = 30, done = width * f / frames;
            fprintf(stderr, "\r[%.*s%*s] frame %d/%d  %ld substeps  %.1f M p-steps/s  ETA %s ", done,
                    "##############################", width - done, "", f, frames, st.substeps, mps, eta);
        } else {
            /* one plain line per frame for farm logs */
            fprintf(stderr,
                    "frame %d/%d: %zu particles, %ld blocks, %ld substeps, max cfl %.2f, %.0f ms "
                    "(sort %.0f p2g %.0f grid %.0f g2p %.0f stress %.0f), %.1f M p-steps/s, %d retries, "
                    "%ld warnings, ETA %s\n",
                    f, frames, kf_state_count(sc.state), st.active_blocks, st.substeps, st.max_cfl, frame_ms,
                    st.ms[KF_STAGE_SORT], st.ms[KF_STAGE_P2G], st.ms[KF_STAGE_GRID], st.ms[KF_STAGE_G2P],
                    st.ms[KF_STAGE_STRESS], mps, st.retries, st.warnings, eta);
        }
    }
    if (!quiet && tty) fputc('\n', stderr);
    if (rc == 0 && !quiet)
        fprintf(stderr, "kerf: wrote %d frames of particles to %s/ in %.1f s\n", frames, out, (kf_now_ms() - start) / 1e3);
    kf_scene_free(&sc);
    return rc;
}

int main(int argc, char **argv) {
    if (argc < 2) {
        usage(stderr);
        return 2;
    }
    const char *cmd = argv[1];
    if (!strcmp(cmd, "run")) return cmd_run(argc - 2, argv + 2);
    if (!strcmp(cmd, "help") || !strcmp(cmd, "--help") || !strcmp(cmd, "-h")) {
        usage(stdout);
        return 0;
    }
    if (!strcmp(cmd, "--version")) {
        printf("kerf %s\n", KERF_VERSION);
        return 0;
    }
    fprintf(stderr, "kerf: unknown command '%s' (see kerf help)\n", cmd);
    return 2;
}
