/* builtin.c — code-built scenes (see builtin.h). */
#include "builtin.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

void kf_scene_free(kf_scene *sc) {
    kf_state_destroy(sc->state);
    kf_model_destroy(sc->model);
    memset(sc, 0, sizeof *sc);
}

static int add_preset(kf_scene *sc, const char *preset, char *err, size_t errlen) {
    kf_material mat;
    if (kf_material_preset(preset, &mat)) {
        snprintf(err, errlen, "unknown material preset '%s'", preset);
        return -1;
    }
    return kf_model_add_material(sc->model, &mat, err, errlen);
}

int kf_scene_demo(kf_scene *sc, int res, char *err, size_t errlen) {
    memset(sc, 0, sizeof *sc);
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 1.0 / res;
    sd.walls = 1;
    sd.wall_boundary = KF_BOUNDARY_SEPARATE;
    sd.wall_friction = 0.3;
    sc->model = kf_model_create(&sd, err, errlen);
    if (!sc->model) return -1;
    sc->name = "demo";
    sc->fps = 24;
    sc->frames = 24;
    int sand = add_preset(sc, "sand", err, errlen);
    int jello = add_preset(sc, "jello", err, errlen);
    int rubber = add_preset(sc, "rubber", err, errlen);
    if (sand < 0 || jello < 0 || rubber < 0) return -1;
    sc->state = kf_state_create(sc->model);
    const double pad = 2.0 / res;
    double lo[3] = {pad, pad, pad}, hi[3] = {1 - pad, 0.18, 1 - pad};
    double cube_lo[3] = {0.2, 0.45, 0.35}, cube_hi[3] = {0.5, 0.75, 0.65}, down[3] = {0, -1.0, 0};
    double ball[3] = {0.72, 0.5, 0.5};
    if (kf_state_fill_box(sc->state, sc->model, lo, hi, sand, NULL, 2, 7) < 0 ||
        kf_state_fill_box(sc->state, sc->model, cube_lo, cube_hi, jello, down, 2, 11) < 0 ||
        kf_state_fill_sphere(sc->state, sc->model, ball, 0.12, rubber, down, 2, 13) < 0) {
        snprintf(err, errlen, "out of memory seeding particles");
        return -1;
    }
    return 0;
}

int kf_scene_bench_cube(kf_scene *sc, int cells, kf_force force, int threads, char *err, size_t errlen) {
    memset(sc, 0, sizeof *sc);
    kf_sim_def sd = kf_default_sim_def();
    int grid = (int)lround(cells * 1.25);
    sd.dx = 1.0 / grid;
    sd.gravity[1] = 0;
    sd.force = force;
    sd.dt_fixed = 1e-2;
    sd.threads = threads;
    sd.j_min = 1e-6, sd.j_max = 1e6;
    sd.max_cells_per_step = 1e9; /* the benchmark is static: F = I, v = 0 */
    sc->model = kf_model_create(&sd, err, errlen);
    if (!sc->model) return -1;
    sc->name = "bench_cube";
    kf_material mat;
    kf_material_preset("jello", &mat);
    snprintf(mat.name, sizeof mat.name, "bench");
    mat.model = KF_MAT_COROTATED;
    mat.E = 100, mat.nu = 0.3, mat.density = 1;
    int id = kf_model_add_material(sc->model, &mat, err, errlen);
    if (id < 0) return -1;
    sc->state = kf_state_create(sc->model);
    /* the cube sits centred in the grid */
    double o = (grid - cells) / 2 * sd.dx, lo[3] = {o, o, o},
           hi[3] = {o + cells * sd.dx, o + cells * sd.dx, o + cells * sd.dx};
    if (kf_state_fill_box(sc->state, sc->model, lo, hi, id, NULL, 2, 0) < 0) {
        snprintf(err, errlen, "out of memory seeding particles");
        return -1;
    }
    return 0;
}

int kf_scene_falling_block(kf_scene *sc, long n, int threads, char *err, size_t errlen) {
    memset(sc, 0, sizeof *sc);
    /* a 2:1:2 block with 8 particles per cell: (2c)(c)(2c) * 8 = n */
    int c = (int)lround(cbrt((double)n / 32.0));
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 1.0 / (4 * c);
    sd.walls = 1;
    sd.threads = threads;
    sc->model = kf_model_create(&sd, err, errlen);
    if (!sc->model) return -1;
    sc->name = "falling_block";
    sc->fps = 24;
    kf_material mat;
    kf_material_preset("jello", &mat);
    int id = kf_model_add_material(sc->model, &mat, err, errlen);
    if (id < 0) return -1;
    sc->state = kf_state_create(sc->model);
    double lo[3] = {0.25, 0.3, 0.25}, hi[3] = {0.25 + 2 * c * sd.dx, 0.3 + c * sd.dx, 0.25 + 2 * c * sd.dx};
    double v[3] = {0, -2, 0};
    if (kf_state_fill_box(sc->state, sc->model, lo, hi, id, v, 2, 0) < 0) {
        snprintf(err, errlen, "out of memory seeding particles");
        return -1;
    }
    return 0;
}
