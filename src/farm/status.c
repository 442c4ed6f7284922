/* status.c — `kerf farm status` and `kerf farm cancel`: what a submission
 * (its <dir>/farm/jobs.txt) became. States come from squeue; frames done
 * come from the files on disk, which outlive Slurm's memory of a job. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "../io/checkpoint.h"
#include "../pipeline/stages.h"
#include "farm_internal.h"
#include "slurm.h"

typedef struct rec_job {
    long id;
    char name[200], step[16];
    int wedge;
} rec_job;

void kf_farm_frames_done(const kf_cli_opts *o, const kf_shot *shot, int *sim, int *surf, int *img) {
    uint64_t hash = kf_shot_sim_hash(shot);
    *sim = *surf = *img = 0;
    for (int f = shot->first; f <= shot->last; f++) {
        kf_frame_paths fp;
        kf_checkpoint_info info;
        char err[4200];
        if (kf_frame_paths_make(shot, o->out, f, &fp) || kf_checkpoint_peek(fp.checkpoint, &info, err, sizeof err) ||
            info.inputs_hash != hash)
            continue;
        (*sim)++;
        *surf += kf_output_current(fp.surface, fp.checkpoint);
        *img += kf_cli_frame_current(o, shot, f);
    }
}

/* the arguments submit was given, NUL-separated in submit.args */
static int read_args(const char *farm, char *buf, size_t n, char **argv, int max) {
    char path[4500];
    snprintf(path, sizeof path, "%s/submit.args", farm);
    FILE *f = fopen(path, "rb");
    if (!f) return -1;
    size_t len = fread(buf, 1, n - 1, f);
    fclose(f);
    buf[len] = 0;
    int argc = 0;
    for (size_t i = 0; i < len && argc < max; i += strlen(buf + i) + 1) argv[argc++] = buf + i;
    return argc;
}

static int read_jobs(const char *farm, rec_job *j, int max, long *submitted) {
    char path[4500], line[512];
    snprintf(path, sizeof path, "%s/jobs.txt", farm);
    FILE *f = fopen(path, "r");
    if (!f) return -1;
    int n = 0;
    *submitted = 0;
    while (fgets(line, sizeof line, f) && n < max) {
        if (sscanf(line, "# submitted %ld", submitted) == 1) continue;
        if (sscanf(line, "%ld\t%199s\t%15s\t%d", &j[n].id, j[n].name, j[n].step, &j[n].wedge) == 4) n++;
    }
    fclose(f);
    return n;
}

/* "RUNNING 1, PENDING 3" from the queue's lines of one job */
static void job_state(const kf_slurm_task *q, int nq, long id, char *out, size_t n, int *live) {
    static const char *order[] = {"RUNNING",   "COMPLETING", "PENDING",       "COMPLETED", "FAILED",
                                  "CANCELLED", "TIMEOUT",    "OUT_OF_MEMORY", "NODE_FAIL"};
    int len = 0;
    out[0] = 0;
    *live = 0;
    for (size_t s = 0; s < sizeof order / sizeof *order; s++) {
        int c = 0;
        for (int i = 0; i < nq; i++)
            if (q[i].job == id && !strcmp(q[i].state, order[s])) c += q[i].count;
        if (!c) continue;
        if (s < 3) *live += c;
        len += snprintf(out + len, n - (size_t)len, "%s%s %d", len ? ", " : "", order[s], c);
        if (len >= (int)n) break;
    }
}

static void fmt_secs(char *buf, size_t n, double s) {
    int t = (int)(s + 0.5);
    if (t >= 3600) snprintf(buf, n, "%dh%02dm", t / 3600, t / 60 % 60);
    else snprintf(buf, n, "%dm%02ds", t / 60, t % 60);
}

static int one_submission(const char *farm, int cancel, int slurm_ok) {
    static rec_job j[4 * KF_WEDGE_MAX + 8];
    static kf_slurm_task q[16384];
    long submitted;
    int nj = read_jobs(farm, j, 4 * KF_WEDGE_MAX + 8, &submitted);
    if (nj < 0) {
        fprintf(stderr, "kerf farm: %s/jobs.txt: no submission recorded there\n", farm);
        return KF_EXIT_USAGE;
    }
    int nq = slurm_ok ? kf_slurm_queue(q, 16384) : -1;
    if (nq < 0) nq = 0;
    if (cancel) {
        /* only the jobs this submission made, and of those only the ones Slurm still holds */
        long ids[4 * KF_WEDGE_MAX + 8];
        int n = 0, live;
        char st[256];
        for (int i = 0; i < nj; i++) {
            job_state(q, nq, j[i].id, st, sizeof st, &live);
            if (live) ids[n++] = j[i].id;
        }
        kf_slurm_cancel(ids, n, 0);
        printf("kerf farm: %s: cancelled %d job%s still queued or running (of %d submitted)\n", farm, n,
               n == 1 ? "" : "s", nj);
        return KF_EXIT_OK;
    }
    /* the submission's own options give each wedge's shot and directory */
    char buf[65536], *argv[512];
    int argc = read_args(farm, buf, sizeof buf, argv, 512);
    kf_farm_opts fo;
    static kf_wedge w[KF_WEDGE_MAX];
    int nw = 0;
    kf_shot *shot = NULL;
    if (argc >= 0 && kf_farm_parse("farm status", argc, argv, &fo) == 0) {
        /* quietly: the shot's warnings were shown at submit */
        kf_diag d;
        char werr[1024];
        kf_diag_init(&d);
        shot = kf_shot_load(fo.o.shot, fo.o.sets, fo.o.nsets, fo.o.quality, fo.o.frames, &d);
        kf_diag_free(&d);
        if (fo.o.nwedges) nw = kf_wedges_expand(fo.o.wedges, fo.o.nwedges, w, KF_WEDGE_MAX, werr, sizeof werr);
        if (nw < 0 && shot) kf_shot_free(shot), shot = NULL;
    }
    time_t now = time(NULL);
    char ago[32];
    fmt_secs(ago, sizeof ago, difftime(now, (time_t)submitted));
    printf("%s (submitted %s ago)\n", farm, ago);
    printf("  %-28s %-8s %-30s %-8s %-7s %s\n", "job", "id", "state", "frames", "failed", "ETA");
    char fpath[4500], line[4600];
    snprintf(fpath, sizeof fpath, "%s/failures.txt", farm);
    for (int i = 0; i < nj; i++) {
        if (!strcmp(j[i].step, "guard")) continue; /* it runs only on a failure, which failures.txt tells */
        char st[256], frames[32] = "-", eta[32] = "";
        int live;
        job_state(q, nq, j[i].id, st, sizeof st, &live);
        if (!st[0]) snprintf(st, sizeof st, "%s", slurm_ok ? "ended" : "? (Slurm unreachable)");
        if (shot && j[i].wedge >= 0) {
            kf_cli_opts wo;
            char out[1200];
            if (nw) kf_wedge_opts(&fo.o, shot, &w[j[i].wedge], j[i].wedge + 1, &wo, out, sizeof out);
            else wo = fo.o;
            kf_diag d;
            kf_diag_init(&d);
            kf_shot *s = kf_shot_load(wo.shot, wo.sets, wo.nsets, wo.quality, wo.frames, &d);
            kf_diag_free(&d);
            if (s) {
                int sim, surf, img, total = s->last - s->first + 1;
                kf_farm_frames_done(&wo, s, &sim, &surf, &img);
                int done = !strcmp(j[i].step, "sim") ? sim : !strcmp(j[i].step, "surface") ? surf : img;
                snprintf(frames, sizeof frames, "%d/%d", done, total);
                /* ETA at the pace since submission, while the step runs */
                double el = difftime(now, (time_t)submitted);
                if (live && done > 0 && done < total) fmt_secs(eta, sizeof eta, el / done * (total - done));
                kf_shot_free(s);
            }
        }
        int failed = 0;
        FILE *ff = fopen(fpath, "r");
        size_t nl = strlen(j[i].name);
        while (ff && fgets(line, sizeof line, ff)) failed += !strncmp(line, j[i].name, nl) && line[nl] == '\t';
        if (ff) fclose(ff);
        printf("  %-28s %-8ld %-30s %-8s %-7d %s\n", j[i].name, j[i].id, st, frames, failed, eta);
    }
    /* each failure with the log to read */
    FILE *ff = fopen(fpath, "r");
    int first = 1;
    while (ff && fgets(line, sizeof line, ff)) {
        char *a = strtok(line, "\t\n"), *b = strtok(NULL, "\t\n"), *c = strtok(NULL, "\t\n");
        if (!a) continue;
        if (first) printf("failed:\n"), first = 0;
        printf("  %s %s: log %s\n", a, b ? b : "", c ? c : "?");
    }
    if (ff) fclose(ff);
    if (shot) kf_shot_free(shot);
    return KF_EXIT_OK;
}

int kf_farm_status(kf_farm_opts *f, int cancel) {
    char why[4500];
    int slurm_ok = kf_slurm_check(why, sizeof why) == 0;
    if (!slurm_ok && cancel) {
        fprintf(stderr, "kerf farm: %s Nothing cancelled.\n", why);
        return KF_EXIT_USAGE;
    }
    if (!slurm_ok) fprintf(stderr, "kerf farm: %s The frames done are read from disk.\n", why);
    char farm[4400], cwd[2048];
    if (f->o.shot) {
        kf_diag d;
        kf_diag_init(&d);
        kf_shot *shot = kf_shot_load(f->o.shot, f->o.sets, f->o.nsets, f->o.quality, f->o.frames, &d);
        kf_diag_print(stderr, &d);
        kf_diag_free(&d);
        if (!shot) return KF_EXIT_USAGE;
        char rel[2300];
        int bad = kf_farm_dir(&f->o, shot, rel, sizeof rel) || !getcwd(cwd, sizeof cwd);
        kf_shot_free(shot);
        if (bad) return KF_EXIT_FAIL;
        if (rel[0] == '/') snprintf(farm, sizeof farm, "%s", rel);
        else snprintf(farm, sizeof farm, "%s/%s", cwd, rel);
        return one_submission(farm, cancel, slurm_ok);
    }
    /* no shot: every submission made from this directory */
    FILE *reg = fopen(KF_FARM_REGISTRY, "r");
    if (!reg) {
        fprintf(stderr, "kerf farm: no submissions from this directory (no ./%s); name a shot\n", KF_FARM_REGISTRY);
        return KF_EXIT_USAGE;
    }
    int rc = KF_EXIT_OK;
    while (fgets(farm, sizeof farm, reg)) {
        farm[strcspn(farm, "\n")] = 0;
        if (!farm[0]) continue;
        int r = one_submission(farm, cancel, slurm_ok);
        if (r > rc) rc = r;
    }
    fclose(reg);
    return rc;
}
