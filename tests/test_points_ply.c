/* test_points_ply.c — the particles' PLY: its header names (velocity as one
 * v_x/v_y/v_z vector, the analysis fields), and its values read back against
 * analytic stress states.
 *
 * Each particle is given a uniaxial stretch F = diag(s, 1, 1), whose Cauchy
 * stress has a closed form per model:
 *   fixed corotated: τ = 2μ(F − R)Fᵀ + λ(J − 1)J I, R = I, so dev σ comes from
 *                    τ_xx = 2μ(s − 1)s alone: von Mises = 2μ(s − 1);
 *   snow:            the same with μ scaled by e^{ξ(1 − Jp)};
 *   von Mises model: StVK on the Hencky strain, τ = 2μ ln F + λ tr(ln F) I:
 *                    von Mises = 2μ ln s / s;
 *   water:           pressure only: von Mises = 0, J = the tracked J. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "kt.h"

#include <kerf/kerf.h>
#include "io/points_ply.h"

enum { NP = 4, REC = 6 * 4 + 2 + 4 + 3 * 4 };

static const char *expected_header =
    "element vertex 4\n"
    "property float x\nproperty float y\nproperty float z\n"
    "property float v_x\nproperty float v_y\nproperty float v_z\n"
    "property ushort material\nproperty uint id\n"
    "property float von_mises\nproperty float J\nproperty float plastic_strain\nend_header\n";

static void stretched_particles(void) {
    const double s = 1.02; /* 2 % stretch: stress well inside every model's elastic range */
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.1;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    KT_CHECK(m != NULL, "%s", err);
    const char *names[NP] = {"jello", "snow", "cheese", "water"};
    kf_material mat[NP];
    int id[NP];
    for (int k = 0; k < NP; k++) {
        kf_material_preset(names[k], &mat[k]);
        if (k == 2) mat[k].yield_stress = 1e9; /* von Mises: no yield at this stretch */
        id[k] = kf_model_add_material(m, &mat[k], err, sizeof err);
        KT_CHECK(id[k] >= 0, "%s", err);
    }
    kf_state *st = kf_state_create(m);
    const double F[9] = {s, 0, 0, 0, 1, 0, 0, 0, 1};
    for (int k = 0; k < NP; k++) {
        double x[3] = {0.3 + 0.1 * k, 0.5, 0.5}, v[3] = {0.25 * k, -1.5, 3.0 + k};
        KT_CHECK(kf_state_add_particles(st, m, 1, x, v, F, id[k], 1e-3) == k, "particle %d", k);
    }
    /* snow compacted to Jp = 0.8; water at J = 0.9 (its F stays I) */
    kf_particles_view pv = kf_state_particles(st);
    pv.ps[0][1] = (kf_real)0.8;
    pv.ps[0][3] = (kf_real)0.9;
    for (int c = 0; c < 9; c++) pv.F[c][3] = (kf_real)(c % 4 == 0);

    char dir[] = "/tmp/kf_ply_XXXXXX", path[64];
    KT_CHECK(mkdtemp(dir) != NULL, "mkdtemp");
    snprintf(path, sizeof path, "%s/p.ply", dir);
    KT_CHECK(kf_write_points_ply(path, m, st, err, sizeof err) == 0, "%s", err);

    FILE *f = fopen(path, "rb");
    KT_CHECK(f != NULL, "%s", path);
    if (!f) return;
    static char buf[4096];
    size_t len = fread(buf, 1, sizeof buf, f);
    fclose(f);
    const char *hdr = strstr(buf, "element vertex");
    const char *end = strstr(buf, "end_header\n");
    KT_CHECK(hdr && end && strncmp(hdr, expected_header, strlen(expected_header)) == 0,
             "the header's element and properties, in order:\n%.*s", hdr && end ? (int)(end + 11 - hdr) : 0,
             hdr ? hdr : "");
    KT_CHECK(strncmp(buf, "ply\nformat binary_little_endian 1.0\n", 36) == 0, "a binary little-endian PLY");
    if (!end) return;
    const unsigned char *d = (const unsigned char *)end + 11;
    KT_CHECK((size_t)((const char *)d - buf) + NP * REC == len, "%d records of %d bytes, no more", NP, REC);

    const double mu[NP] = {mat[0].E / (2 * (1 + mat[0].nu)), mat[1].E / (2 * (1 + mat[1].nu)),
                           mat[2].E / (2 * (1 + mat[2].nu)), 0};
    const double vm[NP] = {2 * mu[0] * (s - 1), 2 * mu[1] * exp(mat[1].xi * (1 - 0.8)) * (s - 1),
                           2 * mu[2] * log(s) / s, 0};
    const double J[NP] = {s, s * 0.8, s, 0.9}, plastic[NP] = {0, log(0.8), 0, 0};
    for (int k = 0; k < NP; k++) {
        float r[6], a[3];
        uint16_t mi;
        uint32_t pid;
        memcpy(r, d + k * REC, sizeof r);
        memcpy(&mi, d + k * REC + 24, 2);
        memcpy(&pid, d + k * REC + 26, 4);
        memcpy(a, d + k * REC + 30, sizeof a);
        /* the writer keeps the state's order: particles were added one by one */
        KT_CHECK(pid == (uint32_t)k && mi == (uint16_t)id[k], "particle %d: id %u material %u", k, pid, mi);
        KT_NEAR(r[0], 0.3 + 0.1 * k, 1e-6, "position as written, float");
        KT_NEAR(r[3], 0.25 * k, 1e-6, "v_x as given");
        KT_NEAR(r[4], -1.5, 1e-6, "v_y as given");
        KT_NEAR(r[5], 3.0 + k, 1e-6, "v_z as given");
        /* float F: s − 1 = 0.02 carries at most ε_float/0.02 = 6e-6 relative error
         * (measured about 1e-6); water's zero is exact up to round-off of its pressure */
        KT_NEAR(a[0], vm[k], 6e-6 * vm[k] + 1e-3, names[k]);
        KT_NEAR(a[1], J[k], 1e-6, "J as a float");
        KT_NEAR(a[2], plastic[k], 1e-6, "the model's plastic strain");
        printf("  %-6s von Mises %.6g Pa (analytic %.6g, relative error %.1e), J %.6f, plastic %.6f\n", names[k], a[0],
               vm[k], vm[k] > 0 ? fabs(a[0] / vm[k] - 1) : 0.0, a[1], a[2]);
    }
    unlink(path);
    rmdir(dir);
    kf_state_destroy(st);
    kf_model_destroy(m);
}

int main(int argc, char **argv) {
    KT_RUN(stretched_particles, argc, argv);
    return KT_EXIT();
}
