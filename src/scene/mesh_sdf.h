/* mesh_sdf.h — a closed triangle mesh sampled into a signed distance grid
 * (kf_sdf_grid, kerf.h) for a mesh collider.
 *
 * Distances: every node within `band` of a triangle gets its exact distance
 * (point-triangle, each triangle visits the nodes of its bounding box grown
 * by the band); the rest inherit the closest triangle from a neighbour in
 * two rounds of sweeps along ±x, ±y, ±z (SDFGen-style propagation: a
 * distance to a real triangle, so never below the true distance, and exact
 * within the band). Signs: Embree inside tests (inside.h). Two neighbouring
 * nodes both farther than spacing/2 from the surface cannot have the
 * surface between them, so a 4³ block of such nodes takes the sign of one
 * test; only blocks near the surface test every node.
 *
 *     kf_mesh_sdf_def d = kf_default_mesh_sdf_def();
 *     d.spacing = dx / 2;  d.pad = 3 * dx;
 *     kf_mesh_sdf sdf;
 *     if (kf_mesh_sdf_build(&placed_mesh, pivot, &d, &sdf, err, sizeof err)) fail(err);
 *     collider.sdf = &sdf.grid;  kf_model_add_collider(m, &collider, ...);  // copies it
 *     kf_mesh_sdf_free(&sdf);
 */
#ifndef KF_SCENE_MESH_SDF_H
#define KF_SCENE_MESH_SDF_H

#include <stddef.h>

#include <kerf/kerf.h>
#include "mesh.h"

/* the default node budget: 2^24 nodes, 64 MB of floats */
#define KF_MESH_SDF_MAX_NODES ((size_t)1 << 24)

typedef struct kf_mesh_sdf_def {
    double spacing;   /* m, grid spacing asked for */
    double pad;       /* m, margin around the mesh's bounds (0 = 3 spacings) */
    double band;      /* m, exact distances within this of the surface (0 = 3 spacings; at least spacing/2) */
    size_t max_nodes; /* the spacing grows until the grid fits (0 = KF_MESH_SDF_MAX_NODES) */
    int threads;      /* 0 = OpenMP default */
} kf_mesh_sdf_def;

kf_mesh_sdf_def kf_default_mesh_sdf_def(void);

typedef struct kf_mesh_sdf {
    kf_sdf_grid grid;     /* ready for kf_collider.sdf (grid.phi = values) */
    float *values;        /* owned */
    double spacing_asked; /* def->spacing; grid.spacing is larger when the grid had to fit max_nodes */
    long inside_tests;    /* Embree inside tests made */
    double seconds;       /* wall time */
} kf_mesh_sdf;

/* Sample the closed mesh m (world coordinates) on a grid in the frame whose
 * origin is `origin` (the collider's pivot: grid positions are x - origin).
 * Returns 0, or -1 with "path: reason" (not closed, no triangles, bad def,
 * out of memory). */
int kf_mesh_sdf_build(const kf_mesh *m, const double origin[3], const kf_mesh_sdf_def *def, kf_mesh_sdf *out, char *err,
                      size_t errlen);

void kf_mesh_sdf_free(kf_mesh_sdf *s);

/* Squared distance from p to the triangle (a, b, c), and the closest point
 * in q (may be NULL). */
double kf_point_triangle_dist2(const double p[3], const double a[3], const double b[3], const double c[3], double q[3]);

#endif
