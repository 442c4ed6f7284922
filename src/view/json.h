/* json.h — a growing text buffer that writes JSON: the server's answers are
 * built in one of these and handed to the HTTP library as they are. */
#ifndef KF_VIEW_JSON_H
#define KF_VIEW_JSON_H

#include <stddef.h>

typedef struct kf_buf {
    char *s; /* (len + 1), NUL-terminated; NULL until the first write */
    size_t len, cap;
    int failed; /* an allocation failed: the text is cut short */
} kf_buf;

void kf_buf_free(kf_buf *b);
void kf_buf_put(kf_buf *b, const char *s, size_t n);
void kf_buf_printf(kf_buf *b, const char *fmt, ...) __attribute__((format(printf, 2, 3)));
/* a JSON string (quoted, escaped); NULL writes null */
void kf_buf_str(kf_buf *b, const char *s);
/* "key": "value", with a comma before it unless it is the first of its object */
void kf_buf_kv(kf_buf *b, const char *key, const char *value);

#endif
