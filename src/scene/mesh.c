/* mesh.c — load, weld, check and orient triangle meshes (see mesh.h).
 *
 * assimp reads the formats; everything after that is ours, because assimp
 * accepts broken files quietly (a truncated OFF loads with faces of zero
 * vertices, a truncated ASCII PLY repeats its last face, garbage OBJ gives no
 * mesh and no error) and does not weld STL. So: PLY and OFF headers are checked
 * against the data that follows them, every face and index is checked, and the
 * surface is welded by exact position before its edges are counted. */
#include "mesh.h"

#include <errno.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>

#include <assimp/cimport.h>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

/* "path: reason" into err */
static int fail(char *err, size_t errlen, const char *path, const char *fmt, ...) {
    if (!err || !errlen) return -1;
    int k = snprintf(err, errlen, "%s: ", path);
    if (k < 0 || (size_t)k >= errlen) return -1;
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(err + k, errlen - (size_t)k, fmt, ap);
    va_end(ap);
    return -1;
}

void kf_mesh_free(kf_mesh *m) {
    if (!m) return;
    free(m->vert);
    free(m->tri);
    memset(m, 0, sizeof *m);
}

int kf_mesh_copy(const kf_mesh *src, kf_mesh *dst) {
    kf_mesh c = *src;
    c.vert = malloc((src->nvert ? src->nvert : 1) * 3 * sizeof *c.vert);
    c.tri = malloc((src->ntri ? src->ntri : 1) * 3 * sizeof *c.tri);
    if (!c.vert || !c.tri) {
        free(c.vert);
        free(c.tri);
        return -1;
    }
    memcpy(c.vert, src->vert, src->nvert * 3 * sizeof *c.vert);
    memcpy(c.tri, src->tri, src->ntri * 3 * sizeof *c.tri);
    *dst = c;
    return 0;
}

/* ---- header checks: is the file as long as its header says? ------------ */

/* non-empty lines from the current position (OFF: '#' comments skipped) */
static long count_data_lines(FILE *f, int skip_comments) {
    long lines = 0;
    int c, seen = 0, comment = 0;
    while ((c = getc(f)) != EOF) {
        if (c == '\n') {
            lines += seen;
            seen = comment = 0;
        } else if (!seen && !comment && skip_comments && c == '#') {
            comment = 1;
        } else if (!comment && c != ' ' && c != '\t' && c != '\r') {
            seen = 1;
        }
    }
    return lines + seen;
}

static int ply_type_size(const char *t) {
    static const struct {
        const char *name;
        int size;
    } types[] = {{"char", 1},   {"int8", 1},    {"uchar", 1},  {"uint8", 1},  {"short", 2}, {"int16", 2},
                 {"ushort", 2}, {"uint16", 2},  {"int", 4},    {"int32", 4},  {"uint", 4},  {"uint32", 4},
                 {"float", 4},  {"float32", 4}, {"double", 8}, {"float64", 8}};
    for (size_t i = 0; i < sizeof types / sizeof types[0]; i++)
        if (!strcmp(t, types[i].name)) return types[i].size;
    return 0;
}

static int check_off_data(FILE *f, long nv, long nf, long lineno, char *why, size_t whylen);

/* PLY: element counts against the data. 0 = consistent (or not checkable). */
static int check_ply(FILE *f, long fsize, char *why, size_t whylen) {
    char line[512], fmt[64] = "";
    double need_bytes = 0, cur_fixed = 0, cur_min = 0, cur_count = 0;
    long nlines_needed = 0, nvert = -1, nface = -1;
    int in_element = 0, ok_types = 1;
    char cur_name[64] = "";
    /* the common layout: vertex (>= 3 scalars), then face (one list), nothing else */
    int nelem = 0, vert_first = 0, face_second = 0, vert_scalars = 0, face_props = 0, face_list = 0;
    if (!fgets(line, sizeof line, f) || strncmp(line, "ply", 3)) return 0;
    for (;;) {
        if (!fgets(line, sizeof line, f)) { /* assimp 5.2 loops forever on this */
            snprintf(why, whylen, "truncated file: the PLY header has no end_header");
            return -1;
        }
        char a[64] = "", b[64] = "", c[64] = "", d[64] = "";
        int n = sscanf(line, "%63s %63s %63s %63s", a, b, c, d);
        if (n <= 0) continue;
        if (!strcmp(a, "format") && n >= 2) {
            snprintf(fmt, sizeof fmt, "%s", b);
        } else if (!strcmp(a, "element") && n >= 3) {
            if (in_element) need_bytes += cur_count * (cur_fixed + cur_min);
            cur_count = atof(c);
            cur_fixed = cur_min = 0;
            in_element = 1;
            snprintf(cur_name, sizeof cur_name, "%s", b);
            nelem++;
            if (nelem == 1) vert_first = !strcmp(b, "vertex");
            if (nelem == 2) face_second = !strcmp(b, "face");
            nlines_needed += (long)cur_count;
            if (!strcmp(b, "vertex")) nvert = (long)cur_count;
            if (!strcmp(b, "face")) nface = (long)cur_count;
        } else if (!strcmp(a, "property") && in_element) {
            if (!strcmp(b, "list") && n >= 4) {
                int cs = ply_type_size(c), is = ply_type_size(d);
                if (!cs || !is) ok_types = 0;
                /* a face lists at least three vertices; other lists may be empty */
                cur_min += cs + (!strcmp(cur_name, "face") ? 3 * is : 0);
                if (!strcmp(cur_name, "face")) face_props++, face_list = 1;
            } else if (n >= 3) {
                int s = ply_type_size(b);
                if (!s) ok_types = 0;
                cur_fixed += s;
                if (!strcmp(cur_name, "vertex")) vert_scalars++;
                if (!strcmp(cur_name, "face")) face_props++;
            }
        } else if (!strcmp(a, "end_header")) {
            break;
        }
    }
    if (in_element) need_bytes += cur_count * (cur_fixed + cur_min);
    long header = ftell(f);
    if (!strcmp(fmt, "ascii")) {
        long have = count_data_lines(f, 0);
        if (have < nlines_needed) {
            snprintf(why, whylen, "truncated file: header declares %ld vertices and %ld faces, %ld data lines follow",
                     nvert, nface, have);
            return -1;
        }
        /* every line of the common layout, as for OFF: assimp 5.2 asked for a
         * 960 MB block for a 23 KB file with vertex lines where faces should
         * be (tests/fuzz/crashes) */
        if (nelem == 2 && vert_first && face_second && vert_scalars >= 3 && face_props == 1 && face_list) {
            long lineno = 0;
            rewind(f);
            for (long i = 0; i < header; i++)
                if (getc(f) == '\n') lineno++;
            return check_off_data(f, nvert, nface, lineno, why, whylen);
        }
    } else if (ok_types && (!strcmp(fmt, "binary_little_endian") || !strcmp(fmt, "binary_big_endian"))) {
        long have = fsize - header;
        if ((double)have < need_bytes) {
            snprintf(why, whylen,
                     "truncated file: header declares %ld vertices and %ld faces, needing at least %.0f bytes of data, "
                     "%ld follow",
                     nvert, nface, need_bytes, have);
            return -1;
        }
    }
    return 0;
}

/* the next data line (blank lines and '#' comments skipped, a trailing
 * comment cut off) into *buf; its number in *lineno. 0 at end of file. */
static int off_data_line(FILE *f, char **buf, size_t *cap, long *lineno) {
    while (getline(buf, cap, f) != -1) {
        ++*lineno;
        char *hash = strchr(*buf, '#');
        if (hash) *hash = 0;
        if ((*buf)[strspn(*buf, " \t\r\n")]) return 1;
    }
    return 0;
}

/* OFF data after the counts: nv vertex lines of at least three numbers, then
 * nf face lines "k i1 ... ik" with every index a vertex of the file. assimp
 * 5.2 reads a face line it cannot parse (a letter, a vertex count larger than
 * the indices given) past its buffers and crashes (tests/fuzz/crashes). */
static int check_off_data(FILE *f, long nv, long nf, long lineno, char *why, size_t whylen) {
    char *buf = NULL;
    size_t cap = 0;
    int bad = 0;
    for (long i = 0; i < nv && !bad; i++) {
        if (!off_data_line(f, &buf, &cap, &lineno)) break; /* counted before: cannot happen */
        char *p = buf, *end;
        for (int d = 0; d < 3 && !bad; d++, p = end) {
            (void)strtod(p, &end);
            if (end == p) {
                snprintf(why, whylen, "line %ld: vertex %ld has %d coordinates, not 3 (corrupt file?)", lineno, i, d);
                bad = 1;
            }
        }
    }
    for (long i = 0; i < nf && !bad; i++) {
        if (!off_data_line(f, &buf, &cap, &lineno)) break;
        char *p = buf, *end;
        long k = strtol(p, &end, 10);
        if (end == p || k < 0 || (*end && !strchr(" \t\r\n", *end))) {
            snprintf(why, whylen, "line %ld: face %ld does not start with its vertex count (corrupt file?)", lineno, i);
            bad = 1;
        }
        for (long j = 0; j < k && !bad; j++) {
            p = end;
            long v = strtol(p, &end, 10);
            if (end == p) {
                snprintf(why, whylen, "line %ld: face %ld lists %ld vertices but gives %ld (corrupt file?)", lineno, i,
                         k, j);
                bad = 1;
            } else if (v < 0 || v >= nv) {
                snprintf(why, whylen, "line %ld: face %ld uses vertex %ld of %ld (truncated or corrupt file?)", lineno,
                         i, v, nv);
                bad = 1;
            }
        }
    }
    free(buf);
    return bad ? -1 : 0;
}

/* OFF: "OFF" (or COFF, NOFF, ...), then "nv nf ne", then nv + nf lines.
 * assimp 5.2 also reads a file without the keyword (counts first), so that
 * is checked the same way. */
static int check_off(FILE *f, char *why, size_t whylen) {
    char tok[64];
    if (fscanf(f, "%63s", tok) != 1) return 0;
    size_t L = strlen(tok);
    int keyword = L >= 3 && !strcmp(tok + L - 3, "OFF");
    if (keyword) {
        /* binary OFF is not line based */
        long pos = ftell(f);
        if (fscanf(f, "%63s", tok) == 1 && !strcmp(tok, "BINARY")) return 0;
        fseek(f, pos, SEEK_SET);
    } else {
        rewind(f);
    }
    long counts[3] = {0, 0, 0};
    int got = 0;
    while (got < 3) {
        int c = getc(f);
        if (c == EOF) break;
        if (c == '#') {
            while (c != '\n' && c != EOF) c = getc(f);
            continue;
        }
        if (c == ' ' || c == '\t' || c == '\r' || c == '\n') continue;
        ungetc(c, f);
        if (fscanf(f, "%ld", &counts[got]) != 1) break;
        got++;
        if (got == 2) { /* the edge count is optional: stop at the end of this line */
            while ((c = getc(f)) == ' ' || c == '\t' || c == '\r') {
            }
            if (c == '\n' || c == EOF) break;
            ungetc(c, f);
        }
    }
    if (got < 2 || counts[0] < 0 || counts[1] < 0) {
        snprintf(why, whylen,
                 keyword ? "truncated file: no vertex and face counts after the OFF keyword"
                         : "not an OFF file: no OFF keyword and no vertex and face counts");
        return -1;
    }
    /* lines before the one the data starts in (for messages: the next line read is lineno + 1) */
    long data = ftell(f), lineno = 0;
    rewind(f);
    for (long i = 0; i < data; i++)
        if (getc(f) == '\n') lineno++;
    long have = count_data_lines(f, 1);
    if (have < counts[0] + counts[1]) {
        snprintf(why, whylen, "truncated file: header declares %ld vertices and %ld faces, %ld data lines follow",
                 counts[0], counts[1], have);
        return -1;
    }
    fseek(f, data, SEEK_SET);
    return check_off_data(f, counts[0], counts[1], lineno, why, whylen);
}

/* binary STL: 80-byte header, triangle count, 50 bytes per triangle. A file
 * that starts with "solid" is taken as ASCII (left to assimp). */
static int check_stl(FILE *f, long fsize, char *why, size_t whylen) {
    unsigned char head[84];
    if (fsize < 84 || fread(head, 1, 84, f) != 84 || !strncmp((const char *)head, "solid", 5)) return 0;
    uint32_t n = (uint32_t)head[80] | (uint32_t)head[81] << 8 | (uint32_t)head[82] << 16 | (uint32_t)head[83] << 24;
    long need = 84 + 50 * (long)n;
    if (fsize < need) {
        snprintf(why, whylen, "truncated file: header declares %u triangles (%ld bytes), the file has %ld", n, need,
                 fsize);
        return -1;
    }
    return 0;
}

/* ---- welding, edges, orientation ------------------------------------------ */

typedef struct wv {
    double p[3];
    uint32_t i;
} wv;

static int cmp_wv(const void *a, const void *b) {
    const wv *x = a, *y = b;
    for (int k = 0; k < 3; k++)
        if (x->p[k] != y->p[k]) return x->p[k] < y->p[k] ? -1 : 1;
    return x->i < y->i ? -1 : x->i > y->i;
}

typedef struct edge_ref {
    uint64_t key; /* min << 32 | max */
    uint32_t tri;
    uint8_t fwd; /* 1 when the triangle walks min -> max */
} edge_ref;

static int cmp_edge(const void *a, const void *b) {
    const edge_ref *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return x->tri < y->tri ? -1 : x->tri > y->tri;
}

static double tri_signed_volume(const double *v, const uint32_t *t, const double c[3]) {
    const double *a = &v[3 * t[0]], *b = &v[3 * t[1]], *d = &v[3 * t[2]];
    double p[3], q[3], r[3];
    for (int k = 0; k < 3; k++) p[k] = a[k] - c[k], q[k] = b[k] - c[k], r[k] = d[k] - c[k];
    return (p[0] * (q[1] * r[2] - q[2] * r[1]) - p[1] * (q[0] * r[2] - q[2] * r[0]) +
            p[2] * (q[0] * r[1] - q[1] * r[0])) /
           6.0;
}

static double tri_area(const double *v, const uint32_t *t) {
    const double *a = &v[3 * t[0]], *b = &v[3 * t[1]], *d = &v[3 * t[2]];
    double e[3], f[3];
    for (int k = 0; k < 3; k++) e[k] = b[k] - a[k], f[k] = d[k] - a[k];
    double x = e[1] * f[2] - e[2] * f[1], y = e[2] * f[0] - e[0] * f[2], z = e[0] * f[1] - e[1] * f[0];
    return 0.5 * sqrt(x * x + y * y + z * z);
}

static void update_measures(kf_mesh *m) {
    for (int k = 0; k < 3; k++) m->lo[k] = m->nvert ? INFINITY : 0, m->hi[k] = m->nvert ? -INFINITY : 0;
    for (size_t i = 0; i < m->nvert; i++)
        for (int k = 0; k < 3; k++) {
            double x = m->vert[3 * i + k];
            if (x < m->lo[k]) m->lo[k] = x;
            if (x > m->hi[k]) m->hi[k] = x;
        }
    double c[3], vol = 0, area = 0;
    for (int k = 0; k < 3; k++) c[k] = 0.5 * (m->lo[k] + m->hi[k]);
    for (size_t t = 0; t < m->ntri; t++) {
        vol += tri_signed_volume(m->vert, &m->tri[3 * t], c);
        area += tri_area(m->vert, &m->tri[3 * t]);
    }
    m->volume = vol;
    m->area = area;
}

static void flip_tri(uint32_t *t) {
    uint32_t s = t[1];
    t[1] = t[2];
    t[2] = s;
}

/* Count boundary and non-manifold edges; orient each edge-connected piece
 * consistently (breadth first over manifold edges) and, when the piece is
 * closed, outward (positive volume). -1 only when out of memory. */
static int analyse_edges(kf_mesh *m) {
    size_t ne = 3 * m->ntri;
    edge_ref *e = malloc((ne ? ne : 1) * sizeof *e);
    uint32_t *nbr = malloc((ne ? ne : 1) * sizeof *nbr);  /* neighbour across edge 3t+k, or UINT32_MAX */
    uint8_t *same = malloc((ne ? ne : 1) * sizeof *same); /* 1: neighbour walks the edge the same way */
    int32_t *comp = malloc((m->ntri ? m->ntri : 1) * sizeof *comp);
    uint8_t *flip = calloc(m->ntri ? m->ntri : 1, 1);
    uint32_t *queue = malloc((m->ntri ? m->ntri : 1) * sizeof *queue);
    if (!e || !nbr || !same || !comp || !flip || !queue) {
        free(e), free(nbr), free(same), free(comp), free(flip), free(queue);
        return -1;
    }
    for (size_t t = 0; t < m->ntri; t++)
        for (int k = 0; k < 3; k++) {
            uint32_t a = m->tri[3 * t + k], b = m->tri[3 * t + (k + 1) % 3];
            uint32_t lo = a < b ? a : b, hi = a < b ? b : a;
            e[3 * t + k] = (edge_ref){((uint64_t)lo << 32) | hi, (uint32_t)t, (uint8_t)(a < b)};
            nbr[3 * t + k] = UINT32_MAX;
        }
    /* sort so the uses of each edge are adjacent; the slot of each use in its
     * triangle is found again below */
    qsort(e, ne, sizeof *e, cmp_edge);
    m->boundary_edges = m->nonmanifold_edges = 0;
    for (size_t i = 0; i < ne;) {
        size_t j = i + 1;
        while (j < ne && e[j].key == e[i].key) j++;
        size_t uses = j - i;
        if (uses == 1) m->boundary_edges++;
        if (uses >= 3) m->nonmanifold_edges++;
        if (uses == 2) {
            for (int s = 0; s < 2; s++) {
                const edge_ref *me = &e[i + s], *other = &e[i + 1 - s];
                const uint32_t *t = &m->tri[3 * (size_t)me->tri];
                uint32_t a = (uint32_t)(me->key >> 32), b = (uint32_t)me->key;
                for (int k = 0; k < 3; k++) {
                    uint32_t p = t[k], q = t[(k + 1) % 3];
                    if ((p == a && q == b) || (p == b && q == a)) {
                        nbr[3 * (size_t)me->tri + k] = other->tri;
                        same[3 * (size_t)me->tri + k] = me->fwd == other->fwd;
                        break;
                    }
                }
            }
        }
        i = j;
    }
    free(e);
    m->closed = m->ntri > 0 && m->boundary_edges == 0 && m->nonmanifold_edges == 0;

    /* breadth-first orientation per piece */
    for (size_t t = 0; t < m->ntri; t++) comp[t] = -1;
    int ncomp = 0, consistent = 1;
    double c[3];
    for (int k = 0; k < 3; k++) c[k] = 0.5 * (m->lo[k] + m->hi[k]);
    for (size_t seed = 0; seed < m->ntri; seed++) {
        if (comp[seed] >= 0) continue;
        size_t head = 0, tail = 0;
        queue[tail++] = (uint32_t)seed;
        comp[seed] = ncomp;
        int piece_closed = 1;
        while (head < tail) {
            uint32_t f = queue[head++];
            for (int k = 0; k < 3; k++) {
                uint32_t g = nbr[3 * (size_t)f + k];
                if (g == UINT32_MAX) {
                    piece_closed = 0; /* boundary or non-manifold edge */
                    continue;
                }
                uint8_t want = flip[f] ^ same[3 * (size_t)f + k];
                if (comp[g] < 0) {
                    comp[g] = ncomp;
                    flip[g] = want;
                    queue[tail++] = g;
                } else if (flip[g] != want) {
                    consistent = 0; /* non-orientable (or self-contradicting) piece */
                }
            }
        }
        /* a closed piece faces outward: positive volume */
        if (piece_closed) {
            double vol = 0;
            for (size_t q = 0; q < tail; q++) {
                uint32_t tt[3], f = queue[q];
                memcpy(tt, &m->tri[3 * (size_t)f], sizeof tt);
                if (flip[f]) flip_tri(tt);
                vol += tri_signed_volume(m->vert, tt, c);
            }
            if (vol < 0)
                for (size_t q = 0; q < tail; q++) flip[queue[q]] ^= 1;
        }
        ncomp++;
    }
    m->flipped_tris = 0;
    for (size_t t = 0; t < m->ntri; t++)
        if (flip[t]) {
            flip_tri(&m->tri[3 * t]);
            m->flipped_tris++;
        }
    m->components = ncomp;
    m->oriented = consistent;
    free(nbr), free(same), free(comp), free(flip), free(queue);
    return 0;
}

typedef struct tkey {
    uint32_t v[3]; /* sorted */
    uint32_t t;
} tkey;

static int cmp_tkey(const void *a, const void *b) {
    const tkey *x = a, *y = b;
    for (int k = 0; k < 3; k++)
        if (x->v[k] != y->v[k]) return x->v[k] < y->v[k] ? -1 : 1;
    return x->t < y->t ? -1 : x->t > y->t;
}

/* remove repeated triangles (same three vertices), keeping the first; returns
 * the new count, or SIZE_MAX when out of memory */
static size_t drop_duplicates(uint32_t *tri, size_t nt, size_t *ndup) {
    tkey *k = malloc((nt ? nt : 1) * sizeof *k);
    uint8_t *dup = calloc(nt ? nt : 1, 1);
    if (!k || !dup) {
        free(k), free(dup);
        return SIZE_MAX;
    }
    for (size_t t = 0; t < nt; t++) {
        uint32_t a = tri[3 * t], b = tri[3 * t + 1], c = tri[3 * t + 2], s;
        if (a > b) s = a, a = b, b = s;
        if (b > c) s = b, b = c, c = s;
        if (a > b) s = a, a = b, b = s;
        k[t] = (tkey){{a, b, c}, (uint32_t)t};
    }
    qsort(k, nt, sizeof *k, cmp_tkey);
    for (size_t i = 1; i < nt; i++)
        if (!memcmp(k[i].v, k[i - 1].v, sizeof k[i].v)) dup[k[i].t] = 1;
    size_t n = 0;
    for (size_t t = 0; t < nt; t++)
        if (!dup[t]) memmove(&tri[3 * n++], &tri[3 * t], 3 * sizeof *tri);
    *ndup = nt - n;
    free(k), free(dup);
    return n;
}

/* Weld by exact position, drop degenerate triangles and unused vertices,
 * then measure and orient. Takes ownership of vert and tri. */
static int finish(kf_mesh *m, double *vert, size_t nvert, uint32_t *tri, size_t ntri, char *err, size_t errlen) {
    char path[sizeof m->path];
    memcpy(path, m->path, sizeof path); /* m is cleared on failure */
    for (size_t i = 0; i < 3 * nvert; i++)
        if (!isfinite(vert[i])) {
            free(vert), free(tri);
            return fail(err, errlen, path, "vertex %zu has a non-finite coordinate", i / 3);
        }
    for (size_t i = 0; i < 3 * ntri; i++)
        if (tri[i] >= nvert) {
            uint32_t bad = tri[i];
            free(vert), free(tri);
            return fail(err, errlen, path, "face %zu uses vertex %u of %zu (corrupt file?)", i / 3, bad, nvert);
        }
    wv *w = malloc((nvert ? nvert : 1) * sizeof *w);
    uint32_t *rep = malloc((nvert ? nvert : 1) * sizeof *rep);
    if (!w || !rep) goto oom;
    for (size_t i = 0; i < nvert; i++) {
        for (int k = 0; k < 3; k++) w[i].p[k] = vert[3 * i + k] + 0.0; /* -0 == +0 */
        w[i].i = (uint32_t)i;
    }
    qsort(w, nvert, sizeof *w, cmp_wv);
    size_t groups = 0;
    for (size_t i = 0; i < nvert; groups++) {
        size_t j = i + 1;
        while (j < nvert && !memcmp(w[j].p, w[i].p, sizeof w[i].p)) j++;
        for (size_t k = i; k < j; k++) rep[w[k].i] = w[i].i; /* the first in file order */
        i = j;
    }
    free(w);
    w = NULL;
    size_t nt = 0;
    for (size_t t = 0; t < ntri; t++) {
        uint32_t a = rep[tri[3 * t]], b = rep[tri[3 * t + 1]], c = rep[tri[3 * t + 2]];
        if (a == b || b == c || a == c) continue;
        tri[3 * nt] = a, tri[3 * nt + 1] = b, tri[3 * nt + 2] = c;
        nt++;
    }
    m->dropped_tris = ntri - nt;
    /* the same triangle twice (either orientation) is dropped: it would make
     * its edges look shared by two faces */
    nt = drop_duplicates(tri, nt, &m->duplicate_tris);
    if (nt == SIZE_MAX) goto oom;
    /* keep only used vertices, in file order */
    uint32_t *newid = rep; /* reuse: rep[] is no longer needed after remapping */
    for (size_t i = 0; i < nvert; i++) newid[i] = UINT32_MAX;
    for (size_t i = 0; i < 3 * nt; i++) newid[tri[i]] = 0;
    size_t nv = 0;
    for (size_t i = 0; i < nvert; i++)
        if (newid[i] == 0) {
            newid[i] = (uint32_t)nv;
            memmove(&vert[3 * nv], &vert[3 * i], 3 * sizeof *vert);
            nv++;
        }
    for (size_t i = 0; i < 3 * nt; i++) tri[i] = newid[tri[i]];
    free(rep);
    m->welded = nvert - groups;
    m->vert = nv ? realloc(vert, nv * 3 * sizeof *vert) : vert;
    m->tri = nt ? realloc(tri, nt * 3 * sizeof *tri) : tri;
    if (!m->vert) m->vert = vert;
    if (!m->tri) m->tri = tri;
    m->nvert = nv;
    m->ntri = nt;
    if (nt == 0) {
        kf_mesh_free(m);
        return fail(err, errlen, path, "no faces (all %zu degenerate)", ntri);
    }
    update_measures(m);
    if (analyse_edges(m)) {
        kf_mesh_free(m);
        return fail(err, errlen, path, "out of memory");
    }
    update_measures(m);
    return 0;
oom:
    free(w), free(rep), free(vert), free(tri);
    return fail(err, errlen, path, "out of memory");
}

int kf_mesh_from_arrays(const char *name, size_t nvert, const double *vert3, size_t ntri, const uint32_t *tri3,
                        kf_mesh *out, char *err, size_t errlen) {
    memset(out, 0, sizeof *out);
    snprintf(out->path, sizeof out->path, "%s", name ? name : "mesh");
    if (nvert >= UINT32_MAX) return fail(err, errlen, out->path, "too many vertices (%zu)", nvert);
    if (ntri == 0) return fail(err, errlen, out->path, "no faces");
    double *v = malloc((nvert ? nvert : 1) * 3 * sizeof *v);
    uint32_t *t = malloc(ntri * 3 * sizeof *t);
    if (!v || !t) {
        free(v), free(t);
        return fail(err, errlen, out->path, "out of memory");
    }
    memcpy(v, vert3, nvert * 3 * sizeof *v);
    memcpy(t, tri3, ntri * 3 * sizeof *t);
    return finish(out, v, nvert, t, ntri, err, errlen);
}

static int has_ext(const char *path, const char *ext) {
    size_t n = strlen(path), e = strlen(ext);
    return n > e && !strcasecmp(path + n - e, ext);
}

int kf_mesh_load(const char *path, kf_mesh *out, char *err, size_t errlen) {
    memset(out, 0, sizeof *out);
    snprintf(out->path, sizeof out->path, "%s", path);
    FILE *f = fopen(path, "rb");
    if (!f) return fail(err, errlen, path, "cannot open: %s", strerror(errno));
    fseek(f, 0, SEEK_END);
    long fsize = ftell(f);
    rewind(f);
    if (fsize <= 0) {
        fclose(f);
        return fail(err, errlen, path, "empty file");
    }
    char why[256] = "";
    int bad = 0;
    char magic[8] = "";
    size_t got = fread(magic, 1, 7, f);
    magic[got] = 0;
    rewind(f);
    if (!strncmp(magic, "ply", 3)) bad = check_ply(f, fsize, why, sizeof why);
    else if (has_ext(path, ".off")) bad = check_off(f, why, sizeof why);
    else if (has_ext(path, ".stl")) bad = check_stl(f, fsize, why, sizeof why);
    fclose(f);
    if (bad) return fail(err, errlen, path, "%s", why);

    /* node transforms baked in; no triangulation (we fan polygons, below,
     * so face counts stay those of the file) and no joining (we weld) */
    const struct aiScene *sc = aiImportFile(path, aiProcess_PreTransformVertices);
    if (!sc) {
        const char *msg = aiGetErrorString();
        /* what assimp says of an OBJ with vertices and no faces */
        if (msg && strstr(msg, "No output meshes")) return fail(err, errlen, path, "no faces (truncated file?)");
        return fail(err, errlen, path, "cannot load: %s", msg ? msg : "unknown assimp error");
    }
    size_t nv = 0, nt = 0, empty_faces = 0, prims = 0;
    for (unsigned i = 0; i < sc->mNumMeshes; i++) {
        const struct aiMesh *me = sc->mMeshes[i];
        nv += me->mNumVertices;
        for (unsigned fi = 0; fi < me->mNumFaces; fi++) {
            unsigned k = me->mFaces[fi].mNumIndices;
            if (k == 0) empty_faces++;
            else if (k < 3) prims++;
            else nt += k - 2;
        }
    }
    if (empty_faces) {
        aiReleaseImport(sc);
        return fail(err, errlen, path, "%zu faces without vertices (truncated file?)", empty_faces);
    }
    if (nt == 0) {
        aiReleaseImport(sc);
        return fail(err, errlen, path, "no faces (truncated file?)");
    }
    if (nv >= UINT32_MAX || nt >= UINT32_MAX) {
        aiReleaseImport(sc);
        return fail(err, errlen, path, "too large (%zu vertices, %zu triangles)", nv, nt);
    }
    double *vert = malloc(nv * 3 * sizeof *vert);
    uint32_t *tri = malloc(nt * 3 * sizeof *tri);
    if (!vert || !tri) {
        free(vert), free(tri);
        aiReleaseImport(sc);
        return fail(err, errlen, path, "out of memory");
    }
    size_t v0 = 0, t = 0;
    for (unsigned i = 0; i < sc->mNumMeshes; i++) {
        const struct aiMesh *me = sc->mMeshes[i];
        for (unsigned j = 0; j < me->mNumVertices; j++) {
            vert[3 * (v0 + j) + 0] = me->mVertices[j].x;
            vert[3 * (v0 + j) + 1] = me->mVertices[j].y;
            vert[3 * (v0 + j) + 2] = me->mVertices[j].z;
        }
        for (unsigned fi = 0; fi < me->mNumFaces; fi++) {
            const struct aiFace *fc = &me->mFaces[fi];
            for (unsigned k = 0; k < fc->mNumIndices; k++)
                if (fc->mIndices[k] >= me->mNumVertices) {
                    free(vert), free(tri);
                    unsigned bad_index = fc->mIndices[k], have = me->mNumVertices;
                    aiReleaseImport(sc);
                    return fail(err, errlen, path, "a face uses vertex %u of %u (truncated or corrupt file?)",
                                bad_index, have);
                }
            /* fan: exact for the convex polygons these formats hold in practice */
            for (unsigned k = 1; k + 1 < fc->mNumIndices; k++) {
                tri[3 * t + 0] = (uint32_t)(v0 + fc->mIndices[0]);
                tri[3 * t + 1] = (uint32_t)(v0 + fc->mIndices[k]);
                tri[3 * t + 2] = (uint32_t)(v0 + fc->mIndices[k + 1]);
                t++;
            }
        }
        v0 += me->mNumVertices;
    }
    aiReleaseImport(sc);
    out->ignored_prims = prims;
    return finish(out, vert, nv, tri, nt, err, errlen);
}

int kf_mesh_check_closed(const kf_mesh *m, char *err, size_t errlen) {
    if (m->closed) return 0;
    if (m->ntri == 0) return fail(err, errlen, m->path, "no faces");
    size_t b = m->boundary_edges, n = m->nonmanifold_edges;
    char nm[96];
    snprintf(nm, sizeof nm, "%zu %s shared by more than two triangles", n, n == 1 ? "edge" : "edges");
    if (b && n) return fail(err, errlen, m->path, "not closed: %zu boundary %s, %s", b, b == 1 ? "edge" : "edges", nm);
    if (b) return fail(err, errlen, m->path, "not closed: %zu boundary %s", b, b == 1 ? "edge" : "edges");
    return fail(err, errlen, m->path, "not closed: %s", nm);
}

void kf_mesh_transform(kf_mesh *m, const double M[12]) {
    for (size_t i = 0; i < m->nvert; i++) {
        double *p = &m->vert[3 * i], q[3];
        for (int r = 0; r < 3; r++) q[r] = M[4 * r] * p[0] + M[4 * r + 1] * p[1] + M[4 * r + 2] * p[2] + M[4 * r + 3];
        memcpy(p, q, sizeof q);
    }
    double det =
        M[0] * (M[5] * M[10] - M[6] * M[9]) - M[1] * (M[4] * M[10] - M[6] * M[8]) + M[2] * (M[4] * M[9] - M[5] * M[8]);
    if (det < 0)
        for (size_t t = 0; t < m->ntri; t++) flip_tri(&m->tri[3 * t]);
    update_measures(m);
}
