/* thin_problem.h — stress problems for thin boundaries, shared by
 * the tests (tests/test_thin.c) and the evidence sweep (thin_sweep.c).
 *
 * A zero-thickness sheet (two triangles) is driven through material:
 *   - SWEEP: the sheet spans a channel (it reaches past the domain on every
 *     side but the top) and translates along its normal through a bed of
 *     material, then stops dead (an abrupt stop) and is held there;
 *   - DIAGONAL: the same with the sheet's normal at 45 degrees to the grid;
 *   - ROTATE: a blade turning about one of its edges, immersed in material.
 * Its speed is set in cells per substep (the fastest point of the sheet),
 * with a fixed substep that keeps the material's own CFL number below 0.3.
 *
 * Every substep, every particle is checked against the exact plane of the
 * sheet at its pose, independently of kerf's colored distance field: a
 * particle whose projection falls on the sheet and whose side disagrees with
 * the side its persistent colour records is across. For the sweeps, a
 * particle that started in front of the sheet and is behind it is across
 * whatever its colour says (nothing can pass a wall that spans the channel). */
#ifndef KF_THIN_PROBLEM_H
#define KF_THIN_PROBLEM_H

typedef enum thin_motion { THIN_SWEEP = 0, THIN_DIAGONAL, THIN_ROTATE, THIN_REST } thin_motion;

typedef struct thin_case {
    const char *material; /* a preset: jello, goo, water, sand, snow, metal */
    thin_motion motion;
    double cells; /* the sheet's fastest point, cells per substep */
    double dx;    /* m */
    int frames;   /* output frames checked (every frame_substeps substeps) */
    int threads;
    int defaults; /* 1: the sheet's penalty and push as a shot leaves them (auto); 0: both off */
    int adaptive; /* 1: the default CFL rule instead of the fixed step (cells: the body's speed in
                     cells per rest step, 0.3 dx / c); checked after each rest step's worth */
} thin_case;

typedef struct thin_result {
    int failed; /* numerical trouble (message in trouble) */
    char trouble[320];
    long particles;
    long substeps;
    long across_frame_max; /* the most particles across at one output frame */
    long across_ever;      /* particles across (by more than 0.1 dx) at the end of some substep */
    double deepest;        /* the deepest any particle was behind at a substep's end, in dx */
    long end_across;       /* across at the end */
    double max_cells;      /* fastest particle, cells per substep */
    double ms;             /* wall time of the run */
    double jitter;         /* rest check: RMS speed of particles touching the sheet at the end, m/s */
    long caught;           /* kerf's own count of crossings it caught and undid (kf_step_stats) */
    double cfl_max;        /* fixed step: the largest CFL number it reached (dt over the step at CFL 1 for
                              the material's current wave speed and fastest particle) */
    double j_min;          /* the smallest volume ratio of any particle at any substep's end (water: its
                              tracked J; the others: det F, elastic and plastic parts together for snow
                              and sand being the particle's F) */
    long stiff_limited;    /* the most particles in one substep evaluated at the stiffness the fixed step
                              resolves (kf_step_stats.stiff_limited) */
} thin_result;

/* Run one case; returns 0 (result filled) or -1 (setup failed). */
int thin_run(const thin_case *c, thin_result *r);

const char *thin_motion_name(thin_motion m);

#endif
