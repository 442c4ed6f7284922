/* diag.c — the diagnostics list, compiler-style printing, input sources,
 * and the "did you mean" helpers every message in shot/ shares. */
#include <ctype.h>
#include <stdarg.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* ---- the list ------------------------------------------------------------------ */

void kf_diag_init(kf_diag *d) { memset(d, 0, sizeof *d); }

void kf_diag_free(kf_diag *d) {
    for (int i = 0; i < d->count; i++) {
        free(d->entry[i].file);
        free(d->entry[i].message);
        free(d->entry[i].source);
    }
    free(d->entry);
    memset(d, 0, sizeof *d);
}

static char *dup_or_null(const char *s) { return s ? strdup(s) : NULL; }

static void diag_vadd(kf_diag *d, kf_severity sev, int order, const char *file, int line, int col, const char *source,
                      const char *fmt, va_list ap) {
    if (d->count == d->cap) {
        int cap = d->cap ? 2 * d->cap : 16;
        kf_diag_entry *e = realloc(d->entry, (size_t)cap * sizeof *e);
        if (!e) return; /* out of memory: the count of errors below still says "failed" */
        d->entry = e;
        d->cap = cap;
    }
    char buf[1024];
    vsnprintf(buf, sizeof buf, fmt, ap);
    kf_diag_entry *e = &d->entry[d->count];
    e->severity = sev;
    e->file = dup_or_null(file ? file : "kerf");
    e->line = line;
    e->col = col;
    e->message = strdup(buf);
    e->source = dup_or_null(source);
    e->order = order;
    e->seq = d->count;
    d->count++;
    if (sev == KF_DIAG_ERROR) d->errors++;
    else d->warnings++;
}

void kf_diag_add(kf_diag *d, kf_severity sev, const char *file, int line, int col, const char *source, const char *fmt,
                 ...) {
    va_list ap;
    va_start(ap, fmt);
    diag_vadd(d, sev, 0, file, line, col, source, fmt, ap);
    va_end(ap);
}

/* input first, then position, then discovery order: an artist reads the
 * file top to bottom, and the command line comes after it */
static int entry_cmp(const void *pa, const void *pb) {
    const kf_diag_entry *a = pa, *b = pb;
    if (a->order != b->order) return a->order < b->order ? -1 : 1;
    if (a->line != b->line) return a->line < b->line ? -1 : 1;
    if (a->col != b->col) return a->col < b->col ? -1 : 1;
    return a->seq < b->seq ? -1 : a->seq > b->seq;
}

void kf_diag_sort(kf_diag *d) {
    if (d->count > 1) qsort(d->entry, (size_t)d->count, sizeof *d->entry, entry_cmp);
}

/* ---- printing ------------------------------------------------------------------ */

/* the caret sits under the col-th character: copy tabs so it lines up in any
 * terminal, count UTF-8 continuation bytes as part of their character */
static void print_caret(FILE *f, const char *src, int col) {
    int c = 1;
    const unsigned char *p = (const unsigned char *)src;
    while (c < col) {
        if (*p) {
            fputc(*p == '\t' ? '\t' : ' ', f);
            p++;
            while ((*p & 0xC0) == 0x80) p++;
        } else {
            fputc(' ', f);
        }
        c++;
    }
    fputs("^\n", f);
}

void kf_diag_print_entry(FILE *f, const kf_diag_entry *e) {
    const char *sev = e->severity == KF_DIAG_ERROR ? "error" : "warning";
    if (e->line > 0 && e->col > 0) fprintf(f, "%s:%d:%d: %s: %s\n", e->file, e->line, e->col, sev, e->message);
    else if (e->line > 0) fprintf(f, "%s:%d: %s: %s\n", e->file, e->line, sev, e->message);
    else fprintf(f, "%s: %s: %s\n", e->file, sev, e->message);
    if (e->source && e->line > 0) {
        fprintf(f, "%5d | %s\n", e->line, e->source);
        if (e->col > 0) {
            fputs("      | ", f);
            print_caret(f, e->source, e->col);
        }
    }
}

void kf_diag_print(FILE *f, const kf_diag *d) {
    for (int i = 0; i < d->count; i++) kf_diag_print_entry(f, &d->entry[i]);
}

/* ---- inputs ------------------------------------------------------------------ */

int kf_srcs_add(kf_srcs *s, const char *file, char *text, size_t len, int line, int col0, const char *echo) {
    if (s->n == s->cap) {
        int cap = s->cap ? 2 * s->cap : 8;
        kf_src *v = realloc(s->v, (size_t)cap * sizeof *v);
        if (!v) return -1;
        s->v = v;
        s->cap = cap;
    }
    kf_src *e = &s->v[s->n];
    e->file = strdup(file);
    e->text = text;
    e->len = len;
    e->line = line;
    e->col0 = col0;
    e->echo = dup_or_null(echo);
    e->order = s->n;
    return s->n++;
}

void kf_srcs_free(kf_srcs *s) {
    for (int i = 0; i < s->n; i++) {
        free(s->v[i].file);
        free(s->v[i].text);
        free(s->v[i].echo);
    }
    free(s->v);
    memset(s, 0, sizeof *s);
}

/* the text of a 1-based line of an input, copied into buf */
static const char *line_text(const kf_src *s, int line, char *buf, size_t n) {
    const char *p = s->text, *end = s->text + s->len;
    for (int l = 1; l < line && p < end; l++) {
        const char *nl = memchr(p, '\n', (size_t)(end - p));
        if (!nl) return NULL;
        p = nl + 1;
    }
    if (p > end) return NULL;
    const char *nl = memchr(p, '\n', (size_t)(end - p));
    size_t len = (size_t)((nl ? nl : end) - p);
    if (len && p[len - 1] == '\r') len--;
    if (len >= n) len = n - 1;
    memcpy(buf, p, len);
    buf[len] = '\0';
    return buf;
}

/* where a node of an input prints: a file's own line and column, or a
 * command-line string's ordinal and its column in the whole string */
const char *kf_locate(const kf_srcs *srcs, int src, int line, int col, const char **file, int *pline, int *pcol,
                      char *buf, size_t n) {
    const kf_src *s = src >= 0 && src < srcs->n ? &srcs->v[src] : NULL;
    *file = s ? s->file : NULL;
    *pline = line;
    *pcol = col;
    if (s && s->line > 0) {
        *pline = s->line;
        *pcol = col > 0 ? s->col0 + col : 0;
        return s->echo;
    }
    return s && line > 0 ? line_text(s, line, buf, n) : NULL;
}

void kf_report(kf_diag *d, const kf_srcs *srcs, int src, int line, int col, kf_severity sev, const char *fmt, ...) {
    char buf[1024];
    const char *file;
    int pline, pcol;
    const char *text = kf_locate(srcs, src, line, col, &file, &pline, &pcol, buf, sizeof buf);
    va_list ap;
    va_start(ap, fmt);
    diag_vadd(d, sev, src >= 0 && src < srcs->n ? srcs->v[src].order : 0, file, pline, pcol, text, fmt, ap);
    va_end(ap);
}

void kf_shot_report(kf_diag *d, const kf_loc *at, kf_severity sev, const char *fmt, ...) {
    va_list ap;
    va_start(ap, fmt);
    diag_vadd(d, sev, 0, at ? at->file : NULL, at ? at->line : 0, at ? at->col : 0, at ? at->source : NULL, fmt, ap);
    va_end(ap);
}

/* ---- did you mean ------------------------------------------------------------------ */

int kf_edit_distance(const char *a, const char *b) {
    int n = (int)strlen(a), m = (int)strlen(b);
    if (n > 63 || m > 63) return 99;
    int D[64][64];
    for (int i = 0; i <= n; i++) D[i][0] = i;
    for (int j = 0; j <= m; j++) D[0][j] = j;
    for (int i = 1; i <= n; i++)
        for (int j = 1; j <= m; j++) {
            int cost = tolower((unsigned char)a[i - 1]) != tolower((unsigned char)b[j - 1]);
            int v = D[i - 1][j] + 1;
            if (D[i][j - 1] + 1 < v) v = D[i][j - 1] + 1;
            if (D[i - 1][j - 1] + cost < v) v = D[i - 1][j - 1] + cost;
            if (i > 1 && j > 1 && tolower((unsigned char)a[i - 1]) == tolower((unsigned char)b[j - 2]) &&
                tolower((unsigned char)a[i - 2]) == tolower((unsigned char)b[j - 1]) && D[i - 2][j - 2] + 1 < v)
                v = D[i - 2][j - 2] + 1; /* a transposition is one typo */
            D[i][j] = v;
        }
    return D[n][m];
}

/* close enough: a third of the word may be wrong (at least one letter, at
 * most three), so "dxx" finds "dx" but "foo" does not find "fps" */
const char *kf_suggest(const char *word, const char *const *cand, int n) {
    int wl = (int)strlen(word), best = 99;
    const char *pick = NULL;
    for (int i = 0; n < 0 ? cand[i] != NULL : i < n; i++) {
        int dist = kf_edit_distance(word, cand[i]);
        if (dist < best) best = dist, pick = cand[i];
    }
    int limit = wl / 3;
    if (limit < 1) limit = 1;
    if (limit > 3) limit = 3;
    return best <= limit ? pick : NULL;
}
