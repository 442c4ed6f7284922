/* bench_child.h — one measurement in a child process of its own, so that its
 * peak resident memory is its own (kerf_bench's scene table and its memory
 * figures). */
#ifndef KF_BENCH_CHILD_H
#define KF_BENCH_CHILD_H

#include <stddef.h>

/* what the child runs: fills result (size bytes, zeroed before) from ctx */
typedef void (*bench_child_fn)(const void *ctx, void *result);

/* Runs fn(ctx, result) in a child process and copies its result back
 * through a pipe. Returns 0, or -1 when no pipe could be made or the child
 * died before its result came back (result zeroed, *status its wait status
 * or -1 without a pipe). */
int bench_in_child(bench_child_fn fn, const void *ctx, void *result, size_t size, int *status);

/* this process's peak resident memory so far, MB */
double bench_peak_mb(void);

#endif
