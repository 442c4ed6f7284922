/* test_bar.c — V4, the free–free axial bar.
 *
 * A bar of length 2L along x, E = 100, ν = 0, ρ = 1, L = 25, so
 * c = √((λ+2μ)/ρ) = √E = 10 and the first free–free period is T₁ = 4L/c = 10.
 * It starts in its first mode, v_x = v₀ sin(π(ξ−L)/(2L)) with ξ ∈ [0, 2L] the
 * distance from the left end and v₀ = 0.1: the two halves move apart, then
 * together. We measure the period of the centre-of-mass velocity of the left
 * half, V(t) = V₀ cos(2πt/T), from its zero crossings (t = T/4, 3T/4, ...).
 *
 * Why this is a clean 1-D problem in 3-D: with ν = 0 (λ = 0) and F = diag(f,1,1)
 * the fixed corotated first Piola stress is P = 2μ(F − R) = diag(2μ(f − 1), 0, 0),
 * exactly linear in the stretch, with no lateral stress; particles sit on a
 * tensor lattice and the velocity depends on x only, so mass, momentum and
 * force on the grid factor into x times (y, z) parts and every grid column
 * carries the same x-velocity. A cross-section of 2 x 2 cells is therefore
 * enough, with no gravity and no walls.
 *
 * Time step: fixed, at CFL number C = Δt c/Δx = 0.3 (quadratic limit ≈ 1.1,
 * §4). Symplectic Euler's own period error, (ωΔt)²/24 with ω = 2π/T (it
 * shortens the period), is 1.5e-5 at L/Δx = 25 and 3.7e-6 at 50: negligible
 * next to 0.5%, a few % of the measured (positive) spatial error, and
 * itself ∝ Δx² at fixed CFL, so it does not disturb the observed order.
 * The run lasts 2.6 T₁, which gives 5 zero crossings (T/4 ... 9T/4).
 *
 * Checks:
 *   - period error ≤ 0.5% at L/Δx = 50, MLS and classic force (the V4 bound);
 *   - the error falls ~Δx² from L/Δx = 25 to 50: the observed order
 *     p = log2(e₂₅/e₅₀) must lie in [1.5, 2.5] for both forces.
 *
 * Measured (Release, commit f107390, float; the double build gives +0.0105%
 * and +0.0137%): period error +0.0107% (MLS) and +0.0137% (classic) at L/Δx = 50;
 * +0.0414% / +0.0530% at 25, i.e. observed order 1.95 / 1.96; at L/Δx = 100
 * (not run here) +0.0027% / +0.0020%. Each L/Δx = 50 run is 3200 particles x
 * 1734 steps, about 0.5 s on 2 threads; the file runs in ~1.5 s. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>

#include "core/timer.h"
#include <kerf/kerf.h>
#include "kt.h"

#define PI 3.14159265358979323846

#define BAR_L 25.0
#define BAR_E 100.0
#define BAR_RHO 1.0
#define BAR_V0 0.1
#define BAR_C 10.0  /* √(E/ρ) with ν = 0 */
#define BAR_T1 10.0 /* 4L/c */
#define BAR_CFL 0.3
#define BAR_THICK 2 /* cells across y and z */
#define BAR_PPC 2   /* particles per cell per axis */

typedef struct bar_result {
    double period;  /* measured */
    int crossings;  /* zero crossings used */
    double v_half0; /* V(0) of the left half */
    double ms;      /* wall time of the stepping loop */
    long particles;
    int res;
} bar_result;

/* Run the bar at L/Δx = res with the given force; periods = how long to run
 * in units of T₁. Returns the period from a least-squares line through the
 * zero crossings of V(t) (crossing k at t = T/4 + kT/2). */
static bar_result run_bar(int res, kf_force force, double periods) {
    bar_result out = {0};
    out.res = res;
    const double L = BAR_L, dx = L / res, h = dx / BAR_PPC;
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = dx;
    sd.gravity[0] = sd.gravity[1] = sd.gravity[2] = 0;
    sd.force = force;
    sd.walls = 0;
    sd.dt_fixed = BAR_CFL * dx / BAR_C;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    KT_CHECK(m != NULL, "model: %s", err);
    if (!m) return out;
    kf_material mat = {0};
    snprintf(mat.name, sizeof mat.name, "bar");
    mat.model = KF_MAT_COROTATED;
    mat.density = BAR_RHO;
    mat.E = BAR_E;
    mat.nu = 0;
    int id = kf_model_add_material(m, &mat, err, sizeof err);
    KT_CHECK(id >= 0, "material: %s", err);
    kf_state *s = kf_state_create(m);

    /* The bar spans x ∈ [−L, L] (centred on the origin to halve the float
     * rounding of positions), y, z ∈ [−THICK Δx/2, THICK Δx/2]; ξ = x + L. */
    const long nx = (long)(2 * L / h + 0.5), ny = BAR_THICK * BAR_PPC;
    const long n = nx * ny * ny;
    double *x = malloc(3 * n * sizeof *x), *v = malloc(3 * n * sizeof *v);
    double *C = malloc(9 * n * sizeof *C);
    long k = 0;
    for (long i = 0; i < nx; i++)
        for (long j = 0; j < ny; j++)
            for (long l = 0; l < ny; l++, k++) {
                double px = -L + (i + 0.5) * h;
                x[3 * k] = px;
                x[3 * k + 1] = -0.5 * ny * h + (j + 0.5) * h;
                x[3 * k + 2] = -0.5 * ny * h + (l + 0.5) * h;
                double xi = px + L, arg = PI * (xi - L) / (2 * L);
                v[3 * k] = BAR_V0 * sin(arg);
                v[3 * k + 1] = v[3 * k + 2] = 0;
                /* APIC's affine velocity starts as the field's gradient */
                for (int e = 0; e < 9; e++) C[9 * k + e] = 0;
                C[9 * k] = BAR_V0 * PI / (2 * L) * cos(arg);
            }
    long first = kf_state_add_particles(s, m, n, x, v, NULL, id, h * h * h);
    KT_CHECK(first == 0, "seeding %ld particles", n);
    /* a fresh state numbers particles 0..n−1 in seeding order: id = k */
    kf_particles_view pv = kf_state_particles(s);
    for (size_t p = 0; p < pv.n; p++)
        for (int e = 0; e < 9; e++) pv.C[e][p] = (kf_real)C[9 * pv.id[p] + e];
    /* the left half, by stable id: ξ < L at t = 0 */
    uint8_t *left = malloc(n);
    for (long q = 0; q < n; q++) left[q] = x[3 * q] < 0;
    free(x), free(v), free(C);

    const double dt = sd.dt_fixed;
    const long steps = (long)(periods * BAR_T1 / dt + 0.5);
    double prev = 0, tprev = 0;
    double sk = 0, st = 0, skk = 0, skt = 0;
    int nc = 0;
    double t0 = kf_now_ms();
    for (long step = 0; step <= steps; step++) {
        if (step > 0 && kf_step(m, s, dt, NULL, NULL)) {
            KT_CHECK(0, "numerical trouble at step %ld", step);
            break;
        }
        pv = kf_state_particles(s);
        double mv = 0, mm = 0;
        for (size_t p = 0; p < pv.n; p++)
            if (left[pv.id[p]]) mv += (double)pv.mass[p] * pv.v[0][p], mm += pv.mass[p];
        double V = mv / mm, t = kf_state_time(s);
        if (step == 0) out.v_half0 = V;
        /* a sign change between samples: linear interpolation, which is
         * accurate to O(Δt³) here because V'' = 0 at a zero of a cosine */
        if (step > 0 && ((prev < 0 && V >= 0) || (prev > 0 && V <= 0))) {
            double tc = tprev + (t - tprev) * prev / (prev - V);
            sk += nc, st += tc, skk += (double)nc * nc, skt += nc * tc;
            nc++;
        }
        prev = V, tprev = t;
    }
    out.ms = kf_now_ms() - t0;
    out.crossings = nc;
    out.particles = n;
    if (nc >= 2) {
        double half = (nc * skt - sk * st) / (nc * skk - sk * sk); /* slope = T/2 */
        out.period = 2 * half;
    }
    free(left);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return out;
}

static void report(const char *what, int res, const bar_result *r) {
    printf("  %-8s L/dx=%3d: %ld particles, %d crossings, T = %.6f, error %+.4f%%, %.2f s\n", what, res, r->particles,
           r->crossings, r->period, 100 * (r->period / BAR_T1 - 1), r->ms / 1e3);
}

/* each (resolution, force) is run once and shared by the cases below */
static bar_result cached(int res, kf_force force) {
    static bar_result memo[2][2];
    static int have[2][2];
    int i = res == 50, f = force == KF_FORCE_CLASSIC;
    if (res != 25 && res != 50) return run_bar(res, force, 2.6);
    if (!have[i][f]) {
        memo[i][f] = run_bar(res, force, 2.6);
        have[i][f] = 1;
        report(f ? "classic" : "mls", res, &memo[i][f]);
    }
    return memo[i][f];
}

static double rel_error(const bar_result *r) { return fabs(r->period / BAR_T1 - 1); }

static void check_run(const bar_result *r) {
    /* 2.6 periods of cos(2πt/T) cross zero at T/4, 3T/4, ..., 9T/4: exactly 5;
     * another count means the signal is not the first mode */
    KT_CHECK(r->crossings == 5, "expected 5 zero crossings of the half's velocity, got %d", r->crossings);
    /* V(0) is the mean of v₀ sin over the half's lattice: the midpoint sum
     * gives −(2v₀/π)·(δ/2)/sin(δ/2) exactly, δ = πh/(2L) the phase step.
     * Velocities are rounded to float (6e-8 relative) and summed in double,
     * so 1e-6 relative checks the initial condition with a wide margin. */
    double d = PI * (BAR_L / r->res / BAR_PPC) / (2 * BAR_L), v0 = -2 * BAR_V0 / PI * (d / 2) / sin(d / 2);
    KT_NEAR(r->v_half0, v0, 1e-6 * fabs(v0), "initial V of the left half: the seeded first mode");
}

/* V4: period within 0.5% at L/Δx = 50. The
 * solver does far better, and a regression to even a few times its error
 * should fail: measured +0.0106% (MLS) and +0.0137% (classic), held to about
 * twice that, 0.022% and 0.028%. The error is deterministic (float, fixed
 * seeding, a fixed CFL step); other CPUs move it in the 4th digit. */
static void bar_mls(void) {
    bar_result r = cached(50, KF_FORCE_MLS);
    check_run(&r);
    KT_NEAR(r.period, BAR_T1, 0.005 * BAR_T1, "V4: period error <= 0.5% at L/dx = 50 (MLS force)");
    KT_NEAR(r.period, BAR_T1, 2.2e-4 * BAR_T1, "period error within 2x the measured +0.0106% at L/dx = 50 (MLS)");
}

static void bar_classic(void) {
    bar_result r = cached(50, KF_FORCE_CLASSIC);
    check_run(&r);
    KT_NEAR(r.period, BAR_T1, 0.005 * BAR_T1, "V4: period error <= 0.5% at L/dx = 50 (classic force)");
    KT_NEAR(r.period, BAR_T1, 2.8e-4 * BAR_T1, "period error within 2x the measured +0.0137% at L/dx = 50 (classic)");
}

/* V4: the error falls ~Δx². The observed order from L/Δx = 25 to 50 is held
 * to [1.5, 2.5]: second order is expected from the quadratic B-spline
 * discretisation of a smooth mode; the window allows for the few-1e-5
 * relative errors being measured (float round-off on the crossing times is
 * ~1e-7 relative, far below) and rejects first order (p = 1) or stagnation. */
static void bar_convergence(void) {
    for (int f = 0; f < 2; f++) {
        kf_force force = f ? KF_FORCE_CLASSIC : KF_FORCE_MLS;
        bar_result c = cached(25, force), r = cached(50, force);
        double e25 = rel_error(&c), e50 = rel_error(&r);
        double p = log(e25 / e50) / log(2.0);
        printf("  %-8s observed order %.2f (errors %.3e -> %.3e)\n", f ? "classic" : "mls", p, e25, e50);
        KT_CHECK(e50 < e25, "error must fall with refinement: %g at L/dx=25, %g at 50", e25, e50);
        KT_NEAR(p, 2.0, 0.5, "V4: period error falls ~dx^2 (observed order from L/dx = 25 to 50 in [1.5, 2.5])");
        /* the order is a ratio: a uniform rise of the error passes it, so the
         * coarse error is held too (measured 4.13e-4 MLS, 5.30e-4 classic) */
        KT_NEAR(e25, 0, f ? 1.1e-3 : 8.3e-4,
                "period error at L/dx = 25 within 2x the measured (4.13e-4 MLS, 5.30e-4 classic)");
    }
}

int main(int argc, char **argv) {
    KT_RUN(bar_mls, argc, argv);
    KT_RUN(bar_classic, argc, argv);
    KT_RUN(bar_convergence, argc, argv);
    return KT_EXIT();
}
