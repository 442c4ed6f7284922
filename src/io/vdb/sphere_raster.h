// sphere_raster.h — particles to a narrow-band level set, rasterised by kerf
// itself (internal to the bridge; C++ only, never included from C).
//
// Why not OpenVDB's ParticlesToLevelSet: it writes every sphere through a
// shared tree accessor, one voxel at a time, and for kerf's radii (under the
// band's half width) every interior voxel stays active, so the filters that
// follow walk the whole volume. Here particles are sorted into 8^3-voxel leaf
// bins, each output leaf is filled in a dense local buffer from the bins
// around it (tbb::parallel_for, no sharing), and the result is re-distanced
// with fast sweeping and cut back to a true narrow band.
#ifndef KF_VDB_SPHERE_RASTER_H
#define KF_VDB_SPHERE_RASTER_H

#include <openvdb/openvdb.h>

#include <cstddef>

namespace kf_vdb {

// Particles as spheres: positions (exactly one of xd / xf, n x 3, world
// units), a radius per particle or one for all, raised to rmin when smaller.
struct sphere_set {
    size_t n;
    const double *xd;
    const float *xf;
    const float *radii; // per particle, or null: r
    double r;
    double rmin;        // 0: no clamp
    const float *vel;   // n x 3, or null
};

struct raster_timing {
    double sort_s, splat_s, redistance_s; // process CPU seconds of each phase
};

// The union of the spheres as a level set of voxel size h and half width hw
// voxels: exact distance to the union near its surface, re-distanced to a
// true signed distance inside the band, interior beyond the band inactive
// (negative background). When s.vel is set, *vel gets a Vec3s grid on the
// same active voxels holding the velocity of the closest particle.
openvdb::FloatGrid::Ptr rasterise_spheres(const sphere_set &s, double h, double hw, openvdb::Vec3SGrid::Ptr *vel,
                                          raster_timing *timing);

} // namespace kf_vdb

#endif
