/* mjcf.h — the MuJoCo model (MJCF text) of a set of rigid bodies: one free
 * body per dynamic body with its origin at the centre of mass and axes of
 * the mesh frame, named "b<index>"; one body "b<index>_0" per static (a
 * mocap body) or kinematic body (a very heavy free body whose pose and
 * velocity the solver sets), origin and axes of the mesh frame; planes for
 * the domain walls; hinges from the joints. */
#ifndef KF_RIGID_MJCF_H
#define KF_RIGID_MJCF_H

#include <stddef.h>

#include "rigid.h"

/* how each joint was built */
typedef enum { KF_MJ_JOINT_TREE = 0, KF_MJ_JOINT_CONNECT } kf_mj_joint_kind;

/* The MJCF text (malloc'ed), or NULL with a message. joint_kind (njoints)
 * may be NULL. */
char *kf_rigid_mjcf(const kf_rigid_body *bodies, int nbodies, const kf_joint_def *joints, int njoints,
                    const double gravity[3], const double *walls, int *joint_kind, char *err, size_t errlen);

#endif
