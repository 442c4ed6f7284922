/* cmd_stages.c — `kerf surface`, `kerf render`, `kerf turntable`, and the
 * surface → render chain that `kerf run` calls after simulating. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../core/timer.h"
#include "../io/atomic_file.h"
#include "../io/checkpoint.h"
#include "../io/vdb_bridge.h"
#include "cli.h"
#include "../../render/render.h"
#include "../pipeline/exr.h"
#include "../pipeline/progress.h"
#include "../pipeline/stages.h"
#include "run_record.h"

/* The camera frames where the material goes over the whole shot, whichever
 * command renders and whichever frames it renders: the particles of up to
 * 12 checkpoints spread over frames.start..frames.end (those that exist). */
static kf_render_opts framing(const kf_cli_opts *o, const kf_shot *shot, kf_scene *sc) {
    float lo[3] = {1e30f, 1e30f, 1e30f}, hi[3] = {-1e30f, -1e30f, -1e30f};
    const int span = shot->frame_end - shot->frame_start, nsample = span < 11 ? span + 1 : 12;
    char err[4200];
    for (int k = 0; k < nsample; k++) {
        int f = shot->frame_start + (nsample > 1 ? (int)((long)span * k / (nsample - 1)) : 0);
        kf_frame_paths fp;
        if (kf_frame_paths_make(shot, o->out, f, &fp) == 0 && access(fp.checkpoint, R_OK) == 0 &&
            kf_checkpoint_read(fp.checkpoint, sc->model, sc->state, NULL, err, sizeof err) == 0)
            kf_particle_bounds_add(sc, lo, hi);
    }
    return kf_render_opts_for(shot, lo, hi);
}

/* The render settings as text: images made under other settings are stale
 * even when newer than their surfaces. Stored in <dir>/images/.settings. */
static void render_settings(const kf_shot *shot, char *buf, size_t n) {
    int len = snprintf(buf, n, "%d %d %d %d %d %.9g %.9g %.9g %.9g %.9g %.9g %.9g %d s%d a%d", shot->render_width,
                       shot->render_height, shot->render_samples, shot->render_eye_set, shot->render_target_set,
                       shot->render_eye[0], shot->render_eye[1], shot->render_eye[2], shot->render_target[0],
                       shot->render_target[1], shot->render_target[2], shot->render_fov, shot->render_ground,
                       shot->render_shadow, shot->render_antialias);
    /* the camera's keys and the lights */
    for (int i = 0; i < shot->ncamera_keys && len > 0 && (size_t)len < n; i++)
        len += snprintf(buf + len, n - (size_t)len, " k%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%d",
                        shot->camera_keys[i].frame, shot->camera_keys[i].eye[0], shot->camera_keys[i].eye[1],
                        shot->camera_keys[i].eye[2], shot->camera_keys[i].target[0], shot->camera_keys[i].target[1],
                        shot->camera_keys[i].target[2], shot->camera_keys[i].fov, shot->render_interp);
    for (int i = 0; i < 3 && len > 0 && (size_t)len < n; i++)
        len += snprintf(buf + len, n - (size_t)len, " l%.4g,%.4g,%.4g,%.4g,%.4g,%.4g,%.4g", shot->lights[i].dir[0],
                        shot->lights[i].dir[1], shot->lights[i].dir[2], shot->lights[i].color[0],
                        shot->lights[i].color[1], shot->lights[i].color[2], shot->lights[i].intensity);
    /* looks too: a recoloured or reshaded material or collider is a new picture */
    for (int i = 0; i < shot->nmaterials && len > 0 && (size_t)len < n; i++)
        len += snprintf(buf + len, n - (size_t)len, " m%.4g,%.4g,%.4g,%.4g,%.4g", shot->materials[i].color[0],
                        shot->materials[i].color[1], shot->materials[i].color[2], shot->materials[i].specular,
                        shot->materials[i].roughness);
    for (int i = 0; i < shot->ncolliders && len > 0 && (size_t)len < n; i++)
        len += snprintf(buf + len, n - (size_t)len, " c%.4g,%.4g,%.4g,%.4g,%.4g", shot->colliders[i].color[0],
                        shot->colliders[i].color[1], shot->colliders[i].color[2], shot->colliders[i].specular,
                        shot->colliders[i].roughness);
    for (int i = 0; i < shot->nrigids && len > 0 && (size_t)len < n; i++)
        len += snprintf(buf + len, n - (size_t)len, " r%.4g,%.4g,%.4g", shot->rigids[i].color[0],
                        shot->rigids[i].color[1], shot->rigids[i].color[2]);
    /* the files and the shutter, written only when not the defaults so
     * images made before these keys existed stay current */
    if (len > 0 && (size_t)len < n && (shot->render_format != KF_FORMAT_PNG || shot->render_motion_blur > 0))
        len += snprintf(buf + len, n - (size_t)len, " f%d b%.6g", shot->render_format, shot->render_motion_blur);
    if (len > 0 && (size_t)len < n - 1) buf[len] = '\n', buf[len + 1] = 0;
}

static int settings_changed(const char *stamp, const char *now) {
    char old[4096] = "";
    FILE *f = fopen(stamp, "r");
    if (!f) return 1;
    size_t got = fread(old, 1, sizeof old - 1, f);
    old[got] = 0;
    fclose(f);
    return strcmp(old, now) != 0;
}

static void write_stamp(const char *stamp, const char *now) {
    kf_atomic_file af;
    if (kf_ensure_parent(stamp) || kf_atomic_open(&af, stamp)) return;
    fputs(now, af.f);
    if (kf_atomic_commit(&af)) kf_atomic_abort(&af);
}

/* the surface settings as text, for <dir>/surface/.settings */
static void surface_settings(const kf_shot *shot, char *buf, size_t n) {
    snprintf(buf, n, "%.9g %.9g %d %d %.9g %.9g %d %.9g %.9g %d %.9g %d\n", shot->surface_voxel, shot->surface_radius,
             shot->surface_smooth, shot->surface_iterations, shot->surface_dilate, shot->surface_erode,
             shot->surface_group, shot->surface_average, shot->surface_average_radius, shot->surface_kernel,
             shot->surface_reach, shot->surface_flatten);
}

/* A PNG ends with its IEND chunk; one cut short (a full disk under an old
 * kerf, a copy that died) does not, and is made again rather than kept. */
static int png_complete(const char *path) {
    static const unsigned char iend[12] = {0, 0, 0, 0, 'I', 'E', 'N', 'D', 0xAE, 0x42, 0x60, 0x82};
    unsigned char tail[12];
    FILE *f = fopen(path, "rb");
    if (!f) return 0;
    int ok = fseek(f, -12, SEEK_END) == 0 && fread(tail, 1, 12, f) == 12 && memcmp(tail, iend, 12) == 0;
    fclose(f);
    return ok;
}

/* the image files render.format asks for exist, are newer than the surface and whole */
static int images_current(const kf_shot *shot, const kf_frame_paths *fp) {
    if (shot->render_format != KF_FORMAT_EXR &&
        (!kf_output_current(fp->image, fp->surface) || !png_complete(fp->image)))
        return 0;
    if (shot->render_format != KF_FORMAT_PNG && (!kf_output_current(fp->exr, fp->surface) || !kf_exr_complete(fp->exr)))
        return 0;
    return 1;
}

int kf_cli_frame_current(const kf_cli_opts *o, const kf_shot *shot, int f) {
    kf_frame_paths fp, first;
    kf_checkpoint_info info;
    char err[4200], now[4096], stamp[2200];
    if (kf_frame_paths_make(shot, o->out, f, &fp) || kf_frame_paths_make(shot, o->out, shot->first, &first)) return 0;
    if (kf_checkpoint_peek(fp.checkpoint, &info, err, sizeof err) || info.inputs_hash != kf_shot_sim_hash(shot) ||
        info.frame != f)
        return 0;
    if (shot->output_surface) {
        surface_settings(shot, now, sizeof now);
        snprintf(stamp, sizeof stamp, "%s/surface/.settings", first.dir);
        if (settings_changed(stamp, now) || !kf_output_current(fp.surface, fp.checkpoint)) return 0;
    }
    if (shot->output_images) {
        render_settings(shot, now, sizeof now);
        snprintf(stamp, sizeof stamp, "%s/images/.settings", first.dir);
        if (settings_changed(stamp, now) || !images_current(shot, &fp)) return 0;
    }
    return 1;
}

/* surface frame f again (its .vdb was missing, stale or damaged); 0 or prints and returns 1 */
static int surface_frame(const kf_shot *shot, kf_scene *sc, const kf_frame_paths *fp, int f, double *ms) {
    char err[4200];
    double t0 = kf_now_ms();
    if (kf_pipeline_surface(shot, sc, fp, f, err, sizeof err)) {
        fprintf(stderr, "kerf: frame %d: surface: %s\n", f, err);
        return 1;
    }
    *ms += kf_now_ms() - t0;
    return 0;
}

/* Render frame f. A surface that cannot be read (damaged on disk) is made
 * again from its checkpoint and the render tried once more: a damaged output
 * is rebuilt, not fatal. 0, or prints and returns 1. */
static int render_frame(const kf_shot *shot, kf_scene *sc, const kf_frame_paths *fp, int f, const kf_render_opts *ro,
                        double *ms_s, double *ms_r, int *made_s) {
    char err[4200], why[4200];
    double t0 = kf_now_ms();
    if (kf_pipeline_render(shot, sc, fp->surface, fp->image, f, ro, err, sizeof err) == 0) {
        *ms_r += kf_now_ms() - t0;
        return 0;
    }
    kf_vdb_file_info info;
    int damaged = kf_vdb_info(fp->surface, &info, why, sizeof why) != 0 || strncmp(err, "vdb: ", 5) == 0;
    if (!damaged || access(fp->checkpoint, R_OK) != 0) {
        fprintf(stderr, "kerf: frame %d: render: %s\n", f, err);
        return 1;
    }
    fprintf(stderr, "kerf: frame %d: %s is damaged (%s); surfacing it again from %s\n", f, fp->surface, err,
            fp->checkpoint);
    if (surface_frame(shot, sc, fp, f, ms_s)) return 1;
    (*made_s)++;
    t0 = kf_now_ms();
    if (kf_pipeline_render(shot, sc, fp->surface, fp->image, f, ro, err, sizeof err)) {
        fprintf(stderr, "kerf: frame %d: render: %s\n", f, err);
        return 1;
    }
    *ms_r += kf_now_ms() - t0;
    return 0;
}

/* kf_cli_post's frames, rendered through the context kept in *keep */
static int post_frames(const kf_cli_opts *o, const kf_shot *shot, kf_scene *sc, int do_surface, int do_render,
                       kf_render_ctx **keep) {
    do_surface &= shot->output_surface;
    do_render &= shot->output_images;
    /* the camera only for rendering: it reads whole checkpoints */
    kf_render_opts ro;
    memset(&ro, 0, sizeof ro);
    if (do_render) ro = framing(o, shot, sc);
    ro.keep = keep;
    char settings[4096], stamp[2200];
    kf_frame_paths first;
    kf_frame_paths_make(shot, o->out, shot->first, &first);
    render_settings(shot, settings, sizeof settings);
    snprintf(stamp, sizeof stamp, "%s/images/.settings", first.dir);
    int rerender = do_render && settings_changed(stamp, settings);
    char ssettings[512], sstamp[2200];
    surface_settings(shot, ssettings, sizeof ssettings);
    snprintf(sstamp, sizeof sstamp, "%s/surface/.settings", first.dir);
    int resurface = do_surface && settings_changed(sstamp, ssettings);
    int made_s = 0, made_r = 0, kept = 0, tty = isatty(fileno(stderr));
    double t_s = 0, t_r = 0;
    for (int f = shot->first; f <= shot->last; f++) {
        kf_frame_paths fp;
        if (kf_frame_paths_make(shot, o->out, f, &fp)) {
            fprintf(stderr, "kerf: output path for frame %d is too long\n", f);
            return KF_EXIT_FAIL;
        }
        if (do_surface) {
            if (access(fp.checkpoint, R_OK) != 0) {
                fprintf(stderr, "kerf: frame %d has no checkpoint (%s): simulate it first (kerf run)\n", f,
                        fp.checkpoint);
                return KF_EXIT_FAIL;
            }
            int current = kf_output_current(fp.surface, fp.checkpoint);
            char why[4200];
            kf_vdb_file_info info;
            if (current && !o->force && !resurface && kf_vdb_info(fp.surface, &info, why, sizeof why)) {
                fprintf(stderr, "kerf: frame %d: %s is damaged (%s); surfacing it again from %s\n", f, fp.surface, why,
                        fp.checkpoint);
                current = 0;
            }
            if (o->force || resurface || !current) {
                if (surface_frame(shot, sc, &fp, f, &t_s)) return KF_EXIT_FAIL;
                made_s++;
            } else kept++;
        }
        if (do_render) {
            if (access(fp.surface, R_OK) != 0) {
                fprintf(stderr, "kerf: frame %d has no surface (%s): run kerf surface first\n", f, fp.surface);
                return KF_EXIT_FAIL;
            }
            int current = images_current(shot, &fp);
            /* a file newer than its surface yet not whole was cut short */
            const char *cut = NULL;
            if (shot->render_format != KF_FORMAT_EXR && kf_output_current(fp.image, fp.surface) &&
                !png_complete(fp.image))
                cut = fp.image;
            else if (shot->render_format != KF_FORMAT_PNG && kf_output_current(fp.exr, fp.surface) &&
                     !kf_exr_complete(fp.exr))
                cut = fp.exr;
            if (cut) fprintf(stderr, "kerf: frame %d: %s is damaged (cut short); rendering it again\n", f, cut);
            if (o->force || rerender || !current) {
                if (render_frame(shot, sc, &fp, f, &ro, &t_s, &t_r, &made_s)) return KF_EXIT_FAIL;
                made_r++;
            } else kept++;
        }
        /* where the run stands, for watchers and on the terminal: frames surfaced
         * and rendered so far, and the time left at the average cost of a frame
         * made so far (kept frames cost nothing) */
        int done = f - shot->first + 1, todo = shot->last - shot->first + 1;
        double ms_s = made_s ? t_s / made_s : 0, ms_r = made_r ? t_r / made_r : 0;
        double eta = (ms_s + ms_r) / 1e3 * (shot->last - f);
        if (made_s || made_r) kf_record_progress(first.dir, shot, do_render ? "render" : "surface", f, done, todo, eta);
        if (!o->quiet && (made_s || made_r)) {
            char extra[96], line[256];
            snprintf(extra, sizeof extra, "surface %.0f ms, render %.0f ms a frame", ms_s, ms_r);
            kf_progress_line(line, sizeof line, do_render ? "render" : "surface", f, done, todo, extra, eta);
            /* a live line on a terminal, one line per frame for farm logs */
            if (tty) fprintf(stderr, "\r%s  ", line);
            else fprintf(stderr, "%s\n", line);
        }
    }
    if (tty && !o->quiet && (made_s || made_r)) fputc('\n', stderr);
    if (do_render) write_stamp(stamp, settings);
    if (do_surface) write_stamp(sstamp, ssettings);
    if (!o->quiet) {
        kf_frame_paths fp;
        kf_frame_paths_make(shot, o->out, shot->first, &fp);
        fprintf(stderr, "kerf: %s: %d surfaces, %d images made, %d current outputs kept; images in %s/images/\n",
                shot->name, made_s, made_r, kept, fp.dir);
    }
    return KF_EXIT_OK;
}

/* surface and render frames first..last, skipping current outputs; one
 * render context for all the frames */
int kf_cli_post(const kf_cli_opts *o, const kf_shot *shot, kf_scene *sc, int do_surface, int do_render) {
    kf_render_ctx *kept = NULL;
    int rc = post_frames(o, shot, sc, do_surface, do_render, &kept);
    kf_render_destroy(kept);
    return rc;
}

static int stage_command(const char *cmd, int argc, char **argv, int do_surface, int do_render) {
    kf_cli_opts o;
    kf_shot *shot;
    kf_scene sc;
    int rc = kf_cli_start(cmd, argc, argv, &o, &shot, &sc, NULL);
    if (!shot) return rc;
    kf_dir_lock lock; /* one run per output directory */
    rc = kf_cli_claim_output(&o, shot, &lock);
    if (rc == KF_EXIT_OK) rc = kf_cli_post(&o, shot, &sc, do_surface, do_render);
    kf_dir_lock_release(&lock);
    kf_scene_free(&sc);
    kf_shot_free(shot);
    return rc;
}

int kf_cmd_surface(int argc, char **argv) { return stage_command("surface", argc, argv, 1, 0); }
int kf_cmd_render(int argc, char **argv) { return stage_command("render", argc, argv, 0, 1); }

/* the first turntable view's number: the convention for a shot's first frame */
#define KF_TURNTABLE_FIRST 1001

/* kerf turntable shot.yaml --frame N --frames K: K views orbiting 360° around
 * frame N's surface, end exclusive, so the sequence loops */
int kf_cmd_turntable(int argc, char **argv) {
    int frame = 0, count = 120;
    char **rest = malloc(sizeof(char *) * (size_t)(argc + 1));
    int nrest = 0;
    for (int i = 0; i < argc; i++) {
        int is_frame = !strcmp(argv[i], "--frame"), is_count = !strcmp(argv[i], "--frames");
        if ((is_frame || is_count) && i + 1 < argc) {
            char *end;
            long v = strtol(argv[i + 1], &end, 10);
            if (*end || v < (is_count ? 1 : -1000000000L) || v > 1000000000L) {
                fprintf(stderr, "kerf turntable: %s wants an integer, got '%s'\n", argv[i], argv[i + 1]);
                free(rest);
                return KF_EXIT_USAGE;
            }
            if (is_frame) frame = (int)v;
            else count = (int)v;
            i++;
        } else rest[nrest++] = argv[i];
    }
    kf_cli_opts o;
    kf_shot *shot;
    kf_scene sc;
    int rc = kf_cli_start("turntable", nrest, rest, &o, &shot, &sc, NULL);
    free(rest);
    if (!shot) return rc;
    if (frame == 0) frame = shot->frame_start;
    kf_frame_paths fp;
    char err[4200];
    kf_dir_lock lock = {.fd = -1};
    if (frame < shot->frame_start || frame > shot->frame_end) {
        fprintf(stderr, "kerf turntable: --frame %d is outside the shot's frames %d-%d\n", frame, shot->frame_start,
                shot->frame_end);
        rc = KF_EXIT_USAGE;
    } else if (kf_frame_paths_make(shot, o.out, frame, &fp) || access(fp.surface, R_OK) != 0) {
        fprintf(stderr, "kerf turntable: frame %d has no surface yet: run kerf run (or kerf surface) first\n", frame);
        rc = KF_EXIT_FAIL;
    } else if ((rc = kf_cli_claim_output(&o, shot, &lock)) == KF_EXIT_OK) {
        kf_render_opts ro = framing(&o, shot, &sc);
        kf_render_ctx *kept = NULL;
        ro.turntable_n = count;
        ro.keep = &kept;
        for (int k = 0; k < count && rc == KF_EXIT_OK; k++) {
            char png[4200];
            /* views are numbered like shot frames, from 1001, so compositing and
             * playback tools take the sequence as they take a shot's */
            snprintf(png, sizeof png, "%s/turntable/%s.f%d.%04d.png", fp.dir, shot->name, frame,
                     KF_TURNTABLE_FIRST + k);
            ro.turntable_k = k;
            if (kf_pipeline_render(shot, &sc, fp.surface, png, frame, &ro, err, sizeof err)) {
                fprintf(stderr, "kerf turntable: %s\n", err);
                rc = KF_EXIT_FAIL;
            }
        }
        kf_render_destroy(kept);
        if (rc == KF_EXIT_OK && !o.quiet)
            fprintf(stderr, "kerf: turntable of frame %d: %d views in %s/turntable/\n", frame, count, fp.dir);
    }
    kf_dir_lock_release(&lock);
    kf_scene_free(&sc);
    kf_shot_free(shot);
    return rc;
}
