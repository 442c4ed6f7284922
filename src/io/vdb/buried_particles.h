// buried_particles.h — particles deep inside the union of spheres, whose
// spheres change nothing in the band (internal to the bridge; C++ only).
//
// Why: when particles are dense next to the voxels (a preview surface, one
// voxel per 1.5 particle spacings, holds ~3 particles a voxel), most of
// them lie far inside, and the splat would spend most of its time on
// spheres that no band voxel sees. A voxel holding a particle is inside
// (radii exceed half a voxel diagonal). A particle whose voxel (the nearest
// to it) has every voxel within Chebyshev distance M holding a particle has
// no outside voxel within M: with M past its splat reach (R + splat width +
// half a voxel, at least a voxel past R), it is nobody's closest sphere
// outside and sets no value beside a crossing. It
// still gives its nearest voxel its distance (sphere_raster.cpp), so every
// voxel it reaches stays inside: each holds a particle that marks it.
#ifndef KF_VDB_BURIED_PARTICLES_H
#define KF_VDB_BURIED_PARTICLES_H

#include <cstdint>
#include <vector>

namespace kf_vdb {

// Positions x, y, z in index space (voxel units), sorted into 8^3-voxel
// leaf bins (bin_key ascending, bin_at: first particle of each bin, and n
// at the end). Returns a flag per particle: 1 buried within M (M <= 8).
std::vector<uint8_t> buried_particles(const float *x, const float *y, const float *z,
                                      const std::vector<uint64_t> &bin_key, const std::vector<uint32_t> &bin_at, int M);

} // namespace kf_vdb

#endif
