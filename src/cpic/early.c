/* early.c — the next substep's CPIC P2G made in the fused sweep.
 *
 * The fused sweep (transfer.c: kf_g2p2g) makes the next substep's P2G
 * owner by owner right after the owner's G2P. In the band that P2G reads
 * the next substep's colored distance field, band and read boxes, the
 * particles' colours as G2P and the guard left them, and writes the
 * particles' colours, distances and normals and impulse rows on the bodies.
 *
 * Where every body is static and this substep's CDF was copied whole from
 * the static store (cdf.c), the next splat over the same blocks (the early
 * scatter is used only when binning keeps every particle in place) copies
 * the same distances and colours, marks the same band owners in the same
 * slots and gives every owner the same (empty) read box: what the P2G reads
 * of the grid now is what it would read then. What differs is kept apart:
 * the impulse rows (the next substep zeroes its rows at its splat, then its
 * P2G adds into them: here the same adds into rows of their own, zeroed
 * now, which become the substep's after its splat) and gΔt (the next Δt's).
 * The colours a band particle's P2G writes are its own and are read by its
 * owner's G2P and guard alone, which this sweep has run: the next substep's
 * splat only lapses the colours of particles outside the band. The
 * particles' distances and normals are only read by the next substep's G2P.
 *
 * With a body that moves (or a static one not copied from the store) the
 * next CDF is not known before its splat, except in one case: no owner in
 * the band now, so every owner's P2G is the ordinary one, which reads
 * nothing of the CDF, the bodies or the particles' colours (a blade above
 * the material, a body that left it). The sweep then scatters the next P2G
 * as it would without bodies, and the next substep takes it only if its
 * own splat leaves the band empty too (then its P2G would be the ordinary
 * one for every owner as well, bit for bit); else it runs its P2G as
 * usual, the early scatter unused (no colour was written, nothing to put
 * back). A body that comes within reach costs one unused scatter.
 *
 * The early P2G rewrites colours before the next substep knows whether it
 * will use the scatter (a particle may leave its owner's reach later in the
 * sweep, Δt may come out different, a caller may edit the particles), so
 * the colours it started from are kept per band owner and put back when the
 * scatter is dropped: the separate P2G then starts from them, as without
 * the sweep. */
#include <stdlib.h>
#include <string.h>

#include "cpic.h"

static int grow_to(void **p, size_t elem, size_t n) {
    void *q = realloc(*p, elem * (n ? n : 1));
    if (!q) return -1;
    *p = q;
    return 0;
}

int kf_cpic_early_begin(const kf_model *m, kf_state *s, double next_dt) {
    kf_cpic *c = s->cpic;
    /* the next CDF foreseen (the store's), or no band now (see above) */
    if (!c || !(c->static_cdf || c->nslot == 0) || !(next_dt > 0) || s->dist) return 0;
    struct kf_cpic_early *e = &c->early;
    if (e->pending) kf_cpic_early_undo(s); /* not taken by this substep: not reached here, kept safe */
    e->empty = !c->static_cdf;
    const kf_grid *g = &s->g;
    const size_t nslot = c->nslot;
    if (nslot > e->cap_slot) {
        size_t cap = nslot + nslot / 2 + 16;
        if (grow_to((void **)&e->imp, sizeof e->imp[0], cap) || grow_to((void **)&e->first, sizeof(size_t), cap) ||
            grow_to((void **)&e->done, 1, cap))
            return 0;
        e->cap_slot = cap;
    }
    /* each band owner's particles, in slot order (slots follow owner order) */
    size_t nkeep = 0;
    for (size_t k = 0; k < g->nowner; k++)
        if (c->slot[k] >= 0) {
            e->first[c->slot[k]] = nkeep;
            nkeep += g->pstart[k + 1] - g->pstart[k];
        }
    if (nkeep > e->cap_keep) {
        size_t cap = nkeep + nkeep / 2 + 64;
        if (grow_to((void **)&e->keep, sizeof(uint32_t), cap)) return 0;
        e->cap_keep = cap;
    }
    if (nslot) {
        memset(e->imp, 0, nslot * sizeof e->imp[0]);
        memset(e->done, 0, nslot);
    }
    e->nslot = nslot;
    e->nkeep = nkeep;
    e->epoch = c->epoch;
    e->dt = next_dt;
    /* as the splat pins it for its substep */
    for (int a = 0; a < 3; a++) e->gdt[a] = next_dt * m->sim.gravity[a];
    e->pending = 1;
    return 1;
}

void kf_cpic_early_owner(kf_state *s, size_t owner, kf_cpic_owner *oc) {
    kf_cpic *c = s->cpic;
    struct kf_cpic_early *e = &c->early;
    const int32_t k = c->slot[owner];
    const size_t lo = s->g.pstart[owner], n = s->g.pstart[owner + 1] - lo;
    memcpy(&e->keep[e->first[k]], &s->p.colour[lo], n * sizeof(uint32_t));
    e->done[k] = 1;
    oc->imp = &e->imp[k][0][0];
    oc->gdt = e->gdt;
}

void kf_cpic_early_colours(const kf_state *s, uint32_t *colour) {
    const kf_cpic *c = s->cpic;
    /* none kept where the band was empty (the slots may be a later splat's) */
    if (!c || !c->early.pending || !c->early.nslot) return;
    const struct kf_cpic_early *e = &c->early;
    const kf_grid *g = &s->g;
    for (size_t k = 0; k < g->nowner; k++) {
        const int32_t sl = c->slot[k];
        if (sl < 0 || !e->done[sl]) continue;
        memcpy(&colour[g->pstart[k]], &e->keep[e->first[sl]], (g->pstart[k + 1] - g->pstart[k]) * sizeof(uint32_t));
    }
}

void kf_cpic_early_swap(kf_state *s) {
    kf_cpic *c = s->cpic;
    if (!c || !c->early.pending || !c->early.nslot) return; /* as above */
    struct kf_cpic_early *e = &c->early;
    const kf_grid *g = &s->g;
    uint32_t *colour = s->p.colour;
    for (size_t k = 0; k < g->nowner; k++) {
        const int32_t sl = c->slot[k];
        if (sl < 0 || !e->done[sl]) continue;
        uint32_t *kept = &e->keep[e->first[sl]];
        for (size_t i = g->pstart[k], j = 0; i < g->pstart[k + 1]; i++, j++) {
            const uint32_t t = colour[i];
            colour[i] = kept[j];
            kept[j] = t;
        }
    }
}

void kf_cpic_early_undo(kf_state *s) {
    if (!s->cpic || !s->cpic->early.pending) return;
    kf_cpic_early_colours(s, s->p.colour);
    s->cpic->early.pending = 0;
}

void kf_cpic_early_drop(kf_state *s) {
    if (s->cpic) s->cpic->early.pending = 0;
}

int kf_cpic_early_pending(const kf_state *s, double *dt) {
    if (!s->cpic || !s->cpic->early.pending) return 0;
    *dt = s->cpic->early.dt;
    return 1;
}

int kf_cpic_early_take(kf_state *s) {
    kf_cpic *c = s->cpic;
    if (!c || !c->early.pending) return 0;
    struct kf_cpic_early *e = &c->early;
    /* the splat just made must be the one foreseen: the next epoch, the
     * store's CDF over the same band (it is, with the same blocks), or
     * after an empty band an empty band again */
    const int foreseen = e->empty ? c->nslot == 0 : c->static_cdf && c->nslot == e->nslot;
    if (!foreseen || c->epoch != e->epoch + 1 || c->band_particles != (long)e->nkeep) {
        kf_cpic_early_undo(s);
        return 0;
    }
    if (c->nslot) memcpy(c->imp, e->imp, c->nslot * sizeof c->imp[0]);
    e->pending = 0;
    return 1;
}
