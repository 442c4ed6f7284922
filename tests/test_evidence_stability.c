/* test_evidence_stability.c — small instances of tools/evidence/stability.c
 *, through the same code (tests/problems/stress.h).
 *
 *   - the default CFL number sits safely below the blow-up threshold for
 *     every material preset: each is stable at 1.5x the default with the
 *     default kernel and both forces (measured thresholds, quadratic kernel:
 *     0.83 (water, classic) to 3.09 (snow, classic), 0.86–1.14 for the elastic
 *     and von Mises presets; see tools/evidence/REPORT.md);
 *   - the detector is not blind: at CFL 2.0 (above every measured
 *     threshold) the same jello block is reported unstable;
 *   - an injected NaN is caught by kf_step;
 *   - kf_advance recovers from a fault inside the interval (sim.cfl = 2.0,
 *     which blows up) by retrying at half the CFL number, and ends within
 *     1e-3 Δx of a run made directly at that CFL number .
 * Runs in a few seconds on 1 thread. */
#include "problems/stress.h"
#include "kt.h"

#define STEPS 120

static void default_cfl_below_threshold(void) {
    const double cfl = 1.5 * kf_default_sim_def().cfl;
    const char *const *names = kf_material_preset_names();
    for (int k = 0; names[k]; k++)
        for (int f = 0; f < 2; f++) {
            ev_stab r =
                ev_stability_run(KF_KERNEL_QUADRATIC, f ? KF_FORCE_CLASSIC : KF_FORCE_MLS, names[k], cfl, STEPS, 1);
            printf("  %-9s %-7s CFL %.2f: %s (largest energy ratio %.3f)%s%s\n", names[k], f ? "classic" : "mls", cfl,
                   r.stable ? "stable" : "UNSTABLE", r.energy_ratio, r.stable ? "" : ": ", r.why);
            KT_CHECK(r.stable, "%s (%s force) must be stable at 1.5x the default CFL %.2f: %s", names[k],
                     f ? "classic" : "mls", cfl, r.why);
        }
}

static void detector_sees_blow_up(void) {
    ev_stab r = ev_stability_run(KF_KERNEL_QUADRATIC, KF_FORCE_MLS, "jello", 2.0, STEPS, 1);
    printf("  jello mls CFL 2.00: %s (%s)\n", r.stable ? "stable" : "unstable", r.why);
    KT_CHECK(!r.stable, "a free jello block at CFL 2.0 must be detected as unstable");
}

static void nan_is_caught(void) {
    kf_model *m;
    kf_state *s = ev_recovery_state(0.4, 2, &m);
    kf_step(m, s, kf_stable_dt(m, s, 0.4), NULL, NULL);
    kf_particles_view p = kf_state_particles(s);
    p.v[0][p.n / 2] = (kf_real)NAN;
    kf_trouble tr;
    int rc = kf_step(m, s, 1e-4, NULL, &tr);
    printf("  NaN injected: kf_step rc %d, \"%s\", particle %u\n", rc, tr.what, tr.particle);
    KT_CHECK(rc == 1 && tr.found, "kf_step must report the injected NaN as trouble");
    KT_CHECK(strstr(tr.what, "NaN") != NULL, "the trouble must say NaN, got \"%s\"", tr.what);
    kf_state_destroy(s);
    kf_model_destroy(m);
}

static void advance_recovers(void) {
    ev_recovery r = ev_recovery_check(2.0, 0.1);
    printf("  kf_advance at cfl 2.0: rc %d, %d retries (cfl %.3f); reference rc %d, %d retries; max |dx|/dx %.3g, "
           "max |dv|/vmax %.3g, hashes %s\n",
           r.rc, r.retries, r.cfl_used, r.rc_ref, r.retries_ref, r.max_dx_rel, r.max_dv_rel,
           r.hash == r.hash_ref ? "identical" : "differ");
    KT_CHECK(r.rc == 0, "kf_advance must recover: %s", r.msg);
    KT_CHECK(r.retries >= 1, "the fault must have been hit (retries = %d)", r.retries);
    KT_CHECK(r.rc_ref == 0 && r.retries_ref == 0, "the reference run at the smaller CFL must need no retry");
    KT_NEAR(r.max_dx_rel, 0, 1e-3, "recovered run within 1e-3 dx of the run made at the smaller step");
    KT_NEAR(r.max_dv_rel, 0, 1e-3, "recovered velocities within 1e-3 of the largest speed");
}

int main(int argc, char **argv) {
    KT_RUN(default_cfl_below_threshold, argc, argv);
    KT_RUN(detector_sees_blow_up, argc, argv);
    KT_RUN(nan_is_caught, argc, argv);
    KT_RUN(advance_recovers, argc, argv);
    return KT_EXIT();
}
