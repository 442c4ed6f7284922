// band_flatten.h — a feature-preserving filter of a band's surface
// (internal to the bridge; C++ only).
//
// Why: a union of kernels over jittered centres leaves its faces rough by a
// fraction of a spacing (each face follows the highest few centres under
// it), and curvature flow flattens that only by rounding the edges as much.
// Here each voxel near the surface gets the weighted mean distance to the
// tangent planes of the surface points around it (points of the band's own
// zero set, with its normals), weighted by distance and by how close their
// normals are to its own: a face averages its bumps over many points, and
// across an edge the other face's points, whose normals differ, take no
// part (a bilateral filter on the zero set).
#ifndef KF_VDB_BAND_FLATTEN_H
#define KF_VDB_BAND_FLATTEN_H

#include "dense_band.h"

namespace kf_vdb {

// the normals' weight: a point whose normal is more than acos(1 - sigma)
// (14 degrees) from a voxel's takes no part in its mean; a face's bumps tilt
// its normals a few degrees, an edge turns them by far more
constexpr float FLATTEN_SIGMA = 0.03f;

// One pass, in voxel units: the surface points (one per voxel edge the zero
// set crosses: the mean of its two voxels' closest points) get their
// normals averaged over normal_radius
// (0: kept), then every voxel within 1.5 of the zero set gets the weighted
// mean, over the points within radius, of its distance to their tangent
// planes (the mean of its own normal's plane and theirs through each
// point: on a sphere their errors cancel), with weights (1 - d^2/r^2)^2 (1 -
// ((1 - n.m) / sigma)^2)^2. Radii at most 7.5 (the points are looked for in
// the 27 leaves around). A missing leaf reads +W (outside).
void band_flatten(dense_band &b, float W, float radius, float sigma, float normal_radius);

} // namespace kf_vdb

#endif
