/* solid_guard.c — material enters a solid as far as contact needs, never
 * through it.
 *
 * Around a solid the colored distance field reaches 2.5 cells inside, and the
 * support under a loaded face comes from particles that have slightly
 * penetrated it: guarding a solid as guard.c guards a sheet (nothing behind
 * the surface) moved a floating block's draft from 0.11 to 0.30 cells off
 * Archimedes (docs/lab-notes.md, "The guard around solids"). But where a
 * solid is thinner than the grid resolves, nothing on the grid stops a
 * particle that has entered it from going on: sand_stir's bowl has an 18 mm
 * base, and preview's cells are 24 mm, so the base falls between two node
 * planes. Stirred sand sank into it and slid out under the bowl's wall (117
 * particles inside the base and 192 under the wall at preview's last frame).
 *
 * So a particle's penetration is bounded, not forbidden. Its centre may lie
 * behind the face it entered by (the triangle its path crossed, or, once it
 * is inside, the face closest to it) by at most
 *     allow = min(dx / 2, 0.4 t),
 * t being the solid's thickness at its thinnest. dx / 2 is deeper than
 * contact goes (a resting or loaded layer sits up to a third of a cell in:
 * sand poured over the bowl's rim), so the guard leaves ordinary contact to
 * the grid. 0.4 t keeps the layers a particle may occupy behind the two
 * faces of any part of the solid apart: a point of a part of thickness t' >= t
 * that is within allow of one face is at least t' - allow > allow from the
 * other, so the face closest to a particle inside is the face it entered by
 * (a particle put back in the layer of one face cannot be handed over to
 * the face behind it, and creep through a thin part, as sand did through
 * the bowl's foot, is stopped at the layer's bottom). One allowance for the
 * whole body, not one per face: near a corner where a thick part meets a
 * thin one a per-face allowance let the layers join. A particle that would
 * end deeper is moved back along that face's normal to the allowed depth,
 * keeping its motion along the face, and loses its approach as the boundary
 * type says; the body takes the momentum it lost (kf_cpic_guard_place:
 * Newton's third law). One found a hair deeper than allowed at the start of
 * a substep is put back too: it was put back against one triangle's plane,
 * and the surface curves away from that plane (in sand_stir, a grain left
 * alone 5e-6 m too deep sank through the bowl's wall). One deeper than
 * allowed by more than a tenth of a cell when the run reached it (seeded
 * inside a solid) is left alone.
 *
 * Every particle with affinity to a solid would cost a segment query per
 * substep; most are farther from the surface than their path is long. A
 * lattice of quarter-cell cells in the body's mesh frame records, as
 * particles first reach each cell, a lower bound of every point's distance
 * to the surface where the cell lies outside the solid (KF_SOLID_NEAR
 * where it may touch the surface or lie inside it): a particle whose path is
 * shorter than its starting cell's bound reaches no triangle and is passed
 * over. The mesh does not change in its frame, so the lattice is kept for
 * the run. Which particles are passed over never changes a result: a
 * passed-over particle's query would have found nothing. */
#include <math.h>
#include <stdlib.h>

#include "../rigid/bvh.h"
#include "cpic.h"
#include "guard_geom.h"

/* the two limits of a particle's depth behind a face, in cells and in
 * thicknesses (see above) */
#define SOLID_ALLOW_CELLS 0.5
#define SOLID_ALLOW_THICKNESS 0.4

/* The solid's thickness behind guard primitive k (mesh frame): the least
 * distance along -n to the surface from four points of the triangle (its
 * centroid and the midpoints between it and each corner, away from the
 * edges, where a neighbouring face would answer), looked for up to `most`;
 * `most` when nothing is that close. */
static double thickness_behind(const kf_rigid_body *b, int k, const double n[3], double most, double tol) {
    const int *f = &b->tri[3 * b->guard_tri[k]];
    double c[3] = {0, 0, 0}, t = most;
    for (int v = 0; v < 3; v++)
        for (int a = 0; a < 3; a++) c[a] += b->vert[3 * f[v] + a] / 3;
    for (int sample = 0; sample < 4; sample++) {
        double from[3], to[3], u;
        for (int a = 0; a < 3; a++) {
            const double at = sample ? 0.5 * (c[a] + b->vert[3 * f[sample - 1] + a]) : c[a];
            from[a] = at - tol * n[a]; /* just behind the triangle: it is not hit itself */
            to[a] = at - most * n[a];
        }
        if (kf_rigid_bvh_first_hit(b->bvh, from, to, &u) >= 0 && tol + u * (most - tol) < t) t = tol + u * (most - tol);
    }
    return t;
}

void kf_cpic_solid_make(const kf_rigid_body *b, double dx, struct kf_cpic_solid *sd) {
    sd->tried = 1;
    if (!b->bvh || b->def.thin || b->nvert <= 0) return;
    const int n = b->nguard_tri;
    double lo[3], hi[3];
    const double ext = kf_guard_mesh_box(b, lo, hi);
    sd->tol = 1e-9 * (1 + ext);
    sd->plane = malloc(sizeof(double[4]) * (size_t)n);
    if (!sd->plane) return;
    /* the allowance, from the solid's thinnest part (a thickness beyond
     * cap / 0.4 does not change it, and is not looked for) */
    const double cap = SOLID_ALLOW_CELLS * dx;
    double thinnest = cap / SOLID_ALLOW_THICKNESS;
    for (int k = 0; k < n; k++) {
        kf_guard_tri_plane(b, b->guard_tri[k], sd->plane[k], &sd->plane[k][3]);
        thinnest = fmin(thinnest, thickness_behind(b, k, sd->plane[k], thinnest, 1e3 * sd->tol));
    }
    sd->allow = fmin(cap, SOLID_ALLOW_THICKNESS * thinnest);
    /* the lattice: quarter-cell cells over the body's box and a reach
     * beyond it, clearances in sixteenths of a cell (a cell farther than the
     * reach from every triangle has the reach's); none for a body too large */
    sd->reach = 1.5 * dx;
    sd->h = 0.25 * dx;
    sd->step = dx / 16;
    size_t cells = 1;
    for (int a = 0; a < 3; a++) {
        sd->lo[a] = lo[a] - sd->reach - sd->h;
        sd->dim[a] = (int)ceil((hi[a] + sd->reach + sd->h - sd->lo[a]) / sd->h) + 1;
        cells *= (size_t)sd->dim[a];
    }
    if (cells <= ((size_t)1 << 26)) sd->clear = calloc(cells, 1);
}

void kf_cpic_solid_free(struct kf_cpic_solid *sd) {
    free(sd->plane);
    free(sd->clear);
    sd->plane = NULL, sd->clear = NULL;
}

/* The clearance of the lattice cell holding mesh point pm: a distance no
 * point of the cell is closer than to any triangle, with the cell outside
 * the solid; 0 when the cell may touch the surface or lie inside. Made on
 * first asking, the same whichever thread asks first. */
static double clearance(const struct kf_cpic_solid *sd, const kf_rigid_body *b, const double pm[3]) {
    if (!sd->clear) return 0;
    int ix[3];
    for (int a = 0; a < 3; a++) {
        const double f = floor((pm[a] - sd->lo[a]) / sd->h);
        if (!(f >= 0 && f < sd->dim[a])) return sd->reach; /* beyond the reach of every triangle */
        ix[a] = (int)f;
    }
    const size_t at = ((size_t)ix[0] * (size_t)sd->dim[1] + (size_t)ix[1]) * (size_t)sd->dim[2] + (size_t)ix[2];
    int v = __atomic_load_n(&sd->clear[at], __ATOMIC_RELAXED);
    if (!v) {
        /* the cell's centre and half diagonal, widened for points that round into the next cell */
        double c[3], q[3];
        for (int a = 0; a < 3; a++) c[a] = sd->lo[a] + (ix[a] + 0.5) * sd->h;
        const double hd = 0.5 * sd->h * 1.01 * sqrt(3.0) + sd->tol;
        int interior, k = kf_rigid_bvh_closest(b->bvh, c, sd->reach + hd, q, &interior);
        double room = sd->reach;
        if (k >= 0) {
            const double *pl = sd->plane[k];
            const double D =
                sqrt((q[0] - c[0]) * (q[0] - c[0]) + (q[1] - c[1]) * (q[1] - c[1]) + (q[2] - c[2]) * (q[2] - c[2]));
            /* behind the closest face's plane (inside), or touching: no bound */
            room = pl[0] * c[0] + pl[1] * c[1] + pl[2] * c[2] - pl[3] > 0 ? D - hd : 0;
        }
        const double steps = floor(room / sd->step);
        v = room > 0 ? 1 + (int)fmin(steps, KF_SOLID_NEAR - 2) : KF_SOLID_NEAR;
        __atomic_store_n(&sd->clear[at], (uint8_t)v, __ATOMIC_RELAXED);
    }
    return v == KF_SOLID_NEAR ? 0 : (v - 1) * sd->step;
}

double kf_cpic_solid_guard(const kf_model *m, kf_state *s, int r, size_t i, const double xold[3], double *imp) {
    const kf_rigid_body *b = &m->rigid[r];
    const kf_cpic *c = s->cpic;
    const struct kf_cpic_solid *sd = &c->solid[r];
    if (!sd->plane) return 0;
    kf_particles *p = &s->p;
    const double x1[3] = {p->x[0][i], p->x[1][i], p->x[2][i]};
    double p0[3], p1[3], d[3];
    kf_guard_to_mesh(&s->rigid[r], xold, p0);
    kf_guard_to_mesh(&c->end[r], x1, p1);
    for (int a = 0; a < 3; a++) d[a] = p1[a] - p0[a];
    /* its whole path farther from the surface than it is long: nothing to do */
    const double room = clearance(sd, b, p0);
    if (kf_v3d_dot(d, d) < room * room) return 0;
    /* the face it entered by and how deep behind it it may end: the face its
     * path entered through, else (already inside) the face closest to it */
    double t, q[3];
    int face = kf_rigid_bvh_first_hit(b->bvh, p0, p1, &t), interior;
    const double *pl = face >= 0 ? sd->plane[face] : NULL;
    double limit;
    if (pl && kf_v3d_dot(pl, p0) - pl[3] >= 0) {
        limit = sd->allow;
    } else {
        face = kf_rigid_bvh_closest(b->bvh, p0, sd->allow + 0.1 * m->sim.dx, q, &interior);
        if (face < 0) return 0; /* outside, or seeded deep inside (left alone) */
        pl = sd->plane[face];
        if (kf_v3d_dot(pl, p0) - pl[3] >= 0) return 0; /* outside, and its path entered nothing */
        limit = sd->allow;
    }
    const double u1 = kf_v3d_dot(pl, p1) - pl[3];
    if (u1 >= -limit) return 0;
    /* back to the allowed depth along the face's normal, its motion along the face kept */
    for (int a = 0; a < 3; a++) p1[a] -= (u1 + limit) * pl[a];
    kf_cpic_guard_place(m, s, r, i, p1, pl, imp);
    return -u1 - limit;
}

/* The particles with affinity to solid r whose centre lies deeper behind the
 * exact face closest to it (within the allowance and a cell, the closest
 * point inside that face) than the guard allows, to a hundredth of a cell;
 * the deepest such, in cells (beyond the allowance's reach, a particle
 * seeded inside a solid is not seen: it is not the guard's). */
long kf_cpic_solid_audit(const kf_model *m, const kf_state *s, int r, double *deepest_cells) {
    const kf_rigid_body *b = &m->rigid[r];
    const struct kf_cpic_solid *sd = s->cpic ? &s->cpic->solid[r] : NULL;
    *deepest_cells = 0;
    if (!sd || !sd->plane) return 0;
    const kf_particles *p = &s->p;
    const double dx = m->sim.dx, over = sd->allow + 0.01 * dx;
    const uint32_t abit = 2u << (2 * r);
    const size_t n = p->n;
    long across = 0;
    double deepest = 0;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) reduction(+ : across) reduction(max : deepest)
    for (size_t i = 0; i < n; i++) {
        if (!(p->colour[i] & abit)) continue;
        double x[3] = {p->x[0][i], p->x[1][i], p->x[2][i]}, pm[3], q[3];
        kf_guard_to_mesh(&s->rigid[r], x, pm);
        int interior = 0, k = kf_rigid_bvh_closest(b->bvh, pm, sd->allow + dx, q, &interior);
        if (k < 0 || !interior) continue;
        const double u = kf_v3d_dot(sd->plane[k], pm) - sd->plane[k][3];
        if (u >= -over) continue;
        across++;
        if (-u / dx > deepest) deepest = -u / dx;
    }
    *deepest_cells = deepest;
    return across;
}
