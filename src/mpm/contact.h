/* contact.h — contact between objects: one velocity field per object where
 * objects share grid nodes (multi-velocity-field MPM, after Bardenhagen et
 * al. 2000), touching only where their surfaces meet. Private to the library.
 *
 * Why: with one velocity per node, two objects move together as soon as
 * their kernels overlap, about a cell and a half before their surfaces meet
 * (two jelly spheres bounced 13.6 mm apart at 10 mm cells), and pieces that
 * come close stay glued by the nodes between them.
 *
 * The design, and what it costs:
 * - A field is a shot object (kf_particles.obj). Each node keeps two field
 *   slots beside its ordinary total: the first field to reach it and the
 *   second (a third one at the same node joins the second: three objects
 *   meeting within a cell and a half are rare, and the price is that two of
 *   them move together there). A slot holds momentum and mass, and the
 *   volume and its gradient for the contact test. Two slots, not one per
 *   object: memory stays 64 bytes a node whatever the number of objects.
 * - Only where fields meet: each substep, every owner block notes its field
 *   and the box of nodes its particles' stencils cover; owners of different
 *   fields whose boxes overlap are candidates, and their particles mark the
 *   fields at their stencils' nodes. Owners that scatter into a block with a
 *   node of two fields take the field path (an extra scatter and gather at
 *   those nodes only). Everywhere else the transfers are the ordinary ones,
 *   and a shot with one object (and no cut) never gets here: bitwise the
 *   results of no contact.
 * - The slots' momenta are the very contributions of the total (the same
 *   MLS momentum and stress force), so the total stays what it is without
 *   contact: gravity, walls and colliders act on it as before, and on each
 *   slot's velocity the same way.
 * - Where surfaces are: a slot's volume over the node's cell volume is the
 *   fraction of the kernel the field fills; for a surface that is flat on
 *   the kernel's scale that fraction names the signed distance from the node
 *   to the surface (the inverse of the B-spline's integral), so the gap
 *   between two fields at a node is the sum of their two distances. The
 *   fields are in contact where the gap has closed (<= 0): surfaces meet
 *   within a fraction of a cell, not where the kernels first overlap
 *   (Bardenhagen's test "both fields have mass here" fires 1-1.5 cells early).
 * - The normal is that of the volume gradients, n = (∇V₁ − ∇V₀)/|...|: from
 *   field 0 toward field 1, the average of the two surfaces' normals.
 * - The rule (Eq. 25's "separate" boundary, applied to the relative
 *   velocity): fields in contact that approach lose their approach and
 *   their sliding by up to μ times it; fields that separate are free. The
 *   change is shared by the two fields in proportion to the other's mass,
 *   so the node's momentum is unchanged.
 * - CPIC: a particle scatters to, and gathers from, the same compatible
 *   nodes as without contact (a thin body still cuts every field).
 * - Under implicit integration contact is not applied (its solve works on
 *   the one field). */
#ifndef KF_CONTACT_H
#define KF_CONTACT_H

#include <stddef.h>
#include <stdint.h>

#include "model.h"

#define KF_FIELD_NONE 0xFFFFu
#define KF_FIELD_MANY 0xFFFEu

typedef struct kf_contact {
    int active;     /* this substep takes the field path somewhere */
    size_t nblocks; /* the grid's blocks when prepared */
    /* per grid block (cap_blocks), per node 2 slots */
    size_t cap_blocks;
    kf_v4 *mv;             /* (cap_blocks x 64 x 2) momentum xyz, mass; after kf_contact_grid: velocity xyz, mass */
    kf_v4 *vol;            /* (cap_blocks x 64 x 2) volume gradient xyz (m²), volume (m³) */
    uint16_t *fid;         /* (cap_blocks x 64 x 2) the slot's field, KF_FIELD_NONE = empty */
    uint8_t *blk;          /* (cap_blocks) 1 = a node of the block has two fields: slots valid */
    uint8_t *ncontrib;     /* (cap_blocks) owners that scatter into the block */
    int32_t (*contrib)[8]; /* (cap_blocks) their indices */
    /* per owner block (cap_owner) */
    size_t cap_owner;
    uint8_t *own;       /* 1 = the owner's particles take the field path */
    uint16_t *ofield;   /* the owner's field, KF_FIELD_MANY for two or more */
    int32_t (*obox)[6]; /* the nodes its particles' stencils cover: lo xyz, hi xyz (inclusive) */
    /* the last substep, for the frame log and tests */
    long owners, two_field_nodes, touching_nodes;
    /* pieces (contact_pieces.c): scratch, and how many substeps split a field */
    uint32_t *pc_node, *pc_parent, *pc_list, *pc_start, *pc_nrep, *pc_keep, *pc_used, *pc_cls, *pc_rep, *pc_cnt;
    size_t pc_node_cap, pc_parent_cap, pc_list_cap, pc_start_cap, pc_nrep_cap, pc_cls_cap, pc_rep_cap, pc_cnt_cap;
    uint64_t *pc_occ, *pc_seen; /* per block: the nodes particles are nearest to, and those reached */
    int32_t (*pc_next)[6];      /* per block: its face neighbours -x +x -y +y -z +z (-1: none) */
    size_t pc_occ_cap;
    long pieces_made;
} kf_contact;

/* A particle's field: its object (low 12 bits of kf_particles.obj) and the
 * piece of it a thin body cut off (the 4 bits above, contact_pieces.c). */
static inline uint16_t kf_contact_field(const kf_particles *p, size_t i) { return p->obj[i]; }

/* Does a thin body cut this material into pieces (solids: elastic, von
 * Mises, snow), or does it flow together again (sand, water)? */
static inline int kf_contact_cuts(const kf_mat *mat) { return mat->model != KF_MAT_WATER && mat->model != KF_MAT_SAND; }

/* Split fields that a thin body has cut apart into pieces (each substep
 * when the model has a thin body). Returns 0 or -1 (out of memory). */
int kf_contact_pieces(const kf_model *m, kf_state *s);

void kf_contact_free(kf_contact *c);

/* After binning: which owners take the field path; clears their slots.
 * Returns 0 or -1 (out of memory). Nothing is done unless m->sim.contact. */
int kf_contact_prepare(const kf_model *m, kf_state *s);

/* Does owner block r take the field path this substep? */
static inline int kf_contact_owner(const kf_state *s, size_t r) {
    return s->contact && s->contact->active && s->contact->own[r];
}

/* After kf_grid_update: each slot's velocity (gravity, the contact rule,
 * walls and colliders). */
void kf_contact_grid(const kf_model *m, kf_state *s, kf_real dt);

/* The field scatter of one chunk of an owner on the field path, after its
 * ordinary (or CPIC) scatter, into the owner's field cache; and the
 * gather's correction to its own field's velocities, after the ordinary (or
 * CPIC) gather. col is the owner's CPIC colour cache (kf_cpic_owner.col) in
 * the band, else NULL. The field cache has KF_CONTACT_CACHE_ROWS rows per
 * node of the owner's neighbourhood (the node cache's order): the momentum
 * and mass of slot 0 and 1, then the volume rows of slot 0 and 1. Like the
 * node cache it is summed per owner and then added to the slots in the
 * owner's colour turn (kf_contact_add_cache), so another rank can add an
 * owner's cache in the same turn and get the same sums. */
#define KF_CONTACT_CACHE_ROWS 4
struct chunk;
void kf_contact_p2g_chunk(const kf_model *m, kf_state *s, size_t owner, const uint32_t *col, const struct chunk *ck,
                          size_t i0, int kw, int classic, kf_v4 *fcache);
/* an owner's field cache (lohi: its particles' base offsets, as
 * kf_p2g_add_cache) added into the slots of the neighbourhood nb, at nodes
 * where two fields meet */
void kf_contact_add_cache(const kf_model *m, kf_state *s, const int32_t nb[8], const kf_v4 *fcache, const int lohi[6]);
void kf_contact_g2p_chunk(const kf_model *m, const kf_state *s, size_t owner, const uint32_t *col, struct chunk *ck,
                          size_t i0, int kw, int classic);

/* Distance from a node to a flat surface, in cells (positive outside), for
 * the fraction fill of the B-spline kernel's weight inside the material
 * (kw = 3 quadratic, 4 cubic). */
double kf_contact_fill_distance(double fill, int kw);

#endif
