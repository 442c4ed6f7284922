/* budget.c — what a shot will cost, before seeding (see budget.h). */
#include "budget.h"

#include <math.h>
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "../core/real.h"
#include "../mpm/grid.h"
#include "../mpm/material.h"
#include "../mpm/particles.h"
#include "mesh.h"
#include "sample.h"

#define KF_PI 3.14159265358979323846

/* an object's volume as placed, m³: analytic shapes from their sizes and
 * scale, a mesh from its enclosed volume under the sampler's placement */
static double object_volume(const kf_shot_object *o) {
    const double *k = o->place.scale;
    double s = fabs(k[0] * k[1] * k[2]);
    switch (o->shape) {
    case KF_SOURCE_BOX: return o->size[0] * o->size[1] * o->size[2] * s;
    case KF_SOURCE_SPHERE: return 4.0 / 3.0 * KF_PI * o->radius * o->radius * o->radius * s;
    case KF_SOURCE_CYLINDER: return KF_PI * o->radius * o->radius * o->height * s;
    default: break;
    }
    kf_mesh mesh;
    char err[1024];
    if (kf_mesh_load(o->mesh_path, &mesh, err, sizeof err)) return 0;
    kf_sample_def d = kf_default_sample_def();
    d.kind = KF_SOURCE_MESH;
    d.place = o->place;
    double M[12], lo[3], hi[3], v = 0;
    if (kf_sample_placement(&d, &mesh, M, lo, hi, err, sizeof err) == 0) {
        double det = M[0] * (M[5] * M[10] - M[6] * M[9]) - M[1] * (M[4] * M[10] - M[6] * M[8]) +
                     M[2] * (M[4] * M[9] - M[5] * M[8]);
        v = fabs(mesh.volume * det);
    }
    kf_mesh_free(&mesh);
    return v;
}

/* physical memory, or the cgroup's limit when lower (containers, farm slots) */
static double machine_memory(void) {
    double phys = (double)sysconf(_SC_PHYS_PAGES) * (double)sysconf(_SC_PAGE_SIZE);
    FILE *f = fopen("/sys/fs/cgroup/memory.max", "r");
    if (f) {
        double lim;
        if (fscanf(f, "%lf", &lim) == 1 && lim > 0 && lim < phys) phys = lim;
        fclose(f);
    }
    return phys;
}

/* the substep rule at the start (step.c's unit_cfl_dt on the initial state) */
static void substeps(const kf_shot *shot, kf_budget *b) {
    const kf_sim_def *sd = &shot->sim;
    double vmax = 0, c = 0;
    for (int i = 0; i < shot->nobjects; i++) {
        const double *v = shot->objects[i].velocity;
        double s = sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        if (s > vmax) vmax = s;
    }
    b->stiffest = -1;
    if (sd->integrator == KF_INTEGRATOR_IMPLICIT) {
        const double *g = sd->gravity;
        c = sqrt(sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) * sd->dx);
    } else
        for (int i = 0; i < shot->nobjects; i++) {
            int k = shot->objects[i].material;
            kf_mat m;
            kf_mat_compile(&m, &shot->materials[k].mat);
            if (m.wave_speed0 > c) c = m.wave_speed0, b->stiffest = k;
        }
    b->wave_speed = c;
    b->dt = sd->cfl * sd->dx / (c + vmax + 1e-30);
    b->dt_from = 0;
    if (sd->dt_max > 0 && b->dt > sd->dt_max) b->dt = sd->dt_max, b->dt_from = 2;
    if (sd->dt_fixed > 0) b->dt = sd->dt_fixed, b->dt_from = 1;
    b->substeps_per_frame = 1.0 / shot->fps / b->dt;
}

int kf_budget_estimate(const kf_shot *shot, kf_budget *b, char *err, size_t errlen) {
    memset(b, 0, sizeof *b);
    const double dx = shot->sim.dx;
    double largest = 0; /* the largest object's seeding buffers, bytes */
    for (int i = 0; i < shot->nobjects; i++) {
        const kf_shot_object *o = &shot->objects[i];
        double n = object_volume(o) * shot->ppc / (dx * dx * dx);
        b->particles += n;
        /* x in doubles, and v too when the object moves (sample.h) */
        int moves = 0;
        for (int a = 0; a < 3; a++) moves |= o->velocity[a] != 0 || o->angular_velocity[a] != 0;
        double seed = n * (moves ? 6 : 3) * sizeof(double);
        if (seed > largest) largest = seed;
    }
    /* the particles as they run (particles.h: the state, the binning's
     * scratch, CPIC's), the grid blocks they fill (twice the full ones:
     * partial blocks at the surface), and the seeding buffers of the largest
     * object */
    double per =
        kf_particle_bytes_running(shot->nrigids > 0, 0); /* every array counted: the model is not compiled yet */
    double blocks = 2 * b->particles / (KF_BLOCK_NODES * (double)shot->ppc);
    b->bytes = per * b->particles + blocks * KF_BLOCK_NODES * 4 * sizeof(kf_v4) + largest;
    b->memory = machine_memory();
    substeps(shot, b);
    long cores = sysconf(_SC_NPROCESSORS_ONLN);
    b->cores = cores > 0 ? (int)cores : 1;
    if (shot->sim.threads > 0 && shot->sim.threads < b->cores) b->cores = shot->sim.threads;
    double steps = b->substeps_per_frame * (shot->last - shot->frame_start);
    b->hours = b->particles * steps / (KF_BUDGET_RATE_PER_CORE * b->cores) / 3600;
    (void)err, (void)errlen;
    return 0;
}

/* "91.1M", "12.3k", "950", "7.64e+13" */
static void count_text(char *buf, size_t n, double v) {
    if (v >= 1e12) snprintf(buf, n, "%.3g", v);
    else if (v >= 1e9) snprintf(buf, n, "%.3gG", v / 1e9);
    else if (v >= 1e6) snprintf(buf, n, "%.3gM", v / 1e6);
    else if (v >= 1e3) snprintf(buf, n, "%.3gk", v / 1e3);
    else snprintf(buf, n, "%.0f", v);
}

static void bytes_text(char *buf, size_t n, double v) {
    if (v >= 1 << 30) snprintf(buf, n, "%.1f GB", v / (1 << 30));
    else snprintf(buf, n, "%.0f MB", v / (1 << 20));
}

int kf_budget_check(const kf_shot *shot, const kf_budget *b, kf_diag *diag) {
    char parts[32], need[32], have[32], steps[32];
    int errors = 0;
    count_text(parts, sizeof parts, b->particles);
    if (b->bytes > b->memory) {
        bytes_text(need, sizeof need, b->bytes);
        bytes_text(have, sizeof have, b->memory);
        kf_shot_report(diag, &shot->dx_at, KF_DIAG_ERROR,
                       "sim.dx %g m%s gives about %s particles needing about %s, more than this machine's %s "
                       "(a larger dx, or --quality preview: 8x fewer; --force to try anyway)",
                       shot->sim.dx, shot->quality == KF_QUALITY_PREVIEW ? " (doubled for preview)" : "", parts, need,
                       have);
        errors++;
    }
    if (b->substeps_per_frame > KF_BUDGET_SUBSTEPS_PER_FRAME) {
        count_text(steps, sizeof steps, b->substeps_per_frame);
        /* point at the cause: a fixed step, a capped step, a tiny CFL number, else the stiffest material */
        char why[300];
        const kf_loc *at = &shot->cfl_at;
        if (b->dt_from == 1) {
            snprintf(why, sizeof why, "sim.dt_fixed %g s", shot->sim.dt_fixed);
            at = &shot->dt_fixed_at;
        } else if (b->dt_from == 2) {
            snprintf(why, sizeof why, "sim.dt_max %g s", shot->sim.dt_max);
            at = &shot->dt_max_at;
        } else if (shot->sim.cfl >= 0.05 && b->stiffest >= 0) {
            const kf_shot_material *m = &shot->materials[b->stiffest];
            snprintf(why, sizeof why, "dt %.3g s: material %s's wave speed %.3g m/s at sim.cfl %g", b->dt, m->mat.name,
                     b->wave_speed, shot->sim.cfl);
            at = &m->stiffness_at;
        } else snprintf(why, sizeof why, "dt %.3g s from sim.cfl %g", b->dt, shot->sim.cfl);
        kf_shot_report(diag, at, KF_DIAG_ERROR,
                       "about %s substeps per frame (%s), over the budget of %.0f: %d frames of about %s particles "
                       "would take about %.2g hours on %d cores (--force to run anyway)",
                       steps, why, KF_BUDGET_SUBSTEPS_PER_FRAME, shot->last - shot->frame_start + 1, parts, b->hours,
                       b->cores);
        errors++;
    }
    return errors;
}
