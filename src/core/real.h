/* real.h — the floating-point type of the simulation state.
 *
 * kerf runs in single precision by default; configure with -DKERF_DOUBLE=ON to
 * build everything in double precision, so convergence studies are not
 * floored by round-off. Every particle and grid quantity is a kf_real. */
#ifndef KF_REAL_H
#define KF_REAL_H

#include <math.h>

#ifdef KF_DOUBLE
typedef double kf_real;
#define KF_EPS 1e-15
#define KF_R(x) (x)
#define kf_sqrt sqrt
#define kf_fabs fabs
#define kf_log log
#define kf_exp exp
#define kf_pow pow
#define kf_floor floor
#define kf_fma fma
#else
typedef float kf_real;
#define KF_EPS 1e-7f
#define KF_R(x) ((float)(x))
#define kf_sqrt sqrtf
#define kf_fabs fabsf
#define kf_log logf
#define kf_exp expf
#define kf_pow powf
#define kf_floor floorf
#define kf_fma fmaf
#endif

#endif
