/* progress.c — the progress line shared by simulation, surfacing and rendering. */
#include "progress.h"

#include <stdio.h>

void kf_progress_eta(char *buf, size_t n, double seconds) {
    int s = seconds > 0 ? (int)(seconds + 0.5) : 0;
    if (s >= 3600) snprintf(buf, n, "%dh%02dm", s / 3600, s / 60 % 60);
    else snprintf(buf, n, "%dm%02ds", s / 60, s % 60);
}

int kf_progress_line(char *buf, size_t n, const char *stage, int frame, int done, int todo, const char *extra,
                     double eta_s) {
    enum { WIDTH = 20 };
    int fill = todo > 0 ? WIDTH * (done < todo ? done : todo) / todo : WIDTH;
    if (fill < 0) fill = 0;
    char eta[32];
    kf_progress_eta(eta, sizeof eta, eta_s);
    return snprintf(buf, n, "[%.*s%*s] %s frame %d (%d/%d)%s%s  ETA %s", fill, "####################", WIDTH - fill, "",
                    stage, frame, done, todo, extra && *extra ? "  " : "", extra ? extra : "", eta);
}
