/* test_sim_hash.c — every shot key either changes the cache hash
 * (kf_shot_sim_hash: frames made under another hash are simulated again) or
 * provably does not. The hash is a hand-kept list of fields (scene/build.c);
 * this walks the key table (shot/keys.c) instead, so a new key that the hash
 * forgets fails here.
 *
 * For each leaf key in the top-level, material and object scopes, two valid
 * values are made from its type, bounds, choices and default, set with
 * overrides on a base shot holding a material of every model and an object of
 * every analytic shape (the key's `only` condition picks the entry), and the
 * two hashes compared: they must differ for a simulation key and be equal for
 * the keys listed below as not simulation inputs. Keys of colliders, rigid
 * bodies, joints and keyframes are not walked yet (listed at the end). */
#include <stdlib.h>
#include <unistd.h>

#include "kt.h"
#include "scene/build.h"
#include "shot/internal.h"

/* keys that must not change the hash: outputs, rendering, surfacing, names */
/* (frames.end: a longer shot makes the same frames; the hash is per frame range start and rate) */
static const char *const not_sim[] = {"shot",
                                      "version",
                                      "frames.end",
                                      "sim.threads",
                                      "materials.*.color",
                                      "materials.*.specular",
                                      "materials.*.roughness",
                                      "objects[].name",
                                      NULL};
static const char *const not_sim_prefix[] = {"output.", "surface.", "render.", NULL};

static const char *base_shot =
    "shot: keys\n"
    "frames: {start: 1001, end: 1010, fps: 24}\n"
    "sim: {dx: 0.05}\n"
    "domain: {min: [0, 0, 0], max: [1, 1, 1]}\n"
    "materials:\n"
    "  jelly: {preset: jello}\n"
    "  goo: {preset: goo}\n"
    "  sand: {preset: sand}\n"
    "  snow: {preset: snow}\n"
    "  water: {preset: water}\n"
    "objects:\n"
    "  - {name: b, shape: box, center: [0.3, 0.3, 0.3], size: 0.2, material: jelly}\n"
    "  - {name: s, shape: sphere, center: [0.7, 0.3, 0.3], radius: 0.1, material: goo}\n"
    "  - {name: c, shape: cylinder, center: [0.5, 0.3, 0.7], radius: 0.1, height: 0.2, material: sand}\n"
    "  - {name: w, shape: box, center: [0.5, 0.7, 0.5], size: 0.1, material: water}\n"
    "  - {name: n, shape: box, center: [0.2, 0.7, 0.7], size: 0.1, material: snow}\n";

static int listed(const char *path) {
    for (int i = 0; not_sim[i]; i++)
        if (!strcmp(path, not_sim[i])) return 1;
    for (int i = 0; not_sim_prefix[i]; i++)
        if (!strncmp(path, not_sim_prefix[i], strlen(not_sim_prefix[i]))) return 1;
    return 0;
}

/* the n-th '|'-separated choice */
static void choice(const char *choices, int n, char *out, size_t len) {
    const char *p = choices;
    for (int i = 0; i < n && p; i++) p = strchr(p, '|'), p = p ? p + 1 : NULL;
    if (!p) p = choices;
    size_t k = strcspn(p, "|");
    snprintf(out, len, "%.*s", (int)(k < len ? k : len - 1), p);
}

static int inside(const kf_keydef *k, double v) {
    if (k->bounds & KB_LO && (k->bounds & KB_LO_OPEN ? v <= k->lo : v < k->lo)) return 0;
    if (k->bounds & KB_HI && (k->bounds & KB_HI_OPEN ? v >= k->hi : v > k->hi)) return 0;
    return 1;
}

/* two distinct valid numbers near the default (or inside the bounds) */
static void two_numbers(const kf_keydef *k, double v[2]) {
    char *end = NULL;
    double d = k->def ? strtod(k->def, &end) : 0;
    int has_def = k->def && end != k->def;
    double lo = k->bounds & KB_LO ? k->lo : 0, hi = k->bounds & KB_HI ? k->hi : lo + 10;
    if (has_def && d != 0) {
        v[0] = d * 1.1, v[1] = d * 1.2;
        if (!inside(k, v[0]) || !inside(k, v[1])) v[0] = d * 0.9, v[1] = d * 0.8;
    } else {
        v[0] = lo + 0.3 * (hi - lo), v[1] = lo + 0.6 * (hi - lo);
        if (!(k->bounds & KB_HI)) v[0] = lo + 0.1, v[1] = lo + 0.2; /* small: dt_max, cohesion */
    }
    if (k->type == KT_INT) {
        v[0] = has_def ? d + 1 : lo + 1, v[1] = v[0] + 1;
        if (!inside(k, v[1])) v[0] = (has_def ? d : hi) - 1, v[1] = v[0] - 1;
    }
}

/* the override path of a key for the entry its `only` names */
static int entry_path(const kf_keydef *k, char *out, size_t len) {
    const char *p = k->path;
    if (!strncmp(p, "materials.*.", 12)) {
        const char *name = "jelly"; /* corotated */
        if (k->only && strstr(k->only, "von_mises") && !strstr(k->only, "corotated")) name = "goo";
        if (k->only && !strcmp(k->only, "model=sand")) name = "sand";
        if (k->only && !strcmp(k->only, "model=snow")) name = "snow";
        if (k->only && !strcmp(k->only, "model=water")) name = "water";
        snprintf(out, len, "materials.%s.%s", name, p + 12);
    } else if (!strncmp(p, "objects[].", 10)) {
        const char *idx = "0"; /* the box */
        if (k->only && strstr(k->only, "shape=") && !strstr(k->only, "box"))
            idx = "2"; /* sphere|cylinder: the cylinder */
        if (k->only && !strcmp(k->only, "shape=sphere")) idx = "1";
        if ((k->only && strstr(k->only, "mesh")) || !strncmp(p, "objects[].fit", 13)) return -1; /* a mesh file */
        if (!strcmp(p, "objects[].shape")) return -1; /* another shape needs other keys: each shape's own are walked */
        snprintf(out, len, "objects.%s.%s", idx, p + 10);
    } else if (strchr(p, '*') || strstr(p, "[]")) {
        return -1;
    } else {
        snprintf(out, len, "%s", p);
    }
    return 0;
}

static void every_key_moves_the_hash(void) {
    char path[256];
    snprintf(path, sizeof path, "/tmp/kerf_test_sim_hash_%d.yaml", (int)getpid());
    FILE *f = fopen(path, "w");
    KT_CHECK(f != NULL, "%s", path);
    if (!f) return;
    fputs(base_shot, f);
    fclose(f);
    int sim = 0, other = 0, skipped = 0;
    for (int i = 0; i < kf_nkeys; i++) {
        const kf_keydef *k = &kf_keys[i];
        if (k->type == KT_SECTION || k->type == KT_DICT || k->type == KT_LIST) continue;
        char key[200], val[2][128], set[2][512], extra[64] = "";
        if (entry_path(k, key, sizeof key)) {
            skipped++;
            continue;
        }
        if (k->only && !strncmp(k->only, "integrator=", 11)) snprintf(extra, sizeof extra, "sim.integrator=implicit");
        if (k->only && !strcmp(k->only, "walls=separate")) snprintf(extra, sizeof extra, "domain.walls=separate");
        double v[2];
        switch (k->type) {
        case KT_NUM:
        case KT_INT:
            two_numbers(k, v);
            for (int j = 0; j < 2; j++) snprintf(val[j], sizeof val[j], "%.9g", v[j]);
            if (k->type == KT_INT && k->choices)
                choice(k->choices, 0, val[0], sizeof val[0]), choice(k->choices, 1, val[1], sizeof val[1]);
            if (!strcmp(k->path, "frames.end"))
                snprintf(val[0], sizeof val[0], "1020"), snprintf(val[1], sizeof val[1], "1030");
            break;
        case KT_BOOL: snprintf(val[0], sizeof val[0], "true"), snprintf(val[1], sizeof val[1], "false"); break;
        case KT_ENUM:
            choice(k->choices, 0, val[0], sizeof val[0]), choice(k->choices, 1, val[1], sizeof val[1]);
            /* the model on goo (which has its yield stress): von_mises against corotated */
            if (!strcmp(k->path, "materials.*.model"))
                snprintf(key, sizeof key, "materials.goo.model"), choice(k->choices, 2, val[1], sizeof val[1]);
            break;
        case KT_VEC3:
            snprintf(val[0], sizeof val[0], "[0.3, 0.2, 0.25]"), snprintf(val[1], sizeof val[1], "[0.25, 0.3, 0.2]");
            if (!strcmp(k->path, "domain.min"))
                snprintf(val[0], sizeof val[0], "[-0.1, 0, 0]"), snprintf(val[1], sizeof val[1], "[0, -0.1, 0]");
            if (!strcmp(k->path, "domain.max"))
                snprintf(val[0], sizeof val[0], "[1.1, 1, 1]"), snprintf(val[1], sizeof val[1], "[1, 1.1, 1]");
            if (strstr(k->path, "center"))
                snprintf(val[0], sizeof val[0], "[0.3, 0.31, 0.3]"),
                    snprintf(val[1], sizeof val[1], "[0.31, 0.3, 0.3]");
            if (!strcmp(k->path, "sim.gravity"))
                snprintf(val[0], sizeof val[0], "[0, -9, 0]"), snprintf(val[1], sizeof val[1], "[0, -10, 0]");
            break;
        case KT_PRESET: snprintf(val[0], sizeof val[0], "jello"), snprintf(val[1], sizeof val[1], "rubber"); break;
        case KT_REF: snprintf(val[0], sizeof val[0], "jelly"), snprintf(val[1], sizeof val[1], "goo"); break;
        default: skipped++; continue;
        }
        uint64_t h[2] = {0, 0};
        int ok = 1;
        for (int j = 0; j < 2; j++) {
            snprintf(set[j], sizeof set[j], "%s=%s", key, val[j]);
            const char *sets[2] = {set[j], extra};
            kf_diag d;
            kf_diag_init(&d);
            kf_shot *s = kf_shot_load(path, sets, extra[0] ? 2 : 1, NULL, NULL, &d);
            if (!s) {
                fprintf(stderr, "  %s: the shot with --set %s %s does not load:\n", k->path, set[j], extra);
                kf_diag_print(stderr, &d);
                ok = 0;
            } else {
                h[j] = kf_shot_sim_hash(s);
                kf_shot_free(s);
            }
            kf_diag_free(&d);
        }
        KT_CHECK(ok, "%s: both values load (%s, %s)", k->path, set[0], set[1]);
        if (!ok) continue;
        if (listed(k->path)) {
            other++;
            KT_CHECK(h[0] == h[1], "%s is not a simulation input, yet %s and %s give other cache hashes", k->path,
                     val[0], val[1]);
        } else {
            sim++;
            KT_CHECK(h[0] != h[1],
                     "%s changes the simulation, yet %s and %s give the same cache hash (add it to "
                     "kf_shot_sim_hash, or to not_sim here if it is not a simulation input)",
                     k->path, val[0], val[1]);
        }
    }
    printf("  %d simulation keys move the hash, %d other keys leave it; %d keys not walked (colliders, rigids, "
           "joints, keyframes, mesh objects)\n",
           sim, other, skipped);
    KT_CHECK(sim >= 50, "the walk reached the simulation keys (%d)", sim);
    remove(path);
}

int main(int argc, char **argv) {
    KT_RUN(every_key_moves_the_hash, argc, argv);
    return KT_EXIT();
}
