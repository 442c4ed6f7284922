/* rigid.h — rigid bodies for CPIC (paper §5.1, §5.2.1, §5.6), private to the library.
 *
 * Three parts:
 *   - a compiled body (kf_rigid_body, in the model): its mesh, mass and
 *     inertia, and the rigid particles ("seeds") that cover its surface;
 *   - a body's motion state (kf_rigid_state, in the state): pose and velocity;
 *   - the rigid solver (kf_rigid_sim, in the state): advances every body by a
 *     substep from the impulses the material gave it. Static bodies stay put,
 *     kinematic bodies follow their keys, dynamic bodies integrate gravity and
 *     impulses and collide with each other and hinge on joints through MuJoCo.
 *
 * Frames: the mesh frame is the frame the def's vertices are given in. The
 * pose maps it to the world, x_world = R x_mesh + t. The velocity of the
 * body's material point at x is v + ω × (x - com), com the world centre of
 * mass (for static and kinematic bodies, the pivot). */
#ifndef KF_RIGID_H
#define KF_RIGID_H

#include <stddef.h>
#include <stdint.h>

#include <kerf/kerf.h>

typedef struct kf_rigid_body {
    kf_rigid_def def; /* as given; def.vertices / def.triangles point at vert / tri below */
    double *vert;     /* (nvert x 3) mesh frame, metres */
    int nvert;
    int *tri; /* (ntri x 3) */
    int ntri;
    double mass;       /* kg; dynamic bodies only (0 otherwise) */
    double com[3];     /* centre of mass in the mesh frame (dynamic), else the pivot def.center */
    double inertia[9]; /* about com, mesh-frame axes, kg·m², row-major; dynamic only */
    double reach;      /* farthest vertex from com, m: |ω| reach bounds the surface's spin speed */
    /* rigid particles on the surface, mesh frame (§5.2.1): every triangle holds
     * at least one, and every point of the surface is within spacing of one */
    size_t nseed;
    float *seed;       /* (nseed x 3) */
    int32_t *seed_tri; /* (nseed) the triangle each seed lies on */
    /* the triangles in an Embree scene (mesh frame): the crossing guard's
     * segment queries (bvh.h, src/cpic/guard.c) */
    struct kf_rigid_bvh *bvh; /* NULL when no triangle is guarded */
    int *guard_tri;           /* (nguard_tri) the mesh triangle of each of its primitives */
    int nguard_tri;
    uint8_t *tri_edge;      /* (ntri) 1: a narrow side of a closed thin body, not part of its sheet */
    double sheet_thickness; /* a closed thin body (a blade with two faces): its thickness, m; else 0 */
} kf_rigid_body;

typedef struct kf_rigid_state {
    double R[9], t[3]; /* x_world = R x_mesh + t */
    double com[3];     /* world centre of mass (static/kinematic: the pivot) */
    double v[3], w[3]; /* linear velocity of com, angular velocity (rad/s), world */
} kf_rigid_state;

/* Check the def, copy its mesh, compute mass properties (dynamic) and seed the
 * surface with spacing below dx. Returns 0, or -1 with a message. */
int kf_rigid_compile(kf_rigid_body *b, const kf_rigid_def *d, double dx, char *err, size_t errlen);
void kf_rigid_body_free(kf_rigid_body *b);

/* Seeds on triangles (mesh frame) so that every triangle holds at least one
 * and no point of any triangle is farther than `spacing` from a seed. Uses
 * Embree. Returns the count (arrays malloc'ed), or 0 with *seed == NULL on
 * failure. */
size_t kf_rigid_seed_surface(const double *vert, int nvert, const int *tri, int ntri, double spacing, float **seed,
                             int32_t **seed_tri);

/* The state at time t for static and kinematic bodies; the initial state
 * (time 0) for dynamic ones. */
void kf_rigid_state_at(const kf_rigid_body *b, double t, kf_rigid_state *st);

/* The velocity of body material at world point x. */
static inline void kf_rigid_point_velocity(const kf_rigid_state *st, const double x[3], double v[3]) {
    double r0 = x[0] - st->com[0], r1 = x[1] - st->com[1], r2 = x[2] - st->com[2];
    v[0] = st->v[0] + st->w[1] * r2 - st->w[2] * r1;
    v[1] = st->v[1] + st->w[2] * r0 - st->w[0] * r2;
    v[2] = st->v[2] + st->w[0] * r1 - st->w[1] * r0;
}

/* ---- the rigid solver ------------------------------------------------------ */

typedef struct kf_rigid_sim kf_rigid_sim;

/* gravity in m/s²; walls (may be NULL) = {min[3], max[3]} of a closed domain
 * the dynamic bodies also collide with. Returns NULL with a message. */
kf_rigid_sim *kf_rigid_sim_create(const kf_rigid_body *bodies, int nbodies, const kf_joint_def *joints, int njoints,
                                  const double gravity[3], const double *walls, char *err, size_t errlen);
void kf_rigid_sim_destroy(kf_rigid_sim *sim); /* NULL is fine */
/* A second solver for the same bodies (kf_state_clone), NULL on failure. */
kf_rigid_sim *kf_rigid_sim_clone(const kf_rigid_sim *sim);

/* Advance every body from time t to t + dt. impulse[r] = {J[3], L[3]}: the
 * linear impulse (N·s, world) and the angular impulse about the body's com
 * (N·m·s, world) the material gave body r during the substep. Dynamic
 * bodies: gravity, impulses, contacts with each other, static/kinematic
 * bodies and walls, joints. Kinematic bodies: st = their keyed state at t+dt. */
void kf_rigid_sim_step(kf_rigid_sim *sim, const kf_rigid_body *bodies, int nbodies, kf_rigid_state *st, double t,
                       double dt, const double (*impulse)[6]);

/* A motored joint's torque (N·m, turning body_a relative to body_b about
 * +axis) in the last substep, and the largest magnitude since the last
 * load or reset. Returns -1 for a joint without a motor. */
int kf_rigid_sim_motor_torque(const kf_rigid_sim *sim, int joint, double *now, double *peak);
void kf_rigid_sim_peak_reset(kf_rigid_sim *sim);

/* Everything the solver carries between substeps beyond kf_rigid_state (for
 * checkpoints and frame retries): bytes, save into buf, load from buf. */
size_t kf_rigid_sim_state_size(const kf_rigid_sim *sim);
void kf_rigid_sim_save(const kf_rigid_sim *sim, void *buf);
int kf_rigid_sim_load(kf_rigid_sim *sim, const void *buf, size_t size);

#endif
