/* expm.c — exp of a 3x3 matrix by scaling and squaring (expm.h). */
#include "expm.h"

#include <math.h>
#include <string.h>

static void mul(const double A[9], const double B[9], double C[9]) {
    for (int r = 0; r < 3; r++)
        for (int c = 0; c < 3; c++) C[3 * r + c] = A[3 * r] * B[c] + A[3 * r + 1] * B[3 + c] + A[3 * r + 2] * B[6 + c];
}

void kf_expm3(const double A[9], double E[9]) {
    /* scale A by 2^-s so its norm is below 1/4: the Taylor terms then fall
     * faster than 4^-k, and degree 6 reaches double round-off */
    double norm = 0;
    for (int k = 0; k < 9; k++) norm += A[k] * A[k];
    norm = sqrt(norm);
    int s = 0;
    if (norm > 0.25) s = (int)ceil(log2(norm / 0.25));
    if (s > 60) s = 60;
    const double scale = ldexp(1.0, -s);
    double X[9], term[9], next[9];
    for (int k = 0; k < 9; k++) X[k] = A[k] * scale;
    /* E = I + X + X²/2! + ... + X⁶/6! */
    for (int k = 0; k < 9; k++) E[k] = (k % 4 == 0) + X[k], term[k] = X[k];
    for (int d = 2; d <= 6; d++) {
        mul(term, X, next);
        for (int k = 0; k < 9; k++) term[k] = next[k] / d, E[k] += term[k];
    }
    /* square back: exp(A) = exp(A / 2^s)^(2^s) */
    for (int i = 0; i < s; i++) {
        mul(E, E, next);
        memcpy(E, next, sizeof next);
    }
}
