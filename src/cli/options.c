/* options.c — option parsing and shot loading shared by the commands. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../scene/budget.h"
#include "cli.h"

static int parse_int(const char *s, int lo, int hi, int *out) {
    char *end;
    errno = 0;
    long v = strtol(s, &end, 10);
    if (errno || *end || end == s || v < lo || v > hi) return -1;
    *out = (int)v;
    return 0;
}

int kf_cli_parse(const char *cmd, int argc, char **argv, kf_cli_opts *o) {
    memset(o, 0, sizeof *o);
    for (int i = 0; i < argc; i++) {
        const char *a = argv[i], *val = i + 1 < argc ? argv[i + 1] : NULL;
        /* --opt=value is the same as --opt value */
        char name[64];
        const char *eq = strchr(a, '=');
        if (a[0] == '-' && a[1] == '-' && eq && (size_t)(eq - a) < sizeof name) {
            memcpy(name, a, (size_t)(eq - a));
            name[eq - a] = 0;
            a = name;
            val = eq + 1;
        } else if (eq == NULL || a[0] != '-') {
            eq = NULL;
        }
        int takes = !strcmp(a, "--set") || !strcmp(a, "--quality") || !strcmp(a, "--frames") || !strcmp(a, "--out") ||
                    !strcmp(a, "--threads") || !strcmp(a, "--wedge");
        if (takes && !val) {
            fprintf(stderr, "kerf %s: %s needs a value (see kerf %s --help)\n", cmd, a, cmd);
            return KF_EXIT_USAGE;
        }
        if (!strcmp(a, "--help") || !strcmp(a, "-h")) o->help = 1;
        else if (!strcmp(a, "--set")) {
            if (o->nsets == (int)(sizeof o->sets / sizeof *o->sets)) {
                fprintf(stderr, "kerf %s: too many --set options\n", cmd);
                return KF_EXIT_USAGE;
            }
            o->sets[o->nsets++] = val;
        } else if (!strcmp(a, "--wedge")) {
            /* a wedge runs the shot once per value: only run and farm submit do */
            if (strcmp(cmd, "run") && strncmp(cmd, "farm ", 5)) {
                fprintf(stderr, "kerf %s: --wedge is for kerf run and kerf farm submit\n", cmd);
                return KF_EXIT_USAGE;
            }
            if (o->nwedges == (int)(sizeof o->wedges / sizeof *o->wedges)) {
                fprintf(stderr, "kerf %s: too many --wedge options\n", cmd);
                return KF_EXIT_USAGE;
            }
            o->wedges[o->nwedges++] = val;
        } else if (!strcmp(a, "--quality")) o->quality = val;
        else if (!strcmp(a, "--frames")) o->frames = val;
        else if (!strcmp(a, "--out")) {
            /* "" would put every output at the root ("/particles/...") */
            if (strspn(val, " \t") == strlen(val)) {
                fprintf(stderr, "kerf %s: --out is empty: give a directory (relative to the current directory)\n", cmd);
                return KF_EXIT_USAGE;
            }
            o->out = val;
        } else if (!strcmp(a, "--threads")) {
            if (parse_int(val, 1, 1024, &o->threads)) {
                fprintf(stderr, "kerf %s: --threads wants an integer in [1, 1024], got '%s'\n", cmd, val);
                return KF_EXIT_USAGE;
            }
        } else if (!strcmp(a, "--resume")) o->resume = 1;
        else if (!strcmp(a, "--force")) o->force = 1;
        else if (!strcmp(a, "--quiet") || !strcmp(a, "-q")) o->quiet = 1;
        else if (a[0] == '-' && a[1]) {
            fprintf(stderr, "kerf %s: unknown option '%s' (see kerf %s --help)\n", cmd, a, cmd);
            return KF_EXIT_USAGE;
        } else if (!o->shot) {
            o->shot = a;
            continue;
        } else {
            fprintf(stderr, "kerf %s: one shot file at a time ('%s' and '%s')\n", cmd, o->shot, a);
            return KF_EXIT_USAGE;
        }
        if (takes && !eq) i++;
    }
    if (!o->help && !o->shot) {
        fprintf(stderr, "kerf %s: which shot? (kerf %s shots/demo.yaml)\n", cmd, cmd);
        return KF_EXIT_USAGE;
    }
    return KF_EXIT_OK;
}

int kf_cli_start(const char *cmd, int argc, char **argv, kf_cli_opts *o, kf_shot **shot, kf_scene *sc,
                 kf_build_stats *stats) {
    *shot = NULL;
    int rc = kf_cli_parse(cmd, argc, argv, o);
    if (rc) return rc;
    if (o->help) {
        kf_cli_usage(stdout, cmd);
        return KF_EXIT_OK;
    }
    return kf_cli_load(o, shot, sc, stats);
}

int kf_cli_load(const kf_cli_opts *o, kf_shot **shot, kf_scene *sc, kf_build_stats *stats) {
    kf_diag diag;
    kf_diag_init(&diag);
    *shot = kf_shot_load(o->shot, o->sets, o->nsets, o->quality, o->frames, &diag);
    int rc = KF_EXIT_OK;
    /* the cost first: a shot too large to seed would take all the memory before any message */
    kf_budget b;
    char err[1024];
    if (!*shot) rc = KF_EXIT_USAGE;
    else if (kf_budget_estimate(*shot, &b, err, sizeof err) == 0 && !o->force && kf_budget_check(*shot, &b, &diag))
        rc = KF_EXIT_USAGE;
    else if (kf_scene_from_shot_part(*shot, o->threads, o->rank_part, sc, stats, &diag)) rc = KF_EXIT_USAGE;
    kf_diag_print(stderr, &diag);
    if (rc != KF_EXIT_OK) {
        fprintf(stderr, "kerf: %s: %d error%s, nothing simulated or written\n", o->shot, diag.errors,
                diag.errors == 1 ? "" : "s");
        if (*shot) kf_shot_free(*shot);
        *shot = NULL;
    }
    kf_diag_free(&diag);
    return rc;
}
