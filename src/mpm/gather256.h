/* gather256.h — the MLS G2P gather in stencil rows for AVX2 + FMA float
 * builds without AVX-512 (the AVX-512 rows are gather_rows512_sum and
 * gather_chunk512 in transfer_chunk.h). Included by transfer_chunk.h after
 * the chunk and the AVX-512 gather; private to the library.
 *
 * Same bits as the AVX-512 gather. A 16-lane AVX-512 row register (four
 * nodes of four floats; lanes 12..15 zero for KW 3, a masked load) is here
 * two 8-lane registers: lo holds its lanes 0..7, hi its lanes 8..15 (for
 * KW 3 the fourth node's lanes are zero too: a 128-bit load zero-extended).
 * Lane L of lo or hi then runs exactly the operation lane L or L + 8 of the
 * AVX-512 register runs, in the same order:
 *   A  = fma(w_b, R_ab, A), A' = fma(wd_b, R_ab, A') for b = 0..KW-1, from +0
 *   S  = fma(w_a, A, S), S0 = fma(wd_a, A, S0), S1 = fma(w_a, A', S1), a = 0..KW-1
 *   the products WK S, WK S0, WK S1, WD S (one rounding each, WK and WD
 *   the z-weights per node group, zero past KW)
 *   group sums: (g0 + g2) + (g1 + g3), group_sums4's association: its
 *   first add pairs 128-bit groups 0 with 2 and 1 with 3 (lo + hi here),
 *   its second adds those two (the two 128-bit halves here).
 * The multiply-adds are fma intrinsics on both sides; the four products are
 * plain multiplies on both sides: AVX-512 feeds them to lane shuffles, which
 * no compiler contracts through, but here the first group add reads them
 * directly, and -ffp-contract=fast would fuse product and add into one
 * multiply-add (one rounding fewer): kf_round256 hides each product from
 * the compiler so it is rounded on its own (checked in the generated code:
 * eight vmulps feed the vaddps, no vfmadd there). The results then match
 * gather_rows512's bit for bit, signed zeros included; against the
 * portable gather_one (another summation order) they differ in the last
 * bits. */
#ifndef KF_GATHER256_H
#define KF_GATHER256_H

#if defined(__AVX2__) && defined(__FMA__) && !defined(KF_DOUBLE) && !defined(KF_ROWS512)
#include <immintrin.h>
#define KF_GATHER256 1

/* a product rounded on its own: an empty asm the compiler cannot look
 * through keeps it from fusing the multiply into the add that reads it */
KF_INLINE __m256 kf_round256(__m256 v) {
    __asm__("" : "+x"(v));
    return v;
}

/* one particle's record [v, m | B:,0] (first) and [B:,1 | B:,2] (second),
 * component k of each in lane k of its 128-bit half: gather_rows512_sum's
 * 16 lanes in two registers; node0: its stencil's first node in the cache */
KF_INLINE void gather_rows256_at(int KW, const chunk *ck, int j, const kf_v4 *node0, __m256 *first, __m256 *second) {
    const int CD = CD_MAX;
    const float *origin = (const float *)node0;
    /* one register for the stencil's origin: each row's loads then address
     * it by a constant offset (the compiler otherwise keeps cache and
     * offset apart and forms every row's address with a lea of its own) */
    __asm__("" : "+r"(origin));
    const __m256 zero = _mm256_setzero_ps();
    __m256 S_lo = zero, S_hi = zero, S0_lo = zero, S0_hi = zero, S1_lo = zero, S1_hi = zero;
    for (int a = 0; a < KW; a++) {
        __m256 A_lo = zero, A_hi = zero, A1_lo = zero, A1_hi = zero;
        for (int b = 0; b < KW; b++) {
            /* row (a, b): nodes 0, 1 in lo, nodes 2 (and 3) in hi */
            const float *row = origin + 4 * (a * CD + b) * CD;
            const __m256 r_lo = _mm256_loadu_ps(row);
            const __m256 r_hi = KW == 4 ? _mm256_loadu_ps(row + 8) : _mm256_zextps128_ps256(_mm_loadu_ps(row + 8));
            const __m256 wb = _mm256_set1_ps(ck->w[1][b][j]), wdb = _mm256_set1_ps(ck->wd[1][b][j]);
            A_lo = _mm256_fmadd_ps(wb, r_lo, A_lo);
            A_hi = _mm256_fmadd_ps(wb, r_hi, A_hi);
            A1_lo = _mm256_fmadd_ps(wdb, r_lo, A1_lo);
            A1_hi = _mm256_fmadd_ps(wdb, r_hi, A1_hi);
        }
        const __m256 wa = _mm256_set1_ps(ck->w[0][a][j]), wda = _mm256_set1_ps(ck->wd[0][a][j]);
        S_lo = _mm256_fmadd_ps(wa, A_lo, S_lo);
        S_hi = _mm256_fmadd_ps(wa, A_hi, S_hi);
        S0_lo = _mm256_fmadd_ps(wda, A_lo, S0_lo);
        S0_hi = _mm256_fmadd_ps(wda, A_hi, S0_hi);
        S1_lo = _mm256_fmadd_ps(wa, A1_lo, S1_lo);
        S1_hi = _mm256_fmadd_ps(wa, A1_hi, S1_hi);
    }
    /* the z-weights w_c and w_c d_c per node group (row_lanes), zero past KW */
    const float w3 = KW == 4 ? ck->w[2][3][j] : 0, wd3 = KW == 4 ? ck->wd[2][3][j] : 0;
    const float w0 = ck->w[2][0][j], w1 = ck->w[2][1][j], w2 = ck->w[2][2][j];
    const float wd0 = ck->wd[2][0][j], wd1 = ck->wd[2][1][j], wd2 = ck->wd[2][2][j];
    const __m256 WK_lo = _mm256_setr_ps(w0, w0, w0, w0, w1, w1, w1, w1);
    const __m256 WK_hi = _mm256_setr_ps(w2, w2, w2, w2, w3, w3, w3, w3);
    const __m256 WD_lo = _mm256_setr_ps(wd0, wd0, wd0, wd0, wd1, wd1, wd1, wd1);
    const __m256 WD_hi = _mm256_setr_ps(wd2, wd2, wd2, wd2, wd3, wd3, wd3, wd3);
    /* group sums, group_sums4's order: [g0 + g2 | g1 + g3], then the halves added */
    const __m256 v = _mm256_add_ps(kf_round256(_mm256_mul_ps(WK_lo, S_lo)), kf_round256(_mm256_mul_ps(WK_hi, S_hi)));
    const __m256 b0 =
        _mm256_add_ps(kf_round256(_mm256_mul_ps(WK_lo, S0_lo)), kf_round256(_mm256_mul_ps(WK_hi, S0_hi)));
    const __m256 b1 =
        _mm256_add_ps(kf_round256(_mm256_mul_ps(WK_lo, S1_lo)), kf_round256(_mm256_mul_ps(WK_hi, S1_hi)));
    const __m256 b2 = _mm256_add_ps(kf_round256(_mm256_mul_ps(WD_lo, S_lo)), kf_round256(_mm256_mul_ps(WD_hi, S_hi)));
    *first = _mm256_add_ps(_mm256_permute2f128_ps(v, b0, 0x20), _mm256_permute2f128_ps(v, b0, 0x31));
    *second = _mm256_add_ps(_mm256_permute2f128_ps(b1, b2, 0x20), _mm256_permute2f128_ps(b1, b2, 0x31));
}

/* the same from the particle's base node in the owner's cache */
KF_INLINE void gather_rows256_sum(int KW, const chunk *ck, int j, const kf_v4 *cache, __m256 *first, __m256 *second) {
    const int CD = CD_MAX;
    gather_rows256_at(KW, ck, j, &cache[(ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j]], first, second);
}

/* one particle's gather: its record into the chunk (gather_rows512's stores) */
KF_INLINE void gather_rows256(int KW, chunk *ck, int j, const kf_v4 *cache) {
    float o[16] __attribute__((aligned(32)));
    __m256 first, second;
    gather_rows256_sum(KW, ck, j, cache, &first, &second);
    _mm256_store_ps(o, first);
    _mm256_store_ps(o + 8, second);
    for (int k = 0; k < 3; k++) {
        ck->v[k][j] = o[k];
        ck->b[3 * k][j] = o[4 + k];
        ck->b[3 * k + 1][j] = o[8 + k];
        ck->b[3 * k + 2][j] = o[12 + k];
    }
}

/* eight records of eight floats into eight columns (column i: element i of
 * every record, in record order): pairs interleaved, then quads, then the
 * 128-bit halves. Columns 3 and 7 (a mass, unused lanes) are never read:
 * their shuffles are dead code. */
KF_INLINE void transpose8(const __m256 in[8], __m256 out[8]) {
    __m256 t[8], u[8];
    for (int q = 0; q < 2; q++) {
        const __m256 *r = in + 4 * q;
        t[4 * q] = _mm256_unpacklo_ps(r[0], r[1]);
        t[4 * q + 1] = _mm256_unpackhi_ps(r[0], r[1]);
        t[4 * q + 2] = _mm256_unpacklo_ps(r[2], r[3]);
        t[4 * q + 3] = _mm256_unpackhi_ps(r[2], r[3]);
        /* u[4q + i], half H: element 4H + i of records 4q..4q+3 */
        u[4 * q] = _mm256_shuffle_ps(t[4 * q], t[4 * q + 2], 0x44);
        u[4 * q + 1] = _mm256_shuffle_ps(t[4 * q], t[4 * q + 2], 0xEE);
        u[4 * q + 2] = _mm256_shuffle_ps(t[4 * q + 1], t[4 * q + 3], 0x44);
        u[4 * q + 3] = _mm256_shuffle_ps(t[4 * q + 1], t[4 * q + 3], 0xEE);
    }
    for (int i = 0; i < 4; i++) {
        out[i] = _mm256_permute2f128_ps(u[i], u[4 + i], 0x20);
        out[4 + i] = _mm256_permute2f128_ps(u[i], u[4 + i], 0x31);
    }
}

/* A whole chunk's gather, eight particles at a time: their records become
 * the chunk's planes by two 8x8 register transposes (a dozen shuffles per
 * record instead of a dozen scalar stores). Particles past n get zero
 * records, as in gather_chunk512. The records are gather_rows256's. */
KF_INLINE void gather_chunk256(int KW, int n, chunk *ck, const kf_v4 *cache) {
    const int CD = CD_MAX;
    /* the particles' base nodes in the cache, across the chunk at once */
    int key[KF_CHUNK];
    KF_SIMD
    for (int j = 0; j < n; j++) key[j] = (ck->l[0][j] * CD + ck->l[1][j]) * CD + ck->l[2][j];
    for (int j0 = 0; j0 < KF_CHUNK; j0 += 8) {
        __m256 first[8], second[8], col[8];
        for (int j = 0; j < 8; j++) {
            if (j0 + j < n) gather_rows256_at(KW, ck, j0 + j, &cache[key[j0 + j]], &first[j], &second[j]);
            else first[j] = second[j] = _mm256_setzero_ps();
        }
        /* first: v0 v1 v2 m | B00 B10 B20 -, second: B01 B11 B21 - | B02 B12 B22 - */
        transpose8(first, col);
        for (int k = 0; k < 3; k++) {
            _mm256_storeu_ps(ck->v[k] + j0, col[k]);
            _mm256_storeu_ps(ck->b[3 * k] + j0, col[4 + k]);
        }
        transpose8(second, col);
        for (int k = 0; k < 3; k++) {
            _mm256_storeu_ps(ck->b[3 * k + 1] + j0, col[k]);
            _mm256_storeu_ps(ck->b[3 * k + 2] + j0, col[4 + k]);
        }
    }
}
#endif

#endif
