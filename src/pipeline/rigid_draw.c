/* rigid_draw.c — rigid bodies at their pose in a rendered frame (see
 * rigid_draw.h). */
#include "rigid_draw.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../io/checkpoint.h"
#include "../mpm/model.h"
#include "../rigid/rigid.h"

/* <dir>/surface/<name>.vdb → <dir>/checkpoints/<name>.kfc (stages.c's layout) */
static int checkpoint_beside(const char *vdb, char *out, size_t n) {
    const char *s = strstr(vdb, "/surface/"), *next;
    while (s && (next = strstr(s + 1, "/surface/"))) s = next;
    size_t len = strlen(vdb);
    if (!s || len < 4 || strcmp(vdb + len - 4, ".vdb") != 0) return -1;
    int w = snprintf(out, n, "%.*s/checkpoints/%.*s.kfc", (int)(s - vdb), vdb, (int)(len - 4 - (size_t)(s + 9 - vdb)),
                     s + 9);
    return w > 0 && (size_t)w < n ? 0 : -1;
}

/* every body's pose at the frame: from its checkpoint, else (no dynamic
 * bodies) from the bodies' scripted motion at the frame's time */
static int poses(const kf_shot *shot, const kf_scene *sc, const char *vdb, int frame, kf_rigid_state *st, char *err,
                 size_t errlen) {
    const kf_model *m = sc->model;
    char path[4200], why[4400] = "no checkpoint beside the surface file";
    kf_state *s = kf_state_create(m);
    int ok = 0;
    if (s && checkpoint_beside(vdb, path, sizeof path) == 0)
        ok = kf_checkpoint_read(path, m, s, NULL, why, sizeof why) == 0;
    for (int i = 0; ok && i < m->nrigid; i++) {
        kf_rigid_pose p = kf_state_rigid(s, i);
        memcpy(st[i].R, p.R, sizeof p.R);
        memcpy(st[i].t, p.t, sizeof p.t);
        memcpy(st[i].com, p.com, sizeof p.com);
        memcpy(st[i].v, p.v, sizeof p.v);
        memcpy(st[i].w, p.omega, sizeof p.omega);
    }
    kf_state_destroy(s);
    if (ok) return 0;
    double t = kf_shot_frame_time(shot, frame);
    for (int i = 0; i < m->nrigid; i++) {
        if (m->rigid[i].def.motion == KF_RIGID_DYNAMIC) {
            snprintf(err, errlen, "the pose of dynamic rigid '%s' is in the frame's checkpoint: %s",
                     m->rigid[i].def.name, why);
            return -1;
        }
        kf_rigid_state_at(&m->rigid[i], t, &st[i]);
    }
    return 0;
}

int kf_rigid_drawing_make(const kf_shot *shot, const kf_scene *sc, const char *vdb, int frame, kf_rigid_drawing *d,
                          char *err, size_t errlen) {
    memset(d, 0, sizeof *d);
    const kf_model *m = sc->model;
    if (!m || m->nrigid == 0) return 0;
    kf_rigid_state st[KF_MAX_RIGIDS];
    if (poses(shot, sc, vdb, frame, st, err, errlen)) return -1;
    size_t nt = 0;
    for (int i = 0; i < m->nrigid; i++) nt += (size_t)m->rigid[i].ntri;
    d->pos = malloc((3 * nt + 1) * 3 * sizeof *d->pos);
    d->tri = malloc((nt + 1) * 3 * sizeof *d->tri);
    d->vel = malloc((3 * nt + 1) * 3 * sizeof *d->vel);
    if (!d->pos || !d->tri || !d->vel) {
        kf_rigid_drawing_free(d);
        snprintf(err, errlen, "out of memory drawing %zu rigid triangles", nt);
        return -1;
    }
    /* x = R x_mesh + t, three corners per triangle so each is shaded flat */
    for (int i = 0; i < m->nrigid; i++) {
        const kf_rigid_body *b = &m->rigid[i];
        const double *R = st[i].R, *t = st[i].t;
        d->first[i] = d->nt;
        for (int k = 0; k < b->ntri; k++) {
            for (int c = 0; c < 3; c++) {
                const double *x = &b->vert[3 * b->tri[3 * k + c]];
                float *o = &d->pos[3 * d->nv];
                for (int a = 0; a < 3; a++)
                    o[a] = (float)(R[3 * a] * x[0] + R[3 * a + 1] * x[1] + R[3 * a + 2] * x[2] + t[a]);
                /* the corner's velocity: v + w x (x - com) */
                const double *v = st[i].v, *w = st[i].w;
                double r[3] = {o[0] - st[i].com[0], o[1] - st[i].com[1], o[2] - st[i].com[2]};
                float *ov = &d->vel[3 * d->nv];
                ov[0] = (float)(v[0] + w[1] * r[2] - w[2] * r[1]);
                ov[1] = (float)(v[1] + w[2] * r[0] - w[0] * r[2]);
                ov[2] = (float)(v[2] + w[0] * r[1] - w[1] * r[0]);
                d->tri[3 * d->nt + (size_t)c] = (uint32_t)d->nv++;
            }
            d->nt++;
        }
    }
    d->n = m->nrigid;
    d->first[d->n] = d->nt;
    return 0;
}

int kf_rigid_drawing_meshes(const kf_shot *shot, const kf_rigid_drawing *d, kf_render_mesh *rm, int max) {
    int n = 0;
    for (int i = 0; i < d->n && n < max; i++) {
        if (d->first[i + 1] == d->first[i]) continue;
        kf_render_mesh *r = &rm[n++];
        memset(r, 0, sizeof *r);
        r->positions = d->pos;
        r->nverts = d->nv;
        r->tris = d->tri + 3 * d->first[i];
        r->ntris = d->first[i + 1] - d->first[i];
        for (int a = 0; a < 3; a++) r->mat.diffuse[a] = i < shot->nrigids ? (float)shot->rigids[i].color[a] : 0.55f;
        r->mat.specular = 0.35f;
        r->mat.roughness = 0.4f;
    }
    return n;
}

void kf_rigid_drawing_free(kf_rigid_drawing *d) {
    free(d->pos);
    free(d->tri);
    free(d->vel);
    memset(d, 0, sizeof *d);
}
