/* cmd_check.c — `kerf check` (validate only) and `kerf info` (what the shot
 * compiles to: particles, grid, materials, memory, substeps per frame). */
#include <stdio.h>
#include <string.h>
#include <unistd.h>

#include "../mpm/model.h"
#include "../scene/budget.h"
#include "cli.h"
#include "rigid_log.h"

int kf_cmd_check(int argc, char **argv) {
    kf_cli_opts o;
    kf_shot *shot;
    kf_scene sc;
    int rc = kf_cli_start("check", argc, argv, &o, &shot, &sc, NULL);
    if (!shot) return rc;
    printf("%s: ok (%s, %zu particles, frames %d-%d)\n", o.shot, shot->name, kf_state_count(sc.state), shot->first,
           shot->last);
    kf_scene_free(&sc);
    kf_shot_free(shot);
    return KF_EXIT_OK;
}

static const char *model_name(kf_material_model m) {
    static const char *names[] = {"fixed corotated", "weakly compressible water", "Hencky + von Mises",
                                  "Hencky + Drucker-Prager", "snow (Stomakhin 2013)"};
    return m < KF_MAT_MODEL_COUNT ? names[m] : "?";
}

/* this process's resident bytes now (0 if unknown): kerf itself, before a shot is built */
static double resident_bytes(void) {
    FILE *f = fopen("/proc/self/statm", "r");
    unsigned long size = 0, resident = 0;
    int ok = f && fscanf(f, "%lu %lu", &size, &resident) == 2;
    if (f) fclose(f);
    long page = sysconf(_SC_PAGESIZE);
    return ok && page > 0 ? (double)resident * (double)page : 0;
}

int kf_cmd_info(int argc, char **argv) {
    const double program = resident_bytes();
    kf_cli_opts o;
    kf_shot *shot;
    kf_scene sc;
    kf_build_stats bs;
    int rc = kf_cli_start("info", argc, argv, &o, &shot, &sc, &bs);
    if (!shot) return rc;
    const kf_model *m = sc.model;
    kf_state *s = sc.state;
    size_t n = kf_state_count(s);

    printf("shot      %s v%03d (%s)\n", shot->name, shot->version, shot->path);
    printf("frames    %d-%d of %d-%d at %g fps, quality %s\n", shot->first, shot->last, shot->frame_start,
           shot->frame_end, shot->fps, shot->quality == KF_QUALITY_PREVIEW ? "preview" : "final");
    char transfer[32];
    if (shot->sim.transfer == KF_TRANSFER_FLIP) snprintf(transfer, sizeof transfer, "FLIP %g", shot->sim.flip_ratio);
    else
        snprintf(transfer, sizeof transfer, "%s",
                 shot->sim.transfer == KF_TRANSFER_PIC       ? "PIC"
                 : shot->sim.transfer == KF_TRANSFER_POLYPIC ? "PolyPIC"
                                                             : "APIC");
    printf("grid      dx %.5g m, %s kernel, %s force, %s, cfl %g, %s\n", shot->sim.dx,
           shot->sim.kernel == KF_KERNEL_CUBIC ? "cubic" : "quadratic",
           shot->sim.force == KF_FORCE_CLASSIC ? "classic" : "MLS", transfer, shot->sim.cfl,
           shot->sim.walls ? "walls on" : "no walls");
    /* (a shot carries every solver setting: the keys' defaults fill what it leaves out) */
    const kf_sim_def *sd = &shot->sim;
    if (sd->integrator == KF_INTEGRATOR_IMPLICIT)
        printf("time      implicit, %s; substeps by advection alone; Newton tol %g (at most %d), CG tol %g (at most "
               "%d), %s preconditioner\n",
               sd->implicit_scheme == KF_SCHEME_MIDPOINT ? "midpoint" : "backward Euler", sd->newton_tol,
               sd->newton_max, sd->krylov_tol, sd->krylov_max,
               sd->precond == KF_PRECOND_JACOBI ? "Jacobi" : "multigrid");
    else printf("time      explicit (symplectic Euler); substeps by the elastic wave speed and advection\n");
    printf("particles %zu (%d per cell), seeded in %.2f s\n", n, shot->ppc, bs.seconds);
    for (int i = 0; i < shot->nobjects && i < 256; i++)
        printf("  %-16s %10zu  %s\n", shot->objects[i].name, bs.particles_per_object[i],
               shot->materials[shot->objects[i].material].mat.name);
    printf("materials\n");
    for (int i = 0; i < m->nmat; i++) {
        const kf_material *d = &m->mat_def[i];
        printf("  %-16s %-26s E %-9.4g nu %-5.3g rho %-7.4g c_p %.3g m/s\n", d->name, model_name(d->model), d->E, d->nu,
               d->density, m->mat[i].wave_speed0);
    }
    if (shot->ncolliders) printf("colliders %d\n", shot->ncolliders);
    kf_rigid_log_info(stdout, shot, m); /* bodies, seeds, masses, joints (rigid_log.c) */

    /* the grid as the first substep will build it, and the substep the CFL rule picks now */
    size_t bad;
    int cubic = shot->sim.kernel == KF_KERNEL_CUBIC;
    long blocks = 0;
    if (n && kf_grid_bin(&s->g, &s->p, (kf_real)(1 / shot->sim.dx), cubic, m->nthreads, &bad) == 0)
        blocks = (long)s->g.nblocks;
    double dt = n ? kf_stable_dt(m, s, shot->sim.cfl) : 0;
    double mb = kf_memory_estimate(m, s, blocks, program) / (1 << 20);
    printf("grid      %ld active blocks of 4^3 nodes at the start\n", blocks);
    printf("memory    about %.0f MB (particles, grid, rigid seeds, kerf itself %.0f MB; a frame's start for retries is "
           "kept in "
           "a temporary file, %.0f MB)\n",
           mb, program / (1 << 20), kf_snapshot_bytes(n) / (1 << 20));
    if (shot->sim.dt_fixed > 0) /* a fixed step is the step, whatever the CFL rule says */
        printf("substeps  %.0f per frame (sim.dt_fixed %.3g s)\n", 1.0 / shot->fps / shot->sim.dt_fixed,
               shot->sim.dt_fixed);
    else if (dt > 0)
        printf("substeps  about %.0f per frame at the start (dt %.3g s; more once things move)\n", 1.0 / shot->fps / dt,
               dt);
    /* what the budget guard estimated before seeding (scene/budget.h) */
    kf_budget b;
    char err[256];
    if (kf_budget_estimate(shot, &b, err, sizeof err) == 0)
        printf("estimate  before seeding: about %.0f particles, %.0f MB, %.0f substeps per frame, %.2g hours for "
               "frames %d-%d on %d cores\n",
               b.particles, b.bytes / (1 << 20), b.substeps_per_frame, b.hours, shot->first, shot->last, b.cores);
    kf_scene_free(&sc);
    kf_shot_free(shot);
    return KF_EXIT_OK;
}
