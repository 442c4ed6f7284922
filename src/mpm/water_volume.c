/* water_volume.c — water's volume ratio J on the grid (sim.water_volume: grid).
 *
 * Water keeps F = I and tracks J ← (1 + Δt tr L) J per particle (transfer.c).
 * Left to itself each particle's J drifts on its own, with two visible
 * faults in water at rest (measured in a 0.4 m tank, 0.15-0.2 m deep):
 *  - neighbours end up with J a few per cent apart in layers a cell thick,
 *    and since p = κ(J^−γ − 1) the pressure alternates by more than its
 *    hydrostatic range (400, 2500, 2100, 400, 1400 Pa at successive
 *    centimetres up from the floor instead of a steady fall);
 *  - particles pack tighter than their J says (1.5-2x the rest density near
 *    the floor with J ≈ 0.99): the water's mean height fell by a third
 *    from 0.2 s to 2 s (κ = 1e4; by a tenth from 1 s to 2 s at κ = 1e5),
 *    with no pressure to stop it (tests/test_water_volume.c).
 * The grid mode, before G2P updates J, replaces each water particle's J by
 *     J̄_p = Σ_i w_ip J_i,   J_i = min(Σ_p w_ip m_p J_p / Σ_p w_ip m_p,  ρ₀ Δx³ / m_i)
 * the mass-weighted average of the water's J at the nodes of its stencil,
 * which keeps Σ m_p J_p and removes the modes the grid cannot see, capped
 * where the node holds more water mass m_i than a cell of water at rest:
 * there the particles are packed tighter than their J says, and the cap
 * gives them the pressure of their real packing. Where a node is only
 * partly covered (free surface, walls) m_i is small and the cap never acts,
 * so the surface feels no tension. Only water particles take part, so other
 * materials neither blur nor cap it. The average uses the positions of the
 * substep's binning, like P2G, and the scatter runs owner by owner in the
 * same colour order, so results stay bitwise independent of the thread count. */
#include <stdlib.h>
#include <string.h>

#include "transfer_chunk.h"

/* does any material need the grid's J (water, in grid mode) */
static int wants_average(const kf_model *m) {
    if (m->sim.water_volume != KF_WATER_VOLUME_GRID) return 0;
    for (int k = 0; k < m->nmat; k++)
        if (m->mat[k].model == KF_MAT_WATER) return 1;
    return 0;
}

/* the water's rest density (one water material is the usual case; with
 * several, the densest: the cap then acts only on truly overpacked nodes) */
static double water_density(const kf_model *m) {
    double rho = 0;
    for (int k = 0; k < m->nmat; k++)
        if (m->mat[k].model == KF_MAT_WATER && m->mat[k].rho > rho) rho = m->mat[k].rho;
    return rho;
}

/* node (a, b, c) of the owner's neighbourhood nb in a per-node array of pairs */
static inline kf_real *nb_pair(kf_real *wj, const int32_t *nb, int a, int b, int c) {
    int blk = nb[(a >> 2) << 2 | (b >> 2) << 1 | (c >> 2)];
    return &wj[2 * ((size_t)blk * KF_BLOCK_NODES + (size_t)((a & 3) << 4 | (b & 3) << 2 | (c & 3)))];
}

/* One owner's water: weights into a dense cache of its neighbourhood (edge
 * CD), then the cache into the grid's blocks, as P2G does with momentum. */
KF_INLINE void scatter_block(int KW, const kf_model *m, kf_state *s, size_t r, chunk *ck, kf_real (*cache)[2]) {
    const int CD = 3 + KW;
    const kf_particles *p = &s->p;
    const kf_grid *g = &s->g;
    const kf_real dx = (kf_real)m->sim.dx, inv_dx = kf_model_inv_dx(m);
    const int32_t *bc = &g->bcoord[3 * r], *nb = g->nb[r];
    int any = 0;
    for (size_t i0 = g->pstart[r]; i0 < g->pstart[r + 1]; i0 += KF_CHUNK) {
        size_t left = g->pstart[r + 1] - i0;
        ck->n = left < KF_CHUNK ? (int)left : KF_CHUNK;
        int water = 0;
        for (int j = 0; j < ck->n; j++) water |= m->mat[p->mat[i0 + (size_t)j]].model == KF_MAT_WATER;
        if (!water) continue;
        if (!any) memset(cache, 0, sizeof(kf_real[2]) * (size_t)(CD * CD * CD)), any = 1;
        stencil_phase(KW, ck, p->x, i0, bc, inv_dx, dx);
        for (int j = 0; j < ck->n; j++) {
            size_t i = i0 + (size_t)j;
            if (m->mat[p->mat[i]].model != KF_MAT_WATER) continue;
            const kf_real mass = p->mass[i], mj = mass * p->ps[0][i];
            for (int a = 0; a < KW; a++)
                for (int b = 0; b < KW; b++) {
                    const kf_real wab = ck->w[0][a][j] * ck->w[1][b][j];
                    kf_real(*row)[2] = &cache[((ck->l[0][j] + a) * CD + ck->l[1][j] + b) * CD + ck->l[2][j]];
                    for (int c = 0; c < KW; c++) {
                        const kf_real w = wab * ck->w[2][c][j];
                        row[c][0] += w * mj;
                        row[c][1] += w * mass;
                    }
                }
        }
    }
    if (!any) return;
    for (int a = 0; a < CD; a++)
        for (int b = 0; b < CD; b++)
            for (int c = 0; c < CD; c++) {
                const kf_real *from = cache[(a * CD + b) * CD + c];
                kf_real *node = nb_pair(s->water_j, nb, a, b, c);
                node[0] += from[0];
                node[1] += from[1];
            }
}

static void scatter_q(const kf_model *m, kf_state *s, size_t r, chunk *ck, kf_real (*cache)[2]) {
    scatter_block(3, m, s, r, ck, cache);
}
static void scatter_c(const kf_model *m, kf_state *s, size_t r, chunk *ck, kf_real (*cache)[2]) {
    scatter_block(4, m, s, r, ck, cache);
}

int kf_water_volume_scatter(const kf_model *m, kf_state *s) {
    if (!wants_average(m)) return 0;
    kf_grid *g = &s->g;
    size_t need = g->nblocks * KF_BLOCK_NODES * 2;
    if (need > s->water_j_cap) {
        kf_real *w = realloc(s->water_j, need * sizeof *w);
        if (!w) return -1;
        s->water_j = w;
        s->water_j_cap = need;
    }
    memset(s->water_j, 0, need * sizeof *s->water_j);
    void (*fn)(const kf_model *, kf_state *, size_t, chunk *, kf_real(*)[2]) =
        m->sim.kernel == KF_KERNEL_CUBIC ? scatter_c : scatter_q;
#pragma omp parallel num_threads(m->nthreads)
    {
        chunk ck __attribute__((aligned(64)));
        kf_real cache[CD_MAX * CD_MAX * CD_MAX][2];
        /* one colour at a time: same-colour owners write disjoint nodes */
        for (int c = 0; c < 8; c++) {
#pragma omp for schedule(dynamic, 4)
            for (size_t k = g->colour_start[c]; k < g->colour_start[c + 1]; k++)
                fn(m, s, (size_t)g->owner[k], &ck, cache);
        }
    }
    /* the nodes' averages in place of the sums, capped at the packing */
    size_t nn = g->nblocks * KF_BLOCK_NODES;
    const kf_real cell_mass = (kf_real)(water_density(m) * m->sim.dx * m->sim.dx * m->sim.dx);
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t k = 0; k < nn; k++) {
        kf_real *node = &s->water_j[2 * k];
        if (!(node[1] > 0)) continue;
        kf_real average = node[0] / node[1], packing = cell_mass / node[1];
        node[0] = average < packing ? average : packing;
    }
    s->water_j_valid = 1;
    return 0;
}

void kf_water_volume_owner(int KW, const kf_state *s, size_t r, kf_real *jc) {
    const int CD = 3 + KW;
    const int32_t *nb = s->g.nb[r];
    for (int a = 0; a < CD; a++)
        for (int b = 0; b < CD; b++)
            for (int c = 0; c < CD; c++) jc[(a * CD + b) * CD + c] = nb_pair(s->water_j, nb, a, b, c)[0];
}
