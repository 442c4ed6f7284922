/* test_material_forms.c — each constitutive model is written in three forms:
 * the per-particle stress (mpm/material.c: kf_mat_kirchhoff, and the energy
 * density kf_mat_energy_density), the batch stress over particle planes
 * (mpm/material_batch.c: kf_mat_update_batch) and the implicit solve's energy
 * with its first Piola–Kirchhoff stress (implicit/energy.c:
 * kf_imp_energy_eval). This test holds the three to one another for every
 * model at random states, so an edit to one form that the others do not get
 * fails here.
 *
 * States: F = Q1 diag(σ) Q2ᵀ with random rotations and σ in [0.7, 1.45]
 * (compressed, stretched, sheared; no inversion), with the per-model plastic
 * state (water's J, sand's v_c and q, snow's Jp) drawn in its working range.
 * Stress is compared in units of the model's stiffness E_s at the state
 * (2μ + 3λ for the solids, times snow's hardening e^{ξ(1 − Jp)}; κγ for
 * water) times the round-off unit u of kf_real:
 *   batch τ vs per-particle τ:   |Δτ_ij| ≤ B u E_s  (float SVD, polynomial
 *                                 log/exp in the batch; both round once)
 *   energy P Fᵀ vs per-particle τ: |Δτ_ij| ≤ B u E_s (the energy runs on the
 *                                 double F the particle holds, in double)
 *   energy ψ vs kf_mat_energy_density: |Δψ| ≤ B u E_s (1 + |ψ|/E_s)
 * with B = 16 in the float build and 64 in the double one (measured maxima:
 * float 6.8 batch, 4.0 energy, 0.6 ψ; double 31 batch (snow), 9.7, 4.6)
 * Water has no energy form (the implicit solve refuses it): kf_imp_energy_eval
 * must say so (-1). */
#include <math.h>
#include <stdint.h>
#include <string.h>

#include "implicit/implicit.h"
#include "kt.h"
#include "mpm/material.h"

/* u, and the bound in units of u E_s: in double the SVD behind the
 * per-particle update stops at a column cosine of 1e-15 (≈ 9 u), whose stress
 * error is a few of those, so the bound is 64 there */
#ifdef KF_DOUBLE
#define U_ 1.1e-16
#define BOUND 64
#else
#define U_ 6e-8
#define BOUND 16
#endif

#define KT_RNG_SEED 0x2545F4914F6CDD1Dull
#include "random_util.h"

enum { N = 2000, OFF = 3 };

static void make_F(kf_real F[9]) {
    double Q1[9], Q2[9], s[3];
    random_rotation(Q1);
    random_rotation(Q2);
    for (int k = 0; k < 3; k++) s[k] = 0.7 + 0.75 * urand();
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double t = 0;
            for (int k = 0; k < 3; k++) t += Q1[3 * i + k] * s[k] * Q2[3 * j + k];
            F[3 * i + j] = (kf_real)t;
        }
}

/* the model's plastic state in its working range */
static void make_ps(const kf_mat *m, kf_real ps[2]) {
    ps[0] = ps[1] = 0;
    if (m->model == KF_MAT_WATER) ps[0] = (kf_real)(0.9 + 0.2 * urand());
    if (m->model == KF_MAT_SAND) ps[0] = (kf_real)(0.02 * srand1()), ps[1] = (kf_real)(urand() * 3);
    if (m->model == KF_MAT_SNOW) ps[0] = (kf_real)(0.8 + 0.4 * urand());
}

/* the model's stiffness at the particle's state: snow's hardens as e^{ξ(1 − Jp)} */
static double stiffness(const kf_mat *m, const kf_real ps[2]) {
    if (m->model == KF_MAT_WATER) return (double)m->kappa * (double)m->gamma;
    double h = m->model == KF_MAT_SNOW ? exp((double)m->xi * (1 - (double)ps[0])) : 1;
    return h * (2 * (double)m->mu + 3 * (double)m->lambda);
}

static void forms_agree(const char *preset) {
    kf_material mat;
    KT_CHECK(kf_material_preset(preset, &mat) == 0, "preset %s", preset);
    kf_mat m;
    kf_mat_compile(&m, &mat);
    static kf_real pF[9][N + OFF], pps[2][N + OFF], ptau[6][N + OFF];
    kf_real *F9[9], *ps2[2], *tau6[6];
    for (int k = 0; k < 9; k++) F9[k] = pF[k];
    for (int k = 0; k < 2; k++) ps2[k] = pps[k];
    for (int k = 0; k < 6; k++) tau6[k] = ptau[k] + OFF; /* the output starts at the run's first particle */
    kf_real F[N][9], ps[N][2];
    for (int i = 0; i < N; i++) {
        make_F(F[i]);
        make_ps(&m, ps[i]);
        for (int k = 0; k < 9; k++) pF[k][OFF + i] = F[i][k];
        for (int k = 0; k < 2; k++) pps[k][OFF + i] = ps[i][k];
    }
    /* the batch form, stress only, from an offset that is not a SIMD boundary */
    kf_mat_update_batch(&m, N, F9, ps2, 0, OFF, tau6);
    double d_batch = 0, d_energy = 0, d_psi = 0;
    int refused = 0;
    static const int sym[6][2] = {{0, 0}, {1, 1}, {2, 2}, {0, 1}, {0, 2}, {1, 2}};
    for (int i = 0; i < N; i++) {
        const double Es = stiffness(&m, ps[i]);
        kf_real tau[9];
        kf_mat_kirchhoff(&m, F[i], ps[i], tau);
        for (int c = 0; c < 6; c++) {
            double d = fabs((double)ptau[c][OFF + i] - (double)tau[3 * sym[c][0] + sym[c][1]]) / (U_ * Es);
            if (!(d <= d_batch)) d_batch = d;
        }
        double Fd[9];
        for (int k = 0; k < 9; k++) Fd[k] = (double)F[i][k];
        kf_imp_energy e;
        if (kf_imp_energy_eval(&m, Fd, ps[i], 0, 0, &e) != 0) {
            refused++;
            continue;
        }
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) {
                double t = 0; /* τ = P Fᵀ */
                for (int k = 0; k < 3; k++) t += e.P[3 * a + k] * Fd[3 * b + k];
                double d = fabs(t - (double)tau[3 * a + b]) / (U_ * Es);
                if (!(d <= d_energy)) d_energy = d;
            }
        double psi = kf_mat_energy_density(&m, F[i], ps[i]);
        double d = fabs(psi - e.psi) / (U_ * Es * (1 + fabs(psi) / Es));
        if (!(d <= d_psi)) d_psi = d;
    }
    printf("  %-7s (model %d): batch τ %.2f u·E_s, energy τ %.2f u·E_s, ψ %.2f u·E_s, energy refused %d of %d\n",
           preset, (int)m.model, d_batch, d_energy, d_psi, refused, N);
    KT_CHECK(d_batch <= BOUND, "%s: batch τ deviates %.2f u·E_s from the per-particle τ (bound %d)", preset, d_batch,
             BOUND);
    if (m.model == KF_MAT_WATER) {
        KT_CHECK(refused == N, "%s: water has no energy form, and the implicit energy says so (%d of %d)", preset,
                 refused, N);
        return;
    }
    KT_CHECK(refused == 0, "%s: the energy form evaluates every state (%d refused)", preset, refused);
    KT_CHECK(d_energy <= BOUND, "%s: P Fᵀ of the energy deviates %.2f u·E_s from τ (bound %d)", preset, d_energy,
             BOUND);
    KT_CHECK(d_psi <= BOUND, "%s: ψ of the energy deviates %.2f u·E_s(1 + |ψ|/E_s) (bound %d)", preset, d_psi, BOUND);
}

/* one preset per model, and the other presets of each model too */
static void every_model(void) {
    int seen[KF_MAT_MODEL_COUNT] = {0};
    for (const char *const *p = kf_material_preset_names(); *p; p++) {
        kf_material mat;
        if (kf_material_preset(*p, &mat) != 0) continue;
        seen[mat.model] = 1;
        forms_agree(*p);
    }
    for (int k = 0; k < KF_MAT_MODEL_COUNT; k++) KT_CHECK(seen[k], "model %d is covered by a preset", k);
}

int main(int argc, char **argv) {
    KT_RUN(every_model, argc, argv);
    return KT_EXIT();
}
