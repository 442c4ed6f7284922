/* test_exr.c — EXR frames with AOVs and motion blur, against analytic
 * answers: real OSMesa renders of small images, files written and read
 * back with OpenEXR's own C library (OpenEXRCore).
 *
 * The camera looks down -z from (0, 0, D) at the origin, so a point at
 * camera depth Z (m) projects f X / Z pixels from the centre with
 * f = (h / 2) / tan(fov / 2): depth, normals, motion and blur lengths all
 * have closed forms. Files go to ./exr_test_out/ (the build tree). */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <kerf/kerf.h>
#include "io/vdb_bridge.h"
#include "kt.h"
#include "pipeline/exr.h"
#include "pipeline/exr_frame.h"
#include "pipeline/stages.h"
#include "render.h"
#include "scene/build.h"

#define W 160
#define H 120
#define DIST 5.0f
#define FOV 40.0f
#define PI 3.14159265358979

/* ---- meshes --------------------------------------------------------------- */

typedef struct mesh {
    float *pos, *nrm, *mot;
    uint32_t *tri;
    size_t nv, nt;
} mesh;

static void mesh_free(mesh *m) { free(m->pos), free(m->nrm), free(m->mot), free(m->tri); }

/* UV sphere with exact normals, centre c, radius r */
static mesh sphere(const float c[3], float r, int stacks, int slices) {
    mesh m = {0};
    m.nv = (size_t)(stacks + 1) * (slices + 1);
    m.nt = (size_t)stacks * slices * 2;
    m.pos = malloc(m.nv * 12), m.nrm = malloc(m.nv * 12), m.tri = malloc(m.nt * 12);
    size_t v = 0, t = 0;
    for (int i = 0; i <= stacks; i++)
        for (int j = 0; j <= slices; j++, v++) {
            double th = PI * i / stacks, ph = 2 * PI * j / slices;
            double n[3] = {sin(th) * cos(ph), cos(th), sin(th) * sin(ph)};
            for (int a = 0; a < 3; a++) m.nrm[3 * v + a] = (float)n[a], m.pos[3 * v + a] = c[a] + r * (float)n[a];
        }
    for (int i = 0; i < stacks; i++)
        for (int j = 0; j < slices; j++) {
            uint32_t a = (uint32_t)(i * (slices + 1) + j), b = a + 1, d = a + (uint32_t)slices + 1, e = d + 1;
            uint32_t q[6] = {a, b, d, b, e, d};
            memcpy(&m.tri[3 * t], q, sizeof q);
            t += 2;
        }
    return m;
}

/* a square facing the camera (+z), centre c, half-size s, no normals (flat) */
static mesh square(const float c[3], float s) {
    mesh m = {0};
    m.nv = 4, m.nt = 2;
    m.pos = malloc(48), m.tri = malloc(24);
    const float xy[4][2] = {{-1, -1}, {1, -1}, {1, 1}, {-1, 1}};
    for (int k = 0; k < 4; k++)
        m.pos[3 * k] = c[0] + s * xy[k][0], m.pos[3 * k + 1] = c[1] + s * xy[k][1], m.pos[3 * k + 2] = c[2];
    const uint32_t q[6] = {0, 1, 2, 0, 2, 3};
    memcpy(m.tri, q, sizeof q);
    return m;
}

/* every vertex moved by d a frame */
static void give_motion(mesh *m, const float d[3]) {
    m->mot = malloc(m->nv * 12);
    for (size_t v = 0; v < m->nv; v++)
        for (int a = 0; a < 3; a++) m->mot[3 * v + a] = d[a];
}

static kf_render_mesh as_render(const mesh *m, int id, float grey) {
    kf_render_mesh r;
    memset(&r, 0, sizeof r);
    r.positions = m->pos, r.normals = m->nrm, r.nverts = m->nv, r.tris = m->tri, r.ntris = m->nt;
    r.mat.diffuse[0] = r.mat.diffuse[1] = r.mat.diffuse[2] = grey;
    r.mat.specular = 0, r.mat.roughness = 1;
    r.motion = m->mot, r.id = id;
    return r;
}

/* a plain scene: no ground, black backdrop, shadows off unless asked */
static kf_render_scene plain_scene(const kf_render_mesh *rm, int n) {
    kf_render_scene sc = kf_render_scene_default();
    sc.meshes = rm, sc.nmeshes = n, sc.ground = 0, sc.shadows = 0;
    memset(sc.bg_top, 0, sizeof sc.bg_top), memset(sc.bg_bottom, 0, sizeof sc.bg_bottom);
    return sc;
}

static kf_camera front_camera(float dist, float fov) {
    kf_camera c = {{0, 0, dist}, {0, 0, 0}, {0, 1, 0}, fov, 0, 0};
    return c;
}

/* pixels per metre at camera depth 1 */
static double focal_px(float fov) { return 0.5 * H / tan(fov * PI / 360.0); }

/* the camera-space ray through the centre of pixel (px, py) (rows top-down), z = -1 */
static void pixel_ray(int px, int py, float fov, double d[3]) {
    double f = focal_px(fov);
    d[0] = (px + 0.5 - 0.5 * W) / f, d[1] = (0.5 * H - (py + 0.5)) / f, d[2] = -1;
}

/* the nearest hit of the ray from (0,0,dist) along d with the sphere (c, r): t, or -1 */
static double hit_sphere(const double d[3], float dist, const float c[3], float r) {
    double o[3] = {-c[0], -c[1], dist - c[2]};
    double a = d[0] * d[0] + d[1] * d[1] + d[2] * d[2], b = 2 * (o[0] * d[0] + o[1] * d[1] + o[2] * d[2]);
    double cc = o[0] * o[0] + o[1] * o[1] + o[2] * o[2] - (double)r * r, disc = b * b - 4 * a * cc;
    return disc < 0 ? -1 : (-b - sqrt(disc)) / (2 * a);
}

/* the AOV planes for W x H with mattes for ids */
static void aovs_for(kf_pipeline_aovs *pa, const kf_render_mesh *rm, int n) {
    const char *names[8] = {"a", "b", "c", "d", "e", "f", "g", "h"};
    KT_CHECK(kf_pipeline_aovs_alloc(pa, rm, names, n, (size_t)W * H) == 0, "AOV planes");
}

/* render with AOVs, write the EXR, read it back */
static int render_exr(kf_render_ctx *r, const kf_render_scene *sc, const kf_camera *cam, const char *path,
                      uint8_t *png_rgba, kf_exr_image *img) {
    char err[512];
    kf_pipeline_aovs pa;
    aovs_for(&pa, sc->meshes, sc->nmeshes);
    int rc = kf_render_frame_ex(r, sc, cam, NULL, 0, png_rgba, &pa.aov, err, sizeof err);
    KT_CHECK(rc == 0, "render: %s", err);
    const char *kv[] = {"software", "kerf test"};
    if (rc == 0) rc = kf_pipeline_aovs_write(&pa, path, W, H, kv, 1, err, sizeof err);
    KT_CHECK(rc == 0, "write: %s", err);
    kf_pipeline_aovs_free(&pa);
    if (rc == 0) rc = kf_exr_read(path, img, err, sizeof err);
    KT_CHECK(rc == 0, "read back: %s", err);
    return rc;
}

static kf_render_ctx *ctx(int samples) {
    char err[512];
    kf_render_ctx *r = kf_render_create(W, H, samples, err, sizeof err);
    KT_CHECK(r != NULL, "renderer: %s", err);
    return r;
}

/* two meshes before the front camera on a plain scene, ids ida and idb: the
 * set-up the layout and motion cases share. The scene points into the pair,
 * so a pair is set up where it stays. */
typedef struct pair {
    mesh m[2];
    kf_render_mesh rm[2];
    kf_render_scene sc;
    kf_camera cam;
} pair;

static void pair_init(pair *p, mesh a, mesh b, int ida, int idb, float grey_b) {
    p->m[0] = a, p->m[1] = b;
    p->rm[0] = as_render(&p->m[0], ida, 0.8f), p->rm[1] = as_render(&p->m[1], idb, grey_b);
    p->sc = plain_scene(p->rm, 2);
    p->cam = front_camera(DIST, FOV);
}

static void pair_free(pair *p) { mesh_free(&p->m[0]), mesh_free(&p->m[1]); }

/* write a shot's YAML (a format with its arguments) to path and load it */
static kf_shot *shot_from(const char *path, kf_diag *d, const char *fmt, ...) {
    FILE *f = fopen(path, "w");
    if (f) {
        va_list ap;
        va_start(ap, fmt);
        vfprintf(f, fmt, ap);
        va_end(ap);
        fclose(f);
    }
    kf_diag_init(d);
    kf_shot *shot = kf_shot_load(path, NULL, 0, NULL, NULL, d);
    if (!shot) kf_diag_print(stderr, d);
    KT_CHECK(shot != NULL, "shot loads");
    return shot;
}

/* ---- the layout ------------------------------------------------------------ */

/* every channel there, half, ZIP; a unit sphere and a plane behind it */
static void test_channels(void) {
    kf_render_ctx *r = ctx(4);
    if (!r) return;
    const float c0[3] = {0, 0, 0}, c1[3] = {0, 0, -1};
    pair two;
    pair_init(&two, sphere(c0, 1, 64, 128), square(c1, 3), 1, 2, 0.5f);
    kf_exr_image img;
    if (render_exr(r, &two.sc, &two.cam, "exr_test_out/channels.exr", NULL, &img) == 0) {
        static const char *want[] = {"A", "B",         "G",         "N.x", "N.y",     "N.z",    "R",
                                     "Z", "forward.u", "forward.v", "id",  "matte.a", "matte.b"};
        KT_CHECK(img.nch == 13, "13 channels, got %d", img.nch);
        for (int k = 0; k < 13 && k < img.nch; k++) {
            KT_CHECK(!strcmp(img.name[k], want[k]), "channel %d is %s, want %s", k, img.name[k], want[k]);
            KT_CHECK(img.type[k] == 1, "channel %s is half (type %d)", img.name[k], img.type[k]);
        }
        KT_CHECK(img.w == W && img.h == H, "size %dx%d", img.w, img.h);
        KT_CHECK(!strcmp(img.compression, "zip"), "zip compression, got %s", img.compression);
        char sw[64];
        kf_exr_read_string_attr("exr_test_out/channels.exr", "software", sw, sizeof sw);
        KT_CHECK(!strcmp(sw, "kerf test"), "software attribute: '%s'", sw);
        kf_exr_image_free(&img);
    }
    pair_free(&two);
    kf_render_destroy(r);
}

/* Z is camera depth: the plane at z = -1 reads 6 m at every pixel, even
 * in the corners (the ray distance there is 6 / cos 24 degrees = 6.5 m);
 * the sphere reads the analytic depth of the ray's first hit */
static void test_depth_and_normals(void) {
    kf_render_ctx *r = ctx(4);
    if (!r) return;
    const float c0[3] = {0, 0, 0}, c1[3] = {0, 0, -1};
    pair two;
    pair_init(&two, sphere(c0, 1, 64, 128), square(c1, 4), 1, 2, 0.5f);
    kf_exr_image img;
    if (render_exr(r, &two.sc, &two.cam, "exr_test_out/depth.exr", NULL, &img) == 0) {
        const float *Z = kf_exr_channel_data(&img, "Z"), *id = kf_exr_channel_data(&img, "id");
        const float *N[3] = {kf_exr_channel_data(&img, "N.x"), kf_exr_channel_data(&img, "N.y"),
                             kf_exr_channel_data(&img, "N.z")};
        double worst_plane = 0, worst_sphere = 0, worst_z = 0, worst_n = 0, worst_pn = 0;
        int nsphere = 0, nplane = 0;
        for (int py = 0; py < H; py++)
            for (int px = 0; px < W; px++) {
                size_t i = (size_t)py * W + px;
                double d[3];
                pixel_ray(px, py, FOV, d);
                double t = hit_sphere(d, DIST, c0, 1);
                /* the analytic silhouette: leave out pixels within 1.5 px of it */
                double rim_px = 0;
                {
                    double dd[3];
                    pixel_ray(px, py, FOV, dd);
                    double len = sqrt(dd[0] * dd[0] + dd[1] * dd[1] + 1), ang = acos(1 / len);
                    double edge = asin(1.0 / DIST);
                    rim_px = fabs(tan(ang) - tan(edge)) * focal_px(FOV);
                }
                if (rim_px < 1.5) continue;
                if (t > 0) {
                    double hit[3] = {t * d[0], t * d[1], DIST + t * d[2]};
                    double z = -t * d[2];
                    /* the facets lie within 1 - cos(pi / 128) = 3.0e-4 of the sphere along
                     * each of the two directions of the 64 x 128 grid (6.1e-4 together);
                     * along the ray that is 6.1e-4 / cos(incidence); half rounds 4..8 m
                     * to within 2^-9 = 1.95e-3 */
                    double dl = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
                    double cosi = fabs(d[0] * hit[0] + d[1] * hit[1] + d[2] * hit[2]) / dl;
                    double allowed = 1.96e-3 + 6.1e-4 / cosi;
                    worst_sphere = fmax(worst_sphere, fabs(Z[i] - z) / allowed);
                    worst_z = fmax(worst_z, fabs(Z[i] - z));
                    /* the outward normal of the unit sphere is the hit point */
                    double e = 0;
                    for (int a = 0; a < 3; a++) e = fmax(e, fabs(N[a][i] - hit[a]));
                    worst_n = fmax(worst_n, e);
                    KT_CHECK(id[i] == 1.0f, "sphere pixel (%d,%d) has id %g", px, py, (double)id[i]);
                    nsphere++;
                } else {
                    worst_plane = fmax(worst_plane, fabs(Z[i] - (DIST + 1)));
                    worst_pn = fmax(worst_pn, fabs(N[0][i]) + fabs(N[1][i]) + fabs(N[2][i] - 1));
                    KT_CHECK(id[i] == 2.0f, "plane pixel (%d,%d) has id %g", px, py, (double)id[i]);
                    nplane++;
                }
            }
        printf("  depth: plane |Z - 6| <= %.2e m over %d px, sphere |Z - analytic| <= %.2e m (%.2f of its bound) "
               "over %d px; normals: sphere <= %.2e, plane <= %.2e\n",
               worst_plane, nplane, worst_z, worst_sphere, nsphere, worst_n, worst_pn);
        KT_CHECK(nsphere > 2000 && nplane > 5000, "pixels tested: %d sphere, %d plane", nsphere, nplane);
        /* half at 6: spacing 2^-8, so a round trip is within 2e-3 */
        KT_CHECK(worst_plane <= 2e-3, "plane depth off by %.3g m (camera depth, not ray length)", worst_plane);
        KT_CHECK(worst_sphere <= 1, "sphere depth off by %.3g of (1.96e-3 + 6.1e-4 / cos incidence) m", worst_sphere);
        /* interpolated vertex normals of that tessellation, renormalised, and half rounding */
        KT_CHECK(worst_n <= 4e-3, "sphere normal off by %.3g", worst_n);
        KT_CHECK(worst_pn <= 1e-3, "plane normal off (0, 0, 1) by %.3g", worst_pn);
        kf_exr_image_free(&img);
    }
    pair_free(&two);
    kf_render_destroy(r);
}

/* two objects, two ids; each matte is 1 inside its object, 0 inside the
 * other, fractional only on its rim, and its sum is the analytic area */
static void test_ids_and_mattes(void) {
    kf_render_ctx *r = ctx(4);
    if (!r) return;
    const float ca[3] = {-1.1f, 0, 0}, cb[3] = {1.1f, 0, 0};
    pair two;
    pair_init(&two, sphere(ca, 0.8f, 64, 128), sphere(cb, 0.8f, 64, 128), 3, 7, 0.8f);
    kf_exr_image img;
    if (render_exr(r, &two.sc, &two.cam, "exr_test_out/ids.exr", NULL, &img) == 0) {
        const float *id = kf_exr_channel_data(&img, "id"), *ma = kf_exr_channel_data(&img, "matte.a"),
                    *mb = kf_exr_channel_data(&img, "matte.b");
        KT_CHECK(ma && mb, "one matte per id");
        int pa = 0, pb = 0, bad = 0, fractional = 0;
        double sum_a = 0;
        for (size_t i = 0; ma && mb && i < (size_t)W * H; i++) {
            pa += id[i] == 3.0f, pb += id[i] == 7.0f;
            bad += id[i] != 0 && id[i] != 3.0f && id[i] != 7.0f;
            if (id[i] == 3.0f) bad += mb[i] != 0;
            if (id[i] == 7.0f) bad += ma[i] != 0;
            fractional += ma[i] > 0 && ma[i] < 1;
            sum_a += ma[i];
        }
        /* the silhouette of a sphere seen off-axis is an ellipse: project
         * 4096 rim points and take the polygon's area */
        double area = 0, prev[2] = {0, 0}, first[2] = {0, 0};
        {
            /* the cone from the eye tangent to the sphere: its rim circle */
            double C[3] = {ca[0], ca[1], ca[2] - DIST}, dc = sqrt(C[0] * C[0] + C[1] * C[1] + C[2] * C[2]);
            double rr = 0.8, u[3] = {C[0] / dc, C[1] / dc, C[2] / dc};
            double rim_d = (dc * dc - rr * rr) / dc, rim_r = rr * sqrt(dc * dc - rr * rr) / dc;
            double e1[3] = {u[2], 0, -u[0]}, l1 = sqrt(e1[0] * e1[0] + e1[2] * e1[2]);
            e1[0] /= l1, e1[2] /= l1;
            double e2[3] = {u[1] * e1[2] - u[2] * e1[1], u[2] * e1[0] - u[0] * e1[2], u[0] * e1[1] - u[1] * e1[0]};
            for (int k = 0; k <= 4096; k++) {
                double ph = 2 * PI * k / 4096, p[3];
                for (int x = 0; x < 3; x++) p[x] = u[x] * rim_d + rim_r * (cos(ph) * e1[x] + sin(ph) * e2[x]);
                double s[2] = {focal_px(FOV) * p[0] / -p[2], focal_px(FOV) * p[1] / -p[2]};
                if (k == 0) memcpy(first, s, sizeof s);
                else area += 0.5 * (prev[0] * s[1] - prev[1] * s[0]);
                memcpy(prev, s, sizeof s);
            }
            (void)first;
        }
        area = fabs(area);
        printf("  ids: %d px of id 3, %d of id 7; matte.a sums to %.1f px against %.1f analytic; %d rim px\n", pa, pb,
               sum_a, area, fractional);
        KT_CHECK(bad == 0, "%d pixels with a wrong id or a matte on the other object", bad);
        KT_CHECK(pa > 1500 && pb > 1500, "both objects seen (%d, %d px)", pa, pb);
        KT_CHECK(fractional > 40, "anti-aliased rim: %d fractional matte pixels", fractional);
        /* coverage from 4 samples a pixel along a rim of ~150 px, and the
         * 128-gon's area 0.04 % short of the circle: within 1 % */
        KT_CHECK(fabs(sum_a - area) <= 0.01 * area, "matte area %.1f px, analytic %.1f", sum_a, area);
        kf_exr_image_free(&img);
    }
    pair_free(&two);
    kf_render_destroy(r);
}

/* ---- motion ------------------------------------------------------------------ */

/* a square moving (0.3, -0.2, 0) m a frame at depth 6: every pixel of it
 * moves f x m / 6 pixels, y up; the still one beside it reads 0 */
static void test_motion_vectors(void) {
    kf_render_ctx *r = ctx(4);
    if (!r) return;
    const float c0[3] = {-1, 0, -1}, c1[3] = {1.2f, 0, -1}, m[3] = {0.3f, -0.2f, 0};
    mesh a = square(c0, 0.6f);
    give_motion(&a, m);
    pair two;
    pair_init(&two, a, square(c1, 0.6f), 1, 2, 0.8f);
    kf_exr_image img;
    if (render_exr(r, &two.sc, &two.cam, "exr_test_out/motion.exr", NULL, &img) == 0) {
        const float *u = kf_exr_channel_data(&img, "forward.u"), *v = kf_exr_channel_data(&img, "forward.v"),
                    *id = kf_exr_channel_data(&img, "id");
        double au = focal_px(FOV) * m[0] / (DIST + 1), av = focal_px(FOV) * m[1] / (DIST + 1);
        double worst = 0, still = 0;
        int n = 0;
        for (size_t i = 0; i < (size_t)W * H; i++) {
            if (id[i] == 1.0f) worst = fmax(worst, fmax(fabs(u[i] - au), fabs(v[i] - av))), n++;
            else still = fmax(still, fmax(fabs(u[i]), fabs(v[i])));
        }
        printf("  motion: analytic (%.4f, %.4f) px a frame, worst off %.2e px over %d px; still |mv| <= %g\n", au, av,
               worst, n, still);
        KT_CHECK(n > 1000, "moving square seen (%d px)", n);
        /* half at 4..8 px: spacing 2^-8 */
        KT_CHECK(worst <= 4e-3, "motion vector off by %.3g px", worst);
        KT_CHECK(still == 0, "still square and background move %g px", still);
        kf_exr_image_free(&img);
    }
    pair_free(&two);
    kf_render_destroy(r);
}

/* a camera moving (0.1, 0.05, 0) m a frame (eye and target): what stands
 * still moves the other way, f x -d / Z pixels; what moves with the camera
 * stands still on screen */
static void test_camera_motion(void) {
    kf_render_ctx *r = ctx(4);
    if (!r) return;
    const float c0[3] = {-1, 0, -1}, c1[3] = {1.2f, 0, -1}, d[3] = {0.1f, 0.05f, 0};
    mesh a = square(c0, 0.6f);
    give_motion(&a, d);
    pair two;
    pair_init(&two, a, square(c1, 0.6f), 1, 2, 0.8f);
    kf_camera next = two.cam;
    for (int k = 0; k < 3; k++) next.eye[k] += d[k], next.target[k] += d[k];
    kf_pipeline_aovs pa;
    aovs_for(&pa, two.rm, 2);
    char err[512];
    KT_CHECK(kf_render_frame_ex(r, &two.sc, &two.cam, &next, 0, NULL, &pa.aov, err, sizeof err) == 0, "render: %s",
             err);
    double su = -focal_px(FOV) * d[0] / (DIST + 1), sv = -focal_px(FOV) * d[1] / (DIST + 1), w_still = 0, w_with = 0;
    int n_still = 0, n_with = 0;
    for (size_t i = 0; i < (size_t)W * H; i++) {
        const float *mv = pa.aov.motion + 2 * i;
        if (pa.aov.id[i] == 2.0f) w_still = fmax(w_still, fmax(fabs(mv[0] - su), fabs(mv[1] - sv))), n_still++;
        if (pa.aov.id[i] == 1.0f) w_with = fmax(w_with, fmax(fabs(mv[0]), fabs(mv[1]))), n_with++;
    }
    printf("  camera motion: a still square moves (%.4f, %.4f) px, off by %.2e over %d px; one moving with the "
           "camera %.2e px over %d px\n",
           su, sv, w_still, n_still, w_with, n_with);
    KT_CHECK(n_still > 1000 && n_with > 1000, "both squares seen");
    /* float projection of two cameras (no half here: the planes as rendered) */
    KT_CHECK(w_still <= 1e-3, "still square's motion off by %.3g px", w_still);
    KT_CHECK(w_with <= 1e-3, "the square moving with the camera moves %.3g px", w_with);
    kf_pipeline_aovs_free(&pa);
    pair_free(&two);
    kf_render_destroy(r);
}

/* the linear beauty, encoded with the renderer's 2.2 power, is the PNG:
 * exactly up to 8-bit rounding away from edges (where the EXR averages
 * samples in linear light and the PNG after encoding) */
static void test_beauty_matches_png(void) {
    kf_render_ctx *r = ctx(4);
    if (!r) return;
    const float c0[3] = {0, 0, 0};
    mesh s = sphere(c0, 1, 64, 128);
    kf_render_mesh rm[1] = {as_render(&s, 1, 0.8f)};
    rm[0].mat.specular = 0.6f, rm[0].mat.roughness = 0.2f, rm[0].mat.diffuse[0] = 0.9f;
    kf_render_scene sc = kf_render_scene_default(); /* the studio: ground, gradient, shadows */
    sc.meshes = rm, sc.nmeshes = 1;
    kf_camera cam = front_camera(DIST, FOV);
    cam.eye[1] = 1.5f;
    uint8_t *png = malloc((size_t)W * H * 4), *plain = malloc((size_t)W * H * 4);
    kf_exr_image img;
    char err[512];
    KT_CHECK(kf_render_frame(r, &sc, &cam, plain, err, sizeof err) == 0, "plain render: %s", err);
    if (render_exr(r, &sc, &cam, "exr_test_out/beauty.exr", png, &img) == 0) {
        KT_CHECK(memcmp(png, plain, (size_t)W * H * 4) == 0, "the PNG with AOVs is the PNG without");
        const float *ch[4] = {kf_exr_channel_data(&img, "R"), kf_exr_channel_data(&img, "G"),
                              kf_exr_channel_data(&img, "B"), kf_exr_channel_data(&img, "A")};
        const float *id = kf_exr_channel_data(&img, "id");
        double worst_in = 0, sum = 0, over1 = 0;
        for (int y = 1; y < H - 1; y++)
            for (int x = 1; x < W - 1; x++) {
                size_t i = (size_t)y * W + x;
                /* an edge: a neighbour of another id */
                int edge = 0;
                for (int dy = -1; dy <= 1; dy++)
                    for (int dx = -1; dx <= 1; dx++) edge |= id[i + (size_t)(dy * W + dx)] != id[i];
                for (int c = 0; c < 3; c++) {
                    double lin = ch[c][i], enc = 255.0 * pow(fmin(fmax(lin, 0), 1), 1 / 2.2);
                    double d = fabs(enc - png[4 * i + (size_t)c]);
                    sum += d;
                    over1 = fmax(over1, lin);
                    if (!edge) worst_in = fmax(worst_in, d);
                }
                KT_CHECK(ch[3][i] == 1.0f, "A is 1");
            }
        double mean = sum / (3.0 * (W - 2) * (H - 2));
        printf("  beauty: encoded EXR - PNG <= %.3f/255 off edges, mean %.3f/255 everywhere; brightest %.3f\n",
               worst_in, mean, over1);
        /* the PNG's own rounding (0.5), half's (under 0.06 of a level) and,
         * where two triangles of the sphere share a pixel, the resolve
         * averaging their samples in linear light rather than encoded
         * (measured 0.68 in all) */
        KT_CHECK(worst_in <= 1.0, "off an edge the encoded EXR is %.3f/255 from the PNG", worst_in);
        KT_CHECK(mean <= 0.3, "mean difference %.3f/255", mean);
        kf_exr_image_free(&img);
    }
    free(png), free(plain);
    mesh_free(&s);
    kf_render_destroy(r);
}

/* weighted moments of |image - background| over a window: the blurred
 * picture is the still one convolved with the shutter's spread of
 * positions, so the means agree and the covariances add */
typedef struct moments {
    double w, mx, my, vxx, vyy, vxy;
} moments;

static moments measure(const uint8_t *img, int x0, int x1) {
    moments m = {0};
    for (int y = 0; y < H; y++)
        for (int x = x0; x < x1; x++) {
            const uint8_t *p = img + 4 * ((size_t)y * W + x);
            double w = p[0] + p[1] + p[2];
            m.w += w, m.mx += w * x, m.my += w * y;
        }
    m.mx /= m.w, m.my /= m.w;
    for (int y = 0; y < H; y++)
        for (int x = x0; x < x1; x++) {
            const uint8_t *p = img + 4 * ((size_t)y * W + x);
            double w = p[0] + p[1] + p[2], dx = x - m.mx, dy = y - m.my;
            m.vxx += w * dx * dx, m.vyy += w * dy * dy, m.vxy += w * dx * dy;
        }
    m.vxx /= m.w, m.vyy /= m.w, m.vxy /= m.w;
    return m;
}

/* a small square moving (1.5, 0.75, 0) m a frame at depth 6, shutter 0.5:
 * its picture is spread along its motion over 0.5 x the analytic screen
 * motion (20.6, 10.3 px, long against its 13.7 px so that the still
 * picture's 4-sample edges weigh little), its mean stays put and its light
 * is its analytic area's; the still square beside it is bit for bit what
 * it was */
static void test_motion_blur(void) {
    kf_render_ctx *r = ctx(4);
    if (!r) return;
    const float half = 0.25f, c0[3] = {-1.2f, 0, -1}, c1[3] = {1.6f, 0.2f, -1}, m[3] = {1.5f, 0.75f, 0};
    mesh a = square(c0, half);
    give_motion(&a, m);
    pair two;
    pair_init(&two, a, square(c1, half), 1, 2, 0.8f);
    uint8_t *still = malloc((size_t)W * H * 4), *blur = malloc((size_t)W * H * 4);
    char err[512];
    kf_render_aovs aov;
    memset(&aov, 0, sizeof aov);
    const float shutter = 0.5f;
    KT_CHECK(kf_render_frame(r, &two.sc, &two.cam, still, err, sizeof err) == 0, "still: %s", err);
    KT_CHECK(kf_render_frame_ex(r, &two.sc, &two.cam, NULL, shutter, blur, &aov, err, sizeof err) == 0, "blur: %s",
             err);
    kf_png_write("exr_test_out/blur_still.png", still, W, H, NULL, 0, err, sizeof err);
    kf_png_write("exr_test_out/blur.png", blur, W, H, NULL, 0, err, sizeof err);
    const int n = aov.blur_samples;
    /* the screen motion over the shutter (rows grow downwards), and the
     * variance of n evenly spaced positions over it: k L^2 */
    double f = focal_px(FOV), Lx = shutter * f * m[0] / (DIST + 1), Ly = -shutter * f * m[1] / (DIST + 1);
    double k = (double)(n * n - 1) / (12.0 * n * n);
    moments mb = measure(blur, 0, W / 2 + 10);
    /* the still square, analytically: its centre (pixel centres at
     * half-integers), its variance side^2 / 12 along each axis plus a
     * pixel's own footprint (1/12; the 4-sample pattern gives 0.078), no
     * covariance; the light, its area times its interior value. The
     * rendered still picture is not the reference: its 4-sample edges put
     * its variance 0.5 px^2 and its mean 0.1 px off these. */
    double side = 2 * half * f / (DIST + 1), var0 = side * side / 12 + 1.0 / 12;
    double cx = 0.5 * W + f * c0[0] / (DIST + 1) - 0.5, cy = 0.5 * H - f * c0[1] / (DIST + 1) - 0.5;
    const uint8_t *mid = still + 4 * ((size_t)(H / 2) * W + (size_t)(cx + 0.5));
    double light = side * side * (mid[0] + mid[1] + mid[2]);
    double dxx = mb.vxx - var0, dyy = mb.vyy - var0, dxy = mb.vxy;
    printf("  blur: %d renders; smear (%.2f, %.2f) px analytic; variance added xx %.3f (%.3f) yy %.3f (%.3f) "
           "xy %.3f (%.3f); mean (%.3f, %.3f) px from the still centre; light %.4f of the analytic\n",
           n, Lx, Ly, dxx, k * Lx * Lx, dyy, k * Ly * Ly, dxy, k * Lx * Ly, mb.mx - cx, mb.my - cy, mb.w / light);
    KT_CHECK(n == (int)ceil(hypot(Lx, Ly)), "renders: one a pixel of smear (%d for %.2f px)", n, hypot(Lx, Ly));
    /* the smear's length along x and y from the added variance (measured within 0.3 %) */
    KT_NEAR(sqrt(fmax(dxx, 0) / k), fabs(Lx), 0.015 * fabs(Lx), "smear along x, px");
    KT_NEAR(sqrt(fmax(dyy, 0) / k), fabs(Ly), 0.015 * fabs(Ly), "smear along y, px");
    /* along the motion: the added covariance has the motion's sign and is the product */
    KT_NEAR(dxy / k, Lx * Ly, 0.03 * fabs(Lx * Ly), "smear direction (covariance / k), px^2");
    KT_NEAR(mb.mx - cx, 0, 0.05, "mean x unmoved (shutter centred on the frame), px");
    KT_NEAR(mb.my - cy, 0, 0.05, "mean y unmoved, px");
    KT_NEAR(mb.w / light, 1, 0.01, "the light is spread, not lost");
    /* the still square's window: bit for bit */
    int changed = 0;
    for (int y = 0; y < H; y++)
        for (int x = W / 2 + 20; x < W; x++)
            changed += memcmp(still + 4 * ((size_t)y * W + x), blur + 4 * ((size_t)y * W + x), 4) != 0;
    KT_CHECK(changed == 0, "%d pixels of the still square changed", changed);
    /* no shutter, no blur: the same bytes */
    KT_CHECK(kf_render_frame_ex(r, &two.sc, &two.cam, NULL, 0, blur, NULL, err, sizeof err) == 0, "shutter 0: %s", err);
    KT_CHECK(memcmp(still, blur, (size_t)W * H * 4) == 0, "shutter 0 is the still picture");
    free(still), free(blur);
    pair_free(&two);
    kf_render_destroy(r);
}

/* ---- the pipeline ------------------------------------------------------------ */

/* A ball of particles all moving at (1.2, 0.6, 0) m/s: surfaced to a .vdb
 * with its velocity grid, rendered by the shot pipeline to EXR and PNG.
 * Every pixel of the ball moves f m / Z pixels a frame (m = v / fps, Z the
 * pixel's depth), which is what forward.u/v read; the two files agree. */
static void test_pipeline(void) {
    kf_diag d;
    kf_shot *shot =
        shot_from("exr_test_out/ball.yaml", &d,
                  "frames: {start: 1001, end: 1002, fps: 24}\n"
                  "materials: {m: {preset: water}}\n"
                  "objects: [{name: ball, shape: sphere, center: [0.5, 0.5, 0.5], radius: 0.2, material: m}]\n"
                  "colliders: [{name: slab, shape: box, size: [0.1, 0.1, 0.1], center: [0.1, 0.3, 0.5],\n"
                  "             velocity: [0.6, -0.3, 0]}]\n"
                  "render: {width: %d, height: %d, eye: [0.5, 0.5, 2.5], target: [0.5, 0.5, 0.5], fov: %g,\n"
                  "         format: both, ground: false}\n",
                  W, H, (double)FOV);
    kf_diag_free(&d);
    if (!shot) return;
    KT_CHECK(shot->render_format == KF_FORMAT_BOTH, "render.format: both");
    /* the particles: a lattice inside the ball, one velocity */
    const double sp = 0.01, v0[3] = {1.2, 0.6, 0};
    size_t n = 0;
    float *x = malloc(sizeof(float) * 3 * 40000), *v = malloc(sizeof(float) * 3 * 40000);
    for (double px = 0.3; px <= 0.7; px += sp)
        for (double py = 0.3; py <= 0.7; py += sp)
            for (double pz = 0.3; pz <= 0.7; pz += sp)
                if ((px - 0.5) * (px - 0.5) + (py - 0.5) * (py - 0.5) + (pz - 0.5) * (pz - 0.5) <= 0.2 * 0.2 &&
                    n < 40000) {
                    x[3 * n] = (float)px, x[3 * n + 1] = (float)py, x[3 * n + 2] = (float)pz;
                    for (int a = 0; a < 3; a++) v[3 * n + a] = (float)v0[a];
                    n++;
                }
    kf_vdb_surface_params p;
    kf_vdb_surface_params_default(&p);
    p.spacing = sp;
    kf_vdb_grid *g = NULL;
    char err[4200];
    int rc = kf_vdb_levelset_from_particles(n, NULL, x, NULL, v, &p, &g, NULL, err, sizeof err);
    KT_CHECK(rc == 0, "surface: %s", err);
    kf_vdb_meta meta;
    memset(&meta, 0, sizeof meta);
    meta.frame = 1001;
    mkdir("exr_test_out/surface", 0755);
    if (rc == 0) rc = kf_vdb_write("exr_test_out/surface/ball.1001.vdb", &g, 1, &meta, err, sizeof err);
    KT_CHECK(rc == 0, "vdb: %s", err);
    kf_vdb_free(g);
    free(x), free(v);
    float lo[3] = {0.3f, 0.3f, 0.3f}, hi[3] = {0.7f, 0.7f, 0.7f};
    kf_render_opts ro = kf_render_opts_for(shot, lo, hi);
    kf_scene sc;
    memset(&sc, 0, sizeof sc);
    if (rc == 0) {
        rc = kf_pipeline_render(shot, &sc, "exr_test_out/surface/ball.1001.vdb", "exr_test_out/images/ball.1001.png",
                                1001, &ro, err, sizeof err);
        KT_CHECK(rc == 0, "pipeline render: %s", err);
    }
    kf_exr_image img;
    if (rc == 0 && kf_exr_read("exr_test_out/images/ball.1001.exr", &img, err, sizeof err) == 0) {
        const float *u = kf_exr_channel_data(&img, "forward.u"), *vv = kf_exr_channel_data(&img, "forward.v"),
                    *Z = kf_exr_channel_data(&img, "Z"), *id = kf_exr_channel_data(&img, "id");
        KT_CHECK(kf_exr_channel_data(&img, "matte.m") != NULL, "a matte named after the material");
        double f = focal_px(FOV), m[2] = {v0[0] / 24.0, v0[1] / 24.0}, worst = 0;
        int npx = 0;
        for (size_t i = 0; i < (size_t)W * H; i++) {
            if (id[i] != 1.0f) continue;
            worst = fmax(worst, fmax(fabs(u[i] - f * m[0] / Z[i]), fabs(vv[i] - f * m[1] / Z[i])));
            npx++;
        }
        /* the collider: id 101 and its own motion, moved a frame's time by its velocity */
        double cworst = 0;
        int ncol = 0;
        for (size_t i = 0; i < (size_t)W * H; i++) {
            if (id[i] != 101.0f) continue;
            cworst = fmax(cworst, fmax(fabs(u[i] - f * 0.6 / 24 / Z[i]), fabs(vv[i] + f * 0.3 / 24 / Z[i])));
            ncol++;
        }
        printf("  pipeline: the moving collider, %d px, forward.u/v within %.2e px of f v / (fps Z)\n", ncol, cworst);
        /* its front face alone is (0.1 m x f / 2 m)^2 = 68 px */
        KT_CHECK(ncol >= 68, "collider seen (%d px)", ncol);
        KT_CHECK(cworst <= 8e-3, "collider motion off by %.3g px", cworst);
        KT_CHECK(kf_exr_channel_data(&img, "matte.slab") != NULL, "a matte named after the collider");
        printf("  pipeline: %d px of the ball, forward.u/v within %.2e px of f v / (fps Z) = (%.3f, %.3f) px at "
               "the centre\n",
               npx, worst, f * m[0] / 1.8, f * m[1] / 1.8);
        /* the ball's disc: radius f tan(asin(0.2 / 2)) = 16.6 px, 861 px */
        KT_CHECK(npx > 800, "ball seen (%d px)", npx);
        /* the velocity grid is uniform, so the vectors are exact up to half
         * rounding (2^-9 at 2..4 px) and Z's (relative 5e-4) */
        KT_CHECK(worst <= 8e-3, "motion of the surfaced ball off by %.3g px", worst);
        /* the PNG beside it is byte for byte the one render.format: png makes */
        shot->render_format = KF_FORMAT_PNG;
        KT_CHECK(kf_pipeline_render(shot, &sc, "exr_test_out/surface/ball.1001.vdb",
                                    "exr_test_out/images/ball_png.1001.png", 1001, &ro, err, sizeof err) == 0,
                 "png render: %s", err);
        FILE *fa = fopen("exr_test_out/images/ball.1001.png", "rb"),
             *fb = fopen("exr_test_out/images/ball_png.1001.png", "rb");
        static char ba[1 << 20], bb[1 << 20];
        size_t na = fa ? fread(ba, 1, sizeof ba, fa) : 0, nb = fb ? fread(bb, 1, sizeof bb, fb) : 1;
        if (fa) fclose(fa);
        if (fb) fclose(fb);
        KT_CHECK(na > 0 && na == nb && memcmp(ba, bb, na) == 0, "format both's PNG is format png's (%zu, %zu bytes)",
                 na, nb);
        kf_exr_image_free(&img);
    } else KT_CHECK(0, "EXR read: %s", err);
    kf_shot_free(shot);
}

/* a kinematic rigid box keyed 0.24 m along x over 12 frames at 24 fps
 * (0.48 m/s, linear): at frame 1005 it reads id 201, its matte, and moves
 * f v / (fps Z) pixels a frame (the pose from its keys, no checkpoint) */
static void test_rigid_motion(void) {
    kf_diag d;
    kf_shot *shot = shot_from(
        "exr_test_out/rigid.yaml", &d,
        "frames: {start: 1001, end: 1013, fps: 24}\n"
        "sim: {dx: 0.05}\n"
        "materials: {m: {preset: water}}\n"
        "objects: [{name: ball, shape: sphere, center: [0.5, 0.5, 0.5], radius: 0.2, material: m}]\n"
        "rigids: [{name: crate, shape: box, size: [0.1, 0.1, 0.1], center: [0.1, 0.75, 0.5], motion: kinematic,\n"
        "          keys: [{frame: 1001}, {frame: 1013, translate: [0.24, 0, 0]}]}]\n"
        "render: {width: %d, height: %d, eye: [0.5, 0.5, 2.5], target: [0.5, 0.5, 0.5], fov: %g,\n"
        "         format: exr, ground: false}\n",
        W, H, (double)FOV);
    if (!shot) {
        kf_diag_free(&d);
        return;
    }
    kf_scene sc;
    memset(&sc, 0, sizeof sc);
    int rc = kf_scene_from_shot(shot, 1, &sc, NULL, &d);
    KT_CHECK(rc == 0, "scene builds");
    float lo[3] = {0.3f, 0.3f, 0.3f}, hi[3] = {0.7f, 0.7f, 0.7f};
    kf_render_opts ro = kf_render_opts_for(shot, lo, hi);
    char err[4200];
    /* the ball's surface test_pipeline wrote (it runs first) stands in for frame 1005's */
    if (rc == 0) {
        rc = kf_pipeline_render(shot, &sc, "exr_test_out/surface/ball.1001.vdb", "exr_test_out/images/crate.1005.png",
                                1005, &ro, err, sizeof err);
        KT_CHECK(rc == 0, "pipeline render: %s", err);
    }
    kf_exr_image img;
    if (rc == 0 && kf_exr_read("exr_test_out/images/crate.1005.exr", &img, err, sizeof err) == 0) {
        const float *u = kf_exr_channel_data(&img, "forward.u"), *vv = kf_exr_channel_data(&img, "forward.v"),
                    *Z = kf_exr_channel_data(&img, "Z"), *id = kf_exr_channel_data(&img, "id");
        double f = focal_px(FOV), worst = 0;
        int n = 0;
        for (size_t i = 0; i < (size_t)W * H; i++) {
            if (id[i] != 201.0f) continue;
            worst = fmax(worst, fmax(fabs(u[i] - f * 0.48 / 24 / Z[i]), fabs(vv[i])));
            n++;
        }
        printf("  rigid: the keyed crate, %d px, forward.u/v within %.2e px of f v / (fps Z)\n", n, worst);
        /* its front face alone is (0.1 m x f / 2 m)^2 = 68 px */
        KT_CHECK(n >= 68, "crate seen (%d px)", n);
        KT_CHECK(worst <= 8e-3, "rigid body motion off by %.3g px", worst);
        KT_CHECK(kf_exr_channel_data(&img, "matte.crate") != NULL, "a matte named after the body");
        KT_CHECK(access("exr_test_out/images/crate.1005.png", F_OK) != 0, "render.format: exr writes no PNG");
        kf_exr_image_free(&img);
    } else KT_CHECK(0, "EXR read: %s", err);
    kf_scene_free(&sc);
    kf_diag_free(&d);
    kf_shot_free(shot);
}

/* the cost of writing one 1280x720 frame's EXR (every channel, two mattes) */
static void test_write_cost(void) {
    enum { BW = 1280, BH = 720 };
    kf_pipeline_aovs pa;
    kf_render_mesh rm[2];
    memset(rm, 0, sizeof rm);
    rm[0].id = 1, rm[1].id = 2;
    const char *names[2] = {"water", "sand"};
    if (kf_pipeline_aovs_alloc(&pa, rm, names, 2, (size_t)BW * BH) != 0) return;
    /* a smooth picture, like a render: gradients compress like one */
    for (size_t i = 0; i < (size_t)BW * BH; i++) {
        float t = (float)(i % BW) / BW, s = (float)(i / BW) / BH;
        for (int c = 0; c < 4; c++) pa.aov.rgba[4 * i + (size_t)c] = 0.2f + 0.5f * t * s + 0.1f * (float)c;
        pa.aov.z[i] = 4 + t;
        for (int c = 0; c < 3; c++) pa.aov.normal[3 * i + (size_t)c] = c == 2 ? 1 - t : t;
        pa.aov.id[i] = t < 0.5f ? 1 : 2;
        pa.aov.motion[2 * i] = 3 * s, pa.aov.motion[2 * i + 1] = -t;
        pa.aov.matte[i] = t < 0.5f, pa.aov.matte[(size_t)BW * BH + i] = t >= 0.5f;
    }
    char err[512];
    /* wall time, and the thread's CPU time (what a shared machine inflates least) */
    double best = 1e30, best_cpu = 1e30;
    for (int k = 0; k < 3; k++) {
        struct timespec a, b, ca, cb;
        clock_gettime(CLOCK_MONOTONIC, &a);
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ca);
        int rc = kf_pipeline_aovs_write(&pa, "exr_test_out/cost.exr", BW, BH, NULL, 0, err, sizeof err);
        clock_gettime(CLOCK_THREAD_CPUTIME_ID, &cb);
        clock_gettime(CLOCK_MONOTONIC, &b);
        KT_CHECK(rc == 0, "write: %s", err);
        best = fmin(best, (b.tv_sec - a.tv_sec) * 1e3 + (b.tv_nsec - a.tv_nsec) / 1e6);
        best_cpu = fmin(best_cpu, (cb.tv_sec - ca.tv_sec) * 1e3 + (cb.tv_nsec - ca.tv_nsec) / 1e6);
    }
    struct stat st;
    stat("exr_test_out/cost.exr", &st);
    printf("  cost: 1280x720, 13 half channels, zip: %.1f ms to write (best of 3; %.1f ms of CPU), %.2f MB\n", best,
           best_cpu, st.st_size / 1e6);
    kf_pipeline_aovs_free(&pa);
}

/* a write into a missing directory says so, and leaves nothing behind */
static void test_write_errors(void) {
    /* a file cut short is not whole; the file it was cut from is */
    KT_CHECK(kf_exr_complete("exr_test_out/channels.exr"), "a written file is whole");
    FILE *in = fopen("exr_test_out/channels.exr", "rb"), *out = fopen("exr_test_out/cut.exr", "wb");
    char buf[4096];
    size_t got = in ? fread(buf, 1, sizeof buf, in) : 0;
    if (out) fwrite(buf, 1, got > 0 ? got - 1 : 0, out), fclose(out);
    if (in) fclose(in);
    KT_CHECK(!kf_exr_complete("exr_test_out/cut.exr"), "the first 4 kB less a byte is not whole");
    KT_CHECK(!kf_exr_complete("exr_test_out/no_such.exr"), "a missing file is not whole");
    float px[4] = {0};
    kf_exr_channel ch[1] = {{"R", px, 1}};
    char err[512];
    int rc = kf_exr_write("exr_test_out/no/such/dir/x.exr", 2, 2, ch, 1, NULL, 0, NULL, NULL, err, sizeof err);
    KT_CHECK(rc == -1 && strstr(err, "exr_test_out/no/such/dir/x.exr: cannot write"), "message: %s", err);
    kf_exr_image img;
    KT_CHECK(kf_exr_read("exr_test_out/ball.yaml", &img, err, sizeof err) == -1 && strstr(err, "not a readable"),
             "a YAML file is not an EXR: %s", err);
}

int main(int argc, char **argv) {
    mkdir("exr_test_out", 0755);
    KT_RUN(test_channels, argc, argv);
    KT_RUN(test_depth_and_normals, argc, argv);
    KT_RUN(test_ids_and_mattes, argc, argv);
    KT_RUN(test_motion_vectors, argc, argv);
    KT_RUN(test_camera_motion, argc, argv);
    KT_RUN(test_beauty_matches_png, argc, argv);
    KT_RUN(test_motion_blur, argc, argv);
    KT_RUN(test_pipeline, argc, argv);
    KT_RUN(test_rigid_motion, argc, argv);
    KT_RUN(test_write_cost, argc, argv);
    KT_RUN(test_write_errors, argc, argv);
    return KT_EXIT();
}
