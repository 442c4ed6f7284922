/* mg_cycle.c — the multigrid preconditioner of the implicit
 * solve's CG (implicit.h).
 *
 * Level 0's operator is the solve's own projected Hessian action P H P;
 * level l >= 1's is P_l (M_l + Σ_q Γ_qᵀ K_q Γ_q) P_l over its quadrature
 * points (implicit/mg_build.c), refreshed from the per-particle blocks Kp
 * at every Newton iteration. Coarse levels smooth with damped Jacobi,
 * x += ω D⁻¹ (b − A x), ω = OMEGA / λ with λ a power-iteration estimate of
 * λmax(D⁻¹A) taken at the substep's first Newton iteration: one pre- and
 * one post-sweep, the same on both sides, so the cycle is symmetric, and
 * positive definite while ω λmax < 2 (the estimate would have to be low by
 * 2 / OMEGA, while power iteration from a random start comes within a few
 * per cent of the top of these spectra). The coarsest level takes
 * COARSE_SWEEPS of the same sweeps from zero: a fixed polynomial in D⁻¹A,
 * symmetric too. Restriction is the prolongation's transpose, each level's
 * boundary projection applied on both sides. */
#include <math.h>
#include <string.h>

#include "implicit.h"

/* damping relative to 1/λmax(D⁻¹A): 1.5 took the fewest CG iterations on
 * the cantilever of tools/evidence/implicit_sweep.c (1.0: 24% more, 1.8: 4%
 * fewer but closer to the limit 2 where the cycle stops being definite) */
#define OMEGA 1.5
#define POWER_STEPS 10  /* power iterations for λmax (coarse levels: cheap) */
#define COARSE_SWEEPS 8 /* smoothing sweeps that stand in for the coarsest solve */

/* ---- one level's operator and diagonal --------------------------------------------- */

void kf_imp_mg_project(const kf_implicit *w, int l, double *x) {
    if (l == 0) {
        kf_imp_project(w, x);
        return;
    }
    const kf_mg_level *L = &w->mg->lev[l];
    for (size_t k = 0; k < L->ncon; k++) {
        double *xi = x + KF_IMP_NV * (size_t)L->con_node[k];
        const double *P = L->con_P + 9 * k;
        double y[3];
        for (int a = 0; a < 3; a++) y[a] = P[3 * a] * xi[0] + P[3 * a + 1] * xi[1] + P[3 * a + 2] * xi[2];
        for (int a = 0; a < 3; a++) xi[a] = y[a];
    }
}

/* y = P_l A_l x for projected x */
static void apply_op(kf_implicit *w, int l, const double *x, double *y) {
    if (l == 0) {
        kf_imp_hessian_action(w, x, y);
        kf_imp_project(w, y);
        return;
    }
    kf_mg_level *L = &w->mg->lev[l];
    for (size_t i = 0; i < L->nn; i++)
        for (int a = 0; a < KF_IMP_NV; a++) y[KF_IMP_NV * i + a] = a < 3 ? L->mass[i] * x[KF_IMP_NV * i + a] : 0.0;
    for (size_t q = 0; q < L->nq; q++) {
        const int32_t *id = L->idx + 27 * q;
        const double *ga = L->gam + 81 * q, *K = L->K + 81 * q;
        /* G = Σ_i x_i γ_iᵀ (G2P) by columns, Y = K G by K's rows (K is a
         * sum of exactly symmetric blocks), y_i += Y γ_i (P2G); a node's
         * (x, y, z, 0) as one vector */
        kf_v4d c0 = {0, 0, 0, 0}, c1 = c0, c2 = c0;
        for (int e = 0; e < 27; e++) {
            const kf_v4d xi = KF_IMP_V4(x, id[e]);
            const double *ge = ga + 3 * e;
            c0 += xi * ge[0], c1 += xi * ge[1], c2 += xi * ge[2];
        }
        const double G[9] = {c0[0], c1[0], c2[0], c0[1], c1[1], c2[1], c0[2], c1[2], c2[2]};
        kf_v4d ylo, yhi;
        double y8;
        kf_imp_block9(K, G, &ylo, &yhi, &y8);
        const kf_v4d y0 = {ylo[0], ylo[3], yhi[2], 0}, y1 = {ylo[1], yhi[0], yhi[3], 0}, y2 = {ylo[2], yhi[1], y8, 0};
        for (int e = 0; e < 27; e++) {
            const double *ge = ga + 3 * e;
            KF_IMP_V4(y, id[e]) += y0 * ge[0] + y1 * ge[1] + y2 * ge[2];
        }
    }
    kf_imp_mg_project(w, l, y);
}

/* D_l: mass plus Σ_q Σ_bc γ_ib K[(a,b),(a,c)] γ_ic (level 0's is the solve's) */
static void coarse_diag(kf_mg_level *L) {
    for (size_t i = 0; i < L->nn; i++)
        for (int a = 0; a < KF_IMP_NV; a++) L->diag[KF_IMP_NV * i + a] = a < 3 ? L->mass[i] : 0.0;
    for (size_t q = 0; q < L->nq; q++) {
        const double *ga = L->gam + 81 * q, *K = L->K + 81 * q;
        for (int e = 0; e < 27; e++) {
            double *o = L->diag + KF_IMP_NV * (size_t)L->idx[27 * q + e];
            const double *ge = ga + 3 * e;
            for (int a = 0; a < 3; a++) {
                const double *row = K + 9 * (3 * a);
                double t = 0;
                for (int b = 0; b < 3; b++)
                    t += ge[b] *
                         (row[9 * b + 3 * a] * ge[0] + row[9 * b + 3 * a + 1] * ge[1] + row[9 * b + 3 * a + 2] * ge[2]);
                o[a] += t;
            }
        }
    }
}

static size_t level_len(const kf_implicit *w, int l) { return KF_IMP_NV * (l ? w->mg->lev[l].nn : w->nnode); }

static double dot(const double *x, const double *y, size_t n) {
    double s = 0;
    for (size_t k = 0; k < n; k++) s += x[k] * y[k];
    return s;
}

/* x = s D⁻¹ y (+ x when add), projected on level 0 */
static void jacobi(kf_implicit *w, int l, double s, const double *y, double *x, int add) {
    const double *d = w->mg->lev[l].diag;
    if (l == 0) {
        /* the fine level: only its nodes with mass (x and y vanish elsewhere) */
        for (size_t k = 0; k < w->nact; k++) {
            const size_t i = KF_IMP_NV * (size_t)w->act[k];
            for (int a = 0; a < 3; a++) {
                double z = d[i + a] > 0 ? s * y[i + a] / d[i + a] : 0.0;
                x[i + a] = add ? x[i + a] + z : z;
            }
        }
        kf_imp_project(w, x);
        return;
    }
    const size_t n = level_len(w, l);
    for (size_t k = 0; k < n; k++) {
        double z = d[k] > 0 ? s * y[k] / d[k] : 0.0;
        x[k] = add ? x[k] + z : z;
    }
    kf_imp_mg_project(w, l, x);
}

/* λmax(D⁻¹A) by power iteration (Rayleigh quotient of A v = λ D v) from a
 * fixed pseudo-random start on the nodes that carry mass */
static double lambda_max(kf_implicit *w, int l) {
    kf_mg_level *L = &w->mg->lev[l];
    const size_t n = level_len(w, l);
    double *v = L->x, *y = L->t;
    uint32_t s = 12345;
    for (size_t k = 0; k < n; k++) {
        s = s * 1664525u + 1013904223u;
        v[k] = L->diag[k] > 0 && k % KF_IMP_NV < 3 ? (double)(s >> 8) / (1 << 24) - 0.5 : 0.0;
    }
    kf_imp_mg_project(w, l, v);
    double lam = 1;
    for (int it = 0; it < POWER_STEPS; it++) {
        apply_op(w, l, v, y);
        double vy = dot(v, y, n), vdv = 0;
        for (size_t k = 0; k < n; k++) vdv += v[k] * L->diag[k] * v[k];
        if (!(vdv > 0)) break;
        lam = vy / vdv;
        jacobi(w, l, 1.0, y, v, 0);
        double nv = 0;
        for (size_t k = 0; k < n; k++) nv += v[k] * L->diag[k] * v[k];
        if (!(nv > 0)) break;
        nv = 1 / sqrt(nv);
        for (size_t k = 0; k < n; k++) v[k] *= nv;
    }
    return lam > 0 ? lam : 1;
}

/* ---- the refresh at every Newton iteration ------------------------------------------ */

void kf_imp_mg_refresh(kf_implicit *w) {
    kf_imp_mg *mg = w->mg;
    mg->lev[0].diag = w->diag; /* the solve's Jacobi diagonal, mass + stiffness */
    for (int l = 1; l < mg->nlev; l++) {
        kf_mg_level *L = &mg->lev[l];
        const kf_mg_level *F = &mg->lev[l - 1];
        memset(L->K, 0, 81 * L->nq * sizeof *L->K);
        if (l >= 2 && F->q_up) {
            /* the finer level's points, each a sum over particles of this level's cell */
            for (size_t q = 0; q < F->nq; q++) {
                double *K = L->K + 81 * (size_t)F->q_up[q];
                const double *Kc = F->K + 81 * q;
                for (int r = 0; r < 81; r++) K[r] += Kc[r];
            }
        } else {
            for (size_t i = 0; i < w->np; i++) {
                double *K = L->K + 81 * (size_t)L->q_of_p[i];
                const double *Kp = w->Kp + 81 * i;
                for (int r = 0; r < 81; r++) K[r] += Kp[r];
            }
        }
        coarse_diag(L);
    }
    /* the coarse dampings: once per substep (Kp moves little between Newton iterations) */
    if (!mg->estimated)
        for (int l = 1; l < mg->nlev; l++) mg->lev[l].omega = OMEGA / lambda_max(w, l);
    mg->estimated = 1;
}

/* ---- the cycle ----------------------------------------------------------------------- */

/* b_c = P_c Pᵀ t: restriction of the finer level's t to level c */
static void restrict_to(kf_implicit *w, int c, const double *t) {
    kf_mg_level *C = &w->mg->lev[c];
    /* from the fine level, only its nodes with mass have parents */
    const size_t nf = c == 1 ? w->nact : w->mg->lev[c - 1].nn;
    memset(C->b, 0, KF_IMP_NV * C->nn * sizeof *C->b);
    for (size_t jj = 0; jj < nf; jj++) {
        const size_t j = c == 1 ? (size_t)w->act[jj] : jj;
        const int32_t *par = C->par + 8 * j;
        const double *pw = C->pw + 8 * j, *tj = t + KF_IMP_NV * j;
        for (int e = 0; e < 8 && par[e] >= 0; e++) {
            double *cb = C->b + KF_IMP_NV * (size_t)par[e];
            for (int a = 0; a < 3; a++) cb[a] += pw[e] * tj[a];
        }
    }
    kf_imp_mg_project(w, c, C->b);
}

/* x ← P_f (x + P C->x): level c's correction added to the finer level */
static void prolongate_add(kf_implicit *w, int c, double *x) {
    const kf_mg_level *C = &w->mg->lev[c];
    const size_t nf = c == 1 ? w->nact : w->mg->lev[c - 1].nn;
    for (size_t jj = 0; jj < nf; jj++) {
        const size_t j = c == 1 ? (size_t)w->act[jj] : jj;
        const int32_t *par = C->par + 8 * j;
        const double *pw = C->pw + 8 * j;
        double *xj = x + KF_IMP_NV * j;
        for (int e = 0; e < 8 && par[e] >= 0; e++) {
            const double *cx = C->x + KF_IMP_NV * (size_t)par[e];
            for (int a = 0; a < 3; a++) xj[a] += pw[e] * cx[a];
        }
    }
    kf_imp_mg_project(w, c - 1, x);
}

/* x = V_l b on a coarse level l >= 1: one damped-Jacobi sweep before and
 * after the next level's correction, the coarsest level by sweeps alone */
static void vcycle(kf_implicit *w, int l, const double *b, double *x) {
    kf_imp_mg *mg = w->mg;
    kf_mg_level *L = &mg->lev[l];
    const size_t n = level_len(w, l);
    double *t = L->t;
    const int coarsest = l == mg->nlev - 1 || l + 1 >= KF_MG_MAX_LEVELS;
    jacobi(w, l, L->omega, b, x, 0);
    for (int s = 1; s < (coarsest ? COARSE_SWEEPS : 1); s++) {
        apply_op(w, l, x, t);
        for (size_t k = 0; k < n; k++) t[k] = b[k] - t[k];
        jacobi(w, l, L->omega, t, x, 1);
    }
    if (coarsest) return;
    apply_op(w, l, x, t);
    for (size_t k = 0; k < n; k++) t[k] = b[k] - t[k];
    restrict_to(w, l + 1, t);
    vcycle(w, l + 1, mg->lev[l + 1].b, mg->lev[l + 1].x);
    prolongate_add(w, l + 1, x);
    apply_op(w, l, x, t);
    for (size_t k = 0; k < n; k++) t[k] = b[k] - t[k];
    jacobi(w, l, L->omega, t, x, 1);
}

/* The fine level adds its Jacobi step and the coarse correction instead of
 * smoothing before and after it: z = P D⁻¹ r + P P_c V₁ (P_cᵀ r). That costs
 * no fine Hessian product per application (a symmetric fine V(1,1)-cycle
 * costs two: 42% fewer iterations but 13% more CPU time on the evidence
 * cantilever at 20x), and the
 * sum of a positive-definite and a positive semi-definite term is positive
 * definite whatever the fine spectrum, so no fine damping is estimated. */
void kf_imp_mg_apply_active(kf_implicit *w, const double *r, double *z) {
    jacobi(w, 0, 1.0, r, z, 0);
    if (w->mg->nlev < 2) return;
    restrict_to(w, 1, r);
    vcycle(w, 1, w->mg->lev[1].b, w->mg->lev[1].x);
    prolongate_add(w, 1, z);
}

void kf_imp_mg_apply(kf_implicit *w, const double *r, double *z) {
    memset(z, 0, KF_IMP_NV * w->nnode * sizeof *z);
    kf_imp_mg_apply_active(w, r, z);
}
