/* test_checkpoint.c — checkpoints are lossless: resuming reproduces the
 * uninterrupted run bit for bit; damaged files are refused with a reason. */
#include <stdlib.h>
#include <unistd.h>

#include "io/checkpoint.h"
#include "mpm/model.h"
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

/* run 3 frames straight; run 1, checkpoint, resume in a fresh state, run 2
 * (under the given transfer: polypic's per-particle modes are state too) */
static void resume_exact_under(kf_transfer transfer, const char *name) {
    char err[256], path[320];
    snprintf(path, sizeof path, "%s/demo_%s.0001.kfc", dir, name);
    kf_scene a, b;
    KT_CHECK(kf_scene_demo(&a, 20, err, sizeof err) == 0, "%s", err);
    a.model->sim.transfer = transfer;
    KT_CHECK(advance_frames(&a, 1) == 0, "frame 1");
    KT_CHECK(kf_checkpoint_write(path, a.state, 1, 42, err, sizeof err) == 0, "%s", err);
    KT_CHECK(advance_frames(&a, 2) == 0, "frames 2-3");
    uint64_t straight = kf_state_hash(a.state);

    /* a fresh model and an empty state: everything comes from the file */
    KT_CHECK(kf_scene_demo(&b, 20, err, sizeof err) == 0, "%s", err);
    b.model->sim.transfer = transfer;
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

static void resume_is_exact(void) { resume_exact_under(KF_TRANSFER_APIC, "apic"); }
static void resume_is_exact_polypic(void) { resume_exact_under(KF_TRANSFER_POLYPIC, "polypic"); }

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
    char err[256], path[320], cmd[2400]; /* room for the five paths the damaging command names */
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

/* ---- forged and damaged headers: refused before anything is
 * allocated from them, each with the true reason ---------------------------- */

static unsigned char *slurp(const char *path, size_t *n) {
    FILE *f = fopen(path, "rb");
    if (!f) return NULL;
    fseek(f, 0, SEEK_END);
    *n = (size_t)ftell(f);
    fseek(f, 0, SEEK_SET);
    unsigned char *b = malloc(*n);
    if (b && fread(b, 1, *n, f) != *n) free(b), b = NULL;
    fclose(f);
    return b;
}

/* a copy of `good` with `len` bytes at `off` replaced; with `resum` the
 * trailing FNV-1a checksum is recomputed (a forgery, not damage) */
static void forge(const char *good, const char *out, size_t off, const void *bytes, size_t len, int resum) {
    size_t n;
    unsigned char *b = slurp(good, &n);
    KT_CHECK(b && n > off + len + 8, "read %s", good);
    if (!b) return;
    memcpy(b + off, bytes, len);
    if (resum) {
        uint64_t h = 1469598103934665603ULL;
        for (size_t i = 0; i + 8 < n; i++) h = (h ^ b[i]) * 1099511628211ULL;
        memcpy(b + n - 8, &h, 8);
    }
    FILE *f = fopen(out, "wb");
    KT_CHECK(f && fwrite(b, 1, n, f) == n, "write %s", out);
    if (f) fclose(f);
    free(b);
}

/* the exact message, and that the header-only peek agrees where it reads */
static void expect_message(const char *path, const char *exact, int peek_too) {
    char err[1024];
    expect_refused(path, exact);
    kf_scene sc;
    kf_scene_demo(&sc, 12, err, sizeof err);
    kf_checkpoint_read(path, sc.model, sc.state, NULL, err, sizeof err);
    KT_CHECK(strcmp(err, exact) == 0, "read says\n  '%s'\nexpected\n  '%s'", err, exact);
    kf_scene_free(&sc);
    if (!peek_too) return;
    kf_checkpoint_info info;
    KT_CHECK(kf_checkpoint_peek(path, &info, err, sizeof err) == -1, "peek refuses %s", path);
    KT_CHECK(strcmp(err, exact) == 0, "peek says\n  '%s'\nexpected\n  '%s'", err, exact);
}

static void forged_headers_are_refused(void) {
    char err[256], good[320], p[8][340], want[1024];
    /* header: magic 0, version 8, real size 12, particles 16, ..., rigid bodies 64, solver bytes 72 */
    snprintf(good, sizeof good, "%s/forge_good.kfc", dir);
    kf_scene sc;
    kf_scene_demo(&sc, 12, err, sizeof err);
    size_t n = kf_state_count(sc.state);
    KT_CHECK(kf_checkpoint_write(good, sc.state, 7, 1, err, sizeof err) == 0, "%s", err);
    kf_scene_free(&sc);
    size_t size;
    free(slurp(good, &size));
    for (int i = 0; i < 8; i++) snprintf(p[i], sizeof p[i], "%s/forge%d.kfc", dir, i);

    /* the audit's case: particle count (offset 16) = 0x7fffffffffffffff; it
     * overflowed the heap (ASan: WRITE of size 4016) and the release build
     * blamed "different shot settings" */
    const uint64_t huge = 0x7fffffffffffffffULL;
    forge(good, p[0], 16, &huge, 8, 0);
    snprintf(want, sizeof want,
             "%s: checkpoint checksum mismatch (file damaged: its header claims 9223372036854775807 particles, which "
             "%zu bytes do not hold)",
             p[0], size);
    expect_message(p[0], want, 1);

    /* the same count with the checksum forged to match: the length still refuses it */
    forge(good, p[1], 16, &huge, 8, 1);
    snprintf(want, sizeof want,
             "%s: checkpoint header is damaged: 9223372036854775807 particles, 0 rigid bodies and 0 solver bytes would "
             "take more than 2^64 bytes, the file has %zu",
             p[1], size);
    expect_message(p[1], want, 1);
    /* one particle more than the file holds, checksum forged: no read past the end */
    uint64_t one_more = (uint64_t)n + 1;
    forge(good, p[2], 16, &one_more, 8, 1);
    size_t per = (size - 80 - 8) / n; /* an 80-byte header and an 8-byte checksum around the particles */
    snprintf(want, sizeof want,
             "%s: checkpoint header is damaged: %zu particles, 0 rigid bodies and 0 solver bytes need %zu bytes, the "
             "file has %zu",
             p[2], n + 1, size + per, size);
    expect_message(p[2], want, 1);
    /* a damaged version field (offset 8) said "written by a single-precision
     * build, this is single precision"; it is damage */
    const unsigned char junk = 0x5a;
    forge(good, p[3], 8, &junk, 1, 0);
    snprintf(want, sizeof want, "%s: checkpoint checksum mismatch (file damaged)", p[3]);
    expect_message(p[3], want, 1);
    /* a damaged precision field (offset 12) likewise */
    forge(good, p[4], 12, &junk, 1, 0);
    snprintf(want, sizeof want, "%s: checkpoint checksum mismatch (file damaged)", p[4]);
    expect_message(p[4], want, 1);
    /* an intact file of another format version is named as such */
    const uint32_t v3 = 3;
    forge(good, p[5], 8, &v3, 4, 1);
    snprintf(want, sizeof want, "%s: checkpoint format version 3, this kerf reads version %d", p[5],
             KF_CHECKPOINT_VERSION);
    expect_message(p[5], want, 1);
    /* an intact file of the other precision likewise */
    const uint32_t other = sizeof(kf_real) == 8 ? 4 : 8;
    forge(good, p[6], 12, &other, 4, 1);
    snprintf(want, sizeof want, "%s: checkpoint was written by a %s-precision build, this is %s precision", p[6],
             other == 8 ? "double" : "single", other == 8 ? "single" : "double");
    expect_message(p[6], want, 1);
    /* a rigid body count over the limit with a forged checksum */
    const uint32_t many = 1000;
    forge(good, p[7], 64, &many, 4, 1); /* nrigid */
    snprintf(want, sizeof want, "%s: checkpoint header is damaged (1000 rigid bodies, at most %d)", p[7],
             KF_MAX_RIGIDS);
    expect_message(p[7], want, 1);
}

int main(int argc, char **argv) {
    make_dir();
    KT_RUN(resume_is_exact, argc, argv);
    KT_RUN(resume_is_exact_polypic, argc, argv);
    KT_RUN(damage_is_refused, argc, argv);
    KT_RUN(forged_headers_are_refused, argc, argv);
    char cmd[300];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    if (system(cmd)) fprintf(stderr, "could not remove %s\n", dir);
    return KT_EXIT();
}
