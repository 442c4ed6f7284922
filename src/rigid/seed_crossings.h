/* seed_crossings.h — pass 1 of surface seeding (paper §5.2.1): where the
 * lines of an axis-aligned lattice cross a triangle mesh. Private to
 * src/rigid (seed.c) and to its tests and benchmark.
 *
 * The lattice has step h and origin o; its lines along axis a pass through
 * (o_b + i h, o_c + j h), b = a+1, c = a+2 (mod 3), i, j >= 0. Every crossing
 * of a line with a triangle is one kf_seed_crossing, its point computed in
 * double on the exact line (not from Embree's float hit distance).
 *
 * Two finders of the same set:
 *   kf_seed_crossings_rays   Embree 3 rays along the lines, every hit along
 *                            each ray (the product's path);
 *   kf_seed_crossings_raster each triangle rasterised into the lines, row by
 *                            row (no Embree: the independent cross-check of
 *                            the tests and the benchmark's baseline).
 * Both return their crossings in one deterministic order with duplicates
 * removed (kf_seed_crossings_order), so they can be compared line by line. */
#ifndef KF_RIGID_SEED_CROSSINGS_H
#define KF_RIGID_SEED_CROSSINGS_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <stdlib.h>

typedef struct kf_seed_lattice {
    double o[3];  /* origin, metres (mesh frame) */
    double h;     /* step, metres */
    int32_t n[3]; /* lattice points along each axis: coordinate a runs over o_a + [0, n_a) h */
} kf_seed_lattice;

typedef struct kf_seed_crossing {
    double x[3];  /* the crossing point, on its triangle */
    int32_t tri;  /* the triangle crossed */
    int8_t axis;  /* the line runs along this axis ... */
    int32_t i, j; /* ... through (o_b + i h, o_c + j h) */
} kf_seed_crossing;

/* A growing list of crossings, as both finders collect them; after a
 * failed allocation it stops growing and says so (oom). */
typedef struct kf_seed_xbuf {
    kf_seed_crossing *c;
    size_t n, cap;
    int oom;
} kf_seed_xbuf;

static inline void kf_seed_xpush(kf_seed_xbuf *s, const kf_seed_crossing *x) {
    if (s->oom) return;
    if (s->n == s->cap) {
        size_t cap = s->cap ? 2 * s->cap : 4096;
        kf_seed_crossing *c = realloc(s->c, sizeof *c * cap);
        if (!c) {
            s->oom = 1;
            return;
        }
        s->c = c, s->cap = cap;
    }
    s->c[s->n++] = *x;
}

/* two crossings of one line this close (relative to the lattice's extent)
 * on triangles sharing a corner are one crossing, found twice: well above
 * the double round-off of a crossing point (1e-15) and of the clamp onto a
 * triangle that Embree's float test took (1e-7), well below any feature */
#define KF_SEED_SAME_POINT 1e-6

/* The seeding lattice of a mesh with bounds lo..hi: step h, origin lo minus
 * fixed irrational-looking fractions of h (so faces on round coordinates do
 * not contain lattice lines), enough points to pass hi. */
void kf_seed_lattice_for(const double lo[3], const double hi[3], double h, kf_seed_lattice *L);

/* Every crossing of the lattice's lines with the triangles, ordered and
 * without duplicates. Return the count (*out malloc'ed; may be 0 with
 * *out != NULL), or -1 with a message in err and *out == NULL. */
long kf_seed_crossings_rays(const double *vert, int nvert, const int *tri, int ntri, const kf_seed_lattice *L,
                            kf_seed_crossing **out, char *err, size_t errlen);
long kf_seed_crossings_raster(const double *vert, int nvert, const int *tri, int ntri, const kf_seed_lattice *L,
                              kf_seed_crossing **out, char *err, size_t errlen);

/* Sort crossings by (axis, j, i, position along the line, triangle) and drop
 * a crossing that repeats the previous one on its line: within tol of it and
 * on a triangle that shares a corner position with the previous one's (a
 * line through a shared edge or vertex). Crossings of distinct sheets that
 * share no corner are kept however close. Returns the new count. */
size_t kf_seed_crossings_order(kf_seed_crossing *c, size_t n, const double *vert, const int *tri, double tol);

/* The point of triangle P on the line along axis a through (ub, wc) in the
 * (b, c) coordinates: barycentric coordinates in the (b, c) plane, clamped
 * onto the triangle against round-off. Returns 0, or -1 when the triangle is
 * parallel to the line (area below 1e-12 of its extent squared). */
static inline int kf_seed_point_on_line(const double *P[3], int a, double ub, double wc, double x[3]) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const double u[3] = {P[0][b], P[1][b], P[2][b]}, w[3] = {P[0][c], P[1][c], P[2][c]};
    double area = (u[1] - u[0]) * (w[2] - w[0]) - (u[2] - u[0]) * (w[1] - w[0]);
    double ext = fmax(fmax(fabs(u[1] - u[0]), fabs(u[2] - u[0])), fmax(fabs(w[1] - w[0]), fabs(w[2] - w[0])));
    if (!(fabs(area) > 1e-12 * ext * ext)) return -1;
    double l1 = ((ub - u[0]) * (w[2] - w[0]) - (u[2] - u[0]) * (wc - w[0])) / area;
    double l2 = ((u[1] - u[0]) * (wc - w[0]) - (ub - u[0]) * (w[1] - w[0])) / area;
    l1 = fmin(fmax(l1, 0), 1), l2 = fmin(fmax(l2, 0), 1 - l1);
    double l0 = 1 - l1 - l2;
    for (int k = 0; k < 3; k++) x[k] = l0 * P[0][k] + l1 * P[1][k] + l2 * P[2][k];
    return 0;
}

#endif
