/* grid_update.c — momentum to velocity, gravity, walls and analytic colliders.
 *
 * After P2G a node holds (momentum, mass). The update turns it into the
 * velocity at the end of the substep (symplectic Euler, Eq. 26) and applies
 * the boundary conditions of Eq. 25 relative to the boundary's own velocity:
 * sticky, slip, or separate with Coulomb friction. A node is constrained by a
 * wall when it lies on or beyond the wall plane, and by a collider when it
 * lies inside the collider (signed distance <= 0). */
#include <math.h>

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

/* centre and velocity of a collider at time t: constant velocity, or
 * piecewise-linear keys (held before the first and after the last) */
void kf_collider_at(const kf_collider *c, double t, double center[3], double velocity[3]) {
    if (c->nkeys < 2) {
        for (int a = 0; a < 3; a++) {
            center[a] = c->center[a] + c->velocity[a] * t;
            velocity[a] = c->velocity[a];
        }
        return;
    }
    const kf_key *k = c->keys;
    int last = c->nkeys - 1;
    if (t <= k[0].time || t >= k[last].time) {
        const kf_key *e = t <= k[0].time ? &k[0] : &k[last];
        for (int a = 0; a < 3; a++) center[a] = e->position[a], velocity[a] = 0;
        return;
    }
    int i = 0;
    while (i + 1 < last && t >= k[i + 1].time) i++;
    double span = k[i + 1].time - k[i].time, u = (t - k[i].time) / span;
    for (int a = 0; a < 3; a++) {
        center[a] = k[i].position[a] + u * (k[i + 1].position[a] - k[i].position[a]);
        velocity[a] = (k[i + 1].position[a] - k[i].position[a]) / span;
    }
}

/* signed distance (negative inside the solid) and outward normal at x */
static double collider_sdf(const kf_collider *c, const double ctr[3], const double x[3], double n[3]) {
    double r[3] = {x[0] - ctr[0], x[1] - ctr[1], x[2] - ctr[2]};
    double phi;
    if (c->shape == KF_SHAPE_PLANE) {
        double len = sqrt(c->normal[0] * c->normal[0] + c->normal[1] * c->normal[1] + c->normal[2] * c->normal[2]);
        for (int a = 0; a < 3; a++) n[a] = c->normal[a] / len;
        return r[0] * n[0] + r[1] * n[1] + r[2] * n[2];
    }
    if (c->shape == KF_SHAPE_SPHERE) {
        double len = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
        for (int a = 0; a < 3; a++) n[a] = len > 0 ? r[a] / len : (a == 1);
        phi = len - c->radius;
    } else {
        /* box: exact distance outside, largest face distance inside */
        double q[3], out2 = 0, inside = -1e300;
        int amax = 0;
        for (int a = 0; a < 3; a++) {
            q[a] = fabs(r[a]) - c->half[a];
            if (q[a] > 0) out2 += q[a] * q[a];
            if (q[a] > inside) inside = q[a], amax = a;
        }
        if (inside > 0) {
            phi = sqrt(out2);
            for (int a = 0; a < 3; a++) n[a] = q[a] > 0 ? copysign(q[a], r[a]) / phi : 0;
        } else {
            phi = inside;
            for (int a = 0; a < 3; a++) n[a] = a == amax ? copysign(1.0, r[a]) : 0;
        }
    }
    if (c->inside) {
        /* a container: material lives inside, the solid is outside */
        phi = -phi;
        for (int a = 0; a < 3; a++) n[a] = -n[a];
    }
    return phi;
}

void kf_grid_update(const kf_model *m, kf_state *s, kf_real dt) {
    kf_grid *g = &s->g;
    const kf_sim_def *sd = &m->sim;
    const double dx = sd->dx, t1 = s->time + dt;
    const kf_v4 gdt = {(kf_real)(dt * sd->gravity[0]), (kf_real)(dt * sd->gravity[1]), (kf_real)(dt * sd->gravity[2]), 0};

    /* collider poses at the end of the substep, once per substep */
    double cctr[KF_MAX_COLLIDERS][3], cvel[KF_MAX_COLLIDERS][3];
    for (int c = 0; c < m->ncol; c++) kf_collider_at(&m->col[c], t1, cctr[c], cvel[c]);
    const int constrained = sd->walls || m->ncol > 0;

    size_t nb = g->nblocks;
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t b = 0; b < nb; b++) {
        kf_ftz();
        kf_v4 *node = &g->node[b * KF_BLOCK_NODES];
        const int32_t *bc = &g->bcoord[3 * b];
        for (int l = 0; l < KF_BLOCK_NODES; l++) {
            kf_real mass = node[l][3];
            if (mass <= 0) {
                node[l] = (kf_v4){0, 0, 0, 0};
                continue;
            }
            kf_v4 v = node[l] / mass + gdt;
            v[3] = mass;
            if (constrained) {
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
                for (int c = 0; c < m->ncol; c++) {
                    double n[3];
                    if (collider_sdf(&m->col[c], cctr[c], x, n) > 0) continue;
                    double rel[3] = {vd[0] - cvel[c][0], vd[1] - cvel[c][1], vd[2] - cvel[c][2]};
                    project_velocity(rel, n, m->col[c].boundary, m->col[c].friction);
                    for (int a = 0; a < 3; a++) vd[a] = rel[a] + cvel[c][a];
                }
                v = (kf_v4){(kf_real)vd[0], (kf_real)vd[1], (kf_real)vd[2], mass};
            }
            node[l] = v;
        }
    }
}
