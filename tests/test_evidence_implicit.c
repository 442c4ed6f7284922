/* test_evidence_implicit.c — one small instance of step sweep
 * (tests/problems/implicit_problem.h; the sweep itself runs from
 * kf_evid_implicit_sweep, never from ctest): the tumbling bar at E = 1e6
 * on a coarse grid (Δx = 0.04 m, 480 particles), 6 frames.
 *
 * - The reference converges: explicit against itself at half the step
 *   halves with each halving (first order), so errors against it mean
 *   something (on the clamped cantilever they do not: see
 *   implicit_results/implicit_sweep.md).
 * - The midpoint scheme at 20x the explicit step is far closer to the
 *   reference than explicit at its own default step (measured 0.099 mm
 *   against 0.48 mm).
 * - Backward Euler at 20x is off by gravity's first-order offset, ½ g Δt T
 *   after T (10.7 mm here; measured 10.3 mm). */
#include <math.h>
#include <stdlib.h>

#include "problems/implicit_problem.h"
#include "kt.h"

static void tumbling_bar(void) {
    g_dx = 0.04;
    g_tumble = 1;
    const double E = 1e6, dt = 20 * 0.4 * g_dx / wave_speed(E);
    double *ref = malloc(sizeof(double) * TRAJ_DOUBLES), *x = malloc(sizeof(double) * TRAJ_DOUBLES);
    double *half[3];
    size_t n = 0;
    run r = simulate(E, EXPLICIT, KF_PRECOND_MULTIGRID, 0.025, 0, ref, &n);
    KT_CHECK(r.ok, "reference runs");

    /* explicit at CFL 0.2, 0.1, 0.05: successive differences halve */
    const double cfl[3] = {0.2, 0.1, 0.05};
    for (int j = 0; j < 3; j++) {
        half[j] = malloc(sizeof(double) * TRAJ_DOUBLES);
        r = simulate(E, EXPLICIT, KF_PRECOND_MULTIGRID, cfl[j], 0, half[j], &n);
        KT_CHECK(r.ok, "explicit at CFL %g runs", cfl[j]);
    }
    const double d1 = traj_diff(half[0], half[1], n), d2 = traj_diff(half[1], half[2], n);
    printf("  explicit against itself at half the step: %.3g m (CFL 0.2 vs 0.1), %.3g m (0.1 vs 0.05): ratio %.2f\n",
           d1, d2, d1 / d2);
    KT_CHECK(d1 / d2 > 1.6 && d1 / d2 < 2.6, "first-order convergence: ratio %g", d1 / d2);

    run ex = simulate(E, EXPLICIT, KF_PRECOND_MULTIGRID, 0.4, 0, x, &n);
    compare(&ex, x, ref, n);
    run mp = simulate(E, MIDPOINT, KF_PRECOND_MULTIGRID, 0.4, dt, x, &n);
    compare(&mp, x, ref, n);
    run be = simulate(E, BACKWARD_EULER, KF_PRECOND_MULTIGRID, 0.4, dt, x, &n);
    compare(&be, x, ref, n);
    const double offset = 0.5 * 9.81 * dt * (FRAMES / FPS);
    printf("  error against explicit at CFL 0.025: explicit CFL 0.4 %.3g m; at 20x (dt %.3g s): midpoint %.3g m, "
           "backward Euler %.3g m (1/2 g dt T = %.3g m)\n",
           ex.rms, dt, mp.rms, be.rms, offset);
    KT_CHECK(ex.ok && mp.ok && be.ok, "every run finishes");
    KT_CHECK(mp.rms < 0.5 * ex.rms, "midpoint at 20x beats explicit at CFL 0.4: %g vs %g", mp.rms, ex.rms);
    KT_CHECK(fabs(be.rms - offset) < 0.25 * offset, "backward Euler is off by 1/2 g dt T: %g vs %g", be.rms, offset);
    for (int j = 0; j < 3; j++) free(half[j]);
    free(ref), free(x);
}

int main(int argc, char **argv) {
    KT_RUN(tumbling_bar, argc, argv);
    return KT_EXIT();
}
