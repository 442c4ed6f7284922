/* test_checkpoint.c — checkpoints are lossless: resuming reproduces the
 * uninterrupted run bit for bit; damaged files are refused with a reason. */
#include <stdlib.h>
#include <unistd.h>

#include "io/checkpoint.h"
#include "kt.h"
#include "scene/builtin.h"

static char dir[256];

static void make_dir(void) {
    snprintf(dir, sizeof dir, "/tmp/kerf_test_ckpt_%d", (int)getpid());
    char cmd[300];
    snprintf(cmd, sizeof cmd, "mkdir -p %s", dir);
    KT_CHECK(system(cmd) == 0, "mkdir");
}

static int advance_frames(kf_scene *sc, int frames) {
    char msg[256];
    for (int f = 0; f < frames; f++)
        if (kf_advance(sc->model, sc->state, 1.0 / 24, NULL, msg, sizeof msg)) {
            fprintf(stderr, "%s\n", msg);
            return -1;
        }
    return 0;
}

/* run 3 frames straight; run 1, checkpoint, resume in a fresh state, run 2 */
static void resume_is_exact(void) {
    char err[256], path[320];
    snprintf(path, sizeof path, "%s/demo.0001.kfc", dir);
    kf_scene a, b;
    KT_CHECK(kf_scene_demo(&a, 20, err, sizeof err) == 0, "%s", err);
    KT_CHECK(advance_frames(&a, 1) == 0, "frame 1");
    KT_CHECK(kf_checkpoint_write(path, a.state, 1, 42, err, sizeof err) == 0, "%s", err);
    KT_CHECK(advance_frames(&a, 2) == 0, "frames 2-3");
    uint64_t straight = kf_state_hash(a.state);

    /* a fresh model and an empty state: everything comes from the file */
    KT_CHECK(kf_scene_demo(&b, 20, err, sizeof err) == 0, "%s", err);
    kf_state_destroy(b.state);
    b.state = kf_state_create(b.model);
    kf_checkpoint_info info;
    KT_CHECK(kf_checkpoint_read(path, b.model, b.state, &info, err, sizeof err) == 0, "%s", err);
    KT_CHECK(info.frame == 1 && info.inputs_hash == 42, "header round trip: frame %d hash %llu", info.frame,
             (unsigned long long)info.inputs_hash);
    KT_NEAR(kf_state_time(b.state), 1.0 / 24, 0, "time restored exactly");
    KT_CHECK(advance_frames(&b, 2) == 0, "resumed frames 2-3");
    uint64_t resumed = kf_state_hash(b.state);
    KT_CHECK(straight == resumed, "resumed run differs: %llx vs %llx", (unsigned long long)straight,
             (unsigned long long)resumed);
    KT_CHECK(access(path, F_OK) == 0, "checkpoint exists");
    char tmp[400];
    snprintf(tmp, sizeof tmp, "%s.tmp-%d", path, (int)getpid());
    KT_CHECK(access(tmp, F_OK) != 0, "no temporary left behind");
    kf_scene_free(&a);
    kf_scene_free(&b);
}

static void expect_refused(const char *path, const char *needle) {
    char err[512];
    kf_scene sc;
    kf_scene_demo(&sc, 12, err, sizeof err);
    size_t before = kf_state_count(sc.state);
    int rc = kf_checkpoint_read(path, sc.model, sc.state, NULL, err, sizeof err);
    KT_CHECK(rc == -1, "damaged checkpoint %s accepted", path);
    KT_CHECK(strstr(err, needle) != NULL, "message '%s' lacks '%s'", err, needle);
    KT_CHECK(strstr(err, path) != NULL, "message '%s' names the path", err);
    KT_CHECK(kf_state_count(sc.state) == before, "a refused checkpoint leaves the state alone");
    kf_scene_free(&sc);
}

/* flipped byte, truncation, garbage, and a missing file */
static void damage_is_refused(void) {
    char err[256], path[320], cmd[800];
    snprintf(path, sizeof path, "%s/good.kfc", dir);
    kf_scene sc;
    kf_scene_demo(&sc, 12, err, sizeof err);
    KT_CHECK(kf_checkpoint_write(path, sc.state, 7, 1, err, sizeof err) == 0, "%s", err);
    kf_scene_free(&sc);

    char flipped[340], cut[340], junk[340], missing[340];
    snprintf(flipped, sizeof flipped, "%s/flipped.kfc", dir);
    snprintf(cut, sizeof cut, "%s/cut.kfc", dir);
    snprintf(junk, sizeof junk, "%s/junk.kfc", dir);
    snprintf(missing, sizeof missing, "%s/missing.kfc", dir);
    snprintf(cmd, sizeof cmd,
             "cp %s %s && printf '\\377' | dd of=%s bs=1 seek=5000 conv=notrunc status=none && "
             "head -c 3000 %s > %s && echo 'hello world, not a checkpoint at all' > %s",
             path, flipped, flipped, path, cut, junk);
    KT_CHECK(system(cmd) == 0, "make damaged copies");
    expect_refused(flipped, "checksum mismatch");
    expect_refused(cut, "truncated");
    expect_refused(junk, "not a kerf checkpoint");
    expect_refused(missing, "cannot open");
}

int main(int argc, char **argv) {
    make_dir();
    KT_RUN(resume_is_exact, argc, argv);
    KT_RUN(damage_is_refused, argc, argv);
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd)) fprintf(stderr, "could not remove %s\n", dir);
    return KT_EXIT();
}
