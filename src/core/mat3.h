/* mat3.h — the one home of kerf's small 3x3 algebra: on kf_real (kf_m3_*)
 * for the particle loops, and in double (kf_m3d_*, kf_v3d_*) with the
 * rotations (axis-angle, quaternions) the rigid bodies need.
 *
 * Matrices are row-major arrays of 9: A[3*i + j] = A_ij. All functions are
 * static inline so the per-particle hot loops can be specialised by the
 * compiler. The output comes first; outputs may not alias inputs unless
 * stated. */
#ifndef KF_MAT3_H
#define KF_MAT3_H

#include <math.h>

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
        for (int j = 0; j < 3; j++) C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
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
        for (int j = 0; j < 3; j++) C[3 * i + j] = A[i] * B[j] + A[3 + i] * B[3 + j] + A[6 + i] * B[6 + j];
}

static inline void kf_m3_transpose(kf_real B[9], const kf_real A[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) B[3 * j + i] = A[3 * i + j];
}

static inline kf_real kf_m3_det(const kf_real A[9]) {
    return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) + A[2] * (A[3] * A[7] - A[4] * A[6]);
}

static inline kf_real kf_m3_trace(const kf_real A[9]) { return A[0] + A[4] + A[8]; }

/* Frobenius inner product A:B */
static inline kf_real kf_m3_ddot(const kf_real A[9], const kf_real B[9]) {
    kf_real s = 0;
    for (int i = 0; i < 9; i++) s += A[i] * B[i];
    return s;
}

/* cofactor matrix: cof(A) = det(A) A⁻ᵀ, defined for singular A too; one
 * body for the kf_real and the double version */
#define KF_M3_COFACTOR(K, A)                                                                                           \
    do {                                                                                                               \
        K[0] = A[4] * A[8] - A[5] * A[7];                                                                              \
        K[1] = A[5] * A[6] - A[3] * A[8];                                                                              \
        K[2] = A[3] * A[7] - A[4] * A[6];                                                                              \
        K[3] = A[2] * A[7] - A[1] * A[8];                                                                              \
        K[4] = A[0] * A[8] - A[2] * A[6];                                                                              \
        K[5] = A[1] * A[6] - A[0] * A[7];                                                                              \
        K[6] = A[1] * A[5] - A[2] * A[4];                                                                              \
        K[7] = A[2] * A[3] - A[0] * A[5];                                                                              \
        K[8] = A[0] * A[4] - A[1] * A[3];                                                                              \
    } while (0)
static inline void kf_m3_cofactor(kf_real K[9], const kf_real A[9]) { KF_M3_COFACTOR(K, A); }

/* U diag(s) Vᵀ */
static inline void kf_m3_usvt(kf_real A[9], const kf_real U[9], const kf_real s[3], const kf_real V[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            A[3 * i + j] =
                U[3 * i] * s[0] * V[3 * j] + U[3 * i + 1] * s[1] * V[3 * j + 1] + U[3 * i + 2] * s[2] * V[3 * j + 2];
}

/* ---- double precision -------------------------------------------------------
 * The same algebra in double, whatever kf_real is: the constitutive models'
 * internals, the rigid bodies, the crossing guard. Output first, as above. */

static inline double kf_m3d_det(const double A[9]) {
    return A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) + A[2] * (A[3] * A[7] - A[4] * A[6]);
}

/* cofactor matrix (KF_M3_COFACTOR above) */
static inline void kf_m3d_cofactor(double K[9], const double A[9]) { KF_M3_COFACTOR(K, A); }

/* y = A x */
static inline void kf_m3d_mv(double y[3], const double A[9], const double x[3]) {
    for (int i = 0; i < 3; i++) y[i] = A[3 * i] * x[0] + A[3 * i + 1] * x[1] + A[3 * i + 2] * x[2];
}

/* y = Aᵀ x */
static inline void kf_m3d_mtv(double y[3], const double A[9], const double x[3]) {
    for (int i = 0; i < 3; i++) y[i] = A[i] * x[0] + A[3 + i] * x[1] + A[6 + i] * x[2];
}

/* C = A B */
static inline void kf_m3d_mul(double C[9], const double A[9], const double B[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

static inline void kf_v3d_cross(double c[3], const double a[3], const double b[3]) {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

static inline double kf_v3d_dot(const double a[3], const double b[3]) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}

/* the rotation by angle |w| about w (Rodrigues), row-major */
static inline void kf_m3d_rotvec(double R[9], const double w[3]) {
    double th = sqrt(kf_v3d_dot(w, w));
    double k[3] = {0, 0, 1};
    if (th > 0) k[0] = w[0] / th, k[1] = w[1] / th, k[2] = w[2] / th;
    double c = cos(th), s = sin(th), C = 1 - c;
    R[0] = c + k[0] * k[0] * C, R[1] = k[0] * k[1] * C - k[2] * s, R[2] = k[0] * k[2] * C + k[1] * s;
    R[3] = k[1] * k[0] * C + k[2] * s, R[4] = c + k[1] * k[1] * C, R[5] = k[1] * k[2] * C - k[0] * s;
    R[6] = k[2] * k[0] * C - k[1] * s, R[7] = k[2] * k[1] * C + k[0] * s, R[8] = c + k[2] * k[2] * C;
}

/* unit quaternion (w, x, y, z) ↔ rotation matrix */
static inline void kf_m3d_from_quat(double R[9], const double q[4]) {
    double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

static inline void kf_m3d_to_quat(double q[4], const double R[9]) {
    double tr = R[0] + R[4] + R[8];
    if (tr > 0) {
        double s = 2 * sqrt(tr + 1);
        q[0] = 0.25 * s, q[1] = (R[7] - R[5]) / s, q[2] = (R[2] - R[6]) / s, q[3] = (R[3] - R[1]) / s;
    } else if (R[0] > R[4] && R[0] > R[8]) {
        double s = 2 * sqrt(1 + R[0] - R[4] - R[8]);
        q[0] = (R[7] - R[5]) / s, q[1] = 0.25 * s, q[2] = (R[1] + R[3]) / s, q[3] = (R[2] + R[6]) / s;
    } else if (R[4] > R[8]) {
        double s = 2 * sqrt(1 + R[4] - R[0] - R[8]);
        q[0] = (R[2] - R[6]) / s, q[1] = (R[1] + R[3]) / s, q[2] = 0.25 * s, q[3] = (R[5] + R[7]) / s;
    } else {
        double s = 2 * sqrt(1 + R[8] - R[0] - R[4]);
        q[0] = (R[3] - R[1]) / s, q[1] = (R[2] + R[6]) / s, q[2] = (R[5] + R[7]) / s, q[3] = 0.25 * s;
    }
    double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int i = 0; i < 4; i++) q[i] /= n;
}

/* x = A⁻¹ b for symmetric positive definite A (Cramer; 3x3 only) */
static inline void kf_m3d_solve_spd(double x[3], const double A[9], const double b[3]) {
    double c0[3] = {A[0], A[3], A[6]}, c1[3] = {A[1], A[4], A[7]}, c2[3] = {A[2], A[5], A[8]};
    double t[3];
    kf_v3d_cross(t, c1, c2);
    double det = kf_v3d_dot(c0, t);
    double x0 = kf_v3d_dot(b, t);
    kf_v3d_cross(t, c2, c0);
    double x1 = kf_v3d_dot(b, t);
    kf_v3d_cross(t, c0, c1);
    double x2 = kf_v3d_dot(b, t);
    x[0] = x0 / det, x[1] = x1 / det, x[2] = x2 / det;
}

#endif
