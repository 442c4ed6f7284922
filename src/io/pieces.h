/* pieces.h — the pieces a cut leaves, for the surfacer.
 *
 * A thin blade that passed through material leaves each particle near it
 * with a scar: the side of the blade it was on (cpic.h, kf_cpic_scar). Two
 * particles are in one piece when a chain of neighbours (closer than 1.5
 * particle spacings) joins them and no link of the chain joins opposite
 * sides of one blade. Pieces that face each other across a cut (opposite
 * sides of one blade, within the surfacer's reach: closer than that, one
 * level set would join them) are given different classes (a greedy
 * colouring of the pieces by their cuts), so the
 * surfacer can make one level set per class and join them by CSG union: a
 * kerf stays open in the surface however close its two sides lie, while
 * material no blade has parted is surfaced as before (one class). */
#ifndef KF_IO_PIECES_H
#define KF_IO_PIECES_H

#include <stddef.h>
#include <stdint.h>

#define KF_PIECES_MAX_CLASSES 8

/* n particles at x (n x 3, m) with their colour words; h the particle
 * spacing (m); reach (m) the distance within which the surfacer would join
 * two particles (twice the sphere radius and a spacing). Writes class[i]
 * in 0..k-1 and returns k (1 when no particle holds a scar, or no cut
 * separates any), or -1 when out of memory. */
int kf_pieces_classes(size_t n, const float *x, const uint32_t *colour, double h, double reach, uint8_t *cls);

#endif
