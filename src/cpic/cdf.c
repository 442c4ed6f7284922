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
#include "../dist/dist.h"

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
    free(c->mark);
    free(c->seed_x);
    free(c->seed_bin);
    free(c->seed_order);
    free(c->bin_start);
    free(c->slot);
    free(c->imp);
    free(c->guard_caught);
    free(c->guard_depth);
    free(c->pd);
    free(c->pn);
    free(c->near);
    for (int r = 0; r < KF_MAX_RIGIDS; r++) free(c->tri[r]), free(c->tri_stamp[r]);
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
        if (grow((void **)&c->node_d, sizeof(float) * 64, cap) ||
            grow((void **)&c->node_c, sizeof(uint32_t) * 64, cap) || grow((void **)&c->stamp, sizeof(uint32_t), cap) ||
            grow((void **)&c->best, sizeof(float) * 64, cap) || grow((void **)&c->best_stamp, sizeof(uint32_t), cap) ||
            grow((void **)&c->mark, sizeof(uint32_t) * 64, cap))
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

/* room for body r's world triangles; none holds this substep's pose yet */
static int world_triangles_reserve(kf_cpic *c, const kf_rigid_body *b, int r) {
    if (b->ntri > c->cap_tri[r]) {
        if (grow((void **)&c->tri[r], sizeof(kf_cpic_tri), (size_t)b->ntri) ||
            grow((void **)&c->tri_stamp[r], sizeof(uint32_t), (size_t)b->ntri))
            return -1;
        memset(c->tri_stamp[r], 0, (size_t)b->ntri * sizeof(uint32_t));
        c->cap_tri[r] = b->ntri;
    }
    return 0;
}

/* body r's triangle k in world space, with what the projection needs:
 * made when a seed near material first asks for it in a substep (a long
 * blade mostly lies away from the material) */
static const kf_cpic_tri *world_triangle(kf_cpic *c, const kf_rigid_body *b, const kf_rigid_state *st, int r, int k) {
    kf_cpic_tri *t = &c->tri[r][k];
    if (c->tri_stamp[r][k] == c->epoch) return t;
    c->tri_stamp[r][k] = c->epoch;
    {
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
    return t;
}

/* a block's CDF cleared, and its per-body best reset, on first touch */
static inline void touch_block(kf_cpic *c, int32_t b, int r) {
    if (c->stamp[b] != c->epoch) {
        c->stamp[b] = c->epoch;
        for (int k = 0; k < 64; k++) c->node_d[64 * (size_t)b + k] = FLT_MAX;
        memset(&c->node_c[64 * (size_t)b], 0, 64 * sizeof(uint32_t));
        memset(&c->mark[64 * (size_t)b], 0, 64 * sizeof(uint32_t));
    }
    uint32_t bs = c->epoch * 16u + (uint32_t)r;
    if (c->best_stamp[b] != bs) {
        c->best_stamp[b] = bs;
        for (int k = 0; k < 64; k++) c->best[64 * (size_t)b + k] = FLT_MAX;
    }
}

/* the node box of one seed (every node within `reach` cells along each
 * axis) and the at most 3x3x3 blocks it spans, each looked up once */
typedef struct seed_box {
    int lo[3], hi[3], b0[3];
    int32_t blk[3][3][3]; /* -1: no such block */
} seed_box;

/* fills sb; returns whether any block exists there (else no material is near) */
static int seed_box_of(const kf_grid *g, const double x[3], double inv_dx, double reach, seed_box *sb) {
    int nbk[3];
    for (int a = 0; a < 3; a++) {
        sb->lo[a] = (int)ceil(x[a] * inv_dx - reach);
        sb->hi[a] = (int)floor(x[a] * inv_dx + reach);
        sb->b0[a] = kf_block_of(sb->lo[a]);
        nbk[a] = kf_block_of(sb->hi[a]) - sb->b0[a] + 1; /* <= 6 nodes span <= 3 blocks */
    }
    int any = 0;
    for (int p = 0; p < 3; p++)
        for (int q = 0; q < 3; q++)
            for (int w = 0; w < 3; w++) {
                int32_t bi = -1;
                if (p < nbk[0] && q < nbk[1] && w < nbk[2])
                    bi = kf_grid_find(g, sb->b0[0] + p, sb->b0[1] + q, sb->b0[2] + w);
                sb->blk[p][q][w] = bi;
                any |= bi >= 0;
            }
    return any;
}

/* the nodes of one seed's box, projected onto its triangle t of body r.
 * What a node gets from a triangle depends on the node and the triangle
 * only, not on the seed, and a second visit changes nothing (strict minima,
 * or-ed bits): a node whose last visitor was this very triangle (tid, from
 * 1, unique across bodies) is skipped, bit for bit. */
static void splat_box(kf_cpic *c, const kf_cpic_tri *t, uint32_t tid, const seed_box *sb, int r, double inv_dx,
                      double dx) {
    if (t->g11 == 0 && t->g22 == 0) return;
    const uint32_t abit = 2u << (2 * r), tbit = 1u << (2 * r);
    for (int i = sb->lo[0]; i <= sb->hi[0]; i++)
        for (int j = sb->lo[1]; j <= sb->hi[1]; j++)
            for (int k = sb->lo[2]; k <= sb->hi[2]; k++) {
                int32_t blk =
                    sb->blk[kf_block_of(i) - sb->b0[0]][kf_block_of(j) - sb->b0[1]][kf_block_of(k) - sb->b0[2]];
                if (blk < 0) continue;
                touch_block(c, blk, r);
                size_t node = 64 * (size_t)blk + (size_t)((i & 3) << 4 | (j & 3) << 2 | (k & 3));
                if (c->mark[node] == tid) continue;
                c->mark[node] = tid;
                /* x_i − v0 = α e1 + β e2 + u n */
                double q[3] = {i * dx - t->v0[0], j * dx - t->v0[1], k * dx - t->v0[2]};
                double d1 = q[0] * t->e1[0] + q[1] * t->e1[1] + q[2] * t->e1[2];
                double d2 = q[0] * t->e2[0] + q[1] * t->e2[1] + q[2] * t->e2[2];
                double al = t->g11 * d1 + t->g12 * d2, be = t->g12 * d1 + t->g22 * d2;
                const double eps = 1e-6; /* shared edges must not fall between two triangles */
                if (al < -eps || be < -eps || al + be > 1 + eps) continue;
                double u = q[0] * t->n[0] + q[1] * t->n[1] + q[2] * t->n[2];
                float au = (float)(fabs(u) * inv_dx);
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

/* Body r's seeds, in parallel without races and for any thread count alike:
 * each seed near material goes to the bin of the x-block where its node box
 * starts. A box spans at most 6 nodes, so a bin's seeds write blocks of its
 * own x-block and the next two only, and bins three apart never share a
 * block: the bins run in three rounds (bin mod 3), each round's bins in
 * parallel, each bin's seeds in seed order. */
static int splat_body(const kf_model *m, kf_state *s, int r, uint32_t tid0, const double glo[3], const double ghi[3]) {
    kf_cpic *c = s->cpic;
    const kf_grid *g = &s->g;
    const kf_rigid_body *b = &m->rigid[r];
    const kf_rigid_state *st = &s->rigid[r];
    const double dx = m->sim.dx, inv_dx = 1 / dx;
    /* a solid reaches a cell deeper: a particle pushed slightly inside it
     * must still see every node of its stencil inside as incompatible */
    const double reach = b->def.thin ? 1.5 : 2.5;
    const size_t ns = b->nseed;
    if (world_triangles_reserve(c, b, r)) return -1;
    if (ns > c->cap_seed) {
        size_t cap = ns + ns / 4 + 64;
        if (grow((void **)&c->seed_x, 3 * sizeof(double), cap) || grow((void **)&c->seed_bin, sizeof(int32_t), cap) ||
            grow((void **)&c->seed_order, sizeof(int32_t), cap))
            return -1;
        c->cap_seed = cap;
    }
    /* bins: the grid's x-blocks, and two below for boxes that start there */
    const int bin0 = kf_block_of((int)floor(glo[0] * inv_dx + 0.5)) - 2;
    const size_t nbins = (size_t)(kf_block_of((int)floor(ghi[0] * inv_dx + 0.5)) - bin0 + 3);
    if (nbins + 1 > c->cap_bins) {
        if (grow((void **)&c->bin_start, sizeof(int32_t), nbins + 1)) return -1;
        c->cap_bins = nbins + 1;
    }
    /* 1. world positions; seeds whose box holds no block drop out. A seed
     * outside the grid's box (with a margin) needs no lookup at all. */
    double slo[3], shi[3];
    for (int a = 0; a < 3; a++) slo[a] = glo[a] - (reach + 1) * dx, shi[a] = ghi[a] + (reach + 1) * dx;
    double *sx = c->seed_x;
    int32_t *sbin = c->seed_bin;
    /* small bodies stay on one thread: waking a sleeping team costs more
     * than their seeds (the bins' order, hence the result, is the same) */
#pragma omp parallel for schedule(static) num_threads(m->nthreads) if (ns >= 8192)
    for (size_t e = 0; e < ns; e++) {
        sbin[e] = -1;
        if (b->tri_edge && b->tri_edge[b->seed_tri[e]]) continue; /* a blade's narrow side: its sheet's edge */
        const float *o = &b->seed[3 * e];
        double *x = &sx[3 * e];
        int out = 0;
        for (int a = 0; a < 3; a++) {
            x[a] = st->R[3 * a] * o[0] + st->R[3 * a + 1] * o[1] + st->R[3 * a + 2] * o[2] + st->t[a];
            out |= x[a] < slo[a] || x[a] > shi[a];
        }
        seed_box sb;
        if (out || !seed_box_of(g, x, inv_dx, reach, &sb)) continue;
        int bin = sb.b0[0] - bin0;
        sbin[e] = bin >= 0 && (size_t)bin < nbins ? bin : -1; /* outside: no block there either */
    }
    /* 2. the triangles the remaining seeds lie on, in world space; the
     * seeds grouped by bin (a stable counting sort) */
    int32_t *bs = c->bin_start;
    memset(bs, 0, (nbins + 1) * sizeof *bs);
    for (size_t e = 0; e < ns; e++)
        if (sbin[e] >= 0) {
            bs[sbin[e] + 1]++;
            world_triangle(c, b, st, r, b->seed_tri[e]);
        }
    for (size_t k = 0; k < nbins; k++) bs[k + 1] += bs[k];
    {
        int32_t *fill = c->seed_order;
        for (size_t e = 0; e < ns; e++)
            if (sbin[e] >= 0) fill[bs[sbin[e]]++] = (int32_t)e;
        for (size_t k = nbins; k > 0; k--) bs[k] = bs[k - 1];
        bs[0] = 0;
    }
    /* 3. three rounds of bins, in one team */
    const int32_t *order = c->seed_order;
#pragma omp parallel num_threads(m->nthreads) if (bs[nbins] >= 1024)
    for (int round = 0; round < 3; round++) {
#pragma omp for schedule(dynamic, 1)
        for (size_t k = (size_t)round; k < nbins; k += 3)
            for (int32_t q = bs[k]; q < bs[k + 1]; q++) {
                size_t e = (size_t)order[q];
                seed_box sb;
                seed_box_of(g, &sx[3 * e], inv_dx, reach, &sb);
                int tri = b->seed_tri[e];
                splat_box(c, &c->tri[r][tri], tid0 + (uint32_t)tri, &sb, r, inv_dx, dx);
            }
    }
    return 0;
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
    const double dx = m->sim.dx;
    /* the grid's extent in metres: a body entirely outside it splats nothing */
    double glo[3] = {1e300, 1e300, 1e300}, ghi[3] = {-1e300, -1e300, -1e300};
    for (size_t b = 0; b < g->nblocks; b++)
        for (int a = 0; a < 3; a++) {
            double x0 = g->bcoord[3 * b + a] * KF_BLOCK * dx;
            if (x0 < glo[a]) glo[a] = x0;
            if (x0 + KF_BLOCK * dx > ghi[a]) ghi[a] = x0 + KF_BLOCK * dx;
        }
    /* across ranks: the one-rank grid's extent, so seeds fall in the same bins */
    if (s->dist) kf_dist_extent(s, glo, ghi);
    uint32_t tri_base = 1; /* triangle ids for the splat's visit marks, unique across bodies */
    for (int r = 0; r < m->nrigid; r++) {
        if (splat_body(m, s, r, tri_base, glo, ghi)) return -1;
        tri_base += (uint32_t)m->rigid[r].ntri;
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
     * (§5.3.3), all but the scar (cpic.h: the side of the last blade) */
    kf_particles *p = &s->p;
    for (size_t k = 0; k < g->nowner; k++)
        if (c->slot[k] < 0)
            for (size_t i = g->pstart[k]; i < g->pstart[k + 1]; i++) {
                uint32_t col = p->colour[i], sc = col >> KF_CPIC_RSTAR_SHIFT;
                uint32_t keep = sc ? (col & ~KF_CPIC_BITS_MASK) | (col & 1u << (2 * (sc - 1))) : 0;
                if (col != keep) p->colour[i] = keep;
            }
    c->dt = dt;
    for (int a = 0; a < 3; a++) c->gdt[a] = dt * m->sim.gravity[a];
    kf_cpic_guard_poses(m, s, dt);
    return 0;
}
