/* particles.c — allocation, copy and permutation of the particle SoA. */
#define _DEFAULT_SOURCE /* madvise */
#include "particles.h"

#include <omp.h>
#include <stddef.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

/* the union in kf_particles must cover every named plane exactly */
_Static_assert(sizeof(((kf_particles *)0)->plane) == 34 * sizeof(kf_real *), "plane count");

/* Each real plane starts KF_PLANE_STAGGER x k bytes into its allocation.
 * Large planes are mmapped, and glibc puts every such block 16 bytes past
 * a page boundary: element i of all 34 planes then sat at one address
 * modulo 4096, in one set of the 8-way L1 cache (64 sets of 64-byte
 * lines), and a transfer's chunk, which touches two dozen planes at the
 * same particles, evicted its own lines (and the lines prefetched ahead)
 * from the L1 on every pass. Staggered by one line per plane, the planes'
 * lines at one particle fall in 34 different sets. */
#define KF_PLANE_STAGGER 64
static size_t plane_pad(int k) { return (size_t)k * KF_PLANE_STAGGER; }
/* the allocation a plane lives in (NULL for none) */
static void *plane_block(kf_real *plane, int k) { return plane ? (char *)plane - plane_pad(k) : NULL; }

void kf_particles_free(kf_particles *p) {
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) free(plane_block(p->plane[k], k));
    free(p->mat);
    free(p->obj);
    free(p->colour);
    free(p->id);
    memset(p, 0, sizeof *p);
}

/* the new tail is left unwritten: the pages of a large allocation become
 * resident only when touched, so the doubling's headroom costs no memory
 * (zeroing it here made a 2.85M-particle state hold 4.2M particles' pages).
 * Whoever raises n writes every field of the new particles (state.c,
 * checkpoint.c, src/dist). */
static int grow(void **ptr, size_t elem, size_t cap) {
    void *q = realloc(*ptr, elem * cap);
    if (!q) return -1;
    *ptr = q;
    return 0;
}

/* Set bytes to zero leaving no page resident but the two partial ones at
 * the ends: the whole pages are handed back (MADV_DONTNEED: private
 * anonymous memory reads as zeros afterwards, and stays unbacked until
 * written). A fresh calloc is not enough: below glibc's mmap threshold
 * (which rises to 32 MB as large blocks are freed) calloc writes its zeros.
 * Where madvise fails the bytes are written. */
static void zero_untouched(void *a, size_t bytes) {
    long page = sysconf(_SC_PAGESIZE);
    uintptr_t lo = (uintptr_t)a, hi = lo + bytes, ps = page > 0 ? (uintptr_t)page : 4096;
    uintptr_t plo = (lo + ps - 1) / ps * ps, phi = hi / ps * ps;
    if (plo >= phi || madvise((void *)plo, phi - plo, MADV_DONTNEED) != 0) {
        memset(a, 0, bytes);
        return;
    }
    memset(a, 0, plo - lo);
    memset((void *)phi, 0, hi - phi);
}

/* a zero array grows without copying: all of it is zeros again */
static int grow_zero(void **ptr, size_t elem, size_t cap) {
    void *q = realloc(*ptr, elem * (cap ? cap : 1));
    if (!q) return -1;
    zero_untouched(q, elem * (cap ? cap : 1));
    *ptr = q;
    return 0;
}

/* real plane k resized to cap elements (zero: a zero array, all of it
 * zeros again), at its stagger inside the allocation; the contents up to
 * the smaller size kept otherwise */
static int grow_plane(kf_particles *p, int k, size_t cap, int zero) {
    const size_t pad = plane_pad(k), bytes = sizeof(kf_real) * (cap ? cap : 1);
    char *q = realloc(plane_block(p->plane[k], k), pad + bytes);
    if (!q) return -1;
    if (zero) zero_untouched(q + pad, bytes);
    p->plane[k] = (kf_real *)(q + pad);
    return 0;
}

int kf_particles_plane_resize(kf_particles *p, int k, size_t cap) { return grow_plane(p, k, cap, 0); }

_Static_assert(offsetof(kf_particles, ps) == offsetof(kf_particles, plane) + KF_PLANE_PS * sizeof(kf_real *),
               "ps plane");
#define plane_zero kf_particles_plane_zero

int kf_particles_reserve(kf_particles *p, size_t cap) {
    if (cap <= p->cap) return 0;
    size_t c = p->cap ? p->cap : 1024;
    while (c < cap) c *= 2;
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++)
        if (grow_plane(p, k, c, plane_zero(p, k))) return -1;
    if (((p->zero & KF_ZERO_MAT) ? grow_zero : grow)((void **)&p->mat, sizeof *p->mat, c) ||
        grow((void **)&p->id, sizeof *p->id, c) ||
        ((p->zero & KF_ZERO_OBJ) ? grow_zero : grow)((void **)&p->obj, sizeof *p->obj, c) ||
        ((p->zero & KF_ZERO_COLOUR) ? grow_zero : grow)((void **)&p->colour, sizeof *p->colour, c))
        return -1;
    p->cap = c;
    return 0;
}

/* all +0 bit for bit in the first `bytes` */
static int all_zero(const void *a, size_t bytes) {
    const unsigned char *b = a;
    for (size_t i = 0; i < bytes; i++)
        if (b[i]) return 0;
    return 1;
}

int kf_particles_zero(kf_particles *p, unsigned which) {
    size_t n = p->n;
    if ((which & KF_ZERO_PS) && !(p->zero & KF_ZERO_PS) && p->cap && all_zero(p->ps[0], n * sizeof(kf_real)) &&
        all_zero(p->ps[1], n * sizeof(kf_real))) {
        if (grow_plane(p, KF_PLANE_PS, p->cap, 1) ||
            grow_plane(p, KF_PLANE_PS + 1, p->cap, 1))
            return -1;
        p->zero |= KF_ZERO_PS;
    }
    if ((which & KF_ZERO_COLOUR) && !(p->zero & KF_ZERO_COLOUR) && p->cap &&
        all_zero(p->colour, n * sizeof *p->colour)) {
        if (grow_zero((void **)&p->colour, sizeof *p->colour, p->cap)) return -1;
        p->zero |= KF_ZERO_COLOUR;
    }
    if ((which & KF_ZERO_MAT) && !(p->zero & KF_ZERO_MAT) && p->cap && all_zero(p->mat, n * sizeof *p->mat)) {
        if (grow_zero((void **)&p->mat, sizeof *p->mat, p->cap)) return -1;
        p->zero |= KF_ZERO_MAT;
    }
    if ((which & KF_ZERO_OBJ) && !(p->zero & KF_ZERO_OBJ) && p->cap && all_zero(p->obj, n * sizeof *p->obj)) {
        if (grow_zero((void **)&p->obj, sizeof *p->obj, p->cap)) return -1;
        p->zero |= KF_ZERO_OBJ;
    }
    /* the stress planes hold a cache of F's stress, not state: whatever they
     * hold goes, and the transfers evaluate the stress from F from now on */
    if ((which & KF_ZERO_TAU) && !(p->zero & KF_ZERO_TAU) && p->cap) {
        for (int k = 0; k < 6; k++)
            if (grow_plane(p, KF_PLANE_TAU + k, p->cap, 1)) return -1;
        p->zero |= KF_ZERO_TAU;
    }
    /* an empty set: the arrays come zeroed when reserved */
    if (!p->cap) p->zero |= which;
    return 0;
}

int kf_particles_copy(kf_particles *dst, const kf_particles *src) {
    /* the source's zero arrays are fresh zeroed ones in the copy */
    unsigned z = src->zero;
    if ((z & KF_ZERO_PS) && !(dst->zero & KF_ZERO_PS) && dst->cap &&
        (grow_plane(dst, KF_PLANE_PS, dst->cap, 1) ||
         grow_plane(dst, KF_PLANE_PS + 1, dst->cap, 1)))
        return -1;
    if ((z & KF_ZERO_COLOUR) && !(dst->zero & KF_ZERO_COLOUR) && dst->cap &&
        grow_zero((void **)&dst->colour, sizeof *dst->colour, dst->cap))
        return -1;
    for (int k = 0; k < 6; k++)
        if ((z & KF_ZERO_TAU) && !(dst->zero & KF_ZERO_TAU) && dst->cap &&
            grow_plane(dst, KF_PLANE_TAU + k, dst->cap, 1))
            return -1;
    if ((z & KF_ZERO_MAT) && !(dst->zero & KF_ZERO_MAT) && dst->cap &&
        grow_zero((void **)&dst->mat, sizeof *dst->mat, dst->cap))
        return -1;
    if ((z & KF_ZERO_OBJ) && !(dst->zero & KF_ZERO_OBJ) && dst->cap &&
        grow_zero((void **)&dst->obj, sizeof *dst->obj, dst->cap))
        return -1;
    dst->zero = z;
    if (kf_particles_reserve(dst, src->n)) return -1;
    size_t n = src->n;
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++)
        if (!plane_zero(src, k)) memcpy(dst->plane[k], src->plane[k], n * sizeof(kf_real));
    if (!(z & KF_ZERO_MAT)) memcpy(dst->mat, src->mat, n * sizeof *src->mat);
    memcpy(dst->id, src->id, n * sizeof *src->id);
    if (!(z & KF_ZERO_OBJ)) memcpy(dst->obj, src->obj, n * sizeof *src->obj);
    if (!(z & KF_ZERO_COLOUR)) memcpy(dst->colour, src->colour, n * sizeof *src->colour);
    dst->n = n;
    return 0;
}

/* ---- the permutation in place, through a ring --------------------------------
 * A re-sort moves nearly every particle, but not far (the falling block's
 * 953k move up to ~5k slots: its owners' columns shift as a whole). With
 * every source within `reach` slots of its destination, each array is
 * gathered RING_W slots at a time into a small ring that stays in cache, and
 * a gathered chunk goes back into the array `lag` slots (>= reach + RING_W)
 * behind the gather, once no later destination reads its old values: the
 * array is read and written once, where the gather through the whole
 * scratch plane and the copy back passed the plane's size through the
 * scratch twice more. A thread's first `lag` slots (which the thread before
 * it reads) wait in a head buffer, and its last chunks (which the thread
 * after it reads) in the ring, until every thread has gathered the array.
 * Arrays of one type go through the ring RING_GROUP at a time, each with
 * its own head and ring: the order (as large as a plane, and read once an
 * array it was a third of the permutation's traffic) is read once a group
 * (a chunk of it stays in L1 while the group's arrays gather it), and the
 * group takes one barrier. Where a move is far or a thread's range short,
 * each array goes through the thread's share of the scratch plane and is
 * copied back after its barrier (one an array). */
#define RING_W 256   /* slots gathered at a time (a power of two) */
#define RING_GROUP 2 /* arrays gathered in one pass through the order (3 and 4: slower, see perf_results.md 64) */
#define RUN 4        /* slots a run covers (see find_runs) */
_Static_assert(RING_W % RUN == 0, "a chunk holds whole runs");

/* A thread's slots in groups of RUN, and where each group's particles come
 * from (find_runs): from[g] is the first source of group g where its RUN
 * slots take RUN consecutive particles (a run, one copy of RUN elements),
 * and 0 where they do not (particles 0..RUN-1, in range: the ring's way
 * needs far more particles; the group's own gather then overwrites the
 * copy); odd lists those groups in order, the ring's chunk c's from
 * odd[chunk[c]] to odd[chunk[c + 1]]. from NULL: no runs are used. */
typedef struct permute_runs {
    uint32_t *from, *odd, *chunk;
} permute_runs;

/* how this thread permutes: its range, the ring's lag and length, and how
 * many arrays a pass takes (0: the scratch plane's way). Every thread takes
 * the same way and group, so the same number of barriers. */
typedef struct permute_way {
    const uint32_t *src; /* slot i takes the particle at src[i] */
    size_t lo, hi;       /* this thread's slots */
    size_t lag, rlen;    /* the ring's lag and length (slots) */
    int group;           /* arrays a pass through the ring; 0: no ring */
    char *share;         /* this thread's share of the scratch */
    permute_runs runs;   /* this thread's groups (find_runs) */
} permute_way;

#define RING_FUNCTIONS(T, SUFFIX)                                                                                      \
    /* w slots of one array from their sources into its ring, every slot                                               \
     * on its own (the compiler vectorises it) */                                                                      \
    static inline void gather_chunk_##SUFFIX(T *restrict r, const T *restrict a, const uint32_t *restrict s,           \
                                             size_t w) {                                                               \
        for (size_t j = 0; j < w; j++) r[j] = a[s[j]];                                                                 \
    }                                                                                                                  \
    /* the same by runs: the chunk's ng groups copied from[g] (no branch),                                             \
     * then its odd groups (odd[0..nodd), chunk-relative) and its last w -                                             \
     * RUN·ng slots gathered slot by slot */                                                                          \
    static inline void gather_runs_##SUFFIX(T *restrict r, const T *restrict a, const uint32_t *restrict s, size_t w,  \
                                            const uint32_t *restrict from, const uint32_t *restrict odd, size_t nodd,  \
                                            size_t g0) {                                                               \
        const size_t ng = w / RUN;                                                                                     \
        for (size_t g = 0; g < ng; g++) memcpy(r + RUN * g, a + from[g], RUN * sizeof(T));                             \
        for (size_t e = 0; e < nodd; e++) {                                                                            \
            const size_t j = RUN * (odd[e] - g0);                                                                      \
            for (int u = 0; u < RUN; u++) r[j + u] = a[s[j + u]];                                                      \
        }                                                                                                              \
        for (size_t j = RUN * ng; j < w; j++) r[j] = a[s[j]];                                                          \
    }                                                                                                                  \
    /* gather this thread's slots of K arrays through their rings; write                                               \
     * back what no reader needs (head[k] and ring[k]: array k's buffers) */                                           \
    static void ring_gather_##SUFFIX(int K, T *const *a, const permute_way *pw, T *const *head, T *const *ring) {      \
        const size_t lo = pw->lo, len = pw->hi - lo, lag = pw->lag, rmask = pw->rlen - 1;                              \
        for (size_t c = 0; c < len; c += RING_W) {                                                                     \
            const size_t w = len - c < RING_W ? len - c : RING_W;                                                      \
            const uint32_t *s = pw->src + lo + c;                                                                      \
            /* the chunk of the order stays in L1 for the group's arrays;                                              \
             * by runs where most of its groups are runs */                                                            \
            const permute_runs *pr = &pw->runs;                                                                        \
            const size_t g0 = c / RUN, e0 = pr->from ? pr->chunk[c / RING_W] : 0,                                      \
                         nodd = pr->from ? pr->chunk[c / RING_W + 1] - e0 : 0;                                         \
            const int by_runs = pr->from && 2 * nodd <= w / RUN;                                                       \
            for (int k = 0; k < K; k++)                                                                                \
                if (by_runs)                                                                                           \
                    gather_runs_##SUFFIX(ring[k] + (c & rmask), a[k], s, w, pr->from + g0, pr->odd + e0, nodd, g0);    \
                else gather_chunk_##SUFFIX(ring[k] + (c & rmask), a[k], s, w);                                         \
            if (c >= lag) {                                                                                            \
                /* every source of the chunks still to gather lies past q */                                           \
                const size_t q = c - lag;                                                                              \
                for (int k = 0; k < K; k++)                                                                            \
                    memcpy(q < lag ? head[k] + q : a[k] + lo + q, ring[k] + (q & rmask), RING_W * sizeof(T));          \
            }                                                                                                          \
        }                                                                                                              \
    }                                                                                                                  \
    /* after the barrier: array a's head, and its chunks still in the ring */                                          \
    static void ring_flush_##SUFFIX(T *restrict a, const permute_way *pw, const T *restrict head,                      \
                                    const T *restrict ring) {                                                          \
        const size_t lo = pw->lo, len = pw->hi - lo, lag = pw->lag, rmask = pw->rlen - 1;                              \
        const size_t last = (len - 1) / RING_W * RING_W;                                                               \
        memcpy(a + lo, head, lag * sizeof(T));                                                                         \
        for (size_t q = last - lag + RING_W; q < len; q += RING_W)                                                     \
            memcpy(a + lo + q, ring + (q & rmask), (len - q < RING_W ? len - q : RING_W) * sizeof(T));                 \
    }                                                                                                                  \
    /* one array through the thread's share of the scratch; once every                                                 \
     * thread has read it (the barrier), the share copied back. The share is                                           \
     * written and read by this thread alone, so the next array's gather                                               \
     * needs no second barrier */                                                                                      \
    static void scratch_gather_##SUFFIX(T *restrict a, const permute_way *pw) {                                        \
        T *restrict tmp = (T *)pw->share - pw->lo;                                                                     \
        for (size_t i = pw->lo; i < pw->hi; i++) tmp[i] = a[pw->src[i]];                                               \
        _Pragma("omp barrier") for (size_t i = pw->lo; i < pw->hi; i++) a[i] = tmp[i];                                 \
    }                                                                                                                  \
    /* the `count` arrays of a, a group (ring) or one (scratch) a barrier */                                           \
    static void permute_arrays_##SUFFIX(T *const *a, int count, const permute_way *pw) {                               \
        if (!pw->group) {                                                                                              \
            for (int k = 0; k < count; k++) scratch_gather_##SUFFIX(a[k], pw);                                         \
            return;                                                                                                    \
        }                                                                                                              \
        for (int g = 0; g < count; g += pw->group) {                                                                   \
            const int K = count - g < pw->group ? count - g : pw->group;                                               \
            /* array k's head and ring, side by side in the share */                                                   \
            T *head[RING_GROUP], *ring[RING_GROUP];                                                                    \
            for (int k = 0; k < K; k++) {                                                                              \
                head[k] = (T *)pw->share + (size_t)k * (pw->lag + pw->rlen);                                           \
                ring[k] = head[k] + pw->lag;                                                                           \
            }                                                                                                          \
            ring_gather_##SUFFIX(K, a + g, pw, head, ring);                                                            \
            _Pragma("omp barrier") for (int k = 0; k < K; k++) ring_flush_##SUFFIX(a[g + k], pw, head[k], ring[k]);    \
        }                                                                                                              \
    }

RING_FUNCTIONS(kf_real, real)
RING_FUNCTIONS(uint16_t, u16)
RING_FUNCTIONS(uint32_t, u32)

/* the ring's lag (a whole number of chunks past reach) and length (a power
 * of two holding the lag and a chunk), and how many arrays' heads and rings
 * fit a thread's share of the scratch side by side: the head's lag slots
 * are delayed, the ring's last chunks too, so they must not overlap. The
 * shortest range (n / nt slots) decides, for every thread alike. A thread's
 * gather reads other threads' slots only within reach of its own, which no
 * thread writes before the barrier. */
static permute_way permute_way_of(const uint32_t *src, size_t n, size_t reach, void *scratch) {
    const size_t t = (size_t)omp_get_thread_num(), nt = (size_t)omp_get_num_threads();
    permute_way pw = {.src = src, .lo = n * t / nt, .hi = n * (t + 1) / nt};
    pw.share = (char *)scratch + pw.lo * kf_particles_permute_bytes(1);
    pw.lag = reach < n ? (reach / RING_W + 2) * RING_W : n;
    pw.rlen = RING_W;
    while (pw.rlen < pw.lag + RING_W) pw.rlen *= 2;
    const size_t shortest = n / nt, fit = shortest / (pw.lag + pw.rlen);
    if (reach < n && shortest >= 2 * pw.lag + RING_W) pw.group = fit < RING_GROUP ? (int)fit : RING_GROUP;
    return pw;
}

/* This thread's groups of RUN slots and their runs (permute_runs). A
 * re-sort moves a cell's particles in runs (the falling block's: 94-97% of
 * the aligned fours, perf_results.md 69): one copy of RUN elements moves
 * them, where the gather loads each element on its own. Found once a
 * permutation, for every array; none where they do not fit the thread's
 * share beside its rings (every slot then goes by the plain gather). */
static permute_runs find_runs(const permute_way *pw) {
    const size_t len = pw->hi - pw->lo, ng = len / RUN, nchunk = (len + RING_W - 1) / RING_W;
    const uint32_t *s = pw->src + pw->lo;
    /* in the thread's share of the scratch, past its heads and rings (the
     * widest type's), where they fit: no memory beyond binning's own */
    const size_t rings = (size_t)pw->group * (pw->lag + pw->rlen) * sizeof(kf_real),
                 need = (2 * ng + nchunk + 1) * sizeof(uint32_t);
    permute_runs pr = {NULL, NULL, NULL};
    if (rings + need > len * kf_particles_permute_bytes(1)) return pr;
    pr.from = (uint32_t *)(pw->share + rings);
    pr.odd = pr.from + ng;
    pr.chunk = pr.odd + ng;
    uint32_t nodd = 0;
    for (size_t g = 0; g < ng; g++) {
        if (g % (RING_W / RUN) == 0) pr.chunk[g / (RING_W / RUN)] = nodd;
        const uint32_t *q = s + RUN * g;
        int run = 1;
        for (int u = 1; u < RUN; u++) run &= q[u] == q[0] + (uint32_t)u;
        pr.from[g] = run ? q[0] : 0;
        if (!run) pr.odd[nodd++] = (uint32_t)g;
    }
    for (size_t c = (ng + RING_W / RUN - 1) / (RING_W / RUN); c <= nchunk; c++) pr.chunk[c] = nodd;
    return pr;
}

void kf_particles_permute_team(kf_particles *p, const uint32_t *src, size_t reach, void *scratch) {
    permute_way pw = permute_way_of(src, p->n, reach, scratch);
    if (pw.group) pw.runs = find_runs(&pw);
    /* zero arrays stay as they are: every slot holds +0 */
    kf_real *reals[KF_PARTICLE_REAL_PLANES];
    uint16_t *u16s[2];
    uint32_t *u32s[2] = {p->id};
    int nreal = 0, nu16 = 0, nu32 = 1;
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++)
        if (!plane_zero(p, k)) reals[nreal++] = p->plane[k];
    if (!(p->zero & KF_ZERO_MAT)) u16s[nu16++] = p->mat;
    if (!(p->zero & KF_ZERO_OBJ)) u16s[nu16++] = p->obj;
    if (!(p->zero & KF_ZERO_COLOUR)) u32s[nu32++] = p->colour;
    permute_arrays_real(reals, nreal, &pw);
    permute_arrays_u16(u16s, nu16, &pw);
    permute_arrays_u32(u32s, nu32, &pw);
}
