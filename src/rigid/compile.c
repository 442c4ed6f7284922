/* compile.c — a rigid def becomes a body: checked, mesh copied, mass
 * properties computed (dynamic), surface seeded (paper §5.2.1). */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "bvh.h"
#include "mass.h"
#include "rigid.h"
#include "thin.h"

static int fail(char *err, size_t errlen, const char *fmt, ...) {
    if (err && errlen) {
        va_list ap;
        va_start(ap, fmt);
        vsnprintf(err, errlen, fmt, ap);
        va_end(ap);
    }
    return -1;
}

static int finite3(const double v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

/* twice the area of triangle t */
static double tri_area2(const double *v, const int *t) {
    const double *a = v + 3 * t[0], *b = v + 3 * t[1], *c = v + 3 * t[2];
    double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
    return sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
}

static int cmp_edge(const void *a, const void *b) {
    const long long *x = a, *y = b;
    return (*x > *y) - (*x < *y);
}

/* closed (every edge is shared by exactly two non-degenerate triangles,
 * used once in each direction): the divergence theorem needs it */
static int closed_mesh(const int *tri, int ntri, int nvert) {
    long long *e = malloc(sizeof(long long) * 3 * (size_t)ntri);
    if (!e) return 0;
    for (int t = 0; t < ntri; t++)
        for (int k = 0; k < 3; k++) e[3 * t + k] = (long long)tri[3 * t + k] * nvert + tri[3 * t + (k + 1) % 3];
    size_t n = 3 * (size_t)ntri;
    qsort(e, n, sizeof *e, cmp_edge);
    int ok = 1;
    for (size_t i = 0; i < n && ok; i++) {
        if (i + 1 < n && e[i + 1] == e[i]) ok = 0; /* the same directed edge twice */
        long long a = e[i] / nvert, b = e[i] % nvert, rev = b * nvert + a;
        if (ok && !bsearch(&rev, e, n, sizeof *e, cmp_edge)) ok = 0; /* a border edge */
    }
    free(e);
    return ok;
}

static int check(const kf_rigid_def *d, double dx, char *err, size_t errlen) {
    const char *nm = d->name[0] ? d->name : "(unnamed)";
    if (!(dx > 0) || !isfinite(dx)) return fail(err, errlen, "rigid %s: grid spacing dx must be positive", nm);
    if (!d->vertices || d->nvertices < 3) return fail(err, errlen, "rigid %s: needs at least 3 vertices", nm);
    if (!d->triangles || d->ntriangles < 1) return fail(err, errlen, "rigid %s: needs at least one triangle", nm);
    if (d->motion < KF_RIGID_STATIC || d->motion > KF_RIGID_DYNAMIC)
        return fail(err, errlen, "rigid %s: unknown motion %d", nm, (int)d->motion);
    for (int i = 0; i < d->nvertices; i++)
        if (!finite3(d->vertices + 3 * i)) return fail(err, errlen, "rigid %s: vertex %d is not finite", nm, i);
    int nondegenerate = 0;
    double ext = 0;
    for (int i = 0; i < 3 * d->nvertices; i++) ext = fmax(ext, fabs(d->vertices[i]));
    for (int t = 0; t < d->ntriangles; t++) {
        for (int k = 0; k < 3; k++) {
            int v = d->triangles[3 * t + k];
            if (v < 0 || v >= d->nvertices)
                return fail(err, errlen, "rigid %s: triangle %d uses vertex %d, outside [0, %d)", nm, t, v,
                            d->nvertices);
        }
        /* degenerate: area below round-off of the mesh's extent */
        if (tri_area2(d->vertices, d->triangles + 3 * t) > 1e-12 * ext * ext) nondegenerate++;
    }
    if (!nondegenerate) return fail(err, errlen, "rigid %s: every triangle is degenerate (zero area)", nm);
    if (!finite3(d->center) || !finite3(d->position) || !finite3(d->rotate) || !finite3(d->velocity) ||
        !finite3(d->angular_velocity))
        return fail(err, errlen, "rigid %s: center, position, rotate, velocity and angular_velocity must be finite",
                    nm);
    if (!isfinite(d->friction) || d->friction < 0) return fail(err, errlen, "rigid %s: friction must be >= 0", nm);
    if (!isfinite(d->penalty) || (d->penalty < 0 && d->penalty != KF_RIGID_AUTO))
        return fail(err, errlen, "rigid %s: penalty must be >= 0 (or auto)", nm);
    if (!isfinite(d->push) || (d->push < 0 && d->push != KF_RIGID_AUTO))
        return fail(err, errlen, "rigid %s: push must be >= 0 (or auto)", nm);
    if (d->motion == KF_RIGID_KINEMATIC) {
        if (d->nkeys < 0 || d->nkeys > KF_MAX_KEYS)
            return fail(err, errlen, "rigid %s: %d keys, at most %d", nm, d->nkeys, KF_MAX_KEYS);
        for (int k = 0; k < d->nkeys; k++) {
            const kf_key *key = &d->keys[k];
            if (!isfinite(key->time) || !finite3(key->position) || !finite3(key->rotate))
                return fail(err, errlen, "rigid %s: key %d is not finite", nm, k);
            if (k > 0 && !(key->time > d->keys[k - 1].time))
                return fail(err, errlen, "rigid %s: key times must increase (key %d)", nm, k);
        }
    }
    if (d->motion == KF_RIGID_DYNAMIC) {
        if (!(d->density > 0) || !isfinite(d->density))
            return fail(err, errlen, "rigid %s: a dynamic body needs density > 0", nm);
        if (!d->thin && !closed_mesh(d->triangles, d->ntriangles, d->nvertices))
            return fail(err, errlen,
                        "rigid %s: a dynamic solid must be a closed, consistently wound mesh (or make it thin: true)",
                        nm);
    }
    return 0;
}

/* The triangles the crossing guard (src/cpic/guard.c) keeps material from
 * passing through, in an Embree scene. All of them, except on a closed thin
 * body (a blade with two faces), whose narrow sides facing across its axis
 * are the sheet's edges: CPIC treats such a body as one sheet with a front
 * and a back (thin.c), whose edges the two sides share. Those triangles are
 * marked (tri_edge) and the colored distance field leaves them out too: a
 * node below a blade's 2 mm bottom face would otherwise take its side from
 * that face's plane, which says nothing about front and back, and material
 * under the edge would acquire that side. */
static int guard_surface(kf_rigid_body *b, const double axis[3]) {
    int *keep = malloc(sizeof(int) * 3 * (size_t)b->ntri);
    b->guard_tri = malloc(sizeof(int) * (size_t)b->ntri);
    b->tri_edge = calloc((size_t)b->ntri, 1);
    if (!keep || !b->guard_tri || !b->tri_edge) return free(keep), -1;
    const int sheet = axis[0] != 0 || axis[1] != 0 || axis[2] != 0;
    int n = 0;
    for (int t = 0; t < b->ntri; t++) {
        const int *f = &b->tri[3 * t];
        const double *p0 = &b->vert[3 * f[0]], *p1 = &b->vert[3 * f[1]], *p2 = &b->vert[3 * f[2]];
        double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]},
               e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
        double nn[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        double a2 = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
        if (sheet && fabs(nn[0] * axis[0] + nn[1] * axis[1] + nn[2] * axis[2]) < 0.3 * a2) {
            b->tri_edge[t] = 1; /* an edge */
            continue;
        }
        memcpy(&keep[3 * n], f, 3 * sizeof(int));
        b->guard_tri[n++] = t;
    }
    b->nguard_tri = n;
    /* a blade's thickness: its extent along the axis */
    if (sheet) {
        double lo = 1e300, hi = -1e300;
        for (int v = 0; v < b->nvert; v++) {
            double x = b->vert[3 * v] * axis[0] + b->vert[3 * v + 1] * axis[1] + b->vert[3 * v + 2] * axis[2];
            lo = x < lo ? x : lo, hi = x > hi ? x : hi;
        }
        b->sheet_thickness = hi - lo;
    }
    char why[160];
    b->bvh = n ? kf_rigid_bvh_build(b->vert, b->nvert, keep, n, why, sizeof why) : NULL;
    free(keep);
    return n && !b->bvh ? -1 : 0;
}

int kf_rigid_compile(kf_rigid_body *b, const kf_rigid_def *d, double dx, char *err, size_t errlen) {
    memset(b, 0, sizeof *b);
    if (check(d, dx, err, errlen)) return -1;
    const char *nm = d->name[0] ? d->name : "(unnamed)";
    b->def = *d;
    b->nvert = d->nvertices;
    b->ntri = d->ntriangles;
    b->vert = malloc(sizeof(double) * 3 * (size_t)b->nvert);
    b->tri = malloc(sizeof(int) * 3 * (size_t)b->ntri);
    if (!b->vert || !b->tri) {
        kf_rigid_body_free(b);
        return fail(err, errlen, "rigid %s: out of memory", nm);
    }
    memcpy(b->vert, d->vertices, sizeof(double) * 3 * (size_t)b->nvert);
    memcpy(b->tri, d->triangles, sizeof(int) * 3 * (size_t)b->ntri);
    b->def.vertices = b->vert;
    b->def.triangles = b->tri;
    /* a closed thin body (a blade with two faces) gets one front and one back */
    double sheet_axis[3] = {0, 0, 0};
    if (d->thin && closed_mesh(b->tri, b->ntri, b->nvert) &&
        kf_rigid_orient_thin(b->vert, b->nvert, b->tri, b->ntri, dx, nm, err, errlen, sheet_axis)) {
        kf_rigid_body_free(b);
        return -1;
    }

    if (d->motion == KF_RIGID_DYNAMIC) {
        kf_mass_props mp;
        if (d->thin) kf_mass_shell(b->vert, b->tri, b->ntri, d->density, &mp);
        else kf_mass_solid(b->vert, b->tri, b->ntri, d->density, &mp);
        if (!(mp.measure > 0) || !(mp.mass > 0)) {
            kf_rigid_body_free(b);
            return fail(err, errlen,
                        d->thin ? "rigid %s: the shell has no area"
                                : "rigid %s: the solid has volume %g <= 0 (inside out? wind counter-clockwise seen "
                                  "from outside)",
                        nm, mp.measure);
        }
        b->mass = mp.mass;
        memcpy(b->com, mp.com, sizeof b->com);
        memcpy(b->inertia, mp.inertia, sizeof b->inertia);
    } else {
        memcpy(b->com, d->center, sizeof b->com);
    }

    for (int v = 0; v < b->nvert; v++) {
        const double *x = &b->vert[3 * v];
        double d2 = (x[0] - b->com[0]) * (x[0] - b->com[0]) + (x[1] - b->com[1]) * (x[1] - b->com[1]) +
                    (x[2] - b->com[2]) * (x[2] - b->com[2]);
        if (d2 > b->reach * b->reach) b->reach = sqrt(d2);
    }

    /* rigid particles at half the grid spacing (paper §5.2.1: finer than dx);
     * about 3.5 per spacing² of area (the lattice's three axes) plus one per
     * small triangle: refuse a surface that would need more than 2e7 (a mesh
     * in the wrong units, most likely) rather than run out of memory */
    const double spacing = 0.5 * dx;
    double area = 0;
    for (int t = 0; t < b->ntri; t++) area += 0.5 * tri_area2(b->vert, b->tri + 3 * t);
    double estimate = 3.5 * area / (spacing * spacing) + b->ntri;
    if (estimate > 2e7) {
        kf_rigid_body_free(b);
        return fail(err, errlen,
                    "rigid %s: its surface (%.3g m²) would need about %.2g rigid particles at dx = %g (at most 2e7): "
                    "is the mesh in metres?",
                    nm, area, estimate, dx);
    }
    b->nseed = kf_rigid_seed_surface(b->vert, b->nvert, b->tri, b->ntri, spacing, &b->seed, &b->seed_tri);
    if (!b->nseed) {
        kf_rigid_body_free(b);
        return fail(err, errlen, "rigid %s: could not seed the surface", nm);
    }
    if (guard_surface(b, sheet_axis)) {
        kf_rigid_body_free(b);
        return fail(err, errlen, "rigid %s: could not index the surface for the crossing guard", nm);
    }
    return 0;
}

void kf_rigid_body_free(kf_rigid_body *b) {
    free(b->vert);
    free(b->tri);
    free(b->seed);
    free(b->seed_tri);
    kf_rigid_bvh_free(b->bvh);
    free(b->guard_tri);
    free(b->tri_edge);
    b->bvh = NULL, b->guard_tri = NULL, b->tri_edge = NULL;
    b->vert = NULL, b->tri = NULL, b->seed = NULL, b->seed_tri = NULL;
    b->nseed = 0;
}
