/* exr_frame.h — a rendered frame's AOVs as one EXR: the planes the renderer
 * fills (render.h, kf_render_aovs), the ids that get a coverage matte, and
 * the channel layout of the file. */
#ifndef KF_EXR_FRAME_H
#define KF_EXR_FRAME_H

#include <stddef.h>

#include "render.h"

typedef struct kf_pipeline_aovs {
    kf_render_aovs aov;
    int ids[KF_RENDER_MAX_MATTES];        /* one matte per distinct mesh id, in scene order */
    char names[KF_RENDER_MAX_MATTES][80]; /* "matte.<name>" */
} kf_pipeline_aovs;

/* Planes for an image of npx pixels and a matte per distinct id of the n
 * meshes (name[i] names mesh i). 0, or -1 when out of memory. */
int kf_pipeline_aovs_alloc(kf_pipeline_aovs *pa, const kf_render_mesh *meshes, const char *const *name, int n,
                           size_t npx);
/* Write the EXR: R G B A, Z, N.x N.y N.z, id, forward.u forward.v and the
 * mattes, half-float, with string attributes kv and the camera. */
int kf_pipeline_aovs_write(const kf_pipeline_aovs *pa, const char *path, int w, int h, const char *const *kv, int nkv,
                           char *err, size_t errlen);
void kf_pipeline_aovs_free(kf_pipeline_aovs *pa);

#endif
