/* inside.c — Embree ray-parity inside test with edge-hit detection and
 * re-casting (see inside.h for the method). */
#include "inside.h"

#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <embree3/rtcore.h>

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#define KF_HAVE_MXCSR 1
#endif

/* a hit this close to an edge (barycentric) or a face this close to parallel
 * to the ray (cosine) makes the ray unreliable: Embree's float test may count
 * such a crossing twice or not at all */
#define EDGE_EPS 1e-4f
#define GRAZE_EPS 1e-5f
#define MAX_HITS 256

struct kf_mesh_inside {
    RTCDevice dev;
    RTCScene scene;
    double c[3]; /* the mesh was shifted by -c before going to float */
    float *nrm;  /* (ntri x 3) unit face normals, for the grazing test */
    int ndirs;
    float dirs[KF_INSIDE_MAX_DIRS][3];
    char error[256]; /* last Embree error message */
};

/* per-ray state: Embree hands the context to the filter, so ours extends it */
typedef struct ray_ctx {
    struct RTCIntersectContext ctx; /* must be first */
    const float *nrm;
    float d[3];
    int nhits;
    int unreliable;
    uint32_t prim[MAX_HITS];
} ray_ctx;

/* Record every hit and reject it, so traversal goes on to the next one.
 * rtcIntersect1 passes one ray (N == 1); the loop keeps to the API's contract
 * of N lanes, SoA layout: u at 3N, v at 4N, primID at 5N. */
static void count_hit(const struct RTCFilterFunctionNArguments *a) {
    ray_ctx *r = (ray_ctx *)a->context;
    const float *hit = (const float *)a->hit;
    const uint32_t *hitu = (const uint32_t *)a->hit;
    const unsigned N = a->N;
    for (unsigned i = 0; i < N; i++) {
        if (!a->valid[i]) continue;
        a->valid[i] = 0;
        float u = hit[3 * N + i], v = hit[4 * N + i], w = 1.0f - u - v;
        uint32_t prim = hitu[5 * N + i];
        int seen = 0;
        for (int k = 0; k < r->nhits && !seen; k++) seen = r->prim[k] == prim; /* reported again (spatial splits) */
        if (seen) continue;
        if (r->nhits == MAX_HITS) {
            r->unreliable = 1;
            continue;
        }
        r->prim[r->nhits++] = prim;
        const float *n = &r->nrm[3 * (size_t)prim];
        float cosang = n[0] * r->d[0] + n[1] * r->d[1] + n[2] * r->d[2];
        if (u < EDGE_EPS || v < EDGE_EPS || w < EDGE_EPS || fabsf(cosang) < GRAZE_EPS) r->unreliable = 1;
    }
}

static void on_error(void *user, enum RTCError code, const char *str) {
    kf_mesh_inside *q = user;
    if (q) snprintf(q->error, sizeof q->error, "Embree error %d: %s", (int)code, str ? str : "");
}

/* directions: the columns of three generic rotations (angles chosen to be far
 * from the axes, the diagonals and each other) */
int kf_mesh_inside_default_dirs(double dirs[KF_INSIDE_MAX_DIRS][3]) {
    static const double euler[4][3] = {
        {0.4137, 0.7923, 0.2311}, {1.1329, 0.3571, 2.0713}, {2.4671, 1.2113, 0.8209}, {0.9091, 2.7183, 1.6180}};
    int n = 0;
    for (int r = 0; r < 4; r++) {
        double a = euler[r][0], b = euler[r][1], g = euler[r][2];
        double ca = cos(a), sa = sin(a), cb = cos(b), sb = sin(b), cg = cos(g), sg = sin(g);
        /* R = Rz(g) Ry(b) Rx(a) */
        double R[3][3] = {{cg * cb, cg * sb * sa - sg * ca, cg * sb * ca + sg * sa},
                          {sg * cb, sg * sb * sa + cg * ca, sg * sb * ca - cg * sa},
                          {-sb, cb * sa, cb * ca}};
        for (int col = 0; col < 3 && n < KF_INSIDE_MAX_DIRS; col++, n++)
            for (int k = 0; k < 3; k++) dirs[n][k] = R[k][col];
    }
    return n;
}

kf_mesh_inside *kf_mesh_inside_create(const kf_mesh *m, const double (*dirs)[3], int ndirs, char *err, size_t errlen) {
    if (kf_mesh_check_closed(m, err, errlen)) return NULL;
    if (m->ntri >= UINT32_MAX / 2) {
        snprintf(err, errlen, "%s: too many triangles for Embree (%zu)", m->path, m->ntri);
        return NULL;
    }
    kf_mesh_inside *q = calloc(1, sizeof *q);
    if (!q) {
        snprintf(err, errlen, "%s: out of memory", m->path);
        return NULL;
    }
    double d[KF_INSIDE_MAX_DIRS][3];
    q->ndirs = kf_mesh_inside_default_dirs(d);
    if (dirs)
        for (int i = 0; i < ndirs && i < KF_INSIDE_MAX_DIRS; i++) memcpy(d[i], dirs[i], sizeof d[i]);
    for (int i = 0; i < q->ndirs; i++) {
        double L = sqrt(d[i][0] * d[i][0] + d[i][1] * d[i][1] + d[i][2] * d[i][2]);
        for (int k = 0; k < 3; k++) q->dirs[i][k] = (float)(L > 0 ? d[i][k] / L : (k == 0));
    }
    for (int k = 0; k < 3; k++) q->c[k] = 0.5 * (m->lo[k] + m->hi[k]);

    q->nrm = malloc(m->ntri * 3 * sizeof *q->nrm);
    q->dev = rtcNewDevice(NULL);
    if (!q->nrm || !q->dev) {
        snprintf(err, errlen, "%s: cannot create the Embree device (%d)", m->path, (int)rtcGetDeviceError(NULL));
        kf_mesh_inside_destroy(q);
        return NULL;
    }
    rtcSetDeviceErrorFunction(q->dev, on_error, q);
    q->scene = rtcNewScene(q->dev);
    rtcSetSceneFlags(q->scene, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(q->scene, RTC_BUILD_QUALITY_MEDIUM);
    RTCGeometry g = rtcNewGeometry(q->dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), m->nvert);
    unsigned *ib =
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), m->ntri);
    if (!vb || !ib) {
        snprintf(err, errlen, "%s: %s", m->path, q->error[0] ? q->error : "Embree buffer allocation failed");
        rtcReleaseGeometry(g);
        kf_mesh_inside_destroy(q);
        return NULL;
    }
    for (size_t i = 0; i < m->nvert; i++)
        for (int k = 0; k < 3; k++) vb[3 * i + k] = (float)(m->vert[3 * i + k] - q->c[k]);
    for (size_t t = 0; t < m->ntri; t++) {
        for (int k = 0; k < 3; k++) ib[3 * t + k] = m->tri[3 * t + k];
        /* normals from the float vertices Embree sees */
        const float *a = &vb[3 * ib[3 * t]], *b = &vb[3 * ib[3 * t + 1]], *c = &vb[3 * ib[3 * t + 2]];
        double e[3], f[3];
        for (int k = 0; k < 3; k++) e[k] = (double)b[k] - a[k], f[k] = (double)c[k] - a[k];
        double n[3] = {e[1] * f[2] - e[2] * f[1], e[2] * f[0] - e[0] * f[2], e[0] * f[1] - e[1] * f[0]};
        double L = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
        for (int k = 0; k < 3; k++) q->nrm[3 * t + k] = L > 0 ? (float)(n[k] / L) : 0.0f;
    }
    rtcSetGeometryIntersectFilterFunction(g, count_hit);
    rtcCommitGeometry(g);
    rtcAttachGeometry(q->scene, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(q->scene);
    if (rtcGetDeviceError(q->dev) != RTC_ERROR_NONE || q->error[0]) {
        snprintf(err, errlen, "%s: %s", m->path, q->error[0] ? q->error : "Embree scene build failed");
        kf_mesh_inside_destroy(q);
        return NULL;
    }
    return q;
}

void kf_mesh_inside_destroy(kf_mesh_inside *q) {
    if (!q) return;
    if (q->scene) rtcReleaseScene(q->scene);
    if (q->dev) rtcReleaseDevice(q->dev);
    free(q->nrm);
    free(q);
}

/* one ray: parity of distinct crossings; *unreliable when a hit is near an edge */
static int cast(const kf_mesh_inside *q, const float o[3], const float d[3], int *unreliable) {
    ray_ctx r;
    rtcInitIntersectContext(&r.ctx);
    r.nrm = q->nrm;
    memcpy(r.d, d, sizeof r.d);
    r.nhits = 0;
    r.unreliable = 0;
    struct RTCRayHit rh;
    rh.ray.org_x = o[0], rh.ray.org_y = o[1], rh.ray.org_z = o[2];
    rh.ray.dir_x = d[0], rh.ray.dir_y = d[1], rh.ray.dir_z = d[2];
    rh.ray.tnear = 0.0f;
    rh.ray.tfar = INFINITY;
    rh.ray.time = 0.0f;
    rh.ray.mask = UINT32_MAX;
    rh.ray.id = 0;
    rh.ray.flags = 0;
    rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.primID = RTC_INVALID_GEOMETRY_ID;
    rh.hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
    rtcIntersect1(q->scene, &r.ctx, &rh);
    *unreliable = r.unreliable;
    return r.nhits & 1;
}

/* majority of the first three reliable rays; counts into st */
static int classify(const kf_mesh_inside *q, const double p[3], kf_inside_stats *st) {
    float o[3];
    for (int k = 0; k < 3; k++) o[k] = (float)(p[k] - q->c[k]);
    int in = 0, out = 0, all_in = 0, all = 0;
    st->points++;
    for (int i = 0; i < q->ndirs; i++) {
        int bad;
        int par = cast(q, o, q->dirs[i], &bad);
        st->rays++;
        all_in += par;
        all++;
        if (bad) {
            st->unreliable++;
            continue;
        }
        if (par) in++;
        else out++;
        if (in == 2) return 1;
        if (out == 2) return 0;
    }
    /* fewer than two reliable rays agree: a point on the surface, or a mesh
     * that is not watertight in float; fall back on everything cast */
    st->undecided++;
    if (in != out) return in > out;
    return 2 * all_in > all;
}

int kf_mesh_inside_point(const kf_mesh_inside *q, const double p[3], kf_inside_stats *stats) {
    kf_inside_stats st = {0};
#ifdef KF_HAVE_MXCSR
    unsigned csr = _mm_getcsr();
    _mm_setcsr(csr | 0x8040); /* FTZ | DAZ, as Embree asks */
#endif
    int r = classify(q, p, &st);
#ifdef KF_HAVE_MXCSR
    _mm_setcsr(csr);
#endif
    if (stats) {
        stats->points += st.points, stats->rays += st.rays;
        stats->unreliable += st.unreliable, stats->undecided += st.undecided;
    }
    return r;
}

void kf_mesh_inside_points(const kf_mesh_inside *q, size_t n, const double *p3, uint8_t *inside, int threads,
                           kf_inside_stats *stats) {
    long rays = 0, unrel = 0, undec = 0;
    int nt = threads > 0 ? threads : omp_get_max_threads();
    if ((size_t)nt > n / 256 + 1) nt = (int)(n / 256 + 1);
#pragma omp parallel num_threads(nt) reduction(+ : rays, unrel, undec)
    {
#ifdef KF_HAVE_MXCSR
        unsigned csr = _mm_getcsr();
        _mm_setcsr(csr | 0x8040); /* per thread: FTZ | DAZ */
#endif
        kf_inside_stats st = {0};
#pragma omp for schedule(dynamic, 512)
        for (size_t i = 0; i < n; i++) inside[i] = (uint8_t)classify(q, &p3[3 * i], &st);
        rays += st.rays, unrel += st.unreliable, undec += st.undecided;
#ifdef KF_HAVE_MXCSR
        _mm_setcsr(csr);
#endif
    }
    if (stats) {
        stats->points += (long)n, stats->rays += rays;
        stats->unreliable += unrel, stats->undecided += undec;
    }
}
