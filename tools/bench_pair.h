/* bench_pair.h — MLS against classic MPM on the same cube, steps alternating
 * in one process (bench_pair.c). */
#ifndef KF_TOOLS_BENCH_PAIR_H
#define KF_TOOLS_BENCH_PAIR_H

/* Print the step time of the cube of `cells` cells with MLS and with the
 * classic force, their steps alternating (the order swapped each round)
 * over `rounds` rounds at `threads` threads, and the per-round ratio
 * classic / MLS (median and range). Returns 0, or 1 on failure. */
int bench_pair(int cells, int threads, int rounds);

#endif
