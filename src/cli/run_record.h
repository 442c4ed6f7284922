/* run_record.h — what a run leaves for whoever watches it (kerf view, a
 * script, the farm): one JSON line per simulated frame in
 * <dir>/frames.jsonl, and where the run stands in <dir>/run.json.
 *
 * frames.jsonl is appended to, one whole line per write: a killed run leaves
 * at most a cut last line, which readers skip; a resumed frame appends again
 * and the later line wins. run.json is replaced atomically. */
#ifndef KF_RUN_RECORD_H
#define KF_RUN_RECORD_H

#include <stddef.h>

#include <kerf/kerf.h>
#include "../shot/shot.h"

/* Start the records of a run in dir: a run from the first frame empties
 * frames.jsonl (a resume keeps it). */
void kf_record_begin(const char *dir, int fresh);

/* One frame's statistics, appended to <dir>/frames.jsonl; with them the
 * thin-body audit at the frame's end: how many particles are on the wrong side
 * of a thin body and the deepest of them, in cells (0, 0 without bodies). */
void kf_record_frame(const char *dir, int frame, size_t particles, const kf_step_stats *st, double frame_ms,
                     long thin_across, double thin_across_deepest);

/* Where the run of shot stands: stage "sim", "surface", "render", "done" or
 * "failed"; frame the last one finished; done of todo in this stage; eta_s < 0
 * unknown. The shot's name, frame range and fps go with it. */
void kf_record_progress(const char *dir, const kf_shot *shot, const char *stage, int frame, int done, int todo,
                        double eta_s);

#endif
