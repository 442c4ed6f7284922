/* guard.c — nothing passes through a rigid surface.
 *
 * CPIC keeps the two sides of a thin surface apart on the grid, but the
 * particles themselves are advected with interpolated velocities: a particle
 * pressed against a moving sheet takes the sheet's velocity only in
 * proportion to the weight of its ghost nodes, so a sheet moving a fraction
 * of a cell per substep overtakes the particles in front of it, and a
 * particle's advection error can carry it through (§5.3.3: "a particle may
 * slightly penetrate a surface due to numerical advection error"). The
 * paper answers with a weak penalty; that bounds nothing, and measured, 3,616
 * of 14,400 sand particles ended up across a sheet at half a cell per substep.
 *
 * The guard makes the crossing impossible. After advection, each particle
 * near a body (its stencil had affinity to it) is followed along its path
 * relative to the body: the segment from where it was in the body's frame at
 * the start of the substep to where it is in the body's frame at the end. If
 * that segment passes through a triangle (an exact, watertight Embree query
 * against the body's own mesh, bvh.h), the particle crossed: it is put back
 * on the side it came from, at half its spacing from the triangle's plane
 * (or where it started, if closer), keeping its motion along the surface; its velocity relative to the
 * body loses its approaching normal part as the boundary type says (Eq. 25),
 * and the momentum it loses goes to the body (Newton's third law). If the
 * corrected path still passes through the surface (a concave fold), the
 * correction is repeated, and after four tries the particle stays where it
 * was relative to the body.
 *
 * The body's pose at the end of the substep is known for static and
 * kinematic bodies; a dynamic body's is predicted from its velocity at the
 * start (gravity included), which the material's impulses, its joints and
 * contacts change by a small fraction of a cell: once the bodies have
 * moved, each particle is followed from the predicted pose to the body's
 * own too (kf_cpic_guard_settle, below), so no leg of its path goes
 * unguarded.
 *
 * Colours are untouched: a particle that never crosses keeps the side its
 * colour records. */
#include <math.h>
#include <stdlib.h>

#include "../mpm/collider.h"
#include "../mpm/transfer_chunk.h"
#include "../rigid/bvh.h"
#include "../core/mat3.h"
#include "cpic.h"
#include "guard_geom.h"

#define NB KF_CPIC_NB

/* the pose of every body at the substep's end (exact, or predicted for dynamic bodies) */
void kf_cpic_guard_poses(const kf_model *m, const kf_state *s, double dt) {
    kf_cpic *c = s->cpic;
    for (int r = 0; r < m->nrigid; r++) {
        const kf_rigid_body *b = &m->rigid[r];
        kf_rigid_state *e = &c->end[r];
        if (!c->sides[r].tried) kf_cpic_sides_make(b, m->sim.dx, &c->sides[r]);
        if (!c->solid[r].tried) kf_cpic_solid_make(b, m->sim.dx, &c->solid[r]);
        if (b->def.motion != KF_RIGID_DYNAMIC) {
            kf_rigid_state_at(b, s->time + dt, e);
            continue;
        }
        const kf_rigid_state *st = &s->rigid[r];
        double wdt[3] = {st->w[0] * dt, st->w[1] * dt, st->w[2] * dt}, Q[9], cm[3];
        kf_m3d_rotvec(Q, wdt);
        kf_m3d_mul(e->R, Q, st->R);
        for (int a = 0; a < 3; a++) {
            e->v[a] = st->v[a] + m->sim.gravity[a] * dt;
            e->w[a] = st->w[a];
            e->com[a] = st->com[a] + e->v[a] * dt;
        }
        kf_m3d_mv(cm, e->R, b->com);
        for (int a = 0; a < 3; a++) e->t[a] = e->com[a] - cm[a];
    }
}

/* Where the segment p0 -> p1 (mesh frame) passes through body b's surface,
 * p1 put back on p0's side (eps: the least distance from the plane; vol0:
 * the particle's volume, for its spacing). Returns 0 when it does not cross
 * (p1 kept); else 1, with the depth p1 was behind the first triangle it
 * hit, the side it is on now (1: the triangle's normal's, -1: behind) and
 * that side's normal. */
static int put_back(const kf_rigid_body *b, const double p0[3], double p1[3], double eps, double vol0, double *depth,
                    double side_n[3], double *side_out) {
    double t;
    int k = kf_rigid_bvh_first_hit(b->bvh, p0, p1, &t);
    if (k < 0) return 0;
    /* a particle that got between the two faces of a blade (through its
     * unguarded edge) is let out: looking back along its path, the other face
     * is within the blade's thickness */
    if (b->sheet_thickness > 0) {
        double d[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]}, len = sqrt(kf_v3d_dot(d, d)), back[3], tb;
        if (len > 0) {
            for (int a = 0; a < 3; a++) back[a] = p0[a] - d[a] / len * 1.5 * b->sheet_thickness;
            if (kf_rigid_bvh_first_hit(b->bvh, p0, back, &tb) >= 0) return 0;
        }
    }
    const double half = 0.5 * cbrt(vol0);
    double n[3], off, side = 1;
    *depth = 0;
    for (int tries = 0; k >= 0; tries++) {
        kf_guard_tri_plane(b, b->guard_tri[k], n, &off);
        double s0 = kf_v3d_dot(n, p0) - off, s1 = kf_v3d_dot(n, p1) - off;
        side = s0 >= 0 ? 1 : -1;
        if (tries == 0) *depth = fabs(s1);
        for (int a = 0; a < 3; a++) side_n[a] = side * n[a];
        if (tries == 4) {
            /* a fold it keeps crossing: it stays where it was relative to the body */
            for (int a = 0; a < 3; a++) p1[a] = p0[a];
            break;
        }
        /* back onto its own side, its motion along the plane kept: at half
         * its spacing from the plane (a particle stands for a cube of side
         * vol0^(1/3), and the penalty keeps that cube out of a body, so this
         * is where it rests either way), or where it started if that was
         * closer (the guard adds no motion away from the surface), but at
         * least a hair */
        double place = fabs(s0) < half ? fabs(s0) : half;
        if (place < eps) place = eps;
        for (int a = 0; a < 3; a++) p1[a] -= (s1 - side * place) * n[a];
        k = kf_rigid_bvh_first_hit(b->bvh, p0, p1, &t);
    }
    *side_out = side;
    return 1;
}

/* Follow one particle's path relative to body r; fix it if it crossed.
 * Returns the depth it would have been behind (m), or 0 when it did not cross. */
static double guard_particle(const kf_model *m, kf_state *s, int r, size_t i, const double xold[3], double *imp) {
    const kf_rigid_body *b = &m->rigid[r];
    const kf_cpic *c = s->cpic;
    kf_particles *p = &s->p;
    double x1[3] = {p->x[0][i], p->x[1][i], p->x[2][i]}, p0[3], p1[3];
    /* thin bodies only: a solid bounds how deep material enters it
     * (solid_guard.c), since guarding it as a sheet removes the slight
     * penetrations that carry a loaded face's support (docs/lab-notes.md,
     * "The guard around solids") */
    if (!b->bvh || !b->def.thin) return 0;
    kf_guard_to_mesh(&s->rigid[r], xold, p0);
    kf_guard_to_mesh(&c->end[r], x1, p1);
    /* farther from the surface than its path is long (the MLS fit's distance
     * at the start, a quarter cell to spare for a curved surface): it cannot
     * have reached it, and the query is skipped (most of the narrow band) */
    if (c->near[i] == r + 1) {
        double d[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]};
        if (c->pd[i] > sqrt(kf_v3d_dot(d, d)) + 0.25 * m->sim.dx) return 0;
    }
    double depth, side_n[3], side;
    if (!put_back(b, p0, p1, 0.01 * m->sim.dx, (double)p->vol0[i], &depth, side_n, &side)) return 0;
    /* its colour for r names the side it is on, as a node's would (T = behind
     * the triangle's normal, cdf.c): the guard knows it exactly, where the
     * colour was voted from the grid when the particle came near */
    const uint32_t bits = 3u << (2 * r), want = (2u << (2 * r)) | (side < 0 ? 1u << (2 * r) : 0);
    p->colour[i] = (p->colour[i] & ~bits) | want;
    kf_cpic_guard_place(m, s, r, i, p1, side_n, imp);
    return depth;
}

void kf_cpic_guard_place(const kf_model *m, kf_state *s, int r, size_t i, const double pm[3], const double nm[3],
                         double *imp) {
    const kf_rigid_body *b = &m->rigid[r];
    kf_particles *p = &s->p;
    /* back to the world, at the body's end pose */
    const kf_rigid_state *e = &s->cpic->end[r];
    double xw[3], nw[3];
    kf_m3d_mv(xw, e->R, pm);
    kf_m3d_mv(nw, e->R, nm);
    for (int a = 0; a < 3; a++) {
        xw[a] += e->t[a];
        p->x[a][i] = (kf_real)xw[a];
    }
    /* its velocity relative to the body there: no approach through the surface (Eq. 25) */
    double V[3], w[3];
    kf_rigid_point_velocity(e, xw, V);
    for (int a = 0; a < 3; a++) w[a] = p->v[a][i] - V[a];
    double wn = kf_v3d_dot(w, nw);
    if (wn < 0 || b->def.boundary == KF_BOUNDARY_STICKY) {
        double w0[3] = {w[0], w[1], w[2]}, J[3];
        kf_project_velocity(w, nw, b->def.boundary, b->def.friction);
        for (int a = 0; a < 3; a++) {
            double dv = w[a] - w0[a];
            p->v[a][i] = (kf_real)(p->v[a][i] + dv);
            J[a] = -p->mass[i] * dv; /* the body takes what the particle lost */
        }
        kf_cpic_add_impulse(imp + 6 * r, &s->rigid[r], xw, J);
    }
}

/* ---- the sides a thin body's surface can give ---------------------------------
 * The re-sync below asks for the triangle closest to a particle within 1.5
 * cells and takes the side of its plane; it changes a tag only where that
 * side differs from the tag (a few in a million on a blade in the material).
 * The answer for every point of a small cell of the mesh frame is bounded
 * by the cell's candidates: if some triangle lies within D of the cell's
 * centre, every point of the cell has one within D + h (h: the cell's half
 * diagonal), so its closest triangle lies within D + 2h of the centre, and
 * within reach + h. With no candidate there is no closest triangle; with
 * the cell strictly on one side of every candidate's plane, the closest
 * (whichever it is) gives that side. So per cell of a lattice of an eighth
 * (or a quarter) of a cell's spacing, made as particles first reach it and kept for the run
 * (the mesh does not change in its frame), one of the values below; a
 * particle whose tag already names its cell's side needs no query. The cell
 * is widened a little past its lattice bounds and the distances and the
 * plane test have a margin far above their rounding, so a point that rounds
 * into the neighbouring cell, or a distance that rounds across 0, is still
 * covered. */

/* The lattice's n cells (all unknown) and the planes of the body's
 * primitives that its cells test (sides_tri: each cell tests dozens, and
 * kf_guard_tri_plane's square root and divisions were most of a test), made once:
 * the mesh does not change in its frame. One allocation, freed as sd->v. */
static void sides_alloc(const kf_rigid_body *b, size_t n, struct kf_cpic_sides *sd) {
    /* the cells rounded up to 32 bytes: the planes start as aligned as calloc's block (enough for doubles) */
    const size_t cells = (n + 31) / 32 * 32;
    uint8_t *mem = calloc(cells + sizeof(double[4]) * (size_t)b->nguard_tri, 1);
    if (!mem) return;
    sd->v = mem;
    sd->plane = (double(*)[4])(void *)(mem + cells);
    for (int k = 0; k < b->nguard_tri; k++) kf_guard_tri_plane(b, b->guard_tri[k], sd->plane[k], &sd->plane[k][3]);
}

void kf_cpic_sides_make(const kf_rigid_body *b, double dx, struct kf_cpic_sides *sd) {
    sd->tried = 1;
    if (!b->bvh || !b->def.thin || b->nvert <= 0) return;
    double lo[3], hi[3];
    const double ext = kf_guard_mesh_box(b, lo, hi);
    sd->reach = 1.5 * dx;
    sd->tol = 1e-9 * (1 + ext);
    /* cells of an eighth of dx where the lattice stays within its bound,
     * else a quarter. Near a closed blade whose faces curve (a crinkle-cut
     * knife) a quarter-dx cell often has candidates on both sides and is
     * MIXED, so each particle there asks the tree; an eighth halves the
     * cells' spread and their candidates' reach past the closest (on the
     * knife in the cheese: 12,350 of the re-sync's closest-triangle
     * queries in 16 substeps down to 2,648). Only which queries are
     * skipped depends on the cell size, never a tag. */
    size_t n = 0;
    for (int pass = 0; pass < 2; pass++) {
        sd->h = (pass ? 0.25 : 0.125) * dx;
        n = 1;
        for (int a = 0; a < 3; a++) {
            /* a cell's margin beyond the reach: a point outside the lattice is
             * farther than the reach from every vertex's box */
            sd->lo[a] = lo[a] - sd->reach - sd->h;
            sd->dim[a] = (int)ceil((hi[a] + sd->reach + sd->h - sd->lo[a]) / sd->h) + 1;
            n *= (size_t)sd->dim[a];
        }
        if (n <= ((size_t)1 << 26)) break;
    }
    /* a body hundreds of cells across in every direction: always query
     * (below that, only the pages of cells particles reach are touched) */
    if (n > ((size_t)1 << 26)) return;
    sides_alloc(b, n, sd);
}

typedef struct sides_ctx {
    const double (*plane)[4];
    double c[3], half[3], tol;
    int front, behind;
} sides_ctx;

static int sides_tri(void *ctx, int k) {
    sides_ctx *x = ctx;
    const double *n = x->plane[k], off = x->plane[k][3];
    /* the plane's distance over the cell: its centre's, give or take the corners' spread */
    const double u = kf_v3d_dot(n, x->c) - off,
                 spread = fabs(n[0]) * x->half[0] + fabs(n[1]) * x->half[1] + fabs(n[2]) * x->half[2];
    if (u - spread > x->tol) x->front = 1;
    else if (u + spread < -x->tol) x->behind = 1;
    else x->front = x->behind = 1;
    return x->front && x->behind; /* mixed: the rest cannot change that */
}

/* the lattice cell of mesh-frame point pm (flat index), or SIDES_BEYOND:
 * outside the lattice, beyond the reach of every triangle */
#define SIDES_BEYOND ((size_t)-1)
static size_t sides_cell(const struct kf_cpic_sides *sd, const double pm[3]) {
    int ix[3];
    for (int a = 0; a < 3; a++) {
        const double f = floor((pm[a] - sd->lo[a]) / sd->h);
        if (!(f >= 0 && f < sd->dim[a])) return SIDES_BEYOND;
        ix[a] = (int)f;
    }
    return ((size_t)ix[0] * (size_t)sd->dim[1] + (size_t)ix[1]) * (size_t)sd->dim[2] + (size_t)ix[2];
}

/* the value of lattice cell `at`, made on first asking */
static int sides_value(const struct kf_cpic_sides *sd, const kf_rigid_body *b, size_t at) {
    if (at == SIDES_BEYOND) return KF_SIDES_NONE;
    int v = __atomic_load_n(&sd->v[at], __ATOMIC_RELAXED);
    if (v) return v;
    int ix[3];
    size_t rest = at;
    ix[2] = (int)(rest % (size_t)sd->dim[2]), rest /= (size_t)sd->dim[2];
    ix[1] = (int)(rest % (size_t)sd->dim[1]), ix[0] = (int)(rest / (size_t)sd->dim[1]);
    /* the same value whichever thread makes it first */
    sides_ctx x = {(const double(*)[4])sd->plane, {0, 0, 0}, {0, 0, 0}, sd->tol, 0, 0};
    double d2 = 0;
    for (int a = 0; a < 3; a++) {
        x.half[a] = 0.5 * sd->h * 1.01; /* widened: points that round into the next cell */
        x.c[a] = sd->lo[a] + (ix[a] + 0.5) * sd->h;
        d2 += x.half[a] * x.half[a];
    }
    const double hd = sqrt(d2);
    double q[3], within = sd->reach + hd;
    int interior;
    if (kf_rigid_bvh_closest(b->bvh, x.c, within * 1.001 + 1000 * sd->tol, q, &interior) >= 0) {
        const double D = sqrt((q[0] - x.c[0]) * (q[0] - x.c[0]) + (q[1] - x.c[1]) * (q[1] - x.c[1]) +
                              (q[2] - x.c[2]) * (q[2] - x.c[2]));
        if (D + 2 * hd < within) within = D + 2 * hd;
        /* widened past the rounding of Embree's float radius, which may
         * have let the query return a triangle a hair farther than the closest */
        kf_rigid_bvh_within(b->bvh, x.c, within * 1.0001 + 1000 * sd->tol, sides_tri, &x);
    }
    v = x.front && x.behind ? KF_SIDES_MIXED : x.front ? KF_SIDES_FRONT : x.behind ? KF_SIDES_BEHIND : KF_SIDES_NONE;
    __atomic_store_n(&sd->v[at], (uint8_t)v, __ATOMIC_RELAXED);
    return v;
}

int kf_cpic_sides_at(const struct kf_cpic_sides *sd, const kf_rigid_body *b, const double pm[3]) {
    if (!sd->v) return KF_SIDES_MIXED;
    return sides_value(sd, b, sides_cell(sd, pm));
}

/* A particle near thin body r that did not cross it takes the side of the
 * exact closest triangle, as a node takes the side of its closest primitive
 * (cdf.c). With the guard nothing is behind a thin body for real (its path
 * was just checked against every triangle), so a tag that disagrees is
 * stale: one bit per body cannot name the side of every plate of a fold
 * (crossing plates, a paddle wheel, a stirrer's blades), and a particle in
 * the corner where two plates meet, or one that slid from one plate to the
 * other, kept the first one's side; a particle that arrives fast takes its
 * tag by the nodes' vote (Eq. 21), which near a fold or an edge can name
 * the other side. The fit's distance does not see these: in the corner it
 * is the distance to the nearer plate, positive on the tag's side of either,
 * and a particle with too few nodes for a fit, or closer to another body,
 * has none for r. So every particle the guard followed is re-synced unless
 * the fit puts it beyond the audit's reach. pose: the body's pose at the
 * substep's end the particle is placed against. */
/* the same at mesh point pm of the pose it is placed against, whose
 * lattice cell says `known` */
static void retag_at(const kf_model *m, kf_state *s, int r, size_t i, const double pm[3], int known) {
    const kf_rigid_body *b = &m->rigid[r];
    kf_particles *p = &s->p;
    double q[3], nrm[3], off;
    const uint32_t tbit = 1u << (2 * r);
    /* the answer known without a query: no triangle within reach, or the
     * side the tag already names */
    if (known == KF_SIDES_NONE || (known == KF_SIDES_FRONT && !(p->colour[i] & tbit)) ||
        (known == KF_SIDES_BEHIND && (p->colour[i] & tbit)))
        return;
    int interior = 0, k = kf_rigid_bvh_closest(b->bvh, pm, 1.5 * m->sim.dx, q, &interior);
    if (k < 0 || !interior) return;
    kf_guard_tri_plane(b, b->guard_tri[k], nrm, &off);
    const double u = kf_v3d_dot(nrm, pm) - off;
    if (u < 0) p->colour[i] |= tbit;
    else if (u > 0) p->colour[i] &= ~tbit;
}

/* the particle where it is, against pose */
static void retag(const kf_model *m, kf_state *s, int r, size_t i, const kf_rigid_state *pose) {
    const kf_rigid_body *b = &m->rigid[r];
    if (!b->bvh || !b->def.thin) return;
    const kf_particles *p = &s->p;
    double x[3] = {p->x[0][i], p->x[1][i], p->x[2][i]}, pm[3];
    kf_guard_to_mesh(pose, x, pm);
    retag_at(m, s, r, i, pm, kf_cpic_sides_at(&s->cpic->sides[r], b, pm));
}

void kf_cpic_guard(const kf_model *m, kf_state *s, size_t owner, const kf_cpic_owner *oc, const chunk *ck, size_t i0,
                   const kf_real *xold) {
    kf_cpic *c = s->cpic;
    const int slot = c->slot[owner];
    double *imp = &c->imp[slot][0][0];
    /* the affinity bits of the solids: guarded after the thin bodies, whose
     * put-backs move a particle along their own normal only, and may move it
     * into a solid (sand a stirrer's blade presses into a bowl's wall) */
    uint32_t solids = 0;
    for (int r = 0; r < m->nrigid; r++)
        if (!m->rigid[r].def.thin) solids |= 2u << (2 * r);
    for (int j = 0; j < ck->n; j++) {
        /* the bodies the particle's stencil (at its start) had affinity to */
        const int o = (ck->l[0][j] * NB + ck->l[1][j]) * NB + ck->l[2][j];
        const uint32_t aff = oc->aff[o];
        if (!aff) continue;
        const double x0[3] = {xold[j], xold[KF_CHUNK + j], xold[2 * KF_CHUNK + j]};
        for (uint32_t B = aff & ~solids; B; B &= B - 1) {
            int r = __builtin_ctz(B) / 2;
            double depth = guard_particle(m, s, r, i0 + (size_t)j, x0, imp);
            if (depth > 0) {
                c->guard_caught[slot]++;
                if (depth > c->guard_depth[slot]) c->guard_depth[slot] = depth;
            }
            /* one put back took the side of the triangle it hit; in a fold's
             * corner the closest triangle may be the other plate's */
            if (depth > 0 || c->near[i0 + (size_t)j] != r + 1 || c->pd[i0 + (size_t)j] < 1.5 * m->sim.dx)
                retag(m, s, r, i0 + (size_t)j, &c->end[r]);
        }
        /* a solid: no deeper than its contact allows (solid_guard.c) */
        for (uint32_t B = aff & solids; B; B &= B - 1) {
            double excess = kf_cpic_solid_guard(m, s, __builtin_ctz(B) / 2, i0 + (size_t)j, x0, imp);
            if (excess > 0) {
                c->guard_caught[slot]++;
                if (excess > c->guard_depth[slot]) c->guard_depth[slot] = excess;
            }
        }
    }
}

/* ---- the last leg: the guard's pose against the body's own -------------------
 * The guard follows each path to the body's pose at the substep's end, and
 * a dynamic body's is predicted from its velocity (kf_cpic_guard_poses);
 * the material's impulses, its joints and contacts then move it a little
 * differently. A paddle hinged at its centre of mass is predicted to fall
 * g Δt² in a substep (1e-7 m at Δt 1e-4 s) and does not, so between the
 * pose the guard placed a particle against and the one the body takes, the
 * particle moves that much in the body's frame, unguarded: one that ended
 * closer to the surface than that (in sand_paddles, a grain sliding into a
 * paddle ended 6e-8 m in front of its predicted plane, 3e-8 m behind its
 * real one) ends on the far side, and the next substep's guard, starting
 * there, sees no crossing. So after the bodies have moved, each particle
 * with affinity to a body that did not end at the guard's pose is followed
 * along that last leg too, from where it is in the frame of the pose the
 * guard used to where it is in the body's own, and put back as the guard
 * puts back (on its own side, at least a hundredth of a cell from the
 * plane: far above the float rounding of its position); no velocity
 * changes (the body has taken its impulses; the next substep's guard
 * stops any approach). Its tag is then re-synced at the body's own pose,
 * where the audit and the next substep read it. Every particle's path
 * relative to a body is then guarded without a gap, substep after substep.
 * Static and kinematic bodies end exactly at the pose the guard used. */

/* whether a body ended exactly at the pose the guard placed particles against */
static int pose_kept(const kf_rigid_state *own, const kf_rigid_state *guarded) {
    for (int k = 0; k < 9; k++)
        if (own->R[k] != guarded->R[k]) return 0;
    for (int a = 0; a < 3; a++)
        if (own->t[a] != guarded->t[a]) return 0;
    return 1;
}

/* One particle's last leg relative to thin body r; 1 when it crossed there
 * (and was put back; *depth: how far behind it would have been, m). */
static int settle_particle(const kf_model *m, kf_state *s, int r, size_t i, double *depth) {
    const kf_rigid_body *b = &m->rigid[r];
    const kf_cpic *c = s->cpic;
    const kf_rigid_state *own = &s->rigid[r];
    kf_particles *p = &s->p;
    double x[3] = {p->x[0][i], p->x[1][i], p->x[2][i]}, pg[3], po[3], d[3];
    kf_guard_to_mesh(&c->end[r], x, pg);
    kf_guard_to_mesh(own, x, po);
    for (int a = 0; a < 3; a++) d[a] = po[a] - pg[a];
    /* a leg no longer than half a lattice cell's side, between two cells
     * that each lie strictly on one side of every triangle that can be
     * closest to them (the same side), or that have none within reach,
     * crosses nothing: a triangle it crosses is within its length of both
     * ends, so it is among both cells' candidates, with both ends in front
     * of its plane (or behind it) */
    const struct kf_cpic_sides *sd = &c->sides[r];
    int known = KF_SIDES_MIXED, clean = 0;
    if (sd->v) {
        const size_t at = sides_cell(sd, po);
        known = sides_value(sd, b, at);
        if (known != KF_SIDES_MIXED && kf_v3d_dot(d, d) <= 0.25 * sd->h * sd->h) {
            const size_t from = sides_cell(sd, pg);
            clean = from == at || sides_value(sd, b, from) == known;
        }
    }
    double side_n[3], side;
    if (clean || !put_back(b, pg, po, 0.01 * m->sim.dx, (double)p->vol0[i], depth, side_n, &side)) {
        /* it stays: its tag against the body's own pose (known: its cell's value there) */
        retag_at(m, s, r, i, po, known);
        return 0;
    }
    const uint32_t bits = 3u << (2 * r), want = (2u << (2 * r)) | (side < 0 ? 1u << (2 * r) : 0);
    p->colour[i] = (p->colour[i] & ~bits) | want;
    double xw[3];
    kf_m3d_mv(xw, own->R, po);
    for (int a = 0; a < 3; a++) p->x[a][i] = (kf_real)(xw[a] + own->t[a]);
    retag(m, s, r, i, own);
    return 1;
}

void kf_cpic_guard_settle(const kf_model *m, kf_state *s) {
    kf_cpic *c = s->cpic;
    if (!c) return;
    /* the affinity bits of the thin bodies that did not end where the guard placed them */
    uint32_t moved = 0;
    for (int r = 0; r < m->nrigid; r++) {
        const kf_rigid_body *b = &m->rigid[r];
        if (b->bvh && b->def.thin && !pose_kept(&s->rigid[r], &c->end[r])) moved |= 2u << (2 * r);
    }
    if (!moved) return;
    kf_particles *p = &s->p;
    const size_t n = p->n;
    long caught = 0;
    double deepest = 0;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) reduction(+ : caught) reduction(max : deepest)
    for (size_t i = 0; i < n; i++)
        for (uint32_t B = p->colour[i] & moved; B; B &= B - 1) {
            double depth = 0;
            if (!settle_particle(m, s, __builtin_ctz(B) / 2, i, &depth)) continue;
            caught++;
            if (depth > deepest) deepest = depth;
        }
    /* with the guard's own, in the frame log's count of crossings put back
     * (across ranks, this rank's) */
    c->caught += caught;
    if (deepest > c->caught_depth) c->caught_depth = deepest;
}

/* ---- the audit: who is on the wrong side now --------------------------------
 * Independent of the grid: each particle with affinity to a body is compared
 * with the exact triangle closest to it (within 1.5 cells; where that point
 * lies on an edge or a corner, the particle is beside the surface, not
 * behind it). Its colour records a side; the triangle's plane says which
 * side it is on. The frame log reports the count after every frame. A
 * solid is audited against its own promise (kf_cpic_solid_audit): material
 * touching a solid overlaps its surface slightly by design, which is
 * contact; a particle deeper inside than the guard allows is across. */
long kf_state_thin_audit(const kf_model *m, const kf_state *s, double *deepest_cells) {
    const kf_particles *p = &s->p;
    const double dx = m->sim.dx;
    long across = 0;
    double deepest = 0;
    for (int r = 0; r < m->nrigid; r++) {
        const kf_rigid_body *b = &m->rigid[r];
        if (b->bvh && !b->def.thin) {
            double d = 0;
            across += kf_cpic_solid_audit(m, s, r, &d);
            deepest = d > deepest ? d : deepest;
        }
        if (!b->bvh || !b->def.thin) continue;
        const uint32_t abit = 2u << (2 * r), tbit = 1u << (2 * r);
        const size_t n = p->n;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) reduction(+ : across) reduction(max : deepest)
        for (size_t i = 0; i < n; i++) {
            if (!(p->colour[i] & abit)) continue;
            double x[3] = {p->x[0][i], p->x[1][i], p->x[2][i]}, pm[3], q[3], nrm[3], off;
            kf_guard_to_mesh(&s->rigid[r], x, pm);
            int interior = 0, k = kf_rigid_bvh_closest(b->bvh, pm, 1.5 * dx, q, &interior);
            if (k < 0 || !interior) continue;
            kf_guard_tri_plane(b, b->guard_tri[k], nrm, &off);
            double u = kf_v3d_dot(nrm, pm) - off;
            int behind = (p->colour[i] & tbit) ? u > 0 : u < 0;
            if (!behind) continue;
            across++;
            if (fabs(u) / dx > deepest) deepest = fabs(u) / dx;
        }
    }
    if (deepest_cells) *deepest_cells = deepest;
    return across;
}
