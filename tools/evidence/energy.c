/* energy.c — the paper's Fig. 17: total energy against time for the
 * oscillating stretched cube and two colliding balls, MLS against classic
 * force (V7, V8 setups ).
 *
 *   kf_evid_energy --out DIR [--quick]
 *
 * cube:  side 1, F₀ = 1.1 I, fixed corotated E = 1e3, ν = 0.3, ρ = 1, no
 *        gravity, 16 cells across, 2³ particles per cell, fixed Δt at CFL 0.3,
 *        t ∈ [0, 0.3] (about 6 periods).
 * balls: two spheres of radius 0.2 (10 cells), same material, centres 0.46
 *        apart (a gap of 0.06), approaching at 2 m/s each, no gravity,
 *        t ∈ [0, 0.15].
 * Energy = kinetic + elastic (kf_state_energy), sampled every step, divided by
 * its initial value. Writes DIR/energy_cube.dat, DIR/energy_balls.dat
 * (t, MLS, classic) and DIR/energy.md. 1 thread. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../../tests/problems/ringing.h"

static ev_series run(int balls, kf_force force, int quick) {
    const double rho = 1, E = 1e3, nu = 0.3, cp = ev_cp(rho, E, nu);
    const double dx = balls ? 0.02 : (quick ? 1.0 / 8 : 1.0 / 16), v0 = balls ? 2.0 : 0;
    const double dt = 0.3 * dx / (cp + v0), tend = balls ? 0.15 : 0.3;
    ev_variant v = {KF_KERNEL_QUADRATIC, force, 2, 0.3, 1, KF_TRANSFER_APIC, 0};
    kf_material mat = ev_corotated(rho, E, nu);
    int id;
    kf_model *m = ev_model(&v, dx, dt, &mat, &id);
    if (!m) exit(1);
    kf_state *s = kf_state_create(m);
    if (balls) {
        const double r = quick ? 0.1 : 0.2, c0[3] = {0.5 - r - 0.03, 0.5, 0.5}, c1[3] = {0.5 + r + 0.03, 0.5, 0.5};
        const double va[3] = {v0, 0, 0}, vb[3] = {-v0, 0, 0};
        kf_state_fill_sphere(s, m, c0, r, id, va, 2, 0);
        kf_state_fill_sphere(s, m, c1, r, id, vb, 2, 0);
    } else if (ev_stretched_cube(s, m, id, (int)lround(1 / dx), EV_CUBE_STRETCH, NULL, 0) < 0) {
        exit(1);
    }
    ev_series out = ev_energy_series(m, s, dx, dt, (long)(tend / dt + 0.5));
    kf_state_destroy(s);
    kf_model_destroy(m);
    return out;
}

int main(int argc, char **argv) {
    const char *dir = ".";
    int quick = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--out") && i + 1 < argc) dir = argv[++i];
        else if (!strcmp(argv[i], "--quick")) quick = 1;
        else {
            fprintf(stderr, "usage: kf_evid_energy --out DIR [--quick]\n");
            return 2;
        }
    }
    char path[1024];
    snprintf(path, sizeof path, "%s/energy.md", dir);
    FILE *md = fopen(path, "w");
    if (!md) return 1;
    fprintf(md, "| case | force | steps | E(end)/E0 | max E/E0 | largest difference MLS − classic (E0) | CPU s |\n"
                "|---|---|---|---|---|---|---|\n");
    for (int b = 0; b < 2; b++) {
        ev_series a = run(b, KF_FORCE_MLS, quick), c = run(b, KF_FORCE_CLASSIC, quick);
        snprintf(path, sizeof path, "%s/energy_%s.dat", dir, b ? "balls" : "cube");
        FILE *f = fopen(path, "w");
        if (!f) return 1;
        fprintf(f, "\"t\" \"MLS-MPM\" \"MPM (classic force)\"\n");
        long n = a.n < c.n ? a.n : c.n;
        double dmax = 0;
        for (long i = 0; i < n; i++) {
            fprintf(f, "%.6f %.6f %.6f\n", a.t[i], a.e[i], c.e[i]);
            dmax = fmax(dmax, fabs(a.e[i] - c.e[i]));
        }
        fclose(f);
        for (int k = 0; k < 2; k++) {
            ev_series *s = k ? &c : &a;
            double mx = 0;
            for (long i = 0; i < s->n; i++) mx = fmax(mx, s->e[i]);
            fprintf(md, "| %s | %s | %ld | %s%.4f | %.4f | %.4f | %.2f |\n", b ? "colliding balls" : "oscillating cube",
                    k ? "classic" : "MLS", s->n - 1, s->ok ? "" : "FAILED ", s->e[s->n - 1], mx, dmax, s->cpu_s);
            fprintf(stderr,
                    "  %-16s %-7s %ld steps, E(end)/E0 %.4f, max %.4f, max |MLS - classic| %.4f E0, %.2f s CPU\n",
                    b ? "colliding balls" : "oscillating cube", k ? "classic" : "MLS", s->n - 1, s->e[s->n - 1], mx,
                    dmax, s->cpu_s);
        }
        ev_series_free(&a), ev_series_free(&c);
    }
    fclose(md);
    return 0;
}
