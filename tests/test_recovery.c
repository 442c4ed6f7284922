/* test_recovery.c — the NaN-recovery path with a fault injected inside an
 * interval (kf_model_set_fault_substep, a private test hook): the step catches it, kf_advance
 * restarts the interval at half the CFL number, and the result is the run
 * made directly at that smaller step, to the bit; the interval's start is
 * read back from its temporary file, or from memory when no file can be
 * made, with the same bits. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mpm/model.h"
#include "kt.h"
#include "scene_util.h"

static kf_state *jello_drop(const kf_model *m, int mat) {
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.3, 0.3, 0.3}, hi[3] = {0.5, 0.5, 0.5}, v[3] = {0.5, -1, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v, 2, 3);
    return s;
}

static void fault_is_retried_exactly(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 1.0 / 32;
    sd.walls = 1;
    const double frame = 1.0 / 24;
    int mat;
    /* A: a fault in the second frame */
    kf_sim_def sa = sd;
    kf_model *plain = tu_model(&sd, "jello", 0, -1, 0, &mat);
    kf_state *probe = jello_drop(plain, mat);
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    char msg[256];
    KT_CHECK(kf_advance(plain, probe, frame, &st, msg, sizeof msg) == 0, "%s", msg);
    long first = st.substeps;
    const long fault_substep = first + 3; /* the fourth substep of frame 2 */
    kf_model *faulty = tu_model(&sa, "jello", 0, -1, 0, &mat);
    kf_model_set_fault_substep(faulty, fault_substep);
    kf_state *a = jello_drop(faulty, mat);
    kf_step_stats sta;
    memset(&sta, 0, sizeof sta);
    for (int f = 0; f < 3; f++) KT_CHECK(kf_advance(faulty, a, frame, &sta, msg, sizeof msg) == 0, "%s", msg);
    KT_CHECK(sta.retries == 1, "the fault was caught and the frame retried once (%d retries)", sta.retries);
    /* B: the same frames, the second one made directly at half the CFL number */
    kf_sim_def sh = sd;
    sh.cfl = sd.cfl / 2;
    kf_model *half = tu_model(&sh, "jello", 0, -1, 0, &mat);
    kf_state *b = jello_drop(plain, mat);
    KT_CHECK(kf_advance(plain, b, frame, NULL, msg, sizeof msg) == 0, "%s", msg);
    KT_CHECK(kf_advance(half, b, frame, NULL, msg, sizeof msg) == 0, "%s", msg);
    KT_CHECK(kf_advance(plain, b, frame, NULL, msg, sizeof msg) == 0, "%s", msg);
    KT_CHECK(kf_state_hash(a) == kf_state_hash(b),
             "the recovered run equals the run made at the smaller step, bit for bit");
    kf_particles_view pa = kf_state_particles_read(a);
    int finite = 1;
    for (size_t i = 0; i < pa.n; i++) finite &= isfinite(pa.v[0][i]) && isfinite(pa.x[1][i]);
    KT_CHECK(finite, "no NaN survives the retry");
    KT_CHECK(a->spill && a->snapshot_in_file, "the interval's start went to a temporary file");
    printf("  fault at substep %ld: %d retry, %ld substeps in 3 frames, state hashes %s\n", fault_substep, sta.retries,
           sta.substeps, kf_state_hash(a) == kf_state_hash(b) ? "equal" : "differ");

    /* C: no temporary file can be made: the memory copy serves, same bits */
    const char *had = getenv("TMPDIR");
    char keep[1024];
    snprintf(keep, sizeof keep, "%s", had ? had : "");
    setenv("TMPDIR", "/nonexistent-kerf-test-dir", 1);
    kf_state *c = jello_drop(faulty, mat);
    kf_step_stats stc;
    memset(&stc, 0, sizeof stc);
    for (int f = 0; f < 3; f++) KT_CHECK(kf_advance(faulty, c, frame, &stc, msg, sizeof msg) == 0, "%s", msg);
    if (had) setenv("TMPDIR", keep, 1);
    else unsetenv("TMPDIR");
    KT_CHECK(c->spill_failed && !c->spill && !c->snapshot_in_file,
             "without a temporary directory the copy is in memory");
    KT_CHECK(stc.retries == 1, "the fault was retried once from memory (%d retries)", stc.retries);
    KT_CHECK(kf_state_hash(c) == kf_state_hash(a), "the retry from memory equals the retry from the file, bit for bit");
    kf_state_destroy(probe), kf_state_destroy(a), kf_state_destroy(b), kf_state_destroy(c);
    kf_model_destroy(plain), kf_model_destroy(faulty), kf_model_destroy(half);
}

int main(int argc, char **argv) {
    KT_RUN(fault_is_retried_exactly, argc, argv);
    return KT_EXIT();
}
