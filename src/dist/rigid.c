/* rigid.c — CPIC and the rigid bodies across ranks: the grid's extent for
 * the splat, and the material's impulses on the bodies summed as one rank
 * sums them (dist.h). */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

void kf_dist_extent(const kf_state *s, double lo[3], double hi[3]) {
    struct kf_dist *d = s->dist;
    double t0 = kf_dist_clock();
    MPI_Allreduce(MPI_IN_PLACE, lo, 3, MPI_DOUBLE, MPI_MIN, d->comm);
    MPI_Allreduce(MPI_IN_PLACE, hi, 3, MPI_DOUBLE, MPI_MAX, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
}

void kf_dist_rigid_sum(const kf_state *s, int nrigid, size_t nslot, const double *imp, size_t stride,
                       const long *caught, const double *depth, double *sum, long *caught_sum, double *depth_max) {
    struct kf_dist *d = s->dist;
    /* a row per band owner: the bodies' six impulse values, then the
     * guard's catches (a count, exact in a double) and its deepest catch */
    const size_t w = (size_t)nrigid * 6 + 2;
    int *cnt = d->counts, *displ = d->counts + d->size;
    int mine = (int)(nslot * w);
    double t0 = kf_dist_clock();
    MPI_Allgather(&mine, 1, MPI_INT, cnt, 1, MPI_INT, d->comm);
    size_t all = 0;
    for (int r = 0; r < d->size; r++) displ[r] = (int)all, all += (size_t)cnt[r];
    double *out = malloc((size_t)mine * sizeof *out + 8), *in = malloc(all * sizeof *in + 8);
    if (!out || !in) MPI_Abort(d->comm, 1);
    for (size_t k = 0; k < nslot; k++) {
        double *row = out + k * w;
        memcpy(row, imp + k * stride, (size_t)nrigid * 6 * sizeof *row);
        row[w - 2] = (double)caught[k];
        row[w - 1] = depth[k];
    }
    MPI_Allgatherv(out, mine, MPI_DOUBLE, in, cnt, displ, MPI_DOUBLE, d->comm);
    d->stats.comm_ms += kf_dist_clock() - t0;
    /* the one-rank loops (kf_cpic_finish) over the rows in rank order */
    memset(sum, 0, (size_t)KF_MAX_RIGIDS * 6 * sizeof *sum);
    const size_t rows = all / w;
    for (size_t k = 0; k < rows; k++)
        for (int r = 0; r < nrigid; r++)
            for (int e = 0; e < 6; e++) sum[6 * r + e] += in[k * w + 6 * (size_t)r + (size_t)e];
    long c = 0;
    double deep = 0;
    for (size_t k = 0; k < rows; k++) {
        c += (long)in[k * w + w - 2];
        if (in[k * w + w - 1] > deep) deep = in[k * w + w - 1];
    }
    *caught_sum = c;
    *depth_max = deep;
    free(out);
    free(in);
}
