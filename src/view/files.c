/* files.c — see files.h. */
#define _DEFAULT_SOURCE /* realpath, getrandom */
#include "files.h"

#include <dirent.h>
#include <errno.h>
#include <fcntl.h>
#include <limits.h>
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

int kf_view_plain_path(const char *rel) {
    size_t n = strlen(rel);
    if (n == 0 || n > 1000 || rel[0] == '/') return 0;
    for (const char *p = rel; *p; p++) {
        char c = *p;
        int ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || strchr("._-+=,@/", c);
        if (!ok) return 0;
    }
    /* every component: not empty, not "." or ".." */
    for (const char *p = rel; *p;) {
        size_t l = strcspn(p, "/");
        if (l == 0 || (l == 1 && p[0] == '.') || (l == 2 && p[0] == '.' && p[1] == '.')) return 0;
        p += l;
        if (*p == '/') {
            p++;
            if (!*p) return 0;
        }
    }
    return 1;
}

int kf_view_open(const char *root_real, const char *rel, int *fd, size_t *size) {
    if (!kf_view_plain_path(rel)) return 400;
    char full[PATH_MAX * 2], real[PATH_MAX];
    snprintf(full, sizeof full, "%s/%s", root_real, rel);
    if (!realpath(full, real)) return errno == ENOENT || errno == ENOTDIR ? 404 : 403;
    /* a symlink may point anywhere: what it resolves to must still be inside */
    size_t rl = strlen(root_real);
    if (strncmp(real, root_real, rl) != 0 || real[rl] != '/') return 403;
    /* non-blocking: a FIFO under the root must not hang the server (it is refused below) */
    int f = open(real, O_RDONLY | O_CLOEXEC | O_NOFOLLOW | O_NONBLOCK);
    if (f < 0) return 404;
    struct stat st;
    if (fstat(f, &st) != 0 || !S_ISREG(st.st_mode)) {
        close(f);
        return 404;
    }
    *fd = f;
    *size = (size_t)st.st_size;
    return 200;
}

/* ---- the walk -------------------------------------------------------------- */

typedef struct png {
    char dir[512];    /* relative to the root ("" for the root) */
    char prefix[256]; /* the name before its last number */
    char name[256];
    long frame;
} png;

/* a set of relative paths */
typedef struct names {
    char (*v)[512];
    size_t n, cap;
} names;

typedef struct walk {
    png *v;
    size_t n, cap;
    names outs;   /* output directories */
    names sheets; /* contact sheets of wedge sets */
} walk;

enum { MAX_DEPTH = 4, MAX_FILES = 50000 };

/* the last run of digits before ".png": the frame number */
static int split_frame(const char *name, png *p) {
    size_t n = strlen(name);
    if (n < 5 || strcmp(name + n - 4, ".png")) return 0;
    size_t e = n - 4, b = e;
    while (b > 0 && name[b - 1] >= '0' && name[b - 1] <= '9') b--;
    if (b == e || e - b > 9) return 0;
    snprintf(p->prefix, sizeof p->prefix, "%.*s", (int)b, name);
    snprintf(p->name, sizeof p->name, "%s", name);
    p->frame = strtol(name + b, NULL, 10);
    return 1;
}

static void add_name(names *l, const char *rel) {
    for (size_t i = 0; i < l->n; i++)
        if (!strcmp(l->v[i], rel)) return;
    if (l->n == l->cap) {
        size_t cap = l->cap ? 2 * l->cap : 16;
        void *v = realloc(l->v, cap * sizeof *l->v);
        if (!v) return;
        l->v = v;
        l->cap = cap;
    }
    snprintf(l->v[l->n++], sizeof *l->v, "%s", rel);
}

static void walk_dir(walk *w, const char *root, const char *rel, int depth) {
    char path[PATH_MAX];
    snprintf(path, sizeof path, "%s%s%s", root, rel[0] ? "/" : "", rel);
    DIR *d = opendir(path);
    if (!d) return;
    struct dirent *e;
    while ((e = readdir(d)) && w->n < MAX_FILES) {
        if (e->d_name[0] == '.') continue;
        char child[PATH_MAX + 256];
        snprintf(child, sizeof child, "%s/%s", path, e->d_name);
        struct stat st;
        if (lstat(child, &st) != 0) continue;
        char crel[512];
        if (snprintf(crel, sizeof crel, "%s%s%s", rel, rel[0] ? "/" : "", e->d_name) >= (int)sizeof crel) continue;
        if (S_ISDIR(st.st_mode)) {
            if (!strcmp(e->d_name, "images") || !strcmp(e->d_name, "checkpoints")) add_name(&w->outs, rel);
            if (depth < MAX_DEPTH) walk_dir(w, root, crel, depth + 1);
        } else if (S_ISREG(st.st_mode)) {
            if (!strcmp(e->d_name, "frames.jsonl") || !strcmp(e->d_name, "run.json") || !strcmp(e->d_name, "view.json"))
                add_name(&w->outs, rel);
            if (!strcmp(e->d_name, "contact_sheet.png") && kf_view_plain_path(crel)) add_name(&w->sheets, crel);
            png p;
            if (!split_frame(e->d_name, &p) || !kf_view_plain_path(crel)) continue;
            snprintf(p.dir, sizeof p.dir, "%s", rel);
            if (w->n == w->cap) {
                size_t cap = w->cap ? 2 * w->cap : 256;
                void *v = realloc(w->v, cap * sizeof *w->v);
                if (!v) break;
                w->v = v;
                w->cap = cap;
            }
            w->v[w->n++] = p;
        }
    }
    closedir(d);
}

static int png_order(const void *a, const void *b) {
    const png *x = a, *y = b;
    int c = strcmp(x->dir, y->dir);
    if (!c) c = strcmp(x->prefix, y->prefix);
    if (!c) c = (x->frame > y->frame) - (x->frame < y->frame);
    return c;
}

static int str_order(const void *a, const void *b) { return strcmp(a, b); }

/* a small JSON file of an output directory, inlined as it is (it is kerf's or kerf view's own) */
static void inline_json(kf_buf *out, const char *root, const char *dir, const char *name, long *pid) {
    char path[PATH_MAX], text[4096];
    snprintf(path, sizeof path, "%s%s%s/%s", root, dir[0] ? "/" : "", dir, name);
    FILE *f = fopen(path, "r");
    size_t n = f ? fread(text, 1, sizeof text - 1, f) : 0;
    if (f) fclose(f);
    text[n] = 0;
    while (n && (text[n - 1] == '\n' || text[n - 1] == ' ')) text[--n] = 0;
    if (n < 2 || text[0] != '{' || text[n - 1] != '}') {
        kf_buf_put(out, "null", 4);
        return;
    }
    kf_buf_put(out, text, n);
    const char *p = pid ? strstr(text, "\"pid\":") : NULL;
    if (p) *pid = strtol(p + 6, NULL, 10);
}

/* A wedge's label: a wedge set's directory lists its wedges in wedges.txt,
 * a line each: "w01<TAB>label<TAB>--set ..." (the wedge is its subdirectory). */
static int wedge_label(const char *root, const char *rel, char *label, size_t n) {
    const char *slash = strrchr(rel, '/'), *base = slash ? slash + 1 : rel;
    char path[PATH_MAX], line[1024];
    snprintf(path, sizeof path, "%s/%.*s%swedges.txt", root, (int)(slash ? slash - rel : 0), rel, slash ? "/" : "");
    FILE *f = fopen(path, "r");
    if (!f) return 0;
    size_t bl = strlen(base);
    int found = 0;
    while (!found && fgets(line, sizeof line, f))
        if (!strncmp(line, base, bl) && line[bl] == '\t') {
            snprintf(label, n, "%.*s", (int)strcspn(line + bl + 1, "\t\n"), line + bl + 1);
            found = 1;
        }
    fclose(f);
    return found;
}

void kf_view_scan(const char *root, kf_buf *out) {
    walk w = {0};
    walk_dir(&w, root, "", 0);
    qsort(w.v, w.n, sizeof *w.v, png_order);
    if (w.outs.n) qsort(w.outs.v, w.outs.n, sizeof *w.outs.v, str_order);
    if (w.sheets.n) qsort(w.sheets.v, w.sheets.n, sizeof *w.sheets.v, str_order);

    kf_buf_put(out, "\"outputs\":[", 11);
    for (size_t i = 0; i < w.outs.n; i++) {
        const char *dir = w.outs.v[i];
        char path[PATH_MAX], label[512];
        kf_buf_printf(out, "%s{", i ? "," : "");
        kf_buf_kv(out, "dir", dir);
        kf_buf_kv(out, "wedge", wedge_label(root, dir, label, sizeof label) ? label : NULL);
        snprintf(path, sizeof path, "%s%s%s/frames.jsonl", root, dir[0] ? "/" : "", dir);
        kf_buf_printf(out, ",\"records\":%s,\"run\":", access(path, R_OK) == 0 ? "true" : "false");
        long pid = 0;
        inline_json(out, root, dir, "run.json", &pid);
        /* the run that wrote run.json still alive (a stopped run never wrote done) */
        int alive = pid > 0 && (kill((pid_t)pid, 0) == 0 || errno == EPERM);
        kf_buf_printf(out, ",\"alive\":%s,\"view\":", alive ? "true" : "false");
        inline_json(out, root, dir, "view.json", NULL);
        kf_buf_put(out, "}", 1);
    }
    kf_buf_put(out, "],\"sheets\":[", 12);
    for (size_t i = 0; i < w.sheets.n; i++) {
        if (i) kf_buf_put(out, ",", 1);
        kf_buf_str(out, w.sheets.v[i]);
    }
    kf_buf_put(out, "],\"sequences\":[", 15);
    for (size_t i = 0, nseq = 0; i < w.n;) {
        size_t j = i;
        while (j < w.n && !strcmp(w.v[j].dir, w.v[i].dir) && !strcmp(w.v[j].prefix, w.v[i].prefix)) j++;
        /* the output directory: the parent of images/ or turntable/, else the directory itself */
        char outdir[512];
        const char *base = strrchr(w.v[i].dir, '/');
        base = base ? base + 1 : w.v[i].dir;
        if (!strcmp(base, "images") || !strcmp(base, "turntable"))
            snprintf(outdir, sizeof outdir, "%.*s", (int)(base == w.v[i].dir ? 0 : base - 1 - w.v[i].dir), w.v[i].dir);
        else snprintf(outdir, sizeof outdir, "%s", w.v[i].dir);
        kf_buf_printf(out, "%s{", nseq++ ? "," : "");
        kf_buf_kv(out, "dir", w.v[i].dir);
        kf_buf_kv(out, "out", outdir);
        kf_buf_kv(out, "kind", !strcmp(base, "turntable") ? "turntable" : "frames");
        kf_buf_kv(out, "prefix", w.v[i].prefix);
        kf_buf_put(out, ",\"frames\":[", 11);
        for (size_t k = i; k < j; k++) kf_buf_printf(out, "%s%ld", k > i ? "," : "", w.v[k].frame);
        kf_buf_put(out, "],\"names\":[", 11);
        for (size_t k = i; k < j; k++) {
            if (k > i) kf_buf_put(out, ",", 1);
            kf_buf_str(out, w.v[k].name);
        }
        kf_buf_put(out, "]}", 2);
        i = j;
    }
    kf_buf_put(out, "]", 1);
    free(w.v);
    free(w.outs.v);
    free(w.sheets.v);
}
