/* rigid_draw.h — rigid bodies in a rendered frame: each body's surface at its
 * pose of that frame, in its shot colour.
 *
 * The pose comes from the frame's checkpoint (kf_state_rigid), which sits
 * beside the frame's surface: <dir>/surface/<name>.vdb has its state in
 * <dir>/checkpoints/<name>.kfc. Without the checkpoint, static and kinematic
 * bodies are placed from their motion at the frame's time; dynamic ones
 * cannot be, which is an error. */
#ifndef KF_RIGID_DRAW_H
#define KF_RIGID_DRAW_H

#include <stdint.h>

#include "../shot/shot.h"
#include "../scene/builtin.h"
#include "render.h"

typedef struct kf_rigid_drawing {
    float *pos;    /* (nv x 3) world, every triangle its own corners (flat shading) */
    uint32_t *tri; /* (nt x 3) */
    float *vel;    /* (nv x 3) each corner's velocity at the frame, m/s */
    size_t nv, nt;
    size_t first[KF_MAX_RIGIDS + 1]; /* body i owns triangles [first[i], first[i + 1]) */
    int n;
} kf_rigid_drawing;

/* Place every body of sc's model at its pose for `frame` (vdb: the frame's
 * surface file). Returns 0, or -1 with a message. */
int kf_rigid_drawing_make(const kf_shot *shot, const kf_scene *sc, const char *vdb, int frame, kf_rigid_drawing *d,
                          char *err, size_t errlen);

/* One render mesh per body into rm (at most max); returns how many. */
int kf_rigid_drawing_meshes(const kf_shot *shot, const kf_rigid_drawing *d, kf_render_mesh *rm, int max);

void kf_rigid_drawing_free(kf_rigid_drawing *d);

#endif
