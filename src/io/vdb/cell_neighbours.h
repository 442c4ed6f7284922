// cell_neighbours.h — particles binned into cells of edge R, and each cell's
// 27-cell neighbourhood gathered once (internal to the bridge; C++ only).
//
// Why: the centre smoothing and the anisotropic kernels both need, for every
// particle near a face, its neighbours within R. Gathering the 27 cells
// around a cell into one local buffer, relative to the cell's corner (floats
// keep their precision there), lets every particle of the cell loop over a
// flat array that vectorises. Cells are visited in parallel; what a visit
// computes depends only on the input, so results are the same for any
// thread count.
#ifndef KF_VDB_CELL_NEIGHBOURS_H
#define KF_VDB_CELL_NEIGHBOURS_H

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include "key_order.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <utility>
#include <vector>

namespace kf_vdb {

inline uint64_t cell_key(int64_t i, int64_t j, int64_t k) {
    const int64_t o = int64_t(1) << 20;
    return (uint64_t(i + o) & 0x1fffff) | (uint64_t(j + o) & 0x1fffff) << 21 | (uint64_t(k + o) & 0x1fffff) << 42;
}

// For each cell that holds a particle not flagged deep, calls
//   visit(first, last, o, bx, by, bz)
// where [first, last) are the cell's particle indices (ascending), o is the
// cell's corner and bx/by/bz the neighbourhood's positions less o, in a fixed
// order (cells z, y, x from -1 to 1; particles by index within a cell).
// pos(i, axis) gives particle i's coordinate as a double.
template <class Pos, class Visit>
void for_each_cell_neighbourhood(size_t n, double R, const Pos &pos, const std::vector<uint8_t> &deep,
                                 const Visit &visit) {
    const double invR = 1 / R;
    // particles sorted into cells (ties by index: deterministic)
    std::vector<uint64_t> keys(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++)
            keys[i] = cell_key(int64_t(std::floor(pos(i, 0) * invR)), int64_t(std::floor(pos(i, 1) * invR)),
                               int64_t(std::floor(pos(i, 2) * invR)));
    });
    const key_bins<size_t> kb = order_by_key<size_t>(keys);
    keys.clear(), keys.shrink_to_fit();
    const std::vector<size_t> &order = kb.order;
    std::vector<std::pair<size_t, size_t>> ranges(kb.key.size());
    for (size_t c = 0; c < ranges.size(); c++) ranges[c] = {kb.at[c], kb.at[c + 1]};
    auto find_cell = [&](uint64_t k) {
        auto it = std::lower_bound(kb.key.begin(), kb.key.end(), k);
        return it == kb.key.end() || *it != k ? long(-1) : long(it - kb.key.begin());
    };
    tbb::parallel_for(tbb::blocked_range<size_t>(0, ranges.size(), 16), [&](const tbb::blocked_range<size_t> &rg) {
        std::vector<float> bx, by, bz;
        for (size_t c = rg.begin(); c != rg.end(); c++) {
            bool any = false; // a cell of deep particles only: nothing to do
            for (size_t s1 = ranges[c].first; s1 < ranges[c].second && !any; s1++) any = !deep[order[s1]];
            if (!any) continue;
            const size_t first = order[ranges[c].first];
            const int64_t ci[3] = {int64_t(std::floor(pos(first, 0) * invR)), int64_t(std::floor(pos(first, 1) * invR)),
                                   int64_t(std::floor(pos(first, 2) * invR))};
            const double o[3] = {double(ci[0]) * R, double(ci[1]) * R, double(ci[2]) * R};
            bx.clear(), by.clear(), bz.clear();
            for (int dz = -1; dz <= 1; dz++)
                for (int dy = -1; dy <= 1; dy++)
                    for (int dxc = -1; dxc <= 1; dxc++) {
                        const long cn = find_cell(cell_key(ci[0] + dxc, ci[1] + dy, ci[2] + dz));
                        if (cn < 0) continue;
                        for (size_t s1 = ranges[size_t(cn)].first; s1 < ranges[size_t(cn)].second; s1++) {
                            const size_t j = order[s1];
                            bx.push_back(float(pos(j, 0) - o[0]));
                            by.push_back(float(pos(j, 1) - o[1]));
                            bz.push_back(float(pos(j, 2) - o[2]));
                        }
                    }
            visit(order.data() + ranges[c].first, order.data() + ranges[c].second, o, bx, by, bz);
        }
    });
}

} // namespace kf_vdb

#endif
