/* seed.c — rigid particles on a surface (paper §5.2.1).
 *
 * Two passes, both deterministic (the same seeds for any thread count):
 *
 * 1. Lattice crossings. The lines of an axis-aligned lattice of step
 *    h = 0.7 spacing, along each of the three axes, cross the surface; each
 *    crossing is a seed on the triangle it crosses. Embree rays along the
 *    lines find every crossing, not only the first on a line
 *    (seed_rays.c), sorted into one order with the repeats at shared
 *    edges and vertices removed (seed_order.c). The crossings are a
 *    property of the surface, not of its triangulation, so a flat region
 *    gets the same seeds however it is cut into triangles. On the lines of
 *    the axis most normal to a triangle, the crossings form a lattice whose
 *    cells have diagonals of at most h√3, so no interior point is farther
 *    than h from one (the circumradius bound h√3/√3).
 *
 * 2. Holes. Near a triangle's edges, on triangles smaller than the lattice
 *    and on slivers, crossings can be missing. Every triangle is checked on
 *    its own points δ = spacing/8 apart (rows parallel to its longest edge,
 *    and its three edges); any check point farther than spacing − 1.5δ from
 *    every seed becomes a seed. Any point of a triangle is within δ√2/2 of a
 *    check point, so afterwards within spacing of a seed. A triangle no
 *    crossing hit gets a seed at its centroid first. The check points are
 *    what costs: a point is first tried against the previous point's
 *    seed, and the points that seed is sure to cover are skipped (the
 *    same seeds as checking every point, at about a third of the checks). */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rigid.h"
#include "../core/mat3.h"
#include "seed_crossings.h"

typedef struct seeds {
    double *x;    /* (n x 3) */
    int32_t *tri; /* (n) */
    size_t n, cap;
    int oom;
} seeds;

static void push(seeds *s, const double p[3], int t) {
    if (s->oom) return;
    if (s->n == s->cap) {
        size_t cap = s->cap ? 2 * s->cap : 4096;
        double *x = realloc(s->x, sizeof(double) * 3 * cap);
        if (x) s->x = x;
        int32_t *tr = realloc(s->tri, sizeof(int32_t) * cap);
        if (tr) s->tri = tr;
        if (!x || !tr) {
            s->oom = 1;
            return;
        }
        s->cap = cap;
    }
    memcpy(s->x + 3 * s->n, p, 3 * sizeof(double));
    s->tri[s->n++] = t;
}

/* ---- a hash grid over the seeds (cell = 2 spacing) ----------------------- */

/* Pass 1's seeds are laid out bucket by bucket with their positions (one
 * contiguous run per bucket: a lookup reads a bucket's seeds without
 * following links through the seed array); the few seeds pass 2 adds go on
 * per-bucket chains. */
typedef struct hg_entry {
    double x[3];
    int64_t idx;
} hg_entry;

typedef struct hgrid {
    double cell, o[3];
    uint32_t mask;
    size_t *start;        /* (buckets + 1) bucket b's pass-1 seeds are run[start[b] .. start[b+1]) */
    hg_entry *run;        /* (pass-1 seeds) */
    int64_t *head, *next; /* chains of the seeds added later, -1 ends */
    size_t cap;
} hgrid;

static uint32_t hash3(int64_t i, int64_t j, int64_t k, uint32_t mask) {
    uint64_t h = (uint64_t)i * 73856093u ^ (uint64_t)j * 19349663u ^ (uint64_t)k * 83492791u;
    return (uint32_t)(h ^ (h >> 29)) & mask;
}

static int64_t cellof(const hgrid *g, const double *x, int a) { return (int64_t)floor((x[a] - g->o[a]) / g->cell); }

static uint32_t bucket(const hgrid *g, const double *x) {
    return hash3(cellof(g, x, 0), cellof(g, x, 1), cellof(g, x, 2), g->mask);
}

/* the grid of seeds 0 .. n-1 (a counting sort by bucket) */
static int hg_build(hgrid *g, const seeds *s, double cell, const double o[3]) {
    g->cell = cell;
    memcpy(g->o, o, sizeof g->o);
    size_t tab = 1024;
    while (tab < 2 * s->n) tab *= 2;
    g->mask = (uint32_t)(tab - 1);
    g->start = calloc(tab + 1, sizeof *g->start);
    g->run = malloc(sizeof *g->run * (s->n ? s->n : 1));
    g->head = malloc(sizeof *g->head * tab);
    uint32_t *bk = malloc(sizeof *bk * (s->n ? s->n : 1));
    if (!g->start || !g->run || !g->head || !bk) {
        free(bk);
        return -1;
    }
    for (size_t i = 0; i < tab; i++) g->head[i] = -1;
    for (size_t i = 0; i < s->n; i++) g->start[(bk[i] = bucket(g, s->x + 3 * i)) + 1]++;
    for (size_t b = 0; b < tab; b++) g->start[b + 1] += g->start[b];
    for (size_t i = 0; i < s->n; i++) {
        hg_entry *e = &g->run[g->start[bk[i]]++];
        memcpy(e->x, s->x + 3 * i, sizeof e->x);
        e->idx = (int64_t)i;
    }
    /* the fill moved each start to the next bucket's: shift back */
    for (size_t b = tab; b > 0; b--) g->start[b] = g->start[b - 1];
    g->start[0] = 0;
    free(bk);
    return 0;
}

/* a seed added after the build: on its bucket's chain */
static int hg_insert(hgrid *g, const seeds *s, size_t idx) {
    if (idx >= g->cap) {
        size_t cap = g->cap ? 2 * g->cap : 4096;
        while (cap <= idx) cap *= 2;
        int64_t *nx = realloc(g->next, sizeof(int64_t) * cap);
        if (!nx) return -1;
        g->next = nx, g->cap = cap;
    }
    uint32_t h = bucket(g, s->x + 3 * idx);
    g->next[idx] = g->head[h];
    g->head[h] = (int64_t)idx;
    return 0;
}

static void hg_free(hgrid *g) {
    free(g->start);
    free(g->run);
    free(g->head);
    free(g->next);
    g->start = NULL, g->run = NULL, g->head = NULL, g->next = NULL;
}

/* the index of the seed nearest to p within r, or -1. Only the cells the
 * ball's bounding box overlaps are visited: with r < spacing and cells of
 * 2 spacing, 1 or 2 along each axis, about 6 cells in all (cells of one
 * spacing: 2 or 3 along each axis, about 18 cells for the same seeds). */
static int64_t hg_nearest(const hgrid *g, const seeds *s, const double p[3], double r) {
    int64_t lo[3], hi[3];
    for (int a = 0; a < 3; a++) {
        lo[a] = (int64_t)floor((p[a] - r - g->o[a]) / g->cell);
        hi[a] = (int64_t)floor((p[a] + r - g->o[a]) / g->cell);
    }
    double best = r * r;
    int64_t found = -1;
    for (int64_t i = lo[0]; i <= hi[0]; i++)
        for (int64_t j = lo[1]; j <= hi[1]; j++)
            for (int64_t k = lo[2]; k <= hi[2]; k++) {
                uint32_t h = hash3(i, j, k, g->mask);
                for (size_t q = g->start[h]; q < g->start[h + 1]; q++) {
                    const hg_entry *e = &g->run[q];
                    double d[3] = {e->x[0] - p[0], e->x[1] - p[1], e->x[2] - p[2]}, d2 = kf_v3d_dot(d, d);
                    if (d2 < best || (d2 == best && found < 0)) best = d2, found = e->idx;
                }
                for (int64_t q = g->head[h]; q >= 0; q = g->next[q]) {
                    const double *x = s->x + 3 * q;
                    double d[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]}, d2 = kf_v3d_dot(d, d);
                    if (d2 < best || (d2 == best && found < 0)) best = d2, found = q;
                }
            }
    return found;
}

/* ---- pass 2: holes ------------------------------------------------------- */

/* check point p of triangle t: a seed there if none is within r. The
 * nearest seed of the previous check point (*last) is tried first: the
 * check points come δ apart, so it usually still covers p, and a seed
 * within r is all the check asks for (the same answer as a grid search).
 * *dist: how far the covering seed is from p (0 for a new seed). */
static int check(hgrid *g, seeds *s, const double p[3], int t, double r, int64_t *last, double *dist) {
    if (*last >= 0) {
        const double *x = s->x + 3 * *last;
        double d[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]}, d2 = kf_v3d_dot(d, d);
        if (d2 <= r * r) {
            *dist = sqrt(d2);
            return 0;
        }
    }
    *last = hg_nearest(g, s, p, r);
    if (*last >= 0) {
        const double *x = s->x + 3 * *last;
        double d[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]};
        *dist = sqrt(kf_v3d_dot(d, d));
        return 0;
    }
    *dist = 0;
    push(s, p, t);
    if (s->oom) return -1;
    *last = (int64_t)s->n - 1;
    return hg_insert(g, s, s->n - 1);
}

/* the check points p0 + (i/n) d, i = i0..i1, of a row or an edge. A point
 * whose covering seed is dist from it covers the next m points too, while
 * m steps (each |d|/n) stay within r - dist: those are skipped (with a
 * relative margin of 1e-9 against the round-off of the points' positions) */
static int check_row(hgrid *g, seeds *s, const double p0[3], const double d[3], int n, int i0, int i1, int t, double r,
                     int64_t *last) {
    const double step = n ? sqrt(kf_v3d_dot(d, d)) / n : 0;
    for (int i = i0; i <= i1; i++) {
        double f = n ? (double)i / n : 0, p[3], dist;
        for (int a = 0; a < 3; a++) p[a] = p0[a] + f * d[a];
        if (check(g, s, p, t, r, last, &dist)) return -1;
        if (step > 0) {
            double m = floor((r - dist) * (1 - 1e-9) / step);
            if (m > 0) i += m < i1 - i ? (int)m : i1 - i;
        }
    }
    return 0;
}

static int fill_holes(hgrid *g, seeds *s, const double *P[3], int t, double delta, double r) {
    /* the longest edge A→B, the third corner C */
    int k = 0;
    double best = -1;
    for (int e = 0; e < 3; e++) {
        const double *p = P[e], *q = P[(e + 1) % 3];
        double d[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, l = kf_v3d_dot(d, d);
        if (l > best) best = l, k = e;
    }
    const double *A = P[k], *B = P[(k + 1) % 3], *C = P[(k + 2) % 3];
    double ab[3] = {B[0] - A[0], B[1] - A[1], B[2] - A[2]}, ac[3] = {C[0] - A[0], C[1] - A[1], C[2] - A[2]};
    double L = sqrt(kf_v3d_dot(ab, ab));
    int64_t last = -1;
    double dist;
    if (!(L > 0)) return check(g, s, A, t, r, &last, &dist);
    double ux = kf_v3d_dot(ac, ab) / L; /* C's position along AB, in [0, L] */
    double hv[3];
    for (int a = 0; a < 3; a++) hv[a] = ac[a] - ux * ab[a] / L;
    double H = sqrt(kf_v3d_dot(hv, hv));
    /* rows parallel to AB, from AB (row 0) to C */
    int ny = (int)ceil(H / delta);
    for (int row = 0; row <= ny; row++) {
        double f = ny ? (double)row / ny : 0; /* fraction of the way to C */
        /* the row runs from A + f (C - A) to B + f (C - B) */
        double p0[3], p1[3];
        for (int a = 0; a < 3; a++) p0[a] = A[a] + f * ac[a], p1[a] = B[a] + f * (C[a] - B[a]);
        double d[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        int nx = (int)ceil(sqrt(kf_v3d_dot(d, d)) / delta);
        if (check_row(g, s, p0, d, nx, 0, nx, t, r, &last)) return -1;
    }
    /* the two other edges, δ apart (the rows' ends may be far apart on a sliver) */
    const double *E[2][2] = {{A, C}, {B, C}};
    for (int e = 0; e < 2; e++) {
        double d[3] = {E[e][1][0] - E[e][0][0], E[e][1][1] - E[e][0][1], E[e][1][2] - E[e][0][2]};
        int n = (int)ceil(sqrt(kf_v3d_dot(d, d)) / delta);
        if (check_row(g, s, E[e][0], d, n, 1, n - 1, t, r, &last)) return -1;
    }
    return 0;
}

size_t kf_rigid_seed_surface(const double *vert, int nvert, const int *tri, int ntri, double spacing, float **seed,
                             int32_t **seed_tri) {
    *seed = NULL, *seed_tri = NULL;
    if (!(spacing > 0) || !isfinite(spacing) || ntri < 1 || nvert < 3) return 0;
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < nvert; i++)
        for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], vert[3 * i + a]), hi[a] = fmax(hi[a], vert[3 * i + a]);
    /* pass 1: the lattice (step 0.7 spacing) and its crossings, by Embree */
    kf_seed_lattice L;
    kf_seed_lattice_for(lo, hi, 0.7 * spacing, &L);
    kf_seed_crossing *cx;
    char err[256];
    long ncx = kf_seed_crossings_rays(vert, nvert, tri, ntri, &L, &cx, err, sizeof err);
    if (ncx < 0) return 0;
    seeds s = {0};
    hgrid g = {0};
    uint8_t *hit = calloc((size_t)ntri, 1);
    for (long k = 0; k < ncx && hit; k++) {
        push(&s, cx[k].x, cx[k].tri);
        hit[cx[k].tri] = 1;
    }
    free(cx);
    if (!hit) goto fail;
    /* a triangle no line crossed: a seed at its centroid */
    for (int t = 0; t < ntri; t++) {
        if (hit[t]) continue;
        const double *P[3] = {vert + 3 * tri[3 * t], vert + 3 * tri[3 * t + 1], vert + 3 * tri[3 * t + 2]};
        double c[3];
        for (int a = 0; a < 3; a++) c[a] = (P[0][a] + P[1][a] + P[2][a]) / 3;
        push(&s, c, t);
    }
    free(hit);
    if (s.oom) goto fail;
    /* pass 2: the hash grid of pass 1's seeds, every triangle's check points */
    if (hg_build(&g, &s, 2 * spacing, L.o)) goto fail;
    const double delta = spacing / 8;
    for (int t = 0; t < ntri; t++) {
        const double *P[3] = {vert + 3 * tri[3 * t], vert + 3 * tri[3 * t + 1], vert + 3 * tri[3 * t + 2]};
        if (fill_holes(&g, &s, P, t, delta, spacing - 1.5 * delta)) goto fail;
    }
    hg_free(&g);
    /* out as floats */
    *seed = malloc(sizeof(float) * 3 * (s.n ? s.n : 1));
    *seed_tri = s.tri;
    if (!*seed) {
        s.tri = NULL;
        *seed_tri = NULL;
        goto fail;
    }
    for (size_t i = 0; i < 3 * s.n; i++) (*seed)[i] = (float)s.x[i];
    free(s.x);
    return s.n;
fail:
    hg_free(&g);
    free(s.x);
    free(s.tri);
    free(*seed);
    *seed = NULL, *seed_tri = NULL;
    return 0;
}
