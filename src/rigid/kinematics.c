/* kinematics.c — where static and kinematic bodies are at a time, and the
 * initial state of dynamic ones.
 *
 * The def's pose maps the mesh to the world as x = p(t) + R(t) (x_mesh - c),
 * c the pivot; so the state's translation is t = p - R c, and the velocity
 * reference point (com) of a static or kinematic body is the pivot p. */
#include <string.h>

#include "../core/euler.h"
#include "../core/keys.h"
#include "rigid.h"
#include "../core/mat3.h"

/* fill t and com from the pivot p, the pivot's mesh point c and R */
static void place(kf_rigid_state *st, const double p[3], const double c[3], const double com_mesh[3]) {
    double Rc[3], Rm[3];
    kf_m3d_mv(Rc, st->R, c);
    kf_m3d_mv(Rm, st->R, com_mesh);
    for (int a = 0; a < 3; a++) {
        st->t[a] = p[a] - Rc[a];
        st->com[a] = st->t[a] + Rm[a];
    }
}

/* keyed motion: the colliders' key interpolation, without scale */
static void keyed(const kf_rigid_def *d, double t, kf_rigid_state *st) {
    static const double zero[3] = {0, 0, 0};
    kf_key_pose pose;
    kf_keys_pose_at(d->keys, d->nkeys > KF_MAX_KEYS ? KF_MAX_KEYS : d->nkeys, d->interp, zero, zero, t, &pose);
    memcpy(st->R, pose.R, sizeof st->R);
    place(st, pose.p, d->center, d->center);
    memcpy(st->v, pose.dp, sizeof st->v);
    memcpy(st->w, pose.omega, sizeof st->w);
}

void kf_rigid_state_at(const kf_rigid_body *b, double t, kf_rigid_state *st) {
    const kf_rigid_def *d = &b->def;
    memset(st, 0, sizeof *st);
    if (d->motion == KF_RIGID_KINEMATIC && d->nkeys > 0) {
        keyed(d, t, st);
        return;
    }
    double R0[9];
    kf_euler_matrix(d->rotate, R0);
    if (d->motion == KF_RIGID_STATIC) {
        memcpy(st->R, R0, sizeof st->R);
        place(st, d->position, d->center, d->center);
        return;
    }
    if (d->motion == KF_RIGID_DYNAMIC) {
        /* time 0: the def's pose, velocity and angular velocity of the centre of mass */
        memcpy(st->R, R0, sizeof st->R);
        place(st, d->position, d->center, b->com);
        memcpy(st->v, d->velocity, sizeof st->v);
        memcpy(st->w, d->angular_velocity, sizeof st->w);
        return;
    }
    /* kinematic without keys: constant velocity of the pivot and constant
     * world angular velocity, R(t) = exp(t [ω]×) R0 */
    double wt[3] = {d->angular_velocity[0] * t, d->angular_velocity[1] * t, d->angular_velocity[2] * t}, Q[9];
    kf_m3d_rotvec(Q, wt);
    kf_m3d_mul(st->R, Q, R0);
    double p[3];
    for (int a = 0; a < 3; a++) p[a] = d->position[a] + d->velocity[a] * t;
    place(st, p, d->center, d->center);
    memcpy(st->v, d->velocity, sizeof st->v);
    memcpy(st->w, d->angular_velocity, sizeof st->w);
}
