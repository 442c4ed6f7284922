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

/* Eq. 25: project v (relative to the boundary) for outward normal n */
static void project_velocity(double v[3], const double n[3], kf_boundary type, double mu) {
    if (type == KF_BOUNDARY_STICKY) {
        v[0] = v[1] = v[2] = 0;
        return;
    }
    double vn = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
    if (type == KF_BOUNDARY_SEPARATE && vn > 0) return; /* leaving: free */
    double vt[3] = {v[0] - vn * n[0], v[1] - vn * n[1], v[2] - vn * n[2]};
    if (type == KF_BOUNDARY_SLIP) {
        for (int a = 0; a < 3; a++) v[a] = vt[a];
        return;
    }
    /* separate, approaching: tangential velocity reduced by friction μ|vn| */
    double t = sqrt(vt[0] * vt[0] + vt[1] * vt[1] + vt[2] * vt[2]);
    double zeta = t + mu * vn; /* vn <= 0 */
    double scale = (zeta > 0 && t > 0) ? zeta / t : 0;
    for (int a = 0; a < 3; a++) v[a] = scale * vt[a];
}

void kf_grid_update(const kf_model *m, kf_state *s, kf_real dt) {
    kf_grid *g = &s->g;
    const kf_sim_def *sd = &m->sim;
    const double dx = sd->dx, t1 = s->time + dt;
    const kf_v4 gdt = {(kf_real)(dt * sd->gravity[0]), (kf_real)(dt * sd->gravity[1]), (kf_real)(dt * sd->gravity[2]), 0};

    /* collider poses at the end of the substep, once per substep */
    kf_collider_frame frame[KF_MAX_COLLIDERS];
    for (int c = 0; c < m->ncol; c++) kf_collider_frame_at(&m->col[c], t1, &frame[c]);

    size_t nb = g->nblocks;
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t b = 0; b < nb; b++) {
        kf_ftz();
        kf_v4 *node = &g->node[b * KF_BLOCK_NODES];
        const int32_t *bc = &g->bcoord[3 * b];
        /* the colliders this block's nodes may be inside of */
        int near[KF_MAX_COLLIDERS], nnear = 0;
        double blo[3], bhi[3];
        for (int a = 0; a < 3; a++) blo[a] = bc[a] * KF_BLOCK * dx, bhi[a] = (bc[a] * KF_BLOCK + KF_BLOCK - 1) * dx;
        for (int c = 0; c < m->ncol; c++)
            if (kf_collider_may_touch(&frame[c], blo, bhi)) near[nnear++] = c;
        for (int l = 0; l < KF_BLOCK_NODES; l++) {
            kf_real mass = node[l][3];
            if (mass <= 0) {
                node[l] = (kf_v4){0, 0, 0, 0};
                continue;
            }
            kf_v4 v = node[l] / mass + gdt;
            v[3] = mass;
            if (sd->walls || nnear) {
                double x[3] = {(bc[0] * KF_BLOCK + (l >> 4)) * dx, (bc[1] * KF_BLOCK + ((l >> 2) & 3)) * dx,
                               (bc[2] * KF_BLOCK + (l & 3)) * dx};
                double vd[3] = {v[0], v[1], v[2]};
                if (sd->walls) {
                    for (int a = 0; a < 3; a++) {
                        double n[3] = {0, 0, 0};
                        if (x[a] <= sd->domain_min[a]) n[a] = 1;
                        else if (x[a] >= sd->domain_max[a]) n[a] = -1;
                        else continue;
                        project_velocity(vd, n, sd->wall_boundary, sd->wall_friction);
                    }
                }
                for (int i = 0; i < nnear; i++) {
                    const kf_collider_frame *f = &frame[near[i]];
                    double n[3], vc[3];
                    if (kf_collider_sdf(f, x, NULL) > 0) continue;
                    kf_collider_sdf(f, x, n); /* constrained: now its normal */
                    kf_collider_velocity(f, x, vc);
                    double rel[3] = {vd[0] - vc[0], vd[1] - vc[1], vd[2] - vc[2]};
                    project_velocity(rel, n, f->c->boundary, f->c->friction);
                    for (int a = 0; a < 3; a++) vd[a] = rel[a] + vc[a];
                }
                v = (kf_v4){(kf_real)vd[0], (kf_real)vd[1], (kf_real)vd[2], mass};
            }
            node[l] = v;
        }
    }
}
