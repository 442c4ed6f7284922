/* guard_geom.h — the geometry the crossing guards share (guard.c for thin
 * bodies, solid_guard.c for solids): a point in a body's mesh frame, a
 * triangle's plane, and what a particle put back against a surface loses
 * of its velocity. Private to src/cpic. */
#ifndef KF_CPIC_GUARD_GEOM_H
#define KF_CPIC_GUARD_GEOM_H

#include <math.h>

#include "../core/mat3.h"
#include "../rigid/rigid.h"

/* world -> mesh frame of pose st */
static inline void kf_guard_to_mesh(const kf_rigid_state *st, const double x[3], double p[3]) {
    double q[3] = {x[0] - st->t[0], x[1] - st->t[1], x[2] - st->t[2]};
    kf_m3d_mtv(p, st->R, q);
}

/* the unit normal and the offset of mesh triangle t's plane, mesh frame */
static inline void kf_guard_tri_plane(const kf_rigid_body *b, int t, double n[3], double *off) {
    const double *a = &b->vert[3 * b->tri[3 * t]], *p = &b->vert[3 * b->tri[3 * t + 1]],
                 *q = &b->vert[3 * b->tri[3 * t + 2]];
    double e1[3] = {p[0] - a[0], p[1] - a[1], p[2] - a[2]}, e2[3] = {q[0] - a[0], q[1] - a[1], q[2] - a[2]};
    kf_v3d_cross(n, e1, e2);
    double nn = sqrt(kf_v3d_dot(n, n));
    for (int i = 0; i < 3; i++) n[i] = nn > 0 ? n[i] / nn : 0;
    *off = kf_v3d_dot(n, a);
}

/* the box of body b's vertices (mesh frame), and its largest |coordinate| */
static inline double kf_guard_mesh_box(const kf_rigid_body *b, double lo[3], double hi[3]) {
    double ext = 0;
    for (int a = 0; a < 3; a++) lo[a] = 1e300, hi[a] = -1e300;
    for (int v = 0; v < b->nvert; v++)
        for (int a = 0; a < 3; a++) {
            const double x = b->vert[3 * v + a];
            lo[a] = x < lo[a] ? x : lo[a];
            hi[a] = x > hi[a] ? x : hi[a];
            ext = fabs(x) > ext ? fabs(x) : ext;
        }
    return ext;
}

#endif
