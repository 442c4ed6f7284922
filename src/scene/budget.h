/* budget.h — what a shot will cost, estimated before anything is seeded.
 *
 * Particles from the objects' volumes (analytic, or a mesh's enclosed volume
 * placed as the sampler places it) times ppc / Δx³; memory from the
 * particle layout (state and its frame snapshot), the grid blocks they fill
 * and the seeding buffers; substeps per frame from the step rule (sim.dt_fixed,
 * or CFL on the stiffest material's wave speed plus the fastest initial
 * velocity, capped by sim.dt_max); hours from a particle-substep rate per core.
 * Seeding a shot that is too large already takes minutes and all the memory
 * (dx 0.002 on a 0.9 m box: 91M particles), so `check`, `info` and `run` ask
 * this first and refuse with the estimate in the message. */
#ifndef KF_BUDGET_H
#define KF_BUDGET_H

#include "../shot/shot.h"

/* a frame's substeps above this are refused (--force runs anyway): stiff
 * metal at dx 1 cm takes about 5e4; E = 1e30 or cfl = 1e-9 take 1e10 and more */
#define KF_BUDGET_SUBSTEPS_PER_FRAME 1e6
/* particle-substeps per second per core assumed for the hours (tiny shots on
 * two cores measure 3.7e6 in all, large ones more) */
#define KF_BUDGET_RATE_PER_CORE 2e6

typedef struct kf_budget {
    double particles;          /* about, all objects */
    double bytes;              /* about, peak while simulating */
    double memory;             /* this machine's (or its cgroup's) memory, bytes */
    double substeps_per_frame; /* at the start */
    double dt;                 /* the substep it comes from, s */
    int dt_from;               /* 0 CFL and wave speed, 1 sim.dt_fixed, 2 sim.dt_max */
    int stiffest;              /* the material setting the wave speed (-1: none, or implicit) */
    double wave_speed;         /* its wave speed, m/s */
    double hours;              /* simulating frames first..last */
    int cores;
} kf_budget;

/* Estimate; meshes are loaded (not seeded). Returns 0, or -1 with a message
 * (a mesh that cannot be read is left for the builder to report). */
int kf_budget_estimate(const kf_shot *shot, kf_budget *b, char *err, size_t errlen);

/* Report what is over the budget as errors at the value that causes it
 * (sim.dx for memory; sim.dt_fixed, sim.cfl or the stiffest material's E for
 * substeps). Returns how many were reported. */
int kf_budget_check(const kf_shot *shot, const kf_budget *b, kf_diag *diag);

#endif
