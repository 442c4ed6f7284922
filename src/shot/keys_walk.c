/* keys_walk.c — every key of a loaded shot with its value, straight from the
 * key table: what a tool that shows and edits a shot (kerf view) lists.
 *
 * A value is printed the way --set takes it back, so an edit round-trips
 * through the same validation as the command line. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "loader.h"

static const char *type_name(kf_ktype t) {
    switch (t) {
    case KT_NUM: return "number";
    case KT_INT: return "integer";
    case KT_BOOL: return "bool";
    case KT_STR: return "string";
    case KT_ENUM: return "enum";
    case KT_VEC3: return "vec3";
    case KT_PRESET: return "preset";
    case KT_REF: return "material";
    default: return "section";
    }
}

/* a double that reads back to the same value, as short as that allows */
static void num_text(double v, int auto_ok, char *out, size_t n) {
    if (auto_ok && v == KF_RIGID_AUTO) {
        snprintf(out, n, "auto");
        return;
    }
    snprintf(out, n, "%.15g", v);
    double back;
    if (sscanf(out, "%lf", &back) != 1 || back != v) snprintf(out, n, "%.17g", v);
}

/* a number the key's bounds allow (a field outside them holds "unset: computed") */
static int allowed(const kf_keydef *k, double v) {
    if (k->flags & KF_AUTO && v == KF_RIGID_AUTO) return 1;
    if (!isfinite(v)) return 0;
    if (k->bounds & KB_LO && (k->bounds & KB_LO_OPEN ? !(v > k->lo) : !(v >= k->lo))) return 0;
    if (k->bounds & KB_HI && (k->bounds & KB_HI_OPEN ? !(v < k->hi) : !(v <= k->hi))) return 0;
    return 1;
}

/* the field at base + off as --set text; "" when it holds no value of the key's
 * (a colour left to the material's kind): the default applies */
static void value_text(const kf_keydef *k, const void *base, char *out, size_t n) {
    const char *p = (const char *)base + k->off;
    char a[40], b[40], c[40];
    out[0] = 0;
    switch (k->type) {
    case KT_NUM:
        if (allowed(k, *(const double *)p)) num_text(*(const double *)p, (k->flags & KF_AUTO) != 0, out, n);
        break;
    case KT_INT: snprintf(out, n, "%d", *(const int *)p); break;
    case KT_BOOL: snprintf(out, n, "%s", *(const int *)p ? "true" : "false"); break;
    case KT_ENUM: kf_key_choice(k, *(const int *)p, out, n); break;
    case KT_VEC3: {
        const double *v = (const double *)p;
        if (!allowed(k, v[0]) || !allowed(k, v[1]) || !allowed(k, v[2])) break;
        num_text(v[0], 0, a, sizeof a);
        num_text(v[1], 0, b, sizeof b);
        num_text(v[2], 0, c, sizeof c);
        snprintf(out, n, "[%s, %s, %s]", a, b, c);
        break;
    }
    case KT_STR:
    case KT_PRESET:
    case KT_REF: snprintf(out, n, "%.*s", (int)k->size, p); break;
    default: break;
    }
}

/* `only` ("shape=sphere|cylinder") on an instance: the condition key is an
 * enum of the same scope, read from the instance */
static int only_holds(const kf_keydef *k, const void *base, size_t base_size) {
    if (!k->only) return 1;
    const char *eq = strchr(k->only, '=');
    char parent[96], cond[160], val[64];
    kf_key_parent(k, parent, sizeof parent);
    /* a key inside a section (objects[].fit.size) names its instance's key */
    char *dot = strstr(parent, "[]");
    if (!dot) dot = strstr(parent, ".*");
    if (dot) dot[2] = 0;
    snprintf(cond, sizeof cond, "%s%s%.*s", parent, parent[0] ? "." : "", (int)(eq - k->only), k->only);
    int c = kf_key_find(cond);
    if (c < 0 || kf_keys[c].type != KT_ENUM || kf_keys[c].off + kf_keys[c].size > base_size) return 1;
    kf_key_choice(&kf_keys[c], *(const int *)((const char *)base + kf_keys[c].off), val, sizeof val);
    size_t len = strlen(val);
    for (const char *p = eq + 1; *p;) {
        size_t l = strcspn(p, "|");
        if (l == len && strncmp(p, val, l) == 0) return 1;
        p += l + (p[l] == '|');
    }
    return 0;
}

/* the keys of one instance: prefix "" (top), "materials.*", "objects[]",
 * "rigids[].keys[]", ...; set: its --set path ("rigids.knife.keys.2"), "" at
 * the top. With I (an instance of the file as written), a key shows the value
 * the file gives it, else its plain default, else nothing (computed). */
static int walk(const kf_shot *shot, const char *prefix, const char *set, const void *base, size_t base_size,
                const inst *I, kf_shot_key_fn fn, void *ctx) {
    size_t pl = strlen(prefix);
    for (int e = 0; e < kf_nkeys; e++) {
        const kf_keydef *k = &kf_keys[e];
        if (k->type == KT_SECTION || k->type == KT_DICT || k->type == KT_LIST) continue;
        if (pl ? strncmp(k->path, prefix, pl) != 0 || k->path[pl] != '.' : strchr(k->path, '*') || strchr(k->path, '['))
            continue;
        if (pl && (strstr(k->path + pl, "[]") || strchr(k->path + pl, '*'))) continue; /* keys of keys */
        kf_shot_keyview v;
        memset(&v, 0, sizeof v);
        if (pl) snprintf(v.path, sizeof v.path, "%s%s", set, k->path + pl);
        else snprintf(v.path, sizeof v.path, "%s", k->path);
        v.key = k->path;
        v.type = type_name(k->type);
        v.choices = k->choices;
        v.def = k->def;
        v.unit = k->unit;
        v.doc = k->doc;
        v.applies = only_holds(k, base, base_size);
        kf_key_bounds_text(k, v.bounds, sizeof v.bounds);
        if (!strcmp(k->path, "domain.walls"))
            snprintf(v.value, sizeof v.value, "%s",
                     !shot->sim.walls ? "none"
                                      : (const char *[]){"sticky", "slip", "separate"}[shot->sim.wall_boundary]);
        else if (I && !I->at[e] && (!k->def || k->def[0] == '('))
            v.value[0] = 0; /* not in the file, and computed: no value of its own to show */
        else if (k->off + k->size <= base_size) value_text(k, base, v.value, sizeof v.value);
        /* a camera left out is computed: no value of its own to show */
        if ((!strcmp(k->path, "render.eye") && !shot->render_eye_set) ||
            (!strcmp(k->path, "render.target") && !shot->render_target_set))
            v.value[0] = 0;
        /* names, paths, templates and the version are the tool's to choose, not an edit's */
        v.editable = k->type != KT_STR && strcmp(k->path, "version") && strncmp(k->path, "output.", 7) &&
                     strcmp(k->path, "sim.threads");
        int rc = fn(&v, ctx);
        if (rc) return rc;
    }
    return 0;
}

/* ---- the lists as written ------------------------------------------------------
 * A loaded collider, rigid body, joint or key holds values the loader has
 * transformed (keys in seconds and absolute positions, a body's rotation baked
 * into its surface, axes normalised), so these come from the file itself,
 * walked against the same table the loader uses. */

static char *read_all(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    size_t cap = 1 << 16, n = 0;
    char *t = malloc(cap);
    for (size_t r; t && (r = fread(t + n, 1, cap - n - 1, f)) > 0;) {
        n += r;
        if (n + 1 == cap) {
            char *g = realloc(t, cap *= 2);
            if (!g) free(t);
            t = g;
        }
    }
    fclose(f);
    if (t) t[n] = 0, *len = n;
    return t;
}

/* an item's --set path: its parent's, the list's key, then its name where the
 * file gives one, else its index ("rigids.knife.keys.2", "joints.0") */
static void set_path(const loader *L, int ii, char *out, size_t n) {
    const inst *I = &L->v[ii], *P = &L->v[I->parent];
    char parent[256] = "";
    if (P->scope != KS_TOP) set_path(L, I->parent, parent, sizeof parent);
    const char *rel = I->prefix + strlen(P->prefix);
    if (*rel == '.') rel++;
    int rl = (int)strcspn(rel, "[");
    const char *open = strrchr(I->label, '[');
    int index = open ? atoi(open + 1) : 0;
    const ky_node *name = I->map ? ky_get(I->map, "name", NULL) : NULL;
    char item[80];
    if (name && name->kind == KY_SCALAR && name->text[0]) snprintf(item, sizeof item, "%s", name->text);
    else snprintf(item, sizeof item, "%d", index);
    snprintf(out, n, "%s%s%.*s.%s", parent, parent[0] ? "." : "", rl, rel, item);
}

/* the instance and, after it, the keys it holds */
static int walk_item(const kf_shot *shot, const loader *L, int ii, kf_shot_key_fn fn, void *ctx) {
    static const size_t size[KS_COUNT] = {
        0, 0, 0, sizeof(kf_shot_collider), sizeof(kf_rawkey), sizeof(kf_shot_rigid), sizeof(kf_shot_joint)};
    const inst *I = &L->v[ii];
    char set[256];
    set_path(L, ii, set, sizeof set);
    int rc = walk(shot, I->prefix, set, I->base, size[I->scope], I, fn, ctx);
    for (int j = ii + 1; !rc && j < L->n; j++)
        if (L->v[j].scope == KS_KEY && L->v[j].parent == ii) rc = walk_item(shot, L, j, fn, ctx);
    return rc;
}

int kf_shot_keys_each(const kf_shot *shot, kf_shot_key_fn fn, void *ctx) {
    int rc = walk(shot, "", "", shot, sizeof *shot, NULL, fn, ctx);
    for (int i = 0; !rc && i < shot->nmaterials; i++) {
        char set[160];
        snprintf(set, sizeof set, "materials.%s", shot->materials[i].mat.name);
        rc = walk(shot, "materials.*", set, &shot->materials[i], sizeof shot->materials[i], NULL, fn, ctx);
    }
    for (int i = 0; !rc && i < shot->nobjects; i++) {
        char set[160];
        snprintf(set, sizeof set, "objects.%s", shot->objects[i].name);
        rc = walk(shot, "objects[]", set, &shot->objects[i], sizeof shot->objects[i], NULL, fn, ctx);
    }
    if (rc) return rc;

    /* camera keys, colliders, rigid bodies (each with its keys), joints: from the file */
    loader L = {0};
    kf_diag d;
    kf_diag_init(&d);
    L.d = &d;
    size_t len = 0;
    char *text = read_all(shot->path, &len);
    int src = text ? kf_srcs_add(&L.srcs, shot->path, text, len, 0, 0, NULL) : -1, empty = 0;
    if (text && src < 0) free(text);
    size_t pl = strlen(shot->path);
    int json = pl > 5 && !strcmp(shot->path + pl - 5, ".json");
    ky_node *root = src >= 0 ? ky_parse(&L.doc, &L.srcs, src, json, &d, &empty) : NULL;
    if (root && root->kind == KY_MAP && kf_inst_new(&L, KS_TOP, "", "", root, -1) == 0) {
        kf_walk_map(&L, 0, root, "");
        static const kf_scope order[] = {KS_KEY, KS_COLLIDER, KS_RIGID, KS_JOINT};
        for (int o = 0; o < 4; o++)
            for (int i = 1; !rc && i < L.n; i++)
                if (L.v[i].scope == order[o] && (order[o] != KS_KEY || L.v[i].parent == 0))
                    rc = walk_item(shot, &L, i, fn, ctx);
    }
    for (int i = 0; i < L.n; i++) kf_inst_free(&L.v[i]);
    free(L.v);
    ky_free(&L.doc);
    kf_srcs_free(&L.srcs);
    kf_diag_free(&d);
    return rc;
}
