/* mass.c — mass properties by exact polynomial integration over simplices.
 *
 * With a the vertices of a simplex (the origin counts as a zero vertex of a
 * tetrahedron) and S their sum, the second moments are exact:
 *   tetrahedron (0, a, b, c), volume V = det[a b c] / 6:
 *     ∫ x_i x_j dV = V/20 (Σ_k a_k,i a_k,j + S_i S_j)
 *   triangle (a, b, c), area A:
 *     ∫ x_i x_j dA = A/12 (Σ_k a_k,i a_k,j + S_i S_j)
 * so the products of inertia come out exactly, and the inertia about the
 * centre of mass is I = tr(C) 1 - C with C = ∫ (x - com)(x - com)ᵀ dm. */
#include "mass.h"

#include <math.h>
#include <string.h>

/* C (second moments about the origin), first moments and measure → mp */
static void finish(double measure, const double first[3], const double C[9], double density, kf_mass_props *mp) {
    memset(mp, 0, sizeof *mp);
    mp->measure = measure;
    if (!(measure > 0)) return;
    mp->mass = density * measure;
    for (int a = 0; a < 3; a++) mp->com[a] = first[a] / measure;
    /* second moments about the centre of mass, times density */
    double Cc[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) Cc[3 * i + j] = density * (C[3 * i + j] - measure * mp->com[i] * mp->com[j]);
    double tr = Cc[0] + Cc[4] + Cc[8];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) mp->inertia[3 * i + j] = (i == j ? tr : 0) - Cc[3 * i + j];
    /* the integration leaves rounding asymmetry below 1e-16 relative; make it exactly symmetric */
    for (int i = 0; i < 3; i++)
        for (int j = i + 1; j < 3; j++) {
            double s = 0.5 * (mp->inertia[3 * i + j] + mp->inertia[3 * j + i]);
            mp->inertia[3 * i + j] = mp->inertia[3 * j + i] = s;
        }
}

/* the moments of one simplex given its measure w and vertices p[0..n-1] */
static void accumulate(double w, double denom, const double *p[3], double first[3], double C[9], double scale_first) {
    double S[3] = {p[0][0] + p[1][0] + p[2][0], p[0][1] + p[1][1] + p[2][1], p[0][2] + p[1][2] + p[2][2]};
    for (int a = 0; a < 3; a++) first[a] += w * S[a] * scale_first;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double s = p[0][i] * p[0][j] + p[1][i] * p[1][j] + p[2][i] * p[2][j] + S[i] * S[j];
            C[3 * i + j] += w / denom * s;
        }
}

void kf_mass_solid(const double *vert, const int *tri, int ntri, double density, kf_mass_props *mp) {
    double V = 0, first[3] = {0, 0, 0}, C[9] = {0};
    for (int t = 0; t < ntri; t++) {
        const double *p[3] = {vert + 3 * tri[3 * t], vert + 3 * tri[3 * t + 1], vert + 3 * tri[3 * t + 2]};
        const double *a = p[0], *b = p[1], *c = p[2];
        double det = a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                     a[2] * (b[0] * c[1] - b[1] * c[0]);
        double v = det / 6;
        V += v;
        /* centroid of (0, a, b, c) is S/4 */
        accumulate(v, 20, p, first, C, 0.25);
    }
    finish(V, first, C, density, mp);
}

void kf_mass_shell(const double *vert, const int *tri, int ntri, double density, kf_mass_props *mp) {
    double A = 0, first[3] = {0, 0, 0}, C[9] = {0};
    for (int t = 0; t < ntri; t++) {
        const double *p[3] = {vert + 3 * tri[3 * t], vert + 3 * tri[3 * t + 1], vert + 3 * tri[3 * t + 2]};
        double e1[3], e2[3];
        for (int k = 0; k < 3; k++) e1[k] = p[1][k] - p[0][k], e2[k] = p[2][k] - p[0][k];
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        double a = 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        A += a;
        /* centroid S/3 */
        accumulate(a, 12, p, first, C, 1.0 / 3);
    }
    finish(A, first, C, density, mp);
}
