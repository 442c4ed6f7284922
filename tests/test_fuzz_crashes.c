/* test_fuzz_crashes.c — every input a fuzzer found crashing (tests/fuzz/
 * crashes, listed in its EXPECT file) goes through the real loader again and
 * must be refused with its message: the shot parser for .yaml and .json, the
 * mesh loader for .obj/.ply/.stl/.off, the checkpoint reader for .kfc (into
 * the model of tests/cli/cut.yaml, the fuzz target's model). Under the
 * sanitizer build (tools/test.sh) a crash comes back as a failed test. */
#include <stdlib.h>

#include "io/checkpoint.h"
#include "kt.h"
#include "mesh_util.h"
#include "scene/build.h"
#include "scene/mesh.h"
#include "shot/shot.h"

static int ends_with(const char *s, const char *ext) {
    size_t n = strlen(s), e = strlen(ext);
    return n >= e && !strcmp(s + n - e, ext);
}

/* the shot's diagnostics as one string */
static void shot_error(const char *path, char *err, size_t errlen, int *loaded) {
    kf_diag diag;
    kf_diag_init(&diag);
    kf_shot *shot = kf_shot_load(path, NULL, 0, NULL, NULL, &diag);
    *loaded = shot != NULL;
    FILE *m = fmemopen(err, errlen, "w");
    if (m) {
        kf_diag_print(m, &diag);
        fclose(m);
    }
    err[errlen - 1] = 0;
    kf_shot_free(shot);
    kf_diag_free(&diag);
}

static kf_scene cut;
static kf_shot *cut_shot; /* the scene points into it: both live to the end of main */
static int cut_built = 0;

static int checkpoint_error(const char *path, char *err, size_t errlen) {
    if (!cut_built) {
        kf_diag diag;
        kf_diag_init(&diag);
        kf_shot *shot = cut_shot = kf_shot_load(tu_repo_path("tests/cli/cut.yaml"), NULL, 0, NULL, NULL, &diag);
        KT_CHECK(shot && kf_scene_from_shot(shot, 1, &cut, NULL, &diag) == 0, "cut.yaml builds");
        kf_diag_free(&diag);
        cut_built = 1; /* the scene points into the shot: both live to the end */
    }
    size_t before = kf_state_count(cut.state);
    int rc = kf_checkpoint_read(path, cut.model, cut.state, NULL, err, errlen);
    KT_CHECK(kf_state_count(cut.state) == before, "%s: a refused checkpoint leaves the state alone", path);
    return rc;
}

static void every_crash_is_refused(void) {
    FILE *f = fopen(tu_repo_path("tests/fuzz/crashes/EXPECT"), "r");
    KT_CHECK(f != NULL, "tests/fuzz/crashes/EXPECT");
    if (!f) return;
    char line[512];
    int n = 0;
    while (fgets(line, sizeof line, f)) {
        line[strcspn(line, "\n")] = 0;
        if (!line[0] || line[0] == '#') continue;
        char *bar = strchr(line, '|');
        KT_CHECK(bar != NULL, "EXPECT line '%s' has no '|'", line);
        if (!bar) continue;
        *bar = 0;
        const char *file = line, *want = bar + 1;
        char rel[600], path[1024], err[4096] = "";
        snprintf(rel, sizeof rel, "tests/fuzz/crashes/%s", file);
        snprintf(path, sizeof path, "%s", tu_repo_path(rel));
        int refused;
        if (ends_with(file, ".yaml") || ends_with(file, ".json")) {
            int loaded;
            shot_error(path, err, sizeof err, &loaded);
            refused = !loaded;
        } else if (ends_with(file, ".kfc")) {
            refused = checkpoint_error(path, err, sizeof err) != 0;
        } else {
            kf_mesh m;
            refused = kf_mesh_load(path, &m, err, sizeof err) != 0;
            if (!refused) kf_mesh_free(&m);
        }
        KT_CHECK(refused, "%s: the crashing input is accepted", file);
        KT_CHECK(strstr(err, want) != NULL, "%s: message '%s' lacks '%s'", file, err, want);
        KT_CHECK(strstr(err, file) != NULL, "%s: message '%s' names the file", file, err);
        n++;
    }
    fclose(f);
    KT_CHECK(n >= 9, "EXPECT lists the crashes found so far (%d)", n);
    printf("%d crashing inputs refused with their messages\n", n);
}

int main(int argc, char **argv) {
    KT_RUN(every_crash_is_refused, argc, argv);
    if (cut_built) kf_scene_free(&cut);
    kf_shot_free(cut_shot);
    return KT_EXIT();
}
