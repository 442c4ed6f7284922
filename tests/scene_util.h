/* scene_util.h — small helpers shared by the tests: build a model with one
 * material, and read the grid after a transfer. */
#ifndef KF_TEST_SCENE_UTIL_H
#define KF_TEST_SCENE_UTIL_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <kerf/kerf.h>
#include "mpm/model.h"

/* A model with the given settings and one material from a preset, with
 * optional overrides of E, nu, density (0 keeps the preset's). */
static inline kf_model *tu_model(const kf_sim_def *sd, const char *preset, double E, double nu, double rho,
                                 int *mat_id) {
    char err[256];
    kf_model *m = kf_model_create(sd, err, sizeof err);
    if (!m) {
        fprintf(stderr, "model: %s\n", err);
        exit(99);
    }
    kf_material mat;
    if (kf_material_preset(preset, &mat)) {
        fprintf(stderr, "no preset %s\n", preset);
        exit(99);
    }
    if (E > 0) mat.E = E;
    if (nu >= 0) mat.nu = nu;
    if (rho > 0) mat.density = rho;
    *mat_id = kf_model_add_material(m, &mat, err, sizeof err);
    if (*mat_id < 0) {
        fprintf(stderr, "material: %s\n", err);
        exit(99);
    }
    return m;
}

/* world position of node l of block b */
static inline void tu_node_pos(const kf_grid *g, size_t b, int l, double dx, double x[3]) {
    const int32_t *bc = &g->bcoord[3 * b];
    x[0] = (bc[0] * KF_BLOCK + (l >> 4)) * dx;
    x[1] = (bc[1] * KF_BLOCK + ((l >> 2) & 3)) * dx;
    x[2] = (bc[2] * KF_BLOCK + (l & 3)) * dx;
}

/* Σ m v of the particles plus M v of every body */
static inline void tu_total_momentum(const kf_model *m, const kf_state *s, double P[3]) {
    kf_particles_view pv = kf_state_particles_read(s);
    for (int a = 0; a < 3; a++) P[a] = 0;
    for (size_t i = 0; i < pv.n; i++)
        for (int a = 0; a < 3; a++) P[a] += (double)pv.mass[i] * pv.v[a][i];
    for (int r = 0; r < kf_model_rigid_count(m); r++) {
        kf_rigid_pose pose = kf_state_rigid(s, r);
        for (int a = 0; a < 3; a++) P[a] += kf_model_rigid_mass(m, r) * pose.v[a];
    }
}

static inline double tu_uniform(unsigned *s) {
    *s = *s * 1664525u + 1013904223u;
    return (*s >> 8) * (1.0 / 16777216.0);
}

#endif
