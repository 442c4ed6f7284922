/* test_dynamics.c — whole substeps: free fall (V1), angular momentum of a
 * spinning cube (V3) with PIC as the negative control, run-to-run and
 * thread-count determinism, sparse-grid cost, and recovery from numerical
 * trouble. */
#include <float.h>
#include <omp.h>

#include "kt.h"
#include "mpm/model.h"
#include "scene/builtin.h"
#include "scene_util.h"

#ifdef KF_DOUBLE
#define ROUNDOFF DBL_EPSILON
#else
#define ROUNDOFF FLT_EPSILON
#endif

/* V1: a stress-free block with no walls falls exactly as symplectic Euler
 * with x += Δt v^{n+1} predicts: x_n = x0 + v0 t + ½ g t² + ½ g Δt t. */
static void free_fall(void) {
    for (int k = 0; k < 2; k++)
        for (int f = 0; f < 2; f++) {
            kf_sim_def sd = kf_default_sim_def();
            sd.dx = 0.05;
            sd.kernel = (kf_kernel)k;
            sd.force = (kf_force)f;
            int mat;
            kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
            kf_state *s = kf_state_create(m);
            double lo[3] = {0.2, 0.5, 0.2}, hi[3] = {0.4, 0.7, 0.4}, v0[3] = {0.5, 1.0, -0.25};
            kf_state_fill_box(s, m, lo, hi, mat, v0, 2, 0);
            kf_particles_view pv = kf_state_particles(s);
            size_t n = pv.n;
            double *x0 = malloc(sizeof(double) * 3 * n);
            for (size_t i = 0; i < n; i++)
                for (int a = 0; a < 3; a++) x0[3 * pv.id[i] + a] = pv.x[a][i];
            const double dt = 1e-3;
            const int steps = 200;
            for (int st = 0; st < steps; st++) kf_step(m, s, dt, NULL, NULL);
            pv = kf_state_particles(s);
            double t = steps * dt, errx = 0, errC = 0, errF = 0, xmax = 0;
            for (size_t i = 0; i < n; i++) {
                for (int a = 0; a < 3; a++) {
                    double g = sd.gravity[a];
                    double want = x0[3 * pv.id[i] + a] + v0[a] * t + 0.5 * g * t * t + 0.5 * g * dt * t;
                    errx = fmax(errx, fabs(pv.x[a][i] - want));
                    xmax = fmax(xmax, fabs(want));
                }
                for (int e = 0; e < 9; e++) {
                    errC = fmax(errC, fabs(pv.C[e][i]));
                    errF = fmax(errF, fabs(pv.F[e][i] - (e % 4 == 0)));
                }
            }
            /* V1: 1e-5 relative in f32 (1e-12 in double) */
            KT_NEAR(errx / xmax, 0, sizeof(kf_real) == 4 ? 1e-5 : 1e-12, "V1 free fall, relative position error");
            /* uniform grid velocity: C is round-off of |v|/Δx, F drifts by steps·dt·C */
            double vmax = 2.5;
            KT_NEAR(errC, 0, 100 * ROUNDOFF * vmax / sd.dx, "C_p = 0 up to round-off of a uniform field");
            KT_NEAR(errF, 0, 100 * ROUNDOFF, "F = I up to round-off");
            free(x0);
            kf_state_destroy(s);
            kf_model_destroy(m);
        }
}

/* V3: a spinning elastic cube with no walls and no gravity keeps its angular
 * momentum (APIC conserves it exactly, up to round-off); PIC loses it. */
static double spin_drift(kf_transfer transfer, kf_force force, int steps) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.05;
    sd.gravity[1] = 0;
    sd.transfer = transfer;
    sd.force = force;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.3, 0.3, 0.3}, hi[3] = {0.7, 0.7, 0.7};
    kf_state_fill_box(s, m, lo, hi, mat, NULL, 2, 0);
    /* rigid rotation about an oblique axis through the centre: ω = (1, 2, 3) rad/s */
    kf_particles_view pv = kf_state_particles(s);
    const double w[3] = {1, 2, 3};
    for (size_t i = 0; i < pv.n; i++) {
        double r[3] = {pv.x[0][i] - 0.5, pv.x[1][i] - 0.5, pv.x[2][i] - 0.5};
        pv.v[0][i] = (kf_real)(w[1] * r[2] - w[2] * r[1]);
        pv.v[1][i] = (kf_real)(w[2] * r[0] - w[0] * r[2]);
        pv.v[2][i] = (kf_real)(w[0] * r[1] - w[1] * r[0]);
        /* C = skew(ω) so the affine part carries the rotation too */
        kf_real W[9] = {
            0, (kf_real)-w[2], (kf_real)w[1], (kf_real)w[2], 0, (kf_real)-w[0], (kf_real)-w[1], (kf_real)w[0], 0};
        for (int e = 0; e < 9; e++) pv.C[e][i] = transfer == KF_TRANSFER_APIC ? W[e] : 0;
    }
    kf_energy e0 = kf_state_energy(m, s);
    double dt = 0.5 * kf_stable_dt(m, s, 1.0);
    for (int st = 0; st < steps; st++) kf_step(m, s, dt, NULL, NULL);
    kf_energy e1 = kf_state_energy(m, s);
    double L0 = sqrt(e0.angular_momentum[0] * e0.angular_momentum[0] + e0.angular_momentum[1] * e0.angular_momentum[1] +
                     e0.angular_momentum[2] * e0.angular_momentum[2]);
    double d = 0;
    for (int a = 0; a < 3; a++) d += pow(e1.angular_momentum[a] - e0.angular_momentum[a], 2);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return sqrt(d) / L0;
}

static void angular_momentum(void) {
    for (int f = 0; f < 2; f++) {
        double apic = spin_drift(KF_TRANSFER_APIC, (kf_force)f, 1000);
        /* V3: relative drift <= 1e-5 in f32 after 1000 steps */
        KT_NEAR(apic, 0, sizeof(kf_real) == 4 ? 1e-5 : 1e-10, "V3 APIC angular momentum drift over 1000 steps");
        double pic = spin_drift(KF_TRANSFER_PIC, (kf_force)f, 200);
        /* negative control: PIC's dissipation of rotation is O(1) over 200 steps */
        KT_CHECK(pic > 1e-2, "PIC should lose angular momentum, drift %.3g", pic);
    }
}

/* Same scene, same thread count: identical bits. Different thread counts:
 * identical too, because each node sums its contributions in colour order
 * whatever the schedule (grid.h). */
static uint64_t demo_hash(int threads, int steps) {
    char err[256];
    kf_scene sc;
    KT_CHECK(kf_scene_demo(&sc, 24, err, sizeof err) == 0, "%s", err);
    /* the demo model uses all threads; rebuild it with the requested count */
    kf_model *m = sc.model;
    m->nthreads = threads;
    for (int i = 0; i < steps; i++) kf_step(m, sc.state, 2e-4, NULL, NULL);
    uint64_t h = kf_state_hash(sc.state);
    kf_scene_free(&sc);
    return h;
}

static void determinism(void) {
    uint64_t a = demo_hash(2, 40), b = demo_hash(2, 40), c = demo_hash(1, 40);
    KT_CHECK(a == b, "run to run: %llx vs %llx", (unsigned long long)a, (unsigned long long)b);
    KT_CHECK(a == c, "1 vs 2 threads: %llx vs %llx", (unsigned long long)a, (unsigned long long)c);
    KT_CHECK(a != 0, "hash computed");
}

/* A small object far from the origin in an unbounded domain costs blocks in
 * proportion to the object, not to the distance. */
static void sparse_grid(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.01;
    int mat;
    kf_model *m = tu_model(&sd, "rubber", 0, -1, 0, &mat);
    kf_state *s = kf_state_create(m);
    double lo[3] = {3000, -2000, 1000}, hi[3] = {3000.16, -1999.84, 1000.16};
    double lo2[3] = {-4000, 5000, -3000}, hi2[3] = {-3999.84, 5000.16, -2999.84};
    kf_state_fill_box(s, m, lo, hi, mat, NULL, 2, 0);
    kf_state_fill_box(s, m, lo2, hi2, mat, NULL, 2, 0);
    KT_CHECK(kf_step(m, s, 1e-5, NULL, NULL) == 0, "step far from the origin");
    /* each 16-cell cube spans at most 5 owner blocks per axis, plus one layer of
     * upper neighbours: <= 2 * 6³ blocks, whatever the 10 km between them */
    KT_CHECK(s->g.nblocks <= 2 * 216, "blocks %zu for two small cubes", s->g.nblocks);
    KT_CHECK(s->g.nowner >= 2 * 64, "owners %zu", s->g.nowner);
    kf_state_destroy(s);
    kf_model_destroy(m);
}

/* Too large a CFL number blows up; kf_advance detects it, restarts the
 * interval at half the CFL number and finishes with a finite state. */
static void recovery_from_blowup(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.05;
    sd.cfl = 1.9; /* beyond the quadratic kernel's limit (~1.1) */
    sd.gravity[1] = 0;
    sd.max_retries = 4;
    int mat;
    kf_model *m = tu_model(&sd, "rubber", 0, -1, 0, &mat);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.3, 0.3, 0.3}, hi[3] = {0.7, 0.7, 0.7};
    kf_state_fill_box(s, m, lo, hi, mat, NULL, 2, 0);
    kf_particles_view pv = kf_state_particles(s);
    for (size_t i = 0; i < pv.n; i++)
        for (int e = 0; e < 9; e++) pv.F[e][i] = (kf_real)((e % 4 == 0) * 1.05);
    kf_step_stats st = {0};
    char msg[512];
    int rc = kf_advance(m, s, 0.02, &st, msg, sizeof msg);
    KT_CHECK(rc == 0, "advance failed: %s", msg);
    KT_CHECK(st.retries >= 1, "expected at least one retry, got %d", st.retries);
    KT_CHECK(st.warnings == st.retries, "each retry is a counted warning");
    KT_NEAR(kf_state_time(s), 0.02, 1e-12, "the interval ends exactly where asked");
    kf_energy e = kf_state_energy(m, s);
    KT_CHECK(isfinite(e.kinetic) && isfinite(e.elastic), "finite energy after recovery");
    kf_state_destroy(s);
    kf_model_destroy(m);
}

/* The CFL-violation retry: a block gliding at 2 m/s (no gravity, no walls,
 * stress free) under a fixed step of 1.6 cells' travel (0.04 s at Δx = 0.05)
 * is "CFL violated" at its first substep; kf_advance goes back to the
 * interval start and retries at 0.02 s (0.8 cells), which passes. The
 * retried run must end on the bits of a run made at 0.02 s from the start
 * (the snapshot restores everything), and with no retries left it fails,
 * naming the violation and the cells moved. */
static kf_state *glide_state_opt(double dt_fixed, int retries, int retry_fixed, kf_model **mp);
static kf_state *glide_state(double dt_fixed, int retries, kf_model **mp) {
    /* a fixed step is halved only where the shot opts in */
    return glide_state_opt(dt_fixed, retries, retries > 0, mp);
}

static kf_state *glide_state_opt(double dt_fixed, int retries, int retry_fixed, kf_model **mp) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.05;
    sd.gravity[1] = 0;
    sd.dt_fixed = dt_fixed;
    sd.max_retries = retries;
    sd.retry_fixed = retry_fixed;
    sd.threads = 1;
    int mat;
    *mp = tu_model(&sd, "jello", 0, -1, 0, &mat);
    kf_state *s = kf_state_create(*mp);
    double lo[3] = {0.3, 0.3, 0.3}, hi[3] = {0.5, 0.5, 0.5}, v[3] = {2, 0, 0};
    kf_state_fill_box(s, *mp, lo, hi, mat, v, 2, 0);
    return s;
}

static void cfl_violation_retried(void) {
    kf_model *m, *mr;
    kf_state *s = glide_state(0.04, 4, &m), *ref = glide_state(0.02, 0, &mr);
    kf_trouble tr = {0};
    /* the violation itself, at the first substep */
    kf_model *m1;
    kf_state *s1 = glide_state(0.04, 0, &m1);
    KT_CHECK(kf_step(m1, s1, 0.04, NULL, &tr) == 1, "a 1.6-cell substep is trouble");
    KT_CHECK(strstr(tr.what, "CFL violated") != NULL, "the trouble is the CFL violation: '%s'", tr.what);
    /* v dt / dx = 2 x 0.04 / 0.05; velocities are float */
    KT_NEAR(tr.value, 1.6, 1e-5, "cells moved in the substep: |v| dt / dx");
    kf_step_stats st = {0}, st_ref = {0};
    char msg[512] = "";
    int rc = kf_advance(m, s, 0.08, &st, msg, sizeof msg);
    KT_CHECK(rc == 0, "the retry at half the step recovers: %s", msg);
    KT_CHECK(st.retries == 1, "one retry (1.6 -> 0.8 cells), got %d", st.retries);
    KT_NEAR(st.fixed_halved, 0.02, 1e-15, "the retry ran at half of sim.dt_fixed, and the stats say so");
    KT_CHECK(kf_advance(mr, ref, 0.08, &st_ref, msg, sizeof msg) == 0 && st_ref.retries == 0, "reference: %s", msg);
    KT_CHECK(st.substeps == st_ref.substeps + 1,
             "the retried interval: the failed 0.04 s substep, then the "
             "reference's %ld, got %ld",
             st_ref.substeps, st.substeps);
    KT_CHECK(kf_state_hash(s) == kf_state_hash(ref),
             "the retried interval ends on the bits of a run at 0.02 s "
             "from the start (%016llx vs %016llx)",
             (unsigned long long)kf_state_hash(s), (unsigned long long)kf_state_hash(ref));
    KT_NEAR(kf_state_time(s), 0.08, 1e-12, "the interval ends where asked");
    /* no retries allowed: the run stops and says why */
    rc = kf_advance(m1, s1, 0.08, NULL, msg, sizeof msg);
    KT_CHECK(rc == 1, "with sim.max_retries = 0 the violation stops the run");
    KT_CHECK(strstr(msg, "numerical trouble: CFL violated (cells moved per substep) (value 1.6") != NULL, "message: %s",
             msg);
    /* sim.dt_fixed means fixed: retries allowed but not opted in
     * for the fixed step, the frame fails at once, naming the step */
    {
        kf_model *mf;
        kf_state *sf = glide_state_opt(0.04, 4, 0, &mf);
        kf_step_stats sst = {0};
        rc = kf_advance(mf, sf, 0.08, &sst, msg, sizeof msg);
        KT_CHECK(rc == 1, "a fixed step that fails is not silently halved");
        KT_CHECK(sst.substeps == 1, "one substep tried, no retry (%ld)", sst.substeps);
        KT_CHECK(strstr(msg, "at the fixed step sim.dt_fixed = 0.04 s, which had reached CFL number ") != NULL,
                 "message names the fixed step and the CFL number it reached: %s", msg);
        KT_CHECK(strstr(msg, "(not retried: a fixed step is never changed; sim.retry_fixed: true lets a retry halve "
                             "it)") != NULL,
                 "message says it was not retried: %s", msg);
        kf_state_destroy(sf);
        kf_model_destroy(mf);
    }
    kf_state_destroy(s), kf_state_destroy(ref), kf_state_destroy(s1);
    kf_model_destroy(m), kf_model_destroy(mr), kf_model_destroy(m1);
}

/* A fault that retries cannot cure (a NaN already in the state) stops the run
 * with a message naming the trouble, the particle and its material. */
static void persistent_fault_reported(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.05;
    sd.max_retries = 2;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.3, 0.3, 0.3}, hi[3] = {0.5, 0.5, 0.5};
    kf_state_fill_box(s, m, lo, hi, mat, NULL, 2, 0);
    kf_particles_view pv = kf_state_particles(s);
    size_t victim = pv.n / 2;
    uint32_t victim_id = pv.id[victim];
    pv.F[0][victim] = NAN;
    kf_step_stats st = {0};
    char msg[512], want[64];
    int rc = kf_advance(m, s, 0.01, &st, msg, sizeof msg);
    KT_CHECK(rc == 1, "a NaN in F must stop the run");
    KT_CHECK(st.retries == 3, "initial try + 2 retries, got %d retries", st.retries);
    snprintf(want, sizeof want, "particle %u", victim_id);
    KT_CHECK(strstr(msg, want) != NULL, "message names the particle: %s", msg);
    KT_CHECK(strstr(msg, "'jello'") != NULL, "message names the material: %s", msg);
    KT_CHECK(strstr(msg, "NaN") != NULL, "message names the trouble: %s", msg);
    kf_state_destroy(s);
    kf_model_destroy(m);
}

int main(int argc, char **argv) {
    KT_RUN(free_fall, argc, argv);
    KT_RUN(angular_momentum, argc, argv);
    KT_RUN(determinism, argc, argv);
    KT_RUN(sparse_grid, argc, argv);
    KT_RUN(recovery_from_blowup, argc, argv);
    KT_RUN(persistent_fault_reported, argc, argv);
    KT_RUN(cfl_violation_retried, argc, argv);
    return KT_EXIT();
}
