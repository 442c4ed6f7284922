/* submit.c — `kerf farm submit`: a shot (each wedge of it) as Slurm jobs.
 *
 * Per wedge, four submissions, in this order:
 *   surface  an array of held tasks, index = frame - first frame, one per
 *            chunk of K frames that is not current yet;
 *   render   the same indices, task i after surface task i (aftercorr);
 *   sim      one job: it simulates (resuming from the last checkpoint made
 *            from the same inputs) and releases surface task i the moment the
 *            checkpoints of its frames are durably on disk (fsync'ed and
 *            renamed), so surfacing overlaps the sim. Releasing from the sim
 *            keeps the whole graph visible in the queue from the start, which
 *            a sim that submits its own followers would not;
 *   guard    runs only when the sim ends in failure (afternotok: an error, a
 *            cancel, a kill, a time limit) and cancels the surface tasks
 *            still held; their render tasks then can never start and Slurm
 *            removes them (--kill-on-invalid-dep). No orphans, nothing
 *            pending forever. A sim that ends well makes the guard's
 *            dependency impossible, and Slurm removes the guard.
 * With wedges, a last job makes the contact sheet after every render array.
 * Everything is checked first (Slurm answers, the shot and every wedge are
 * valid, no version holds other inputs, no earlier submission still runs):
 * a problem exits 2 with nothing submitted; an sbatch failure half-way
 * cancels what was submitted. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "../pipeline/stages.h"
#include "../io/atomic_file.h"
#include "../dist/dist.h"
#include "farm_internal.h"
#include "slurm.h"

/* An MPI sim with N ranks is one srun step of its job (which the
 * submission gives --ntasks=N): srun starts the ranks and wires them up
 * through PMIx, the interface Debian's Open MPI and Slurm share. A site whose
 * MPI wants another plugin sets SLURM_MPI_TYPE (pmi2, say) where it submits;
 * the job inherits it. */
static void sim_launch(FILE *f, int ranks) {
    fprintf(f, "exec ");
    if (ranks > 1) fprintf(f, "srun --ntasks=%d --mpi=\"${SLURM_MPI_TYPE:-pmix}\" ", ranks);
}

/* a shell word: 'text' with each ' written as '\'' */
static void sh_word(FILE *f, const char *s) {
    fputc('\'', f);
    for (; *s; s++)
        if (*s == '\'') fputs("'\\''", f);
        else fputc(*s, f);
    fputc('\'', f);
}

/* the options every step of a wedge shares: the shot, its values, quality, output */
static void sh_common(FILE *f, const kf_cli_opts *o) {
    sh_word(f, o->shot);
    for (int i = 0; i < o->nsets; i++) fputs(" --set ", f), sh_word(f, o->sets[i]);
    if (o->quality) fputs(" --quality ", f), sh_word(f, o->quality);
    if (o->out) fputs(" --out ", f), sh_word(f, o->out);
}

typedef struct job_set {
    char name[160];
    long surface, render, sim, guard;
} job_set;

/* write <farm>/scripts/<name>.sh; 0 or -1 */
static int script_open(kf_atomic_file *af, const char *farm, const char *name, char *path, size_t n) {
    snprintf(path, n, "%s/scripts/%s.sh", farm, name);
    if (kf_ensure_parent(path) || kf_atomic_open(af, path)) return -1;
    fprintf(af->f, "#!/bin/sh\n# %s: written by kerf farm submit; Slurm runs it\n", name);
    return 0;
}

static int script_close(kf_atomic_file *af, const char *path) {
    if (kf_atomic_commit(af)) return -1;
    return chmod(path, 0755);
}

/* the surface or render array's script: frames [first + index, + chunk - 1],
 * tried twice; a second failure is written to failures.txt with its log */
static int write_task_script(const char *farm, const char *name, const char *step, const char *kerf,
                             const kf_cli_opts *o, const kf_shot *shot, int chunk, char *path, size_t n) {
    kf_atomic_file af;
    if (script_open(&af, farm, name, path, n)) return -1;
    FILE *f = af.f;
    fprintf(f, "lo=$((%d + SLURM_ARRAY_TASK_ID)); hi=$((lo + %d)); [ $hi -gt %d ] && hi=%d\n", shot->first, chunk - 1,
            shot->last, shot->last);
    fprintf(f, "log=");
    sh_word(f, farm);
    fprintf(f, "/logs/%s.${SLURM_ARRAY_JOB_ID}_${SLURM_ARRAY_TASK_ID}.log\n", name);
    /* when the task started (seconds since the epoch): the queue's delay, read from the logs */
    fprintf(f, "echo \"kerf farm: %s task $SLURM_ARRAY_TASK_ID (frames $lo-$hi) started at $(date +%%s.%%N)\"\n", name);
    fprintf(f, "step() {\n    ");
    sh_word(f, kerf);
    fprintf(f, " farm task %s ", step);
    sh_common(f, o);
    fprintf(f, " --frames $lo-$hi\n}\n");
    fprintf(f, "step && exit 0\n");
    fprintf(f, "echo \"kerf farm: %s: frames $lo-$hi failed; retrying once\" >&2\n", name);
    fprintf(f, "step && exit 0\n");
    fprintf(f, "printf '%%s\\tframes %%s-%%s\\t%%s\\n' '%s' $lo $hi \"$log\" >> ", name);
    sh_word(f, farm);
    fprintf(f, "/failures.txt\nexit 1\n");
    return script_close(&af, path);
}

static int write_sim_script(const char *farm, const char *name, const char *kerf, const kf_cli_opts *o,
                            const char *frames, int threads, int ranks, long surface, int chunk, char *path, size_t n) {
    kf_atomic_file af;
    if (script_open(&af, farm, name, path, n)) return -1;
    FILE *f = af.f;
    fprintf(f, "export OMP_WAIT_POLICY=PASSIVE\n");
    sim_launch(f, ranks);
    sh_word(f, kerf);
    fprintf(f, " farm task sim ");
    sh_common(f, o);
    if (frames) fputs(" --frames ", f), sh_word(f, frames);
    fprintf(f, " --threads %d --resume --release-job %ld --chunk %d\n", threads, surface, chunk);
    return script_close(&af, path);
}

/* runs only when the sim failed: cancel what still waits on it, and say so */
static int write_guard_script(const char *farm, const char *name, const job_set *j, char *path, size_t n) {
    kf_atomic_file af;
    if (script_open(&af, farm, name, path, n)) return -1;
    FILE *f = af.f;
    fprintf(f, "scancel --state=PENDING %ld %ld\n", j->surface, j->render);
    fprintf(f, "printf '%%s\\t%%s\\t%%s\\n' '%s_sim' 'failed or cancelled; its waiting tasks were cancelled' ",
            j->name);
    sh_word(f, farm);
    fprintf(f, "'/logs/%s_sim.%ld.log' >> ", j->name, j->sim);
    sh_word(f, farm);
    fprintf(f, "/failures.txt\n");
    return script_close(&af, path);
}

static int write_sheet_script(const char *farm, const char *name, const char *kerf, const kf_cli_opts *o, char *path,
                              size_t n) {
    kf_atomic_file af;
    if (script_open(&af, farm, name, path, n)) return -1;
    FILE *f = af.f;
    fprintf(f, "exec ");
    sh_word(f, kerf);
    fprintf(f, " farm task sheet ");
    sh_common(f, o);
    if (o->frames) fputs(" --frames ", f), sh_word(f, o->frames);
    for (int i = 0; i < o->nwedges; i++) fputs(" --wedge ", f), sh_word(f, o->wedges[i]);
    fputc('\n', f);
    return script_close(&af, path);
}

/* sbatch with the usual options; the id or -1 (printed) */
static long sbatch(const kf_farm_opts *fo, const char *cwd, const char *name, const char *log, const char *extra[],
                   const char *script) {
    const char *argv[32];
    int k = 0;
    argv[k++] = "sbatch";
    argv[k++] = "--parsable";
    argv[k++] = "-J";
    argv[k++] = name;
    argv[k++] = "-o";
    argv[k++] = log;
    argv[k++] = "-D";
    argv[k++] = cwd;
    if (fo->partition) argv[k++] = "-p", argv[k++] = fo->partition;
    for (int i = 0; extra[i]; i++) argv[k++] = extra[i];
    argv[k++] = script;
    argv[k] = NULL;
    char err[4200];
    long id = kf_slurm_submit(argv, err, sizeof err);
    if (id < 0) fprintf(stderr, "kerf farm: %s: %s\n", name, err);
    return id;
}

/* the ids of an earlier submission from this farm dir that Slurm still runs or holds */
static int still_live(const char *farm, long *live, int max) {
    char path[4500], line[512];
    snprintf(path, sizeof path, "%s/jobs.txt", farm);
    FILE *f = fopen(path, "r");
    if (!f) return 0;
    static kf_slurm_task q[8192];
    int nq = kf_slurm_queue(q, 8192), n = 0;
    while (fgets(line, sizeof line, f) && n < max) {
        long id;
        if (line[0] == '#' || sscanf(line, "%ld", &id) != 1) continue;
        for (int i = 0; i < nq; i++)
            if (q[i].job == id && (!strcmp(q[i].state, "PENDING") || !strcmp(q[i].state, "RUNNING") ||
                                   !strcmp(q[i].state, "CONFIGURING") || !strcmp(q[i].state, "COMPLETING") ||
                                   !strcmp(q[i].state, "SUSPENDED") || !strcmp(q[i].state, "REQUEUED"))) {
                live[n++] = id;
                break;
            }
    }
    fclose(f);
    return n;
}

/* one line in ./.kerf-farm per farm dir */
static void remember(const char *farm) {
    char line[4500];
    FILE *f = fopen(KF_FARM_REGISTRY, "r");
    while (f && fgets(line, sizeof line, f)) {
        line[strcspn(line, "\n")] = 0;
        if (!strcmp(line, farm)) {
            fclose(f);
            return;
        }
    }
    if (f) fclose(f);
    f = fopen(KF_FARM_REGISTRY, "a");
    if (f) fprintf(f, "%s\n", farm), fclose(f);
}

int kf_farm_submit(kf_farm_opts *fo) {
    kf_cli_opts *o = &fo->o;
    char why[4500];
    if (kf_slurm_check(why, sizeof why)) {
        fprintf(stderr, "kerf farm: %s Nothing submitted.\n", why);
        return KF_EXIT_USAGE;
    }
    static kf_wedge w[KF_WEDGE_MAX];
    int nw;
    kf_shot *shot = kf_farm_load_wedges(o, w, &nw);
    if (!shot) return KF_EXIT_USAGE;
    char farm_rel[2300], farm[4400], cwd[2048], kerf[2048];
    ssize_t kl = readlink("/proc/self/exe", kerf, sizeof kerf - 1);
    if (kl <= 0 || !getcwd(cwd, sizeof cwd) || kf_farm_dir(o, shot, farm_rel, sizeof farm_rel)) {
        fprintf(stderr, "kerf farm: cannot find kerf's own path or the output directory. Nothing submitted.\n");
        kf_shot_free(shot);
        return KF_EXIT_FAIL;
    }
    kerf[kl] = 0;
    if (farm_rel[0] == '/') snprintf(farm, sizeof farm, "%s", farm_rel);
    else snprintf(farm, sizeof farm, "%s/%s", cwd, farm_rel);
    long live[64];
    int nlive = still_live(farm, live, 64);
    if (nlive) {
        fprintf(stderr,
                "kerf farm: %d job%s of the last submission of %s (%s/jobs.txt) %s still queued or "
                "running (job %ld%s); wait for them, or kerf farm cancel first. Nothing submitted.\n",
                nlive, nlive == 1 ? "" : "s", shot->name, farm, nlive == 1 ? "is" : "are", live[0],
                nlive > 1 ? ", ..." : "");
        kf_shot_free(shot);
        return KF_EXIT_USAGE;
    }

    /* each wedge's options and shot; no version may hold other inputs */
    int nj = nw ? nw : 1, problems = 0;
    kf_cli_opts *wo = calloc((size_t)nj, sizeof *wo);
    kf_shot **ws = calloc((size_t)nj, sizeof *ws);
    char(*outs)[1200] = calloc((size_t)nj, sizeof *outs);
    job_set *js = calloc((size_t)nj, sizeof *js);
    if (!wo || !ws || !outs || !js) {
        fprintf(stderr, "kerf farm: out of memory\n");
        return KF_EXIT_FAIL;
    }
    for (int k = 0; k < nj; k++) {
        if (nw) kf_wedge_opts(o, shot, &w[k], k + 1, &wo[k], outs[k], sizeof outs[k]);
        else wo[k] = *o;
        kf_diag d;
        kf_diag_init(&d);
        ws[k] = kf_shot_load(wo[k].shot, wo[k].sets, wo[k].nsets, wo[k].quality, wo[k].frames, &d);
        kf_diag_free(&d);
        if (!ws[k] || kf_cli_version_taken(&wo[k], ws[k])) problems++;
        /* what the ranks would refuse, refused before anything is queued */
        const char *no_mpi = ws[k] && fo->ranks > 1 ? kf_dist_unsupported_def(&ws[k]->sim, ws[k]->nrigids) : NULL;
        if (no_mpi) {
            fprintf(stderr,
                    "kerf farm: %s: --ranks %d: %s does not run over several MPI ranks yet; submit with "
                    "--ranks 1\n",
                    wo[k].shot, fo->ranks, no_mpi);
            problems++;
        }
        snprintf(js[k].name, sizeof js[k].name, "%s_w%02d", shot->name, nw ? k + 1 : 0);
        js[k].surface = js[k].render = js[k].sim = js[k].guard = -1; /* -1: not submitted (yet) */
    }
    int rc = problems ? KF_EXIT_USAGE : KF_EXIT_OK;
    if (problems) fprintf(stderr, "kerf farm: nothing submitted\n");

    /* the jobs; an sbatch that fails cancels everything submitted before it */
    long ids[4 * KF_WEDGE_MAX + 1];
    int nids = 0, tasks = 0;
    char renders[16 * KF_WEDGE_MAX + 32] = "afterok";
    char path[8192], log[8192], arr[8192], dep[64], cpus[32];
    for (int k = 0; k < nj && rc == KF_EXIT_OK; k++) {
        kf_shot *s = ws[k];
        job_set *j = &js[k];
        /* the chunks holding a frame whose image is not current */
        int len = 0, nchunks = 0;
        arr[0] = 0;
        for (int i = 0; i <= s->last - s->first; i += fo->chunk) {
            int todo = 0;
            for (int f = s->first + i; f <= s->last && f < s->first + i + fo->chunk && !todo; f++)
                todo = !kf_cli_frame_current(&wo[k], s, f);
            if (!todo || len > (int)sizeof arr - 16) continue;
            len += snprintf(arr + len, sizeof arr - (size_t)len, "%s%d", nchunks ? "," : "", i);
            nchunks++;
        }
        if (!nchunks) {
            j->sim = 0; /* 0: nothing to submit */
            if (!o->quiet)
                fprintf(stderr, "kerf farm: %s: frames %d-%d are current; nothing to do\n", j->name, s->first, s->last);
            continue;
        }
        char name[200], sarr[8200];
        snprintf(sarr, sizeof sarr, "--array=%s", arr);
        /* surface: held until the sim releases it */
        snprintf(name, sizeof name, "%s_surface", j->name);
        snprintf(log, sizeof log, "%s/logs/%s.%%A_%%a.log", farm, name);
        if (kf_mkdirs(strcat(strcpy(path, farm), "/logs")) ||
            write_task_script(farm, name, "surface", kerf, &wo[k], s, fo->chunk, path, sizeof path)) {
            fprintf(stderr, "kerf farm: %s: cannot write it (%s)\n", path, kf_io_reason(errno));
            rc = KF_EXIT_FAIL;
            break;
        }
        const char *ex_s[] = {"--hold", sarr, "-c", "1", NULL};
        if ((j->surface = sbatch(fo, cwd, name, log, ex_s, path)) < 0) break;
        ids[nids++] = j->surface;
        /* render: task i after surface task i */
        snprintf(name, sizeof name, "%s_render", j->name);
        snprintf(log, sizeof log, "%s/logs/%s.%%A_%%a.log", farm, name);
        snprintf(dep, sizeof dep, "--dependency=aftercorr:%ld", j->surface);
        if (write_task_script(farm, name, "render", kerf, &wo[k], s, fo->chunk, path, sizeof path)) break;
        const char *ex_r[] = {sarr, dep, "--kill-on-invalid-dep=yes", "-c", "1", NULL};
        if ((j->render = sbatch(fo, cwd, name, log, ex_r, path)) < 0) break;
        ids[nids++] = j->render;
        len = (int)strlen(renders);
        snprintf(renders + len, sizeof renders - (size_t)len, ":%ld", j->render);
        /* the sim */
        int threads = o->threads > 0 ? o->threads : 1;
        char ntasks[32];
        snprintf(name, sizeof name, "%s_sim", j->name);
        snprintf(log, sizeof log, "%s/logs/%s.%%j.log", farm, name);
        snprintf(cpus, sizeof cpus, "--cpus-per-task=%d", threads);
        snprintf(ntasks, sizeof ntasks, "--ntasks=%d", fo->ranks);
        if (write_sim_script(farm, name, kerf, &wo[k], o->frames, threads, fo->ranks, j->surface, fo->chunk, path,
                             sizeof path))
            break;
        const char *ex_sim[] = {cpus, ntasks, NULL};
        if ((j->sim = sbatch(fo, cwd, name, log, ex_sim, path)) < 0) break;
        ids[nids++] = j->sim;
        /* the guard: only if the sim fails */
        snprintf(name, sizeof name, "%s_guard", j->name);
        snprintf(log, sizeof log, "%s/logs/%s.%%j.log", farm, name);
        snprintf(dep, sizeof dep, "--dependency=afternotok:%ld", j->sim);
        if (write_guard_script(farm, name, j, path, sizeof path)) break;
        const char *ex_g[] = {dep, "--kill-on-invalid-dep=yes", "-c", "1", NULL};
        if ((j->guard = sbatch(fo, cwd, name, log, ex_g, path)) < 0) break;
        ids[nids++] = j->guard;
        tasks += nchunks;
    }
    long sheet = 0;
    if (rc == KF_EXIT_OK && nw) {
        char name[200], depall[sizeof renders + 32];
        snprintf(name, sizeof name, "%s_sheet", shot->name);
        snprintf(log, sizeof log, "%s/logs/%s.%%j.log", farm, name);
        snprintf(depall, sizeof depall, "--dependency=%s", renders);
        const char *ex_dep[] = {depall, "--kill-on-invalid-dep=yes", "-c", "1", NULL};
        const char *ex_none[] = {"-c", "1", NULL};
        if (write_sheet_script(farm, name, kerf, o, path, sizeof path) == 0 &&
            (sheet = sbatch(fo, cwd, name, log, strchr(renders, ':') ? ex_dep : ex_none, path)) > 0)
            ids[nids++] = sheet;
    }
    int complete = !problems && (!nw || sheet > 0);
    for (int k = 0; k < nj && complete; k++)
        if (js[k].sim != 0 && (js[k].surface < 0 || js[k].render < 0 || js[k].sim < 0 || js[k].guard < 0)) complete = 0;
    if (!problems && !complete) {
        kf_slurm_cancel(ids, nids, 0);
        fprintf(stderr,
                "kerf farm: the %d job%s submitted before the failure were cancelled; nothing is left "
                "queued\n",
                nids, nids == 1 ? "" : "s");
        rc = KF_EXIT_FAIL;
    }

    /* the record status and cancel read: jobs.txt, the arguments, ./.kerf-farm */
    if (rc == KF_EXIT_OK && nids) {
        kf_atomic_file af;
        snprintf(path, sizeof path, "%s/jobs.txt", farm);
        if (kf_ensure_parent(path) == 0 && kf_atomic_open(&af, path) == 0) {
            fprintf(af.f, "# submitted %ld\n", (long)time(NULL));
            for (int k = 0; k < nj; k++) {
                if (js[k].sim <= 0) continue;
                fprintf(af.f, "%ld\t%s_sim\tsim\t%d\n", js[k].sim, js[k].name, k);
                fprintf(af.f, "%ld\t%s_surface\tsurface\t%d\n", js[k].surface, js[k].name, k);
                fprintf(af.f, "%ld\t%s_render\trender\t%d\n", js[k].render, js[k].name, k);
                fprintf(af.f, "%ld\t%s_guard\tguard\t%d\n", js[k].guard, js[k].name, k);
            }
            if (sheet > 0) fprintf(af.f, "%ld\t%s_sheet\tsheet\t-1\n", sheet, shot->name);
            kf_atomic_commit(&af);
        }
        snprintf(path, sizeof path, "%s/submit.args", farm);
        if (kf_atomic_open(&af, path) == 0) {
            for (int i = 0; i < fo->argc; i++) fprintf(af.f, "%s%c", fo->argv[i], 0);
            kf_atomic_commit(&af);
        }
        snprintf(path, sizeof path, "%s/failures.txt", farm);
        unlink(path); /* failures of an earlier submission are history */
        remember(farm);
        if (!o->quiet)
            for (int k = 0; k < nj; k++)
                if (js[k].sim > 0)
                    fprintf(stderr, "kerf farm: %s: sim %ld, surface %ld, render %ld (%d frames, chunks of %d)%s%s\n",
                            js[k].name, js[k].sim, js[k].surface, js[k].render, ws[k]->last - ws[k]->first + 1,
                            fo->chunk, nw ? ": " : "", nw ? w[k].label : "");
        if (!o->quiet)
            fprintf(stderr, "kerf farm: %d jobs, %d tasks submitted%s; kerf farm status %s to watch, logs in %s/logs\n",
                    nids, tasks, sheet > 0 ? " (contact sheet last)" : "", o->shot, farm);
    }
    for (int k = 0; k < nj; k++)
        if (ws[k]) kf_shot_free(ws[k]);
    free(wo), free(ws), free(outs), free(js);
    kf_shot_free(shot);
    return rc;
}
