/* keys.c — key interpolation of colliders and kinematic bodies (see keys.h). */
#include "keys.h"

#include <math.h>

#include "euler.h"

#define DEG (3.14159265358979323846 / 180.0)

/* channel ch of key i: 0-2 position, 3-5 rotation (degrees), 6-8 scale */
static double key_value(const kf_key *k, int ch) {
    if (ch < 3) return k->position[ch];
    if (ch < 6) return k->rotate[ch - 3];
    return k->scale[ch - 6] != 0 ? k->scale[ch - 6] : 1.0;
}

/* Hermite tangent at key i (units per second): central difference over
 * the neighbouring keys, zero at the ends */
static double tangent(const kf_key *k, int n, int i, int ch) {
    if (i <= 0 || i >= n - 1) return 0;
    return (key_value(&k[i + 1], ch) - key_value(&k[i - 1], ch)) / (k[i + 1].time - k[i - 1].time);
}

void kf_keys_pose_at(const kf_key *keys, int n, kf_interp interp, const double center[3], const double velocity[3],
                     double t, kf_key_pose *pose) {
    double val[9], rate[9];
    const kf_key *k = keys;
    if (n <= 0) {
        for (int a = 0; a < 3; a++) {
            val[a] = center[a] + velocity[a] * t, rate[a] = velocity[a];
            val[3 + a] = 0, rate[3 + a] = 0;
            val[6 + a] = 1, rate[6 + a] = 0;
        }
    } else if (n == 1 || t <= k[0].time || t >= k[n - 1].time) {
        /* held before the first key and after the last */
        const kf_key *e = (n == 1 || t <= k[0].time) ? &k[0] : &k[n - 1];
        for (int ch = 0; ch < 9; ch++) val[ch] = key_value(e, ch), rate[ch] = 0;
    } else {
        int i = 0;
        while (i + 2 < n && t >= k[i + 1].time) i++;
        const double h = k[i + 1].time - k[i].time, u = (t - k[i].time) / h;
        for (int ch = 0; ch < 9; ch++) {
            double p0 = key_value(&k[i], ch), p1 = key_value(&k[i + 1], ch);
            if (interp == KF_INTERP_SMOOTH) {
                double m0 = tangent(k, n, i, ch) * h, m1 = tangent(k, n, i + 1, ch) * h;
                double u2 = u * u, u3 = u2 * u;
                val[ch] =
                    (2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * m1;
                rate[ch] = ((6 * u2 - 6 * u) * p0 + (3 * u2 - 4 * u + 1) * m0 + (-6 * u2 + 6 * u) * p1 +
                            (3 * u2 - 2 * u) * m1) /
                           h;
            } else {
                val[ch] = p0 + u * (p1 - p0);
                rate[ch] = (p1 - p0) / h;
            }
        }
    }
    for (int a = 0; a < 3; a++) {
        pose->p[a] = val[a], pose->dp[a] = rate[a];
        pose->deg[a] = val[3 + a];
        pose->s[a] = val[6 + a], pose->ds[a] = rate[6 + a];
        /* smooth keys may overshoot: a scale key near 0 between larger ones
         * could swing through 0, which would mirror the shape */
        if (!(pose->s[a] >= 1e-6)) pose->s[a] = 1e-6, pose->ds[a] = 0;
    }
    kf_euler_matrix(pose->deg, pose->R);
    /* ω = a' Rz Ry e_x + b' Rz e_y + c' e_z (rates in rad/s) */
    double ad = rate[3] * DEG, bd = rate[4] * DEG, cd = rate[5] * DEG;
    double cb = cos(val[4] * DEG), sb = sin(val[4] * DEG), cg = cos(val[5] * DEG), sg = sin(val[5] * DEG);
    pose->omega[0] = ad * cg * cb - bd * sg;
    pose->omega[1] = ad * sg * cb + bd * cg;
    pose->omega[2] = -ad * sb + cd;
}
