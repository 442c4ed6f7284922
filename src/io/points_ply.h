/* points_ply.h — particles as a binary PLY point cloud (Houdini, Blender and
 * MeshLab read it): position, velocity, material index, stable id, and the
 * fields for analysis (von Mises stress, J, plastic strain). */
#ifndef KF_POINTS_PLY_H
#define KF_POINTS_PLY_H

#include <kerf/kerf.h>

/* Written atomically. Returns 0, or -1 with a message in err. */
int kf_write_points_ply(const char *path, const kf_model *m, const kf_state *s, char *err, size_t errlen);

/* The same file from pieces (one MPI run's ranks' particles, without the
 * whole state in one place): _begin with the state's time and the whole
 * count n, _records for each piece's particles in the whole array's order,
 * _end renames (or drops the file and says why). 0, or -1 with err. */
typedef struct kf_ply_out {
    void *af; /* the atomic file */
} kf_ply_out;
int kf_ply_begin(kf_ply_out *o, const char *path, const kf_state *s, size_t n, char *err, size_t errlen);
void kf_ply_records(kf_ply_out *o, const kf_model *m, const kf_state *s);
int kf_ply_end(kf_ply_out *o, char *err, size_t errlen);

#endif
