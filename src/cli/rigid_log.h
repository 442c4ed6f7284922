/* rigid_log.h — rigid bodies in the text a run prints: what each body is
 * (kerf info) and where it is after each frame (the frame log). */
#ifndef KF_RIGID_LOG_H
#define KF_RIGID_LOG_H

#include <stdio.h>

#include <kerf/kerf.h>
#include "../shot/shot.h"

/* One line per body: "  rigid NAME: thin kinematic mesh, 1234 seeds" (and
 * the mass of a dynamic one), then one per joint. */
void kf_rigid_log_info(FILE *f, const kf_shot *shot, const kf_model *m);

/* One line per body after a frame: where its centre of mass (static and
 * kinematic: its pivot) is and how it moves, e.g.
 * "  rigid blade: at [0.500, 0.433, 0.300] m, v [0.000, -0.360, 0.000] m/s, w [0.00, 0.00, 0.00] rad/s" */
void kf_rigid_log_frame(FILE *f, const kf_shot *shot, const kf_state *s);

#endif
