/* test_thin.c — thin boundaries under stress, at the defaults a
 * shot gets (penalty and push auto), against the exact geometry of the
 * sheet, not kerf's grid (tests/problems/thin_problem.c):
 *   - a zero-thickness sheet spanning a channel sweeps through a bed of sand,
 *     goo, water, jelly and snow at 0.05, 0.5 and 1 cell per substep, then
 *     stops dead: no particle is behind it at any output frame, none more
 *     than 0.1 cell behind at any substep's end, the run has no numerical
 *     trouble and no particle's J falls below 0.01;
 *   - the same diagonal to the grid, and a blade turning about its edge;
 *   - the same under the default CFL rule;
 *   - material at rest on a sheet does not jitter;
 *   - a free plate pushed by a jelly block keeps the total momentum;
 *   - a plate moving off leaves the material behind it at rest, and the two
 *     halves of a cut block part freely;
 *   - kerf's own audit (kf_state_thin_audit) sees a particle put across.
 * The speed is the sheet's fastest point in cells per substep, under a fixed
 * step at CFL 0.3 of the material's wave speed at rest (sim.dt_fixed). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "kt.h"
#include "scene_util.h"
#include "cpic/cpic.h"
#include "rigid/bvh.h"
#include "rigid/rigid.h"
#include "problems/thin_problem.h"

/* A run is sane when no particle's volume ratio fell below J_SANE at any
 * substep's end: ten times the default det F floor (sim.j_min 1e-3), below
 * which a run stops on numerical trouble. The material right at a sheet that
 * outruns its waves is crushed into a thin layer (sand and goo, whose
 * pressure grows as J shrinks, reach J = 0.015-0.03 at 1 cell per substep). */
#define J_SANE 0.01

static void expect_clean(const char *material, thin_motion motion, double cells, int adaptive) {
    thin_case c = {material, motion, cells, 0.02, 10, 0, 1, adaptive};
    thin_result r;
    KT_CHECK(thin_run(&c, &r) == 0, "%s %s: the scene builds", material, thin_motion_name(motion));
    const char *mode = adaptive ? "CFL rule" : "fixed step";
    KT_CHECK(!r.failed, "%s %s at %.2f cells/substep (%s): no numerical trouble (%s)", material,
             thin_motion_name(motion), cells, mode, r.trouble);
    KT_CHECK(r.across_frame_max == 0,
             "%s %s at %.2f cells/substep (%s): nobody behind the sheet at an output frame "
             "(%ld)",
             material, thin_motion_name(motion), cells, mode, r.across_frame_max);
    KT_CHECK(r.deepest <= 0.1,
             "%s %s at %.2f cells/substep (%s): nobody more than 0.1 cell behind at a substep's "
             "end (deepest %.3f cells)",
             material, thin_motion_name(motion), cells, mode, r.deepest);
    KT_CHECK(r.j_min > J_SANE, "%s %s at %.2f cells/substep (%s): J stays above %g (smallest %.4f)", material,
             thin_motion_name(motion), cells, mode, J_SANE, r.j_min);
    /* a sheet at 0.05 cell per substep compresses nothing beyond what the
     * step resolves: the model runs unchanged (snow packs under its own
     * weight beyond it, and is limited at every speed) */
    if (cells <= 0.05 && strcmp(material, "snow") != 0)
        KT_CHECK(r.stiff_limited == 0, "%s %s at %.2f cells/substep: nobody stiffness-limited (%ld)", material,
                 thin_motion_name(motion), cells, r.stiff_limited);
    printf("  %-5s %-8s %4.2f cells/substep (%s): %ld particles, %ld substeps, across 0 (deepest %.3f cells), %ld "
           "caught by the guard, fastest particle %.2f cells/substep, J >= %.3f, %ld stiffness-limited, %.0f ms\n",
           material, thin_motion_name(motion), cells, mode, r.particles, r.substeps, r.deepest, r.caught, r.max_cells,
           r.j_min, r.stiff_limited, r.ms);
}

/* The sheet sweeping through a bed along an axis, then stopping dead (the
 * abrupt stop), at 0.05, 0.5 and 1 cell per substep under a fixed step at
 * CFL 0.3 of the material at rest: at 0.5 and 1 the sheet outruns the
 * material's waves (Mach 1.7 and 3.3). Water's shocked Tait state and
 * jelly's crushed volume then stiffen past what the step resolves; they are
 * evaluated at the stiffness it does (material.h: kf_mat_limit, the
 * corotated volume barrier). The CFL rule runs the fastest sheet too. */
static void sweep_sand(void) {
    expect_clean("sand", THIN_SWEEP, 0.05, 0);
    expect_clean("sand", THIN_SWEEP, 0.5, 0);
    expect_clean("sand", THIN_SWEEP, 1.0, 0);
}
static void sweep_goo(void) {
    expect_clean("goo", THIN_SWEEP, 0.05, 0);
    expect_clean("goo", THIN_SWEEP, 0.5, 0);
    expect_clean("goo", THIN_SWEEP, 1.0, 0);
}
static void sweep_water(void) {
    expect_clean("water", THIN_SWEEP, 0.05, 0);
    expect_clean("water", THIN_SWEEP, 0.5, 0);
    expect_clean("water", THIN_SWEEP, 1.0, 0);
    expect_clean("water", THIN_SWEEP, 1.0, 1);
}
static void sweep_jelly(void) {
    expect_clean("jello", THIN_SWEEP, 0.05, 0);
    expect_clean("jello", THIN_SWEEP, 0.5, 0);
    expect_clean("jello", THIN_SWEEP, 1.0, 0);
    expect_clean("jello", THIN_SWEEP, 1.0, 1);
}

/* snow hardens as it compacts (its wave speed grows with e^{xi (1 - Jp)});
 * beyond what the fixed step resolves it is limited to that */
static void sweep_snow(void) {
    expect_clean("snow", THIN_SWEEP, 0.05, 0);
    expect_clean("snow", THIN_SWEEP, 1.0, 0);
}

/* the sheet's normal at 45 degrees to the grid */
static void diagonal_sweep(void) {
    expect_clean("sand", THIN_DIAGONAL, 0.5, 0);
    expect_clean("goo", THIN_DIAGONAL, 1.0, 0);
    expect_clean("water", THIN_DIAGONAL, 1.0, 0);
    expect_clean("jello", THIN_DIAGONAL, 1.0, 0);
}

/* a blade turning about its edge, immersed */
static void rotating_blade(void) {
    expect_clean("goo", THIN_ROTATE, 0.05, 0);
    expect_clean("water", THIN_ROTATE, 1.0, 0);
    expect_clean("jello", THIN_ROTATE, 1.0, 0);
    expect_clean("sand", THIN_ROTATE, 1.0, 0);
}

/* A jello block placed on a static horizontal sheet settles; at the end it
 * moves no more than the same block placed on the domain's floor (a grid
 * wall, no CPIC), so the penalty and the guard add no jitter. */
static double rest_speed(int on_sheet, double *ymin) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.walls = 1;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    double vert[12] = {-1, 0.3, -1, 1, 0.3, -1, 1, 0.3, 2, -1, 0.3, 2};
    int tri[6] = {0, 2, 1, 0, 3, 2}; /* normal +y */
    double base = 0.3;
    if (on_sheet) {
        kf_rigid_def d;
        memset(&d, 0, sizeof d);
        snprintf(d.name, sizeof d.name, "shelf");
        d.vertices = vert, d.nvertices = 4, d.triangles = tri, d.ntriangles = 2;
        d.thin = 1;
        d.penalty = KF_RIGID_AUTO, d.push = KF_RIGID_AUTO;
        char err[256];
        KT_CHECK(kf_model_add_rigid(m, &d, err, sizeof err) >= 0, "shelf: %s", err);
    } else {
        /* the floor's wall layer: where material rests on it */
        base = 0;
    }
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.4, base, 0.4}, hi[3] = {0.6, base + 0.1, 0.6}, v0[3] = {0, 0, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v0, 2, 5);
    char msg[256];
    KT_CHECK(kf_advance(m, s, 1.0, NULL, msg, sizeof msg) == 0, "settling: %s", msg);
    kf_particles_view pv = kf_state_particles_read(s);
    double v2 = 0;
    *ymin = 1e9;
    for (size_t i = 0; i < pv.n; i++) {
        v2 += (double)pv.v[0][i] * pv.v[0][i] + (double)pv.v[1][i] * pv.v[1][i] + (double)pv.v[2][i] * pv.v[2][i];
        if (pv.x[1][i] - base < *ymin) *ymin = pv.x[1][i] - base;
    }
    double rms = sqrt(v2 / (double)pv.n);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return rms;
}

static void rest_without_jitter(void) {
    double ys, yf, sheet = rest_speed(1, &ys), floor = rest_speed(0, &yf);
    printf("  at rest after 1 s: rms speed %.2e m/s on the sheet, %.2e m/s on the floor; lowest particle %.2f cells "
           "above the sheet\n",
           sheet, floor, ys / 0.02);
    KT_CHECK(sheet <= 2 * floor + 1e-4, "no more motion on the sheet (%.3g m/s) than on the floor (%.3g m/s)", sheet,
             floor);
    /* the penalty keeps each particle's cube (half a spacing, a quarter cell
     * at 8 per cell) off the sheet, so the surfaced material does not poke
     * through it; measured 0.25 cells */
    KT_CHECK(ys / 0.02 > 0.2 && ys / 0.02 < 0.3, "resting half a particle spacing above the sheet (lowest %.3f cells)",
             ys / 0.02);
}

/* A free thin plate (a dynamic shell) in empty space, no gravity, no walls,
 * hit by a jelly block at 3 m/s: every impulse on the material (transfers,
 * penalty, the guard's corrections) goes back to the plate, so the total
 * momentum stays where it was, to float round-off. */
static void plate_keeps_momentum(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 1.0 / 50;
    sd.gravity[1] = 0;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    double vert[12] = {0.6, 0.35, 0.35, 0.6, 0.65, 0.35, 0.6, 0.65, 0.65, 0.6, 0.35, 0.65};
    int tri[6] = {0, 1, 2, 0, 2, 3};
    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "plate");
    d.vertices = vert, d.nvertices = 4, d.triangles = tri, d.ntriangles = 2;
    d.thin = 1;
    d.motion = KF_RIGID_DYNAMIC;
    d.density = 4; /* kg/m²: 0.36 kg */
    d.boundary = KF_BOUNDARY_SEPARATE;
    d.friction = 0.3;
    d.penalty = KF_RIGID_AUTO, d.push = KF_RIGID_AUTO;
    char err[256];
    KT_CHECK(kf_model_add_rigid(m, &d, err, sizeof err) >= 0, "plate: %s", err);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.45, 0.42, 0.42}, hi[3] = {0.58, 0.58, 0.58}, v[3] = {3, 0.2, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v, 2, 9);
    double P0[3], P[3], drift = 0;
    tu_total_momentum(m, s, P0);
    const double scale = sqrt(P0[0] * P0[0] + P0[1] * P0[1] + P0[2] * P0[2]);
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    for (int k = 0; k < 400; k++) {
        kf_trouble tr;
        if (kf_step(m, s, 2e-4, &st, &tr)) {
            KT_CHECK(0, "substep %d: %s", k, tr.what);
            break;
        }
        tu_total_momentum(m, s, P);
        for (int a = 0; a < 3; a++) drift = fmax(drift, fabs(P[a] - P0[a]) / scale);
    }
    kf_rigid_pose pose = kf_state_rigid(s, 0);
    double left = 0;
    long across = kf_state_thin_audit(m, s, &left);
    printf("  free plate: v = %.4f m/s after the hit, guard caught %ld, momentum drift %.2e of |P0| = %.4f kg m/s, "
           "%ld across at the end\n",
           pose.v[0], st.thin_caught, drift, scale, across);
    KT_CHECK(pose.v[0] > 0.5, "the block pushed the plate (v = %g m/s)", pose.v[0]);
    KT_CHECK(across == 0, "nobody across the plate (%ld, deepest %.3f cells)", across, left);
    /* float particle sums over 400 substeps (the ball-on-box test of
     * test_cpic measures 1.1e-6 the same way) */
    KT_NEAR(drift, 0, 1e-5, "relative drift of the total linear momentum (float sums over 400 substeps)");
    kf_state_destroy(s);
    kf_model_destroy(m);
}

/* A sheet across the middle of a block, in its plane x = 0.5 (normal +x),
 * reaching past the block on every side. */
static void add_mid_sheet(kf_model *m, const char *name, kf_rigid_motion motion, const double vel[3]) {
    double vert[12] = {0.5, 0.2, 0.2, 0.5, 0.8, 0.2, 0.5, 0.8, 0.8, 0.5, 0.2, 0.8};
    int tri[6] = {0, 1, 2, 0, 2, 3};
    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "%s", name);
    d.vertices = vert, d.nvertices = 4, d.triangles = tri, d.ntriangles = 2;
    d.thin = 1;
    d.motion = motion;
    if (vel) memcpy(d.velocity, vel, sizeof d.velocity); /* kinematic without keys: constant */
    d.boundary = KF_BOUNDARY_SEPARATE;
    d.friction = 0.3;
    d.penalty = KF_RIGID_AUTO, d.push = KF_RIGID_AUTO;
    char err[256];
    KT_CHECK(kf_model_add_rigid(m, &d, err, sizeof err) >= 0, "%s: %s", name, err);
}

/* A plate embedded across the middle of a block (no gravity) moves off
 * along its normal at 1 m/s for 0.1 s (5 cells). The half in front is
 * pushed; the half behind it was at rest, unstressed, and nothing acts on
 * it: it must stay exactly where it is (nothing sticks to the plate's
 * back and is pulled along), and none of the front half is dragged
 * through to the back. */
static void plate_back_stays(const char *preset) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.gravity[1] = 0;
    int mat;
    kf_model *m = tu_model(&sd, preset, 0, -1, 0, &mat);
    const double V = 1.0, T = 0.1;
    const double vel[3] = {V, 0, 0};
    add_mid_sheet(m, "plate", KF_RIGID_KINEMATIC, vel);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.4, 0.4, 0.4}, hi[3] = {0.6, 0.6, 0.6}, v0[3] = {0, 0, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v0, 2, 7);
    kf_particles_view pv = kf_state_particles_read(s);
    const size_t n = pv.n;
    double *x0 = malloc(n * sizeof *x0); /* x at the start, by id */
    for (size_t i = 0; i < n; i++) x0[pv.id[i]] = pv.x[0][i];
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    char msg[256];
    KT_CHECK(kf_advance(m, s, T, &st, msg, sizeof msg) == 0, "%s: the plate moves off: %s", preset, msg);
    pv = kf_state_particles_read(s);
    const double plate = 0.5 + V * T;
    double back_v = 0, back_move = 0, back_gap = 1, front_lag = 1;
    long nb = 0, through = 0;
    for (size_t i = 0; i < pv.n; i++) {
        double x = pv.x[0][i], start = x0[pv.id[i]];
        if (start < 0.5) {
            back_v += pv.v[0][i], nb++;
            back_move = fmax(back_move, x - start); /* along the plate's travel */
            back_gap = fmin(back_gap, plate - x);
        } else {
            if (x < plate) through++; /* a front particle behind the plate */
            front_lag = fmin(front_lag, x - plate);
        }
    }
    back_v /= (double)(nb ? nb : 1);
    printf("  %s: behind the plate after %.0f cells: mean v_x %.2e m/s, moved along it at most %.4f cells, gap %.2f "
           "cells; "
           "%ld of the front half behind it (closest %.3f cells in front), %ld substeps\n",
           preset, V * T / sd.dx, back_v, back_move / sd.dx, back_gap / sd.dx, through, front_lag / sd.dx, st.substeps);
    /* the back half only feels what crosses the plate: nothing (float
     * positions at 0.5 m carry 3e-8 m of round-off, 1e-6 cells) */
    KT_CHECK(fabs(back_v) < 1e-3 * V, "%s: the half behind the plate stays at rest (mean v_x %.3g m/s)", preset,
             back_v);
    /* (a jittered particle that started inside the contact layer, less than
     * half a spacing from the plate, is eased back off it: that is away
     * from the plate, not along) */
    KT_CHECK(back_move / sd.dx < 0.01, "%s: no particle behind the plate is pulled along (moved %.4f cells)", preset,
             back_move / sd.dx);
    KT_CHECK(back_gap / sd.dx > V * T / sd.dx - 0.3, "%s: the gap behind the plate is its travel (%.2f of %.0f cells)",
             preset, back_gap / sd.dx, V * T / sd.dx);
    KT_CHECK(through == 0, "%s: nothing dragged through the plate (%ld)", preset, through);
    free(x0);
    kf_state_destroy(s);
    kf_model_destroy(m);
}
static void plate_back_jelly(void) { plate_back_stays("jello"); }
static void plate_back_water(void) { plate_back_stays("water"); }
static void plate_back_goo(void) { plate_back_stays("goo"); }

/* A jelly block cut through by a static sheet (no gravity, no walls
 * reached), its two halves thrown apart at 0.5 m/s each: the halves part
 * cleanly, each keeping its momentum (nothing holds them together across
 * the cut), whereas the same block without the sheet holds together and
 * its halves pull each other back. */
static double halves_speed(int cut, double *gap) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.gravity[1] = 0;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    if (cut) add_mid_sheet(m, "cut", KF_RIGID_STATIC, NULL);
    kf_state *s = kf_state_create(m);
    const double u = 0.5, T = 0.1;
    double lo[3] = {0.4, 0.4, 0.4}, mid[3] = {0.5, 0.6, 0.6}, lo2[3] = {0.5, 0.4, 0.4}, hi[3] = {0.6, 0.6, 0.6};
    double vl[3] = {-u, 0, 0}, vr[3] = {u, 0, 0};
    kf_state_fill_box(s, m, lo, mid, mat, vl, 2, 0); /* a regular lattice: the gap is exact */
    kf_state_fill_box(s, m, lo2, hi, mat, vr, 2, 0);
    char msg[256];
    KT_CHECK(kf_advance(m, s, T, NULL, msg, sizeof msg) == 0, "the halves fly apart: %s", msg);
    kf_particles_view pv = kf_state_particles_read(s);
    double pr = 0, mr = 0, left_max = -1, right_min = 2;
    for (size_t i = 0; i < pv.n; i++) {
        /* the halves by where they are (a particle across would show as a closed gap) */
        if (pv.x[0][i] > 0.5) pr += (double)pv.mass[i] * pv.v[0][i], mr += pv.mass[i];
        if (pv.x[0][i] > 0.5) right_min = fmin(right_min, pv.x[0][i]);
        else left_max = fmax(left_max, pv.x[0][i]);
    }
    *gap = (right_min - left_max) / sd.dx;
    kf_state_destroy(s);
    kf_model_destroy(m);
    return pr / mr;
}

static void halves_part(void) {
    double gap_cut, gap_whole;
    double cut = halves_speed(1, &gap_cut), whole = halves_speed(0, &gap_whole);
    printf("  halves thrown apart at 0.5 m/s: mean speed after 0.1 s %.4f m/s with the cut (gap %.2f cells), %.4f "
           "m/s without (gap %.2f cells)\n",
           cut, gap_cut, whole, gap_whole);
    /* each half is a free body moving off the sheet: its momentum is kept to
     * float round-off of the transfers */
    KT_NEAR(cut, 0.5, 1e-3, "the cut halves keep their speed (m/s)");
    /* they started half a particle spacing (a quarter cell) either side of
     * the plane and the same again apart: 0.5 cells + 2 u T */
    KT_NEAR(gap_cut, 0.5 + 2 * 0.5 * 0.1 / 0.02, 0.1, "the cut opens by the halves' travel (cells)");
    KT_CHECK(whole < 0.45, "without the cut the halves hold together (%.3f m/s)", whole);
}

/* The audit kerf prints every frame sees a particle that is put across a
 * sheet by hand, at the depth it was put, and nothing before. */
static void audit_sees_crossing(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.gravity[1] = 0;
    int mat;
    kf_model *m = tu_model(&sd, "jello", 0, -1, 0, &mat);
    double vert[12] = {0.5, 0.2, 0.2, 0.5, 0.8, 0.2, 0.5, 0.8, 0.8, 0.5, 0.2, 0.8};
    int tri[6] = {0, 1, 2, 0, 2, 3};
    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "wall");
    d.vertices = vert, d.nvertices = 4, d.triangles = tri, d.ntriangles = 2;
    d.thin = 1;
    char err[256];
    KT_CHECK(kf_model_add_rigid(m, &d, err, sizeof err) >= 0, "wall: %s", err);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.4, 0.4, 0.4}, hi[3] = {0.5, 0.6, 0.6}, v0[3] = {0, 0, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v0, 2, 3);
    kf_step(m, s, 1e-4, NULL, NULL); /* colours are made in P2G */
    double deep;
    long before = kf_state_thin_audit(m, s, &deep);
    KT_CHECK(before == 0, "nobody across after a substep (%ld)", before);
    /* the coloured particle nearest the wall, moved 0.3 cell through it */
    kf_particles_view pv = kf_state_particles(s);
    size_t pick = 0;
    double best = 1;
    for (size_t i = 0; i < pv.n; i++)
        if ((pv.colour[i] & 2) && 0.5 - pv.x[0][i] < best && fabs(pv.x[1][i] - 0.5) < 0.05 &&
            fabs(pv.x[2][i] - 0.5) < 0.05)
            best = 0.5 - pv.x[0][i], pick = i;
    pv.x[0][pick] = (kf_real)(0.5 + 0.3 * sd.dx);
    long after = kf_state_thin_audit(m, s, &deep);
    KT_CHECK(after == 1, "the audit finds the one particle across (%ld)", after);
    KT_NEAR(deep, 0.3, 1e-3, "at the depth it was put, in cells (float positions)");
    kf_state_destroy(s);
    kf_model_destroy(m);
}

/* ---- the guard's lattice of sides ------------------------------------------
 * The guard skips its closest-triangle query where a lattice cell says what
 * the answer would be. On two sheets at dx 12 mm, a crinkle (a wave of
 * amplitude 7.5 mm and wavelength 50 mm, triangles of 2.5 x 7.5 mm, as a
 * crinkle-cut knife) and a sharp ridge (slopes of 1.5 meeting at a crest,
 * where the closest triangle jumps from one slope to the other and each
 * slope's plane cuts through the other's side), at random points around
 * them, mostly close to the surface, and at points on the lattice's own
 * planes, the query the guard makes (the closest triangle within 1.5 dx)
 * must agree with every cell's claim: none within reach where the cell says
 * none, and the point on the side of the closest triangle's plane the cell
 * names. Exact: no tolerance. The cells must also answer for a fair share
 * of the points, or the lattice saves nothing. */
static double sheet_z(int ridge, double x) {
    return ridge ? -1.5 * fabs(x - 0.1) : 0.0075 * sin(2 * 3.14159265358979323846 * x / 0.05);
}

static void sides_on(int ridge) {
    enum { NX = 81, NY = 9, NP = 300000 };
    static double vert[3 * NX * NY];
    static int tri[6 * (NX - 1) * (NY - 1)];
    const double dx = 0.012, R = 1.5 * dx;
    for (int i = 0; i < NX; i++)
        for (int j = 0; j < NY; j++) {
            double *v = &vert[3 * (i * NY + j)];
            v[0] = 0.0025 * i, v[1] = 0.0075 * j, v[2] = sheet_z(ridge, v[0]);
        }
    int nt = 0;
    for (int i = 0; i + 1 < NX; i++)
        for (int j = 0; j + 1 < NY; j++) {
            const int a = i * NY + j, b = a + NY;
            const int t[6] = {a, b, a + 1, a + 1, b, b + 1};
            memcpy(&tri[3 * nt], t, sizeof t);
            nt += 2;
        }
    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, ridge ? "ridge" : "crinkle");
    d.vertices = vert, d.nvertices = NX * NY, d.triangles = tri, d.ntriangles = nt;
    d.thin = 1, d.motion = KF_RIGID_KINEMATIC, d.boundary = KF_BOUNDARY_SLIP;
    kf_rigid_body body;
    char err[256];
    KT_CHECK(kf_rigid_compile(&body, &d, dx, err, sizeof err) == 0, "%s", err);
    if (!body.bvh) return;
    struct kf_cpic_sides sd;
    memset(&sd, 0, sizeof sd);
    kf_cpic_sides_make(&body, dx, &sd);
    KT_CHECK(sd.v != NULL, "a sheet 20 cm long gets a lattice");
    long count[5] = {0}, reached = 0, bad = 0;
    uint64_t state = 12345;
    for (int n = 0; n < NP; n++) {
        double p[3];
        for (int a = 0; a < 3; a++) {
            state = state * 6364136223846793005ull + 1442695040888963407ull;
            const double u = (double)(state >> 11) / 9007199254740992.0;
            static const double lo[3] = {-0.03, -0.03, -0.2}, span[3] = {0.26, 0.12, 0.25};
            p[a] = lo[a] + span[a] * u;
        }
        /* two of three points within 8 mm of the sheet, where the closest
         * triangle changes from cell to cell */
        if (n % 3) p[2] = sheet_z(ridge, p[0]) + (p[2] + 0.075) / 0.125 * 0.008;
        /* every fourth point on a plane of the lattice: the cell it rounds into */
        if (n % 4 == 0) {
            const int a = n / 4 % 3;
            p[a] = sd.lo[a] + sd.h * floor((p[a] - sd.lo[a]) / sd.h);
        }
        const int v = kf_cpic_sides_at(&sd, &body, p);
        count[v]++;
        double q[3];
        int interior = 0;
        const int k = kf_rigid_bvh_closest(body.bvh, p, R, q, &interior);
        if (k >= 0) reached++;
        if (v == KF_SIDES_NONE && k >= 0) {
            bad++;
            KT_CHECK(0, "a cell says none within reach, the query found triangle %d", k);
        }
        if ((v == KF_SIDES_FRONT || v == KF_SIDES_BEHIND) && k >= 0) {
            const int *t = &body.tri[3 * body.guard_tri[k]];
            const double *a = &body.vert[3 * t[0]], *b = &body.vert[3 * t[1]], *c = &body.vert[3 * t[2]];
            double e1[3], e2[3], nrm[3];
            for (int e = 0; e < 3; e++) e1[e] = b[e] - a[e], e2[e] = c[e] - a[e];
            nrm[0] = e1[1] * e2[2] - e1[2] * e2[1];
            nrm[1] = e1[2] * e2[0] - e1[0] * e2[2];
            nrm[2] = e1[0] * e2[1] - e1[1] * e2[0];
            const double len = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
            const double u = (nrm[0] * (p[0] - a[0]) + nrm[1] * (p[1] - a[1]) + nrm[2] * (p[2] - a[2])) / len;
            if (v == KF_SIDES_FRONT ? !(u > 0) : !(u < 0)) {
                bad++;
                if (bad < 5)
                    KT_CHECK(0, "a cell says %s, the closest triangle's plane gives %.3g m",
                             v == KF_SIDES_FRONT ? "front" : "behind", u);
            }
        }
    }
    printf("sides (%s): %ld points, %ld with a triangle within reach; cells none %ld, front %ld, behind %ld, mixed "
           "%ld; %ld disagree\n",
           d.name, (long)NP, reached, count[KF_SIDES_NONE], count[KF_SIDES_FRONT], count[KF_SIDES_BEHIND],
           count[KF_SIDES_MIXED], bad);
    KT_CHECK(bad == 0, "every cell's claim holds (%ld do not)", bad);
    /* not vacuous: each kind occurs, and the cells answer for most points */
    KT_CHECK(count[KF_SIDES_NONE] > 0 && count[KF_SIDES_FRONT] > 0 && count[KF_SIDES_BEHIND] > 0 &&
                 count[KF_SIDES_MIXED] > 0,
             "none %ld front %ld behind %ld mixed %ld", count[KF_SIDES_NONE], count[KF_SIDES_FRONT],
             count[KF_SIDES_BEHIND], count[KF_SIDES_MIXED]);
    KT_CHECK(count[KF_SIDES_MIXED] < NP / 2, "mixed %ld of %d points", count[KF_SIDES_MIXED], NP);
    free(sd.v);
    kf_rigid_body_free(&body);
}

static void sides_lattice(void) {
    sides_on(0);
    sides_on(1);
}

int main(int argc, char **argv) {
    KT_RUN(sweep_sand, argc, argv);
    KT_RUN(sweep_goo, argc, argv);
    KT_RUN(sweep_water, argc, argv);
    KT_RUN(sweep_jelly, argc, argv);
    KT_RUN(sweep_snow, argc, argv);
    KT_RUN(diagonal_sweep, argc, argv);
    KT_RUN(rotating_blade, argc, argv);
    KT_RUN(rest_without_jitter, argc, argv);
    KT_RUN(plate_keeps_momentum, argc, argv);
    KT_RUN(plate_back_jelly, argc, argv);
    KT_RUN(plate_back_goo, argc, argv);
    KT_RUN(plate_back_water, argc, argv);
    KT_RUN(halves_part, argc, argv);
    KT_RUN(audit_sees_crossing, argc, argv);
    KT_RUN(sides_lattice, argc, argv);
    return KT_EXIT();
}
