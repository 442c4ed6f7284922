/* bench_scenes.c — the paper's scenes as kerf ships them, at the paper's
 * size: `kerf_bench --only scenes [--frames N] [--scenes a,b] [--paper-dx]
 * [--scale S] [--threads T] [--hash] [--dump DIR] [--set k=v]`. --dump writes each
 * scene's particles (x, v, F in id order, float32) to DIR/<scene>.f32. --set passes an override
 * to every scene's shot (`--set 'rigids=[]'`: the scene without its bodies,
 * the baseline of CPIC's overhead).
 *
 * Each shipped shot that reproduces a Table 3 example runs its first N frames
 * (default 2) from the shot's start, in a child process of its own so that
 * its peak resident memory is its own. kerf's shots are in metres, the
 * paper's in its code's units, so Table 3's Δx does not give Table 3's
 * particle count: by default Δx is chosen so that the estimated particle
 * count matches Table 3's (the shot's own estimate scaled by Δx³), and
 * --paper-dx uses Table 3's Δx as printed. --scale multiplies the chosen Δx
 * (2 = an eighth of the particles) for a quick run.
 *
 * With --substeps N only about N substeps run, timed after 5 untimed ones
 * from the shot's start (first touches, first splats), and the frame's
 * figures are extrapolated: seconds per substep times the substeps a
 * frame takes at the Δt those substeps averaged (the substeps column then
 * says "~"). The paper's sizes take minutes per frame; this takes seconds,
 * at the price of the action that comes later in the frame.
 *
 * Printed per scene: particles, substeps per frame, seconds per frame (wall
 * and process CPU),
 * particle-steps/s, ms per stage per frame, peak RSS (and bytes per
 * particle), Table 3's seconds per frame (4-core i7-7700K at 4.2 GHz) and a
 * per-core comparison: core-seconds per frame per million particles for kerf
 * (wall × threads) and for the paper (wall × 4). */
#include "bench_scenes.h"
#include "bench_child.h"

#include <errno.h>
#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "../src/core/timer.h"
#include <kerf/kerf.h>
#include "../src/mpm/model.h" /* kf_stable_dt */
#include "../src/scene/budget.h"
#include "../src/scene/build.h"
#include "../src/shot/shot.h"

/* Table 3 of the paper: Δx, seconds per frame, particles */
typedef struct paper_scene {
    const char *shot, *figure;
    double dx, s_per_frame, particles;
    int match_count; /* 0: a 2D example in the paper, whose count means nothing in 3D: Table 3's dx */
} paper_scene;

static const paper_scene paper[] = {
    {"bunny_split", "Fig. 4", 3.3e-3, 16.7, 2.0e6, 1},
    {"cheese_cut", "Fig. 3", 3.3e-3, 227.1, 1.8e6, 1},
    {"water_wheel", "Fig. 1", 2.5e-3, 120.3, 1.4e6, 1},
    {"buoyancy", "Fig. 6", 3.1e-3, 122.9, 5.3e6, 1},
    {"goo_blocks", "Fig. 8", 4.2e-3, 105.3, 1.8e6, 1},
    {"sand_sweep", "Fig. 15", 2.0e-3, 288.3, 2.6e6, 1},
    {"sand_stir", "Fig. 9", 3.1e-3, 158.3, 5.2e6, 1},
    {"sand_paddles", "Fig. 14", 2.0e-3, 20.0, 1.0e6, 1},
    {"sand_wheel", "Fig. 5 (2D)", 2.5e-3, 0.3, 4.1e3, 0},
    {"armadillo_cut", "Fig. 7", 5.0e-3, 107.0, 1.3e6, 1},
    {"banana", "Fig. 1", 4.2e-3, 140.5, 1.2e6, 1},
    {"robot_sand", "Fig. 16", 3.3e-3, 112.4, 3.4e6, 1},
    {"robot_sand_reverse", "Fig. 16 (reverse)", 3.3e-3, 116.8, 3.4e6, 1},
};
#define NPAPER ((int)(sizeof paper / sizeof *paper))

typedef struct scene_result {
    int ok;
    char msg[200];
    double dx, particles, est_particles, substeps_per_frame, s_per_frame, mpsteps;
    double ms_per_frame[KF_STAGE_COUNT];
    double peak_mb, cpu_s_per_frame;
    double band_share;       /* the particle-steps in CPIC's band, a fraction of all */
    unsigned long long hash; /* kf_state_hash after the frames */
    int threads, frames;
    long substeps_run;
    long fused; /* substeps whose P2G the substep before made early (the fused sweep) */
} scene_result;

/* x, v and F of every particle as float32, in id order (ids are 0..n-1),
 * after a count: two builds' files compare particle by particle */
static void dump_particles(const char *dir, const char *name, kf_state *s) {
    char path[512];
    snprintf(path, sizeof path, "%s/%s.f32", dir, name);
    /* the folder made if missing; a file that cannot be written said, not skipped in silence */
    if (mkdir(dir, 0777) && errno != EEXIST) fprintf(stderr, "kerf_bench: --dump %s: %s\n", dir, strerror(errno));
    FILE *f = fopen(path, "wb");
    if (!f) {
        fprintf(stderr, "kerf_bench: cannot write %s: %s\n", path, strerror(errno));
        return;
    }
    kf_particles_view p = kf_state_particles_read(s);
    float *rec = calloc(p.n ? p.n : 1, 15 * sizeof *rec);
    for (size_t i = 0; rec && i < p.n; i++) {
        float *r = rec + 15 * (size_t)(p.id[i] < p.n ? p.id[i] : 0);
        for (int a = 0; a < 3; a++) r[a] = (float)p.x[a][i], r[3 + a] = (float)p.v[a][i];
        for (int k = 0; k < 9; k++) r[6 + k] = (float)p.F[k][i];
    }
    uint64_t n = p.n;
    fwrite(&n, sizeof n, 1, f);
    if (rec) fwrite(rec, sizeof *rec, 15 * p.n, f);
    free(rec);
    fclose(f);
}

/* substeps run untimed before --substeps' timed ones */
#define BENCH_WARM_SUBSTEPS 5

/* in the child: load the shot at Δx, run `frames` frames, fill r */
static void run_scene(const char *shot_dir, const paper_scene *ps, const bench_scenes_opts *o, scene_result *r) {
    char path[400], set[64];
    snprintf(path, sizeof path, "%s/%s.yaml", shot_dir, ps->shot);
    kf_diag diag;
    kf_diag_init(&diag);
    kf_shot *shot = kf_shot_load(path, o->set, o->nset, NULL, NULL, &diag);
    if (!shot) {
        snprintf(r->msg, sizeof r->msg, "cannot load %.150s", path);
        return;
    }
    double dx = ps->dx;
    if (!o->paper_dx && ps->match_count) {
        /* the Δx whose particle count matches Table 3's */
        kf_budget b;
        char err[256];
        if (kf_budget_estimate(shot, &b, err, sizeof err)) {
            snprintf(r->msg, sizeof r->msg, "%.150s", err);
            return;
        }
        dx = shot->sim.dx * cbrt(b.particles / ps->particles);
    }
    dx *= o->scale;
    kf_shot_free(shot);
    snprintf(set, sizeof set, "sim.dx=%.6g", dx);
    const char *ov[9] = {set};
    for (int k = 0; k < o->nset; k++) ov[1 + k] = o->set[k];
    shot = kf_shot_load(path, ov, 1 + o->nset, NULL, NULL, &diag);
    kf_scene sc;
    if (!shot || kf_scene_from_shot(shot, o->threads, &sc, NULL, &diag)) {
        snprintf(r->msg, sizeof r->msg, "cannot build %.120s at %.60s", path, set);
        return;
    }
    kf_budget b;
    char err[256];
    r->est_particles = kf_budget_estimate(shot, &b, err, sizeof err) ? 0 : b.particles;
    r->dx = dx;
    r->particles = (double)kf_state_count(sc.state);
    kf_model_set_unfused(sc.model, o->unfused);
    r->threads = kf_model_sim(sc.model)->threads > 0 ? kf_model_sim(sc.model)->threads : omp_get_max_threads();
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    char msg[512];
    double c0 = kf_process_cpu_ms();
    double t0 = kf_now_ms();
    /* f frames, or the fraction of one frame that about N substeps cover */
    double f = 0;
    if (o->substeps > 0) {
        /* the first substeps untimed: they touch every page for the first
         * time and splat every body's first distance field, costs a whole
         * frame spreads over hundreds of substeps */
        const kf_model *m = sc.model;
        double dt = m->sim.dt_fixed > 0 ? m->sim.dt_fixed : kf_stable_dt(m, sc.state, m->sim.cfl);
        kf_step_stats warm;
        memset(&warm, 0, sizeof warm);
        if (kf_advance(sc.model, sc.state, BENCH_WARM_SUBSTEPS * dt, &warm, msg, sizeof msg)) {
            snprintf(r->msg, sizeof r->msg, "warm-up: %.150s", msg);
            goto done;
        }
        dt = m->sim.dt_fixed > 0 ? m->sim.dt_fixed : kf_stable_dt(m, sc.state, m->sim.cfl);
        double span = fmin(o->substeps * dt, 1.0 / sc.fps);
        c0 = kf_process_cpu_ms();
        t0 = kf_now_ms();
        if (kf_advance(sc.model, sc.state, span, &st, msg, sizeof msg)) snprintf(r->msg, sizeof r->msg, "%.150s", msg);
        else f = span * sc.fps;
    } else
        for (int k = 0; k < o->frames; k++, f++)
            if (kf_advance(sc.model, sc.state, 1.0 / sc.fps, &st, msg, sizeof msg)) {
                snprintf(r->msg, sizeof r->msg, "frame %d: %.150s", k + 1, msg);
                break;
            }
    double sec = (kf_now_ms() - t0) / 1e3;
    double cpu = (kf_process_cpu_ms() - c0) / 1e3;
    r->frames = (int)f;
    r->substeps_run = st.substeps;
    r->fused = st.fused;
    if (f > 0) {
        r->ok = 1;
        r->s_per_frame = sec / f;
        r->cpu_s_per_frame = cpu / f;
        r->substeps_per_frame = (double)st.substeps / f;
        r->mpsteps = (double)st.particle_steps / sec / 1e6;
        r->band_share = st.particle_steps ? (double)st.band_particle_steps / (double)st.particle_steps : 0;
        for (int k = 0; k < KF_STAGE_COUNT; k++) r->ms_per_frame[k] = st.ms[k] / f;
    }
done:
    r->hash = kf_state_hash(sc.state);
    if (o->dump) dump_particles(o->dump, ps->shot, sc.state);
    kf_scene_free(&sc);
    kf_shot_free(shot);
    kf_diag_free(&diag);
}

/* a scene in a child process of its own (bench_child.h): its peak RSS is its own */
typedef struct scene_job {
    const char *shot_dir;
    const paper_scene *ps;
    const bench_scenes_opts *o;
} scene_job;

static void scene_child(const void *ctx, void *result) {
    const scene_job *j = ctx;
    scene_result *r = result;
    run_scene(j->shot_dir, j->ps, j->o, r);
    r->peak_mb = bench_peak_mb();
}

static void run_child(const char *shot_dir, const paper_scene *ps, const bench_scenes_opts *o, scene_result *r) {
    const scene_job j = {shot_dir, ps, o};
    int status;
    if (bench_in_child(scene_child, &j, r, sizeof *r, &status))
        snprintf(r->msg, sizeof r->msg, status == -1 ? "pipe failed" : "the run died (status %d)", status);
}

static int wanted(const char *list, const char *name) {
    if (!list) return 1;
    size_t n = strlen(name);
    for (const char *p = list; (p = strstr(p, name)); p += n)
        if ((p == list || p[-1] == ',') && (p[n] == 0 || p[n] == ',')) return 1;
    return 0;
}

int bench_scenes(const bench_scenes_opts *o) {
    const char *dir = o->shot_dir ? o->shot_dir : "shots";
    if (o->substeps > 0)
        printf("paper scenes, about %d substeps each after %d untimed from the shot's start, per-frame figures "
               "extrapolated, %s%s\n",
               o->substeps, BENCH_WARM_SUBSTEPS, o->paper_dx ? "Table 3's dx" : "dx matching Table 3's particle count",
               o->scale != 1 ? " (scaled)" : "");
    else
        printf("paper scenes, %d frame(s) each from the shot's start, %s%s\n", o->frames,
               o->paper_dx ? "Table 3's dx" : "dx matching Table 3's particle count", o->scale != 1 ? " (scaled)" : "");
    printf("%-12s %8s %9s %8s %9s %9s %8s", "scene", "dx", "particles", "substeps", "s/frame", "cpu s/f", "Mp-st/s");
    for (int k = 0; k < KF_STAGE_COUNT; k++) printf(" %8s", kf_stage_name((kf_stage)k));
    printf(" %8s %6s %9s %9s %9s %6s %6s\n", "peak MB", "B/p", "paper s", "kerf c-s", "paper c-s", "ratio", "band%");
    int fails = 0;
    for (int i = 0; i < NPAPER; i++) {
        if (!wanted(o->only, paper[i].shot)) continue;
        scene_result r;
        run_child(dir, &paper[i], o, &r);
        if (!r.ok) {
            printf("%-12s %s\n", paper[i].shot, r.msg);
            fails++;
            continue;
        }
        /* core-seconds per frame per million particles: kerf's threads, the paper's 4 cores */
        double kcs = r.s_per_frame * r.threads / (r.particles / 1e6);
        double pcs = paper[i].match_count ? paper[i].s_per_frame * 4 / (paper[i].particles / 1e6) : NAN;
        printf("%-12s %8.5f %9.0f %s%7.1f %9.2f %9.2f %8.2f", paper[i].shot, r.dx, r.particles,
               o->substeps > 0 ? "~" : " ", r.substeps_per_frame, r.s_per_frame, r.cpu_s_per_frame, r.mpsteps);
        for (int k = 0; k < KF_STAGE_COUNT; k++) printf(" %8.0f", r.ms_per_frame[k]);
        printf(" %8.0f %6.0f %9.1f %9.2f %9.2f %6.2f %6.1f\n", r.peak_mb, r.peak_mb * 1048576.0 / r.particles,
               paper[i].s_per_frame, kcs, pcs, kcs / pcs, 100 * r.band_share);
        if (o->hash && o->substeps > 0) printf("  state hash after %ld substeps: %016llx\n", r.substeps_run, r.hash);
        else if (o->hash) printf("  state hash after %d frame(s): %016llx\n", r.frames, r.hash);
        if (o->hash) printf("  early P2G (made by the substep before): %ld of %ld substeps\n", r.fused, r.substeps_run);
        if (r.msg[0]) printf("  (%s)\n", r.msg);
        fflush(stdout);
    }
    printf("s/frame: wall; cpu s/f: the process's CPU seconds per frame (the honest figure at 1 thread on a busy "
           "machine; with idle OpenMP threads spinning it overstates). ~: extrapolated from the substeps run. stage "
           "columns: ms per frame (wall). kerf c-s / "
           "paper c-s: core-seconds per frame per million particles "
           "(kerf: wall x threads; Table 3: wall x 4 cores of an i7-7700K at 4.2 GHz); ratio < 1: kerf "
           "spends less per core. band%%: the particle-steps in CPIC's narrow band (owner blocks near a body, whose "
           "transfers take CPIC's paths).\n");
    return fails ? 1 : 0;
}
