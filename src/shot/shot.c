/* shot.c — load a shot: read the text, graft the command line onto it, walk
 * it against the key table, then resolve what the table alone cannot check
 * (presets, references between sections, files, ranges across keys) into a
 * kf_shot. Every problem is reported and the walk goes on, so one run shows
 * them all; nothing is returned unless there were none. */
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "loader.h"

/* ---- the entry point -------------------------------------------------------------------- */

static char *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 1 << 16, n = 0;
    char *buf = malloc(cap + 1);
    while (buf) {
        n += fread(buf + n, 1, cap - n, f);
        if (n < cap) break;
        char *b = realloc(buf, 2 * cap + 1);
        if (!b) free(buf);
        buf = b;
        cap *= 2;
    }
    int err = ferror(f);
    fclose(f);
    if (!buf || err) {
        free(buf);
        return NULL;
    }
    buf[n] = '\0';
    *len = n;
    return buf;
}

static int ends_with(const char *s, const char *suffix) {
    size_t a = strlen(s), b = strlen(suffix);
    return a >= b && strcasecmp(s + a - b, suffix) == 0;
}

/* Offset of the first byte in [p, p + n) that is not UTF-8 (overlong forms,
 * surrogates and code points above U+10FFFF included), or -1. */
static long utf8_bad_at(const unsigned char *p, size_t n) {
    for (size_t i = 0; i < n;) {
        unsigned c = p[i];
        if (c < 0x80) {
            i++;
            continue;
        }
        size_t k = (c & 0xe0) == 0xc0 ? 1 : (c & 0xf0) == 0xe0 ? 2 : (c & 0xf8) == 0xf0 ? 3 : 0;
        if (k == 0 || c < 0xc2 || c > 0xf4 || i + k >= n) return (long)i;
        for (size_t j = 1; j <= k; j++)
            if ((p[i + j] & 0xc0) != 0x80) return (long)i;
        unsigned d = p[i + 1];
        if ((c == 0xe0 && d < 0xa0) || (c == 0xed && d >= 0xa0) || (c == 0xf0 && d < 0x90) || (c == 0xf4 && d >= 0x90))
            return (long)i;
        i += k + 1;
    }
    return -1;
}

/* A shot file is UTF-8 text (YAML). libfyaml 0.8 loops for ever on a byte
 * that is not UTF-8 in a directive ('%' after any line break, CR included;
 * found by tests/fuzz/fuzz_shot.c), and refuses one in a scalar: name the
 * byte at its line:col before it parses. Returns 0, or -1 reported. */
static int check_utf8(kf_diag *d, kf_srcs *srcs, int src, const char *text, size_t len) {
    long bad = utf8_bad_at((const unsigned char *)text, len);
    if (bad < 0) return 0;
    int line = 1, col = 1;
    for (long i = 0; i < bad; i++) col = text[i] == '\n' ? (line++, 1) : col + 1;
    kf_report(d, srcs, src, line, col, KF_DIAG_ERROR,
              "byte 0x%02x (byte %ld of %zu) is not UTF-8: a shot file is UTF-8 text; was it saved in another "
              "encoding, or is it damaged?",
              (unsigned char)text[bad], bad + 1, len);
    return -1;
}

kf_shot *kf_shot_load(const char *path, const char *const *overrides, int n_overrides, const char *quality,
                      const char *frames, kf_diag *d) {
    const int errors0 = d->errors;
    loader L = {0};
    L.d = d;
    kf_shot *s = calloc(1, sizeof *s);
    size_t len = 0;
    char *text = read_file(path, &len);
    if (!s || !text) {
        kf_diag_add(d, KF_DIAG_ERROR, path, 0, 0, NULL, "cannot read the shot file: %s",
                    strerror(errno ? errno : ENOMEM));
        free(text);
        goto done;
    }
    int src = kf_srcs_add(&L.srcs, path, text, len, 0, 0, NULL), empty = 0;
    /* a NUL byte ends the text for the YAML parser, which then reports the
     * keys after it as missing: name the byte instead */
    const char *nul = memchr(text, 0, len);
    if (nul) {
        int line = 1, col = 1;
        for (const char *c = text; c < nul; c++) col = *c == '\n' ? (line++, 1) : col + 1;
        kf_report(d, &L.srcs, src, line, col, KF_DIAG_ERROR,
                  "a NUL byte (byte %zu of %zu): a shot file is text; is this file damaged or not a shot?",
                  (size_t)(nul - text) + 1, len);
        goto done;
    }
    if (check_utf8(d, &L.srcs, src, text, len)) goto done;
    ky_node *root = ky_parse(&L.doc, &L.srcs, src, ends_with(path, ".json"), d, &empty);
    if (!root) {
        if (empty) kf_report(d, &L.srcs, src, 0, 0, KF_DIAG_ERROR, "the shot file is empty");
        goto done;
    }
    if (root->kind != KY_MAP) {
        kf_report_at(d, &L.srcs, root, KF_DIAG_ERROR, "a shot file is a mapping of keys (shot:, frames:, sim:, ...)");
        goto done;
    }
    for (int i = 0; i < n_overrides; i++) kf_override_apply(&L.doc, root, &L.srcs, overrides[i], i + 1, d);

    /* the walk: every key checked against the table */
    int top = kf_inst_new(&L, KS_TOP, "", "", root, -1);
    if (top < 0) goto done;
    kf_walk_map(&L, top, root, "");
    kf_resolve_top(&L, &L.v[top], path, s);
    inst *T = &L.v[top];
    int times_ok = T->ok[KK_FRAMES] && (!T->at[KK_FRAMES_START] || T->ok[KK_FRAMES_START]) &&
                   (!T->at[KK_FRAMES_FPS] || T->ok[KK_FRAMES_FPS]);

    /* count, allocate, resolve each kind in file order */
    int nm = 0, no = 0, nc = 0, nr = 0, nj = 0;
    for (int i = 0; i < L.n; i++) {
        nm += L.v[i].scope == KS_MATERIAL;
        no += L.v[i].scope == KS_OBJECT;
        nc += L.v[i].scope == KS_COLLIDER;
        nr += L.v[i].scope == KS_RIGID;
        nj += L.v[i].scope == KS_JOINT;
    }
    s->rigids = calloc((size_t)nr + 1, sizeof *s->rigids);
    s->joints = calloc((size_t)nj + 1, sizeof *s->joints);
    if (!s->rigids || !s->joints) goto done;
    s->materials = calloc((size_t)nm + 1, sizeof *s->materials);
    s->objects = calloc((size_t)no + 1, sizeof *s->objects);
    s->colliders = calloc((size_t)nc + 1, sizeof *s->colliders);
    if (!s->materials || !s->objects || !s->colliders) goto done;
    for (int i = 0; i < L.n; i++) {
        if (L.v[i].scope == KS_MATERIAL) kf_resolve_material(&L, &L.v[i], s, &s->materials[s->nmaterials++]);
        else if (L.v[i].scope == KS_OBJECT) {
            kf_resolve_object(&L, &L.v[i], s->nobjects, s, &s->objects[s->nobjects]);
            s->nobjects++;
        } else if (L.v[i].scope == KS_COLLIDER) {
            kf_resolve_collider(&L, i, s->ncolliders, s, times_ok, &s->colliders[s->ncolliders]);
            s->ncolliders++;
        } else if (L.v[i].scope == KS_RIGID) {
            kf_resolve_rigid(&L, i, s->nrigids, s, times_ok, &s->rigids[s->nrigids]);
            s->nrigids++;
        }
    }
    for (int i = 0; i < L.n; i++) /* joints name bodies, wherever they are in the file */
        if (L.v[i].scope == KS_JOINT) {
            kf_resolve_joint(&L, &L.v[i], s->njoints, s, &s->joints[s->njoints]);
            s->njoints++;
        }
    kf_check_unique(&L, KS_RIGID, KK_RIGIDS_NAME, s->rigids[0].def.name, sizeof *s->rigids, nr);
    kf_check_unique(&L, KS_JOINT, KK_JOINTS_NAME, s->joints[0].name, sizeof *s->joints, nj);
    for (int i = 0, r = 0; i < L.n && nr > KF_MAX_RIGIDS; i++) /* reported at the first body over the limit */
        if (L.v[i].scope == KS_RIGID && r++ == KF_MAX_RIGIDS)
            kf_report_at(d, &L.srcs, L.v[i].map, KF_DIAG_ERROR,
                         "%s: too many rigid bodies: %d (at most %d: a grid node holds 2 bits per body in one 32-bit "
                         "word)",
                         L.v[i].label, nr, KF_MAX_RIGIDS);
    if (nj > KF_MAX_JOINTS) kf_report_inst(&L, T, KK_JOINTS, KF_DIAG_ERROR, "too many joints (at most 32)");
    kf_check_unique(&L, KS_OBJECT, KK_OBJECTS_NAME, s->objects[0].name, sizeof *s->objects, no);
    kf_resolve_bonds(&L, s);
    /* sim.contact auto: on where objects can touch each other, or a thin
     * body can cut a solid into pieces that then touch (sand and water flow
     * together again) */
    const int contact_mode = ((const kf_top *)T->base)->contact;
    int cutter = 0, solid = 0, fields = 0;
    for (int i = 0; i < s->nrigids; i++) cutter |= s->rigids[i].def.thin != 0;
    for (int i = 0; i < s->nobjects; i++) fields += s->objects[i].field == i; /* bonded objects are one */
    for (int i = 0; i < s->nobjects; i++) {
        int k = s->objects[i].material;
        if (k >= 0 && k < s->nmaterials)
            solid |= s->materials[k].mat.model != KF_MAT_WATER && s->materials[k].mat.model != KF_MAT_SAND;
    }
    s->sim.contact = contact_mode == 0 || (contact_mode == 2 && (fields > 1 || (cutter && solid)));
    kf_check_unique(&L, KS_COLLIDER, KK_COLLIDERS_NAME, s->colliders[0].name, sizeof *s->colliders, nc);
    if (no == 0)
        kf_report_inst(&L, T, KK_OBJECTS, KF_DIAG_ERROR, "the shot has no objects: nothing would be simulated");
    if (nm > KF_MAX_MATERIALS) kf_report_inst(&L, T, KK_MATERIALS, KF_DIAG_ERROR, "too many materials (at most 64)");
    if (nc > KF_MAX_COLLIDERS) kf_report_inst(&L, T, KK_COLLIDERS, KF_DIAG_ERROR, "too many colliders (at most 64)");
    for (int i = 0, m = 0; i < L.n; i++) { /* unused materials are probably a typo elsewhere */
        if (L.v[i].scope != KS_MATERIAL) continue;
        int used = 0;
        for (int j = 0; j < s->nobjects; j++) used |= s->objects[j].material == m;
        if (!used) {
            char msg[160];
            snprintf(msg, sizeof msg, "%s is not used by any object", L.v[i].label);
            kf_report_at(d, &L.srcs, L.v[i].name, KF_DIAG_WARNING, "%s", msg);
        }
        m++;
    }

    /* the command line's own options */
    if (kf_quality_parse(quality, &L.srcs, &s->quality, d) == 0 && s->quality == KF_QUALITY_PREVIEW) {
        s->sim.dx *= 2;
        s->resolution_scale = 0.5;
        s->render_width = s->render_width / 2 > 16 ? s->render_width / 2 : 16;
        s->render_height = s->render_height / 2 > 16 ? s->render_height / 2 : 16;
        s->render_samples = 1;
        s->render_quality = 1;
        if (!T->at[KK_SURFACE_FLATTEN]) s->surface_flatten = 0; /* a quick look: the faces' flattening off */
    }
    /* the preview presets (surface.quality, render.quality): what the shot
     * sets itself wins; the numbers live beside the code they drive */
    /* the spheres' own look had one smoothing pass */
    if (s->surface_kernel == 1 && !T->at[KK_SURFACE_ITERATIONS]) s->surface_iterations = 1;
    if (s->surface_kernel == 1 && !T->at[KK_SURFACE_FLATTEN]) s->surface_flatten = 0;
    if (s->surface_quality == 1) {
        if (!T->at[KK_SURFACE_FLATTEN]) s->surface_flatten = 0; /* most of a preview's surfacing time otherwise */
        if (!T->at[KK_SURFACE_VOXEL]) s->surface_voxel = KF_VDB_PREVIEW_VOXEL;
        if (!T->at[KK_SURFACE_RADIUS]) s->surface_radius = KF_VDB_PREVIEW_RADIUS;
        if (!T->at[KK_SURFACE_ITERATIONS]) s->surface_iterations = KF_VDB_PREVIEW_ITERATIONS;
    }
    if (s->render_quality == 1) {
        if (!T->at[KK_RENDER_SAMPLES] || s->quality == KF_QUALITY_PREVIEW) s->render_samples = 1;
        s->render_shadow = KF_RENDER_PREVIEW_SHADOW;
    }
    s->first = s->frame_start;
    s->last = s->frame_end;
    int range_ok = (!T->at[KK_FRAMES_START] || T->ok[KK_FRAMES_START]) && T->at[KK_FRAMES_END] &&
                   T->ok[KK_FRAMES_END] && s->frame_end >= s->frame_start;
    if (frames && range_ok) kf_frames_parse(frames, &L.srcs, s->frame_start, s->frame_end, &s->first, &s->last, d);

done:
    kf_diag_sort(d);
    for (int i = 0; i < L.n; i++) kf_inst_free(&L.v[i]);
    free(L.v);
    ky_free(&L.doc);
    kf_srcs_free(&L.srcs);
    if (d->errors > errors0) {
        kf_shot_free(s);
        return NULL;
    }
    return s;
}

void kf_shot_free(kf_shot *s) {
    if (!s) return;
    free(s->materials);
    free(s->objects);
    free(s->colliders);
    free(s->rigids);
    free(s->joints);
    for (int i = 0; i < s->nstrings; i++) free(s->strings[i]);
    free(s->strings);
    free(s);
}

double kf_shot_frame_time(const kf_shot *s, int frame) { return (frame - s->frame_start) / s->fps; }
