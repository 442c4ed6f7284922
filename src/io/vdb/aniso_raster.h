// aniso_raster.h — particles to a narrow-band level set through anisotropic
// kernels (after Yu & Turk 2013; internal to the bridge; C++ only).
//
// Why: a union of spheres takes the highest sphere under each point, and a
// sphere's cap is round, so a face follows the one or two highest jittered
// centres under it; flattening that (averaging the centres, smoothing)
// rounds every edge by as much. Here each particle near a face is a thin
// disc along the face (its neighbours' weighted covariance gives the
// orientation): a face is then the highest of the many centres under a
// disc's width, nearly flat, while a disc near an edge is as short across
// the edge as its neighbourhood and does not reach round it. Particles deep
// inside are balls of the full reach; a lone particle a small ball.
#ifndef KF_VDB_ANISO_RASTER_H
#define KF_VDB_ANISO_RASTER_H

#include "dense_band.h"
#include "sphere_raster.h"

#include <openvdb/openvdb.h>

#include <cstddef>

namespace kf_vdb {

// world units
struct aniso_params {
    double spacing;   // particle spacing h
    double support;   // a disc's radius in a full neighbourhood (and a deep ball's)
    double R;         // the neighbourhood of the covariance
    double thickness; // a disc's half thickness (a lone particle's ball: twice that)
    double kr;        // a disc's radius at least 1/kr of its longest
};

struct aniso_timing {
    double shape_s, sort_s, splat_s, redistance_s, filter_s; // process CPU seconds of each phase
    double shape_w, sort_w, splat_w, redistance_w, filter_w; // wall seconds of each phase
    size_t n_deep;                                           // particles given a ball unexamined
};

// The union of the particles' kernels (positions: exactly one of xd / xf,
// n x 3, world units) as a level set of voxel size vx and half width hw
// voxels (at most 6): a signed distance in the band from the union's
// crossings of the voxel edges, filtered by f when given. Its faces lie
// `thickness` beyond the outermost centres. With vel (n x 3) and velgrid,
// *velgrid holds on the active voxels the velocity of the particle whose
// kernel reaches farthest there. Deterministic for any thread count.
openvdb::FloatGrid::Ptr rasterise_anisotropic(size_t n, const double *xd, const float *xf, const float *vel,
                                              const aniso_params &a, double vx, double hw, const band_filter *f,
                                              openvdb::Vec3SGrid::Ptr *velgrid, aniso_timing *timing);

} // namespace kf_vdb

#endif
