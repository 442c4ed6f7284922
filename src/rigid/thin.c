/* thin.c — one side for the two faces of a closed thin body.
 *
 * CPIC tells the sides of a surface apart by its normals (§5.2.2: a node
 * behind the closest primitive is on the negative side). A cutter modelled as
 * a closed, thin solid (a blade with two faces a millimetre apart) has
 * outward normals on both faces, so a node on either side is "in front" of
 * its closest face: both sides get the same tag and the blade cuts nothing.
 * Such a body is a blade or a plate: most of its area faces along one axis
 * (the smallest principal axis of its vertices). Its triangles are turned to
 * face along that axis, so the two faces act as one sheet with a front and a
 * back. A closed thin body without such an axis (more than a quarter of its
 * area facing sideways, like a bowl) is refused with a message saying what
 * to use instead. */
#include <math.h>
#include <stdio.h>

#include "../core/svd3.h"
#include "thin.h"

int kf_rigid_orient_thin(double *vert, int nvert, int *tri, int ntri, double dx, const char *name, char *err,
                         size_t errlen, double axis_out[3]) {
    (void)dx;
    double c[3] = {0, 0, 0};
    for (int v = 0; v < nvert; v++)
        for (int a = 0; a < 3; a++) c[a] += vert[3 * v + a] / nvert;
    kf_real C[9] = {0};
    for (int v = 0; v < nvert; v++) {
        double d[3] = {vert[3 * v] - c[0], vert[3 * v + 1] - c[1], vert[3 * v + 2] - c[2]};
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) C[3 * a + b] += (kf_real)(d[a] * d[b] / nvert);
    }
    kf_real U[9], s[3], V[9];
    kf_svd3(C, U, s, V);
    int k = 0; /* the smallest principal axis */
    for (int a = 1; a < 3; a++)
        if (s[a] < s[k]) k = a;
    double axis[3] = {V[k], V[3 + k], V[6 + k]};
    if (axis_out) axis_out[0] = axis[0], axis_out[1] = axis[1], axis_out[2] = axis[2];
    /* a front and a back exist when most of the area faces along the axis
     * (a wavy blade tilts its normals, a bowl turns them sideways) */
    double area = 0, side_on = 0;
    for (int t = 0; t < ntri; t++) {
        const int *f = &tri[3 * t];
        const double *p0 = &vert[3 * f[0]], *p1 = &vert[3 * f[1]], *p2 = &vert[3 * f[2]];
        double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        double a2 = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        area += a2;
        if (fabs(n[0] * axis[0] + n[1] * axis[1] + n[2] * axis[2]) < 0.3 * a2) side_on += a2;
    }
    if (!(area > 0) || side_on > 0.25 * area) {
        if (err && errlen)
            snprintf(err, errlen,
                     "rigid %s: a thin body that is a closed mesh must be a flat blade or plate (%.0f%% of its area "
                     "faces sideways): its two faces would look like one side to the material. Use an open sheet (one "
                     "surface), or thin: false for a solid",
                     name, area > 0 ? 100 * side_on / area : 100.0);
        return -1;
    }
    for (int t = 0; t < ntri; t++) {
        int *f = &tri[3 * t];
        const double *p0 = &vert[3 * f[0]], *p1 = &vert[3 * f[1]], *p2 = &vert[3 * f[2]];
        double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        double e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        if (n[0] * axis[0] + n[1] * axis[1] + n[2] * axis[2] < 0) {
            int tmp = f[1];
            f[1] = f[2];
            f[2] = tmp;
        }
    }
    return 0;
}
