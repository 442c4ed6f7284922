/* stages.c — surfacing and rendering of one frame (see stages.h). */
#include "stages.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "../io/atomic_file.h"
#include "../io/checkpoint.h"
#include "../io/pieces.h"
#include "../io/vdb_bridge.h"
#include <kerf/kerf.h>
#include "../mpm/collider.h"
#include "../scene/mesh.h"
#include "../scene/sample.h"
#include "render.h"
#include "exr_frame.h"
#include "rigid_draw.h"
#include "surface_keep.h"

int kf_frame_paths_make(const kf_shot *shot, const char *out, int frame, kf_frame_paths *fp) {
    char name[1024];
    if (kf_shot_expand(out ? out : shot->output_dir, shot, frame, fp->dir, sizeof fp->dir) ||
        kf_shot_expand(shot->output_name, shot, frame, name, sizeof name))
        return -1;
    snprintf(fp->particles, sizeof fp->particles, "%s/particles/%s.ply", fp->dir, name);
    snprintf(fp->checkpoint, sizeof fp->checkpoint, "%s/checkpoints/%s.kfc", fp->dir, name);
    snprintf(fp->surface, sizeof fp->surface, "%s/surface/%s.vdb", fp->dir, name);
    snprintf(fp->image, sizeof fp->image, "%s/images/%s.png", fp->dir, name);
    snprintf(fp->exr, sizeof fp->exr, "%s/images/%s.exr", fp->dir, name);
    snprintf(fp->points, sizeof fp->points, "%s/points/%s.vdb", fp->dir, name);
    return 0;
}

int kf_ensure_parent(const char *path) {
    char dir[4096];
    snprintf(dir, sizeof dir, "%s", path);
    char *slash = strrchr(dir, '/');
    if (!slash) return 0;
    *slash = 0;
    return kf_mkdirs(dir);
}

int kf_output_current(const char *output, const char *input) {
    struct stat so, si;
    if (stat(output, &so) != 0 || stat(input, &si) != 0) return 0;
    if (so.st_mtim.tv_sec != si.st_mtim.tv_sec) return so.st_mtim.tv_sec > si.st_mtim.tv_sec;
    return so.st_mtim.tv_nsec >= si.st_mtim.tv_nsec;
}

/* the metadata every .vdb a stage writes carries: the shot, the frame, this
 * kerf and the grid spacing */
static kf_vdb_meta vdb_meta(const kf_shot *shot, int frame) {
    kf_vdb_meta meta;
    memset(&meta, 0, sizeof meta);
    snprintf(meta.shot, sizeof meta.shot, "%s", shot->name);
    meta.frame = frame;
    snprintf(meta.kerf_version, sizeof meta.kerf_version, "%s", KERF_VERSION);
    meta.dx = shot->sim.dx;
    return meta;
}

/* ---- surface ------------------------------------------------------------ */

/* the settings every material's level set uses (the shot's surface keys):
 * anisotropic discs (or spheres on averaged centres), a voxel finer than
 * the spacing, a little mean-curvature smoothing, then an erosion that puts
 * the zero crossing back on the material's boundary (vdb_bridge.h gives
 * each kernel's offset; the bridge takes off the averaging's inward shift) */
static void surface_params(const kf_shot *shot, kf_vdb_surface_params *p, const char *name) {
    static const kf_vdb_op ops[4] = {KF_VDB_OP_NONE, KF_VDB_OP_MEAN_CURVATURE, KF_VDB_OP_GAUSSIAN, KF_VDB_OP_LAPLACIAN};
    kf_vdb_surface_params_default(p);
    double spacing = shot->sim.dx / shot->ppc_axis;
    p->spacing = spacing;
    p->voxel = shot->surface_voxel * spacing;
    p->smooth = ops[shot->surface_smooth & 3];
    p->smooth_iterations = shot->surface_iterations;
    p->flatten = shot->surface_flatten;
    p->dilate = shot->surface_dilate;
    if (shot->surface_kernel == 0) {
        p->kernel = KF_VDB_KERNEL_ANISOTROPIC;
        p->radius = shot->surface_reach * spacing;
        p->average_radius = shot->surface_reach * spacing;
    } else {
        p->radius = shot->surface_radius * spacing;
        p->average = shot->surface_average;
        p->average_radius = shot->surface_average_radius * spacing;
    }
    /* automatic erosion puts the zero crossing back on the material boundary */
    p->erode = shot->surface_erode >= 0 ? shot->surface_erode : kf_vdb_surface_offset(p) + shot->surface_dilate;
    p->clamp_small = 1;
    p->name = name;
}

/* The groups a frame is surfaced in (surface.group): per material, or per
 * shot object. Group g of particle i, the number of groups, and their names. */
static int group_count(const kf_shot *shot) {
    return shot->surface_group ? (shot->nobjects > 0 ? shot->nobjects : 1)
                               : (shot->nmaterials > 0 ? shot->nmaterials : 1);
}

static const char *group_name(const kf_shot *shot, int g) {
    if (shot->surface_group) return g < shot->nobjects ? shot->objects[g].name : "object";
    return g < shot->nmaterials ? shot->materials[g].mat.name : "material";
}

int kf_pipeline_surface(const kf_shot *shot, const kf_scene *sc, const kf_frame_paths *fp, int frame, char *err,
                        size_t errlen) {
    kf_checkpoint_info info;
    if (kf_checkpoint_read(fp->checkpoint, sc->model, sc->state, &info, err, errlen)) return -1;
    kf_particles_view pv = kf_state_particles_read(sc->state);
    const int ng = group_count(shot);
    int ngrids = 0, rc = -1;
    kf_vdb_grid *grids[KF_VDB_MAX_GRIDS] = {0};
    /* particles gathered group by group (a counting sort): group g is
     * x[3 * at[g] ...] up to at[g + 1] */
    float *x = malloc(sizeof(float) * 3 * (pv.n + 1)), *v = malloc(sizeof(float) * 3 * (pv.n + 1));
    float *xs = malloc(sizeof(float) * 3 * (pv.n + 1)), *vs = malloc(sizeof(float) * 3 * (pv.n + 1));
    uint32_t *col = malloc(sizeof(uint32_t) * (pv.n + 1));
    uint8_t *cls = malloc(pv.n + 1);
    size_t *at = calloc((size_t)ng + 2, sizeof *at), *fill = calloc((size_t)ng + 1, sizeof *fill);
    if (!x || !v || !xs || !vs || !col || !cls || !at || !fill) {
        snprintf(err, errlen, "out of memory surfacing %zu particles", pv.n);
        goto done;
    }
    for (size_t i = 0; i < pv.n; i++) {
        int g = shot->surface_group ? (int)(pv.obj[i] & KF_OBJECT_MASK) : pv.mat[i];
        at[(g < ng ? g : ng - 1) + 1]++;
    }
    int used = 0;
    for (int g = 0; g < ng; g++) used += at[g + 1] > 0, at[g + 1] += at[g];
    if (used > KF_VDB_MAX_GRIDS / 2) {
        snprintf(err, errlen, "%d %ss hold particles; a .vdb takes at most %d level sets (surface.group)", used,
                 shot->surface_group ? "object" : "material", KF_VDB_MAX_GRIDS / 2);
        goto done;
    }
    memcpy(fill, at, sizeof *fill * (size_t)ng);
    for (size_t i = 0; i < pv.n; i++) {
        int g = shot->surface_group ? (int)(pv.obj[i] & KF_OBJECT_MASK) : pv.mat[i];
        size_t k = fill[g < ng ? g : ng - 1]++;
        for (int a = 0; a < 3; a++) x[3 * k + a] = (float)pv.x[a][i], v[3 * k + a] = (float)pv.v[a][i];
        col[k] = pv.colour[i];
    }
    /* one level set per group that holds particles: `surface` when there is
     * one, else `surface_<name>`; each with its velocity grid */
    for (int g = 0; g < ng; g++) {
        size_t n = at[g + 1] - at[g];
        if (n == 0) continue;
        char name[128];
        if (used == 1) snprintf(name, sizeof name, "surface");
        else snprintf(name, sizeof name, "surface_%s", group_name(shot, g));
        kf_vdb_surface_params p;
        surface_params(shot, &p, name);
        /* the pieces a blade parted (io/pieces.h): one level set per class
         * of pieces, joined by CSG union, so a cut stays open however close
         * its sides lie; one class (no cut) is the whole group at once */
        int k = kf_pieces_classes(n, x + 3 * at[g], col + at[g], p.spacing, 2 * p.radius + p.spacing, cls);
        if (k < 0) {
            snprintf(err, errlen, "out of memory finding the pieces of %zu particles", n);
            goto done;
        }
        for (int c = 0; c < k; c++) {
            const float *xc = x + 3 * at[g], *vc = v + 3 * at[g];
            size_t m = n;
            if (k > 1) {
                m = 0;
                for (size_t i = 0; i < n; i++)
                    if (cls[i] == c) {
                        memcpy(xs + 3 * m, xc + 3 * i, 3 * sizeof *xs);
                        memcpy(vs + 3 * m, vc + 3 * i, 3 * sizeof *vs);
                        m++;
                    }
                xc = xs, vc = vs;
            }
            if (m == 0) continue;
            kf_vdb_grid *piece = NULL;
            if (kf_vdb_levelset_from_particles(m, NULL, xc, NULL, vc, &p, &piece, NULL, err, errlen)) goto done;
            if (!grids[ngrids]) {
                grids[ngrids] = piece;
                continue;
            }
            int urc = kf_vdb_union(grids[ngrids], piece, err, errlen);
            kf_vdb_free(piece);
            if (urc) goto done;
        }
        if (grids[ngrids]) ngrids++;
    }
    kf_vdb_meta meta = vdb_meta(shot, frame);
    if (kf_ensure_parent(fp->surface)) {
        snprintf(err, errlen, "%s: cannot create directory: %s", fp->surface, strerror(errno));
        goto done;
    }
    rc = kf_vdb_write(fp->surface, grids, ngrids, &meta, err, errlen);
    /* the render that usually follows meshes these grids instead of reading the file back */
    if (rc == 0) {
        kf_surface_keep(fp->surface, grids, ngrids);
        memset(grids, 0, sizeof grids);
        ngrids = 0;
    }
done:
    for (int g = 0; g < ngrids; g++) kf_vdb_free(grids[g]);
    if (grids[ngrids]) kf_vdb_free(grids[ngrids]); /* a group cut short by an error */
    free(x);
    free(v);
    free(xs);
    free(vs);
    free(col);
    free(cls);
    free(at);
    free(fill);
    return rc;
}

/* ---- points ----------------------------------------------------------------- */

int kf_pipeline_points(const kf_shot *shot, const kf_model *m, const kf_state *s, const char *path, int frame,
                       char *err, size_t errlen) {
    kf_particles_view p = kf_state_particles_read(s);
    float *x = malloc(sizeof(float) * 3 * (p.n + 1)), *v = malloc(sizeof(float) * 3 * (p.n + 1));
    /* the float attributes: the raw plastic state, and the fields for analysis */
    float *fl[KF_VDB_PT_FLOATS];
    int ok = x && v;
    for (int a = 0; a < KF_VDB_PT_FLOATS; a++) ok &= (fl[a] = malloc(sizeof(float) * (p.n + 1))) != NULL;
    int32_t *mat = malloc(sizeof(int32_t) * (p.n + 1));
    int rc = -1;
    if (!ok || !mat) snprintf(err, errlen, "out of memory writing %zu points", p.n);
    else {
        for (size_t i = 0; i < p.n; i++) {
            for (int a = 0; a < 3; a++) x[3 * i + a] = (float)p.x[a][i], v[3 * i + a] = (float)p.v[a][i];
            kf_particle_fields pf = kf_state_particle_fields(m, s, i);
            fl[KF_VDB_PT_JP][i] = (float)p.ps[0][i];
            fl[KF_VDB_PT_VON_MISES][i] = (float)pf.von_mises;
            fl[KF_VDB_PT_J][i] = (float)pf.J;
            fl[KF_VDB_PT_PLASTIC][i] = (float)pf.plastic;
            mat[i] = p.mat[i];
        }
        kf_vdb_meta meta = vdb_meta(shot, frame);
        if (kf_ensure_parent(path)) snprintf(err, errlen, "%s: cannot create directory: %s", path, strerror(errno));
        else rc = kf_vdb_points_write(path, p.n, x, v, mat, (const float *const *)fl, 0, &meta, err, errlen);
    }
    free(x), free(v), free(mat);
    for (int a = 0; a < KF_VDB_PT_FLOATS; a++) free(fl[a]);
    return rc;
}

/* ---- render --------------------------------------------------------------- */

static int cmp_float(const void *a, const void *b) {
    float x = *(const float *)a, y = *(const float *)b;
    return x < y ? -1 : x > y;
}

void kf_particle_bounds_add(const kf_scene *sc, float lo[3], float hi[3]) {
    /* robust: the 0.2 % and 99.8 % points of up to 4096 particles per axis,
     * so a few stray drops do not shrink the subject to a dot */
    kf_particles_view p = kf_state_particles_read(sc->state);
    if (p.n == 0) return;
    enum { NS = 4096 };
    static float v[NS];
    size_t step = p.n > NS ? p.n / NS : 1, m = 0;
    for (int a = 0; a < 3; a++) {
        m = 0;
        for (size_t i = 0; i < p.n && m < NS; i += step) v[m++] = (float)p.x[a][i];
        qsort(v, m, sizeof *v, cmp_float);
        float l = v[(size_t)(0.002 * (double)(m - 1))], h = v[(size_t)(0.998 * (double)(m - 1) + 0.5)];
        lo[a] = l < lo[a] ? l : lo[a];
        hi[a] = h > hi[a] ? h : hi[a];
    }
}

kf_render_opts kf_render_opts_for(const kf_shot *shot, const float blo[3], const float bhi[3]) {
    /* the shot's size and sampling, with --quality already applied */
    kf_render_opts o = {shot->render_width,  shot->render_height, shot->render_samples,   0,   0, {0, 0, 0}, {1, 1, 1},
                        shot->render_ground, shot->render_shadow, shot->render_antialias, NULL};
    if (!(bhi[0] >= blo[0])) return o; /* no particles */
    float lo[3], hi[3];
    for (int a = 0; a < 3; a++) lo[a] = blo[a], hi[a] = bhi[a];
    /* the bounds already cover the whole shot: a small margin sideways */
    float ext = 0;
    for (int a = 0; a < 3; a++) ext = hi[a] - lo[a] > ext ? hi[a] - lo[a] : ext;
    for (int a = 0; a < 3; a += 2) lo[a] -= 0.05f * ext, hi[a] += 0.05f * ext;
    if (shot->sim.walls) {
        /* the floor is in the picture; nothing beyond the walls is. Material
         * that reaches a side wall is held by the walls and flows along them
         * (a dam break runs to the far wall): frame the whole floor then. */
        const float near = 2 * (float)shot->sim.dx;
        int held = 0;
        for (int a = 0; a < 3; a += 2)
            held |= blo[a] < (float)shot->sim.domain_min[a] + near || bhi[a] > (float)shot->sim.domain_max[a] - near;
        lo[1] = (float)shot->sim.domain_min[1];
        for (int a = 0; a < 3; a++) {
            if (lo[a] < shot->sim.domain_min[a] || (held && a != 1)) lo[a] = (float)shot->sim.domain_min[a];
            if (hi[a] > shot->sim.domain_max[a] || (held && a != 1)) hi[a] = (float)shot->sim.domain_max[a];
        }
    }
    for (int a = 0; a < 3; a++) o.lo[a] = lo[a], o.hi[a] = hi[a];
    return o;
}

/* A collider as triangles at its pose at time t (grown arrays in *pos /
 * *tri). Planes stay out of the picture (the ground is drawn). Returns the
 * triangles added, or -1 with a message. */
typedef struct tri_soup {
    float *pos;
    uint32_t *tri;
    size_t nv, nt, capv, capt;
} tri_soup;

static int soup_grow(tri_soup *s, size_t nv, size_t nt) {
    if (s->nv + nv > s->capv) {
        size_t c = (s->nv + nv) * 2;
        float *p = realloc(s->pos, c * 3 * sizeof *p);
        if (!p) return -1;
        s->pos = p, s->capv = c;
    }
    if (s->nt + nt > s->capt) {
        size_t c = (s->nt + nt) * 2;
        uint32_t *t = realloc(s->tri, c * 3 * sizeof *t);
        if (!t) return -1;
        s->tri = t, s->capt = c;
    }
    return 0;
}

/* x = p + R S R0 X: the collider's rest offset X placed at its pose */
static void place(const kf_collider *c, const kf_collider_pose *ps, const double X[3], float out[3]) {
    double R0[9], y[3], z[3];
    kf_euler_matrix(c->rotate, R0);
    for (int i = 0; i < 3; i++)
        y[i] = (R0[3 * i] * X[0] + R0[3 * i + 1] * X[1] + R0[3 * i + 2] * X[2]) * (ps->s[i] ? ps->s[i] : 1);
    for (int i = 0; i < 3; i++) z[i] = ps->R[3 * i] * y[0] + ps->R[3 * i + 1] * y[1] + ps->R[3 * i + 2] * y[2];
    for (int i = 0; i < 3; i++) out[i] = (float)(ps->p[i] + z[i]);
}

static int collider_mesh(const kf_shot_collider *sc, double t, tri_soup *s, char *err, size_t errlen) {
    const kf_collider *c = &sc->col;
    kf_collider_pose ps;
    kf_collider_pose_at(c, t, &ps);
    size_t base = s->nv;
    if (c->shape == KF_SHAPE_MESH) {
        /* the mesh placed as the builder placed it (build.c), then moved by
         * the pose about its pivot like its distance field */
        kf_mesh mesh;
        if (kf_mesh_load(sc->mesh_path, &mesh, err, errlen)) return -1;
        kf_sample_def d = kf_default_sample_def();
        d.kind = KF_SOURCE_MESH;
        d.place = sc->place;
        double M[12], lo[3], hi[3];
        int rc = kf_sample_placement(&d, &mesh, M, lo, hi, err, errlen);
        if (rc == 0 && soup_grow(s, mesh.nvert, mesh.ntri)) {
            snprintf(err, errlen, "out of memory drawing %s", sc->mesh_path);
            rc = -1;
        }
        if (rc == 0) {
            kf_mesh_transform(&mesh, M);
            for (size_t v = 0; v < mesh.nvert; v++) {
                double X[3] = {mesh.vert[3 * v] - c->center[0], mesh.vert[3 * v + 1] - c->center[1],
                               mesh.vert[3 * v + 2] - c->center[2]};
                place(c, &ps, X, &s->pos[3 * (s->nv + v)]);
            }
            for (size_t k = 0; k < 3 * mesh.ntri; k++) s->tri[3 * s->nt + k] = (uint32_t)base + mesh.tri[k];
            s->nv += mesh.nvert;
            s->nt += mesh.ntri;
            rc = (int)mesh.ntri;
        }
        kf_mesh_free(&mesh);
        return rc;
    }
    if (c->shape == KF_SHAPE_BOX) {
        static const int quads[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                                        {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
        if (soup_grow(s, 8, 12)) return -1;
        for (int k = 0; k < 8; k++) {
            double X[3] = {(k & 4 ? 1 : -1) * c->half[0], (k & 2 ? 1 : -1) * c->half[1], (k & 1 ? 1 : -1) * c->half[2]};
            place(c, &ps, X, &s->pos[3 * (s->nv + (size_t)k)]);
        }
        for (int q = 0; q < 6; q++) {
            uint32_t *t2 = &s->tri[3 * s->nt];
            t2[0] = (uint32_t)base + quads[q][0], t2[1] = (uint32_t)base + quads[q][1],
            t2[2] = (uint32_t)base + quads[q][2];
            t2[3] = (uint32_t)base + quads[q][0], t2[4] = (uint32_t)base + quads[q][2],
            t2[5] = (uint32_t)base + quads[q][3];
            s->nt += 2;
        }
        s->nv += 8;
        return 12;
    }
    if (c->shape == KF_SHAPE_SPHERE) {
        enum { RINGS = 24, SEGS = 48 };
        if (soup_grow(s, (RINGS + 1) * SEGS, RINGS * SEGS * 2)) return -1;
        for (int i = 0; i <= RINGS; i++)
            for (int j = 0; j < SEGS; j++) {
                double th = 3.14159265358979 * i / RINGS, ph = 2 * 3.14159265358979 * j / SEGS;
                double X[3] = {c->radius * sin(th) * cos(ph), c->radius * cos(th), c->radius * sin(th) * sin(ph)};
                place(c, &ps, X, &s->pos[3 * (s->nv + (size_t)(i * SEGS + j))]);
            }
        for (int i = 0; i < RINGS; i++)
            for (int j = 0; j < SEGS; j++) {
                uint32_t a = (uint32_t)(base + (size_t)(i * SEGS + j)),
                         b = (uint32_t)(base + (size_t)(i * SEGS + (j + 1) % SEGS));
                uint32_t *t2 = &s->tri[3 * s->nt];
                t2[0] = a, t2[1] = b, t2[2] = a + SEGS, t2[3] = b, t2[4] = b + SEGS, t2[5] = a + SEGS;
                s->nt += 2;
            }
        s->nv += (size_t)(RINGS + 1) * SEGS;
        return RINGS * SEGS * 2;
    }
    return 0;
}

/* a palette for materials in file order: warm, cool, neutral, ... */
static const float palette[6][3] = {{0.80f, 0.62f, 0.38f}, {0.85f, 0.25f, 0.30f}, {0.25f, 0.55f, 0.85f},
                                    {0.45f, 0.75f, 0.40f}, {0.85f, 0.80f, 0.70f}, {0.60f, 0.45f, 0.75f}};

/* what a material looks like: by what it is (water blue and glossy, sand
 * tan and matte, snow white, ...), else the palette by its place in the
 * file; colour, specular and roughness given in the shot win */
static void material_look(const kf_shot *shot, int i, kf_render_material *m) {
    static const struct {
        const char *preset;
        float rgb[3], spec, rough;
    } known[] = {{"water", {0.25f, 0.50f, 0.85f}, 0.60f, 0.15f},    {"sand", {0.80f, 0.65f, 0.42f}, 0.05f, 0.90f},
                 {"wet_sand", {0.55f, 0.43f, 0.30f}, 0.15f, 0.60f}, {"snow", {0.92f, 0.94f, 0.97f}, 0.15f, 0.70f},
                 {"jello", {0.85f, 0.25f, 0.30f}, 0.50f, 0.25f},    {"rubber", {0.25f, 0.55f, 0.85f}, 0.30f, 0.45f},
                 {"goo", {0.45f, 0.75f, 0.40f}, 0.50f, 0.20f},      {"cheese", {0.95f, 0.80f, 0.35f}, 0.20f, 0.50f},
                 {"metal", {0.70f, 0.72f, 0.75f}, 0.80f, 0.30f}};
    memcpy(m->diffuse, palette[(i < 0 ? 0 : i) % 6], sizeof m->diffuse);
    m->specular = 0.3f;
    m->roughness = 0.5f;
    if (i < 0 || i >= shot->nmaterials) return;
    const kf_shot_material *sm = &shot->materials[i];
    for (size_t k = 0; k < sizeof known / sizeof *known; k++)
        if (!strcmp(sm->preset, known[k].preset)) {
            memcpy(m->diffuse, known[k].rgb, sizeof m->diffuse);
            m->specular = known[k].spec;
            m->roughness = known[k].rough;
        }
    if (sm->color[0] >= 0)
        for (int a = 0; a < 3; a++) m->diffuse[a] = (float)sm->color[a];
    if (sm->specular >= 0) m->specular = (float)sm->specular;
    if (sm->roughness > 0) m->roughness = (float)sm->roughness;
}

/* what a surfaced object looks like: its material's look; when objects of
 * one material without a colour of its own are told apart, each takes the
 * palette colour of its place in the file */
static void object_look(const kf_shot *shot, int o, kf_render_material *m) {
    if (o < 0 || o >= shot->nobjects) {
        material_look(shot, -1, m);
        return;
    }
    int mat = shot->objects[o].material, sharing = 0;
    material_look(shot, mat, m);
    for (int k = 0; k < shot->nobjects; k++) sharing += shot->objects[k].material == mat;
    if (sharing > 1 && shot->materials[mat].color[0] < 0) memcpy(m->diffuse, palette[o % 6], sizeof m->diffuse);
}

/* the look of a level set in the .vdb: `surface` alone is the first
 * object's (or its material's), `surface_<name>` the group of that name */
static void surface_look(const kf_shot *shot, const char *grid, kf_render_material *m) {
    const char *name = strncmp(grid, "surface_", 8) == 0 || strncmp(grid, "surface.", 8) == 0 ? grid + 8 : NULL;
    if (shot->surface_group) {
        int o = shot->nobjects > 0 ? 0 : -1;
        for (int k = 0; name && k < shot->nobjects; k++)
            if (!strcmp(name, shot->objects[k].name)) o = k;
        object_look(shot, o, m);
        return;
    }
    int mat = shot->nobjects > 0 ? shot->objects[0].material : 0;
    for (int k = 0; name && k < shot->nmaterials; k++)
        if (!strcmp(name, shot->materials[k].mat.name)) mat = k;
    material_look(shot, mat, m);
}

/* The automatic camera moved along its line of sight until the box's eight
 * corners just fit the frame (5 % margin), both ways: the bounding sphere
 * leaves a wide, flat subject small in a 16:9 frame. */
static void fit_box(kf_camera *c, const float lo[3], const float hi[3], float aspect) {
    float d[3], r[3], u[3], len = 0;
    for (int a = 0; a < 3; a++) d[a] = c->target[a] - c->eye[a], len += d[a] * d[a];
    len = sqrtf(len);
    if (!(len > 0)) return;
    for (int a = 0; a < 3; a++) d[a] /= len;
    r[0] = d[1] * c->up[2] - d[2] * c->up[1], r[1] = d[2] * c->up[0] - d[0] * c->up[2],
    r[2] = d[0] * c->up[1] - d[1] * c->up[0];
    float rl = sqrtf(r[0] * r[0] + r[1] * r[1] + r[2] * r[2]);
    if (!(rl > 0)) return;
    for (int a = 0; a < 3; a++) r[a] /= rl;
    u[0] = r[1] * d[2] - r[2] * d[1], u[1] = r[2] * d[0] - r[0] * d[2], u[2] = r[0] * d[1] - r[1] * d[0];
    const float ty = tanf(c->fov_deg * 3.14159265f / 360.0f), tx = ty * aspect;
    float need = 0;
    for (int k = 0; k < 8; k++) {
        float p[3] = {k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1], k & 4 ? hi[2] : lo[2]}, v[3];
        for (int a = 0; a < 3; a++) v[a] = p[a] - c->target[a];
        float x = v[0] * r[0] + v[1] * r[1] + v[2] * r[2], y = v[0] * u[0] + v[1] * u[1] + v[2] * u[2];
        float z = v[0] * d[0] + v[1] * d[1] + v[2] * d[2]; /* depth beyond the target */
        float dx = fabsf(x) / (0.95f * tx) - z, dy = fabsf(y) / (0.95f * ty) - z;
        need = dx > need ? dx : need;
        need = dy > need ? dy : need;
    }
    if (need > 0)
        for (int a = 0; a < 3; a++) c->eye[a] = c->target[a] - d[a] * need;
}

/* the index of a level set's group in the shot (its object under
 * surface.group: object, else its material), as surface_look finds it */
static int surface_index(const kf_shot *shot, const char *grid) {
    const char *name = strncmp(grid, "surface_", 8) == 0 || strncmp(grid, "surface.", 8) == 0 ? grid + 8 : NULL;
    if (shot->surface_group) {
        for (int k = 0; name && k < shot->nobjects; k++)
            if (!strcmp(name, shot->objects[k].name)) return k;
        return 0;
    }
    int mat = shot->nobjects > 0 ? shot->objects[0].material : 0;
    for (int k = 0; name && k < shot->nmaterials; k++)
        if (!strcmp(name, shot->materials[k].mat.name)) mat = k;
    return mat;
}

/* Each vertex's motion over one frame (m): the velocity grid beside the
 * level set (`vel` for `surface`, `<name>_vel` otherwise; the closest
 * particle's velocity) times the frame's duration. The grid is sampled
 * trilinearly one voxel inside the surface, along the normal: at the zero
 * crossing itself some of the eight voxels around can lie outside the
 * grid's active band and read zero, which slowed a uniformly moving ball's
 * rim by up to 3 %. A level set without one does not move. */
static int surface_motion(const char *vdb, const kf_vdb_file_info *info, const char *grid, const kf_vdb_trimesh *m,
                          double voxel, double dt, float **out, char *err, size_t errlen) {
    *out = NULL;
    char vel[160];
    if (!strcmp(grid, "surface")) snprintf(vel, sizeof vel, "vel");
    else snprintf(vel, sizeof vel, "%s_vel", grid);
    int found = 0;
    for (int g = 0; g < info->ngrids; g++) found |= !strcmp(info->grids[g].name, vel);
    if (!found || m->nverts == 0) return 0;
    double *xyz = malloc(sizeof(double) * 3 * m->nverts), *v = malloc(sizeof(double) * 3 * m->nverts);
    float *mot = malloc(sizeof(float) * 3 * m->nverts);
    int rc = -1;
    if (!xyz || !v || !mot) snprintf(err, errlen, "out of memory for the motion of %zu vertices", m->nverts);
    else {
        for (size_t i = 0; i < 3 * m->nverts; i++) xyz[i] = m->verts[i] - voxel * m->normals[i];
        rc = kf_vdb_read_vec3_sample(vdb, vel, xyz, m->nverts, v, err, errlen);
        for (size_t i = 0; rc == 0 && i < 3 * m->nverts; i++) mot[i] = (float)(v[i] * dt);
    }
    free(xyz), free(v);
    if (rc == 0) *out = mot;
    else free(mot);
    return rc;
}

/* The camera for `frame` (fractional frames allowed for keyed cameras): the
 * keyed camera, the shot's eye, a turntable view or the automatic framing */
static kf_camera shot_camera(const kf_shot *shot, const kf_render_opts *ro, double frame) {
    const float *lo = ro->lo, *hi = ro->hi;
    /* looking from the front right, above: view_dir points from the eye to the subject */
    float view[3] = {-0.55f, -0.45f, -1.0f}, fov = (float)shot->render_fov;
    kf_camera cam = ro->turntable_n > 0 ? kf_camera_turntable(lo, hi, ro->turntable_k, ro->turntable_n, 25.0f, fov)
                                        : kf_camera_frame_bounds(lo, hi, view, fov);
    if (ro->turntable_n == 0) fit_box(&cam, lo, hi, (float)ro->width / (float)ro->height);
    if (shot->ncamera_keys > 0 && ro->turntable_n == 0) {
        /* the keyed camera (render.camera_keys) */
        kf_camera_key keys[KF_MAX_KEYS];
        for (int k = 0; k < shot->ncamera_keys; k++) {
            keys[k].frame = shot->camera_keys[k].frame;
            for (int a = 0; a < 3; a++)
                keys[k].eye[a] = (float)shot->camera_keys[k].eye[a],
                keys[k].target[a] = (float)shot->camera_keys[k].target[a];
            keys[k].fov_deg = (float)(shot->camera_keys[k].fov > 0 ? shot->camera_keys[k].fov : shot->render_fov);
        }
        cam = kf_camera_keyed(keys, shot->ncamera_keys, frame, shot->render_interp);
    } else if (shot->render_eye_set && ro->turntable_n == 0) {
        /* the shot's camera; the target defaults to the framed centre */
        for (int a = 0; a < 3; a++) {
            cam.eye[a] = (float)shot->render_eye[a];
            if (shot->render_target_set) cam.target[a] = (float)shot->render_target[a];
        }
        cam.up[0] = 0, cam.up[1] = 1, cam.up[2] = 0;
    }
    return cam;
}

/* `path` with its extension replaced by ext (".exr") */
static void with_extension(const char *path, const char *ext, char *out, size_t n) {
    const char *dot = strrchr(path, '.'), *slash = strrchr(path, '/');
    size_t len = dot && (!slash || dot > slash) ? (size_t)(dot - path) : strlen(path);
    snprintf(out, n, "%.*s%s", (int)len, path, ext);
}

int kf_pipeline_render(const kf_shot *shot, const kf_scene *sc, const char *vdb, const char *png, int frame,
                       const kf_render_opts *ro, char *err, size_t errlen) {
    (void)sc;
    kf_vdb_file_info info;
    if (kf_vdb_info(vdb, &info, err, errlen)) return -1;
    const int want_png = shot->render_format != KF_FORMAT_EXR, want_exr = shot->render_format != KF_FORMAT_PNG;
    /* motion is needed by the EXR's vectors and by motion blur */
    const int want_motion = want_exr || shot->render_motion_blur > 0;
    const double dt = 1.0 / shot->fps;
    /* the group surfaces (surface_<name>) when the file has them, else `surface`
     * (files of kerf 0.1 held `surface` and `surface.<material>` both) */
    int use_groups = 0;
    for (int g = 0; g < info.ngrids; g++)
        use_groups |=
            strncmp(info.grids[g].name, "surface_", 8) == 0 || strncmp(info.grids[g].name, "surface.", 8) == 0;
    kf_vdb_trimesh meshes[KF_VDB_MAX_GRIDS];
    kf_render_mesh rm[KF_VDB_MAX_GRIDS];
    float *motion[KF_VDB_MAX_GRIDS + 2] = {0};
    const char *mesh_name[KF_VDB_MAX_GRIDS];
    int nm = 0, rc = -1;
    tri_soup soup = {0}, soup_next = {0};
    kf_rigid_drawing rigids = {0};
    for (int g = 0; g < info.ngrids && nm < KF_VDB_MAX_GRIDS; g++) {
        const char *name = info.grids[g].name;
        int group = strncmp(name, "surface_", 8) == 0 || strncmp(name, "surface.", 8) == 0;
        if (strcmp(info.grids[g].cls, "level set") != 0 || (use_groups ? !group : strcmp(name, "surface") != 0))
            continue;
        /* the level set this process just wrote to vdb, else the file's */
        kf_vdb_grid *ls = kf_surface_take(vdb, name);
        if (!ls && kf_vdb_read_levelset(vdb, name, &ls, NULL, err, errlen)) goto done;
        int mesh_rc = kf_vdb_mesh(ls, 0, 0, &meshes[nm], err, errlen);
        double voxel = kf_vdb_voxel_size(ls);
        kf_vdb_free(ls);
        if (mesh_rc) goto done;
        memset(&rm[nm], 0, sizeof rm[nm]);
        rm[nm].positions = meshes[nm].verts;
        rm[nm].normals = meshes[nm].normals;
        rm[nm].nverts = meshes[nm].nverts;
        rm[nm].tris = meshes[nm].tris;
        rm[nm].ntris = meshes[nm].ntris;
        rm[nm].closed = 1; /* a level set's zero set */
        surface_look(shot, name, &rm[nm].mat);
        /* ids: a surfaced group is 1 + its place in the shot's materials (or objects) */
        int gi = surface_index(shot, name);
        rm[nm].id = 1 + gi;
        mesh_name[nm] = shot->surface_group ? (gi < shot->nobjects ? shot->objects[gi].name : "object")
                                            : (gi < shot->nmaterials ? shot->materials[gi].mat.name : "material");
        nm++;
        if (want_motion && surface_motion(vdb, &info, name, &meshes[nm - 1], voxel, dt, &motion[nm - 1], err, errlen))
            goto done;
        rm[nm - 1].motion = motion[nm - 1];
    }
    /* the colliders at their pose for this frame, each in its colour: one
     * vertex soup, one render mesh per collider over its triangle range */
    double t = kf_shot_frame_time(shot, frame);
    size_t first_tri[KF_VDB_MAX_GRIDS + 1];
    int ncol = shot->ncolliders < KF_VDB_MAX_GRIDS - nm ? shot->ncolliders : KF_VDB_MAX_GRIDS - nm;
    for (int i = 0; i < ncol; i++) {
        first_tri[i] = soup.nt;
        if (collider_mesh(&shot->colliders[i], t, &soup, err, errlen) < 0) goto done;
        /* a frame later: the same vertices in the same order, moved */
        if (want_motion && collider_mesh(&shot->colliders[i], t + dt, &soup_next, err, errlen) < 0) goto done;
    }
    first_tri[ncol] = soup.nt;
    float *col_motion = NULL;
    if (want_motion && soup.nv > 0 && soup_next.nv == soup.nv) {
        if (!(col_motion = motion[KF_VDB_MAX_GRIDS] = malloc(sizeof(float) * 3 * soup.nv))) {
            snprintf(err, errlen, "out of memory for the colliders' motion");
            goto done;
        }
        for (size_t i = 0; i < 3 * soup.nv; i++) col_motion[i] = soup_next.pos[i] - soup.pos[i];
    }
    int nscene = nm;
    for (int i = 0; i < ncol; i++) {
        if (first_tri[i + 1] == first_tri[i]) continue; /* planes */
        mesh_name[nscene] = shot->colliders[i].name;
        kf_render_mesh *r = &rm[nscene++];
        memset(r, 0, sizeof *r);
        r->positions = soup.pos;
        r->nverts = soup.nv;
        r->tris = soup.tri + 3 * first_tri[i];
        r->ntris = first_tri[i + 1] - first_tri[i];
        r->motion = col_motion;
        r->id = 101 + i;
        for (int a = 0; a < 3; a++) r->mat.diffuse[a] = (float)shot->colliders[i].color[a];
        r->mat.specular = (float)shot->colliders[i].specular;
        r->mat.roughness = (float)shot->colliders[i].roughness;
    }
    /* the rigid bodies at their pose of this frame (rigid_draw.c) */
    if (kf_rigid_drawing_make(shot, sc, vdb, frame, &rigids, err, errlen)) goto done;
    int nrig = kf_rigid_drawing_meshes(shot, &rigids, rm + nscene, KF_VDB_MAX_GRIDS - nscene);
    if (want_motion && rigids.nv > 0) {
        float *rm_motion = motion[KF_VDB_MAX_GRIDS + 1] = malloc(sizeof(float) * 3 * rigids.nv);
        if (!rm_motion) {
            snprintf(err, errlen, "out of memory for the rigid bodies' motion");
            goto done;
        }
        for (size_t i = 0; i < 3 * rigids.nv; i++) rm_motion[i] = (float)(rigids.vel[i] * dt);
        for (int k = 0; k < nrig; k++) rm[nscene + k].motion = rm_motion;
    }
    /* rigid meshes come in body order, bodies without triangles skipped */
    for (int i = 0, k = 0; i < rigids.n && k < nrig; i++) {
        if (rigids.first[i + 1] == rigids.first[i]) continue;
        rm[nscene + k].id = 201 + i;
        mesh_name[nscene + k] = i < shot->nrigids ? shot->rigids[i].def.name : "rigid";
        k++;
    }
    nscene += nrig;
    kf_render_scene scene = kf_render_scene_default();
    scene.meshes = rm;
    scene.nmeshes = nscene;
    scene.ground = ro->ground;
    /* the shot's key, fill and rim lights (camera space: they follow the camera) */
    for (int a = 0; a < 3; a++) {
        scene.key_dir[a] = (float)shot->lights[0].dir[a];
        scene.key_color[a] = (float)(shot->lights[0].color[a] * shot->lights[0].intensity);
        scene.fill_dir[a] = (float)shot->lights[1].dir[a];
        scene.fill_color[a] = (float)(shot->lights[1].color[a] * shot->lights[1].intensity);
        scene.rim_dir[a] = (float)shot->lights[2].dir[a];
        scene.rim_color[a] = (float)(shot->lights[2].color[a] * shot->lights[2].intensity);
    }
    if (shot->sim.walls) scene.ground_y = (float)shot->sim.domain_min[1];
    /* a steady camera on what the options frame; a keyed one moves between frames */
    kf_camera cam = shot_camera(shot, ro, frame), cam_next = shot_camera(shot, ro, frame + 1.0);
    /* the context kept from the last frame, if any: making one and compiling
     * its shaders at the first draw cost about 0.13 CPU s a 1080p frame */
    kf_render_ctx *ctx = ro->keep ? *ro->keep : NULL;
    if (ro->keep) *ro->keep = NULL;
    if (!ctx) {
        if (!(ctx = kf_render_create(ro->width, ro->height, ro->samples, err, errlen))) goto done;
        /* the PNG's anti-aliasing: edges unless the shot asks for MSAA (without samples, none) */
        if (ro->samples > 1 && ro->antialias == 0 && kf_render_set_antialias(ctx, KF_RENDER_AA_EDGES, err, errlen)) {
            kf_render_destroy(ctx);
            goto done;
        }
        /* the preview's shadow map is at most ro->shadow (small images already have smaller ones) */
        if (ro->shadow > 0 && ro->shadow < kf_render_shadow_size(ctx) &&
            kf_render_set_shadow_size(ctx, ro->shadow, err, errlen)) {
            kf_render_destroy(ctx);
            goto done;
        }
    }
    const size_t npx = (size_t)ro->width * ro->height;
    uint8_t *rgba = want_png ? malloc(npx * 4) : NULL;
    kf_pipeline_aovs pa;
    if ((want_png && !rgba) || (want_exr && kf_pipeline_aovs_alloc(&pa, rm, mesh_name, nscene, npx) != 0)) {
        snprintf(err, errlen, "out of memory for a %dx%d image", ro->width, ro->height);
        free(rgba);
        kf_render_destroy(ctx);
        goto done;
    }
    char fr[32];
    snprintf(fr, sizeof fr, "%d", frame);
    const char *kv[] = {"shot", shot->name, "frame", fr, "Software", "kerf " KERF_VERSION};
    if (shot->render_motion_blur <= 0 && !want_exr) {
        /* the picture alone, as it always was */
        if (kf_render_frame(ctx, &scene, &cam, rgba, err, errlen) == 0) {
            if (kf_ensure_parent(png)) snprintf(err, errlen, "%s: cannot create directory: %s", png, strerror(errno));
            else rc = kf_png_write(png, rgba, ro->width, ro->height, kv, 3, err, errlen);
        }
    } else if (kf_render_frame_ex(ctx, &scene, &cam, &cam_next, (float)shot->render_motion_blur, rgba,
                                  want_exr ? &pa.aov : NULL, err, errlen) == 0) {
        char exr[4200];
        with_extension(png, ".exr", exr, sizeof exr);
        if (kf_ensure_parent(png)) snprintf(err, errlen, "%s: cannot create directory: %s", png, strerror(errno));
        else if (!want_png || kf_png_write(png, rgba, ro->width, ro->height, kv, 3, err, errlen) == 0) {
            const char *ekv[] = {"kerf.shot", shot->name, "kerf.frame", fr, "software", "kerf " KERF_VERSION};
            rc = want_exr ? kf_pipeline_aovs_write(&pa, exr, ro->width, ro->height, ekv, 3, err, errlen) : 0;
        }
    }
    if (want_exr) kf_pipeline_aovs_free(&pa);
    free(rgba);
    /* kept for the next frame only after a frame that went well */
    if (ro->keep && rc == 0) *ro->keep = ctx;
    else kf_render_destroy(ctx);
done:
    for (int i = 0; i < nm; i++) kf_vdb_mesh_free(&meshes[i]);
    for (int i = 0; i < KF_VDB_MAX_GRIDS + 2; i++) free(motion[i]);
    free(soup.pos);
    free(soup.tri);
    free(soup_next.pos);
    free(soup_next.tri);
    kf_rigid_drawing_free(&rigids);
    return rc;
}
