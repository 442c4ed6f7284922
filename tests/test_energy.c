/* test_energy.c — V7, the oscillating stretched cube.
 *
 * A free cube of rest side 1 (fixed corotated, E = 1e3, ν = 0.3, ρ = 1, no
 * gravity, no walls) starts at rest, stretched uniformly by F₀ = 1.1·I, and
 * oscillates. Particles sit on a reference lattice of spacing h = Δx/2 with
 * reference volume h³ and start at x = 1.1 X, F = 1.1 I. Fixed step at CFL
 * number C = Δt c_p/Δx = 0.3 (production range, §4), so Δt ∝ Δx when refining.
 * Two resolutions, 8 and 16 cells across the rest cube (4096 and 32768
 * particles), each with MLS and classic force, over t ∈ [0, 0.15] ≈ 3.1
 * periods of the fundamental (T ≈ 0.047–0.048, measured from the zero
 * crossings of the dilatation Σ m (x − X)·X after the first, which the
 * release transient distorts).
 *
 * Which energy never increases. The V7 quantity is E = ΣV₀ψ(F) + Σ½m|v|².
 * Sampled at the end of each step (kf_state_energy: v^{n+1}, F^{n+1}) it
 * does NOT decrease monotonically step by step: measured, it rises by up to
 * 4.3% of E₀ in one step (res 8, CFL 0.3, during the release) and over
 * stretches up to ~0.4 T long. This is the time integrator, not an energy
 * source: symplectic Euler conserves a modified energy, and the plain energy
 * oscillates about it with relative amplitude ~ωΔt/2 (3.4% at res 16,
 * 6.7% at res 8), i.e. per-step rises of O(Δt²) — halving Δt cuts the
 * largest rise by 3.4x.
 * The discrete energy that APIC + symplectic Euler actually dissipate is
 *     S_n = Σ½m(|v_n|² + tr(C_n D C_nᵀ)) + ½(ΣV₀ψ(F_{n−1}) + ΣV₀ψ(F_n)),
 * the kinetic energy including APIC's affine part (D = Δx²/4 I, as in V3's
 * angular momentum) at the velocity that moved F_{n−1} to F_n, with the
 * strain energy averaged over the two ends of that move (the analogue of the
 * x_n·x_{n+1} term in the exactly conserved energy of symplectic Euler for a
 * linear oscillator). S_n needs F_{n−1}, so it is defined from n = 1 on.
 * From then, S never increases by more than round-off in any step of any
 * run here (its smallest per-step drop is measured below). The first step
 * from rest is not comparable: S₁ − E₀ is +0.9% E₀ at res 8 because the
 * release loads grid-scale modes, for which the two-point average of ψ
 * exceeds the conserved x_n·x_{n+1}-type term by (ω_h Δt)²/4 of their
 * kinetic energy. So the tests assert:
 *   1. S_n ≤ S_{n−1} + 1e-6 E₀ at every step n ≥ 2 (round-off only);
 *   2. the V7 quantity E never exceeds E₀, decreases from period to period
 *      (sampled at t = kT), and its per-step rises shrink ≥ 2.5x when Δt
 *      halves (Δt² predicts 4x; measured 3.4x);
 *   3. dissipation per period falls as Δx shrinks;
 *   4. MLS and classic force dissipate nearly equally (see the case).
 *
 * Measured (Release, commit f107390, float; double agrees to 4 digits):
 * E₀ = 43.1426; period T = 0.0469 (res 8) / 0.0479 (res 16); S after 0.15 s
 * 7.05 / 20.69 (MLS), 6.34 / 19.51 (classic); largest one-step rise of E
 * 4.3% / 2.1% of E₀ (MLS), of S (n ≥ 2) −1.5e-4 / −1.1e-4 E₀ (i.e. S drops
 * every step). The file runs in ~4 s on 2 threads. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "core/timer.h"
#include <kerf/kerf.h>
#include "kt.h"

#define CUBE_RHO 1.0
#define CUBE_E 1000.0
#define CUBE_NU 0.3
#define CUBE_STRETCH 1.1
#define CUBE_CFL 0.3
#define CUBE_TEND 0.15

/* round-off allowance per step, relative to E₀: the state is float (u = 6e-8)
 * and ψ depends on F − R ≈ 0.1, so one particle's ψ carries ~10 u relative
 * error; sums run in double over ~1e4 particles with random-sign errors.
 * 1e-6 is ~15 u: above the evaluation noise, 4 orders below the O(Δt²)
 * rises of the plain energy that this tolerance must not hide, and 100x
 * below the smallest per-step drop of S that was measured (1.06e-4 E₀,
 * res 16 MLS), so it decides nothing but round-off. */
#define ROUNDOFF 1e-6

typedef struct cube_run {
    int res, ok;
    kf_force force;
    double cfl;
    long steps, n;
    double *E; /* V7: elastic + kinetic (kf_state_energy) */
    double *S; /* staggered, with APIC's affine kinetic energy */
    double *t;
    double T; /* measured period of the fundamental */
    double ms;
} cube_run;

static double cube_cp(void) { return sqrt(CUBE_E * (1 - CUBE_NU) / ((1 + CUBE_NU) * (1 - 2 * CUBE_NU)) / CUBE_RHO); }

static cube_run run_cube(int res, kf_force force, double cfl, double duration) {
    cube_run out = {0};
    out.res = res, out.force = force, out.cfl = cfl;
    const double dx = 1.0 / res, h = dx / 2, d = dx * dx / 4; /* D = d I for the quadratic kernel */
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = dx;
    sd.gravity[0] = sd.gravity[1] = sd.gravity[2] = 0;
    sd.force = force;
    sd.kernel = KF_KERNEL_QUADRATIC;
    sd.transfer = KF_TRANSFER_APIC;
    sd.dt_fixed = cfl * dx / cube_cp();
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    KT_CHECK(m != NULL, "model: %s", err);
    if (!m) return out;
    kf_material mat = {0};
    snprintf(mat.name, sizeof mat.name, "cube");
    mat.model = KF_MAT_COROTATED;
    mat.density = CUBE_RHO;
    mat.E = CUBE_E;
    mat.nu = CUBE_NU;
    int id = kf_model_add_material(m, &mat, err, sizeof err);
    KT_CHECK(id >= 0, "material: %s", err);
    kf_state *s = kf_state_create(m);

    /* rest lattice: 2·res particles per side, centred on the origin */
    const int N = res;
    const size_t n = (size_t)8 * N * N * N;
    double *X = malloc(3 * n * sizeof *X), *x = malloc(3 * n * sizeof *x), *F = malloc(9 * n * sizeof *F);
    size_t k = 0;
    for (int i = -N; i < N; i++)
        for (int j = -N; j < N; j++)
            for (int l = -N; l < N; l++, k++) {
                double q[3] = {(i + 0.5) * h, (j + 0.5) * h, (l + 0.5) * h};
                for (int e = 0; e < 3; e++) X[3 * k + e] = q[e], x[3 * k + e] = CUBE_STRETCH * q[e];
                for (int e = 0; e < 9; e++) F[9 * k + e] = e % 4 == 0 ? CUBE_STRETCH : 0;
            }
    long first = kf_state_add_particles(s, m, n, x, NULL, F, id, h * h * h);
    KT_CHECK(first == 0, "seeding %zu particles", n); /* fresh state: id = k */
    free(x), free(F);

    const double dt = sd.dt_fixed;
    out.steps = (long)(duration / dt + 0.5);
    out.n = (long)n;
    out.E = malloc((out.steps + 1) * sizeof(double));
    out.S = malloc((out.steps + 1) * sizeof(double));
    out.t = malloc((out.steps + 1) * sizeof(double));
    double tc[64], sig_prev = 0, P_prev = 0, t0 = kf_now_ms();
    int nc = 0;
    out.ok = 1;
    for (long st = 0; st <= out.steps; st++) {
        if (st > 0 && kf_step(m, s, dt, NULL, NULL)) {
            KT_CHECK(0, "numerical trouble at step %ld", st);
            out.ok = 0;
            out.steps = st - 1;
            break;
        }
        kf_energy e = kf_state_energy(m, s);
        kf_particles_view pv = kf_state_particles(s);
        double sig = 0, ka = 0;
        for (size_t p = 0; p < pv.n; p++) {
            const uint32_t i = pv.id[p];
            double c2 = 0;
            for (int c = 0; c < 9; c++) c2 += (double)pv.C[c][p] * pv.C[c][p];
            ka += 0.5 * pv.mass[p] * d * c2;
            for (int c = 0; c < 3; c++) sig += pv.mass[p] * ((double)pv.x[c][p] - X[3 * i + c]) * X[3 * i + c];
        }
        out.t[st] = kf_state_time(s);
        out.E[st] = e.kinetic + e.elastic;
        /* S₀ := E₀ (at rest), used only as the start of the loss per period */
        out.S[st] = st == 0 ? out.E[0] : e.kinetic + ka + 0.5 * (P_prev + e.elastic);
        P_prev = e.elastic;
        if (st > 0 && ((sig_prev > 0 && sig <= 0) || (sig_prev < 0 && sig >= 0)) && nc < 64)
            tc[nc++] = out.t[st - 1] + dt * sig_prev / (sig_prev - sig);
        sig_prev = sig;
    }
    out.ms = kf_now_ms() - t0;
    /* crossings 2.. are half a period apart: least-squares slope = T/2 */
    double sk = 0, stt = 0, skk = 0, skt = 0;
    int nf = nc - 1;
    for (int c = 0; c < nf; c++) sk += c, stt += tc[c + 1], skk += (double)c * c, skt += c * tc[c + 1];
    out.T = nf >= 2 ? 2 * (nf * skt - sk * stt) / (nf * skk - sk * sk) : 0;
    KT_CHECK(nf >= 4, "res %d: expected >= 5 zero crossings of the dilatation in %.2f s, got %d", res, duration, nc);
    free(X);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return out;
}

/* largest one-step rise of a series from step `from` on, relative to E₀ */
static double max_rise_from(const double *y, long from, long steps, double E0) {
    double r = -1e300;
    for (long st = from; st <= steps; st++)
        if (y[st] - y[st - 1] > r) r = y[st] - y[st - 1];
    return r / E0;
}

static double max_rise(const double *y, long steps, double E0) { return max_rise_from(y, 1, steps, E0); }

/* S_n needs F_{n−1}, so it is defined from n = 1 and compared from n = 2 on */
static double max_rise_S(const cube_run *r) { return max_rise_from(r->S, 2, r->steps, r->E[0]); }

/* fraction of the energy S lost per period over the run */
static double loss_per_period(const cube_run *r) { return 1 - pow(r->S[r->steps] / r->S[0], r->T / r->t[r->steps]); }

/* the series at t = kT, by linear interpolation */
static double at_time(const cube_run *r, const double *y, double tk) {
    if (tk <= r->t[0]) return y[0];
    for (long st = 0; st < r->steps; st++)
        if (r->t[st + 1] >= tk) {
            double u = (tk - r->t[st]) / (r->t[st + 1] - r->t[st]);
            return y[st] + u * (y[st + 1] - y[st]);
        }
    return y[r->steps];
}

static cube_run runs[2][2]; /* [res 8, 16][MLS, classic] at CFL 0.3 */
static int have[2][2];

static const cube_run *cached(int res, kf_force force) {
    int i = res == 16, f = force == KF_FORCE_CLASSIC;
    if (!have[i][f]) {
        runs[i][f] = run_cube(res, force, CUBE_CFL, CUBE_TEND);
        have[i][f] = 1;
        const cube_run *r = &runs[i][f];
        printf("  %-7s res %2d: %ld particles, %ld steps, T = %.5f, E0 = %.4f, E(end) = %.4f, S(end) = %.4f, "
               "loss/period %.4f; largest step rise: E %+.2e, S %+.2e (x E0; S1 - E0 = %+.2e); %.2f s\n",
               f ? "classic" : "mls", res, r->n, r->steps, r->T, r->E[0], r->E[r->steps], r->S[r->steps],
               loss_per_period(r), max_rise(r->E, r->steps, r->E[0]), max_rise_S(r), (r->S[1] - r->E[0]) / r->E[0],
               r->ms / 1e3);
    }
    return &runs[i][f];
}

/* 1. the discrete energy S never increases, to round-off, in any step */
static void energy_never_increases(void) {
    for (int i = 0; i < 2; i++)
        for (int f = 0; f < 2; f++) {
            const cube_run *r = cached(i ? 16 : 8, f ? KF_FORCE_CLASSIC : KF_FORCE_MLS);
            if (!r->ok) continue;
            printf("  %-7s res %2d: largest one-step change of S (n >= 2) %+.3e E0\n", f ? "classic" : "mls", r->res,
                   max_rise_S(r));
            KT_NEAR(fmax(max_rise_S(r), 0), 0, ROUNDOFF,
                    "V7: the discrete energy S never rises in a step by more than float round-off (1e-6 E0)");
        }
}

/* 2. the V7 quantity itself: bounded by E₀, decreasing period to period, and
 * its in-period rises are a Δt-consistent integration error */
static void energy_v7_quantity(void) {
    for (int i = 0; i < 2; i++)
        for (int f = 0; f < 2; f++) {
            const cube_run *r = cached(i ? 16 : 8, f ? KF_FORCE_CLASSIC : KF_FORCE_MLS);
            if (!r->ok) continue;
            double emax = -1e300;
            for (long st = 1; st <= r->steps; st++) emax = fmax(emax, r->E[st]);
            /* never above the initial energy (round-off as in ROUNDOFF) */
            KT_NEAR(fmax(emax, r->E[0]), r->E[0], ROUNDOFF * r->E[0],
                    "V7: elastic + kinetic never exceeds its initial value");
            /* once per period it is strictly lower: the O(ωΔt) oscillation
             * has the period T/2, so samples a whole period apart see the
             * dissipation (measured: 20-50% lost per period) */
            double prev = r->E[0];
            for (int k = 1; k * r->T <= r->t[r->steps]; k++) {
                double ek = at_time(r, r->E, k * r->T);
                KT_CHECK(ek < prev, "V7 (%s, res %d): E(%dT) = %.5g not below E(%dT) = %.5g", f ? "classic" : "mls",
                         r->res, k, ek, k - 1, prev);
                prev = ek;
            }
        }
    /* the per-step rises of E are O(Δt²): halving Δt (same Δx = 1/8, MLS)
     * must cut the largest one by >= 2.5x (4x predicted for a smooth
     * oscillation; measured 3.4x, the largest rise being in the nonlinear
     * release transient) */
    const cube_run *a = cached(8, KF_FORCE_MLS);
    cube_run b = run_cube(8, KF_FORCE_MLS, CUBE_CFL / 2, CUBE_TEND);
    if (a->ok && b.ok) {
        double ra = max_rise(a->E, a->steps, a->E[0]), rb = max_rise(b.E, b.steps, b.E[0]);
        printf("  mls     res  8: largest one-step rise of E: %.3e E0 at CFL %.2f, %.3e E0 at CFL %.2f (ratio %.2f); "
               "S: %+.2e E0\n",
               ra, CUBE_CFL, rb, CUBE_CFL / 2, ra / rb, max_rise_S(&b));
        KT_CHECK(ra >= 2.5 * rb, "V7: per-step rises of E should shrink like dt^2: %.3e at CFL %.2f, %.3e at %.2f", ra,
                 CUBE_CFL, rb, CUBE_CFL / 2);
        KT_NEAR(fmax(max_rise_S(&b), 0), 0, ROUNDOFF,
                "V7: S never rises in a step by more than float round-off (1e-6 E0), also at half the step");
    }
    free(b.E), free(b.S), free(b.t);
}

/* 3. dissipation per period falls as Δx shrinks (Δt ∝ Δx at fixed CFL).
 * Measured loss per period of S: 0.432 → 0.209 (MLS), 0.452 → 0.224
 * (classic) from 8 to 16 cells: about halved (x0.48, x0.50). We require a
 * fall to at most 0.7x, which first-order convergence of the loss (0.5x)
 * passes with margin and no convergence (1x) fails. */
static void energy_dissipation_falls(void) {
    for (int f = 0; f < 2; f++) {
        kf_force force = f ? KF_FORCE_CLASSIC : KF_FORCE_MLS;
        const cube_run *c = cached(8, force), *r = cached(16, force);
        if (!c->ok || !r->ok) continue;
        double l8 = loss_per_period(c), l16 = loss_per_period(r);
        printf("  %-7s loss per period %.4f (res 8) -> %.4f (res 16), ratio %.3f\n", f ? "classic" : "mls", l8, l16,
               l16 / l8);
        KT_CHECK(l16 <= 0.7 * l8, "V7: dissipation per period must fall with dx: %.4f at res 8, %.4f at res 16", l8,
                 l16);
    }
}

/* 4. MLS and classic force nearly equal (paper Fig. 17). "Nearly" as
 * measured here: the loss per period differs by 4.6% (res 8) and 7.2%
 * (res 16) of the loss itself (0.432 vs 0.452, 0.209 vs 0.224), and the S
 * histories differ by at most 3.6% / 4.5% of E₀ at any step (the two forces
 * give slightly different periods, 0.0479 vs 0.0480 at res 16, so the
 * histories drift in phase). We allow 15% relative on the loss per period
 * and 9% of E₀ on the histories, twice the largest measured difference;
 * a force that dissipated differently by a factor (e.g. a missing or doubled
 * stress term, which also shifts the period by 30% or more) is far outside. */
static void energy_mls_vs_classic(void) {
    for (int i = 0; i < 2; i++) {
        const cube_run *a = cached(i ? 16 : 8, KF_FORCE_MLS), *b = cached(i ? 16 : 8, KF_FORCE_CLASSIC);
        if (!a->ok || !b->ok) continue;
        double la = loss_per_period(a), lb = loss_per_period(b), dmax = 0;
        for (long st = 0; st <= a->steps && st <= b->steps; st++) dmax = fmax(dmax, fabs(a->S[st] - b->S[st]));
        dmax /= a->E[0];
        printf("  res %2d: loss per period MLS %.4f, classic %.4f (relative difference %.3f); max |S_mls - S_classic| "
               "= %.4f E0\n",
               a->res, la, lb, fabs(la - lb) / la, dmax);
        KT_NEAR(lb, la, 0.15 * la, "V7: MLS and classic lose energy at nearly the same rate (15% relative)");
        KT_NEAR(dmax, 0, 0.09, "V7: MLS and classic energy histories within 9% of E0 at every step");
    }
}

int main(int argc, char **argv) {
    KT_RUN(energy_never_increases, argc, argv);
    KT_RUN(energy_v7_quantity, argc, argv);
    KT_RUN(energy_dissipation_falls, argc, argv);
    KT_RUN(energy_mls_vs_classic, argc, argv);
    for (int i = 0; i < 2; i++)
        for (int f = 0; f < 2; f++) free(runs[i][f].E), free(runs[i][f].S), free(runs[i][f].t);
    return KT_EXIT();
}
