/* model.h — the compiled model and the mutable state (private to the library).
 *
 * The model holds everything the step reads and never writes: settings,
 * compiled materials, colliders. The state holds everything it writes:
 * particles, the grid, time, and the snapshot used to retry a frame. */
#ifndef KF_MODEL_H
#define KF_MODEL_H

#include "../kerf.h"
#include "grid.h"
#include "material.h"
#include "particles.h"

#define KF_MAX_MATERIALS 64
#define KF_MAX_COLLIDERS 64

struct kf_model {
    kf_sim_def sim;
    int nthreads;
    int nmat;
    kf_material mat_def[KF_MAX_MATERIALS];
    kf_mat mat[KF_MAX_MATERIALS];
    int ncol;
    kf_collider col[KF_MAX_COLLIDERS];
    int any_plastic; /* some material needs the return-mapping pass */
};

struct kf_state {
    kf_particles p;
    kf_grid g;
    double time;       /* s */
    long substep;      /* substeps taken since creation */
    uint32_t next_id;  /* id of the next particle added */
    kf_particles snapshot; /* particles at the start of the interval being advanced */
    int tau_valid;     /* particle stress planes match F (set by kf_stress) */
    int snapshot_tau_valid;
};

/* MLS inertia-like tensor D_p = d I: d = Δx²/4 (quadratic), Δx²/3 (cubic) */
static inline double kf_model_dfactor(const kf_model *m) {
    double dx = m->sim.dx;
    return m->sim.kernel == KF_KERNEL_CUBIC ? dx * dx / 3.0 : dx * dx / 4.0;
}

/* the stages of a substep (transfer.c, grid_update.c) */
typedef struct kf_g2p_result {
    kf_trouble trouble; /* first (lowest id) particle in trouble */
    double max_cells;   /* max |v| Δt / Δx after the step */
} kf_g2p_result;

/* P2G; trouble (may be NULL) receives the first particle with non-finite stress */
void kf_p2g(const kf_model *m, kf_state *s, kf_real dt, kf_trouble *trouble);
void kf_grid_update(const kf_model *m, kf_state *s, kf_real dt);
void kf_g2p(const kf_model *m, kf_state *s, kf_real dt, kf_g2p_result *out);
/* return mapping (when project) and the stress of every particle's F */
void kf_stress(const kf_model *m, kf_state *s, int project);

/* collider pose and velocity at a time (collider.c) */
void kf_collider_at(const kf_collider *c, double t, double center[3], double velocity[3]);

#endif
