/* runs.c — the tweak loop: the shot's keys for the page, an edit checked
 * exactly as `--set` is (the same loader, the same messages), and a valid
 * edit re-run at preview quality into a new version by kerf itself, a child
 * process started from an argument vector (no shell ever sees request data). */
#define _DEFAULT_SOURCE /* realpath, getrandom */
#include <errno.h>
#include <fcntl.h>
#include <signal.h>
#include <spawn.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "../io/atomic_file.h"
#include "../scene/budget.h"
#include "internal.h"

extern char **environ;

static int key_json(const kf_shot_keyview *k, void *ctx) {
    kf_buf *b = ctx;
    kf_buf_printf(b, "%s{", b->s[b->len - 1] == '[' ? "" : ",");
    kf_buf_kv(b, "path", k->path);
    kf_buf_kv(b, "key", k->key);
    kf_buf_kv(b, "type", k->type);
    kf_buf_kv(b, "choices", k->choices);
    kf_buf_kv(b, "default", k->def);
    kf_buf_kv(b, "unit", k->unit);
    kf_buf_kv(b, "doc", k->doc);
    kf_buf_kv(b, "bounds", k->bounds);
    kf_buf_kv(b, "value", k->value);
    kf_buf_printf(b, ",\"applies\":%s,\"editable\":%s}", k->applies ? "true" : "false",
                  k->editable && k->applies ? "true" : "false");
    return 0;
}

void kf_view_keys_json(const kf_view *v, kf_buf *out) {
    kf_buf_put(out, "{\"keys\":[", 9);
    if (v->shot) kf_shot_keys_each(v->shot, key_json, out);
    kf_buf_put(out, "]}", 2);
}

/* the shot loaded with these overrides at preview quality; diag gets every problem */
static kf_shot *load_with(const kf_view *v, char **sets, int n, kf_diag *diag) {
    return kf_shot_load(v->shot_path, (const char *const *)sets, n, "preview", NULL, diag);
}

/* every diagnostic; an override's carries which one (its line under --set) */
static int diag_json(const kf_diag *d, kf_buf *out) {
    kf_buf_printf(out, "{\"ok\":%s,\"errors\":[", d->errors ? "false" : "true");
    for (int i = 0; i < d->count; i++) {
        const kf_diag_entry *e = &d->entry[i];
        char where[1200];
        snprintf(where, sizeof where, "%s:%d:%d", e->file ? e->file : "", e->line, e->col);
        kf_buf_printf(out, "%s{\"set\":%d", i ? "," : "", e->file && !strcmp(e->file, "--set") ? e->line - 1 : -1);
        kf_buf_kv(out, "severity", e->severity == KF_DIAG_ERROR ? "error" : "warning");
        kf_buf_kv(out, "where", where);
        kf_buf_kv(out, "message", e->message);
        kf_buf_kv(out, "source", e->source);
        kf_buf_put(out, "}", 1);
    }
    kf_buf_put(out, "]", 1);
    return d->errors;
}

/* the check; with budget, also what kerf run refuses before seeding (memory,
 * substeps a frame), reported at the value that causes it */
static int check(const kf_view *v, char **sets, int n, int budget, kf_buf *out) {
    if (!v->shot) {
        kf_buf_printf(out, "{\"ok\":false,\"errors\":[{\"set\":-1,\"severity\":\"error\",\"where\":\"\","
                           "\"message\":\"a directory is being viewed, not a shot: nothing to re-run\"}]}");
        return 1;
    }
    kf_diag d;
    kf_diag_init(&d);
    kf_shot *s = load_with(v, sets, n, &d);
    kf_budget b;
    char err[1024];
    if (s && budget && kf_budget_estimate(s, &b, err, sizeof err) == 0) kf_budget_check(s, &b, &d);
    kf_diag_sort(&d);
    int errors = diag_json(&d, out);
    kf_buf_put(out, "}", 1);
    if (s) kf_shot_free(s);
    kf_diag_free(&d);
    return errors;
}

int kf_view_check(const kf_view *v, char **sets, int n, kf_buf *out) { return check(v, sets, n, 0, out); }

/* the output directory of version `version` (absolute or relative to where kerf runs) */
static int version_dir(const kf_shot *shot, int version, char *out, size_t n) {
    kf_shot copy = *shot; /* the template reads the name and the version only */
    copy.version = version;
    return kf_shot_expand(shot->output_dir, &copy, shot->first, out, n);
}

/* the first version after every one the output root holds */
static int next_version(const kf_shot *shot) {
    int top = shot->version, misses = 0;
    for (int v = 1; v <= 9999 && misses < 200; v++) {
        char dir[2048];
        struct stat st;
        if (version_dir(shot, v, dir, sizeof dir) == 0 && stat(dir, &st) == 0) {
            if (v > top) top = v;
            misses = 0;
        } else if (v > top) misses++;
    }
    return top + 1;
}

/* collect the runs that ended */
static void reap(kf_view *v) {
    for (int i = 0; i < v->nruns; i++) {
        kf_view_run *r = &v->runs[i];
        int st;
        if (r->pid > 0 && waitpid(r->pid, &st, WNOHANG) == r->pid) {
            r->status = WIFEXITED(st) ? WEXITSTATUS(st) : 128 + WTERMSIG(st);
            r->pid = 0;
        }
    }
}

int kf_view_start_run(kf_view *v, char **sets, int n, kf_buf *out) {
    reap(v); /* a slot may have freed */
    if (check(v, sets, n, 1, out)) return 400;
    int live = 0;
    for (int i = 0; i < v->nruns; i++) live += v->runs[i].pid > 0;
    if (live >= 2 || v->nruns == KF_VIEW_MAX_RUNS) {
        out->len = 0;
        kf_buf_printf(out,
                      "{\"ok\":false,\"errors\":[{\"set\":-1,\"severity\":\"error\",\"where\":\"\",\"message\":"
                      "\"%d runs are going already: wait for one to end\"}]}",
                      live);
        return 409;
    }
    /* a new version: {version} in output.dir when the template has it, else view_NNN under the root */
    char vset[64], outdir[2048], absdir[PATH_MAX + 64];
    int templ = strstr(v->shot->output_dir, "{version") != NULL, version = 0;
    if (templ) {
        version = next_version(v->shot);
        snprintf(vset, sizeof vset, "version=%d", version);
        if (version_dir(v->shot, version, outdir, sizeof outdir)) return 500;
        snprintf(absdir, sizeof absdir, "%s", outdir);
    } else {
        for (version = 1; version < 10000; version++) {
            struct stat st;
            snprintf(absdir, sizeof absdir, "%s/view_%03d", v->root, version);
            if (stat(absdir, &st) != 0) break;
        }
    }
    if (kf_mkdirs(absdir)) {
        out->len = 0;
        kf_buf_printf(out, "{\"ok\":false,\"errors\":[{\"set\":-1,\"severity\":\"error\",\"where\":\"\",\"message\":");
        kf_buf_str(out, strerror(errno));
        kf_buf_put(out, "}]}", 3);
        return 500;
    }
    char real[PATH_MAX];
    if (!realpath(absdir, real)) return 500;
    size_t rl = strlen(v->root);
    const char *rel = strncmp(real, v->root, rl) == 0 && real[rl] == '/' ? real + rl + 1 : NULL;
    if (!rel) {
        out->len = 0;
        kf_buf_printf(out, "{\"ok\":false,\"errors\":[{\"set\":-1,\"severity\":\"error\",\"where\":\"\",\"message\":"
                           "\"the new version's directory is outside the output root\"}]}");
        return 500;
    }

    /* what the run was asked, for the version grid's labels */
    char path[PATH_MAX + 32];
    snprintf(path, sizeof path, "%s/view.json", real);
    kf_atomic_file a;
    if (kf_atomic_open(&a, path) == 0) {
        kf_buf j = {0};
        kf_buf_printf(&j, "{\"version\":%d,\"quality\":\"preview\",\"started\":%lld,\"sets\":[", version,
                      (long long)time(NULL));
        for (int i = 0; i < n; i++) {
            if (i) kf_buf_put(&j, ",", 1);
            kf_buf_str(&j, sets[i]);
        }
        kf_buf_put(&j, "]}\n", 3);
        if (j.s) fputs(j.s, a.f);
        kf_buf_free(&j);
        kf_atomic_commit(&a);
    }

    /* kerf run <shot> --quality preview --set ... (--set version=N | --out DIR), its output in view.log */
    char *argv[2 * KF_VIEW_MAX_SETS + 12];
    int c = 0;
    argv[c++] = v->exe;
    argv[c++] = "run";
    argv[c++] = v->shot_path;
    argv[c++] = "--quality";
    argv[c++] = "preview";
    for (int i = 0; i < n && i < KF_VIEW_MAX_SETS; i++) {
        argv[c++] = "--set";
        argv[c++] = sets[i];
    }
    if (templ) {
        argv[c++] = "--set";
        argv[c++] = vset;
    } else {
        argv[c++] = "--out";
        argv[c++] = real;
    }
    argv[c] = NULL;
    snprintf(path, sizeof path, "%s/view.log", real);
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t at;
    posix_spawn_file_actions_init(&fa);
    posix_spawn_file_actions_addopen(&fa, 0, "/dev/null", O_RDONLY, 0);
    posix_spawn_file_actions_addopen(&fa, 1, path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_adddup2(&fa, 1, 2);
    posix_spawnattr_init(&at);
    /* the child gets the default signal mask and handlers, not the server's */
    sigset_t none, all;
    sigemptyset(&none);
    sigfillset(&all);
    posix_spawnattr_setsigmask(&at, &none);
    posix_spawnattr_setsigdefault(&at, &all);
    posix_spawnattr_setflags(&at, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
    pid_t pid;
    int e = posix_spawn(&pid, v->exe, &fa, &at, argv, environ);
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&at);
    out->len = 0;
    if (e) {
        kf_buf_printf(out, "{\"ok\":false,\"errors\":[{\"set\":-1,\"severity\":\"error\",\"where\":\"\",\"message\":");
        kf_buf_str(out, strerror(e));
        kf_buf_put(out, "}]}", 3);
        return 500;
    }
    kf_view_run *r = &v->runs[v->nruns++];
    r->pid = pid;
    r->status = -1;
    snprintf(r->dir, sizeof r->dir, "%s", rel);
    kf_buf_printf(out, "{\"ok\":true,\"pid\":%ld,\"version\":%d,\"dir\":", (long)pid, version);
    kf_buf_str(out, rel);
    kf_buf_put(out, "}", 1);
    return 200;
}

void kf_view_runs_json(kf_view *v, kf_buf *out) {
    reap(v);
    kf_buf_put(out, "[", 1);
    for (int i = 0; i < v->nruns; i++) {
        kf_view_run *r = &v->runs[i];
        kf_buf_printf(out, "%s{\"running\":%s,\"status\":%d,\"dir\":", i ? "," : "", r->pid > 0 ? "true" : "false",
                      r->status);
        kf_buf_str(out, r->dir);
        kf_buf_put(out, "}", 1);
    }
    kf_buf_put(out, "]", 1);
}

void kf_view_runs_stop(kf_view *v) {
    for (int i = 0; i < v->nruns; i++)
        if (v->runs[i].pid > 0) kill(v->runs[i].pid, SIGTERM);
    for (int i = 0; i < v->nruns; i++)
        if (v->runs[i].pid > 0) {
            int st;
            waitpid(v->runs[i].pid, &st, 0);
            v->runs[i].pid = 0;
        }
}
