/* wall_ghost.c — domain walls where the shot puts them, not at the next node.
 *
 * The grid update constrains a node that lies on or beyond a wall plane.
 * When the plane falls between two nodes, material then flows on until the
 * first constrained node, up to a cell past the wall: a tank 0.4 m wide at
 * 48 cells/m (the plane 0.2 cells short of a node) held water 0.415 m wide,
 * and its level sank 5% while every particle's J stayed hydrostatic.
 *
 * Here every node within a cell of a plane (on either side, not on it)
 * takes the linear velocity profile that is zero on the plane, from the
 * reference node R, the first node at least a cell inside: v = v_R δ / δ_R,
 * with δ a node's distance inside the plane (negative past it). The
 * quadratic and cubic B-splines reproduce a linear field exactly, so
 * material reaching the plane stops there. The profile's slope is at most
 * v_R / Δx, that of a wall on a node, so the pressure waves the wall
 * reflects are no stiffer than before (docs/lab-notes.md, "Walls between
 * nodes", says why not a mirror). slip sets the normal component outright;
 * separate only bounds the outward one by the profile of R's approach (by
 * zero when R is at rest or leaves), so material may leave the wall;
 * sticky sets every component. A node on the plane is the wall as the grid
 * update left it, so walls on nodes do not change.
 *
 * Each axis and side is one pass, shared among the threads of the grid
 * update's parallel region, that writes only nodes within a cell of its
 * plane and reads only nodes at least a cell inside it, so the result does
 * not depend on the thread count. A pass whose plane has no block within a
 * cell is not run (nor waited for). */
#include <math.h>

#include "model.h"

/* whether the block at bc has nodes within a cell of the plane (blocks
 * without any are skipped by the pass) */
static inline int near_plane(const int32_t bc[3], int a, double dx, double plane) {
    const double lo = bc[a] * KF_BLOCK * dx, hi = (bc[a] * KF_BLOCK + KF_BLOCK - 1) * dx;
    return !(hi <= plane - dx || lo >= plane + dx);
}

unsigned kf_wall_ghost_passes(const kf_model *m, const int32_t bc[3]) {
    const kf_sim_def *sd = &m->sim;
    unsigned passes = 0;
    if (!sd->walls) return 0;
    for (int a = 0; a < 3; a++) {
        passes |= (unsigned)near_plane(bc, a, sd->dx, sd->domain_min[a]) << (2 * a);
        passes |= (unsigned)near_plane(bc, a, sd->dx, sd->domain_max[a]) << (2 * a + 1);
    }
    return passes;
}

/* one block's nodes within a cell of the plane at `plane` on axis a,
 * outward out (+1 upper, -1 lower), under the walls' boundary type */
static void ghost_block(kf_grid *g, kf_boundary type, int a, int out, double dx, double plane, size_t b) {
    const int32_t *bc = &g->bcoord[3 * b];
    /* skip blocks with no node within a cell of the plane */
    if (!near_plane(bc, a, dx, plane)) return;
    kf_v4 *node = &g->node[b * KF_BLOCK_NODES];
    for (int l = 0; l < KF_BLOCK_NODES; l++) {
        int idx[3] = {bc[0] * KF_BLOCK + (l >> 4), bc[1] * KF_BLOCK + ((l >> 2) & 3), bc[2] * KF_BLOCK + (l & 3)};
        const double in = out * (plane - idx[a] * dx); /* inside the plane by (negative: beyond) */
        /* a node on the plane (to round-off) is the wall itself, as the grid update left it */
        if (!(fabs(in) > 1e-6 * dx && fabs(in) < dx - 1e-6 * dx) || !(node[l][3] > 0)) continue;
        /* the reference node R: the first at least a cell inside */
        const int steps = in > 0 ? 1 : 2;
        const double inR = in + steps * dx;
        idx[a] -= steps * out;
        int32_t rb = kf_grid_find(g, kf_block_of(idx[0]), kf_block_of(idx[1]), kf_block_of(idx[2]));
        if (rb < 0) continue;
        int li = (idx[0] - kf_block_of(idx[0]) * KF_BLOCK) << 4 | (idx[1] - kf_block_of(idx[1]) * KF_BLOCK) << 2 |
                 (idx[2] - kf_block_of(idx[2]) * KF_BLOCK);
        const kf_v4 vR = g->node[(size_t)rb * KF_BLOCK_NODES + (size_t)li];
        if (!(vR[3] > 0)) continue;
        const double f = in / inR; /* the linear profile through zero on the plane */
        if (type == KF_BOUNDARY_STICKY) {
            for (int e = 0; e < 3; e++) node[l][e] = (kf_real)(f * vR[e]);
            continue;
        }
        if (type == KF_BOUNDARY_SLIP) {
            node[l][a] = (kf_real)(f * vR[a]);
            continue;
        }
        /* separate: outward at most the profile of R's approach (none
         * when R is at rest or leaves); inward free */
        const double approach = out * vR[a] > 0 ? out * vR[a] : 0, bound = f * approach;
        if (out * node[l][a] > bound) node[l][a] = (kf_real)(out * bound);
    }
}

/* one plane's pass over the blocks, shared among the region's threads; the
 * last pass leaves without the barrier (the region's end is one) */
static void ghost_pass(const kf_model *m, kf_state *s, int a, int upper, int last) {
    kf_grid *g = &s->g;
    const kf_sim_def *sd = &m->sim;
    const double dx = sd->dx, plane = upper ? sd->domain_max[a] : sd->domain_min[a];
    const int out = upper ? 1 : -1; /* outward along axis a */
    const kf_boundary type = sd->wall_boundary;
    const size_t nb = g->nblocks;
    if (last) {
#pragma omp for schedule(static) nowait
        for (size_t b = 0; b < nb; b++) ghost_block(g, type, a, out, dx, plane, b);
    } else {
#pragma omp for schedule(static)
        for (size_t b = 0; b < nb; b++) ghost_block(g, type, a, out, dx, plane, b);
    }
}

void kf_wall_ghosts(const kf_model *m, kf_state *s, unsigned passes) {
    if (!m->sim.walls) return;
    /* in the fixed order: a later pass may read what an earlier one wrote */
    for (int k = 0; k < 6; k++)
        if (passes >> k & 1) ghost_pass(m, s, k >> 1, k & 1, (passes >> (k + 1)) == 0);
}
