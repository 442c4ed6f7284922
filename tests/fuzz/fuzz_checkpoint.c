/* fuzz_checkpoint.c — libFuzzer target: the checkpoint reader.
 * The model is built once from a small shot with a thin kinematic rigid
 * (tests/cli/cut.yaml, or $KERF_FUZZ_SHOT), the one tools/fuzz.sh runs to
 * make the seed checkpoint, so the seed's materials and rigid bodies match.
 * Each input is read twice: as it is, and with its last 8 bytes replaced by
 * the FNV-1a checksum of the bytes before them, so the mutations also reach
 * what the reader does after the checksum is found good. */
#include "fuzz_util.h"
#include "io/checkpoint.h"
#include "scene/build.h"

#ifndef KERF_SOURCE_DIR
#define KERF_SOURCE_DIR "."
#endif

static kf_scene scene;

int LLVMFuzzerInitialize(int *argc, char ***argv) {
    const char *shot_path = getenv("KERF_FUZZ_SHOT");
    if (!shot_path) shot_path = KERF_SOURCE_DIR "/tests/cli/cut.yaml";
    kf_diag diag;
    kf_diag_init(&diag);
    kf_shot *shot = kf_shot_load(shot_path, NULL, 0, NULL, NULL, &diag);
    if (!shot || kf_scene_from_shot(shot, 1, &scene, NULL, &diag)) {
        kf_diag_print(stderr, &diag);
        abort();
    }
    /* the scene keeps pointers into the shot (its name): the shot lives on */
    kf_diag_free(&diag);
    return 0;
}

static void read_one(const char *name, const uint8_t *data, size_t size) {
    char path[320], err[512];
    kf_fuzz_write(name, data, size, path, sizeof path);
    kf_checkpoint_info info;
    size_t before = kf_state_count(scene.state);
    if (kf_checkpoint_read(path, scene.model, scene.state, &info, err, sizeof err) == 0) {
        if (info.particles != kf_state_count(scene.state)) abort();
    } else {
        /* checkpoint.h: a message naming the path; a refused file leaves the state alone */
        if (!strstr(err, path)) {
            fprintf(stderr, "message without the path: %s\n", err);
            abort();
        }
        if (kf_state_count(scene.state) != before) abort();
    }
    (void)kf_checkpoint_peek(path, &info, err, sizeof err);
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    read_one("ckpt.kfc", data, size);
    if (size >= 8) {
        uint8_t *fixed = malloc(size);
        if (!fixed) return 0;
        memcpy(fixed, data, size);
        uint64_t h = 1469598103934665603ULL;
        for (size_t i = 0; i < size - 8; i++) h = (h ^ fixed[i]) * 1099511628211ULL;
        for (int k = 0; k < 8; k++) fixed[size - 8 + k] = (uint8_t)(h >> (8 * k)); /* little-endian */
        read_one("ckpt_fixed.kfc", fixed, size);
        free(fixed);
    }
    return 0;
}
