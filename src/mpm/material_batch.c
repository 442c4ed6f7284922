/* material_batch.c — stress for a run of particles, SIMD across particles.
 *
 * The fixed-corotated stress needs the polar rotation R of F for every
 * particle every substep, the largest per-particle cost of an elastic scene.
 * Here a run of up to BATCH particles goes through the scaled Newton polar
 * iteration X ← ½(ζX + ζ⁻¹X⁻ᵀ) in lock step: every loop runs across the
 * particles, so the compiler vectorises it (16 floats per AVX-512 register).
 * A particle whose iteration has not converged after the fixed number of
 * sweeps, or whose F is near-singular or inverted, is recomputed by the
 * robust scalar path (kf_mat_update: sign-fixed SVD). The Hencky models
 * (von Mises, Drucker–Prager sand) and snow run an SVD, return map and
 * stress in lock step the same way (hencky_batch, snow_batch), in either
 * precision. */
#include "material.h"
#include "../core/vmath.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#define BATCH 16
#define SWEEPS 8

/* x·y + z, fused where the target has FMA. The polar sweep's update
 * ζX + ζ⁻¹X⁻ᵀ names which product it rounds: these are the forms GCC
 * contracted the expression to when the sweep stored X in place (masked
 * stores), kept so the results stay what they were bit for bit. */
#ifdef __FMA__
#define MB_FMA(x, y, z) kf_fma(x, y, z)
#else
#define MB_FMA(x, y, z) ((x) * (y) + (z))
#endif

/* c ? x : y by bits, for a select stored back where y was read: written
 * as ?: GCC turns that into a store under the mask c (a masked store,
 * microcoded on AMD); as bit operations it is an ordinary store */
#ifdef KF_DOUBLE
typedef uint64_t mb_bits;
#else
typedef uint32_t mb_bits;
#endif
static inline kf_real mb_pick(int c, kf_real x, kf_real y) {
    mb_bits bx, by, m = (mb_bits)0 - (mb_bits)(c != 0);
    memcpy(&bx, &x, sizeof bx);
    memcpy(&by, &y, sizeof by);
    mb_bits r = (bx & m) | (by & ~m);
    kf_real out;
    memcpy(&out, &r, sizeof out);
    return out;
}

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

/* kf_mat_is_limited for particle i of the planes */
static int limited_at(const kf_mat *m, kf_real *const F[9], kf_real *const ps[2], size_t i) {
    kf_real Fi[9], psi[2] = {ps[0][i], ps[1][i]};
    for (int k = 0; k < 9; k++) Fi[k] = F[k][i];
    return kf_mat_is_limited(m, Fi, psi);
}

/* One sweep of the scaled Newton polar iteration X ← ½(ζX + ζ⁻¹X⁻ᵀ) for n
 * lanes, X⁻ᵀ = cof(X)/det X, ζ = (‖X⁻¹‖/‖X‖)^½, X's nine rows at X[k]: the
 * lanes still live take the new iterate into Y, the others copy theirs; a
 * lane whose step was below stop2 stops (live 0). Returns whether a lane is
 * still live. Y is not X, so the select is an ordinary store (one selected
 * back where it was read compiles to masked stores, microcoded on AMD), and
 * the caller swaps the two instead of copying back; the first sweep reads F
 * from the particles' planes, not from a local copy (whose 16-byte stores
 * the sweep's 32-byte loads could not take forwarded). The cofactors stay
 * in registers, and the live flags and the test for any live lane run
 * across the lanes in the same loop (a separate pass of per-lane compares
 * and a reduction over int flags compiled to scalar code, about a third of
 * a sweep's instructions). The first sweep (first: a constant) sets the
 * flags without reading them. The arithmetic is the earlier sweep's,
 * expression for expression, so every lane's bits are what they were. */
static inline __attribute__((always_inline)) mb_bits polar_sweep(int n, const kf_real *const X[9],
                                                                 kf_real (*restrict Y)[BATCH], mb_bits *restrict live,
                                                                 kf_real stop2, int first) {
    mb_bits any = 0;
    for (int j = 0; j < n; j++) {
        kf_real x[9], K[9];
        for (int k = 0; k < 9; k++) x[k] = X[k][j];
        K[0] = x[4] * x[8] - x[5] * x[7];
        K[1] = x[5] * x[6] - x[3] * x[8];
        K[2] = x[3] * x[7] - x[4] * x[6];
        K[3] = x[2] * x[7] - x[1] * x[8];
        K[4] = x[0] * x[8] - x[2] * x[6];
        K[5] = x[1] * x[6] - x[0] * x[7];
        K[6] = x[1] * x[5] - x[2] * x[4];
        K[7] = x[2] * x[3] - x[0] * x[5];
        K[8] = x[0] * x[4] - x[1] * x[3];
        kf_real det = x[0] * K[0] + x[1] * K[1] + x[2] * K[2];
        kf_real x2 = 0, k2 = 0;
        for (int k = 0; k < 9; k++) x2 += x[k] * x[k], k2 += K[k] * K[k];
        /* det > 0 is checked after the sweeps; guard the division for the SIMD lanes */
        kf_real id = det > 0 ? 1 / det : 0;
        kf_real z = kf_sqrt(kf_sqrt(k2 * id * id / (x2 > 0 ? x2 : 1)));
        z = z > 0 ? z : 1;
        kf_real a = KF_R(0.5) * z, b = KF_R(0.5) * id / z, st = 0;
        /* every lane is live in the first sweep (a constant here: no
         * select of the new iterate, no flags read) */
        const mb_bits on = first ? 1 : live[j];
        for (int k = 0; k < 9; k++) {
            kf_real xn = ((k >= 4) & (k <= 7)) ? MB_FMA(b, K[k], a * x[k]) : MB_FMA(a, x[k], b * K[k]);
            st += (xn - x[k]) * (xn - x[k]);
            Y[k][j] = on ? xn : x[k];
        }
        /* a lane stops once its own step was that small */
        live[j] = st < stop2 ? 0 : on;
        any |= live[j];
    }
    return any;
}

/* τ = 2μ sym((F − R)Fᵀ) + λ(J − 1)J I for n <= BATCH particles; returns how
 * many of them the scalar path evaluated at the limited stiffness */
static int corotated_batch(const kf_mat *m, int n, kf_real *const Fp[9], kf_real *const ps[2], size_t first,
                           kf_real *const tau[6]) {
    kf_real XA[9][BATCH], XB[9][BATCH];
    mb_bits ok[BATCH];
    const kf_real mu = m->mu, la = m->lambda;
    /* F read in place from the planes (the first sweep's X, and at the end) */
    const kf_real *F[9];
    for (int k = 0; k < 9; k++) F[k] = Fp[k] + first;

    /* stop when no lane moved more than ~√tol: quadratic convergence then
     * leaves an error far below round-off */
    const kf_real stop2 = sizeof(kf_real) == 4 ? KF_R(1e-11) : KF_R(1e-26);
    /* a lane stops once its own step was that small, whatever its batch
     * mates do: a particle's stress depends on its F alone, so any grouping
     * of particles into batches (the fused transfer's owner blocks, the
     * stress pass's runs) gives the same bits */
    /* live flags of the planes' own width (mb_bits): a select on them is
     * one blend, where an int flag cost the double build lane permutations
     * in every select (and a kf_real flag the float build a compare) */
    mb_bits live[BATCH];
    mb_bits any = polar_sweep(n, F, XA, live, stop2, 1);
    kf_real(*X)[BATCH] = XA, (*Y)[BATCH] = XB;
    for (int sweep = 1; any && sweep < SWEEPS; sweep++) {
        const kf_real *const rows[9] = {X[0], X[1], X[2], X[3], X[4], X[5], X[6], X[7], X[8]};
        any = polar_sweep(n, rows, Y, live, stop2, 0);
        kf_real(*t)[BATCH] = X;
        X = Y, Y = t;
    }

    /* converged means XᵀX = I to a few ulps; otherwise the scalar path.
     * Straight-line code per particle so the loop vectorises. */
    const kf_real tol2 = sizeof(kf_real) == 4 ? KF_R(1e-10) : KF_R(1e-24);
    kf_real T[6][BATCH];
    /* whether any lane failed, reduced across the lanes in the same loop:
     * the lanes' scalar check after it (16 loads, tests and branches, about
     * a tenth of a batch's instructions) runs only where one did */
    mb_bits bad = 0;
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
        /* below J_b the volume barrier (material.h): the scalar path */
        ok[j] = (mb_bits)((e < tol2) & (Jj > KF_R(KF_COROT_JB)));
        bad |= ok[j] ^ 1;
        /* τ = μ (A + Aᵀ) + λ(J − 1)J I with A = (F − R)Fᵀ = FFᵀ − RFᵀ */
        kf_real vol = la * (Jj - 1) * Jj;
        kf_real ff00 = f0 * f0 + f1 * f1 + f2 * f2, ff11 = f3 * f3 + f4 * f4 + f5 * f5,
                ff22 = f6 * f6 + f7 * f7 + f8 * f8;
        kf_real ff01 = f0 * f3 + f1 * f4 + f2 * f5, ff02 = f0 * f6 + f1 * f7 + f2 * f8,
                ff12 = f3 * f6 + f4 * f7 + f5 * f8;
        kf_real rf00 = x0 * f0 + x1 * f1 + x2 * f2, rf11 = x3 * f3 + x4 * f4 + x5 * f5,
                rf22 = x6 * f6 + x7 * f7 + x8 * f8;
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
    int limited = 0;
    if (bad)
        for (int j = 0; j < n; j++)
            if (!ok[j]) {
                scalar_one(m, Fp, ps, 0, first + (size_t)j, tau, j);
                if (m->c_limit > 0) limited += limited_at(m, Fp, ps, first + (size_t)j);
            }
    return limited;
}

/* ---- the lock-step SVD: Hencky models (von Mises, Drucker–Prager sand), snow ---
 *
 * StVK on Hencky strain and snow's clamped singular values need the full
 * SVD F = U Σ Vᵀ. For a run of up to BATCH particles it is computed in lock
 * step, in kf_real:
 *   A = FᵀF, cyclic Jacobi with branch-free rotations (fixed sweeps, early
 *   exit once every lane is diagonal), σ² sorted descending with the columns
 *   of V (each swap negates one column: det V = +1), B = F V, U by
 *   Gram–Schmidt on B and u2 = u0 × u1, σ2 = u2·b2 signed (as kf_svd3).
 * Forming FᵀF squares the condition number: σ_i comes out with an error of
 * about ε σ_max²/σ_min, so a lane is accepted only when every σ lies in
 * [HB_LO, HB_HI] (ratio² ≤ 5), which also bounds the ranges of the log and
 * exp polynomials below, and when the columns of B are orthogonal to
 * HB_RES (the dropped Gram–Schmidt terms, i.e. the reconstruction error of
 * F = U Σ Vᵀ). Every other lane — inverted, strongly stretched or
 * compressed, NaN, or a return map leaving |H| > HB_HMAX — is recomputed
 * by the scalar path (kf_mat_update, double SVD), from its untouched
 * inputs: nothing is written for such a lane before that. In the double
 * build the thresholds scale with ε, the Jacobi sweeps run one more time
 * and log/exp are the library's (the polynomials below are float-accurate). */
#define HB_LO KF_R(0.67)
#define HB_HI KF_R(1.5)
#define HB_HMAX KF_R(0.75)
#ifdef KF_DOUBLE
#define HB_RES2 1e-26 /* (1e-13)²: a few hundred ε */
#define HB_OFF2 1e-30 /* off-diagonal² / diagonal² where a lane is diagonal */
#define HB_SWEEPS 6
#else
#define HB_RES2 KF_R(1e-12) /* (1e-6)²: a few ε, where round-off lands */
#define HB_OFF2 KF_R(1e-16)
#define HB_SWEEPS 5
#endif

/* log x = 2 atanh(t), t = (x − 1)/(x + 1); |t| ≤ 0.2 on [0.67, 1.5], so the
 * series to t¹¹ leaves a relative truncation of 0.04⁶/13 ≈ 3e-10 */
static inline kf_real hb_log(kf_real x) {
#ifdef KF_DOUBLE
    return log(x);
#endif
    kf_real t = (x - 1) / (x + 1), t2 = t * t;
    kf_real p = KF_R(1.0 / 11);
    p = p * t2 + KF_R(1.0 / 9);
    p = p * t2 + KF_R(1.0 / 7);
    p = p * t2 + KF_R(1.0 / 5);
    p = p * t2 + KF_R(1.0 / 3);
    p = p * t2 + 1;
    return 2 * t * p;
}

/* exp x by Taylor to x¹¹ for |x| ≤ 0.75: truncation 0.75¹²/12! ≈ 7e-11 */
static inline kf_real hb_exp(kf_real x) {
#ifdef KF_DOUBLE
    return exp(x);
#endif
    kf_real p = KF_R(1.0 / 39916800);
    p = p * x + KF_R(1.0 / 3628800);
    p = p * x + KF_R(1.0 / 362880);
    p = p * x + KF_R(1.0 / 40320);
    p = p * x + KF_R(1.0 / 5040);
    p = p * x + KF_R(1.0 / 720);
    p = p * x + KF_R(1.0 / 120);
    p = p * x + KF_R(1.0 / 24);
    p = p * x + KF_R(1.0 / 6);
    p = p * x + KF_R(0.5);
    p = p * x + 1;
    return p * x + 1;
}

/* one Jacobi rotation in the (p, q) plane of the symmetric A (six planes
 * a00 a11 a22 a01 a02 a12), accumulated into the columns of V; r is the
 * third index. Angle as kf_svd3: t = 2g sgn(d)/(|d| + √(d² + 4g²)). */
#define HB_ROT(app, aqq, apq, arp, arq, P, Q)                                                                          \
    for (int j = 0; j < n; j++) {                                                                                      \
        kf_real a = app[j], b = aqq[j], g = apq[j];                                                                    \
        kf_real d = b - a, r = kf_sqrt(d * d + 4 * g * g), w = kf_fabs(d) + r, rw = 2 * r * w;                         \
        int live = (rw > KF_R(1e-30)) & act[j];                                                                        \
        kf_real inv = 1 / kf_sqrt(live ? rw : 1);                                                                      \
        kf_real c = live ? w * inv : 1, s = live ? (d >= 0 ? 2 * g : -2 * g) * inv : 0;                                \
        kf_real cs = c * s;                                                                                            \
        app[j] = mb_pick(act[j], c * c * a - 2 * cs * g + s * s * b, a);                                                \
        aqq[j] = mb_pick(act[j], s * s * a + 2 * cs * g + c * c * b, b);                                                \
        apq[j] = mb_pick(act[j], 0, g);                                                                                 \
        kf_real xp = arp[j], xq = arq[j];                                                                              \
        arp[j] = mb_pick(act[j], c * xp - s * xq, xp);                                                                  \
        arq[j] = mb_pick(act[j], s * xp + c * xq, xq);                                                                  \
        for (int i = 0; i < 3; i++) {                                                                                  \
            kf_real vp = V[3 * i + P][j], vq = V[3 * i + Q][j];                                                        \
            V[3 * i + P][j] = mb_pick(act[j], c * vp - s * vq, vp);                                                     \
            V[3 * i + Q][j] = mb_pick(act[j], s * vp + c * vq, vq);                                                     \
        }                                                                                                              \
    }

/* sort step on the σ² of columns p < q: swap when q is larger, negating the
 * new column q so det V stays +1 */
#define HB_SORT(P, Q)                                                                                                  \
    for (int j = 0; j < n; j++) {                                                                                      \
        kf_real sp = S2[P][j], sq = S2[Q][j];                                                                          \
        int sw = sq > sp;                                                                                              \
        S2[P][j] = mb_pick(sw, sq, sp);                                                                                    \
        S2[Q][j] = mb_pick(sw, sp, sq);                                                                                    \
        for (int i = 0; i < 3; i++) {                                                                                  \
            kf_real vp = V[3 * i + P][j], vq = V[3 * i + Q][j];                                                        \
            V[3 * i + P][j] = mb_pick(sw, vq, vp);                                                                         \
            V[3 * i + Q][j] = mb_pick(sw, -vp, vq);                                                                        \
        }                                                                                                              \
    }

/* F = U diag(SG) Vᵀ for n lanes (SG[2] signed, det U = det V = +1); ok: the
 * lane's σ all lie in [lo, hi] (within [HB_LO, HB_HI]) and the
 * reconstruction is within HB_RES2 */
static inline __attribute__((always_inline)) void hb_svd(int n, kf_real (*F)[BATCH], kf_real (*U)[BATCH],
                                                         kf_real (*V)[BATCH], kf_real (*SG)[BATCH], int *ok, kf_real lo,
                                                         kf_real hi) {
    kf_real S2[3][BATCH];
    kf_real a00[BATCH], a11[BATCH], a22[BATCH], a01[BATCH], a02[BATCH], a12[BATCH];

    /* A = FᵀF, V = I */
    for (int j = 0; j < n; j++) {
        kf_real f0 = F[0][j], f1 = F[1][j], f2 = F[2][j], f3 = F[3][j], f4 = F[4][j], f5 = F[5][j], f6 = F[6][j],
                f7 = F[7][j], f8 = F[8][j];
        a00[j] = f0 * f0 + f3 * f3 + f6 * f6;
        a11[j] = f1 * f1 + f4 * f4 + f7 * f7;
        a22[j] = f2 * f2 + f5 * f5 + f8 * f8;
        a01[j] = f0 * f1 + f3 * f4 + f6 * f7;
        a02[j] = f0 * f2 + f3 * f5 + f6 * f8;
        a12[j] = f1 * f2 + f4 * f5 + f7 * f8;
        for (int k = 0; k < 9; k++) V[k][j] = (k % 4 == 0) ? 1 : 0;
    }
    for (int sweep = 0; sweep < HB_SWEEPS; sweep++) {
        /* a lane diagonal to round-off rotates no more, whatever its batch
         * mates do (a particle's result depends on its F alone); every lane
         * diagonal: stop (a separate pass, so the rotation loops have no
         * early exit) */
        int act[BATCH];
        for (int j = 0; j < n; j++) {
            kf_real dg = a00[j] * a00[j] + a11[j] * a11[j] + a22[j] * a22[j];
            kf_real o = a01[j] * a01[j] + a02[j] * a02[j] + a12[j] * a12[j];
            act[j] = !(o <= HB_OFF2 * dg);
        }
        int done = 1;
        for (int j = 0; j < n; j++) done &= !act[j];
        if (done) break;
        HB_ROT(a00, a11, a01, a02, a12, 0, 1)
        HB_ROT(a00, a22, a02, a01, a12, 0, 2)
        HB_ROT(a11, a22, a12, a01, a02, 1, 2)
    }
    for (int j = 0; j < n; j++) S2[0][j] = a00[j], S2[1][j] = a11[j], S2[2][j] = a22[j];
    HB_SORT(0, 1)
    HB_SORT(1, 2)
    HB_SORT(0, 1)

    /* B = F V; U by Gram–Schmidt; σ; validity */
    for (int j = 0; j < n; j++) {
        kf_real b[3][3]; /* b[c][i]: column c */
        for (int c = 0; c < 3; c++)
            for (int i = 0; i < 3; i++)
                b[c][i] = F[3 * i][j] * V[c][j] + F[3 * i + 1][j] * V[3 + c][j] + F[3 * i + 2][j] * V[6 + c][j];
        kf_real s0 = kf_sqrt(b[0][0] * b[0][0] + b[0][1] * b[0][1] + b[0][2] * b[0][2]);
        kf_real i0 = 1 / (s0 > 0 ? s0 : 1);
        kf_real u0[3] = {b[0][0] * i0, b[0][1] * i0, b[0][2] * i0};
        kf_real r01 = u0[0] * b[1][0] + u0[1] * b[1][1] + u0[2] * b[1][2];
        kf_real w1[3] = {b[1][0] - r01 * u0[0], b[1][1] - r01 * u0[1], b[1][2] - r01 * u0[2]};
        kf_real s1 = kf_sqrt(w1[0] * w1[0] + w1[1] * w1[1] + w1[2] * w1[2]);
        kf_real i1 = 1 / (s1 > 0 ? s1 : 1);
        kf_real u1[3] = {w1[0] * i1, w1[1] * i1, w1[2] * i1};
        kf_real u2[3] = {u0[1] * u1[2] - u0[2] * u1[1], u0[2] * u1[0] - u0[0] * u1[2], u0[0] * u1[1] - u0[1] * u1[0]};
        kf_real s2 = u2[0] * b[2][0] + u2[1] * b[2][1] + u2[2] * b[2][2];
        kf_real r02 = u0[0] * b[2][0] + u0[1] * b[2][1] + u0[2] * b[2][2];
        kf_real r12 = u1[0] * b[2][0] + u1[1] * b[2][1] + u1[2] * b[2][2];
        for (int i = 0; i < 3; i++) U[3 * i][j] = u0[i], U[3 * i + 1][j] = u1[i], U[3 * i + 2][j] = u2[i];
        /* NaN fails every comparison, so a broken F is never accepted */
        ok[j] = (s0 >= lo) & (s0 <= hi) & (s1 >= lo) & (s1 <= hi) & (s2 >= lo) & (s2 <= hi) &
                (r01 * r01 + r02 * r02 + r12 * r12 <= HB_RES2);
        /* rejected lanes read 1: the polynomials and clamps stay in range */
        SG[0][j] = ok[j] ? s0 : 1, SG[1][j] = ok[j] ? s1 : 1, SG[2][j] = ok[j] ? s2 : 1;
    }
}

/* n lanes of a particle plane into a local one, as a copy: a loop over
 * Fp[k][first + j] GCC vectorises across the planes (gathers); n is BATCH
 * here, a fixed-size copy is two vector moves */
static inline __attribute__((always_inline)) void mb_load(int n, kf_real *restrict dst, const kf_real *restrict src) {
    memcpy(dst, src, (size_t)n * sizeof *src);
}

/* dst = ok ? a : b for n lanes, selected by bits and stored plainly: a
 * store under a condition compiles to a branch per lane (scalar) or to
 * masked stores (microcoded on AMD) */
static inline __attribute__((always_inline)) void mb_store_pick(int n, kf_real *restrict dst, const int *ok,
                                                                const kf_real *a, const kf_real *b) {
    for (int j = 0; j < n; j++) dst[j] = mb_pick(ok[j], a[j], b[j]);
}

/* the new F out, shared by the Hencky models and snow: G (equal to F where
 * F did not change) for lanes that stayed in the window, the untouched F
 * (the copy read from Fp, the same bits) for the others, which the scalar
 * path then reads and writes. Every lane is stored (mb_store_pick). */
static inline __attribute__((always_inline)) void hb_store_F(int n, kf_real (*G)[BATCH], kf_real (*F)[BATCH],
                                                             const int *ok, kf_real *const Fp[9], size_t first) {
    for (int k = 0; k < 9; k++) mb_store_pick(n, Fp[k] + first, ok, G[k], F[k]);
}

/* sand's hardened friction coefficient for n lanes of hardening state q,
 * with kf_mat_update's float bits: φ = h0 + (h1 q − h3) e^{−h2 q} clamped
 * to [0, π/2 − 1e-6], c_f = √(2/3) 2 sin φ / (3 − sin φ), in double.
 * Across the lanes with vmath.h's exp and sin; a lane whose float could
 * differ from the library route's within the error bound below takes that
 * route (rare, see vmath.h). The clamps are fmax and fmin exactly: φ is
 * never −0 (h0 > 0), and NaN clamps to 0 as fmax(NaN, 0) does. Bound on
 * this route's double against the library route's, u = 2^-53:
 *   e^x: 3u + 0.51 ulp ≤ 4.1u relative, so
 *   Δφ ≤ 4.1u |a e| + 2u (|a e| + |h0 + a e|) ≤ 8.1u |a e| + 2u h0
 *        (a = h1 q − h3; the roundings of a e and of the sum, fused or
 *        not; the clamps do not widen it);
 *   Δ sin φ ≤ Δφ + 40u φ + 2u φ (vmath.h's sin, the library's ≤ 1 ulp);
 *   Δc_f ≤ (3 · 1.64 / 4) Δ sin φ + 4u c_f (d c_f / d sin φ ≤ 3c/4 with
 *        3 − sin φ ≥ 2, and the three roundings).
 * The check takes twice that. */
static inline __attribute__((always_inline)) void sand_friction(const kf_mat *m, int n, const kf_real *P1,
                                                                kf_real *cf) {
    const double cap = 0.5 * 3.14159265358979323846 - 1e-6, u = 0x1p-53;
    int safe[BATCH];
    for (int j = 0; j < n; j++) {
#ifdef KF_DOUBLE
        /* no float rounding to hide the difference in: the library's */
        safe[j] = 0;
        continue;
#endif
        double q = P1[j], x = -(double)m->h2 * q, a = m->h1 * q - m->h3;
        double ae = a * kf_vm_exp(x), phi = m->h0 + ae;
        phi = phi > 0 ? phi : 0.0;
        phi = phi < cap ? phi : cap;
        double sp = kf_vm_sin(phi), c = sqrt(2.0 / 3.0) * 2 * sp / (3 - sp);
        double aae = ae < 0 ? -ae : ae, dphi = 8.1 * u * aae + 2 * u * m->h0;
        double dsp = dphi + 42 * u * phi, dcf = 1.25 * dsp + 4 * u * c;
        safe[j] = (x >= -KF_VM_EXP_MAX) & (x <= KF_VM_EXP_MAX) & kf_vm_float_safe(c, 2 * dcf);
        cf[j] = (kf_real)c;
    }
    for (int j = 0; j < n; j++)
        if (!safe[j]) cf[j] = (kf_real)kf_mat_friction_hardened(m, P1[j]);
}

static void hencky_batch(const kf_mat *m, int n, kf_real *const Fp[9], kf_real *const ps[2], int project, size_t first,
                         kf_real *const tau[6]) {
    kf_real F[9][BATCH], V[9][BATCH], U[9][BATCH], E[3][BATCH];
    int ok[BATCH];
    for (int k = 0; k < 9; k++) mb_load(n, F[k], Fp[k] + first);
    /* log σ */
    hb_svd(n, F, U, V, E, ok, HB_LO, HB_HI);
    for (int j = 0; j < n; j++) E[0][j] = hb_log(E[0][j]), E[1][j] = hb_log(E[1][j]), E[2][j] = hb_log(E[2][j]);

    /* the return map in principal space: E ← H; chg = F must change */
    int chg[BATCH];
    kf_real ps0[BATCH], ps1[BATCH], VC[BATCH], P1[BATCH];
    for (int j = 0; j < n; j++) chg[j] = 0;
    if (project && m->model == KF_MAT_VON_MISES) {
        const kf_real ry = m->tau_y / (2 * m->mu);
        for (int j = 0; j < n; j++) {
            kf_real e0 = E[0][j], e1 = E[1][j], e2 = E[2][j], tr3 = (e0 + e1 + e2) * KF_R(1.0 / 3);
            kf_real h0 = e0 - tr3, h1 = e1 - tr3, h2 = e2 - tr3;
            kf_real nh = kf_sqrt(h0 * h0 + h1 * h1 + h2 * h2);
            kf_real dg = nh - ry;
            int y = dg > 0;
            kf_real f = y ? dg / (nh > 0 ? nh : 1) : 0;
            E[0][j] = e0 - f * h0, E[1][j] = e1 - f * h1, E[2][j] = e2 - f * h2;
            chg[j] = y;
        }
    } else if (project && m->model == KF_MAT_SAND) {
        const kf_real mu = m->mu, la = m->lambda, c = m->cohesion, kk = (3 * la + 2 * mu) / (2 * mu);
        const int vcorr = m->volume_correction, hard = m->hardening;
        kf_real cf[BATCH];
        mb_load(n, P1, ps[1] + first);
        if (vcorr) mb_load(n, VC, ps[0] + first);
        else
            for (int j = 0; j < n; j++) VC[j] = 0;
        if (hard) sand_friction(m, n, P1, cf);
        else {
            for (int j = 0; j < n; j++) cf[j] = m->c_f;
        }
        for (int j = 0; j < n; j++) {
            kf_real vc = VC[j];
            kf_real e0 = E[0][j], e1 = E[1][j], e2 = E[2][j], trt = e0 + e1 + e2;
            kf_real sh = vc * KF_R(1.0 / 3) - c;
            kf_real s0 = e0 + sh, s1 = e1 + sh, s2 = e2 + sh, tr = s0 + s1 + s2, tr3 = tr * KF_R(1.0 / 3);
            kf_real h0 = s0 - tr3, h1 = s1 - tr3, h2 = s2 - tr3;
            kf_real nh = kf_sqrt(h0 * h0 + h1 * h1 + h2 * h2);
            kf_real dg = nh + kk * tr * cf[j];
            int tension = tr >= 0, elastic = !tension & (dg <= 0);
            kf_real f = dg / (nh > 0 ? nh : 1);
            /* every candidate computed, then picked by bits: nested ?:
             * (and a root under a condition) GCC if-converts into masked
             * stores, microcoded on AMD */
            kf_real H0 = mb_pick(tension, c, mb_pick(elastic, s0 + c, s0 - f * h0 + c));
            kf_real H1 = mb_pick(tension, c, mb_pick(elastic, s1 + c, s1 - f * h1 + c));
            kf_real H2 = mb_pick(tension, c, mb_pick(elastic, s2 + c, s2 - f * h2 + c));
            /* |s| in tension, the products fused as GCC fused them under
             * the condition (where it was taken before) */
            kf_real st = kf_sqrt(MB_FMA(s2, s2, MB_FMA(s1, s1, s0 * s0)));
            kf_real dq = mb_pick(tension, st, mb_pick(elastic, 0, dg));
            ps1[j] = P1[j] + dq; /* stored only with hardening */
            /* an elastic state with nothing to correct keeps F bit for bit */
            int ch = !(elastic & (vc == 0));
            ps0[j] = mb_pick(ch, vc + trt - (H0 + H1 + H2), vc); /* stored only with volume correction */
            E[0][j] = mb_pick(ch, H0, e0), E[1][j] = mb_pick(ch, H1, e1), E[2][j] = mb_pick(ch, H2, e2);
            chg[j] = ch;
        }
    }

    /* F_E = U diag(exp H) Vᵀ where it changed; τ = U diag(2μH + λ tr H) Uᵀ */
    const kf_real mu2 = 2 * m->mu, la = m->lambda;
    kf_real T[6][BATCH], G[9][BATCH];
    for (int j = 0; j < n; j++) {
        kf_real e0 = E[0][j], e1 = E[1][j], e2 = E[2][j];
        /* |H| beyond the exp polynomial's range: the scalar path */
        int in = (kf_fabs(e0) <= HB_HMAX) & (kf_fabs(e1) <= HB_HMAX) & (kf_fabs(e2) <= HB_HMAX);
        ok[j] &= in;
        e0 = in ? e0 : 0, e1 = in ? e1 : 0, e2 = in ? e2 : 0;
        kf_real x0 = hb_exp(e0), x1 = hb_exp(e1), x2 = hb_exp(e2);
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++) {
                kf_real g = U[3 * i][j] * x0 * V[3 * k][j] + U[3 * i + 1][j] * x1 * V[3 * k + 1][j] +
                            U[3 * i + 2][j] * x2 * V[3 * k + 2][j];
                G[3 * i + k][j] = chg[j] ? g : F[3 * i + k][j];
            }
        kf_real tr = la * (e0 + e1 + e2), d0 = mu2 * e0 + tr, d1 = mu2 * e1 + tr, d2 = mu2 * e2 + tr;
#define HB_T(a, b)                                                                                                     \
    (U[3 * a][j] * d0 * U[3 * b][j] + U[3 * a + 1][j] * d1 * U[3 * b + 1][j] + U[3 * a + 2][j] * d2 * U[3 * b + 2][j])
        T[0][j] = HB_T(0, 0), T[1][j] = HB_T(1, 1), T[2][j] = HB_T(2, 2);
        T[3][j] = HB_T(0, 1), T[4][j] = HB_T(0, 2), T[5][j] = HB_T(1, 2);
#undef HB_T
    }
    for (int k = 0; k < 6; k++)
        for (int j = 0; j < n; j++) tau[k][j] = T[k][j];
    /* VC and P1 hold the states' bits where they are stored (volume
     * correction, hardening): rejected lanes get them back unchanged */
    if (project) {
        hb_store_F(n, G, F, ok, Fp, first);
        if (m->model == KF_MAT_SAND && m->volume_correction)
            mb_store_pick(n, ps[0] + first, ok, ps0, VC);
        if (m->model == KF_MAT_SAND && m->hardening)
            mb_store_pick(n, ps[1] + first, ok, ps1, P1);
    }
    for (int j = 0; j < n; j++)
        if (!ok[j]) scalar_one(m, Fp, ps, project, first + (size_t)j, tau, j);
}

/* H = (float)e^x for n lanes with the library's bits: kf_vm_exp across
 * the lanes (≤ 3u, the library ≤ 0.51 ulp: within 16u of each other), the
 * library's exp for a lane whose float could round either way within
 * that (vmath.h), or whose x is out of range */
static inline __attribute__((always_inline)) void snow_hardening(int n, const double *X, kf_real *H) {
#ifdef KF_DOUBLE
    /* no float rounding to hide the difference in: the library's */
    for (int j = 0; j < n; j++) H[j] = exp(X[j]);
    return;
#endif
    int safe[BATCH];
    for (int j = 0; j < n; j++) {
        double x = X[j], y = kf_vm_exp(x);
        safe[j] = (x >= -KF_VM_EXP_MAX) & (x <= KF_VM_EXP_MAX) & kf_vm_float_safe(y, y * 0x1p-49);
        H[j] = (kf_real)y;
    }
    for (int j = 0; j < n; j++)
        if (!safe[j]) H[j] = (kf_real)exp(X[j]);
}

/* Snow (Stomakhin et al. 2013), as kf_mat_update: σ clamped to
 * [1 − θc, 1 + θs] with the discarded volume moved into Jp (ps[0]), then the
 * corotated stress with moduli hardened by e^{ξ(1 − Jp)}:
 * τ = U diag(2μ(σ − 1)σ + λ(J − 1)J) Uᵀ. J − 1 is summed from the σ − 1
 * (exact in floating point near 1), not formed as a difference near 1.
 * The window is narrower than the Hencky models': the corotated stress
 * grows with σ², so the eigen route's σ error of a few ε σ_max²/σ_min
 * costs more stress far from 1, and snow that has been clamped to
 * [1 − θc, 1 + θs] leaves [SNOW_LO, SNOW_HI] only under a deformation of
 * more than 10% in one substep. A lane outside the window goes to the
 * scalar path, from its untouched inputs; a lane whose σ need no clamp
 * keeps F bit for bit. */
#define SNOW_LO KF_R(0.9)
#define SNOW_HI KF_R(1.1)
static int snow_batch(const kf_mat *m, int n, kf_real *const Fp[9], kf_real *const ps[2], int project, size_t first,
                      kf_real *const tau[6]) {
    kf_real F[9][BATCH], V[9][BATCH], U[9][BATCH], S[3][BATCH], D[3][BATCH], JP[BATCH], JP0[BATCH], H[BATCH];
    int ok[BATCH], chg[BATCH];
    for (int k = 0; k < 9; k++) mb_load(n, F[k], Fp[k] + first);
    mb_load(n, JP0, ps[0] + first);
    hb_svd(n, F, U, V, S, ok, SNOW_LO, SNOW_HI);
    const kf_real lo = 1 - m->theta_c, hi = 1 + m->theta_s;
    for (int j = 0; j < n; j++) {
        kf_real jp = JP0[j], ratio = 1;
        int c = 0;
        for (int i = 0; i < 3; i++) {
            kf_real si = S[i][j], di = project ? (si < lo ? lo : si > hi ? hi : si) : si;
            c |= di != si;
            ratio *= si / di; /* σ > 0 in the window */
            D[i][j] = di;
        }
        chg[j] = c;
        JP[j] = c ? jp * ratio : jp;
    }
    /* the hardening e^{ξ(1 − Jp)} in double, rounded to float as
     * kf_mat_update's; under a fixed step at most the stiffness the step
     * resolves (Jp below state_limit hardens as at state_limit, material.h:
     * kf_mat_limit) */
    int limited = 0;
    double X[BATCH];
    for (int j = 0; j < n; j++) {
        double jp = (double)JP[j];
        int lim = (m->c_limit > 0) & (jp < m->state_limit);
        jp = lim ? m->state_limit : jp;
        limited += lim & ok[j];
        X[j] = (double)m->xi * (1.0 - jp);
    }
    snow_hardening(n, X, H);
    const kf_real mu2 = 2 * m->mu, la = m->lambda;
    kf_real T[6][BATCH], G[9][BATCH];
    for (int j = 0; j < n; j++) {
        kf_real d0 = D[0][j], d1 = D[1][j], d2 = D[2][j];
        kf_real e0 = d0 - 1, e1 = d1 - 1, e2 = d2 - 1;
        kf_real jm1 = e0 + e1 + e2 + (e0 * e1 + e0 * e2 + e1 * e2) + e0 * e1 * e2, J = 1 + jm1;
        kf_real h = H[j], vol = h * la * jm1 * J;
        kf_real t0 = h * mu2 * e0 * d0 + vol, t1 = h * mu2 * e1 * d1 + vol, t2 = h * mu2 * e2 * d2 + vol;
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++) {
                kf_real g = U[3 * i][j] * d0 * V[3 * k][j] + U[3 * i + 1][j] * d1 * V[3 * k + 1][j] +
                            U[3 * i + 2][j] * d2 * V[3 * k + 2][j];
                G[3 * i + k][j] = chg[j] ? g : F[3 * i + k][j];
            }
#define SB_T(a, b)                                                                                                     \
    (U[3 * a][j] * t0 * U[3 * b][j] + U[3 * a + 1][j] * t1 * U[3 * b + 1][j] + U[3 * a + 2][j] * t2 * U[3 * b + 2][j])
        T[0][j] = SB_T(0, 0), T[1][j] = SB_T(1, 1), T[2][j] = SB_T(2, 2);
        T[3][j] = SB_T(0, 1), T[4][j] = SB_T(0, 2), T[5][j] = SB_T(1, 2);
#undef SB_T
    }
    for (int k = 0; k < 6; k++)
        for (int j = 0; j < n; j++) tau[k][j] = T[k][j];
    if (project) {
        hb_store_F(n, G, F, ok, Fp, first);
        mb_store_pick(n, ps[0] + first, ok, JP, JP0);
    }
    for (int j = 0; j < n; j++)
        if (!ok[j]) {
            scalar_one(m, Fp, ps, project, first + (size_t)j, tau, j);
            if (m->c_limit > 0) limited += limited_at(m, Fp, ps, first + (size_t)j);
        }
    return limited;
}

/* c < BATCH lanes of a short batch's plane, as at most four fixed-size
 * copies (vector moves): a loop of variable length compiles to a call to
 * memmove, whose start-up costs more than the copy */
static inline void copy_lanes(kf_real *restrict dst, const kf_real *restrict src, int c) {
    int o = 0;
    if (c & 8) memcpy(dst + o, src + o, 8 * sizeof *src), o += 8;
    if (c & 4) memcpy(dst + o, src + o, 4 * sizeof *src), o += 4;
    if (c & 2) memcpy(dst + o, src + o, 2 * sizeof *src), o += 2;
    if (c & 1) dst[o] = src[o];
}

/* One batch of c <= BATCH particles from index first, through lanes of a
 * full BATCH in aligned local planes (the rest padded with F = I at rest):
 * every particle takes the same machine code whatever its place in a run
 * and the run's length (a short run would otherwise go through the
 * compiler's scalar remainder loop, whose roundings differ), so its result
 * depends on its own F and state alone. */
static int lanes_batch(const kf_mat *m, int c, kf_real *const Fp[9], kf_real *const ps[2], int project, size_t first,
                       kf_real *const tau6[6]) {
    /* a full batch reads the particles' planes and writes τ, F and the
     * states in place (no copies through the local planes, whose 16-byte
     * stores the next 32-byte loads could not take forwarded): every model
     * loads its inputs into locals first and stores whole planes last, so
     * the arithmetic is that of the local planes. The corotated model
     * changes neither F nor ps. */
    if (c == BATCH) {
        int proj = project && m->plastic;
        if (m->model == KF_MAT_COROTATED) return corotated_batch(m, BATCH, Fp, ps, first, tau6);
        if (m->model == KF_MAT_SNOW) return snow_batch(m, BATCH, Fp, ps, proj, first, tau6);
        hencky_batch(m, BATCH, Fp, ps, proj, first, tau6);
        return 0;
    }
    kf_real F[9][BATCH] __attribute__((aligned(64))), P[2][BATCH] __attribute__((aligned(64)));
    kf_real T[6][BATCH] __attribute__((aligned(64)));
    /* the pads at rest: snow's Jp 1, the Hencky models' corrections 0 */
    const kf_real rest = m->model == KF_MAT_SNOW ? 1 : 0;
    /* a short batch: the pads first, then the particles over them */
    for (int k = 0; k < 9; k++) {
        for (int j = 0; j < BATCH; j++) F[k][j] = (kf_real)(k % 4 == 0);
        copy_lanes(F[k], Fp[k] + first, c);
    }
    for (int k = 0; k < 2; k++) {
        for (int j = 0; j < BATCH; j++) P[k][j] = k == 0 ? rest : 0;
        copy_lanes(P[k], ps[k] + first, c);
    }
    kf_real *const Fl[9] = {F[0], F[1], F[2], F[3], F[4], F[5], F[6], F[7], F[8]};
    kf_real *const Pl[2] = {P[0], P[1]};
    kf_real *const Tl[6] = {T[0], T[1], T[2], T[3], T[4], T[5]};
    int limited = 0;
    if (m->model == KF_MAT_COROTATED) limited = corotated_batch(m, BATCH, Fl, Pl, 0, Tl);
    else if (m->model == KF_MAT_SNOW) limited = snow_batch(m, BATCH, Fl, Pl, project && m->plastic, 0, Tl);
    else hencky_batch(m, BATCH, Fl, Pl, project && m->plastic, 0, Tl);
    for (int k = 0; k < 6; k++) copy_lanes(tau6[k], T[k], c);
    /* the corotated model changes neither (its ps may be an untouched zero array) */
    if (project && m->plastic && m->model != KF_MAT_COROTATED) {
        for (int k = 0; k < 9; k++) copy_lanes(Fp[k] + first, F[k], c);
        for (int k = 0; k < 2; k++) copy_lanes(ps[k] + first, P[k], c);
    }
    return limited;
}

int kf_mat_update_batch(const kf_mat *m, int n, kf_real *const F[9], kf_real *const ps[2], int project, size_t first,
                        kf_real *const tau6[6]) {
    /* one full corotated batch to evaluate (P2G's chunk of 16, the stress
     * not kept): straight to its lanes, without the loop's set-up */
    if (n == BATCH && !project && m->model == KF_MAT_COROTATED) return corotated_batch(m, BATCH, F, ps, first, tau6);
    if (m->model == KF_MAT_COROTATED || m->model == KF_MAT_VON_MISES || m->model == KF_MAT_SAND ||
        m->model == KF_MAT_SNOW) {
        int limited = 0;
        for (int j0 = 0; j0 < n; j0 += BATCH) {
            int c = n - j0 < BATCH ? n - j0 : BATCH;
            kf_real *out[6];
            for (int k = 0; k < 6; k++) out[k] = tau6[k] + j0;
            /* the stress pass writes planes last touched a substep ago
             * (memory): their lines asked for four batches ahead */
            if (project)
                for (int k = 0; k < 6; k++) __builtin_prefetch(out[k] + 4 * BATCH, 1, 3);
            /* a full corotated batch straight to its lanes (lanes_batch's
             * own first test, without the call and its dispatch) */
            if (c == BATCH && m->model == KF_MAT_COROTATED)
                limited += corotated_batch(m, BATCH, F, ps, first + (size_t)j0, out);
            else limited += lanes_batch(m, c, F, ps, project, first + (size_t)j0, out);
        }
        return limited;
    }
    int limited = 0;
    for (int j = 0; j < n; j++) {
        size_t i = first + (size_t)j;
        scalar_one(m, F, ps, project && m->plastic, i, tau6, j);
        if (m->c_limit > 0) limited += limited_at(m, F, ps, i);
    }
    return limited;
}

void kf_mat_batch_hardening(const kf_mat *m, int n, const kf_real *state, kf_real *out) {
    if (n > BATCH) n = BATCH;
    if (m->model == KF_MAT_SNOW) {
        double X[BATCH];
        for (int j = 0; j < n; j++) X[j] = (double)m->xi * (1.0 - (double)state[j]);
        snow_hardening(n, X, out);
    } else if (m->model == KF_MAT_SAND && m->hardening) {
        sand_friction(m, n, state, out);
    } else {
        for (int j = 0; j < n; j++) out[j] = 1;
    }
}
