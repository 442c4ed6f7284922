/* cpic.h — Compatible Particle-In-Cell (paper §5): material on the two sides
 * of an infinitely thin rigid surface moves independently, and rigid bodies
 * and material exchange momentum. Private to the library.
 *
 * A substep with rigid bodies (step.c), in the paper's order (Fig. 10):
 *   bin → kf_cpic_splat (grid colored distance field from the rigid seeds,
 *   §5.2; marks the owner blocks in the narrow band) → P2G (band blocks go
 *   through kf_cpic_p2g_particle: particle colour, distance and normal
 *   §5.3, compatible nodes only, impulses on the bodies for incompatible
 *   ones §5.4) → grid update → G2P (band blocks: ghost velocities on
 *   incompatible nodes, §5.5; penalty) → kf_cpic_finish (rigid advection
 *   from the summed impulses, §5.6).
 * Blocks outside the narrow band take the ordinary vectorised path and pay
 * nothing; a scene without rigid bodies never gets here.
 *
 * Node colour word (32 bits, beside a 32-bit float distance: §5.2.3):
 *   bit 2r   = T_ir, the node is on body r's negative side (behind its normals)
 *   bit 2r+1 = A_ir, the node has a valid distance to body r
 *   bits 28..31 = r*(x_i) + 1, the closest body (0 = none)
 * so a scene holds at most KF_MAX_RIGIDS = 14 bodies. A particle's colour
 * (kf_particles.colour) uses the same low 28 bits.
 *
 * Choices where the paper is silent: the tag at a node is
 * the sign at the body's closest valid primitive (the paper's rule, not the
 * authors' code's "negative wins"); ties go to the smaller distance, then the
 * smaller body index, so runs are deterministic for any thread count. The
 * body velocity V_r is pinned for the whole substep. P2G gives the body
 * everything an incompatible node would have received; G2P takes back the
 * ghost velocity the particle keeps there, computed once, so momentum is
 * exchanged exactly (the push and the penalty give the body their
 * reactions too). The impulse of an incompatible node includes the node's
 * share of the particle's affine momentum, stress force and gravity, so an
 * isolated system of material and bodies conserves momentum. */
#ifndef KF_CPIC_H
#define KF_CPIC_H

#include <stddef.h>
#include <stdint.h>

#include "../mpm/cpic_seam.h" /* what the step calls: splat, chunk transfers, guard, finish */
#include "../mpm/model.h"

#define KF_CPIC_RSTAR_SHIFT 28
#define KF_CPIC_BITS_MASK ((1u << KF_CPIC_RSTAR_SHIFT) - 1)
#define KF_CPIC_AFFINITY 0xAAAAAAAu /* the A bits of the 14 bodies */
#define KF_CPIC_RUN 64              /* seeds per bounding sphere (cdf.c) */

/* A body's primitives in world space for this substep (plane data per triangle). */
typedef struct kf_cpic_tri {
    float v0[3], e1[3], e2[3], n[3]; /* corner, edges, unit normal */
    float g11, g12, g22;             /* inverse Gram matrix of (e1, e2) */
} kf_cpic_tri;

/* The crossing guard's pose pass (guard.c): every body's pose at the
 * substep's end, called by the splat. */
void kf_cpic_guard_poses(const kf_model *m, const kf_state *s, double dt);

typedef struct kf_cpic {
    uint32_t epoch; /* one per splat: a block's CDF is valid iff stamp == epoch */
    /* grid colored distance field, per grid block (cap_blocks x 64 nodes) */
    size_t cap_blocks;
    float *node_d;        /* unsigned distance in cells */
    uint32_t *node_c;     /* colour word */
    uint32_t *stamp;      /* per block */
    float *best;          /* per node: the closest |u| of the body being splatted */
    uint32_t *best_stamp; /* per block: epoch * 16 + body of `best` */
    uint32_t *mark;       /* per node: the last triangle (numbered across bodies, from 1) that visited it */
    /* the splat's per-seed scratch (cap_seed) and its x-block bins (cap_bins) */
    size_t cap_seed, cap_bins;
    double *seed_x;      /* (3 x seeds) world position */
    int32_t *seed_bin;   /* x-block bin of its node box, -1: touches no block */
    int32_t *seed_order; /* seeds grouped by bin, in seed order within one */
    void *seed_sb;       /* (seeds) a kept seed's node box and its blocks, as found when it was kept (cdf.c) */
    int32_t *bin_start;  /* (bins + 1) */
    /* this substep's blocks by coordinate, dense over the grid's box of
     * blocks (-1: none; all -1 between splats), where that box is small
     * enough: the splat's block lookups without hashing */
    int32_t *bmap;
    size_t cap_bmap;
    int bmap_on;
    int32_t bmap_lo[3], bmap_dim[3];
    /* per body, its seeds in runs of KF_CPIC_RUN, and those in runs of
     * KF_CPIC_RUN / 8, each with a bounding sphere in the body's frame (x,
     * y, z, radius) and the half sides of the seeds' box about the same
     * centre (x, y, z; the last slot unused): a run far from every block is
     * passed over without placing its seeds */
    double (*run_sphere[KF_MAX_RIGIDS])[8];
    double (*sub_sphere[KF_MAX_RIGIDS])[8];
    uint8_t *run_kept; /* per run of the body being splatted: some seed was kept */
    size_t cap_run_kept;
    const float *run_seed[KF_MAX_RIGIDS]; /* the seeds they were made for */
    size_t run_nseed[KF_MAX_RIGIDS];
    /* per block, the box of its nodes some particle's stencil may read this
     * substep (local node indices lo[3], hi[3]; lo > hi: none), and per
     * owner the node box its particles' stencils span: a seed whose box
     * reaches no such node is not splatted (cdf.c) */
    int8_t (*rbox)[6];
    int32_t (*obox)[6];
    size_t cap_rbox, cap_obox;
    uint8_t *aff; /* per block: some node has affinity this substep */
    size_t cap_aff;
    uint8_t *near_blk; /* per block: some seed may reach its owner's reads this substep (cdf.c) */
    size_t cap_near;
    /* owner blocks in the narrow band and their impulse accumulators */
    size_t cap_owner;
    int32_t *slot; /* per owner: index into imp, or -1 outside the band */
    uint32_t *xm_epoch; /* per owner: == epoch: P2G left its particles' xmask for G2P */
    size_t nslot, cap_slot;
    double (*imp)[KF_MAX_RIGIDS][6];
    long band_owners; /* for the frame log */
    long band_particles;
    /* particle distance and normal of this substep (§5.3.2), per particle */
    size_t cap_p;
    float *pd;     /* d_p, m; valid where near[p] */
    float *pn;     /* (n x 3) n_p */
    uint8_t *near; /* the MLS fit succeeded */
    uint32_t *xmask; /* P2G's nodes across a surface (a bit per stencil node), where the colour has affinity */
    /* world primitives, per body */
    kf_cpic_tri *tri[KF_MAX_RIGIDS];
    uint32_t *tri_stamp[KF_MAX_RIGIDS]; /* == epoch: tri[r][k] holds this substep's pose */
    int cap_tri[KF_MAX_RIGIDS];
    /* the substep's totals per body: J[3], L[3] about the com */
    double impulse[KF_MAX_RIGIDS][6];
    /* running totals since the state was made (diagnostics, frame log) */
    double impulse_total[KF_MAX_RIGIDS][6];
    /* the substep's pinned constants */
    double dt, gdt[3];
    /* The static bodies' CDF (cdf.c), splatted once for every block within
     * reach of their seeds inside the domain (with a margin): per block
     * coordinate (a small open-addressed hash), 64 distances and colours.
     * Valid while every static body's pose, seeds and the grid spacing are
     * those it was made with (sig). */
    struct kf_cpic_static {
        int built, used;               /* built: valid for sig; used: holds at least one block */
        double sig[KF_MAX_RIGIDS][13]; /* per static body: R, t, dx */
        const float *sig_seed[KF_MAX_RIGIDS];
        int32_t lo[3], hi[3]; /* the block region it covers */
        size_t n, cap;        /* blocks */
        int32_t *coord;       /* (n x 3) */
        float *d;
        uint32_t *c, *stamp, *best_stamp, *mark;
        float *best;
        uint64_t *hkey; /* block key, UINT64_MAX: empty */
        int32_t *hval;
        size_t hcap;
    } st;
    /* the crossing guard (guard.c): every body's pose at the substep's end,
     * and per owner slot the crossings caught and the deepest (m) */
    kf_rigid_state end[KF_MAX_RIGIDS];
    /* per thin body, which side its surface can give a point of each cell
     * of a lattice in its mesh frame (guard.c), filled as particles reach
     * the cells: the guard's re-sync needs no closest-triangle query where
     * the answer cannot change the particle's tag */
    struct kf_cpic_sides {
        int tried;
        uint8_t *v; /* per cell: 0 not yet known, else a KF_SIDES_* value */
        double (*plane)[4]; /* per guard primitive: tri_plane's unit normal and offset (in v's allocation) */
        double lo[3], h, reach, tol;
        int dim[3];
    } sides[KF_MAX_RIGIDS];
    /* per solid body, how deep material may enter it and where it cannot
     * reach the surface within a substep (solid_guard.c) */
    struct kf_cpic_solid {
        int tried;
        double allow;       /* the deepest a particle's centre may lie behind the face it entered by, m */
        double (*plane)[4]; /* per guard primitive: its unit normal and offset (mesh frame) */
        uint8_t *clear;     /* per lattice cell: 0 not yet known, KF_SOLID_NEAR, else 1 + its clearance in steps */
        double lo[3], h, step, reach, tol;
        int dim[3];
    } solid[KF_MAX_RIGIDS];
    long *guard_caught;
    double *guard_depth;
    /* the substep's guard totals (kf_cpic_finish) */
    long caught;
    double caught_depth;
    /* this substep's CDF is every body's, all static, copied from the
     * store: the next substep's splat over the same blocks gives the same
     * CDF, band and read boxes (kf_cpic_splat) */
    int static_cdf;
    /* The next substep's P2G made early in the fused sweep (early.c): its
     * impulse rows and gΔt, and the colours its band owners' particles had
     * before it (per slot from first[slot], kept where done[slot]), put
     * back if that substep does not use the scatter; or, with moving
     * bodies, made over an empty band (no owner in it: every owner's P2G
     * the ordinary one), usable only if the next band is empty too. */
    struct kf_cpic_early {
        int pending;         /* some owner's particles hold colours of the early P2G */
        int empty;           /* made over an empty band with a body not static: usable if the next band is empty */
        double dt, gdt[3];   /* the next substep's Δt and gΔt */
        uint32_t epoch;      /* the splat it was made after */
        size_t nslot, nkeep; /* band owners and their particles then */
        double (*imp)[KF_MAX_RIGIDS][6];
        uint32_t *keep;
        size_t *first;
        uint8_t *done;
        size_t cap_slot, cap_keep;
    } early;
} kf_cpic;

/* The sides a thin body's surface can give the points of each cell of a
 * lattice in its mesh frame (guard.c): made for cells of an eighth of dx,
 * or a quarter for a larger body (kf_cpic_sides_make; a body too large for
 * either gets none), each
 * cell's value found when a point first asks (kf_cpic_sides_at, safe from
 * any thread). KF_SIDES_NONE: no triangle within 1.5 dx of any point of the
 * cell; FRONT (BEHIND): the cell strictly in front of (behind) the plane of
 * every triangle that can be the closest within that reach; MIXED: no
 * answer without a query. */
enum { KF_SIDES_NONE = 1, KF_SIDES_FRONT, KF_SIDES_BEHIND, KF_SIDES_MIXED };
void kf_cpic_sides_make(const kf_rigid_body *b, double dx, struct kf_cpic_sides *sd);
int kf_cpic_sides_at(const struct kf_cpic_sides *sd, const kf_rigid_body *b, const double pm[3]);

/* The guard around solids (solid_guard.c). A particle's centre may enter a
 * solid by at most min(dx / 2, 0.4 t) behind the face it entered by (t: the
 * solid's thickness at its thinnest), never through it. kf_cpic_solid_make: the
 * allowances and the lattice, once per body; kf_cpic_solid_guard: one
 * particle after advection (xold: where it started, world), put back to
 * that depth if it went deeper; returns how much deeper it went (m), 0 if
 * it did not. */
#define KF_SOLID_NEAR 255
void kf_cpic_solid_make(const kf_rigid_body *b, double dx, struct kf_cpic_solid *sd);
double kf_cpic_solid_guard(const kf_model *m, kf_state *s, int r, size_t i, const double xold[3], double *imp);
void kf_cpic_solid_free(struct kf_cpic_solid *sd);
/* the particles deeper in solid r than the guard allows now (the audit, guard.c) */
long kf_cpic_solid_audit(const kf_model *m, const kf_state *s, int r, double *deepest_cells);

/* Particle i put back by a guard at point pm of body r's mesh frame (normal
 * nm there, on the side it is put on), at the body's end pose: its position
 * written, and its velocity's approach relative to the body removed as the
 * boundary type says (Eq. 25), the body taking that momentum (guard.c). */
void kf_cpic_guard_place(const kf_model *m, kf_state *s, int r, size_t i, const double pm[3], const double nm[3],
                         double *imp);

/* J (linear impulse at world point x) and its moment about the body's com, added to imp[6] */
static inline void kf_cpic_add_impulse(double *imp, const kf_rigid_state *st, const double x[3], const double J[3]) {
    double r0 = x[0] - st->com[0], r1 = x[1] - st->com[1], r2 = x[2] - st->com[2];
    imp[0] += J[0];
    imp[1] += J[1];
    imp[2] += J[2];
    imp[3] += r1 * J[2] - r2 * J[1];
    imp[4] += r2 * J[0] - r0 * J[2];
    imp[5] += r0 * J[1] - r1 * J[0];
}

/* The scar: which side of a thin body (a blade) a particle was on, kept
 * after the body has left, so the surfacer can tell the two sides of a cut
 * apart however close they lie. Bits 28..31 of a particle's colour hold
 * r + 1 of the thin body it last had affinity to (0: none), and bit 2r its
 * side then. Without the affinity bit 2r + 1 that side bit is a label only:
 * compatibility (below) reads side bits under shared affinity alone. New
 * colour cp (low bits) from the old word: the lowest thin body it now has
 * affinity to, else the old scar with its side. */
static inline uint32_t kf_cpic_scar(uint32_t cp, uint32_t old, const uint8_t *thin_body) {
    cp &= KF_CPIC_BITS_MASK;
    for (uint32_t held = cp & KF_CPIC_AFFINITY; held; held &= held - 1) {
        int r = __builtin_ctz(held) / 2;
        if (thin_body[r]) return cp | (uint32_t)(r + 1) << KF_CPIC_RSTAR_SHIFT;
    }
    uint32_t s = old >> KF_CPIC_RSTAR_SHIFT;
    if (!s) return cp;
    uint32_t side = 1u << (2 * (s - 1));
    return (cp & ~side) | (old & side) | (s << KF_CPIC_RSTAR_SHIFT);
}

/* compatible (§5.3.4): equal tags on every body both node and particle have affinity to */
static inline int kf_cpic_compatible(uint32_t node, uint32_t part) {
    uint32_t shared = (node & part & KF_CPIC_AFFINITY) >> 1;
    return ((node ^ part) & shared) == 0;
}

#endif
