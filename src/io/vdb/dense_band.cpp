// dense_band.cpp — the leaves' neighbour table (see dense_band.h).
#include "dense_band.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

namespace kf_vdb {

// one binary search per neighbour, once: every later pass reads the table
void dense_band::link() {
    nbr.assign(27 * key.size(), -1);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, key.size(), 64), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            const openvdb::Coord c = leaf_coord(key[i]);
            for (int dx = -1; dx <= 1; dx++)
                for (int dy = -1; dy <= 1; dy++)
                    for (int dz = -1; dz <= 1; dz++)
                        nbr[27 * i + nbr_slot(dx, dy, dz)] =
                            int32_t(find(leaf_key(c.x() + dx, c.y() + dy, c.z() + dz)));
        }
    });
}

} // namespace kf_vdb
