/* context_osmesa.c — the OSMesa backend: a core-profile context drawing into
 * a malloc'ed buffer. libOSMesa is opened at run time (Mesa >= 25.1 no
 * longer ships it; context.c then falls back to EGL). */
#include "context_backend.h"

#include <GL/osmesa.h>
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>

typedef OSMesaContext (*create_fn)(const int *, OSMesaContext);
typedef GLboolean (*make_current_fn)(OSMesaContext, void *, GLenum, GLsizei, GLsizei);
typedef void (*destroy_fn)(OSMesaContext);
typedef OSMESAproc (*proc_fn)(const char *);
typedef void (*pixel_store_fn)(GLint, GLint);

static struct {
    void *lib;
    create_fn create;
    make_current_fn make_current;
    destroy_fn destroy;
    proc_fn proc;
    pixel_store_fn pixel_store;
} os;

typedef struct osmesa_ctx {
    OSMesaContext ctx;
    int w, h;
    unsigned char *buf; /* (h x w x 4) the default framebuffer; the renderer draws into FBOs */
} osmesa_ctx;

/* open libOSMesa once and find its five functions */
static int load(char *err, size_t errlen) {
    if (os.lib) return 0;
    const char *names[] = {"libOSMesa.so.8", "libOSMesa.so.6", "libOSMesa.so"};
    void *lib = NULL;
    for (size_t i = 0; i < sizeof names / sizeof *names && !lib; i++) lib = dlopen(names[i], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        snprintf(err, errlen, "render context: OSMesa is not installed (no libOSMesa.so.8: %s)", dlerror());
        return -1;
    }
    os.create = (create_fn)kf_dlsym(lib, "OSMesaCreateContextAttribs");
    os.make_current = (make_current_fn)kf_dlsym(lib, "OSMesaMakeCurrent");
    os.destroy = (destroy_fn)kf_dlsym(lib, "OSMesaDestroyContext");
    os.proc = (proc_fn)kf_dlsym(lib, "OSMesaGetProcAddress");
    os.pixel_store = (pixel_store_fn)kf_dlsym(lib, "OSMesaPixelStore");
    if (!os.create || !os.make_current || !os.destroy || !os.proc || !os.pixel_store) {
        snprintf(err, errlen, "render context: libOSMesa lacks OSMesaCreateContextAttribs (too old)");
        dlclose(lib);
        return -1;
    }
    os.lib = lib;
    return 0;
}

static int osmesa_make_current(void *p, char *err, size_t errlen) {
    osmesa_ctx *c = p;
    if (!os.make_current(c->ctx, c->buf, GL_UNSIGNED_BYTE, c->w, c->h)) {
        snprintf(err, errlen, "render context: OSMesaMakeCurrent failed for %dx%d", c->w, c->h);
        return -1;
    }
    return 0;
}

static void osmesa_destroy(void *p) {
    osmesa_ctx *c = p;
    if (!c) return;
    if (c->ctx) os.destroy(c->ctx);
    free(c->buf);
    free(c);
}

static void *osmesa_create(int w, int h, char *err, size_t errlen) {
    if (load(err, errlen)) return NULL;
    osmesa_ctx *c = calloc(1, sizeof *c);
    if (!c || !(c->buf = malloc((size_t)w * (size_t)h * 4))) {
        snprintf(err, errlen, "render context: out of memory for a %dx%d buffer", w, h);
        free(c);
        return NULL;
    }
    c->w = w;
    c->h = h;
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
    c->ctx = os.create(attribs, NULL);
    if (!c->ctx) {
        snprintf(err, errlen, "render context: OSMesaCreateContextAttribs refused a GL 3.3 core context");
        osmesa_destroy(c);
        return NULL;
    }
    if (osmesa_make_current(c, err, errlen)) {
        osmesa_destroy(c);
        return NULL;
    }
    /* rows of the default buffer top-down, should anyone read it directly */
    os.pixel_store(OSMESA_Y_UP, 0);
    return c;
}

static kf_proc osmesa_proc(const char *name) { return os.proc ? (kf_proc)os.proc(name) : NULL; }

const kf_gl_backend kf_gl_backend_osmesa = {"osmesa", osmesa_create, osmesa_make_current, osmesa_destroy, osmesa_proc};
