/* particles.c — allocation, copy and permutation of the particle SoA. */
#include "particles.h"

#include <omp.h>
#include <stdlib.h>
#include <string.h>

/* the union in kf_particles must cover every named plane exactly */
_Static_assert(sizeof(((kf_particles *)0)->plane) == 34 * sizeof(kf_real *), "plane count");

void kf_particles_free(kf_particles *p) {
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) free(p->plane[k]);
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

int kf_particles_reserve(kf_particles *p, size_t cap) {
    if (cap <= p->cap) return 0;
    size_t c = p->cap ? p->cap : 1024;
    while (c < cap) c *= 2;
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++)
        if (grow((void **)&p->plane[k], sizeof(kf_real), c)) return -1;
    if (grow((void **)&p->mat, sizeof *p->mat, c) || grow((void **)&p->id, sizeof *p->id, c) ||
        grow((void **)&p->obj, sizeof *p->obj, c) || grow((void **)&p->colour, sizeof *p->colour, c))
        return -1;
    p->cap = c;
    return 0;
}

int kf_particles_copy(kf_particles *dst, const kf_particles *src) {
    if (kf_particles_reserve(dst, src->n)) return -1;
    size_t n = src->n;
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) memcpy(dst->plane[k], src->plane[k], n * sizeof(kf_real));
    memcpy(dst->mat, src->mat, n * sizeof *src->mat);
    memcpy(dst->id, src->id, n * sizeof *src->id);
    memcpy(dst->obj, src->obj, n * sizeof *src->obj);
    memcpy(dst->colour, src->colour, n * sizeof *src->colour);
    dst->n = n;
    return 0;
}

/* scatter one array through dest into the scratch, then copy it back; both
 * halves split the particles over the threads (dest is a permutation, so
 * no two threads write one slot), and one scratch plane serves every array */
#define PERMUTE_PLANE(T, arr)                                                                                          \
    do {                                                                                                               \
        T *tmp_ = (T *)scratch, *a_ = (T *)(arr);                                                                      \
        _Pragma("omp for schedule(static)") for (size_t i_ = 0; i_ < n; i_++) tmp_[dest[i_]] = a_[i_];                 \
        _Pragma("omp for schedule(static)") for (size_t i_ = 0; i_ < n; i_++) a_[i_] = tmp_[i_];                       \
    } while (0)

void kf_particles_permute(kf_particles *p, const uint32_t *dest, void *scratch, int threads) {
    size_t n = p->n;
#pragma omp parallel num_threads(threads)
    {
        for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) PERMUTE_PLANE(kf_real, p->plane[k]);
        PERMUTE_PLANE(uint16_t, p->mat);
        PERMUTE_PLANE(uint32_t, p->id);
        PERMUTE_PLANE(uint16_t, p->obj);
        PERMUTE_PLANE(uint32_t, p->colour);
    }
}
