/* progress.h — the one progress line every stage prints (simulating,
 * surfacing, rendering): a bar, the stage, the frame, frames done of the
 * run's total, the stage's own figures, and the time left. */
#ifndef KF_PROGRESS_H
#define KF_PROGRESS_H

#include <stddef.h>

/* seconds as "4m05s", or "1h02m" from an hour up */
void kf_progress_eta(char *buf, size_t n, double seconds);

/* "[#######             ] surface frame 1003 (3/12)  <extra>  ETA 0m04s":
 * the bar is 20 wide, filled done/todo; extra (may be NULL or "") is the
 * stage's own figures. Returns snprintf's count. */
int kf_progress_line(char *buf, size_t n, const char *stage, int frame, int done, int todo, const char *extra,
                     double eta_s);

#endif
