/* cmd_run.c — `kerf run`: simulate a shot frame by frame, with progress,
 * per-frame checkpoints and particles, and --resume.
 *
 * Frame f's outputs hold the state at t = (f − frames.start) / fps, so the
 * first frame is the initial state. Every file is written to a temporary name
 * and renamed: a killed run loses at most the frame in progress, and
 * --resume continues from the last good checkpoint, bit for bit. */
#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "../core/timer.h"
#include "../dist/dist.h"
#include "../io/atomic_file.h"
#include "../io/checkpoint.h"
#include "../farm/farm.h"
#include "../io/points_ply.h"
#include "cli.h"
#include "rigid_log.h"
#include "../pipeline/progress.h"
#include "../pipeline/stages.h"
#include "run_record.h"

/* Over several MPI ranks every rank walks this same path: each seeds only
 * its own part of the scene (or reads its own part of a checkpoint it resumes from), rank
 * 0 alone speaks, holds the directory and writes files, from the whole
 * state gathered to it when a frame has files to write (dist.h). */
static int ranks(void) { return kf_dist_size(); }
static int root(void) { return kf_dist_rank() == 0; }

/* Over several ranks a resume reads only this rank's part of a checkpoint:
 * the positions counted per block give every rank the same cut (as seeding
 * does), then each keeps the particles in its range (dist.h). */
static int part_see(void *ctx, kf_real *const x[3], size_t n) { return kf_dist_seed_count_reals(ctx, x, n); }
static long part_settle(void *ctx) { return kf_dist_seed_cut(ctx) ? -1 : (long)kf_dist_seed_mine(ctx); }
static int part_keep(void *ctx, const kf_real x[3]) { return kf_dist_seed_owns_real(ctx, x); }

static int read_checkpoint(const char *path, kf_scene *sc, kf_checkpoint_info *info, char *err, size_t errlen) {
    if (ranks() == 1) return kf_checkpoint_read(path, sc->model, sc->state, info, err, errlen);
    kf_dist_seed *sd = kf_dist_seed_new(sc->model);
    kf_checkpoint_filter f = {part_see, part_settle, part_keep, sd};
    if (!sd) snprintf(err, errlen, "%s: out of memory reading checkpoint", path);
    if (!sd || kf_checkpoint_read_part(path, sc->model, sc->state, &f, info, err, errlen)) {
        kf_dist_seed_free(sd);
        return -1;
    }
    kf_dist_seed_adopt_read(sd, sc->state);
    return 0;
}

/* Rank 0 writes a particle file from a checkpoint a window at a time (no
 * rank holds the whole state over several ranks): the header when the
 * file's clock is known, then each window's records. */
typedef struct ply_copy {
    const kf_model *m;
    const char *path;
    size_t n;
    kf_ply_out out;
    int open;
    char *err;
    size_t errlen;
} ply_copy;

static int ply_open(ply_copy *pc, const kf_state *clock) {
    if (!pc->open && kf_ply_begin(&pc->out, pc->path, clock, pc->n, pc->err, pc->errlen)) return -1;
    pc->open = 1;
    return 0;
}

static int ply_window(void *ctx, const kf_state *win, size_t at) {
    ply_copy *pc = ctx;
    (void)at; /* the windows come in order */
    if (ply_open(pc, win)) return -1;
    kf_ply_records(&pc->out, pc->m, win);
    return 0;
}

static int ply_from_checkpoint(const char *ck, const char *ply, const kf_model *m, char *err, size_t errlen) {
    kf_checkpoint_info info;
    if (kf_checkpoint_peek(ck, &info, err, errlen)) return -1;
    kf_state *win = kf_state_create(m);
    if (!win) {
        snprintf(err, errlen, "out of memory writing %s", ply);
        return -1;
    }
    ply_copy pc = {m, ply, info.particles, {0}, 0, err, errlen};
    /* (a file without particles has no window: its header after the read) */
    int rc = kf_checkpoint_windows(ck, m, win, ply_window, &pc, err, errlen) || ply_open(&pc, win) ? -1 : 0;
    if (rc && pc.open) {
        kf_atomic_abort(pc.out.af);
        free(pc.out.af);
    } else if (pc.open && kf_ply_end(&pc.out, err, errlen)) rc = -1;
    kf_state_destroy(win);
    return rc;
}

/* the last frame up to `from` with a readable checkpoint made from the same inputs */
static int find_resume(const kf_shot *shot, const char *out, kf_scene *sc, uint64_t hash, int from, int *frame) {
    char err[4200];
    for (int f = from; f >= shot->frame_start; f--) {
        kf_frame_paths rp;
        kf_checkpoint_info info;
        if (kf_frame_paths_make(shot, out, f, &rp) || access(rp.checkpoint, R_OK) != 0) continue;
        if (kf_checkpoint_peek(rp.checkpoint, &info, err, sizeof err)) {
            fprintf(stderr, "kerf: resume: skipping %s\n", err);
            continue;
        }
        if (info.inputs_hash != hash) {
            fprintf(stderr, "kerf: resume: %s was made from different shot settings; not resuming from it\n",
                    rp.checkpoint);
            return -1;
        }
        if (read_checkpoint(rp.checkpoint, sc, &info, err, sizeof err)) {
            fprintf(stderr, "kerf: resume: skipping %s\n", err);
            continue;
        }
        *frame = f;
        return 0;
    }
    return -1;
}

/* A particle PLY is whole when its size is its header plus the records the
 * header counts (30 bytes each, points_ply.c); one cut short is written again. */
static int ply_complete(const char *path) {
    char head[1024];
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    size_t got = fread(head, 1, sizeof head - 1, f);
    head[got] = 0;
    struct stat st;
    int ok = fstat(fileno(f), &st) == 0;
    fclose(f);
    const char *count = strstr(head, "element vertex "), *end = strstr(head, "end_header\n");
    if (!ok || !count || !end) return 0;
    unsigned long long n = strtoull(count + 15, NULL, 10);
    return (unsigned long long)st.st_size == (unsigned long long)(end + 11 - head) + 30 * n;
}

/* Every requested frame has a checkpoint from the same inputs: the cache is
 * current. Missing particle files are rewritten from their checkpoints. Only
 * headers are read, except the last frame's, which is checked whole.
 * *matched: how many frames from the start are cached; *damaged: the frame
 * whose checkpoint exists but cannot be used (said why), else 0. */
static int cache_current(const kf_shot *shot, const char *out, kf_scene *sc, uint64_t hash, int *matched,
                         int *damaged) {
    char err[4200];
    *matched = *damaged = 0;
    for (int f = shot->frame_start; f <= shot->last; f++) {
        kf_frame_paths rp;
        kf_checkpoint_info info;
        if (kf_frame_paths_make(shot, out, f, &rp) || access(rp.checkpoint, F_OK) != 0) return 0;
        if (kf_checkpoint_peek(rp.checkpoint, &info, err, sizeof err)) {
            fprintf(stderr, "kerf: cache: %s\n", err);
            *damaged = f;
            return 0;
        }
        if (info.inputs_hash != hash || info.frame != f) return 0;
        (*matched)++;
    }
    for (int f = shot->first; f <= shot->last; f++) {
        kf_frame_paths rp;
        kf_frame_paths_make(shot, out, f, &rp);
        int need_ply = shot->output_particles && access(rp.particles, R_OK) != 0;
        if (shot->output_particles && !need_ply && !ply_complete(rp.particles)) {
            fprintf(stderr, "kerf: frame %d: %s is damaged (cut short); writing it again from %s\n", f, rp.particles,
                    rp.checkpoint);
            need_ply = 1;
        }
        if (f != shot->last && !need_ply) continue;
        if (kf_checkpoint_read(rp.checkpoint, sc->model, sc->state, NULL, err, sizeof err)) {
            fprintf(stderr, "kerf: cache: %s\n", err);
            *matched = f - shot->frame_start; /* the frames before it stand */
            *damaged = f;
            return 0;
        }
        if (need_ply && (kf_ensure_parent(rp.particles) ||
                         kf_write_points_ply(rp.particles, sc->model, sc->state, err, sizeof err))) {
            fprintf(stderr, "kerf: %s\n", err);
            return -1;
        }
    }
    return 1;
}

/* Frames after this run's range whose checkpoints were made from other
 * inputs (a partial re-run after a physics change) no longer follow from the
 * frames this run writes: remove them and every output made from them, and
 * say so. Frames from the same inputs, and frames without a checkpoint (whose
 * inputs are unknown), are left alone. */
static void remove_stale_after(const kf_shot *shot, const char *out, uint64_t hash) {
    int lo = 0, hi = 0, files = 0;
    for (int f = shot->last + 1; f <= shot->frame_end; f++) {
        kf_frame_paths fp;
        kf_checkpoint_info info;
        char err[4200];
        if (kf_frame_paths_make(shot, out, f, &fp) || access(fp.checkpoint, F_OK) != 0) continue;
        if (kf_checkpoint_peek(fp.checkpoint, &info, err, sizeof err) == 0 && info.inputs_hash == hash) continue;
        const char *paths[] = {fp.checkpoint, fp.particles, fp.surface, fp.image, fp.points, fp.exr};
        for (size_t k = 0; k < sizeof paths / sizeof *paths; k++) files += unlink(paths[k]) == 0;
        if (!lo) lo = f;
        hi = f;
    }
    char which[64];
    if (lo == hi) snprintf(which, sizeof which, "frame %d", lo);
    else snprintf(which, sizeof which, "frames %d-%d", lo, hi);
    if (lo)
        fprintf(stderr,
                "kerf: %s: removed %s (%d files): made from other inputs than this run's, they would not "
                "follow from frame %d\n",
                shot->name, which, files, shot->last);
}

static int write_frame_here(const kf_shot *shot, const char *out, kf_scene *sc, int frame, uint64_t hash);

/* over several ranks, rank 0's window of the whole state (or all of it, gathered) */
static kf_state *whole;

/* Over several ranks a frame's checkpoint and particle file are written by
 * rank 0 a window of particles at a time (kf_dist_stream): no rank holds
 * the whole state. */
typedef struct frame_out {
    const kf_model *m;
    kf_checkpoint_out ck;
    kf_ply_out ply;
    int ck_open, ply_open;
} frame_out;

static int put_window(void *ctx, const kf_state *win, size_t a) {
    frame_out *fo = ctx;
    if (fo->ck_open) kf_checkpoint_window(&fo->ck, win, a);
    if (fo->ply_open) kf_ply_records(&fo->ply, fo->m, win);
    return 0;
}

static int write_frame_streamed(const kf_shot *shot, const char *out, kf_scene *sc, int frame, uint64_t hash) {
    frame_out fo;
    memset(&fo, 0, sizeof fo);
    fo.m = sc->model;
    kf_frame_paths rp;
    char err[4200];
    int rc = 0;
    long n = kf_dist_sum_long(sc->state, (long)kf_state_count(sc->state));
    const int ply = shot->output_particles && frame >= shot->first;
    if (root()) {
        if (kf_frame_paths_make(shot, out, frame, &rp)) {
            fprintf(stderr, "kerf: output path for frame %d is too long\n", frame);
            rc = 1;
        } else if (shot->output_checkpoints && kf_ensure_parent(rp.checkpoint)) {
            fprintf(stderr, "kerf: %s: cannot create directory: %s\n", rp.checkpoint, strerror(errno));
            rc = 1;
        } else if (ply && kf_ensure_parent(rp.particles)) {
            fprintf(stderr, "kerf: %s: cannot create directory: %s\n", rp.particles, strerror(errno));
            rc = 1;
        } else if (shot->output_checkpoints &&
                   kf_checkpoint_begin(&fo.ck, rp.checkpoint, sc->state, (size_t)n, frame, hash, err, sizeof err)) {
            fprintf(stderr, "kerf: %s\n", err);
            rc = 1;
        } else {
            fo.ck_open = shot->output_checkpoints;
            if (ply && kf_ply_begin(&fo.ply, rp.particles, sc->state, (size_t)n, err, sizeof err)) {
                fprintf(stderr, "kerf: %s\n", err);
                rc = 1;
            } else fo.ply_open = ply;
        }
    }
    /* the first frame of a run from the start: the state as seeded, in id order */
    if (kf_dist_stream(sc->state, whole, frame == shot->frame_start, put_window, &fo) && root()) {
        fprintf(stderr, "kerf: frame %d: the ranks' particles did not add up to the whole state\n", frame);
        rc = 1;
    }
    /* the checkpoint last: a frame whose checkpoint exists has its other files */
    if (fo.ply_open && kf_ply_end(&fo.ply, err, sizeof err)) {
        fprintf(stderr, "kerf: %s\n", err);
        rc = 1;
    }
    if (fo.ck_open && kf_checkpoint_end(&fo.ck, sc->state, err, sizeof err)) {
        fprintf(stderr, "kerf: %s\n", err);
        rc = 1;
    }
    return kf_dist_bcast_int(rc);
}

/* write this frame's outputs; returns 0 or prints and returns 1. Over
 * several ranks only when the frame has a file to write: streamed, or for
 * the points output (the pipeline's, which reads a whole state) from the
 * whole state gathered into `whole`, written by rank 0. */
static int write_frame(const kf_shot *shot, const char *out, kf_scene *sc, int frame, uint64_t hash) {
    if (ranks() == 1) return write_frame_here(shot, out, sc, frame, hash);
    const int later = frame >= shot->first;
    if (!shot->output_checkpoints && !(later && (shot->output_points || shot->output_particles))) return 0;
    if (!(later && shot->output_points)) return write_frame_streamed(shot, out, sc, frame, hash);
    int rc = kf_dist_gather(sc->state, whole, frame == shot->frame_start);
    if (root() && rc == 0) {
        kf_scene w = *sc;
        w.state = whole;
        rc = write_frame_here(shot, out, &w, frame, hash);
    }
    return kf_dist_bcast_int(rc);
}

static int write_frame_here(const kf_shot *shot, const char *out, kf_scene *sc, int frame, uint64_t hash) {
    kf_frame_paths rp;
    char err[4200];
    if (kf_frame_paths_make(shot, out, frame, &rp)) {
        fprintf(stderr, "kerf: output path for frame %d is too long\n", frame);
        return 1;
    }
    if (shot->output_checkpoints) {
        if (kf_ensure_parent(rp.checkpoint)) {
            fprintf(stderr, "kerf: %s: cannot create directory: %s\n", rp.checkpoint, strerror(errno));
            return 1;
        }
        if (kf_checkpoint_write(rp.checkpoint, sc->state, frame, hash, err, sizeof err)) {
            fprintf(stderr, "kerf: %s\n", err);
            return 1;
        }
    }
    if (shot->output_points && frame >= shot->first &&
        kf_pipeline_points(shot, sc->model, sc->state, rp.points, frame, err, sizeof err)) {
        fprintf(stderr, "kerf: %s\n", err);
        return 1;
    }
    if (shot->output_particles && frame >= shot->first) {
        if (kf_ensure_parent(rp.particles)) {
            fprintf(stderr, "kerf: %s: cannot create directory: %s\n", rp.particles, strerror(errno));
            return 1;
        }
        if (kf_write_points_ply(rp.particles, sc->model, sc->state, err, sizeof err)) {
            fprintf(stderr, "kerf: %s\n", err);
            return 1;
        }
    }
    return 0;
}

static int run_claimed(const kf_cli_opts *opts, kf_shot *shot, kf_scene *scp);

int kf_cmd_run(int argc, char **argv) {
    kf_cli_opts o;
    int rc = kf_cli_parse("run", argc, argv, &o);
    if (rc) return rc;
    if (o.help) {
        kf_cli_usage(stdout, "run");
        return KF_EXIT_OK;
    }
    /* wedges: the shot once per value, one after another (farm/wedge_run.c) */
    if (o.nwedges) return kf_farm_run_wedges(&o);
    return kf_cli_run(&o);
}

int kf_cli_run(const kf_cli_opts *o) {
    kf_shot *shot;
    kf_scene sc;
    kf_build_stats bs;
    /* the other ranks' words would repeat rank 0's */
    if (!root() && !freopen("/dev/null", "w", stderr)) return KF_EXIT_FAIL;
    kf_cli_opts lo = *o;
    lo.rank_part = ranks() > 1;
    int rc = kf_cli_load(&lo, &shot, &sc, &bs);
    if (!shot) return rc;
    const char *missing = ranks() > 1 ? kf_dist_unsupported(sc.model) : NULL;
    if (missing) {
        fprintf(stderr, "kerf: %s: %s does not run over several MPI ranks yet (%d ranks); run this shot on one rank\n",
                shot->name, missing, ranks());
        kf_scene_free(&sc);
        kf_shot_free(shot);
        return KF_EXIT_USAGE;
    }
    /* one run per output directory, held until this one ends */
    kf_dir_lock lock;
    memset(&lock, 0, sizeof lock);
    rc = root() ? kf_cli_claim_output(o, shot, &lock) : KF_EXIT_OK;
    rc = kf_dist_bcast_int(rc);
    if (rc == KF_EXIT_OK) rc = run_claimed(o, shot, &sc);
    if (root()) kf_dir_lock_release(&lock);
    kf_scene_free(&sc);
    kf_shot_free(shot);
    return rc;
}

/* the first frame of the shot's range whose checkpoint in `out` was made
 * from inputs other than `hash`; 0 when none */
static int other_inputs(const kf_shot *shot, const char *out, uint64_t hash) {
    for (int f = shot->frame_start; f <= shot->frame_end; f++) {
        kf_frame_paths fp;
        kf_checkpoint_info info;
        char err[4200];
        if (kf_frame_paths_make(shot, out, f, &fp) || access(fp.checkpoint, F_OK) != 0) continue;
        if (kf_checkpoint_peek(fp.checkpoint, &info, err, sizeof err) == 0 && info.inputs_hash != hash) return f;
    }
    return 0;
}

/* 1 when --set value `skip` changes the simulation: the shot loaded without
 * it hashes differently (a render or output value does not) */
static int set_moves_sim(const kf_cli_opts *o, int skip, uint64_t hash) {
    const char *sets[128];
    int n = 0;
    for (int i = 0; i < o->nsets; i++)
        if (i != skip) sets[n++] = o->sets[i];
    kf_diag d;
    kf_diag_init(&d);
    kf_shot *s = kf_shot_load(o->shot, sets, n, o->quality, o->frames, &d);
    kf_diag_free(&d);
    int moves = !s || kf_shot_sim_hash(s) != hash;
    if (s) kf_shot_free(s);
    return moves;
}

/* The command-line values a version was simulated with (--quality, and the
 * --set values that change the simulation, sorted, one a line), kept in
 * <dir>/.kerf-values: they tell an experiment from the command line (other
 * values: another version) from the shot's own iteration (the file, a mesh
 * or kerf changed: simulate again, as the cache always has). */
static void values_text(const kf_cli_opts *o, uint64_t hash, char *buf, size_t n) {
    const char *v[130];
    int k = 0, len = 0;
    for (int i = 0; i < o->nsets; i++)
        if (set_moves_sim(o, i, hash)) v[k++] = o->sets[i];
    for (int i = 1; i < k; i++) /* insertion sort: a handful of values */
        for (int j = i; j > 0 && strcmp(v[j - 1], v[j]) > 0; j--) {
            const char *t = v[j];
            v[j] = v[j - 1], v[j - 1] = t;
        }
    buf[0] = 0;
    if (o->quality && strcmp(o->quality, "final"))
        len += snprintf(buf + len, n - (size_t)len, "--quality %s\n", o->quality);
    for (int i = 0; i < k && len < (int)n; i++) len += snprintf(buf + len, n - (size_t)len, "--set %s\n", v[i]);
}

static void values_path(const kf_cli_opts *o, const kf_shot *shot, char *path, size_t n) {
    kf_frame_paths fp;
    if (kf_frame_paths_make(shot, o->out, shot->frame_start, &fp)) path[0] = 0;
    else snprintf(path, n, "%s/.kerf-values", fp.dir);
}

/* the values as one line for a message: "--set a=1 --set b=2", or "none" */
static void values_line(char *text) {
    size_t n = strlen(text);
    while (n && text[n - 1] == '\n') text[--n] = 0;
    for (char *p = text; *p; p++)
        if (*p == '\n') *p = ' ';
    if (!text[0]) strcpy(text, "no --set values");
}

int kf_cli_version_taken(const kf_cli_opts *o, const kf_shot *shot) {
    if (o->force) return 0;
    uint64_t hash = kf_shot_sim_hash(shot);
    int f = other_inputs(shot, o->out, hash);
    if (!f) return 0;
    /* the same values: the shot file, a mesh or kerf changed, and the cache simulates again */
    char path[4200], now[8192], had[8192] = "";
    values_path(o, shot, path, sizeof path);
    values_text(o, hash, now, sizeof now);
    FILE *vf = fopen(path, "r");
    if (vf) {
        had[fread(had, 1, sizeof had - 1, vf)] = 0;
        fclose(vf);
    }
    if (!strcmp(had, now)) return 0;
    kf_frame_paths fp, np;
    kf_frame_paths_make(shot, o->out, f, &fp);
    /* the next version whose directory is another one and holds no other inputs */
    kf_shot *next = malloc(sizeof *next);
    int v = 0;
    if (next) {
        memcpy(next, shot, sizeof *next);
        for (int t = shot->version + 1; t <= 9999 && !v; t++) {
            next->version = t;
            if (kf_frame_paths_make(next, o->out, shot->frame_start, &np) || !strcmp(np.dir, fp.dir)) break;
            if (!other_inputs(next, o->out, hash)) v = t;
        }
        free(next);
    }
    values_line(had);
    values_line(now);
    fprintf(stderr,
            "kerf: %s/ holds %s simulated with other values (%s); this run (%s) would replace it, so "
            "nothing was written\n",
            fp.dir, shot->name, had, now);
    if (v) fprintf(stderr, "kerf: keep both: --set version=%d (the next free version); replace it: --force\n", v);
    else
        fprintf(stderr, "kerf: keep both: another --out DIR (or {version} in it and --set version=N); replace it: "
                        "--force\n");
    return 1;
}

/* write <dir>/.kerf-values for the run about to simulate into <dir> */
static void values_record(const kf_cli_opts *o, const kf_shot *shot, uint64_t hash) {
    char path[4200], now[8192];
    kf_atomic_file af;
    values_path(o, shot, path, sizeof path);
    values_text(o, hash, now, sizeof now);
    if (!path[0] || kf_ensure_parent(path) || kf_atomic_open(&af, path)) return;
    fputs(now, af.f);
    if (kf_atomic_commit(&af)) kf_atomic_abort(&af);
}

/* simulate, then surface and render, in a directory this run holds */
static int run_claimed(const kf_cli_opts *opts, kf_shot *shot, kf_scene *scp) {
    kf_cli_opts o = *opts;
    kf_scene sc = *scp; /* handles: the model and state are the caller's */
    int rc = KF_EXIT_OK;
    uint64_t hash = kf_shot_sim_hash(shot);
    int frame = shot->frame_start;               /* the frame the state is at */
    int resume_from = o.resume ? shot->last : 0; /* the latest frame a resume may start from; 0: none */
    /* a version holds one set of inputs: a run from others does not silently replace it */
    if (kf_cli_version_taken(&o, shot)) return KF_EXIT_USAGE;
    if (root()) values_record(&o, shot, hash);
    if (!o.force && !o.resume) {
        int matched = 0, damaged = 0, c = root() ? cache_current(shot, o.out, &sc, hash, &matched, &damaged) : 0;
        c = kf_dist_bcast_int(c), matched = kf_dist_bcast_int(matched), damaged = kf_dist_bcast_int(damaged);
        if (c != 0 && !root()) return c > 0 ? KF_EXIT_OK : KF_EXIT_FAIL;
        if (c != 0) {
            if (c > 0 && !o.quiet)
                fprintf(stderr,
                        "kerf: %s: frames %d-%d are cached from the same inputs; nothing to simulate "
                        "(--force to simulate anyway)\n",
                        shot->name, shot->first, shot->last);
            /* the later stages still run: their own outputs may be missing or stale */
            if (c > 0 && o.frame_ready)
                for (int f = shot->first; f <= shot->last; f++) o.frame_ready(o.frame_ctx, f);
            if (c > 0 && o.sim_only) return KF_EXIT_OK;
            rc = c > 0 ? kf_cli_post(&o, shot, &sc, 1, 1) : KF_EXIT_FAIL;
            kf_frame_paths cp;
            if (c > 0 && kf_frame_paths_make(shot, o.out, shot->first, &cp) == 0)
                kf_record_progress(cp.dir, shot, rc == KF_EXIT_OK ? "done" : "failed", shot->last, 0, 0, 0);
            return rc;
        }
        if (damaged && matched > 0) {
            /* a damaged checkpoint is made again from the good frames before it, not from the start */
            fprintf(stderr, "kerf: %s: frames %d-%d are cached from the same inputs; simulating again after frame %d\n",
                    shot->name, shot->frame_start, shot->frame_start + matched - 1, shot->frame_start + matched - 1);
            resume_from = shot->frame_start + matched - 1;
        } else if (matched > 1 && !o.quiet)
            fprintf(stderr, "kerf: frames %d-%d are cached from the same inputs; --resume continues after them\n",
                    shot->frame_start, shot->frame_start + matched - 1);
    }
    if (resume_from) {
        if (find_resume(shot, o.out, &sc, hash, resume_from, &frame) == 0) {
            if (!o.quiet) fprintf(stderr, "kerf: resuming after frame %d\n", frame);
            /* a run killed between the frame's checkpoint and its particle file: that file again */
            kf_frame_paths fp;
            char err[4200];
            if (root() && shot->output_particles && frame >= shot->first &&
                kf_frame_paths_make(shot, o.out, frame, &fp) == 0 && !ply_complete(fp.particles)) {
                fprintf(stderr, "kerf: frame %d: %s is missing or cut short; writing it again from %s\n", frame,
                        fp.particles, fp.checkpoint);
                /* over several ranks this rank holds its part only: from the file */
                if (kf_ensure_parent(fp.particles) ||
                    (ranks() > 1 ? ply_from_checkpoint(fp.checkpoint, fp.particles, sc.model, err, sizeof err)
                                 : kf_write_points_ply(fp.particles, sc.model, sc.state, err, sizeof err))) {
                    fprintf(stderr, "kerf: %s\n", err);
                    rc = KF_EXIT_FAIL;
                }
            }
        } else {
            if (!o.quiet) fprintf(stderr, "kerf: nothing to resume; starting at frame %d\n", shot->frame_start);
            frame = shot->frame_start;
        }
    }
    rc = kf_dist_bcast_int(rc);                                 /* rank 0's word on the rewritten particle file */
    const int resumed = frame != shot->frame_start ? frame : 0; /* the frame the simulation continued after */
    /* the frames a resume keeps are ready for the later stages now */
    if (!root()) o.frame_ready = NULL; /* the frame callbacks are rank 0's */
    if (o.frame_ready)
        for (int f = shot->first; f <= frame && resumed; f++) o.frame_ready(o.frame_ctx, f);
    if (frame < shot->last && root()) remove_stale_after(shot, o.out, hash);
    kf_frame_paths rp;
    kf_frame_paths_make(shot, o.out, shot->first, &rp);
    int tty = isatty(fileno(stderr));
    /* over several ranks, whole particle counts are sums over the ranks */
    long count = kf_dist_sum_long(sc.state, (long)kf_state_count(sc.state));
    if (!o.quiet)
        fprintf(stderr, "kerf %s: %s v%03d, %ld particles, dx %.4g m, frames %d-%d at %g fps -> %s/\n", KERF_VERSION,
                shot->name, shot->version, count, shot->sim.dx, shot->first, shot->last, shot->fps, rp.dir);

    /* the records watchers read (kerf view): a run from the first frame starts them afresh */
    if (root()) kf_record_begin(rp.dir, frame == shot->frame_start);
    if (root()) kf_record_progress(rp.dir, shot, "sim", frame, 0, shot->last - frame, -1);

    /* over several ranks: rank 0 gathers the whole state into this for writing */
    if (ranks() > 1 && root() && !(whole = kf_state_create(sc.model))) {
        fprintf(stderr, "kerf: out of memory splitting the state over %d ranks\n", ranks());
        kf_dist_abort(KF_EXIT_FAIL);
    }
    /* the initial state is the first frame's output */
    if (frame == shot->frame_start && write_frame(shot, o.out, &sc, frame, hash)) rc = KF_EXIT_FAIL;
    else if (frame == shot->frame_start && o.frame_ready && frame >= shot->first) o.frame_ready(o.frame_ctx, frame);

    double start = kf_now_ms();
    int todo = shot->last - frame, done = 0;
    while (rc == KF_EXIT_OK && frame < shot->last) {
        kf_step_stats st = {0};
        char msg[1024];
        double t0 = kf_now_ms();
        if (kf_advance(sc.model, sc.state, 1.0 / shot->fps, &st, msg, sizeof msg)) {
            if (tty && !o.quiet) fputc('\n', stderr);
            fprintf(stderr, "kerf: frame %d: %s\n", frame + 1, msg);
            rc = KF_EXIT_FAIL;
            break;
        }
        frame++;
        done++;
        double frame_ms = kf_now_ms() - t0;
        if (write_frame(shot, o.out, &sc, frame, hash)) {
            rc = KF_EXIT_FAIL;
            break;
        }
        if (o.frame_ready && frame >= shot->first) o.frame_ready(o.frame_ctx, frame);
        /* over several ranks: totals, the balance and the traffic for the log, then a re-cut if lopsided */
        kf_dist_stats ds;
        kf_dist_stats_get(sc.state, &ds);
        st.particle_steps = kf_dist_sum_long(sc.state, st.particle_steps);
        kf_dist_stats_reset(sc.state);
        kf_dist_rebalance(sc.state, 1.1);
        double elapsed = (kf_now_ms() - start) / 1e3;
        /* thin boundaries: who is on the wrong side of a body at the frame's end */
        double deep_left = 0;
        long left = kf_model_rigid_count(sc.model) > 0 ? kf_state_thin_audit(sc.model, sc.state, &deep_left) : 0;
        if (ranks() > 1) {
            /* each rank audited its own particles: a count and a maximum, exact in any order */
            left = kf_dist_sum_long(sc.state, left);
            deep_left = kf_dist_max(sc.state, deep_left);
        }
        count = kf_dist_sum_long(sc.state, (long)kf_state_count(sc.state));
        if (root()) kf_record_frame(rp.dir, frame, (size_t)count, &st, frame_ms, left, deep_left);
        if (root()) kf_record_progress(rp.dir, shot, "sim", frame, done, todo, elapsed / done * (todo - done));
        if (o.quiet) continue;
        char eta[32];
        kf_progress_eta(eta, sizeof eta, elapsed / done * (todo - done));
        double mps = (double)st.particle_steps / (frame_ms * 1e3);
        if (tty) {
            /* a live status line on a terminal, the same line surfacing and rendering print */
            char extra[96], line[256];
            snprintf(extra, sizeof extra, "%ld substeps  %.1f M p-steps/s", st.substeps, mps);
            kf_progress_line(line, sizeof line, "simulate", frame, done, todo, extra, elapsed / done * (todo - done));
            fprintf(stderr, "\r%s  ", line);
        } else {
            /* one plain line per frame for farm logs */
            fprintf(stderr,
                    "frame %d: %zu particles, %ld blocks, %ld substeps, max cfl %.2f, %.0f ms (sort %.0f p2g %.0f "
                    "grid %.0f g2p %.0f stress %.0f cdf %.0f rigid %.0f), %.1f M p-steps/s, %d retries, %ld warnings, "
                    "ETA %s\n",
                    frame, (size_t)count, st.active_blocks, st.substeps, st.max_cfl, frame_ms, st.ms[KF_STAGE_SORT],
                    st.ms[KF_STAGE_P2G], st.ms[KF_STAGE_GRID], st.ms[KF_STAGE_G2P], st.ms[KF_STAGE_STRESS],
                    st.ms[KF_STAGE_CDF], st.ms[KF_STAGE_RIGID], mps, st.retries, st.warnings, eta);
            if (ranks() > 1)
                fprintf(stderr,
                        "frame %d: %d ranks: %zu-%zu particles per rank, halo %.0f bytes (%.0f per substep), %.0f "
                        "particles migrated, comm %.0f ms (slowest rank)%s\n",
                        frame, ranks(), ds.particles_min, ds.particles_max, ds.halo_bytes,
                        ds.substeps ? ds.halo_bytes / (double)ds.substeps : 0.0, ds.migrated, ds.comm_ms,
                        ds.rebalances ? ", re-cut" : "");
            /* the labelling of pieces a thin body cut: what it sent, against what it labelled */
            if (ranks() > 1 && ds.pieces_classes > 0)
                fprintf(stderr,
                        "frame %d: pieces: %.0f bytes per substep sent to label %.0f particle classes per substep; "
                        "%ld substeps made pieces\n",
                        frame, ds.substeps ? ds.pieces_bytes / (double)ds.substeps : 0.0,
                        ds.substeps ? ds.pieces_classes / (double)ds.substeps : 0.0, ds.pieces_splits);
            /* implicit integration: how hard the solves worked this frame */
            if (kf_model_sim(sc.model)->integrator == KF_INTEGRATOR_IMPLICIT)
                fprintf(stderr, "frame %d: implicit (%s): %ld Newton, %ld Krylov iterations, last residual %.2g\n",
                        frame,
                        kf_model_sim(sc.model)->implicit_scheme == KF_SCHEME_MIDPOINT ? "midpoint" : "backward Euler",
                        st.newton_iterations, st.krylov_iterations, st.newton_residual);
            /* thin boundaries: crossings the guard caught and undid this frame, and
             * a fixed step an opted-in retry halved */
            if (kf_model_rigid_count(sc.model) > 0) {
                fprintf(stderr,
                        "frame %d: crossings: %ld caught and put back (deepest %.2f cells behind); %ld across at the "
                        "frame's end (deepest %.2f cells)\n",
                        frame, st.thin_caught, st.thin_deepest, left, deep_left);
            }
            /* a fixed step too long for compressed water, packed snow or
             * crushed jelly: those particles were evaluated at the stiffness
             * the step resolves (a local softening), so the artist knows */
            if (st.stiff_limited > 0)
                fprintf(stderr,
                        "frame %d: %ld particles stiffness-limited (stiffer than sim.dt_fixed = %g s resolves; "
                        "evaluated at the stiffness it does, a local softening; a shorter step or the CFL rule "
                        "keeps the full stiffness)\n",
                        frame, st.stiff_limited, kf_model_sim(sc.model)->dt_fixed);
            if (st.fixed_halved > 0)
                fprintf(stderr,
                        "frame %d: retried at a fixed step of %g s (sim.retry_fixed: half of sim.dt_fixed %g s)\n",
                        frame, st.fixed_halved, kf_model_sim(sc.model)->dt_fixed);
            kf_rigid_log_frame(stderr, shot, sc.state); /* where each rigid body is (rigid_log.c) */
        }
        kf_state_joint_peak_reset(sc.state); /* motors' peak torque: per frame */
    }
    if (!o.quiet && tty) fputc('\n', stderr);
    /* what this run simulated: after a resume, only the frames after it */
    if (rc == KF_EXIT_OK && !o.quiet && !resumed)
        fprintf(stderr, "kerf: %s: simulated frames %d-%d in %s/ (%.1f s)\n", shot->name, shot->first, shot->last,
                rp.dir, (kf_now_ms() - start) / 1e3);
    else if (rc == KF_EXIT_OK && !o.quiet && resumed < shot->last) {
        char which[64];
        if (resumed + 1 == shot->last) snprintf(which, sizeof which, "frame %d", shot->last);
        else snprintf(which, sizeof which, "frames %d-%d", resumed + 1, shot->last);
        fprintf(stderr, "kerf: %s: simulated %s (resumed after frame %d) in %s/ (%.1f s)\n", shot->name, which, resumed,
                rp.dir, (kf_now_ms() - start) / 1e3);
    } else if (rc == KF_EXIT_OK && !o.quiet)
        fprintf(stderr, "kerf: %s: nothing left to simulate after frame %d in %s/\n", shot->name, resumed, rp.dir);
    /* simulate → surface → render (on a farm, the array tasks do the last two) */
    /* (over several ranks: rank 0, from the files) */
    if (whole) sc.state = whole;
    if (rc == KF_EXIT_OK && !o.sim_only && root()) rc = kf_cli_post(&o, shot, &sc, 1, 1);
    if (root()) kf_record_progress(rp.dir, shot, rc == KF_EXIT_OK ? "done" : "failed", frame, done, todo, 0);
    if (whole) sc.state = scp->state, kf_state_destroy(whole), whole = NULL;
    return kf_dist_bcast_int(rc);
}
