/* test_render.c — the headless renderer: silhouettes, orientation, a golden
 * image, PNG round trips, turntable loops and error messages.
 *
 * Images the cases draw are written to ./render_test_out/ (the ctest working
 * directory is the build tree) so a person can look at them. Set
 * KERF_UPDATE_GOLDEN=1 to rewrite tests/render_golden/ from this machine. */
#include <dirent.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include <kerf/kerf.h>
#include "kt.h"
#include "render.h"

/* ---- meshes made here ----------------------------------------------------- */

typedef struct test_mesh {
    float *pos, *nrm;
    uint32_t *tri;
    size_t nv, nt;
} test_mesh;

static void test_mesh_free(test_mesh *m) {
    free(m->pos);
    free(m->nrm);
    free(m->tri);
}

/* axis-aligned cube, centre c, half-size s; 8 shared vertices, CCW outward, no normals */
static test_mesh make_cube(const float c[3], float s) {
    test_mesh m = {malloc(8 * 12), NULL, malloc(36 * 4), 8, 12};
    for (int i = 0; i < 8; i++) {
        m.pos[3 * i + 0] = c[0] + ((i & 1) ? s : -s);
        m.pos[3 * i + 1] = c[1] + ((i & 2) ? s : -s);
        m.pos[3 * i + 2] = c[2] + ((i & 4) ? s : -s);
    }
    static const uint32_t t[36] = {0, 2, 1, 1, 2, 3, 4, 5, 6, 5, 7, 6,  /* -z, +z */
                                   0, 1, 4, 1, 5, 4, 2, 6, 3, 3, 6, 7,  /* -y, +y */
                                   0, 4, 2, 2, 4, 6, 1, 3, 5, 3, 7, 5}; /* -x, +x */
    memcpy(m.tri, t, sizeof t);
    return m;
}

/* octahedron, centre c, radius s, no normals */
static test_mesh make_octahedron(const float c[3], float s) {
    test_mesh m = {malloc(6 * 12), NULL, malloc(24 * 4), 6, 8};
    static const float v[18] = {1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1};
    for (int i = 0; i < 18; i++) m.pos[i] = c[i % 3] + s * v[i];
    static const uint32_t t[24] = {0, 2, 4, 4, 2, 1, 1, 2, 5, 5, 2, 0, 4, 3, 0, 1, 3, 4, 5, 3, 1, 0, 3, 5};
    memcpy(m.tri, t, sizeof t);
    return m;
}

/* UV sphere with normals: 2*stacks*slices triangles (minus the poles' degenerate ones kept) */
static test_mesh make_sphere(const float c[3], float rad, int stacks, int slices) {
    test_mesh m;
    m.nv = (size_t)(stacks + 1) * (slices + 1);
    m.nt = (size_t)2 * stacks * slices;
    m.pos = malloc(m.nv * 12);
    m.nrm = malloc(m.nv * 12);
    m.tri = malloc(m.nt * 12);
    size_t k = 0;
    for (int i = 0; i <= stacks; i++) {
        double th = 3.14159265358979 * i / stacks;
        for (int j = 0; j <= slices; j++, k++) {
            double ph = 2 * 3.14159265358979 * j / slices;
            float n[3] = {(float)(sin(th) * cos(ph)), (float)cos(th), (float)(sin(th) * sin(ph))};
            for (int a = 0; a < 3; a++) m.nrm[3 * k + a] = n[a], m.pos[3 * k + a] = c[a] + rad * n[a];
        }
    }
    k = 0;
    for (int i = 0; i < stacks; i++)
        for (int j = 0; j < slices; j++) {
            uint32_t a = (uint32_t)(i * (slices + 1) + j), b = a + (uint32_t)slices + 1;
            uint32_t t[6] = {a, a + 1, b, a + 1, b + 1, b};
            memcpy(m.tri + k, t, sizeof t);
            k += 6;
        }
    return m;
}

static kf_render_mesh as_render(const test_mesh *m, float r, float g, float b, float spec, float rough) {
    kf_render_mesh rm = {m->pos, m->nrm, m->nv, m->tri, m->nt, {{r, g, b}, spec, rough}, NULL, 0, 0};
    return rm;
}

/* ---- helpers --------------------------------------------------------------- */

static const char *out_dir(void) {
    mkdir("render_test_out", 0755);
    return "render_test_out";
}

static void save(const char *name, const uint8_t *img, int w, int h) {
    char path[512], err[256];
    snprintf(path, sizeof path, "%s/%s", out_dir(), name);
    if (kf_png_write(path, img, w, h, NULL, 0, err, sizeof err) != 0)
        fprintf(stderr, "note: could not save %s: %s\n", path, err);
}

static double mean_abs_diff(const uint8_t *a, const uint8_t *b, size_t n) {
    double s = 0;
    for (size_t i = 0; i < n; i++) s += abs((int)a[i] - (int)b[i]);
    return s / (double)n;
}

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

/* the directory of this source file, for tests/render_golden/ */
static void golden_path(char *buf, size_t n, const char *name) {
    const char *f = __FILE__, *slash = strrchr(f, '/');
    int len = slash ? (int)(slash - f) : 1;
    snprintf(buf, n, "%.*s/render_golden/%s", len, slash ? f : ".", name);
}

/* the two-object scene shared by the golden and turntable cases */
typedef struct two_objects {
    test_mesh cube, octa;
    kf_render_mesh meshes[2];
    kf_render_scene sc;
} two_objects;

static void two_objects_init(two_objects *t) {
    float cc[3] = {-0.35f, 0.3f, 0.0f}, oc[3] = {0.45f, 0.35f, 0.15f};
    t->cube = make_cube(cc, 0.3f);
    t->octa = make_octahedron(oc, 0.35f);
    t->meshes[0] = as_render(&t->cube, 0.85f, 0.45f, 0.25f, 0.3f, 0.4f);
    t->meshes[1] = as_render(&t->octa, 0.3f, 0.55f, 0.85f, 0.5f, 0.25f);
    t->sc = kf_render_scene_default();
    t->sc.meshes = t->meshes;
    t->sc.nmeshes = 2;
}
static void two_objects_free(two_objects *t) {
    test_mesh_free(&t->cube);
    test_mesh_free(&t->octa);
}

/* ---- cases ----------------------------------------------------------------- */

/* A cube in the upper half of the frame seen head-on: inside its projected
 * square the pixels are lit geometry, outside they are the exact background
 * gradient, and it appears in the top half (rows are top-down). */
static void test_silhouette_and_upright(void) {
    const int W = 160, H = 120;
    char err[256] = "";
    kf_render_ctx *r = kf_render_create(W, H, 4, err, sizeof err);
    KT_CHECK(r != NULL, "%s", err);
    if (!r) return;
    float c[3] = {0, 0.6f, 0}, lo[3], hi[3];
    test_mesh cube = make_cube(c, 0.3f);
    kf_render_mesh m = as_render(&cube, 0.8f, 0.8f, 0.8f, 0.2f, 0.5f);
    kf_render_scene sc = kf_render_scene_default();
    sc.meshes = &m;
    sc.nmeshes = 1;
    sc.ground = 0;
    KT_CHECK(kf_render_scene_bounds(&sc, lo, hi) == 0, "bounds of one cube");
    KT_NEAR(lo[1], 0.3, 1e-6, "cube bottom at 0.6 - 0.3");
    kf_camera cam = {{0, 0, 5}, {0, 0, 0}, {0, 1, 0}, 40, 0, 0};
    uint8_t *img = malloc((size_t)W * H * 4);
    int rc = kf_render_frame(r, &sc, &cam, img, err, sizeof err);
    KT_CHECK(rc == 0, "%s", err);
    save("silhouette.png", img, W, H);

    /* the front face (z = 0.3, 4.7 from the eye) projects to ndc y in
     * [0.3, 0.9]/(4.7 tan 20deg) = [0.175, 0.526], x in +-0.175/aspect */
    double t = tan(20 * 3.14159265358979 / 180), zf = 4.7;
    double y_top = (1 - 0.9 / (zf * t)) / 2 * H, y_bot = (1 - 0.3 / (zf * t)) / 2 * H;
    double x_half = 0.3 / (zf * t) / ((double)W / H) / 2 * W;
    KT_CHECK(y_bot < H / 2.0, "the cube sits in the top half: rows %.1f..%.1f of %d", y_top, y_bot, H);
    int inside = 0, inside_n = 0, outside = 0, outside_n = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const uint8_t *p = img + ((size_t)y * W + x) * 4;
            double fy = y + 0.5, fx = x + 0.5 - W / 2.0;
            /* expected background at this row (the gradient is linear in rows) */
            double tt = 1.0 - fy / H;
            int bg[3];
            for (int k = 0; k < 3; k++)
                bg[k] = (int)lround(255 * (sc.bg_bottom[k] + (sc.bg_top[k] - sc.bg_bottom[k]) * tt));
            int is_bg = abs(p[0] - bg[0]) <= 2 && abs(p[1] - bg[1]) <= 2 && abs(p[2] - bg[2]) <= 2;
            /* 3 pixels of margin from the projected edges: anti-aliasing and the
             * side faces seen in perspective stay out of the test */
            if (fy > y_top + 3 && fy < y_bot - 3 && fabs(fx) < x_half - 3) {
                inside_n++;
                int lum = (p[0] + p[1] + p[2]) / 3;
                if (!is_bg && lum > 60) inside++;
            } else if (fy < y_top - 8 || fy > y_bot + 8 || fabs(fx) > x_half + 8) {
                /* 8 pixels: beyond the top and side faces seen in perspective */
                outside_n++;
                if (is_bg) outside++;
            }
        }
    KT_CHECK(inside_n > 100 && inside == inside_n, "lit pixels inside the silhouette: %d of %d", inside, inside_n);
    KT_CHECK(outside_n > 1000 && outside == outside_n, "background outside: %d of %d", outside, outside_n);
    /* upright: all geometry in the top half */
    int top = 0, bottom = 0;
    for (int y = 0; y < H; y++)
        for (int x = 0; x < W; x++) {
            const uint8_t *p = img + ((size_t)y * W + x) * 4;
            double tt = 1.0 - (y + 0.5) / H;
            int g = (int)lround(255 * (sc.bg_bottom[1] + (sc.bg_top[1] - sc.bg_bottom[1]) * tt));
            if (abs(p[1] - g) > 3) {
                if (y < H / 2) top++;
                else bottom++;
            }
        }
    KT_CHECK(top > 500 && bottom == 0, "object pixels top %d, bottom %d (image upright)", top, bottom);
    free(img);
    test_mesh_free(&cube);
    kf_render_destroy(r);
}

/* The largest per-tile mean |difference| (of 255) over tile x tile squares
 * and the three colour channels; the tile holding it in *tx, *ty. */
static double max_tile_diff(const uint8_t *a, const uint8_t *b, int W, int H, int tile, int *tx, int *ty) {
    double worst = 0;
    for (int y0 = 0; y0 < H; y0 += tile)
        for (int x0 = 0; x0 < W; x0 += tile) {
            double s = 0;
            int n = 0;
            for (int y = y0; y < y0 + tile && y < H; y++)
                for (int x = x0; x < x0 + tile && x < W; x++, n++)
                    for (int ch = 0; ch < 3; ch++)
                        s += abs((int)a[4 * (y * W + x) + ch] - (int)b[4 * (y * W + x) + ch]);
            s /= 3.0 * n;
            if (s > worst) worst = s, *tx = x0 / tile, *ty = y0 / tile;
        }
    return worst;
}

/* A 64x48 image of two objects on the ground against tests/render_golden/.
 * Tolerance: mean absolute difference <= 1.0 (of 255) per channel. llvmpipe
 * is deterministic on one machine, but another CPU (AVX2 vs AVX-512 code
 * paths) or Mesa release may round a few edge samples or shadow-map texels
 * differently; that is well below 1.0 on average, while (measured on this
 * golden) shifting the image by one pixel gives 1.6-2.2 and brightening it by
 * 2% gives 2.5-2.7, both caught.
 * The whole-image mean misses local changes: rendering without shadows moves
 * it by only 1.7 (of 255). So each 8x8 tile is compared too: its mean
 * |difference| over the three channels must stay within 6 (measured here: 0;
 * a tile with a few edge pixels rounded differently elsewhere stays far below
 * 6). Measured on this golden, the largest tile moves 26.3 without shadows,
 * 17.7 when shifted a pixel, 3.0 when 2% brighter (the mean catches that). */
#define GOLDEN_TILE_TOL 6.0
static void test_golden(void) {
    const int W = 64, H = 48;
    char err[256] = "", path[1024];
    kf_render_ctx *r = kf_render_create(W, H, 4, err, sizeof err);
    KT_CHECK(r != NULL, "%s", err);
    if (!r) return;
    two_objects t;
    two_objects_init(&t);
    float lo[3], hi[3], dir[3] = {-0.4f, -0.35f, -1};
    kf_render_scene_bounds(&t.sc, lo, hi);
    kf_camera cam = kf_camera_frame_bounds(lo, hi, dir, 35);
    uint8_t *img = malloc((size_t)W * H * 4);
    KT_CHECK(kf_render_frame(r, &t.sc, &cam, img, err, sizeof err) == 0, "%s", err);
    save("golden_actual.png", img, W, H);
    golden_path(path, sizeof path, "two_objects_64x48.png");
    const char *upd = getenv("KERF_UPDATE_GOLDEN");
    if (upd && *upd == '1') {
        const char *kv[] = {"Software", "kerf " KERF_VERSION, "Comment", "test_render golden"};
        KT_CHECK(kf_png_write(path, img, W, H, kv, 2, err, sizeof err) == 0, "%s", err);
        printf("  golden rewritten: %s\n", path);
    }
    uint8_t *gold = NULL;
    int gw = 0, gh = 0;
    int rc = kf_png_read(path, &gold, &gw, &gh, NULL, NULL, err, sizeof err);
    KT_CHECK(rc == 0, "%s (KERF_UPDATE_GOLDEN=1 creates it)", err);
    if (rc == 0) {
        KT_CHECK(gw == W && gh == H, "golden is %dx%d", gw, gh);
        if (gw == W && gh == H) {
            for (int ch = 0; ch < 3; ch++) {
                double s = 0;
                for (int i = 0; i < W * H; i++) s += abs((int)img[4 * i + ch] - (int)gold[4 * i + ch]);
                KT_NEAR(s / (W * H), 0.0, 1.0, "per-channel mean |diff| vs golden (see comment)");
            }
            /* per 8x8 tile: a local change (a shadow, a missing object) is not
             * averaged away over the whole image */
            int tx = 0, ty = 0;
            double worst = max_tile_diff(img, gold, W, H, 8, &tx, &ty);
            printf("  largest 8x8 tile mean |diff| vs golden: %.3f (tile %d,%d)\n", worst, tx, ty);
            KT_NEAR(worst, 0.0, GOLDEN_TILE_TOL, "per-tile mean |diff| vs golden (see comment)");
            /* the check is not blind: the same scene without shadows fails it */
            t.sc.shadows = 0;
            uint8_t *alt = malloc((size_t)W * H * 4);
            KT_CHECK(kf_render_frame(r, &t.sc, &cam, alt, err, sizeof err) == 0, "%s", err);
            t.sc.shadows = 1;
            double noshadow = max_tile_diff(alt, gold, W, H, 8, &tx, &ty), mean = 0;
            for (int i = 0; i < W * H; i++)
                for (int ch = 0; ch < 3; ch++) mean += abs((int)alt[4 * i + ch] - (int)gold[4 * i + ch]);
            mean /= 3.0 * W * H;
            printf("  without shadows: largest tile %.3f (tile %d,%d), whole-image mean %.3f\n", noshadow, tx, ty,
                   mean);
            KT_CHECK(noshadow > 2 * GOLDEN_TILE_TOL,
                     "removing the shadows must fail the tile check by a margin "
                     "(largest tile %.3f, tolerance %.1f; measured 26.3)",
                     noshadow, GOLDEN_TILE_TOL);
            free(alt);
        }
    }
    free(gold);
    free(img);
    two_objects_free(&t);
    kf_render_destroy(r);
}

/* PNG written with text chunks reads back identical, with every chunk, and
 * leaves no temporary file behind. */
static void test_png_round_trip(void) {
    char dir[] = "/tmp/kf_png_XXXXXX", path[256], err[256] = "";
    KT_CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    snprintf(path, sizeof path, "%s/frame.1001.png", dir);
    const int W = 37, H = 23; /* odd sizes: no row padding assumptions */
    uint8_t *img = malloc((size_t)W * H * 4);
    for (int i = 0; i < W * H * 4; i++) img[i] = (uint8_t)(i * 7 + (i / (W * 4)) * 13);
    const char *kv[] = {"shot",     "bunny_split",        "frame",   "1001",
                        "Software", "kerf " KERF_VERSION, "Comment", "caf\xc3\xa9 cr\xc3\xa8me"}; /* UTF-8 -> iTXt */
    KT_CHECK(kf_png_write(path, img, W, H, kv, 4, err, sizeof err) == 0, "%s", err);
    /* overwrite: the second write replaces the first atomically */
    KT_CHECK(kf_png_write(path, img, W, H, kv, 4, err, sizeof err) == 0, "%s", err);
    uint8_t *back = NULL;
    int w = 0, h = 0, nt = 0;
    char **tx = NULL;
    KT_CHECK(kf_png_read(path, &back, &w, &h, &tx, &nt, err, sizeof err) == 0, "%s", err);
    KT_CHECK(w == W && h == H, "size %dx%d", w, h);
    KT_CHECK(back && w == W && h == H && memcmp(back, img, (size_t)W * H * 4) == 0,
             "pixels identical (PNG is lossless)");
    KT_CHECK(nt == 4, "4 text chunks, got %d", nt);
    for (int i = 0; i < 4; i++) {
        int found = 0;
        for (int j = 0; j < nt; j++)
            if (strcmp(tx[2 * j], kv[2 * i]) == 0 && strcmp(tx[2 * j + 1], kv[2 * i + 1]) == 0) found = 1;
        KT_CHECK(found, "text chunk %s=%s read back", kv[2 * i], kv[2 * i + 1]);
    }
    kf_png_free_texts(tx, nt);
    free(back);
    /* nothing but the frame in the directory */
    int files = 0;
    DIR *d = opendir(dir);
    for (struct dirent *e; d && (e = readdir(d));)
        if (e->d_name[0] != '.') files++;
    if (d) closedir(d);
    KT_CHECK(files == 1, "%d files in %s (a temporary was left behind?)", files, dir);
    unlink(path);
    rmdir(dir);
    free(img);
}

/* Turntable of N frames, end exclusive: frame N is frame 0 bit for bit, and the
 * half-turn frame N/2 looks different. */
static void test_turntable_loop(void) {
    const int W = 96, H = 72, N = 8;
    char err[256] = "";
    kf_render_ctx *r = kf_render_create(W, H, 4, err, sizeof err);
    KT_CHECK(r != NULL, "%s", err);
    if (!r) return;
    two_objects t;
    two_objects_init(&t);
    float lo[3], hi[3];
    kf_render_scene_bounds(&t.sc, lo, hi);
    kf_camera c0 = kf_camera_turntable(lo, hi, 0, N, 20, 35);
    kf_camera cN = kf_camera_turntable(lo, hi, N, N, 20, 35);
    kf_camera cq = kf_camera_turntable(lo, hi, N / 4, N, 20, 35);
    KT_CHECK(memcmp(&c0, &cN, sizeof c0) == 0, "camera of frame N equals frame 0");
    /* a quarter turn: frame 0 looks from +Z, frame N/4 from +X */
    float ctr = 0.5f * (lo[0] + hi[0]);
    KT_CHECK(cq.eye[0] > ctr + 1 && fabsf(cq.eye[2] - 0.5f * (lo[2] + hi[2])) < 1e-4f,
             "frame N/4 eye at +X: (%g, %g, %g)", cq.eye[0], cq.eye[1], cq.eye[2]);
    size_t n = (size_t)W * H * 4;
    uint8_t *a = malloc(n), *b = malloc(n), *c = malloc(n);
    kf_camera ch = kf_camera_turntable(lo, hi, N / 2, N, 20, 35);
    KT_CHECK(kf_render_frame(r, &t.sc, &c0, a, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_render_frame(r, &t.sc, &ch, c, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_render_frame(r, &t.sc, &cN, b, err, sizeof err) == 0, "%s", err);
    KT_CHECK(memcmp(a, b, n) == 0, "frame N pixelwise identical to frame 0 (mean diff %.4f)", mean_abs_diff(a, b, n));
    double dh = mean_abs_diff(a, c, n);
    KT_CHECK(dh > 3.0, "half-turn frame differs from frame 0: mean |diff| %.2f", dh);
    save("turntable_0.png", a, W, H);
    save("turntable_half.png", c, W, H);
    free(a);
    free(b);
    free(c);
    two_objects_free(&t);
    kf_render_destroy(r);
}

/* Bad input becomes a message, never a crash or exit. */
static void test_errors(void) {
    char err[256] = "";
    KT_CHECK(kf_render_create(0, 48, 4, err, sizeof err) == NULL, "zero width refused");
    KT_CHECK(strstr(err, "0x48") != NULL, "message names the size: %s", err);
    err[0] = 0;
    KT_CHECK(kf_render_create(64, -3, 1, err, sizeof err) == NULL, "negative height refused");
    KT_CHECK(strstr(err, "size") != NULL, "message: %s", err);

    uint8_t px[4 * 4 * 4] = {0};
    err[0] = 0;
    KT_CHECK(kf_png_write("/nonexistent_kf_dir/x.png", px, 4, 4, NULL, 0, err, sizeof err) != 0,
             "unwritable path refused");
    KT_CHECK(strstr(err, "/nonexistent_kf_dir/x.png") && strstr(err, "No such file"),
             "message names the path and the reason: %s", err);
    err[0] = 0;
    KT_CHECK(kf_png_write("/tmp/kf_bad.png", px, 0, 4, NULL, 0, err, sizeof err) != 0, "zero-size image refused");
    KT_CHECK(strstr(err, "0x4") != NULL, "message: %s", err);
    const char *bad_kv[] = {"", "v"};
    err[0] = 0;
    KT_CHECK(kf_png_write("/tmp/kf_bad.png", px, 4, 4, bad_kv, 1, err, sizeof err) != 0, "empty text key refused");
    KT_CHECK(strstr(err, "keyword") != NULL, "message: %s", err);
    uint8_t *img = NULL;
    int w, h;
    err[0] = 0;
    KT_CHECK(kf_png_read(__FILE__, &img, &w, &h, NULL, NULL, err, sizeof err) != 0 && !img, "a C file is not a PNG");
    KT_CHECK(strstr(err, "not a PNG") != NULL, "message: %s", err);

    kf_render_ctx *r = kf_render_create(32, 24, 1, err, sizeof err);
    KT_CHECK(r != NULL, "%s", err);
    if (!r) return;
    float c[3] = {0, 0, 0};
    test_mesh cube = make_cube(c, 0.5f);
    cube.tri[5] = 8; /* one past the last vertex */
    kf_render_mesh m = as_render(&cube, 1, 1, 1, 0, 0.5f);
    kf_render_scene sc = kf_render_scene_default();
    sc.meshes = &m;
    sc.nmeshes = 1;
    kf_camera cam = {{0, 0, 4}, {0, 0, 0}, {0, 1, 0}, 40, 0, 0};
    uint8_t out[32 * 24 * 4];
    err[0] = 0;
    KT_CHECK(kf_render_frame(r, &sc, &cam, out, err, sizeof err) != 0, "bad index refused");
    KT_CHECK(strstr(err, "mesh 0 triangle 1 uses vertex 8") != NULL, "message: %s", err);
    cube.tri[5] = 3;
    kf_camera same = {{0, 0, 0}, {0, 0, 0}, {0, 1, 0}, 40, 0, 0};
    err[0] = 0;
    KT_CHECK(kf_render_frame(r, &sc, &same, out, err, sizeof err) != 0, "eye == target refused");
    KT_CHECK(strstr(err, "degenerate camera") != NULL, "message: %s", err);
    cam.fov_deg = 0;
    err[0] = 0;
    KT_CHECK(kf_render_frame(r, &sc, &cam, out, err, sizeof err) != 0, "fov 0 refused");
    KT_CHECK(strstr(err, "fov") != NULL, "message: %s", err);
    cam.fov_deg = 40;
    KT_CHECK(kf_render_frame(r, &sc, &cam, out, err, sizeof err) == 0, "fixed scene renders: %s", err);
    test_mesh_free(&cube);
    kf_render_destroy(r);
}

/* An artist-facing preview (smooth sphere, cube, octahedron on the ground)
 * saved for eyes, plus the throughput of ~1M triangles at 1920x1080, printed
 * not asserted. */
static void test_preview_and_timing(void) {
    char err[256] = "";
    {
        const int W = 480, H = 270;
        kf_render_ctx *r = kf_render_create(W, H, 4, err, sizeof err);
        KT_CHECK(r != NULL, "%s", err);
        if (!r) return;
        two_objects t;
        two_objects_init(&t);
        float sc_c[3] = {0.05f, 0.25f, -0.55f};
        test_mesh sph = make_sphere(sc_c, 0.25f, 48, 96);
        kf_render_mesh all[3] = {t.meshes[0], t.meshes[1], as_render(&sph, 0.9f, 0.88f, 0.82f, 0.6f, 0.2f)};
        t.sc.meshes = all;
        t.sc.nmeshes = 3;
        float lo[3], hi[3];
        kf_render_scene_bounds(&t.sc, lo, hi);
        kf_camera cam = kf_camera_turntable(lo, hi, 1, 16, 22, 30);
        uint8_t *img = malloc((size_t)W * H * 4);
        KT_CHECK(kf_render_frame(r, &t.sc, &cam, img, err, sizeof err) == 0, "%s", err);
        save("preview.png", img, W, H);
        printf("  renderer: %s, %d samples\n", kf_render_gl_renderer(r), kf_render_samples(r));
        free(img);
        test_mesh_free(&sph);
        two_objects_free(&t);
        kf_render_destroy(r);
    }
    {
        const int W = 1920, H = 1080;
        float c[3] = {0, 0.5f, 0};
        test_mesh sph = make_sphere(c, 0.5f, 500, 1000); /* 1,000,000 triangles */
        kf_render_mesh m = as_render(&sph, 0.8f, 0.7f, 0.6f, 0.4f, 0.3f);
        kf_render_scene sc = kf_render_scene_default();
        sc.meshes = &m;
        sc.nmeshes = 1;
        float lo[3], hi[3], dir[3] = {0, -0.3f, -1};
        kf_render_scene_bounds(&sc, lo, hi);
        kf_camera cam = kf_camera_frame_bounds(lo, hi, dir, 35);
        uint8_t *img = malloc((size_t)W * H * 4);
        for (int samples = 1; samples <= 4; samples += 3) {
            double t0 = now();
            kf_render_ctx *r = kf_render_create(W, H, samples, err, sizeof err);
            KT_CHECK(r != NULL, "%s", err);
            if (!r) break;
            double t1 = now();
            int ok = kf_render_frame(r, &sc, &cam, img, err, sizeof err) == 0;
            double t2 = now();
            ok = ok && kf_render_frame(r, &sc, &cam, img, err, sizeof err) == 0;
            double t3 = now();
            KT_CHECK(ok, "%s", err);
            printf("  1920x1080, %zu triangles, %d sample(s): create %.3f s, first frame %.3f s, "
                   "next frame %.3f s\n",
                   sph.nt, kf_render_samples(r), t1 - t0, t2 - t1, t3 - t2);
            if (samples == 4) save("sphere_1M_1080p.png", img, W, H);
            kf_render_destroy(r);
        }
        free(img);
        test_mesh_free(&sph);
    }
}

/* Edge anti-aliasing (render.antialias: edges, render/edge_aa.c) of the
 * golden scene: it meets the 4x MSAA golden's own tolerances (whole-image
 * mean |diff| <= 1.0 per channel, every 8x8 tile <= GOLDEN_TILE_TOL), and at
 * 256x192 against a 4x MSAA render of the same scene, on the pixels where
 * one sample and MSAA differ by more than 8 (the edges: silhouettes, the
 * flat-shaded creases, the objects' contact with the ground), it takes away
 * at least half of the one-sample picture's error. */
static void test_edge_antialias(void) {
    char err[256] = "", path[1024];
    two_objects t;
    two_objects_init(&t);
    float lo[3], hi[3], dir[3] = {-0.4f, -0.35f, -1};
    kf_render_scene_bounds(&t.sc, lo, hi);
    kf_camera cam = kf_camera_frame_bounds(lo, hi, dir, 35);
    {
        const int W = 64, H = 48;
        kf_render_ctx *r = kf_render_create(W, H, 4, err, sizeof err);
        KT_CHECK(r != NULL, "%s", err);
        if (!r) goto done;
        KT_CHECK(kf_render_set_antialias(r, KF_RENDER_AA_EDGES, err, sizeof err) == 0, "%s", err);
        uint8_t *img = malloc((size_t)W * H * 4), *gold = NULL;
        KT_CHECK(kf_render_frame(r, &t.sc, &cam, img, err, sizeof err) == 0, "%s", err);
        save("golden_edges.png", img, W, H);
        golden_path(path, sizeof path, "two_objects_64x48.png");
        int gw = 0, gh = 0;
        KT_CHECK(kf_png_read(path, &gold, &gw, &gh, NULL, NULL, err, sizeof err) == 0, "%s", err);
        if (gold && gw == W && gh == H) {
            for (int ch = 0; ch < 3; ch++) {
                double s = 0;
                for (int i = 0; i < W * H; i++) s += abs((int)img[4 * i + ch] - (int)gold[4 * i + ch]);
                printf("  edges vs golden, channel %d: mean |diff| %.3f\n", ch, s / (W * H));
                KT_NEAR(s / (W * H), 0.0, 1.0, "per-channel mean |diff| vs the MSAA golden");
            }
            int tx = 0, ty = 0;
            double worst = max_tile_diff(img, gold, W, H, 8, &tx, &ty);
            printf("  edges vs golden: largest 8x8 tile %.3f (tile %d,%d)\n", worst, tx, ty);
            KT_NEAR(worst, 0.0, GOLDEN_TILE_TOL, "per-tile mean |diff| vs the MSAA golden");
        }
        free(gold);
        free(img);
        kf_render_destroy(r);
    }
    {
        const int W = 256, H = 192;
        const size_t n = (size_t)W * H * 4;
        uint8_t *img[3] = {malloc(n), malloc(n), malloc(n)}; /* MSAA, one sample, edges */
        kf_render_ctx *rm = kf_render_create(W, H, 4, err, sizeof err),
                      *r1 = kf_render_create(W, H, 1, err, sizeof err);
        KT_CHECK(rm && r1, "%s", err);
        if (rm && r1) {
            KT_CHECK(kf_render_frame(rm, &t.sc, &cam, img[0], err, sizeof err) == 0, "%s", err);
            KT_CHECK(kf_render_frame(r1, &t.sc, &cam, img[1], err, sizeof err) == 0, "%s", err);
            KT_CHECK(kf_render_set_antialias(rm, KF_RENDER_AA_EDGES, err, sizeof err) == 0, "%s", err);
            KT_CHECK(kf_render_frame(rm, &t.sc, &cam, img[2], err, sizeof err) == 0, "%s", err);
            save("edges_256.png", img[2], W, H);
            double e1 = 0, ee = 0;
            long edge = 0;
            for (size_t i = 0; i < n; i += 4) {
                int d1 = 0, de = 0;
                for (int ch = 0; ch < 3; ch++) {
                    int a = abs((int)img[1][i + ch] - (int)img[0][i + ch]),
                        b = abs((int)img[2][i + ch] - (int)img[0][i + ch]);
                    d1 = a > d1 ? a : d1, de = b > de ? b : de;
                }
                if (d1 > 8) edge++, e1 += d1, ee += de;
            }
            printf("  256x192, %ld edge pixels: mean max-channel |diff| from 4x MSAA: one sample %.2f, edges %.2f\n",
                   edge, edge ? e1 / edge : 0, edge ? ee / edge : 0);
            KT_CHECK(edge > 200, "the scene has edges (%ld pixels)", edge);
            KT_CHECK(ee <= 0.5 * e1, "edges take away at least half of the aliasing (%.2f against %.2f a pixel)",
                     edge ? ee / edge : 0, edge ? e1 / edge : 0);
        }
        for (int k = 0; k < 3; k++) free(img[k]);
        kf_render_destroy(rm);
        kf_render_destroy(r1);
    }
done:
    two_objects_free(&t);
}

/* The two context backends (render/context.c): KERF_GL=osmesa and
 * KERF_GL=egl (surfaceless) each render the golden scene, on the backend
 * asked for, to the same picture (both are Mesa's llvmpipe here: within the
 * golden tolerance); an unknown KERF_GL is refused with a message. */
static void test_backends(void) {
    const int W = 64, H = 48;
    const char *names[2] = {"osmesa", "egl"};
    uint8_t *img[2] = {malloc((size_t)W * H * 4), malloc((size_t)W * H * 4)};
    int ok[2] = {0, 0};
    char err[1024] = "";
    const char *was = getenv("KERF_GL");
    char saved[64] = "";
    if (was) snprintf(saved, sizeof saved, "%s", was);
    two_objects t;
    two_objects_init(&t);
    float lo[3], hi[3], dir[3] = {-0.4f, -0.35f, -1};
    kf_render_scene_bounds(&t.sc, lo, hi);
    kf_camera cam = kf_camera_frame_bounds(lo, hi, dir, 35);
    for (int b = 0; b < 2; b++) {
        setenv("KERF_GL", names[b], 1);
        kf_render_ctx *r = kf_render_create(W, H, 4, err, sizeof err);
        KT_CHECK(r != NULL, "KERF_GL=%s: %s", names[b], err);
        if (!r) continue;
        KT_CHECK(!strcmp(kf_render_backend(r), names[b]), "asked for %s, got %s", names[b], kf_render_backend(r));
        printf("  %s: %s\n", kf_render_backend(r), kf_render_gl_renderer(r));
        ok[b] = kf_render_frame(r, &t.sc, &cam, img[b], err, sizeof err) == 0;
        KT_CHECK(ok[b], "%s: %s", names[b], err);
        kf_render_destroy(r);
    }
    if (ok[0] && ok[1]) {
        double d = mean_abs_diff(img[0], img[1], (size_t)W * H * 4);
        printf("  osmesa vs egl: mean |diff| %.4f\n", d);
        KT_NEAR(d, 0.0, 1.0, "the two backends draw the same picture");
    }
    setenv("KERF_GL", "vulkan", 1);
    kf_render_ctx *r = kf_render_create(W, H, 1, err, sizeof err);
    KT_CHECK(r == NULL && strstr(err, "KERF_GL") != NULL, "unknown KERF_GL refused: '%s'", err);
    kf_render_destroy(r);
    if (was) setenv("KERF_GL", saved, 1);
    else unsetenv("KERF_GL");
    two_objects_free(&t);
    free(img[0]);
    free(img[1]);
}

/* The shadow map's size (the preview preset makes it smaller): a bad size
 * is refused with a message; a smaller map draws the same shadows, softer
 * at their edges, so the picture moves far less than it does without
 * shadows at all. */
static void test_shadow_size(void) {
    const int W = 160, H = 120;
    char err[256] = "";
    kf_render_ctx *r = kf_render_create(W, H, 1, err, sizeof err);
    KT_CHECK(r != NULL, "%s", err);
    if (!r) return;
    KT_CHECK(kf_render_shadow_size(r) == 512, "automatic size for 160x120: %d (512..2048)", kf_render_shadow_size(r));
    KT_CHECK(kf_render_set_shadow_size(r, 8, err, sizeof err) == -1 && strstr(err, "shadow map"), "8 texels: '%s'",
             err);
    KT_CHECK(kf_render_set_shadow_size(r, 1 << 30, err, sizeof err) == -1, "2^30 texels refused");
    KT_CHECK(kf_render_shadow_size(r) == 512, "a refused size changes nothing");
    two_objects t;
    two_objects_init(&t);
    float lo[3], hi[3];
    kf_render_scene_bounds(&t.sc, lo, hi);
    kf_camera cam = kf_camera_turntable(lo, hi, 1, 8, 25, 35);
    size_t n = (size_t)W * H * 4;
    uint8_t *big = malloc(n), *small = malloc(n), *none = malloc(n);
    KT_CHECK(kf_render_frame(r, &t.sc, &cam, big, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_render_set_shadow_size(r, 128, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_render_shadow_size(r) == 128, "size now %d", kf_render_shadow_size(r));
    KT_CHECK(kf_render_frame(r, &t.sc, &cam, small, err, sizeof err) == 0, "%s", err);
    t.sc.shadows = 0;
    KT_CHECK(kf_render_frame(r, &t.sc, &cam, none, err, sizeof err) == 0, "%s", err);
    double d_small = mean_abs_diff(big, small, n), d_none = mean_abs_diff(big, none, n);
    printf("  shadow map 512 vs 128 texels: mean |diff| %.3f; vs no shadows %.3f (of 255)\n", d_small, d_none);
    KT_CHECK(d_none > 0.5, "the scene casts visible shadows (%.3f)", d_none);
    KT_CHECK(d_small < d_none / 3, "a smaller map keeps the shadows: %.3f vs %.3f without", d_small, d_none);
    free(big);
    free(small);
    free(none);
    two_objects_free(&t);
    kf_render_destroy(r);
}

/* A closed mesh's back faces are skipped only where none can show: the
 * picture is the same byte for byte with the flag and without, from
 * outside, from inside the cube, and with the near plane cutting it open
 * (where the inside's faces show, and must still be drawn). */
static void test_closed_meshes(void) {
    char err[256] = "";
    enum { W = 64, H = 48 };
    kf_render_ctx *r = kf_render_create(W, H, 1, err, sizeof err);
    KT_CHECK(r != NULL, "%s", err);
    if (!r) return;
    float c[3] = {0, 0, 0};
    test_mesh cube = make_cube(c, 0.5f);
    kf_render_mesh m = as_render(&cube, 0.8f, 0.6f, 0.4f, 0.2f, 0.5f);
    kf_render_scene sc = kf_render_scene_default();
    sc.meshes = &m;
    sc.nmeshes = 1;
    sc.ground = 0;
    const kf_camera cams[3] = {{{0.8f, 0.9f, 3}, {0, 0, 0}, {0, 1, 0}, 40, 0, 0},
                               {{0.1f, 0.05f, 0.2f}, {1, 0.2f, -0.3f}, {0, 1, 0}, 60, 0, 0},
                               {{0.3f, 0.4f, 3}, {0, 0, 0}, {0, 1, 0}, 40, 2.7f, 10}};
    const char *what[3] = {"outside", "inside", "near plane through it"};
    static uint8_t open[W * H * 4], closed[W * H * 4];
    for (int k = 0; k < 3; k++) {
        m.closed = 0;
        int rc = kf_render_frame(r, &sc, &cams[k], open, err, sizeof err);
        m.closed = 1;
        rc |= kf_render_frame(r, &sc, &cams[k], closed, err, sizeof err);
        KT_CHECK(rc == 0, "%s: %s", what[k], err);
        KT_CHECK(memcmp(open, closed, sizeof open) == 0, "%s: the closed flag changed the picture (mean diff %g)",
                 what[k], mean_abs_diff(open, closed, sizeof open));
        /* the cube is in the picture: not every pixel is the background's */
        int varied = 0;
        for (int i = 1; i < W * H && !varied; i++) varied = memcmp(closed + 4 * i, closed, 4) != 0;
        KT_CHECK(varied, "%s: the cube is drawn", what[k]);
    }
    test_mesh_free(&cube);
    kf_render_destroy(r);
}

int main(int argc, char **argv) {
    KT_RUN(test_silhouette_and_upright, argc, argv);
    KT_RUN(test_golden, argc, argv);
    KT_RUN(test_edge_antialias, argc, argv);
    KT_RUN(test_backends, argc, argv);
    KT_RUN(test_png_round_trip, argc, argv);
    KT_RUN(test_turntable_loop, argc, argv);
    KT_RUN(test_errors, argc, argv);
    KT_RUN(test_preview_and_timing, argc, argv);
    KT_RUN(test_shadow_size, argc, argv);
    KT_RUN(test_closed_meshes, argc, argv);
    return KT_EXIT();
}
