/* stress.h — stability measurements shared by tools/evidence/stability.c and
 * tests/test_evidence_stability.c: the largest stable CFL number of a free
 * block by bisection, and the recovery of kf_advance from numerical trouble.
 *
 * The threshold problem: a free block (no gravity, no walls) of 8³ cells,
 * 2³ particles per cell, of a preset material, set moving by a smooth
 * velocity field of amplitude 2% of its wave speed c (a shear on a uniform
 * compression, which loads every model, sand too) plus a 1e-4 relative random part that seeds every grid
 * mode. Each substep is Δt = C Δx / (c + |v|max) from kf_stable_dt (the rule
 * the solver uses), for a fixed number of substeps. It is unstable when a
 * step reports trouble (NaN, J out of range, CFL violated) or when the
 * kinetic + elastic energy exceeds 1.5x its initial value (the problem has
 * no energy source, so growth is the integrator's). */
#ifndef KF_EVIDENCE_STRESS_H
#define KF_EVIDENCE_STRESS_H

#include "problems.h"

typedef struct ev_stab {
    int stable;
    char why[96]; /* what ended an unstable run */
    long steps;
    double energy_ratio; /* largest (K + U) / (K + U)₀ seen */
} ev_stab;

static inline double ev_lcg(uint32_t *s) {
    *s = *s * 1664525u + 1013904223u;
    return ((*s >> 8) * (1.0 / 16777216.0)) * 2 - 1;
}

/* A model + state of the threshold problem. cells = block size in cells. */
static inline kf_state *ev_block_state(kf_kernel kernel, kf_force force, const char *preset, int cells, int threads,
                                       kf_model **mout) {
    kf_material mat;
    if (kf_material_preset(preset, &mat)) return NULL;
    ev_variant v = {kernel, force, 2, 0, threads, KF_TRANSFER_APIC, 0};
    const double dx = 0.02;
    int id;
    kf_model *m = ev_model(&v, dx, 0, &mat, &id);
    if (!m) return NULL;
    kf_state *s = kf_state_create(m);
    const double L = cells * dx, lo[3] = {0.3, 0.3, 0.3}, hi[3] = {0.3 + L, 0.3 + L, 0.3 + L}, zero[3] = {0, 0, 0};
    kf_state_fill_box(s, m, lo, hi, id, zero, 2, 0);
    /* c at rest: the unit-CFL step is Δx / c with no motion yet */
    const double c = dx / kf_stable_dt(m, s, 1.0), amp = 0.02 * c;
    kf_particles_view pv = kf_state_particles(s);
    uint32_t seed = 12345u;
    for (size_t p = 0; p < pv.n; p++) {
        double u[3];
        for (int a = 0; a < 3; a++) u[a] = (pv.x[a][p] - lo[a]) / L; /* in [0, 1] */
        /* a shear along x varying in y on a uniform compression: the
         * compression loads every model, sand too (in tension it carries
         * no stress and would only fly apart) */
        pv.v[0][p] = (kf_real)(amp * (sin(EV_PI * u[1]) - (u[0] - 0.5)) + 1e-4 * amp * ev_lcg(&seed));
        pv.v[1][p] = (kf_real)(-amp * (u[1] - 0.5) + 1e-4 * amp * ev_lcg(&seed));
        pv.v[2][p] = (kf_real)(-amp * (u[2] - 0.5) + 1e-4 * amp * ev_lcg(&seed));
    }
    *mout = m;
    return s;
}

static inline ev_stab ev_stability_run(kf_kernel kernel, kf_force force, const char *preset, double cfl, long steps,
                                       int threads) {
    ev_stab out = {0};
    kf_model *m;
    kf_state *s = ev_block_state(kernel, force, preset, 8, threads, &m);
    if (!s) {
        snprintf(out.why, sizeof out.why, "setup failed");
        return out;
    }
    kf_energy e0 = kf_state_energy(m, s);
    const double E0 = e0.kinetic + e0.elastic;
    out.stable = 1;
    out.energy_ratio = 1;
    for (long st = 0; st < steps; st++) {
        double dt = kf_stable_dt(m, s, cfl);
        kf_trouble tr;
        if (kf_step(m, s, dt, NULL, &tr)) {
            out.stable = 0;
            snprintf(out.why, sizeof out.why, "%s at substep %ld", tr.what, st);
            out.steps = st;
            break;
        }
        if (st % 10 == 9 || st == steps - 1) {
            kf_energy e = kf_state_energy(m, s);
            double r = (e.kinetic + e.elastic) / E0;
            if (!(r <= out.energy_ratio)) out.energy_ratio = r;
            if (!(r < 1.5)) {
                out.stable = 0;
                snprintf(out.why, sizeof out.why, "energy grew %.3gx by substep %ld", r, st + 1);
                out.steps = st + 1;
                break;
            }
        }
        out.steps = st + 1;
    }
    kf_state_destroy(s);
    kf_model_destroy(m);
    return out;
}

/* The largest stable CFL number in [lo, hi] by bisection to a relative width
 * of `rel`: returns the last stable value (lo if even lo is unstable, which
 * *lo_unstable reports; hi if hi is stable). */
static inline double ev_cfl_threshold(kf_kernel kernel, kf_force force, const char *preset, double lo, double hi,
                                      double rel, long steps, int *lo_unstable, ev_stab *first_unstable) {
    *lo_unstable = 0;
    ev_stab a = ev_stability_run(kernel, force, preset, lo, steps, 1);
    if (!a.stable) {
        *lo_unstable = 1;
        if (first_unstable) *first_unstable = a;
        return lo;
    }
    ev_stab b = ev_stability_run(kernel, force, preset, hi, steps, 1);
    if (b.stable) return hi;
    if (first_unstable) *first_unstable = b;
    while (hi - lo > rel * lo) {
        double mid = 0.5 * (lo + hi);
        ev_stab r = ev_stability_run(kernel, force, preset, mid, steps, 1);
        if (r.stable) lo = mid;
        else {
            hi = mid;
            if (first_unstable) *first_unstable = r;
        }
    }
    return lo;
}

/* ---- recovery from numerical trouble --------------------------------------
 * The fault: kf_advance with sim.cfl above the measured blow-up threshold
 * (so its first attempt fails), against a reference run whose sim.cfl is the
 * CFL number the retry ended at. Same start state, same interval. */
typedef struct ev_recovery {
    int rc, rc_ref;
    int retries, retries_ref;
    double cfl_used;   /* sim.cfl / 2^retries */
    double max_dx_rel; /* max |x − x_ref| / Δx over particles */
    double max_dv_rel; /* max |v − v_ref| / max |v_ref| */
    uint64_t hash, hash_ref;
    char msg[512];
} ev_recovery;

static inline kf_state *ev_recovery_state(double cfl, int retries, kf_model **mout) {
    kf_material mat;
    kf_material_preset("rubber", &mat);
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.cfl = cfl;
    sd.max_retries = retries;
    sd.threads = 1;
    sd.walls = 1;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    if (!m) return NULL;
    int id = kf_model_add_material(m, &mat, err, sizeof err);
    kf_state *s = kf_state_create(m);
    const double lo[3] = {0.3, 0.1, 0.3}, hi[3] = {0.46, 0.26, 0.46}, v[3] = {0.5, -2, 0}, zero[3] = {0, 0, 0};
    kf_state_fill_box(s, m, lo, hi, id, zero, 2, 0);
    /* thrown at the floor, and strained from the first substep by
     * ev_block_state's shear on a uniform compression (2% of the wave
     * speed, with a little noise): the block's elastic modes start at a
     * fixed amplitude, so above the threshold the fault comes within a few
     * substeps on every machine. Thrown alone, its modes started from the
     * impact and round-off, and whether CFL 2 faulted within the interval
     * depended on the machine's roundings (an AVX2 build ran 0.4 s without
     * trouble where an AVX-512 build failed within 0.1 s) */
    const double c = sd.dx / kf_stable_dt(m, s, 1.0), amp = 0.02 * c;
    kf_particles_view pv = kf_state_particles(s);
    uint32_t seed = 12345u;
    for (size_t p = 0; p < pv.n; p++) {
        double u[3];
        for (int a = 0; a < 3; a++) u[a] = (pv.x[a][p] - lo[a]) / (hi[a] - lo[a]);
        pv.v[0][p] = (kf_real)(v[0] + amp * (sin(EV_PI * u[1]) - (u[0] - 0.5)) + 1e-4 * amp * ev_lcg(&seed));
        pv.v[1][p] = (kf_real)(v[1] - amp * (u[1] - 0.5) + 1e-4 * amp * ev_lcg(&seed));
        pv.v[2][p] = (kf_real)(v[2] - amp * (u[2] - 0.5) + 1e-4 * amp * ev_lcg(&seed));
    }
    *mout = m;
    return s;
}

static inline ev_recovery ev_recovery_check(double cfl, double duration) {
    ev_recovery out = {0};
    kf_model *m, *mr;
    kf_state *s = ev_recovery_state(cfl, 4, &m);
    if (!s) {
        snprintf(out.msg, sizeof out.msg, "the model refused sim.cfl = %g", cfl);
        out.rc = out.rc_ref = -1;
        return out;
    }
    kf_step_stats st = {0};
    out.rc = kf_advance(m, s, duration, &st, out.msg, sizeof out.msg);
    out.retries = st.retries;
    out.cfl_used = cfl / (1 << st.retries);
    kf_state *r = ev_recovery_state(out.cfl_used, 0, &mr);
    kf_step_stats sr = {0};
    char msg[512];
    out.rc_ref = kf_advance(mr, r, duration, &sr, msg, sizeof msg);
    out.retries_ref = sr.retries;
    kf_particles_view a = kf_state_particles_read(s), b = kf_state_particles_read(r);
    /* compare by stable id */
    double *xb = malloc(6 * b.n * sizeof *xb), vmax = 0;
    for (size_t p = 0; p < b.n; p++)
        for (int c = 0; c < 3; c++) {
            xb[6 * b.id[p] + c] = b.x[c][p], xb[6 * b.id[p] + 3 + c] = b.v[c][p];
            vmax = fmax(vmax, fabs(b.v[c][p]));
        }
    for (size_t p = 0; p < a.n && a.n == b.n; p++)
        for (int c = 0; c < 3; c++) {
            out.max_dx_rel = fmax(out.max_dx_rel, fabs(a.x[c][p] - xb[6 * a.id[p] + c]) / 0.02);
            out.max_dv_rel = fmax(out.max_dv_rel, fabs(a.v[c][p] - xb[6 * a.id[p] + 3 + c]) / vmax);
        }
    if (a.n != b.n) out.max_dx_rel = out.max_dv_rel = INFINITY;
    out.hash = kf_state_hash(s), out.hash_ref = kf_state_hash(r);
    free(xb);
    kf_state_destroy(s), kf_state_destroy(r);
    kf_model_destroy(m), kf_model_destroy(mr);
    return out;
}

#endif
