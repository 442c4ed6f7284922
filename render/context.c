/* context.c — OSMesa core-profile context (the only file that includes osmesa.h). */
#include "context.h"

#include <GL/osmesa.h>
#include <stdio.h>
#include <stdlib.h>

struct kf_gl_context {
    OSMesaContext ctx;
    int w, h;
    unsigned char *buf; /* (h x w x 4) the default framebuffer; the renderer draws into FBOs */
};

kf_gl_context *kf_gl_context_create(int w, int h, char *err, size_t errlen) {
    if (w <= 0 || h <= 0 || w > 16384 || h > 16384) {
        snprintf(err, errlen, "render context: bad size %dx%d (1..16384 each way)", w, h);
        return NULL;
    }
    kf_gl_context *c = calloc(1, sizeof *c);
    if (!c) {
        snprintf(err, errlen, "render context: out of memory");
        return NULL;
    }
    c->w = w;
    c->h = h;
    c->buf = malloc((size_t)w * (size_t)h * 4);
    if (!c->buf) {
        snprintf(err, errlen, "render context: out of memory for a %dx%d buffer", w, h);
        free(c);
        return NULL;
    }
    /* a core 3.3 request: llvmpipe answers with its highest core version (4.5) */
    const int attribs[] = {OSMESA_FORMAT,
                           OSMESA_RGBA,
                           OSMESA_DEPTH_BITS,
                           24,
                           OSMESA_STENCIL_BITS,
                           0,
                           OSMESA_ACCUM_BITS,
                           0,
                           OSMESA_PROFILE,
                           OSMESA_CORE_PROFILE,
                           OSMESA_CONTEXT_MAJOR_VERSION,
                           3,
                           OSMESA_CONTEXT_MINOR_VERSION,
                           3,
                           0};
    c->ctx = OSMesaCreateContextAttribs(attribs, NULL);
    if (!c->ctx) {
        snprintf(err, errlen,
                 "render context: OSMesaCreateContextAttribs refused a GL 3.3 core context "
                 "(is Mesa's llvmpipe OSMesa installed?)");
        free(c->buf);
        free(c);
        return NULL;
    }
    if (kf_gl_context_make_current(c, err, errlen) != 0) {
        kf_gl_context_destroy(c);
        return NULL;
    }
    /* rows of the default buffer top-down, should anyone read it directly */
    OSMesaPixelStore(OSMESA_Y_UP, 0);
    return c;
}

int kf_gl_context_make_current(kf_gl_context *c, char *err, size_t errlen) {
    if (!OSMesaMakeCurrent(c->ctx, c->buf, GL_UNSIGNED_BYTE, c->w, c->h)) {
        snprintf(err, errlen, "render context: OSMesaMakeCurrent failed for %dx%d", c->w, c->h);
        return -1;
    }
    return 0;
}

void kf_gl_context_destroy(kf_gl_context *c) {
    if (!c) return;
    if (c->ctx) OSMesaDestroyContext(c->ctx);
    free(c->buf);
    free(c);
}

void *kf_gl_context_proc(const char *name) {
    return (void *)OSMesaGetProcAddress(name);
}
