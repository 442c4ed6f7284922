/* bench_stress.h — the stress pass per material model (bench_stress.c). */
#ifndef KF_TOOLS_BENCH_STRESS_H
#define KF_TOOLS_BENCH_STRESS_H

/* Print ns per particle of the batch stress path and of the per-particle
 * scalar path for each plastic or elastic solid model, one thread; runs
 * is the number of timed passes (median). Returns 0. */
int bench_stress(int runs);

#endif
