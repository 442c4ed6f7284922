/* flip.c — the flip transfer (sim.transfer: flip) against APIC: the energy
 * a ringing jelly cube keeps, the cost per substep, and the work–precision
 * points of the accuracy problems.
 *
 *   kf_evid_flip --out DIR [--quick] [--repeat N] [--no-sweep] [--no-energy] [--bar] [--polypic]
 *
 * --polypic: the polypic transfer instead (sim.transfer: polypic): the
 * energy runs for APIC, polypic and flip 0.95, cost and sweep for APIC and
 * polypic, into DIR/polypic*.dat and DIR/polypic.md.
 * --no-energy skips the energy runs (cost and sweep only), --bar runs the
 * bar's energy alone.
 *
 * cube:  V7's stretched cube (tests/problems/ringing.h): side 1, F₀ = 1.1 I,
 *        fixed corotated E = 1e3, ν = 0.3, ρ = 1, no gravity, 16 cells
 *        across (8 with --quick), 8 particles per cell, fixed step at CFL
 *        0.4 (the default) and 0.1, t ∈ [0, 0.48] (10 periods of
 *        T = 0.0479). Energy = kinetic + elastic (kf_state_energy) / E₀,
 *        and the staggered S (ringing.h).
 * cost:  the cube's first 150 substeps at CFL 0.4, APIC and flip
 *        alternating, N times each (--repeat, default 5): median process
 *        CPU seconds per substep inside kf_step, 1 thread.
 * sweep: the Δx sweeps of V4 (bar), V5 (manufactured solution) and V6
 *        (breathing sphere) of accuracy.c at CFL 0.3, quad-mls-8, APIC and
 *        flip: error against CPU time (the work–precision plot).
 * Writes DIR/flip_energy.dat (t, then E/E₀ per run at CFL 0.4),
 * DIR/flip_energy_cfl01.dat (the same at CFL 0.1), DIR/flip_wp_<problem>.dat
 * (cpu error per variant, blank-line separated) and DIR/flip.md. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../../tests/problems/ringing.h"
#include "../median.h"

#define CUBE_T EV_CUBE_T
#define BAR_T EV_RING_BAR_T

typedef struct variant {
    const char *name;
    kf_transfer transfer;
    double ratio;
} variant;

static const variant FLIP_VARIANTS[] = {{"APIC", KF_TRANSFER_APIC, 0},
                                        {"flip 0.95", KF_TRANSFER_FLIP, 0.95},
                                        {"flip 0.99", KF_TRANSFER_FLIP, 0.99},
                                        {"flip 1", KF_TRANSFER_FLIP, 1.0},
                                        {"PIC", KF_TRANSFER_PIC, 0}};
/* --polypic: polypic against APIC and the default flip */
static const variant POLY_VARIANTS[] = {
    {"APIC", KF_TRANSFER_APIC, 0}, {"polypic", KF_TRANSFER_POLYPIC, 0}, {"flip 0.95", KF_TRANSFER_FLIP, 0.95}};
static const variant *VARIANTS = FLIP_VARIANTS;
static int NVAR = 5;
#define MAXVAR 5

typedef ev_series series;

/* the cube, run for `steps` substeps (all of tend when steps < 0) */
static series cube(const variant *var, double cfl, int quick, long steps) {
    const double rho = 1, E = 1e3, nu = 0.3, cp = ev_cp(rho, E, nu);
    const double dx = quick ? 1.0 / 8 : 1.0 / 16, dt = cfl * dx / cp, tend = 10 * CUBE_T;
    ev_variant v = {KF_KERNEL_QUADRATIC, KF_FORCE_MLS, 2, cfl, 1, var->transfer, var->ratio};
    kf_material mat = ev_corotated(rho, E, nu);
    int id;
    kf_model *m = ev_model(&v, dx, dt, &mat, &id);
    if (!m) exit(1);
    kf_state *s = kf_state_create(m);
    if (ev_stretched_cube(s, m, id, (int)lround(1 / dx), EV_CUBE_STRETCH, NULL, 0) < 0) exit(1);
    if (steps < 0) steps = (long)(tend / dt + 0.5);
    series out = ev_energy_series(m, s, dx, dt, steps);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return out;
}

/* the ringing bar (ringing.h) at CFL cfl for `tend` seconds */
static series bar(const variant *var, double cfl, double tend) {
    kf_state *s;
    kf_model *m = ev_ringing_bar(var->transfer, var->ratio, 1, &s);
    if (!m) exit(1);
    const double dt = cfl * EV_RING_BAR_DX / ev_cp(1000, 1e6, 0.3);
    series out = ev_energy_series(m, s, EV_RING_BAR_DX, dt, (long)(tend / dt + 0.5));
    kf_state_destroy(s);
    kf_model_destroy(m);
    return out;
}

/* energy at CFL cfl for every variant: the .dat file and the table rows */
static void energy(FILE *md, const char *dir, const char *file, int is_bar, double cfl, int quick) {
    series r[MAXVAR];
    for (int v = 0; v < NVAR; v++) {
        r[v] = is_bar ? bar(&VARIANTS[v], cfl, 10 * BAR_T) : cube(&VARIANTS[v], cfl, quick, -1);
        fprintf(stderr, "  %s cfl %.2f %-9s %ld steps: E(10T)/E0 %.4f, S(10T)/E0 %.4f, %.2f s CPU%s\n",
                is_bar ? "bar" : "cube", cfl, VARIANTS[v].name, r[v].n - 1, r[v].e[r[v].n - 1], r[v].s[r[v].n - 1],
                r[v].cpu_s, r[v].ok ? "" : " FAILED");
    }
    char path[1024];
    snprintf(path, sizeof path, "%s/%s", dir, file);
    FILE *f = fopen(path, "w");
    if (!f) exit(1);
    fprintf(f, "\"t\"");
    for (int v = 0; v < NVAR; v++) fprintf(f, " \"%s\"", VARIANTS[v].name);
    fprintf(f, "\n");
    long n = r[0].n;
    for (int v = 1; v < NVAR; v++) n = r[v].n < n ? r[v].n : n;
    for (long i = 0; i < n; i++) {
        fprintf(f, "%.6f", r[0].t[i]);
        for (int v = 0; v < NVAR; v++) fprintf(f, " %.6f", r[v].e[i]);
        fprintf(f, "\n");
    }
    fclose(f);
    for (int v = 0; v < NVAR; v++) {
        /* at each whole period: the energy is sampled where the cube is
         * back near its stretched start */
        const long per = (long)((double)(r[v].n - 1) / 10 + 0.5);
        fprintf(md, "| %s | %.1f | %s | %ld | %s%.4f | %.4f | %.4f | %.4f |\n", is_bar ? "bar" : "cube", cfl,
                VARIANTS[v].name, r[v].n - 1, r[v].ok ? "" : "FAILED ", r[v].e[r[v].n - 1], r[v].s[r[v].n - 1],
                r[v].e[per < r[v].n ? per : r[v].n - 1], r[v].e[5 * per < r[v].n ? 5 * per : r[v].n - 1]);
        ev_series_free(&r[v]);
    }
}

int main(int argc, char **argv) {
    const char *dir = ".";
    int quick = 0, repeat = 5, sweep = 1, only_bar = 0, no_energy = 0, poly = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--out") && i + 1 < argc) dir = argv[++i];
        else if (!strcmp(argv[i], "--quick")) quick = 1;
        else if (!strcmp(argv[i], "--no-sweep")) sweep = 0;
        else if (!strcmp(argv[i], "--bar")) only_bar = 1;
        else if (!strcmp(argv[i], "--no-energy")) no_energy = 1;
        else if (!strcmp(argv[i], "--polypic")) VARIANTS = POLY_VARIANTS, NVAR = 3, poly = 1;
        else if (!strcmp(argv[i], "--repeat") && i + 1 < argc) repeat = atoi(argv[++i]);
        else {
            fprintf(stderr, "usage: kf_evid_flip --out DIR [--quick] [--repeat N] [--no-sweep]\n");
            return 2;
        }
    }
    if (repeat < 1 || repeat > 99) repeat = 5;
    char path[1024];
    const char *pre = poly ? "polypic" : "flip";
    snprintf(path, sizeof path, "%s/%s.md", dir, pre);
    FILE *md = fopen(path, "w");
    if (!md) return 1;

    /* energy over 10 periods */
    if (!no_energy)
        fprintf(md,
                "Total energy (kinetic + elastic) / E0 after 1, 5 and 10 periods of the fundamental: the ringing "
                "bar (jello, 4 cells thick at the default dx = 2 cm, T = %.4f s) and V7's ringing cube (%d cells "
                "across, T = %.4f s); 8 particles per cell, fixed step. S: the staggered energy symplectic Euler "
                "conserves (tests/problems/ringing.h), which the plain E oscillates about within each period:\n\n",
                BAR_T, quick ? 8 : 16, CUBE_T);
    if (!no_energy) {
        fprintf(md, "| body | CFL | transfer | steps | E(10T)/E0 | S(10T)/E0 | E(T)/E0 | E(5T)/E0 |\n"
                    "|---|---|---|---|---|---|---|---|\n");
        char name[64];
        snprintf(name, sizeof name, "%s_bar.dat", pre);
        energy(md, dir, name, 1, 0.4, quick);
        snprintf(name, sizeof name, "%s_bar_cfl01.dat", pre);
        energy(md, dir, name, 1, 0.1, quick);
        if (only_bar) return 0;
        snprintf(name, sizeof name, "%s_energy.dat", pre);
        energy(md, dir, name, 0, 0.4, quick);
        snprintf(name, sizeof name, "%s_energy_cfl01.dat", pre);
        energy(md, dir, name, 0, 0.1, quick);
    }

    /* cost per substep, A/B alternating */
    double cost[2][99];
    const variant *ab[2] = {&VARIANTS[0], &VARIANTS[1]};
    const long steps = 150;
    for (int k = 0; k < repeat; k++)
        for (int v = 0; v < 2; v++) {
            series r = cube(ab[v], 0.4, quick, steps);
            cost[v][k] = r.cpu_s / (double)(r.n - 1);
            ev_series_free(&r);
        }
    double med[2] = {kf_median(cost[0], repeat), kf_median(cost[1], repeat)};
    fprintf(md,
            "\nCost per substep (the cube at CFL 0.4, %ld substeps, %d runs each alternating, 1 thread, median "
            "process CPU time inside kf_step):\n\n| transfer | ms per substep | min | max |\n|---|---|---|---|\n",
            steps, repeat);
    for (int v = 0; v < 2; v++) {
        double lo = cost[v][0], hi = cost[v][0];
        for (int k = 1; k < repeat; k++) lo = cost[v][k] < lo ? cost[v][k] : lo, hi = cost[v][k] > hi ? cost[v][k] : hi;
        fprintf(md, "| %s | %.3f | %.3f | %.3f |\n", ab[v]->name, 1e3 * med[v], 1e3 * lo, 1e3 * hi);
    }
    fprintf(md, "\n%s / APIC: %.3f\n", ab[1]->name, med[1] / med[0]);
    fprintf(stderr, "  cost per substep: APIC %.3f ms, %s %.3f ms (x%.3f)\n", 1e3 * med[0], ab[1]->name, 1e3 * med[1],
            med[1] / med[0]);

    /* the work–precision points */
    if (sweep) {
        typedef ev_run (*fn)(double, const ev_variant *);
        const struct {
            const char *name;
            fn run;
            double res[4];
        } probs[3] = {{"bar", ev_bar, {12.5, 25, 50, 100}},
                      {"mms", ev_mms, {8, 12, 16, 24}},
                      {"sphere", ev_sphere, {6, 8, 12, 16}}};
        fprintf(md, "\nWork–precision (accuracy.c's Δx sweeps, quad-mls-8, CFL 0.3, 1 thread, CPU s inside "
                    "kf_step, median of 3 where under 1 s):\n\n| problem | res | transfer | CPU s | error |\n"
                    "|---|---|---|---|---|\n");
        for (int p = 0; p < 3; p++) {
            snprintf(path, sizeof path, "%s/%s_wp_%s.dat", dir, pre, probs[p].name);
            FILE *f = fopen(path, "w");
            if (!f) return 1;
            for (int v = 0; v < 2; v++) {
                ev_variant ev = {KF_KERNEL_QUADRATIC, KF_FORCE_MLS, 2, 0.3, 1, ab[v]->transfer, ab[v]->ratio};
                fprintf(f, "\"%s\"\n", ab[v]->name);
                for (int k = 0; k < (quick ? 2 : 4); k++) {
                    ev_run r = probs[p].run(probs[p].res[k], &ev);
                    if (r.ok && r.cpu_s < 1.0) {
                        double c[3] = {r.cpu_s, 0, 0};
                        for (int q = 1; q < 3; q++) c[q] = probs[p].run(probs[p].res[k], &ev).cpu_s;
                        r.cpu_s = kf_median(c, 3);
                    }
                    fprintf(f, "%.6g %.6g\n", r.cpu_s, r.error);
                    fprintf(md, "| %s | %g | %s | %.3f | %s%.4g |\n", probs[p].name, probs[p].res[k], ab[v]->name,
                            r.cpu_s, r.ok ? "" : "FAILED ", r.error);
                    fprintf(stderr, "  %s res %g %s: %.3f s, error %.4g\n", probs[p].name, probs[p].res[k], ab[v]->name,
                            r.cpu_s, r.error);
                }
                fprintf(f, "\n\n");
            }
            fclose(f);
        }
    }
    fclose(md);
    return 0;
}
