/* thin.h — closed thin bodies as one-sided sheets for CPIC (thin.c). */
#ifndef KF_RIGID_THIN_H
#define KF_RIGID_THIN_H

#include <stddef.h>

/* Turn every triangle of a closed blade or plate to face along its thinnest
 * axis. Returns 0, or -1 with a message when more than a quarter of its area
 * faces sideways (no front and back). axis_out (may be NULL): that axis. */
int kf_rigid_orient_thin(double *vert, int nvert, int *tri, int ntri, double dx, const char *name, char *err,
                         size_t errlen, double axis_out[3]);

#endif
