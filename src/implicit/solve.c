/* solve.c — backward Euler on the grid velocities: Newton's method
 * on the incremental potential E(v) (implicit.h), each step solved by CG
 * on the projected (positive semi-definite) Hessian, preconditioned by the
 * multigrid cycle (implicit/mg_cycle.c, the default) or by Jacobi
 * (sim.precond), then a backtracking line search on E.
 *
 * The Hessian is never assembled: its action is a gather of G_p from the
 * increment, the per-particle 9x9 block Kp (the energy's projected second
 * derivative mapped to G), and a scatter (Eq. 19). Walls and colliders are
 * linear constraints: the solve starts admissible and every direction is
 * projected onto the free directions (implicit/boundary.c). Convergence is
 * the residual ‖P g‖ in the inverse-mass norm relative to the momentum
 * scale √M · v_scale, v_scale the RMS speed of v* (at least |g| Δt). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "implicit.h"

#define DEF_NEWTON_TOL 1e-3
#define DEF_NEWTON_MAX 20
#define DEF_KRYLOV_TOL 1e-2
#define DEF_KRYLOV_MAX 200
/* CG need not solve a Newton step more accurately than the Newton
 * tolerance asks: its relative residual target is at most FORCING ×
 * newton_tol / (the current Newton residual), so a Newton iteration that
 * starts near convergence stops CG early (an inexact Newton forcing term) */
#define FORCING 0.5
/* a Newton iteration on kept blocks that cut the residual by less than this
 * makes the next one linearise afresh */
#define RELINEARIZE 0.1

/* ---- the profile (implicit.h) ------------------------------------------------ */

static kf_imp_profile prof;
static int prof_on;
/* counters too only while profiling: with it off (every simulation but the
 * evidence sweep's) the solve writes no process-wide state, so two states
 * may be stepped on two threads at once */
#define PROF_COUNT(field)                                                                                              \
    do {                                                                                                               \
        if (prof_on) prof.field++;                                                                                     \
    } while (0)
static const char *const STAGE_NAME[KF_IMP_T_COUNT] = {
    "setup",    "constraints", "predict", "linearize", "line search", "gradient", "diagonal",
    "mg build", "mg refresh",  "hessian", "precond",   "cg vectors",  "finish"};

void kf_imp_profile_enable(int on) { prof_on = on; }
void kf_imp_profile_take(kf_imp_profile *out) {
    if (out) *out = prof;
    memset(&prof, 0, sizeof prof);
}
const char *kf_imp_profile_stage(int stage) { return stage >= 0 && stage < KF_IMP_T_COUNT ? STAGE_NAME[stage] : "?"; }

static double prof_now(void) {
    if (!prof_on) return 0;
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return 1e3 * ts.tv_sec + 1e-6 * ts.tv_nsec;
}
/* the time since *t goes to stage; *t becomes now */
static void prof_lap(int stage, double *t) {
    if (!prof_on) return;
    double n = prof_now();
    prof.ms[stage] += n - *t;
    *t = n;
}

/* ---- vectors over the grid nodes (3 per node), block-ordered sums -------- */

double kf_imp_dot(kf_implicit *w, const double *x, const double *y) {
    size_t nb = w->nnode / KF_BLOCK_NODES;
#pragma omp parallel for schedule(static) num_threads(w->m->nthreads)
    for (size_t b = 0; b < nb; b++) {
        kf_v4d t = {0, 0, 0, 0};
        for (size_t k = w->act_start[b]; k < w->act_start[b + 1]; k++)
            t += KF_IMP_V4(x, w->act[k]) * KF_IMP_V4(y, w->act[k]);
        w->bsum[b] = t[0] + t[1] + t[2] + t[3];
    }
    double s = 0;
    for (size_t b = 0; b < nb; b++) s += w->bsum[b];
    return s;
}

/* Σ |x_i|² / m_i over the nodes with mass, block-ordered */
static double sum_minv(kf_implicit *w, const double *x) {
    size_t nb = w->nnode / KF_BLOCK_NODES;
#pragma omp parallel for schedule(static) num_threads(w->m->nthreads)
    for (size_t b = 0; b < nb; b++) {
        double t = 0;
        for (size_t k = w->act_start[b]; k < w->act_start[b + 1]; k++) {
            size_t i = (size_t)w->act[k];
            kf_v4d xi = KF_IMP_V4(x, i), x2 = xi * xi;
            t += (x2[0] + x2[1] + x2[2]) / w->mass[i];
        }
        w->bsum[b] = t;
    }
    double s = 0;
    for (size_t b = 0; b < nb; b++) s += w->bsum[b];
    return s;
}

/* ‖x‖ in the inverse-mass norm: √(Σ |x_i|² / m_i) over nodes with mass */
static double norm_minv(kf_implicit *w, const double *x) { return sqrt(sum_minv(w, x)); }

/* CG's update d += α p, r −= α q, returning ‖r‖ in the inverse-mass norm (one pass) */
static double cg_update(kf_implicit *w, double alpha) {
    size_t nb = w->nnode / KF_BLOCK_NODES;
    double *d = w->d, *r = w->r;
    const double *p = w->p, *q = w->q;
#pragma omp parallel for schedule(static) num_threads(w->m->nthreads)
    for (size_t b = 0; b < nb; b++) {
        double t = 0;
        for (size_t k = w->act_start[b]; k < w->act_start[b + 1]; k++) {
            size_t i = (size_t)w->act[k];
            KF_IMP_V4(d, i) += alpha * KF_IMP_V4(p, i);
            kf_v4d ri = KF_IMP_V4(r, i) - alpha * KF_IMP_V4(q, i), r2 = ri * ri;
            KF_IMP_V4(r, i) = ri;
            t += (r2[0] + r2[1] + r2[2]) / w->mass[i];
        }
        w->bsum[b] = t;
    }
    double s = 0;
    for (size_t b = 0; b < nb; b++) s += w->bsum[b];
    return sqrt(s);
}

/* ---- the potential ------------------------------------------------------------- */

/* F(v), Ψ and the gradient's S for every particle, and the Hessian blocks
 * when hessian is set (the line search needs only E and S) */
static double evaluate(kf_implicit *w, const double *v, int hessian, int project) {
    const kf_model *m = w->m;
    const kf_particles *p = &w->s->p;
    const double dt = w->dt;
    int bad = 0;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) reduction(| : bad)
    for (size_t i = 0; i < w->np; i++) {
        double G[9], *F = w->F + 9 * i;
        const double *Fn = w->Fn + 9 * i;
        kf_imp_gather(w, v, i, G);
        /* F(v) = (I + Δt G) Fⁿ, as kf_g2p computes it */
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                F[3 * a + b] =
                    Fn[3 * a + b] + dt * (G[3 * a] * Fn[b] + G[3 * a + 1] * Fn[3 + b] + G[3 * a + 2] * Fn[6 + b]);
        kf_imp_energy e;
        const kf_real ps[2] = {p->ps[0][i], p->ps[1][i]};
        const double vol = p->vol0[i];
        if (kf_imp_energy_eval_in(&m->mat[p->mat[i]], F, ps, Fn, hessian, project, &e) || !isfinite(e.psi)) {
            bad = 1;
            continue;
        }
        w->psi[i] = vol * e.psi;
        /* S = Δt V⁰ P Fⁿᵀ: the particle's gradient, scattered with γ */
        double *S = w->S + 9 * i;
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                S[3 * a + b] =
                    dt * vol *
                    (e.P[3 * a] * Fn[3 * b] + e.P[3 * a + 1] * Fn[3 * b + 1] + e.P[3 * a + 2] * Fn[3 * b + 2]);
        if (!hessian) continue;
        /* Kp = Δt² V⁰ Tᵀ H T with T: G ↦ G Fⁿ (e.H is already Tᵀ H T, exactly symmetric) */
        double *Kp = w->Kp + 81 * i, s2 = dt * dt * vol;
        for (int r = 0; r < 81; r++) Kp[r] = s2 * e.H[r];
    }
    if (bad) return NAN;
    /* E = ½ Σ m |v − v*|² + Σ V⁰ Ψ, summed in a fixed order */
    size_t nb = w->nnode / KF_BLOCK_NODES;
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t b = 0; b < nb; b++) {
        double t = 0;
        for (size_t i = b * KF_BLOCK_NODES; i < (b + 1) * KF_BLOCK_NODES; i++)
            for (int a = 0; a < 3; a++) {
                double d = v[KF_IMP_NV * i + a] - w->vstar[KF_IMP_NV * i + a];
                t += 0.5 * w->mass[i] * d * d;
            }
        w->bsum[b] = t;
    }
    double E = 0;
    for (size_t b = 0; b < nb; b++) E += w->bsum[b];
    for (size_t i = 0; i < w->np; i++) E += w->psi[i];
    return E;
}

double kf_imp_linearize(kf_implicit *w, const double *v, int project) { return evaluate(w, v, 1, project); }

void kf_imp_gradient(kf_implicit *w, const double *v, double *g) {
#pragma omp parallel for schedule(static) num_threads(w->m->nthreads)
    for (size_t i = 0; i < w->nnode; i++)
        for (int a = 0; a < KF_IMP_NV; a++)
            g[KF_IMP_NV * i + a] = w->mass[i] * (v[KF_IMP_NV * i + a] - w->vstar[KF_IMP_NV * i + a]);
    kf_imp_scatter(w, w->S, g);
}

void kf_imp_hessian_action(kf_implicit *w, const double *x, double *y) {
#pragma omp parallel for schedule(static) num_threads(w->m->nthreads)
    for (size_t i = 0; i < w->nnode; i++)
        for (int a = 0; a < KF_IMP_NV; a++) y[KF_IMP_NV * i + a] = a < 3 ? w->mass[i] * x[KF_IMP_NV * i + a] : 0.0;
    kf_imp_scatter_product(w, x, y);
}

/* S = Δt V⁰ τ(Fⁿ) from the particles' stored Kirchhoff stress; 0 when the
 * state has none */
static int stress_of_fn(kf_implicit *w) {
    const kf_particles *p = &w->s->p;
    if (!w->s->tau_valid) return 0;
    static const int sym[9] = {0, 3, 4, 3, 1, 5, 4, 5, 2}; /* τ_ij in the xx yy zz xy xz yz planes */
#pragma omp parallel for schedule(static) num_threads(w->m->nthreads)
    for (size_t i = 0; i < w->np; i++) {
        const double s = w->dt * (double)p->vol0[i];
        for (int k = 0; k < 9; k++) w->S[9 * i + k] = s * (double)p->tau[sym[k]][i];
    }
    return 1;
}

/* ---- Newton–Krylov ------------------------------------------------------------ */

/* z = P D⁻¹ r: the Jacobi preconditioner restricted to the free directions;
 * or the multigrid V-cycle (implicit/mg_cycle.c) */
static void precondition(kf_implicit *w, const double *r, double *z) {
    if (w->mg) {
        kf_imp_mg_apply_active(w, r, z);
        return;
    }
#pragma omp parallel for schedule(static) num_threads(w->m->nthreads)
    for (size_t k = 0; k < w->nact; k++) {
        size_t i = (size_t)w->act[k];
        for (int a = 0; a < 3; a++)
            z[KF_IMP_NV * i + a] =
                w->diag[KF_IMP_NV * i + a] > 0 ? r[KF_IMP_NV * i + a] / w->diag[KF_IMP_NV * i + a] : 0.0;
    }
    kf_imp_project(w, z);
}

/* CG on (P H P) d = −P g from d = 0; returns the iterations taken.
 * blocks_changed: Kp is new since the last call (the diagonal and the
 * preconditioner's operators are rebuilt) */
static int pcg(kf_implicit *w, double tol, int kmax, int blocks_changed) {
    const size_t n3 = KF_IMP_NV * w->nnode;
    double *d = w->d, *r = w->r, *z = w->z, *p = w->p, *q = w->q;
    double t = prof_now();
    memset(d, 0, n3 * sizeof *d);
    for (size_t k = 0; k < n3; k++) r[k] = -w->g[k];
    /* (d, r, z, p, q vanish off the nodes with mass: only those are visited) */
    if (blocks_changed) {
        /* the diagonal of the Hessian: mass plus the particles' stiffness */
        for (size_t i = 0; i < w->nnode; i++)
            for (int a = 0; a < 3; a++) w->diag[KF_IMP_NV * i + a] = w->mass[i];
        kf_imp_scatter_diag(w, w->diag);
    }
    prof_lap(KF_IMP_T_DIAG, &t);
    if (blocks_changed && w->m->sim.precond == KF_PRECOND_MULTIGRID) {
        /* the levels once per substep, their operators at every Newton iteration */
        if (!w->mg && kf_imp_mg_create(w)) {
            kf_imp_mg_free(w->mg); /* out of memory: Jacobi instead */
            w->mg = NULL;
        }
        prof_lap(KF_IMP_T_MG_BUILD, &t);
        if (w->mg) kf_imp_mg_refresh(w);
        prof_lap(KF_IMP_T_MG_REFRESH, &t);
    }
    precondition(w, r, z);
    PROF_COUNT(precond_applications);
    prof_lap(KF_IMP_T_PRECOND, &t);
    memcpy(p, z, n3 * sizeof *p);
    double rz = kf_imp_dot(w, r, z), r0 = norm_minv(w, r);
    int it = 0;
    while (it < kmax && r0 > 0) {
        prof_lap(KF_IMP_T_CG_VECTORS, &t);
        kf_imp_hessian_action(w, p, q);
        kf_imp_project(w, q);
        PROF_COUNT(hessian_products);
        prof_lap(KF_IMP_T_HESSIAN, &t);
        double pq = kf_imp_dot(w, p, q);
        it++;
        if (!(pq > 0)) break;
        if (cg_update(w, rz / pq) <= tol * r0) break;
        prof_lap(KF_IMP_T_CG_VECTORS, &t);
        precondition(w, r, z);
        PROF_COUNT(precond_applications);
        prof_lap(KF_IMP_T_PRECOND, &t);
        double rz1 = kf_imp_dot(w, r, z), beta = rz1 / rz;
        rz = rz1;
        for (size_t k = 0; k < w->nact; k++)
            KF_IMP_V4(p, w->act[k]) = KF_IMP_V4(z, w->act[k]) + beta * KF_IMP_V4(p, w->act[k]);
    }
    prof_lap(KF_IMP_T_CG_VECTORS, &t);
    return it;
}

int kf_imp_solve(kf_implicit *w, double *v) {
    const kf_sim_def *sd = &w->m->sim;
    const double tol = sd->newton_tol > 0 ? sd->newton_tol : DEF_NEWTON_TOL;
    const int nmax = sd->newton_max > 0 ? sd->newton_max : DEF_NEWTON_MAX;
    const double ktol = sd->krylov_tol > 0 ? sd->krylov_tol : DEF_KRYLOV_TOL;
    const int kmax = sd->krylov_max > 0 ? sd->krylov_max : DEF_KRYLOV_MAX;
    const size_t n3 = KF_IMP_NV * w->nnode;

    /* the momentum scale: √M times the RMS speed of v* (at least what gravity adds in a substep) */
    double M = 0, mv2 = 0;
    for (size_t i = 0; i < w->nnode; i++) {
        const double *vs = w->vstar + KF_IMP_NV * i;
        M += w->mass[i];
        mv2 += w->mass[i] * (vs[0] * vs[0] + vs[1] * vs[1] + vs[2] * vs[2]);
    }
    double gmag =
        sqrt(sd->gravity[0] * sd->gravity[0] + sd->gravity[1] * sd->gravity[1] + sd->gravity[2] * sd->gravity[2]);
    double vscale = M > 0 ? sqrt(mv2 / M) : 0;
    if (vscale < gmag * w->dt) vscale = gmag * w->dt;
    if (vscale < 1e-6 * sd->dx / w->dt) vscale = 1e-6 * sd->dx / w->dt;
    const double scale = sqrt(M) * vscale;

    w->newton_iterations = w->krylov_iterations = 0;
    w->converged = 0;
    /* start from the explicit step when it lowers E: v + P Δt f(Fⁿ)/m. Its
     * slow part (a body resting or bending under gravity) is what Jacobi-CG
     * resolves slowest; the fast part it overshoots at large steps is what
     * CG removes in a few iterations (and the comparison catches a blow-up).
     * f(Fⁿ) is the scatter of S = Δt V⁰ τ(Fⁿ), the Kirchhoff stress the last
     * substep's stress pass left in the particles (float: it only picks the
     * start), or an evaluation at G = 0 when there is none. */
    double t = prof_now();
    if (!stress_of_fn(w)) {
        memset(w->vt, 0, n3 * sizeof *w->vt);
        if (!isfinite(evaluate(w, w->vt, 0, 1))) return -1; /* G = 0: F = Fⁿ, S = Δt V⁰ P(Fⁿ) Fⁿᵀ */
        PROF_COUNT(energy_evals);
    }
    memset(w->r, 0, n3 * sizeof *w->r);
    kf_imp_scatter(w, w->S, w->r);
    for (size_t i = 0; i < w->nnode; i++)
        for (int a = 0; a < 3; a++)
            w->d[KF_IMP_NV * i + a] = w->mass[i] > 0 ? -w->r[KF_IMP_NV * i + a] / w->mass[i] : 0.0;
    kf_imp_project(w, w->d);
    for (size_t k = 0; k < n3; k++) w->vt[k] = v[k] + w->d[k];
    prof_lap(KF_IMP_T_PREDICT, &t);
    /* the Hessian blocks at v*, then E at two other starts; Newton begins
     * at the lowest of the three, with the blocks of v* (see below):
     * - the explicit predictor above, best at small steps;
     * - the grid's velocity before gravity, v* − P Δt g: a stiff body
     *   barely moves in a step, so at large steps (hundreds of explicit
     *   steps) v* is far from the solution in the stiffness's norm (E = 1e10,
     *   4 steps a frame: a residual 1e5 times the tolerance's scale, six
     *   Newton iterations) while the body's last velocity is close */
    double E = evaluate(w, v, 1, 1);
    PROF_COUNT(linearizations);
    double *S_best = w->S, *S_try = w->S_alt;
    const double *best = v;
    double *q = w->q; /* (CG's scratch, unused before the first solve) */
    const double gdt[3] = {w->dt * sd->gravity[0], w->dt * sd->gravity[1], w->dt * sd->gravity[2]};
    memset(q, 0, n3 * sizeof *q);
    for (size_t k = 0; k < w->nact; k++)
        for (int a = 0; a < 3; a++) q[KF_IMP_NV * (size_t)w->act[k] + a] = -gdt[a];
    kf_imp_project(w, q);
    for (size_t k = 0; k < n3; k++) q[k] += v[k];
    double *const start[2] = {w->vt, q};
    for (int c = 0; c < 2; c++) {
        w->S = S_try;
        double Ec = evaluate(w, start[c], 0, 1);
        PROF_COUNT(energy_evals);
        if (isfinite(Ec) && Ec < E) {
            E = Ec, best = start[c];
            S_try = S_best, S_best = w->S;
        }
    }
    w->S = S_best, w->S_alt = S_try;
    prof_lap(KF_IMP_T_LINEARIZE, &t);
    if (!isfinite(E)) return -1;
    if (best != v) memcpy(v, best, n3 * sizeof *v);
    prof_lap(KF_IMP_T_PREDICT, &t);
    kf_imp_gradient(w, v, w->g);
    kf_imp_project(w, w->g);
    double res = scale > 0 ? norm_minv(w, w->g) / scale : 0;
    prof_lap(KF_IMP_T_GRADIENT, &t);
    /* Newton with the blocks kept while they work: a Newton iteration only
     * linearises again (SVD, blocks, diagonal, coarse operators) when the
     * previous one, on older blocks, cut the residual by less than
     * RELINEARIZE; otherwise CG runs on the blocks of an earlier iterate
     * (a chord step: still a descent direction, the blocks being positive
     * semi-definite, and the line search and the convergence test use the
     * true E and gradient, so the solution meets the same tolerance) */
    int fresh = 1;          /* the blocks are the current iterate's (or v*'s, before the first step) */
    int blocks_changed = 1; /* the diagonal and coarse operators need rebuilding */
    double res_prev = INFINITY;
    while (res > tol && w->newton_iterations < nmax) {
        if (!fresh && res > RELINEARIZE * res_prev) {
            evaluate(w, v, 1, 1);
            PROF_COUNT(linearizations);
            prof_lap(KF_IMP_T_LINEARIZE, &t);
            blocks_changed = 1;
        }
        int kit = pcg(w, fmax(ktol, FORCING * tol / res), kmax, blocks_changed);
        blocks_changed = 0;
        w->krylov_iterations += kit;
        t = prof_now();
        double slope = kf_imp_dot(w, w->g, w->d);
        if (!(slope < 0)) {
            /* CG found no descent (round-off at convergence): steepest descent in the mass metric */
            for (size_t i = 0; i < w->nnode; i++)
                for (int a = 0; a < 3; a++)
                    w->d[KF_IMP_NV * i + a] = w->mass[i] > 0 ? -w->g[KF_IMP_NV * i + a] / w->mass[i] : 0.0;
            slope = kf_imp_dot(w, w->g, w->d);
        }
        /* backtracking (Armijo) on E; the slack is E's round-off */
        double alpha = 1, Et = NAN;
        int ok = 0;
        for (int ls = 0; ls < 30; ls++) {
            for (size_t k = 0; k < n3; k++) w->vt[k] = v[k] + alpha * w->d[k];
            Et = evaluate(w, w->vt, 0, 1);
            PROF_COUNT(energy_evals);
            if (isfinite(Et) && Et <= E + 1e-4 * alpha * slope + 1e-13 * fabs(E)) {
                ok = 1;
                break;
            }
            alpha *= 0.5;
        }
        w->newton_iterations++;
        if (!ok) {
            prof_lap(KF_IMP_T_LINESEARCH, &t);
            if (!fresh) {
                /* the old blocks gave no decrease: linearise here and try again */
                evaluate(w, v, 1, 1);
                PROF_COUNT(linearizations);
                prof_lap(KF_IMP_T_LINEARIZE, &t);
                fresh = blocks_changed = 1;
                res_prev = INFINITY;
                continue;
            }
            /* no decrease to round-off: v is as good as it gets */
            evaluate(w, v, 0, 1);
            prof_lap(KF_IMP_T_LINESEARCH, &t);
            break;
        }
        memcpy(v, w->vt, n3 * sizeof *v);
        E = Et;
        fresh = 0;
        prof_lap(KF_IMP_T_LINESEARCH, &t);
        kf_imp_gradient(w, v, w->g);
        kf_imp_project(w, w->g);
        res_prev = res;
        res = norm_minv(w, w->g) / scale;
        prof_lap(KF_IMP_T_GRADIENT, &t);
        if (!isfinite(res)) return -1;
    }
    w->residual = res;
    w->converged = res <= tol;
    return 0;
}

/* ---- the substep's grid stage ------------------------------------------------- */

/* Implicit midpoint (kf_implicit_scheme): the solve ran backward Euler over
 * half the step, so w->v is v_{n+½}, and the grid is left at it: kf_g2p
 * moves and deforms the particles with it over the whole step. Their
 * velocity must leave at v_{n+1} = 2 v_{n+½} − v_n, so the G2P of the
 * grid's δ = v_{n+½} − v_n (projected where a boundary fixes a direction:
 * there v_{n+1} is the boundary's, as v_{n+½} is) is kept per particle and
 * added after kf_g2p (kf_implicit_g2p_finish). v_n = v* − h g. Returns 0 or
 * -1 (out of memory). */
static int midpoint_velocity(const kf_model *m, kf_state *s, kf_implicit *w, double h) {
    const size_t n3 = KF_IMP_NV * w->nnode, np = w->np;
    if (s->mid_cap < np) {
        free(s->mid_dv);
        s->mid_dv = malloc(12 * (np ? np : 1) * sizeof *s->mid_dv);
        s->mid_cap = s->mid_dv ? np : 0;
        if (!s->mid_dv) return -1;
    }
    double *dl = w->q; /* CG's scratch, free after the solve */
    const double gh[3] = {h * m->sim.gravity[0], h * m->sim.gravity[1], h * m->sim.gravity[2]};
    memset(dl, 0, n3 * sizeof *dl);
    for (size_t k = 0; k < w->nact; k++) {
        size_t i = (size_t)w->act[k];
        for (int a = 0; a < 3; a++)
            dl[KF_IMP_NV * i + a] = w->v[KF_IMP_NV * i + a] - (w->vstar[KF_IMP_NV * i + a] - gh[a]);
    }
    kf_imp_project(w, dl);
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t i = 0; i < np; i++) {
        double dv[3], dC[9];
        kf_imp_g2p_vector(w, dl, i, dv, dC);
        kf_real *o = s->mid_dv + 12 * i;
        for (int a = 0; a < 3; a++) o[a] = (kf_real)dv[a];
        for (int k = 0; k < 9; k++) o[3 + k] = (kf_real)dC[k];
    }
    s->mid_pending = 1;
    return 0;
}

void kf_implicit_g2p_finish(const kf_model *m, kf_state *s) {
    if (!s->mid_pending) return;
    kf_particles *p = &s->p;
    const kf_real *dv = s->mid_dv;
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t i = 0; i < p->n; i++) {
        const kf_real *o = dv + 12 * i;
        for (int a = 0; a < 3; a++) p->v[a][i] += o[a];
        for (int k = 0; k < 9; k++) p->C[k][i] += o[3 + k];
    }
    s->mid_pending = 0;
}

int kf_implicit_grid(const kf_model *m, kf_state *s, double dt, kf_step_stats *st, kf_trouble *trouble) {
    memset(trouble, 0, sizeof *trouble);
    kf_implicit w;
    int rc = 0;
    double t = prof_now();
    PROF_COUNT(substeps);
    const int mid = m->sim.implicit_scheme == KF_SCHEME_MIDPOINT;
    int crc = kf_imp_create(&w, m, s, mid ? 0.5 * dt : dt);
    prof_lap(KF_IMP_T_SETUP, &t);
    if (!crc) crc = kf_imp_constraints(&w, w.v);
    prof_lap(KF_IMP_T_CONSTRAINTS, &t);
    if (crc) {
        rc = 1;
        trouble->found = 1;
        snprintf(trouble->what, sizeof trouble->what, "out of memory in the implicit solve");
    } else if (kf_imp_solve(&w, w.v)) {
        rc = 1;
        trouble->found = 1;
        snprintf(trouble->what, sizeof trouble->what, "implicit solve: non-finite potential");
        trouble->value = w.residual;
    }
    trouble->substep = s->substep;
    trouble->material = -1;
    if (rc) {
        kf_imp_free(&w);
        return 1;
    }
    t = prof_now();
    /* the boundaries' reactions: the gradient at the solution, unprojected.
     * A separate boundary that pulls lets go, and the substep is solved once
     * more without it (one active-set step); then friction from the pushes */
    kf_imp_gradient(&w, w.v, w.g);
    int rel = kf_imp_release_pulling(&w, w.g);
    if (rel > 0) {
        if (kf_imp_constraints(&w, w.v) || kf_imp_solve(&w, w.v)) rel = -1;
        else kf_imp_gradient(&w, w.v, w.g);
    }
    if (rel < 0) {
        kf_imp_free(&w);
        trouble->found = 1;
        snprintf(trouble->what, sizeof trouble->what, "implicit solve failed releasing a separate boundary");
        return 1;
    }
    kf_imp_friction(&w, w.v, w.g);
    if (mid && midpoint_velocity(m, s, &w, 0.5 * dt)) {
        kf_imp_free(&w);
        trouble->found = 1;
        snprintf(trouble->what, sizeof trouble->what, "out of memory in the implicit solve");
        return 1;
    }
    /* leave (m (v − h g), m) so the explicit grid update over the solve's
     * step h turns it into exactly the velocity it would have produced,
     * boundaries included (midpoint: h = Δt/2, so the colliders' velocities
     * are the mid-step ones, as v's are) */
    kf_grid *g = &s->g;
    const double h = w.dt, gdt[3] = {h * m->sim.gravity[0], h * m->sim.gravity[1], h * m->sim.gravity[2]};
#pragma omp parallel for schedule(static) num_threads(m->nthreads)
    for (size_t i = 0; i < w.nnode; i++) {
        double mi = w.mass[i];
        if (mi > 0)
            g->node[i] = (kf_v4){(kf_real)(mi * (w.v[KF_IMP_NV * i] - gdt[0])),
                                 (kf_real)(mi * (w.v[KF_IMP_NV * i + 1] - gdt[1])),
                                 (kf_real)(mi * (w.v[KF_IMP_NV * i + 2] - gdt[2])), (kf_real)mi};
        else g->node[i] = (kf_v4){0, 0, 0, 0};
    }
    kf_grid_update(m, s, (kf_real)h);
    if (st) {
        st->newton_iterations += w.newton_iterations;
        st->krylov_iterations += w.krylov_iterations;
        st->newton_residual = w.residual;
    }
    kf_imp_free(&w);
    prof_lap(KF_IMP_T_FINISH, &t);
    return 0;
}
