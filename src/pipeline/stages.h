/* stages.h — the stages after simulation: surface a frame's particles into
 * OpenVDB level sets, and render the surfaces to PNG.
 *
 * Each stage reads only what the previous one wrote (a checkpoint, a .vdb),
 * so `kerf surface` and `kerf render` run on their own for any frame range,
 * and a stage whose output is newer than its input and was made with the same
 * settings is skipped. */
#ifndef KF_STAGES_H
#define KF_STAGES_H

#include <stdint.h>

#include "../shot/shot.h"
#include "../scene/builtin.h"

typedef struct kf_frame_paths {
    char dir[2048];
    char particles[4096], checkpoint[4096], surface[4096], image[4096], points[4096], exr[4096];
} kf_frame_paths;

/* {dir}/particles/{name}.ply, checkpoints/{name}.kfc, surface/{name}.vdb,
 * images/{name}.png and images/{name}.exr (render.format says which are
 * made). out: a directory template replacing output.dir, or NULL. */
int kf_frame_paths_make(const kf_shot *shot, const char *out, int frame, kf_frame_paths *fp);

/* mkdir -p the directory holding path */
int kf_ensure_parent(const char *path);

/* 1 when `output` exists and is at least as new as `input` */
int kf_output_current(const char *output, const char *input);

/* Checkpoint → particles grouped by material or by shot object
 * (surface.group) → one level set per group that holds particles, with its
 * velocity grid: `surface` (and `vel`) when there is one group, else
 * `surface_<name>` (and `surface_<name>_vel`) each → .vdb. Returns 0, or -1
 * with a message. */
int kf_pipeline_surface(const kf_shot *shot, const kf_scene *sc, const kf_frame_paths *fp, int frame, char *err,
                        size_t errlen);

/* Render settings that are not in the shot file yet: size and sampling. */
typedef struct kf_render_opts {
    int width, height, samples;
    int turntable_k, turntable_n; /* n > 0: orbit camera, view k of n */
    float lo[3], hi[3];           /* what the camera frames, the same for every frame */
    int ground;
    int shadow;    /* shadow map texels a side, 0: automatic */
    int antialias; /* render.antialias: 0 edges, 1 msaa */
    /* NULL, or where the render context is kept from one frame to the next
     * (every frame rendered through it with the same options; the caller
     * destroys what is left there with kf_render_destroy) */
    struct kf_render_ctx **keep;
} kf_render_opts;

/* particles as OpenVDB points (output.points): P, v, material, Jp and the
 * fields for analysis (von_mises, J, plastic_strain: kf_state_particle_fields) */
int kf_pipeline_points(const kf_shot *shot, const kf_model *m, const kf_state *s, const char *path, int frame,
                       char *err, size_t errlen);
/* Grow [lo, hi] by the particles of sc's state (robust: a few strays are
 * left out). */
void kf_particle_bounds_add(const kf_scene *sc, float lo[3], float hi[3]);
/* The shot's render settings; the camera frames [lo, hi] (the particles over
 * the whole shot; lo > hi: none), clipped to the domain when walled. */
kf_render_opts kf_render_opts_for(const kf_shot *shot, const float lo[3], const float hi[3]);

/* .vdb → a mesh per group surface, each in its group's colour and shading →
 * PNG at `png` and/or (render.format) the EXR with AOVs beside it (`png`
 * with .exr for .png). */
int kf_pipeline_render(const kf_shot *shot, const kf_scene *sc, const char *vdb, const char *png, int frame,
                       const kf_render_opts *ro, char *err, size_t errlen);

#endif
