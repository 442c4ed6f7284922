/* euler.h — the one Euler-angle convention kerf uses everywhere (objects,
 * colliders, keys): degrees about x, then y, then z, fixed axes, so
 * R = Rz Ry Rx. Row-major. */
#ifndef KF_EULER_H
#define KF_EULER_H

void kf_euler_matrix(const double deg[3], double R[9]);

#endif
