/* fuzz_shot.c — libFuzzer target: the shot parser and validator.
 * Each input is a shot file (YAML or JSON); kf_shot_load reads, validates and
 * resolves it as `kerf check` does. A shot that loads is also hashed and its
 * output template expanded, the other readers of a loaded shot. */
#include "fuzz_util.h"
#include "shot/shot.h"
#include "scene/build.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    char path[320];
    kf_fuzz_write("shot.yaml", data, size, path, sizeof path);
    kf_diag diag;
    kf_diag_init(&diag);
    kf_shot *shot = kf_shot_load(path, NULL, 0, NULL, NULL, &diag);
    /* every message must print (the diagnostics echo the source line) */
    FILE *null = fopen("/dev/null", "w");
    if (null) {
        kf_diag_print(null, &diag);
        fclose(null);
    }
    if (shot) {
        (void)kf_shot_sim_hash(shot);
        char out[512];
        (void)kf_shot_expand(shot->output_name, shot, shot->frame_start, out, sizeof out);
        (void)kf_shot_expand(shot->output_dir, shot, shot->frame_end, out, sizeof out);
        kf_shot_free(shot);
    }
    kf_diag_free(&diag);
    return 0;
}
