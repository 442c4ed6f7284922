/* grid.h — the sparse background grid.
 *
 * Nodes live in blocks of 4x4x4 that exist only where particles are: memory
 * and clearing cost follow the particles, not the domain, and a scene without
 * walls is not confined to a box. A block is found by its integer block
 * coordinate through an open-addressing hash, used only when particles are
 * re-binned (a particle that stays in its block never touches the hash).
 *
 * Ownership: a particle belongs to an owner block whose 2x2x2 neighbourhood
 * (the owner and its upper neighbours along each axis, 8 nodes per axis,
 * which binning guarantees to exist) holds its whole stencil (3 or 4 nodes
 * per axis). Binning puts each particle in the block of its base node less
 * KF_OWNER_SHIFT, so that its base sits 1..4 (quadratic) or 0..3 (cubic)
 * nodes into the owner; it may then drift to 0..5 (quadratic) or 0..4
 * (cubic) and still fit: particles are re-sorted only when one drifts out
 * (or after kf_grid_invalidate), not every time one crosses a block face. A
 * falling body re-sorts every few substeps instead of every substep.
 *
 * Race-free parallel P2G: owner blocks are coloured by the parity of their
 * coordinates (8 colours). Two owners of one colour differ by an even,
 * non-zero offset along some axis, so their 2x2x2 block neighbourhoods are
 * disjoint; each colour is one parallel loop with no atomics, and since every
 * node receives its contributions in colour order the sums are bitwise
 * identical for any thread count. */
#ifndef KF_GRID_H
#define KF_GRID_H

#include <stdatomic.h>
#include <stddef.h>
#include <stdint.h>

#include "../core/simd.h"
#include "particles.h"

#define KF_BLOCK 4 /* nodes per block edge */
#define KF_BLOCK_NODES 64
#define KF_KEY_BITS 21
#define KF_KEY_OFFSET (1 << 20)      /* block coordinates in [-2^20, 2^20) */
#define KF_CACHE_EDGE (2 * KF_BLOCK) /* nodes per axis of an owner's neighbourhood */

/* binning's offset of the base node, and the largest base offset inside the
 * owner whose stencil still fits the neighbourhood */
static inline int kf_owner_shift(int cubic) { return cubic ? 0 : 1; }
static inline int kf_owner_lmax(int cubic) { return KF_CACHE_EDGE - (cubic ? 4 : 3); }

typedef struct kf_grid {
    /* block storage */
    size_t nblocks, bcap;
    int32_t *bcoord; /* (nblocks x 3) block coordinate */
    kf_v4 *node;     /* (nblocks x 64) momentum+mass, then velocity+mass */
    size_t node_cap; /* blocks the node array has room for */
    /* the FLIP transfer only: per node the momentum and mass without the
     * stress impulse, then the velocity before the substep's forces
     * (transfer.c); NULL otherwise */
    kf_v4 *node_old;
    size_t node_old_cap;
    /* the fused step (transfer.c: kf_g2p2g): the next substep's momentum
     * and mass, scattered at the end of this one while node still holds its
     * velocities, for the next substep's Δt announced in advance; node and
     * node_next trade places when that substep uses it */
    kf_v4 *node_next;
    size_t node_next_cap;
    int fused_ready;    /* node_next holds a usable scatter ... */
    long fused_substep; /* ... for the substep with this number */
    long fused_rebins;  /* ... made while rebins had this value */
    kf_real fused_dt;   /* ... with this Δt */
    /* the fused sweep tested every owner's reach before the substep with
     * this number, while rebins had this value; reach_all: every particle
     * was within it (that substep's binning has nothing to do), else step.c
     * sets known_out for that substep's kf_grid_bin, which clears it
     * (binning's own test of every owner would only find that again) */
    long reach_substep, reach_rebins;
    int reach_all, known_out;
    /* hash: block key -> block index */
    size_t hcap;    /* power of two */
    uint64_t *hkey; /* UINT64_MAX = empty */
    int32_t *hval;
    /* owner blocks (holding particles), in colour then spatial order */
    size_t nowner;
    int32_t *owner;   /* (nowner) block index */
    int32_t (*nb)[8]; /* (nowner) the 2x2x2 neighbourhood, index (dx<<2)|(dy<<1)|dz */
    size_t *pstart;   /* (nowner + 1) particle range of each owner */
    size_t colour_start[9];
    size_t owner_cap;
    /* P2G's flush order (kf_grid_flush_order): each owner's turn at each
     * block of its neighbourhood, and per block the flushes made so far */
    uint8_t (*turn)[8];    /* (nowner) index as nb */
    atomic_int *flushes;   /* (nblocks) */
    uint8_t *touches;      /* (nblocks) the owners that touch each block */
    size_t turn_cap, flushes_cap, touches_cap;
    /* binning scratch */
    uint32_t *dest; /* (n) */
    void *scratch;  /* permutation scratch, one plane (kf_particles_permute_bytes) */
    size_t scratch_n;
    int32_t *count; /* (nblocks) */
    int valid;      /* 0 until the first bin, and after particles are added */
    /* what the last bin did, for the frame log */
    long rebins, permutes;
} kf_grid;

/* Bytes a grid block holds: its nodes, and with rigid bodies CPIC's
 * per-node distance, colour, closest distance and visit mark (cpic.h). */
static inline double kf_grid_bytes_per_block(int rigid_bodies) {
    return KF_BLOCK_NODES * (sizeof(kf_v4) + (rigid_bodies ? 16 : 0));
}

void kf_grid_free(kf_grid *g);

/* Bin the particles: when some particle's stencil left its owner's
 * neighbourhood (or the grid is not valid), compute each particle's owner,
 * create the blocks its stencil needs, and sort particles by owner block;
 * otherwise only check (positions finite and in range). cubic selects the 4-node stencil. Returns 0, -1 out of
 * memory, or -2 when a particle is outside the representable range
 * (*bad_particle is set to its index). */
int kf_grid_bin(kf_grid *g, kf_particles *p, kf_real inv_dx, int cubic, int threads, size_t *bad_particle);

/* The next kf_grid_bin re-sorts every particle (recentred in its owner), as
 * after loading a checkpoint or restoring an interval's start: writing a
 * checkpoint and starting an interval (kf_advance) call this, so that a run,
 * its resume and its retry group particles alike. */
static inline void kf_grid_invalidate(kf_grid *g) {
    g->valid = 0;
    g->fused_ready = 0;
    g->reach_substep = -1;
    g->known_out = 0;
}

/* The block with this block coordinate, or -1 if there is none. */
int32_t kf_grid_find(const kf_grid *g, int bx, int by, int bz);

/* The block with this coordinate, created (with node storage) if missing;
 * -1 out of memory. Used after binning, before P2G clears the nodes. */
int32_t kf_grid_ensure_block(kf_grid *g, int bx, int by, int bz);

/* How many owners a thread takes at a time in one colour's loop (P2G's
 * colour turns end in a barrier): 4 where each thread has many owners of
 * the colour (neighbouring owners share nodes in cache), fewer where it has
 * few, so that the threads end a colour's turn together (a preview scene
 * has some 15 owners a colour: chunks of 4 left one thread up to a quarter
 * of the turn alone). The owners' sums do not depend on who takes them. */
static inline int kf_grid_colour_chunk(const kf_grid *g, int threads) {
    const size_t per_thread = g->nowner / (8 * (size_t)(threads > 0 ? threads : 1));
    return per_thread >= 16 ? 4 : per_thread >= 8 ? 2 : 1;
}

/* P2G without a barrier per colour. Colour turns give every node its
 * owners' caches in colour order; the same order holds where each owner
 * adds its cache once every owner before it (in g->owner's order) that
 * shares one of its 8 blocks has added its own: its turn at each block.
 * An owner then waits only on neighbours still being flushed, not on the
 * whole colour, and the sums are those of the colour turns, to the bit,
 * for any thread count. Owners must be taken in g->owner's order (each
 * thread's own in increasing order), so the first unfinished owner never
 * waits. kf_grid_flush_order (serial, before the parallel loop) computes
 * the turns and zeroes the counts; -1 out of memory. */
int kf_grid_flush_order(kf_grid *g);
void kf_grid_flush_wait(const kf_grid *g, size_t r);
void kf_grid_flush_done(kf_grid *g, size_t r);
/* block b has every owner's cache that touches it (the grid update's turn) */
void kf_grid_flush_wait_block(const kf_grid *g, size_t b);

/* Zero every node of every block. */
void kf_grid_clear(kf_grid *g, int threads);

static inline uint64_t kf_block_key(int bx, int by, int bz) {
    return ((uint64_t)(uint32_t)(bx + KF_KEY_OFFSET) << (2 * KF_KEY_BITS)) |
           ((uint64_t)(uint32_t)(by + KF_KEY_OFFSET) << KF_KEY_BITS) | (uint64_t)(uint32_t)(bz + KF_KEY_OFFSET);
}

/* floor division by the block size for negative node indices too */
static inline int kf_block_of(int node) { return node >= 0 ? node / KF_BLOCK : -((-node + KF_BLOCK - 1) / KF_BLOCK); }

/* Base node of a particle's stencil along one axis. Binning and the
 * transfers must agree on it to the bit, so the quadratic x/Δx − ½ is an
 * explicit fused multiply-add: the compiler may not contract it differently
 * in scalar and vectorised code. */
static inline int kf_base_node(kf_real x, kf_real inv_dx, int cubic) {
    return cubic ? (int)kf_floor(x * inv_dx) - 1 : (int)kf_floor(kf_fma(x, inv_dx, KF_R(-0.5)));
}

/* Whether every particle of owner r (of a valid grid) is finite, in range
 * and has its stencil inside the owner's neighbourhood: binning's test,
 * also made by the fused sweep while the positions are in cache. The base
 * node is monotonic in x (one rounding of x/Δx, or of x/Δx − ½, then
 * floor), so once every position is finite and in range the lowest and
 * highest per axis stand for all of them: a min, a max and a range test a
 * particle, vectorised, where a base node each took a floor, a conversion
 * and two compares. */
static inline int kf_grid_owner_fits(const kf_grid *g, const kf_particles *p, size_t r, kf_real inv_dx, int cubic) {
    const int32_t *bc = &g->bcoord[3 * r];
    const int lmax = kf_owner_lmax(cubic);
    const size_t lo = g->pstart[r], hi = g->pstart[r + 1];
    const kf_real far = (kf_real)(KF_BLOCK * (double)(KF_KEY_OFFSET - 2));
    if (lo == hi) return 1;
    for (int a = 0; a < 3; a++) {
        const kf_real *x = p->x[a];
        kf_real xmin = x[lo], xmax = x[lo];
        int ok = 1;
#pragma omp simd reduction(min : xmin) reduction(max : xmax) reduction(& : ok)
        for (size_t i = lo; i < hi; i++) {
            const kf_real xi = x[i];
            /* NaN and far-away positions fail here */
            ok &= kf_fabs(xi * inv_dx) < far;
            xmin = xi < xmin ? xi : xmin;
            xmax = xi > xmax ? xi : xmax;
        }
        const int origin = KF_BLOCK * bc[a];
        if (!ok || kf_base_node(xmin, inv_dx, cubic) - origin < 0 || kf_base_node(xmax, inv_dx, cubic) - origin > lmax)
            return 0;
    }
    return 1;
}

#endif
