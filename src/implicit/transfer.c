/* transfer.c — the implicit solve's transfers, in double.
 *
 * Once per substep each particle's stencil is laid out flat: the grid node
 * of every stencil entry and its γ_ip (MLS: w_ip D⁻¹ (x_i − x_p), classic:
 * ∇w_ip), while mass and APIC momentum go to the grid (P2G without the
 * stress term: the solve supplies the force). Every Newton and Krylov
 * iteration is then a gather G_p = Σ_i x_i γ_ipᵀ (G2P, Eq. 19's A_p) and a
 * scatter Σ_p Y_p γ_ip (P2G, Eq. 19's δf_i) over these flat stencils.
 *
 * Scatters run owner colour by owner colour, as the explicit P2G does
 * (grid.h): same-colour owners write disjoint nodes, so there are no atomics
 * and each node sums its contributions in the same order for any thread
 * count. */
#include <stdlib.h>
#include <string.h>

#include "implicit.h"

/* a pragma that takes macro arguments */
#define IMP_PRAGMA(x) _Pragma(#x)
/* The scatters' loop: the statement after it runs for every particle i of
 * grid g, owner by owner, the 8 owner colours in turn (same-colour owners
 * write disjoint nodes, as the top of this file says), on `threads` threads. */
#define IMP_EACH_PARTICLE_BY_COLOUR(g, threads, i)                                                                     \
    IMP_PRAGMA(omp parallel num_threads(threads))                                                                      \
    for (int c_ = 0; c_ < 8; c_++)                                                                                     \
        IMP_PRAGMA(omp for schedule(dynamic, 4))                                                                       \
    for (size_t k_ = (g)->colour_start[c_]; k_ < (g)->colour_start[c_ + 1]; k_++)                                      \
        for (size_t i = (g)->pstart[(size_t)(g)->owner[k_]]; i < (g)->pstart[(size_t)(g)->owner[k_] + 1]; i++)

/* flat node of offset (a, b, c) from an owner's first node, in its 2x2x2 neighbourhood */
static inline int32_t flat_node(const int32_t *nb, int a, int b, int c) {
    int blk = nb[(a >> 2) << 2 | (b >> 2) << 1 | (c >> 2)];
    return (int32_t)(blk * KF_BLOCK_NODES + ((a & 3) << 4 | (b & 3) << 2 | (c & 3)));
}

/* B-spline weights and derivatives (grid units) along one axis, in double;
 * base node as the binning computes it (to the bit) */
static int axis_weights(kf_real x, kf_real inv_dx, int cubic, double w[4], double dw[4], double *fx_out) {
    int base = kf_base_node(x, inv_dx, cubic);
    double fx = (double)x * (double)inv_dx - base;
    if (!cubic) {
        double p = 1.5 - fx, q = fx - 1, r = fx - 0.5;
        w[0] = 0.5 * p * p, w[1] = 0.75 - q * q, w[2] = 0.5 * r * r, w[3] = 0;
        dw[0] = -p, dw[1] = -2 * q, dw[2] = r, dw[3] = 0;
    } else {
        double r1 = fx - 1, s2 = 2 - fx;
        w[0] = s2 * s2 * s2 / 6;
        w[1] = 0.5 * r1 * r1 * r1 - r1 * r1 + 2.0 / 3.0;
        w[2] = 0.5 * s2 * s2 * s2 - s2 * s2 + 2.0 / 3.0;
        w[3] = r1 * r1 * r1 / 6;
        dw[0] = -0.5 * s2 * s2;
        dw[1] = 1.5 * r1 * r1 - 2 * r1;
        dw[2] = -(1.5 * s2 * s2 - 2 * s2);
        dw[3] = 0.5 * r1 * r1;
    }
    *fx_out = fx;
    return base;
}

/* stencil and P2G of mass and momentum for the particles of owner block r */
static void owner_stencils(kf_implicit *w, size_t r, double *mom) {
    const kf_model *m = w->m;
    const kf_particles *p = &w->s->p;
    const kf_grid *g = &w->s->g;
    const int cubic = m->sim.kernel == KF_KERNEL_CUBIC, KW = cubic ? 4 : 3, K = w->K;
    const int classic = m->sim.force == KF_FORCE_CLASSIC, apic = m->sim.transfer == KF_TRANSFER_APIC;
    const double dx = m->sim.dx, inv_dxd = 1 / dx, minv = 1 / kf_model_dfactor(m);
    const kf_real inv_dx = (kf_real)(1.0 / m->sim.dx);
    const int32_t *bc = &g->bcoord[3 * r], *nb = g->nb[r];
    for (size_t i = g->pstart[r]; i < g->pstart[r + 1]; i++) {
        double wt[3][4], dw[3][4], d[3][4];
        int l[3];
        for (int a = 0; a < 3; a++) {
            double fx;
            int base = axis_weights(p->x[a][i], inv_dx, cubic, wt[a], dw[a], &fx);
            l[a] = base - KF_BLOCK * bc[a];
            for (int k = 0; k < KW; k++) d[a][k] = (k - fx) * dx;
        }
        double mp = p->mass[i], vp[3] = {p->v[0][i], p->v[1][i], p->v[2][i]}, C[9];
        for (int k = 0; k < 9; k++) C[k] = apic ? (double)p->C[k][i] : 0.0;
        int32_t *id = w->idx + (size_t)K * i;
        /* γ's factors per axis: w, then h (classic: ∂w/∂x; MLS: w D⁻¹ (x_i − x_p)) */
        double *f = w->wts + (size_t)KF_IMP_WS * i;
        for (int a = 0; a < 3; a++)
            for (int k = 0; k < 4; k++) {
                f[8 * a + k] = k < KW ? wt[a][k] : 0.0;
                f[8 * a + 4 + k] = k >= KW ? 0.0 : classic ? dw[a][k] * inv_dxd : minv * wt[a][k] * d[a][k];
            }
        int e = 0;
        for (int a = 0; a < KW; a++)
            for (int b = 0; b < KW; b++)
                for (int c = 0; c < KW; c++, e++) {
                    double wabc = wt[0][a] * wt[1][b] * wt[2][c], dd[3] = {d[0][a], d[1][b], d[2][c]};
                    int32_t node = flat_node(nb, l[0] + a, l[1] + b, l[2] + c);
                    id[e] = node;
                    /* APIC: m w (v + C (x_i − x_p)) */
                    w->mass[node] += wabc * mp;
                    for (int k = 0; k < 3; k++)
                        mom[KF_IMP_NV * (size_t)node + k] +=
                            wabc * mp * (vp[k] + C[3 * k] * dd[0] + C[3 * k + 1] * dd[1] + C[3 * k + 2] * dd[2]);
                }
        for (int k = 0; k < 9; k++) w->Fn[9 * i + k] = p->F[k][i];
    }
}

void kf_imp_free(kf_implicit *w) {
    void *all[] = {w->idx,    w->wts,  w->mass,     w->vstar, w->Fn,       w->F,       w->S,       w->S_alt,
                   w->Kp,     w->psi,  w->con_node, w->con_P, w->con_mu,   w->con_sep, w->release, w->con_n,
                   w->con_vc, w->v,    w->g,        w->d,     w->r,        w->z,       w->p,       w->q,
                   w->vt,     w->diag, w->bsum,     w->act,   w->act_start};
    for (size_t k = 0; k < sizeof all / sizeof *all; k++) free(all[k]);
    kf_imp_mg_free(w->mg);
    memset(w, 0, sizeof *w);
}

int kf_imp_create(kf_implicit *w, const kf_model *m, kf_state *s, double dt) {
    memset(w, 0, sizeof *w);
    w->m = m;
    w->s = s;
    w->dt = dt;
    const kf_grid *g = &s->g;
    w->nnode = g->nblocks * KF_BLOCK_NODES;
    w->np = s->p.n;
    w->K = m->sim.kernel == KF_KERNEL_CUBIC ? 64 : 27;
    size_t n3 = KF_IMP_NV * w->nnode, np = w->np ? w->np : 1, K = (size_t)w->K;
    w->idx = malloc(np * K * sizeof *w->idx);
    w->wts = malloc(np * KF_IMP_WS * sizeof *w->wts);
    w->mass = calloc(w->nnode + 1, sizeof *w->mass);
    w->vstar = calloc(n3 + 1, sizeof *w->vstar);
    w->Fn = malloc(np * 9 * sizeof *w->Fn);
    w->F = malloc(np * 9 * sizeof *w->F);
    w->Kp = malloc(np * 81 * sizeof *w->Kp);
    w->S = malloc(np * 9 * sizeof *w->S);
    w->S_alt = malloc(np * 9 * sizeof *w->S_alt);
    w->psi = malloc(np * sizeof *w->psi);
    w->bsum = malloc((g->nblocks + 1) * sizeof *w->bsum);
    double **vec[] = {&w->v, &w->g, &w->d, &w->r, &w->z, &w->p, &w->q, &w->vt, &w->diag};
    int bad = 0;
    for (size_t k = 0; k < sizeof vec / sizeof *vec; k++) bad |= !(*vec[k] = calloc(n3 + 1, sizeof(double)));
    if (bad || !w->idx || !w->wts || !w->mass || !w->vstar || !w->Fn || !w->F || !w->Kp || !w->S || !w->S_alt ||
        !w->psi || !w->bsum) {
        kf_imp_free(w);
        return -1;
    }
    /* momentum into vstar, then divided by the mass (plus gravity) */
    double *mom = w->vstar;
#pragma omp parallel num_threads(m->nthreads)
    for (int c = 0; c < 8; c++) {
#pragma omp for schedule(dynamic, 4)
        for (size_t k = g->colour_start[c]; k < g->colour_start[c + 1]; k++)
            owner_stencils(w, (size_t)g->owner[k], mom);
    }
    const double gdt[3] = {dt * m->sim.gravity[0], dt * m->sim.gravity[1], dt * m->sim.gravity[2]};
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t i = 0; i < w->nnode; i++) {
        double mi = w->mass[i];
        for (int k = 0; k < 3; k++) mom[KF_IMP_NV * i + k] = mi > 0 ? mom[KF_IMP_NV * i + k] / mi + gdt[k] : 0.0;
    }
    /* the nodes that carry mass, block by block (a quarter of the sparse
     * grid's nodes on the evidence cantilever): the solver's vector loops
     * visit only these (a stencil node without mass has zero weight, so
     * zero γ too, and every solver vector stays 0 there) */
    w->act = malloc((w->nnode + 1) * sizeof *w->act);
    w->act_start = malloc((g->nblocks + 1) * sizeof *w->act_start);
    if (!w->act || !w->act_start) {
        kf_imp_free(w);
        return -1;
    }
    w->nact = 0;
    for (size_t b = 0; b < g->nblocks; b++) {
        w->act_start[b] = w->nact;
        for (size_t i = b * KF_BLOCK_NODES; i < (b + 1) * KF_BLOCK_NODES; i++)
            if (w->mass[i] > 0) w->act[w->nact++] = (int32_t)i;
    }
    w->act_start[g->nblocks] = w->nact;
    return 0;
}

/* G = Σ_i x_i γ_iᵀ over particle p's KW³ stencil, summed axis by axis:
 * column j of G is Σ_a f0 Σ_b f1 Σ_c f2 x_abc with f = h on axis j and w on
 * the others (KW a constant where inlined, so the loops unroll) */
static inline void gather_kw(const kf_implicit *w, const double *x, size_t p, double G[9], const int KW) {
    const int32_t *id = w->idx + (size_t)w->K * p;
    const double *f = w->wts + (size_t)KF_IMP_WS * p;
    const double *w0 = f, *h0 = f + 4, *w1 = f + 8, *h1 = f + 12, *w2 = f + 16, *h2 = f + 20;
    kf_v4d c0 = {0, 0, 0, 0}, c1 = c0, c2 = c0;
    int e = 0;
    for (int a = 0; a < KW; a++) {
        kf_v4d t00 = {0, 0, 0, 0}, t01 = t00, t10 = t00;
        for (int b = 0; b < KW; b++) {
            kf_v4d s0 = {0, 0, 0, 0}, s1 = s0;
            for (int c = 0; c < KW; c++, e++) {
                const kf_v4d xi = KF_IMP_V4(x, id[e]);
                s0 += w2[c] * xi;
                s1 += h2[c] * xi;
            }
            t00 += w1[b] * s0;
            t01 += h1[b] * s0;
            t10 += w1[b] * s1;
        }
        c0 += h0[a] * t00;
        c1 += w0[a] * t01;
        c2 += w0[a] * t10;
    }
    for (int a = 0; a < 3; a++) G[3 * a] = c0[a], G[3 * a + 1] = c1[a], G[3 * a + 2] = c2[a];
}

static inline void gather(const kf_implicit *w, const double *x, size_t p, double G[9]) {
    if (w->K == 27) gather_kw(w, x, p, G, 3);
    else gather_kw(w, x, p, G, 4);
}

void kf_imp_gather(const kf_implicit *w, const double *x, size_t p, double G[9]) { gather(w, x, p, G); }

void kf_imp_g2p_vector(const kf_implicit *w, const double *x, size_t p, double v[3], double C[9]) {
    const kf_model *m = w->m;
    const kf_particles *pp = &w->s->p;
    const int cubic = m->sim.kernel == KF_KERNEL_CUBIC, KW = cubic ? 4 : 3;
    const double dx = m->sim.dx, minv = 1 / kf_model_dfactor(m);
    const kf_real inv_dx = kf_model_inv_dx(m);
    double wt[3][4], dw[3][4], d[3][4];
    for (int a = 0; a < 3; a++) {
        double fx;
        axis_weights(pp->x[a][p], inv_dx, cubic, wt[a], dw[a], &fx);
        for (int k = 0; k < KW; k++) d[a][k] = minv * (k - fx) * dx;
    }
    const int32_t *id = w->idx + (size_t)w->K * p;
    kf_v4d sv = {0, 0, 0, 0}, c0 = sv, c1 = sv, c2 = sv;
    int e = 0;
    for (int a = 0; a < KW; a++)
        for (int b = 0; b < KW; b++)
            for (int c = 0; c < KW; c++, e++) {
                const kf_v4d wx = (wt[0][a] * wt[1][b] * wt[2][c]) * KF_IMP_V4(x, id[e]);
                sv += wx;
                c0 += d[0][a] * wx;
                c1 += d[1][b] * wx;
                c2 += d[2][c] * wx;
            }
    for (int a = 0; a < 3; a++) v[a] = sv[a], C[3 * a] = c0[a], C[3 * a + 1] = c1[a], C[3 * a + 2] = c2[a];
}

/* out_i += Y γ_i over particle p's stencil: with y_j the columns of Y,
 * Y γ_abc = w2_c (h0_a w1_b y0 + w0_a h1_b y1) + h2_c (w0_a w1_b y2) */
static inline void scatter_kw(const kf_implicit *w, const double Y[9], size_t p, double *out, const int KW) {
    const int32_t *id = w->idx + (size_t)w->K * p;
    const double *f = w->wts + (size_t)KF_IMP_WS * p;
    const double *w0 = f, *h0 = f + 4, *w1 = f + 8, *h1 = f + 12, *w2 = f + 16, *h2 = f + 20;
    const kf_v4d y0 = {Y[0], Y[3], Y[6], 0}, y1 = {Y[1], Y[4], Y[7], 0}, y2 = {Y[2], Y[5], Y[8], 0};
    int e = 0;
    for (int a = 0; a < KW; a++) {
        const kf_v4d u0 = h0[a] * y0, u1 = w0[a] * y1, u2 = w0[a] * y2;
        for (int b = 0; b < KW; b++) {
            const kf_v4d P = w1[b] * u0 + h1[b] * u1, Q = w1[b] * u2;
            for (int c = 0; c < KW; c++, e++) KF_IMP_V4(out, id[e]) += w2[c] * P + h2[c] * Q;
        }
    }
}

static inline void scatter_one(const kf_implicit *w, const double Y[9], size_t p, double *out) {
    if (w->K == 27) scatter_kw(w, Y, p, out, 3);
    else scatter_kw(w, Y, p, out, 4);
}

/* γ of every node of particle p's stencil (3 K) */
static void stencil_gamma(const kf_implicit *w, size_t p, double *ga) {
    const int KW = w->K == 27 ? 3 : 4;
    const double *f = w->wts + (size_t)KF_IMP_WS * p;
    int e = 0;
    for (int a = 0; a < KW; a++)
        for (int b = 0; b < KW; b++)
            for (int c = 0; c < KW; c++, e++) {
                ga[3 * e] = f[4 + a] * f[8 + b] * f[16 + c];
                ga[3 * e + 1] = f[a] * f[12 + b] * f[16 + c];
                ga[3 * e + 2] = f[a] * f[8 + b] * f[20 + c];
            }
}

/* One pass per particle instead of a gather pass and a scatter pass: the
 * stencil (γ and node indices) is read once while it is in cache, and no
 * per-particle Y is stored and read back. Reading x while writing out in
 * owner colours is race-free (x and out are different vectors). */
void kf_imp_scatter_product(const kf_implicit *w, const double *x, double *out) {
    const kf_grid *g = &w->s->g;
    IMP_EACH_PARTICLE_BY_COLOUR(g, w->m->nthreads, i) {
        double G[9], Y[9];
        const double *Kp = w->Kp + 81 * i;
        gather(w, x, i, G);
        /* Y = Kp G (Kp is exactly symmetric) */
        kf_v4d ylo, yhi;
        double y8;
        kf_imp_block9(Kp, G, &ylo, &yhi, &y8);
        for (int j = 0; j < 4; j++) Y[j] = ylo[j], Y[4 + j] = yhi[j];
        Y[8] = y8;
        scatter_one(w, Y, i, out);
    }
}

void kf_imp_scatter(const kf_implicit *w, const double *Y, double *out) {
    const kf_grid *g = &w->s->g;
    IMP_EACH_PARTICLE_BY_COLOUR(g, w->m->nthreads, i) scatter_one(w, Y + 9 * i, i, out);
}

void kf_imp_scatter_diag(const kf_implicit *w, double *out) {
    const kf_grid *g = &w->s->g;
    const int K = w->K;
    IMP_EACH_PARTICLE_BY_COLOUR(g, w->m->nthreads, i) {
        const double *Kp = w->Kp + 81 * i;
        double ga[3 * 64];
        stencil_gamma(w, i, ga);
        const int32_t *id = w->idx + (size_t)K * i;
        /* the diagonal entry (a, a) of node e is γᵀ K_a γ, K_a[b][c] =
         * Kp[(a,b),(a,c)]: with the three a in the lanes of one vector
         * (kbc) and the symmetric pairs summed, 6 vector FMAs a node */
        kf_v4d kbc[3][3];
        for (int b = 0; b < 3; b++)
            for (int bc = 0; bc < 3; bc++)
                kbc[b][bc] = (kf_v4d){Kp[9 * b + bc], Kp[9 * (3 + b) + 3 + bc], Kp[9 * (6 + b) + 6 + bc], 0};
        const kf_v4d k01 = kbc[0][1] + kbc[1][0], k02 = kbc[0][2] + kbc[2][0], k12 = kbc[1][2] + kbc[2][1];
        for (int e = 0; e < K; e++) {
            kf_v4d *o = (kf_v4d *)(out + KF_IMP_NV * (size_t)id[e]);
            const double *ge = ga + 3 * e;
            *o += kbc[0][0] * (ge[0] * ge[0]) + kbc[1][1] * (ge[1] * ge[1]) + kbc[2][2] * (ge[2] * ge[2]) +
                  k01 * (ge[0] * ge[1]) + k02 * (ge[0] * ge[2]) + k12 * (ge[1] * ge[2]);
        }
    }
}
