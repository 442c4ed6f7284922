/* simd.h — a 4-lane vector of kf_real for grid nodes, and per-thread FPU setup.
 *
 * A grid node is one kf_v4: (momentum or velocity xyz, mass). GCC/Clang vector
 * extensions compile it to one SSE/AVX register (or plain scalar code on
 * targets without SIMD), which keeps the transfer loops portable. */
#ifndef KF_SIMD_H
#define KF_SIMD_H

#include "real.h"

typedef kf_real kf_v4 __attribute__((vector_size(4 * sizeof(kf_real))));

static inline kf_v4 kf_v4_splat(kf_real a) { return (kf_v4){a, a, a, a}; }

#if defined(__x86_64__) || defined(__i386__)
#include <xmmintrin.h>
/* Flush denormals to zero in the calling thread: low-mass surface nodes and
 * decaying velocities otherwise produce subnormals that cost 100x per op.
 * MXCSR is per thread, so every parallel region calls this. */
static inline void kf_ftz(void) { _mm_setcsr(_mm_getcsr() | 0x8040); }
#else
static inline void kf_ftz(void) {}
#endif

#endif
