// buried_particles.cpp — occupancy eroded by M voxels, per leaf bin (see buried_particles.h).
#include "buried_particles.h"

#include "dense_band.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace kf_vdb {

namespace {

// keep only the voxels whose window [-M, M] along one axis (stride st, n
// voxels a line, lines given by the two other strides) is all set
void erode_axis(std::vector<uint8_t> &a, std::vector<uint8_t> &tmp, int S, int M, int st, int s1, int s2) {
    std::vector<int> run(S + 1);
    for (int i = 0; i < S; i++)
        for (int j = 0; j < S; j++) {
            const int base = i * s1 + j * s2;
            run[0] = 0;
            for (int k = 0; k < S; k++) run[k + 1] = run[k] + a[base + k * st];
            for (int k = 0; k < S; k++) {
                const int lo = k - M, hi = k + M + 1; // beyond the box counts as empty
                tmp[base + k * st] = lo >= 0 && hi <= S && run[hi] - run[lo] == 2 * M + 1;
            }
        }
    a.swap(tmp);
}

} // namespace

std::vector<uint8_t> buried_particles(const float *x, const float *y, const float *z,
                                      const std::vector<uint64_t> &bin_key, const std::vector<uint32_t> &bin_at,
                                      int M) {
    if (M < 1 || M > 8) throw std::runtime_error("buried particles: M outside 1..8");
    const size_t nb = bin_key.size();
    std::vector<uint8_t> flag(bin_at.empty() ? 0 : bin_at.back(), 0);
    // each bin's voxels holding one of its particles (nearest voxel; one
    // rounding into the next leaf is left out, which only buries fewer)
    std::vector<uint8_t> occ(nb * LEAF_SIZE, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nb, 16), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t b = rg.begin(); b != rg.end(); b++) {
            const openvdb::Coord lc = leaf_coord(bin_key[b]);
            const int ox = lc.x() * LEAF_DIM, oy = lc.y() * LEAF_DIM,
                      oz = lc.z() * LEAF_DIM; // not << : leaves may be below 0
            for (uint32_t q = bin_at[b]; q < bin_at[b + 1]; q++) {
                const int vx = int(std::floor(x[q] + 0.5f)) - ox, vy = int(std::floor(y[q] + 0.5f)) - oy,
                          vz = int(std::floor(z[q] + 0.5f)) - oz;
                if (vx < LEAF_DIM && vy < LEAF_DIM && vz < LEAF_DIM)
                    occ[b * LEAF_SIZE + (vx << 6) + (vy << 3) + vz] = 1;
            }
        }
    });
    // per bin: its leaf and M voxels around from the 27 masks, eroded by M
    const int S = LEAF_DIM + 2 * M;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nb, 1), [&](const tbb::blocked_range<size_t> &rg) {
        std::vector<uint8_t> box(size_t(S) * S * S), tmp(box.size());
        for (size_t b = rg.begin(); b != rg.end(); b++) {
            const openvdb::Coord lc = leaf_coord(bin_key[b]);
            long nbr[27];
            for (int i = -1; i <= 1; i++)
                for (int j = -1; j <= 1; j++)
                    for (int k = -1; k <= 1; k++) {
                        const uint64_t key = leaf_key(lc.x() + i, lc.y() + j, lc.z() + k);
                        auto it = std::lower_bound(bin_key.begin(), bin_key.end(), key);
                        nbr[(i + 1) * 9 + (j + 1) * 3 + k + 1] =
                            it != bin_key.end() && *it == key ? long(it - bin_key.begin()) : -1;
                    }
            for (int vx = 0; vx < S; vx++)
                for (int vy = 0; vy < S; vy++)
                    for (int vz = 0; vz < S; vz++) {
                        const int gx = vx - M + LEAF_DIM, gy = vy - M + LEAF_DIM, gz = vz - M + LEAF_DIM; // 0..23
                        const long n = nbr[(gx >> 3) * 9 + (gy >> 3) * 3 + (gz >> 3)];
                        box[(size_t(vx) * S + vy) * S + vz] =
                            n < 0 ? 0 : occ[size_t(n) * LEAF_SIZE + ((gx & 7) << 6) + ((gy & 7) << 3) + (gz & 7)];
                    }
            erode_axis(box, tmp, S, M, S * S, S, 1);
            erode_axis(box, tmp, S, M, S, S * S, 1);
            erode_axis(box, tmp, S, M, 1, S * S, S);
            const int lx = lc.x() * LEAF_DIM - M, ly = lc.y() * LEAF_DIM - M, lz = lc.z() * LEAF_DIM - M;
            for (uint32_t q = bin_at[b]; q < bin_at[b + 1]; q++) {
                const int vx = int(std::floor(x[q] + 0.5f)) - lx, vy = int(std::floor(y[q] + 0.5f)) - ly,
                          vz = int(std::floor(z[q] + 0.5f)) - lz;
                flag[q] = box[(size_t(vx) * S + vy) * S + vz];
            }
        }
    });
    return flag;
}

} // namespace kf_vdb
