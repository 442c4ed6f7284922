/* implicit_sweep.c — run time against error, explicit against implicit
 * integration, over a range of stiffnesses (issue 7's evidence).
 *
 *   kf_evid_implicit_sweep --out DIR [--quick] [--E 1e6,3e6,1e7,3e7] [--repeat N]
 *   kf_evid_implicit_sweep --out DIR --E 1e6 --only-k 20 [--jacobi] [--profile]   (one run, for profiling)
 *   kf_evid_implicit_sweep --out DIR --crossover [--tumble] [--E 1e6,1e7,1e8,1e9,1e10] [--repeat N]
 * --profile prints the implicit step's CPU milliseconds per stage per substep
 * (implicit.h's kf_imp_profile; median over the repeats) and the rest of
 * the substep (binning, G2P, stress) from kerf's own stage timers.
 * The committed results: OMP_NUM_THREADS=1 kf_evid_implicit_sweep --out
 * tools/evidence/implicit_results --repeat 3 2> .../implicit_sweep.log, then
 * gnuplot -e "dir='tools/evidence/implicit_results'" tools/evidence/implicit_sweep.gp;
 * the crossover (see crossover() below): --crossover --E 1e6,3e6,1e7,3e7,1e8,3e8,1e9
 * --repeat 3 (2> implicit_crossover.log) and --crossover --tumble --repeat 3
 * (2> implicit_crossover_tumble.log) into the same directory, then
 * tools/evidence/implicit_crossover.gp; implicit_sweep_newton_tol_1e-2.{md,log}
 * are --E 1e6 --newton-tol 1e-2 --repeat 3 run into a scratch directory (it
 * would overwrite the E = 1e6 .dat files). The .md files' closing sections
 * (what changed, conclusions) are written by hand. kf_evid_implicit_sweep_f64
 * (make target, not built by default) is the same with double particles.
 *
 * The problem: a stiff elastic (fixed corotated) cantilever, ρ = 1000 kg/m³,
 * ν = 0.3, 0.4 m long, 8 x 12 cm section, clamped by sticky walls at x = 0
 * (its root lies beyond the wall), released from rest under gravity: it
 * sags and swings, the slow bending motion where the explicit step is set
 * by the fast compression waves. Simulated for FRAMES frames at 24 fps;
 * every frame is compared with a fine explicit reference (CFL 0.1) of the
 * same stiffness: the error is the largest over the frames of the RMS
 * particle position difference, in metres (the last frame's alone is
 * reported too: it was the metric before, and it depends on where the
 * swing happens to be at that instant).
 *
 * Explicit runs at CFL 0.4 (kerf's default) and 0.8; implicit at fixed
 * steps k × Δt_explicit, Δt_explicit = 0.4 Δx / c the step explicit takes,
 * for k in {5, 10, 20, 50}, with CG preconditioned by multigrid (the
 * default) and by Jacobi. Cost: process CPU seconds per frame on 1 thread
 * (CLOCK_PROCESS_CPUTIME_ID), so other load on the machine does not
 * inflate it much; --repeat N keeps the median of N runs. Each implicit
 * step k is also solved tightly (Newton tolerance TIGHT_TOL, untimed): the
 * "solve error" is the RMS position difference to that run, the part of
 * the error the solver's tolerance causes, against the time step's. Writes
 * DIR/implicit_sweep.csv (every run), DIR/implicit_sweep.md (tables, the
 * verdict at E = 1e6, k = 20, and the implicit step's CPU profile there)
 * and DIR/implicit_<E>_<integrator>.dat (cpu, error) for the plot
 * (DIR/implicit_sweep.gp).
 *
 * The verdict (issue 7's target): implicit at k = 20 must cost less CPU
 * per frame than explicit at an error no better than implicit's, i.e. than
 * the cheapest explicit run whose error is at least implicit's; an
 * explicit run that is both cheaper and at least as accurate settles it
 * the other way. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "kerf.h"
#include "mpm/implicit.h" /* the solve's per-stage profile (--profile) */

#define FPS 24.0
#define FRAMES 6
#define TIGHT_TOL 1e-6 /* Newton tolerance of the solve-error reference (the default is 1e-3) */
/* a run's trajectory: positions by stable id at the start and after each
 * frame, frame f at traj + f · 3 NP_MAX */
#define NP_MAX 200000
#define TRAJ_DOUBLES ((size_t)(FRAMES + 1) * 3 * NP_MAX)
static double *traj_frame(double *traj, int f) { return traj + (size_t)f * 3 * NP_MAX; }

typedef struct run {
    double dt;         /* fixed step (0 = CFL) */
    double cfl;
    int implicit;
    kf_precond precond; /* implicit: CG's preconditioner */
    int ok;
    double cpu_per_frame;
    double rms;     /* the error: the largest over the frames of the RMS position difference to the reference */
    double rms_end; /* the same at the last frame alone (the metric before: it depends on the swing's phase) */
    double maxerr;  /* the largest position difference of any particle at any frame */
    double solve_rms; /* implicit: RMS position difference to the same step solved to TIGHT_TOL */
    long substeps, newton, krylov;
    kf_imp_profile prof; /* --profile: the implicit solve's stages */
    double other_ms[KF_STAGE_COUNT]; /* kerf's stage timers (wall ms; CPU ms on an idle core) */
} run;

static double cpu_now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static double g_dx = 0.025;
/* the implicit solve's settings (0 = kerf's defaults) */
static double g_newton_tol, g_krylov_tol;
static int g_krylov_max, g_newton_max;
/* the solve-error reference: TIGHT_TOL instead of the settings above */
static int g_tight;
/* profiling: run only the implicit step k = g_only_k (0 = the whole sweep) */
static int g_only_k;
static kf_precond g_only_precond = KF_PRECOND_MULTIGRID;
/* timed runs are repeated this many times and their median CPU time kept
 * (the machine is shared: one run can be slowed by another's cache traffic) */
static int g_repeat = 1;
static int g_profile;
/* --crossover: the stiffness sweep at fixed steps per frame instead */
static int g_crossover;
/* the problem: the clamped cantilever, or (--tumble) the same bar thrown
 * tumbling through the air (see make_sim) */
static int g_tumble;
#define TUMBLE_OMEGA 4.0 /* rad/s about z */
#define TUMBLE_VY 1.2    /* m/s up: it rises and falls back to about its start in the 6 frames */

/* the cantilever's model and seeded state for stiffness E and the given integrator */
static kf_state *make_sim(double E, int implicit, kf_precond pc, double cfl, double dt_fixed, kf_model **mo) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = g_dx;
    sd.walls = 1;
    sd.wall_boundary = KF_BOUNDARY_STICKY;
    sd.threads = 1;
    sd.cfl = cfl;
    sd.dt_fixed = dt_fixed;
    sd.max_retries = 0;
    sd.integrator = implicit ? KF_INTEGRATOR_IMPLICIT : KF_INTEGRATOR_EXPLICIT;
    sd.precond = pc;
    if (g_newton_tol > 0) sd.newton_tol = g_newton_tol;
    if (g_krylov_tol > 0) sd.krylov_tol = g_krylov_tol;
    if (g_krylov_max > 0) sd.krylov_max = g_krylov_max;
    if (g_newton_max > 0) sd.newton_max = g_newton_max;
    if (g_tight) sd.newton_tol = TIGHT_TOL, sd.newton_max = 200;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    kf_material mat;
    kf_material_preset("jello", &mat);
    mat.E = E;
    mat.nu = 0.3;
    mat.density = 1000;
    int id = kf_model_add_material(m, &mat, err, sizeof err);
    kf_state *s = kf_state_create(m);
    if (!g_tumble) {
        double lo[3] = {-0.08, 0.46, 0.44}, hi[3] = {0.4, 0.54, 0.56};
        kf_state_fill_box(s, m, lo, hi, id, NULL, 2, 0);
    } else {
        /* the bar free in the air: spinning about z through its centre
         * (tips at 0.8 m/s) and thrown up, so gravity's curve, the
         * rotation and the elastic response all count, and the motion
         * (tens of cm) does not shrink with the stiffness */
        const double c[3] = {0.5, 0.6, 0.5}, lo[3] = {0.3, 0.56, 0.44}, hi[3] = {0.7, 0.64, 0.56};
        kf_state_fill_box(s, m, lo, hi, id, NULL, 2, 0);
        kf_particles_view pv = kf_state_particles(s);
        for (size_t i = 0; i < pv.n; i++) {
            const double dx = pv.x[0][i] - c[0], dy = pv.x[1][i] - c[1];
            pv.v[0][i] = (kf_real)(-TUMBLE_OMEGA * dy);
            pv.v[1][i] = (kf_real)(TUMBLE_OMEGA * dx + TUMBLE_VY);
            pv.v[2][i] = 0;
        }
    }
    *mo = m;
    return s;
}

/* the particles' positions by stable id (3 n) */
static void read_positions(kf_state *s, double *x, size_t *n_out) {
    kf_particles_view pv = kf_state_particles(s);
    for (size_t i = 0; i < pv.n; i++)
        for (int a = 0; a < 3; a++) x[3 * pv.id[i] + a] = pv.x[a][i];
    *n_out = pv.n;
}

/* simulate; traj receives the trajectory (TRAJ_DOUBLES, see traj_frame) */
static run simulate(double E, int implicit, kf_precond pc, double cfl, double dt_fixed, double *traj, size_t *n_out) {
    run r = {0};
    r.implicit = implicit;
    r.precond = pc;
    r.cfl = cfl;
    r.dt = dt_fixed;
    kf_model *m;
    kf_state *s = make_sim(E, implicit, pc, cfl, dt_fixed, &m);
    kf_step_stats st = {0};
    char msg[512];
    kf_imp_profile_enable(g_profile);
    kf_imp_profile_take(NULL);
    read_positions(s, traj_frame(traj, 0), n_out);
    double cpu = 0;
    r.ok = 1;
    for (int f = 0; f < FRAMES && r.ok; f++) {
        double t0 = cpu_now();
        r.ok = !kf_advance(m, s, 1.0 / FPS, &st, msg, sizeof msg);
        cpu += cpu_now() - t0;
        read_positions(s, traj_frame(traj, f + 1), n_out);
    }
    if (!r.ok) fprintf(stderr, "  (E %.0e, %s, step %.3g s: %s)\n", E, implicit ? "implicit" : "explicit", dt_fixed, msg);
    r.cpu_per_frame = cpu / FRAMES;
    kf_imp_profile_take(&r.prof);
    memcpy(r.other_ms, st.ms, sizeof r.other_ms);
    r.substeps = st.substeps;
    r.newton = st.newton_iterations;
    r.krylov = st.krylov_iterations;
    kf_state_destroy(s);
    kf_model_destroy(m);
    return r;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

/* simulate g_repeat times (the runs are deterministic: same result, same
 * counts) and keep the median CPU time per frame */
static run simulate_median(double E, int implicit, kf_precond pc, double cfl, double dt_fixed, double *traj, size_t *n_out) {
    double t[64], ps[KF_IMP_T_COUNT + KF_STAGE_COUNT][64];
    int n = g_repeat < 1 ? 1 : g_repeat > 64 ? 64 : g_repeat;
    run r = {0};
    for (int k = 0; k < n; k++) {
        r = simulate(E, implicit, pc, cfl, dt_fixed, traj, n_out);
        t[k] = r.cpu_per_frame;
        for (int j = 0; j < KF_IMP_T_COUNT; j++) ps[j][k] = r.prof.ms[j];
        for (int j = 0; j < KF_STAGE_COUNT; j++) ps[KF_IMP_T_COUNT + j][k] = r.other_ms[j];
    }
    qsort(t, n, sizeof *t, cmp_double);
    r.cpu_per_frame = n % 2 ? t[n / 2] : 0.5 * (t[n / 2 - 1] + t[n / 2]);
    for (int j = 0; j < KF_IMP_T_COUNT + KF_STAGE_COUNT; j++) {
        qsort(ps[j], n, sizeof *ps[j], cmp_double);
        double med = n % 2 ? ps[j][n / 2] : 0.5 * (ps[j][n / 2 - 1] + ps[j][n / 2]);
        if (j < KF_IMP_T_COUNT) r.prof.ms[j] = med;
        else r.other_ms[j - KF_IMP_T_COUNT] = med;
    }
    return r;
}

/* CPU ms per substep of each stage of the implicit solve, then the rest of the substep */
static void print_profile(FILE *o, const run *r) {
    const double ns = (double)r->substeps, sub_ms = 1e3 * r->cpu_per_frame * FRAMES / ns;
    const kf_imp_profile *p = &r->prof;
    double sum = 0;
    fprintf(o, "  per substep: %.3f CPU ms; %.2f linearisations, %.2f energies, %.2f Hessian products, "
                    "%.2f preconditioner applications\n",
            sub_ms, p->linearizations / ns, p->energy_evals / ns, p->hessian_products / ns,
            p->precond_applications / ns);
    for (int j = 0; j < KF_IMP_T_COUNT; j++) {
        sum += p->ms[j];
        fprintf(o, "    %-12s %7.3f ms  %5.1f%%\n", kf_imp_profile_stage(j), p->ms[j] / ns, 100 * p->ms[j] / ns / sub_ms);
    }
    const char *other[] = {"sort", "p2g", "grid", "g2p", "stress"};
    fprintf(o, "    %-12s %7.3f ms  %5.1f%%  (implicit grid stage, profiled)\n", "sum", sum / ns, 100 * sum / ns / sub_ms);
    for (int j = 0; j < 5; j++)
        if (j != KF_STAGE_GRID && j != KF_STAGE_P2G)
            fprintf(o, "    %-12s %7.3f ms  %5.1f%%  (kerf's wall-clock stage timer)\n", other[j], r->other_ms[j] / ns,
                    100 * r->other_ms[j] / ns / sub_ms);
}

static double rms_diff(const double *x, const double *y, size_t n) {
    double s2 = 0;
    for (size_t k = 0; k < 3 * n; k++) s2 += (x[k] - y[k]) * (x[k] - y[k]);
    return sqrt(s2 / n);
}

/* the largest over frames 1..FRAMES of the RMS difference of two trajectories */
static double traj_diff(double *x, double *y, size_t n) {
    double worst = 0;
    for (int f = 1; f <= FRAMES; f++) worst = fmax(worst, rms_diff(traj_frame(x, f), traj_frame(y, f), n));
    return worst;
}

/* the error of trajectory x against the reference's: the worst frame's RMS
 * position difference (a swing seen at one instant can coincide with a
 * wrong one: the last frame alone scored backward Euler at 50x the
 * explicit step better than at 20x) */
static void compare(run *r, double *x, double *ref, size_t n) {
    double mx = 0;
    for (int f = 1; f <= FRAMES; f++) {
        const double *xf = traj_frame(x, f), *rf = traj_frame(ref, f);
        for (size_t k = 0; k < 3 * n; k++) mx = fmax(mx, fabs(xf[k] - rf[k]));
    }
    r->rms = traj_diff(x, ref, n);
    r->rms_end = rms_diff(traj_frame(x, FRAMES), traj_frame(ref, FRAMES), n);
    r->maxerr = mx;
    if (!r->ok || r->rms != r->rms) r->rms = r->rms_end = r->maxerr = INFINITY;
}

/* ---- the crossover: which integrator is cheapest for a given error, by stiffness ----
 * The k-sweep above ties the implicit step to the explicit one, so both
 * costs grow as √E and their ratio hardly moves with stiffness. An artist
 * picks the implicit step for the motion instead (a few steps per frame,
 * whatever the stiffness), while explicit stays bound to 0.4–0.8 Δx / c.
 * Here implicit takes n = 1..16 steps per frame at every E, explicit runs
 * at CFL 0.4 and 0.8, and for each error budget (a fraction of Δx, what
 * a render at the grid's resolution can show) the cheapest run of each
 * integrator that meets it is compared. A budget at least as large as
 * the motion itself (the reference's largest RMS displacement) is met by a
 * body that does not move, so it says nothing at that E and is left out.
 * The crossover for a budget is the smallest measured E from which
 * implicit is cheaper at every larger measured E where the budget counts. */
#define XO_NSTEPS 5
#define XO_NBUDGET 4
/* implicit steps per frame: the tumbling bar moves up to ~2 m/s, and a
 * step may move a particle at most one cell (kerf's advection limit), so
 * it starts at 4 */
static const int XO_STEPS[2][XO_NSTEPS] = {{1, 2, 4, 8, 16}, {4, 8, 16, 32, 64}};
static const double XO_BUDGET[XO_NBUDGET] = {0.1, 0.02, 0.004, 0.001}; /* × Δx */

static int crossover(const char *out, const double *Es, int nE) {
    char path[1024];
    const char *name = g_tumble ? "implicit_crossover_tumble" : "implicit_crossover";
    snprintf(path, sizeof path, "%s/%s.md", out, name);
    FILE *md = fopen(path, "w");
    snprintf(path, sizeof path, "%s/%s.csv", out, name);
    FILE *csv = fopen(path, "w");
    if (!md || !csv) {
        fprintf(stderr, "cannot write into %s\n", out);
        return 1;
    }
    fprintf(csv, "E,integrator,cfl,steps_per_frame,ok,cpu_s_per_frame,rms_error_m,ref_rms_displacement_m,substeps,newton,krylov\n");
    fprintf(md, "# Explicit against implicit by stiffness: the cheapest run that meets an error budget\n\n%s (dx = %g m, %d frames at 24 fps, 1 thread, CPU seconds per frame, "
                "median of %d runs; error = the largest over the frames of the RMS particle position difference to "
                "explicit at CFL 0.1). "
                "Explicit runs at CFL 0.4 and 0.8; implicit (multigrid-CG, kerf's default solver settings) at a fixed "
                "number of steps per frame, whatever the stiffness. \"motion\" is the reference's largest RMS particle "
                "displacement from the start, the size of what the error is measured against: a budget above it is met "
                "by a body that does not move at all, so such a budget (marked \"above the motion\") does not count "
                "towards the crossover.\n\n",
                g_tumble ? "The bar of implicit_sweep.md's cantilever, free in the air: thrown up at 1.2 m/s and spinning at "
                           "4 rad/s about z, under gravity (no wall touches it)"
                         : "The cantilever of implicit_sweep.md",
                g_dx, FRAMES, g_repeat);
    double cost[8][2][XO_NBUDGET]; /* [E][explicit, implicit][budget]: cheapest run meeting it, INFINITY = none */
    int best_n[8][XO_NBUDGET];
    double motion[8];
    double *ref = malloc(sizeof(double) * TRAJ_DOUBLES), *x = malloc(sizeof(double) * TRAJ_DOUBLES);
    for (int e = 0; e < nE; e++) {
        const double E = Es[e], nu = 0.3, la = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
        const double c = sqrt((la + 2 * mu) / 1000);
        size_t n = 0;
        /* the start positions: a run of zero frames is the seeding */
        run rr = simulate(E, 0, KF_PRECOND_MULTIGRID, 0.1, 0, ref, &n);
        /* the motion's size: the reference's largest RMS displacement from the start */
        double disp = 0;
        for (int f = 1; f <= FRAMES; f++) disp = fmax(disp, rms_diff(traj_frame(ref, f), traj_frame(ref, 0), n));
        motion[e] = disp;
        fprintf(stderr, "crossover E %.0e: reference %s, %.2f s/frame, motion %.3g m\n", E, rr.ok ? "ok" : "FAILED",
                rr.cpu_per_frame, disp);
        fprintf(md, "## E = %.0e Pa (c = %.0f m/s; reference %.2f CPU s/frame; motion %.3g m)\n\n"
                    "| integrator | step | CPU s/frame | RMS error (m) | error / dx | error / motion | substeps | Newton | CG |\n"
                    "|---|---|---|---|---|---|---|---|---|\n",
                E, c, rr.cpu_per_frame, disp);
        for (int b = 0; b < XO_NBUDGET; b++) cost[e][0][b] = cost[e][1][b] = INFINITY, best_n[e][b] = 0;
        for (int j = 0; j < 2 + XO_NSTEPS; j++) {
            const int imp = j >= 2, steps = imp ? XO_STEPS[g_tumble][j - 2] : 0;
            const double cfl = imp ? 0.4 : (j ? 0.8 : 0.4);
            /* a hair over 1/(24 n) so that round-off cannot split the last step */
            const double dt = imp ? (1.0 / FPS) / steps * (1 + 1e-12) : 0;
            run r = simulate_median(E, imp, KF_PRECOND_MULTIGRID, cfl, dt, x, &n);
            compare(&r, x, ref, n);
            char step[48];
            if (imp) snprintf(step, sizeof step, "%d / frame", steps);
            else snprintf(step, sizeof step, "CFL %.1f", cfl);
            fprintf(md, "| %s | %s | %.4f | %s%.3g | %.3g | %.3g | %ld | %ld | %ld |\n", imp ? "implicit" : "explicit", step,
                    r.cpu_per_frame, r.ok ? "" : "failed ", r.rms, r.rms / g_dx, r.rms / disp, r.substeps, r.newton,
                    r.krylov);
            fprintf(csv, "%g,%s,%g,%d,%d,%.6g,%.6g,%.6g,%ld,%ld,%ld\n", E, imp ? "implicit" : "explicit", imp ? 0 : cfl,
                    steps, r.ok, r.cpu_per_frame, r.rms, disp, r.substeps, r.newton, r.krylov);
            fprintf(stderr, "  %-9s %-10s %.4f s/frame  rms %.3g m  substeps %ld newton %ld cg %ld\n",
                    imp ? "implicit" : "explicit", step, r.cpu_per_frame, r.rms, r.substeps, r.newton, r.krylov);
            for (int b = 0; b < XO_NBUDGET; b++)
                if (r.ok && r.rms <= XO_BUDGET[b] * g_dx && r.cpu_per_frame < cost[e][imp][b]) {
                    cost[e][imp][b] = r.cpu_per_frame;
                    if (imp) best_n[e][b] = steps;
                }
        }
        fprintf(md, "\n");
    }
    /* the verdict per budget, and the plot's data (E, explicit, implicit; NaN = none meets it or it is
     * above the motion) */
    fprintf(md, "## The cheapest run meeting each error budget (CPU s/frame; bold: the cheaper)\n\n| E | motion (m) |");
    for (int b = 0; b < XO_NBUDGET; b++) fprintf(md, " %.3g dx (%.2g m): explicit | implicit |", XO_BUDGET[b], XO_BUDGET[b] * g_dx);
    fprintf(md, "\n|---|---|");
    for (int b = 0; b < XO_NBUDGET; b++) fprintf(md, "---|---|");
    fprintf(md, "\n");
    for (int e = 0; e < nE; e++) {
        fprintf(md, "| %.0e | %.2g |", Es[e], motion[e]);
        for (int b = 0; b < XO_NBUDGET; b++) {
            const double ex = cost[e][0][b], im = cost[e][1][b];
            if (XO_BUDGET[b] * g_dx >= motion[e]) {
                fprintf(md, " above the motion | |");
                continue;
            }
            if (isfinite(ex)) fprintf(md, " %s%.4f%s |", ex <= im ? "**" : "", ex, ex <= im ? "**" : "");
            else fprintf(md, " none |");
            if (isfinite(im)) fprintf(md, " %s%.4f (%d / frame)%s |", im < ex ? "**" : "", im, best_n[e][b], im < ex ? "**" : "");
            else fprintf(md, " none |");
        }
        fprintf(md, "\n");
    }
    fprintf(md, "\n");
    for (int b = 0; b < XO_NBUDGET; b++) {
        const double budget = XO_BUDGET[b] * g_dx;
        snprintf(path, sizeof path, "%s/%s_%d.dat", out, name, b);
        FILE *d = fopen(path, "w");
        if (d) fprintf(d, "# E explicit_cpu_s_per_frame implicit_cpu_s_per_frame (budget %g dx; NaN = none meets it, or it is above the motion)\n", XO_BUDGET[b]);
        for (int e = 0; e < nE && d; e++) {
            const int counts = budget < motion[e];
            fprintf(d, "%g %.6g %.6g\n", Es[e], counts && isfinite(cost[e][0][b]) ? cost[e][0][b] : NAN,
                    counts && isfinite(cost[e][1][b]) ? cost[e][1][b] : NAN);
        }
        if (d) fclose(d);
        /* per counted E: which integrator is the cheaper within the budget (or neither meets it); the
         * crossover: implicit at every counted E from Es[from] on */
        char who[8];
        int from = -1, counted = 0;
        for (int e = 0; e < nE; e++) {
            const double ex = cost[e][0][b], im = cost[e][1][b];
            who[e] = budget >= motion[e] ? '-' : !isfinite(ex) && !isfinite(im) ? 'n' : im < ex ? 'i' : 'e';
            counted += who[e] != '-';
        }
        for (int e = nE - 1; e >= 0; e--) {
            if (who[e] == '-') continue;
            if (who[e] != 'i') break;
            from = e;
        }
        fprintf(md, "Budget %.3g dx (%.2g m): ", XO_BUDGET[b], budget);
        if (!counted) fprintf(md, "above the motion at every measured stiffness");
        else if (from >= 0) fprintf(md, "**implicit is the cheaper from E = %.0e on** (%.2fx cheaper there)", Es[from],
                                    cost[from][0][b] / cost[from][1][b]);
        else fprintf(md, "implicit is not the cheaper at the stiffest E where the budget counts");
        static const char *const WHAT[] = {"explicit is the cheaper", "implicit is the cheaper", "no run meets it",
                                           "it is above the motion"};
        static const char CODE[] = "ein";
        for (int k = 0; k < 4; k++) {
            int any = 0;
            for (int e = 0; e < nE; e++)
                if (who[e] == (k == 3 ? '-' : CODE[k])) fprintf(md, "%s%.0e", any++ ? ", " : "; ", Es[e]);
            if (any) fprintf(md, ": %s", WHAT[k]);
        }
        fprintf(md, ".\n\n");
        fprintf(stderr, "budget %.3g dx: %s %.0e\n", XO_BUDGET[b], from < 0 ? "no crossover up to" : "implicit from",
                from < 0 ? Es[nE - 1] : Es[from]);
    }
    free(ref), free(x);
    fclose(md);
    fclose(csv);
    return 0;
}

int main(int argc, char **argv) {
    const char *out = NULL;
    double Es[8] = {1e6, 3e6, 1e7, 3e7};
    int nE = 4, Es_given = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--out") && i + 1 < argc) out = argv[++i];
        else if (!strcmp(argv[i], "--quick")) g_dx = 0.04;
        else if (!strcmp(argv[i], "--newton-tol") && i + 1 < argc) g_newton_tol = atof(argv[++i]);
        else if (!strcmp(argv[i], "--newton-max") && i + 1 < argc) g_newton_max = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--krylov-tol") && i + 1 < argc) g_krylov_tol = atof(argv[++i]);
        else if (!strcmp(argv[i], "--krylov-max") && i + 1 < argc) g_krylov_max = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--only-k") && i + 1 < argc) g_only_k = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--jacobi")) g_only_precond = KF_PRECOND_JACOBI;
        else if (!strcmp(argv[i], "--profile")) g_profile = 1;
        else if (!strcmp(argv[i], "--crossover")) g_crossover = 1;
        else if (!strcmp(argv[i], "--tumble")) g_tumble = 1;
        else if (!strcmp(argv[i], "--repeat") && i + 1 < argc) g_repeat = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--E") && i + 1 < argc) {
            nE = 0, Es_given = 1;
            for (char *t = strtok(argv[++i], ","); t && nE < 8; t = strtok(NULL, ",")) Es[nE++] = atof(t);
        } else {
            fprintf(stderr, "usage: %s --out DIR [--quick] [--crossover] [--E 1e6,3e6,1e7,3e7] [--repeat N]\n", argv[0]);
            return 2;
        }
    }
    if (!out) {
        fprintf(stderr, "usage: %s --out DIR [--quick] [--crossover] [--E 1e6,3e6,1e7,3e7] [--repeat N]\n", argv[0]);
        return 2;
    }
    if (g_crossover) {
        if (!Es_given) nE = 5, Es[0] = 1e6, Es[1] = 1e7, Es[2] = 1e8, Es[3] = 1e9, Es[4] = 1e10;
        return crossover(out, Es, nE);
    }
    char path[1024];
    snprintf(path, sizeof path, "%s/implicit_sweep.csv", out);
    FILE *csv = fopen(path, "w");
    snprintf(path, sizeof path, "%s/implicit_sweep.md", out);
    FILE *md = fopen(path, "w");
    if (!csv || !md) {
        fprintf(stderr, "cannot write into %s\n", out);
        return 1;
    }
    fprintf(csv, "E,integrator,cfl,dt,k,ok,cpu_s_per_frame,rms_error_m,max_error_m,substeps,newton,krylov,"
                 "solve_rms_error_m,rms_error_last_frame_m\n");
    fprintf(md, "# Explicit against implicit integration: CPU time per frame against error\n\n"
                "Stiff cantilever (corotated, rho 1000, nu 0.3, 0.4 x 0.08 x 0.12 m, clamped by sticky walls) "
                "sagging under gravity from rest, "
                "dx = %g m, %d frames at 24 fps, 1 thread, CPU seconds per frame (median of %d runs); error = the largest "
                "over the frames of the RMS particle position difference to explicit at CFL 0.1 (last frame: the same "
                "at the last frame alone); solve error = the same difference to the same implicit step solved to a "
                "Newton tolerance of %g (what the solver's tolerance adds). k = implicit step / explicit step "
                "(0.4 dx / c).\n\n",
                g_dx, FRAMES, g_repeat, TIGHT_TOL);
    if (g_newton_tol > 0 || g_krylov_tol > 0 || g_newton_max > 0 || g_krylov_max > 0)
        fprintf(md, "Solver settings other than kerf's defaults: newton_tol %g, krylov_tol %g, newton_max %d, "
                    "krylov_max %d (0 = default).\n\n",
                g_newton_tol, g_krylov_tol, g_newton_max, g_krylov_max);
    const int ks[4] = {5, 10, 20, 50};
    const double cfls[2] = {0.4, 0.8};
    for (int e = 0; e < nE; e++) {
        double E = Es[e];
        /* P-wave speed of the block */
        double nu = 0.3, la = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
        double c = sqrt((la + 2 * mu) / 1000), dt_exp = 0.4 * g_dx / c;
        size_t n = 0;
        double *ref = malloc(sizeof(double) * TRAJ_DOUBLES), *x = malloc(sizeof(double) * TRAJ_DOUBLES);
        if (g_only_k > 0) {
            /* profiling: one implicit run, no reference */
            run r = simulate_median(E, 1, g_only_precond, 0.4, g_only_k * dt_exp, x, &n);
            fprintf(stderr, "E %.0e k %d: %.4f CPU s/frame, substeps %ld newton %ld cg %ld\n", E, g_only_k,
                    r.cpu_per_frame, r.substeps, r.newton, r.krylov);
            if (g_profile && r.substeps > 0) print_profile(stderr, &r);
            free(ref);
            free(x);
            continue;
        }
        run rr = simulate(E, 0, KF_PRECOND_MULTIGRID, 0.1, 0, ref, &n);
        fprintf(stderr, "E %.0e: reference %s, %.2f s/frame, %zu particles\n", E, rr.ok ? "ok" : "FAILED",
                rr.cpu_per_frame, n);
        fprintf(md, "## E = %.0e Pa (c = %.1f m/s, explicit step %.3g s, reference %.2f CPU s/frame)\n\n"
                    "| integrator | step | CPU s/frame | RMS error (m) | last frame (m) | solve error (m) | substeps | Newton | CG |\n"
                    "|---|---|---|---|---|---|---|---|---|\n",
                E, c, dt_exp, rr.cpu_per_frame);
        /* explicit at two CFL numbers, then implicit at each k with the
         * multigrid preconditioner (the default) and with Jacobi */
        run rows[10];
        int nr = 0, kof[10] = {0};
        for (int k = 0; k < 2; k++)
            rows[nr++] = simulate_median(E, 0, KF_PRECOND_MULTIGRID, cfls[k], 0, x, &n), compare(&rows[nr - 1], x, ref, n);
        /* each step solved tightly once (untimed): the solve-error reference */
        double *tight[4];
        for (int k = 0; k < 4; k++) {
            tight[k] = malloc(sizeof(double) * TRAJ_DOUBLES);
            g_tight = 1;
            simulate(E, 1, KF_PRECOND_MULTIGRID, 0.4, ks[k] * dt_exp, tight[k], &n);
            g_tight = 0;
        }
        for (int pc = 0; pc < 2; pc++)
            for (int k = 0; k < 4; k++) {
                kof[nr] = ks[k];
                rows[nr++] = simulate_median(E, 1, pc ? KF_PRECOND_JACOBI : KF_PRECOND_MULTIGRID, 0.4, ks[k] * dt_exp, x, &n);
                compare(&rows[nr - 1], x, ref, n);
                rows[nr - 1].solve_rms = rows[nr - 1].ok ? traj_diff(x, tight[k], n) : INFINITY;
            }
        for (int k = 0; k < 4; k++) free(tight[k]);
        for (int j = 0; j < nr; j++) {
            run *r = &rows[j];
            int k = kof[j];
            const char *name = !r->implicit ? "explicit" : r->precond == KF_PRECOND_JACOBI ? "implicit jacobi" : "implicit multigrid";
            fprintf(csv, "%g,%s,%g,%g,%d,%d,%.6g,%.6g,%.6g,%ld,%ld,%ld,%.6g,%.6g\n", E, name, r->cfl, r->dt, k, r->ok,
                    r->cpu_per_frame, r->rms, r->maxerr, r->substeps, r->newton, r->krylov, r->implicit ? r->solve_rms : 0.0,
                    r->rms_end);
            char step[64], serr[32];
            if (r->implicit) snprintf(step, sizeof step, "%d x (%.3g s)", k, r->dt);
            else snprintf(step, sizeof step, "CFL %.1f", r->cfl);
            if (r->implicit) snprintf(serr, sizeof serr, "%.2g", r->solve_rms);
            else snprintf(serr, sizeof serr, "-");
            fprintf(md, "| %s | %s | %.4f | %s%.3g | %.3g | %s | %ld | %ld | %ld |\n", name, step, r->cpu_per_frame,
                    r->ok ? "" : "failed ", r->rms, r->rms_end, serr, r->substeps, r->newton, r->krylov);
            fprintf(stderr, "  %-18s %-18s %.4f s/frame  rms %.3g m  solve %s m  substeps %ld newton %ld cg %ld\n", name,
                    step, r->cpu_per_frame, r->rms, serr, r->substeps, r->newton, r->krylov);
        }
        fprintf(md, "\n");
        /* the plot's data: cost against error per integrator */
        /* (implicit_<E>_implicit.dat: multigrid, _jacobi.dat: Jacobi) */
        for (int kind = 0; kind < 3; kind++) {
            const char *tag = kind == 0 ? "explicit" : kind == 1 ? "implicit" : "jacobi";
            snprintf(path, sizeof path, "%s/implicit_%.0e_%s.dat", out, E, tag);
            FILE *d = fopen(path, "w");
            if (!d) continue;
            fprintf(d, "# cpu_s_per_frame rms_error_m (E = %.0e, %s)\n", E, tag);
            for (int j = 0; j < nr; j++) {
                int rk = !rows[j].implicit ? 0 : rows[j].precond == KF_PRECOND_JACOBI ? 2 : 1;
                if (rk == kind && rows[j].ok) fprintf(d, "%.6g %.6g\n", rows[j].cpu_per_frame, rows[j].rms);
            }
            fclose(d);
        }
        /* the target: E = 1e6 at k = 20 against the cheapest
         * explicit run whose error is no better than implicit's */
        if (E == 1e6) {
            run *im = &rows[2 + 2], *ja = &rows[6 + 2], *cmp = NULL, *dom = NULL;
            for (int j = 0; j < 2; j++) {
                run *ex = &rows[j];
                if (!ex->ok) continue;
                if (ex->rms >= im->rms && (!cmp || ex->cpu_per_frame < cmp->cpu_per_frame)) cmp = ex;
                if (ex->rms <= im->rms && ex->cpu_per_frame <= im->cpu_per_frame) dom = ex;
            }
            /* one implicit step in explicit substeps (CFL 0.4) of the same run */
            double step_cost = (im->cpu_per_frame / im->substeps) / (rows[0].cpu_per_frame / rows[0].substeps);
            fprintf(md, "Target (E = 1e6, k = 20): implicit (multigrid) %.4f CPU s/frame at RMS error %.3g m (solve error "
                        "%.2g m; Jacobi: %.4f s, %ld CG); one implicit step costs %.0f explicit substeps at CFL 0.4. ",
                    im->cpu_per_frame, im->rms, im->solve_rms, ja->cpu_per_frame, ja->krylov, step_cost);
            if (cmp)
                fprintf(md, "The cheapest explicit run at an error no better than implicit's, CFL %.1f, costs %.4f CPU "
                            "s/frame at %.3g m: implicit is %s (%.2fx its cost)",
                        cmp->cfl, cmp->cpu_per_frame, cmp->rms, im->cpu_per_frame < cmp->cpu_per_frame ? "cheaper" : "dearer",
                        im->cpu_per_frame / cmp->cpu_per_frame);
            else
                fprintf(md, "Every explicit run is more accurate than implicit");
            if (dom)
                fprintf(md, "; explicit at CFL %.1f is both cheaper (%.4f s) and at least as accurate (%.3g m)", dom->cfl,
                        dom->cpu_per_frame, dom->rms);
            fprintf(md, ". **Target %s.**\n\n", cmp && !dom && im->cpu_per_frame < cmp->cpu_per_frame ? "met" : "not met");
            /* where the implicit step's time goes there (a separate, profiled run) */
            g_profile = 1;
            run pr = simulate_median(E, 1, KF_PRECOND_MULTIGRID, 0.4, 20 * dt_exp, x, &n);
            g_profile = 0;
            if (pr.substeps > 0) {
                const double ns = (double)pr.substeps;
                fprintf(md, "Profile at the target point (a separate run with the stage clocks on; CPU ms per implicit "
                            "step, %.2f linearisations, %.2f energy evaluations, %.1f Hessian products and preconditioner "
                            "applications per step):\n\n| stage | CPU ms / step |\n|---|---|\n",
                        pr.prof.linearizations / ns, pr.prof.energy_evals / ns, pr.prof.hessian_products / ns);
                double sum = 0;
                for (int j = 0; j < KF_IMP_T_COUNT; j++) {
                    sum += pr.prof.ms[j];
                    fprintf(md, "| %s | %.3f |\n", kf_imp_profile_stage(j), pr.prof.ms[j] / ns);
                }
                fprintf(md, "| (implicit grid stage) | %.3f |\n", sum / ns);
                const char *other[] = {"sort", "p2g", "grid", "g2p", "stress"};
                for (int j = 0; j < 5; j++)
                    if (j != KF_STAGE_GRID && j != KF_STAGE_P2G)
                        fprintf(md, "| %s (kerf's wall-clock stage timer) | %.3f |\n", other[j], pr.other_ms[j] / ns);
                fprintf(md, "| whole step | %.3f |\n\n", 1e3 * pr.cpu_per_frame * FRAMES / ns);
            }
        }
        free(ref);
        free(x);
    }
    fclose(csv);
    fclose(md);
    return 0;
}
