/* svd.c — double-precision 3x3 symmetric eigensolver and
 * sign-fixed SVD for the implicit solve's energies.
 *
 * The library's kf_svd3 rounds its output to kf_real; the Newton solve and
 * its finite-difference checks need the stress and Hessian to double
 * round-off, so the energies use this double path. The SVD follows the
 * eigenvalue route: V from the eigenvectors of FᵀF (Jacobi, which converges
 * to round-off), then B = F V is orthogonalised column by column (its
 * columns are already orthogonal up to round-off, so Gram–Schmidt is stable)
 * and the singular values are B's column lengths, not square roots of
 * eigenvalues, so small ones keep their absolute accuracy. */
#include <math.h>

#include "implicit.h"

/* cyclic Jacobi on a symmetric 3x3: rotate away the largest off-diagonal
 * entries until they are below round-off of the diagonal */
void kf_imp_sym_eig3(const double A[9], double w[3], double Q[9]) {
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

static void cross(const double a[3], const double b[3], double c[3]) {
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* a unit vector orthogonal to the unit vector u */
static void orthogonal_to(const double u[3], double o[3]) {
    int k = fabs(u[0]) <= fabs(u[1]) ? (fabs(u[0]) <= fabs(u[2]) ? 0 : 2) : (fabs(u[1]) <= fabs(u[2]) ? 1 : 2);
    double e[3] = {0, 0, 0};
    e[k] = 1;
    cross(u, e, o);
    double n = sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2]);
    for (int a = 0; a < 3; a++) o[a] /= n;
}

void kf_imp_svd(const double F[9], double U[9], double sigma[3], double V[9]) {
    /* V: eigenvectors of FᵀF, sorted by decreasing eigenvalue, det V = +1 */
    double S[9], w[3], Q[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) S[3 * i + j] = F[i] * F[j] + F[3 + i] * F[3 + j] + F[6 + i] * F[6 + j];
    kf_imp_sym_eig3(S, w, Q);
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
    double det = V[0] * (V[4] * V[8] - V[5] * V[7]) - V[1] * (V[3] * V[8] - V[5] * V[6]) +
                 V[2] * (V[3] * V[7] - V[4] * V[6]);
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
    cross(u[0], u[1], u[2]);
    sigma[0] = n0;
    sigma[1] = u[1][0] * b[1][0] + u[1][1] * b[1][1] + u[1][2] * b[1][2];
    sigma[2] = u[2][0] * b[2][0] + u[2][1] * b[2][1] + u[2][2] * b[2][2];
    if (sigma[1] < 0) sigma[1] = 0; /* round-off of a rank-1 F */
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) U[3 * i + j] = u[j][i];
}
