/* dist.h — one simulation over MPI ranks: block ownership, halo sums,
 * particle migration, balance.
 *
 * Ownership. kerf keeps particles sorted by the key of their 4³ owner block
 * (grid.h), a key whose order is x-major (x, then y, then z). Each rank owns
 * one contiguous range of keys, cut where the particle count reaches k/N of
 * the total: slabs of block planes along x, cut inside a plane where the
 * count asks for it. The cut follows kerf's own particle order on purpose:
 * the ranks' arrays, laid end to end in rank order, are the one-rank array,
 * so migration (the particles each rank receives, concatenated in sender
 * order, then kerf's stable sort by block) rebuilds exactly the order the
 * one-rank run has, and every owner block's particles sit in the same order.
 *
 * Halo sums. One rank sums a grid node in colour order of its source owner
 * blocks; two owners of a colour never share a node (grid.h). Each rank
 * sends the P2G cache (the part its stencils touched) of every owner block
 * lying within R blocks of another rank's owner block (R = 1, or 2 with
 * domain walls, whose ghost nodes read two cells inward) to that rank, and
 * to no other (every rank's owner keys are gathered after each re-sort),
 * which adds it in the owner's colour turn: every node the rank's G2P
 * reads is then the one-rank sum, bit for bit. Both
 * sharers hold the sum, so G2P needs no second exchange.
 *
 * Rigid bodies (CPIC). A node's colour and distance depend on the node and
 * the bodies' triangles alone, visited in an order fixed by the grid's
 * extent: with the ranks' common extent each rank colours its blocks as one
 * rank does. The material's impulses on the bodies are kept per owner
 * block; every rank receives every rank's and sums them in owner order, so
 * each holds the one-rank impulse and steps its own copy of the rigid
 * solver to the same state.
 *
 * Contact between objects (contact.h). An owner's field slots (momentum,
 * mass, volume and its gradient per field) ride in its halo record and are
 * added in its colour turn like its cache. Which fields reach a node comes
 * first, in two exchanges with the same ranks (kf_dist_owner_exchange): the
 * boundary owners' fields and boxes, then the candidates' claims per node.
 * The pieces a thin body cuts are labelled on each rank over its own
 * particles; only the classes near another rank's owners travel, to that
 * rank, and a small table of the parts that span ranks or are large
 * enough to matter reaches every rank (pieces.c, contact_pieces.c).
 *
 * Memory. No rank holds the whole state: each seeds only its own range,
 * and a resume reads only its own part of the checkpoint (seed.c),
 * migration rebuilds the part in place, and a frame's files reach rank 0
 * a window of particles at a time (stream.c), only when the frame has a
 * file to write.
 *
 * Everything else that couples particles is a global reduction of an exact
 * operation (max, min, or), so the substep, the retries and the trouble
 * report agree on every rank. Nothing here runs on one rank: a state
 * without dist is the single-rank step, untouched. */
#ifndef KF_DIST_H
#define KF_DIST_H

#include <stddef.h>
#include <stdint.h>

#include <kerf/kerf.h>

#include "../core/simd.h"

struct kf_dist;

/* What the frame log shows, since the last kf_dist_stats_reset. */
typedef struct kf_dist_stats {
    size_t particles_min, particles_max; /* per rank, at the last substep */
    double halo_bytes;                   /* P2G cache bytes sent by all ranks, summed over substeps */
    double pieces_bytes;                 /* the pieces' labelling: bytes sent by all ranks (pieces.c) */
    double pieces_classes;               /* the particle classes it labelled, over all ranks */
    long pieces_splits;                  /* substeps in which a part became a piece */
    double migrated;                     /* particles that changed rank */
    long substeps;
    double comm_ms; /* this rank's wall time in communication */
    int rebalances;
} kf_dist_stats;

/* MPI start, only when a launcher (mpirun, srun) started this process;
 * returns the rank count (1 without one). */
int kf_dist_init(int *argc, char ***argv);
void kf_dist_finalize(void);
int kf_dist_size(void);
int kf_dist_rank(void);
/* rank 0's v on every rank (v itself without MPI) */
int kf_dist_bcast_int(int v);
/* every rank stops now, with this exit code (a rank's fatal error) */
void kf_dist_abort(int code);

/* The feature of this model the distributed step does not cover, or NULL;
 * the _def form answers from the settings and the rigid body count alone,
 * so a farm can refuse a shot before it queues a job. */
const char *kf_dist_unsupported(const kf_model *m);
const char *kf_dist_unsupported_def(const kf_sim_def *sim, int nrigid);

void kf_dist_free(struct kf_dist *d);

/* Seeding only this rank's part (the scene build). Every rank samples every
 * object twice alike: _count over every sampled point (x3: n points), _cut,
 * then _owns says which points are this rank's; the build adds those, in
 * sampling order, and gives each the id a whole build would. _adopt makes
 * the state this rank's part (s->dist set, the whole build's next id) and
 * frees sd. _count and _cut return 0 or -1 (out of memory). */
typedef struct kf_dist_seed kf_dist_seed;
kf_dist_seed *kf_dist_seed_new(const kf_model *m);
int kf_dist_seed_count(kf_dist_seed *sd, const double *x3, size_t n);
int kf_dist_seed_cut(kf_dist_seed *sd);
int kf_dist_seed_owns(const kf_dist_seed *sd, const double x[3]);
void kf_dist_seed_adopt(kf_dist_seed *sd, kf_state *s);
/* The same for the particles of a checkpoint (a resume reads only this
 * rank's part): positions as the state holds them, window by window;
 * _mine, after the cut, how many _owns_real will accept. */
int kf_dist_seed_count_reals(kf_dist_seed *sd, kf_real *const x[3], size_t n);
int kf_dist_seed_owns_real(const kf_dist_seed *sd, const kf_real x[3]);
size_t kf_dist_seed_mine(const kf_dist_seed *sd);
/* _adopt for a checkpoint's part: the state keeps the file's next id */
void kf_dist_seed_adopt_read(kf_dist_seed *sd, kf_state *s);
void kf_dist_seed_free(kf_dist_seed *sd);

/* Rank 0 receives every rank's particles, in the one-rank order, into
 * whole (scalars copied from s); the others send. Collective. by_id: a
 * state not stepped yet, whose one-rank order is the seeding order, the
 * order of the ids (0 to n - 1); else a stepped state, whose ranks' parts
 * end to end are the one-rank order. */
int kf_dist_gather(const kf_state *s, kf_state *whole, int by_id);

/* The same particles, a window at a time, without the whole state on rank
 * 0: put(ctx, win, a) is called on rank 0 for each window, in order, with
 * win holding particles [a, a + its count) of the one-rank array (and s's
 * clock); a put that fails (returns nonzero) ends the calls, not the
 * collective. Returns 0, or on rank 0 -1 when a window was wrong or put
 * failed. */
typedef int (*kf_dist_put)(void *ctx, const kf_state *win, size_t a);
int kf_dist_stream(const kf_state *s, kf_state *win, int by_id, kf_dist_put put, void *ctx);

/* Re-cut the ranges when the busiest rank holds more than `threshold` times
 * the mean; particles move at the next substep. Collective. */
void kf_dist_rebalance(kf_state *s, double threshold);

void kf_dist_stats_get(const kf_state *s, kf_dist_stats *out);
void kf_dist_stats_reset(kf_state *s);
/* sums over ranks, for the frame log (collective) */
long kf_dist_sum_long(const kf_state *s, long v);

/* ---- the step's hooks (step.c, transfer.c) ---- */

/* Before binning: particles whose block now lies in another rank's range go
 * there. Returns 0 or -1 (out of memory). */
int kf_dist_migrate(const kf_model *m, kf_state *s);
/* After binning: caches of this rank's boundary owners to the ranks that
 * share their nodes, and blocks for what arrives. 0 or -1 (out of memory). */
int kf_dist_halo(const kf_model *m, kf_state *s, kf_real dt);
/* Inside kf_p2g's parallel region, after colour c's own owners: the halo
 * caches of colour c added to the nodes. */
void kf_dist_p2g_colour(const kf_model *m, kf_state *s, int c);
/* kf_stress over this rank's particles in the one-rank array's batches of
 * 64: a batch cut by a rank boundary is computed whole, from copies of the
 * neighbours' particles in it (collective). Returns the particles evaluated
 * at the limited stiffness over all ranks (kf_state.stiff_limited). */
long kf_dist_stress(const kf_model *m, kf_state *s, int project);
/* Trouble agreed: returns 1 on every rank if any rank found trouble, and t
 * becomes the report of the lowest particle id among them. */
int kf_dist_agree(const kf_state *s, int found, kf_trouble *t);
/* CPIC across ranks (cdf.c, cpic_transfer.c). The grid's extent over every
 * rank, lo the minimum and hi the maximum per axis: the union of the ranks'
 * blocks is the one-rank grid, so the splat bins its seeds as one rank does
 * and a node's triangles visit it in the one-rank order. */
void kf_dist_extent(const kf_state *s, double lo[3], double hi[3]);
/* The rigid bodies' impulses and the crossing guard's counts of every
 * rank's narrow-band owners, summed in the one-rank owner order (the ranks'
 * owners end to end are the one-rank owners): every rank gets the one-rank
 * totals bit for bit and so steps its copy of the rigid solver alike.
 * imp: nslot rows of `stride` doubles, body r's six at 6r; sum: body r's
 * six at 6r (KF_MAX_RIGIDS rows), zeroed here. Collective. */
void kf_dist_rigid_sum(const kf_state *s, int nrigid, size_t nslot, const double *imp, size_t stride,
                       const long *caught, const double *depth, double *sum, long *caught_sum, double *depth_max);
/* Contact between objects (contact.c). Each owner block whose nodes
 * another rank's owners share sends what put(ctx, owner, dst) writes for
 * it to those ranks: put with dst NULL says how many bytes (at most max;
 * 0: nothing for this owner), then writes them. *in gets what arrived (in
 * sender rank order, each sender's in owner order), each record with its
 * owner's block coordinate and this rank's blocks of the owner's 2x2x2
 * neighbourhood (made where missing); valid until the next call. The bytes
 * count as halo traffic. 0 or -1 (out of memory). Collective. */
typedef struct kf_dist_owner_msg {
    int32_t bc[3];
    int32_t nb[8];
    size_t bytes;
    const void *data;
} kf_dist_owner_msg;
typedef size_t (*kf_dist_owner_put)(void *ctx, size_t owner, void *dst);
int kf_dist_owner_exchange(const kf_model *m, kf_state *s, kf_dist_owner_put put, size_t max, void *ctx,
                           kf_dist_owner_msg **in, size_t *nin);
/* The pieces a thin body cuts (contact_pieces.c). _node_exchange: n
 * records of `size` bytes, each starting with a node's coordinate
 * (int32_t[3]), about nodes particles are nearest to (4o to 4o + 7 along
 * each axis, o the coordinate of their owner block); each goes to every
 * other rank holding a record at its node or the next along an axis;
 * *in (malloc'd) gets what arrived, *nin records. _gather: as
 * kf_dist_allgather. Both count their bytes as the pieces' traffic
 * (nclass: the classes labelled here, for the log). 0 or -1. Collective. */
int kf_dist_node_exchange(const kf_model *m, kf_state *s, const void *rec, size_t n, size_t size, void **in,
                          size_t *nin);
int kf_dist_pieces_gather(kf_state *s, const void *mine, size_t bytes, size_t nclass, void **all, size_t *all_bytes);
/* a substep in which a part became a piece (every rank alike), for the log */
void kf_dist_pieces_split(kf_state *s);
/* Every rank's bytes, in rank order, to every rank: *all (malloc'd, the
 * caller frees it) and their sum. 0 or -1. Collective. */
int kf_dist_allgather(const kf_state *s, const void *mine, size_t bytes, void **all, size_t *all_bytes);
/* the index in the one-rank particle array of this rank's first particle
 * (the ranks' parts end to end are the one-rank array). Collective. */
size_t kf_dist_first_index(const kf_state *s);
/* the global max of v, and the element-wise min of n values */
double kf_dist_max(const kf_state *s, double v);
void kf_dist_min_reals(const kf_state *s, kf_real *v, int n);

#endif
