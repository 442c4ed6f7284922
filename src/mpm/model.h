/* model.h — the compiled model and the mutable state (private to the library).
 *
 * The model holds everything the step reads and never writes: settings,
 * compiled materials, colliders. The state holds everything it writes:
 * particles, the grid, time, and the snapshot used to retry a frame. */
#ifndef KF_MODEL_H
#define KF_MODEL_H

#include <stdio.h>

#include <kerf/kerf.h>
#include "grid.h"
#include "material.h"
#include "particles.h"
#include "../rigid/rigid.h"

struct kf_model {
    kf_sim_def sim;
    int nthreads;
    int nmat;
    kf_material mat_def[KF_MAX_MATERIALS];
    kf_mat mat[KF_MAX_MATERIALS];
    int ncol;
    kf_collider col[KF_MAX_COLLIDERS];
    int any_plastic; /* some material needs the return-mapping pass */
    int nrigid;
    kf_rigid_body rigid[KF_MAX_RIGIDS];
    int njoint;
    kf_joint_def joint[KF_MAX_JOINTS];
    /* testing the recovery path: at this substep count (kf_state's substeps
     * since creation) one particle's velocity becomes NaN, once per state; the
     * step must catch it and kf_advance retry the interval (0 = never) */
    long fault_substep;
    /* testing and measuring: G2P, stress and P2G always as separate passes
     * (never kf_g2p2g), the reference the fused substep must equal */
    int unfused;
};

/* polypic transfer: reals per particle id, 23 modes x 3, 3 α and the modes' energy (polypic.h) */
#define KF_POLY_MODES 23
#define KF_POLY_REALS (3 * KF_POLY_MODES + 4)

struct kf_state {
    kf_particles p;
    kf_grid g;
    double time;      /* s */
    long substep;     /* substeps taken since creation */
    uint32_t next_id; /* id of the next particle added */
    /* particles at the start of the interval being advanced (step.c): in an
     * unlinked temporary file, or in memory when no file can be written */
    FILE *spill;           /* NULL until the first interval */
    int spill_failed;      /* no temporary file could be made: the memory copy serves */
    int snapshot_in_file;  /* the current interval's start is in the file */
    kf_particles snapshot; /* the memory copy (empty while the file serves) */
    int tau_valid;         /* particle stress planes match F (set by kf_stress) */
    /* the model the stress was last made for (kf_stress, kf_g2p2g): where
     * it is not kept (KF_ZERO_TAU), the hash and checkpoints evaluate it */
    const struct kf_model *stress_model;
    /* > 0: the next kf_step's Δt, announced (kf_state_fuse_next, kf_advance)
     * with nothing editing the state in between; kf_step may then end with
     * the next substep's P2G (kf_g2p2g) */
    double fuse_next;
    /* the CFL rule's look-ahead (step.c), within one kf_advance interval:
     * fuse_cfl > 0 has kf_step pick the next substep's length itself once
     * the grid's velocities are known (guess_dt, landed in the fuse_left
     * still to go after this substep, 0: the interval ends), so the fused
     * sweep can scatter its P2G; kf_advance then steps min(guess_dt, the
     * CFL rule's Δt), so no substep is longer than the rule allows */
    double fuse_cfl, fuse_left, guess_dt;
    /* the CFL rule's particle figures made by the fused sweep (kf_cfl_scan
     * over every owner: the fastest |v|², each material's smallest state),
     * read once by kf_advance (which asks for them, scan_want) in place of
     * its own pass */
    int scan_want, scan_valid;
    double scan_v2;
    kf_real scan_state[KF_MAX_MATERIALS];
    /* the smallest states the last two substeps were chosen from (newest
     * first; cfl_hist of them valid): their trend predicts the next */
    int cfl_hist;
    kf_real cfl_state[2][KF_MAX_MATERIALS];
    long stiff_limited; /* particles the last kf_stress evaluated at the limited stiffness */
    int snapshot_tau_valid;
    /* rigid bodies (CPIC): motion state and the solver, created with the
     * state from the model's bodies; copies for retrying an interval */
    int nrigid;
    kf_rigid_state rigid[KF_MAX_RIGIDS];
    kf_rigid_sim *rsim;
    kf_rigid_state snapshot_rigid[KF_MAX_RIGIDS];
    void *snapshot_rsim; /* kf_rigid_sim_save bytes */
    size_t snapshot_rsim_size;
    double drive_cells;         /* the fastest rigid surface so far, cells per substep (step.c's speed bound) */
    int fault_done;             /* the testing fault (kf_model.fault_substep) has happened */
    struct kf_cpic *cpic;       /* CPIC scratch (grid colored distance field, particle distances), src/cpic */
    struct kf_contact *contact; /* contact between objects: per-field node slots (contact.h) */
    /* implicit midpoint: per particle (dv, dC) the G2P of the grid's
     * v_{n+1} − v_{n+½} adds after kf_g2p (12 floats a particle) */
    kf_real *mid_dv;
    size_t mid_cap;
    int mid_pending;
    /* polypic transfer: each particle's higher velocity modes, KF_POLY_REALS
     * per stable id (polypic.h), for ids below poly_cap; the copy for
     * retrying an interval */
    kf_real *poly, *snapshot_poly;
    size_t poly_cap, snapshot_poly_cap;
    /* one simulation over MPI ranks (src/dist): this rank's part; NULL on one rank */
    struct kf_dist *dist;
};

/* kf_advance's interval start (snapshot.c): save the particles, rigid
 * bodies and time; restore them for a retry. Both return 0 or -1 (out of
 * memory, or the temporary file could not be read back). */
int kf_snapshot_save(kf_state *s);
int kf_snapshot_restore(kf_state *s, double time0, long substep0);
/* the temporary file's size for n particles: the kf_real planes, mat, obj, colour, id */
static inline double kf_snapshot_bytes(size_t n) {
    return sizeof(size_t) + (double)n * (KF_PARTICLE_REAL_PLANES * sizeof(kf_real) + 2 + 2 + 4 + 4);
}

/* The fastest wave a fixed explicit step resolves, KF_CFL_STIFF Δx/Δt
 * (material.h: kf_mat_limit); 0 under the CFL rule or the implicit
 * integrator, which leave every material as it is. */
static inline double kf_model_c_limit(const kf_model *m) {
    if (!(m->sim.dt_fixed > 0) || m->sim.integrator == KF_INTEGRATOR_IMPLICIT) return 0;
    return KF_CFL_STIFF * m->sim.dx / m->sim.dt_fixed;
}

/* the particle arrays (KF_ZERO_*) this model never writes: colour without
 * rigid bodies (only CPIC writes it), ps when every material is fixed
 * corotated (the only model with no plastic state and no water J), and
 * then the stress planes too under the explicit integrator at the model's
 * own stiffness: a corotated particle's τ is a function of its F alone, bit
 * for bit whichever SIMD batch evaluates it (material_batch.c), so the
 * transfers evaluate it where they read it instead of keeping 24 bytes a
 * particle (the implicit solver reads the planes; a fixed step's limited
 * stiffness counts its particles in the stress pass). Across MPI ranks the
 * planes are kept (kf_state_zero_arrays). */
static inline unsigned kf_model_zero_arrays(const kf_model *m) {
    unsigned z = m->nrigid ? 0 : KF_ZERO_COLOUR;
    /* mat with one material; obj unless contact cuts pieces (it writes their
     * bits), while the scene puts every particle in object 0 (build.c) */
    if (m->nmat <= 1) z |= KF_ZERO_MAT;
    if (!m->sim.contact) z |= KF_ZERO_OBJ;
    for (int k = 0; k < m->nmat; k++)
        if (m->mat[k].model != KF_MAT_COROTATED) return z;
    z |= KF_ZERO_PS;
    if (m->sim.integrator == KF_INTEGRATOR_EXPLICIT && !(kf_model_c_limit(m) > 0)) z |= KF_ZERO_TAU;
    return z;
}

/* the same for a state: across MPI ranks the stress planes are kept (the
 * ranks' stress pass and halo write them), and obj (particles arriving from
 * another rank bring their objects) */
static inline unsigned kf_state_zero_arrays(const kf_model *m, const kf_state *s) {
    unsigned z = kf_model_zero_arrays(m);
    return s->dist ? z & ~(KF_ZERO_TAU | KF_ZERO_OBJ) : z;
}

/* kerf info's memory figure, bytes: n particles as they run (particles.h), rigid bodies' seeds,
 * the grid's blocks (grid.h), and what the process held before the scene
 * (program). kerf_bench --only memory prints it beside the measured peak. */
static inline double kf_memory_estimate(const kf_model *m, const kf_state *s, long blocks, double program) {
    const size_t n = s->p.n;
    /* rigid bodies' surface seeds: position 12 + triangle 4 each (rigid.h),
     * and CPIC's splat scratch for the largest body's: world position 24,
     * bin 4, order 4 (cpic.h), freed after the splat (the heap is trimmed
     * after an interval's first substep: step.c) */
    double seeds = 0, most = 0;
    for (int r = 0; r < m->nrigid; r++) {
        seeds += (double)m->rigid[r].nseed;
        if ((double)m->rigid[r].nseed > most) most = (double)m->rigid[r].nseed;
    }
    /* the arrays that stay untouched zeros once the shot runs (kf_advance) */
    const unsigned zero = kf_state_zero_arrays(m, s) & (s->p.zero | ~(KF_ZERO_OBJ | KF_ZERO_MAT));
    /* the binning's scratch and the splat's are not resident together (the
     * binning hands its pages back before the splat): the larger counts */
    const double bin = kf_particle_bytes_binning() * (double)n, splat = most * 32;
    return (kf_particle_bytes_running(m->nrigid > 0, zero) - kf_particle_bytes_binning()) * (double)n +
           (bin > splat ? bin : splat) + (double)blocks * kf_grid_bytes_per_block(m->nrigid > 0) + seeds * 16 + program;
}

/* The recovery path's test hook (kf_model.fault_substep): set after
 * kf_model_create, before the first step. */
static inline void kf_model_set_fault_substep(kf_model *m, long substep) { m->fault_substep = substep; }

/* The separate passes' reference (kf_model.unfused): set after
 * kf_model_create, before the first step. */
static inline void kf_model_set_unfused(kf_model *m, int unfused) { m->unfused = unfused; }

/* MLS inertia-like tensor D_p = d I: d = Δx²/4 (quadratic), Δx²/3 (cubic) */
static inline double kf_model_dfactor(const kf_model *m) {
    double dx = m->sim.dx;
    return m->sim.kernel == KF_KERNEL_CUBIC ? dx * dx / 3.0 : dx * dx / 4.0;
}

/* 1/Δx in kf_real, for every caller of kf_base_node: binning (step.c) and
 * the transfers (transfer.c) must use the same bits. 1/(float)Δx is not
 * (float)(1/Δx) for many Δx (0.016: 62.499996 vs 62.5), and a particle
 * within an ulp of a block face then had its stencil base one node outside
 * its owner block: P2G wrote and G2P read outside the node cache (stack
 * garbage, run-to-run and thread-count dependent results, NaN blow-ups). */
static inline kf_real kf_model_inv_dx(const kf_model *m) { return (kf_real)(1.0 / m->sim.dx); }

/* the stages of a substep (transfer.c, grid_update.c) */
typedef struct kf_g2p_result {
    kf_trouble trouble; /* first (lowest id) particle in trouble */
    double max_cells;   /* max |v| Δt / Δx after the step */
} kf_g2p_result;

/* P2G; trouble (may be NULL) receives the first particle with non-finite stress */
void kf_p2g(const kf_model *m, kf_state *s, kf_real dt, kf_trouble *trouble);
/* polypic: the mode table grown to every particle id (0, or -1 out of memory) */
int kf_poly_reserve(kf_state *s);
/* one owner block's P2G scatter into cache (edge kf_p2g_cache_edge, CD³
 * nodes; lohi: the base offsets its particles used, lo then hi per axis)
 * without touching the grid, and such a cache added into a 2x2x2 block
 * neighbourhood: P2G across ranks (src/dist). An owner on contact's field
 * path (kf_contact_owner) also fills fcache (KF_CONTACT_CACHE_ROWS x CD³,
 * contact.h: kf_contact_add_cache adds it); else fcache is not touched. */
int kf_p2g_cache_edge(const kf_model *m);
void kf_p2g_owner_cache(const kf_model *m, kf_state *s, size_t r, kf_real dt, kf_v4 *cache, kf_v4 *fcache, int lohi[6]);
void kf_p2g_add_cache(const kf_model *m, kf_grid *g, const int32_t nb[8], const kf_v4 *cache, const int lohi[6]);
/* implicit integration instead of kf_p2g + kf_grid_update (implicit/solve.c):
 * P2G of mass and momentum, backward Euler by Newton-Krylov on the grid
 * velocities, boundaries; the grid ends as kf_grid_update leaves it.
 * Returns 0, or 1 with trouble filled. Adds iteration counts to st. */
int kf_implicit_grid(const kf_model *m, kf_state *s, double dt, kf_step_stats *st, kf_trouble *trouble);
/* after kf_g2p: the implicit midpoint's velocity correction (nothing for
 * backward Euler or explicit) */
void kf_implicit_g2p_finish(const kf_model *m, kf_state *s);
void kf_grid_update(const kf_model *m, kf_state *s, kf_real dt);
/* the same inside a parallel region every thread of which calls it
 * (grid_update.c; passes: a shared word, zero on entry; in_turn: within
 * P2G's region, each block once its owners' caches are in, grid.h) */
void kf_grid_update_team(const kf_model *m, kf_state *s, kf_real dt, unsigned *passes, int in_turn);
/* one rank without FLIP (kf_p2g_joins_update): P2G and kf_grid_update in
 * one parallel region, no hand-off between; *p2g_end_ms: when the calling
 * thread ran out of owners (the frame log's P2G time ends there) */
int kf_p2g_joins_update(const kf_model *m, const kf_state *s);
void kf_p2g_update(const kf_model *m, kf_state *s, kf_real dt, kf_trouble *trouble, double *p2g_end_ms);
/* after the walls' projection: the nodes within a cell of a wall plane
 * that lies between nodes take a linear profile through zero on it, so
 * material stops at the plane (wall_ghost.c). The passes named in `passes`
 * (bit 2a: axis a's lower plane, 2a+1 its upper; the union of
 * kf_wall_ghost_passes over the blocks) run as worksharing loops of the
 * calling parallel region (every thread of it calls this), after a barrier
 * that follows the update of every node. */
void kf_wall_ghosts(const kf_model *m, kf_state *s, unsigned passes);
unsigned kf_wall_ghost_passes(const kf_model *m, const int32_t bc[3]);
void kf_g2p(const kf_model *m, kf_state *s, kf_real dt, kf_g2p_result *out);
/* The fused substep end (transfer.c): G2P, the stress pass and the next
 * substep's P2G in one sweep over the owner blocks, the P2G at the next
 * substep's Δt announced by the caller (next_dt), into grid.node_next. It
 * applies to the explicit integrator on one rank without FLIP or the
 * testing fault (kf_fuse_applies; with rigid bodies or contact fields, G2P
 * and stress only, since the next P2G needs the next substep's CDF and
 * fields): each node
 * then sums the same terms in the same order as the unfused P2G, so the
 * next substep is the same bit for bit whichever path made its grid.
 * Returns KF_FUSED_REACH when every particle's stencil still fits its
 * owner (binning's test, so the next substep's binning has nothing to do),
 * and KF_FUSED_SCATTER with it when the scatter is usable too (every
 * stress finite); without them the next substep bins and scatters as
 * usual. */
#define KF_FUSED_REACH 1
#define KF_FUSED_SCATTER 2
int kf_fuse_applies(const kf_model *m, const kf_state *s);
/* The CFL rule's scan of particles lo..hi (step.c): the fastest |v|² into
 * *v2max and each material's smallest state (water's J, snow's Jp, the
 * corotated det F; sand none) into state_min, both only lowered or raised,
 * so any split of the particles gives the same figures. One compiled
 * function for kf_advance's pass and the fused sweep: the same bits. With
 * states_only, the plastic states ps[0] alone (the fused sweep's G2P makes
 * the rest). */
void kf_cfl_scan(const kf_model *m, const kf_particles *p, size_t lo, size_t hi, double *v2max, kf_real *state_min,
                 int states_only);
int kf_g2p2g(const kf_model *m, kf_state *s, kf_real dt, double next_dt, kf_g2p_result *out);
/* return mapping (when project) and the stress of every particle's F
 * (nothing to do where the stress is not kept: KF_ZERO_TAU) */
void kf_stress(const kf_model *m, kf_state *s, int project);

/* The stress τ of particles [first, first + n) evaluated from F into out
 * (xx yy zz xy xz yz planes, out[k][0] for particle first), without the
 * return mapping: the planes' contents where the stress is not kept
 * (KF_ZERO_TAU), bit for bit. */
void kf_stress_eval(const kf_model *m, kf_particles *p, size_t first, int n, kf_real *const out[6]);

/* the same over n particles' planes, in runs of one material inside chunks
 * of 64 counted from the first (a particle's stress depends on its own F
 * and state alone, not on which particles share its SIMD batch). Returns
 * how many were evaluated at the limited stiffness. */
long kf_stress_span(const kf_model *m, kf_real *const F[9], kf_real *const ps[2], const uint16_t *mat,
                    kf_real *const tau[6], size_t n, int project);

/* collider pose and velocity at a time (collider.c) */
void kf_collider_at(const kf_collider *c, double t, double center[3], double velocity[3]);

#endif
