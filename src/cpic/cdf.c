/* cdf.c — the grid colored distance field (paper §5.2), rebuilt every substep.
 *
 * Every rigid seed projects the grid nodes around it onto the plane of its
 * triangle. A projection that lands inside the triangle is a valid
 * point-plane distance u: the node gains affinity to the body (A_ir), the
 * body's closest valid primitive decides the node's side (T_ir = u < 0), and
 * the smallest |u| over all bodies is the node's distance d_i with its body
 * r*. Only nodes of existing grid blocks matter (no particle reads others),
 * so a seed far from material costs a hash miss and nothing else.
 *
 * Reach: the paper visits the 3x3x3 nodes around a seed's nearest node; kerf
 * visits every node within 1.5 cells of the seed along each axis (3 or 4 per
 * axis), 2.5 cells for solid bodies (see below). A particle's quadratic stencil reaches nodes up to 1.5 cells away,
 * so with seeds closer than half a cell every node a particle beside the
 * surface can touch on the far side gets its colour; the 3x3x3 rule misses
 * some of them when the surface lies between nodes, and those nodes then
 * couple both sides. Around a solid, a particle that advection pushed a
 * fraction of a cell inside would, with 1.5, reach interior nodes that no
 * seed colours: free space inside the body, through which the material
 * leaks in (a floating block measured it); 2.5 cells closes that.
 *
 * Order: bodies in index order, seeds in array order, strict comparisons:
 * deterministic, and ties go to the smaller body index. */
#include <float.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "cpic.h"

int kf_cpic_band(const kf_state *s, size_t owner) {
    return s->cpic && owner < s->cpic->cap_owner && s->cpic->slot[owner] >= 0;
}

void kf_cpic_free(kf_cpic *c) {
    if (!c) return;
    free(c->node_d);
    free(c->node_c);
    free(c->stamp);
    free(c->best);
    free(c->best_stamp);
    free(c->slot);
    free(c->imp);
    free(c->guard_caught);
    free(c->guard_depth);
    free(c->pd);
    free(c->pn);
    free(c->near);
    for (int r = 0; r < KF_MAX_RIGIDS; r++) free(c->tri[r]);
    free(c);
}

static int grow(void **p, size_t elem, size_t n) {
    void *q = realloc(*p, elem * (n ? n : 1));
    if (!q) return -1;
    *p = q;
    return 0;
}

/* room for the current grid and particles; stamps restart at 0 (= stale) */
static int reserve(kf_cpic *c, const kf_state *s) {
    size_t nb = s->g.nblocks, no = s->g.nowner, np = s->p.n;
    if (nb > c->cap_blocks) {
        size_t cap = nb + nb / 2 + 16;
        if (grow((void **)&c->node_d, sizeof(float) * 64, cap) || grow((void **)&c->node_c, sizeof(uint32_t) * 64, cap) ||
            grow((void **)&c->stamp, sizeof(uint32_t), cap) || grow((void **)&c->best, sizeof(float) * 64, cap) ||
            grow((void **)&c->best_stamp, sizeof(uint32_t), cap))
            return -1;
        memset(c->stamp, 0, cap * sizeof(uint32_t));
        memset(c->best_stamp, 0, cap * sizeof(uint32_t));
        c->cap_blocks = cap;
    }
    if (no > c->cap_owner) {
        size_t cap = no + no / 2 + 16;
        if (grow((void **)&c->slot, sizeof(int32_t), cap)) return -1;
        c->cap_owner = cap;
    }
    if (np > c->cap_p) {
        size_t cap = np + np / 4 + 64;
        if (grow((void **)&c->pd, sizeof(float), cap) || grow((void **)&c->pn, 3 * sizeof(float), cap) ||
            grow((void **)&c->near, 1, cap))
            return -1;
        c->cap_p = cap;
    }
    return 0;
}

/* body r's triangles in world space, with what the projection needs */
static int world_triangles(kf_cpic *c, const kf_rigid_body *b, const kf_rigid_state *st, int r) {
    if (b->ntri > c->cap_tri[r]) {
        if (grow((void **)&c->tri[r], sizeof(kf_cpic_tri), (size_t)b->ntri)) return -1;
        c->cap_tri[r] = b->ntri;
    }
    for (int k = 0; k < b->ntri; k++) {
        double w[3][3];
        for (int v = 0; v < 3; v++) {
            const double *x = &b->vert[3 * b->tri[3 * k + v]];
            for (int a = 0; a < 3; a++)
                w[v][a] = st->R[3 * a] * x[0] + st->R[3 * a + 1] * x[1] + st->R[3 * a + 2] * x[2] + st->t[a];
        }
        double e1[3], e2[3], n[3];
        for (int a = 0; a < 3; a++) e1[a] = w[1][a] - w[0][a], e2[a] = w[2][a] - w[0][a];
        n[0] = e1[1] * e2[2] - e1[2] * e2[1];
        n[1] = e1[2] * e2[0] - e1[0] * e2[2];
        n[2] = e1[0] * e2[1] - e1[1] * e2[0];
        double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        double a11 = e1[0] * e1[0] + e1[1] * e1[1] + e1[2] * e1[2];
        double a12 = e1[0] * e2[0] + e1[1] * e2[1] + e1[2] * e2[2];
        double a22 = e2[0] * e2[0] + e2[1] * e2[1] + e2[2] * e2[2];
        double det = a11 * a22 - a12 * a12;
        kf_cpic_tri *t = &c->tri[r][k];
        for (int a = 0; a < 3; a++) {
            t->v0[a] = (float)w[0][a];
            t->e1[a] = (float)e1[a];
            t->e2[a] = (float)e2[a];
            t->n[a] = nn > 0 ? (float)(n[a] / nn) : 0;
        }
        /* a degenerate triangle gets no valid projections */
        int ok = nn > 0 && det > 1e-30;
        t->g11 = ok ? (float)(a22 / det) : 0;
        t->g12 = ok ? (float)(-a12 / det) : 0;
        t->g22 = ok ? (float)(a11 / det) : 0;
        if (!ok) t->n[0] = t->n[1] = t->n[2] = 0;
    }
    return 0;
}

/* a block's CDF cleared, and its per-body best reset, on first touch */
static inline void touch_block(kf_cpic *c, int32_t b, int r) {
    if (c->stamp[b] != c->epoch) {
        c->stamp[b] = c->epoch;
        for (int k = 0; k < 64; k++) c->node_d[64 * (size_t)b + k] = FLT_MAX;
        memset(&c->node_c[64 * (size_t)b], 0, 64 * sizeof(uint32_t));
    }
    uint32_t bs = c->epoch * 16u + (uint32_t)r;
    if (c->best_stamp[b] != bs) {
        c->best_stamp[b] = bs;
        for (int k = 0; k < 64; k++) c->best[64 * (size_t)b + k] = FLT_MAX;
    }
}

/* all nodes within 1.5 cells (per axis) of one seed on triangle t of body r */
static void splat_seed(kf_cpic *c, const kf_grid *g, const kf_cpic_tri *t, const double x[3], int r, double inv_dx,
                       double dx, double reach) {
    int lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = (int)ceil(x[a] * inv_dx - reach);
        hi[a] = (int)floor(x[a] * inv_dx + reach);
    }
    if (t->g11 == 0 && t->g22 == 0) return;
    const uint32_t abit = 2u << (2 * r), tbit = 1u << (2 * r);
    /* the (at most 3x3x3) blocks the node box spans, each looked up once */
    int b0[3], nbk[3];
    for (int a = 0; a < 3; a++) {
        b0[a] = kf_block_of(lo[a]);
        nbk[a] = kf_block_of(hi[a]) - b0[a] + 1; /* <= 6 nodes span <= 3 blocks */
    }
    int32_t blkof[3][3][3];
    int any = 0;
    for (int p = 0; p < 3; p++)
        for (int q = 0; q < 3; q++)
            for (int w = 0; w < 3; w++) {
                int32_t bi = -1;
                if (p < nbk[0] && q < nbk[1] && w < nbk[2]) bi = kf_grid_find(g, b0[0] + p, b0[1] + q, b0[2] + w);
                blkof[p][q][w] = bi;
                any |= bi >= 0;
            }
    if (!any) return; /* no material near this seed */
    for (int i = lo[0]; i <= hi[0]; i++)
        for (int j = lo[1]; j <= hi[1]; j++)
            for (int k = lo[2]; k <= hi[2]; k++) {
                int32_t blk = blkof[kf_block_of(i) - b0[0]][kf_block_of(j) - b0[1]][kf_block_of(k) - b0[2]];
                if (blk < 0) continue;
                touch_block(c, blk, r);
                /* x_i − v0 = α e1 + β e2 + u n */
                double q[3] = {i * dx - t->v0[0], j * dx - t->v0[1], k * dx - t->v0[2]};
                double d1 = q[0] * t->e1[0] + q[1] * t->e1[1] + q[2] * t->e1[2];
                double d2 = q[0] * t->e2[0] + q[1] * t->e2[1] + q[2] * t->e2[2];
                double al = t->g11 * d1 + t->g12 * d2, be = t->g12 * d1 + t->g22 * d2;
                const double eps = 1e-6; /* shared edges must not fall between two triangles */
                if (al < -eps || be < -eps || al + be > 1 + eps) continue;
                double u = q[0] * t->n[0] + q[1] * t->n[1] + q[2] * t->n[2];
                float au = (float)(fabs(u) * inv_dx);
                size_t node = 64 * (size_t)blk + (size_t)((i & 3) << 4 | (j & 3) << 2 | (k & 3));
                uint32_t w = c->node_c[node] | abit;
                if (au < c->best[node]) {
                    /* the body's closest primitive decides the side */
                    c->best[node] = au;
                    w = u < 0 ? (w | tbit) : (w & ~tbit);
                }
                if (au < c->node_d[node]) {
                    c->node_d[node] = au;
                    w = (w & KF_CPIC_BITS_MASK) | (uint32_t)(r + 1) << KF_CPIC_RSTAR_SHIFT;
                }
                c->node_c[node] = w;
            }
}

int kf_cpic_splat(const kf_model *m, kf_state *s, double dt) {
    if (!s->cpic) {
        s->cpic = calloc(1, sizeof(kf_cpic));
        if (!s->cpic) return -1;
    }
    kf_cpic *c = s->cpic;
    if (reserve(c, s)) return -1;
    if (++c->epoch == 0) c->epoch = 1; /* never 0: fresh stamps are 0 */
    const kf_grid *g = &s->g;
    const double dx = m->sim.dx, inv_dx = 1 / dx;
    /* the grid's extent in metres: a body entirely outside it splats nothing */
    double glo[3] = {1e300, 1e300, 1e300}, ghi[3] = {-1e300, -1e300, -1e300};
    for (size_t b = 0; b < g->nblocks; b++)
        for (int a = 0; a < 3; a++) {
            double x0 = g->bcoord[3 * b + a] * KF_BLOCK * dx;
            if (x0 < glo[a]) glo[a] = x0;
            if (x0 + KF_BLOCK * dx > ghi[a]) ghi[a] = x0 + KF_BLOCK * dx;
        }
    for (int r = 0; r < m->nrigid; r++) {
        const kf_rigid_body *b = &m->rigid[r];
        const kf_rigid_state *st = &s->rigid[r];
        if (world_triangles(c, b, st, r)) return -1;
        /* a solid reaches a cell deeper: a particle pushed slightly inside it
         * must still see every node of its stencil inside as incompatible */
        const double reach = b->def.thin ? 1.5 : 2.5;
        int apart = 0;
        for (int a = 0; a < 3 && !apart; a++) {
            double lo = 1e300, hi = -1e300;
            for (int k = 0; k < b->ntri; k++) {
                const kf_cpic_tri *t = &c->tri[r][k];
                double v[3] = {t->v0[a], t->v0[a] + t->e1[a], t->v0[a] + t->e2[a]};
                for (int q = 0; q < 3; q++) lo = v[q] < lo ? v[q] : lo, hi = v[q] > hi ? v[q] : hi;
            }
            apart = lo > ghi[a] + reach * dx || hi < glo[a] - reach * dx;
        }
        if (apart) continue;
        for (size_t e = 0; e < b->nseed; e++) {
            if (b->tri_edge && b->tri_edge[b->seed_tri[e]]) continue; /* a blade's narrow side: its sheet's edge */
            const float *o = &b->seed[3 * e];
            double x[3];
            for (int a = 0; a < 3; a++)
                x[a] = st->R[3 * a] * o[0] + st->R[3 * a + 1] * o[1] + st->R[3 * a + 2] * o[2] + st->t[a];
            splat_seed(c, g, &c->tri[r][b->seed_tri[e]], x, r, inv_dx, dx, reach);
        }
    }
    /* the narrow band: owners whose 2x2x2 neighbourhood holds a coloured block */
    c->nslot = 0;
    c->band_particles = 0;
    for (size_t k = 0; k < g->nowner; k++) {
        int in = 0;
        for (int q = 0; q < 8 && !in; q++) in = c->stamp[g->nb[k][q]] == c->epoch;
        c->slot[k] = in ? (int32_t)c->nslot++ : -1;
        if (in) c->band_particles += (long)(g->pstart[k + 1] - g->pstart[k]);
    }
    c->band_owners = (long)c->nslot;
    if (c->nslot > c->cap_slot) {
        size_t cap = c->nslot + c->nslot / 2 + 16;
        if (grow((void **)&c->imp, sizeof c->imp[0], cap) || grow((void **)&c->guard_caught, sizeof(long), cap) ||
            grow((void **)&c->guard_depth, sizeof(double), cap))
            return -1;
        c->cap_slot = cap;
    }
    memset(c->imp, 0, c->nslot * sizeof c->imp[0]);
    memset(c->guard_caught, 0, c->nslot * sizeof(long));
    memset(c->guard_depth, 0, c->nslot * sizeof(double));
    /* particles outside the band touch no coloured node: their colour lapses
     * (§5.3.3); the bits above the bodies' are not CPIC's (the piece a cut
     * made, contact.h) and stay */
    kf_particles *p = &s->p;
    for (size_t k = 0; k < g->nowner; k++)
        if (c->slot[k] < 0)
            for (size_t i = g->pstart[k]; i < g->pstart[k + 1]; i++)
                if (p->colour[i] & KF_CPIC_BITS_MASK) p->colour[i] &= ~KF_CPIC_BITS_MASK;
    c->dt = dt;
    for (int a = 0; a < 3; a++) c->gdt[a] = dt * m->sim.gravity[a];
    kf_cpic_guard_poses(m, s, dt);
    return 0;
}
