/* test_collider.c — kinematic colliders: keyframed translate, rotate and
 * scale (linear and smooth), the velocity of the collider's material point at
 * a node (ω × r and scale rate), oriented boxes, sampled distance grids of
 * meshes against the analytic shapes they approximate, and whole simulations:
 * material resting on a mesh, a rotating mesh paddle stirring, a collider that
 * acts between frames because it is evaluated every substep. */
#define _GNU_SOURCE /* realpath */
#include <limits.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include <kerf/kerf.h>
#include "kt.h"
#include "mesh_util.h"
#include "mpm/collider.h"
#include "mpm/model.h"
#include "mpm/sdf_grid.h"
#include "scene/build.h"
#include "scene/mesh.h"
#include "scene/mesh_sdf.h"
#include "scene/sample.h"
#include "scene_util.h"
#include "shot/shot.h"

static const double PI = 3.14159265358979323846;

static double uniform(unsigned *s, double lo, double hi) { return lo + (hi - lo) * tu_uniform(s); }

/* a mesh from a file, placed by kf_sample_placement (fit to size at c) */
static void placed_mesh(const char *rel, const double c[3], double size, const double rotate[3], const double scale[3],
                        kf_mesh *m) {
    char err[512];
    if (kf_mesh_load(tu_repo_path(rel), m, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        exit(99);
    }
    kf_sample_def d = kf_default_sample_def();
    d.kind = KF_SOURCE_MESH;
    if (size > 0) {
        d.place.fit = 1;
        d.place.fit_size = size;
        memcpy(d.place.fit_center, c, sizeof d.place.fit_center);
    } else {
        memcpy(d.place.translate, c, sizeof d.place.translate);
    }
    if (rotate) memcpy(d.place.rotate, rotate, sizeof d.place.rotate);
    if (scale) memcpy(d.place.scale, scale, sizeof d.place.scale);
    double M[12], lo[3], hi[3];
    if (kf_sample_placement(&d, m, M, lo, hi, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        exit(99);
    }
    kf_mesh_transform(m, M);
}

static void build_sdf(const kf_mesh *m, const double pivot[3], double h, kf_mesh_sdf *sdf) {
    char err[512];
    kf_mesh_sdf_def d = kf_default_mesh_sdf_def();
    d.spacing = h;
    d.pad = 6 * h;
    if (kf_mesh_sdf_build(m, pivot, &d, sdf, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        exit(99);
    }
}

/* exact signed distance to an axis-aligned box of half extents h at the origin */
static double box_sdf(const double X[3], const double h[3]) {
    double out2 = 0, in = -1e300;
    for (int a = 0; a < 3; a++) {
        double q = fabs(X[a]) - h[a];
        if (q > 0) out2 += q * q;
        if (q > in) in = q;
    }
    return in > 0 ? sqrt(out2) : in;
}

/* rotation by deg degrees about axis a (0 x, 1 y, 2 z), written out by hand */
static void axis_rotation(int a, double deg, double R[9]) {
    double c = cos(deg * PI / 180), s = sin(deg * PI / 180);
    double X[9] = {1, 0, 0, 0, c, -s, 0, s, c}, Y[9] = {c, 0, s, 0, 1, 0, -s, 0, c},
           Z[9] = {c, -s, 0, s, c, 0, 0, 0, 1};
    memcpy(R, a == 0 ? X : a == 1 ? Y : Z, sizeof X);
}

static void mat_mul(const double A[9], const double B[9], double C[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

/* y = Aᵀ x */
static void mat_tvec(const double A[9], const double x[3], double y[3]) {
    for (int i = 0; i < 3; i++) y[i] = A[i] * x[0] + A[3 + i] * x[1] + A[6 + i] * x[2];
}

static kf_key key(double t, double x, double y, double z) {
    kf_key k;
    memset(&k, 0, sizeof k);
    k.time = t;
    k.position[0] = x, k.position[1] = y, k.position[2] = z;
    return k;
}

/* ---- motion ------------------------------------------------------------------- */

/* linear keys: exact at keys, straight between, slopes as rates, held outside */
static void linear_keys(void) {
    kf_collider c = {0};
    c.shape = KF_SHAPE_BOX;
    c.half[0] = c.half[1] = c.half[2] = 0.1;
    c.nkeys = 3;
    c.keys[0] = key(0, 0, 0, 0);
    c.keys[0].scale[0] = c.keys[0].scale[1] = c.keys[0].scale[2] = 1;
    c.keys[1] = key(1, 1, 2, 0);
    c.keys[1].rotate[1] = 90;
    c.keys[1].scale[0] = c.keys[1].scale[1] = c.keys[1].scale[2] = 2;
    c.keys[2] = key(3, 1, 2, 4);
    c.keys[2].rotate[1] = 90, c.keys[2].rotate[2] = 180; /* scale 0: means 1 */
    kf_collider_pose P;
    double want[3][7] = {{0, 0, 0, 0, 0, 0, 1}, {1, 2, 0, 0, 90, 0, 2}, {1, 2, 4, 0, 90, 180, 1}};
    for (int k = 0; k < 3; k++) {
        kf_collider_pose_at(&c, c.keys[k].time, &P);
        for (int a = 0; a < 3; a++) {
            KT_NEAR(P.p[a], want[k][a], 1e-15, "exact at a key");
            KT_NEAR(P.deg[a], want[k][3 + a], 1e-13, "exact at a key");
            KT_NEAR(P.s[a], want[k][6], 1e-15, "exact at a key (scale 0 means 1)");
        }
    }
    kf_collider_pose_at(&c, 0.5, &P);
    KT_NEAR(P.p[0], 0.5, 1e-15, "midpoint");
    KT_NEAR(P.p[1], 1.0, 1e-15, "midpoint");
    KT_NEAR(P.deg[1], 45, 1e-13, "midpoint angle");
    KT_NEAR(P.s[2], 1.5, 1e-15, "midpoint scale");
    KT_NEAR(P.dp[1], 2, 1e-15, "segment slope");
    KT_NEAR(P.omega[1], PI / 2, 1e-14, "90 degrees per second about y");
    KT_NEAR(P.omega[0] + P.omega[2], 0, 1e-15, "about y only");
    KT_NEAR(P.ds[0], 1, 1e-15, "scale rate");
    kf_collider_pose_at(&c, 2.0, &P);
    KT_NEAR(P.p[2], 2, 1e-15, "second segment");
    KT_NEAR(P.deg[2], 90, 1e-13, "second segment angle");
    KT_NEAR(P.s[0], 1.5, 1e-15, "second segment scale 2 -> 1");
    KT_NEAR(P.ds[0], -0.5, 1e-15, "shrinking");
    /* z turns after y: ω = c' e_z (the outermost rotation) */
    KT_NEAR(P.omega[2], PI / 2, 1e-14, "90 degrees per second about z");
    kf_collider_pose_at(&c, -1, &P);
    KT_CHECK(P.p[0] == 0 && P.dp[0] == 0 && P.omega[1] == 0 && P.ds[0] == 0, "held before the first key");
    kf_collider_pose_at(&c, 7, &P);
    KT_CHECK(P.p[2] == 4 && P.deg[2] == 180 && P.dp[2] == 0 && P.omega[2] == 0, "held after the last key");
    /* one key: held there */
    c.nkeys = 1;
    kf_collider_pose_at(&c, 5, &P);
    KT_CHECK(P.p[0] == 0 && P.s[0] == 1 && P.dp[0] == 0, "one key holds");
}

/* smooth keys: through every key, C1 (velocity continuous across inner keys,
 * equal to the Catmull-Rom tangent there), at rest at the ends; the rates are
 * the derivatives of the values */
static void smooth_keys(void) {
    kf_collider c = {0};
    c.shape = KF_SHAPE_SPHERE;
    c.radius = 0.1;
    c.interp = KF_INTERP_SMOOTH;
    c.nkeys = 4;
    double t[4] = {0, 1, 1.5, 3};
    double pos[4][3] = {{0, 0, 0}, {1, 2, -1}, {1.5, 1, 0}, {3, 0, 2}};
    double rot[4][3] = {{0, 0, 0}, {30, 90, 10}, {45, 200, -20}, {90, 360, 0}};
    double scl[4][3] = {{1, 1, 1}, {2, 1, 1}, {1, 0.5, 1}, {1, 1, 3}};
    for (int k = 0; k < 4; k++) {
        c.keys[k] = key(t[k], pos[k][0], pos[k][1], pos[k][2]);
        memcpy(c.keys[k].rotate, rot[k], sizeof rot[k]);
        memcpy(c.keys[k].scale, scl[k], sizeof scl[k]);
    }
    kf_collider_pose P, Q;
    for (int k = 0; k < 4; k++) {
        kf_collider_pose_at(&c, t[k], &P);
        for (int a = 0; a < 3; a++) {
            KT_NEAR(P.p[a], pos[k][a], 1e-14, "smooth passes through the key");
            KT_NEAR(P.deg[a], rot[k][a], 1e-12, "smooth passes through the key");
            KT_NEAR(P.s[a], scl[k][a], 1e-14, "smooth passes through the key");
        }
    }
    /* continuity of value and rate across the inner keys, and the tangent */
    const double e = 1e-9;
    for (int k = 1; k <= 2; k++) {
        kf_collider_pose_at(&c, t[k] - e, &P);
        kf_collider_pose_at(&c, t[k] + e, &Q);
        for (int a = 0; a < 3; a++) {
            double m = (pos[k + 1][a] - pos[k - 1][a]) / (t[k + 1] - t[k - 1]);
            KT_NEAR(P.dp[a], m, 1e-6, "velocity at an inner key is the central difference (O(e) off the key)");
            KT_NEAR(Q.dp[a], P.dp[a], 1e-6, "velocity continuous across the key (O(e) apart)");
            KT_NEAR(Q.ds[a], P.ds[a], 1e-6, "scale rate continuous across the key");
            KT_NEAR(Q.omega[a], P.omega[a], 1e-6, "angular velocity continuous across the key");
        }
    }
    /* at rest at the first and last key, and held outside */
    kf_collider_pose_at(&c, 1e-7, &P);
    kf_collider_pose_at(&c, 3 - 1e-7, &Q);
    for (int a = 0; a < 3; a++) {
        KT_NEAR(P.dp[a], 0, 1e-5, "eases in (zero end tangent)");
        KT_NEAR(Q.omega[a], 0, 1e-5, "eases out (zero end tangent)");
    }
    /* the rates are the derivatives of the values (central differences, h = 1e-5:
     * error ~h² |x'''| ~ 1e-9) */
    const double h = 1e-5;
    for (double tt = 0.05; tt < 3; tt += 0.1) {
        kf_collider_pose M0, M1;
        kf_collider_pose_at(&c, tt, &P);
        kf_collider_pose_at(&c, tt - h, &M0);
        kf_collider_pose_at(&c, tt + h, &M1);
        for (int a = 0; a < 3; a++) {
            KT_NEAR(P.dp[a], (M1.p[a] - M0.p[a]) / (2 * h), 1e-7, "dp/dt");
            KT_NEAR(P.ds[a], (M1.s[a] - M0.s[a]) / (2 * h), 1e-7, "ds/dt");
        }
        /* ω from the rotation matrices: Ṙ Rᵀ = [ω]× */
        double W[9];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                double s = 0;
                for (int k = 0; k < 3; k++) s += (M1.R[3 * i + k] - M0.R[3 * i + k]) / (2 * h) * P.R[3 * j + k];
                W[3 * i + j] = s;
            }
        KT_NEAR(P.omega[0], W[7], 1e-6, "omega_x = (R' R^T)_zy");
        KT_NEAR(P.omega[1], W[2], 1e-6, "omega_y = (R' R^T)_xz");
        KT_NEAR(P.omega[2], W[3], 1e-6, "omega_z = (R' R^T)_yx");
    }
    /* two keys: zero tangents, so the midpoint is the average */
    c.nkeys = 2;
    kf_collider_pose_at(&c, 0.5, &P);
    KT_NEAR(P.p[1], 1.0, 1e-15, "two smooth keys: midpoint is the average");
    KT_NEAR(P.dp[1], 1.5 * 2 / 1.0, 1e-14, "and the speed there is 1.5x the mean speed");
}

/* velocity of the collider's material point: ω × r for a turning box, and the
 * time derivative of x(t) = p(t) + R(t) S(t) R0 X for a general keyed motion */
static void material_point_velocity(void) {
    kf_collider c = {0};
    c.shape = KF_SHAPE_BOX;
    c.half[0] = 0.3, c.half[1] = 0.05, c.half[2] = 0.1;
    c.center[0] = c.center[1] = c.center[2] = 0.5;
    c.nkeys = 2;
    c.keys[0] = key(0, 0.5, 0.5, 0.5);
    c.keys[1] = key(1, 0.5, 0.5, 0.5);
    c.keys[1].rotate[1] = 360; /* one turn about y per second */
    kf_collider_frame f;
    kf_collider_frame_at(&c, 0.3, &f);
    double R[9];
    axis_rotation(1, 0.3 * 360, R);
    double X[3] = {0.3, 0.05, -0.07}, r[3], x[3], v[3], n[3];
    for (int i = 0; i < 3; i++) r[i] = R[3 * i] * X[0] + R[3 * i + 1] * X[1] + R[3 * i + 2] * X[2], x[i] = 0.5 + r[i];
    kf_collider_velocity(&f, x, v);
    double w = 2 * PI;
    KT_NEAR(v[0], w * r[2], 1e-12, "v = omega x r, omega = 2 pi e_y");
    KT_NEAR(v[1], 0, 1e-12, "v = omega x r");
    KT_NEAR(v[2], -w * r[0], 1e-12, "v = omega x r");
    KT_NEAR(kf_collider_sdf(&f, x, n), 0, 1e-12, "the point is on the turned box's corner edge");

    /* everything at once: smooth keys with translate, compound rotation and
     * non-uniform scale, on a rest-rotated box */
    c.interp = KF_INTERP_SMOOTH;
    c.rotate[0] = 20, c.rotate[2] = 30;
    c.nkeys = 3;
    c.keys[0] = key(0, 0.5, 0.5, 0.5);
    c.keys[1] = key(0.4, 0.6, 0.4, 0.5);
    c.keys[1].rotate[0] = 40, c.keys[1].rotate[1] = 70, c.keys[1].rotate[2] = -30;
    c.keys[1].scale[0] = 1.5, c.keys[1].scale[1] = 0.8, c.keys[1].scale[2] = 1.2;
    c.keys[2] = key(1, 0.7, 0.5, 0.3);
    c.keys[2].rotate[1] = 180;
    double R0[9];
    kf_euler_matrix(c.rotate, R0);
    double Xs[3] = {0.3, -0.05, 0.04}; /* a point of the box's surface, shape frame */
    for (double t = 0.05; t < 1; t += 0.1) {
        const double h = 1e-6;
        double xt[3][3];
        for (int q = 0; q < 3; q++) {
            kf_collider_pose P;
            kf_collider_pose_at(&c, t + (q - 1) * h, &P);
            double Y[3];
            for (int i = 0; i < 3; i++) Y[i] = R0[3 * i] * Xs[0] + R0[3 * i + 1] * Xs[1] + R0[3 * i + 2] * Xs[2];
            for (int i = 0; i < 3; i++) Y[i] *= P.s[i];
            for (int i = 0; i < 3; i++)
                xt[q][i] = P.p[i] + P.R[3 * i] * Y[0] + P.R[3 * i + 1] * Y[1] + P.R[3 * i + 2] * Y[2];
        }
        kf_collider_frame_at(&c, t, &f);
        kf_collider_velocity(&f, xt[1], v);
        for (int a = 0; a < 3; a++)
            KT_NEAR(v[a], (xt[2][a] - xt[0][a]) / (2 * h), 1e-6,
                    "velocity = d/dt of the material point (central difference, h = 1e-6)");
        KT_NEAR(kf_collider_sdf(&f, xt[1], n), 0, 1e-12, "a surface point stays on the surface");
    }
}

/* ---- distances ------------------------------------------------------------------- */

/* an oriented box: rest rotation, then keyed rotation and uniform scale,
 * against the distance computed by hand in the box's frame */
static void oriented_box_sdf(void) {
    kf_collider c = {0};
    c.shape = KF_SHAPE_BOX;
    c.half[0] = 0.2, c.half[1] = 0.1, c.half[2] = 0.05;
    c.center[0] = 0.5, c.center[1] = 0.4, c.center[2] = 0.6;
    c.rotate[2] = 30;
    unsigned seed = 7;
    double Rz[9], worst = 0, worst_n = 0;
    axis_rotation(2, 30, Rz);
    for (int pass = 0; pass < 2; pass++) {
        double t = 0, s = 1, Ry[9], A[9];
        axis_rotation(1, 0, Ry);
        if (pass == 1) {
            /* keys: 0 -> 90 degrees about y and scale 1 -> 2 over a second; at t = 0.5 */
            c.nkeys = 2;
            c.keys[0] = key(0, 0.5, 0.4, 0.6);
            c.keys[1] = key(1, 0.5, 0.4, 0.6);
            c.keys[1].rotate[1] = 90;
            c.keys[1].scale[0] = c.keys[1].scale[1] = c.keys[1].scale[2] = 2;
            t = 0.5, s = 1.5;
            axis_rotation(1, 45, Ry);
        }
        mat_mul(Ry, Rz, A); /* box axes in the world */
        kf_collider_frame f;
        kf_collider_frame_at(&c, t, &f);
        double hs[3] = {s * c.half[0], s * c.half[1], s * c.half[2]};
        for (int i = 0; i < 2000; i++) {
            double x[3], r[3], X[3], n[3];
            for (int a = 0; a < 3; a++) x[a] = c.center[a] + uniform(&seed, -0.5, 0.5), r[a] = x[a] - c.center[a];
            mat_tvec(A, r, X);
            double want = box_sdf(X, hs), got = kf_collider_sdf(&f, x, n);
            worst = fmax(worst, fabs(got - want));
            /* the normal is the gradient: compare with central differences
             * where they do not straddle a crease of the distance */
            double g[3], e = 1e-6, g2 = 0;
            for (int a = 0; a < 3; a++) {
                double xp[3] = {x[0], x[1], x[2]}, xm[3] = {x[0], x[1], x[2]}, Xp[3], Xm[3], rp[3], rm[3];
                xp[a] += e, xm[a] -= e;
                for (int b = 0; b < 3; b++) rp[b] = xp[b] - c.center[b], rm[b] = xm[b] - c.center[b];
                mat_tvec(A, rp, Xp);
                mat_tvec(A, rm, Xm);
                g[a] = (box_sdf(Xp, hs) - box_sdf(Xm, hs)) / (2 * e);
                g2 += g[a] * g[a];
            }
            if (fabs(sqrt(g2) - 1) < 1e-6)
                for (int a = 0; a < 3; a++) worst_n = fmax(worst_n, fabs(n[a] - g[a]));
        }
    }
    KT_NEAR(worst, 0, 1e-12, "oriented box distance: exact (round-off)");
    KT_NEAR(worst_n, 0, 1e-6, "normal = gradient of the distance (central differences, e = 1e-6)");

    /* a plane turns about its point: +y tilted 90 degrees about x is +z */
    kf_collider p = {0};
    p.shape = KF_SHAPE_PLANE;
    p.normal[1] = 2;
    p.nkeys = 2;
    p.keys[0] = key(0, 0, 0.1, 0);
    p.keys[1] = key(1, 0, 0.1, 0);
    p.keys[1].rotate[0] = 90;
    kf_collider_frame f;
    kf_collider_frame_at(&p, 1, &f);
    double x[3] = {0.7, 0.1, 0.3}, n[3];
    KT_NEAR(kf_collider_sdf(&f, x, n), 0.3, 1e-15, "turned plane: distance along +z");
    KT_NEAR(n[2], 1, 1e-15, "turned plane: normal +z");
    kf_collider_frame_at(&p, 0.5, &f);
    double v[3];
    kf_collider_velocity(&f, x, v);
    KT_NEAR(v[1], -PI / 2 * 0.3, 1e-14, "a point of the turning plane: v = omega x r, omega = pi/2 e_x");
    KT_NEAR(v[2], 0, 1e-15, "v = omega x r (r along z)");
}

/* trilinear reads: exact for a linear field, value + distance outside */
static void sdf_grid_reads(void) {
    kf_sdf_grid g = {{-0.2, 0.1, 0.3}, 0.1, {5, 6, 7}, NULL};
    float *phi = malloc(5 * 6 * 7 * sizeof *phi);
    for (int i = 0; i < 5; i++)
        for (int j = 0; j < 6; j++)
            for (int k = 0; k < 7; k++) {
                double x = -0.2 + 0.1 * i, y = 0.1 + 0.1 * j, z = 0.3 + 0.1 * k;
                phi[(i * 6 + j) * 7 + k] = (float)(0.3 * x - 0.5 * y + 0.2 * z + 0.1);
            }
    g.phi = phi;
    KT_CHECK(*kf_sdf_grid_check(&g) == 0, "a good grid passes: %s", kf_sdf_grid_check(&g));
    unsigned seed = 3;
    double worst = 0, gworst = 0;
    for (int i = 0; i < 1000; i++) {
        double X[3] = {uniform(&seed, -0.2, 0.2), uniform(&seed, 0.1, 0.6), uniform(&seed, 0.3, 0.9)}, gr[3];
        double f = kf_sdf_grid_sample(&g, X, gr);
        worst = fmax(worst, fabs(f - (0.3 * X[0] - 0.5 * X[1] + 0.2 * X[2] + 0.1)));
        gworst = fmax(gworst, fabs(gr[0] - 0.3) + fabs(gr[1] + 0.5) + fabs(gr[2] - 0.2));
    }
    KT_NEAR(worst, 0, 1e-6, "trilinear is exact for a linear field (float values)");
    KT_NEAR(gworst, 0, 1e-5, "and so is its gradient (float values / spacing)");
    double X[3] = {0.5, 0.3, 0.5}, gr[3]; /* 0.3 beyond x = 0.2 */
    double f = kf_sdf_grid_sample(&g, X, gr);
    KT_NEAR(f, (0.3 * 0.2 - 0.5 * 0.3 + 0.2 * 0.5 + 0.1) + 0.3, 1e-6, "outside: value at the box + distance to it");
    KT_NEAR(gr[0], 1, 0, "outside: gradient points away from the box");
    g.dims[1] = 1;
    KT_CHECK(*kf_sdf_grid_check(&g) != 0, "a grid one node thick is refused");
    g.dims[1] = 6;
    phi[17] = NAN;
    KT_CHECK(strstr(kf_sdf_grid_check(&g), "finite") != NULL, "NaN values are refused");
    free(phi);
}

/* assets/sphere.obj (UV sphere, 64 x 32) fitted to radius R: the sampled grid
 * against |x - c| - R. The mesh is inscribed in the sphere: a flat triangle
 * spanning angles (2π/64, π/32) sits inside it by up to R (1 - cos θ/2) with
 * θ the triangle's angular diameter ≈ 0.11 rad: R·0.0015 = 0.3 mm at R = 0.2;
 * trilinear interpolation of |x| adds up to h²/(4R) = 0.13 mm at h = 0.01
 * (second derivative 1/R across the surface, over a cell). Stated bound
 * 0.6 mm near the surface (|φ| < 3h); the whole grid, where distances far
 * away were propagated by sweeps, gets h/2. */
static void mesh_sdf_sphere(void) {
    const double c[3] = {0.5, 0.45, 0.55}, R = 0.2, h = 0.01;
    kf_mesh m;
    placed_mesh("assets/sphere.obj", c, 2 * R, NULL, NULL, &m);
    kf_mesh_sdf sdf;
    /* a pivot off the centre: the grid's frame is relative to it */
    const double pivot[3] = {0.45, 0.5, 0.5};
    build_sdf(&m, pivot, h, &sdf);
    KT_NEAR(sdf.grid.spacing, h, 0, "spacing as asked (the grid fits the node budget)");
    unsigned seed = 11;
    double near_err = 0, far_err = 0;
    double lo[3], hi[3];
    kf_sdf_grid_bounds(&sdf.grid, lo, hi);
    for (int i = 0; i < 20000; i++) {
        double X[3], x[3], g[3];
        for (int a = 0; a < 3; a++) X[a] = uniform(&seed, lo[a], hi[a]), x[a] = X[a] + pivot[a];
        double want = sqrt(pow(x[0] - c[0], 2) + pow(x[1] - c[1], 2) + pow(x[2] - c[2], 2)) - R;
        double got = kf_sdf_grid_sample(&sdf.grid, X, g), e = fabs(got - want);
        if (fabs(want) < 3 * h) near_err = fmax(near_err, e);
        else far_err = fmax(far_err, e);
    }
    printf("  sphere sdf (h = %g, %d x %d x %d nodes, %.3f s, %ld inside tests): max error %.3g mm near the "
           "surface, %.3g mm elsewhere\n",
           h, sdf.grid.dims[0], sdf.grid.dims[1], sdf.grid.dims[2], sdf.seconds, sdf.inside_tests, near_err * 1e3,
           far_err * 1e3);
    KT_NEAR(near_err, 0, 0.6e-3, "chordal error of the UV sphere + trilinear interpolation (see above)");
    KT_NEAR(far_err, 0, 0.5 * h, "propagated distances away from the surface");
    KT_CHECK(sdf.inside_tests < (long)(0.5 * sdf.grid.dims[0] * sdf.grid.dims[1] * sdf.grid.dims[2]),
             "blocks away from the surface take one inside test (%ld tests)", sdf.inside_tests);
    kf_mesh_sdf_free(&sdf);

    /* a node budget coarsens the grid instead of failing */
    char err[256];
    kf_mesh_sdf_def d = kf_default_mesh_sdf_def();
    d.spacing = h;
    d.max_nodes = 20000;
    KT_CHECK(kf_mesh_sdf_build(&m, pivot, &d, &sdf, err, sizeof err) == 0, "%s", err);
    size_t nodes = kf_sdf_grid_nodes(&sdf.grid);
    KT_CHECK(nodes <= 20000 && sdf.grid.spacing > h && sdf.spacing_asked == h, "coarsened to %g m, %zu nodes",
             sdf.grid.spacing, nodes);
    double X[3] = {c[0] + R - pivot[0], c[1] - pivot[1], c[2] - pivot[2]}, g[3];
    KT_NEAR(kf_sdf_grid_sample(&sdf.grid, X, g), 0, 0.25 * sdf.grid.spacing, "still a distance field");
    kf_mesh_sdf_free(&sdf);
    kf_mesh_free(&m);
}

/* tests/meshes/cube.obj, a unit cube scaled to a box: planar faces, so the
 * distance is exactly linear within any cell whose nodes share the nearest
 * face; the test keeps to points within 2h of one face and 5h inside the
 * others, so every node of their cells has that face nearest */
static void mesh_sdf_cube(void) {
    const double c[3] = {0.3, 0.2, 0.1}, half[3] = {0.15, 0.1, 0.2}, h = 0.01;
    double scale[3] = {0.3, 0.2, 0.4};
    kf_mesh m;
    placed_mesh("tests/meshes/cube.obj", (double[3]){0, 0, 0}, 0, NULL, scale, &m);
    /* the file's cube is [0, 1]^3: move its centre to c */
    double M[12] = {1, 0, 0, c[0] - 0.15, 0, 1, 0, c[1] - 0.1, 0, 0, 1, c[2] - 0.2};
    kf_mesh_transform(&m, M);
    kf_mesh_sdf sdf;
    build_sdf(&m, c, h, &sdf);
    unsigned seed = 5;
    double worst = 0;
    int n = 0;
    for (int i = 0; i < 40000 && n < 5000; i++) {
        double X[3], g[3], q[3];
        for (int a = 0; a < 3; a++) X[a] = uniform(&seed, -half[a] - 2 * h, half[a] + 2 * h);
        int faces_near = 0, far_from_rest = 1;
        for (int a = 0; a < 3; a++) {
            q[a] = fabs(X[a]) - half[a];
            faces_near += fabs(q[a]) < 2 * h;
        }
        for (int a = 0; a < 3; a++)
            if (fabs(q[a]) >= 2 * h) far_from_rest &= q[a] < -5 * h;
        if (faces_near != 1 || !far_from_rest) continue;
        double want = box_sdf(X, half), got = kf_sdf_grid_sample(&sdf.grid, X, g);
        worst = fmax(worst, fabs(got - want));
        n++;
    }
    KT_CHECK(n > 1000, "enough samples near faces (%d)", n);
    KT_NEAR(worst, 0, 1e-6, "flat faces: exact up to float round-off");
    kf_mesh_sdf_free(&sdf);
    kf_mesh_free(&m);
}

/* a mesh collider (sphere.obj) moving and turning with keys, against the
 * analytic sphere collider with the same keys: the same distance within the
 * sphere's stated error, the same normal, and the same velocity */
static void mesh_collider_matches_sphere(void) {
    const double R = 0.2, h = 0.01, c0[3] = {0.5, 0.5, 0.5};
    kf_mesh m;
    placed_mesh("assets/sphere.obj", c0, 2 * R, NULL, NULL, &m);
    kf_mesh_sdf sdf;
    build_sdf(&m, c0, h, &sdf);
    kf_collider mc = {0}, sc = {0};
    mc.shape = KF_SHAPE_MESH;
    mc.sdf = &sdf.grid;
    sc.shape = KF_SHAPE_SPHERE;
    sc.radius = R;
    for (kf_collider *c = &mc; c; c = c == &mc ? &sc : NULL) {
        memcpy(c->center, c0, sizeof c0);
        c->interp = KF_INTERP_SMOOTH;
        c->nkeys = 3;
        c->keys[0] = key(0, 0.5, 0.5, 0.5);
        c->keys[1] = key(0.5, 0.6, 0.3, 0.5);
        c->keys[1].rotate[0] = 50, c->keys[1].rotate[1] = 120;
        c->keys[2] = key(1.0, 0.7, 0.4, 0.4);
        c->keys[2].rotate[2] = 300;
    }
    /* through a model, which keeps its own copy of the grid */
    kf_sim_def sd = kf_default_sim_def();
    char err[256];
    kf_model *model = kf_model_create(&sd, err, sizeof err);
    KT_CHECK(kf_model_add_collider(model, &mc, err, sizeof err) == 0, "%s", err);
    kf_mesh_sdf_free(&sdf); /* the caller's grid is gone */
    unsigned seed = 9;
    double derr = 0, nerr = 0, verr = 0;
    for (double t = 0.1; t < 1; t += 0.2) {
        kf_collider_frame fm, fs;
        kf_collider_frame_at(&model->col[0], t, &fm);
        kf_collider_frame_at(&sc, t, &fs);
        for (int i = 0; i < 2000; i++) {
            double x[3], nm[3], ns[3], vm[3], vs[3];
            for (int a = 0; a < 3; a++) x[a] = fs.pose.p[a] + uniform(&seed, -0.3, 0.3);
            double dm = kf_collider_sdf(&fm, x, nm), ds = kf_collider_sdf(&fs, x, ns);
            if (fabs(ds) < 3 * h) derr = fmax(derr, fabs(dm - ds));
            if (fabs(ds) < 3 * h && ds < -h) nerr = fmax(nerr, 1 - (nm[0] * ns[0] + nm[1] * ns[1] + nm[2] * ns[2]));
            kf_collider_velocity(&fm, x, vm);
            kf_collider_velocity(&fs, x, vs);
            for (int a = 0; a < 3; a++) verr = fmax(verr, fabs(vm[a] - vs[a]));
        }
    }
    printf("  turning mesh sphere vs analytic: distance %.3g mm, normal 1 - cos %.2g, velocity %.2g m/s apart\n",
           derr * 1e3, nerr, verr);
    KT_NEAR(derr, 0, 0.6e-3, "turning mesh sphere: distance as the analytic sphere (mesh_sdf_sphere's bound)");
    KT_NEAR(nerr, 0, 1e-3, "normals within 2.6 degrees inside the surface (facets, central differences)");
    KT_NEAR(verr, 0, 1e-12, "the same motion gives the same velocity field");
    kf_model_destroy(model);
    kf_mesh_free(&m);
}

/* kf_model_add_collider refuses what the grid update cannot use */
static void model_validation(void) {
    kf_sim_def sd = kf_default_sim_def();
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    kf_collider c = {0};
    c.shape = KF_SHAPE_MESH;
    KT_CHECK(kf_model_add_collider(m, &c, err, sizeof err) < 0 && strstr(err, "no distance field"), "%s", err);
    c.shape = KF_SHAPE_SPHERE;
    c.radius = 0.1;
    c.nkeys = 2;
    c.keys[0] = key(1, 0, 0, 0);
    c.keys[1] = key(1, 1, 0, 0);
    KT_CHECK(kf_model_add_collider(m, &c, err, sizeof err) < 0 && strstr(err, "increasing"), "%s", err);
    c.keys[1].time = 2;
    c.keys[1].scale[1] = -1;
    KT_CHECK(kf_model_add_collider(m, &c, err, sizeof err) < 0 && strstr(err, "scale"), "%s", err);
    c.keys[1].scale[1] = 0;
    c.keys[1].rotate[0] = NAN;
    KT_CHECK(kf_model_add_collider(m, &c, err, sizeof err) < 0 && strstr(err, "finite"), "%s", err);
    c.keys[1].rotate[0] = 0;
    c.interp = (kf_interp)7;
    KT_CHECK(kf_model_add_collider(m, &c, err, sizeof err) < 0 && strstr(err, "interpolation"), "%s", err);
    c.interp = KF_INTERP_SMOOTH;
    KT_CHECK(kf_model_add_collider(m, &c, err, sizeof err) == 0, "a good sphere: %s", err);
    kf_collider p = {0};
    p.shape = KF_SHAPE_PLANE;
    p.normal[1] = 1;
    p.inside = 1;
    KT_CHECK(kf_model_add_collider(m, &p, err, sizeof err) < 0 && strstr(err, "plane"), "%s", err);
    kf_model_destroy(m);
}

/* ---- simulations ------------------------------------------------------------------ */

/* lowest particle height and mean vertical velocity */
static void column_stats(kf_state *s, double *lowest, double *vy) {
    kf_particles_view pv = kf_state_particles(s);
    *lowest = 1e9;
    double sum = 0;
    for (size_t i = 0; i < pv.n; i++) *lowest = fmin(*lowest, pv.x[1][i]), sum += pv.v[1][i];
    *vy = sum / (double)pv.n;
}

/* a snow block dropped on a static mesh box (tests/meshes/cube.obj) comes to
 * rest on its top face, exactly where it comes to rest on the analytic box
 * (the sampled distance of flat faces is exact). Snow, because its plasticity
 * soaks up the bounce: an elastic block still rings after a second, and goo
 * flows off the edge. The top face is off the node plane y = 0.30: a node
 * exactly on the surface has φ = 0 analytically but ±1e-8 after sampling,
 * which moves the resting height by half a cell. */
static void block_rests_on_mesh(void) {
    const double dx = 0.02, top = 0.31;
    double lowest[2], vy[2], height[2];
    for (int pass = 0; pass < 2; pass++) {
        kf_sim_def sd = kf_default_sim_def();
        sd.dx = dx;
        sd.cfl = 0.4;
        int mat;
        kf_model *m = tu_model(&sd, "snow", 0, -1, 0, &mat);
        kf_collider c = {0};
        c.boundary = KF_BOUNDARY_SEPARATE;
        c.friction = 0.5;
        c.center[0] = 0.5, c.center[1] = 0.21, c.center[2] = 0.5; /* a 0.4 x 0.2 x 0.4 pedestal, top at y = 0.31 */
        kf_mesh mesh;
        kf_mesh_sdf sdf = {0};
        if (pass == 0) {
            double scale[3] = {0.4, 0.2, 0.4};
            placed_mesh("tests/meshes/cube.obj", (double[3]){0.3, 0.11, 0.3}, 0, NULL, scale, &mesh);
            build_sdf(&mesh, c.center, 0.5 * dx, &sdf);
            c.shape = KF_SHAPE_MESH;
            c.sdf = &sdf.grid;
        } else {
            c.shape = KF_SHAPE_BOX;
            c.half[0] = 0.2, c.half[1] = 0.1, c.half[2] = 0.2;
        }
        char err[256];
        KT_CHECK(kf_model_add_collider(m, &c, err, sizeof err) == 0, "%s", err);
        if (pass == 0) kf_mesh_sdf_free(&sdf), kf_mesh_free(&mesh);
        kf_state *s = kf_state_create(m);
        double lo[3] = {0.42, 0.37, 0.42}, hi[3] = {0.58, 0.49, 0.58};
        kf_state_fill_box(s, m, lo, hi, mat, NULL, 2, 0);
        char msg[256];
        KT_CHECK(kf_advance(m, s, 0.6, NULL, msg, sizeof msg) == 0, "%s", msg);
        column_stats(s, &lowest[pass], &vy[pass]);
        kf_energy e = kf_state_energy(m, s);
        kf_particles_view pv = kf_state_particles(s);
        double sum = 0;
        for (size_t i = 0; i < pv.n; i++) sum += pv.x[1][i];
        height[pass] = sum / (double)pv.n;
        (void)e;
        kf_state_destroy(s);
        kf_model_destroy(m);
    }
    printf("  block on a mesh box: lowest particle %.4f (top face %.2f), mean vy %.2g m/s, mean height %.5f "
           "(analytic box: %.5f)\n",
           lowest[0], top, vy[0], height[0], height[1]);
    /* grid-node boundaries hold material about half a cell off the surface;
     * no particle may be more than a quarter cell inside */
    KT_CHECK(lowest[0] > top - 0.25 * dx, "no particle inside the mesh box (lowest %.4f)", lowest[0]);
    KT_NEAR(vy[0], 0, 1e-3, "at rest on it after 0.6 s (measured 3e-7 m/s)");
    KT_NEAR(height[0], height[1], 1e-4,
            "mesh box and analytic box hold the block at the same height (measured equal "
            "to 5 digits)");
}

/* a jello block dropped on a static mesh sphere (assets/sphere.obj) stays
 * outside it */
static void block_on_mesh_sphere(void) {
    const double dx = 0.02, R = 0.15, c[3] = {0.5, 0.3, 0.5};
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = dx;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    kf_mesh mesh;
    placed_mesh("assets/sphere.obj", c, 2 * R, NULL, NULL, &mesh);
    kf_mesh_sdf sdf;
    build_sdf(&mesh, c, 0.5 * dx, &sdf);
    kf_collider col = {0};
    col.shape = KF_SHAPE_MESH;
    col.sdf = &sdf.grid;
    col.boundary = KF_BOUNDARY_SEPARATE;
    col.friction = 0.5;
    memcpy(col.center, c, sizeof col.center);
    char err[256];
    KT_CHECK(kf_model_add_collider(m, &col, err, sizeof err) == 0, "%s", err);
    kf_mesh_sdf_free(&sdf);
    kf_mesh_free(&mesh);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.4, 0.48, 0.4}, hi[3] = {0.6, 0.58, 0.6};
    kf_state_fill_box(s, m, lo, hi, mat, NULL, 2, 0);
    char msg[256];
    KT_CHECK(kf_advance(m, s, 0.5, NULL, msg, sizeof msg) == 0, "%s", msg);
    kf_particles_view pv = kf_state_particles(s);
    double deepest = 1e9;
    for (size_t i = 0; i < pv.n; i++)
        deepest =
            fmin(deepest, sqrt(pow(pv.x[0][i] - c[0], 2) + pow(pv.x[1][i] - c[1], 2) + pow(pv.x[2][i] - c[2], 2)) - R);
    double vy;
    column_stats(s, &(double){0}, &vy);
    printf("  block on a mesh sphere: deepest particle %.4f m from the surface, mean vy %.2g m/s\n", deepest, vy);
    KT_CHECK(deepest > -0.25 * dx, "no particle inside the mesh sphere beyond a quarter cell (%.4f)", deepest);
    KT_NEAR(vy, 0, 0.05, "resting on top of the sphere");
    kf_state_destroy(s);
    kf_model_destroy(m);
}

/* assets/paddle.obj, thickened, keyed to turn a quarter turn about y (sense
 * +1 or -1) in a layer of goo; returns the goo's angular momentum about the
 * paddle's axis after 0.3 s and the deepest particle inside the paddle */
static double stir(int sense, double *deepest) {
    const double dx = 0.025, pivot[3] = {0.5, 0.15, 0.5};
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = dx;
    sd.walls = 1;
    int mat;
    kf_model *m = tu_model(&sd, "goo", 0, -1, 0, &mat);
    /* 1 m x 0.24 m x 0.02 m along x, y, z -> 0.4 x 0.144 x 0.05 */
    kf_mesh mesh;
    double scale[3] = {0.4, 0.6, 2.5};
    placed_mesh("assets/paddle.obj", pivot, 0.4, NULL, scale, &mesh);
    kf_mesh_sdf sdf;
    build_sdf(&mesh, pivot, 0.5 * dx, &sdf);
    kf_mesh_free(&mesh);
    kf_collider col = {0};
    col.shape = KF_SHAPE_MESH;
    col.sdf = &sdf.grid;
    col.boundary = KF_BOUNDARY_STICKY;
    memcpy(col.center, pivot, sizeof col.center);
    col.interp = KF_INTERP_SMOOTH;
    col.nkeys = 2;
    col.keys[0] = key(0, pivot[0], pivot[1], pivot[2]);
    col.keys[1] = key(0.4, pivot[0], pivot[1], pivot[2]);
    col.keys[1].rotate[1] = sense * 90; /* a quarter turn; +: counter-clockwise seen from +y */
    char err[256];
    KT_CHECK(kf_model_add_collider(m, &col, err, sizeof err) == 0, "%s", err);
    kf_mesh_sdf_free(&sdf);
    /* goo around the paddle: a lattice of 2³ per cell, less what the paddle
     * holds; symmetric about z = 0.5, as the paddle is */
    kf_collider_frame f0;
    kf_collider_frame_at(&m->col[0], 0, &f0);
    size_t cap = 48 * 10 * 48, np = 0;
    double *x0 = malloc(cap * 3 * sizeof *x0), hl = 0.5 * dx, n[3];
    for (int i = 0; i < 48; i++)
        for (int j = 0; j < 10; j++)
            for (int k = 0; k < 48; k++) {
                double p[3] = {0.2 + (i + 0.5) * hl, 0.02 + (j + 0.5) * hl, 0.2 + (k + 0.5) * hl};
                if (kf_collider_sdf(&f0, p, n) > 0.5 * dx) memcpy(&x0[3 * np++], p, sizeof p);
            }
    kf_state *s = kf_state_create(m);
    kf_state_add_particles(s, m, np, x0, NULL, NULL, mat, hl * hl * hl);
    free(x0);
    char msg[256];
    KT_CHECK(kf_advance(m, s, 0.3, NULL, msg, sizeof msg) == 0, "%s", msg);
    kf_particles_view pv = kf_state_particles(s);
    kf_collider_frame f;
    kf_collider_frame_at(&m->col[0], 0.3, &f);
    double Ly = 0;
    *deepest = 1e9;
    for (size_t i = 0; i < pv.n; i++) {
        double rx = pv.x[0][i] - pivot[0], rz = pv.x[2][i] - pivot[2];
        Ly += pv.mass[i] * (rz * pv.v[0][i] - rx * pv.v[2][i]);
        double x[3] = {pv.x[0][i], pv.x[1][i], pv.x[2][i]};
        *deepest = fmin(*deepest, kf_collider_sdf(&f, x, n));
    }
    kf_state_destroy(s);
    kf_model_destroy(m);
    return Ly;
}

/* The goo turns with the paddle, both ways: mirroring z maps one sense onto
 * the other (paddle, goo and grid are symmetric about z = 0.5), so the two
 * angular momenta are opposite and equal up to round-off in the order of sums. */
static void rotating_paddle_stirs(void) {
    double deep_p, deep_m;
    double Lp = stir(+1, &deep_p), Lm = stir(-1, &deep_m);
    printf("  paddle: goo angular momentum about its axis %+.4g (turning +y) and %+.4g kg m^2/s (turning -y); "
           "deepest particles %.4f and %.4f m inside\n",
           Lp, Lm, deep_p, deep_m);
    KT_CHECK(Lp > 0 && Lm < 0, "goo turns with the paddle: %.4g, %.4g", Lp, Lm);
    KT_NEAR(Lp, -Lm, 0.01 * Lp, "mirror images (1%: float sums in another order)");
    /* goo in front of a pushing collider sinks into it until every node of its
     * stencil moves with the collider: measured 0.57 Δx here, 0.64 Δx for a
     * box paddle of the same size, so the bound is one cell */
    KT_CHECK(deep_p > -0.025 && deep_m > -0.025, "no particle more than a cell inside the paddle (%.4f, %.4f)", deep_p,
             deep_m);
}

/* softened water sloshing in a closed box container for 0.6 s: the mesh container
 * (tests/meshes/cube.obj with inside: true) or the analytic box with inside;
 * returns how far the farthest particle is outside the box [0.295, 0.705]³ */
static double contain(kf_shape shape, kf_boundary boundary) {
    const double dx = 0.02;
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = dx;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    kf_material water;
    kf_material_preset("water", &water);
    water.bulk_modulus = 1e4; /* a tenth: 3x longer substeps, the same flow at these speeds */
    int mat = kf_model_add_material(m, &water, err, sizeof err);
    double c[3] = {0.5, 0.5, 0.5};
    kf_collider col = {0};
    col.inside = 1;
    col.boundary = boundary;
    memcpy(col.center, c, sizeof col.center);
    kf_mesh_sdf sdf = {0};
    if (shape == KF_SHAPE_MESH) {
        kf_mesh mesh;
        double scale[3] = {0.41, 0.41, 0.41};
        placed_mesh("tests/meshes/cube.obj", (double[3]){0.295, 0.295, 0.295}, 0, NULL, scale, &mesh);
        build_sdf(&mesh, c, 0.5 * dx, &sdf);
        kf_mesh_free(&mesh);
        col.shape = KF_SHAPE_MESH;
        col.sdf = &sdf.grid;
    } else {
        col.shape = KF_SHAPE_BOX;
        col.half[0] = col.half[1] = col.half[2] = 0.205;
    }
    KT_CHECK(kf_model_add_collider(m, &col, err, sizeof err) == 0, "%s", err);
    kf_mesh_sdf_free(&sdf);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.32, 0.32, 0.32}, hi[3] = {0.5, 0.52, 0.52}, v0[3] = {1, 0, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v0, 2, 0);
    char msg[256];
    KT_CHECK(kf_advance(m, s, 0.6, NULL, msg, sizeof msg) == 0, "%s", msg);
    kf_particles_view pv = kf_state_particles(s);
    double worst = -1e9;
    for (size_t i = 0; i < pv.n; i++)
        for (int a = 0; a < 3; a++) worst = fmax(worst, fabs(pv.x[a][i] - 0.5) - 0.205);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return worst;
}

/* A closed mesh used as a container holds water like the analytic box
 * container does. Sticky walls hold it within about half a cell (measured
 * 0.44 Δx; bound 0.6 Δx). Slip walls let the water creep past a corner by
 * about a cell (measured 1.2 Δx), for the mesh and
 * the analytic box alike: a node outside an edge of a container gets the
 * diagonal normal, and slipping along it is sliding outward along a face
 * (the domain walls project each axis on its own and do not have this). */
static void mesh_container_holds(void) {
    const double dx = 0.02;
    double sticky = contain(KF_SHAPE_MESH, KF_BOUNDARY_STICKY);
    double slip_mesh = contain(KF_SHAPE_MESH, KF_BOUNDARY_SLIP), slip_box = contain(KF_SHAPE_BOX, KF_BOUNDARY_SLIP);
    printf("  water in a box container: farthest particle outside it %.4f m (sticky mesh), %.4f m (slip mesh), "
           "%.4f m (slip analytic box)\n",
           sticky, slip_mesh, slip_box);
    KT_CHECK(sticky < 0.6 * dx, "sticky mesh container: no particle beyond 0.6 cell outside (%.4f)", sticky);
    KT_NEAR(slip_mesh, slip_box, 0.15 * dx, "slip: the mesh container leaks no more than the analytic box");
}

/* The collider's pose is evaluated at every substep: a box that dips into a
 * goo block and leaves again within one frame (outside it at both frame
 * boundaries) still pushes the goo down. */
static void acts_between_frames(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.gravity[1] = 0;
    int mat;
    kf_model *m = tu_model(&sd, "goo", 0, -1, 0, &mat);
    kf_collider c = {0};
    c.shape = KF_SHAPE_BOX;
    c.boundary = KF_BOUNDARY_STICKY;
    c.half[0] = c.half[2] = 0.1, c.half[1] = 0.05;
    c.interp = KF_INTERP_SMOOTH;
    c.nkeys = 3;
    const double frame = 1.0 / 24;
    c.keys[0] = key(0, 0.5, 0.66, 0.5);           /* bottom at 0.61, above the goo's top at 0.6 */
    c.keys[1] = key(0.5 * frame, 0.5, 0.58, 0.5); /* 2 cm into the goo */
    c.keys[2] = key(frame, 0.5, 0.66, 0.5);
    char err[256];
    KT_CHECK(kf_model_add_collider(m, &c, err, sizeof err) == 0, "%s", err);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.3, 0.4, 0.3}, hi[3] = {0.7, 0.6, 0.7};
    kf_state_fill_box(s, m, lo, hi, mat, NULL, 2, 0);
    kf_step_stats st = {0};
    char msg[256];
    KT_CHECK(kf_advance(m, s, frame, &st, msg, sizeof msg) == 0, "%s", msg);
    kf_energy e = kf_state_energy(m, s);
    printf("  dip within one frame: %ld substeps, goo momentum (%.3g, %.4g, %.3g) kg m/s, kinetic energy %.3g J\n",
           st.substeps, e.momentum[0], e.momentum[1], e.momentum[2], e.kinetic);
    KT_CHECK(st.substeps > 4, "a frame is several substeps (%ld)", st.substeps);
    /* measured 30.1 J and -15.5 kg m/s down; held to within 2x either way:
     * a collider evaluated only at the frame ends (outside the goo at both)
     * gives nothing, one that pulls instead of pushing gives upward momentum */
    KT_CHECK(e.kinetic > 15 && e.kinetic < 60, "the goo was hit between frames: kinetic %.3g J, measured 30.1 J",
             e.kinetic);
    KT_CHECK(e.momentum[1] < -7.7 && e.momentum[1] > -31, "pushed down: momentum y %.4g kg m/s, measured -15.5",
             e.momentum[1]);
    /* the box and the goo are symmetric about x = z = 0.5: sideways momentum is
     * round-off (measured 5e-8 of the vertical in float, 4e-15 in double) */
    KT_CHECK(fabs(e.momentum[0]) < 1e-4 * fabs(e.momentum[1]) && fabs(e.momentum[2]) < 1e-4 * fabs(e.momentum[1]),
             "straight down: momentum x %.3g, z %.3g against y %.4g", e.momentum[0], e.momentum[2], e.momentum[1]);
    kf_state_destroy(s);
    kf_model_destroy(m);
}

/* ---- the shot path ------------------------------------------------------------------ */

static void copy_file(const char *from, const char *to, const char *append) {
    FILE *f = fopen(from, "rb"), *g = fopen(to, "wb");
    if (!f || !g) {
        fprintf(stderr, "cannot copy %s to %s\n", from, to);
        exit(99);
    }
    int c;
    while ((c = getc(f)) != EOF) putc(c, g);
    if (append) fputs(append, g);
    fclose(f);
    fclose(g);
}

static uint64_t hash_of(const char *path, const char *const *sets, int nsets) {
    kf_diag d;
    kf_diag_init(&d);
    kf_shot *s = kf_shot_load(path, sets, nsets, NULL, NULL, &d);
    uint64_t h = s ? kf_shot_sim_hash(s) : 0;
    if (!s) kf_diag_print(stderr, &d);
    kf_shot_free(s);
    kf_diag_free(&d);
    return h;
}

/* tests/shots/colliders.yaml builds: each mesh collider gets a distance grid
 * of spacing dx/2 in the frame of its pivot, placed as the shot says; the
 * sim hash sees collider keys and the mesh file's bytes; a mesh that is not
 * closed is reported at the collider's mesh: value */
static void shot_builds_colliders(void) {
    kf_diag d;
    kf_diag_init(&d);
    const char *path = tu_repo_path("tests/shots/colliders.yaml");
    kf_shot *shot = kf_shot_load(path, NULL, 0, NULL, NULL, &d);
    KT_CHECK(shot != NULL, "colliders.yaml loads");
    if (!shot) return kf_diag_print(stderr, &d), kf_diag_free(&d);
    kf_scene sc;
    int rc = kf_scene_from_shot(shot, 0, &sc, NULL, &d);
    KT_CHECK(rc == 0, "and builds");
    if (rc) return kf_diag_print(stderr, &d), kf_shot_free(shot), kf_diag_free(&d);
    const kf_model *m = sc.model;
    KT_CHECK(m->ncol == 4 && m->col[0].shape == KF_SHAPE_MESH && m->col[0].sdf, "4 colliders, the first a mesh");
    KT_NEAR(m->col[0].sdf->spacing, 0.5 * shot->sim.dx, 0, "grid spacing dx/2");
    /* spinner: the unit cube, scaled [2, 1, 1], turned 45 degrees about y and
     * fitted to 0.2 (its x and z extents are 3/sqrt 2): half height 0.5 s,
     * s = 0.2 sqrt 2 / 3; centred on the pivot fit.center + translate */
    double s = 0.2 * sqrt(2.0) / 3, pivot[3] = {0.5, 0.35, 0.5}, n[3];
    kf_collider_frame f;
    kf_collider_frame_at(&m->col[0], 0, &f);
    double above[3] = {0.5, 0.35 + 0.5 * s + 0.013, 0.5};
    KT_NEAR(kf_collider_sdf(&f, above, n), 0.013, 1e-5, "13 mm above the top face (flat face: exact)");
    KT_NEAR(n[1], 1, 1e-6, "normal up");
    /* the pivot sits on the crease where the top and side faces are equally
     * near, φ = max(|y|, |z'|) - half there; a trilinear read of a crease is
     * off by up to h/2 (a cell centred on it: all four corners read h/2) */
    double phi_c = kf_collider_sdf(&f, pivot, n), h = m->col[0].sdf->spacing;
    printf("  spinner at its pivot: %.4f m (exact %.4f, h = %g)\n", phi_c, -0.5 * s, h);
    KT_NEAR(phi_c, -0.5 * s, 0.5 * h + 1e-6, "inside at the pivot, within h/2 (a crease)");
    /* at the middle key the spinner is 0.1 m along x, turned 180 degrees and 1.5x larger */
    kf_collider_frame_at(&m->col[0], 0.5, &f);
    double above2[3] = {0.6, 0.35 + 1.5 * 0.5 * s + 0.013, 0.5};
    KT_NEAR(kf_collider_sdf(&f, above2, n), 0.013, 1e-5, "keyed pose: moved, turned, scaled 1.5");
    /* lid: a container, the unit cube at [0.4, 1.4]³ */
    kf_collider_frame_at(&m->col[1], 0, &f);
    KT_NEAR(kf_collider_sdf(&f, (double[3]){0.6, 0.9, 0.9}, n), 0.2, 1e-5,
            "inside the container: free, 0.2 from its wall");
    KT_NEAR(kf_collider_sdf(&f, (double[3]){0.3, 0.9, 0.9}, n), -0.1, 1e-5, "outside it: constrained");
    KT_NEAR(n[0], 1, 1e-6, "pushed back in");
    /* flap: an oriented box, its rest rotation and first key */
    kf_collider_frame_at(&m->col[2], 0, &f);
    KT_NEAR(f.pose.deg[2], -30, 0, "the first key's rotation");
    KT_NEAR(kf_collider_sdf(&f, (double[3]){0.2, 0.8 + 0.02, 0.2}, n), 0.01, 1e-12, "-30 on top of +30: level again");
    kf_scene_free(&sc);

    /* the hash: collider keys and the mesh's bytes */
    uint64_t h0 = kf_shot_sim_hash(shot);
    KT_CHECK(h0 == hash_of(path, NULL, 0), "same shot, same hash");
    const char *set1[] = {"colliders.spinner.interpolation=linear"}, *set2[] = {"colliders.flap.rotate=[0, 0, 31]"},
               *set3[] = {"colliders.lid.pivot=[0.5, 0.5, 0.6]"}, *set4[] = {"colliders.spinner.scale=[2, 1, 1.01]"};
    KT_CHECK(hash_of(path, set1, 1) != h0, "interpolation changes the hash");
    KT_CHECK(hash_of(path, set2, 1) != h0, "a box's rotate changes the hash");
    KT_CHECK(hash_of(path, set3, 1) != h0, "a mesh's pivot changes the hash");
    KT_CHECK(hash_of(path, set4, 1) != h0, "a mesh's placement changes the hash");
    char dir[] = "/tmp/kf_collider_XXXXXX", p1[512], p2[512];
    KT_CHECK(mkdtemp(dir) != NULL, "temp dir");
    snprintf(p1, sizeof p1, "%s/assets", dir);
    mkdir(p1, 0755);
    snprintf(p1, sizeof p1, "%s/colliders.yaml", dir);
    copy_file(path, p1, NULL);
    snprintf(p2, sizeof p2, "%s/assets/cube.off", dir);
    copy_file(tu_repo_path("tests/shots/assets/cube.off"), p2, NULL);
    uint64_t ha = hash_of(p1, NULL, 0);
    copy_file(tu_repo_path("tests/shots/assets/cube.off"), p2, "\n");
    KT_CHECK(hash_of(p1, NULL, 0) != ha, "an edited mesh file changes the hash");

    /* an open mesh: reported at its mesh: line by the builder */
    snprintf(p1, sizeof p1, "%s/open.yaml", dir);
    char open_mesh[PATH_MAX];
    KT_CHECK(realpath(tu_repo_path("tests/meshes/cube_open.obj"), open_mesh) != NULL, "the open mesh exists");
    FILE *y = fopen(p1, "w");
    fprintf(y,
            "frames: {end: 1002}\n"
            "materials: {goo: {preset: goo}}\n"
            "objects: [{shape: box, size: 0.1, center: [0.5, 0.5, 0.5], material: goo}]\n"
            "colliders:\n"
            "  - {name: lid, shape: mesh, mesh: %s}\n",
            open_mesh);
    fclose(y);
    kf_shot_free(shot);
    kf_diag_free(&d);
    kf_diag_init(&d);
    shot = kf_shot_load(p1, NULL, 0, NULL, NULL, &d);
    KT_CHECK(shot != NULL, "an open mesh passes the shot checks (the file exists)");
    if (shot) {
        KT_CHECK(kf_scene_from_shot(shot, 0, &sc, NULL, &d) == -1, "but not the build");
        int found = 0;
        for (int i = 0; i < d.count; i++)
            found |= d.entry[i].line == 5 && d.entry[i].col == 36 && strstr(d.entry[i].message, "collider 'lid': ") &&
                     strstr(d.entry[i].message, "not closed");
        KT_CHECK(found, "reported at 5:36 as not closed");
        if (!found) kf_diag_print(stderr, &d);
    }
    kf_shot_free(shot);
    kf_diag_free(&d);
    char cmd[600];
    snprintf(cmd, sizeof cmd, "rm -rf %s", dir);
    KT_CHECK(system(cmd) == 0, "clean up");
}

int main(int argc, char **argv) {
    KT_RUN(linear_keys, argc, argv);
    KT_RUN(smooth_keys, argc, argv);
    KT_RUN(material_point_velocity, argc, argv);
    KT_RUN(oriented_box_sdf, argc, argv);
    KT_RUN(sdf_grid_reads, argc, argv);
    KT_RUN(mesh_sdf_sphere, argc, argv);
    KT_RUN(mesh_sdf_cube, argc, argv);
    KT_RUN(mesh_collider_matches_sphere, argc, argv);
    KT_RUN(model_validation, argc, argv);
    KT_RUN(block_rests_on_mesh, argc, argv);
    KT_RUN(block_on_mesh_sphere, argc, argv);
    KT_RUN(rotating_paddle_stirs, argc, argv);
    KT_RUN(mesh_container_holds, argc, argv);
    KT_RUN(acts_between_frames, argc, argv);
    KT_RUN(shot_builds_colliders, argc, argv);
    return KT_EXIT();
}
