/* tank_rest.c — water at rest in a closed tank: does it keep its level?
 *
 *   kf_evid_tank_rest [--cells C] [--zwidth Z | --zcells N] [--kappa K] [--seconds T]
 *                     [--walls slip|separate|sticky] [--depth D]
 *
 * A tank 0.4 m wide in x and y and Z m in z (default N = 4 cells) at C
 * cells per metre (40), filled wall to wall to D m (0.2) with water of bulk
 * modulus K (1e4 Pa, Table 3's) at 8 particles per cell, jittered as shots
 * seed, under gravity, at the default CFL, one thread. At 48 cells/m the
 * walls at 0.4 m lie 0.2 cells short of a node. Prints every 0.1 s: time,
 * the level (mean top particle of 64 columns across x, plus a quarter
 * cell), the level the particles' J claims (Σ J V⁰ over the floor area),
 * the mean, smallest and largest J, the kinetic energy (J), and the range
 * of particle x and z. Hydrostatic compression alone lowers the level by
 * about ρ g D / (2 κ γ) of D (1.2% at 0.17 m), within the first half second.
 * tools/evidence/fluid_results.md shows the level before and after the
 * walls were put at their planes (wall_ghost.c). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include <kerf/kerf.h>

int main(int argc, char **argv) {
    double cells = 40;
    double zwidth = 0, kappa = 1e4, seconds = 10, depth = 0.2, zcells = 4;
    kf_boundary walls = KF_BOUNDARY_SEPARATE;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (!strcmp(argv[i], "--cells")) cells = atof(argv[i + 1]);
        else if (!strcmp(argv[i], "--zwidth")) zwidth = atof(argv[i + 1]);
        else if (!strcmp(argv[i], "--kappa")) kappa = atof(argv[i + 1]);
        else if (!strcmp(argv[i], "--seconds")) seconds = atof(argv[i + 1]);
        else if (!strcmp(argv[i], "--depth")) depth = atof(argv[i + 1]);
        else if (!strcmp(argv[i], "--zcells")) zcells = atof(argv[i + 1]);
        else if (!strcmp(argv[i], "--walls"))
            walls = !strcmp(argv[i + 1], "slip")     ? KF_BOUNDARY_SLIP
                    : !strcmp(argv[i + 1], "sticky") ? KF_BOUNDARY_STICKY
                                                     : KF_BOUNDARY_SEPARATE;
    }
    const double W = 0.4, dx = 1 / cells, Z = zwidth > 0 ? zwidth : zcells * dx;
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = dx;
    sd.walls = 1;
    sd.wall_boundary = walls;
    sd.threads = 1;
    sd.domain_max[0] = W, sd.domain_max[1] = W, sd.domain_max[2] = Z;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    if (!m) return fprintf(stderr, "%s\n", err), 1;
    kf_material water;
    kf_material_preset("water", &water);
    water.bulk_modulus = kappa;
    int mat = kf_model_add_material(m, &water, err, sizeof err);
    if (mat < 0) return fprintf(stderr, "%s\n", err), 1;
    kf_state *s = kf_state_create(m);
    const double lo[3] = {0, 0, 0}, hi[3] = {W, depth, Z};
    kf_state_fill_box(s, m, lo, hi, mat, NULL, 2, 1);
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    printf("# cells %g kappa %g depth %g walls %d particles %zu\n", cells, kappa, depth, (int)walls, kf_state_count(s));
    printf("# t level level_J meanJ minJ maxJ kinetic\n");
    const double frame = 0.1;
    for (int f = 0; f <= (int)lround(seconds / frame); f++) {
        if (f > 0 && kf_advance(m, s, frame, &st, err, sizeof err)) return fprintf(stderr, "%s\n", err), 1;
        kf_particles_view pv = kf_state_particles_read(s);
        enum { NC = 64 };
        double top[NC];
        for (int i = 0; i < NC; i++) top[i] = -1;
        double sj = 0, jmin = 1e9, jmax = 0, vj = 0, ke = 0, xlo = 1e9, xhi = -1e9, zlo = 1e9, zhi = -1e9;
        for (size_t i = 0; i < pv.n; i++) {
            int c = (int)(pv.x[0][i] / W * NC);
            if (c >= 0 && c < NC && pv.x[1][i] > top[c]) top[c] = pv.x[1][i];
            xlo = fmin(xlo, pv.x[0][i]), xhi = fmax(xhi, pv.x[0][i]);
            zlo = fmin(zlo, pv.x[2][i]), zhi = fmax(zhi, pv.x[2][i]);
            double J = pv.ps[0][i];
            sj += J, vj += J * pv.vol0[i];
            jmin = J < jmin ? J : jmin, jmax = J > jmax ? J : jmax;
            ke += 0.5 * pv.mass[i] * (pv.v[0][i] * pv.v[0][i] + pv.v[1][i] * pv.v[1][i] + pv.v[2][i] * pv.v[2][i]);
        }
        double sum = 0;
        int n = 0;
        for (int i = 0; i < NC; i++)
            if (top[i] >= 0) sum += top[i], n++;
        printf("%.2f %.5f %.5f %.5f %.4f %.4f %.3e x %.4f %.4f z %.4f %.4f\n", kf_state_time(s), sum / n + 0.25 * dx,
               vj / (W * Z), sj / pv.n, jmin, jmax, ke, xlo, xhi, zlo, zhi);
        fflush(stdout);
    }
    fprintf(stderr, "%ld substeps\n", st.substeps);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return 0;
}
