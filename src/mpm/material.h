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
#include <math.h>

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
    /* the resolvable stiffness under a fixed step (kf_mat_limit): 0, or the
     * fastest wave speed the step integrates, m/s, and the state where the
     * model's own wave speed reaches it (water: J, snow: Jp); states below
     * it are evaluated with a pressure of that constant wave speed */
    double c_limit, state_limit;
} kf_mat;

/* Fixed corotated's volume term ½λ(J − 1)² gives a Cauchy pressure λ(1 − J)
 * bounded by λ, and a volume wave speed √(λ/ρ) J that vanishes as J → 0:
 * nothing resists a collapse, so a blow faster than the material's waves
 * crushes it through J = 0 whatever the step (the pressure a piston at u
 * needs, ρ u² r/(r − 1), exceeds λ once u outruns those waves). Below
 * KF_COROT_JB the volume stiffens instead, as real matter does: its wave
 * speed grows as c(J) = c0 J_b/J from the P-wave speed at rest c0 =
 * √((λ + 2μ)/ρ) (dp/dJ = −(λ + 2μ) J_b²/J⁴, so p → ∞ as J → 0), continuous in
 * pressure with the model at J_b. Above J_b the model is unchanged and so
 * is every state an ordinary shot reaches; the CFL rule sees the stiffened
 * speed (kf_mat_wave_speed of the smallest J). Under a fixed step whose
 * resolvable wave speed c_l (kf_mat_limit) the barrier would outgrow, it
 * goes on below J_c = J_b c0/c_l at the constant speed c_l. g, g1, g2: the
 * volume energy per reference volume and its first and second derivatives
 * in J (g1 J is the Kirchhoff volume stress); jc: J_c, or 0 for no limit. */
#define KF_COROT_JB 0.3
static inline void kf_corot_volume(double mu, double la, double J, double jc, double *g, double *g1, double *g2) {
    /* an inverted F (J <= 0) keeps the model's own term: the step stops such a run on its det F check */
    if (!(J < KF_COROT_JB) || !(J > 0)) {
        *g = 0.5 * la * (J - 1) * (J - 1), *g1 = la * (J - 1), *g2 = la;
        return;
    }
    const double jb = KF_COROT_JB, kb3 = (la + 2 * mu) * jb * jb / 3;
    double j = J > 1e-6 ? J : 1e-6, jl = j < jc ? jc : j; /* the barrier's own part down to J_c */
    *g = 0.5 * la * (jb - 1) * (jb - 1) + la * (1 - jb) * (jb - jl) +
         kb3 * (0.5 / (jl * jl) - 0.5 / (jb * jb) - (jb - jl) / (jb * jb * jb));
    *g1 = -la * (1 - jb) - kb3 * (1 / (jl * jl * jl) - 1 / (jb * jb * jb));
    *g2 = 3 * kb3 / (jl * jl * jl * jl);
    if (jl == j) return;
    /* below J_c: the gas of wave speed c_l, ρ c_l² = g''(J_c) J_c² */
    const double kl = *g2 * jl * jl;
    *g += -*g1 * (jl - j) + kl * (log(jl / j) - (jl - j) / jl);
    *g1 -= kl * (1 / j - 1 / jl);
    *g2 = kl / (j * j);
}

/* The resolvable stiffness: a fixed step Δt integrates waves up to
 * KF_CFL_STIFF Δx/Δt. Water (Tait), snow (hardening) and the corotated
 * barrier stiffen without bound as they compact; where a state's wave speed
 * would exceed that, the material is evaluated at the stiffness the step
 * resolves (never below its stiffness at rest). c_limit 0: none (the CFL
 * rule's steps resolve every state, and the model is untouched). */
#define KF_CFL_STIFF 1.0
void kf_mat_limit(kf_mat *m, double c_limit);

/* 1 when the particle's state (F, ps) is evaluated at the limited stiffness */
int kf_mat_is_limited(const kf_mat *m, const kf_real F[9], const kf_real ps[2]);

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
 * (material_batch.c). Returns how many of them were evaluated at the
 * limited stiffness (kf_mat_limit). */
int kf_mat_update_batch(const kf_mat *m, int n, kf_real *const F[9], kf_real *const ps[2], int project, size_t first,
                        kf_real *const tau6[6]);

/* sand's hardened friction coefficient c_f at hardening state q, the
 * library route in double (kf_mat_update's; the batch's lanes match it) */
double kf_mat_friction_hardened(const kf_mat *m, double q);

/* the batch path's hardening for n <= 16 lanes, rounded to kf_real as
 * kf_mat_update_batch rounds it: snow's e^{ξ(1 − Jp)} from state = Jp (no
 * state limit), sand's hardened friction coefficient from state = q; 1 for
 * other models. For tests: the batch takes these across the lanes
 * (core/vmath.h) and must keep the library's bits. */
void kf_mat_batch_hardening(const kf_mat *m, int n, const kf_real *state, kf_real *out);

/* Return mapping after F ← (I + Δt C) F: replaces F by its elastic part and
 * updates ps. Does nothing for elastic models and water. */
void kf_mat_project(const kf_mat *m, kf_real F[9], kf_real ps[2]);

/* Strain energy density ψ(F) per unit reference volume (J/m³). */
double kf_mat_energy_density(const kf_mat *m, const kf_real F[9], const kf_real ps[2]);

/* P-wave speed in the stiffest state: state is ps[0], the smallest among the
 * material's particles, for water (J: stiffens under compression) and snow
 * (Jp: hardens as it compacts), the smallest det F for fixed corotated (its
 * volume barrier); 1 (ignored) for the other models. */
double kf_mat_wave_speed(const kf_mat *m, double state);

#endif
