/* slurm.c — running Slurm's client commands (sbatch, scontrol, squeue,
 * scancel) and reading what they print; the only place that starts them. */
#include <errno.h>
#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/wait.h>
#include <unistd.h>

#include "slurm.h"

int kf_slurm_cmd(const char *const *argv, char *out, size_t n) {
    int fds[2];
    if (out && n) out[0] = 0;
    if (pipe(fds)) return -1;
    pid_t pid = fork();
    if (pid < 0) {
        close(fds[0]), close(fds[1]);
        return -1;
    }
    if (pid == 0) {
        /* the child: stdout and stderr into the pipe, stdin from nothing */
        int devnull = open("/dev/null", O_RDONLY);
        if (devnull >= 0) dup2(devnull, 0);
        dup2(fds[1], 1), dup2(fds[1], 2);
        close(fds[0]), close(fds[1]);
        execvp(argv[0], (char *const *)argv);
        _exit(127);
    }
    close(fds[1]);
    size_t len = 0;
    char buf[4096];
    ssize_t got;
    while ((got = read(fds[0], buf, sizeof buf)) != 0) {
        if (got < 0 && errno == EINTR) continue;
        if (got < 0) break;
        for (ssize_t i = 0; i < got && out && len + 1 < n; i++) out[len++] = buf[i];
    }
    if (out && n) out[len] = 0;
    close(fds[0]);
    int st;
    while (waitpid(pid, &st, 0) < 0)
        if (errno != EINTR) return -1;
    return WIFEXITED(st) ? WEXITSTATUS(st) : 128 + (WIFSIGNALED(st) ? WTERMSIG(st) : 0);
}

/* 1 when an executable named `name` is on PATH */
static int on_path(const char *name) {
    const char *path = getenv("PATH");
    char full[4096];
    for (const char *p = path ? path : ""; *p;) {
        size_t len = strcspn(p, ":");
        snprintf(full, sizeof full, "%.*s/%s", (int)len, p, name);
        if (len && access(full, X_OK) == 0) return 1;
        p += len + (p[len] == ':');
    }
    return 0;
}

int kf_slurm_check(char *why, size_t n) {
    char out[4096];
    if (!on_path("sbatch") || !on_path("scontrol")) {
        snprintf(why, n,
                 "Slurm is not installed here (no sbatch on PATH); install slurm-wlm and munge, or run the "
                 "shot locally with kerf run.");
        return -1;
    }
    /* without its configuration every Slurm command retries for a minute before it gives up */
    const char *conf = getenv("SLURM_CONF");
    if (!conf || !conf[0]) conf = "/etc/slurm/slurm.conf";
    if (access(conf, R_OK) != 0) {
        snprintf(why, n, "no Slurm configuration at %s (%s); set SLURM_CONF to the cluster's slurm.conf.", conf,
                 strerror(errno));
        return -1;
    }
    /* the controller answers a ping when it is up and munge lets us in */
    const char *ping[] = {"scontrol", "ping", NULL};
    int rc = kf_slurm_cmd(ping, out, sizeof out);
    if (rc != 0 || !strstr(out, " is UP")) {
        char *nl;
        while ((nl = strchr(out, '\n')) && nl[1] == 0) *nl = 0;
        for (nl = out; (nl = strchr(nl, '\n'));) *nl = ' ';
        snprintf(why, n,
                 "the Slurm controller does not answer (scontrol ping: %s); is slurmctld running, and "
                 "SLURM_CONF pointing at its slurm.conf?",
                 out[0] ? out : "no output");
        return -1;
    }
    return 0;
}

long kf_slurm_submit(const char *const *argv, char *err, size_t n) {
    char out[4096];
    int rc = kf_slurm_cmd(argv, out, sizeof out);
    char *end;
    long id = strtol(out, &end, 10);
    if (rc != 0 || id <= 0 || (*end && *end != '\n' && *end != ';')) {
        char *nl = strchr(out, '\n');
        if (nl && nl[1] == 0) *nl = 0;
        snprintf(err, n, "sbatch failed (exit %d): %s", rc, out);
        return -1;
    }
    return id;
}

void kf_slurm_release(long job, int index) {
    char id[64];
    snprintf(id, sizeof id, "%ld_%d", job, index);
    const char *argv[] = {"scontrol", "release", id, NULL};
    kf_slurm_cmd(argv, NULL, 0);
}

int kf_slurm_queue(kf_slurm_task *t, int max) {
    /* every job the controller still knows, finished ones included (MinJobAge) */
    static char out[1 << 20];
    const char *argv[] = {"squeue", "--states=all", "-h", "-o", "%F|%i|%T", NULL};
    if (kf_slurm_cmd(argv, out, sizeof out) != 0) return -1;
    int n = 0;
    for (char *line = strtok(out, "\n"); line && n < max; line = strtok(NULL, "\n")) {
        char state[64];
        if (sscanf(line, "%ld|%*[^|]|%63s", &t[n].job, state) != 2) continue;
        snprintf(t[n].state, sizeof t[n].state, "%s", state);
        /* a pending array's tasks are one line, "12_[3-5]": count them */
        const char *br = strchr(line, '[');
        t[n].count = 1;
        if (br) {
            t[n].count = 0;
            for (const char *p = br + 1; *p && *p != ']';) {
                long a = strtol(p, (char **)&p, 10), b = a;
                if (*p == '-') b = strtol(p + 1, (char **)&p, 10);
                if (*p == ':') strtol(p + 1, (char **)&p, 10); /* a step: counted as the span */
                if (*p == '%') strtol(p + 1, (char **)&p, 10);
                t[n].count += (int)(b - a + 1);
                if (*p == ',') p++;
                else if (*p != ']') break;
            }
        }
        n++;
    }
    return n;
}

void kf_slurm_cancel(const long *jobs, int n, int pending_only) {
    if (n <= 0) return;
    const char **argv = calloc((size_t)n + 3, sizeof *argv);
    char(*ids)[32] = calloc((size_t)n, sizeof *ids);
    if (!argv || !ids) {
        free(argv), free(ids);
        return;
    }
    int k = 0;
    argv[k++] = "scancel";
    if (pending_only) argv[k++] = "--state=PENDING";
    for (int i = 0; i < n; i++) {
        snprintf(ids[i], sizeof ids[i], "%ld", jobs[i]);
        argv[k++] = ids[i];
    }
    kf_slurm_cmd(argv, NULL, 0);
    free(argv), free(ids);
}
