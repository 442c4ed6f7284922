/* fields.c — per-particle stress, volume ratio and plastic strain for
 * analysis outputs, computed from F and the plastic state (not from the
 * step's cached stress, which a checkpoint does not carry). */
#include <math.h>

#include "model.h"

kf_particle_fields kf_state_particle_fields(const kf_model *m, const kf_state *s, size_t i) {
    const kf_particles *p = &s->p;
    const kf_mat *mat = &m->mat[p->mat[i]];
    kf_real F[9], ps[2] = {p->ps[0][i], p->ps[1][i]}, tau[9];
    for (int k = 0; k < 9; k++) F[k] = p->F[k][i];
    double detF = (double)F[0] * ((double)F[4] * F[8] - (double)F[5] * F[7]) -
                  (double)F[1] * ((double)F[3] * F[8] - (double)F[5] * F[6]) +
                  (double)F[2] * ((double)F[3] * F[7] - (double)F[4] * F[6]);
    kf_particle_fields out = {0, detF, 0};
    /* τ = J_e σ with J_e the volume ratio the stress is a function of */
    double Je = detF;
    if (mat->model == KF_MAT_WATER) out.J = Je = (double)ps[0];
    if (mat->model == KF_MAT_SNOW) {
        out.J = detF * (double)ps[0];
        out.plastic = log((double)ps[0]);
    }
    if (mat->model == KF_MAT_SAND) out.plastic = (double)ps[1];
    kf_mat_kirchhoff(mat, F, ps, tau);
    /* von Mises of σ: only the deviator counts */
    double tr = ((double)tau[0] + tau[4] + tau[8]) / 3, ss = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            double d = (double)tau[3 * a + b] - (a == b ? tr : 0);
            ss += d * d;
        }
    out.von_mises = Je > 0 ? sqrt(1.5 * ss) / Je : 0;
    return out;
}
