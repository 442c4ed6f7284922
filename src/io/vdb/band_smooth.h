// band_smooth.h — dilate, mean-curvature flow and erode on a dense band
// (internal to the bridge; C++ only).
//
// Why not LevelSetFilter: on a true distance an offset within the band is
// one exact shift, and a few curvature steps move the surface a fraction of
// a voxel, so the band can keep its voxels throughout. OpenVDB's filter
// re-normalises, dilates and prunes its band after every step (most of its
// cost); here each step is one pass of the curvature stencil over a band
// made wide enough beforehand (dilate + erode + a voxel beyond the final
// half width), and the shifts are exact.
#ifndef KF_VDB_BAND_SMOOTH_H
#define KF_VDB_BAND_SMOOTH_H

#include "dense_band.h"

namespace kf_vdb {

// In voxel units: phi -= dilate, then `iterations` mean-curvature steps
// (OpenVDB's scheme and time step: second-order central differences,
// dt = 1/3 voxel^2, speed = curvature x |grad phi|) on the voxels with
// |phi| < W, then phi += erode. A missing leaf reads +W (outside).
void band_smooth(dense_band &b, float W, float dilate, int iterations, float erode);

} // namespace kf_vdb

#endif
