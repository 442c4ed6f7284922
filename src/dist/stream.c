/* stream.c — every rank's particles to rank 0 a window at a time, in the
 * one-rank order, so rank 0 writes a frame's files without the whole state
 * (dist.h). A window is a range [a, a + W) of positions in the one-rank
 * array: a stepped state's position is the rank's offset plus the index
 * (the ranks' parts end to end), a state as seeded has its id for
 * position. Either way a rank's positions rise along its array, so each
 * window takes the next slice of every rank's particles. */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* particles in one window: rank 0 holds this many besides its part */
enum { WINDOW = 1 << 15 };

int kf_dist_stream(const kf_state *s, kf_state *win, int by_id, kf_dist_put put, void *ctx) {
    struct kf_dist *d = s->dist;
    double t0 = kf_dist_clock();
    const size_t rb = kf_dist_record_bytes();
    const kf_particles *p = &s->p;
    long n = (long)p->n, total = 0, offset = 0;
    MPI_Allreduce(&n, &total, 1, MPI_LONG, MPI_SUM, d->comm);
    MPI_Exscan(&n, &offset, 1, MPI_LONG, MPI_SUM, d->comm);
    if (d->rank == 0) offset = 0; /* Exscan leaves rank 0's undefined */
    MPI_Datatype rec;
    MPI_Type_contiguous((int)rb, MPI_BYTE, &rec);
    MPI_Type_commit(&rec);
    int rc = 0;
    /* a window's records from one rank never exceed the window */
    if (kf_dist_reserve((void **)&d->pbuf[0], &d->pbuf_cap[0], WINDOW * rb) ||
        (d->rank == 0 && (kf_dist_reserve((void **)&d->pbuf[1], &d->pbuf_cap[1], WINDOW * rb) ||
                          kf_particles_reserve(&win->p, WINDOW))))
        MPI_Abort(d->comm, 1);
    int *cnt = d->counts, *displ = d->counts + d->size;
    size_t next = 0; /* this rank's first particle not sent yet */
    for (long a = 0; a < total; a += WINDOW) {
        const long end = a + WINDOW < total ? a + WINDOW : total;
        size_t j = next;
        while (j < (size_t)n && (by_id ? (long)p->id[j] : offset + (long)j) < end) j++;
        int m = (int)(j - next);
        for (int i = 0; i < m; i++) kf_dist_pack(p, next + (size_t)i, d->pbuf[0] + (size_t)i * rb);
        next = j;
        MPI_Gather(&m, 1, MPI_INT, cnt, 1, MPI_INT, 0, d->comm);
        size_t got = 0;
        if (d->rank == 0)
            for (int r = 0; r < d->size; r++) displ[r] = (int)got, got += (size_t)cnt[r];
        MPI_Gatherv(d->pbuf[0], m, rec, d->pbuf[1], cnt, displ, rec, 0, d->comm);
        if (d->rank != 0) continue;
        /* the window in order: records arrive in rank order, which is
         * position order for a stepped state; as seeded, each goes to its id */
        if (got != (size_t)(end - a)) rc = -1;
        for (size_t i = 0; rc == 0 && i < got; i++) {
            const char *src = d->pbuf[1] + i * rb;
            size_t at = i;
            if (by_id) {
                uint32_t id;
                memcpy(&id, src + KF_PARTICLE_REAL_PLANES * sizeof(kf_real), sizeof id);
                if ((long)id < a || (long)id >= end) {
                    rc = -1;
                    break;
                }
                at = (size_t)((long)id - a);
            }
            kf_dist_unpack(&win->p, at, src);
        }
        if (rc) continue; /* the others still send: every window is collective */
        win->p.n = got;
        win->time = s->time;
        win->substep = s->substep;
        win->next_id = s->next_id;
        win->tau_valid = s->tau_valid;
        win->g.valid = 0;
        rc = put(ctx, win, (size_t)a);
    }
    MPI_Type_free(&rec);
    d->stats.comm_ms += kf_dist_clock() - t0;
    return rc;
}
