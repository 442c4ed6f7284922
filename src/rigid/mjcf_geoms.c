/* mjcf_geoms.c — the collision geometry of one rigid body in MuJoCo.
 *
 * MuJoCo collides convex geoms only. A convex mesh becomes one convex-hull
 * geom; any other (a bowl, a blade, a bunny) becomes thin pieces: each
 * triangle swept ± h along its normal (a prism), and for meshes of more than
 * KF_MJ_MAX_PIECES triangles the hull of the prisms of a compact set of
 * nearby triangles, so that a body can rest inside a concave container. A
 * piece fills the concavity of its own few triangles only (about size² ×
 * curvature / 8). MuJoCo 2.2 pays per geom every step (about 0.2 µs each)
 * and far more per extra body (it tests every geom pair of two nearby
 * bodies), so pieces are few and all of a rigid body's pieces stay in one
 * MuJoCo body. */
#include "mjcf_geoms.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "../core/mat3.h"

#define KF_MJ_MAX_PIECES 256

/* a body's extent: the diagonal of its vertices' box */
double kf_mj_extent(const kf_rigid_body *b) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < b->nvert; i++)
        for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], b->vert[3 * i + a]), hi[a] = fmax(hi[a], b->vert[3 * i + a]);
    double d[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    return sqrt(kf_v3d_dot(d, d));
}

static void tri_normal(const kf_rigid_body *b, int t, double n[3], double *area2) {
    const double *p0 = b->vert + 3 * b->tri[3 * t], *p1 = b->vert + 3 * b->tri[3 * t + 1],
                 *p2 = b->vert + 3 * b->tri[3 * t + 2];
    double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]}, e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
    kf_v3d_cross(n, e1, e2);
    *area2 = sqrt(kf_v3d_dot(n, n));
    if (*area2 > 0)
        for (int a = 0; a < 3; a++) n[a] /= *area2;
}

/* a closed solid whose every vertex lies behind every face plane */
static int convex(const kf_rigid_body *b, double tol) {
    if (b->def.thin || (double)b->ntri * b->nvert > 5e7) return 0;
    for (int t = 0; t < b->ntri; t++) {
        double n[3], a2;
        tri_normal(b, t, n, &a2);
        if (!(a2 > 0)) continue;
        const double *p0 = b->vert + 3 * b->tri[3 * t];
        for (int i = 0; i < b->nvert; i++) {
            const double *p = b->vert + 3 * i;
            double d[3] = {p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]};
            if (kf_v3d_dot(d, n) > tol) return 0;
        }
    }
    return 1;
}

static const char *groups_of(const kf_rigid_body *b) {
    return b->def.motion == KF_RIGID_DYNAMIC ? "contype=\"1\" conaffinity=\"1\"" : "contype=\"2\" conaffinity=\"1\"";
}
#define CONTACT "friction=\"0.5 0.005 0.0001\" solref=\"0.004 1\" condim=\"3\""

/* one geom: the convex hull of body r's vertices, shifted by -shift (the
 * MuJoCo body origin in the mesh frame) */
static void hull_geom(kf_mj_text *x, const kf_rigid_body *b, int r, const double shift[3]) {
    kf_sb_printf(&x->asset, "<mesh name=\"m%d\" vertex=\"", r);
    for (int i = 0; i < b->nvert; i++)
        for (int a = 0; a < 3; a++) kf_sb_printf(&x->asset, "%.17g ", b->vert[3 * i + a] - shift[a]);
    kf_sb_printf(&x->asset, "\"/>\n");
    kf_sb_printf(&x->body, "<geom type=\"mesh\" mesh=\"m%d\" %s " CONTACT "/>\n", r, groups_of(b));
}

/* a triangle's prism corners, or 0 for a degenerate triangle; *solid: the
 * prism is not a sliver (height above h/100), so its hull is not flat */
static int prism(const kf_rigid_body *b, int t, double h, double P[18], int *solid) {
    double n[3], a2, L = 0;
    tri_normal(b, t, n, &a2);
    for (int k = 0; k < 3; k++) {
        const double *p = b->vert + 3 * b->tri[3 * t + k], *q = b->vert + 3 * b->tri[3 * t + (k + 1) % 3];
        double d[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
        L = fmax(L, sqrt(kf_v3d_dot(d, d)));
    }
    *solid = a2 > 0 && a2 / L > 0.01 * h;
    if (!(a2 > 0)) return 0;
    for (int s = 0; s < 2; s++)
        for (int k = 0; k < 3; k++) {
            const double *p = b->vert + 3 * b->tri[3 * t + k];
            for (int a = 0; a < 3; a++) P[9 * s + 3 * k + a] = p[a] + (2 * s - 1) * h * n[a];
        }
    return 1;
}

/* one geom: the hull of the prisms of triangles order[q0..q1) (shifted by
 * -shift); none when all are slivers */
static void piece_geom(kf_mj_text *x, const kf_rigid_body *b, int r, const int *order, int q0, int q1, double h,
                       const double shift[3]) {
    int solid = 0, sl;
    double P[18];
    for (int q = q0; q < q1; q++)
        if (prism(b, order[q], h, P, &sl)) solid |= sl;
    if (!solid) return;
    const int id = x->npiece++;
    kf_sb_printf(&x->asset, "<mesh name=\"m%d_%d\" vertex=\"", r, id);
    for (int q = q0; q < q1; q++)
        if (prism(b, order[q], h, P, &sl))
            for (int i = 0; i < 18; i++) kf_sb_printf(&x->asset, "%.17g ", P[i] - shift[i % 3]);
    kf_sb_printf(&x->asset, "\"/>\n");
    kf_sb_printf(&x->body, "<geom type=\"mesh\" mesh=\"m%d_%d\" %s " CONTACT "/>\n", r, id, groups_of(b));
}

/* prisms are 2h thick, h a fraction of the body's size */
static double prism_half(const kf_rigid_body *b) { return fmax(2e-3 * kf_mj_extent(b), 1e-6); }

/* one hull, or pieces (see the top of the file) */
static int use_hull(const kf_rigid_body *b) { return convex(b, 1e-9 * kf_mj_extent(b)); }

/* the pieces of a non-convex body: the triangles split at the median
 * centroid along the longest side of their centroids' box until a set holds
 * at most ntri / KF_MJ_MAX_PIECES triangles (compact pieces: a hull never
 * bridges distant parts of the surface) */
typedef struct ckey {
    double c;
    int tri;
} ckey;

static int cmp_ckey(const void *x, const void *y) {
    const ckey *a = x, *b = y;
    if (a->c != b->c) return a->c < b->c ? -1 : 1;
    return (a->tri > b->tri) - (a->tri < b->tri);
}

static double centroid(const kf_rigid_body *b, int t, int a) {
    return (b->vert[3 * b->tri[3 * t] + a] + b->vert[3 * b->tri[3 * t + 1] + a] + b->vert[3 * b->tri[3 * t + 2] + a]) /
           3;
}

static void split(kf_mj_text *x, const kf_rigid_body *b, int r, int *set, ckey *tmp, int n, int run, double h,
                  const double shift[3]) {
    if (n <= run) {
        piece_geom(x, b, r, set, 0, n, h, shift);
        return;
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < n; i++)
        for (int a = 0; a < 3; a++) {
            double ci = centroid(b, set[i], a);
            lo[a] = fmin(lo[a], ci), hi[a] = fmax(hi[a], ci);
        }
    int ax = 0;
    for (int a = 1; a < 3; a++)
        if (hi[a] - lo[a] > hi[ax] - lo[ax]) ax = a;
    for (int i = 0; i < n; i++) tmp[i].c = centroid(b, set[i], ax), tmp[i].tri = set[i];
    qsort(tmp, (size_t)n, sizeof *tmp, cmp_ckey);
    for (int i = 0; i < n; i++) set[i] = tmp[i].tri;
    split(x, b, r, set, tmp, n / 2, run, h, shift);
    split(x, b, r, set + n / 2, tmp, n - n / 2, run, h, shift);
}

static void pieces(kf_mj_text *x, const kf_rigid_body *b, int r, const double shift[3]) {
    int *set = malloc(sizeof(int) * (size_t)b->ntri);
    ckey *tmp = malloc(sizeof(ckey) * (size_t)b->ntri);
    if (!set || !tmp) {
        free(set);
        free(tmp);
        x->body.oom = 1;
        return;
    }
    for (int t = 0; t < b->ntri; t++) set[t] = t;
    const int run = (b->ntri + KF_MJ_MAX_PIECES - 1) / KF_MJ_MAX_PIECES;
    split(x, b, r, set, tmp, b->ntri, run, prism_half(b), shift);
    free(set);
    free(tmp);
}

/* MuJoCo 2.2 finds one contact point per pair of convex meshes, so a box on
 * a box rocks on that one point forever. Small spheres tucked into up to
 * KF_MJ_CORNERS well-spread vertices of a convex solid (farthest-point
 * order, from the vertex farthest from the com) give a resting body several
 * points of support. Each sphere touches the face planes around its vertex
 * from inside: centre p - α n_v with α = radius / min_f (n_f · n_v). */
#define KF_MJ_CORNERS 48
static void corner_spheres(kf_mj_text *x, const kf_rigid_body *b, int r, const double shift[3]) {
    const int n = b->nvert;
    double *dist = malloc(sizeof(double) * (size_t)n), *nv = calloc(3 * (size_t)n, sizeof(double));
    double *mindot = malloc(sizeof(double) * (size_t)n);
    if (!dist || !nv || !mindot) goto done;
    /* area-weighted vertex normals, then the least aligned adjacent face */
    for (int t = 0; t < b->ntri; t++) {
        double fn[3], a2;
        tri_normal(b, t, fn, &a2);
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++) nv[3 * b->tri[3 * t + k] + a] += a2 * fn[a];
    }
    for (int i = 0; i < n; i++) {
        double l = sqrt(kf_v3d_dot(nv + 3 * i, nv + 3 * i));
        for (int a = 0; a < 3; a++) nv[3 * i + a] = l > 0 ? nv[3 * i + a] / l : 0;
        mindot[i] = 1;
    }
    for (int t = 0; t < b->ntri; t++) {
        double fn[3], a2;
        tri_normal(b, t, fn, &a2);
        if (!(a2 > 0)) continue;
        for (int k = 0; k < 3; k++) {
            int v = b->tri[3 * t + k];
            mindot[v] = fmin(mindot[v], kf_v3d_dot(fn, nv + 3 * v));
        }
    }
    const double rad = 0.01 * kf_mj_extent(b);
    int pick = 0;
    for (int i = 0; i < n; i++) {
        const double *p = b->vert + 3 * i;
        double d[3] = {p[0] - b->com[0], p[1] - b->com[1], p[2] - b->com[2]};
        dist[i] = kf_v3d_dot(d, d);
        if (dist[i] > dist[pick]) pick = i;
    }
    for (int i = 0; i < n; i++) dist[i] = INFINITY;
    for (int k = 0; k < KF_MJ_CORNERS && k < n; k++) {
        const double *p = b->vert + 3 * pick;
        if (mindot[pick] > 0.1) {
            double al = rad / mindot[pick], *q = nv + 3 * pick;
            kf_sb_printf(&x->body,
                         "<geom type=\"sphere\" size=\"%.17g\" pos=\"%.17g %.17g %.17g\" contype=\"1\" "
                         "conaffinity=\"1\" friction=\"0.5 0.005 0.0001\" solref=\"0.004 1\" condim=\"3\"/>\n",
                         rad, p[0] - al * q[0] - shift[0], p[1] - al * q[1] - shift[1], p[2] - al * q[2] - shift[2]);
        }
        /* next: the vertex farthest from all picked */
        int next = pick;
        double best = -1;
        for (int i = 0; i < n; i++) {
            const double *q = b->vert + 3 * i;
            double e[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
            dist[i] = fmin(dist[i], kf_v3d_dot(e, e));
            if (dist[i] > best) best = dist[i], next = i;
        }
        if (!(best > 0)) break;
        pick = next;
    }
done:
    free(dist);
    free(nv);
    free(mindot);
}

void kf_mj_geoms(kf_mj_text *x, const kf_rigid_body *b, int r, const double shift[3]) {
    if (!use_hull(b)) {
        pieces(x, b, r, shift);
        return;
    }
    hull_geom(x, b, r, shift);
    if (b->def.motion == KF_RIGID_DYNAMIC && !b->def.thin) corner_spheres(x, b, r, shift);
}
