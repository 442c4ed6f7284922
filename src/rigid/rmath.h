/* rmath.h — double-precision 3-vectors, 3x3 matrices (row-major) and
 * rotations for the rigid-body code (src/core/mat3.h is in kf_real). */
#ifndef KF_RIGID_RMATH_H
#define KF_RIGID_RMATH_H

#include <math.h>

/* y = A x */
static inline void rm_mv(const double A[9], const double x[3], double y[3]) {
    for (int i = 0; i < 3; i++) y[i] = A[3 * i] * x[0] + A[3 * i + 1] * x[1] + A[3 * i + 2] * x[2];
}

/* y = Aᵀ x */
static inline void rm_mtv(const double A[9], const double x[3], double y[3]) {
    for (int i = 0; i < 3; i++) y[i] = A[i] * x[0] + A[3 + i] * x[1] + A[6 + i] * x[2];
}

/* C = A B */
static inline void rm_mm(const double A[9], const double B[9], double C[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

static inline void rm_cross(const double a[3], const double b[3], double c[3]) {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

static inline double rm_dot(const double a[3], const double b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }

/* the rotation by angle |w| about w (Rodrigues), row-major */
static inline void rm_rotvec(const double w[3], double R[9]) {
    double th = sqrt(rm_dot(w, w));
    double k[3] = {0, 0, 1};
    if (th > 0) k[0] = w[0] / th, k[1] = w[1] / th, k[2] = w[2] / th;
    double c = cos(th), s = sin(th), C = 1 - c;
    R[0] = c + k[0] * k[0] * C, R[1] = k[0] * k[1] * C - k[2] * s, R[2] = k[0] * k[2] * C + k[1] * s;
    R[3] = k[1] * k[0] * C + k[2] * s, R[4] = c + k[1] * k[1] * C, R[5] = k[1] * k[2] * C - k[0] * s;
    R[6] = k[2] * k[0] * C - k[1] * s, R[7] = k[2] * k[1] * C + k[0] * s, R[8] = c + k[2] * k[2] * C;
}

/* unit quaternion (w, x, y, z) ↔ rotation matrix */
static inline void rm_quat_to_mat(const double q[4], double R[9]) {
    double w = q[0], x = q[1], y = q[2], z = q[3];
    R[0] = 1 - 2 * (y * y + z * z), R[1] = 2 * (x * y - w * z), R[2] = 2 * (x * z + w * y);
    R[3] = 2 * (x * y + w * z), R[4] = 1 - 2 * (x * x + z * z), R[5] = 2 * (y * z - w * x);
    R[6] = 2 * (x * z - w * y), R[7] = 2 * (y * z + w * x), R[8] = 1 - 2 * (x * x + y * y);
}

static inline void rm_mat_to_quat(const double R[9], double q[4]) {
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
static inline void rm_solve3(const double A[9], const double b[3], double x[3]) {
    double c0[3] = {A[0], A[3], A[6]}, c1[3] = {A[1], A[4], A[7]}, c2[3] = {A[2], A[5], A[8]};
    double t[3];
    rm_cross(c1, c2, t);
    double det = rm_dot(c0, t);
    double x0 = rm_dot(b, t);
    rm_cross(c2, c0, t);
    double x1 = rm_dot(b, t);
    rm_cross(c0, c1, t);
    double x2 = rm_dot(b, t);
    x[0] = x0 / det, x[1] = x1 / det, x[2] = x2 / det;
}

#endif
