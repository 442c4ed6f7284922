/* bench_memory.c — peak resident memory per particle: `kerf_bench --only
 * memory [--substeps N] [--threads T] [--scale S]`.
 *
 * Two scenes, each in a child process of its own so that its peak is its
 * own: the benchmark cube (100³ cells at 2³ particles per cell = 8M
 * particles, kf_scene_bench_cube) and bunny_split at Δx 0.0033 m (Table 3's
 * Δx, 2.85M particles). Each is built (seeded), then advanced through
 * kf_advance as a shot runs (the interval's start saved for retries, the
 * grid binned, CPIC's fields with bodies) for about N substeps (default 3);
 * memory per particle does not grow after the first substep that sorts.
 *
 * Printed per scene: particles, peak RSS after seeding and after the
 * substeps (MB), the peak per particle (bytes, kerf itself included, as the
 * target counts it), and `kerf info`'s estimate (kf_memory_estimate, the
 * same call) with its error against the peak. --scale multiplies Δx (and
 * divides the cube's cells) for a quick look. */
#include "bench_memory.h"
#include "bench_child.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <kerf/kerf.h>
#include "../src/mpm/model.h"
#include "../src/scene/build.h"
#include "../src/scene/builtin.h"
#include "../src/shot/shot.h"

typedef struct mem_result {
    int ok;
    char msg[160];
    double particles, seed_peak_mb, run_peak_mb, estimate_mb, program_mb;
    long substeps;
} mem_result;

/* resident bytes now (/proc/self/statm), as kerf info measures kerf itself */
static double resident_bytes(void) {
    FILE *f = fopen("/proc/self/statm", "r");
    unsigned long size = 0, resident = 0;
    int ok = f && fscanf(f, "%lu %lu", &size, &resident) == 2;
    if (f) fclose(f);
    long page = sysconf(_SC_PAGESIZE);
    return ok && page > 0 ? (double)resident * (double)page : 0;
}

/* in the child: build the scene, estimate as kerf info does, advance, measure */
static void run_scene(int which, const bench_memory_opts *o, mem_result *r) {
    const double program = resident_bytes();
    kf_scene sc;
    memset(&sc, 0, sizeof sc);
    kf_shot *shot = NULL;
    kf_diag diag;
    kf_diag_init(&diag);
    char err[256];
    if (which == 0) {
        int cells = (int)lround(100 / o->scale);
        if (kf_scene_bench_cube(&sc, cells, KF_FORCE_MLS, o->threads, err, sizeof err)) {
            snprintf(r->msg, sizeof r->msg, "%.150s", err);
            return;
        }
    } else {
        char set[64];
        snprintf(set, sizeof set, "sim.dx=%.6g", 0.0033 * o->scale);
        const char *ov[1] = {set};
        shot = kf_shot_load("shots/bunny_split.yaml", ov, 1, NULL, NULL, &diag);
        if (!shot || kf_scene_from_shot(shot, o->threads, &sc, NULL, &diag)) {
            snprintf(r->msg, sizeof r->msg, "cannot build shots/bunny_split.yaml at %s", set);
            return;
        }
    }
    r->seed_peak_mb = bench_peak_mb();
    kf_model *m = sc.model;
    kf_state *s = sc.state;
    size_t n = kf_state_count(s), bad;
    /* the grid as the first substep builds it: kerf info's figure */
    long blocks = 0;
    if (kf_grid_bin(&s->g, &s->p, kf_model_inv_dx(m), m->sim.kernel == KF_KERNEL_CUBIC, m->nthreads, &bad) == 0)
        blocks = (long)s->g.nblocks;
    r->estimate_mb = kf_memory_estimate(m, s, blocks, program) / (1 << 20);
    r->program_mb = program / (1 << 20);
    r->particles = (double)n;
    /* about N substeps: at a fixed step N of them, else N at today's CFL step */
    double dt = m->sim.dt_fixed > 0 ? m->sim.dt_fixed : kf_stable_dt(m, s, m->sim.cfl);
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    char msg[512];
    if (kf_advance(m, s, o->substeps * dt, &st, msg, sizeof msg)) snprintf(r->msg, sizeof r->msg, "%.150s", msg);
    else r->ok = 1;
    r->substeps = st.substeps;
    r->run_peak_mb = bench_peak_mb();
    kf_scene_free(&sc);
    kf_shot_free(shot);
    kf_diag_free(&diag);
}

/* in a child process of its own (bench_child.h): its peak is its own */
typedef struct mem_job {
    int which;
    const bench_memory_opts *o;
} mem_job;

static void mem_child(const void *ctx, void *result) {
    const mem_job *j = ctx;
    run_scene(j->which, j->o, result);
}

static void run_child(int which, const bench_memory_opts *o, mem_result *r) {
    const mem_job j = {which, o};
    int status;
    if (bench_in_child(mem_child, &j, r, sizeof *r, &status))
        snprintf(r->msg, sizeof r->msg, status == -1 ? "pipe failed" : "the run died (status %d)", status);
}

int bench_memory(const bench_memory_opts *o) {
    static const char *const names[2] = {"cube", "bunny_split"};
    printf("peak resident memory per particle, ~%d substeps through kf_advance, %d thread(s)%s\n", o->substeps,
           o->threads, o->scale != 1 ? " (scaled)" : "");
    printf("%-12s %9s %8s %9s %9s %8s %9s %9s %7s\n", "scene", "particles", "substeps", "seed MB", "peak MB", "B/p",
           "kerf MB", "info MB", "info");
    int fails = 0;
    for (int w = 0; w < 2; w++) {
        if (o->only && !strstr(o->only, names[w])) continue;
        mem_result r;
        run_child(w, o, &r);
        if (!r.ok) {
            printf("%-12s %s\n", names[w], r.msg);
            fails++;
            continue;
        }
        double peak = r.run_peak_mb > r.seed_peak_mb ? r.run_peak_mb : r.seed_peak_mb;
        printf("%-12s %9.0f %8ld %9.0f %9.0f %8.1f %9.0f %9.0f %+6.1f%%\n", names[w], r.particles, r.substeps,
               r.seed_peak_mb, peak, peak * 1048576.0 / r.particles, r.program_mb, r.estimate_mb,
               100.0 * (r.estimate_mb / peak - 1));
        fflush(stdout);
    }
    printf("seed MB: peak after seeding; peak MB: the whole run's; B/p: peak / particles (kerf itself included); "
           "kerf MB: resident before the scene; info: kerf info's estimate and its error against the peak.\n");
    return fails ? 1 : 0;
}
