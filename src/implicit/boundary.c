/* boundary.c — walls and colliders inside the implicit solve.
 *
 * The explicit grid update projects each node's velocity once (Eq. 25). In
 * the solve the same conditions become constraints: a node on or beyond a
 * wall, or inside a collider at the substep's end, has its velocity fixed
 * along the boundary's normal (slip, and separate when approaching) or
 * entirely (sticky), relative to the boundary's own velocity. The solve
 * starts from v* projected exactly as the explicit update would project it
 * (without friction) and moves only along the free directions (the
 * orthogonal projection P_i of each constrained node), so every iterate
 * satisfies the conditions. A separate boundary the material leaves at v*
 * does not constrain the node. Coulomb friction comes after the solve, from
 * the boundary's normal reaction there: the gradient of the incremental
 * potential at the solution, M (v − v*) − Δt f, is the impulse the
 * boundary gave the node, and its normal part bounds the tangential
 * impulse friction may take away (μ times it). The normal velocity removed
 * from v* alone, used before, left out the weight the material above
 * presses onto the node through its stress: a block sliding on the floor
 * at 10x the explicit step felt a sixth of its Coulomb friction. Geometry (what is inside, the
 * normals and velocities) is the collider code's, as in grid_update.c. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../mpm/collider.h"
#include "implicit.h"

/* the constraint a node collects: an orthonormal basis of fixed directions */
typedef struct node_con {
    double q[3][3];
    int nq;
    double v[3]; /* v* projected */
    double mu;   /* friction coefficient of a separate boundary that holds the node */
    int sep;     /* held by a separate boundary */
    double n[3], vc[3];
} node_con;

static void fix_direction(node_con *c, const double n[3]) {
    double r[3] = {n[0], n[1], n[2]};
    for (int k = 0; k < c->nq; k++) {
        double d = r[0] * c->q[k][0] + r[1] * c->q[k][1] + r[2] * c->q[k][2];
        for (int a = 0; a < 3; a++) r[a] -= d * c->q[k][a];
    }
    double len = sqrt(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    if (c->nq < 3 && len > 1e-6)
        for (int a = 0; a < 3; a++) c->q[c->nq][a] = r[a] / len;
    if (c->nq < 3 && len > 1e-6) c->nq++;
}

/* one boundary (type, μ, outward normal n, boundary velocity vc) on the node */
static void apply(node_con *c, kf_boundary type, double mu, const double n[3], const double vc[3]) {
    double rel[3] = {c->v[0] - vc[0], c->v[1] - vc[1], c->v[2] - vc[2]};
    if (type == KF_BOUNDARY_STICKY) {
        for (int a = 0; a < 3; a++) c->v[a] = vc[a];
        c->nq = 3;
        return;
    }
    double vn = rel[0] * n[0] + rel[1] * n[1] + rel[2] * n[2];
    if (type == KF_BOUNDARY_SEPARATE && vn > 0) return; /* leaving: free */
    for (int a = 0; a < 3; a++) c->v[a] -= vn * n[a];
    fix_direction(c, n);
    if (type == KF_BOUNDARY_SEPARATE) {
        c->sep = 1;
        c->mu = mu;
        for (int a = 0; a < 3; a++) c->n[a] = n[a], c->vc[a] = vc[a];
    }
}

static int grow(void **a, size_t elem, size_t *cap, size_t need) {
    if (need <= *cap) return 0;
    size_t nc = *cap ? 2 * *cap : 256;
    while (nc < need) nc *= 2;
    void *b = realloc(*a, nc * elem);
    if (!b) return -1;
    *a = b;
    *cap = nc;
    return 0;
}

int kf_imp_constraints(kf_implicit *w, double *v) {
    const kf_model *m = w->m;
    const kf_sim_def *sd = &m->sim;
    const kf_grid *g = &w->s->g;
    const double dx = sd->dx, t1 = w->s->time + w->dt;
    memcpy(v, w->vstar, KF_IMP_NV * w->nnode * sizeof *v);
    kf_collider_frame frame[KF_MAX_COLLIDERS];
    for (int c = 0; c < m->ncol; c++) kf_collider_frame_at(&m->col[c], t1, &frame[c]);
    size_t cap = 0, cap1 = 0, cap2 = 0, cap3 = 0, cap4 = 0, cap5 = 0;
    w->ncon = 0;
    for (size_t b = 0; b < g->nblocks; b++) {
        const int32_t *bc = &g->bcoord[3 * b];
        int near[KF_MAX_COLLIDERS], nnear = kf_colliders_near_block(frame, m->ncol, bc, dx, near);
        if (!sd->walls && !nnear) continue;
        for (int l = 0; l < KF_BLOCK_NODES; l++) {
            size_t node = b * KF_BLOCK_NODES + (size_t)l;
            if (!(w->mass[node] > 0)) continue;
            double x[3] = {(bc[0] * KF_BLOCK + (l >> 4)) * dx, (bc[1] * KF_BLOCK + ((l >> 2) & 3)) * dx,
                           (bc[2] * KF_BLOCK + (l & 3)) * dx};
            node_con c;
            memset(&c, 0, sizeof c);
            /* a separate boundary whose reaction pulled here in this substep's first solve lets go */
            const int let_go = w->release && w->release[node];
            for (int a = 0; a < 3; a++) c.v[a] = v[KF_IMP_NV * node + a];
            int touched = 0;
            if (sd->walls) {
                const double zero[3] = {0, 0, 0};
                for (int a = 0; a < 3; a++) {
                    double n[3] = {0, 0, 0};
                    if (x[a] <= sd->domain_min[a]) n[a] = 1;
                    else if (x[a] >= sd->domain_max[a]) n[a] = -1;
                    else continue;
                    if (let_go && sd->wall_boundary == KF_BOUNDARY_SEPARATE) continue;
                    apply(&c, sd->wall_boundary, sd->wall_friction, n, zero);
                    touched = 1;
                }
            }
            for (int i = 0; i < nnear; i++) {
                const kf_collider_frame *f = &frame[near[i]];
                double n[3], vc[3];
                if (kf_collider_sdf(f, x, NULL) > 0) continue;
                kf_collider_sdf(f, x, n);
                kf_collider_velocity(f, x, vc);
                if (let_go && f->c->boundary == KF_BOUNDARY_SEPARATE) continue;
                apply(&c, f->c->boundary, f->c->friction, n, vc);
                touched = 1;
            }
            if (!touched) continue;
            for (int a = 0; a < 3; a++) v[KF_IMP_NV * node + a] = c.v[a];
            if (c.nq == 0) continue;
            size_t k = w->ncon;
            if (grow((void **)&w->con_node, sizeof *w->con_node, &cap, k + 1) ||
                grow((void **)&w->con_P, 9 * sizeof *w->con_P, &cap1, k + 1) ||
                grow((void **)&w->con_mu, sizeof *w->con_mu, &cap2, k + 1) ||
                grow((void **)&w->con_n, 3 * sizeof *w->con_n, &cap3, k + 1) ||
                grow((void **)&w->con_vc, 3 * sizeof *w->con_vc, &cap4, k + 1) ||
                grow((void **)&w->con_sep, sizeof *w->con_sep, &cap5, k + 1))
                return -1;
            w->con_node[k] = (int32_t)node;
            double *P = w->con_P + 9 * k;
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++) {
                    double t = i == j;
                    for (int q = 0; q < c.nq; q++) t -= c.q[q][i] * c.q[q][j];
                    P[3 * i + j] = c.nq == 3 ? 0.0 : t;
                }
            w->con_mu[k] = c.mu;
            w->con_sep[k] = (uint8_t)c.sep;
            for (int a = 0; a < 3; a++) w->con_n[3 * k + a] = c.n[a], w->con_vc[3 * k + a] = c.vc[a];
            w->ncon++;
        }
    }
    return 0;
}

void kf_imp_project(const kf_implicit *w, double *x) {
    for (size_t k = 0; k < w->ncon; k++) {
        double *xi = x + KF_IMP_NV * (size_t)w->con_node[k];
        const double *P = w->con_P + 9 * k;
        double y[3];
        for (int a = 0; a < 3; a++) y[a] = P[3 * a] * xi[0] + P[3 * a + 1] * xi[1] + P[3 * a + 2] * xi[2];
        for (int a = 0; a < 3; a++) xi[a] = y[a];
    }
}

void kf_imp_friction(const kf_implicit *w, double *v, const double *g) {
    for (size_t k = 0; k < w->ncon; k++) {
        const double mu = w->con_mu[k];
        const size_t node = (size_t)w->con_node[k];
        if (!(mu > 0) || !(w->mass[node] > 0)) continue;
        double *vi = v + KF_IMP_NV * node;
        const double *n = w->con_n + 3 * k, *vc = w->con_vc + 3 * k, *gi = g + KF_IMP_NV * node;
        /* the normal reaction (an impulse, pushing along n), as a velocity budget */
        const double push = gi[0] * n[0] + gi[1] * n[1] + gi[2] * n[2];
        const double slide = push > 0 ? mu * push / w->mass[node] : 0.0;
        double rel[3] = {vi[0] - vc[0], vi[1] - vc[1], vi[2] - vc[2]};
        double vn = rel[0] * n[0] + rel[1] * n[1] + rel[2] * n[2];
        double vt[3] = {rel[0] - vn * n[0], rel[1] - vn * n[1], rel[2] - vn * n[2]};
        double t = sqrt(vt[0] * vt[0] + vt[1] * vt[1] + vt[2] * vt[2]);
        double scale = t > slide ? (t - slide) / t : 0.0;
        for (int a = 0; a < 3; a++) vi[a] = vc[a] + vn * n[a] + scale * vt[a];
    }
}

int kf_imp_release_pulling(kf_implicit *w, const double *g) {
    const double *gr = w->m->sim.gravity;
    const double gh = w->dt * sqrt(gr[0] * gr[0] + gr[1] * gr[1] + gr[2] * gr[2]);
    int any = 0;
    for (size_t k = 0; k < w->ncon; k++) {
        if (!w->con_sep[k]) continue;
        const size_t node = (size_t)w->con_node[k];
        const double *n = w->con_n + 3 * k, *gi = g + KF_IMP_NV * node;
        /* pulling by more than a thousandth of the node's own weight over the step */
        if (gi[0] * n[0] + gi[1] * n[1] + gi[2] * n[2] < -1e-3 * w->mass[node] * (gh > 0 ? gh : 1e-9)) {
            if (!w->release) w->release = calloc(w->nnode + 1, 1);
            if (!w->release) return -1;
            w->release[node] = 1;
            any = 1;
        }
    }
    return any;
}
