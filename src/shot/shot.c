/* shot.c — load a shot: read the text, graft the command line onto it, walk
 * it against the key table, then resolve what the table alone cannot check
 * (presets, references between sections, files, ranges across keys) into a
 * kf_shot. Every problem is reported and the walk goes on, so one run shows
 * them all; nothing is returned unless there were none. */
#include "../core/euler.h"
#include <ctype.h>
#include <errno.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "internal.h"

#define KF_PI 3.14159265358979323846

/* ---- instances: one per struct the walk fills ------------------------------------ */

/* The top level, each material, object, collider and key is an instance:
 * the struct its keys write into, and for each key of the table the node
 * that gave it (so later checks can point at it). */
typedef struct inst {
    kf_scope scope;
    void *base;
    char prefix[32];        /* table path of its keys: "", "materials.*", "objects[]" */
    char label[96];         /* in messages: "", "materials.jelly", "objects[1]" */
    const ky_node *map;     /* its mapping */
    const ky_node *name;    /* materials: the name key */
    const ky_node **at;     /* (kf_nkeys) the value node of each key given */
    const ky_node **keyat;  /* (kf_nkeys) its key node */
    unsigned char *ok;      /* (kf_nkeys) 1 = given and valid */
    int parent;             /* keys: the collider's instance */
    int errors;             /* errors in its own keys */
} inst;

typedef struct loader {
    kf_diag *d;
    kf_srcs srcs;
    ky_doc doc;
    inst *v;
    int n, cap;
} loader;

static const size_t scope_size[KS_COUNT] = {sizeof(kf_top), sizeof(kf_shot_material), sizeof(kf_shot_object),
                                            sizeof(kf_shot_collider), sizeof(kf_rawkey), sizeof(kf_shot_rigid),
                                            sizeof(kf_shot_joint)};

static int is_leaf(const kf_keydef *k) { return k->type != KT_SECTION && k->type != KT_DICT && k->type != KT_LIST; }

static int inst_new(loader *L, kf_scope scope, const char *prefix, const char *label, const ky_node *map, int parent) {
    if (L->n == L->cap) {
        int cap = L->cap ? 2 * L->cap : 16;
        inst *v = realloc(L->v, (size_t)cap * sizeof *v);
        if (!v) return -1;
        L->v = v;
        L->cap = cap;
    }
    inst *I = &L->v[L->n];
    memset(I, 0, sizeof *I);
    I->scope = scope;
    I->base = calloc(1, scope_size[scope]);
    I->at = calloc((size_t)kf_nkeys, sizeof *I->at);
    I->keyat = calloc((size_t)kf_nkeys, sizeof *I->keyat);
    I->ok = calloc((size_t)kf_nkeys, 1);
    if (!I->base || !I->at || !I->keyat || !I->ok) return -1;
    snprintf(I->prefix, sizeof I->prefix, "%s", prefix);
    snprintf(I->label, sizeof I->label, "%s", label);
    I->map = map;
    I->parent = parent;
    if (scope == KS_TOP) ((kf_top *)I->base)->s.sim = kf_default_sim_def();
    /* defaults come from the table, in the same syntax as the file */
    for (int e = 0; e < kf_nkeys; e++)
        if (kf_keys[e].scope == scope && is_leaf(&kf_keys[e])) kf_key_default(&kf_keys[e], I->base);
    return L->n++;
}

static void inst_free(inst *I) {
    free(I->base);
    free(I->at);
    free(I->keyat);
    free(I->ok);
}

/* "objects[1].radius" from the instance's label and the key's path */
static void what_of(const inst *I, const kf_keydef *k, char *out, size_t n) {
    const char *rel = k->path + (I->prefix[0] ? strlen(I->prefix) + 1 : 0);
    snprintf(out, n, "%s%s%s", I->label, I->label[0] ? "." : "", rel);
}

/* ---- the walk -------------------------------------------------------------------- */

static void walk_map(loader *L, int ii, const ky_node *map, const char *prefix);

static void unknown_key(loader *L, const ky_node *key, const char *prefix, const char *where) {
    const char *cand[64];
    int nc = 0;
    char parent[96];
    for (int e = 0; e < kf_nkeys && nc < 64; e++) {
        kf_key_parent(&kf_keys[e], parent, sizeof parent);
        if (strcmp(parent, prefix) == 0) cand[nc++] = kf_key_leaf(&kf_keys[e]);
    }
    const char *near = kf_suggest(key->text, cand, nc);
    char ctx[200];
    if (where[0]) snprintf(ctx, sizeof ctx, "in %s", where);
    else snprintf(ctx, sizeof ctx, "at the top level");
    if (near) {
        kf_report_at(L->d, &L->srcs, key, KF_DIAG_ERROR, "unknown key '%s' %s (did you mean '%s'?)", key->text, ctx,
                     near);
        return;
    }
    char list[512] = "";
    for (int i = 0; i < nc; i++) {
        size_t l = strlen(list);
        snprintf(list + l, sizeof list - l, "%s%s", i ? ", " : "", cand[i]);
    }
    kf_report_at(L->d, &L->srcs, key, KF_DIAG_ERROR, "unknown key '%s' %s; keys here: %s", key->text, ctx, list);
}

static int expect_kind(loader *L, const ky_node *v, ky_kind kind, const char *what, const char *shape) {
    if (v->kind == kind) return 0;
    char got[96];
    if (v->kind == KY_MAP) snprintf(got, sizeof got, "a mapping {...}");
    else if (v->kind == KY_SEQ) snprintf(got, sizeof got, "a list [...]");
    else if (ky_is_null(v)) snprintf(got, sizeof got, "nothing");
    else snprintf(got, sizeof got, "'%.60s'", v->text);
    kf_report_at(L->d, &L->srcs, v, KF_DIAG_ERROR, "%s: expected %s, got %s", what, shape, got);
    return -1;
}

/* materials: NAME: {...} — each entry is a new instance */
static void walk_dict(loader *L, int ii, const kf_keydef *k, const ky_node *v) {
    char prefix[96], label[96], what[128];
    snprintf(prefix, sizeof prefix, "%s.*", k->path);
    what_of(&L->v[ii], k, what, sizeof what);
    if (ky_is_null(v)) return;
    if (expect_kind(L, v, KY_MAP, what, "a mapping of NAME: {...}")) return;
    for (int i = 0; i + 1 < v->n; i += 2) {
        const ky_node *name = v->item[i], *body = v->item[i + 1];
        if (name->kind != KY_SCALAR) {
            kf_report_at(L->d, &L->srcs, name, KF_DIAG_ERROR, "%s: an entry's name must be plain text", what);
            continue;
        }
        snprintf(label, sizeof label, "%.40s.%.40s", what, name->text);
        int bad = strlen(name->text) >= sizeof(((kf_material *)0)->name) || !name->text[0];
        for (const char *p = name->text; *p; p++) bad |= !isalnum((unsigned char)*p) && *p != '_' && *p != '-';
        if (bad) {
            kf_report_at(L->d, &L->srcs, name, KF_DIAG_ERROR,
                         "%s: '%s' is not a usable name (1 to 31 letters, digits, '_' or '-')", what, name->text);
            continue;
        }
        int dup = -1;
        for (int j = 0; j < L->n; j++)
            if (L->v[j].scope == k->scope && L->v[j].name && strcmp(L->v[j].name->text, name->text) == 0) dup = j;
        if (dup >= 0) {
            kf_report_at(L->d, &L->srcs, name, KF_DIAG_ERROR, "%s is defined twice (first at line %d)", label,
                         L->v[dup].name->line);
            continue;
        }
        if (ky_is_null(body)) {
            kf_report_at(L->d, &L->srcs, name, KF_DIAG_ERROR, "%s is empty: give at least a preset", label);
            continue;
        }
        if (expect_kind(L, body, KY_MAP, label, "a mapping {preset: ..., ...}")) continue;
        int c = inst_new(L, k->scope, prefix, label, body, ii);
        if (c < 0) return;
        L->v[c].name = name;
        walk_map(L, c, body, prefix);
    }
}

/* objects: [{...}, ...] — each item is a new instance */
static void walk_list(loader *L, int ii, const kf_keydef *k, const ky_node *v) {
    char prefix[96], label[128], what[128];
    snprintf(prefix, sizeof prefix, "%s[]", k->path);
    what_of(&L->v[ii], k, what, sizeof what);
    if (ky_is_null(v)) return;
    if (expect_kind(L, v, KY_SEQ, what, "a list [{...}, ...]")) return;
    for (int i = 0; i < v->n; i++) {
        snprintf(label, sizeof label, "%.80s[%d]", what, i);
        if (expect_kind(L, v->item[i], KY_MAP, label, "a mapping {...}")) continue;
        int c = inst_new(L, k->scope, prefix, label, v->item[i], ii);
        if (c < 0) return;
        walk_map(L, c, v->item[i], prefix);
    }
}

static void walk_map(loader *L, int ii, const ky_node *map, const char *prefix) {
    for (int i = 0; i + 1 < map->n; i += 2) {
        const ky_node *key = map->item[i], *v = map->item[i + 1];
        inst *I = &L->v[ii]; /* re-read: walking children may move the array */
        char path[160], what[192], where[160];
        if (key->kind != KY_SCALAR) {
            kf_report_at(L->d, &L->srcs, key, KF_DIAG_ERROR, "a key must be plain text");
            I->errors++;
            continue;
        }
        snprintf(path, sizeof path, "%s%s%s", prefix, prefix[0] ? "." : "", key->text);
        int e = kf_key_find(path);
        if (e < 0) {
            /* where: the container as the user sees it ("sim", "objects[1]", "objects[1].fit") */
            const char *rel = prefix + (I->prefix[0] ? strlen(I->prefix) : 0);
            if (*rel == '.') rel++;
            snprintf(where, sizeof where, "%s%s%s", I->label, I->label[0] && rel[0] ? "." : "", rel);
            unknown_key(L, key, prefix, where);
            I->errors++;
            continue;
        }
        const kf_keydef *k = &kf_keys[e];
        what_of(I, k, what, sizeof what);
        if (I->keyat[e]) {
            const ky_node *first = I->keyat[e];
            const kf_src *fs = &L->srcs.v[first->src];
            kf_report_at(L->d, &L->srcs, key, KF_DIAG_ERROR, "%s is given twice (first at %s:%d:%d)", what, fs->file,
                         fs->line > 0 ? fs->line : first->line, fs->line > 0 ? fs->col0 + first->col : first->col);
            I->errors++;
            continue;
        }
        I->keyat[e] = key;
        I->at[e] = v;
        int ok;
        switch (k->type) {
        case KT_SECTION: /* ok = it is a mapping; its keys count their own errors */
            ok = ky_is_null(v) || !expect_kind(L, v, KY_MAP, what, "a mapping {...}");
            if (ok && !ky_is_null(v)) walk_map(L, ii, v, k->path);
            break;
        case KT_DICT: ok = 1, walk_dict(L, ii, k, v); break;
        case KT_LIST: ok = 1, walk_list(L, ii, k, v); break;
        default: ok = kf_key_set(k, v, I->base, what, L->d, &L->srcs) == 0; break;
        }
        I = &L->v[ii];
        I->ok[e] = (unsigned char)ok;
        if (!ok) I->errors++;
    }
}

/* ---- what the table says about presence ----------------------------------------- */

/* `only`: the condition "key=a|b" on the instance. 1 holds, 0 does not,
 * -1 unknown (the key it depends on is missing or bad). */
static int only_holds(const inst *I, const kf_keydef *k, char *val, size_t n) {
    if (!k->only) return 1;
    char parent[96], cond[128];
    const char *eq = strchr(k->only, '=');
    kf_key_parent(k, parent, sizeof parent);
    snprintf(cond, sizeof cond, "%s%s%.*s", parent, parent[0] ? "." : "", (int)(eq - k->only), k->only);
    int c = kf_key_find(cond);
    if (c < 0) return -1;
    const kf_keydef *ck = &kf_keys[c];
    if (I->at[c] ? !I->ok[c] : ck->def == NULL) return -1;
    int idx = *(const int *)((const char *)I->base + ck->off);
    kf_key_choice(ck, idx, val, n);
    size_t len = strlen(val);
    for (const char *p = eq + 1; *p;) {
        size_t l = strcspn(p, "|");
        if (l == len && strncmp(p, val, l) == 0) return 1;
        p += l + (p[l] == '|');
    }
    return 0;
}

/* Inapplicable keys (an error, or a warning when it merely has no effect)
 * and missing required ones. */
static void check_presence(loader *L, inst *I) {
    for (int e = 0; e < kf_nkeys; e++) {
        const kf_keydef *k = &kf_keys[e];
        if (k->scope != I->scope || k->type == KT_DICT || k->type == KT_LIST) continue;
        /* keys share a scope (colliders' and rigids' keys): only this instance's rows */
        size_t pl = strlen(I->prefix);
        if (pl && (strncmp(k->path, I->prefix, pl) != 0 || k->path[pl] != '.')) continue;
        char val[64], what[160], cond[64];
        int holds = only_holds(I, k, val, sizeof val);
        what_of(I, k, what, sizeof what);
        if (k->only) snprintf(cond, sizeof cond, "%.*s", (int)(strchr(k->only, '=') - k->only), k->only);
        if (I->at[e] && holds == 0) {
            const char *opts = strchr(k->only, '=') + 1;
            if (k->flags & KF_SOFT)
                kf_report_at(L->d, &L->srcs, I->keyat[e], KF_DIAG_WARNING,
                             "%s has no effect with %s %s (only with %s)", what, cond, val, opts);
            else
                kf_report_at(L->d, &L->srcs, I->keyat[e], KF_DIAG_ERROR, "%s does not apply to %s %s (only to %s)",
                             what, cond, val, opts);
            continue;
        }
        if (!(k->flags & KF_REQ) || I->at[e] || holds != 1) continue;
        /* inside an optional section, required only when the section is given */
        char parent[96];
        kf_key_parent(k, parent, sizeof parent);
        int p = strcmp(parent, I->prefix) == 0 ? -1 : kf_key_find(parent);
        if (p >= 0 && (!I->at[p] || !I->ok[p])) continue; /* a missing required section is reported itself */
        const ky_node *where = p >= 0 && I->keyat[p] ? I->keyat[p] : I->name ? I->name : I->map;
        if (k->only)
            kf_report(L->d, &L->srcs, where ? where->src : 0, where ? where->line : 1, where ? where->col : 1,
                      KF_DIAG_ERROR, "%s is missing (required for %s %s)", what, cond, val);
        else
            kf_report(L->d, &L->srcs, where ? where->src : 0, where ? where->line : 1, where ? where->col : 1,
                      KF_DIAG_ERROR, "%s is missing (required)", what);
    }
}

/* ---- resolving: what the table cannot see on its own --------------------------------- */

/* the node to point at for a key of an instance: its value, else the instance */
static const ky_node *node_for(const inst *I, int key) {
    if (key >= 0 && I->at[key]) return I->at[key];
    return I->name ? I->name : I->map;
}

static void report_inst(loader *L, const inst *I, int key, kf_severity sev, const char *msg) {
    const ky_node *n = node_for(I, key);
    if (n) kf_report_at(L->d, &L->srcs, n, sev, "%s", msg);
    else kf_report(L->d, &L->srcs, 0, 1, 1, sev, "%s", msg);
}

/* a copy the shot owns, so kf_loc outlives the loader */
static const char *keep(kf_shot *s, const char *str) {
    if (!str) return NULL;
    char **v = realloc(s->strings, (size_t)(s->nstrings + 1) * sizeof *v);
    if (!v) return NULL;
    s->strings = v;
    return s->strings[s->nstrings++] = strdup(str);
}

static kf_loc loc_of(loader *L, kf_shot *s, const ky_node *n) {
    kf_loc at = {0};
    if (!n) return at;
    char buf[1024];
    const char *file, *text = kf_locate(&L->srcs, n->src, n->line, n->col, &file, &at.line, &at.col, buf, sizeof buf);
    at.file = keep(s, file);
    at.source = keep(s, text);
    return at;
}

/* preset, then every key given over it; then the model's own check */
static void resolve_material(loader *L, inst *I, kf_shot *s, kf_shot_material *out) {
    const kf_shot_material *raw = I->base;
    int pk = KK_MATERIALS_PRESET, mk = KK_MATERIALS_MODEL;
    char msg[512];
    memset(out, 0, sizeof *out);
    out->color[0] = out->color[1] = out->color[2] = -1; /* by kind unless given */
    out->specular = out->roughness = -1;                /* likewise */
    int based = 0;
    if (I->at[pk]) {
        based = I->ok[pk] && kf_material_preset(raw->preset, &out->mat) == 0;
        if (based) snprintf(out->preset, sizeof out->preset, "%s", raw->preset);
    } else if (I->at[mk]) {
        based = I->ok[mk];
    } else {
        snprintf(msg, sizeof msg, "%s needs a preset (or a model and its parameters)", I->label);
        report_inst(L, I, KK_MATERIALS_PRESET, KF_DIAG_ERROR, msg);
        I->errors++;
    }
    for (int e = 0; e < kf_nkeys; e++) {
        const kf_keydef *k = &kf_keys[e];
        if (k->scope == KS_MATERIAL && is_leaf(k) && e != pk && I->at[e] && I->ok[e])
            memcpy((char *)out + k->off, (const char *)raw + k->off, k->size);
    }
    /* an explicit friction angle means "this angle", not the hardening curve */
    if (I->at[KK_MATERIALS_FRICTION_ANGLE] && !I->at[KK_MATERIALS_HARDENING]) out->mat.hardening = 0;
    snprintf(out->mat.name, sizeof out->mat.name, "%s", I->name->text);
    out->at = loc_of(L, s, I->name);
    out->stiffness_at = loc_of(L, s, node_for(I, out->mat.model == KF_MAT_WATER ? KK_MATERIALS_BULK_MODULUS
                                                                                 : KK_MATERIALS_E));
    if (!based) return;
    ((kf_shot_material *)I->base)->mat.model = out->mat.model; /* what `only: model=...` reads */
    check_presence(L, I);
    if (I->errors) return;
    const char *bad = kf_material_check(&out->mat);
    if (*bad) {
        /* the message starts with the parameter's name: point at it when given */
        char key[64], path[96];
        size_t n = strspn(bad, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_");
        snprintf(key, sizeof key, "%.*s", (int)(n < sizeof key ? n : sizeof key - 1), bad);
        snprintf(path, sizeof path, "materials.*.%s", key);
        snprintf(msg, sizeof msg, "%s: %s", I->label, bad);
        report_inst(L, I, kf_key_find(path), KF_DIAG_ERROR, msg);
    }
}

static void default_name(char *name, size_t n, const inst *I, kf_key_id shape_key, int index) {
    char shape[32];
    const kf_keydef *k = &kf_keys[shape_key];
    kf_key_choice(k, *(const int *)((const char *)I->base + k->off), shape, sizeof shape);
    snprintf(name, n, "%s%d", shape, index);
}


/* the inverse: degrees about x, y, z of a rotation matrix (any at gimbal lock) */
static void euler_angles(const double R[9], double deg[3]) {
    const double d = 180.0 / KF_PI;
    double sb = -R[6];
    if (sb > 1) sb = 1;
    if (sb < -1) sb = -1;
    double b = asin(sb);
    if (fabs(cos(b)) > 1e-9) {
        deg[0] = atan2(R[7], R[8]) * d;
        deg[2] = atan2(R[3], R[0]) * d;
    } else { /* x and z turn about the same axis: put it all in x */
        deg[0] = atan2(sb * R[1], R[4]) * d;
        deg[2] = 0;
    }
    deg[1] = b * d;
}

/* The sampler's cylinder runs along local y, so another axis is one more
 * rotation applied first (and the scale permuted to stay in object axes);
 * the centre and translate become one translation; a fit ignores
 * translate, so it moves the fit centre instead. */
static void placement(kf_shot_object *o) {
    kf_placement *p = &o->place;
    memset(p, 0, sizeof *p);
    memcpy(p->rotate, o->rotate, sizeof p->rotate);
    memcpy(p->scale, o->scale, sizeof p->scale);
    if (o->shape == KF_SOURCE_CYLINDER && o->axis != 1) {
        static const double to_x[9] = {0, 1, 0, -1, 0, 0, 0, 0, 1}; /* Rz(-90): y → x */
        static const double to_z[9] = {1, 0, 0, 0, 0, -1, 0, 1, 0}; /* Rx(90): y → z */
        const double *A = o->axis == 0 ? to_x : to_z;
        double U[9], R[9];
        kf_euler_matrix(o->rotate, U);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) R[3 * i + j] = U[3 * i] * A[j] + U[3 * i + 1] * A[3 + j] + U[3 * i + 2] * A[6 + j];
        euler_angles(R, p->rotate);
        double sx = o->scale[0], sy = o->scale[1], sz = o->scale[2];
        if (o->axis == 0) p->scale[0] = sy, p->scale[1] = sx, p->scale[2] = sz;
        else p->scale[0] = sx, p->scale[1] = sz, p->scale[2] = sy;
    }
    for (int a = 0; a < 3; a++) {
        if (o->shape == KF_SOURCE_MESH) p->translate[a] = o->translate[a];
        else p->translate[a] = o->center[a] + o->translate[a];
        p->fit_center[a] = o->fit_center[a] + o->translate[a];
    }
    p->fit = o->fit;
    p->fit_size = o->fit_size;
    if (!p->fit) memset(p->fit_center, 0, sizeof p->fit_center);
}

/* a mesh path relative to the shot's folder, checked to exist (reported at
 * the key's value) */
static void resolve_mesh_path(loader *L, inst *I, const kf_shot *s, kf_key_id key, const char *mesh, char *path,
                              size_t n) {
    char msg[1600];
    if (mesh[0] == '/' || strcmp(s->dir, ".") == 0) snprintf(path, n, "%s", mesh);
    else snprintf(path, n, "%.700s/%s", s->dir, mesh);
    struct stat st;
    if (stat(path, &st) != 0) {
        snprintf(msg, sizeof msg, "%s: mesh file '%s' not found (looked for %s)", I->label, mesh, path);
        report_inst(L, I, key, KF_DIAG_ERROR, msg);
    } else if (!S_ISREG(st.st_mode)) {
        snprintf(msg, sizeof msg, "%s: mesh path '%s' is %s, not a mesh file (%s)", I->label, mesh,
                 S_ISDIR(st.st_mode) ? "a directory" : "not a regular file", path);
        report_inst(L, I, key, KF_DIAG_ERROR, msg);
    }
}

static void resolve_object(loader *L, inst *I, int index, kf_shot *s, kf_shot_object *o) {
    char msg[1600];
    *o = *(const kf_shot_object *)I->base;
    check_presence(L, I);
    if (!I->at[KK_OBJECTS_NAME]) default_name(o->name, sizeof o->name, I, KK_OBJECTS_SHAPE, index);
    /* the material, by name */
    int mk = KK_OBJECTS_MATERIAL;
    if (I->ok[mk]) {
        const char *names[KF_MAX_MATERIALS * 4];
        int nm = 0;
        o->material = -1;
        for (int j = 0; j < L->n; j++)
            if (L->v[j].scope == KS_MATERIAL && nm < (int)(sizeof names / sizeof *names)) {
                if (strcmp(L->v[j].name->text, o->material_name) == 0) o->material = nm;
                names[nm++] = L->v[j].name->text;
            }
        if (o->material < 0) {
            const char *near = kf_suggest(o->material_name, names, nm);
            char list[512] = "";
            for (int j = 0; j < nm; j++) {
                size_t l = strlen(list);
                snprintf(list + l, sizeof list - l, "%s%s", j ? ", " : "", names[j]);
            }
            if (near) snprintf(msg, sizeof msg, "%s: material '%s' is not defined (did you mean '%s'?)", I->label,
                               o->material_name, near);
            else if (nm) snprintf(msg, sizeof msg, "%s: material '%s' is not defined; materials: %s", I->label,
                                  o->material_name, list);
            else snprintf(msg, sizeof msg, "%s: material '%s' is not defined (the shot has no materials:)", I->label,
                          o->material_name);
            report_inst(L, I, KK_OBJECTS_MATERIAL, KF_DIAG_ERROR, msg);
        }
    }
    /* a mesh must exist now, not after an hour of simulation */
    int meshk = KK_OBJECTS_MESH;
    if (o->shape == KF_SOURCE_MESH && I->ok[meshk])
        resolve_mesh_path(L, I, s, KK_OBJECTS_MESH, o->mesh, o->mesh_path, sizeof o->mesh_path);
    o->fit = I->at[KK_OBJECTS_FIT] != NULL && o->shape == KF_SOURCE_MESH;
    placement(o);
    if (o->fit) memcpy(o->center, o->place.fit_center, sizeof o->center);
    o->at = loc_of(L, s, I->map);
    if (I->at[meshk]) o->mesh_at = loc_of(L, s, I->at[meshk]);
}

/* A mesh collider is placed like a mesh object (the sampler's placement);
 * its pivot, the origin of its distance grid and of its keys, is the given
 * pivot, else the fitted bounding box's centre, else where its origin went. */
static void collider_placement(const inst *I, kf_shot_collider *c) {
    kf_placement *p = &c->place;
    memset(p, 0, sizeof *p);
    if (c->col.shape != KF_SHAPE_MESH) return;
    c->fit = I->at[KK_COLLIDERS_FIT] != NULL;
    memcpy(p->rotate, c->rotate, sizeof p->rotate);
    memcpy(p->scale, c->scale, sizeof p->scale);
    for (int a = 0; a < 3; a++) {
        p->translate[a] = c->translate[a];
        p->fit_center[a] = c->fit ? c->fit_center[a] + c->translate[a] : 0;
    }
    p->fit = c->fit;
    p->fit_size = c->fit ? c->fit_size : 0;
    if (I->at[KK_COLLIDERS_PIVOT]) memcpy(c->col.center, c->pivot, sizeof c->col.center);
    else memcpy(c->col.center, c->fit ? p->fit_center : p->translate, sizeof c->col.center);
}

/* The keys of a collider or rigid body (the key instances under instance
 * ii): frames → seconds from the shot's start, offsets from origin →
 * absolute pivot positions, scale from the key (scaled) or 1. Frames must
 * increase and there are at most KF_MAX_KEYS. Returns how many were made. */
static int resolve_keys(loader *L, int ii, const kf_shot *s, int times_ok, kf_key_id frame_key, const double origin[3],
                        int scaled, kf_key *keys) {
    const inst *I = &L->v[ii];
    char msg[512];
    int nk = 0;
    double prev = 0;
    for (int j = 0; j < L->n; j++) {
        inst *KI = &L->v[j];
        if (KI->scope != KS_KEY || KI->parent != ii) continue;
        check_presence(L, KI);
        const kf_rawkey *rk = KI->base;
        if (nk == KF_MAX_KEYS) {
            snprintf(msg, sizeof msg, "%s: too many keys (at most %d)", I->label, KF_MAX_KEYS);
            report_inst(L, KI, frame_key, KF_DIAG_ERROR, msg);
            break;
        }
        if (KI->ok[frame_key] && nk > 0 && !(rk->frame > prev)) {
            snprintf(msg, sizeof msg, "%s.frame must come after the previous key's frame %g, got %g", KI->label, prev,
                     rk->frame);
            report_inst(L, KI, frame_key, KF_DIAG_ERROR, msg);
        }
        if (KI->ok[frame_key]) prev = rk->frame;
        kf_key *key = &keys[nk];
        if (times_ok) key->time = (rk->frame - s->frame_start) / s->fps;
        for (int a = 0; a < 3; a++) {
            key->position[a] = origin[a] + rk->translate[a];
            key->rotate[a] = rk->rotate[a];
            key->scale[a] = scaled ? rk->scale[a] : 1;
        }
        nk++;
    }
    return nk;
}

static void resolve_collider(loader *L, int ii, int index, kf_shot *s, int times_ok, kf_shot_collider *c) {
    inst *I = &L->v[ii];
    char msg[512];
    *c = *(const kf_shot_collider *)I->base;
    c->at = loc_of(L, s, I->map);
    check_presence(L, I);
    if (!I->at[KK_COLLIDERS_NAME]) default_name(c->name, sizeof c->name, I, KK_COLLIDERS_SHAPE, index);
    if (c->col.shape == KF_SHAPE_PLANE) {
        double len = sqrt(c->col.normal[0] * c->col.normal[0] + c->col.normal[1] * c->col.normal[1] +
                          c->col.normal[2] * c->col.normal[2]);
        if (len > 0)
            for (int a = 0; a < 3; a++) c->col.normal[a] /= len;
    }
    for (int a = 0; a < 3; a++) c->col.half[a] = 0.5 * c->size[a];
    /* a box's rest orientation is the collider's; a mesh's goes into its placement */
    if (c->col.shape == KF_SHAPE_BOX) memcpy(c->col.rotate, c->rotate, sizeof c->col.rotate);
    int meshk = KK_COLLIDERS_MESH;
    if (c->col.shape == KF_SHAPE_MESH && I->ok[meshk])
        resolve_mesh_path(L, I, s, KK_COLLIDERS_MESH, c->mesh, c->mesh_path, sizeof c->mesh_path);
    collider_placement(I, c);
    if (I->at[meshk]) c->mesh_at = loc_of(L, s, I->at[meshk]);
    /* keys: frames → seconds, offsets → absolute pivot positions */
    int nk = resolve_keys(L, ii, s, times_ok, KK_COLLIDERS_KEYS_FRAME, c->col.center, 1, c->col.keys);
    if (nk > 0 && I->at[KK_COLLIDERS_VELOCITY]) {
        snprintf(msg, sizeof msg, "%s: give velocity or keys, not both (keys define the motion)", I->label);
        report_inst(L, I, KK_COLLIDERS_VELOCITY, KF_DIAG_ERROR, msg);
    }
    if (nk < 2 && I->at[KK_COLLIDERS_INTERPOLATION]) {
        snprintf(msg, sizeof msg, "%s.interpolation has no effect with %s", I->label,
                 nk ? "one key (the collider is held there)" : "no keys");
        report_inst(L, I, KK_COLLIDERS_INTERPOLATION, KF_DIAG_WARNING, msg);
    }
    c->col.nkeys = nk; /* one key: held there */
}

/* A rigid body: its mesh must exist, keys belong to kinematic bodies only,
 * and a kinematic body moves by keys or by a velocity, not both. */
static void resolve_rigid(loader *L, int ii, int index, kf_shot *s, int times_ok, kf_shot_rigid *r) {
    inst *I = &L->v[ii];
    char msg[512], motion[32];
    *r = *(const kf_shot_rigid *)I->base;
    r->at = loc_of(L, s, I->map);
    check_presence(L, I);
    if (!I->at[KK_RIGIDS_NAME]) {
        char name[64];
        default_name(name, sizeof name, I, KK_RIGIDS_SHAPE, index);
        snprintf(r->def.name, sizeof r->def.name, "%.31s", name);
    }
    int meshk = KK_RIGIDS_MESH;
    if (r->shape == 1 && I->ok[meshk])
        resolve_mesh_path(L, I, s, KK_RIGIDS_MESH, r->mesh, r->mesh_path, sizeof r->mesh_path);
    if (I->at[meshk]) r->mesh_at = loc_of(L, s, I->at[meshk]);
    r->pivot_set = I->at[KK_RIGIDS_PIVOT] != NULL;
    kf_key_choice(&kf_keys[KK_RIGIDS_MOTION], (int)r->def.motion, motion, sizeof motion);
    int nk = resolve_keys(L, ii, s, times_ok, KK_RIGIDS_KEYS_FRAME, r->def.position, 0, r->def.keys);
    int keysk = KK_RIGIDS_KEYS;
    if (I->at[keysk] && r->def.motion != KF_RIGID_KINEMATIC) {
        snprintf(msg, sizeof msg, "%s.keys: only a kinematic body follows keys (this one is %s; add motion: kinematic)",
                 I->label, motion);
        report_inst(L, I, KK_RIGIDS_KEYS, KF_DIAG_ERROR, msg);
    }
    if (nk > 0 && (I->at[KK_RIGIDS_VELOCITY] || I->at[KK_RIGIDS_ANGULAR_VELOCITY])) {
        snprintf(msg, sizeof msg, "%s: give velocities or keys, not both (keys define the motion)", I->label);
        report_inst(L, I, I->at[KK_RIGIDS_VELOCITY] ? KK_RIGIDS_VELOCITY : KK_RIGIDS_ANGULAR_VELOCITY,
                    KF_DIAG_ERROR, msg);
    }
    if (nk < 2 && I->at[KK_RIGIDS_INTERPOLATION] && r->def.motion == KF_RIGID_KINEMATIC) {
        snprintf(msg, sizeof msg, "%s.interpolation has no effect with %s", I->label,
                 nk ? "one key (the body is held there)" : "no keys");
        report_inst(L, I, KK_RIGIDS_INTERPOLATION, KF_DIAG_WARNING, msg);
    }
    r->def.nkeys = r->def.motion == KF_RIGID_KINEMATIC ? nk : 0;
}

/* A joint names its bodies: each must be a dynamic rigid body of the shot
 * (or the world for `to`), and not the same one twice. */
static int joint_body(loader *L, inst *I, const kf_shot *s, kf_key_id key, const char *name, int world_ok) {
    char msg[900];
    const char *names[KF_MAX_RIGIDS + 64] = {0};
    int n = 0, found = -1;
    for (int i = 0; i < s->nrigids && n < (int)(sizeof names / sizeof *names) - 1; i++) {
        if (!strcmp(s->rigids[i].def.name, name)) found = i;
        names[n++] = s->rigids[i].def.name;
    }
    if (world_ok && !strcmp(name, "world")) return -1;
    if (found < 0) {
        const char *near = kf_suggest(name, names, n);
        char list[600] = "";
        for (int i = 0; i < n; i++) {
            size_t l = strlen(list);
            snprintf(list + l, sizeof list - l, "%s%s", i ? ", " : "", names[i]);
        }
        if (near) snprintf(msg, sizeof msg, "%s: rigid body '%s' is not defined (did you mean '%s'?)", I->label, name, near);
        else if (n) snprintf(msg, sizeof msg, "%s: rigid body '%s' is not defined; rigid bodies: %s%s", I->label, name,
                             list, world_ok ? " (or world)" : "");
        else snprintf(msg, sizeof msg, "%s: rigid body '%s' is not defined (the shot has no rigids:)", I->label, name);
        report_inst(L, I, key, KF_DIAG_ERROR, msg);
        return -2;
    }
    if (s->rigids[found].def.motion != KF_RIGID_DYNAMIC) {
        char motion[32];
        kf_key_choice(&kf_keys[KK_RIGIDS_MOTION], (int)s->rigids[found].def.motion, motion, sizeof motion);
        snprintf(msg, sizeof msg, "%s: rigid body '%s' is %s; joints connect dynamic bodies (and the world)", I->label,
                 name, motion);
        report_inst(L, I, key, KF_DIAG_ERROR, msg);
        return -2;
    }
    return found;
}

static void resolve_joint(loader *L, inst *I, int index, kf_shot *s, kf_shot_joint *j) {
    char msg[256];
    *j = *(const kf_shot_joint *)I->base;
    j->at = loc_of(L, s, I->map);
    check_presence(L, I);
    if (!I->at[KK_JOINTS_NAME]) default_name(j->name, sizeof j->name, I, KK_JOINTS_TYPE, index);
    int bk = KK_JOINTS_BODY, tk = KK_JOINTS_TO;
    int a = I->ok[bk] ? joint_body(L, I, s, KK_JOINTS_BODY, j->body, 0) : -2;
    int b = !I->at[tk] || I->ok[tk] ? joint_body(L, I, s, KK_JOINTS_TO, j->to, 1) : -2;
    if (a >= 0 && a == b) {
        snprintf(msg, sizeof msg, "%s: a joint connects two different bodies ('%s' twice; use to: world for an axle)",
                 I->label, j->body);
        report_inst(L, I, KK_JOINTS_TO, KF_DIAG_ERROR, msg);
    }
    j->def.body_a = a;
    j->def.body_b = b;
    double len = sqrt(j->def.axis[0] * j->def.axis[0] + j->def.axis[1] * j->def.axis[1] + j->def.axis[2] * j->def.axis[2]);
    if (len > 0)
        for (int k = 0; k < 3; k++) j->def.axis[k] /= len;
}

/* two objects (or colliders) must not share a name: --set addresses by it */
static void check_unique(loader *L, kf_scope scope, kf_key_id key, const char *names, size_t stride, int n) {
    for (int i = 0, ii = 0; ii < L->n; ii++) {
        if (L->v[ii].scope != scope) continue;
        const char *a = names + (size_t)i * stride;
        for (int j = 0; j < i; j++)
            if (strcmp(a, names + (size_t)j * stride) == 0) {
                char msg[256];
                snprintf(msg, sizeof msg, "%s: the name '%s' is taken by an earlier item", L->v[ii].label, a);
                report_inst(L, &L->v[ii], key, KF_DIAG_ERROR, msg);
                break;
            }
        if (++i == n) break;
    }
}

/* 1 when a path has ".." as one of its components */
static int has_dotdot(const char *p) {
    for (const char *c = p; (c = strstr(c, "..")) != NULL; c += 2)
        if ((c == p || c[-1] == '/') && (c[2] == 0 || c[2] == '/')) return 1;
    return 0;
}

/* Outputs go under output.dir (relative to where kerf runs): an empty one
 * would write into "/" (".../particles" becomes "/particles"), and a name
 * that climbs out with ".." writes where the log does not say. */
static void check_output_paths(loader *L, inst *T, const kf_shot *s) {
    char msg[700];
    if (T->at[KK_OUTPUT_DIR] && T->ok[KK_OUTPUT_DIR] && strspn(s->output_dir, " \t") == strlen(s->output_dir)) {
        snprintf(msg, sizeof msg, "output.dir is empty: give a directory, relative to where kerf runs (e.g. out/{shot})");
        report_inst(L, T, KK_OUTPUT_DIR, KF_DIAG_ERROR, msg);
    }
    if (T->at[KK_OUTPUT_NAME] && T->ok[KK_OUTPUT_NAME] && has_dotdot(s->output_name)) {
        snprintf(msg, sizeof msg, "output.name must stay inside the output directory ('..' climbs out of it), got '%s'",
                 s->output_name);
        report_inst(L, T, KK_OUTPUT_NAME, KF_DIAG_ERROR, msg);
    }
}

static void resolve_top(loader *L, inst *T, const char *path, kf_shot *s) {
    const kf_top *t = T->base;
    char msg[256];
    *s = t->s;
    check_presence(L, T);
    /* where the shot lives, and its name */
    snprintf(s->path, sizeof s->path, "%s", path);
    const char *slash = strrchr(path, '/');
    if (slash) snprintf(s->dir, sizeof s->dir, "%.*s", (int)(slash - path + (slash == path)), path);
    else snprintf(s->dir, sizeof s->dir, ".");
    if (!T->at[KK_SHOT]) {
        const char *base = slash ? slash + 1 : path, *dot = strrchr(base, '.');
        snprintf(s->name, sizeof s->name, "%.*s", (int)(dot && dot != base ? dot - base : (long)strlen(base)), base);
    }
    int sk = KK_FRAMES_START, ek = KK_FRAMES_END;
    if (T->at[ek] && T->ok[ek] && (!T->at[sk] || T->ok[sk]) && s->frame_end < s->frame_start) {
        snprintf(msg, sizeof msg, "frames.end must not be before frames.start (%d), got %d", s->frame_start, s->frame_end);
        report_inst(L, T, KK_FRAMES_END, KF_DIAG_ERROR, msg);
    }
    /* a camera must look somewhere: eye and target may not coincide */
    int ek2 = KK_RENDER_EYE, tk = KK_RENDER_TARGET;
    s->render_eye_set = T->at[ek2] != NULL;
    s->render_target_set = T->at[tk] != NULL;
    if (s->render_eye_set && T->ok[ek2] && (!s->render_target_set || T->ok[tk])) {
        double d2 = 0;
        for (int a = 0; a < 3; a++) d2 += (s->render_eye[a] - s->render_target[a]) * (s->render_eye[a] - s->render_target[a]);
        if (s->render_target_set && !(d2 > 1e-12)) {
            snprintf(msg, sizeof msg, "render.eye is at render.target (%g, %g, %g): the camera looks nowhere",
                     s->render_eye[0], s->render_eye[1], s->render_eye[2]);
            report_inst(L, T, KK_RENDER_EYE, KF_DIAG_ERROR, msg);
        }
    }
    if (T->at[KK_OUTPUT_IMAGES] && s->output_images && !s->output_surface) {
        snprintf(msg, sizeof msg, "output.images renders the surfaces: it needs output.surface: true");
        report_inst(L, T, KK_OUTPUT_IMAGES, KF_DIAG_ERROR, msg);
    }
    int mk = KK_DOMAIN_MIN, xk = KK_DOMAIN_MAX;
    if ((!T->at[mk] || T->ok[mk]) && (!T->at[xk] || T->ok[xk]))
        for (int a = 0; a < 3; a++)
            if (!(s->sim.domain_max[a] > s->sim.domain_min[a])) {
                snprintf(msg, sizeof msg, "domain.max must be above domain.min on every axis (%c: %g <= %g)", "xyz"[a],
                         s->sim.domain_max[a], s->sim.domain_min[a]);
                report_inst(L, T, T->at[xk] ? KK_DOMAIN_MAX : KK_DOMAIN_MIN, KF_DIAG_ERROR, msg);
                break;
            }
    s->sim.walls = t->walls != 0;
    s->sim.wall_boundary = t->walls ? (kf_boundary)(t->walls - 1) : KF_BOUNDARY_SEPARATE;
    s->ppc_axis = (int)lround(cbrt((double)s->ppc));
    if (!strstr(s->output_name, "{frame")) {
        snprintf(msg, sizeof msg, "output.name must contain {frame} (or {frame:04d}) so frames do not overwrite each other");
        report_inst(L, T, KK_OUTPUT_NAME, KF_DIAG_ERROR, msg);
    }
    check_output_paths(L, T, s);
    s->dx_at = loc_of(L, s, node_for(T, KK_SIM_DX));
    s->cfl_at = loc_of(L, s, node_for(T, KK_SIM_CFL));
    s->dt_fixed_at = loc_of(L, s, node_for(T, KK_SIM_DT_FIXED));
    s->dt_max_at = loc_of(L, s, node_for(T, KK_SIM_DT_MAX));
    s->resolution_scale = 1;
}

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
        kf_diag_add(d, KF_DIAG_ERROR, path, 0, 0, NULL, "cannot read the shot file: %s", strerror(errno ? errno : ENOMEM));
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
    int top = inst_new(&L, KS_TOP, "", "", root, -1);
    if (top < 0) goto done;
    walk_map(&L, top, root, "");
    resolve_top(&L, &L.v[top], path, s);
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
        if (L.v[i].scope == KS_MATERIAL) resolve_material(&L, &L.v[i], s, &s->materials[s->nmaterials++]);
        else if (L.v[i].scope == KS_OBJECT) {
            resolve_object(&L, &L.v[i], s->nobjects, s, &s->objects[s->nobjects]);
            s->nobjects++;
        } else if (L.v[i].scope == KS_COLLIDER) {
            resolve_collider(&L, i, s->ncolliders, s, times_ok, &s->colliders[s->ncolliders]);
            s->ncolliders++;
        } else if (L.v[i].scope == KS_RIGID) {
            resolve_rigid(&L, i, s->nrigids, s, times_ok, &s->rigids[s->nrigids]);
            s->nrigids++;
        }
    }
    for (int i = 0; i < L.n; i++) /* joints name bodies, wherever they are in the file */
        if (L.v[i].scope == KS_JOINT) {
            resolve_joint(&L, &L.v[i], s->njoints, s, &s->joints[s->njoints]);
            s->njoints++;
        }
    check_unique(&L, KS_RIGID, KK_RIGIDS_NAME, s->rigids[0].def.name, sizeof *s->rigids, nr);
    check_unique(&L, KS_JOINT, KK_JOINTS_NAME, s->joints[0].name, sizeof *s->joints, nj);
    for (int i = 0, r = 0; i < L.n && nr > KF_MAX_RIGIDS; i++) /* reported at the first body over the limit */
        if (L.v[i].scope == KS_RIGID && r++ == KF_MAX_RIGIDS)
            kf_report_at(d, &L.srcs, L.v[i].map, KF_DIAG_ERROR,
                         "%s: too many rigid bodies: %d (at most %d: a grid node holds 2 bits per body in one 32-bit "
                         "word)", L.v[i].label, nr, KF_MAX_RIGIDS);
    if (nj > KF_MAX_JOINTS) report_inst(&L, T, KK_JOINTS, KF_DIAG_ERROR, "too many joints (at most 32)");
    check_unique(&L, KS_OBJECT, KK_OBJECTS_NAME, s->objects[0].name, sizeof *s->objects, no);
    /* sim.contact auto: on where objects can touch each other */
    const int contact_mode = ((const kf_top *)T->base)->contact;
    s->sim.contact = contact_mode == 0 || (contact_mode == 2 && s->nobjects > 1);
    check_unique(&L, KS_COLLIDER, KK_COLLIDERS_NAME, s->colliders[0].name, sizeof *s->colliders, nc);
    if (no == 0)
        report_inst(&L, T, KK_OBJECTS, KF_DIAG_ERROR, "the shot has no objects: nothing would be simulated");
    if (nm > KF_MAX_MATERIALS) report_inst(&L, T, KK_MATERIALS, KF_DIAG_ERROR, "too many materials (at most 64)");
    if (nc > KF_MAX_COLLIDERS) report_inst(&L, T, KK_COLLIDERS, KF_DIAG_ERROR, "too many colliders (at most 64)");
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
    }
    /* the preview presets (surface.quality, render.quality): what the shot
     * sets itself wins; the numbers live beside the code they drive */
    if (s->surface_quality == 1) {
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
    for (int i = 0; i < L.n; i++) inst_free(&L.v[i]);
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
