// aniso_raster.cpp — a union of anisotropic kernels made a signed distance
// (see aniso_raster.h).
#include "aniso_raster.h"

#include "band_distance.h"
#include "centre_smooth.h"
#include "cell_neighbours.h"
#include "key_order.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_reduce.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <ctime>
#include <stdexcept>
#include <unordered_map>
#include <utility>
#include <vector>

namespace kf_vdb {

namespace {

using openvdb::Coord;

double cpu_now() {
    timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// wall seconds: beside a phase's CPU time, whether it kept the cores busy
double wall_now() {
    timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

// fewer neighbours than this (within R) and the covariance says little:
// a small round kernel
constexpr int FEW_NEIGHBOURS = 6;
// each kernel's value is evaluated within its ellipsoid grown by this much
// (voxels) along each axis, which holds every voxel beside one inside it
// (their crossings need the values on both sides); -PAD where none reaches
constexpr float PAD = 1.01f;
// the covariance's sums run in this many lanes (a vector's width)
constexpr int LANES = 16;

// One particle's kernel in index space: the ellipsoid d^T M d <= 1 about c,
// its value at a voxel amin (1 - sqrt(d^T M d)) (the distance to its
// surface along its thinnest axis, positive inside), evaluated within ext
// voxels of c along each axis.
struct kernel {
    float c[3];
    float M[6]; // xx, xy, xz, yy, yz, zz
    float P[6]; // the same for the grown ellipsoid
    float amin;
    float ext[3]; // the grown ellipsoid's half extent along each axis
};

// A kernel less its centre: what the deep balls share
struct shape {
    float M[6], P[6], amin, ext[3];
};

// The kernels as stored, in slot order: each one's centre, and the entry of
// its shape in a table whose entry 0 is the deep balls' one shape (most of a
// block's particles are deep: 16 bytes each instead of 76, written and read)
struct kernel_table {
    std::vector<std::array<float, 3>> c;
    std::vector<uint32_t> of;
    std::vector<shape> s;
    const shape &at(size_t q) const { return s[of[q]]; }
    // kernel k's shape at entry e
    void put_shape(size_t e, const kernel &k) {
        shape &d = s[e];
        std::copy(k.M, k.M + 6, d.M), std::copy(k.P, k.P + 6, d.P), std::copy(k.ext, k.ext + 3, d.ext);
        d.amin = k.amin;
    }
    // kernel k at slot q (its shape at the slot's own entry). Out of line:
    // inlined into shape_kernels' cell loop it changed which of the
    // covariance sums' products GCC fuses into multiply-adds (one FMA more;
    // the level set moved by 9e-7 voxels); out of line they compile as before
    __attribute__((noinline)) void put(size_t q, const kernel &k) {
        for (int a = 0; a < 3; a++) c[q][a] = k.c[a];
        put_shape(of[q], k);
    }
};

// eigenvalues (descending) and eigenvectors (columns of V) of a symmetric
// 3x3 matrix, by cyclic Jacobi rotations
void eigen3(const double A0[3][3], double ev[3], double V[3][3]) {
    double A[3][3];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) A[i][j] = A0[i][j], V[i][j] = i == j;
    for (int sweep = 0; sweep < 12; sweep++) {
        const double off = A[0][1] * A[0][1] + A[0][2] * A[0][2] + A[1][2] * A[1][2];
        if (off <= 1e-30 * (A[0][0] * A[0][0] + A[1][1] * A[1][1] + A[2][2] * A[2][2]) || off == 0) break;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                if (A[p][q] == 0) continue;
                const double th = (A[q][q] - A[p][p]) / (2 * A[p][q]);
                const double t = (th >= 0 ? 1 : -1) / (std::fabs(th) + std::sqrt(th * th + 1));
                const double c = 1 / std::sqrt(t * t + 1), s = t * c;
                for (int k = 0; k < 3; k++) {
                    const double akp = A[k][p], akq = A[k][q];
                    A[k][p] = c * akp - s * akq, A[k][q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; k++) {
                    const double apk = A[p][k], aqk = A[q][k];
                    A[p][k] = c * apk - s * aqk, A[q][k] = s * apk + c * aqk;
                }
                for (int k = 0; k < 3; k++) {
                    const double vkp = V[k][p], vkq = V[k][q];
                    V[k][p] = c * vkp - s * vkq, V[k][q] = s * vkp + c * vkq;
                }
            }
    }
    int o[3] = {0, 1, 2};
    std::sort(o, o + 3, [&](int a, int b) { return A[a][a] > A[b][b]; });
    double W[3][3];
    for (int k = 0; k < 3; k++) {
        ev[k] = A[o[k]][o[k]];
        for (int i = 0; i < 3; i++) W[i][k] = V[i][o[k]];
    }
    for (int i = 0; i < 3; i++)
        for (int k = 0; k < 3; k++) V[i][k] = W[i][k];
}

// the radius of a deep particle's ball (world units): the spheres' radius,
// at least twice the discs' half thickness
double deep_ball_radius(const aniso_params &a) { return std::max(2 * a.R / 3, 2 * a.thickness); }

// a kernel with semi-axes a (index space) along the columns of V, centred at c
kernel make_kernel(const double c[3], const double a[3], const double V[3][3]) {
    kernel k;
    for (int i = 0; i < 3; i++) k.c[i] = float(c[i]);
    double M[3][3] = {{0}}, P[3][3] = {{0}}, E[3] = {0, 0, 0};
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            for (int m = 0; m < 3; m++) {
                M[i][j] += V[i][m] * V[j][m] / (a[m] * a[m]);
                P[i][j] += V[i][m] * V[j][m] / ((a[m] + PAD) * (a[m] + PAD));
            }
    for (int i = 0; i < 3; i++)
        for (int m = 0; m < 3; m++) E[i] += V[i][m] * V[i][m] * (a[m] + PAD) * (a[m] + PAD);
    k.M[0] = float(M[0][0]), k.M[1] = float(M[0][1]), k.M[2] = float(M[0][2]);
    k.M[3] = float(M[1][1]), k.M[4] = float(M[1][2]), k.M[5] = float(M[2][2]);
    k.P[0] = float(P[0][0]), k.P[1] = float(P[0][1]), k.P[2] = float(P[0][2]);
    k.P[3] = float(P[1][1]), k.P[4] = float(P[1][2]), k.P[5] = float(P[2][2]);
    for (int i = 0; i < 3; i++) k.ext[i] = float(std::sqrt(E[i]));
    k.amin = float(std::min(a[0], std::min(a[1], a[2])));
    return k;
}

// Every particle's kernel (index space, voxel vx). Deep particles (deeper
// than their ball reaches) get a ball of 2/3 the neighbourhood unexamined
// (the spheres' radius: no gaps inside, on a lattice or after it deforms); the others a disc from the weighted
// covariance of their neighbours within R (weight 1 - (d/R)^3), gathered in cells of edge R, cell by cell in parallel
// (each kernel depends only on the input). Particle i's kernel is written
// at slot[i] (its shape at its own entry of the table, entry 0 if deep).
kernel_table shape_kernels(size_t n, const double *xd, const float *xf, const aniso_params &a, double vx,
                                  const uint32_t *slot, std::vector<uint8_t> &deep) {
    auto pos = [&](size_t i, int k) { return xd ? xd[3 * i + k] : double(xf[3 * i + k]); };
    const double inv = 1 / vx, R = a.R, invR = 1 / R, R2 = R * R;
    // a full neighbourhood's covariance per axis: the weighted second moment
    // of a uniform ball, int w r^4 dr / int w r^2 dr / 3 = 0.15 R^2
    const double s_full = 0.15 * R2, sup = a.support * inv, t = a.thickness * inv;
    kernel_table K;
    K.c.resize(n), K.of.resize(n);
    const double I3[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
    // deep: a ball of rb, at least rb under every face (which the discs put
    // `thickness` beyond the outermost centres)
    const double rb = deep_ball_radius(a);
    deep = deep_particles(n, xd, xf, a.spacing, rb);
    // the shapes' entries: 0 for the deep, the others numbered in slot order
    for (size_t i = 0; i < n; i++) K.of[slot[i]] = !deep[i];
    uint32_t ns = 0;
    for (size_t q = 0; q < n; q++) K.of[q] = K.of[q] ? ++ns : 0;
    K.s.resize(size_t(ns) + 1);
    // every deep ball has the same shape: made once, then moved to each
    // centre (the same floats as making each one)
    const double c0[3] = {0, 0, 0}, axb[3] = {rb * inv, rb * inv, rb * inv};
    const kernel ball = make_kernel(c0, axb, I3);
    K.put_shape(0, ball);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            if (!deep[i]) continue;
            for (int k = 0; k < 3; k++) K.c[slot[i]][k] = float(pos(i, k) * inv);
        }
    });
    const float fR2 = float(R2), finvR = float(invR);
    for_each_cell_neighbourhood(
        n, R, pos, deep,
        [&](const size_t *first, const size_t *last, const double *o, const std::vector<float> &bx,
            const std::vector<float> &by, const std::vector<float> &bz) {
            // the candidates padded to whole blocks of LANES with points far
            // away (weight 0, squares still finite)
            const size_t nb = bx.size(), nbp = (nb + LANES - 1) / LANES * LANES;
            thread_local std::vector<float> px, py, pz;
            px.assign(nbp, 1e18f), py.assign(nbp, 1e18f), pz.assign(nbp, 1e18f);
            std::copy(bx.begin(), bx.end(), px.begin());
            std::copy(by.begin(), by.end(), py.begin());
            std::copy(bz.begin(), bz.end(), pz.begin());
            for (const size_t *q = first; q != last; q++) {
                const size_t i = *q;
                if (deep[i]) continue;
                const float x = float(pos(i, 0) - o[0]), y = float(pos(i, 1) - o[1]), z = float(pos(i, 2) - o[2]);
                // the weighted mean of the neighbours (relative to the particle),
                // their count, and their weighted covariance about that mean (one
                // pass: second moments less the mean's; offsets are a few spacings)
                // (in floats, candidate k summed in lane k % LANES, the lanes
                // then added in order: it vectorises, and the sums are the
                // same for any thread count)
                float A[10][LANES] = {};
                int cn[LANES] = {};
                for (size_t k0 = 0; k0 < nbp; k0 += LANES)
                    for (int j = 0; j < LANES; j++) {
                        const float dx = px[k0 + j] - x, dy = py[k0 + j] - y, dz = pz[k0 + j] - z,
                                    d2 = dx * dx + dy * dy + dz * dz;
                        const float sd = std::sqrt(d2) * finvR, w = d2 < fR2 ? 1 - sd * sd * sd : 0.f;
                        cn[j] += d2 < fR2;
                        A[0][j] += w, A[1][j] += w * dx, A[2][j] += w * dy, A[3][j] += w * dz;
                        A[4][j] += w * dx * dx, A[5][j] += w * dx * dy, A[6][j] += w * dx * dz;
                        A[7][j] += w * dy * dy, A[8][j] += w * dy * dz, A[9][j] += w * dz * dz;
                    }
                float fw = 0, f0 = 0, f1 = 0, f2 = 0, g0 = 0, g1 = 0, g2 = 0, g3 = 0, g4 = 0, g5 = 0;
                int cnt = 0;
                for (int j = 0; j < LANES; j++) {
                    fw += A[0][j], f0 += A[1][j], f1 += A[2][j], f2 += A[3][j];
                    g0 += A[4][j], g1 += A[5][j], g2 += A[6][j], g3 += A[7][j], g4 += A[8][j], g5 += A[9][j];
                    cnt += cn[j];
                }
                double ws = fw, m[3] = {f0, f1, f2}, S[6] = {g0, g1, g2, g3, g4, g5};
                const double c[3] = {pos(i, 0) * inv, pos(i, 1) * inv, pos(i, 2) * inv};
                if (cnt < FEW_NEIGHBOURS) {
                    const double ax[3] = {2 * t, 2 * t, 2 * t};
                    K.put(slot[i], make_kernel(c, ax, I3));
                    continue;
                }
                for (int k = 0; k < 3; k++) m[k] /= ws; // ws >= 1: the particle itself
                const double C[3][3] = {{S[0] / ws - m[0] * m[0], S[1] / ws - m[0] * m[1], S[2] / ws - m[0] * m[2]},
                                        {S[1] / ws - m[0] * m[1], S[3] / ws - m[1] * m[1], S[4] / ws - m[1] * m[2]},
                                        {S[2] / ws - m[0] * m[2], S[4] / ws - m[1] * m[2], S[5] / ws - m[2] * m[2]}};
                double ev[3], V[3][3], ax[3];
                eigen3(C, ev, V);
                // a disc: across its thinnest direction the thickness; along
                // the other two the reach, shortened as the neighbourhood is
                // (Yu & Turk: in proportion to the covariance, at least 1/kr
                // of the longest), so that near an edge it stops at the edge
                for (int k = 0; k < 2; k++)
                    ax[k] = std::max(t, sup * std::min(std::max(ev[k], ev[0] / a.kr) / s_full, 1.0));
                ax[2] = t;
                K.put(slot[i], make_kernel(c, ax, V));
            }
        });
    return K;
}

// kernels in 8^3-voxel leaf bins of their centres
struct binned {
    kernel_table k;
    std::vector<uint32_t> src;
    std::vector<uint8_t> deep; // 1: a deep particle's ball of radius rb (voxels)
    float core = 0;            // rb - 1, a little less; 0: no culling
    std::vector<uint64_t> key; // distinct bins, ascending
    std::vector<uint32_t> at;  // (nbins + 1)
    int reach = 1;             // leaves a kernel reaches beyond its own
    // the voxels each kernel is evaluated on lie in its box (x lo, y lo,
    // z lo, x hi, y hi, z hi: ceil(c - ext), floor(c + ext)); a bin's box
    // is their union, its core box the union of its deep balls' cores
    // (the same with `core` for ext). A leaf tests a bin's box, then its
    // kernels' (small, contiguous), before it reads a kernel: most kernels
    // of the 27 bins around a leaf do not reach it.
    std::vector<int32_t> box;               // 6 per kernel
    std::vector<int32_t> bin_box, bin_cbox; // 6 per bin
    long find(uint64_t q) const {
        auto it = std::lower_bound(key.begin(), key.end(), q);
        return it == key.end() || *it != q ? -1 : long(it - key.begin());
    }
};

inline int64_t leaf_of(float c) { return int64_t(std::floor(c)) >> LEAF_LOG2; }

// the union's value over one leaf (the largest kernel value at each voxel,
// -PAD where none reaches), and the particle it came from
// The bits of a row's voxels za..zb (leaf offsets 0..7)
inline unsigned row_bits(int za, int zb) { return (0xFFu >> (7 - (zb - za))) << za & 0xFFu; }

// The rows of a leaf's x plane (y = 0..7) as the bytes of a word, each
// 0x80 where wanted. span_bytes: rows ya..yb. rows_to_do: the rows whose
// core bits (one byte each, cores[0..7]) do not hold every bit of zmask.
inline uint64_t span_bytes(int ya, int yb) {
    return (~uint64_t(0) >> (8 * (7 - (yb - ya)))) << (8 * ya) & 0x8080808080808080ull;
}
inline uint64_t rows_to_do(const uint8_t *cores, unsigned zmask) {
    uint64_t w;
    std::memcpy(&w, cores, sizeof w);
    const uint64_t z = uint64_t(zmask) * 0x0101010101010101ull, t = (w & z) ^ z; // a byte: zmask's bits missing
    const uint64_t lo7 = 0x7F7F7F7F7F7F7F7Full;
    return (((t & lo7) + lo7) | t) & ~lo7; // 0x80 in each nonzero byte
}
inline int kf_ctz64(uint64_t v) { return __builtin_ctzll(v); }

// whether box (lo x y z, hi x y z) meets the leaf's voxels o .. o + 7
inline bool box_meets(const int32_t *bx, const int o[3]) {
    return bx[0] <= o[0] + LEAF_DIM - 1 && bx[3] >= o[0] && bx[1] <= o[1] + LEAF_DIM - 1 && bx[4] >= o[1] &&
           bx[2] <= o[2] + LEAF_DIM - 1 && bx[5] >= o[2];
}

// Calls fn(q) for every kernel binned in the leaves within the bins' reach
// of leaf lc whose bin's box (bin_boxes) and own box (boxes, if given)
// meet the leaf, leaf by leaf in a fixed order (x, then y, then z offsets).
// The others have no voxel there: fn would return at once.
template <class Fn>
void for_each_kernel_near(const binned &b, Coord lc, const int32_t *boxes, const std::vector<int32_t> &bin_boxes,
                          Fn &&fn) {
    const int r = b.reach;
    const int o[3] = {lc.x() * LEAF_DIM, lc.y() * LEAF_DIM, lc.z() * LEAF_DIM};
    for (int i = -r; i <= r; i++)
        for (int j = -r; j <= r; j++)
            for (int l = -r; l <= r; l++) {
                const long bi = b.find(leaf_key(lc.x() + i, lc.y() + j, lc.z() + l));
                if (bi < 0 || !box_meets(bin_boxes.data() + 6 * size_t(bi), o)) continue;
                for (uint32_t q = b.at[size_t(bi)]; q < b.at[size_t(bi) + 1]; q++)
                    if (!boxes || box_meets(boxes + 6 * size_t(q), o)) fn(q);
            }
}

// the kernels' boxes, and their bins' boxes and core boxes (binned's
// comment): the same integers splat_leaf and core_rows compute from each
// kernel. In one pass over the kernels, bin by bin, which also returns the
// largest extent (a maximum, the same in any order).
float make_boxes(binned &b) {
    const size_t n = b.k.c.size(), nbin = b.key.size();
    b.box.resize(6 * n), b.bin_box.resize(6 * nbin), b.bin_cbox.resize(6 * nbin);
    const float rc = b.core;
    return tbb::parallel_reduce(
        tbb::blocked_range<size_t>(0, nbin, 64), 0.f,
        [&](const tbb::blocked_range<size_t> &rg, float e) {
            for (size_t bi = rg.begin(); bi != rg.end(); bi++) {
                int32_t *bb = b.bin_box.data() + 6 * bi, *bc = b.bin_cbox.data() + 6 * bi;
                for (int a = 0; a < 3; a++) bb[a] = bc[a] = INT32_MAX, bb[a + 3] = bc[a + 3] = INT32_MIN;
                for (uint32_t q = b.at[bi]; q < b.at[bi + 1]; q++) {
                    const shape &K = b.k.at(q);
                    const float *c = b.k.c[q].data();
                    e = std::max(e, std::max(K.ext[0], std::max(K.ext[1], K.ext[2])));
                    int32_t *x = b.box.data() + 6 * size_t(q);
                    for (int a = 0; a < 3; a++) {
                        x[a] = int32_t(std::ceil(c[a] - K.ext[a])), x[a + 3] = int32_t(std::floor(c[a] + K.ext[a]));
                        bb[a] = std::min(bb[a], x[a]), bb[a + 3] = std::max(bb[a + 3], x[a + 3]);
                    }
                    // core_rows' test: no core voxel unless rc > 0 and the kernel is deep
                    if (!b.deep[q] || !(rc > 0)) continue;
                    for (int a = 0; a < 3; a++)
                        bc[a] = std::min(bc[a], int32_t(std::ceil(c[a] - rc))),
                        bc[a + 3] = std::max(bc[a + 3], int32_t(std::floor(c[a] + rc)));
                }
            }
            return e;
        },
        [](float x, float y) { return std::max(x, y); });
}

// The voxels of one leaf within b.core of a deep ball's centre (a bit per
// voxel, a byte per row): such a voxel's six neighbours lie within the
// ball, inside the union, so its value is never used, only its sign.
// Returns whether every voxel of the leaf is such a voxel.
bool core_rows(const binned &b, Coord lc, uint8_t core[LEAF_DIM * LEAF_DIM]) {
    std::fill(core, core + LEAF_DIM * LEAF_DIM, uint8_t(0));
    const int ox = lc.x() * LEAF_DIM, oy = lc.y() * LEAF_DIM, oz = lc.z() * LEAF_DIM;
    const float rc = b.core, rc2 = rc * rc;
    for_each_kernel_near(b, lc, nullptr, b.bin_cbox, [&](uint32_t q) {
        if (!b.deep[q]) return;
        const float *c = b.k.c[q].data();
        const int x0 = std::max(ox, int(std::ceil(c[0] - rc))),
                  x1 = std::min(ox + LEAF_DIM - 1, int(std::floor(c[0] + rc)));
        const int y0 = std::max(oy, int(std::ceil(c[1] - rc))),
                  y1 = std::min(oy + LEAF_DIM - 1, int(std::floor(c[1] + rc)));
        if (x0 > x1 || y0 > y1 || c[2] + rc < float(oz) || c[2] - rc > float(oz + LEAF_DIM - 1)) return;
        for (int x = x0; x <= x1; x++) {
            const float dx = float(x) - c[0];
            for (int y = y0; y <= y1; y++) {
                const float dy = float(y) - c[1], r2 = rc2 - dx * dx - dy * dy;
                if (r2 < 0) continue;
                const float sq = std::sqrt(r2);
                const int za = std::max(oz, int(std::ceil(c[2] - sq))),
                          zb = std::min(oz + LEAF_DIM - 1, int(std::floor(c[2] + sq)));
                if (za <= zb) core[((x - ox) << LEAF_LOG2) + (y - oy)] |= uint8_t(row_bits(za - oz, zb - oz));
            }
        }
    });
    return std::all_of(core, core + LEAF_DIM * LEAF_DIM, [](uint8_t m) { return m == 0xFF; });
}

void splat_leaf(const binned &b, Coord lc, float *F, int32_t *who, unsigned open) {
    std::fill(F, F + LEAF_SIZE, -PAD);
    if (who) std::fill(who, who + LEAF_SIZE, -1);
    const int ox = lc.x() * LEAF_DIM, oy = lc.y() * LEAF_DIM, oz = lc.z() * LEAF_DIM;
    // Without particle tracking only the sign of a voxel whose neighbours
    // are all inside matters (the distance is made from the crossings):
    // such voxels (deep balls' cores) read 1, and no kernel is evaluated
    // on a row of them. The values that are used stay exact. The voxels
    // on a face of the leaf whose neighbour leaf lies beyond the band (a
    // bit of `open`: -x, +x, -y, +y, -z, +z) keep their values: their
    // neighbours there read `outside`, whatever is there.
    uint8_t core[LEAF_DIM * LEAF_DIM];
    const bool cull = !who && b.core > 0;
    if (cull) {
        const bool all = core_rows(b, lc, core);
        if (!open && all) {
            std::fill(F, F + LEAF_SIZE, 1.f);
            return;
        }
        if (open) {
            const uint8_t zkeep = uint8_t(~((open >> 4 & 1) | (open >> 5 & 1) << 7));
            for (int xy = 0; xy < LEAF_DIM * LEAF_DIM; xy++) {
                const int x = xy >> LEAF_LOG2, y = xy & (LEAF_DIM - 1);
                const bool face = (x == 0 && (open & 1)) || (x == LEAF_DIM - 1 && (open & 2)) ||
                                  (y == 0 && (open & 4)) || (y == LEAF_DIM - 1 && (open & 8));
                core[xy] &= face ? 0 : zkeep;
            }
        }
        for (int v = 0; v < LEAF_SIZE; v++)
            if (core[v >> LEAF_LOG2] >> (v & (LEAF_DIM - 1)) & 1) F[v] = 1.f;
    }
    for_each_kernel_near(b, lc, b.box.data(), b.bin_box, [&](uint32_t q) {
        const shape &K = b.k.at(q);
        const float *Kc = b.k.c[q].data();
        const int32_t *bx = b.box.data() + 6 * size_t(q);
        const int x0 = std::max(ox, int(bx[0])), x1 = std::min(ox + LEAF_DIM - 1, int(bx[3]));
        const int y0 = std::max(oy, int(bx[1])), y1 = std::min(oy + LEAF_DIM - 1, int(bx[4]));
        const int z0 = std::max(oz, int(bx[2])), z1 = std::min(oz + LEAF_DIM - 1, int(bx[5]));
        if (x0 > x1 || y0 > y1 || z0 > z1) return;
        const unsigned zmask = row_bits(z0 - oz, z1 - oz);
        // the rows y0..y1 as bytes of a word; with the cores, those whose
        // voxels in reach are not all cores (the others: nothing to do)
        const uint64_t yspan = span_bytes(y0 - oy, y1 - oy);
        const float inv2 = 0.5f / K.P[5];
        for (int x = x0; x <= x1; x++) {
            const uint64_t todo = cull ? rows_to_do(core + ((x - ox) << LEAF_LOG2), zmask) & yspan : yspan;
            if (!todo) continue;
            const float dx = float(x) - Kc[0];
            // the eight rows' spans inside the grown ellipsoid (P5 dz^2 + pb
            // dz + pa <= 1) and their quadratics, at once (a vector each; the
            // same floats row by row); a row outside has disc < 0
            float qa[LEAF_DIM], qb[LEAF_DIM], disc[LEAF_DIM];
            int za[LEAF_DIM], zb[LEAF_DIM];
            for (int j = 0; j < LEAF_DIM; j++) {
                const float dy = float(oy + j) - Kc[1];
                const float pa = K.P[0] * dx * dx + 2 * K.P[1] * dx * dy + K.P[3] * dy * dy;
                const float pb = 2 * (K.P[2] * dx + K.P[4] * dy);
                disc[j] = pb * pb - 4 * K.P[5] * (pa - 1);
                const float sq = std::sqrt(std::max(disc[j], 0.f));
                za[j] = std::max(z0, int(std::floor(Kc[2] + (-pb - sq) * inv2)));
                zb[j] = std::min(z1, int(std::ceil(Kc[2] + (-pb + sq) * inv2)));
                qa[j] = K.M[0] * dx * dx + 2 * K.M[1] * dx * dy + K.M[3] * dy * dy;
                qb[j] = 2 * (K.M[2] * dx + K.M[4] * dy);
            }
            for (uint64_t rows = todo; rows; rows &= rows - 1) {
                const int j = kf_ctz64(rows) >> 3, y = oy + j;
                if (disc[j] < 0 || za[j] > zb[j]) continue;
                const unsigned cr = cull ? core[((x - ox) << LEAF_LOG2) + j] : 0u;
                if (cr) {
                    const unsigned m = row_bits(za[j] - oz, zb[j] - oz);
                    if ((cr & m) == m) continue;
                }
                const int row = ((x - ox) << (2 * LEAF_LOG2)) + ((y - oy) << LEAF_LOG2);
                const int ma = za[j] - oz, mb = zb[j] - oz;
                float *d = F + row;
                const float cz = Kc[2], m5 = K.M[5], am = K.amin, qaj = qa[j], qbj = qb[j];
                if (!who) {
                    // the whole 8-voxel row, branch-free so that it
                    // vectorises; voxels outside [za, zb] keep theirs
                    // (not unrolled: GCC unrolls the 8 iterations first
                    // and then leaves them scalar, with branches). One
                    // vector costs less than a short span's scalar loop.
#pragma GCC unroll 1
                    for (int z = 0; z < LEAF_DIM; z++) {
                        const float dz = float(oz + z) - cz;
                        const float val = am * (1 - std::sqrt(std::max(qaj + dz * (qbj + m5 * dz), 0.f)));
                        d[z] = z >= ma && z <= mb && val > d[z] ? val : d[z];
                    }
                } else {
                    // particles tracked: the span alone, the first
                    // kernel of the largest value keeping the voxel
                    int32_t *w = who + row;
                    for (int z = ma; z <= mb; z++) {
                        const float dz = float(oz + z) - cz;
                        const float val = am * (1 - std::sqrt(std::max(qaj + dz * (qbj + m5 * dz), 0.f)));
                        if (val > d[z]) {
                            d[z] = val;
                            w[z] = int32_t(q);
                        }
                    }
                }
            }
        }
    });
}

// Where the union's value D (one per band voxel; a missing leaf reads
// `outside`) crosses 0, made a signed distance in band.phi (voxel units).
// D's buffer then becomes the band's scratch (the passes after write there).
void distance_from_crossings(dense_band &band, std::vector<float> &D, float outside, float W) {
    const float iso = 0;
    const size_t nl = band.size();
    // The crossings: along each voxel edge from an inside voxel (value at
    // least 0) to an outside one, linearly placed; they are the surface
    // points of the distance. An inside voxel beside a crossing gets the
    // distance to the plane through its crossings (intercepts t_a on its
    // axes: 1 / sqrt(sum 1 / t_a^2)); every other voxel gets its sign alone.
    band.phi.assign(nl * LEAF_SIZE, 0.f);
    std::vector<std::vector<float>> pts(nl);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nl, 4), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            const float *d = D.data() + i * LEAF_SIZE;
            float *phi = band.leaf(i);
            const Coord lc = leaf_coord(band.key[i]);
            for (int v = 0; v < LEAF_SIZE; v++) {
                if (d[v] < iso) {
                    phi[v] = 0.f; // outside: the distance decides
                    continue;
                }
                const int c[3] = {v >> 6, (v >> 3) & 7, v & 7};
                double inv2 = 0;
                for (int ax = 0; ax < 3; ax++) {
                    double tmin = 2;
                    for (int s = -1; s <= 1; s += 2) {
                        int nn[3] = {c[0], c[1], c[2]}, dl[3] = {0, 0, 0};
                        nn[ax] += s;
                        if (nn[ax] < 0 || nn[ax] >= LEAF_DIM) dl[ax] = s, nn[ax] -= s * LEAF_DIM;
                        const int32_t j =
                            dl[ax] ? band.nbr[27 * i + dense_band::nbr_slot(dl[0], dl[1], dl[2])] : int32_t(i);
                        const float dn =
                            j < 0 ? outside : D[size_t(j) * LEAF_SIZE + size_t((nn[0] << 6) + (nn[1] << 3) + nn[2])];
                        if (dn >= iso) continue;
                        const double t = double(d[v] - iso) / double(d[v] - dn);
                        tmin = std::min(tmin, t);
                        float p[3] = {float(lc.x() * LEAF_DIM + c[0]), float(lc.y() * LEAF_DIM + c[1]),
                                      float(lc.z() * LEAF_DIM + c[2])};
                        p[ax] += float(s * t);
                        pts[i].insert(pts[i].end(), p, p + 3);
                    }
                    if (tmin < 2) inv2 += 1 / std::max(tmin * tmin, 1e-12);
                }
                phi[v] = inv2 > 0 ? -float(1 / std::sqrt(inv2)) : -1e-6f;
            }
        }
    });
    surface_points sp;
    sp.at.assign(nl + 1, 0);
    for (size_t i = 0; i < nl; i++) sp.at[i + 1] = sp.at[i] + uint32_t(pts[i].size() / 3);
    sp.x.resize(sp.at[nl]), sp.y.resize(sp.at[nl]), sp.z.resize(sp.at[nl]);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nl, 64), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++)
            for (size_t k = 0; 3 * k < pts[i].size(); k++)
                sp.x[sp.at[i] + k] = pts[i][3 * k], sp.y[sp.at[i] + k] = pts[i][3 * k + 1],
                                sp.z[sp.at[i] + k] = pts[i][3 * k + 2];
    });
    pts.clear();
    band.scratch.swap(D);
    band_distance(band, sp, 0.f, W);
}

} // namespace

openvdb::FloatGrid::Ptr rasterise_anisotropic(size_t n, const double *xd, const float *xf, const float *vel,
                                              const aniso_params &a, double vx, double hw, const band_filter *f,
                                              openvdb::Vec3SGrid::Ptr *velgrid, aniso_timing *timing) {
    if (n >= (size_t(1) << 31)) throw std::runtime_error("more than 2^31 particles");
    if (!(a.support > 0 && a.R > 0 && a.kr >= 1 && a.thickness > 0 && a.spacing > 0))
        throw std::runtime_error("anisotropic kernels: reach, neighbourhood, ratio, thickness or spacing out of range");
    aniso_timing tm{};
    // the kernels' leaf bins, from their centres (ties by index:
    // deterministic), before they are made: each is made in its place
    double t0 = cpu_now(), w0 = wall_now();
    const double inv = 1 / vx;
    std::vector<uint64_t> keys(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            int64_t l[3];
            for (int k = 0; k < 3; k++) l[k] = leaf_of(float((xd ? xd[3 * i + k] : double(xf[3 * i + k])) * inv));
            keys[i] = leaf_key(l[0], l[1], l[2]);
        }
    });
    key_bins<uint32_t> kb = order_by_key<uint32_t>(keys);
    keys.clear(), keys.shrink_to_fit();
    std::vector<uint32_t> slot(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t q = rg.begin(); q != rg.end(); q++) slot[kb.order[q]] = uint32_t(q);
    });
    tm.sort_s = cpu_now() - t0, tm.sort_w = wall_now() - w0;

    t0 = cpu_now(), w0 = wall_now();
    std::vector<uint8_t> deep;
    kernel_table K = shape_kernels(n, xd, xf, a, vx, slot.data(), deep);
    for (size_t i = 0; i < n; i++) tm.n_deep += deep[i];
    slot.clear(), slot.shrink_to_fit();
    tm.shape_s = cpu_now() - t0, tm.shape_w = wall_now() - w0;

    t0 = cpu_now(), w0 = wall_now();
    binned b;
    b.k = std::move(K), b.deep.resize(n);
    b.src.swap(kb.order), b.key.swap(kb.key), b.at.swap(kb.at);
    // a deep ball's core: within rb - 1 voxels (less a margin far above
    // rounding) its neighbours are inside the ball
    const double rbv = deep_ball_radius(a) / vx;
    b.core = rbv > 1.5 ? float(rbv - 1 - 0.01) : 0.f;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t q = rg.begin(); q != rg.end(); q++) b.deep[q] = deep[b.src[q]];
    });
    // the boxes, and the largest extent
    const float emax = make_boxes(b);
    b.reach = int(std::ceil(double(emax) / LEAF_DIM));
    // the leaves within reach of a bin holding a particle near a face: the
    // surface lies in them; the others are wholly inside or outside (each
    // bin's in its own slots, NONE where it holds none: the same set)
    const int r = b.reach, side = 2 * r + 1, per = side * side * side;
    const size_t nbin = b.key.size();
    constexpr uint64_t NONE = ~uint64_t(0);
    std::vector<uint64_t> targets(nbin * size_t(per), NONE);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nbin, 64), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t bi = rg.begin(); bi != rg.end(); bi++) {
            bool any = false;
            for (uint32_t q = b.at[bi]; q < b.at[bi + 1] && !any; q++) any = !b.deep[q];
            if (!any) continue;
            const Coord c = leaf_coord(b.key[bi]);
            uint64_t *t = targets.data() + bi * size_t(per);
            for (int x = -r; x <= r; x++)
                for (int y = -r; y <= r; y++)
                    for (int z = -r; z <= r; z++) *t++ = leaf_key(c.x() + x, c.y() + y, c.z() + z);
        }
    });
    tbb::parallel_sort(targets.begin(), targets.end());
    targets.erase(std::unique(targets.begin(), targets.end()), targets.end());
    if (!targets.empty() && targets.back() == NONE) targets.pop_back();
    tm.sort_s += cpu_now() - t0, tm.sort_w += wall_now() - w0;

    // the union over the targets; then the band: the targets and the 26
    // leaves around each that holds an inside voxel (the deep leaves beside
    // the surface), each leaf in its own buffer
    t0 = cpu_now(), w0 = wall_now();
    const bool track = vel && velgrid;
    std::vector<float> F(targets.size() * LEAF_SIZE);
    std::vector<int32_t> who(track ? targets.size() * LEAF_SIZE : 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, targets.size(), 4), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t t = rg.begin(); t != rg.end(); t++)
            splat_leaf(b, leaf_coord(targets[t]), F.data() + t * LEAF_SIZE,
                       track ? who.data() + t * LEAF_SIZE : nullptr, 0);
    });
    dense_band band;
    // (each target's 26 neighbours in its own slots, NONE where it holds no
    // inside voxel: the same set)
    band.key.assign(targets.size() * 27, NONE);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, targets.size(), 64), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t t = rg.begin(); t != rg.end(); t++) {
            uint64_t *o = band.key.data() + 27 * t;
            o[0] = targets[t];
            const float *f0 = F.data() + t * LEAF_SIZE;
            if (std::none_of(f0, f0 + LEAF_SIZE, [](float v) { return v >= 0; })) continue;
            const Coord c = leaf_coord(targets[t]);
            for (int i = -1; i <= 1; i++)
                for (int j = -1; j <= 1; j++)
                    for (int k = -1; k <= 1; k++)
                        if (i || j || k) *++o = leaf_key(c.x() + i, c.y() + j, c.z() + k);
        }
    });
    tbb::parallel_sort(band.key.begin(), band.key.end());
    band.key.erase(std::unique(band.key.begin(), band.key.end()), band.key.end());
    if (!band.key.empty() && band.key.back() == NONE) band.key.pop_back();
    const size_t nl = band.size();
    std::vector<float> D(nl * LEAF_SIZE);
    std::vector<int32_t> bwho(track ? nl * LEAF_SIZE : 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nl, 4), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            auto it = std::lower_bound(targets.begin(), targets.end(), band.key[i]);
            float *d = D.data() + i * LEAF_SIZE;
            int32_t *w = track ? bwho.data() + i * LEAF_SIZE : nullptr;
            if (it != targets.end() && *it == band.key[i]) {
                const size_t t = size_t(it - targets.begin());
                std::copy(F.data() + t * LEAF_SIZE, F.data() + (t + 1) * LEAF_SIZE, d);
                if (w) std::copy(who.data() + t * LEAF_SIZE, who.data() + (t + 1) * LEAF_SIZE, w);
            } else {
                // the faces whose neighbour leaf is not in the band
                const Coord c = leaf_coord(band.key[i]);
                const int f[6][3] = {{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}};
                unsigned open = 0;
                for (int k = 0; k < 6; k++)
                    if (band.find(leaf_key(c.x() + f[k][0], c.y() + f[k][1], c.z() + f[k][2])) < 0) open |= 1u << k;
                splat_leaf(b, c, d, w, open);
            }
            if (w)
                for (int v = 0; v < LEAF_SIZE; v++)
                    if (w[v] >= 0) w[v] = int32_t(b.src[size_t(w[v])]);
        }
    });
    F.clear(), F.shrink_to_fit(), who.clear(), who.shrink_to_fit();
    band.link();
    tm.splat_s = cpu_now() - t0, tm.splat_w = wall_now() - w0;

    t0 = cpu_now(), w0 = wall_now();
    const float W = float(hw + 1 + (f ? f->dilate / vx + f->erode / vx : 0.0));
    if (W > 7) throw std::runtime_error("half width + dilate + erode must stay within 6 voxels");
    distance_from_crossings(band, D, -PAD, W);
    D.clear(), D.shrink_to_fit();
    tm.redistance_s = cpu_now() - t0, tm.redistance_w = wall_now() - w0;

    t0 = cpu_now(), w0 = wall_now();
    openvdb::FloatGrid::Ptr grid = band_to_grid(band, vx, hw, W, f, track ? &bwho : nullptr, vel, velgrid);
    tm.filter_s = cpu_now() - t0, tm.filter_w = wall_now() - w0;
    if (timing) *timing = tm;
    return grid;
}

} // namespace kf_vdb
