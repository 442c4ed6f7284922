/* loader.h — the shot loader's working state, shared by its three parts:
 * the generic walk against the key table (walk.c), the section-specific
 * checks (resolve.c) and the entry point that reads, parses and runs them
 * (shot.c). Private to src/shot. */
#ifndef KF_SHOT_LOADER_H
#define KF_SHOT_LOADER_H

#include "internal.h"

/* The top level, each material, object, collider and key is an instance:
 * the struct its keys write into, and for each key of the table the node
 * that gave it (so later checks can point at it). */
typedef struct inst {
    kf_scope scope;
    void *base;
    char prefix[32];       /* table path of its keys: "", "materials.*", "objects[]" */
    char label[96];        /* in messages: "", "materials.jelly", "objects[1]" */
    const ky_node *map;    /* its mapping */
    const ky_node *name;   /* materials: the name key */
    const ky_node **at;    /* (kf_nkeys) the value node of each key given */
    const ky_node **keyat; /* (kf_nkeys) its key node */
    unsigned char *ok;     /* (kf_nkeys) 1 = given and valid */
    int parent;            /* keys: the collider's instance */
    int errors;            /* errors in its own keys */
} inst;

typedef struct loader {
    kf_diag *d;
    kf_srcs srcs;
    ky_doc doc;
    inst *v;
    int n, cap;
} loader;

/* a key that holds a value (not a section, dict or list) */
static inline int is_leaf(const kf_keydef *k) {
    return k->type != KT_SECTION && k->type != KT_DICT && k->type != KT_LIST;
}

/* ---- the walk (walk.c) ---------------------------------------------------------- */

int kf_inst_new(loader *L, kf_scope scope, const char *prefix, const char *label, const ky_node *map, int parent);
void kf_inst_free(inst *I);
void kf_walk_map(loader *L, int ii, const ky_node *map, const char *prefix);
void kf_check_presence(loader *L, inst *I);
const ky_node *kf_node_for(const inst *I, int key);
void kf_report_inst(loader *L, const inst *I, int key, kf_severity sev, const char *msg);

/* ---- the section-specific checks (resolve.c) ----------------------------------- */

void kf_resolve_material(loader *L, inst *I, kf_shot *s, kf_shot_material *out);
void kf_resolve_object(loader *L, inst *I, int index, kf_shot *s, kf_shot_object *o);
void kf_resolve_collider(loader *L, int ii, int index, kf_shot *s, int times_ok, kf_shot_collider *c);
void kf_resolve_rigid(loader *L, int ii, int index, kf_shot *s, int times_ok, kf_shot_rigid *r);
void kf_resolve_joint(loader *L, inst *I, int index, kf_shot *s, kf_shot_joint *j);
/* each object's field (objects[].bond), once every object has its name */
void kf_resolve_bonds(loader *L, kf_shot *s);
void kf_check_unique(loader *L, kf_scope scope, kf_key_id key, const char *names, size_t stride, int n);
void kf_resolve_top(loader *L, inst *T, const char *path, kf_shot *s);

#endif
