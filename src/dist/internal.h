/* internal.h — what the files of src/dist share: the rank's part of the
 * decomposition, and the particle record that travels between ranks. */
#ifndef KF_DIST_INTERNAL_H
#define KF_DIST_INTERNAL_H

#include <mpi.h>

#include "../mpm/model.h"
#include "dist.h"

struct kf_dist {
    MPI_Comm comm;
    int rank, size;
    uint64_t *split; /* (size + 1) rank r owns block keys [split[r], split[r+1]) */
    /* the halo caches received this substep, by colour of their owner block */
    size_t nforeign;
    int32_t (*fnb)[8]; /* (nforeign) the receiver's block ids of each owner's 2x2x2 neighbourhood */
    size_t *forder;    /* (nforeign) indices grouped by colour */
    size_t fstart[9];
    kf_v4 *recv; /* received records: a header kf_v4 (block coordinate), then the cache */
    size_t recv_cap, nfnb_cap;
    kf_v4 *send;
    size_t send_cap;
    kf_v4 *pack, *unpack; /* the touched parts of the caches, out and in */
    size_t pack_cap, unpack_cap;
    /* field caches of owners on contact's field path (contact.h), out and
     * in; ffield: each received record's, or -1 */
    kf_v4 *fsend, *frecv;
    size_t fsend_cap, frecv_cap;
    ptrdiff_t *ffield;
    size_t ffield_cap;
    /* the owner payloads of kf_dist_owner_exchange, out and in */
    char *xsend, *xrecv;
    size_t xsend_cap, xrecv_cap;
    kf_dist_owner_msg *xmsg;
    size_t xmsg_cap;
    char *pbuf[2]; /* particle records out and in */
    size_t pbuf_cap[2];
    uint32_t *colour_save; /* CPIC colours kept while the halo's caches are made (halo.c) */
    /* every rank's owner block keys, ascending (the ranks' owners end to
     * end), gathered after each re-sort: a cache travels only to a rank
     * with an owner within reach (halo.c) */
    uint64_t *owner_keys;
    size_t nowner_keys, owner_keys_cap;
    int owners_stale;
    size_t colour_cap;
    int *counts; /* (4 * size) MPI counts and displacements */
    kf_dist_stats stats;
};

/* the rank whose range holds block key k */
static inline int kf_dist_rank_of(const struct kf_dist *d, uint64_t k) {
    int lo = 0, hi = d->size - 1;
    while (lo < hi) {
        int mid = (lo + hi + 1) / 2;
        if (d->split[mid] <= k) lo = mid;
        else hi = mid - 1;
    }
    return lo;
}

/* whether some rank has an owner block with this key (the owner keys are
 * every rank's, ascending: a binary search) */
static inline int kf_dist_is_owner(const struct kf_dist *d, uint64_t key) {
    size_t lo = 0, hi = d->nowner_keys;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (d->owner_keys[mid] < key) lo = mid + 1;
        else hi = mid;
    }
    return lo < d->nowner_keys && d->owner_keys[lo] == key;
}

/* the owner block key a sort gives a particle at x (its base node
 * recentred in a block); UINT64_MAX when binning will refuse it (NaN, out
 * of range) */
static inline uint64_t kf_dist_key_at(kf_real x0, kf_real x1, kf_real x2, kf_real inv_dx, int cubic) {
    const kf_real x[3] = {x0, x1, x2};
    const int limit = KF_KEY_OFFSET - 2, shift = kf_owner_shift(cubic);
    int b[3];
    for (int a = 0; a < 3; a++) {
        kf_real xg = x[a] * inv_dx;
        if (!(kf_fabs(xg) < (kf_real)(KF_BLOCK * (double)limit))) return UINT64_MAX;
        b[a] = kf_block_of(kf_base_node(x[a], inv_dx, cubic) - shift);
    }
    return kf_block_key(b[0], b[1], b[2]);
}

/* a decomposition whose ranges are not cut yet, or NULL */
struct kf_dist *kf_dist_new(void);
/* split[] cut from owner block keys, ascending, and their particle counts:
 * rank r starts at the first block before which r/size of them lie */
void kf_dist_cut(struct kf_dist *d, const uint64_t *key, const int64_t *count, size_t nb);
/* a particle array's capacity cut to its count */
void kf_dist_shrink(kf_particles *p);

/* the halo's pairs (owner, rank): each owner block whose nodes another
 * rank's owners share, and that rank; an owner's pairs adjacent, owners
 * ascending. *pairs is malloc'd. 0 or -1; collective (once per re-sort). */
int kf_dist_pairs(const kf_model *m, kf_state *s, int32_t **pairs, size_t *npairs);

/* bytes of one particle's record, and its packing */
size_t kf_dist_record_bytes(void);
void kf_dist_pack(const kf_particles *p, size_t i, char *dst);
void kf_dist_unpack(kf_particles *p, size_t j, const char *src);
/* a buffer of at least want bytes; 0 or -1 */
int kf_dist_reserve(void **buf, size_t *cap, size_t want);
/* MPI with its wall time counted */
double kf_dist_clock(void);

/* Rank 0's watchdog (watch.c): _start forks it before MPI starts; _say
 * tells it DONE (rank 0 exits and has said its piece; the pipe closes) or
 * SAID (a signal handler printed why the run stopped). Safe in a signal
 * handler; nothing without a watchdog. */
enum { KF_DIST_WATCH_DONE = 'D', KF_DIST_WATCH_SAID = 'S' };
void kf_dist_watch_start(void);
void kf_dist_watch_say(char c);
/* the line a run that stopped early ends with (async-signal-safe) */
void kf_dist_say_stopped(void);

#endif
