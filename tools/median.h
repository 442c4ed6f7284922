/* median.h — the median of repeated timings, shared by the benchmark programs
 * (bench.c, bench_cpic.c, evidence/). Sorts v in place. */
#ifndef KF_TOOLS_MEDIAN_H
#define KF_TOOLS_MEDIAN_H

#include <stdlib.h>

static inline int kf_cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return x < y ? -1 : x > y;
}

static inline double kf_median(double *v, int n) {
    qsort(v, (size_t)n, sizeof *v, kf_cmp_double);
    return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

#endif
