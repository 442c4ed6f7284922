/* bvh.h — segment queries against a rigid body's triangles in its mesh frame (bvh.c). */
#ifndef KF_RIGID_BVH_H
#define KF_RIGID_BVH_H

#include <stddef.h>

typedef struct kf_rigid_bvh kf_rigid_bvh;

/* Build once per body (mesh frame). NULL with a message on failure. */
kf_rigid_bvh *kf_rigid_bvh_build(const double *vert, int nvert, const int *tri, int ntri, char *err, size_t errlen);
void kf_rigid_bvh_free(kf_rigid_bvh *b); /* NULL is fine */

/* The first triangle the segment p0 -> p1 passes through (its index), with
 * the segment's parameter there in *t (0..1); -1 when it passes through none.
 * Thread-safe. */
int kf_rigid_bvh_first_hit(const kf_rigid_bvh *b, const double p0[3], const double p1[3], double *t);

/* The closest point q of the surface to p within radius (mesh frame), the
 * triangle's index as returned, or -1 when none is that close. *interior:
 * q lies inside that triangle, not on an edge or a corner (where the side
 * of p is not the triangle's to say). Thread-safe. */
int kf_rigid_bvh_closest(const kf_rigid_bvh *b, const double p[3], double radius, double q[3], int *interior);

/* Every triangle whose closest point to p (mesh frame) is within radius:
 * fn(ctx, index) for each, in the scene's order; once fn returns nonzero
 * the rest are passed over. Thread-safe. */
void kf_rigid_bvh_within(const kf_rigid_bvh *b, const double p[3], double radius, int (*fn)(void *ctx, int tri),
                         void *ctx);

#endif
