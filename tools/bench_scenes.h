/* bench_scenes.h — the paper-scene table of kerf_bench (bench_scenes.c). */
#ifndef KF_TOOLS_BENCH_SCENES_H
#define KF_TOOLS_BENCH_SCENES_H

typedef struct bench_scenes_opts {
    int frames; /* frames per scene from the shot's start */
    /* > 0: only about this many substeps from the shot's start, the frame's
     * figures extrapolated from them (a paper-size frame takes minutes) */
    int substeps;
    int threads;          /* 0: the shot's setting */
    int paper_dx;         /* 1: Table 3's dx; 0: the dx matching Table 3's particle count */
    double scale;         /* multiplies the dx (2: an eighth of the particles) */
    const char *only;     /* comma-separated shot names, or NULL for all */
    const char *shot_dir; /* NULL: shots */
    const char *set[8];   /* extra shot overrides, "a.b=value", as kerf's --set */
    int nset;
    int hash; /* print each scene's state hash (bit-for-bit checks across builds and threads) */
    /* write each scene's particles after the frames to <dump>/<scene>.f32 (NULL: none): x, v and F of
     * every particle as float32 in id order, to measure how far two builds' results differ */
    const char *dump;
    int unfused; /* 1: G2P, stress and P2G as separate passes (the fused sweep's reference) */
} bench_scenes_opts;

/* Print the table; returns 0, or 1 if a scene failed (its row says why). */
int bench_scenes(const bench_scenes_opts *o);

#endif
