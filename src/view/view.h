/* view.h — `kerf view`: a local web page that plays a shot's frames, plots
 * its frame records, and re-runs it with edited keys at preview quality.
 *
 * The server binds 127.0.0.1 only, answers only requests addressed to that
 * host, serves only files under the shot's output root, and starts runs only
 * for a request carrying this session's token (a random value written into
 * the page it serves). Runs are kerf itself as a child process, started from
 * an argument vector, never through a shell.
 *
 *     kf_view_opts o = {.target = "shots/demo.yaml", .port = 8765};
 *     char err[1024];
 *     kf_view *v = kf_view_start(&o, &diag, &status, err, sizeof err);
 *     printf("%s\n", kf_view_url(v));
 *     ... wait for a signal ...
 *     kf_view_stop(v);
 */
#ifndef KF_VIEW_H
#define KF_VIEW_H

#include <stddef.h>

#include "../shot/diag.h"

typedef struct kf_view kf_view;

typedef struct kf_view_opts {
    const char *target; /* a shot file (.yaml, .yml, .json), or an output directory */
    int port;           /* 0: any free port */
    const char *kerf;   /* the kerf executable runs start; NULL: this process's own */
} kf_view_opts;

/* Load the shot (its problems go to diag), find its output root, bind and
 * start serving. Returns NULL with a message in err (and 2 in *status for bad
 * input, 1 for anything else: the port in use, a missing directory). */
kf_view *kf_view_start(const kf_view_opts *o, kf_diag *diag, int *status, char *err, size_t errlen);
/* "http://127.0.0.1:PORT/" */
const char *kf_view_url(const kf_view *v);
/* the directory served, resolved */
const char *kf_view_root(const kf_view *v);
/* Stop serving; runs this view started are stopped too (SIGTERM: they can
 * be resumed with kerf run --resume). */
void kf_view_stop(kf_view *v);

#endif
