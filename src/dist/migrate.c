/* migrate.c — particles to the rank whose key range holds their block.
 *
 * The new array is what arrives from each rank, in rank order, with this
 * rank's own particles in its place: the ranks' arrays end to end are the
 * one-rank array, so this is the one-rank array's subsequence of particles
 * in this rank's range, and kerf's stable sort by block (kf_grid_bin) then
 * gives them the one-rank order. */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* the key a sort gives particle i; UINT64_MAX: it stays here and binning
 * reports it */
static uint64_t new_key(const kf_particles *p, size_t i, kf_real inv_dx, int cubic) {
    return kf_dist_key_at(p->x[0][i], p->x[1][i], p->x[2][i], inv_dx, cubic);
}

/* whether binning would sort now: the grid is not valid, or a particle's
 * stencil left its owner's neighbourhood (or is not a number) */
static int needs_sort(const kf_grid *g, const kf_particles *p, kf_real inv_dx, int cubic, int threads) {
    if (!g->valid) return 1;
    const int limit = KF_KEY_OFFSET - 2, lmax = kf_owner_lmax(cubic);
    long out = 0;
    const size_t nowner = g->nowner;
    /* owner r (block id r) holds particles pstart[r]..pstart[r+1] (grid.c) */
#pragma omp parallel for reduction(+ : out) schedule(dynamic, 64) num_threads(threads)
    for (size_t r = 0; r < nowner; r++) {
        const int32_t *bc = &g->bcoord[3 * r];
        for (size_t i = g->pstart[r]; i < g->pstart[r + 1]; i++)
            for (int a = 0; a < 3; a++) {
                kf_real xg = p->x[a][i] * inv_dx;
                if (!(kf_fabs(xg) < (kf_real)(KF_BLOCK * (double)limit))) {
                    out++;
                    break;
                }
                int l = kf_base_node(p->x[a][i], inv_dx, cubic) - KF_BLOCK * bc[a];
                if (l < 0 || l > lmax) {
                    out++;
                    break;
                }
            }
    }
    return out > 0;
}

int kf_dist_migrate(const kf_model *m, kf_state *s) {
    struct kf_dist *d = s->dist;
    kf_particles *p = &s->p;
    const size_t n = p->n, rb = kf_dist_record_bytes();
    const kf_real inv_dx = kf_model_inv_dx(m);
    const int cubic = m->sim.kernel == KF_KERNEL_CUBIC;
    /* one rank sorts every particle when any stencil left its owner's
     * neighbourhood, and otherwise none: so do all ranks together */
    int need = needs_sort(&s->g, p, inv_dx, cubic, m->nthreads), any_sort = 0;
    double tq = kf_dist_clock();
    MPI_Allreduce(&need, &any_sort, 1, MPI_INT, MPI_LOR, d->comm);
    d->stats.comm_ms += kf_dist_clock() - tq;
    if (!any_sort) return 0;
    s->g.valid = 0;
    d->owners_stale = 1; /* every rank's owners change: the halo gathers them again */
    int *scount = d->counts, *sdispl = d->counts + d->size, *rcount = d->counts + 2 * d->size,
        *rdispl = d->counts + 3 * d->size;
    /* where each particle goes (the key array holds it until packed) */
    memset(scount, 0, (size_t)d->size * sizeof *scount);
    uint8_t *stay = (uint8_t *)malloc(n + 1);
    int *dest = malloc((n + 1) * sizeof *dest);
    if (!stay || !dest) return free(stay), free(dest), -1;
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t i = 0; i < n; i++) {
        uint64_t k = new_key(p, i, inv_dx, cubic);
        dest[i] = k == UINT64_MAX ? d->rank : kf_dist_rank_of(d, k);
    }
    for (size_t i = 0; i < n; i++) {
        stay[i] = dest[i] == d->rank;
        if (!stay[i]) scount[dest[i]]++;
    }
    double t0 = kf_dist_clock();
    MPI_Alltoall(scount, 1, MPI_INT, rcount, 1, MPI_INT, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
    size_t nsend = 0, nrecv = 0;
    for (int r = 0; r < d->size; r++) {
        sdispl[r] = (int)nsend, nsend += (size_t)scount[r];
        rdispl[r] = (int)nrecv, nrecv += (size_t)rcount[r];
    }
    /* the exchange is collective: skipped only when no rank sends */
    long sent = (long)nsend, any = 0;
    t0 = kf_dist_clock();
    MPI_Allreduce(&sent, &any, 1, MPI_LONG, MPI_SUM, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
    if (any == 0) return free(stay), free(dest), 0;

    if (kf_dist_reserve((void **)&d->pbuf[0], &d->pbuf_cap[0], nsend * rb + 1) ||
        kf_dist_reserve((void **)&d->pbuf[1], &d->pbuf_cap[1], nrecv * rb + 1))
        return free(stay), free(dest), -1;
    {
        /* pack in array order per destination */
        int *at = malloc((size_t)d->size * sizeof *at);
        if (!at) return free(stay), free(dest), -1;
        memcpy(at, sdispl, (size_t)d->size * sizeof *at);
        for (size_t i = 0; i < n; i++)
            if (!stay[i]) kf_dist_pack(p, i, d->pbuf[0] + (size_t)at[dest[i]]++ * rb);
        free(at);
    }
    MPI_Datatype rec;
    MPI_Type_contiguous((int)rb, MPI_BYTE, &rec);
    MPI_Type_commit(&rec);
    t0 = kf_dist_clock();
    MPI_Alltoallv(d->pbuf[0], scount, sdispl, rec, d->pbuf[1], rcount, rdispl, rec, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
    MPI_Type_free(&rec);

    if (nsend == 0 && nrecv == 0) return free(stay), free(dest), 0; /* nothing changes here */
    /* The new array, in place (no second copy of the part): this rank's own
     * particles close up in order, move up past what the ranks before this
     * one send, and the arrivals fill in before and after them. */
    const size_t keep = n - nsend, total = keep + nrecv, low = (size_t)rdispl[d->rank];
    if (nsend) {
        for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) {
            kf_real *a = p->plane[k];
            size_t j = 0;
            for (size_t i = 0; i < n; i++)
                if (stay[i]) a[j++] = a[i];
        }
        uint16_t *mat = p->mat, *obj = p->obj;
        uint32_t *colour = p->colour, *id = p->id;
        size_t j = 0;
        for (size_t i = 0; i < n; i++)
            if (stay[i]) mat[j] = mat[i], obj[j] = obj[i], colour[j] = colour[i], id[j] = id[i], j++;
    }
    if (kf_particles_reserve(p, total + 1)) return free(stay), free(dest), -1;
    if (low) {
        for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++)
            memmove(p->plane[k] + low, p->plane[k], keep * sizeof(kf_real));
        memmove(p->mat + low, p->mat, keep * sizeof *p->mat);
        memmove(p->obj + low, p->obj, keep * sizeof *p->obj);
        memmove(p->colour + low, p->colour, keep * sizeof *p->colour);
        memmove(p->id + low, p->id, keep * sizeof *p->id);
    }
    for (int r = 0; r < d->size; r++) {
        size_t at = (size_t)rdispl[r] + (r > d->rank ? keep : 0);
        for (int q = 0; q < rcount[r]; q++)
            kf_dist_unpack(p, at + (size_t)q, d->pbuf[1] + ((size_t)rdispl[r] + (size_t)q) * rb);
    }
    p->n = total;
    s->g.valid = 0;
    d->stats.migrated += (double)nsend;
    free(stay);
    free(dest);
    return 0;
}
