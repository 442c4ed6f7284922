/* cpic_seam.h — what the explicit step asks of CPIC (src/cpic), and nothing
 * more: the seam between the MPM core and the rigid coupling.
 *
 * The step (step.c) and the transfers (transfer.c) call these; src/cpic
 * implements them against the model and state it reads through mpm/model.h.
 * So the dependency runs one way, cpic → mpm: this header names the state
 * only by its public type and the transfer's chunk by a forward declaration.
 *
 * Order within a substep with rigid bodies: kf_cpic_splat after the bin; per
 * owner block in the band (kf_cpic_band), kf_cpic_owner_cdf, then the
 * chunk transfers; after G2P's advection kf_cpic_penalty and kf_cpic_guard;
 * kf_cpic_finish after the stress pass. */
#ifndef KF_MPM_CPIC_SEAM_H
#define KF_MPM_CPIC_SEAM_H

#include <stddef.h>
#include <stdint.h>

#include <kerf/kerf.h>
#include "../core/real.h"

#define KF_CPIC_NB 8 /* the owner's node cache edge: its 2x2x2 block neighbourhood (grid.h: KF_CACHE_EDGE) */

struct kf_cpic;
struct chunk;

/* The CDF of one owner's 2x2x2 block neighbourhood, laid out like the
 * transfer's node cache; made once per owner block and read by each chunk. */
typedef struct kf_cpic_owner {
    uint32_t col[KF_CPIC_NB * KF_CPIC_NB * KF_CPIC_NB];
    float dist[KF_CPIC_NB * KF_CPIC_NB * KF_CPIC_NB];
    /* per base node (a particle's first stencil node), the affinity bits of
     * its 3x3x3 stencil's colours together: 0 where no node of it is near
     * a body, and the particle's transfers are the ordinary ones */
    uint32_t aff[KF_CPIC_NB * KF_CPIC_NB * KF_CPIC_NB];
    /* where the owner's P2G adds its impulses on the bodies, and the gΔt it
     * uses: this substep's, or (kf_cpic_early_owner) the next one's */
    double *imp;
    const double *gdt;
} kf_cpic_owner;

void kf_cpic_free(struct kf_cpic *c);

/* Build the grid CDF for the current bin (after kf_grid_bin). Returns 0 or -1
 * (out of memory). */
int kf_cpic_splat(const kf_model *m, kf_state *s, double dt);

/* Is this owner block in the narrow band (valid between splat and finish)? */
int kf_cpic_band(const kf_state *s, size_t owner);
/* The particles of the owner blocks in the band this substep (0 without
 * CPIC): those whose transfers take CPIC's paths (the step's statistics) */
long kf_cpic_band_particles(const kf_state *s);

/* CPIC transfers of one owner block in the band (cpic_transfer.c). The
 * chunk's stencil, q, mv (and t for classic) are computed by the caller as
 * in the ordinary path, and for the gather the chunk's stress (ck->tau);
 * these replace the scatter and the gather. */
void kf_cpic_owner_cdf(const kf_state *s, size_t owner, kf_cpic_owner *oc);
void kf_cpic_p2g_chunk(const kf_model *m, kf_state *s, size_t owner, const kf_cpic_owner *oc, struct chunk *ck,
                       size_t i0, void *cache, int classic);
void kf_cpic_g2p_chunk(const kf_model *m, kf_state *s, size_t owner, const kf_cpic_owner *oc, struct chunk *ck,
                       size_t i0, const void *cache, int classic);
/* after G2P's advection: the penalty on slightly penetrated particles (Eq. 22) */
void kf_cpic_penalty(const kf_model *m, kf_state *s, size_t owner, size_t i0, int n);

/* The crossing guard (guard.c): after a chunk's advection, every particle
 * whose path relative to a body passed through it put back on its own side.
 * xold: the chunk's positions before advection, [3][KF_CHUNK] flat. */
void kf_cpic_guard(const kf_model *m, kf_state *s, size_t owner, const kf_cpic_owner *oc, const struct chunk *ck,
                   size_t i0, const kf_real *xold);

/* The next substep's P2G made early by the fused sweep (early.c), where
 * its CDF is known before the sweep: every body static and this
 * substep's CDF copied from the static store, so the next splat over the
 * same blocks gives it again; or no owner in the band now (every owner's
 * P2G the ordinary one), taken only if the next band is empty too. kf_cpic_early_begin, before the sweep: 1 if
 * the sweep may scatter at next_dt (the impulse rows zeroed). Per band
 * owner, kf_cpic_early_owner after its G2P: keeps its particles' colours
 * and points oc at the next substep's impulse rows and gΔt. The next
 * substep, after its splat, kf_cpic_early_take: the early impulses become
 * the substep's (1), or, when the CDF is not the one foreseen, the colours
 * go back (0: run P2G). kf_cpic_early_undo puts the kept colours back
 * (the scatter is not used; particles where the sweep left them);
 * kf_cpic_early_drop forgets them (the particles were restored);
 * kf_cpic_early_colours writes them into a copy's colours (NULL: none
 * held). kf_cpic_early_pending: colours of an early P2G are held, made
 * at *dt. */
int kf_cpic_early_begin(const kf_model *m, kf_state *s, double next_dt);
void kf_cpic_early_owner(kf_state *s, size_t owner, kf_cpic_owner *oc);
int kf_cpic_early_take(kf_state *s);
void kf_cpic_early_undo(kf_state *s);
void kf_cpic_early_drop(kf_state *s);
void kf_cpic_early_colours(const kf_state *s, uint32_t *colour);
/* the kept colours and the particles' trade places (twice: as they were) */
void kf_cpic_early_swap(kf_state *s);
int kf_cpic_early_pending(const kf_state *s, double *dt);

/* Sum the impulses and advance the rigid bodies to t + dt. */
void kf_cpic_finish(const kf_model *m, kf_state *s, double dt);

/* After kf_cpic_finish (guard.c): where a body did not end at the pose the
 * guard placed the particles against (a dynamic body's is predicted), each
 * particle with affinity to it followed from the one to the other, and put
 * back on its side if that last leg crossed the surface. */
void kf_cpic_guard_settle(const kf_model *m, kf_state *s);

/* The crossing guard's totals of the substep kf_cpic_finish closed:
 * particles put back, and the deepest crossing (m). */
void kf_cpic_caught(const kf_state *s, long *caught, double *depth);

#endif
