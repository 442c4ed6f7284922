/* surface_look.h — how finished a surfaced block looks, measured: a jittered
 * box of particles is surfaced with the shot defaults and its level set is
 * probed along lines. Shared by test_surface_look.c and the evidence tool
 * tools/evidence/surface_look.c (header-only, static functions).
 *
 * The block is seeded like a shot object: 8 particles per cell on the
 * jittered lattice (each particle uniform in its lattice cell), so the
 * outermost centres lie anywhere in the last spacing h. Its material
 * boundary is the box itself. Measures, all in particle spacings h:
 *   top_rms   RMS distance of the top face (probed on a grid of vertical
 *             lines at least 2 h in from its edges) from its least-squares
 *             plane;
 *   top_off   mean height of the top face above the box's top;
 *   edge      radius of the rounded top edges: along the diagonal through
 *             the corner of the two faces' fitted planes, a round edge of
 *             radius rho lies rho (sqrt 2 - 1) in from that corner;
 *   vol_err   enclosed volume (the mesh's, by the divergence theorem) over
 *             the box's volume, minus 1. */
#ifndef KF_SURFACE_LOOK_H
#define KF_SURFACE_LOOK_H

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "io/vdb_bridge.h"
#include "scene/sample.h"
#include "shot/shot.h"

/* a shot's surface settings, in particle spacings, as the surface stage
 * turns them into the bridge's parameters (erosion back onto the material);
 * kernel as the shot key: 0 anisotropic discs, 1 spheres */
typedef struct look_settings {
    int kernel;
    double voxel, radius, average, average_radius, reach;
    int iterations, flatten;
} look_settings;

/* kerf's settings before the anisotropic discs: spheres on averaged centres
 * (the comparison in the evidence) */
static const look_settings look_spheres = {1, 0.75, 2, 1, 3, 3, 1, 0};

/* a loaded shot's surface settings */
static inline look_settings look_of_shot(const kf_shot *shot) {
    return (look_settings){shot->surface_kernel,     shot->surface_voxel,          shot->surface_radius,
                           shot->surface_average,    shot->surface_average_radius, shot->surface_reach,
                           shot->surface_iterations, shot->surface_flatten};
}

static inline void look_params(kf_vdb_surface_params *p, double h, look_settings s) {
    kf_vdb_surface_params_default(p);
    p->spacing = h;
    p->voxel = s.voxel * h;
    p->smooth = KF_VDB_OP_MEAN_CURVATURE;
    p->smooth_iterations = s.iterations;
    p->flatten = s.flatten;
    if (s.kernel == 0) {
        p->kernel = KF_VDB_KERNEL_ANISOTROPIC;
        p->radius = p->average_radius = s.reach * h;
    } else {
        p->radius = s.radius * h;
        p->average = s.average;
        p->average_radius = s.average_radius * h;
    }
    p->erode = kf_vdb_surface_offset(p);
    p->clamp_small = 1;
}

/* jittered particles of shape d (ppc 8 on a grid of dx = 2 h) */
static inline int look_fill(kf_sample_def *d, double h, uint32_t seed, kf_points *pts) {
    d->dx = 2 * h;
    d->ppc = 8;
    d->seed = seed;
    d->threads = 1;
    char err[256];
    if (kf_sample_shape(d, pts, err, sizeof err)) {
        fprintf(stderr, "seed: %s\n", err);
        return -1;
    }
    return 0;
}

/* jittered particles in the box lo..hi */
static inline int look_seed(const double lo[3], const double hi[3], double h, uint32_t seed, kf_points *pts) {
    kf_sample_def d = kf_default_sample_def();
    d.kind = KF_SOURCE_BOX;
    for (int a = 0; a < 3; a++) d.size[a] = hi[a] - lo[a], d.place.translate[a] = 0.5 * (lo[a] + hi[a]);
    return look_fill(&d, h, seed, pts);
}

/* signed volume enclosed by a closed, outward-wound mesh */
static inline double look_mesh_volume(const kf_vdb_trimesh *m) {
    double v = 0;
    for (size_t t = 0; t < m->ntris; t++) {
        const float *a = m->verts + 3 * m->tris[3 * t], *b = m->verts + 3 * m->tris[3 * t + 1],
                    *c = m->verts + 3 * m->tris[3 * t + 2];
        v += (double)a[0] * (b[1] * c[2] - b[2] * c[1]) - (double)a[1] * (b[0] * c[2] - b[2] * c[0]) +
             (double)a[2] * (b[0] * c[1] - b[1] * c[0]);
    }
    return v / 6;
}

/* jittered particles in a ball of radius r about c */
static inline int look_seed_ball(const double c[3], double r, double h, uint32_t seed, kf_points *pts) {
    kf_sample_def d = kf_default_sample_def();
    d.kind = KF_SOURCE_SPHERE;
    d.radius = r;
    for (int a = 0; a < 3; a++) d.place.translate[a] = c[a];
    return look_fill(&d, h, seed, pts);
}

/* enclosed volume of a level set's mesh over vol, minus 1 */
static inline double look_volume_error(const kf_vdb_grid *g, double vol) {
    kf_vdb_trimesh mesh;
    char err[256];
    if (kf_vdb_mesh(g, 0, 0, &mesh, err, sizeof err)) return NAN;
    const double e = look_mesh_volume(&mesh) / vol - 1;
    kf_vdb_mesh_free(&mesh);
    return e;
}

static inline double look_phi(const kf_vdb_grid *g, double x, double y, double z) {
    double q[3] = {x, y, z}, d = 0;
    kf_vdb_sample(g, q, 1, &d, NULL, 0);
    return d;
}

/* the zero crossing between a (inside) and b (outside) on a line, bisected */
static inline double look_cross(const kf_vdb_grid *g, const double a[3], const double b[3]) {
    double s0 = 0, s1 = 1;
    for (int it = 0; it < 40; it++) {
        double s = 0.5 * (s0 + s1), q[3];
        for (int k = 0; k < 3; k++) q[k] = a[k] + s * (b[k] - a[k]);
        if (look_phi(g, q[0], q[1], q[2]) < 0) s0 = s;
        else s1 = s;
    }
    return 0.5 * (s0 + s1);
}

typedef struct look_result {
    double top_rms, top_off, edge, vol_err;
} look_result;

/* least-squares plane y = c0 + c1 x + c2 z through m points (x, y, z); RMS residual */
static inline double look_plane_rms(const double *p, int m, double *mean) {
    double A[3][3] = {{0}}, b[3] = {0};
    for (int i = 0; i < m; i++) {
        double r[3] = {1, p[3 * i], p[3 * i + 2]};
        for (int u = 0; u < 3; u++) {
            b[u] += r[u] * p[3 * i + 1];
            for (int v = 0; v < 3; v++) A[u][v] += r[u] * r[v];
        }
    }
    /* Gaussian elimination on the 3x3 normal equations */
    for (int c = 0; c < 3; c++)
        for (int r = c + 1; r < 3; r++) {
            double f = A[r][c] / A[c][c];
            for (int k = 0; k < 3; k++) A[r][k] -= f * A[c][k];
            b[r] -= f * b[c];
        }
    double x[3];
    for (int r = 2; r >= 0; r--) {
        double s = b[r];
        for (int k = r + 1; k < 3; k++) s -= A[r][k] * x[k];
        x[r] = s / A[r][r];
    }
    double ss = 0, sum = 0;
    for (int i = 0; i < m; i++) {
        double e = p[3 * i + 1] - (x[0] + x[1] * p[3 * i] + x[2] * p[3 * i + 2]);
        ss += e * e;
        sum += p[3 * i + 1];
    }
    *mean = sum / m;
    return sqrt(ss / m);
}

/* Probe a block's level set g (box lo..hi, spacing h). */
static inline look_result look_measure(const kf_vdb_grid *g, const double lo[3], const double hi[3], double h) {
    look_result r = {0};
    /* top face: vertical lines every half spacing, 2 h in from its edges */
    const double step = 0.5 * h, m0 = 2 * h;
    int nx = (int)((hi[0] - lo[0] - 2 * m0) / step) + 1, nz = (int)((hi[2] - lo[2] - 2 * m0) / step) + 1;
    double *p = malloc(sizeof(double) * 3 * (size_t)nx * (size_t)nz);
    int m = 0;
    for (int i = 0; i < nx; i++)
        for (int k = 0; k < nz; k++) {
            double x = lo[0] + m0 + i * step, z = lo[2] + m0 + k * step;
            double a[3] = {x, hi[1] - 2 * h, z}, b[3] = {x, hi[1] + 2 * h, z};
            double s = look_cross(g, a, b);
            p[3 * m] = x, p[3 * m + 1] = a[1] + s * (b[1] - a[1]), p[3 * m + 2] = z;
            m++;
        }
    double mean;
    r.top_rms = look_plane_rms(p, m, &mean) / h;
    r.top_off = (mean - hi[1]) / h;
    /* the four top edges: the faces' mean positions (probed 2 h from the
     * edge), then the crossing along the 45-degree diagonal through their
     * corner, averaged along each edge's middle half */
    double rho = 0;
    int ne = 0;
    for (int e = 0; e < 4; e++) {
        int ax = e < 2 ? 0 : 2, oth = 2 - ax; /* the edge runs along oth */
        double sgn = (e & 1) ? 1 : -1, face = (e & 1) ? hi[ax] : lo[ax];
        double L = hi[oth] - lo[oth];
        for (int j = 0; j < 16; j++) {
            double t = lo[oth] + L * (0.25 + 0.5 * j / 15.0);
            /* the side face's position 3 h below the top */
            double a[3], b[3];
            a[1] = b[1] = hi[1] - 3 * h;
            a[oth] = b[oth] = t;
            a[ax] = face - sgn * 2 * h, b[ax] = face + sgn * 2 * h;
            double side = a[ax] + look_cross(g, a, b) * (b[ax] - a[ax]);
            /* the top face's height 3 h in from the edge */
            a[ax] = b[ax] = face - sgn * 3 * h;
            a[1] = hi[1] - 2 * h, b[1] = hi[1] + 2 * h;
            double top = a[1] + look_cross(g, a, b) * (b[1] - a[1]);
            /* diagonal from inside to the corner of the two planes and beyond */
            double c[3];
            c[oth] = t, c[ax] = side, c[1] = top;
            a[oth] = b[oth] = t;
            a[ax] = c[ax] - sgn * 2 * h, a[1] = c[1] - 2 * h;
            b[ax] = c[ax] + sgn * 1 * h, b[1] = c[1] + 1 * h;
            double s = look_cross(g, a, b);
            double q0 = a[ax] + s * (b[ax] - a[ax]), q1 = a[1] + s * (b[1] - a[1]);
            double d = hypot(c[ax] - q0, c[1] - q1);
            if ((q0 - c[ax]) * sgn > 0) d = -d; /* beyond the corner: sharper than square */
            rho += d / (sqrt(2.0) - 1);
            ne++;
        }
    }
    r.edge = rho / ne / h;
    /* volume of the mesh */
    kf_vdb_trimesh mesh;
    char err[256];
    if (kf_vdb_mesh(g, 0, 0, &mesh, err, sizeof err) == 0) {
        double box = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
        r.vol_err = look_mesh_volume(&mesh) / box - 1;
        kf_vdb_mesh_free(&mesh);
    } else {
        r.vol_err = NAN;
    }
    free(p);
    return r;
}

/* Holes in a sheet lo..hi two spacings thick: the fraction of vertical lines
 * (every half spacing, 2 h in from its edges) along which the level set is
 * nowhere inside. */
static inline double look_sheet_holes(const kf_vdb_grid *g, const double lo[3], const double hi[3], double h) {
    const double step = 0.5 * h, m0 = 2 * h;
    int nx = (int)((hi[0] - lo[0] - 2 * m0) / step) + 1, nz = (int)((hi[2] - lo[2] - 2 * m0) / step) + 1, holes = 0;
    for (int i = 0; i < nx; i++)
        for (int k = 0; k < nz; k++) {
            double x = lo[0] + m0 + i * step, z = lo[2] + m0 + k * step, lowest = 1e30;
            for (double y = lo[1] - h; y <= hi[1] + h; y += 0.05 * h) {
                double d = look_phi(g, x, y, z);
                lowest = d < lowest ? d : lowest;
            }
            holes += lowest >= 0;
        }
    return (double)holes / ((double)nx * nz);
}

#endif
