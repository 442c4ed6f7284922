/* keys.c — the one table of shot-file keys, and everything read straight
 * from it: converting a node to a field, range checks and their message,
 * defaults, and `kerf help shot`.
 *
 * Adding a key is adding a row to key_list.h (and a field it writes); the
 * loader, overrides, error text and help pick it up with no other change. */
#include <ctype.h>
#include <math.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

/* ---- the table ------------------------------------------------------------------ */

#define F(T, m) offsetof(T, m), sizeof(((T *)0)->m)
#define TOP(m) KS_TOP, F(kf_top, m)
#define MAT(m) KS_MATERIAL, F(kf_shot_material, m)
#define OBJ(m) KS_OBJECT, F(kf_shot_object, m)
#define COL(m) KS_COLLIDER, F(kf_shot_collider, m)
#define KEY(m) KS_KEY, F(kf_rawkey, m)
#define RIG(m) KS_RIGID, F(kf_shot_rigid, m)
#define JNT(m) KS_JOINT, F(kf_shot_joint, m)
#define NOFIELD 0, 0

#define ANY 0, 0.0, 0.0
#define GT(a) KB_LO | KB_LO_OPEN, (double)(a), 0.0
#define GE(a) KB_LO, (double)(a), 0.0
#define CC(a, b) KB_LO | KB_HI, (double)(a), (double)(b)                           /* [a, b] */
#define OO(a, b) KB_LO | KB_LO_OPEN | KB_HI | KB_HI_OPEN, (double)(a), (double)(b) /* (a, b) */
#define CO(a, b) KB_LO | KB_HI | KB_HI_OPEN, (double)(a), (double)(b)              /* [a, b) */
#define OC(a, b) KB_LO | KB_LO_OPEN | KB_HI, (double)(a), (double)(b)              /* (a, b] */

#define PRESET_DEF "(the preset's)"
#define SOLID "model=corotated|von_mises|sand|snow"

/* the rows are key_list.h; each expands to one kf_keydef, in list order, so
 * kf_keys[KK_ID] is the row of KK_ID */
const kf_keydef kf_keys[] = {
#define KF_KEY(id, ...) {__VA_ARGS__},
#include "key_list.h"
#undef KF_KEY
};
const int kf_nkeys = (int)(sizeof kf_keys / sizeof kf_keys[0]);
_Static_assert(sizeof kf_keys / sizeof kf_keys[0] == KK_COUNT, "one table row per key id");

/* ---- table look-ups ------------------------------------------------------------------ */

int kf_key_find(const char *path) {
    for (int i = 0; i < kf_nkeys; i++)
        if (strcmp(kf_keys[i].path, path) == 0) return i;
    return -1;
}

const char *kf_key_leaf(const kf_keydef *k) {
    const char *dot = strrchr(k->path, '.');
    return dot ? dot + 1 : k->path;
}

void kf_key_parent(const kf_keydef *k, char *out, size_t n) {
    const char *dot = strrchr(k->path, '.');
    size_t len = dot ? (size_t)(dot - k->path) : 0;
    if (len >= n) len = n - 1;
    memcpy(out, k->path, len);
    out[len] = '\0';
}

const char *kf_key_choice(const kf_keydef *k, int i, char *buf, size_t n) {
    const char *p = k->choices ? k->choices : "";
    for (int j = 0; j < i && p; j++) {
        p = strchr(p, '|');
        if (p) p++;
    }
    buf[0] = '\0';
    if (!p || !*p) return buf;
    size_t len = strcspn(p, "|");
    if (len >= n) len = n - 1;
    memcpy(buf, p, len);
    buf[len] = '\0';
    return buf;
}

static int choice_index(const kf_keydef *k, const char *s) {
    char buf[64];
    for (int i = 0; *kf_key_choice(k, i, buf, sizeof buf); i++)
        if (strcmp(buf, s) == 0) return i;
    return -1;
}

/* "a, b or c" */
static void choices_text(const kf_keydef *k, char *out, size_t n) {
    char buf[64];
    int count = 0;
    while (*kf_key_choice(k, count, buf, sizeof buf)) count++;
    out[0] = '\0';
    for (int i = 0; i < count; i++) {
        size_t l = strlen(out);
        snprintf(out + l, n - l, "%s%s",
                 i == 0           ? ""
                 : i == count - 1 ? " or "
                                  : ", ",
                 kf_key_choice(k, i, buf, sizeof buf));
    }
}

/* whole numbers in full (9999999, not 1e+07), others as %g */
static const char *num_text(double v, char *buf, size_t n) {
    if (v == floor(v) && fabs(v) < 1e15) snprintf(buf, n, "%.0f", v);
    else snprintf(buf, n, "%g", v);
    return buf;
}

void kf_key_bounds_text(const kf_keydef *k, char *out, size_t n) {
    unsigned b = k->bounds;
    char lo[32], hi[32];
    num_text(k->lo, lo, sizeof lo);
    num_text(k->hi, hi, sizeof hi);
    if ((b & KB_LO) && (b & KB_HI))
        snprintf(out, n, "in %c%s, %s%c", b & KB_LO_OPEN ? '(' : '[', lo, hi, b & KB_HI_OPEN ? ')' : ']');
    else if (b & KB_LO) snprintf(out, n, "%s %s", b & KB_LO_OPEN ? ">" : ">=", lo);
    else if (b & KB_HI) snprintf(out, n, "%s %s", b & KB_HI_OPEN ? "<" : "<=", hi);
    else snprintf(out, n, "%s", "");
}

static int in_bounds(const kf_keydef *k, double v) {
    unsigned b = k->bounds;
    if (!isfinite(v)) return 0;
    if (b & KB_LO) {
        if (b & KB_LO_OPEN ? !(v > k->lo) : !(v >= k->lo)) return 0;
    }
    if (b & KB_HI) {
        if (b & KB_HI_OPEN ? !(v < k->hi) : !(v <= k->hi)) return 0;
    }
    return 1;
}

/* ---- node → value ------------------------------------------------------------------ */

/* how a node looks, for "expected X, got Y" */
static void describe(const ky_node *n, char *out, size_t len) {
    if (n->kind == KY_MAP) snprintf(out, len, "a mapping {...}");
    else if (n->kind == KY_SEQ) snprintf(out, len, "a list [...]");
    else if (ky_is_null(n)) snprintf(out, len, "nothing");
    else if (n->quoted) snprintf(out, len, "the string \"%.60s\"", n->text);
    else snprintf(out, len, "'%.60s'", n->text);
}

static int parse_number(const char *s, double *v) {
    if (!*s || strpbrk(s, "xXpP") || !(isdigit((unsigned char)*s) || strchr("+-.", *s))) return -1;
    char *end;
    *v = strtod(s, &end);
    return *end == '\0' && isfinite(*v) ? 0 : -1;
}

static int parse_int(const char *s, double *v) {
    if (!*s) return -1;
    char *end;
    long long x = strtoll(s, &end, 10);
    if (*end || x > 2147483647LL || x < -2147483647LL) return -1;
    *v = (double)x;
    return 0;
}

static int parse_bool(const char *s, int *v) {
    static const char *yes[] = {"true", "True", "TRUE", "yes", "Yes", "on", "On"};
    static const char *no[] = {"false", "False", "FALSE", "no", "No", "off", "Off"};
    for (int i = 0; i < 7; i++) {
        if (strcmp(s, yes[i]) == 0) return *v = 1, 0;
        if (strcmp(s, no[i]) == 0) return *v = 0, 0;
    }
    return -1;
}

/* a number in the key's bounds (and choices), or a reported error */
static int number_at(const kf_keydef *k, const ky_node *n, const char *what, int axis, double *out, kf_diag *d,
                     const kf_srcs *srcs) {
    char got[96], ax[4] = "";
    int whole = k->type == KT_INT;
    if (axis >= 0) snprintf(ax, sizeof ax, ".%c", "xyz"[axis]);
    if (n->kind != KY_SCALAR || n->quoted || (whole ? parse_int(n->text, out) : parse_number(n->text, out))) {
        int quoted_number = n->kind == KY_SCALAR && n->quoted && !parse_number(n->text, out);
        describe(n, got, sizeof got);
        kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s%s: expected %s, got %s%s", what, ax,
                     whole                  ? "a whole number"
                     : (k->flags & KF_AUTO) ? "auto or a number"
                                            : "a number",
                     got, quoted_number ? " (drop the quotes)" : "");
        return -1;
    }
    if (k->choices) {
        char buf[64], list[128];
        for (int i = 0; *kf_key_choice(k, i, buf, sizeof buf); i++)
            if (atof(buf) == *out) return 0;
        choices_text(k, list, sizeof list);
        kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s must be %s, got %s", what, list, n->text);
        return -1;
    }
    if (!in_bounds(k, *out)) {
        char bt[96];
        kf_key_bounds_text(k, bt, sizeof bt);
        kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s%s must be %s%s%s, got %s", what, ax, bt, k->unit ? " " : "",
                     k->unit ? k->unit : "", n->text);
        return -1;
    }
    return 0;
}

static int string_at(const kf_keydef *k, const ky_node *n, const char *what, char *dst, kf_diag *d,
                     const kf_srcs *srcs) {
    char got[96];
    if (n->kind != KY_SCALAR || ky_is_null(n)) {
        describe(n, got, sizeof got);
        kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: expected %s, got %s", what,
                     k->type == KT_STR && !(k->flags & KF_IDENT) ? "text" : "a name", got);
        return -1;
    }
    if (strlen(n->text) >= k->size) {
        kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s is too long (at most %zu characters)", what, k->size - 1);
        return -1;
    }
    if (k->flags & KF_IDENT) {
        for (const char *p = n->text; *p; p++)
            if (!isalnum((unsigned char)*p) && *p != '_' && *p != '-') {
                kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s '%s': a name holds only letters, digits, '_' and '-'", what,
                             n->text);
                return -1;
            }
    }
    if (k->flags & KF_TEMPLATE) {
        int at = 0;
        char why[128];
        if (kf_template_check(n->text, &at, why, sizeof why)) {
            kf_report(d, srcs, n->src, n->line, n->col + at + (n->quoted ? 1 : 0), KF_DIAG_ERROR, "%s: %s", what, why);
            return -1;
        }
    }
    memcpy(dst, n->text, strlen(n->text) + 1);
    return 0;
}

int kf_key_set(const kf_keydef *k, const ky_node *n, void *base, const char *what, kf_diag *d, const kf_srcs *srcs) {
    char *dst = (char *)base + k->off;
    char got[96], list[256];
    double v;
    switch (k->type) {
    case KT_NUM:
        if ((k->flags & KF_AUTO) && n->kind == KY_SCALAR && !n->quoted && strcmp(n->text, "auto") == 0) {
            *(double *)dst = KF_RIGID_AUTO;
            return 0;
        }
        if (number_at(k, n, what, -1, &v, d, srcs)) return -1;
        *(double *)dst = v;
        return 0;
    case KT_INT:
        if (number_at(k, n, what, -1, &v, d, srcs)) return -1;
        *(int *)dst = (int)v; /* int, or the uint32_t seed (bounded to int's range) */
        return 0;
    case KT_BOOL: {
        int b;
        if (n->kind != KY_SCALAR || n->quoted || parse_bool(n->text, &b)) {
            describe(n, got, sizeof got);
            kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: expected true or false, got %s", what, got);
            return -1;
        }
        *(int *)dst = b;
        return 0;
    }
    case KT_ENUM: {
        int i = n->kind == KY_SCALAR ? choice_index(k, n->text) : -1;
        if (i < 0) {
            char opts[16][64];
            const char *cand[16];
            int nc = 0;
            while (nc < 16 && *kf_key_choice(k, nc, opts[nc], sizeof opts[nc])) cand[nc] = opts[nc], nc++;
            const char *near = n->kind == KY_SCALAR ? kf_suggest(n->text, cand, nc) : NULL;
            describe(n, got, sizeof got);
            choices_text(k, list, sizeof list);
            if (near)
                kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: unknown value %s (did you mean '%s'?); choose %s", what,
                             got, near, list);
            else kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: expected %s, got %s", what, list, got);
            return -1;
        }
        *(int *)dst = i;
        return 0;
    }
    case KT_VEC3: {
        double x[3];
        if (n->kind == KY_SCALAR && (k->flags & KF_BROADCAST) && !ky_is_null(n) && !parse_number(n->text, &v)) {
            if (number_at(k, n, what, -1, &v, d, srcs)) return -1;
            x[0] = x[1] = x[2] = v;
        } else if (n->kind != KY_SEQ || n->n != 3) {
            if (n->kind == KY_SEQ) snprintf(got, sizeof got, "%d number%s", n->n, n->n == 1 ? "" : "s");
            else describe(n, got, sizeof got);
            kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: expected [x, y, z]%s, got %s", what,
                         k->flags & KF_BROADCAST ? " or one number" : "", got);
            return -1;
        } else {
            int bad = 0;
            for (int a = 0; a < 3; a++) bad |= number_at(k, n->item[a], what, a, &x[a], d, srcs);
            if (bad) return -1;
        }
        if ((k->flags & KF_NONZERO) && x[0] == 0 && x[1] == 0 && x[2] == 0) {
            kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s must not be [0, 0, 0]", what);
            return -1;
        }
        memcpy(dst, x, sizeof x);
        return 0;
    }
    case KT_PRESET: {
        const char *const *names = kf_material_preset_names();
        for (int i = 0; n->kind == KY_SCALAR && names[i]; i++)
            if (strcmp(names[i], n->text) == 0) return string_at(k, n, what, dst, d, srcs);
        list[0] = '\0';
        for (int i = 0; names[i]; i++) {
            size_t l = strlen(list);
            snprintf(list + l, sizeof list - l, "%s%s", i ? ", " : "", names[i]);
        }
        const char *near = n->kind == KY_SCALAR ? kf_suggest(n->text, names, -1) : NULL;
        describe(n, got, sizeof got);
        if (near)
            kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: unknown preset %s (did you mean '%s'?); presets: %s", what,
                         got, near, list);
        else kf_report_at(d, srcs, n, KF_DIAG_ERROR, "%s: unknown preset %s; presets: %s", what, got, list);
        return -1;
    }
    case KT_STR:
    case KT_REF: return string_at(k, n, what, dst, d, srcs);
    default: return 0;
    }
}

/* defaults are text in the same syntax as the file, so the help shows
 * exactly what a user would write */
int kf_key_default(const kf_keydef *k, void *base) {
    if (!k->def || k->def[0] == '(') return 0;
    char *dst = (char *)base + k->off;
    double v, x[3];
    int b;
    switch (k->type) {
    case KT_NUM:
        if ((k->flags & KF_AUTO) && strcmp(k->def, "auto") == 0) {
            *(double *)dst = KF_RIGID_AUTO;
            return 0;
        }
        if (parse_number(k->def, &v) || !in_bounds(k, v)) return -1;
        *(double *)dst = v;
        return 0;
    case KT_INT:
        if (parse_int(k->def, &v) || (!k->choices && !in_bounds(k, v))) return -1;
        *(int *)dst = (int)v;
        return 0;
    case KT_BOOL:
        if (parse_bool(k->def, &b)) return -1;
        *(int *)dst = b;
        return 0;
    case KT_ENUM:
        if ((b = choice_index(k, k->def)) < 0) return -1;
        *(int *)dst = b;
        return 0;
    case KT_VEC3:
        if (sscanf(k->def, "[%lf, %lf, %lf]", &x[0], &x[1], &x[2]) != 3) {
            if (!(k->flags & KF_BROADCAST) || parse_number(k->def, &x[0])) return -1;
            x[1] = x[2] = x[0];
        }
        for (int a = 0; a < 3; a++)
            if (!in_bounds(k, x[a])) return -1;
        memcpy(dst, x, sizeof x);
        return 0;
    case KT_STR:
        if (strlen(k->def) >= k->size) return -1;
        memcpy(dst, k->def, strlen(k->def) + 1);
        return 0;
    default: return 0;
    }
}

/* ---- kerf help shot ------------------------------------------------------------------ */

static void type_text(const kf_keydef *k, char *out, size_t n) {
    char bt[96], ch[256];
    kf_key_bounds_text(k, bt, sizeof bt);
    const char *unit = k->unit ? k->unit : "";
    switch (k->type) {
    case KT_NUM:
        snprintf(out, n, "%s%s%s%s%s", k->flags & KF_AUTO ? "auto or number" : "number", *bt ? " " : "", bt,
                 *unit ? ", " : "", unit);
        break;
    case KT_INT:
        if (k->choices) choices_text(k, ch, sizeof ch), snprintf(out, n, "%s", ch);
        else snprintf(out, n, "integer%s%s", *bt ? " " : "", bt);
        break;
    case KT_BOOL: snprintf(out, n, "true or false"); break;
    case KT_ENUM: choices_text(k, ch, sizeof ch), snprintf(out, n, "%s", ch); break;
    case KT_VEC3:
        snprintf(out, n, "[x, y, z]%s%s%s%s%s", k->flags & KF_BROADCAST ? " or one number" : "", *bt ? ", each " : "",
                 bt, *unit ? ", " : "", unit);
        break;
    case KT_PRESET: snprintf(out, n, "a preset name"); break;
    case KT_REF: snprintf(out, n, "a material name"); break;
    case KT_STR: snprintf(out, n, k->flags & KF_TEMPLATE ? "template" : k->flags & KF_IDENT ? "name" : "text"); break;
    case KT_SECTION: snprintf(out, n, "mapping"); break;
    case KT_DICT: snprintf(out, n, "mapping of NAME: {...}"); break;
    case KT_LIST: snprintf(out, n, "list of {...}"); break;
    }
}

/* "only for shape sphere or cylinder" */
static void only_text(const char *only, char *out, size_t n) {
    const char *eq = strchr(only, '=');
    snprintf(out, n, "only for %.*s ", (int)(eq - only), only);
    for (const char *p = eq + 1; *p; p++) {
        size_t l = strlen(out);
        if (*p == '|') snprintf(out + l, n - l, "%s", strchr(p + 1, '|') ? ", " : " or ");
        else if (l + 1 < n) out[l] = *p, out[l + 1] = '\0';
    }
}

void kf_shot_help(FILE *f) {
    fprintf(f, "kerf shot files: YAML (comments allowed) or JSON. Every key, with its type and default.\n"
               "Units are SI unless given. Keys a shot omits take the default; --set path=value overrides any\n"
               "key (list items by name or index: objects.cube.center=[0.5,0.6,0.5]).\n");
    for (int i = 0; i < kf_nkeys; i++) {
        const kf_keydef *k = &kf_keys[i];
        char path[96], ty[256], only[128] = "", def[160];
        int p = 0;
        for (const char *s = k->path; *s && p < (int)sizeof path - 8; s++) /* materials.*.E → materials.NAME.E */
            if (*s == '*') p += snprintf(path + p, sizeof path - p, "NAME");
            else path[p++] = *s;
        path[p] = '\0';
        type_text(k, ty, sizeof ty);
        if (k->only) only_text(k->only, only, sizeof only);
        if (k->type == KT_SECTION || k->type == KT_DICT || k->type == KT_LIST) {
            fprintf(f, "\n%s  (%s%s%s%s)\n    %s\n", path, ty, k->flags & KF_REQ ? ", required" : "", *only ? ", " : "",
                    only, k->doc);
            continue;
        }
        if (k->flags & KF_REQ) snprintf(def, sizeof def, "required");
        else if (k->def) snprintf(def, sizeof def, "default %s", k->def);
        else def[0] = '\0';
        fprintf(f, "  %-32s %s%s%s%s%s\n      %s\n", path, ty, *def ? "; " : "", def, *only ? "; " : "", only, k->doc);
    }
    fprintf(f, "\nmaterial presets (materials.NAME.preset):\n");
    const char *const *names = kf_material_preset_names();
    for (int i = 0; names[i]; i++) {
        kf_material m;
        kf_material_preset(names[i], &m);
        char ch[64];
        const kf_keydef *model = &kf_keys[KK_MATERIALS_MODEL];
        fprintf(f, "  %-10s model %-10s density %g kg/m^3", names[i], kf_key_choice(model, (int)m.model, ch, sizeof ch),
                m.density);
        if (m.model == KF_MAT_WATER) fprintf(f, ", bulk_modulus %g Pa, gamma %g\n", m.bulk_modulus, m.gamma);
        else fprintf(f, ", E %g Pa, nu %g\n", m.E, m.nu);
    }
    fprintf(f, "\ntemplates (output.dir, output.name): {shot}, {version}, {frame}, each with an optional\n"
               "zero-padded width, e.g. {version:03d} -> 001, {frame:04d} -> 1001; {{ and }} are braces.\n"
               "\npaths: mesh files (objects, colliders, rigids) are relative to the shot file's directory;\n"
               "output.dir and --out are relative to the directory kerf runs in.\n"
               "\ncommand line: --set path=value (repeatable), --quality preview|final (preview doubles sim.dx\n"
               "and halves image resolution), --frames A-B (a sub-range of frames.start..frames.end).\n");
}
