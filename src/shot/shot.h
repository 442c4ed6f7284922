/* shot.h — shot files: YAML (or JSON) text → a resolved, validated kf_shot.
 *
 * Only this module reads shot text. Every key a shot file may hold is declared
 * once, in the table in keys.c (name, type, bounds, default, unit, doc); the
 * parser, the validator, the defaults, the error messages and
 * `kerf help shot` (kf_shot_help) are all driven by it.
 *
 *     kf_diag diag;
 *     kf_diag_init(&diag);
 *     const char *sets[] = {"materials.jelly.E=2e3"};
 *     kf_shot *shot = kf_shot_load("shots/demo.yaml", sets, 1, "preview", "1001-1010", &diag);
 *     kf_diag_print(stderr, &diag);      // warnings too, so print it either way
 *     if (!shot) exit(2);                // the CLI's business, not this module's
 *     ... build the model from shot->sim, ->materials, ->objects, ->colliders ...
 *     kf_shot_free(shot);
 *     kf_diag_free(&diag);
 *
 * The values in a kf_shot are final: presets merged with overrides, --set
 * applied, quality applied (preview doubles sim.dx), collider keys in
 * seconds, paths resolved (objects' and colliders' meshes). Nothing here
 * touches the file system except reading the shot and checking that mesh
 * files exist. */
#ifndef KF_SHOT_H
#define KF_SHOT_H

#include <stdint.h>
#include <stdio.h>

#include <kerf/kerf.h>
#include "diag.h"
#include "source.h" /* kf_source_kind, kf_placement */

#ifdef __cplusplus
extern "C" {
#endif

/* The preview surfacing preset (a shot's surface.quality: preview): voxel and
 * radius in particle spacings; the voxel twice the final default (0.75), so
 * the grid has 1/8 the voxels, the sphere 1.6 voxels; one mean-curvature pass. The spec holds the numbers; the
 * surfacing and the renderer only read the shot's values. */
#define KF_VDB_PREVIEW_VOXEL 1.5
#define KF_VDB_PREVIEW_RADIUS 2.4
#define KF_VDB_PREVIEW_ITERATIONS 1
/* the preview render preset (render.quality: preview): the key light's
 * shadow map, texels a side */
#define KF_RENDER_PREVIEW_SHADOW 1024
/* render.format: which image files a frame gets */
enum { KF_FORMAT_PNG = 0, KF_FORMAT_EXR = 1, KF_FORMAT_BOTH = 2 };

typedef enum kf_quality {
    KF_QUALITY_FINAL = 0, /* the shot as written */
    KF_QUALITY_PREVIEW    /* Δx doubled (≈ 1/8 the particles), images at half resolution */
} kf_quality;

/* Where a value was written, so a later stage (the builder loading a mesh)
 * can report at it with kf_shot_report. Strings are owned by the kf_shot. */
typedef struct kf_loc {
    const char *file; /* NULL: unknown */
    int line, col;
    const char *source; /* the line's text, or NULL */
} kf_loc;

typedef struct kf_shot_material {
    kf_material mat;            /* ready for kf_model_add_material; mat.name is the shot's name for it */
    char preset[32];            /* the preset it started from, "" when none */
    double color[3];            /* sRGB render colour; negative: by kind (unset) */
    double specular, roughness; /* render shading, [0, 1]; negative: by kind (unset) */
    kf_loc at;                  /* its name under materials: */
    kf_loc stiffness_at;        /* its E (water: bulk_modulus) where given, else its name: the budget points here */
} kf_shot_material;

/* An object is filled with particles at t = 0. `place` is ready for the
 * sampler (scene/sample.h, x_world = T + R S x_local): the centre and
 * translate are in place.translate, a cylinder's axis is folded into
 * place.rotate (scale stays in the object's axes), and a fitted mesh's
 * translate is folded into place.fit_center (the sampler ignores translate
 * when fitting). The fields above it are the values as written. */
typedef struct kf_shot_object {
    char name[64];
    kf_source_kind shape;
    char material_name[32];
    int material;               /* index into kf_shot.materials */
    double center[3];           /* m; box, sphere, cylinder (a fitted mesh: place.fit_center) */
    double size[3];             /* box: full edge lengths, m */
    double radius;              /* sphere, cylinder, m */
    double height;              /* cylinder, m */
    int axis;                   /* cylinder: 0 x, 1 y, 2 z */
    char mesh[256];             /* mesh: the path as written */
    char mesh_path[1024];       /* mesh: resolved against the shot file's directory (exists) */
    int fit;                    /* mesh: 1 = fit its bounding box */
    double fit_center[3];       /* m, as written */
    double fit_size;            /* m: the largest bounding box extent becomes this */
    double rotate[3];           /* degrees about x, then y, then z (R = Rz Ry Rx) */
    double scale[3];            /* factors */
    double translate[3];        /* m */
    double velocity[3];         /* m/s, initial */
    double angular_velocity[3]; /* rad/s, initial, about the centroid of its particles */
    char bond[64];              /* the object this one is part of, by name ("" = none) */
    int field;                  /* its object for contact and surface.group: its own index, or the bonded one's */
    kf_placement place;         /* all of the above as the sampler wants it */
    kf_loc at;                  /* the object's entry */
    kf_loc mesh_at;             /* its mesh: value (mesh objects) */
} kf_shot_object;

/* A collider. Analytic shapes are complete in `col`; a mesh collider also
 * needs its distance grid, which the builder samples from the mesh placed by
 * `place` (the same placement objects use), in the frame centred on the
 * pivot col.center. Keys are in col.keys: seconds since frames.start,
 * absolute pivot positions (pivot + translate), rotate and scale as written. */
typedef struct kf_shot_collider {
    char name[64];
    double color[3];            /* sRGB render colour */
    double specular, roughness; /* render shading, [0, 1] */
    kf_collider col;            /* ready for kf_model_add_collider except a mesh's col.sdf: box half = size/2, plane
                                   normal unit, col.rotate the box's rest orientation (a mesh's is in place) */
    double size[3];             /* box: full edge lengths as written, m */
    char mesh[256];             /* mesh: the path as written */
    char mesh_path[1024];       /* mesh: resolved against the shot file's directory (exists) */
    int fit;                    /* mesh: 1 = fit its bounding box */
    double fit_center[3];       /* m, as written */
    double fit_size;            /* m */
    double rotate[3];           /* degrees about x, then y, then z (R = Rz Ry Rx) */
    double scale[3];            /* mesh: factors */
    double translate[3];        /* mesh: m */
    double pivot[3];            /* mesh: m, as written (col.center is the one used) */
    kf_placement place;         /* mesh: for kf_sample_placement (kind KF_SOURCE_MESH) */
    kf_loc at;                  /* the collider's entry */
    kf_loc mesh_at;             /* its mesh: value (mesh colliders) */
} kf_shot_collider;

/* A rigid body (CPIC). `def` is ready for kf_model_add_rigid except its
 * surface, which the builder makes (scene/build_rigid.c): a box of `size`
 * centred on the origin, or the mesh file scaled by `scale` about its origin
 * with `pivot` (default: its bounding-box centre) moved to the origin; then
 * turned by `rotate`, which is baked into the surface like a collider's rest
 * orientation, so def.rotate and def.center stay zero and keys turn on top
 * of it. def.position is the shot's `center`. Keys: seconds since
 * frames.start, absolute pivot positions (center + translate), rotate as
 * written, scale 1. */
typedef struct kf_shot_rigid {
    kf_rigid_def def;     /* name, thin, motion, pose, keys, velocities, density, boundary, ... */
    int shape;            /* 0 box, 1 mesh (the order of rigids[].shape's choices) */
    double size[3];       /* box: edge lengths, m */
    char mesh[256];       /* mesh: the path as written */
    char mesh_path[1024]; /* mesh: resolved against the shot file's directory (exists) */
    double scale[3];      /* mesh: factors about the mesh's origin */
    double pivot[3];      /* mesh: in the scaled mesh's coordinates, when pivot_set */
    int pivot_set;
    double color[3]; /* sRGB render colour */
    kf_loc at;       /* the body's entry */
    kf_loc mesh_at;  /* its mesh: value (mesh bodies) */
} kf_shot_rigid;

/* A hinge: def.body_a / body_b are indices into kf_shot.rigids (-1 world),
 * def.axis is unit. */
typedef struct kf_shot_joint {
    char name[64];
    int type;              /* 0 hinge */
    char body[32], to[32]; /* as written ("world" for the world) */
    kf_joint_def def;
    kf_loc at;
} kf_shot_joint;

typedef struct kf_shot {
    char name[64];   /* {shot}: `shot:` or the file's stem */
    int version;     /* {version} */
    char path[1024]; /* the shot file as given */
    char dir[1024];  /* its directory ("." when none); meshes are relative to it */

    int frame_start, frame_end; /* the shot's frame range, inclusive */
    double fps;
    int first, last; /* the frames this run should produce (--frames, else the range) */

    kf_quality quality;
    double resolution_scale; /* images: 1 final, 0.5 preview */

    kf_sim_def sim;                               /* dx (quality applied), walls and domain filled */
    kf_loc dx_at, cfl_at, dt_fixed_at, dt_max_at; /* sim.dx, .cfl, .dt_fixed, .dt_max where given (else the
                                                     top of the file): what the budget's messages point at */
    int ppc;                                      /* particles per cell: 1, 8, 27 or 64 */
    int ppc_axis;                                 /* its cube root, for kf_state_fill_*() */
    int jitter;                                   /* 1 = jittered lattice */
    uint32_t seed; /* jitter seed (>= 1); sampler seed for object i: jitter ? seed + i : 0 */

    kf_shot_material *materials; /* (nmaterials), in file order */
    int nmaterials;
    kf_shot_object *objects; /* (nobjects), in file order */
    int nobjects;
    kf_shot_collider *colliders; /* (ncolliders), in file order */
    int ncolliders;
    kf_shot_rigid *rigids; /* (nrigids <= KF_MAX_RIGIDS), in file order = model indices */
    int nrigids;
    kf_shot_joint *joints; /* (njoints), in file order */
    int njoints;

    char output_dir[512];   /* template: {shot}, {version:03d}, {frame:04d} */
    char output_name[256];  /* template of a frame's file stem (no extension) */
    int output_particles;   /* write particles each frame */
    int output_checkpoints; /* write checkpoints each frame */
    int output_surface;     /* surface each frame to .vdb */
    int output_images;      /* render each frame to .png */
    int output_points;      /* particles as OpenVDB points each frame */

    int surface_kernel;    /* 0 anisotropic discs, 1 spheres (vdb_bridge.h) */
    double surface_reach;  /* particle spacings: anisotropic neighbourhood and disc radius */
    double surface_voxel;  /* particle spacings */
    double surface_radius; /* particle spacings */
    int surface_smooth;    /* 0 none, 1 mean curvature, 2 gaussian, 3 laplacian */
    int surface_iterations;
    int surface_flatten;
    double surface_average;               /* 0..1: centre smoothing weight (Yu & Turk) */
    double surface_average_radius;        /* particle spacings */
    double surface_dilate, surface_erode; /* m; erode < 0: automatic */
    int surface_group;                    /* 0: a level set per material, 1: per object */
    int surface_quality;                  /* 0 final, 1 preview (preset applied to the fields above) */

    int render_width, render_height;        /* pixels, quality applied */
    int render_samples;                     /* anti-aliasing samples (1 in preview) */
    int render_antialias;                   /* 0 edges, 1 msaa */
    int render_quality;                     /* 0 final, 1 preview (preset applied) */
    int render_shadow;                      /* shadow map texels a side; 0: automatic */
    double render_eye[3], render_target[3]; /* m, when render_eye_set / render_target_set */
    int render_eye_set, render_target_set;
    double render_fov; /* vertical, degrees */
    int render_interp; /* camera keys: 0 linear, 1 smooth */
    int ncamera_keys;  /* render.keys, frames increasing */
    struct {
        double frame, eye[3], target[3], fov; /* fov 0: render_fov */
    } camera_keys[KF_MAX_KEYS];
    /* lights: key, fill, rim; direction towards the light in camera space
     * (x right, y up, z towards the viewer), colour, intensity */
    struct {
        double dir[3], color[3], intensity;
    } lights[3];
    int render_ground;
    int render_format;         /* 0 png, 1 exr, 2 both (KF_FORMAT_*) */
    double render_motion_blur; /* shutter, fraction of a frame centred on it; 0: no blur */

    char **strings; /* (nstrings) owned by the shot: the text kf_loc points to */
    int nstrings;
} kf_shot;

/* Load, validate and resolve a shot file.
 *   overrides: n_overrides strings "a.b.c=value" (value is YAML: 2e3, [0,1,0],
 *              {preset: goo}); list items are addressed by name or index:
 *              objects.cube.velocity=[0,-2,0], colliders.0.friction=0.1
 *   quality:   "final", "preview" or NULL (final)
 *   frames:    "1001-1010", "1005" or NULL (the whole range)
 * Returns NULL when anything is wrong; every problem found is in diag
 * (warnings may be there on success too). Free with kf_shot_free. */
kf_shot *kf_shot_load(const char *path, const char *const *overrides, int n_overrides, const char *quality,
                      const char *frames, kf_diag *diag);
void kf_shot_free(kf_shot *shot);

/* Add a diagnostic at a place in the shot (e.g. a mesh that will not load:
 * kf_shot_report(d, &obj->mesh_at, KF_DIAG_ERROR, "%s", err)). */
void kf_shot_report(kf_diag *d, const kf_loc *at, kf_severity sev, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* Seconds since frames.start at the start of `frame`. */
double kf_shot_frame_time(const kf_shot *shot, int frame);

/* Expand an output template for a frame: {shot}, {version}, {frame}, each
 * with an optional printf-style integer width such as {frame:04d};
 * {{ and }} are literal braces. Returns 0, or -1 if the template is bad or
 * out is too small (out then holds "" ). */
int kf_shot_expand(const char *tmpl, const kf_shot *shot, int frame, char *out, size_t outlen);

/* One key of a loaded shot as a tool that shows and edits values lists it
 * (kerf view): from the key table, with the loaded value printed the way
 * --set takes it back. */
typedef struct kf_shot_keyview {
    const char *key;     /* the table's path: "materials.*.E" */
    char path[160];      /* the --set path: "materials.jelly.E", "rigids.knife.keys.2.translate" */
    const char *type;    /* number, integer, bool, string, enum, vec3, preset, material */
    const char *choices; /* "a|b|c", or NULL */
    const char *def;     /* the default as text, or NULL */
    const char *unit;    /* "m", "Pa", ... or NULL */
    const char *doc;     /* the help text */
    char bounds[96];     /* "> 0", "in [0, 0.5)", or "" */
    char value[256];     /* the value the shot has */
    int applies;         /* 0: the key's condition (shape=box, ...) does not hold here */
    int editable;        /* 0: names, paths, templates, version: not a value to tweak */
} kf_shot_keyview;
typedef int (*kf_shot_key_fn)(const kf_shot_keyview *k, void *ctx);
/* Call fn for every key of the top level, each material and object (their
 * loaded values), then the camera keys, each collider, rigid body (with its
 * keys) and joint, whose values are read again from the shot file as written
 * (the loaded ones are transformed: keys in seconds, a body's rotation baked
 * into its surface); in table order; stops at the first non-zero return and
 * returns it. */
int kf_shot_keys_each(const kf_shot *shot, kf_shot_key_fn fn, void *ctx);

/* `kerf help shot`: every key, generated from the key table. */
void kf_shot_help(FILE *f);

#ifdef __cplusplus
}
#endif
#endif
