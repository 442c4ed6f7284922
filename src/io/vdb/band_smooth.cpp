// band_smooth.cpp — shifts and curvature flow on a dense band (see band_smooth.h).
#include "band_smooth.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>

namespace kf_vdb {

namespace {

constexpr int P = PADDED; // a leaf with a one-voxel apron

// one explicit step of phi_t = kappa |grad phi| (OpenVDB's
// meanCurvatureNormGrad with dt = dx^2 / 3), into out
void curvature_step(const dense_band &b, float W, std::vector<float> &out) {
    tbb::parallel_for(tbb::blocked_range<size_t>(0, b.size(), 4), [&](const tbb::blocked_range<size_t> &rg) {
        float pad[P * P * P];
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            const float *phi = b.leaf(i);
            float *o = out.data() + i * LEAF_SIZE;
            bool any = false;
            for (int v = 0; v < LEAF_SIZE && !any; v++) any = std::fabs(phi[v]) < W;
            if (!any) {
                std::copy(phi, phi + LEAF_SIZE, o);
                continue;
            }
            gather_padded(b, i, W, pad);
            for (int x = 0; x < LEAF_DIM; x++)
                for (int y = 0; y < LEAF_DIM; y++)
                    for (int z = 0; z < LEAF_DIM; z++) {
                        const int v = (x << 6) + (y << 3) + z;
                        const float c = phi[v];
                        if (!(std::fabs(c) < W)) {
                            o[v] = c;
                            continue;
                        }
                        const float *q = pad + ((x + 1) * P + (y + 1)) * P + (z + 1);
                        const int sx = P * P, sy = P;
                        const float Dx = 0.5f * (q[sx] - q[-sx]), Dy = 0.5f * (q[sy] - q[-sy]),
                                    Dz = 0.5f * (q[1] - q[-1]);
                        const float Dx2 = Dx * Dx, Dy2 = Dy * Dy, Dz2 = Dz * Dz, g2 = Dx2 + Dy2 + Dz2;
                        if (g2 <= 1e-8f) {
                            o[v] = c;
                            continue;
                        }
                        const float Dxx = q[sx] + q[-sx] - 2 * c, Dyy = q[sy] + q[-sy] - 2 * c,
                                    Dzz = q[1] + q[-1] - 2 * c;
                        const float Dxy = 0.25f * (q[sx + sy] - q[sx - sy] - q[-sx + sy] + q[-sx - sy]);
                        const float Dxz = 0.25f * (q[sx + 1] - q[sx - 1] - q[-sx + 1] + q[-sx - 1]);
                        const float Dyz = 0.25f * (q[sy + 1] - q[sy - 1] - q[-sy + 1] + q[-sy - 1]);
                        const float alpha = Dx2 * (Dyy + Dzz) + Dy2 * (Dxx + Dzz) + Dz2 * (Dxx + Dyy) -
                                            2 * (Dx * (Dy * Dxy + Dz * Dxz) + Dy * Dz * Dyz);
                        o[v] = c + alpha / (6 * g2); // dt (1/3) x alpha / (2 |grad|^2)
                    }
        }
    });
}

void shift(dense_band &b, float by) {
    if (by == 0) return;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, b.phi.size(), 1 << 16), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t v = rg.begin(); v != rg.end(); v++) b.phi[v] += by;
    });
}

} // namespace

void band_smooth(dense_band &b, float W, float dilate, int iterations, float erode) {
    shift(b, -dilate);
    std::vector<float> &out = b.scratch;
    if (iterations > 0) out.resize(b.phi.size());
    for (int k = 0; k < iterations; k++) {
        curvature_step(b, W, out);
        b.phi.swap(out);
    }
    shift(b, erode);
}

} // namespace kf_vdb
