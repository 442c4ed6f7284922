/* transfer.c — particle-to-grid and grid-to-particle transfers.
 *
 * One code path serves MLS-MPM and classic MPM (kf_sim_def.force), quadratic
 * and cubic B-splines, APIC and PIC, so the variants are compared on equal
 * footing. The kernel width and the force are compile-time constants of each
 * specialisation (always-inlined bodies instantiated by the dispatchers), so
 * the stencil loops unroll.
 *
 * Both transfers work owner block by owner block (grid.h): the block's
 * particles scatter into, or gather from, a small dense cache of the block's
 * 2x2x2 neighbourhood, and only the cache touches the sparse grid.
 *
 * The Kirchhoff stress each particle scatters was computed at the end of the
 * previous substep (kf_stress, with the return mapping that produced F).
 *
 * Inside a block, particles go in chunks of KF_CHUNK, in phases: the
 * per-particle algebra (kernel weights, Q, C, the F update, checks)
 * runs as loops across the chunk's particles that the compiler turns into
 * SIMD over particles; only the stencil scatter and gather run particle by
 * particle, with one node row (a kf_v4) per vector operation.
 *
 * FLIP (sim.transfer: flip). APIC keeps the affine part of each particle's
 * velocity and drops the rest at every transfer, so fine motion decays
 * with the number of substeps, not with time: a jelly bar 4 cells thick
 * ringing for 10 periods keeps 31% of its energy at CFL 0.4 and 4% at 0.1.
 * Flip keeps APIC's C (from the new grid velocity) and sets
 *     v_p ← Σ w v_i + r (v_p − Σ w v_i⁰),
 * v_i⁰ the grid's velocity before the substep's forces: a second scatter of
 * the momentum alone (m v + m C d, without the stress impulse MLS fuses
 * into the first), into a grid array that exists only under flip, and a
 * second gather. The bar keeps 60% and 54%. Against polypic (below): flip
 * keeps the particle's extra velocity (times r) with no per-particle
 * storage and the same stencil loops, but the grid never sees it. Why it is safe
 * for solids: positions and F still follow the grid (x += Δt Σ w v_i,
 * F ← (I + Δt L) F, L from the grid), so the particle's extra velocity
 * never deforms material itself; it reaches the grid only as momentum in
 * the next P2G, which conserves it exactly (the added parts sum to zero:
 * Σ_p m_p Σ_i w v_i⁰ = Σ_i m_i v_i⁰ = Σ_p m_p v_p). What the grid cannot
 * see of it (the transfer's null space, FLIP's noise) is not amplified,
 * and r < 1 damps it by r per substep (0.95: e-fold in 20 substeps). Near
 * a rigid body (CPIC's band) and where objects meet (contact fields) the
 * particle's velocity comes from the nodes it is compatible with or from
 * its own field, which the shared old velocity does not describe: APIC
 * there.
 *
 * PolyPIC (sim.transfer: polypic, quadratic kernel). Each particle also
 * keeps the 23 velocity modes of its 3x3x3 stencil beyond APIC's four
 * (polypic.h): G2P projects the new grid velocity onto all 27, P2G
 * scatters them back, so what a transfer loses is only what the particles'
 * motion between the two blurs, and the grid sees all of what is kept
 * (flip's extra velocity it never sees). V7's stretched cube at 16 cells
 * keeps 65% of its energy over 10 periods at CFL 0.4, where pure FLIP
 * keeps 51%. The modes live in a table by particle id (kf_state.poly), so
 * the particle arrays, checkpoints and the MPI record are unchanged; a
 * restart begins with them zero. Near rigid surfaces and where objects
 * meet: APIC, as for flip. */
#include <omp.h>
#include <stdatomic.h>
#include <stdio.h>
#include <string.h>

#include "../core/expm.h"
#include "../core/mat3.h"
#include "../core/timer.h"
#include "model.h"

#include "transfer_chunk.h"
#include "polypic.h"

#include "contact.h"
#include "cpic_seam.h"
#include "../dist/dist.h"

/* CPIC's per-owner colour cache is indexed like the node cache */
_Static_assert(KF_CPIC_NB == KF_CACHE_EDGE, "CPIC's owner cache is laid out like the transfer's");

/* ---- P2G ---------------------------------------------------------------------- */

/* the stress section's: the materials a stress pass evaluates, and a
 * chunk's stress evaluated with them */
static const kf_mat *stress_mats(const kf_model *m, kf_mat buf[KF_MAX_MATERIALS]);
static void stress_eval_mats(const kf_mat *mats, kf_particles *p, size_t first, int n, kf_real *const out[6]);

/* fused (kf_g2p2g, the next substep's scatter made early): a stencil
 * outside the owner's neighbourhood or a non-finite stress makes the
 * scatter unusable (returns 1 at once; the next substep bins and scatters
 * as usual, and reports the trouble then) */
/* what one owner's P2G chunks share (p2g_block_cache) */
typedef struct p2g_owner {
    const kf_model *m;
    const kf_mat *mats; /* eval: stress_mats's, resolved once an owner */
    kf_state *s;
    size_t r;
    kf_real dt, dx, inv_dx, minv;
    const int32_t *bc;
    int apic, poly, band, fields, eval, fused;
    kf_cpic_owner *oc;
    kf_v4 *cache, *mcache, *fcache;
    step_acc *acc;
} p2g_owner;

/* A chunk's per-particle P2G terms in one pass across its particles, each
 * lane the expressions of the per-plane loops it replaced (so the same
 * roundings): Q = m C − Δt V⁰ D⁻¹ τ (MLS), or m C and the separate force
 * term −Δt V⁰ τ / Δx (classic), PIC without m C, FLIP's m C alone; m v
 * and m. τ (tc: xx yy zz xy xz yz) is read once per entry, six planes for
 * Q's nine (τ_ij = τ_ji). APIC a constant, as the per-plane loops had it
 * after the compiler took the test out of them: m C + Δt V⁰ D⁻¹ τ then
 * contracts to the same multiply-add. Returns whether any τ is not
 * finite. */
KF_INLINE int p2g_terms(int CLASSIC, int FLIP, int APIC, int n, chunk *ck, const kf_particles *p, size_t i0,
                        const kf_real *const tc[6], kf_real dt, kf_real inv_dx, kf_real minv) {
    const kf_real *restrict mass = p->mass + i0, *restrict vol = p->vol0 + i0;
    const kf_real *restrict t0 = tc[0], *restrict t1 = tc[1], *restrict t2 = tc[2];
    const kf_real *restrict t3 = tc[3], *restrict t4 = tc[4], *restrict t5 = tc[5];
    const kf_real *restrict C0 = p->C[0] + i0, *restrict C1 = p->C[1] + i0, *restrict C2 = p->C[2] + i0;
    const kf_real *restrict C3 = p->C[3] + i0, *restrict C4 = p->C[4] + i0, *restrict C5 = p->C[5] + i0;
    const kf_real *restrict C6 = p->C[6] + i0, *restrict C7 = p->C[7] + i0, *restrict C8 = p->C[8] + i0;
    const kf_real *restrict v0 = p->v[0] + i0, *restrict v1 = p->v[1] + i0, *restrict v2 = p->v[2] + i0;
    int bad = 0;
    KF_SIMD_OR(bad)
    for (int j = 0; j < n; j++) {
        const kf_real m = mass[j];
        /* the stress term −Δt V⁰ τ, once per entry of τ */
        const kf_real st0 = -dt * vol[j] * t0[j], st1 = -dt * vol[j] * t1[j], st2 = -dt * vol[j] * t2[j];
        const kf_real st3 = -dt * vol[j] * t3[j], st4 = -dt * vol[j] * t4[j], st5 = -dt * vol[j] * t5[j];
        bad |= !(kf_fabs(t0[j]) < (kf_real)1e30) | !(kf_fabs(t1[j]) < (kf_real)1e30) |
               !(kf_fabs(t2[j]) < (kf_real)1e30) | !(kf_fabs(t3[j]) < (kf_real)1e30) |
               !(kf_fabs(t4[j]) < (kf_real)1e30) | !(kf_fabs(t5[j]) < (kf_real)1e30);
        /* entry k of Q from C's entry k and τ's entry s (row-major ij to xx yy zz xy xz yz) */
#define P2G_Q(k, s)                                                                                                    \
    {                                                                                                                  \
        const kf_real mc = APIC ? m * C##k[j] : 0;                                                                     \
        if (FLIP) ck->qm[k][j] = mc;                                                                                   \
        if (CLASSIC) {                                                                                                 \
            ck->q[k][j] = mc;                                                                                          \
            ck->t[k][j] = st##s * inv_dx;                                                                              \
        } else {                                                                                                       \
            ck->q[k][j] = mc + minv * st##s;                                                                           \
        }                                                                                                              \
    }
        P2G_Q(0, 0) P2G_Q(1, 3) P2G_Q(2, 4) P2G_Q(3, 3) P2G_Q(4, 1) P2G_Q(5, 5) P2G_Q(6, 4) P2G_Q(7, 5) P2G_Q(8, 2)
#undef P2G_Q
        ck->mv[0][j] = m * v0[j];
        ck->mv[1][j] = m * v1[j];
        ck->mv[2][j] = m * v2[j];
        ck->mv[3][j] = m;
    }
    return bad;
}

/* one chunk of an owner's particles from i0: n of them, a constant
 * KF_CHUNK for every full chunk (each per-particle loop is then one
 * register per row, with no remainder code or alias checks) or the
 * owner's tail; the stencil's base offsets widen lo..hi. Returns 1 where
 * the fused sweep's scatter is unusable. */
KF_INLINE int p2g_chunk(int KW, int CLASSIC, int FLIP, int n, const p2g_owner *o, chunk *ck, size_t i0, int lo[3],
                        int hi[3]) {
    const int CD = CD_MAX;
    const kf_model *m = o->m;
    kf_state *s = o->s;
    kf_particles *p = &s->p;
    const size_t r = o->r;
    const kf_real dt = o->dt, inv_dx = o->inv_dx, minv = o->minv;
    const int apic = o->apic, band = o->band, fields = o->fields, eval = o->eval, fused = o->fused;
    kf_v4 *cache = o->cache;
    ck->n = n;
    /* the planes this chunk's successors read */
    prefetch_planes(p->x, 3, i0, 0);
    prefetch_planes(p->v, 3, i0, 0);
    prefetch_planes(p->C, 9, i0, 0);
    if (!eval) prefetch_planes(p->tau, 6, i0, 0);
    prefetch_planes(&p->mass, 1, i0, 0);
    prefetch_planes(&p->vol0, 1, i0, 0);
    /* the weight gradients only where a caller reads them (classic MPM,
     * CPIC's band, the objects' own fields, polypic) */
    if (CLASSIC || band || fields || o->poly) stencil_phase_n(KW, 1, 1, 0, n, ck, p->x, i0, o->bc, inv_dx, o->dx);
    else stencil_phase_n(KW, 0, 1, 0, n, ck, p->x, i0, o->bc, inv_dx, o->dx);
    /* the base offsets' range, all three axes in one pass (min and max are exact in any order) */
    {
        const int *restrict l0 = ck->l[0], *restrict l1 = ck->l[1], *restrict l2 = ck->l[2];
        int lo0 = lo[0], lo1 = lo[1], lo2 = lo[2], hi0 = hi[0], hi1 = hi[1], hi2 = hi[2];
        _Pragma("omp simd reduction(min : lo0, lo1, lo2) reduction(max : hi0, hi1, hi2)")
        for (int j = 0; j < n; j++) {
            lo0 = l0[j] < lo0 ? l0[j] : lo0, hi0 = l0[j] > hi0 ? l0[j] : hi0;
            lo1 = l1[j] < lo1 ? l1[j] : lo1, hi1 = l1[j] > hi1 ? l1[j] : hi1;
            lo2 = l2[j] < lo2 ? l2[j] : lo2, hi2 = l2[j] > hi2 ? l2[j] : hi2;
        }
        lo[0] = lo0, lo[1] = lo1, lo[2] = lo2, hi[0] = hi0, hi[1] = hi1, hi[2] = hi2;
    }
    /* binned particles fit by construction; after the fused G2P one
     * may have drifted out of reach (binning will re-sort it) */
    if (fused && (lo[0] < 0 || lo[1] < 0 || lo[2] < 0 || hi[0] > CD - KW || hi[1] > CD - KW || hi[2] > CD - KW))
        return 1;

    /* Q = m C − Δt V⁰ D⁻¹ τ (MLS), or m C and the separate force term
     * −Δt V⁰ τ ∇w (classic); PIC drops m C */
    const kf_real *restrict mass = p->mass + i0;
    /* the stress not kept (KF_ZERO_TAU): the chunk's evaluated from F here */
    kf_real tbuf[6][KF_CHUNK] __attribute__((aligned(64)));
    kf_real *const tout[6] = {tbuf[0], tbuf[1], tbuf[2], tbuf[3], tbuf[4], tbuf[5]};
    const kf_real *tc[6];
    if (eval) stress_eval_mats(o->mats, p, i0, n, tout);
    for (int k = 0; k < 6; k++) tc[k] = eval ? tbuf[k] : p->tau[k] + i0;
    /* Q, m v and m, and τ's finiteness: one pass across the chunk */
    int bad = apic ? p2g_terms(CLASSIC, FLIP, 1, n, ck, p, i0, tc, dt, inv_dx, minv)
                   : p2g_terms(CLASSIC, FLIP, 0, n, ck, p, i0, tc, dt, inv_dx, minv);
    if (bad && fused) return 1;
    if (bad) {
        /* catch non-finite state where it starts, before P2G spreads it */
        for (int j = 0; j < n; j++)
            for (int k = 0; k < 6; k++)
                if (!(kf_fabs(tc[k][j]) < (kf_real)1e30))
                    note_trouble(o->acc, p, i0 + (size_t)j, "NaN or Inf stress", (double)tc[k][j], s->substep);
    }

    /* near a rigid surface: compatible nodes only, impulses on the bodies */
    if (band) kf_cpic_p2g_chunk(m, s, r, o->oc, ck, i0, cache, CLASSIC);
    /* scatter: one node row per vector op, Q d as three column FMAs */
    else scatter_chunk_n(KW, CLASSIC, n, ck, cache);
    /* where objects meet: each particle's share into its own field too */
    if (fields) kf_contact_p2g_chunk(m, s, r, band ? o->oc->col : NULL, ck, i0, KW, CLASSIC, o->fcache);
    /* polypic, away from rigid surfaces and objects' own fields (APIC
     * there, as for flip): each particle's higher modes */
    if (o->poly && !band && !fields)
        for (int j = 0; j < n; j++)
            poly_scatter(ck, j, inv_dx, mass[j], &s->poly[(size_t)p->id[i0 + (size_t)j] * KF_POLY_REALS], cache);
    /* FLIP: the momentum alone, on every node the ordinary scatter
     * reaches (in the band too: a particle outside the band reads only
     * nodes no rigid surface colours, where both scatters agree) */
    if (FLIP)
        for (int j = 0; j < n; j++) scatter_momentum(KW, ck, j, o->mcache);
    return 0;
}

/* P2G's flags: the fused sweep's early scatter (p2g_chunk stops where a
 * particle is out of reach), and caches that arrive zero (kf_p2g's driver
 * keeps its own so: each flush clears the part it read, some 40% of the
 * cache, where a memset clears all 512 nodes an owner) */
enum { P2G_FUSED = 1, P2G_ZEROED = 2 };

KF_INLINE int p2g_block_cache(int KW, int CLASSIC, int FLIP, const kf_model *m, kf_state *s, size_t r, kf_real dt,
                              kf_v4 *cache, kf_v4 *mcache, kf_v4 *fcache, chunk *ck, step_acc *acc, int lohi[6],
                              int flags) {
    const int fused = flags & P2G_FUSED;
    const int CD = CD_MAX;
    kf_particles *p = &s->p;
    kf_grid *g = &s->g;
    const int band = kf_cpic_band(s, r), fields = kf_contact_owner(s, r);
    kf_cpic_owner oc; /* near a rigid surface: the neighbourhood's CDF, once per block */
    if (band) kf_cpic_owner_cdf(s, r, &oc);
    /* the next substep's, made early: its impulse rows and gΔt, its particles' colours kept */
    if (band && fused) kf_cpic_early_owner(s, r, &oc);
    if (!(flags & P2G_ZEROED)) {
        memset(cache, 0, sizeof(kf_v4) * CD * CD * CD);
        if (FLIP) memset(mcache, 0, sizeof(kf_v4) * CD * CD * CD);
    }
    if (fields) memset(fcache, 0, sizeof(kf_v4) * KF_CONTACT_CACHE_ROWS * CD * CD * CD);
    /* the base offsets the block's particles use: only their nodes are flushed */
    int lo[3] = {CD, CD, CD}, hi[3] = {0, 0, 0};
    /* the stress not kept (KF_ZERO_TAU): the materials it is evaluated with */
    const int eval = (p->zero & KF_ZERO_TAU) != 0;
    kf_mat limited_mat[KF_MAX_MATERIALS];
    /* the binning's 1/Δx, bit for bit: each stencil base must lie in its owner block (model.h) */
    const p2g_owner o = {.m = m,
                         .mats = eval ? stress_mats(m, limited_mat) : NULL,
                         .s = s,
                         .r = r,
                         .dt = dt,
                         .dx = (kf_real)m->sim.dx,
                         .inv_dx = kf_model_inv_dx(m),
                         .minv = (kf_real)(1.0 / kf_model_dfactor(m)),
                         .bc = &g->bcoord[3 * r],
                         .apic = m->sim.transfer != KF_TRANSFER_PIC, /* APIC, FLIP and polypic carry C */
                         .poly = m->sim.transfer == KF_TRANSFER_POLYPIC,
                         .band = band,
                         .fields = fields,
                         .eval = eval,
                         .fused = fused,
                         .oc = band ? &oc : NULL,
                         .cache = cache,
                         .mcache = mcache,
                         .fcache = fcache,
                         .acc = acc};
    for (size_t i0 = g->pstart[r]; i0 < g->pstart[r + 1]; i0 += KF_CHUNK) {
        const size_t left = g->pstart[r + 1] - i0;
        const int stop = left >= KF_CHUNK ? p2g_chunk(KW, CLASSIC, FLIP, KF_CHUNK, &o, ck, i0, lo, hi)
                                          : p2g_chunk(KW, CLASSIC, FLIP, (int)left, &o, ck, i0, lo, hi);
        if (stop) return 1;
    }

    for (int a = 0; a < 3; a++) lohi[a] = lo[a], lohi[3 + a] = hi[a];
    return 0;
}

/* FLIP: the touched part of the momentum cache into the old-velocity
 * nodes, and back to zero for the next owner (kf_p2g's caches stay zero) */
KF_INLINE void p2g_flush_old(int KW, kf_grid *g, const int32_t *nb, kf_v4 *cache, const int lohi[6]) {
    const int CD = CD_MAX;
    for (int a = lohi[0]; a < lohi[3] + KW; a++)
        for (int b = lohi[1]; b < lohi[4] + KW; b++) {
            kf_v4 *row = &cache[(a * CD + b) * CD];
            for (int c = lohi[2]; c < lohi[5] + KW; c++) {
                size_t at = (size_t)(nb_node(g, nb, a, b, c) - g->node);
                g->node_old[at] += row[c];
                row[c] = (kf_v4){0, 0, 0, 0};
            }
        }
}

/* the touched part of the cache (lohi: base offsets lo, hi per axis) into
 * the 8 blocks of the neighbourhood nb, in the node array (the grid's
 * nodes, or the fused step's next ones); with CLEAR each row's touched
 * part cleared once added (in L1 still): kf_p2g's caches are zero again
 * for their next owner, with the same sums */
KF_INLINE void p2g_flush_rows(int KW, int CLEAR, kf_v4 *node, const int32_t *nb, kf_v4 *cache, const int lohi[6]) {
    const int CD = CD_MAX;
    /* per cache row, the part in the lower z block, then the upper one */
    const int c0 = lohi[2], c1 = lohi[5] + KW, cm = c1 < KF_BLOCK ? c1 : KF_BLOCK;
    const int cu = c0 > KF_BLOCK ? c0 : KF_BLOCK;
    for (int a = lohi[0]; a < lohi[3] + KW; a++)
        for (int b = lohi[1]; b < lohi[4] + KW; b++) {
            kf_v4 *row = &cache[(a * CD + b) * CD];
            kf_v4 *lo = nb_row(node, nb, a, b, 0), *hi = nb_row(node, nb, a, b, 1);
            for (int c = c0; c < cm; c++) {
                lo[c] += row[c];
                if (CLEAR) row[c] = (kf_v4){0, 0, 0, 0};
            }
            for (int c = cu; c < c1; c++) {
                hi[c - KF_BLOCK] += row[c];
                if (CLEAR) row[c] = (kf_v4){0, 0, 0, 0};
            }
        }
}
/* the cache left as it is (another rank's, kf_p2g_add_cache): only read */
KF_INLINE void p2g_flush(int KW, kf_v4 *node, const int32_t *nb, const kf_v4 *cache, const int lohi[6]) {
    p2g_flush_rows(KW, 0, node, nb, (kf_v4 *)cache, lohi);
}
/* the cache zero again after */
KF_INLINE void p2g_flush_clear(int KW, kf_v4 *node, const int32_t *nb, kf_v4 *cache, const int lohi[6]) {
    p2g_flush_rows(KW, 1, node, nb, cache, lohi);
}

/* The cache of one owner block, one compiled function per variant: the
 * grid's own P2G and another rank's halo (kf_p2g_owner_cache) run the same
 * machine code, so their caches agree to the bit (a second inlined copy may
 * contract multiply-adds differently). */
#define P2G_VARIANT(name, KW, CLASSIC)                                                                                 \
    __attribute__((noinline)) static int name(const kf_model *m, kf_state *s, size_t r, kf_real dt, kf_v4 *cache,      \
                                              kf_v4 *fcache, chunk *ck, step_acc *acc, int lohi[6], int flags) {       \
        return p2g_block_cache(KW, CLASSIC, 0, m, s, r, dt, cache, NULL, fcache, ck, acc, lohi, flags);                \
    }
P2G_VARIANT(p2g_q_mls, 3, 0)
P2G_VARIANT(p2g_q_classic, 3, 1)
P2G_VARIANT(p2g_c_mls, 4, 0)
P2G_VARIANT(p2g_c_classic, 4, 1)

/* FLIP: the same with the momentum cache (one rank only: kf_dist_unsupported) */
#define P2G_FLIP_VARIANT(name, KW, CLASSIC)                                                                            \
    __attribute__((noinline)) static void name(const kf_model *m, kf_state *s, size_t r, kf_real dt, kf_v4 *cache,     \
                                               kf_v4 *mcache, kf_v4 *fcache, chunk *ck, step_acc *acc, int lohi[6],    \
                                               int flags) {                                                            \
        p2g_block_cache(KW, CLASSIC, 1, m, s, r, dt, cache, mcache, fcache, ck, acc, lohi, flags);                     \
    }
P2G_FLIP_VARIANT(p2g_q_mls_flip, 3, 0)
P2G_FLIP_VARIANT(p2g_q_classic_flip, 3, 1)
P2G_FLIP_VARIANT(p2g_c_mls_flip, 4, 0)
P2G_FLIP_VARIANT(p2g_c_classic_flip, 4, 1)
typedef void (*p2g_flip_fn)(const kf_model *, kf_state *, size_t, kf_real, kf_v4 *, kf_v4 *, kf_v4 *, chunk *,
                            step_acc *, int *, int);
static p2g_flip_fn p2g_flip_variant(const kf_model *m) {
    int cubic = m->sim.kernel == KF_KERNEL_CUBIC, classic = m->sim.force == KF_FORCE_CLASSIC;
    return cubic ? (classic ? p2g_c_classic_flip : p2g_c_mls_flip) : (classic ? p2g_q_classic_flip : p2g_q_mls_flip);
}

/* FLIP: room for the old-velocity nodes, zeroed (their contents last one substep) */
static int flip_nodes(kf_grid *g, int threads) {
    if (g->nblocks > g->node_old_cap) {
        free(g->node_old);
        size_t cap = g->node_cap > g->nblocks ? g->node_cap : g->nblocks;
        g->node_old = aligned_alloc(64, cap * KF_BLOCK_NODES * sizeof(kf_v4));
        g->node_old_cap = g->node_old ? cap : 0;
        if (!g->node_old) return -1;
    }
    size_t nb = g->nblocks;
#pragma omp parallel for schedule(static) num_threads(threads)
    for (size_t b = 0; b < nb; b++) memset(&g->node_old[b * KF_BLOCK_NODES], 0, KF_BLOCK_NODES * sizeof(kf_v4));
    return 0;
}

/* FLIP: momentum and mass to the velocity before the substep's forces */
static void flip_old_velocity(kf_grid *g, int threads) {
    size_t nb = g->nblocks;
#pragma omp parallel for schedule(static) num_threads(threads)
    for (size_t b = 0; b < nb; b++) {
        kf_v4 *node = &g->node_old[b * KF_BLOCK_NODES];
        for (int l = 0; l < KF_BLOCK_NODES; l++) {
            kf_real mass = node[l][3];
            node[l] = mass > 0 ? node[l] / mass : (kf_v4){0, 0, 0, 0};
        }
    }
}

/* polypic: room for the modes of every id, the new ones zero (a particle
 * added since starts with APIC's four modes only) */
int kf_poly_reserve(kf_state *s) {
    if (s->next_id <= s->poly_cap) return 0;
    size_t cap = s->poly_cap ? s->poly_cap : 1024;
    while (cap < s->next_id) cap *= 2;
    kf_real *t = realloc(s->poly, cap * KF_POLY_REALS * sizeof *t);
    if (!t) return -1;
    memset(t + s->poly_cap * KF_POLY_REALS, 0, (cap - s->poly_cap) * KF_POLY_REALS * sizeof *t);
    s->poly = t, s->poly_cap = cap;
    return 0;
}

typedef int (*p2g_fn)(const kf_model *, kf_state *, size_t, kf_real, kf_v4 *, kf_v4 *, chunk *, step_acc *, int *, int);
static p2g_fn p2g_variant(const kf_model *m) {
    int cubic = m->sim.kernel == KF_KERNEL_CUBIC, classic = m->sim.force == KF_FORCE_CLASSIC;
    return cubic ? (classic ? p2g_c_classic : p2g_c_mls) : (classic ? p2g_q_classic : p2g_q_mls);
}

/* One owner block's P2G contribution, left in cache (CD_MAX³ nodes) with
 * the base offsets its particles touched, not added to the grid: another
 * rank adds it to its nodes in the owner's colour turn, so every node sums
 * in the same order as on one rank. */
int kf_p2g_cache_edge(const kf_model *m) { return CD_MAX; }

void kf_p2g_owner_cache(const kf_model *m, kf_state *s, size_t r, kf_real dt, kf_v4 *cache, kf_v4 *fcache,
                        int lohi[6]) {
    chunk ck __attribute__((aligned(64)));
    step_acc acc = {0};
    p2g_variant(m)(m, s, r, dt, cache, fcache, &ck, &acc, lohi, 0);
}

/* A cache from kf_p2g_owner_cache added into the neighbourhood nb. */
void kf_p2g_add_cache(const kf_model *m, kf_grid *g, const int32_t nb[8], const kf_v4 *cache, const int lohi[6]) {
    if (m->sim.kernel == KF_KERNEL_CUBIC) p2g_flush(4, g->node, nb, cache, lohi);
    else p2g_flush(3, g->node, nb, cache, lohi);
}

/* One owner's P2G in kf_p2g: its cache (arriving zero) made, added to the
 * grid's nodes (in the owner's turn at its blocks where ordered, grid.h)
 * and left zero for the thread's next owner. FLIP (ffn): the momentum
 * cache into the old-velocity nodes too. */
static void p2g_owner_turn(const kf_model *m, kf_state *s, p2g_fn fn, p2g_flip_fn ffn, size_t r, kf_real dt,
                           kf_v4 *cache, kf_v4 *mcache, kf_v4 *fcache, chunk *ck, step_acc *acc, int ordered) {
    kf_grid *g = &s->g;
    const int cubic = m->sim.kernel == KF_KERNEL_CUBIC;
    int lohi[6];
    if (ffn) ffn(m, s, r, dt, cache, mcache, fcache, ck, acc, lohi, P2G_ZEROED);
    else fn(m, s, r, dt, cache, fcache, ck, acc, lohi, P2G_ZEROED);
    if (ordered) kf_grid_flush_wait(g, r);
    if (ffn) {
        if (cubic) p2g_flush_old(4, g, g->nb[r], mcache, lohi);
        else p2g_flush_old(3, g, g->nb[r], mcache, lohi);
    }
    if (cubic) p2g_flush_clear(4, g->node, g->nb[r], cache, lohi);
    else p2g_flush_clear(3, g->node, g->nb[r], cache, lohi);
    if (kf_contact_owner(s, r)) kf_contact_add_cache(m, s, g->nb[r], fcache, lohi);
    if (ordered) kf_grid_flush_done(g, r);
}

/* P2G over the owner blocks; with update (kf_p2g_update) the grid update
 * follows in the same parallel region */
static void p2g_run(const kf_model *m, kf_state *s, kf_real dt, kf_trouble *trouble, int update, double *p2g_end_ms) {
    p2g_fn fn = p2g_variant(m);
    kf_grid *g = &s->g;
    /* particles added or edited since the last substep: their stress first */
    if (!s->tau_valid) kf_stress(m, s, 0);
    kf_grid_clear(g, m->nthreads);
    step_acc total = {0};
    const int flip = m->sim.transfer == KF_TRANSFER_FLIP;
    const int poly = m->sim.transfer == KF_TRANSFER_POLYPIC;
    p2g_flip_fn ffn = flip ? p2g_flip_variant(m) : NULL;
    /* one rank: owners in colour order, each added in its turns (grid.h),
     * no barrier per colour; across ranks the colour turns, which the
     * other ranks' owners of each colour join */
    const int ordered = !s->dist;
    if ((flip && flip_nodes(g, m->nthreads)) || (poly && kf_poly_reserve(s)) || (ordered && kf_grid_flush_order(g))) {
        if (trouble) {
            memset(trouble, 0, sizeof *trouble);
            trouble->found = 1;
            snprintf(trouble->what, sizeof trouble->what, "out of memory for the %s",
                     flip ? "flip transfer" : poly ? "polypic transfer" : "transfer's order");
        }
        return;
    }
    const int colour_chunk = kf_grid_colour_chunk(g, m->nthreads); /* grid.h */
    atomic_size_t next_owner = 0;
    unsigned passes = 0; /* the grid update's ghost passes (kf_grid_update_team) */
#pragma omp parallel num_threads(m->nthreads)
    {
        kf_ftz();
        kf_v4 cache[CD_MAX * CD_MAX * CD_MAX] __attribute__((aligned(64)));
        chunk ck __attribute__((aligned(64)));
        step_acc acc = {0};
        /* FLIP: the momentum without the stress, per owner */
        kf_v4 mcache[CD_MAX * CD_MAX * CD_MAX] __attribute__((aligned(64)));
        /* where objects meet: the owner's share of each field (contact.h) */
        kf_v4 fcache[KF_CONTACT_CACHE_ROWS * CD_MAX * CD_MAX * CD_MAX] __attribute__((aligned(64)));
        /* zero once: each owner's flush clears what it used */
        memset(cache, 0, sizeof cache);
        if (flip) memset(mcache, 0, sizeof mcache);
        if (ordered) {
            /* runs of owners taken in order: the first unfinished owner never waits */
            for (;;) {
                const size_t k0 = atomic_fetch_add_explicit(&next_owner, (size_t)colour_chunk, memory_order_relaxed);
                if (k0 >= g->nowner) break;
                const size_t k1 = k0 + (size_t)colour_chunk < g->nowner ? k0 + (size_t)colour_chunk : g->nowner;
                for (size_t k = k0; k < k1; k++)
                    p2g_owner_turn(m, s, fn, ffn, (size_t)g->owner[k], dt, cache, mcache, fcache, &ck, &acc, 1);
            }
        } else {
            /* one colour at a time: same-colour owners write disjoint nodes */
            for (int c = 0; c < 8; c++) {
#pragma omp for schedule(dynamic, colour_chunk)
                for (size_t k = g->colour_start[c]; k < g->colour_start[c + 1]; k++)
                    p2g_owner_turn(m, s, fn, ffn, (size_t)g->owner[k], dt, cache, mcache, fcache, &ck, &acc, 0);
                /* other ranks' owners of this colour, in the same turn */
                if (s->dist) kf_dist_p2g_colour(m, s, c);
            }
        }
#pragma omp critical
        if (acc.trouble.found && (!total.trouble.found || acc.trouble.particle < total.trouble.particle))
            total.trouble = acc.trouble;
        if (update) {
#pragma omp master
            *p2g_end_ms = kf_now_ms();
            kf_grid_update_team(m, s, dt, &passes, 1);
        }
    }
    if (flip) flip_old_velocity(g, m->nthreads);
    if (trouble) *trouble = total.trouble;
}

void kf_p2g(const kf_model *m, kf_state *s, kf_real dt, kf_trouble *trouble) { p2g_run(m, s, dt, trouble, 0, NULL); }

/* the update waits on the owners' turns (grid.h), which one rank keeps;
 * FLIP's old velocities come between P2G and the update */
int kf_p2g_joins_update(const kf_model *m, const kf_state *s) {
    return !s->dist && m->sim.transfer != KF_TRANSFER_FLIP;
}

void kf_p2g_update(const kf_model *m, kf_state *s, kf_real dt, kf_trouble *trouble, double *p2g_end_ms) {
    *p2g_end_ms = kf_now_ms();
    p2g_run(m, s, dt, trouble, 1, p2g_end_ms);
}

/* |Δt L|² beyond which G2P steps F by exp(Δt L): 0.1², where the linear
 * step's error (|Δt L|²/2) passes half a percent */
#define KF_EXPM_FROM2 0.01

/* ---- G2P ---------------------------------------------------------------------- */

/* C = D⁻¹ B in the chunk (ck->b: MLS's L, read again below) and in the
 * particles' C planes, classic's L = Σ v_i ∇wᵀ / Δx, and each particle's
 * |Δt L|² (a2): one pass over the nine planes, each lane the expressions
 * of the per-plane loops it replaced. Returns whether any |Δt L|² passes
 * KF_EXPM_FROM2. */
KF_INLINE int g2p_scale_c(int CLASSIC, int n, chunk *ck, kf_real *const C[9], size_t i0, kf_real minv, kf_real inv_dx,
                          kf_real dt, kf_real *restrict a2) {
    kf_real *restrict c0 = C[0] + i0, *restrict c1 = C[1] + i0, *restrict c2 = C[2] + i0;
    kf_real *restrict c3 = C[3] + i0, *restrict c4 = C[4] + i0, *restrict c5 = C[5] + i0;
    kf_real *restrict c6 = C[6] + i0, *restrict c7 = C[7] + i0, *restrict c8 = C[8] + i0;
    kf_real *const restrict out[9] = {c0, c1, c2, c3, c4, c5, c6, c7, c8};
    int any = 0;
    KF_SIMD_OR(any)
    for (int j = 0; j < n; j++) {
        kf_real sum = 0;
        /* plane k: C, and L's entry k squared into the sum */
#define G2P_SCALE_C(k)                                                                                                 \
    {                                                                                                                  \
        const kf_real c = ck->b[k][j] * minv;                                                                          \
        ck->b[k][j] = c;                                                                                               \
        out[k][j] = c;                                                                                                 \
        kf_real l = c;                                                                                                 \
        if (CLASSIC) ck->g[k][j] = l = ck->g[k][j] * inv_dx;                                                           \
        sum += l * l;                                                                                                  \
    }
        G2P_SCALE_C(0) G2P_SCALE_C(1) G2P_SCALE_C(2) G2P_SCALE_C(3) G2P_SCALE_C(4) G2P_SCALE_C(5) G2P_SCALE_C(6)
        G2P_SCALE_C(7) G2P_SCALE_C(8)
#undef G2P_SCALE_C
        a2[j] = sum * dt * dt;
        any |= a2[j] > (kf_real)KF_EXPM_FROM2;
    }
    return any;
}

/* whether any of a chunk's particles is in trouble: |v|² not finite, or
 * J = det F outside (jmin, jmax) */
KF_INLINE int g2p_bad(int n, const kf_real *restrict J, const kf_real *restrict v2s, kf_real jmin, kf_real jmax) {
    int bad = 0;
    KF_SIMD_OR(bad)
    for (int j = 0; j < n; j++) bad |= !(v2s[j] < (kf_real)1e30) | !(J[j] > jmin) | !(J[j] < jmax);
    return bad;
}

/* F ← (I + Δt L) F in the particles' planes and J = det F, with MOVE the
 * velocity out and x += Δt v, and |v|² (v2s): one pass across the chunk,
 * the F planes read and written once, nothing staged in the chunk. Each
 * lane is the expression the per-row loops had, so the roundings (and
 * the multiply-adds they contract to) are theirs. Returns g2p_bad. */
KF_INLINE int g2p_update(int MOVE, int n, kf_real (*L)[KF_CHUNK], const chunk *ck, kf_particles *p, size_t i0,
                         kf_real dt, kf_real jmin, kf_real jmax, kf_real *restrict J, kf_real *restrict v2s) {
    kf_real *restrict F0 = p->F[0] + i0, *restrict F1 = p->F[1] + i0, *restrict F2 = p->F[2] + i0;
    kf_real *restrict F3 = p->F[3] + i0, *restrict F4 = p->F[4] + i0, *restrict F5 = p->F[5] + i0;
    kf_real *restrict F6 = p->F[6] + i0, *restrict F7 = p->F[7] + i0, *restrict F8 = p->F[8] + i0;
    kf_real *restrict x0 = p->x[0] + i0, *restrict x1 = p->x[1] + i0, *restrict x2 = p->x[2] + i0;
    kf_real *restrict v0 = p->v[0] + i0, *restrict v1 = p->v[1] + i0, *restrict v2 = p->v[2] + i0;
    const kf_real *restrict u0 = ck->v[0], *restrict u1 = ck->v[1], *restrict u2 = ck->v[2];
    int bad = 0;
    KF_SIMD_OR(bad)
    for (int j = 0; j < n; j++) {
        /* row r of F is f_r0 f_r1 f_r2 */
        const kf_real f00 = F0[j], f01 = F1[j], f02 = F2[j];
        const kf_real f10 = F3[j], f11 = F4[j], f12 = F5[j];
        const kf_real f20 = F6[j], f21 = F7[j], f22 = F8[j];
        const kf_real n00 = f00 + dt * (L[0][j] * f00 + L[1][j] * f10 + L[2][j] * f20);
        const kf_real n01 = f01 + dt * (L[0][j] * f01 + L[1][j] * f11 + L[2][j] * f21);
        const kf_real n02 = f02 + dt * (L[0][j] * f02 + L[1][j] * f12 + L[2][j] * f22);
        const kf_real n10 = f10 + dt * (L[3][j] * f00 + L[4][j] * f10 + L[5][j] * f20);
        const kf_real n11 = f11 + dt * (L[3][j] * f01 + L[4][j] * f11 + L[5][j] * f21);
        const kf_real n12 = f12 + dt * (L[3][j] * f02 + L[4][j] * f12 + L[5][j] * f22);
        const kf_real n20 = f20 + dt * (L[6][j] * f00 + L[7][j] * f10 + L[8][j] * f20);
        const kf_real n21 = f21 + dt * (L[6][j] * f01 + L[7][j] * f11 + L[8][j] * f21);
        const kf_real n22 = f22 + dt * (L[6][j] * f02 + L[7][j] * f12 + L[8][j] * f22);
        F0[j] = n00, F1[j] = n01, F2[j] = n02;
        F3[j] = n10, F4[j] = n11, F5[j] = n12;
        F6[j] = n20, F7[j] = n21, F8[j] = n22;
        const kf_real det =
            n00 * (n11 * n22 - n12 * n21) - n01 * (n10 * n22 - n12 * n20) + n02 * (n10 * n21 - n11 * n20);
        J[j] = det;
        if (MOVE) {
            v0[j] = u0[j], v1[j] = u1[j], v2[j] = u2[j];
            x0[j] += dt * u0[j];
            x1[j] += dt * u1[j];
            x2[j] += dt * u2[j];
        }
        const kf_real q = u0[j] * u0[j] + u1[j] * u1[j] + u2[j] * u2[j];
        v2s[j] = q;
        bad |= !(q < (kf_real)1e30) | !(det > jmin) | !(det < jmax);
    }
    return bad;
}

/* what follows an owner in this thread's order, for the prefetches made
 * while it runs: the next particles' first index, the next owner's
 * neighbourhood of blocks (NULL: none), the node arrays its G2P reads
 * (node) and its fused scatter adds to (next_nodes, or NULL), and whether
 * this owner's fused scatter follows its G2P (p2g) */
typedef struct g2p_follow {
    size_t first;
    const int32_t *nb;
    const kf_v4 *node;
    kf_v4 *next_nodes;
    int p2g;
} g2p_follow;

/* lines l0..l1-1 of the 2x2x2 neighbourhood nb of node blocks (16 lines a
 * block, 128 in all) asked for into L2, from the node array node and (when
 * not NULL) for ownership from next (the fused scatter's). A prefetch
 * changes no result. Block by block: a block's first line found once, then
 * one line after the other (a line's block and place in it found line by
 * line cost some 12 instructions a line) */
#define KF_NB_LINES (8 * KF_BLOCK_NODES * (int)sizeof(kf_v4) / 64)
static inline void prefetch_nb_lines(const kf_v4 *node, kf_v4 *next, const int32_t *nb, int l0, int l1) {
    /* unsigned: the block and the line in it by a shift and a mask */
    const unsigned per_block = KF_NB_LINES / 8, last = (unsigned)l1;
    for (unsigned l = (unsigned)l0; l < last;) {
        const unsigned blk = l / per_block, end = (blk + 1) * per_block < last ? (blk + 1) * per_block : last;
        const size_t first = (size_t)nb[blk] * KF_BLOCK_NODES * sizeof(kf_v4) + (size_t)(l % per_block) * 64;
        const char *line = (const char *)node + first;
        const char *line_next = next ? (const char *)next + first : NULL;
        for (; l < end; l++, line += 64) {
            __builtin_prefetch(line, 0, 2);
            if (line_next) __builtin_prefetch(line_next, 1, 2), line_next += 64;
        }
    }
}

/* what one owner's chunks share (g2p_block) */
typedef struct g2p_owner {
    const kf_model *m;
    kf_state *s;
    size_t r;
    kf_real dt, dx, inv_dx, minv, jmin, jmax, ratio;
    const int32_t *bc;
    int band, fields, poly, water, flip;
    /* the CFL figures (acc->scan): 0 no corotated material, 1 only
     * material corot_k (corotated), 2 some corotated among others */
    int corot, corot_k;
    /* the prefetch stream: the owner's particles end at pend, and this
     * thread's next ones begin at next (another owner's, in the fused
     * sweep's colour order); p2g: the fused scatter follows, so its
     * planes G2P does not touch (mass, V⁰) are asked for too */
    size_t pend, next;
    int p2g;
    const kf_cpic_owner *oc;
    const kf_v4 *cache, *ocache;
    step_acc *acc;
} g2p_owner;

/* the particle KF_PREFETCH ahead of i0 in this thread's order: past the
 * owner's end, the next owner's head, a line (KF_CHUNK particles) per
 * chunk from its first particle (the owner's own prefetches begin
 * KF_PREFETCH in; without this its head came from memory unasked, and the
 * lines past the owner's end, another colour's, were fetched for nothing) */
KF_INLINE size_t g2p_ahead(const g2p_owner *o, size_t i0) {
    const size_t ahead = i0 + KF_PREFETCH;
    if (ahead < o->pend) return ahead;
    const size_t past = ahead - o->pend;
    return o->next + (past - past % KF_CHUNK);
}

/* one chunk of an owner's particles from i0: n of them, a constant
 * KF_CHUNK for every full chunk (each per-particle loop is then one
 * register per row, with no remainder code) or the owner's tail. Returns
 * the chunk's largest |v|². */
KF_INLINE kf_real g2p_chunk(int KW, int CLASSIC, int FLIP, int n, const g2p_owner *o, chunk *ck, size_t i0) {
    const kf_model *m = o->m;
    kf_state *s = o->s;
    kf_particles *p = &s->p;
    const size_t r = o->r;
    const kf_real dt = o->dt, dx = o->dx, inv_dx = o->inv_dx, minv = o->minv, jmin = o->jmin, jmax = o->jmax;
    const kf_real ratio = o->ratio;
    const int32_t *bc = o->bc;
    const int band = o->band, fields = o->fields, poly = o->poly, water = o->water, flip = FLIP && o->flip;
    const kf_cpic_owner *oc = o->oc;
    const kf_v4 *cache = o->cache, *ocache = o->ocache;
    step_acc *acc = o->acc;
    kf_real max_v2 = 0;
    ck->n = n;
    /* the planes this chunk's successors read or write (and the fused
     * scatter's mass and V⁰) */
    const size_t ahead = g2p_ahead(o, i0);
    prefetch_planes_at(p->x, 3, ahead, 1);
    prefetch_planes_at(p->v, 3, ahead, 1);
    prefetch_planes_at(p->C, 9, ahead, 1);
    prefetch_planes_at(p->F, 9, ahead, 1);
    if (o->p2g) {
        prefetch_planes_at(&p->mass, 1, ahead, 0);
        prefetch_planes_at(&p->vol0, 1, ahead, 0);
    }
    /* the MLS gather in rows (band particles' gather_one too) reads w d */
    const int WD = KF_GATHER_ROWS && !CLASSIC;
    /* the offsets d for every reader but the MLS gather in rows */
    if (CLASSIC || band) stencil_phase_n(KW, 1, 1, WD, n, ck, p->x, i0, bc, inv_dx, dx);
    else if (fields || poly || !WD) stencil_phase_n(KW, 0, 1, WD, n, ck, p->x, i0, bc, inv_dx, dx);
    else stencil_phase_n(KW, 0, 0, WD, n, ck, p->x, i0, bc, inv_dx, dx);

    /* gather: v = Σ w v_i, B_k = Σ w d_k v_i, classic G_k = Σ ∂_k w v_i;
     * near a rigid surface, ghost velocities on incompatible nodes (CPIC
     * reads the stress P2G scattered: F's before this chunk updates it) */
    if (band) kf_cpic_g2p_chunk(m, s, r, oc, ck, i0, cache, CLASSIC);
    else gather_chunk(KW, CLASSIC, n, ck, cache);
    /* where objects meet: each particle's own field's velocity */
    if (fields) kf_contact_g2p_chunk(m, s, r, band ? oc->col : NULL, ck, i0, KW, CLASSIC);
    /* polypic: the higher modes of the new velocities; none near rigid
     * surfaces or where objects meet (APIC there) */
    if (poly)
        for (int j = 0; j < n; j++) {
            kf_real *md = &s->poly[(size_t)p->id[i0 + (size_t)j] * KF_POLY_REALS];
            if (band || fields) memset(md, 0, KF_POLY_REALS * sizeof *md);
            else poly_gather(ck, j, inv_dx, cache, md);
        }

    /* C = D⁻¹ B, written to the particles' C planes at once, and |Δt L|²,
     * across the chunk (one pass over the nine planes); velocity gradient
     * L = C (MLS: the one product) or Σ v_i ∇wᵀ (classic) */
    kf_real a2[KF_CHUNK];
    const int any_large = g2p_scale_c(CLASSIC, n, ck, p->C, i0, minv, inv_dx, dt, a2);
    kf_real(*L)[KF_CHUNK] = CLASSIC ? ck->g : ck->b;

    /* near a rigid surface, where each particle starts: the guard follows its path */
    kf_real xold[3 * KF_CHUNK];
    if (band)
        for (int a = 0; a < 3; a++) memcpy(&xold[a * KF_CHUNK], p->x[a] + i0, sizeof(kf_real) * (size_t)n);

    /* FLIP: v ← Σ w v_i + ratio (v − Σ w v_i⁰), the particle's velocity
     * beyond what the grid's old velocity v_i⁰ held of it kept; the
     * particle still moves with the grid's Σ w v_i, as F does */
    if (flip)
        for (int j = 0; j < n; j++) {
            kf_v4 vo = gather_velocity(KW, ck, j, ocache);
            for (int a = 0; a < 3; a++) {
                kf_real *v = p->v[a] + i0;
                v[j] = ck->v[a][j] + ratio * (v[j] - vo[a]);
                p->x[a][i0 + (size_t)j] += dt * ck->v[a][j];
            }
        }

    /* where the step deforms by more than a few percent (a body driving
     * material a large fraction of a cell per substep), the exact step
     * exp(Δt L) F instead (det stays positive, expm.h): its F before the
     * in-place update below kept (rare) */
    kf_real Fold[9][KF_CHUNK];
    if (any_large)
        for (int k = 0; k < 9; k++) memcpy(Fold[k], p->F[k] + i0, sizeof(kf_real) * (size_t)n);

    /* F ← (I + Δt L) F in place and its determinant, v out and x advanced
     * (FLIP did both above), |v|² and the checks: one pass across the chunk */
    kf_real J[KF_CHUNK], v2s[KF_CHUNK];
    int bad = flip ? g2p_update(0, n, L, ck, p, i0, dt, jmin, jmax, J, v2s)
                   : g2p_update(1, n, L, ck, p, i0, dt, jmin, jmax, J, v2s);
    for (int j = 0; j < (any_large ? n : 0); j++) {
        if (!(a2[j] > (kf_real)KF_EXPM_FROM2)) continue;
        size_t i = i0 + (size_t)j;
        double A[9], E[9];
        kf_real Fn[9];
        for (int k = 0; k < 9; k++) A[k] = (double)dt * L[k][j];
        kf_expm3(A, E);
        for (int rr = 0; rr < 3; rr++)
            for (int cc = 0; cc < 3; cc++)
                Fn[3 * rr + cc] = (kf_real)(E[3 * rr] * Fold[cc][j] + E[3 * rr + 1] * Fold[3 + cc][j] +
                                            E[3 * rr + 2] * Fold[6 + cc][j]);
        for (int k = 0; k < 9; k++) p->F[k][i] = Fn[k];
        J[j] = Fn[0] * (Fn[4] * Fn[8] - Fn[5] * Fn[7]) - Fn[1] * (Fn[3] * Fn[8] - Fn[5] * Fn[6]) +
               Fn[2] * (Fn[3] * Fn[7] - Fn[4] * Fn[6]);
    }

    /* water keeps F = I and tracks J ← (1 + Δt tr L) J instead */
    int any_water = 0;
    for (int j = 0; j < (water ? n : 0); j++) any_water |= m->mat[p->mat[i0 + (size_t)j]].model == KF_MAT_WATER;
    if (any_water) {
        for (int j = 0; j < n; j++) {
            size_t i = i0 + (size_t)j;
            if (m->mat[p->mat[i]].model != KF_MAT_WATER) continue;
            kf_real div = dt * (L[0][j] + L[4][j] + L[8][j]);
            /* exp(Δt tr L) where the linear step could reach 0 (as for F above) */
            J[j] = p->ps[0][i] * (div * div > (kf_real)KF_EXPM_FROM2 ? kf_exp(div) : 1 + div);
            p->ps[0][i] = J[j];
            for (int k = 0; k < 9; k++) p->F[k][i] = (kf_real)(k % 4 == 0);
        }
    }
    /* the checks again where J changed after the pass */
    if (any_large || any_water) bad = g2p_bad(n, J, v2s, jmin, jmax);

    /* slightly penetrated particles pushed back out (Eq. 22); then
     * nothing may have passed through a surface (guard.c) */
    if (band) {
        kf_cpic_penalty(m, s, r, i0, n);
        kf_cpic_guard(m, s, r, oc, ck, i0, xold);
    }

    /* numerical trouble (bad, above): non-finite, volume out of range, too fast */
    /* all finite and >= 0: the largest in any order */
    if (!bad) {
        KF_SIMD_MAX(max_v2)
        for (int j = 0; j < n; j++) max_v2 = v2s[j] > max_v2 ? v2s[j] : max_v2;
    } else {
        for (int j = 0; j < n; j++) {
            size_t i = i0 + (size_t)j;
            kf_real v2 = v2s[j];
            max_v2 = v2 > max_v2 ? v2 : max_v2;
            if (!(v2 < (kf_real)1e30) || J[j] != J[j])
                note_trouble(acc, p, i, "NaN or Inf velocity", (double)v2, s->substep);
            else if (!(J[j] > jmin && J[j] < jmax))
                note_trouble(acc, p, i, "J = det F out of range", (double)J[j], s->substep);
        }
    }

    /* the CFL rule's figures (kf_cfl_scan's, bit for bit) while v and F are
     * in cache: |v|² in double (exact products of floats, whatever the
     * contraction) from the planes CPIC's guard may have changed, and det F
     * of the corotated particles; max and min are exact, so the split into
     * chunks changes nothing (non-finite values are trouble, and then the
     * figures are not used) */
    if (acc->scan) {
        const kf_real *restrict v0 = p->v[0] + i0, *restrict v1 = p->v[1] + i0, *restrict v2 = p->v[2] + i0;
        double vb = acc->scan_v2;
        KF_SIMD_MAX(vb)
        for (int j = 0; j < n; j++) {
            const double q = (double)v0[j] * v0[j] + (double)v1[j] * v1[j] + (double)v2[j] * v2[j];
            vb = q > vb ? q : vb;
        }
        acc->scan_v2 = vb;
        if (o->corot == 1) {
            kf_real sb = acc->scan_state[o->corot_k];
            KF_SIMD_MIN(sb)
            for (int j = 0; j < n; j++) sb = J[j] < sb ? J[j] : sb;
            acc->scan_state[o->corot_k] = sb;
        } else if (o->corot == 2) {
            for (int j = 0; j < n; j++) {
                const int k = p->mat[i0 + (size_t)j];
                if (m->mat[k].model == KF_MAT_COROTATED && J[j] < acc->scan_state[k]) acc->scan_state[k] = J[j];
            }
        }
    }
    return max_v2;
}

/* owner r's G2P; f: what follows it in this thread's order */
KF_INLINE void g2p_block(int KW, int CLASSIC, int FLIP, const kf_model *m, kf_state *s, size_t r, const g2p_follow *f,
                         kf_real dt, kf_v4 *cache, kf_v4 *ocache, chunk *ck, step_acc *acc) {
    kf_grid *g = &s->g;
    /* the binning's 1/Δx, bit for bit: each stencil base must lie in its owner block (model.h) */
    const kf_real dx = (kf_real)m->sim.dx, inv_dx = kf_model_inv_dx(m);
    const kf_real minv = (kf_real)(1.0 / kf_model_dfactor(m));
    const int32_t *bc = &g->bcoord[3 * r];
    const kf_real jmin = (kf_real)m->sim.j_min, jmax = (kf_real)m->sim.j_max;
    const int band = kf_cpic_band(s, r), fields = kf_contact_owner(s, r);
    const int poly = m->sim.transfer == KF_TRANSFER_POLYPIC;
    kf_cpic_owner oc; /* near a rigid surface: the neighbourhood's CDF, once per block */
    if (band) kf_cpic_owner_cdf(s, r, &oc);
    /* whether any material is water: else no chunk looks at the particles' materials */
    int water = 0, corot = 0, corot_k = 0;
    for (int k = 0; k < m->nmat; k++) {
        water |= m->mat[k].model == KF_MAT_WATER;
        if (m->mat[k].model == KF_MAT_COROTATED) corot++, corot_k = k;
    }
    corot = !corot ? 0 : corot == 1 && m->nmat == 1 ? 1 : 2;

    /* gather the neighbourhood's velocities */
    const int32_t *nb = g->nb[r];
    nb_gather(g->node, nb, cache);
    /* FLIP, away from rigid surfaces and objects' own fields (where the
     * particle's velocity is CPIC's or its field's, APIC there): the old
     * velocities of the neighbourhood too */
    const int flip = FLIP && !band && !fields;
    const kf_real ratio = (kf_real)m->sim.flip_ratio;
    if (flip) nb_gather(g->node_old, nb, ocache);

    const g2p_owner o = {.m = m,
                         .s = s,
                         .r = r,
                         .dt = dt,
                         .dx = dx,
                         .inv_dx = inv_dx,
                         .minv = minv,
                         .jmin = jmin,
                         .jmax = jmax,
                         .ratio = ratio,
                         .bc = bc,
                         .band = band,
                         .fields = fields,
                         .poly = poly,
                         .water = water,
                         .flip = flip,
                         .corot = corot,
                         .corot_k = corot_k,
                         .pend = g->pstart[r + 1],
                         .next = f->first,
                         .p2g = f->p2g,
                         .oc = band ? &oc : NULL,
                         .cache = cache,
                         .ocache = ocache,
                         .acc = acc};
    kf_real max_v2 = 0;
    /* the following owner's nodes (its cache fill reads them, its fused
     * scatter's flush adds to them) asked for a slice before each chunk:
     * asked for at once, the 256 requests filled the miss buffers */
    const size_t nchunks = (g->pstart[r + 1] - g->pstart[r] + KF_CHUNK - 1) / KF_CHUNK;
    const int per = nchunks ? (int)((KF_NB_LINES + nchunks - 1) / nchunks) : 0;
    int l0 = 0;
    for (size_t i0 = g->pstart[r]; i0 < g->pstart[r + 1]; i0 += KF_CHUNK) {
        if (f->nb) {
            const int l1 = l0 + per < KF_NB_LINES ? l0 + per : KF_NB_LINES;
            prefetch_nb_lines(f->node, f->next_nodes, f->nb, l0, l1);
            l0 = l1;
        }
        const size_t left = g->pstart[r + 1] - i0;
        const kf_real v2 = left >= KF_CHUNK ? g2p_chunk(KW, CLASSIC, FLIP, KF_CHUNK, &o, ck, i0)
                                            : g2p_chunk(KW, CLASSIC, FLIP, (int)left, &o, ck, i0);
        max_v2 = v2 > max_v2 ? v2 : max_v2;
    }
    double cells = sqrt((double)max_v2) * dt * inv_dx;
    if (cells > acc->max_cells) acc->max_cells = cells;
}

#define G2P_VARIANT(name, KW, CLASSIC, FLIP)                                                                           \
    __attribute__((noinline)) static void name(const kf_model *m, kf_state *s, size_t r, const g2p_follow *f,          \
                                               kf_real dt, kf_v4 *cache, kf_v4 *ocache, chunk *ck, step_acc *acc) {    \
        g2p_block(KW, CLASSIC, FLIP, m, s, r, f, dt, cache, ocache, ck, acc);                                          \
    }
G2P_VARIANT(g2p_q_mls, 3, 0, 0)
G2P_VARIANT(g2p_q_classic, 3, 1, 0)
G2P_VARIANT(g2p_c_mls, 4, 0, 0)
G2P_VARIANT(g2p_c_classic, 4, 1, 0)
G2P_VARIANT(g2p_q_mls_flip, 3, 0, 1)
G2P_VARIANT(g2p_q_classic_flip, 3, 1, 1)
G2P_VARIANT(g2p_c_mls_flip, 4, 0, 1)
G2P_VARIANT(g2p_c_classic_flip, 4, 1, 1)

typedef void (*g2p_fn)(const kf_model *, kf_state *, size_t, const g2p_follow *, kf_real, kf_v4 *, kf_v4 *, chunk *,
                       step_acc *);
static g2p_fn g2p_variant(const kf_model *m) {
    int cubic = m->sim.kernel == KF_KERNEL_CUBIC, classic = m->sim.force == KF_FORCE_CLASSIC;
    if (m->sim.transfer == KF_TRANSFER_FLIP)
        return cubic ? (classic ? g2p_c_classic_flip : g2p_c_mls_flip)
                     : (classic ? g2p_q_classic_flip : g2p_q_mls_flip);
    return cubic ? (classic ? g2p_c_classic : g2p_c_mls) : (classic ? g2p_q_classic : g2p_q_mls);
}

void kf_g2p(const kf_model *m, kf_state *s, kf_real dt, kf_g2p_result *out) {
    g2p_fn fn = g2p_variant(m);
    kf_grid *g = &s->g;
    step_acc total = {0};
#pragma omp parallel num_threads(m->nthreads)
    {
        kf_ftz();
        kf_v4 cache[CD_MAX * CD_MAX * CD_MAX] __attribute__((aligned(64)));
        kf_v4 ocache[CD_MAX * CD_MAX * CD_MAX] __attribute__((aligned(64))); /* FLIP: old velocities */
        chunk ck __attribute__((aligned(64)));
        step_acc acc = {0};
#pragma omp for schedule(dynamic, 4)
        for (size_t k = 0; k < g->nowner; k++) {
            const g2p_follow f = {.first = g->pstart[k + 1]};
            fn(m, s, k, &f, dt, cache, ocache, &ck, &acc);
        }
#pragma omp critical
        {
            if (acc.trouble.found && (!total.trouble.found || acc.trouble.particle < total.trouble.particle))
                total.trouble = acc.trouble;
            if (acc.max_cells > total.max_cells) total.max_cells = acc.max_cells;
        }
    }
    out->trouble = total.trouble;
    out->max_cells = total.max_cells;
}

/* ---- stress --------------------------------------------------------------------
 * After G2P: the return mapping of plastic materials and the Kirchhoff stress
 * of every particle's (new) F, stored for the next P2G. One decomposition
 * serves both (kf_mat_update); runs of one material go through the batch
 * path, SIMD across particles for the corotated model. */

/* the materials the stress pass evaluates: under a fixed step, as the
 * step resolves them (in buf), else the model's */
static const kf_mat *stress_mats(const kf_model *m, kf_mat buf[KF_MAX_MATERIALS]) {
    double c_limit = kf_model_c_limit(m);
    if (!(c_limit > 0)) return m->mat;
    for (int k = 0; k < m->nmat; k++) buf[k] = m->mat[k], kf_mat_limit(&buf[k], c_limit);
    return buf;
}

long kf_stress_span(const kf_model *m, kf_real *const F[9], kf_real *const ps[2], const uint16_t *mat,
                    kf_real *const tau_all[6], size_t n, int project) {
    size_t nchunks = (n + 63) / 64;
    kf_mat limited_mat[KF_MAX_MATERIALS];
    const kf_mat *mats = stress_mats(m, limited_mat);
    long limited = 0;
#pragma omp parallel for schedule(static) num_threads(m->nthreads) reduction(+ : limited)
    for (size_t c = 0; c < nchunks; c++) {
        kf_ftz();
        size_t lo = c * 64, hi = lo + 64 < n ? lo + 64 : n;
        while (lo < hi) {
            uint16_t mt = mat[lo];
            size_t e = lo + 1;
            while (e < hi && mat[e] == mt) e++;
            kf_real *tau[6];
            for (int k = 0; k < 6; k++) tau[k] = tau_all[k] + lo;
            limited += kf_mat_update_batch(&mats[mt], (int)(e - lo), F, ps, project, lo, tau);
            lo = e;
        }
    }
    return limited;
}

/* kf_stress_eval with the materials resolved (stress_mats): P2G resolves
 * them once an owner, not once a chunk (kf_model_c_limit, and the limited
 * materials' 6.8 KB frame, for every 16 particles) */
static void stress_eval_mats(const kf_mat *mats, kf_particles *p, size_t first, int n, kf_real *const out[6]) {
    for (int j = 0; j < n;) {
        uint16_t mt = p->mat[first + (size_t)j];
        int e = j + 1;
        /* one material (a zero array): one run, not a scan of every particle's */
        if (p->zero & KF_ZERO_MAT) e = n;
        while (e < n && p->mat[first + (size_t)e] == mt) e++;
        kf_real *o[6];
        for (int k = 0; k < 6; k++) o[k] = out[k] + j;
        kf_mat_update_batch(&mats[mt], e - j, p->F, p->ps, 0, first + (size_t)j, o);
        j = e;
    }
}

void kf_stress_eval(const kf_model *m, kf_particles *p, size_t first, int n, kf_real *const out[6]) {
    kf_mat limited_mat[KF_MAX_MATERIALS];
    stress_eval_mats(stress_mats(m, limited_mat), p, first, n, out);
}

void kf_stress(const kf_model *m, kf_state *s, int project) {
    kf_particles *p = &s->p;
    s->stress_model = m;
    /* not kept: the transfers evaluate it (no return mapping to make: every
     * material is corotated, at its own stiffness) */
    if (p->zero & KF_ZERO_TAU) {
        s->stiff_limited = 0;
        s->tau_valid = 1;
        return;
    }
    /* across ranks: the batches of 64 fall where they fall in the one-rank array */
    if (s->dist) s->stiff_limited = kf_dist_stress(m, s, project);
    else s->stiff_limited = kf_stress_span(m, p->F, p->ps, p->mat, p->tau, p->n, project);
    s->tau_valid = 1;
}

/* ---- the fused substep end -----------------------------------------------------
 * G2P, the stress pass and (with the next Δt announced) the next substep's
 * P2G, owner block by owner block: the particle planes the three passes
 * stream (x, v, C, F, τ, mass, V⁰) are read from memory once instead of
 * three times, while the owner's particles sit in cache. Every particle
 * goes through the same compiled functions as in the unfused passes (G2P
 * and P2G variants, the stress batch, whose lanes do not depend on their
 * batch mates), and every node receives the same owners' caches in the
 * same colour order, so the results are the unfused ones bit for bit. */

int kf_fuse_applies(const kf_model *m, const kf_state *s) {
    return m->sim.integrator == KF_INTEGRATOR_EXPLICIT && !s->dist && m->sim.transfer != KF_TRANSFER_FLIP &&
           m->fault_substep <= 0 && !m->unfused;
}

/* the stress planes of an owner's first particles (the stress batches ask
 * for the rest as they go), asked for before its G2P: the planes were last
 * written a substep ago, so their lines come from memory while G2P runs */
static inline void prefetch_tau_head(const kf_particles *p, size_t lo, size_t hi) {
    const size_t end = hi < lo + 64 ? hi : lo + 64;
    for (int k = 0; k < 6; k++)
        for (size_t i = lo; i < end; i += 16) __builtin_prefetch(p->tau[k] + i, 1, 3);
}

/* the return mapping and stress of one owner's particles, in runs of one material */
static long stress_owner(const kf_mat *mats, kf_particles *p, size_t lo, size_t hi) {
    long limited = 0;
    while (lo < hi) {
        uint16_t mt = p->mat[lo];
        size_t e = lo + 1;
        while (e < hi && p->mat[e] == mt) e++;
        kf_real *tau[6];
        for (int k = 0; k < 6; k++) tau[k] = p->tau[k] + lo;
        limited += kf_mat_update_batch(&mats[mt], (int)(e - lo), p->F, p->ps, 1, lo, tau);
        lo = e;
    }
    return limited;
}

/* whether every particle of owner r (at its new position) still has its
 * stencil inside the owner's neighbourhood: binning's test (grid.h) */
static int owner_in_reach(const kf_grid *g, const kf_particles *p, size_t r, kf_real inv_dx, int cubic) {
    return kf_grid_owner_fits(g, p, r, inv_dx, cubic);
}

int kf_g2p2g(const kf_model *m, kf_state *s, kf_real dt, double next_dt_d, kf_g2p_result *out) {
    g2p_fn gfn = g2p_variant(m);
    p2g_fn pfn = p2g_variant(m);
    kf_grid *g = &s->g;
    kf_particles *p = &s->p;
    const int KW = m->sim.kernel == KF_KERNEL_CUBIC ? 4 : 3;
    const kf_real next_dt = (kf_real)next_dt_d;
    /* where contact fields meet, or with rigid bodies whose next colored
     * distance field is not this one (a moving body's; cpic/early.c), the
     * next substep's P2G reads what the next substep makes first (that
     * field, the owners where fields meet): G2P and stress only, and the
     * reach test that spares the next binning. Where no fields meet now
     * the scatter is made, and dropped if they meet at the next substep
     * (step.c) */
    int scatter =
        next_dt > 0 && !(s->contact && s->contact->active) && (!m->nrigid || kf_cpic_early_begin(m, s, next_dt_d));
    /* the next substep's nodes: the same blocks as now (a scatter is usable
     * only if binning will keep every particle where it is) */
    if (scatter && g->node_next_cap < g->nblocks) {
        free(g->node_next);
        g->node_next = aligned_alloc(64, g->node_cap * KF_BLOCK_NODES * sizeof(kf_v4));
        g->node_next_cap = g->node_next ? g->node_cap : 0;
        scatter = g->node_next != NULL;
        if (!scatter) kf_cpic_early_drop(s); /* nothing written yet */
    }
    kf_mat mat_buf[KF_MAX_MATERIALS];
    const kf_mat *mats = stress_mats(m, mat_buf);
    /* the stress kept in the planes, or (KF_ZERO_TAU) evaluated by the next P2G */
    const int keep = !(p->zero & KF_ZERO_TAU);
    step_acc total = {0};
    long limited = 0;
    int usable = scatter, give_up = 0, reach = 1;
    const kf_real inv_dx = kf_model_inv_dx(m);
    const size_t nblocks = g->nblocks, nowner = g->nowner;
    /* the CFL rule's figures for kf_advance, while each owner is in cache */
    const int scan = s->scan_want;
    const int nmat = m->nmat;
    /* G2P makes |v|² and det F as it goes; the plastic states ps[0] are
     * scanned after the stress, which may project them */
    int scan_states = 0;
    for (int k = 0; k < nmat; k++) scan_states |= m->mat[k].model != KF_MAT_COROTATED && m->mat[k].model != KF_MAT_SAND;
    double scan_v2 = 0;
    kf_real scan_state[KF_MAX_MATERIALS];
    for (int k = 0; k < nmat; k++) scan_state[k] = 1;
    const int colour_chunk = kf_grid_colour_chunk(g, m->nthreads); /* grid.h */
#pragma omp parallel num_threads(m->nthreads) reduction(+ : limited)
    {
        kf_ftz();
        double v2max = 0;
        kf_real state_min[KF_MAX_MATERIALS];
        for (int k = 0; k < nmat; k++) state_min[k] = 1;
        kf_v4 cache[CD_MAX * CD_MAX * CD_MAX] __attribute__((aligned(64)));  /* this substep's velocities */
        kf_v4 pcache[CD_MAX * CD_MAX * CD_MAX] __attribute__((aligned(64))); /* the next substep's P2G */
        chunk ck __attribute__((aligned(64)));
        step_acc acc = {.scan = scan};
        for (int k = 0; k < nmat; k++) acc.scan_state[k] = 1;
        int ok = 1, in_reach = 1;
        if (scatter) {
            /* zero once: each owner's flush clears the part its scatter used
             * (some 40% of the cache, where a memset per owner cleared all
             * of it) */
            memset(pcache, 0, sizeof pcache);
#pragma omp for schedule(static)
            for (size_t b = 0; b < nblocks; b++)
                memset(&g->node_next[b * KF_BLOCK_NODES], 0, KF_BLOCK_NODES * sizeof(kf_v4));
            /* one colour at a time, as kf_p2g: same-colour owners write disjoint nodes */
            for (int c = 0; c < 8; c++) {
#pragma omp for schedule(dynamic, colour_chunk)
                for (size_t k = g->colour_start[c]; k < g->colour_start[c + 1]; k++) {
                    size_t r = (size_t)g->owner[k];
                    if (keep) prefetch_tau_head(p, g->pstart[r], g->pstart[r + 1]);
                    /* the next owner of the colour (this thread's next, mostly): its
                     * nodes (one owner ahead: a large scene's grid has left the
                     * caches since the grid update) and its particles' head, asked
                     * for while G2P runs */
                    g2p_follow f = {.first = g->pstart[r + 1], .node = g->node, .p2g = ok};
                    if (k + 1 < g->colour_start[c + 1]) {
                        const size_t r1 = (size_t)g->owner[k + 1];
                        f.first = g->pstart[r1], f.nb = g->nb[r1], f.next_nodes = g->node_next;
                    }
                    gfn(m, s, r, &f, dt, cache, NULL, &ck, &acc);
                    if (keep) limited += stress_owner(mats, p, g->pstart[r], g->pstart[r + 1]);
                    if (scan && scan_states) kf_cfl_scan(m, p, g->pstart[r], g->pstart[r + 1], &v2max, state_min, 1);
                    in_reach &= owner_in_reach(g, p, r, inv_dx, KW == 4);
                    int stop;
#pragma omp atomic read
                    stop = give_up;
                    if (stop || !ok) continue;
                    int lohi[6];
                    if (pfn(m, s, r, next_dt, pcache, NULL, &ck, &acc, lohi, P2G_FUSED | P2G_ZEROED)) {
                        /* unusable: the rest of the scatter is skipped (the
                         * cache stays as the scatter left it: this thread
                         * scatters no other owner) */
                        ok = 0;
#pragma omp atomic write
                        give_up = 1;
                        continue;
                    }
                    /* the cache zero again for the next owner, as kf_p2g's */
                    if (KW == 4) p2g_flush_clear(4, g->node_next, g->nb[r], pcache, lohi);
                    else p2g_flush_clear(3, g->node_next, g->nb[r], pcache, lohi);
                }
            }
        } else {
#pragma omp for schedule(dynamic, 4)
            for (size_t r = 0; r < nowner; r++) {
                if (keep) prefetch_tau_head(p, g->pstart[r], g->pstart[r + 1]);
                const g2p_follow f = {
                    .first = g->pstart[r + 1], .nb = r + 1 < nowner ? g->nb[r + 1] : NULL, .node = g->node};
                gfn(m, s, r, &f, dt, cache, NULL, &ck, &acc);
                if (keep) limited += stress_owner(mats, p, g->pstart[r], g->pstart[r + 1]);
                if (scan && scan_states) kf_cfl_scan(m, p, g->pstart[r], g->pstart[r + 1], &v2max, state_min, 1);
                in_reach &= owner_in_reach(g, p, r, inv_dx, KW == 4);
            }
        }
#pragma omp critical
        {
            if (acc.trouble.found && (!total.trouble.found || acc.trouble.particle < total.trouble.particle))
                total.trouble = acc.trouble;
            if (acc.max_cells > total.max_cells) total.max_cells = acc.max_cells;
            usable &= ok;
            reach &= in_reach;
            if (v2max > scan_v2) scan_v2 = v2max;
            if (acc.scan_v2 > scan_v2) scan_v2 = acc.scan_v2;
            for (int k = 0; k < nmat; k++) {
                if (state_min[k] < scan_state[k]) scan_state[k] = state_min[k];
                if (acc.scan_state[k] < scan_state[k]) scan_state[k] = acc.scan_state[k];
            }
        }
    }
    /* owners hold every particle once (binning), so these are the figures of all */
    s->scan_valid = scan && !total.trouble.found;
    s->scan_v2 = scan_v2;
    memcpy(s->scan_state, scan_state, sizeof(kf_real) * (size_t)nmat);
    s->stiff_limited = limited;
    s->tau_valid = 1;
    s->stress_model = m;
    out->trouble = total.trouble;
    out->max_cells = total.max_cells;
    const int scattered = !total.trouble.found && usable && !give_up && reach;
    /* a dropped early P2G in the band: its particles' colours back as G2P left them */
    if (scatter && m->nrigid && !scattered) kf_cpic_early_undo(s);
    if (total.trouble.found) return 0;
    return (reach ? KF_FUSED_REACH : 0) | (scattered ? KF_FUSED_SCATTER : 0);
}
