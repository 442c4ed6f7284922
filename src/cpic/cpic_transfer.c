/* cpic_transfer.c — the CPIC transfers of an owner block in the narrow band
 * (paper §5.3–§5.5), particle by particle on the quadratic stencil.
 *
 * P2G, per particle: its colour from the nodes' colours (§5.3.1, with
 * persistence §5.3.3), its signed distance and normal by an MLS fit of the
 * nodes' distances made signed relative to the particle (§5.3.2), then the
 * scatter: compatible nodes (§5.3.4) get the ordinary MLS-MPM contribution
 * (Eq. 23–24); an incompatible node gets nothing, and its closest body r*
 * gets the impulse of everything the node would have received minus what the
 * particle keeps there, the projected velocity u = Proj_r*(v_p) (Eq. 25).
 * G2P, per particle: incompatible nodes contribute the ghost velocity
 * u + Δt c n_p (Eq. 27–28); the push's reaction goes to the body. */
#include <math.h>
#include <string.h>

#include "../mpm/transfer_chunk.h"
#include "../mpm/collider.h"
#include "cpic.h"
#include "../dist/dist.h"
#if defined(__AVX2__)
#include <immintrin.h>
#endif

#define NB KF_CPIC_NB
#define AFF KF_CPIC_AFFINITY

/* The offset in the owner's node cache of stencil node n = 9a + 3b + k from
 * the particle's base node */
static const int stencil_off[27] = {
#define KF_ROW3(a, b) ((a) * NB + (b)) * NB, ((a) * NB + (b)) * NB + 1, ((a) * NB + (b)) * NB + 2
    KF_ROW3(0, 0), KF_ROW3(0, 1), KF_ROW3(0, 2), KF_ROW3(1, 0), KF_ROW3(1, 1),
    KF_ROW3(1, 2), KF_ROW3(2, 0), KF_ROW3(2, 1), KF_ROW3(2, 2)
#undef KF_ROW3
};

/* particle j's base node in the owner's node cache (its stencil's first) */
static inline int stencil_base(const chunk *ck, int j) {
    return (ck->l[0][j] * NB + ck->l[1][j]) * NB + ck->l[2][j];
}

/* stencil node n's offsets {a, b, k} from the base node (n = 9a + 3b + k) */
static const int32_t stencil_s3[27][4] = {
#define KF_S3(a, b) {a, b, 0, 0}, {a, b, 1, 0}, {a, b, 2, 0}
    KF_S3(0, 0), KF_S3(0, 1), KF_S3(0, 2), KF_S3(1, 0), KF_S3(1, 1),
    KF_S3(1, 2), KF_S3(2, 0), KF_S3(2, 1), KF_S3(2, 2)
#undef KF_S3
};

/* Stencil node n = 9a + 3b + k of particle j in owner block bc: its
 * offsets s3 = {a, b, k} from the base node and its world position xi (one
 * place for the across paths of P2G and G2P, so they agree) */
static inline void stencil_node(const chunk *ck, int j, const int32_t *bc, double dx, int n, int s3[3],
                                double xi[3]) {
    for (int e = 0; e < 3; e++) s3[e] = stencil_s3[n][e];
    for (int e = 0; e < 3; e++) xi[e] = (KF_BLOCK * bc[e] + ck->l[e][j] + s3[e]) * dx;
}

void kf_cpic_owner_cdf(const kf_state *s, size_t owner, kf_cpic_owner *oc) {
    const kf_cpic *c = s->cpic;
    const int32_t *nb = s->g.nb[owner];
    /* block by block: a block's row of 4 nodes along z is 4 consecutive
     * entries both in the grid and in the cache (the same values as node
     * by node, in vector moves) */
    _Static_assert(NB == 2 * KF_BLOCK, "the cache spans the owner's 2x2x2 blocks");
    for (int e = 0; e < 8; e++) {
        const int blk = nb[e], da = e >> 2, db = (e >> 1) & 1, dk = e & 1;
        const int valid = c->stamp[blk] == c->epoch;
        const uint32_t *nc = &c->node_c[64 * (size_t)blk];
        const float *nd = &c->node_d[64 * (size_t)blk];
        for (int a = 0; a < KF_BLOCK; a++)
            for (int b = 0; b < KF_BLOCK; b++) {
                const int q = ((KF_BLOCK * da + a) * NB + KF_BLOCK * db + b) * NB + KF_BLOCK * dk, n = a << 4 | b << 2;
                for (int k = 0; k < KF_BLOCK; k++) {
                    oc->col[q + k] = valid ? nc[n + k] : 0;
                    oc->dist[q + k] = valid ? nd[n + k] : 0;
                }
            }
    }
    /* the stencils' affinity, one axis at a time (the quadratic stencil's
     * base nodes lie in 0..NB-3 along each axis) */
    uint32_t t[NB * NB * NB];
    for (int q = 0; q < NB * NB * NB; q++) t[q] = oc->col[q] & AFF;
    for (int a = 0; a < NB; a++)
        for (int b = 0; b < NB; b++)
            for (int k = 0; k + 2 < NB; k++) {
                const int q = (a * NB + b) * NB + k;
                t[q] |= t[q + 1] | t[q + 2];
            }
    for (int a = 0; a < NB; a++)
        for (int b = 0; b + 2 < NB; b++)
            for (int k = 0; k < NB; k++) {
                const int q = (a * NB + b) * NB + k;
                t[q] |= t[q + NB] | t[q + 2 * NB];
            }
    for (int q = 0; q < NB * NB * NB; q++)
        oc->aff[q] = q < (NB - 2) * NB * NB ? t[q] | t[q + NB * NB] | t[q + 2 * NB * NB] : t[q];
    /* this substep's impulse rows and gΔt (the fused sweep's early P2G points them at the next one's) */
    oc->imp = &c->imp[c->slot[owner]][0][0];
    oc->gdt = c->gdt;
}

#define compatible kf_cpic_compatible

/* Eq. 25 on v relative to the body; without a normal (the fit failed) only
 * a sticky body constrains v */
static void project(double v[3], const double n[3], kf_boundary type, double mu) {
    if (type != KF_BOUNDARY_STICKY && n[0] * n[0] + n[1] * n[1] + n[2] * n[2] == 0) return;
    kf_project_velocity(v, n, type, mu);
}

/* u = V_r(x_i) + Proj(v_p + gΔt − V_r(x_i)): what the particle keeps at an
 * incompatible node. A separate face the particle presses on (held, see
 * pressed_bodies) acts as a slip face: the normal part goes whichever its
 * sign (the friction budget from the approach alone). */
static void kept_velocity(const kf_model *m, const kf_state *s, int r, const double xi[3], const double vp[3],
                          const double n[3], int held, double u[3]) {
    const kf_rigid_def *d = &m->rigid[r].def;
    double V[3], w[3];
    kf_rigid_point_velocity(&s->rigid[r], xi, V);
    for (int a = 0; a < 3; a++) w[a] = vp[a] + s->cpic->gdt[a] - V[a];
    const double wn = w[0] * n[0] + w[1] * n[1] + w[2] * n[2];
    if (d->boundary == KF_BOUNDARY_SEPARATE && held && wn > 0)
        for (int a = 0; a < 3; a++) w[a] -= wn * n[a]; /* held though receding: the normal part goes */
    else project(w, n, d->boundary, d->friction);
    for (int a = 0; a < 3; a++) u[a] = V[a] + w[a];
}

/* A body that does not turn has one velocity everywhere, bit for bit:
 * V(x) = v + w × (x − com) rounds to v at every x when every component of w
 * is zero and none of v is −0 (+0 + −0 rounds to +0, v + ±0 to v otherwise).
 * Then a particle keeps the same u at each of its incompatible nodes of
 * that body, and it is made once per particle instead of once per node. */
static inline int uniform_velocity(const kf_rigid_state *st) {
    for (int a = 0; a < 3; a++)
        if (st->w[a] != 0 || (st->v[a] == 0 && signbit(st->v[a]))) return 0;
    return 1;
}

/* kept_velocity, reused across a particle's nodes of a uniform body:
 * bit r of *have says ur[r] holds it for this particle */
static inline void kept_velocity_at(const kf_model *m, const kf_state *s, int r, const double xi[3], const double vp[3],
                                    const double n[3], int held, const uint8_t *uniform, uint32_t *have,
                                    double (*ur)[3], double u[3]) {
    if (uniform[r] && (*have >> r & 1)) {
        for (int a = 0; a < 3; a++) u[a] = ur[r][a];
        return;
    }
    kept_velocity(m, s, r, xi, vp, n, held, u);
    if (uniform[r]) {
        for (int a = 0; a < 3; a++) ur[r][a] = u[a];
        *have |= 1u << r;
    }
}

/* The separate bodies a particle presses on, a bit per body: those whose
 * nodes across its surface, held as slip, would take an impulse into the
 * body from it as a whole, Σ_i w_i (m (v̂ − V_r(x_i))·n + f_i·n) ≤ 0, with
 * v̂ = v_p + gΔt and f_i the particle's stress push on node i (MLS:
 * w_i (−Δt V⁰ D⁻¹ τ) d_i, classic: −Δt V⁰ τ ∇w_i). Water at rest under a
 * floating block recedes from it by gravity every substep while its
 * pressure presses it on: judged on v̂ alone (the paper's rule), it was let
 * go while the pressure's share still pushed the block up, and the block
 * floated high and hopped on the water's jitter. Judged node by node, the
 * nodes that would pull (level with the particle: little push, all its
 * weight) were let go while the others pushed, a sum of one-sided parts
 * that rectifies the jitter; a 0.61 block then settled 12-14 degrees off
 * upright (2.3 judged per particle). A contact force is one-sided as a
 * whole, so the particle's whole exchange with the body decides. */
static uint32_t pressed_bodies(const kf_model *m, const kf_state *s, const chunk *ck, int j, const uint32_t *col, int o,
                               uint32_t xm, const int32_t *bc, const double vp[3], const double n[3], const double T[9],
                               double mass, int classic, const uint8_t *uniform) {
    const double dx = m->sim.dx, minv = 1.0 / kf_model_dfactor(m);
    double acc[KF_MAX_RIGIDS];
    uint32_t seen = 0, held = 0;
    /* the nodes across the particle's surface (bits of xm), in node order */
    for (uint32_t left = xm; left; left &= left - 1) {
        const int nd = __builtin_ctz(left);
        int r = (int)(col[o + stencil_off[nd]] >> KF_CPIC_RSTAR_SHIFT) - 1;
        if (m->rigid[r].def.boundary != KF_BOUNDARY_SEPARATE) continue;
        if (!(seen >> r & 1)) acc[r] = 0, seen |= 1u << r;
        int s3[3];
        double xi[3];
        stencil_node(ck, j, bc, dx, nd, s3, xi);
        const int a = s3[0], b = s3[1], k = s3[2];
        const double w = (double)ck->w[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j];
        const double d[3] = {ck->d[0][a][j], ck->d[1][b][j], ck->d[2][k][j]};
        double V[3], g[3];
        /* a body that does not turn: its v at every point, bit for bit (uniform_velocity) */
        if (uniform[r])
            for (int e = 0; e < 3; e++) V[e] = s->rigid[r].v[e];
        else kf_rigid_point_velocity(&s->rigid[r], xi, V);
        if (classic) {
            g[0] = (double)ck->dw[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j] / dx;
            g[1] = (double)ck->w[0][a][j] * ck->dw[1][b][j] * ck->w[2][k][j] / dx;
            g[2] = (double)ck->w[0][a][j] * ck->w[1][b][j] * ck->dw[2][k][j] / dx;
        } else {
            for (int e = 0; e < 3; e++) g[e] = w * minv * d[e];
        }
        for (int e = 0; e < 3; e++)
            acc[r] += (w * mass * (vp[e] + s->cpic->gdt[e] - V[e]) + T[3 * e] * g[0] + T[3 * e + 1] * g[1] +
                       T[3 * e + 2] * g[2]) *
                      n[e];
    }
    for (uint32_t left = seen; left; left &= left - 1) {
        int r = __builtin_ctz(left);
        if (acc[r] <= 0) held |= 1u << r;
    }
    return held;
}

/* Where the exchange at an incompatible node acts on a solid body. The
 * grid sees a solid as the cells of its nodes across the surface: a face
 * between two nodes stands on the grid where their cells meet, up to half a
 * cell off, and the load its nodes take acts at the middle of the nodes,
 * not of the face. A block whose opposite faces lie at different offsets
 * between nodes was turned by its own buoyancy: held upright at its draft,
 * a 0.83 block 7.68 cells wide, faces 0.24 and 0.44 cells past their
 * nodes, took 0.047 N m (0.006 with its faces mirror-placed); with a
 * metacentric height of 0.8 cells it settled 13 degrees over. So along
 * each axis the node's cell is cut where the surface crosses toward a
 * neighbour on the particle's side, giving the covered length L (up to 2:
 * a face past the midpoint adds the part of the neighbour's cell the grid
 * gave the water) and its centre m, and the impulse acts at
 * com + L (x_i + m - com): the covered part at its centre, the rest (the
 * load the grid's face takes beyond the body's, or misses short of it) at
 * the com, where it turns nothing. A node whose neighbours along the axis
 * are both in the body keeps its place there (L = 1, m = 0). The linear
 * impulse is unchanged. Held so, the block took 0.007 N m. The crossing
 * comes from the distance outside, growing along the axis from the
 * neighbour to the next node out (exact for a plane at any angle and at a
 * convex corner, where the node inside measures to another face), else
 * from the two nodes' distances interpolated; a neighbour outside the
 * owner's node cache counts as in the body.
 * Only nodes in the owner's read box (ob: the nodes its own particles'
 * stencils span, in grid coordinates) are read. The distance field is
 * splatted only where some owner reads, so a node past the stencil outside
 * this owner's box was filled or empty depending on which other owners were
 * on this rank: a box skidding over ranks' cuts turned differently on 2
 * ranks than on 1. Widening every owner's box by two nodes instead cost a
 * robot_sand frame 45% more splat. */
static void contact_point(const uint32_t *col, const float *dist, int q, const int l[3], const int s3[3],
                          const int32_t bc[3], const int32_t ob[6], int r, uint32_t cp, const double xi[3],
                          const double com[3], double dx, double out[3]) {
    static const int stride[3] = {NB * NB, NB, 1};
    const uint32_t aff = 1u << (2 * r + 1), side = 1u << (2 * r);
    /* deeper than a cell, no neighbour along an axis is outside */
    if (dist[q] > 1) {
        for (int a = 0; a < 3; a++) out[a] = xi[a];
        return;
    }
    for (int a = 0; a < 3; a++) {
        double e[2] = {0.5, 0.5};
        const int first = KF_BLOCK * bc[a]; /* the cache's node 0 along a */
        for (int h = 0; h < 2; h++) {
            const int at = l[a] + s3[a] + (h ? 1 : -1);
            if (at < 0 || at >= NB || first + at < ob[a] || first + at > ob[3 + a]) continue;
            const int j = q + (h ? stride[a] : -stride[a]);
            /* the neighbour on the particle's side of body r: the surface lies between */
            if (!(col[j] & aff) || ((col[j] ^ cp) & side)) continue;
            const double di = dist[q], dj = dist[j];
            if (di + dj > 0) e[h] = di / (di + dj);
            /* from outside: the distance's growth along the axis */
            const int at2 = at + (h ? 1 : -1), jj = j + (h ? stride[a] : -stride[a]);
            if (at2 < 0 || at2 >= NB || first + at2 < ob[a] || first + at2 > ob[3 + a] || !(col[jj] & aff) ||
                ((col[jj] ^ cp) & side))
                continue;
            const double rate = dist[jj] - dj;
            if (rate > 0.25) e[h] = fmin(1, fmax(0, 1 - dj / rate));
        }
        const double L = e[0] + e[1], mid = 0.5 * (e[1] - e[0]) * dx;
        out[a] = com[a] + L * (xi[a] + mid - com[a]);
    }
}

/* APIC's affine velocity C_p d of a particle at a node offset d from it (0
 * under PIC). At an incompatible node the particle keeps it: only v_p is
 * projected against the body and only the removed part is the body's
 * impulse; G2P gives C_p d back to the particle's velocity, so no momentum
 * is lost, but not to its new C: a particle mostly among ghosts would keep
 * its old velocity gradient forever (a bunny particle on a plate was
 * crushed to J = 0.001). Handing it to the body instead (its normal part,
 * under slip) let a particle pressed against a face pull the body toward
 * it with the velocity gradient of its own making (compatible nodes moving
 * toward the face, ghosts not): 1.2 of a floating block's 12.6 N at 48
 * cells/m, a quarter cell of draft. Dropping C near bodies (PIC there, as
 * the authors' code does) removed that too, but PIC's damping in the band
 * held a sinking brick up in still water. */
static inline void affine_velocity_of(const double C[9], int apic, const double d[3], double cd[3]) {
    for (int e = 0; e < 3; e++) {
        cd[e] = 0;
        if (apic)
            for (int f = 0; f < 3; f++) cd[e] += C[3 * e + f] * d[f];
    }
}

#if defined(__AVX2__) && defined(__FMA__) && !defined(KF_DOUBLE)
/* The across paths' per-node work with the three components of a vector in
 * the lanes of one register (the fourth lane unused), each lane the scalar
 * code's operations as the compiler contracts them there: bit for bit. */
#define KF_CPIC_NODE_LANES 1

/* the first three of v in lanes 0-2, lane 3 zero */
static inline __m256d lanes3(const double v[3]) {
    return _mm256_maskload_pd(v, _mm256_setr_epi64x(-1, -1, -1, 0));
}

/* affine_velocity_of: cd_e = fma(C_e2, d_2, fma(C_e1, d_1, fma(C_e0, d_0, +0)))
 * in lane e, from C's columns (Ccol[f] lane e: C_ef; all zero under PIC,
 * which gives +0 as the scalar code's cd = 0 does) */
static inline __m256d affine_lanes(const __m256d Ccol[3], double d0, double d1, double d2) {
    __m256d cd = _mm256_fmadd_pd(Ccol[0], _mm256_set1_pd(d0), _mm256_setzero_pd());
    cd = _mm256_fmadd_pd(Ccol[1], _mm256_set1_pd(d1), cd);
    return _mm256_fmadd_pd(Ccol[2], _mm256_set1_pd(d2), cd);
}

/* C's columns in lanes for affine_lanes (lane 3 zero; made by a blend: the
 * zero-extending move a plain set can compile to is one valgrind 3.19
 * does not decode) */
static inline void affine_columns(const double Cj[9], __m256d Ccol[3]) {
    for (int f = 0; f < 3; f++)
        Ccol[f] = _mm256_blend_pd(_mm256_setr_pd(Cj[f], Cj[3 + f], Cj[6 + f], Cj[6 + f]), _mm256_setzero_pd(), 8);
}

/* The arm r = at − com of an impulse at point at, in lanes rotated for the
 * moment r × J: (r_y, r_z, r_x) and (r_z, r_x, r_y). One per node across,
 * for every impulse there (G2P's kept velocity and push both act at it). */
typedef struct impulse_arm {
    __m256d yzx, zxy;
} impulse_arm;

static inline impulse_arm impulse_arm_of(const kf_rigid_state *st, __m256d at) {
    const __m256d r = _mm256_sub_pd(at, lanes3(st->com));
    return (impulse_arm){_mm256_permute4x64_pd(r, _MM_SHUFFLE(3, 0, 2, 1)),
                         _mm256_permute4x64_pd(r, _MM_SHUFFLE(3, 1, 0, 2))};
}

/* kf_cpic_add_impulse with J and the arm in lanes: the moment's lane e
 * is r_{e+1} J_{e+2} fused with the rounded −r_{e+2} J_{e+1}, as the inline
 * function compiles; imp[0..3] += (J, m_0) and imp[4..5] += (m_1, m_2),
 * as it stores them */
static inline void impulse_lanes(double *imp, const impulse_arm *arm, __m256d J) {
    const __m256d J_yzx = _mm256_permute4x64_pd(J, _MM_SHUFFLE(3, 0, 2, 1));
    const __m256d J_zxy = _mm256_permute4x64_pd(J, _MM_SHUFFLE(3, 1, 0, 2));
    const __m256d mo = _mm256_fmsub_pd(arm->yzx, J_zxy, _mm256_mul_pd(arm->zxy, J_yzx));
    const __m256d lo = _mm256_blend_pd(J, _mm256_permute4x64_pd(mo, _MM_SHUFFLE(0, 0, 0, 0)), 8);
    _mm256_storeu_pd(imp, _mm256_add_pd(_mm256_loadu_pd(imp), lo));
    const __m128d hi = _mm256_castpd256_pd128(_mm256_permute4x64_pd(mo, _MM_SHUFFLE(3, 3, 2, 1)));
    _mm_storeu_pd(imp + 4, _mm_add_pd(_mm_loadu_pd(imp + 4), hi));
}

/* A particle's constants for its nodes across in lanes (scatter_across,
 * ghost_reads): its base node in grid coordinates, Δx, C's columns */
typedef struct across_lanes {
    __m128i base;
    __m256d dx, Ccol[3];
} across_lanes;

static inline across_lanes across_lanes_of(const chunk *ck, int j, const int32_t *bc, double dx, const double Cj[9]) {
    across_lanes al;
    al.base = _mm_setr_epi32(KF_BLOCK * bc[0] + ck->l[0][j], KF_BLOCK * bc[1] + ck->l[1][j],
                             KF_BLOCK * bc[2] + ck->l[2][j], 0);
    al.dx = _mm256_set1_pd(dx);
    affine_columns(Cj, al.Ccol);
    return al;
}

/* stencil node n's world position (stencil_node's xi: one integer add,
 * one conversion, one multiply) */
static inline __m256d node_position(const across_lanes *al, int n) {
    const __m128i s3 = _mm_loadu_si128((const __m128i *)stencil_s3[n]);
    return _mm256_mul_pd(_mm256_cvtepi32_pd(_mm_add_epi32(al->base, s3)), al->dx);
}

/* particle j's affine velocity C d at stencil node n */
static inline __m256d node_affine(const across_lanes *al, const chunk *ck, int j, int n) {
    const int32_t *s3 = stencil_s3[n];
    return affine_lanes(al->Ccol, ck->d[0][s3[0]][j], ck->d[1][s3[1]][j], ck->d[2][s3[2]][j]);
}

/* Where the impulse at stencil node n (cache index q, body r) acts: the
 * node itself on a thin body, else its contact_point */
static inline __m256d impulse_point(const kf_state *s, size_t owner, const kf_cpic_owner *oc, const chunk *ck, int j,
                                    int n, int q, int r, uint32_t cp, int thin, __m256d xi, double dx) {
    if (thin) return xi;
    double xs[4], as[3];
    _mm256_storeu_pd(xs, xi);
    const int l3[3] = {ck->l[0][j], ck->l[1][j], ck->l[2][j]};
    const int32_t *bc = &s->g.bcoord[3 * owner];
    contact_point(oc->col, oc->dist, q, l3, stencil_s3[n], bc, s->cpic->obox[owner], r, cp, xs, s->rigid[r].com, dx,
                  as);
    return lanes3(as);
}

/* lanes 0-2 of v into out[0], out[stride], out[2 stride] */
static inline void store3(double *out, int stride, __m256d v) {
    const __m128d lo = _mm256_castpd256_pd128(v);
    _mm_store_sd(out, lo);
    _mm_storeh_pd(out + stride, lo);
    _mm_store_sd(out + 2 * stride, _mm256_extractf128_pd(v, 1));
}
#endif

/* Solve the symmetric 4x4 system M c = y (Gaussian elimination with partial
 * pivoting); returns det M. Each x -= a b is one fused multiply-add, as the
 * compiler contracted it before this was written out (and as the lanes of
 * solve4_lanes do it). */
static double solve4(double M[4][4], double y[4], double c[4]) {
    double det = 1;
    for (int k = 0; k < 4; k++) {
        int piv = k;
        for (int i = k + 1; i < 4; i++)
            if (fabs(M[i][k]) > fabs(M[piv][k])) piv = i;
        if (piv != k) {
            for (int j = 0; j < 4; j++) {
                double t = M[k][j];
                M[k][j] = M[piv][j];
                M[piv][j] = t;
            }
            double t = y[k];
            y[k] = y[piv];
            y[piv] = t;
            det = -det;
        }
        det *= M[k][k];
        if (M[k][k] == 0) return 0;
        for (int i = k + 1; i < 4; i++) {
            double f = M[i][k] / M[k][k];
            for (int j = k; j < 4; j++) M[i][j] = fma(-f, M[k][j], M[i][j]);
            y[i] = fma(-f, y[k], y[i]);
        }
    }
    for (int k = 3; k >= 0; k--) {
        double sum = y[k];
        for (int j = k + 1; j < 4; j++) sum = fma(-M[k][j], c[j], sum);
        c[k] = sum / M[k][k];
    }
    return det;
}

/* A particle's distance fit between its sums and its solve: the sums, the
 * closest node's body and whether the fit's nodes mix bodies. The solves of
 * a chunk's particles run together (solve4_lanes). */
typedef struct cdf_fit {
    double M[4][4][KF_CHUNK], y[4][KF_CHUNK], coef[4][KF_CHUNK], det[KF_CHUNK]; /* by lane */
    int rstar[KF_CHUNK], mixed[KF_CHUNK], idx[KF_CHUNK], n;
    uint32_t cp[KF_CHUNK]; /* the queued particle's colour, as its fit reads it */
} cdf_fit;

/* solve4 for the fits queued in f, eight at a time (AVX-512; four with
 * AVX2, below; one by one elsewhere). Each lane does what
 * solve4 does, in its order and with its roundings: the pivot by the same
 * strict comparisons, rows swapped where the lane's pivot says, every
 * x -= a b as one fused multiply-add (as solve4 compiles: the compiler
 * contracts each of them), the same divisions. A lane whose pivot is 0 has
 * det 0 (its coefficients are not read). Bit for bit with solve4. */
#if defined(__AVX512F__) && defined(__FP_FAST_FMA)
#include <immintrin.h>
static void solve4_lanes(cdf_fit *f) {
    for (int q0 = 0; q0 < f->n; q0 += 8) {
        const int nl = f->n - q0 < 8 ? f->n - q0 : 8;
        const __mmask8 live = (__mmask8)((1u << nl) - 1);
        /* the lanes' matrices and right-hand sides (the unused lanes: the identity) */
        __m512d M[4][4], y[4];
        for (int r = 0; r < 4; r++) {
            for (int c = 0; c < 4; c++) M[r][c] = _mm512_mask_loadu_pd(_mm512_set1_pd(r == c), live, &f->M[r][c][q0]);
            y[r] = _mm512_maskz_loadu_pd(live, &f->y[r][q0]);
        }
        const __m512d sign = _mm512_set1_pd(-0.0);
        __m512d det = _mm512_set1_pd(1);
        __mmask8 zero = 0;
        for (int k = 0; k < 4; k++) {
            /* the pivot: the first largest |M[i][k]|, by strict comparisons in row order */
            __m512i piv = _mm512_set1_epi64(k);
            __m512d big = _mm512_andnot_pd(sign, M[k][k]);
            for (int i = k + 1; i < 4; i++) {
                const __m512d a = _mm512_andnot_pd(sign, M[i][k]);
                const __mmask8 gt = _mm512_cmp_pd_mask(a, big, _CMP_GT_OQ);
                piv = _mm512_mask_mov_epi64(piv, gt, _mm512_set1_epi64(i));
                big = _mm512_mask_mov_pd(big, gt, a);
            }
            for (int i = k + 1; i < 4; i++) {
                const __mmask8 sw = _mm512_cmpeq_epi64_mask(piv, _mm512_set1_epi64(i));
                for (int j = 0; j < 4; j++) {
                    const __m512d t = M[k][j];
                    M[k][j] = _mm512_mask_mov_pd(M[k][j], sw, M[i][j]);
                    M[i][j] = _mm512_mask_mov_pd(M[i][j], sw, t);
                }
                const __m512d t = y[k];
                y[k] = _mm512_mask_mov_pd(y[k], sw, y[i]);
                y[i] = _mm512_mask_mov_pd(y[i], sw, t);
                det = _mm512_mask_xor_pd(det, sw, det, sign);
            }
            det = _mm512_mul_pd(det, M[k][k]);
            zero |= _mm512_cmp_pd_mask(M[k][k], _mm512_setzero_pd(), _CMP_EQ_OQ);
            for (int i = k + 1; i < 4; i++) {
                const __m512d fk = _mm512_div_pd(M[i][k], M[k][k]);
                for (int j = k; j < 4; j++) M[i][j] = _mm512_fnmadd_pd(fk, M[k][j], M[i][j]);
                y[i] = _mm512_fnmadd_pd(fk, y[k], y[i]);
            }
        }
        __m512d cf[4];
        for (int k = 3; k >= 0; k--) {
            __m512d sum = y[k];
            for (int j = k + 1; j < 4; j++) sum = _mm512_fnmadd_pd(M[k][j], cf[j], sum);
            cf[k] = _mm512_div_pd(sum, M[k][k]);
        }
        det = _mm512_mask_mov_pd(det, zero, _mm512_setzero_pd());
        _mm512_mask_storeu_pd(&f->det[q0], live, det);
        for (int k = 0; k < 4; k++) _mm512_mask_storeu_pd(&f->coef[k][q0], live, cf[k]);
    }
}
#elif defined(__AVX2__) && defined(__FMA__)
#include <immintrin.h>
/* The same lanes four at a time in AVX2's 256-bit registers (no mask
 * registers: the comparisons give all-ones lanes, blends and ands use them).
 * Bit for bit with solve4, as the AVX-512 lanes above. */
static void solve4_lanes(cdf_fit *f) {
    for (int q0 = 0; q0 < f->n; q0 += 4) {
        const int nl = f->n - q0 < 4 ? f->n - q0 : 4;
        const __m256i live = _mm256_cmpgt_epi64(_mm256_set1_epi64x(nl), _mm256_setr_epi64x(0, 1, 2, 3));
        /* the lanes' matrices and right-hand sides (the unused lanes: the identity) */
        __m256d M[4][4], y[4];
        for (int r = 0; r < 4; r++) {
            for (int c = 0; c < 4; c++)
                M[r][c] = _mm256_blendv_pd(_mm256_set1_pd(r == c), _mm256_maskload_pd(&f->M[r][c][q0], live),
                                           _mm256_castsi256_pd(live));
            y[r] = _mm256_maskload_pd(&f->y[r][q0], live);
        }
        const __m256d sign = _mm256_set1_pd(-0.0);
        __m256d det = _mm256_set1_pd(1), zero = _mm256_setzero_pd();
        for (int k = 0; k < 4; k++) {
            /* the pivot: the first largest |M[i][k]|, by strict comparisons in row order */
            __m256d piv = _mm256_set1_pd(k);
            __m256d big = _mm256_andnot_pd(sign, M[k][k]);
            for (int i = k + 1; i < 4; i++) {
                const __m256d a = _mm256_andnot_pd(sign, M[i][k]);
                const __m256d gt = _mm256_cmp_pd(a, big, _CMP_GT_OQ);
                piv = _mm256_blendv_pd(piv, _mm256_set1_pd(i), gt);
                big = _mm256_blendv_pd(big, a, gt);
            }
            for (int i = k + 1; i < 4; i++) {
                const __m256d sw = _mm256_cmp_pd(piv, _mm256_set1_pd(i), _CMP_EQ_OQ);
                for (int j = 0; j < 4; j++) {
                    const __m256d t = M[k][j];
                    M[k][j] = _mm256_blendv_pd(M[k][j], M[i][j], sw);
                    M[i][j] = _mm256_blendv_pd(M[i][j], t, sw);
                }
                const __m256d t = y[k];
                y[k] = _mm256_blendv_pd(y[k], y[i], sw);
                y[i] = _mm256_blendv_pd(y[i], t, sw);
                det = _mm256_xor_pd(det, _mm256_and_pd(sw, sign));
            }
            det = _mm256_mul_pd(det, M[k][k]);
            zero = _mm256_or_pd(zero, _mm256_cmp_pd(M[k][k], _mm256_setzero_pd(), _CMP_EQ_OQ));
            for (int i = k + 1; i < 4; i++) {
                const __m256d fk = _mm256_div_pd(M[i][k], M[k][k]);
                for (int j = k; j < 4; j++) M[i][j] = _mm256_fnmadd_pd(fk, M[k][j], M[i][j]);
                y[i] = _mm256_fnmadd_pd(fk, y[k], y[i]);
            }
        }
        __m256d cf[4];
        for (int k = 3; k >= 0; k--) {
            __m256d sum = y[k];
            for (int j = k + 1; j < 4; j++) sum = _mm256_fnmadd_pd(M[k][j], cf[j], sum);
            cf[k] = _mm256_div_pd(sum, M[k][k]);
        }
        det = _mm256_andnot_pd(zero, det);
        _mm256_maskstore_pd(&f->det[q0], live, det);
        for (int k = 0; k < 4; k++) _mm256_maskstore_pd(&f->coef[k][q0], live, cf[k]);
    }
}
#else
static void solve4_lanes(cdf_fit *f) {
    for (int q = 0; q < f->n; q++) {
        double M[4][4], y[4], c[4];
        for (int r = 0; r < 4; r++) {
            for (int k = 0; k < 4; k++) M[r][k] = f->M[r][k][q];
            y[r] = f->y[r][q];
        }
        f->det[q] = solve4(M, y, c);
        for (int r = 0; r < 4; r++) f->coef[r][q] = c[r];
    }
}
#endif

/* One node of the linear MLS fit of §5.3.2: weight w, value at the node, and
 * P = [z / Δx; 1] with z the node minus the particle. Solving M c = y gives
 * c = [∇ (grid units); the value at the particle]. */
static inline void fit_add(double M[4][4], double y[4], double w, double value, const chunk *ck, int j, int a, int b,
                           int k, double inv_dx) {
    const double P[4] = {ck->d[0][a][j] * inv_dx, ck->d[1][b][j] * inv_dx, ck->d[2][k][j] * inv_dx, 1};
    for (int r = 0; r < 4; r++) {
        y[r] += w * value * P[r];
        for (int c = 0; c < 4; c++) M[r][c] += w * P[r] * P[c];
    }
}

/* The same sums as fit_add, a row of M (and y) per 4-lane multiply and add,
 * for the particle's own fit (particle_cdf), where fit_add compiles to
 * separately rounded products and sums, none fused: each lane is w P_r
 * rounded, times P_c rounded, added (w P_r in M's last column and row, w
 * value P_r in y), bit for bit. The empty asm keeps each product a value of
 * its own, so the add is not contracted into a fused multiply-add. */
#if defined(__AVX__) && !defined(KF_DOUBLE)
#include <immintrin.h>
typedef struct fit4 {
    __m256d m[4], y;
} fit4;
static inline void fit4_add(fit4 *f, double w, double value, const chunk *ck, int j, int a, int b, int k,
                            double inv_dx) {
    const double P0 = ck->d[0][a][j] * inv_dx, P1 = ck->d[1][b][j] * inv_dx, P2 = ck->d[2][k][j] * inv_dx;
    const __m256d P = _mm256_setr_pd(P0, P1, P2, 1);
    __m256d wp = _mm256_mul_pd(_mm256_set1_pd(w), P), t[4];
    __asm__("" : "+x"(wp));
    const double wv = w * value;
    t[0] = _mm256_mul_pd(_mm256_set1_pd(wp[0]), P);
    t[1] = _mm256_mul_pd(_mm256_set1_pd(wp[1]), P);
    t[2] = _mm256_mul_pd(_mm256_set1_pd(wp[2]), P);
    t[3] = _mm256_mul_pd(_mm256_set1_pd(wv), P);
    __asm__("" : "+x"(t[0]), "+x"(t[1]), "+x"(t[2]), "+x"(t[3]));
    f->m[0] = _mm256_add_pd(f->m[0], t[0]);
    f->m[1] = _mm256_add_pd(f->m[1], t[1]);
    f->m[2] = _mm256_add_pd(f->m[2], t[2]);
    f->m[3] = _mm256_add_pd(f->m[3], wp);
    f->y = _mm256_add_pd(f->y, t[3]);
}
static inline void fit4_zero(fit4 *f) {
    for (int r = 0; r < 4; r++) f->m[r] = _mm256_setzero_pd();
    f->y = _mm256_setzero_pd();
}
static inline void fit4_out(const fit4 *f, double M[4][4], double y[4]) {
    for (int r = 0; r < 4; r++) _mm256_storeu_pd(M[r], f->m[r]);
    _mm256_storeu_pd(y, f->y);
}
#else
typedef struct fit4 {
    double m[4][4], y[4];
} fit4;
static inline void fit4_add(fit4 *f, double w, double value, const chunk *ck, int j, int a, int b, int k,
                            double inv_dx) {
    fit_add(f->m, f->y, w, value, ck, j, a, b, k, inv_dx);
}
static inline void fit4_zero(fit4 *f) { memset(f, 0, sizeof *f); }
static inline void fit4_out(const fit4 *f, double M[4][4], double y[4]) {
    memcpy(M, f->m, sizeof f->m);
    memcpy(y, f->y, sizeof f->y);
}
#endif

/* The side of body r (bit = 2r + 1) a particle newly near it is on: 1
 * negative, 0 positive, -1 undecided (retry next substep).
 * Eq. 21 votes with the nodes' tags weighted by N_i d_i. d_i is the distance
 * to the closest body of all, so where surfaces meet it measures another
 * body and the vote can go wrong within a fraction of a cell of the surface
 * (a test with three intersecting plates found 16 of 13k). Where at least
 * four nodes have r as their closest body, their signed distances to r are
 * exact, and the linear MLS fit of them (the §5.3.2 fit) gives the signed
 * distance at the particle itself: its sign is the side. Elsewhere, Eq. 21. */
static int acquire_side(const chunk *ck, int j, const uint32_t *col, const float *dist, int o, int bit, double dx) {
    const uint32_t rstar = (uint32_t)(bit / 2 + 1);
    double M[4][4] = {{0}}, y[4] = {0}, coef[4], vote[2] = {0, 0};
    int own = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            for (int k = 0; k < 3; k++) {
                int q = o + (a * NB + b) * NB + k;
                if (!(col[q] >> bit & 1)) continue;
                int neg = col[q] >> (bit - 1) & 1;
                double w = (double)ck->w[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j];
                vote[neg] += w * dist[q];
                if (col[q] >> KF_CPIC_RSTAR_SHIFT != rstar) continue;
                fit_add(M, y, w, neg ? -dist[q] : dist[q], ck, j, a, b, k, 1 / dx);
                own++;
            }
    if (own >= 4 && fabs(solve4(M, y, coef)) > 1e-6 && fabs(coef[3]) > 1e-6) return coef[3] < 0;
    if (vote[0] + vote[1] > 1e-7) return vote[1] > vote[0];
    return -1;
}

/* Over a particle's stencil (base node o), the or of the nodes' colours
 * (B), and per bit of them whether some node has it with the particle's
 * (old) next lower bit (agree) or with the other (across): bit operations
 * alone, so a row of 3 nodes at once where AVX2 is (a zero fourth lane
 * changes none of the ors) gives the same words as node by node. */
static inline void stencil_sides(const uint32_t *col, int o, uint32_t old, uint32_t *B, uint32_t *agree,
                                 uint32_t *across) {
#if defined(__AVX2__)
    const __m128i three = _mm_setr_epi32(-1, -1, -1, 0), vold = _mm_set1_epi32((int)old);
    __m128i b = _mm_setzero_si128(), ag = b, ac = b;
    for (int a = 0; a < 3; a++)
        for (int r = 0; r < 3; r++) {
            const __m128i cn = _mm_maskload_epi32((const int *)&col[o + (a * NB + r) * NB], three);
            const __m128i other = _mm_slli_epi32(_mm_xor_si128(cn, vold), 1);
            b = _mm_or_si128(b, cn);
            ac = _mm_or_si128(ac, _mm_and_si128(cn, other));
            ag = _mm_or_si128(ag, _mm_andnot_si128(other, cn));
        }
    /* the four lanes' ors */
    uint32_t w[3][4];
    _mm_storeu_si128((__m128i *)w[0], b);
    _mm_storeu_si128((__m128i *)w[1], ag);
    _mm_storeu_si128((__m128i *)w[2], ac);
    *B = w[0][0] | w[0][1] | w[0][2] | w[0][3];
    *agree = w[1][0] | w[1][1] | w[1][2] | w[1][3];
    *across = w[2][0] | w[2][1] | w[2][2] | w[2][3];
#else
    uint32_t bs = 0, ag = 0, ac = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            for (int k = 0; k < 3; k++) {
                const uint32_t cn = col[o + (a * NB + b) * NB + k], other = (cn ^ old) << 1;
                bs |= cn;
                ac |= cn & other;
                ag |= cn & ~other;
            }
    *B = bs, *agree = ag, *across = ac;
#endif
}

/* What the colour pass read of a particle's stencil that the nodes across
 * it (nodes_across) can use: the colour it read the nodes' sides against,
 * and the bodies (their A bits) some node of which is on the other side of
 * that colour */
typedef struct stencil_read {
    uint32_t old, differ;
} stencil_read;

/* §5.3.1–5.3.3: the particle's colour (kept, dropped, acquired), and its
 * distance fit queued in f (the sums follow in fit_sums, the solve and the
 * rest in particle_cdf_finish). Writes the colour, and resets pd, pn and
 * near (r*+1 of the fit's closest node, 0 when the fit failed); *sr says
 * what it read of the stencil's sides. */
static void particle_cdf(kf_cpic *c, kf_particles *p, size_t i, const chunk *ck, int j, const uint32_t *col,
                         const float *dist, const uint32_t *oc_aff, double dx, const uint8_t *thin_body, cdf_fit *f,
                         stencil_read *sr) {
    const int o = stencil_base(ck, j);
    sr->old = p->colour[i];
    sr->differ = 0;
    /* no node of the stencil near a body: only the scar stays */
    if (!oc_aff[o]) {
        p->colour[i] = kf_cpic_scar(0, p->colour[i], thin_body);
        c->near[i] = 0;
        c->pd[i] = 0;
        c->pn[3 * i] = c->pn[3 * i + 1] = c->pn[3 * i + 2] = 0;
        return;
    }
    /* one pass over the stencil's colours: B, the bodies some node is close
     * to, and per body (at its A bit) whether some close node is on the
     * particle's recorded side (agree) and some on the other (across) */
    const uint32_t old = p->colour[i];
    uint32_t B, agree, across;
    stencil_sides(col, o, old, &B, &agree, &across);
    sr->differ = across & AFF;
    B &= AFF;
    /* drop bodies no kernel node is close to; keep the rest as they are */
    uint32_t cp = old & ((B | B >> 1));
    /* ... unless every node near body r says the particle is on its other
     * side: with the crossing guard (guard.c) nothing passes through a
     * surface, so such a tag is stale, kept by a particle that went around
     * an edge (a blade's tip) and drifted away from it, too far for the
     * distance fit below to notice; the particle takes its nodes' side. A
     * solid has no edge to go around. (A body cp holds has its side bit as
     * in old, so agree and across read it as cp.) */
    uint32_t thin_mask = 0;
    for (uint32_t held = cp & AFF; held; held &= held - 1) {
        int bit = __builtin_ctz(held); /* 2r + 1 */
        if (thin_body[bit / 2]) thin_mask |= 1u << bit;
    }
    cp ^= (thin_mask & across & ~agree) >> 1;
    /* acquire: the side of the distance-weighted majority (Eq. 21); a side
     * bit kept from before (the scar below) is replaced */
    for (uint32_t need = B & ~cp; need; need &= need - 1) {
        int bit = __builtin_ctz(need); /* 2r + 1 */
        int neg = acquire_side(ck, j, col, dist, o, bit, dx);
        if (neg >= 0) cp = (cp & ~(1u << (bit - 1))) | (1u << bit) | (neg ? 1u << (bit - 1) : 0);
    }
    cp = kf_cpic_scar(cp, p->colour[i], thin_body);
    p->colour[i] = cp;
    c->near[i] = 0;
    c->pd[i] = 0;
    c->pn[3 * i] = c->pn[3 * i + 1] = c->pn[3 * i + 2] = 0;
    if (!(cp & AFF)) return;
    /* its MLS fit of the nodes' distances, queued (fit_sums) */
    const int q = f->n++;
    f->idx[q] = j;
    f->cp[q] = cp;
}

#if !(defined(__AVX2__) && defined(__FMA__) && !defined(KF_DOUBLE))
/* The sums of queued fit q (particle j of the chunk, colour cp): the MLS
 * fit of the nodes' distances, signed relative to the particle, the
 * closest node's body and whether the fit's nodes mix bodies. (Where AVX2
 * is, fit_sums_lanes below does the same four at a time.) */
static void fit_sums_one(const chunk *ck, const uint32_t *col, const float *dist, double inv_dx, cdf_fit *f, int q) {
    const int j = f->idx[q];
    const uint32_t cp = f->cp[q];
    const int o = stencil_base(ck, j);
    fit4 fit;
    fit4_zero(&fit);
    float closest = 1e30f;
    int rstar = -1, first_body = -1, mixed = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            for (int k = 0; k < 3; k++) {
                const int qn = o + (a * NB + b) * NB + k;
                uint32_t cn = col[qn];
                if (!(cn >> KF_CPIC_RSTAR_SHIFT)) continue; /* no distance here */
                uint32_t shared = (cn & cp & AFF) >> 1, differ = (cn ^ cp) & shared;
                int flips = __builtin_popcount(differ);
                if (flips > 1) continue;
                double sgn = flips ? -dist[qn] : dist[qn];
                double w = (double)ck->w[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j];
                fit4_add(&fit, w, sgn, ck, j, a, b, k, inv_dx);
                if (first_body < 0) first_body = (int)(cn >> KF_CPIC_RSTAR_SHIFT);
                mixed |= (int)(cn >> KF_CPIC_RSTAR_SHIFT) != first_body;
                if (dist[qn] < closest) closest = dist[qn], rstar = (int)(cn >> KF_CPIC_RSTAR_SHIFT) - 1;
            }
    double M[4][4], y[4];
    fit4_out(&fit, M, y);
    for (int r = 0; r < 4; r++) {
        for (int k = 0; k < 4; k++) f->M[r][k][q] = M[r][k];
        f->y[r][q] = y[r];
    }
    f->rstar[q] = rstar;
    f->mixed[q] = mixed;
}
#endif

/* the fit's outcome for queued fit q of particle i (colour cp) */
static void particle_cdf_finish(kf_cpic *c, kf_particles *p, size_t i, const cdf_fit *f, int q, double dx,
                                const uint8_t *thin_body) {
    const uint32_t cp = p->colour[i];
    const int rstar = f->rstar[q], mixed = f->mixed[q];
    if (!(fabs(f->det[q]) > 1e-4)) return; /* too few nodes: colour kept, no distance (a full stencil gives 1/64) */
    double coef[4] = {f->coef[0][q], f->coef[1][q], f->coef[2][q], f->coef[3][q]};
    double g2 = coef[0] * coef[0] + coef[1] * coef[1] + coef[2] * coef[2];
    /* A tag that disagrees with the geometry by more than a quarter cell is
     * stale, not a penetration: the crossing guard (guard.c) lets no
     * particle through a surface, so a particle only gets "behind" one by
     * going around its edge (a blade's tip, a plate's rim) while it kept
     * affinity, its old tag naming the side it left. Kept, it would treat
     * its own side's nodes as the far side's. It takes the side it is on.
     * Only where one body is the closest at every node of the fit: where
     * surfaces meet, the fit mixes their distances and its sign is no guide. */
    if (coef[3] < -0.25 && !mixed && rstar >= 0 && (cp >> (2 * rstar + 1) & 1) && thin_body[rstar]) {
        p->colour[i] = cp ^ (1u << (2 * rstar));
        for (int a = 0; a < 4; a++) coef[a] = -coef[a];
    }
    c->near[i] = (uint8_t)(rstar + 1);
    c->pd[i] = (float)(coef[3] * dx);
    if (g2 > 1e-4) {
        double gn = 1 / sqrt(g2);
        for (int a = 0; a < 3; a++) c->pn[3 * i + a] = (float)(coef[a] * gn);
    }
}

/* The nodes of a particle's stencil (base node o) across a surface from it,
 * incompatible with its colour cp: bit n = 9a + 3b + k. 0 for most of the
 * band (material near a surface but not across it): what it sees of the
 * grid is the ordinary MLS-MPM. Where AVX2 is, a row of 3 nodes per
 * 128-bit op (bit operations: the same answer as node by node; a zero
 * fourth lane is compatible and left out). The transfers then visit the
 * nodes across by their bits, in node order, without a test per node. */
static inline uint32_t across_nodes(const uint32_t *col, int o, uint32_t cp) {
    uint32_t xm = 0;
#if defined(__AVX2__)
    const __m128i three = _mm_setr_epi32(-1, -1, -1, 0), vcp = _mm_set1_epi32((int)cp);
    const __m128i aff = _mm_set1_epi32((int)AFF), zero = _mm_setzero_si128();
    for (int r = 0; r < 9; r++) {
        const __m128i cn = _mm_maskload_epi32((const int *)&col[o + stencil_off[3 * r]], three);
        const __m128i shared = _mm_srli_epi32(_mm_and_si128(_mm_and_si128(cn, vcp), aff), 1);
        const __m128i differ = _mm_and_si128(_mm_xor_si128(cn, vcp), shared);
        const int ok = _mm_movemask_ps(_mm_castsi128_ps(_mm_cmpeq_epi32(differ, zero)));
        xm |= (uint32_t)(~ok & 7) << (3 * r);
    }
#else
    for (int n = 0; n < 27; n++) xm |= (uint32_t)!compatible(col[o + stencil_off[n]], cp) << n;
#endif
    return xm;
}

/* The nodes across a surface from a particle of final colour cp (P2G,
 * after its colour pass read the stencil's sides, sr). Where cp has old's
 * side of every body it has affinity to, a node across is one on the other
 * side of such a body than old: there is none unless sr->differ names one
 * of cp's bodies, and then across_nodes finds them. Most of the band has
 * none: the same 0, without a second pass over the stencil. */
static inline uint32_t nodes_across(const uint32_t *col, int o, uint32_t cp, stencil_read sr) {
    const uint32_t bodies = cp & AFF;
    if (!((cp ^ sr.old) & bodies >> 1) && !(sr.differ & bodies)) return 0;
    return across_nodes(col, o, cp);
}

#if defined(__AVX2__) && defined(__FMA__) && !defined(KF_DOUBLE)
/* Lane l of a per-axis plane of the chunk (weights w, offsets d) for the
 * lanes' particles jl[0..3], as doubles */
static inline __m256d lanes_of(const kf_real *plane, const int jl[4]) {
    return _mm256_cvtps_pd(_mm_setr_ps(plane[jl[0]], plane[jl[1]], plane[jl[2]], plane[jl[3]]));
}
#endif

#if defined(__AVX2__) && defined(__FMA__) && !defined(KF_DOUBLE)
/* The row (a, b) of 3 nodes along z of 4 stencils (bases o[l]) as 3
 * registers of 4 lanes, one per node k: each stencil's row loaded (a zero
 * fourth element: the last row of the cache may end there), then
 * transposed */
static inline void rows_of(const uint32_t *src, const int o[4], int off, __m128i out[3]) {
    const __m128i three = _mm_setr_epi32(-1, -1, -1, 0);
    __m128i r[4];
    for (int l = 0; l < 4; l++) r[l] = _mm_maskload_epi32((const int *)&src[o[l] + off], three);
    const __m128i t0 = _mm_unpacklo_epi32(r[0], r[1]), t1 = _mm_unpacklo_epi32(r[2], r[3]);
    const __m128i t2 = _mm_unpackhi_epi32(r[0], r[1]), t3 = _mm_unpackhi_epi32(r[2], r[3]);
    out[0] = _mm_unpacklo_epi64(t0, t1);
    out[1] = _mm_unpackhi_epi64(t0, t1);
    out[2] = _mm_unpacklo_epi64(t2, t3);
}

/* the product a b as a value of its own: the add it goes into is not
 * contracted into a fused multiply-add (as in fit4_add) */
static inline __m256d product(__m256d a, __m256d b) {
    __m256d t = _mm256_mul_pd(a, b);
    __asm__("" : "+x"(t));
    return t;
}

/* fit_sums_one for the queued fits q0..q0+3, one per lane (lanes past the
 * queue's end repeat fit q0 and are not read): each lane the scalar sums'
 * operations in node order, with their roundings. A node the scalar loop
 * passes over (no distance, or more than one flipped side) adds w = 0 and
 * value 0: products of ±0, and x + ±0 is x for every sum, which starts at
 * +0. The sums: w P_r P_c for r, c < 3 (w P_r rounded, then the product),
 * w P_r (M's last column and row, both the same sums), w (M[3][3]),
 * (w value) P_c and w value (y). Bit for bit with fit_sums_one. */
static void fit_sums_lanes(const chunk *ck, const uint32_t *col, const float *dist, double inv_dx, cdf_fit *f,
                           int q0) {
    const int nl = f->n - q0 < 4 ? f->n - q0 : 4;
    int jl[4], o[4];
    uint32_t cpl[4];
    for (int l = 0; l < 4; l++) {
        const int q = q0 + (l < nl ? l : 0);
        jl[l] = f->idx[q];
        cpl[l] = f->cp[q];
        o[l] = stencil_base(ck, jl[l]);
    }
    __m256d W[3][3], P[3][3];
    const __m256d vinv = _mm256_set1_pd(inv_dx);
    for (int ax = 0; ax < 3; ax++)
        for (int t = 0; t < 3; t++) {
            W[ax][t] = lanes_of(ck->w[ax][t], jl);
            P[ax][t] = _mm256_mul_pd(lanes_of(ck->d[ax][t], jl), vinv);
        }
    const __m128i cp = _mm_loadu_si128((const __m128i *)cpl), aff = _mm_set1_epi32((int)AFF);
    const __m128i zero = _mm_setzero_si128(), one = _mm_set1_epi32(1);
    const __m256d sign = _mm256_set1_pd(-0.0);
    __m256d S[3][3], Sr3[3], S33 = _mm256_setzero_pd(), Y[4];
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) S[r][c] = _mm256_setzero_pd();
        Sr3[r] = _mm256_setzero_pd();
    }
    for (int r = 0; r < 4; r++) Y[r] = _mm256_setzero_pd();
    __m128 closest = _mm_set1_ps(1e30f);
    __m128i rstar = _mm_set1_epi32(-1), first = zero, mixed = zero;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            __m128i cr[3], dr[3];
            rows_of(col, o, (a * NB + b) * NB, cr);
            rows_of((const uint32_t *)dist, o, (a * NB + b) * NB, dr);
            const __m256d wab = _mm256_mul_pd(W[0][a], W[1][b]);
            for (int k = 0; k < 3; k++) {
                const __m128i cn = cr[k], body = _mm_srli_epi32(cn, KF_CPIC_RSTAR_SHIFT);
                if (_mm_testz_si128(body, body)) continue; /* no lane's node has a distance: nothing changes */
                const __m128 dn = _mm_castsi128_ps(dr[k]);
                /* used: a distance here, and at most one shared body's side flipped (neg: one) */
                const __m128i shared = _mm_srli_epi32(_mm_and_si128(_mm_and_si128(cn, cp), aff), 1);
                const __m128i differ = _mm_and_si128(_mm_xor_si128(cn, cp), shared);
                const __m128i single = _mm_cmpeq_epi32(_mm_and_si128(differ, _mm_sub_epi32(differ, one)), zero);
                const __m128i use = _mm_andnot_si128(_mm_cmpeq_epi32(body, zero), single);
                const __m128i neg = _mm_andnot_si128(_mm_cmpeq_epi32(differ, zero), use);
                /* the first used node's body, mixed bodies, the closest node (strict) */
                first = _mm_blendv_epi8(first, body, _mm_and_si128(use, _mm_cmpeq_epi32(first, zero)));
                mixed = _mm_or_si128(mixed, _mm_andnot_si128(_mm_cmpeq_epi32(body, first), use));
                const __m128i closer = _mm_and_si128(use, _mm_castps_si128(_mm_cmplt_ps(dn, closest)));
                closest = _mm_blendv_ps(closest, dn, _mm_castsi128_ps(closer));
                rstar = _mm_blendv_epi8(rstar, _mm_sub_epi32(body, one), closer);
                /* the sums, w and value 0 where unused (a node no lane uses adds nothing) */
                if (_mm_testz_si128(use, use)) continue;
                const __m256d use64 = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(use));
                const __m256d neg64 = _mm256_castsi256_pd(_mm256_cvtepi32_epi64(neg));
                const __m256d w = _mm256_and_pd(_mm256_mul_pd(wab, W[2][k]), use64);
                const __m256d value =
                    _mm256_and_pd(_mm256_xor_pd(_mm256_cvtps_pd(dn), _mm256_and_pd(neg64, sign)), use64);
                const __m256d Pn[3] = {P[0][a], P[1][b], P[2][k]};
                __m256d wp[3];
                for (int r = 0; r < 3; r++) wp[r] = product(w, Pn[r]);
                for (int r = 0; r < 3; r++) {
                    for (int c = 0; c < 3; c++) S[r][c] = _mm256_add_pd(S[r][c], product(wp[r], Pn[c]));
                    Sr3[r] = _mm256_add_pd(Sr3[r], wp[r]);
                }
                S33 = _mm256_add_pd(S33, w);
                const __m256d wv = product(w, value);
                for (int c = 0; c < 3; c++) Y[c] = _mm256_add_pd(Y[c], product(wv, Pn[c]));
                Y[3] = _mm256_add_pd(Y[3], wv);
            }
        }
    /* q0..q0+3 are within the chunk's lanes (KF_CHUNK is a multiple of 4) */
    for (int r = 0; r < 3; r++) {
        for (int c = 0; c < 3; c++) _mm256_storeu_pd(&f->M[r][c][q0], S[r][c]);
        _mm256_storeu_pd(&f->M[r][3][q0], Sr3[r]);
        _mm256_storeu_pd(&f->M[3][r][q0], Sr3[r]);
    }
    _mm256_storeu_pd(&f->M[3][3][q0], S33);
    for (int r = 0; r < 4; r++) _mm256_storeu_pd(&f->y[r][q0], Y[r]);
    int rs[4], mx[4];
    _mm_storeu_si128((__m128i *)rs, rstar);
    _mm_storeu_si128((__m128i *)mx, mixed);
    for (int l = 0; l < nl; l++) f->rstar[q0 + l] = rs[l], f->mixed[q0 + l] = mx[l] != 0;
}
#define KF_CPIC_FIT_LANES 1
#endif

/* The queued fits' sums, four at a time where AVX2 is (a chunk's fits are
 * few: the lanes pass over a node no lane's fit uses) */
static void fit_sums(const chunk *ck, const uint32_t *col, const float *dist, double inv_dx, cdf_fit *f) {
#ifdef KF_CPIC_FIT_LANES
    for (int q0 = 0; q0 < f->n; q0 += 4) fit_sums_lanes(ck, col, dist, inv_dx, f, q0);
#else
    for (int q = 0; q < f->n; q++) fit_sums_one(ck, col, dist, inv_dx, f, q);
#endif
}

/* What an across particle's P2G gives each node of its stencil (node n =
 * 9a + 3b + k) in ordinary MLS-MPM (or classic MPM): momentum and mass, for
 * up to 4 particles (lanes), a node's four values side by side: one load
 * and one conversion per node when the scatter adds them. */
typedef struct scatter_adds {
    double add[4][27][4];
} scatter_adds;

/* One particle's adds into lane `lane` of sa (the particle's terms in
 * locals, once: the compiler would load the chunk's floats again at every
 * node otherwise) */
static void node_adds(const chunk *ck, int j, int classic, scatter_adds *sa, int lane) {
    const double mass = ck->mv[3][j];
    double mvj[3], qj[9];
    for (int e = 0; e < 3; e++) mvj[e] = ck->mv[e][j];
    for (int e = 0; e < 9; e++) qj[e] = ck->q[e][j];
    int n = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            for (int k = 0; k < 3; k++, n++) {
                const double w = (double)ck->w[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j];
                const double d[3] = {ck->d[0][a][j], ck->d[1][b][j], ck->d[2][k][j]};
                for (int r = 0; r < 3; r++) {
                    double add = w * (mvj[r] + qj[3 * r] * d[0] + qj[3 * r + 1] * d[1] + qj[3 * r + 2] * d[2]);
                    if (classic) {
                        double gw[3] = {(double)ck->dw[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j],
                                        (double)ck->w[0][a][j] * ck->dw[1][b][j] * ck->w[2][k][j],
                                        (double)ck->w[0][a][j] * ck->w[1][b][j] * ck->dw[2][k][j]};
                        add += ck->t[3 * r][j] * gw[0] + ck->t[3 * r + 1][j] * gw[1] + ck->t[3 * r + 2][j] * gw[2];
                    }
                    sa->add[lane][n][r] = add;
                }
                sa->add[lane][n][3] = w * mass;
            }
}

#if defined(__AVX2__) && defined(__FMA__) && !defined(KF_DOUBLE)
/* node_adds (MLS) for up to 4 particles, one per lane, each lane the
 * scalar code's operations as the compiler contracts them there:
 * w (fma(q_r2, d_z, fma(q_r1, d_y, fma(q_r0, d_x, mv_r)))), and w m, with w the
 * rounded product (w_x w_y) w_z. Bit for bit with node_adds. A node's four
 * values are made by component across the lanes, then transposed to the
 * particles' rows (moves only). */
static void node_adds_lanes(const chunk *ck, const int jl[4], scatter_adds *sa) {
    __m256d W[3][3], D[3][3], mv[4], q[9];
    for (int ax = 0; ax < 3; ax++)
        for (int t = 0; t < 3; t++) {
            W[ax][t] = lanes_of(ck->w[ax][t], jl);
            D[ax][t] = lanes_of(ck->d[ax][t], jl);
        }
    for (int e = 0; e < 4; e++) mv[e] = lanes_of(ck->mv[e], jl);
    for (int e = 0; e < 9; e++) q[e] = lanes_of(ck->q[e], jl);
    int n = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            const __m256d wab = _mm256_mul_pd(W[0][a], W[1][b]);
            for (int k = 0; k < 3; k++, n++) {
                const __m256d w = _mm256_mul_pd(wab, W[2][k]);
                __m256d c4[4];
                for (int r = 0; r < 3; r++) {
                    __m256d t = _mm256_fmadd_pd(q[3 * r], D[0][a], mv[r]);
                    t = _mm256_fmadd_pd(q[3 * r + 1], D[1][b], t);
                    t = _mm256_fmadd_pd(q[3 * r + 2], D[2][k], t);
                    c4[r] = _mm256_mul_pd(w, t);
                }
                c4[3] = _mm256_mul_pd(w, mv[3]);
                const __m256d t0 = _mm256_unpacklo_pd(c4[0], c4[1]), t1 = _mm256_unpackhi_pd(c4[0], c4[1]);
                const __m256d t2 = _mm256_unpacklo_pd(c4[2], c4[3]), t3 = _mm256_unpackhi_pd(c4[2], c4[3]);
                _mm256_storeu_pd(sa->add[0][n], _mm256_permute2f128_pd(t0, t2, 0x20));
                _mm256_storeu_pd(sa->add[1][n], _mm256_permute2f128_pd(t1, t3, 0x20));
                _mm256_storeu_pd(sa->add[2][n], _mm256_permute2f128_pd(t0, t2, 0x31));
                _mm256_storeu_pd(sa->add[3][n], _mm256_permute2f128_pd(t1, t3, 0x31));
            }
        }
}
#define KF_CPIC_SCATTER_LANES 1
#endif

#if defined(__AVX__) && !defined(KF_DOUBLE)
/* For a stencil row's 3 nodes, the lanes of each node that keeps its add
 * (bit k of the index: node k is compatible): nodes 0 and 1 (8 floats),
 * node 2 (4 floats) */
#define KF_KEEP4(k, bit) ((k) >> (bit) & 1 ? -1 : 0)
#define KF_KEEP01(k) {KF_KEEP4(k, 0), KF_KEEP4(k, 0), KF_KEEP4(k, 0), KF_KEEP4(k, 0), \
                      KF_KEEP4(k, 1), KF_KEEP4(k, 1), KF_KEEP4(k, 1), KF_KEEP4(k, 1)}
#define KF_KEEP2(k) {KF_KEEP4(k, 2), KF_KEEP4(k, 2), KF_KEEP4(k, 2), KF_KEEP4(k, 2)}
static const int32_t row_keep01[8][8] = {KF_KEEP01(0), KF_KEEP01(1), KF_KEEP01(2), KF_KEEP01(3),
                                         KF_KEEP01(4), KF_KEEP01(5), KF_KEEP01(6), KF_KEEP01(7)};
static const int32_t row_keep2[8][4] = {KF_KEEP2(0), KF_KEEP2(1), KF_KEEP2(2), KF_KEEP2(3),
                                        KF_KEEP2(4), KF_KEEP2(5), KF_KEEP2(6), KF_KEEP2(7)};
#undef KF_KEEP01
#undef KF_KEEP2
#undef KF_KEEP4
#endif

/* An across particle's adds (add[n]: node n's, in doubles) into the nodes
 * of its stencil (base o) that are compatible (not bits of xm), each
 * rounded to float and added as alone. Where AVX is, a stencil row of 3
 * nodes (12 floats, contiguous in the cache) at a time: the row's nodes
 * with their adds, written back where the node is compatible and as they
 * were where it is across (a blend: the same bits as adding node by node,
 * and a node across untouched). */
static inline void compatible_adds(kf_v4 *cache, int o, uint32_t xm, const double (*add)[4]) {
#if defined(__AVX__) && !defined(KF_DOUBLE)
    for (int row = 0; row < 9; row++) {
        const uint32_t keep = ~xm >> (3 * row) & 7;
        if (!keep) continue;
        const double *ad = add[3 * row];
        float *at = (float *)&cache[o + stencil_off[3 * row]];
        /* the four conversions to float of a node in one (each rounded as alone) */
        const __m256 add01 =
            _mm256_set_m128(_mm256_cvtpd_ps(_mm256_loadu_pd(ad + 4)), _mm256_cvtpd_ps(_mm256_loadu_pd(ad)));
        const __m128 add2 = _mm256_cvtpd_ps(_mm256_loadu_pd(ad + 8));
        const __m256 old01 = _mm256_loadu_ps(at);
        const __m128 old2 = _mm_loadu_ps(at + 8);
        __m256 new01 = _mm256_add_ps(old01, add01);
        __m128 new2 = _mm_add_ps(old2, add2);
        if (keep != 7) {
            const __m256i keep01 = _mm256_loadu_si256((const __m256i *)row_keep01[keep]);
            const __m128i keep2 = _mm_loadu_si128((const __m128i *)row_keep2[keep]);
            new01 = _mm256_blendv_ps(old01, new01, _mm256_castsi256_ps(keep01));
            new2 = _mm_blendv_ps(old2, new2, _mm_castsi128_ps(keep2));
        }
        _mm256_storeu_ps(at, new01);
        _mm_storeu_ps(at + 8, new2);
    }
#else
    for (uint32_t left = ~xm & ((1u << 27) - 1); left; left &= left - 1) {
        const int n = __builtin_ctz(left);
        const double *ad = add[n];
        kf_v4 v4 = {(kf_real)ad[0], (kf_real)ad[1], (kf_real)ad[2], (kf_real)ad[3]};
        cache[o + stencil_off[n]] += v4;
    }
#endif
}

/* One across particle's scatter from its adds (lane `lane` of sa):
 * compatible nodes get them; an incompatible node (bit of xm) gets nothing,
 * and its closest body takes all it would have received (§5.4); G2P takes
 * back the velocity the particle keeps there, computed once, there. A
 * node's sum and a body's are apart, so the compatible nodes go first and
 * the nodes across after them, each set in node order: every sum gets its
 * terms in the order it did node by node. */
static void scatter_across(const kf_model *m, kf_state *s, size_t owner, const kf_cpic_owner *oc, const chunk *ck,
                           int j, size_t i, uint32_t xm, kf_v4 *cache, const scatter_adds *sa, int lane,
                           const uint8_t *thin_body) {
    const uint32_t *col = oc->col;
    const int32_t *bc = &s->g.bcoord[3 * owner];
    const double dx = m->sim.dx, *gdt = oc->gdt;
    double *imp = oc->imp;
    const int apic = m->sim.transfer != KF_TRANSFER_PIC; /* APIC and FLIP carry C */
    const uint32_t cp = s->p.colour[i];
    const int o = stencil_base(ck, j);
    compatible_adds(cache, o, xm, sa->add[lane]);
    double Cj[9];
    for (int e = 0; e < 9; e++) Cj[e] = apic ? s->p.C[e][i] : 0;
#ifdef KF_CPIC_NODE_LANES
    /* the nodes across with a vector's components in lanes: J = fma(m_i,
     * gΔt − C d, the node's momentum) as the scalar loop below rounds it */
    const across_lanes al = across_lanes_of(ck, j, bc, dx, Cj);
    const __m256d gdtv = lanes3(gdt);
    for (uint32_t left = xm; left; left &= left - 1) {
        const int n = __builtin_ctz(left), q = o + stencil_off[n];
        const __m256d add = _mm256_loadu_pd(sa->add[lane][n]);
        const __m256d cd = node_affine(&al, ck, j, n);
        const __m256d J =
            _mm256_fmadd_pd(_mm256_permute4x64_pd(add, _MM_SHUFFLE(3, 3, 3, 3)), _mm256_sub_pd(gdtv, cd), add);
        const int r = (int)(col[q] >> KF_CPIC_RSTAR_SHIFT) - 1;
        const __m256d at = impulse_point(s, owner, oc, ck, j, n, q, r, cp, thin_body[r], node_position(&al, n), dx);
        const impulse_arm arm = impulse_arm_of(&s->rigid[r], at);
        impulse_lanes(imp + 6 * r, &arm, J);
    }
#else
    for (uint32_t left = xm; left; left &= left - 1) {
        const int n = __builtin_ctz(left), q = o + stencil_off[n];
        const double *add = sa->add[lane][n];
        int s3[3];
        double xi[3];
        stencil_node(ck, j, bc, dx, n, s3, xi);
        const double d[3] = {ck->d[0][s3[0]][j], ck->d[1][s3[1]][j], ck->d[2][s3[2]][j]};
        int r = (int)(col[q] >> KF_CPIC_RSTAR_SHIFT) - 1;
        double J[3], cd[3];
        affine_velocity_of(Cj, apic, d, cd);
        for (int e = 0; e < 3; e++) J[e] = add[e] + add[3] * (gdt[e] - cd[e]);
        double at[3] = {xi[0], xi[1], xi[2]};
        if (!thin_body[r]) {
            const int l3[3] = {ck->l[0][j], ck->l[1][j], ck->l[2][j]};
            contact_point(col, oc->dist, q, l3, s3, bc, s->cpic->obox[owner], r, cp, xi, s->rigid[r].com, dx, at);
        }
        kf_cpic_add_impulse(imp + 6 * r, &s->rigid[r], at, J);
    }
#endif
}

void kf_cpic_p2g_chunk(const kf_model *m, kf_state *s, size_t owner, const kf_cpic_owner *oc, chunk *ck, size_t i0,
                       void *cache_v, int classic) {
    kf_cpic *c = s->cpic;
    kf_particles *p = &s->p;
    kf_v4 *cache = cache_v;
    const uint32_t *col = oc->col;
    const float *dist = oc->dist;
    const double dx = m->sim.dx;
    uint8_t thin_body[KF_MAX_RIGIDS];
    for (int r = 0; r < m->nrigid; r++) thin_body[r] = (uint8_t)(m->rigid[r].def.thin != 0);
    /* the colours first (they read the owner's CDF alone, not the cache):
     * a chunk with no particle across a surface scatters as outside the
     * band, the same sums in the same order */
    int across[KF_CHUNK], nacross = 0;
    uint32_t xmask[KF_CHUNK];
    stencil_read sides[KF_CHUNK];
    cdf_fit fit;
    fit.n = 0;
    for (int j = 0; j < ck->n; j++)
        particle_cdf(c, p, i0 + (size_t)j, ck, j, col, dist, oc->aff, dx, thin_body, &fit, &sides[j]);
    fit_sums(ck, col, dist, 1 / dx, &fit);
    solve4_lanes(&fit);
    for (int q = 0; q < fit.n; q++) particle_cdf_finish(c, p, i0 + (size_t)fit.idx[q], &fit, q, dx, thin_body);
    /* the nodes across, kept for G2P (the same colours, the same CDF) */
    const uint32_t *colour = p->colour + i0;
    uint32_t *kept = c->xmask + i0;
    for (int j = 0; j < ck->n; j++) {
        const uint32_t cp = colour[j];
        if (!(cp & AFF)) continue;
        const uint32_t xm = nodes_across(col, stencil_base(ck, j), cp, sides[j]);
        kept[j] = xm;
        if (xm) xmask[nacross] = xm, across[nacross++] = j;
    }
    c->xm_epoch[owner] = c->epoch;
    if (!nacross) {
        if (classic) scatter_chunk(3, 1, ck, cache);
        else scatter_chunk(3, 0, ck, cache);
        return;
    }
    /* particle by particle in order (the nodes' sums in the order of the
     * ordinary scatter); the across particles' adds made four at a time,
     * ahead of the first of them */
    scatter_adds sa;
    for (int j = 0, g = 0; j < ck->n; j++) {
        /* no affinity to any body, or no node across a surface: the ordinary scatter */
        if (g == nacross || across[g] != j) {
            if (classic) scatter_one(3, 1, ck, j, cache);
            else scatter_one(3, 0, ck, j, cache);
            continue;
        }
        if (g % 4 == 0) {
            const int nl = nacross - g < 4 ? nacross - g : 4;
            int jl[4];
            for (int l = 0; l < 4; l++) jl[l] = across[g + (l < nl ? l : 0)];
#ifdef KF_CPIC_SCATTER_LANES
            if (!classic) node_adds_lanes(ck, jl, &sa);
            else
#endif
                for (int l = 0; l < nl; l++) node_adds(ck, jl[l], classic, &sa, l);
        }
        scatter_across(m, s, owner, oc, ck, j, i0 + (size_t)j, xmask[g], cache, &sa, g % 4, thin_body);
        g++;
    }
}

/* What the gather of a particle across a surface reads at each node of its
 * stencil (node n = 9a + 3b + k): the velocity vi (the grid's, or at an
 * incompatible node the ghost velocity) and the affine velocity cd added
 * there (0 at a compatible node), by lane of up to 4 particles. (The lanes'
 * sums, gather_sums_lanes, read the grid's velocities from the node cache
 * themselves: there only the nodes across are filled.) */
typedef struct gather_reads {
    double vi[27][3][4], cd[27][3][4];
} gather_reads;

/* The constants a chunk's ghosts need, made once per chunk. */
typedef struct ghost_ctx {
    const kf_model *m;
    kf_state *s;
    const kf_cpic_owner *oc;
    const kf_v4 *cache;
    double *imp;
    const int32_t *bc;
    size_t owner;
    double dx, dt;
    int apic, classic, need_tau;
    uint8_t uniform[KF_MAX_RIGIDS], thin_body[KF_MAX_RIGIDS];
} ghost_ctx;

/* One particle across a surface, at every node of its stencil: the velocity
 * the gather reads there, into lane `lane` of gr. At an incompatible node,
 * the ghost (Eq. 27): the velocity P2G let the particle keep, plus the
 * push, whose reactions go to the body (in node order: the impulse sums
 * are the same for any grouping of the particles). */
static void ghost_reads(const ghost_ctx *x, chunk *ck, int j, size_t i, uint32_t xm, int presses, int fill_grid,
                        gather_reads *gr, int lane) {
    const kf_model *m = x->m;
    kf_state *s = x->s;
    kf_cpic *c = s->cpic;
    const kf_particles *p = &s->p;
    const uint32_t *col = x->oc->col;
    const int32_t *bc = x->bc;
    const double dx = x->dx, dt = x->dt;
    static const int SYM[9] = {0, 3, 4, 3, 1, 5, 4, 5, 2}; /* τ_ef in the xx yy zz xy xz yz planes */
    const uint32_t cp = p->colour[i];
    const int o = stencil_base(ck, j);
    const double vp[3] = {p->v[0][i], p->v[1][i], p->v[2][i]};
    const double np[3] = {c->pn[3 * i], c->pn[3 * i + 1], c->pn[3 * i + 2]};
    const double mass = p->mass[i];
    double Cj[9];
#ifndef KF_CPIC_NODE_LANES
    double ur[KF_MAX_RIGIDS][3];
#endif
    uint32_t have = 0;
    for (int e = 0; e < 9; e++) Cj[e] = x->apic ? p->C[e][i] : 0;
    /* the particle's stress as P2G scatters it: −Δt V⁰ τ */
    double T[9] = {0};
    for (int e = 0; e < (x->need_tau ? 9 : 0); e++) T[e] = -dt * (double)p->vol0[i] * (double)ck->tau[SYM[e]][j];
    /* (a particle with no separate body's node across its surface presses on none) */
    const uint32_t held =
        presses ? pressed_bodies(m, s, ck, j, col, o, xm, bc, vp, np, T, mass, x->classic, x->uniform) : 0;
    /* every node's grid velocity, with no affine term: what a compatible node gives */
    for (int n = 0; n < (fill_grid ? 27 : 0); n++) {
        const kf_v4 vg = x->cache[o + stencil_off[n]];
        for (int e = 0; e < 3; e++) {
            gr->vi[n][e][lane] = vg[e];
            gr->cd[n][e][lane] = 0;
        }
    }
    /* then the nodes across (bits of xm) in node order, their ghosts over those */
#ifdef KF_CPIC_NODE_LANES
    /* (a vector's components in lanes: the same operations as the scalar loop below) */
    const across_lanes al = across_lanes_of(ck, j, bc, dx, Cj);
    const __m256d npv = lanes3(np);
    __m256d urv[KF_MAX_RIGIDS]; /* ur in lanes */
    for (uint32_t left = xm; left; left &= left - 1) {
        const int n = __builtin_ctz(left), q = o + stencil_off[n];
        const int32_t *s3 = stencil_s3[n];
        const __m256d xi = node_position(&al, n);
        const double w = (double)ck->w[0][s3[0]][j] * ck->w[1][s3[1]][j] * ck->w[2][s3[2]][j];
        const int r = (int)(col[q] >> KF_CPIC_RSTAR_SHIFT) - 1;
        __m256d vi;
        if (x->uniform[r] && (have >> r & 1)) {
            vi = urv[r];
        } else {
            double xs[4], u[3];
            _mm256_storeu_pd(xs, xi);
            kept_velocity(m, s, r, xs, vp, np, (int)(held >> r & 1), u);
            vi = lanes3(u);
            if (x->uniform[r]) urv[r] = vi, have |= 1u << r;
        }
        const __m256d cd = node_affine(&al, ck, j, n);
        /* the body gave P2G's whole share: the kept velocity comes back from it, where P2G's went */
        const double kw = -w * mass;
        const __m256d at = impulse_point(s, x->owner, x->oc, ck, j, n, q, r, cp, x->thin_body[r], xi, dx);
        const impulse_arm arm = impulse_arm_of(&s->rigid[r], at);
        impulse_lanes(x->imp + 6 * r, &arm, _mm256_mul_pd(_mm256_set1_pd(kw), vi));
        double push = m->rigid[r].def.push;
        if (push == KF_RIGID_AUTO) push = 0;
        if (push != 0 && c->near[i]) {
            vi = _mm256_fmadd_pd(_mm256_set1_pd(dt * push), npv, vi);
            impulse_lanes(x->imp + 6 * r, &arm, _mm256_mul_pd(_mm256_set1_pd(kw * dt * push), npv));
        }
        store3(&gr->vi[n][0][lane], 4, vi);
        store3(&gr->cd[n][0][lane], 4, cd);
    }
#else
    for (uint32_t left = xm; left; left &= left - 1) {
        const int n = __builtin_ctz(left), q = o + stencil_off[n];
        int s3[3];
        double vi[3], cd[3], xi[3];
        stencil_node(ck, j, bc, dx, n, s3, xi);
        const int a = s3[0], b = s3[1], k = s3[2];
        const double w = (double)ck->w[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j];
        const double d[3] = {ck->d[0][a][j], ck->d[1][b][j], ck->d[2][k][j]};
        int r = (int)(col[q] >> KF_CPIC_RSTAR_SHIFT) - 1;
        kept_velocity_at(m, s, r, xi, vp, np, (int)(held >> r & 1), x->uniform, &have, ur, vi);
        affine_velocity_of(Cj, x->apic, d, cd);
        /* the body gave P2G's whole share: the kept velocity comes back from it, where P2G's went */
        double K[3] = {-w * mass * vi[0], -w * mass * vi[1], -w * mass * vi[2]}, at[3] = {xi[0], xi[1], xi[2]};
        if (!x->thin_body[r]) {
            const int l3[3] = {ck->l[0][j], ck->l[1][j], ck->l[2][j]};
            contact_point(col, x->oc->dist, q, l3, s3, bc, c->obox[x->owner], r, cp, xi, s->rigid[r].com, dx, at);
        }
        kf_cpic_add_impulse(x->imp + 6 * r, &s->rigid[r], at, K);
        double push = m->rigid[r].def.push;
        if (push == KF_RIGID_AUTO) push = 0;
        if (push != 0 && c->near[i]) {
            double J[3];
            for (int e = 0; e < 3; e++) {
                vi[e] += dt * push * np[e];
                J[e] = -w * mass * dt * push * np[e];
            }
            kf_cpic_add_impulse(x->imp + 6 * r, &s->rigid[r], at, J);
        }
        for (int e = 0; e < 3; e++) {
            gr->vi[n][e][lane] = vi[e];
            gr->cd[n][e][lane] = cd[e];
        }
    }
#endif
}

/* The gather's sums of one particle from its reads (lane `lane` of gr):
 * v = Σ w (vi + cd), B = Σ w vi dᵀ, classic G = Σ vi ∇wᵀ, in node order. */
static void gather_sums(chunk *ck, int j, const gather_reads *gr, int lane, int classic) {
    double v[3] = {0}, B[9] = {0}, G[9] = {0};
    int n = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++)
            for (int k = 0; k < 3; k++, n++) {
                const double w = (double)ck->w[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j];
                const double d[3] = {ck->d[0][a][j], ck->d[1][b][j], ck->d[2][k][j]};
                const double gw[3] = {(double)ck->dw[0][a][j] * ck->w[1][b][j] * ck->w[2][k][j],
                                      (double)ck->w[0][a][j] * ck->dw[1][b][j] * ck->w[2][k][j],
                                      (double)ck->w[0][a][j] * ck->w[1][b][j] * ck->dw[2][k][j]};
                for (int e = 0; e < 3; e++) {
                    const double vi = gr->vi[n][e][lane];
                    v[e] += w * (vi + gr->cd[n][e][lane]);
                    for (int f = 0; f < 3; f++) {
                        B[3 * e + f] += w * vi * d[f];
                        if (classic) G[3 * e + f] += vi * gw[f];
                    }
                }
            }
    for (int e = 0; e < 3; e++) ck->v[e][j] = (kf_real)v[e];
    for (int e = 0; e < 9; e++) {
        ck->b[e][j] = (kf_real)B[e];
        if (classic) ck->g[e][j] = (kf_real)G[e];
    }
}

#if defined(__AVX2__) && defined(__FMA__) && !defined(KF_DOUBLE)
/* gather_sums (MLS) for up to 4 particles at once, one per lane: each lane
 * does the scalar sums' operations in their order, and as the compiler
 * contracts them there: v = fma(w, vi + cd, v), B = fma(w vi, d, B), w the
 * rounded product (w_x w_y) w_z. Bit for bit with gather_sums. A node's
 * grid velocity comes from the node cache (lane l's stencil at base o[l]:
 * four rows of 4 floats transposed, then widened, the same values as
 * ghost_reads' copies), and where lane l's node is across (bit n of xm[l])
 * its ghost and affine term from gr instead; cd is +0 elsewhere, and
 * vi + cd is still added (it turns a −0 into +0, as the scalar sum does). */
static void gather_sums_lanes(chunk *ck, const int jl[4], int nl, const gather_reads *gr, const kf_v4 *cache,
                              const int o[4], const uint32_t xm[4]) {
    __m256d W[3][3], D[3][3];
    for (int ax = 0; ax < 3; ax++)
        for (int t = 0; t < 3; t++) {
            W[ax][t] = lanes_of(ck->w[ax][t], jl);
            D[ax][t] = lanes_of(ck->d[ax][t], jl);
        }
    __m256d v[3], B[9];
    for (int e = 0; e < 3; e++) v[e] = _mm256_setzero_pd();
    for (int e = 0; e < 9; e++) B[e] = _mm256_setzero_pd();
    const uint32_t some = xm[0] | xm[1] | xm[2] | xm[3];
    const __m256i xmv = _mm256_setr_epi64x(xm[0], xm[1], xm[2], xm[3]);
    const float *c0 = (const float *)&cache[o[0]], *c1 = (const float *)&cache[o[1]];
    const float *c2 = (const float *)&cache[o[2]], *c3 = (const float *)&cache[o[3]];
    int n = 0;
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 3; b++) {
            const __m256d wab = _mm256_mul_pd(W[0][a], W[1][b]);
            for (int k = 0; k < 3; k++, n++) {
                const __m256d w = _mm256_mul_pd(wab, W[2][k]);
                const __m256d d[3] = {D[0][a], D[1][b], D[2][k]};
                /* the lanes' grid velocities at node n, by component */
                const int off = 4 * stencil_off[n];
                __m128 r0 = _mm_loadu_ps(c0 + off), r1 = _mm_loadu_ps(c1 + off);
                __m128 r2 = _mm_loadu_ps(c2 + off), r3 = _mm_loadu_ps(c3 + off);
                _MM_TRANSPOSE4_PS(r0, r1, r2, r3);
                __m256d vg[3] = {_mm256_cvtps_pd(r0), _mm256_cvtps_pd(r1), _mm256_cvtps_pd(r2)};
                __m256d cd[3] = {_mm256_setzero_pd(), _mm256_setzero_pd(), _mm256_setzero_pd()};
                if (some >> n & 1) {
                    /* the lanes whose node n is across: their ghost and affine term */
                    const __m256i bit = _mm256_set1_epi64x((long long)1 << n);
                    const __m256d ghost = _mm256_castsi256_pd(_mm256_cmpeq_epi64(_mm256_and_si256(xmv, bit), bit));
                    for (int e = 0; e < 3; e++) {
                        vg[e] = _mm256_blendv_pd(vg[e], _mm256_loadu_pd(gr->vi[n][e]), ghost);
                        cd[e] = _mm256_and_pd(ghost, _mm256_loadu_pd(gr->cd[n][e]));
                    }
                }
                for (int e = 0; e < 3; e++) {
                    const __m256d vi = vg[e];
                    v[e] = _mm256_fmadd_pd(w, _mm256_add_pd(vi, cd[e]), v[e]);
                    const __m256d wv = _mm256_mul_pd(w, vi);
                    for (int f = 0; f < 3; f++) B[3 * e + f] = _mm256_fmadd_pd(wv, d[f], B[3 * e + f]);
                }
            }
        }
    float out[12][4];
    for (int e = 0; e < 3; e++) _mm_storeu_ps(out[e], _mm256_cvtpd_ps(v[e]));
    for (int e = 0; e < 9; e++) _mm_storeu_ps(out[3 + e], _mm256_cvtpd_ps(B[e]));
    for (int l = 0; l < nl; l++) {
        for (int e = 0; e < 3; e++) ck->v[e][jl[l]] = out[e][l];
        for (int e = 0; e < 9; e++) ck->b[e][jl[l]] = out[3 + e][l];
    }
}
#define KF_CPIC_GATHER_LANES 1
#endif

void kf_cpic_g2p_chunk(const kf_model *m, kf_state *s, size_t owner, const kf_cpic_owner *oc, chunk *ck, size_t i0,
                       const void *cache_v, int classic) {
    kf_cpic *c = s->cpic;
    kf_particles *p = &s->p;
    ghost_ctx x = {.m = m,
                   .s = s,
                   .oc = oc,
                   .cache = cache_v,
                   .imp = &c->imp[c->slot[owner]][0][0],
                   .bc = &s->g.bcoord[3 * owner],
                   .owner = owner,
                   .dx = m->sim.dx,
                   .dt = c->dt,
                   .apic = m->sim.transfer != KF_TRANSFER_PIC, /* APIC and FLIP carry C */
                   .classic = classic};
    const uint32_t *col = oc->col;
    uint8_t separate[KF_MAX_RIGIDS];
    for (int r = 0; r < m->nrigid; r++) {
        x.uniform[r] = (uint8_t)uniform_velocity(&s->rigid[r]);
        x.thin_body[r] = (uint8_t)(m->rigid[r].def.thin != 0);
        separate[r] = (uint8_t)(m->rigid[r].def.boundary == KF_BOUNDARY_SEPARATE);
    }
    /* Which particles see a node across a surface (the rest gather as
     * usual), and whether one of those nodes belongs to a separate body:
     * only then is the particle's pressing judged (pressed_bodies), from
     * the stress P2G scattered. Where the stress is not kept it is
     * evaluated again from F (not yet updated by this chunk), which is a
     * whole batch of lanes: most chunks of the band need none of it. */
    int across[KF_CHUNK], presses[KF_CHUNK], nacross = 0;
    uint32_t xmask[KF_CHUNK];
    int need_tau = 0;
    /* P2G's masks where this substep's P2G left them: between P2G and G2P
     * no colour and no node of the CDF changes (an early P2G of the
     * substep before, or none, leaves an older epoch: found again here) */
    const int kept = c->xm_epoch[owner] == c->epoch;
    for (int j = 0; j < ck->n; j++) {
        const uint32_t cp = p->colour[i0 + (size_t)j];
        const int o = stencil_base(ck, j);
        if (!(cp & AFF)) continue;
        const uint32_t xm = kept ? c->xmask[i0 + (size_t)j] : across_nodes(col, o, cp);
        if (!xm) continue;
        int sep = 0;
        for (uint32_t left = xm; left; left &= left - 1)
            sep |= separate[(col[o + stencil_off[__builtin_ctz(left)]] >> KF_CPIC_RSTAR_SHIFT) - 1];
        need_tau |= sep;
        presses[nacross] = sep, xmask[nacross] = xm, across[nacross++] = j;
    }
    x.need_tau = need_tau;
    kf_real tbuf[6][KF_CHUNK] __attribute__((aligned(64)));
    if (need_tau && (p->zero & KF_ZERO_TAU)) {
        kf_real *const out[6] = {tbuf[0], tbuf[1], tbuf[2], tbuf[3], tbuf[4], tbuf[5]};
        kf_stress_eval(m, p, i0, ck->n, out);
        for (int k = 0; k < 6; k++) ck->tau[k] = tbuf[k];
    } else {
        for (int k = 0; k < 6; k++) ck->tau[k] = need_tau ? p->tau[k] + i0 : NULL;
    }
    /* every particle's ordinary gather as one chunk (the rows of the
     * particles outside the band's, the same sums); those across a surface
     * then write theirs over it, four at a time: their reads (and the
     * bodies' impulses) particle by particle in order, then their sums in
     * lanes */
    if (classic) gather_chunk(3, 1, ck->n, ck, x.cache);
    else gather_chunk(3, 0, ck->n, ck, x.cache);
    gather_reads gr;
#ifdef KF_CPIC_GATHER_LANES
    const int fill_grid = classic; /* the lanes read the grid's velocities themselves */
#else
    const int fill_grid = 1;
#endif
    for (int g0 = 0; g0 < nacross; g0 += 4) {
        const int nl = nacross - g0 < 4 ? nacross - g0 : 4;
        int jl[4];
        for (int l = 0; l < 4; l++) jl[l] = across[g0 + (l < nl ? l : 0)];
        for (int l = 0; l < nl; l++)
            ghost_reads(&x, ck, jl[l], i0 + (size_t)jl[l], xmask[g0 + l], presses[g0 + l], fill_grid, &gr, l);
#ifdef KF_CPIC_GATHER_LANES
        if (!classic) {
            /* the unused lanes repeat lane 0's stencil with no node across (their sums are not stored) */
            int ol[4];
            uint32_t xl[4];
            for (int l = 0; l < 4; l++) {
                ol[l] = stencil_base(ck, jl[l]);
                xl[l] = l < nl ? xmask[g0 + l] : 0;
            }
            gather_sums_lanes(ck, jl, nl, &gr, x.cache, ol, xl);
            continue;
        }
#endif
        for (int l = 0; l < nl; l++) gather_sums(ck, jl[l], &gr, l, classic);
    }
}

void kf_cpic_penalty(const kf_model *m, kf_state *s, size_t owner, size_t i0, int n) {
    kf_cpic *c = s->cpic;
    kf_particles *p = &s->p;
    double *imp = &c->imp[c->slot[owner]][0][0];
    const double dx = m->sim.dx;
    for (int j = 0; j < n; j++) {
        size_t i = i0 + (size_t)j;
        if (!c->near[i]) continue;
        int r = c->near[i] - 1;
        double k = m->rigid[r].def.penalty, d = c->pd[i];
        /* slightly penetrated (Eq. 22), measured at the particle's extent: a
         * particle stands for a cube of side vol0^(1/3), and it has entered
         * the body once that cube has, with its centre still half a side out.
         * Measured by the centre, material rests with its particles' centres
         * on the face and so overlaps the body by half a particle spacing
         * (a floating block sat a quarter cell deeper than Archimedes with
         * 8 particles per cell). Deeper than the splat's reach minus the
         * kernel (1 cell for a thin body, 2 inside a solid) the fit is not
         * trusted. */
        double depth = m->rigid[r].def.thin ? dx : 2 * dx, half = 0.5 * cbrt((double)p->vol0[i]);
        if (k == 0 || !(d < half && d > -depth)) continue;
        d -= half;
        /* auto, around a solid: off, since the support under a loaded face is
         * the grid's and both contact forms below disturb it
         * (docs/lab-notes.md, "Penalty around solids"). A number still gives
         * the paper's kick. */
        if (k == KF_RIGID_AUTO && !m->rigid[r].def.thin) continue;
        if (k == KF_RIGID_AUTO) {
            /* auto, on a thin body: the skin is a contact, not a spring. A particle found
             * inside it (d, from P2G's fit at the substep's start, carried to
             * its new position relative to the body) is put back on the skin
             * and loses its approach toward the body as the boundary type
             * says, the body taking that momentum: material rests on a body
             * as a sphere of half its spacing, without bouncing. Springs and
             * position-only fixes were tried and rejected (docs/lab-notes.md,
             * "The skin on thin bodies"). */
            double x[3] = {p->x[0][i], p->x[1][i], p->x[2][i]}, V[3], moved = 0;
            kf_rigid_point_velocity(&c->end[r], x, V);
            const double nrm[3] = {c->pn[3 * i], c->pn[3 * i + 1], c->pn[3 * i + 2]};
            for (int a = 0; a < 3; a++) moved += ((double)p->v[a][i] - V[a]) * c->dt * nrm[a];
            double overlap = -(d + moved); /* d is already measured from the skin (d -= half) */
            if (overlap <= 0) continue;
            for (int a = 0; a < 3; a++) p->x[a][i] += (kf_real)(overlap * nrm[a]), x[a] = p->x[a][i];
            double w[3], w0[3], J[3], wn = 0;
            kf_rigid_point_velocity(&c->end[r], x, V);
            for (int a = 0; a < 3; a++) w[a] = w0[a] = (double)p->v[a][i] - V[a], wn += w[a] * nrm[a];
            if (wn >= 0 && m->rigid[r].def.boundary != KF_BOUNDARY_STICKY) continue;
            kf_project_velocity(w, nrm, m->rigid[r].def.boundary, m->rigid[r].def.friction);
            for (int a = 0; a < 3; a++) {
                double dv = w[a] - w0[a];
                p->v[a][i] += (kf_real)dv;
                J[a] = -p->mass[i] * dv;
            }
            kf_cpic_add_impulse(imp + 6 * r, &s->rigid[r], x, J);
            continue;
        }
        /* the penetration closes at rate k, but never faster than within this
         * substep: k Δt <= 1 (a larger kick would overshoot and, repeated
         * every substep, blow up) */
        double rate = k * c->dt < 1 ? k : 1 / c->dt;
        double x[3] = {p->x[0][i], p->x[1][i], p->x[2][i]}, J[3];
        for (int a = 0; a < 3; a++) {
            double dv = -rate * d * c->pn[3 * i + a];
            p->v[a][i] += (kf_real)dv;
            J[a] = -p->mass[i] * dv;
        }
        kf_cpic_add_impulse(imp + 6 * r, &s->rigid[r], x, J);
    }
}

void kf_cpic_finish(const kf_model *m, kf_state *s, double dt) {
    kf_cpic *c = s->cpic;
    if (s->dist) {
        /* across ranks: every rank's band owners, summed in the one-rank order
         * (a rank without band owners may have no impulse rows at all) */
        kf_dist_rigid_sum(s, m->nrigid, c->nslot, c->nslot ? &c->imp[0][0][0] : NULL, KF_MAX_RIGIDS * 6,
                          c->guard_caught, c->guard_depth, &c->impulse[0][0], &c->caught, &c->caught_depth);
        for (int r = 0; r < m->nrigid; r++)
            for (int e = 0; e < 6; e++) c->impulse_total[r][e] += c->impulse[r][e];
        kf_rigid_sim_step(s->rsim, m->rigid, m->nrigid, s->rigid, s->time, dt, (const double(*)[6])c->impulse);
        return;
    }
    memset(c->impulse, 0, sizeof c->impulse);
    /* in owner order: the sum does not depend on the thread count */
    for (size_t k = 0; k < c->nslot; k++)
        for (int r = 0; r < m->nrigid; r++)
            for (int e = 0; e < 6; e++) c->impulse[r][e] += c->imp[k][r][e];
    for (int r = 0; r < m->nrigid; r++)
        for (int e = 0; e < 6; e++) c->impulse_total[r][e] += c->impulse[r][e];
    c->caught = 0;
    c->caught_depth = 0;
    for (size_t k = 0; k < c->nslot; k++) {
        c->caught += c->guard_caught[k];
        if (c->guard_depth[k] > c->caught_depth) c->caught_depth = c->guard_depth[k];
    }
    kf_rigid_sim_step(s->rsim, m->rigid, m->nrigid, s->rigid, s->time, dt, (const double(*)[6])c->impulse);
}

void kf_cpic_caught(const kf_state *s, long *caught, double *depth) {
    *caught = s->cpic ? s->cpic->caught : 0;
    *depth = s->cpic ? s->cpic->caught_depth : 0;
}
