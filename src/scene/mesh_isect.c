/* mesh_isect.c — triangle–triangle intersection and a mesh's
 * self-intersections (see mesh_isect.h).
 *
 * Two triangles meet exactly when an edge of one meets the other: the ends
 * of their common segment (non-coplanar) or the corners of their common
 * polygon (coplanar) lie on edges. So the pair test is six segment–triangle
 * tests, each made of orientation signs: the segment's ends against the
 * triangle's plane, then the segment's line against the triangle's three
 * edges (Plücker signs); a segment in the plane is tested in the projection
 * that keeps the triangle largest. Triangles sharing one vertex v meet away
 * from v exactly when the edge of one opposite v meets the other (their
 * common part is a segment or wedge from v whose far end lies on such an
 * edge), so two tests suffice there. */
#include "mesh_isect.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* the error bounds below assume every product is rounded on its own */
#if defined(__clang__)
#pragma clang fp contract(off)
#elif defined(__GNUC__)
#pragma GCC optimize("fp-contract=off")
#endif

/* ---- predicates ----------------------------------------------------------- */

/* Shewchuk's bounds for the floating-point stage of orient2d and orient3d
 * (Robust Adaptive Floating-Point Geometric Predicates, 1997): a determinant
 * larger than bound x permanent has the sign of the exact one */
#define KF_EPS 1.1102230246251565e-16 /* 2^-53 */
static const double ccw_bound = (3.0 + 16.0 * KF_EPS) * KF_EPS;
static const double o3d_bound = (7.0 + 56.0 * KF_EPS) * KF_EPS;

/* positive when d lies below the plane of a, b, c (a, b, c counter-clockwise
 * seen from above); 0 when that cannot be told from zero */
static double orient3d(const double *a, const double *b, const double *c, const double *d) {
    double adx = a[0] - d[0], bdx = b[0] - d[0], cdx = c[0] - d[0];
    double ady = a[1] - d[1], bdy = b[1] - d[1], cdy = c[1] - d[1];
    double adz = a[2] - d[2], bdz = b[2] - d[2], cdz = c[2] - d[2];
    double bdxcdy = bdx * cdy, cdxbdy = cdx * bdy;
    double cdxady = cdx * ady, adxcdy = adx * cdy;
    double adxbdy = adx * bdy, bdxady = bdx * ady;
    double det = adz * (bdxcdy - cdxbdy) + bdz * (cdxady - adxcdy) + cdz * (adxbdy - bdxady);
    double perm = (fabs(bdxcdy) + fabs(cdxbdy)) * fabs(adz) + (fabs(cdxady) + fabs(adxcdy)) * fabs(bdz) +
                  (fabs(adxbdy) + fabs(bdxady)) * fabs(cdz);
    return fabs(det) > o3d_bound * perm ? det : 0;
}

/* positive when a, b, c turn counter-clockwise; 0 when that cannot be told */
static double orient2d(const double *a, const double *b, const double *c) {
    double l = (a[0] - c[0]) * (b[1] - c[1]), r = (a[1] - c[1]) * (b[0] - c[0]), det = l - r;
    return fabs(det) > ccw_bound * (fabs(l) + fabs(r)) ? det : 0;
}

static int mixed(double s1, double s2, double s3) {
    return (s1 > 0 || s2 > 0 || s3 > 0) && (s1 < 0 || s2 < 0 || s3 < 0);
}

/* ---- a segment against a triangle ----------------------------------------------- */

/* a triangle ready for tests: its corners and the axis its plane is projected
 * along (the normal's largest component); axis < 0 for zero area */
typedef struct ttri {
    const double *p[3];
    double q[3][2]; /* the corners projected */
    int axis;
} ttri;

static void project(const double *x, int axis, double out[2]) {
    out[0] = x[(axis + 1) % 3], out[1] = x[(axis + 2) % 3];
}

static void ttri_make(ttri *t, const double *a, const double *b, const double *c) {
    t->p[0] = a, t->p[1] = b, t->p[2] = c;
    double e[3], f[3];
    for (int k = 0; k < 3; k++) e[k] = b[k] - a[k], f[k] = c[k] - a[k];
    double n[3] = {fabs(e[1] * f[2] - e[2] * f[1]), fabs(e[2] * f[0] - e[0] * f[2]), fabs(e[0] * f[1] - e[1] * f[0])};
    t->axis = n[0] >= n[1] && n[0] >= n[2] ? 0 : n[1] >= n[2] ? 1 : 2;
    for (int k = 0; k < 3; k++) project(t->p[k], t->axis, t->q[k]);
    /* zero area even in the projection that shows the most of it */
    if (orient2d(t->q[0], t->q[1], t->q[2]) == 0) t->axis = -1;
}

/* c (collinear with a and b) within their bounding box */
static int on_segment2(const double *a, const double *b, const double *c) {
    return fmin(a[0], b[0]) <= c[0] && c[0] <= fmax(a[0], b[0]) && fmin(a[1], b[1]) <= c[1] && c[1] <= fmax(a[1], b[1]);
}

/* where along a-b (0..1) point c projects */
static double param2(const double *a, const double *b, const double *c) {
    double dx = b[0] - a[0], dy = b[1] - a[1], L = dx * dx + dy * dy;
    return L > 0 ? ((c[0] - a[0]) * dx + (c[1] - a[1]) * dy) / L : 0;
}

/* 2-D segments a-b and u-v meet (touching included); *t along a-b */
static int segments2(const double *a, const double *b, const double *u, const double *v, double *t) {
    double o1 = orient2d(a, b, u), o2 = orient2d(a, b, v), o3 = orient2d(u, v, a), o4 = orient2d(u, v, b);
    if (((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0))) {
        *t = o3 / (o3 - o4);
        return 1;
    }
    if (o3 == 0 && on_segment2(u, v, a)) return *t = 0, 1;
    if (o4 == 0 && on_segment2(u, v, b)) return *t = 1, 1;
    if (o1 == 0 && on_segment2(a, b, u)) return *t = param2(a, b, u), 1;
    if (o2 == 0 && on_segment2(a, b, v)) return *t = param2(a, b, v), 1;
    return 0;
}

static void lerp3(const double *a, const double *b, double t, double at[3]) {
    for (int k = 0; k < 3; k++) at[k] = a[k] + t * (b[k] - a[k]);
}

/* a segment lying in the triangle's plane: an end inside, or an edge crossed */
static int segment_in_plane(const double *a, const double *b, const ttri *T, double at[3]) {
    double a2[2], b2[2], t;
    project(a, T->axis, a2), project(b, T->axis, b2);
    const double *end3[2] = {a, b}, *end2[2] = {a2, b2};
    for (int e = 0; e < 2; e++)
        if (!mixed(orient2d(T->q[0], T->q[1], end2[e]), orient2d(T->q[1], T->q[2], end2[e]),
                   orient2d(T->q[2], T->q[0], end2[e]))) {
            memcpy(at, end3[e], 3 * sizeof *at);
            return 1;
        }
    for (int k = 0; k < 3; k++)
        if (segments2(a2, b2, T->q[k], T->q[(k + 1) % 3], &t)) {
            lerp3(a, b, t, at);
            return 1;
        }
    return 0;
}

/* segment a-b meets triangle T (touching included) */
static int segment_triangle(const double *a, const double *b, const ttri *T, double at[3]) {
    const double *p = T->p[0], *q = T->p[1], *r = T->p[2];
    double da = orient3d(p, q, r, a), db = orient3d(p, q, r, b);
    if ((da > 0 && db > 0) || (da < 0 && db < 0)) return 0;
    if (da == 0 && db == 0) return segment_in_plane(a, b, T, at);
    /* the line through a and b passes inside the triangle, or along its boundary, when
     * the three edge signs do not disagree */
    double s1 = orient3d(a, b, p, q), s2 = orient3d(a, b, q, r), s3 = orient3d(a, b, r, p);
    if (mixed(s1, s2, s3)) return 0;
    /* all three zero: the line is in the plane after all (within rounding) */
    if (s1 == 0 && s2 == 0 && s3 == 0) return segment_in_plane(a, b, T, at);
    lerp3(a, b, da == 0 ? 0 : db == 0 ? 1 : da / (da - db), at);
    return 1;
}

/* ---- a pair of triangles ------------------------------------------------------------ */

/* sp, sq: the corner of P and of Q that is one shared vertex, or -1 */
static int pair_meets(const ttri *P, const ttri *Q, int sp, int sq, double at[3]) {
    if (P->axis < 0 || Q->axis < 0) return 0;
    if (sp >= 0)
        return segment_triangle(P->p[(sp + 1) % 3], P->p[(sp + 2) % 3], Q, at) ||
               segment_triangle(Q->p[(sq + 1) % 3], Q->p[(sq + 2) % 3], P, at);
    for (int k = 0; k < 3; k++)
        if (segment_triangle(P->p[k], P->p[(k + 1) % 3], Q, at)) return 1;
    for (int k = 0; k < 3; k++)
        if (segment_triangle(Q->p[k], Q->p[(k + 1) % 3], P, at)) return 1;
    return 0;
}

int kf_tri_tri_intersect(const double a[9], const double b[9], double at[3]) {
    double tmp[3];
    if (!at) at = tmp;
    int shared = 0, sp = -1, sq = -1;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            if (!memcmp(&a[3 * i], &b[3 * j], 3 * sizeof *a)) shared++, sp = i, sq = j;
    if (shared >= 2) return 0; /* an edge: neighbours */
    ttri P, Q;
    ttri_make(&P, &a[0], &a[3], &a[6]);
    ttri_make(&Q, &b[0], &b[3], &b[6]);
    return pair_meets(&P, &Q, shared ? sp : -1, shared ? sq : -1, at);
}

/* ---- every pair of a mesh: a uniform grid over bounding boxes ---------------------- */

typedef struct cell_entry {
    uint64_t key; /* ix << 42 | iy << 21 | iz */
    uint32_t tri;
} cell_entry;

static int cmp_entry(const void *x, const void *y) {
    const cell_entry *a = x, *b = y;
    if (a->key != b->key) return a->key < b->key ? -1 : 1;
    return a->tri < b->tri ? -1 : a->tri > b->tri;
}

typedef struct grid {
    double lo[3], h;
    int64_t n[3];
} grid;

static int64_t cell_of(const grid *g, double x, int a) {
    int64_t i = (int64_t)floor((x - g->lo[a]) / g->h);
    return i < 0 ? 0 : i >= g->n[a] ? g->n[a] - 1 : i;
}

static uint64_t key_of(const grid *g, const double x[3]) {
    return (uint64_t)cell_of(g, x[0], 0) << 42 | (uint64_t)cell_of(g, x[1], 1) << 21 | (uint64_t)cell_of(g, x[2], 2);
}

/* cells a box covers, the grid's shape permitting */
static size_t cells_covered(const grid *g, const double *box) {
    size_t c = 1;
    for (int a = 0; a < 3; a++) c *= (size_t)(cell_of(g, box[3 + a], a) - cell_of(g, box[a], a) + 1);
    return c;
}

int kf_mesh_self_intersections(const kf_mesh *m, int threads, kf_mesh_isect *out) {
    memset(out, 0, sizeof *out);
    size_t nt = m->ntri;
    if (nt < 2) return 0;
    double *box = malloc(nt * 6 * sizeof *box); /* (nt x 6) lo, hi */
    if (!box) return -1;
    grid g;
    double hi[3], ext = 0;
    for (int a = 0; a < 3; a++) g.lo[a] = INFINITY, hi[a] = -INFINITY;
    for (size_t t = 0; t < nt; t++) {
        double *b = &box[6 * t], big = 0;
        for (int a = 0; a < 3; a++) {
            b[a] = INFINITY, b[3 + a] = -INFINITY;
            for (int k = 0; k < 3; k++) {
                double x = m->vert[3 * m->tri[3 * t + k] + a];
                b[a] = fmin(b[a], x), b[3 + a] = fmax(b[3 + a], x);
            }
            g.lo[a] = fmin(g.lo[a], b[a]), hi[a] = fmax(hi[a], b[3 + a]);
            big = fmax(big, b[3 + a] - b[a]);
        }
        ext += big;
    }
    /* cells about the size of a typical triangle, no finer than 1/512 of the
     * mesh, coarser where a few large triangles would cover too many */
    double diag = sqrt((hi[0] - g.lo[0]) * (hi[0] - g.lo[0]) + (hi[1] - g.lo[1]) * (hi[1] - g.lo[1]) +
                       (hi[2] - g.lo[2]) * (hi[2] - g.lo[2]));
    g.h = fmax(ext / (double)nt, diag / 512);
    if (!(g.h > 0)) g.h = 1;
    size_t ne;
    for (;;) {
        int fits = 1;
        for (int a = 0; a < 3; a++) {
            double n = floor((hi[a] - g.lo[a]) / g.h) + 1;
            fits &= n < (double)(1 << 20);
            g.n[a] = fits ? (int64_t)n : 1;
        }
        ne = 0;
        for (size_t t = 0; t < nt && fits; t++) ne += cells_covered(&g, &box[6 * t]);
        if (fits && ne <= 16 * nt + ((size_t)1 << 20)) break;
        g.h *= 2;
    }
    cell_entry *e = malloc(ne * sizeof *e);
    size_t *run = malloc((ne + 1) * sizeof *run); /* starts of the cells in e */
    if (!e || !run) {
        free(box), free(e), free(run);
        return -1;
    }
    size_t k = 0;
    for (size_t t = 0; t < nt; t++) {
        const double *b = &box[6 * t];
        int64_t c0[3], c1[3];
        for (int a = 0; a < 3; a++) c0[a] = cell_of(&g, b[a], a), c1[a] = cell_of(&g, b[3 + a], a);
        for (int64_t i = c0[0]; i <= c1[0]; i++)
            for (int64_t j = c0[1]; j <= c1[1]; j++)
                for (int64_t l = c0[2]; l <= c1[2]; l++)
                    e[k++] = (cell_entry){(uint64_t)i << 42 | (uint64_t)j << 21 | (uint64_t)l, (uint32_t)t};
    }
    qsort(e, ne, sizeof *e, cmp_entry);
    size_t nrun = 0;
    for (size_t i = 0; i < ne; i++)
        if (i == 0 || e[i].key != e[i - 1].key) run[nrun++] = i;
    run[nrun] = ne;

    /* pairs within each cell; a pair is tested in one cell only, the one
     * holding the low corner of the two boxes' overlap. The first pair (in
     * triangle order) is kept, so the report does not depend on threads. */
    size_t total = 0;
    uint64_t first = UINT64_MAX;
    double first_at[3] = {0, 0, 0};
    int nth = threads > 0 ? threads : omp_get_max_threads();
#pragma omp parallel num_threads(nth)
    {
        size_t mine = 0;
        uint64_t my_first = UINT64_MAX;
        double my_at[3] = {0, 0, 0};
#pragma omp for schedule(dynamic, 64)
        for (size_t r = 0; r < nrun; r++) {
            for (size_t x = run[r]; x < run[r + 1]; x++)
                for (size_t y = x + 1; y < run[r + 1]; y++) {
                    uint32_t i = e[x].tri < e[y].tri ? e[x].tri : e[y].tri, j = e[x].tri ^ e[y].tri ^ i;
                    const double *bi = &box[6 * (size_t)i], *bj = &box[6 * (size_t)j];
                    double corner[3];
                    int apart = 0;
                    for (int a = 0; a < 3; a++) {
                        apart |= bi[a] > bj[3 + a] || bj[a] > bi[3 + a];
                        corner[a] = fmax(bi[a], bj[a]);
                    }
                    if (apart || key_of(&g, corner) != e[x].key) continue;
                    const uint32_t *ti = &m->tri[3 * (size_t)i], *tj = &m->tri[3 * (size_t)j];
                    int shared = 0, sp = -1, sq = -1;
                    for (int u = 0; u < 3; u++)
                        for (int v = 0; v < 3; v++)
                            if (ti[u] == tj[v]) shared++, sp = u, sq = v;
                    if (shared >= 2) continue; /* neighbours across an edge */
                    ttri P, Q;
                    ttri_make(&P, &m->vert[3 * (size_t)ti[0]], &m->vert[3 * (size_t)ti[1]],
                              &m->vert[3 * (size_t)ti[2]]);
                    ttri_make(&Q, &m->vert[3 * (size_t)tj[0]], &m->vert[3 * (size_t)tj[1]],
                              &m->vert[3 * (size_t)tj[2]]);
                    double at[3];
                    if (!pair_meets(&P, &Q, shared ? sp : -1, shared ? sq : -1, at)) continue;
                    mine++;
                    uint64_t id = (uint64_t)i << 32 | j;
                    if (id < my_first) my_first = id, memcpy(my_at, at, sizeof at);
                }
        }
#pragma omp critical(kf_mesh_isect)
        {
            total += mine;
            if (my_first < first) first = my_first, memcpy(first_at, my_at, sizeof my_at);
        }
    }
    free(box), free(e), free(run);
    out->pairs = total;
    if (total) {
        out->tri[0] = (uint32_t)(first >> 32), out->tri[1] = (uint32_t)first;
        for (int a = 0; a < 3; a++) out->at[a] = first_at[a] + 0.0; /* no "-0" in messages */
    }
    return 0;
}

int kf_mesh_check_self_intersection(const kf_mesh *m, int threads, char *err, size_t errlen) {
    kf_mesh_isect x;
    if (kf_mesh_self_intersections(m, threads, &x)) {
        snprintf(err, errlen, "%s: out of memory checking for self-intersections", m->path);
        return -1;
    }
    if (x.pairs == 0) return 0;
    /* triangles by their place in the file; dropped ones shift the count */
    char dropped[96] = "", more[64] = "";
    size_t gone = m->dropped_tris + m->duplicate_tris;
    if (gone)
        snprintf(dropped, sizeof dropped, ", not counting %zu degenerate or repeated %s", gone,
                 gone == 1 ? "triangle" : "triangles");
    if (x.pairs > 1) snprintf(more, sizeof more, "; %zu pairs of triangles intersect", x.pairs);
    snprintf(err, errlen,
             "%s: intersects itself: triangles %u and %u meet at (%.6g, %.6g, %.6g) (file coordinates%s)%s", m->path,
             x.tri[0] + 1, x.tri[1] + 1, x.at[0], x.at[1], x.at[2], dropped, more);
    return -1;
}
