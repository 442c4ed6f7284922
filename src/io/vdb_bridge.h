/* vdb_bridge.h — the OpenVDB bridge: kerf's only C++ (src/io/vdb/ *.cpp), seen from C.
 *
 * No C++ type crosses this header. Every function catches every exception at
 * the boundary and turns it into a message in the caller's buffer
 * (char *err, size_t errlen; err may be NULL), and returns 0 or -1.
 * Arrays handed out by the bridge (meshes, points) are freed with the
 * bridge's own free functions.
 *
 * Surfacing convention (kf_vdb_levelset_from_particles):
 *   Each particle becomes a sphere of radius r; the level set is their union.
 *   Default r = KF_VDB_RADIUS_FACTOR x spacing (1.0 x spacing) on a voxel of
 *   spacing / 2 (r = 2 voxels). For particles seeded on a lattice inside a
 *   shape, the zero crossing lies on average r - spacing/2 beyond the shape's
 *   boundary: in any direction the outermost centre sits on average half a
 *   spacing inside it (the lattice's staircase) and its sphere reaches r
 *   beyond. So the default surface is spacing/2 proud of the material;
 *   erode by r - spacing/2 (the `erode` field) to put it on the boundary.
 *   The staircase leaves bumps of about +/- spacing/2 (tests/test_vdb.c
 *   measures them); smoothing (dilate, smooth, erode) flattens them.
 *   Spheres under 1.5 voxels can miss every voxel centre (OpenVDB's own
 *   rasteriser silently skips them): by default such particles are an error
 *   (message gives the count and the smallest radius); with clamp_small they
 *   are raised to 1.5 voxels and counted in stats.n_small.
 *   The spheres are rasterised by the bridge (io/vdb/sphere_raster.cpp: leaf
 *   bins, tbb, exact distances within a voxel outside the union), made a
 *   true signed distance in a band of half_width voxels (at most 6) from
 *   the spheres' closest points and crease points (io/vdb/band_distance.h;
 *   no fast sweeping, no iteration), and filtered on that band before it
 *   becomes a tree: dilate and erode are exact shifts, mean-curvature steps
 *   are OpenVDB's scheme and time step without its per-step re-normalising
 *   and re-banding (io/vdb/band_smooth.h). Gaussian or Laplacian smoothing,
 *   and shifts that leave no room in 6 voxels, go through OpenVDB's
 *   LevelSetFilter afterwards. Where particles are denser than the voxels
 *   (a voxel or more each), those buried deeper than their splat reaches
 *   are given only their nearest voxel (io/vdb/buried_particles.h): the
 *   level set is the same; the velocity of a voxel deep inside may then
 *   come from a particle near it rather than the nearest one.
 *
 * Files: the level set grid is written as class "level set" under its name
 * (default "surface"); a particle-velocity grid "vel" (vec3s, closest
 * particle) comes with it when velocities were given. File and grid metadata:
 * shot (string), frame (int32), kerf_version (string), dx (double), and
 * compression ("blosc" or "zip", whichever this OpenVDB build supports).
 * Every write goes to <path>.tmp-<pid>, is fsync'ed and renamed over path. */
#ifndef KF_VDB_BRIDGE_H
#define KF_VDB_BRIDGE_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define KF_VDB_RADIUS_FACTOR 1.0 /* default particle radius / spacing */
#define KF_VDB_RMIN_VOXELS 1.5   /* OpenVDB's smallest rasterised radius, voxels */
#define KF_VDB_MAX_GRIDS 32

/* An opaque float level set (plus an optional velocity grid). */
typedef struct kf_vdb_grid kf_vdb_grid;

/* smoothing operators for kf_vdb_filter and kf_vdb_surface_params.smooth */
typedef enum kf_vdb_op {
    KF_VDB_OP_NONE = 0,
    KF_VDB_OP_DILATE,         /* amount: metres outward (LevelSetFilter offset(-amount)) */
    KF_VDB_OP_ERODE,          /* amount: metres inward  (offset(+amount)) */
    KF_VDB_OP_MEAN_CURVATURE, /* iterations: mean-curvature flow steps */
    KF_VDB_OP_GAUSSIAN,       /* iterations: Gaussian passes of width 1 voxel */
    KF_VDB_OP_LAPLACIAN,      /* iterations: Laplacian flow steps */
} kf_vdb_op;

/* how particles become a level set:
 *   SPHERES: the union of spheres of `radius` (the convention above), centres
 *     averaged first when `average` > 0;
 *   ANISOTROPIC: anisotropic kernels (after Yu & Turk 2013): each particle
 *     near a face is an ellipsoidal disc, `thickness` thick on either side
 *     of its centre across its neighbourhood's thinnest direction (the
 *     weighted covariance of its neighbours within average_radius, default
 *     3 spacings) and of radius `radius` along the other two, shortened
 *     in proportion to the covariance where the neighbourhood is cut short
 *     (at an edge, in a sheet); deep particles are balls of `radius`, a
 *     particle with under 6 neighbours a ball of 2 x thickness. The surface
 *     is their union, `thickness` proud of the outermost centres (erode by
 *     it to put it on the material); `average` does not apply. */
typedef enum kf_vdb_kernel { KF_VDB_KERNEL_SPHERES = 0, KF_VDB_KERNEL_ANISOTROPIC } kf_vdb_kernel;

/* particles -> level set. Zero means default in every field. */
typedef struct kf_vdb_surface_params {
    double voxel;         /* voxel size, m (default spacing / 2) */
    double spacing;       /* particle spacing, m (required unless every radius is given) */
    double radius;        /* one radius for all particles, m (default factor x spacing) */
    double radius_factor; /* radius / spacing (default KF_VDB_RADIUS_FACTOR) */
    double half_width;    /* narrow-band half width, voxels (default 3, at most 6) */
    double dilate;        /* m, applied first (0: none) */
    kf_vdb_op smooth;     /* KF_VDB_OP_MEAN_CURVATURE / _GAUSSIAN / _LAPLACIAN or NONE */
    int smooth_iterations;
    double erode;          /* m, applied last (0: none) */
    double average;        /* 0..1: pull each centre this far toward its neighbours' weighted mean
                              first (Yu & Turk 2013; 0: none); erode is reduced by the inward
                              shift this gives a flat face (vdb_bridge.cpp) */
    double average_radius; /* m, the neighbourhood of `average` (default 2 x spacing) */
    int clamp_small;       /* 1: raise radii under 1.5 voxels and count; 0: error */
    const char *name;      /* grid name (default "surface") */
    kf_vdb_kernel kernel;  /* KF_VDB_KERNEL_SPHERES (the union above) or _ANISOTROPIC (below) */
    double thickness;      /* anisotropic: a disc's half thickness, m (default spacing / 2) */
    double anisotropy;     /* anisotropic: a disc's radius at least 1/anisotropy of its longest (default 8) */
    int flatten;           /* passes of a bilateral filter of the zero set after smoothing and erosion:
                              faces flattened, edges kept (0: none; needs smooth NONE or
                              MEAN_CURVATURE and the shifts within the band) */
    double flatten_radius; /* m, its neighbourhood (default 3.75 x spacing, at most 7.5 voxels) */
} kf_vdb_surface_params;

typedef struct kf_vdb_surface_stats {
    size_t n_in;      /* particles given */
    size_t n_small;   /* radius < 1.5 voxels (clamped; 0 unless clamp_small) */
    size_t n_dropped; /* particles OpenVDB skipped anyway (always 0 or an error) */
    double r_min;     /* smallest radius used, m */
    size_t active_voxels;
    double seconds;                        /* wall time: rasterise + filter */
    double seconds_raster, seconds_filter; /* wall time of its two parts (filters run on the band count in the first) */
    double cpu_average;                    /* process CPU seconds of the centre averaging (surface_params.average) */
    size_t n_average_kept;                 /* particles deep enough to keep their place in it (not averaged) */
    double cpu_sort, cpu_splat, cpu_redistance, cpu_filter; /* process CPU seconds of each phase */
    /* wall seconds of each phase (anisotropic kernels; 0 for spheres): with
     * the CPU seconds, how much of each phase ran on more than one core */
    double wall_average, wall_sort, wall_splat, wall_redistance, wall_filter;
} kf_vdb_surface_stats;

/* File / grid metadata. */
typedef struct kf_vdb_meta {
    char shot[256];
    int frame;
    char kerf_version[64];
    double dx;
    char compression[16]; /* filled on read: "blosc", "zip" or "" */
} kf_vdb_meta;

typedef struct kf_vdb_file_info {
    int ngrids;
    struct {
        char name[128];
        char cls[32];  /* "level set", "fog volume", "staggered", "unknown" */
        char type[32]; /* OpenVDB value type: "float", "vec3s", "ptdataidx32"... */
    } grids[KF_VDB_MAX_GRIDS];
    kf_vdb_meta meta; /* the file-level metadata */
} kf_vdb_file_info;

/* A triangle mesh; arrays are the bridge's, freed by kf_vdb_mesh_free. */
typedef struct kf_vdb_trimesh {
    size_t nverts, ntris;
    float *verts;   /* (nverts x 3) world position, m */
    float *normals; /* (nverts x 3) unit outward normal (level-set gradient) */
    uint32_t *tris; /* (ntris x 3) vertex indices, counter-clockwise seen from outside */
} kf_vdb_trimesh;

/* The points' float attributes, by index into kf_vdb_points_write's floats
 * and kf_vdb_points.f; their names in the file are kf_vdb_point_float_names. */
enum {
    KF_VDB_PT_JP,        /* "Jp": the plastic state ps[0] as the model keeps it */
    KF_VDB_PT_VON_MISES, /* "von_mises": von Mises Cauchy stress, Pa */
    KF_VDB_PT_J,         /* "J": volume ratio V/V0 */
    KF_VDB_PT_PLASTIC,   /* "plastic_strain": the model's plastic strain */
    KF_VDB_PT_FLOATS
};
extern const char *const kf_vdb_point_float_names[KF_VDB_PT_FLOATS];

/* Particles as OpenVDB points; read back by kf_vdb_points_read. */
typedef struct kf_vdb_points {
    size_t n;
    float *x;                   /* (n x 3) position, m */
    float *v;                   /* (n x 3) velocity, m/s (NULL: not written / absent) */
    int32_t *material;          /* (n) material id (NULL: absent) */
    float *f[KF_VDB_PT_FLOATS]; /* (n) each float attribute (NULL: absent) */
} kf_vdb_points;

void kf_vdb_surface_params_default(kf_vdb_surface_params *p);

/* How far (m) the surface of p's kernels lies beyond the material's boundary
 * on a flat face, before smoothing: the erosion that puts it back there.
 * Spheres: radius - spacing / 2 (the convention above; the bridge itself
 * takes off the averaging's shift). Anisotropic: the discs' half thickness
 * less how far the highest of the N centres under a disc (N = pi radius^2 /
 * spacing^2, each uniform in the outermost spacing) lies below the face on
 * average, spacing / (N + 1). */
double kf_vdb_surface_offset(const kf_vdb_surface_params *p);

/* Surface n particles. Positions are xd (n x 3 doubles) or xf (n x 3
 * floats), exactly one non-NULL. radii: (n) per-particle radius in m or NULL
 * (then p->radius or factor x spacing). vel: (n x 3) m/s or NULL; when given
 * the grid carries a "vel" grid (velocity of the closest particle).
 * stats may be NULL. Returns 0 and *out, or -1 with a message. */
int kf_vdb_levelset_from_particles(size_t n, const double *xd, const float *xf, const float *radii, const float *vel,
                                   const kf_vdb_surface_params *p, kf_vdb_grid **out, kf_vdb_surface_stats *stats,
                                   char *err, size_t errlen);

/* a = a union b (CSG on the level sets, openvdb::tools::csgUnion; the
 * velocity grids merged, a's value where both have one); b is emptied and
 * still freed by the caller. Both must have the same voxel size. */
int kf_vdb_union(kf_vdb_grid *a, kf_vdb_grid *b, char *err, size_t errlen);

/* One filter pass: amount (m) for dilate/erode, iterations for smoothing. */
int kf_vdb_filter(kf_vdb_grid *g, kf_vdb_op op, double amount, int iterations, char *err, size_t errlen);

int kf_vdb_set_name(kf_vdb_grid *g, const char *name, char *err, size_t errlen);
const char *kf_vdb_name(const kf_vdb_grid *g);
double kf_vdb_voxel_size(const kf_vdb_grid *g);
size_t kf_vdb_active_voxels(const kf_vdb_grid *g);

/* Write level sets (each with its vel grid, named "vel" for the grid named
 * "surface" and "<name>_vel" otherwise) to one .vdb, atomically. */
int kf_vdb_write(const char *path, kf_vdb_grid *const *grids, int ngrids, const kf_vdb_meta *meta, char *err,
                 size_t errlen);

/* Write particles as a PointDataGrid named "points" with attributes P and,
 * where given, v (vec3f), material (int32) and the float attributes (floats
 * may be NULL, or hold NULL for an attribute left out). voxel: the points
 * grid's voxel size in m (0: OpenVDB's ~8 points per voxel estimate). */
int kf_vdb_points_write(const char *path, size_t n, const float *x, const float *v, const int32_t *material,
                        const float *const *floats, double voxel, const kf_vdb_meta *meta, char *err, size_t errlen);
/* Read every point of the first PointDataGrid (order is OpenVDB's, not the
 * writer's). Free with kf_vdb_points_free. */
int kf_vdb_points_read(const char *path, kf_vdb_points *out, char *err, size_t errlen);
void kf_vdb_points_free(kf_vdb_points *pts);

/* Level set -> triangles (volumeToMesh; quads split in two). isovalue in m
 * (0: the surface), adaptivity 0..1 (0: uniform). */
int kf_vdb_mesh(const kf_vdb_grid *g, double isovalue, double adaptivity, kf_vdb_trimesh *out, char *err,
                size_t errlen);
void kf_vdb_mesh_free(kf_vdb_trimesh *m);

/* Read-back. */
int kf_vdb_info(const char *path, kf_vdb_file_info *info, char *err, size_t errlen);
/* Load the float level set called name (NULL: "surface"); meta may be NULL. */
int kf_vdb_read_levelset(const char *path, const char *name, kf_vdb_grid **out, kf_vdb_meta *meta, char *err,
                         size_t errlen);
/* Signed distance (m, negative inside) at n world points xyz (n x 3),
 * trilinear; outside the narrow band it is +/- the band width. */
int kf_vdb_sample(const kf_vdb_grid *g, const double *xyz, size_t n, double *out, char *err, size_t errlen);
/* Read the vec3s grid called name (NULL: "vel") and sample it trilinearly
 * at n world points xyz (n x 3) into out (n x 3); zero where inactive. */
int kf_vdb_read_vec3_sample(const char *path, const char *name, const double *xyz, size_t n, double *out, char *err,
                            size_t errlen);
/* The renderer's path from a .vdb alone: read "surface" and mesh it. */
int kf_vdb_read_surface_mesh(const char *path, double adaptivity, kf_vdb_trimesh *out, kf_vdb_meta *meta, char *err,
                             size_t errlen);

void kf_vdb_free(kf_vdb_grid *g);

#ifdef __cplusplus
}
#endif

#endif
