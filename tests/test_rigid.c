/* test_rigid.c — rigid bodies for CPIC (src/rigid): mass properties against
 * analytic values and a Monte-Carlo estimate, kinematic velocities against
 * finite differences of the pose, and the MuJoCo-backed solver: free fall,
 * impulses, hinges, resting contact and bit-identical resume from a saved
 * state. Surface seeding has its own test_seed.c. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <kerf/kerf.h>
#include "kt.h"
#include "mesh_util.h"
#include "random_util.h"
#include "rigid/mass.h"
#include "rigid/mjcf.h"
#include "rigid/rigid.h"
#include "scene/mesh.h"

/* ---- meshes ------------------------------------------------------------- */

/* an axis-aligned box [lo, hi], 12 triangles wound counter-clockwise outside */
static const int BOX_TRI[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3};
static void box_vertices(const double lo[3], const double hi[3], double v[24]) {
    for (int i = 0; i < 8; i++) {
        int x = (i == 1 || i == 2 || i == 5 || i == 6), y = (i == 2 || i == 3 || i == 6 || i == 7), z = i >= 4;
        v[3 * i] = x ? hi[0] : lo[0], v[3 * i + 1] = y ? hi[1] : lo[1], v[3 * i + 2] = z ? hi[2] : lo[2];
    }
}

static kf_rigid_def box_def(const double lo[3], const double hi[3], double v[24], kf_rigid_motion motion) {
    box_vertices(lo, hi, v);
    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "box");
    d.vertices = v, d.nvertices = 8, d.triangles = BOX_TRI, d.ntriangles = 12;
    d.motion = motion;
    d.density = 1000;
    return d;
}

/* ---- mass properties ------------------------------------------------------ */

/* unit cube of density 1000: M = 1000, I = M/6 on the diagonal, no products */
static void test_mass_unit_cube(void) {
    double v[24];
    kf_rigid_def d = box_def((double[3]){0, 0, 0}, (double[3]){1, 1, 1}, v, KF_RIGID_DYNAMIC);
    kf_rigid_body b;
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b, &d, 0.25, err, sizeof err) == 0, "%s", err);
    KT_NEAR(b.mass, 1000, 1e-9, "exact polynomial integration, round-off only");
    for (int a = 0; a < 3; a++) KT_NEAR(b.com[a], 0.5, 1e-12, "exact");
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) KT_NEAR(b.inertia[3 * i + j], i == j ? 1000.0 / 6 : 0, 1e-9, "exact");
    kf_rigid_body_free(&b);
}

/* a box off the origin, then the same box turned by a random rotation Q:
 * com → Q com, I → Q I Qᵀ (so every product of inertia is exercised) */
static void test_mass_box_off_centre(void) {
    const double lo[3] = {1, -1, 2}, hi[3] = {3, 0, 2.5}, e[3] = {2, 1, 0.5};
    double v[24];
    box_vertices(lo, hi, v);
    kf_mass_props mp;
    kf_mass_solid(v, BOX_TRI, 12, 7.5, &mp);
    const double M = 7.5 * e[0] * e[1] * e[2];
    const double I0[3] = {M * (e[1] * e[1] + e[2] * e[2]) / 12, M * (e[0] * e[0] + e[2] * e[2]) / 12,
                          M * (e[0] * e[0] + e[1] * e[1]) / 12};
    KT_NEAR(mp.mass, M, 1e-12 * M, "exact");
    for (int a = 0; a < 3; a++) KT_NEAR(mp.com[a], 0.5 * (lo[a] + hi[a]), 1e-12, "exact");
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            KT_NEAR(mp.inertia[3 * i + j], i == j ? I0[i] : 0, 1e-11 * M, "exact; round-off of |x|² ~ 10 m²");
    double Q[9];
    random_rotation(Q);
    double w[24];
    for (int k = 0; k < 8; k++)
        for (int i = 0; i < 3; i++)
            w[3 * k + i] = Q[3 * i] * v[3 * k] + Q[3 * i + 1] * v[3 * k + 1] + Q[3 * i + 2] * v[3 * k + 2];
    kf_mass_solid(w, BOX_TRI, 12, 7.5, &mp);
    KT_NEAR(mp.mass, M, 1e-12 * M, "exact");
    double c0[3] = {2, -0.5, 2.25};
    for (int i = 0; i < 3; i++)
        KT_NEAR(mp.com[i], Q[3 * i] * c0[0] + Q[3 * i + 1] * c0[1] + Q[3 * i + 2] * c0[2], 1e-12, "exact");
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double want = 0;
            for (int k = 0; k < 3; k++) want += Q[3 * i + k] * I0[k] * Q[3 * j + k];
            KT_NEAR(mp.inertia[3 * i + j], want, 1e-11 * M, "exact up to round-off");
        }
}

/* assets/sphere.obj: a UV sphere (64 x 32, angular step δ = π/32) with its
 * vertices on a sphere of radius R. The inscribed polyhedron lies within
 * s = R (1 - cos(δ/√2)) ≈ 2.4e-3 R of the sphere (a facet's centre is δ/√2
 * from its corners), so volume and second moments are low by at most 3 s/R
 * and 5 s/R relative, and never high. */
static void test_mass_sphere(void) {
    tu_loaded_mesh L;
    if (tu_load_mesh("assets/sphere.obj", &L)) return;
    /* radius of the vertices */
    double R = 0;
    for (size_t i = 0; i < L.m.nvert; i++) {
        const double *p = L.m.vert + 3 * i;
        R = fmax(R, sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]));
    }
    kf_mass_props mp;
    kf_mass_solid(L.m.vert, L.tri, (int)L.m.ntri, 1000, &mp);
    const double PI = 3.14159265358979323846, sag = 1 - cos(PI / 32 / sqrt(2));
    const double M = 1000 * 4.0 / 3 * PI * R * R * R, I = 0.4 * M * R * R;
    printf("  sphere R = %g: mass %.6g (analytic %.6g), Ixx %.6g (analytic %.6g)\n", R, mp.mass, M, mp.inertia[0], I);
    KT_CHECK(mp.mass <= M && mp.mass >= M * (1 - 3 * sag), "mass %g vs %g", mp.mass, M);
    KT_NEAR(mp.mass / 1000, L.m.volume, 1e-9 * L.m.volume, "the mesh loader's own divergence-theorem volume");
    for (int a = 0; a < 3; a++) KT_NEAR(mp.com[a], 0, 1e-9 * R, "symmetric mesh");
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            if (i == j)
                KT_CHECK(mp.inertia[4 * i] <= I * (1 + 1e-9) && mp.inertia[4 * i] >= I * (1 - 5 * sag),
                         "I%d%d = %g vs %g", i, i, mp.inertia[4 * i], I);
            else KT_NEAR(mp.inertia[3 * i + j], 0, 1e-9 * I, "symmetric mesh");
        }
    tu_free_mesh(&L);
}

/* the asymmetric tetrahedron of cpic-notes §8.7, where a known formula swaps
 * I_xy and I_xz: our products of inertia against a Monte-Carlo estimate with
 * N uniform samples; tolerance 5 standard errors (σ/√N from the samples) */
static void test_mass_tetra_monte_carlo(void) {
    const double V[12] = {0, 0, 0, 1, .2, .1, .3, 1.1, .2, .1, .4, .9};
    const int T[12] = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
    kf_mass_props mp;
    kf_mass_solid(V, T, 4, 1, &mp);
    if (mp.measure < 0) { /* wound inward: flip */
        const int T2[12] = {0, 1, 2, 0, 3, 1, 0, 2, 3, 1, 3, 2};
        kf_mass_solid(V, T2, 4, 1, &mp);
    }
    const double *a = V + 3, *b = V + 6, *c = V + 9;
    double det =
        a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
    KT_NEAR(mp.measure, fabs(det) / 6, 1e-15, "exact volume");
    const long N = 2000000;
    double sum[3] = {0}, sum2[9] = {0}, sq[9] = {0};
    for (long n = 0; n < N; n++) {
        /* uniform in the tetrahedron: sorted uniforms give barycentric weights */
        double u[3] = {urand(), urand(), urand()};
        for (int i = 0; i < 2; i++)
            for (int j = 0; j < 2 - i; j++)
                if (u[j] > u[j + 1]) {
                    double t = u[j];
                    u[j] = u[j + 1], u[j + 1] = t;
                }
        double w[3] = {u[0], u[1] - u[0], u[2] - u[1]}, x[3];
        for (int k = 0; k < 3; k++) x[k] = w[0] * a[k] + w[1] * b[k] + w[2] * c[k];
        for (int i = 0; i < 3; i++) {
            sum[i] += x[i];
            for (int j = 0; j < 3; j++) sum2[3 * i + j] += x[i] * x[j], sq[3 * i + j] += x[i] * x[i] * x[j] * x[j];
        }
    }
    const double M = mp.mass;
    double mean[3];
    for (int i = 0; i < 3; i++) mean[i] = sum[i] / N;
    for (int i = 0; i < 3; i++) KT_NEAR(mp.com[i], mean[i], 2e-3, "Monte-Carlo mean, σ/√N ≈ 3e-4");
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            if (i == j) continue;
            /* product of inertia −M E[(x_i − c_i)(x_j − c_j)] = −M (E[x_i x_j] − c_i c_j) */
            double exx = sum2[3 * i + j] / N, var = sq[3 * i + j] / N - exx * exx;
            double est = -M * (exx - mean[i] * mean[j]);
            double tol = 5 * M * sqrt(var / N) + 5 * M * 3e-4 * (fabs(mean[i]) + fabs(mean[j]));
            KT_NEAR(mp.inertia[3 * i + j], est, tol, "5 standard errors of the Monte-Carlo estimate");
            /* about the origin the products are 100x larger than about the com: the sharper test
             * of which entry is which (−M E[x_i x_j], standard error M σ/√N) */
            double orig = mp.inertia[3 * i + j] - M * mp.com[i] * mp.com[j], to = 5 * M * sqrt(var / N);
            KT_NEAR(orig, -M * exx, to, "5 standard errors of the Monte-Carlo estimate");
            if (j == i + 1 || (i == 0 && j == 2))
                printf("  tetra I_%c%c: about the com %.5f (Monte-Carlo %.5f ± %.1e), about the origin %.5f (%.5f ± "
                       "%.1e)\n",
                       "xyz"[i], "xyz"[j], mp.inertia[3 * i + j], est, tol / 5, orig, -M * exx, to / 5);
        }
    /* and the values cpic-notes §8.7 quotes from its Monte-Carlo run (density 1, about the
     * origin: −∫x_i x_j dV = I_ij(com) − M c_i c_j), which a swapped formula gets backwards */
    KT_NEAR(mp.inertia[1] - M * mp.com[0] * mp.com[1], -0.02126, 1e-4, "cpic-notes §8.7, 4 digits");
    KT_NEAR(mp.inertia[2] - M * mp.com[0] * mp.com[2], -0.01386, 1e-4, "cpic-notes §8.7, 4 digits");
}

/* a unit square shell of area density 2: M = 2, Ixx = Iyy = M/12, Izz = M/6 */
static void test_mass_shell_plate(void) {
    const double v[12] = {0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0};
    const int t[6] = {0, 1, 2, 0, 2, 3};
    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    d.vertices = v, d.nvertices = 4, d.triangles = t, d.ntriangles = 2, d.thin = 1, d.motion = KF_RIGID_DYNAMIC;
    d.density = 2;
    kf_rigid_body b;
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == 0, "%s", err);
    KT_NEAR(b.mass, 2, 1e-12, "exact");
    KT_NEAR(b.com[0], 0.5, 1e-12, "exact");
    KT_NEAR(b.com[1], 0.5, 1e-12, "exact");
    KT_NEAR(b.inertia[0], 2.0 / 12, 1e-12, "exact");
    KT_NEAR(b.inertia[4], 2.0 / 12, 1e-12, "exact");
    KT_NEAR(b.inertia[8], 2.0 / 6, 1e-12, "exact");
    KT_NEAR(b.inertia[1], 0, 1e-12, "exact");
    kf_rigid_body_free(&b);
}

/* bad defs are refused with the reason */
static void test_compile_errors(void) {
    double v[24];
    kf_rigid_def d = box_def((double[3]){0, 0, 0}, (double[3]){1, 1, 1}, v, KF_RIGID_DYNAMIC);
    kf_rigid_body b;
    char err[256];
    int tri[36];
    memcpy(tri, BOX_TRI, sizeof tri);
    d.triangles = tri;
    /* open: drop the last triangle */
    d.ntriangles = 11;
    err[0] = 0;
    KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == -1 && strstr(err, "closed"), "%s", err);
    d.ntriangles = 12;
    /* inside out */
    for (int k = 0; k < 12; k++) {
        int s = tri[3 * k + 1];
        tri[3 * k + 1] = tri[3 * k + 2], tri[3 * k + 2] = s;
    }
    err[0] = 0;
    KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == -1 && strstr(err, "volume"), "%s", err);
    memcpy(tri, BOX_TRI, sizeof tri);
    d.density = 0;
    err[0] = 0;
    KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == -1 && strstr(err, "density"), "%s", err);
    d.density = 1;
    tri[4] = 8;
    err[0] = 0;
    KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == -1 && strstr(err, "vertex 8"), "%s", err);
    tri[4] = BOX_TRI[4];
    v[5] = NAN;
    err[0] = 0;
    KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == -1 && strstr(err, "not finite"), "%s", err);
    v[5] = 0;
    /* every triangle degenerate */
    const double flat[9] = {0, 0, 0, 1, 1, 1, 2, 2, 2};
    const int ft[3] = {0, 1, 2};
    d.vertices = flat, d.nvertices = 3, d.triangles = ft, d.ntriangles = 1, d.motion = KF_RIGID_STATIC;
    err[0] = 0;
    KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == -1 && strstr(err, "degenerate"), "%s", err);
    d.ntriangles = 0;
    err[0] = 0;
    KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == -1 && strstr(err, "triangle"), "%s", err);
    /* a 1 km box at dx = 1 cm (millimetres read as metres): refused before seeding */
    double big[24];
    kf_rigid_def huge = box_def((double[3]){0, 0, 0}, (double[3]){1000, 1000, 1000}, big, KF_RIGID_STATIC);
    err[0] = 0;
    KT_CHECK(kf_rigid_compile(&b, &huge, 0.01, err, sizeof err) == -1 && strstr(err, "in metres"), "%s", err);
}

/* y = R x + t */
static void apply(const double R[9], const double x[3], const double t[3], double y[3]) {
    for (int i = 0; i < 3; i++) y[i] = R[3 * i] * x[0] + R[3 * i + 1] * x[1] + R[3 * i + 2] * x[2] + t[i];
}

/* ---- kinematics ----------------------------------------------------------- */

/* the velocity of a material point and ω against central differences of the
 * pose: error O(h²) (third derivatives of the motion are ~100 here, so
 * ~1e-8 at h = 1e-5; round-off ~1e-16/h = 1e-11) */
static void check_fd(const kf_rigid_body *b, double t, const char *what) {
    const double h = 1e-5, xm[3] = {0.3, -0.2, 0.7};
    kf_rigid_state s0, s1, sm;
    kf_rigid_state_at(b, t - h, &s0);
    kf_rigid_state_at(b, t + h, &s1);
    kf_rigid_state_at(b, t, &sm);
    double x0[3], x1[3], x[3], v[3];
    apply(s0.R, xm, s0.t, x0);
    apply(s1.R, xm, s1.t, x1);
    apply(sm.R, xm, sm.t, x);
    kf_rigid_point_velocity(&sm, x, v);
    for (int a = 0; a < 3; a++) KT_NEAR(v[a], (x1[a] - x0[a]) / (2 * h), 1e-6, what);
    for (int a = 0; a < 3; a++) KT_NEAR(sm.v[a], (s1.com[a] - s0.com[a]) / (2 * h), 1e-6, what);
    /* [ω]× = Ṙ Rᵀ */
    double W[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            W[3 * i + j] = 0;
            for (int k = 0; k < 3; k++) W[3 * i + j] += (s1.R[3 * i + k] - s0.R[3 * i + k]) / (2 * h) * sm.R[3 * j + k];
        }
    KT_NEAR(sm.w[0], W[7], 1e-6, what);
    KT_NEAR(sm.w[1], W[2], 1e-6, what);
    KT_NEAR(sm.w[2], W[3], 1e-6, what);
}

static void test_kinematic(void) {
    double v[24];
    kf_rigid_def d = box_def((double[3]){0, 0, 0}, (double[3]){1, 0.5, 0.2}, v, KF_RIGID_KINEMATIC);
    d.center[0] = 0.5, d.center[1] = 0.25, d.center[2] = 0.1;
    /* keys: turning about every axis, smooth and linear */
    d.nkeys = 3;
    const double kt[3] = {0, 0.5, 1.2}, kp[3][3] = {{0, 0, 0}, {0.3, 0.1, -0.2}, {0.5, -0.4, 0.1}},
                 kr[3][3] = {{0, 0, 0}, {40, -20, 60}, {90, 30, -45}};
    for (int k = 0; k < 3; k++) {
        d.keys[k].time = kt[k];
        memcpy(d.keys[k].position, kp[k], sizeof kp[k]);
        memcpy(d.keys[k].rotate, kr[k], sizeof kr[k]);
    }
    for (int interp = 0; interp < 2; interp++) {
        d.interp = interp ? KF_INTERP_SMOOTH : KF_INTERP_LINEAR;
        kf_rigid_body b;
        char err[256] = "";
        KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == 0, "%s", err);
        KT_NEAR(b.mass, 0, 0, "kinematic bodies carry no mass");
        for (int a = 0; a < 3; a++) KT_NEAR(b.com[a], d.center[a], 0, "com = pivot");
        check_fd(&b, 0.23, interp ? "smooth keys" : "linear keys");
        check_fd(&b, 0.81, interp ? "smooth keys" : "linear keys");
        /* at a key, the pivot is where the key says */
        kf_rigid_state st;
        kf_rigid_state_at(&b, 0.5, &st);
        for (int a = 0; a < 3; a++) KT_NEAR(st.com[a], kp[1][a], 1e-12, "pivot at the key");
        double x[3];
        apply(st.R, d.center, st.t, x);
        for (int a = 0; a < 3; a++) KT_NEAR(x[a], kp[1][a], 1e-12, "x = R x_mesh + t maps the pivot to the key");
        kf_rigid_body_free(&b);
    }
    /* no keys: constant velocity and angular velocity from the time-0 pose */
    d.nkeys = 0;
    d.position[0] = 1, d.rotate[1] = 30;
    d.velocity[0] = 0.5, d.velocity[2] = -1;
    d.angular_velocity[0] = 2, d.angular_velocity[1] = -1, d.angular_velocity[2] = 0.5;
    kf_rigid_body b;
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == 0, "%s", err);
    check_fd(&b, 0.4, "constant motion");
    kf_rigid_state st;
    kf_rigid_state_at(&b, 0.4, &st);
    for (int a = 0; a < 3; a++) KT_NEAR(st.w[a], d.angular_velocity[a], 0, "constant ω");
    KT_NEAR(st.com[0], 1 + 0.5 * 0.4, 1e-15, "pivot moves at the velocity");
    kf_rigid_body_free(&b);
    /* static: x = position + R (x_mesh - center), R = Rz Ry Rx */
    d.motion = KF_RIGID_STATIC;
    d.rotate[0] = 90, d.rotate[1] = 0, d.rotate[2] = 90;
    KT_CHECK(kf_rigid_compile(&b, &d, 0.1, err, sizeof err) == 0, "%s", err);
    kf_rigid_state_at(&b, 3, &st);
    /* Rx(90) takes e_y to e_z, then Rz(90) leaves e_z: the mesh's +y points up z */
    double p[3], q[3] = {d.center[0], d.center[1] + 1, d.center[2]};
    apply(st.R, q, st.t, p);
    KT_NEAR(p[0], 1, 1e-12, "Rz Ry Rx order");
    KT_NEAR(p[1], 0, 1e-12, "Rz Ry Rx order");
    KT_NEAR(p[2], 1, 1e-12, "Rz Ry Rx order");
    /* and Rx(90) then Rz(90) takes e_x to e_y */
    double q2[3] = {d.center[0] + 1, d.center[1], d.center[2]};
    apply(st.R, q2, st.t, p);
    KT_NEAR(p[0], 1, 1e-12, "Rz Ry Rx order");
    KT_NEAR(p[1], 1, 1e-12, "Rz Ry Rx order");
    for (int a = 0; a < 3; a++) KT_NEAR(st.v[a] + st.w[a], 0, 0, "static bodies do not move");
    kf_rigid_body_free(&b);
}

/* ---- the solver --------------------------------------------------------- */

/* a dynamic box in free fall from rest, no walls: MuJoCo's semi-implicit
 * Euler gives y_n = -g dt² n(n+1)/2 = -½gt² - ½g dt t exactly (so ½gt² to
 * within ½g dt t), v_n = -g t; orientation and angular velocity unchanged */
static void test_free_fall(void) {
    double v[24];
    kf_rigid_def d = box_def((double[3]){-0.1, -0.05, -0.05}, (double[3]){0.1, 0.05, 0.05}, v, KF_RIGID_DYNAMIC);
    d.position[1] = 1;
    d.rotate[2] = 30;
    kf_rigid_body b;
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b, &d, 0.05, err, sizeof err) == 0, "%s", err);
    const double g = 9.81, dt = 1e-3;
    kf_rigid_sim *sim = kf_rigid_sim_create(&b, 1, NULL, 0, (double[3]){0, -g, 0}, NULL, err, sizeof err);
    KT_CHECK(sim != NULL, "%s", err);
    if (!sim) return;
    kf_rigid_state st;
    kf_rigid_state_at(&b, 0, &st);
    const double R0[9] = {st.R[0], st.R[1], st.R[2], st.R[3], st.R[4], st.R[5], st.R[6], st.R[7], st.R[8]};
    const int N = 500;
    for (int n = 0; n < N; n++) kf_rigid_sim_step(sim, &b, 1, &st, n * dt, dt, NULL);
    const double t = N * dt;
    KT_NEAR(st.com[1], 1 - 0.5 * g * t * t - 0.5 * g * dt * t, 1e-9, "semi-implicit Euler, exactly");
    KT_NEAR(st.com[1], 1 - 0.5 * g * t * t, 0.5 * g * dt * t * 1.0001, "½gt² to first order in dt");
    KT_NEAR(st.v[1], -g * t, 1e-9, "exact");
    KT_NEAR(st.com[0], 0, 1e-12, "no sideways force");
    for (int k = 0; k < 9; k++) KT_NEAR(st.R[k], R0[k], 1e-12, "no torque");
    /* t and com agree: the com in the mesh frame maps to com */
    double c[3];
    apply(st.R, b.com, st.t, c);
    for (int a = 0; a < 3; a++) KT_NEAR(c[a], st.com[a], 1e-12, "x = R x_mesh + t");
    kf_rigid_sim_destroy(sim);
    kf_rigid_body_free(&b);
}

/* one substep with impulses J and L on a turned off-centre box at rest, no
 * gravity: Δv = J/M and Δω = I_w⁻¹ L with I_w = R I Rᵀ (ω starts at 0, so
 * there is no gyroscopic term; the turn during the substep is about ω itself
 * and leaves the world ω unchanged) */
static void test_impulse(void) {
    double v[24];
    kf_rigid_def d = box_def((double[3]){0.1, -0.05, 0.2}, (double[3]){0.4, 0.05, 0.3}, v, KF_RIGID_DYNAMIC);
    d.rotate[0] = 20, d.rotate[1] = -35, d.rotate[2] = 50;
    d.position[0] = 0.5;
    kf_rigid_body b;
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b, &d, 0.05, err, sizeof err) == 0, "%s", err);
    kf_rigid_sim *sim = kf_rigid_sim_create(&b, 1, NULL, 0, (double[3]){0, 0, 0}, NULL, err, sizeof err);
    KT_CHECK(sim != NULL, "%s", err);
    if (!sim) return;
    kf_rigid_state st;
    kf_rigid_state_at(&b, 0, &st);
    double R[9];
    memcpy(R, st.R, sizeof R);
    const double imp[1][6] = {{0.3, -0.2, 0.5, 0.01, 0.02, -0.015}};
    kf_rigid_sim_step(sim, &b, 1, &st, 0, 1e-3, imp);
    for (int a = 0; a < 3; a++) KT_NEAR(st.v[a], imp[0][a] / b.mass, 1e-12, "Δv = J/M");
    /* I_w ω = L */
    double RI[9], Iw[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            RI[3 * i + j] = 0;
            for (int k = 0; k < 3; k++) RI[3 * i + j] += R[3 * i + k] * b.inertia[3 * k + j];
        }
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            Iw[3 * i + j] = 0;
            for (int k = 0; k < 3; k++) Iw[3 * i + j] += RI[3 * i + k] * R[3 * j + k];
        }
    double Imax = b.inertia[0] + b.inertia[4] + b.inertia[8];
    for (int i = 0; i < 3; i++) {
        double Lw = Iw[3 * i] * st.w[0] + Iw[3 * i + 1] * st.w[1] + Iw[3 * i + 2] * st.w[2];
        KT_NEAR(Lw, imp[0][3 + i],
                1e-8 * Imax * sqrt(st.w[0] * st.w[0] + st.w[1] * st.w[1] + st.w[2] * st.w[2]) + 1e-14,
                "I_w Δω = L; MuJoCo's inertia is ours plus 1e-9 tr(I) (flat-shell guard)");
    }
    kf_rigid_sim_destroy(sim);
    kf_rigid_body_free(&b);
}

/* a box hinged to the world, and a second box hinged to the first: under
 * gravity they swing; the anchors stay put (world hinge) and together (body
 * hinge), and each hinge axis stays the same material line */
static void test_hinge(void) {
    double v0[24], v1[24];
    kf_rigid_def d0 = box_def((double[3]){0, -0.02, -0.02}, (double[3]){0.3, 0.02, 0.02}, v0, KF_RIGID_DYNAMIC);
    kf_rigid_def d1 = box_def((double[3]){0, -0.02, -0.02}, (double[3]){0.2, 0.02, 0.02}, v1, KF_RIGID_DYNAMIC);
    d0.position[1] = 1;
    d1.position[0] = 0.3, d1.position[1] = 1, d1.rotate[2] = -40;
    kf_rigid_body b[2];
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b[0], &d0, 0.05, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_rigid_compile(&b[1], &d1, 0.05, err, sizeof err) == 0, "%s", err);
    kf_joint_def j[2] = {{.body_a = -1, .body_b = 0, .anchor = {0, 1, 0}, .axis = {0, 0, 1}, .damping = 0},
                         {.body_a = 0, .body_b = 1, .anchor = {0.3, 1, 0}, .axis = {0, 0.6, 0.8}, .damping = 0.001}};
    kf_rigid_sim *sim = kf_rigid_sim_create(b, 2, j, 2, (double[3]){0, -9.81, 0}, NULL, err, sizeof err);
    KT_CHECK(sim != NULL, "%s", err);
    if (!sim) return;
    kf_rigid_state st[2];
    for (int r = 0; r < 2; r++) kf_rigid_state_at(&b[r], 0, &st[r]);
    /* the anchors and axes in each mesh frame at time 0 */
    double a0[3] = {0, 0, 0}, a1[3] = {0, 0, 0}, ax0[3] = {0, 0, 1}, ax1[3];
    double w[3] = {0.3 - st[0].t[0], 1 - st[0].t[1], 0 - st[0].t[2]}, a01[3];
    for (int i = 0; i < 3; i++) a01[i] = st[0].R[i] * w[0] + st[0].R[3 + i] * w[1] + st[0].R[6 + i] * w[2];
    double w1[3] = {0.3 - st[1].t[0], 1 - st[1].t[1], -st[1].t[2]};
    for (int i = 0; i < 3; i++) a1[i] = st[1].R[i] * w1[0] + st[1].R[3 + i] * w1[1] + st[1].R[6 + i] * w1[2];
    for (int i = 0; i < 3; i++) ax1[i] = st[1].R[i] * 0 + st[1].R[3 + i] * 0.6 + st[1].R[6 + i] * 0.8;
    double ax10[3];
    for (int i = 0; i < 3; i++) ax10[i] = st[0].R[i] * 0 + st[0].R[3 + i] * 0.6 + st[0].R[6 + i] * 0.8;
    (void)a0;
    double swing = 0;
    for (int n = 0; n < 400; n++) {
        kf_rigid_sim_step(sim, b, 2, st, n * 1e-3, 1e-3, NULL);
        swing = fmax(swing, fabs(st[0].w[2]));
    }
    KT_CHECK(swing > 1, "the arm swings: max |ω_z| = %g rad/s", swing);
    double p[3], q[3], zero[3] = {0, 0, 0};
    apply(st[0].R, zero, st[0].t, p); /* mesh origin of body 0 is the world anchor */
    KT_NEAR(p[0], 0, 1e-9, "world hinge anchor");
    KT_NEAR(p[1], 1, 1e-9, "world hinge anchor");
    KT_NEAR(p[2], 0, 1e-9, "world hinge anchor");
    double axw[3];
    for (int i = 0; i < 3; i++)
        axw[i] = st[0].R[3 * i] * ax0[0] + st[0].R[3 * i + 1] * ax0[1] + st[0].R[3 * i + 2] * ax0[2];
    KT_NEAR(axw[2], 1, 1e-9, "world hinge axis stays z");
    KT_NEAR(st[0].w[0], 0, 1e-9, "ω along the axis");
    KT_NEAR(st[0].w[1], 0, 1e-9, "ω along the axis");
    apply(st[0].R, a01, st[0].t, p);
    apply(st[1].R, a1, st[1].t, q);
    for (int i = 0; i < 3; i++) KT_NEAR(p[i], q[i], 1e-9, "body hinge anchor shared");
    double e0[3], e1[3];
    for (int i = 0; i < 3; i++) {
        e0[i] = st[0].R[3 * i] * ax10[0] + st[0].R[3 * i + 1] * ax10[1] + st[0].R[3 * i + 2] * ax10[2];
        e1[i] = st[1].R[3 * i] * ax1[0] + st[1].R[3 * i + 1] * ax1[1] + st[1].R[3 * i + 2] * ax1[2];
    }
    for (int i = 0; i < 3; i++) KT_NEAR(e0[i], e1[i], 1e-9, "body hinge axis shared");
    kf_rigid_sim_destroy(sim);
    for (int r = 0; r < 2; r++) kf_rigid_body_free(&b[r]);
}

static const double PI = 3.14159265358979323846;

/* the turn of a bar about z (its hinge), unwrapped against the previous value */
static double turn_z(const kf_rigid_state *st, double prev) {
    double a = atan2(st->R[3], st->R[0]);
    while (a - prev > PI) a -= 2 * PI;
    while (a - prev < -PI) a += 2 * PI;
    return a;
}

/* motors on a bar hinged to the world at its centre, no gravity:
 * - a velocity motor far from its target rate gives its torque limit L, so
 *   the bar spins up at exactly L / I (constant torque: Euler is exact), the
 *   logged torque and peak are L, and with the world as body_a the bar
 *   turns the other way (the motor turns body_a relative to body_b);
 * - a critically damped position servo (10 Hz) tracks its target angle
 *   angle + 360 frequency t: after 1 s at 0.25 Hz from 30 degrees, the bar
 *   is at 120 degrees. */
static void test_motor(void) {
    double v[24];
    kf_rigid_def d = box_def((double[3]){-0.15, -0.02, -0.02}, (double[3]){0.15, 0.02, 0.02}, v, KF_RIGID_DYNAMIC);
    kf_rigid_body b;
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b, &d, 0.05, err, sizeof err) == 0, "%s", err);
    const double Izz = b.inertia[8] + 1e-9 * (b.inertia[0] + b.inertia[4] + b.inertia[8]); /* MuJoCo's (mjcf.c) */
    const double zero_g[3] = {0, 0, 0}, L = 0.01, T = 0.5, dt = 1e-3;
    for (int flip = 0; flip < 2; flip++) {
        kf_joint_def j = {.body_a = flip ? -1 : 0,
                          .body_b = flip ? 0 : -1,
                          .axis = {0, 0, 1},
                          .motor = KF_MOTOR_VELOCITY,
                          .frequency = 1,
                          .kv = 10,
                          .torque_limit = L};
        kf_rigid_sim *sim = kf_rigid_sim_create(&b, 1, &j, 1, zero_g, NULL, err, sizeof err);
        KT_CHECK(sim != NULL, "%s", err);
        if (!sim) continue;
        kf_rigid_state st;
        kf_rigid_state_at(&b, 0, &st);
        for (int n = 0; n < (int)(T / dt + 0.5); n++) kf_rigid_sim_step(sim, &b, 1, &st, n * dt, dt, NULL);
        const double sign = flip ? -1 : 1;
        KT_NEAR(st.w[2], sign * L * T / Izz, 1e-9 * L * T / Izz, "spin-up at the torque limit: ω = L t / I");
        double now = 0, peak = 0;
        KT_CHECK(kf_rigid_sim_motor_torque(sim, 0, &now, &peak) == 0, "the joint has a motor");
        KT_NEAR(now, L, 1e-12, "the torque is at its limit");
        KT_NEAR(peak, L, 1e-12, "and so is its peak");
        KT_CHECK(st.w[2] * sign < 2 * PI, "still below the target rate (%g rad/s)", st.w[2]);
        kf_rigid_sim_destroy(sim);
    }
    /* the position servo */
    const double wn = 2 * PI * 10, kp = Izz * wn * wn, kv = 2 * Izz * wn;
    kf_joint_def j = {.body_a = 0,
                      .body_b = -1,
                      .axis = {0, 0, 1},
                      .motor = KF_MOTOR_POSITION,
                      .frequency = 0.25,
                      .angle = 30,
                      .kp = kp,
                      .kv = kv,
                      .torque_limit = 1e3};
    kf_rigid_sim *sim = kf_rigid_sim_create(&b, 1, &j, 1, zero_g, NULL, err, sizeof err);
    KT_CHECK(sim != NULL, "%s", err);
    if (sim) {
        kf_rigid_state st;
        kf_rigid_state_at(&b, 0, &st);
        double a = 0;
        for (int n = 0; n < 1000; n++) {
            kf_rigid_sim_step(sim, &b, 1, &st, n * dt, dt, NULL);
            a = turn_z(&st, a);
        }
        KT_NEAR(a, 120 * PI / 180, 1e-6, "the servo is on its target, 30 + 360 x 0.25 x 1 degrees");
        KT_NEAR(st.w[2], 2 * PI * 0.25, 1e-6, "turning at the commanded rate");
        double now = 1, peak = 0;
        kf_rigid_sim_motor_torque(sim, 0, &now, &peak);
        KT_NEAR(now, 0, 1e-6, "no torque once on target (no load)");
        KT_CHECK(peak > 0 && peak < 1e3, "the peak (the start: 30 degrees off) is below the limit: %g N m", peak);
        kf_rigid_sim_destroy(sim);
    }
    kf_rigid_body_free(&b);
}

/* a bar hinged to a kinematic post that moves sideways at 0.2 m/s: the
 * hinge is two ball-joint equalities (MuJoCo's soft constraints, time
 * constant 4 ms: the anchor gives ~a τ² = 0.4 mm under the swing's ~25 m/s²),
 * so anchor and axis hold to within a millimetre and a hundredth of a
 * radian while the bar swings and is carried along */
static void test_hinge_to_kinematic(void) {
    double v0[24], v1[24];
    kf_rigid_def post = box_def((double[3]){-0.02, -0.02, -0.1}, (double[3]){0.02, 0.02, 0.1}, v0, KF_RIGID_KINEMATIC);
    post.position[1] = 1, post.velocity[0] = 0.2;
    kf_rigid_def bar = box_def((double[3]){0, -0.01, -0.01}, (double[3]){0.3, 0.01, 0.01}, v1, KF_RIGID_DYNAMIC);
    bar.position[0] = 0.05, bar.position[1] = 1;
    kf_rigid_body b[2];
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b[0], &post, 0.05, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_rigid_compile(&b[1], &bar, 0.05, err, sizeof err) == 0, "%s", err);
    kf_joint_def j = {.body_a = 0, .body_b = 1, .anchor = {0.05, 1, 0}, .axis = {0, 0, 1}};
    kf_rigid_sim *sim = kf_rigid_sim_create(b, 2, &j, 1, (double[3]){0, -9.81, 0}, NULL, err, sizeof err);
    KT_CHECK(sim != NULL, "%s", err);
    if (!sim) return;
    kf_rigid_state st[2];
    for (int r = 0; r < 2; r++) kf_rigid_state_at(&b[r], 0, &st[r]);
    double worst = 0, tilt = 0, swing = 0;
    const double zero[3] = {0, 0, 0}, ez[3] = {0, 0, 1};
    for (int k = 0; k < 1000; k++) {
        kf_rigid_sim_step(sim, b, 2, st, k * 1e-3, 1e-3, NULL);
        double p[3], q[3];
        apply(st[1].R, zero, st[1].t, p); /* the bar's mesh origin is the anchor */
        double post_anchor[3] = {0.05, 0, 0};
        apply(st[0].R, post_anchor, st[0].t, q);
        worst = fmax(
            worst, sqrt((p[0] - q[0]) * (p[0] - q[0]) + (p[1] - q[1]) * (p[1] - q[1]) + (p[2] - q[2]) * (p[2] - q[2])));
        double a[3];
        apply(st[1].R, ez, zero, a);
        tilt = fmax(tilt, acos(fmin(1, a[2])));
        swing = fmax(swing, fabs(st[1].w[2]));
    }
    printf("  bar on a moving post: anchor gap %.2g m, axis tilt %.2g rad, max |ω_z| %.2f rad/s\n", worst, tilt, swing);
    KT_CHECK(swing > 1, "it swings: %g rad/s", swing);
    KT_CHECK(worst < 1e-3, "anchor held: gap %g m", worst);
    KT_CHECK(tilt < 1e-2, "axis held: tilt %g rad", tilt);
    kf_rigid_sim_destroy(sim);
    for (int r = 0; r < 2; r++) kf_rigid_body_free(&b[r]);
}

/* a 10 cm cube dropped from 5 cm onto a static slab comes to rest on it:
 * after 1.5 s its velocity is below 0.1 mm/s and it sinks at most 0.1 mm
 * (MuJoCo's soft contact, solref 4 ms: measured 1 µm and 1e-5 m/s) */
static void test_rest_on_static(void) {
    double v0[24], v1[24];
    kf_rigid_def slab = box_def((double[3]){-0.5, -0.1, -0.5}, (double[3]){0.5, 0, 0.5}, v0, KF_RIGID_STATIC);
    kf_rigid_def cube = box_def((double[3]){-0.05, -0.05, -0.05}, (double[3]){0.05, 0.05, 0.05}, v1, KF_RIGID_DYNAMIC);
    cube.position[1] = 0.1;
    cube.rotate[1] = 10;
    kf_rigid_body b[2];
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b[0], &slab, 0.05, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_rigid_compile(&b[1], &cube, 0.05, err, sizeof err) == 0, "%s", err);
    kf_rigid_sim *sim = kf_rigid_sim_create(b, 2, NULL, 0, (double[3]){0, -9.81, 0}, NULL, err, sizeof err);
    KT_CHECK(sim != NULL, "%s", err);
    if (!sim) return;
    kf_rigid_state st[2];
    for (int r = 0; r < 2; r++) kf_rigid_state_at(&b[r], 0, &st[r]);
    double dt = 1e-3;
    for (int n = 0; n < 1500; n++) kf_rigid_sim_step(sim, b, 2, st, n * dt, dt, NULL);
    double lowest = INFINITY;
    for (int i = 0; i < 8; i++) {
        double p[3];
        apply(st[1].R, v1 + 3 * i, st[1].t, p);
        lowest = fmin(lowest, p[1]);
    }
    double speed = sqrt(st[1].v[0] * st[1].v[0] + st[1].v[1] * st[1].v[1] + st[1].v[2] * st[1].v[2]);
    printf("  resting cube: lowest corner y = %.3g m, speed %.3g m/s, com y %.6f\n", lowest, speed, st[1].com[1]);
    KT_CHECK(lowest > -1e-4 && lowest < 1e-4, "sinks at most 0.1 mm, no gap: lowest corner %g", lowest);
    KT_CHECK(speed < 1e-4, "at rest: %g m/s", speed);
    KT_NEAR(st[1].R[4], 1, 1e-4, "lies flat on a face");
    /* the static body never moved */
    KT_NEAR(st[0].t[1], 0, 0, "static");
    kf_rigid_sim_destroy(sim);
    for (int r = 0; r < 2; r++) kf_rigid_body_free(&b[r]);
}

/* a cube dropped into an open static box (a thin, concave container: its
 * convex hull would hold the cube out) settles on the container's floor.
 * Concave bodies collide as prisms 2h thick, h = 2e-3 of their size, so
 * the cube rests between the floor and h above it. */
static void test_rest_in_container(void) {
    double v0[24], v1[24];
    kf_rigid_def tray = box_def((double[3]){-0.15, 0, -0.15}, (double[3]){0.15, 0.2, 0.15}, v0, KF_RIGID_STATIC);
    /* drop the top face: the two triangles with every corner at y = 0.2 */
    int open_tri[30];
    int n = 0;
    for (int t = 0; t < 12; t++) {
        int top = 1;
        for (int k = 0; k < 3; k++) top &= v0[3 * BOX_TRI[3 * t + k] + 1] == 0.2;
        if (!top)
            for (int k = 0; k < 3; k++) open_tri[n++] = BOX_TRI[3 * t + k];
    }
    KT_CHECK(n == 30, "10 triangles left");
    tray.triangles = open_tri, tray.ntriangles = 10, tray.thin = 1;
    kf_rigid_def cube = box_def((double[3]){-0.05, -0.05, -0.05}, (double[3]){0.05, 0.05, 0.05}, v1, KF_RIGID_DYNAMIC);
    cube.position[1] = 0.12, cube.rotate[1] = 20, cube.velocity[0] = 0.3;
    kf_rigid_body b[2];
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b[0], &tray, 0.05, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_rigid_compile(&b[1], &cube, 0.05, err, sizeof err) == 0, "%s", err);
    kf_rigid_sim *sim = kf_rigid_sim_create(b, 2, NULL, 0, (double[3]){0, -9.81, 0}, NULL, err, sizeof err);
    KT_CHECK(sim != NULL, "%s", err);
    if (!sim) return;
    kf_rigid_state st[2];
    for (int r = 0; r < 2; r++) kf_rigid_state_at(&b[r], 0, &st[r]);
    for (int k = 0; k < 2000; k++) kf_rigid_sim_step(sim, b, 2, st, k * 1e-3, 1e-3, NULL);
    double lowest = INFINITY, h = 2e-3 * sqrt(0.3 * 0.3 * 2 + 0.2 * 0.2);
    for (int i = 0; i < 8; i++) {
        double p[3];
        apply(st[1].R, v1 + 3 * i, st[1].t, p);
        lowest = fmin(lowest, p[1]);
    }
    double speed = sqrt(st[1].v[0] * st[1].v[0] + st[1].v[1] * st[1].v[1] + st[1].v[2] * st[1].v[2]);
    printf("  cube in a tray: lowest corner y = %.4g m (prism half thickness %.3g), x %.3f, speed %.2g m/s\n", lowest,
           h, st[1].com[0], speed);
    KT_CHECK(lowest > -1e-4 && lowest < h + 1e-4, "rests on the floor inside: lowest corner %g", lowest);
    KT_CHECK(fabs(st[1].com[0]) < 0.1 && fabs(st[1].com[2]) < 0.1, "inside the walls: com %g %g", st[1].com[0],
             st[1].com[2]);
    KT_CHECK(speed < 1e-3, "at rest: %g m/s", speed);
    kf_rigid_sim_destroy(sim);
    for (int r = 0; r < 2; r++) kf_rigid_body_free(&b[r]);
}

/* a box resting on a kinematic conveyor (moving at 0.5 m/s, no keys) is
 * dragged along by friction (μ = 0.5: it reaches the belt's speed u after
 * u/(μg) = 0.1 s, lagging u²/(2μg) = 25.5 mm behind the belt) and rides on
 * it: contacts see the kinematic body's velocity */
static void test_conveyor(void) {
    double v0[24], v1[24];
    kf_rigid_def belt = box_def((double[3]){-1, -0.05, -0.3}, (double[3]){1, 0, 0.3}, v0, KF_RIGID_KINEMATIC);
    belt.velocity[0] = 0.5;
    kf_rigid_def box = box_def((double[3]){-0.05, -0.05, -0.05}, (double[3]){0.05, 0.05, 0.05}, v1, KF_RIGID_DYNAMIC);
    box.position[1] = 0.05;
    kf_rigid_body b[2];
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b[0], &belt, 0.05, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_rigid_compile(&b[1], &box, 0.05, err, sizeof err) == 0, "%s", err);
    kf_rigid_sim *sim = kf_rigid_sim_create(b, 2, NULL, 0, (double[3]){0, -9.81, 0}, NULL, err, sizeof err);
    KT_CHECK(sim != NULL, "%s", err);
    if (!sim) return;
    kf_rigid_state st[2];
    for (int r = 0; r < 2; r++) kf_rigid_state_at(&b[r], 0, &st[r]);
    for (int k = 0; k < 1000; k++) kf_rigid_sim_step(sim, b, 2, st, k * 1e-3, 1e-3, NULL);
    printf("  box on a conveyor: v = %.4f %.2g %.2g m/s, x = %.4f (belt at %.4f), y = %.5f\n", st[1].v[0], st[1].v[1],
           st[1].v[2], st[1].com[0], st[0].com[0], st[1].com[1]);
    KT_NEAR(st[0].com[0], 0.5, 1e-12, "the belt moves as told");
    KT_NEAR(st[1].v[0], 0.5, 5e-3, "the box rides at the belt's speed (1%)");
    KT_NEAR(st[1].com[1], 0.05, 1e-4, "on the belt");
    KT_NEAR(st[0].com[0] - st[1].com[0], 0.25 / (2 * 0.5 * 9.81), 1e-3, "lag u²/(2μg); 1 mm for the soft contact");
    kf_rigid_sim_destroy(sim);
    for (int r = 0; r < 2; r++) kf_rigid_body_free(&b[r]);
}

/* a cube thrown sideways in a closed domain [0, 1]³ ends resting on the
 * floor plane, inside the walls. MuJoCo's contact is a critically damped
 * spring of time constant τ = 4 ms, so an impact at speed v overshoots by at
 * most v τ / e: 4.4 mm at the 3 m/s here (measured 2.2 mm). */
static void test_walls(void) {
    double v[24];
    kf_rigid_def cube = box_def((double[3]){-0.05, -0.05, -0.05}, (double[3]){0.05, 0.05, 0.05}, v, KF_RIGID_DYNAMIC);
    cube.position[0] = 0.5, cube.position[1] = 0.3, cube.position[2] = 0.5;
    cube.velocity[0] = 3, cube.velocity[2] = -2, cube.rotate[0] = 30, cube.rotate[2] = 15;
    kf_rigid_body b;
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b, &cube, 0.05, err, sizeof err) == 0, "%s", err);
    const double walls[6] = {0, 0, 0, 1, 1, 1};
    kf_rigid_sim *sim = kf_rigid_sim_create(&b, 1, NULL, 0, (double[3]){0, -9.81, 0}, walls, err, sizeof err);
    KT_CHECK(sim != NULL, "%s", err);
    if (!sim) return;
    kf_rigid_state st;
    kf_rigid_state_at(&b, 0, &st);
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int k = 0; k < 3000; k++) {
        kf_rigid_sim_step(sim, &b, 1, &st, k * 1e-3, 1e-3, NULL);
        for (int i = 0; i < 8; i++) {
            double p[3];
            apply(st.R, v + 3 * i, st.t, p);
            for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], p[a]), hi[a] = fmax(hi[a], p[a]);
        }
    }
    printf("  thrown cube: corners in [%.4f %.4f %.4f] - [%.4f %.4f %.4f], rests at com y %.5f\n", lo[0], lo[1], lo[2],
           hi[0], hi[1], hi[2], st.com[1]);
    for (int a = 0; a < 3; a++) {
        KT_CHECK(lo[a] > -4.5e-3, "a corner went %g m through the wall %d (at most v τ / e)", lo[a], a);
        KT_CHECK(hi[a] < 1 + 4.5e-3, "a corner went %g m through the wall %d (at most v τ / e)", hi[a] - 1, a);
    }
    KT_NEAR(st.com[1], 0.05, 1e-4, "resting on the floor, sunk at most 0.1 mm");
    KT_CHECK(fabs(st.v[0]) + fabs(st.v[1]) + fabs(st.v[2]) < 1e-3, "at rest: v %g %g %g", st.v[0], st.v[1], st.v[2]);
    kf_rigid_sim_destroy(sim);
    kf_rigid_body_free(&b);
}

/* a bar spinning on a hinge to the world at its centre, in a unit box of
 * walls (mjcf.c walls_out_of_reach):
 * - hinged at the box's centre the walls are out of its reach: its model
 *   excludes the world, and its motion is bitwise the one without walls;
 * - hinged 0.1 m above the floor (the bar reaches 0.15 m) there is no
 *   exclude, and the floor stops the bar (no corner more than 4.5 mm below
 *   it, as in test_walls). */
static void test_hinge_walls(void) {
    double v[24];
    kf_rigid_def d = box_def((double[3]){-0.15, -0.02, -0.02}, (double[3]){0.15, 0.02, 0.02}, v, KF_RIGID_DYNAMIC);
    const double walls[6] = {0, 0, 0, 1, 1, 1}, g[3] = {0, -9.81, 0}, dt = 1e-3;
    for (int low = 0; low < 2; low++) {
        d.position[0] = 0.5, d.position[1] = low ? 0.1 : 0.5, d.position[2] = 0.5;
        d.angular_velocity[2] = 6;
        kf_rigid_body b;
        char err[256] = "";
        KT_CHECK(kf_rigid_compile(&b, &d, 0.05, err, sizeof err) == 0, "%s", err);
        kf_joint_def j = {.body_a = -1, .body_b = 0, .axis = {0, 0, 1}};
        memcpy(j.anchor, d.position, sizeof j.anchor);
        char *xml = kf_rigid_mjcf(&b, 1, &j, 1, g, walls, NULL, err, sizeof err);
        KT_CHECK(xml != NULL, "%s", err);
        const int excluded = xml && strstr(xml, "<exclude body1=\"world\" body2=\"b0\"/>") != NULL;
        KT_CHECK(excluded == !low, "hinged at y %.1f: the walls %s excluded", d.position[1], low ? "not" : "");
        free(xml);
        kf_rigid_sim *with = kf_rigid_sim_create(&b, 1, &j, 1, g, walls, err, sizeof err);
        kf_rigid_sim *without = kf_rigid_sim_create(&b, 1, &j, 1, g, NULL, err, sizeof err);
        KT_CHECK(with && without, "%s", err);
        if (with && without) {
            kf_rigid_state sw, so;
            kf_rigid_state_at(&b, 0, &sw);
            so = sw;
            double lowest = INFINITY;
            int same = 1;
            for (int n = 0; n < 500; n++) {
                kf_rigid_sim_step(with, &b, 1, &sw, n * dt, dt, NULL);
                kf_rigid_sim_step(without, &b, 1, &so, n * dt, dt, NULL);
                same &= !memcmp(&sw, &so, sizeof sw);
                for (int i = 0; i < 8; i++) {
                    double p[3];
                    apply(sw.R, v + 3 * i, sw.t, p);
                    lowest = fmin(lowest, p[1]);
                }
            }
            if (!low) KT_CHECK(same, "out of the walls' reach: bitwise the motion without walls");
            if (low) KT_CHECK(!same && lowest > -4.5e-3, "the floor stops the bar: lowest corner %g m", lowest);
        }
        kf_rigid_sim_destroy(with);
        kf_rigid_sim_destroy(without);
        kf_rigid_body_free(&b);
    }
}

/* the solver's own refusals come back as messages */
static void test_sim_errors(void) {
    double v0[24], v1[24];
    kf_rigid_def a = box_def((double[3]){0, 0, 0}, (double[3]){1, 1, 1}, v0, KF_RIGID_STATIC);
    kf_rigid_def c = box_def((double[3]){0, 0, 0}, (double[3]){1, 1, 1}, v1, KF_RIGID_DYNAMIC);
    kf_rigid_body b[2];
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b[0], &a, 0.25, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_rigid_compile(&b[1], &c, 0.25, err, sizeof err) == 0, "%s", err);
    kf_joint_def j = {.body_a = 0, .body_b = 0, .axis = {0, 0, 1}};
    err[0] = 0;
    KT_CHECK(!kf_rigid_sim_create(b, 2, &j, 1, (double[3]){0, 0, 0}, NULL, err, sizeof err) && strstr(err, "joint 0"),
             "%s", err);
    j.body_b = 1, j.axis[2] = 0;
    err[0] = 0;
    KT_CHECK(!kf_rigid_sim_create(b, 2, &j, 1, (double[3]){0, 0, 0}, NULL, err, sizeof err) && strstr(err, "axis"),
             "%s", err);
    /* a non-finite impulse: MuJoCo would reset the world to time 0; the body
     * stays where it was, at rest, and nothing is printed */
    kf_rigid_sim *m = kf_rigid_sim_create(b + 1, 1, NULL, 0, (double[3]){0, -9.81, 0}, NULL, err, sizeof err);
    KT_CHECK(m != NULL, "%s", err);
    if (m) {
        kf_rigid_state st;
        kf_rigid_state_at(&b[1], 0, &st);
        for (int k = 0; k < 10; k++) kf_rigid_sim_step(m, b + 1, 1, &st, k * 1e-3, 1e-3, NULL);
        double y = st.com[1];
        const double bad[1][6] = {{NAN, 0, 0, 0, 0, 0}};
        for (int k = 0; k < 2; k++) {
            kf_rigid_sim_step(m, b + 1, 1, &st, (10 + k) * 1e-3, 1e-3, bad);
            KT_NEAR(st.com[1], y, 0, "held where it was");
            KT_NEAR(st.v[1], 0, 0, "and stopped");
        }
        kf_rigid_sim_step(m, b + 1, 1, &st, 12e-3, 1e-3, NULL);
        KT_NEAR(st.v[1], -9.81e-3, 1e-12, "then falls again");
        kf_rigid_sim_destroy(m);
    }
    /* static bodies alone need no MuJoCo world, and nothing to save */
    kf_rigid_sim *s = kf_rigid_sim_create(b, 1, NULL, 0, (double[3]){0, -9.81, 0}, NULL, err, sizeof err);
    KT_CHECK(s && kf_rigid_sim_state_size(s) == 0, "a solver without dynamic bodies");
    kf_rigid_sim_destroy(s);
    for (int r = 0; r < 2; r++) kf_rigid_body_free(&b[r]);
}

/* two dynamic boxes, a keyed kinematic paddle and walls: save at step 50,
 * run 100 more, load, run the same 100: bit-identical states; a clone taken
 * at the save point does the same */
static void test_save_load_bitwise(void) {
    double v0[24], v1[24], v2[24];
    kf_rigid_def a = box_def((double[3]){-0.05, -0.05, -0.05}, (double[3]){0.05, 0.05, 0.05}, v0, KF_RIGID_DYNAMIC);
    kf_rigid_def c = box_def((double[3]){-0.04, -0.06, -0.03}, (double[3]){0.04, 0.06, 0.03}, v1, KF_RIGID_DYNAMIC);
    kf_rigid_def k = box_def((double[3]){-0.2, -0.01, -0.1}, (double[3]){0.2, 0.01, 0.1}, v2, KF_RIGID_KINEMATIC);
    a.position[0] = 0.3, a.position[1] = 0.3, a.rotate[0] = 15, a.velocity[0] = 0.2, a.angular_velocity[1] = 3;
    c.position[0] = 0.33, c.position[1] = 0.45, c.rotate[2] = 25;
    k.position[0] = 0.5, k.position[1] = 0.1, k.angular_velocity[2] = 1;
    kf_rigid_body b[3];
    char err[256] = "";
    KT_CHECK(kf_rigid_compile(&b[0], &a, 0.05, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_rigid_compile(&b[1], &c, 0.05, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_rigid_compile(&b[2], &k, 0.05, err, sizeof err) == 0, "%s", err);
    const double walls[6] = {0, 0, -0.5, 1, 1, 0.5};
    kf_rigid_sim *sim = kf_rigid_sim_create(b, 3, NULL, 0, (double[3]){0, -9.81, 0}, walls, err, sizeof err);
    KT_CHECK(sim != NULL, "%s", err);
    if (!sim) return;
    kf_rigid_state st[3];
    for (int r = 0; r < 3; r++) kf_rigid_state_at(&b[r], 0, &st[r]);
    const double dt = 2e-3;
    double imp[3][6];
    int n = 0;
    for (; n < 50; n++) {
        for (int r = 0; r < 3; r++)
            for (int q = 0; q < 6; q++) imp[r][q] = 1e-3 * sin(n + 7 * r + q);
        kf_rigid_sim_step(sim, b, 3, st, n * dt, dt, (const double(*)[6])imp);
    }
    size_t size = kf_rigid_sim_state_size(sim);
    void *buf = malloc(size);
    kf_rigid_sim_save(sim, buf);
    kf_rigid_sim *clone = kf_rigid_sim_clone(sim);
    kf_rigid_state saved[3], first[3], second[3], third[3];
    memcpy(saved, st, sizeof st);
    for (int pass = 0; pass < 3; pass++) {
        kf_rigid_sim *s = pass == 2 ? clone : sim;
        if (pass == 1) KT_CHECK(kf_rigid_sim_load(sim, buf, size) == 0, "load");
        memcpy(st, saved, sizeof st);
        for (int m = n; m < n + 100; m++) {
            for (int r = 0; r < 3; r++)
                for (int q = 0; q < 6; q++) imp[r][q] = 1e-3 * sin(m + 7 * r + q);
            kf_rigid_sim_step(s, b, 3, st, m * dt, dt, (const double(*)[6])imp);
        }
        memcpy(pass == 0 ? first : pass == 1 ? second : third, st, sizeof st);
    }
    KT_CHECK(memcmp(first, second, sizeof first) == 0, "save → run → load → run is bit-identical");
    KT_CHECK(memcmp(first, third, sizeof first) == 0, "a clone runs bit-identically");
    KT_CHECK(memcmp(first, saved, sizeof first) != 0, "and the bodies did move");
    KT_CHECK(kf_rigid_sim_load(sim, buf, size - 8) == -1, "a blob of the wrong size is refused");
    free(buf);
    kf_rigid_sim_destroy(clone);
    kf_rigid_sim_destroy(sim);
    for (int r = 0; r < 3; r++) kf_rigid_body_free(&b[r]);
}

int main(int argc, char **argv) {
    KT_RUN(test_mass_unit_cube, argc, argv);
    KT_RUN(test_mass_box_off_centre, argc, argv);
    KT_RUN(test_mass_sphere, argc, argv);
    KT_RUN(test_mass_tetra_monte_carlo, argc, argv);
    KT_RUN(test_mass_shell_plate, argc, argv);
    KT_RUN(test_compile_errors, argc, argv);
    KT_RUN(test_kinematic, argc, argv);
    KT_RUN(test_free_fall, argc, argv);
    KT_RUN(test_impulse, argc, argv);
    KT_RUN(test_hinge, argc, argv);
    KT_RUN(test_hinge_to_kinematic, argc, argv);
    KT_RUN(test_motor, argc, argv);
    KT_RUN(test_rest_on_static, argc, argv);
    KT_RUN(test_rest_in_container, argc, argv);
    KT_RUN(test_conveyor, argc, argv);
    KT_RUN(test_walls, argc, argv);
    KT_RUN(test_hinge_walls, argc, argv);
    KT_RUN(test_sim_errors, argc, argv);
    KT_RUN(test_save_load_bitwise, argc, argv);
    return KT_EXIT();
}
