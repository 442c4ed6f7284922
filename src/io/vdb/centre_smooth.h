// centre_smooth.h — particle centres pulled toward their neighbours' weighted
// mean before surfacing (internal to the bridge; C++ only).
//
// Why: particles seeded on a jittered lattice put the outermost centres
// anywhere in the last spacing, and a union of spheres shows that as bumps
// a spacing wide and a tenth of one high ("orange peel"), which no amount
// of level-set smoothing removes without also rounding every edge. Yu and
// Turk (2013) smooth the centres first: x_i <- (1 - lambda) x_i +
// lambda sum_j w_ij x_j / sum_j w_ij, with w = 1 - (d / R)^3 inside R.
// Averaging over the ~30 neighbours within two spacings divides the jitter
// by about five; a flat face stays flat because every centre near it moves
// inward by the same amount, which the caller gives back as a smaller
// erosion (shift_depth below).
#ifndef KF_VDB_CENTRE_SMOOTH_H
#define KF_VDB_CENTRE_SMOOTH_H

#include <cstddef>
#include <cstdint>
#include <vector>

namespace kf_vdb {

// Smoothed positions (n x 3 floats) of n particles given as doubles xd or
// floats xf (exactly one non-null); lambda in [0, 1], R in world units.
// Particles at least keep_depth below every face of the material (particle
// spacing h; 0: none) keep their place, found by occupancy of cells of two
// spacings (centre_smooth.cpp): their spheres lie under the surface either
// way, and skipping them is most of the work in a large body. *n_skipped
// (may be null) counts them. Deterministic for any thread count (each
// output depends only on the input).
std::vector<float> smooth_centres(size_t n, const double *xd, const float *xf, double lambda, double R, double h,
                                  double keep_depth, size_t *n_skipped);

// Flags in input order, 1 = deeper than `depth` below every face of a
// material seeded at spacing h (every cell of two spacings around holds a
// particle); all 0 when the test cannot run (depth over 14 h, too far out).
std::vector<uint8_t> deep_particles(size_t n, const double *xd, const float *xf, double h, double depth);

// How far inward the smoothing moves the centres of a flat face of a
// uniformly filled half-space with particle spacing h, averaged over the
// outermost layer (depths uniform in [0, h)): the surface moves in by as
// much, so erosion is reduced by it. A quadrature of the kernel over the
// half-space, not a fitted constant.
double shift_depth(double lambda, double R, double h);

} // namespace kf_vdb

#endif
