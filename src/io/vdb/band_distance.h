// band_distance.h — a true signed distance in a narrow band, from points
// on the surface (internal to the bridge; C++ only).
//
// Why not fast sweeping: inside a union of spheres the splat's value is the
// depth in the deepest sphere, not the distance to the surface, but outside
// it is exact, and so is each outside voxel's closest point (on its closest
// sphere). Those points lie on the surface about a voxel apart; the distance
// to the nearest of them is an upper bound of the true distance that is
// within a few hundredths of a voxel of it a voxel or more away, one pass
// over the band with no iteration and no sweeping order.
#ifndef KF_VDB_BAND_DISTANCE_H
#define KF_VDB_BAND_DISTANCE_H

#include "dense_band.h"

namespace kf_vdb {

// points on the surface (index space), grouped by the leaf of the voxel
// that found them: those of leaf i are [at[i], at[i + 1])
struct surface_points {
    std::vector<float> x, y, z;
    std::vector<uint32_t> at;
};

// Every voxel of b whose value is exact (0 <= phi < exact_out: the splat's
// distances outside) or places the zero crossing (inside, with an outside
// face neighbour) keeps it; every other voxel gets sign(phi) x the
// distance to the nearest point, less half the worst sampling error, never
// less than what the splat proves (its depth inside, exact_out outside),
// at most W. Points must lie within a voxel of the voxel that found them
// and W <= 7 (the nearest point is then in one of the 27 leaves around).
void band_distance(dense_band &b, const surface_points &s, float exact_out, float W);

} // namespace kf_vdb

#endif
