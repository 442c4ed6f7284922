/* sample.h — particles seeded inside a box, sphere, cylinder or closed mesh.
 *
 * The lattice is the one kf_state_fill_box uses, fixed to the world: with
 * ppc = n³ particles per cell and h = Δx / n, candidate points sit at
 * (i + ½)·h per axis (regular), or at (i + u)·h with u ∈ [0, 1) hashed from
 * (i, j, k, seed) (jittered, seed != 0), so the result does not depend on
 * thread count or visiting order. A candidate is kept when it is inside the
 * placed shape. Every particle has volume Δx³ / ppc.
 *
 *     kf_sample_def d = kf_default_sample_def();
 *     d.kind = KF_SOURCE_MESH;  d.mesh_path = "assets/bunny.off";
 *     d.place.fit = 1;  d.place.fit_size = 0.5;  (fit_center = {0.5, 0.35, 0.5})
 *     d.dx = 0.01;  d.ppc = 8;  d.seed = 7;  d.velocity[1] = -1;
 *     kf_points pts;
 *     if (kf_sample_shape(&d, &pts, err, sizeof err)) report(err);
 *     kf_state_add_particles(s, m, pts.n, pts.x, pts.v, NULL, material, pts.volume);
 *     kf_points_free(&pts);
 */
#ifndef KF_SCENE_SAMPLE_H
#define KF_SCENE_SAMPLE_H

#include <stddef.h>
#include <stdint.h>

#include "../shot/source.h" /* kf_source_kind, kf_placement: the shot spec's words */
#include "inside.h"
#include "mesh.h"

typedef struct kf_sample_def {
    kf_source_kind kind;
    double size[3];        /* box: edge lengths, m (local) */
    double radius;         /* sphere, cylinder: m (local) */
    double height;         /* cylinder: m (local) */
    const char *mesh_path; /* mesh: file to load when mesh is NULL */
    const kf_mesh *mesh;   /* mesh: already loaded (not changed; takes precedence over mesh_path) */
    kf_placement place;
    double dx;                  /* grid spacing, m */
    int ppc;                    /* particles per cell: 1, 8, 27 or 64 (0 = 8) */
    uint32_t seed;              /* 0 = regular lattice, else jittered with this seed */
    double velocity[3];         /* v0, m/s */
    double angular_velocity[3]; /* ω, rad/s: v = v0 + ω × (x − centroid of the seeded particles) */
    int threads;                /* 0 = OpenMP default */
    /* Keep only the points this says (NULL: all): called once per point of
     * the shape, in the output order, from one thread. The centroid and the
     * velocities are those of the whole shape; n counts the kept points. */
    int (*keep)(void *ctx, const double x[3]);
    void *keep_ctx;
    /* Hand the kept points here instead of keeping them in kf_points.x
     * (NULL: kept): called from one thread, in the output order, up to
     * KF_SAMPLE_EMIT_CHUNK at a time, with their velocities (NULL for a
     * shape at rest), each particle's volume (kf_points.volume) and the
     * most points the shape can have (its candidates: room for them once
     * costs only address space, growing by doubling would copy), so a large shape never sits in doubles beside the
     * particles made from it. Only without angular_velocity (each velocity is
     * then v0, bit for bit, whatever the centroid) and without a -0 in
     * velocity; kf_sample_shape refuses it otherwise. kf_points.x stays NULL
     * and n counts the points handed over. Return 0, or -1 to stop (out of
     * memory: kf_sample_shape then fails). */
    int (*emit)(void *ctx, const double *x, const double *v, size_t n, double volume, size_t most);
    void *emit_ctx;
} kf_sample_def;

#define KF_SAMPLE_EMIT_CHUNK 65536

/* whether def's velocities allow emit (see above) */
int kf_sample_can_emit(const kf_sample_def *def);

/* Zero everything, ppc = 8, scale = 1. */
kf_sample_def kf_default_sample_def(void);

typedef struct kf_sample_stats {
    long candidates; /* lattice points in the shape's bounding box */
    long tested;     /* mesh inside tests actually made (blocks away from the surface take one) */
    kf_inside_stats inside;
    double seconds; /* wall time of kf_sample_shape */
} kf_sample_stats;

typedef struct kf_points {
    size_t n;
    size_t whole;        /* the shape's points: n, and with def.keep those it left out too */
    double *x;           /* (n x 3) positions, m */
    double *v;           /* (n x 3) velocities, m/s; NULL for a shape at rest (velocity and angular_velocity +0) */
    double volume;       /* rest volume of each particle, Δx³ / ppc, m³ */
    double centroid[3];  /* mean of x, m: the pivot of angular_velocity */
    double lo[3], hi[3]; /* world bounding box of the placed shape, m */
    kf_sample_stats stats;
} kf_points;

/* Seed the shape. Returns 0 (out filled; n may be 0 for a shape thinner than
 * the lattice), or -1 with a message: every problem with the def ("sample:
 * dx must be > 0 (got 0)"; several joined by "; "), or the mesh's
 * "path: reason" (not found, no faces, not closed: N boundary edges, ...). */
int kf_sample_shape(const kf_sample_def *def, kf_points *out, char *err, size_t errlen);

void kf_points_free(kf_points *p);

/* The local-to-world map of a def's placement, row-major 3x4 [A | t]
 * (x_world = A x_local + t), and the world bounding box of the placed shape.
 * mesh is used for KF_SOURCE_MESH (its vertices give the exact fitted box).
 * Use it to place rigid meshes the same way (kf_mesh_transform(mesh, M)).
 * Returns 0, or -1 with a message for a bad shape size, scale or fit. */
int kf_sample_placement(const kf_sample_def *def, const kf_mesh *mesh, double M[12], double lo[3], double hi[3],
                        char *err, size_t errlen);

#endif
