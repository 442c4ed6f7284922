/* make_meshes — writes kerf's generated meshes, so they can be remade.
 *
 *   make_meshes <outdir>              the asset meshes (assets/): plates, a wavy
 *                                     and a straight knife, a paddle, a wheel, a
 *                                     bowl, a C-shaped robot leg, a banana's
 *                                     flesh and peel, and a closed cube, sphere
 *                                     and torus; then open
 *                                     thin sheets for rigid bodies (crossing
 *                                     plates, a scoop, a paddle wheel, a paddle
 *                                     outline, a stirrer)
 *   make_meshes --fixtures <outdir>   the small test meshes (tests/meshes/):
 *                                     one torus in OBJ, PLY, STL and OFF, cubes,
 *                                     an octahedron, a 45°-turned square prism,
 *                                     and deliberately broken files (open,
 *                                     non-manifold, self-intersecting, empty,
 *                                     garbage)
 *
 * Every solid goes through kf_mesh_from_arrays before it is written: it must
 * come out closed, consistently oriented, of positive volume and not
 * intersecting itself (kf_mesh_check_self_intersection), and what is
 * written is that welded, outward-oriented mesh. Coordinates are rounded to
 * float first, so every format holds exactly the same numbers. Units: metres,
 * y up. */
/* no fused multiply-adds, so a Debug and a -march=native Release build write
 * the same bytes */
#pragma GCC optimize("fp-contract=off")

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "scene/mesh.h"
#include "scene/mesh_isect.h"

static const double PI = 3.14159265358979323846;

/* ---- a growing triangle soup --------------------------------------------- */

typedef struct build {
    double *v;
    uint32_t *t;
    size_t nv, nt, cv, ct;
} build;

static uint32_t vtx(build *b, double x, double y, double z) {
    if (b->nv == b->cv) {
        b->cv = b->cv ? 2 * b->cv : 1024;
        b->v = realloc(b->v, b->cv * 3 * sizeof *b->v);
        if (!b->v) exit(3);
    }
    /* float-exact, so OBJ, PLY, STL and OFF hold identical numbers */
    b->v[3 * b->nv] = (float)x + 0.0f, b->v[3 * b->nv + 1] = (float)y + 0.0f, b->v[3 * b->nv + 2] = (float)z + 0.0f;
    return (uint32_t)b->nv++;
}

static void tri(build *b, uint32_t p, uint32_t q, uint32_t r) {
    if (b->nt == b->ct) {
        b->ct = b->ct ? 2 * b->ct : 1024;
        b->t = realloc(b->t, b->ct * 3 * sizeof *b->t);
        if (!b->t) exit(3);
    }
    b->t[3 * b->nt] = p, b->t[3 * b->nt + 1] = q, b->t[3 * b->nt + 2] = r;
    b->nt++;
}

static void quad(build *b, uint32_t p, uint32_t q, uint32_t r, uint32_t s) {
    tri(b, p, q, r);
    tri(b, p, r, s);
}

static void build_free(build *b) {
    free(b->v);
    free(b->t);
    memset(b, 0, sizeof *b);
}

/* ---- shapes ----------------------------------------------------------------- */

static void box(build *b, const double lo[3], const double hi[3]) {
    uint32_t c[8];
    for (int i = 0; i < 8; i++) c[i] = vtx(b, i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1], i & 4 ? hi[2] : lo[2]);
    quad(b, c[0], c[2], c[3], c[1]); /* z lo */
    quad(b, c[4], c[5], c[7], c[6]); /* z hi */
    quad(b, c[0], c[1], c[5], c[4]); /* y lo */
    quad(b, c[2], c[6], c[7], c[3]); /* y hi */
    quad(b, c[0], c[4], c[6], c[2]); /* x lo */
    quad(b, c[1], c[3], c[7], c[5]); /* x hi */
}

/* Revolve a profile (r, y) about the y axis in ns segments. An open profile
 * must start and end on the axis (r == 0: a single pole vertex); a closed one
 * (loop = 1) must stay off it. */
static void revolve(build *b, int m, const double (*prof)[2], int ns, int loop) {
    uint32_t *ring = malloc((size_t)m * sizeof *ring); /* first vertex of each profile point's ring */
    for (int p = 0; p < m; p++) {
        if (prof[p][0] <= 0) {
            ring[p] = vtx(b, 0, prof[p][1], 0);
            continue;
        }
        for (int s = 0; s < ns; s++) {
            double a = 2 * PI * s / ns;
            uint32_t id = vtx(b, prof[p][0] * cos(a), prof[p][1], -prof[p][0] * sin(a));
            if (s == 0) ring[p] = id;
        }
    }
    int segs = loop ? m : m - 1;
    for (int p = 0; p < segs; p++) {
        int q = (p + 1) % m;
        int pole_p = prof[p][0] <= 0, pole_q = prof[q][0] <= 0;
        for (int s = 0; s < ns; s++) {
            int s1 = (s + 1) % ns;
            /* outward when the profile runs counter-clockwise in the (r, y) plane */
            if (pole_p && !pole_q) tri(b, ring[p], ring[q] + s1, ring[q] + s);
            else if (!pole_p && pole_q) tri(b, ring[p] + s, ring[p] + s1, ring[q]);
            else if (!pole_p && !pole_q) quad(b, ring[p] + s, ring[p] + s1, ring[q] + s1, ring[q] + s);
        }
    }
    free(ring);
}

static void uv_sphere(build *b, double r, int ns, int nr) {
    double(*prof)[2] = malloc((size_t)(nr + 1) * sizeof *prof);
    for (int i = 0; i <= nr; i++) {
        double phi = PI * i / nr;
        prof[i][0] = i == 0 || i == nr ? 0 : r * sin(phi);
        prof[i][1] = -r * cos(phi);
    }
    revolve(b, nr + 1, (const double(*)[2])prof, ns, 0);
    free(prof);
}

static void torus(build *b, double R, double r, int ns, int nr) {
    double(*prof)[2] = malloc((size_t)nr * sizeof *prof);
    for (int i = 0; i < nr; i++) {
        double phi = 2 * PI * i / nr;
        prof[i][0] = R + r * cos(phi);
        prof[i][1] = r * sin(phi);
    }
    revolve(b, nr, (const double(*)[2])prof, ns, 1);
    free(prof);
}

/* A thin solid over a parameter grid: (s, t) in [0,1]² maps to (x, y) by
 * plane(), the mid-surface sits at z = mid(x, y) and the half thickness is
 * half(s, t). Front and back sheets joined by walls around the boundary. */
typedef struct sheet {
    void (*plane)(const struct sheet *, double s, double t, double xy[2]);
    double (*mid)(const struct sheet *, double x, double y);
    double (*half)(const struct sheet *, double s, double t);
    double p[8]; /* shape parameters */
} sheet;

static void sheet_solid(build *b, const sheet *sh, int nx, int ny) {
    uint32_t base = (uint32_t)b->nv;
    for (int side = 0; side < 2; side++)
        for (int i = 0; i <= nx; i++)
            for (int j = 0; j <= ny; j++) {
                double s = (double)i / nx, t = (double)j / ny, xy[2];
                sh->plane(sh, s, t, xy);
                double z = sh->mid(sh, xy[0], xy[1]) + (side ? -1 : 1) * sh->half(sh, s, t);
                vtx(b, xy[0], xy[1], z);
            }
#define F(i, j) (base + (uint32_t)((i) * (ny + 1) + (j)))
#define B(i, j) (base + (uint32_t)((nx + 1) * (ny + 1) + (i) * (ny + 1) + (j)))
    for (int i = 0; i < nx; i++)
        for (int j = 0; j < ny; j++) {
            quad(b, F(i, j), F(i + 1, j), F(i + 1, j + 1), F(i, j + 1));
            quad(b, B(i, j), B(i, j + 1), B(i + 1, j + 1), B(i + 1, j));
        }
    /* the boundary, counter-clockwise seen from +z; walls face outward (right of travel) */
    int n = 2 * (nx + ny), (*loop)[2] = malloc((size_t)n * sizeof *loop), k = 0;
    for (int i = 0; i < nx; i++) loop[k][0] = i, loop[k++][1] = 0;
    for (int j = 0; j < ny; j++) loop[k][0] = nx, loop[k++][1] = j;
    for (int i = nx; i > 0; i--) loop[k][0] = i, loop[k++][1] = ny;
    for (int j = ny; j > 0; j--) loop[k][0] = 0, loop[k++][1] = j;
    for (int e = 0; e < n; e++) {
        int *a = loop[e], *c = loop[(e + 1) % n];
        tri(b, F(a[0], a[1]), B(a[0], a[1]), B(c[0], c[1]));
        tri(b, F(a[0], a[1]), B(c[0], c[1]), F(c[0], c[1]));
    }
    free(loop);
#undef F
#undef B
}

static double smoothstep(double e0, double e1, double x) {
    double t = (x - e0) / (e1 - e0);
    t = t < 0 ? 0 : t > 1 ? 1 : t;
    return t * t * (3 - 2 * t);
}

static double flat_mid(const sheet *sh, double x, double y) { return 0; }

/* plate: p[0] x size, p[1] y size, p[2] thickness; centred */
static void plate_plane(const sheet *sh, double s, double t, double xy[2]) {
    xy[0] = (s - 0.5) * sh->p[0], xy[1] = (t - 0.5) * sh->p[1];
}
static double plate_half(const sheet *sh, double s, double t) { return 0.5 * sh->p[2]; }

/* wavy (crinkle-cut) knife: blade along x from 0 to L = p[0], cutting edge at
 * y = 0 rising to a blunt tip over the last quarter, spine at y = H = p[1];
 * the blade is corrugated across its length, z = A sin(2π x / λ) (A = p[2],
 * λ = p[3]); thickness tapers from p[5] at the spine to p[4] at the edge */
static void knife_plane(const sheet *sh, double s, double t, double xy[2]) {
    double L = sh->p[0], H = sh->p[1], x = s * L, tip = 0.1 * H;
    double rise = smoothstep(0.7 * L, L, x), edge = (H - tip) * rise * rise;
    xy[0] = x, xy[1] = edge + t * (H - edge);
}
static double knife_mid(const sheet *sh, double x, double y) { return sh->p[2] * sin(2 * PI * x / sh->p[3]); }
static double knife_half(const sheet *sh, double s, double t) { return 0.5 * (sh->p[4] + (sh->p[5] - sh->p[4]) * t); }

/* paddle: along x from 0 to L = p[0]; a handle of half width p[1] widening
 * over [0.55 L, 0.65 L] into a blade of half width p[2] with rounded corners;
 * thickness p[3] */
static void paddle_plane(const sheet *sh, double s, double t, double xy[2]) {
    double L = sh->p[0], x = s * L;
    double w = sh->p[1] + (sh->p[2] - sh->p[1]) * smoothstep(0.55 * L, 0.65 * L, x);
    double end = 0.92 * L;
    if (x > end) w *= sqrt(1 - 0.85 * ((x - end) / (L - end)) * ((x - end) / (L - end)));
    xy[0] = x, xy[1] = (2 * t - 1) * w;
}
static double paddle_half(const sheet *sh, double s, double t) { return 0.5 * sh->p[3]; }

/* wheel: axis z, outer radius R with nteeth tread blocks of depth d, an axle
 * hole of radius ri, width W (centred on z = 0) */
static void wheel(build *b, double R, double d, int nteeth, double ri, double W, int per_tooth) {
    int ns = nteeth * per_tooth;
    uint32_t base = (uint32_t)b->nv;
    for (int s = 0; s < ns; s++) {
        double a = 2 * PI * s / ns;
        int phase = s % per_tooth;
        double ro = phase < per_tooth / 2 ? R : R - d; /* square tread */
        for (int side = 0; side < 2; side++) {
            double z = side ? -0.5 * W : 0.5 * W;
            vtx(b, ro * cos(a), ro * sin(a), z); /* outer */
            vtx(b, ri * cos(a), ri * sin(a), z); /* inner */
        }
    }
    /* vertex k: 4 per angle: outer front, inner front, outer back, inner back */
#define OF(s) (base + 4u * (uint32_t)((s) % ns))
#define IF(s) (OF(s) + 1)
#define OB(s) (OF(s) + 2)
#define IB(s) (OF(s) + 3)
    for (int s = 0; s < ns; s++) {
        quad(b, IF(s), OF(s), OF(s + 1), IF(s + 1)); /* front, +z */
        quad(b, IB(s), IB(s + 1), OB(s + 1), OB(s)); /* back, -z */
        quad(b, OF(s), OB(s), OB(s + 1), OF(s + 1)); /* tread, outward */
        quad(b, IF(s), IF(s + 1), IB(s + 1), IB(s)); /* axle hole, inward */
    }
#undef OF
#undef IF
#undef OB
#undef IB
}

/* bowl: a hemispherical shell of outer radius R and thickness t, open at
 * the top (a flat rim at y = 0), standing on a foot ring: a solid cylinder of
 * the radius where the outer sphere is foot_deg from the pole, from the
 * sphere down to a flat base at y = -R, a full wall below the inner bottom
 * (y = -(R - t)). A foot cut flat across the sphere instead (at -R cos(foot),
 * as this bowl once had) lies above the inner bottom when the wall is thinner
 * than R (1 - cos(foot)): the inside poked out through the foot, the mesh
 * intersected itself and sand leaked through its bottom. The profile runs
 * counter-clockwise in (r, y): base centre, foot edge, up the foot's side,
 * the outer arc to the rim, the inner arc down to the inner bottom. */
static void bowl(build *b, double R, double t, double foot_deg, int ns, int narc) {
    int m = 0;
    double(*prof)[2] = malloc((size_t)(2 * narc + 8) * sizeof *prof);
    double f = foot_deg * PI / 180, rf = R * sin(f);
    prof[m][0] = 0, prof[m++][1] = -R;  /* centre of the base (pole) */
    prof[m][0] = rf, prof[m++][1] = -R; /* the base's edge */
    for (int i = 0; i <= narc; i++) {   /* outer arc, from the top of the foot's side to the rim */
        double phi = f + (PI / 2 - f) * i / narc;
        prof[m][0] = R * sin(phi), prof[m++][1] = i == narc ? 0 : -R * cos(phi);
    }
    double Ri = R - t;
    for (int i = narc; i >= 0; i--) { /* inner arc, rim to bottom */
        double phi = PI / 2 * i / narc;
        prof[m][0] = i == 0 ? 0 : Ri * sin(phi), prof[m++][1] = i == narc ? 0 : -Ri * cos(phi);
    }
    revolve(b, m, (const double(*)[2])prof, ns, 0);
    free(prof);
}

/* C-shaped leg (a RHex-style whegs leg): half a ring of radius p[0] (to the
 * middle of its band) from the hip at the origin round the +x side to the
 * tip at (0, -2 p[0]); the band is p[1] thick radially and 2 half() wide in z */
static void cleg_plane(const sheet *sh, double s, double t, double xy[2]) {
    double a = PI / 2 - PI * s, r = sh->p[0] + (t - 0.5) * sh->p[1];
    xy[0] = r * cos(a), xy[1] = -sh->p[0] + r * sin(a);
}
static double cleg_half(const sheet *sh, double s, double t) { return 0.5 * sh->p[2]; }

/* A rod of radius r along z from z0 to z1 (z1 > z0) through (x, y): a
 * revolved rectangle, turned from the y axis onto z (a rotation, so it stays
 * outward). */
static void rod_z(build *b, double x, double y, double z0, double z1, double r, int ns) {
    const double prof[4][2] = {{0, z0}, {r, z0}, {r, z1}, {0, z1}};
    size_t first = b->nv;
    revolve(b, 4, prof, ns, 0);
    for (size_t i = first; i < b->nv; i++) { /* (u, w, v) about y -> (u, -v, w) about z */
        double *p = b->v + 3 * i, u = p[0], w = p[1], v = p[2];
        p[0] = (float)(x + u) + 0.0f, p[1] = (float)(y - v) + 0.0f, p[2] = (float)w + 0.0f;
    }
}

/* The hexapod's body: a box (p[0..2] full sizes, centred on the origin) and
 * its six hip axles, rods of radius p[3] at height p[4], at x = 0 and ±p[5];
 * from a tenth of a millimetre off the box's sides (separate closed shells
 * that never touch) out to z = ±p[6] (front and rear pair) and ±p[7] (the
 * middle pair, further out). */
static void robot_body(build *b, const double *p) {
    const double lo[3] = {-p[0] / 2, -p[1] / 2, -p[2] / 2}, hi[3] = {p[0] / 2, p[1] / 2, p[2] / 2};
    box(b, lo, hi);
    const double side = p[2] / 2 + 1e-4;
    for (int k = -1; k <= 1; k++) {
        const double x = k * p[5], out = k ? p[6] : p[7];
        rod_z(b, x, p[4], side, out, p[3], 12);
        rod_z(b, x, p[4], -out, -side, p[3], 12);
    }
}

/* ---- the banana ----------------------------------------------------------------- */

/* Its centre line: an arc of radius BANANA_BEND in the x-z plane, bowed
 * towards -z, u in [0, 1] from the stem (-x) to the tip (+x), BANANA_LEN long;
 * its cross-section is a rounded pentagon (the ridges of a banana), radius
 * banana_r(u). */
#define BANANA_LEN 0.5
#define BANANA_BEND 0.55
#define BANANA_R 0.042
#define BANANA_STEM 0.011
#define BANANA_PEEL 0.012

static double banana_body(double v, double r0) { return v <= 0 || v >= 1 ? 0 : r0 * pow(sin(PI * v), 0.45); }

/* the outer surface: a stalk of radius BANANA_STEM over the first 12 %
 * (rounded at its cut end), then the body; the flesh runs inside it over
 * [0.14, 0.97], BANANA_PEEL thinner */
static double banana_r(double u, int flesh) {
    if (flesh) return banana_body((u - 0.14) / 0.83, BANANA_R - BANANA_PEEL);
    double body = banana_body((u - 0.06) / 0.94, BANANA_R);
    double cap = u < 0.015 ? sqrt(1 - (1 - u / 0.015) * (1 - u / 0.015)) : 1;
    double stalk = u < 0.2 ? BANANA_STEM * cap : 0;
    return body > stalk ? body : stalk;
}

/* one closed tube along the centre line over [u0, u1] (poles at the ends),
 * facing outward */
static void banana_tube(build *b, int flesh, double u0, double u1, int nu, int nth) {
    uint32_t pole0 = 0, pole1 = 0, base = 0;
    for (int i = 0; i <= nu; i++) {
        double u = u0 + (u1 - u0) * i / nu, phi = (u - 0.5) * BANANA_LEN / BANANA_BEND;
        double c[3] = {BANANA_BEND * sin(phi), 0,
                       BANANA_BEND * (1 - cos(phi)) - 0.5 * BANANA_BEND * (1 - cos(0.5 * BANANA_LEN / BANANA_BEND))};
        double n2[3] = {sin(phi), 0, cos(phi)}; /* across the arc, in x-z; the other normal is y */
        if (i == 0 || i == nu) {
            uint32_t id = vtx(b, c[0], c[1], c[2]);
            if (i == 0) pole0 = id;
            else pole1 = id;
            continue;
        }
        double r = banana_r(u, flesh);
        for (int k = 0; k < nth; k++) {
            double th = 2 * PI * k / nth, rr = r * (1 + 0.05 * cos(5 * th));
            uint32_t id = vtx(b, c[0] + rr * sin(th) * n2[0], c[1] + rr * cos(th), c[2] + rr * sin(th) * n2[2]);
            if (i == 1 && k == 0) base = id;
        }
    }
#define RING(i, k) (base + (uint32_t)(((i)-1) * nth + ((k) % nth)))
    for (int k = 0; k < nth; k++) {
        uint32_t a0 = RING(1, k), a1 = RING(1, k + 1), z0 = RING(nu - 1, k), z1 = RING(nu - 1, k + 1);
        tri(b, pole0, a1, a0), tri(b, pole1, z0, z1);
        for (int i = 1; i < nu - 1; i++) quad(b, RING(i, k), RING(i, k + 1), RING(i + 1, k + 1), RING(i + 1, k));
    }
#undef RING
}

/* ---- thin sheets (open surfaces for CPIC rigid bodies) ------------------------ */

/* One open sheet through the points f(p, s, t) for s, t in [0, 1], nx x ny
 * quads. Sheets that cross share the vertices they have in common once the
 * mesh is welded: intersecting thin boundaries, as in the paper's Fig. 12. */
typedef void (*sheet_fn)(const double *p, double s, double t, double x[3]);

static void open_sheet(build *b, sheet_fn f, const double *p, int nx, int ny) {
    uint32_t base = (uint32_t)b->nv;
    for (int i = 0; i <= nx; i++)
        for (int j = 0; j <= ny; j++) {
            double x[3];
            f(p, (double)i / nx, (double)j / ny, x);
            vtx(b, x[0], x[1], x[2]);
        }
    for (int i = 0; i < nx; i++)
        for (int j = 0; j < ny; j++) {
            uint32_t a = base + (uint32_t)(i * (ny + 1) + j);
            quad(b, a, a + (uint32_t)(ny + 1), a + (uint32_t)(ny + 2), a + 1);
        }
}

/* a flat rectangle through the origin at angle p[2] about y from the x axis:
 * p[0] wide (horizontal), p[1] high (y) */
static void upright_plate(const double *p, double s, double t, double x[3]) {
    double u = (s - 0.5) * p[0];
    x[0] = u * cos(p[2]), x[1] = (t - 0.5) * p[1], x[2] = -u * sin(p[2]);
}

/* a plate through the z axis at angle p[2] in the x-y plane: a diameter of
 * length 2 p[0], p[1] wide along z (one pair of a paddle wheel's blades) */
static void axle_plate(const double *p, double s, double t, double x[3]) {
    double r = (2 * s - 1) * p[0];
    x[0] = r * cos(p[2]), x[1] = r * sin(p[2]), x[2] = (t - 0.5) * p[1];
}

/* a curved blade: a cylinder of radius p[0] about z, spanning the angles
 * [-p[1], p[1]] on the -x side (concave towards +x), p[2] wide along z */
static void scoop(const double *p, double s, double t, double x[3]) {
    double a = (2 * s - 1) * p[1];
    x[0] = -p[0] * cos(a), x[1] = p[0] * sin(a), x[2] = (t - 0.5) * p[2];
}

/* a stirring blade at angle p[3] about y: half width p[0] along its plane, top at
 * y = p[1], bottom edge following a sphere of radius p[2] (a bowl's inside) */
static void stir_blade(const double *p, double s, double t, double x[3]) {
    double u = (2 * s - 1) * p[0], bottom = -sqrt(p[2] * p[2] - u * u);
    x[0] = u * cos(p[3]), x[1] = bottom + t * (p[1] - bottom), x[2] = -u * sin(p[3]);
}

/* the paddle's outline (paddle_plane) as one sheet with no thickness */
static void paddle_outline(const double *p, double s, double t, double x[3]) {
    sheet sh = {paddle_plane, flat_mid, paddle_half, {p[0], p[1], p[2], 0}};
    double xy[2];
    paddle_plane(&sh, s, t, xy);
    x[0] = xy[0], x[1] = xy[1], x[2] = 0;
}

/* ---- writers ------------------------------------------------------------------ */

static FILE *open_out(const char *dir, const char *name, const char *mode, char *path, size_t n) {
    snprintf(path, n, "%s/%s", dir, name);
    FILE *f = fopen(path, mode);
    if (!f) {
        perror(path);
        exit(2);
    }
    return f;
}

static void write_obj(const char *dir, const char *name, const kf_mesh *m, const char *what) {
    char path[1024];
    FILE *f = open_out(dir, name, "w", path, sizeof path);
    fprintf(f, "# %s\n# generated by tools/make_meshes.c; %zu vertices, %zu triangles, %s\n", what, m->nvert, m->ntri,
            m->closed ? "closed, outward" : "open (thin sheets for rigid bodies)");
    for (size_t i = 0; i < m->nvert; i++)
        fprintf(f, "v %.9g %.9g %.9g\n", m->vert[3 * i], m->vert[3 * i + 1], m->vert[3 * i + 2]);
    for (size_t t = 0; t < m->ntri; t++)
        fprintf(f, "f %u %u %u\n", m->tri[3 * t] + 1, m->tri[3 * t + 1] + 1, m->tri[3 * t + 2] + 1);
    fclose(f);
}

static void write_off(const char *dir, const char *name, const kf_mesh *m) {
    char path[1024];
    FILE *f = open_out(dir, name, "w", path, sizeof path);
    fprintf(f, "OFF\n%zu %zu 0\n", m->nvert, m->ntri);
    for (size_t i = 0; i < m->nvert; i++)
        fprintf(f, "%.9g %.9g %.9g\n", m->vert[3 * i], m->vert[3 * i + 1], m->vert[3 * i + 2]);
    for (size_t t = 0; t < m->ntri; t++)
        fprintf(f, "3 %u %u %u\n", m->tri[3 * t], m->tri[3 * t + 1], m->tri[3 * t + 2]);
    fclose(f);
}

static void write_ply(const char *dir, const char *name, const kf_mesh *m, int binary) {
    char path[1024];
    FILE *f = open_out(dir, name, binary ? "wb" : "w", path, sizeof path);
    fprintf(
        f,
        "ply\nformat %s 1.0\ncomment generated by tools/make_meshes.c\nelement vertex %zu\nproperty float x\n"
        "property float y\nproperty float z\nelement face %zu\nproperty list uchar int vertex_indices\nend_header\n",
        binary ? "binary_little_endian" : "ascii", m->nvert, m->ntri);
    for (size_t i = 0; i < m->nvert; i++) {
        float p[3] = {(float)m->vert[3 * i], (float)m->vert[3 * i + 1], (float)m->vert[3 * i + 2]};
        if (binary) fwrite(p, sizeof p, 1, f); /* x86: little endian */
        else fprintf(f, "%.9g %.9g %.9g\n", p[0], p[1], p[2]);
    }
    for (size_t t = 0; t < m->ntri; t++) {
        int32_t q[3] = {(int32_t)m->tri[3 * t], (int32_t)m->tri[3 * t + 1], (int32_t)m->tri[3 * t + 2]};
        if (binary) {
            uint8_t three = 3;
            fwrite(&three, 1, 1, f);
            fwrite(q, sizeof q, 1, f);
        } else {
            fprintf(f, "3 %d %d %d\n", q[0], q[1], q[2]);
        }
    }
    fclose(f);
}

/* binary STL: every triangle carries its own three vertices (unwelded) */
static void write_stl(const char *dir, const char *name, const kf_mesh *m) {
    char path[1024], header[80];
    FILE *f = open_out(dir, name, "wb", path, sizeof path);
    memset(header, 0, sizeof header);
    snprintf(header, sizeof header, "kerf tools/make_meshes.c");
    fwrite(header, 1, 80, f);
    uint32_t n = (uint32_t)m->ntri;
    fwrite(&n, 4, 1, f);
    for (size_t t = 0; t < m->ntri; t++) {
        const double *a = &m->vert[3 * m->tri[3 * t]], *b = &m->vert[3 * m->tri[3 * t + 1]],
                     *c = &m->vert[3 * m->tri[3 * t + 2]];
        double e[3], g[3];
        for (int k = 0; k < 3; k++) e[k] = b[k] - a[k], g[k] = c[k] - a[k];
        double nn[3] = {e[1] * g[2] - e[2] * g[1], e[2] * g[0] - e[0] * g[2], e[0] * g[1] - e[1] * g[0]};
        double L = sqrt(nn[0] * nn[0] + nn[1] * nn[1] + nn[2] * nn[2]);
        float rec[12];
        for (int k = 0; k < 3; k++) {
            rec[k] = (float)(L > 0 ? nn[k] / L : 0);
            rec[3 + k] = (float)a[k], rec[6 + k] = (float)b[k], rec[9 + k] = (float)c[k];
        }
        uint16_t attr = 0;
        fwrite(rec, sizeof rec, 1, f);
        fwrite(&attr, 2, 1, f);
    }
    fclose(f);
}

static void write_text(const char *dir, const char *name, const char *text) {
    char path[1024];
    FILE *f = open_out(dir, name, "w", path, sizeof path);
    fputs(text, f);
    fclose(f);
}

/* ---- checking ----------------------------------------------------------------- */

/* welded, closed, outward and not passing through itself: or the tool stops */
static void finish(build *b, const char *name, kf_mesh *m, int must_close) {
    char err[512];
    if (kf_mesh_from_arrays(name, b->nv, b->v, b->nt, b->t, m, err, sizeof err)) {
        fprintf(stderr, "make_meshes: %s\n", err);
        exit(1);
    }
    if (must_close && (kf_mesh_check_closed(m, err, sizeof err) || !m->oriented || !(m->volume > 0))) {
        fprintf(stderr, "make_meshes: %s: closed %d oriented %d volume %g %s\n", name, m->closed, m->oriented,
                m->volume, err);
        exit(1);
    }
    if (must_close && kf_mesh_check_self_intersection(m, 0, err, sizeof err)) {
        fprintf(stderr, "make_meshes: %s\n", err);
        exit(1);
    }
    printf("%-18s %7zu vertices %7zu triangles  volume %.6g m^3  bounds [%.4g %.4g %.4g]..[%.4g %.4g %.4g]%s\n", name,
           m->nvert, m->ntri, m->volume, m->lo[0], m->lo[1], m->lo[2], m->hi[0], m->hi[1], m->hi[2],
           m->flipped_tris ? "  (some triangles reoriented)" : "");
    build_free(b);
}

static void make_assets(const char *dir) {
    build b = {0};
    kf_mesh m;
    sheet sh;

    double lo[3] = {-0.5, -0.5, -0.5}, hi[3] = {0.5, 0.5, 0.5};
    box(&b, lo, hi);
    finish(&b, "cube.obj", &m, 1);
    write_obj(dir, "cube.obj", &m, "unit cube centred on the origin");
    kf_mesh_free(&m);

    uv_sphere(&b, 0.5, 64, 32);
    finish(&b, "sphere.obj", &m, 1);
    write_obj(dir, "sphere.obj", &m, "UV sphere, radius 0.5, 64 x 32 segments");
    kf_mesh_free(&m);

    torus(&b, 0.35, 0.15, 64, 32);
    finish(&b, "torus.obj", &m, 1);
    write_obj(dir, "torus.obj", &m, "torus about y, R = 0.35, r = 0.15, 64 x 32 segments");
    kf_mesh_free(&m);

    sh = (sheet){plate_plane, flat_mid, plate_half, {1.0, 1.0, 0.02}};
    sheet_solid(&b, &sh, 10, 10);
    finish(&b, "plate.obj", &m, 1);
    write_obj(dir, "plate.obj", &m, "plate 1 x 1 m, 20 mm thick (z), centred");
    kf_mesh_free(&m);

    sh = (sheet){plate_plane, flat_mid, plate_half, {1.0, 1.0, 0.002}};
    sheet_solid(&b, &sh, 10, 10);
    finish(&b, "plate_thin.obj", &m, 1);
    write_obj(dir, "plate_thin.obj", &m, "thin plate 1 x 1 m, 2 mm thick (z), centred: thinner than a grid cell");
    kf_mesh_free(&m);

    sh = (sheet){knife_plane, knife_mid, knife_half, {0.8, 0.12, 0.008, 0.05, 0.001, 0.004}};
    sheet_solid(&b, &sh, 320, 8);
    finish(&b, "knife_wavy.obj", &m, 1);
    write_obj(dir, "knife_wavy.obj", &m,
              "wavy (crinkle-cut) knife blade: 0.8 m along x, edge at y = 0, spine at y = 0.12, "
              "corrugated z = 8 mm sin(2 pi x / 50 mm), 1 mm thick at the edge to 4 mm at the spine");
    kf_mesh_free(&m);

    sh = (sheet){paddle_plane, flat_mid, paddle_half, {1.0, 0.02, 0.12, 0.02}};
    sheet_solid(&b, &sh, 100, 6);
    finish(&b, "paddle.obj", &m, 1);
    write_obj(dir, "paddle.obj", &m,
              "paddle along x: 1 m long, handle 40 mm wide widening to a 240 mm blade, 20 mm thick (z)");
    kf_mesh_free(&m);

    wheel(&b, 0.5, 0.03, 24, 0.08, 0.25, 8);
    finish(&b, "wheel.obj", &m, 1);
    write_obj(dir, "wheel.obj", &m,
              "wheel about z: radius 0.5 m with 24 tread blocks 30 mm deep, 0.25 m wide, 80 mm axle hole");
    kf_mesh_free(&m);

    bowl(&b, 0.5, 0.03, 25, 96, 32);
    finish(&b, "bowl.obj", &m, 1);
    write_obj(dir, "bowl.obj", &m,
              "bowl about y: outer radius 0.5 m, 30 mm wall, open at y = 0 (the rim), inner bottom at y = -0.47, "
              "standing on a foot ring of radius 0.211 m with its flat base at y = -0.5");
    kf_mesh_free(&m);

    sh = (sheet){knife_plane, flat_mid, knife_half, {1.0, 0.15, 0, 1, 0.001, 0.003}};
    sheet_solid(&b, &sh, 200, 8);
    finish(&b, "blade.obj", &m, 1);
    write_obj(dir, "blade.obj", &m,
              "straight knife blade: 1 m along x, edge at y = 0 rising to a blunt tip over the last 30 %, spine at "
              "y = 0.15, 1 mm thick at the edge to 3 mm at the spine");
    kf_mesh_free(&m);

    sh = (sheet){cleg_plane, flat_mid, cleg_half, {0.035, 0.012, 0.014}};
    sheet_solid(&b, &sh, 16, 1); /* few triangles: MuJoCo collides each one as a piece */
    finish(&b, "c_leg.obj", &m, 1);
    write_obj(dir, "c_leg.obj", &m,
              "C-shaped robot leg: half a ring of radius 35 mm from the hip at the origin round the +x side to the "
              "tip at y = -70 mm, a band 12 mm thick and 14 mm wide (z)");
    kf_mesh_free(&m);

    /* its hips 5 mm below the box's centre, the legs 14 mm wide centred 55 mm
     * (75 mm in the middle) from the body's centre line: each axle runs
     * through its leg's hip and 3 mm past it */
    robot_body(&b, (const double[]){0.18, 0.03, 0.09, 0.004, -0.005, 0.07, 0.065, 0.085});
    finish(&b, "robot_body.obj", &m, 1);
    write_obj(dir, "robot_body.obj", &m,
              "hexapod body: a box 180 x 30 x 90 mm centred on the origin and six hip axles 8 mm across, 5 mm below "
              "its centre at x = 0 and +-70 mm, out to z = +-65 mm (+-85 mm in the middle)");
    kf_mesh_free(&m);

    banana_tube(&b, 1, 0.14, 0.97, 120, 40);
    finish(&b, "banana_flesh.obj", &m, 1);
    write_obj(dir, "banana_flesh.obj", &m,
              "banana flesh: 0.42 m along an arc of radius 0.55 m in the x-z plane (bowed towards -z), up to 60 mm "
              "across, a rounded pentagon in section; inside banana_peel.obj, which it fills");
    kf_mesh_free(&m);

    /* the peel: the banana's surface and, nested in it, the flesh's; what
     * lies between them (an odd number of crossings) is the skin */
    banana_tube(&b, 0, 0, 1, 160, 40);
    banana_tube(&b, 1, 0.14, 0.97, 120, 40);
    finish(&b, "banana_peel.obj", &m, 1);
    write_obj(dir, "banana_peel.obj", &m,
              "banana peel: the skin of a banana 0.5 m long with its stalk (-x end), up to 84 mm across, 12 mm thick; "
              "two nested closed surfaces, the outer skin and banana_flesh.obj's surface: the solid between them");
    kf_mesh_free(&m);

    /* thin sheets for CPIC rigid bodies: open surfaces, no thickness */
    double cross[2][3] = {{1.0, 1.0, 0}, {1.0, 1.0, PI / 2}};
    for (int k = 0; k < 2; k++) open_sheet(&b, upright_plate, cross[k], 20, 20);
    finish(&b, "cross_plates.obj", &m, 0);
    write_obj(dir, "cross_plates.obj", &m,
              "two thin upright plates 1 x 1 m crossing at right angles on the y axis (a cutter that splits in four)");
    kf_mesh_free(&m);

    double blade[3] = {0.3, 60 * PI / 180, 1.0};
    open_sheet(&b, scoop, blade, 24, 20);
    finish(&b, "scoop.obj", &m, 0);
    write_obj(
        dir, "scoop.obj", &m,
        "thin curved blade: radius 0.3 m about z, 120 degrees of arc concave towards +x, 1 m wide (a sweeping shell)");
    kf_mesh_free(&m);

    for (int k = 0; k < 4; k++) {
        double wheel_plate[3] = {0.5, 0.4, k * PI / 4};
        open_sheet(&b, axle_plate, wheel_plate, 20, 8);
    }
    finish(&b, "paddle_wheel.obj", &m, 0);
    write_obj(dir, "paddle_wheel.obj", &m,
              "paddle wheel about z: 8 thin blades of radius 0.5 m, 0.4 m wide, made of 4 plates crossing on the axle");
    kf_mesh_free(&m);

    double outline[3] = {1.0, 0.02, 0.12};
    open_sheet(&b, paddle_outline, outline, 50, 6);
    finish(&b, "paddle_sheet.obj", &m, 0);
    write_obj(dir, "paddle_sheet.obj", &m,
              "paddle.obj's outline as one thin sheet in z = 0: 1 m along x, handle 40 mm wide, blade 240 mm");
    kf_mesh_free(&m);

    for (int k = 0; k < 2; k++) {
        double stir[4] = {0.4, 0.2, 0.45, k * PI / 2};
        open_sheet(&b, stir_blade, stir, 24, 12);
    }
    finish(&b, "stirrer.obj", &m, 0);
    write_obj(dir, "stirrer.obj", &m,
              "two thin stirring blades crossing on the y axis, 0.8 m across, top at y = 0.2, bottom edge on a sphere "
              "of radius 0.45 m about the origin (inside bowl.obj, 20 mm clear)");
    kf_mesh_free(&m);
}

static void make_fixtures(const char *dir) {
    build b = {0};
    kf_mesh m;

    /* the same torus in four formats */
    torus(&b, 0.3, 0.12, 24, 12);
    finish(&b, "torus (fixture)", &m, 1);
    write_obj(dir, "torus.obj", &m, "torus R = 0.3, r = 0.12, 24 x 12");
    write_ply(dir, "torus.ply", &m, 1);
    write_ply(dir, "torus_ascii.ply", &m, 0);
    write_stl(dir, "torus.stl", &m);
    write_off(dir, "torus.off", &m);
    kf_mesh_free(&m);

    double lo[3] = {0, 0, 0}, hi[3] = {1, 1, 1};
    box(&b, lo, hi);
    finish(&b, "cube.obj", &m, 1);
    write_obj(dir, "cube.obj", &m, "unit cube [0, 1]^3");
    kf_mesh_free(&m);

    /* open: the cube without its top (two triangles), four boundary edges */
    write_text(dir, "cube_open.obj",
               "# unit cube without its top face: 4 boundary edges\n"
               "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n"
               "f 1 3 4 2\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n");
    /* two tetrahedra sharing an edge: that edge is used by four triangles */
    write_text(dir, "bowtie.obj",
               "# two tetrahedra sharing the edge 1-2: non-manifold\n"
               "v 0 0 0\nv 0 0 1\nv 1 0 0.5\nv 0 1 0.5\nv -1 0 0.5\nv 0 -1 0.5\n"
               "f 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\nf 1 2 5\nf 1 6 2\nf 1 5 6\nf 2 6 5\n");
    /* vertices on the axes: axis-aligned rays through lattice points hit its edges and vertices */
    write_text(dir, "octahedron.obj",
               "# |x| + |y| + |z| <= 1\n"
               "v 1 0 0\nv -1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nv 0 0 -1\n"
               "f 1 3 5\nf 3 2 5\nf 2 4 5\nf 4 1 5\nf 3 1 6\nf 2 3 6\nf 4 2 6\nf 1 4 6\n");
    /* a square prism turned 45 degrees about z: |x| + |y| <= 1, |z| <= 0.75 */
    write_text(dir, "diamond.obj",
               "# square prism turned 45 degrees about z: |x| + |y| <= 1, |z| <= 0.75\n"
               "v 1 0 -0.75\nv 0 1 -0.75\nv -1 0 -0.75\nv 0 -1 -0.75\n"
               "v 1 0 0.75\nv 0 1 0.75\nv -1 0 0.75\nv 0 -1 0.75\n"
               "f 1 4 3 2\nf 5 6 7 8\nf 1 2 6 5\nf 2 3 7 6\nf 3 4 8 7\nf 4 1 5 8\n");
    /* closed and outward, but two cubes passing through each other: a solid
     * that intersects itself ([0, 1]^3 and [0.5, 1.5] x [0.25, 1.25]^2) */
    write_text(dir, "cubes_crossed.obj",
               "# two cubes passing through each other: closed and outward, but intersecting itself\n"
               "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nv 0 0 1\nv 1 0 1\nv 0 1 1\nv 1 1 1\n"
               "v 0.5 0.25 0.25\nv 1.5 0.25 0.25\nv 0.5 1.25 0.25\nv 1.5 1.25 0.25\n"
               "v 0.5 0.25 1.25\nv 1.5 0.25 1.25\nv 0.5 1.25 1.25\nv 1.5 1.25 1.25\n"
               "f 1 3 4 2\nf 5 6 8 7\nf 1 2 6 5\nf 3 7 8 4\nf 1 5 7 3\nf 2 4 8 6\n"
               "f 9 11 12 10\nf 13 14 16 15\nf 9 10 14 13\nf 11 15 16 12\nf 9 13 15 11\nf 10 12 16 14\n");
    write_text(dir, "empty.obj", "");
    write_text(dir, "garbage.obj", "this is not a mesh\nneither is this 1 2 3\n");
}

int main(int argc, char **argv) {
    const char *dir = NULL;
    int fixtures = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--fixtures")) fixtures = 1;
        else if (argv[i][0] == '-') dir = NULL, i = argc;
        else dir = argv[i];
    }
    if (!dir) {
        fprintf(stderr, "usage: make_meshes [--fixtures] <outdir>\n");
        return 2;
    }
    mkdir(dir, 0777);
    if (fixtures) make_fixtures(dir);
    else make_assets(dir);
    return 0;
}
