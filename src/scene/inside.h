/* inside.h — is a point inside a closed triangle mesh? Embree ray parity.
 *
 * A ray from the point crosses the surface an odd number of times when the
 * point is inside. Embree's triangle test is not watertight, so a ray that
 * passes through (or within ε of) an edge or a vertex may count a crossing
 * twice or not at all, and a ray grazing a face is ill-conditioned. Every hit
 * is therefore checked: a ray with a hit whose barycentric coordinates are
 * within ε of an edge, or whose direction is within ε of the face plane, is
 * *unreliable* and is discarded; the next direction of a fixed list of generic
 * (irrational, non-axis) directions is cast instead. The answer is the
 * majority of the first three reliable rays (two agreeing suffice). Each
 * triangle is counted once per ray, however often Embree reports it.
 *
 * Parity means a mesh of several closed pieces that overlap counts the
 * overlap as outside (nested pieces make cavities, as intended); union such
 * pieces before seeding, or seed them as separate sources.
 *
 * The query object is read-only after creation: any number of threads may
 * query it at once (each call uses its own intersect context on the stack).
 *
 *     kf_mesh_inside *q = kf_mesh_inside_create(&mesh, NULL, 0, err, sizeof err);
 *     kf_mesh_inside_points(q, n, xyz, flags, &stats);  // OpenMP over points
 *     kf_mesh_inside_destroy(q);
 */
#ifndef KF_SCENE_INSIDE_H
#define KF_SCENE_INSIDE_H

#include <stddef.h>
#include <stdint.h>

#include "mesh.h"

typedef struct kf_mesh_inside kf_mesh_inside;

/* How much work the queries did (added to by each call that is given one). */
typedef struct kf_inside_stats {
    long points;     /* points classified */
    long rays;       /* rays cast */
    long unreliable; /* rays discarded for a hit near an edge/vertex or a grazing hit */
    long undecided;  /* points where no reliable majority was found (answered by all rays' majority) */
} kf_inside_stats;

#define KF_INSIDE_MAX_DIRS 16

/* Build the Embree scene of a closed mesh (copied to float, about its bounds'
 * centre for precision). dirs (may be NULL) replaces the first ndirs of the
 * default ray directions, for tests that want axis-aligned rays to hit edges
 * exactly; they are normalised. Returns NULL with "path: reason" in err when
 * the mesh is not closed or Embree fails. */
kf_mesh_inside *kf_mesh_inside_create(const kf_mesh *m, const double (*dirs)[3], int ndirs, char *err, size_t errlen);
void kf_mesh_inside_destroy(kf_mesh_inside *q);

/* 1 inside, 0 outside. Points within about 1e-6 of the mesh size of the
 * surface may go either way. stats may be NULL. Sets FTZ/DAZ for the call and
 * restores the caller's floating-point mode afterwards. */
int kf_mesh_inside_point(const kf_mesh_inside *q, const double p[3], kf_inside_stats *stats);

/* Classify n points (p3: n x 3) into inside[n] (1/0), in parallel with
 * OpenMP (threads <= 0: the OpenMP default). stats may be NULL. */
void kf_mesh_inside_points(const kf_mesh_inside *q, size_t n, const double *p3, uint8_t *inside, int threads,
                           kf_inside_stats *stats);

/* The default ray directions (unit vectors), for reference. Returns the count. */
int kf_mesh_inside_default_dirs(double dirs[KF_INSIDE_MAX_DIRS][3]);

#endif
