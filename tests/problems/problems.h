/* problems.h — the verification problems with exact answers (V4 bar, V5 manufactured solution, V6 breathing sphere),
 * set up for any kernel, force, particles per cell and CFL number, and timed
 * by per-process CPU time. Shared by the evidence sweeps (tools/evidence/)
 * and their regression tests (tests/test_evidence_*.c), so both measure the
 * same thing; tests/test_sphere.c builds its sphere and measures its zero
 * crossings with the same helpers.
 *
 * Every run uses a fixed step Δt = C Δx / (c_p + v_max) with v_max the
 * problem's largest exact speed, no gravity, no walls, and sim.threads from
 * the variant (1 for the sweeps: CPU time of one thread is what is compared).
 * Only the kf_step calls are timed; setup and measurement are not. */
#ifndef KF_EVIDENCE_PROBLEMS_H
#define KF_EVIDENCE_PROBLEMS_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include <kerf/kerf.h>

#define EV_PI 3.14159265358979323846

/* What is varied in a sweep. */
typedef struct ev_variant {
    kf_kernel kernel;
    kf_force force;
    int ppc;              /* particles per cell per axis: 2 (8 per cell) or 3 (27) */
    double cfl;           /* C in Δt = C Δx / (c_p + v_max) */
    int threads;          /* 1 for the timed sweeps */
    kf_transfer transfer; /* left out: APIC */
    double flip_ratio;    /* KF_TRANSFER_FLIP: the share kept per substep */
} ev_variant;

/* One run: the error against the exact answer and its cost. */
typedef struct ev_run {
    double error; /* relative, problem-specific (see each run function) */
    double value; /* the measured quantity (period, ωa/c_p, L2 error) */
    double cpu_s; /* process CPU seconds spent inside kf_step */
    long particles;
    long steps;
    int ok; /* 0: numerical trouble or too few zero crossings */
} ev_run;

static inline double ev_cpu_s(void) {
    struct timespec ts;
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static inline const char *ev_variant_name(const ev_variant *v, char *buf, size_t len) {
    snprintf(buf, len, "%s-%s-%d%s", v->kernel == KF_KERNEL_CUBIC ? "cubic" : "quad",
             v->force == KF_FORCE_CLASSIC ? "classic" : "mls", v->ppc * v->ppc * v->ppc,
             v->transfer == KF_TRANSFER_FLIP      ? "-flip"
             : v->transfer == KF_TRANSFER_PIC     ? "-pic"
             : v->transfer == KF_TRANSFER_POLYPIC ? "-polypic"
                                                  : "");
    return buf;
}

/* fixed corotated, the material of V4–V7 */
static inline kf_material ev_corotated(double rho, double E, double nu) {
    kf_material mat;
    memset(&mat, 0, sizeof mat);
    snprintf(mat.name, sizeof mat.name, "elastic");
    mat.model = KF_MAT_COROTATED;
    mat.density = rho;
    mat.E = E;
    mat.nu = nu;
    return mat;
}

static inline double ev_cp(double rho, double E, double nu) {
    return sqrt(E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)) / rho);
}

/* A free-space model (no gravity, no walls) with one material. Returns NULL
 * with a message on stderr. */
static inline kf_model *ev_model(const ev_variant *v, double dx, double dt, const kf_material *mat, int *id) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = dx;
    sd.gravity[0] = sd.gravity[1] = sd.gravity[2] = 0;
    sd.kernel = v->kernel;
    sd.force = v->force;
    sd.transfer = v->transfer;
    sd.flip_ratio = v->flip_ratio;
    sd.walls = 0;
    sd.dt_fixed = dt;
    sd.threads = v->threads;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    if (!m) {
        fprintf(stderr, "evidence: model: %s\n", err);
        return NULL;
    }
    *id = kf_model_add_material(m, mat, err, sizeof err);
    if (*id < 0) {
        fprintf(stderr, "evidence: material: %s\n", err);
        kf_model_destroy(m);
        return NULL;
    }
    return m;
}

/* least-squares slope of t[k] against k: zero crossings half a period apart */
static inline double ev_slope(int n, const double *t) {
    double sk = 0, st = 0, skk = 0, skt = 0;
    for (int k = 0; k < n; k++) sk += k, st += t[k], skk += (double)k * k, skt += k * t[k];
    return n >= 2 ? (n * skt - sk * st) / (n * skk - sk * sk) : 0;
}

/* one step, of which only kf_step's CPU time is added to *cpu; nonzero on
 * numerical trouble */
static inline int ev_timed_step(const kf_model *m, kf_state *s, double dt, double *cpu) {
    double c0 = ev_cpu_s();
    int bad = kf_step(m, s, dt, NULL, NULL);
    *cpu += ev_cpu_s() - c0;
    return bad;
}

/* a zero crossing of y between the samples (tprev, yprev) and (t, y): its
 * time, linear between the two, appended to tc[*nc] (at most 16 kept) */
static inline void ev_crossing(double yprev, double tprev, double y, double t, double tc[16], int *nc) {
    if (((yprev < 0 && y >= 0) || (yprev > 0 && y <= 0)) && *nc < 16)
        tc[(*nc)++] = tprev + (t - tprev) * yprev / (yprev - y);
}

/* ---- V4: the free–free axial bar ------------------------------------------
 * Length 2L = 50, E = 100, ν = 0, ρ = 1: c = 10, first period T₁ = 4L/c = 10.
 * Started in its first mode (v₀ = 0.1); a 2 x 2-cell cross-section suffices
 * (ν = 0 makes it exactly 1-D, see tests/test_bar.c). Measured: the period of
 * the left half's centre-of-mass velocity from its 5 zero crossings in 2.6 T₁.
 * res = L/Δx; error = |T/T₁ − 1|. */
#define EV_BAR_L 25.0
#define EV_BAR_C 10.0
#define EV_BAR_T1 10.0
#define EV_BAR_V0 0.1

static inline ev_run ev_bar(double res, const ev_variant *v) {
    ev_run out = {0};
    const double L = EV_BAR_L, dx = L / res, h = dx / v->ppc, dt = v->cfl * dx / (EV_BAR_C + EV_BAR_V0);
    kf_material mat = ev_corotated(1.0, 100.0, 0.0);
    int id;
    kf_model *m = ev_model(v, dx, dt, &mat, &id);
    if (!m) return out;
    kf_state *s = kf_state_create(m);
    const long nx = (long)(2 * L / h + 0.5), ny = 2 * v->ppc;
    const long n = nx * ny * ny;
    double *x = malloc(3 * n * sizeof *x), *vel = malloc(3 * n * sizeof *vel), *cxx = malloc(n * sizeof *cxx);
    uint8_t *left = malloc(n);
    long k = 0;
    for (long i = 0; i < nx; i++)
        for (long j = 0; j < ny; j++)
            for (long l = 0; l < ny; l++, k++) {
                double px = -L + (i + 0.5) * h, arg = EV_PI * px / (2 * L);
                x[3 * k] = px;
                x[3 * k + 1] = -0.5 * ny * h + (j + 0.5) * h;
                x[3 * k + 2] = -0.5 * ny * h + (l + 0.5) * h;
                vel[3 * k] = EV_BAR_V0 * sin(arg), vel[3 * k + 1] = vel[3 * k + 2] = 0;
                cxx[k] = EV_BAR_V0 * EV_PI / (2 * L) * cos(arg); /* APIC's C starts as the field's gradient */
                left[k] = px < 0;
            }
    kf_state_add_particles(s, m, n, x, vel, NULL, id, h * h * h);
    kf_particles_view pv = kf_state_particles(s);
    for (size_t p = 0; p < pv.n; p++) pv.C[0][p] = (kf_real)cxx[pv.id[p]];
    free(x), free(vel), free(cxx);

    const long steps = (long)(2.6 * EV_BAR_T1 / dt + 0.5);
    double prev = 0, tprev = 0, tc[16], cpu = 0;
    int nc = 0;
    out.ok = 1;
    for (long st = 0; st <= steps; st++) {
        if (st > 0 && ev_timed_step(m, s, dt, &cpu)) {
            out.ok = 0;
            break;
        }
        kf_particles_view r = kf_state_particles_read(s);
        double mv = 0, mm = 0;
        for (size_t p = 0; p < r.n; p++)
            if (left[r.id[p]]) mv += (double)r.mass[p] * r.v[0][p], mm += r.mass[p];
        double V = mv / mm, t = kf_state_time(s);
        if (st > 0) ev_crossing(prev, tprev, V, t, tc, &nc);
        prev = V, tprev = t;
    }
    free(left);
    kf_state_destroy(s);
    kf_model_destroy(m);
    out.cpu_s = cpu, out.particles = n, out.steps = steps;
    if (nc != 5) out.ok = 0;
    out.value = 2 * ev_slope(nc, tc);
    out.error = fabs(out.value / EV_BAR_T1 - 1);
    return out;
}

/* ---- V6: the breathing sphere --------------------------------------------
 * Rest radius a = 1, E = 1e3, ν = 0.3, ρ = 1, started at rest with
 * F₀ = 1.01 I. ω a/c_p is the first root z of 1 − z cot z = (λ+2μ)/(4μ) z²
 * (2.6702 for ν = 0.3). Measured from the zero crossings of the projection
 * onto the fundamental mode, q = Σ m (x − X)·r̂ j₁(z r/a), over 1.3 periods
 * (see tests/test_sphere.c for why the projection). res = a/Δx;
 * error = |ω a/c_p ÷ z − 1|. */
#define EV_SPH_E 1000.0
#define EV_SPH_NU 0.3
#define EV_SPH_STRETCH 1.01

static inline double ev_sph_j1(double z) { return z < 1e-4 ? z / 3 : (sin(z) / z - cos(z)) / z; }

/* first root of 1 − z cot z − (λ+2μ)/(4μ) z² in (2, 3.1), by bisection;
 * (λ+2μ)/μ = 2(1−ν)/(1−2ν) */
static inline double ev_breathing_root(double nu) {
    double r = (1 - nu) / (1 - 2 * nu) * 2 / 4, lo = 2.0, hi = 3.1;
    for (int it = 0; it < 100; it++) {
        double z = 0.5 * (lo + hi), f = 1 - z * cos(z) / sin(z) - r * z * z;
        /* f(2) < 0, and f → +∞ as z → π⁻ (cot z → −∞): one sign change */
        if (f < 0) lo = z;
        else hi = z;
    }
    return 0.5 * (lo + hi);
}

/* The sphere's particles: reference positions X on a lattice of spacing h
 * inside |X| < a (cell centres, in i, j, k order), placed at x = stretch X
 * with F = stretch I. The lattice spans one cell more than the sphere needs,
 * so rounding never drops a particle. Returns the count; X, x, F (3, 3 and 9
 * per particle) are the caller's to free. */
static inline size_t ev_sphere_lattice(double a, double h, double stretch, double **Xo, double **xo, double **Fo) {
    const int N = (int)ceil(a / h) + 1;
    size_t cap = (size_t)8 * N * N * N, n = 0;
    double *X = malloc(3 * cap * sizeof *X), *x = malloc(3 * cap * sizeof *x), *F = malloc(9 * cap * sizeof *F);
    for (int i = -N; i < N; i++)
        for (int j = -N; j < N; j++)
            for (int k = -N; k < N; k++) {
                double q[3] = {(i + 0.5) * h, (j + 0.5) * h, (k + 0.5) * h};
                if (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] >= a * a) continue;
                for (int e = 0; e < 3; e++) X[3 * n + e] = q[e], x[3 * n + e] = stretch * q[e];
                for (int e = 0; e < 9; e++) F[9 * n + e] = e % 4 == 0 ? stretch : 0;
                n++;
            }
    *Xo = X, *xo = x, *Fo = F;
    return n;
}

static inline ev_run ev_sphere(double res, const ev_variant *v) {
    ev_run out = {0};
    const double a = 1.0, dx = a / res, h = dx / v->ppc, cp = ev_cp(1.0, EV_SPH_E, EV_SPH_NU);
    const double z = ev_breathing_root(EV_SPH_NU), T = 2 * EV_PI * a / (z * cp);
    const double dt = v->cfl * dx / cp; /* at rest initially; |v| stays < 1% of c_p */
    kf_material mat = ev_corotated(1.0, EV_SPH_E, EV_SPH_NU);
    int id;
    kf_model *m = ev_model(v, dx, dt, &mat, &id);
    if (!m) return out;
    kf_state *s = kf_state_create(m);
    double *X, *x, *F;
    size_t n = ev_sphere_lattice(a, h, EV_SPH_STRETCH, &X, &x, &F);
    kf_state_add_particles(s, m, n, x, NULL, F, id, h * h * h);
    double *w = malloc(3 * n * sizeof *w);
    for (size_t p = 0; p < n; p++) {
        double r = sqrt(X[3 * p] * X[3 * p] + X[3 * p + 1] * X[3 * p + 1] + X[3 * p + 2] * X[3 * p + 2]);
        for (int e = 0; e < 3; e++) w[3 * p + e] = ev_sph_j1(z * r / a) * X[3 * p + e] / r;
    }
    free(x), free(F);
    const long steps = (long)(1.3 * T / dt + 0.5);
    double tc[16], qprev = 0, tprev = 0, cpu = 0;
    int nc = 0;
    out.ok = 1;
    for (long st = 0; st <= steps; st++) {
        if (st > 0 && ev_timed_step(m, s, dt, &cpu)) {
            out.ok = 0;
            break;
        }
        kf_particles_view r = kf_state_particles_read(s);
        double q = 0;
        for (size_t p = 0; p < r.n; p++) {
            uint32_t i = r.id[p];
            for (int e = 0; e < 3; e++) q += (double)r.mass[p] * w[3 * i + e] * ((double)r.x[e][p] - X[3 * i + e]);
        }
        double t = kf_state_time(s);
        if (st > 0) ev_crossing(qprev, tprev, q, t, tc, &nc);
        qprev = q, tprev = t;
    }
    free(X), free(w);
    kf_state_destroy(s);
    kf_model_destroy(m);
    out.cpu_s = cpu, out.particles = (long)n, out.steps = steps;
    if (nc != 3) out.ok = 0;
    double period = 2 * ev_slope(nc, tc);
    out.value = period > 0 ? 2 * EV_PI / period * a / cp : 0;
    out.error = fabs(out.value / z - 1);
    return out;
}

/* ---- V5: the manufactured solution ----------------------------------------
 * Exact motion of a fixed-corotated solid (E = 1e3, ν = 0.3, ρ = 1):
 *     U_a(X, t) = A sin(k X_a) sin(ω t + φ_a),  φ = 0, 2π/3, 4π/3,
 * k = 2π, A = 0.02 (A k = 0.126 < 0.3), ω = c_p k (so the linear part of the
 * body force vanishes and it is a standing wave; the nonlinear part remains).
 * F = I + diag(f_a), f_a = A k cos(k X_a) sin(ω t + φ_a) > 0, so R = I and
 *     P_aa = 2μ f_a + λ (J − 1) Π_{b≠a} (1 + f_b),
 *     ∂P_aa/∂X_a = f_a' (2μ + λ Π_{b≠a} (1 + f_b)²),  f_a' = ∂f_a/∂X_a,
 * and the body force per reference volume is b = ρ Ü − ∇·P.
 *
 * How it is imposed through the public API (no periodic boundary or body
 * force exists in the solver): the unit cube [0, 1]³ is the measured region;
 * it is surrounded by a layer of particles (3 Δx thick for the quadratic
 * kernel, 4 Δx for the cubic: every grid node an inner particle reads sees
 * only correct particles) whose x, v, F, C are set to the exact solution
 * after every step. Before each step every inner particle gets the impulse
 * Δt b(X_p, t_n)/ρ on its velocity, which P2G carries to the grid exactly as
 * a body force at t_n would be (symplectic Euler). The layer costs time too,
 * and it is counted (it is part of the computation).
 * Measured after one period T = 2π/ω: the RMS displacement error of the
 * inner particles, error = ‖u_h − U‖_rms / A. res = 1/Δx. */
#define EV_MMS_E 1000.0
#define EV_MMS_NU 0.3
#define EV_MMS_A 0.02

typedef struct ev_mms_field {
    double x[3], v[3], F[3], C[3]; /* F and C are diagonal */
} ev_mms_field;

static inline ev_mms_field ev_mms_exact(const double X[3], double t, double k, double w) {
    ev_mms_field f;
    for (int a = 0; a < 3; a++) {
        double ph = w * t + a * 2 * EV_PI / 3, s = sin(k * X[a]), c = cos(k * X[a]);
        f.x[a] = X[a] + EV_MMS_A * s * sin(ph);
        f.v[a] = EV_MMS_A * w * s * cos(ph);
        f.F[a] = 1 + EV_MMS_A * k * c * sin(ph);
        f.C[a] = EV_MMS_A * k * w * c * cos(ph) / f.F[a]; /* ∂v/∂x = ∂v/∂X F⁻¹ */
    }
    return f;
}

/* b_a / ρ at X, t (acceleration from the body force) */
static inline void ev_mms_body_accel(const double X[3], double t, double k, double w, double mu, double lam, double rho,
                                     double out[3]) {
    double f[3], fp[3], s[3];
    for (int a = 0; a < 3; a++) {
        double ph = w * t + a * 2 * EV_PI / 3;
        s[a] = EV_MMS_A * sin(k * X[a]) * sin(ph);
        f[a] = EV_MMS_A * k * cos(k * X[a]) * sin(ph);
        fp[a] = -k * k * s[a];
    }
    for (int a = 0; a < 3; a++) {
        int b = (a + 1) % 3, c = (a + 2) % 3;
        double g = (1 + f[b]) * (1 + f[c]);
        double div = fp[a] * (2 * mu + lam * g * g);
        out[a] = (-rho * w * w * s[a] - div) / rho;
    }
}

static inline ev_run ev_mms(double res, const ev_variant *v) {
    ev_run out = {0};
    const double dx = 1.0 / res, h = dx / v->ppc, rho = 1.0, E = EV_MMS_E, nu = EV_MMS_NU;
    const double mu = E / (2 * (1 + nu)), lam = E * nu / ((1 + nu) * (1 - 2 * nu)), cp = ev_cp(rho, E, nu);
    const double k = 2 * EV_PI, w = cp * k, T = 2 * EV_PI / w;
    const double vmax = EV_MMS_A * w;
    const long steps_est = (long)ceil(T / (v->cfl * dx / (cp + vmax)));
    const double dt = T / steps_est; /* land exactly on t = T */
    const double layer = (v->kernel == KF_KERNEL_CUBIC ? 4 : 3) * dx;
    kf_material mat = ev_corotated(rho, E, nu);
    int id;
    kf_model *m = ev_model(v, dx, dt, &mat, &id);
    if (!m) return out;
    kf_state *s = kf_state_create(m);
    const long na = (long)llround((1 + 2 * layer) / h);
    const long n = na * na * na;
    double *X = malloc(3 * n * sizeof *X), *x = malloc(3 * n * sizeof *x), *vel = malloc(3 * n * sizeof *vel);
    double *F = malloc(9 * n * sizeof *F);
    uint8_t *inner = malloc(n);
    long q = 0, ninner = 0;
    for (long i = 0; i < na; i++)
        for (long j = 0; j < na; j++)
            for (long l = 0; l < na; l++, q++) {
                double P[3] = {-layer + (i + 0.5) * h, -layer + (j + 0.5) * h, -layer + (l + 0.5) * h};
                ev_mms_field f = ev_mms_exact(P, 0, k, w);
                inner[q] = P[0] > 0 && P[0] < 1 && P[1] > 0 && P[1] < 1 && P[2] > 0 && P[2] < 1;
                ninner += inner[q];
                for (int a = 0; a < 3; a++) X[3 * q + a] = P[a], x[3 * q + a] = f.x[a], vel[3 * q + a] = f.v[a];
                for (int e = 0; e < 9; e++) F[9 * q + e] = 0;
                for (int a = 0; a < 3; a++) F[9 * q + 4 * a] = f.F[a];
            }
    kf_state_add_particles(s, m, n, x, vel, F, id, h * h * h);
    free(x), free(vel), free(F);
    kf_particles_view pv = kf_state_particles(s);
    for (size_t p = 0; p < pv.n; p++) {
        ev_mms_field f = ev_mms_exact(&X[3 * pv.id[p]], 0, k, w);
        for (int a = 0; a < 3; a++) pv.C[4 * a][p] = (kf_real)f.C[a];
    }
    double cpu = 0;
    out.ok = 1;
    for (long st = 0; st < steps_est; st++) {
        double t = kf_state_time(s);
        pv = kf_state_particles(s);
        for (size_t p = 0; p < pv.n; p++) {
            if (!inner[pv.id[p]]) continue;
            double acc[3];
            ev_mms_body_accel(&X[3 * pv.id[p]], t, k, w, mu, lam, rho, acc);
            for (int a = 0; a < 3; a++) pv.v[a][p] += (kf_real)(dt * acc[a]);
        }
        if (ev_timed_step(m, s, dt, &cpu)) {
            out.ok = 0;
            break;
        }
        /* the layer follows the exact solution */
        t = kf_state_time(s);
        pv = kf_state_particles(s);
        for (size_t p = 0; p < pv.n; p++) {
            if (inner[pv.id[p]]) continue;
            ev_mms_field f = ev_mms_exact(&X[3 * pv.id[p]], t, k, w);
            for (int a = 0; a < 3; a++) {
                pv.x[a][p] = (kf_real)f.x[a], pv.v[a][p] = (kf_real)f.v[a];
                for (int b = 0; b < 3; b++) pv.F[3 * a + b][p] = pv.C[3 * a + b][p] = 0;
                pv.F[4 * a][p] = (kf_real)f.F[a], pv.C[4 * a][p] = (kf_real)f.C[a];
            }
        }
    }
    double t = kf_state_time(s), e2 = 0;
    kf_particles_view r = kf_state_particles_read(s);
    for (size_t p = 0; p < r.n; p++) {
        if (!inner[r.id[p]]) continue;
        ev_mms_field f = ev_mms_exact(&X[3 * r.id[p]], t, k, w);
        for (int a = 0; a < 3; a++) {
            double d = (double)r.x[a][p] - f.x[a];
            e2 += d * d;
        }
    }
    free(X), free(inner);
    kf_state_destroy(s);
    kf_model_destroy(m);
    out.cpu_s = cpu, out.particles = n, out.steps = steps_est;
    out.value = sqrt(e2 / (double)ninner);
    out.error = out.value / EV_MMS_A;
    if (!(out.error < 1)) out.ok = 0;
    return out;
}

#endif
