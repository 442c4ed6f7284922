/* context.h — the one door to an offscreen OpenGL core context.
 *
 * Two backends behind it, chosen in kf_gl_context_create: OSMesa
 * (context_osmesa.c) and EGL surfaceless (context_egl.c), for Mesa >= 25.1,
 * which removed OSMesa. KERF_GL=osmesa|egl picks one; by default OSMesa,
 * falling back to EGL. The renderer draws into its own FBOs and loads every
 * GL entry point through kf_gl_context_proc, so it never touches a
 * window-system buffer. */
#ifndef KF_RENDER_CONTEXT_H
#define KF_RENDER_CONTEXT_H

#include <stddef.h>

#include "proc.h"

typedef struct kf_gl_context kf_gl_context;

/* A GL >= 3.3 core-profile context with a w x h RGBA8 default buffer,
 * made current on the calling thread. NULL + err on failure. */
kf_gl_context *kf_gl_context_create(int w, int h, char *err, size_t errlen);

/* Make c current on the calling thread (contexts may be used from one thread at a time). */
int kf_gl_context_make_current(kf_gl_context *c, char *err, size_t errlen);

void kf_gl_context_destroy(kf_gl_context *c);

/* "osmesa" or "egl": the backend c runs on */
const char *kf_gl_context_backend(const kf_gl_context *c);

/* The address of a GL function (core 1.1 functions included), or NULL. */
kf_proc kf_gl_context_proc(const char *name);

#endif
