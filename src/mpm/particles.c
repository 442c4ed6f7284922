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
    free(p->key);
    free(p->block);
    memset(p, 0, sizeof *p);
}

/* the new tail is zeroed: planes a model does not fill before the first
 * step (the stress planes of an explicit run) are written to the first
 * frame's checkpoint, which must not depend on what the heap held before */
static int grow(void **ptr, size_t elem, size_t old, size_t cap) {
    void *q = realloc(*ptr, elem * cap);
    if (!q) return -1;
    memset((char *)q + elem * old, 0, elem * (cap - old));
    *ptr = q;
    return 0;
}

int kf_particles_reserve(kf_particles *p, size_t cap) {
    if (cap <= p->cap) return 0;
    size_t c = p->cap ? p->cap : 1024;
    while (c < cap) c *= 2;
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++)
        if (grow((void **)&p->plane[k], sizeof(kf_real), p->cap, c)) return -1;
    if (grow((void **)&p->mat, sizeof *p->mat, p->cap, c) || grow((void **)&p->id, sizeof *p->id, p->cap, c) ||
        grow((void **)&p->obj, sizeof *p->obj, p->cap, c) || grow((void **)&p->colour, sizeof *p->colour, p->cap, c) ||
        grow((void **)&p->key, sizeof *p->key, p->cap, c) || grow((void **)&p->block, sizeof *p->block, p->cap, c))
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
    memcpy(dst->key, src->key, n * sizeof *src->key);
    memcpy(dst->block, src->block, n * sizeof *src->block);
    dst->n = n;
    return 0;
}

/* scatter one array through dest into scratch, then copy back; each plane is
 * an independent task, so the planes run in parallel */
#define PERMUTE_PLANE(T, arr)                                                                                          \
    do {                                                                                                               \
        T *tmp_ = (T *)scratch_t;                                                                                      \
        for (size_t i_ = 0; i_ < n; i_++) tmp_[dest[i_]] = (arr)[i_];                                                  \
        memcpy((arr), tmp_, n * sizeof(T));                                                                            \
    } while (0)

void kf_particles_permute(kf_particles *p, const uint32_t *dest, void *scratch, int threads) {
    size_t n = p->n;
    int nplanes = KF_PARTICLE_REAL_PLANES + 6;
    /* scratch holds one plane per thread: n * 8 bytes * threads */
#pragma omp parallel num_threads(threads)
    {
        void *scratch_t = 0;
#pragma omp for schedule(dynamic, 1)
        for (int k = 0; k < nplanes; k++) {
            scratch_t = (char *)scratch + (size_t)omp_get_thread_num() * n * 8;
            if (k < KF_PARTICLE_REAL_PLANES) PERMUTE_PLANE(kf_real, p->plane[k]);
            else if (k == KF_PARTICLE_REAL_PLANES) PERMUTE_PLANE(uint16_t, p->mat);
            else if (k == KF_PARTICLE_REAL_PLANES + 1) PERMUTE_PLANE(uint32_t, p->id);
            else if (k == KF_PARTICLE_REAL_PLANES + 2) PERMUTE_PLANE(uint64_t, p->key);
            else if (k == KF_PARTICLE_REAL_PLANES + 3) PERMUTE_PLANE(uint16_t, p->obj);
            else if (k == KF_PARTICLE_REAL_PLANES + 4) PERMUTE_PLANE(uint32_t, p->colour);
            else PERMUTE_PLANE(int32_t, p->block);
        }
    }
}
