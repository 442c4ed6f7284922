/* test_svd.c — the sign-fixed 3x3 SVD and polar rotation (core/svd3.c).
 *
 * Every property is measured in double from the kf_real outputs. Tolerances
 * follow from the output precision: internals run in double, so the only
 * float error is rounding U, σ, V (and F) to float, u = 6e-8 per entry.
 * A product of three rounded 3x3 factors then carries a few u; we allow
 * ~100 u (1e-5 relative) in float and 1e-12 in double. */
#include <stdint.h>

#include "core/svd3.h"
#include "kt.h"

#ifdef KF_DOUBLE
#define TOL_REC 1e-12  /* reconstruction, relative to ‖F‖ */
#define TOL_ORTH 1e-13 /* UᵀU = I, det = 1: a handful of double roundings */
#else
#define TOL_REC 1e-5  /* three float-rounded factors: a few 6e-8, with margin */
#define TOL_ORTH 1e-6 /* each entry of UᵀU sums three products of rounded entries */
#endif

/* ---- deterministic random numbers ----------------------------------------- */

#define KT_RNG_SEED 0x9E3779B97F4A7C15ull
#include "random_util.h"

/* F = Q1 diag(s) Q2ᵀ rounded to kf_real */
static void compose(kf_real F[9], const double Q1[9], const double s[3], const double Q2[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double t = 0;
            for (int k = 0; k < 3; k++) t += Q1[3 * i + k] * s[k] * Q2[3 * j + k];
            F[3 * i + j] = (kf_real)t;
        }
}

static double det_d(const kf_real A[9]) {
    double a[9];
    for (int i = 0; i < 9; i++) a[i] = A[i];
    return a[0] * (a[4] * a[8] - a[5] * a[7]) - a[1] * (a[3] * a[8] - a[5] * a[6]) + a[2] * (a[3] * a[7] - a[4] * a[6]);
}

static double fro(const kf_real A[9]) {
    double s = 0;
    for (int i = 0; i < 9; i++) s += (double)A[i] * A[i];
    return sqrt(s);
}

/* max |QᵀQ − I| */
static double orth_err(const kf_real Q[9]) {
    double e = 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double t = 0;
            for (int k = 0; k < 3; k++) t += (double)Q[3 * k + i] * Q[3 * k + j];
            e = fmax(e, fabs(t - (i == j)));
        }
    return e;
}

/* worst errors over a batch of matrices */
typedef struct worst {
    double rec, orth, det, order;
    int n, neg_s01;
} worst;

/* all invariants of one decomposition, folded into *w */
static void measure(const kf_real F[9], worst *w) {
    kf_real U[9], s[3], V[9];
    kf_svd3(F, U, s, V);
    double nf = fro(F), r = 0;
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double t = 0;
            for (int k = 0; k < 3; k++) t += (double)U[3 * i + k] * s[k] * V[3 * j + k];
            r += (t - F[3 * i + j]) * (t - F[3 * i + j]);
        }
    r = sqrt(r);
    w->rec = fmax(w->rec, nf > 0 ? r / nf : r);
    w->orth = fmax(w->orth, fmax(orth_err(U), orth_err(V)));
    w->det = fmax(w->det, fmax(fabs(det_d(U) - 1), fabs(det_d(V) - 1)));
    double s0 = s[0] > 0 ? s[0] : 1;
    w->order = fmax(w->order, fmax((s[1] - s[0]) / s0, (fabs(s[2]) - s[1]) / s0));
    if (s[0] < 0 || s[1] < 0) w->neg_s01++;
    w->n++;
}

static void check_worst(const worst *w, const char *what) {
    KT_CHECK(w->rec <= TOL_REC, "%s: worst ‖UΣVᵀ−F‖/‖F‖ = %.3g over %d (limit %.1g: output rounding)", what, w->rec,
             w->n, TOL_REC);
    KT_CHECK(w->orth <= TOL_ORTH, "%s: worst |QᵀQ−I| = %.3g (limit %.1g: output rounding)", what, w->orth, TOL_ORTH);
    KT_CHECK(w->det <= TOL_ORTH, "%s: worst |det−1| = %.3g (limit %.1g: output rounding)", what, w->det, TOL_ORTH);
    /* ordering: exact ties may differ by rounding of σ */
    KT_CHECK(w->order <= TOL_ORTH, "%s: ordering violated by %.3g relative (limit %.1g: rounding of ties)", what,
             w->order, TOL_ORTH);
    KT_CHECK(w->neg_s01 == 0, "%s: %d decompositions with σ0 or σ1 < 0", what, w->neg_s01);
}

/* ---- cases -------------------------------------------------------------------- */

static void svd_random_general(void) {
    worst w = {0};
    for (int t = 0; t < 20000; t++) {
        kf_real F[9];
        double scale = pow(10.0, 6 * urand() - 3); /* 1e-3 .. 1e3 */
        for (int i = 0; i < 9; i++) F[i] = (kf_real)(scale * srand1());
        measure(F, &w);
    }
    check_worst(&w, "random entries");
}

static void svd_sign_follows_det(void) {
    /* σ2 has the sign of det F; tolerance-free where |det F| is well above
     * round-off (σ2 ≥ 1e-2 σ0 by construction) */
    worst w = {0};
    int wrong = 0;
    for (int t = 0; t < 5000; t++) {
        double Q1[9], Q2[9], s[3] = {0.5 + urand(), 0.5 + urand(), 0.5 + urand()};
        random_rotation(Q1);
        random_rotation(Q2);
        if (t % 2) s[t % 3] = -s[t % 3]; /* inverted */
        kf_real F[9], U[9], sg[3], V[9];
        compose(F, Q1, s, Q2);
        measure(F, &w);
        kf_svd3(F, U, sg, V);
        if ((sg[2] < 0) != (det_d(F) < 0)) wrong++;
        /* magnitudes are the |s| sorted */
        double a[3] = {fabs(s[0]), fabs(s[1]), fabs(s[2])};
        for (int i = 0; i < 3; i++)
            for (int j = i + 1; j < 3; j++)
                if (a[j] > a[i]) {
                    double x = a[i];
                    a[i] = a[j];
                    a[j] = x;
                }
        for (int i = 0; i < 3; i++)
            if (fabs(fabs((double)sg[i]) - a[i]) > 10 * TOL_REC * a[0]) wrong++;
    }
    check_worst(&w, "rotations x diag, half inverted");
    KT_CHECK(wrong == 0, "%d decompositions with wrong σ2 sign or |σ| (limit 1e-4 σ0 float: F rounding)", wrong);
}

static void svd_rank_deficient(void) {
    worst w = {0};
    double max_s2 = 0, max_s1 = 0;
    for (int t = 0; t < 5000; t++) {
        double a[3], b[3], c[3], d[3];
        for (int i = 0; i < 3; i++) a[i] = srand1(), b[i] = srand1(), c[i] = srand1(), d[i] = srand1();
        kf_real F2[9], F1[9];
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                F2[3 * i + j] = (kf_real)(a[i] * b[j] + c[i] * d[j]); /* rank 2 */
                F1[3 * i + j] = (kf_real)(a[i] * b[j]);               /* rank 1 */
            }
        kf_real U[9], s[3], V[9];
        measure(F2, &w);
        kf_svd3(F2, U, s, V);
        max_s2 = fmax(max_s2, fabs(s[2]) / s[0]);
        measure(F1, &w);
        kf_svd3(F1, U, s, V);
        max_s1 = fmax(max_s1, fabs(s[1]) / s[0]);
    }
    check_worst(&w, "rank 1 and 2");
    /* the rounded F is only rank-deficient to its own rounding */
    KT_CHECK(max_s2 <= 10 * TOL_ORTH, "rank 2: σ2/σ0 up to %.3g (limit %.1g: rounding of F)", max_s2, 10 * TOL_ORTH);
    KT_CHECK(max_s1 <= 10 * TOL_ORTH, "rank 1: σ1/σ0 up to %.3g (limit %.1g: rounding of F)", max_s1, 10 * TOL_ORTH);

    /* exact zero and exactly singular integer matrices */
    kf_real Z[9] = {0}, U[9], s[3], V[9];
    kf_svd3(Z, U, s, V);
    KT_CHECK(s[0] == 0 && s[1] == 0 && s[2] == 0, "F = 0: σ = %g %g %g", s[0], s[1], s[2]);
    KT_NEAR(det_d(U), 1, TOL_ORTH, "F = 0 still gives rotations");
    KT_NEAR(det_d(V), 1, TOL_ORTH, "F = 0 still gives rotations");
    kf_real S1[9] = {1, 2, 3, 2, 4, 6, -1, -2, -3}, S2[9] = {1, 0, 1, 0, 1, 1, 1, 1, 2},
            E00[9] = {0, 0, 0, 0, 0, 0, 0, 0, 5};
    worst w2 = {0};
    measure(S1, &w2);
    measure(S2, &w2);
    measure(E00, &w2);
    measure(Z, &w2);
    check_worst(&w2, "exact singular");
}

static void svd_repeated(void) {
    worst w = {0};
    for (int t = 0; t < 5000; t++) {
        double Q1[9], Q2[9], x = 0.1 + urand(), y = 0.1 + urand();
        random_rotation(Q1);
        random_rotation(Q2);
        double s3[3][3] = {{x, x, y}, {y, x, x}, {x, x, x}};
        for (int k = 0; k < 3; k++) {
            kf_real F[9];
            compose(F, Q1, s3[k], Q2);
            measure(F, &w);
            double neg[3] = {s3[k][0], s3[k][1], -s3[k][2]};
            compose(F, Q1, neg, Q2);
            measure(F, &w);
        }
    }
    check_worst(&w, "repeated σ");

    /* exact matrices: identity, −I, permutations, unsorted diagonals, π rotation */
    kf_real M[][9] = {{1, 0, 0, 0, 1, 0, 0, 0, 1}, {-1, 0, 0, 0, -1, 0, 0, 0, -1}, {0, 1, 0, 1, 0, 0, 0, 0, 1},
                      {0, 1, 0, 0, 0, 1, 1, 0, 0}, {1, 0, 0, 0, 3, 0, 0, 0, 2},    {-1, 0, 0, 0, -1, 0, 0, 0, 1},
                      {2, 0, 0, 0, 2, 0, 0, 0, 1}, {0, 0, -2, 0, 2, 0, 2, 0, 0},   {1, 0, 0, 0, -1, 0, 0, 0, 1}};
    int nm = (int)(sizeof M / sizeof M[0]);
    worst w2 = {0};
    for (int k = 0; k < nm; k++) {
        measure(M[k], &w2);
        kf_real U[9], s[3], V[9];
        kf_svd3(M[k], U, s, V);
        double d = det_d(M[k]);
        KT_CHECK((s[2] < 0) == (d < 0), "exact matrix %d: σ2 = %g but det = %g", k, s[2], d);
    }
    check_worst(&w2, "exact special matrices");
    /* −I is inverted: σ = (1, 1, −1) */
    kf_real U[9], s[3], V[9];
    kf_svd3(M[1], U, s, V);
    KT_NEAR(s[0], 1, TOL_ORTH, "−I: |σ| = 1");
    KT_NEAR(s[2], -1, TOL_ORTH, "−I: σ2 = −1 carries det < 0");
}

static void svd_near_identity(void) {
    /* F = Q diag(1 + δ a) Qᵀ: σ = 1 + δ a. Tolerance: F carries one rounding
     * of its entries (u), the σ are then good to a few u */
#ifdef KF_DOUBLE
    const double delta = 1e-7, tol = 1e-14;
#else
    const double delta = 1e-4, tol = 5e-7;
#endif
    worst w = {0};
    double err = 0;
    for (int t = 0; t < 5000; t++) {
        double Q[9], a[3] = {srand1(), srand1(), srand1()}, s[3];
        random_rotation(Q);
        for (int i = 0; i < 3; i++) s[i] = 1 + delta * a[i];
        kf_real F[9], U[9], sg[3], V[9];
        compose(F, Q, s, Q);
        measure(F, &w);
        kf_svd3(F, U, sg, V);
        for (int i = 0; i < 3; i++)
            for (int j = i + 1; j < 3; j++)
                if (s[j] > s[i]) {
                    double x = s[i];
                    s[i] = s[j];
                    s[j] = x;
                }
        for (int i = 0; i < 3; i++) err = fmax(err, fabs(sg[i] - s[i]));
        /* and an exact identity plus one tiny off-diagonal entry */
        kf_real G[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        static const int off[3] = {1, 5, 6};
        G[off[t % 3]] = (kf_real)(delta * a[0]);
        measure(G, &w);
    }
    check_worst(&w, "near identity");
    KT_CHECK(err <= tol, "near identity: σ off by %.3g (limit %.1g: one rounding of F)", err, tol);
}

static void svd_extreme_scales(void) {
    worst w = {0};
    double scales[] = {1e-30, 1e-12, 1e12, 1e30};
    for (int k = 0; k < 4; k++)
        for (int t = 0; t < 1000; t++) {
            kf_real F[9];
            for (int i = 0; i < 9; i++) F[i] = (kf_real)(scales[k] * srand1());
            measure(F, &w);
        }
    check_worst(&w, "scales 1e-30..1e30 (internal rescaling)");
    /* graded: one tiny direction must still be resolved relatively */
    double Q1[9], Q2[9], s[3] = {1, 1e-3, 1e-6};
    random_rotation(Q1);
    random_rotation(Q2);
    kf_real F[9], U[9], sg[3], V[9];
    compose(F, Q1, s, Q2);
    kf_svd3(F, U, sg, V);
    /* rounding F moves σ2 by up to ~u‖F‖ (Weyl), so that is the absolute
     * accuracy available; an eigen-solve of FᵀF would lose u σ0²/σ1 = 1e3 u */
#ifdef KF_DOUBLE
    const double tol = 1e-15;
#else
    const double tol = 3e-7;
#endif
    KT_NEAR(sg[2], 1e-6, tol, "graded σ2: absolute error about u·‖F‖");
    KT_NEAR(sg[1], 1e-3, tol, "graded σ1: absolute error about u·‖F‖");
}

static void svd_nonfinite(void) {
    /* NaN must not be hidden as a zero stress */
    kf_real F[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, U[9], s[3], V[9];
    F[4] = (kf_real)NAN;
    kf_svd3(F, U, s, V);
    KT_CHECK(isnan(s[0]), "NaN in F shows as NaN σ, got %g", s[0]);
}

static void polar_matches_uvt(void) {
    double err = 0, orth = 0, det = 0, qerr = 0;
    for (int t = 0; t < 5000; t++) {
        double Q1[9], Q2[9], s[3] = {0.2 + urand(), 0.2 + urand(), 0.2 + urand()};
        random_rotation(Q1);
        random_rotation(Q2);
        if (t % 3 == 0) s[1] = -s[1]; /* inverted: R stays a rotation */
        kf_real F[9], U[9], sg[3], V[9], R[9];
        compose(F, Q1, s, Q2);
        kf_svd3(F, U, sg, V);
        kf_polar3(F, R);
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++) {
                double t2 = 0;
                for (int k = 0; k < 3; k++) t2 += (double)U[3 * i + k] * V[3 * j + k];
                err = fmax(err, fabs(t2 - R[3 * i + j]));
            }
        orth = fmax(orth, orth_err(R));
        det = fmax(det, fabs(det_d(R) - 1));
        /* G = Q3 S with S = Q1 diag(s) Q1ᵀ symmetric positive: R = Q3 */
        if (s[1] > 0) {
            double Q3[9], S[9];
            kf_real G[9];
            random_rotation(Q3);
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++) {
                    double x = 0;
                    for (int k = 0; k < 3; k++) x += Q1[3 * i + k] * s[k] * Q1[3 * j + k];
                    S[3 * i + j] = x;
                }
            for (int i = 0; i < 3; i++)
                for (int j = 0; j < 3; j++) {
                    double x = 0;
                    for (int k = 0; k < 3; k++) x += Q3[3 * i + k] * S[3 * k + j];
                    G[3 * i + j] = (kf_real)x;
                }
            kf_polar3(G, R);
            for (int i = 0; i < 9; i++) qerr = fmax(qerr, fabs(R[i] - Q3[i]));
        }
    }
    KT_CHECK(err <= 2 * TOL_ORTH, "polar vs UVᵀ: %.3g (limit %.1g: rounding of U, V, R)", err, 2 * TOL_ORTH);
    KT_CHECK(orth <= TOL_ORTH, "polar: |RᵀR−I| = %.3g (limit %.1g)", orth, TOL_ORTH);
    KT_CHECK(det <= TOL_ORTH, "polar: |det R − 1| = %.3g even for inverted F (limit %.1g)", det, TOL_ORTH);
    /* σ ≥ 0.2 bounds the polar factor's sensitivity to F rounding by ~u/0.2 */
    KT_CHECK(qerr <= 20 * TOL_ORTH, "polar of Q S: |R − Q| = %.3g (limit %.1g: u / σmin)", qerr, 20 * TOL_ORTH);
}

int main(int argc, char **argv) {
    KT_RUN(svd_random_general, argc, argv);
    KT_RUN(svd_sign_follows_det, argc, argv);
    KT_RUN(svd_rank_deficient, argc, argv);
    KT_RUN(svd_repeated, argc, argv);
    KT_RUN(svd_near_identity, argc, argv);
    KT_RUN(svd_extreme_scales, argc, argv);
    KT_RUN(svd_nonfinite, argc, argv);
    KT_RUN(polar_matches_uvt, argc, argv);
    return KT_EXIT();
}
