/* build.h — a validated shot becomes a model and its initial state.
 *
 * Materials and colliders go into the model in file order (so indices in the
 * shot are the model's), every object is seeded by the sampler, and problems
 * found only now (a mesh that loads broken or open) are reported at the
 * object's mesh: line in the shot, like every other shot error. */
#ifndef KF_BUILD_H
#define KF_BUILD_H

#include <stdint.h>

#include "../shot/shot.h"
#include "builtin.h"

typedef struct kf_build_stats {
    size_t particles_per_object[256]; /* first 256 objects */
    double seconds;                   /* seeding wall time */
} kf_build_stats;

/* Returns 0 with sc filled (sc->name points into shot), or -1 with every
 * problem in diag. threads: 0 = the shot's setting. */
int kf_scene_from_shot(const kf_shot *shot, int threads, kf_scene *sc, kf_build_stats *stats, kf_diag *diag);
/* The same, and with part != 0 under several MPI ranks: the state holds
 * only this rank's particles (every rank samples the whole scene, one
 * object at a time, and keeps its own: src/dist/dist.h). */
int kf_scene_from_shot_part(const kf_shot *shot, int threads, int part, kf_scene *sc, kf_build_stats *stats,
                            kf_diag *diag);

/* A hash of every input that changes the simulation: the shot's sim-relevant
 * values, the bytes of its mesh files and the kerf version (not outputs, not
 * render settings, not the frame sub-range). A checkpoint made under another
 * hash is neither resumed nor reused as a cache. */
uint64_t kf_shot_sim_hash(const kf_shot *shot);

#endif
