/* grid.c — sparse block grid: hashing, binning particles into owner blocks,
 * colouring for race-free P2G. See grid.h for the scheme. */
#define _DEFAULT_SOURCE /* madvise */
#include "grid.h"

#include <omp.h>
#include <sched.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <unistd.h>

void kf_grid_free(kf_grid *g) {
    free(g->bcoord);
    free(g->node);
    free(g->node_old);
    free(g->node_next);
    free(g->hkey);
    free(g->hval);
    free(g->owner);
    free(g->nb);
    free(g->pstart);
    free(g->dest);
    free(g->scratch);
    free(g->count);
    free(g->turn);
    free(g->flushes);
    free(g->touches);
    memset(g, 0, sizeof *g);
}

static int grow(void **ptr, size_t elem, size_t *cap, size_t want) {
    if (want <= *cap && *ptr) return 0;
    size_t c = *cap ? *cap : 256;
    while (c < want) c *= 2;
    void *q = realloc(*ptr, elem * c);
    if (!q) return -1;
    *ptr = q;
    *cap = c;
    return 0;
}

/* ---- hash ------------------------------------------------------------------ */

static inline size_t hash_slot(uint64_t key, size_t mask) {
    key ^= key >> 33;
    key *= 0xff51afd7ed558ccdULL;
    key ^= key >> 33;
    return (size_t)key & mask;
}

static int hash_reset(kf_grid *g, size_t expect) {
    size_t cap = 1024;
    while (cap < 2 * expect) cap *= 2;
    if (cap != g->hcap) {
        free(g->hkey);
        free(g->hval);
        g->hkey = malloc(cap * sizeof *g->hkey);
        g->hval = malloc(cap * sizeof *g->hval);
        if (!g->hkey || !g->hval) return -1;
        g->hcap = cap;
    }
    memset(g->hkey, 0xff, cap * sizeof *g->hkey);
    g->nblocks = 0;
    return 0;
}

static size_t bcoord_cap_of(const kf_grid *g) { return g->bcap; }

int32_t kf_grid_find(const kf_grid *g, int bx, int by, int bz) {
    if (!g->hcap) return -1;
    uint64_t key = kf_block_key(bx, by, bz);
    size_t mask = g->hcap - 1, s = hash_slot(key, mask);
    while (g->hkey[s] != UINT64_MAX) {
        if (g->hkey[s] == key) return g->hval[s];
        s = (s + 1) & mask;
    }
    return -1;
}

/* index of the block with this coordinate, created if missing; -1 on OOM */
static int32_t block_get_or_insert(kf_grid *g, int bx, int by, int bz) {
    uint64_t key = kf_block_key(bx, by, bz);
    size_t mask = g->hcap - 1, s = hash_slot(key, mask);
    while (g->hkey[s] != UINT64_MAX) {
        if (g->hkey[s] == key) return g->hval[s];
        s = (s + 1) & mask;
    }
    if (2 * (g->nblocks + 1) > g->hcap) {
        /* keep the load factor under 1/2: rehash into a table twice the size */
        size_t old_cap = g->hcap;
        uint64_t *ok = g->hkey;
        int32_t *ov = g->hval;
        g->hcap = 0;
        g->hkey = 0;
        g->hval = 0;
        size_t keep = g->nblocks;
        if (hash_reset(g, old_cap)) return -1;
        g->nblocks = keep;
        size_t m2 = g->hcap - 1;
        for (size_t i = 0; i < old_cap; i++) {
            if (ok[i] == UINT64_MAX) continue;
            size_t t = hash_slot(ok[i], m2);
            while (g->hkey[t] != UINT64_MAX) t = (t + 1) & m2;
            g->hkey[t] = ok[i];
            g->hval[t] = ov[i];
        }
        free(ok);
        free(ov);
        mask = g->hcap - 1;
        s = hash_slot(key, mask);
        while (g->hkey[s] != UINT64_MAX) s = (s + 1) & mask;
    }
    size_t cap = bcoord_cap_of(g);
    if (grow((void **)&g->bcoord, 3 * sizeof(int32_t), &cap, g->nblocks + 1)) return -1;
    g->bcap = cap;
    int32_t id = (int32_t)g->nblocks++;
    g->bcoord[3 * id] = bx;
    g->bcoord[3 * id + 1] = by;
    g->bcoord[3 * id + 2] = bz;
    g->hkey[s] = key;
    g->hval[s] = id;
    return id;
}

/* ---- binning ------------------------------------------------------------------ */

/* step 1's flags in dest[] (block ids and slots stay below 2^31) */
#define DEST_MOVED (UINT32_MAX - 1)
#define DEST_BAD UINT32_MAX

typedef struct owner_rec {
    uint64_t key;
    int32_t old_id;
    int32_t count;
} owner_rec;

static int cmp_owner(const void *a, const void *b) {
    uint64_t ka = ((const owner_rec *)a)->key, kb = ((const owner_rec *)b)->key;
    return ka < kb ? -1 : ka > kb;
}

static int ensure_particle_scratch(kf_grid *g, size_t n) {
    if (n <= g->scratch_n && g->dest) return 0;
    free(g->dest);
    free(g->scratch);
    g->dest = malloc(n * sizeof *g->dest + 1);
    g->scratch = malloc(kf_particles_permute_bytes(n) + 8);
    g->scratch_n = n;
    return g->dest && g->scratch ? 0 : -1;
}

/* Hand the pages of a large scratch array back to the system (they read
 * as zeros afterwards and are backed again when next written): memory a
 * pass needs only while it runs is then not resident beside the rest of
 * the substep. Where madvise fails they stay as they are. */
static void release_pages(void *a, size_t bytes) {
    if (!a || bytes < ((size_t)256 << 10)) return;
    long page = sysconf(_SC_PAGESIZE);
    uintptr_t ps = page > 0 ? (uintptr_t)page : 4096, lo = ((uintptr_t)a + ps - 1) / ps * ps,
              hi = ((uintptr_t)a + bytes) / ps * ps;
    if (lo < hi) madvise((void *)lo, hi - lo, MADV_DONTNEED);
}

/* whether particle i's position is finite and in range on every axis (NaN
 * and far-away particles fail): its owner's key and its base nodes fit */
static inline int position_in_range(const kf_particles *p, size_t i, kf_real inv_dx) {
    const kf_real far = (kf_real)(KF_BLOCK * (double)(KF_KEY_OFFSET - 2));
    int ok = 1;
    for (int a = 0; a < 3; a++) ok &= kf_fabs(p->x[a][i] * inv_dx) < far;
    return ok;
}

/* the owner's coordinate along one axis for a position x in range: the
 * block of its base node less the shift */
static inline int owner_coord(kf_real x, kf_real inv_dx, int cubic) {
    return kf_block_of(kf_base_node(x, inv_dx, cubic) - kf_owner_shift(cubic));
}

/* step 1 for owner r's particles (a valid grid): dest is r where the
 * particle's owner is still r, DEST_MOVED where it is another block,
 * DEST_BAD where its position is out of range; the moved and bad counted.
 * By owner the owner's coordinate is at hand (no per-particle owner to
 * store and look up), and the loop runs across the particles in vector
 * lanes. An out-of-range position's base node is taken at 0 (its own would
 * overflow the conversion to int) and not used. */
static void flag_owner(const kf_grid *g, const kf_particles *p, size_t r, kf_real inv_dx, int cubic, long *moved,
                       long *bad) {
    const int32_t *bc = &g->bcoord[3 * r];
    uint32_t *restrict dest = g->dest;
    int nm = 0, nb = 0;
#pragma omp simd reduction(+ : nm, nb)
    for (size_t i = g->pstart[r]; i < g->pstart[r + 1]; i++) {
        const int ok = position_in_range(p, i, inv_dx);
        int same = 1;
        for (int a = 0; a < 3; a++) same &= owner_coord(ok ? p->x[a][i] : 0, inv_dx, cubic) == bc[a];
        dest[i] = !ok ? DEST_BAD : same ? (uint32_t)r : DEST_MOVED;
        nm += ok & !same;
        nb += !ok;
    }
    *moved += nm;
    *bad += nb;
}

static int bin(kf_grid *g, kf_particles *p, kf_real inv_dx, int cubic, int threads, int known_out,
               size_t *bad_particle);

/* The binning's per-particle scratch (dest and the permutation plane, 8
 * bytes a particle) is needed only while it bins: its pages go back
 * afterwards, so the substep's other passes run without them resident. */
int kf_grid_bin(kf_grid *g, kf_particles *p, kf_real inv_dx, int cubic, int threads, size_t *bad_particle) {
    const int known_out = g->known_out;
    g->known_out = 0;
    int rc = bin(g, p, inv_dx, cubic, threads, known_out, bad_particle);
    release_pages(g->dest, g->scratch_n * sizeof *g->dest);
    release_pages(g->scratch, kf_particles_permute_bytes(g->scratch_n));
    return rc;
}

static int bin(kf_grid *g, kf_particles *p, kf_real inv_dx, int cubic, int threads, int known_out,
               size_t *bad_particle) {
    size_t n = p->n;
    if (threads < 1) threads = 1;
    if (ensure_particle_scratch(g, n)) return -1;

    /* 0. nothing to do while every stencil still fits its owner's
     * neighbourhood: the test depends on positions alone, so on no thread count */
    long nmoved = 0, nbad = 0, nout = 0;
    const int shift = kf_owner_shift(cubic);
    uint32_t *dest = g->dest;
    int full = !g->valid;
    /* while the grid is valid, owner r (block id r) holds particles
     * pstart[r]..pstart[r+1]: no per-particle owner is stored */
    const size_t nown = full ? 0 : g->nowner;
    /* (not where the fused sweep found an owner that does not fit) */
    if (!full && !known_out) {
#pragma omp parallel for reduction(+ : nout) schedule(dynamic, 64) num_threads(threads)
        for (size_t r = 0; r < nown; r++) nout += !kf_grid_owner_fits(g, p, r, inv_dx, cubic);
        /* step 1 finds the bad particles again */
        if (!nout) return 0;
    }

    /* 1. each particle's owner block; flag those whose owner changed (dest
     * holds the flags, then the block ids, then the sorted slots): by owner
     * while the grid is valid, every particle moved where it is not */
    if (full) {
#pragma omp parallel for reduction(+ : nmoved, nbad) schedule(static) num_threads(threads)
        for (size_t i = 0; i < n; i++) {
            const int ok = position_in_range(p, i, inv_dx);
            dest[i] = ok ? DEST_MOVED : DEST_BAD;
            nmoved += ok;
            nbad += !ok;
        }
    } else {
#pragma omp parallel for reduction(+ : nmoved, nbad) schedule(dynamic, 64) num_threads(threads)
        for (size_t r = 0; r < nown; r++) flag_owner(g, p, r, inv_dx, cubic, &nmoved, &nbad);
    }
    if (nbad) {
        for (size_t i = 0; i < n; i++)
            if (dest[i] == DEST_BAD) {
                *bad_particle = i;
                break;
            }
        g->valid = 0;
        return -2;
    }
    if (nmoved == 0 && g->valid) return 0;
    g->rebins++;

    /* 2. blocks for the particles that moved (the others keep theirs):
     * those that exist looked up in parallel (the hash only read), then the
     * missing ones inserted in particle order, the ids one serial pass gave */
    if (full && hash_reset(g, n / 64 + 64)) return -1;
    size_t nmissing = full ? nmoved : 0;
    if (!full) {
#pragma omp parallel for reduction(+ : nmissing) schedule(static) num_threads(threads)
        for (size_t i = 0; i < n; i++) {
            if (dest[i] != DEST_MOVED) continue;
            int b[3];
            for (int a = 0; a < 3; a++) b[a] = owner_coord(p->x[a][i], inv_dx, cubic);
            const int32_t id = kf_grid_find(g, b[0], b[1], b[2]);
            if (id >= 0) dest[i] = (uint32_t)id;
            else nmissing++;
        }
    }
    for (size_t i = 0; nmissing && i < n; i++) {
        if (dest[i] != DEST_MOVED) continue;
        /* the owner again from the position, as step 1 found it: no
         * per-particle key is kept between the two steps */
        int b[3];
        for (int a = 0; a < 3; a++) b[a] = owner_coord(p->x[a][i], inv_dx, cubic);
        int32_t id = block_get_or_insert(g, b[0], b[1], b[2]);
        if (id < 0) return -1;
        dest[i] = (uint32_t)id;
        nmissing--;
    }

    /* 3. particles per block; blocks with particles become owners, sorted by key
     * so particle memory follows space */
    size_t nb_old = g->nblocks;
    int32_t *count = calloc(nb_old + 1, sizeof *count);
    if (!count) return -1;
    /* per-thread histograms over static particle ranges: thread t's range
     * precedes thread t+1's, which step 5 relies on for a stable sort */
    const int nt = threads;
    int32_t *hist = calloc((size_t)nt * (nb_old + 1), sizeof *hist);
    if (!hist) return free(count), -1;
#pragma omp parallel num_threads(nt)
    {
        int t = omp_get_thread_num(), T = omp_get_num_threads();
        size_t lo = n * (size_t)t / (size_t)T, hi = n * (size_t)(t + 1) / (size_t)T;
        int32_t *h = hist + (size_t)t * (nb_old + 1);
        for (size_t i = lo; i < hi; i++) h[dest[i]]++;
#pragma omp barrier
#pragma omp for schedule(static)
        for (size_t b = 0; b < nb_old; b++) {
            int32_t c = 0;
            for (int u = 0; u < T; u++) c += hist[(size_t)u * (nb_old + 1) + b];
            count[b] = c;
        }
    }
    size_t nowner = 0;
    for (size_t b = 0; b < nb_old; b++) nowner += count[b] > 0;
    owner_rec *rec = malloc((nowner + 1) * sizeof *rec);
    int32_t *remap = malloc((nb_old + 1) * sizeof *remap);
    int32_t *old_coord = malloc((nb_old * 3 + 1) * sizeof *old_coord);
    if (!rec || !remap || !old_coord) {
        free(count), free(rec), free(remap), free(old_coord), free(hist);
        return -1;
    }
    memcpy(old_coord, g->bcoord, nb_old * 3 * sizeof *old_coord);
    size_t k = 0;
    for (size_t b = 0; b < nb_old; b++)
        if (count[b] > 0) {
            const int32_t *c = &old_coord[3 * b];
            rec[k++] = (owner_rec){kf_block_key(c[0], c[1], c[2]), (int32_t)b, count[b]};
        }
    qsort(rec, nowner, sizeof *rec, cmp_owner);

    /* 4. a fresh block set: owners take ids 0..nowner-1 in key order, then the
     * upper neighbours their stencils reach */
    if (hash_reset(g, nowner * 4 + 64)) goto oom;
    for (size_t r = 0; r < nowner; r++) {
        const int32_t *c = &old_coord[3 * rec[r].old_id];
        if (block_get_or_insert(g, c[0], c[1], c[2]) != (int32_t)r) goto oom;
        remap[rec[r].old_id] = (int32_t)r;
    }
    if (grow((void **)&g->owner, sizeof *g->owner, &g->owner_cap, nowner + 1)) goto oom;
    {
        size_t cap = g->owner_cap;
        void *q1 = realloc(g->nb, cap * sizeof *g->nb), *q2;
        if (!q1) goto oom;
        g->nb = q1;
        q2 = realloc(g->pstart, (cap + 1) * sizeof *g->pstart);
        if (!q2) goto oom;
        g->pstart = q2;
    }
    for (size_t r = 0; r < nowner; r++) {
        const int32_t *c = &old_coord[3 * rec[r].old_id];
        for (int d = 0; d < 8; d++) {
            int32_t id = block_get_or_insert(g, c[0] + (d >> 2), c[1] + ((d >> 1) & 1), c[2] + (d & 1));
            if (id < 0) goto oom;
            g->nb[r][d] = id;
        }
    }
    g->nowner = nowner;

    /* 5. particle ranges per owner and a stable counting sort */
    g->pstart[0] = 0;
    for (size_t r = 0; r < nowner; r++) g->pstart[r + 1] = g->pstart[r] + (size_t)rec[r].count;
    {
        /* each thread starts its range where the threads before it left off
         * in every owner: the same order a serial stable sort would give */
        int identity = 1;
        size_t reach = 0; /* how far a particle moves in the array: the permutation's window */
        size_t *first_slot = malloc((size_t)nt * (nb_old + 1) * sizeof *first_slot);
        if (!first_slot) goto oom;
#pragma omp parallel num_threads(nt)
        {
            int t = omp_get_thread_num(), T = omp_get_num_threads();
            size_t lo = n * (size_t)t / (size_t)T, hi = n * (size_t)(t + 1) / (size_t)T;
            /* this thread's first slot per owner: the owner's start plus what
             * the threads before it hold there */
            for (size_t b = 0; b < nb_old; b++) {
                if (!count[b]) continue;
                size_t before = 0;
                for (int u = 0; u < t; u++) before += (size_t)hist[(size_t)u * (nb_old + 1) + b];
                first_slot[(size_t)t * (nb_old + 1) + b] = g->pstart[remap[b]] + before;
            }
            size_t *slot = first_slot + (size_t)t * (nb_old + 1);
            for (size_t i = lo; i < hi; i++) dest[i] = (uint32_t)slot[dest[i]]++;
        }
        free(first_slot);
        /* inside each owner, particles by their base node (stable): runs of
         * particles with the same stencil, which P2G adds up in registers
         * before it touches the owner's nodes. The slot's particle comes
         * from the permutation's scratch, used here as the inverse of dest;
         * dest then becomes the final order's inverse (slot d holds particle
         * dest[d]), which the permutation gathers through in the same
         * parallel region (the loop's reduction is every thread's after its
         * barrier, and inv is read no more) */
        uint32_t *inv = g->scratch;
        /* the key: the base node's place in the owner's block of base nodes
         * less the shift (step 1 put every particle where that block is its
         * owner: 0..KF_BLOCK-1 per axis), KF_BLOCK³ cells to count and sum,
         * in the order of the base node's offset in the owner */
        enum { CELLS = KF_BLOCK * KF_BLOCK * KF_BLOCK, KEEP_KEYS = 4096 };
        _Static_assert(CELLS <= 256, "cell keys fit 8 bits");
#pragma omp parallel num_threads(nt)
        {
#pragma omp for schedule(static)
            for (size_t i = 0; i < n; i++) inv[dest[i]] = (uint32_t)i;
#pragma omp for schedule(dynamic, 16) reduction(& : identity) reduction(max : reach)
            for (size_t r = 0; r < nowner; r++) {
                int32_t cnt[CELLS + 1];
                memset(cnt, 0, sizeof cnt);
                const int32_t *bc = &g->bcoord[3 * r];
                const size_t s0 = g->pstart[r], s1 = g->pstart[r + 1];
#define CELL_KEY(i)                                                                                                    \
    (((kf_base_node(p->x[0][i], inv_dx, cubic) - shift - KF_BLOCK * bc[0]) * KF_BLOCK +                                \
      (kf_base_node(p->x[1][i], inv_dx, cubic) - shift - KF_BLOCK * bc[1])) *                                          \
         KF_BLOCK +                                                                                                    \
     (kf_base_node(p->x[2][i], inv_dx, cubic) - shift - KF_BLOCK * bc[2]))
                /* the keys kept from the count to the placement (three base
                 * nodes a particle once, not twice), for owners up to
                 * KEEP_KEYS particles; larger ones compute them again */
                uint8_t keys[KEEP_KEYS];
                const int keep = s1 - s0 <= KEEP_KEYS;
                if (keep)
                    for (size_t q = s0; q < s1; q++) {
                        const int key = CELL_KEY(inv[q]);
                        keys[q - s0] = (uint8_t)key;
                        cnt[1 + key]++;
                    }
                else
                    for (size_t q = s0; q < s1; q++) cnt[1 + CELL_KEY(inv[q])]++;
                for (int c = 0; c < CELLS; c++) cnt[c + 1] += cnt[c];
                for (size_t q = s0; q < s1; q++) {
                    const size_t i = inv[q];
                    const size_t d = s0 + (size_t)cnt[keep ? keys[q - s0] : CELL_KEY(i)]++;
                    dest[d] = (uint32_t)i;
                    identity &= d == i;
                    reach = d > i ? (d - i > reach ? d - i : reach) : (i - d > reach ? i - d : reach);
                }
#undef CELL_KEY
            }
            if (!identity) kf_particles_permute_team(p, dest, reach, g->scratch);
        }
        if (!identity) g->permutes++;
    }

    /* 6. colour lists: owners grouped by the parity of their coordinate */
    {
        size_t cstart[9] = {0};
        for (size_t r = 0; r < nowner; r++) {
            const int32_t *c = &g->bcoord[3 * r];
            cstart[1 + ((c[0] & 1) << 2 | (c[1] & 1) << 1 | (c[2] & 1))]++;
        }
        for (int c = 0; c < 8; c++) cstart[c + 1] += cstart[c];
        memcpy(g->colour_start, cstart, sizeof cstart);
        for (size_t r = 0; r < nowner; r++) {
            const int32_t *c = &g->bcoord[3 * r];
            g->owner[cstart[(c[0] & 1) << 2 | (c[1] & 1) << 1 | (c[2] & 1)]++] = (int32_t)r;
        }
    }

    /* 7. node storage for every block; nodes hold nothing between substeps,
     * so growing is free + alloc. 64-byte aligned: a double kf_v4 is an AVX
     * register that aligned loads require at 32 bytes. */
    if (g->nblocks > g->node_cap) {
        free(g->node);
        size_t cap = g->nblocks + g->nblocks / 4 + 64;
        g->node = aligned_alloc(64, cap * KF_BLOCK_NODES * sizeof(kf_v4));
        if (!g->node) goto oom;
        g->node_cap = cap;
    }
    free(count), free(rec), free(remap), free(old_coord), free(hist);
    g->valid = 1;
    return 0;
oom:
    free(count), free(rec), free(remap), free(old_coord), free(hist);
    g->valid = 0;
    return -1;
}

/* ---- P2G's flush order (grid.h) --------------------------------------------- */

int kf_grid_flush_order(kf_grid *g) {
    if (grow((void **)&g->turn, sizeof *g->turn, &g->turn_cap, g->nowner)) return -1;
    if (grow((void **)&g->flushes, sizeof *g->flushes, &g->flushes_cap, g->nblocks)) return -1;
    if (grow((void **)&g->touches, sizeof *g->touches, &g->touches_cap, g->nblocks)) return -1;
    atomic_int *count = g->flushes;
    for (size_t b = 0; b < g->nblocks; b++) atomic_init(&count[b], 0);
    /* an owner's turn at a block: the owners before it that touch the block */
    for (size_t k = 0; k < g->nowner; k++) {
        const size_t r = (size_t)g->owner[k];
        for (int j = 0; j < 8; j++) {
            atomic_int *c = &count[g->nb[r][j]];
            const int t = atomic_load_explicit(c, memory_order_relaxed);
            g->turn[r][j] = (uint8_t)t;
            atomic_store_explicit(c, t + 1, memory_order_relaxed);
        }
    }
    for (size_t b = 0; b < g->nblocks; b++) {
        g->touches[b] = (uint8_t)atomic_load_explicit(&count[b], memory_order_relaxed);
        atomic_store_explicit(&count[b], 0, memory_order_relaxed);
    }
    return 0;
}

/* a neighbour's flush is one owner's scatter away at most: spin a little,
 * then give the core up (on a loaded machine the neighbour may be waiting
 * for it) */
void kf_grid_flush_wait(const kf_grid *g, size_t r) {
    for (int j = 0; j < 8; j++) {
        const atomic_int *c = &g->flushes[g->nb[r][j]];
        for (int spins = 0; atomic_load_explicit(c, memory_order_acquire) != g->turn[r][j]; spins++)
            if (spins >= 256) sched_yield();
    }
}

void kf_grid_flush_wait_block(const kf_grid *g, size_t b) {
    const atomic_int *c = &g->flushes[b];
    for (int spins = 0; atomic_load_explicit(c, memory_order_acquire) != g->touches[b]; spins++)
        if (spins >= 256) sched_yield();
}

/* the owner's nodes are written: the next owner of each block may go */
void kf_grid_flush_done(kf_grid *g, size_t r) {
    for (int j = 0; j < 8; j++) atomic_fetch_add_explicit(&g->flushes[g->nb[r][j]], 1, memory_order_release);
}

/* Grids below this many blocks (256 KB of nodes) are cleared on the calling
 * thread: a few microseconds of memset, less than a hand-off to the other
 * threads and back (a preview scene's grid is a few hundred blocks) */
#define KF_CLEAR_SERIAL_BLOCKS 256

void kf_grid_clear(kf_grid *g, int threads) {
    size_t nb = g->nblocks;
    if (nb < KF_CLEAR_SERIAL_BLOCKS) {
        if (nb) memset(g->node, 0, nb * KF_BLOCK_NODES * sizeof(kf_v4));
        return;
    }
#pragma omp parallel for schedule(static) num_threads(threads)
    for (size_t b = 0; b < nb; b++) memset(&g->node[b * KF_BLOCK_NODES], 0, KF_BLOCK_NODES * sizeof(kf_v4));
}

/* A block outside the owners' neighbourhoods (another rank's halo writes
 * into it): created if missing, with node storage to match. Blocks made
 * here last until the next re-bin builds a fresh block set. */
int32_t kf_grid_ensure_block(kf_grid *g, int bx, int by, int bz) {
    int32_t id = block_get_or_insert(g, bx, by, bz);
    if (id < 0) return -1;
    if (g->nblocks > g->node_cap) {
        /* nodes hold nothing between transfers: grow by free + alloc, kept
         * before P2G clears them */
        size_t cap = g->nblocks + g->nblocks / 4 + 64;
        kf_v4 *node = aligned_alloc(64, cap * KF_BLOCK_NODES * sizeof(kf_v4));
        if (!node) return -1;
        free(g->node);
        g->node = node;
        g->node_cap = cap;
    }
    return id;
}
