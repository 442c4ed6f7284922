/* strbuf.h — a growing text buffer with printf (for the MJCF text). */
#ifndef KF_RIGID_STRBUF_H
#define KF_RIGID_STRBUF_H

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

typedef struct kf_strbuf {
    char *s;
    size_t len, cap;
    int oom; /* an allocation failed: s is incomplete */
} kf_strbuf;

static inline void kf_sb_printf(kf_strbuf *b, const char *fmt, ...) {
    if (b->oom) return;
    for (;;) {
        va_list ap;
        va_start(ap, fmt);
        size_t room = b->cap - b->len;
        int n = vsnprintf(b->s ? b->s + b->len : NULL, b->s ? room : 0, fmt, ap);
        va_end(ap);
        if (n < 0) {
            b->oom = 1;
            return;
        }
        if (b->s && (size_t)n < room) {
            b->len += (size_t)n;
            return;
        }
        size_t cap = b->cap ? b->cap : 4096;
        while (cap < b->len + (size_t)n + 1) cap *= 2;
        char *s = realloc(b->s, cap);
        if (!s) {
            b->oom = 1;
            return;
        }
        b->s = s, b->cap = cap;
    }
}

#endif
