/* context_egl.c — the EGL backend: a core-profile context with no surface at
 * all (EGL_MESA_platform_surfaceless + EGL_KHR_surfaceless_context), the
 * door that stays open now that Mesa >= 25.1 has dropped OSMesa. The
 * renderer draws into its own FBOs, so no window-system buffer is needed.
 * libEGL (Debian libegl1 + libegl-mesa0) is opened at run time. */
#include "context_backend.h"

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static struct {
    void *lib;
    PFNEGLGETPROCADDRESSPROC get_proc;
    PFNEGLGETPLATFORMDISPLAYEXTPROC get_platform_display;
    PFNEGLINITIALIZEPROC initialize;
    PFNEGLQUERYSTRINGPROC query_string;
    PFNEGLBINDAPIPROC bind_api;
    PFNEGLCHOOSECONFIGPROC choose_config;
    PFNEGLCREATECONTEXTPROC create_context;
    PFNEGLMAKECURRENTPROC make_current;
    PFNEGLDESTROYCONTEXTPROC destroy_context;
    PFNEGLGETERRORPROC get_error;
    EGLDisplay dpy; /* one surfaceless display for the process, initialised once */
} egl;

typedef struct egl_ctx {
    EGLContext ctx;
} egl_ctx;

#define EGL_FN(field, type, name) egl.field = (type)egl.get_proc(name)

/* open libEGL, find its entry points, and initialise the surfaceless display */
static int load(char *err, size_t errlen) {
    if (egl.dpy) return 0;
    if (!egl.lib) {
        egl.lib = dlopen("libEGL.so.1", RTLD_NOW | RTLD_LOCAL);
        if (!egl.lib) {
            snprintf(err, errlen, "render context: EGL is not installed (no libEGL.so.1: %s)", dlerror());
            return -1;
        }
        egl.get_proc = (PFNEGLGETPROCADDRESSPROC)kf_dlsym(egl.lib, "eglGetProcAddress");
        if (!egl.get_proc) {
            snprintf(err, errlen, "render context: libEGL.so.1 has no eglGetProcAddress");
            return -1;
        }
    }
    EGL_FN(get_platform_display, PFNEGLGETPLATFORMDISPLAYEXTPROC, "eglGetPlatformDisplayEXT");
    EGL_FN(initialize, PFNEGLINITIALIZEPROC, "eglInitialize");
    EGL_FN(query_string, PFNEGLQUERYSTRINGPROC, "eglQueryString");
    EGL_FN(bind_api, PFNEGLBINDAPIPROC, "eglBindAPI");
    EGL_FN(choose_config, PFNEGLCHOOSECONFIGPROC, "eglChooseConfig");
    EGL_FN(create_context, PFNEGLCREATECONTEXTPROC, "eglCreateContext");
    EGL_FN(make_current, PFNEGLMAKECURRENTPROC, "eglMakeCurrent");
    EGL_FN(destroy_context, PFNEGLDESTROYCONTEXTPROC, "eglDestroyContext");
    EGL_FN(get_error, PFNEGLGETERRORPROC, "eglGetError");
    if (!egl.get_platform_display || !egl.initialize || !egl.query_string || !egl.bind_api || !egl.choose_config ||
        !egl.create_context || !egl.make_current || !egl.destroy_context || !egl.get_error) {
        snprintf(err, errlen, "render context: libEGL lacks eglGetPlatformDisplayEXT (no EXT_platform_base)");
        return -1;
    }
    const char *client = egl.query_string(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!client || !strstr(client, "EGL_MESA_platform_surfaceless")) {
        snprintf(err, errlen, "render context: EGL has no EGL_MESA_platform_surfaceless (is libegl-mesa0 installed?)");
        return -1;
    }
    EGLDisplay dpy = egl.get_platform_display(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, NULL);
    EGLint major = 0, minor = 0;
    if (dpy == EGL_NO_DISPLAY || !egl.initialize(dpy, &major, &minor)) {
        snprintf(err, errlen, "render context: eglInitialize failed on the surfaceless platform (EGL error 0x%x)",
                 (unsigned)egl.get_error());
        return -1;
    }
    const char *ext = egl.query_string(dpy, EGL_EXTENSIONS);
    if (!ext || !strstr(ext, "EGL_KHR_surfaceless_context")) {
        snprintf(err, errlen, "render context: EGL %d.%d has no EGL_KHR_surfaceless_context", major, minor);
        return -1;
    }
    egl.dpy = dpy;
    return 0;
}

static void *egl_create(int w, int h, char *err, size_t errlen) {
    (void)w, (void)h; /* no surface: the renderer's FBOs have the size */
    if (load(err, errlen)) return NULL;
    if (!egl.bind_api(EGL_OPENGL_API)) {
        snprintf(err, errlen, "render context: eglBindAPI(EGL_OPENGL_API) failed (0x%x)", (unsigned)egl.get_error());
        return NULL;
    }
    /* no surface, so no config is needed where EGL allows that; else any
     * config that renders desktop GL (the default surface type, windows,
     * does not exist on the surfaceless platform: ask for pbuffers) */
    const EGLint cfg_attribs[] = {EGL_SURFACE_TYPE, EGL_PBUFFER_BIT, EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_NONE};
    EGLConfig cfg = EGL_NO_CONFIG_KHR;
    EGLint ncfg = 0;
    const char *ext = egl.query_string(egl.dpy, EGL_EXTENSIONS);
    if (!(ext && strstr(ext, "EGL_KHR_no_config_context")) &&
        (!egl.choose_config(egl.dpy, cfg_attribs, &cfg, 1, &ncfg) || ncfg < 1)) {
        snprintf(err, errlen, "render context: no EGL config renders desktop OpenGL (0x%x)", (unsigned)egl.get_error());
        return NULL;
    }
    const EGLint ctx_attribs[] = {
        EGL_CONTEXT_MAJOR_VERSION,           3,       EGL_CONTEXT_MINOR_VERSION, 3, EGL_CONTEXT_OPENGL_PROFILE_MASK,
        EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT, EGL_NONE};
    egl_ctx *c = calloc(1, sizeof *c);
    if (!c) {
        snprintf(err, errlen, "render context: out of memory");
        return NULL;
    }
    c->ctx = egl.create_context(egl.dpy, cfg, EGL_NO_CONTEXT, ctx_attribs);
    if (c->ctx == EGL_NO_CONTEXT) {
        snprintf(err, errlen, "render context: eglCreateContext refused a GL 3.3 core context (0x%x)",
                 (unsigned)egl.get_error());
        free(c);
        return NULL;
    }
    if (!egl.make_current(egl.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, c->ctx)) {
        snprintf(err, errlen, "render context: eglMakeCurrent without a surface failed (0x%x)",
                 (unsigned)egl.get_error());
        egl.destroy_context(egl.dpy, c->ctx);
        free(c);
        return NULL;
    }
    return c;
}

static int egl_make_current(void *p, char *err, size_t errlen) {
    egl_ctx *c = p;
    if (!egl.make_current(egl.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, c->ctx)) {
        snprintf(err, errlen, "render context: eglMakeCurrent failed (0x%x)", (unsigned)egl.get_error());
        return -1;
    }
    return 0;
}

static void egl_destroy(void *p) {
    egl_ctx *c = p;
    if (!c) return;
    egl.make_current(egl.dpy, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
    egl.destroy_context(egl.dpy, c->ctx);
    free(c);
}

/* eglGetProcAddress answers for core functions too (EGL_KHR_get_all_proc_addresses, EGL 1.5) */
static kf_proc egl_proc(const char *name) { return egl.get_proc ? (kf_proc)egl.get_proc(name) : NULL; }

const kf_gl_backend kf_gl_backend_egl = {"egl", egl_create, egl_make_current, egl_destroy, egl_proc};
