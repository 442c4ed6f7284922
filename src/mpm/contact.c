/* contact.c — contact between objects: which owners take the field path,
 * and the grid rule (contact.h says why and how). The field scatter and
 * gather are in contact_transfer.c. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "collider.h"
#include "contact.h"
#include "../dist/dist.h"

void kf_contact_free(kf_contact *c) {
    if (!c) return;
    free(c->mv);
    free(c->vol);
    free(c->fid);
    free(c->blk);
    free(c->ncontrib);
    free(c->contrib);
    free(c->own);
    free(c->ofield);
    free(c->obox);
    free(c->pc_node);
    free(c->pc_parent);
    free(c->pc_list);
    free(c->pc_start);
    free(c->pc_nrep);
    free(c->pc_keep);
    free(c->pc_used);
    free(c->pc_cls);
    free(c->pc_rep);
    free(c->pc_cnt);
    free(c->pc_occ);
    free(c->pc_seen);
    free(c->pc_next);
    free(c);
}

static int grow(void **p, size_t n, size_t size) {
    void *q = realloc(*p, n * size);
    if (!q) return -1;
    *p = q;
    return 0;
}

/* room for the grid's blocks and owners */
static int reserve(kf_contact *c, size_t nblocks, size_t nowner) {
    if (nblocks > c->cap_blocks || !c->blk) {
        size_t n = nblocks + nblocks / 4 + 16;
        if (grow((void **)&c->mv, n * KF_BLOCK_NODES * 2, sizeof(kf_v4)) ||
            grow((void **)&c->vol, n * KF_BLOCK_NODES * 2, sizeof(kf_v4)) ||
            grow((void **)&c->fid, n * KF_BLOCK_NODES * 2, sizeof(uint16_t)) || grow((void **)&c->blk, n, 1) ||
            grow((void **)&c->ncontrib, n, 1) || grow((void **)&c->contrib, n, sizeof *c->contrib))
            return -1;
        c->cap_blocks = n;
    }
    if (nowner > c->cap_owner || !c->own) {
        size_t n = nowner + nowner / 4 + 16;
        if (grow((void **)&c->own, n, 1) || grow((void **)&c->ofield, n, sizeof(uint16_t)) ||
            grow((void **)&c->obox, n, sizeof *c->obox))
            return -1;
        c->cap_owner = n;
    }
    return 0;
}

/* ---- across ranks ------------------------------------------------------------
 * Which fields reach a node, and so the slots, depend on every owner that
 * scatters into it, some of them another rank's (dist.h). Two exchanges
 * with the ranks that share an owner's nodes make each rank's slots the
 * one-rank slots at every node its own owners touch: first each boundary
 * owner's field and box (the candidate test below needs its neighbours'),
 * then each candidate's claims, the first two fields its particles reach
 * at each node of its box in particle order (the claim rule keeps the first
 * two distinct fields a node sees, so a third of one owner never counts),
 * applied in the owner's colour turn. */

typedef struct {
    uint16_t field, pad;
    int32_t box[6];
} owner_head;

typedef struct {
    const kf_model *m;
    const kf_state *s;
    const kf_contact *c;
} put_ctx;

static size_t put_head(void *ctx, size_t k, void *dst) {
    const put_ctx *x = ctx;
    if (dst) {
        owner_head h = {x->c->ofield[k], 0, {0}};
        memcpy(h.box, x->c->obox[k], sizeof h.box);
        memcpy(dst, &h, sizeof h);
    }
    return sizeof(owner_head);
}

/* a claim payload: the box in neighbourhood nodes (lo, hi inclusive), then
 * two fields per node of it */
static size_t claims_bytes(const int32_t *lo, const int32_t *hi) {
    return 6 * sizeof(int32_t) +
           2 * sizeof(uint16_t) * (size_t)((hi[0] - lo[0] + 1) * (hi[1] - lo[1] + 1) * (hi[2] - lo[2] + 1));
}

static size_t put_claims(void *ctx, size_t k, void *dst) {
    const put_ctx *x = ctx;
    const kf_contact *c = x->c;
    if (!c->own[k]) return 0;
    const kf_grid *g = &x->s->g;
    const kf_particles *p = &x->s->p;
    const int32_t *bc = &g->bcoord[3 * k];
    int32_t lohi[6];
    for (int a = 0; a < 3; a++)
        lohi[a] = c->obox[k][a] - KF_BLOCK * bc[a], lohi[3 + a] = c->obox[k][3 + a] - KF_BLOCK * bc[a];
    if (!dst) return claims_bytes(lohi, lohi + 3);
    const int ex[3] = {lohi[3] - lohi[0] + 1, lohi[4] - lohi[1] + 1, lohi[5] - lohi[2] + 1};
    memcpy(dst, lohi, sizeof lohi);
    uint16_t *id = (uint16_t *)((char *)dst + sizeof lohi);
    memset(id, 0xFF, 2 * sizeof(uint16_t) * (size_t)(ex[0] * ex[1] * ex[2]));
    const kf_real inv_dx = kf_model_inv_dx(x->m);
    const int cubic = x->m->sim.kernel == KF_KERNEL_CUBIC, kw = cubic ? 4 : 3;
    for (size_t i = g->pstart[k]; i < g->pstart[k + 1]; i++) {
        const uint16_t f = kf_contact_field(p, i);
        int l[3];
        for (int a = 0; a < 3; a++) l[a] = kf_base_node(p->x[a][i], inv_dx, cubic) - KF_BLOCK * bc[a] - lohi[a];
        for (int a = 0; a < kw; a++)
            for (int b = 0; b < kw; b++)
                for (int e = 0; e < kw; e++) {
                    uint16_t *q = &id[2 * (size_t)(((l[0] + a) * ex[1] + l[1] + b) * ex[2] + l[2] + e)];
                    if (q[0] == f || q[1] == f) continue;
                    if (q[0] == KF_FIELD_NONE) q[0] = f;
                    else if (q[1] == KF_FIELD_NONE) q[1] = f;
                }
    }
    return claims_bytes(lohi, lohi + 3);
}

/* another rank's owner's claims into the slots' fields */
static void apply_claims(kf_contact *c, const kf_dist_owner_msg *msg) {
    int32_t lohi[6];
    memcpy(lohi, msg->data, sizeof lohi);
    const uint16_t *id = (const uint16_t *)((const char *)msg->data + sizeof lohi);
    for (int a = lohi[0]; a <= lohi[3]; a++)
        for (int b = lohi[1]; b <= lohi[4]; b++)
            for (int e = lohi[2]; e <= lohi[5]; e++, id += 2) {
                int blk = msg->nb[(a >> 2) << 2 | (b >> 2) << 1 | (e >> 2)];
                uint16_t *q =
                    &c->fid[2 * ((size_t)blk * KF_BLOCK_NODES + (size_t)((a & 3) << 4 | (b & 3) << 2 | (e & 3)))];
                for (int u = 0; u < 2 && id[u] != KF_FIELD_NONE; u++) {
                    const uint16_t f = id[u];
                    if (q[0] == f || q[1] == f) continue;
                    if (q[0] == KF_FIELD_NONE) q[0] = f;
                    else if (q[1] == KF_FIELD_NONE) q[1] = f;
                }
            }
}

static int colour_of(const int32_t *c) { return (c[0] & 1) << 2 | (c[1] & 1) << 1 | (c[2] & 1); }

/* two owners' candidate test: they scatter into a common block, are not of
 * one field, and their boxes overlap */
static int meet(uint16_t f1, const int32_t *box1, uint16_t f2, const int32_t *box2) {
    if (f1 == f2 && f1 != KF_FIELD_MANY) return 0;
    int overlap = 1;
    for (int a = 0; a < 3; a++) overlap &= box1[a] <= box2[3 + a] && box2[a] <= box1[3 + a];
    return overlap;
}

/* Scenes below this many particles scan their field ids on one thread */
#define KF_CONTACT_SERIAL_PARTICLES (1 << 17)

int kf_contact_prepare(const kf_model *m, kf_state *s) {
    if (!m->sim.contact || m->sim.integrator != KF_INTEGRATOR_EXPLICIT) {
        if (s->contact) s->contact->active = 0;
        return 0;
    }
    if (!s->contact && !(s->contact = calloc(1, sizeof(kf_contact)))) return -1;
    kf_contact *c = s->contact;
    const kf_grid *g = &s->g;
    const kf_particles *p = &s->p;
    c->active = 0;
    c->owners = c->two_field_nodes = c->touching_nodes = 0;
    /* across ranks every rank takes each collective step below, particles or not */
    const int dist = s->dist != NULL;
    if (!dist && (!g->nowner || !p->n)) return 0;
    if (reserve(c, g->nblocks, g->nowner)) return -1;
    /* pieces a thin body cut apart: fields of their own from now on */
    int thin = 0, solid = 0;
    for (int r = 0; r < m->nrigid; r++) thin |= m->rigid[r].def.thin != 0;
    for (int k = 0; k < m->nmat; k++) solid |= kf_contact_cuts(&m->mat[k]);
    if (thin && solid && kf_contact_pieces(m, s)) return -1;
    const size_t nowner = g->nowner, nblocks = g->nblocks;
    const kf_real inv_dx = kf_model_inv_dx(m);
    const int cubic = m->sim.kernel == KF_KERNEL_CUBIC, kw = cubic ? 4 : 3;

    /* each owner's field (KF_FIELD_MANY: two or more of its own); one field
     * in all of them (one object, nothing cut): nothing to do. A preview
     * scene's scan (some 30 k particles, one id each) takes less than a
     * hand-off to the other threads and back: on this thread */
    int uniform = 1;
    const int scan_threads = p->n < KF_CONTACT_SERIAL_PARTICLES ? 1 : m->nthreads;
#pragma omp parallel for schedule(static) num_threads(scan_threads) reduction(& : uniform)
    for (size_t k = 0; k < nowner; k++) {
        uint16_t f0 = kf_contact_field(p, g->pstart[k]), f = f0;
        for (size_t i = g->pstart[k]; i < g->pstart[k + 1]; i++)
            if (kf_contact_field(p, i) != f0) f = KF_FIELD_MANY;
        c->ofield[k] = f;
        uniform &= f == kf_contact_field(p, g->pstart[0]);
    }
    if (dist) {
        /* one field in all the ranks' particles: the largest and the
         * smallest of the ranks' own fields agree (a rank without particles
         * has no say) */
        const int any = nowner > 0;
        const double mine = !any ? -1 : uniform ? (double)kf_contact_field(p, g->pstart[0]) : (double)KF_FIELD_MANY;
        const double hi = kf_dist_max(s, mine), lo = -kf_dist_max(s, any ? -mine : -1e9);
        uniform = hi < 0 || (hi == lo && hi != (double)KF_FIELD_MANY);
    }
    if (uniform) return 0;
        /* the box of nodes each owner's particles' stencils cover */
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t k = 0; k < nowner; k++) {
        const uint16_t f = c->ofield[k];
        int32_t lo[3] = {INT32_MAX, INT32_MAX, INT32_MAX}, hi[3] = {INT32_MIN, INT32_MIN, INT32_MIN};
        for (size_t i = g->pstart[k]; i < g->pstart[k + 1]; i++) {
            for (int a = 0; a < 3; a++) {
                int32_t base = kf_base_node(p->x[a][i], inv_dx, cubic);
                lo[a] = base < lo[a] ? base : lo[a];
                hi[a] = base > hi[a] ? base : hi[a];
            }
        }
        for (int a = 0; a < 3; a++) c->obox[k][a] = lo[a], c->obox[k][3 + a] = hi[a] + kw - 1;
        c->own[k] = f == KF_FIELD_MANY;
    }
    /* fields may meet at a node only where the boxes of owners of two fields
     * overlap; owners that scatter into a common block are the candidates
     * (at most 8 per block) */
    memset(c->ncontrib, 0, nblocks);
    for (size_t k = 0; k < nowner; k++)
        for (int e = 0; e < 8; e++) {
            int32_t b = g->nb[k][e];
            c->contrib[b][c->ncontrib[b]++] = (int32_t)k;
        }
    for (size_t b = 0; b < nblocks; b++)
        for (int u = 0; u < c->ncontrib[b]; u++)
            for (int v = u + 1; v < c->ncontrib[b]; v++) {
                int32_t k1 = c->contrib[b][u], k2 = c->contrib[b][v];
                if (meet(c->ofield[k1], c->obox[k1], c->ofield[k2], c->obox[k2])) c->own[k1] = c->own[k2] = 1;
            }
    /* across ranks: other ranks' owners that scatter into a block with
     * ours (within one block along each axis) are candidates' partners too;
     * then the candidates' claims travel */
    kf_dist_owner_msg *claims = NULL;
    size_t nclaims = 0;
    if (dist) {
        put_ctx x = {m, s, c};
        kf_dist_owner_msg *head = NULL;
        size_t nhead = 0;
        if (kf_dist_owner_exchange(m, s, put_head, sizeof(owner_head), &x, &head, &nhead)) kf_dist_abort(1);
        for (size_t h = 0; h < nhead; h++) {
            owner_head oh;
            memcpy(&oh, head[h].data, sizeof oh);
            for (int d = 0; d < 27; d++) {
                int32_t k = kf_grid_find(g, head[h].bc[0] + d / 9 - 1, head[h].bc[1] + d / 3 % 3 - 1,
                                         head[h].bc[2] + d % 3 - 1);
                if (k < 0 || (size_t)k >= nowner) continue; /* an owner is the block of the same index */
                if (meet(c->ofield[k], c->obox[k], oh.field, oh.box)) c->own[k] = 1;
            }
        }
        size_t most = claims_bytes((const int32_t[3]){0, 0, 0},
                                   (const int32_t[3]){KF_CACHE_EDGE - 1, KF_CACHE_EDGE - 1, KF_CACHE_EDGE - 1});
        if (kf_dist_owner_exchange(m, s, put_claims, most, &x, &claims, &nclaims)) kf_dist_abort(1);
        /* the exchanges may have made blocks */
        if (reserve(c, g->nblocks, nowner)) kf_dist_abort(1);
    }
    const size_t nblocks_all = g->nblocks;
    memset(c->blk, 0, nblocks_all);
    long owners = 0;
    for (size_t k = 0; k < nowner; k++) {
        if (!c->own[k]) continue;
        owners++;
        for (int e = 0; e < 8; e++) c->blk[g->nb[k][e]] = 1;
    }
    for (size_t h = 0; h < nclaims; h++)
        for (int e = 0; e < 8; e++) c->blk[claims[h].nb[e]] = 1;
    c->nblocks = nblocks_all;
    if (!owners) return 0;
        /* the slots of every block a candidate owner scatters into, emptied */
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t b = 0; b < nblocks_all; b++) {
        if (!c->blk[b]) continue;
        size_t n0 = b * KF_BLOCK_NODES * 2;
        memset(&c->mv[n0], 0, sizeof(kf_v4) * KF_BLOCK_NODES * 2);
        memset(&c->vol[n0], 0, sizeof(kf_v4) * KF_BLOCK_NODES * 2);
        memset(&c->fid[n0], 0xFF, sizeof(uint16_t) * KF_BLOCK_NODES * 2);
    }
    /* which fields reach each node: every candidate particle claims a slot at
     * its stencil's nodes (CPIC's separation aside, so that every node two
     * fields may share is found); the transfers then spend their field work
     * only where a node has two. Colour by colour, as P2G: race-free, and the
     * same claims for any thread count. */
#pragma omp parallel num_threads(m->nthreads)
    for (int col = 0; col < 8; col++) {
#pragma omp for schedule(dynamic, 4)
        for (size_t o = g->colour_start[col]; o < g->colour_start[col + 1]; o++) {
            size_t k = (size_t)g->owner[o];
            if (!c->own[k]) continue;
            const int32_t *bc = &g->bcoord[3 * k], *nb = g->nb[k];
            for (size_t i = g->pstart[k]; i < g->pstart[k + 1]; i++) {
                const uint16_t f = kf_contact_field(p, i);
                int l[3];
                for (int a = 0; a < 3; a++) l[a] = kf_base_node(p->x[a][i], inv_dx, cubic) - KF_BLOCK * bc[a];
                for (int a = 0; a < kw; a++)
                    for (int b = 0; b < kw; b++)
                        for (int e = 0; e < kw; e++) {
                            int x = l[0] + a, y = l[1] + b, z = l[2] + e;
                            int blk = nb[(x >> 2) << 2 | (y >> 2) << 1 | (z >> 2)];
                            uint16_t *id = &c->fid[2 * ((size_t)blk * KF_BLOCK_NODES +
                                                        (size_t)((x & 3) << 4 | (y & 3) << 2 | (z & 3)))];
                            if (id[0] == f || id[1] == f) continue;
                            if (id[0] == KF_FIELD_NONE) id[0] = f;
                            else if (id[1] == KF_FIELD_NONE) id[1] = f;
                        }
            }
        }
        /* other ranks' owners of this colour, in the same turn */
#pragma omp for schedule(dynamic, 4)
        for (size_t h = 0; h < nclaims; h++)
            if (colour_of(claims[h].bc) == col) apply_claims(c, &claims[h]);
    }
    /* only owners that scatter into a block with a node of two fields take
     * the field path (the others' particles reach no such node) */
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t b = 0; b < nblocks_all; b++) {
        uint8_t two = 0;
        if (c->blk[b])
            for (int l = 0; l < KF_BLOCK_NODES; l++)
                two |= c->fid[2 * (b * KF_BLOCK_NODES + (size_t)l) + 1] != KF_FIELD_NONE;
        c->blk[b] = two;
    }
    owners = 0;
    for (size_t k = 0; k < nowner; k++) {
        uint8_t two = 0;
        for (int e = 0; e < 8; e++) two |= c->blk[g->nb[k][e]];
        c->own[k] = c->own[k] && two;
        owners += c->own[k];
    }
    c->owners = owners;
    c->active = owners > 0;
    return 0;
}

/* ---- where surfaces are ---------------------------------------------------------
 * The integral of the B-spline from -infinity to x (cells): the fraction of
 * a kernel centred at a node that lies below a flat surface x cells above
 * it. */
static double kernel_cdf(double x, int kw) {
    if (kw == 3) {
        if (x <= -1.5) return 0;
        if (x >= 1.5) return 1;
        if (x < -0.5) return (1.5 + x) * (1.5 + x) * (1.5 + x) / 6;
        if (x <= 0.5) return 1.0 / 6 + 0.75 * (x + 0.5) - (x * x * x + 0.125) / 3;
        return 1 - (1.5 - x) * (1.5 - x) * (1.5 - x) / 6;
    }
    if (x <= -2) return 0;
    if (x >= 2) return 1;
    double a = x < 0 ? x : -x, k; /* the lower half, then by symmetry */
    if (a < -1) k = (2 + a) * (2 + a) * (2 + a) * (2 + a) / 24;
    else k = 1.0 / 24 + 2.0 / 3 * (a + 1) - (a * a * a + 1) / 3 - (a * a * a * a - 1) / 8;
    return x < 0 ? k : 1 - k;
}

double kf_contact_fill_distance(double fill, int kw) {
    /* material fills the kernel up to the surface: fill = cdf(-s), s the
     * node's distance outside; bisection (the cdf is monotone) */
    double half = kw == 3 ? 1.5 : 2.0;
    if (fill >= 1) return -half;
    if (fill <= 0) return half;
    double lo = -half, hi = half; /* in s */
    for (int it = 0; it < 40; it++) {
        double mid = 0.5 * (lo + hi);
        if (kernel_cdf(-mid, kw) > fill) lo = mid;
        else hi = mid;
    }
    return 0.5 * (lo + hi);
}

/* ---- the grid rule ----------------------------------------------------------- */

/* two fields at a node: their velocities after gravity, in contact where the
 * gap between their surfaces has closed and they approach (Eq. 25's separate
 * rule on the relative velocity, with friction mu); the change is shared so
 * that the node's momentum stays */
static int node_rule(kf_v4 *mv, const kf_v4 *vol, const double gdt[3], double cell, int kw, double mu, double v[2][3]) {
    double m0 = mv[0][3], m1 = mv[1][3];
    for (int f = 0; f < 2; f++)
        for (int a = 0; a < 3; a++) v[f][a] = (double)mv[f][a] / (double)mv[f][3] + gdt[a];
    double n[3], n2 = 0;
    for (int a = 0; a < 3; a++) n[a] = (double)vol[1][a] - (double)vol[0][a], n2 += n[a] * n[a];
    if (!(n2 > 0)) return 0;
    double gap =
        kf_contact_fill_distance((double)vol[0][3] / cell, kw) + kf_contact_fill_distance((double)vol[1][3] / cell, kw);
    if (gap > 0) return 0;
    double inv = 1 / sqrt(n2), out[3], w[3], w0[3];
    /* field 1's outward normal points toward field 0: -n */
    for (int a = 0; a < 3; a++) out[a] = -n[a] * inv, w[a] = w0[a] = v[0][a] - v[1][a];
    kf_project_velocity(w, out, KF_BOUNDARY_SEPARATE, mu);
    double M = m0 + m1;
    for (int a = 0; a < 3; a++) {
        double dw = w[a] - w0[a];
        v[0][a] += m1 / M * dw;
        v[1][a] -= m0 / M * dw;
    }
    return 1;
}

void kf_contact_grid(const kf_model *m, kf_state *s, kf_real dt) {
    kf_contact *c = s->contact;
    if (!c || !c->active) return;
    const kf_grid *g = &s->g;
    const double dx = m->sim.dx, t1 = s->time + dt, cell = dx * dx * dx, mu = m->sim.contact_friction;
    const int kw = m->sim.kernel == KF_KERNEL_CUBIC ? 4 : 3;
    const double gdt[3] = {(double)(kf_real)(dt * m->sim.gravity[0]), (double)(kf_real)(dt * m->sim.gravity[1]),
                           (double)(kf_real)(dt * m->sim.gravity[2])};
    kf_collider_frame frame[KF_MAX_COLLIDERS];
    for (int k = 0; k < m->ncol; k++) kf_collider_frame_at(&m->col[k], t1, &frame[k]);
    long two = 0, touching = 0;
    const size_t nb = c->nblocks; /* the blocks prepared (the halo makes no others) */
#pragma omp parallel for schedule(dynamic, 16) num_threads(m->nthreads) reduction(+ : two, touching)
    for (size_t b = 0; b < nb; b++) {
        if (!c->blk[b]) continue;
        const int32_t *bc = &g->bcoord[3 * b];
        int near[KF_MAX_COLLIDERS], nnear = kf_colliders_near_block(frame, m->ncol, bc, dx, near);
        for (int l = 0; l < KF_BLOCK_NODES; l++) {
            size_t q = b * KF_BLOCK_NODES + (size_t)l;
            kf_v4 *mv = &c->mv[2 * q];
            const uint16_t *id = &c->fid[2 * q];
            if (id[1] == KF_FIELD_NONE) continue; /* one field: the total is its velocity */
            if (!(mv[0][3] > 0 && mv[1][3] > 0)) {
                /* a slot with no weight (a particle on its kernel's edge): the total */
                mv[0] = mv[1] = g->node[q];
                continue;
            }
            two++;
            double v[2][3];
            touching += node_rule(mv, &c->vol[2 * q], gdt, cell, kw, mu, v);
            double x[3] = {(bc[0] * KF_BLOCK + (l >> 4)) * dx, (bc[1] * KF_BLOCK + ((l >> 2) & 3)) * dx,
                           (bc[2] * KF_BLOCK + (l & 3)) * dx};
            for (int f = 0; f < 2; f++) {
                if (m->sim.walls || nnear) kf_grid_node_boundaries(m, frame, near, nnear, x, v[f]);
                mv[f] = (kf_v4){(kf_real)v[f][0], (kf_real)v[f][1], (kf_real)v[f][2], mv[f][3]};
            }
        }
    }
    c->two_field_nodes = two;
    c->touching_nodes = touching;
}
