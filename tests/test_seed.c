/* test_seed.c — rigid particles on a surface (src/rigid/seed*.c, paper
 * §5.2.1): the lattice crossings Embree's rays find against analytic
 * crossings of convex meshes (count and position on every line) and against
 * the independent rasteriser on the real meshes; lines exactly through
 * vertices and edges; the crossings of a flat square independent of its
 * triangulation; and the seeds themselves: every triangle of every mesh in
 * assets/ and tests/meshes (tu_loaded_mesh by assimp) holds a seed, every surface
 * point is within the spacing of one, long thin triangles (a sliver, a tube
 * of 1 m x 1 mm strips) and specks included, and the seeds are
 * bit-identical run to run and for any thread count. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "kt.h"
#include "mesh_util.h"
#include "random_util.h"
#include "rigid/rigid.h"
#include "rigid/seed_crossings.h"
#include "scene/mesh.h"

/* ---- meshes ------------------------------------------------------------- */

static double extent(const kf_mesh *m) {
    double ext = 0;
    for (int a = 0; a < 3; a++) ext = fmax(ext, m->hi[a] - m->lo[a]);
    return ext;
}

/* every mesh file shipped: the seeding must cover each of them */
static const char *const MESHES[] = {"assets/armadillo.off",
                                     "assets/banana_flesh.obj",
                                     "assets/banana_peel.obj",
                                     "assets/blade.obj",
                                     "assets/bowl.obj",
                                     "assets/bunny.off",
                                     "assets/c_leg.obj",
                                     "assets/cross_plates.obj",
                                     "assets/cube.obj",
                                     "assets/knife_wavy.obj",
                                     "assets/paddle.obj",
                                     "assets/paddle_sheet.obj",
                                     "assets/paddle_wheel.obj",
                                     "assets/plate.obj",
                                     "assets/plate_thin.obj",
                                     "assets/scoop.obj",
                                     "assets/sphere.obj",
                                     "assets/stirrer.obj",
                                     "assets/torus.obj",
                                     "assets/wheel.obj",
                                     "tests/meshes/bowtie.obj",
                                     "tests/meshes/cube.obj",
                                     "tests/meshes/cube_open.obj",
                                     "tests/meshes/diamond.obj",
                                     "tests/meshes/octahedron.obj",
                                     "tests/meshes/torus.obj",
                                     "tests/meshes/torus.off",
                                     "tests/meshes/torus.ply",
                                     "tests/meshes/torus.stl",
                                     "tests/meshes/torus_ascii.ply"};
#define NMESHES (int)(sizeof MESHES / sizeof MESHES[0])

/* ---- the seeds ------------------------------------------------------------ */

/* brute-force-free nearest-seed check: a uniform grid of the seeds */
typedef struct seed_grid {
    double lo[3], cell;
    int n[3];
    int *start, *idx;
    const float *seed;
} seed_grid;

static void seed_grid_build(seed_grid *g, const float *seed, size_t ns, double cell) {
    g->seed = seed, g->cell = cell;
    double hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int a = 0; a < 3; a++) g->lo[a] = INFINITY;
    for (size_t i = 0; i < ns; i++)
        for (int a = 0; a < 3; a++) g->lo[a] = fmin(g->lo[a], seed[3 * i + a]), hi[a] = fmax(hi[a], seed[3 * i + a]);
    for (int a = 0; a < 3; a++) g->lo[a] -= cell, g->n[a] = (int)((hi[a] - g->lo[a]) / cell) + 2;
    size_t nc = (size_t)g->n[0] * g->n[1] * g->n[2];
    g->start = calloc(nc + 1, sizeof(int));
    g->idx = malloc(sizeof(int) * ns);
    int *cellof = malloc(sizeof(int) * ns);
    for (size_t i = 0; i < ns; i++) {
        int c[3];
        for (int a = 0; a < 3; a++) c[a] = (int)((seed[3 * i + a] - g->lo[a]) / cell);
        cellof[i] = (c[0] * g->n[1] + c[1]) * g->n[2] + c[2];
        g->start[cellof[i] + 1]++;
    }
    for (size_t c = 0; c < nc; c++) g->start[c + 1] += g->start[c];
    int *fill = calloc(nc, sizeof(int));
    for (size_t i = 0; i < ns; i++) g->idx[g->start[cellof[i]] + fill[cellof[i]]++] = (int)i;
    free(fill);
    free(cellof);
}

/* distance from p to the nearest seed, or INFINITY beyond one cell */
static double seed_grid_nearest(const seed_grid *g, const double p[3]) {
    int c[3];
    for (int a = 0; a < 3; a++) c[a] = (int)floor((p[a] - g->lo[a]) / g->cell);
    double best = INFINITY;
    for (int i = c[0] - 1; i <= c[0] + 1; i++)
        for (int j = c[1] - 1; j <= c[1] + 1; j++)
            for (int k = c[2] - 1; k <= c[2] + 1; k++) {
                if (i < 0 || j < 0 || k < 0 || i >= g->n[0] || j >= g->n[1] || k >= g->n[2]) continue;
                int cc = (i * g->n[1] + j) * g->n[2] + k;
                for (int q = g->start[cc]; q < g->start[cc + 1]; q++) {
                    const float *x = g->seed + 3 * g->idx[q];
                    double d[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]};
                    best = fmin(best, sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]));
                }
            }
    return best;
}

/* every triangle holds a seed; every seed lies on its triangle; random
 * points of every triangle (and its corners) are within spacing of a seed.
 * Returns the seed count. */
static size_t check_seeding(const char *what, const double *vert, int nvert, const int *tri, int ntri, double spacing,
                            int samples_per_tri) {
    float *seed;
    int32_t *seed_tri;
    size_t ns = kf_rigid_seed_surface(vert, nvert, tri, ntri, spacing, &seed, &seed_tri);
    KT_CHECK(ns > 0, "%s: seeded", what);
    if (!ns) return 0;
    int *count = calloc((size_t)ntri, sizeof(int));
    double worst_off = 0, scale = 0;
    for (int i = 0; i < 3 * nvert; i++) scale = fmax(scale, fabs(vert[i]));
    for (size_t i = 0; i < ns; i++) {
        int t = seed_tri[i];
        if (t < 0 || t >= ntri) {
            KT_CHECK(0, "%s: seed %zu on triangle %d", what, i, t);
            continue;
        }
        count[t]++;
        /* distance to the triangle's plane */
        const double *a = vert + 3 * tri[3 * t], *b = vert + 3 * tri[3 * t + 1], *c = vert + 3 * tri[3 * t + 2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        double ln = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        if (ln > 0) {
            double off =
                fabs((seed[3 * i] - a[0]) * n[0] + (seed[3 * i + 1] - a[1]) * n[1] + (seed[3 * i + 2] - a[2]) * n[2]) /
                ln;
            worst_off = fmax(worst_off, off);
        }
    }
    int empty = 0;
    double area = 0;
    for (int t = 0; t < ntri; t++) {
        empty += count[t] == 0;
        const double *a = vert + 3 * tri[3 * t], *b = vert + 3 * tri[3 * t + 1], *c = vert + 3 * tri[3 * t + 2];
        double e1[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]}, e2[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
        double n[3] = {e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2], e1[0] * e2[1] - e1[1] * e2[0]};
        area += 0.5 * sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    }
    KT_CHECK(empty == 0, "%s: %d of %d triangles hold no seed", what, empty, ntri);
    KT_CHECK(worst_off <= 1e-6 * scale, "%s: a seed lies %g off its triangle's plane (float: 1e-6 of the extent %g)",
             what, worst_off, scale);
    seed_grid g;
    seed_grid_build(&g, seed, ns, spacing);
    double worst = 0;
    long checked = 0;
    for (int t = 0; t < ntri; t++) {
        const double *a = vert + 3 * tri[3 * t], *b = vert + 3 * tri[3 * t + 1], *c = vert + 3 * tri[3 * t + 2];
        for (int k = 0; k < samples_per_tri + 3; k++) {
            double u = urand(), v = urand();
            if (k >= samples_per_tri) u = k == samples_per_tri, v = k == samples_per_tri + 1; /* the corners */
            if (u + v > 1) u = 1 - u, v = 1 - v;
            double p[3];
            for (int q = 0; q < 3; q++) p[q] = a[q] + u * (b[q] - a[q]) + v * (c[q] - a[q]);
            worst = fmax(worst, seed_grid_nearest(&g, p));
            checked++;
        }
    }
    /* the float seeds move by up to 6e-8 of the extent */
    KT_CHECK(worst <= spacing * (1 + 1e-6) + 1e-7 * scale,
             "%s: a surface point is %g from the nearest seed (spacing %g)", what, worst, spacing);
    printf("  %-16s %6d triangles, spacing %.4g: %7zu seeds (%.2f per spacing² of area), farthest point %.3f spacing "
           "(%ld points)\n",
           what, ntri, spacing, ns, ns / (area / (spacing * spacing)), worst / spacing, checked);
    free(g.start);
    free(g.idx);
    free(count);
    free(seed);
    free(seed_tri);
    return ns;
}

/* a long thin triangle (1 m by 2 mm) and a tiny one, far below the lattice */
static void test_seed_slivers(void) {
    const double v[18] = {0, 0, 0, 1, 0, 0, 0.5, 0.002, 0.001, 2, 2, 2, 2.001, 2, 2, 2, 2.001, 2.0005};
    const int t[6] = {0, 1, 2, 3, 4, 5};
    size_t n = check_seeding("sliver + speck", v, 6, t, 2, 0.05, 2000);
    /* a line of seeds, not an area's worth: the sliver needs about 1 m / spacing */
    KT_CHECK(n < 4 * 1.0 / 0.05, "%zu seeds for a 1 m sliver at spacing 0.05", n);
}

/* a closed tube of long thin triangles only: 1 m long, radius 1 cm, 64
 * strips each cut into two triangles along its whole length (1 m by 1 mm:
 * aspect 1000, narrower than the lattice and than the hole pass's δ),
 * tilted off the axes. The lattice lines still cross it (most on a strip's
 * interior, some near its long edges); the hole pass covers the rest. */
static void test_seed_thin_tube(void) {
    const int m = 64;
    const double PI = 3.14159265358979323846, R = 0.01, spacing = 0.02;
    double v[2 * 64 * 3], Q[9];
    int t[2 * 64 * 3];
    random_rotation(Q);
    for (int k = 0; k < m; k++)
        for (int e = 0; e < 2; e++) {
            double p[3] = {R * cos(2 * PI * k / m), R * sin(2 * PI * k / m), e ? 1.0 : 0.0};
            for (int r = 0; r < 3; r++)
                v[3 * (2 * k + e) + r] = Q[3 * r] * p[0] + Q[3 * r + 1] * p[1] + Q[3 * r + 2] * p[2];
        }
    for (int k = 0; k < m; k++) {
        int a = 2 * k, b = 2 * k + 1, c = 2 * ((k + 1) % m), d = c + 1;
        t[6 * k] = a, t[6 * k + 1] = c, t[6 * k + 2] = d, t[6 * k + 3] = a, t[6 * k + 4] = d, t[6 * k + 5] = b;
    }
    size_t n = check_seeding("tube of slivers", v, 2 * m, t, 2 * m, spacing, 500);
    /* about 2π R x 1 m / spacing² ≈ 157 spacing² of area: an area's worth of
     * seeds (2 to 4 per spacing² on the other meshes), not one per check point */
    KT_CHECK(n > 157 && n < 10 * 157, "%zu seeds for 157 spacing² of tube", n);
}

/* the same flat square cut into 2 and into 2 x 8² triangles gets nearly the
 * same number of seeds (the lattice crossings are the surface's, the hole
 * fill differs only along the inner edges) */
static void test_seed_triangulation_independent(void) {
    int cuts[2] = {1, 8};
    size_t count[2];
    for (int c = 0; c < 2; c++) {
        int m = cuts[c], nv = (m + 1) * (m + 1), nt = 2 * m * m;
        double *v = malloc(sizeof(double) * 3 * nv);
        int *t = malloc(sizeof(int) * 3 * nt);
        for (int i = 0; i <= m; i++)
            for (int j = 0; j <= m; j++) {
                double *p = v + 3 * (i * (m + 1) + j);
                /* tilted so every axis crosses it */
                double x = (double)i / m, y = (double)j / m;
                p[0] = x, p[1] = 0.3 * x + 0.5 * y, p[2] = y;
            }
        int k = 0;
        for (int i = 0; i < m; i++)
            for (int j = 0; j < m; j++) {
                int a = i * (m + 1) + j, b = a + 1, cc = a + m + 1, d = cc + 1;
                t[k++] = a, t[k++] = cc, t[k++] = d, t[k++] = a, t[k++] = d, t[k++] = b;
            }
        char what[32];
        snprintf(what, sizeof what, "square / %d tris", nt);
        count[c] = check_seeding(what, v, nv, t, nt, 0.02, 50);
        free(v);
        free(t);
    }
    KT_NEAR((double)count[1] / count[0], 1, 0.05, "the seeds of a flat square do not depend on its triangulation (5%)");
}

/* every mesh shipped, at a spacing of 1/60 of its size (the scale of dx/2 on
 * a typical shot) */
static void test_seed_meshes(void) {
    for (int f = 0; f < NMESHES; f++) {
        tu_loaded_mesh L;
        if (tu_load_mesh(MESHES[f], &L)) continue;
        const char *name = strrchr(MESHES[f], '/') + 1;
        check_seeding(name, L.m.vert, (int)L.m.nvert, L.tri, (int)L.m.ntri, extent(&L.m) / 60, 8);
        tu_free_mesh(&L);
    }
}

/* ---- the crossings -------------------------------------------------------- */

/* the crossings on one line: c[k..*end) */
static size_t line_end(const kf_seed_crossing *c, size_t n, size_t k, int a, int32_t i, int32_t j) {
    while (k < n && c[k].axis == a && c[k].j == j && c[k].i == i) k++;
    return k;
}

/* the line along axis a through (ub, wc) clipped by the face planes of a
 * convex mesh (outward: away from its centre): the interval [*s_in, *s_out]
 * of the axis coordinate inside it; *s_in > *s_out when the line misses */
static void clip_line(const double *vert, const int *tri, int ntri, const double centre[3], int a, double ub, double wc,
                      double *s_in, double *s_out) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    double base[3];
    base[a] = 0, base[b] = ub, base[c] = wc;
    *s_in = -INFINITY, *s_out = INFINITY;
    for (int t = 0; t < ntri; t++) {
        const double *p = vert + 3 * tri[3 * t], *q = vert + 3 * tri[3 * t + 1], *r = vert + 3 * tri[3 * t + 2];
        double e[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]}, f[3] = {r[0] - p[0], r[1] - p[1], r[2] - p[2]};
        double nn[3] = {e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0]};
        double len = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
        if (!(len > 0)) continue;
        double side = (p[0] - centre[0]) * nn[0] + (p[1] - centre[1]) * nn[1] + (p[2] - centre[2]) * nn[2];
        double sg = side < 0 ? -1 : 1, m[3] = {sg * nn[0] / len, sg * nn[1] / len, sg * nn[2] / len};
        /* inside: m·(base + s e_a) <= m·p */
        double g = m[0] * (p[0] - base[0]) + m[1] * (p[1] - base[1]) + m[2] * (p[2] - base[2]);
        if (m[a] > 0) *s_out = fmin(*s_out, g / m[a]);
        else if (m[a] < 0) *s_in = fmax(*s_in, g / m[a]);
        else if (g < 0) *s_in = INFINITY, *s_out = -INFINITY;
    }
}

/* on every line of the lattice through a convex mesh: no crossing where the
 * line misses, exactly two where it passes through (one per entry and exit,
 * however many triangles meet there), at the clipped interval's ends.
 * Lines within 1e-6 of the extent of grazing the mesh are left out (a line
 * touching an edge may count 0, 1 or 2) and counted. */
static void check_convex(const char *what, const double *vert, int nvert, const int *tri, int ntri, double h) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, centre[3] = {0, 0, 0};
    for (int v = 0; v < nvert; v++)
        for (int a = 0; a < 3; a++) {
            lo[a] = fmin(lo[a], vert[3 * v + a]), hi[a] = fmax(hi[a], vert[3 * v + a]);
            centre[a] += vert[3 * v + a] / nvert;
        }
    double ext = fmax(hi[0] - lo[0], fmax(hi[1] - lo[1], hi[2] - lo[2]));
    kf_seed_lattice L;
    kf_seed_lattice_for(lo, hi, h, &L);
    kf_seed_crossing *c;
    char err[256] = "";
    long n = kf_seed_crossings_rays(vert, nvert, tri, ntri, &L, &c, err, sizeof err);
    KT_CHECK(n >= 0, "%s: %s", what, err);
    if (n < 0) return;
    long lines = 0, through = 0, grazing = 0, wrong = 0, expected = 0;
    double worst = 0;
    size_t k = 0;
    for (int a = 0; a < 3; a++) {
        const int b = (a + 1) % 3, cc = (a + 2) % 3;
        for (int32_t j = 0; j < L.n[cc]; j++)
            for (int32_t i = 0; i < L.n[b]; i++) {
                lines++;
                size_t e = line_end(c, (size_t)n, k, a, i, j);
                double s0, s1;
                clip_line(vert, tri, ntri, centre, a, L.o[b] + i * L.h, L.o[cc] + j * L.h, &s0, &s1);
                if (fabs(s1 - s0) <= 1e-6 * ext) {
                    grazing++;
                } else if (s1 < s0) {
                    wrong += e != k;
                } else {
                    through++, expected += 2;
                    if (e - k != 2) {
                        if (wrong++ < 5)
                            fprintf(stderr, "  %s: line %d (%d, %d) has %zu crossings, expected 2 at %.9g, %.9g\n",
                                    what, a, i, j, e - k, s0, s1);
                    } else {
                        worst = fmax(worst, fmax(fabs(c[k].x[a] - s0), fabs(c[k + 1].x[a] - s1)));
                        /* and on the line itself */
                        double db = fabs(c[k].x[b] - (L.o[b] + i * L.h)), dc = fabs(c[k].x[cc] - (L.o[cc] + j * L.h));
                        worst = fmax(worst, fmax(db, dc));
                    }
                }
                k = e;
            }
    }
    KT_CHECK(k == (size_t)n, "%s: %zu of %ld crossings on no lattice line", what, (size_t)n - k, n);
    KT_CHECK(wrong == 0, "%s: %ld of %ld lines with the wrong number of crossings", what, wrong, lines);
    KT_NEAR(grazing, 0, lines / 1000, "a line within 1e-6 of grazing a convex mesh is rare (0.1% of the lines)");
    /* the points are recomputed in double on the exact line: round-off of the
     * barycentric solve, plus the clamp onto a triangle Embree's float test
     * took near an edge (up to float's 6e-8 of the extent, times the edge's
     * slant) */
    KT_CHECK(worst <= 1e-6 * ext, "%s: a crossing %g from the analytic one (extent %g)", what, worst, ext);
    printf("  %-16s %5d triangles, %6ld lines (%ld through, %ld grazing): %6ld crossings, %ld expected, worst %.2e "
           "of the extent\n",
           what, ntri, lines, through, grazing, n, expected, worst / ext);
    free(c);
}

/* convex meshes whose crossings are known in closed form: the unit cube
 * (lines parallel to faces), the same cube turned by a random rotation, the
 * octahedron, the square prism and the 64 x 32 UV sphere (many triangles
 * meeting at its poles) */
static const int BOX_TRI[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3};
static void test_crossings_convex_analytic(void) {
    const char *files[4] = {"tests/meshes/cube.obj", "tests/meshes/octahedron.obj", "tests/meshes/diamond.obj",
                            "assets/sphere.obj"};
    for (int f = 0; f < 4; f++) {
        tu_loaded_mesh L;
        if (tu_load_mesh(files[f], &L)) continue;
        double ext = extent(&L.m);
        check_convex(strrchr(files[f], '/') + 1, L.m.vert, (int)L.m.nvert, L.tri, (int)L.m.ntri, ext / 41);
        tu_free_mesh(&L);
    }
    /* a 1 x 0.6 x 0.3 box turned and moved */
    double Q[9], v[24];
    random_rotation(Q);
    for (int i = 0; i < 8; i++) {
        double p[3] = {(i == 1 || i == 2 || i == 5 || i == 6) * 1.0, (i == 2 || i == 3 || i == 6 || i == 7) * 0.6,
                       (i >= 4) * 0.3};
        for (int r = 0; r < 3; r++)
            v[3 * i + r] = Q[3 * r] * p[0] + Q[3 * r + 1] * p[1] + Q[3 * r + 2] * p[2] + 0.1 * r;
    }
    check_convex("turned box", v, 8, BOX_TRI, 12, 0.013);
}

/* the rays and the rasteriser find the same crossings on the real meshes:
 * line by line the same count, the same triangle, the same point. They share
 * no code but the point-on-line formula; where they can differ is a line
 * within round-off of an edge (Embree decides in float, the rasteriser in
 * double), counted and reported. */
static void test_crossings_match_raster(void) {
    long all_lines = 0, all_diff = 0, all_cross = 0;
    for (int f = 0; f < NMESHES; f++) {
        tu_loaded_mesh M;
        if (tu_load_mesh(MESHES[f], &M)) continue;
        const double ext = extent(&M.m);
        kf_seed_lattice L;
        kf_seed_lattice_for(M.m.lo, M.m.hi, 0.7 * ext / 60, &L);
        kf_seed_crossing *r, *s;
        char err[256] = "";
        long nr = kf_seed_crossings_rays(M.m.vert, (int)M.m.nvert, M.tri, (int)M.m.ntri, &L, &r, err, sizeof err);
        long ns = kf_seed_crossings_raster(M.m.vert, (int)M.m.nvert, M.tri, (int)M.m.ntri, &L, &s, err, sizeof err);
        KT_CHECK(nr >= 0 && ns >= 0, "%s: %s", MESHES[f], err);
        if (nr < 0 || ns < 0) continue;
        long lines = 0, diff_lines = 0, other_tri = 0;
        double worst = 0;
        size_t kr = 0, ks = 0;
        for (int a = 0; a < 3; a++) {
            const int b = (a + 1) % 3, c = (a + 2) % 3;
            for (int32_t j = 0; j < L.n[c]; j++)
                for (int32_t i = 0; i < L.n[b]; i++) {
                    size_t er = line_end(r, (size_t)nr, kr, a, i, j), es = line_end(s, (size_t)ns, ks, a, i, j);
                    if (er == kr && es == ks) continue;
                    lines++;
                    if (er - kr != es - ks) {
                        if (diff_lines++ < 3)
                            fprintf(stderr, "  %s: line %d (%d, %d): %zu crossings by rays, %zu by rasterising\n",
                                    MESHES[f], a, i, j, er - kr, es - ks);
                    } else
                        for (size_t q = 0; q < er - kr; q++) {
                            other_tri += r[kr + q].tri != s[ks + q].tri;
                            for (int d = 0; d < 3; d++) worst = fmax(worst, fabs(r[kr + q].x[d] - s[ks + q].x[d]));
                        }
                    kr = er, ks = es;
                }
        }
        KT_CHECK(kr == (size_t)nr && ks == (size_t)ns, "%s: crossings off the lattice", MESHES[f]);
        /* the same line, the same plane: the points agree to double round-off
         * unless the two took different triangles at an edge (then both are
         * clamped to it: float round-off, 6e-8 of the extent) */
        KT_CHECK(worst <= (other_tri ? 1e-6 : 1e-12) * ext, "%s: crossings %g apart", MESHES[f], worst);
        KT_CHECK(diff_lines <= lines / 10000, "%s: %ld of %ld lines with different crossing counts", MESHES[f],
                 diff_lines, lines);
        printf("  %-18s %6ld lines crossing, %7ld crossings (rays) %7ld (raster), lines differing %ld, other "
               "triangle %ld, worst %.1e of the extent\n",
               strrchr(MESHES[f], '/') + 1, lines, nr, ns, diff_lines, other_tri, worst / ext);
        all_lines += lines, all_diff += diff_lines, all_cross += nr;
        free(r);
        free(s);
        tu_free_mesh(&M);
    }
    printf("  all meshes: %ld lines, %ld crossings, %ld lines differing\n", all_lines, all_cross, all_diff);
}

/* lines exactly through vertices and edges: a tilted sheet y = 0.3 x + 0.5 z
 * whose m x m cells have their corners on every second lattice line, so each
 * line along y through the sheet meets a vertex (6 triangles), the middle of
 * an edge (2 triangles) or the middle of a cell's diagonal (2 triangles).
 * Embree's watertight mode must find each such crossing, and the repeats at
 * the shared point must go: exactly one crossing per interior line, at
 * y = 0.3 x + 0.5 z. Rim lines touch the sheet's boundary edge: at most one. */
static void test_crossings_through_vertices(void) {
    const int m = 12;
    kf_seed_lattice L = {.o = {0.0131, -0.2, 0.0297}, .h = 0.05, .n = {2 * m + 1, 0, 2 * m + 1}};
    const int nv = (m + 1) * (m + 1), nt = 2 * m * m;
    double *v = malloc(sizeof(double) * 3 * nv);
    int *t = malloc(sizeof(int) * 3 * nt);
    for (int i = 0; i <= m; i++)
        for (int j = 0; j <= m; j++) {
            double *p = v + 3 * (i * (m + 1) + j);
            /* the same expression as the ray's line, o + index * h */
            p[0] = L.o[0] + (2 * i) * L.h, p[2] = L.o[2] + (2 * j) * L.h;
            p[1] = 0.3 * p[0] + 0.5 * p[2];
        }
    int k = 0;
    for (int i = 0; i < m; i++)
        for (int j = 0; j < m; j++) {
            int a = i * (m + 1) + j, b = a + 1, cc = a + m + 1, d = cc + 1;
            t[k++] = a, t[k++] = cc, t[k++] = d, t[k++] = a, t[k++] = d, t[k++] = b;
        }
    double ylo = INFINITY, yhi = -INFINITY;
    for (int q = 0; q < nv; q++) ylo = fmin(ylo, v[3 * q + 1]), yhi = fmax(yhi, v[3 * q + 1]);
    L.o[1] = ylo - 0.37 * L.h, L.n[1] = (int32_t)floor((yhi - L.o[1]) / L.h) + 1;
    kf_seed_crossing *c;
    char err[256] = "";
    long n = kf_seed_crossings_rays(v, nv, t, nt, &L, &c, err, sizeof err);
    KT_CHECK(n > 0, "%s", err);
    if (n <= 0) return;
    /* along y (axis 1): b = z (i), c = x (j) */
    long interior = 0, bad = 0, rim_hits = 0;
    double worst = 0, off_plane = 0;
    size_t q = 0;
    while (q < (size_t)n && c[q].axis < 1) q++;
    for (int32_t j = 0; j < L.n[0]; j++)
        for (int32_t i = 0; i < L.n[2]; i++) {
            size_t e = line_end(c, (size_t)n, q, 1, i, j);
            int rim = i == 0 || j == 0 || i == 2 * m || j == 2 * m;
            if (rim) {
                rim_hits += e - q;
                bad += e - q > 1;
            } else {
                interior++;
                if (e - q != 1) {
                    if (bad++ < 5) fprintf(stderr, "  line (%d, %d): %zu crossings\n", i, j, e - q);
                } else {
                    double x = L.o[0] + j * L.h, z = L.o[2] + i * L.h;
                    worst = fmax(worst, fabs(c[q].x[1] - (0.3 * x + 0.5 * z)));
                    worst = fmax(worst, fmax(fabs(c[q].x[0] - x), fabs(c[q].x[2] - z)));
                }
            }
            q = e;
        }
    KT_CHECK(bad == 0, "%ld of %ld lines through vertices and edges with the wrong number of crossings", bad, interior);
    KT_CHECK(worst <= 1e-14, "a crossing %g off its analytic point (double round-off of values ~1)", worst);
    /* the crossings of the other two axes lie on the sheet too */
    for (long p = 0; p < n; p++) off_plane = fmax(off_plane, fabs(c[p].x[1] - 0.3 * c[p].x[0] - 0.5 * c[p].x[2]));
    KT_CHECK(off_plane <= 1e-14, "a crossing %g off the sheet", off_plane);
    printf("  %ld interior lines through vertices/edges: one crossing each; %ld of %d rim lines hit; %ld crossings in "
           "all, worst %.1e\n",
           interior, rim_hits, 8 * m, n, worst);
    free(c);
    free(v);
    free(t);
}

/* the crossings of a flat square are the same points whether it is cut into
 * 2 triangles or 2 x 8² (a line through an inner edge crosses once either
 * way): coverage does not depend on the triangulation */
static void test_crossings_triangulation_independent(void) {
    kf_seed_crossing *c[2];
    long n[2];
    for (int s = 0; s < 2; s++) {
        int m = s ? 8 : 1, nv = (m + 1) * (m + 1), nt = 2 * m * m;
        double *v = malloc(sizeof(double) * 3 * nv);
        int *t = malloc(sizeof(int) * 3 * nt);
        for (int i = 0; i <= m; i++)
            for (int j = 0; j <= m; j++) {
                double *p = v + 3 * (i * (m + 1) + j), x = (double)i / m, y = (double)j / m;
                p[0] = x, p[1] = 0.3 * x + 0.5 * y, p[2] = y; /* tilted so every axis crosses it */
            }
        int k = 0;
        for (int i = 0; i < m; i++)
            for (int j = 0; j < m; j++) {
                int a = i * (m + 1) + j, b = a + 1, cc = a + m + 1, d = cc + 1;
                t[k++] = a, t[k++] = cc, t[k++] = d, t[k++] = a, t[k++] = d, t[k++] = b;
            }
        kf_seed_lattice L;
        kf_seed_lattice_for((double[3]){0, 0, 0}, (double[3]){1, 0.8, 1}, 0.7 * 0.02, &L);
        char err[256] = "";
        n[s] = kf_seed_crossings_rays(v, nv, t, nt, &L, &c[s], err, sizeof err);
        KT_CHECK(n[s] > 0, "%s", err);
        free(v);
        free(t);
    }
    if (n[0] <= 0 || n[1] <= 0) return;
    KT_CHECK(n[0] == n[1], "%ld crossings on 2 triangles, %ld on 128", n[0], n[1]);
    double worst = 0;
    long other_line = 0;
    for (long k = 0; k < n[0] && k < n[1]; k++) {
        other_line += c[0][k].axis != c[1][k].axis || c[0][k].i != c[1][k].i || c[0][k].j != c[1][k].j;
        for (int d = 0; d < 3; d++) worst = fmax(worst, fabs(c[0][k].x[d] - c[1][k].x[d]));
    }
    KT_CHECK(other_line == 0, "%ld crossings on other lines", other_line);
    KT_CHECK(worst <= 1e-14, "crossings %g apart (the same plane: double round-off of values ~1)", worst);
    printf("  %ld crossings on 2 and on 128 triangles, at most %.1e apart\n", n[0], worst);
    free(c[0]);
    free(c[1]);
}

/* the seeds are bit-identical run to run and for 1, 2 and 3 threads */
static void test_seed_deterministic(void) {
    tu_loaded_mesh L;
    if (tu_load_mesh("assets/bunny.off", &L)) return;
    const double spacing = extent(&L.m) / 60;
    const int threads[4] = {2, 1, 2, 3};
    float *seed0 = NULL;
    int32_t *tri0 = NULL;
    size_t n0 = 0;
    const int saved = omp_get_max_threads();
    for (int r = 0; r < 4; r++) {
        omp_set_num_threads(threads[r]);
        float *seed;
        int32_t *st;
        size_t n = kf_rigid_seed_surface(L.m.vert, (int)L.m.nvert, L.tri, (int)L.m.ntri, spacing, &seed, &st);
        KT_CHECK(n > 0, "seeded with %d threads", threads[r]);
        if (!r) {
            seed0 = seed, tri0 = st, n0 = n;
            continue;
        }
        KT_CHECK(n == n0 && !memcmp(seed, seed0, sizeof(float) * 3 * n) && !memcmp(st, tri0, sizeof(int32_t) * n),
                 "run %d (%d threads): %zu seeds, first run %zu; not bit-identical", r, threads[r], n, n0);
        free(seed);
        free(st);
    }
    omp_set_num_threads(saved);
    printf("  bunny: %zu seeds, bit-identical over 4 runs with 2, 1, 2 and 3 threads\n", n0);
    free(seed0);
    free(tri0);
    tu_free_mesh(&L);
}

int main(int argc, char **argv) {
    KT_RUN(test_crossings_convex_analytic, argc, argv);
    KT_RUN(test_crossings_match_raster, argc, argv);
    KT_RUN(test_crossings_through_vertices, argc, argv);
    KT_RUN(test_crossings_triangulation_independent, argc, argv);
    KT_RUN(test_seed_meshes, argc, argv);
    KT_RUN(test_seed_slivers, argc, argv);
    KT_RUN(test_seed_thin_tube, argc, argv);
    KT_RUN(test_seed_triangulation_independent, argc, argv);
    KT_RUN(test_seed_deterministic, argc, argv);
    return KT_EXIT();
}
