/* task.c — what the farm's jobs run (`kerf farm task <step> ...`):
 *   sim      kerf run without its later stages; after each frame whose
 *            checkpoint is durably written, the surface task holding it is
 *            released once every frame of its chunk is there
 *   surface  the level sets of --frames A-B
 *   render   the images of --frames A-B
 *   sheet    the wedges' contact sheet
 * Tasks take no lock on the output directory: the farm gives each task its
 * own frames, while the sim (which holds the lock) writes only later ones. */
#include <stdio.h>
#include <string.h>

#include "farm_internal.h"
#include "slurm.h"
#include "../dist/dist.h"

typedef struct release_ctx {
    long job;
    int first, last, chunk;
} release_ctx;

/* the chunk's last frame (or the shot's) is on disk: release its task */
static void release_ready(void *ctx, int frame) {
    const release_ctx *r = ctx;
    int i = frame - r->first;
    if (frame == r->last || (i + 1) % r->chunk == 0) kf_slurm_release(r->job, i / r->chunk * r->chunk);
}

static int task_sim(kf_farm_opts *f) {
    kf_cli_opts o = f->o;
    release_ctx r = {.job = f->release_job, .chunk = f->chunk};
    /* the range the arrays were made for: the sim's --frames */
    kf_diag d;
    kf_diag_init(&d);
    kf_shot *shot = kf_shot_load(o.shot, o.sets, o.nsets, o.quality, o.frames, &d);
    if (kf_dist_rank() == 0) kf_diag_print(stderr, &d); /* once, not once per MPI rank */
    kf_diag_free(&d);
    if (!shot) return KF_EXIT_USAGE;
    r.first = shot->first, r.last = shot->last;
    kf_shot_free(shot);
    o.sim_only = 1;
    if (r.job > 0) o.frame_ready = release_ready, o.frame_ctx = &r;
    return kf_cli_run(&o);
}

static int task_frames(kf_farm_opts *f, int do_surface, int do_render) {
    kf_shot *shot;
    kf_scene sc;
    int rc = kf_cli_load(&f->o, &shot, &sc, NULL);
    if (!shot) return rc;
    rc = kf_cli_post(&f->o, shot, &sc, do_surface, do_render);
    kf_scene_free(&sc);
    kf_shot_free(shot);
    return rc;
}

static int task_sheet(kf_farm_opts *f) {
    static kf_wedge w[KF_WEDGE_MAX];
    int nw;
    kf_shot *shot = kf_farm_load_wedges(&f->o, w, &nw);
    if (!shot) return KF_EXIT_USAGE;
    int rc = kf_contact_sheet(&f->o, shot, w, nw, 6) ? KF_EXIT_FAIL : KF_EXIT_OK;
    if (rc == KF_EXIT_OK) {
        char dir[2048];
        kf_farm_base_dir(&f->o, shot, dir, sizeof dir);
        fprintf(stderr, "kerf farm: contact sheet of %d wedges: %s/contact_sheet.png\n", nw, dir);
    }
    kf_shot_free(shot);
    return rc;
}

int kf_farm_task(const char *step, kf_farm_opts *f) {
    if (!strcmp(step, "sim")) return task_sim(f);
    if (!strcmp(step, "surface")) return task_frames(f, 1, 0);
    if (!strcmp(step, "render")) return task_frames(f, 0, 1);
    if (!strcmp(step, "sheet")) return task_sheet(f);
    fprintf(stderr, "kerf farm task: no step '%s' (sim, surface, render, sheet)\n", step);
    return KF_EXIT_USAGE;
}
