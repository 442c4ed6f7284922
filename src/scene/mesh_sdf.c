/* mesh_sdf.c — signed distance grids of closed meshes (see mesh_sdf.h). */
#include "mesh_sdf.h"

#include <math.h>
#include <omp.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../core/mat3.h"
#include "../core/timer.h"
#include "inside.h"

#define CHUNK 4 /* x-layers of nodes per parallel task of the band pass */

kf_mesh_sdf_def kf_default_mesh_sdf_def(void) {
    kf_mesh_sdf_def d;
    memset(&d, 0, sizeof d);
    return d;
}

void kf_mesh_sdf_free(kf_mesh_sdf *s) {
    if (!s) return;
    free(s->values);
    memset(s, 0, sizeof *s);
}

/* ---- point-triangle distance (Ericson, Real-Time Collision Detection 5.1.5) ---- */

double kf_point_triangle_dist2(const double p[3], const double a[3], const double b[3], const double c[3],
                               double q[3]) {
    double ab[3], ac[3], ap[3], r[3];
    for (int k = 0; k < 3; k++) ab[k] = b[k] - a[k], ac[k] = c[k] - a[k], ap[k] = p[k] - a[k];
    double d1 = kf_v3d_dot(ab, ap), d2 = kf_v3d_dot(ac, ap);
    double s = 0, t = 0;               /* r = a + s ab + t ac */
    if (d1 <= 0 && d2 <= 0) goto done; /* vertex a */
    double bp[3], cp[3];
    for (int k = 0; k < 3; k++) bp[k] = p[k] - b[k], cp[k] = p[k] - c[k];
    double d3 = kf_v3d_dot(ab, bp), d4 = kf_v3d_dot(ac, bp);
    if (d3 >= 0 && d4 <= d3) { /* vertex b */
        s = 1;
        goto done;
    }
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) { /* edge ab */
        s = d1 / (d1 - d3);
        goto done;
    }
    double d5 = kf_v3d_dot(ab, cp), d6 = kf_v3d_dot(ac, cp);
    if (d6 >= 0 && d5 <= d6) { /* vertex c */
        t = 1;
        goto done;
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) { /* edge ac */
        t = d2 / (d2 - d6);
        goto done;
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) { /* edge bc */
        double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        s = 1 - w, t = w;
        goto done;
    }
    { /* the face */
        double den = 1.0 / (va + vb + vc);
        s = vb * den, t = vc * den;
    }
done:
    for (int k = 0; k < 3; k++) r[k] = a[k] + s * ab[k] + t * ac[k];
    if (q) memcpy(q, r, sizeof r);
    double e[3] = {p[0] - r[0], p[1] - r[1], p[2] - r[2]};
    return kf_v3d_dot(e, e);
}

/* ---- the build ------------------------------------------------------------------ */

typedef struct sdf_work {
    const double *V;   /* (nvert x 3) vertices relative to the origin */
    const uint32_t *T; /* (ntri x 3) */
    double o[3], h;    /* grid origin and spacing */
    int n[3];
    float *d;     /* (nodes) unsigned distance, m */
    int32_t *tri; /* (nodes) the triangle it is the distance to, -1 none yet */
} sdf_work;

static inline size_t node_index(const sdf_work *w, int i, int j, int k) {
    return ((size_t)i * w->n[1] + j) * w->n[2] + k;
}

/* distance from node (i, j, k) to triangle t; keep it if closer */
static inline void try_tri(sdf_work *w, size_t at, int i, int j, int k, int32_t t) {
    double p[3] = {w->o[0] + i * w->h, w->o[1] + j * w->h, w->o[2] + k * w->h};
    const uint32_t *v = &w->T[3 * (size_t)t];
    double d2 = kf_point_triangle_dist2(p, &w->V[3 * v[0]], &w->V[3 * v[1]], &w->V[3 * v[2]], NULL);
    double cur = w->d[at];
    if (d2 < cur * cur) {
        w->d[at] = (float)sqrt(d2);
        w->tri[at] = t;
    }
}

/* the node range [lo, hi] along each axis within `grow` of triangle t's box */
static void tri_range(const sdf_work *w, size_t t, double grow, int lo[3], int hi[3]) {
    const uint32_t *v = &w->T[3 * t];
    for (int a = 0; a < 3; a++) {
        double mn = w->V[3 * v[0] + a], mx = mn;
        for (int c = 1; c < 3; c++) {
            double x = w->V[3 * v[c] + a];
            mn = x < mn ? x : mn;
            mx = x > mx ? x : mx;
        }
        int l = (int)ceil((mn - grow - w->o[a]) / w->h), u = (int)floor((mx + grow - w->o[a]) / w->h);
        lo[a] = l < 0 ? 0 : l;
        hi[a] = u > w->n[a] - 1 ? w->n[a] - 1 : u;
    }
}

/* exact distances near the surface: triangles binned by x-chunk, chunks in
 * parallel (a chunk's nodes are written by its task alone) */
static int band_pass(sdf_work *w, size_t ntri, double band, int nt) {
    int nchunk = (w->n[0] + CHUNK - 1) / CHUNK;
    size_t *start = calloc((size_t)nchunk + 1, sizeof *start);
    if (!start) return -1;
    int lo[3], hi[3];
    for (size_t t = 0; t < ntri; t++) {
        tri_range(w, t, band, lo, hi);
        if (lo[0] > hi[0] || lo[1] > hi[1] || lo[2] > hi[2]) continue;
        for (int c = lo[0] / CHUNK; c <= hi[0] / CHUNK; c++) start[c + 1]++;
    }
    for (int c = 0; c < nchunk; c++) start[c + 1] += start[c];
    int32_t *list = malloc((start[nchunk] + 1) * sizeof *list);
    size_t *fill = malloc((size_t)nchunk * sizeof *fill);
    if (!list || !fill) {
        free(start), free(list), free(fill);
        return -1;
    }
    memcpy(fill, start, (size_t)nchunk * sizeof *fill);
    for (size_t t = 0; t < ntri; t++) {
        tri_range(w, t, band, lo, hi);
        if (lo[0] > hi[0] || lo[1] > hi[1] || lo[2] > hi[2]) continue;
        for (int c = lo[0] / CHUNK; c <= hi[0] / CHUNK; c++) list[fill[c]++] = (int32_t)t;
    }
#pragma omp parallel for schedule(dynamic, 1) num_threads(nt)
    for (int c = 0; c < nchunk; c++) {
        int l[3], u[3];
        for (size_t e = start[c]; e < start[c + 1]; e++) {
            int32_t t = list[e];
            tri_range(w, (size_t)t, band, l, u);
            int i0 = l[0] > c * CHUNK ? l[0] : c * CHUNK,
                i1 = u[0] < c * CHUNK + CHUNK - 1 ? u[0] : c * CHUNK + CHUNK - 1;
            for (int i = i0; i <= i1; i++)
                for (int j = l[1]; j <= u[1]; j++)
                    for (int k = l[2]; k <= u[2]; k++) try_tri(w, node_index(w, i, j, k), i, j, k, t);
        }
    }
    free(start), free(list), free(fill);
    return 0;
}

/* one sweep along axis a in direction s: each node tries the triangle of the
 * node behind it. Lines along the axis are independent. */
static void sweep(sdf_work *w, int a, int s, int nt) {
    const int nx = w->n[0], ny = w->n[1], nz = w->n[2];
    if (a == 0) {
        for (int q = 1; q < nx; q++) {
            int i = s > 0 ? q : nx - 1 - q, ib = i - s;
#pragma omp parallel for schedule(static) num_threads(nt)
            for (int j = 0; j < ny; j++)
                for (int k = 0; k < nz; k++) {
                    int32_t t = w->tri[node_index(w, ib, j, k)];
                    size_t at = node_index(w, i, j, k);
                    if (t >= 0 && t != w->tri[at]) try_tri(w, at, i, j, k, t);
                }
        }
    } else if (a == 1) {
#pragma omp parallel for schedule(static) num_threads(nt)
        for (int i = 0; i < nx; i++)
            for (int q = 1; q < ny; q++) {
                int j = s > 0 ? q : ny - 1 - q, jb = j - s;
                for (int k = 0; k < nz; k++) {
                    int32_t t = w->tri[node_index(w, i, jb, k)];
                    size_t at = node_index(w, i, j, k);
                    if (t >= 0 && t != w->tri[at]) try_tri(w, at, i, j, k, t);
                }
            }
    } else {
#pragma omp parallel for schedule(static) num_threads(nt)
        for (int i = 0; i < nx; i++)
            for (int j = 0; j < ny; j++)
                for (int q = 1; q < nz; q++) {
                    int k = s > 0 ? q : nz - 1 - q, kb = k - s;
                    int32_t t = w->tri[node_index(w, i, j, kb)];
                    size_t at = node_index(w, i, j, k);
                    if (t >= 0 && t != w->tri[at]) try_tri(w, at, i, j, k, t);
                }
    }
}

/* signs by Embree, one x-slab of 4³ blocks at a time: a block whose nodes are
 * all farther than h/2 from the surface has one sign (no grid edge between two
 * of its nodes can cross the surface), so one test decides it. tri[] is done
 * with: it now holds the index of the test that decides each node. */
static int sign_pass(sdf_work *w, const double origin[3], const kf_mesh_inside *q, float *phi, int nt, long *tests) {
    const int nx = w->n[0], ny = w->n[1], nz = w->n[2];
    const float half = (float)(0.5 * w->h);
    size_t cap = (size_t)4 * ny * nz;
    double *pts = malloc(cap * 3 * sizeof *pts);
    uint8_t *in = malloc(cap);
    if (!pts || !in) {
        free(pts), free(in);
        return -1;
    }
    for (int bi = 0; bi < nx; bi += 4) {
        int32_t np = 0;
        const int ie = bi + 4 < nx ? bi + 4 : nx;
        for (int bj = 0; bj < ny; bj += 4)
            for (int bk = 0; bk < nz; bk += 4) {
                const int je = bj + 4 < ny ? bj + 4 : ny, ke = bk + 4 < nz ? bk + 4 : nz;
                int near = 0;
                for (int i = bi; i < ie; i++)
                    for (int j = bj; j < je; j++)
                        for (int k = bk; k < ke; k++) near |= !(w->d[node_index(w, i, j, k)] > half);
                for (int i = bi; i < ie; i++)
                    for (int j = bj; j < je; j++)
                        for (int k = bk; k < ke; k++) {
                            if (near || (i == bi && j == bj && k == bk)) {
                                pts[3 * np] = origin[0] + w->o[0] + i * w->h;
                                pts[3 * np + 1] = origin[1] + w->o[1] + j * w->h;
                                pts[3 * np + 2] = origin[2] + w->o[2] + k * w->h;
                                np++;
                            }
                            w->tri[node_index(w, i, j, k)] = np - 1;
                        }
            }
        kf_mesh_inside_points(q, (size_t)np, pts, in, nt, NULL);
        *tests += np;
        for (int i = bi; i < ie; i++)
            for (int j = 0; j < ny; j++)
                for (int k = 0; k < nz; k++) {
                    size_t at = node_index(w, i, j, k);
                    phi[at] = in[w->tri[at]] ? -w->d[at] : w->d[at];
                }
    }
    free(pts), free(in);
    return 0;
}

int kf_mesh_sdf_build(const kf_mesh *m, const double origin[3], const kf_mesh_sdf_def *def, kf_mesh_sdf *out, char *err,
                      size_t errlen) {
    double t0 = kf_now_ms();
    memset(out, 0, sizeof *out);
    if (!(def->spacing > 0 && isfinite(def->spacing))) {
        snprintf(err, errlen, "%s: distance grid spacing must be > 0 (got %g)", m->path, def->spacing);
        return -1;
    }
    if (m->ntri == 0 || m->nvert == 0) {
        snprintf(err, errlen, "%s: no triangles", m->path);
        return -1;
    }
    if (kf_mesh_check_closed(m, err, errlen)) return -1;
    const int nt = def->threads > 0 ? def->threads : omp_get_max_threads();
    const size_t max_nodes = def->max_nodes ? def->max_nodes : KF_MESH_SDF_MAX_NODES;
    double h = def->spacing, pad = def->pad > 0 ? def->pad : 3 * h;

    /* vertices in the grid's frame, and their bounds */
    double *V = malloc(m->nvert * 3 * sizeof *V), lo[3], hi[3];
    if (!V) {
        snprintf(err, errlen, "%s: out of memory", m->path);
        return -1;
    }
    for (int a = 0; a < 3; a++) lo[a] = INFINITY, hi[a] = -INFINITY;
    for (size_t v = 0; v < m->nvert; v++)
        for (int a = 0; a < 3; a++) {
            double x = m->vert[3 * v + a] - origin[a];
            V[3 * v + a] = x;
            lo[a] = x < lo[a] ? x : lo[a];
            hi[a] = x > hi[a] ? x : hi[a];
        }
    /* the grid: coarser when it would not fit */
    sdf_work w = {V, m->tri, {0, 0, 0}, h, {0, 0, 0}, NULL, NULL};
    for (;;) {
        double nodes = 1;
        for (int a = 0; a < 3; a++) {
            w.o[a] = lo[a] - pad;
            w.n[a] = (int)ceil((hi[a] - lo[a] + 2 * pad) / h) + 1;
            if (w.n[a] < 2) w.n[a] = 2;
            nodes *= w.n[a];
        }
        if (nodes <= (double)max_nodes) break;
        h *= 1.1 * cbrt(nodes / (double)max_nodes);
    }
    w.h = h;
    double band = def->band > 0 ? def->band : 3 * h;
    if (band < 0.5 * h) band = 0.5 * h;
    size_t n = (size_t)w.n[0] * w.n[1] * w.n[2];
    w.d = malloc(n * sizeof *w.d);
    w.tri = malloc(n * sizeof *w.tri);
    out->values = malloc(n * sizeof *out->values);
    kf_mesh_inside *q = NULL;
    int rc = -1;
    if (!w.d || !w.tri || !out->values) {
        snprintf(err, errlen, "%s: out of memory for a distance grid of %zu nodes", m->path, n);
        goto done;
    }
    for (size_t i = 0; i < n; i++) w.d[i] = INFINITY, w.tri[i] = -1;
    if (band_pass(&w, m->ntri, band, nt)) {
        snprintf(err, errlen, "%s: out of memory", m->path);
        goto done;
    }
    for (int round = 0; round < 2; round++)
        for (int a = 0; a < 3; a++) sweep(&w, a, 1, nt), sweep(&w, a, -1, nt);
    q = kf_mesh_inside_create(m, NULL, 0, err, errlen);
    if (!q) goto done;
    if (sign_pass(&w, origin, q, out->values, nt, &out->inside_tests)) {
        snprintf(err, errlen, "%s: out of memory", m->path);
        goto done;
    }
    memcpy(out->grid.origin, w.o, sizeof w.o);
    out->grid.spacing = h;
    memcpy(out->grid.dims, w.n, sizeof w.n);
    out->grid.phi = out->values;
    out->spacing_asked = def->spacing;
    rc = 0;
done:
    if (q) kf_mesh_inside_destroy(q);
    free(V);
    free(w.d);
    free(w.tri);
    if (rc) kf_mesh_sdf_free(out);
    else out->seconds = (kf_now_ms() - t0) / 1e3;
    return rc;
}
