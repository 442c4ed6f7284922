/* exchange.c — a payload per boundary owner block, to the ranks that share
 * its nodes: what contact between objects needs of other ranks' owners
 * before their caches travel (the owner's field and box, then the fields
 * its particles claim at each node: contact.c). */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* a record on the wire: the owner's block coordinate, the payload's bytes,
 * then the payload padded to 8 bytes */
typedef struct {
    int32_t bc[3];
    uint32_t bytes;
} wire_head;

static size_t padded(size_t b) { return (b + 7) / 8 * 8; }

int kf_dist_owner_exchange(const kf_model *m, kf_state *s, kf_dist_owner_put put, size_t max, void *ctx,
                           kf_dist_owner_msg **in, size_t *nin) {
    struct kf_dist *d = s->dist;
    kf_grid *g = &s->g;
    int *scount = d->counts, *sdispl = d->counts + d->size, *rcount = d->counts + 2 * d->size,
        *rdispl = d->counts + 3 * d->size;
    int32_t *pair = NULL;
    size_t npair = 0;
    if (kf_dist_pairs(m, s, &pair, &npair)) return -1;
    /* each owner's payload once (its pairs are adjacent), sizes first */
    const size_t recmax = sizeof(wire_head) + padded(max);
    char *one = malloc(recmax);
    size_t *len = malloc((npair + 1) * sizeof *len);
    if (!one || !len) return free(pair), free(one), free(len), -1;
    memset(scount, 0, (size_t)d->size * sizeof *scount);
    size_t total = 0;
    for (size_t k = 0; k < npair; k++) {
        if (k == 0 || pair[2 * k] != pair[2 * (k - 1)]) len[k] = put(ctx, (size_t)pair[2 * k], NULL);
        else len[k] = len[k - 1];
        if (!len[k]) continue;
        scount[pair[2 * k + 1]] += (int)(sizeof(wire_head) + padded(len[k]));
        total += sizeof(wire_head) + padded(len[k]);
    }
    for (int r = 0, at = 0; r < d->size; r++) sdispl[r] = at, at += scount[r];
    if (kf_dist_reserve((void **)&d->xsend, &d->xsend_cap, total + 8)) return free(pair), free(one), free(len), -1;
    /* pairs are in owner order, so each rank's records go in owner order too */
    int *at = malloc((size_t)d->size * sizeof *at);
    if (!at) return free(pair), free(one), free(len), -1;
    memcpy(at, sdispl, (size_t)d->size * sizeof *at);
    for (size_t k = 0; k < npair; k++) {
        if (!len[k]) continue;
        const size_t o = (size_t)pair[2 * k];
        if (k == 0 || pair[2 * k] != pair[2 * (k - 1)]) {
            wire_head h = {{g->bcoord[3 * o], g->bcoord[3 * o + 1], g->bcoord[3 * o + 2]}, (uint32_t)len[k]};
            memset(one, 0, recmax);
            memcpy(one, &h, sizeof h);
            put(ctx, o, one + sizeof h);
        }
        size_t b = sizeof(wire_head) + padded(len[k]);
        memcpy(d->xsend + at[pair[2 * k + 1]], one, b);
        at[pair[2 * k + 1]] += (int)b;
    }
    free(at);
    free(one);
    free(len);
    free(pair);

    double t0 = kf_dist_clock();
    MPI_Alltoall(scount, 1, MPI_INT, rcount, 1, MPI_INT, d->comm);
    size_t rtotal = 0;
    for (int r = 0; r < d->size; r++) rdispl[r] = (int)rtotal, rtotal += (size_t)rcount[r];
    if (kf_dist_reserve((void **)&d->xrecv, &d->xrecv_cap, rtotal + 8)) MPI_Abort(d->comm, 1);
    MPI_Alltoallv(d->xsend, scount, sdispl, MPI_BYTE, d->xrecv, rcount, rdispl, MPI_BYTE, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
    d->stats.halo_bytes += (double)total;

    /* the records, with this rank's blocks of each owner's neighbourhood */
    size_t n = 0;
    for (size_t u = 0; u < rtotal; n++) {
        wire_head h;
        memcpy(&h, d->xrecv + u, sizeof h);
        u += sizeof h + padded(h.bytes);
    }
    if (kf_dist_reserve((void **)&d->xmsg, &d->xmsg_cap, (n + 1) * sizeof *d->xmsg)) return -1;
    for (size_t u = 0, k = 0; k < n; k++) {
        wire_head h;
        memcpy(&h, d->xrecv + u, sizeof h);
        kf_dist_owner_msg *msg = &d->xmsg[k];
        memcpy(msg->bc, h.bc, sizeof h.bc);
        for (int e = 0; e < 8; e++) {
            msg->nb[e] = kf_grid_ensure_block(g, h.bc[0] + (e >> 2), h.bc[1] + ((e >> 1) & 1), h.bc[2] + (e & 1));
            if (msg->nb[e] < 0) return -1;
        }
        msg->bytes = h.bytes;
        msg->data = d->xrecv + u + sizeof h;
        u += sizeof h + padded(h.bytes);
    }
    *in = d->xmsg;
    *nin = n;
    return 0;
}

int kf_dist_allgather(const kf_state *s, const void *mine, size_t bytes, void **all, size_t *all_bytes) {
    struct kf_dist *d = s->dist;
    int *cnt = malloc(2 * (size_t)d->size * sizeof *cnt);
    if (!cnt) return -1;
    int *displ = cnt + d->size, n = (int)bytes;
    double t0 = kf_dist_clock();
    MPI_Allgather(&n, 1, MPI_INT, cnt, 1, MPI_INT, d->comm);
    size_t total = 0;
    for (int r = 0; r < d->size; r++) displ[r] = (int)total, total += (size_t)cnt[r];
    char *buf = malloc(total + 8);
    if (!buf) MPI_Abort(d->comm, 1);
    MPI_Allgatherv(mine, n, MPI_BYTE, buf, cnt, displ, MPI_BYTE, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
    free(cnt);
    *all = buf;
    *all_bytes = total;
    return 0;
}

size_t kf_dist_first_index(const kf_state *s) {
    struct kf_dist *d = s->dist;
    unsigned long long n = s->p.n, before = 0;
    double t0 = kf_dist_clock();
    MPI_Exscan(&n, &before, 1, MPI_UNSIGNED_LONG_LONG, MPI_SUM, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
    return d->rank == 0 ? 0 : (size_t)before;
}
