/* polypic.h — the higher velocity modes of the polypic transfer
 * (sim.transfer: polypic), for the quadratic kernel.
 *
 * A particle's 3x3x3 stencil holds 27 node velocities. On each axis the
 * three functions 1, d and g(d) = d² − α d − ¼ (d = node minus particle, in
 * cells; α = 4 Σ w d³) are orthogonal under the kernel's weights, because
 * Σ w = 1, Σ w d = 0 and Σ w d² = ¼ wherever the particle sits. Their 27
 * tensor products are a complete orthogonal basis of the stencil, so a
 * particle that stores the coefficient of each of them,
 *     c_r = Σ_i w_i e_r(i) v_i / Σ_i w_i e_r(i)²,
 * gives the grid back all 27 node velocities it gathered: one particle's
 * G2P then P2G is the identity. APIC stores four of them (v and C); this
 * stores the other 23 (3 reals each) and the three α, in a table indexed
 * by the particle's stable id, so the particle arrays and their order are
 * untouched. Each higher mode scatters no net momentum (Σ w g = ¼ − ¼ = 0
 * and Σ w d = 0 at any position), so P2G still conserves momentum. */
#ifndef KF_POLYPIC_H
#define KF_POLYPIC_H

#include "model.h"
#include "transfer_chunk.h"

/* added to g's weighted norm Σ w g² (in [0, 3/16]) before dividing by it */
#define KF_POLY_FLOOR KF_R(1e-3)

/* the 23 modes beyond APIC's, as per-axis orders (0: 1, 1: d, 2: g) */
static const unsigned char kf_poly_mode[KF_POLY_MODES][3] = {
    {0, 0, 2}, {0, 1, 1}, {0, 1, 2}, {0, 2, 0}, {0, 2, 1}, {0, 2, 2}, {1, 0, 1}, {1, 0, 2},
    {1, 1, 0}, {1, 1, 1}, {1, 1, 2}, {1, 2, 0}, {1, 2, 1}, {1, 2, 2}, {2, 0, 0}, {2, 0, 1},
    {2, 0, 2}, {2, 1, 0}, {2, 1, 1}, {2, 1, 2}, {2, 2, 0}, {2, 2, 1}, {2, 2, 2}};

/* e[axis][order][node]: the three functions at the stencil's nodes, d from
 * ck->d (m) times 1/Δx, α given per axis */
KF_INLINE void poly_functions(const chunk *ck, int j, kf_real inv_dx, const kf_real alpha[3], kf_real e[3][3][3]) {
    for (int a = 0; a < 3; a++)
        for (int k = 0; k < 3; k++) {
            kf_real d = ck->d[a][k][j] * inv_dx;
            e[a][0][k] = 1;
            e[a][1][k] = d;
            e[a][2][k] = d * d - alpha[a] * d - KF_R(0.25);
        }
}

/* G2P: the 23 coefficients (3 reals each) and α of particle j from the node
 * velocities in cache, into md[KF_POLY_REALS] */
KF_INLINE void poly_gather(const chunk *ck, int j, kf_real inv_dx, const kf_v4 *cache, kf_real *md) {
    const int CD = CD_MAX;
    kf_real alpha[3], e[3][3][3], norm[3][3];
    for (int a = 0; a < 3; a++) {
        kf_real s3 = 0;
        for (int k = 0; k < 3; k++) {
            kf_real d = ck->d[a][k][j] * inv_dx;
            s3 += ck->w[a][k][j] * d * d * d;
        }
        alpha[a] = 4 * s3;
    }
    poly_functions(ck, j, inv_dx, alpha, e);
    /* Σ w e² per axis and order, and the weighted functions w e */
    kf_real we[3][3][3];
    for (int a = 0; a < 3; a++)
        for (int o = 0; o < 3; o++) {
            norm[a][o] = 0;
            for (int k = 0; k < 3; k++) {
                we[a][o][k] = ck->w[a][k][j] * e[a][o][k];
                norm[a][o] += we[a][o][k] * e[a][o][k];
            }
        }
    /* g's weighted norm falls to 0 where a node's weight does (the particle
     * on a cell face): there the mode's coefficient is 0/0 in floats. A
     * floor of KF_POLY_FLOOR (0.5% of the norm's 3/16 at a cell centre)
     * keeps it finite and only shrinks such modes (less energy, never more) */
    for (int a = 0; a < 3; a++) norm[a][2] += KF_POLY_FLOOR;
    /* the projections, one axis at a time: z, then y, then x */
    const kf_v4 *origin = &cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]];
    kf_v4 pz[3][3][3], py[3][3][3]; /* pz[a][b][o2], py[a][o1][o2] */
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            const kf_v4 *row = origin + (a * CD + b) * CD;
            for (int o = 0; o < 3; o++)
                pz[a][b][o] = we[2][o][0] * row[0] + we[2][o][1] * row[1] + we[2][o][2] * row[2];
        }
    for (int a = 0; a < 3; a++)
        for (int o1 = 0; o1 < 3; o1++)
            for (int o2 = 0; o2 < 3; o2++)
                py[a][o1][o2] = we[1][o1][0] * pz[a][0][o2] + we[1][o1][1] * pz[a][1][o2] + we[1][o1][2] * pz[a][2][o2];
    kf_real energy = 0;
    for (int q = 0; q < KF_POLY_MODES; q++) {
        const int o0 = kf_poly_mode[q][0], o1 = kf_poly_mode[q][1], o2 = kf_poly_mode[q][2];
        kf_v4 c = we[0][o0][0] * py[0][o1][o2] + we[0][o0][1] * py[1][o1][o2] + we[0][o0][2] * py[2][o1][o2];
        kf_real nr = norm[0][o0] * norm[1][o1] * norm[2][o2], inv = 1 / nr;
        for (int k = 0; k < 3; k++) md[3 * q + k] = c[k] * inv;
        energy += (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]) * inv;
    }
    for (int a = 0; a < 3; a++) md[3 * KF_POLY_MODES + a] = alpha[a];
    md[3 * KF_POLY_MODES + 3] = energy;
}

/* P2G: particle j's higher modes, m Σ_r c_r e_r(i) at each node, added to
 * the momentum of cache (the mass lane untouched) */
KF_INLINE void poly_scatter(const chunk *ck, int j, kf_real inv_dx, kf_real mass, const kf_real *md, kf_v4 *cache) {
    const int CD = CD_MAX;
    kf_real e[3][3][3];
    poly_functions(ck, j, inv_dx, &md[3 * KF_POLY_MODES], e);
    /* the coefficients as a 3x3x3 array of orders, APIC's four left at zero */
    kf_v4 c[3][3][3] = {{{{0}}}};
    for (int q = 0; q < KF_POLY_MODES; q++)
        c[kf_poly_mode[q][0]][kf_poly_mode[q][1]][kf_poly_mode[q][2]] =
            (kf_v4){md[3 * q], md[3 * q + 1], md[3 * q + 2], 0};
    /* the field at the nodes, one axis at a time: x, then y, then z */
    kf_v4 ux[3][3][3], uy[3][3][3]; /* ux[a][o1][o2], uy[a][b][o2] */
    for (int a = 0; a < 3; a++)
        for (int o1 = 0; o1 < 3; o1++)
            for (int o2 = 0; o2 < 3; o2++)
                ux[a][o1][o2] = e[0][0][a] * c[0][o1][o2] + e[0][1][a] * c[1][o1][o2] + e[0][2][a] * c[2][o1][o2];
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            for (int o2 = 0; o2 < 3; o2++)
                uy[a][b][o2] = e[1][0][b] * ux[a][0][o2] + e[1][1][b] * ux[a][1][o2] + e[1][2][b] * ux[a][2][o2];
    kf_v4 u[3][3][3];
    kf_real energy = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            for (int k = 0; k < 3; k++) {
                u[a][b][k] = e[2][0][k] * uy[a][b][0] + e[2][1][k] * uy[a][b][1] + e[2][2][k] * uy[a][b][2];
                kf_v4 u2 = u[a][b][k] * u[a][b][k];
                energy += ck->w[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j] * (u2[0] + u2[1] + u2[2]);
            }
    /* having moved, the particle weighs its nodes anew: where that would
     * give the modes more energy than they had at G2P (a node it barely
     * saw, nearer now), they are scaled back to it */
    const kf_real had = md[3 * KF_POLY_MODES + 3];
    const kf_real scale = energy > had ? kf_sqrt(had / energy) : 1;
    kf_v4 *origin = &cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]];
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            const kf_real mab = scale * mass * ck->w[0][a][j] * ck->w[1][b][j];
            kf_v4 *row = origin + (a * CD + b) * CD;
            for (int k = 0; k < 3; k++) row[k] += (mab * ck->w[2][k][j]) * u[a][b][k];
        }
}

/* the kinetic energy of a particle's higher modes, ½ m Σ_r |c_r|² Σ w e_r²,
 * needs the weights at its position: kf_state_energy evaluates it there */

#endif
