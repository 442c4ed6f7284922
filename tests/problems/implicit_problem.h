/* implicit_problem.h — the problems, runs and error metric that the implicit
 * evidence tools share (implicit_sweep.c: the step sweep and the target;
 * implicit_crossover.c: the stiffness crossover).
 *
 * Two problems: a stiff elastic (fixed corotated) bar, ρ = 1000 kg/m³,
 * ν = 0.3, 0.4 m long, 8 x 12 cm section, either clamped by sticky walls at
 * x = 0 (its root lies beyond the wall) and released from rest under
 * gravity, where it sags and swings (the cantilever), or (g_tumble) free in
 * the air, thrown up at 1.2 m/s and spinning at 4 rad/s about z (the
 * tumbling bar). Simulated for FRAMES frames at 24 fps; a run's trajectory
 * (every particle's position by stable id at each frame) is compared with
 * a fine explicit reference's: the error is the largest over the frames of
 * the RMS particle position difference, in metres. Cost: process CPU
 * seconds per frame on 1 thread (CLOCK_PROCESS_CPUTIME_ID), the median of
 * g_repeat runs. */
#ifndef KF_EVID_IMPLICIT_PROBLEM_H
#define KF_EVID_IMPLICIT_PROBLEM_H

#include <stdio.h>

#include <kerf/kerf.h>
#include "implicit/implicit.h" /* the solve's per-stage profile */

#define FPS 24.0
#define FRAMES 6
#define TIGHT_TOL 1e-6 /* Newton tolerance of the solve-error reference (the default is 1e-3) */
/* a run's trajectory: positions by stable id at the start and after each
 * frame, frame f at traj + f · 3 NP_MAX */
#define NP_MAX 200000
#define TRAJ_DOUBLES ((size_t)(FRAMES + 1) * 3 * NP_MAX)
static inline double *traj_frame(double *traj, int f) { return traj + (size_t)f * 3 * NP_MAX; }

/* how a run integrates: explicit, or implicit by either scheme */
typedef enum integ { EXPLICIT = 0, BACKWARD_EULER = 1, MIDPOINT = 2 } integ;

typedef struct run {
    double dt; /* fixed step (0 = CFL) */
    double cfl;
    integ implicit;     /* EXPLICIT (0) or the implicit scheme */
    kf_precond precond; /* implicit: CG's preconditioner */
    int ok;
    double cpu_per_frame;
    double rms;       /* the error: the largest over the frames of the RMS position difference to the reference */
    double rms_end;   /* the same at the last frame alone (the metric before: it depends on the swing's phase) */
    double maxerr;    /* the largest position difference of any particle at any frame */
    double solve_rms; /* implicit: RMS position difference to the same step solved to TIGHT_TOL */
    long substeps, newton, krylov;
    kf_imp_profile prof;             /* the implicit solve's stages (g_profile) */
    double other_ms[KF_STAGE_COUNT]; /* kerf's stage timers (wall ms; CPU ms on an idle core) */
} run;

/* the settings every run reads */
extern double g_dx;
/* the implicit solve's settings (0 = kerf's defaults) */
extern double g_newton_tol, g_krylov_tol;
extern int g_krylov_max, g_newton_max;
/* the solve-error reference: TIGHT_TOL instead of the settings above */
extern int g_tight;
/* timed runs are repeated this many times and their median CPU time kept
 * (the machine is shared: one run can be slowed by another's cache traffic) */
extern int g_repeat;
extern int g_profile;
/* cost by wall-clock time (CLOCK_MONOTONIC) instead of process CPU time:
 * for an idle machine, where the two should agree on 1 thread */
extern int g_wall;
/* the problem: the clamped cantilever (0) or the tumbling bar (1) */
extern int g_tumble;

/* the P-wave speed of the bar at stiffness E */
double wave_speed(double E);
/* simulate FRAMES frames; traj receives the trajectory (TRAJ_DOUBLES, see
 * traj_frame), *n_out the particle count */
run simulate(double E, integ how, kf_precond pc, double cfl, double dt_fixed, double *traj, size_t *n_out);
/* the same g_repeat times (the runs are deterministic), keeping the median CPU time */
run simulate_median(double E, integ how, kf_precond pc, double cfl, double dt_fixed, double *traj, size_t *n_out);
/* CPU ms per substep of each stage of the implicit solve, then the rest of the substep */
void print_profile(FILE *o, const run *r);
double rms_diff(const double *x, const double *y, size_t n);
/* the largest over frames 1..FRAMES of the RMS difference of two trajectories */
double traj_diff(double *x, double *y, size_t n);
/* the reference's largest RMS displacement from its start: the motion's size */
double traj_motion(double *ref, size_t n);
/* fill r's errors from trajectory x against the reference's */
void compare(run *r, double *x, double *ref, size_t n);
/* "explicit", "backward Euler", "midpoint" (with the preconditioner when not multigrid) */
const char *run_name(const run *r);

#endif
