/* bvh.c — a rigid body's triangles in an Embree scene, in its own (mesh)
 * frame, for the crossing guard of CPIC (src/cpic/guard.c): "does the path
 * of this particle relative to the body, a segment in the mesh frame, pass
 * through the surface, and through which triangle first?"
 *
 * The body is rigid, so the scene is built once, when the model is made, and
 * read by every thread during stepping (Embree's queries on a committed scene
 * are thread-safe). The scene is robust (watertight): a segment through a
 * shared edge or vertex hits one of the triangles there, never slips between
 * them. Vertices are stored relative to the mesh's bounding-box centre, so
 * float keeps its precision for a mesh far from its origin. */
#include "bvh.h"

#include "../core/mat3.h"

#include <embree3/rtcore.h>
#include <math.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct kf_rigid_bvh {
    RTCDevice dev;
    RTCScene scn;
    double c[3]; /* the vertices were shifted by -c before going to float */
    /* the mesh in double (shifted), for exact closest points */
    double *vert;
    int *tri;
    /* per triangle its plane (unit normal, offset; zero for a sliver), and
     * a distance far above the rounding of the distances closest_cb compares */
    double *plane, tol;
};

void kf_rigid_bvh_free(kf_rigid_bvh *b) {
    if (!b) return;
    if (b->scn) rtcReleaseScene(b->scn);
    if (b->dev) rtcReleaseDevice(b->dev);
    free(b->vert);
    free(b->tri);
    free(b->plane);
    free(b);
}

kf_rigid_bvh *kf_rigid_bvh_build(const double *vert, int nvert, const int *tri, int ntri, char *err, size_t errlen) {
    kf_rigid_bvh *b = calloc(1, sizeof *b);
    if (!b) return snprintf(err, errlen, "out of memory"), NULL;
    double lo[3] = {1e300, 1e300, 1e300}, hi[3] = {-1e300, -1e300, -1e300};
    for (int i = 0; i < nvert; i++)
        for (int a = 0; a < 3; a++) {
            if (vert[3 * i + a] < lo[a]) lo[a] = vert[3 * i + a];
            if (vert[3 * i + a] > hi[a]) hi[a] = vert[3 * i + a];
        }
    for (int a = 0; a < 3; a++) b->c[a] = 0.5 * (lo[a] + hi[a]);
    b->vert = malloc(sizeof(double) * 3 * (size_t)nvert);
    b->tri = malloc(sizeof(int) * 3 * (size_t)ntri);
    if (!b->vert || !b->tri) return snprintf(err, errlen, "out of memory"), kf_rigid_bvh_free(b), NULL;
    for (size_t i = 0; i < 3 * (size_t)nvert; i++) b->vert[i] = vert[i] - b->c[i % 3];
    memcpy(b->tri, tri, sizeof(int) * 3 * (size_t)ntri);
    b->plane = malloc(sizeof(double) * 4 * (size_t)ntri);
    if (!b->plane) return snprintf(err, errlen, "out of memory"), kf_rigid_bvh_free(b), NULL;
    double ext = 0;
    for (size_t i = 0; i < 3 * (size_t)nvert; i++) ext = fmax(ext, fabs(b->vert[i]));
    b->tol = 1e-9 * (1 + ext);
    for (size_t k = 0; k < (size_t)ntri; k++) {
        const double *v0 = &b->vert[3 * tri[3 * k]], *v1 = &b->vert[3 * tri[3 * k + 1]],
                     *v2 = &b->vert[3 * tri[3 * k + 2]];
        double e1[3], e2[3], n[3];
        for (int a = 0; a < 3; a++) e1[a] = v1[a] - v0[a], e2[a] = v2[a] - v0[a];
        kf_v3d_cross(n, e1, e2);
        /* a sliver's normal is not trusted (its cross product cancels):
         * it keeps a zero plane, never skipped */
        double nn = sqrt(kf_v3d_dot(n, n)), l1 = sqrt(kf_v3d_dot(e1, e1)), l2 = sqrt(kf_v3d_dot(e2, e2));
        int ok = nn > 1e-3 * l1 * l2;
        double *pl = &b->plane[4 * k];
        for (int a = 0; a < 3; a++) pl[a] = ok ? n[a] / nn : 0;
        pl[3] = kf_v3d_dot(pl, v0);
    }
    /* one build thread: the simulation's OpenMP threads own the cores */
    b->dev = rtcNewDevice("threads=1");
    if (!b->dev) {
        snprintf(err, errlen, "cannot create the Embree device (error %d)", (int)rtcGetDeviceError(NULL));
        return kf_rigid_bvh_free(b), NULL;
    }
    b->scn = rtcNewScene(b->dev);
    rtcSetSceneFlags(b->scn, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(b->scn, RTC_BUILD_QUALITY_HIGH);
    RTCGeometry g = rtcNewGeometry(b->dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *vb =
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), (size_t)nvert);
    unsigned *ib =
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), (size_t)ntri);
    if (!vb || !ib) {
        snprintf(err, errlen, "Embree buffer allocation failed");
        rtcReleaseGeometry(g);
        return kf_rigid_bvh_free(b), NULL;
    }
    for (size_t i = 0; i < (size_t)nvert; i++)
        for (int a = 0; a < 3; a++) vb[3 * i + a] = (float)(vert[3 * i + a] - b->c[a]);
    for (size_t t = 0; t < 3 * (size_t)ntri; t++) ib[t] = (unsigned)tri[t];
    rtcCommitGeometry(g);
    rtcAttachGeometry(b->scn, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(b->scn);
    if (rtcGetDeviceError(b->dev) != RTC_ERROR_NONE) {
        snprintf(err, errlen, "Embree scene build failed");
        return kf_rigid_bvh_free(b), NULL;
    }
    return b;
}

int kf_rigid_bvh_first_hit(const kf_rigid_bvh *b, const double p0[3], const double p1[3], double *t) {
    struct RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    struct RTCRayHit rh;
    rh.ray.org_x = (float)(p0[0] - b->c[0]);
    rh.ray.org_y = (float)(p0[1] - b->c[1]);
    rh.ray.org_z = (float)(p0[2] - b->c[2]);
    rh.ray.dir_x = (float)(p1[0] - p0[0]);
    rh.ray.dir_y = (float)(p1[1] - p0[1]);
    rh.ray.dir_z = (float)(p1[2] - p0[2]);
    rh.ray.tnear = 0;
    rh.ray.tfar = 1;
    rh.ray.time = 0;
    rh.ray.mask = 0xFFFFFFFFu;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(b->scn, &ctx, &rh);
    if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return -1;
    if (t) *t = rh.ray.tfar;
    return (int)rh.hit.primID;
}

/* ---- closest points -------------------------------------------------------- */

/* The closest point of triangle (a, b, c) to p, and whether it lies inside
 * the triangle (not on an edge or a corner): Ericson's region test. */
static void closest_on_triangle(const double p[3], const double a[3], const double b[3], const double c[3], double q[3],
                                int *interior) {
    double ab[3], ac[3], ap[3];
    for (int i = 0; i < 3; i++) ab[i] = b[i] - a[i], ac[i] = c[i] - a[i], ap[i] = p[i] - a[i];
#define DOT(u, v) ((u)[0] * (v)[0] + (u)[1] * (v)[1] + (u)[2] * (v)[2])
    double d1 = DOT(ab, ap), d2 = DOT(ac, ap);
    *interior = 0;
    if (d1 <= 0 && d2 <= 0) {
        memcpy(q, a, 3 * sizeof(double));
        return;
    }
    double bp[3] = {p[0] - b[0], p[1] - b[1], p[2] - b[2]}, d3 = DOT(ab, bp), d4 = DOT(ac, bp);
    if (d3 >= 0 && d4 <= d3) {
        memcpy(q, b, 3 * sizeof(double));
        return;
    }
    double vc = d1 * d4 - d3 * d2;
    if (vc <= 0 && d1 >= 0 && d3 <= 0) {
        double v = d1 / (d1 - d3);
        for (int i = 0; i < 3; i++) q[i] = a[i] + v * ab[i];
        return;
    }
    double cp[3] = {p[0] - c[0], p[1] - c[1], p[2] - c[2]}, d5 = DOT(ab, cp), d6 = DOT(ac, cp);
    if (d6 >= 0 && d5 <= d6) {
        memcpy(q, c, 3 * sizeof(double));
        return;
    }
    double vb = d5 * d2 - d1 * d6;
    if (vb <= 0 && d2 >= 0 && d6 <= 0) {
        double w = d2 / (d2 - d6);
        for (int i = 0; i < 3; i++) q[i] = a[i] + w * ac[i];
        return;
    }
    double va = d3 * d6 - d5 * d4;
    if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
        double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        for (int i = 0; i < 3; i++) q[i] = b[i] + w * (c[i] - b[i]);
        return;
    }
    double den = 1 / (va + vb + vc), v = vb * den, w = vc * den;
    for (int i = 0; i < 3; i++) q[i] = a[i] + ab[i] * v + ac[i] * w;
    *interior = 1;
#undef DOT
}

typedef struct closest_ctx {
    const kf_rigid_bvh *b;
    double p[3];        /* shifted */
    double best2, best; /* the best distance, squared and not */
    int prim, interior;
    double q[3]; /* shifted */
} closest_ctx;

static bool closest_cb(struct RTCPointQueryFunctionArguments *args) {
    closest_ctx *c = args->userPtr;
    const int *t = &c->b->tri[3 * args->primID];
    /* A triangle whose plane is already farther than the best point cannot
     * hold a closer one (its closest point lies on the plane): skipped
     * before the region test. With the margin (tol) it is skipped only
     * where the test below would reject it too: the result is the same. */
    const double *pl = &c->b->plane[4 * args->primID];
    if (fabs(pl[0] * c->p[0] + pl[1] * c->p[1] + pl[2] * c->p[2] - pl[3]) > c->best + c->b->tol) return false;
    double q[3];
    int interior;
    closest_on_triangle(c->p, &c->b->vert[3 * t[0]], &c->b->vert[3 * t[1]], &c->b->vert[3 * t[2]], q, &interior);
    double d2 =
        (q[0] - c->p[0]) * (q[0] - c->p[0]) + (q[1] - c->p[1]) * (q[1] - c->p[1]) + (q[2] - c->p[2]) * (q[2] - c->p[2]);
    if (d2 < c->best2) {
        c->best2 = d2;
        c->prim = (int)args->primID;
        c->interior = interior;
        memcpy(c->q, q, sizeof q);
        c->best = sqrt(d2);
        args->query->radius = (float)c->best; /* shrink the search */
        return true;
    }
    return false;
}

int kf_rigid_bvh_closest(const kf_rigid_bvh *b, const double p[3], double radius, double q[3], int *interior) {
    closest_ctx c = {b, {p[0] - b->c[0], p[1] - b->c[1], p[2] - b->c[2]}, radius * radius, radius, -1, 0, {0, 0, 0}};
    struct RTCPointQuery pq = {(float)c.p[0], (float)c.p[1], (float)c.p[2], 0, (float)radius};
    struct RTCPointQueryContext ctx;
    rtcInitPointQueryContext(&ctx);
    rtcPointQuery(b->scn, &pq, &ctx, closest_cb, &c);
    if (c.prim < 0) return -1;
    for (int a = 0; a < 3; a++) q[a] = c.q[a] + b->c[a];
    if (interior) *interior = c.interior;
    return c.prim;
}

/* ---- every triangle within a radius ---------------------------------------- */

typedef struct within_ctx {
    const kf_rigid_bvh *b;
    double p[3]; /* shifted */
    double r2;
    int (*fn)(void *, int);
    void *ctx;
    int done;
} within_ctx;

static bool within_cb(struct RTCPointQueryFunctionArguments *args) {
    within_ctx *c = args->userPtr;
    if (c->done) return false;
    const int *t = &c->b->tri[3 * args->primID];
    double q[3];
    int interior;
    closest_on_triangle(c->p, &c->b->vert[3 * t[0]], &c->b->vert[3 * t[1]], &c->b->vert[3 * t[2]], q, &interior);
    double d2 =
        (q[0] - c->p[0]) * (q[0] - c->p[0]) + (q[1] - c->p[1]) * (q[1] - c->p[1]) + (q[2] - c->p[2]) * (q[2] - c->p[2]);
    if (d2 <= c->r2) c->done = c->fn(c->ctx, (int)args->primID);
    return false; /* the radius stays: every triangle within it is visited */
}

void kf_rigid_bvh_within(const kf_rigid_bvh *b, const double p[3], double radius, int (*fn)(void *ctx, int tri),
                         void *ctx) {
    within_ctx c = {b, {p[0] - b->c[0], p[1] - b->c[1], p[2] - b->c[2]}, radius * radius, fn, ctx, 0};
    /* Embree's radius widened far beyond the rounding of its float point and
     * vertices (tol is 1e-9 of the mesh's extent), so that no triangle within
     * the double radius is left out of its traversal; the distance test
     * above decides */
    struct RTCPointQuery pq = {(float)c.p[0], (float)c.p[1], (float)c.p[2], 0, (float)(radius * 1.001 + 1000 * b->tol)};
    struct RTCPointQueryContext ctx2;
    rtcInitPointQueryContext(&ctx2);
    rtcPointQuery(b->scn, &pq, &ctx2, within_cb, &c);
}
