/* seed.c — rigid particles on a surface (paper §5.2.1).
 *
 * Two passes, both deterministic:
 *
 * 1. Lattice crossings. The lines of an axis-aligned lattice of step
 *    h = 0.7 spacing, along each of the three axes, cross the surface; each
 *    crossing is a seed on the triangle it crosses. The crossings are a
 *    property of the surface, not of its triangulation, so a flat region
 *    gets the same seeds however it is cut into triangles. Every crossing is
 *    found (not only the first along a line), by rasterising each triangle
 *    into the lines of each axis row by row. On the lines of the axis most
 *    normal to a triangle, the crossings form a lattice whose cells have
 *    diagonals of at most h√3, so no interior point is farther than h from
 *    one (the circumradius bound h√3/√3).
 *
 * 2. Holes. Near a triangle's edges, on triangles smaller than the lattice
 *    and on slivers, crossings can be missing. Every triangle is checked on
 *    its own points δ = spacing/8 apart (rows parallel to its longest edge,
 *    and its three edges); any check point farther than spacing − 1.5δ from
 *    every seed becomes a seed. Any point of a triangle is within δ√2/2 of a
 *    check point, so afterwards within spacing of a seed. A triangle no
 *    crossing hit gets a seed at its centroid first.
 *
 * (Embree's rays would find the same crossings but only the first along a
 * ray; the rasteriser finds all of them and needs no scene.) */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "rigid.h"
#include "rmath.h"

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

/* ---- pass 1: lattice crossings ------------------------------------------- */

/* the lines along axis a through (o_b + i h, o_c + j h) that cross triangle t */
static void crossings(seeds *s, const double *P[3], int t, int a, const double o[3], double h) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    /* 2D triangle in (b, c) and its signed doubled area */
    double u[3] = {P[0][b], P[1][b], P[2][b]}, w[3] = {P[0][c], P[1][c], P[2][c]};
    double area = (u[1] - u[0]) * (w[2] - w[0]) - (u[2] - u[0]) * (w[1] - w[0]);
    double ext = fmax(fmax(fabs(u[1] - u[0]), fabs(u[2] - u[0])), fmax(fabs(w[1] - w[0]), fabs(w[2] - w[0])));
    if (!(fabs(area) > 1e-12 * ext * ext)) return; /* parallel to the lines */
    double wlo = fmin(w[0], fmin(w[1], w[2])), whi = fmax(w[0], fmax(w[1], w[2]));
    long j0 = (long)ceil((wlo - o[c]) / h), j1 = (long)floor((whi - o[c]) / h);
    for (long j = j0; j <= j1; j++) {
        double wy = o[c] + j * h;
        /* the row's span: where the row crosses the three edges */
        double xl = INFINITY, xr = -INFINITY;
        for (int e = 0; e < 3; e++) {
            int e1 = (e + 1) % 3;
            double w0 = w[e], w1 = w[e1];
            if ((wy < w0 && wy < w1) || (wy > w0 && wy > w1) || w0 == w1) continue;
            double x = u[e] + (u[e1] - u[e]) * (wy - w0) / (w1 - w0);
            xl = fmin(xl, x), xr = fmax(xr, x);
        }
        if (!(xl <= xr)) continue;
        long i0 = (long)ceil((xl - o[b]) / h), i1 = (long)floor((xr - o[b]) / h);
        for (long i = i0; i <= i1; i++) {
            double ux = o[b] + i * h;
            /* barycentric coordinates of (ux, wy), clamped onto the triangle against round-off */
            double l1 = ((ux - u[0]) * (w[2] - w[0]) - (u[2] - u[0]) * (wy - w[0])) / area;
            double l2 = ((u[1] - u[0]) * (wy - w[0]) - (ux - u[0]) * (w[1] - w[0])) / area;
            l1 = fmin(fmax(l1, 0), 1), l2 = fmin(fmax(l2, 0), 1 - l1);
            double l0 = 1 - l1 - l2, p[3];
            for (int k = 0; k < 3; k++) p[k] = l0 * P[0][k] + l1 * P[1][k] + l2 * P[2][k];
            push(s, p, t);
        }
    }
}

/* ---- a hash grid over the seeds (cell = spacing) ------------------------- */

typedef struct hgrid {
    double cell, o[3];
    uint32_t mask;
    int64_t *head, *next; /* chains of seed indices, -1 ends */
    size_t cap;
} hgrid;

static uint32_t hash3(int64_t i, int64_t j, int64_t k, uint32_t mask) {
    uint64_t h = (uint64_t)i * 73856093u ^ (uint64_t)j * 19349663u ^ (uint64_t)k * 83492791u;
    return (uint32_t)(h ^ (h >> 29)) & mask;
}

static int64_t cellof(const hgrid *g, const double *x, int a) { return (int64_t)floor((x[a] - g->o[a]) / g->cell); }

static int hg_insert(hgrid *g, const seeds *s, size_t idx) {
    if (idx >= g->cap) {
        size_t cap = g->cap ? 2 * g->cap : 4096;
        while (cap <= idx) cap *= 2;
        int64_t *nx = realloc(g->next, sizeof(int64_t) * cap);
        if (!nx) return -1;
        g->next = nx, g->cap = cap;
    }
    const double *x = s->x + 3 * idx;
    uint32_t h = hash3(cellof(g, x, 0), cellof(g, x, 1), cellof(g, x, 2), g->mask);
    g->next[idx] = g->head[h];
    g->head[h] = (int64_t)idx;
    return 0;
}

/* is some seed within r of p (r <= cell) */
static int hg_near(const hgrid *g, const seeds *s, const double p[3], double r) {
    int64_t ci = cellof(g, p, 0), cj = cellof(g, p, 1), ck = cellof(g, p, 2);
    double r2 = r * r;
    for (int di = -1; di <= 1; di++)
        for (int dj = -1; dj <= 1; dj++)
            for (int dk = -1; dk <= 1; dk++)
                for (int64_t q = g->head[hash3(ci + di, cj + dj, ck + dk, g->mask)]; q >= 0; q = g->next[q]) {
                    const double *x = s->x + 3 * q;
                    double d[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]};
                    if (rm_dot(d, d) <= r2) return 1;
                }
    return 0;
}

/* ---- pass 2: holes ------------------------------------------------------- */

/* check point p of triangle t: a seed there if none is within r */
static int check(hgrid *g, seeds *s, const double p[3], int t, double r) {
    if (hg_near(g, s, p, r)) return 0;
    push(s, p, t);
    if (s->oom) return -1;
    return hg_insert(g, s, s->n - 1);
}

static int fill_holes(hgrid *g, seeds *s, const double *P[3], int t, double delta, double r) {
    /* the longest edge A→B, the third corner C */
    int k = 0;
    double best = -1;
    for (int e = 0; e < 3; e++) {
        const double *p = P[e], *q = P[(e + 1) % 3];
        double d[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, l = rm_dot(d, d);
        if (l > best) best = l, k = e;
    }
    const double *A = P[k], *B = P[(k + 1) % 3], *C = P[(k + 2) % 3];
    double ab[3] = {B[0] - A[0], B[1] - A[1], B[2] - A[2]}, ac[3] = {C[0] - A[0], C[1] - A[1], C[2] - A[2]};
    double L = sqrt(rm_dot(ab, ab));
    if (!(L > 0)) return check(g, s, A, t, r);
    double ux = rm_dot(ac, ab) / L; /* C's position along AB, in [0, L] */
    double hv[3];
    for (int a = 0; a < 3; a++) hv[a] = ac[a] - ux * ab[a] / L;
    double H = sqrt(rm_dot(hv, hv));
    /* rows parallel to AB, from AB (row 0) to C */
    int ny = (int)ceil(H / delta);
    for (int row = 0; row <= ny; row++) {
        double f = ny ? (double)row / ny : 0; /* fraction of the way to C */
        /* the row runs from A + f (C - A) to B + f (C - B) */
        double p0[3], p1[3];
        for (int a = 0; a < 3; a++) p0[a] = A[a] + f * ac[a], p1[a] = B[a] + f * (C[a] - B[a]);
        double d[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        int nx = (int)ceil(sqrt(rm_dot(d, d)) / delta);
        for (int i = 0; i <= nx; i++) {
            double g2 = nx ? (double)i / nx : 0, p[3];
            for (int a = 0; a < 3; a++) p[a] = p0[a] + g2 * d[a];
            if (check(g, s, p, t, r)) return -1;
        }
    }
    /* the two other edges, δ apart (the rows' ends may be far apart on a sliver) */
    const double *E[2][2] = {{A, C}, {B, C}};
    for (int e = 0; e < 2; e++) {
        double d[3] = {E[e][1][0] - E[e][0][0], E[e][1][1] - E[e][0][1], E[e][1][2] - E[e][0][2]};
        int n = (int)ceil(sqrt(rm_dot(d, d)) / delta);
        for (int i = 1; i < n; i++) {
            double p[3];
            for (int a = 0; a < 3; a++) p[a] = E[e][0][a] + (double)i / n * d[a];
            if (check(g, s, p, t, r)) return -1;
        }
    }
    return 0;
}

size_t kf_rigid_seed_surface(const double *vert, int nvert, const int *tri, int ntri, double spacing, float **seed,
                             int32_t **seed_tri) {
    *seed = NULL, *seed_tri = NULL;
    if (!(spacing > 0) || !isfinite(spacing) || ntri < 1 || nvert < 3) return 0;
    double lo[3] = {INFINITY, INFINITY, INFINITY};
    for (int i = 0; i < nvert; i++)
        for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], vert[3 * i + a]);
    /* the lattice: step 0.7 spacing, offset from the mesh's corner by
     * irrational-looking fractions so faces on round coordinates do not
     * contain lattice lines */
    const double h = 0.7 * spacing, frac[3] = {0.3719, 0.5227, 0.6811};
    double o[3];
    for (int a = 0; a < 3; a++) o[a] = lo[a] - frac[a] * h;
    seeds s = {0};
    hgrid g = {0};
    for (int t = 0; t < ntri && !s.oom; t++) {
        const double *P[3] = {vert + 3 * tri[3 * t], vert + 3 * tri[3 * t + 1], vert + 3 * tri[3 * t + 2]};
        size_t before = s.n;
        for (int a = 0; a < 3; a++) crossings(&s, P, t, a, o, h);
        if (s.n == before) {
            double c[3];
            for (int a = 0; a < 3; a++) c[a] = (P[0][a] + P[1][a] + P[2][a]) / 3;
            push(&s, c, t);
        }
    }
    if (s.oom) goto fail;
    /* the hash grid of pass 1's seeds */
    g.cell = spacing;
    memcpy(g.o, o, sizeof o);
    size_t tab = 1024;
    while (tab < 2 * s.n) tab *= 2;
    g.mask = (uint32_t)(tab - 1);
    g.head = malloc(sizeof(int64_t) * tab);
    if (!g.head) goto fail;
    for (size_t i = 0; i < tab; i++) g.head[i] = -1;
    for (size_t i = 0; i < s.n; i++)
        if (hg_insert(&g, &s, i)) goto fail;
    const double delta = spacing / 8;
    for (int t = 0; t < ntri; t++) {
        const double *P[3] = {vert + 3 * tri[3 * t], vert + 3 * tri[3 * t + 1], vert + 3 * tri[3 * t + 2]};
        if (fill_holes(&g, &s, P, t, delta, spacing - 1.5 * delta)) goto fail;
    }
    free(g.head);
    free(g.next);
    g.head = g.next = NULL;
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
    free(g.head);
    free(g.next);
    free(s.x);
    free(s.tri);
    free(*seed);
    *seed = NULL, *seed_tri = NULL;
    return 0;
}
