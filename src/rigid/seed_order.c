/* seed_order.c — the seeding lattice of a mesh, and the one deterministic
 * order of lattice crossings (see seed_crossings.h). */
#include <math.h>
#include <stdlib.h>

#include "seed_crossings.h"

void kf_seed_lattice_for(const double lo[3], const double hi[3], double h, kf_seed_lattice *L) {
    /* offsets far from 0, 1/2 and simple fractions: an axis-aligned face or
     * edge at a round coordinate never holds a lattice line */
    static const double frac[3] = {0.3719, 0.5227, 0.6811};
    L->h = h;
    for (int a = 0; a < 3; a++) {
        L->o[a] = lo[a] - frac[a] * h;
        L->n[a] = (int32_t)floor((hi[a] - L->o[a]) / h) + 1;
    }
}

/* the sort key: the line, then the position along it, then the triangle
 * (so two triangles crossed at one point come in index order) */
static int cmp_crossing(const void *pa, const void *pb) {
    const kf_seed_crossing *p = pa, *q = pb;
    if (p->axis != q->axis) return p->axis < q->axis ? -1 : 1;
    if (p->j != q->j) return p->j < q->j ? -1 : 1;
    if (p->i != q->i) return p->i < q->i ? -1 : 1;
    double s = p->x[p->axis], t = q->x[q->axis];
    if (s != t) return s < t ? -1 : 1;
    if (p->tri != q->tri) return p->tri < q->tri ? -1 : 1;
    /* the same triangle twice on a line (cannot happen for a plane that the
     * line crosses once; kept total for qsort) */
    for (int k = 0; k < 3; k++)
        if (p->x[k] != q->x[k]) return p->x[k] < q->x[k] ? -1 : 1;
    return 0;
}

/* do triangles s and t share a corner position (welded or not) */
static int share_corner(const double *vert, const int *tri, int s, int t) {
    for (int m = 0; m < 3; m++)
        for (int k = 0; k < 3; k++) {
            const double *p = vert + 3 * (size_t)tri[3 * s + m], *q = vert + 3 * (size_t)tri[3 * t + k];
            if (p[0] == q[0] && p[1] == q[1] && p[2] == q[2]) return 1;
        }
    return 0;
}

size_t kf_seed_crossings_order(kf_seed_crossing *c, size_t n, const double *vert, const int *tri, double tol) {
    if (n < 2) return n;
    /* a line's few crossings (seed_rays.c orders line by line): insertion
     * sort, without qsort's call overhead; whole lists: qsort */
    if (n <= 32) {
        for (size_t k = 1; k < n; k++) {
            kf_seed_crossing x = c[k];
            size_t m = k;
            for (; m > 0 && cmp_crossing(&c[m - 1], &x) > 0; m--) c[m] = c[m - 1];
            c[m] = x;
        }
    } else qsort(c, n, sizeof *c, cmp_crossing);
    /* a line through a shared edge or vertex crosses every triangle there at
     * one point: keep the first (lowest triangle index at the lowest position) */
    size_t m = 1;
    for (size_t k = 1; k < n; k++) {
        const kf_seed_crossing *p = &c[m - 1], *q = &c[k];
        int same_line = p->axis == q->axis && p->i == q->i && p->j == q->j;
        if (same_line && fabs(q->x[q->axis] - p->x[p->axis]) <= tol &&
            (p->tri == q->tri || share_corner(vert, tri, p->tri, q->tri)))
            continue;
        c[m++] = *q;
    }
    return m;
}
