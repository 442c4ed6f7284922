/* seed_rays.c — lattice crossings by Embree 3 rays (see seed_crossings.h).
 *
 * One ray along each lattice line, over the mesh's bounds, cast 16 at a
 * time (neighbouring lines of a row: a coherent packet). Embree stops at
 * the first hit; an intersection filter records every hit (triangle and
 * barycentric u, v) and rejects it, so traversal goes on to the next one and
 * a ray reports every triangle on its line, each once.
 *
 * Order: each row of lines goes to one thread; each line's crossings are
 * sorted and rid of repeats there (kf_seed_crossings_order on the line), and
 * the rows are joined in row order, which is the order of
 * kf_seed_crossings_order on the whole list, for any thread count.
 *
 * Watertightness: the scene is built with RTC_SCENE_FLAG_ROBUST (Embree's
 * watertight triangle test), so a line through a shared edge or vertex of
 * the float mesh hits at least one of the triangles there (often several:
 * kf_seed_crossings_order keeps one). Without it such a line can slip
 * between two triangles (measured: 6 of 529 lines through the vertices and
 * edges of test_seed's tilted sheet found no crossing); seed.c's hole pass
 * would then add a seed, but the crossings would depend on the
 * triangulation again. The lattice's odd offsets keep real meshes' edges
 * off the lines, where both modes agree.
 *
 * Precision: Embree sees the mesh in float, shifted by its bounds' centre.
 * It only decides which triangles a line crosses; the crossing point is
 * recomputed in double on the exact line (kf_seed_point_on_line). Taking
 * Embree's float u, v instead puts crossings up to 3e-6 of the mesh's
 * extent off the line (bunny, armadillo, knife): harmless for coverage, but
 * the double points lie on their triangles and their lines to round-off
 * (1e-16) and equal the rasteriser's exactly. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <embree3/rtcore.h>

#include "seed_crossings.h"

#if defined(__SSE__) || defined(__x86_64__)
#include <xmmintrin.h>
#define KF_SEED_MXCSR 1
#endif

/* one hit reported by Embree */
typedef struct ray_hit {
    uint32_t prim;
    float u, v;
} ray_hit;

#define PACKET 16

/* per-packet state: Embree hands the context to the filter, so ours extends
 * it; one growing hit list per lane (the ray's id) */
typedef struct ray_ctx {
    struct RTCIntersectContext ctx; /* must be first */
    ray_hit *hit[PACKET];
    int n[PACKET], cap[PACKET];
    int oom;
} ray_ctx;

/* Record every hit and reject it (valid = 0), so traversal continues.
 * Embree may call with the packet (N = 16) or with single rays of it (N = 1),
 * so a lane is known by its ray id, not its position. SoA layouts of the
 * API: hit u at 3N, v at 4N, primID at 5N; ray id at 10N. A triangle
 * reported twice for one ray (spatial splits) is recorded once. */
static void record_hit(const struct RTCFilterFunctionNArguments *a) {
    ray_ctx *r = (ray_ctx *)a->context;
    const float *hf = (const float *)a->hit;
    const uint32_t *hu = (const uint32_t *)a->hit, *ru = (const uint32_t *)a->ray;
    const unsigned N = a->N;
    for (unsigned i = 0; i < N; i++) {
        if (!a->valid[i]) continue;
        a->valid[i] = 0;
        uint32_t prim = hu[5 * N + i], lane = ru[10 * N + i];
        if (lane >= PACKET) continue;
        int seen = 0;
        for (int k = 0; k < r->n[lane] && !seen; k++) seen = r->hit[lane][k].prim == prim;
        if (seen) continue;
        if (r->n[lane] == r->cap[lane]) {
            int cap = r->cap[lane] ? 2 * r->cap[lane] : 16;
            ray_hit *h = realloc(r->hit[lane], sizeof *h * (size_t)cap);
            if (!h) {
                r->oom = 1;
                continue;
            }
            r->hit[lane] = h, r->cap[lane] = cap;
        }
        r->hit[lane][r->n[lane]++] = (ray_hit){prim, hf[3 * N + i], hf[4 * N + i]};
    }
}

typedef struct scene {
    RTCDevice dev;
    RTCScene scn;
    double c[3]; /* the mesh was shifted by -c before going to float */
    char error[256];
} scene;

static void on_error(void *user, enum RTCError code, const char *str) {
    scene *s = user;
    snprintf(s->error, sizeof s->error, "Embree error %d: %s", (int)code, str ? str : "");
}

static void scene_free(scene *s) {
    if (s->scn) rtcReleaseScene(s->scn);
    if (s->dev) rtcReleaseDevice(s->dev);
    s->scn = NULL, s->dev = NULL;
}

/* the float mesh in an Embree scene with the recording filter */
static int scene_build(scene *s, const double *vert, int nvert, const int *tri, int ntri, const double c[3], char *err,
                       size_t errlen) {
    memset(s, 0, sizeof *s);
    memcpy(s->c, c, sizeof s->c);
    s->dev = rtcNewDevice(NULL);
    if (!s->dev) {
        snprintf(err, errlen, "cannot create the Embree device (error %d)", (int)rtcGetDeviceError(NULL));
        return -1;
    }
    rtcSetDeviceErrorFunction(s->dev, on_error, s);
    s->scn = rtcNewScene(s->dev);
    rtcSetSceneFlags(s->scn, RTC_SCENE_FLAG_ROBUST);
    rtcSetSceneBuildQuality(s->scn, RTC_BUILD_QUALITY_MEDIUM);
    RTCGeometry g = rtcNewGeometry(s->dev, RTC_GEOMETRY_TYPE_TRIANGLE);
    float *vb =
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), (size_t)nvert);
    unsigned *ib =
        rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3, 3 * sizeof(unsigned), (size_t)ntri);
    if (!vb || !ib) {
        snprintf(err, errlen, "%s", s->error[0] ? s->error : "Embree buffer allocation failed");
        rtcReleaseGeometry(g);
        scene_free(s);
        return -1;
    }
    for (size_t i = 0; i < (size_t)nvert; i++)
        for (int k = 0; k < 3; k++) vb[3 * i + k] = (float)(vert[3 * i + k] - c[k]);
    for (size_t t = 0; t < 3 * (size_t)ntri; t++) ib[t] = (unsigned)tri[t];
    rtcSetGeometryIntersectFilterFunction(g, record_hit);
    rtcCommitGeometry(g);
    rtcAttachGeometry(s->scn, g);
    rtcReleaseGeometry(g);
    rtcCommitScene(s->scn);
    if (rtcGetDeviceError(s->dev) != RTC_ERROR_NONE || s->error[0]) {
        snprintf(err, errlen, "%s", s->error[0] ? s->error : "Embree scene build failed");
        scene_free(s);
        return -1;
    }
    return 0;
}

/* the lines along axis a through lattice points (i0 .. i0 + 15, j) of one
 * row: every triangle each hits between lo_a - h and hi_a + h, each a
 * crossing computed in double, each line's crossings in order */
static void cast_packet(const scene *s, ray_ctx *r, kf_seed_xbuf *out, const double *vert, const int *tri,
                        const kf_seed_lattice *L, const double lo[3], const double hi[3], int a, int32_t i0, int32_t j,
                        double tol) {
    const int b = (a + 1) % 3, c = (a + 2) % 3;
    const double wc = L->o[c] + j * L->h;
    /* Embree reads the valid mask and the packet as 64-byte aligned vectors */
    _Alignas(64) int valid[PACKET];
    _Alignas(64) struct RTCRayHit16 rh;
    float *org[3] = {rh.ray.org_x, rh.ray.org_y, rh.ray.org_z}, *dir[3] = {rh.ray.dir_x, rh.ray.dir_y, rh.ray.dir_z};
    for (int k = 0; k < PACKET; k++) {
        valid[k] = i0 + k < L->n[b] ? -1 : 0;
        org[a][k] = (float)(lo[a] - L->h - s->c[a]);
        org[b][k] = (float)(L->o[b] + (i0 + k) * L->h - s->c[b]);
        org[c][k] = (float)(wc - s->c[c]);
        dir[a][k] = 1, dir[b][k] = 0, dir[c][k] = 0;
        rh.ray.tnear[k] = 0.0f;
        rh.ray.tfar[k] = (float)(hi[a] - lo[a] + 2 * L->h);
        rh.ray.time[k] = 0.0f;
        rh.ray.mask[k] = UINT32_MAX;
        rh.ray.id[k] = (unsigned)k;
        rh.ray.flags[k] = 0;
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.primID[k] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
        r->n[k] = 0;
    }
    rtcIntersect16(valid, s->scn, &r->ctx, &rh);
    for (int k = 0; k < PACKET && valid[k]; k++) {
        const int32_t i = i0 + k;
        const double ub = L->o[b] + i * L->h;
        size_t first = out->n;
        for (int q = 0; q < r->n[k]; q++) {
            const int t = (int)r->hit[k][q].prim;
            const double *P[3] = {vert + 3 * (size_t)tri[3 * t], vert + 3 * (size_t)tri[3 * t + 1],
                                  vert + 3 * (size_t)tri[3 * t + 2]};
            kf_seed_crossing x = {.tri = t, .axis = (int8_t)a, .i = i, .j = j};
            if (kf_seed_point_on_line(P, a, ub, wc, x.x)) {
                /* parallel to the line in double yet hit in float: Embree's
                 * own barycentric point, in double */
                double u = r->hit[k][q].u, v = r->hit[k][q].v;
                for (int d = 0; d < 3; d++) x.x[d] = (1 - u - v) * P[0][d] + u * P[1][d] + v * P[2][d];
            }
            kf_seed_xpush(out, &x);
        }
        if (!out->oom) out->n = first + kf_seed_crossings_order(out->c + first, out->n - first, vert, tri, tol);
    }
}

long kf_seed_crossings_rays(const double *vert, int nvert, const int *tri, int ntri, const kf_seed_lattice *L,
                            kf_seed_crossing **out, char *err, size_t errlen) {
    *out = NULL;
    if (ntri < 1 || nvert < 3 || (unsigned)ntri >= UINT32_MAX / 2) {
        snprintf(err, errlen, "%d triangles: nothing Embree can trace", ntri);
        return -1;
    }
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY}, c[3];
    for (size_t v = 0; v < (size_t)nvert; v++)
        for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], vert[3 * v + a]), hi[a] = fmax(hi[a], vert[3 * v + a]);
    for (int a = 0; a < 3; a++) c[a] = 0.5 * (lo[a] + hi[a]);
    scene s;
    if (scene_build(&s, vert, nvert, tri, ntri, c, err, errlen)) return -1;

    /* the rows (axis a, j); each row's lines i go to one thread, which
     * notes where in its buffer the row's crossings went */
    const long rows = (long)L->n[2] + L->n[0] + L->n[1]; /* axis 0 rows run over c = 2, and so on */
    double ext = 0;
    for (int a = 0; a < 3; a++) ext = fmax(ext, L->n[a] * L->h);
    const double tol = KF_SEED_SAME_POINT * ext;
    int nt = omp_get_max_threads();
    kf_seed_xbuf *part = calloc((size_t)nt, sizeof *part);
    size_t *row_at = malloc(sizeof *row_at * (size_t)(rows + 1)), *row_n = malloc(sizeof *row_n * (size_t)(rows + 1));
    int *row_by = malloc(sizeof *row_by * (size_t)(rows + 1));
    int oom = !part || !row_at || !row_n || !row_by;
    if (!oom) {
#pragma omp parallel num_threads(nt) reduction(| : oom)
        {
#ifdef KF_SEED_MXCSR
            unsigned csr = _mm_getcsr();
            _mm_setcsr(csr | 0x8040); /* per thread: FTZ | DAZ, as Embree asks */
#endif
            const int me = omp_get_thread_num();
            kf_seed_xbuf *mine = &part[me];
            ray_ctx r;
            memset(&r, 0, sizeof r);
            rtcInitIntersectContext(&r.ctx);
#pragma omp for schedule(dynamic, 4)
            for (long row = 0; row < rows; row++) {
                int a = row < L->n[2] ? 0 : row < (long)L->n[2] + L->n[0] ? 1 : 2;
                int32_t j = (int32_t)(a == 0 ? row : a == 1 ? row - L->n[2] : row - L->n[2] - L->n[0]);
                const int b = (a + 1) % 3;
                row_at[row] = mine->n, row_by[row] = me;
                for (int32_t i = 0; i < L->n[b]; i += PACKET)
                    cast_packet(&s, &r, mine, vert, tri, L, lo, hi, a, i, j, tol);
                row_n[row] = mine->n - row_at[row];
            }
            oom |= r.oom | mine->oom;
            for (int k = 0; k < PACKET; k++) free(r.hit[k]);
#ifdef KF_SEED_MXCSR
            _mm_setcsr(csr);
#endif
        }
    }
    scene_free(&s);
    /* the rows joined in row order: the same list for any thread count */
    size_t n = 0;
    for (long row = 0; !oom && row < rows; row++) n += row_n[row];
    kf_seed_crossing *all = oom ? NULL : malloc(sizeof *all * (n ? n : 1));
    if (all) {
        size_t m = 0;
        for (long row = 0; row < rows; row++) {
            if (row_n[row]) memcpy(all + m, part[row_by[row]].c + row_at[row], sizeof *all * row_n[row]);
            m += row_n[row];
        }
    }
    for (int k = 0; part && k < nt; k++) free(part[k].c);
    free(part);
    free(row_at);
    free(row_n);
    free(row_by);
    if (!all) {
        snprintf(err, errlen, "out of memory for the lattice crossings");
        return -1;
    }
    *out = all;
    return (long)n;
}
