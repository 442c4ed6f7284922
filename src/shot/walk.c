/* walk.c — the generic walk of a shot: each mapping checked key by key
 * against the table (unknown keys with a suggestion, wrong shapes, values out
 * of bounds), one instance per struct it fills, and what the table says about
 * presence (required keys, keys that hold only with another's value). Knows
 * no section: the checks that need one are in resolve.c. */
#include <ctype.h>
#include <stdlib.h>
#include <string.h>

#include "loader.h"

/* ---- instances: one per struct the walk fills ------------------------------------ */

static const size_t scope_size[KS_COUNT] = {sizeof(kf_top),           sizeof(kf_shot_material), sizeof(kf_shot_object),
                                            sizeof(kf_shot_collider), sizeof(kf_rawkey),        sizeof(kf_shot_rigid),
                                            sizeof(kf_shot_joint)};

int kf_inst_new(loader *L, kf_scope scope, const char *prefix, const char *label, const ky_node *map, int parent) {
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

void kf_inst_free(inst *I) {
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
        int c = kf_inst_new(L, k->scope, prefix, label, body, ii);
        if (c < 0) return;
        L->v[c].name = name;
        kf_walk_map(L, c, body, prefix);
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
        int c = kf_inst_new(L, k->scope, prefix, label, v->item[i], ii);
        if (c < 0) return;
        kf_walk_map(L, c, v->item[i], prefix);
    }
}

void kf_walk_map(loader *L, int ii, const ky_node *map, const char *prefix) {
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
            if (ok && !ky_is_null(v)) kf_walk_map(L, ii, v, k->path);
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
void kf_check_presence(loader *L, inst *I) {
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
                kf_report_at(L->d, &L->srcs, I->keyat[e], KF_DIAG_WARNING, "%s has no effect with %s %s (only with %s)",
                             what, cond, val, opts);
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

/* ---- pointing at what a message is about ------------------------------------------- */

/* the node to point at for a key of an instance: its value, else the instance */
const ky_node *kf_node_for(const inst *I, int key) {
    if (key >= 0 && I->at[key]) return I->at[key];
    return I->name ? I->name : I->map;
}

void kf_report_inst(loader *L, const inst *I, int key, kf_severity sev, const char *msg) {
    const ky_node *n = kf_node_for(I, key);
    if (n) kf_report_at(L->d, &L->srcs, n, sev, "%s", msg);
    else kf_report(L->d, &L->srcs, 0, 1, 1, sev, "%s", msg);
}
