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
 * Each axis and side is one parallel pass that writes only nodes within a
 * cell of its plane and reads only nodes at least a cell inside it, so the
 * result does not depend on the thread count. */
#include <math.h>

#include "model.h"

static void ghost_pass(const kf_model *m, kf_state *s, int a, int upper) {
    kf_grid *g = &s->g;
    const kf_sim_def *sd = &m->sim;
    const double dx = sd->dx, plane = upper ? sd->domain_max[a] : sd->domain_min[a];
    const int out = upper ? 1 : -1; /* outward along axis a */
    const kf_boundary type = sd->wall_boundary;
    size_t nb = g->nblocks;
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t b = 0; b < nb; b++) {
        const int32_t *bc = &g->bcoord[3 * b];
        /* skip blocks with no node within a cell of the plane */
        double lo = bc[a] * KF_BLOCK * dx, hi = (bc[a] * KF_BLOCK + KF_BLOCK - 1) * dx;
        if (hi <= plane - dx || lo >= plane + dx) continue;
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
}

void kf_wall_ghosts(const kf_model *m, kf_state *s) {
    if (!m->sim.walls) return;
    for (int a = 0; a < 3; a++)
        for (int upper = 0; upper < 2; upper++) ghost_pass(m, s, a, upper);
}
