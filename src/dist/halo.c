/* halo.c — P2G across ranks: each boundary owner block's cache travels to
 * the ranks that share its nodes and is added there in its colour's turn,
 * so every node a rank reads holds the one-rank sum bit for bit (dist.h). */
#include <stdlib.h>
#include <string.h>

#include "internal.h"
#include "../cpic/cpic.h"
#include "../mpm/contact.h"

/* the header's flag: a field cache follows the node cache (contact.h) */
#define HEAD_FIELDS (1 << 24)

/* A field cache on the wire: a bit per node of the touched box (its
 * nodes in cache order) saying whether its rows follow, then those rows.
 * Rows are sent only where they are not all zero: fields meet at few of an
 * owner's nodes, and a zero row rebuilt is the same zero (a sum started at
 * +0 is never -0). The mask's kf_v4 units for a box of vol nodes: */
static size_t mask_units(size_t vol) {
    return ((vol + 63) / 64 * sizeof(uint64_t) + sizeof(kf_v4) - 1) / sizeof(kf_v4);
}

static int row_zero(const kf_v4 *row, int n) {
    static const kf_v4 zero[KF_CONTACT_CACHE_ROWS];
    return !memcmp(row, zero, (size_t)n * sizeof *row);
}

/* the colour of an owner block: the parity of its coordinate (grid.h) */
static inline int colour_of(const int32_t *c) { return (c[0] & 1) << 2 | (c[1] & 1) << 1 | (c[2] & 1); }

/* How far, in blocks along each axis, owner block c's cache reaches other
 * owners' nodes: its 2x2x2 neighbourhood meets theirs within one block.
 * Near a domain wall two: a node within a cell of a wall plane takes its
 * velocity from a node up to two cells inward along that axis
 * (wall_ghost.c), so an owner two blocks away reads c's nodes when the
 * plane lies between 3 cells below c's first node and 10 above it. */
static void reach(const kf_model *m, const int32_t c[3], int R[3]) {
    for (int a = 0; a < 3; a++) {
        R[a] = 1;
        if (!m->sim.walls) continue;
        const double lo = (KF_BLOCK * c[a] - 3) * m->sim.dx, hi = (KF_BLOCK * c[a] + 10) * m->sim.dx;
        for (int side = 0; side < 2; side++) {
            double plane = side ? m->sim.domain_max[a] : m->sim.domain_min[a];
            if (plane >= lo && plane <= hi) R[a] = 2;
        }
    }
}

/* every rank's owner keys into d->owner_keys (collective) */
static int gather_owners(struct kf_dist *d, const kf_grid *g) {
    int n = (int)g->nowner, *cnt = d->counts, *displ = d->counts + d->size;
    uint64_t *mine = malloc(((size_t)n + 1) * sizeof *mine);
    if (!mine) return -1;
    for (int r = 0; r < n; r++) {
        const int32_t *c = &g->bcoord[3 * r];
        mine[r] = kf_block_key(c[0], c[1], c[2]);
    }
    double t0 = kf_dist_clock();
    MPI_Allgather(&n, 1, MPI_INT, cnt, 1, MPI_INT, d->comm);
    size_t all = 0;
    for (int r = 0; r < d->size; r++) displ[r] = (int)all, all += (size_t)cnt[r];
    if (kf_dist_reserve((void **)&d->owner_keys, &d->owner_keys_cap, (all + 1) * sizeof *d->owner_keys))
        MPI_Abort(d->comm, 1);
    MPI_Allgatherv(mine, n, MPI_UINT64_T, d->owner_keys, cnt, displ, MPI_UINT64_T, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
    free(mine);
    d->nowner_keys = all;
    d->owners_stale = 0;
    return 0;
}

/* Which owner blocks other ranks need, and which ranks: those with an
 * owner block within R of it (its neighbourhood's nodes and theirs
 * overlap, or a wall ghost node reads across). A box whose corner keys lie
 * in this rank's range lies in it whole: keys are x-major. Pairs (owner,
 * rank), an owner's pairs adjacent, owners ascending. */
int kf_dist_pairs(const kf_model *m, kf_state *s, int32_t **pairs, size_t *npairs) {
    struct kf_dist *d = s->dist;
    const kf_grid *g = &s->g;
    const uint64_t lo = d->split[d->rank], hi = d->split[d->rank + 1];
    /* every rank's owners, once per re-sort */
    if (d->owners_stale && gather_owners(d, g)) return -1;
    size_t npair = 0, pair_cap = 0;
    int32_t *pair = NULL; /* (owner, rank) */
    int *mark = malloc((size_t)d->size * sizeof *mark);
    if (!mark) return -1;
    for (int r = 0; r < d->size; r++) mark[r] = -1;
    for (size_t o = 0; o < g->nowner; o++) {
        const int32_t *c = &g->bcoord[3 * o];
        int R[3];
        reach(m, c, R);
        uint64_t k0 = kf_block_key(c[0] - R[0], c[1] - R[1], c[2] - R[2]),
                 k1 = kf_block_key(c[0] + R[0], c[1] + R[1], c[2] + R[2]);
        if (k0 >= lo && k1 < hi) continue;
        for (int dx = -R[0]; dx <= R[0]; dx++)
            for (int dy = -R[1]; dy <= R[1]; dy++)
                for (int dz = -R[2]; dz <= R[2]; dz++) {
                    uint64_t key = kf_block_key(c[0] + dx, c[1] + dy, c[2] + dz);
                    int q = kf_dist_rank_of(d, key);
                    if (q == d->rank || mark[q] == (int)o || !kf_dist_is_owner(d, key)) continue;
                    mark[q] = (int)o;
                    if (npair == pair_cap) {
                        pair_cap = pair_cap ? 2 * pair_cap : 256;
                        int32_t *np = realloc(pair, pair_cap * 2 * sizeof *np);
                        if (!np) return free(pair), free(mark), -1;
                        pair = np;
                    }
                    pair[2 * npair] = (int32_t)o;
                    pair[2 * npair + 1] = q;
                    npair++;
                }
    }
    free(mark);
    *pairs = pair;
    *npairs = npair;
    return 0;
}

int kf_dist_halo(const kf_model *m, kf_state *s, kf_real dt) {
    struct kf_dist *d = s->dist;
    kf_grid *g = &s->g;
    const int CD = kf_p2g_cache_edge(m);
    const size_t rec = 1 + (size_t)CD * CD * CD; /* kf_v4s per record: header + cache */
    int *scount = d->counts, *sdispl = d->counts + d->size, *rcount = d->counts + 2 * d->size,
        *rdispl = d->counts + 3 * d->size;
    /* stress first, as kf_p2g (collective, and it uses the count arrays) */
    if (!s->tau_valid) kf_stress(m, s, 0);

    size_t npair = 0;
    int32_t *pair = NULL; /* (owner, rank) */
    if (kf_dist_pairs(m, s, &pair, &npair)) return -1;

    /* the records, grouped by destination rank */
    memset(scount, 0, (size_t)d->size * sizeof *scount);
    for (size_t k = 0; k < npair; k++) scount[pair[2 * k + 1]]++;
    size_t nsend = 0;
    for (int r = 0; r < d->size; r++) sdispl[r] = (int)nsend, nsend += (size_t)scount[r];
    if (kf_dist_reserve((void **)&d->send, &d->send_cap, (nsend * rec + 1) * sizeof(kf_v4))) return free(pair), -1;
    size_t *slot = malloc((npair + 1) * sizeof *slot);
    int *at = malloc((size_t)d->size * sizeof *at);
    if (!slot || !at) return free(pair), free(slot), free(at), -1;
    memcpy(at, sdispl, (size_t)d->size * sizeof *at);
    for (size_t k = 0; k < npair; k++) slot[k] = (size_t)at[pair[2 * k + 1]]++;
    free(at);
    /* where objects meet, an owner on the field path sends its field cache
     * too (FR kf_v4s), in the same record: fslot[k] its place, or -1 */
    const size_t FR = (size_t)KF_CONTACT_CACHE_ROWS * CD * CD * CD;
    ptrdiff_t *fslot = malloc((npair + 1) * sizeof *fslot);
    if (!fslot) return free(pair), free(slot), -1;
    size_t nf = 0;
    for (size_t k = 0; k < npair; k++) fslot[k] = kf_contact_owner(s, (size_t)pair[2 * k]) ? (ptrdiff_t)nf++ : -1;
    if (nf && kf_dist_reserve((void **)&d->fsend, &d->fsend_cap, nf * FR * sizeof(kf_v4)))
        return free(pair), free(slot), free(fslot), -1;
    /* The caches, as the owner's P2G makes them. Near a rigid body an
     * owner's P2G also writes its particles' colours and the bodies'
     * impulses (cpic.h), which the grid's own P2G writes again right after:
     * the colours are put back as they were and the impulses zeroed, so P2G
     * starts from what the one-rank P2G starts from. Each owner's cache is
     * made once (an owner's pairs are adjacent), then copied for its other
     * destinations. */
    kf_cpic *cp = m->nrigid ? s->cpic : NULL;
    if (cp && kf_dist_reserve((void **)&d->colour_save, &d->colour_cap, s->p.n * sizeof(uint32_t) + 4))
        return free(pair), free(slot), free(fslot), -1;
    if (cp) memcpy(d->colour_save, s->p.colour, s->p.n * sizeof(uint32_t));
#pragma omp parallel for schedule(dynamic, 4) num_threads(m->nthreads)
    for (size_t k = 0; k < npair; k++) {
        if (k > 0 && pair[2 * k] == pair[2 * (k - 1)]) continue; /* the owner's first pair makes it */
        kf_ftz();
        kf_v4 *r = d->send + slot[k] * rec;
        /* header: the block coordinate and the touched base offsets (4 bits each) */
        int32_t head[4], lohi[6];
        memcpy(head, &g->bcoord[3 * pair[2 * k]], 3 * sizeof *head);
        kf_p2g_owner_cache(m, s, (size_t)pair[2 * k], dt, r + 1,
                           fslot[k] >= 0 ? d->fsend + (size_t)fslot[k] * FR : NULL, lohi);
        head[3] = fslot[k] >= 0 ? HEAD_FIELDS : 0;
        for (int e = 0; e < 6; e++) head[3] |= (lohi[e] & 15) << (4 * e);
        r[0] = (kf_v4){0, 0, 0, 0};
        memcpy(&r[0], head, sizeof head);
    }
    for (size_t k = 1; k < npair; k++)
        if (pair[2 * k] == pair[2 * (k - 1)]) {
            memcpy(d->send + slot[k] * rec, d->send + slot[k - 1] * rec, rec * sizeof(kf_v4));
            /* the copy's field cache: the first pair's (the record names no place) */
            fslot[k] = fslot[k - 1];
        }
    if (cp) {
        memcpy(s->p.colour, d->colour_save, s->p.n * sizeof(uint32_t));
        if (cp->nslot) memset(cp->imp, 0, cp->nslot * sizeof cp->imp[0]);
    }
    /* each send slot's field cache, by the slot's place in the records */
    ptrdiff_t *sfield = malloc((nsend + 1) * sizeof *sfield);
    if (!sfield) return free(pair), free(slot), free(fslot), -1;
    for (size_t k = 0; k < npair; k++) sfield[slot[k]] = fslot[k];
    free(fslot);
    free(slot);
    free(pair);

    /* on the wire only the touched part of each cache: the header, then the
     * nodes of the box the owner's stencils reached (at most 6³ of 8³ for
     * the quadratic kernel), in the cache's order; then, for an owner on the
     * field path, the same nodes' field cache rows where not zero */
    const int KW = m->sim.kernel == KF_KERNEL_CUBIC ? 4 : 3;
    const int FROWS = KF_CONTACT_CACHE_ROWS;
    if (kf_dist_reserve((void **)&d->pack, &d->pack_cap,
                        (nsend * rec + nf * (FR + mask_units(FR)) + 1) * sizeof(kf_v4)))
        return free(sfield), -1;
    size_t packed = 0;
    for (int r = 0; r < d->size; r++) {
        size_t first = packed;
        for (size_t k = (size_t)sdispl[r]; k < (size_t)(sdispl[r] + scount[r]); k++) {
            const kf_v4 *rr = d->send + k * rec;
            int32_t head[4];
            memcpy(head, &rr[0], sizeof head);
            int from[3], to[3];
            for (int e = 0; e < 3; e++)
                from[e] = (head[3] >> (4 * e)) & 15, to[e] = ((head[3] >> (4 * (3 + e))) & 15) + KW;
            d->pack[packed++] = rr[0];
            for (int a = from[0]; a < to[0]; a++)
                for (int b = from[1]; b < to[1]; b++)
                    for (int c = from[2]; c < to[2]; c++) d->pack[packed++] = rr[1 + (a * CD + b) * CD + c];
            if (!(head[3] & HEAD_FIELDS)) continue;
            const kf_v4 *fr = d->fsend + (size_t)sfield[k] * FR;
            const size_t vol = (size_t)(to[0] - from[0]) * (size_t)(to[1] - from[1]) * (size_t)(to[2] - from[2]);
            uint64_t mask[(KF_CACHE_EDGE * KF_CACHE_EDGE * KF_CACHE_EDGE + 63) / 64] = {0};
            kf_v4 *mslot = &d->pack[packed];
            memset(mslot, 0, mask_units(vol) * sizeof(kf_v4));
            packed += mask_units(vol);
            size_t bit = 0;
            for (int a = from[0]; a < to[0]; a++)
                for (int b = from[1]; b < to[1]; b++)
                    for (int c = from[2]; c < to[2]; c++, bit++) {
                        const kf_v4 *row = &fr[(size_t)FROWS * (size_t)((a * CD + b) * CD + c)];
                        if (row_zero(row, FROWS)) continue;
                        mask[bit / 64] |= 1ull << (bit % 64);
                        for (int e = 0; e < FROWS; e++) d->pack[packed++] = row[e];
                    }
            memcpy(mslot, mask, (vol + 63) / 64 * sizeof *mask);
        }
        scount[r] = (int)(packed - first);
        sdispl[r] = (int)first;
    }

    /* exchange, in kf_v4 units */
    MPI_Datatype rt;
    MPI_Type_contiguous((int)sizeof(kf_v4), MPI_BYTE, &rt);
    MPI_Type_commit(&rt);
    double t0 = kf_dist_clock();
    MPI_Alltoall(scount, 1, MPI_INT, rcount, 1, MPI_INT, d->comm);
    size_t nunits = 0;
    for (int r = 0; r < d->size; r++) rdispl[r] = (int)nunits, nunits += (size_t)rcount[r];
    int ok = kf_dist_reserve((void **)&d->unpack, &d->unpack_cap, (nunits + 1) * sizeof(kf_v4)) == 0;
    if (!ok) MPI_Abort(d->comm, 1);
    MPI_Alltoallv(d->pack, scount, sdispl, rt, d->unpack, rcount, rdispl, rt, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
    MPI_Type_free(&rt);
    free(sfield);
    d->stats.halo_bytes += (double)(packed * sizeof(kf_v4));
    d->stats.substeps++;

    /* back to whole caches: count the records, then lay each out in full */
    size_t nrecv = 0, nfrecv = 0;
    for (size_t u = 0; u < nunits; nrecv++) {
        int32_t head[4];
        memcpy(head, &d->unpack[u], sizeof head);
        size_t vol = 1;
        for (int e = 0; e < 3; e++)
            vol *= (size_t)(((head[3] >> (4 * (3 + e))) & 15) + KW - ((head[3] >> (4 * e)) & 15));
        u += 1 + vol;
        if (!(head[3] & HEAD_FIELDS)) continue;
        uint64_t mask[(KF_CACHE_EDGE * KF_CACHE_EDGE * KF_CACHE_EDGE + 63) / 64];
        memcpy(mask, &d->unpack[u], (vol + 63) / 64 * sizeof *mask);
        size_t rows = 0;
        for (size_t w = 0; w < (vol + 63) / 64; w++) rows += (size_t)__builtin_popcountll(mask[w]);
        u += mask_units(vol) + rows * (size_t)FROWS;
        nfrecv++;
    }
    if (kf_dist_reserve((void **)&d->recv, &d->recv_cap, (nrecv * rec + 1) * sizeof(kf_v4)) ||
        kf_dist_reserve((void **)&d->frecv, &d->frecv_cap, (nfrecv * FR + 1) * sizeof(kf_v4)) ||
        kf_dist_reserve((void **)&d->ffield, &d->ffield_cap, (nrecv + 1) * sizeof *d->ffield))
        MPI_Abort(d->comm, 1);
    for (size_t u = 0, k = 0, nfk = 0; k < nrecv; k++) {
        kf_v4 *rr = d->recv + k * rec;
        int32_t head[4];
        memcpy(head, &d->unpack[u], sizeof head);
        rr[0] = d->unpack[u++];
        int from[3], to[3];
        for (int e = 0; e < 3; e++) from[e] = (head[3] >> (4 * e)) & 15, to[e] = ((head[3] >> (4 * (3 + e))) & 15) + KW;
        for (int a = from[0]; a < to[0]; a++)
            for (int b = from[1]; b < to[1]; b++)
                for (int c = from[2]; c < to[2]; c++) rr[1 + (a * CD + b) * CD + c] = d->unpack[u++];
        d->ffield[k] = -1;
        if (!(head[3] & HEAD_FIELDS)) continue;
        /* the field cache, whole: zero beyond the touched box, as the sender's */
        kf_v4 *fr = d->frecv + nfk * FR;
        d->ffield[k] = (ptrdiff_t)nfk++;
        memset(fr, 0, FR * sizeof(kf_v4));
        const size_t vol = (size_t)(to[0] - from[0]) * (size_t)(to[1] - from[1]) * (size_t)(to[2] - from[2]);
        uint64_t mask[(KF_CACHE_EDGE * KF_CACHE_EDGE * KF_CACHE_EDGE + 63) / 64];
        memcpy(mask, &d->unpack[u], (vol + 63) / 64 * sizeof *mask);
        u += mask_units(vol);
        size_t bit = 0;
        for (int a = from[0]; a < to[0]; a++)
            for (int b = from[1]; b < to[1]; b++)
                for (int c = from[2]; c < to[2]; c++, bit++) {
                    if (!(mask[bit / 64] >> (bit % 64) & 1)) continue;
                    for (int e = 0; e < FROWS; e++)
                        fr[(size_t)FROWS * (size_t)((a * CD + b) * CD + c) + (size_t)e] = d->unpack[u++];
                }
    }

    /* blocks for what arrived, and the arrivals by colour */
    if (nrecv > d->nfnb_cap) {
        free(d->fnb);
        free(d->forder);
        d->fnb = malloc(nrecv * sizeof *d->fnb);
        d->forder = malloc(nrecv * sizeof *d->forder);
        if (!d->fnb || !d->forder) return d->nfnb_cap = 0, -1;
        d->nfnb_cap = nrecv;
    }
    size_t cstart[9] = {0};
    for (size_t k = 0; k < nrecv; k++) {
        int32_t c[3];
        memcpy(c, &d->recv[k * rec], sizeof c);
        for (int e = 0; e < 8; e++) {
            int32_t id = kf_grid_ensure_block(g, c[0] + (e >> 2), c[1] + ((e >> 1) & 1), c[2] + (e & 1));
            if (id < 0) return -1;
            d->fnb[k][e] = id;
        }
        cstart[1 + colour_of(c)]++;
    }
    for (int c = 0; c < 8; c++) cstart[c + 1] += cstart[c];
    memcpy(d->fstart, cstart, sizeof cstart);
    for (size_t k = 0; k < nrecv; k++) {
        int32_t c[3];
        memcpy(c, &d->recv[k * rec], sizeof c);
        d->forder[cstart[colour_of(c)]++] = k;
    }
    d->nforeign = nrecv;
    return 0;
}

void kf_dist_p2g_colour(const kf_model *m, kf_state *s, int c) {
    struct kf_dist *d = s->dist;
    const int CD = kf_p2g_cache_edge(m);
    const size_t rec = 1 + (size_t)CD * CD * CD, FR = (size_t)KF_CONTACT_CACHE_ROWS * CD * CD * CD;
    /* same-colour owners write disjoint nodes: any order, any thread */
#pragma omp for schedule(dynamic, 4)
    for (size_t k = d->fstart[c]; k < d->fstart[c + 1]; k++) {
        size_t f = d->forder[k];
        int32_t head[4], lohi[6];
        memcpy(head, &d->recv[f * rec], sizeof head);
        for (int e = 0; e < 6; e++) lohi[e] = (head[3] >> (4 * e)) & 15;
        kf_p2g_add_cache(m, &s->g, d->fnb[f], d->recv + f * rec + 1, lohi);
        if (head[3] & HEAD_FIELDS) kf_contact_add_cache(m, s, d->fnb[f], d->frecv + (size_t)d->ffield[f] * FR, lohi);
    }
}
