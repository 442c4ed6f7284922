/* test_material_batch.c — the batch stress path (mpm/material_batch.c)
 * against the per-particle reference kf_mat_update, for every model the
 * Hencky-strain models the batch path vectorises: von Mises and Drucker–Prager sand
 * (elastic, yielding and tension-tip states; with and without hardening,
 * volume correction and cohesion), and snow (clamped σ, Jp, hardening).
 *
 * In the float build the Hencky models run a float SVD (Jacobi on FᵀF)
 * with polynomial log/exp for particles whose σ all lie in the batch's
 * window, and the scalar path otherwise. The reference rounds a double SVD
 * to float, so both carry a few u (u = 6e-8) of absolute error in the
 * Hencky strain H ≈ log σ (σ ~ 1 in the window); the float eigen route adds
 * ε σ_max²/σ_min ≤ 3.4 u, and float B = F V, sqrt, log, exp and the
 * products U diag(·) Vᵀ add a few u each. The stated bounds, in units of u
 * (measured maxima over these samples: F 31 u, τ 13 u, ps 26 u):
 *   F (elastic part):  |ΔF_ij| ≤ 40 u = 2.4e-6  (entries O(1), σ ≤ 1.5)
 *   τ:                 |Δτ_ij| ≤ 16 u (2μ + 3λ) (the stress of a strain
 *                      error of a few u, plus τ's own rounding)
 *   ps (v_c, q):       |Δ| ≤ 40 u (1 + |ps|)    (v_c sums three logs and H)
 * i.e. a few 1e-6 relative to F and to the material's modulus, whatever
 * the size of the strain: an absolute error in H of a few u is inherent
 * (F itself is rounded to float), so small stresses are not compared
 * relative to themselves. Particles outside the window, and elastic
 * particles' F (no volume correction), must be bit-identical. Snow's
 * stress is compared in units of its hardened moduli, e^{ξ(1 − Jp)}
 * (2μ + 3λ) at the reference's Jp (measured: F 16 u, τ 11 u, Jp 8 u). The
 * double build runs the same batch path with library log/exp and the same
 * bounds in its own u (measured maxima: F 39 u, τ 15 u, ps 29 u). */
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "core/vmath.h"
#include "kt.h"
#include "mpm/material.h"

#ifdef KF_DOUBLE
#define U_ 1.1e-16
#else
#define U_ 6e-8
#endif

#define KT_RNG_SEED 0x9E3779B97F4A7C15ull
#include "random_util.h"

/* F = Q1 diag(s) Q2ᵀ; a third of them with Q1 = Q2 (symmetric: repeated
 * directions), a few with s exactly equal (degenerate) */
static void make_F(kf_real F[9], const double s[3]) {
    double Q1[9], Q2[9];
    random_rotation(Q1);
    if (urand() < 0.33) memcpy(Q2, Q1, sizeof Q2);
    else random_rotation(Q2);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double t = 0;
            for (int k = 0; k < 3; k++) t += Q1[3 * i + k] * s[k] * Q2[3 * j + k];
            F[3 * i + j] = (kf_real)t;
        }
}

enum { IN_WINDOW, OUTSIDE };

/* particles for snow: ps[0] is Jp */
static int snow_jp;

/* one particle: a strain scale picked to cover elastic, yielding and
 * tension-tip states, or (kind OUTSIDE) σ clearly outside [0.67, 1.5],
 * inverted, or NaN */
static int make_particle(kf_real F[9], kf_real ps[2], int with_vc, int with_q) {
    double s[3], r = urand();
    int kind = IN_WINDOW;
    if (r < 0.12) {
        kind = OUTSIDE;
        double t = urand();
        s[0] = 1 + 0.1 * srand1(), s[1] = 1 + 0.1 * srand1(), s[2] = 1 + 0.1 * srand1();
        if (t < 0.3) s[(int)(urand() * 3) % 3] = 0.3 + 0.3 * urand();          /* compressed */
        else if (t < 0.6) s[(int)(urand() * 3) % 3] = 1.6 + urand();           /* stretched */
        else if (t < 0.85) s[(int)(urand() * 3) % 3] = -(0.8 + 0.2 * urand()); /* inverted */
        else s[0] = NAN;
    } else {
        double amp = r < 0.3 ? 1e-4 : r < 0.5 ? 1e-3 : r < 0.75 ? 1e-2 : 0.15;
        double bias = urand() < 0.25 ? amp : 0; /* tension-tip states */
        for (int i = 0; i < 3; i++) {
            s[i] = exp(bias + amp * srand1());
            if (s[i] < 0.7) s[i] = 0.7;
            if (s[i] > 1.45) s[i] = 1.45;
        }
        if (urand() < 0.05) s[1] = s[2] = s[0];
    }
    make_F(F, s);
    if (snow_jp) {
        /* snow: Jp near 1, hardening factors e^{ξ(1 − Jp)} of 0.74 to 1.35 */
        ps[0] = (kf_real)(1 + 0.03 * srand1()), ps[1] = 0;
        return kind;
    }
    ps[0] = with_vc && urand() < 0.6 ? (kf_real)(0.02 * srand1()) : 0;
    ps[1] = with_q ? (kf_real)(urand() < 0.3 ? 0 : 3 * urand()) : 0;
    return kind;
}

typedef struct {
    double dF, dtau, dps; /* max deviations in units of u (scaled as above) */
    long n_in, n_out, n_elastic_same;
} stats;

static int same_bits(kf_real a, kf_real b) { return memcmp(&a, &b, sizeof a) == 0; }

/* run N particles through both paths from an offset first (so the batch
 * sees runs that do not start on a 16-particle boundary) */
static stats compare(const kf_mat *m, int project, int with_vc, int with_q, const char *what) {
    enum { N = 3000, OFF = 5 };
    static kf_real plane_F[9][N + OFF], plane_ps[2][N + OFF], plane_tau[6][N + OFF];
    static kf_real ref_F[N][9], ref_ps[N][2], ref_tau[N][9];
    static int kind[N];
    stats st = {0};
    for (int p = 0; p < N; p++) {
        kf_real F[9], ps[2];
        kind[p] = make_particle(F, ps, with_vc, with_q);
        for (int k = 0; k < 9; k++) plane_F[k][OFF + p] = ref_F[p][k] = F[k];
        for (int k = 0; k < 2; k++) plane_ps[k][OFF + p] = ref_ps[p][k] = ps[k];
        kf_mat_update(m, ref_F[p], ref_ps[p], project && m->plastic, ref_tau[p]);
    }
    kf_real *Fp[9], *pp[2], *tp[6];
    for (int k = 0; k < 9; k++) Fp[k] = plane_F[k];
    for (int k = 0; k < 2; k++) pp[k] = plane_ps[k];
    for (int k = 0; k < 6; k++) tp[k] = plane_tau[k] + OFF;
    /* runs of assorted lengths, as the stress pass makes them */
    for (int lo = 0; lo < N;) {
        int len = 1 + (int)(urand() * 64);
        if (lo + len > N) len = N - lo;
        kf_real *t[6];
        for (int k = 0; k < 6; k++) t[k] = tp[k] + lo;
        kf_mat_update_batch(m, len, Fp, pp, project, (size_t)(OFF + lo), t);
        lo += len;
    }
    const double M0 = 2 * (double)m->mu + 3 * fabs((double)m->lambda);
    static const int t6[6] = {0, 4, 8, 1, 2, 5};
    for (int p = 0; p < N; p++) {
        const kf_real *F = ref_F[p], *ps = ref_ps[p];
        /* snow: the moduli hardened by e^{ξ(1 − Jp)} at the reference's Jp */
        const double M = M0 * (snow_jp ? exp((double)m->xi * (1 - (double)ps[0])) : 1);
        if (kind[p] == OUTSIDE) {
            st.n_out++;
            int same = 1;
            for (int k = 0; k < 9; k++)
                same &= same_bits(plane_F[k][OFF + p], F[k]) | (isnan(F[k]) & isnan(plane_F[k][OFF + p]));
            for (int k = 0; k < 2; k++) same &= same_bits(plane_ps[k][OFF + p], ps[k]);
            for (int k = 0; k < 6; k++)
                same &= same_bits(plane_tau[k][OFF + p], ref_tau[p][t6[k]]) |
                        (isnan(ref_tau[p][t6[k]]) & isnan(plane_tau[k][OFF + p]));
            KT_CHECK(same, "%s: particle %d outside the window differs from the scalar path", what, p);
            continue;
        }
        st.n_in++;
        int F_same = 1;
        for (int k = 0; k < 9; k++) {
            double d = fabs((double)plane_F[k][OFF + p] - F[k]) / U_;
            if (d > st.dF) st.dF = d;
            F_same &= same_bits(plane_F[k][OFF + p], F[k]);
        }
        for (int k = 0; k < 2; k++) {
            double d = fabs((double)plane_ps[k][OFF + p] - ps[k]) / (U_ * (1 + fabs((double)ps[k])));
            if (d > st.dps) st.dps = d;
        }
        for (int k = 0; k < 6; k++) {
            double d = fabs((double)plane_tau[k][OFF + p] - ref_tau[p][t6[k]]) / (U_ * M);
            if (d > st.dtau) st.dtau = d;
        }
        st.n_elastic_same += F_same;
    }
    printf("  %-34s in-window %5ld  outside %4ld  max |dF| %5.2f u  |dtau| %5.2f u(2mu+3la)  |dps| %5.2f u\n", what,
           st.n_in, st.n_out, st.dF, st.dtau, st.dps);
    KT_CHECK(st.dF <= 40, "%s: F deviates %.2f u (bound 40 u)", what, st.dF);
    KT_CHECK(st.dtau <= 16, "%s: tau deviates %.2f u(2mu+3la) (bound 16)", what, st.dtau);
    KT_CHECK(st.dps <= 40, "%s: ps deviates %.2f u(1+|ps|) (bound 40)", what, st.dps);
    return st;
}

static void mat_from_preset(kf_mat *m, const char *preset, void (*tweak)(kf_material *)) {
    kf_material mat;
    KT_CHECK(kf_material_preset(preset, &mat) == 0, "preset %s", preset);
    if (tweak) tweak(&mat);
    kf_mat_compile(m, &mat);
}

static void no_hardening(kf_material *o) { o->hardening = 0; }
static void no_vc(kf_material *o) { o->volume_correction = 0; }
static void bare_sand(kf_material *o) { o->hardening = 0, o->volume_correction = 0; }
static void cohesive_hardening(kf_material *o) {
    o->cohesion = 3e-3;
    o->hardening = 1, o->h0 = 35, o->h1 = 9, o->h2 = 0.2, o->h3 = 10;
}

static void test_von_mises(void) {
    const char *presets[] = {"goo", "cheese", "metal"};
    for (int i = 0; i < 3; i++) {
        kf_mat m;
        mat_from_preset(&m, presets[i], NULL);
        char what[64];
        snprintf(what, sizeof what, "von Mises %s, project", presets[i]);
        compare(&m, 1, 0, 0, what);
        snprintf(what, sizeof what, "von Mises %s, stress only", presets[i]);
        compare(&m, 0, 0, 0, what);
    }
}

static void test_sand(void) {
    struct {
        const char *preset, *name;
        void (*tweak)(kf_material *);
    } cases[] = {
        {"sand", "sand (hardening, v_c)", NULL},
        {"sand", "sand (v_c only)", no_hardening},
        {"sand", "sand (hardening only)", no_vc},
        {"sand", "sand (bare)", bare_sand},
        {"wet_sand", "wet sand (cohesion, v_c)", NULL},
        {"wet_sand", "wet sand (cohesion, hardening, v_c)", cohesive_hardening},
    };
    for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
        kf_mat m;
        mat_from_preset(&m, cases[i].preset, cases[i].tweak);
        compare(&m, 1, m.volume_correction, m.hardening, cases[i].name);
        char what[80];
        snprintf(what, sizeof what, "%s, stress only", cases[i].name);
        compare(&m, 0, m.volume_correction, m.hardening, what);
    }
}

/* elastic particles without volume correction keep F bit for bit, as the
 * scalar path does: small strains of a von Mises and a bare sand material */
static void test_elastic_keeps_F(void) {
    const char *presets[] = {"metal", "sand"};
    for (int i = 0; i < 2; i++) {
        kf_mat m;
        mat_from_preset(&m, presets[i], bare_sand);
        enum { N = 64 };
        kf_real planes[9][N], ps[2][N] = {{0}}, tau[6][N], F0[9][N];
        for (int p = 0; p < N; p++) {
            /* compression (inside the sand cone), deviator far below yield */
            double s[3] = {exp(-1e-4 + 1e-6 * srand1()), exp(-1e-4 + 1e-6 * srand1()), exp(-1e-4 + 1e-6 * srand1())};
            kf_real F[9];
            make_F(F, s);
            for (int k = 0; k < 9; k++) planes[k][p] = F0[k][p] = F[k];
        }
        kf_real *Fp[9], *pp[2] = {ps[0], ps[1]}, *tp[6];
        for (int k = 0; k < 9; k++) Fp[k] = planes[k];
        for (int k = 0; k < 6; k++) tp[k] = tau[k];
        kf_mat_update_batch(&m, N, Fp, pp, 1, 0, tp);
        int same = 1;
        for (int k = 0; k < 9; k++)
            for (int p = 0; p < N; p++) same &= same_bits(planes[k][p], F0[k][p]);
        KT_CHECK(same, "%s: an elastic particle's F changed", presets[i]);
    }
}

/* snow: σ about the clamp window [1 − θc, 1 + θs] (in it, clamped on either
 * side), and the stress alone; θc widened in a second case so that some
 * particles sit inside the window */
static void wide_snow(kf_material *o) { o->theta_c = 0.05, o->theta_s = 0.02; }
static void test_snow(void) {
    snow_jp = 1;
    for (int i = 0; i < 2; i++) {
        kf_mat m;
        mat_from_preset(&m, "snow", i ? wide_snow : NULL);
        compare(&m, 1, 0, 0, i ? "snow (wide window), project" : "snow, project");
        compare(&m, 0, 0, 0, i ? "snow (wide window), stress only" : "snow, stress only");
    }
    snow_jp = 0;
}

/* the batch takes the hardening's exp and sin across the lanes
 * (core/vmath.h) and must keep the library's float bits: snow's
 * e^{ξ(1 − Jp)} and sand's friction coefficient c_f(q), over wide states
 * and the edges (beyond exp's range, NaN, ±inf, 0) */
static void test_hardening_bits(void) {
    kf_mat snow, sand;
    mat_from_preset(&snow, "snow", NULL);
    mat_from_preset(&sand, "sand", NULL);
    const kf_real edge[] = {0, -0.0f, 1, -80, 71, 1e30f, -1e30f, INFINITY, -INFINITY, NAN, 1e-40f, 200, 1e4f};
    const int n_edge = (int)(sizeof edge / sizeof edge[0]);
    int differ = 0;
    for (int it = 0; it < 40000; it++) {
        kf_real jp[16], q[16], h[16], cf[16];
        for (int j = 0; j < 16; j++) {
            int e = it * 16 + j;
            jp[j] = e < n_edge ? edge[e] : (kf_real)(urand() < 0.5 ? 0.5 + urand() : -2 + 6 * urand());
            q[j] = e < n_edge ? edge[e] : (kf_real)(urand() < 0.5 ? 2 * urand() : 60 * urand() * urand());
        }
        kf_mat_batch_hardening(&snow, 16, jp, h);
        kf_mat_batch_hardening(&sand, 16, q, cf);
        for (int j = 0; j < 16; j++) {
            kf_real rh = (kf_real)exp((double)snow.xi * (1.0 - (double)jp[j]));
            kf_real rc = (kf_real)kf_mat_friction_hardened(&sand, q[j]); /* kf_mat_update's route */
            differ += !same_bits(h[j], rh) + !same_bits(cf[j], rc);
            if (differ && differ < 4 && (!same_bits(h[j], rh) || !same_bits(cf[j], rc)))
                printf("  Jp %.9g: %.9g vs %.9g; q %.9g: %.9g vs %.9g\n", (double)jp[j], (double)h[j], (double)rh,
                       (double)q[j], (double)cf[j], (double)rc);
        }
    }
    KT_CHECK(differ == 0, "%d hardening factors differ from the library's bits", differ);
}

/* ulps between two doubles of one sign */
static double ulps(double a, double b) {
    int64_t ia, ib;
    memcpy(&ia, &a, sizeof ia);
    memcpy(&ib, &b, sizeof ib);
    return (double)(ia > ib ? ia - ib : ib - ia);
}

/* vmath.h's stated accuracy against the library (itself within 0.51 ulp
 * of exact): exp on [−700, 700] and [−1, 1], sin on [0, π/2], ≤ 2 ulp */
static void test_vmath_ulps(void) {
    double de = 0, ds = 0;
    for (int i = 0; i < 400000; i++) {
        double x = i % 2 ? -700 + 1400 * urand() : -1 + 2 * urand(), t = 1.5707963 * urand();
        double e = ulps(kf_vm_exp(x), exp(x)), s = ulps(kf_vm_sin(t), sin(t));
        de = e > de ? e : de, ds = s > ds ? s : ds;
    }
    printf("  vmath: exp %.0f ulp, sin %.0f ulp from the library\n", de, ds);
    /* the guard: a double at a float halfway point, or whose float is
     * subnormal, infinite or NaN, is not safe; one clear of it is */
    KT_CHECK(!kf_vm_float_safe(1 + 0x1p-24, 0x1p-52), "halfway between two floats judged safe");
    KT_CHECK(kf_vm_float_safe(1 + 0x1p-24 + 0x1p-40, 0x1p-48), "a double clear of the halfway point judged unsafe");
    KT_CHECK(!kf_vm_float_safe(1e-39, 0) && !kf_vm_float_safe(1e39, 0) && !kf_vm_float_safe(NAN, 0),
             "a subnormal, infinite or NaN float judged safe");
    KT_CHECK(de <= 2, "kf_vm_exp %.0f ulp from exp (stated 2)", de);
    KT_CHECK(ds <= 2, "kf_vm_sin %.0f ulp from sin (stated 2)", ds);
}

int main(int argc, char **argv) {
    KT_RUN(test_snow, argc, argv);
    KT_RUN(test_von_mises, argc, argv);
    KT_RUN(test_sand, argc, argv);
    KT_RUN(test_elastic_keeps_F, argc, argv);
    /* last: the samples of the tests above stay those they were */
    KT_RUN(test_hardening_bits, argc, argv);
    KT_RUN(test_vmath_ulps, argc, argv);
    return KT_EXIT();
}
