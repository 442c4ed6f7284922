/* test_transfer.c — the transfers on their own: partition of unity and the
 * kernel moments, conservation of mass, momentum and angular momentum in P2G,
 * exact reproduction of an affine velocity field in G2P (V2), for quadratic
 * and cubic kernels and for the MLS and classic force. */
#include "kt.h"
#include "mpm/model.h"
#include "mpm/transfer_chunk.h"
#include "random_util.h"
#include "scene_util.h"

#include <float.h>
/* one unit of round-off in the build's precision */
#ifdef KF_DOUBLE
#define ROUNDOFF DBL_EPSILON
#else
#define ROUNDOFF FLT_EPSILON
#endif

/* particles at random positions with random v, C, and a stressed F */
static kf_state *random_state(kf_model *m, int mat, int n, unsigned seed, double spread) {
    kf_state *s = kf_state_create(m);
    double *x = malloc(sizeof(double) * 3 * n), *v = malloc(sizeof(double) * 3 * n),
           *F = malloc(sizeof(double) * 9 * n);
    for (int i = 0; i < n; i++) {
        for (int a = 0; a < 3; a++) {
            x[3 * i + a] = 0.3 + spread * tu_uniform(&seed);
            v[3 * i + a] = tu_uniform(&seed) - 0.5;
        }
        for (int e = 0; e < 9; e++) F[9 * i + e] = (e % 4 == 0) + 0.2 * (tu_uniform(&seed) - 0.5);
    }
    kf_state_add_particles(s, m, (size_t)n, x, v, F, mat, 1e-6);
    kf_particles_view pv = kf_state_particles(s);
    for (int i = 0; i < n; i++)
        for (int e = 0; e < 9; e++) pv.C[e][i] = (kf_real)(2 * (tu_uniform(&seed) - 0.5));
    free(x), free(v), free(F);
    return s;
}

static void bin(kf_model *m, kf_state *s) {
    size_t bad;
    int rc = kf_grid_bin(&s->g, &s->p, (kf_real)(1 / m->sim.dx), m->sim.kernel == KF_KERNEL_CUBIC, m->nthreads, &bad);
    KT_CHECK(rc == 0, "binning failed: %d", rc);
}

/* One particle: the grid mass, its first and second moments are the
 * particle's mass, position and m(x xᵀ + D): partition of unity, linear
 * reproduction, and D_p = Δx²/4 or Δx²/3 . */
static void kernel_moments(kf_kernel kernel) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.1;
    sd.kernel = kernel;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    unsigned seed = 7;
    double dfac = kf_model_dfactor(m);
    for (int trial = 0; trial < 50; trial++) {
        kf_state *s = kf_state_create(m);
        double x[3] = {-1 + 2 * tu_uniform(&seed), -1 + 2 * tu_uniform(&seed), -1 + 2 * tu_uniform(&seed)};
        kf_state_add_particles(s, m, 1, x, NULL, NULL, mat, 1e-3);
        kf_real mp = s->p.mass[0];
        bin(m, s);
        kf_p2g(m, s, 0, NULL);
        double M = 0, M1[3] = {0}, M2[9] = {0};
        for (size_t b = 0; b < s->g.nblocks; b++)
            for (int l = 0; l < KF_BLOCK_NODES; l++) {
                double w = s->g.node[b * KF_BLOCK_NODES + l][3] / mp, xi[3];
                if (w == 0) continue;
                tu_node_pos(&s->g, b, l, sd.dx, xi);
                M += w;
                for (int a = 0; a < 3; a++) {
                    M1[a] += w * (xi[a] - x[a]);
                    for (int c = 0; c < 3; c++) M2[3 * a + c] += w * (xi[a] - x[a]) * (xi[c] - x[c]);
                }
            }
        /* float weights: relative round-off of a 27/64-term sum */
        KT_NEAR(M, 1.0, 10 * ROUNDOFF, "partition of unity to round-off");
        for (int a = 0; a < 3; a++) {
            KT_NEAR(M1[a], 0.0, 10 * ROUNDOFF * sd.dx, "first moment vanishes to round-off");
            for (int c = 0; c < 3; c++)
                KT_NEAR(M2[3 * a + c], a == c ? dfac : 0.0, 10 * ROUNDOFF * sd.dx * sd.dx, "D_p = d I exactly");
        }
        kf_state_destroy(s);
    }
    kf_model_destroy(m);
}
static void kernel_moments_quadratic(void) { kernel_moments(KF_KERNEL_QUADRATIC); }
static void kernel_moments_cubic(void) { kernel_moments(KF_KERNEL_CUBIC); }

/* P2G conserves mass, linear momentum (internal forces sum to zero) and
 * angular momentum (symmetric Kirchhoff stress exerts no torque; APIC's
 * affine part contributes m D (C - Cᵀ)). */
static void p2g_conservation(kf_kernel kernel, kf_force force) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.05;
    sd.kernel = kernel;
    sd.force = force;
    sd.gravity[1] = 0;
    int mat;
    kf_model *m = tu_model(&sd, "rubber", 0, -1, 0, &mat);
    kf_state *s = random_state(m, mat, 3000, 3, 0.4);
    kf_energy e = kf_state_energy(m, s); /* particle mass, momentum, angular momentum incl. APIC term */
    bin(m, s);
    const double dt = 1e-3;
    kf_p2g(m, s, (kf_real)dt, NULL);
    double M = 0, P[3] = {0}, L[3] = {0};
    for (size_t b = 0; b < s->g.nblocks; b++)
        for (int l = 0; l < KF_BLOCK_NODES; l++) {
            kf_v4 n = s->g.node[b * KF_BLOCK_NODES + l];
            double xi[3];
            tu_node_pos(&s->g, b, l, sd.dx, xi);
            M += n[3];
            for (int a = 0; a < 3; a++) P[a] += n[a];
            L[0] += xi[1] * n[2] - xi[2] * n[1];
            L[1] += xi[2] * n[0] - xi[0] * n[2];
            L[2] += xi[0] * n[1] - xi[1] * n[0];
        }
    /* Each node receives stress terms dt V0 |τ|/Δx ~ 1e-3 while the totals are
     * ~0.03: the forces must cancel. Float round-off over ~1e5 additions was
     * measured at 2.5e-8; 10 units of round-off (1.2e-6 in float) keeps a
     * margin yet sits 1000x below the per-node force, so a force that does not
     * cancel fails. */
    /* mass: positive terms, so 10 units of round-off, plus the round-off of
     * the double-precision reference summed over 3000 particles */
    KT_NEAR(M, e.mass, (10 * ROUNDOFF + 3000 * DBL_EPSILON) * e.mass, "mass: sum of positive terms, round-off");
    for (int a = 0; a < 3; a++) {
        KT_NEAR(P[a], e.momentum[a], 10 * ROUNDOFF, "momentum to round-off (internal forces cancel)");
        KT_NEAR(L[a], e.angular_momentum[a], 10 * ROUNDOFF, "angular momentum to round-off (no torque)");
    }
    kf_state_destroy(s);
    kf_model_destroy(m);
}
static void p2g_conservation_all(void) {
    for (int k = 0; k < 2; k++)
        for (int f = 0; f < 2; f++) p2g_conservation((kf_kernel)k, (kf_force)f);
}

/* V2: a grid velocity field v = a + G x is reproduced exactly: v_p = a + G x_p
 * and C_p = G, for MLS and classic; the F update uses G for both. */
static void affine_field(kf_kernel kernel, kf_force force) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.05;
    sd.kernel = kernel;
    sd.force = force;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    kf_state *s = random_state(m, mat, 2000, 11, 0.5);
    kf_particles_view pv = kf_state_particles(s);
    for (size_t i = 0; i < pv.n; i++)
        for (int e = 0; e < 9; e++) pv.F[e][i] = (kf_real)(e % 4 == 0);
    bin(m, s);
    const double a[3] = {0.3, -0.2, 0.1}, G[9] = {0.5, -1.0, 0.25, 0.7, 0.1, -0.4, -0.3, 0.9, -0.2};
    for (size_t b = 0; b < s->g.nblocks; b++)
        for (int l = 0; l < KF_BLOCK_NODES; l++) {
            double xi[3];
            tu_node_pos(&s->g, b, l, sd.dx, xi);
            kf_v4 v;
            for (int r = 0; r < 3; r++)
                v[r] = (kf_real)(a[r] + G[3 * r] * xi[0] + G[3 * r + 1] * xi[1] + G[3 * r + 2] * xi[2]);
            v[3] = 1;
            s->g.node[b * KF_BLOCK_NODES + l] = v;
        }
    double xs[3][2000];
    for (size_t i = 0; i < pv.n; i++)
        for (int c = 0; c < 3; c++) xs[c][i] = pv.x[c][i];
    const double dt = 1e-3;
    kf_g2p_result res;
    kf_g2p(m, s, (kf_real)dt, &res);
    double errC = 0, errv = 0, errF = 0;
    for (size_t i = 0; i < pv.n; i++) {
        for (int r = 0; r < 3; r++) {
            double vr = a[r] + G[3 * r] * xs[0][i] + G[3 * r + 1] * xs[1][i] + G[3 * r + 2] * xs[2][i];
            errv = fmax(errv, fabs(pv.v[r][i] - vr));
            for (int c = 0; c < 3; c++) {
                errC = fmax(errC, fabs(pv.C[3 * r + c][i] - G[3 * r + c]));
                errF = fmax(errF, fabs(pv.F[3 * r + c][i] - ((r == c) + dt * G[3 * r + c])));
            }
        }
    }
    /* |v| ~ 1, so 10 units of round-off; C = D⁻¹ Σ w v dᵀ divides that by Δx
     * (measured in float: 2e-7, 3e-6, 4e-8) */
    KT_NEAR(errv, 0, 10 * ROUNDOFF, "v_p = a + G x_p to round-off");
    KT_NEAR(errC, 0, 10 * ROUNDOFF / sd.dx, "C_p = G to round-off");
    KT_NEAR(errF, 0, 10 * ROUNDOFF, "F = (I + dt G) to round-off");
    kf_state_destroy(s);
    kf_model_destroy(m);
}
static void affine_field_all(void) {
    for (int k = 0; k < 2; k++)
        for (int f = 0; f < 2; f++) affine_field((kf_kernel)k, (kf_force)f);
}

#if defined(KF_ROWS512) || defined(KF_SCATTER256)
#ifdef KF_ROWS512
/* one particle's MLS scatter with the roundings the AVX-512 rows promise
 * (scatter_one as GCC compiles it with FMA): h_a = m v + d_a Q:,0 and
 * h_ab = h_a + d_b Q:,1 as multiply-adds, t = h_ab + d_c Q:,2 with the
 * product rounded apart, w = (w_a w_b) w_c, node += w t as a multiply-add.
 * Contraction off, so that only the fmaf calls fuse: two inlined copies of
 * scatter_one itself may contract differently, and are no reference. */
__attribute__((noinline, optimize("fp-contract=off"))) static void scatter_reference(int KW, const chunk *ck, int j,
                                                                                     kf_v4 *cache) {
    const int CD = CD_MAX;
    kf_v4 *origin = &cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]];
    for (int a = 0; a < KW; a++)
        for (int b = 0; b < KW; b++)
            for (int c = 0; c < KW; c++) {
                const kf_real w = (ck->w[0][a][j] * ck->w[1][b][j]) * ck->w[2][c][j];
                kf_v4 *node = &origin[(a * CD + b) * CD + c];
                for (int k = 0; k < 4; k++) {
                    const kf_real q0 = k < 3 ? ck->q[3 * k][j] : 0, q1 = k < 3 ? ck->q[3 * k + 1][j] : 0;
                    const kf_real q2 = k < 3 ? ck->q[3 * k + 2][j] : 0;
                    const kf_real ha = fmaf(ck->d[0][a][j], q0, ck->mv[k][j]);
                    const kf_real hab = fmaf(ck->d[1][b][j], q1, ha);
                    const kf_real dq = ck->d[2][c][j] * q2;
                    (*node)[k] = fmaf(w, hab + dq, (*node)[k]);
                }
            }
}
#else
/* one particle's MLS scatter with the AVX2 rows' roundings
 * (scatter_chunk256, performance-notes.md's two multiply-adds a row): the
 * z-weight folded into the particle's terms, B = w_c fma(d_c, Q:,2, m v),
 * G_0 = w_c Q:,0, G_1 = w_c Q:,1, H_a = fma(d_a, G_0, B), then
 * node += (w_a w_b) fma(d_b, G_1, H_a) as a multiply-add. Contraction
 * off, as above. */
__attribute__((noinline, optimize("fp-contract=off"))) static void scatter_reference256(const chunk *ck, int j,
                                                                                         kf_v4 *cache) {
    const int CD = CD_MAX, KW = 3;
    kf_v4 *origin = &cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]];
    for (int a = 0; a < KW; a++)
        for (int b = 0; b < KW; b++)
            for (int c = 0; c < KW; c++) {
                const kf_real wab = ck->w[0][a][j] * ck->w[1][b][j], wc = ck->w[2][c][j];
                kf_v4 *node = &origin[(a * CD + b) * CD + c];
                for (int k = 0; k < 4; k++) {
                    const kf_real q0 = k < 3 ? ck->q[3 * k][j] : 0, q1 = k < 3 ? ck->q[3 * k + 1][j] : 0;
                    const kf_real q2 = k < 3 ? ck->q[3 * k + 2][j] : 0;
                    const kf_real B = wc * fmaf(ck->d[2][c][j], q2, ck->mv[k][j]);
                    const kf_real Ha = fmaf(ck->d[0][a][j], wc * q0, B);
                    const kf_real t = fmaf(ck->d[1][b][j], wc * q1, Ha);
                    (*node)[k] = fmaf(wab, t, (*node)[k]);
                }
            }
}
#endif

/* A chunk's MLS scatter in register runs (scatter_chunk_n: AVX-512, or
 * AVX2 with the quadratic kernel) adds exactly the reference's sums (the
 * AVX2 rows: scatter_reference256's roundings), bit for bit: runs of one
 * to sixteen particles on one base node, consecutive runs one node apart
 * in z (the overlapping rows the binning's order gives) or anywhere, full
 * chunks and a short last one, into a cache that already holds sums. */
static void scatter_chunk_bits(int KW, int run, int n, int far) {
    const kf_real dx = KF_R(0.01), inv_dx = 1 / dx;
    const int span = CD_MAX - KW; /* base nodes 0..span keep the stencil in the cache */
    chunk ck;
    memset(&ck, 0, sizeof ck);
    ck.n = n;
    kf_real x[3][KF_CHUNK];
    kf_real *xp[3] = {x[0], x[1], x[2]};
    int base[3] = {0, 0, 0};
    for (int j = 0; j < n; j++) {
        if (j % run == 0) {
            if (far)
                for (int a = 0; a < 3; a++) base[a] = (int)(urand() * (span + 1));
            else if (++base[2] > span) base[2] = 0, base[1] = (base[1] + 1) % (span + 1);
        }
        /* a position whose stencil base is base: fx in [0.5, 1.5) (quadratic) or [1, 2) (cubic) */
        for (int a = 0; a < 3; a++)
            x[a][j] = ((kf_real)base[a] + (KW == 4 ? 1 : KF_R(0.5)) + (kf_real)(0.02 + 0.96 * urand())) * dx;
    }
    const int32_t bc[3] = {0, 0, 0};
    stencil_phase_n(KW, 0, 1, 0, n, &ck, xp, 0, bc, inv_dx, dx);
    for (int j = 0; j < n; j++) {
        for (int k = 0; k < 4; k++) ck.mv[k][j] = (kf_real)(k == 3 ? 0.1 + urand() : srand1());
        for (int k = 0; k < 9; k++) ck.q[k][j] = (kf_real)(100 * srand1());
    }
    static kf_v4 by_chunk[CD_MAX * CD_MAX * CD_MAX], by_particle[CD_MAX * CD_MAX * CD_MAX];
    for (int i = 0; i < CD_MAX * CD_MAX * CD_MAX; i++)
        for (int c = 0; c < 4; c++) by_chunk[i][c] = by_particle[i][c] = (kf_real)srand1();
    if (n == KF_CHUNK) scatter_chunk_n(KW, 0, KF_CHUNK, &ck, by_chunk);
    else scatter_chunk(KW, 0, &ck, by_chunk);
#ifdef KF_ROWS512
    for (int j = 0; j < n; j++) scatter_reference(KW, &ck, j, by_particle);
#else
    for (int j = 0; j < n; j++) scatter_reference256(&ck, j, by_particle);
#endif
    KT_CHECK(memcmp(by_chunk, by_particle, sizeof by_chunk) == 0, "KW %d, runs of %d, %d particles, %s", KW, run, n,
             far ? "runs anywhere" : "runs one node apart");
}
#endif
static void scatter_chunk_matches_particles(void) {
#if defined(KF_ROWS512) || defined(KF_SCATTER256)
    const int runs[] = {1, 2, 3, 4, 5, 8, 16};
#ifdef KF_ROWS512
    const int kw_last = 4;
#else
    const int kw_last = 3; /* the AVX2 rows: quadratic only */
#endif
    for (int KW = 3; KW <= kw_last; KW++)
        for (int r = 0; r < (int)(sizeof runs / sizeof runs[0]); r++)
            for (int far = 0; far < 2; far++) {
                scatter_chunk_bits(KW, runs[r], KF_CHUNK, far);
                scatter_chunk_bits(KW, runs[r], 11, far);
            }
#else
    printf("  (no scatter in register runs in this build: particle by particle only)\n");
#endif
}

int main(int argc, char **argv) {
    KT_RUN(kernel_moments_quadratic, argc, argv);
    KT_RUN(kernel_moments_cubic, argc, argv);
    KT_RUN(p2g_conservation_all, argc, argv);
    KT_RUN(affine_field_all, argc, argv);
    KT_RUN(scatter_chunk_matches_particles, argc, argv);
    return KT_EXIT();
}
