// sphere_raster.h — particles to a narrow-band level set, rasterised by kerf
// itself (internal to the bridge; C++ only, never included from C).
//
// Why not OpenVDB's ParticlesToLevelSet: it writes every sphere through a
// shared tree accessor, one voxel at a time, and for kerf's radii (under the
// band's half width) every interior voxel stays active, so the filters that
// follow walk the whole volume. Here particles are sorted into 8^3-voxel leaf
// bins, each output leaf is filled in a dense local buffer from the bins
// around it (tbb::parallel_for, no sharing); the band is made a true signed
// distance from the spheres' closest points (band_distance.h), dilated,
// smoothed and eroded in place when asked (band_smooth.h), and only then
// becomes an OpenVDB tree.
#ifndef KF_VDB_SPHERE_RASTER_H
#define KF_VDB_SPHERE_RASTER_H

#include "dense_band.h"

#include <openvdb/openvdb.h>

#include <cstddef>
#include <cstdint>
#include <vector>

namespace kf_vdb {

// Particles as spheres: positions (exactly one of xd / xf, n x 3, world
// units), a radius per particle or one for all, raised to rmin when smaller.
struct sphere_set {
    size_t n;
    const double *xd;
    const float *xf;
    const float *radii; // per particle, or null: r
    double r;
    double rmin;      // 0: no clamp
    const float *vel; // n x 3, or null
};

struct raster_timing {
    double sort_s, splat_s, redistance_s, filter_s; // process CPU seconds of each phase
};

// the filters applied on the band before it becomes a tree (world units):
// dilate, mean-curvature steps, erode, then passes of the zero set's
// bilateral filter (band_flatten.h; radii in world units); (dilate +
// erode) / h + half width must stay within 6 voxels
struct band_filter {
    double dilate, erode;
    int mc_iterations;
    int flatten;                  // passes (0: none)
    double flatten_radius;        // the neighbourhood of each voxel's mean
    double flatten_normal_radius; // the neighbourhood of each point's mean normal
};

// The union of the spheres as a level set of voxel size h and half width hw
// voxels (at most 6): a signed distance in the band (exact outside within
// 1.5 voxels and inside within one, from the closest points beyond),
// filtered by f when given, interior beyond the band inactive (negative
// background). When s.vel is set, *vel gets a Vec3s grid on the active
// voxels within the spheres' reach, holding the velocity of the closest
// particle.
// A band (values in voxels, negative inside) as a level set of voxel size h:
// filtered by f first when given (W: the width it was computed to), |phi| <
// hw active, the interior by flood fill. With who (band.size() x LEAF_SIZE
// particle indices, -1 none), vel (n x 3) and velgrid, *velgrid gets each
// active voxel's particle's velocity.
openvdb::FloatGrid::Ptr band_to_grid(dense_band &band, double h, double hw, float W, const band_filter *f,
                                     const std::vector<int32_t> *who, const float *vel,
                                     openvdb::Vec3SGrid::Ptr *velgrid);

openvdb::FloatGrid::Ptr rasterise_spheres(const sphere_set &s, double h, double hw, const band_filter *f,
                                          openvdb::Vec3SGrid::Ptr *vel, raster_timing *timing);

} // namespace kf_vdb

#endif
