/* expm.h — the exponential of a 3x3 matrix (expm.c).
 *
 * The deformation update F ← (I + Δt L) F is the first-order step of
 * dF/dt = L F. Where Δt |L| is small it is exact enough, and cheap; where a
 * body drives material a cell per substep, Δt |L| reaches 1 and the linear
 * step can turn F inside out (det F <= 0: compressing by 100% in one
 * substep). exp(Δt L) is the exact step for constant L over the substep and
 * has det = exp(Δt tr L) > 0 always, so the transfers use it beyond a small
 * Δt |L| (transfer.c). */
#ifndef KF_EXPM_H
#define KF_EXPM_H

/* E = exp(A), row-major, by scaling and squaring a degree-6 Taylor series
 * (relative error near double round-off for |A| up to ~50). */
void kf_expm3(const double A[9], double E[9]);

#endif
