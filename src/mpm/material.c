/* material.c — constitutive models of kerf (see material.h).
 *
 * Every formula runs in double on kf_real inputs and rounds once at the end:
 * the per-particle cost is dominated by the polar decomposition / SVD, not by
 * the precision of the few multiplies around it. */
#include "material.h"

#include <math.h>
#include <string.h>

#include "../core/mat3.h"
#include "../core/svd3.h"

#define KF_PI 3.14159265358979323846
#define DEG2RAD (KF_PI / 180.0)

/* guard rails: a Hencky strain needs σ > 0, so inverted or flat directions
 * use this floor (log = -9.2, a large but finite restoring stress) */
#define HENCKY_SIGMA_MIN 1e-4
/* water: J below this is numerical trouble anyway; the floor keeps p finite
 * (with γ = 7, p(0.01) = 1e14 κ) so the step's checks, not inf, report it */
#define WATER_J_MIN 1e-2

/* ---- small double helpers (the 3x3 algebra itself is core/mat3.h) ------- */

static inline void to_double(double D[9], const kf_real A[9]) {
    for (int i = 0; i < 9; i++) D[i] = (double)A[i];
}

/* U diag(d) Uᵀ, written symmetric by construction */
static void sym_udut(kf_real out[9], const kf_real U[9], const double d[3]) {
    for (int i = 0; i < 3; i++) {
        for (int j = i; j < 3; j++) {
            double t = 0;
            for (int k = 0; k < 3; k++) t += (double)U[3 * i + k] * d[k] * (double)U[3 * j + k];
            out[3 * i + j] = out[3 * j + i] = (kf_real)t;
        }
    }
}

/* F ← U diag(d) Vᵀ */
static void set_usvt(kf_real F[9], const kf_real U[9], const double d[3], const kf_real V[9]) {
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double t = 0;
            for (int k = 0; k < 3; k++) t += (double)U[3 * i + k] * d[k] * (double)V[3 * j + k];
            F[3 * i + j] = (kf_real)t;
        }
}

/* ---- polar rotation: scaled Newton fast path, SVD fallback -------------- */

/* Newton's iteration X ← ½(ζX + ζ⁻¹X⁻ᵀ) converges quadratically to the polar
 * rotation of any F with det F > 0. Frobenius scaling ζ = (‖X⁻¹‖/‖X‖)^½
 * speeds up the first steps when F is far from volume preserving; near
 * J = 1 (the common case) it is ≈ 1 and skipped, so an iteration costs one
 * division. Only used when det F is safely positive relative to the size of
 * F (conditioning bounded); returns 0 to ask for the SVD instead. */
static int polar_newton(const double F[9], double R[9]) {
#ifdef KF_DOUBLE
    const double target = 1e-16;
#else
    const double target = 1e-9;
#endif
    double f2 = 0;
    for (int i = 0; i < 9; i++) f2 += F[i] * F[i];
    double rms2 = f2 / 3; /* mean squared singular value */
    if (!(kf_m3d_det(F) > 1e-3 * rms2 * sqrt(rms2))) return 0;
    double X[9], K[9];
    for (int i = 0; i < 9; i++) X[i] = F[i];
    for (int it = 0; it < 16; it++) {
        kf_m3d_cofactor(K, X);
        double d = X[0] * K[0] + X[1] * K[1] + X[2] * K[2];
        if (!(d > 0)) return 0;
        double id = 1 / d, k2 = 0; /* X⁻ᵀ = K / d */
        for (int i = 0; i < 9; i++) k2 += K[i] * K[i];
        double a = 0.5, b = 0.5 * id;
        if (fabs(d - 1) > 0.1) {
            double x2 = 0;
            for (int i = 0; i < 9; i++) x2 += X[i] * X[i];
            double z = sqrt(sqrt(k2 / x2) * id);
            a = 0.5 * z;
            b = 0.5 * id / z;
        }
        double step2 = 0;
        for (int i = 0; i < 9; i++) {
            double xn = a * X[i] + b * K[i];
            step2 += (xn - X[i]) * (xn - X[i]);
            X[i] = xn;
        }
        /* quadratic convergence: the new error is about ½ step² ‖X⁻¹‖ */
        if (0.5 * step2 * sqrt(k2) * id <= target) {
            for (int i = 0; i < 9; i++) R[i] = X[i];
            return 1;
        }
    }
    return 0;
}

static void rotation_of(const double Fd[9], const kf_real F[9], double R[9]) {
    if (polar_newton(Fd, R)) return;
    kf_real Rr[9];
    kf_polar3(F, Rr);
    to_double(R, Rr);
}

/* fixed corotated τ = 2μ(F − R)Fᵀ + λ(J − 1)J I (below J_b the volume
 * barrier's g'(J) J, material.h), symmetrised so the transfer's angular
 * momentum balance does not see round-off skew */
static void corotated_tau(double mu, double la, double jc, const kf_real F[9], kf_real tau[9]) {
    double Fd[9], R[9], A[9];
    to_double(Fd, F);
    rotation_of(Fd, F, R);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double t = 0;
            for (int k = 0; k < 3; k++) t += (Fd[3 * i + k] - R[3 * i + k]) * Fd[3 * j + k];
            A[3 * i + j] = t;
        }
    double J = kf_m3d_det(Fd), g, g1, g2;
    kf_corot_volume(mu, la, J, jc, &g, &g1, &g2);
    double vol = g1 * J;
    for (int i = 0; i < 3; i++)
        for (int j = i; j < 3; j++) {
            double t = mu * (A[3 * i + j] + A[3 * j + i]) + (i == j ? vol : 0.0);
            tau[3 * i + j] = tau[3 * j + i] = (kf_real)t;
        }
}

static double corotated_psi(double mu, double la, double jc, const kf_real F[9]) {
    double Fd[9], R[9], s = 0;
    to_double(Fd, F);
    rotation_of(Fd, F, R);
    for (int i = 0; i < 9; i++) s += (Fd[i] - R[i]) * (Fd[i] - R[i]);
    double J = kf_m3d_det(Fd), g, g1, g2;
    kf_corot_volume(mu, la, J, jc, &g, &g1, &g2);
    return mu * s + g;
}

/* fixed corotated's limited state J_c (kf_corot_volume), 0 for none */
static double corot_jc(const kf_mat *m) { return m->model == KF_MAT_COROTATED ? m->state_limit : 0.0; }

/* sand's hardened friction coefficient at hardening state q (Klár 2016):
 * φ = h0 + (h1 q − h3) e^{−h2 q} clamped to [0, π/2 − 1e-6],
 * c_f = √(2/3) 2 sin φ / (3 − sin φ); the library's exp and sin, in double */
double kf_mat_friction_hardened(const kf_mat *m, double q) {
    double phi = m->h0 + (m->h1 * q - m->h3) * exp(-(double)m->h2 * q);
    phi = fmin(fmax(phi, 0.0), 0.5 * KF_PI - 1e-6);
    double sp = sin(phi);
    return sqrt(2.0 / 3.0) * 2 * sp / (3 - sp);
}

/* snow's hardening factor e^{ξ(1 − Jp)}; under a fixed step, at most the
 * stiffness the step resolves (Jp below state_limit: the factor there) */
static double snow_hardening(const kf_mat *m, const kf_real ps[2]) {
    double jp = m->c_limit > 0 && (double)ps[0] < m->state_limit ? m->state_limit : (double)ps[0];
    return exp((double)m->xi * (1.0 - jp));
}

/* ---- Hencky helpers -------------------------------------------------------- */

/* lower clamps written so a NaN passes through (fmax would drop it and
 * hide a broken particle behind a finite stress) */
static inline double floor_nan(double x, double lo) { return x < lo ? lo : x; }

static void hencky_strain(const kf_real F[9], kf_real U[9], kf_real V[9], kf_real s[3], double e[3]) {
    kf_svd3(F, U, s, V);
    for (int i = 0; i < 3; i++) e[i] = log(floor_nan((double)s[i], HENCKY_SIGMA_MIN));
}

static double water_J(const kf_real ps[2]) { return floor_nan((double)ps[0], WATER_J_MIN); }

/* Tait's p = κ(J^−γ − 1); below the limited state J_c (kf_mat_limit) the
 * pressure goes on with the constant wave speed c_limit the step resolves,
 * dp/dJ = −ρ c²/J²: continuous at J_c, still without bound as J → 0 */
static double water_pressure(const kf_mat *m, double J) {
    double k = m->kappa, g = m->gamma;
    if (!(m->c_limit > 0 && J < m->state_limit)) return k * (pow(J, -g) - 1);
    double jc = m->state_limit, c2 = m->c_limit * m->c_limit * (double)m->rho;
    return k * (pow(jc, -g) - 1) + c2 * (1 / J - 1 / jc);
}

/* ψ(J) = κ/(γ−1) (J^{1−γ} − 1 + (γ−1)(J − 1)), so ψ(1) = 0 and ψ'(J) = −p;
 * written with expm1 to keep accuracy near J = 1; below J_c the integral of
 * the limited pressure */
static double water_psi(const kf_mat *m, double J) {
    double k = m->kappa, g = m->gamma, jl = J;
    if (m->c_limit > 0 && J < m->state_limit) jl = m->state_limit;
    double psi =
        fabs(g - 1) < 1e-12 ? k * ((jl - 1) - log(jl)) : k / (g - 1) * (expm1((1 - g) * log(jl)) + (g - 1) * (jl - 1));
    if (jl == J) return psi;
    double c2 = m->c_limit * m->c_limit * (double)m->rho;
    return psi + water_pressure(m, jl) * (jl - J) + c2 * (log(jl / J) - (jl - J) / jl);
}

/* ---- compile --------------------------------------------------------------- */

void kf_mat_compile(kf_mat *out, const kf_material *in) {
    memset(out, 0, sizeof *out);
    out->model = in->model;
    out->rho = (kf_real)in->density;
    if (in->model != KF_MAT_WATER) {
        double E = in->E, nu = in->nu;
        out->mu = (kf_real)(E / (2 * (1 + nu)));
        out->lambda = (kf_real)(E * nu / ((1 + nu) * (1 - 2 * nu)));
    }
    out->tau_y = (kf_real)(sqrt(2.0 / 3.0) * in->yield_stress);
    double sphi = sin(in->friction_angle * DEG2RAD);
    out->c_f = (kf_real)(sqrt(2.0 / 3.0) * 2 * sphi / (3 - sphi));
    out->cohesion = (kf_real)in->cohesion;
    out->hardening = in->hardening;
    out->volume_correction = in->volume_correction;
    out->h0 = (kf_real)(in->h0 * DEG2RAD);
    out->h1 = (kf_real)(in->h1 * DEG2RAD);
    out->h2 = (kf_real)in->h2;
    out->h3 = (kf_real)(in->h3 * DEG2RAD);
    out->kappa = (kf_real)in->bulk_modulus;
    out->gamma = (kf_real)in->gamma;
    out->viscosity = (kf_real)in->viscosity;
    out->theta_c = (kf_real)in->theta_c;
    out->theta_s = (kf_real)in->theta_s;
    out->xi = (kf_real)in->xi;
    out->plastic = in->model == KF_MAT_VON_MISES || in->model == KF_MAT_SAND || in->model == KF_MAT_SNOW;
    out->wave_speed0 = kf_mat_wave_speed(out, 1.0);
}

/* ---- Kirchhoff stress ------------------------------------------------------ */

void kf_mat_kirchhoff(const kf_mat *m, const kf_real F[9], const kf_real ps[2], kf_real tau[9]) {
    switch (m->model) {
    case KF_MAT_COROTATED: corotated_tau(m->mu, m->lambda, corot_jc(m), F, tau); return;
    case KF_MAT_SNOW: {
        double h = snow_hardening(m, ps);
        corotated_tau(h * m->mu, h * m->lambda, 0, F, tau);
        return;
    }
    case KF_MAT_VON_MISES:
    case KF_MAT_SAND: {
        /* StVK on Hencky strain: τ = U (2μ ε + λ tr ε I) Uᵀ */
        kf_real U[9], V[9], s[3];
        double e[3], d[3];
        hencky_strain(F, U, V, s, e);
        double tr = e[0] + e[1] + e[2];
        for (int i = 0; i < 3; i++) d[i] = 2 * (double)m->mu * e[i] + (double)m->lambda * tr;
        sym_udut(tau, U, d);
        return;
    }
    case KF_MAT_WATER: {
        /* τ = −p J I, p = κ(J^−γ − 1), J tracked in ps[0]. The viscosity
         * field is not used here: a viscous stress needs the velocity
         * gradient C, which this interface does not see. */
        double J = water_J(ps);
        double p = water_pressure(m, J);
        for (int i = 0; i < 9; i++) tau[i] = 0;
        tau[0] = tau[4] = tau[8] = (kf_real)(-p * J);
        return;
    }
    default:
        for (int i = 0; i < 9; i++) tau[i] = 0;
        return;
    }
}

/* ---- return mapping -------------------------------------------------------- */

/* von Mises on Hencky strain: scale the deviatoric strain back to the yield
 * radius τ_Y/(2μ); the trace, hence det F, is kept */
/* von Mises return in principal Hencky strain: e ← H, returns 1 if it yielded */
static int return_von_mises(const kf_mat *m, double e[3]) {
    double tr3 = (e[0] + e[1] + e[2]) / 3, eh[3], nh = 0;
    for (int i = 0; i < 3; i++) {
        eh[i] = e[i] - tr3;
        nh += eh[i] * eh[i];
    }
    nh = sqrt(nh);
    double dg = nh - (double)m->tau_y / (2 * (double)m->mu);
    if (!(dg > 0)) return 0;
    for (int i = 0; i < 3; i++) e[i] -= dg * eh[i] / nh;
    return 1;
}

/* Drucker–Prager sand (Klár et al. 2016). Cohesion c shifts the cone tip to
 * ε = c·1 (the state tolerates a little tension); volume correction adds the
 * log-volume v_c (ps[0]) lost in earlier tension projections to the strain
 * before projecting, and keeps v_c = log det F_trial − log det F_E summed. */
/* e ← H in principal space; updates ps; returns 1 if F must change */
static int return_sand(const kf_mat *m, double e[3], kf_real ps[2]) {
    double mu = m->mu, la = m->lambda, c = m->cohesion;
    double vc = m->volume_correction ? (double)ps[0] : 0.0;
    double tr_trial = e[0] + e[1] + e[2];

    /* friction coefficient: fixed, or hardened by the plastic strain q */
    double cf = m->hardening ? kf_mat_friction_hardened(m, ps[1]) : m->c_f;

    double es[3], tr = 0; /* strain relative to the cone tip */
    for (int i = 0; i < 3; i++) {
        es[i] = e[i] + vc / 3 - c;
        tr += es[i];
    }
    double H[3], dq;
    int elastic = 0;
    if (tr >= 0) {
        /* tension: the whole strain relative to the tip is plastic */
        H[0] = H[1] = H[2] = c;
        dq = sqrt(es[0] * es[0] + es[1] * es[1] + es[2] * es[2]);
    } else {
        double eh[3], nh = 0;
        for (int i = 0; i < 3; i++) {
            eh[i] = es[i] - tr / 3;
            nh += eh[i] * eh[i];
        }
        nh = sqrt(nh);
        double dg = nh + (3 * la + 2 * mu) / (2 * mu) * tr * cf;
        if (dg <= 0) {
            elastic = 1;
            for (int i = 0; i < 3; i++) H[i] = es[i] + c;
            dq = 0;
        } else {
            /* dg > 0 with tr < 0 implies nh > 0 */
            for (int i = 0; i < 3; i++) H[i] = es[i] - dg * eh[i] / nh + c;
            dq = dg;
        }
    }
    if (m->hardening) ps[1] = (kf_real)((double)ps[1] + dq);
    /* an elastic state with nothing to correct keeps F bit for bit */
    if (elastic && vc == 0) return 0;
    if (m->volume_correction) ps[0] = (kf_real)(vc + tr_trial - (H[0] + H[1] + H[2]));
    for (int i = 0; i < 3; i++) e[i] = H[i];
    return 1;
}

/* snow (Stomakhin 2013): clamp the singular values and move the discarded
 * volume into Jp. An inverted direction counts by its magnitude (floored),
 * so Jp stays positive. */
static int return_snow(const kf_mat *m, const kf_real s[3], double d[3], kf_real ps[2]) {
    double lo = 1 - (double)m->theta_c, hi = 1 + (double)m->theta_s, ratio = 1;
    int changed = 0;
    for (int i = 0; i < 3; i++) d[i] = s[i];
    if (isnan(s[0])) return 0; /* leave a broken F for the step's checks */
    for (int i = 0; i < 3; i++) {
        double si = s[i];
        d[i] = fmin(fmax(si, lo), hi);
        if (d[i] != si) changed = 1;
        ratio *= fmax(fabs(si), HENCKY_SIGMA_MIN) / d[i];
    }
    if (changed) ps[0] = (kf_real)((double)ps[0] * ratio);
    return changed;
}

/* One SVD serves the return map and the stress of the result: the step's
 * stress pass calls this once per particle per substep. */
void kf_mat_update(const kf_mat *m, kf_real F[9], kf_real ps[2], int project, kf_real tau[9]) {
    if (m->model == KF_MAT_COROTATED || m->model == KF_MAT_WATER || !(m->model < KF_MAT_MODEL_COUNT)) {
        kf_mat_kirchhoff(m, F, ps, tau);
        return;
    }
    kf_real U[9], V[9], s[3];
    double e[3], d[3];
    if (m->model == KF_MAT_SNOW) {
        /* clamp σ, move the discarded volume into Jp, then corotated with the
         * hardened moduli: τ = U diag(2μ(σ − 1)σ + λ(J − 1)J) Uᵀ */
        kf_svd3(F, U, s, V);
        if (project && return_snow(m, s, d, ps)) set_usvt(F, U, d, V);
        else
            for (int i = 0; i < 3; i++) d[i] = s[i];
        double h = snow_hardening(m, ps), mu = h * m->mu, la = h * m->lambda, J = d[0] * d[1] * d[2], t[3], g, g1, g2;
        kf_corot_volume(mu, la, J, 0, &g, &g1, &g2);
        for (int i = 0; i < 3; i++) t[i] = 2 * mu * (d[i] - 1) * d[i] + g1 * J;
        sym_udut(tau, U, t);
        return;
    }
    /* StVK on Hencky strain under von Mises or Drucker–Prager */
    hencky_strain(F, U, V, s, e);
    int changed = 0;
    if (project) changed = m->model == KF_MAT_VON_MISES ? return_von_mises(m, e) : return_sand(m, e, ps);
    if (changed) {
        double x[3] = {exp(e[0]), exp(e[1]), exp(e[2])};
        set_usvt(F, U, x, V);
    }
    double tr = e[0] + e[1] + e[2];
    for (int i = 0; i < 3; i++) d[i] = 2 * (double)m->mu * e[i] + (double)m->lambda * tr;
    sym_udut(tau, U, d);
}

void kf_mat_project(const kf_mat *m, kf_real F[9], kf_real ps[2]) {
    kf_real tau[9];
    if (m->plastic) kf_mat_update(m, F, ps, 1, tau);
}

/* ---- energy and wave speed ------------------------------------------------- */

double kf_mat_energy_density(const kf_mat *m, const kf_real F[9], const kf_real ps[2]) {
    switch (m->model) {
    case KF_MAT_COROTATED: return corotated_psi(m->mu, m->lambda, corot_jc(m), F);
    case KF_MAT_SNOW: {
        double h = snow_hardening(m, ps);
        return corotated_psi(h * m->mu, h * m->lambda, 0, F);
    }
    case KF_MAT_VON_MISES:
    case KF_MAT_SAND: {
        kf_real U[9], V[9], s[3];
        double e[3];
        hencky_strain(F, U, V, s, e);
        double tr = e[0] + e[1] + e[2];
        return (double)m->mu * (e[0] * e[0] + e[1] * e[1] + e[2] * e[2]) + 0.5 * (double)m->lambda * tr * tr;
    }
    case KF_MAT_WATER: return water_psi(m, water_J(ps));
    default: return 0;
    }
}

/* the model's own wave speed, without the limit */
static double wave_speed_of(const kf_mat *m, double state) {
    if (m->model == KF_MAT_WATER) {
        double Jc = floor_nan(state, WATER_J_MIN), g = m->gamma;
        return sqrt((double)m->kappa * g * pow(Jc, 1 - g) / (double)m->rho);
    }
    double c = sqrt(((double)m->lambda + 2 * (double)m->mu) / (double)m->rho);
    /* snow stiffens by e^{ξ(1 − Jp)} as it compacts: c grows by its root */
    if (m->model == KF_MAT_SNOW) c *= sqrt(exp((double)m->xi * (1.0 - state)));
    /* fixed corotated's volume barrier below J_b: c0 J_b/J (material.h);
     * J floored where the step's det F check stops a run anyway */
    if (m->model == KF_MAT_COROTATED && state < KF_COROT_JB) c *= KF_COROT_JB / (state > 1e-3 ? state : 1e-3);
    return c;
}

double kf_mat_wave_speed(const kf_mat *m, double state) {
    double c = wave_speed_of(m, state);
    if (m->c_limit > 0 && c > m->c_limit) c = m->c_limit;
    return c;
}

int kf_mat_is_limited(const kf_mat *m, const kf_real F[9], const kf_real ps[2]) {
    if (!(m->c_limit > 0)) return 0;
    if (m->model == KF_MAT_COROTATED) {
        double Fd[9];
        to_double(Fd, F);
        return kf_m3d_det(Fd) < m->state_limit;
    }
    return (double)ps[0] < m->state_limit;
}

/* the state where the model's wave speed reaches c_limit: water's
 * c = √(κγ J^{1−γ}/ρ), snow's c0 e^{ξ(1 − Jp)/2} and the corotated barrier's
 * c0 J_b/J solved for J, Jp, J; a limit below the speed at rest is raised
 * to it (the material at rest is never softened) */
void kf_mat_limit(kf_mat *m, double c_limit) {
    m->c_limit = 0, m->state_limit = 0;
    if (!(c_limit > 0) || (m->model != KF_MAT_WATER && m->model != KF_MAT_SNOW && m->model != KF_MAT_COROTATED)) return;
    double c0 = wave_speed_of(m, 1.0), c = c_limit > c0 ? c_limit : c0;
    if (m->model == KF_MAT_WATER) {
        double g = m->gamma;
        if (!(g > 1)) return; /* γ <= 1 does not stiffen */
        m->state_limit = pow(c * c * (double)m->rho / ((double)m->kappa * g), 1 / (1 - g));
    } else if (m->model == KF_MAT_COROTATED) {
        m->state_limit = KF_COROT_JB * c0 / c;
    } else {
        if (!(m->xi > 0)) return;
        m->state_limit = 1 - 2 * log(c / c0) / (double)m->xi;
    }
    m->c_limit = c;
}

/* ---- public presets and validation ----------------------------------------- */

static const char *const preset_names[] = {"jello", "rubber",   "goo",  "cheese", "metal",
                                           "sand",  "wet_sand", "snow", "water",  NULL};

const char *const *kf_material_preset_names(void) { return preset_names; }

static void solid(kf_material *o, kf_material_model model, double rho, double E, double nu) {
    o->model = model;
    o->density = rho;
    o->E = E;
    o->nu = nu;
}

/* SI values chosen for a ~1 m VFX domain: stiff enough to read as the
 * material, soft enough that the P-wave speed (hence the CFL step) stays at
 * tens of m/s. "metal" is deliberately far softer than real steel. */
int kf_material_preset(const char *name, kf_material *out) {
    if (!name || !out) return -1;
    kf_material o;
    memset(&o, 0, sizeof o);
    if (strcmp(name, "jello") == 0) {
        solid(&o, KF_MAT_COROTATED, 1000, 2e4, 0.3); /* c_p ≈ 5.2 m/s */
    } else if (strcmp(name, "rubber") == 0) {
        solid(&o, KF_MAT_COROTATED, 1100, 5e5, 0.4); /* c_p ≈ 31 m/s */
    } else if (strcmp(name, "goo") == 0) {
        solid(&o, KF_MAT_VON_MISES, 1000, 1e4, 0.4); /* flows under its own weight */
        o.yield_stress = 100;
    } else if (strcmp(name, "cheese") == 0) {
        solid(&o, KF_MAT_VON_MISES, 1050, 1e5, 0.35); /* holds shape, tears on impact */
        o.yield_stress = 5e3;
    } else if (strcmp(name, "metal") == 0) {
        solid(&o, KF_MAT_VON_MISES, 7800, 2e7, 0.3); /* yields at 0.5% strain; c_p ≈ 59 m/s */
        o.yield_stress = 1e5;
    } else if (strcmp(name, "sand") == 0) {
        solid(&o, KF_MAT_SAND, 1600, 3.537e5, 0.3); /* Klár et al. 2016 */
        o.friction_angle = 30;
        o.hardening = 1;
        o.h0 = 35;
        o.h1 = 9;
        o.h2 = 0.2;
        o.h3 = 10;
        o.volume_correction = 1;
    } else if (strcmp(name, "wet_sand") == 0) {
        solid(&o, KF_MAT_SAND, 1900, 3.537e5, 0.3); /* cohesive: ~2 kPa tensile strength */
        o.friction_angle = 40;
        o.cohesion = 2e-3;
        o.volume_correction = 1;
    } else if (strcmp(name, "snow") == 0) {
        solid(&o, KF_MAT_SNOW, 400, 1.4e5, 0.2); /* Stomakhin et al. 2013 */
        o.theta_c = 2.5e-2;
        o.theta_s = 7.5e-3;
        o.xi = 10;
    } else if (strcmp(name, "water") == 0) {
        o.model = KF_MAT_WATER; /* c = √(κγ/ρ) ≈ 26 m/s */
        o.density = 1000;
        o.bulk_modulus = 1e5;
        o.gamma = 7;
        o.viscosity = 0;
    } else {
        return -1;
    }
    size_t n = strlen(name);
    if (n >= sizeof o.name) n = sizeof o.name - 1;
    memcpy(o.name, name, n);
    o.name[n] = '\0';
    *out = o;
    return 0;
}

/* comparisons are written so NaN fails them */
const char *kf_material_check(const kf_material *m) {
    if (!m) return "material is NULL";
    if (!((int)m->model >= 0 && (int)m->model < (int)KF_MAT_MODEL_COUNT)) return "model: unknown material model";
    if (!(m->density > 0) || !isfinite(m->density)) return "density must be > 0 kg/m^3";
    if (m->model == KF_MAT_WATER) {
        if (!(m->bulk_modulus > 0) || !isfinite(m->bulk_modulus)) return "bulk_modulus must be > 0 Pa for water";
        if (!(m->gamma >= 1) || !isfinite(m->gamma)) return "gamma must be >= 1 for water";
        if (!(m->viscosity >= 0)) return "viscosity must be >= 0 Pa s for water";
        return "";
    }
    if (!(m->E > 0) || !isfinite(m->E)) return "E (Young's modulus) must be > 0 Pa";
    if (!(m->nu >= 0 && m->nu < 0.5)) return "nu (Poisson ratio) must be in [0, 0.5)";
    switch (m->model) {
    case KF_MAT_VON_MISES:
        if (!(m->yield_stress > 0) || !isfinite(m->yield_stress)) return "yield_stress must be > 0 Pa for von Mises";
        break;
    case KF_MAT_SAND:
        if (!(m->cohesion >= 0) || !isfinite(m->cohesion)) return "cohesion must be >= 0 for sand";
        if (m->hardening) {
            if (!(m->h0 > 0 && m->h0 < 90)) return "h0 must be in (0, 90) degrees for sand hardening";
            if (!(m->h2 >= 0) || !isfinite(m->h2)) return "h2 must be >= 0 for sand hardening";
            if (!(m->h0 - m->h3 >= 0 && m->h0 - m->h3 < 90))
                return "h0 - h3 (initial friction angle) must be in [0, 90) degrees for sand hardening";
            if (!isfinite(m->h1)) return "h1 must be finite for sand hardening";
        } else if (!(m->friction_angle > 0 && m->friction_angle < 90)) {
            return "friction_angle must be in (0, 90) degrees for sand";
        }
        break;
    case KF_MAT_SNOW:
        if (!(m->theta_c > 0 && m->theta_c < 1)) return "theta_c must be in (0, 1) for snow";
        if (!(m->theta_s > 0 && m->theta_s < 1)) return "theta_s must be in (0, 1) for snow";
        if (!(m->xi >= 0) || !isfinite(m->xi)) return "xi must be >= 0 for snow";
        break;
    default: break;
    }
    return "";
}
