/* mass.h — mass, centre of mass and inertia of a triangle mesh: a closed
 * solid of uniform density, or a shell of uniform area density. */
#ifndef KF_RIGID_MASS_H
#define KF_RIGID_MASS_H

typedef struct kf_mass_props {
    double mass;       /* kg */
    double com[3];     /* mesh frame */
    double inertia[9]; /* about com, mesh-frame axes, row-major, kg·m² */
    double measure;    /* volume (solid, m³) or area (shell, m²) */
} kf_mass_props;

/* Closed solid, counter-clockwise outside: divergence theorem over the
 * tetrahedra the triangles span with the origin. measure <= 0 means the
 * mesh is inside out or not a solid. */
void kf_mass_solid(const double *vert, const int *tri, int ntri, double density, kf_mass_props *mp);

/* Shell: every triangle is a thin sheet of area density `density`. */
void kf_mass_shell(const double *vert, const int *tri, int ntri, double density, kf_mass_props *mp);

#endif
