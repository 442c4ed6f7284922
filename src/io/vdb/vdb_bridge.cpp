// vdb_bridge.cpp — the OpenVDB bridge (C++17), implementing src/io/vdb_bridge.h.
//
// Every extern "C" entry point runs its body inside guard(), which catches
// every exception and writes "vdb: <what>: <message>" into the caller's
// buffer. Nothing C++ leaves this file.

#include "io/vdb_bridge.h"
#include "aniso_raster.h"
#include "centre_smooth.h"
#include "sphere_raster.h"

#include <openvdb/openvdb.h>
#include <openvdb/io/File.h>
#include <openvdb/points/PointConversion.h>
#include <openvdb/points/PointCount.h>
#include <openvdb/tools/Composite.h>
#include <openvdb/tools/Interpolation.h>
#include <openvdb/tools/LevelSetFilter.h>
#include <openvdb/tools/LevelSetTracker.h>
#include <openvdb/tools/VolumeToMesh.h>
#include <tbb/parallel_for.h>

#include <errno.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#ifndef KERF_VERSION
#define KERF_VERSION "0.1.0"
#endif

using openvdb::FloatGrid;
using openvdb::Vec3R;
using openvdb::Vec3s;
using openvdb::Vec3SGrid;

struct kf_vdb_grid {
    FloatGrid::Ptr ls;
    Vec3SGrid::Ptr vel; // may be null
};

namespace {

// a failure whose message is already worded for the user
struct bridge_error : std::runtime_error {
    using std::runtime_error::runtime_error;
};

std::string fmt(const char *f, ...) __attribute__((format(printf, 1, 2)));
std::string fmt(const char *f, ...) {
    char buf[1024];
    va_list ap;
    va_start(ap, f);
    vsnprintf(buf, sizeof buf, f, ap);
    va_end(ap);
    return buf;
}

// process CPU seconds (all threads)
double cpu_seconds() {
    timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

void set_err(char *err, size_t errlen, const char *what, const char *msg) {
    if (err && errlen) snprintf(err, errlen, "vdb: %s: %s", what, msg);
}

// run body; every exception becomes a message and -1
template <class F> int guard(const char *what, char *err, size_t errlen, F &&body) {
    try {
        openvdb::initialize();
        body();
        return 0;
    } catch (const bridge_error &e) {
        set_err(err, errlen, what, e.what());
    } catch (const openvdb::Exception &e) {
        set_err(err, errlen, what, e.what());
    } catch (const std::bad_alloc &) {
        set_err(err, errlen, what, "out of memory");
    } catch (const std::exception &e) {
        set_err(err, errlen, what, e.what());
    } catch (...) {
        set_err(err, errlen, what, "unknown C++ exception");
    }
    return -1;
}

// positions and radii as the input checks read them
struct particle_list {
    using PosType = Vec3R;
    size_t n;
    const double *xd;
    const float *xf;
    const float *radii; // per-particle or null
    double r;           // uniform radius when radii is null
    double rmin;        // clamp radii up to this (world units), 0: no clamp
    const float *vel;

    size_t size() const { return n; }
    void getPos(size_t i, Vec3R &p) const {
        if (xd) p = Vec3R(xd[3 * i], xd[3 * i + 1], xd[3 * i + 2]);
        else p = Vec3R(xf[3 * i], xf[3 * i + 1], xf[3 * i + 2]);
    }
    double radius(size_t i) const {
        double ri = radii ? double(radii[i]) : r;
        return ri < rmin ? rmin : ri;
    }
};

void apply_filter(FloatGrid &g, kf_vdb_op op, double amount, int iterations) {
    if (op == KF_VDB_OP_NONE) return;
    if ((op == KF_VDB_OP_DILATE || op == KF_VDB_OP_ERODE) && !(amount >= 0 && std::isfinite(amount)))
        throw bridge_error(fmt("dilate/erode amount %g m must be finite and >= 0", amount));
    if (iterations < 0) throw bridge_error(fmt("iterations %d must be >= 0", iterations));
    // An offset within the band is exact on a signed distance: shift every
    // value at once and re-normalise once (LevelSetFilter::offset creeps in
    // half-voxel steps, re-normalising after each)
    const double vox = g.voxelSize()[0], band = double(g.background());
    if ((op == KF_VDB_OP_DILATE || op == KF_VDB_OP_ERODE) && amount > 0 && amount <= band - vox) {
        const float d = float(op == KF_VDB_OP_ERODE ? amount : -amount);
        openvdb::tools::LevelSetTracker<FloatGrid> t(g);
        t.setNormCount(1);
        t.leafs().foreach ([d](FloatGrid::TreeType::LeafNodeType &leaf, size_t) {
            for (auto it = leaf.beginValueOn(); it; ++it) it.setValue(*it + d);
        });
        t.track();
        return;
    }
    openvdb::tools::LevelSetFilter<FloatGrid> f(g);
    // one re-normalisation per step, not OpenVDB's three: the grid comes in
    // as a true distance (sphere_raster re-distances it) and a step moves the
    // surface under a voxel; 2.4x faster, the sphere moves < 0.1 voxel more
    f.setNormCount(1);
    switch (op) {
    case KF_VDB_OP_DILATE:
        if (amount > 0) f.offset(float(-amount));
        break;
    case KF_VDB_OP_ERODE:
        if (amount > 0) f.offset(float(amount));
        break;
    case KF_VDB_OP_MEAN_CURVATURE:
        for (int i = 0; i < iterations; i++) f.meanCurvature();
        break;
    case KF_VDB_OP_GAUSSIAN:
        for (int i = 0; i < iterations; i++) f.gaussian(1);
        break;
    case KF_VDB_OP_LAPLACIAN:
        for (int i = 0; i < iterations; i++) f.laplacian();
        break;
    default: throw bridge_error(fmt("unknown filter op %d", int(op)));
    }
}

// the four promised keys plus the compression actually used
void put_meta(openvdb::MetaMap &m, const kf_vdb_meta *meta, const char *compression) {
    m.insertMeta("shot", openvdb::StringMetadata(meta ? meta->shot : ""));
    m.insertMeta("frame", openvdb::Int32Metadata(meta ? meta->frame : 0));
    m.insertMeta("kerf_version",
                 openvdb::StringMetadata(meta && meta->kerf_version[0] ? meta->kerf_version : KERF_VERSION));
    m.insertMeta("dx", openvdb::DoubleMetadata(meta ? meta->dx : 0.0));
    m.insertMeta("compression", openvdb::StringMetadata(compression));
}

void get_meta(const openvdb::MetaMap &m, kf_vdb_meta *meta) {
    if (!meta) return;
    memset(meta, 0, sizeof *meta);
    if (auto s = m.getMetadata<openvdb::StringMetadata>("shot"))
        snprintf(meta->shot, sizeof meta->shot, "%s", s->value().c_str());
    if (auto s = m.getMetadata<openvdb::StringMetadata>("kerf_version"))
        snprintf(meta->kerf_version, sizeof meta->kerf_version, "%s", s->value().c_str());
    if (auto s = m.getMetadata<openvdb::StringMetadata>("compression"))
        snprintf(meta->compression, sizeof meta->compression, "%s", s->value().c_str());
    if (auto i = m.getMetadata<openvdb::Int32Metadata>("frame")) meta->frame = i->value();
    if (auto d = m.getMetadata<openvdb::DoubleMetadata>("dx")) meta->dx = d->value();
}

// The archive exactly as io::File writes it (seekable, with grid offsets, so
// a reader can load one grid alone), but into memory: io::File writes through
// an std::ofstream that ignores a full disk and leaves a short file, which the
// rename then published ("KeyError: Map", then "Cannot read grid"
// forever). From memory every byte goes through write(2), whose errno counts.
struct memory_archive : openvdb::io::Archive {
    using openvdb::io::Archive::write;
};

// what a failed write says: a full disk in words an artist reads
std::string write_failure(const std::string &path, const char *step, int e) {
    if (e == ENOSPC || e == EDQUOT)
        return fmt("cannot write '%s': no space left on the device (%s)", path.c_str(),
                   e == EDQUOT ? "quota" : "disk full");
    return fmt("cannot write '%s': %s: %s", path.c_str(), step, strerror(e));
}

// all of bytes to a new file at tmp, fsync'ed; throws with errno's reason
void write_file(const std::string &tmp, const std::string &path, const std::string &bytes) {
    int fd = open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) throw bridge_error(write_failure(path, "create", errno));
    const char *p = bytes.data();
    size_t left = bytes.size();
    while (left > 0) {
        ssize_t n = ::write(fd, p, left);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            int e = n < 0 ? errno : EIO;
            close(fd);
            unlink(tmp.c_str());
            throw bridge_error(write_failure(path, "write", e));
        }
        p += n;
        left -= size_t(n);
    }
    if (fsync(fd) != 0 || close(fd) != 0) {
        int e = errno;
        unlink(tmp.c_str());
        throw bridge_error(write_failure(path, "fsync", e));
    }
}

// write grids to path.tmp-<pid>, fsync, rename over path, fsync the directory
void write_atomic(const std::string &path, const openvdb::GridPtrVec &grids, const kf_vdb_meta *meta) {
    if (path.empty()) throw bridge_error("empty output path");
    const bool blosc = openvdb::io::Archive::hasBloscCompression();
    const char *comp = blosc ? "blosc" : "zip";
    openvdb::MetaMap fm;
    put_meta(fm, meta, comp);
    for (auto &g : grids) put_meta(*g, meta, comp);

    std::ostringstream os(std::ios_base::out | std::ios_base::binary);
    try {
        memory_archive a;
        a.setCompression((blosc ? openvdb::io::COMPRESS_BLOSC : openvdb::io::COMPRESS_ZIP) |
                         openvdb::io::COMPRESS_ACTIVE_MASK);
        a.write(os, grids, /*seekable=*/true, fm);
    } catch (const std::exception &e) {
        throw bridge_error(fmt("cannot write '%s': %s", path.c_str(), e.what()));
    }
    if (!os) throw bridge_error(fmt("cannot write '%s': out of memory for the archive", path.c_str()));
    const std::string tmp = path + ".tmp-" + std::to_string(long(getpid()));
    write_file(tmp, path, os.str());
    if (rename(tmp.c_str(), path.c_str()) != 0) {
        int e = errno;
        unlink(tmp.c_str());
        throw bridge_error(write_failure(path, "rename", e));
    }
    std::string dir = path.substr(0, path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/'));
    if (dir.empty()) dir = path[0] == '/' ? "/" : ".";
    int dfd = open(dir.c_str(), O_RDONLY | O_DIRECTORY);
    if (dfd >= 0) {
        fsync(dfd); // best effort: the data is already durable under its final name
        close(dfd);
    }
}

// open for reading with a message that names the path
struct reader {
    openvdb::io::File f;
    explicit reader(const char *path) : f(path ? path : "") {
        if (!path || !*path) throw bridge_error("empty input path");
        try {
            f.open();
        } catch (const std::exception &e) {
            throw bridge_error(fmt("cannot open '%s': %s", path, e.what()));
        }
    }
    ~reader() {
        try {
            if (f.isOpen()) f.close();
        } catch (...) {
        }
    }
};

void mesh_grid(const FloatGrid &g, double iso, double adaptivity, kf_vdb_trimesh *out) {
    if (!(adaptivity >= 0 && adaptivity <= 1)) throw bridge_error(fmt("adaptivity %g outside 0..1", adaptivity));
    std::vector<Vec3s> pts;
    std::vector<openvdb::Vec3I> tri;
    std::vector<openvdb::Vec4I> quad;
    openvdb::tools::volumeToMesh(g, pts, tri, quad, iso, adaptivity, true);

    const size_t nv = pts.size(), nt = tri.size() + 2 * quad.size();
    float *v = (float *)malloc((nv ? nv : 1) * 3 * sizeof(float));
    float *nrm = (float *)malloc((nv ? nv : 1) * 3 * sizeof(float));
    uint32_t *t = (uint32_t *)malloc((nt ? nt : 1) * 3 * sizeof(uint32_t));
    if (!v || !nrm || !t) {
        free(v);
        free(nrm);
        free(t);
        throw std::bad_alloc();
    }
    // normals: gradient of the signed distance by central differences of
    // trilinear samples half a voxel apart (negative inside: points outward);
    // vertices in parallel, each range sampling through its own cached
    // accessor (the values read, and so the normals, are the same)
    const double h = 0.5 * g.voxelSize()[0];
    tbb::parallel_for(tbb::blocked_range<size_t>(0, nv, 2048), [&](const tbb::blocked_range<size_t> &rg) {
        FloatGrid::ConstAccessor acc = g.getConstAccessor();
        openvdb::tools::GridSampler<FloatGrid::ConstAccessor, openvdb::tools::BoxSampler> s(acc, g.transform());
        for (size_t i = rg.begin(); i != rg.end(); i++) {
            const Vec3R p(pts[i]);
            Vec3R d(s.wsSample(p + Vec3R(h, 0, 0)) - s.wsSample(p - Vec3R(h, 0, 0)),
                    s.wsSample(p + Vec3R(0, h, 0)) - s.wsSample(p - Vec3R(0, h, 0)),
                    s.wsSample(p + Vec3R(0, 0, h)) - s.wsSample(p - Vec3R(0, 0, h)));
            double l = d.length();
            if (l > 0) d /= l;
            for (int k = 0; k < 3; k++) {
                v[3 * i + k] = pts[i][k];
                nrm[3 * i + k] = float(d[k]);
            }
        }
    });
    // volumeToMesh winds faces clockwise seen from outside for a level set
    // (checked by the tests' signed volume); reverse to counter-clockwise
    size_t j = 0;
    for (auto &q : tri) {
        t[3 * j] = q[0];
        t[3 * j + 1] = q[2];
        t[3 * j + 2] = q[1];
        j++;
    }
    for (auto &q : quad) {
        t[3 * j] = q[0];
        t[3 * j + 1] = q[2];
        t[3 * j + 2] = q[1];
        j++;
        t[3 * j] = q[0];
        t[3 * j + 1] = q[3];
        t[3 * j + 2] = q[2];
        j++;
    }
    out->nverts = nv;
    out->ntris = nt;
    out->verts = v;
    out->normals = nrm;
    out->tris = t;
}

FloatGrid::Ptr find_levelset(openvdb::io::File &f, const char *path, const char *name) {
    if (!f.hasGrid(name)) throw bridge_error(fmt("'%s' has no grid named '%s'", path, name));
    auto base = f.readGrid(name);
    auto g = openvdb::gridPtrCast<FloatGrid>(base);
    if (!g)
        throw bridge_error(fmt("'%s': grid '%s' is %s, not a float level set", path, name, base->valueType().c_str()));
    if (g->getGridClass() != openvdb::GRID_LEVEL_SET)
        throw bridge_error(fmt("'%s': grid '%s' is a %s, not a level set", path, name,
                               openvdb::GridBase::gridClassToString(g->getGridClass()).c_str()));
    return g;
}

} // namespace

extern "C" {

void kf_vdb_surface_params_default(kf_vdb_surface_params *p) {
    memset(p, 0, sizeof *p);
    p->radius_factor = KF_VDB_RADIUS_FACTOR;
    p->half_width = 3.0;
    p->name = "surface";
}

double kf_vdb_surface_offset(const kf_vdb_surface_params *p) {
    const double h = p->spacing, r = p->radius > 0 ? p->radius : (p->radius_factor > 0 ? p->radius_factor : 1) * h;
    if (p->kernel != KF_VDB_KERNEL_ANISOTROPIC) return r - 0.5 * h;
    const double t = p->thickness > 0 ? p->thickness : 0.5 * h, N = 3.14159265358979323846 * (r / h) * (r / h);
    return t - h / (N + 1);
}

int kf_vdb_levelset_from_particles(size_t n, const double *xd, const float *xf, const float *radii, const float *vel,
                                   const kf_vdb_surface_params *pp, kf_vdb_grid **out, kf_vdb_surface_stats *stats,
                                   char *err, size_t errlen) {
    if (out) *out = nullptr;
    return guard("surfacing", err, errlen, [&] {
        auto t0 = std::chrono::steady_clock::now();
        kf_vdb_surface_params p;
        kf_vdb_surface_params_default(&p);
        if (pp) p = *pp;
        if (!out) throw bridge_error("no output handle");
        if ((xd == nullptr) == (xf == nullptr)) throw bridge_error("give exactly one of double or float positions");
        if (n == 0) throw bridge_error("no particles to surface");
        const double factor = p.radius_factor > 0 ? p.radius_factor : KF_VDB_RADIUS_FACTOR;
        double r = p.radius > 0 ? p.radius : factor * p.spacing;
        if (!radii && !(r > 0)) throw bridge_error("particle spacing (or a radius) must be > 0");
        double voxel = p.voxel > 0 ? p.voxel : (p.spacing > 0 ? 0.5 * p.spacing : 0.5 * r);
        if (!(voxel > 0 && std::isfinite(voxel))) throw bridge_error(fmt("voxel size %g must be > 0", voxel));
        const double hw = p.half_width > 0 ? p.half_width : 3.0;
        if (hw < 1.0) throw bridge_error(fmt("half width %g voxels must be >= 1", hw));

        // never let OpenVDB drop a particle silently: check every position
        // and radius first, and clamp or refuse radii under 1.5 voxels
        particle_list pl{n, xd, xf, radii, r, 0.0, vel};
        // OpenVDB skips a sphere when (1 / dx) * r < Rmin: test exactly that,
        // and clamp to a radius that passes it
        const double inv_dx = 1 / voxel;
        double rmin = KF_VDB_RMIN_VOXELS * voxel;
        while (inv_dx * rmin < KF_VDB_RMIN_VOXELS) rmin = std::nextafter(rmin, INFINITY);
        size_t nsmall = 0, nbad = 0, first_bad = 0;
        double rlo = INFINITY;
        for (size_t i = 0; i < n; i++) {
            Vec3R x;
            pl.getPos(i, x);
            double ri = pl.radius(i);
            if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]) || !std::isfinite(ri) ||
                !(ri > 0)) {
                if (!nbad++) first_bad = i;
                continue;
            }
            if (inv_dx * ri < KF_VDB_RMIN_VOXELS) nsmall++;
            if (ri < rlo) rlo = ri;
        }
        if (nbad)
            throw bridge_error(
                fmt("%zu particles have a non-finite position or a radius <= 0 (first: #%zu)", nbad, first_bad));
        if (nsmall && !p.clamp_small)
            throw bridge_error(fmt("%zu of %zu particles have radius under %.1f voxels (smallest %g m, "
                                   "voxel %g m, need >= %g m); OpenVDB would drop them: raise the radius, "
                                   "shrink the voxel or set clamp_small",
                                   nsmall, n, KF_VDB_RMIN_VOXELS, rlo, voxel, rmin));
        if (nsmall) pl.rmin = rmin;

        auto h = new kf_vdb_grid;
        std::unique_ptr<kf_vdb_grid> hold(h);
        kf_vdb::sphere_set ss{n, xd, xf, radii, r, nsmall ? rmin : 0.0, vel};
        // jittered centres averaged with their neighbours (centre_smooth.h):
        // a flat face moves in by shift, so the erosion that puts the
        // surface back on the material is smaller by as much (a dilation
        // where the erosion was smaller than the shift)
        std::vector<float> averaged;
        size_t n_kept = 0;
        double cpu_average = 0;
        if (!(p.average >= 0 && p.average <= 1)) throw bridge_error(fmt("average %g must be in 0..1", p.average));
        const bool aniso = p.kernel == KF_VDB_KERNEL_ANISOTROPIC;
        if (p.kernel != KF_VDB_KERNEL_SPHERES && !aniso) throw bridge_error(fmt("unknown kernel %d", int(p.kernel)));
        if (p.average > 0 && !aniso) {
            const double spacing = p.spacing > 0 ? p.spacing : r / factor;
            const double R = p.average_radius > 0 ? p.average_radius : 2 * spacing;
            // particles deeper than their sphere plus the averaging's reach
            // keep their place (no averaged neighbour's sphere comes near theirs)
            double rmax = r;
            for (size_t i = 0; radii && i < n; i++) rmax = std::max(rmax, double(radii[i]));
            const double ca = cpu_seconds();
            averaged = kf_vdb::smooth_centres(n, xd, xf, p.average, R, spacing, rmax + R, &n_kept);
            cpu_average = cpu_seconds() - ca;
            ss.xd = nullptr;
            ss.xf = averaged.data();
            const double shift = kf_vdb::shift_depth(p.average, R, spacing);
            p.erode -= shift;
            if (p.erode < 0) p.dilate -= p.erode, p.erode = 0;
        }
        kf_vdb::raster_timing rt{};
        double wall[5] = {0, 0, 0, 0, 0}; // the anisotropic phases' wall seconds
        if (hw > 6) throw bridge_error(fmt("half width %g voxels must be <= 6", hw));
        // dilate, mean-curvature smoothing and erode run on the band before
        // it becomes a tree when the band has room for the shifts (within 6
        // voxels); other filters, and larger shifts, through LevelSetFilter
        const bool amounts_ok = std::isfinite(p.dilate) && std::isfinite(p.erode) && p.dilate >= 0 && p.erode >= 0;
        const bool on_band = amounts_ok && (p.smooth == KF_VDB_OP_NONE || p.smooth == KF_VDB_OP_MEAN_CURVATURE) &&
                             p.smooth_iterations >= 0 && hw + (p.dilate + p.erode) / voxel <= 6;
        // the flattening's neighbourhoods: the mean over 3.75 spacings (5
        // voxels at 0.75), the normals over 1.2 times that
        if (p.flatten < 0) throw bridge_error(fmt("flatten %d passes must be >= 0", p.flatten));
        const double spacing_f = p.spacing > 0 ? p.spacing : r / factor;
        const double fr = p.flatten_radius > 0 ? p.flatten_radius : 3.75 * spacing_f;
        kf_vdb::band_filter bf{p.dilate,  p.erode, p.smooth == KF_VDB_OP_MEAN_CURVATURE ? p.smooth_iterations : 0,
                               p.flatten, fr,      1.2 * fr};
        if (aniso) {
            // the discs' radius is the radius; their neighbourhood the averaging's
            if (!(p.spacing > 0)) throw bridge_error("anisotropic kernels need the particle spacing");
            if (radii) throw bridge_error("anisotropic kernels take one radius for all particles");
            kf_vdb::aniso_params ap{p.spacing, r, p.average_radius > 0 ? p.average_radius : 3 * p.spacing,
                                    p.thickness > 0 ? p.thickness : 0.5 * p.spacing,
                                    p.anisotropy > 0 ? p.anisotropy : 8};
            kf_vdb::aniso_timing at{};
            h->ls = kf_vdb::rasterise_anisotropic(n, xd, xf, vel, ap, voxel, hw, on_band ? &bf : nullptr,
                                                  vel ? &h->vel : nullptr, &at);
            cpu_average = at.shape_s, n_kept = at.n_deep;
            rt.sort_s = at.sort_s, rt.splat_s = at.splat_s, rt.redistance_s = at.redistance_s,
            rt.filter_s = at.filter_s;
            wall[0] = at.shape_w, wall[1] = at.sort_w, wall[2] = at.splat_w, wall[3] = at.redistance_w,
            wall[4] = at.filter_w;
        } else {
            h->ls = kf_vdb::rasterise_spheres(ss, voxel, hw, on_band ? &bf : nullptr, vel ? &h->vel : nullptr, &rt);
        }
        h->ls->setName(p.name && *p.name ? p.name : "surface");
        if (h->vel) {
            h->vel->setName(h->ls->getName() == "surface" ? std::string("vel") : h->ls->getName() + "_vel");
            h->vel->setVectorType(openvdb::VEC_CONTRAVARIANT_RELATIVE);
        }
        const size_t dropped = 0; // every sphere is rasterised (radii clamped above)
        auto t1 = std::chrono::steady_clock::now();
        const double c1 = cpu_seconds();

        if (!on_band) {
            apply_filter(*h->ls, KF_VDB_OP_DILATE, p.dilate, 0);
            apply_filter(*h->ls, p.smooth, 0, p.smooth_iterations);
            apply_filter(*h->ls, KF_VDB_OP_ERODE, p.erode, 0);
            if (h->vel) h->vel->tree().topologyIntersection(h->ls->tree()); // the filters moved the band
        }

        if (stats) {
            stats->n_in = n;
            stats->n_small = nsmall;
            stats->n_dropped = dropped;
            stats->r_min = nsmall ? rmin : rlo;
            stats->active_voxels = h->ls->activeVoxelCount();
            stats->seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
            stats->seconds_raster = std::chrono::duration<double>(t1 - t0).count();
            stats->seconds_filter = std::chrono::duration<double>(std::chrono::steady_clock::now() - t1).count();
            stats->cpu_average = cpu_average;
            stats->n_average_kept = n_kept;
            stats->cpu_sort = rt.sort_s;
            stats->cpu_splat = rt.splat_s;
            stats->cpu_redistance = rt.redistance_s;
            stats->cpu_filter = rt.filter_s + cpu_seconds() - c1;
            stats->wall_average = wall[0], stats->wall_sort = wall[1], stats->wall_splat = wall[2];
            stats->wall_redistance = wall[3];
            stats->wall_filter = aniso ? wall[4] + stats->seconds_filter : 0;
        }
        *out = hold.release();
    });
}

int kf_vdb_union(kf_vdb_grid *a, kf_vdb_grid *b, char *err, size_t errlen) {
    return guard("union", err, errlen, [&] {
        if (!a || !b) throw bridge_error("no grid");
        if (a->ls->voxelSize() != b->ls->voxelSize())
            throw bridge_error(fmt("voxel sizes differ (%g and %g m)", a->ls->voxelSize()[0], b->ls->voxelSize()[0]));
        openvdb::tools::csgUnion(*a->ls, *b->ls);
        if (a->vel && b->vel) {
            // b's velocities where a has none
            auto acc = a->vel->getAccessor();
            for (auto it = b->vel->cbeginValueOn(); it; ++it)
                if (!acc.isValueOn(it.getCoord())) acc.setValue(it.getCoord(), *it);
            a->vel->tree().topologyIntersection(a->ls->tree());
        }
    });
}

int kf_vdb_filter(kf_vdb_grid *g, kf_vdb_op op, double amount, int iterations, char *err, size_t errlen) {
    return guard("filter", err, errlen, [&] {
        if (!g) throw bridge_error("no grid");
        apply_filter(*g->ls, op, amount, iterations);
    });
}

int kf_vdb_set_name(kf_vdb_grid *g, const char *name, char *err, size_t errlen) {
    return guard("set name", err, errlen, [&] {
        if (!g || !name || !*name) throw bridge_error("no grid or empty name");
        g->ls->setName(name);
        if (g->vel) g->vel->setName(std::string(name) == "surface" ? std::string("vel") : std::string(name) + "_vel");
    });
}

const char *kf_vdb_name(const kf_vdb_grid *g) { return g ? g->ls->getName().c_str() : ""; }
double kf_vdb_voxel_size(const kf_vdb_grid *g) { return g ? g->ls->voxelSize()[0] : 0.0; }
size_t kf_vdb_active_voxels(const kf_vdb_grid *g) { return g ? size_t(g->ls->activeVoxelCount()) : 0; }

int kf_vdb_write(const char *path, kf_vdb_grid *const *grids, int ngrids, const kf_vdb_meta *meta, char *err,
                 size_t errlen) {
    return guard("write", err, errlen, [&] {
        if (!path) throw bridge_error("no output path");
        if (ngrids < 0 || (ngrids > 0 && !grids)) throw bridge_error("bad grid list");
        openvdb::GridPtrVec v;
        for (int i = 0; i < ngrids; i++) {
            if (!grids[i]) throw bridge_error(fmt("grid %d is NULL", i));
            v.push_back(grids[i]->ls);
            if (grids[i]->vel) v.push_back(grids[i]->vel);
        }
        write_atomic(path, v, meta);
    });
}

const char *const kf_vdb_point_float_names[KF_VDB_PT_FLOATS] = {"Jp", "von_mises", "J", "plastic_strain"};

int kf_vdb_points_write(const char *path, size_t n, const float *x, const float *v, const int32_t *material,
                        const float *const *floats, double voxel, const kf_vdb_meta *meta, char *err, size_t errlen) {
    namespace pts = openvdb::points;
    return guard("points write", err, errlen, [&] {
        if (!path) throw bridge_error("no output path");
        if (n && !x) throw bridge_error("no positions");
        std::vector<Vec3s> P(n);
        for (size_t i = 0; i < n; i++) {
            P[i] = Vec3s(x[3 * i], x[3 * i + 1], x[3 * i + 2]);
            if (!std::isfinite(P[i][0]) || !std::isfinite(P[i][1]) || !std::isfinite(P[i][2]))
                throw bridge_error(fmt("particle #%zu has a non-finite position", i));
        }
        pts::PointAttributeVector<Vec3s> Pw(P);
        if (!(voxel > 0)) voxel = n ? pts::computeVoxelSize(Pw, 8) : 0.1;
        auto xform = openvdb::math::Transform::createLinearTransform(voxel);
        auto idx = openvdb::tools::createPointIndexGrid<openvdb::tools::PointIndexGrid>(Pw, *xform);
        auto grid = pts::createPointDataGrid<pts::NullCodec, pts::PointDataGrid>(*idx, Pw, *xform);
        grid->setName("points");
        auto &tree = grid->tree();
        if (v) {
            std::vector<Vec3s> V(n);
            for (size_t i = 0; i < n; i++) V[i] = Vec3s(v[3 * i], v[3 * i + 1], v[3 * i + 2]);
            pts::appendAttribute<Vec3s>(tree, "v");
            pts::populateAttribute(tree, idx->tree(), "v", pts::PointAttributeVector<Vec3s>(V));
        }
        if (material) {
            std::vector<int32_t> M(material, material + n);
            pts::appendAttribute<int32_t>(tree, "material");
            pts::populateAttribute(tree, idx->tree(), "material", pts::PointAttributeVector<int32_t>(M));
        }
        for (int a = 0; floats && a < KF_VDB_PT_FLOATS; a++) {
            if (!floats[a]) continue;
            const char *name = kf_vdb_point_float_names[a];
            std::vector<float> F(floats[a], floats[a] + n);
            pts::appendAttribute<float>(tree, name);
            pts::populateAttribute(tree, idx->tree(), name, pts::PointAttributeVector<float>(F));
        }
        write_atomic(path, openvdb::GridPtrVec{grid}, meta);
    });
}

int kf_vdb_points_read(const char *path, kf_vdb_points *out, char *err, size_t errlen) {
    namespace pts = openvdb::points;
    if (out) memset(out, 0, sizeof *out);
    int rc = guard("points read", err, errlen, [&] {
        if (!out) throw bridge_error("no output");
        reader r(path);
        pts::PointDataGrid::Ptr grid;
        auto all = r.f.getGrids();
        for (auto &b : *all)
            if ((grid = openvdb::gridPtrCast<pts::PointDataGrid>(b))) break;
        if (!grid) throw bridge_error(fmt("'%s' has no point data grid", path));
        const auto &tree = grid->tree();
        const size_t n = size_t(pts::pointCount(tree));
        auto leaf0 = tree.cbeginLeaf();
        const bool hv = leaf0 && leaf0->hasAttribute("v"), hm = leaf0 && leaf0->hasAttribute("material");
        bool hf[KF_VDB_PT_FLOATS];
        out->n = n;
        out->x = (float *)malloc((n ? n : 1) * 3 * sizeof(float));
        if (hv) out->v = (float *)malloc((n ? n : 1) * 3 * sizeof(float));
        if (hm) out->material = (int32_t *)malloc((n ? n : 1) * sizeof(int32_t));
        if (!out->x || (hv && !out->v) || (hm && !out->material)) throw std::bad_alloc();
        for (int a = 0; a < KF_VDB_PT_FLOATS; a++) {
            hf[a] = leaf0 && leaf0->hasAttribute(kf_vdb_point_float_names[a]);
            if (hf[a] && !(out->f[a] = (float *)malloc((n ? n : 1) * sizeof(float)))) throw std::bad_alloc();
        }
        size_t k = 0;
        for (auto leaf = tree.cbeginLeaf(); leaf; ++leaf) {
            pts::AttributeHandle<Vec3s> Ph(leaf->constAttributeArray("P"));
            std::unique_ptr<pts::AttributeHandle<Vec3s>> Vh;
            std::unique_ptr<pts::AttributeHandle<int32_t>> Mh;
            std::unique_ptr<pts::AttributeHandle<float>> Fh[KF_VDB_PT_FLOATS];
            if (hv) Vh.reset(new pts::AttributeHandle<Vec3s>(leaf->constAttributeArray("v")));
            if (hm) Mh.reset(new pts::AttributeHandle<int32_t>(leaf->constAttributeArray("material")));
            for (int a = 0; a < KF_VDB_PT_FLOATS; a++)
                if (hf[a])
                    Fh[a].reset(
                        new pts::AttributeHandle<float>(leaf->constAttributeArray(kf_vdb_point_float_names[a])));
            for (auto it = leaf->beginIndexOn(); it; ++it) {
                if (k >= n) throw bridge_error("point count mismatch");
                const Vec3R w = grid->transform().indexToWorld(Ph.get(*it) + it.getCoord().asVec3d());
                for (int c = 0; c < 3; c++) out->x[3 * k + c] = float(w[c]);
                if (Vh) {
                    Vec3s vv = Vh->get(*it);
                    for (int c = 0; c < 3; c++) out->v[3 * k + c] = vv[c];
                }
                if (Mh) out->material[k] = Mh->get(*it);
                for (int a = 0; a < KF_VDB_PT_FLOATS; a++)
                    if (Fh[a]) out->f[a][k] = Fh[a]->get(*it);
                k++;
            }
        }
        if (k != n) throw bridge_error("point count mismatch");
    });
    if (rc && out) kf_vdb_points_free(out);
    return rc;
}

void kf_vdb_points_free(kf_vdb_points *p) {
    if (!p) return;
    free(p->x);
    free(p->v);
    free(p->material);
    for (int a = 0; a < KF_VDB_PT_FLOATS; a++) free(p->f[a]);
    memset(p, 0, sizeof *p);
}

int kf_vdb_mesh(const kf_vdb_grid *g, double isovalue, double adaptivity, kf_vdb_trimesh *out, char *err,
                size_t errlen) {
    if (out) memset(out, 0, sizeof *out);
    return guard("mesh", err, errlen, [&] {
        if (!g || !out) throw bridge_error("no grid or no output");
        mesh_grid(*g->ls, isovalue, adaptivity, out);
    });
}

void kf_vdb_mesh_free(kf_vdb_trimesh *m) {
    if (!m) return;
    free(m->verts);
    free(m->normals);
    free(m->tris);
    memset(m, 0, sizeof *m);
}

int kf_vdb_info(const char *path, kf_vdb_file_info *info, char *err, size_t errlen) {
    if (info) memset(info, 0, sizeof *info);
    return guard("info", err, errlen, [&] {
        if (!info) throw bridge_error("no output");
        reader r(path);
        auto grids = r.f.readAllGridMetadata();
        for (auto &g : *grids) {
            if (info->ngrids >= KF_VDB_MAX_GRIDS) break;
            auto &e = info->grids[info->ngrids++];
            snprintf(e.name, sizeof e.name, "%s", g->getName().c_str());
            snprintf(e.cls, sizeof e.cls, "%s", openvdb::GridBase::gridClassToString(g->getGridClass()).c_str());
            snprintf(e.type, sizeof e.type, "%s", g->valueType().c_str());
        }
        get_meta(*r.f.getMetadata(), &info->meta);
    });
}

int kf_vdb_read_levelset(const char *path, const char *name, kf_vdb_grid **out, kf_vdb_meta *meta, char *err,
                         size_t errlen) {
    if (out) *out = nullptr;
    return guard("read", err, errlen, [&] {
        if (!out) throw bridge_error("no output handle");
        reader r(path);
        const char *nm = name && *name ? name : "surface";
        std::unique_ptr<kf_vdb_grid> h(new kf_vdb_grid);
        h->ls = find_levelset(r.f, path, nm);
        get_meta(*r.f.getMetadata(), meta);
        *out = h.release();
    });
}

int kf_vdb_sample(const kf_vdb_grid *g, const double *xyz, size_t n, double *out, char *err, size_t errlen) {
    return guard("sample", err, errlen, [&] {
        if (!g || (n && (!xyz || !out))) throw bridge_error("no grid or no arrays");
        openvdb::tools::GridSampler<FloatGrid, openvdb::tools::BoxSampler> s(*g->ls);
        for (size_t i = 0; i < n; i++) out[i] = s.wsSample(Vec3R(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]));
    });
}

int kf_vdb_read_vec3_sample(const char *path, const char *name, const double *xyz, size_t n, double *out, char *err,
                            size_t errlen) {
    return guard("read", err, errlen, [&] {
        if (n && (!xyz || !out)) throw bridge_error("no arrays");
        reader r(path);
        const char *nm = name && *name ? name : "vel";
        if (!r.f.hasGrid(nm)) throw bridge_error(fmt("'%s' has no grid named '%s'", path, nm));
        auto base = r.f.readGrid(nm);
        auto g = openvdb::gridPtrCast<openvdb::Vec3SGrid>(base);
        if (!g) throw bridge_error(fmt("'%s': grid '%s' is %s, not vec3s", path, nm, base->valueType().c_str()));
        openvdb::tools::GridSampler<openvdb::Vec3SGrid, openvdb::tools::BoxSampler> s(*g);
        for (size_t i = 0; i < n; i++) {
            openvdb::Vec3s v = s.wsSample(Vec3R(xyz[3 * i], xyz[3 * i + 1], xyz[3 * i + 2]));
            for (int a = 0; a < 3; a++) out[3 * i + a] = v[a];
        }
    });
}

int kf_vdb_read_surface_mesh(const char *path, double adaptivity, kf_vdb_trimesh *out, kf_vdb_meta *meta, char *err,
                             size_t errlen) {
    if (out) memset(out, 0, sizeof *out);
    return guard("read surface", err, errlen, [&] {
        if (!out) throw bridge_error("no output");
        reader r(path);
        auto g = find_levelset(r.f, path, "surface");
        get_meta(*r.f.getMetadata(), meta);
        mesh_grid(*g, 0.0, adaptivity, out);
    });
}

void kf_vdb_free(kf_vdb_grid *g) { delete g; }

} // extern "C"
