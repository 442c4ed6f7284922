/* state.c — particles in, diagnostics out: creation, seeding, energy, hash. */
#include <math.h>
#ifdef __GLIBC__
#include <malloc.h>
#endif
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../core/fnv.h"
#include "../core/mat3.h"
#include "cpic_seam.h"
#include "model.h"
#include "../dist/dist.h"

/* rigid bodies at time 0 and their solver (none without rigid bodies) */
static int rigid_init(kf_state *s, const kf_model *m) {
    s->nrigid = m->nrigid;
    if (!m->nrigid) return 0;
    for (int r = 0; r < m->nrigid; r++) kf_rigid_state_at(&m->rigid[r], 0, &s->rigid[r]);
    double walls[6];
    for (int a = 0; a < 3; a++) walls[a] = m->sim.domain_min[a], walls[3 + a] = m->sim.domain_max[a];
    char err[256];
    s->rsim = kf_rigid_sim_create(m->rigid, m->nrigid, m->joint, m->njoint, m->sim.gravity, m->sim.walls ? walls : NULL,
                                  err, sizeof err);
    return s->rsim ? 0 : -1;
}

/* Blocks of a megabyte or more come straight from the system and go back
 * to it when freed. glibc's threshold otherwise rises (to 32 MB) each time
 * such a block is freed, after which the seeding's and the substeps'
 * scratch is carved from the heap and stays resident once freed: the peak
 * then depends on which scratch the heap still holds (bunny_split at
 * Δx 0.0033: 400 or 415 MB for the same state, 374 with the threshold
 * fixed). The setting is the process's; results do not depend on it. */
static void heap_policy(void) {
#ifdef __GLIBC__
    mallopt(M_MMAP_THRESHOLD, 1 << 20);
#endif
}

kf_state *kf_state_create(const kf_model *m) {
    heap_policy();
    kf_state *s = calloc(1, sizeof(kf_state));
    if (s && rigid_init(s, m)) {
        kf_state_destroy(s);
        return NULL;
    }
    /* the arrays this model never writes start (and stay) untouched zeros */
    if (s) s->p.zero = kf_model_zero_arrays(m);
    return s;
}

void kf_contact_free(struct kf_contact *c);

void kf_state_destroy(kf_state *s) {
    if (!s) return;
    kf_rigid_sim_destroy(s->rsim);
    free(s->snapshot_rsim);
    kf_cpic_free(s->cpic);
    kf_contact_free(s->contact);
    free(s->mid_dv);
    free(s->poly);
    free(s->snapshot_poly);
    kf_particles_free(&s->p);
    kf_particles_free(&s->snapshot);
    if (s->spill) fclose(s->spill);
    kf_grid_free(&s->g);
    kf_dist_free(s->dist);
    free(s);
}

void kf_state_copy(kf_state *dst, const kf_state *src) {
    kf_particles_copy(&dst->p, &src->p);
    /* an early P2G pending in src (step.c): the copy gets the colours it started from */
    if (dst->p.colour) kf_cpic_early_colours(src, dst->p.colour);
    dst->time = src->time;
    dst->substep = src->substep;
    dst->next_id = src->next_id;
    dst->tau_valid = src->tau_valid;
    dst->stress_model = src->stress_model;
    kf_grid_invalidate(&dst->g);
    /* polypic's modes, per id */
    if (src->poly_cap && kf_poly_reserve(dst) == 0) {
        size_t n = src->poly_cap < dst->poly_cap ? src->poly_cap : dst->poly_cap;
        memcpy(dst->poly, src->poly, n * KF_POLY_REALS * sizeof *src->poly);
    }
    /* rigid bodies: both states come from the same model */
    dst->nrigid = src->nrigid;
    memcpy(dst->rigid, src->rigid, sizeof dst->rigid);
    if (src->rsim && dst->rsim) {
        size_t n = kf_rigid_sim_state_size(src->rsim);
        void *buf = malloc(n ? n : 1);
        if (buf) {
            kf_rigid_sim_save(src->rsim, buf);
            kf_rigid_sim_load(dst->rsim, buf, n);
            free(buf);
        }
    }
}

kf_state *kf_state_clone(const kf_state *s) {
    kf_state *c = calloc(1, sizeof *c);
    if (!c) return NULL;
    if (s->rsim) {
        /* a solver of the same shape: created from the blob of the source */
        c->rsim = kf_rigid_sim_clone(s->rsim);
        if (!c->rsim) {
            free(c);
            return NULL;
        }
    }
    kf_state_copy(c, s);
    return c;
}

kf_rigid_pose kf_state_rigid(const kf_state *s, int body) {
    kf_rigid_pose p;
    memset(&p, 0, sizeof p);
    if (body < 0 || body >= s->nrigid) return p;
    const kf_rigid_state *r = &s->rigid[body];
    memcpy(p.R, r->R, sizeof p.R);
    memcpy(p.t, r->t, sizeof p.t);
    memcpy(p.com, r->com, sizeof p.com);
    memcpy(p.v, r->v, sizeof p.v);
    memcpy(p.omega, r->w, sizeof p.omega);
    return p;
}

int kf_state_joint_torque(const kf_state *s, int joint, double *now, double *peak) {
    return kf_rigid_sim_motor_torque(s->rsim, joint, now, peak);
}
void kf_state_joint_peak_reset(kf_state *s) { kf_rigid_sim_peak_reset(s->rsim); }

void kf_state_fuse_next(kf_state *s, double next_dt) { s->fuse_next = next_dt > 0 ? next_dt : 0; }

size_t kf_state_count(const kf_state *s) { return s->p.n; }
double kf_state_time(const kf_state *s) { return s->time; }

kf_particles_view kf_state_particles(kf_state *s) {
    /* the caller may write F or ps: the cached stress must be recomputed,
     * and no array is known to hold only zeros any more (kf_advance finds
     * the ones that still do) */
    s->tau_valid = 0;
    s->p.zero = 0;
    /* an early P2G's colours (step.c) back first: the caller sees and edits the substep's own */
    kf_cpic_early_undo(s);
    return kf_state_particles_read(s);
}

kf_particles_view kf_state_particles_read(const kf_state *s) {
    kf_particles_view v;
    const kf_particles *p = &s->p;
    v.n = p->n;
    for (int k = 0; k < 3; k++) v.x[k] = p->x[k], v.v[k] = p->v[k];
    for (int k = 0; k < 9; k++) v.C[k] = p->C[k], v.F[k] = p->F[k];
    v.mass = p->mass;
    v.vol0 = p->vol0;
    v.ps[0] = p->ps[0];
    v.ps[1] = p->ps[1];
    v.mat = p->mat;
    v.id = p->id;
    v.obj = p->obj;
    v.colour = p->colour;
    return v;
}

long kf_state_add_particles(kf_state *s, const kf_model *m, size_t n, const double *x3, const double *v3,
                            const double *F9, int material, double volume) {
    if (material < 0 || material >= m->nmat) return -1;
    kf_particles *p = &s->p;
    if (kf_particles_reserve(p, p->n + n)) return -1;
    const kf_mat *mat = &m->mat[material];
    size_t first = p->n;
    for (size_t k = 0; k < n; k++) {
        size_t i = first + k;
        for (int a = 0; a < 3; a++) {
            p->x[a][i] = (kf_real)x3[3 * k + a];
            p->v[a][i] = v3 ? (kf_real)v3[3 * k + a] : 0;
        }
        for (int e = 0; e < 9; e++) {
            p->C[e][i] = 0;
            p->F[e][i] = F9 ? (kf_real)F9[9 * k + e] : (kf_real)(e % 4 == 0);
        }
        p->vol0[i] = (kf_real)volume;
        p->mass[i] = (kf_real)(volume * mat->rho);
        /* plastic state starts at rest: water J (from F if given), snow Jp = 1 */
        kf_real ps0 = 0;
        if (mat->model == KF_MAT_WATER) {
            kf_real F[9];
            for (int e = 0; e < 9; e++) F[e] = p->F[e][i];
            ps0 = kf_m3_det(F);
            for (int e = 0; e < 9; e++) p->F[e][i] = (kf_real)(e % 4 == 0);
        } else if (mat->model == KF_MAT_SNOW) {
            ps0 = 1;
        }
        if (ps0 != 0) p->zero &= ~KF_ZERO_PS; /* water's J, snow's Jp: not zero any more */
        if (!(p->zero & KF_ZERO_PS)) p->ps[0][i] = ps0, p->ps[1][i] = 0;
        if (material) p->zero &= ~KF_ZERO_MAT; /* a second material (the model's table allows it) */
        if (!(p->zero & KF_ZERO_MAT)) p->mat[i] = (uint16_t)material;
        if (!(p->zero & KF_ZERO_OBJ)) p->obj[i] = 0;
        if (!(p->zero & KF_ZERO_COLOUR)) p->colour[i] = 0;
        p->id[i] = s->next_id++;
        /* the stress planes until kf_stress fills them: the first frame's
         * checkpoint holds them and must not depend on the heap (zero arrays
         * where the stress is not kept) */
        for (int e = 0; e < 6 && !(p->zero & KF_ZERO_TAU); e++) p->tau[e][i] = 0;
    }
    p->n += n;
    s->g.valid = 0;
    s->tau_valid = 0;
    return (long)first;
}

/* small deterministic generator for jittered seeding */
static double jitter(uint32_t *st) {
    *st ^= *st << 13;
    *st ^= *st >> 17;
    *st ^= *st << 5;
    return (*st >> 8) * (1.0 / 16777216.0);
}

typedef int (*inside_fn)(const double x[3], const void *ctx);

/* seed ppc³ particles per grid cell over [lo, hi], keeping those inside;
 * they go into the state a chunk at a time (the same order and ids as all
 * at once), so the candidates in doubles never sit beside the whole state */
#define FILL_CHUNK 65536
static long fill(kf_state *s, const kf_model *m, const double lo[3], const double hi[3], inside_fn inside,
                 const void *ctx, int material, const double v[3], int ppc, uint32_t seed) {
    double dx = m->sim.dx, h = dx / ppc;
    long i0[3], i1[3];
    for (int a = 0; a < 3; a++) {
        i0[a] = (long)floor(lo[a] / h);
        i1[a] = (long)ceil(hi[a] / h);
    }
    if (material < 0 || material >= m->nmat) return -1;
    size_t n = 0;
    long first = -1;
    double *x = malloc(FILL_CHUNK * 3 * sizeof *x), *vel = v ? malloc(FILL_CHUNK * 3 * sizeof *vel) : NULL;
    if (!x || (v && !vel)) return free(x), free(vel), -1;
    for (size_t k = 0; v && k < FILL_CHUNK; k++) memcpy(&vel[3 * k], v, 3 * sizeof *v);
    uint32_t st = seed ? seed : 1;
    for (long i = i0[0]; i < i1[0]; i++)
        for (long j = i0[1]; j < i1[1]; j++)
            for (long k = i0[2]; k < i1[2]; k++) {
                double o[3] = {0.5, 0.5, 0.5};
                if (seed)
                    for (int a = 0; a < 3; a++) o[a] = jitter(&st);
                double q[3] = {(i + o[0]) * h, (j + o[1]) * h, (k + o[2]) * h};
                if (q[0] < lo[0] || q[1] < lo[1] || q[2] < lo[2] || q[0] >= hi[0] || q[1] >= hi[1] || q[2] >= hi[2])
                    continue;
                if (inside && !inside(q, ctx)) continue;
                memcpy(&x[3 * n++], q, sizeof q);
                if (n == FILL_CHUNK) {
                    long f = kf_state_add_particles(s, m, n, x, vel, NULL, material, h * h * h);
                    if (f < 0) return free(x), free(vel), -1;
                    if (first < 0) first = f;
                    n = 0;
                }
            }
    /* the last chunk; with none at all, the state changes as adding none does */
    long f = n ? kf_state_add_particles(s, m, n, x, vel, NULL, material, h * h * h) : (long)s->p.n;
    free(x);
    free(vel);
    if (f < 0) return -1;
    s->g.valid = 0;
    s->tau_valid = 0;
    return first < 0 ? f : first;
}

long kf_state_fill_box(kf_state *s, const kf_model *m, const double lo[3], const double hi[3], int material,
                       const double v[3], int ppc_axis, uint32_t seed) {
    return fill(s, m, lo, hi, NULL, NULL, material, v, ppc_axis, seed);
}

static int inside_sphere(const double x[3], const void *ctx) {
    const double *c = ctx;
    double r2 = 0;
    for (int a = 0; a < 3; a++) r2 += (x[a] - c[a]) * (x[a] - c[a]);
    return r2 < c[3] * c[3];
}

long kf_state_fill_sphere(kf_state *s, const kf_model *m, const double c[3], double r, int material, const double v[3],
                          int ppc_axis, uint32_t seed) {
    double ctx[4] = {c[0], c[1], c[2], r}, lo[3], hi[3];
    for (int a = 0; a < 3; a++) lo[a] = c[a] - r, hi[a] = c[a] + r;
    return fill(s, m, lo, hi, inside_sphere, ctx, material, v, ppc_axis, seed);
}

kf_energy kf_state_energy(const kf_model *m, const kf_state *s) {
    const kf_particles *p = &s->p;
    const double d = kf_model_dfactor(m);
    const int apic = m->sim.transfer != KF_TRANSFER_PIC; /* APIC and FLIP carry C */
    double ke = 0, el = 0, gp = 0, mom[3] = {0}, L[3] = {0}, mass = 0;
    for (size_t i = 0; i < p->n; i++) {
        double mp = p->mass[i], x[3], v[3];
        for (int a = 0; a < 3; a++) x[a] = p->x[a][i], v[a] = p->v[a][i];
        kf_real F[9], ps[2] = {p->ps[0][i], p->ps[1][i]};
        for (int k = 0; k < 9; k++) F[k] = p->F[k][i];
        mass += mp;
        ke += 0.5 * mp * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]);
        el += p->vol0[i] * kf_mat_energy_density(&m->mat[p->mat[i]], F, ps);
        for (int a = 0; a < 3; a++) {
            mom[a] += mp * v[a];
            gp -= mp * m->sim.gravity[a] * x[a];
        }
        L[0] += mp * (x[1] * v[2] - x[2] * v[1]);
        L[1] += mp * (x[2] * v[0] - x[0] * v[2]);
        L[2] += mp * (x[0] * v[1] - x[1] * v[0]);
        if (apic) {
            /* APIC's affine part carries m d (C - Cᵀ) of angular momentum */
            L[0] += mp * d * (p->C[7][i] - p->C[5][i]);
            L[1] += mp * d * (p->C[2][i] - p->C[6][i]);
            L[2] += mp * d * (p->C[3][i] - p->C[1][i]);
        }
    }
    kf_energy e = {ke, el, gp, {mom[0], mom[1], mom[2]}, {L[0], L[1], L[2]}, mass};
    return e;
}

/* FNV-1a over every particle field, visited in stable id order so the hash
 * does not depend on how the grid sorted the particles */
uint64_t kf_state_hash(const kf_state *s) {
    const kf_particles *p = &s->p;
    size_t n = p->n;
    uint32_t maxid = 0;
    for (size_t i = 0; i < n; i++)
        if (p->id[i] > maxid) maxid = p->id[i];
    int64_t *where = malloc(((size_t)maxid + 1) * sizeof *where);
    if (!where) return 0;
    for (size_t k = 0; k <= maxid; k++) where[k] = -1;
    for (size_t i = 0; i < n; i++) where[p->id[i]] = (int64_t)i;
    uint64_t h = KF_FNV_BASIS;
#define FNV(ptr, len) (h = kf_fnv1a(h, (ptr), (len)))
    for (size_t k = 0; k <= maxid; k++) {
        if (where[k] < 0) continue;
        size_t i = (size_t)where[k];
        /* stress not kept: the planes' contents as kf_stress would have left them */
        kf_real tau[6];
        const int eval = (p->zero & KF_ZERO_TAU) && s->tau_valid && s->stress_model;
        if (eval) {
            kf_real *const out[6] = {&tau[0], &tau[1], &tau[2], &tau[3], &tau[4], &tau[5]};
            kf_stress_eval(s->stress_model, (kf_particles *)p, i, 1, out);
        }
        for (int f = 0; f < KF_PARTICLE_REAL_PLANES; f++)
            FNV(eval && f >= KF_PLANE_TAU ? &tau[f - KF_PLANE_TAU] : &p->plane[f][i], sizeof(kf_real));
        FNV(&p->mat[i], sizeof p->mat[i]);
        FNV(&p->obj[i], sizeof p->obj[i]);
        FNV(&p->colour[i], sizeof p->colour[i]);
    }
    /* rigid bodies: pose and velocity */
    FNV(s->rigid, (size_t)s->nrigid * sizeof s->rigid[0]);
#undef FNV
    free(where);
    return h;
}

/* polypic: ½ m Σ_i w_i |u(x_i)|² per particle, u its higher-mode field
 * (polypic.h) at its stencil's nodes, in double */
double kf_state_mode_energy(const kf_model *m, const kf_state *s) {
    if (m->sim.transfer != KF_TRANSFER_POLYPIC || !s->poly_cap) return 0;
    static const unsigned char mode[KF_POLY_MODES][3] = {
        {0, 0, 2}, {0, 1, 1}, {0, 1, 2}, {0, 2, 0}, {0, 2, 1}, {0, 2, 2}, {1, 0, 1}, {1, 0, 2},
        {1, 1, 0}, {1, 1, 1}, {1, 1, 2}, {1, 2, 0}, {1, 2, 1}, {1, 2, 2}, {2, 0, 0}, {2, 0, 1},
        {2, 0, 2}, {2, 1, 0}, {2, 1, 1}, {2, 1, 2}, {2, 2, 0}, {2, 2, 1}, {2, 2, 2}};
    const kf_particles *p = &s->p;
    const kf_real inv_dx = kf_model_inv_dx(m);
    double total = 0;
    for (size_t i = 0; i < p->n; i++) {
        if (p->id[i] >= s->poly_cap) continue;
        const kf_real *md = &s->poly[(size_t)p->id[i] * KF_POLY_REALS];
        double w[3][3], e[3][3][3];
        for (int a = 0; a < 3; a++) {
            double fx = (double)p->x[a][i] * inv_dx - kf_base_node(p->x[a][i], inv_dx, 0);
            w[a][0] = 0.5 * (1.5 - fx) * (1.5 - fx);
            w[a][1] = 0.75 - (fx - 1) * (fx - 1);
            w[a][2] = 0.5 * (fx - 0.5) * (fx - 0.5);
            for (int k = 0; k < 3; k++) {
                double d = k - fx;
                e[a][0][k] = 1, e[a][1][k] = d, e[a][2][k] = d * d - md[3 * KF_POLY_MODES + a] * d - 0.25;
            }
        }
        double sum = 0;
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++)
                for (int c = 0; c < 3; c++) {
                    double u[3] = {0, 0, 0};
                    for (int q = 0; q < KF_POLY_MODES; q++) {
                        double f = e[0][mode[q][0]][a] * e[1][mode[q][1]][b] * e[2][mode[q][2]][c];
                        for (int k = 0; k < 3; k++) u[k] += f * md[3 * q + k];
                    }
                    sum += w[0][a] * w[1][b] * w[2][c] * (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]);
                }
        total += 0.5 * p->mass[i] * sum;
    }
    return total;
}
