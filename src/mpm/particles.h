/* particles.h — material points as structure of arrays.
 *
 * Every field is its own array of n entries so the per-particle loops stream
 * memory and vectorise. Matrices are stored as 9 planes, row-major:
 * F[3*i+j][p] = (F_p)_ij. The arrays are permuted together when the grid
 * re-sorts particles by block; id[] keeps each particle's stable index.
 * Which block owns a particle is the grid's (its owners' particle ranges),
 * not stored per particle.
 * Capacity beyond n is allocated but never written until particles are
 * added there, so it costs address space, not resident memory. */
#ifndef KF_PARTICLES_H
#define KF_PARTICLES_H

#include <stddef.h>
#include <stdint.h>

#include "../core/real.h"

/* the kf_real planes, in the order permute/copy/hash walk them */
#define KF_PARTICLE_REAL_PLANES 34 /* x3 v3 C9 F9 mass vol0 ps2 tau6 */

typedef struct kf_particles {
    size_t n, cap;
    union {
        struct {
            kf_real *x[3];   /* (n) position, m */
            kf_real *v[3];   /* (n) velocity, m/s */
            kf_real *C[9];   /* (n) APIC affine velocity / MLS velocity gradient, 1/s */
            kf_real *F[9];   /* (n) elastic deformation gradient */
            kf_real *mass;   /* (n) kg */
            kf_real *vol0;   /* (n) reference volume, m³ */
            kf_real *ps[2];  /* (n) plastic state, see material.h */
            kf_real *tau[6]; /* (n) Kirchhoff stress of F (xx yy zz xy xz yz), Pa */
        };
        kf_real *plane[KF_PARTICLE_REAL_PLANES];
    };
    uint16_t *mat;    /* (n) material index into the model */
    uint16_t *obj;    /* (n) shot object index (surfacing per object) */
    uint32_t *colour; /* (n) CPIC colour: bit 2r = side (1 = negative), bit 2r+1 = affinity to body r */
    uint32_t *id;     /* (n) stable particle index */
    unsigned zero;    /* KF_ZERO_* arrays that hold only +0 and are not written */
} kf_particles;

/* Arrays a model never writes (ps without a plastic or water material,
 * colour without rigid bodies) are kept as zeroed allocations nobody
 * touches, so their pages are never resident: permute, copy and adding
 * particles skip them. Whoever may write one clears its bit first.
 * KF_ZERO_TAU is the same for the stress planes where the stress is not
 * kept at all: the transfers evaluate each particle's τ from its F where
 * they need it (model.h: kf_model_zero_arrays says when), so nothing reads
 * the planes and they stay untouched zeros. */
#define KF_ZERO_PS 1u     /* ps[0], ps[1] */
#define KF_ZERO_COLOUR 2u /* colour */
#define KF_ZERO_TAU 4u    /* tau[0..5]: the stress is evaluated from F, not stored */
#define KF_ZERO_MAT 8u    /* mat: one material */
#define KF_ZERO_OBJ 16u   /* obj: every particle in object 0, no pieces */
#define KF_PLANE_PS 26    /* ps[0], ps[1] are planes 26 and 27 (x3 v3 C9 F9 mass vol0 ps2 tau6) */
#define KF_PLANE_TAU 28   /* tau[0..5] are planes 28 to 33 */

/* whether real plane k is a zero array now */
static inline int kf_particles_plane_zero(const kf_particles *p, int k) {
    return ((p->zero & KF_ZERO_PS) && (k == KF_PLANE_PS || k == KF_PLANE_PS + 1)) ||
           ((p->zero & KF_ZERO_TAU) && k >= KF_PLANE_TAU && k < KF_PLANE_TAU + 6);
}

/* Mark those of the `which` arrays that hold only +0 (bit for bit) in
 * [0, n) as zero, each given a fresh zeroed allocation; the others stay as
 * they are. Returns -1 out of memory. */
int kf_particles_zero(kf_particles *p, unsigned which);

/* The permutation's scratch: one plane of the widest field. */
static inline size_t kf_particles_permute_bytes(size_t n) { return n * (sizeof(kf_real) > 4 ? sizeof(kf_real) : 4); }

/* Bytes one particle holds while a shot runs, field by field (float build;
 * the double build doubles the kf_real planes):
 *   state        x 12, v 12, C 36, F 9x4 = 36, mass 4, vol0 4, ps 8,
 *                tau 24 (34 kf_real planes: 136), mat 2, obj 2, colour 4,
 *                id 4                                               148
 *                less ps 8 without plastic or water materials, less
 *                tau 24 where the stress is evaluated, not kept, less
 *                mat 2 with one material, obj 2 with one object and no
 *                pieces, colour 4 without rigid bodies (KF_ZERO_*: zero
 *                the arrays that are untouched zeros)
 *   binning      dest 4, one shared permutation plane 4, while it      8
 *                bins (its pages go back after: kf_grid_bin)
 *   CPIC         with rigid bodies: distance 4, normal 12, flag 1     17
 * kf_advance's interval start lives in a temporary file (snapshot.c), not
 * here; grid nodes come on top (kf_grid_bytes_per_block). */
static inline double kf_particle_bytes_running(int rigid_bodies, unsigned zero) {
    kf_particles p;
    double state = KF_PARTICLE_REAL_PLANES * sizeof(kf_real) + sizeof *p.mat + sizeof *p.obj + sizeof *p.id;
    if (zero & KF_ZERO_PS) state -= 2 * sizeof(kf_real);
    if (zero & KF_ZERO_TAU) state -= 6 * sizeof(kf_real);
    if (zero & KF_ZERO_MAT) state -= sizeof *p.mat;
    if (zero & KF_ZERO_OBJ) state -= sizeof *p.obj;
    if (rigid_bodies && !(zero & KF_ZERO_COLOUR)) state += sizeof *p.colour;
    double bin = sizeof(uint32_t) + (double)kf_particles_permute_bytes(1);
    return state + bin + (rigid_bodies ? 4 + 12 + 1 : 0);
}

/* the binning's share of kf_particle_bytes_running (resident only while it bins) */
static inline double kf_particle_bytes_binning(void) {
    return sizeof(uint32_t) + (double)kf_particles_permute_bytes(1);
}

void kf_particles_free(kf_particles *p);
/* Make room for at least cap particles. Returns 0 or -1 (out of memory). */
int kf_particles_reserve(kf_particles *p, size_t cap);
/* Real plane k reallocated to cap elements, its contents kept up to the
 * smaller size (planes sit staggered in their allocations: resize and free
 * them only through these functions). Returns 0 or -1 (out of memory). */
int kf_particles_plane_resize(kf_particles *p, int k, size_t cap);
/* dst becomes an exact copy of src (capacity grows as needed). */
int kf_particles_copy(kf_particles *dst, const kf_particles *src);
/* Reorder: new[i] = old[src[i]] (src a permutation), by every thread of a
 * parallel region (it holds barriers; the region's end, or a barrier, comes
 * before the particles are read). reach bounds |src[i] - i| (SIZE_MAX: not
 * known): the closer, the less of the scratch it passes through. scratch
 * holds kf_particles_permute_bytes(n) and must not be read by another thread
 * meanwhile. The arrays stay where they are: pointers to them stay valid. */
void kf_particles_permute_team(kf_particles *p, const uint32_t *src, size_t reach, void *scratch);

#endif
