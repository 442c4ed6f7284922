/* mat3.h — small 3x3 matrix algebra on kf_real.
 *
 * Matrices are row-major arrays of 9: A[3*i + j] = A_ij. All functions are
 * static inline so the per-particle hot loops can be specialised by the
 * compiler. Outputs may not alias inputs unless stated. */
#ifndef KF_MAT3_H
#define KF_MAT3_H

#include "real.h"

static inline void kf_m3_identity(kf_real A[9]) {
    for (int i = 0; i < 9; i++) A[i] = 0;
    A[0] = A[4] = A[8] = 1;
}

static inline void kf_m3_copy(kf_real B[9], const kf_real A[9]) {
    for (int i = 0; i < 9; i++) B[i] = A[i];
}

/* C = A B */
static inline void kf_m3_mul(kf_real C[9], const kf_real A[9], const kf_real B[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* C = A Bᵀ */
static inline void kf_m3_mul_bt(kf_real C[9], const kf_real A[9], const kf_real B[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            C[3 * i + j] = A[3 * i] * B[3 * j] + A[3 * i + 1] * B[3 * j + 1] + A[3 * i + 2] * B[3 * j + 2];
}

/* C = Aᵀ B */
static inline void kf_m3_mul_at(kf_real C[9], const kf_real A[9], const kf_real B[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            C[3 * i + j] = A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j];
}

static inline void kf_m3_transpose(kf_real B[9], const kf_real A[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) B[3 * j + i] = A[3 * i + j];
}

static inline kf_real kf_m3_det(const kf_real A[9]) {
    return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) +
           A[2] * (A[3] * A[7] - A[4] * A[6]);
}

static inline kf_real kf_m3_trace(const kf_real A[9]) { return A[0] + A[4] + A[8]; }

/* Frobenius inner product A:B */
static inline kf_real kf_m3_ddot(const kf_real A[9], const kf_real B[9]) {
    kf_real s = 0;
    for (int i = 0; i < 9; i++) s += A[i] * B[i];
    return s;
}

/* cofactor matrix: cof(A) = det(A) A⁻ᵀ, defined for singular A too */
static inline void kf_m3_cofactor(kf_real K[9], const kf_real A[9]) {
    K[0] = A[4] * A[8] - A[5] * A[7];
    K[1] = A[5] * A[6] - A[3] * A[8];
    K[2] = A[3] * A[7] - A[4] * A[6];
    K[3] = A[2] * A[7] - A[1] * A[8];
    K[4] = A[0] * A[8] - A[2] * A[6];
    K[5] = A[1] * A[6] - A[0] * A[7];
    K[6] = A[1] * A[5] - A[2] * A[4];
    K[7] = A[2] * A[3] - A[0] * A[5];
    K[8] = A[0] * A[4] - A[1] * A[3];
}

/* U diag(s) Vᵀ */
static inline void kf_m3_usvt(kf_real A[9], const kf_real U[9], const kf_real s[3], const kf_real V[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            A[3 * i + j] = U[3 * i] * s[0] * V[3 * j] + U[3 * i + 1] * s[1] * V[3 * j + 1] +
                           U[3 * i + 2] * s[2] * V[3 * j + 2];
}

#endif
