/* surface_look.c — orange peel, measured: a resting jittered block and a
 * sheet two particles thick, surfaced with kerf's earlier settings (spheres
 * on averaged centres, surface.kernel: spheres) and with the shot defaults
 * now (anisotropic discs; read from shots/demo.yaml, which sets no surface
 * key), probed by tests/surface_look.h.
 *   kf_evid_surface_look OUT.png [repeats]   (repeats 0: the shot defaults' rows alone)
 * prints a markdown table (3 seeds each) and the surfacing time of a larger
 * block (median of `repeats`, wall clock, before and after interleaved), and
 * writes OUT.png: the top face's height above its fitted plane, spheres
 * (left) and now (right), grey = plane, white/black = +/- 0.25 spacing. */
#include <stdio.h>
#include <stdlib.h>
#include <time.h>

#include "../../tests/surface_look.h"
#include "../median.h"
#include "render.h"
#include "shot/diag.h"
#include "shot/shot.h"

static double now(void) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return t.tv_sec + 1e-9 * t.tv_nsec;
}

static kf_vdb_surface_stats last_stats;

static kf_vdb_grid *surface(const kf_points *pts, double h, look_settings s, double *sec) {
    kf_vdb_surface_params p;
    look_params(&p, h, s);
    kf_vdb_grid *g = NULL;
    char err[512];
    double t0 = now();
    if (kf_vdb_levelset_from_particles(pts->n, pts->x, NULL, NULL, NULL, &p, &g, &last_stats, err, sizeof err)) {
        fprintf(stderr, "%s\n", err);
        exit(1);
    }
    if (sec) *sec = now() - t0;
    return g;
}

/* the top face's height map (every quarter spacing) into the image's half */
static void height_map(const kf_vdb_grid *g, const double lo[3], const double hi[3], double h, uint8_t *img, int W,
                       int x0, int n) {
    double *y = malloc(sizeof(double) * (size_t)n * n), mean = 0;
    for (int i = 0; i < n; i++)
        for (int k = 0; k < n; k++) {
            double x = lo[0] + (hi[0] - lo[0]) * (i + 0.5) / n, z = lo[2] + (hi[2] - lo[2]) * (k + 0.5) / n;
            double a[3] = {x, hi[1] - 2 * h, z}, b[3] = {x, hi[1] + 2 * h, z};
            y[i * n + k] = a[1] + look_cross(g, a, b) * (b[1] - a[1]);
        }
    /* the plane: the mean over the face away from its edges */
    int m = 0;
    for (int i = n / 8; i < n - n / 8; i++)
        for (int k = n / 8; k < n - n / 8; k++) mean += y[i * n + k], m++;
    mean /= m;
    for (int i = 0; i < n; i++)
        for (int k = 0; k < n; k++) {
            double v = 128 + 127 * (y[i * n + k] - mean) / (0.25 * h);
            uint8_t c = (uint8_t)(v < 0 ? 0 : v > 255 ? 255 : v);
            uint8_t *px = img + 4 * ((size_t)k * W + x0 + i);
            px[0] = px[1] = px[2] = c, px[3] = 255;
        }
    free(y);
}

int main(int argc, char **argv) {
    if (argc < 2) {
        fprintf(stderr, "usage: %s OUT.png [repeats]\n", argv[0]);
        return 2;
    }
    int reps = argc > 2 ? atoi(argv[2]) : 5;
    kf_diag diag;
    kf_diag_init(&diag);
    kf_shot *shot = kf_shot_load(KERF_SOURCE_DIR "/shots/demo.yaml", NULL, 0, NULL, NULL, &diag);
    if (!shot) {
        kf_diag_print(stderr, &diag);
        return 1;
    }
    const look_settings after = look_of_shot(shot);
    kf_shot_free(shot);
    kf_diag_free(&diag);
    const double h = 0.01;
    /* a 32 x 12 x 32 spacing block, and a 32 x 2 x 32 sheet */
    const double lo[3] = {0.2, 0.1, 0.2}, hi[3] = {0.2 + 32 * h, 0.1 + 12 * h, 0.2 + 32 * h};
    const double shi[3] = {0.2 + 32 * h, 0.1 + 2 * h, 0.2 + 32 * h};
    printf("| settings | seed | top RMS (h) | top offset (h) | edge radius (h) | volume error | sheet holes |\n");
    printf("|---|---|---|---|---|---|---|\n");
    const int n = 128, W = 2 * n + 8;
    uint8_t *img = calloc((size_t)W * n * 4, 1);
    for (int v = reps == 0 ? 1 : 0; v < 2; v++) {
        look_settings s = v ? after : look_spheres;
        for (uint32_t seed = 1; seed <= 3; seed++) {
            kf_points pts, sheet;
            if (look_seed(lo, hi, h, seed, &pts) || look_seed(lo, shi, h, seed, &sheet)) return 1;
            kf_vdb_grid *g = surface(&pts, h, s, NULL), *gs = surface(&sheet, h, s, NULL);
            look_result r = look_measure(g, lo, hi, h);
            printf("| %s | %u | %.4f | %+.3f | %.3f | %+.4f | %.4f |\n", v ? "now" : "spheres", seed, r.top_rms,
                   r.top_off, r.edge, r.vol_err, look_sheet_holes(gs, lo, shi, h));
            if (seed == 1) height_map(g, lo, hi, h, img, W, v ? n + 8 : 0, n);
            kf_vdb_free(g);
            kf_vdb_free(gs);
            kf_points_free(&pts);
            kf_points_free(&sheet);
        }
    }
    /* balls of 4 and 8 spacings: a curved face keeps its volume */
    printf("\n| settings | ball radius (h) | seed | volume error |\n|---|---|---|---|\n");
    for (int v = reps == 0 ? 1 : 0; v < 2; v++)
        for (int rr = 4; rr <= 8; rr += 4)
            for (uint32_t seed = 1; seed <= 3; seed++) {
                const double c[3] = {0.5, 0.5, 0.5}, rad = rr * h;
                kf_points pts;
                if (look_seed_ball(c, rad, h, seed, &pts)) return 1;
                kf_vdb_grid *g = surface(&pts, h, v ? after : look_spheres, NULL);
                printf("| %s | %d | %u | %+.4f |\n", v ? "now" : "spheres", rr, seed,
                       look_volume_error(g, 4.0 / 3.0 * 3.14159265358979323846 * rad * rad * rad));
                kf_vdb_free(g);
                kf_points_free(&pts);
            }
    char err[256];
    if (kf_png_write(argv[1], img, W, n, NULL, 0, err, sizeof err)) fprintf(stderr, "%s\n", err);
    free(img);
    if (reps <= 0) return 0; /* the table alone */
    /* time: a 96 x 48 x 96 spacing block (442k particles), interleaved */
    const double blo[3] = {0, 0, 0}, bhi[3] = {96 * h, 48 * h, 96 * h};
    kf_points big;
    if (look_seed(blo, bhi, h, 1, &big)) return 1;
    /* wall, then process CPU seconds of each phase (averaging, sort, splat,
     * re-distance, filter) and their sum */
    enum { T_WALL, T_AVG, T_SORT, T_SPLAT, T_DIST, T_FILT, T_CPU, T_N };
    static const char *const tname[T_N] = {"wall",        "average / shape", "sort",     "splat",
                                           "re-distance", "filter",          "CPU total"};
    double t[2][T_N][32];
    size_t kept = 0;
    reps = reps > 32 ? 32 : reps;
    for (int r = 0; r < reps; r++)
        for (int v = 0; v < 2; v++) {
            kf_vdb_free(surface(&big, h, v ? after : look_spheres, &t[v][T_WALL][r]));
            const kf_vdb_surface_stats *st = &last_stats;
            double c[T_N] = {0, st->cpu_average, st->cpu_sort, st->cpu_splat, st->cpu_redistance, st->cpu_filter, 0};
            for (int k = T_AVG; k < T_CPU; k++) t[v][k][r] = c[k], c[T_CPU] += c[k];
            t[v][T_CPU][r] = c[T_CPU];
            if (v) kept = st->n_average_kept;
        }
    printf("\nsurfacing %zu particles, seconds (median of %d; %zu deep enough to need no shape):\n\n", big.n, reps,
           kept);
    printf("| phase | spheres | now |\n|---|---|---|\n");
    for (int k = 0; k < T_N; k++)
        printf("| %s | %.3f | %.3f |\n", tname[k], kf_median(t[0][k], reps), kf_median(t[1][k], reps));
    kf_points_free(&big);
    return 0;
}
