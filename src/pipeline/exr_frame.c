/* exr_frame.c — a frame's AOVs into one EXR (exr_frame.h). */
#include "exr_frame.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "exr.h"

int kf_pipeline_aovs_alloc(kf_pipeline_aovs *pa, const kf_render_mesh *meshes, const char *const *name, int n,
                           size_t npx) {
    memset(pa, 0, sizeof *pa);
    /* one matte per distinct id, first come first named */
    int nm = 0;
    for (int i = 0; i < n && nm < KF_RENDER_MAX_MATTES; i++) {
        int id = meshes[i].id, seen = id == 0;
        for (int k = 0; k < nm && !seen; k++) seen = pa->ids[k] == id;
        if (seen) continue;
        pa->ids[nm] = id;
        snprintf(pa->names[nm], sizeof pa->names[nm], "matte.%s", name[i]);
        nm++;
    }
    kf_render_aovs *a = &pa->aov;
    a->rgba = malloc(sizeof(float) * 4 * npx);
    a->z = malloc(sizeof(float) * npx);
    a->normal = malloc(sizeof(float) * 3 * npx);
    a->id = malloc(sizeof(float) * npx);
    a->motion = malloc(sizeof(float) * 2 * npx);
    a->matte = malloc(sizeof(float) * (nm + 1) * npx);
    a->matte_ids = pa->ids;
    a->nmatte = nm;
    if (!a->rgba || !a->z || !a->normal || !a->id || !a->motion || !a->matte) {
        kf_pipeline_aovs_free(pa);
        return -1;
    }
    return 0;
}

int kf_pipeline_aovs_write(const kf_pipeline_aovs *pa, const char *path, int w, int h, const char *const *kv, int nkv,
                           char *err, size_t errlen) {
    const kf_render_aovs *a = &pa->aov;
    const size_t npx = (size_t)w * h;
    kf_exr_channel ch[KF_EXR_MAX_CHANNELS] = {
        {"R", a->rgba + 0, 4}, {"G", a->rgba + 1, 4},       {"B", a->rgba + 2, 4},           {"A", a->rgba + 3, 4},
        {"Z", a->z, 1},        {"N.x", a->normal, 3},       {"N.y", a->normal + 1, 3},       {"N.z", a->normal + 2, 3},
        {"id", a->id, 1},      {"forward.u", a->motion, 2}, {"forward.v", a->motion + 1, 2},
    };
    int nch = 11;
    for (int k = 0; k < a->nmatte && nch < KF_EXR_MAX_CHANNELS; k++)
        ch[nch++] = (kf_exr_channel){pa->names[k], a->matte + (size_t)k * npx, 1};
    /* two mattes of one name (a material and an object so called) would be
     * one channel: the file takes the first */
    for (int i = 11; i < nch; i++)
        for (int j = 11; j < i; j++)
            if (!strcmp(ch[i].name, ch[j].name)) {
                ch[i--] = ch[--nch];
                break;
            }
    return kf_exr_write(path, w, h, ch, nch, kv, nkv, a->world_to_camera, a->world_to_ndc, err, errlen);
}

void kf_pipeline_aovs_free(kf_pipeline_aovs *pa) {
    kf_render_aovs *a = &pa->aov;
    free(a->rgba), free(a->z), free(a->normal), free(a->id), free(a->motion), free(a->matte);
    memset(a, 0, sizeof *a);
}
