/* thin_problem.c — stress problems (see thin_problem.h). */
#include "thin_problem.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "core/timer.h"
#include <kerf/kerf.h>
#include "mpm/material.h"
#include "mpm/model.h"

const char *thin_motion_name(thin_motion m) {
    static const char *names[] = {"sweep", "diagonal", "rotate", "rest"};
    return m <= THIN_REST ? names[m] : "?";
}

/* the sheet: a rectangle through c spanned by unit u, v (half sizes hu, hv), normal u x v */
typedef struct sheet {
    double c[3], u[3], v[3], n[3], hu, hv;
    double vert[12];
    int tri[6];
} sheet;

static void make_sheet(sheet *s, const double c[3], const double u[3], const double v[3], double hu, double hv) {
    memcpy(s->c, c, sizeof s->c);
    memcpy(s->u, u, sizeof s->u);
    memcpy(s->v, v, sizeof s->v);
    s->hu = hu, s->hv = hv;
    s->n[0] = u[1] * v[2] - u[2] * v[1];
    s->n[1] = u[2] * v[0] - u[0] * v[2];
    s->n[2] = u[0] * v[1] - u[1] * v[0];
    static const int su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
    for (int k = 0; k < 4; k++)
        for (int a = 0; a < 3; a++) s->vert[3 * k + a] = c[a] + su[k] * hu * u[a] + sv[k] * hv * v[a];
    static const int t[6] = {0, 1, 2, 0, 2, 3};
    memcpy(s->tri, t, sizeof t);
}

/* x in the sheet's frame at pose (x_world = R x_mesh + t): in-plane (a, b) and normal offset w */
static void sheet_coords(const sheet *s, const kf_rigid_pose *p, const double x[3], double *a, double *b, double *w) {
    double q[3], m[3];
    for (int k = 0; k < 3; k++) q[k] = x[k] - p->t[k];
    for (int k = 0; k < 3; k++) m[k] = p->R[k] * q[0] + p->R[3 + k] * q[1] + p->R[6 + k] * q[2]; /* Rᵀ q */
    double d[3] = {m[0] - s->c[0], m[1] - s->c[1], m[2] - s->c[2]};
    *a = d[0] * s->u[0] + d[1] * s->u[1] + d[2] * s->u[2];
    *b = d[0] * s->v[0] + d[1] * s->v[1] + d[2] * s->v[2];
    *w = d[0] * s->n[0] + d[1] * s->n[1] + d[2] * s->n[2];
}

/* the scene of each motion: sheet, material box, keys or spin, substeps */
typedef struct scene {
    sheet sh;
    double lo[3], hi[3]; /* material box */
    double travel;       /* m along the normal (sweeps) or rad (rotate) */
    double axis_pt[3];   /* rotate: a point on the axis (the pivot) */
} scene;

static void build_scene(thin_motion mo, scene *sc) {
    memset(sc, 0, sizeof *sc);
    if (mo == THIN_SWEEP || mo == THIN_DIAGONAL) {
        /* a bed on the floor; the sheet reaches below the floor, past the side walls and far above the bed */
        const double lo[3] = {0.35, 0.0, 0.35}, hi[3] = {0.65, 0.12, 0.65};
        memcpy(sc->lo, lo, sizeof lo), memcpy(sc->hi, hi, sizeof hi);
        double u[3] = {0, 1, 0}, v[3] = {0, 0, 1}; /* normal +x */
        double start = -0.2;                       /* the plane's offset from the bed's centre */
        if (mo == THIN_DIAGONAL) {
            const double h = sqrt(0.5);
            v[0] = -h, v[2] = h; /* normal (1, 0, 1)/√2 */
            start = -0.25;
        }
        double n[3] = {u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0]};
        double c[3] = {0.5 + start * n[0], 0.25, 0.5 + start * n[2]};
        make_sheet(&sc->sh, c, u, v, 0.35, 1.0);
        sc->travel = 0.3;
    } else if (mo == THIN_ROTATE) {
        /* a blade from the axis (along z through y = 0.25) out to 0.15 m, in a box of material that covers its sweep */
        const double lo[3] = {0.3, 0.0, 0.4}, hi[3] = {0.7, 0.45, 0.6};
        memcpy(sc->lo, lo, sizeof lo), memcpy(sc->hi, hi, sizeof hi);
        const double R = 0.15, u[3] = {1, 0, 0}, v[3] = {0, 0, 1}; /* normal -y */
        double c[3] = {0.5 + 0.5 * R, 0.25, 0.5};
        make_sheet(&sc->sh, c, u, v, 0.5 * R, 0.6);
        sc->axis_pt[0] = 0.5, sc->axis_pt[1] = 0.25, sc->axis_pt[2] = 0.5;
        sc->travel = 0.5 * 3.14159265358979323846; /* a quarter turn */
    } else {
        /* rest: a static horizontal sheet spanning the domain, a block resting on it */
        const double lo[3] = {0.35, 0.3, 0.35}, hi[3] = {0.65, 0.4, 0.65};
        memcpy(sc->lo, lo, sizeof lo), memcpy(sc->hi, hi, sizeof hi);
        double u[3] = {0, 0, 1}, v[3] = {1, 0, 0}; /* normal +y */
        double c[3] = {0.5, 0.3 - 1e-4, 0.5};
        make_sheet(&sc->sh, c, u, v, 1.0, 1.0);
    }
}

int thin_run(const thin_case *c, thin_result *r) {
    memset(r, 0, sizeof *r);
    scene sc;
    build_scene(c->motion, &sc);
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = c->dx;
    sd.walls = 1;
    sd.threads = c->threads;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    if (!m) return fprintf(stderr, "thin: %s\n", err), -1;
    kf_material mat;
    if (kf_material_preset(c->material, &mat)) return fprintf(stderr, "thin: no preset %s\n", c->material), -1;
    int mid = kf_model_add_material(m, &mat, err, sizeof err);
    if (mid < 0) return fprintf(stderr, "thin: %s\n", err), -1;
    /* the substep: the material's elastic CFL number 0.3 (its wave speed at rest) */
    const double wave = kf_mat_wave_speed(&m->mat[mid], 1.0), dt = 0.3 * c->dx / wave;
    const double speed = c->cells * c->dx / dt; /* m/s of the fastest point of the sheet */
    /* as a shot's sim.dt_fixed, or (adaptive) the default CFL rule, which
     * takes as many substeps within each such step as the body's speed and
     * the material's state ask for */
    m->sim.dt_fixed = c->adaptive ? 0 : dt;

    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "sheet");
    d.vertices = sc.sh.vert, d.nvertices = 4, d.triangles = sc.sh.tri, d.ntriangles = 2;
    d.thin = 1;
    d.boundary = KF_BOUNDARY_SEPARATE;
    d.friction = 0.3;
#ifdef KF_RIGID_AUTO
    d.penalty = c->defaults ? KF_RIGID_AUTO : 0;
    d.push = c->defaults ? KF_RIGID_AUTO : 0;
#endif
    long travel_steps = 0, hold_steps = 0;
    if (c->motion == THIN_SWEEP || c->motion == THIN_DIAGONAL) {
        /* along the normal, then an abrupt stop, held */
        double T = sc.travel / speed;
        d.motion = KF_RIGID_KINEMATIC;
        d.interp = KF_INTERP_LINEAR;
        d.nkeys = 2;
        d.keys[0].time = 0;
        d.keys[1].time = T;
        for (int a = 0; a < 3; a++) d.keys[1].position[a] = sc.travel * sc.sh.n[a];
        travel_steps = (long)ceil(T / dt);
        hold_steps = travel_steps / 4 > 20 ? travel_steps / 4 : 20;
    } else if (c->motion == THIN_ROTATE) {
        const double R = 2 * sc.sh.hu;
        d.motion = KF_RIGID_KINEMATIC;
        memcpy(d.center, sc.axis_pt, sizeof d.center);
        memcpy(d.position, sc.axis_pt, sizeof d.position);
        d.angular_velocity[2] = speed / R;
        travel_steps = (long)ceil(sc.travel / (speed / R) / dt);
    } else {
        d.motion = KF_RIGID_STATIC;
        hold_steps = (long)ceil(0.3 / dt);
    }
    if (kf_model_add_rigid(m, &d, err, sizeof err) < 0)
        return fprintf(stderr, "thin: %s\n", err), kf_model_destroy(m), -1;
    kf_state *s = kf_state_create(m);
    if (!s) return kf_model_destroy(m), -1;
    const double still[3] = {0, 0, 0};
    kf_state_fill_box(s, m, sc.lo, sc.hi, mid, still, 2, 17);
    const size_t n = kf_state_count(s);
    r->particles = (long)n;

    /* each particle's side at the start, by stable id (sweeps: all in front) */
    kf_particles_view pv = kf_state_particles_read(s);
    kf_rigid_pose pose = kf_state_rigid(s, 0);
    signed char *side0 = calloc(n, 1);
    unsigned char *ever = calloc(n, 1);
    for (size_t i = 0; i < n; i++) {
        double a, b, w, x[3] = {pv.x[0][i], pv.x[1][i], pv.x[2][i]};
        sheet_coords(&sc.sh, &pose, x, &a, &b, &w);
        side0[pv.id[i]] = w > 0 ? 1 : -1;
    }
    const int sweep = c->motion == THIN_SWEEP || c->motion == THIN_DIAGONAL;
    const int water = mat.model == KF_MAT_WATER;
    r->j_min = 1;
    const long total = travel_steps + hold_steps;
    const int frames = c->frames > 0 ? c->frames : 10;
    const long per_frame = total / frames > 0 ? total / frames : 1;
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    double t0 = kf_now_ms();
    for (long k = 0; k < total; k++) {
        kf_trouble tr;
        if (c->adaptive) {
            char msg[256];
            if (kf_advance(m, s, dt, &st, msg, sizeof msg)) {
                r->failed = 1;
                snprintf(r->trouble, sizeof r->trouble, "%s", msg);
                break;
            }
            r->substeps = st.substeps;
        } else if ((r->cfl_max = fmax(r->cfl_max, dt / kf_stable_dt(m, s, 1.0))), kf_step(m, s, dt, &st, &tr)) {
            r->failed = 1;
            snprintf(r->trouble, sizeof r->trouble, "%s (value %g) at substep %ld", tr.what, tr.value, k);
            break;
        } else {
            r->substeps++;
        }
        pv = kf_state_particles_read(s);
        pose = kf_state_rigid(s, 0);
        long across = 0;
        for (size_t i = 0; i < pv.n; i++) {
            /* how far the material was compressed */
            double J = pv.ps[0][i];
            if (!water) {
                double f[9];
                for (int q = 0; q < 9; q++) f[q] = pv.F[q][i];
                J = f[0] * (f[4] * f[8] - f[5] * f[7]) - f[1] * (f[3] * f[8] - f[5] * f[6]) +
                    f[2] * (f[3] * f[7] - f[4] * f[6]);
            }
            if (J < r->j_min) r->j_min = J;
            double a, b, w, x[3] = {pv.x[0][i], pv.x[1][i], pv.x[2][i]};
            sheet_coords(&sc.sh, &pose, x, &a, &b, &w);
            if (fabs(a) > sc.sh.hu || fabs(b) > sc.sh.hv) continue; /* beside the sheet, not behind it */
            /* the rim: within the splat's reach (1.5 cells) of a free edge the
             * two sides share nodes (the paper's sub-grid limit, §8) and
             * material goes around the edge, keeping its tag while it is
             * near: a blade's tip and the edge at its axis */
            if (c->motion == THIN_ROTATE && fabs(a) > sc.sh.hu - 1.5 * c->dx) continue;
            /* the recorded side: the colour's tag (bit 0: negative side) once it has affinity (bit 1);
             * for a sweep, the side it started on whatever its colour */
            int held = 0;
            if (pv.colour[i] & 2) held = pv.colour[i] & 1 ? -1 : 1;
            if (sweep) held = side0[pv.id[i]];
            if (!held) continue;
            double behind = -held * w / c->dx; /* cells behind the surface */
            if (behind <= 0) continue;
            across++;
            if (behind > r->deepest) r->deepest = behind;
            if (behind > 0.1 && !ever[pv.id[i]]) ever[pv.id[i]] = 1, r->across_ever++;
        }
        if ((k + 1) % per_frame == 0 || k + 1 == total) {
            if (across > r->across_frame_max) r->across_frame_max = across;
        }
        r->end_across = across;
    }
    r->ms = kf_now_ms() - t0;
#ifdef KF_RIGID_AUTO /* the counters came with the automatic penalty; an older build lacks them */
    r->max_cells = st.max_cells_moved;
    r->caught = st.thin_caught;
    r->stiff_limited = st.stiff_limited;
#endif
    /* rest: how still the material on the sheet is */
    if (c->motion == THIN_REST && !r->failed) {
        double v2 = 0;
        long cnt = 0;
        pv = kf_state_particles_read(s);
        for (size_t i = 0; i < pv.n; i++) {
            v2 += (double)pv.v[0][i] * pv.v[0][i] + (double)pv.v[1][i] * pv.v[1][i] + (double)pv.v[2][i] * pv.v[2][i];
            cnt++;
        }
        r->jitter = cnt ? sqrt(v2 / cnt) : 0;
    }
    free(side0);
    free(ever);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return 0;
}
