/* keys.h — a keyed motion at a time: the one key interpolation that
 * colliders and kinematic rigid bodies share.
 *
 * Each channel (the pivot's position, the three Euler angles in degrees,
 * the three scale factors) is interpolated on its own between the keys
 * around t, linearly or by a C1 cubic Hermite whose tangents are central
 * differences over the neighbouring keys (zero at the ends), and is
 * differentiated exactly. Before the first key and after the last the
 * motion is held. With no keys the pivot moves from `center` at the
 * constant `velocity`, unrotated and unscaled. The angular velocity follows
 * from the Euler angle rates (R = Rz Ry Rx):
 *     ω = a' Rz Ry e_x + b' Rz e_y + c' e_z. */
#ifndef KF_CORE_KEYS_H
#define KF_CORE_KEYS_H

#include <kerf/kerf.h>

/* the motion at a time: pivot, orientation, scale and their rates */
typedef struct kf_key_pose {
    double p[3];     /* pivot, m */
    double dp[3];    /* its velocity, m/s */
    double deg[3];   /* keyed rotation, degrees about x, y, z */
    double R[9];     /* Rz Ry Rx of deg, row-major */
    double omega[3]; /* angular velocity, rad/s (world) */
    double s[3];     /* scale factors (at least 1e-6: a smooth key never mirrors the shape) */
    double ds[3];    /* their rates, 1/s */
} kf_key_pose;

/* Pose and rates of the n keys at time t (seconds). center and velocity
 * give the motion when n is 0. */
void kf_keys_pose_at(const kf_key *keys, int n, kf_interp interp, const double center[3], const double velocity[3],
                     double t, kf_key_pose *pose);

#endif
