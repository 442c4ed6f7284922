/* material_batch.c — stress for a run of particles, SIMD across particles.
 *
 * The fixed-corotated stress needs the polar rotation R of F for every
 * particle every substep, the largest per-particle cost of an elastic scene.
 * Here a run of up to BATCH particles goes through the scaled Newton polar
 * iteration X ← ½(ζX + ζ⁻¹X⁻ᵀ) in lock step: every loop runs across the
 * particles, so the compiler vectorises it (16 floats per AVX-512 register).
 * A particle whose iteration has not converged after the fixed number of
 * sweeps, or whose F is near-singular or inverted, is recomputed by the
 * robust scalar path (kf_mat_update: sign-fixed SVD). Other models take the
 * scalar path for every particle, one SVD each for plasticity and stress. */
#include "material.h"

#define BATCH 16
#define SWEEPS 8

/* the robust path for particle i: update F and ps in place, τ to slot j */
static void scalar_one(const kf_mat *m, kf_real *const F[9], kf_real *const ps[2], int project, size_t i,
                       kf_real *const tau6[6], int j) {
    kf_real Fi[9], psi[2] = {ps[0][i], ps[1][i]}, t[9];
    for (int k = 0; k < 9; k++) Fi[k] = F[k][i];
    kf_mat_update(m, Fi, psi, project, t);
    if (project) {
        for (int k = 0; k < 9; k++) F[k][i] = Fi[k];
        ps[0][i] = psi[0];
        ps[1][i] = psi[1];
    }
    tau6[0][j] = t[0], tau6[1][j] = t[4], tau6[2][j] = t[8];
    tau6[3][j] = t[1], tau6[4][j] = t[2], tau6[5][j] = t[5];
}

/* τ = 2μ sym((F − R)Fᵀ) + λ(J − 1)J I for n <= BATCH particles */
static void corotated_batch(const kf_mat *m, int n, kf_real *const Fp[9], kf_real *const ps[2], size_t first,
                            kf_real *const tau[6]) {
    kf_real F[9][BATCH], X[9][BATCH], K[9][BATCH];
    int ok[BATCH];
    const kf_real mu = m->mu, la = m->lambda;
    for (int k = 0; k < 9; k++)
        for (int j = 0; j < n; j++) X[k][j] = F[k][j] = Fp[k][first + (size_t)j];

    /* X⁻ᵀ = cof(X)/det X; ζ = (‖X⁻¹‖/‖X‖)^½ speeds up the first sweeps */
    /* stop when no lane moved more than ~√tol: quadratic convergence then
     * leaves an error far below round-off */
    const kf_real stop2 = sizeof(kf_real) == 4 ? KF_R(1e-11) : KF_R(1e-26);
    for (int sweep = 0; sweep < SWEEPS; sweep++) {
        kf_real step[BATCH];
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
            kf_real a = KF_R(0.5) * z, b = KF_R(0.5) * id / z, st = 0;
            for (int k = 0; k < 9; k++) {
                kf_real xn = a * X[k][j] + b * K[k][j];
                st += (xn - X[k][j]) * (xn - X[k][j]);
                X[k][j] = xn;
            }
            step[j] = st;
        }
        /* a separate pass: float max-reductions would block vectorisation */
        int done = 1;
        for (int j = 0; j < n; j++) done &= step[j] < stop2;
        if (done) break;
    }

    /* converged means XᵀX = I to a few ulps; otherwise the scalar path.
     * Straight-line code per particle so the loop vectorises. */
    const kf_real tol2 = sizeof(kf_real) == 4 ? KF_R(1e-10) : KF_R(1e-24);
    kf_real T[6][BATCH];
    for (int j = 0; j < n; j++) {
        kf_real x0 = X[0][j], x1 = X[1][j], x2 = X[2][j], x3 = X[3][j], x4 = X[4][j], x5 = X[5][j], x6 = X[6][j],
                x7 = X[7][j], x8 = X[8][j];
        kf_real f0 = F[0][j], f1 = F[1][j], f2 = F[2][j], f3 = F[3][j], f4 = F[4][j], f5 = F[5][j], f6 = F[6][j],
                f7 = F[7][j], f8 = F[8][j];
        kf_real e00 = x0 * x0 + x3 * x3 + x6 * x6 - 1, e11 = x1 * x1 + x4 * x4 + x7 * x7 - 1,
                e22 = x2 * x2 + x5 * x5 + x8 * x8 - 1, e01 = x0 * x1 + x3 * x4 + x6 * x7,
                e02 = x0 * x2 + x3 * x5 + x6 * x8, e12 = x1 * x2 + x4 * x5 + x7 * x8;
        kf_real e = e00 * e00 + e11 * e11 + e22 * e22 + 2 * (e01 * e01 + e02 * e02 + e12 * e12);
        kf_real Jj = f0 * (f4 * f8 - f5 * f7) - f1 * (f3 * f8 - f5 * f6) + f2 * (f3 * f7 - f4 * f6);
        ok[j] = (e < tol2) & (Jj > KF_R(1e-2));
        /* τ = μ (A + Aᵀ) + λ(J − 1)J I with A = (F − R)Fᵀ = FFᵀ − RFᵀ */
        kf_real vol = la * (Jj - 1) * Jj;
        kf_real ff00 = f0 * f0 + f1 * f1 + f2 * f2, ff11 = f3 * f3 + f4 * f4 + f5 * f5, ff22 = f6 * f6 + f7 * f7 + f8 * f8;
        kf_real ff01 = f0 * f3 + f1 * f4 + f2 * f5, ff02 = f0 * f6 + f1 * f7 + f2 * f8, ff12 = f3 * f6 + f4 * f7 + f5 * f8;
        kf_real rf00 = x0 * f0 + x1 * f1 + x2 * f2, rf11 = x3 * f3 + x4 * f4 + x5 * f5, rf22 = x6 * f6 + x7 * f7 + x8 * f8;
        kf_real rf01 = x0 * f3 + x1 * f4 + x2 * f5, rf10 = x3 * f0 + x4 * f1 + x5 * f2;
        kf_real rf02 = x0 * f6 + x1 * f7 + x2 * f8, rf20 = x6 * f0 + x7 * f1 + x8 * f2;
        kf_real rf12 = x3 * f6 + x4 * f7 + x5 * f8, rf21 = x6 * f3 + x7 * f4 + x8 * f5;
        T[0][j] = 2 * mu * (ff00 - rf00) + vol;
        T[1][j] = 2 * mu * (ff11 - rf11) + vol;
        T[2][j] = 2 * mu * (ff22 - rf22) + vol;
        T[3][j] = mu * (2 * ff01 - rf01 - rf10);
        T[4][j] = mu * (2 * ff02 - rf02 - rf20);
        T[5][j] = mu * (2 * ff12 - rf12 - rf21);
    }
    for (int k = 0; k < 6; k++)
        for (int j = 0; j < n; j++) tau[k][j] = T[k][j];
    for (int j = 0; j < n; j++)
        if (!ok[j]) scalar_one(m, Fp, ps, 0, first + (size_t)j, tau, j);
}

void kf_mat_update_batch(const kf_mat *m, int n, kf_real *const F[9], kf_real *const ps[2], int project, size_t first,
                         kf_real *const tau6[6]) {
    if (m->model == KF_MAT_COROTATED) {
        for (int j0 = 0; j0 < n; j0 += BATCH) {
            int c = n - j0 < BATCH ? n - j0 : BATCH;
            kf_real *out[6];
            for (int k = 0; k < 6; k++) out[k] = tau6[k] + j0;
            corotated_batch(m, c, F, ps, first + (size_t)j0, out);
        }
        return;
    }
    for (int j = 0; j < n; j++) scalar_one(m, F, ps, project && m->plastic, first + (size_t)j, tau6, j);
}
