/* internal.h — what the files of view/ share: the server's state. */
#ifndef KF_VIEW_INTERNAL_H
#define KF_VIEW_INTERNAL_H

#include <limits.h>
#include <sys/types.h>

#include "../shot/shot.h"
#include "json.h"
#include "view.h"

enum { KF_VIEW_MAX_RUNS = 64, KF_VIEW_MAX_SETS = 64, KF_VIEW_MAX_BODY = 16384 };

typedef struct kf_view_run {
    pid_t pid;     /* 0 once reaped */
    int status;    /* exit status once reaped, -1 while running */
    char dir[512]; /* its output directory, relative to the root */
} kf_view_run;

struct kf_view {
    struct MHD_Daemon *mhd;
    int sock, port;
    char url[64];
    char token[33];           /* 32 hex digits from the system's random source */
    char root[PATH_MAX];      /* the output root, resolved */
    char shot_path[PATH_MAX]; /* as given; "" when viewing a directory */
    kf_shot *shot;            /* the shot as written (final quality); NULL for a directory */
    char exe[PATH_MAX];       /* kerf, for runs */
    kf_buf keys;              /* the /api/keys answer, made once */
    kf_view_run runs[KF_VIEW_MAX_RUNS];
    int nruns;
};

/* ---- tweaks (runs.c) ------------------------------------------------------- */

/* The shot's keys as JSON (/api/keys). */
void kf_view_keys_json(const kf_view *v, kf_buf *out);
/* Validate sets (path=value) exactly as --set is, at preview quality:
 * {"ok":..,"errors":[{"set":i,"severity","where","message"}...]}.
 * Returns the number of errors. */
int kf_view_check(const kf_view *v, char **sets, int n, kf_buf *out);
/* Validate, then start kerf run at preview quality into a new version.
 * Returns the HTTP status: 200 started ({"ok":true,"dir":..}), 400 invalid
 * (the check's answer), 409 too many runs, 500 the start failed. */
int kf_view_start_run(kf_view *v, char **sets, int n, kf_buf *out);
/* Collect runs that ended; list this view's runs as JSON. */
void kf_view_runs_json(kf_view *v, kf_buf *out);
/* SIGTERM every run still going and wait for it. */
void kf_view_runs_stop(kf_view *v);

#endif
