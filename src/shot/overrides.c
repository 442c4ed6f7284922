/* overrides.c — what the command line adds to a shot: --set grafts values
 * onto the parsed file before validation (so they are checked by the same
 * table, and their errors point into the --set string), --quality, --frames;
 * and the output templates ({shot}, {version:03d}, {frame:04d}). */
#include <ctype.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* ---- --set path=value ------------------------------------------------------------------ */

/* the pair index of key in a mapping, or -1 */
static int pair_of(const ky_node *map, const char *key) {
    int found = -1; /* the last one: that is the value a reader would take */
    for (int i = 0; i + 1 < map->n; i += 2)
        if (map->item[i]->kind == KY_SCALAR && strcmp(map->item[i]->text, key) == 0) found = i;
    return found;
}

/* an item's name: its own, or the default the loader gives it (shape + index) */
static const char *item_name(const ky_node *item, int index, char *buf, size_t n) {
    const ky_node *name = ky_get(item, "name", NULL), *shape = ky_get(item, "shape", NULL);
    if (name && name->kind == KY_SCALAR) return name->text;
    if (shape && shape->kind == KY_SCALAR && !name) {
        snprintf(buf, n, "%.40s%d", shape->text, index);
        return buf;
    }
    return NULL;
}

/* a list item by its name, else by its index */
static int item_of(const ky_node *seq, const char *seg) {
    char buf[64];
    for (int i = 0; i < seq->n; i++) {
        const char *name = item_name(seq->item[i], i, buf, sizeof buf);
        if (name && strcmp(name, seg) == 0) return i;
    }
    char *end;
    long i = strtol(seg, &end, 10);
    return *seg && !*end && i >= 0 && i < seq->n ? (int)i : -1;
}

static void list_missing(const ky_node *seq, const char *seg, const char *where, int src, int col, kf_srcs *srcs,
                         kf_diag *d) {
    char bufs[64][64];
    const char *names[64];
    char list[512] = "";
    int n = 0;
    for (int i = 0; i < seq->n && n < 64; i++) {
        const char *name = item_name(seq->item[i], i, bufs[n], sizeof bufs[n]);
        if (name) names[n++] = name;
    }
    for (int i = 0; i < n; i++) {
        size_t l = strlen(list);
        snprintf(list + l, sizeof list - l, "%s%s", i ? ", " : "", names[i]);
    }
    const char *near = kf_suggest(seg, names, n);
    if (near)
        kf_report(d, srcs, src, 1, col, KF_DIAG_ERROR, "%s has no item '%s' (did you mean '%s'?)", where, seg, near);
    else
        kf_report(d, srcs, src, 1, col, KF_DIAG_ERROR, "%s has no item '%s'; its items: %s (or an index 0..%d)", where,
                  seg, list, seq->n - 1);
}

int kf_override_apply(ky_doc *doc, ky_node *root, kf_srcs *srcs, const char *text, int ordinal, kf_diag *d) {
    const char *eq = strchr(text, '=');
    int plen = eq ? (int)(eq - text) : (int)strlen(text);
    /* two inputs with one echo: the path (columns from 1) and the value
     * (columns from just after '='), so every node knows its column */
    int psrc = kf_srcs_add(srcs, "--set", NULL, 0, ordinal, 0, text);
    if (psrc < 0) return -1;
    if (!eq || plen == 0) {
        kf_report(d, srcs, psrc, 1, eq ? 1 : plen + 1, KF_DIAG_ERROR,
                  "--set wants path=value (e.g. materials.jelly.E=2e3)");
        return -1;
    }
    char *vtext = strdup(eq + 1);
    int vsrc = vtext ? kf_srcs_add(srcs, "--set", vtext, strlen(vtext), ordinal, plen + 1, text) : -1;
    if (vsrc < 0) return -1;
    int empty = 0;
    ky_node *value = ky_parse(doc, srcs, vsrc, 0, d, &empty);
    if (!value && !empty) return -1;
    if (!value) value = ky_scalar(doc, "", vsrc, 1, 1); /* "E=": nothing, reported by the walk */

    ky_node *cur = root;
    char tp[256] = "", seg[96], where[192] = "";
    for (int off = 0; off < plen;) {
        int len = 0;
        while (off + len < plen && text[off + len] != '.') len++;
        int col = off + 1, last = off + len >= plen;
        if (len == 0 || len >= (int)sizeof seg) {
            kf_report(d, srcs, psrc, 1, col, KF_DIAG_ERROR, "--set: %s key in the path", len ? "overlong" : "empty");
            return -1;
        }
        snprintf(seg, sizeof seg, "%.*s", len, text + off);
        char child_tp[400];
        if (cur->kind == KY_MAP) {
            int e = tp[0] ? kf_key_find(tp) : -1;
            if (e >= 0 && kf_keys[e].type == KT_DICT) snprintf(child_tp, sizeof child_tp, "%.250s.*", tp);
            else snprintf(child_tp, sizeof child_tp, "%.250s%s%s", tp, tp[0] ? "." : "", seg);
            int p = pair_of(cur, seg);
            if (last) {
                if (p >= 0) cur->item[p + 1] = value;
                else ky_push(cur, ky_scalar(doc, seg, psrc, 1, col)), ky_push(cur, value);
                return 0;
            }
            ky_node *next = p >= 0 ? cur->item[p + 1] : NULL;
            int ce = kf_key_find(child_tp);
            if (!next || ky_is_null(next)) {
                if (ce >= 0 && kf_keys[ce].type == KT_LIST) {
                    kf_report(d, srcs, psrc, 1, off + len + 2, KF_DIAG_ERROR, "%s%s%s has no items to set", where,
                              where[0] ? "." : "", seg);
                    return -1;
                }
                next = ky_new(doc, KY_MAP, psrc, 1, col);
                if (p >= 0) cur->item[p + 1] = next;
                else ky_push(cur, ky_scalar(doc, seg, psrc, 1, col)), ky_push(cur, next);
            }
            cur = next;
            snprintf(tp, sizeof tp, "%.250s", child_tp);
        } else if (cur->kind == KY_SEQ) {
            int i = item_of(cur, seg);
            if (i < 0) {
                list_missing(cur, seg, where, psrc, col, srcs, d);
                return -1;
            }
            size_t tl = strlen(tp);
            snprintf(tp + tl, sizeof tp - tl, "[]");
            if (last) {
                cur->item[i] = value;
                return 0;
            }
            cur = cur->item[i];
        }
        if (cur->kind == KY_SCALAR) {
            kf_report(d, srcs, psrc, 1, col, KF_DIAG_ERROR, "--set: %.*s is a single value in the shot, not a mapping",
                      off + len, text);
            return -1;
        }
        size_t wl = strlen(where);
        snprintf(where + wl, sizeof where - wl, "%s%s", wl ? "." : "", seg);
        off += len + 1;
    }
    return 0;
}

/* ---- --quality, --frames ------------------------------------------------------------------ */

int kf_quality_parse(const char *text, kf_srcs *srcs, kf_quality *q, kf_diag *d) {
    *q = KF_QUALITY_FINAL;
    if (!text) return 0;
    static const char *const names[] = {"final", "preview", NULL};
    for (int i = 0; names[i]; i++)
        if (strcmp(text, names[i]) == 0) return *q = (kf_quality)i, 0;
    int src = kf_srcs_add(srcs, "--quality", NULL, 0, 1, 0, text);
    const char *near = kf_suggest(text, names, -1);
    kf_report(d, srcs, src, 1, 1, KF_DIAG_ERROR, "unknown quality '%s'%s%s%s; choose preview or final", text,
              near ? " (did you mean '" : "", near ? near : "", near ? "'?)" : "");
    return -1;
}

/* "1001-1010" or "1005": a sub-range of the shot's frames */
int kf_frames_parse(const char *text, kf_srcs *srcs, int start, int end, int *first, int *last, kf_diag *d) {
    int src = kf_srcs_add(srcs, "--frames", NULL, 0, 1, 0, text);
    const char *p = text;
    char *e1, *e2;
    long a = strtol(p, &e1, 10), b = a;
    const char *bpos = text;
    int bad = e1 == p || !isdigit((unsigned char)*p);
    if (!bad && *e1 == '-') {
        bpos = e1 + 1;
        b = strtol(bpos, &e2, 10);
        bad = e2 == bpos || !isdigit((unsigned char)*bpos) || *e2;
        if (bad) e1 = e2 == bpos ? (char *)bpos : e2;
    } else if (!bad && *e1) {
        bad = 1;
    }
    if (bad) {
        kf_report(d, srcs, src, 1, (int)(e1 - text) + 1, KF_DIAG_ERROR,
                  "--frames wants FIRST-LAST or one frame (e.g. 1001-1010), got '%s'", text);
        return -1;
    }
    int bcol = (int)(bpos - text) + 1;
    if (b < a) {
        kf_report(d, srcs, src, 1, bcol, KF_DIAG_ERROR, "--frames: last frame %ld is before first frame %ld", b, a);
        return -1;
    }
    if (a < start || a > end) {
        kf_report(d, srcs, src, 1, 1, KF_DIAG_ERROR, "--frames: frame %ld is outside the shot's frames %d-%d", a, start,
                  end);
        return -1;
    }
    if (b > end) {
        kf_report(d, srcs, src, 1, bcol, KF_DIAG_ERROR, "--frames: frame %ld is after the shot's last frame %d", b,
                  end);
        return -1;
    }
    *first = (int)a;
    *last = (int)b;
    return 0;
}

/* ---- templates ------------------------------------------------------------------ */

/* One pass serves both: with out == NULL it only checks. */
static int tmpl_run(const char *t, const kf_shot *s, int frame, char *out, size_t outlen, int *at, char *msg,
                    size_t msglen) {
    size_t o = 0;
#define PUT(str)                                                                                                       \
    do {                                                                                                               \
        if (out) {                                                                                                     \
            size_t l_ = strlen(str);                                                                                   \
            if (o + l_ >= outlen) return snprintf(msg, msglen, "the expansion is too long"), -1;                       \
            memcpy(out + o, str, l_ + 1);                                                                              \
            o += l_;                                                                                                   \
        }                                                                                                              \
    } while (0)
    for (const char *p = t; *p;) {
        *at = (int)(p - t);
        if ((p[0] == '{' && p[1] == '{') || (p[0] == '}' && p[1] == '}')) {
            char c[2] = {p[0], 0};
            PUT(c);
            p += 2;
            continue;
        }
        if (*p == '}') return snprintf(msg, msglen, "a lone '}' (write }} for a brace)"), -1;
        if (*p != '{') {
            char c[2] = {p[0], 0};
            PUT(c);
            p++;
            continue;
        }
        const char *close = strchr(p, '}');
        if (!close) return snprintf(msg, msglen, "'{' is not closed (write {{ for a brace)"), -1;
        char field[32] = "", spec[32] = "";
        size_t flen = strcspn(p + 1, ":}");
        if (flen >= sizeof field) flen = sizeof field - 1;
        memcpy(field, p + 1, flen);
        field[flen] = '\0';
        if (p[1 + flen] == ':') snprintf(spec, sizeof spec, "%.*s", (int)(close - (p + 2 + flen)), p + 2 + flen);
        int is_shot = strcmp(field, "shot") == 0, is_ver = strcmp(field, "version") == 0,
            is_frame = strcmp(field, "frame") == 0;
        if (!is_shot && !is_ver && !is_frame)
            return snprintf(msg, msglen, "unknown field {%s}; use {shot}, {version} or {frame}", field), -1;
        int width = 0, zero = 0;
        if (spec[0] || p[1 + flen] == ':') {
            const char *q = spec;
            if (is_shot) return snprintf(msg, msglen, "{shot} takes no format"), -1;
            if (*q == '0') zero = 1, q++;
            /* capped as it is read: a long run of digits must not overflow (fuzz_shot) */
            for (; isdigit((unsigned char)*q); q++) width = width > 12 ? 13 : width * 10 + (*q - '0');
            if (strcmp(q, "d") != 0 || width > 12)
                return snprintf(msg, msglen, "bad format '%s' in {%s:...}; write e.g. {%s:04d}", spec, field, field),
                       -1;
        }
        char val[80];
        if (is_shot) snprintf(val, sizeof val, "%s", s ? s->name : "");
        else snprintf(val, sizeof val, zero ? "%0*d" : "%*d", width, is_ver ? (s ? s->version : 0) : frame);
        PUT(val);
        p = close + 1;
    }
#undef PUT
    return 0;
}

int kf_template_check(const char *tmpl, int *at, char *msg, size_t n) {
    return tmpl_run(tmpl, NULL, 0, NULL, 0, at, msg, n);
}

int kf_shot_expand(const char *tmpl, const kf_shot *shot, int frame, char *out, size_t outlen) {
    int at;
    char msg[128];
    if (!out || outlen == 0) return -1;
    out[0] = '\0';
    if (tmpl_run(tmpl, shot, frame, out, outlen, &at, msg, sizeof msg)) {
        out[0] = '\0';
        return -1;
    }
    return 0;
}
