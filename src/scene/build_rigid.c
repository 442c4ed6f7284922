/* build_rigid.c — a shot's rigid bodies and joints into the model (see
 * build_rigid.h). */
#include "build_rigid.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../core/euler.h"
#include "../core/fnv.h"
#include "mesh.h"
#include "mesh_isect.h"

/* a box of edge lengths size centred on the origin: 8 corners, 12 triangles
 * counter-clockwise seen from outside (each quad below runs clockwise, so
 * its triangles are taken in reverse) */
static int box_surface(const double size[3], double **vert, int *nv, int **tri, int *nt) {
    static const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4}, {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
    double *v = malloc(24 * sizeof *v);
    int *t = malloc(36 * sizeof *t);
    if (!v || !t) {
        free(v), free(t);
        return -1;
    }
    /* corner k: x from bit 2, y from bit 1, z from bit 0 */
    for (int k = 0; k < 8; k++) {
        v[3 * k] = (k & 4 ? 0.5 : -0.5) * size[0];
        v[3 * k + 1] = (k & 2 ? 0.5 : -0.5) * size[1];
        v[3 * k + 2] = (k & 1 ? 0.5 : -0.5) * size[2];
    }
    for (int q = 0; q < 6; q++) {
        const int *c = quads[q];
        int *o = &t[6 * q];
        o[0] = c[0], o[1] = c[2], o[2] = c[1], o[3] = c[0], o[4] = c[3], o[5] = c[2];
    }
    *vert = v, *nv = 8, *tri = t, *nt = 12;
    return 0;
}

int kf_rigid_surface(const kf_shot_rigid *r, double **vert, int *nv, int **tri, int *nt, char *err, size_t errlen) {
    double pivot[3] = {0, 0, 0};
    *vert = NULL, *tri = NULL, *nv = *nt = 0;
    if (r->shape == 0) {
        if (box_surface(r->size, vert, nv, tri, nt)) {
            snprintf(err, errlen, "out of memory");
            return -1;
        }
    } else {
        kf_mesh mesh;
        if (kf_mesh_load(r->mesh_path, &mesh, err, errlen)) return -1;
        if (mesh.nvert > 0x7fffffff / 3 || mesh.ntri > 0x7fffffff / 3) {
            snprintf(err, errlen, "%s: too large (%zu triangles)", r->mesh_path, mesh.ntri);
            kf_mesh_free(&mesh);
            return -1;
        }
        *vert = malloc(3 * mesh.nvert * sizeof **vert);
        *tri = malloc(3 * mesh.ntri * sizeof **tri);
        if (!*vert || !*tri) {
            free(*vert), free(*tri);
            kf_mesh_free(&mesh);
            snprintf(err, errlen, "%s: out of memory", r->mesh_path);
            return -1;
        }
        /* scaled about the file's origin; the pivot is in scaled coordinates */
        for (size_t i = 0; i < mesh.nvert; i++)
            for (int a = 0; a < 3; a++) (*vert)[3 * i + a] = mesh.vert[3 * i + a] * r->scale[a];
        for (size_t k = 0; k < 3 * mesh.ntri; k++) (*tri)[k] = (int)mesh.tri[k];
        for (int a = 0; a < 3; a++)
            pivot[a] = r->pivot_set ? r->pivot[a] : 0.5 * (mesh.lo[a] + mesh.hi[a]) * r->scale[a];
        *nv = (int)mesh.nvert, *nt = (int)mesh.ntri;
        kf_mesh_free(&mesh);
    }
    /* pivot to the origin, then the rest rotation, as a collider's rest shape */
    double R[9];
    kf_euler_matrix(r->def.rotate, R);
    for (int i = 0; i < *nv; i++) {
        double *p = &(*vert)[3 * i], x[3] = {p[0] - pivot[0], p[1] - pivot[1], p[2] - pivot[2]};
        for (int a = 0; a < 3; a++) p[a] = R[3 * a] * x[0] + R[3 * a + 1] * x[1] + R[3 * a + 2] * x[2];
    }
    return 0;
}

/* A solid body (not thin) has an inside, so its mesh must be closed; the
 * rigid compiler checks dynamic ones, this checks static and kinematic ones
 * the same way. And its surface must bound that inside once: a mesh that
 * passes through itself (a bowl whose inner bottom pokes out through its
 * foot) leaks material, so every solid is checked for self-intersections, in
 * the file's coordinates (placing it changes nothing). Returns 0, or -1 with
 * the message in err. */
static int solid_is_sound(const kf_shot_rigid *r, int threads, char *err, size_t errlen) {
    if (r->shape != 1 || r->def.thin) return 0;
    kf_mesh mesh;
    char why[900];
    if (kf_mesh_load(r->mesh_path, &mesh, why, sizeof why)) return 0; /* kf_rigid_surface reports it */
    const char *kind = r->def.motion == KF_RIGID_STATIC      ? "static"
                       : r->def.motion == KF_RIGID_KINEMATIC ? "kinematic"
                                                             : "dynamic";
    int rc = 0;
    /* an open dynamic mesh is refused by the rigid compiler, in its words */
    if (r->def.motion != KF_RIGID_DYNAMIC && kf_mesh_check_closed(&mesh, why, sizeof why)) {
        snprintf(err, errlen, "rigid %s: a %s solid must be a closed mesh (or make it thin: true): %s", r->def.name,
                 kind, why);
        rc = -1;
    } else if (mesh.closed && kf_mesh_check_self_intersection(&mesh, threads, why, sizeof why)) {
        snprintf(err, errlen, "rigid %s: a %s solid must not intersect itself: %s", r->def.name, kind, why);
        rc = -1;
    }
    kf_mesh_free(&mesh);
    return rc;
}

int kf_scene_add_rigids(const kf_shot *shot, kf_model *m, kf_diag *diag) {
    char err[1024];
    int bad = 0;
    for (int i = 0; i < shot->nrigids; i++) {
        const kf_shot_rigid *r = &shot->rigids[i];
        const kf_loc *at = r->shape == 1 ? &r->mesh_at : &r->at;
        double *vert;
        int *tri, nv, nt;
        if (solid_is_sound(r, shot->sim.threads, err, sizeof err)) {
            kf_shot_report(diag, at, KF_DIAG_ERROR, "%s", err);
            bad = 1;
            continue;
        }
        if (kf_rigid_surface(r, &vert, &nv, &tri, &nt, err, sizeof err)) {
            kf_shot_report(diag, at, KF_DIAG_ERROR, "rigid '%s': %s", r->def.name, err);
            bad = 1;
            continue;
        }
        kf_rigid_def d = r->def;
        d.vertices = vert, d.nvertices = nv;
        d.triangles = tri, d.ntriangles = nt;
        memset(d.center, 0, sizeof d.center);
        memset(d.rotate, 0, sizeof d.rotate);
        /* every body is tried, so all problems show at once; joints need them all */
        if (kf_model_add_rigid(m, &d, err, sizeof err) < 0) {
            kf_shot_report(diag, at, KF_DIAG_ERROR, "%s", err);
            bad = 1;
        }
        free(vert);
        free(tri);
    }
    for (int i = 0; i < shot->njoints && !bad; i++)
        if (kf_model_add_joint(m, &shot->joints[i].def, err, sizeof err) < 0) {
            kf_shot_report(diag, &shot->joints[i].at, KF_DIAG_ERROR, "joint '%s': %s", shot->joints[i].name, err);
            bad = 1;
        }
    return bad ? -1 : 0;
}

/* FNV-1a over printed values, as kf_shot_sim_hash does */
static void mix_str(uint64_t *h, const char *s) { *h = kf_fnv1a_str(*h, s); }

static void mix_vals(uint64_t *h, const double *v, int n) {
    char buf[64];
    for (int i = 0; i < n; i++) {
        snprintf(buf, sizeof buf, "%.17g,", v[i]);
        mix_str(h, buf);
    }
}

uint64_t kf_shot_rigids_hash(const kf_shot *shot, uint64_t h) {
    if (shot->nrigids == 0 && shot->njoints == 0) return h; /* shots without bodies keep their hash */
    mix_str(&h, "rigids");
    for (int i = 0; i < shot->nrigids; i++) {
        const kf_shot_rigid *r = &shot->rigids[i];
        const kf_rigid_def *d = &r->def;
        double v[] = {r->shape,
                      r->size[0],
                      r->size[1],
                      r->size[2],
                      r->scale[0],
                      r->scale[1],
                      r->scale[2],
                      r->pivot_set,
                      r->pivot[0],
                      r->pivot[1],
                      r->pivot[2],
                      d->thin,
                      d->motion,
                      d->position[0],
                      d->position[1],
                      d->position[2],
                      d->rotate[0],
                      d->rotate[1],
                      d->rotate[2],
                      d->interp,
                      d->nkeys,
                      d->velocity[0],
                      d->velocity[1],
                      d->velocity[2],
                      d->angular_velocity[0],
                      d->angular_velocity[1],
                      d->angular_velocity[2],
                      d->density,
                      d->boundary,
                      d->friction,
                      d->penalty,
                      d->push};
        mix_vals(&h, v, (int)(sizeof v / sizeof *v));
        for (int k = 0; k < d->nkeys; k++) {
            const kf_key *key = &d->keys[k];
            mix_vals(&h, &key->time, 1), mix_vals(&h, key->position, 3), mix_vals(&h, key->rotate, 3);
        }
        if (r->shape == 1) h = kf_hash_file(h, r->mesh_path);
    }
    for (int i = 0; i < shot->njoints; i++) {
        const kf_joint_def *j = &shot->joints[i].def;
        double v[] = {shot->joints[i].type, j->body_a,  j->body_b,  j->anchor[0], j->anchor[1],
                      j->anchor[2],         j->axis[0], j->axis[1], j->axis[2],   j->damping};
        mix_vals(&h, v, (int)(sizeof v / sizeof *v));
        /* a motor changes the motion; a shot without one keeps its hash */
        if (j->motor == KF_MOTOR_NONE) continue;
        double mv[] = {j->motor, j->frequency, j->angle, j->kp, j->kv, j->torque_limit};
        mix_vals(&h, mv, (int)(sizeof mv / sizeof *mv));
    }
    return h;
}
