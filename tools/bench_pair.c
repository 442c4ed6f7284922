/* bench_pair.c — issue 22's "MLS against classic, same build" figure,
 * measured so that the host's drift cancels.
 *
 * Two cubes (the same as bench.c's: E = 100, Δt = 1e-2, static) live side
 * by side, one with MLS forces and one with classic MPM's. Each round steps
 * both once, the order swapped every round, and the ratio is taken within
 * the round: a slow minute slows both lanes of the round alike, where
 * separate processes (bench.c's cube rows) meet different minutes of a
 * shared machine and scatter the ratio by tens of percent. */
#include <stdio.h>

#include <kerf/kerf.h>
#include "../src/core/timer.h"
#include "../src/scene/builtin.h"
#include "bench_pair.h"
#include "median.h"

#define PAIR_MAX_ROUNDS 256

/* one step of a cube, its wall and process CPU milliseconds */
static void timed_step(kf_scene *sc, double *wall_ms, double *cpu_ms) {
    double t0 = kf_now_ms(), c0 = kf_process_cpu_ms();
    kf_step(sc->model, sc->state, 1e-2, NULL, NULL);
    *wall_ms = kf_now_ms() - t0;
    *cpu_ms = kf_process_cpu_ms() - c0;
}

/* median, least and largest of n values (v is sorted in place) */
static void spread(double *v, int n, double out[3]) {
    out[0] = kf_median(v, n);
    out[1] = v[0];
    out[2] = v[n - 1];
}

int bench_pair(int cells, int threads, int rounds) {
    if (rounds < 2) rounds = 2;
    if (rounds > PAIR_MAX_ROUNDS) rounds = PAIR_MAX_ROUNDS;
    char err[256];
    kf_scene sc[2];
    for (int f = 0; f < 2; f++) {
        if (kf_scene_bench_cube(&sc[f], cells, f ? KF_FORCE_CLASSIC : KF_FORCE_MLS, threads, err, sizeof err)) {
            fprintf(stderr, "bench: %s\n", err);
            if (f) kf_scene_free(&sc[0]);
            return 1;
        }
        /* as bench.c's cube: every substep 1e-2 s, so each may end with the
         * next one's P2G; the first step bins and allocates */
        kf_state_fuse_next(sc[f].state, 1e-2);
        kf_step(sc[f].model, sc[f].state, 1e-2, NULL, NULL);
    }
    const size_t n = kf_state_count(sc[0].state);
    static double wall[2][PAIR_MAX_ROUNDS], cpu[2][PAIR_MAX_ROUNDS], ratio_wall[PAIR_MAX_ROUNDS],
        ratio_cpu[PAIR_MAX_ROUNDS];
    int classic_won = 0;
    for (int r = 0; r < rounds; r++) {
        for (int k = 0; k < 2; k++) {
            const int f = (r + k) % 2; /* MLS first in even rounds, classic first in odd ones */
            timed_step(&sc[f], &wall[f][r], &cpu[f][r]);
        }
        ratio_wall[r] = wall[1][r] / wall[0][r];
        ratio_cpu[r] = cpu[1][r] / cpu[0][r];
        classic_won += wall[1][r] < wall[0][r];
    }
    double s[4][3];
    spread(wall[0], rounds, s[0]);
    spread(wall[1], rounds, s[1]);
    spread(ratio_wall, rounds, s[2]);
    spread(ratio_cpu, rounds, s[3]);
    printf("cube %d cells, %zu particles, %d threads, %d rounds (MLS and classic steps alternating, order swapped "
           "each round)\n",
           cells, n, threads, rounds);
    printf("  MLS step      %9.1f ms wall median (%.1f-%.1f), %.2f M particle-steps/s\n", s[0][0], s[0][1], s[0][2],
           (double)n / (s[0][0] * 1e3));
    printf("  classic step  %9.1f ms wall median (%.1f-%.1f), %.2f M particle-steps/s\n", s[1][0], s[1][1], s[1][2],
           (double)n / (s[1][0] * 1e3));
    printf("  classic / MLS %9.3fx by wall (rounds' ratios %.3f-%.3f), %.3fx by process CPU (%.3f-%.3f); classic "
           "faster in %d of %d rounds\n",
           s[2][0], s[2][1], s[2][2], s[3][0], s[3][1], s[3][2], classic_won, rounds);
    kf_scene_free(&sc[0]);
    kf_scene_free(&sc[1]);
    return 0;
}
