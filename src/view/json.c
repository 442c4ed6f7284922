/* json.c — see json.h. */
#include "json.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void kf_buf_free(kf_buf *b) {
    free(b->s);
    memset(b, 0, sizeof *b);
}

/* room for n more bytes and the terminator */
static int grow(kf_buf *b, size_t n) {
    if (b->failed) return -1;
    if (b->len + n + 1 <= b->cap) return 0;
    size_t cap = b->cap ? b->cap : 1024;
    while (cap < b->len + n + 1) cap *= 2;
    char *s = realloc(b->s, cap);
    if (!s) {
        b->failed = 1;
        return -1;
    }
    b->s = s;
    b->cap = cap;
    return 0;
}

void kf_buf_put(kf_buf *b, const char *s, size_t n) {
    if (grow(b, n)) return;
    memcpy(b->s + b->len, s, n);
    b->len += n;
    b->s[b->len] = 0;
}

void kf_buf_printf(kf_buf *b, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    int n = vsnprintf(NULL, 0, fmt, ap);
    va_end(ap);
    if (n < 0 || grow(b, (size_t)n)) return;
    va_start(ap, fmt);
    vsnprintf(b->s + b->len, (size_t)n + 1, fmt, ap);
    va_end(ap);
    b->len += (size_t)n;
}

void kf_buf_str(kf_buf *b, const char *s) {
    if (!s) {
        kf_buf_put(b, "null", 4);
        return;
    }
    kf_buf_put(b, "\"", 1);
    for (const unsigned char *p = (const unsigned char *)s; *p; p++) {
        if (*p == '"' || *p == '\\') {
            char e[2] = {'\\', (char)*p};
            kf_buf_put(b, e, 2);
        } else if (*p < 0x20) {
            kf_buf_printf(b, "\\u%04x", *p);
        } else {
            kf_buf_put(b, (const char *)p, 1);
        }
    }
    kf_buf_put(b, "\"", 1);
}

void kf_buf_kv(kf_buf *b, const char *key, const char *value) {
    if (b->len && b->s[b->len - 1] != '{') kf_buf_put(b, ",", 1);
    kf_buf_str(b, key);
    kf_buf_put(b, ":", 1);
    kf_buf_str(b, value);
}
