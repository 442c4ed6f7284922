/* wedge.c — wedges: the shot at each combination of --wedge values, each in
 * its own directory <dir>/w<NN>, and `kerf run --wedge` that runs them one
 * after another and ends with the contact sheet (layout in farm.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "farm.h"

/* split "v1,v2,[a,b]" at the commas outside brackets and braces */
static int split_values(const char *s, char vals[][512], int max) {
    int n = 0, depth = 0;
    size_t len = 0;
    for (const char *p = s;; p++) {
        if (*p == '[' || *p == '{') depth++;
        if (*p == ']' || *p == '}') depth--;
        if (*p == 0 || (*p == ',' && depth == 0)) {
            if (n == max || len == 0) return -1;
            vals[n++][len] = 0;
            len = 0;
            if (*p == 0) break;
            continue;
        }
        if (n == max || len + 1 >= 512) return -1;
        vals[n][len++] = *p;
    }
    return n;
}

int kf_wedges_expand(const char *const *specs, int nspecs, kf_wedge *out, int max, char *err, size_t errlen) {
    static char vals[16][KF_WEDGE_MAX][512];
    int nvals[16], total = 1;
    char keys[16][256];
    if (nspecs > 16) return snprintf(err, errlen, "at most 16 --wedge options"), -1;
    for (int i = 0; i < nspecs; i++) {
        const char *eq = strchr(specs[i], '=');
        if (!eq || eq == specs[i] || (size_t)(eq - specs[i]) >= sizeof keys[i])
            return snprintf(err, errlen, "--wedge '%s': want KEY=V1,V2,... (e.g. materials.jelly.E=1e3,2e3)", specs[i]),
                   -1;
        memcpy(keys[i], specs[i], (size_t)(eq - specs[i]));
        keys[i][eq - specs[i]] = 0;
        nvals[i] = split_values(eq + 1, vals[i], KF_WEDGE_MAX);
        if (nvals[i] < 1)
            return snprintf(err, errlen, "--wedge '%s': want one or more values separated by commas (at most %d)",
                            specs[i], KF_WEDGE_MAX),
                   -1;
        total *= nvals[i];
        if (total > max) return snprintf(err, errlen, "the --wedge values make more than %d wedges", max), -1;
    }
    /* the product, the last option varying fastest */
    for (int k = 0; k < total; k++) {
        kf_wedge *w = &out[k];
        memset(w, 0, sizeof *w);
        int rest = k, len = 0;
        for (int i = nspecs - 1; i >= 0; i--) {
            int j = rest % nvals[i];
            rest /= nvals[i];
            snprintf(w->sets[i], sizeof w->sets[i], "%s=%s", keys[i], vals[i][j]);
        }
        w->nsets = nspecs;
        /* the label names each key by its last word: "E=1e3 nu=0.3" */
        for (int i = 0; i < nspecs; i++) {
            const char *dot = strrchr(keys[i], '.'), *eq = strchr(w->sets[i], '=');
            len += snprintf(w->label + len, sizeof w->label - (size_t)len, "%s%s=%s", i ? " " : "",
                            dot ? dot + 1 : keys[i], eq + 1);
            if (len >= (int)sizeof w->label) len = (int)sizeof w->label - 1;
        }
    }
    return total;
}

void kf_wedge_opts(const kf_cli_opts *base, const kf_shot *shot, const kf_wedge *w, int index, kf_cli_opts *o,
                   char *out, size_t outlen) {
    *o = *base;
    o->nwedges = 0;
    for (int i = 0; i < w->nsets && o->nsets < (int)(sizeof o->sets / sizeof *o->sets); i++)
        o->sets[o->nsets++] = w->sets[i];
    snprintf(out, outlen, "%s/w%02d", base->out ? base->out : shot->output_dir, index);
    o->out = out;
}

int kf_farm_base_dir(const kf_cli_opts *o, const kf_shot *shot, char *dir, size_t n) {
    return kf_shot_expand(o->out ? o->out : shot->output_dir, shot, shot->first, dir, n);
}

kf_shot *kf_farm_load_wedges(const kf_cli_opts *o, kf_wedge *w, int *nw) {
    kf_diag diag;
    kf_diag_init(&diag);
    kf_shot *shot = kf_shot_load(o->shot, o->sets, o->nsets, o->quality, o->frames, &diag);
    int errors = diag.errors;
    kf_diag_print(stderr, &diag);
    kf_diag_free(&diag);
    *nw = 0;
    if (shot && o->nwedges) {
        char err[1024];
        *nw = kf_wedges_expand(o->wedges, o->nwedges, w, KF_WEDGE_MAX, err, sizeof err);
        if (*nw < 0) {
            fprintf(stderr, "kerf: %s\n", err);
            errors++;
        }
        /* every wedge's values are checked like --set, all problems at once */
        for (int k = 0; k < *nw; k++) {
            const char *sets[160];
            int n = 0;
            for (int i = 0; i < o->nsets; i++) sets[n++] = o->sets[i];
            for (int i = 0; i < w[k].nsets; i++) sets[n++] = w[k].sets[i];
            kf_diag_init(&diag);
            kf_shot *ws = kf_shot_load(o->shot, sets, n, o->quality, o->frames, &diag);
            if (!ws) fprintf(stderr, "kerf: wedge w%02d (%s):\n", k + 1, w[k].label);
            kf_diag_print(stderr, &diag);
            errors += diag.errors + (ws == NULL && diag.errors == 0);
            kf_diag_free(&diag);
            if (ws) kf_shot_free(ws);
        }
    }
    if (!shot || errors) {
        fprintf(stderr, "kerf: %s: %d error%s, nothing simulated or written\n", o->shot, errors,
                errors == 1 ? "" : "s");
        if (shot) kf_shot_free(shot);
        return NULL;
    }
    return shot;
}

int kf_farm_run_wedges(const kf_cli_opts *o) {
    static kf_wedge w[KF_WEDGE_MAX];
    int nw;
    kf_shot *shot = kf_farm_load_wedges(o, w, &nw);
    if (!shot) return KF_EXIT_USAGE;
    char dir[2048];
    kf_farm_base_dir(o, shot, dir, sizeof dir);
    int rc = KF_EXIT_OK;
    for (int k = 0; k < nw && rc == KF_EXIT_OK; k++) {
        kf_cli_opts wo;
        char out[1200];
        kf_wedge_opts(o, shot, &w[k], k + 1, &wo, out, sizeof out);
        if (!o->quiet) fprintf(stderr, "kerf: wedge w%02d of %d: %s\n", k + 1, nw, w[k].label);
        rc = kf_cli_run(&wo);
        if (rc != KF_EXIT_OK)
            fprintf(stderr, "kerf: wedge w%02d (%s) failed; the wedges after it were not run\n", k + 1, w[k].label);
    }
    if (rc == KF_EXIT_OK && kf_contact_sheet(o, shot, w, nw, 6)) rc = KF_EXIT_FAIL;
    if (rc == KF_EXIT_OK && !o->quiet)
        fprintf(stderr, "kerf: %s: %d wedges in %s/w01..w%02d, contact sheet %s/contact_sheet.png\n", shot->name, nw,
                dir, nw, dir);
    kf_shot_free(shot);
    return rc;
}
