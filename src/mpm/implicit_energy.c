/* implicit_energy.c — Ψ, P = ∂Ψ/∂F and the (projected) Hessian ∂²Ψ/∂F² of
 * kerf's elastic models, for the implicit solve.
 *
 * All of them are isotropic, Ψ(F) = ψ(σ) on the signed singular values, so
 * everything follows from ψ, its gradient ψ_i and Hessian ψ_ij in σ
 * (implicit.h). The same formulas as material.c's stresses:
 *   fixed corotated: ψ = μ Σ (σ_i − 1)² + ½ λ (J − 1)²  (snow: μ, λ × e^{ξ(1 − Jp)})
 *   StVK on Hencky strain (von Mises, sand): ψ = μ Σ ε_i² + ½ λ (Σ ε_i)², ε_i = ln σ_i
 * so P Fᵀ is the Kirchhoff stress the explicit path scatters. The 2x2
 * eigenvalues are written without the difference quotient's cancellation,
 * so repeated singular values (F = I) are exact, not 0/0. */
#include <math.h>
#include <string.h>

#include "implicit.h"

/* as material.c: Hencky strain needs σ > 0; flat or inverted directions use this floor */
#define HENCKY_SIGMA_MIN 1e-4

/* ψ in principal space: value, gradient, Hessian, and the pair eigenvalues
 * (stretch (ψ_i − ψ_j)/(σ_i − σ_j), twist (ψ_i + ψ_j)/(σ_i + σ_j)) of the
 * pairs (0,1), (0,2), (1,2) */
typedef struct principal {
    double psi, d[3], A[9], stretch[3], twist[3];
} principal;

static const int PAIR[3][3] = {{0, 1, 2}, {0, 2, 1}, {1, 2, 0}}; /* i, j, and the third k */

static void corotated(double mu, double la, const double s[3], principal *o) {
    double J = s[0] * s[1] * s[2];
    o->psi = 0.5 * la * (J - 1) * (J - 1);
    for (int i = 0; i < 3; i++) o->psi += mu * (s[i] - 1) * (s[i] - 1);
    for (int i = 0; i < 3; i++) {
        int j = (i + 1) % 3, k = (i + 2) % 3;
        double Ji = s[j] * s[k]; /* ∂J/∂σ_i */
        o->d[i] = 2 * mu * (s[i] - 1) + la * (J - 1) * Ji;
        o->A[4 * i] = 2 * mu + la * Ji * Ji;
        /* ∂²ψ/∂σ_i∂σ_j = λ σ_k (2J − 1) for i ≠ j */
        o->A[3 * i + j] = o->A[3 * j + i] = la * s[k] * (2 * J - 1);
    }
    for (int q = 0; q < 3; q++) {
        int i = PAIR[q][0], j = PAIR[q][1], k = PAIR[q][2];
        o->stretch[q] = 2 * mu - la * (J - 1) * s[k];
        double sum = s[i] + s[j];
        if (fabs(sum) < 1e-12) sum = 1e-12; /* only a degenerate, inverted F gets here */
        o->twist[q] = 2 * mu - 4 * mu / sum + la * (J - 1) * s[k];
    }
}

/* (ln a / a − ln b / b) / (a − b) for a, b > 0, without cancellation when a ≈ b */
static double dq_log_over(double a, double b) {
    double x = (a - b) / b, l; /* l = ln(a/b) / (a − b) */
    if (fabs(x) < 1e-5) l = (1 - x / 2 + x * x / 3) / b;
    else l = log1p(x) / (a - b);
    return l / a - log(b) / (a * b);
}

static void hencky(double mu, double la, const double s0[3], principal *o) {
    double s[3], e[3];
    for (int i = 0; i < 3; i++) {
        s[i] = s0[i] < HENCKY_SIGMA_MIN ? HENCKY_SIGMA_MIN : s0[i];
        e[i] = log(s[i]);
    }
    double tr = e[0] + e[1] + e[2];
    o->psi = mu * (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) + 0.5 * la * tr * tr;
    for (int i = 0; i < 3; i++) {
        double t = 2 * mu * e[i] + la * tr; /* Kirchhoff principal stress */
        o->d[i] = t / s[i];
        o->A[4 * i] = (2 * mu + la - t) / (s[i] * s[i]);
        for (int j = 0; j < 3; j++)
            if (j != i) o->A[3 * i + j] = la / (s[i] * s[j]);
    }
    for (int q = 0; q < 3; q++) {
        int i = PAIR[q][0], j = PAIR[q][1];
        o->stretch[q] = 2 * mu * dq_log_over(s[i], s[j]) - la * tr / (s[i] * s[j]);
        o->twist[q] = (o->d[i] + o->d[j]) / (s[i] + s[j]);
    }
}

static int principal_of(const kf_mat *m, const double s[3], const kf_real ps[2], principal *o) {
    memset(o, 0, sizeof *o);
    switch (m->model) {
    case KF_MAT_COROTATED: corotated(m->mu, m->lambda, s, o); return 0;
    case KF_MAT_SNOW: {
        double h = exp((double)m->xi * (1.0 - (double)ps[0]));
        corotated(h * m->mu, h * m->lambda, s, o);
        return 0;
    }
    case KF_MAT_VON_MISES:
    case KF_MAT_SAND: hencky(m->mu, m->lambda, s, o); return 0;
    default: return -1;
    }
}

double kf_imp_energy_psi(const kf_mat *m, const double F[9], const kf_real ps[2]) {
    double U[9], s[3], V[9];
    principal pr;
    kf_imp_svd(F, U, s, V);
    if (principal_of(m, s, ps, &pr)) return NAN;
    return pr.psi;
}

int kf_imp_energy_eval(const kf_mat *m, const double F[9], const kf_real ps[2], int want_hessian, int project,
                       kf_imp_energy *out) {
    double U[9], s[3], V[9];
    principal pr;
    kf_imp_svd(F, U, s, V);
    if (principal_of(m, s, ps, &pr)) return -1;
    out->psi = pr.psi;
    /* P = U diag(ψ_i) Vᵀ */
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            out->P[3 * a + b] = U[3 * a] * pr.d[0] * V[3 * b] + U[3 * a + 1] * pr.d[1] * V[3 * b + 1] +
                                U[3 * a + 2] * pr.d[2] * V[3 * b + 2];
    if (!want_hessian) return 0;

    /* the principal blocks, projected to PSD when asked */
    double A[9];
    memcpy(A, pr.A, sizeof A);
    double pa[3], pb[3]; /* the 2x2 block [[a, b], [b, a]] of each pair */
    for (int q = 0; q < 3; q++) {
        double st = pr.stretch[q], tw = pr.twist[q];
        if (project) st = st > 0 ? st : 0, tw = tw > 0 ? tw : 0;
        pa[q] = 0.5 * (st + tw);
        pb[q] = 0.5 * (st - tw);
    }
    /* a positive-definite block (leading minors > 0, the usual case) is its
     * own projection: the eigen-decomposition is only for the others */
    double m2 = pr.A[0] * pr.A[4] - pr.A[1] * pr.A[3];
    double det = pr.A[0] * (pr.A[4] * pr.A[8] - pr.A[5] * pr.A[7]) - pr.A[1] * (pr.A[3] * pr.A[8] - pr.A[5] * pr.A[6]) +
                 pr.A[2] * (pr.A[3] * pr.A[7] - pr.A[4] * pr.A[6]);
    if (project && !(pr.A[0] > 0 && m2 > 0 && det > 0)) {
        double w[3], Q[9];
        kf_imp_sym_eig3(pr.A, w, Q);
        for (int k = 0; k < 3; k++) w[k] = w[k] > 0 ? w[k] : 0;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                A[3 * i + j] = Q[3 * i] * w[0] * Q[3 * j] + Q[3 * i + 1] * w[1] * Q[3 * j + 1] +
                               Q[3 * i + 2] * w[2] * Q[3 * j + 2];
    }

    /* column (c, d) of ∂P/∂F: δF = e_c e_dᵀ, δF̂ = Uᵀ δF V, δP = U Ĥ(δF̂) Vᵀ */
    for (int c = 0; c < 3; c++)
        for (int dd = 0; dd < 3; dd++) {
            double M[9], R[9], T[9];
            for (int k = 0; k < 3; k++)
                for (int l = 0; l < 3; l++) M[3 * k + l] = U[3 * c + k] * V[3 * dd + l];
            for (int i = 0; i < 3; i++) R[4 * i] = A[3 * i] * M[0] + A[3 * i + 1] * M[4] + A[3 * i + 2] * M[8];
            for (int q = 0; q < 3; q++) {
                int i = PAIR[q][0], j = PAIR[q][1];
                double mij = M[3 * i + j], mji = M[3 * j + i];
                R[3 * i + j] = pa[q] * mij + pb[q] * mji;
                R[3 * j + i] = pb[q] * mij + pa[q] * mji;
            }
            /* T = R Vᵀ, δP = U T */
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++)
                    T[3 * i + j] = R[3 * i] * V[3 * j] + R[3 * i + 1] * V[3 * j + 1] + R[3 * i + 2] * V[3 * j + 2];
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    out->H[9 * (3 * a + b) + 3 * c + dd] =
                        U[3 * a] * T[b] + U[3 * a + 1] * T[3 + b] + U[3 * a + 2] * T[6 + b];
        }
    /* exactly symmetric (the blocks are; this removes the rotations' round-off) */
    for (int i = 0; i < 9; i++)
        for (int j = i + 1; j < 9; j++) {
            double h = 0.5 * (out->H[9 * i + j] + out->H[9 * j + i]);
            out->H[9 * i + j] = out->H[9 * j + i] = h;
        }
    return 0;
}
