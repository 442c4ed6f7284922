/* points_ply.h — particles as a binary PLY point cloud (Houdini, Blender and
 * MeshLab read it): position, velocity, material index, stable id, and the
 * fields for analysis (von Mises stress, J, plastic strain). */
#ifndef KF_POINTS_PLY_H
#define KF_POINTS_PLY_H

#include <kerf/kerf.h>

/* Written atomically. Returns 0, or -1 with a message in err. */
int kf_write_points_ply(const char *path, const kf_model *m, const kf_state *s, char *err, size_t errlen);

#endif
