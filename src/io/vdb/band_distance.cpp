// band_distance.cpp — signed distance from surface points (see band_distance.h).
#include "band_distance.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <cstring>
#include <stdexcept>

namespace kf_vdb {

// a row of a leaf's voxels as one vector (the compiler left the 8-voxel
// minimum scalar)
typedef float v8 __attribute__((vector_size(LEAF_DIM * sizeof(float))));

// half the worst case: a voxel t from the surface midway between points
// a voxel apart is sqrt(t^2 + 1/4) from them
constexpr float GAP2 = 0.125f;

// an inside voxel with an outside face neighbour (a missing leaf is
// outside): its splat value places the zero crossing, as the values beside
// a crossing do in fast sweeping's initialisation
bool at_crossing(const dense_band &b, size_t i, int v) {
    const int c[3] = {v >> 6, (v >> 3) & 7, v & 7};
    for (int a = 0; a < 3; a++)
        for (int s = -1; s <= 1; s += 2) {
            int n[3] = {c[0], c[1], c[2]}, d[3] = {0, 0, 0};
            n[a] += s;
            if (n[a] < 0 || n[a] >= LEAF_DIM) d[a] = s, n[a] -= s * LEAF_DIM;
            const int32_t j = d[a] ? b.nbr[27 * i + dense_band::nbr_slot(d[0], d[1], d[2])] : int32_t(i);
            if (j < 0 || b.leaf(size_t(j))[(n[0] << 6) + (n[1] << 3) + n[2]] >= 0) return true;
        }
    return false;
}

void band_distance(dense_band &b, const surface_points &s, float exact_out, float W) {
    if (!(W > 0 && W <= 7)) throw std::runtime_error("band distance: width over 7 voxels");
    const float W2 = W * W;
    std::vector<float> &out = b.scratch; // every value is written below
    out.resize(b.phi.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, b.size(), 4), [&](const tbb::blocked_range<size_t> &rg) {
        float d2[LEAF_SIZE]; // squared distance to the nearest point so far
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            std::fill(d2, d2 + LEAF_SIZE, W2);
            const openvdb::Coord lc = leaf_coord(b.key[i]);
            const int ox = lc.x() * LEAF_DIM, oy = lc.y() * LEAF_DIM,
                      oz = lc.z() * LEAF_DIM; // not << : leaves may be below 0
            for (int n = 0; n < 27; n++) {
                const int32_t j = b.nbr[27 * i + n];
                if (j < 0) continue;
                for (uint32_t q = s.at[j]; q < s.at[j + 1]; q++) {
                    const float px = s.x[q], py = s.y[q], pz = s.z[q];
                    const int x0 = std::max(ox, int(std::ceil(px - W))),
                              x1 = std::min(ox + LEAF_DIM - 1, int(std::floor(px + W)));
                    const int y0 = std::max(oy, int(std::ceil(py - W))),
                              y1 = std::min(oy + LEAF_DIM - 1, int(std::floor(py + W)));
                    const int z0 = std::max(oz, int(std::ceil(pz - W))),
                              z1 = std::min(oz + LEAF_DIM - 1, int(std::floor(pz + W)));
                    if (x0 > x1 || y0 > y1 || z0 > z1) continue;
                    // the squares along z once per point, then whole 8-voxel
                    // rows, branch-free so they vectorise
                    float fz2[LEAF_DIM];
                    for (int z = 0; z < LEAF_DIM; z++) {
                        const float fz = float(oz + z) - pz;
                        fz2[z] = fz * fz;
                    }
                    for (int x = x0; x <= x1; x++) {
                        const float fx = float(x) - px, fx2 = fx * fx;
                        for (int y = y0; y <= y1; y++) {
                            const float fy = float(y) - py, fxy = fx2 + fy * fy;
                            if (fxy >= W2) continue;
                            float *d = d2 + ((x - ox) << (2 * LEAF_LOG2)) + ((y - oy) << LEAF_LOG2);
                            v8 row, sq;
                            std::memcpy(&row, d, sizeof row), std::memcpy(&sq, fz2, sizeof sq);
                            const v8 e = sq + fxy;
                            row = e < row ? e : row;
                            std::memcpy(d, &row, sizeof row);
                        }
                    }
                }
            }
            // the nearest point is at most half a gap (gaps under a voxel)
            // farther than the surface; take off half that worst case, and
            // never go below what the splat proves (its depth inside, its
            // reach outside)
            const float *phi = b.leaf(i);
            float *o = out.data() + i * LEAF_SIZE;
            for (int v = 0; v < LEAF_SIZE; v++) {
                const float p = phi[v];
                if ((p >= 0 && p < exact_out) || (p < 0 && d2[v] < 4 && at_crossing(b, i, v))) {
                    o[v] = p;
                    continue;
                }
                const float lower = p < 0 ? -p : exact_out;
                const float u = std::min(std::max(std::sqrt(std::max(d2[v] - GAP2, 0.f)), lower), W);
                o[v] = p < 0 ? -u : u;
            }
        }
    });
    b.phi.swap(out);
}

} // namespace kf_vdb
