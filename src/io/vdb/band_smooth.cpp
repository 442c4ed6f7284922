// band_smooth.cpp — shifts and curvature flow on a dense band (see band_smooth.h).
#include "band_smooth.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <cmath>
#include <cstring>

namespace kf_vdb {

namespace {

constexpr int P = PADDED; // a leaf with a one-voxel apron

// a row of a leaf's voxels as one vector
typedef float v8 __attribute__((vector_size(LEAF_DIM * sizeof(float))));
inline v8 load8(const float *p) {
    v8 r;
    std::memcpy(&r, p, sizeof r);
    return r;
}

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
            // each 8-voxel row as one vector (the compiler left the voxel
            // loop scalar, with branches): a voxel beyond W or where the
            // gradient vanishes keeps its value
            for (int x = 0; x < LEAF_DIM; x++)
                for (int y = 0; y < LEAF_DIM; y++) {
                    const float *q = pad + ((x + 1) * P + (y + 1)) * P + 1;
                    const int sx = P * P, sy = P;
                    const v8 c = load8(phi + (x << 6) + (y << 3));
                    const v8 Dx = 0.5f * (load8(q + sx) - load8(q - sx)), Dy = 0.5f * (load8(q + sy) - load8(q - sy)),
                             Dz = 0.5f * (load8(q + 1) - load8(q - 1));
                    const v8 Dx2 = Dx * Dx, Dy2 = Dy * Dy, Dz2 = Dz * Dz, g2 = Dx2 + Dy2 + Dz2;
                    const v8 Dxx = load8(q + sx) + load8(q - sx) - 2 * c, Dyy = load8(q + sy) + load8(q - sy) - 2 * c,
                             Dzz = load8(q + 1) + load8(q - 1) - 2 * c;
                    const v8 Dxy =
                        0.25f * (load8(q + sx + sy) - load8(q + sx - sy) - load8(q - sx + sy) + load8(q - sx - sy));
                    const v8 Dxz =
                        0.25f * (load8(q + sx + 1) - load8(q + sx - 1) - load8(q - sx + 1) + load8(q - sx - 1));
                    const v8 Dyz =
                        0.25f * (load8(q + sy + 1) - load8(q + sy - 1) - load8(q - sy + 1) + load8(q - sy - 1));
                    const v8 alpha = Dx2 * (Dyy + Dzz) + Dy2 * (Dxx + Dzz) + Dz2 * (Dxx + Dyy) -
                                     2 * (Dx * (Dy * Dxy + Dz * Dxz) + Dy * Dz * Dyz);
                    const v8 moved = c + alpha / (6 * g2); // dt (1/3) x alpha / (2 |grad|^2)
                    const v8 r = (c < W) & (c > -W) & (g2 > 1e-8f) ? moved : c;
                    std::memcpy(o + (x << 6) + (y << 3), &r, sizeof r);
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
