/* test_camera_keys.c — the keyed camera and the lights: interpolation
 * against its formulas, the shot keys (render.camera_keys, the three
 * lights) read through the key table, and the errors at their place. */
#include <stdio.h>
#include <stdlib.h>
#include <unistd.h>

#include "kt.h"
#include "render.h"
#include "shot/diag.h"
#include "shot/shot.h"

/* two keys: linear is the straight blend; smooth is the cubic Hermite with
 * zero end tangents, 3u^2 - 2u^3 of the way at u */
static void interpolation(void) {
    kf_camera_key k[3] = {
        {1001, {0, 1, 4}, {0, 0, 0}, 30}, {1011, {2, 1, 4}, {1, 0, 0}, 40}, {1021, {2, 3, 4}, {1, 0, 0}, 40}};
    kf_camera c = kf_camera_keyed(k, 2, 1003.5, 0);
    KT_NEAR(c.eye[0], 0.5, 1e-6, "linear: a quarter of the way");
    KT_NEAR(c.fov_deg, 32.5, 1e-5, "linear fov");
    c = kf_camera_keyed(k, 2, 1003.5, 1);
    KT_NEAR(c.eye[0], 2 * (3 * 0.0625 - 2 * 0.015625), 1e-6, "smooth: 3u^2 - 2u^3 at u = 1/4");
    KT_NEAR(c.target[0], 3 * 0.0625 - 2 * 0.015625, 1e-6, "smooth target");
    c = kf_camera_keyed(k, 3, 990, 1);
    KT_NEAR(c.eye[0], 0, 0, "held before the first key");
    c = kf_camera_keyed(k, 3, 1030, 1);
    KT_NEAR(c.eye[1], 3, 0, "held after the last key");
    /* through the middle key: Catmull-Rom tangent (central difference) */
    c = kf_camera_keyed(k, 3, 1011, 1);
    KT_NEAR(c.eye[0], 2, 1e-6, "passes through its keys");
    KT_NEAR(c.up[1], 1, 0, "up is +Y");
}

static kf_shot *load(const char *text, kf_diag *d) {
    char path[64];
    snprintf(path, sizeof path, "/tmp/kerf_test_camera_%ld.yaml", (long)getpid());
    FILE *f = fopen(path, "w");
    fputs(text, f);
    fclose(f);
    kf_diag_init(d);
    kf_shot *s = kf_shot_load(path, NULL, 0, NULL, NULL, d);
    remove(path);
    return s;
}

#define BASE                                                                                                           \
    "frames: {start: 1001, end: 1010}\n"                                                                               \
    "materials: {m: {preset: jello}}\n"                                                                                \
    "objects: [{shape: box, size: 0.2, center: [0.5, 0.3, 0.5], material: m}]\n"

static void shot_keys(void) {
    kf_diag d;
    kf_shot *s = load(BASE "render:\n"
                           "  camera_keys:\n"
                           "    - {frame: 1001, eye: [2, 1, 2], target: [0.5, 0.3, 0.5]}\n"
                           "    - {frame: 1010, eye: [1, 1, 1], target: [0.5, 0.2, 0.5], fov: 25}\n"
                           "  rim_light: {intensity: 0.8, color: [1, 0.5, 0.25]}\n",
                      &d);
    KT_CHECK(s != NULL, "a shot with camera keys loads (%d errors)", d.errors);
    if (s) {
        KT_CHECK(s->ncamera_keys == 2, "two keys (%d)", s->ncamera_keys);
        KT_NEAR(s->camera_keys[1].fov, 25, 0, "the second key's fov");
        KT_NEAR(s->camera_keys[0].fov, 0, 0, "no fov: render.fov is used");
        KT_NEAR(s->lights[2].intensity, 0.8, 0, "rim intensity as given");
        KT_NEAR(s->lights[2].color[2], 0.25, 0, "rim colour as given");
        KT_NEAR(s->lights[0].intensity, 1.35, 0, "the key light's default from the table");
        KT_CHECK(s->render_interp == 1, "smooth by default");
        kf_shot_free(s);
    }
    kf_diag_free(&d);
    /* frames out of order, an eye on its target, keys with render.eye: each at its line */
    s = load(BASE "render:\n"
                  "  eye: [2, 2, 2]\n"
                  "  camera_keys:\n"
                  "    - {frame: 1005, eye: [2, 1, 2], target: [0.5, 0.3, 0.5]}\n"
                  "    - {frame: 1003, eye: [1, 1, 1], target: [1, 1, 1]}\n",
             &d);
    KT_CHECK(s == NULL, "the bad camera keys are refused");
    int order = 0, nowhere = 0, both = 0;
    for (int i = 0; i < d.count; i++) {
        const kf_diag_entry *e = &d.entry[i];
        printf("  %d:%d: %s\n", e->line, e->col, e->message);
        order |=
            e->line == 8 && e->col == 15 && strstr(e->message, "must come after the previous key's frame 1005") != NULL;
        nowhere |= e->line == 8 && e->col == 26 && strstr(e->message, "the camera looks nowhere") != NULL;
        both |= e->line == 5 && e->col == 8 && strstr(e->message, "not both") != NULL;
    }
    KT_CHECK(order && nowhere && both, "order %d, looks nowhere %d, eye and keys %d (each at its line)", order, nowhere,
             both);
    kf_shot_free(s);
    kf_diag_free(&d);
}

int main(int argc, char **argv) {
    KT_RUN(interpolation, argc, argv);
    KT_RUN(shot_keys, argc, argv);
    return KT_EXIT();
}
