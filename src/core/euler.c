/* euler.c — R = Rz Ry Rx from degrees (see euler.h). */
#include "euler.h"

#include <math.h>
#include <string.h>

#define DEG (3.14159265358979323846 / 180.0)

void kf_euler_matrix(const double deg[3], double R[9]) {
    double ca = cos(deg[0] * DEG), sa = sin(deg[0] * DEG), cb = cos(deg[1] * DEG), sb = sin(deg[1] * DEG);
    double cg = cos(deg[2] * DEG), sg = sin(deg[2] * DEG);
    double M[9] = {cg * cb,
                   cg * sb * sa - sg * ca,
                   cg * sb * ca + sg * sa,
                   sg * cb,
                   sg * sb * sa + cg * ca,
                   sg * sb * ca - cg * sa,
                   -sb,
                   cb * sa,
                   cb * ca};
    memcpy(R, M, sizeof M);
}
