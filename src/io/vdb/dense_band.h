// dense_band.h — a narrow band as dense 8^3-voxel leaves in index space
// (internal to the bridge; C++ only, never included from C).
//
// Why dense leaves and not an OpenVDB tree while surfacing: the splat, the
// distance and the smoothing each touch every band voxel a few times with
// a 3x3x3 stencil; flat arrays and one neighbour table cost less than tree
// accessors, topology dilation and pruning at every step. The tree is built
// once, at the end (sphere_raster.cpp).
#ifndef KF_VDB_DENSE_BAND_H
#define KF_VDB_DENSE_BAND_H

#include <openvdb/openvdb.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <vector>

namespace kf_vdb {

// OpenVDB's leaf layout: 8^3 voxels, offset (x << 6) + (y << 3) + z
constexpr int LEAF_LOG2 = 3;
constexpr int LEAF_DIM = 1 << LEAF_LOG2;
constexpr int LEAF_SIZE = LEAF_DIM * LEAF_DIM * LEAF_DIM;
constexpr int64_t LEAF_BIAS = int64_t(1) << 20; // leaf coordinates in +/- 2^20 pack into 21 bits

inline uint64_t leaf_key(int64_t lx, int64_t ly, int64_t lz) {
    return (uint64_t(lx + LEAF_BIAS) << 42) | (uint64_t(ly + LEAF_BIAS) << 21) | uint64_t(lz + LEAF_BIAS);
}

// leaf coordinates (voxel origin >> 3) of a key
inline openvdb::Coord leaf_coord(uint64_t k) {
    const uint64_t m = (uint64_t(1) << 21) - 1;
    return openvdb::Coord(int(int64_t((k >> 42) & m) - LEAF_BIAS), int(int64_t((k >> 21) & m) - LEAF_BIAS),
                          int(int64_t(k & m) - LEAF_BIAS));
}

// the leaves of a band: values in voxel units, negative inside. A leaf
// that is not listed lies wholly outside (every inside voxel's leaf is).
struct dense_band {
    std::vector<uint64_t> key; // ascending
    std::vector<float> phi;    // key.size() x LEAF_SIZE
    std::vector<int32_t> nbr;  // key.size() x 27: index of the leaf at (dx, dy, dz), -1 absent
    // a second buffer of phi's size for the passes that write a new phi and
    // swap it in: kept, so that each pass writes pages already mapped
    std::vector<float> scratch;

    size_t size() const { return key.size(); }
    float *leaf(size_t i) { return phi.data() + i * LEAF_SIZE; }
    const float *leaf(size_t i) const { return phi.data() + i * LEAF_SIZE; }
    static int nbr_slot(int dx, int dy, int dz) { return (dx + 1) * 9 + (dy + 1) * 3 + (dz + 1); }

    long find(uint64_t k) const {
        auto it = std::lower_bound(key.begin(), key.end(), k);
        return it != key.end() && *it == k ? long(it - key.begin()) : -1;
    }
    // fill nbr from key
    void link();
};

// a leaf with a one-voxel apron, as the band's stencil passes read it
constexpr int PADDED = LEAF_DIM + 2;

// leaf i and an apron of A voxels from the 26 neighbours into pad
// ((LEAF_DIM + 2 A)^3; missing neighbours: W), row by row: each z row is
// up to three runs, one from each leaf it crosses
template <int A> inline void gather_apron(const dense_band &b, size_t i, float W, float *pad) {
    constexpr int E = LEAF_DIM + 2 * A;
    for (int px = 0; px < E; px++) {
        const int lx = px - A, dx = lx < 0 ? -1 : (lx >= LEAF_DIM ? 1 : 0), x = lx - dx * LEAF_DIM;
        for (int py = 0; py < E; py++) {
            const int ly = py - A, dy = ly < 0 ? -1 : (ly >= LEAF_DIM ? 1 : 0), y = ly - dy * LEAF_DIM;
            float *row = pad + (px * E + py) * E;
            const int off = (x << 6) + (y << 3);
            const int32_t *nb = b.nbr.data() + 27 * i + dense_band::nbr_slot(dx, dy, 0);
            const int32_t jm = nb[-1], j0 = nb[0], jp = nb[1];
            for (int pz = 0; pz < A; pz++) row[pz] = jm < 0 ? W : b.leaf(size_t(jm))[off + LEAF_DIM - A + pz];
            if (j0 < 0) std::fill(row + A, row + A + LEAF_DIM, W);
            else std::copy(b.leaf(size_t(j0)) + off, b.leaf(size_t(j0)) + off + LEAF_DIM, row + A);
            for (int pz = 0; pz < A; pz++) row[A + LEAF_DIM + pz] = jp < 0 ? W : b.leaf(size_t(jp))[off + pz];
        }
    }
}

// leaf i and its one-voxel apron, as the band's stencil passes read it (PADDED^3)
inline void gather_padded(const dense_band &b, size_t i, float W, float *pad) { gather_apron<1>(b, i, W, pad); }

} // namespace kf_vdb

#endif
