/* contact_pieces.c — pieces a thin body cut from an object become fields of
 * their own (contact.h), so that once the blade has gone they touch and part
 * as two objects do instead of welding again through the nodes they share.
 *
 * A piece is a connected part of one field: each substep the particles are
 * linked to the others of their field at their nearest grid node and the
 * next node along +x, +y and +z, unless a thin body separates them (their
 * CPIC colours disagree on a side: kf_cpic_compatible). A field that falls
 * apart this way keeps its number on its largest part; every other part gets
 * a new piece number. A blade that cuts through and stays between the halves
 * separates them at once; one that only nicks an object leaves it connected
 * around the cut (material beyond the blade's edge, more than about two
 * cells, links both sides), so it stays one field. Pieces never merge again.
 *
 * Only solids come apart in pieces: sand and water that a paddle parted
 * flow together again as one (kf_contact_cuts).
 *
 * The piece number lives in the 4 bits of the particle's object index above
 * the object (kf_particles.obj: KF_OBJECT_MASK is the object): checkpointed
 * and re-sorted with the particle, 16 pieces per object (a 17th part joins
 * piece 15). The field of a particle is the whole word. */
#include <stdlib.h>
#include <string.h>

#include "contact.h"
#include "../cpic/cpic.h"
#include "../dist/dist.h"

#define PIECE_SHIFT 12
/* the fewest particles a part needs to become a piece: four cells at 8 per cell */
#define KF_PIECE_MIN 32

static inline int compatible(uint32_t a, uint32_t b) {
    uint32_t shared = (a & b & 0xAAAAAAAu) >> 1;
    return ((a ^ b) & shared) == 0;
}

static uint32_t find(uint32_t *parent, uint32_t i) {
    while (parent[i] != i) {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    return i;
}

static int reserve(void **p, size_t *cap, size_t n, size_t size) {
    if (n <= *cap) return 0;
    size_t c = n + n / 4 + 64;
    void *q = realloc(*p, c * size);
    if (!q) return -1;
    *p = q;
    *cap = c;
    return 0;
}

/* A block's 64 nodes as one mask (bit x << 4 | y << 2 | z) and its faces:
 * X0 the nodes at x = 0 .. Z3 those at z = 3. */
#define PC_X0 0xFFFFull
#define PC_X3 (PC_X0 << 48)
#define PC_Y0 0x000F000F000F000Full
#define PC_Y3 (PC_Y0 << 12)
#define PC_Z0 0x1111111111111111ull
#define PC_Z3 (PC_Z0 << 3)

/* the nodes of mask r and those next to them along an axis, within the block */
static inline uint64_t pc_grow(uint64_t r) {
    return r | ((r & ~PC_X3) << 16) | ((r & ~PC_X0) >> 16) | ((r & ~PC_Y3) << 4) | ((r & ~PC_Y0) >> 4) |
           ((r & ~PC_Z3) << 1) | ((r & ~PC_Z0) >> 1);
}

/* the nodes of block b next to a node of mask m (per block) in a face neighbour */
static inline uint64_t pc_from_faces(const uint64_t *m, const int32_t *x) {
    uint64_t r = 0;
    if (x[0] >= 0) r |= (m[x[0]] & PC_X3) >> 48;
    if (x[1] >= 0) r |= (m[x[1]] & PC_X0) << 48;
    if (x[2] >= 0) r |= (m[x[2]] & PC_Y3) >> 12;
    if (x[3] >= 0) r |= (m[x[3]] & PC_Y0) << 12;
    if (x[4] >= 0) r |= (m[x[4]] & PC_Z3) >> 3;
    if (x[5] >= 0) r |= (m[x[5]] & PC_Z0) << 3;
    return r;
}

/* The common case, decided without the per-particle union-find: all
 * particles share one field and at most one body colours them. Two
 * particles at one node, or at nodes next to each other along an axis, are
 * linked when compatible, and with one body a particle is of one of three
 * kinds: without affinity (compatible with every particle), or with
 * affinity on the body's front or back (compatible with its own side and
 * the first kind). So the parts are the connected sets of (node, kind)
 * pairs some particle holds, linked as the particles are, and one flood
 * over each block's three 64-bit masks of such nodes tells whether the
 * field is whole: the same answer as the full pass's union-find, which
 * would then find one part and change nothing. With no blade in the
 * material only the first kind is there. Returns 1 when the field is
 * whole, 0 when the full pass must decide, -1 out of memory. */
static int whole_at_once(const kf_state *s, kf_contact *c, const uint32_t *node_of, uint32_t aff, int one) {
    const kf_particles *p = &s->p;
    const kf_grid *g = &s->g;
    const size_t n = p->n, nb = g->nblocks;
    const uint32_t A = aff & 0xAAAAAAAu;
    /* more than one body's affinity: the kinds are no longer three */
    if ((A & (A - 1)) || !one || !n) return 0;
    const int kinds = A ? 3 : 1;
    const uint32_t side = A >> 1; /* the body's side bit */
    if (nb > c->pc_occ_cap) {
        size_t cap = nb + nb / 4 + 64;
        uint64_t *o = realloc(c->pc_occ, 3 * cap * sizeof *o), *r = o ? realloc(c->pc_seen, 3 * cap * sizeof *r) : NULL;
        if (o) c->pc_occ = o;
        if (r) c->pc_seen = r;
        int32_t(*x)[6] = r ? realloc(c->pc_next, cap * sizeof *x) : NULL;
        if (!x) return -1;
        c->pc_next = x;
        c->pc_occ_cap = cap;
    }
    /* per kind k, occ[k * nb + b]: block b's nodes a particle of kind k is nearest to; seen: those reached */
    uint64_t *occ = c->pc_occ, *seen = c->pc_seen;
    int32_t(*next)[6] = c->pc_next;
    memset(occ, 0, (size_t)kinds * nb * sizeof *occ);
    memset(seen, 0, (size_t)kinds * nb * sizeof *seen);
    for (size_t i = 0; i < n; i++) {
        const uint32_t col = p->colour[i];
        const size_t k = !(col & A) ? 0 : (col & side) ? 2 : 1;
        occ[k * nb + node_of[i] / KF_BLOCK_NODES] |= 1ull << (node_of[i] % KF_BLOCK_NODES);
    }
    for (size_t b = 0; b < nb; b++) {
        const int32_t *bc = &g->bcoord[3 * b];
        uint64_t any = 0;
        for (int k = 0; k < kinds; k++) any |= occ[(size_t)k * nb + b];
        for (int e = 0; e < 6; e++) {
            int a = e / 2, d = e % 2 ? 1 : -1;
            next[b][e] = any ? kf_grid_find(g, bc[0] + d * (a == 0), bc[1] + d * (a == 1), bc[2] + d * (a == 2)) : -1;
        }
    }
    {
        const size_t k0 = !(p->colour[0] & A) ? 0 : (p->colour[0] & side) ? 2 : 1;
        seen[k0 * nb + node_of[0] / KF_BLOCK_NODES] = 1ull << (node_of[0] % KF_BLOCK_NODES);
    }
    uint64_t *sN = seen, *s1 = seen + nb, *s2 = seen + 2 * nb;
    const uint64_t *oN = occ, *o1 = occ + nb, *o2 = occ + 2 * nb;
    /* sweeps up and down the blocks until nothing more is reached */
    for (int changed = 1, pass = 0; changed; pass++) {
        changed = 0;
        for (size_t q = 0; q < nb; q++) {
            size_t b = pass % 2 ? nb - 1 - q : q;
            const int32_t *x = next[b];
            if (kinds == 1) {
                if (!oN[b]) continue;
                uint64_t r = (sN[b] | pc_from_faces(sN, x)) & oN[b];
                if (!r) continue;
                for (uint64_t was = 0; was != r;) was = r, r = pc_grow(r) & oN[b];
                if (r != sN[b]) sN[b] = r, changed = 1;
                continue;
            }
            if (!(oN[b] | o1[b] | o2[b])) continue;
            /* what each kind links to: the first kind every kind, a side its own and the first */
            const uint64_t fN = pc_from_faces(sN, x), f1 = pc_from_faces(s1, x), f2 = pc_from_faces(s2, x);
            uint64_t rN = (sN[b] | fN | f1 | f2) & oN[b], r1 = (s1[b] | fN | f1) & o1[b], r2 = (s2[b] | fN | f2) & o2[b];
            uint64_t wN, w1, w2;
            do {
                wN = rN, w1 = r1, w2 = r2;
                rN |= pc_grow(wN | w1 | w2) & oN[b];
                r1 |= pc_grow(wN | w1) & o1[b];
                r2 |= pc_grow(wN | w2) & o2[b];
            } while (wN != rN || w1 != r1 || w2 != r2);
            if (rN != sN[b] || r1 != s1[b] || r2 != s2[b]) sN[b] = rN, s1[b] = r1, s2[b] = r2, changed = 1;
        }
    }
    for (size_t b = 0; b < (size_t)kinds * nb; b++)
        if (seen[b] != occ[b]) return 0;
    return 1;
}

/* ---- across ranks -------------------------------------------------------------
 * A part may span ranks. Each rank makes the classes of its own particles
 * (nearest node, field, CPIC colour: as below) and links them as one rank
 * does; a part found so is labelled by its smallest particle index in the
 * one-rank array, a label no other rank's part has. The classes at or
 * next to another rank's classes' nodes travel to that rank with their
 * labels (kf_dist_node_exchange): a class received that links with one of
 * this rank's joins the two labels. Every rank then gets a small table
 * (kf_dist_pieces_gather): the joins, the fields each rank holds, and the
 * parts that were joined or have KF_PIECE_MIN particles or more (a smaller
 * part on one rank alone cannot become a piece, and where it is its
 * field's largest part no part of the field can). Merging joined labels
 * gives every part of the one-rank run that matters, with its smallest
 * particle index, size and field, in an order that depends on the table
 * alone: every rank numbers them as one rank does. What travels is the
 * classes near rank boundaries and a record per part, not the scene. */
typedef struct {
    int32_t node[3]; /* the nearest node */
    uint16_t field, cuts;
    uint32_t mcol;  /* the CPIC colour's bits (kf_cpic_compatible reads only them) */
    uint32_t count; /* its particles */
    uint64_t rep;   /* its first particle's index in the one-rank array */
} gclass;

/* a class on the wire to a neighbouring rank: its node first, and its part's label */
typedef struct {
    int32_t node[3];
    uint32_t mcol;
    uint32_t label[2]; /* low and high words */
    uint16_t field, pad;
} wclass;

/* a part in the table every rank gets */
typedef struct {
    uint64_t label, size;
    uint16_t field, cuts;
    uint32_t pad;
} gpart;

static int key_cmp(const gclass *a, const gclass *b) {
    for (int e = 0; e < 3; e++)
        if (a->node[e] != b->node[e]) return a->node[e] < b->node[e] ? -1 : 1;
    if (a->field != b->field) return a->field < b->field ? -1 : 1;
    if (a->mcol != b->mcol) return a->mcol < b->mcol ? -1 : 1;
    return 0;
}

static int class_cmp(const void *x, const void *y) {
    const gclass *a = x, *b = y;
    int k = key_cmp(a, b);
    return k ? k : a->rep < b->rep ? -1 : a->rep > b->rep;
}

/* sorted by key and first particle, entries of one key made one */
static size_t merge(gclass *g, size_t n) {
    qsort(g, n, sizeof *g, class_cmp);
    size_t out = 0;
    for (size_t i = 0; i < n; i++) {
        if (out && !key_cmp(&g[out - 1], &g[i])) g[out - 1].count += g[i].count;
        else g[out++] = g[i];
    }
    return out;
}

/* the first class at or after node (x, y, z) */
static size_t node_lower(const gclass *g, size_t n, const int32_t *q) {
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        int less = 0;
        for (int e = 0; e < 3; e++)
            if (g[mid].node[e] != q[e]) {
                less = g[mid].node[e] < q[e];
                break;
            }
        if (less) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

/* orders of pairs of labels, and of parts by label */
static int by_pair(const void *x, const void *y) {
    const uint64_t *a = x, *b = y;
    if (a[0] != b[0]) return a[0] < b[0] ? -1 : 1;
    return a[1] < b[1] ? -1 : a[1] > b[1];
}

static int by_label(const void *x, const void *y) {
    const gpart *a = x, *b = y;
    return a->label < b->label ? -1 : a->label > b->label;
}

/* the part with this label in parts sorted by label, or SIZE_MAX */
static size_t part_of(const gpart *pt, size_t n, uint64_t label) {
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (pt[mid].label < label) lo = mid + 1;
        else hi = mid;
    }
    return lo < n && pt[lo].label == label ? lo : SIZE_MAX;
}

/* whether a join (sorted pairs) names label first */
static int joined(const uint64_t (*e)[2], size_t n, uint64_t label) {
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (e[mid][0] < label) lo = mid + 1;
        else hi = mid;
    }
    return lo < n && e[lo][0] == label;
}

/* the table's head from each rank: its parts, joins and fields */
typedef struct {
    uint64_t nparts, njoins, nfields, pad;
} ghead;

static size_t pad8(size_t b) { return (b + 7) / 8 * 8; }

/* the links of one rank's classes (same field, no thin body between, same
 * node or the next along an axis), roots the classes of smallest first
 * particle; parent has nc entries */
static void link_classes(const gclass *cl, size_t nc, uint32_t *parent) {
    for (uint32_t k = 0; k < nc; k++) parent[k] = k;
    for (size_t i = 0; i < nc; i++) {
        for (int a = -1; a < 3; a++) {
            int32_t q[3] = {cl[i].node[0], cl[i].node[1], cl[i].node[2]};
            size_t j = i + 1;
            if (a >= 0) q[a]++, j = node_lower(cl, nc, q);
            for (; j < nc && !memcmp(cl[j].node, q, sizeof q); j++) {
                if (cl[j].field != cl[i].field || !compatible(cl[i].mcol, cl[j].mcol)) continue;
                uint32_t r1 = find(parent, (uint32_t)i), r2 = find(parent, (uint32_t)j);
                if (r1 == r2) continue;
                if (cl[r1].rep < cl[r2].rep) parent[r2] = r1;
                else parent[r1] = r2;
            }
        }
    }
}

/* The joins: each received class that links with a class of this rank
 * (same field, compatible colours, same node or next along an axis either
 * way), as pairs (this rank's label, the received one), sorted, unique.
 * *out is malloc'd. 0 or -1. */
static int joins(const gclass *cl, size_t nc, uint32_t *parent, const wclass *in, size_t nin, uint64_t (**out)[2],
                 size_t *nout) {
    size_t n = 0, cap = 64;
    uint64_t(*e)[2] = malloc(cap * sizeof *e);
    if (!e) return -1;
    for (size_t u = 0; u < nin; u++) {
        wclass w;
        memcpy(&w, &in[u], sizeof w);
        const uint64_t label = (uint64_t)w.label[1] << 32 | w.label[0];
        for (int a = -1; a < 6; a++) {
            int32_t q[3] = {w.node[0], w.node[1], w.node[2]};
            if (a >= 0) q[a / 2] += a % 2 ? 1 : -1;
            for (size_t j = node_lower(cl, nc, q); j < nc && !memcmp(cl[j].node, q, sizeof q); j++) {
                if (cl[j].field != w.field || !compatible(cl[j].mcol, w.mcol)) continue;
                if (n == cap) {
                    cap *= 2;
                    uint64_t(*ne)[2] = realloc(e, cap * sizeof *e);
                    if (!ne) return free(e), -1;
                    e = ne;
                }
                e[n][0] = cl[find(parent, (uint32_t)j)].rep;
                e[n++][1] = label;
            }
        }
    }
    qsort(e, n, sizeof *e, by_pair);
    size_t m = 0;
    for (size_t k = 0; k < n; k++)
        if (!m || e[k][0] != e[m - 1][0] || e[k][1] != e[m - 1][1]) e[m][0] = e[k][0], e[m++][1] = e[k][1];
    *out = e;
    *nout = m;
    return 0;
}

/* The numbering over the table every rank got (all, bytes): the parts of
 * the one-rank run that matter, each with its new piece + 1 (0: keeps its
 * own) into *newp, by index in *parts (malloc'd, sorted by label: a
 * part's root is its smallest label), roots in *par. Returns 1 when some
 * part became a piece, 0 when none, -1 out of memory. */
static int number_parts(kf_contact *c, const char *all, size_t bytes, gpart **parts, size_t *nparts, uint32_t **par,
                        uint32_t **newp) {
    size_t np = 0, nj = 0;
    for (size_t u = 0; u < bytes;) {
        ghead h;
        memcpy(&h, all + u, sizeof h);
        np += h.nparts, nj += h.njoins;
        u += sizeof h + h.nparts * sizeof(gpart) + h.njoins * 2 * sizeof(uint64_t) + pad8(h.nfields * 2);
    }
    if (np >= UINT32_MAX) return -1;
    gpart *pt = malloc((np + 1) * sizeof *pt);
    uint64_t(*jn)[2] = malloc((nj + 1) * sizeof *jn), *size = calloc(np + 1, sizeof *size);
    uint32_t *parent = malloc((np + 1) * sizeof *parent), *piece = calloc(np + 1, sizeof *piece);
    uint32_t *keep = c->pc_keep, *used = c->pc_used;
    if (!keep) {
        keep = c->pc_keep = malloc(sizeof(uint32_t) * 65536);
        used = c->pc_used = malloc(sizeof(uint32_t) * 4096);
    }
    if (!pt || !jn || !size || !parent || !piece || !keep || !used)
        return free(pt), free(jn), free(size), free(parent), free(piece), -1;
    /* every field some rank holds: no part of it keeps its number yet; its piece is in use */
    memset(used, 0, sizeof(uint32_t) * 4096);
    size_t ip = 0, ij = 0;
    for (size_t u = 0; u < bytes;) {
        ghead h;
        memcpy(&h, all + u, sizeof h);
        u += sizeof h;
        memcpy(pt + ip, all + u, h.nparts * sizeof *pt);
        ip += h.nparts, u += h.nparts * sizeof *pt;
        memcpy(jn + ij, all + u, h.njoins * sizeof *jn);
        ij += h.njoins, u += h.njoins * sizeof *jn;
        for (size_t k = 0; k < h.nfields; k++) {
            uint16_t f;
            memcpy(&f, all + u + 2 * k, sizeof f);
            keep[f] = UINT32_MAX;
            used[f & KF_OBJECT_MASK] |= 1u << (f >> PIECE_SHIFT);
        }
        u += pad8(h.nfields * 2);
    }
    /* joined parts are one; the root of each is its smallest label, the
     * first of its parts by label */
    qsort(pt, np, sizeof *pt, by_label);
    for (uint32_t k = 0; k < np; k++) parent[k] = k;
    for (size_t k = 0; k < nj; k++) {
        size_t a = part_of(pt, np, jn[k][0]), b = part_of(pt, np, jn[k][1]);
        if (a == SIZE_MAX || b == SIZE_MAX) continue; /* (every rank sends the parts it joins) */
        uint32_t r1 = find(parent, (uint32_t)a), r2 = find(parent, (uint32_t)b);
        if (r1 < r2) parent[r2] = r1;
        else if (r2 < r1) parent[r1] = r2;
    }
    for (uint32_t k = 0; k < np; k++) size[find(parent, k)] += pt[k].size;
    /* the largest part of each field keeps its number (the first by label
     * among equals); every other of a few cells or more, in label order,
     * takes the next free piece of its object */
    for (uint32_t k = 0; k < np; k++) {
        if (parent[k] != k) continue;
        uint16_t f = pt[k].field;
        if (keep[f] == UINT32_MAX || size[k] > size[keep[f]]) keep[f] = k;
    }
    int split = 0;
    for (uint32_t k = 0; k < np; k++) {
        uint16_t f = pt[k].field;
        if (parent[k] != k || keep[f] == k || size[k] < KF_PIECE_MIN || !pt[k].cuts) continue;
        uint32_t obj = f & KF_OBJECT_MASK, free_mask = ~used[obj] & 0xFFFFu;
        uint32_t pk = free_mask ? (uint32_t)__builtin_ctz(free_mask) : 15;
        used[obj] |= 1u << pk;
        piece[k] = pk + 1;
        split = 1;
    }
    free(jn);
    free(size);
    *parts = pt;
    *nparts = np;
    *par = parent;
    *newp = piece;
    return split;
}

static int pieces_across_ranks(const kf_model *m, kf_state *s, const uint32_t *node_of) {
    kf_contact *c = s->contact;
    kf_particles *p = &s->p;
    const kf_grid *g = &s->g;
    const size_t n = p->n, first = kf_dist_first_index(s);
    const uint32_t cmask = KF_CPIC_BITS_MASK;
    /* this rank's classes, linked */
    gclass *cl = malloc((n + 1) * sizeof *cl);
    if (!cl) return -1;
    for (size_t k = 0; k < g->nowner; k++)
        for (size_t i = g->pstart[k]; i < g->pstart[k + 1]; i++) {
            const uint32_t q = node_of[i], l = q % KF_BLOCK_NODES;
            const int32_t *bc = &g->bcoord[3 * (q / KF_BLOCK_NODES)];
            gclass e = {{KF_BLOCK * bc[0] + (int32_t)(l >> 4), KF_BLOCK * bc[1] + (int32_t)((l >> 2) & 3),
                         KF_BLOCK * bc[2] + (int32_t)(l & 3)},
                        kf_contact_field(p, i),
                        (uint16_t)kf_contact_cuts(&m->mat[p->mat[i]]),
                        p->colour[i] & cmask,
                        1,
                        first + i};
            cl[i] = e;
        }
    const size_t nc = merge(cl, n);
    uint32_t *parent = nc < UINT32_MAX ? malloc((nc + 1) * sizeof *parent) : NULL;
    uint64_t *size = calloc(nc + 1, sizeof *size);
    wclass *w = malloc((nc + 1) * sizeof *w);
    if (!parent || !size || !w) return free(cl), free(parent), free(size), free(w), -1;
    link_classes(cl, nc, parent);
    for (uint32_t k = 0; k < nc; k++) size[find(parent, k)] += cl[k].count;

    /* each class with its part's label to the ranks whose classes it may link with */
    for (size_t k = 0; k < nc; k++) {
        const uint64_t label = cl[find(parent, (uint32_t)k)].rep;
        wclass e = {{cl[k].node[0], cl[k].node[1], cl[k].node[2]},
                    cl[k].mcol,
                    {(uint32_t)label, (uint32_t)(label >> 32)},
                    cl[k].field,
                    0};
        w[k] = e;
    }
    void *in = NULL;
    size_t nin = 0, nj = 0;
    uint64_t(*jn)[2] = NULL;
    if (kf_dist_node_exchange(m, s, w, nc, sizeof *w, &in, &nin) || joins(cl, nc, parent, in, nin, &jn, &nj))
        return free(cl), free(parent), free(size), free(w), free(in), -1;
    free(in);
    free(w);

    /* the table's share of this rank: its parts joined or large, the joins, its fields */
    uint32_t *fseen = calloc(65536 / 32, sizeof *fseen);
    size_t npart = 0, nfield = 0;
    if (!fseen) return free(cl), free(parent), free(size), free(jn), -1;
    for (uint32_t k = 0; k < nc; k++) {
        const uint16_t f = cl[k].field;
        if (!(fseen[f / 32] >> (f % 32) & 1)) fseen[f / 32] |= 1u << (f % 32), nfield++;
        if (parent[k] == k && (size[k] >= KF_PIECE_MIN || joined((const uint64_t(*)[2])jn, nj, cl[k].rep))) npart++;
    }
    const size_t out_bytes = sizeof(ghead) + npart * sizeof(gpart) + nj * sizeof *jn + pad8(nfield * 2);
    char *out = calloc(1, out_bytes);
    if (!out) return free(cl), free(parent), free(size), free(jn), free(fseen), -1;
    ghead h = {npart, nj, nfield, 0};
    memcpy(out, &h, sizeof h);
    size_t u = sizeof h;
    for (uint32_t k = 0; k < nc; k++)
        if (parent[k] == k && (size[k] >= KF_PIECE_MIN || joined((const uint64_t(*)[2])jn, nj, cl[k].rep))) {
            gpart e = {cl[k].rep, size[k], cl[k].field, cl[k].cuts, 0};
            memcpy(out + u, &e, sizeof e);
            u += sizeof e;
        }
    if (nj) memcpy(out + u, jn, nj * sizeof *jn);
    u += nj * sizeof *jn;
    for (uint32_t f = 0; f < 65536; f++)
        if (fseen[f / 32] >> (f % 32) & 1) {
            const uint16_t v = (uint16_t)f;
            memcpy(out + u, &v, sizeof v);
            u += sizeof v;
        }
    free(fseen);
    free(jn);
    void *all = NULL;
    size_t all_bytes = 0;
    if (kf_dist_pieces_gather(s, out, out_bytes, nc, &all, &all_bytes))
        return free(cl), free(parent), free(size), free(out), -1;
    free(out);

    /* the numbering, the same on every rank; then this rank's particles:
     * their class, its part, the part's root in the table, its piece */
    gpart *pt = NULL;
    size_t np = 0;
    uint32_t *gparent = NULL, *newp = NULL;
    const int split = number_parts(c, all, all_bytes, &pt, &np, &gparent, &newp);
    free(all);
    if (split < 0) return free(cl), free(parent), free(size), -1;
    if (split) {
        /* by root class: its part's piece + 1, 0 = keeps its own (size reused) */
        for (uint32_t k = 0; k < nc; k++) {
            if (parent[k] != k) continue;
            size_t a = part_of(pt, np, cl[k].rep);
            size[k] = a == SIZE_MAX ? 0 : newp[find(gparent, (uint32_t)a)];
        }
        for (size_t i = 0; i < n; i++) {
            const uint32_t q = node_of[i], l = q % KF_BLOCK_NODES;
            const int32_t *bc = &g->bcoord[3 * (q / KF_BLOCK_NODES)];
            gclass e = {{KF_BLOCK * bc[0] + (int32_t)(l >> 4), KF_BLOCK * bc[1] + (int32_t)((l >> 2) & 3),
                         KF_BLOCK * bc[2] + (int32_t)(l & 3)},
                        kf_contact_field(p, i),
                        0,
                        p->colour[i] & cmask,
                        0,
                        0};
            size_t lo = node_lower(cl, nc, e.node);
            while (lo < nc && key_cmp(&cl[lo], &e) < 0) lo++;
            uint64_t k = size[find(parent, (uint32_t)lo)];
            if (k) p->obj[i] = (uint16_t)((p->obj[i] & KF_OBJECT_MASK) | (k - 1) << PIECE_SHIFT);
        }
        c->pieces_made++;
        kf_dist_pieces_split(s);
    }
    free(cl);
    free(parent);
    free(size);
    free(pt);
    free(gparent);
    free(newp);
    return 0;
}

int kf_contact_pieces(const kf_model *m, kf_state *s) {
    kf_contact *c = s->contact;
    kf_particles *p = &s->p;
    const kf_grid *g = &s->g;
    const size_t n = p->n, nodes = g->nblocks * KF_BLOCK_NODES;
    if (!s->dist && (!n || n >= UINT32_MAX)) return 0;
    if (reserve((void **)&c->pc_node, &c->pc_node_cap, n, sizeof(uint32_t)) ||
        reserve((void **)&c->pc_parent, &c->pc_parent_cap, n, sizeof(uint32_t)) ||
        reserve((void **)&c->pc_list, &c->pc_list_cap, n, sizeof(uint32_t)) ||
        reserve((void **)&c->pc_cls, &c->pc_cls_cap, n, sizeof(uint32_t)) ||
        reserve((void **)&c->pc_rep, &c->pc_rep_cap, n, sizeof(uint32_t)) ||
        reserve((void **)&c->pc_cnt, &c->pc_cnt_cap, n, sizeof(uint32_t)) ||
        reserve((void **)&c->pc_start, &c->pc_start_cap, nodes + 1, sizeof(uint32_t)) ||
        reserve((void **)&c->pc_nrep, &c->pc_nrep_cap, nodes, sizeof(uint32_t)))
        return -1;
    uint32_t *node_of = c->pc_node, *parent = c->pc_parent, *list = c->pc_list, *start = c->pc_start;
    uint32_t *cls = c->pc_cls, *rep = c->pc_rep, *cnt = c->pc_cnt;
    const kf_real inv_dx = kf_model_inv_dx(m);

    /* each particle's nearest node, inside its owner's neighbourhood; with
     * it, whether any particle has affinity to a body and whether all share
     * one field (whole_at_once). The owner's neighbours and corner are
     * copied to locals: the node stores cannot change them, so the loop
     * runs in vector lanes (the same arithmetic per particle). */
    const size_t nowner = g->nowner;
    uint32_t aff = 0;
    int one = 1;
    const uint16_t f0 = n ? kf_contact_field(p, 0) : 0;
    const kf_real *restrict px = p->x[0], *restrict py = p->x[1], *restrict pz = p->x[2];
    const uint32_t *restrict pcol = p->colour;
    uint32_t *restrict nodes_out = node_of;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) if (n >= 65536) reduction(| : aff) reduction(& : one)
    for (size_t k = 0; k < nowner; k++) {
        const int32_t *bc = &g->bcoord[3 * k]; /* an owner is the block of the same index */
        const int o0 = KF_BLOCK * bc[0], o1 = KF_BLOCK * bc[1], o2 = KF_BLOCK * bc[2];
        int32_t nbk[8];
        memcpy(nbk, g->nb[k], sizeof nbk);
        uint32_t a_k = 0;
        int one_k = 1;
        for (size_t i = g->pstart[k]; i < g->pstart[k + 1]; i++) {
            int l0 = (int)kf_floor(px[i] * inv_dx + KF_R(0.5)) - o0;
            int l1 = (int)kf_floor(py[i] * inv_dx + KF_R(0.5)) - o1;
            int l2 = (int)kf_floor(pz[i] * inv_dx + KF_R(0.5)) - o2;
            l0 = l0 < 0 ? 0 : l0 > 7 ? 7 : l0;
            l1 = l1 < 0 ? 0 : l1 > 7 ? 7 : l1;
            l2 = l2 < 0 ? 0 : l2 > 7 ? 7 : l2;
            int blk = nbk[(l0 >> 2) << 2 | (l1 >> 2) << 1 | (l2 >> 2)];
            nodes_out[i] = (uint32_t)blk * KF_BLOCK_NODES + (uint32_t)((l0 & 3) << 4 | (l1 & 3) << 2 | (l2 & 3));
            a_k |= pcol[i];
            one_k &= kf_contact_field(p, i) == f0;
        }
        aff |= a_k;
        one &= one_k;
    }
    /* particles outside the owners' ranges (none where the grid binned
     * them all) are read as well */
    if (!nowner || g->pstart[0] != 0 || g->pstart[nowner] != n)
        for (size_t i = 0; i < n; i++) {
            aff |= pcol[i];
            one &= kf_contact_field(p, i) == f0;
        }
    if (s->dist) return pieces_across_ranks(m, s, node_of);
    {
        int whole = whole_at_once(s, c, node_of, aff, one);
        if (whole) return whole < 0 ? -1 : 0;
    }
    memset(start, 0, sizeof(uint32_t) * (nodes + 1));
    for (size_t i = 0; i < n; i++) start[node_of[i] + 1]++;
    for (size_t q = 0; q < nodes; q++) start[q + 1] += start[q];
    for (size_t i = 0; i < n; i++) list[start[node_of[i]]++] = (uint32_t)i;
    for (size_t q = nodes; q > 0; q--) start[q] = start[q - 1];
    start[0] = 0;

    /* At each node, particles of one field and one CPIC colour are one
     * class (compatible with each other, so connected at once). The rest
     * works on classes, not particles: a class's first particle (its
     * smallest index: the node's list is in index order) is its
     * representative, moved to the front of the node's list. */
    const uint32_t cmask = KF_CPIC_BITS_MASK;
    uint32_t *nrep = c->pc_nrep, ncls = 0;
    for (size_t q = 0; q < nodes; q++) {
        uint32_t s0 = start[q], k = s0;
        for (uint32_t u = s0; u < start[q + 1]; u++) {
            uint32_t i = list[u], ci = p->colour[i] & cmask, w = s0;
            uint16_t fi = kf_contact_field(p, i);
            for (; w < k; w++) {
                uint32_t j = list[w];
                if (kf_contact_field(p, j) == fi && (p->colour[j] & cmask) == ci) break;
            }
            if (w < k) {
                uint32_t cl = cls[list[w]];
                cls[i] = cl;
                cnt[cl]++;
            } else {
                list[u] = list[k], list[k++] = i;
                cls[i] = ncls;
                rep[ncls] = i;
                cnt[ncls] = 1;
                parent[ncls] = ncls;
                ncls++;
            }
        }
        nrep[q] = k - s0;
    }

    /* links between classes: same field, no thin body between, same node or
     * the next along an axis. The root of a part is the class of its
     * smallest particle index, whatever order the links come in. */
    for (size_t b = 0; b < g->nblocks; b++) {
        const int32_t *bc = &g->bcoord[3 * b];
        int32_t next[3] = {-2, -2, -2}; /* looked up when first needed */
        for (int l = 0; l < KF_BLOCK_NODES; l++) {
            size_t q = b * KF_BLOCK_NODES + (size_t)l;
            if (!nrep[q]) continue;
            size_t other[4] = {q, 0, 0, 0};
            int no = 1;
            int lc[3] = {l >> 4, (l >> 2) & 3, l & 3};
            for (int a = 0; a < 3; a++) {
                int t[3] = {lc[0], lc[1], lc[2]};
                t[a]++;
                int32_t blk = (int32_t)b;
                if (t[a] == KF_BLOCK) {
                    if (next[a] == -2) next[a] = kf_grid_find(g, bc[0] + (a == 0), bc[1] + (a == 1), bc[2] + (a == 2));
                    if (next[a] < 0) continue;
                    blk = next[a];
                    t[a] = 0;
                }
                other[no++] = (size_t)blk * KF_BLOCK_NODES + (size_t)(t[0] << 4 | t[1] << 2 | t[2]);
            }
            for (uint32_t u = start[q]; u < start[q] + nrep[q]; u++) {
                uint32_t i = list[u];
                uint16_t fi = kf_contact_field(p, i);
                for (int e = 0; e < no; e++) {
                    size_t r = other[e];
                    for (uint32_t w = e ? start[r] : u + 1; w < start[r] + nrep[r]; w++) {
                        uint32_t j = list[w];
                        if (kf_contact_field(p, j) == fi && compatible(p->colour[i], p->colour[j])) {
                            uint32_t a = find(parent, cls[i]), bb = find(parent, cls[j]);
                            if (a == bb) continue;
                            if (rep[a] < rep[bb]) parent[bb] = a;
                            else parent[a] = bb;
                        }
                    }
                }
            }
        }
    }

    /* the size of each part; its roots in the order of their smallest
     * particle index; the largest part of each field keeps its number */
    uint32_t *size = list;                /* reused: the node lists are done */
    uint32_t nroot = 0, *roots = node_of; /* reused likewise */
    for (uint32_t k = 0; k < ncls; k++) size[k] = 0;
    for (uint32_t k = 0; k < ncls; k++) size[find(parent, k)] += cnt[k];
    /* classes were numbered node by node: the roots in particle index order */
    for (size_t i = 0; i < n; i++) {
        uint32_t k = cls[i];
        if (parent[k] == k && rep[k] == (uint32_t)i) roots[nroot++] = k;
    }
    uint32_t *keep = c->pc_keep, *used = c->pc_used;
    if (!keep) {
        keep = c->pc_keep = malloc(sizeof(uint32_t) * 65536);
        used = c->pc_used = malloc(sizeof(uint32_t) * 4096);
        if (!keep || !used) return -1;
    }
    memset(used, 0, sizeof(uint32_t) * 4096);
    for (uint32_t k = 0; k < ncls; k++) {
        uint16_t f = kf_contact_field(p, rep[k]);
        keep[f] = UINT32_MAX;
        used[f & KF_OBJECT_MASK] |= 1u << (f >> PIECE_SHIFT);
    }
    for (uint32_t a = 0; a < nroot; a++) {
        uint32_t k = roots[a];
        uint16_t f = kf_contact_field(p, rep[k]);
        if (keep[f] == UINT32_MAX || size[k] > size[keep[f]]) keep[f] = k;
    }
    /* every other part of a few cells or more: the next free piece number of
     * its object (roots in index order, so the numbering does not depend on
     * threads); a stray particle or two cut off stays with its field */
    uint32_t *piece = cnt; /* per root class: its new piece + 1, 0 = keeps its own (the counts are done) */
    int split = 0;
    for (uint32_t a = 0; a < nroot; a++) {
        uint32_t k = roots[a], i = rep[k];
        uint16_t f = kf_contact_field(p, i);
        piece[k] = 0;
        if (keep[f] == k || size[k] < KF_PIECE_MIN || !kf_contact_cuts(&m->mat[p->mat[i]])) continue;
        uint32_t obj = f & KF_OBJECT_MASK, free_mask = ~used[obj] & 0xFFFFu;
        uint32_t pk = free_mask ? (uint32_t)__builtin_ctz(free_mask) : 15;
        used[obj] |= 1u << pk;
        piece[k] = pk + 1;
        split = 1;
    }
    if (!split) return 0;
    for (size_t i = 0; i < n; i++) {
        uint32_t k = piece[find(parent, cls[i])];
        if (k) p->obj[i] = (uint16_t)((p->obj[i] & KF_OBJECT_MASK) | (k - 1) << PIECE_SHIFT);
    }
    c->pieces_made++;
    return 0;
}
