/* gl_api.c — load the GL entry points listed in gl_api.h. */
#include "gl_api.h"

#include <stdio.h>

int kf_gl_load(kf_gl *gl, kf_proc (*lookup)(const char *), char *err, size_t errlen) {
    kf_proc p;
#define KF_GL_LOAD(type, name)                                                                                         \
    p = lookup("gl" #name);                                                                                            \
    if (!p) {                                                                                                          \
        snprintf(err, errlen, "render: the GL has no gl%s (need GL 3.3 core)", #name);                                 \
        return -1;                                                                                                     \
    }                                                                                                                  \
    gl->name = (type)p;
    KF_GL_FUNCS(KF_GL_LOAD)
#undef KF_GL_LOAD
    return 0;
}
