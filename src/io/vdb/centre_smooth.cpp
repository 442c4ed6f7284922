// centre_smooth.cpp — see centre_smooth.h.
#include "centre_smooth.h"
#include "cell_neighbours.h"

#include "buried_particles.h"
#include "dense_band.h"
#include "key_order.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <unordered_map>

namespace kf_vdb {

// Particles deeper than `depth` below every face, by occupancy: cells of
// edge c = 2 spacings each hold a particle of a jittered lattice (every
// such cube contains a whole lattice cell), so an empty cell is a gap in
// the material. A particle whose cell has every cell within Chebyshev
// distance M occupied, M = ceil(depth / c) + 1, is at least depth from any
// such gap and from any face (the cells just beyond a face are empty; the
// +1 is the cell a face cuts). Flags in input order, 1 = deep.
std::vector<uint8_t> deep_particles(size_t n, const double *xd, const float *xf, double h, double depth) {
    const double c = 2 * h, inv = 1 / c;
    const int M = int(std::ceil(depth * inv)) + 1;
    std::vector<uint8_t> deep(n, 0);
    if (M > 8 || n >= (size_t(1) << 32)) return deep;
    const double lim = double(LEAF_BIAS) * LEAF_DIM - 64;
    // positions in cell units, sorted into 8^3-cell bins (ties by index)
    // (a particle beyond the keys' reach: none is deep)
    std::vector<uint64_t> keys(n);
    std::atomic<bool> far{false};
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            int64_t l[3];
            for (int a = 0; a < 3; a++) {
                const double u = (xd ? xd[3 * i + a] : double(xf[3 * i + a])) * inv;
                if (!(std::fabs(u) < lim)) {
                    far = true;
                    l[a] = 0;
                } else {
                    l[a] = int64_t(std::floor(u + 0.5)) >> LEAF_LOG2;
                }
            }
            keys[i] = leaf_key(l[0], l[1], l[2]);
        }
    });
    if (far) return deep;
    const key_bins<uint32_t> kb = order_by_key<uint32_t>(keys);
    keys.clear(), keys.shrink_to_fit();
    const std::vector<uint32_t> &order = kb.order;
    std::vector<float> x(n), y(n), z(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t k = rg.begin(); k != rg.end(); k++) {
            const size_t i = order[k];
            x[k] = float((xd ? xd[3 * i] : double(xf[3 * i])) * inv);
            y[k] = float((xd ? xd[3 * i + 1] : double(xf[3 * i + 1])) * inv);
            z[k] = float((xd ? xd[3 * i + 2] : double(xf[3 * i + 2])) * inv);
        }
    });
    const std::vector<uint8_t> flag = buried_particles(x.data(), y.data(), z.data(), kb.key, kb.at, M);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t k = rg.begin(); k != rg.end(); k++) deep[order[k]] = flag[k];
    });
    return deep;
}

std::vector<float> smooth_centres(size_t n, const double *xd, const float *xf, double lambda, double R, double h,
                                  double keep_depth, size_t *n_skipped) {
    std::vector<float> out(3 * n);
    auto pos = [&](size_t i, int a) { return xd ? xd[3 * i + a] : double(xf[3 * i + a]); };
    // deep particles keep their place: their spheres lie under the surface
    // whatever the averaging does, and they are most of a large body
    const std::vector<uint8_t> deep =
        keep_depth > 0 && h > 0 ? deep_particles(n, xd, xf, h, keep_depth) : std::vector<uint8_t>(n, 0);
    size_t skipped = 0;
    for (size_t i = 0; i < n; i++) {
        if (!deep[i]) continue;
        skipped++;
        for (int a = 0; a < 3; a++) out[3 * i + a] = float(pos(i, a));
    }
    if (n_skipped) *n_skipped = skipped;
    // cell by cell (cells of edge R): each of the cell's centres against the
    // neighbourhood gathered once
    const float fR2 = float(R * R), finvR = float(1 / R);
    for_each_cell_neighbourhood(
        n, R, pos, deep,
        [&](const size_t *first, const size_t *last, const double *o, const std::vector<float> &bx,
            const std::vector<float> &by, const std::vector<float> &bz) {
            const size_t nb = bx.size();
            for (const size_t *q = first; q != last; q++) {
                const size_t i = *q;
                if (deep[i]) continue;
                const float x = float(pos(i, 0) - o[0]), y = float(pos(i, 1) - o[1]), z = float(pos(i, 2) - o[2]);
                float ws = 0, mx = 0, my = 0, mz = 0;
                for (size_t k = 0; k < nb; k++) {
                    float dx = bx[k] - x, dy = by[k] - y, dz = bz[k] - z, d2 = dx * dx + dy * dy + dz * dz;
                    float sd = std::sqrt(d2) * finvR, w = d2 < fR2 ? 1 - sd * sd * sd : 0.0f;
                    ws += w, mx += w * dx, my += w * dy, mz += w * dz;
                }
                // ws >= 1: the particle itself is its own neighbour at distance 0
                const float f = float(lambda) / ws;
                out[3 * i] = float(pos(i, 0) + double(f * mx));
                out[3 * i + 1] = float(pos(i, 1) + double(f * my));
                out[3 * i + 2] = float(pos(i, 2) + double(f * mz));
            }
        });
    return out;
}

double shift_depth(double lambda, double R, double h) {
    // A centre at depth u below a flat face of a continuum filled below it:
    // the weighted mean of the ball of radius R clipped at the face sits
    // below the centre by m(u) = int w(r) z dV / int w(r) dV over the
    // clipped ball (z: depth below the centre); by symmetry only the
    // vertical offset remains. Sliced in z, a slab at z holds a disc of
    // radius sqrt(R^2 - z^2), whose weighted area is 2 pi int_0^a w(sqrt(z^2+s^2)) s ds.
    auto disc = [&](double z) {
        const int ns = 64;
        double a = std::sqrt(std::max(0.0, R * R - z * z)), sum = 0;
        for (int k = 0; k < ns; k++) {
            double s = (k + 0.5) * a / ns, r = std::sqrt(z * z + s * s) / R;
            sum += (1 - r * r * r) * s;
        }
        return sum * a / ns;
    };
    const int nz = 128, nu = 16;
    double avg = 0;
    for (int q = 0; q < nu; q++) {
        double u = (q + 0.5) * h / nu, w0 = 0, w1 = 0;
        // the ball spans z in [-R, R] relative to the centre (z > 0 upward);
        // material only where z < u (below the face)
        double zt = std::min(R, u);
        for (int k = 0; k < nz; k++) {
            double z = -R + (k + 0.5) * (zt + R) / nz, a = disc(z);
            w0 += a;
            w1 += a * z;
        }
        avg += -(w1 / w0);
    }
    return lambda * avg / nu;
}

} // namespace kf_vdb
