/* mjcf_geoms.h — the MJCF mesh assets and geoms of one rigid body (see
 * mjcf_geoms.c for how concave meshes are cut into convex pieces). */
#ifndef KF_RIGID_MJCF_GEOMS_H
#define KF_RIGID_MJCF_GEOMS_H

#include "rigid.h"
#include "strbuf.h"

typedef struct kf_mj_text {
    kf_strbuf asset, body; /* <asset> contents, <worldbody> contents */
    int npiece;            /* mesh assets named so far (unique names) */
} kf_mj_text;

/* Geoms of body r inside the current <body> element, vertices shifted by
 * -shift (the MuJoCo body origin in the mesh frame): dynamic bodies collide
 * with everything, static and kinematic ones with dynamic ones only. */
void kf_mj_geoms(kf_mj_text *x, const kf_rigid_body *b, int r, const double shift[3]);

/* the diagonal of a body's vertex box */
double kf_mj_extent(const kf_rigid_body *b);

#endif
