/* svd3.h — sign-fixed 3x3 singular value decomposition and polar rotation.
 *
 * F = U diag(σ) Vᵀ with det U = det V = +1, |σ0| >= |σ1| >= |σ2|, σ0, σ1 >= 0;
 * σ2 carries the sign of det F, so an inverted F (det F < 0) gets a negative
 * σ2 instead of a reflection in U or V. Degenerate F (rank 0, 1, 2) still
 * yields orthonormal U and V. Internals run in double for robustness. */
#ifndef KF_SVD3_H
#define KF_SVD3_H

#include "real.h"

void kf_svd3(const kf_real F[9], kf_real U[9], kf_real sigma[3], kf_real V[9]);

/* Rotation R = U Vᵀ of the sign-fixed SVD (det R = +1 even for inverted F). */
void kf_polar3(const kf_real F[9], kf_real R[9]);

/* The same decomposition in double to round-off (the eigenvalue route; see
 * svd3.c), for the implicit solve's energies and Hessians. */
void kf_svd3d(const double F[9], double U[9], double sigma[3], double V[9]);
/* Symmetric eigen-decomposition A = Q diag(w) Qᵀ (cyclic Jacobi, to round-off). */
void kf_sym_eig3d(const double A[9], double w[3], double Q[9]);

#endif
