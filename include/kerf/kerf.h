/* kerf.h — the public API of the kerf MLS-MPM simulator.
 *
 * Three layers, as in MuJoCo: definitions the caller fills (zero or the
 * kf_default_*() value means default), a compiled read-only kf_model, and a
 * mutable kf_state that every step writes. The step never changes the model.
 *
 *     kf_sim_def sd = kf_default_sim_def();      sd.dx = 0.01;
 *     kf_model *m = kf_model_create(&sd, err, sizeof err);
 *     int jelly = kf_model_add_material(m, &mat, err, sizeof err);
 *     kf_state *s = kf_state_create(m);
 *     kf_state_fill_box(s, m, lo, hi, jelly, v0, 2, jitter_seed);
 *     kf_advance(m, s, 1.0 / 24, &report);
 */
#ifndef KERF_H
#define KERF_H

#include <stddef.h>
#include <stdint.h>

#include "core/real.h"

#ifdef __cplusplus
extern "C" {
#endif

#define KERF_VERSION "0.1.0"

/* ---- materials (SI units) ---------------------------------------------- */

typedef enum kf_material_model {
    KF_MAT_COROTATED = 0, /* fixed corotated elastic (jello, rubber) */
    KF_MAT_WATER,         /* weakly compressible fluid, p = κ(J^-γ - 1) */
    KF_MAT_VON_MISES,     /* StVK on Hencky strain + von Mises plasticity (goo, cheese, metal) */
    KF_MAT_SAND,          /* StVK on Hencky strain + Drucker-Prager (Klár 2016) */
    KF_MAT_SNOW,          /* fixed corotated + Stomakhin 2013 clamping and hardening */
    KF_MAT_MODEL_COUNT
} kf_material_model;

typedef struct kf_material {
    char name[32];
    kf_material_model model;
    double density;        /* ρ₀, kg/m³ */
    double E;              /* Young's modulus, Pa */
    double nu;             /* Poisson ratio, [0, 0.5) */
    double yield_stress;   /* von Mises uniaxial yield σ_Y, Pa */
    double friction_angle; /* sand: internal friction angle φ, degrees (used when hardening is off) */
    double cohesion;       /* sand: tensile cohesion as a Hencky strain offset, >= 0 */
    int hardening;         /* sand: 1 = φ_F = h0 + (h1 q - h3) e^{-h2 q}, q accumulated plastic strain */
    double h0, h1, h2, h3; /* sand hardening, degrees (h0, h1, h3) and 1 (h2) */
    int volume_correction; /* sand: 1 = Klár's volume correction of the tensile state */
    double bulk_modulus;   /* water: κ, Pa (rest bulk modulus is κγ) */
    double gamma;          /* water: γ, typically 7 */
    double viscosity;      /* water: dynamic viscosity μ, Pa·s (0 = inviscid) */
    double theta_c;        /* snow: critical compression */
    double theta_s;        /* snow: critical stretch */
    double xi;             /* snow: hardening coefficient */
} kf_material;

/* Fill *out from a named preset (jello, rubber, goo, cheese, metal, sand,
 * wet_sand, snow, water). Returns 0, or -1 for an unknown name. */
int kf_material_preset(const char *name, kf_material *out);
/* Names of all presets, NULL terminated. */
const char *const *kf_material_preset_names(void);
/* "" when the parameters are usable, else a message naming the bad one. */
const char *kf_material_check(const kf_material *m);

/* ---- boundaries and colliders ------------------------------------------ */

typedef enum kf_boundary { KF_BOUNDARY_STICKY = 0, KF_BOUNDARY_SLIP, KF_BOUNDARY_SEPARATE } kf_boundary;

typedef enum kf_shape { KF_SHAPE_PLANE = 0, KF_SHAPE_BOX, KF_SHAPE_SPHERE, KF_SHAPE_MESH } kf_shape;

/* How a keyed collider moves between keys (per channel: position, each
 * rotation angle and each scale factor). Both pass exactly through the keys
 * and hold the first and last key outside the keyed range.
 *   LINEAR: straight segments; the velocity is each segment's slope.
 *   SMOOTH: cubic Hermite; the tangent at an inner key is the central
 *           difference (p[i+1] - p[i-1]) / (t[i+1] - t[i-1]) (Catmull-Rom
 *           for uneven key spacing), zero at the first and last key, so the
 *           velocity is continuous everywhere (it eases in and out). */
typedef enum kf_interp { KF_INTERP_LINEAR = 0, KF_INTERP_SMOOTH } kf_interp;

#define KF_MAX_KEYS 64
/* A pose of a keyed collider. The collider's rest shape (centred on its
 * pivot, `center`) is scaled along world axes, then rotated, about the
 * pivot, then the pivot is put at `position`:
 *     x(t) = position(t) + R(t) S(t) (x_rest - center)
 * Rotation angles are interpolated per channel like a DCC's animation
 * curves, so a key of 720 degrees means two full turns. */
typedef struct kf_key {
    double time;        /* seconds */
    double position[3]; /* metres: where the pivot is */
    double rotate[3];   /* degrees about x, then y, then z (fixed axes: R = Rz Ry Rx) */
    double scale[3];    /* factors along x, y, z (0 means 1) */
} kf_key;

/* A signed distance field sampled on a regular grid (mesh colliders). Node
 * (i, j, k) sits at origin + spacing (i, j, k) in the collider's shape frame
 * (the rest shape relative to the pivot, before `rotate`), and holds
 * phi[(i * dims[1] + j) * dims[2] + k], metres, negative inside the solid.
 * Between nodes φ is trilinear; outside the grid it grows with the distance
 * to the grid's box, so the grid should pad the solid by a few cells. */
typedef struct kf_sdf_grid {
    double origin[3]; /* m */
    double spacing;   /* m */
    int dims[3];      /* nodes along x, y, z; each >= 2 */
    const float *phi; /* (dims[0] x dims[1] x dims[2]) */
} kf_sdf_grid;

/* A kinematic collider: its shape at rest, and its motion (static, constant
 * velocity, or keys). The pose and the velocity of the collider's own
 * material point at a grid node (linear + angular + scale rate) are
 * evaluated at each substep's time. */
typedef struct kf_collider {
    kf_shape shape;
    kf_boundary boundary;
    double friction;        /* Coulomb μ (separate boundaries) */
    double center[3];       /* the pivot at rest. plane: a point on it; box, sphere: centre; mesh: the
                               origin of the sdf's frame */
    double normal[3];       /* plane: the side material stays on */
    double half[3];         /* box half extents */
    double radius;          /* sphere */
    double rotate[3];       /* rest orientation of the shape, degrees XYZ (R0 = Rz Ry Rx): a box's axes, a
                               plane's normal, a mesh's sdf frame */
    const kf_sdf_grid *sdf; /* mesh: the distance field (kf_model_add_collider copies it) */
    double velocity[3];     /* constant velocity of the pivot when nkeys == 0 */
    kf_interp interp;       /* between keys */
    int nkeys;              /* >= 1: the pose follows the keys (one key: held there) */
    kf_key keys[KF_MAX_KEYS];
    int inside; /* box, sphere, mesh: 1 = material is kept inside (a container) */
} kf_collider;

/* ---- rigid bodies (CPIC, paper §5) ------------------------------------------
 *
 * A rigid body is a triangle mesh that material cannot pass through, however
 * thin: a cutter, a thin wall, a paddle, a floating block. Material on its two
 * sides moves independently (Compatible Particle-In-Cell). Static and
 * kinematic bodies move as told; dynamic bodies are pushed by the material
 * and push back (two-way coupling), and collide with each other. */
typedef enum kf_rigid_motion { KF_RIGID_STATIC = 0, KF_RIGID_KINEMATIC, KF_RIGID_DYNAMIC } kf_rigid_motion;

/* One grid node stores 2 bits per body (affinity, side) and the closest
 * body's index in one 32-bit word beside its distance (paper §5.2.3). */
#define KF_MAX_RIGIDS 14
/* the model's other fixed limits: materials, kinematic colliders, joints */
#define KF_MAX_MATERIALS 64
#define KF_MAX_COLLIDERS 64
#define KF_MAX_JOINTS 32

/* penalty and push left to kerf: sized from the substep, the grid and the material */
#define KF_RIGID_AUTO (-1.0)

typedef struct kf_rigid_def {
    char name[32];
    /* the surface in the mesh's own frame, metres; a closed solid is wound
     * counter-clockwise seen from outside. The model copies it. */
    const double *vertices; /* (nvertices x 3) */
    int nvertices;
    const int *triangles; /* (ntriangles x 3) */
    int ntriangles;
    int thin; /* 1 = a shell or cutter (may be open); 0 = a closed solid */
    kf_rigid_motion motion;
    /* pose: x_world = position(t) + R(t) (x_mesh - center), R = Rz Ry Rx of rotate (degrees) */
    double center[3];   /* the pivot, in the mesh frame */
    double position[3]; /* where the pivot is at time 0 */
    double rotate[3];   /* orientation at time 0, degrees */
    kf_interp interp;   /* kinematic: between keys */
    int nkeys;          /* kinematic: >= 1 keys (their scale is ignored: bodies are rigid) */
    kf_key keys[KF_MAX_KEYS];
    double velocity[3];         /* dynamic: initial, m/s; kinematic without keys: constant */
    double angular_velocity[3]; /* dynamic: initial; kinematic without keys: constant, rad/s, world */
    double density;             /* dynamic: kg/m³ for a solid, kg/m² for a thin shell */
    kf_boundary boundary;       /* how material meets it (Eq. 25) */
    double friction;            /* Coulomb μ for slip and separate */
    double penalty;             /* k, 1/s: a slightly penetrated particle is pushed back out at k x its depth,
                                   never faster than closing it within one substep (Eq. 22); 0 = off */
    double push;                /* c, m/s²: the collided velocity's push away from the surface (Eq. 27) */
} kf_rigid_def;

/* A hinge's motor: none (free), velocity (drives the turn rate toward
 * 2π frequency) or position (a servo tracking an angle that advances at
 * 2π frequency from `angle`). */
typedef enum kf_motor { KF_MOTOR_NONE = 0, KF_MOTOR_VELOCITY, KF_MOTOR_POSITION } kf_motor;

/* A hinge between two dynamic bodies, or a body and the world (-1): a
 * wheel on an axle, a hinged paddle, a robot's leg on its motor. The motor
 * turns body_a relative to body_b about +axis (right hand); its torque is
 * kp (target angle - angle) + kv (target rate - rate) for a position motor,
 * kv (target rate - rate) for a velocity motor, clipped to ±torque_limit. */
typedef struct kf_joint_def {
    int body_a, body_b; /* rigid indices, or -1 for the world */
    double anchor[3];   /* a point on the axis at time 0, world metres */
    double axis[3];     /* hinge axis, world */
    double damping;     /* N·m·s/rad */
    kf_motor motor;
    double frequency;    /* commanded turns per second (Hz); the sign is the direction */
    double angle;        /* position motor: target at time 0, degrees from the initial pose */
    double kp;           /* position gain, N·m/rad */
    double kv;           /* rate gain, N·m·s/rad */
    double torque_limit; /* N·m, > 0 with a motor */
} kf_joint_def;

/* Where a body is and how it moves, at the state's time:
 * x_world = R x_mesh + t, v(x) = v + ω × (x - com). */
typedef struct kf_rigid_pose {
    double R[9]; /* row-major */
    double t[3];
    double com[3];         /* centre of mass, world */
    double v[3], omega[3]; /* of the centre of mass; rad/s */
} kf_rigid_pose;

/* ---- simulation settings ----------------------------------------------- */

typedef enum kf_kernel { KF_KERNEL_QUADRATIC = 0, KF_KERNEL_CUBIC } kf_kernel;
typedef enum kf_force { KF_FORCE_MLS = 0, KF_FORCE_CLASSIC } kf_force;
/* APIC keeps each particle's affine velocity; PIC drops it; FLIP keeps
 * APIC's affine part and also the rest of the particle's velocity, which
 * APIC drops at every transfer: the particle's velocity is the grid's new
 * velocity plus flip_ratio times what the grid's old velocity missed of it
 * (mpm/transfer.c). POLYPIC keeps, beyond APIC's velocity and affine part,
 * every other velocity mode the quadratic kernel's 3x3x3 stencil can hold
 * (23 more, mpm/polypic.h), so one particle's G2P then P2G loses nothing. */
typedef enum kf_transfer { KF_TRANSFER_APIC = 0, KF_TRANSFER_PIC, KF_TRANSFER_FLIP, KF_TRANSFER_POLYPIC } kf_transfer;
/* How the grid velocities advance: explicit symplectic Euler, or
 * backward Euler solved by Newton-Krylov on the incremental potential. */
typedef enum kf_integrator { KF_INTEGRATOR_EXPLICIT = 0, KF_INTEGRATOR_IMPLICIT } kf_integrator;
/* The implicit step's time discretisation. Backward Euler: v_{n+1} solves
 * the incremental potential over Δt (first order, damps what the step does
 * not resolve). Implicit midpoint: the same solve over Δt/2 gives v_{n+½};
 * particles move and deform with it over Δt and leave at v_{n+1} = 2 v_{n+½}
 * − v_n (second order, no numerical damping: gravity's parabola exact). */
typedef enum kf_implicit_scheme { KF_SCHEME_BACKWARD_EULER = 0, KF_SCHEME_MIDPOINT } kf_implicit_scheme;
/* The implicit solve's CG preconditioner: a multigrid V-cycle, or Jacobi. */
typedef enum kf_precond { KF_PRECOND_MULTIGRID = 0, KF_PRECOND_JACOBI } kf_precond;

typedef struct kf_sim_def {
    double dx;         /* grid spacing, m */
    double cfl;        /* CFL number C in Δt = C Δx / (c + |v|max) */
    double dt_max;     /* upper bound on a substep, s (0 = none) */
    double dt_fixed;   /* > 0: every substep is exactly this (tests, benchmarks) */
    double gravity[3]; /* m/s² */
    kf_kernel kernel;
    kf_force force;
    kf_transfer transfer;
    int walls; /* 1 = the domain box is closed by walls */
    double domain_min[3], domain_max[3];
    kf_boundary wall_boundary;
    double wall_friction;
    int max_retries;           /* frame retries at half the CFL number on numerical trouble */
    int retry_fixed;           /* 1: under dt_fixed, a retry may halve the fixed step too (the log says so); 0: a
                                  fixed step is never changed, and trouble at it is reported as such */
    double j_min, j_max;       /* sane range of det F; outside it is numerical trouble */
    double max_cells_per_step; /* CFL violation: |v| Δt / Δx above this is trouble */
    int threads;               /* 0 = OpenMP default */
    /* contact between objects (mpm/contact.h): 1 = each shot object (kf_particles_view.obj) moves on its own
     * velocity field where objects share grid nodes, and fields touch only where their surfaces meet:
     * they slide with Coulomb friction contact_friction and pull apart freely. 0 = one shared field (objects
     * that come within a kernel of each other move together). Explicit integration only. */
    int contact;
    double contact_friction;
    /* implicit integration (integrator == KF_INTEGRATOR_IMPLICIT) */
    kf_integrator integrator;
    double newton_tol;  /* residual relative to the momentum scale (0 = default) */
    int newton_max;     /* Newton iterations per substep (0 = default) */
    double krylov_tol;  /* CG relative residual (0 = default) */
    int krylov_max;     /* CG iterations per Newton step (0 = default) */
    kf_precond precond; /* CG preconditioner */
    kf_implicit_scheme implicit_scheme;
    /* transfer == KF_TRANSFER_FLIP: the share of the particle's non-affine
     * velocity kept at each substep, in [0, 1] (1 = pure FLIP) */
    double flip_ratio;
} kf_sim_def;

kf_sim_def kf_default_sim_def(void);

/* ---- model, state, step -------------------------------------------------- */

typedef struct kf_model kf_model;
typedef struct kf_state kf_state;

/* err receives a message on failure (NULL returned / -1). */
kf_model *kf_model_create(const kf_sim_def *def, char *err, size_t errlen);
void kf_model_destroy(kf_model *m);
int kf_model_add_material(kf_model *m, const kf_material *mat, char *err, size_t errlen);
int kf_model_add_collider(kf_model *m, const kf_collider *c, char *err, size_t errlen);
const kf_sim_def *kf_model_sim(const kf_model *m);
/* Rigid bodies and joints (at most KF_MAX_RIGIDS bodies). Returns the index. */
int kf_model_add_rigid(kf_model *m, const kf_rigid_def *r, char *err, size_t errlen);
int kf_model_add_joint(kf_model *m, const kf_joint_def *j, char *err, size_t errlen);
int kf_model_rigid_count(const kf_model *m);
/* Mass (kg), and the rigid particles (seeds) the body carries. */
double kf_model_rigid_mass(const kf_model *m, int body);
size_t kf_model_rigid_seeds(const kf_model *m, int body);

kf_state *kf_state_create(const kf_model *m);
void kf_state_destroy(kf_state *s);
kf_state *kf_state_clone(const kf_state *s);
void kf_state_copy(kf_state *dst, const kf_state *src);

/* Append particles (arrays of n; v, F may be NULL for zero / identity).
 * Returns the index of the first, or -1 on allocation failure. */
long kf_state_add_particles(kf_state *s, const kf_model *m, size_t n, const double *x3, const double *v3,
                            const double *F9, int material, double volume);
/* Fill the box [lo, hi] with ppc_axis³ particles per cell (regular lattice, or
 * jittered when seed != 0) of the given material and velocity. */
long kf_state_fill_box(kf_state *s, const kf_model *m, const double lo[3], const double hi[3], int material,
                       const double v[3], int ppc_axis, uint32_t seed);
long kf_state_fill_sphere(kf_state *s, const kf_model *m, const double c[3], double r, int material, const double v[3],
                          int ppc_axis, uint32_t seed);

size_t kf_state_count(const kf_state *s);
double kf_state_time(const kf_state *s);

/* The particle arrays (SoA, length kf_state_count()), for reading and
 * writing: the state recomputes its cached stress before the next substep.
 * Order changes when particles are re-sorted; id[] is the stable index. */
#define KF_OBJECT_MASK 0x0FFFu /* kf_particles_view.obj: the object, without its piece */
typedef struct kf_particles_view {
    size_t n;
    kf_real *x[3], *v[3], *C[9], *F[9]; /* C and F row-major: C[3*i+j][p] */
    kf_real *mass, *vol0;
    kf_real *ps[2]; /* plastic state: Jp / J (water) / log-volume correction, q */
    uint16_t *mat;
    uint32_t *id;
    uint16_t *obj;    /* the shot object a particle came from (surfacing per object), 0 by default: the
                         low 12 bits (KF_OBJECT_MASK); the 4 above number the pieces a thin body cut it
                         into (sim.contact) */
    uint32_t *colour; /* CPIC: 2 bits (affinity, side) per rigid body; persists between substeps */
} kf_particles_view;
kf_particles_view kf_state_particles(kf_state *s);
/* The same arrays for reading only: the state's cached per-particle stress
 * stays valid (writing through this view is a bug). */
kf_particles_view kf_state_particles_read(const kf_state *s);

/* Per-particle fields for analysis (the PLY and .vdb points outputs):
 *   von_mises: the von Mises equivalent of the Cauchy stress, √(3/2 s:s) with s
 *              the deviator of σ = τ/J (Pa);
 *   J:         the volume ratio V/V0 (water: the tracked J; snow: det Fe · Jp;
 *              the others: det F of the elastic F they keep);
 *   plastic:   the plastic strain the model keeps: sand, the accumulated plastic
 *              strain q (tracked with hardening); snow, ln Jp (negative when
 *              compacted); 0 for corotated, water and von_mises (the von Mises
 *              return mapping keeps no history). */
typedef struct kf_particle_fields {
    double von_mises, J, plastic;
} kf_particle_fields;
kf_particle_fields kf_state_particle_fields(const kf_model *m, const kf_state *s, size_t i);

/* Per-stage timing of everything the step did since the last reset. */
typedef enum kf_stage {
    KF_STAGE_SORT = 0,
    KF_STAGE_P2G,
    KF_STAGE_GRID,
    KF_STAGE_G2P,
    KF_STAGE_STRESS, /* return mapping (plasticity) and the stress of the new F */
    KF_STAGE_CDF,    /* CPIC: rigid seeds, grid colored distance field, particle colour */
    KF_STAGE_RIGID,  /* rigid bodies: contacts, joints, advection */
    KF_STAGE_COUNT
} kf_stage;
const char *kf_stage_name(kf_stage s);

typedef struct kf_step_stats {
    /* implicit integration: totals since the last reset, and the last solve's residual */
    long newton_iterations, krylov_iterations;
    double newton_residual;
    double ms[KF_STAGE_COUNT]; /* wall milliseconds per stage */
    long substeps;
    long particle_steps;
    /* of them, in CPIC's narrow band: owner blocks near a body, whose transfers take CPIC's paths */
    long band_particle_steps;
    long active_blocks; /* grid blocks (4³ nodes) at the last substep */
    double max_cfl;     /* largest (c + |v|) Δt / Δx seen */
    double dt_min, dt_max;
    double max_cells_moved; /* fastest particle, cells per substep */
    /* thin boundaries (CPIC): particles whose path passed through a rigid
     * surface, caught and put back on their own side, and how far behind the
     * surface the deepest would have been, in cells */
    long thin_caught;
    double thin_deepest;
    int retries;         /* frames retried at a smaller CFL number (or, opted in, a halved fixed step) */
    double fixed_halved; /* > 0: the last retry ran the frame at this halved sim.dt_fixed, s */
    long warnings;       /* counted warnings (see message) */
    /* under a fixed step: the most particles in one substep whose state was
     * stiffer than the step resolves (compressed water, hardened snow),
     * evaluated at the stiffness it resolves instead */
    long stiff_limited;
    /* substeps whose P2G the substep before scattered, fused with its G2P
     * (kf_state_fuse_next) */
    long fused;
} kf_step_stats;

typedef struct kf_trouble {
    int found;
    char what[64];     /* "NaN velocity", "J out of range", "CFL violated", ... */
    uint32_t particle; /* stable particle id */
    int material;
    long substep;
    double value;
} kf_trouble;

/* One substep of length dt. Returns 0, or 1 on numerical trouble (filled). */
int kf_step(const kf_model *m, kf_state *s, double dt, kf_step_stats *stats, kf_trouble *trouble);

/* Announce the next kf_step's dt (seconds; 0: unknown, the default), when
 * nothing will edit the state before it but this library's own calls (a
 * writable particle view or added particles cancel the announcement). The
 * current kf_step may then end with the next one's P2G, fused with its G2P
 * and stress pass: the same bits, one sweep over the particles fewer.
 * kf_advance announces its own substeps whenever it knows the next one's
 * length (a fixed step, the sim.dt_max clamp, or under the CFL rule its
 * look-ahead from the grid's velocities). */
void kf_state_fuse_next(kf_state *s, double next_dt);

/* Advance by `duration` seconds in CFL-adaptive substeps. On trouble the
 * interval is restarted from its beginning at half the CFL number, up to
 * max_retries times. Returns 0, or 1 if it still fails (message in msg). */
int kf_advance(const kf_model *m, kf_state *s, double duration, kf_step_stats *stats, char *msg, size_t msglen);

/* The substep the CFL rule would choose now. */
double kf_stable_dt(const kf_model *m, const kf_state *s, double cfl);

/* Particles on the wrong side of a rigid body now: those whose colour
 * records one side of a thin body while the exact triangle closest to them
 * (within 1.5 cells, the point inside it) puts them on the other, and those
 * deeper inside a solid than its contact allows (min(dx / 2, 0.4 of its
 * thinnest part) behind its closest face); the deepest such, in cells, in
 * *deepest_cells (may be NULL). 0 is the promise. */
long kf_state_thin_audit(const kf_model *m, const kf_state *s, double *deepest_cells);

/* The pose of rigid body `body` at the state's time. */
kf_rigid_pose kf_state_rigid(const kf_state *s, int body);
/* A motored joint's torque (N·m, about its axis on body_a) at the last
 * substep in *now, and the largest magnitude since the state was last
 * loaded or kf_state_joint_peak_reset() in *peak. Returns 0, or -1 when the
 * joint has no motor. */
int kf_state_joint_torque(const kf_state *s, int joint, double *now, double *peak);
void kf_state_joint_peak_reset(kf_state *s);

/* Diagnostics. */
typedef struct kf_energy {
    double kinetic, elastic, gravity_potential;
    double momentum[3], angular_momentum[3], mass;
} kf_energy;
kf_energy kf_state_energy(const kf_model *m, const kf_state *s);
/* FNV-1a hash of every particle field, in stable id order. */
uint64_t kf_state_hash(const kf_state *s);
/* The kinetic energy the polypic transfer's higher velocity modes carry
 * beyond kf_energy's ½ m |v|²: Σ_p ½ m_p Σ_i w_ip |u_p(x_i)|², u_p the
 * particle's higher-mode field at its stencil's nodes (0 under other
 * transfers). J. */
double kf_state_mode_energy(const kf_model *m, const kf_state *s);

#ifdef __cplusplus
}
#endif
#endif
