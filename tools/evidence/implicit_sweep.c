/* implicit_sweep.c — run time against error, explicit against implicit
 * integration, over a range of stiffnesses (evidence).
 *
 *   kf_evid_implicit_sweep --out DIR [--tumble | --bend] [--quick | --dx H] [--E 1e6,3e6,1e7,3e7] [--repeat N]
 *   kf_evid_implicit_sweep --out DIR --E 1e6 --only-k 20 [--jacobi] [--midpoint] [--profile]   (one run)
 *   kf_evid_implicit_sweep --out DIR --crossover [--tumble] [--E 1e6,1e7,1e8,1e9,1e10] [--repeat N]
 * --wall costs runs by wall-clock time instead of process CPU time (an idle machine).
 *
 * The problems (implicit_problem.h): the clamped cantilever (default), the
 * bar thrown tumbling through the air (--tumble), and the same bar free
 * with a bending velocity field (--bend: the cantilever's bending without
 * its wall, to tell the two apart). The step sweep: a fine explicit
 * reference (CFL REF_CFL); explicit at CFL 0.05 to 0.8 (kerf's default is
 * 0.4); implicit at fixed steps k × Δt_explicit, Δt_explicit = 0.4 Δx / c
 * the step explicit takes, k in {5, 10, 20, 50}, by backward Euler (CG
 * preconditioned by multigrid, the default, and by Jacobi) and by the
 * midpoint scheme (multigrid). Each implicit step k is also solved tightly
 * (Newton tolerance TIGHT_TOL, untimed): the "solve error" is the RMS
 * position difference to that run, what the solver's tolerance adds to
 * the time step's error. The explicit runs' successive differences (CFL c
 * against c/2) show whether the reference converges at all: for a first-
 * order method they halve with each halving of the step.
 *
 * Writes DIR/<name>.csv (every run), DIR/<name>.md (tables, the verdict
 * at E = 1e6, k = 20, the implicit step's CPU profile there) and
 * DIR/<prefix>_<E>_<kind>.dat (cpu, error) for the plot, with <name>
 * implicit_sweep, implicit_sweep_tumble or implicit_sweep_bend and
 * <prefix> implicit, implicit_tumble or implicit_bend; --profile prints
 * the implicit step's CPU milliseconds per stage per substep.
 *
 * The verdict (the implicit step's target): implicit at k = 20 must cost less CPU per
 * frame than explicit at the same error: explicit's cost there is
 * interpolated (log-log) between the two explicit runs whose errors
 * bracket implicit's; an explicit run that is both cheaper and at least as
 * accurate settles it the other way.
 *
 * The committed results (tools/evidence/implicit_results/), each on 1
 * thread (OMP_NUM_THREADS=1), stderr to the .log of the same name:
 *   --out DIR --repeat 3                      implicit_sweep.*
 *   --out DIR --tumble --repeat 3             implicit_sweep_tumble.*
 *   --out DIR --bend --E 1e6 --repeat 3       implicit_sweep_bend.*
 *   --out DIR --crossover --E 1e6,3e6,1e7,3e7,1e8,3e8,1e9 --repeat 3
 *   --out DIR --crossover --tumble --repeat 3
 *   --out SCRATCH --E 1e6 --newton-tol 1e-2 --repeat 3 [--tumble]: the .md and .log copied to
 *     implicit_sweep[_tumble]_newton_tol_1e-2.* (run into a scratch directory: they would
 *     overwrite the E = 1e6 .dat files)
 *   kf_evid_implicit_sweep_f64 --out SCRATCH --tumble --E 1e6,1e7: implicit_sweep_tumble_f64.*
 *   --out SCRATCH --bend --dx 0.0125 --E 1e6: implicit_sweep_bend_dx0.0125.*
 *   --out SCRATCH --tumble --E 1e6 --wall --repeat 5 (nothing else running): implicit_sweep_tumble_wall.*
 * then gnuplot -e "dir='tools/evidence/implicit_results'" on
 * tools/evidence/implicit_sweep.gp and implicit_crossover.gp. The .md
 * files' closing sections (what changed, conclusions) are written by hand.
 * kf_evid_implicit_sweep_f64 (make target, not built by default) is the
 * same with double particles. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../../tests/problems/implicit_problem.h"

#include "implicit_crossover.h"

#define REF_CFL 0.025
#define NEX 5
#define NK 4
#define NIMP 3
static const double EX_CFL[NEX] = {0.05, 0.1, 0.2, 0.4, 0.8};
static const int KS[NK] = {5, 10, 20, 50};
/* the implicit kinds of the table; tag: the .dat file's */
static const struct {
    integ how;
    kf_precond pc;
    const char *tag;
} IMP[NIMP] = {{BACKWARD_EULER, KF_PRECOND_MULTIGRID, "implicit"},
               {BACKWARD_EULER, KF_PRECOND_JACOBI, "jacobi"},
               {MIDPOINT, KF_PRECOND_MULTIGRID, "midpoint"}};
#define TARGET_E 1e6
#define TARGET_K 20

/* profiling: run only the implicit step k = g_only_k (0 = the whole sweep) */
static int g_only_k;
static kf_precond g_only_precond = KF_PRECOND_MULTIGRID;
static integ g_only_how = BACKWARD_EULER;

/* the implicit step's target for one implicit run im against the explicit runs ex
 * (sorted by error, most accurate first): explicit's cost at im's error,
 * interpolated log-log between the two runs that bracket it. Returns 1
 * when implicit is the cheaper. */
static int target_verdict(FILE *md, const run *im, const run *ex, int nex, double step_cost) {
    const run *acc = NULL, *less = NULL; /* the bracket: at least as accurate, and less accurate */
    for (int j = 0; j < nex; j++) {
        if (!ex[j].ok) continue;
        if (ex[j].rms <= im->rms) acc = &ex[j]; /* the least accurate of those at least as accurate */
        else if (!less) less = &ex[j];          /* the most accurate of those less accurate */
    }
    fprintf(md,
            "Target (E = %.0e, k = %d), %s: %.4f %s s/frame at RMS error %.3g m (solve error %.2g m); one step "
            "costs %.0f explicit substeps at CFL 0.4. ",
            TARGET_E, TARGET_K, run_name(im), im->cpu_per_frame, g_wall ? "wall-clock" : "CPU", im->rms, im->solve_rms,
            step_cost);
    double at = NAN;
    int met = 0;
    if (acc && less) {
        const double t = (log(im->rms) - log(acc->rms)) / (log(less->rms) - log(acc->rms));
        at = exp(log(acc->cpu_per_frame) + t * (log(less->cpu_per_frame) - log(acc->cpu_per_frame)));
        met = im->cpu_per_frame < at;
        fprintf(md,
                "Explicit at the same error lies between CFL %g (%.3g m, %.4f s) and CFL %g (%.3g m, %.4f s): "
                "%.4f s/frame interpolated, so implicit costs %.2fx as much",
                acc->cfl, acc->rms, acc->cpu_per_frame, less->cfl, less->rms, less->cpu_per_frame, at,
                im->cpu_per_frame / at);
    } else if (acc) {
        /* less accurate than every explicit run: explicit at its error would need a step above CFL 0.8 */
        met = im->cpu_per_frame < acc->cpu_per_frame;
        fprintf(md, "Every explicit run is at least as accurate; the cheapest, CFL %g, costs %.4f s at %.3g m",
                acc->cfl, acc->cpu_per_frame, acc->rms);
    } else if (less) {
        /* more accurate than every explicit run: explicit would need a step below the finest measured */
        met = im->cpu_per_frame < less->cpu_per_frame;
        fprintf(md, "More accurate than every explicit run; the most accurate, CFL %g, has %.3g m at %.4f s", less->cfl,
                less->rms, less->cpu_per_frame);
    }
    for (int j = 0; j < nex; j++)
        if (ex[j].ok && ex[j].rms <= im->rms && ex[j].cpu_per_frame <= im->cpu_per_frame) {
            met = 0;
            fprintf(md, "; explicit at CFL %g is both cheaper (%.4f s) and at least as accurate (%.3g m)", ex[j].cfl,
                    ex[j].cpu_per_frame, ex[j].rms);
            break;
        }
    fprintf(md, ". **Target %s.**\n\n", met ? "met" : "not met");
    return met;
}

/* where an implicit step's time goes (a separate, profiled run) */
static void profile_table(FILE *md, double E, integ how, double dt, double *x) {
    size_t n;
    g_profile = 1;
    run pr = simulate_median(E, how, KF_PRECOND_MULTIGRID, 0.4, dt, x, &n);
    g_profile = 0;
    if (pr.substeps <= 0) return;
    const double ns = (double)pr.substeps;
    fprintf(md,
            "Profile of %s at the target point (a separate run with the stage clocks on; CPU ms per implicit step, "
            "%.2f linearisations, %.2f energy evaluations, %.1f Hessian products and preconditioner applications per "
            "step):\n\n| stage | CPU ms / step |\n|---|---|\n",
            run_name(&pr), pr.prof.linearizations / ns, pr.prof.energy_evals / ns, pr.prof.hessian_products / ns);
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

static const char *problem_text(void) {
    switch (g_tumble) {
    case 1:
        return "Tumbling bar (corotated, rho 1000, nu 0.3, 0.4 x 0.08 x 0.12 m) free in the air: thrown up at 1.2 m/s "
               "and spinning at 4 rad/s about z, under gravity, no wall near it";
    case 2:
        return "Bending bar (corotated, rho 1000, nu 0.3, 0.4 x 0.08 x 0.12 m) free in the air, thrown up at 1.2 m/s "
               "with a bending velocity field (1 m/s (2 u^2 - 2/3) along y, u = -1 at one end to 1 at the other): "
               "the cantilever's bending without its wall";
    default:
        return "Stiff cantilever (corotated, rho 1000, nu 0.3, 0.4 x 0.08 x 0.12 m, clamped by sticky walls) sagging "
               "under gravity from rest";
    }
}

static int ksweep(const char *out, const double *Es, int nE) {
    static const char *const NAME[3] = {"implicit_sweep", "implicit_sweep_tumble", "implicit_sweep_bend"};
    static const char *const PREFIX[3] = {"implicit", "implicit_tumble", "implicit_bend"};
    const char *name = NAME[g_tumble], *prefix = PREFIX[g_tumble];
    char path[1024];
    FILE *csv = NULL, *md = NULL;
    if (!g_only_k) {
        snprintf(path, sizeof path, "%s/%s.csv", out, name);
        csv = fopen(path, "w");
        snprintf(path, sizeof path, "%s/%s.md", out, name);
        md = fopen(path, "w");
        if (!csv || !md) {
            fprintf(stderr, "cannot write into %s\n", out);
            return 1;
        }
        fprintf(csv, "E,integrator,cfl,dt,k,ok,cpu_s_per_frame,rms_error_m,max_error_m,substeps,newton,krylov,"
                     "solve_rms_error_m,rms_error_last_frame_m\n");
        fprintf(md,
                "# Explicit against implicit integration: CPU time per frame against error\n\n"
                "%s, dx = %g m, %d frames at 24 fps, 1 thread, %s seconds per frame (median of %d runs); error = "
                "the largest over the frames of the RMS particle position difference to explicit at CFL %g (last "
                "frame: the same at the last frame alone); solve error = the same difference to the same implicit "
                "step solved to a Newton tolerance of %g (what the solver's tolerance adds). k = implicit step / "
                "explicit step (0.4 dx / c). Implicit: backward Euler with multigrid-CG (kerf's default) and "
                "Jacobi-CG, the midpoint scheme with multigrid-CG.\n\n",
                problem_text(), g_dx, FRAMES, g_wall ? "wall-clock" : "CPU", g_repeat, REF_CFL, TIGHT_TOL);
        if (g_newton_tol > 0 || g_krylov_tol > 0 || g_newton_max > 0 || g_krylov_max > 0)
            fprintf(md,
                    "Solver settings other than kerf's defaults: newton_tol %g, krylov_tol %g, newton_max %d, "
                    "krylov_max %d (0 = default).\n\n",
                    g_newton_tol, g_krylov_tol, g_newton_max, g_krylov_max);
    }
    double *ref = malloc(sizeof(double) * TRAJ_DOUBLES), *x = malloc(sizeof(double) * TRAJ_DOUBLES);
    double *exr[NEX], *tight[2][NK];
    for (int j = 0; j < NEX; j++) exr[j] = malloc(sizeof(double) * TRAJ_DOUBLES);
    for (int s = 0; s < 2; s++)
        for (int k = 0; k < NK; k++) tight[s][k] = malloc(sizeof(double) * TRAJ_DOUBLES);
    for (int e = 0; e < nE; e++) {
        const double E = Es[e], c = wave_speed(E), dt_exp = 0.4 * g_dx / c;
        size_t n = 0;
        if (g_only_k > 0) {
            /* profiling: one implicit run, no reference */
            run r = simulate_median(E, g_only_how, g_only_precond, 0.4, g_only_k * dt_exp, x, &n);
            fprintf(stderr, "E %.0e k %d, %s: %.4f CPU s/frame, substeps %ld newton %ld cg %ld\n", E, g_only_k,
                    run_name(&r), r.cpu_per_frame, r.substeps, r.newton, r.krylov);
            if (g_profile && r.substeps > 0) print_profile(stderr, &r);
            continue;
        }
        run rr = simulate(E, EXPLICIT, KF_PRECOND_MULTIGRID, REF_CFL, 0, ref, &n);
        const double motion = traj_motion(ref, n);
        fprintf(stderr, "E %.0e: reference %s, %.2f s/frame, %zu particles, motion %.3g m\n", E,
                rr.ok ? "ok" : "FAILED", rr.cpu_per_frame, n, motion);
        fprintf(md,
                "## E = %.0e Pa (c = %.1f m/s, explicit step %.3g s, reference %.2f CPU s/frame, motion %.3g m)\n\n"
                "| integrator | step | CPU s/frame | RMS error (m) | last frame (m) | solve error (m) | substeps | "
                "Newton | CG |\n"
                "|---|---|---|---|---|---|---|---|---|\n",
                E, c, dt_exp, rr.cpu_per_frame, motion);
        run rows[NEX + NIMP * NK];
        int nr = 0, kof[NEX + NIMP * NK] = {0};
        for (int j = 0; j < NEX; j++) {
            rows[nr] = simulate_median(E, EXPLICIT, KF_PRECOND_MULTIGRID, EX_CFL[j], 0, exr[j], &n);
            compare(&rows[nr], exr[j], ref, n);
            nr++;
        }
        /* each step solved tightly once per scheme (untimed): the solve-error references */
        g_tight = 1;
        for (int s = 0; s < 2; s++)
            for (int k = 0; k < NK; k++)
                simulate(E, s ? MIDPOINT : BACKWARD_EULER, KF_PRECOND_MULTIGRID, 0.4, KS[k] * dt_exp, tight[s][k], &n);
        g_tight = 0;
        for (int i = 0; i < NIMP; i++)
            for (int k = 0; k < NK; k++) {
                kof[nr] = KS[k];
                rows[nr] = simulate_median(E, IMP[i].how, IMP[i].pc, 0.4, KS[k] * dt_exp, x, &n);
                compare(&rows[nr], x, ref, n);
                rows[nr].solve_rms = rows[nr].ok ? traj_diff(x, tight[IMP[i].how == MIDPOINT][k], n) : INFINITY;
                nr++;
            }
        for (int j = 0; j < nr; j++) {
            run *r = &rows[j];
            char step[64], serr[32];
            if (r->implicit) snprintf(step, sizeof step, "%d x (%.3g s)", kof[j], r->dt);
            else snprintf(step, sizeof step, "CFL %g", r->cfl);
            if (r->implicit) snprintf(serr, sizeof serr, "%.2g", r->solve_rms);
            else snprintf(serr, sizeof serr, "-");
            fprintf(csv, "%g,%s,%g,%g,%d,%d,%.6g,%.6g,%.6g,%ld,%ld,%ld,%.6g,%.6g\n", E, run_name(r), r->cfl, r->dt,
                    kof[j], r->ok, r->cpu_per_frame, r->rms, r->maxerr, r->substeps, r->newton, r->krylov,
                    r->implicit ? r->solve_rms : 0.0, r->rms_end);
            fprintf(md, "| %s | %s | %.4f | %s%.3g | %.3g | %s | %ld | %ld | %ld |\n", run_name(r), step,
                    r->cpu_per_frame, r->ok ? "" : "failed ", r->rms, r->rms_end, serr, r->substeps, r->newton,
                    r->krylov);
            fprintf(stderr, "  %-22s %-18s %.4f s/frame  rms %.3g m  solve %s m  substeps %ld newton %ld cg %ld\n",
                    run_name(r), step, r->cpu_per_frame, r->rms, serr, r->substeps, r->newton, r->krylov);
        }
        /* does explicit converge? its successive differences, CFL c against c/2 */
        fprintf(md, "\nExplicit against itself at half the step (the largest over the frames of the RMS position "
                    "difference; a converging first-order method halves it with each halving):");
        for (int j = NEX - 1; j >= 0; j--) {
            const double d = j ? traj_diff(exr[j], exr[j - 1], n) : traj_diff(exr[0], ref, n);
            fprintf(md, " CFL %g vs %g: %.3g m%s", EX_CFL[j], j ? EX_CFL[j - 1] : REF_CFL, d, j ? ";" : ".");
        }
        fprintf(md, "\n\n");
        /* the plot's data: cost against error per kind */
        for (int kind = 0; kind <= NIMP; kind++) {
            const char *tag = kind == 0 ? "explicit" : IMP[kind - 1].tag;
            snprintf(path, sizeof path, "%s/%s_%.0e_%s.dat", out, prefix, E, tag);
            FILE *d = fopen(path, "w");
            if (!d) continue;
            fprintf(d, "# cpu_s_per_frame rms_error_m (E = %.0e, %s)\n", E, tag);
            for (int j = 0; j < nr; j++) {
                const int rk = j < NEX ? 0 : 1 + (j - NEX) / NK;
                if (rk == kind && rows[j].ok) fprintf(d, "%.6g %.6g\n", rows[j].cpu_per_frame, rows[j].rms);
            }
            fclose(d);
        }
        if (E != TARGET_E) continue;
        /* the target, for each implicit kind at k = 20 */
        const int kt = 2; /* KS[kt] == TARGET_K */
        for (int i = 0; i < NIMP; i++) {
            const run *im = &rows[NEX + i * NK + kt];
            const run *ex04 = &rows[3]; /* CFL 0.4 */
            const double step_cost = (im->cpu_per_frame / im->substeps) / (ex04->cpu_per_frame / ex04->substeps);
            target_verdict(md, im, rows, NEX, step_cost);
        }
        profile_table(md, E, BACKWARD_EULER, TARGET_K * dt_exp, x);
        profile_table(md, E, MIDPOINT, TARGET_K * dt_exp, x);
    }
    for (int j = 0; j < NEX; j++) free(exr[j]);
    for (int s = 0; s < 2; s++)
        for (int k = 0; k < NK; k++) free(tight[s][k]);
    free(ref), free(x);
    if (csv) fclose(csv);
    if (md) fclose(md);
    return 0;
}

static void usage(const char *argv0) {
    fprintf(
        stderr,
        "usage: %s --out DIR [--tumble | --bend] [--quick | --dx H] [--crossover] [--E 1e6,3e6,1e7,3e7] [--repeat N]\n"
        "       [--only-k K [--jacobi] [--midpoint] [--profile]] [--wall] [--newton-tol X] [--newton-max N] "
        "[--krylov-tol X] "
        "[--krylov-max N]\n",
        argv0);
}

int main(int argc, char **argv) {
    const char *out = NULL;
    double Es[8] = {1e6, 3e6, 1e7, 3e7};
    int nE = 4, Es_given = 0, cross = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--out") && i + 1 < argc) out = argv[++i];
        else if (!strcmp(argv[i], "--quick")) g_dx = 0.04;
        else if (!strcmp(argv[i], "--dx") && i + 1 < argc) g_dx = atof(argv[++i]);
        else if (!strcmp(argv[i], "--newton-tol") && i + 1 < argc) g_newton_tol = atof(argv[++i]);
        else if (!strcmp(argv[i], "--newton-max") && i + 1 < argc) g_newton_max = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--krylov-tol") && i + 1 < argc) g_krylov_tol = atof(argv[++i]);
        else if (!strcmp(argv[i], "--krylov-max") && i + 1 < argc) g_krylov_max = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--only-k") && i + 1 < argc) g_only_k = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--jacobi")) g_only_precond = KF_PRECOND_JACOBI;
        else if (!strcmp(argv[i], "--midpoint")) g_only_how = MIDPOINT;
        else if (!strcmp(argv[i], "--profile")) g_profile = 1;
        else if (!strcmp(argv[i], "--wall")) g_wall = 1;
        else if (!strcmp(argv[i], "--crossover")) cross = 1;
        else if (!strcmp(argv[i], "--tumble")) g_tumble = 1;
        else if (!strcmp(argv[i], "--bend")) g_tumble = 2;
        else if (!strcmp(argv[i], "--repeat") && i + 1 < argc) g_repeat = atoi(argv[++i]);
        else if (!strcmp(argv[i], "--E") && i + 1 < argc) {
            nE = 0, Es_given = 1;
            for (char *t = strtok(argv[++i], ","); t && nE < 8; t = strtok(NULL, ",")) Es[nE++] = atof(t);
        } else {
            usage(argv[0]);
            return 2;
        }
    }
    if (!out || (cross && g_tumble == 2)) {
        usage(argv[0]);
        return 2;
    }
    if (cross) {
        if (!Es_given) nE = 5, Es[0] = 1e6, Es[1] = 1e7, Es[2] = 1e8, Es[3] = 1e9, Es[4] = 1e10;
        return crossover(out, Es, nE);
    }
    return ksweep(out, Es, nE);
}
