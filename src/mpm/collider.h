/* collider.h — where a kinematic collider is at a time, and what a grid node
 * sees of it: signed distance, outward normal, and the velocity of the
 * collider's own material point there.
 *
 * Motion (kerf.h, kf_key): the rest shape, centred on the pivot `center`, is
 * scaled along world axes, rotated, then moved so the pivot is at p(t):
 *     x(t) = p(t) + R(t) S(t) (x_rest - center),   x_rest - center = R0 X
 * where X is a point in the shape's own frame (a box's axes, the sdf grid's
 * frame) and R0 the rest orientation `rotate`. Each channel (p, the three
 * angles, the three scale factors) is interpolated on its own, linearly or
 * by a C1 cubic Hermite (kf_interp), and differentiated exactly, so the
 * velocity of a point of the collider is
 *     v(x) = p' + ω × r + R S' S⁻¹ Rᵀ r,   r = x - p,
 * with ω from the Euler angle rates (R = Rz Ry Rx):
 *     ω = a' Rz Ry e_x + b' Rz e_y + c' e_z.
 *
 * Distance: with B = R0ᵀ S⁻¹ Rᵀ the shape-frame point is X = B (x - p). The
 * shape gives f(X) and g = ∇f; the world gradient is Bᵀ g and the returned
 * φ = f |g| / |Bᵀ g| (exact for rigid motion and uniform scale, first order
 * for non-uniform scale), n = Bᵀ g / |Bᵀ g|.
 *
 * The grid update makes one kf_collider_frame per collider per substep and
 * then only evaluates nodes in the frame's world bounds. */
#ifndef KF_COLLIDER_H
#define KF_COLLIDER_H

#include <math.h>
#include <stdint.h>

#include "../core/euler.h"
#include "../core/keys.h"
#include <kerf/kerf.h>

/* the motion at a time (the shared key interpolation, core/keys.h) */
typedef kf_key_pose kf_collider_pose;

/* everything a node needs, computed once per collider per substep */
typedef struct kf_collider_frame {
    const kf_collider *c;
    kf_collider_pose pose;
    double B[9];         /* world → shape frame: X = B (x - p) */
    double L[9];         /* velocity gradient: v(x) = dp + L (x - p) */
    double nplane[3];    /* plane: unit normal in the shape frame */
    int uniform;         /* the scale is the same on every axis: φ = s f exactly */
    int bounded;         /* 1: φ <= 0 only inside [lo, hi] (not planes, not containers) */
    double lo[3], hi[3]; /* world box of the solid (bounded) */
} kf_collider_frame;

/* Pose and rates at time t (seconds). */
void kf_collider_pose_at(const kf_collider *c, double t, kf_collider_pose *pose);

/* The frame of c at time t. */
void kf_collider_frame_at(const kf_collider *c, double t, kf_collider_frame *f);

/* Signed distance at world point x (negative where material may not be:
 * inside a solid, outside a container) and, when n is not NULL, the unit
 * normal pointing to where material may be (without it, rigid and uniformly
 * scaled colliders skip the gradient: the cheap test for every node). */
double kf_collider_sdf(const kf_collider_frame *f, const double x[3], double n[3]);

/* Velocity of the collider's material point at world point x. */
void kf_collider_velocity(const kf_collider_frame *f, const double x[3], double v[3]);

/* Whether the block of nodes spanning [lo, hi] may hold a node with φ <= 0. */
/* Eq. 25: project v (relative to the boundary) for outward normal n: the
 * one rule for walls and colliders (grid_update.c, implicit/boundary.c) and
 * CPIC's rigid bodies (cpic_transfer.c) */
static inline void kf_project_velocity(double v[3], const double n[3], kf_boundary type, double mu) {
    if (type == KF_BOUNDARY_STICKY) {
        v[0] = v[1] = v[2] = 0;
        return;
    }
    double vn = v[0] * n[0] + v[1] * n[1] + v[2] * n[2];
    if (type == KF_BOUNDARY_SEPARATE && vn > 0) return; /* leaving: free */
    double vt[3] = {v[0] - vn * n[0], v[1] - vn * n[1], v[2] - vn * n[2]};
    if (type == KF_BOUNDARY_SLIP) {
        for (int a = 0; a < 3; a++) v[a] = vt[a];
        return;
    }
    /* separate, approaching: tangential velocity reduced by friction μ|vn| */
    double t = sqrt(vt[0] * vt[0] + vt[1] * vt[1] + vt[2] * vt[2]);
    double zeta = t + mu * vn; /* vn <= 0 */
    double scale = (zeta > 0 && t > 0) ? zeta / t : 0;
    for (int a = 0; a < 3; a++) v[a] = scale * vt[a];
}

/* The colliders (indices into frame) the nodes of the grid block with block
 * coordinate bc may be inside of; returns their count. */
int kf_colliders_near_block(const kf_collider_frame *frame, int ncol, const int32_t bc[3], double dx, int near[]);

int kf_collider_may_touch(const kf_collider_frame *f, const double lo[3], const double hi[3]);

/* The walls and the nearby colliders (near[0..nnear)) applied to one grid
 * node's velocity vd at x, as the grid update does (grid_update.c); the
 * contact fields use it on each of their velocities. */
void kf_grid_node_boundaries(const kf_model *m, const kf_collider_frame *frame, const int *near, int nnear,
                             const double x[3], double vd[3]);

#endif
