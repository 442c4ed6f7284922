/* energy.c — Ψ, P = ∂Ψ/∂F and the (projected) Hessian ∂²Ψ/∂F² of
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

/* the volume term g(J) (½λ(J − 1)², with material.h's barrier below J_b):
 * ψ_i = 2μ(σ_i − 1) + g' J/σ_i, ψ_ii = 2μ + g'' (J/σ_i)², and for i ≠ j
 * ψ_ij = σ_k (g'' J + g') */
static void corotated(double mu, double la, const double s[3], principal *o) {
    double J = s[0] * s[1] * s[2], g, g1, g2;
    kf_corot_volume(mu, la, J, 0, &g, &g1, &g2);
    o->psi = g;
    for (int i = 0; i < 3; i++) o->psi += mu * (s[i] - 1) * (s[i] - 1);
    for (int i = 0; i < 3; i++) {
        int j = (i + 1) % 3, k = (i + 2) % 3;
        double Ji = s[j] * s[k]; /* ∂J/∂σ_i */
        o->d[i] = 2 * mu * (s[i] - 1) + g1 * Ji;
        o->A[4 * i] = 2 * mu + g2 * Ji * Ji;
        /* above J_b written as before the barrier, λ σ_k (2J − 1), bit for bit */
        o->A[3 * i + j] = o->A[3 * j + i] = J < KF_COROT_JB ? s[k] * (g2 * J + g1) : la * s[k] * (2 * J - 1);
    }
    for (int q = 0; q < 3; q++) {
        int i = PAIR[q][0], j = PAIR[q][1], k = PAIR[q][2];
        o->stretch[q] = 2 * mu - g1 * s[k];
        double sum = s[i] + s[j];
        if (fabs(sum) < 1e-12) sum = 1e-12; /* only a degenerate, inverted F gets here */
        o->twist[q] = 2 * mu - 4 * mu / sum + g1 * s[k];
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

/* ---- the corotated stress by the polar decomposition -------------------------
 * Ψ and P of the corotated models need only the rotation R of F = R S:
 *     Ψ = μ |F − R|² + ½ λ (J − 1)²,   P = 2μ (F − R) + λ (J − 1) cof F,
 * and Newton's iteration X ← ½ (X + X⁻ᵀ) from X = F finds R to round-off in
 * three to five steps for strains up to tens of per cent (the error squares
 * each step), several times cheaper than the SVD's Jacobi eigen-solve. The
 * line search and the gradient need only Ψ and P; the SVD is left to the
 * Hessian. An inverted or degenerate F (det F <= 0: the SVD's signed
 * rotation is then not the polar factor) takes the SVD path. */

#define POLAR_MAX_STEPS 30
#define POLAR_SCALED_UNTIL 0.1 /* Higham's norm scaling after a step that moved X by more than this */
#define POLAR_DONE 1e-8        /* a step this small leaves an error below its square: round-off */

/* cof X (rows: products of the other two rows); returns det X */
static double cofactor(const double X[9], double C[9]) {
    for (int i = 0; i < 3; i++) {
        const double *a = X + 3 * ((i + 1) % 3), *b = X + 3 * ((i + 2) % 3);
        C[3 * i] = a[1] * b[2] - a[2] * b[1];
        C[3 * i + 1] = a[2] * b[0] - a[0] * b[2];
        C[3 * i + 2] = a[0] * b[1] - a[1] * b[0];
    }
    return X[0] * C[0] + X[1] * C[1] + X[2] * C[2];
}

/* R of F = R S for det F > 0; -1 when F is inverted, degenerate or the iteration stalls */
static int polar_rotation(const double F[9], double R[9]) {
    double X[9], C[9];
    memcpy(X, F, sizeof X);
    for (int step = 0, scaled = 0; step < POLAR_MAX_STEPS; step++) {
        double det = cofactor(X, C);
        if (!(det > 0)) return -1;
        /* X⁻ᵀ = C / det; the scaling γ = √(|X⁻¹| / |X|) speeds up large stretches */
        double g = 1;
        if (scaled) {
            double x2 = 0, c2 = 0;
            for (int k = 0; k < 9; k++) x2 += X[k] * X[k], c2 += C[k] * C[k];
            g = sqrt(sqrt(c2 / x2) / det);
        }
        const double gx = 0.5 * g, gc = 0.5 / (g * det);
        double d2 = 0;
        for (int k = 0; k < 9; k++) {
            double y = gx * X[k] + gc * C[k];
            d2 += (y - X[k]) * (y - X[k]);
            X[k] = y;
        }
        scaled = d2 > POLAR_SCALED_UNTIL * POLAR_SCALED_UNTIL;
        if (d2 <= POLAR_DONE * POLAR_DONE) {
            memcpy(R, X, sizeof X);
            return 0;
        }
    }
    return -1;
}

/* μ and λ of a corotated model (snow: hardened by its plastic J); 0 for the others */
static int corotated_moduli(const kf_mat *m, const kf_real ps[2], double *mu, double *la) {
    double h = 1;
    if (m->model == KF_MAT_SNOW) h = exp((double)m->xi * (1.0 - (double)ps[0]));
    else if (m->model != KF_MAT_COROTATED) return 0;
    *mu = h * m->mu, *la = h * m->lambda;
    return 1;
}

/* Ψ and P of a corotated model from the polar decomposition; -1: use the SVD */
static int corotated_by_polar(const kf_mat *m, const double F[9], const kf_real ps[2], double *psi, double P[9]) {
    double mu, la, R[9], C[9];
    if (!corotated_moduli(m, ps, &mu, &la) || polar_rotation(F, R)) return -1;
    double J = cofactor(F, C), fr2 = 0, g, g1, g2;
    kf_corot_volume(mu, la, J, 0, &g, &g1, &g2);
    for (int k = 0; k < 9; k++) {
        double e = F[k] - R[k];
        fr2 += e * e;
        if (P) P[k] = 2 * mu * e + g1 * C[k];
    }
    *psi = mu * fr2 + g;
    return 0;
}

double kf_imp_energy_psi(const kf_mat *m, const double F[9], const kf_real ps[2]) {
    double U[9], s[3], V[9], psi;
    principal pr;
    if (!corotated_by_polar(m, F, ps, &psi, NULL)) return psi;
    kf_svd3d(F, U, s, V);
    if (principal_of(m, s, ps, &pr)) return NAN;
    return pr.psi;
}

int kf_imp_energy_eval(const kf_mat *m, const double F[9], const kf_real ps[2], int want_hessian, int project,
                       kf_imp_energy *out) {
    return kf_imp_energy_eval_in(m, F, ps, NULL, want_hessian, project, out);
}

int kf_imp_energy_eval_in(const kf_mat *m, const double F[9], const kf_real ps[2], const double *Fn, int want_hessian,
                          int project, kf_imp_energy *out) {
    double U[9], s[3], V[9];
    principal pr;
    /* Ψ and P: by the polar decomposition where it applies, unless the
     * Hessian needs the SVD anyway (the two agree to round-off, far below
     * the line search's slack) */
    int polar = !want_hessian && !corotated_by_polar(m, F, ps, &out->psi, out->P);
    if (polar) return 0;
    kf_svd3d(F, U, s, V);
    if (principal_of(m, s, ps, &pr)) return -1;
    if (!polar) {
        out->psi = pr.psi;
        /* P = U diag(ψ_i) Vᵀ */
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                out->P[3 * a + b] = U[3 * a] * pr.d[0] * V[3 * b] + U[3 * a + 1] * pr.d[1] * V[3 * b + 1] +
                                    U[3 * a + 2] * pr.d[2] * V[3 * b + 2];
    }
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
        kf_sym_eig3d(pr.A, w, Q);
        for (int k = 0; k < 3; k++) w[k] = w[k] > 0 ? w[k] : 0;
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                A[3 * i + j] = Q[3 * i] * w[0] * Q[3 * j] + Q[3 * i + 1] * w[1] * Q[3 * j + 1] +
                               Q[3 * i + 2] * w[2] * Q[3 * j + 2];
    }

    /* In G (F = (I + G) Fⁿ) the Hessian is Tᵀ H T, T: G ↦ G Fⁿ, and since
     * Uᵀ (G Fⁿ) V = Uᵀ G W with W = Fⁿ V, it is the same congruence as H
     * with W in place of V: no 9x9 products afterwards. */
    double W[9];
    for (int b = 0; b < 3; b++)
        for (int l = 0; l < 3; l++)
            W[3 * b + l] = Fn ? Fn[3 * b] * V[l] + Fn[3 * b + 1] * V[3 + l] + Fn[3 * b + 2] * V[6 + l] : V[3 * b + l];
    /* column (c, d) of ∂P/∂F: δF = e_c e_dᵀ, δF̂ = Uᵀ δF W, δP = U Ĥ(δF̂) Wᵀ */
    for (int c = 0; c < 3; c++)
        for (int dd = 0; dd < 3; dd++) {
            double M[9], R[9], T[9];
            for (int k = 0; k < 3; k++)
                for (int l = 0; l < 3; l++) M[3 * k + l] = U[3 * c + k] * W[3 * dd + l];
            for (int i = 0; i < 3; i++) R[4 * i] = A[3 * i] * M[0] + A[3 * i + 1] * M[4] + A[3 * i + 2] * M[8];
            for (int q = 0; q < 3; q++) {
                int i = PAIR[q][0], j = PAIR[q][1];
                double mij = M[3 * i + j], mji = M[3 * j + i];
                R[3 * i + j] = pa[q] * mij + pb[q] * mji;
                R[3 * j + i] = pb[q] * mij + pa[q] * mji;
            }
            /* T = R Wᵀ, δP = U T */
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++)
                    T[3 * i + j] = R[3 * i] * W[3 * j] + R[3 * i + 1] * W[3 * j + 1] + R[3 * i + 2] * W[3 * j + 2];
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
