// sphere_raster.cpp — particles to a narrow-band level set (see sphere_raster.h).
#include "sphere_raster.h"

#include "band_distance.h"
#include "band_flatten.h"
#include "band_smooth.h"
#include "buried_particles.h"

#include <openvdb/tools/SignedFloodFill.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <ctime>
#include <cmath>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <utility>
#include <vector>

namespace kf_vdb {

namespace {

using openvdb::Coord;
using openvdb::FloatGrid;
using openvdb::FloatTree;
using openvdb::Vec3s;
using openvdb::Vec3SGrid;
using Leaf = FloatTree::LeafNodeType;
using VelLeaf = Vec3SGrid::TreeType::LeafNodeType;

constexpr int LOG2 = LEAF_LOG2; // 8^3-voxel leaves
constexpr int DIM = LEAF_DIM;
constexpr int64_t BIAS = LEAF_BIAS;
static_assert(Leaf::LOG2DIM == LEAF_LOG2, "OpenVDB's leaves are 8^3");

// process CPU seconds (all threads): honest when other work shares the machine
double cpu_now() {
    timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

uint64_t pack(int64_t lx, int64_t ly, int64_t lz) { return leaf_key(lx, ly, lz); }
Coord unpack(uint64_t k) { return leaf_coord(k); }

// particles in leaf-bin order, in index space (voxel units), structure of arrays
struct sorted_particles {
    std::vector<float> x, y, z, r;
    std::vector<uint32_t> src;     // original index (for velocities)
    std::vector<uint64_t> bin_key; // distinct bins, ascending
    std::vector<uint32_t> bin_at;  // (nbins + 1) first particle of each bin
    float rmax = 0;

    std::vector<uint32_t> bin_mid; // (nbins) first buried particle of each bin (buried_particles.h)

    // the particles splatted as spheres in the bin with this key, and the
    // buried ones after them, [first, last) (empty when there is no bin)
    std::pair<uint32_t, uint32_t> spheres(uint64_t key) const {
        const long b = find(key);
        return b < 0 ? std::make_pair(0u, 0u) : std::make_pair(bin_at[size_t(b)], bin_mid[size_t(b)]);
    }
    std::pair<uint32_t, uint32_t> buried(uint64_t key) const {
        const long b = find(key);
        return b < 0 ? std::make_pair(0u, 0u) : std::make_pair(bin_mid[size_t(b)], bin_at[size_t(b) + 1]);
    }
    long find(uint64_t key) const {
        auto it = std::lower_bound(bin_key.begin(), bin_key.end(), key);
        return it == bin_key.end() || *it != key ? -1 : long(it - bin_key.begin());
    }
};

sorted_particles sort_particles(const sphere_set &s, double h) {
    const size_t n = s.n;
    if (n >= (size_t(1) << 32)) throw std::runtime_error("more than 2^32 particles");
    std::vector<std::pair<uint64_t, uint32_t>> order(n);
    const double inv_h = 1 / h, lim = double(BIAS) * DIM - 64;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            double c[3];
            for (int a = 0; a < 3; a++) c[a] = (s.xd ? s.xd[3 * i + a] : double(s.xf[3 * i + a])) * inv_h;
            int64_t l[3];
            for (int a = 0; a < 3; a++) {
                if (!(std::fabs(c[a]) < lim)) throw std::runtime_error("a particle lies too far from the origin");
                l[a] = int64_t(std::floor(c[a])) >> LOG2;
            }
            order[i] = {pack(l[0], l[1], l[2]), uint32_t(i)};
        }
    });
    tbb::parallel_sort(order.begin(), order.end());
    sorted_particles p;
    p.x.resize(n), p.y.resize(n), p.z.resize(n), p.r.resize(n), p.src.resize(n);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4096), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t k = rg.begin(); k != rg.end(); k++) {
            const size_t i = order[k].second;
            double ri = s.radii ? double(s.radii[i]) : s.r;
            if (ri < s.rmin) ri = s.rmin;
            p.x[k] = float((s.xd ? s.xd[3 * i] : double(s.xf[3 * i])) * inv_h);
            p.y[k] = float((s.xd ? s.xd[3 * i + 1] : double(s.xf[3 * i + 1])) * inv_h);
            p.z[k] = float((s.xd ? s.xd[3 * i + 2] : double(s.xf[3 * i + 2])) * inv_h);
            p.r[k] = float(ri * inv_h);
            p.src[k] = uint32_t(i);
        }
    });
    for (size_t k = 0; k < n; k++) {
        if (k == 0 || order[k].first != order[k - 1].first) {
            p.bin_key.push_back(order[k].first);
            p.bin_at.push_back(uint32_t(k));
        }
        p.rmax = std::max(p.rmax, p.r[k]);
    }
    p.bin_at.push_back(uint32_t(n));
    p.bin_mid.assign(p.bin_at.begin() + 1, p.bin_at.end());
    return p;
}

// put each bin's buried particles last (bin_mid), so the splat gives them
// only their nearest voxel: that keeps every voxel they reach inside, as
// all those voxels hold particles (buried_particles.h)
void mark_buried(sorted_particles &p, int M) {
    const std::vector<uint8_t> buried = buried_particles(p.x.data(), p.y.data(), p.z.data(), p.bin_key, p.bin_at, M);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, p.bin_key.size(), 16), [&](const tbb::blocked_range<size_t> &rg) {
        std::vector<uint32_t> order;
        std::vector<float> t;
        std::vector<uint32_t> ts;
        for (size_t b = rg.begin(); b != rg.end(); b++) {
            const uint32_t first = p.bin_at[b], last = p.bin_at[b + 1];
            order.clear();
            for (uint32_t k = first; k < last; k++)
                if (!buried[k]) order.push_back(k);
            p.bin_mid[b] = first + uint32_t(order.size());
            for (uint32_t k = first; k < last; k++)
                if (buried[k]) order.push_back(k);
            for (std::vector<float> *a : {&p.x, &p.y, &p.z, &p.r}) {
                t.assign(order.size(), 0);
                for (size_t k = 0; k < order.size(); k++) t[k] = (*a)[order[k]];
                std::copy(t.begin(), t.end(), a->begin() + first);
            }
            ts.assign(order.size(), 0);
            for (size_t k = 0; k < order.size(); k++) ts[k] = p.src[order[k]];
            std::copy(ts.begin(), ts.end(), p.src.begin() + first);
        }
    });
}

// one output leaf: the union-of-spheres distance (voxel units, clamped to
// the band w) of every particle in the bins within `reach` leaves
struct leaf_buffer {
    float d[Leaf::SIZE];
    int32_t who[Leaf::SIZE]; // closest particle (sorted index), -1: none
};

void splat_leaf(const sorted_particles &p, Coord leaf, int reach, float w, bool track, leaf_buffer &b) {
    std::fill(b.d, b.d + Leaf::SIZE, w);
    if (track) std::fill(b.who, b.who + Leaf::SIZE, -1);
    const int ox = leaf.x() * DIM, oy = leaf.y() * DIM, oz = leaf.z() * DIM; // not << : leaves may be below 0
    const float fox = float(ox), foy = float(oy), foz = float(oz);
    for (int i = -reach; i <= reach; i++)
        for (int j = -reach; j <= reach; j++)
            for (int k = -reach; k <= reach; k++) {
                auto rg = p.spheres(pack(leaf.x() + i, leaf.y() + j, leaf.z() + k));
                for (uint32_t q = rg.first; q < rg.second; q++) {
                    const float px = p.x[q], py = p.y[q], pz = p.z[q], R = p.r[q], ext = R + w, ext2 = ext * ext;
                    // most particles of the bins around miss this leaf: say so cheaply
                    if (px + ext < fox || px - ext > fox + (DIM - 1) || py + ext < foy || py - ext > foy + (DIM - 1) ||
                        pz + ext < foz || pz - ext > foz + (DIM - 1))
                        continue;
                    const int x0 = std::max(ox, int(std::ceil(px - ext))),
                              x1 = std::min(ox + DIM - 1, int(std::floor(px + ext)));
                    const int y0 = std::max(oy, int(std::ceil(py - ext))),
                              y1 = std::min(oy + DIM - 1, int(std::floor(py + ext)));
                    const int z0 = std::max(oz, int(std::ceil(pz - ext))),
                              z1 = std::min(oz + DIM - 1, int(std::floor(pz + ext)));
                    if (z0 > z1) continue;
                    // whole 8-voxel rows, branch-free so they vectorise: beyond
                    // the reach a distance exceeds w and min() keeps the buffer
                    for (int x = x0; x <= x1; x++) {
                        const float fx = float(x) - px, fx2 = fx * fx;
                        for (int y = y0; y <= y1; y++) {
                            const float fy = float(y) - py, fxy = fx2 + fy * fy;
                            if (fxy >= ext2) continue;
                            const int row = ((x - ox) << (2 * LOG2)) + ((y - oy) << LOG2);
                            float *d = b.d + row;
                            if (track) {
                                int32_t *who = b.who + row;
                                for (int z = 0; z < DIM; z++) {
                                    const float fz = float(oz + z) - pz, dist = std::sqrt(fxy + fz * fz) - R;
                                    const bool closer = dist < d[z];
                                    d[z] = closer ? dist : d[z];
                                    who[z] = closer ? int32_t(q) : who[z];
                                }
                            } else {
                                for (int z = 0; z < DIM; z++) {
                                    const float fz = float(oz + z) - pz;
                                    d[z] = std::min(d[z], std::sqrt(fxy + fz * fz) - R);
                                }
                            }
                        }
                    }
                }
            }
    // buried particles: their nearest voxel only (from this leaf's bin and
    // the bins below, whose particles may round into it)
    for (int i = -1; i <= 0; i++)
        for (int j = -1; j <= 0; j++)
            for (int k = -1; k <= 0; k++) {
                auto rg = p.buried(pack(leaf.x() + i, leaf.y() + j, leaf.z() + k));
                for (uint32_t q = rg.first; q < rg.second; q++) {
                    const int x = int(std::floor(p.x[q] + 0.5f)) - ox, y = int(std::floor(p.y[q] + 0.5f)) - oy,
                              z = int(std::floor(p.z[q] + 0.5f)) - oz;
                    if (x < 0 || y < 0 || z < 0 || x >= DIM || y >= DIM || z >= DIM) continue;
                    const float fx = float(ox + x) - p.x[q], fy = float(oy + y) - p.y[q], fz = float(oz + z) - p.z[q];
                    const float dist = std::sqrt(fx * fx + fy * fy + fz * fz) - p.r[q];
                    const int v = (x << 6) + (y << 3) + z;
                    if (dist < b.d[v]) {
                        b.d[v] = dist;
                        if (track) b.who[v] = int32_t(q);
                    }
                }
            }
}

// the point of the circle where spheres q and u meet nearest to (vx, vy, vz)
void crease_point(const sorted_particles &p, uint32_t q, uint32_t u, float vx, float vy, float vz,
                  std::vector<float> &out) {
    const float ex = p.x[u] - p.x[q], ey = p.y[u] - p.y[q], ez = p.z[u] - p.z[q],
                L = std::sqrt(ex * ex + ey * ey + ez * ez);
    const float R = p.r[q], S = p.r[u];
    if (!(L > std::fabs(R - S) && L < R + S)) return; // no circle
    const float t = (L * L + R * R - S * S) / (2 * L), rc = std::sqrt(std::max(R * R - t * t, 0.f));
    const float nx = ex / L, ny = ey / L, nz = ez / L;
    const float cx = p.x[q] + t * nx, cy = p.y[q] + t * ny, cz = p.z[q] + t * nz;
    const float wx = vx - cx, wy = vy - cy, wz = vz - cz, along = wx * nx + wy * ny + wz * nz;
    const float ux = wx - along * nx, uy = wy - along * ny, uz = wz - along * nz,
                ul = std::sqrt(ux * ux + uy * uy + uz * uz);
    if (!(ul > 1e-6f)) return;
    out.push_back(cx + rc * ux / ul);
    out.push_back(cy + rc * uy / ul);
    out.push_back(cz + rc * uz / ul);
}

// a leaf's closest points on the spheres, from its voxels just outside
// (0 <= d < 1): on the closest sphere, which outside the union is exact
void closest_points(const sorted_particles &p, openvdb::Coord lc, const leaf_buffer &b, std::vector<float> &out) {
    const int ox = lc.x() * DIM, oy = lc.y() * DIM, oz = lc.z() * DIM;
    for (int v = 0; v < LEAF_SIZE; v++) {
        const float d = b.d[v];
        if (!(d >= 0 && d < 1) || b.who[v] < 0) continue;
        const uint32_t q = uint32_t(b.who[v]);
        const float vx = float(ox + (v >> 6)) - p.x[q], vy = float(oy + ((v >> 3) & 7)) - p.y[q],
                    vz = float(oz + (v & 7)) - p.z[q];
        const float k = p.r[q] / (d + p.r[q]); // |voxel - centre| = d + R
        out.push_back(p.x[q] + k * vx);
        out.push_back(p.y[q] + k * vy);
        out.push_back(p.z[q] + k * vz);
        // where a face neighbour in this leaf is inside another sphere, a
        // crease runs between them: its nearest point on the two spheres'
        // circle, which the projections alone sample thinly (a concave
        // crease is nobody's closest point from outside)
        for (int a = 0; a < 3; a++)
            for (int sgn = -1; sgn <= 1; sgn += 2) {
                const int c = a == 0 ? (v >> 6) : (a == 1 ? (v >> 3) & 7 : v & 7);
                if (c + sgn < 0 || c + sgn >= DIM) continue;
                const int w = v + sgn * (a == 0 ? 64 : (a == 1 ? 8 : 1));
                if (!(b.d[w] < 0) || b.who[w] < 0 || b.who[w] == b.who[v]) continue;
                crease_point(p, q, uint32_t(b.who[w]), float(ox + (v >> 6)), float(oy + ((v >> 3) & 7)),
                             float(oz + (v & 7)), out);
            }
    }
}

// a splatted leaf kept for the band: values, closest particles, surface points
struct splat_leaf_out {
    std::unique_ptr<float[]> d;
    std::unique_ptr<int32_t[]> who;
    std::vector<float> pts;
};

} // namespace

FloatGrid::Ptr band_to_grid(dense_band &band, double h, double hw, float W, const band_filter *f,
                            const std::vector<int32_t> *who, const float *vel, Vec3SGrid::Ptr *velgrid) {
    if (f) band_smooth(band, W, float(f->dilate / h), f->mc_iterations, float(f->erode / h));
    // the neighbourhoods within the 27 leaves around (8 voxels)
    for (int k = 0; f && k < f->flatten; k++)
        band_flatten(band, W, float(std::min(f->flatten_radius / h, 7.5)), FLATTEN_SIGMA,
                     float(std::min(f->flatten_normal_radius / h, 7.5)));
    const bool track = who && vel && velgrid;
    const size_t nl = band.size();
    const float bg = float(hw * h), hwv = float(hw);
    std::vector<Leaf *> leaves(nl, nullptr);
    std::vector<VelLeaf *> vleaves(track ? nl : 0, nullptr);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nl, 16), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            const float *phi = band.leaf(i);
            bool any = false;
            for (int v = 0; v < LEAF_SIZE && !any; v++) any = std::fabs(phi[v]) < hwv;
            if (!any) continue;
            const Coord lc = unpack(band.key[i]);
            const Coord origin(lc.x() * DIM, lc.y() * DIM, lc.z() * DIM);
            auto *leaf = new Leaf(origin, bg, false);
            VelLeaf *vl = track ? new VelLeaf(origin, Vec3s(0.f), false) : nullptr;
            const int32_t *w = track ? who->data() + i * Leaf::SIZE : nullptr;
            for (int v = 0; v < LEAF_SIZE; v++) {
                const float d = phi[v];
                if (!(std::fabs(d) < hwv)) {
                    leaf->setValueOnly(v, d < 0 ? -bg : bg);
                    continue;
                }
                leaf->setValueOn(v, d * float(h));
                if (vl && w[v] >= 0) {
                    const size_t k = size_t(w[v]);
                    vl->setValueOn(v, Vec3s(vel[3 * k], vel[3 * k + 1], vel[3 * k + 2]));
                }
            }
            leaves[i] = leaf;
            if (vl && vl->isEmpty()) delete vl;
            else if (vl) vleaves[i] = vl;
        }
    });
    auto grid = openvdb::createLevelSet<FloatGrid>(h, float(hw));
    for (Leaf *l : leaves)
        if (l) grid->tree().addLeaf(l);
    openvdb::tools::signedFloodFill(grid->tree()); // the interior's tiles and inactive values get their sign
    if (track) {
        auto vg = Vec3SGrid::create(Vec3s(0.f));
        vg->setTransform(grid->transform().copy());
        for (VelLeaf *l : vleaves)
            if (l) vg->tree().addLeaf(l);
        *velgrid = vg;
    }
    return grid;
}

FloatGrid::Ptr rasterise_spheres(const sphere_set &s, double h, double hw, const band_filter *f, Vec3SGrid::Ptr *vel,
                                 raster_timing *timing) {
    double t0 = cpu_now();
    // Spheres are splatted only SPLAT voxels beyond their radius: exact
    // distances near the zero crossing, their closest points and the right
    // sign everywhere inside is all the distance below needs (wider splats
    // cost the cube).
    const float ws = 1.0f;
    // the band is computed this wide (voxels): the final half width, a voxel
    // more for the stencils at its edge, and room for the shifts
    const float W = float(hw + 1 + (f ? f->dilate / h + f->erode / h : 0.0));
    if (W > 7) throw std::runtime_error("half width + dilate + erode must stay within 6 voxels");
    sorted_particles p = sort_particles(s, h);
    // dense particles (a voxel or more each): the buried ones change
    // nothing within the band but the sign (buried_particles.h)
    // (every voxel a sphere reaches, or beside one inside it, lies within
    // Chebyshev distance R + ws + 1/2 of its centre's nearest voxel)
    const int M = int(std::ceil(p.rmax + ws + 0.5f));
    if (M <= 8 && double(s.n) >= double(LEAF_SIZE) * double(p.bin_key.size())) mark_buried(p, M);
    if (timing) timing->sort_s = cpu_now() - t0;

    // every leaf within reach of an occupied bin may hold band voxels
    t0 = cpu_now();
    const int reach = int(std::ceil((double(p.rmax) + ws) / DIM));
    std::vector<uint64_t> targets;
    targets.reserve(p.bin_key.size() * size_t((2 * reach + 1) * (2 * reach + 1) * (2 * reach + 1)));
    for (uint64_t key : p.bin_key) {
        const Coord c = unpack(key);
        for (int i = -reach; i <= reach; i++)
            for (int j = -reach; j <= reach; j++)
                for (int k = -reach; k <= reach; k++) targets.push_back(pack(c.x() + i, c.y() + j, c.z() + k));
    }
    tbb::parallel_sort(targets.begin(), targets.end());
    targets.erase(std::unique(targets.begin(), targets.end()), targets.end());

    // fill each target leaf in its own buffer (no two tasks share anything);
    // keep those with a voxel inside or near the surface
    std::vector<splat_leaf_out> kept(targets.size());
    tbb::parallel_for(tbb::blocked_range<size_t>(0, targets.size(), 4), [&](const tbb::blocked_range<size_t> &rg) {
        std::unique_ptr<leaf_buffer> b(new leaf_buffer);
        for (size_t t = rg.begin(); t != rg.end(); t++) {
            const Coord lc = unpack(targets[t]);
            splat_leaf(p, lc, reach, ws, true, *b);
            bool any = false;
            for (int v = 0; v < LEAF_SIZE && !any; v++) any = b->d[v] < ws;
            if (!any) continue; // entirely outside
            auto &k = kept[t];
            k.d.reset(new float[Leaf::SIZE]);
            k.who.reset(new int32_t[Leaf::SIZE]);
            std::copy(b->d, b->d + Leaf::SIZE, k.d.get());
            std::copy(b->who, b->who + Leaf::SIZE, k.who.get());
            closest_points(p, lc, *b, k.pts);
        }
    });
    if (timing) timing->splat_s = cpu_now() - t0;

    // The band: the kept leaves and, around every leaf with surface points,
    // its 26 neighbours (the band reaches under 8 voxels beyond a point);
    // a neighbour that was not kept lies outside (+ws). Then the distance.
    t0 = cpu_now();
    dense_band band;
    for (size_t t = 0; t < targets.size(); t++) {
        if (!kept[t].d) continue;
        band.key.push_back(targets[t]);
        if (kept[t].pts.empty()) continue;
        const Coord c = unpack(targets[t]);
        for (int i = -1; i <= 1; i++)
            for (int j = -1; j <= 1; j++)
                for (int k = -1; k <= 1; k++)
                    if (i || j || k) band.key.push_back(pack(c.x() + i, c.y() + j, c.z() + k));
    }
    tbb::parallel_sort(band.key.begin(), band.key.end());
    band.key.erase(std::unique(band.key.begin(), band.key.end()), band.key.end());
    const size_t nl = band.size();
    band.phi.resize(nl * Leaf::SIZE);
    std::vector<int32_t> who(nl * Leaf::SIZE);
    std::vector<long> from(nl); // the target each band leaf was kept as, -1: none
    surface_points sp;
    sp.at.assign(nl + 1, 0);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nl, 64), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            auto it = std::lower_bound(targets.begin(), targets.end(), band.key[i]);
            const long t = it != targets.end() && *it == band.key[i] && kept[size_t(it - targets.begin())].d
                               ? long(it - targets.begin())
                               : -1;
            from[i] = t;
            float *phi = band.leaf(i);
            int32_t *w = who.data() + i * Leaf::SIZE;
            if (t < 0) {
                std::fill(phi, phi + Leaf::SIZE, ws);
                std::fill(w, w + Leaf::SIZE, -1);
            } else {
                std::copy(kept[size_t(t)].d.get(), kept[size_t(t)].d.get() + Leaf::SIZE, phi);
                std::copy(kept[size_t(t)].who.get(), kept[size_t(t)].who.get() + Leaf::SIZE, w);
            }
            sp.at[i + 1] = t < 0 ? 0 : uint32_t(kept[size_t(t)].pts.size() / 3);
        }
    });
    for (size_t i = 0; i < nl; i++) sp.at[i + 1] += sp.at[i];
    sp.x.resize(sp.at[nl]), sp.y.resize(sp.at[nl]), sp.z.resize(sp.at[nl]);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nl, 64), [&](const tbb::blocked_range<size_t> &rg) {
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            if (from[i] < 0) continue;
            auto &pts = kept[size_t(from[i])].pts;
            for (size_t k = 0; 3 * k < pts.size(); k++)
                sp.x[sp.at[i] + k] = pts[3 * k], sp.y[sp.at[i] + k] = pts[3 * k + 1],
                                sp.z[sp.at[i] + k] = pts[3 * k + 2];
        }
    });
    kept.clear();
    kept.shrink_to_fit();
    band.link();
    band_distance(band, sp, ws, W);
    if (timing) timing->redistance_s = cpu_now() - t0;

    // dilate, smooth and erode in place; then the tree, once
    t0 = cpu_now();
    const bool track = s.vel != nullptr && vel;
    if (track)
        tbb::parallel_for(tbb::blocked_range<size_t>(0, who.size(), 4096), [&](const tbb::blocked_range<size_t> &rg) {
            for (size_t v = rg.begin(); v != rg.end(); v++)
                if (who[v] >= 0) who[v] = int32_t(p.src[size_t(who[v])]);
        });
    FloatGrid::Ptr grid = band_to_grid(band, h, hw, W, f, track ? &who : nullptr, s.vel, vel);
    if (timing) timing->filter_s = cpu_now() - t0;
    return grid;
}

} // namespace kf_vdb
