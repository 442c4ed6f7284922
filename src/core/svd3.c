/* svd3.c — sign-fixed 3x3 SVD by one-sided (Hestenes) Jacobi in double.
 *
 * Why one-sided Jacobi on the columns of F instead of an eigen-solve of FᵀF:
 * forming FᵀF squares the condition number, so the small singular directions
 * of a nearly flat F come out with errors of order ε σ0²/σ1. Rotating the
 * columns of B = F V until they are mutually orthogonal keeps every column
 * accurate relative to its own length, at about the same cost. */
#include "svd3.h"

#include <math.h>

#include "mat3.h"

/* stop when every pair of columns of B has |cos| below this: the float build
 * only needs its output rounding, the double build goes to near round-off.
 * Convergence is quadratic, so typically 3 rotating sweeps (4 in double) and
 * one that only checks; the cap bounds the work whatever the input */
#ifdef KF_DOUBLE
#define SVD_TOL 1e-15
#else
#define SVD_TOL 1e-9
#endif
#define SVD_MAX_SWEEPS 12

/* dot product of columns p and q of a row-major 3x3 */
static inline double col_dot(const double B[9], int p, int q) {
    return B[p] * B[q] + B[3 + p] * B[3 + q] + B[6 + p] * B[6 + q];
}

static inline void col_swap_negate(double B[9], int p, int q) {
    /* swap columns p and q and negate the new q, which keeps the determinant */
    for (int i = 0; i < 3; i++) {
        double t = B[3 * i + p];
        B[3 * i + p] = B[3 * i + q];
        B[3 * i + q] = -t;
    }
}

/* any unit vector orthogonal to the unit vector u: project out u from the
 * coordinate axis u is least aligned with */
static void any_orthogonal(const double u[3], double w[3]) {
    int k = 0;
    if (fabs(u[1]) < fabs(u[k])) k = 1;
    if (fabs(u[2]) < fabs(u[k])) k = 2;
    for (int i = 0; i < 3; i++) w[i] = (i == k ? 1.0 : 0.0) - u[k] * u[i];
    double n = sqrt(w[0] * w[0] + w[1] * w[1] + w[2] * w[2]);
    for (int i = 0; i < 3; i++) w[i] /= n;
}

/* the double-precision core; F is not modified */
static void svd3_d(const double F[9], double U[9], double s[3], double V[9]) {
    /* scale so the largest entry is 1: no overflow or underflow in the
     * squared column norms whatever the magnitude of F */
    double scale = 0;
    int finite = 1;
    for (int i = 0; i < 9; i++) {
        if (!isfinite(F[i])) finite = 0;
        if (fabs(F[i]) > scale) scale = fabs(F[i]);
    }
    for (int i = 0; i < 9; i++) U[i] = V[i] = (i % 4 == 0) ? 1.0 : 0.0;
    if (!finite || scale == 0) {
        /* F = 0: any rotations work; NaN or inf: let it show in σ */
        s[0] = s[1] = s[2] = finite ? 0.0 : NAN;
        return;
    }
    double B[9];
    for (int i = 0; i < 9; i++) B[i] = F[i] / scale;

    /* cyclic sweeps over column pairs; a rotation in the (p, q) plane zeroes
     * their inner product; stop after a sweep that rotated nothing */
    const double tol2 = SVD_TOL * SVD_TOL;
    for (int sweep = 0; sweep < SVD_MAX_SWEEPS; sweep++) {
        int rotated = 0;
        for (int p = 0; p < 2; p++) {
            for (int q = p + 1; q < 3; q++) {
                double a = col_dot(B, p, p), b = col_dot(B, q, q), g = col_dot(B, p, q);
                if (g == 0 || g * g <= tol2 * a * b) continue;
                rotated = 1;
                /* tan of the angle t = 2g sgn(d) / (|d| + r), d = b − a,
                 * r = √(d² + 4g²); cos c = 1/√(1+t²) = w/√(2rw), w = |d| + r,
                 * which needs two square roots and one division in series */
                double dd = b - a, r = sqrt(dd * dd + 4 * g * g), w = fabs(dd) + r;
                double inv = 1 / sqrt(2 * r * w);
                double c = w * inv, sn = (dd >= 0 ? 2 * g : -2 * g) * inv;
                for (int i = 0; i < 3; i++) {
                    double bp = B[3 * i + p], bq = B[3 * i + q];
                    B[3 * i + p] = c * bp - sn * bq;
                    B[3 * i + q] = sn * bp + c * bq;
                    double vp = V[3 * i + p], vq = V[3 * i + q];
                    V[3 * i + p] = c * vp - sn * vq;
                    V[3 * i + q] = sn * vp + c * vq;
                }
            }
        }
        if (!rotated) break;
    }

    /* order columns by length, descending; each swap negates a column so
     * det V stays +1 (V is a product of rotations) */
    double n[3] = {col_dot(B, 0, 0), col_dot(B, 1, 1), col_dot(B, 2, 2)};
    for (int pass = 0; pass < 2; pass++) {
        for (int p = 0; p < 2 - pass; p++) {
            if (n[p + 1] > n[p]) {
                double t = n[p];
                n[p] = n[p + 1];
                n[p + 1] = t;
                col_swap_negate(B, p, p + 1);
                col_swap_negate(V, p, p + 1);
            }
        }
    }

    /* U from the columns: u0 along b0, u1 from b1 orthogonalised against u0,
     * u2 = u0 × u1 so det U = +1; σ2 = u2·b2 then carries the sign of det F */
    double u0[3], u1[3], u2[3], b[3][3];
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 3; i++) b[j][i] = B[3 * i + j];
    double n0 = sqrt(n[0]); /* > 0: the largest entry of B is 1 */
    for (int i = 0; i < 3; i++) u0[i] = b[0][i] / n0;
    double d01 = u0[0] * b[1][0] + u0[1] * b[1][1] + u0[2] * b[1][2];
    for (int i = 0; i < 3; i++) u1[i] = b[1][i] - d01 * u0[i];
    double n1 = sqrt(u1[0] * u1[0] + u1[1] * u1[1] + u1[2] * u1[2]);
    if (n1 > 1e-150) {
        for (int i = 0; i < 3; i++) u1[i] /= n1;
    } else {
        /* rank 1 (or 0 after scaling round-off): σ1 is negligible, so any
         * direction orthogonal to u0 reconstructs F */
        any_orthogonal(u0, u1);
    }
    double s1 = u1[0] * b[1][0] + u1[1] * b[1][1] + u1[2] * b[1][2];
    if (s1 < 0) {
        for (int i = 0; i < 3; i++) u1[i] = -u1[i];
        s1 = -s1;
    }
    u2[0] = u0[1] * u1[2] - u0[2] * u1[1];
    u2[1] = u0[2] * u1[0] - u0[0] * u1[2];
    u2[2] = u0[0] * u1[1] - u0[1] * u1[0];
    double s2 = u2[0] * b[2][0] + u2[1] * b[2][1] + u2[2] * b[2][2];
    for (int i = 0; i < 3; i++) {
        U[3 * i] = u0[i];
        U[3 * i + 1] = u1[i];
        U[3 * i + 2] = u2[i];
    }
    s[0] = n0 * scale;
    s[1] = s1 * scale;
    s[2] = s2 * scale;
}

/* public entry: kf_real in and out, double inside */
void kf_svd3(const kf_real F[9], kf_real U[9], kf_real sigma[3], kf_real V[9]) {
    double Fd[9], Ud[9], sd[3], Vd[9];
    for (int i = 0; i < 9; i++) Fd[i] = (double)F[i];
    svd3_d(Fd, Ud, sd, Vd);
    for (int i = 0; i < 9; i++) {
        U[i] = (kf_real)Ud[i];
        V[i] = (kf_real)Vd[i];
    }
    for (int i = 0; i < 3; i++) sigma[i] = (kf_real)sd[i];
}

/* R = U Vᵀ formed in double before rounding, so R is orthonormal to the
 * output precision */
void kf_polar3(const kf_real F[9], kf_real R[9]) {
    double Fd[9], Ud[9], sd[3], Vd[9];
    for (int i = 0; i < 9; i++) Fd[i] = (double)F[i];
    svd3_d(Fd, Ud, sd, Vd);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            R[3 * i + j] =
                (kf_real)(Ud[3 * i] * Vd[3 * j] + Ud[3 * i + 1] * Vd[3 * j + 1] + Ud[3 * i + 2] * Vd[3 * j + 2]);
}

/* ---- double in, double out, to round-off: the implicit solve's energies ----
 *
 * The Newton solve and its finite-difference checks need the stress and
 * Hessian to double round-off whatever kf_real is. This path follows the
 * eigenvalue route: V from the eigenvectors of FᵀF (Jacobi, which converges
 * to round-off), then B = F V is orthogonalised column by column (its
 * columns are already orthogonal up to round-off, so Gram–Schmidt is stable)
 * and the singular values are B's column lengths, not square roots of
 * eigenvalues, so small ones keep their absolute accuracy. It stays beside
 * the one-sided Jacobi above rather than replacing it (or being replaced):
 * either swap changes every result at round-off. */

/* cyclic Jacobi on a symmetric 3x3: rotate away the largest off-diagonal
 * entries until they are below round-off of the diagonal */
void kf_sym_eig3d(const double A[9], double w[3], double Q[9]) {
    double S[9];
    for (int i = 0; i < 9; i++) S[i] = A[i], Q[i] = (i % 4 == 0);
    for (int sweep = 0; sweep < 32; sweep++) {
        double off = S[1] * S[1] + S[2] * S[2] + S[5] * S[5];
        double diag = S[0] * S[0] + S[4] * S[4] + S[8] * S[8];
        if (off <= 1e-34 * diag || off == 0) break;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                double apq = S[3 * p + q];
                /* an entry already below the stopping threshold (a third of it)
                 * needs no rotation: in a converging sweep often two of three */
                if (apq * apq <= 3e-35 * diag) continue;
                double app = S[3 * p + p], aqq = S[3 * q + q];
                /* the rotation angle that zeroes S_pq (Golub & Van Loan 8.4) */
                double theta = (aqq - app) / (2 * apq);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1));
                double c = 1 / sqrt(t * t + 1), s = t * c;
                /* S ← Jᵀ S J, Q ← Q J with J the (p, q) rotation */
                for (int k = 0; k < 3; k++) {
                    double skp = S[3 * k + p], skq = S[3 * k + q];
                    S[3 * k + p] = c * skp - s * skq;
                    S[3 * k + q] = s * skp + c * skq;
                }
                for (int k = 0; k < 3; k++) {
                    double spk = S[3 * p + k], sqk = S[3 * q + k];
                    S[3 * p + k] = c * spk - s * sqk;
                    S[3 * q + k] = s * spk + c * sqk;
                }
                S[3 * p + q] = S[3 * q + p] = 0;
                for (int k = 0; k < 3; k++) {
                    double qkp = Q[3 * k + p], qkq = Q[3 * k + q];
                    Q[3 * k + p] = c * qkp - s * qkq;
                    Q[3 * k + q] = s * qkp + c * qkq;
                }
            }
    }
    for (int i = 0; i < 3; i++) w[i] = S[4 * i];
}

/* a unit vector orthogonal to the unit vector u */
static void orthogonal_to(const double u[3], double o[3]) {
    int k = fabs(u[0]) <= fabs(u[1]) ? (fabs(u[0]) <= fabs(u[2]) ? 0 : 2) : (fabs(u[1]) <= fabs(u[2]) ? 1 : 2);
    double e[3] = {0, 0, 0};
    e[k] = 1;
    kf_v3d_cross(o, u, e);
    double n = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    for (int a = 0; a < 3; a++) o[a] /= n;
}

void kf_svd3d(const double F[9], double U[9], double sigma[3], double V[9]) {
    /* V: eigenvectors of FᵀF, sorted by decreasing eigenvalue, det V = +1 */
    double S[9], w[3], Q[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) S[3 * i + j] = F[i] * F[j] + F[3 + i] * F[3 + j] + F[6 + i] * F[6 + j];
    kf_sym_eig3d(S, w, Q);
    int o[3] = {0, 1, 2};
    for (int a = 0; a < 2; a++)
        for (int b = 0; b < 2 - a; b++)
            if (w[o[b]] < w[o[b + 1]]) {
                int t = o[b];
                o[b] = o[b + 1];
                o[b + 1] = t;
            }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) V[3 * i + j] = Q[3 * i + o[j]];
    double det = kf_m3d_det(V);
    if (det < 0)
        for (int i = 0; i < 3; i++) V[3 * i + 2] = -V[3 * i + 2];

    /* B = F V; U from its columns, σ their (signed, for the last) lengths */
    double b[3][3]; /* b[j] = column j of B */
    for (int j = 0; j < 3; j++)
        for (int i = 0; i < 3; i++) b[j][i] = F[3 * i] * V[j] + F[3 * i + 1] * V[3 + j] + F[3 * i + 2] * V[6 + j];
    double u[3][3];
    double n0 = sqrt(b[0][0] * b[0][0] + b[0][1] * b[0][1] + b[0][2] * b[0][2]);
    if (n0 > 0) {
        for (int i = 0; i < 3; i++) u[0][i] = b[0][i] / n0;
    } else {
        u[0][0] = 1, u[0][1] = 0, u[0][2] = 0;
    }
    double d01 = u[0][0] * b[1][0] + u[0][1] * b[1][1] + u[0][2] * b[1][2];
    double r1[3] = {b[1][0] - d01 * u[0][0], b[1][1] - d01 * u[0][1], b[1][2] - d01 * u[0][2]};
    double n1 = sqrt(r1[0] * r1[0] + r1[1] * r1[1] + r1[2] * r1[2]);
    if (n1 > 1e-300 && n1 > 1e-15 * n0) {
        for (int i = 0; i < 3; i++) u[1][i] = r1[i] / n1;
    } else {
        orthogonal_to(u[0], u[1]);
    }
    kf_v3d_cross(u[2], u[0], u[1]);
    sigma[0] = n0;
    sigma[1] = u[1][0] * b[1][0] + u[1][1] * b[1][1] + u[1][2] * b[1][2];
    sigma[2] = u[2][0] * b[2][0] + u[2][1] * b[2][1] + u[2][2] * b[2][2];
    if (sigma[1] < 0) sigma[1] = 0; /* round-off of a rank-1 F */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) U[3 * i + j] = u[j][i];
}
