/* context_backend.h — what each offscreen GL backend provides to context.c
 * (internal to render/). A backend loads its library with dlopen at run
 * time, so a machine without it still runs with the other one. */
#ifndef KF_RENDER_CONTEXT_BACKEND_H
#define KF_RENDER_CONTEXT_BACKEND_H

#include <stddef.h>

#include "proc.h"

typedef struct kf_gl_backend {
    const char *name;
    /* a GL >= 3.3 core context of size w x h, made current; NULL + err */
    void *(*create)(int w, int h, char *err, size_t errlen);
    int (*make_current)(void *ctx, char *err, size_t errlen);
    void (*destroy)(void *ctx);
    kf_proc (*proc)(const char *name); /* a GL entry point by name, or NULL */
} kf_gl_backend;

extern const kf_gl_backend kf_gl_backend_osmesa; /* context_osmesa.c */
extern const kf_gl_backend kf_gl_backend_egl;    /* context_egl.c: EGL surfaceless (Mesa) */

#endif
