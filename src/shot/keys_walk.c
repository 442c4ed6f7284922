/* keys_walk.c — every key of a loaded shot with its value, straight from the
 * key table: what a tool that shows and edits a shot (kerf view) lists.
 *
 * A value is printed the way --set takes it back, so an edit round-trips
 * through the same validation as the command line. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "internal.h"

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

/* the keys of one instance: prefix "" (top), "materials.*", "objects[]", ...;
 * name: its --set name */
static int walk(const kf_shot *shot, const char *prefix, const char *name, const void *base, size_t base_size,
                kf_shot_key_fn fn, void *ctx) {
    size_t pl = strlen(prefix);
    for (int e = 0; e < kf_nkeys; e++) {
        const kf_keydef *k = &kf_keys[e];
        if (k->type == KT_SECTION || k->type == KT_DICT || k->type == KT_LIST) continue;
        if (pl ? strncmp(k->path, prefix, pl) != 0 || k->path[pl] != '.' : strchr(k->path, '*') || strchr(k->path, '['))
            continue;
        if (pl && (strstr(k->path + pl, "[]") || strchr(k->path + pl, '*'))) continue; /* keys of keys */
        kf_shot_keyview v;
        memset(&v, 0, sizeof v);
        if (pl) snprintf(v.path, sizeof v.path, "%.*s.%s%s", (int)strcspn(prefix, ".["), prefix, name, k->path + pl);
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
        else if (k->off + k->size <= base_size) value_text(k, base, v.value, sizeof v.value);
        /* a camera or pivot left out is computed: no value of its own to show */
        if ((!strcmp(k->path, "render.eye") && !shot->render_eye_set) ||
            (!strcmp(k->path, "render.target") && !shot->render_target_set) ||
            (!strcmp(k->path, "rigids[].pivot") && !((const kf_shot_rigid *)base)->pivot_set))
            v.value[0] = 0;
        /* names, paths, templates and the version are the tool's to choose, not an edit's */
        v.editable = k->type != KT_STR && strcmp(k->path, "version") && strncmp(k->path, "output.", 7) &&
                     strcmp(k->path, "sim.threads");
        int rc = fn(&v, ctx);
        if (rc) return rc;
    }
    return 0;
}

int kf_shot_keys_each(const kf_shot *shot, kf_shot_key_fn fn, void *ctx) {
    int rc = walk(shot, "", "", shot, sizeof *shot, fn, ctx);
    for (int i = 0; !rc && i < shot->nmaterials; i++)
        rc = walk(shot, "materials.*", shot->materials[i].mat.name, &shot->materials[i], sizeof shot->materials[i], fn,
                  ctx);
    for (int i = 0; !rc && i < shot->nobjects; i++)
        rc = walk(shot, "objects[]", shot->objects[i].name, &shot->objects[i], sizeof shot->objects[i], fn, ctx);
    for (int i = 0; !rc && i < shot->nrigids; i++)
        rc = walk(shot, "rigids[]", shot->rigids[i].def.name, &shot->rigids[i], sizeof shot->rigids[i], fn, ctx);
    return rc;
}
