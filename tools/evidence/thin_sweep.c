/* thin_sweep.c — evidence: particles across a thin sheet against
 * its speed in cells per substep, per material and motion (thin_problem.h).
 *   kf_evid_thin_sweep [--dx 0.02] [--motion sweep|diagonal|rotate|rest] [--material NAME] [--cells C] [--off]
 * One line per case: material, motion, cells/substep, particles, substeps,
 * most across at an output frame, ever across (> 0.1 dx), deepest (dx),
 * across at the end, fastest particle (cells/substep), crossings the guard
 * caught, ms, the largest CFL number the fixed step reached (the material's
 * wave speed in its current state, as the step resolves it, plus the fastest
 * particle), the smallest volume ratio J of any particle at any substep's
 * end, the most particles evaluated at the stiffness the fixed step resolves
 * in one substep (stiff), and the trouble if the run failed. --off: penalty and push off
 * (the shot defaults before the thin-boundary work). --adaptive: the default CFL rule
 * instead of the fixed step (the speed is then cells per rest step). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../../tests/problems/thin_problem.h"

int main(int argc, char **argv) {
    double dx = 0.02, only_cells = 0;
    const char *only_mat = NULL, *only_motion = NULL;
    int defaults = 1, adaptive = 0;
    for (int i = 1; i < argc; i++) {
        if (!strcmp(argv[i], "--dx") && i + 1 < argc) dx = atof(argv[++i]);
        else if (!strcmp(argv[i], "--material") && i + 1 < argc) only_mat = argv[++i];
        else if (!strcmp(argv[i], "--motion") && i + 1 < argc) only_motion = argv[++i];
        else if (!strcmp(argv[i], "--cells") && i + 1 < argc) only_cells = atof(argv[++i]);
        else if (!strcmp(argv[i], "--off")) defaults = 0;
        else if (!strcmp(argv[i], "--adaptive")) adaptive = 1;
        else
            return fprintf(stderr, "usage: %s [--dx DX] [--material M] [--motion M] [--cells C] [--off] [--adaptive]\n",
                           argv[0]),
                   2;
    }
    static const char *mats[] = {"sand", "goo", "water", "jello", "snow", NULL};
    static const double speeds[] = {0.05, 0.25, 0.5, 1.0, 0};
    printf("%-6s %-9s %5s %7s %6s %6s %6s %7s %5s %6s %7s %8s %5s %6s %6s %s\n", "mat", "motion", "cells", "parts",
           "steps", "frame", "ever", "deep", "end", "vmax", "caught", "ms", "cfl", "J_min", "stiff", "trouble");
    for (int mo = THIN_SWEEP; mo <= THIN_REST; mo++) {
        if (only_motion && strcmp(only_motion, thin_motion_name((thin_motion)mo))) continue;
        for (int k = 0; mats[k]; k++) {
            if (only_mat && strcmp(only_mat, mats[k])) continue;
            for (int v = 0; speeds[v] > 0; v++) {
                if (only_cells > 0 && speeds[v] != only_cells) continue;
                if (mo == THIN_REST && v > 0) break;
                thin_case c = {mats[k], (thin_motion)mo, speeds[v], dx, 10, 0, defaults, adaptive};
                thin_result r;
                if (thin_run(&c, &r)) return 1;
                printf("%-6s %-9s %5.2f %7ld %6ld %6ld %6ld %7.3f %5ld %6.2f %7ld %8.0f %5.2f %6.3f %6ld %s", mats[k],
                       thin_motion_name((thin_motion)mo), mo == THIN_REST ? 0 : speeds[v], r.particles, r.substeps,
                       r.across_frame_max, r.across_ever, r.deepest, r.end_across, r.max_cells, r.caught, r.ms,
                       r.cfl_max, r.j_min, r.stiff_limited, r.failed ? r.trouble : "");
                if (mo == THIN_REST) printf(" rms speed %.4f m/s", r.jitter);
                printf("\n");
                fflush(stdout);
            }
        }
    }
    return 0;
}
