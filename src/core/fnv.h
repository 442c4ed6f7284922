/* fnv.h — the one FNV-1a hash of kerf: checkpoint checksums, the state hash
 * the determinism tests compare, and the inputs hash that decides whether
 * cached frames are current.
 *
 * h ← (h ⊕ byte) · 1099511628211 per byte, from KF_FNV_BASIS. The basis is
 * kerf's own (the published 64-bit basis is 14695981039346656037): every
 * checkpoint's checksum and every recorded state hash is made from it, so it
 * stays. */
#ifndef KF_CORE_FNV_H
#define KF_CORE_FNV_H

#include <stddef.h>
#include <stdint.h>

#define KF_FNV_BASIS 1469598103934665603ULL
#define KF_FNV_PRIME 1099511628211ULL

/* h continued over n bytes at p */
static inline uint64_t kf_fnv1a(uint64_t h, const void *p, size_t n) {
    const unsigned char *b = (const unsigned char *)p;
    for (size_t i = 0; i < n; i++) h = (h ^ b[i]) * KF_FNV_PRIME;
    return h;
}

/* h continued over a C string's bytes (not its terminator) */
static inline uint64_t kf_fnv1a_str(uint64_t h, const char *s) {
    for (; *s; s++) h = (h ^ (unsigned char)*s) * KF_FNV_PRIME;
    return h;
}

#endif
