/* particles.h — material points as structure of arrays.
 *
 * Every field is its own array of n entries so the per-particle loops stream
 * memory and vectorise. Matrices are stored as 9 planes, row-major:
 * F[3*i+j][p] = (F_p)_ij. The arrays are permuted together when the grid
 * re-sorts particles by block; id[] keeps each particle's stable index. */
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
    uint64_t *key;    /* (n) grid block key of the base node at the last sort */
    int32_t *block;   /* (n) grid block owning the particle at the last sort */
} kf_particles;

/* Bytes one particle holds while a shot runs: the state's arrays and their
 * copy in kf_advance's interval snapshot, the binning's scratch (a
 * destination, a flag and an 8-byte permutation slot per thread: grid.c),
 * and with rigid bodies CPIC's distance, normal and flag (cpic.h). Grid
 * nodes come on top (kf_grid_bytes_per_block). */
static inline double kf_particle_bytes_running(int threads, int rigid_bodies) {
    kf_particles p;
    double state = KF_PARTICLE_REAL_PLANES * sizeof(kf_real) + sizeof *p.mat + sizeof *p.obj + sizeof *p.colour +
                   sizeof *p.id + sizeof *p.key + sizeof *p.block;
    double bin = sizeof(uint32_t) + 1 + 8.0 * (threads > 0 ? threads : 1);
    return 2 * state + bin + (rigid_bodies ? 4 + 12 + 1 : 0);
}

void kf_particles_free(kf_particles *p);
/* Make room for at least cap particles. Returns 0 or -1 (out of memory). */
int kf_particles_reserve(kf_particles *p, size_t cap);
/* dst becomes an exact copy of src (capacity grows as needed). */
int kf_particles_copy(kf_particles *dst, const kf_particles *src);
/* Reorder: new[dest[p]] = old[p]. scratch holds n * 8 bytes. */
void kf_particles_permute(kf_particles *p, const uint32_t *dest, void *scratch, int threads);

#endif
