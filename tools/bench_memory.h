/* bench_memory.h — peak memory per particle of kerf_bench (bench_memory.c). */
#ifndef KF_TOOLS_BENCH_MEMORY_H
#define KF_TOOLS_BENCH_MEMORY_H

typedef struct bench_memory_opts {
    int substeps;     /* about this many substeps after seeding */
    int threads;      /* worker threads */
    double scale;     /* multiplies Δx (2: an eighth of the particles) */
    const char *only; /* "cube", "bunny_split", or NULL for both */
} bench_memory_opts;

/* Print the table; returns 0, or 1 if a scene failed (its row says why). */
int bench_memory(const bench_memory_opts *o);

#endif
