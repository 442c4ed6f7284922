/* transfer.c — particle-to-grid and grid-to-particle transfers.
 *
 * One code path serves MLS-MPM and classic MPM (kf_sim_def.force), quadratic
 * and cubic B-splines, APIC and PIC, so the variants are compared on equal
 * footing. The kernel width and the force are compile-time constants of each
 * specialisation (always-inlined bodies instantiated by the dispatchers at
 * the bottom), so the stencil loops unroll.
 *
 * Both transfers work owner block by owner block (grid.h): the block's
 * particles scatter into, or gather from, a small dense cache of the block's
 * 2x2x2 neighbourhood, and only the cache touches the sparse grid. */
#include <omp.h>
#include <stdio.h>
#include <string.h>

#include "../core/mat3.h"
#include "model.h"

#define KF_INLINE static inline __attribute__((always_inline))
#define CD_MAX 7 /* cache edge: 4 base offsets + cubic stencil (4) - 1 */

/* ---- kernels ----------------------------------------------------------------
 * fx is the particle position in grid units minus its base node. w[i] is the
 * weight of node base+i, dw[i] its derivative with respect to the particle
 * position, in grid units (divide by Δx for world units). */
KF_INLINE void kernel_weights(int KW, kf_real fx, kf_real w[4], kf_real dw[4]) {
    if (KW == 3) {
        /* quadratic: fx in [0.5, 1.5) */
        kf_real a = KF_R(1.5) - fx, b = fx - 1, c = fx - KF_R(0.5);
        w[0] = KF_R(0.5) * a * a;
        w[1] = KF_R(0.75) - b * b;
        w[2] = KF_R(0.5) * c * c;
        w[3] = 0;
        dw[0] = -a;
        dw[1] = -2 * b;
        dw[2] = c;
        dw[3] = 0;
    } else {
        /* cubic: fx in [1, 2) */
        kf_real r1 = fx - 1, s2 = 2 - fx, a = 2 - fx, d = fx - 1;
        w[0] = a * a * a / 6;
        w[1] = KF_R(0.5) * r1 * r1 * r1 - r1 * r1 + KF_R(2.0 / 3.0);
        w[2] = KF_R(0.5) * s2 * s2 * s2 - s2 * s2 + KF_R(2.0 / 3.0);
        w[3] = d * d * d / 6;
        dw[0] = -KF_R(0.5) * a * a;
        dw[1] = KF_R(1.5) * r1 * r1 - 2 * r1;
        dw[2] = -(KF_R(1.5) * s2 * s2 - 2 * s2);
        dw[3] = KF_R(0.5) * d * d;
    }
}

/* a particle's stencil: base-node offset inside its owner block, weights,
 * and node-minus-particle distances d (world units) per axis */
typedef struct stencil {
    int l[3];
    kf_real w[3][4], dw[3][4], d[3][4];
} stencil;

KF_INLINE void stencil_make(int KW, stencil *st, const kf_real xp[3], const int32_t *bc, kf_real inv_dx,
                            kf_real dx) {
    for (int a = 0; a < 3; a++) {
        kf_real xg = xp[a] * inv_dx;
        int base = kf_base_node(xg, KW == 4);
        kf_real fx = xg - (kf_real)base;
        st->l[a] = base - KF_BLOCK * bc[a];
        kernel_weights(KW, fx, st->w[a], st->dw[a]);
        for (int i = 0; i < 4; i++) st->d[a][i] = ((kf_real)i - fx) * dx;
    }
}

static inline kf_v4 col4(const kf_real M[9], int k) { return (kf_v4){M[k], M[3 + k], M[6 + k], 0}; }

/* ---- trouble: the first (lowest id) particle in trouble, per thread ---- */

typedef struct step_acc {
    kf_trouble trouble;
    double max_cells;
} step_acc;

static void note_trouble(step_acc *acc, const kf_particles *p, size_t i, const char *what, double value, long substep) {
    if (acc->trouble.found && acc->trouble.particle <= p->id[i]) return;
    acc->trouble.found = 1;
    snprintf(acc->trouble.what, sizeof acc->trouble.what, "%s", what);
    acc->trouble.particle = p->id[i];
    acc->trouble.material = p->mat[i];
    acc->trouble.value = value;
    acc->trouble.substep = substep;
}

/* ---- P2G ---------------------------------------------------------------------- */

KF_INLINE void p2g_block(int KW, int CLASSIC, const kf_model *m, kf_state *s, size_t r, kf_real dt, kf_v4 *cache,
                         step_acc *acc) {
    const int CD = 3 + KW;
    kf_particles *p = &s->p;
    kf_grid *g = &s->g;
    const kf_real dx = (kf_real)m->sim.dx, inv_dx = 1 / dx;
    const kf_real minv = (kf_real)(1.0 / kf_model_dfactor(m));
    const int apic = m->sim.transfer == KF_TRANSFER_APIC;
    const int32_t *bc = &g->bcoord[3 * r];
    memset(cache, 0, sizeof(kf_v4) * CD * CD * CD);

    for (size_t i = g->pstart[r]; i < g->pstart[r + 1]; i++) {
        const kf_real xp[3] = {p->x[0][i], p->x[1][i], p->x[2][i]};
        stencil st;
        stencil_make(KW, &st, xp, bc, inv_dx, dx);
        const kf_real mp = p->mass[i];

        /* stress: Kirchhoff τ = P Fᵀ */
        kf_real F[9], tau[9], ps[2] = {p->ps[0][i], p->ps[1][i]};
        for (int k = 0; k < 9; k++) F[k] = p->F[k][i];
        kf_mat_kirchhoff(&m->mat[p->mat[i]], F, ps, tau);
        /* catch non-finite state where it starts, before P2G spreads it */
        kf_real tsum = tau[0] + tau[4] + tau[8] + tau[1] + tau[2] + tau[5];
        if (!(kf_fabs(tsum) < (kf_real)1e30)) note_trouble(acc, p, i, "NaN or Inf stress", (double)tsum, s->substep);

        /* affine momentum m C (zero for PIC) and the stress term */
        kf_real Q[9], T[9];
        const kf_real cm = apic ? mp : 0;
        const kf_real sv = -dt * p->vol0[i];
        for (int k = 0; k < 9; k++) {
            kf_real mc = cm * p->C[k][i];
            if (CLASSIC) {
                Q[k] = mc;
                T[k] = sv * tau[k] * inv_dx; /* times ∇w in grid units */
            } else {
                Q[k] = mc + sv * minv * tau[k]; /* fused MLS: one mat-vec per node */
            }
        }
        const kf_v4 base = {mp * p->v[0][i], mp * p->v[1][i], mp * p->v[2][i], mp};
        const kf_v4 q0 = col4(Q, 0), q1 = col4(Q, 1), q2 = col4(Q, 2);
        kf_v4 t0 = {0}, t1 = {0}, t2 = {0};
        if (CLASSIC) t0 = col4(T, 0), t1 = col4(T, 1), t2 = col4(T, 2);

        for (int a = 0; a < KW; a++) {
            const kf_v4 ha = base + st.d[0][a] * q0;
            for (int b = 0; b < KW; b++) {
                const kf_real wab = st.w[0][a] * st.w[1][b];
                const kf_v4 hab = ha + st.d[1][b] * q1;
                kf_v4 *row = &cache[((st.l[0] + a) * CD + (st.l[1] + b)) * CD + st.l[2]];
                for (int c = 0; c < KW; c++) {
                    kf_v4 add = (wab * st.w[2][c]) * (hab + st.d[2][c] * q2);
                    if (CLASSIC) {
                        /* classic force f = -V⁰ τ ∇w */
                        kf_real g0 = st.dw[0][a] * st.w[1][b] * st.w[2][c];
                        kf_real g1 = st.w[0][a] * st.dw[1][b] * st.w[2][c];
                        kf_real g2 = wab * st.dw[2][c];
                        add += g0 * t0 + g1 * t1 + g2 * t2;
                    }
                    row[c] += add;
                }
            }
        }
    }

    /* flush the cache into the 8 blocks of the neighbourhood */
    const int32_t *nb = g->nb[r];
    for (int a = 0; a < CD; a++)
        for (int b = 0; b < CD; b++) {
            const kf_v4 *row = &cache[(a * CD + b) * CD];
            for (int c = 0; c < CD; c++) {
                int blk = nb[(a >> 2) << 2 | (b >> 2) << 1 | (c >> 2)];
                kf_v4 *node = &g->node[(size_t)blk * KF_BLOCK_NODES + ((a & 3) << 4 | (b & 3) << 2 | (c & 3))];
                *node += row[c];
            }
        }
}

#define P2G_VARIANT(name, KW, CLASSIC)                                                                    \
    static void name(const kf_model *m, kf_state *s, size_t r, kf_real dt, kf_v4 *cache, step_acc *acc) { \
        p2g_block(KW, CLASSIC, m, s, r, dt, cache, acc);                                                \
    }
P2G_VARIANT(p2g_q_mls, 3, 0)
P2G_VARIANT(p2g_q_classic, 3, 1)
P2G_VARIANT(p2g_c_mls, 4, 0)
P2G_VARIANT(p2g_c_classic, 4, 1)

void kf_p2g(const kf_model *m, kf_state *s, kf_real dt, kf_trouble *trouble) {
    typedef void (*p2g_fn)(const kf_model *, kf_state *, size_t, kf_real, kf_v4 *, step_acc *);
    int cubic = m->sim.kernel == KF_KERNEL_CUBIC, classic = m->sim.force == KF_FORCE_CLASSIC;
    p2g_fn fn = cubic ? (classic ? p2g_c_classic : p2g_c_mls) : (classic ? p2g_q_classic : p2g_q_mls);
    kf_grid *g = &s->g;
    kf_grid_clear(g);
    step_acc total = {0};
#pragma omp parallel num_threads(m->nthreads)
    {
        kf_ftz();
        kf_v4 cache[CD_MAX * CD_MAX * CD_MAX] __attribute__((aligned(64)));
        step_acc acc = {0};
        /* one colour at a time: same-colour owners write disjoint nodes */
        for (int c = 0; c < 8; c++) {
#pragma omp for schedule(dynamic, 4)
            for (size_t k = g->colour_start[c]; k < g->colour_start[c + 1]; k++)
                fn(m, s, (size_t)g->owner[k], dt, cache, &acc);
        }
#pragma omp critical
        if (acc.trouble.found && (!total.trouble.found || acc.trouble.particle < total.trouble.particle))
            total.trouble = acc.trouble;
    }
    if (trouble) *trouble = total.trouble;
}

/* ---- G2P ---------------------------------------------------------------------- */

KF_INLINE void g2p_block(int KW, int CLASSIC, const kf_model *m, kf_state *s, size_t r, kf_real dt, kf_v4 *cache,
                         step_acc *acc) {
    const int CD = 3 + KW;
    kf_particles *p = &s->p;
    kf_grid *g = &s->g;
    const kf_real dx = (kf_real)m->sim.dx, inv_dx = 1 / dx;
    const kf_real minv = (kf_real)(1.0 / kf_model_dfactor(m));
    const int32_t *bc = &g->bcoord[3 * r];
    const kf_real jmin = (kf_real)m->sim.j_min, jmax = (kf_real)m->sim.j_max;
    double max_v2 = 0;

    /* gather the neighbourhood's velocities */
    const int32_t *nb = g->nb[r];
    for (int a = 0; a < CD; a++)
        for (int b = 0; b < CD; b++) {
            kf_v4 *row = &cache[(a * CD + b) * CD];
            for (int c = 0; c < CD; c++) {
                int blk = nb[(a >> 2) << 2 | (b >> 2) << 1 | (c >> 2)];
                row[c] = g->node[(size_t)blk * KF_BLOCK_NODES + ((a & 3) << 4 | (b & 3) << 2 | (c & 3))];
            }
        }

    for (size_t i = g->pstart[r]; i < g->pstart[r + 1]; i++) {
        const kf_real xp[3] = {p->x[0][i], p->x[1][i], p->x[2][i]};
        stencil st;
        stencil_make(KW, &st, xp, bc, inv_dx, dx);

        /* v = Σ w v_i, B_k = Σ w d_k v_i, and for classic G_k = Σ ∂_k w v_i */
        kf_v4 v = {0}, b0 = {0}, b1 = {0}, b2 = {0}, g0 = {0}, g1 = {0}, g2 = {0};
        for (int a = 0; a < KW; a++)
            for (int b = 0; b < KW; b++) {
                const kf_real wab = st.w[0][a] * st.w[1][b];
                const kf_v4 *row = &cache[((st.l[0] + a) * CD + (st.l[1] + b)) * CD + st.l[2]];
                kf_v4 ra = {0}, rd = {0}, rg = {0};
                for (int c = 0; c < KW; c++) {
                    ra += st.w[2][c] * row[c];
                    rd += (st.w[2][c] * st.d[2][c]) * row[c];
                    if (CLASSIC) rg += st.dw[2][c] * row[c];
                }
                v += wab * ra;
                b0 += (wab * st.d[0][a]) * ra;
                b1 += (wab * st.d[1][b]) * ra;
                b2 += wab * rd;
                if (CLASSIC) {
                    g0 += (st.dw[0][a] * st.w[1][b]) * ra;
                    g1 += (st.w[0][a] * st.dw[1][b]) * ra;
                    g2 += wab * rg;
                }
            }

        /* C = D⁻¹ B; the F update uses C (MLS) or the spline gradient (classic) */
        kf_real C[9], L[9];
        for (int k = 0; k < 3; k++) {
            C[3 * k] = minv * b0[k];
            C[3 * k + 1] = minv * b1[k];
            C[3 * k + 2] = minv * b2[k];
            if (CLASSIC) {
                L[3 * k] = inv_dx * g0[k];
                L[3 * k + 1] = inv_dx * g1[k];
                L[3 * k + 2] = inv_dx * g2[k];
            }
        }
        const kf_real *Lu = CLASSIC ? L : C;
        for (int k = 0; k < 9; k++) p->C[k][i] = C[k];
        for (int k = 0; k < 3; k++) {
            p->v[k][i] = v[k];
            p->x[k][i] = xp[k] + dt * v[k];
        }

        /* F ← (I + Δt ∇v) F; water tracks only J ← (1 + Δt tr ∇v) J */
        const kf_mat *mat = &m->mat[p->mat[i]];
        kf_real J;
        if (mat->model == KF_MAT_WATER) {
            J = p->ps[0][i] * (1 + dt * (Lu[0] + Lu[4] + Lu[8]));
            p->ps[0][i] = J;
        } else {
            kf_real F[9], A[9], Fn[9];
            for (int k = 0; k < 9; k++) {
                F[k] = p->F[k][i];
                A[k] = dt * Lu[k];
            }
            A[0] += 1, A[4] += 1, A[8] += 1;
            kf_m3_mul(Fn, A, F);
            for (int k = 0; k < 9; k++) p->F[k][i] = Fn[k];
            J = kf_m3_det(Fn);
        }

        /* numerical trouble: non-finite, volume out of range, too fast */
        kf_real v2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        if (!(v2 < (kf_real)1e30) || !(J == J)) note_trouble(acc, p, i, "NaN or Inf velocity", (double)v2, s->substep);
        else if (!(J > jmin && J < jmax)) note_trouble(acc, p, i, "J = det F out of range", (double)J, s->substep);
        if (v2 > max_v2) max_v2 = v2;
    }
    double cells = sqrt(max_v2) * dt * inv_dx;
    if (cells > acc->max_cells) acc->max_cells = cells;
}

#define G2P_VARIANT(name, KW, CLASSIC)                                                                     \
    static void name(const kf_model *m, kf_state *s, size_t r, kf_real dt, kf_v4 *cache, step_acc *acc) {  \
        g2p_block(KW, CLASSIC, m, s, r, dt, cache, acc);                                                 \
    }
G2P_VARIANT(g2p_q_mls, 3, 0)
G2P_VARIANT(g2p_q_classic, 3, 1)
G2P_VARIANT(g2p_c_mls, 4, 0)
G2P_VARIANT(g2p_c_classic, 4, 1)

void kf_g2p(const kf_model *m, kf_state *s, kf_real dt, kf_g2p_result *out) {
    typedef void (*g2p_fn)(const kf_model *, kf_state *, size_t, kf_real, kf_v4 *, step_acc *);
    int cubic = m->sim.kernel == KF_KERNEL_CUBIC, classic = m->sim.force == KF_FORCE_CLASSIC;
    g2p_fn fn = cubic ? (classic ? g2p_c_classic : g2p_c_mls) : (classic ? g2p_q_classic : g2p_q_mls);
    kf_grid *g = &s->g;
    step_acc total = {0};
#pragma omp parallel num_threads(m->nthreads)
    {
        kf_ftz();
        kf_v4 cache[CD_MAX * CD_MAX * CD_MAX] __attribute__((aligned(64)));
        step_acc acc = {0};
#pragma omp for schedule(dynamic, 4)
        for (size_t k = 0; k < g->nowner; k++) fn(m, s, k, dt, cache, &acc);
#pragma omp critical
        {
            if (acc.trouble.found && (!total.trouble.found || acc.trouble.particle < total.trouble.particle))
                total.trouble = acc.trouble;
            if (acc.max_cells > total.max_cells) total.max_cells = acc.max_cells;
        }
    }
    out->trouble = total.trouble;
    out->max_cells = total.max_cells;
}

/* ---- plasticity ------------------------------------------------------------------ */

void kf_plasticity(const kf_model *m, kf_state *s) {
    kf_particles *p = &s->p;
    size_t n = p->n;
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t i = 0; i < n; i++) {
        const kf_mat *mat = &m->mat[p->mat[i]];
        if (!mat->plastic) continue;
        kf_real F[9], ps[2] = {p->ps[0][i], p->ps[1][i]};
        for (int k = 0; k < 9; k++) F[k] = p->F[k][i];
        kf_mat_project(mat, F, ps);
        for (int k = 0; k < 9; k++) p->F[k][i] = F[k];
        p->ps[0][i] = ps[0];
        p->ps[1][i] = ps[1];
    }
}
