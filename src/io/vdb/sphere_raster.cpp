// sphere_raster.cpp — particles to a narrow-band level set (see sphere_raster.h).
#include "sphere_raster.h"

#include <openvdb/tools/ChangeBackground.h>
#include <openvdb/tools/FastSweeping.h>
#include <openvdb/tools/Morphology.h>
#include <openvdb/tools/Prune.h>
#include <openvdb/tools/SignedFloodFill.h>
#include <openvdb/tree/LeafManager.h>

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>
#include <tbb/parallel_sort.h>

#include <algorithm>
#include <ctime>
#include <cmath>
#include <cstdint>
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
using MaskLeaf = openvdb::MaskTree::LeafNodeType;

constexpr int LOG2 = Leaf::LOG2DIM; // 3: 8^3-voxel leaves
constexpr int DIM = Leaf::DIM;
constexpr int64_t BIAS = int64_t(1) << 20; // leaf coordinates in +/- 2^20 pack into 21 bits

// process CPU seconds (all threads): honest when other work shares the machine
double cpu_now()
{
    timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

uint64_t pack(int64_t lx, int64_t ly, int64_t lz)
{
    return (uint64_t(lx + BIAS) << 42) | (uint64_t(ly + BIAS) << 21) | uint64_t(lz + BIAS);
}

Coord unpack(uint64_t k)
{
    const uint64_t m = (uint64_t(1) << 21) - 1;
    return Coord(int(int64_t((k >> 42) & m) - BIAS), int(int64_t((k >> 21) & m) - BIAS), int(int64_t(k & m) - BIAS));
}

// particles in leaf-bin order, in index space (voxel units), structure of arrays
struct sorted_particles {
    std::vector<float> x, y, z, r;
    std::vector<uint32_t> src;     // original index (for velocities)
    std::vector<uint64_t> bin_key; // distinct bins, ascending
    std::vector<uint32_t> bin_at;  // (nbins + 1) first particle of each bin
    float rmax = 0;

    // [first, last) of the bin with this key, or an empty range
    std::pair<uint32_t, uint32_t> bin(uint64_t key) const
    {
        auto it = std::lower_bound(bin_key.begin(), bin_key.end(), key);
        if (it == bin_key.end() || *it != key) return {0, 0};
        size_t b = size_t(it - bin_key.begin());
        return {bin_at[b], bin_at[b + 1]};
    }
};

sorted_particles sort_particles(const sphere_set &s, double h)
{
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
    return p;
}

// one output leaf: the union-of-spheres distance (voxel units, clamped to
// the band w) of every particle in the bins within `reach` leaves
struct leaf_buffer {
    float d[Leaf::SIZE];
    int32_t who[Leaf::SIZE]; // closest particle (sorted index), -1: none
};

void splat_leaf(const sorted_particles &p, Coord leaf, int reach, float w, bool track, leaf_buffer &b)
{
    std::fill(b.d, b.d + Leaf::SIZE, w);
    if (track) std::fill(b.who, b.who + Leaf::SIZE, -1);
    const int ox = leaf.x() << LOG2, oy = leaf.y() << LOG2, oz = leaf.z() << LOG2;
    for (int i = -reach; i <= reach; i++)
        for (int j = -reach; j <= reach; j++)
            for (int k = -reach; k <= reach; k++) {
                auto rg = p.bin(pack(leaf.x() + i, leaf.y() + j, leaf.z() + k));
                for (uint32_t q = rg.first; q < rg.second; q++) {
                    const float px = p.x[q], py = p.y[q], pz = p.z[q], R = p.r[q], ext = R + w, ext2 = ext * ext;
                    const int x0 = std::max(ox, int(std::ceil(px - ext))), x1 = std::min(ox + DIM - 1, int(std::floor(px + ext)));
                    const int y0 = std::max(oy, int(std::ceil(py - ext))), y1 = std::min(oy + DIM - 1, int(std::floor(py + ext)));
                    const int z0 = std::max(oz, int(std::ceil(pz - ext))), z1 = std::min(oz + DIM - 1, int(std::floor(pz + ext)));
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
}

} // namespace

FloatGrid::Ptr rasterise_spheres(const sphere_set &s, double h, double hw, Vec3SGrid::Ptr *vel, raster_timing *timing)
{
    double t0 = cpu_now();
    const float bg = float(hw * h);
    // Spheres are splatted only SPLAT voxels beyond their radius: exact
    // distances near the zero crossing and the right sign everywhere inside
    // is all the re-distancing below needs (wider splats cost the cube).
    const float ws = float(std::min(hw, 1.5));
    sorted_particles p = sort_particles(s, h);
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
    // mark the outside voxels within a voxel of the zero crossing in `near`
    // (inside ones will not do: between particles the union's distance
    // never falls below -r, so |d| < 1 would take in the whole interior)
    const bool track = s.vel != nullptr;
    std::vector<Leaf *> leaves(targets.size(), nullptr);
    std::vector<MaskLeaf *> near(targets.size(), nullptr);
    std::vector<VelLeaf *> vleaves(track ? targets.size() : 0, nullptr);
    tbb::parallel_for(tbb::blocked_range<size_t>(0, targets.size(), 4), [&](const tbb::blocked_range<size_t> &rg) {
        std::unique_ptr<leaf_buffer> b(new leaf_buffer);
        for (size_t t = rg.begin(); t != rg.end(); t++) {
            const Coord lc = unpack(targets[t]);
            splat_leaf(p, lc, reach, ws, track, *b);
            bool any = false;
            for (int v = 0; v < Leaf::SIZE && !any; v++) any = b->d[v] < ws;
            if (!any) continue; // entirely outside: background
            const Coord origin(lc.x() << LOG2, lc.y() << LOG2, lc.z() << LOG2);
            auto *leaf = new Leaf(origin, bg, false);
            auto *mask = new MaskLeaf(origin, false, false);
            VelLeaf *vl = track ? new VelLeaf(origin, Vec3s(0.f), false) : nullptr;
            for (int v = 0; v < Leaf::SIZE; v++) {
                const float d = b->d[v];
                if (d >= ws) continue;
                leaf->setValueOn(v, d <= -ws ? -bg : d * float(h));
                if (d >= 0 && d < 1) mask->setValueOn(v); // just outside: a crossing is within a voxel
                if (vl && b->who[v] >= 0) {
                    const size_t i = p.src[size_t(b->who[v])];
                    vl->setValueOn(v, Vec3s(s.vel[3 * i], s.vel[3 * i + 1], s.vel[3 * i + 2]));
                }
            }
            leaves[t] = leaf;
            if (mask->isEmpty()) delete mask;
            else near[t] = mask;
            if (vl) vleaves[t] = vl;
        }
    });
    auto grid = openvdb::createLevelSet<FloatGrid>(h, float(hw));
    auto &tree = grid->tree();
    for (Leaf *l : leaves)
        if (l) tree.addLeaf(l);
    openvdb::MaskTree band(false);
    for (MaskLeaf *l : near)
        if (l) band.addLeaf(l);
    if (timing) timing->splat_s = cpu_now() - t0;

    // Inside, the union of spheres of radius under the band is no distance
    // (it never falls below -r): re-distance by fast sweeping from the zero
    // crossing over the voxels within the band of it, then keep |phi| < band.
    t0 = cpu_now();
    openvdb::tools::dilateActiveValues(band, int(std::ceil(hw)) + 1, openvdb::tools::NN_FACE_EDGE_VERTEX,
                                       openvdb::tools::IGNORE_TILES);
    openvdb::tools::signedFloodFill(tree); // inactive values get their side's sign
    tree.topologyUnion(band);
    tree.topologyIntersection(band);
    FloatGrid::Ptr sdf = openvdb::tools::sdfToSdf(*grid, 0.0f, 1);
    sdf->setTransform(grid->transform().copy());
    sdf->setGridClass(openvdb::GRID_LEVEL_SET);
    {
        openvdb::tree::LeafManager<FloatTree> lm(sdf->tree());
        lm.foreach([bg](Leaf &leaf, size_t) {
            for (auto it = leaf.beginValueOn(); it; ++it) {
                const float v = *it;
                if (!std::isfinite(v)) it.setValueOff(), it.setValue(v > 0 ? bg : -bg);
                else if (v >= bg) it.setValueOff(), it.setValue(bg);
                else if (v <= -bg) it.setValueOff(), it.setValue(-bg);
            }
        });
    }
    // fast sweeping leaves its own (wider) background; the filters' band follows it
    openvdb::tools::changeLevelSetBackground(sdf->tree(), bg);
    openvdb::tools::signedFloodFill(sdf->tree());
    openvdb::tools::pruneLevelSet(sdf->tree());
    if (timing) timing->redistance_s = cpu_now() - t0;

    if (track && vel) {
        auto vg = Vec3SGrid::create(Vec3s(0.f));
        vg->setTransform(grid->transform().copy());
        for (VelLeaf *l : vleaves)
            if (l) vg->tree().addLeaf(l);
        vg->tree().topologyIntersection(sdf->tree());
        openvdb::tools::prune(vg->tree());
        *vel = vg;
    } else {
        for (VelLeaf *l : vleaves) delete l;
    }
    return sdf;
}

} // namespace kf_vdb
