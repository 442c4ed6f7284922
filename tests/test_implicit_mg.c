/* test_implicit_mg.c — the multigrid preconditioner of the implicit solve
 * (implicit/mg_build.c, implicit/mg_cycle.c).
 *
 * CG needs a symmetric positive-definite preconditioner: the cycle is
 * checked for x·By = y·Bx to round-off and x·Bx > 0 on random vectors that
 * satisfy the boundary projection (slip floor and sticky side walls, so
 * the coarse levels carry constraints too). Newton–CG with it reaches the
 * same minimiser as with Jacobi, and on the evidence cantilever (E = 1e6,
 * tools/evidence/implicit_sweep.c) its CG iterations per Newton iteration
 * at 20x the explicit step stay under a stated bound, and grow less from
 * 5x to 20x than Jacobi's do; at 1200x on a stiff one (E = 1e9, 4 steps a
 * frame) Newton and CG stay under stated bounds. Implicit substeps are
 * bit-identical on 1 and 2 threads. */
#include <float.h>
#include <stdlib.h>

#include "kt.h"
#include "implicit/implicit.h"
#include "scene_util.h"
#include "implicit_util.h"

/* a jello block resting on a slip floor against sticky side walls at
 * x = 0, with a random smooth deformation and velocity */
static scene floor_block_threads(kf_precond pc, int threads) {
    scene sc;
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.05;
    sd.integrator = KF_INTEGRATOR_IMPLICIT;
    sd.precond = pc;
    sd.walls = 1;
    sd.wall_boundary = KF_BOUNDARY_SLIP;
    sd.threads = threads;
    sc.m = tu_model(&sd, "jello", 1e5, 0.3, 1000, &sc.mat);
    sc.s = kf_state_create(sc.m);
    double lo[3] = {0.02, 0.01, 0.3}, hi[3] = {0.5, 0.2, 0.55};
    kf_state_fill_box(sc.s, sc.m, lo, hi, sc.mat, NULL, 2, 3);
    kf_particles_view pv = kf_state_particles(sc.s);
    unsigned seed = 17;
    for (size_t i = 0; i < pv.n; i++) {
        for (int k = 0; k < 9; k++) pv.F[k][i] = (kf_real)((k % 4 == 0) + 0.1 * urand(&seed));
        for (int a = 0; a < 3; a++) pv.v[a][i] = (kf_real)(0.3 * urand(&seed));
    }
    return sc;
}

static scene floor_block(kf_precond pc) { return floor_block_threads(pc, 2); }

/* the workspace of a substep: stencils, constraints, linearised at v* */
static void workspace(scene *sc, double dt, kf_implicit *w) {
    workspace_create(sc, dt, w);
    KT_CHECK(kf_imp_constraints(w, w->v) == 0, "constraints");
    KT_CHECK(isfinite(kf_imp_linearize(w, w->v, 1)), "linearised");
}

/* the operator's diagonal as the solve forms it, then the levels */
static void build_mg(kf_implicit *w) {
    for (size_t i = 0; i < w->nnode; i++)
        for (int a = 0; a < 3; a++) w->diag[KF_IMP_NV * i + a] = w->mass[i];
    kf_imp_scatter_diag(w, w->diag);
    KT_CHECK(kf_imp_mg_create(w) == 0, "levels built");
    kf_imp_mg_refresh(w);
}

/* a random admissible vector on the nodes that carry mass */
static void random_field(const kf_implicit *w, double *x, unsigned *seed) {
    for (size_t i = 0; i < w->nnode; i++)
        for (int a = 0; a < KF_IMP_NV; a++) x[KF_IMP_NV * i + a] = w->mass[i] > 0 && a < 3 ? urand(seed) : 0.0;
    kf_imp_project(w, x);
}

/* x·By = y·Bx to round-off and x·Bx > 0, at a large step (stiffness far
 * above the mass, where the coarse levels matter), with one quadrature
 * point per coarse cell (dt 2e-2) and with eight (dt 0.2: the stiffness
 * outweighs the mass past implicit/mg_build.c's switch) */
static void vcycle_symmetric_definite_at(double dt, int full_quadrature) {
    scene sc = floor_block(KF_PRECOND_MULTIGRID);
    kf_implicit w;
    workspace(&sc, dt, &w);
    build_mg(&w);
    KT_CHECK(w.mg->full_quadrature == full_quadrature, "dt %g: %s quadrature on the coarse levels", dt,
             full_quadrature ? "full" : "one-point");
    int nlev = kf_imp_mg_levels(&w);
    size_t ncon = 0;
    for (int l = 1; l < nlev; l++) ncon += w.mg->lev[l].ncon;
    printf("  %d levels (%zu, %zu, ... nodes), %zu fine and %zu coarse constrained nodes\n", nlev,
           kf_imp_mg_nodes(&w, 0), kf_imp_mg_nodes(&w, 1), w.ncon, ncon);
    KT_CHECK(nlev >= 3, "a block of ~700 massive nodes coarsens at least twice: %d levels", nlev);
    KT_CHECK(w.ncon > 0 && ncon > 0, "the walls constrain fine (%zu) and coarse (%zu) nodes", w.ncon, ncon);
    size_t n4 = KF_IMP_NV * w.nnode;
    double *x = malloc(n4 * sizeof *x), *y = malloc(n4 * sizeof *y), *Bx = malloc(n4 * sizeof *Bx),
           *By = malloc(n4 * sizeof *By), *Px = malloc(n4 * sizeof *Px);
    unsigned seed = 3;
    double asym = 0, qmin = INFINITY, leak = 0;
    for (int t = 0; t < 20; t++) {
        random_field(&w, x, &seed);
        random_field(&w, y, &seed);
        kf_imp_mg_apply(&w, x, Bx);
        kf_imp_mg_apply(&w, y, By);
        double xBy = kf_imp_dot(&w, x, By), yBx = kf_imp_dot(&w, y, Bx);
        double nx = sqrt(kf_imp_dot(&w, x, x)), nBy = sqrt(kf_imp_dot(&w, By, By));
        asym = fmax(asym, fabs(xBy - yBx) / (nx * nBy));
        /* x·Bx relative to |x| |Bx|: a cosine, > 0 for a definite B */
        qmin = fmin(qmin, kf_imp_dot(&w, x, Bx) / (nx * sqrt(kf_imp_dot(&w, Bx, Bx))));
        /* B's output satisfies the constraints: projecting it changes nothing */
        memcpy(Px, Bx, n4 * sizeof *Px);
        kf_imp_project(&w, Px);
        for (size_t k = 0; k < n4; k++) leak = fmax(leak, fabs(Px[k] - Bx[k]));
    }
    printf("  symmetry %.3g (relative), min x.Bx / |x||Bx| %.3g, projection leak %.3g\n", asym, qmin, leak);
    /* a few hundred terms per entry summed in double: 1e-12 is ~1e4 ulps */
    KT_NEAR(asym, 0, 1e-12, "x.By = y.Bx: the cycle is symmetric");
    KT_CHECK(qmin > 0, "x.Bx > 0 on every random admissible vector: %g", qmin);
    KT_NEAR(leak, 0, 0, "B r lies in the free directions");
    free(x), free(y), free(Bx), free(By), free(Px);
    kf_imp_free(&w);
    scene_free(&sc);
}

static void vcycle_symmetric_definite(void) {
    vcycle_symmetric_definite_at(2e-2, 0);
    vcycle_symmetric_definite_at(0.2, 1);
}

/* Newton–CG with either preconditioner, solved tightly from the same
 * state, reaches the same grid velocities */
static void same_solution_as_jacobi(void) {
    double *v[2] = {NULL, NULL};
    size_t n4 = 0;
    int cg[2] = {0, 0};
    double vmax = 0;
    for (int k = 0; k < 2; k++) {
        scene sc = floor_block(k ? KF_PRECOND_JACOBI : KF_PRECOND_MULTIGRID);
        sc.m->sim.newton_tol = 1e-10;
        sc.m->sim.krylov_tol = 1e-10;
        sc.m->sim.krylov_max = 2000;
        sc.m->sim.newton_max = 50;
        kf_implicit w;
        workspace(&sc, 1e-2, &w);
        KT_CHECK(kf_imp_solve(&w, w.v) == 0, "solve");
        KT_CHECK(w.converged, "converged to 1e-10: residual %g", w.residual);
        n4 = KF_IMP_NV * w.nnode;
        v[k] = malloc(n4 * sizeof(double));
        memcpy(v[k], w.v, n4 * sizeof(double));
        cg[k] = w.krylov_iterations;
        for (size_t i = 0; i < n4; i++) vmax = fmax(vmax, fabs(w.v[i]));
        kf_imp_free(&w);
        scene_free(&sc);
    }
    double d = 0;
    for (size_t i = 0; i < n4; i++) d = fmax(d, fabs(v[0][i] - v[1][i]));
    printf("  max |v_mg - v_jacobi| %.3g m/s of max |v| %.3g m/s; CG iterations %d (multigrid) vs %d (Jacobi)\n", d,
           vmax, cg[0], cg[1]);
    /* both residuals are below 1e-10 of the momentum scale; the minimiser is
     * unique (positive-definite Hessian), so they agree to ~1e-9 of |v| */
    KT_NEAR(d / vmax, 0, 1e-8, "the same minimiser");
    free(v[0]), free(v[1]);
}

/* the evidence cantilever (implicit_sweep.c) of stiffness E for the given
 * time at a fixed step dt; fills the step statistics */
static void cantilever_run(kf_precond pc, double E, double dt, double duration, kf_step_stats *st) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.025;
    sd.walls = 1;
    sd.wall_boundary = KF_BOUNDARY_STICKY;
    sd.threads = 2;
    sd.max_retries = 0;
    sd.integrator = KF_INTEGRATOR_IMPLICIT;
    sd.precond = pc;
    const double nu = 0.3;
    sd.dt_fixed = dt;
    int mat;
    kf_model *m = tu_model(&sd, "jello", E, nu, 1000, &mat);
    kf_state *s = kf_state_create(m);
    double lo[3] = {-0.08, 0.46, 0.44}, hi[3] = {0.4, 0.54, 0.56};
    kf_state_fill_box(s, m, lo, hi, mat, NULL, 2, 0);
    char msg[512];
    int rc = kf_advance(m, s, duration, st, msg, sizeof msg);
    KT_CHECK(rc == 0, "frame: %s", msg);
    kf_state_destroy(s);
    kf_model_destroy(m);
}

/* the cantilever at E = 1e6 for half a frame at k times the explicit step;
 * returns CG iterations per Newton iteration */
static double cantilever_cg_per_newton(kf_precond pc, int k) {
    const double E = 1e6, nu = 0.3, la = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
    kf_step_stats st = {0};
    cantilever_run(pc, E, k * 0.4 * 0.025 / sqrt((la + 2 * mu) / 1000), 1.0 / 48, &st);
    return st.newton_iterations ? (double)st.krylov_iterations / st.newton_iterations : 0;
}

/* Measured on the evidence cantilever over its first half frame on 2
 * threads: multigrid 6.6 CG iterations per Newton iteration at 5x and 17.9
 * at 20x; Jacobi 8.4 and 28.9 (since CG stops at half the Newton tolerance,
 * implicit/solve.c: multigrid 4.6 and 11.1, Jacobi 6.1 and 20.9). The bound 24 at 20x is the measurement with
 * a third of headroom (jitter, thread count and build move it by an
 * iteration or two). Jacobi's iterations grow like Δt c / Δx (3.4x from 5x
 * to 20x here); multigrid's grow too but slower (2.7x), asserted below 3x. */
static void iterations_bounded_at_20x(void) {
    double mg5 = cantilever_cg_per_newton(KF_PRECOND_MULTIGRID, 5),
           mg20 = cantilever_cg_per_newton(KF_PRECOND_MULTIGRID, 20);
    double ja5 = cantilever_cg_per_newton(KF_PRECOND_JACOBI, 5), ja20 = cantilever_cg_per_newton(KF_PRECOND_JACOBI, 20);
    printf("  CG per Newton iteration: multigrid %.1f (5x) %.1f (20x), Jacobi %.1f (5x) %.1f (20x)\n", mg5, mg20, ja5,
           ja20);
    KT_CHECK(mg20 > 0 && mg20 <= 24, "multigrid at 20x: %.1f CG iterations per Newton iteration (bound 24)", mg20);
    KT_CHECK(mg20 < 0.7 * ja20, "multigrid at 20x needs well under Jacobi's %.1f: %.1f", ja20, mg20);
    KT_CHECK(mg20 / mg5 < 3.0, "multigrid's growth from 5x to 20x: %.2fx (Jacobi %.2fx)", mg20 / mg5, ja20 / ja5);
}

/* An artist's large step on a very stiff body: E = 1e9, 4 steps per frame
 * (1200x the explicit step), the first frame from rest, 2 threads. Before
 * the pre-gravity start (implicit/solve.c) and the full coarse quadrature
 * (implicit/mg_build.c): 12.5 Newton iterations a step, 190 CG iterations
 * per Newton iteration (CG stopping at its cap of 200 in most). After:
 * 2.75 and 31.9. Asserted: the last step converges, at most 4 Newton
 * iterations a step and 45 CG iterations per Newton iteration (the
 * measurement with about 40% headroom, as in the test above). */
static void stiff_large_steps_converge(void) {
    kf_step_stats st = {0};
    cantilever_run(KF_PRECOND_MULTIGRID, 1e9, (1.0 / 24) / 4 * (1 + 1e-12), 1.0 / 24, &st);
    const double newton_per_step = (double)st.newton_iterations / st.substeps,
                 cg_per_newton = (double)st.krylov_iterations / st.newton_iterations;
    printf("  E = 1e9, 4 steps a frame: %ld steps, %.2f Newton iterations a step, %.1f CG per Newton iteration, "
           "last residual %.3g\n",
           st.substeps, newton_per_step, cg_per_newton, st.newton_residual);
    KT_CHECK(st.substeps == 4, "4 steps: %ld", st.substeps);
    KT_CHECK(st.newton_residual <= 1e-3, "the last step converged to the default tolerance: %g", st.newton_residual);
    KT_CHECK(newton_per_step <= 4, "Newton iterations a step: %.2f (bound 4)", newton_per_step);
    KT_CHECK(cg_per_newton <= 45, "CG iterations per Newton iteration: %.1f (bound 45)", cg_per_newton);
}

/* The solve's sums (dots, norms, the fused CG update, the coarse blocks)
 * run in a fixed block order, so implicit substeps give bit-identical
 * particles on 1 and 2 threads, with either preconditioner */
static void same_result_any_thread_count(void) {
    for (int pc = 0; pc < 2; pc++) {
        kf_particles_view pv[2];
        scene sc[2];
        long newton = 0;
        for (int t = 0; t < 2; t++) {
            sc[t] = floor_block_threads(pc ? KF_PRECOND_JACOBI : KF_PRECOND_MULTIGRID, t + 1);
            kf_step_stats st = {0};
            for (int k = 0; k < 4; k++) KT_CHECK(kf_step(sc[t].m, sc[t].s, 1e-2, &st, NULL) == 0, "substep %d", k);
            if (t == 0) newton = st.newton_iterations;
            pv[t] = kf_state_particles(sc[t].s);
        }
        KT_CHECK(pv[0].n == pv[1].n && pv[0].n > 0, "same particles");
        size_t diff = 0;
        for (size_t i = 0; i < pv[0].n; i++) {
            for (int a = 0; a < 3; a++) diff += pv[0].x[a][i] != pv[1].x[a][i] || pv[0].v[a][i] != pv[1].v[a][i];
            for (int k = 0; k < 9; k++) diff += pv[0].F[k][i] != pv[1].F[k][i];
        }
        printf("  %s: %ld Newton iterations over 4 substeps, %zu values differ between 1 and 2 threads\n",
               pc ? "Jacobi" : "multigrid", newton, diff);
        KT_CHECK(newton >= 4, "the solve did work: %ld Newton iterations", newton);
        KT_CHECK(diff == 0, "%s: %zu position, velocity or F values differ between 1 and 2 threads",
                 pc ? "Jacobi" : "multigrid", diff);
        scene_free(&sc[0]);
        scene_free(&sc[1]);
    }
}

int main(int argc, char **argv) {
    KT_RUN(vcycle_symmetric_definite, argc, argv);
    KT_RUN(same_solution_as_jacobi, argc, argv);
    KT_RUN(iterations_bounded_at_20x, argc, argv);
    KT_RUN(stiff_large_steps_converge, argc, argv);
    KT_RUN(same_result_any_thread_count, argc, argv);
    return KT_EXIT();
}
