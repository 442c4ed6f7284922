/* builtin.h — scenes built in code, shared by the command, the tests and the
 * benchmarks so all three exercise the same setups. */
#ifndef KF_BUILTIN_H
#define KF_BUILTIN_H

#include <kerf/kerf.h>

typedef struct kf_scene {
    kf_model *model;
    kf_state *state;
    const char *name;
    double fps;
    int frames;
} kf_scene;

/* The default shot until shot files land: a jello cube and a rubber ball
 * dropped onto a bed of sand in a closed box. res = cells across the box. */
int kf_scene_demo(kf_scene *sc, int res, char *err, size_t errlen);

/* The paper's Table 2 benchmark: an elastic cube (E = 100, ν = 0.3, ρ = 1) of
 * cells³ cells with 2x2x2 particles per cell in a grid of (cells * 1.25)³,
 * no gravity, fixed Δt = 1e-2. */
int kf_scene_bench_cube(kf_scene *sc, int cells, kf_force force, int threads, char *err, size_t errlen);

/* A fixed-corotated block of about n particles falling onto the floor. */
int kf_scene_falling_block(kf_scene *sc, long n, int threads, char *err, size_t errlen);

void kf_scene_free(kf_scene *sc);

#endif
