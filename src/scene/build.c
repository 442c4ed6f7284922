/* build.c — shot → model + state (see build.h). */
#include "build.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../core/fnv.h"
#include "../core/timer.h"
#include "../dist/dist.h"
#include "../mpm/model.h"
#include "build_rigid.h"
#include "mesh_isect.h"
#include "mesh_sdf.h"
#include "sample.h"

/* A mesh collider's distance grid: the mesh placed like an object, checked
 * closed and not passing through itself (in the file's coordinates), sampled
 * at spacing dx/2 (padded by 3 dx) in the frame centred on the pivot. */
static int mesh_collider(const kf_shot_collider *c, double dx, int threads, kf_mesh_sdf *sdf, char *err, size_t n) {
    kf_mesh mesh;
    if (kf_mesh_load(c->mesh_path, &mesh, err, n)) return -1;
    int rc = kf_mesh_check_closed(&mesh, err, n);
    if (rc == 0) rc = kf_mesh_check_self_intersection(&mesh, threads, err, n);
    if (rc == 0) {
        kf_sample_def d = kf_default_sample_def();
        d.kind = KF_SOURCE_MESH;
        d.place = c->place;
        double M[12], lo[3], hi[3];
        rc = kf_sample_placement(&d, &mesh, M, lo, hi, err, n);
        if (rc == 0) {
            kf_mesh_transform(&mesh, M);
            kf_mesh_sdf_def sd = kf_default_mesh_sdf_def();
            sd.spacing = 0.5 * dx;
            sd.pad = 3 * dx;
            sd.threads = threads;
            rc = kf_mesh_sdf_build(&mesh, c->col.center, &sd, sdf, err, n);
        }
    }
    kf_mesh_free(&mesh);
    return rc;
}

/* an object's mesh as kf_sample_shape checks it: it loads, it is closed and
 * it does not pass through itself. Returns 0, or -1 with the message. */
static int object_mesh_check(const char *path, int threads, char *err, size_t n) {
    kf_mesh mesh;
    if (kf_mesh_load(path, &mesh, err, n)) return -1;
    int rc = kf_mesh_check_closed(&mesh, err, n);
    if (rc == 0) rc = kf_mesh_check_self_intersection(&mesh, threads, err, n);
    kf_mesh_free(&mesh);
    return rc;
}

/* the seeded particles outside the domain */
static size_t count_outside(const kf_sim_def *sd, const kf_points *pts) {
    const double *lo = sd->domain_min, *hi = sd->domain_max;
    size_t out = 0;
    for (size_t k = 0; k < pts->n; k++) {
        const double *x = &pts->x[3 * k];
        int in = 1;
        for (int a = 0; a < 3; a++) in &= x[a] >= lo[a] && x[a] <= hi[a];
        out += !in;
    }
    return out;
}

/* An object wholly outside the domain (its placed bounding box misses the
 * box) is a mistake: an error at its entry. One partly outside is allowed
 * (material may start against a wall's far side), with a warning counting
 * its `out` particles out there. Returns -1 on the error. */
static int check_in_domain(const kf_shot_object *o, const kf_sim_def *sd, const kf_points *pts, size_t out,
                           kf_diag *diag) {
    const double *lo = sd->domain_min, *hi = sd->domain_max;
    int misses = 0;
    for (int a = 0; a < 3; a++) misses |= pts->hi[a] < lo[a] || pts->lo[a] > hi[a];
    if (misses) {
        kf_shot_report(diag, &o->at, KF_DIAG_ERROR,
                       "object '%s' lies entirely outside the domain [%g, %g, %g]-[%g, %g, %g]: it spans "
                       "[%.3g, %.3g, %.3g]-[%.3g, %.3g, %.3g]",
                       o->name, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2], pts->lo[0], pts->lo[1], pts->lo[2],
                       pts->hi[0], pts->hi[1], pts->hi[2]);
        return -1;
    }
    if (out)
        kf_shot_report(diag, &o->at, KF_DIAG_WARNING,
                       "object '%s': %zu of its %zu particles start outside the domain "
                       "[%g, %g, %g]-[%g, %g, %g]",
                       o->name, out, pts->whole, lo[0], lo[1], lo[2], hi[0], hi[1], hi[2]);
    return 0;
}

/* Over MPI ranks, what the sampler keeps of an object: in the first pass
 * nothing (every point counted per block, and those outside the domain),
 * in the second this rank's points, with their index in the whole object. */
typedef struct part_sink {
    kf_dist_seed *seed;
    int pass;
    const kf_sim_def *sd;
    size_t seen, outside;
    uint32_t *index;
    size_t n, cap;
    int failed; /* out of memory */
} part_sink;

static int part_keep(void *ctx, const double x[3]) {
    part_sink *ps = ctx;
    size_t i = ps->seen++;
    if (ps->pass == 0) {
        int in = 1;
        for (int a = 0; a < 3; a++) in &= x[a] >= ps->sd->domain_min[a] && x[a] <= ps->sd->domain_max[a];
        ps->outside += !in;
        if (kf_dist_seed_count(ps->seed, x, 1)) ps->failed = 1;
        return 0;
    }
    if (!kf_dist_seed_owns(ps->seed, x)) return 0;
    if (ps->n == ps->cap) {
        size_t c = ps->cap ? 2 * ps->cap : 4096;
        uint32_t *q = realloc(ps->index, c * sizeof *q);
        if (!q) return ps->failed = 1, 0;
        ps->index = q, ps->cap = c;
    }
    ps->index[ps->n++] = (uint32_t)i;
    return 1;
}

/* Where one rank holds the whole scene, an object's points go into the
 * state as the sampler makes them, a chunk at a time (the same order, ids
 * and values as all at once), so its candidates in doubles (24 bytes a
 * particle, 48 with velocities) never sit beside the whole state. */
typedef struct state_sink {
    kf_scene *sc;
    const kf_shot_object *o;
    const kf_sim_def *sd;
    size_t outside; /* particles outside the domain */
    int reserved;
} state_sink;

static int state_emit(void *ctx, const double *x, const double *v, size_t n, double volume, size_t most) {
    state_sink *t = ctx;
    /* room for the whole shape at once: untouched beyond what is written */
    if (!t->reserved && kf_particles_reserve(&t->sc->state->p, t->sc->state->p.n + most)) return -1;
    t->reserved = 1;
    const double *lo = t->sd->domain_min, *hi = t->sd->domain_max;
    for (size_t k = 0; k < n; k++) {
        int in = 1;
        for (int a = 0; a < 3; a++) in &= x[3 * k + a] >= lo[a] && x[3 * k + a] <= hi[a];
        t->outside += !in;
    }
    long first = kf_state_add_particles(t->sc->state, t->sc->model, n, x, v, NULL, t->o->material, volume);
    if (first < 0) return -1;
    /* the object each particle belongs to (see add_object) */
    kf_particles *p = &t->sc->state->p;
    if (t->o->field) p->zero &= ~KF_ZERO_OBJ;
    for (size_t k = 0; k < n && !(p->zero & KF_ZERO_OBJ); k++) p->obj[(size_t)first + k] = (uint16_t)t->o->field;
    return 0;
}

/* object i sampled (build.h's lattice, so the same on every call); with
 * ps, through it; with ss, straight into the state */
static int sample_object(const kf_shot *shot, int i, const kf_sim_def *sd, part_sink *ps, state_sink *ss,
                         kf_points *pts, char *err, size_t n) {
    const kf_shot_object *o = &shot->objects[i];
    kf_sample_def d = kf_default_sample_def();
    d.kind = o->shape;
    memcpy(d.size, o->size, sizeof d.size);
    d.radius = o->radius;
    d.height = o->height;
    d.mesh_path = o->shape == KF_SOURCE_MESH ? o->mesh_path : NULL;
    d.place = o->place;
    d.dx = sd->dx;
    d.ppc = shot->ppc;
    d.seed = shot->jitter ? shot->seed + (uint32_t)i : 0;
    memcpy(d.velocity, o->velocity, sizeof d.velocity);
    memcpy(d.angular_velocity, o->angular_velocity, sizeof d.angular_velocity);
    d.threads = sd->threads;
    if (ps) d.keep = part_keep, d.keep_ctx = ps;
    if (ss && !ps && kf_sample_can_emit(&d)) d.emit = state_emit, d.emit_ctx = ss;
    int rc = kf_sample_shape(&d, pts, err, n);
    if (rc == 0 && ps && ps->failed) {
        kf_points_free(pts);
        snprintf(err, n, "out of memory splitting it over MPI ranks");
        return -1;
    }
    return rc;
}

/* An object's particles added to the state; with index (this rank's part),
 * each with the id a whole build gives it: base + its index in the object.
 * Returns 0 or -1 (out of memory). */
static int add_object(kf_scene *sc, const kf_shot_object *o, const kf_points *pts, const uint32_t *index,
                      uint32_t base) {
    long first = kf_state_add_particles(sc->state, sc->model, pts->n, pts->x, pts->v, NULL, o->material, pts->volume);
    if (first < 0) return -1;
    /* remember the object each particle belongs to (contact, surface.group:
     * object): its own, or the one it is bonded to. Written in place, not
     * through a writable view, which would make every array the model never
     * writes (model.h: kf_model_zero_arrays) a plain one until the first
     * interval, so a binning before it would touch their pages */
    kf_particles *p = &sc->state->p;
    if (o->field) p->zero &= ~KF_ZERO_OBJ; /* obj holds zeros until here */
    for (size_t k = 0; k < pts->n && !(p->zero & KF_ZERO_OBJ); k++) p->obj[(size_t)first + k] = (uint16_t)o->field;
    for (size_t k = 0; k < pts->n && index; k++) p->id[(size_t)first + k] = base + index[k];
    return 0;
}

int kf_scene_from_shot(const kf_shot *shot, int threads, kf_scene *sc, kf_build_stats *stats, kf_diag *diag) {
    return kf_scene_from_shot_part(shot, threads, 0, sc, stats, diag);
}

int kf_scene_from_shot_part(const kf_shot *shot, int threads, int part, kf_scene *sc, kf_build_stats *stats,
                            kf_diag *diag) {
    char err[1024];
    double t0 = kf_now_ms();
    memset(sc, 0, sizeof *sc);
    if (stats) memset(stats, 0, sizeof *stats);
    kf_sim_def sd = shot->sim;
    if (threads > 0) sd.threads = threads;
    sc->name = shot->name;
    sc->fps = shot->fps;
    sc->frames = shot->frame_end - shot->frame_start + 1;
    sc->model = kf_model_create(&sd, err, sizeof err);
    if (!sc->model) {
        kf_shot_report(diag, NULL, KF_DIAG_ERROR, "sim: %s", err);
        return -1;
    }
    int bad = 0;
    for (int i = 0; i < shot->nmaterials; i++)
        if (kf_model_add_material(sc->model, &shot->materials[i].mat, err, sizeof err) != i) {
            kf_shot_report(diag, &shot->materials[i].at, KF_DIAG_ERROR, "%s", err);
            bad = 1;
        }
    for (int i = 0; i < shot->ncolliders; i++) {
        const kf_shot_collider *c = &shot->colliders[i];
        kf_collider col = c->col;
        kf_mesh_sdf sdf = {0};
        if (col.shape == KF_SHAPE_MESH) {
            if (mesh_collider(c, sd.dx, sd.threads, &sdf, err, sizeof err)) {
                kf_shot_report(diag, &c->mesh_at, KF_DIAG_ERROR, "collider '%s': %s", c->name, err);
                bad = 1;
                continue;
            }
            col.sdf = &sdf.grid;
            if (sdf.grid.spacing > 1.001 * sdf.spacing_asked)
                kf_shot_report(diag, &c->mesh_at, KF_DIAG_WARNING,
                               "collider '%s': distance grid spacing %.3g m instead of dx/2 = %.3g m (at dx/2 the grid "
                               "would exceed %zu nodes)",
                               c->name, sdf.grid.spacing, sdf.spacing_asked, (size_t)KF_MESH_SDF_MAX_NODES);
        }
        if (kf_model_add_collider(sc->model, &col, err, sizeof err) < 0) {
            kf_shot_report(diag, &c->at, KF_DIAG_ERROR, "%s", err);
            bad = 1;
        }
        kf_mesh_sdf_free(&sdf); /* the model keeps its own copy */
    }
    if (kf_scene_add_rigids(shot, sc->model, diag)) bad = 1; /* rigid bodies and joints (build_rigid.c) */
    sc->state = kf_state_create(sc->model);
    /* nothing is seeded after a bad body or collider, but every object's mesh
     * is still checked as seeding would check it, so all problems show at once */
    for (int i = 0; i < shot->nobjects && bad; i++) {
        const kf_shot_object *o = &shot->objects[i];
        if (o->shape == KF_SOURCE_MESH && object_mesh_check(o->mesh_path, sd.threads, err, sizeof err))
            kf_shot_report(diag, &o->mesh_at, KF_DIAG_ERROR, "object '%s': %s", o->name, err);
    }
    if (bad || !sc->state) goto fail;

    /* over MPI ranks only this rank's part is kept (src/dist/seed.c): a
     * first pass counts every object's particles per block to cut the
     * ranges, the second keeps the rank's own */
    kf_dist_seed *seed = NULL;
    if (part && !(seed = kf_dist_seed_new(sc->model))) {
        kf_shot_report(diag, NULL, KF_DIAG_ERROR, "out of memory splitting the scene over MPI ranks");
        goto fail;
    }
    for (int pass = seed ? 0 : 1; pass < 2 && !bad; pass++) {
        if (pass == 1 && seed && kf_dist_seed_cut(seed)) {
            kf_shot_report(diag, NULL, KF_DIAG_ERROR, "out of memory splitting the scene over MPI ranks");
            bad = 1;
            break;
        }
        /* the first pass reports; the second samples the same again */
        const int report = pass == 0 || !seed;
        uint32_t base = 0; /* the id a whole build gives the object's first particle */
        /* seed every object; keep going after a bad one so all are reported */
        for (int i = 0; i < shot->nobjects; i++) {
            const kf_shot_object *o = &shot->objects[i];
            kf_points pts;
            part_sink ps = {seed, pass, &sd, 0, 0, NULL, 0, 0, 0};
            state_sink ss = {sc, o, &sd, 0, 0};
            if (sample_object(shot, i, &sd, seed ? &ps : NULL, &ss, &pts, err, sizeof err)) {
                kf_shot_report(diag, o->shape == KF_SOURCE_MESH ? &o->mesh_at : &o->at, KF_DIAG_ERROR,
                               "object '%s': %s", o->name, err);
                bad = 1;
                free(ps.index);
                continue;
            }
            const int emitted = pts.n && !pts.x; /* in the state already */
            if (report && check_in_domain(o, &sd, &pts,
                                          seed      ? ps.outside
                                          : emitted ? ss.outside
                                                    : count_outside(&sd, &pts),
                                          diag)) {
                bad = 1;
                kf_points_free(&pts);
                continue;
            }
            if (report && stats && i < 256) stats->particles_per_object[i] = pts.whole;
            if (pts.whole == 0 && report)
                kf_shot_report(diag, &o->at, KF_DIAG_WARNING,
                               "object '%s' holds no particles at dx %g (thinner than the lattice)", o->name, sd.dx);
            else if (pass == 1 && !emitted && add_object(sc, o, &pts, ps.index, base)) {
                kf_shot_report(diag, &o->at, KF_DIAG_ERROR, "object '%s': out of memory for %zu particles", o->name,
                               pts.n);
                bad = 1;
            }
            base += (uint32_t)pts.whole;
            free(ps.index);
            kf_points_free(&pts);
        }
    }
    if (seed && !bad) kf_dist_seed_adopt(seed, sc->state);
    else kf_dist_seed_free(seed);
    if (bad) goto fail;
    if (stats) stats->seconds = (kf_now_ms() - t0) / 1e3;
    return 0;
fail:
    kf_scene_free(sc);
    return -1;
}

/* FNV-1a over a printed form of the values, so struct padding and field
 * order never matter */
static void hash_str(uint64_t *h, const char *s) { *h = kf_fnv1a_str(*h, s); }

static void hash_fmt(uint64_t *h, const char *fmt, double v) {
    char buf[64];
    snprintf(buf, sizeof buf, fmt, v);
    hash_str(h, buf);
}

static void hash_vals(uint64_t *h, const double *v, int n) {
    for (int i = 0; i < n; i++) hash_fmt(h, "%.17g,", v[i]);
}

/* an asset's bytes: an edited mesh under the same name is a different input */
uint64_t kf_hash_file(uint64_t h, const char *path) {
    FILE *f = fopen(path, "rb");
    if (!f) return kf_fnv1a_str(h, "<missing>");
    unsigned char buf[65536];
    size_t got;
    while ((got = fread(buf, 1, sizeof buf, f)) > 0) h = kf_fnv1a(h, buf, got);
    fclose(f);
    return h;
}

uint64_t kf_shot_sim_hash(const kf_shot *shot) {
    uint64_t h = KF_FNV_BASIS;
    hash_str(&h, "kerf " KERF_VERSION);
    /* the program's own bytes: a rebuilt kerf whose solver changed under the
     * same version string must not reuse frames an older build made (about
     * 5 ms for a 5 MB executable) */
    h = kf_hash_file(h, "/proc/self/exe");
    const kf_sim_def *s = &shot->sim;
    double sim[] = {s->dx,
                    s->cfl,
                    s->dt_max,
                    s->dt_fixed,
                    s->gravity[0],
                    s->gravity[1],
                    s->gravity[2],
                    s->kernel,
                    s->force,
                    s->transfer,
                    s->walls,
                    s->domain_min[0],
                    s->domain_min[1],
                    s->domain_min[2],
                    s->domain_max[0],
                    s->domain_max[1],
                    s->domain_max[2],
                    s->wall_boundary,
                    s->wall_friction,
                    s->max_retries,
                    s->j_min,
                    s->j_max,
                    s->max_cells_per_step,
                    s->integrator,
                    s->newton_tol,
                    s->newton_max,
                    s->krylov_tol,
                    s->krylov_max,
                    s->precond,
                    s->implicit_scheme,
                    s->retry_fixed,
                    s->contact,
                    s->contact_friction,
                    shot->ppc,
                    shot->jitter,
                    shot->seed,
                    shot->fps,
                    shot->frame_start,
                    sizeof(kf_real)};
    hash_vals(&h, sim, (int)(sizeof sim / sizeof *sim));
    hash_vals(&h, &s->flip_ratio, 1);
    for (int i = 0; i < shot->nmaterials; i++) {
        const kf_material *m = &shot->materials[i].mat;
        double v[] = {
            m->model,   m->density, m->E,  m->nu, m->yield_stress,      m->friction_angle, m->cohesion, m->hardening,
            m->h0,      m->h1,      m->h2, m->h3, m->volume_correction, m->bulk_modulus,   m->gamma,    m->viscosity,
            m->theta_c, m->theta_s, m->xi};
        hash_vals(&h, v, (int)(sizeof v / sizeof *v));
    }
    for (int i = 0; i < shot->nobjects; i++) {
        const kf_shot_object *o = &shot->objects[i];
        const kf_placement *p = &o->place;
        double v[] = {o->shape,
                      o->material,
                      o->size[0],
                      o->size[1],
                      o->size[2],
                      o->radius,
                      o->height,
                      p->translate[0],
                      p->translate[1],
                      p->translate[2],
                      p->rotate[0],
                      p->rotate[1],
                      p->rotate[2],
                      p->scale[0],
                      p->scale[1],
                      p->scale[2],
                      p->fit,
                      p->fit_center[0],
                      p->fit_center[1],
                      p->fit_center[2],
                      p->fit_size,
                      o->velocity[0],
                      o->velocity[1],
                      o->velocity[2],
                      o->angular_velocity[0],
                      o->angular_velocity[1],
                      o->angular_velocity[2]};
        hash_vals(&h, v, (int)(sizeof v / sizeof *v));
        if (o->shape == KF_SOURCE_MESH) h = kf_hash_file(h, o->mesh_path);
    }
    for (int i = 0; i < shot->ncolliders; i++) {
        const kf_shot_collider *sc = &shot->colliders[i];
        const kf_collider *c = &sc->col;
        const kf_placement *p = &sc->place;
        double v[] = {c->shape,       c->boundary,  c->friction,  c->center[0], c->center[1],   c->center[2],
                      c->normal[0],   c->normal[1], c->normal[2], c->half[0],   c->half[1],     c->half[2],
                      c->radius,      c->rotate[0], c->rotate[1], c->rotate[2], c->velocity[0], c->velocity[1],
                      c->velocity[2], c->interp,    c->nkeys,     c->inside};
        hash_vals(&h, v, (int)(sizeof v / sizeof *v));
        for (int k = 0; k < c->nkeys; k++) {
            const kf_key *key = &c->keys[k];
            hash_vals(&h, &key->time, 1), hash_vals(&h, key->position, 3);
            hash_vals(&h, key->rotate, 3), hash_vals(&h, key->scale, 3);
        }
        if (c->shape == KF_SHAPE_MESH) {
            double pl[] = {p->translate[0],  p->translate[1],  p->translate[2],  p->rotate[0], p->rotate[1],
                           p->rotate[2],     p->scale[0],      p->scale[1],      p->scale[2],  p->fit,
                           p->fit_center[0], p->fit_center[1], p->fit_center[2], p->fit_size};
            hash_vals(&h, pl, (int)(sizeof pl / sizeof *pl));
            h = kf_hash_file(h, sc->mesh_path);
        }
    }
    return kf_shot_rigids_hash(shot, h); /* bodies, joints and their mesh bytes */
}
