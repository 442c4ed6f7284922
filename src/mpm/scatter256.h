/* scatter256.h — a chunk's MLS P2G scatter in AVX2 stencil rows (256-bit
 * vectors and FMA, float builds without AVX-512): scatter_chunk512's
 * counterpart for machines that have no AVX-512, in the notes' two
 * multiply-adds a row (its own rounding, see scatter_chunk256). Included
 * by transfer_chunk.h after scatter_one. Private to the library. */
#ifndef KF_SCATTER256_H
#define KF_SCATTER256_H

#if defined(__AVX2__) && defined(__FMA__) && !defined(KF_DOUBLE) && !defined(KF_ROWS512)
#include <immintrin.h>
#define KF_SCATTER256 1

/* a value the compiler may not look through: an operand passed through it
 * stays in a register instead of being reloaded as a memory operand by
 * each row's multiply-add */
#define KF_OPAQUE256(v) __asm__("" : "+x"(v))

/* four planes of 8 floats (particles 0-7 of a half chunk) as records,
 * rec[j] = particle j's four values in plane order: the planes' particles
 * reordered 0 2 4 6 1 3 5 7, then a 4x4 transpose inside each 128-bit
 * lane puts particles 2k and 2k + 1 in out[k]'s lanes, stored in turn */
KF_INLINE void records256(__m256 p0, __m256 p1, __m256 p2, __m256 p3, float (*rec)[4]) {
    const __m256i order = _mm256_setr_epi32(0, 2, 4, 6, 1, 3, 5, 7);
    p0 = _mm256_permutevar8x32_ps(p0, order), p1 = _mm256_permutevar8x32_ps(p1, order);
    p2 = _mm256_permutevar8x32_ps(p2, order), p3 = _mm256_permutevar8x32_ps(p3, order);
    const __m256 t0 = _mm256_unpacklo_ps(p0, p1), t1 = _mm256_unpackhi_ps(p0, p1);
    const __m256 t2 = _mm256_unpacklo_ps(p2, p3), t3 = _mm256_unpackhi_ps(p2, p3);
    _mm256_store_ps(rec[0], _mm256_shuffle_ps(t0, t2, 0x44));
    _mm256_store_ps(rec[2], _mm256_shuffle_ps(t0, t2, 0xEE));
    _mm256_store_ps(rec[4], _mm256_shuffle_ps(t1, t3, 0x44));
    _mm256_store_ps(rec[6], _mm256_shuffle_ps(t1, t3, 0xEE));
}

/* two z-nodes' scalars (c and c + 1) spread over the 4 lanes of each node */
static inline __m256 znodes256(const kf_real *lo, const kf_real *hi) {
    return _mm256_set_m128(_mm_broadcast_ss(hi), _mm_broadcast_ss(lo));
}

/* a stencil row's nodes 0-1 (or 2-3) as one register, loaded and stored
 * node by node: the cache's 16-byte nodes are what the neighbouring run
 * (base node one apart) stored, so each load is forwarded from one store */
static inline __m256 nodes2_load(const float *at) { return _mm256_loadu2_m128(at + 4, at); }
static inline void nodes2_store(float *at, __m256 v) { _mm256_storeu2_m128(at + 4, at, v); }

/* A chunk's MLS scatter, AVX2, in the 2-multiply-add rows of
 * performance-notes.md (technique 2). Node (a, b, c) of particle j gets
 *     w_a w_b (H_a + d_b G_1),   H_a = B + d_a G_0,
 *     B = WK (m v + d_c Q:,2; m), G_0 = WK Q:,0, G_1 = WK Q:,1,
 * with WK the z-weights w_c and d_c the z-offsets spread over the row's node
 * lanes: the z-weights are folded into the particle's terms once, so a row
 * costs a multiply-add for its terms and one for the node (in a 256-bit
 * register for z-nodes 0-1 and a 128-bit one for node 2). This rounds
 * otherwise than scatter_one (which forms (w_a w_b w_c)(h_ab + d_c Q:,2)):
 * the sums differ from the portable path's and the AVX-512 rows' at
 * round-off (perf_results.md section 48 measures both against a double
 * build). Each particle's share is still made on its own and added to each
 * node in chunk order, so the sums do not depend on how particles are cut
 * into runs, chunks or threads.
 * As scatter_chunk512, a run of consecutive particles with the same base
 * node (binning orders an owner's particles by base node) adds into its
 * stencil rows held in registers, loaded and stored once per run. AVX2's 16
 * registers do not hold the run's KW² rows, so a run goes row plane by row
 * plane (a), each particle's KW rows of that plane in turn. Quadratic kernel
 * only (with KW 4 the rows' registers spill and the runs cost what the wider
 * rows save: measured even). */
KF_INLINE void scatter_chunk256(int n, const chunk *ck, kf_v4 *cache) {
    const int CD = CD_MAX, KW = 3;
    const __m256 zero = _mm256_setzero_ps();
    /* records: group 0 [m v, m], 1 Q:,0, 2 Q:,1, 3 Q:,2 (fourth lane 0) */
    float rec[4][KF_CHUNK][4] __attribute__((aligned(32)));
    for (int h = 0; h < (n + 7) / 8; h++) {
        const int o = 8 * h;
        records256(_mm256_loadu_ps(ck->mv[0] + o), _mm256_loadu_ps(ck->mv[1] + o), _mm256_loadu_ps(ck->mv[2] + o),
                   _mm256_loadu_ps(ck->mv[3] + o), rec[0] + o);
        for (int c = 0; c < 3; c++)
            records256(_mm256_loadu_ps(ck->q[c] + o), _mm256_loadu_ps(ck->q[3 + c] + o),
                       _mm256_loadu_ps(ck->q[6 + c] + o), zero, rec[1 + c] + o);
    }
    /* w_a w_b of every particle, KW² products a vector at a time */
    float wab[9][KF_CHUNK] __attribute__((aligned(32)));
    for (int a = 0; a < KW; a++)
        for (int b = 0; b < KW; b++)
            for (int h = 0; h < (n + 7) / 8; h++)
                _mm256_store_ps(wab[a * KW + b] + 8 * h, _mm256_mul_ps(_mm256_loadu_ps(ck->w[0][a] + 8 * h),
                                                                       _mm256_loadu_ps(ck->w[1][b] + 8 * h)));
    /* per particle, once: H_a and G_1 in the row's node lanes (nodes 0-1
     * in 256 bits, node 2 in 128), and its base node */
    __m256 H[3][KF_CHUNK], G1[KF_CHUNK];
    __m128 H2[3][KF_CHUNK], G12[KF_CHUNK];
    int key[KF_CHUNK];
    KF_SIMD
    for (int j = 0; j < n; j++) key[j] = (ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j];
    for (int j = 0; j < n; j++) {
        const __m256 base = _mm256_broadcast_ps((const __m128 *)rec[0][j]);
        const __m256 q0 = _mm256_broadcast_ps((const __m128 *)rec[1][j]);
        const __m256 q1 = _mm256_broadcast_ps((const __m128 *)rec[2][j]);
        const __m256 q2 = _mm256_broadcast_ps((const __m128 *)rec[3][j]);
        const __m256 wk = znodes256(&ck->w[2][0][j], &ck->w[2][1][j]);
        const __m128 wk2 = _mm_broadcast_ss(&ck->w[2][2][j]);
        const __m256 B = _mm256_mul_ps(wk, _mm256_fmadd_ps(znodes256(&ck->d[2][0][j], &ck->d[2][1][j]), q2, base));
        const __m128 B2 = _mm_mul_ps(wk2, _mm_fmadd_ps(_mm_broadcast_ss(&ck->d[2][2][j]), _mm256_castps256_ps128(q2),
                                                       _mm256_castps256_ps128(base)));
        const __m256 G0 = _mm256_mul_ps(wk, q0);
        const __m128 G02 = _mm_mul_ps(wk2, _mm256_castps256_ps128(q0));
        G1[j] = _mm256_mul_ps(wk, q1);
        G12[j] = _mm_mul_ps(wk2, _mm256_castps256_ps128(q1));
        for (int a = 0; a < KW; a++) {
            const __m256 da = _mm256_broadcast_ss(&ck->d[0][a][j]);
            H[a][j] = _mm256_fmadd_ps(da, G0, B);
            H2[a][j] = _mm_fmadd_ps(_mm256_castps256_ps128(da), G02, B2);
        }
    }
    for (int j0 = 0, j1; j0 < n; j0 = j1) {
        for (j1 = j0 + 1; j1 < n && key[j1] == key[j0];) j1++;
        float *origin = (float *)&cache[key[j0]];
        for (int a = 0; a < KW; a++) {
            /* the plane's KW rows: nodes 0-1 in lo, node 2 in hi */
            __m256 lo[3];
            __m128 hi[3];
            for (int b = 0; b < KW; b++) {
                const float *row = origin + 4 * (a * CD + b) * CD;
                lo[b] = nodes2_load(row);
                hi[b] = _mm_loadu_ps(row + 8);
            }
            for (int j = j0; j < j1; j++) {
                /* the particle's terms, once per plane, in registers */
                __m256 Ha = H[a][j], G1j = G1[j];
                __m128 Ha2 = H2[a][j], G1j2 = G12[j];
                KF_OPAQUE256(Ha);
                KF_OPAQUE256(G1j);
                KF_OPAQUE256(Ha2);
                KF_OPAQUE256(G1j2);
                for (int b = 0; b < KW; b++) {
                    const __m256 db = _mm256_broadcast_ss(&ck->d[1][b][j]);
                    const __m256 w = _mm256_broadcast_ss(&wab[a * KW + b][j]);
                    lo[b] = _mm256_fmadd_ps(w, _mm256_fmadd_ps(db, G1j, Ha), lo[b]);
                    hi[b] = _mm_fmadd_ps(_mm256_castps256_ps128(w),
                                         _mm_fmadd_ps(_mm256_castps256_ps128(db), G1j2, Ha2), hi[b]);
                }
            }
            for (int b = 0; b < KW; b++) {
                float *row = origin + 4 * (a * CD + b) * CD;
                nodes2_store(row, lo[b]);
                _mm_storeu_ps(row + 8, hi[b]);
            }
        }
    }
}
#endif

#endif
