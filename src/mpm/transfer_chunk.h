/* transfer_chunk.h — what the explicit transfers (transfer.c) and the CPIC
 * transfers (src/cpic/cpic_transfer.c) share: the per-thread chunk of
 * particles in structure-of-arrays form, the B-spline stencil, the owner
 * block's node cache, the G2P finish phase, and trouble reporting.
 * Private to the library. */
#ifndef KF_TRANSFER_CHUNK_H
#define KF_TRANSFER_CHUNK_H

#include <math.h>
#include <stdio.h>
#include <string.h>

#include "model.h"

#define KF_INLINE static inline __attribute__((always_inline))
#define CD_MAX KF_CACHE_EDGE /* cache edge: the owner's 2x2x2 block neighbourhood (grid.h) */
#define KF_CHUNK 16          /* particles per phase: one AVX-512 register of floats */
/* a per-particle loop over a chunk as one vector loop: without it a full
 * chunk's fixed 16 iterations are unrolled first, then left scalar where
 * the compiler cannot prove the planes apart; the lanes' arithmetic is the
 * scalar loop's, operation for operation (the OR and max are exact in any
 * order) */
#define KF_SIMD _Pragma("omp simd")
#define KF_SIMD_OR(v) _Pragma(KF_STR(omp simd reduction(| : v)))
#define KF_SIMD_MAX(v) _Pragma(KF_STR(omp simd reduction(max : v)))
#define KF_SIMD_MIN(v) _Pragma(KF_STR(omp simd reduction(min : v)))
#define KF_STR(x) #x

/* per-thread scratch of one chunk, structure of arrays across particles */
typedef struct chunk {
    /* every plane on its own 64-byte line: a chunk-wide access is one aligned register */
    _Alignas(64) int l[3][KF_CHUNK]; /* base node offset inside the owner block */
    kf_real w[3][4][KF_CHUNK];       /* kernel weights per axis */
    kf_real dw[3][4][KF_CHUNK];      /* their derivatives (grid units) */
    kf_real d[3][4][KF_CHUNK];       /* node minus particle, m */
    kf_real wd[3][4][KF_CHUNK];      /* G2P, MLS in rows: w d */
    kf_real q[9][KF_CHUNK];          /* P2G: MLS Q, or APIC m C for classic */
    kf_real qm[9][KF_CHUNK];         /* P2G, FLIP: m C alone (the momentum without the stress) */
    kf_real t[9][KF_CHUNK];          /* P2G classic: -Δt V⁰ τ / Δx */
    kf_real mv[4][KF_CHUNK];         /* P2G: m v, m */
    kf_real v[3][KF_CHUNK];          /* G2P: Σ w v_i */
    kf_real b[9][KF_CHUNK];          /* G2P: Σ w v_i dᵀ */
    kf_real g[9][KF_CHUNK];          /* G2P classic: Σ v_i ∇wᵀ (grid units) */
    const kf_real *tau[6];           /* G2P near a rigid surface: the chunk's stress τ (xx yy zz xy xz yz), from 0 */
    int n;                           /* particles in the chunk, at most KF_CHUNK */
} chunk;

/* ---- kernels ----------------------------------------------------------------
 * fx is the particle position in grid units minus its base node. w[i] is the
 * weight of node base+i, dw[i] its derivative with respect to the particle
 * position, in grid units (divide by Δx for world units). */
KF_INLINE void stencil_axis(int KW, int DW, int D, int WD, int n, const kf_real *restrict x, int origin, kf_real inv_dx,
                            kf_real dx, int *restrict l, kf_real (*restrict w)[KF_CHUNK],
                            kf_real (*restrict dw)[KF_CHUNK], kf_real (*restrict d)[KF_CHUNK],
                            kf_real (*restrict wd)[KF_CHUNK]) {
    KF_SIMD
    for (int j = 0; j < n; j++) {
        int base = kf_base_node(x[j], inv_dx, KW == 4);
        kf_real fx = x[j] * inv_dx - (kf_real)base;
        l[j] = base - origin;
        if (KW == 3) {
            /* quadratic: fx in [0.5, 1.5) */
            kf_real p = KF_R(1.5) - fx, q = fx - 1, r = fx - KF_R(0.5);
            w[0][j] = KF_R(0.5) * p * p;
            w[1][j] = KF_R(0.75) - q * q;
            w[2][j] = KF_R(0.5) * r * r;
            if (DW) {
                dw[0][j] = -p;
                dw[1][j] = -2 * q;
                dw[2][j] = r;
            }
        } else {
            /* cubic: fx in [1, 2) */
            kf_real r1 = fx - 1, s2 = 2 - fx;
            w[0][j] = s2 * s2 * s2 / 6;
            w[1][j] = KF_R(0.5) * r1 * r1 * r1 - r1 * r1 + KF_R(2.0 / 3.0);
            w[2][j] = KF_R(0.5) * s2 * s2 * s2 - s2 * s2 + KF_R(2.0 / 3.0);
            w[3][j] = r1 * r1 * r1 / 6;
            if (DW) {
                dw[0][j] = -KF_R(0.5) * s2 * s2;
                dw[1][j] = KF_R(1.5) * r1 * r1 - 2 * r1;
                dw[2][j] = -(KF_R(1.5) * s2 * s2 - 2 * s2);
                dw[3][j] = KF_R(0.5) * r1 * r1;
            }
        }
        for (int i = 0; i < (D ? KW : 0); i++) d[i][j] = ((kf_real)i - fx) * dx;
        for (int i = 0; i < (WD ? KW : 0); i++) wd[i][j] = w[i][j] * (((kf_real)i - fx) * dx);
    }
}

/* the stencil of n particles (a constant KF_CHUNK for a full chunk: each
 * loop is then one register per row); the weight gradients only where a
 * caller reads them (DW: classic MPM, CPIC's band), the offsets d only
 * where they are read (D: not by the MLS gather in rows, which reads only
 * w and w d), the products w d only for that gather (WD) */
KF_INLINE void stencil_phase_n(int KW, int DW, int D, int WD, int n, chunk *ck, kf_real *const x[3], size_t i0,
                               const int32_t *bc, kf_real inv_dx, kf_real dx) {
    for (int a = 0; a < 3; a++)
        stencil_axis(KW, DW, D, WD, n, x[a] + i0, KF_BLOCK * bc[a], inv_dx, dx, ck->l[a], ck->w[a], ck->dw[a], ck->d[a],
                     ck->wd[a]);
}
KF_INLINE void stencil_phase(int KW, chunk *ck, kf_real *const x[3], size_t i0, const int32_t *bc, kf_real inv_dx,
                             kf_real dx) {
    stencil_phase_n(KW, 1, 1, 0, ck->n, ck, x, i0, bc, inv_dx, dx);
}

/* the index of the first node of row (a, b) of the 2x2x2 block
 * neighbourhood nb's lower (hz 0) or upper (hz 1) z block; then node
 * (a, b, c) of an owner's cache, counted from the owner's first node */
static inline size_t nb_row_index(const int32_t *nb, int a, int b, int hz) {
    int blk = nb[(a >> 2) << 2 | (b >> 2) << 1 | hz];
    return (size_t)blk * KF_BLOCK_NODES + ((a & 3) << 4 | (b & 3) << 2);
}
static inline size_t nb_index(const int32_t *nb, int a, int b, int c) {
    return nb_row_index(nb, a, b, c >> 2) + (size_t)(c & 3);
}
static inline kf_v4 *nb_node(const kf_grid *g, const int32_t *nb, int a, int b, int c) {
    return &g->node[nb_index(nb, a, b, c)];
}
/* the first node of row (a, b) of the neighbourhood's lower (hz 0) or upper
 * (hz 1) z block: KF_BLOCK contiguous nodes */
static inline kf_v4 *nb_row(kf_v4 *node, const int32_t *nb, int a, int b, int hz) {
    return &node[nb_row_index(nb, a, b, hz)];
}
/* the whole neighbourhood of nodes into a cache (edge CD_MAX), a row's
 * block-long runs at a time (fixed-size copies: vector moves) */
static inline void nb_gather(kf_v4 *node, const int32_t *nb, kf_v4 *cache) {
    _Static_assert(CD_MAX == 2 * KF_BLOCK && KF_BLOCK == 4, "a cache row is two blocks' rows");
    for (int a = 0; a < CD_MAX; a++)
        for (int b = 0; b < CD_MAX; b++) {
            kf_v4 *row = &cache[(a * CD_MAX + b) * CD_MAX];
            memcpy(row, nb_row(node, nb, a, b, 0), KF_BLOCK * sizeof(kf_v4));
            memcpy(row + KF_BLOCK, nb_row(node, nb, a, b, 1), KF_BLOCK * sizeof(kf_v4));
        }
}

/* ---- prefetching -------------------------------------------------------------
 * A chunk's phases stream two to three dozen particle planes at once, more
 * streams than the hardware prefetcher follows, and a large scene's planes
 * live in memory: each transfer asks for the planes it reads (and writes)
 * KF_PREFETCH particles ahead. A prefetch never faults, past an array's end
 * included. */
#ifndef KF_PREFETCH
#define KF_PREFETCH 64
#endif
/* element i of each plane asked for (write: for ownership) */
KF_INLINE void prefetch_planes_at(kf_real *const *plane, int count, size_t i, int write) {
    for (int k = 0; k < count; k++) {
        if (write) __builtin_prefetch(plane[k] + i, 1, 3);
        else __builtin_prefetch(plane[k] + i, 0, 3);
    }
}
KF_INLINE void prefetch_planes(kf_real *const *plane, int count, size_t i, int write) {
    prefetch_planes_at(plane, count, i + KF_PREFETCH, write);
}

/* ---- trouble: the first (lowest id) particle in trouble, per thread ---- */

typedef struct step_acc {
    kf_trouble trouble;
    double max_cells;
    /* the fused sweep's CFL figures, made by G2P where scan is set (the
     * fastest |v|², each corotated material's smallest det F) */
    int scan;
    double scan_v2;
    kf_real scan_state[KF_MAX_MATERIALS];
} step_acc;

static inline void note_trouble(step_acc *acc, const kf_particles *p, size_t i, const char *what, double value,
                                long substep) {
    if (acc->trouble.found && acc->trouble.particle <= p->id[i]) return;
    acc->trouble.found = 1;
    snprintf(acc->trouble.what, sizeof acc->trouble.what, "%s", what);
    acc->trouble.particle = p->id[i];
    acc->trouble.material = p->mat[i];
    acc->trouble.value = value;
    acc->trouble.substep = substep;
}

#if defined(__AVX512F__) && !defined(KF_DOUBLE)
#include <immintrin.h>
#define KF_ROWS512 1
#define KF_RN (_MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC)
/* AVX-512, float: one stencil row (KW nodes along z, contiguous in the
 * cache, 4 floats each) is one register under a mask of 4 KW lanes. Each
 * lane computes what the portable path computes per node, with the same
 * roundings: only the number of instructions changes. */
static inline __m512 row_lanes(const kf_real *v, int KW) {
    return _mm512_setr_ps(v[0], v[0], v[0], v[0], v[1], v[1], v[1], v[1], v[2], v[2], v[2], v[2], KW == 4 ? v[3] : 0,
                          KW == 4 ? v[3] : 0, KW == 4 ? v[3] : 0, KW == 4 ? v[3] : 0);
}
static inline __m512 row_v4(kf_v4 a) { return _mm512_broadcast_f32x4((__m128)a); }
#endif

#ifdef KF_ROWS512
/* one particle's MLS scatter terms (scatter_one; scatter_chunk512 forms
 * the same ones, rounding alike): stencil row (a, b) gets
 * (w_a w_b WK) (h_ab + DQ2) in its z-lanes, h_ab = base + d_a q0 + d_b q1 */
typedef struct {
    kf_v4 base, q0, q1;
    __m512 WK, DQ2;
} rows512;

KF_INLINE rows512 rows512_of(int KW, const chunk *ck, int j) {
    rows512 r;
    r.base = (kf_v4){ck->mv[0][j], ck->mv[1][j], ck->mv[2][j], ck->mv[3][j]};
    r.q0 = (kf_v4){ck->q[0][j], ck->q[3][j], ck->q[6][j], 0};
    r.q1 = (kf_v4){ck->q[1][j], ck->q[4][j], ck->q[7][j], 0};
    const __m512 Q2 = row_v4((kf_v4){ck->q[2][j], ck->q[5][j], ck->q[8][j], 0});
    kf_real w2[4], d2[4];
    for (int c = 0; c < 4; c++) w2[c] = c < KW ? ck->w[2][c][j] : 0, d2[c] = c < KW ? ck->d[2][c][j] : 0;
    /* d_c q2 once per particle, then added, rounded apart as the portable
     * path compiles (the explicit rounding keeps the compiler from
     * contracting the pair into one multiply-add) */
    r.WK = row_lanes(w2, KW);
    r.DQ2 = _mm512_mul_round_ps(row_lanes(d2, KW), Q2, KF_RN);
    return r;
}

/* acc + row (a, b)'s terms; ha = base + d_a q0 */
KF_INLINE __m512 rows512_add(const rows512 *r, const chunk *ck, int j, int a, int b, kf_v4 ha, __m512 acc) {
    const kf_real wab = ck->w[0][a][j] * ck->w[1][b][j];
    const kf_v4 hab = ha + ck->d[1][b][j] * r->q1;
    const __m512 t = _mm512_add_round_ps(row_v4(hab), r->DQ2, KF_RN);
    const __m512 w = _mm512_mul_ps(_mm512_set1_ps(wab), r->WK);
    return _mm512_fmadd_ps(w, t, acc);
}
#endif

/* one particle's P2G contribution to the owner's node cache (edge CD_MAX) */
KF_INLINE void scatter_one(int KW, int CLASSIC, const chunk *ck, int j, kf_v4 *cache) {
    const int CD = CD_MAX;
#ifdef KF_ROWS512
    if (!CLASSIC) {
        const __mmask16 mk = KW == 4 ? 0xFFFF : 0x0FFF;
        const rows512 r = rows512_of(KW, ck, j);
        float *origin = (float *)&cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]];
        for (int a = 0; a < KW; a++) {
            const kf_v4 ha = r.base + ck->d[0][a][j] * r.q0;
            for (int b = 0; b < KW; b++) {
                float *row = origin + 4 * (a * CD + b) * CD;
                _mm512_mask_storeu_ps(row, mk, rows512_add(&r, ck, j, a, b, ha, _mm512_maskz_loadu_ps(mk, row)));
            }
        }
        return;
    }
#endif
    const kf_v4 base = {ck->mv[0][j], ck->mv[1][j], ck->mv[2][j], ck->mv[3][j]};
    const kf_v4 q0 = {ck->q[0][j], ck->q[3][j], ck->q[6][j], 0};
    const kf_v4 q1 = {ck->q[1][j], ck->q[4][j], ck->q[7][j], 0};
    const kf_v4 q2 = {ck->q[2][j], ck->q[5][j], ck->q[8][j], 0};
    kf_v4 t0 = {0}, t1 = {0}, t2 = {0};
    if (CLASSIC) {
        t0 = (kf_v4){ck->t[0][j], ck->t[3][j], ck->t[6][j], 0};
        t1 = (kf_v4){ck->t[1][j], ck->t[4][j], ck->t[7][j], 0};
        t2 = (kf_v4){ck->t[2][j], ck->t[5][j], ck->t[8][j], 0};
    }
    kf_real w2[4], d2[4], dw2[4];
    for (int c = 0; c < KW; c++) w2[c] = ck->w[2][c][j], d2[c] = ck->d[2][c][j], dw2[c] = ck->dw[2][c][j];
    kf_v4 *origin = &cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]];
    for (int a = 0; a < KW; a++) {
        const kf_v4 ha = base + ck->d[0][a][j] * q0;
        for (int b = 0; b < KW; b++) {
            const kf_real wab = ck->w[0][a][j] * ck->w[1][b][j];
            const kf_v4 hab = ha + ck->d[1][b][j] * q1;
            kf_v4 *row = origin + (a * CD + b) * CD;
            kf_v4 fa = {0}, fb = {0};
            if (CLASSIC) {
                /* classic force f = −V⁰ τ ∇w, ∇w split by axis */
                fa = (ck->dw[0][a][j] * ck->w[1][b][j]) * t0 + (ck->w[0][a][j] * ck->dw[1][b][j]) * t1;
                fb = wab * t2;
            }
            for (int c = 0; c < KW; c++) {
                kf_v4 add = (wab * w2[c]) * (hab + d2[c] * q2);
                if (CLASSIC) add += w2[c] * fa + dw2[c] * fb;
                row[c] += add;
            }
        }
    }
}

#ifdef KF_ROWS512
/* 16 planes of 16 floats into 16 records (record j: element j of every
 * plane, in plane order): pairs of planes interleaved, then quads, then
 * the 128-bit lanes */
KF_INLINE void transpose16(const __m512 in[16], __m512 out[16]) {
    __m512 t[16], u[16];
    for (int q = 0; q < 4; q++) {
        const __m512d t0 = _mm512_castps_pd(_mm512_unpacklo_ps(in[4 * q], in[4 * q + 1]));
        const __m512d t1 = _mm512_castps_pd(_mm512_unpackhi_ps(in[4 * q], in[4 * q + 1]));
        const __m512d t2 = _mm512_castps_pd(_mm512_unpacklo_ps(in[4 * q + 2], in[4 * q + 3]));
        const __m512d t3 = _mm512_castps_pd(_mm512_unpackhi_ps(in[4 * q + 2], in[4 * q + 3]));
        /* u[4q + i], 128-bit lane L: element 4L + i of planes 4q..4q+3 */
        u[4 * q] = _mm512_castpd_ps(_mm512_unpacklo_pd(t0, t2));
        u[4 * q + 1] = _mm512_castpd_ps(_mm512_unpackhi_pd(t0, t2));
        u[4 * q + 2] = _mm512_castpd_ps(_mm512_unpacklo_pd(t1, t3));
        u[4 * q + 3] = _mm512_castpd_ps(_mm512_unpackhi_pd(t1, t3));
    }
    for (int i = 0; i < 4; i++) {
        t[i] = _mm512_shuffle_f32x4(u[i], u[4 + i], 0x88);
        t[4 + i] = _mm512_shuffle_f32x4(u[i], u[4 + i], 0xDD);
        t[8 + i] = _mm512_shuffle_f32x4(u[8 + i], u[12 + i], 0x88);
        t[12 + i] = _mm512_shuffle_f32x4(u[8 + i], u[12 + i], 0xDD);
    }
    for (int i = 0; i < 4; i++) {
        out[i] = _mm512_shuffle_f32x4(t[i], t[8 + i], 0x88);
        out[4 + i] = _mm512_shuffle_f32x4(t[4 + i], t[12 + i], 0x88);
        out[8 + i] = _mm512_shuffle_f32x4(t[i], t[8 + i], 0xDD);
        out[12 + i] = _mm512_shuffle_f32x4(t[4 + i], t[12 + i], 0xDD);
    }
}

/* A chunk's MLS scatter, AVX-512. A run of consecutive particles with the
 * same base node (binning orders an owner's particles by base node) keeps
 * its KW² stencil rows in registers: loaded once, each particle's share
 * added in order, stored once (no store-to-load round trip through the
 * same rows between particles). Each lane computes what scatter_one
 * computes, rounding for rounding; what changes is where the operands come
 * from: each particle's [m v, m | Q:,0 | Q:,1 | Q:,2] and its z-weights
 * and z-offsets as one register each (two transposes per chunk, then one
 * 128-bit broadcast or lane permute per term instead of a dozen inserts),
 * the products w_a w_b for the whole chunk at once (one broadcast operand
 * per row), and h_ab = m v + d_a Q:,0 + d_b Q:,1 made in all four node
 * groups at once (no broadcast of it per row). */
KF_INLINE void scatter_chunk512(int KW, int n, const chunk *ck, kf_v4 *cache) {
    const int CD = CD_MAX;
    const __mmask16 mk = KW == 4 ? 0xFFFF : 0x0FFF;
    const __m512 zero = _mm512_setzero_ps();
    __m512 pl[16], rec[KF_CHUNK], zr[KF_CHUNK];
    for (int k = 0; k < 4; k++) pl[k] = _mm512_loadu_ps(ck->mv[k]);
    for (int c = 0; c < 3; c++) {
        pl[4 + 4 * c] = _mm512_loadu_ps(ck->q[c]);
        pl[5 + 4 * c] = _mm512_loadu_ps(ck->q[3 + c]);
        pl[6 + 4 * c] = _mm512_loadu_ps(ck->q[6 + c]);
        pl[7 + 4 * c] = zero;
    }
    transpose16(pl, rec);
    for (int c = 0; c < 4; c++) {
        pl[c] = c < KW ? _mm512_loadu_ps(ck->w[2][c]) : zero;
        pl[4 + c] = c < KW ? _mm512_loadu_ps(ck->d[2][c]) : zero;
        pl[8 + c] = pl[12 + c] = zero;
    }
    transpose16(pl, zr);
    float wab[16][KF_CHUNK] __attribute__((aligned(64)));
    for (int a = 0; a < KW; a++)
        for (int b = 0; b < KW; b++)
            _mm512_store_ps(wab[a * KW + b], _mm512_mul_ps(_mm512_loadu_ps(ck->w[0][a]), _mm512_loadu_ps(ck->w[1][b])));
    /* a record's z-weights and z-offsets spread over the row's node groups */
    const __m512i iw = _mm512_setr_epi32(0, 0, 0, 0, 1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3);
    const __m512i id = _mm512_setr_epi32(4, 4, 4, 4, 5, 5, 5, 5, 6, 6, 6, 6, 7, 7, 7, 7);

    __m512 acc[16];
    for (int k = 0; k < 16; k++) acc[k] = zero;
    float *origin = NULL;
    int run = -1;
    for (int j = 0; j < n; j++) {
        const int key = (ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j];
        if (key != run) {
            if (origin)
                for (int a = 0; a < KW; a++)
                    for (int b = 0; b < KW; b++)
                        _mm512_mask_storeu_ps(origin + 4 * (a * CD + b) * CD, mk, acc[a * KW + b]);
            run = key;
            origin = (float *)&cache[key];
            for (int a = 0; a < KW; a++)
                for (int b = 0; b < KW; b++)
                    acc[a * KW + b] = _mm512_maskz_loadu_ps(mk, origin + 4 * (a * CD + b) * CD);
        }
        /* rows512_of's terms: base, q0, q1 in every node group, WK and d_c q2 */
        const __m512 base = _mm512_shuffle_f32x4(rec[j], rec[j], 0x00);
        const __m512 q0 = _mm512_shuffle_f32x4(rec[j], rec[j], 0x55);
        const __m512 q1 = _mm512_shuffle_f32x4(rec[j], rec[j], 0xAA);
        const __m512 q2 = _mm512_shuffle_f32x4(rec[j], rec[j], 0xFF);
        const __m512 WK = _mm512_maskz_permutexvar_ps(mk, iw, zr[j]);
        const __m512 DQ2 = _mm512_mul_round_ps(_mm512_maskz_permutexvar_ps(mk, id, zr[j]), q2, KF_RN);
        /* rows512_add's, row by row: h_a, h_ab as the multiply-adds the
         * one-particle path compiles to */
        for (int a = 0; a < KW; a++) {
            const __m512 ha = _mm512_fmadd_ps(_mm512_set1_ps(ck->d[0][a][j]), q0, base);
            for (int b = 0; b < KW; b++) {
                const __m512 hab = _mm512_fmadd_ps(_mm512_set1_ps(ck->d[1][b][j]), q1, ha);
                const __m512 t = _mm512_add_round_ps(hab, DQ2, KF_RN);
                const __m512 w = _mm512_mul_ps(_mm512_set1_ps(wab[a * KW + b][j]), WK);
                acc[a * KW + b] = _mm512_fmadd_ps(w, t, acc[a * KW + b]);
            }
        }
    }
    if (origin)
        for (int a = 0; a < KW; a++)
            for (int b = 0; b < KW; b++) _mm512_mask_storeu_ps(origin + 4 * (a * CD + b) * CD, mk, acc[a * KW + b]);
}
#endif

/* the AVX2 scatter in stencil rows (float builds without AVX-512) */
#include "scatter256.h"

/* a chunk's P2G contributions of n particles (ck->n, or the constant
 * KF_CHUNK) to the owner's node cache: with AVX-512 (MLS) in register
 * runs (scatter_chunk512), with AVX2 (MLS, quadratic) in runs of rows
 * (scatter_chunk256), else particle by particle */
KF_INLINE void scatter_chunk_n(int KW, int CLASSIC, int n, const chunk *ck, kf_v4 *cache) {
#ifdef KF_ROWS512
    if (!CLASSIC) {
        scatter_chunk512(KW, n, ck, cache);
        return;
    }
#endif
#ifdef KF_SCATTER256
    /* quadratic only (scatter256.h says why) */
    if (!CLASSIC && KW == 3) {
        scatter_chunk256(n, ck, cache);
        return;
    }
#endif
    for (int j = 0; j < n; j++) scatter_one(KW, CLASSIC, ck, j, cache);
}
KF_INLINE void scatter_chunk(int KW, int CLASSIC, const chunk *ck, kf_v4 *cache) {
    scatter_chunk_n(KW, CLASSIC, ck->n, ck, cache);
}

/* FLIP: one particle's momentum and mass alone, m v + m C d (no stress
 * impulse), into a second node cache: divided by the mass, the grid's
 * velocity before the substep's forces */
KF_INLINE void scatter_momentum(int KW, const chunk *ck, int j, kf_v4 *cache) {
    const int CD = CD_MAX;
    const kf_v4 base = {ck->mv[0][j], ck->mv[1][j], ck->mv[2][j], ck->mv[3][j]};
    const kf_v4 q0 = {ck->qm[0][j], ck->qm[3][j], ck->qm[6][j], 0};
    const kf_v4 q1 = {ck->qm[1][j], ck->qm[4][j], ck->qm[7][j], 0};
    const kf_v4 q2 = {ck->qm[2][j], ck->qm[5][j], ck->qm[8][j], 0};
    kf_v4 *origin = &cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]];
    for (int a = 0; a < KW; a++) {
        const kf_v4 ha = base + ck->d[0][a][j] * q0;
        for (int b = 0; b < KW; b++) {
            const kf_real wab = ck->w[0][a][j] * ck->w[1][b][j];
            const kf_v4 hab = ha + ck->d[1][b][j] * q1;
            kf_v4 *row = origin + (a * CD + b) * CD;
            for (int c = 0; c < KW; c++) row[c] += (wab * ck->w[2][c][j]) * (hab + ck->d[2][c][j] * q2);
        }
    }
}

/* FLIP: one particle's interpolated velocity Σ w v_i from a node cache */
KF_INLINE kf_v4 gather_velocity(int KW, const chunk *ck, int j, const kf_v4 *cache) {
    const int CD = CD_MAX;
    const kf_v4 *origin = &cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]];
    kf_v4 v = {0};
    for (int a = 0; a < KW; a++)
        for (int b = 0; b < KW; b++) {
            const kf_real wab = ck->w[0][a][j] * ck->w[1][b][j];
            const kf_v4 *row = origin + (a * CD + b) * CD;
            kf_v4 ra = {0};
            for (int c = 0; c < KW; c++) ra += ck->w[2][c][j] * row[c];
            v += wab * ra;
        }
    return v;
}

#ifdef KF_ROWS512
/* The sums of four registers' four 4-lane groups: lanes 4k..4k+3 of the
 * result hold register k's sum. */
static inline __m512 group_sums4(__m512 a, __m512 b, __m512 c, __m512 d) {
    __m512 ab = _mm512_add_ps(_mm512_shuffle_f32x4(a, b, 0x44), _mm512_shuffle_f32x4(a, b, 0xEE));
    __m512 cd = _mm512_add_ps(_mm512_shuffle_f32x4(c, d, 0x44), _mm512_shuffle_f32x4(c, d, 0xEE));
    return _mm512_add_ps(_mm512_shuffle_f32x4(ab, cd, 0x88), _mm512_shuffle_f32x4(ab, cd, 0xDD));
}

/* The quadratic MLS gather without the masked rows' idle lanes. A row of
 * three nodes fills 12 of a register's 16 lanes, and a 512-bit operation
 * costs as much as two 256-bit ones on cores that split it (AMD Zen 4):
 * here a row's nodes 0, 1 are broadcast to both halves of one register
 * and its node 2 to both halves of a 256-bit one, the lower halves
 * multiplied by w_b and the upper ones by w_b d_b, so that A and A' of
 * gather_rows512_sum share every operation: 3 register halves a row
 * instead of 4. Lane by lane the same multiply-adds in the same order,
 * so the same bits: S and S1 share registers alike; S0 runs on the lower
 * halves; the z-weights' products are those of group_sums4, and its
 * fourth node group, +0 for KW 3 (zero rows: every product and sum of
 * them is +0), is added as a +0 (it turns a -0 sum of groups 1 into +0).
 * The record: [v, m | B:,1 | B:,0 | B:,2]. */
KF_INLINE __m512 gather_rows512_sum3(const chunk *ck, int j, const kf_v4 *node0) {
    const int CD = CD_MAX;
    const float *origin = (const float *)node0;
    const __m512 zero = _mm512_setzero_ps();
    __m512 SL = zero;                        /* nodes 0, 1: [S | S1] */
    __m256 SH = _mm512_castps512_ps256(SL);  /* node 2: [S | S1] */
    __m256 S0L = SH;                         /* nodes 0, 1: S0 */
    __m128 S0H = _mm512_castps512_ps128(SL); /* node 2: S0 */
    for (int a = 0; a < 3; a++) {
        __m512 AL = zero;                       /* nodes 0, 1: [A | A'] */
        __m256 AH = _mm512_castps512_ps256(AL); /* node 2: [A | A'] */
        for (int b = 0; b < 3; b++) {
            const float *row = origin + 4 * (a * CD + b) * CD;
            const __m512 rl = _mm512_broadcast_f32x8(_mm256_loadu_ps(row));
            const __m256 rh = _mm256_broadcast_ps((const __m128 *)(row + 8));
            /* [w_b | w_b d_b] over the halves: broadcast loads joined by one insert (a
             * merge-masked broadcast from a register costs the compiler's form two
             * lane shuffles more, and as much time as the lanes save) */
            const float *wb = &ck->w[1][b][j], *wdb = &ck->wd[1][b][j];
            const __m512 wl =
                _mm512_insertf32x8(_mm512_castps256_ps512(_mm256_broadcast_ss(wb)), _mm256_broadcast_ss(wdb), 1);
            const __m256 wh = _mm256_setr_m128(_mm_broadcast_ss(wb), _mm_broadcast_ss(wdb));
            AL = _mm512_fmadd_ps(wl, rl, AL);
            AH = _mm256_fmadd_ps(wh, rh, AH);
        }
        const float wa = ck->w[0][a][j], wda = ck->wd[0][a][j];
        SL = _mm512_fmadd_ps(_mm512_set1_ps(wa), AL, SL);
        SH = _mm256_fmadd_ps(_mm256_set1_ps(wa), AH, SH);
        S0L = _mm256_fmadd_ps(_mm256_set1_ps(wda), _mm512_castps512_ps256(AL), S0L);
        S0H = _mm_fmadd_ps(_mm_set1_ps(wda), _mm256_castps256_ps128(AH), S0H);
    }
    /* the z-weights' products: [v | B:,1] of nodes 0, 1 and of node 2,
     * B:,0 of nodes 0, 1 and of node 2, B:,2 of nodes 0, 1 and of node 2 */
    const float w0 = ck->w[2][0][j], w1 = ck->w[2][1][j], w2 = ck->w[2][2][j];
    const float wd0 = ck->wd[2][0][j], wd1 = ck->wd[2][1][j], wd2 = ck->wd[2][2][j];
    const __m256 WK01 = _mm256_setr_m128(_mm_set1_ps(w0), _mm_set1_ps(w1));
    const __m256 WD01 = _mm256_setr_m128(_mm_set1_ps(wd0), _mm_set1_ps(wd1));
    const __m512 P1 = _mm512_mul_ps(_mm512_broadcast_f32x8(WK01), SL);
    const __m256 P2 = _mm256_mul_ps(_mm256_set1_ps(w2), SH);
    const __m256 P3 = _mm256_mul_ps(WK01, S0L);
    const __m128 P4 = _mm_mul_ps(_mm_set1_ps(w2), S0H);
    const __m256 P5 = _mm256_mul_ps(WD01, _mm512_castps512_ps256(SL));
    const __m128 P6 = _mm_mul_ps(_mm_set1_ps(wd2), _mm256_castps256_ps128(SH));
    /* node groups 0, 1 and 2 of the record, then (g0 + g2) + (g1 + g3) */
    const __m512 Q = _mm512_insertf32x8(_mm512_castps256_ps512(P3), P5, 1);
    const __m512 g0 = _mm512_shuffle_f32x4(P1, Q, 0x88), g1 = _mm512_shuffle_f32x4(P1, Q, 0xDD);
    const __m512 g2 = _mm512_insertf32x8(_mm512_castps256_ps512(P2), _mm256_setr_m128(P4, P6), 1);
    return _mm512_add_ps(_mm512_add_ps(g0, g2), _mm512_add_ps(g1, zero));
}

/* MLS gather, one stencil row per register: the rows of one x-offset a
 * are summed with their y-weights first (A_a = Σ_b w_b R_ab and
 * A'_a = Σ_b w_b d_b R_ab), then the x-weights (S = Σ_a w_a A_a,
 * S0 = Σ_a w_a d_a A_a, S1 = Σ_a w_a A'_a), and the z-weights last, per
 * lane: v = Σ_c w_c S_c, B:,0 = Σ_c w_c S0_c, B:,1 = Σ_c w_c S1_c,
 * B:,2 = Σ_c w_c d_c S_c. The same sums as the portable path in another
 * order: results differ from it in the last bits. The record is
 * [v, m | B:,1 | B:,0 | B:,2] (the order gather_rows512_sum3 makes). */
KF_INLINE __m512 gather_rows512_sum(int KW, const chunk *ck, int j, const kf_v4 *cache) {
    const int CD = CD_MAX;
    if (KW == 3) return gather_rows512_sum3(ck, j, &cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]]);
    kf_real w2[4], wd2[4];
    for (int c = 0; c < 4; c++) {
        w2[c] = c < KW ? ck->w[2][c][j] : 0;
        wd2[c] = c < KW ? ck->wd[2][c][j] : 0;
    }
    const float *origin = (const float *)&cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]];
    __m512 S = _mm512_setzero_ps(), S0 = S, S1 = S;
    for (int a = 0; a < KW; a++) {
        __m512 A = _mm512_setzero_ps(), A1 = A;
        for (int b = 0; b < KW; b++) {
            const __m512 r = _mm512_loadu_ps(origin + 4 * (a * CD + b) * CD);
            const kf_real wb = ck->w[1][b][j];
            A = _mm512_fmadd_ps(_mm512_set1_ps(wb), r, A);
            A1 = _mm512_fmadd_ps(_mm512_set1_ps(ck->wd[1][b][j]), r, A1);
        }
        const kf_real wa = ck->w[0][a][j];
        S = _mm512_fmadd_ps(_mm512_set1_ps(wa), A, S);
        S0 = _mm512_fmadd_ps(_mm512_set1_ps(ck->wd[0][a][j]), A, S0);
        S1 = _mm512_fmadd_ps(_mm512_set1_ps(wa), A1, S1);
    }
    const __m512 WK = row_lanes(w2, KW);
    return group_sums4(_mm512_mul_ps(WK, S), _mm512_mul_ps(WK, S1), _mm512_mul_ps(WK, S0),
                       _mm512_mul_ps(row_lanes(wd2, KW), S));
}

/* one particle's gather: its record [v, m | B:,1 | B:,0 | B:,2] into the chunk */
KF_INLINE void gather_rows512(int KW, chunk *ck, int j, const kf_v4 *cache) {
    float o[16] __attribute__((aligned(64)));
    _mm512_store_ps(o, gather_rows512_sum(KW, ck, j, cache));
    for (int k = 0; k < 3; k++) {
        ck->v[k][j] = o[k];
        ck->b[3 * k + 1][j] = o[4 + k];
        ck->b[3 * k][j] = o[8 + k];
        ck->b[3 * k + 2][j] = o[12 + k];
    }
}

/* A whole chunk's gather: each particle's record is one row of a 16x16
 * block, and one register transpose turns the block into the chunk's
 * planes (a dozen shuffles per record instead of a dozen scalar stores;
 * the shuffles of the unused columns, the masses, are dead code). The
 * records are gather_rows512's, bit for bit. */
KF_INLINE void gather_chunk512(int KW, int n, chunk *ck, const kf_v4 *cache) {
    __m512 rec[KF_CHUNK], col[16];
    for (int j = 0; j < KF_CHUNK; j++) rec[j] = j < n ? gather_rows512_sum(KW, ck, j, cache) : _mm512_setzero_ps();
    transpose16(rec, col);
    for (int i = 0; i < 3; i++) {
        _mm512_storeu_ps(ck->v[i], col[i]);
        _mm512_storeu_ps(ck->b[3 * i + 1], col[4 + i]);
        _mm512_storeu_ps(ck->b[3 * i], col[8 + i]);
        _mm512_storeu_ps(ck->b[3 * i + 2], col[12 + i]);
    }
}
#endif

/* AVX2 + FMA without AVX-512: the same rows in 256-bit registers */
#include "gather256.h"

/* whether the MLS gather runs in rows, reading the stencil's products w d
 * (the stencil phase's WD) rather than the offsets d */
#if defined(KF_ROWS512) || defined(KF_GATHER256)
#define KF_GATHER_ROWS 1
#else
#define KF_GATHER_ROWS 0
#endif

/* one particle's G2P gather from the owner's node cache into the chunk's v, B (and G) */
KF_INLINE void gather_one(int KW, int CLASSIC, chunk *ck, int j, const kf_v4 *cache) {
    const int CD = CD_MAX;
#ifdef KF_ROWS512
    if (!CLASSIC) {
        gather_rows512(KW, ck, j, cache);
        return;
    }
#endif
#ifdef KF_GATHER256
    if (!CLASSIC) {
        gather_rows256(KW, ck, j, cache);
        return;
    }
#endif
    kf_real w2[4], wd2[4], dw2[4];
    for (int c = 0; c < KW; c++) {
        w2[c] = ck->w[2][c][j];
        wd2[c] = ck->w[2][c][j] * ck->d[2][c][j];
        dw2[c] = ck->dw[2][c][j];
    }
    const kf_v4 *origin = &cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]];
    kf_v4 v = {0}, b0 = {0}, b1 = {0}, b2 = {0}, g0 = {0}, g1 = {0}, g2 = {0};
    for (int a = 0; a < KW; a++)
        for (int b = 0; b < KW; b++) {
            const kf_real wab = ck->w[0][a][j] * ck->w[1][b][j];
            const kf_v4 *row = origin + (a * CD + b) * CD;
            kf_v4 ra = {0}, rd = {0}, rg = {0};
            for (int c = 0; c < KW; c++) {
                ra += w2[c] * row[c];
                rd += wd2[c] * row[c];
                if (CLASSIC) rg += dw2[c] * row[c];
            }
            v += wab * ra;
            b0 += (wab * ck->d[0][a][j]) * ra;
            b1 += (wab * ck->d[1][b][j]) * ra;
            b2 += wab * rd;
            if (CLASSIC) {
                g0 += (ck->dw[0][a][j] * ck->w[1][b][j]) * ra;
                g1 += (ck->w[0][a][j] * ck->dw[1][b][j]) * ra;
                g2 += wab * rg;
            }
        }
    for (int k = 0; k < 3; k++) {
        ck->v[k][j] = v[k];
        ck->b[3 * k][j] = b0[k];
        ck->b[3 * k + 1][j] = b1[k];
        ck->b[3 * k + 2][j] = b2[k];
        if (CLASSIC) {
            ck->g[3 * k][j] = g0[k];
            ck->g[3 * k + 1][j] = g1[k];
            ck->g[3 * k + 2][j] = g2[k];
        }
    }
}

/* a chunk's G2P gathers of n particles (ck->n, or the constant KF_CHUNK),
 * particle by particle or (MLS: AVX-512, or AVX2 + FMA) as one block */
KF_INLINE void gather_chunk(int KW, int CLASSIC, int n, chunk *ck, const kf_v4 *cache) {
#ifdef KF_ROWS512
    if (!CLASSIC) {
        gather_chunk512(KW, n, ck, cache);
        return;
    }
#endif
#ifdef KF_GATHER256
    if (!CLASSIC) {
        gather_chunk256(KW, n, ck, cache);
        return;
    }
#endif
    for (int j = 0; j < n; j++) gather_one(KW, CLASSIC, ck, j, cache);
}

#endif
