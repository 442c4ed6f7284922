/* mg_build.c — the coarse levels of the multigrid preconditioner
 * (implicit.h): their nodes, masses, quadrature points and the trilinear
 * prolongation from each level to the next finer one.
 *
 * Built once per substep (particles do not move during the solve). Level
 * l >= 1 has spacing H = 2^l Δx and its nodes are found through a hash of
 * integer coordinates. Level 1 re-transfers the particles' masses with the
 * quadratic kernel at spacing H (so every parent of a fine node that
 * carries mass carries mass too: the parent is within 1.25 H of the
 * particle on each axis, inside the 1.5 H stencil); deeper levels restrict
 * the finer masses (Pᵀ m, the lumped Galerkin mass: same total, and a
 * re-transfer on every level cost 14% more CPU time per frame at 5x the
 * explicit step, where the levels are rebuilt most often). The particles
 * of one cell of the level become one quadrature point at their mass
 * centroid carrying the sum of their Hessian blocks. Where mass dominates
 * the operator, one point per cell of spacing H is enough (a coarse level
 * only has to be spectrally close, and its mass keeps it definite): on the
 * evidence cantilever at 20x the explicit step it took 1% fewer CG
 * iterations than eight and 25% less CPU time per frame. Where stiffness
 * dominates, one point per cell under-integrates: a body one or two coarse
 * cells thick bends with no strain at its only point, so the coarse level
 * is far too soft in bending and its correction overshoots (more coarse
 * sweeps made it worse). There each cell of spacing H/2 is a point, eight
 * per cell: at 1 to 4 steps per frame (E = 1e8 to 1e10, 350 to 3800x the
 * explicit step) that took 2-4x fewer CG iterations and 2.4x less time.
 * The switch is the ratio of the fine diagonal's stiffness to its mass,
 * FULL_QUADRATURE_RATIO. Everything
 * is serial and in particle order, so the levels are the same for any
 * thread count. */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "implicit.h"

/* coarsening stops once a level has at most this many nodes */
#define COARSEST_NODES 64
/* eight quadrature points per coarse cell once Σ (fine diagonal − mass) /
 * Σ mass over the nodes with mass exceeds this (the cantilever: one point
 * was cheaper at 34 (20x the explicit step) and 149 (50x), eight at 545
 * (100x) and beyond; 300 splits the measured break-even) */
#define FULL_QUADRATURE_RATIO 300

/* ---- integer coordinates → index ---------------------------------------------- */

typedef struct coord_hash {
    size_t cap, n; /* cap: power of two */
    uint64_t *key; /* UINT64_MAX = empty */
    int32_t *val;
} coord_hash;

static uint64_t pack(int32_t x, int32_t y, int32_t z) {
    const int64_t o = 1 << 20;
    return ((uint64_t)(x + o) << 42) | ((uint64_t)(y + o) << 21) | (uint64_t)(z + o);
}

static size_t slot_of(uint64_t k, size_t cap) {
    k ^= k >> 33;
    k *= 0xff51afd7ed558ccdULL;
    k ^= k >> 33;
    return (size_t)k & (cap - 1);
}

static int hash_init(coord_hash *h, size_t expect) {
    h->cap = 64;
    while (h->cap < 2 * expect) h->cap *= 2;
    h->n = 0;
    h->key = malloc(h->cap * sizeof *h->key);
    h->val = malloc(h->cap * sizeof *h->val);
    if (!h->key || !h->val) return -1;
    memset(h->key, 0xff, h->cap * sizeof *h->key);
    return 0;
}

static void hash_free(coord_hash *h) {
    free(h->key);
    free(h->val);
}

/* the index of k, inserting it as the next index when new; -1 out of memory */
static int32_t hash_insert(coord_hash *h, uint64_t k) {
    if (2 * (h->n + 1) > h->cap) {
        coord_hash g;
        g.cap = 2 * h->cap;
        g.n = h->n;
        g.key = malloc(g.cap * sizeof *g.key);
        g.val = malloc(g.cap * sizeof *g.val);
        if (!g.key || !g.val) {
            free(g.key), free(g.val);
            return -1;
        }
        memset(g.key, 0xff, g.cap * sizeof *g.key);
        for (size_t s = 0; s < h->cap; s++)
            if (h->key[s] != UINT64_MAX) {
                size_t t = slot_of(h->key[s], g.cap);
                while (g.key[t] != UINT64_MAX) t = (t + 1) & (g.cap - 1);
                g.key[t] = h->key[s], g.val[t] = h->val[s];
            }
        hash_free(h);
        *h = g;
    }
    size_t s = slot_of(k, h->cap);
    while (h->key[s] != UINT64_MAX && h->key[s] != k) s = (s + 1) & (h->cap - 1);
    if (h->key[s] == k) return h->val[s];
    h->key[s] = k;
    h->val[s] = (int32_t)h->n++;
    return h->val[s];
}

/* ---- growable per-node arrays ----------------------------------------------------- */

typedef struct node_list {
    size_t cap;
    int32_t *coord;
    double *mass;
} node_list;

static int nodes_reserve(node_list *l, size_t n) {
    if (n <= l->cap) return 0;
    size_t c = l->cap ? 2 * l->cap : 256;
    while (c < n) c *= 2;
    int32_t *co = realloc(l->coord, 3 * c * sizeof *co);
    if (co) l->coord = co;
    double *ma = realloc(l->mass, c * sizeof *ma);
    if (ma) l->mass = ma;
    if (!co || !ma) return -1;
    memset(l->mass + l->cap, 0, (c - l->cap) * sizeof *ma);
    l->cap = c;
    return 0;
}

/* the node at integer coordinate (x, y, z), added with zero mass when new */
static int32_t node_at(coord_hash *h, node_list *l, int32_t x, int32_t y, int32_t z) {
    int32_t k = hash_insert(h, pack(x, y, z));
    if (k < 0 || nodes_reserve(l, h->n)) return -1;
    l->coord[3 * k] = x, l->coord[3 * k + 1] = y, l->coord[3 * k + 2] = z;
    return k;
}

/* quadratic B-spline weights at spacing h: base node and w[3], fx = x/h − base */
static int32_t quad_weights(double x, double inv_h, double w[3], double *fx) {
    double u = x * inv_h;
    int32_t base = (int32_t)floor(u - 0.5);
    double f = u - base, p = 1.5 - f, q = f - 1, r = f - 0.5;
    w[0] = 0.5 * p * p, w[1] = 0.75 - q * q, w[2] = 0.5 * r * r;
    *fx = f;
    return base;
}

/* ---- one coarse level ------------------------------------------------------------- */

static void level_free(kf_mg_level *L) {
    void *all[] = {L->coord, L->mass, L->diag, L->q_of_p, L->qx, L->idx, L->gam,      L->K,
                   L->q_up,  L->par,  L->pw,   L->b,      L->x,  L->t,   L->con_node, L->con_P};
    for (size_t k = 0; k < sizeof all / sizeof *all; k++) free(all[k]);
    memset(L, 0, sizeof *L);
}

/* level L at spacing h below the finer level F: nodes, their masses (the
 * particles' at level 1, F's restricted below), the trilinear parents of
 * F's nodes that carry mass, and the quadrature points with their
 * stencils. Per axis an even finer coordinate sits on a
 * coarse node (weight 1), an odd one between two (½, ½). */
static int build_level(const kf_implicit *w, kf_mg_level *L, const kf_mg_level *F, double h, int full_quadrature) {
    const kf_particles *p = &w->s->p;
    const size_t np = w->np;
    const double inv_h = 1 / h, dinv = 4 / (h * h); /* MLS D⁻¹ of the quadratic kernel */
    coord_hash nodes, cells;
    node_list nl = {0};
    int bad = hash_init(&nodes, F->nn / 4 + 16) | hash_init(&cells, np / 8 + 16);
    L->h = h;
    L->q_of_p = malloc((np + 1) * sizeof *L->q_of_p);
    L->par = malloc((8 * F->nn + 1) * sizeof *L->par);
    L->pw = malloc((8 * F->nn + 1) * sizeof *L->pw);
    bad |= !L->q_of_p || !L->par || !L->pw;
    /* level 1: the particles' masses re-transferred at spacing h (the
     * re-discretisation itself; below it the finer masses restricted) */
    const int from_particles = F->h == w->m->sim.dx;
    /* the 27 nodes of a base node, cached (direct-mapped): the 64 or so
     * particles that share a base at spacing 2 Δx come in runs, and hashing
     * 27 coordinates per particle was most of the levels' building time */
    enum { STENCIL_CACHE = 256 };
    struct {
        uint64_t key;
        int32_t k[27];
    } *cache = from_particles ? malloc(STENCIL_CACHE * sizeof *cache) : NULL;
    if (from_particles && !cache) bad = 1;
    for (int e = 0; cache && e < STENCIL_CACHE; e++) cache[e].key = UINT64_MAX;
    for (size_t i = 0; i < np && from_particles && !bad; i++) {
        double wt[3][3], fx;
        int32_t base[3];
        for (int a = 0; a < 3; a++) base[a] = quad_weights(p->x[a][i], inv_h, wt[a], &fx);
        const uint64_t key = pack(base[0], base[1], base[2]);
        __typeof__(cache) ce = &cache[slot_of(key, STENCIL_CACHE)];
        if (ce->key != key) {
            int e = 0;
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++)
                    for (int c = 0; c < 3; c++, e++) {
                        ce->k[e] = node_at(&nodes, &nl, base[0] + a, base[1] + b, base[2] + c);
                        if (ce->k[e] < 0) bad = 1;
                    }
            ce->key = bad ? UINT64_MAX : key;
            if (bad) break;
        }
        int e = 0;
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                for (int c = 0; c < 3; c++, e++) nl.mass[ce->k[e]] += wt[0][a] * wt[1][b] * wt[2][c] * p->mass[i];
    }
    free(cache);
    /* the parents of the finer nodes, and the finer masses restricted */
    for (size_t j = 0; j < F->nn && !bad; j++) {
        int32_t *par = L->par + 8 * j;
        double *pw = L->pw + 8 * j;
        for (int k = 0; k < 8; k++) par[k] = -1, pw[k] = 0;
        if (!(F->mass[j] > 0)) continue;
        int32_t lo[3], n[3];
        for (int a = 0; a < 3; a++) lo[a] = F->coord[3 * j + a] >> 1, n[a] = (F->coord[3 * j + a] & 1) ? 2 : 1;
        const double wt = 1.0 / (n[0] * n[1] * n[2]);
        int e = 0;
        for (int a = 0; a < n[0]; a++)
            for (int b = 0; b < n[1]; b++)
                for (int c = 0; c < n[2]; c++) {
                    int32_t k = node_at(&nodes, &nl, lo[0] + a, lo[1] + b, lo[2] + c);
                    if (k < 0) bad = 1;
                    if (k < 0) continue;
                    par[e] = k;
                    pw[e++] = wt;
                    if (!from_particles) nl.mass[k] += wt * F->mass[j];
                }
    }
    /* each particle's quadrature cell: the level's cells, or their eighths */
    const double q_inv = full_quadrature ? 2 * inv_h : inv_h;
    double *qm = NULL, *qs = NULL;
    size_t qcap = 0;
    for (size_t i = 0; i < np && !bad; i++) {
        double x[3] = {p->x[0][i], p->x[1][i], p->x[2][i]};
        int32_t q = hash_insert(
            &cells, pack((int32_t)floor(x[0] * q_inv), (int32_t)floor(x[1] * q_inv), (int32_t)floor(x[2] * q_inv)));
        if (q < 0) {
            bad = 1;
            break;
        }
        if ((size_t)q >= qcap) {
            size_t c = qcap ? 2 * qcap : 256;
            double *a1 = realloc(qm, c * sizeof *qm), *a2 = a1 ? realloc(qs, 3 * c * sizeof *qs) : NULL;
            if (a1) qm = a1;
            if (a2) qs = a2;
            if (!a1 || !a2) {
                bad = 1;
                break;
            }
            memset(qm + qcap, 0, (c - qcap) * sizeof *qm);
            memset(qs + 3 * qcap, 0, 3 * (c - qcap) * sizeof *qs);
            qcap = c;
        }
        L->q_of_p[i] = q;
        qm[q] += p->mass[i];
        for (int a = 0; a < 3; a++) qs[3 * q + a] += p->mass[i] * x[a];
    }
    size_t nq = cells.n;
    L->nq = nq;
    L->qx = malloc((3 * nq + 1) * sizeof *L->qx);
    L->idx = malloc((27 * nq + 1) * sizeof *L->idx);
    L->gam = malloc((81 * nq + 1) * sizeof *L->gam);
    L->K = malloc((81 * nq + 1) * sizeof *L->K);
    bad |= !L->qx || !L->idx || !L->gam || !L->K;
    /* each point's stencil: γ = w D⁻¹ (x_i − x_q), the MLS form of Eq. 19
     * (a stencil node no finer node reaches joins with zero mass) */
    for (size_t q = 0; q < nq && !bad; q++) {
        double wt[3][3], d[3][3];
        int32_t base[3];
        for (int a = 0; a < 3; a++) {
            double fx;
            L->qx[3 * q + a] = qs[3 * q + a] / qm[q];
            base[a] = quad_weights(L->qx[3 * q + a], inv_h, wt[a], &fx);
            for (int k = 0; k < 3; k++) d[a][k] = (k - fx) * h;
        }
        int e = 0;
        for (int a = 0; a < 3 && !bad; a++)
            for (int b = 0; b < 3 && !bad; b++)
                for (int c = 0; c < 3; c++, e++) {
                    int32_t k = node_at(&nodes, &nl, base[0] + a, base[1] + b, base[2] + c);
                    if (k < 0) {
                        bad = 1;
                        break;
                    }
                    double wabc = wt[0][a] * wt[1][b] * wt[2][c] * dinv;
                    L->idx[27 * q + e] = k;
                    L->gam[81 * q + 3 * e] = wabc * d[0][a];
                    L->gam[81 * q + 3 * e + 1] = wabc * d[1][b];
                    L->gam[81 * q + 3 * e + 2] = wabc * d[2][c];
                }
    }
    L->nn = nodes.n;
    L->coord = nl.coord;
    L->mass = nl.mass;
    hash_free(&nodes);
    hash_free(&cells);
    free(qm);
    free(qs);
    if (bad) return -1;
    size_t n4 = KF_IMP_NV * L->nn + 1;
    double **vec[] = {&L->diag, &L->b, &L->x, &L->t};
    for (size_t k = 0; k < sizeof vec / sizeof *vec; k++) bad |= !(*vec[k] = calloc(n4, sizeof(double)));
    return bad ? -1 : 0;
}

/* the level's boundary projection from its children's: a coarse node fixes
 * the directions its children fix for at least half of their prolongation
 * weight (the eigenvectors of Σ w (I − P_child) / Σ w with eigenvalue ½ or
 * more), so a sticky wall stays a wall on every level instead of leaving a
 * coarse body free to float where the fine one is clamped */
static int build_constraints(kf_mg_level *L, size_t nfine, size_t fncon, const int32_t *fcon_node,
                             const double *fcon_P) {
    int32_t *con_of = malloc((nfine + 1) * sizeof *con_of);
    double *C = calloc(9 * L->nn + 1, sizeof *C), *ws = calloc(L->nn + 1, sizeof *ws);
    int bad = !con_of || !C || !ws;
    if (!bad) {
        for (size_t j = 0; j < nfine; j++) con_of[j] = -1;
        for (size_t k = 0; k < fncon; k++) con_of[fcon_node[k]] = (int32_t)k;
        for (size_t j = 0; j < nfine; j++)
            for (int e = 0; e < 8 && L->par[8 * j + e] >= 0; e++) {
                size_t I = (size_t)L->par[8 * j + e];
                double pw = L->pw[8 * j + e];
                ws[I] += pw;
                if (con_of[j] < 0) continue;
                const double *P = fcon_P + 9 * (size_t)con_of[j];
                for (int r = 0; r < 9; r++) C[9 * I + r] += pw * ((r % 4 == 0) - P[r]);
            }
        size_t cap = 0;
        for (size_t I = 0; I < L->nn && !bad; I++) {
            if (!(ws[I] > 0) || (C[9 * I] == 0 && C[9 * I + 4] == 0 && C[9 * I + 8] == 0)) continue;
            double A[9], ev[3], Q[9], P[9];
            for (int r = 0; r < 9; r++) A[r] = C[9 * I + r] / ws[I];
            kf_sym_eig3d(A, ev, Q);
            int nfix = 0;
            for (int r = 0; r < 9; r++) P[r] = r % 4 == 0;
            for (int k = 0; k < 3; k++)
                if (ev[k] >= 0.5) {
                    nfix++;
                    for (int a = 0; a < 3; a++)
                        for (int b = 0; b < 3; b++) P[3 * a + b] -= Q[3 * a + k] * Q[3 * b + k];
                }
            if (!nfix) continue;
            if (nfix == 3)
                for (int r = 0; r < 9; r++) P[r] = 0;
            if (L->ncon == cap) {
                cap = cap ? 2 * cap : 64;
                int32_t *cn = realloc(L->con_node, cap * sizeof *cn);
                if (cn) L->con_node = cn;
                double *cp = realloc(L->con_P, 9 * cap * sizeof *cp);
                if (cp) L->con_P = cp;
                if (!cn || !cp) {
                    bad = 1;
                    break;
                }
            }
            L->con_node[L->ncon] = (int32_t)I;
            memcpy(L->con_P + 9 * L->ncon, P, sizeof P);
            L->ncon++;
        }
    }
    free(con_of);
    free(C);
    free(ws);
    return bad ? -1 : 0;
}

/* ---- the hierarchy ------------------------------------------------------------------ */

void kf_imp_mg_free(kf_imp_mg *mg) {
    if (!mg) return;
    for (int l = 1; l < mg->nlev; l++) level_free(&mg->lev[l]);
    free(mg->lev[0].coord); /* level 0's mass and diagonal are the solve's */
    free(mg);
}

int kf_imp_mg_create(kf_implicit *w) {
    kf_imp_mg *mg = calloc(1, sizeof *mg);
    if (!mg) return -1;
    w->mg = mg;
    const kf_grid *g = &w->s->g;
    kf_mg_level *L0 = &mg->lev[0];
    L0->h = w->m->sim.dx;
    L0->nn = w->nnode;
    L0->mass = w->mass;
    L0->diag = w->diag;
    L0->coord = malloc((3 * w->nnode + 1) * sizeof *L0->coord);
    mg->nlev = 1;
    if (!L0->coord) return -1;
    /* the solve's nodes: block coordinate × 4 + the node's place in its block */
    for (size_t i = 0; i < w->nnode; i++) {
        size_t b = i / KF_BLOCK_NODES, l = i % KF_BLOCK_NODES;
        L0->coord[3 * i] = g->bcoord[3 * b] * KF_BLOCK + (int32_t)(l >> 4);
        L0->coord[3 * i + 1] = g->bcoord[3 * b + 1] * KF_BLOCK + (int32_t)((l >> 2) & 3);
        L0->coord[3 * i + 2] = g->bcoord[3 * b + 2] * KF_BLOCK + (int32_t)(l & 3);
    }
    size_t prev = 0;
    for (size_t i = 0; i < w->nnode; i++) prev += w->mass[i] > 0;
    /* how much stiffness outweighs mass on the fine diagonal (built before the levels) */
    double sum_m = 0, sum_k = 0;
    for (size_t k = 0; k < w->nact; k++) {
        const size_t i = (size_t)w->act[k];
        for (int a = 0; a < 3; a++) sum_m += w->mass[i], sum_k += w->diag[KF_IMP_NV * i + a] - w->mass[i];
    }
    mg->full_quadrature = sum_k > FULL_QUADRATURE_RATIO * sum_m;
    /* coarsen while the level is big enough to be worth it and still shrinks */
    while (mg->nlev < KF_MG_MAX_LEVELS && prev > COARSEST_NODES) {
        kf_mg_level *L = &mg->lev[mg->nlev], *F = &mg->lev[mg->nlev - 1];
        mg->nlev++;
        if (build_level(w, L, F, 2 * F->h, mg->full_quadrature)) return -1;
        if (build_constraints(L, F->nn, F == L0 ? w->ncon : F->ncon, F == L0 ? w->con_node : F->con_node,
                              F == L0 ? w->con_P : F->con_P))
            return -1;
        if (L->nn * 2 > prev * 3 / 2) break; /* no longer coarsening (a flat or thin body) */
        prev = L->nn;
    }
    /* the cells of spacing 2h nest those of h, so a coarse point's blocks
     * are its children's sums (kf_imp_mg_refresh): each point's parent,
     * checked on every particle (a position on a cell face can round into
     * different cells on the two levels; then that level sums particles) */
    for (int l = 1; l + 1 < mg->nlev; l++) {
        kf_mg_level *L = &mg->lev[l], *C = &mg->lev[l + 1];
        L->q_up = malloc((L->nq + 1) * sizeof *L->q_up);
        if (!L->q_up) return -1;
        for (size_t q = 0; q < L->nq; q++) L->q_up[q] = -1;
        int nested = 1;
        for (size_t i = 0; i < w->np && nested; i++) {
            int32_t *u = &L->q_up[L->q_of_p[i]];
            if (*u < 0) *u = C->q_of_p[i];
            nested = *u == C->q_of_p[i];
        }
        if (!nested) {
            free(L->q_up);
            L->q_up = NULL;
        }
    }
    return 0;
}

int kf_imp_mg_levels(const kf_implicit *w) { return w->mg ? w->mg->nlev : 1; }

size_t kf_imp_mg_nodes(const kf_implicit *w, int level) {
    if (!w->mg || level >= w->mg->nlev) return 0;
    if (level == 0) return w->nnode;
    return w->mg->lev[level].nn;
}
