/* test_sphere.c — V6, the breathing sphere.
 *
 * A free elastic sphere (fixed corotated, ν = 0.3, no gravity, no walls) of
 * rest radius a starts at rest, stretched uniformly by F₀ = 1.01·I, and
 * breathes. Linear theory: a radial mode u = A j₁(kr) r̂ (pure dilatation, so
 * ω = c_p k) is traction free when
 *     (λ+2μ) z² sin z = 4μ (sin z − z cos z),  z = ka = ωa/c_p,
 * i.e. 1 − z cot z = (λ+2μ)/(4μ) z², whose first root is z = 2.6702 for
 * ν = 0.3 (the V6 value; the test re-solves it and checks the two agree).
 *
 * "Sphere radius a" is the rest radius: particles sit on a lattice of spacing
 * h = Δx/2 inside |X − c| < a with reference volume h³, and start at
 * x = c + 1.01 (X − c) with F = 1.01·I (the reference shape stretched, not a
 * radius-a body compressed back), so ω = 2.6702 c_p / a exactly in theory.
 *
 * Measuring the radial frequency: the uniform initial strain u₀ = 0.01 (X − c)
 * excites the overtones too (the second root is z = 6.092), and they move
 * zero crossings of the mean radius or mean radial velocity by much more than
 * the 1% being tested. So we measure the modal coordinate of the fundamental,
 *     q(t) = Σ_p m_p (x_p − X_p) · r̂_p j₁(z r_p / a),   r_p = |X_p − c|,
 * the mass-weighted projection onto the first mode shape. Radial modes are
 * orthogonal in that inner product, so q(t) = q(0) cos(ω t) up to the
 * discretisation; the projection only filters, it cannot pull the measured
 * frequency towards z (a simulation at another frequency would show that
 * frequency in q). The period is 2 (t₂ − t₁) from the zero crossings at T/4
 * and 3T/4 (and later ones if run longer), by a least-squares line.
 *
 * Resolution a/Δx = 16 with 2³ particles per cell (~137k particles), fixed
 * step at CFL number C = Δt c_p/Δx = 0.3 (quadratic limit ≈ 1.1, §4); the
 * symplectic Euler period error (ωΔt)²/24 = 1e-4 is a hundredth of the bound.
 * The amplitude is 1% strain, whose nonlinear frequency shift is second order,
 * ~1e-4.
 *
 * Measured (Release, commit f107390, float and double identical to 5 digits):
 * ω a/c_p = 2.66331 (−0.258%) MLS and 2.66182 (−0.314%) classic at
 * a/Δx = 16; 2.64342 (−1.00%) and 2.63879 (−1.18%) at a/Δx = 8, so the
 * error falls ~3.8x per halving (second order). For comparison, the zero
 * crossings of the plain mean radial displacement give +0.03% / −0.04% at 16
 * but −0.84% / −1.03% at 8: overtones and discretisation errors partly
 * cancel there, which is why it is printed but not asserted. The file runs
 * in ~2.5 s on 2 threads (each a/Δx = 16 run: 137376 particles x 163 steps). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "core/timer.h"
#include <kerf/kerf.h>
#include "kt.h"
#include "problems/problems.h"

#define SPH_A 1.0 /* rest radius */
#define SPH_RHO 1.0
#define SPH_E 1000.0
#define SPH_NU 0.3
#define SPH_STRETCH 1.01
#define SPH_CFL 0.3
#define SPH_Z_REF 2.6702 /* V6, ν = 0.3 */

typedef struct sph_result {
    double period;     /* measured from q(t) */
    double period_raw; /* from the mean radial displacement, for information */
    int crossings, crossings_raw;
    double ms;
    long particles;
} sph_result;

static sph_result run_sphere(int res, kf_force force, double periods, double z) {
    sph_result out = {0};
    const double a = SPH_A, dx = a / res, h = dx / 2;
    const double cp = sqrt(SPH_E * (1 - SPH_NU) / ((1 + SPH_NU) * (1 - 2 * SPH_NU)) / SPH_RHO);
    const double T = 2 * EV_PI * a / (z * cp);
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = dx;
    sd.gravity[0] = sd.gravity[1] = sd.gravity[2] = 0;
    sd.force = force;
    sd.walls = 0;
    sd.dt_fixed = SPH_CFL * dx / cp;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    KT_CHECK(m != NULL, "model: %s", err);
    if (!m) return out;
    kf_material mat = {0};
    snprintf(mat.name, sizeof mat.name, "sphere");
    mat.model = KF_MAT_COROTATED;
    mat.density = SPH_RHO;
    mat.E = SPH_E;
    mat.nu = SPH_NU;
    int id = kf_model_add_material(m, &mat, err, sizeof err);
    KT_CHECK(id >= 0, "material: %s", err);
    kf_state *s = kf_state_create(m);

    /* reference lattice about c = 0, stretched by F₀ */
    double *X, *x, *F;
    size_t n = ev_sphere_lattice(a, h, SPH_STRETCH, &X, &x, &F);
    long first = kf_state_add_particles(s, m, n, x, NULL, F, id, h * h * h);
    KT_CHECK(first == 0, "seeding %zu particles", n);
    /* per id: the mode-shape weight m r̂ j₁(z r/a) and the unit radial direction */
    double *w = malloc(3 * n * sizeof *w), *rh = malloc(3 * n * sizeof *rh);
    double mtot = 0;
    for (size_t p = 0; p < n; p++) {
        double r = sqrt(X[3 * p] * X[3 * p] + X[3 * p + 1] * X[3 * p + 1] + X[3 * p + 2] * X[3 * p + 2]);
        double mp = SPH_RHO * h * h * h, phi = ev_sph_j1(z * r / a);
        for (int e = 0; e < 3; e++) rh[3 * p + e] = X[3 * p + e] / r, w[3 * p + e] = mp * phi * X[3 * p + e] / r;
        mtot += mp;
    }
    free(x), free(F);

    const double dt = sd.dt_fixed;
    const long steps = (long)(periods * T / dt + 0.5);
    double tc[16], tr[16], qprev = 0, uprev = 0, tprev = 0;
    int nc = 0, nr = 0;
    double t0 = kf_now_ms();
    for (long step = 0; step <= steps; step++) {
        if (step > 0 && kf_step(m, s, dt, NULL, NULL)) {
            KT_CHECK(0, "numerical trouble at step %ld", step);
            break;
        }
        kf_particles_view pv = kf_state_particles(s);
        double q = 0, ur = 0;
#pragma omp parallel for reduction(+ : q, ur)
        for (size_t p = 0; p < pv.n; p++) {
            uint32_t i = pv.id[p];
            double u[3];
            for (int e = 0; e < 3; e++) u[e] = (double)pv.x[e][p] - X[3 * i + e];
            q += w[3 * i] * u[0] + w[3 * i + 1] * u[1] + w[3 * i + 2] * u[2];
            ur += (double)pv.mass[p] * (rh[3 * i] * u[0] + rh[3 * i + 1] * u[1] + rh[3 * i + 2] * u[2]);
        }
        ur /= mtot;
        double t = kf_state_time(s);
        if (step > 0) {
            ev_crossing(qprev, tprev, q, t, tc, &nc);
            ev_crossing(uprev, tprev, ur, t, tr, &nr);
        }
        qprev = q, uprev = ur, tprev = t;
    }
    out.ms = kf_now_ms() - t0;
    out.particles = (long)n;
    out.crossings = nc;
    out.crossings_raw = nr;
    double half;
    half = ev_slope(nc, tc);
    out.period = 2 * half;
    half = ev_slope(nr, tr);
    out.period_raw = 2 * half;
    free(X), free(w), free(rh);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return out;
}

static double cp_of(void) { return sqrt(SPH_E * (1 - SPH_NU) / ((1 + SPH_NU) * (1 - 2 * SPH_NU)) / SPH_RHO); }

/* ω a / c_p from a measured period */
static double za_of(double period) { return 2 * EV_PI / period * SPH_A / cp_of(); }

/* each (resolution, force) runs once, for 1.3 periods: q crosses zero at
 * T/4, 3T/4 and 5T/4 */
static sph_result cached(int res, kf_force force) {
    static sph_result memo[2][2];
    static int have[2][2];
    int i = res == 16, f = force == KF_FORCE_CLASSIC;
    if (!have[i][f]) {
        memo[i][f] = run_sphere(res, force, 1.3, ev_breathing_root(SPH_NU));
        have[i][f] = 1;
        const sph_result *r = &memo[i][f];
        double za = za_of(r->period), zr = za_of(r->period_raw);
        printf("  %-7s a/dx=%2d: %ld particles, %d crossings, wa/c_p = %.5f (error %+.3f%%); "
               "mean radial displacement alone: %.5f (%+.3f%%, %d crossings); %.2f s\n",
               f ? "classic" : "mls", res, r->particles, r->crossings, za, 100 * (za / SPH_Z_REF - 1), zr,
               100 * (zr / SPH_Z_REF - 1), r->crossings_raw, r->ms / 1e3);
    }
    return memo[i][f];
}

/* the frequency equation as coded reproduces the V6 table value; the table
 * rounds to 4 decimals, so agreement within 5e-5 */
static void sphere_root(void) {
    KT_NEAR(ev_breathing_root(SPH_NU), SPH_Z_REF, 5e-5, "first radial root for nu = 0.3 is 2.6702 (4 decimals)");
    KT_NEAR(ev_breathing_root(0.2), 2.4605, 5e-5, "first radial root for nu = 0.2 is 2.4605 (4 decimals)");
    KT_NEAR(ev_breathing_root(0.4), 2.8966, 5e-5, "first radial root for nu = 0.4 is 2.8966 (4 decimals)");
}

static void check_sphere(int res, kf_force force, double tight, const char *why, const char *why_tight) {
    sph_result r = cached(res, force);
    KT_CHECK(r.crossings == 3, "1.3 periods of q(t) should cross zero 3 times, got %d", r.crossings);
    KT_NEAR(za_of(r.period), SPH_Z_REF, 0.01 * SPH_Z_REF, why);
    KT_NEAR(za_of(r.period), SPH_Z_REF, tight * SPH_Z_REF, why_tight);
}

/* V6: ω a/c_p = 2.6702 within 1% at a/Δx = 16; the solver does better, and
 * is held to about twice its measured error: -0.258% (MLS), -0.314% (classic)
 * -> 0.52% and 0.63% (deterministic: float, fixed lattice, fixed step) */
static void sphere_mls(void) {
    check_sphere(16, KF_FORCE_MLS, 0.0052, "V6: breathing frequency within 1% at a/dx = 16 (MLS)",
                 "within 2x the measured -0.258% at a/dx = 16 (MLS)");
}

static void sphere_classic(void) {
    check_sphere(16, KF_FORCE_CLASSIC, 0.0063, "V6: breathing frequency within 1% at a/dx = 16 (classic force)",
                 "within 2x the measured -0.314% at a/dx = 16 (classic)");
}

/* the frequency error falls from a/Δx = 8 to 16. Only a decrease is demanded
 * (measured: about 4x, second order): at a/Δx = 8 the error is already near
 * 1% and the lattice's fit of the sphere changes irregularly with Δx, so a
 * tight order window on two points would be fragile. */
static void sphere_convergence(void) {
    for (int f = 0; f < 2; f++) {
        kf_force force = f ? KF_FORCE_CLASSIC : KF_FORCE_MLS;
        double e8 = fabs(za_of(cached(8, force).period) / SPH_Z_REF - 1);
        double e16 = fabs(za_of(cached(16, force).period) / SPH_Z_REF - 1);
        printf("  %-7s error %.3e (a/dx=8) -> %.3e (a/dx=16), ratio %.2f\n", f ? "classic" : "mls", e8, e16, e8 / e16);
        KT_CHECK(e16 < e8, "V6: frequency error must fall with refinement: %g at a/dx=8, %g at 16", e8, e16);
        /* a ratio alone passes a uniform rise of the error: the coarse error
         * is held to about twice its measured value too (1.00% MLS, 1.18%
         * classic; the fine one in sphere_mls/classic), and the fall to better
         * than first order (measured ratios 3.89 and 3.75, second order 4) */
        KT_NEAR(e8, 0, f ? 0.024 : 0.020,
                "frequency error at a/dx = 8 within 2x the measured (1.00% MLS, 1.18% classic)");
        KT_CHECK(e8 / e16 > 2.0, "error ratio from a/dx = 8 to 16 above first order's 2 (measured 3.9, 3.75): %.2f",
                 e8 / e16);
    }
}

int main(int argc, char **argv) {
    KT_RUN(sphere_root, argc, argv);
    KT_RUN(sphere_mls, argc, argv);
    KT_RUN(sphere_classic, argc, argv);
    KT_RUN(sphere_convergence, argc, argv);
    return KT_EXIT();
}
