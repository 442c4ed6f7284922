/* mesh_isect.h — does a triangle mesh intersect itself?
 *
 * A solid's surface must bound its inside once: where it passes through
 * itself (a bowl whose inner bottom pokes out through its foot) the inside
 * is ambiguous and material leaks through. Closed and consistently wound is
 * not enough, so solids are also checked here.
 *
 *     kf_mesh m;  ... kf_mesh_load ...
 *     if (kf_mesh_check_self_intersection(&m, 0, err, sizeof err)) fail(err);
 *
 * err then reads, for example,
 *     "tests/meshes/cubes_crossed.obj: intersects itself: triangles 3 and 18
 *      meet at (1, 0.25, 1) (file coordinates); 14 pairs of triangles intersect"
 *
 * Triangles that share an edge are never tested (neighbours always touch
 * along it); triangles that share one vertex intersect only where they meet
 * beyond it. Any other contact counts, touching included: in a valid solid,
 * triangles that are not neighbours do not meet at all. Orientation signs
 * are exact where a double-precision error bound proves them (Shewchuk's
 * filter); a sign within rounding of zero is taken as zero (on the plane),
 * so a contact within rounding is reported as a contact.
 * Nothing here prints or exits. */
#ifndef KF_SCENE_MESH_ISECT_H
#define KF_SCENE_MESH_ISECT_H

#include <stddef.h>
#include <stdint.h>

#include "mesh.h"

typedef struct kf_mesh_isect {
    size_t pairs;    /* pairs of triangles that intersect */
    uint32_t tri[2]; /* the first pair in triangle order (tri[0] < tri[1]), indices into m->tri */
    double at[3];    /* a point on both, in the mesh's coordinates */
} kf_mesh_isect;

/* Do triangles a and b (3 vertices x 3 coordinates each) intersect? Vertices
 * with identical coordinates are shared: two shared (an edge) give 0, one
 * shared gives 1 only where the triangles meet away from it. A triangle of
 * zero area gives 0. On 1, *at (if given) is a point on both. */
int kf_tri_tri_intersect(const double a[9], const double b[9], double at[3]);

/* Every pair of the mesh's triangles (a uniform grid over their bounding
 * boxes finds the candidates). threads <= 0: OpenMP's default. Returns 0 with
 * *out filled (out->pairs == 0: no self-intersection), -1 out of memory. */
int kf_mesh_self_intersections(const kf_mesh *m, int threads, kf_mesh_isect *out);

/* 0 when the mesh does not intersect itself, else -1 and the message above:
 * triangles counted from 1 in the order they load (the file's order for PLY,
 * STL, OFF and an OBJ of one material; polygons split into triangles, so an
 * all-triangle OBJ's face numbers), the point in the mesh's coordinates. */
int kf_mesh_check_self_intersection(const kf_mesh *m, int threads, char *err, size_t errlen);

#endif
