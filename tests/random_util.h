/* random_util.h — deterministic random numbers and rotations for the tests.
 *
 * A test file may define KT_RNG_SEED before including this to choose its
 * own sequence; the sequence is fixed, so a failure always reproduces. */
#ifndef KT_RANDOM_UTIL_H
#define KT_RANDOM_UTIL_H

#include <math.h>
#include <stdint.h>

#ifndef KT_RNG_SEED
#define KT_RNG_SEED 0x9E3779B97F4A7C15ull
#endif

static uint64_t rng_state = KT_RNG_SEED;

/* xorshift64: uniform in [0, 1) */
static inline double urand(void) {
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return (double)(rng_state >> 11) * (1.0 / 9007199254740992.0);
}

/* uniform in [-1, 1) */
static inline double srand1(void) { return 2 * urand() - 1; }

/* a random rotation from a normalised quaternion (row-major) */
static inline void random_rotation(double Q[9]) {
    double q[4], n = 0;
    for (int i = 0; i < 4; i++) {
        q[i] = srand1();
        n += q[i] * q[i];
    }
    n = sqrt(n);
    double w = q[0] / n, x = q[1] / n, y = q[2] / n, z = q[3] / n;
    Q[0] = 1 - 2 * (y * y + z * z), Q[1] = 2 * (x * y - w * z), Q[2] = 2 * (x * z + w * y);
    Q[3] = 2 * (x * y + w * z), Q[4] = 1 - 2 * (x * x + z * z), Q[5] = 2 * (y * z - w * x);
    Q[6] = 2 * (x * z - w * y), Q[7] = 2 * (y * z + w * x), Q[8] = 1 - 2 * (x * x + y * y);
}

#endif
