/* resolve.c — the section-specific checks after the walk: what the table
 * cannot see on its own (presets, references between sections, files, keys
 * and their frames, ranges across keys, unique names), resolved into the
 * kf_shot. Every problem is reported at its node and the checks go on. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <strings.h>
#include <sys/stat.h>

#include "../core/euler.h"
#include "loader.h"

#define KF_PI 3.14159265358979323846

/* ---- resolving: what the table cannot see on its own --------------------------------- */

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
void kf_resolve_material(loader *L, inst *I, kf_shot *s, kf_shot_material *out) {
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
        kf_report_inst(L, I, KK_MATERIALS_PRESET, KF_DIAG_ERROR, msg);
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
    out->stiffness_at =
        loc_of(L, s, kf_node_for(I, out->mat.model == KF_MAT_WATER ? KK_MATERIALS_BULK_MODULUS : KK_MATERIALS_E));
    if (!based) return;
    ((kf_shot_material *)I->base)->mat.model = out->mat.model; /* what `only: model=...` reads */
    kf_check_presence(L, I);
    if (I->errors) return;
    const char *bad = kf_material_check(&out->mat);
    if (*bad) {
        /* the message starts with the parameter's name: point at it when given */
        char key[64], path[96];
        size_t n = strspn(bad, "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_");
        snprintf(key, sizeof key, "%.*s", (int)(n < sizeof key ? n : sizeof key - 1), bad);
        snprintf(path, sizeof path, "materials.*.%s", key);
        snprintf(msg, sizeof msg, "%s: %s", I->label, bad);
        kf_report_inst(L, I, kf_key_find(path), KF_DIAG_ERROR, msg);
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
            for (int j = 0; j < 3; j++)
                R[3 * i + j] = U[3 * i] * A[j] + U[3 * i + 1] * A[3 + j] + U[3 * i + 2] * A[6 + j];
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
        kf_report_inst(L, I, key, KF_DIAG_ERROR, msg);
    } else if (!S_ISREG(st.st_mode)) {
        snprintf(msg, sizeof msg, "%s: mesh path '%s' is %s, not a mesh file (%s)", I->label, mesh,
                 S_ISDIR(st.st_mode) ? "a directory" : "not a regular file", path);
        kf_report_inst(L, I, key, KF_DIAG_ERROR, msg);
    }
}

void kf_resolve_object(loader *L, inst *I, int index, kf_shot *s, kf_shot_object *o) {
    char msg[1600];
    *o = *(const kf_shot_object *)I->base;
    kf_check_presence(L, I);
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
            if (near)
                snprintf(msg, sizeof msg, "%s: material '%s' is not defined (did you mean '%s'?)", I->label,
                         o->material_name, near);
            else if (nm)
                snprintf(msg, sizeof msg, "%s: material '%s' is not defined; materials: %s", I->label, o->material_name,
                         list);
            else
                snprintf(msg, sizeof msg, "%s: material '%s' is not defined (the shot has no materials:)", I->label,
                         o->material_name);
            kf_report_inst(L, I, KK_OBJECTS_MATERIAL, KF_DIAG_ERROR, msg);
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
        kf_check_presence(L, KI);
        const kf_rawkey *rk = KI->base;
        if (nk == KF_MAX_KEYS) {
            snprintf(msg, sizeof msg, "%s: too many keys (at most %d)", I->label, KF_MAX_KEYS);
            kf_report_inst(L, KI, frame_key, KF_DIAG_ERROR, msg);
            break;
        }
        if (KI->ok[frame_key] && nk > 0 && !(rk->frame > prev)) {
            snprintf(msg, sizeof msg, "%s.frame must come after the previous key's frame %g, got %g", KI->label, prev,
                     rk->frame);
            kf_report_inst(L, KI, frame_key, KF_DIAG_ERROR, msg);
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

void kf_resolve_collider(loader *L, int ii, int index, kf_shot *s, int times_ok, kf_shot_collider *c) {
    inst *I = &L->v[ii];
    char msg[512];
    *c = *(const kf_shot_collider *)I->base;
    c->at = loc_of(L, s, I->map);
    kf_check_presence(L, I);
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
        kf_report_inst(L, I, KK_COLLIDERS_VELOCITY, KF_DIAG_ERROR, msg);
    }
    if (nk < 2 && I->at[KK_COLLIDERS_INTERPOLATION]) {
        snprintf(msg, sizeof msg, "%s.interpolation has no effect with %s", I->label,
                 nk ? "one key (the collider is held there)" : "no keys");
        kf_report_inst(L, I, KK_COLLIDERS_INTERPOLATION, KF_DIAG_WARNING, msg);
    }
    c->col.nkeys = nk; /* one key: held there */
}

/* A rigid body: its mesh must exist, keys belong to kinematic bodies only,
 * and a kinematic body moves by keys or by a velocity, not both. */
void kf_resolve_rigid(loader *L, int ii, int index, kf_shot *s, int times_ok, kf_shot_rigid *r) {
    inst *I = &L->v[ii];
    char msg[512], motion[32];
    *r = *(const kf_shot_rigid *)I->base;
    r->at = loc_of(L, s, I->map);
    kf_check_presence(L, I);
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
        kf_report_inst(L, I, KK_RIGIDS_KEYS, KF_DIAG_ERROR, msg);
    }
    if (nk > 0 && (I->at[KK_RIGIDS_VELOCITY] || I->at[KK_RIGIDS_ANGULAR_VELOCITY])) {
        snprintf(msg, sizeof msg, "%s: give velocities or keys, not both (keys define the motion)", I->label);
        kf_report_inst(L, I, I->at[KK_RIGIDS_VELOCITY] ? KK_RIGIDS_VELOCITY : KK_RIGIDS_ANGULAR_VELOCITY, KF_DIAG_ERROR,
                       msg);
    }
    if (nk < 2 && I->at[KK_RIGIDS_INTERPOLATION] && r->def.motion == KF_RIGID_KINEMATIC) {
        snprintf(msg, sizeof msg, "%s.interpolation has no effect with %s", I->label,
                 nk ? "one key (the body is held there)" : "no keys");
        kf_report_inst(L, I, KK_RIGIDS_INTERPOLATION, KF_DIAG_WARNING, msg);
    }
    r->def.nkeys = r->def.motion == KF_RIGID_KINEMATIC ? nk : 0;
}

/* An object that names a bond is part of another object: it takes that
 * object's index as its own for contact and surfacing (kf_shot_object.field).
 * The named object must exist, be another one, and not be part of a third
 * (a chain would make "the object" ambiguous). */
void kf_resolve_bonds(loader *L, kf_shot *s) {
    char msg[900];
    const char *names[256] = {0}; /* for the suggestion */
    int n = 0;
    for (int i = 0; i < s->nobjects && n < 256; i++) names[n++] = s->objects[i].name;
    for (int i = 0, o = 0; i < L->n; i++) {
        if (L->v[i].scope != KS_OBJECT) continue;
        inst *I = &L->v[i];
        kf_shot_object *ob = &s->objects[o];
        ob->field = o++;
        if (!ob->bond[0] || !I->ok[KK_OBJECTS_BOND]) continue;
        int found = -1;
        for (int j = 0; j < s->nobjects; j++)
            if (!strcmp(s->objects[j].name, ob->bond)) found = j;
        if (found < 0) {
            const char *near = kf_suggest(ob->bond, names, n);
            if (near)
                snprintf(msg, sizeof msg, "%s: object '%s' is not defined (did you mean '%s'?)", I->label, ob->bond,
                         near);
            else snprintf(msg, sizeof msg, "%s: object '%s' is not defined", I->label, ob->bond);
        } else if (found == ob->field)
            snprintf(msg, sizeof msg, "%s: an object cannot be bonded to itself ('%s')", I->label, ob->bond);
        else if (s->objects[found].bond[0])
            snprintf(msg, sizeof msg,
                     "%s: object '%s' is itself bonded to '%s' (bond every part to the one object that names no "
                     "bond)",
                     I->label, ob->bond, s->objects[found].bond);
        else {
            ob->field = found;
            continue;
        }
        kf_report_inst(L, I, KK_OBJECTS_BOND, KF_DIAG_ERROR, msg);
    }
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
        if (near)
            snprintf(msg, sizeof msg, "%s: rigid body '%s' is not defined (did you mean '%s'?)", I->label, name, near);
        else if (n)
            snprintf(msg, sizeof msg, "%s: rigid body '%s' is not defined; rigid bodies: %s%s", I->label, name, list,
                     world_ok ? " (or world)" : "");
        else snprintf(msg, sizeof msg, "%s: rigid body '%s' is not defined (the shot has no rigids:)", I->label, name);
        kf_report_inst(L, I, key, KF_DIAG_ERROR, msg);
        return -2;
    }
    if (s->rigids[found].def.motion != KF_RIGID_DYNAMIC) {
        char motion[32];
        kf_key_choice(&kf_keys[KK_RIGIDS_MOTION], (int)s->rigids[found].def.motion, motion, sizeof motion);
        snprintf(msg, sizeof msg, "%s: rigid body '%s' is %s; joints connect dynamic bodies (and the world)", I->label,
                 name, motion);
        kf_report_inst(L, I, key, KF_DIAG_ERROR, msg);
        return -2;
    }
    return found;
}

void kf_resolve_joint(loader *L, inst *I, int index, kf_shot *s, kf_shot_joint *j) {
    char msg[256];
    *j = *(const kf_shot_joint *)I->base;
    j->at = loc_of(L, s, I->map);
    kf_check_presence(L, I);
    if (!I->at[KK_JOINTS_NAME]) default_name(j->name, sizeof j->name, I, KK_JOINTS_TYPE, index);
    int bk = KK_JOINTS_BODY, tk = KK_JOINTS_TO;
    int a = I->ok[bk] ? joint_body(L, I, s, KK_JOINTS_BODY, j->body, 0) : -2;
    int b = !I->at[tk] || I->ok[tk] ? joint_body(L, I, s, KK_JOINTS_TO, j->to, 1) : -2;
    if (a >= 0 && a == b) {
        snprintf(msg, sizeof msg, "%s: a joint connects two different bodies ('%s' twice; use to: world for an axle)",
                 I->label, j->body);
        kf_report_inst(L, I, KK_JOINTS_TO, KF_DIAG_ERROR, msg);
    }
    j->def.body_a = a;
    j->def.body_b = b;
    /* a velocity motor is nothing but its rate gain */
    if (j->def.motor == KF_MOTOR_VELOCITY && !(j->def.kv > 0) && I->ok[KK_JOINTS_MOTOR]) {
        snprintf(msg, sizeof msg, "%s: a velocity motor needs kv > 0 (its torque is kv times the rate it lacks)",
                 I->label);
        kf_report_inst(L, I, I->at[KK_JOINTS_KV] ? KK_JOINTS_KV : KK_JOINTS_MOTOR, KF_DIAG_ERROR, msg);
    }
    double len =
        sqrt(j->def.axis[0] * j->def.axis[0] + j->def.axis[1] * j->def.axis[1] + j->def.axis[2] * j->def.axis[2]);
    if (len > 0)
        for (int k = 0; k < 3; k++) j->def.axis[k] /= len;
}

/* two objects (or colliders) must not share a name: --set addresses by it */
void kf_check_unique(loader *L, kf_scope scope, kf_key_id key, const char *names, size_t stride, int n) {
    for (int i = 0, ii = 0; ii < L->n; ii++) {
        if (L->v[ii].scope != scope) continue;
        const char *a = names + (size_t)i * stride;
        for (int j = 0; j < i; j++)
            if (strcmp(a, names + (size_t)j * stride) == 0) {
                char msg[256];
                snprintf(msg, sizeof msg, "%s: the name '%s' is taken by an earlier item", L->v[ii].label, a);
                kf_report_inst(L, &L->v[ii], key, KF_DIAG_ERROR, msg);
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
        snprintf(msg, sizeof msg,
                 "output.dir is empty: give a directory, relative to where kerf runs (e.g. out/{shot})");
        kf_report_inst(L, T, KK_OUTPUT_DIR, KF_DIAG_ERROR, msg);
    }
    if (T->at[KK_OUTPUT_NAME] && T->ok[KK_OUTPUT_NAME] && has_dotdot(s->output_name)) {
        snprintf(msg, sizeof msg, "output.name must stay inside the output directory ('..' climbs out of it), got '%s'",
                 s->output_name);
        kf_report_inst(L, T, KK_OUTPUT_NAME, KF_DIAG_ERROR, msg);
    }
}

void kf_resolve_top(loader *L, inst *T, const char *path, kf_shot *s) {
    const kf_top *t = T->base;
    char msg[256];
    *s = t->s;
    kf_check_presence(L, T);
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
        snprintf(msg, sizeof msg, "frames.end must not be before frames.start (%d), got %d", s->frame_start,
                 s->frame_end);
        kf_report_inst(L, T, KK_FRAMES_END, KF_DIAG_ERROR, msg);
    }
    /* a camera must look somewhere: eye and target may not coincide */
    int ek2 = KK_RENDER_EYE, tk = KK_RENDER_TARGET;
    s->render_eye_set = T->at[ek2] != NULL;
    s->render_target_set = T->at[tk] != NULL;
    if (s->render_eye_set && T->ok[ek2] && (!s->render_target_set || T->ok[tk])) {
        double d2 = 0;
        for (int a = 0; a < 3; a++)
            d2 += (s->render_eye[a] - s->render_target[a]) * (s->render_eye[a] - s->render_target[a]);
        if (s->render_target_set && !(d2 > 1e-12)) {
            snprintf(msg, sizeof msg, "render.eye is at render.target (%g, %g, %g): the camera looks nowhere",
                     s->render_eye[0], s->render_eye[1], s->render_eye[2]);
            kf_report_inst(L, T, KK_RENDER_EYE, KF_DIAG_ERROR, msg);
        }
    }
    /* camera keys (render.camera_keys): frames increase, each looks somewhere */
    s->ncamera_keys = 0;
    for (int j = 0, ti = (int)(T - L->v); j < L->n; j++) {
        inst *KI = &L->v[j];
        if (KI->scope != KS_KEY || KI->parent != ti) continue;
        kf_check_presence(L, KI);
        const kf_rawkey *rk = KI->base;
        int n = s->ncamera_keys;
        if (n == KF_MAX_KEYS) {
            snprintf(msg, sizeof msg, "render.camera_keys: too many keys (at most %d)", KF_MAX_KEYS);
            kf_report_inst(L, KI, KK_RENDER_CAMERA_KEYS_FRAME, KF_DIAG_ERROR, msg);
            break;
        }
        if (KI->ok[KK_RENDER_CAMERA_KEYS_FRAME] && n > 0 && !(rk->frame > s->camera_keys[n - 1].frame)) {
            snprintf(msg, sizeof msg, "%s.frame must come after the previous key's frame %g, got %g", KI->label,
                     s->camera_keys[n - 1].frame, rk->frame);
            kf_report_inst(L, KI, KK_RENDER_CAMERA_KEYS_FRAME, KF_DIAG_ERROR, msg);
        }
        double d2 = 0;
        for (int a = 0; a < 3; a++) d2 += (rk->eye[a] - rk->target[a]) * (rk->eye[a] - rk->target[a]);
        if (KI->ok[KK_RENDER_CAMERA_KEYS_EYE] && KI->ok[KK_RENDER_CAMERA_KEYS_TARGET] && !(d2 > 1e-12)) {
            snprintf(msg, sizeof msg, "%s.eye is at its target (%g, %g, %g): the camera looks nowhere", KI->label,
                     rk->eye[0], rk->eye[1], rk->eye[2]);
            kf_report_inst(L, KI, KK_RENDER_CAMERA_KEYS_EYE, KF_DIAG_ERROR, msg);
        }
        s->camera_keys[n].frame = rk->frame;
        memcpy(s->camera_keys[n].eye, rk->eye, sizeof rk->eye);
        memcpy(s->camera_keys[n].target, rk->target, sizeof rk->target);
        s->camera_keys[n].fov = rk->fov;
        s->ncamera_keys++;
    }
    if (s->ncamera_keys && (s->render_eye_set || s->render_target_set)) {
        snprintf(msg, sizeof msg,
                 "give render.eye/render.target or render.camera_keys, not both (keys move the camera)");
        kf_report_inst(L, T, s->render_eye_set ? KK_RENDER_EYE : KK_RENDER_TARGET, KF_DIAG_ERROR, msg);
    }
    if (T->at[KK_OUTPUT_IMAGES] && s->output_images && !s->output_surface) {
        snprintf(msg, sizeof msg, "output.images renders the surfaces: it needs output.surface: true");
        kf_report_inst(L, T, KK_OUTPUT_IMAGES, KF_DIAG_ERROR, msg);
    }
    int mk = KK_DOMAIN_MIN, xk = KK_DOMAIN_MAX;
    if ((!T->at[mk] || T->ok[mk]) && (!T->at[xk] || T->ok[xk]))
        for (int a = 0; a < 3; a++)
            if (!(s->sim.domain_max[a] > s->sim.domain_min[a])) {
                snprintf(msg, sizeof msg, "domain.max must be above domain.min on every axis (%c: %g <= %g)", "xyz"[a],
                         s -> sim.domain_max[a], s->sim.domain_min[a]);
                kf_report_inst(L, T, T->at[xk] ? KK_DOMAIN_MAX : KK_DOMAIN_MIN, KF_DIAG_ERROR, msg);
                break;
            }
    s->sim.walls = t->walls != 0;
    s->sim.wall_boundary = t->walls ? (kf_boundary)(t->walls - 1) : KF_BOUNDARY_SEPARATE;
    s->ppc_axis = (int)lround(cbrt((double)s->ppc));
    if (!strstr(s->output_name, "{frame")) {
        snprintf(msg, sizeof msg,
                 "output.name must contain {frame} (or {frame:04d}) so frames do not overwrite each other");
        kf_report_inst(L, T, KK_OUTPUT_NAME, KF_DIAG_ERROR, msg);
    }
    check_output_paths(L, T, s);
    /* the implicit solve makes its own grid velocities and keeps no old ones */
    if (s->sim.transfer == KF_TRANSFER_FLIP && s->sim.integrator == KF_INTEGRATOR_IMPLICIT) {
        snprintf(msg, sizeof msg,
                 "sim.transfer: flip needs sim.integrator: explicit (the implicit solve keeps no old grid velocity "
                 "to take the particles' increment from); use apic with the implicit integrator");
        kf_report_inst(L, T, T->at[KK_SIM_TRANSFER] ? KK_SIM_TRANSFER : KK_SIM_INTEGRATOR, KF_DIAG_ERROR, msg);
    }
    /* polypic's modes are those of the quadratic kernel's stencil, carried by the explicit step's transfers */
    if (s->sim.transfer == KF_TRANSFER_POLYPIC && s->sim.integrator == KF_INTEGRATOR_IMPLICIT) {
        snprintf(msg, sizeof msg,
                 "sim.transfer: polypic needs sim.integrator: explicit (the implicit solve has its own transfers); "
                 "use apic with the implicit integrator");
        kf_report_inst(L, T, T->at[KK_SIM_TRANSFER] ? KK_SIM_TRANSFER : KK_SIM_INTEGRATOR, KF_DIAG_ERROR, msg);
    }
    if (s->sim.transfer == KF_TRANSFER_POLYPIC && s->sim.kernel != KF_KERNEL_QUADRATIC) {
        snprintf(msg, sizeof msg,
                 "sim.transfer: polypic needs sim.kernel: quadratic (its modes are those of the 3x3x3 stencil)");
        kf_report_inst(L, T, T->at[KK_SIM_TRANSFER] ? KK_SIM_TRANSFER : KK_SIM_KERNEL, KF_DIAG_ERROR, msg);
    }
    s->dx_at = loc_of(L, s, kf_node_for(T, KK_SIM_DX));
    s->cfl_at = loc_of(L, s, kf_node_for(T, KK_SIM_CFL));
    s->dt_fixed_at = loc_of(L, s, kf_node_for(T, KK_SIM_DT_FIXED));
    s->dt_max_at = loc_of(L, s, kf_node_for(T, KK_SIM_DT_MAX));
    s->resolution_scale = 1;
}
