/* pieces.c — what the labelling of pieces (contact_pieces.c) sends between
 * ranks: records about grid nodes to the ranks whose particles may link
 * with them, and a small table every rank gets whole. Both count as the
 * pieces' traffic in the frame log's balance line. */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* The other ranks a record about node q goes to, into r (at most 27):
 * those with an owner block o whose 2x2x2 neighbourhood (nodes 4o to
 * 4o + 7 along each axis) holds a node within one node of q along each
 * axis, o from ceil((q - 8) / 4) to floor((q + 1) / 4). A box of such
 * owners inside this rank's key range (its corner keys are: keys are
 * x-major) sends nowhere. */
static int destinations(const struct kf_dist *d, const int32_t q[3], int r[27]) {
    int lo[3], hi[3], nr = 0;
    for (int a = 0; a < 3; a++) lo[a] = -kf_block_of(8 - q[a]), hi[a] = kf_block_of(q[a] + 1);
    if (kf_block_key(lo[0], lo[1], lo[2]) >= d->split[d->rank] &&
        kf_block_key(hi[0], hi[1], hi[2]) < d->split[d->rank + 1])
        return 0;
    for (int x = lo[0]; x <= hi[0]; x++)
        for (int y = lo[1]; y <= hi[1]; y++)
            for (int z = lo[2]; z <= hi[2]; z++) {
                const uint64_t key = kf_block_key(x, y, z);
                const int k = kf_dist_rank_of(d, key);
                int seen = k == d->rank;
                for (int e = 0; e < nr && !seen; e++) seen = r[e] == k;
                if (!seen && kf_dist_is_owner(d, key)) r[nr++] = k;
            }
    return nr;
}

/* bytes out (scount per rank, in rank order) to the ranks, what arrives
 * into *in (malloc'd) with its counts and places in rcount, rdispl */
static char *swap(struct kf_dist *d, const char *out, const int *scount, int *rcount, int *rdispl, size_t *rtotal) {
    int *sdispl = malloc((size_t)d->size * sizeof *sdispl);
    if (!sdispl) return NULL;
    size_t total = 0;
    for (int r = 0; r < d->size; r++) sdispl[r] = (int)total, total += (size_t)scount[r];
    double t0 = kf_dist_clock();
    MPI_Alltoall(scount, 1, MPI_INT, rcount, 1, MPI_INT, d->comm);
    size_t rt = 0;
    for (int r = 0; r < d->size; r++) rdispl[r] = (int)rt, rt += (size_t)rcount[r];
    char *buf = malloc(rt + 8);
    if (!buf) MPI_Abort(d->comm, 1);
    MPI_Alltoallv(out, scount, sdispl, MPI_BYTE, buf, rcount, rdispl, MPI_BYTE, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
    d->stats.pieces_bytes += (double)total;
    free(sdispl);
    *rtotal = rt;
    return buf;
}

/* a block's nodes a rank holds records at: its key, a bit per node */
typedef struct {
    uint64_t key, mask;
} occupied;

typedef struct {
    int rank;
    uint64_t key, mask;
} occ_to;

static int by_rank_key(const void *x, const void *y) {
    const occ_to *a = x, *b = y;
    if (a->rank != b->rank) return a->rank < b->rank ? -1 : 1;
    return a->key < b->key ? -1 : a->key > b->key;
}

static void node_key(const int32_t q[3], uint64_t *key, uint64_t *bit) {
    *key = kf_block_key(kf_block_of(q[0]), kf_block_of(q[1]), kf_block_of(q[2]));
    *bit = 1ull << ((q[0] & 3) << 4 | (q[1] & 3) << 2 | (q[2] & 3));
}

/* whether a rank's blocks (sorted by key) hold node q or one next to it along an axis */
static int near_any(const occupied *o, size_t n, const int32_t q[3]) {
    for (int a = -1; a < 6; a++) {
        int32_t t[3] = {q[0], q[1], q[2]};
        if (a >= 0) t[a / 2] += a % 2 ? 1 : -1;
        uint64_t key, bit;
        node_key(t, &key, &bit);
        size_t lo = 0, hi = n;
        while (lo < hi) {
            size_t mid = (lo + hi) / 2;
            if (o[mid].key < key) lo = mid + 1;
            else hi = mid;
        }
        if (lo < n && o[lo].key == key && (o[lo].mask & bit)) return 1;
    }
    return 0;
}

/* Two rounds. First each rank tells the ranks its records may concern
 * (destinations) at which nodes it has records, a bit per node of each
 * block; then a record goes only to those of them holding a record at its
 * node or the next along an axis. Two records so linked each reach the
 * other's rank: each rank's first round names the other's node. */
int kf_dist_node_exchange(const kf_model *m, kf_state *s, const void *rec, size_t n, size_t size, void **in,
                          size_t *nin) {
    struct kf_dist *d = s->dist;
    /* every rank's owner keys, fresh after a re-sort (the pairs are not needed) */
    int32_t *pair = NULL;
    size_t npair = 0;
    if (kf_dist_pairs(m, s, &pair, &npair)) return -1;
    free(pair);
    const int R = d->size;
    int *cnt = calloc(4 * (size_t)R, sizeof *cnt);
    if (!cnt) return -1;
    int *scount = cnt, *sdispl = cnt + R, *rcount = cnt + 2 * R, *rdispl = cnt + 3 * R;

    /* the candidates (record, rank), in record order, and the blocks' bits for each rank */
    size_t nc = 0, cap = 256;
    occ_to *cand = malloc(cap * sizeof *cand);
    size_t *rec_of = malloc(cap * sizeof *rec_of);
    if (!cand || !rec_of) return free(cnt), free(cand), free(rec_of), -1;
    for (size_t i = 0; i < n; i++) {
        int32_t q[3];
        int to[27];
        memcpy(q, (const char *)rec + i * size, sizeof q);
        const int nr = destinations(d, q, to);
        if (nc + (size_t)nr > cap) {
            cap = 2 * (nc + (size_t)nr);
            occ_to *c2 = realloc(cand, cap * sizeof *cand);
            if (c2) cand = c2;
            size_t *r2 = c2 ? realloc(rec_of, cap * sizeof *rec_of) : NULL;
            if (!r2) return free(cnt), free(cand), free(rec_of), -1;
            rec_of = r2;
        }
        for (int e = 0; e < nr; e++) {
            cand[nc].rank = to[e];
            node_key(q, &cand[nc].key, &cand[nc].mask);
            rec_of[nc++] = i;
        }
    }
    occ_to *blk = malloc((nc + 1) * sizeof *blk);
    if (!blk) return free(cnt), free(cand), free(rec_of), -1;
    memcpy(blk, cand, nc * sizeof *blk);
    qsort(blk, nc, sizeof *blk, by_rank_key);
    size_t nb = 0;
    for (size_t k = 0; k < nc; k++) {
        if (nb && blk[nb - 1].rank == blk[k].rank && blk[nb - 1].key == blk[k].key) blk[nb - 1].mask |= blk[k].mask;
        else blk[nb++] = blk[k];
    }
    occupied *ob = malloc((nb + 1) * sizeof *ob);
    if (!ob) return free(cnt), free(cand), free(rec_of), free(blk), -1;
    for (size_t k = 0; k < nb; k++) {
        ob[k].key = blk[k].key, ob[k].mask = blk[k].mask;
        scount[blk[k].rank] += (int)sizeof *ob;
    }
    free(blk);
    size_t rt = 0;
    occupied *theirs = (occupied *)swap(d, (const char *)ob, scount, rcount, rdispl, &rt);
    free(ob);
    if (!theirs) return free(cnt), free(cand), free(rec_of), -1;

    /* the records each rank's blocks are next to, in record order */
    memset(scount, 0, (size_t)R * sizeof *scount);
    char *keepc = malloc(nc + 1);
    if (!keepc) return free(cnt), free(cand), free(rec_of), free(theirs), -1;
    for (size_t k = 0; k < nc; k++) {
        int32_t q[3];
        const int r = cand[k].rank;
        memcpy(q, (const char *)rec + rec_of[k] * size, sizeof q);
        keepc[k] = (char)near_any(theirs + rdispl[r] / (int)sizeof *theirs, (size_t)rcount[r] / sizeof *theirs, q);
        if (keepc[k]) scount[r] += (int)size;
    }
    free(theirs);
    size_t total = 0;
    for (int r = 0; r < R; r++) sdispl[r] = (int)total, total += (size_t)scount[r];
    char *out = malloc(total + 8);
    if (!out) return free(cnt), free(cand), free(rec_of), free(keepc), -1;
    for (size_t k = 0; k < nc; k++)
        if (keepc[k]) {
            memcpy(out + sdispl[cand[k].rank], (const char *)rec + rec_of[k] * size, size);
            sdispl[cand[k].rank] += (int)size;
        }
    free(cand);
    free(rec_of);
    free(keepc);
    char *buf = swap(d, out, scount, rcount, rdispl, &rt);
    free(out);
    free(cnt);
    if (!buf) return -1;
    *in = buf;
    *nin = rt / size;
    return 0;
}

int kf_dist_pieces_gather(kf_state *s, const void *mine, size_t bytes, size_t nclass, void **all, size_t *all_bytes) {
    struct kf_dist *d = s->dist;
    if (kf_dist_allgather(s, mine, bytes, all, all_bytes)) return -1;
    /* every other rank receives this rank's bytes */
    d->stats.pieces_bytes += (double)bytes * (double)(d->size - 1);
    d->stats.pieces_classes += (double)nclass;
    return 0;
}

void kf_dist_pieces_split(kf_state *s) { s->dist->stats.pieces_splits++; }
