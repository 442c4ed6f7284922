/* bench_stress.c — kerf_bench --only stress: ns per particle of the stress
 * pass (return mapping and Kirchhoff stress) for each solid model, through
 * the batch path the simulation runs (kf_mat_update_batch, SIMD across
 * particles) and through the per-particle scalar path (kf_mat_update, a
 * double SVD), on one thread.
 *
 * Each pass starts from the same deformation gradients: σ within a few
 * percent of 1 (about where snow clamps, where sand and von Mises
 * materials yield), random rotations, hardening states near 1. The batch
 * path sends particles outside its window to the scalar path, so the
 * figures include that fallback at its rate in this sample. Times are the
 * thread's CPU time, so a busy machine inflates them little. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../src/core/timer.h"
#include "../src/mpm/material.h"
#include "bench_stress.h"
#include "median.h"

enum { N = 1 << 18 };

static double cpu_ms(void) { return kf_thread_cpu_ms(); }

/* a rotation from a random unit quaternion */
static void rotation(double R[9], unsigned *seed) {
    double q[4], n = 0;
    for (int k = 0; k < 4; k++) q[k] = (double)rand_r(seed) / RAND_MAX - 0.5, n += q[k] * q[k];
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    double r[9] = {1 - 2 * (y * y + z * z), 2 * (x * y - w * z),     2 * (x * z + w * y),
                   2 * (x * y + w * z),     1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                   2 * (x * z - w * y),     2 * (y * z + w * x),     1 - 2 * (x * x + y * y)};
    memcpy(R, r, sizeof r);
}

int bench_stress(int runs) {
    static const char *presets[] = {"jello", "snow", "goo", "sand"};
    kf_real *F0[9], *F[9], *ps0[2], *ps[2], *tau[6];
    for (int k = 0; k < 9; k++) F0[k] = malloc(N * sizeof(kf_real)), F[k] = malloc(N * sizeof(kf_real));
    for (int k = 0; k < 2; k++) ps0[k] = malloc(N * sizeof(kf_real)), ps[k] = malloc(N * sizeof(kf_real));
    for (int k = 0; k < 6; k++) tau[k] = malloc(N * sizeof(kf_real));
    unsigned seed = 12345;
    for (size_t i = 0; i < N; i++) {
        double A[9], B[9], s[3];
        rotation(A, &seed), rotation(B, &seed);
        for (int a = 0; a < 3; a++) s[a] = 1 + 0.04 * ((double)rand_r(&seed) / RAND_MAX - 0.5);
        for (int r = 0; r < 3; r++)
            for (int c = 0; c < 3; c++) {
                double t = 0;
                for (int k = 0; k < 3; k++) t += A[3 * r + k] * s[k] * B[3 * c + k];
                F0[3 * r + c][i] = (kf_real)t;
            }
        ps0[0][i] = (kf_real)(1 + 0.02 * ((double)rand_r(&seed) / RAND_MAX - 0.5));
        ps0[1][i] = 0;
    }
    printf("stress pass, 1 thread, %d particles, median of %d: CPU ns per particle\n", N, runs);
    printf("%-8s %10s %10s %8s\n", "model", "batch", "scalar", "ratio");
    for (size_t m = 0; m < sizeof presets / sizeof presets[0]; m++) {
        kf_material mat;
        kf_material_preset(presets[m], &mat);
        kf_mat km;
        kf_mat_compile(&km, &mat);
        double tb[64], ts[64];
        if (runs > 64) runs = 64;
        for (int r = 0; r < runs; r++) {
            for (int path = 0; path < 2; path++) {
                for (int k = 0; k < 9; k++) memcpy(F[k], F0[k], N * sizeof(kf_real));
                for (int k = 0; k < 2; k++) memcpy(ps[k], ps0[k], N * sizeof(kf_real));
                double t0 = cpu_ms();
                if (path == 0) {
                    /* runs of 64, as the stress pass hands them over */
                    for (size_t lo = 0; lo < N; lo += 64) {
                        kf_real *t6[6];
                        for (int k = 0; k < 6; k++) t6[k] = tau[k] + lo;
                        kf_mat_update_batch(&km, 64, F, ps, 1, lo, t6);
                    }
                } else {
                    for (size_t i = 0; i < N; i++) {
                        kf_real Fi[9], pi[2] = {ps[0][i], ps[1][i]}, t[9];
                        for (int k = 0; k < 9; k++) Fi[k] = F[k][i];
                        kf_mat_update(&km, Fi, pi, km.plastic, t);
                        tau[0][i] = t[0];
                    }
                }
                (path ? ts : tb)[r] = (cpu_ms() - t0) * 1e6 / N;
            }
        }
        double b = kf_median(tb, runs), s = kf_median(ts, runs);
        printf("%-8s %10.1f %10.1f %8.2f\n", presets[m], b, s, s / b);
    }
    for (int k = 0; k < 9; k++) free(F0[k]), free(F[k]);
    for (int k = 0; k < 2; k++) free(ps0[k]), free(ps[k]);
    for (int k = 0; k < 6; k++) free(tau[k]);
    return 0;
}
