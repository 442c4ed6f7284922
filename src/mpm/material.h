/* material.h — constitutive models: stress, return mapping, energy, wave speed.
 *
 * A kf_material (public, doubles, SI) is compiled once into a kf_mat (kf_real,
 * Lamé parameters and derived constants precomputed). The step calls
 * kf_mat_kirchhoff() in P2G for every particle and kf_mat_project() after
 * the F update for plastic models. The formulas are in material.c, beside
 * each model.
 *
 * Per-particle state beyond F: ps[0], ps[1]
 *   water:      ps[0] = J (tracked volume ratio; F is unused and kept = I)
 *   sand:       ps[0] = log-volume correction (Klár's v_c), ps[1] = q (accumulated plastic strain)
 *   snow:       ps[0] = Jp (plastic volume ratio), ps[1] unused
 *   others:     unused (0)
 */
#ifndef KF_MATERIAL_H
#define KF_MATERIAL_H

#include <kerf/kerf.h>

typedef struct kf_mat {
    kf_material_model model;
    kf_real rho;        /* density */
    kf_real mu, lambda; /* Lamé */
    kf_real tau_y;      /* von Mises: √(2/3) σ_Y */
    kf_real c_f;        /* sand (no hardening): √(2/3) 2 sinφ / (3 − sinφ) */
    kf_real cohesion;
    int hardening, volume_correction;
    kf_real h0, h1, h2, h3; /* radians for h0, h1, h3 */
    kf_real kappa, gamma, viscosity;
    kf_real theta_c, theta_s, xi;
    int plastic;        /* 1 when kf_mat_project does anything */
    double wave_speed0; /* elastic P-wave speed at rest, m/s */
} kf_mat;

void kf_mat_compile(kf_mat *out, const kf_material *in);

/* Kirchhoff stress τ = P(F) Fᵀ (= J σ) for the particle's F and plastic state. */
void kf_mat_kirchhoff(const kf_mat *m, const kf_real F[9], const kf_real ps[2], kf_real tau[9]);

/* Plasticity and stress from one decomposition: when project is set, the
 * return mapping replaces F by its elastic part and updates ps (as
 * kf_mat_project); then τ of the resulting F is written. */
void kf_mat_update(const kf_mat *m, kf_real F[9], kf_real ps[2], int project, kf_real tau[9]);

/* kf_mat_update for n consecutive particles first..first+n-1 of one material,
 * on the particle planes; τ goes to the symmetric planes tau6 (xx, yy, zz,
 * xy, xz, yz). The fixed-corotated model runs SIMD across particles
 * (material_batch.c). */
void kf_mat_update_batch(const kf_mat *m, int n, kf_real *const F[9], kf_real *const ps[2], int project, size_t first,
                         kf_real *const tau6[6]);

/* Return mapping after F ← (I + Δt C) F: replaces F by its elastic part and
 * updates ps. Does nothing for elastic models and water. */
void kf_mat_project(const kf_mat *m, kf_real F[9], kf_real ps[2]);

/* Strain energy density ψ(F) per unit reference volume (J/m³). */
double kf_mat_energy_density(const kf_mat *m, const kf_real F[9], const kf_real ps[2]);

/* P-wave speed in the stiffest state: state is ps[0], the smallest among the
 * material's particles, for water (J: stiffens under compression) and snow
 * (Jp: hardens as it compacts); 1 (ignored) for the other models. */
double kf_mat_wave_speed(const kf_mat *m, double state);

#endif
