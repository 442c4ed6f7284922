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
 * seconds, paths resolved. Nothing here touches the file system except
 * reading the shot and checking that mesh files exist. */
#ifndef KF_SHOT_H
#define KF_SHOT_H

#include <stdint.h>
#include <stdio.h>

#include "../kerf.h"
#include "diag.h"

#ifdef __cplusplus
extern "C" {
#endif

typedef enum kf_quality {
    KF_QUALITY_FINAL = 0, /* the shot as written */
    KF_QUALITY_PREVIEW    /* Δx doubled (≈ 1/8 the particles), images at half resolution */
} kf_quality;

/* particle sources (objects:) */
typedef enum kf_source_shape { KF_SOURCE_BOX = 0, KF_SOURCE_SPHERE, KF_SOURCE_CYLINDER, KF_SOURCE_MESH } kf_source_shape;

typedef struct kf_shot_material {
    kf_material mat;  /* ready for kf_model_add_material; mat.name is the shot's name for it */
    char preset[32];  /* the preset it started from, "" when none */
} kf_shot_material;

/* An object is filled with particles at t = 0. Placement: the shape is built
 * around `center` (a mesh: fitted to fit_center/fit_size when fit is set,
 * else as modelled, with `center` the fitted centre or the mesh's bounding
 * box centre), then scaled by scale[] and rotated by rotate[] (degrees, about
 * x then y then z, i.e. R = Rz Ry Rx) about that centre, then moved by
 * translate[]. */
typedef struct kf_shot_object {
    char name[64];
    kf_source_shape shape;
    char material_name[32];
    int material;              /* index into kf_shot.materials */
    double center[3];          /* m; box, sphere, cylinder (mesh: fit_center when fitted) */
    double size[3];            /* box: full edge lengths, m */
    double radius;             /* sphere, cylinder, m */
    double height;             /* cylinder, m */
    int axis;                  /* cylinder: 0 x, 1 y, 2 z */
    char mesh[256];            /* mesh: the path as written */
    char mesh_path[1024];      /* mesh: resolved against the shot file's directory (exists) */
    int fit;                   /* mesh: 1 = fit its bounding box first */
    double fit_center[3];      /* m: where the bounding box centre goes */
    double fit_size;           /* m: the largest bounding box extent becomes this */
    double rotate[3];          /* degrees about x, y, z */
    double scale[3];           /* factors */
    double translate[3];       /* m */
    double velocity[3];        /* m/s, initial */
    double angular_velocity[3];/* rad/s about the object's centre, initial */
} kf_shot_object;

typedef struct kf_shot_collider {
    char name[64];
    kf_collider col;  /* ready for kf_model_add_collider: box half = size/2, plane normal unit,
                         keys in seconds since frames.start (absolute centre positions) */
    double size[3];   /* box: full edge lengths as written, m */
} kf_shot_collider;

typedef struct kf_shot {
    char name[64];               /* {shot}: `shot:` or the file's stem */
    int version;                 /* {version} */
    char path[1024];             /* the shot file as given */
    char dir[1024];              /* its directory ("." when none); meshes are relative to it */

    int frame_start, frame_end;  /* the shot's frame range, inclusive */
    double fps;
    int first, last;             /* the frames this run should produce (--frames, else the range) */

    kf_quality quality;
    double resolution_scale;     /* images: 1 final, 0.5 preview */

    kf_sim_def sim;              /* dx (quality applied), walls and domain filled */
    int ppc;                     /* particles per cell: 1, 8, 27 or 64 */
    int ppc_axis;                /* its cube root, for kf_state_fill_*() */
    int jitter;                  /* 1 = jittered lattice */
    uint32_t seed;               /* jitter seed; give object i seed + i */

    kf_shot_material *materials; /* (nmaterials), in file order */
    int nmaterials;
    kf_shot_object *objects;     /* (nobjects), in file order */
    int nobjects;
    kf_shot_collider *colliders; /* (ncolliders), in file order */
    int ncolliders;

    char output_dir[512];        /* template: {shot}, {version:03d}, {frame:04d} */
    char output_name[256];       /* template of a frame's file stem (no extension) */
    int output_particles;        /* write particles each frame */
    int output_checkpoints;      /* write checkpoints each frame */
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

/* Seconds since frames.start at the start of `frame`. */
double kf_shot_frame_time(const kf_shot *shot, int frame);

/* Expand an output template for a frame: {shot}, {version}, {frame}, each
 * with an optional printf-style integer width such as {frame:04d};
 * {{ and }} are literal braces. Returns 0, or -1 if the template is bad or
 * out is too small (out then holds "" ). */
int kf_shot_expand(const char *tmpl, const kf_shot *shot, int frame, char *out, size_t outlen);

/* `kerf help shot`: every key, generated from the key table. */
void kf_shot_help(FILE *f);

#ifdef __cplusplus
}
#endif
#endif
