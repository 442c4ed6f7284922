/* material_batch.c — stress for a run of particles, SIMD across particles.
 *
 * The fixed-corotated stress needs the polar rotation R of F for every
 * particle every substep, the largest per-particle cost of an elastic scene.
 * Here a run of up to BATCH particles goes through the scaled Newton polar
 * iteration X ← ½(ζX + ζ⁻¹X⁻ᵀ) in lock step: every loop runs across the
 * particles, so the compiler vectorises it (16 floats per AVX-512 register).
 * A particle whose iteration has not converged after the fixed number of
 * sweeps, or whose F is near-singular or inverted, is recomputed by the
 * robust scalar path (kf_mat_kirchhoff: sign-fixed SVD). */
#include "material.h"

#define BATCH 16
#define SWEEPS 5

/* the robust path for particle j */
static void scalar_one(const kf_mat *m, const kf_real *const F[9], const kf_real *const ps[2], size_t i,
                       kf_real *const tau[9], int j) {
    kf_real Fi[9], psi[2] = {ps[0][i], ps[1][i]}, t[9];
    for (int k = 0; k < 9; k++) Fi[k] = F[k][i];
    kf_mat_kirchhoff(m, Fi, psi, t);
    for (int k = 0; k < 9; k++) tau[k][j] = t[k];
}

/* τ = 2μ sym((F − R)Fᵀ) + λ(J − 1)J I for n <= BATCH particles */
static void corotated_batch(const kf_mat *m, int n, const kf_real *const Fp[9], const kf_real *const ps[2], size_t first,
                            kf_real *const tau[9]) {
    kf_real F[9][BATCH], X[9][BATCH], K[9][BATCH], J[BATCH];
    int ok[BATCH];
    const kf_real mu = m->mu, la = m->lambda;
    for (int k = 0; k < 9; k++)
        for (int j = 0; j < n; j++) X[k][j] = F[k][j] = Fp[k][first + (size_t)j];

    /* X⁻ᵀ = cof(X)/det X; ζ = (‖X⁻¹‖/‖X‖)^½ speeds up the first sweeps */
    for (int sweep = 0; sweep < SWEEPS; sweep++) {
        for (int j = 0; j < n; j++) {
            K[0][j] = X[4][j] * X[8][j] - X[5][j] * X[7][j];
            K[1][j] = X[5][j] * X[6][j] - X[3][j] * X[8][j];
            K[2][j] = X[3][j] * X[7][j] - X[4][j] * X[6][j];
            K[3][j] = X[2][j] * X[7][j] - X[1][j] * X[8][j];
            K[4][j] = X[0][j] * X[8][j] - X[2][j] * X[6][j];
            K[5][j] = X[1][j] * X[6][j] - X[0][j] * X[7][j];
            K[6][j] = X[1][j] * X[5][j] - X[2][j] * X[4][j];
            K[7][j] = X[2][j] * X[3][j] - X[0][j] * X[5][j];
            K[8][j] = X[0][j] * X[4][j] - X[1][j] * X[3][j];
            kf_real det = X[0][j] * K[0][j] + X[1][j] * K[1][j] + X[2][j] * K[2][j];
            kf_real x2 = 0, k2 = 0;
            for (int k = 0; k < 9; k++) x2 += X[k][j] * X[k][j], k2 += K[k][j] * K[k][j];
            /* det > 0 is checked below; guard the division for the SIMD lanes */
            kf_real id = det > 0 ? 1 / det : 0;
            kf_real z = kf_sqrt(kf_sqrt(k2 * id * id / (x2 > 0 ? x2 : 1)));
            z = z > 0 ? z : 1;
            kf_real a = KF_R(0.5) * z, b = KF_R(0.5) * id / z;
            for (int k = 0; k < 9; k++) X[k][j] = a * X[k][j] + b * K[k][j];
        }
    }

    /* converged means XᵀX = I to a few ulps; otherwise the scalar path */
    const kf_real tol = sizeof(kf_real) == 4 ? KF_R(1e-5) : KF_R(1e-12);
    for (int j = 0; j < n; j++) {
        kf_real e = 0;
        for (int r = 0; r < 3; r++)
            for (int c = r; c < 3; c++) {
                kf_real d = X[r][j] * X[c][j] + X[3 + r][j] * X[3 + c][j] + X[6 + r][j] * X[6 + c][j] - (r == c);
                e += d * d;
            }
        J[j] = F[0][j] * (F[4][j] * F[8][j] - F[5][j] * F[7][j]) - F[1][j] * (F[3][j] * F[8][j] - F[5][j] * F[6][j]) +
               F[2][j] * (F[3][j] * F[7][j] - F[4][j] * F[6][j]);
        ok[j] = e < tol * tol && J[j] > KF_R(1e-2);
    }

    /* τ = μ (A + Aᵀ) + λ(J − 1)J I with A = (F − R)Fᵀ */
    for (int r = 0; r < 3; r++)
        for (int c = r; c < 3; c++)
            for (int j = 0; j < n; j++) {
                kf_real a = 0, at = 0;
                for (int k = 0; k < 3; k++) {
                    a += (F[3 * r + k][j] - X[3 * r + k][j]) * F[3 * c + k][j];
                    at += (F[3 * c + k][j] - X[3 * c + k][j]) * F[3 * r + k][j];
                }
                kf_real t = mu * (a + at) + (r == c ? la * (J[j] - 1) * J[j] : 0);
                tau[3 * r + c][j] = t;
                tau[3 * c + r][j] = t;
            }
    for (int j = 0; j < n; j++)
        if (!ok[j]) scalar_one(m, Fp, ps, first + (size_t)j, tau, j);
}

void kf_mat_kirchhoff_batch(const kf_mat *m, int n, const kf_real *const F[9], const kf_real *const ps[2], size_t first,
                            kf_real *const tau[9]) {
    if (m->model == KF_MAT_COROTATED) {
        for (int j0 = 0; j0 < n; j0 += BATCH) {
            int c = n - j0 < BATCH ? n - j0 : BATCH;
            kf_real *out[9];
            for (int k = 0; k < 9; k++) out[k] = tau[k] + j0;
            corotated_batch(m, c, F, ps, first + (size_t)j0, out);
        }
        return;
    }
    for (int j = 0; j < n; j++) scalar_one(m, F, ps, first + (size_t)j, tau, j);
}
