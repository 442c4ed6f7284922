/* test_shot_rigid.c — rigid bodies and joints in shot files: every key of
 * tests/shots/rigids.yaml lands where it should (keys in seconds at absolute
 * positions, joints by index, defaults); every mistake in bad_rigids.yaml is
 * reported in one pass at its exact line:col; the builder turns the bodies
 * into the model with the right surfaces, masses and initial poses; and the
 * cache hash follows the rigid inputs, mesh bytes included. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "kt.h"
#include "scene/build.h"
#include "scene/build_rigid.h"
#include "scene/mesh.h"
#include "scene/mesh_isect.h"
#include "shot/shot.h"

/* fixtures sit beside this file: tests/shots/NAME */
static const char *fixture(const char *name) {
    static char buf[4][1024];
    static int slot = 0;
    char *out = buf[slot++ % 4];
    const char *slash = strrchr(__FILE__, '/');
    if (slash) snprintf(out, 1024, "%.*s/shots/%s", (int)(slash - __FILE__), __FILE__, name);
    else snprintf(out, 1024, "shots/%s", name);
    return out;
}

static kf_shot *load(const char *path, const char *const *sets, int nsets, kf_diag *d) {
    kf_diag_init(d);
    kf_shot *s = kf_shot_load(path, sets, nsets, NULL, NULL, d);
    if (!s) kf_diag_print(stderr, d);
    return s;
}

/* the entry at line:col whose message holds `text` */
static int has(const kf_diag *d, int line, int col, kf_severity sev, const char *text) {
    for (int i = 0; i < d->count; i++) {
        const kf_diag_entry *e = &d->entry[i];
        if (e->line == line && e->col == col && e->severity == sev && strstr(e->message, text)) return 1;
    }
    return 0;
}
#define EXPECT(d, line, col, sev, text)                                                                                \
    KT_CHECK(has((d), (line), (col), (sev), (text)), "no diagnostic at %d:%d with \"%s\"", (line), (col), (text))

/* ---- parsing ---------------------------------------------------------------------------- */

/* penalty and push: auto by default (kerf sizes them), a number
 * as the paper's, and anything else refused naming both choices */
static void penalty_auto(void) {
    kf_diag d;
    const char *sets[] = {"rigids.blade.penalty=auto", "rigids.box1.push=12.5"};
    kf_shot *s = load(fixture("rigids.yaml"), sets, 2, &d);
    KT_CHECK(s != NULL, "auto and a number both parse");
    if (s) {
        KT_NEAR(s->rigids[0].def.penalty, KF_RIGID_AUTO, 0, "penalty: auto");
        KT_NEAR(s->rigids[1].def.push, 12.5, 0, "push: a number as given");
        KT_NEAR(s->rigids[1].def.penalty, 1000, 0, "penalty as the file gives it");
        KT_NEAR(s->rigids[3].def.push, KF_RIGID_AUTO, 0, "push default: auto");
        kf_shot_free(s);
    }
    kf_diag_free(&d);
    const char *bad[] = {"rigids.blade.penalty=fast"};
    kf_diag_init(&d);
    s = kf_shot_load(fixture("rigids.yaml"), bad, 1, NULL, NULL, &d);
    KT_CHECK(s == NULL && d.errors == 1, "a word other than auto is an error (%d errors)", d.errors);
    KT_CHECK(d.count == 1 && strstr(d.entry[0].message, "rigids[0].penalty: expected auto or a number, got 'fast'"),
             "message: %s", d.count ? d.entry[0].message : "(none)");
    /* at the value in the --set text: "rigids.blade.penalty=" is 21 characters */
    KT_CHECK(d.count == 1 && d.entry[0].line == 1 && d.entry[0].col == 22, "at --set:1:22 (got %d:%d)",
             d.count ? d.entry[0].line : 0, d.count ? d.entry[0].col : 0);
    kf_shot_free(s);
    kf_diag_free(&d);
}

static void rigid_values(void) {
    kf_diag d;
    kf_shot *s = load(fixture("rigids.yaml"), NULL, 0, &d);
    KT_CHECK(s != NULL && d.count == 0, "rigids.yaml loads cleanly (%d diagnostics)", d.count);
    if (!s) return kf_diag_free(&d);
    KT_CHECK(s->nrigids == 4 && s->njoints == 2, "4 bodies, 2 joints (got %d, %d)", s->nrigids, s->njoints);
    const kf_shot_rigid *blade = &s->rigids[0], *box = &s->rigids[1], *lid = &s->rigids[2], *wall = &s->rigids[3];
    /* a thin kinematic mesh with keys */
    KT_CHECK(!strcmp(blade->def.name, "blade") && blade->shape == 1 && blade->def.thin == 1, "blade: thin mesh");
    KT_CHECK(strstr(blade->mesh_path, "/shots/../../assets/cross_plates.obj") != NULL, "mesh relative to the shot: %s",
             blade->mesh_path);
    KT_CHECK(blade->mesh_at.line == 13 && blade->mesh_at.col == 11, "where its mesh: is (%d:%d)", blade->mesh_at.line,
             blade->mesh_at.col);
    KT_NEAR(blade->scale[1], 0.2, 0, "per-axis scale");
    KT_CHECK(blade->pivot_set == 0, "no pivot given: the bounding-box centre");
    KT_CHECK(blade->def.motion == KF_RIGID_KINEMATIC && blade->def.interp == KF_INTERP_SMOOTH, "kinematic, smooth");
    KT_NEAR(blade->def.position[1], 0.8, 0, "center is the pivot's position");
    KT_NEAR(blade->def.rotate[1], 90, 0, "rest rotation");
    KT_CHECK(blade->def.nkeys == 2, "2 keys (got %d)", blade->def.nkeys);
    const kf_key *k = blade->def.keys;
    KT_NEAR(k[0].time, 0, 0, "frame 1001 is t = 0");
    KT_NEAR(k[1].time, 0.5, 1e-12, "frame 1013 at 24 fps = 0.5 s");
    KT_NEAR(k[1].position[1], 0.5, 1e-15, "key position = center + translate");
    KT_NEAR(k[1].rotate[1], 45, 0, "key rotate as written (on top of the baked rest rotation)");
    KT_NEAR(k[1].scale[0] + k[1].scale[1] + k[1].scale[2], 3, 0, "bodies are rigid: key scale 1");
    KT_CHECK(blade->def.boundary == KF_BOUNDARY_SLIP, "slip");
    KT_NEAR(blade->def.push, 50, 0, "push");
    KT_NEAR(blade->def.penalty, KF_RIGID_AUTO, 0, "penalty default auto (on, sized by kerf)");
    KT_NEAR(blade->def.friction, 0.3, 0, "friction default");
    KT_NEAR(blade->color[2], 0.9, 0, "colour");
    /* a dynamic box with the defaults of everything else */
    KT_CHECK(!strcmp(box->def.name, "box1"), "default name: shape and index (got %s)", box->def.name);
    KT_CHECK(box->shape == 0 && box->def.thin == 0 && box->def.motion == KF_RIGID_DYNAMIC, "a dynamic solid box");
    KT_NEAR(box->size[0] + box->size[1] + box->size[2], 0.35, 1e-15, "size");
    KT_NEAR(box->def.density, 500, 0, "density");
    KT_NEAR(box->def.velocity[0], 1, 0, "initial velocity");
    KT_NEAR(box->def.angular_velocity[2], 2, 0, "initial spin");
    KT_NEAR(box->def.penalty, 1000, 0, "penalty");
    KT_CHECK(box->def.boundary == KF_BOUNDARY_SEPARATE && box->def.nkeys == 0, "separate by default, no keys");
    KT_NEAR(box->color[0], 0.55, 0, "default colour");
    KT_CHECK(lid->pivot_set == 1 && lid->def.friction == 0.1, "lid: pivot given, friction");
    KT_NEAR(lid->scale[2], 0.1, 0, "one number scales uniformly");
    KT_CHECK(wall->def.motion == KF_RIGID_STATIC && wall->def.boundary == KF_BOUNDARY_STICKY, "a static sticky wall");
    /* joints: bodies by index, axis normalised, the world as -1 */
    const kf_shot_joint *pin = &s->joints[0], *hinge = &s->joints[1];
    KT_CHECK(pin->def.body_a == 1 && pin->def.body_b == 2, "pin: box1 to lid (got %d, %d)", pin->def.body_a,
             pin->def.body_b);
    KT_NEAR(pin->def.axis[2], 1, 1e-15, "axis normalised");
    KT_NEAR(pin->def.damping, 0.5, 0, "damping");
    KT_CHECK(!strcmp(hinge->name, "hinge1") && !strcmp(hinge->to, "world"), "default name and `to: world`");
    KT_CHECK(hinge->def.body_a == 2 && hinge->def.body_b == -1, "lid to the world (got %d, %d)", hinge->def.body_a,
             hinge->def.body_b);
    kf_shot_free(s);
    kf_diag_free(&d);

    /* --set reaches bodies and joints by name */
    const char *sets[] = {"rigids.lid.density=300", "rigids.blade.push=10", "joints.pin.damping=1"};
    s = load(fixture("rigids.yaml"), sets, 3, &d);
    KT_CHECK(s != NULL && d.count == 0, "overrides of rigid keys apply cleanly");
    if (s) {
        KT_NEAR(s->rigids[2].def.density, 300, 0, "density overridden");
        KT_NEAR(s->rigids[0].def.push, 10, 0, "push overridden");
        KT_NEAR(s->joints[0].def.damping, 1, 0, "damping overridden");
    }
    kf_shot_free(s);
    kf_diag_free(&d);

    /* a motor: off by default; its keys as given, in the units of the help (an
     * unnamed joint is reached by its index) */
    s = load(fixture("rigids.yaml"), NULL, 0, &d);
    KT_CHECK(s && s->joints[1].def.motor == KF_MOTOR_NONE, "no motor unless asked");
    kf_shot_free(s);
    kf_diag_free(&d);
    const char *motor[] = {"joints.1.motor=position", "joints.1.frequency=-1.5", "joints.1.angle=90",
                           "joints.1.kp=2",           "joints.1.kv=0.05",        "joints.1.torque_limit=0.3"};
    s = load(fixture("rigids.yaml"), motor, 6, &d);
    KT_CHECK(s != NULL && d.count == 0, "a position motor set by --set loads cleanly");
    if (s) {
        const kf_joint_def *j = &s->joints[1].def;
        KT_CHECK(j->motor == KF_MOTOR_POSITION, "motor: position");
        KT_NEAR(j->frequency, -1.5, 0, "frequency in Hz, signed");
        KT_NEAR(j->angle, 90, 0, "angle in degrees");
        KT_NEAR(j->kp, 2, 0, "kp");
        KT_NEAR(j->kv, 0.05, 0, "kv");
        KT_NEAR(j->torque_limit, 0.3, 0, "torque limit");
    }
    kf_shot_free(s);
    kf_diag_free(&d);
}

static void bad_rigids(void) {
    kf_diag d;
    kf_diag_init(&d);
    kf_shot *s = kf_shot_load(fixture("bad_rigids.yaml"), NULL, 0, NULL, NULL, &d);
    KT_CHECK(s == NULL, "bad_rigids.yaml fails");
    KT_CHECK(d.errors == 22 && d.warnings == 1, "22 errors and 1 warning, got %d and %d", d.errors, d.warnings);
    const kf_severity E = KF_DIAG_ERROR;
    EXPECT(&d, 7, 5, E, "rigids[0].mesh is missing (required for shape mesh)");
    EXPECT(&d, 8, 5, E, "rigids[1].density is missing (required for motion dynamic)");
    EXPECT(&d, 9, 63, E, "rigids[2].density does not apply to motion static (only to dynamic)");
    EXPECT(&d, 9, 77, E, "rigids[2].velocity does not apply to motion static (only to kinematic|dynamic)");
    EXPECT(&d, 10, 92, E, "rigids[3]: give velocities or keys, not both");
    EXPECT(&d, 11, 22, E, "rigids[4].shape: expected box or mesh, got 'sphere'");
    EXPECT(&d, 12, 79, KF_DIAG_WARNING, "rigids[5].friction has no effect with boundary slip");
    EXPECT(&d, 13, 12, E, "rigids[6]: the name 'a' is taken by an earlier item");
    EXPECT(&d, 13, 112, E, "rigids[6].keys[1].frame must come after the previous key's frame 1005, got 1002");
    EXPECT(&d, 14, 46, E, "rigids[7].center: expected [x, y, z], got 2 numbers");
    EXPECT(&d, 14, 84, E, "rigids[7].density must be > 0");
    EXPECT(&d, 16, 19, E, "joints[0]: rigid body 'nobody' is not defined; rigid bodies: a, b, c");
    EXPECT(&d, 17, 5, E, "joints[1].axis is missing (required)");
    EXPECT(&d, 17, 12, E, "joints[1]: rigid body 'c' is static; joints connect dynamic bodies");
    EXPECT(&d, 18, 21, E, "joints[2].type: expected hinge, got 'slider'");
    /* motors */
    EXPECT(&d, 19, 5, E, "joints[3].kp is missing (required for motor position)");
    EXPECT(&d, 19, 5, E, "joints[3].torque_limit is missing (required for motor position)");
    EXPECT(&d, 20, 58, E, "joints[4]: a velocity motor needs kv > 0");
    EXPECT(&d, 21, 51, E, "joints[5].kp does not apply to motor none (only to position)");
    EXPECT(&d, 21, 58, E, "joints[5].frequency does not apply to motor none (only to velocity|position)");
    EXPECT(&d, 22, 58, E, "joints[6].motor: expected none, velocity or position, got 'servo'");
    EXPECT(&d, 23, 89, E, "joints[7].torque_limit must be in (0, 1000000] N m, got -1");
    EXPECT(&d, 23, 104, E, "joints[7].frequency must be in [-100, 100] Hz, got 200");
    kf_diag_free(&d);
}

/* ---- building ------------------------------------------------------------------------------- */

static void bounds(const double *v, int n, double lo[3], double hi[3]) {
    for (int a = 0; a < 3; a++) lo[a] = 1e30, hi[a] = -1e30;
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], v[3 * i + a]);
            hi[a] = fmax(hi[a], v[3 * i + a]);
        }
}

/* the surfaces: pivot at the origin, rest rotation baked in */
static void rigid_surfaces(void) {
    kf_diag d;
    kf_shot *s = load(fixture("rigids.yaml"), NULL, 0, &d);
    if (!s) return kf_diag_free(&d);
    char err[512];
    double *v, lo[3], hi[3];
    int *t, nv, nt;
    /* box 0.2 x 0.1 x 0.05 turned 90 degrees about z: 0.1 along x, 0.2 along y */
    KT_CHECK(kf_rigid_surface(&s->rigids[1], &v, &nv, &t, &nt, err, sizeof err) == 0, "%s", err);
    KT_CHECK(nv == 8 && nt == 12, "a box is 8 corners and 12 triangles");
    bounds(v, nv, lo, hi);
    KT_NEAR(hi[0], 0.05, 1e-15, "x half extent after Rz(90)");
    KT_NEAR(hi[1], 0.1, 1e-15, "y half extent after Rz(90)");
    KT_NEAR(lo[2], -0.025, 1e-15, "z untouched");
    /* outward winding: the divergence theorem gives +volume */
    double vol = 0;
    for (int k = 0; k < nt; k++) {
        const double *a = &v[3 * t[3 * k]], *b = &v[3 * t[3 * k + 1]], *c = &v[3 * t[3 * k + 2]];
        vol += (a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                a[2] * (b[0] * c[1] - b[1] * c[0])) /
               6;
    }
    KT_NEAR(vol, 0.2 * 0.1 * 0.05, 1e-15, "wound counter-clockwise seen from outside");
    free(v), free(t);
    /* cross plates scaled [0.4, 0.2, 0.4] about their centre, turned 90 degrees about y */
    KT_CHECK(kf_rigid_surface(&s->rigids[0], &v, &nv, &t, &nt, err, sizeof err) == 0, "%s", err);
    bounds(v, nv, lo, hi);
    KT_NEAR(hi[0] - lo[0], 0.4, 1e-6, "x extent (float file coordinates)");
    KT_NEAR(hi[1], 0.1, 1e-6, "centred on the pivot");
    KT_NEAR(lo[2], -0.2, 1e-6, "z extent");
    KT_CHECK(nt == 1600, "the file's triangles (got %d)", nt);
    free(v), free(t);
    /* a pivot given at the file's origin: the unit cube [0, 1]^3 scaled by 0.1 stays in [0, 0.1]^3 */
    KT_CHECK(kf_rigid_surface(&s->rigids[2], &v, &nv, &t, &nt, err, sizeof err) == 0, "%s", err);
    bounds(v, nv, lo, hi);
    KT_NEAR(lo[0], 0, 1e-15, "pivot at the origin");
    KT_NEAR(hi[1], 0.1, 1e-15, "scaled");
    free(v), free(t);
    kf_shot_free(s);
    kf_diag_free(&d);
}

/* the model: bodies in file order with their masses, seeds and first poses */
static void rigid_model(void) {
    kf_diag d;
    kf_shot *s = load(fixture("rigids.yaml"), NULL, 0, &d);
    if (!s) return kf_diag_free(&d);
    kf_scene sc;
    int rc = kf_scene_from_shot(s, 1, &sc, NULL, &d);
    KT_CHECK(rc == 0, "rigids.yaml builds");
    if (rc) {
        kf_diag_print(stderr, &d);
        kf_shot_free(s);
        return kf_diag_free(&d);
    }
    KT_CHECK(kf_model_rigid_count(sc.model) == 4, "4 bodies in the model");
    KT_NEAR(kf_model_rigid_mass(sc.model, 1), 500 * 0.2 * 0.1 * 0.05, 1e-12, "box: density x volume");
    KT_NEAR(kf_model_rigid_mass(sc.model, 2), 200 * 0.1 * 0.1 * 0.1, 1e-12, "lid: the 0.1 m cube");
    KT_NEAR(kf_model_rigid_mass(sc.model, 0), 0, 0, "a kinematic body has no mass");
    for (int i = 0; i < 4; i++) KT_CHECK(kf_model_rigid_seeds(sc.model, i) > 0, "body %d carries seeds", i);
    /* poses at t = 0: the rest rotation is in the surface, so R = I and the pivot sits at center */
    kf_rigid_pose blade = kf_state_rigid(sc.state, 0), box = kf_state_rigid(sc.state, 1),
                  lid = kf_state_rigid(sc.state, 2);
    KT_NEAR(blade.R[0] + blade.R[4] + blade.R[8], 3, 1e-12, "the blade's first key: no rotation");
    KT_NEAR(blade.t[1], 0.8, 1e-12, "the blade's pivot at center");
    KT_NEAR(box.com[0], 0.3, 1e-9, "the box's centre of mass at center");
    KT_NEAR(box.v[0], 1, 1e-12, "initial velocity");
    KT_NEAR(box.omega[2], 2, 1e-12, "initial spin");
    KT_NEAR(lid.t[0], 0.7, 1e-12, "the lid's pivot (its file origin) at center");
    KT_NEAR(lid.com[1], 0.75, 1e-9, "the lid's centre of mass half a cube above its pivot");
    kf_scene_free(&sc);
    kf_shot_free(s);
    kf_diag_free(&d);
}

/* ---- the cache hash ------------------------------------------------------------------------- */

static uint64_t hash_with(const char *path, const char *set) {
    kf_diag d;
    const char *sets[1] = {set};
    kf_shot *s = load(path, sets, set ? 1 : 0, &d);
    uint64_t h = s ? kf_shot_sim_hash(s) : 0;
    kf_shot_free(s);
    kf_diag_free(&d);
    return h;
}

static void rigid_hash(void) {
    const char *path = fixture("rigids.yaml");
    uint64_t h = hash_with(path, NULL);
    KT_CHECK(h != 0 && h == hash_with(path, NULL), "the hash is stable");
    KT_CHECK(h != hash_with(path, "rigids.box1.density=600"), "a density is a simulation input");
    KT_CHECK(h != hash_with(path, "rigids.blade.keys.1.translate=[0, -0.2, 0]"), "a key is a simulation input");
    KT_CHECK(h != hash_with(path, "joints.pin.damping=2"), "a joint is a simulation input");
    KT_CHECK(h == hash_with(path, "rigids.blade.color=[0, 0, 0]"), "a colour is not");
    /* a shot without bodies hashes as before rigid bodies existed */
    kf_diag d;
    kf_shot *s = load(path, NULL, 0, &d);
    if (s) {
        s->nrigids = s->njoints = 0;
        KT_CHECK(kf_shot_rigids_hash(s, 12345) == 12345, "no bodies: the hash is unchanged");
    }
    kf_shot_free(s);
    kf_diag_free(&d);
    /* the mesh's bytes: an edited file under the same name is a new input */
    char dir[] = "/tmp/kf_rigid_hash.XXXXXX", shot[256], mesh[256];
    if (!mkdtemp(dir)) return;
    snprintf(shot, sizeof shot, "%s/s.yaml", dir);
    snprintf(mesh, sizeof mesh, "%s/m.obj", dir);
    FILE *f = fopen(mesh, "w");
    fputs("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n", f);
    fclose(f);
    f = fopen(shot, "w");
    fputs("frames: {end: 1002}\nmaterials: {m: {preset: jello}}\n"
          "objects: [{shape: box, size: 0.2, center: [0.5, 0.3, 0.5], material: m}]\n"
          "rigids: [{shape: mesh, mesh: m.obj, thin: true, center: [0.5, 0.7, 0.5]}]\n",
          f);
    fclose(f);
    uint64_t before = hash_with(shot, NULL);
    f = fopen(mesh, "a");
    fputs("# edited\n", f);
    fclose(f);
    KT_CHECK(before != 0 && before != hash_with(shot, NULL), "an edited mesh file changes the hash");
    unlink(mesh), unlink(shot), rmdir(dir);
}

/* The thin sheets in assets/ load open, with the triangles and the area
 * their construction gives (flat ones exactly, curved ones within the
 * chord error of their segments). */
static void thin_assets(void) {
    const double pi = 3.14159265358979323846;
    /* the scoop: 24 chords over 120 degrees of radius 0.3, 1 m wide */
    double scoop = 24 * 2 * 0.3 * sin(pi / 3 / 24) * 1.0;
    /* area: relative tolerance `rel` (float coordinates: 1e-6) */
    struct {
        const char *name;
        size_t ntri;
        double area, rel;
    } sheets[] = {
        {"cross_plates", 1600, 2.0, 1e-6},
        {"scoop", 960, scoop, 1e-6},
        {"paddle_wheel", 1280, 4 * 1.0 * 0.4, 1e-6},
        /* paddle.obj's outline: that solid's volume over its 20 mm thickness (it samples the
           outline at 100 segments, the sheet at 50: 0.5 %) */
        {"paddle_sheet", 600, 0.00233359 / 0.02, 0.005},
        {"stirrer", 1152, 0.0, 0}, /* curved bottom edge: area checked against the lattice below */
    };
    for (int i = 0; i < (int)(sizeof sheets / sizeof *sheets); i++) {
        char path[1024], err[512];
        const char *slash = strrchr(__FILE__, '/');
        snprintf(path, sizeof path, "%.*s/../assets/%s.obj", slash ? (int)(slash - __FILE__) : 1,
                 slash ? __FILE__ : ".", sheets[i].name);
        kf_mesh m;
        int rc = kf_mesh_load(path, &m, err, sizeof err);
        KT_CHECK(rc == 0, "%s", err);
        if (rc) continue;
        KT_CHECK(!m.closed && m.ntri == sheets[i].ntri && m.dropped_tris == 0, "%s: open, %zu triangles (got %zu)",
                 sheets[i].name, sheets[i].ntri, m.ntri);
        if (sheets[i].rel > 0) KT_NEAR(m.area / sheets[i].area, 1, sheets[i].rel, sheets[i].name);
        else KT_CHECK(m.area > 0.4 && m.area < 2 * 0.8 * 0.65, "stirrer: two blades under 0.8 x 0.65 m (%g)", m.area);
        kf_mesh_free(&m);
    }
}

/* ---- solids that intersect themselves (sand_stir's bowl) -------------------------- */

/* the triangle-triangle test on cases whose answer is known by hand */
static void tri_tri_cases(void) {
    double at[3];
    /* a vertical triangle through the floor triangle z = 0, x + y <= 2: they share the
       segment y = 0.5, z = 0, x in [0.5, 1.5] */
    const double floor_tri[9] = {0, 0, 0, 2, 0, 0, 0, 2, 0};
    const double wall[9] = {0.5, 0.5, -1, 0.5, 0.5, 1, 3, 0.5, 0};
    KT_CHECK(kf_tri_tri_intersect(floor_tri, wall, at) == 1, "a wall through a floor intersects it");
    KT_CHECK(at[2] == 0 && fabs(at[1] - 0.5) < 1e-15 && at[0] >= 0.5 - 1e-15 && at[0] <= 1.5 + 1e-15,
             "the point is on both (%g, %g, %g)", at[0], at[1], at[2]);
    KT_CHECK(kf_tri_tri_intersect(wall, floor_tri, NULL) == 1, "in either order");
    /* two triangles of a closed surface folded along their shared edge x in [0, 1]:
       they touch only along it, which is no intersection */
    const double a[9] = {0, 0, 0, 1, 0, 0, 0, 1, 0}, b[9] = {1, 0, 0, 0, 0, 0, 0.3, -1, 0.5};
    KT_CHECK(kf_tri_tri_intersect(a, b, at) == 0, "neighbours across a shared edge do not intersect");
    /* sharing one vertex: touching only there is fine, passing through the other is not */
    const double fan[9] = {0, 0, 0, -1, 0, 0.2, -1, 1, 0.2};
    KT_CHECK(kf_tri_tri_intersect(a, fan, at) == 0, "triangles meeting only at a shared vertex");
    const double fold[9] = {0, 0, 0, 0.5, 0.2, 1, 0.5, 0.2, -1};
    KT_CHECK(
        kf_tri_tri_intersect(a, fold, at) == 1 && fabs(at[0] - 0.5) < 1e-15 && fabs(at[1] - 0.2) < 1e-15 && at[2] == 0,
        "a triangle from a shared vertex through the other: at (0.5, 0.2, 0), got (%g, %g, %g)", at[0], at[1], at[2]);
    /* a corner resting on the other's face counts; a parallel face 1e-9 above does not */
    const double corner[9] = {0.25, 0.25, 0, 0.25, 0.25, 1, 1, 0.25, 1};
    KT_CHECK(kf_tri_tri_intersect(a, corner, at) == 1, "a corner touching a face");
    const double above[9] = {0, 0, 1e-9, 1, 0, 1e-9, 0, 1, 1e-9};
    KT_CHECK(kf_tri_tri_intersect(a, above, at) == 0, "a parallel copy 1e-9 above");
}

/* kerf's shot error: the mesh, two triangles and a point, at the entry's mesh: key; the
 * refused solids all reported in one pass; and the bowl make_meshes now writes passes */
static void self_intersecting_solids(void) {
    kf_diag d;
    kf_shot *s = load(fixture("bad_solid.yaml"), NULL, 0, &d);
    KT_CHECK(s != NULL && d.count == 0, "bad_solid.yaml parses");
    if (s) {
        kf_scene sc;
        int rc = kf_scene_from_shot(s, 1, &sc, NULL, &d);
        KT_CHECK(rc != 0, "a self-intersecting solid is refused");
        if (rc == 0) kf_scene_free(&sc);
        /* every entry uses the same mesh; its path as the shot resolved it */
        const char *path = s->rigids[0].mesh_path;
        KT_CHECK(strstr(path, "shots/../meshes/cubes_crossed.obj") != NULL, "mesh relative to the shot: %s", path);
        char where[1536], want[3][2048];
        snprintf(where, sizeof where,
                 "%s: intersects itself: triangles 3 and 18 meet at (1, 0.25, 1) (file coordinates); 14 pairs of "
                 "triangles intersect",
                 path);
        snprintf(want[0], sizeof want[0], "rigid cup: a static solid must not intersect itself: %s", where);
        snprintf(want[1], sizeof want[1], "rigid lid: a dynamic solid must not intersect itself: %s", where);
        snprintf(want[2], sizeof want[2], "object 'lump': %s", where);
        const int line[3] = {13, 14, 11}, col[3] = {36, 36, 37};
        for (int k = 0; k < 3; k++) {
            int found = 0;
            for (int i = 0; i < d.count; i++)
                found |= d.entry[i].line == line[k] && d.entry[i].col == col[k] &&
                         d.entry[i].severity == KF_DIAG_ERROR && !strcmp(d.entry[i].message, want[k]);
            KT_CHECK(found, "no error at %d:%d reading \"%s\"", line[k], col[k], want[k]);
        }
        KT_CHECK(d.count == 3, "three errors, the sound box not among them (got %d)", d.count);
        if (d.count != 3) kf_diag_print(stderr, &d);
    }
    kf_shot_free(s);
    kf_diag_free(&d);

    /* the fixture itself: the pairs found, and the first of them (in triangle order) */
    char path[1024], err[1024];
    const char *slash = strrchr(__FILE__, '/');
    snprintf(path, sizeof path, "%.*s/meshes/cubes_crossed.obj", slash ? (int)(slash - __FILE__) : 1,
             slash ? __FILE__ : ".");
    kf_mesh m;
    int rc = kf_mesh_load(path, &m, err, sizeof err);
    KT_CHECK(rc == 0 && m.closed && m.oriented && m.volume > 0, "cubes_crossed.obj: closed and outward %s",
             rc ? err : "");
    if (rc == 0) {
        kf_mesh_isect x;
        for (int threads = 1; threads <= 2; threads++) {
            KT_CHECK(kf_mesh_self_intersections(&m, threads, &x) == 0, "memory");
            KT_CHECK(x.pairs == 14 && x.tri[0] == 2 && x.tri[1] == 17 && x.at[0] == 1 && x.at[1] == 0.25 &&
                         x.at[2] == 1,
                     "%d threads: %zu pairs, first %u and %u at (%g, %g, %g)", threads, x.pairs, x.tri[0], x.tri[1],
                     x.at[0], x.at[1], x.at[2]);
        }
        kf_mesh_free(&m);
    }

    /* the regenerated bowl: closed, outward, and passing the check; standing on its foot
       ring's base at y = -0.5, a 30 mm wall under the inside's bottom at -0.47 */
    snprintf(path, sizeof path, "%.*s/../assets/bowl.obj", slash ? (int)(slash - __FILE__) : 1, slash ? __FILE__ : ".");
    rc = kf_mesh_load(path, &m, err, sizeof err);
    KT_CHECK(rc == 0 && m.closed && m.oriented && m.flipped_tris == 0, "bowl.obj: closed and outward %s",
             rc ? err : "");
    if (rc == 0) {
        KT_CHECK(kf_mesh_check_self_intersection(&m, 0, err, sizeof err) == 0, "%s", err);
        KT_NEAR(m.lo[1], -0.5, 1e-7, "the base (float coordinates)");
        KT_NEAR(m.hi[1], 0, 0, "the rim");
        KT_NEAR(m.hi[0], 0.5, 1e-7, "outer radius");
        kf_mesh_free(&m);
    }
}

/* the paper's scenes in shots/ load and build (at preview quality: seconds) */
static void example_shots(void) {
    const char *names[] = {"bunny_split.yaml",  "cheese_cut.yaml",  "sand_stir.yaml",
                           "sand_sweep.yaml",   "goo_blocks.yaml",  "buoyancy.yaml",
                           "sand_paddles.yaml", "water_wheel.yaml", "sand_wheel.yaml"};
    for (int i = 0; i < (int)(sizeof names / sizeof *names); i++) {
        char path[1024];
        const char *slash = strrchr(__FILE__, '/');
        snprintf(path, sizeof path, "%.*s/../shots/%s", slash ? (int)(slash - __FILE__) : 1, slash ? __FILE__ : ".",
                 names[i]);
        kf_diag d;
        kf_diag_init(&d);
        kf_shot *s = kf_shot_load(path, NULL, 0, "preview", NULL, &d);
        KT_CHECK(s != NULL && d.count == 0 && s->nrigids > 0, "%s loads cleanly, with rigid bodies", names[i]);
        kf_scene sc;
        if (s) {
            int rc = kf_scene_from_shot(s, 1, &sc, NULL, &d);
            KT_CHECK(rc == 0 && kf_model_rigid_count(sc.model) == s->nrigids, "%s builds its %d bodies", names[i],
                     s->nrigids);
            if (rc == 0) kf_scene_free(&sc);
        }
        if (d.count) kf_diag_print(stderr, &d);
        kf_shot_free(s);
        kf_diag_free(&d);
    }
}

int main(int argc, char **argv) {
    KT_RUN(rigid_values, argc, argv);
    KT_RUN(penalty_auto, argc, argv);
    KT_RUN(bad_rigids, argc, argv);
    KT_RUN(rigid_surfaces, argc, argv);
    KT_RUN(rigid_model, argc, argv);
    KT_RUN(rigid_hash, argc, argv);
    KT_RUN(thin_assets, argc, argv);
    KT_RUN(example_shots, argc, argv);
    KT_RUN(tri_tri_cases, argc, argv);
    KT_RUN(self_intersecting_solids, argc, argv);
    return KT_EXIT();
}
