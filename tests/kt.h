/* kt.h — the smallest test harness that states its tolerances.
 *
 * Each tests/test_*.c is one ctest executable. A case is a function listed
 * in main() via KT_RUN; checks print file:line, the values and the reason
 * for the tolerance, and count failures. The exit code is the failure count
 * (capped), so ctest sees any failure. Pass a case name as argv[1] to run
 * only that case. */
#ifndef KT_H
#define KT_H

#include <math.h>
#include <stdio.h>
#include <string.h>

static int kt_failures = 0;
static int kt_checks = 0;

#define KT_CHECK(cond, ...)                                                                                            \
    do {                                                                                                               \
        kt_checks++;                                                                                                   \
        if (!(cond)) {                                                                                                 \
            kt_failures++;                                                                                             \
            fprintf(stderr, "%s:%d: FAIL: %s: ", __FILE__, __LINE__, #cond);                                           \
            fprintf(stderr, __VA_ARGS__);                                                                              \
            fprintf(stderr, "\n");                                                                                     \
        }                                                                                                              \
    } while (0)

/* |a - b| <= tol, with the reason the tolerance is what it is. */
#define KT_NEAR(a, b, tol, why)                                                                                        \
    do {                                                                                                               \
        double kt_a_ = (double)(a), kt_b_ = (double)(b), kt_t_ = (double)(tol);                                        \
        kt_checks++;                                                                                                   \
        if (!(fabs(kt_a_ - kt_b_) <= kt_t_)) {                                                                         \
            kt_failures++;                                                                                             \
            fprintf(stderr, "%s:%d: FAIL: %s = %.17g, expected %s = %.17g within %.3g (%s)\n", __FILE__, __LINE__, #a, \
                    kt_a_, #b, kt_b_, kt_t_, why);                                                                     \
        }                                                                                                              \
    } while (0)

#define KT_RUN(fn, argc, argv)                                                                                         \
    do {                                                                                                               \
        if ((argc) < 2 || strcmp((argv)[1], #fn) == 0) {                                                               \
            int kt_before_ = kt_failures;                                                                              \
            fn();                                                                                                      \
            printf("%-40s %s\n", #fn, kt_failures == kt_before_ ? "ok" : "FAILED");                                    \
        }                                                                                                              \
    } while (0)

#define KT_EXIT() (printf("%d checks, %d failed\n", kt_checks, kt_failures), kt_failures > 100 ? 100 : kt_failures)

#endif
