/* test_progress.c — the progress line simulation, surfacing and rendering
 * share: its exact text, the bar's fill and the time left's format. */
#include <string.h>

#include "kt.h"

#include "pipeline/progress.h"

#define KT_STR(got, want) KT_CHECK(strcmp(got, want) == 0, "got '%s', want '%s'", got, want)

static void line_format(void) {
    char b[256];
    kf_progress_line(b, sizeof b, "surface", 1003, 3, 12, "surface 120 ms, render 0 ms a frame", 4.4);
    KT_STR(b, "[#####               ] surface frame 1003 (3/12)  surface 120 ms, render 0 ms a frame  ETA 0m04s");
    kf_progress_line(b, sizeof b, "render", 1012, 12, 12, NULL, 0);
    KT_STR(b, "[####################] render frame 1012 (12/12)  ETA 0m00s");
    kf_progress_line(b, sizeof b, "simulate", 1001, 1, 3, "", 3725);
    KT_STR(b, "[######              ] simulate frame 1001 (1/3)  ETA 1h02m");
    /* a bar never overflows, an empty run fills it */
    kf_progress_line(b, sizeof b, "render", 1, 5, 4, NULL, 0);
    KT_STR(b, "[####################] render frame 1 (5/4)  ETA 0m00s");
    kf_progress_line(b, sizeof b, "render", 1, 0, 0, NULL, 0);
    KT_STR(b, "[####################] render frame 1 (0/0)  ETA 0m00s");
}

static void eta_format(void) {
    char b[32];
    kf_progress_eta(b, sizeof b, 65);
    KT_STR(b, "1m05s");
    kf_progress_eta(b, sizeof b, 59.6); /* rounded to the second */
    KT_STR(b, "1m00s");
    kf_progress_eta(b, sizeof b, 7322);
    KT_STR(b, "2h02m");
    kf_progress_eta(b, sizeof b, -3); /* a clock step back shows no time left, not a negative one */
    KT_STR(b, "0m00s");
}

int main(int argc, char **argv) {
    KT_RUN(line_format, argc, argv);
    KT_RUN(eta_format, argc, argv);
    return KT_EXIT();
}
