/* sample.c — seed particles in placed shapes (see sample.h).
 *
 * The candidate lattice covers the shape's world bounding box and is visited
 * in blocks of 4³ points, a few x-layers of blocks at a time (so memory is
 * about 2 MB of flags, not one byte per candidate of the whole box). For a mesh, blocks that no triangle's
 * bounding box touches lie wholly inside or wholly outside, so one inside
 * test decides the whole block; only blocks near the surface test each point.
 * The output order is block order, fixed for a given def whatever the thread
 * count. */
#include "../core/euler.h"
#include "sample.h"
#include "mesh_isect.h"

#include <math.h>
#include <omp.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define BLOCK 4
#define BLOCK3 (BLOCK * BLOCK * BLOCK)

kf_sample_def kf_default_sample_def(void) {
    kf_sample_def d;
    memset(&d, 0, sizeof d);
    d.ppc = 8;
    for (int k = 0; k < 3; k++) d.place.scale[k] = 1;
    return d;
}

void kf_points_free(kf_points *p) {
    if (!p) return;
    free(p->x);
    free(p->v);
    memset(p, 0, sizeof *p);
}

/* ---- problems, collected ---------------------------------------------------- */

typedef struct problems {
    char *err;
    size_t len;
    int count;
} problems;

static void problem(problems *p, const char *fmt, ...) {
    if (p->err && p->len) {
        size_t used = p->count ? strlen(p->err) : 0;
        if (used + 3 < p->len) {
            int k = p->count ? snprintf(p->err + used, p->len - used, "; ") : snprintf(p->err, p->len, "sample: ");
            used += (size_t)k;
            va_list ap;
            va_start(ap, fmt);
            if (used < p->len) vsnprintf(p->err + used, p->len - used, fmt, ap);
            va_end(ap);
        }
    }
    p->count++;
}

static int ppc_axis(int ppc) {
    switch (ppc == 0 ? 8 : ppc) {
    case 1: return 1;
    case 8: return 2;
    case 27: return 3;
    case 64: return 4;
    default: return 0;
    }
}

static int check_def(const kf_sample_def *d, char *err, size_t errlen) {
    problems p = {err, errlen, 0};
    if ((int)d->kind < 0 || d->kind >= KF_SOURCE_KIND_COUNT) problem(&p, "unknown shape kind %d", (int)d->kind);
    if (!(d->dx > 0) || !isfinite(d->dx)) problem(&p, "dx must be > 0 (got %g)", d->dx);
    if (!ppc_axis(d->ppc)) problem(&p, "ppc must be 1, 8, 27 or 64 particles per cell (got %d)", d->ppc);
    if (d->kind == KF_SOURCE_BOX)
        for (int k = 0; k < 3; k++)
            if (!(d->size[k] > 0) || !isfinite(d->size[k]))
                problem(&p, "box size[%d] must be > 0 (got %g)", k, d->size[k]);
    if ((d->kind == KF_SOURCE_SPHERE || d->kind == KF_SOURCE_CYLINDER) && !(d->radius > 0 && isfinite(d->radius)))
        problem(&p, "radius must be > 0 (got %g)", d->radius);
    if (d->kind == KF_SOURCE_CYLINDER && !(d->height > 0 && isfinite(d->height)))
        problem(&p, "cylinder height must be > 0 (got %g)", d->height);
    if (d->kind == KF_SOURCE_MESH && !d->mesh && !(d->mesh_path && d->mesh_path[0]))
        problem(&p, "a mesh source needs a mesh or a mesh path");
    for (int k = 0; k < 3; k++) {
        if (!isfinite(d->place.scale[k])) problem(&p, "scale[%d] must be finite (got %g)", k, d->place.scale[k]);
        if (!isfinite(d->place.rotate[k])) problem(&p, "rotate[%d] must be finite (got %g)", k, d->place.rotate[k]);
        if (!isfinite(d->place.translate[k]))
            problem(&p, "translate[%d] must be finite (got %g)", k, d->place.translate[k]);
        if (!isfinite(d->velocity[k]) || !isfinite(d->angular_velocity[k]))
            problem(&p, "velocity and angular_velocity must be finite");
    }
    if (d->emit && !kf_sample_can_emit(d))
        problem(&p, "points can be handed over as they come only without angular velocity and without -0 in velocity");
    if (d->place.fit && !(d->place.fit_size > 0 && isfinite(d->place.fit_size)))
        problem(&p, "fit size must be > 0 (got %g)", d->place.fit_size);
    if (d->place.fit)
        for (int k = 0; k < 3; k++)
            if (!isfinite(d->place.fit_center[k]))
                problem(&p, "fit center[%d] must be finite (got %g)", k, d->place.fit_center[k]);
    return p.count ? -1 : 0;
}

/* ---- placement ---------------------------------------------------------------- */

int kf_sample_placement(const kf_sample_def *def, const kf_mesh *mesh, double M[12], double lo[3], double hi[3],
                        char *err, size_t errlen) {
    const kf_placement *pl = &def->place;
    double R[9], A[9];
    kf_euler_matrix(pl->rotate, R);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) A[3 * i + j] = R[3 * i + j] * (pl->scale[j] != 0 ? pl->scale[j] : 1.0);
    /* bounds of the shape under A (before translation / fit) */
    double blo[3], bhi[3];
    switch (def->kind) {
    case KF_SOURCE_BOX:
        for (int i = 0; i < 3; i++) {
            double e = 0;
            for (int j = 0; j < 3; j++) e += fabs(A[3 * i + j]) * 0.5 * def->size[j];
            blo[i] = -e, bhi[i] = e;
        }
        break;
    case KF_SOURCE_SPHERE:
        for (int i = 0; i < 3; i++) {
            double e =
                def->radius * sqrt(A[3 * i] * A[3 * i] + A[3 * i + 1] * A[3 * i + 1] + A[3 * i + 2] * A[3 * i + 2]);
            blo[i] = -e, bhi[i] = e;
        }
        break;
    case KF_SOURCE_CYLINDER:
        for (int i = 0; i < 3; i++) {
            double e = fabs(A[3 * i + 1]) * 0.5 * def->height +
                       def->radius * sqrt(A[3 * i] * A[3 * i] + A[3 * i + 2] * A[3 * i + 2]);
            blo[i] = -e, bhi[i] = e;
        }
        break;
    case KF_SOURCE_MESH:
        if (!mesh || mesh->nvert == 0) {
            snprintf(err, errlen, "sample: the mesh source has no mesh");
            return -1;
        }
        for (int i = 0; i < 3; i++) blo[i] = INFINITY, bhi[i] = -INFINITY;
        for (size_t v = 0; v < mesh->nvert; v++) {
            const double *p = &mesh->vert[3 * v];
            for (int i = 0; i < 3; i++) {
                double x = A[3 * i] * p[0] + A[3 * i + 1] * p[1] + A[3 * i + 2] * p[2];
                if (x < blo[i]) blo[i] = x;
                if (x > bhi[i]) bhi[i] = x;
            }
        }
        break;
    default: snprintf(err, errlen, "sample: unknown shape kind %d", (int)def->kind); return -1;
    }
    double s = 1, t[3];
    if (pl->fit) {
        double ext = 0;
        for (int i = 0; i < 3; i++)
            if (bhi[i] - blo[i] > ext) ext = bhi[i] - blo[i];
        if (!(ext > 0)) {
            snprintf(err, errlen, "sample: cannot fit a shape of zero size");
            return -1;
        }
        s = pl->fit_size / ext;
        for (int i = 0; i < 3; i++) t[i] = pl->fit_center[i] - s * 0.5 * (blo[i] + bhi[i]);
    } else {
        for (int i = 0; i < 3; i++) t[i] = pl->translate[i];
    }
    for (int i = 0; i < 3; i++) {
        for (int j = 0; j < 3; j++) M[4 * i + j] = s * A[3 * i + j];
        M[4 * i + 3] = t[i];
        lo[i] = t[i] + s * blo[i];
        hi[i] = t[i] + s * bhi[i];
    }
    double det =
        A[0] * (A[4] * A[8] - A[5] * A[7]) - A[1] * (A[3] * A[8] - A[5] * A[6]) + A[2] * (A[3] * A[7] - A[4] * A[6]);
    if (!(fabs(det) > 0) || !isfinite(det)) {
        snprintf(err, errlen, "sample: the placement is singular (a zero scale?)");
        return -1;
    }
    return 0;
}

/* inverse of the 3x3 part of a 3x4 map */
static void inverse3(const double M[12], double I[9]) {
    double a = M[0], b = M[1], c = M[2], d = M[4], e = M[5], f = M[6], g = M[8], h = M[9], k = M[10];
    double det = a * (e * k - f * h) - b * (d * k - f * g) + c * (d * h - e * g), r = 1.0 / det;
    I[0] = (e * k - f * h) * r, I[1] = (c * h - b * k) * r, I[2] = (b * f - c * e) * r;
    I[3] = (f * g - d * k) * r, I[4] = (a * k - c * g) * r, I[5] = (c * d - a * f) * r;
    I[6] = (d * h - e * g) * r, I[7] = (b * g - a * h) * r, I[8] = (a * e - b * d) * r;
}

/* ---- the lattice ---------------------------------------------------------------- */

typedef struct lattice {
    double h;
    int64_t i0[3], n[3]; /* first index and count per axis */
    int64_t nb[3];       /* blocks per axis */
    uint32_t seed;
} lattice;

static inline uint64_t mix64(uint64_t z) {
    z += 0x9e3779b97f4a7c15ull;
    z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
    z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
    return z ^ (z >> 31);
}

/* the candidate with global lattice index (i, j, k) */
static inline void lattice_point(const lattice *L, int64_t i, int64_t j, int64_t k, double q[3]) {
    if (!L->seed) {
        q[0] = ((double)i + 0.5) * L->h, q[1] = ((double)j + 0.5) * L->h, q[2] = ((double)k + 0.5) * L->h;
        return;
    }
    uint64_t z = mix64(mix64(mix64(L->seed ^ ((uint64_t)i * 0x100000001b3ull)) ^ (uint64_t)j) ^ ((uint64_t)k << 1));
    const double s = 1.0 / 2097152.0; /* 21 bits per axis */
    q[0] = ((double)i + (double)(z & 0x1fffff) * s) * L->h;
    q[1] = ((double)j + (double)((z >> 21) & 0x1fffff) * s) * L->h;
    q[2] = ((double)k + (double)((z >> 42) & 0x1fffff) * s) * L->h;
}

/* the shape's own inside test */
typedef struct shape_ctx {
    kf_source_kind kind;
    double inv[9], t[3]; /* world -> local: inv (x - t) */
    double half[3], r2, hh;
    const kf_mesh_inside *mesh;
} shape_ctx;

static inline int inside_analytic(const shape_ctx *s, const double q[3]) {
    double d[3] = {q[0] - s->t[0], q[1] - s->t[1], q[2] - s->t[2]}, x[3];
    for (int i = 0; i < 3; i++) x[i] = s->inv[3 * i] * d[0] + s->inv[3 * i + 1] * d[1] + s->inv[3 * i + 2] * d[2];
    switch (s->kind) {
    case KF_SOURCE_BOX: /* half-open, like kf_state_fill_box */
        return x[0] >= -s->half[0] && x[0] < s->half[0] && x[1] >= -s->half[1] && x[1] < s->half[1] &&
               x[2] >= -s->half[2] && x[2] < s->half[2];
    case KF_SOURCE_SPHERE: return x[0] * x[0] + x[1] * x[1] + x[2] * x[2] < s->r2;
    case KF_SOURCE_CYLINDER: return x[1] >= -s->hh && x[1] < s->hh && x[0] * x[0] + x[2] * x[2] < s->r2;
    default: return 0;
    }
}

/* blocks that a triangle's bounding box touches (mesh sources) */
static uint8_t *mark_surface_blocks(const lattice *L, const kf_mesh *m) {
    size_t nblocks = (size_t)(L->nb[0] * L->nb[1] * L->nb[2]);
    uint8_t *mark = calloc(nblocks ? nblocks : 1, 1);
    if (!mark) return NULL;
    for (size_t t = 0; t < m->ntri; t++) {
        int64_t b0[3], b1[3];
        for (int a = 0; a < 3; a++) {
            double tlo = INFINITY, thi = -INFINITY;
            for (int c = 0; c < 3; c++) {
                double x = m->vert[3 * (size_t)m->tri[3 * t + c] + a];
                tlo = x < tlo ? x : tlo;
                thi = x > thi ? x : thi;
            }
            /* sub-cells [i h, (i+1) h) the box can touch, one more each side for rounding */
            int64_t ia = (int64_t)floor(tlo / L->h) - 1 - L->i0[a], ib = (int64_t)floor(thi / L->h) + 1 - L->i0[a];
            if (ia < 0) ia = 0;
            if (ib > L->n[a] - 1) ib = L->n[a] - 1;
            b0[a] = ia / BLOCK, b1[a] = ib / BLOCK;
        }
        for (int64_t x = b0[0]; x <= b1[0]; x++)
            for (int64_t y = b0[1]; y <= b1[1]; y++)
                for (int64_t z = b0[2]; z <= b1[2]; z++) mark[(x * L->nb[1] + y) * L->nb[2] + z] = 1;
    }
    return mark;
}

/* append with doubling */
typedef struct growing {
    double *x;
    size_t n, cap;
} growing;

static int push(growing *g, const double q[3]) {
    if (g->n == g->cap) {
        size_t cap = g->cap ? 2 * g->cap : 4096;
        double *nx = realloc(g->x, cap * 3 * sizeof *nx);
        if (!nx) return -1;
        g->x = nx, g->cap = cap;
    }
    memcpy(&g->x[3 * g->n++], q, 3 * sizeof *q);
    return 0;
}

/* where the points inside go: kept (all, or those def.keep says), and
 * summed for the centroid, all of them in output order; with emit, handed
 * over a chunk at a time (out then holds one chunk) */
typedef struct sink {
    int (*keep)(void *ctx, const double x[3]);
    void *ctx;
    double sum[3];
    size_t whole;
    int (*emit)(void *ctx, const double *x, const double *v, size_t n, double volume, size_t most);
    void *emit_ctx;
    const double *v; /* a chunk of v0 (NULL at rest) */
    double volume;
    size_t most;
    size_t emitted;
} sink;

/* the chunk in out to emit, and out emptied */
static int flush(sink *to, growing *out) {
    if (!to->emit || !out->n) return 0;
    if (to->emit(to->emit_ctx, out->x, to->v, out->n, to->volume, to->most)) return -1;
    to->emitted += out->n;
    out->n = 0;
    return 0;
}

int kf_sample_can_emit(const kf_sample_def *def) {
    for (int a = 0; a < 3; a++)
        if (def->angular_velocity[a] != 0 || (def->velocity[a] == 0 && signbit(def->velocity[a]))) return 0;
    return 1;
}

static int seed_lattice(const lattice *L, const shape_ctx *S, const uint8_t *mark, int threads, growing *out, sink *to,
                        kf_sample_stats *st) {
    const size_t layer = (size_t)(L->nb[1] * L->nb[2]);
    /* several x-layers of blocks per parallel region (about 2 MB of flags),
     * so threads meet at few barriers: on a shared machine each barrier can
     * cost a scheduler time slice */
    int64_t group = (int64_t)((2u << 20) / (layer * BLOCK3));
    if (group < 1) group = 1;
    if (group > L->nb[0]) group = L->nb[0];
    uint8_t *flags = malloc((size_t)group * layer * BLOCK3);
    if (!flags) return -1;
    int nt = threads > 0 ? threads : omp_get_max_threads();
    long tested = 0, rays = 0, unrel = 0, undec = 0;
    for (int64_t bx0 = 0; bx0 < L->nb[0]; bx0 += group) {
        const int64_t nlayers = bx0 + group <= L->nb[0] ? group : L->nb[0] - bx0;
        const size_t nblk = (size_t)nlayers * layer;
#pragma omp parallel num_threads(nt) reduction(+ : tested, rays, unrel, undec)
        {
            kf_inside_stats ist = {0};
#pragma omp for schedule(dynamic, 8)
            for (size_t bi = 0; bi < nblk; bi++) {
                int64_t bx = bx0 + (int64_t)(bi / layer);
                size_t bl = bi % layer;
                int64_t by = (int64_t)bl / L->nb[2], bz = (int64_t)bl % L->nb[2];
                uint8_t *f = &flags[bi * BLOCK3];
                int64_t base[3] = {L->i0[0] + bx * BLOCK, L->i0[1] + by * BLOCK, L->i0[2] + bz * BLOCK};
                int whole = -1; /* mesh block away from the surface: one answer for all */
                if (S->mesh && !mark[(size_t)bx * layer + bl]) {
                    double c[3];
                    for (int a = 0; a < 3; a++) c[a] = ((double)base[a] + 0.5 * BLOCK) * L->h;
                    whole = kf_mesh_inside_point(S->mesh, c, &ist);
                    tested++;
                }
                for (int l = 0; l < BLOCK3; l++) {
                    int lx = l / (BLOCK * BLOCK), ly = (l / BLOCK) % BLOCK, lz = l % BLOCK;
                    int64_t g[3] = {base[0] + lx, base[1] + ly, base[2] + lz};
                    if (g[0] - L->i0[0] >= L->n[0] || g[1] - L->i0[1] >= L->n[1] || g[2] - L->i0[2] >= L->n[2]) {
                        f[l] = 0;
                        continue;
                    }
                    if (whole >= 0) {
                        f[l] = (uint8_t)whole;
                        continue;
                    }
                    double q[3];
                    lattice_point(L, g[0], g[1], g[2], q);
                    if (S->mesh) {
                        f[l] = (uint8_t)kf_mesh_inside_point(S->mesh, q, &ist);
                        tested++;
                    } else {
                        f[l] = (uint8_t)inside_analytic(S, q);
                    }
                }
            }
            rays += ist.rays, unrel += ist.unreliable, undec += ist.undecided;
        }
        /* compact in block order */
        for (size_t bi = 0; bi < nblk; bi++) {
            int64_t bx = bx0 + (int64_t)(bi / layer);
            size_t bl = bi % layer;
            int64_t by = (int64_t)bl / L->nb[2], bz = (int64_t)bl % L->nb[2];
            const uint8_t *f = &flags[bi * BLOCK3];
            for (int l = 0; l < BLOCK3; l++) {
                if (!f[l]) continue;
                int lx = l / (BLOCK * BLOCK), ly = (l / BLOCK) % BLOCK, lz = l % BLOCK;
                double q[3];
                lattice_point(L, L->i0[0] + bx * BLOCK + lx, L->i0[1] + by * BLOCK + ly, L->i0[2] + bz * BLOCK + lz, q);
                for (int a = 0; a < 3; a++) to->sum[a] += q[a];
                to->whole++;
                if ((!to->keep || to->keep(to->ctx, q)) && push(out, q)) return free(flags), -1;
                if (to->emit && out->n == KF_SAMPLE_EMIT_CHUNK && flush(to, out)) return free(flags), -1;
            }
        }
    }
    free(flags);
    if (flush(to, out)) return -1;
    st->tested = tested;
    st->inside.points = tested;
    st->inside.rays = rays;
    st->inside.unreliable = unrel;
    st->inside.undecided = undec;
    return 0;
}

int kf_sample_shape(const kf_sample_def *def, kf_points *out, char *err, size_t errlen) {
    memset(out, 0, sizeof *out);
    if (err && errlen) err[0] = 0;
    if (check_def(def, err, errlen)) return -1;
    double t_start = omp_get_wtime();

    /* the mesh, loaded and checked */
    kf_mesh loaded = {0}, world = {0};
    const kf_mesh *mesh = NULL;
    if (def->kind == KF_SOURCE_MESH) {
        if (def->mesh) {
            mesh = def->mesh;
        } else {
            if (kf_mesh_load(def->mesh_path, &loaded, err, errlen)) return -1;
            mesh = &loaded;
        }
        /* a solid to fill: closed, and bounding its inside once (in the
         * file's coordinates, before it is placed) */
        if (kf_mesh_check_closed(mesh, err, errlen) ||
            kf_mesh_check_self_intersection(mesh, def->threads, err, errlen)) {
            kf_mesh_free(&loaded);
            return -1;
        }
    }
    double M[12], lo[3], hi[3];
    if (kf_sample_placement(def, mesh, M, lo, hi, err, errlen)) {
        kf_mesh_free(&loaded);
        return -1;
    }

    shape_ctx S;
    memset(&S, 0, sizeof S);
    S.kind = def->kind;
    inverse3(M, S.inv);
    for (int k = 0; k < 3; k++) S.t[k] = M[4 * k + 3], S.half[k] = 0.5 * def->size[k];
    S.r2 = def->radius * def->radius;
    S.hh = 0.5 * def->height;
    kf_mesh_inside *q = NULL;
    if (mesh) {
        int bad = kf_mesh_copy(mesh, &world);
        if (bad) snprintf(err, errlen, "%s: out of memory", mesh->path);
        kf_mesh_free(&loaded);
        if (bad) return -1;
        kf_mesh_transform(&world, M);
        q = kf_mesh_inside_create(&world, NULL, 0, err, errlen);
        if (!q) {
            kf_mesh_free(&world);
            return -1;
        }
        S.mesh = q;
    }

    /* the lattice over the bounding box */
    lattice L;
    const int n = ppc_axis(def->ppc);
    L.h = def->dx / n;
    L.seed = def->seed;
    double total = 1;
    for (int a = 0; a < 3; a++) {
        L.i0[a] = (int64_t)floor(lo[a] / L.h);
        L.n[a] = (int64_t)ceil(hi[a] / L.h) - L.i0[a];
        if (L.n[a] < 1) L.n[a] = 1;
        L.nb[a] = (L.n[a] + BLOCK - 1) / BLOCK;
        total *= (double)L.n[a];
    }
    int rc = 0;
    growing g = {0};
    uint8_t *mark = NULL;
    if (total > 4e9) {
        snprintf(err, errlen, "sample: %.3g candidate points (bounding box / (dx / %d)³) is too many", total, n);
        rc = -1;
        goto done;
    }
    out->stats.candidates = (long)total;
    if (mesh && !(mark = mark_surface_blocks(&L, &world))) {
        snprintf(err, errlen, "sample: out of memory");
        rc = -1;
        goto done;
    }
    sink to = {def->keep, def->keep_ctx, {0, 0, 0}, 0, def->emit, def->emit_ctx, NULL, 0, 0, 0};
    to.volume = def->dx * def->dx * def->dx / (n * n * n);
    to.most = (size_t)total;
    /* emitting: a chunk of velocities, all v0 (none at rest) */
    const double *v0 = def->velocity, *w = def->angular_velocity;
    int still = 1;
    for (int a = 0; a < 3; a++) still &= !signbit(v0[a]) && v0[a] == 0 && !signbit(w[a]) && w[a] == 0;
    double *vchunk = NULL;
    if (def->emit && !still) {
        if (!(vchunk = malloc(KF_SAMPLE_EMIT_CHUNK * 3 * sizeof *vchunk))) {
            snprintf(err, errlen, "sample: out of memory");
            rc = -1;
            goto done;
        }
        for (size_t k = 0; k < KF_SAMPLE_EMIT_CHUNK; k++) memcpy(&vchunk[3 * k], v0, 3 * sizeof *v0);
        to.v = vchunk;
    }
    if (seed_lattice(&L, &S, mark, def->threads, &g, &to, &out->stats)) {
        free(vchunk);
        snprintf(err, errlen, "sample: out of memory (%zu particles so far)", to.emitted + g.n);
        rc = -1;
        goto done;
    }
    free(vchunk);

    /* velocities: v0 + ω × (x − centroid); a shape at rest (all +0) gets
     * none: every one would be +0, and the array was a sixth of a large
     * scene's seeding peak */
    if (def->emit) {
        /* handed over already */
        out->n = to.emitted;
        out->whole = to.whole;
        memcpy(out->lo, lo, sizeof out->lo);
        memcpy(out->hi, hi, sizeof out->hi);
        for (int a = 0; a < 3; a++) out->centroid[a] = to.whole ? to.sum[a] / (double)to.whole : 0.5 * (lo[a] + hi[a]);
        out->volume = to.volume;
        out->stats.seconds = omp_get_wtime() - t_start;
        goto done;
    }
    out->n = g.n;
    out->x = g.x ? g.x : malloc(3 * sizeof *out->x);
    g.x = NULL;
    out->v = still ? NULL : malloc((out->n ? out->n : 1) * 3 * sizeof *out->v);
    if (!out->x || (!still && !out->v)) {
        kf_points_free(out);
        snprintf(err, errlen, "sample: out of memory");
        rc = -1;
        goto done;
    }
    /* the centroid of every point, summed in output order as they came */
    double c[3];
    out->whole = to.whole;
    for (int a = 0; a < 3; a++) c[a] = to.whole ? to.sum[a] / (double)to.whole : 0.5 * (lo[a] + hi[a]);
    for (size_t i = 0; i < out->n && !still; i++) {
        double r[3] = {out->x[3 * i] - c[0], out->x[3 * i + 1] - c[1], out->x[3 * i + 2] - c[2]};
        out->v[3 * i + 0] = v0[0] + w[1] * r[2] - w[2] * r[1];
        out->v[3 * i + 1] = v0[1] + w[2] * r[0] - w[0] * r[2];
        out->v[3 * i + 2] = v0[2] + w[0] * r[1] - w[1] * r[0];
    }
    memcpy(out->centroid, c, sizeof c);
    memcpy(out->lo, lo, sizeof out->lo);
    memcpy(out->hi, hi, sizeof out->hi);
    out->volume = def->dx * def->dx * def->dx / (n * n * n);
    out->stats.seconds = omp_get_wtime() - t_start;
done:
    free(g.x);
    free(mark);
    kf_mesh_inside_destroy(q);
    kf_mesh_free(&world);
    return rc;
}
