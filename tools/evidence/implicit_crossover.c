/* implicit_crossover.c — which integrator is cheapest for a given error,
 * by stiffness (kf_evid_implicit_sweep --crossover [--tumble]).
 *
 * The step sweep (implicit_sweep.c) ties the implicit step to the explicit
 * one, so both costs grow as √E and their ratio hardly moves with
 * stiffness. An artist picks the implicit step for the motion instead (a
 * few steps per frame, whatever the stiffness), while explicit stays bound
 * to 0.4–0.8 Δx / c. Here implicit takes n steps per frame at every E, by
 * backward Euler and by the midpoint scheme, explicit runs at CFL 0.4 and
 * 0.8, and for each error budget (a fraction of Δx, what a render at the
 * grid's resolution can show) the cheapest run of each that meets it is
 * compared. A budget at least as large as the motion itself (the
 * reference's largest RMS displacement) is met by a body that does not
 * move, so it says nothing at that E and is left out. The crossover for a
 * budget is the smallest measured E from which an implicit scheme is the
 * cheaper at every larger measured E where the budget counts.
 *
 * The reference is explicit at CFL 0.1, not the step sweep's 0.025: at
 * E = 1e10 a float run at 0.025 takes ~1.5 million substeps, whose
 * round-off alone is about the budgets measured here. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "implicit_crossover.h"

#include "../../tests/problems/implicit_problem.h"

#define XO_REF_CFL 0.1
#define XO_NSTEPS 5
#define XO_NBUDGET 4
#define XO_NKIND 3 /* explicit, backward Euler, midpoint */
/* implicit steps per frame: the tumbling bar moves up to ~2 m/s, and a
 * step may move a particle at most one cell (kerf's advection limit), so
 * it starts at 4 */
static const int XO_STEPS[2][XO_NSTEPS] = {{1, 2, 4, 8, 16}, {4, 8, 16, 32, 64}};
static const double XO_BUDGET[XO_NBUDGET] = {0.1, 0.02, 0.004, 0.001}; /* × Δx */
static const char *const KIND_NAME[XO_NKIND] = {"explicit", "backward Euler", "midpoint"};

int crossover(const char *out, const double *Es, int nE) {
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
    fprintf(csv, "E,integrator,cfl,steps_per_frame,ok,cpu_s_per_frame,rms_error_m,ref_rms_displacement_m,substeps,"
                 "newton,krylov\n");
    fprintf(md,
            "# Explicit against implicit by stiffness: the cheapest run that meets an error budget\n\n%s (dx = %g m, "
            "%d frames at 24 fps, 1 thread, CPU seconds per frame, "
            "median of %d runs; error = the largest over the frames of the RMS particle position difference to "
            "explicit at CFL %g). "
            "Explicit runs at CFL 0.4 and 0.8; implicit (multigrid-CG, kerf's default solver settings), by backward "
            "Euler and by the midpoint scheme, at a fixed "
            "number of steps per frame, whatever the stiffness. \"motion\" is the reference's largest RMS particle "
            "displacement from the start, the size of what the error is measured against: a budget above it is met "
            "by a body that does not move at all, so such a budget (marked \"above the motion\") does not count "
            "towards the crossover.\n\n",
            g_tumble
                ? "The bar of implicit_sweep.md's cantilever, free in the air: thrown up at 1.2 m/s and spinning at "
                  "4 rad/s about z, under gravity (no wall touches it)"
                : "The cantilever of implicit_sweep.md",
            g_dx, FRAMES, g_repeat, XO_REF_CFL);
    /* [E][kind][budget]: the cheapest run meeting it, INFINITY = none */
    double cost[8][XO_NKIND][XO_NBUDGET];
    int best_n[8][XO_NKIND][XO_NBUDGET];
    double motion[8];
    double *ref = malloc(sizeof(double) * TRAJ_DOUBLES), *x = malloc(sizeof(double) * TRAJ_DOUBLES);
    for (int e = 0; e < nE; e++) {
        const double E = Es[e], c = wave_speed(E);
        size_t n = 0;
        run rr = simulate(E, EXPLICIT, KF_PRECOND_MULTIGRID, XO_REF_CFL, 0, ref, &n);
        const double disp = motion[e] = traj_motion(ref, n);
        fprintf(stderr, "crossover E %.0e: reference %s, %.2f s/frame, motion %.3g m\n", E, rr.ok ? "ok" : "FAILED",
                rr.cpu_per_frame, disp);
        fprintf(md,
                "## E = %.0e Pa (c = %.0f m/s; reference %.2f CPU s/frame; motion %.3g m)\n\n"
                "| integrator | step | CPU s/frame | RMS error (m) | error / dx | error / motion | substeps | Newton | "
                "CG |\n"
                "|---|---|---|---|---|---|---|---|---|\n",
                E, c, rr.cpu_per_frame, disp);
        for (int k = 0; k < XO_NKIND; k++)
            for (int b = 0; b < XO_NBUDGET; b++) cost[e][k][b] = INFINITY, best_n[e][k][b] = 0;
        for (int j = 0; j < 2 + 2 * XO_NSTEPS; j++) {
            const integ how = j < 2 ? EXPLICIT : j < 2 + XO_NSTEPS ? BACKWARD_EULER : MIDPOINT;
            const int steps = how ? XO_STEPS[g_tumble][(j - 2) % XO_NSTEPS] : 0;
            const double cfl = how ? 0.4 : (j ? 0.8 : 0.4);
            /* a hair over 1/(24 n) so that round-off cannot split the last step */
            const double dt = how ? (1.0 / FPS) / steps * (1 + 1e-12) : 0;
            run r = simulate_median(E, how, KF_PRECOND_MULTIGRID, cfl, dt, x, &n);
            compare(&r, x, ref, n);
            char step[48];
            if (how) snprintf(step, sizeof step, "%d / frame", steps);
            else snprintf(step, sizeof step, "CFL %.1f", cfl);
            fprintf(md, "| %s | %s | %.4f | %s%.3g | %.3g | %.3g | %ld | %ld | %ld |\n", KIND_NAME[how], step,
                    r.cpu_per_frame, r.ok ? "" : "failed ", r.rms, r.rms / g_dx, r.rms / disp, r.substeps, r.newton,
                    r.krylov);
            fprintf(csv, "%g,%s,%g,%d,%d,%.6g,%.6g,%.6g,%ld,%ld,%ld\n", E, KIND_NAME[how], how ? 0 : cfl, steps, r.ok,
                    r.cpu_per_frame, r.rms, disp, r.substeps, r.newton, r.krylov);
            fprintf(stderr, "  %-14s %-10s %.4f s/frame  rms %.3g m  substeps %ld newton %ld cg %ld\n", KIND_NAME[how],
                    step, r.cpu_per_frame, r.rms, r.substeps, r.newton, r.krylov);
            for (int b = 0; b < XO_NBUDGET; b++)
                if (r.ok && r.rms <= XO_BUDGET[b] * g_dx && r.cpu_per_frame < cost[e][how][b]) {
                    cost[e][how][b] = r.cpu_per_frame;
                    best_n[e][how][b] = steps;
                }
        }
        fprintf(md, "\n");
    }
    /* the verdict per budget, and the plot's data (E, explicit, backward
     * Euler, midpoint; NaN = none meets it or it is above the motion) */
    fprintf(md, "## The cheapest run meeting each error budget (CPU s/frame; bold: the cheapest)\n\n"
                "Implicit columns: backward Euler / midpoint, each with its steps per frame.\n\n| E | motion (m) |");
    for (int b = 0; b < XO_NBUDGET; b++)
        fprintf(md, " %.3g dx (%.2g m): explicit | implicit |", XO_BUDGET[b], XO_BUDGET[b] * g_dx);
    fprintf(md, "\n|---|---|");
    for (int b = 0; b < XO_NBUDGET; b++) fprintf(md, "---|---|");
    fprintf(md, "\n");
    for (int e = 0; e < nE; e++) {
        fprintf(md, "| %.0e | %.2g |", Es[e], motion[e]);
        for (int b = 0; b < XO_NBUDGET; b++) {
            const double ex = cost[e][EXPLICIT][b], im = fmin(cost[e][BACKWARD_EULER][b], cost[e][MIDPOINT][b]);
            if (XO_BUDGET[b] * g_dx >= motion[e]) {
                fprintf(md, " above the motion | |");
                continue;
            }
            if (isfinite(ex)) fprintf(md, " %s%.4f%s |", ex <= im ? "**" : "", ex, ex <= im ? "**" : "");
            else fprintf(md, " none |");
            for (int k = BACKWARD_EULER; k <= MIDPOINT; k++) {
                const double ck = cost[e][k][b];
                const int bold = ck < ex && ck <= im;
                if (isfinite(ck))
                    fprintf(md, "%s%s%.4f (%d / frame)%s", k == MIDPOINT ? " / " : " ", bold ? "**" : "", ck,
                            best_n[e][k][b], bold ? "**" : "");
                else fprintf(md, "%snone", k == MIDPOINT ? " / " : " ");
            }
            fprintf(md, " |");
        }
        fprintf(md, "\n");
    }
    fprintf(md, "\n");
    for (int b = 0; b < XO_NBUDGET; b++) {
        const double budget = XO_BUDGET[b] * g_dx;
        snprintf(path, sizeof path, "%s/%s_%d.dat", out, name, b);
        FILE *d = fopen(path, "w");
        if (d)
            fprintf(d,
                    "# E explicit backward_euler midpoint: CPU s/frame of the cheapest run within %g dx (NaN = none "
                    "meets it, or it is above the motion)\n",
                    XO_BUDGET[b]);
        for (int e = 0; e < nE && d; e++) {
            const int counts = budget < motion[e];
            fprintf(d, "%g", Es[e]);
            for (int k = 0; k < XO_NKIND; k++)
                fprintf(d, " %.6g", counts && isfinite(cost[e][k][b]) ? cost[e][k][b] : NAN);
            fprintf(d, "\n");
        }
        if (d) fclose(d);
        /* per counted E: which is the cheaper within the budget, explicit or
         * the better implicit scheme (or none meets it); the crossover:
         * implicit at every counted E from Es[from] on */
        char who[8];
        int from = -1, counted = 0;
        for (int e = 0; e < nE; e++) {
            const double ex = cost[e][EXPLICIT][b], im = fmin(cost[e][BACKWARD_EULER][b], cost[e][MIDPOINT][b]);
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
        else if (from >= 0) {
            const double ex = cost[from][EXPLICIT][b], be = cost[from][BACKWARD_EULER][b], mp = cost[from][MIDPOINT][b];
            fprintf(md, "**implicit is the cheaper from E = %.0e on** (%s there, %.2fx cheaper)", Es[from],
                    mp <= be ? "midpoint" : "backward Euler", ex / fmin(be, mp));
        } else fprintf(md, "implicit is not the cheaper at the stiffest E where the budget counts");
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
