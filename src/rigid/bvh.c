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

#include <embree3/rtcore.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

struct kf_rigid_bvh {
    RTCDevice dev;
    RTCScene scn;
    double c[3]; /* the vertices were shifted by -c before going to float */
};

void kf_rigid_bvh_free(kf_rigid_bvh *b) {
    if (!b) return;
    if (b->scn) rtcReleaseScene(b->scn);
    if (b->dev) rtcReleaseDevice(b->dev);
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
    float *vb = rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float),
                                        (size_t)nvert);
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
