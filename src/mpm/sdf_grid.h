/* sdf_grid.h — reading a sampled signed distance field (kf_sdf_grid, kerf.h).
 *
 * The grid is plain data: mesh colliders get theirs from scene/mesh_sdf.c
 * (Embree and assimp stay out of this module), and a caller of the public
 * API may fill one from anywhere (an OpenVDB level set, an analytic shape). */
#ifndef KF_SDF_GRID_H
#define KF_SDF_GRID_H

#include <kerf/kerf.h>

/* φ at X (the grid's frame, metres) by trilinear interpolation, and its
 * gradient (the trilinear interpolant's, exact within a cell) in grad.
 * Outside the grid's box: the value at the nearest point of the box plus
 * the distance to it, with the gradient pointing away from the box; so
 * points beyond the padding read as outside, far from the surface. */
double kf_sdf_grid_sample(const kf_sdf_grid *g, const double X[3], double grad[3]);

/* The gradient of the interpolated field by central differences one grid
 * spacing either side of X (six reads). Unlike the trilinear gradient,
 * which is one-sided at cell faces and nodes, it points to the nearer
 * surface inside a wall only a cell or two thick. */
void kf_sdf_grid_gradient(const kf_sdf_grid *g, const double X[3], double grad[3]);

/* The box the grid's nodes span, in its frame. */
void kf_sdf_grid_bounds(const kf_sdf_grid *g, double lo[3], double hi[3]);

/* "" when the grid is usable, else what is wrong with it. */
const char *kf_sdf_grid_check(const kf_sdf_grid *g);

/* Node count (dims[0] dims[1] dims[2]). */
size_t kf_sdf_grid_nodes(const kf_sdf_grid *g);

#endif
