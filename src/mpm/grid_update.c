/* grid_update.c — momentum to velocity, gravity, walls and colliders.
 *
 * After P2G a node holds (momentum, mass). The update turns it into the
 * velocity at the end of the substep (symplectic Euler, Eq. 26) and applies
 * the boundary conditions of Eq. 25 relative to the boundary's own velocity:
 * sticky, slip, or separate with Coulomb friction. A node is constrained by a
 * wall when it lies on or beyond the wall plane, and by a collider when it
 * lies inside the collider (signed distance <= 0); the boundary velocity
 * there is the velocity of the collider's own material point at the node
 * (translation, rotation and scaling, collider.h). Every collider's pose is
 * evaluated once per substep, at the substep's end time, and a block of
 * nodes skips each collider it cannot be inside of (kf_collider_may_touch:
 * outside the collider's world box, or too far by its distance at the
 * block's centre). */
#include <math.h>

#include "collider.h"
#include "model.h"

/* the walls' and the nearby colliders' conditions on the velocity vd of the
 * node at x, in that order */
static inline void node_boundaries(const kf_sim_def *sd, const kf_collider_frame *frame, const int *near, int nnear,
                                   const double x[3], double vd[3]) {
    if (sd->walls) {
        for (int a = 0; a < 3; a++) {
            double n[3] = {0, 0, 0};
            if (x[a] <= sd->domain_min[a]) n[a] = 1;
            else if (x[a] >= sd->domain_max[a]) n[a] = -1;
            else continue;
            kf_project_velocity(vd, n, sd->wall_boundary, sd->wall_friction);
        }
    }
    for (int i = 0; i < nnear; i++) {
        const kf_collider_frame *f = &frame[near[i]];
        double n[3], vc[3];
        if (kf_collider_sdf(f, x, NULL) > 0) continue;
        kf_collider_sdf(f, x, n); /* constrained: now its normal */
        kf_collider_velocity(f, x, vc);
        double rel[3] = {vd[0] - vc[0], vd[1] - vc[1], vd[2] - vc[2]};
        kf_project_velocity(rel, n, f->c->boundary, f->c->friction);
        for (int a = 0; a < 3; a++) vd[a] = rel[a] + vc[a];
    }
}

void kf_grid_node_boundaries(const kf_model *m, const kf_collider_frame *frame, const int *near, int nnear,
                             const double x[3], double vd[3]) {
    node_boundaries(&m->sim, frame, near, nnear, x, vd);
}

/* Whether a wall plane can constrain a node of the block at bc: node
 * positions grow with their index, so the block's first and last node along
 * each axis bound the others, computed as node_boundaries computes x */
static inline int block_meets_walls(const kf_sim_def *sd, const int32_t bc[3], double dx) {
    if (!sd->walls) return 0;
    for (int a = 0; a < 3; a++) {
        const double lo = (bc[a] * KF_BLOCK) * dx, hi = (bc[a] * KF_BLOCK + KF_BLOCK - 1) * dx;
        if (lo <= sd->domain_min[a] || hi >= sd->domain_max[a]) return 1;
    }
    return 0;
}

/* One block's nodes: momentum to velocity, gravity, then the walls and
 * colliders where the block can meet them (elsewhere node_boundaries would
 * change nothing: the double round trip of a float is exact) */
static void update_block(const kf_sim_def *sd, const kf_collider_frame *frame, int ncol, kf_v4 *node,
                         const int32_t bc[3], kf_v4 gdt) {
    const double dx = sd->dx;
    /* the colliders this block's nodes may be inside of */
    int near[KF_MAX_COLLIDERS], nnear = kf_colliders_near_block(frame, ncol, bc, dx, near);
    const int bounded = nnear || block_meets_walls(sd, bc, dx);
    for (int l = 0; l < KF_BLOCK_NODES; l++) {
        kf_real mass = node[l][3];
        if (mass <= 0) {
            node[l] = (kf_v4){0, 0, 0, 0};
            continue;
        }
        kf_v4 v = node[l] / mass + gdt;
        v[3] = mass;
        if (bounded) {
            double x[3] = {(bc[0] * KF_BLOCK + (l >> 4)) * dx, (bc[1] * KF_BLOCK + ((l >> 2) & 3)) * dx,
                           (bc[2] * KF_BLOCK + (l & 3)) * dx};
            double vd[3] = {v[0], v[1], v[2]};
            node_boundaries(sd, frame, near, nnear, x, vd);
            v = (kf_v4){(kf_real)vd[0], (kf_real)vd[1], (kf_real)vd[2], mass};
        }
        node[l] = v;
    }
}

/* Blocks below this many go through the update on one thread: the work is
 * a few microseconds, less than handing it to a second thread and back */
#define KF_UPDATE_SERIAL_BLOCKS 64

/* The update and the walls' ghost passes, by every thread of the calling
 * parallel region: the update gathers which planes have blocks within a
 * cell (into *passes, shared, zero on entry), so only those passes run,
 * and the barrier after the update lets each pass read its neighbours'
 * nodes. in_turn: inside P2G's region (transfer.c), each block once every
 * owner has added its cache there (grid.h), with no barrier before. */
void kf_grid_update_team(const kf_model *m, kf_state *s, kf_real dt, unsigned *passes, int in_turn) {
    kf_grid *g = &s->g;
    const kf_sim_def *sd = &m->sim;
    const double t1 = s->time + dt;
    const kf_v4 gdt = {(kf_real)(dt * sd->gravity[0]), (kf_real)(dt * sd->gravity[1]), (kf_real)(dt * sd->gravity[2]),
                       0};
    /* collider poses at the end of the substep, once per substep (and thread) */
    kf_collider_frame frame[KF_MAX_COLLIDERS];
    for (int c = 0; c < m->ncol; c++) kf_collider_frame_at(&m->col[c], t1, &frame[c]);
    const size_t nb = g->nblocks;
    unsigned mine = 0;
#pragma omp for schedule(static) nowait
    for (size_t b = 0; b < nb; b++) {
        const int32_t *bc = &g->bcoord[3 * b];
        if (in_turn) kf_grid_flush_wait_block(g, b);
        update_block(sd, frame, m->ncol, &g->node[b * KF_BLOCK_NODES], bc, gdt);
        mine |= kf_wall_ghost_passes(m, bc);
    }
    if (mine) {
#pragma omp atomic
        *passes |= mine;
    }
#pragma omp barrier
    /* walls between nodes: the nodes within a cell of each plane take a linear profile through zero on it */
    kf_wall_ghosts(m, s, *passes);
}

void kf_grid_update(const kf_model *m, kf_state *s, kf_real dt) {
    /* one parallel region for the update and the walls' ghost passes (one
     * hand-off to the threads a substep, not seven) */
    const int nthreads = s->g.nblocks < KF_UPDATE_SERIAL_BLOCKS ? 1 : m->nthreads;
    unsigned passes = 0;
#pragma omp parallel num_threads(nthreads)
    {
        kf_ftz();
        kf_grid_update_team(m, s, dt, &passes, 0);
    }
}
