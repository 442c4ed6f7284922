/* cmd_view.c — `kerf view [shot.yaml | output dir]`: serve the flipbook and
 * tweak page (src/view) on 127.0.0.1 until Ctrl-C. */
#include <signal.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../view/view.h"
#include "cli.h"

/* the end of the view: a signal handler writes a byte here. A handler, not a
 * blocked-signal wait, because libraries start threads of their own before
 * main (a signal could land on one of those and kill the process without
 * stopping the runs the view started). */
static int stop_pipe[2] = {-1, -1};

static void on_stop(int sig) {
    char c = (char)sig;
    ssize_t w = write(stop_pipe[1], &c, 1);
    (void)w;
}

static void usage(FILE *f) {
    fprintf(f, "usage: kerf view <shot.yaml | output directory> [--port N]\n"
               "\n"
               "A local web page (http://127.0.0.1:N/, only this machine) that plays the shot's frames at its\n"
               "fps, side by side or wiped against another version, plots each frame's record (substeps,\n"
               "max CFL, ms per stage, retries, warnings, crossings), shows a run's progress while it writes,\n"
               "and re-runs the shot at preview quality into a new version with edited keys.\n"
               "\n"
               "options:\n"
               "  --port N            port to listen on (default 8765; 0: any free one)\n"
               "  --help              this text\n");
}

int kf_cmd_view(int argc, char **argv) {
    kf_view_opts o = {.port = 8765};
    for (int i = 0; i < argc; i++) {
        if (!strcmp(argv[i], "--help") || !strcmp(argv[i], "-h")) {
            usage(stdout);
            return KF_EXIT_OK;
        } else if (!strcmp(argv[i], "--port") && i + 1 < argc) {
            char *end;
            long p = strtol(argv[++i], &end, 10);
            if (*end || end == argv[i] || p < 0 || p > 65535) {
                fprintf(stderr, "kerf view: --port wants an integer in [0, 65535], got '%s'\n", argv[i]);
                return KF_EXIT_USAGE;
            }
            o.port = (int)p;
        } else if (argv[i][0] == '-') {
            fprintf(stderr, "kerf view: unknown option '%s' (see kerf view --help)\n", argv[i]);
            return KF_EXIT_USAGE;
        } else if (o.target) {
            fprintf(stderr, "kerf view: one shot or directory at a time ('%s' and '%s')\n", o.target, argv[i]);
            return KF_EXIT_USAGE;
        } else o.target = argv[i];
    }
    if (!o.target) {
        fprintf(stderr, "kerf view: which shot or output directory? (kerf view shots/demo.yaml)\n");
        return KF_EXIT_USAGE;
    }
    if (pipe(stop_pipe) != 0) {
        perror("kerf view: pipe");
        return KF_EXIT_FAIL;
    }
    struct sigaction sa;
    memset(&sa, 0, sizeof sa);
    sa.sa_handler = on_stop;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    sigaction(SIGINT, &sa, NULL);
    sigaction(SIGTERM, &sa, NULL);
    sigaction(SIGHUP, &sa, NULL);
    signal(SIGPIPE, SIG_IGN);

    kf_diag diag;
    kf_diag_init(&diag);
    char err[4400];
    int status;
    kf_view *v = kf_view_start(&o, &diag, &status, err, sizeof err);
    kf_diag_print(stderr, &diag);
    kf_diag_free(&diag);
    if (!v) {
        fprintf(stderr, "%s\n", err);
        return status;
    }
    printf("kerf view: %s  (serving %s; Ctrl-C to stop)\n", kf_view_url(v), kf_view_root(v));
    fflush(stdout);
    char c;
    while (read(stop_pipe[0], &c, 1) < 0) continue; /* interrupted: read again */
    kf_view_stop(v);
    fprintf(stderr, "kerf view: stopped\n");
    return KF_EXIT_OK;
}
