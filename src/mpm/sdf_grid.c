/* sdf_grid.c — trilinear reads of a sampled signed distance field. */
#include "sdf_grid.h"

#include <math.h>

size_t kf_sdf_grid_nodes(const kf_sdf_grid *g) { return (size_t)g->dims[0] * (size_t)g->dims[1] * (size_t)g->dims[2]; }

void kf_sdf_grid_bounds(const kf_sdf_grid *g, double lo[3], double hi[3]) {
    for (int a = 0; a < 3; a++) {
        lo[a] = g->origin[a];
        hi[a] = g->origin[a] + g->spacing * (g->dims[a] - 1);
    }
}

const char *kf_sdf_grid_check(const kf_sdf_grid *g) {
    if (!g) return "mesh collider has no distance field (sdf)";
    if (!(g->spacing > 0 && isfinite(g->spacing))) return "sdf spacing must be > 0";
    for (int a = 0; a < 3; a++) {
        if (g->dims[a] < 2) return "sdf needs at least 2 nodes along each axis";
        if (!isfinite(g->origin[a])) return "sdf origin must be finite";
    }
    if (kf_sdf_grid_nodes(g) > ((size_t)1 << 31)) return "sdf has too many nodes (at most 2^31)";
    if (!g->phi) return "sdf has no values";
    size_t n = kf_sdf_grid_nodes(g);
    for (size_t i = 0; i < n; i++)
        if (!isfinite(g->phi[i])) return "sdf values must be finite";
    return "";
}

double kf_sdf_grid_sample(const kf_sdf_grid *g, const double X[3], double grad[3]) {
    const double h = g->spacing, inv = 1.0 / h;
    const int ny = g->dims[1], nz = g->dims[2];
    int c[3];
    double u[3], out[3] = {0, 0, 0}, out2 = 0;
    for (int a = 0; a < 3; a++) {
        double s = (X[a] - g->origin[a]) * inv, top = g->dims[a] - 1;
        /* beyond the box: read at its surface, add the distance to it */
        if (s < 0) out[a] = s * h, s = 0;
        else if (s > top) out[a] = (s - top) * h, s = top;
        out2 += out[a] * out[a];
        int i = (int)s;
        if (i > g->dims[a] - 2) i = g->dims[a] - 2;
        c[a] = i;
        u[a] = s - i;
    }
    const float *p = g->phi + ((size_t)c[0] * ny + c[1]) * nz + c[2];
    const size_t sx = (size_t)ny * nz, sy = (size_t)nz;
    double f000 = p[0], f001 = p[1], f010 = p[sy], f011 = p[sy + 1];
    double f100 = p[sx], f101 = p[sx + 1], f110 = p[sx + sy], f111 = p[sx + sy + 1];
    /* along z, then y, then x (fractions fx, fy, fz within the cell) */
    const double fx = u[0], fy = u[1], fz = u[2];
    double f00 = f000 + fz * (f001 - f000), f01 = f010 + fz * (f011 - f010);
    double f10 = f100 + fz * (f101 - f100), f11 = f110 + fz * (f111 - f110);
    double f0 = f00 + fy * (f01 - f00), f1 = f10 + fy * (f11 - f10);
    double f = f0 + fx * (f1 - f0);
    if (out2 > 0) {
        double d = sqrt(out2);
        for (int a = 0; a < 3; a++) grad[a] = out[a] / d;
        return f + d;
    }
    /* the interpolant's derivative along each axis */
    grad[0] = (f1 - f0) * inv;
    grad[1] = ((f01 - f00) + fx * ((f11 - f10) - (f01 - f00))) * inv;
    double dz0 = (f001 - f000) + fy * ((f011 - f010) - (f001 - f000));
    double dz1 = (f101 - f100) + fy * ((f111 - f110) - (f101 - f100));
    grad[2] = (dz0 + fx * (dz1 - dz0)) * inv;
    return f;
}

void kf_sdf_grid_gradient(const kf_sdf_grid *g, const double X[3], double grad[3]) {
    const double h = g->spacing;
    double unused[3];
    for (int a = 0; a < 3; a++) {
        double P[3] = {X[0], X[1], X[2]}, M[3] = {X[0], X[1], X[2]};
        P[a] += h, M[a] -= h;
        grad[a] = (kf_sdf_grid_sample(g, P, unused) - kf_sdf_grid_sample(g, M, unused)) / (2 * h);
    }
}
