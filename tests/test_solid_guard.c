/* test_solid_guard.c — material does not pass through a solid, however thin
 * (src/cpic/solid_guard.c), at the defaults a shot gets:
 *   - a block of sand, water, jelly or goo falls onto a static solid slab
 *     0.6 cells thick (thinner than the grid resolves, as sand_stir's bowl
 *     base at preview): no particle ever gets below the slab, and none is
 *     deeper in it than its allowance (0.4 of its thickness) at any
 *     substep's end (the slab reaches past the domain's walls: nothing goes
 *     around it);
 *   - a free thin solid plate in empty space, hit by a jelly block, keeps
 *     the total momentum of plate and jelly (every correction's impulse goes
 *     to the plate) and nothing passes through it;
 *   - a jelly block resting on a thick solid: the guard never acts (contact
 *     is the grid's; the guard only bounds what the grid cannot hold);
 *   - kerf's audit counts a particle deeper in a solid than allowed.
 * Positions are checked against the exact faces of the box, not kerf's grid. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "kt.h"
#include "scene_util.h"

#define DX 0.02
#define SLAB_Y 0.3                /* the slab's bottom face */
#define SLAB_T (0.6 * DX)         /* its thickness: 0.6 cells */
#define SLAB_ALLOW (0.4 * SLAB_T) /* the deepest a particle's centre may be behind its top face */

/* A closed box from lo to hi: 8 corners, 12 triangles wound so that every
 * normal points out of the box. */
static void box_mesh(const double lo[3], const double hi[3], double vert[24], int tri[36]) {
    for (int v = 0; v < 8; v++) {
        vert[3 * v] = v & 4 ? hi[0] : lo[0];
        vert[3 * v + 1] = v & 2 ? hi[1] : lo[1];
        vert[3 * v + 2] = v & 1 ? hi[2] : lo[2];
    }
    /* per axis and side, the face's four corners in a cycle */
    static const int quad[6][4] = {{0, 1, 3, 2}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 3, 7, 6}, {0, 2, 6, 4}, {1, 3, 7, 5}};
    for (int f = 0; f < 6; f++) {
        const int *q = quad[f], axis = f / 2;
        int t[6] = {q[0], q[1], q[2], q[0], q[2], q[3]};
        /* flip both triangles if the first one's normal points into the box */
        const double *a = &vert[3 * t[0]], *b = &vert[3 * t[1]], *c = &vert[3 * t[2]];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        const double out = f % 2 ? 1 : -1;
        if (n[axis] * out < 0) {
            int s = t[1];
            t[1] = t[2], t[2] = s;
            s = t[4], t[4] = t[5], t[5] = s;
        }
        memcpy(&tri[6 * f], t, sizeof t);
    }
}

/* a solid box body with the defaults a shot leaves (penalty and push auto) */
static void add_box(kf_model *m, const char *name, const double lo[3], const double hi[3], kf_rigid_motion motion,
                    double density) {
    static double vert[KF_MAX_RIGIDS][24];
    static int tri[KF_MAX_RIGIDS][36];
    const int r = kf_model_rigid_count(m);
    box_mesh(lo, hi, vert[r], tri[r]);
    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "%s", name);
    d.vertices = vert[r], d.nvertices = 8, d.triangles = tri[r], d.ntriangles = 12;
    d.motion = motion;
    d.density = density;
    d.boundary = KF_BOUNDARY_SEPARATE;
    d.friction = 0.3;
    d.penalty = KF_RIGID_AUTO, d.push = KF_RIGID_AUTO;
    char err[256];
    KT_CHECK(kf_model_add_rigid(m, &d, err, sizeof err) >= 0, "%s: %s", name, err);
}

/* one substep under the default CFL rule; 0 or 1 on trouble (reported) */
static int step(const kf_model *m, kf_state *s, double cfl, kf_step_stats *st, const char *what) {
    kf_trouble tr;
    if (kf_step(m, s, kf_stable_dt(m, s, cfl), st, &tr) == 0) return 0;
    KT_CHECK(0, "%s: numerical trouble at substep %ld: %s", what, st->substeps, tr.what);
    return 1;
}

/* A block falls at v0 onto the thin static slab and comes to rest on it. */
static void slab_holds(const char *preset, double v0) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = DX;
    sd.walls = 1;
    int mat;
    kf_model *m = tu_model(&sd, preset, 0, -1, 0, &mat);
    /* past the domain's walls on every side: nothing can go around it */
    const double slo[3] = {-0.1, SLAB_Y, -0.1}, shi[3] = {1.1, SLAB_Y + SLAB_T, 1.1};
    add_box(m, "slab", slo, shi, KF_RIGID_STATIC, 0);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.38, SLAB_Y + SLAB_T + 0.01, 0.38}, hi[3] = {0.62, SLAB_Y + SLAB_T + 0.13, 0.62},
           v[3] = {0, -v0, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v, 2, 7);
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    long through = 0;
    double deepest = 0, t = 0;
    while (t < 0.3 && !step(m, s, sd.cfl, &st, preset)) {
        t = kf_state_time(s);
        kf_particles_view pv = kf_state_particles_read(s);
        for (size_t i = 0; i < pv.n; i++) {
            const double y = pv.x[1][i];
            if (y < SLAB_Y) through++;
            else deepest = fmax(deepest, SLAB_Y + SLAB_T - y);
        }
    }
    printf("  %-5s falling at %4.1f m/s onto a slab of %.1f cells: %ld substeps, %ld particle-substeps below it, "
           "deepest %.3f cells into it (allowed %.3f), %ld put back\n",
           preset, v0, SLAB_T / DX, st.substeps, through, deepest / DX, SLAB_ALLOW / DX, st.thin_caught);
    double audit_deep = 0;
    const long audit = kf_state_thin_audit(m, s, &audit_deep);
    KT_CHECK(through == 0, "%s at %g m/s: nothing gets below the slab (%ld particle-substeps did)", preset, v0,
             through);
    KT_CHECK(audit == 0, "%s at %g m/s: kerf's audit finds nobody too deep at the end (%ld, %.3f cells)", preset, v0,
             audit, audit_deep);
    /* the allowance, to float rounding of a position near 0.3 m */
    KT_CHECK(deepest <= SLAB_ALLOW + 1e-6, "%s at %g m/s: nobody deeper than %.3f cells into the slab (%.4f)", preset,
             v0, SLAB_ALLOW / DX, deepest / DX);
    kf_state_destroy(s);
    kf_model_destroy(m);
}

static void slab_sand(void) {
    slab_holds("sand", 1);
    slab_holds("sand", 6);
}
static void slab_water(void) { slab_holds("water", 6); }
static void slab_jelly(void) { slab_holds("jello", 6); }
static void slab_goo(void) { slab_holds("goo", 6); }

/* A free solid plate 0.6 cells thick (normal x) in empty space, no gravity,
 * hit by a jelly block at 3 m/s: the plate is pushed, the total momentum
 * stays where it was to float round-off, and no particle gets past the
 * plate's far face (in the plate's own frame, over its face). */
static void free_plate_momentum(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = DX;
    sd.gravity[1] = 0;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    const double plo[3] = {0.6, 0.35, 0.35}, phi[3] = {0.6 + SLAB_T, 0.65, 0.65};
    add_box(m, "plate", plo, phi, KF_RIGID_DYNAMIC, 300); /* 0.32 kg */
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.45, 0.42, 0.42}, hi[3] = {0.58, 0.58, 0.58}, v[3] = {3, 0.2, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v, 2, 9);
    double P0[3], P[3], drift = 0;
    tu_total_momentum(m, s, P0);
    const double scale = sqrt(P0[0] * P0[0] + P0[1] * P0[1] + P0[2] * P0[2]);
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    long past = 0;
    for (int k = 0; k < 400; k++) {
        kf_trouble tr;
        if (kf_step(m, s, 2e-4, &st, &tr)) {
            KT_CHECK(0, "substep %d: %s", k, tr.what);
            break;
        }
        tu_total_momentum(m, s, P);
        for (int a = 0; a < 3; a++) drift = fmax(drift, fabs(P[a] - P0[a]) / scale);
        /* each particle in the plate's mesh frame (x_world = R x_mesh + t) */
        kf_rigid_pose pose = kf_state_rigid(s, 0);
        kf_particles_view pv = kf_state_particles_read(s);
        for (size_t i = 0; i < pv.n; i++) {
            double q[3] = {pv.x[0][i] - pose.t[0], pv.x[1][i] - pose.t[1], pv.x[2][i] - pose.t[2]}, xm[3];
            for (int a = 0; a < 3; a++) xm[a] = pose.R[a] * q[0] + pose.R[3 + a] * q[1] + pose.R[6 + a] * q[2];
            if (xm[0] > phi[0] && xm[1] > plo[1] && xm[1] < phi[1] && xm[2] > plo[2] && xm[2] < phi[2]) past++;
        }
    }
    kf_rigid_pose pose = kf_state_rigid(s, 0);
    printf("  free plate: v = %.4f m/s after the hit, %ld put back, momentum drift %.2e of |P0| = %.4f kg m/s, %ld "
           "particle-substeps past its far face\n",
           pose.v[0], st.thin_caught, drift, scale, past);
    KT_CHECK(pose.v[0] > 0.5, "the block pushed the plate (v = %g m/s)", pose.v[0]);
    KT_CHECK(past == 0, "nothing passed through the plate (%ld particle-substeps past its far face)", past);
    /* float particle sums over 400 substeps, as test_thin's free sheet */
    KT_NEAR(drift, 0, 1e-5, "relative drift of the total linear momentum (float sums over 400 substeps)");
    kf_state_destroy(s);
    kf_model_destroy(m);
}

/* A jelly block dropped onto a thick solid (5 cells) settles on it: the
 * grid holds it, and the guard never has to. */
static void contact_left_to_grid(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = DX;
    sd.walls = 1;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    const double slo[3] = {0.1, 0.2, 0.1}, shi[3] = {0.9, 0.3, 0.9};
    add_box(m, "table", slo, shi, KF_RIGID_STATIC, 0);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.4, 0.31, 0.4}, hi[3] = {0.6, 0.41, 0.6}, v[3] = {0, -1, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v, 2, 5);
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    double lowest = 1e9;
    while (kf_state_time(s) < 0.5 && !step(m, s, sd.cfl, &st, "jelly on a table")) {
        kf_particles_view pv = kf_state_particles_read(s);
        for (size_t i = 0; i < pv.n; i++) lowest = fmin(lowest, pv.x[1][i]);
    }
    printf("  jelly on a table: %ld substeps, lowest particle %.3f cells above its top, %ld put back by the guard\n",
           st.substeps, (lowest - shi[1]) / DX, st.thin_caught);
    KT_CHECK(st.thin_caught == 0, "resting contact is left to the grid (%ld put back)", st.thin_caught);
    KT_CHECK(lowest > shi[1] - 0.5 * DX, "nothing sank half a cell into the table (lowest %.3f cells)",
             (lowest - shi[1]) / DX);
    kf_state_destroy(s);
    kf_model_destroy(m);
}

/* kerf's own audit (kf_state_thin_audit, the frame log's "across") counts a
 * particle deeper in a solid than the guard allows, and not one in contact:
 * a jelly block on a table 5 cells thick (allowance half a cell), one
 * particle moved 0.3 cells into it and one 0.7 cells. */
static void audit_sees_too_deep(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = DX;
    sd.gravity[1] = 0;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    const double slo[3] = {0.3, 0.2, 0.3}, shi[3] = {0.7, 0.3, 0.7};
    add_box(m, "table", slo, shi, KF_RIGID_STATIC, 0);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.4, 0.31, 0.4}, hi[3] = {0.6, 0.41, 0.6}, v0[3] = {0, 0, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v0, 2, 3);
    kf_step(m, s, 1e-4, NULL, NULL); /* colours and the guard's tables are made in the first substep */
    double deep;
    long before = kf_state_thin_audit(m, s, &deep);
    KT_CHECK(before == 0, "nobody too deep after a substep (%ld)", before);
    /* the two coloured particles nearest the table's top, near its middle */
    kf_particles_view pv = kf_state_particles(s);
    size_t pick[2] = {0, 0};
    double best[2] = {1, 1};
    for (size_t i = 0; i < pv.n; i++) {
        if (!(pv.colour[i] & 2) || fabs(pv.x[0][i] - 0.5) > 0.05 || fabs(pv.x[2][i] - 0.5) > 0.05) continue;
        const double h = pv.x[1][i] - shi[1];
        if (h < best[0]) best[1] = best[0], pick[1] = pick[0], best[0] = h, pick[0] = i;
        else if (h < best[1]) best[1] = h, pick[1] = i;
    }
    pv.x[1][pick[0]] = (kf_real)(shi[1] - 0.3 * DX);
    pv.x[1][pick[1]] = (kf_real)(shi[1] - 0.7 * DX);
    long after = kf_state_thin_audit(m, s, &deep);
    KT_CHECK(after == 1, "the audit finds the one particle deeper than half a cell (%ld)", after);
    KT_NEAR(deep, 0.7, 1e-3, "at the depth it was put, in cells (float positions)");
    kf_state_destroy(s);
    kf_model_destroy(m);
}

int main(int argc, char **argv) {
    KT_RUN(slab_sand, argc, argv);
    KT_RUN(slab_water, argc, argv);
    KT_RUN(slab_jelly, argc, argv);
    KT_RUN(slab_goo, argc, argv);
    KT_RUN(free_plate_momentum, argc, argv);
    KT_RUN(contact_left_to_grid, argc, argv);
    KT_RUN(audit_sees_too_deep, argc, argv);
    return KT_EXIT();
}
