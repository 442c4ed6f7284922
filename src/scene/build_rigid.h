/* build_rigid.h — a shot's rigid bodies and joints into the model.
 *
 * Each body's surface is made here: a box is triangulated, a mesh file is
 * loaded (assimp, welded, closed ones oriented outward) and scaled; the
 * pivot goes to the origin and the rest rotation is baked in, so the model
 * sees a surface in its own frame with def.center = 0 and def.rotate = 0.
 * Problems the model finds (an open dynamic solid, a surface with no area)
 * are reported at the body's mesh: line, like every other shot error. */
#ifndef KF_BUILD_RIGID_H
#define KF_BUILD_RIGID_H

#include <stdint.h>

#include "../shot/shot.h"

/* Add shot->rigids then shot->joints to m, in file order (indices match).
 * Returns 0, or -1 with every problem in diag. */
int kf_scene_add_rigids(const kf_shot *shot, kf_model *m, kf_diag *diag);

/* The surface of one body in its model frame (pivot at the origin, rest
 * rotation applied): vertices (nv x 3) and triangles (nt x 3), malloc'ed.
 * Returns 0, or -1 with "path: reason" in err. */
int kf_rigid_surface(const kf_shot_rigid *r, double **vert, int *nv, int **tri, int *nt, char *err, size_t errlen);

/* Mix every simulation input of the rigid bodies and joints (values and
 * mesh file bytes) into the FNV-1a hash h; returns the new hash. */
uint64_t kf_shot_rigids_hash(const kf_shot *shot, uint64_t h);

/* h continued over a file's bytes (build.c), or over "<missing>" when it
 * cannot be read: an edited mesh under the same name is a new input. */
uint64_t kf_hash_file(uint64_t h, const char *path);

#endif
