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
 *   kerf_bench_cpic --rounds N [--cells N] [--batch B] [--hash]
 * keeps the three modes' slabs side by side in one process and runs N
 * rounds of B substeps of each (default 2), their order rotated each round;
 * prints every round's CPU and wall ms and its ratios against `none`, then
 * their median and range (the figure on a host whose speed drifts).
 *
 *   kerf_bench_cpic --rounds N --shot FILE [--set k=v]... [--span F] [--threads T] [--hash]
 * the same for a shot: the shot as it is ("bodies") against the shot with
 * `rigids=[]` ("none"), each round F frames of simulated time (default
 * 1/16) from the shot's start, no warm-up; --threads 0: the shot's.
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

#include "core/timer.h"
#include "cpic/cpic.h"
#include <kerf/kerf.h>
#include "median.h"
#include "rigid/rigid.h"
#include "rigid/seed_crossings.h"
#include "scene/build.h"
#include "shot/diag.h"
#include "shot/shot.h"
#include "scene/mesh.h"

typedef struct result {
    double ms[KF_STAGE_COUNT]; /* per substep */
    double total_ms, mpsteps;
    double cpu_ms; /* process CPU per substep, all threads together */
    long particles, band_particles;
    uint64_t hash; /* the state after the last substep */
} result;

static double cpu_s(void);
static double wall_s(void);

/* mode 0 none, 1 far, 2 cutting: the slab's model and state, before any substep */
static int slab_make(int mode, int cells, kf_model **mo, kf_state **so) {
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
            kf_model_destroy(m);
            return -1;
        }
    }
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.25, 0.0, 0.25}, hi[3] = {0.75, 0.125, 0.75};
    kf_state_fill_box(s, m, lo, hi, id, NULL, 2, 0);
    *mo = m, *so = s;
    return 0;
}

/* the slab's fixed substep */
#define SLAB_DT 2e-4

/* steps substeps of the slab; *band: its narrow band's particles summed over them */
static int slab_steps(const kf_model *m, kf_state *s, int steps, kf_step_stats *st, long *band) {
    for (int k = 0; k < steps; k++) {
        kf_trouble tr;
        if (kf_step(m, s, SLAB_DT, st, &tr)) {
            fprintf(stderr, "substep %d: %s\n", k, tr.what);
            return -1;
        }
        if (s->cpic && band) *band += s->cpic->band_particles;
    }
    return 0;
}

/* one run of a mode: a fresh slab, one untimed substep, then the timed ones */
static int run(int mode, int cells, int steps, int hash, result *out) {
    kf_model *m;
    kf_state *s;
    if (slab_make(mode, cells, &m, &s)) return -1;
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    long band = 0;
    kf_step(m, s, SLAB_DT, NULL, NULL); /* the first bin builds everything */
    const double cpu0 = cpu_s();
    if (slab_steps(m, s, steps, &st, &band)) return -1;
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

static double wall_s(void) { return kf_now_ms() * 1e-3; }
static double cpu_s(void) { return kf_process_cpu_ms() * 1e-3; }

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

/* ---- rounds: the modes side by side in one process ------------------------
 * On a shared host the speed drifts by 20-30% over minutes, more than the
 * overhead to be measured, and one mode's run after another's lands on a
 * different part of that drift. --rounds makes every mode's simulation once
 * and keeps it; each round runs one batch of each mode (their order rotated
 * round by round), so a round's batches are a second or so apart and see the
 * same host. Each round gives its own ratio against `none` (process CPU,
 * the calling thread's CPU and wall time), and the median and range of the
 * rounds' ratios are the figure. The modes advance in step: round k of every
 * mode covers the same substeps (the slab) or the same span of simulated
 * time (a shot, --shot: the shot as it is against the shot with
 * `rigids=[]`, so the knife in the cheese against the cheese alone). */

#define ROUNDS_MAX 400

typedef struct lane {
    const char *name;
    kf_model *m; /* the slab's model and state; NULL for a shot's */
    kf_state *s;
    kf_scene sc; /* a shot's */
    kf_shot *shot;
    kf_step_stats st; /* summed over the timed batches */
    long band;        /* the slab's band particles, summed over the timed substeps */
    double cpu[ROUNDS_MAX], thr[ROUNDS_MAX], wall[ROUNDS_MAX];
    long sub[ROUNDS_MAX]; /* substeps in each round's batch */
} lane;

typedef struct rounds_opts {
    int cells, batch, rounds, hash, threads;
    const char *shot; /* NULL: the slab */
    const char *set[8];
    int nset;
    double span_frames; /* a shot's batch, frames */
} rounds_opts;

static double thread_cpu_s(void) { return kf_thread_cpu_ms() * 1e-3; }

/* a shot's scene, with its rigid bodies or without (rigids=[]) */
static int lane_shot(lane *L, const rounds_opts *o, int bodies) {
    const char *ov[10];
    int n = 0;
    for (int k = 0; k < o->nset; k++) ov[n++] = o->set[k];
    if (!bodies) ov[n++] = "rigids=[]";
    kf_diag diag;
    kf_diag_init(&diag);
    L->shot = kf_shot_load(o->shot, ov, n, NULL, NULL, &diag);
    int bad = !L->shot || kf_scene_from_shot(L->shot, o->threads, &L->sc, NULL, &diag);
    kf_diag_free(&diag);
    if (bad) fprintf(stderr, "cannot build %s%s\n", o->shot, bodies ? "" : " with rigids=[]");
    return bad ? -1 : 0;
}

/* one batch of a lane: the slab's `batch` substeps or the shot's span */
static int lane_batch(lane *L, const rounds_opts *o, int round) {
    const long before = L->st.substeps;
    const double w0 = wall_s(), c0 = cpu_s(), t0 = thread_cpu_s();
    int bad;
    if (L->m) bad = slab_steps(L->m, L->s, o->batch, &L->st, &L->band);
    else {
        char msg[256];
        bad = kf_advance(L->sc.model, L->sc.state, o->span_frames / L->sc.fps, &L->st, msg, sizeof msg);
        if (bad) fprintf(stderr, "%s: %s\n", L->name, msg);
    }
    L->cpu[round] = 1e3 * (cpu_s() - c0), L->thr[round] = 1e3 * (thread_cpu_s() - t0);
    L->wall[round] = 1e3 * (wall_s() - w0);
    L->sub[round] = L->m ? o->batch : L->st.substeps - before;
    return bad;
}

/* median, least and greatest of the rounds' ratios a / b - 1, in % */
static void ratio_stats(const double *a, const double *b, int n, double out[3]) {
    double r[ROUNDS_MAX];
    for (int k = 0; k < n; k++) r[k] = 100 * (a[k] / b[k] - 1);
    out[0] = kf_median(r, n), out[1] = r[0], out[2] = r[n - 1]; /* kf_median sorted r */
}

static int bench_rounds(const rounds_opts *o) {
    static lane lanes[3];
    static const char *slab_names[3] = {"none", "far", "cutting"};
    const int nl = o->shot ? 2 : 3;
    for (int l = 0; l < nl; l++) {
        lane *L = &lanes[l];
        memset(L, 0, sizeof *L);
        L->name = o->shot ? (l ? "bodies" : "none") : slab_names[l];
        if (o->shot ? lane_shot(L, o, l) : slab_make(l, o->cells, &L->m, &L->s)) return 1;
        /* the slab's first substep untimed, as a single run's (it builds everything) */
        if (L->m) kf_step(L->m, L->s, SLAB_DT, NULL, NULL);
    }
    /* the threads the simulations run on: a shot's own setting, else OpenMP's */
    const int shot_threads = o->shot ? kf_model_sim(lanes[0].sc.model)->threads : 0;
    const int threads = shot_threads > 0 ? shot_threads : omp_get_max_threads();
    printf("CPIC overhead by rounds: %s, %d threads, %d rounds of one batch per mode (%s), order rotated each "
           "round\n",
           o->shot ? o->shot : "the slab", threads, o->rounds, o->shot ? "a span of simulated time" : "substeps");
    printf("%5s", "round");
    for (int l = 0; l < nl; l++) printf(" | %-7s %4s %9s %9s", lanes[l].name, "sub", "cpu ms", "wall ms");
    for (int l = 1; l < nl; l++) printf(" | %s/none cpu  wall", lanes[l].name);
    printf("\n");
    for (int k = 0; k < o->rounds; k++) {
        for (int j = 0; j < nl; j++)
            if (lane_batch(&lanes[(k + j) % nl], o, k)) return 1;
        printf("%5d", k + 1);
        for (int l = 0; l < nl; l++)
            printf(" | %-7s %4ld %9.1f %9.1f", lanes[l].name, lanes[l].sub[k], lanes[l].cpu[k], lanes[l].wall[k]);
        for (int l = 1; l < nl; l++)
            printf(" | %+6.1f%% %+6.1f%%", 100 * (lanes[l].cpu[k] / lanes[0].cpu[k] - 1),
                   100 * (lanes[l].wall[k] / lanes[0].wall[k] - 1));
        printf("\n");
        fflush(stdout);
    }
    /* the figure: the rounds' ratios, and each mode's own spread */
    for (int l = 0; l < nl; l++) {
        lane *L = &lanes[l];
        double c[ROUNDS_MAX], lo = 1e300, hi = 0, subs = 0;
        for (int k = 0; k < o->rounds; k++) {
            c[k] = L->cpu[k] / L->sub[k], subs += L->sub[k];
            lo = c[k] < lo ? c[k] : lo, hi = c[k] > hi ? c[k] : hi;
        }
        printf("%-7s cpu ms per substep: median %.2f, range %.2f-%.2f over %.0f substeps | wall ms per substep by "
               "stage:",
               L->name, kf_median(c, o->rounds), lo, hi, subs);
        for (int e = 0; e < KF_STAGE_COUNT; e++) printf(" %s %.2f", kf_stage_name((kf_stage)e), L->st.ms[e] / subs);
        if (L->m) printf(" | band %.0f particles", L->band / subs);
        if (o->hash) printf(" | hash %016llx", (unsigned long long)kf_state_hash(L->m ? L->s : L->sc.state));
        printf("\n");
    }
    for (int l = 1; l < nl; l++) {
        double c[3], t[3], w[3];
        ratio_stats(lanes[l].cpu, lanes[0].cpu, o->rounds, c);
        ratio_stats(lanes[l].thr, lanes[0].thr, o->rounds, t);
        ratio_stats(lanes[l].wall, lanes[0].wall, o->rounds, w);
        printf("%s against none, the rounds' ratios: process CPU median %+.1f%% (range %+.1f%% to %+.1f%%), "
               "thread CPU %+.1f%% (%+.1f%% to %+.1f%%), wall %+.1f%% (%+.1f%% to %+.1f%%)\n",
               lanes[l].name, c[0], c[1], c[2], t[0], t[1], t[2], w[0], w[1], w[2]);
    }
    for (int l = 0; l < nl; l++) {
        if (lanes[l].m) kf_state_destroy(lanes[l].s), kf_model_destroy(lanes[l].m);
        else kf_scene_free(&lanes[l].sc), kf_shot_free(lanes[l].shot);
    }
    return 0;
}

int main(int argc, char **argv) {
    int cells = 128, steps = 20, runs = 3, json = 0, only = -1, hash = 0;
    rounds_opts ro = {.batch = 2, .span_frames = 1.0 / 16};
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
        else if (!strcmp(argv[i], "--rounds") && i + 1 < argc) ro.rounds = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--batch") && i + 1 < argc) ro.batch = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--shot") && i + 1 < argc) ro.shot = argv[++i];
        else if (!strcmp(argv[i], "--span") && i + 1 < argc) ro.span_frames = atof(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) ro.threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--set") && i + 1 < argc && ro.nset < 8) ro.set[ro.nset++] = argv[++i];
        else if (!strcmp(argv[i], "--mode") && i + 1 < argc) {
            ++i;
            for (int k = 0; k < 3; k++)
                if (!strcmp(argv[i], mode_name[k])) only = k;
            if (only < 0) {
                fprintf(stderr, "--mode: none, far or cutting\n");
                return 2;
            }
        } else {
            fprintf(stderr,
                    "usage: %s [--cells N] [--steps N] [--runs N] [--json] [--mode M] [--hash] | --seeding [--runs N]\n"
                    "       %s --rounds N [--cells N] [--batch B] [--hash]\n"
                    "       %s --rounds N --shot FILE [--set k=v]... [--span F] [--threads T] [--hash]\n",
                    argv[0], argv[0], argv[0]);
            return 2;
        }
    }
    if (ro.rounds > 0 || ro.shot) {
        ro.cells = cells, ro.hash = hash;
        if (ro.rounds < 1) ro.rounds = 1;
        if (ro.rounds > ROUNDS_MAX) ro.rounds = ROUNDS_MAX;
        if (ro.batch < 1 || !(ro.span_frames > 0)) {
            fprintf(stderr, "--batch and --span must be positive\n");
            return 2;
        }
        return bench_rounds(&ro);
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
