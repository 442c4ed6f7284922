/* test_shot.c — shot files: real YAML/JSON fixtures in tests/shots/ load to
 * the right values and defaults; bad ones report every problem in one pass
 * with exact line:col, text, echoed line and caret; the command line
 * (--set, --quality, --frames) is validated like the file; templates expand. */
#define _GNU_SOURCE /* open_memstream */
#include <stdlib.h>
#include <string.h>

#include "kt.h"
#include "shot/internal.h"
#include "scene/mesh.h"
#include "scene/sample.h"
#include "shot/shot.h"

/* fixtures sit beside this file: tests/shots/NAME */
static const char *fixture(const char *name) {
    static char buf[8][1024];
    static int slot = 0;
    char *out = buf[slot++ % 8];
    const char *slash = strrchr(__FILE__, '/');
    if (slash) snprintf(out, 1024, "%.*s/shots/%s", (int)(slash - __FILE__), __FILE__, name);
    else snprintf(out, 1024, "shots/%s", name);
    return out;
}

static kf_shot *load(const char *name, const char *const *sets, int nsets, const char *quality, const char *frames,
                     kf_diag *d) {
    kf_diag_init(d);
    return kf_shot_load(fixture(name), sets, nsets, quality, frames, d);
}

/* the entry at file:line:col whose message holds `text`, or NULL */
static const kf_diag_entry *find(const kf_diag *d, const char *file, int line, int col, const char *text) {
    for (int i = 0; i < d->count; i++) {
        const kf_diag_entry *e = &d->entry[i];
        if (e->line == line && e->col == col && strstr(e->message, text) && (!file || strcmp(e->file, file) == 0))
            return e;
    }
    return NULL;
}

static void dump(const kf_diag *d) { kf_diag_print(stderr, d); }

#define EXPECT(d, file, line, col, sev, text)                                                                          \
    do {                                                                                                               \
        const kf_diag_entry *e_ = find((d), (file), (line), (col), (text));                                            \
        KT_CHECK(e_ != NULL, "no diagnostic at %d:%d with \"%s\"", (line), (col), (text));                             \
        if (e_) KT_CHECK(e_->severity == (sev), "%d:%d has the wrong severity", (line), (col));                        \
    } while (0)

static char *printed(const kf_diag_entry *e) {
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    kf_diag_print_entry(f, e);
    fclose(f);
    return buf;
}

/* ---- the table itself ------------------------------------------------------------------ */

/* every default satisfies its own key, every `only` names a real choice,
 * every key sits in a container the table declares and says what it is */
static void table_is_consistent(void) {
    static char scratch[sizeof(kf_top) + sizeof(kf_shot_object) + sizeof(kf_shot_rigid) + 4096];
    for (int i = 0; i < kf_nkeys; i++) {
        const kf_keydef *k = &kf_keys[i];
        KT_CHECK(kf_key_default(k, scratch) == 0, "default of %s ('%s') does not satisfy its own bounds", k->path,
                 k->def);
        KT_CHECK(k->doc && k->doc[0], "%s has no doc line", k->path);
        KT_CHECK(kf_key_find(k->path) == i, "%s is declared twice", k->path);
        char parent[96];
        kf_key_parent(k, parent, sizeof parent);
        size_t pl = strlen(parent);
        if (pl > 2 && strcmp(parent + pl - 2, ".*") == 0) parent[pl - 2] = '\0';
        if (pl > 2 && strcmp(parent + pl - 2, "[]") == 0) parent[pl - 2] = '\0';
        KT_CHECK(parent[0] == '\0' || kf_key_find(parent) >= 0, "%s: its container %s is not declared", k->path,
                 parent);
        if (k->only) {
            char cond[128], choice[64];
            const char *eq = strchr(k->only, '=');
            kf_key_parent(k, cond, sizeof cond);
            size_t cl = strlen(cond);
            snprintf(cond + cl, sizeof cond - cl, "%s%.*s", cl ? "." : "", (int)(eq - k->only), k->only);
            int c = kf_key_find(cond);
            KT_CHECK(c >= 0 && kf_keys[c].type == KT_ENUM, "%s: only= names %s, not an enum key", k->path, cond);
            for (const char *p = eq + 1; c >= 0 && *p;) {
                size_t l = strcspn(p, "|");
                int found = 0;
                for (int j = 0; *kf_key_choice(&kf_keys[c], j, choice, sizeof choice); j++)
                    found |= strlen(choice) == l && strncmp(choice, p, l) == 0;
                KT_CHECK(found, "%s: only= names a value %.*s that %s does not have", k->path, (int)l, p, cond);
                p += l + (p[l] == '|');
            }
        }
    }
    /* enums written in C order, so an index is the kf_* value */
#define CHOICE(path, value, name)                                                                                      \
    KT_CHECK(strcmp(kf_key_choice(&kf_keys[kf_key_find(path)], (value), b, sizeof b), name) == 0,                      \
             "%s: choice %d should be %s", path, (int)(value), name)
    char b[32];
    CHOICE("sim.kernel", KF_KERNEL_CUBIC, "cubic");
    CHOICE("sim.force", KF_FORCE_CLASSIC, "classic");
    CHOICE("sim.transfer", KF_TRANSFER_PIC, "pic");
    CHOICE("colliders[].shape", KF_SHAPE_SPHERE, "sphere");
    CHOICE("colliders[].shape", KF_SHAPE_MESH, "mesh");
    CHOICE("colliders[].interpolation", KF_INTERP_SMOOTH, "smooth");
    CHOICE("colliders[].boundary", KF_BOUNDARY_SLIP, "slip");
    CHOICE("materials.*.model", KF_MAT_SNOW, "snow");
    CHOICE("objects[].shape", KF_SOURCE_MESH, "mesh");
    CHOICE("domain.walls", KF_BOUNDARY_SEPARATE + 1, "separate"); /* after "none" */
    CHOICE("rigids[].motion", KF_RIGID_DYNAMIC, "dynamic");
    CHOICE("rigids[].boundary", KF_BOUNDARY_SEPARATE, "separate");
    CHOICE("rigids[].interpolation", KF_INTERP_SMOOTH, "smooth");
#undef CHOICE

    /* the help is generated from the same rows */
    char *buf = NULL;
    size_t len = 0;
    FILE *f = open_memstream(&buf, &len);
    kf_shot_help(f);
    fclose(f);
    KT_CHECK(strstr(buf, "  sim.dx                           number in (0, 10], m; default 0.02\n"),
             "help shows sim.dx:\n%s", buf);
    KT_CHECK(strstr(buf, "materials.NAME.nu"), "help shows material keys");
    KT_CHECK(strstr(buf, "only for shape sphere or cylinder"), "help shows where a key applies");
    KT_CHECK(strstr(buf, "  wet_sand "), "help lists the presets");
    free(buf);
}

static void suggestions(void) {
    const char *keys[] = {"dx", "ppc", "cfl", "friction", "velocity", NULL};
    KT_CHECK(kf_suggest("dxx", keys, -1) && strcmp(kf_suggest("dxx", keys, -1), "dx") == 0, "dxx -> dx");
    KT_CHECK(kf_suggest("fricton", keys, -1) && strcmp(kf_suggest("fricton", keys, -1), "friction") == 0, "fricton");
    KT_CHECK(kf_suggest("veloctiy", keys, -1) && strcmp(kf_suggest("veloctiy", keys, -1), "velocity") == 0,
             "a transposition is one edit");
    KT_CHECK(kf_suggest("gravity", keys, -1) == NULL, "nothing close: no guess");
    KT_NEAR(kf_edit_distance("kitten", "sitting"), 3, 0, "the textbook case");
}

/* ---- good input ------------------------------------------------------------------ */

static void good_shot_values(void) {
    kf_diag d;
    kf_shot *s = load("good.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s != NULL, "good.yaml loads");
    KT_CHECK(d.count == 0, "and says nothing (%d diagnostics)", d.count);
    if (!s) return dump(&d), kf_diag_free(&d);
    KT_CHECK(strcmp(s->name, "bunny_drop") == 0, "shot name %s", s->name);
    KT_CHECK(s->version == 3 && s->frame_start == 1001 && s->frame_end == 1048, "frames");
    KT_NEAR(s->fps, 24, 0, "fps as written");
    KT_CHECK(s->first == 1001 && s->last == 1048, "no --frames: the whole range");
    KT_NEAR(s->sim.dx, 0.01, 0, "dx as written");
    KT_CHECK(s->ppc == 27 && s->ppc_axis == 3, "ppc 27 = 3 per axis");
    KT_NEAR(s->sim.cfl, 0.5, 0, "cfl");
    KT_CHECK(s->sim.kernel == KF_KERNEL_CUBIC && s->sim.transfer == KF_TRANSFER_PIC && s->sim.force == KF_FORCE_MLS,
             "enums (force by default)");
    KT_CHECK(s->jitter == 0 && s->seed == 1, "jitter off, default seed");
    KT_CHECK(s->sim.walls == 1 && s->sim.wall_boundary == KF_BOUNDARY_SLIP, "walls: slip");
    KT_NEAR(s->sim.domain_max[1], 2, 0, "domain max");
    KT_CHECK(strcmp(s->dir + strlen(s->dir) - 6, "/shots") == 0, "dir is the shot's folder: %s", s->dir);

    KT_CHECK(s->nmaterials == 4, "4 materials");
    const kf_material *jelly = &s->materials[0].mat, *firm = &s->materials[1].mat, *dune = &s->materials[2].mat,
                      *slime = &s->materials[3].mat;
    KT_CHECK(strcmp(jelly->name, "jelly") == 0 && strcmp(s->materials[0].preset, "jello") == 0, "names");
    KT_NEAR(jelly->E, 1.5e3, 0, "override of the preset's E");
    KT_NEAR(jelly->density, 400, 0, "override of the preset's density");
    KT_CHECK(jelly->model == KF_MAT_COROTATED, "jello is corotated");
    KT_NEAR(firm->E, 3e3, 0, "merge key: own E wins");
    KT_NEAR(firm->density, 400, 0, "merge key: the rest comes from the anchor");
    KT_CHECK(dune->model == KF_MAT_SAND && dune->hardening == 0, "an explicit friction angle turns hardening off");
    KT_NEAR(dune->friction_angle, 35, 0, "friction angle");
    KT_NEAR(dune->h0, 35, 0, "the rest of the sand preset stays");
    KT_CHECK(slime->model == KF_MAT_VON_MISES && s->materials[3].preset[0] == '\0', "a material without a preset");
    KT_NEAR(slime->yield_stress, 50, 0, "its yield stress");

    KT_CHECK(s->nobjects == 4, "4 objects");
    const kf_shot_object *cube = &s->objects[0], *ball = &s->objects[1], *can = &s->objects[2], *bunny = &s->objects[3];
    KT_CHECK(cube->shape == KF_SOURCE_BOX && cube->material == 0, "cube");
    KT_NEAR(cube->size[2], 0.4, 0, "box size");
    KT_NEAR(cube->velocity[1], -1, 0, "velocity");
    KT_NEAR(cube->scale[0] + cube->scale[1] + cube->scale[2], 3, 0, "default scale 1");
    KT_CHECK(strcmp(ball->name, "sphere1") == 0, "unnamed: shape + index (%s)", ball->name);
    KT_CHECK(ball->material == 1 && strcmp(ball->material_name, "firm") == 0, "material by name");
    KT_CHECK(can->shape == KF_SOURCE_CYLINDER && can->axis == 0, "cylinder along x");
    KT_NEAR(can->height, 0.3, 0, "cylinder height");
    KT_CHECK(bunny->shape == KF_SOURCE_MESH && bunny->fit == 1, "fitted mesh");
    KT_CHECK(strstr(bunny->mesh_path, "/shots/assets/cube.off") != NULL, "mesh relative to the shot: %s",
             bunny->mesh_path);
    KT_NEAR(bunny->center[1], 0.3, 0, "a fitted mesh's centre is fit.center");
    KT_NEAR(bunny->fit_size, 0.4, 0, "fit size");
    KT_NEAR(bunny->scale[2], 2, 0, "one number scales uniformly");
    KT_NEAR(bunny->rotate[1], 90, 0, "rotate, degrees");
    KT_NEAR(bunny->angular_velocity[1], 3.14, 0, "spin");

    KT_CHECK(s->ncolliders == 3, "3 colliders");
    const kf_collider *floor_ = &s->colliders[0].col, *press = &s->colliders[1].col, *ball_c = &s->colliders[2].col;
    KT_CHECK(floor_->shape == KF_SHAPE_PLANE && floor_->boundary == KF_BOUNDARY_SEPARATE, "floor");
    KT_NEAR(floor_->normal[1], 1, 1e-15, "normal normalised");
    KT_NEAR(floor_->center[1], 0.05, 0, "point");
    KT_NEAR(floor_->friction, 0.5, 0, "friction");
    KT_CHECK(press->shape == KF_SHAPE_BOX && press->boundary == KF_BOUNDARY_STICKY && press->nkeys == 2, "press");
    KT_NEAR(press->half[1], 0.05, 1e-15, "half extents from size");
    KT_NEAR(press->keys[0].time, 0, 0, "frame 1001 = t 0");
    KT_NEAR(press->keys[1].time, 1.0, 1e-12, "frame 1025 at 24 fps = 1 s");
    KT_NEAR(press->keys[1].position[1], 0.5, 1e-15, "key position = center + translate");
    KT_CHECK(strcmp(s->colliders[2].name, "ball") == 0 && ball_c->nkeys == 0, "constant velocity collider");
    KT_NEAR(ball_c->velocity[0], 1, 0, "its velocity");
    KT_NEAR(ball_c->friction, 0.3, 0, "default friction");

    KT_CHECK(strcmp(s->output_dir, "renders/{shot}/v{version:03d}") == 0, "output dir");
    KT_CHECK(strcmp(s->output_name, "{shot}.{frame:04d}") == 0, "default output name");
    KT_CHECK(s->output_particles == 1 && s->output_checkpoints == 0, "output switches");
    KT_CHECK(s->quality == KF_QUALITY_FINAL && s->resolution_scale == 1, "final quality");
    kf_shot_free(s);
    kf_diag_free(&d);
}

/* the implicit step's scheme: parsed, a warning without the implicit
 * integrator, an error for a name it does not know */
static void implicit_scheme_key(void) {
    kf_diag d;
    const char *good[] = {"sim.integrator=implicit", "sim.implicit_scheme=midpoint"};
    kf_shot *s = load("good.yaml", good, 2, NULL, NULL, &d);
    KT_CHECK(s != NULL && d.count == 0, "midpoint loads, nothing said (%d diagnostics)", d.count);
    if (s) KT_CHECK(s->sim.implicit_scheme == KF_SCHEME_MIDPOINT, "scheme %d", (int)s->sim.implicit_scheme);
    kf_shot_free(s);
    kf_diag_free(&d);
    s = load("good.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s != NULL && s->sim.implicit_scheme == KF_SCHEME_BACKWARD_EULER, "backward Euler by default");
    kf_shot_free(s);
    kf_diag_free(&d);
    const char *unused[] = {"sim.implicit_scheme=midpoint"};
    s = load("good.yaml", unused, 1, NULL, NULL, &d);
    KT_CHECK(s != NULL && d.errors == 0, "without the implicit integrator: loads");
    EXPECT(&d, "--set", 1, 5, KF_DIAG_WARNING,
           "sim.implicit_scheme has no effect with integrator explicit (only with implicit)");
    kf_shot_free(s);
    kf_diag_free(&d);
    const char *bad[] = {"sim.integrator=implicit", "sim.implicit_scheme=leapfrog"};
    s = load("good.yaml", bad, 2, NULL, NULL, &d);
    KT_CHECK(s == NULL && d.errors == 1, "unknown scheme refused (%d errors)", d.errors);
    EXPECT(&d, "--set", 2, 21, KF_DIAG_ERROR,
           "sim.implicit_scheme: expected backward_euler or midpoint, got 'leapfrog'");
    kf_shot_free(s);
    kf_diag_free(&d);
}

/* what the builder hands the sampler: the real kf_sample_placement puts each
 * object where the shot says */
static void placement_for_sampler(void) {
    kf_diag d;
    kf_shot *s = load("good.yaml", NULL, 0, NULL, NULL, &d);
    if (!s) return dump(&d), kf_diag_free(&d);
    char err[256];
    double M[12], lo[3], hi[3];
    kf_sample_def sd = kf_default_sample_def();

    const kf_shot_object *cube = &s->objects[0];
    sd.kind = cube->shape;
    memcpy(sd.size, cube->size, sizeof sd.size);
    sd.place = cube->place;
    KT_CHECK(kf_sample_placement(&sd, NULL, M, lo, hi, err, sizeof err) == 0, "%s", err);
    KT_NEAR(lo[0], 0.4, 1e-12, "box centred at center (x)");
    KT_NEAR(hi[2], 0.7, 1e-12, "box centred at center (z)");

    /* axis: x becomes one rotation the sampler applies to its y-cylinder */
    const kf_shot_object *can = &s->objects[2];
    sd = kf_default_sample_def();
    sd.kind = can->shape;
    sd.radius = can->radius;
    sd.height = can->height;
    sd.place = can->place;
    KT_CHECK(kf_sample_placement(&sd, NULL, M, lo, hi, err, sizeof err) == 0, "%s", err);
    KT_NEAR(hi[0] - lo[0], 0.3, 1e-9, "cylinder runs along x");
    KT_NEAR(hi[1] - lo[1], 0.2, 1e-9, "and is round in y");
    KT_NEAR(0.5 * (lo[0] + hi[0]), 0.7, 1e-9, "centred at center");

    /* a fitted mesh: rotate, scale, then fit; translate moves the fit centre */
    const kf_shot_object *bunny = &s->objects[3];
    kf_mesh mesh;
    KT_CHECK(kf_mesh_load(bunny->mesh_path, &mesh, err, sizeof err) == 0, "the resolved mesh path loads: %s", err);
    sd = kf_default_sample_def();
    sd.kind = bunny->shape;
    sd.place = bunny->place;
    if (kf_sample_placement(&sd, &mesh, M, lo, hi, err, sizeof err) == 0) {
        KT_NEAR(lo[0], 0.4, 1e-9, "fit centre x 0.5 + translate 0.1, size 0.4");
        KT_NEAR(hi[1], 0.5, 1e-9, "fit centre y 0.3 + half of 0.4");
    } else {
        KT_CHECK(0, "placement: %s", err);
    }
    kf_mesh_free(&mesh);

    /* the builder reports at the shot's own line */
    kf_diag_free(&d);
    kf_diag_init(&d);
    kf_shot_report(&d, &bunny->mesh_at, KF_DIAG_ERROR, "%s", "assets/cube.off: not closed: 3 boundary edges");
    char *got = printed(&d.entry[0]);
    char want[1400];
    snprintf(want, sizeof want,
             "%s:33:11: error: assets/cube.off: not closed: 3 boundary edges\n"
             "   33 |     mesh: assets/cube.off\n"
             "      |           ^\n",
             fixture("good.yaml"));
    KT_CHECK(strcmp(got, want) == 0, "got\n%s", got);
    free(got);
    KT_CHECK(s->materials[2].at.line == 18 && s->materials[2].at.col == 3, "a material's place");
    KT_CHECK(s->colliders[1].at.line == 43 && s->colliders[1].at.col == 5, "a collider's place (%d:%d)",
             s->colliders[1].at.line, s->colliders[1].at.col);
    kf_shot_free(s);
    kf_diag_free(&d);
}

/* only the required keys: everything else is the table's default */
static void defaults(void) {
    kf_diag d;
    kf_shot *s = load("minimal.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s != NULL && d.count == 0, "minimal.yaml loads cleanly");
    if (!s) return dump(&d), kf_diag_free(&d);
    KT_CHECK(strcmp(s->name, "minimal") == 0, "name from the file stem: %s", s->name);
    KT_CHECK(s->version == 1 && s->frame_start == 1001 && s->frame_end == 1010, "version, start");
    KT_NEAR(s->fps, 24, 0, "fps");
    KT_NEAR(s->sim.dx, 0.02, 0, "dx");
    KT_CHECK(s->ppc == 8 && s->ppc_axis == 2 && s->jitter == 1, "ppc, jitter");
    KT_NEAR(s->sim.cfl, 0.4, 0, "cfl");
    KT_NEAR(s->sim.gravity[1], -9.81, 0, "gravity");
    KT_CHECK(s->sim.walls == 1 && s->sim.wall_boundary == KF_BOUNDARY_SEPARATE, "closed separate walls");
    KT_NEAR(s->sim.wall_friction, 0.3, 0, "wall friction");
    KT_CHECK(s->sim.max_retries == 4 && s->sim.threads == 0, "retries, threads");
    KT_NEAR(s->sim.j_max, kf_default_sim_def().j_max, 0, "keys the file cannot set keep the library default");
    KT_CHECK(s->materials[0].mat.model == KF_MAT_WATER, "water preset");
    KT_NEAR(s->materials[0].mat.bulk_modulus, 1e5, 0, "preset values");
    KT_CHECK(strcmp(s->objects[0].name, "sphere0") == 0, "default object name");
    KT_CHECK(strcmp(s->output_dir, "out/{shot}/v{version:03d}") == 0 && s->output_particles && s->output_checkpoints,
             "output defaults");
    kf_shot_free(s);
    kf_diag_free(&d);
}

static void json_input(void) {
    kf_diag d;
    kf_shot *s = load("good.json", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s != NULL && d.count == 0, "good.json loads");
    if (s) {
        KT_CHECK(strcmp(s->name, "from_json") == 0 && s->frame_start == 1 && s->frame_end == 12, "values");
        KT_NEAR(s->fps, 30, 0, "fps");
        KT_NEAR(s->objects[0].size[1], 0.2, 0, "one number: a cube");
        KT_NEAR(s->materials[0].mat.yield_stress, 80, 0, "override in JSON");
    }
    kf_shot_free(s);
    kf_diag_free(&d);

    s = load("bad.json", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s == NULL && d.errors == 1, "bad.json: one error");
    EXPECT(&d, fixture("bad.json"), 3, 41, KF_DIAG_ERROR,
           "objects[0].size: expected [x, y, z] or one number, got the string \"big\"");
    kf_diag_free(&d);
}

/* ---- bad input ------------------------------------------------------------------ */

/* every mistake in bad.yaml, found in one pass, each at its exact place */
static void bad_reports_everything(void) {
    kf_diag d;
    const char *f = fixture("bad.yaml");
    kf_shot *s = load("bad.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s == NULL, "bad.yaml fails");
    KT_CHECK(d.errors == 16 && d.warnings == 4, "16 errors and 4 warnings, got %d and %d", d.errors, d.warnings);
    EXPECT(&d, f, 5, 3, KF_DIAG_ERROR, "unknown key 'dxx' in sim (did you mean 'dx'?)");
    EXPECT(&d, f, 6, 8, KF_DIAG_ERROR, "sim.cfl: expected a number, got 'abc'");
    EXPECT(&d, f, 7, 8, KF_DIAG_ERROR, "sim.ppc must be 1, 8, 27 or 64, got 10");
    EXPECT(&d, f, 8, 11, KF_DIAG_ERROR, "sim.kernel: unknown value 'quadratik' (did you mean 'quadratic'?)");
    EXPECT(&d, f, 9, 12, KF_DIAG_ERROR, "sim.gravity: expected [x, y, z], got 2 numbers");
    EXPECT(&d, f, 10, 57, KF_DIAG_WARNING, "domain.friction has no effect with walls sticky (only with separate)");
    EXPECT(&d, f, 12, 19, KF_DIAG_ERROR, "materials.jelly.preset: unknown preset 'jelo' (did you mean 'jello'?)");
    EXPECT(&d, f, 12, 28, KF_DIAG_ERROR, "materials.jelly.E must be > 0 Pa, got -5");
    EXPECT(&d, f, 12, 3, KF_DIAG_WARNING, "materials.jelly is not used by any object");
    EXPECT(&d, f, 13, 28, KF_DIAG_ERROR, "materials.gel.nu must be in [0, 0.5), got 0.7");
    EXPECT(&d, f, 14, 24, KF_DIAG_WARNING, "materials.grit.yield_stress has no effect with model sand");
    /* kf_material_check's message, at the parameter it names */
    EXPECT(&d, f, 15, 28, KF_DIAG_ERROR, "materials.hard: h0 - h3 (initial friction angle) must be in [0, 90)");
    EXPECT(&d, f, 15, 3, KF_DIAG_WARNING, "materials.hard is not used by any object");
    EXPECT(&d, f, 17, 88, KF_DIAG_ERROR, "objects[0]: material 'jely' is not defined (did you mean 'jelly'?)");
    EXPECT(&d, f, 18, 5, KF_DIAG_ERROR, "objects[1].radius is missing (required for shape sphere)");
    EXPECT(&d, f, 18, 73, KF_DIAG_ERROR, "objects[1].size does not apply to shape sphere (only to box)");
    EXPECT(&d, f, 19, 38, KF_DIAG_ERROR, "objects[2]: mesh file 'assets/bunny.off' not found (looked for ");
    EXPECT(&d, f, 20, 82, KF_DIAG_ERROR, "unknown key 'velocty' in objects[3] (did you mean 'velocity'?)");
    EXPECT(&d, f, 26, 35, KF_DIAG_ERROR,
           "colliders[0].keys[1].frame must come after the previous key's frame 1010, got 1005");
    EXPECT(&d, f, 27, 28, KF_DIAG_ERROR, "output.dir: unknown field {verison}; use {shot}, {version} or {frame}");

    /* sorted top to bottom */
    for (int i = 1; i < d.count; i++)
        KT_CHECK(d.entry[i - 1].line <= d.entry[i].line, "entries in file order (%d after %d)", d.entry[i].line,
                 d.entry[i - 1].line);

    /* printed like a compiler: location, message, the line, a caret */
    const kf_diag_entry *e = find(&d, f, 6, 8, "sim.cfl");
    if (e) {
        char want[1400];
        snprintf(want, sizeof want,
                 "%s:6:8: error: sim.cfl: expected a number, got 'abc'\n"
                 "    6 |   cfl: abc\n"
                 "      |        ^\n",
                 f);
        char *got = printed(e);
        KT_CHECK(strcmp(got, want) == 0, "printed as\n%s\nexpected\n%s", got, want);
        free(got);
    }
    kf_diag_free(&d);
}

static void bad_structure(void) {
    kf_diag d;
    const char *f = fixture("bad_structure.yaml");
    kf_shot *s = load("bad_structure.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s == NULL && d.errors == 6 && d.warnings == 0, "6 errors, got %d", d.errors);
    EXPECT(&d, f, 2, 1, KF_DIAG_ERROR, "frames is missing (required)");
    EXPECT(&d, f, 3, 17, KF_DIAG_ERROR, "sim.dx is given twice (first at ");
    EXPECT(&d, f, 8, 12, KF_DIAG_ERROR, "objects[1]: the name 'same' is taken by an earlier item");
    EXPECT(&d, f, 10, 63, KF_DIAG_ERROR, "colliders[0]: give velocity or keys, not both");
    EXPECT(&d, f, 11, 46, KF_DIAG_ERROR, "colliders[1].normal must not be [0, 0, 0]");
    EXPECT(&d, f, 12, 17, KF_DIAG_ERROR, "output.name must contain {frame}");
    kf_diag_free(&d);
}

/* the image keys: a format that is not one, a shutter over a frame, a
 * number that is not one; from the file and from --set, each at its place */
static void bad_render_keys(void) {
    kf_diag d;
    const char *f = fixture("bad_render.yaml");
    kf_shot *s = load("bad_render.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s == NULL && d.errors == 2 && d.warnings == 0, "2 errors, got %d", d.errors);
    EXPECT(&d, f, 7, 11, KF_DIAG_ERROR,
           "render.format: unknown value 'ex' (did you mean 'exr'?); choose png, exr or both");
    EXPECT(&d, f, 8, 16, KF_DIAG_ERROR, "render.motion_blur must be in [0, 1] frames, got 1.5");
    kf_diag_free(&d);
    const char *sets[] = {"render.motion_blur=-1", "render.format=tiff", "render.motion_blur=fast"};
    for (int k = 0; k < 3; k++) {
        s = load("minimal.yaml", &sets[k], 1, NULL, NULL, &d);
        KT_CHECK(s == NULL && d.errors == 1, "--set %s is one error", sets[k]);
        static const char *want[] = {"render.motion_blur must be in [0, 1] frames, got -1",
                                     "render.format: expected png, exr or both, got 'tiff'",
                                     "render.motion_blur: expected a number, got 'fast'"};
        static const int col[] = {20, 15, 20};
        EXPECT(&d, "--set", 1, col[k], KF_DIAG_ERROR, want[k]);
        kf_diag_free(&d);
    }
    /* the defaults: PNG only, no blur; and the values taken */
    s = load("minimal.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s && s->render_format == KF_FORMAT_PNG && s->render_motion_blur == 0, "defaults png, no blur");
    kf_shot_free(s);
    kf_diag_free(&d);
    const char *good[] = {"render.format=both", "render.motion_blur=0.5"};
    s = load("minimal.yaml", good, 2, NULL, NULL, &d);
    KT_CHECK(s && s->render_format == KF_FORMAT_BOTH && s->render_motion_blur == 0.5, "both, shutter 0.5");
    kf_shot_free(s);
    kf_diag_free(&d);
}

static void syntax_error(void) {
    kf_diag d;
    kf_shot *s = load("syntax.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s == NULL && d.errors == 1, "a YAML syntax error is one error");
    KT_CHECK(d.count == 1 && d.entry[0].line == 5 && strstr(d.entry[0].message, "YAML syntax: flow sequence"),
             "at libfyaml's position with its message");
    kf_diag_free(&d);

    s = kf_shot_load("/nonexistent/shot.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s == NULL && d.count == 1 && strstr(d.entry[0].message, "cannot read the shot file"), "missing file");
    kf_diag_free(&d);
}

/* a caret lines up under tabs and multi-byte characters */
static void caret(void) {
    kf_diag d;
    kf_diag_init(&d);
    kf_diag_add(&d, KF_DIAG_WARNING, "x.yaml", 3, 7, "\tnäme: 1", "look");
    char *got = printed(&d.entry[0]);
    KT_CHECK(strcmp(got, "x.yaml:3:7: warning: look\n    3 | \tnäme: 1\n      | \t     ^\n") == 0, "got\n%s", got);
    free(got);
    kf_diag_free(&d);
}

/* ---- the command line ------------------------------------------------------------------ */

static void overrides(void) {
    kf_diag d;
    const char *sets[] = {"materials.jelly.E=2e3",         "objects.cube.velocity=[0, -2, 0]",
                          "colliders.0.friction=0.1",      "sim.kernel=quadratic",
                          "materials.extra={preset: goo}", "objects.1.material=extra",
                          "objects.sphere1.radius=0.15",   "domain={walls: none}"};
    kf_shot *s = load("good.yaml", sets, 8, NULL, NULL, &d);
    KT_CHECK(s != NULL && d.errors == 0 && d.warnings == 1, "overrides apply cleanly");
    EXPECT(&d, fixture("good.yaml"), 17, 3, KF_DIAG_WARNING, "materials.firm is not used by any object");
    if (s) {
        KT_NEAR(s->materials[0].mat.E, 2e3, 0, "materials.jelly.E");
        KT_NEAR(s->materials[0].mat.density, 400, 0, "the rest of the material is the file's");
        KT_NEAR(s->objects[0].velocity[1], -2, 0, "a list item by name");
        KT_NEAR(s->colliders[0].col.friction, 0.1, 0, "a list item by index");
        KT_CHECK(s->sim.kernel == KF_KERNEL_QUADRATIC, "an enum");
        KT_CHECK(s->nmaterials == 5 && s->objects[1].material == 4, "a new material, then used");
        KT_NEAR(s->objects[1].radius, 0.15, 0, "an unnamed item by its default name");
        KT_CHECK(s->sim.walls == 0, "a whole section replaced");
        KT_NEAR(s->sim.domain_max[1], 1, 0, "... so its other keys take their defaults");
    } else {
        dump(&d);
    }
    kf_shot_free(s);
    kf_diag_free(&d);

    /* bad overrides: checked by the same table, reported at the override */
    const char *bad[] = {"materials.jelly.E=abc", "objects.cub.center=1", "sim.dxx=3", "frames.end", "sim.dx=-1"};
    s = load("good.yaml", bad, 5, NULL, NULL, &d);
    KT_CHECK(s == NULL && d.errors == 5, "5 errors, got %d", d.errors);
    EXPECT(&d, "--set", 1, 19, KF_DIAG_ERROR, "materials.jelly.E: expected a number, got 'abc'");
    EXPECT(&d, "--set", 2, 9, KF_DIAG_ERROR, "objects has no item 'cub' (did you mean 'cube'?)");
    EXPECT(&d, "--set", 3, 5, KF_DIAG_ERROR, "unknown key 'dxx' in sim (did you mean 'dx'?)");
    EXPECT(&d, "--set", 4, 11, KF_DIAG_ERROR, "--set wants path=value");
    EXPECT(&d, "--set", 5, 8, KF_DIAG_ERROR, "sim.dx must be in (0, 10] m, got -1");
    const kf_diag_entry *e = find(&d, "--set", 1, 19, "materials.jelly.E");
    if (e) {
        char *got = printed(e);
        KT_CHECK(strcmp(got, "--set:1:19: error: materials.jelly.E: expected a number, got 'abc'\n"
                             "    1 | materials.jelly.E=abc\n"
                             "      |                   ^\n") == 0,
                 "the override is echoed:\n%s", got);
        free(got);
    }
    kf_diag_free(&d);
}

static void quality(void) {
    kf_diag d;
    kf_shot *s = load("good.yaml", NULL, 0, "preview", NULL, &d);
    KT_CHECK(s != NULL, "preview loads");
    if (s) {
        KT_NEAR(s->sim.dx, 0.02, 0, "preview doubles dx");
        KT_CHECK(s->quality == KF_QUALITY_PREVIEW && s->resolution_scale == 0.5, "and halves the images");
    }
    kf_shot_free(s);
    kf_diag_free(&d);
    s = load("good.yaml", NULL, 0, "final", NULL, &d);
    KT_CHECK(s && s->sim.dx == 0.01, "final keeps dx");
    kf_shot_free(s);
    kf_diag_free(&d);
    s = load("good.yaml", NULL, 0, "previw", NULL, &d);
    KT_CHECK(s == NULL && d.errors == 1, "a bad quality fails");
    EXPECT(&d, "--quality", 1, 1, KF_DIAG_ERROR, "unknown quality 'previw' (did you mean 'preview'?)");
    kf_diag_free(&d);
}

static void frames(void) {
    kf_diag d;
    kf_shot *s = load("good.yaml", NULL, 0, NULL, "1005-1010", &d);
    KT_CHECK(s && s->first == 1005 && s->last == 1010, "a sub-range");
    KT_CHECK(s && s->frame_start == 1001, "the shot's range stays (keys count from it)");
    kf_shot_free(s);
    kf_diag_free(&d);
    s = load("good.yaml", NULL, 0, NULL, "1048", &d);
    KT_CHECK(s && s->first == 1048 && s->last == 1048, "one frame");
    kf_shot_free(s);
    kf_diag_free(&d);

    struct {
        const char *arg;
        int col;
        const char *msg;
    } bad[] = {
        {"1040-1060", 6, "frame 1060 is after the shot's last frame 1048"},
        {"990-1002", 1, "frame 990 is outside the shot's frames 1001-1048"},
        {"1010-1005", 6, "last frame 1005 is before first frame 1010"},
        {"10x", 3, "--frames wants FIRST-LAST or one frame"},
        {"1001-", 6, "--frames wants FIRST-LAST or one frame"},
    };
    for (int i = 0; i < (int)(sizeof bad / sizeof bad[0]); i++) {
        s = load("good.yaml", NULL, 0, NULL, bad[i].arg, &d);
        KT_CHECK(s == NULL && d.errors == 1, "--frames %s fails", bad[i].arg);
        EXPECT(&d, "--frames", 1, bad[i].col, KF_DIAG_ERROR, bad[i].msg);
        kf_diag_free(&d);
    }
    /* the range checked is the one after --set */
    const char *sets[] = {"frames.end=1100"};
    s = load("good.yaml", sets, 1, NULL, "1050-1100", &d);
    KT_CHECK(s && s->last == 1100, "--set frames.end widens what --frames may ask");
    kf_shot_free(s);
    kf_diag_free(&d);
}

static void templates(void) {
    kf_shot sh;
    memset(&sh, 0, sizeof sh);
    snprintf(sh.name, sizeof sh.name, "bunny_drop");
    sh.version = 3;
    char out[256];
    KT_CHECK(kf_shot_expand("out/{shot}/v{version:03d}/{shot}.{frame:04d}.vdb", &sh, 1001, out, sizeof out) == 0 &&
                 strcmp(out, "out/bunny_drop/v003/bunny_drop.1001.vdb") == 0,
             "got %s", out);
    KT_CHECK(kf_shot_expand("{frame:04d}", &sh, 7, out, sizeof out) == 0 && strcmp(out, "0007") == 0, "zero padding");
    KT_CHECK(kf_shot_expand("{frame}", &sh, 1001, out, sizeof out) == 0 && strcmp(out, "1001") == 0, "no width");
    KT_CHECK(kf_shot_expand("{version:03d}", &sh, 0, out, sizeof out) == 0 && strcmp(out, "003") == 0, "version");
    KT_CHECK(kf_shot_expand("{{x}}_{shot}", &sh, 0, out, sizeof out) == 0 && strcmp(out, "{x}_bunny_drop") == 0,
             "escaped braces");
    KT_CHECK(kf_shot_expand("{nope}", &sh, 0, out, sizeof out) == -1 && out[0] == '\0', "unknown field");
    KT_CHECK(kf_shot_expand("{frame:4x}", &sh, 0, out, sizeof out) == -1, "bad format");
    KT_CHECK(kf_shot_expand("{frame", &sh, 0, out, sizeof out) == -1, "unclosed");
    KT_CHECK(kf_shot_expand("{shot}{shot}", &sh, 0, out, 8) == -1 && out[0] == '\0', "too small a buffer");
    KT_NEAR(kf_shot_frame_time(&(kf_shot){.frame_start = 1001, .fps = 24}, 1013), 0.5, 1e-15, "frame to seconds");
}

/* ---- colliders: meshes, placement, rotate/scale keys, interpolation ---------------------- */

static void collider_keys(void) {
    kf_diag d;
    kf_shot *s = load("colliders.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s != NULL && d.count == 0, "colliders.yaml loads cleanly (%d diagnostics)", d.count);
    if (!s) return dump(&d), kf_diag_free(&d);
    KT_CHECK(s->ncolliders == 4, "4 colliders");
    const kf_shot_collider *spin = &s->colliders[0], *lid = &s->colliders[1], *flap = &s->colliders[2],
                           *tilt = &s->colliders[3];
    /* a fitted mesh: placed like an object, pivot at fit.center + translate */
    KT_CHECK(spin->col.shape == KF_SHAPE_MESH && spin->col.boundary == KF_BOUNDARY_STICKY, "mesh collider");
    KT_CHECK(strstr(spin->mesh_path, "/shots/assets/cube.off") != NULL, "mesh relative to the shot: %s",
             spin->mesh_path);
    KT_CHECK(spin->fit == 1 && spin->place.fit == 1, "fitted");
    KT_NEAR(spin->place.fit_center[1], 0.35, 1e-15, "the fit centre moved by translate");
    KT_NEAR(spin->place.fit_size, 0.2, 0, "fit size");
    KT_NEAR(spin->place.rotate[1], 45, 0, "rest rotation goes into the placement");
    KT_NEAR(spin->place.scale[0], 2, 0, "scale into the placement");
    KT_NEAR(spin->col.rotate[1], 0, 0, "a mesh's rest rotation is baked into its distance grid, not col.rotate");
    KT_NEAR(spin->col.center[1], 0.35, 1e-15, "pivot = fit.center + translate");
    KT_CHECK(spin->col.interp == KF_INTERP_SMOOTH && spin->col.nkeys == 3, "smooth, 3 keys");
    const kf_key *k = spin->col.keys;
    KT_NEAR(k[1].time, 0.5, 1e-12, "frame 1013 at 24 fps = 0.5 s");
    KT_NEAR(k[1].position[0], 0.6, 1e-15, "key position = pivot + translate");
    KT_NEAR(k[0].rotate[1] + k[0].scale[0], 1, 0, "a bare key: no rotation, scale 1");
    KT_NEAR(k[1].rotate[1], 180, 0, "key rotate");
    KT_NEAR(k[1].scale[2], 1.5, 0, "one number scales uniformly");
    KT_NEAR(k[2].scale[1], 2, 0, "per-axis key scale");
    KT_NEAR(k[2].rotate[1], 360, 0, "a full turn is kept as written");
    /* an unfitted mesh with its own pivot, a container */
    KT_CHECK(lid->fit == 0 && lid->col.inside == 1 && lid->col.nkeys == 0, "lid");
    KT_NEAR(lid->place.translate[0], 0.4, 0, "placed by translate");
    KT_NEAR(lid->col.center[0], 0.5, 0, "the given pivot");
    KT_NEAR(lid->place.scale[1], 1, 0, "default scale");
    KT_CHECK(lid->mesh_at.line == 24 && lid->mesh_at.col == 36, "where its mesh: is (%d:%d)", lid->mesh_at.line,
             lid->mesh_at.col);
    /* a box: rest rotation on the collider, keys rotate on top of it */
    KT_CHECK(flap->col.shape == KF_SHAPE_BOX && flap->col.interp == KF_INTERP_LINEAR && flap->col.nkeys == 2, "flap");
    KT_NEAR(flap->col.rotate[2], 30, 0, "a box's rest orientation");
    KT_NEAR(flap->col.keys[1].rotate[2], 60, 0, "key rotation");
    KT_NEAR(flap->col.keys[1].position[1], 0.7, 1e-15, "key position = center + translate");
    KT_NEAR(flap->col.keys[1].time, 0.25, 1e-12, "frame 1007 = 0.25 s");
    /* one key holds the pose */
    KT_CHECK(tilt->col.nkeys == 1, "one key kept (held)");
    KT_NEAR(tilt->col.keys[0].rotate[0], 10, 0, "its rotation");
    KT_NEAR(tilt->col.keys[0].position[1], 0.1, 0, "at the point");
    kf_shot_free(s);
    kf_diag_free(&d);
}

static void bad_collider_keys(void) {
    kf_diag d;
    const char *f = fixture("bad_colliders.yaml");
    kf_shot *s = load("bad_colliders.yaml", NULL, 0, NULL, NULL, &d);
    KT_CHECK(s == NULL, "bad_colliders.yaml fails");
    KT_CHECK(d.errors == 13 && d.warnings == 1, "13 errors and 1 warning, got %d and %d", d.errors, d.warnings);
    EXPECT(&d, f, 7, 5, KF_DIAG_ERROR, "colliders[0].mesh is missing (required for shape mesh)");
    EXPECT(&d, f, 7, 33, KF_DIAG_ERROR, "colliders[0].fit.size is missing (required)");
    EXPECT(&d, f, 8, 37, KF_DIAG_ERROR, "colliders[1]: mesh file 'assets/none.obj' not found (looked for ");
    EXPECT(&d, f, 8, 61, KF_DIAG_ERROR, "colliders[1].scale must be > 0, got 0");
    EXPECT(&d, f, 9, 66, KF_DIAG_ERROR, "colliders[2].scale does not apply to shape box (only to mesh)");
    EXPECT(&d, f, 9, 76, KF_DIAG_ERROR, "colliders[2].fit does not apply to shape box (only to mesh)");
    EXPECT(&d, f, 10, 71, KF_DIAG_ERROR, "colliders[3].rotate does not apply to shape sphere (only to box|mesh)");
    EXPECT(&d, f, 10, 106, KF_DIAG_WARNING, "colliders[3].interpolation has no effect with no keys");
    EXPECT(&d, f, 15, 20, KF_DIAG_ERROR,
           "colliders[4].interpolation: unknown value 'smoth' (did you mean 'smooth'?); choose linear or smooth");
    EXPECT(&d, f, 17, 31, KF_DIAG_ERROR, "colliders[4].keys[0].rotate: expected [x, y, z], got 2 numbers");
    EXPECT(&d, f, 18, 17, KF_DIAG_ERROR,
           "colliders[4].keys[1].frame must come after the previous key's frame 1010, got 1005");
    EXPECT(&d, f, 18, 30, KF_DIAG_ERROR, "colliders[4].keys[1].scale must be > 0, got 0");
    EXPECT(&d, f, 19, 23, KF_DIAG_ERROR,
           "unknown key 'rotation' in colliders[4].keys[2]; keys here: frame, translate, "
           "rotate, scale");
    EXPECT(&d, f, 20, 70, KF_DIAG_ERROR, "colliders[5].inside does not apply to shape plane (only to box|sphere|mesh)");
    kf_diag_free(&d);

    /* overrides reach the new keys too */
    const char *sets[] = {"colliders.spinner.interpolation=linear", "colliders.flap.rotate=[0, 0, 45]",
                          "colliders.lid.scale=0.5"};
    s = load("colliders.yaml", sets, 3, NULL, NULL, &d);
    KT_CHECK(s != NULL && d.count == 0, "overrides of collider keys apply cleanly");
    if (s) {
        KT_CHECK(s->colliders[0].col.interp == KF_INTERP_LINEAR, "interpolation overridden");
        KT_NEAR(s->colliders[2].col.rotate[2], 45, 0, "rotate overridden");
        KT_NEAR(s->colliders[1].place.scale[2], 0.5, 0, "scale overridden");
    } else {
        dump(&d);
    }
    kf_shot_free(s);
    kf_diag_free(&d);
}

/* the example shots in shots/ load cleanly */
static void example_shots(void) {
    const char *names[] = {"demo.yaml", "goo_sphere.yaml", "dam_break.yaml", "mesh_collider.yaml"};
    for (int i = 0; i < (int)(sizeof names / sizeof *names); i++) {
        char path[1024];
        const char *slash = strrchr(__FILE__, '/');
        snprintf(path, sizeof path, "%.*s/../shots/%s", slash ? (int)(slash - __FILE__) : 1, slash ? __FILE__ : ".",
                 names[i]);
        kf_diag d;
        kf_diag_init(&d);
        kf_shot *s = kf_shot_load(path, NULL, 0, NULL, NULL, &d);
        KT_CHECK(s != NULL && d.count == 0, "%s loads cleanly", names[i]);
        if (!s) dump(&d);
        kf_shot_free(s);
        kf_diag_free(&d);
    }
}

int main(int argc, char **argv) {
    KT_RUN(table_is_consistent, argc, argv);
    KT_RUN(suggestions, argc, argv);
    KT_RUN(good_shot_values, argc, argv);
    KT_RUN(placement_for_sampler, argc, argv);
    KT_RUN(defaults, argc, argv);
    KT_RUN(json_input, argc, argv);
    KT_RUN(bad_reports_everything, argc, argv);
    KT_RUN(bad_structure, argc, argv);
    KT_RUN(bad_render_keys, argc, argv);
    KT_RUN(syntax_error, argc, argv);
    KT_RUN(caret, argc, argv);
    KT_RUN(overrides, argc, argv);
    KT_RUN(implicit_scheme_key, argc, argv);
    KT_RUN(quality, argc, argv);
    KT_RUN(frames, argc, argv);
    KT_RUN(templates, argc, argv);
    KT_RUN(collider_keys, argc, argv);
    KT_RUN(bad_collider_keys, argc, argv);
    KT_RUN(example_shots, argc, argv);
    return KT_EXIT();
}
