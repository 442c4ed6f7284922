// band_flatten.cpp — a bilateral filter of a band's zero set (see band_flatten.h).
#include "band_flatten.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

namespace kf_vdb {

namespace {

constexpr int P = PADDED; // a leaf with a one-voxel apron
constexpr int SB = 4;     // sub-blocks of SB^3 voxels, 8 to a leaf
// the weighted sums run in this many lanes (a vector's width), added in
// order after: it vectorises, and the sums are the same for any thread count
constexpr int LANES = 16;
// a flat face's points (one per voxel column) weigh pi / 3 r^2 in all
// about a voxel; one with under SUPPORT r^2 (a quarter of that) is moved
// only in proportion
constexpr float SUPPORT = 0.25f;
// a leaf with a two-voxel apron: the normals of the apron's first layer
constexpr int P2 = LEAF_DIM + 4;
// a candidate this far beyond the reach (squared, relative) weighs 0 for
// every target however its distances round (cands::gather)
constexpr float FAR_MARGIN = 1.001f;

// the unit gradient at voxel q of a leaf padded to edge E (central
// differences); false if flat
template <int E = P> inline bool normal_at(const float *q, float n[3]) {
    const int sx = E * E, sy = E;
    n[0] = 0.5f * (q[sx] - q[-sx]), n[1] = 0.5f * (q[sy] - q[-sy]), n[2] = 0.5f * (q[1] - q[-1]);
    const float g = std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    if (!(g > 1e-4f)) return false;
    for (int k = 0; k < 3; k++) n[k] /= g;
    return true;
}

// surface points (index space) and their normals, leaf by leaf, each
// leaf's sorted by sub-block: leaf i's sub-block s holds [at[9 i + s], at[9 i + s + 1])
struct samples {
    std::vector<float> x, y, z, nx, ny, nz;
    std::vector<uint32_t> at;
};

// a sub-block's voxel box (index space) of leaf lc, sub-block s
inline void sub_box(const openvdb::Coord &lc, int s, float lo[3]) {
    lo[0] = float(lc.x() * LEAF_DIM + (s >> 2 & 1) * SB), lo[1] = float(lc.y() * LEAF_DIM + (s >> 1 & 1) * SB),
    lo[2] = float(lc.z() * LEAF_DIM + (s & 1) * SB);
}

// d[k] = s[k] - o for k < n (one loop the compiler vectorises)
inline void copy_less(float *__restrict d, const float *__restrict s, size_t n, float o) {
    for (size_t k = 0; k < n; k++) d[k] = s[k] - o;
}

// the samples within r of sub-block box lo..lo+SB-1 (box distance), copied
// relative to o into the candidate arrays. The weighted sums run in LANES
// lanes, candidate m in lane m % LANES: a row of LANES candidates whose every
// one lies beyond the reach from all the targets (box tlo..thi, with a margin
// over the roundings) adds +0 or -0 to each lane's sum, which is never -0,
// and is left out: every sum stays the same. The sub-block granularity of
// the ranges puts about 5x more candidates in the list than lie within the
// reach of a voxel; on the bench's frame 40% of the voxel pass's rows are
// that far (19.3 -> 11.5 a sub-block), 23% of the normals' (30.4 -> 23.4).
struct cands {
    std::vector<float> x, y, z, nx, ny, nz;
    size_t count = 0; // the candidates (a multiple of LANES) at the arrays' start
    void gather(const dense_band &b, const samples &S, size_t i, const float lo[3], float r, const float o[3],
                const float tlo[3], const float thi[3], float reach) {
        // the ranges of samples to copy first (consecutive sub-blocks of a
        // leaf merged), then one copy into arrays sized once: the same
        // candidates in the same order as appending them one by one
        uint32_t rg[2 * 27 * 8];
        int nr = 0;
        size_t tot = 0;
        const float r2 = r * r;
        for (int k = 0; k < 27; k++) {
            const int32_t j = b.nbr[27 * i + size_t(k)];
            if (j < 0) continue;
            const openvdb::Coord lc = leaf_coord(b.key[size_t(j)]);
            for (int s = 0; s < 8; s++) {
                const uint32_t a0 = S.at[9 * size_t(j) + size_t(s)], a1 = S.at[9 * size_t(j) + size_t(s) + 1];
                if (a0 == a1) continue;
                float bl[3];
                sub_box(lc, s, bl);
                float d2 = 0;
                for (int c = 0; c < 3; c++) {
                    // gap between [lo, lo + SB - 1] and the sub-block's points (within half a voxel of its box)
                    const float g =
                        std::max(0.f, std::max(bl[c] - 0.5f - (lo[c] + SB - 1), lo[c] - (bl[c] + SB - 0.5f)));
                    d2 += g * g;
                }
                if (d2 >= r2) continue;
                if (nr > 0 && rg[2 * nr - 1] == a0) rg[2 * nr - 1] = a1;
                else rg[2 * nr] = a0, rg[2 * nr + 1] = a1, nr++;
                tot += a1 - a0;
            }
        }
        // padded to whole rows with points far away (weight 0)
        const size_t padded = (tot + LANES - 1) / LANES * LANES;
        // (the arrays only grow: filling what a shorter list left is wasted)
        if (x.size() < padded)
            for (std::vector<float> *v : {&x, &y, &z, &nx, &ny, &nz}) v->resize(padded);
        // (through pointers that alias nothing, so that the copies vectorise)
        float *__restrict px = x.data(), *__restrict py = y.data(), *__restrict pz = z.data();
        float *__restrict pnx = nx.data(), *__restrict pny = ny.data(), *__restrict pnz = nz.data();
        const float ox = o[0], oy = o[1], oz = o[2];
        size_t m = 0;
        for (int q = 0; q < nr; q++) {
            const uint32_t a0 = rg[2 * q], n = rg[2 * q + 1] - a0;
            copy_less(px + m, S.x.data() + a0, n, ox);
            copy_less(py + m, S.y.data() + a0, n, oy);
            copy_less(pz + m, S.z.data() + a0, n, oz);
            std::copy(S.nx.data() + a0, S.nx.data() + a0 + n, pnx + m);
            std::copy(S.ny.data() + a0, S.ny.data() + a0 + n, pny + m);
            std::copy(S.nz.data() + a0, S.nz.data() + a0 + n, pnz + m);
            m += n;
        }
        for (; m < padded; m++) px[m] = py[m] = pz[m] = 1e17f, pnx[m] = pny[m] = pnz[m] = 0.f;
        // the rows with a candidate within reach of the targets' box, moved
        // down over the others (a target's offset from a candidate rounds to
        // at least its distance from the box: rounding is monotonic)
        const float lim = FAR_MARGIN * reach * reach;
        size_t kept = 0;
        for (size_t m0 = 0; m0 < padded; m0 += LANES) {
            int near = 0;
            for (int j = 0; j < LANES; j++) {
                const size_t c = m0 + size_t(j);
                const float gx = std::max(0.f, std::max(tlo[0] - x[c], x[c] - thi[0])),
                            gy = std::max(0.f, std::max(tlo[1] - y[c], y[c] - thi[1])),
                            gz = std::max(0.f, std::max(tlo[2] - z[c], z[c] - thi[2]));
                near |= gx * gx + gy * gy + gz * gz < lim;
            }
            if (!near) continue;
            if (kept != m0) // (the rows do not overlap: kept <= m0 - LANES)
                for (float *v : {px, py, pz, pnx, pny, pnz}) std::memcpy(v + kept, v + m0, LANES * sizeof(float));
            kept += LANES;
        }
        count = kept;
    }
};

// the weight of a candidate at squared distance d2 whose normal has dot
// product dot with the point's: (1 - d2 / r2)^2 (1 - ((1 - dot) / sc)^2)^2
inline float weight(float d2, float ir2, float dot, float isc) {
    const float ws = std::max(0.f, 1 - d2 * ir2), t = std::min(1.f, (1 - dot) * isc), wn = 1 - t * t;
    return ws * ws * wn * wn;
}

samples collect(const dense_band &b, float W) {
    const size_t nl = b.size();
    std::vector<std::vector<float>> per(nl);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nl, 4), [&](const tbb::blocked_range<size_t> &rg) {
        float pad[P2 * P2 * P2];
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            const float *phi = b.leaf(i);
            bool any = false;
            for (int v = 0; v < LEAF_SIZE && !any; v++) any = std::fabs(phi[v]) < 1.f;
            if (!any) continue;
            gather_apron<2>(b, i, W, pad);
            const openvdb::Coord lc = leaf_coord(b.key[i]);
            std::vector<float> &o = per[i];
            // sub-block by sub-block, so that each one's points are contiguous
            for (int s = 0; s < 8; s++) {
                const int x0 = (s >> 2 & 1) * SB, y0 = (s >> 1 & 1) * SB, z0 = (s & 1) * SB;
                for (int x = x0; x < x0 + SB; x++)
                    for (int y = y0; y < y0 + SB; y++)
                        for (int z = z0; z < z0 + SB; z++) {
                            const float *q = pad + ((x + 2) * P2 + (y + 2)) * P2 + (z + 2);
                            const float c = q[0];
                            // one point per crossing voxel edge, made by the voxel of
                            // the two nearer the zero set (ties: the inside one), so
                            // that it lies within half a voxel of that voxel: the
                            // mean of the two voxels' closest points (the inside one's
                            // and the outside one's lie a few hundredths of a voxel
                            // either side of the zero set) and of their normals. The
                            // far voxel lies within 1.5 of the zero set: a leaf missing
                            // from the band reads W, also where it lies inside (beyond
                            // the band's inner rim the values carry only their sign).
                            const bool in = c < 0;
                            const float ac = std::fabs(c);
                            const int st[6] = {P2 * P2, -P2 * P2, P2, -P2, 1, -1};
                            float n[3] = {0, 0, 0};
                            bool have_n = false, flat = false;
                            for (int k = 0; k < 6 && !flat; k++) {
                                const float u = q[st[k]], au = std::fabs(u);
                                if ((u < 0) == in || !(ac < au || (ac == au && in)) || !(au < 1.5f)) continue;
                                if (!have_n) {
                                    flat = !normal_at<P2>(q, n);
                                    have_n = true;
                                    if (flat) continue;
                                }
                                float m[3];
                                if (!normal_at<P2>(q + st[k], m)) continue;
                                // the neighbour's offset from this voxel
                                const int ex = k == 0 ? 1 : (k == 1 ? -1 : 0), ey = k == 2 ? 1 : (k == 3 ? -1 : 0),
                                          ez = k == 4 ? 1 : (k == 5 ? -1 : 0);
                                const float nm[3] = {n[0] + m[0], n[1] + m[1], n[2] + m[2]};
                                const float g = std::sqrt(nm[0] * nm[0] + nm[1] * nm[1] + nm[2] * nm[2]);
                                if (!(g > 1e-4f)) continue;
                                const float rec[7] = {
                                    float(s),
                                    float(lc.x() * LEAF_DIM + x) + 0.5f * (float(ex) - c * n[0] - u * m[0]),
                                    float(lc.y() * LEAF_DIM + y) + 0.5f * (float(ey) - c * n[1] - u * m[1]),
                                    float(lc.z() * LEAF_DIM + z) + 0.5f * (float(ez) - c * n[2] - u * m[2]),
                                    nm[0] / g,
                                    nm[1] / g,
                                    nm[2] / g};
                                o.insert(o.end(), rec, rec + 7);
                            }
                        }
            }
        }
    });
    samples S;
    S.at.assign(9 * nl + 1, 0);
    size_t tot = 0;
    for (size_t i = 0; i < nl; i++) tot += per[i].size() / 7;
    S.x.resize(tot), S.y.resize(tot), S.z.resize(tot), S.nx.resize(tot), S.ny.resize(tot), S.nz.resize(tot);
    uint32_t m = 0;
    for (size_t i = 0; i < nl; i++) {
        const std::vector<float> &o = per[i];
        size_t q = 0;
        for (int s = 0; s < 8; s++) {
            S.at[9 * i + size_t(s)] = m;
            for (; q < o.size() / 7 && int(o[7 * q]) == s; q++, m++)
                S.x[m] = o[7 * q + 1], S.y[m] = o[7 * q + 2], S.z[m] = o[7 * q + 3], S.nx[m] = o[7 * q + 4],
                S.ny[m] = o[7 * q + 5], S.nz[m] = o[7 * q + 6];
        }
        S.at[9 * i + 8] = m;
    }
    return S;
}

} // namespace

void band_flatten(dense_band &b, float W, float radius, float sigma, float ns) {
    const size_t nl = b.size();
    // the voxels within B0 of the zero set get the filtered value, those
    // out to B1 a blend down to their own (a continuous band)
    const float B0 = 0.75f, B1 = 1.5f;
    samples S = collect(b, W);
    const float isc = 1 / sigma;
    // the samples' normals averaged over their neighbourhood (the same
    // weights): a face's normals then tilt with its long waves, not its bumps
    if (ns > 0) {
        samples T = S;
        const float ir2 = 1 / (ns * ns);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, nl, 4), [&](const tbb::blocked_range<size_t> &rg) {
            cands C;
            for (size_t i = rg.begin(); i != rg.end(); i++) {
                const openvdb::Coord lc = leaf_coord(b.key[i]);
                for (int s = 0; s < 8; s++) {
                    const uint32_t a0 = S.at[9 * i + size_t(s)], a1 = S.at[9 * i + size_t(s) + 1];
                    if (a0 == a1) continue;
                    float lo[3];
                    sub_box(lc, s, lo);
                    // the targets: this sub-block's points, relative to lo as below
                    float tlo[3] = {INFINITY, INFINITY, INFINITY}, thi[3] = {-INFINITY, -INFINITY, -INFINITY};
                    for (uint32_t q = a0; q < a1; q++) {
                        const float X = S.x[q] - lo[0], Y = S.y[q] - lo[1], Z = S.z[q] - lo[2];
                        tlo[0] = std::min(tlo[0], X), tlo[1] = std::min(tlo[1], Y), tlo[2] = std::min(tlo[2], Z);
                        thi[0] = std::max(thi[0], X), thi[1] = std::max(thi[1], Y), thi[2] = std::max(thi[2], Z);
                    }
                    C.gather(b, S, i, lo, ns + 0.5f, lo, tlo, thi, ns);
                    const size_t nc = C.count;
                    for (uint32_t q = a0; q < a1; q++) {
                        const float X = S.x[q] - lo[0], Y = S.y[q] - lo[1], Z = S.z[q] - lo[2];
                        const float n0 = S.nx[q], n1 = S.ny[q], n2 = S.nz[q];
                        float A[3][LANES] = {};
                        for (size_t m0 = 0; m0 < nc; m0 += LANES)
                            for (int j = 0; j < LANES; j++) {
                                const size_t m = m0 + size_t(j);
                                const float dx = X - C.x[m], dy = Y - C.y[m], dz = Z - C.z[m];
                                const float w = weight(dx * dx + dy * dy + dz * dz, ir2,
                                                       n0 * C.nx[m] + n1 * C.ny[m] + n2 * C.nz[m], isc);
                                A[0][j] += w * C.nx[m], A[1][j] += w * C.ny[m], A[2][j] += w * C.nz[m];
                            }
                        float a[3] = {0, 0, 0};
                        for (int j = 0; j < LANES; j++) a[0] += A[0][j], a[1] += A[1][j], a[2] += A[2][j];
                        const float g = std::sqrt(a[0] * a[0] + a[1] * a[1] + a[2] * a[2]);
                        if (g > 0) T.nx[q] = a[0] / g, T.ny[q] = a[1] / g, T.nz[q] = a[2] / g;
                    }
                }
            }
        });
        S.nx.swap(T.nx), S.ny.swap(T.ny), S.nz.swap(T.nz);
    }
    std::vector<float> &out = b.scratch;
    out = b.phi;
    const float ir2 = 1 / (radius * radius);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nl, 4), [&](const tbb::blocked_range<size_t> &rg) {
        float pad[P * P * P];
        cands C;
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            const float *phi = b.leaf(i);
            bool any = false;
            for (int v = 0; v < LEAF_SIZE && !any; v++) any = std::fabs(phi[v]) < B1;
            if (!any) continue;
            gather_padded(b, i, W, pad);
            const openvdb::Coord lc = leaf_coord(b.key[i]);
            float *o = out.data() + i * LEAF_SIZE;
            for (int s = 0; s < 8; s++) {
                const int x0 = (s >> 2 & 1) * SB, y0 = (s >> 1 & 1) * SB, z0 = (s & 1) * SB;
                bool near = false;
                for (int x = x0; x < x0 + SB && !near; x++)
                    for (int y = y0; y < y0 + SB && !near; y++)
                        for (int z = z0; z < z0 + SB && !near; z++) near = std::fabs(phi[(x << 6) + (y << 3) + z]) < B1;
                if (!near) continue;
                float lo[3];
                sub_box(lc, s, lo);
                // the targets: the sub-block's voxels (offsets 0..SB-1 from lo)
                const float tlo[3] = {0, 0, 0}, thi[3] = {SB - 1, SB - 1, SB - 1};
                C.gather(b, S, i, lo, radius, lo, tlo, thi, radius);
                const size_t nc = C.count;
                if (!nc) continue;
                for (int x = x0; x < x0 + SB; x++)
                    for (int y = y0; y < y0 + SB; y++)
                        for (int z = z0; z < z0 + SB; z++) {
                            const int v = (x << 6) + (y << 3) + z;
                            const float c = phi[v];
                            if (!(std::fabs(c) < B1)) continue;
                            float n[3];
                            if (!normal_at(pad + ((x + 1) * P + (y + 1)) * P + (z + 1), n)) continue;
                            const float X = float(x - x0), Y = float(y - y0), Z = float(z - z0);
                            float SW[LANES] = {}, SF[LANES] = {};
                            for (size_t m0 = 0; m0 < nc; m0 += LANES)
                                for (int j = 0; j < LANES; j++) {
                                    const size_t m = m0 + size_t(j);
                                    const float dx = X - C.x[m], dy = Y - C.y[m], dz = Z - C.z[m];
                                    const float w = weight(dx * dx + dy * dy + dz * dz, ir2,
                                                           n[0] * C.nx[m] + n[1] * C.ny[m] + n[2] * C.nz[m], isc);
                                    // the mean of the two tangent planes' distances (own normal and the
                                    // sample's): a sphere's bias cancels to second order
                                    const float f =
                                        0.5f * ((n[0] + C.nx[m]) * dx + (n[1] + C.ny[m]) * dy + (n[2] + C.nz[m]) * dz);
                                    SW[j] += w, SF[j] += w * f;
                                }
                            float sw = 0, sf = 0;
                            for (int j = 0; j < LANES; j++) sw += SW[j], sf += SF[j];
                            if (!(sw > 1e-3f)) continue;
                            const float f = sf / sw;
                            // a voxel few points agree with (a crevice, a bridge across
                            // a crack) moves only as far as they weigh against SUPPORT
                            const float t = (std::fabs(c) <= B0 ? 1.f : (B1 - std::fabs(c)) / (B1 - B0)) *
                                            std::min(1.f, sw * ir2 / SUPPORT);
                            o[v] = c + t * (f - c);
                        }
            }
        }
    });
    b.phi.swap(out);
}

} // namespace kf_vdb
