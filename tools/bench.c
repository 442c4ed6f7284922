/* bench.c — kerf's speed figures, printed, never asserted.
 *
 *   kerf_bench [--json] [--runs N] [--quick] [--only cube|block|frame|scenes|memory|stress|pair]
 *              [--frames N] [--scenes a,b] [--paper-dx] [--scale S] [--threads T] [--hash] [--dump DIR] [--set k=v]
 *              [--substeps N] [--cells N] [--force mls|classic] [--unfused] [--particles N]
 *
 * cube:  the paper's Table 2 setup (grid 125³, a 100³-cell cube, 2x2x2
 *        particles per cell = 8M particles, E = 100, ν = 0.3, Δt = 1e-2, no
 *        gravity), and the same at 1M particles (grid 63³). P2G and G2P alone
 *        (ns per particle) and the whole step, MLS vs classic, 1 and 2 threads,
 *        median of N runs. kerf evaluates the stress in its own pass after G2P
 *        (with the return mapping), so P2G here scatters a stored stress; the
 *        stress column is that pass, and "all" = P2G + G2P + stress is the
 *        figure comparable with a P2G that evaluates the stress itself.
 * block: a fixed-corotated block of ~1M particles falling onto the floor
 *        (sorting and grid allocation exercised), CFL-adaptive frames:
 *        particle-steps per second, ms per stage, peak memory. --particles N,
 *        --frames N and --threads T pick its size, frames and threads (a
 *        small block under callgrind); --hash prints its state hash after
 *        the frames (a bit-for-bit check of the elastic path, deformed).
 * frame: one frame of the falling block's ~1M particles surfaced (level
 *        set: centre averaging, sort, splat, re-distance, filters; mesh; .vdb
 *        write) and rendered (OSMesa, 1920x1080) at final quality (the shot's
 *        defaults: centres averaged over 3 spacings, spheres of 2 spacings on
 *        voxels of 0.75, one mean-curvature pass, edge anti-aliasing) and at preview
 *        quality (surface.quality and render.quality preview: voxel 1.5
 *        spacings, spheres of 2.4, the same averaging, one pass, no MSAA, a
 *        1024-texel shadow map), seconds
 *        per stage (wall and process CPU; the render's a warm context's
 *        second frame, as in a sequence, its first frame's beside it), beside the cost of simulating that
 *        frame at preview quality (2x dx, 1/8 the particles) and of simulating the surfaced
 *        frame itself (the block's first frame at its own dx). KERF_BENCH_PNG=dir
 *        writes both pictures there. Process CPU seconds are the honest figure
 *        on a shared machine only when idle OpenMP threads sleep: libgomp's
 *        default spins (measured: 4.3 CPU s instead of 0.5 for the preview
 *        frame on 2 busy cores), so `--only frame` re-runs itself with
 *        OMP_WAIT_POLICY=passive unless it is set.
 * scenes: the paper's scenes at the paper's size, N frames each, or with
 *        --substeps N the first N substeps and the frame extrapolated (only
 *        with --only scenes; see bench_scenes.c for the options).
 * memory: peak resident bytes per particle of the 8M cube and bunny_split
 *        at Δx 0.0033 over a few substeps, against kerf info's estimate
 *        (only with --only memory; bench_memory.c; --scenes cube picks one).
 * stress: ns per particle of the stress pass per solid model, batch path
 *        and scalar path, one thread (only with --only stress; bench_stress.c).
 * pair:  MLS against classic on one cube (--cells, default 100; --threads,
 *        default 2), their steps alternating for --runs rounds, and the ratio
 *        taken within each round (only with --only pair; bench_pair.c).
 * --cells, --force and --threads pick one cube size, force or thread count.
 * --unfused runs G2P, the stress pass and P2G as separate passes (cube,
 *        block and scenes), the reference the fused substep end must equal bit for bit.
 * --quick shrinks them (24³ and 16³ cubes, a 100k-particle block) for a smoke run. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "../render/render.h"
#include "../src/core/timer.h"
#include "../src/io/vdb_bridge.h"
#include "../src/shot/shot.h" /* the preview presets */
#include <kerf/kerf.h>
#include "../src/mpm/model.h" /* kf_model_set_unfused */
#include "../src/scene/builtin.h"
#include "bench_memory.h"
#include "bench_pair.h"
#include "bench_scenes.h"
#include "bench_stress.h"
#include "median.h"

static double peak_rss_mb(void) {
    struct rusage ru;
    getrusage(RUSAGE_SELF, &ru);
    return ru.ru_maxrss / 1024.0;
}

/* process CPU seconds: honest at 1 thread on a busy machine when idle OpenMP threads sleep */
static double cpu_s(void) { return kf_process_cpu_ms() * 1e-3; }

typedef struct cube_result {
    int cells, threads;
    const char *force;
    size_t particles;
    double p2g_ns, g2p_ns, stress_ns, grid_ms, step_ms, mpsteps;
    double cpu_ms; /* process CPU per step (median) */
} cube_result;

/* --unfused: G2P, stress and P2G as separate passes, the fused step's reference */
static int unfused;

static int bench_cube(int cells, kf_force force, int threads, int runs, cube_result *out) {
    char err[256];
    kf_scene sc;
    if (kf_scene_bench_cube(&sc, cells, force, threads, err, sizeof err)) {
        fprintf(stderr, "bench: %s\n", err);
        return -1;
    }
    kf_model_set_unfused(sc.model, unfused);
    size_t n = kf_state_count(sc.state);
    /* every substep is 1e-2 s and nothing edits the state in between: each
     * may end with the next one's P2G (fused with its G2P and stress pass;
     * P2G then reads 0 and G2P holds all three) */
    kf_state_fuse_next(sc.state, 1e-2);
    /* warm-up: the first step bins the particles and allocates the grid */
    kf_step(sc.model, sc.state, 1e-2, NULL, NULL);
    double p2g[64], g2p[64], stress[64], grid[64], step[64], cpu[64];
    if (runs > 64) runs = 64;
    for (int r = 0; r < runs; r++) {
        kf_step_stats st = {0};
        double t0 = kf_now_ms(), c0 = cpu_s();
        kf_step(sc.model, sc.state, 1e-2, &st, NULL);
        step[r] = kf_now_ms() - t0;
        cpu[r] = (cpu_s() - c0) * 1e3;
        p2g[r] = st.ms[KF_STAGE_P2G];
        g2p[r] = st.ms[KF_STAGE_G2P];
        stress[r] = st.ms[KF_STAGE_STRESS];
        grid[r] = st.ms[KF_STAGE_GRID];
    }
    out->cells = cells;
    out->threads = threads;
    out->force = force == KF_FORCE_MLS ? "mls" : "classic";
    out->particles = n;
    out->p2g_ns = kf_median(p2g, runs) * 1e6 / (double)n;
    out->g2p_ns = kf_median(g2p, runs) * 1e6 / (double)n;
    out->stress_ns = kf_median(stress, runs) * 1e6 / (double)n;
    out->grid_ms = kf_median(grid, runs);
    out->step_ms = kf_median(step, runs);
    out->cpu_ms = kf_median(cpu, runs);
    out->mpsteps = (double)n / (out->step_ms * 1e3);
    kf_scene_free(&sc);
    return 0;
}

/* the frame benchmark's stages, each timed in wall and process CPU seconds
 * (CPU time stays honest when other work shares the machine) */
enum { FS_AVERAGE, FS_SORT, FS_SPLAT, FS_REDISTANCE, FS_FILTER, FS_MESH, FS_WRITE, FS_RENDER, FS_COUNT };
static const char *const frame_stage_name[FS_COUNT] = {"average", "sort", "splat",     "redistance",
                                                       "filter",  "mesh", "write_vdb", "render_1080p"};

/* the settings a frame is surfaced and rendered with: the shot's defaults
 * (src/shot/keys.c) and its `quality: preview` presets (src/shot/shot.c);
 * beside them the same with surface.kernel: spheres (kerf's earlier look) */
typedef struct frame_quality {
    const char *name;
    int kernel;                     /* 0 anisotropic discs, 1 spheres (surface.kernel) */
    double voxel, radius, reach;    /* particle spacings */
    int iterations;                 /* mean-curvature passes */
    double average, average_radius; /* spheres' centre averaging: weight, neighbourhood in spacings */
    int samples, shadow;            /* anti-aliasing samples; shadow map texels (0: automatic) */
    int flatten;                    /* passes of the faces' flattening (surface.flatten) */
} frame_quality;
enum { FQ_FINAL, FQ_PREVIEW, FQ_FINAL_SPHERES, FQ_PREVIEW_SPHERES, FQ_COUNT };
static const frame_quality frame_qualities[FQ_COUNT] = {
    {"final", 0, 0.75, 2, 3, 2, 1, 3, 4, 0, 3},
    {"preview", 0, KF_VDB_PREVIEW_VOXEL, KF_VDB_PREVIEW_RADIUS, 3, KF_VDB_PREVIEW_ITERATIONS, 1, 3, 1,
     KF_RENDER_PREVIEW_SHADOW, 0},
    {"final_spheres", 1, 0.75, 2, 3, 1, 1, 3, 4, 0, 0},
    {"preview_spheres", 1, KF_VDB_PREVIEW_VOXEL, KF_VDB_PREVIEW_RADIUS, 3, KF_VDB_PREVIEW_ITERATIONS, 1, 3, 1,
     KF_RENDER_PREVIEW_SHADOW, 0},
};

typedef struct frame_post_result {
    size_t triangles, active_voxels;
    double wall[FS_COUNT], cpu[FS_COUNT];
    double first_render_wall, first_render_cpu; /* a fresh context's first frame (its shaders' JIT) */
    double vdb_mb;
} frame_post_result;

typedef struct frame_result {
    size_t particles, preview_particles;
    long preview_substeps, final_substeps;
    double sim_wall, sim_cpu;             /* simulating the frame at preview quality */
    double final_sim_wall, final_sim_cpu; /* simulating the surfaced frame itself (its own particles) */
    frame_post_result q[FQ_COUNT];
} frame_result;

/* surface, write and render n particles x (spacing apart) with quality q:
 * erosion back onto the material, 1920x1080 */
static int frame_post(size_t n, const float *x, double spacing, double dx, const frame_quality *q,
                      frame_post_result *out) {
    char err[512] = "";
    kf_vdb_surface_params sp;
    kf_vdb_surface_params_default(&sp);
    sp.spacing = spacing;
    sp.voxel = q->voxel * spacing;
    sp.smooth = KF_VDB_OP_MEAN_CURVATURE;
    sp.smooth_iterations = q->iterations;
    sp.flatten = q->flatten;
    if (q->kernel == 0) {
        sp.kernel = KF_VDB_KERNEL_ANISOTROPIC;
        sp.radius = sp.average_radius = q->reach * spacing;
    } else {
        sp.radius = q->radius * spacing;
        sp.average = q->average;
        sp.average_radius = q->average_radius * spacing;
    }
    sp.erode = kf_vdb_surface_offset(&sp);
    sp.clamp_small = 1;
    kf_vdb_grid *g = NULL;
    kf_vdb_trimesh mesh = {0};
    kf_vdb_surface_stats st = {0};
    int rc = kf_vdb_levelset_from_particles(n, NULL, x, NULL, NULL, &sp, &g, &st, err, sizeof err);
    /* the bridge times its phases in process CPU and wall seconds (wall
     * against CPU: how much of a phase ran on both cores); where it gives no
     * wall times (spheres) the phases share the level set's wall time in
     * proportion to their CPU time */
    out->cpu[FS_AVERAGE] = st.cpu_average;
    out->cpu[FS_SORT] = st.cpu_sort, out->cpu[FS_SPLAT] = st.cpu_splat;
    out->cpu[FS_REDISTANCE] = st.cpu_redistance, out->cpu[FS_FILTER] = st.cpu_filter;
    const double walls[] = {st.wall_average, st.wall_sort, st.wall_splat, st.wall_redistance, st.wall_filter};
    double cls = st.cpu_average + st.cpu_sort + st.cpu_splat + st.cpu_redistance + st.cpu_filter, wls = 0;
    for (int k = FS_AVERAGE; k <= FS_FILTER; k++) wls += walls[k - FS_AVERAGE];
    for (int k = FS_AVERAGE; k <= FS_FILTER; k++)
        out->wall[k] = wls > 0 ? walls[k - FS_AVERAGE] : (cls > 0 ? st.seconds * out->cpu[k] / cls : 0);
    out->active_voxels = st.active_voxels;
    double t0 = kf_now_ms(), c0 = cpu_s();
    if (!rc) rc = kf_vdb_mesh(g, 0, 0, &mesh, err, sizeof err);
    out->wall[FS_MESH] = (kf_now_ms() - t0) / 1e3, out->cpu[FS_MESH] = cpu_s() - c0;
    out->triangles = mesh.ntris;
    char path[256];
    snprintf(path, sizeof path, "/tmp/kerf_bench_frame_%d.vdb", (int)getpid());
    kf_vdb_meta meta = {.frame = 1, .dx = dx};
    snprintf(meta.shot, sizeof meta.shot, "bench");
    t0 = kf_now_ms(), c0 = cpu_s();
    if (!rc) rc = kf_vdb_write(path, &g, 1, &meta, err, sizeof err);
    out->wall[FS_WRITE] = (kf_now_ms() - t0) / 1e3, out->cpu[FS_WRITE] = cpu_s() - c0;
    struct stat fs;
    if (!rc && stat(path, &fs) == 0) out->vdb_mb = (double)fs.st_size / 1e6;
    unlink(path);
    if (!rc) {
        /* the context is made outside the timing: a sequence renders many frames with one */
        kf_render_ctx *ctx = kf_render_create(1920, 1080, q->samples, err, sizeof err);
        if (ctx && q->shadow && kf_render_set_shadow_size(ctx, q->shadow, err, sizeof err)) rc = -1;
        /* render.antialias' default: edges when there are samples (src/pipeline/stages.c) */
        if (ctx && q->samples > 1 && kf_render_set_antialias(ctx, KF_RENDER_AA_EDGES, err, sizeof err)) rc = -1;
        uint8_t *rgba = malloc((size_t)1920 * 1080 * 4);
        /* closed: a level set's mesh, as the pipeline renders it */
        kf_render_mesh rm = {
            mesh.verts, mesh.normals, mesh.nverts, mesh.tris, mesh.ntris, {{0.8f, 0.3f, 0.3f}, 0.3f, 0.5f}, NULL, 0, 1};
        kf_render_scene scene = kf_render_scene_default();
        scene.meshes = &rm;
        scene.nmeshes = 1;
        scene.ground = 1;
        float lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1}, view[3] = {-0.55f, -0.45f, -1.0f};
        kf_camera cam = kf_camera_frame_bounds(lo, hi, view, 35.0f);
        /* the frame drawn twice: a fresh context's first frame compiles the
         * shaders (llvmpipe JITs them at the first draw), which `kerf run`
         * pays once for all its frames (it keeps its context: stages.c), so
         * the stage's figure is the second, warm frame, the first beside it */
        t0 = kf_now_ms(), c0 = cpu_s();
        if (!ctx || !rgba || rc || kf_render_frame(ctx, &scene, &cam, rgba, err, sizeof err)) rc = -1;
        out->first_render_wall = (kf_now_ms() - t0) / 1e3, out->first_render_cpu = cpu_s() - c0;
        t0 = kf_now_ms(), c0 = cpu_s();
        if (rc || kf_render_frame(ctx, &scene, &cam, rgba, err, sizeof err)) rc = -1;
        out->wall[FS_RENDER] = (kf_now_ms() - t0) / 1e3, out->cpu[FS_RENDER] = cpu_s() - c0;
        const char *png = getenv("KERF_BENCH_PNG"); /* a look at the picture: KERF_BENCH_PNG=dir */
        if (!rc && png) {
            char pp[512];
            snprintf(pp, sizeof pp, "%s/bench_frame_%s.png", png, q->name);
            if (kf_png_write(pp, rgba, 1920, 1080, NULL, 0, err, sizeof err)) rc = -1;
        }
        free(rgba);
        if (ctx) kf_render_destroy(ctx);
    }
    if (rc) fprintf(stderr, "bench: frame (%s): %s\n", q->name, err);
    kf_vdb_mesh_free(&mesh);
    if (g) kf_vdb_free(g);
    return rc;
}

/* one frame of the falling block's ~n particles, surfaced and rendered at
 * final and at preview quality; beside it, the cost of simulating that
 * frame at preview quality (dx doubled, 1/8 the particles) and of
 * simulating the surfaced frame itself (its first frame, from rest) */
static int bench_frame(long n, frame_result *out) {
    char err[512], msg[512];
    kf_scene sc, pv;
    if (kf_scene_falling_block(&sc, n, 0, err, sizeof err) || kf_scene_falling_block(&pv, n / 8, 0, err, sizeof err)) {
        fprintf(stderr, "bench: %s\n", err);
        return -1;
    }
    kf_step_stats pst = {0};
    double t0 = kf_now_ms(), c0 = cpu_s();
    if (kf_advance(pv.model, pv.state, 1.0 / 24, &pst, msg, sizeof msg)) fprintf(stderr, "bench: %s\n", msg);
    out->sim_wall = (kf_now_ms() - t0) / 1e3, out->sim_cpu = cpu_s() - c0;
    out->preview_substeps = pst.substeps, out->preview_particles = kf_state_count(pv.state);
    kf_step_stats fst = {0};
    t0 = kf_now_ms(), c0 = cpu_s();
    if (kf_advance(sc.model, sc.state, 1.0 / 24, &fst, msg, sizeof msg)) fprintf(stderr, "bench: %s\n", msg);
    out->final_sim_wall = (kf_now_ms() - t0) / 1e3, out->final_sim_cpu = cpu_s() - c0;
    out->final_substeps = fst.substeps;
    kf_particles_view p = kf_state_particles_read(sc.state);
    out->particles = p.n;
    float *x = malloc(sizeof(float) * 3 * p.n);
    for (size_t i = 0; i < p.n; i++)
        for (int a = 0; a < 3; a++) x[3 * i + a] = (float)p.x[a][i];
    const double dx = kf_model_sim(sc.model)->dx;
    int rc = 0;
    for (int k = 0; k < FQ_COUNT && !rc; k++)
        rc = frame_post(p.n, x, dx / 2 /* 8 particles per cell */, dx, &frame_qualities[k], &out->q[k]);
    free(x);
    kf_scene_free(&sc);
    kf_scene_free(&pv);
    return rc;
}

/* surfacing + rendering: every stage after simulation */
static double frame_total(const double *t) {
    double s = 0;
    for (int k = 0; k < FS_COUNT; k++) s += t[k];
    return s;
}

typedef struct block_result {
    size_t particles;
    int frames;
    long substeps, fused;                                              /* fused: substeps whose P2G came early */
    unsigned long long hash;                                           /* kf_state_hash after the frames */
    double seconds, cpu_seconds, mpsteps, ms[KF_STAGE_COUNT], peak_mb; /* cpu: process CPU of the frames */
} block_result;

static int bench_block(long n, int frames, int threads, block_result *out) {
    char err[256], msg[512];
    kf_scene sc;
    if (kf_scene_falling_block(&sc, n, threads, err, sizeof err)) {
        fprintf(stderr, "bench: %s\n", err);
        return -1;
    }
    kf_model_set_unfused(sc.model, unfused);
    kf_step_stats st = {0};
    double t0 = kf_now_ms(), c0 = cpu_s();
    for (int f = 0; f < frames; f++)
        if (kf_advance(sc.model, sc.state, 1.0 / sc.fps, &st, msg, sizeof msg)) {
            fprintf(stderr, "bench: falling block: %s\n", msg);
            break;
        }
    out->seconds = (kf_now_ms() - t0) / 1e3;
    out->cpu_seconds = cpu_s() - c0;
    out->fused = st.fused;
    out->particles = kf_state_count(sc.state);
    out->frames = frames;
    out->substeps = st.substeps;
    out->mpsteps = st.particle_steps / out->seconds / 1e6;
    for (int k = 0; k < KF_STAGE_COUNT; k++) out->ms[k] = st.ms[k] / (st.substeps ? st.substeps : 1);
    out->peak_mb = peak_rss_mb();
    out->hash = kf_state_hash(sc.state);
    kf_scene_free(&sc);
    return 0;
}

int main(int argc, char **argv) {
    int json = 0, runs = 5, quick = 0;
    const char *only = NULL;
    bench_scenes_opts so = {.frames = 2, .scale = 1};
    int substeps = 3;
    /* the cube: only this size, force (0 MLS, 1 classic) or thread count, when given */
    int only_cells = 0, only_force = -1;
    /* the falling block: its particle count and frames, when given */
    long block_particles = 0;
    int frames_given = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--json")) json = 1;
        else if (!strcmp(argv[i], "--frames") && i + 1 < argc) so.frames = atoi(argv[++i]), frames_given = 1;
        else if (!strcmp(argv[i], "--particles") && i + 1 < argc) block_particles = atol(argv[++i]);
        else if (!strcmp(argv[i], "--scenes") && i + 1 < argc) so.only = argv[++i];
        else if (!strcmp(argv[i], "--paper-dx")) so.paper_dx = 1;
        else if (!strcmp(argv[i], "--hash")) so.hash = 1;
        else if (!strcmp(argv[i], "--dump") && i + 1 < argc) so.dump = argv[++i];
        else if (!strcmp(argv[i], "--set") && i + 1 < argc && so.nset < 8) so.set[so.nset++] = argv[++i];
        else if (!strcmp(argv[i], "--scale") && i + 1 < argc) so.scale = atof(argv[++i]);
        else if (!strcmp(argv[i], "--threads") && i + 1 < argc) so.threads = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--quick")) quick = 1;
        else if (!strcmp(argv[i], "--unfused")) unfused = so.unfused = 1;
        else if (!strcmp(argv[i], "--substeps") && i + 1 < argc) substeps = so.substeps = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--runs") && i + 1 < argc) runs = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--cells") && i + 1 < argc) only_cells = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--force") && i + 1 < argc) only_force = !strcmp(argv[++i], "classic");
        else if (!strcmp(argv[i], "--only") && i + 1 < argc) only = argv[++i];
        else {
            fprintf(stderr,
                    "usage: kerf_bench [--json] [--runs N] [--quick] [--only cube|block|frame|scenes|memory|stress|pair]\n"
                    "                  [--frames N] [--scenes a,b] [--paper-dx] [--scale S] [--threads T] "
                    "[--hash] [--dump DIR] [--set k=v] [--substeps N]\n"
                    "                  [--cells N] [--force mls|classic] [--unfused] [--particles N]\n");
            return 2;
        }
    }
    if (runs < 1) runs = 1;
    if (only && !strcmp(only, "memory")) {
        bench_memory_opts mo = {substeps > 0 ? substeps : 1, so.threads > 0 ? so.threads : 2,
                                so.scale > 0 ? so.scale : 1, so.only};
        return bench_memory(&mo);
    }
    if (only && !strcmp(only, "stress")) return bench_stress(runs);
    if (only && !strcmp(only, "pair"))
        return bench_pair(only_cells ? only_cells : quick ? 24 : 100, so.threads > 0 ? so.threads : 2, runs);
    if (only && !strcmp(only, "scenes")) {
        if (so.frames < 1 || !(so.scale > 0)) {
            fprintf(stderr, "kerf_bench: --frames must be >= 1 and --scale > 0\n");
            return 2;
        }
        return bench_scenes(&so);
    }
    /* the frame figures are CPU seconds: idle OpenMP threads must sleep, not spin */
    if (only && !strcmp(only, "frame") && !getenv("OMP_WAIT_POLICY")) {
        setenv("OMP_WAIT_POLICY", "passive", 1);
        execv("/proc/self/exe", argv);
    }

    /* the falling block first, so its peak memory is its own */
    block_result blk = {0};
    int have_block = !only || !strcmp(only, "block");
    if (have_block && bench_block(block_particles > 0 ? block_particles : quick ? 100000 : 1000000,
                                  frames_given && so.frames > 0 ? so.frames : quick ? 1 : 2,
                                  so.threads, &blk))
        return 1;

    frame_result fr = {0};
    int have_frame = !only || !strcmp(only, "frame");
    if (have_frame && bench_frame(quick ? 100000 : 1000000, &fr)) return 1;

    cube_result cubes[16];
    int nc = 0;
    if (!only || !strcmp(only, "cube")) {
        int sizes[2] = {quick ? 24 : 100, quick ? 16 : 50};
        for (int s = 0; s < 2; s++)
            for (int f = 0; f < 2; f++)
                for (int t = 1; t <= 2; t++) {
                    if ((only_cells && sizes[s] != only_cells) || (only_force >= 0 && f != only_force) ||
                        (so.threads > 0 && t != so.threads))
                        continue;
                    if (bench_cube(sizes[s], (kf_force)f, t, runs, &cubes[nc])) return 1;
                    if (!json)
                        fprintf(stderr,
                                "cube %d³ %s %dT: %.1f ns P2G + %.1f ns G2P + %.1f ns stress, step %.1f ms "
                                "(CPU %.1f ms), %.1f M p-steps/s\n",
                                cubes[nc].cells, cubes[nc].force, t, cubes[nc].p2g_ns, cubes[nc].g2p_ns,
                                cubes[nc].stress_ns, cubes[nc].step_ms, cubes[nc].cpu_ms, cubes[nc].mpsteps);
                    nc++;
                }
    }

    if (json) {
        printf("{\"kerf\":\"%s\",\"precision\":\"%s\",\"runs\":%d,", KERF_VERSION,
               sizeof(kf_real) == 4 ? "float" : "double", runs);
        printf("\"cube\":[");
        for (int i = 0; i < nc; i++)
            printf("%s{\"cells\":%d,\"particles\":%zu,\"force\":\"%s\",\"threads\":%d,\"p2g_ns\":%.2f,"
                   "\"g2p_ns\":%.2f,\"stress_ns\":%.2f,\"transfer_ns\":%.2f,\"transfer_with_stress_ns\":%.2f,"
                   "\"grid_ms\":%.2f,\"step_ms\":%.2f,\"step_cpu_ms\":%.2f,\"mpsteps_per_s\":%.2f}",
                   i ? "," : "", cubes[i].cells, cubes[i].particles, cubes[i].force, cubes[i].threads, cubes[i].p2g_ns,
                   cubes[i].g2p_ns, cubes[i].stress_ns, cubes[i].p2g_ns + cubes[i].g2p_ns,
                   cubes[i].p2g_ns + cubes[i].g2p_ns + cubes[i].stress_ns, cubes[i].grid_ms, cubes[i].step_ms,
                   cubes[i].cpu_ms, cubes[i].mpsteps);
        printf("]");
        if (have_block) {
            printf(",\"falling_block\":{\"particles\":%zu,\"frames\":%d,\"substeps\":%ld,\"seconds\":%.3f,"
                   "\"mpsteps_per_s\":%.2f,\"peak_mb\":%.0f,\"ms_per_substep\":{",
                   blk.particles, blk.frames, blk.substeps, blk.seconds, blk.mpsteps, blk.peak_mb);
            for (int k = 0; k < KF_STAGE_COUNT; k++)
                printf("%s\"%s\":%.3f", k ? "," : "", kf_stage_name((kf_stage)k), blk.ms[k]);
            printf("}}");
        }
        if (have_frame) {
            printf(",\"frame\":{\"particles\":%zu,\"simulate_preview_s\":%.3f,\"simulate_preview_cpu_s\":%.3f,"
                   "\"preview_particles\":%zu,\"preview_substeps\":%ld,\"simulate_frame_s\":%.3f,"
                   "\"simulate_frame_cpu_s\":%.3f,\"frame_substeps\":%ld",
                   fr.particles, fr.sim_wall, fr.sim_cpu, fr.preview_particles, fr.preview_substeps, fr.final_sim_wall,
                   fr.final_sim_cpu, fr.final_substeps);
            for (int q = 0; q < FQ_COUNT; q++) {
                const frame_post_result *r = &fr.q[q];
                printf(",\"%s\":{\"triangles\":%zu,\"active_voxels\":%zu,\"vdb_mb\":%.2f,", frame_qualities[q].name,
                       r->triangles, r->active_voxels, r->vdb_mb);
                for (int k = 0; k < FS_COUNT; k++)
                    printf("\"%s_s\":%.3f,\"%s_cpu_s\":%.3f,", frame_stage_name[k], r->wall[k], frame_stage_name[k],
                           r->cpu[k]);
                printf("\"first_render_s\":%.3f,\"first_render_cpu_s\":%.3f,", r->first_render_wall,
                       r->first_render_cpu);
                printf("\"surface_and_render_s\":%.3f,\"surface_and_render_cpu_s\":%.3f}", frame_total(r->wall),
                       frame_total(r->cpu));
            }
            printf("}");
        }
        printf("}\n");
    } else {
        if (have_frame) {
            printf("frame of %zu particles, seconds wall (CPU), 1920x1080:\n  %-18s", fr.particles, "");
            for (int q = 0; q < FQ_COUNT; q++) printf(" %19s", frame_qualities[q].name);
            printf("\n");
            for (int k = 0; k < FS_COUNT; k++) {
                printf("  %-18s", frame_stage_name[k]);
                for (int q = 0; q < FQ_COUNT; q++) printf("    %7.3f (%7.3f)", fr.q[q].wall[k], fr.q[q].cpu[k]);
                printf("\n");
            }
            printf("  %-18s", "(first render)"); /* a fresh context's: not in the total */
            for (int q = 0; q < FQ_COUNT; q++)
                printf("    %7.3f (%7.3f)", fr.q[q].first_render_wall, fr.q[q].first_render_cpu);
            printf("\n  %-18s", "surface + render");
            for (int q = 0; q < FQ_COUNT; q++)
                printf("    %7.3f (%7.3f)", frame_total(fr.q[q].wall), frame_total(fr.q[q].cpu));
            printf("\n  %-18s", "active voxels");
            for (int q = 0; q < FQ_COUNT; q++) printf(" %19zu", fr.q[q].active_voxels);
            printf("\n  %-18s", "triangles");
            for (int q = 0; q < FQ_COUNT; q++) printf(" %19zu", fr.q[q].triangles);
            printf("\n  %-18s", ".vdb MB");
            for (int q = 0; q < FQ_COUNT; q++) printf(" %19.1f", fr.q[q].vdb_mb);
            printf("\n  %-18s    %7.3f (%7.3f)   [simulating that frame at preview quality: %zu particles, %ld "
                   "substeps]\n",
                   "simulate_preview", fr.sim_wall, fr.sim_cpu, fr.preview_particles, fr.preview_substeps);
            printf("  %-18s    %7.3f (%7.3f)   [simulating the surfaced frame itself: %zu particles, %ld substeps]\n",
                   "simulate_frame", fr.final_sim_wall, fr.final_sim_cpu, fr.particles, fr.final_substeps);
            const char *wp = getenv("OMP_WAIT_POLICY");
            if (!wp || strcasecmp(wp, "passive")) /* OpenMP reads the value case-insensitively */
                printf("  (OMP_WAIT_POLICY is not passive: idle OpenMP threads spin and inflate simulate_preview's CPU "
                       "seconds; run --only frame)\n");
        }
        if (have_block) {
            printf("falling block: %zu particles, %d frames, %ld substeps (%ld with an early P2G), %.2f s (CPU %.2f s, "
                   "%.1f ns per particle-step), %.2f M particle-steps/s, peak %.0f MB\n",
                   blk.particles, blk.frames, blk.substeps, blk.fused, blk.seconds, blk.cpu_seconds,
                   blk.cpu_seconds * 1e9 / ((double)blk.particles * (double)(blk.substeps ? blk.substeps : 1)),
                   blk.mpsteps, blk.peak_mb);
            printf("  ms per substep:");
            for (int k = 0; k < KF_STAGE_COUNT; k++) printf(" %s %.2f", kf_stage_name((kf_stage)k), blk.ms[k]);
            printf("\n");
            if (so.hash) printf("  falling block state hash after %d frame(s): %016llx\n", blk.frames, blk.hash);
        }
        printf("%-6s %-9s %-8s %-2s %8s %8s %8s %8s %8s %9s %10s\n", "cells", "particles", "force", "T", "P2G ns",
               "G2P ns", "P2G+G2P", "stress", "all ns", "step ms", "Mp-step/s");
        for (int i = 0; i < nc; i++)
            printf("%-6d %-9zu %-8s %-2d %8.1f %8.1f %8.1f %8.1f %8.1f %9.1f %10.2f\n", cubes[i].cells,
                   cubes[i].particles, cubes[i].force, cubes[i].threads, cubes[i].p2g_ns, cubes[i].g2p_ns,
                   cubes[i].p2g_ns + cubes[i].g2p_ns, cubes[i].stress_ns,
                   cubes[i].p2g_ns + cubes[i].g2p_ns + cubes[i].stress_ns, cubes[i].step_ms, cubes[i].mpsteps);
    }
    return 0;
}
