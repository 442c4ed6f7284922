/* implicit_problem.c — the evidence's problems, runs and error metric
 * (implicit_problem.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "implicit_problem.h"

int g_wall;

/* the cost clock: process CPU time, or (g_wall) wall-clock time */
static double cpu_now(void) {
    struct timespec ts;
    clock_gettime(g_wall ? CLOCK_MONOTONIC : CLOCK_PROCESS_CPUTIME_ID, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

double g_dx = 0.025;
double g_newton_tol, g_krylov_tol;
int g_krylov_max, g_newton_max;
int g_tight;
int g_repeat = 1;
int g_profile;
int g_tumble;
#define TUMBLE_OMEGA 4.0 /* rad/s about z */
#define TUMBLE_VY 1.2    /* m/s up: it rises and falls back to about its start in the 6 frames */
#define BEND_V 1.0       /* m/s: the bending field's scale (ends up, middle down) */

/* the problem's model and seeded state for stiffness E and the given integrator */
static kf_state *make_sim(double E, integ how, kf_precond pc, double cfl, double dt_fixed, kf_model **mo) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = g_dx;
    sd.walls = 1;
    sd.wall_boundary = KF_BOUNDARY_STICKY;
    sd.threads = 1;
    sd.cfl = cfl;
    sd.dt_fixed = dt_fixed;
    sd.max_retries = 0;
    sd.integrator = how ? KF_INTEGRATOR_IMPLICIT : KF_INTEGRATOR_EXPLICIT;
    sd.implicit_scheme = how == MIDPOINT ? KF_SCHEME_MIDPOINT : KF_SCHEME_BACKWARD_EULER;
    sd.precond = pc;
    if (g_newton_tol > 0) sd.newton_tol = g_newton_tol;
    if (g_krylov_tol > 0) sd.krylov_tol = g_krylov_tol;
    if (g_krylov_max > 0) sd.krylov_max = g_krylov_max;
    if (g_newton_max > 0) sd.newton_max = g_newton_max;
    if (g_tight) sd.newton_tol = TIGHT_TOL, sd.newton_max = 200;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    kf_material mat;
    kf_material_preset("jello", &mat);
    mat.E = E;
    mat.nu = 0.3;
    mat.density = 1000;
    int id = kf_model_add_material(m, &mat, err, sizeof err);
    kf_state *s = kf_state_create(m);
    if (!g_tumble) {
        double lo[3] = {-0.08, 0.46, 0.44}, hi[3] = {0.4, 0.54, 0.56};
        kf_state_fill_box(s, m, lo, hi, id, NULL, 2, 0);
    } else {
        /* the bar free in the air, thrown up; tumbling: spinning about z
         * through its centre (tips at 0.8 m/s), so gravity's curve, the
         * rotation and the elastic response all count, and the motion (tens
         * of cm) does not shrink with the stiffness; bending (g_tumble 2):
         * a velocity field quadratic along the bar with no net momentum,
         * which rings its bending modes as the cantilever's sag does */
        const double c[3] = {0.5, 0.6, 0.5}, lo[3] = {0.3, 0.56, 0.44}, hi[3] = {0.7, 0.64, 0.56};
        kf_state_fill_box(s, m, lo, hi, id, NULL, 2, 0);
        kf_particles_view pv = kf_state_particles(s);
        for (size_t i = 0; i < pv.n; i++) {
            const double dx = pv.x[0][i] - c[0], dy = pv.x[1][i] - c[1], u = dx / 0.2;
            if (g_tumble == 2) {
                pv.v[0][i] = 0;
                pv.v[1][i] = (kf_real)(BEND_V * (2 * u * u - 2.0 / 3.0) + TUMBLE_VY);
            } else {
                pv.v[0][i] = (kf_real)(-TUMBLE_OMEGA * dy);
                pv.v[1][i] = (kf_real)(TUMBLE_OMEGA * dx + TUMBLE_VY);
            }
            pv.v[2][i] = 0;
        }
    }
    *mo = m;
    return s;
}

/* the particles' positions by stable id (3 n) */
static void read_positions(kf_state *s, double *x, size_t *n_out) {
    kf_particles_view pv = kf_state_particles(s);
    for (size_t i = 0; i < pv.n; i++)
        for (int a = 0; a < 3; a++) x[3 * pv.id[i] + a] = pv.x[a][i];
    *n_out = pv.n;
}

/* simulate; traj receives the trajectory (TRAJ_DOUBLES, see traj_frame) */
run simulate(double E, integ how, kf_precond pc, double cfl, double dt_fixed, double *traj, size_t *n_out) {
    run r = {0};
    r.implicit = how;
    r.precond = pc;
    r.cfl = cfl;
    r.dt = dt_fixed;
    kf_model *m;
    kf_state *s = make_sim(E, how, pc, cfl, dt_fixed, &m);
    kf_step_stats st = {0};
    char msg[512];
    kf_imp_profile_enable(g_profile);
    kf_imp_profile_take(NULL);
    read_positions(s, traj_frame(traj, 0), n_out);
    double cpu = 0;
    r.ok = 1;
    for (int f = 0; f < FRAMES && r.ok; f++) {
        double t0 = cpu_now();
        r.ok = !kf_advance(m, s, 1.0 / FPS, &st, msg, sizeof msg);
        cpu += cpu_now() - t0;
        read_positions(s, traj_frame(traj, f + 1), n_out);
    }
    if (!r.ok) fprintf(stderr, "  (E %.0e, %s, step %.3g s: %s)\n", E, run_name(&r), dt_fixed, msg);
    r.cpu_per_frame = cpu / FRAMES;
    kf_imp_profile_take(&r.prof);
    memcpy(r.other_ms, st.ms, sizeof r.other_ms);
    r.substeps = st.substeps;
    r.newton = st.newton_iterations;
    r.krylov = st.krylov_iterations;
    kf_state_destroy(s);
    kf_model_destroy(m);
    return r;
}

static int cmp_double(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

run simulate_median(double E, integ how, kf_precond pc, double cfl, double dt_fixed, double *traj, size_t *n_out) {
    double t[64], ps[KF_IMP_T_COUNT + KF_STAGE_COUNT][64];
    int n = g_repeat < 1 ? 1 : g_repeat > 64 ? 64 : g_repeat;
    run r = {0};
    for (int k = 0; k < n; k++) {
        r = simulate(E, how, pc, cfl, dt_fixed, traj, n_out);
        t[k] = r.cpu_per_frame;
        for (int j = 0; j < KF_IMP_T_COUNT; j++) ps[j][k] = r.prof.ms[j];
        for (int j = 0; j < KF_STAGE_COUNT; j++) ps[KF_IMP_T_COUNT + j][k] = r.other_ms[j];
    }
    qsort(t, n, sizeof *t, cmp_double);
    r.cpu_per_frame = n % 2 ? t[n / 2] : 0.5 * (t[n / 2 - 1] + t[n / 2]);
    for (int j = 0; j < KF_IMP_T_COUNT + KF_STAGE_COUNT; j++) {
        qsort(ps[j], n, sizeof *ps[j], cmp_double);
        double med = n % 2 ? ps[j][n / 2] : 0.5 * (ps[j][n / 2 - 1] + ps[j][n / 2]);
        if (j < KF_IMP_T_COUNT) r.prof.ms[j] = med;
        else r.other_ms[j - KF_IMP_T_COUNT] = med;
    }
    return r;
}

void print_profile(FILE *o, const run *r) {
    const double ns = (double)r->substeps, sub_ms = 1e3 * r->cpu_per_frame * FRAMES / ns;
    const kf_imp_profile *p = &r->prof;
    double sum = 0;
    fprintf(o,
            "  per substep: %.3f CPU ms; %.2f linearisations, %.2f energies, %.2f Hessian products, "
            "%.2f preconditioner applications\n",
            sub_ms, p->linearizations / ns, p->energy_evals / ns, p->hessian_products / ns,
            p->precond_applications / ns);
    for (int j = 0; j < KF_IMP_T_COUNT; j++) {
        sum += p->ms[j];
        fprintf(o, "    %-12s %7.3f ms  %5.1f%%\n", kf_imp_profile_stage(j), p->ms[j] / ns,
                100 * p->ms[j] / ns / sub_ms);
    }
    const char *other[] = {"sort", "p2g", "grid", "g2p", "stress"};
    fprintf(o, "    %-12s %7.3f ms  %5.1f%%  (implicit grid stage, profiled)\n", "sum", sum / ns,
            100 * sum / ns / sub_ms);
    for (int j = 0; j < 5; j++)
        if (j != KF_STAGE_GRID && j != KF_STAGE_P2G)
            fprintf(o, "    %-12s %7.3f ms  %5.1f%%  (kerf's wall-clock stage timer)\n", other[j], r->other_ms[j] / ns,
                    100 * r->other_ms[j] / ns / sub_ms);
}

double rms_diff(const double *x, const double *y, size_t n) {
    double s2 = 0;
    for (size_t k = 0; k < 3 * n; k++) s2 += (x[k] - y[k]) * (x[k] - y[k]);
    return sqrt(s2 / n);
}

double traj_diff(double *x, double *y, size_t n) {
    double worst = 0;
    for (int f = 1; f <= FRAMES; f++) worst = fmax(worst, rms_diff(traj_frame(x, f), traj_frame(y, f), n));
    return worst;
}

/* the error of trajectory x against the reference's: the worst frame's RMS
 * position difference (a swing seen at one instant can coincide with a
 * wrong one: the last frame alone scored backward Euler at 50x the
 * explicit step better than at 20x) */
void compare(run *r, double *x, double *ref, size_t n) {
    double mx = 0;
    for (int f = 1; f <= FRAMES; f++) {
        const double *xf = traj_frame(x, f), *rf = traj_frame(ref, f);
        for (size_t k = 0; k < 3 * n; k++) mx = fmax(mx, fabs(xf[k] - rf[k]));
    }
    r->rms = traj_diff(x, ref, n);
    r->rms_end = rms_diff(traj_frame(x, FRAMES), traj_frame(ref, FRAMES), n);
    r->maxerr = mx;
    if (!r->ok || r->rms != r->rms) r->rms = r->rms_end = r->maxerr = INFINITY;
}

double wave_speed(double E) {
    const double nu = 0.3, la = E * nu / ((1 + nu) * (1 - 2 * nu)), mu = E / (2 * (1 + nu));
    return sqrt((la + 2 * mu) / 1000);
}

double traj_motion(double *ref, size_t n) {
    double disp = 0;
    for (int f = 1; f <= FRAMES; f++) disp = fmax(disp, rms_diff(traj_frame(ref, f), traj_frame(ref, 0), n));
    return disp;
}

const char *run_name(const run *r) {
    if (!r->implicit) return "explicit";
    if (r->implicit == MIDPOINT) return r->precond == KF_PRECOND_JACOBI ? "midpoint, Jacobi" : "midpoint";
    return r->precond == KF_PRECOND_JACOBI ? "backward Euler, Jacobi" : "backward Euler";
}
