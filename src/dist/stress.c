/* stress.c — the stress pass across ranks, batch for batch as on one rank.
 *
 * kf_stress runs the particles in chunks of 64 of the array, and inside a
 * chunk SIMD batches of one material in lock step. A particle's stress no
 * longer depends on its batch mates (material_batch.c: full 16-lane batches,
 * per-lane convergence), so cutting the chunks as one rank does is no longer
 * needed for the bits; it is kept as it was. The ranks' arrays laid end to end are the one-rank
 * array (dist.h), so a rank's particle at local index i sits at global index
 * g0 + i: chunks are cut at global multiples of 64, and the (at most two)
 * chunks a rank shares with its neighbours are computed whole here, from
 * copies of the neighbours' particles in them. */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* the stress record: F, ps, material */
#define SREC (9 + 2 + 1)

typedef struct span {
    size_t lo, hi; /* global index range */
} span;

static span meet(span a, span b) {
    span r = {a.lo > b.lo ? a.lo : b.lo, a.hi < b.hi ? a.hi : b.hi};
    if (r.hi < r.lo) r.hi = r.lo;
    return r;
}

/* the chunks of [g0, g0 + n) shared with other ranks: head and tail, global */
static void shared_chunks(size_t g0, size_t n, size_t total, span *head, span *tail) {
    size_t hs = g0 / 64 * 64, he = hs + 64 < total ? hs + 64 : total;
    size_t ts = n ? (g0 + n - 1) / 64 * 64 : hs, te = ts + 64 < total ? ts + 64 : total;
    *head = (span){hs, he};
    *tail = (span){ts, te};
    if (!n || (hs == g0 && he <= g0 + n)) head->hi = head->lo; /* starts on a boundary and ends inside: not shared */
    if (!n || (te <= g0 + n && ts >= g0)) tail->hi = tail->lo;
    if (head->hi > head->lo && head->lo == tail->lo) tail->hi = tail->lo; /* one chunk */
}

/* compute one shared chunk: copies of the whole chunk, this rank's part
 * back; returns the chunk's particles at the limited stiffness when its
 * first particle is this rank's (each chunk counted once over the ranks),
 * else 0 */
static long one_chunk(const kf_model *m, kf_particles *p, size_t g0, span ch, const kf_real *recv, const size_t *from,
                      int project) {
    size_t len = ch.hi - ch.lo;
    if (!len) return 0;
    kf_real *buf = malloc(len * 17 * sizeof *buf + 1);
    uint16_t *mat = malloc(len * sizeof *mat + 1);
    if (!buf || !mat) kf_dist_abort(1);
    kf_real *F[9], *ps[2], *tau[6];
    for (int k = 0; k < 9; k++) F[k] = buf + (size_t)k * len;
    for (int k = 0; k < 2; k++) ps[k] = buf + (size_t)(9 + k) * len;
    for (int k = 0; k < 6; k++) tau[k] = buf + (size_t)(11 + k) * len;
    for (size_t j = 0; j < len; j++) {
        size_t gi = ch.lo + j;
        if (gi >= g0 && gi < g0 + p->n) {
            size_t i = gi - g0;
            for (int k = 0; k < 9; k++) F[k][j] = p->F[k][i];
            for (int k = 0; k < 2; k++) ps[k][j] = p->ps[k][i];
            mat[j] = p->mat[i];
        } else {
            const kf_real *r = recv + from[gi - ch.lo] * SREC;
            for (int k = 0; k < 9; k++) F[k][j] = r[k];
            for (int k = 0; k < 2; k++) ps[k][j] = r[9 + k];
            mat[j] = (uint16_t)r[11];
        }
    }
    long limited = kf_stress_span(m, F, ps, mat, tau, len, project);
    for (size_t j = 0; j < len; j++) {
        size_t gi = ch.lo + j;
        if (gi < g0 || gi >= g0 + p->n) continue;
        size_t i = gi - g0;
        for (int k = 0; k < 9; k++) p->F[k][i] = F[k][j];
        for (int k = 0; k < 2; k++) p->ps[k][i] = ps[k][j];
        for (int k = 0; k < 6; k++) p->tau[k][i] = tau[k][j];
    }
    free(buf);
    free(mat);
    return ch.lo >= g0 && ch.lo < g0 + p->n ? limited : 0;
}

long kf_dist_stress(const kf_model *m, kf_state *s, int project) {
    struct kf_dist *d = s->dist;
    kf_particles *p = &s->p;
    const int R = d->size;
    double t0 = kf_dist_clock();
    /* every rank's global range */
    unsigned long n = p->n, *all = malloc((size_t)R * sizeof *all);
    size_t *start = malloc(((size_t)R + 1) * sizeof *start);
    if (!all || !start) kf_dist_abort(1);
    MPI_Allgather(&n, 1, MPI_UNSIGNED_LONG, all, 1, MPI_UNSIGNED_LONG, d->comm);
    start[0] = 0;
    for (int r = 0; r < R; r++) start[r + 1] = start[r] + all[r];
    const size_t total = start[R], g0 = start[d->rank];

    /* what each rank needs from this one: its shared chunks met with this rank's range */
    int *scount = d->counts, *sdispl = d->counts + R, *rcount = d->counts + 2 * R, *rdispl = d->counts + 3 * R;
    span mine = {g0, g0 + n};
    size_t nsend = 0;
    for (int r = 0; r < R; r++) {
        span h, t;
        shared_chunks(start[r], all[r], total, &h, &t);
        size_t c = 0;
        if (r != d->rank) c = (meet(h, mine).hi - meet(h, mine).lo) + (meet(t, mine).hi - meet(t, mine).lo);
        scount[r] = (int)(c * SREC);
        sdispl[r] = (int)(nsend * SREC);
        nsend += c;
    }
    kf_real *sbuf = malloc((nsend + 1) * SREC * sizeof *sbuf);
    if (!sbuf) kf_dist_abort(1);
    for (int r = 0; r < R; r++) {
        if (r == d->rank || !scount[r]) continue;
        span h, t, parts[2];
        shared_chunks(start[r], all[r], total, &h, &t);
        parts[0] = meet(h, mine), parts[1] = meet(t, mine);
        kf_real *w = sbuf + sdispl[r];
        for (int q = 0; q < 2; q++)
            for (size_t gi = parts[q].lo; gi < parts[q].hi; gi++, w += SREC) {
                size_t i = gi - g0;
                for (int k = 0; k < 9; k++) w[k] = p->F[k][i];
                for (int k = 0; k < 2; k++) w[9 + k] = p->ps[k][i];
                w[11] = (kf_real)p->mat[i];
            }
    }
    /* and what this rank gets: the rest of its shared chunks, by owner rank */
    span head, tail;
    shared_chunks(g0, n, total, &head, &tail);
    size_t nrecv = 0;
    for (int r = 0; r < R; r++) {
        span them = {start[r], start[r + 1]};
        size_t c = 0;
        if (r != d->rank) c = (meet(head, them).hi - meet(head, them).lo) + (meet(tail, them).hi - meet(tail, them).lo);
        rcount[r] = (int)(c * SREC);
        rdispl[r] = (int)(nrecv * SREC);
        nrecv += c;
    }
    kf_real *rbuf = malloc((nrecv + 1) * SREC * sizeof *rbuf);
    size_t *hfrom = malloc((head.hi - head.lo + 1) * sizeof *hfrom),
           *tfrom = malloc((tail.hi - tail.lo + 1) * sizeof *tfrom);
    if (!rbuf || !hfrom || !tfrom) kf_dist_abort(1);
    MPI_Datatype real = sizeof(kf_real) == 8 ? MPI_DOUBLE : MPI_FLOAT;
    MPI_Alltoallv(sbuf, scount, sdispl, real, rbuf, rcount, rdispl, real, d->comm);
    /* where each copied particle's record landed (senders packed head part, then tail part) */
    for (int r = 0; r < R; r++) {
        if (r == d->rank) continue;
        span them = {start[r], start[r + 1]}, a = meet(head, them), b = meet(tail, them);
        size_t at = (size_t)rdispl[r] / SREC;
        for (size_t gi = a.lo; gi < a.hi; gi++) hfrom[gi - head.lo] = at++;
        for (size_t gi = b.lo; gi < b.hi; gi++) tfrom[gi - tail.lo] = at++;
    }
    d->stats.comm_ms += kf_dist_clock() - t0;

    /* the shared chunks whole; the chunks in between in place */
    long limited = one_chunk(m, p, g0, head, rbuf, hfrom, project);
    limited += one_chunk(m, p, g0, tail, rbuf, tfrom, project);
    size_t lo = head.hi > head.lo ? head.hi - g0 : 0, hi = tail.hi > tail.lo ? tail.lo - g0 : n;
    if (head.hi > head.lo && tail.hi == tail.lo && head.hi >= g0 + n) hi = lo; /* one shared chunk holds them all */
    if (hi > lo) {
        kf_real *F[9], *ps[2], *tau[6];
        for (int k = 0; k < 9; k++) F[k] = p->F[k] + lo;
        for (int k = 0; k < 2; k++) ps[k] = p->ps[k] + lo;
        for (int k = 0; k < 6; k++) tau[k] = p->tau[k] + lo;
        limited += kf_stress_span(m, F, ps, p->mat + lo, tau, hi - lo, project);
    }
    free(sbuf), free(rbuf), free(hfrom), free(tfrom), free(all), free(start);
    /* the particles at the limited stiffness, over all ranks (none without a limit) */
    long sum = 0;
    if (kf_model_c_limit(m) > 0) {
        t0 = kf_dist_clock();
        MPI_Allreduce(&limited, &sum, 1, MPI_LONG, MPI_SUM, d->comm);
        d->stats.comm_ms += kf_dist_clock() - t0;
    }
    return sum;
}
