/* vmath.h — exp and sin in double, branch-free, for loops GCC vectorises.
 *
 * The stress batch (mpm/material_batch.c) needs e^x and sin x per particle
 * where a float result is formed from a double one: snow's hardening
 * e^{ξ(1 − Jp)}, sand's hardened friction sin φ(q). A scalar libm call per
 * lane costs more than the lane's SVD. These run across the lanes instead,
 * and the caller keeps the library's float bits exactly: a lane whose
 * double result lies so near a float rounding boundary that the library's
 * own double could round to the other float (kf_vm_float_safe) takes the
 * library's path instead. Rare: the bounds below are a few hundred double
 * ulps against the 2^29 double ulps of a float ulp.
 *
 * Accuracy (u = 2^-53, relative to the exact value):
 *   kf_vm_exp, |x| ≤ KF_VM_EXP_MAX: Cody–Waite reduction x = k ln2 + r,
 *     |r| ≤ 0.35 (x − k ln2_hi exact, k ln2_lo rounded: ≤ 0.5u |r|),
 *     Taylor to r¹³ (truncation 0.35¹⁴/14! / e^-0.35 < 0.07u), Horner with
 *     coefficients ≤ 1 on |r| ≤ 0.35 (≤ 2u), exact scaling by 2^k: ≤ 3u.
 *     Measured against glibc's exp (≤ 0.51 ulp itself): ≤ 2 ulp
 *     (tests/test_material_batch.c).
 *   kf_vm_sin, 0 ≤ x ≤ π/2: Taylor to x²¹ (truncation (π/2)²³/23! ≈ 1.3e-18 < 0.02u),
 *     Horner in x² (≤ 2 · 11 u times Σ|terms| = sinh x ≤ 1.47 x): error
 *     ≤ 40u · x absolute, i.e. ≤ 63u relative to sin x ≥ 2x/π. Measured:
 *     ≤ 2 ulp. */
#ifndef KF_VMATH_H
#define KF_VMATH_H

#include <stdint.h>
#include <string.h>

/* beyond it the caller takes the library's path (2^k stays a normal double) */
#define KF_VM_EXP_MAX 700.0

static inline uint64_t kf_vm_bits(double x) {
    uint64_t b;
    memcpy(&b, &x, sizeof b);
    return b;
}

static inline double kf_vm_double(uint64_t b) {
    double x;
    memcpy(&x, &b, sizeof x);
    return x;
}

/* e^x for |x| ≤ KF_VM_EXP_MAX (outside: a finite wrong value, never NaN
 * traps; the caller must not use it). k = round(x / ln 2) by the 1.5·2^52
 * shift, whose low mantissa bits are then k: 2^k is built from them with
 * integer adds and shifts (vectorise on AVX2, unlike a conversion to
 * int64). */
static inline double kf_vm_exp(double x) {
    const double shift = 0x1.8p52, ln2_hi = 6.93147180369123816490e-01, ln2_lo = 1.90821492927058770002e-10;
    double xc = x > KF_VM_EXP_MAX ? KF_VM_EXP_MAX : x < -KF_VM_EXP_MAX ? -KF_VM_EXP_MAX : x;
    double t = xc * 1.44269504088896338700e+00 + shift, k = t - shift;
    /* ln2_hi has 32 trailing zero bits: k ln2_hi and x − k ln2_hi are exact */
    double r = (xc - k * ln2_hi) - k * ln2_lo;
    double p = 1.0 / 6227020800.0;
    p = p * r + 1.0 / 479001600.0;
    p = p * r + 1.0 / 39916800.0;
    p = p * r + 1.0 / 3628800.0;
    p = p * r + 1.0 / 362880.0;
    p = p * r + 1.0 / 40320.0;
    p = p * r + 1.0 / 5040.0;
    p = p * r + 1.0 / 720.0;
    p = p * r + 1.0 / 120.0;
    p = p * r + 1.0 / 24.0;
    p = p * r + 1.0 / 6.0;
    p = p * r + 0.5;
    p = p * r + 1.0;
    p = p * r + 1.0;
    /* t's bits minus the shift's are k (two's complement, |k| < 2^51) */
    uint64_t kb = kf_vm_bits(t) - kf_vm_bits(shift);
    return p * kf_vm_double((kb + 1023) << 52);
}

/* sin x for 0 ≤ x ≤ π/2 */
static inline double kf_vm_sin(double x) {
    double x2 = x * x;
    double p = -1.0 / 51090942171709440000.0;
    p = p * x2 + 1.0 / 121645100408832000.0;
    p = p * x2 - 1.0 / 355687428096000.0;
    p = p * x2 + 1.0 / 1307674368000.0;
    p = p * x2 - 1.0 / 6227020800.0;
    p = p * x2 + 1.0 / 39916800.0;
    p = p * x2 - 1.0 / 362880.0;
    p = p * x2 + 1.0 / 5040.0;
    p = p * x2 - 1.0 / 120.0;
    p = p * x2 + 1.0 / 6.0;
    return x - x * x2 * p;
}

/* 1 when every double within e of y (e ≥ 0) rounds to the float y rounds
 * to, and that float is normal: then a double y' with |y' − y| ≤ e gives
 * the same float as y. Rounding is monotone, so the two ends decide; the
 * ends' own roundings are covered by e's slack at the call sites. NaN: 0. */
static inline int kf_vm_float_safe(double y, double e) {
    float lo = (float)(y - e), hi = (float)(y + e);
    double a = y < 0 ? -y : y;
    return (lo == hi) & (a >= 0x1p-126) & (a <= 0x1p127);
}

#endif
