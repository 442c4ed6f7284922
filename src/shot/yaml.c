/* yaml.c — YAML/JSON text → a small tree whose every node knows its line and
 * column.
 *
 * libfyaml 0.7's document API does not expose node positions, but its event
 * API gives a start mark for every scalar and collection, so the tree is
 * built from events. Anchors, aliases and merge keys (<<: *base) work; tags
 * are ignored. A syntax error stops the parse (nothing after it can be
 * trusted) and becomes one diagnostic at libfyaml's position. */
#include <libfyaml.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* ---- nodes ------------------------------------------------------------------ */

ky_node *ky_new(ky_doc *doc, ky_kind kind, int src, int line, int col) {
    if (doc->n == doc->cap) {
        size_t cap = doc->cap ? 2 * doc->cap : 64;
        ky_node **all = realloc(doc->all, cap * sizeof *all);
        if (!all) return NULL;
        doc->all = all;
        doc->cap = cap;
    }
    ky_node *n = calloc(1, sizeof *n);
    if (!n) return NULL;
    n->kind = kind;
    n->src = src;
    n->line = line;
    n->col = col;
    doc->all[doc->n++] = n;
    return n;
}

ky_node *ky_scalar(ky_doc *doc, const char *text, int src, int line, int col) {
    ky_node *n = ky_new(doc, KY_SCALAR, src, line, col);
    if (n) n->text = strdup(text);
    return n;
}

void ky_push(ky_node *p, ky_node *child) {
    if (p->n == p->cap) {
        int cap = p->cap ? 2 * p->cap : 8;
        ky_node **item = realloc(p->item, (size_t)cap * sizeof *item);
        if (!item) return;
        p->item = item;
        p->cap = cap;
    }
    p->item[p->n++] = child;
}

ky_node *ky_get(const ky_node *map, const char *key, ky_node **keyp) {
    if (!map || map->kind != KY_MAP) return NULL;
    for (int i = 0; i + 1 < map->n; i += 2) {
        ky_node *k = map->item[i];
        if (k->kind == KY_SCALAR && strcmp(k->text, key) == 0) {
            if (keyp) *keyp = k;
            return map->item[i + 1];
        }
    }
    return NULL;
}

/* YAML's null: nothing, ~ or null (unquoted) */
int ky_is_null(const ky_node *n) {
    if (!n || n->kind != KY_SCALAR || n->quoted) return 0;
    return n->text[0] == '\0' || strcmp(n->text, "~") == 0 || strcmp(n->text, "null") == 0 ||
           strcmp(n->text, "Null") == 0 || strcmp(n->text, "NULL") == 0;
}

void ky_free(ky_doc *doc) {
    for (size_t i = 0; i < doc->n; i++) {
        free(doc->all[i]->text);
        free(doc->all[i]->item);
        free(doc->all[i]);
    }
    free(doc->all);
    memset(doc, 0, sizeof *doc);
}

/* ---- merge keys ------------------------------------------------------------------ */

/* `<<: *base` (or a list of them): the base's pairs join the mapping unless
 * it already has the key; explicit keys come first so they report first */
static void merge_keys(ky_node *map) {
    int has = 0;
    for (int i = 0; i + 1 < map->n; i += 2)
        if (map->item[i]->kind == KY_SCALAR && !map->item[i]->quoted && strcmp(map->item[i]->text, "<<") == 0) has = 1;
    if (!has) return;
    ky_node tmp = {.kind = KY_MAP};
    ky_node *bases[32];
    int nb = 0;
    for (int i = 0; i + 1 < map->n; i += 2) {
        ky_node *k = map->item[i], *v = map->item[i + 1];
        if (k->kind == KY_SCALAR && !k->quoted && strcmp(k->text, "<<") == 0) {
            if (v->kind == KY_MAP && nb < 32) bases[nb++] = v;
            else if (v->kind == KY_SEQ)
                for (int j = 0; j < v->n && nb < 32; j++)
                    if (v->item[j]->kind == KY_MAP) bases[nb++] = v->item[j];
            continue;
        }
        ky_push(&tmp, k);
        ky_push(&tmp, v);
    }
    for (int b = 0; b < nb; b++)
        for (int i = 0; i + 1 < bases[b]->n; i += 2) {
            ky_node *k = bases[b]->item[i];
            if (k->kind == KY_SCALAR && !ky_get(&tmp, k->text, NULL)) {
                ky_push(&tmp, k);
                ky_push(&tmp, bases[b]->item[i + 1]);
            }
        }
    free(map->item);
    map->item = tmp.item;
    map->n = tmp.n;
    map->cap = tmp.cap;
}

/* ---- libfyaml's messages ---------------------------------------------------------- */

typedef struct capture {
    char *buf;
    size_t n, cap;
} capture;

static void capture_out(struct fy_diag *diag, void *user, const char *buf, size_t len) {
    capture *c = user;
    if (c->n + len + 1 > c->cap) {
        size_t cap = (c->n + len + 1) * 2;
        char *b = realloc(c->buf, cap);
        if (!b) return;
        c->buf = b;
        c->cap = cap;
    }
    memcpy(c->buf + c->n, buf, len);
    c->n += len;
    c->buf[c->n] = '\0';
}

/* libfyaml prints "<name>:LINE:COL: error: MESSAGE"; take the first */
static int first_error(const char *text, int *line, int *col, char *msg, size_t n) {
    const char *e = text ? strstr(text, ": error: ") : NULL;
    if (!e) return -1;
    const char *p = e; /* back over ":LINE:COL" */
    int colons = 0;
    while (p > text && colons < 2) {
        p--;
        if (*p == ':') colons++;
        else if (*p < '0' || *p > '9') return -1;
    }
    if (sscanf(p, ":%d:%d", line, col) != 2) return -1;
    const char *m = e + strlen(": error: "), *nl = strchr(m, '\n');
    size_t len = nl ? (size_t)(nl - m) : strlen(m);
    if (len >= n) len = n - 1;
    memcpy(msg, m, len);
    msg[len] = '\0';
    return 0;
}

/* ---- events → tree ------------------------------------------------------------------ */

typedef struct anchor {
    char *name;
    ky_node *node;
} anchor;

static char *token_text(struct fy_token *t) {
    size_t len = 0;
    const char *s = t ? fy_token_get_text(t, &len) : NULL;
    return s ? strndup(s, len) : NULL;
}

ky_node *ky_parse(ky_doc *doc, const kf_srcs *srcs, int src, int json, kf_diag *d, int *empty) {
    const kf_src *in = &srcs->v[src];
    capture cap = {0};
    struct fy_diag_cfg dcfg;
    fy_diag_cfg_default(&dcfg);
    dcfg.fp = NULL;
    dcfg.output_fn = capture_out;
    dcfg.user = &cap;
    dcfg.colorize = false;
    struct fy_diag *fdiag = fy_diag_create(&dcfg);
    struct fy_parse_cfg cfg;
    memset(&cfg, 0, sizeof cfg);
    cfg.flags = FYPCF_QUIET | FYPCF_COLLECT_DIAG | (json ? FYPCF_JSON_FORCE : FYPCF_JSON_NONE);
    cfg.diag = fdiag;
    struct fy_parser *fyp = fdiag ? fy_parser_create(&cfg) : NULL;
    if (!fyp || fy_parser_set_string(fyp, in->text, in->len)) {
        kf_report(d, srcs, src, 0, 0, KF_DIAG_ERROR, "cannot start the YAML parser");
        if (fyp) fy_parser_destroy(fyp);
        if (fdiag) fy_diag_destroy(fdiag);
        return NULL;
    }

    ky_node *root = NULL, *stack[256];
    int depth = 0, docs = 0, failed = 0;
    anchor *anchors = NULL;
    int nanchors = 0;
    struct fy_event *ev;
    while (!failed && (ev = fy_parser_parse(fyp))) {
        const struct fy_mark *mk = fy_event_start_mark(ev);
        int line = mk ? mk->line + 1 : 0, col = mk ? mk->column + 1 : 0;
        ky_node *parent = depth ? stack[depth - 1] : NULL;
        /* an empty value has no mark: point at its key */
        if (!mk && parent) {
            ky_node *ref = parent->kind == KY_MAP && parent->n % 2 == 1 ? parent->item[parent->n - 1] : parent;
            line = ref->line, col = ref->col;
        }
        ky_node *node = NULL;
        struct fy_token *anchor_tok = NULL;
        switch (ev->type) {
        case FYET_DOCUMENT_START:
            if (++docs > 1) {
                kf_report(d, srcs, src, line, col, KF_DIAG_ERROR,
                          "a shot file holds one YAML document; a second one starts here");
                failed = 1;
            }
            break;
        case FYET_SCALAR: {
            node = ky_new(doc, KY_SCALAR, src, line, col);
            node->text = token_text(ev->scalar.value);
            if (!node->text) node->text = strdup("");
            enum fy_scalar_style st = fy_token_scalar_style(ev->scalar.value);
            node->quoted = st != FYSS_PLAIN && st != FYSS_ANY;
            anchor_tok = ev->scalar.anchor;
            break;
        }
        case FYET_MAPPING_START:
        case FYET_SEQUENCE_START:
            node = ky_new(doc, ev->type == FYET_MAPPING_START ? KY_MAP : KY_SEQ, src, line, col);
            anchor_tok = ev->type == FYET_MAPPING_START ? ev->mapping_start.anchor : ev->sequence_start.anchor;
            break;
        case FYET_MAPPING_END:
        case FYET_SEQUENCE_END:
            if (depth > 0) {
                if (stack[depth - 1]->kind == KY_MAP) merge_keys(stack[depth - 1]);
                depth--;
            }
            break;
        case FYET_ALIAS: {
            char *name = token_text(ev->alias.anchor);
            for (int i = nanchors - 1; i >= 0 && !node; i--)
                if (name && strcmp(anchors[i].name, name) == 0) node = anchors[i].node;
            if (!node) {
                kf_report(d, srcs, src, line, col, KF_DIAG_ERROR, "alias *%s names no anchor defined before it",
                          name ? name : "?");
                failed = 1;
            }
            free(name);
            if (node) { /* shared, not re-entered */
                if (parent) ky_push(parent, node);
                else root = node;
                node = NULL;
            }
            break;
        }
        default: break;
        }
        if (node) {
            if (anchor_tok) {
                anchor *a = realloc(anchors, (size_t)(nanchors + 1) * sizeof *a);
                if (a) {
                    anchors = a;
                    anchors[nanchors].name = token_text(anchor_tok);
                    anchors[nanchors].node = node;
                    if (anchors[nanchors].name) nanchors++;
                }
            }
            if (parent) ky_push(parent, node);
            else if (!root) root = node;
            if (node->kind != KY_SCALAR) {
                if (depth == (int)(sizeof stack / sizeof *stack)) {
                    kf_report(d, srcs, src, line, col, KF_DIAG_ERROR, "nested too deeply");
                    failed = 1;
                } else {
                    stack[depth++] = node;
                }
            }
        }
        fy_parser_event_free(fyp, ev);
    }
    if (!failed && fy_parser_get_stream_error(fyp)) {
        int line = 0, col = 0;
        char msg[512];
        if (first_error(cap.buf, &line, &col, msg, sizeof msg) == 0)
            kf_report(d, srcs, src, line, col, KF_DIAG_ERROR, "YAML syntax: %s", msg);
        else kf_report(d, srcs, src, 0, 0, KF_DIAG_ERROR, "YAML syntax error");
        failed = 1;
    }
    for (int i = 0; i < nanchors; i++) free(anchors[i].name);
    free(anchors);
    free(cap.buf);
    fy_parser_destroy(fyp);
    fy_diag_destroy(fdiag);
    if (failed) return NULL;
    if (empty) *empty = root == NULL;
    return root;
}
