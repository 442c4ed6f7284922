/* seed_raster.c — lattice crossings by rasterising each triangle into the
 * lattice's lines, row by row, in double (see seed_crossings.h).
 *
 * Not the product's path (seed.c casts Embree rays): it needs no ray tracer
 * and shares no code with one, so the tests compare the two crossing sets on
 * real meshes, and the seeding benchmark times the rays against it. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>

#include "seed_crossings.h"

/* the lines along axis a that cross triangle t: for each lattice row j in
 * the triangle's c-range, the span of b where the row is inside the
 * triangle (from its crossings with the three edges), and the lattice
 * points i in that span */
static void raster_axis(kf_seed_xbuf *s, const double *P[3], int t, int a, const kf_seed_lattice *L) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const double h = L->h;
    double u[3] = {P[0][b], P[1][b], P[2][b]}, w[3] = {P[0][c], P[1][c], P[2][c]};
    double area = (u[1] - u[0]) * (w[2] - w[0]) - (u[2] - u[0]) * (w[1] - w[0]);
    double ext = fmax(fmax(fabs(u[1] - u[0]), fabs(u[2] - u[0])), fmax(fabs(w[1] - w[0]), fabs(w[2] - w[0])));
    if (!(fabs(area) > 1e-12 * ext * ext)) return; /* parallel to the lines */
    double wlo = fmin(w[0], fmin(w[1], w[2])), whi = fmax(w[0], fmax(w[1], w[2]));
    long j0 = (long)ceil((wlo - L->o[c]) / h), j1 = (long)floor((whi - L->o[c]) / h);
    if (j0 < 0) j0 = 0;
    if (j1 > L->n[c] - 1) j1 = L->n[c] - 1;
    for (long j = j0; j <= j1; j++) {
        double wy = L->o[c] + j * h;
        double xl = INFINITY, xr = -INFINITY;
        for (int e = 0; e < 3; e++) {
            int e1 = (e + 1) % 3;
            double w0 = w[e], w1 = w[e1];
            if ((wy < w0 && wy < w1) || (wy > w0 && wy > w1) || w0 == w1) continue;
            double x = u[e] + (u[e1] - u[e]) * (wy - w0) / (w1 - w0);
            xl = fmin(xl, x), xr = fmax(xr, x);
        }
        if (!(xl <= xr)) continue;
        long i0 = (long)ceil((xl - L->o[b]) / h), i1 = (long)floor((xr - L->o[b]) / h);
        if (i0 < 0) i0 = 0;
        if (i1 > L->n[b] - 1) i1 = L->n[b] - 1;
        for (long i = i0; i <= i1; i++) {
            kf_seed_crossing x = {.tri = t, .axis = (int8_t)a, .i = (int32_t)i, .j = (int32_t)j};
            if (kf_seed_point_on_line(P, a, L->o[b] + i * h, wy, x.x) == 0) kf_seed_xpush(s, &x);
        }
    }
}

long kf_seed_crossings_raster(const double *vert, int nvert, const int *tri, int ntri, const kf_seed_lattice *L,
                              kf_seed_crossing **out, char *err, size_t errlen) {
    (void)nvert;
    kf_seed_xbuf s = {0};
    for (int t = 0; t < ntri && !s.oom; t++) {
        const double *P[3] = {vert + 3 * (size_t)tri[3 * t], vert + 3 * (size_t)tri[3 * t + 1],
                              vert + 3 * (size_t)tri[3 * t + 2]};
        for (int a = 0; a < 3; a++) raster_axis(&s, P, t, a, L);
    }
    if (s.oom) {
        free(s.c);
        *out = NULL;
        snprintf(err, errlen, "out of memory for the lattice crossings");
        return -1;
    }
    if (!s.c) s.c = malloc(sizeof *s.c); /* an empty list is still a list */
    *out = s.c;
    double ext = 0;
    for (int a = 0; a < 3; a++) ext = fmax(ext, L->n[a] * L->h);
    return (long)kf_seed_crossings_order(s.c, s.n, vert, tri, KF_SEED_SAME_POINT * ext);
}
