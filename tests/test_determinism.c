/* test_determinism.c — the explicit solver gives the same bits for any thread
 * count (grid.h), down to particles sitting on a block face.
 *
 * The regression behind this test: binning computed 1/Δx as (float)(1/Δx)
 * and the transfers as 1/(float)Δx, which differ by an ulp for many Δx
 * (0.016: 62.5 vs 62.499996). A particle within an ulp of a block face then
 * had its stencil base one node outside its owner block, so P2G wrote and
 * G2P read outside the block's node cache: stray mass far from the particle
 * and uninitialised stack values in the velocity, different from run to run
 * and between thread counts (a von Mises block on the floor blew up in about
 * half the 2-thread runs). */
#include <float.h>
#include <math.h>
#include <stdint.h>
#include <stdlib.h>

#include "kt.h"
#include "mpm/model.h"
#include "mesh_util.h"
#include "scene/build.h"
#include "scene_util.h"

#ifdef KF_DOUBLE
#define NEXT_REAL nextafter
#else
#define NEXT_REAL nextafterf
#endif

/* Δx whose two float roundings of 1/Δx differ (see above) */
#define DX 0.016

/* A particle exactly where the two roundings of 1/Δx put its stencil base in
 * different blocks (on a block face along `axis`, mid-block on the others):
 * P2G must give mass only to nodes of its own stencil, |x_i − x_p| < 1.5 Δx
 * per axis (quadratic B-spline support), and all of the particle's mass. */
static void face_particle(int axis) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = DX;
    sd.threads = 1;
    int mat;
    kf_model *m = tu_model(&sd, "cheese", 0, -1, 0, &mat);
    const kf_real ib = kf_model_inv_dx(m), other = 1 / (kf_real)sd.dx;
    if (ib == other) {
        /* double build: both roundings agree, no such position exists */
        printf("  axis %d: 1/dx rounds one way only in this precision, nothing to place\n", axis);
        kf_model_destroy(m);
        return;
    }
    /* search the floats around the block faces 4k + ½ (in nodes), a few ulps
     * up and down: the window where the roundings disagree is about an ulp
     * wide, so not every face has a float inside it */
    kf_real z = 0;
    int found = 0;
    for (int face = 4; face < 4 * 64 && !found; face += 4) {
        const kf_real c = (kf_real)((face + 0.5) * sd.dx);
        kf_real up = c, down = c;
        for (int k = 0; k < 8 && !found; k++) {
            kf_real t[2] = {up, down};
            for (int u = 0; u < 2 && !found; u++)
                if (kf_block_of(kf_base_node(t[u], ib, 0)) != kf_block_of(kf_base_node(t[u], other, 0)))
                    z = t[u], found = 1;
            up = NEXT_REAL(up, 1), down = NEXT_REAL(down, 0);
        }
    }
    printf("  axis %d: particle at %.9g m, base node %d (1/dx = %.9g) or %d (1/dx = %.9g)\n", axis, (double)z,
           kf_base_node(z, ib, 0), (double)ib, kf_base_node(z, other, 0), (double)other);
    KT_CHECK(found, "a position within 8 ulps of a block face where the roundings disagree");
    double x[3];
    for (int a = 0; a < 3; a++) x[a] = a == axis ? (double)z : (4 * 3 + 2.3) * sd.dx; /* base node 13: mid-block */

    kf_state *s = kf_state_create(m);
    kf_state_add_particles(s, m, 1, x, NULL, NULL, mat, 1e-6);
    size_t bad;
    KT_CHECK(kf_grid_bin(&s->g, &s->p, ib, 0, 1, &bad) == 0, "binning");
    const double mp = s->p.mass[0], xp[3] = {s->p.x[0][0], s->p.x[1][0], s->p.x[2][0]};
    kf_p2g(m, s, 1e-4, NULL);
    double M = 0, far = 0;
    long stray = 0;
    for (size_t b = 0; b < s->g.nblocks; b++)
        for (int l = 0; l < KF_BLOCK_NODES; l++) {
            double w = s->g.node[b * KF_BLOCK_NODES + l][3], xi[3], d = 0;
            if (w == 0) continue;
            tu_node_pos(&s->g, b, l, sd.dx, xi);
            for (int a = 0; a < 3; a++) d = fmax(d, fabs(xi[a] - xp[a]) / sd.dx);
            M += w;
            if (d >= 1.5) stray++, far = fmax(far, d);
        }
    KT_CHECK(stray == 0, "axis %d: %ld node(s) outside the particle's support got mass, up to %.2f dx away", axis,
             stray, far);
    /* 27 float products summed: relative round-off */
    KT_NEAR(M / mp, 1.0, 10 * FLT_EPSILON, "the particle's mass, all on its stencil");
    kf_state_destroy(s);
    kf_model_destroy(m);
}

static void face_particle_y(void) { face_particle(1); }
static void face_particle_z(void) { face_particle(2); }

/* The field case: a von Mises ("cheese") block resting on the floor of a
 * closed box, walls with Coulomb friction, Δx = 0.016: the state hash after
 * each substep must be the same with 1 and 2 threads and from run to run, and
 * every substep free of trouble. A guard for thread-count determinism in
 * general; the face-particle cases above are what catches the 1/Δx mismatch
 * every time (here a particle reaches a face's ulp-wide window only now and
 * then, and the stray read only shows when the stack garbage is large). */
static int cheese_run(int threads, int steps, uint64_t *hash) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = DX;
    sd.walls = 1;
    sd.wall_boundary = KF_BOUNDARY_SEPARATE;
    sd.wall_friction = 0.5;
    for (int a = 0; a < 3; a++) sd.domain_min[a] = 0;
    sd.domain_max[0] = 1, sd.domain_max[1] = 0.5, sd.domain_max[2] = 0.6;
    sd.threads = threads;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    KT_CHECK(m != NULL, "%s", err);
    if (!m) return 0;
    kf_material mat;
    kf_material_preset("cheese", &mat);
    mat.density = 400, mat.E = 4e5, mat.nu = 0.3, mat.yield_stress = 5000;
    int id = kf_model_add_material(m, &mat, err, sizeof err);
    KT_CHECK(id >= 0, "%s", err);
    kf_state *s = kf_state_create(m);
    /* on the floor, with a sideways push so material slides against friction */
    double lo[3] = {0.35, 0.0, 0.2}, hi[3] = {0.65, 0.1, 0.4}, v[3] = {0.3, 0, -0.2};
    kf_state_fill_box(s, m, lo, hi, id, v, 2, 1);
    int done = 0;
    for (; done < steps; done++) {
        kf_trouble tr;
        if (kf_step(m, s, kf_stable_dt(m, s, sd.cfl), NULL, &tr)) {
            fprintf(stderr, "  %d threads: trouble at substep %d: %s (%g), particle %u\n", threads, done, tr.what,
                    tr.value, tr.particle);
            break;
        }
        hash[done] = kf_state_hash(s);
    }
    kf_state_destroy(s);
    kf_model_destroy(m);
    return done;
}

static void cheese_threads_agree(void) {
    enum { STEPS = 240 };
    uint64_t *h1 = calloc(STEPS, sizeof *h1), *h2 = calloc(STEPS, sizeof *h2), *h2b = calloc(STEPS, sizeof *h2b);
    int n1 = cheese_run(1, STEPS, h1), n2 = cheese_run(2, STEPS, h2), n2b = cheese_run(2, STEPS, h2b);
    KT_CHECK(n1 == STEPS && n2 == STEPS && n2b == STEPS, "every substep without trouble (%d, %d, %d of %d)", n1, n2,
             n2b, STEPS);
    int first12 = -1, first22 = -1;
    for (int k = 0; k < STEPS; k++) {
        if (first12 < 0 && h1[k] != h2[k]) first12 = k;
        if (first22 < 0 && h2[k] != h2b[k]) first22 = k;
    }
    KT_CHECK(first12 < 0, "1 and 2 threads agree after every substep (first difference at substep %d)", first12);
    KT_CHECK(first22 < 0, "two 2-thread runs agree after every substep (first difference at substep %d)", first22);
    printf("  %d substeps: 1-thread, 2-thread and 2-thread hashes %s (last %016llx)\n", STEPS,
           first12 < 0 && first22 < 0 ? "identical" : "differ", (unsigned long long)h1[STEPS - 1]);
    free(h1), free(h2), free(h2b);
}

/* The rigid/CPIC path, stepped with 1, 2 and 3 threads: the state hash
 * (every particle plane, the CPIC colours, every rigid body's pose and
 * velocity) must be the same bits after each of 6 frames.
 *   cut:    tests/cli/cut.yaml, a thin kinematic plate cutting jello (the CDF,
 *           particle colours, compatible transfers; checked: particles coloured)
 *   bodies: tests/shots/rigids.yaml, two dynamic bodies on a pin and a hinge
 *           (MuJoCo), a thin kinematic cross and a static wall over goo
 *           (checked: the dynamic box moved) */
typedef struct rigid_run {
    int done;
    uint64_t hash[6];
    size_t coloured;
    double box_drop; /* m the dynamic box (body 1 of rigids.yaml) fell */
} rigid_run;

static rigid_run rigids_run(const char *shot_rel, const char *const *sets, int nsets, int threads) {
    rigid_run r = {0};
    kf_diag diag;
    kf_diag_init(&diag);
    kf_shot *shot = kf_shot_load(tu_repo_path(shot_rel), sets, nsets, NULL, NULL, &diag);
    kf_scene sc;
    int ok = shot && kf_scene_from_shot(shot, threads, &sc, NULL, &diag) == 0;
    if (!ok) kf_diag_print(stderr, &diag);
    KT_CHECK(ok, "%s builds with %d threads", shot_rel, threads);
    kf_diag_free(&diag);
    char msg[256];
    double y0 = ok && kf_model_rigid_count(sc.model) > 1 ? kf_state_rigid(sc.state, 1).com[1] : 0;
    for (; ok && r.done < 6; r.done++) {
        if (kf_advance(sc.model, sc.state, 1.0 / shot->fps, NULL, msg, sizeof msg)) {
            KT_CHECK(0, "%s, %d threads, frame %d: %s", shot_rel, threads, r.done + 1, msg);
            break;
        }
        r.hash[r.done] = kf_state_hash(sc.state);
    }
    if (ok) {
        for (size_t i = 0; i < sc.state->p.n; i++) r.coloured += sc.state->p.colour[i] != 0;
        if (kf_model_rigid_count(sc.model) > 1) r.box_drop = y0 - kf_state_rigid(sc.state, 1).com[1];
        kf_scene_free(&sc);
    }
    kf_shot_free(shot);
    return r;
}

static void threads_agree_on(const char *shot_rel, const char *const *sets, int nsets, rigid_run *one) {
    rigid_run r[3];
    for (int t = 0; t < 3; t++) r[t] = rigids_run(shot_rel, sets, nsets, t + 1);
    for (int t = 1; t < 3; t++) {
        int first = -1;
        for (int f = 0; f < 6 && first < 0; f++)
            if (f >= r[0].done || f >= r[t].done || r[0].hash[f] != r[t].hash[f]) first = f;
        KT_CHECK(first < 0,
                 "%s: 1 and %d threads give the same bits after every frame (first difference after "
                 "frame %d)",
                 shot_rel, t + 1, first + 1);
    }
    printf("  %s, 6 frames: state hash %016llx with 1, 2 and 3 threads; %zu particles coloured; box fell %.3f m\n",
           shot_rel, (unsigned long long)r[0].hash[5], r[0].coloured, r[0].box_drop);
    *one = r[0];
}

static void cpic_cut_threads_agree(void) {
    rigid_run r;
    threads_agree_on("tests/cli/cut.yaml", NULL, 0, &r);
    /* measured 1035 of 2304: the plate is in the jello from frame 1002 */
    KT_CHECK(r.coloured > 500, "the cut is under way: particles by the plate carry CPIC colours (%zu)", r.coloured);
}

static void rigid_bodies_threads_agree(void) {
    rigid_run r;
    const char *sets[] = {"sim.ppc=8"}; /* 1000 goo particles: several blocks for every thread */
    threads_agree_on("tests/shots/rigids.yaml", sets, 1, &r);
    /* from 0.7 m under gravity, pinned to the lid by a damped hinge: it falls (measured 0.120 m in 6 frames) */
    KT_CHECK(r.box_drop > 0.05, "the dynamic box moved (fell %.3f m)", r.box_drop);
}

int main(int argc, char **argv) {
    KT_RUN(face_particle_y, argc, argv);
    KT_RUN(face_particle_z, argc, argv);
    KT_RUN(cheese_threads_agree, argc, argv);
    KT_RUN(cpic_cut_threads_agree, argc, argv);
    KT_RUN(rigid_bodies_threads_agree, argc, argv);
    return KT_EXIT();
}
