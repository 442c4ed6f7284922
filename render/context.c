/* context.c — the one door to an offscreen GL context: picks the backend.
 *
 * KERF_GL=osmesa or KERF_GL=egl asks for one; otherwise OSMesa, and EGL
 * surfaceless when OSMesa cannot be had (not installed: Mesa >= 25.1). Both
 * libraries are opened at run time, so kerf starts without either. */
#include "context.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "context_backend.h"

struct kf_gl_context {
    const kf_gl_backend *be;
    void *ctx;
};

/* the backend of the last context made: GL entry points come from it */
static const kf_gl_backend *current;

kf_gl_context *kf_gl_context_create(int w, int h, char *err, size_t errlen) {
    if (w <= 0 || h <= 0 || w > 16384 || h > 16384) {
        snprintf(err, errlen, "render context: bad size %dx%d (1..16384 each way)", w, h);
        return NULL;
    }
    const char *want = getenv("KERF_GL");
    if (want && *want && strcmp(want, "osmesa") != 0 && strcmp(want, "egl") != 0) {
        snprintf(err, errlen, "render context: KERF_GL=%s: use osmesa or egl", want);
        return NULL;
    }
    const kf_gl_backend *order[2] = {&kf_gl_backend_osmesa, &kf_gl_backend_egl};
    int n = 2;
    if (want && !strcmp(want, "osmesa")) n = 1;
    if (want && !strcmp(want, "egl")) order[0] = &kf_gl_backend_egl, n = 1;
    char first[512] = "";
    for (int i = 0; i < n; i++) {
        void *ctx = order[i]->create(w, h, err, errlen);
        if (ctx) {
            kf_gl_context *c = calloc(1, sizeof *c);
            if (!c) {
                order[i]->destroy(ctx);
                snprintf(err, errlen, "render context: out of memory");
                return NULL;
            }
            c->be = current = order[i];
            c->ctx = ctx;
            return c;
        }
        if (i == 0) snprintf(first, sizeof first, "%s", err);
    }
    /* both failed: say why for each */
    if (n == 2) {
        char second[512];
        snprintf(second, sizeof second, "%s", err);
        snprintf(err, errlen, "%s; and %s", first, second);
    }
    return NULL;
}

int kf_gl_context_make_current(kf_gl_context *c, char *err, size_t errlen) {
    current = c->be;
    return c->be->make_current(c->ctx, err, errlen);
}

void kf_gl_context_destroy(kf_gl_context *c) {
    if (!c) return;
    c->be->destroy(c->ctx);
    free(c);
}

const char *kf_gl_context_backend(const kf_gl_context *c) { return c ? c->be->name : ""; }

kf_proc kf_gl_context_proc(const char *name) { return current ? current->proc(name) : NULL; }
