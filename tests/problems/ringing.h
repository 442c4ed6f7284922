/* ringing.h — free elastic bodies set ringing, and the energy they keep:
 * V7's stretched cube and a jelly bar ringing in bending. Shared by the
 * energy evidence (tools/evidence/energy.c, tools/evidence/flip.c) and the
 * flip transfer's test (tests/test_flip.c), so all of them ring the same
 * bodies. */
#ifndef KF_EVIDENCE_RINGING_H
#define KF_EVIDENCE_RINGING_H

#include "problems.h"

/* ---- V7: the stretched cube ------------------------------------------------
 * Rest side 1 centred on the origin, N cells across (Δx = 1/N), 2³
 * particles per cell on the rest lattice, released from x = s X, F = s I.
 * With v0: every particle moves at v0 plus a spin of `spin` rad/s about z
 * (a drift and a rotation, so that momentum is not trivially zero). Returns
 * kf_state_add_particles' answer (the first index, or < 0). */
#define EV_CUBE_STRETCH 1.1
#define EV_CUBE_T 0.0479 /* the fundamental's period at 16 cells, E = 1e3 (tests/test_energy.c) */

static inline long ev_stretched_cube(kf_state *s, const kf_model *m, int id, int N, double stretch, const double v0[3],
                                     double spin) {
    const double h = 0.5 / N;
    const size_t n = (size_t)8 * N * N * N;
    double *x = malloc(3 * n * sizeof *x), *F = malloc(9 * n * sizeof *F), *v = v0 ? malloc(3 * n * sizeof *v) : NULL;
    if (!x || !F || (v0 && !v)) {
        free(x), free(F), free(v);
        return -1;
    }
    size_t k = 0;
    for (int i = -N; i < N; i++)
        for (int j = -N; j < N; j++)
            for (int l = -N; l < N; l++, k++) {
                double q[3] = {(i + 0.5) * h, (j + 0.5) * h, (l + 0.5) * h};
                for (int a = 0; a < 3; a++) x[3 * k + a] = stretch * q[a];
                for (int e = 0; e < 9; e++) F[9 * k + e] = e % 4 == 0 ? stretch : 0;
                if (v0) {
                    v[3 * k] = v0[0] - spin * x[3 * k + 1];
                    v[3 * k + 1] = v0[1] + spin * x[3 * k];
                    v[3 * k + 2] = v0[2];
                }
            }
    long first = kf_state_add_particles(s, m, n, x, v, F, id, h * h * h);
    free(x), free(F), free(v);
    return first;
}

/* ---- the ringing bar ---------------------------------------------------------
 * The jello preset's stiffness (E = 1e6, ν = 0.3, ρ = 1000), 0.4 m x 8 cm x
 * 12 cm at the default Δx = 2 cm (4 cells thick, 3840 particles), free, no
 * gravity, set ringing in its first bending mode by v_y = 1 m/s (2u² − 2/3)
 * with u = −1..1 along it (no net momentum). Its first bending period,
 * measured, is EV_RING_BAR_T. Returns the model, with the bar in *s; NULL
 * with a message on stderr. */
#define EV_RING_BAR_T 0.0715
#define EV_RING_BAR_DX 0.02

static inline kf_model *ev_ringing_bar(kf_transfer transfer, double ratio, int threads, kf_state **s) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = EV_RING_BAR_DX;
    sd.gravity[1] = 0;
    sd.walls = 0;
    sd.threads = threads;
    sd.transfer = transfer;
    sd.flip_ratio = ratio;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    if (!m) {
        fprintf(stderr, "ringing bar: model: %s\n", err);
        return NULL;
    }
    kf_material mat;
    kf_material_preset("jello", &mat);
    mat.E = 1e6, mat.nu = 0.3, mat.density = 1000;
    int id = kf_model_add_material(m, &mat, err, sizeof err);
    if (id < 0) {
        fprintf(stderr, "ringing bar: material: %s\n", err);
        kf_model_destroy(m);
        return NULL;
    }
    *s = kf_state_create(m);
    const double lo[3] = {0.3, 0.56, 0.44}, hi[3] = {0.7, 0.64, 0.56};
    kf_state_fill_box(*s, m, lo, hi, id, NULL, 2, 0);
    kf_particles_view pv = kf_state_particles(*s);
    for (size_t i = 0; i < pv.n; i++) {
        const double u = (pv.x[0][i] - 0.5) / 0.2;
        pv.v[1][i] = (kf_real)(2 * u * u - 2.0 / 3.0);
    }
    return m;
}

/* ---- the energy kept ---------------------------------------------------------
 * After every one of `steps` fixed steps of dt, relative to E₀:
 *  e: the plain energy E = Σ V₀ψ(F) + Σ ½ m |v|² (kf_state_energy);
 *  s: the staggered energy S_n = Σ ½ m (|v_n|² + tr(C_n D C_nᵀ)) +
 *     ½ (Σ V₀ψ(F_{n−1}) + Σ V₀ψ(F_n)), D = Δx²/4 I (the quadratic kernel):
 *     the kinetic energy with APIC's affine part, the strain energy
 *     averaged over the two ends of the step's move (tests/test_energy.c).
 *     Symplectic Euler's plain energy oscillates about what it conserves by
 *     ~ωΔt/2 of it within every period (4.5% for the cube at 16 cells and
 *     CFL 0.4), so E at one step is that much off; S is not (s[0] = 1).
 * and the process CPU time spent inside kf_step. ok = 0: a step reported
 * trouble (the series stops there). */
typedef struct ev_series {
    long n; /* samples: t[0..n), e[0..n), s[0..n) */
    double *t, *e, *s;
    double cpu_s;
    int ok;
} ev_series;

static inline ev_series ev_energy_series(const kf_model *m, kf_state *s, double dx, double dt, long steps) {
    ev_series out = {0};
    const size_t len = (size_t)(steps + 1) * sizeof(double);
    out.t = malloc(len), out.e = malloc(len), out.s = malloc(len);
    if (!out.t || !out.e || !out.s) return out;
    kf_energy e0 = kf_state_energy(m, s);
    const double E0 = e0.kinetic + e0.elastic, d = dx * dx / 4;
    double elastic_prev = e0.elastic;
    out.ok = 1;
    for (long st = 0; st <= steps; st++) {
        if (st > 0) {
            double c = ev_cpu_s();
            int bad = kf_step(m, s, dt, NULL, NULL);
            out.cpu_s += ev_cpu_s() - c;
            if (bad) {
                out.ok = 0;
                break;
            }
        }
        kf_energy e = kf_state_energy(m, s);
        /* read only: a writable view would make the next substep recompute the stress */
        kf_particles_view pv = kf_state_particles_read(s);
        double ka = 0;
        for (size_t i = 0; i < pv.n; i++) {
            double c2 = 0;
            for (int k = 0; k < 9; k++) c2 += (double)pv.C[k][i] * pv.C[k][i];
            ka += 0.5 * pv.mass[i] * d * c2;
        }
        out.t[st] = kf_state_time(s), out.e[st] = (e.kinetic + e.elastic) / E0;
        ka += kf_state_mode_energy(m, s); /* polypic's higher modes (0 otherwise) */
        out.s[st] = st == 0 ? 1 : (e.kinetic + ka + 0.5 * (elastic_prev + e.elastic)) / E0;
        elastic_prev = e.elastic;
        out.n = st + 1;
    }
    return out;
}

static inline void ev_series_free(ev_series *r) {
    free(r->t), free(r->e), free(r->s);
    r->t = r->e = r->s = NULL;
}

#endif
