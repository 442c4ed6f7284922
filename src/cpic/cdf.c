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

#include "../core/mat3.h"
#include "cpic.h"
#include "../dist/dist.h"
#if defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
#endif

int kf_cpic_band(const kf_state *s, size_t owner) {
    return s->cpic && owner < s->cpic->cap_owner && s->cpic->slot[owner] >= 0;
}

long kf_cpic_band_particles(const kf_state *s) { return s->cpic ? s->cpic->band_particles : 0; }

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
    free(c->seed_sb);
    free(c->run_kept);
    free(c->aff);
    free(c->near_blk);
    free(c->rbox);
    free(c->obox);
    free(c->bin_start);
    free(c->slot);
    free(c->xm_epoch);
    free(c->imp);
    for (int r = 0; r < KF_MAX_RIGIDS; r++) free(c->sides[r].v), kf_cpic_solid_free(&c->solid[r]);
    free(c->guard_caught);
    free(c->guard_depth);
    free(c->pd);
    free(c->pn);
    free(c->near);
    free(c->xmask);
    for (int r = 0; r < KF_MAX_RIGIDS; r++)
        free(c->tri[r]), free(c->tri_stamp[r]), free(c->run_sphere[r]), free(c->sub_sphere[r]);
    free(c->bmap);
    free(c->st.coord);
    free(c->st.d);
    free(c->st.c);
    free(c->st.stamp);
    free(c->st.best_stamp);
    free(c->st.mark);
    free(c->st.best);
    free(c->st.hkey);
    free(c->st.hval);
    free(c->early.imp);
    free(c->early.keep);
    free(c->early.first);
    free(c->early.done);
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
        if (grow((void **)&c->slot, sizeof(int32_t), cap) || grow((void **)&c->xm_epoch, sizeof(uint32_t), cap))
            return -1;
        memset(c->xm_epoch, 0, cap * sizeof(uint32_t)); /* none left yet (epochs start at 1) */
        c->cap_owner = cap;
    }
    if (np > c->cap_p) {
        size_t cap = np + np / 4 + 64;
        if (grow((void **)&c->pd, sizeof(float), cap) || grow((void **)&c->pn, 3 * sizeof(float), cap) ||
            grow((void **)&c->near, 1, cap) || grow((void **)&c->xmask, sizeof(uint32_t), cap))
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
__attribute__((noinline)) static const kf_cpic_tri *world_triangle(kf_cpic *c, const kf_rigid_body *b,
                                                                   const kf_rigid_state *st, int r, int k) {
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

/* Where a splat writes: the grid's CDF (kf_cpic's arrays, blocks numbered
 * as the grid's), or the static bodies' store (its own block numbers). */
typedef struct cdf_layer {
    float *d, *best;
    uint32_t *c, *stamp, *best_stamp, *mark;
    uint32_t epoch;
    const kf_cpic *reads; /* the grid's: splat only the nodes particles may read (NULL: all) */
    const kf_grid *g;
} cdf_layer;

static cdf_layer grid_layer(kf_cpic *c, const kf_grid *g) {
    return (cdf_layer){c->node_d, c->best, c->node_c, c->stamp, c->best_stamp, c->mark, c->epoch, c, g};
}

/* a block's CDF cleared, and its per-body best reset, on first touch */
static inline void touch_block(const cdf_layer *L, int32_t b, int r) {
    if (L->stamp[b] != L->epoch) {
        L->stamp[b] = L->epoch;
        for (int k = 0; k < 64; k++) L->d[64 * (size_t)b + k] = FLT_MAX;
        memset(&L->c[64 * (size_t)b], 0, 64 * sizeof(uint32_t));
        memset(&L->mark[64 * (size_t)b], 0, 64 * sizeof(uint32_t));
    }
    uint32_t bs = L->epoch * 16u + (uint32_t)r;
    if (L->best_stamp[b] != bs) {
        L->best_stamp[b] = bs;
        for (int k = 0; k < 64; k++) L->best[64 * (size_t)b + k] = FLT_MAX;
    }
}

/* the node box of one seed (every node within `reach` cells along each
 * axis) and the at most 3x3x3 blocks it spans (nbk along each axis), each
 * looked up once, with those the splat writes (box_live) */
typedef struct seed_box {
    int lo[3], hi[3], b0[3], nbk[3];
    int32_t blk[3][3][3]; /* -1: no such block; only [0, nbk) along each axis is set */
    uint32_t live;        /* bit (p * 3 + q) * 3 + w: blk[p][q][w] holds nodes of the box that particles may read */
} seed_box;

/* the grid's block at a block coordinate, or -1 */
static inline int32_t find_block(const kf_cpic *c, const kf_grid *g, int bx, int by, int bz) {
    if (!c->bmap_on) return kf_grid_find(g, bx, by, bz);
    unsigned x = (unsigned)(bx - c->bmap_lo[0]), y = (unsigned)(by - c->bmap_lo[1]), z = (unsigned)(bz - c->bmap_lo[2]);
    if (x >= (unsigned)c->bmap_dim[0] || y >= (unsigned)c->bmap_dim[1] || z >= (unsigned)c->bmap_dim[2]) return -1;
    return c->bmap[((size_t)x * (size_t)c->bmap_dim[1] + y) * (size_t)c->bmap_dim[2] + z];
}

/* the dense map of this substep's blocks, where their box of blocks holds
 * at most 64 entries per block (and a floor): else lookups hash */
static int bmap_fill(kf_cpic *c, const kf_grid *g) {
    c->bmap_on = 0;
    if (!g->nblocks) return 0;
    int32_t lo[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
    for (size_t b = 0; b < g->nblocks; b++)
        for (int a = 0; a < 3; a++) {
            int32_t v = g->bcoord[3 * b + a];
            lo[a] = v < lo[a] ? v : lo[a];
            hi[a] = v > hi[a] ? v : hi[a];
        }
    size_t vol = 1;
    for (int a = 0; a < 3; a++) vol *= (size_t)(hi[a] - lo[a] + 1);
    if (vol > 64 * g->nblocks + 65536) return 0;
    if (vol > c->cap_bmap) {
        size_t cap = vol + vol / 2;
        if (grow((void **)&c->bmap, sizeof(int32_t), cap)) return -1;
        memset(c->bmap, 0xff, cap * sizeof(int32_t));
        c->cap_bmap = cap;
    }
    for (int a = 0; a < 3; a++) c->bmap_lo[a] = lo[a], c->bmap_dim[a] = hi[a] - lo[a] + 1;
    c->bmap_on = 1;
    for (size_t b = 0; b < g->nblocks; b++) {
        const int32_t *bc = &g->bcoord[3 * b];
        c->bmap[((size_t)(bc[0] - lo[0]) * (size_t)c->bmap_dim[1] + (size_t)(bc[1] - lo[1])) * (size_t)c->bmap_dim[2] +
                (size_t)(bc[2] - lo[2])] = (int32_t)b;
    }
    return 0;
}

/* the map back to all -1 (its entries are exactly the grid's blocks) */
static void bmap_clear(kf_cpic *c, const kf_grid *g) {
    if (!c->bmap_on) return;
    for (size_t b = 0; b < g->nblocks; b++) {
        const int32_t *bc = &g->bcoord[3 * b];
        c->bmap[((size_t)(bc[0] - c->bmap_lo[0]) * (size_t)c->bmap_dim[1] + (size_t)(bc[1] - c->bmap_lo[1])) *
                    (size_t)c->bmap_dim[2] +
                (size_t)(bc[2] - c->bmap_lo[2])] = -1;
    }
    c->bmap_on = 0;
}

/* the node box of a seed at x (its lo, hi, b0 and nbk; no lookups) */
static inline void seed_box_span(const double x[3], double inv_dx, double reach, seed_box *sb) {
    for (int a = 0; a < 3; a++) {
        sb->lo[a] = (int)ceil(x[a] * inv_dx - reach);
        sb->hi[a] = (int)floor(x[a] * inv_dx + reach);
        sb->b0[a] = kf_block_of(sb->lo[a]);
        sb->nbk[a] = kf_block_of(sb->hi[a]) - sb->b0[a] + 1; /* <= 6 nodes span <= 3 blocks */
    }
}

/* sb's blocks looked up (its span set); returns whether any block exists
 * there (else no material is near) */
static int seed_box_blocks(const kf_cpic *c, const kf_grid *g, seed_box *sb) {
    /* the blocks the box spans only (a thin body's box of 3 or 4 nodes: 1 or 2 along each axis) */
    int any = 0;
    for (int p = 0; p < sb->nbk[0]; p++)
        for (int q = 0; q < sb->nbk[1]; q++)
            for (int w = 0; w < sb->nbk[2]; w++) {
                const int32_t bi = find_block(c, g, sb->b0[0] + p, sb->b0[1] + q, sb->b0[2] + w);
                sb->blk[p][q][w] = bi;
                any |= bi >= 0;
            }
    return any;
}

/* The nodes particles read. A node's colour and distance matter only to a
 * particle whose stencil holds it: P2G's colour and fit, the scatter, the
 * gather and the guard all read the particle's own stencil, and an owner
 * whose particles' stencils hold no node with affinity behaves as outside
 * the band (their colours lapse alike; their transfers are the ordinary
 * ones). So a seed splats only the nodes some stencil may read, and a seed
 * whose box holds none is not splatted at all: every node that is read
 * gets the same seeds in the same order, and so the same bits, while a
 * blade above the material, or the part of one far from it, costs nothing.
 * The boxes are per block, from the owners' particle positions.
 * An owner whose nodes no seed can reach (near[owner] == 0, mark_near;
 * near NULL: all are near) gets no box, without a pass over its particles:
 * no seed is kept or dropped for its nodes, and a block's box (the union
 * of its owners') only shrinks by nodes nothing reads and no seed reaches. */
static int read_boxes(const kf_model *m, kf_state *s, const uint8_t *near) {
    kf_cpic *c = s->cpic;
    const kf_grid *g = &s->g;
    const kf_particles *p = &s->p;
    const size_t nb = g->nblocks, no = g->nowner;
    if (nb > c->cap_rbox) {
        size_t cap = nb + nb / 2 + 16;
        if (grow((void **)&c->rbox, sizeof c->rbox[0], cap)) return -1;
        c->cap_rbox = cap;
    }
    if (no > c->cap_obox) {
        size_t cap = no + no / 2 + 16;
        if (grow((void **)&c->obox, sizeof c->obox[0], cap)) return -1;
        c->cap_obox = cap;
    }
    /* the stencil's base node, as the transfers find it, is monotone in the
     * position: the owner's extreme particles give its extreme base nodes */
    const kf_real inv_dx = kf_model_inv_dx(m);
    const int cubic = m->sim.kernel == KF_KERNEL_CUBIC, kw = cubic ? 4 : 3;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) if (p->n >= 65536)
    for (size_t k = 0; k < no; k++) {
        int32_t *ob = c->obox[k];
        if ((near && !near[k]) || g->pstart[k] == g->pstart[k + 1]) {
            ob[0] = ob[1] = ob[2] = 1, ob[3] = ob[4] = ob[5] = 0; /* empty along every axis (contact_point reads it) */
            continue;
        }
        for (int a = 0; a < 3; a++) {
            const kf_real *x = p->x[a];
            kf_real lo = x[g->pstart[k]], hi = lo;
            for (size_t i = g->pstart[k] + 1; i < g->pstart[k + 1]; i++) {
                lo = x[i] < lo ? x[i] : lo;
                hi = x[i] > hi ? x[i] : hi;
            }
            ob[a] = kf_base_node(lo, inv_dx, cubic);
            ob[3 + a] = kf_base_node(hi, inv_dx, cubic) + kw - 1;
        }
    }
    for (size_t b = 0; b < nb; b++)
        c->rbox[b][0] = c->rbox[b][1] = c->rbox[b][2] = 4, c->rbox[b][3] = c->rbox[b][4] = c->rbox[b][5] = -1;
    for (size_t k = 0; k < no; k++) {
        const int32_t *ob = c->obox[k];
        if (ob[0] > ob[3]) continue;
        for (int e = 0; e < 8; e++) {
            int32_t blk = g->nb[k][e];
            if (blk < 0) continue;
            const int32_t *bc = &g->bcoord[3 * (size_t)blk];
            int lo[3], hi[3], in = 1;
            for (int a = 0; a < 3; a++) {
                int first = KF_BLOCK * bc[a];
                lo[a] = ob[a] > first ? ob[a] - first : 0;
                hi[a] = ob[3 + a] < first + KF_BLOCK - 1 ? ob[3 + a] - first : KF_BLOCK - 1;
                in &= lo[a] <= hi[a];
            }
            if (!in) continue;
            int8_t *rb = c->rbox[blk];
            for (int a = 0; a < 3; a++) {
                if (lo[a] < rb[a]) rb[a] = (int8_t)lo[a];
                if (hi[a] > rb[3 + a]) rb[3 + a] = (int8_t)hi[a];
            }
        }
    }
    return 0;
}

/* the part of nodes lo..hi (global) in block blk that particles may read; 0: none */
static inline int clip_reads(const kf_cpic *c, const kf_grid *g, int32_t blk, int lo[3], int hi[3]) {
    const int8_t *rb = c->rbox[blk];
    const int32_t *bc = &g->bcoord[3 * (size_t)blk];
    int in = 1;
    for (int a = 0; a < 3; a++) {
        int first = KF_BLOCK * bc[a];
        if (first + rb[a] > lo[a]) lo[a] = first + rb[a];
        if (first + rb[3 + a] < hi[a]) hi[a] = first + rb[3 + a];
        in &= lo[a] <= hi[a];
    }
    return in;
}

/* whether the seed's box holds a node of block blk that particles may
 * read (clip_reads of the box, without the clipped range) */
static inline int box_meets_reads(const kf_cpic *c, const kf_grid *g, int32_t blk, const seed_box *sb) {
    const int8_t *rb = c->rbox[blk];
    const int32_t *bc = &g->bcoord[3 * (size_t)blk];
    for (int a = 0; a < 3; a++) {
        const int first = KF_BLOCK * bc[a], lo = first + rb[a], hi = first + rb[3 + a];
        if ((lo > sb->lo[a] ? lo : sb->lo[a]) > (hi < sb->hi[a] ? hi : sb->hi[a])) return 0;
    }
    return 1;
}

/* The blocks of the seed's box that hold nodes of it particles may read
 * (reads NULL: every block there is), as seed_box's live bits: the blocks
 * the splat touches and writes. 0: no node of the box is read. */
static uint32_t box_live(const kf_cpic *reads, const kf_grid *g, const seed_box *sb) {
    uint32_t live = 0;
    for (int p = 0; p < sb->nbk[0]; p++)
        for (int q = 0; q < sb->nbk[1]; q++)
            for (int w = 0; w < sb->nbk[2]; w++) {
                const int32_t blk = sb->blk[p][q][w];
                if (blk >= 0 && (!reads || box_meets_reads(reads, g, blk, sb))) live |= 1u << ((p * 3 + q) * 3 + w);
            }
    return live;
}

/* whether two seed boxes hold the same nodes */
static inline int same_nodes(const seed_box *a, const seed_box *b) {
    return a->lo[0] == b->lo[0] && a->lo[1] == b->lo[1] && a->lo[2] == b->lo[2] && a->hi[0] == b->hi[0] &&
           a->hi[1] == b->hi[1] && a->hi[2] == b->hi[2];
}

/* The box of the seed at x with its blocks and live bits (returned; 0: the
 * seed drops out, its box holds no node particles read). The blocks and
 * their read boxes do not change during the keep pass, so a box of the
 * same nodes as the one found just before it (prev; NULL: none) is a copy
 * of that one: on a thin blade the seeds of its two faces on one line of
 * the seeding lattice are a few millimetres apart, and their boxes mostly
 * the same (41% of the knife's; the last four boxes instead of one: 49%,
 * for no fewer instructions in all). */
static uint32_t seed_box_live(const kf_cpic *c, const kf_grid *g, const double x[3], double inv_dx, double reach,
                              const seed_box *prev, seed_box *sb) {
    seed_box_span(x, inv_dx, reach, sb);
    if (prev && same_nodes(prev, sb)) {
        *sb = *prev;
        return sb->live;
    }
    sb->live = seed_box_blocks(c, g, sb) ? box_live(c, g, sb) : 0;
    return sb->live;
}

/* the bounding spheres of a body's seeds in runs of `len` (body frame),
 * with the half sides of their boxes */
static int spheres_of(const kf_rigid_body *b, size_t len, double (**out)[8]) {
    size_t nrun = (b->nseed + len - 1) / len;
    if (grow((void **)out, sizeof(**out), nrun)) return -1;
    for (size_t k = 0; k < nrun; k++) {
        size_t e0 = k * len, e1 = e0 + len < b->nseed ? e0 + len : b->nseed;
        double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300}, mid[3], rad2 = 0;
        for (size_t e = e0; e < e1; e++)
            for (int a = 0; a < 3; a++) {
                double v = b->seed[3 * e + a];
                lo[a] = v < lo[a] ? v : lo[a];
                hi[a] = v > hi[a] ? v : hi[a];
            }
        for (int a = 0; a < 3; a++) mid[a] = 0.5 * (lo[a] + hi[a]);
        for (size_t e = e0; e < e1; e++) {
            double d2 = 0;
            for (int a = 0; a < 3; a++) d2 += (b->seed[3 * e + a] - mid[a]) * (b->seed[3 * e + a] - mid[a]);
            rad2 = d2 > rad2 ? d2 : rad2;
        }
        for (int a = 0; a < 3; a++) (*out)[k][a] = mid[a];
        /* a little more: the seeds' world positions round differently */
        (*out)[k][3] = sqrt(rad2) * (1 + 1e-6) + 1e-9;
        for (int a = 0; a < 3; a++) (*out)[k][4 + a] = 0.5 * (hi[a] - lo[a]) * (1 + 1e-6) + 1e-9;
        (*out)[k][7] = 0;
    }
    return 0;
}

/* body r's runs of seeds and their bounding spheres (made once per mesh) */
static int run_spheres(kf_cpic *c, const kf_rigid_body *b, int r) {
    if (c->run_sphere[r] && c->run_seed[r] == b->seed && c->run_nseed[r] == b->nseed) return 0;
    if (spheres_of(b, KF_CPIC_RUN, &c->run_sphere[r]) || spheres_of(b, KF_CPIC_RUN / 8, &c->sub_sphere[r])) return -1;
    c->run_seed[r] = b->seed;
    c->run_nseed[r] = b->nseed;
    return 0;
}

/* a run's sphere centre in the world */
static inline void sphere_world(const kf_rigid_state *st, const double *sp, double xc[3]) {
    for (int a = 0; a < 3; a++)
        xc[a] = st->R[3 * a] * sp[0] + st->R[3 * a + 1] * sp[1] + st->R[3 * a + 2] * sp[2] + st->t[a];
}

/* How far a run's seeds lie from its centre along each world axis: the
 * rotated box's half sides (|R| times the body-frame half sides, a little
 * more for the rounding of the seeds' world positions), at most the
 * sphere's radius. For a body that does not turn this is the seeds' own
 * box: much tighter than the sphere for a run along a blade's edge. */
static inline void run_extent(const kf_rigid_state *st, const double *sp, double ext[3]) {
    for (int a = 0; a < 3; a++) {
        const double e = fabs(st->R[3 * a]) * sp[4] + fabs(st->R[3 * a + 1]) * sp[5] + fabs(st->R[3 * a + 2]) * sp[6];
        const double m = e * (1 + 1e-9) + 1e-9;
        ext[a] = m < sp[3] ? m : sp[3];
    }
}

static void seed_world(const kf_rigid_state *st, const float *o, double x[3]);

/* Marks in near[] every block whose owner's stencils could read a node
 * within reach of a seed in the sphere (xc, rad): the node range run_far
 * bounds such a seed's box by, a node wider. Returns 1 when the blocks
 * number more than `most` (nothing marked), -1 for a position that is not
 * finite. With near NULL it only looks: 1 when some such block exists (or
 * they number more than `most`), 0 when none does. */
static int mark_sphere(const kf_cpic *c, const kf_grid *g, const double xc[3], double rad, double inv_dx, double reach,
                       int kw, size_t most, uint8_t *near) {
    int b0[3], b1[3];
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        const double lo = floor((xc[a] - rad) * inv_dx - reach) - 2, hi = ceil((xc[a] + rad) * inv_dx + reach) + 2;
        if (!(lo == lo) || !(hi == hi)) return -1;
        /* an owner's stencils read its block's nodes and kw - 1 beyond;
         * clamped to the block map's box (a block outside it is none) */
        const double blo = c->bmap_lo[a], bhi = c->bmap_lo[a] + c->bmap_dim[a] - 1;
        const double mlo = (blo - 2) * KF_BLOCK, mhi = (bhi + 2) * KF_BLOCK;
        b0[a] = kf_block_of((int)fmin(fmax(lo - (KF_BLOCK - 1 + kw - 1), mlo), mhi));
        b1[a] = kf_block_of((int)fmin(fmax(hi, mlo), mhi));
        b0[a] = b0[a] < (int)blo ? (int)blo : b0[a];
        b1[a] = b1[a] > (int)bhi ? (int)bhi : b1[a];
        n *= (size_t)(b1[a] >= b0[a] ? b1[a] - b0[a] + 1 : 0);
    }
    if (n > most) return 1;
    for (int p = b0[0]; p <= b1[0] && n; p++)
        for (int q = b0[1]; q <= b1[1]; q++)
            for (int w = b0[2]; w <= b1[2]; w++) {
                int32_t blk = find_block(c, g, p, q, w);
                if (blk < 0) continue;
                if (!near) return 1;
                near[blk] = 1;
            }
    return 0;
}

/* mark_sphere's marks for every seed on triangle k of body b (pose st),
 * by the triangle itself: the blocks of its box (its corners' box in place
 * of a sphere) whose reach its plane passes through. A seed marks block p
 * along an axis only when it lies within [4p - reach - 3, 4p + 8 + kw +
 * reach] nodes (mark_sphere's box, a node wider), so a block none of whose
 * such boxes the plane meets is marked by none of its seeds. Seeds are
 * floats on the triangle: a margin of a node covers their rounding. */
static int mark_triangle(const kf_cpic *c, const kf_grid *g, const kf_rigid_body *b, const kf_rigid_state *st, int k,
                         double inv_dx, double reach, int kw, uint8_t *near) {
    double v[3][3], lo[3], hi[3], e1[3], e2[3], n[3];
    for (int q = 0; q < 3; q++) {
        const double *o = &b->vert[3 * b->tri[3 * k + q]];
        for (int a = 0; a < 3; a++)
            v[q][a] = (st->R[3 * a] * o[0] + st->R[3 * a + 1] * o[1] + st->R[3 * a + 2] * o[2] + st->t[a]) * inv_dx;
    }
    for (int a = 0; a < 3; a++) {
        lo[a] = fmin(v[0][a], fmin(v[1][a], v[2][a]));
        hi[a] = fmax(v[0][a], fmax(v[1][a], v[2][a]));
        e1[a] = v[1][a] - v[0][a];
        e2[a] = v[2][a] - v[0][a];
    }
    kf_v3d_cross(n, e1, e2);
    const double nn = sqrt(kf_v3d_dot(n, n));
    for (int a = 0; a < 3; a++) n[a] = nn > 0 ? n[a] / nn : 0; /* degenerate: every block of the box */
    int b0[3], b1[3];
    for (int a = 0; a < 3; a++) {
        const double l = floor(lo[a] - reach) - 3, h = ceil(hi[a] + reach) + 3;
        if (!(l == l) || !(h == h)) return -1;
        const double blo = c->bmap_lo[a], bhi = c->bmap_lo[a] + c->bmap_dim[a] - 1;
        const double mlo = (blo - 2) * KF_BLOCK, mhi = (bhi + 2) * KF_BLOCK;
        b0[a] = kf_block_of((int)fmin(fmax(l - (KF_BLOCK - 1 + kw - 1), mlo), mhi));
        b1[a] = kf_block_of((int)fmin(fmax(h, mlo), mhi));
        b0[a] = b0[a] < (int)blo ? (int)blo : b0[a];
        b1[a] = b1[a] > (int)bhi ? (int)bhi : b1[a];
    }
    /* the plane's offset, and a block's reach as a box: centre and half
     * sides. Along the axis the plane faces most, the blocks it passes
     * within reach of form one run per column of the other two axes (a
     * block wider each way): the work follows the triangle's area, not its
     * box's volume. */
    const double off = kf_v3d_dot(n, v[0]);
    const double half = 0.5 * (11 + kw + 2 * reach) + 1, mid = 0.5 * (5 + kw);
    const double spread = half * (fabs(n[0]) + fabs(n[1]) + fabs(n[2]));
    int ax = 0;
    for (int a = 1; a < 3; a++)
        if (fabs(n[a]) > fabs(n[ax])) ax = a;
    const int a1 = (ax + 1) % 3, a2 = (ax + 2) % 3;
    int blk3[3];
    for (int p = b0[a1]; p <= b1[a1]; p++)
        for (int q = b0[a2]; q <= b1[a2]; q++) {
            int w0 = b0[ax], w1 = b1[ax];
            if (n[ax] != 0) {
                const double rest = n[a1] * (KF_BLOCK * p + mid) + n[a2] * (KF_BLOCK * q + mid);
                const double f0 = (off - rest - spread) / n[ax], f1 = (off - rest + spread) / n[ax];
                const double wlo = floor((fmin(f0, f1) - mid) / KF_BLOCK) - 1,
                             whi = ceil((fmax(f0, f1) - mid) / KF_BLOCK) + 1;
                if (wlo > w0) w0 = (int)wlo;
                if (whi < w1) w1 = (int)whi;
            }
            for (int w = w0; w <= w1; w++) {
                blk3[a1] = p, blk3[a2] = q, blk3[ax] = w;
                int32_t blk = find_block(c, g, blk3[0], blk3[1], blk3[2]);
                if (blk >= 0) near[blk] = 1;
            }
        }
    return 0;
}

/* The owners some seed of body r (pose st) may reach this substep, marked
 * in near[] (one byte per block of the grid): per short run of seeds, by
 * its bounding sphere, or seed by seed where the sphere is wide (a run
 * that turns a corner of the mesh). A mesh of few large triangles (many
 * seeds each: a blade of two) is marked triangle by triangle instead.
 * Returns 1 when every owner must count as near (no block map, a pose
 * that is not finite). */
static int mark_near(const kf_cpic *c, const kf_grid *g, const kf_rigid_body *b, const kf_rigid_state *st, int r,
                     double inv_dx, int kw, uint8_t *near) {
    if (!c->bmap_on) return 1;
    const double reach = b->def.thin ? 1.5 : 2.5; /* splat_body's */
    if ((size_t)b->ntri * 16 <= b->nseed) {
        for (int k = 0; k < b->ntri; k++)
            if (mark_triangle(c, g, b, st, k, inv_dx, reach, kw, near) < 0) return 1;
        return 0;
    }
    const size_t len = KF_CPIC_RUN / 8, nrun = (b->nseed + len - 1) / len;
    for (size_t k = 0; k < nrun; k++) {
        double xc[3];
        /* a long run with no block within reach: its eight short runs pass */
        if (k % 8 == 0) {
            const double *lp = c->run_sphere[r][k / 8];
            sphere_world(st, lp, xc);
            int any = mark_sphere(c, g, xc, lp[3], inv_dx, reach, kw, 64, NULL);
            if (any < 0) return 1;
            if (!any) {
                k += 7;
                continue;
            }
        }
        const double *sp = c->sub_sphere[r][k];
        sphere_world(st, sp, xc);
        int wide = mark_sphere(c, g, xc, sp[3], inv_dx, reach, kw, 64, near);
        if (wide < 0) return 1;
        for (size_t e = k * len; wide && e < (k + 1) * len && e < b->nseed; e++) {
            seed_world(st, &b->seed[3 * e], xc);
            if (mark_sphere(c, g, xc, 0, inv_dx, reach, kw, SIZE_MAX, near) < 0) return 1;
        }
    }
    return 0;
}

/* The owners some seed of any body may reach, marked in near[], by the
 * box of each body's seeds (the union of its runs' boxes, rotated into the
 * world): a coarse mark_near that costs a few comparisons per owner. An
 * owner reads the nodes of its 2x2x2 blocks; a seed's box reaches reach
 * nodes about it (seed_box_span), so an owner none of whose nodes lies
 * within reach of a body's box is reached by none of its seeds. Every
 * body counts, static ones too, so an owner near any body's surface gets
 * its box as without marks. Returns 1 when every owner must count as near
 * (no body has seeds, or a pose is not finite). */
static int near_bodies(const kf_model *m, kf_state *s, uint8_t *near) {
    kf_cpic *c = s->cpic;
    const kf_grid *g = &s->g;
    const double inv_dx = 1 / m->sim.dx;
    int lo[KF_MAX_RIGIDS][3], hi[KF_MAX_RIGIDS][3], nb = 0;
    for (int r = 0; r < m->nrigid; r++) {
        const kf_rigid_body *b = &m->rigid[r];
        if (b->nseed == 0) continue;
        if (run_spheres(c, b, r)) return 1;
        const kf_rigid_state *st = &s->rigid[r];
        const double reach = b->def.thin ? 1.5 : 2.5; /* splat_body's */
        double blo[3] = {1e300, 1e300, 1e300}, bhi[3] = {-1e300, -1e300, -1e300};
        const size_t nrun = (b->nseed + KF_CPIC_RUN - 1) / KF_CPIC_RUN;
        for (size_t k = 0; k < nrun; k++) {
            const double *sp = c->run_sphere[r][k];
            for (int a = 0; a < 3; a++) {
                blo[a] = fmin(blo[a], sp[a] - sp[4 + a]);
                bhi[a] = fmax(bhi[a], sp[a] + sp[4 + a]);
            }
        }
        double box[8] = {0.5 * (blo[0] + bhi[0]), 0.5 * (blo[1] + bhi[1]), 0.5 * (blo[2] + bhi[2]), 1e300, 0, 0, 0, 0};
        for (int a = 0; a < 3; a++) box[4 + a] = (0.5 * (bhi[a] - blo[a])) * (1 + 1e-9) + 1e-9;
        double xc[3], ext[3];
        sphere_world(st, box, xc);
        run_extent(st, box, ext);
        for (int a = 0; a < 3; a++) {
            const double l = floor((xc[a] - ext[a]) * inv_dx - reach) - 1,
                         h = ceil((xc[a] + ext[a]) * inv_dx + reach) + 1;
            if (!(l > -1e9 && h < 1e9)) return 1;
            lo[nb][a] = (int)l, hi[nb][a] = (int)h;
        }
        nb++;
    }
    if (!nb) return 1;
    const size_t no = g->nowner;
    for (size_t k = 0; k < no; k++) {
        const int32_t *bc = &g->bcoord[3 * k]; /* an owner is the block of the same index */
        uint8_t in = 0;
        for (int q = 0; q < nb && !in; q++) {
            in = 1;
            for (int a = 0; a < 3; a++)
                in &= KF_BLOCK * bc[a] + 2 * KF_BLOCK >= lo[q][a] && KF_BLOCK * bc[a] - 1 <= hi[q][a];
        }
        near[k] = in;
    }
    return 0;
}

/* Can no seed of this run (centre xc, within ext of it along each axis, world) have a
 * block in its box? Outside the grid's box with a margin (slo, shi), or no
 * block in the blocks its seeds' boxes can span. Conservative: a run it
 * passes over would have had every seed drop out one by one. */
static int run_far(const kf_cpic *c, const kf_grid *g, const double xc[3], const double ext[3], const double slo[3],
                   const double shi[3], double inv_dx, double reach) {
    for (int a = 0; a < 3; a++)
        if (xc[a] + ext[a] < slo[a] || xc[a] - ext[a] > shi[a]) return 1;
    if (!c->bmap_on) return 0;
    int n0[3], n1[3], b0[3], b1[3];
    size_t n = 1;
    for (int a = 0; a < 3; a++) {
        /* the seeds' boxes' nodes (seed_box_span: ceil(x - reach) ..
         * floor(x + reach) in nodes): each step is monotone in x, and ext
         * covers the seeds' rounding, so these bound them; a millionth of
         * a node more */
        n0[a] = (int)ceil((xc[a] - ext[a]) * inv_dx - reach - 1e-6);
        n1[a] = (int)floor((xc[a] + ext[a]) * inv_dx + reach + 1e-6);
        b0[a] = kf_block_of(n0[a]);
        b1[a] = kf_block_of(n1[a]);
        n *= (size_t)(b1[a] - b0[a] + 1);
    }
    if (n > 64) return 0;
    /* a block counts only where particles may read its nodes (read_boxes) */
    for (int p = b0[0]; p <= b1[0]; p++)
        for (int q = b0[1]; q <= b1[1]; q++)
            for (int w = b0[2]; w <= b1[2]; w++) {
                int32_t blk = find_block(c, g, p, q, w);
                int lo[3] = {n0[0], n0[1], n0[2]}, hi[3] = {n1[0], n1[1], n1[2]};
                if (blk >= 0 && clip_reads(c, g, blk, lo, hi)) return 0;
            }
    return 1;
}

/* What node `node` (of the layer) takes from a triangle of body r whose
 * plane lies at signed distance u (m) from it, the projection inside the
 * triangle: affinity, the side from the body's closest primitive, and the
 * closest body (ties to the smaller index, as when the bodies are splatted
 * in index order with strict minima, whatever order they come in) */
static inline void splat_node(const cdf_layer *c, size_t node, double u, uint32_t abit, uint32_t tbit, int r,
                              double inv_dx) {
    float au = (float)(fabs(u) * inv_dx);
    uint32_t w = c->c[node] | abit;
    if (au < c->best[node]) {
        /* the body's closest primitive decides the side */
        c->best[node] = au;
        w = u < 0 ? (w | tbit) : (w & ~tbit);
    }
    uint32_t rs = w >> KF_CPIC_RSTAR_SHIFT;
    if (au < c->d[node] || (au == c->d[node] && rs > (uint32_t)(r + 1))) {
        c->d[node] = au;
        w = (w & KF_CPIC_BITS_MASK) | (uint32_t)(r + 1) << KF_CPIC_RSTAR_SHIFT;
    }
    c->c[node] = w;
}

#if defined(__AVX2__) && defined(__FMA__)
/* The lanes `in` of splat_box's row (i, j) of z nodes from k0, those that
 * landed inside triangle T, to their nodes. Out of line: one row in twenty
 * has such a lane, and the row loop keeps its registers. q and u are made
 * with the row loop's fma chains, so to the same bits. */
__attribute__((noinline)) static void splat_row_hits(const cdf_layer *c, const kf_cpic_tri *T, uint32_t tid,
                                                     const seed_box *sb, int r, int i, int j, int k0, int in,
                                                     double inv_dx, double dx) {
    const uint32_t abit = 2u << (2 * r), tbit = 1u << (2 * r);
    const double qx = fma((double)i, dx, -(double)T->v0[0]), qy = fma((double)j, dx, -(double)T->v0[1]);
    const double yu = fma(qy, (double)T->n[1], qx * T->n[0]);
    const int p = kf_block_of(i) - sb->b0[0], q = kf_block_of(j) - sb->b0[1];
    for (; in; in &= in - 1) {
        const int k = k0 + __builtin_ctz((unsigned)in), w = kf_block_of(k) - sb->b0[2];
        const int bit = (p * 3 + q) * 3 + w;
        if (!(sb->live >> bit & 1)) continue;
        const int32_t blk = (&sb->blk[0][0][0])[bit];
        const int n3[3] = {i & 3, j & 3, k & 3}; /* the node within its block */
        if (c->reads) {
            const int8_t *rb = c->reads->rbox[blk];
            if (n3[0] < rb[0] || n3[0] > rb[3] || n3[1] < rb[1] || n3[1] > rb[4] || n3[2] < rb[2] || n3[2] > rb[5])
                continue;
        }
        const size_t node = 64 * (size_t)blk + (size_t)(n3[0] << 4 | n3[1] << 2 | n3[2]);
        if (c->mark[node] == tid) continue;
        c->mark[node] = tid;
        const double qz = fma((double)k, dx, -(double)T->v0[2]);
        splat_node(c, node, fma(qz, (double)T->n[2], yu), abit, tbit, r, inv_dx);
    }
}

/* The nodes of one seed's box, projected onto its triangle t of body r.
 * What a node gets from a triangle depends on the node and the triangle
 * only, not on the seed, and a second visit changes nothing (strict minima,
 * or-ed bits): a node whose last visitor was this very triangle (tid, from
 * 1, unique across bodies) is skipped, bit for bit.
 * The box's live blocks (those holding nodes particles may read) are
 * touched first, then its nodes are projected in rows along z over the
 * whole box, whatever block each is in: a box of 3 or 4 nodes along z is
 * one AVX2 register of 4 lanes (a solid's 5 or 6, two). Only the nodes
 * whose projection lands inside the triangle (one in thirty on a knife of
 * fine triangles) go on one by one (splat_row_hits): to their block, if it
 * is live and particles read the node (the block's read box), as the
 * block-by-block loop (#else) clips them. Each lane does the scalar loop's arithmetic as
 * the compiler contracts it there: q = fma(i, Δx, −v0), d1 = fma(q_z,
 * e1_z, fma(q_y, e1_y, q_x e1_x)) (d2 and u alike), α = fma(d1, g11, g12
 * d2), β = fma(d1, g12, g22 d2), and the same three strict tests: bit for
 * bit. A seed visits each node once, so the order of its nodes changes no
 * node's sequence of visitors. A node whose projection is outside is not
 * marked: a later seed of the same triangle projects it again to the same
 * outcome (the mark only saves that work). */
__attribute__((noinline)) static void splat_box(const cdf_layer *c, const kf_cpic_tri *t, uint32_t tid,
                                                const seed_box *sb, int r, double inv_dx, double dx) {
    if ((t->g11 == 0 && t->g22 == 0) || !sb->live) return;
    /* live's bit numbers index blk as a flat array */
    for (uint32_t live = sb->live; live; live &= live - 1) touch_block(c, (&sb->blk[0][0][0])[__builtin_ctz(live)], r);
    const kf_cpic_tri T = *t;
    const double eps = 1e-6; /* shared edges must not fall between two triangles */
    const __m256d e1z = _mm256_set1_pd(T.e1[2]), e2z = _mm256_set1_pd(T.e2[2]);
    const __m256d g11 = _mm256_set1_pd(T.g11), g12 = _mm256_set1_pd(T.g12), g22 = _mm256_set1_pd(T.g22);
    const __m256d lo_eps = _mm256_set1_pd(-eps), hi_eps = _mm256_set1_pd(1 + eps);
    for (int k0 = sb->lo[2]; k0 <= sb->hi[2]; k0 += 4) {
        const int nk = sb->hi[2] - k0 + 1 < 4 ? sb->hi[2] - k0 + 1 : 4;
        const __m256d kz = _mm256_add_pd(_mm256_set1_pd(k0), _mm256_setr_pd(0, 1, 2, 3));
        const __m256d qz = _mm256_fmsub_pd(kz, _mm256_set1_pd(dx), _mm256_set1_pd(T.v0[2]));
        const int lanes = (1 << nk) - 1;
        for (int i = sb->lo[0]; i <= sb->hi[0]; i++) {
            const double qx = fma((double)i, dx, -(double)T.v0[0]);
            const double x1 = qx * T.e1[0], x2 = qx * T.e2[0];
            for (int j = sb->lo[1]; j <= sb->hi[1]; j++) {
                const double qy = fma((double)j, dx, -(double)T.v0[1]);
                const double y1 = fma(qy, (double)T.e1[1], x1), y2 = fma(qy, (double)T.e2[1], x2);
                const __m256d d1 = _mm256_fmadd_pd(qz, e1z, _mm256_set1_pd(y1));
                const __m256d d2 = _mm256_fmadd_pd(qz, e2z, _mm256_set1_pd(y2));
                const __m256d al = _mm256_fmadd_pd(d1, g11, _mm256_mul_pd(g12, d2));
                const __m256d be = _mm256_fmadd_pd(d1, g12, _mm256_mul_pd(g22, d2));
                /* outside: al < −eps, or be < −eps, or al + be > 1 + eps (a NaN is inside, as in the scalar tests) */
                const __m256d out = _mm256_or_pd(
                    _mm256_or_pd(_mm256_cmp_pd(al, lo_eps, _CMP_LT_OQ), _mm256_cmp_pd(be, lo_eps, _CMP_LT_OQ)),
                    _mm256_cmp_pd(_mm256_add_pd(al, be), hi_eps, _CMP_GT_OQ));
                const int in = ~_mm256_movemask_pd(out) & lanes;
                if (in) splat_row_hits(c, &T, tid, sb, r, i, j, k0, in, inv_dx, dx);
            }
        }
    }
}
#else
/* the nodes lo..hi of one block blk, projected onto triangle t (splat_box) */
static inline void splat_nodes(const cdf_layer *c, const kf_cpic_tri *t, uint32_t tid, int32_t blk, const int lo[3],
                               const int hi[3], uint32_t abit, uint32_t tbit, int r, double inv_dx, double dx) {
    /* the triangle in locals: the stores below cannot change them, so they
     * stay in registers (the same values, the same arithmetic) */
    const kf_cpic_tri T = *t;
    for (int i = lo[0]; i <= hi[0]; i++)
        for (int j = lo[1]; j <= hi[1]; j++)
            for (int k = lo[2]; k <= hi[2]; k++) {
                size_t node = 64 * (size_t)blk + (size_t)((i & 3) << 4 | (j & 3) << 2 | (k & 3));
                if (c->mark[node] == tid) continue;
                c->mark[node] = tid;
                /* x_i − v0 = α e1 + β e2 + u n */
                double q[3] = {i * dx - T.v0[0], j * dx - T.v0[1], k * dx - T.v0[2]};
                double d1 = q[0] * T.e1[0] + q[1] * T.e1[1] + q[2] * T.e1[2];
                double d2 = q[0] * T.e2[0] + q[1] * T.e2[1] + q[2] * T.e2[2];
                double al = T.g11 * d1 + T.g12 * d2, be = T.g12 * d1 + T.g22 * d2;
                const double eps = 1e-6; /* shared edges must not fall between two triangles */
                if (al < -eps || be < -eps || al + be > 1 + eps) continue;
                double u = q[0] * T.n[0] + q[1] * T.n[1] + q[2] * T.n[2];
                splat_node(c, node, u, abit, tbit, r, inv_dx);
            }
}

/* the nodes of one seed's box, projected onto its triangle t of body r.
 * What a node gets from a triangle depends on the node and the triangle
 * only, not on the seed, and a second visit changes nothing (strict minima,
 * or-ed bits): a node whose last visitor was this very triangle (tid, from
 * 1, unique across bodies) is skipped, bit for bit. */
__attribute__((noinline)) static void splat_box(const cdf_layer *c, const kf_cpic_tri *t, uint32_t tid,
                                                const seed_box *sb, int r, double inv_dx, double dx) {
    if (t->g11 == 0 && t->g22 == 0) return;
    const uint32_t abit = 2u << (2 * r), tbit = 1u << (2 * r);
    /* block by block: each block of the box once, then its part of the box */
    for (int bp = 0; bp < sb->nbk[0]; bp++)
        for (int bq = 0; bq < sb->nbk[1]; bq++)
            for (int bw = 0; bw < sb->nbk[2]; bw++) {
                int32_t blk = sb->blk[bp][bq][bw];
                if (blk < 0) continue;
                const int b3[3] = {bp, bq, bw};
                int lo[3], hi[3];
                for (int a = 0; a < 3; a++) {
                    int first = KF_BLOCK * (sb->b0[a] + b3[a]);
                    lo[a] = sb->lo[a] > first ? sb->lo[a] : first;
                    hi[a] = sb->hi[a] < first + KF_BLOCK - 1 ? sb->hi[a] : first + KF_BLOCK - 1;
                }
                if (c->reads && !clip_reads(c->reads, c->g, blk, lo, hi)) continue;
                touch_block(c, blk, r);
                splat_nodes(c, t, tid, blk, lo, hi, abit, tbit, r, inv_dx, dx);
            }
}
#endif

/* a seed's world position: one function for the grid's splat and the
 * static store, so both round alike */
__attribute__((noinline)) static void seed_world(const kf_rigid_state *st, const float *o, double x[3]) {
    for (int a = 0; a < 3; a++)
        x[a] = st->R[3 * a] * o[0] + st->R[3 * a + 1] * o[1] + st->R[3 * a + 2] * o[2] + st->t[a];
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
            grow((void **)&c->seed_order, sizeof(int32_t), cap) || grow(&c->seed_sb, sizeof(seed_box), cap))
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
    seed_box *sbox = c->seed_sb;
    /* small bodies stay on one thread: waking a sleeping team costs more
     * than their seeds (the bins' order, hence the result, is the same) */
    if (run_spheres(c, b, r)) return -1;
    const size_t nrun = (ns + KF_CPIC_RUN - 1) / KF_CPIC_RUN;
    if (nrun > c->cap_run_kept) {
        size_t cap = nrun + nrun / 4 + 16;
        if (grow((void **)&c->run_kept, 1, cap)) return -1;
        c->cap_run_kept = cap;
    }
    uint8_t *kept = c->run_kept;
    size_t nkept = 0;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) if (ns >= 8192) reduction(+ : nkept)
    for (size_t k = 0; k < nrun; k++) {
        const size_t e0 = k * KF_CPIC_RUN, e1 = e0 + KF_CPIC_RUN < ns ? e0 + KF_CPIC_RUN : ns;
        /* a run far from every block: its seeds all drop out */
        const double *sp = c->run_sphere[r][k];
        double xc[3], ext[3];
        sphere_world(st, sp, xc);
        run_extent(st, sp, ext);
        kept[k] = 0;
        for (size_t e = e0; e < e1; e++) sbin[e] = -1;
        if (run_far(c, g, xc, ext, slo, shi, inv_dx, reach)) continue;
        const seed_box *prev = NULL; /* the box found last in this run */
        for (size_t e = e0; e < e1; e++) {
            /* the same, eight times finer */
            if ((e - e0) % (KF_CPIC_RUN / 8) == 0) {
                const double *ss = c->sub_sphere[r][e / (KF_CPIC_RUN / 8)];
                sphere_world(st, ss, xc);
                run_extent(st, ss, ext);
                if (run_far(c, g, xc, ext, slo, shi, inv_dx, reach)) {
                    e += KF_CPIC_RUN / 8 - 1;
                    continue;
                }
            }
            if (b->tri_edge && b->tri_edge[b->seed_tri[e]]) continue; /* a blade's narrow side: its sheet's edge */
            const float *o = &b->seed[3 * e];
            double *x = &sx[3 * e];
            int out = 0;
            seed_world(st, o, x);
            for (int a = 0; a < 3; a++) out |= x[a] < slo[a] || x[a] > shi[a];
            if (out) continue;
            /* the box is kept for the splat below (the grid does not change in between) */
            seed_box *sb = &sbox[e];
            const uint32_t live = seed_box_live(c, g, x, inv_dx, reach, prev, sb);
            prev = sb;
            if (!live) continue;
            int bin = sb->b0[0] - bin0;
            sbin[e] = bin >= 0 && (size_t)bin < nbins ? bin : -1; /* outside: no block there either */
            if (sbin[e] >= 0) kept[k] = 1, nkept++;
        }
    }
    /* none kept (a body near the material but reaching no node it reads):
     * nothing to splat */
    if (!nkept) return 0;
    /* 2. the triangles the remaining seeds lie on, in world space; the
     * seeds grouped by bin (a stable counting sort), over the runs that
     * kept a seed */
    int32_t *bs = c->bin_start;
    memset(bs, 0, (nbins + 1) * sizeof *bs);
    for (size_t k = 0; k < nrun; k++)
        for (size_t e = k * KF_CPIC_RUN, e1 = e + KF_CPIC_RUN < ns ? e + KF_CPIC_RUN : ns; kept[k] && e < e1; e++)
            if (sbin[e] >= 0) {
                bs[sbin[e] + 1]++;
                if (c->tri_stamp[r][b->seed_tri[e]] != c->epoch) world_triangle(c, b, st, r, b->seed_tri[e]);
            }
    for (size_t k = 0; k < nbins; k++) bs[k + 1] += bs[k];
    {
        int32_t *fill = c->seed_order;
        for (size_t k = 0; k < nrun; k++)
            for (size_t e = k * KF_CPIC_RUN, e1 = e + KF_CPIC_RUN < ns ? e + KF_CPIC_RUN : ns; kept[k] && e < e1; e++)
                if (sbin[e] >= 0) fill[bs[sbin[e]]++] = (int32_t)e;
        for (size_t k = nbins; k > 0; k--) bs[k] = bs[k - 1];
        bs[0] = 0;
    }
    /* 3. three rounds of bins, in one team; a round is the bins whose
     * x-block is the same mod 3 (counted from x-block 0, not from the grid's
     * edge: so a node sees its seeds in an order fixed by where it is, the
     * order the static bodies' store is made in) */
    const int32_t *order = c->seed_order;
    const cdf_layer L = grid_layer(c, g);
#pragma omp parallel num_threads(m->nthreads) if (bs[nbins] >= 1024)
    for (int round = 0; round < 3; round++) {
        const int first = ((round - bin0) % 3 + 3) % 3;
#pragma omp for schedule(dynamic, 1)
        for (size_t k = (size_t)first; k < nbins; k += 3)
            for (int32_t q = bs[k]; q < bs[k + 1]; q++) {
                size_t e = (size_t)order[q];
                int tri = b->seed_tri[e];
                splat_box(&L, &c->tri[r][tri], tid0 + (uint32_t)tri, &sbox[e], r, inv_dx, dx);
            }
    }
    return 0;
}

/* ---- the static bodies' store --------------------------------------------
 * A static body's CDF at a node depends on the node and the body alone: it
 * is the same every substep. So it is splatted once, for every block within
 * reach of its seeds in the domain (and three blocks around it), into a
 * store of its own, and each substep only copies the blocks the grid has.
 * What a substep with moving bodies adds on top (their own bits, and the
 * closest body by distance, ties to the smaller index) does not depend on
 * the order the bodies come in, and each body's seeds reach a node in the
 * same order either way (rounds by x-block mod 3, then x-block, then seed),
 * so the copy gives the grid bit for bit what splatting it would. */

typedef struct kf_cpic_static cstatic;

static int is_static(const kf_model *m, int r) {
    return m->rigid[r].def.motion == KF_RIGID_STATIC && m->rigid[r].nseed > 0;
}

static int32_t st_find(const cstatic *S, int bx, int by, int bz) {
    if (!S->hcap) return -1;
    uint64_t key = kf_block_key(bx, by, bz), h = key;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 33;
    for (size_t q = (size_t)h & (S->hcap - 1);; q = (q + 1) & (S->hcap - 1)) {
        if (S->hkey[q] == UINT64_MAX) return -1;
        if (S->hkey[q] == key) return S->hval[q];
    }
}

static int st_insert_key(cstatic *S, uint64_t key, int32_t v) {
    uint64_t h = key;
    h ^= h >> 33;
    h *= 0xff51afd7ed558ccdULL;
    h ^= h >> 33;
    size_t q = (size_t)h & (S->hcap - 1);
    while (S->hkey[q] != UINT64_MAX) q = (q + 1) & (S->hcap - 1);
    S->hkey[q] = key;
    S->hval[q] = v;
    return 0;
}

/* the store's block at (bx, by, bz), made if missing; -1: out of memory */
static int32_t st_ensure(cstatic *S, int bx, int by, int bz) {
    int32_t f = st_find(S, bx, by, bz);
    if (f >= 0) return f;
    if (2 * (S->n + 1) > S->hcap) {
        size_t cap = S->hcap ? 2 * S->hcap : 1024;
        uint64_t *ok = S->hkey;
        int32_t *ov = S->hval;
        size_t ocap = S->hcap;
        S->hkey = malloc(cap * sizeof *S->hkey);
        S->hval = malloc(cap * sizeof *S->hval);
        if (!S->hkey || !S->hval) {
            free(ok), free(ov);
            return -1;
        }
        memset(S->hkey, 0xff, cap * sizeof *S->hkey);
        S->hcap = cap;
        for (size_t q = 0; q < ocap; q++)
            if (ok[q] != UINT64_MAX) st_insert_key(S, ok[q], ov[q]);
        free(ok), free(ov);
    }
    if (S->n + 1 > S->cap) {
        size_t cap = S->cap ? 2 * S->cap : 256;
        if (grow((void **)&S->coord, 3 * sizeof(int32_t), cap) || grow((void **)&S->d, 64 * sizeof(float), cap) ||
            grow((void **)&S->best, 64 * sizeof(float), cap) || grow((void **)&S->c, 64 * sizeof(uint32_t), cap) ||
            grow((void **)&S->mark, 64 * sizeof(uint32_t), cap) || grow((void **)&S->stamp, sizeof(uint32_t), cap) ||
            grow((void **)&S->best_stamp, sizeof(uint32_t), cap))
            return -1;
        S->cap = cap;
    }
    int32_t b = (int32_t)S->n++;
    S->coord[3 * b] = bx, S->coord[3 * b + 1] = by, S->coord[3 * b + 2] = bz;
    S->stamp[b] = S->best_stamp[b] = 0;
    st_insert_key(S, kf_block_key(bx, by, bz), b);
    return b;
}

/* does the store hold what the static bodies look like now? */
static int st_current(const kf_model *m, const kf_state *s) {
    const cstatic *S = &s->cpic->st;
    if (!S->built) return 0;
    for (int r = 0; r < m->nrigid; r++) {
        if (!is_static(m, r)) {
            if (S->sig_seed[r]) return 0;
            continue;
        }
        const kf_rigid_state *st = &s->rigid[r];
        if (S->sig_seed[r] != m->rigid[r].seed || S->sig[r][12] != m->sim.dx) return 0;
        for (int k = 0; k < 9; k++)
            if (S->sig[r][k] != st->R[k]) return 0;
        for (int k = 0; k < 3; k++)
            if (S->sig[r][9 + k] != st->t[k]) return 0;
    }
    for (int r = m->nrigid; r < KF_MAX_RIGIDS; r++)
        if (S->sig_seed[r]) return 0;
    return 1;
}

typedef struct st_seed {
    int32_t round, bx, e;
} st_seed;

static int st_seed_cmp(const void *a, const void *b) {
    const st_seed *p = a, *q = b;
    if (p->round != q->round) return p->round < q->round ? -1 : 1;
    if (p->bx != q->bx) return p->bx < q->bx ? -1 : 1;
    return (p->e > q->e) - (p->e < q->e);
}

/* splat every static body into the store (see above); 0 or -1 */
static int st_build(const kf_model *m, kf_state *s) {
    kf_cpic *c = s->cpic;
    cstatic *S = &c->st;
    const double dx = m->sim.dx, inv_dx = 1 / dx;
    S->built = S->used = 0;
    /* from nothing: the splat's scratch (best, mark) was freed after the last build */
    free(S->coord), free(S->d), free(S->c), free(S->stamp), free(S->best_stamp), free(S->mark), free(S->best);
    S->coord = NULL, S->d = S->best = NULL, S->c = S->stamp = S->best_stamp = S->mark = NULL;
    S->n = S->cap = 0;
    if (S->hcap) memset(S->hkey, 0xff, S->hcap * sizeof *S->hkey);
    for (int a = 0; a < 3; a++) {
        S->lo[a] = kf_block_of((int)floor(m->sim.domain_min[a] * inv_dx)) - 3;
        S->hi[a] = kf_block_of((int)ceil(m->sim.domain_max[a] * inv_dx)) + 3;
    }
    memset(S->sig_seed, 0, sizeof S->sig_seed);
    uint32_t tri_base = 1;
    for (int r = 0; r < m->nrigid; tri_base += (uint32_t)m->rigid[r].ntri, r++) {
        if (!is_static(m, r)) continue;
        const kf_rigid_body *b = &m->rigid[r];
        const kf_rigid_state *st = &s->rigid[r];
        const double reach = b->def.thin ? 1.5 : 2.5;
        if (world_triangles_reserve(c, b, r)) return -1;
        st_seed *ord = malloc(sizeof *ord * (b->nseed ? b->nseed : 1));
        double *sx = malloc(3 * sizeof(double) * (b->nseed ? b->nseed : 1));
        if (!ord || !sx) {
            free(ord), free(sx);
            return -1;
        }
        /* the seeds whose box meets the region, in the grid splat's order,
         * their blocks made */
        size_t n = 0;
        for (size_t e = 0; e < b->nseed; e++) {
            if (b->tri_edge && b->tri_edge[b->seed_tri[e]]) continue;
            const float *o = &b->seed[3 * e];
            double *x = &sx[3 * e];
            int lo[3], hi[3], in = 1;
            seed_world(st, o, x);
            for (int a = 0; a < 3; a++) {
                lo[a] = kf_block_of((int)ceil(x[a] * inv_dx - reach));
                hi[a] = kf_block_of((int)floor(x[a] * inv_dx + reach));
                if (lo[a] < S->lo[a]) lo[a] = S->lo[a];
                if (hi[a] > S->hi[a]) hi[a] = S->hi[a];
                in &= lo[a] <= hi[a];
            }
            if (!in) continue;
            for (int p = lo[0]; p <= hi[0]; p++)
                for (int q = lo[1]; q <= hi[1]; q++)
                    for (int w = lo[2]; w <= hi[2]; w++)
                        if (st_ensure(S, p, q, w) < 0) {
                            free(ord), free(sx);
                            return -1;
                        }
            int bx = kf_block_of((int)ceil(x[0] * inv_dx - reach));
            ord[n++] = (st_seed){((bx % 3) + 3) % 3, bx, (int32_t)e};
            world_triangle(c, b, st, r, b->seed_tri[e]);
        }
        qsort(ord, n, sizeof *ord, st_seed_cmp);
        const cdf_layer L = {S->d, S->best, S->c, S->stamp, S->best_stamp, S->mark, 1, NULL, NULL};
        for (size_t k = 0; k < n; k++) {
            const double *x = &sx[3 * (size_t)ord[k].e];
            seed_box sb;
            seed_box_span(x, inv_dx, reach, &sb);
            for (int p = 0; p < sb.nbk[0]; p++)
                for (int q = 0; q < sb.nbk[1]; q++)
                    for (int w = 0; w < sb.nbk[2]; w++)
                        sb.blk[p][q][w] = st_find(S, sb.b0[0] + p, sb.b0[1] + q, sb.b0[2] + w);
            sb.live = box_live(NULL, NULL, &sb);
            int tri = b->seed_tri[ord[k].e];
            splat_box(&L, &c->tri[r][tri], tri_base + (uint32_t)tri, &sb, r, inv_dx, dx);
        }
        free(ord), free(sx);
        for (int k = 0; k < 9; k++) S->sig[r][k] = st->R[k];
        for (int k = 0; k < 3; k++) S->sig[r][9 + k] = st->t[k];
        S->sig[r][12] = dx;
        S->sig_seed[r] = b->seed;
    }
    /* what the substeps copy is the distances and colours: the rest was the splat's */
    free(S->best_stamp), free(S->mark), free(S->best);
    S->best_stamp = S->mark = NULL, S->best = NULL;
    S->built = 1;
    S->used = S->n > 0;
    return 0;
}

/* The static bodies' CDF of every grid block the store holds, into the
 * grid's CDF (this substep's epoch). Returns 1 if done, 0 if the static
 * bodies must be splatted as the others (a block outside the store's
 * region), -1 out of memory. */
static int st_apply(const kf_model *m, kf_state *s) {
    int any = 0;
    for (int r = 0; r < m->nrigid; r++) any |= is_static(m, r);
    if (!any) return 0;
    kf_cpic *c = s->cpic;
    if (!st_current(m, s) && st_build(m, s)) return -1;
    const cstatic *S = &c->st;
    const kf_grid *g = &s->g;
    for (size_t b = 0; b < g->nblocks; b++)
        for (int a = 0; a < 3; a++)
            if (g->bcoord[3 * b + a] < S->lo[a] || g->bcoord[3 * b + a] > S->hi[a]) return 0;
    if (!S->used) return 1;
    const uint32_t epoch = c->epoch;
    const size_t nb = g->nblocks;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) if (nb >= 4096)
    for (size_t b = 0; b < nb; b++) {
        const int32_t *bc = &g->bcoord[3 * b];
        int32_t k = st_find(S, bc[0], bc[1], bc[2]);
        if (k < 0) continue;
        c->stamp[b] = epoch;
        memcpy(&c->node_d[64 * b], &S->d[64 * (size_t)k], 64 * sizeof(float));
        memcpy(&c->node_c[64 * b], &S->c[64 * (size_t)k], 64 * sizeof(uint32_t));
        memset(&c->mark[64 * b], 0, 64 * sizeof(uint32_t));
    }
    return 1;
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
    /* across ranks: the one-rank grid's extent (each rank colours its own
     * blocks' nodes as one rank does either way: a seed's order at a node
     * is fixed by where the node is) */
    if (s->dist) kf_dist_extent(s, glo, ghi);
    /* the static bodies from their store, then every other body */
    int from_store = st_apply(m, s);
    if (from_store < 0 || bmap_fill(c, g)) return -1;
    /* every body static and copied from the store: the next substep's
     * splat over the same blocks gives the same CDF (early.c) */
    c->static_cdf = from_store == 1 && !s->dist;
    for (int r = 0; r < m->nrigid; r++) c->static_cdf &= is_static(m, r);
    /* the owners the splatted bodies' seeds may reach (mark_near) */
    if (g->nblocks > c->cap_near) {
        size_t cap = g->nblocks + g->nblocks / 2 + 16;
        if (grow((void **)&c->near_blk, 1, cap)) return -1;
        c->cap_near = cap;
    }
    /* worth it only where the particles far outnumber the short runs: a
     * run's marks (up to 64 block lookups, 8 times that seed by seed where
     * the run is wide, as on a turning blade) cost about what the scan of a
     * few hundred particles' positions does. The marks are conservative, so
     * with or without them the CDF is the same. 32 here cost sand_stir at
     * --scale 4 (81k particles, under 2,600 short runs of the stirrer) half its
     * "cdf" stage on an AMD Zen 3 (perf_results.md section 25); a preview's
     * knife of fine triangles has more runs than that either way. */
    size_t nsub = 0;
    for (int r = 0; r < m->nrigid; r++)
        if (!(from_store && is_static(m, r))) nsub += m->rigid[r].nseed / (KF_CPIC_RUN / 8) + 1;
    int all_near = 256 * nsub > s->p.n;
    if (!all_near) memset(c->near_blk, 0, g->nblocks);
    for (int r = 0; r < m->nrigid && !all_near; r++)
        if (!(from_store && is_static(m, r)) && m->rigid[r].nseed > 0) {
            if (run_spheres(c, &m->rigid[r], r)) return -1;
            all_near = mark_near(c, g, &m->rigid[r], &s->rigid[r], r, 1 / dx, m->sim.kernel == KF_KERNEL_CUBIC ? 4 : 3,
                                 c->near_blk);
        }
    /* without the marks, the owners no body's seeds can reach at all (the
     * box of all its seeds) still get no box (read_boxes) */
    if (all_near) all_near = near_bodies(m, s, c->near_blk);
    if (read_boxes(m, s, all_near ? NULL : c->near_blk)) return -1;
    uint32_t tri_base = 1; /* triangle ids for the splat's visit marks, unique across bodies */
    for (int r = 0; r < m->nrigid; r++) {
        if (!(from_store && is_static(m, r)) && splat_body(m, s, r, tri_base, glo, ghi)) {
            bmap_clear(c, g);
            return -1;
        }
        tri_base += (uint32_t)m->rigid[r].ntri;
    }
    bmap_clear(c, g);
    /* the narrow band: owners whose 2x2x2 neighbourhood holds a node with
     * affinity to a body. Elsewhere no particle can gain a colour, and the
     * band's transfers would do what the ordinary ones do (the colour lapses
     * below as it would there). aff[b]: some node of block b has affinity. */
    if (g->nblocks > c->cap_aff) {
        size_t cap = g->nblocks + g->nblocks / 2 + 16;
        if (grow((void **)&c->aff, 1, cap)) return -1;
        c->cap_aff = cap;
    }
    for (size_t b = 0; b < g->nblocks; b++) {
        uint32_t any = 0;
        if (c->stamp[b] == c->epoch)
            for (int k = 0; k < 64; k++) any |= c->node_c[64 * b + (size_t)k];
        c->aff[b] = (any & KF_CPIC_AFFINITY) != 0;
    }
    c->nslot = 0;
    c->band_particles = 0;
    for (size_t k = 0; k < g->nowner; k++) {
        int in = 0;
        for (int q = 0; q < 8 && !in; q++) in = c->aff[g->nb[k][q]];
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
    /* with no owner in the band the arrays may never have been allocated,
     * and memset of a null pointer is undefined even for 0 bytes */
    if (c->nslot) {
        memset(c->imp, 0, c->nslot * sizeof c->imp[0]);
        memset(c->guard_caught, 0, c->nslot * sizeof(long));
        memset(c->guard_depth, 0, c->nslot * sizeof(double));
    }
    /* particles outside the band touch no coloured node: their colour lapses
     * (§5.3.3), all but the scar (cpic.h: the side of the last blade); each
     * particle alone, so in parallel */
    kf_particles *p = &s->p;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) if (p->n >= 65536)
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
