/* bench_cpic.c — what CPIC costs (the paper's §6.1 claim
 * of 6% on a large cutting scene).
 *
 * One scene three ways, the same substeps with a fixed Δt:
 *   none    a jello slab, no rigid body;
 *   far     the same with a thin blade far from the material (pays the splat only);
 *   cutting the blade moving down through the slab (the narrow band pays CPIC).
 * Prints ms per stage per substep (median of --runs, the modes interleaved),
 * process CPU ms per substep, particle-steps/s and the
 * overhead against `none`.
 *
 *   kerf_bench_cpic [--cells N] [--steps N] [--runs N] [--json] [--mode none|far|cutting] [--hash]
 * N cells across the slab's width (default 128: 4.2M particles). --mode runs
 * that mode alone (for a profiler); overheads then read against nothing.
 * --hash prints each mode's state hash after its last run's substeps.
 *
 *   kerf_bench_cpic --seeding [--runs N]
 * instead times the rigid-particle seeding (§5.2.1) of meshes of different
 * sizes: pass 1's lattice crossings by Embree rays (the product) and by the
 * rasteriser it replaced, and the whole seeding (crossings + hole pass). */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "cpic/cpic.h"
#include <kerf/kerf.h>
#include "median.h"
#include "rigid/rigid.h"
#include "rigid/seed_crossings.h"
#include "scene/mesh.h"

typedef struct result {
    double ms[KF_STAGE_COUNT]; /* per substep */
    double total_ms, mpsteps;
    double cpu_ms; /* process CPU per substep, all threads together */
    long particles, band_particles;
    uint64_t hash; /* the state after the last substep */
} result;

static double cpu_s(void);

/* mode 0 none, 1 far, 2 cutting */
static int run(int mode, int cells, int steps, int hash, result *out) {
    kf_sim_def sd = kf_default_sim_def();
    const double width = 0.5;
    sd.dx = width / cells;
    sd.walls = 1;
    sd.wall_boundary = KF_BOUNDARY_STICKY;
    for (int a = 0; a < 3; a++) sd.domain_min[a] = 0, sd.domain_max[a] = 1;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    kf_material mat;
    kf_material_preset("jello", &mat);
    int id = kf_model_add_material(m, &mat, err, sizeof err);
    /* the blade: a 0.4 x 0.6 m quad in the plane x = 0.5, bottom edge at y = 0 of its frame */
    double vert[12] = {0.5, 0, 0.2, 0.5, 0, 0.8, 0.5, 0.6, 0.8, 0.5, 0.6, 0.2};
    int tri[6] = {0, 1, 2, 0, 2, 3};
    if (mode) {
        kf_rigid_def d;
        memset(&d, 0, sizeof d);
        snprintf(d.name, sizeof d.name, "blade");
        d.vertices = vert, d.nvertices = 4, d.triangles = tri, d.ntriangles = 2;
        d.thin = 1;
        d.motion = KF_RIGID_KINEMATIC;
        d.boundary = KF_BOUNDARY_SEPARATE;
        d.nkeys = 2;
        d.keys[0].time = 0, d.keys[1].time = 1;
        if (mode == 1) d.keys[0].position[2] = d.keys[1].position[2] = 5; /* far away */
        /* from inside the slab, 1 m/s down: the bottom edge cuts from y = 0.1 */
        d.keys[0].position[1] = 0.1, d.keys[1].position[1] = 0.1 - 1.0;
        if (kf_model_add_rigid(m, &d, err, sizeof err) < 0) {
            fprintf(stderr, "rigid: %s\n", err);
            return -1;
        }
    }
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.25, 0.0, 0.25}, hi[3] = {0.75, 0.125, 0.75};
    kf_state_fill_box(s, m, lo, hi, id, NULL, 2, 0);
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    const double dt = 2e-4;
    long band = 0;
    kf_step(m, s, dt, NULL, NULL); /* the first bin builds everything */
    const double cpu0 = cpu_s();
    for (int k = 0; k < steps; k++) {
        kf_trouble tr;
        if (kf_step(m, s, dt, &st, &tr)) {
            fprintf(stderr, "substep %d: %s\n", k, tr.what);
            return -1;
        }
        if (s->cpic) band += s->cpic->band_particles;
    }
    const double cpu = cpu_s() - cpu0;
    memset(out, 0, sizeof *out);
    out->cpu_ms = 1e3 * cpu / steps;
    for (int k = 0; k < KF_STAGE_COUNT; k++) {
        out->ms[k] = st.ms[k] / steps;
        out->total_ms += out->ms[k];
    }
    out->particles = (long)kf_state_count(s);
    out->hash = hash ? kf_state_hash(s) : 0;
    out->band_particles = band / steps;
    out->mpsteps = out->particles / (out->total_ms * 1e3);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return 0;
}

/* ---- seeding ------------------------------------------------------------ */

/* a path under the repository root (found from this file's own path) */
static const char *repo_path(const char *rel) {
    static char buf[1024];
    const char *me = __FILE__, *cut = strstr(me, "tools/bench_cpic.c");
    snprintf(buf, sizeof buf, "%.*s%s", cut ? (int)(cut - me) : 0, me, rel);
    return buf;
}

static double wall_s(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static double cpu_s(void) {
    struct timespec t;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

/* what = 0: crossings by rays, 1: by rasterising, 2: the whole seeding.
 * Median wall and process-CPU ms of runs; *count the crossings or seeds. */
static int time_seeding(int what, const kf_mesh *m, const int *tri, double spacing, int runs, double *wall_ms,
                        double *cpu_ms, long *count) {
    double w[16], c[16];
    kf_seed_lattice L;
    kf_seed_lattice_for(m->lo, m->hi, 0.7 * spacing, &L);
    for (int k = 0; k < runs && k < 16; k++) {
        double w0 = wall_s(), c0 = cpu_s();
        char err[256] = "";
        if (what < 2) {
            kf_seed_crossing *x;
            *count = (what ? kf_seed_crossings_raster : kf_seed_crossings_rays)(m->vert, (int)m->nvert, tri,
                                                                                (int)m->ntri, &L, &x, err, sizeof err);
            free(x);
        } else {
            float *seed;
            int32_t *st;
            *count = (long)kf_rigid_seed_surface(m->vert, (int)m->nvert, tri, (int)m->ntri, spacing, &seed, &st);
            free(seed);
            free(st);
            if (!*count) *count = -1, snprintf(err, sizeof err, "seeding failed");
        }
        if (*count < 0) {
            fprintf(stderr, "%s: %s\n", m->path, err);
            return -1;
        }
        w[k] = 1e3 * (wall_s() - w0), c[k] = 1e3 * (cpu_s() - c0);
    }
    *wall_ms = kf_median(w, runs < 16 ? runs : 16), *cpu_ms = kf_median(c, runs < 16 ? runs : 16);
    return 0;
}

/* meshes from 4k to 75k triangles, each at two spacings (1/60 and 1/240 of
 * its size: dx/2 on a preview and on a finer shot) */
static int bench_seeding(int runs) {
    static const char *files[4] = {"assets/sphere.obj", "assets/knife_wavy.obj", "assets/armadillo.off",
                                   "assets/bunny.off"};
    printf("seeding, %d threads, median of %d runs: ms wall (ms process CPU)\n", omp_get_max_threads(), runs);
    printf("%-16s %7s %7s %9s | %20s %20s %6s | %20s %8s\n", "mesh", "tris", "1/spc", "crossings", "rays", "rasteriser",
           "ratio", "whole seeding", "seeds");
    for (int f = 0; f < 4; f++) {
        kf_mesh m;
        char err[256];
        if (kf_mesh_load(repo_path(files[f]), &m, err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            return 1;
        }
        int *tri = malloc(sizeof(int) * 3 * m.ntri);
        for (size_t i = 0; i < 3 * m.ntri; i++) tri[i] = (int)m.tri[i];
        double ext = fmax(m.hi[0] - m.lo[0], fmax(m.hi[1] - m.lo[1], m.hi[2] - m.lo[2]));
        for (int s = 0; s < 2; s++) {
            const double per = s ? 240 : 60, spacing = ext / per;
            double w[3], c[3];
            long n[3];
            for (int what = 0; what < 3; what++)
                if (time_seeding(what, &m, tri, spacing, runs, &w[what], &c[what], &n[what])) return 1;
            printf("%-16s %7zu %7.0f %9ld | %9.1f (%8.1f) %9.1f (%8.1f) %5.2fx | %9.1f (%8.1f) %8ld\n",
                   strrchr(files[f], '/') + 1, m.ntri, per, n[0], w[0], c[0], w[1], c[1], w[1] / w[0], w[2], c[2],
                   n[2]);
            if (n[0] != n[1]) printf("  (the crossing counts differ: %ld by rays, %ld by rasterising)\n", n[0], n[1]);
        }
        free(tri);
        kf_mesh_free(&m);
    }
    return 0;
}

int main(int argc, char **argv) {
    int cells = 128, steps = 20, runs = 3, json = 0, only = -1, hash = 0;
    static const char *mode_name[3] = {"none", "far", "cutting"};
    for (int i = 1; i < argc; i++)
        if (!strcmp(argv[i], "--seeding")) {
            for (int k = 1; k < argc; k++)
                if (!strcmp(argv[k], "--runs") && k + 1 < argc) runs = atoi(argv[k + 1]);
            return bench_seeding(runs < 1 ? 1 : runs);
        }
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--cells") && i + 1 < argc) cells = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--steps") && i + 1 < argc) steps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc) runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--json")) json = 1;
        else if (!strcmp(argv[i], "--hash")) hash = 1;
        else if (!strcmp(argv[i], "--mode") && i + 1 < argc) {
            ++i;
            for (int k = 0; k < 3; k++)
                if (!strcmp(argv[i], mode_name[k])) only = k;
            if (only < 0) {
                fprintf(stderr, "--mode: none, far or cutting\n");
                return 2;
            }
        } else {
            fprintf(
                stderr,
                "usage: %s [--cells N] [--steps N] [--runs N] [--json] [--mode M] [--hash] | --seeding [--runs N]\n",
                argv[0]);
            return 2;
        }
    }
    /* the modes' runs interleaved (none, far, cutting, none, ...) so that a
     * shared machine's changing load falls on all three alike */
    result med[3], rr[3][16];
    if (runs > 16) runs = 16;
    for (int k = 0; k < runs; k++)
        for (int mode = 0; mode < 3; mode++)
            if (only >= 0 && mode != only) memset(&rr[mode][k], 0, sizeof rr[mode][k]);
            else if (run(mode, cells, steps, hash, &rr[mode][k])) return 1;
    for (int mode = 0; mode < 3; mode++) {
        double ms[KF_STAGE_COUNT][16], tot[16], cpu[16];
        for (int k = 0; k < runs; k++) {
            for (int e = 0; e < KF_STAGE_COUNT; e++) ms[e][k] = rr[mode][k].ms[e];
            tot[k] = rr[mode][k].total_ms, cpu[k] = rr[mode][k].cpu_ms;
        }
        med[mode] = rr[mode][runs - 1];
        for (int e = 0; e < KF_STAGE_COUNT; e++) med[mode].ms[e] = kf_median(ms[e], runs);
        med[mode].total_ms = kf_median(tot, runs);
        med[mode].cpu_ms = kf_median(cpu, runs);
        med[mode].mpsteps = med[mode].particles / (med[mode].total_ms * 1e3);
    }
    if (json) printf("{\"cells\":%d,\"steps\":%d,\"runs\":%d", cells, steps, runs);
    else
        printf("CPIC overhead: %ld particles, %d substeps, median of %d runs (ms per substep)\n", med[0].particles,
               steps, runs);
    for (int mode = 0; mode < 3; mode++) {
        const result *r = &med[mode];
        double over = 100 * (r->total_ms / med[0].total_ms - 1);
        double cpu_over = 100 * (r->cpu_ms / med[0].cpu_ms - 1);
        if (json) {
            printf(",\"%s\":{\"total_ms\":%.3f,\"mpsteps\":%.3f,\"overhead_pct\":%.2f,\"cpu_ms\":%.3f,"
                   "\"cpu_overhead_pct\":%.2f,\"band_particles\":%ld",
                   mode_name[mode], r->total_ms, r->mpsteps, over, r->cpu_ms, cpu_over, r->band_particles);
            for (int e = 0; e < KF_STAGE_COUNT; e++) printf(",\"%s\":%.3f", kf_stage_name((kf_stage)e), r->ms[e]);
            printf("}");
        } else {
            printf("%-8s total %8.2f  %6.2f M p-steps/s  overhead %+6.1f%%  cpu %8.2f (%+6.1f%%)  band %ld particles |",
                   mode_name[mode], r->total_ms, r->mpsteps, over, r->cpu_ms, cpu_over, r->band_particles);
            for (int e = 0; e < KF_STAGE_COUNT; e++) printf(" %s %.2f", kf_stage_name((kf_stage)e), r->ms[e]);
            if (hash) printf(" | hash %016llx", (unsigned long long)r->hash);
            printf("\n");
        }
    }
    if (json) printf("}\n");
    return 0;
}
