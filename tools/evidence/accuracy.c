/* accuracy.c — error against cost for V4 (bar), V5 (manufactured solution)
 * and V6 (breathing sphere): Δx, CFL, kernel, force and particles-per-cell
 * sweeps .
 *
 *   kf_evid_accuracy --out DIR [--quick] [--tables-only]
 *
 * --tables-only rewrites the tables and plot files from DIR/accuracy.csv.
 *
 * Every run is on 1 thread and costs the process CPU time spent inside
 * kf_step (CLOCK_PROCESS_CPUTIME_ID), so other work on the machine does not
 * inflate it; runs under 1 s are repeated and the median CPU time kept (the
 * error is deterministic and checked identical across repeats).
 * Writes into DIR:
 *   accuracy.csv              every run
 *   accuracy.md               tables, fitted orders, the cheapest variant per error budget
 *   dx_<problem>_<variant>.dat   dx, error, cpu (header = plot title with the fitted order)
 *   fit_<problem>_<variant>.dat  the fitted power law at the ends of the dx range
 *   cost_<problem>_<variant>.dat cpu, error (the Δx sweep, for the work–precision plot)
 *   pareto_<problem>.dat         the Pareto front over all runs of the problem
 *   cfl_<problem>_<variant>.dat  cfl, error, cpu */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../../tests/problems/problems.h"
#include "../median.h"

typedef ev_run (*ev_problem_fn)(double res, const ev_variant *v);

typedef struct problem {
    const char *name, *title, *res_name, *error_name;
    ev_problem_fn run;
    double res[5]; /* the Δx sweep (cells per length scale), coarse to fine */
    int nres;
    double cfl_res; /* resolution of the CFL sweep */
} problem;

typedef struct row {
    const char *sweep;
    int problem;
    ev_variant v;
    double res;
    ev_run r;
    int pareto;
} row;

static row rows[1024];
static int nrows;

/* one point: repeated (at most 3 runs) when short, median CPU time */
static ev_run measure(const problem *p, double res, const ev_variant *v) {
    ev_run r = p->run(res, v);
    if (r.ok && r.cpu_s < 1.0) {
        double c[3] = {r.cpu_s, 0, 0};
        for (int k = 1; k < 3; k++) {
            ev_run again = p->run(res, v);
            c[k] = again.cpu_s;
            if (again.error != r.error) fprintf(stderr, "accuracy: %s repeat gave a different error\n", p->name);
        }
        r.cpu_s = kf_median(c, 3);
    }
    return r;
}

static void add(const char *sweep, int pi, const problem *p, double res, const ev_variant *v) {
    char name[64];
    ev_run r = measure(p, res, v);
    rows[nrows++] = (row){sweep, pi, *v, res, r, 0};
    fprintf(stderr,
            "  %-4s %-6s %-16s C=%.2f res %6.2f: %8ld particles x %5ld steps, %8.3f s CPU, %6.1f ns/p-step, "
            "error %.3e%s\n",
            sweep, p->name, ev_variant_name(v, name, sizeof name), v->cfl, res, r.particles, r.steps, r.cpu_s,
            1e9 * r.cpu_s / ((double)r.particles * r.steps), r.error, r.ok ? "" : "  (FAILED)");
}

static int same_variant(const ev_variant *a, const ev_variant *b) {
    return a->kernel == b->kernel && a->force == b->force && a->ppc == b->ppc && a->cfl == b->cfl;
}

/* --tables-only: the runs back from DIR/accuracy.csv (as this program wrote
 * it), to redo the tables and plot files without simulating again */
static int read_csv(const char *dir, const char *const names[3]) {
    char path[1024], line[1024];
    snprintf(path, sizeof path, "%s/accuracy.csv", dir);
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    if (!fgets(line, sizeof line, f)) return -1;
    while (fgets(line, sizeof line, f) && nrows < (int)(sizeof rows / sizeof *rows)) {
        char sweep[8], prob[16], vname[32], kernel[16], force[16];
        int ppc, ok, pareto;
        double cfl, res, dx, cpu, nsps, err, val;
        long np, steps;
        if (sscanf(line, "%7[^,],%15[^,],%31[^,],%15[^,],%15[^,],%d,%lf,%lf,%lf,%ld,%ld,%lf,%lf,%lf,%lf,%d,%d", sweep,
                   prob, vname, kernel, force, &ppc, &cfl, &res, &dx, &np, &steps, &cpu, &nsps, &err, &val, &ok,
                   &pareto) != 17)
            continue;
        row *w = &rows[nrows];
        w->sweep = strcmp(sweep, "dx") ? "cfl" : "dx";
        w->problem = -1;
        for (int p = 0; p < 3; p++)
            if (!strcmp(prob, names[p])) w->problem = p;
        if (w->problem < 0) continue;
        w->v = (ev_variant){strcmp(kernel, "cubic") ? KF_KERNEL_QUADRATIC : KF_KERNEL_CUBIC,
                            strcmp(force, "classic") ? KF_FORCE_MLS : KF_FORCE_CLASSIC,
                            ppc == 27 ? 3 : 2,
                            cfl,
                            1,
                            KF_TRANSFER_APIC,
                            0};
        w->res = res;
        w->r = (ev_run){err, val, cpu, np, steps, ok};
        nrows++;
    }
    fclose(f);
    return 0;
}

/* least-squares slope and intercept of log(error) against log(dx) */
static void fit_order(const double *dx, const double *e, int n, double *order, double *logc) {
    double sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (int i = 0; i < n; i++) {
        double x = log(dx[i]), y = log(e[i]);
        sx += x, sy += y, sxx += x * x, sxy += x * y;
    }
    *order = n >= 2 ? (n * sxy - sx * sy) / (n * sxx - sx * sx) : 0;
    *logc = n >= 1 ? (sy - *order * sx) / n : 0;
}

static FILE *open_out(const char *dir, const char *name) {
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, name);
    FILE *f = fopen(path, "w");
    if (!f) {
        fprintf(stderr, "accuracy: cannot write %s\n", path);
        exit(1);
    }
    return f;
}

int main(int argc, char **argv) {
    const char *dir = ".";
    int quick = 0, tables_only = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--out") && i + 1 < argc) dir = argv[++i];
        else if (!strcmp(argv[i], "--quick")) quick = 1;
        else if (!strcmp(argv[i], "--tables-only")) tables_only = 1;
        else {
            fprintf(stderr, "usage: kf_evid_accuracy --out DIR [--quick] [--tables-only]\n");
            return 2;
        }
    }
    problem probs[3] = {
        {"bar", "V4 axial bar: period error", "L/dx", "rel. period error", ev_bar, {12.5, 25, 50, 100}, 4, 25},
        {"mms",
         "V5 manufactured solution: RMS displacement error / A after one period",
         "1/dx",
         "RMS error / A",
         ev_mms,
         {8, 12, 16, 24},
         4,
         12},
        {"sphere",
         "V6 breathing sphere: frequency error",
         "a/dx",
         "rel. frequency error",
         ev_sphere,
         {6, 8, 12, 16},
         4,
         8},
    };
    if (quick)
        for (int p = 0; p < 3; p++) probs[p].nres = 2;
    /* the variants of the Δx sweep: kernel x force at 8 particles per cell,
     * and 27 per cell for the MLS force of each kernel */
    const ev_variant variants[] = {
        {KF_KERNEL_QUADRATIC, KF_FORCE_MLS, 2, 0.3, 1, KF_TRANSFER_APIC, 0},
        {KF_KERNEL_QUADRATIC, KF_FORCE_CLASSIC, 2, 0.3, 1, KF_TRANSFER_APIC, 0},
        {KF_KERNEL_CUBIC, KF_FORCE_MLS, 2, 0.3, 1, KF_TRANSFER_APIC, 0},
        {KF_KERNEL_CUBIC, KF_FORCE_CLASSIC, 2, 0.3, 1, KF_TRANSFER_APIC, 0},
        {KF_KERNEL_QUADRATIC, KF_FORCE_MLS, 3, 0.3, 1, KF_TRANSFER_APIC, 0},
        {KF_KERNEL_CUBIC, KF_FORCE_MLS, 3, 0.3, 1, KF_TRANSFER_APIC, 0},
    };
    const int nvar = quick ? 2 : (int)(sizeof variants / sizeof *variants);
    const double cfls[] = {0.05, 0.1, 0.2, 0.3, 0.4, 0.6, 0.8};
    const int ncfl = quick ? 2 : 7;
    const ev_variant cfl_variants[] = {{KF_KERNEL_QUADRATIC, KF_FORCE_MLS, 2, 0, 1, KF_TRANSFER_APIC, 0},
                                       {KF_KERNEL_CUBIC, KF_FORCE_MLS, 2, 0, 1, KF_TRANSFER_APIC, 0}};

    const char *const pnames[3] = {probs[0].name, probs[1].name, probs[2].name};
    if (tables_only && read_csv(dir, pnames)) {
        fprintf(stderr, "accuracy: cannot read %s/accuracy.csv\n", dir);
        return 1;
    }
    for (int p = 0; p < 3 && !tables_only; p++) {
        fprintf(stderr, "%s\n", probs[p].title);
        for (int v = 0; v < nvar; v++)
            for (int k = 0; k < probs[p].nres; k++) add("dx", p, &probs[p], probs[p].res[k], &variants[v]);
        for (int v = 0; v < (quick ? 1 : 2); v++)
            for (int c = 0; c < ncfl; c++) {
                ev_variant cv = cfl_variants[v];
                cv.cfl = cfls[c];
                add("cfl", p, &probs[p], probs[p].cfl_res, &cv);
            }
    }

    /* the Pareto front per problem: no other run is both cheaper and more accurate */
    for (int i = 0; i < nrows; i++) {
        rows[i].pareto = rows[i].r.ok;
        for (int j = 0; j < nrows && rows[i].pareto; j++)
            if (j != i && rows[j].problem == rows[i].problem && rows[j].r.ok && rows[j].r.cpu_s <= rows[i].r.cpu_s &&
                rows[j].r.error <= rows[i].r.error &&
                (rows[j].r.cpu_s < rows[i].r.cpu_s || rows[j].r.error < rows[i].r.error))
                rows[i].pareto = 0;
    }

    FILE *csv = open_out(dir, "accuracy.csv");
    fprintf(csv, "sweep,problem,variant,kernel,force,particles_per_cell,cfl,res,dx,particles,steps,cpu_s,"
                 "ns_per_particle_step,error,value,ok,pareto\n");
    for (int i = 0; i < nrows; i++) {
        const row *w = &rows[i];
        char name[64];
        double dx = w->problem == 0 ? EV_BAR_L / w->res : 1.0 / w->res;
        fprintf(csv, "%s,%s,%s,%s,%s,%d,%.3f,%.2f,%.6g,%ld,%ld,%.4f,%.2f,%.6e,%.8g,%d,%d\n", w->sweep,
                probs[w->problem].name, ev_variant_name(&w->v, name, sizeof name),
                w->v.kernel == KF_KERNEL_CUBIC ? "cubic" : "quadratic",
                w->v.force == KF_FORCE_CLASSIC ? "classic" : "mls", w->v.ppc * w->v.ppc * w->v.ppc, w->v.cfl, w->res,
                dx, w->r.particles, w->r.steps, w->r.cpu_s, 1e9 * w->r.cpu_s / ((double)w->r.particles * w->r.steps),
                w->r.error, w->r.value, w->r.ok, w->pareto);
    }
    fclose(csv);

    FILE *md = open_out(dir, "accuracy.md");
    fprintf(md, "CPU seconds are process CPU time inside `kf_step` on 1 thread (median of 3 when under 1 s); "
                "ns/p-step = CPU ns per particle per step. Fitted order = least-squares slope of log error "
                "against log Δx over all levels. ★ = on the Pareto front of its problem.\n\n");
    for (int p = 0; p < 3; p++) {
        const problem *pr = &probs[p];
        fprintf(md, "### %s\n\nΔx sweep at CFL 0.3 (%s = ", pr->title, pr->res_name);
        for (int k = 0; k < pr->nres; k++) fprintf(md, "%s%g", k ? ", " : "", pr->res[k]);
        fprintf(md,
                "):\n\n| variant | %s | particles | steps | CPU s | ns/p-step | %s | "
                "|\n|---|---|---|---|---|---|---|---|\n",
                pr->res_name, pr->error_name);
        for (int i = 0; i < nrows; i++) {
            const row *w = &rows[i];
            char name[64];
            if (w->problem != p || strcmp(w->sweep, "dx")) continue;
            fprintf(md, "| %s | %g | %ld | %ld | %.3f | %.0f | %s%.3e | %s |\n",
                    ev_variant_name(&w->v, name, sizeof name), w->res, w->r.particles, w->r.steps, w->r.cpu_s,
                    1e9 * w->r.cpu_s / ((double)w->r.particles * w->r.steps), w->r.ok ? "" : "FAILED ", w->r.error,
                    w->pareto ? "★" : "");
        }
        /* fitted orders, and the per-variant plot files */
        fprintf(md, "\n| variant | fitted order | order, finest pair |\n|---|---|---|\n");
        for (int v = 0; v < nvar; v++) {
            double dx[8], e[8], cpu[8];
            int n = 0;
            for (int i = 0; i < nrows; i++) {
                const row *w = &rows[i];
                if (w->problem != p || strcmp(w->sweep, "dx") || !same_variant(&w->v, &variants[v]) || !w->r.ok)
                    continue;
                dx[n] = p == 0 ? EV_BAR_L / w->res : 1.0 / w->res, e[n] = w->r.error, cpu[n] = w->r.cpu_s, n++;
            }
            double order, logc;
            fit_order(dx, e, n, &order, &logc);
            double last = n >= 2 ? log(e[n - 2] / e[n - 1]) / log(dx[n - 2] / dx[n - 1]) : 0;
            char name[64], file[256];
            ev_variant_name(&variants[v], name, sizeof name);
            fprintf(md, "| %s | %.2f | %.2f |\n", name, order, last);
            snprintf(file, sizeof file, "dx_%s_%s.dat", pr->name, name);
            FILE *f = open_out(dir, file);
            fprintf(f, "\"dx\" \"%s (order %.2f)\" \"cpu\"\n", name, order);
            for (int i = 0; i < n; i++) fprintf(f, "%.6g %.6e %.5f\n", dx[i], e[i], cpu[i]);
            fclose(f);
            snprintf(file, sizeof file, "fit_%s_%s.dat", pr->name, name);
            f = open_out(dir, file);
            fprintf(f, "\"dx\" \"fit\"\n");
            if (n >= 2)
                fprintf(f, "%.6g %.6e\n%.6g %.6e\n", dx[0], exp(logc + order * log(dx[0])), dx[n - 1],
                        exp(logc + order * log(dx[n - 1])));
            fclose(f);
            snprintf(file, sizeof file, "cost_%s_%s.dat", pr->name, name);
            f = open_out(dir, file);
            fprintf(f, "\"cpu\" \"%s\"\n", name);
            for (int i = 0; i < n; i++) fprintf(f, "%.5f %.6e\n", cpu[i], e[i]);
            fclose(f);
        }
        /* CFL sweep */
        fprintf(md, "\nCFL sweep at %s = %g:\n\n| variant | CFL | steps | CPU s | error |\n|---|---|---|---|---|\n",
                pr->res_name, pr->cfl_res);
        for (int v = 0; v < (quick ? 1 : 2); v++) {
            char name[64], file[256];
            ev_variant_name(&cfl_variants[v], name, sizeof name);
            snprintf(file, sizeof file, "cfl_%s_%s.dat", pr->name, name);
            FILE *f = open_out(dir, file);
            fprintf(f, "\"cfl\" \"%s\" \"cpu\"\n", name);
            for (int i = 0; i < nrows; i++) {
                const row *w = &rows[i];
                if (w->problem != p || strcmp(w->sweep, "cfl") || w->v.kernel != cfl_variants[v].kernel) continue;
                fprintf(md, "| %s | %.2f | %ld | %.3f | %s%.3e |\n", name, w->v.cfl, w->r.steps, w->r.cpu_s,
                        w->r.ok ? "" : "FAILED ", w->r.error);
                if (w->r.ok) fprintf(f, "%.3f %.6e %.5f\n", w->v.cfl, w->r.error, w->r.cpu_s);
            }
            fclose(f);
        }
        /* Pareto front, sorted by cost */
        char file[256];
        snprintf(file, sizeof file, "pareto_%s.dat", pr->name);
        FILE *f = open_out(dir, file);
        fprintf(f, "\"cpu\" \"Pareto front\" \"label\"\n");
        double done = -1;
        for (;;) {
            int best = -1;
            for (int i = 0; i < nrows; i++)
                if (rows[i].problem == p && rows[i].pareto && rows[i].r.cpu_s > done &&
                    (best < 0 || rows[i].r.cpu_s < rows[best].r.cpu_s))
                    best = i;
            if (best < 0) break;
            char name[64];
            fprintf(f, "%.5f %.6e \"%s,C%.2g,%g\"\n", rows[best].r.cpu_s, rows[best].r.error,
                    ev_variant_name(&rows[best].v, name, sizeof name), rows[best].v.cfl, rows[best].res);
            done = rows[best].r.cpu_s;
        }
        fclose(f);
        /* the cheapest run that meets each error budget */
        fprintf(md,
                "\nCheapest run meeting an error budget:\n\n| budget | variant | CFL | %s | CPU s "
                "|\n|---|---|---|---|---|\n",
                pr->res_name);
        const double budgets[] = {3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5};
        for (int b = 0; b < 7; b++) {
            int best = -1;
            for (int i = 0; i < nrows; i++)
                if (rows[i].problem == p && rows[i].r.ok && rows[i].r.error <= budgets[b] &&
                    (best < 0 || rows[i].r.cpu_s < rows[best].r.cpu_s))
                    best = i;
            char name[64];
            if (best < 0) fprintf(md, "| %.0e | (none of the runs) | | | |\n", budgets[b]);
            else
                fprintf(md, "| %.0e | %s | %.2f | %g | %.3f |\n", budgets[b],
                        ev_variant_name(&rows[best].v, name, sizeof name), rows[best].v.cfl, rows[best].res,
                        rows[best].r.cpu_s);
        }
        fprintf(md, "\n");
    }
    fclose(md);
    int failed = 0;
    for (int i = 0; i < nrows; i++) failed += !rows[i].r.ok;
    fprintf(stderr, "accuracy: %d runs, %d failed; wrote %s/accuracy.csv and accuracy.md\n", nrows, failed, dir);
    return 0;
}
