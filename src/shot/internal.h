/* internal.h — what the files of shot/ share: the parsed text tree (yaml.c),
 * the key table (keys.c), the loader's instances (shot.c) and the helpers
 * that turn a node into a diagnostic (diag.c). Not for use outside shot/. */
#ifndef KF_SHOT_INTERNAL_H
#define KF_SHOT_INTERNAL_H

#include <stddef.h>

#include "shot.h"

/* ---- inputs: the shot file and each command-line string ----------------- */

/* Every node remembers which input it came from. A file reports its own
 * line and column; a command-line string reports `--set:N:col` where N is
 * which --set and col counts from the start of the whole override. */
typedef struct kf_src {
    char *file; /* the name printed */
    char *text; /* the text parsed (owned) */
    size_t len;
    int line;   /* > 0: every node of this input reports this line */
    int col0;   /* added to columns (an override: the length of "path=") */
    char *echo; /* with line > 0: the text echoed under the message */
    int order;  /* diagnostics sort by input: 0 the file, then the command line */
} kf_src;

typedef struct kf_srcs {
    kf_src *v;
    int n, cap;
} kf_srcs;

int kf_srcs_add(kf_srcs *s, const char *file, char *text, size_t len, int line, int col0, const char *echo);
void kf_srcs_free(kf_srcs *s);

/* ---- the parsed tree ------------------------------------------------------ */

typedef enum ky_kind { KY_SCALAR, KY_MAP, KY_SEQ } ky_kind;

typedef struct ky_node {
    ky_kind kind;
    int src, line, col;    /* input, and 1-based position in it */
    char *text;            /* scalar: the value (unescaped, NUL-terminated) */
    int quoted;            /* scalar: written in quotes (so never a number) */
    struct ky_node **item; /* seq: n items; map: n pairs as key, value, key, value, ... */
    int n, cap;
} ky_node;

/* owns every node, so aliases may share them */
typedef struct ky_doc {
    ky_node **all;
    size_t n, cap;
} ky_doc;

ky_node *ky_new(ky_doc *doc, ky_kind kind, int src, int line, int col);
void ky_push(ky_node *parent, ky_node *child);
ky_node *ky_scalar(ky_doc *doc, const char *text, int src, int line, int col);
/* Parse input src of srcs; NULL on a syntax error (reported) or an empty
 * document (*empty set, not reported). */
ky_node *ky_parse(ky_doc *doc, const kf_srcs *srcs, int src, int json, kf_diag *d, int *empty);
/* map: the value of key (or NULL), and its key node in *keyp */
ky_node *ky_get(const ky_node *map, const char *key, ky_node **keyp);
int ky_is_null(const ky_node *n);
void ky_free(ky_doc *doc);

/* ---- reporting ------------------------------------------------------------ */

void kf_report(kf_diag *d, const kf_srcs *srcs, int src, int line, int col, kf_severity sev, const char *fmt, ...)
    __attribute__((format(printf, 7, 8)));
/* The printed file, line, column and echoed text of a position in an input
 * (the text is in buf, or the input's own echo). */
const char *kf_locate(const kf_srcs *srcs, int src, int line, int col, const char **file, int *pline, int *pcol,
                      char *buf, size_t n);
#define kf_report_at(d, srcs, node, sev, ...)                                                                          \
    kf_report((d), (srcs), (node)->src, (node)->line, (node)->col, (sev), __VA_ARGS__)

/* Damerau–Levenshtein (optimal string alignment) distance, case-insensitive. */
int kf_edit_distance(const char *a, const char *b);
/* The closest of candidates (n of them, or NULL-terminated when n < 0) to
 * word if it is close enough to be a likely typo, else NULL. */
const char *kf_suggest(const char *word, const char *const *candidates, int n);

/* ---- the key table ---------------------------------------------------------- */

typedef enum kf_ktype {
    KT_SECTION, /* a mapping of fixed keys (sim:, frames:) */
    KT_DICT,    /* a mapping of user-named entries (materials:) */
    KT_LIST,    /* a sequence of mappings (objects:) */
    KT_NUM,     /* double */
    KT_INT,     /* int; choices may restrict it ("1|8|27|64") */
    KT_BOOL,    /* int 0/1 */
    KT_STR,     /* char[size] */
    KT_ENUM,    /* int: the index of the value in choices "a|b|c" */
    KT_VEC3,    /* double[3], bounds apply to each component */
    KT_PRESET,  /* char[size]: a name from kf_material_preset_names() */
    KT_REF      /* char[size]: the name of a material (checked once all are read) */
} kf_ktype;

/* which struct a key's offset is into */
typedef enum kf_scope {
    KS_TOP = 0,
    KS_MATERIAL,
    KS_OBJECT,
    KS_COLLIDER,
    KS_KEY,
    KS_RIGID,
    KS_JOINT,
    KS_COUNT
} kf_scope;

enum {
    KB_LO = 1,      /* has a lower bound */
    KB_LO_OPEN = 2, /* ... excluded */
    KB_HI = 4,
    KB_HI_OPEN = 8,
};

enum {
    KF_REQ = 1,       /* must be given (within a present section, or where `only` holds) */
    KF_BROADCAST = 2, /* vec3: one number means the same on every axis */
    KF_TEMPLATE = 4,  /* str: an output template ({shot}, {version}, {frame}) */
    KF_IDENT = 8,     /* str: a name (letters, digits, _ and -) */
    KF_NONZERO = 16,  /* vec3: not all zero */
    KF_SOFT = 32,     /* `only` not holding is a warning (has no effect), not an error */
    KF_AUTO = 64,     /* num: the word auto is accepted too, stored as KF_RIGID_AUTO (kerf sizes it) */
};

typedef struct kf_keydef {
    const char *path; /* "sim.dx", "materials.*.E", "objects[].fit.size" */
    kf_ktype type;
    kf_scope scope;   /* leaves: the struct written; DICT, LIST: the scope of their entries */
    size_t off, size; /* the field in that struct */
    unsigned bounds;  /* KB_* */
    double lo, hi;
    const char *choices; /* KT_ENUM, KT_INT: "a|b|c" */
    const char *def;     /* default, parsed like input; "(text)" = computed, described; NULL = none */
    const char *unit;    /* "m", "Pa", ... or NULL */
    const char *only;    /* "shape=sphere|cylinder": applies only there */
    unsigned flags;      /* KF_* */
    const char *doc;
} kf_keydef;

/* the structs the table's offsets point into, beyond the public ones */
typedef struct kf_top {
    kf_shot s;
    int walls;   /* index into domain.walls' choices: none, sticky, slip, separate */
    int contact; /* index into sim.contact's choices: on, off, auto */
} kf_top;

typedef struct kf_rawkey {
    double frame;
    double translate[3];
    double rotate[3];
    double scale[3];
    double eye[3], target[3]; /* render.camera_keys: camera position and aim, m */
    double fov;               /* render.camera_keys: degrees (0: render.fov) */
} kf_rawkey;

/* One constant per key of key_list.h, in table order: kf_keys[KK_SIM_DX] is
 * the row of "sim.dx". Code names keys by these; a path typed at run time
 * (--set, the walk) goes through kf_key_find. */
typedef enum kf_key_id {
#define KF_KEY(id, ...) KK_##id,
#include "key_list.h"
#undef KF_KEY
    KK_COUNT
} kf_key_id;

extern const kf_keydef kf_keys[];
extern const int kf_nkeys; /* KK_COUNT */

/* The entry with this full path, or -1. */
int kf_key_find(const char *path);
/* The leaf name after the last '.' of a path. */
const char *kf_key_leaf(const kf_keydef *k);
/* The path of the key's parent container ("" for top level). */
void kf_key_parent(const kf_keydef *k, char *out, size_t n);
/* "> 0", "in [0, 0.5)", ... ("" when unbounded). */
void kf_key_bounds_text(const kf_keydef *k, char *out, size_t n);
/* The i-th choice of an enum ("" past the end). */
const char *kf_key_choice(const kf_keydef *k, int i, char *buf, size_t n);

/* Convert node into the key's field at base + off. `what` names the value
 * in messages (e.g. "objects[1].radius"). Returns 0, or -1 after reporting. */
int kf_key_set(const kf_keydef *k, const ky_node *node, void *base, const char *what, kf_diag *d, const kf_srcs *srcs);
/* Write a key's default into base (nothing for computed or no default).
 * Returns -1 if the default does not satisfy the key (a table bug). */
int kf_key_default(const kf_keydef *k, void *base);

/* ---- output templates (overrides.c) ----------------------------------------- */

/* 0 if tmpl is a valid template, else -1 with the offending character's
 * index in *at and a reason in msg. */
int kf_template_check(const char *tmpl, int *at, char *msg, size_t n);

/* ---- the command line (overrides.c) ------------------------------------------ */

/* Graft one --set onto the document root. Returns 0, or -1 after reporting. */
int kf_override_apply(ky_doc *doc, ky_node *root, kf_srcs *srcs, const char *text, int ordinal, kf_diag *d);
/* --quality: 0 and *q, or -1 after reporting. NULL means final. */
int kf_quality_parse(const char *text, kf_srcs *srcs, kf_quality *q, kf_diag *d);
/* --frames within [start, end]: 0 and the range, or -1 after reporting. */
int kf_frames_parse(const char *text, kf_srcs *srcs, int start, int end, int *first, int *last, kf_diag *d);

#endif
