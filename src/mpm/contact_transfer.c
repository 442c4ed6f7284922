/* contact_transfer.c — the field path of the transfers (contact.h): an owner
 * block where fields may meet scatters each particle's contribution a second
 * time, into its own field's slot at every node, and gathers, at nodes where
 * two fields meet, its own field's velocity instead of the total's.
 *
 * Both run particle by particle on the owner's chunk after the ordinary (or
 * CPIC) transfer of the chunk, reading its stencil. The scatter sums into
 * the owner's field cache, which is added to the slots as the node cache is
 * added to the nodes: owners of one P2G colour write disjoint nodes, so this
 * is race-free and every node sums in the same order of owners for any
 * thread count and, an owner's cache travelling whole, any rank count. */
#include "contact.h"
#include "transfer_chunk.h"

#define NB KF_CACHE_EDGE /* the CPIC colour cache's edge (cpic_seam.h: KF_CPIC_NB) */

/* the grid node (a, b, c) of the owner's neighbourhood, as an index */
static inline size_t node_index(const int32_t *nb, int a, int b, int c) {
    int blk = nb[(a >> 2) << 2 | (b >> 2) << 1 | (c >> 2)];
    return (size_t)blk * KF_BLOCK_NODES + (size_t)((a & 3) << 4 | (b & 3) << 2 | (c & 3));
}

/* compatible in CPIC's sense (cpic.h: kf_cpic_compatible) */
static inline int compatible(uint32_t node, uint32_t part) {
    uint32_t shared = (node & part & 0xAAAAAAAu) >> 1;
    return ((node ^ part) & shared) == 0;
}

/* the particle's volume now: V⁰ det F (water: V⁰ J) */
static inline double volume_now(const kf_model *m, const kf_particles *p, size_t i) {
    if (m->mat[p->mat[i]].model == KF_MAT_WATER) return (double)p->vol0[i] * p->ps[0][i];
    kf_real *const *F = p->F;
    double J = (double)F[0][i] * ((double)F[4][i] * F[8][i] - (double)F[5][i] * F[7][i]) -
               (double)F[1][i] * ((double)F[3][i] * F[8][i] - (double)F[5][i] * F[6][i]) +
               (double)F[2][i] * ((double)F[3][i] * F[7][i] - (double)F[4][i] * F[6][i]);
    return (double)p->vol0[i] * J;
}

void kf_contact_p2g_chunk(const kf_model *m, kf_state *s, size_t owner, const uint32_t *col, const chunk *ck, size_t i0,
                          int kw, int classic, kf_v4 *fcache) {
    kf_contact *c = s->contact;
    const kf_particles *p = &s->p;
    const int32_t *nb = s->g.nb[owner];
    const kf_real inv_dx = kf_model_inv_dx(m);
    for (int j = 0; j < ck->n; j++) {
        size_t i = i0 + (size_t)j;
        const uint16_t f = kf_contact_field(p, i);
        const uint32_t cp = col ? p->colour[i] : 0;
        const kf_real V = (kf_real)volume_now(m, p, i);
        const int l0 = ck->l[0][j], l1 = ck->l[1][j], l2 = ck->l[2][j];
        for (int a = 0; a < kw; a++)
            for (int b = 0; b < kw; b++)
                for (int k = 0; k < kw; k++) {
                    /* only where two fields meet (kf_contact_prepare claimed the slots): one field's
                     * velocity is the total's */
                    size_t q = node_index(nb, l0 + a, l1 + b, l2 + k);
                    uint16_t *id = &c->fid[2 * q];
                    if (id[1] == KF_FIELD_NONE) continue;
                    /* where CPIC separates the particle from the node, nothing (as for the total) */
                    if (col && !compatible(col[((l0 + a) * NB + l1 + b) * NB + l2 + k], cp)) continue;
                    const kf_real w = ck->w[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j];
                    const kf_real gw[3] = {ck->dw[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j],
                                           ck->w[0][a][j] * ck->dw[1][b][j] * ck->w[2][k][j],
                                           ck->w[0][a][j] * ck->w[1][b][j] * ck->dw[2][k][j]};
                    const kf_real d[3] = {ck->d[0][a][j], ck->d[1][b][j], ck->d[2][k][j]};
                    kf_v4 add;
                    for (int r = 0; r < 3; r++) {
                        add[r] = w * (ck->mv[r][j] + ck->q[3 * r][j] * d[0] + ck->q[3 * r + 1][j] * d[1] +
                                      ck->q[3 * r + 2][j] * d[2]);
                        if (classic)
                            add[r] +=
                                ck->t[3 * r][j] * gw[0] + ck->t[3 * r + 1][j] * gw[1] + ck->t[3 * r + 2][j] * gw[2];
                    }
                    add[3] = w * ck->mv[3][j];
                    /* the particle's slot; a third field at the node joins the second */
                    const int slot = id[0] == f ? 0 : 1;
                    kf_v4 *row = &fcache[KF_CONTACT_CACHE_ROWS * (size_t)(((l0 + a) * NB + l1 + b) * NB + l2 + k)];
                    row[slot] += add;
                    /* volume, and its gradient at the node: ∂w/∂x_i = -∂w/∂x_p (dw is the latter, in
                     * grid units); it points into the field */
                    const kf_real gs = -V * inv_dx;
                    row[2 + slot] += (kf_v4){gs * gw[0], gs * gw[1], gs * gw[2], V * w};
                }
    }
}

void kf_contact_add_cache(const kf_model *m, kf_state *s, const int32_t nb[8], const kf_v4 *fcache, const int lohi[6]) {
    kf_contact *c = s->contact;
    const int kw = m->sim.kernel == KF_KERNEL_CUBIC ? 4 : 3;
    for (int a = lohi[0]; a < lohi[3] + kw; a++)
        for (int b = lohi[1]; b < lohi[4] + kw; b++)
            for (int k = lohi[2]; k < lohi[5] + kw; k++) {
                size_t q = node_index(nb, a, b, k);
                if (c->fid[2 * q + 1] == KF_FIELD_NONE) continue; /* the scatter left nothing here */
                const kf_v4 *row = &fcache[KF_CONTACT_CACHE_ROWS * (size_t)((a * NB + b) * NB + k)];
                c->mv[2 * q] += row[0];
                c->mv[2 * q + 1] += row[1];
                c->vol[2 * q] += row[2];
                c->vol[2 * q + 1] += row[3];
            }
}

void kf_contact_g2p_chunk(const kf_model *m, const kf_state *s, size_t owner, const uint32_t *col, chunk *ck, size_t i0,
                          int kw, int classic) {
    const kf_contact *c = s->contact;
    const kf_particles *p = &s->p;
    const int32_t *nb = s->g.nb[owner];
    const kf_v4 *node = s->g.node;
    (void)m;
    for (int j = 0; j < ck->n; j++) {
        size_t i = i0 + (size_t)j;
        const uint16_t f = kf_contact_field(p, i);
        const uint32_t cp = col ? p->colour[i] : 0;
        const int l0 = ck->l[0][j], l1 = ck->l[1][j], l2 = ck->l[2][j];
        kf_real dv[3] = {0, 0, 0}, dB[9] = {0}, dG[9] = {0};
        int any = 0;
        for (int a = 0; a < kw; a++)
            for (int b = 0; b < kw; b++)
                for (int k = 0; k < kw; k++) {
                    size_t q = node_index(nb, l0 + a, l1 + b, l2 + k);
                    const uint16_t *id = &c->fid[2 * q];
                    if (id[1] == KF_FIELD_NONE) continue; /* one field here: the total is its own */
                    if (col && !compatible(col[((l0 + a) * NB + l1 + b) * NB + l2 + k], cp)) continue;
                    const kf_v4 own = c->mv[2 * q + (id[0] == f ? 0 : 1)];
                    const kf_real w = ck->w[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j];
                    const kf_real d[3] = {ck->d[0][a][j], ck->d[1][b][j], ck->d[2][k][j]};
                    const kf_real gw[3] = {ck->dw[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j],
                                           ck->w[0][a][j] * ck->dw[1][b][j] * ck->w[2][k][j],
                                           ck->w[0][a][j] * ck->w[1][b][j] * ck->dw[2][k][j]};
                    any = 1;
                    for (int e = 0; e < 3; e++) {
                        kf_real delta = own[e] - node[q][e];
                        dv[e] += w * delta;
                        for (int g = 0; g < 3; g++) {
                            dB[3 * e + g] += w * delta * d[g];
                            if (classic) dG[3 * e + g] += delta * gw[g];
                        }
                    }
                }
        if (!any) continue;
        for (int e = 0; e < 3; e++) ck->v[e][j] += dv[e];
        for (int e = 0; e < 9; e++) {
            ck->b[e][j] += dB[e];
            if (classic) ck->g[e][j] += dG[e];
        }
    }
}
