/* test_particles.c — the particle arrays' permutation (binning's re-sort).
 *
 * kf_particles_permute_team reorders every array in place, by a window
 * that stays in cache where no particle moves far (particles.c: the ring)
 * and through a whole scratch plane where one does. Either way every array
 * must end as old[src[i]] exactly, for any thread count, and stay where it
 * was (callers hold the pointers across re-sorts). */
#include "kt.h"
#include "mpm/particles.h"
#include "random_util.h"

#include <omp.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

/* n particles whose every field holds a value unique to (field, particle) */
static void fill(kf_particles *p, size_t n) {
    KT_CHECK(kf_particles_reserve(p, n) == 0, "reserve %zu", n);
    p->n = n;
    for (size_t i = 0; i < n; i++) {
        for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) p->plane[k][i] = (kf_real)(k * 100000 + (double)i);
        p->mat[i] = (uint16_t)(i * 7u);
        p->obj[i] = (uint16_t)(i * 13u);
        p->id[i] = (uint32_t)i;
        p->colour[i] = (uint32_t)(i * 2654435761u);
    }
}

/* a permutation that moves each slot at most `reach` away: random swaps
 * inside consecutive windows of reach / 2 + 1 slots (halves: every slot
 * of a window of 2 reach slots trades places with its twin in the other
 * half, exactly reach away, as a whole run of particles moves at a re-sort) */
static void local_permutation(uint32_t *src, size_t n, size_t reach, int halves) {
    for (size_t i = 0; i < n; i++) src[i] = (uint32_t)i;
    if (halves) {
        for (size_t lo = 0; reach && lo + 2 * reach <= n; lo += 2 * reach)
            for (size_t i = lo; i < lo + reach; i++) src[i] = (uint32_t)(i + reach), src[i + reach] = (uint32_t)i;
        return;
    }
    const size_t w = reach / 2 + 1;
    for (size_t lo = 0; lo < n; lo += w) {
        size_t hi = lo + w < n ? lo + w : n;
        for (size_t i = hi - 1; i > lo; i--) {
            size_t j = lo + (size_t)(urand() * (double)(i - lo + 1));
            uint32_t t = src[i];
            src[i] = src[j], src[j] = t;
        }
    }
}

/* the largest |src[i] - i| */
static size_t reach_of(const uint32_t *src, size_t n) {
    size_t r = 0;
    for (size_t i = 0; i < n; i++) {
        size_t d = src[i] > i ? src[i] - i : i - src[i];
        if (d > r) r = d;
    }
    return r;
}

/* permute by `threads` threads and check every array and its place */
static void check_permute(size_t n, const uint32_t *src, size_t reach, int threads, const char *what) {
    kf_particles p = {0}, ref = {0};
    fill(&p, n);
    fill(&ref, n);
    kf_real *planes[KF_PARTICLE_REAL_PLANES];
    memcpy(planes, p.plane, sizeof planes);
    void *scratch = malloc(kf_particles_permute_bytes(n) + 8);
#pragma omp parallel num_threads(threads)
    kf_particles_permute_team(&p, src, reach, scratch);
    int bad = 0;
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) {
        bad += p.plane[k] != planes[k];
        for (size_t i = 0; i < n; i++) bad += memcmp(&p.plane[k][i], &ref.plane[k][src[i]], sizeof(kf_real)) != 0;
    }
    for (size_t i = 0; i < n; i++)
        bad += p.mat[i] != ref.mat[src[i]] || p.obj[i] != ref.obj[src[i]] || p.id[i] != ref.id[src[i]] ||
               p.colour[i] != ref.colour[src[i]];
    KT_CHECK(bad == 0, "%s: n %zu, reach %zu, %d threads: %d slots differ", what, n, reach, threads, bad);
    free(scratch);
    kf_particles_free(&p);
    kf_particles_free(&ref);
}

/* near permutations (the ring: 1 and 2 threads at the largest, 1 to 3 below),
 * far ones and short ranges (the scratch plane), the bound given loosely
 * or not at all */
static void permute_exact(void) {
    const size_t sizes[] = {40000, 700};
    const size_t reaches[] = {0, 255, 1000, 5000};
    uint32_t *src = malloc(sizes[0] * sizeof *src);
    for (int a = 0; a < 2; a++)
        for (int b = 0; b < 5; b++) {
            const size_t n = sizes[a];
            local_permutation(src, n, b < 4 ? reaches[b] : 3000, b == 4);
            const size_t r = reach_of(src, n);
            for (int t = 1; t <= 3; t += 2) {
                check_permute(n, src, r, t, "exact bound");
                check_permute(n, src, SIZE_MAX, t, "no bound");
            }
            check_permute(n, src, r + 777, 2, "loose bound");
        }
    /* a far permutation: reversed */
    for (size_t i = 0; i < sizes[0]; i++) src[i] = (uint32_t)(sizes[0] - 1 - i);
    check_permute(sizes[0], src, sizes[0] - 1, 2, "reversed");
    free(src);
}

/* runs as a re-sort makes them (particles.c: find_runs): aligned fours of
 * consecutive particles trading places with the fours `gap` fours on, and
 * in every `every`-th four two particles swapped (a four that is no run,
 * which the copy of its run misses and its own gather puts right) */
static void runs_permutation(uint32_t *src, size_t n, size_t gap, size_t every) {
    for (size_t i = 0; i < n; i++) src[i] = (uint32_t)i;
    const size_t fours = n / 4;
    for (size_t lo = 0; lo + 2 * gap <= fours; lo += 2 * gap)
        for (size_t g = lo; g < lo + gap; g++)
            for (size_t u = 0; u < 4; u++) {
                const size_t i = 4 * g + u, j = 4 * (g + gap) + u;
                src[i] = (uint32_t)j, src[j] = (uint32_t)i;
            }
    for (size_t g = 0; g < fours; g += every) {
        const uint32_t t = src[4 * g + 1];
        src[4 * g + 1] = src[4 * g + 2], src[4 * g + 2] = t;
    }
}

/* the ring by runs: fours that are runs, some that are not (a chunk mostly
 * runs and one mostly not), counts that leave a thread's range a partial
 * four or start it off the fours, 1 to 3 threads */
static void permute_runs(void) {
    const size_t sizes[] = {40000, 40002, 39999};
    const size_t gaps[] = {3, 200}, every[] = {1000000, 7, 2, 1};
    uint32_t *src = malloc(sizes[1] * sizeof *src); /* the largest */
    for (int a = 0; a < 3; a++)
        for (int b = 0; b < 2; b++)
            for (int c = 0; c < 4; c++) {
                runs_permutation(src, sizes[a], gaps[b], every[c]);
                const size_t r = reach_of(src, sizes[a]);
                for (int t = 1; t <= 3; t++) check_permute(sizes[a], src, r, t, "runs");
            }
    free(src);
}

/* zero arrays are left out of the permutation, which leaves the ring's
 * groups of arrays with a remainder (an odd count of a type): every other
 * array still ends as old[src[i]], for 1 to 3 threads, and the zero ones
 * stay as they were */
static void permute_some_zero(void) {
    const size_t n = 40000;
    uint32_t *src = malloc(n * sizeof *src);
    local_permutation(src, n, 1000, 1);
    const size_t reach = reach_of(src, n);
    for (int threads = 1; threads <= 3; threads++) {
        kf_particles p = {0}, ref = {0};
        fill(&p, n);
        fill(&ref, n);
        p.zero = KF_ZERO_OBJ | KF_ZERO_COLOUR | KF_ZERO_PS;
        void *scratch = malloc(kf_particles_permute_bytes(n) + 8);
#pragma omp parallel num_threads(threads)
        kf_particles_permute_team(&p, src, reach, scratch);
        int bad = 0;
        for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) {
            const int zero = k == KF_PLANE_PS || k == KF_PLANE_PS + 1;
            for (size_t i = 0; i < n; i++)
                bad += memcmp(&p.plane[k][i], &ref.plane[k][zero ? i : src[i]], sizeof(kf_real)) != 0;
        }
        for (size_t i = 0; i < n; i++)
            bad += p.mat[i] != ref.mat[src[i]] || p.id[i] != ref.id[src[i]] || p.obj[i] != ref.obj[i] ||
                   p.colour[i] != ref.colour[i];
        KT_CHECK(bad == 0, "zero arrays left out, %d threads: %d slots differ", threads, bad);
        free(scratch);
        p.zero = 0;
        kf_particles_free(&p);
        kf_particles_free(&ref);
    }
    free(src);
}

int main(int argc, char **argv) {
    KT_RUN(permute_exact, argc, argv);
    KT_RUN(permute_some_zero, argc, argv);
    KT_RUN(permute_runs, argc, argv);
    return KT_EXIT();
}
