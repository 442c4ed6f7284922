/* implicit.h — backward Euler by Newton–Krylov on the grid velocities
 * (paper §3.5, Eq. 19). Private to the library (and its tests).
 *
 * A substep minimises the incremental potential over the velocities v of
 * the grid nodes that carry mass:
 *     E(v) = ½ Σ_i m_i |v_i − v*_i|² + Σ_p V⁰_p Ψ(F_p(v)),
 *     F_p(v) = (I + Δt Σ_i v_i γ_ipᵀ) F_pⁿ,
 * where v*_i = (P2G momentum)/m_i + Δt g (inertia and gravity) and γ_ip is
 * the per-node "gradient" of the force discretisation: w_ip D_p⁻¹ (x_i − x_p)
 * for MLS (no kernel gradients, Eq. 19) or ∇w_ip for classic MPM. F_p(v) is
 * exactly the F that kf_g2p computes from the same grid velocities, so after
 * the solve the explicit G2P and stress pass run unchanged.
 *
 * The midpoint scheme (kf_implicit_scheme) runs the same solve over Δt/2:
 * its v is v_{n+½}, with which kf_g2p moves and deforms the particles over
 * Δt; their velocity then ends at 2 v_{n+½} − v_n (implicit/solve.c).
 *
 * Everything here is double: the solve's symmetry and convergence checks
 * need it even when the particles are float. */
#ifndef KF_IMPLICIT_H
#define KF_IMPLICIT_H

#include "../core/svd3.h" /* kf_svd3d, kf_sym_eig3d: the energies' double SVD */
#include "../mpm/model.h"

/* ---- energies (implicit/energy.c) ------------------------------------------
 * Every elastic model of kerf is isotropic: Ψ(F) = ψ(σ). The stress is
 * P = U diag(∂ψ/∂σ) Vᵀ and the Hessian, in the rotated frame δF̂ = Uᵀ δF V,
 * splits into the 3x3 block ∂²ψ/∂σ² on the diagonal entries and one 2x2
 * block per pair (i, j) acting on (δF̂_ij, δF̂_ji), whose eigenvalues are
 * (ψ_i − ψ_j)/(σ_i − σ_j) (stretch) and (ψ_i + ψ_j)/(σ_i + σ_j) (twist).
 * Projecting to positive semi-definite clamps those eigenvalues at 0.
 * Without the Hessian, Ψ and P of the corotated models (fixed corotated,
 * snow) come from the polar decomposition F = R S instead (a few Newton
 * steps, several times cheaper than the SVD), unless F is inverted; with
 * it, all three come from the SVD the Hessian needs anyway. */
typedef struct kf_imp_energy {
    double psi;   /* Ψ, J/m³ */
    double P[9];  /* first Piola–Kirchhoff stress ∂Ψ/∂F, row-major */
    double H[81]; /* ∂²Ψ/∂F², H[9 (3a + b) + 3c + d] = ∂P_ab / ∂F_cd (symmetric) */
} kf_imp_energy;

/* Ψ, P and (when H is wanted) the Hessian of material m at F with plastic
 * state ps (snow's hardening). project: clamp the Hessian's eigenvalues at
 * zero. Water is not supported (returns -1); 0 otherwise. */
int kf_imp_energy_eval(const kf_mat *m, const double F[9], const kf_real ps[2], int want_hessian, int project,
                       kf_imp_energy *out);
/* The same, except that with Fn given, H is the Hessian in G of
 * Ψ((I + G) Fn) at G = 0, i.e. Tᵀ (∂²Ψ/∂F²) T with T: G ↦ G Fn (what the
 * solve's per-particle blocks need), at the cost of H itself. */
int kf_imp_energy_eval_in(const kf_mat *m, const double F[9], const kf_real ps[2], const double *Fn, int want_hessian,
                          int project, kf_imp_energy *out);
/* Ψ alone (the line search's energy). */
double kf_imp_energy_psi(const kf_mat *m, const double F[9], const kf_real ps[2]);

/* ---- the workspace of one substep ------------------------------------------- */

/* doubles per node in grid vectors: (x, y, z, 0), one 256-bit register */
#define KF_IMP_NV 4
/* γ_ip is a tensor product over the stencil's axes: with per-axis kernel
 * weights w_a and factors h_a (MLS: w_a D⁻¹ (x_ia − x_pa); classic: the
 * weight's derivative), γ_ip = (h_0 w_1 w_2, w_0 h_1 w_2, w_0 w_1 h_2) at
 * stencil node (i0, i1, i2). A particle keeps, per axis a, w_a[0..3] then
 * h_a[0..3]: 24 doubles instead of 81 (quadratic) or 192 (cubic) for γ, and
 * the gather and scatter sum axis by axis. */
#define KF_IMP_WS 24

typedef struct kf_implicit {
    const kf_model *m;
    kf_state *s;
    double dt;
    size_t nnode; /* nodes of the sparse grid: nblocks × 64, flat index block·64 + local */
    size_t np;    /* particles */
    int K;        /* stencil nodes per particle: 27 (quadratic) or 64 (cubic) */
    int32_t *idx; /* (np × K) flat node of each stencil entry */
    double *wts;  /* (np × KF_IMP_WS) γ_ip's tensor factors, see below */
    double *mass; /* (nnode) m_i */
    int32_t *act; /* (nact) the nodes that carry mass, ascending: every solver vector vanishes elsewhere */
    size_t nact;
    size_t *act_start; /* (nblocks + 1) block b's active nodes: act[act_start[b] .. act_start[b + 1]) */
    double *vstar;     /* (4 nnode) v*_i, 0 where m_i = 0 */
    double *Fn;        /* (9 np) F_pⁿ */
    double *F;         /* (9 np) F_p(v) at the last linearisation */
    double *Kp;    /* (81 np) Δt² V⁰ Tᵀ (∂²Ψ/∂F²) T, T: G ↦ G Fⁿ: the per-particle Hessian of E in G */
    double *S;     /* (9 np) Δt V⁰ P Fⁿᵀ: what a particle scatters into the gradient */
    double *S_alt; /* (9 np) scratch for a second S (the solve swaps the two) */
    double *psi;   /* (np) V⁰ Ψ at the last linearisation */
    /* boundary conditions (implicit/boundary.c): constrained nodes, each with
     * the orthogonal projection onto its free directions */
    size_t ncon;
    int32_t *con_node;
    double *con_P;    /* (9 ncon) */
    double *con_mu;   /* (ncon) Coulomb friction coefficient of the node's separate boundary (0 = none) */
    uint8_t *con_sep; /* (ncon) 1: held by a separate boundary (it may let go) */
    uint8_t *release; /* (nnode) or NULL: nodes a separate boundary lets go (their reaction pulled) */
    double *con_n;    /* (3 ncon) the separate boundary's normal */
    double *con_vc;   /* (3 ncon) the boundary's velocity */
    /* solver vectors (KF_IMP_NV nnode each; the 4th entry of a node stays 0) */
    double *v, *g, *d, *r, *z, *p, *q, *vt, *diag;
    double *bsum; /* (nblocks) partial sums, summed in block order (deterministic) */
    /* the multigrid preconditioner's levels (implicit_mg_*.c), built on first use */
    struct kf_imp_mg *mg;
    /* what the last solve did */
    int newton_iterations, krylov_iterations, converged;
    double residual;
} kf_implicit;

/* ---- transfers (implicit/transfer.c) ------------------------------------------- */

/* The stencils of every particle (after kf_grid_bin) and the P2G of mass
 * and momentum without the stress term; fills mass, vstar (with gravity)
 * and Fn. Returns 0 or -1 (out of memory). */
int kf_imp_create(kf_implicit *w, const kf_model *m, kf_state *s, double dt);
void kf_imp_free(kf_implicit *w);
/* G_p = Σ_i x_i γ_ipᵀ of particle p for a grid vector x. */
void kf_imp_gather(const kf_implicit *w, const double *x, size_t p, double G[9]);
/* What kf_g2p takes from the grid vector x at particle p, still at x_pⁿ:
 * the velocity Σ_i w_ip x_i and APIC's affine C = Σ_i w_ip x_i (x_i − x_p)ᵀ
 * D⁻¹ (the MLS form in both force modes, as kf_g2p stores it). */
void kf_imp_g2p_vector(const kf_implicit *w, const double *x, size_t p, double v[3], double C[9]);
/* out_i += Σ_p Y_p γ_ip (race-free in the owner colours, deterministic). */
void kf_imp_scatter(const kf_implicit *w, const double *Y, double *out);
/* out_i += Σ_p (Kp G_p(x)) γ_ip: the particles' part of the Hessian action,
 * each particle's gather, block product and scatter in one pass. */
void kf_imp_scatter_product(const kf_implicit *w, const double *x, double *out);
/* out_ia += Σ_p Σ_bc Kp[(a,b),(a,c)] γ_ipb γ_ipc: the particles' part of the
 * Hessian's diagonal (the Jacobi preconditioner). */
void kf_imp_scatter_diag(const kf_implicit *w, double *out);

/* ---- the potential and its derivatives (implicit/solve.c) --------------------- */

/* F_p(v), Ψ, and the per-particle Hessian blocks (projected or exact).
 * Returns E(v), or NaN when some particle's F is not finite. */
double kf_imp_linearize(kf_implicit *w, const double *v, int project);
/* g = ∂E/∂v at the last linearisation (unprojected on boundaries). */
void kf_imp_gradient(kf_implicit *w, const double *v, double *g);
/* y = (∂²E/∂v²) x at the last linearisation (unprojected on boundaries). */
void kf_imp_hessian_action(kf_implicit *w, const double *x, double *y);
/* x · y over the nodes that carry mass (the solver's vectors vanish
 * elsewhere), deterministic. */
double kf_imp_dot(kf_implicit *w, const double *x, const double *y);

/* ---- boundary conditions (implicit/boundary.c) --------------------------------- */

/* Walls and colliders at the substep's end: which nodes are constrained,
 * and v (4 nnode) set to v* projected (sticky: the boundary's velocity; slip
 * and separate approaching: the normal part; separate leaving: free).
 * Returns 0 or -1 (out of memory). */
int kf_imp_constraints(kf_implicit *w, double *v);
/* x_i ← P_i x_i on constrained nodes (search directions stay admissible). */
void kf_imp_project(const kf_implicit *w, double *x);
/* Coulomb friction of separate boundaries after the solve: the tangential
 * velocity relative to the boundary shrinks by μ times the normal reaction
 * per unit mass, the reaction being g·n with g the unprojected gradient of
 * the incremental potential at the solution (M (v − v*) − Δt f). */
void kf_imp_friction(const kf_implicit *w, double *v, const double *g);
/* Marks (w->release) the nodes a separate boundary holds whose reaction
 * g·n pulls the material onto it: the constraint was chosen from v*,
 * before the elastic forces, and material leaving after them must go free.
 * Returns 1 if any was marked (solve again), 0, or -1 (out of memory). */
int kf_imp_release_pulling(kf_implicit *w, const double *g);

/* ---- the multigrid preconditioner (implicit/mg_build.c, implicit/mg_cycle.c) ----
 * In the style of HOT (Wang et al. 2020): level 0 is the solve's grid and
 * operator (matrix-free, boundary-projected); level l >= 1 re-discretises
 * the same energy on a grid of spacing 2^l Δx, with the particles' masses
 * re-transferred to its nodes and their per-particle Hessian blocks Kp
 * summed into one quadrature point per cell of the level (the particles'
 * centroid; eight per cell, one per cell of half the spacing, when
 * stiffness outweighs mass: implicit/mg_build.c), so a coarse product
 * costs a fraction of a fine one. Levels are
 * joined by trilinear prolongation P and restriction Pᵀ, each level's
 * boundary projection applied after P and before Pᵀ (coarse levels inherit
 * their children's fixed directions). Coarse levels run a symmetric
 * V(1,1)-cycle of damped Jacobi (ω from a power-iteration estimate of
 * λmax(D⁻¹A), the coarsest level a fixed number of sweeps); the fine level
 * adds its Jacobi step and the coarse correction (no fine smoothing, so no
 * fine Hessian product per application). The whole is a symmetric
 * positive-definite operator, as CG needs. */
#define KF_MG_MAX_LEVELS 6
typedef struct kf_mg_level {
    double h;          /* node spacing, m */
    size_t nn;         /* nodes (level 0: the solve's nnode) */
    int32_t *coord;    /* (3 nn) integer node coordinates (coarse levels) */
    double *mass;      /* (nn) coarse levels: the particles' masses re-transferred */
    double *diag;      /* (KF_IMP_NV nn) the operator's diagonal (level 0: the solve's) */
    double omega;      /* Jacobi damping: OMEGA / λmax(D⁻¹A), estimated (coarse levels) */
    size_t nq;         /* quadrature points (coarse levels): one per cell of the level */
    int32_t *q_of_p;   /* (np) each particle's point */
    double *qx;        /* (3 nq) the point's position (its particles' mass centroid) */
    int32_t *idx;      /* (27 nq) stencil nodes */
    double *gam;       /* (81 nq) MLS γ of each stencil node at spacing h */
    double *K;         /* (81 nq) Σ Kp of the point's particles */
    int32_t *q_up;     /* (nq) each point's point on the next coarser level, whose cell holds its
                        * cell; NULL when rounding splits a cell's particles (or on the coarsest) */
    int32_t *par;      /* (8 per node of the finer level) parents on this level, -1 none */
    double *pw;        /* (8 per node of the finer level) trilinear weights */
    double *b, *x, *t; /* (KF_IMP_NV nn, coarse levels) right-hand side, iterate, scratch */
    size_t ncon;       /* coarse levels: constrained nodes and their projections (level 0: the solve's) */
    int32_t *con_node;
    double *con_P; /* (9 ncon) */
} kf_mg_level;
typedef struct kf_imp_mg {
    int nlev;
    int full_quadrature; /* eight quadrature points per coarse cell (stiffness-dominated), not one */
    int estimated;       /* the coarse dampings were estimated (once per substep) */
    kf_mg_level lev[KF_MG_MAX_LEVELS];
} kf_imp_mg;
/* the levels for w's particles (0 on success, -1 out of memory); the
 * geometry is built once per substep, the operators by kf_imp_mg_refresh */
int kf_imp_mg_create(kf_implicit *w);
void kf_imp_mg_free(kf_imp_mg *mg);
/* the coarse operators and every level's smoother from the current Kp */
void kf_imp_mg_refresh(kf_implicit *w);
/* x ← P_l x: level l's boundary projection (level 0: kf_imp_project) */
void kf_imp_mg_project(const kf_implicit *w, int level, double *x);
/* z = B r, B the V-cycle (z and r: KF_IMP_NV nnode; z projected) */
void kf_imp_mg_apply(kf_implicit *w, const double *r, double *z);
/* the same, writing only the nodes with mass (and lanes 0-2): for a z that
 * already vanishes elsewhere (the solve's own vectors) */
void kf_imp_mg_apply_active(kf_implicit *w, const double *r, double *z);
/* levels built (1 = only the fine grid) and the node count of level l */
int kf_imp_mg_levels(const kf_implicit *w);
size_t kf_imp_mg_nodes(const kf_implicit *w, int level);

/* ---- the solve's profile ------------------------------------------------------
 * Process CPU milliseconds per stage of the implicit grid stage, summed
 * over every substep since the last kf_imp_profile_take, for the evidence
 * sweep (run it on one thread). Off unless kf_imp_profile_enable(1): the
 * clock reads cost a system call each. Process-wide, not per model; while
 * it is off the solve writes none of it (two states may then step on two
 * threads at once). */
enum {
    KF_IMP_T_SETUP,       /* stencils, P2G of mass and momentum, allocation */
    KF_IMP_T_CONSTRAINTS, /* walls and colliders */
    KF_IMP_T_PREDICT,     /* the explicit predictor and its energies */
    KF_IMP_T_LINEARIZE,   /* F, Ψ, P and the Hessian blocks (SVD) at each Newton iterate */
    KF_IMP_T_LINESEARCH,  /* the line search's energies (F, Ψ, P by the polar decomposition) */
    KF_IMP_T_GRADIENT,    /* the gradient's scatter and residual */
    KF_IMP_T_DIAG,        /* the Hessian's diagonal */
    KF_IMP_T_MG_BUILD,    /* the multigrid levels' geometry */
    KF_IMP_T_MG_REFRESH,  /* the coarse operators from the blocks (and the dampings) */
    KF_IMP_T_HESSIAN,     /* CG's fine Hessian products */
    KF_IMP_T_PRECOND,     /* CG's preconditioner (the V-cycle) */
    KF_IMP_T_CG_VECTORS,  /* CG's dots, norms and updates */
    KF_IMP_T_FINISH,      /* friction, the grid update, freeing */
    KF_IMP_T_COUNT
};
typedef struct kf_imp_profile {
    double ms[KF_IMP_T_COUNT];
    long substeps, linearizations, energy_evals, hessian_products, precond_applications;
} kf_imp_profile;
void kf_imp_profile_enable(int on);
/* the profile so far, and a fresh start */
void kf_imp_profile_take(kf_imp_profile *out);
/* its stage names ("setup", "hessian", ...) */
const char *kf_imp_profile_stage(int stage);

/* ---- the solve ---------------------------------------------------------------- */

/* Newton with preconditioned CG and a line search, from v (admissible) to
 * the minimiser; fills the iteration counts and residual. Returns 0, or -1
 * when the potential or the residual stopped being finite. */
int kf_imp_solve(kf_implicit *w, double *v);

/* ---- vector helpers of the hot loops (GCC/Clang vector extension) ------------- */

/* a node's (x, y, z, 0) as one vector; node vectors are only 8-byte aligned.
 * The implicit solver's files use these two names, not local copies. */
typedef double kf_v4d __attribute__((vector_size(32), aligned(8)));
#define KF_IMP_V4(x, i) (*(kf_v4d *)((x) + KF_IMP_NV * (size_t)(i)))

/* y = K g for a 9x9 block K that is exactly symmetric, stored by rows:
 * Σ_j g_j (row j), contiguous rows, two vector FMAs and one scalar per j.
 * y[0..3] comes back in *lo, y[4..7] in *hi, y[8] in *y8. */
static inline void kf_imp_block9(const double *K, const double g[9], kf_v4d *lo, kf_v4d *hi, double *y8) {
    kf_v4d a = {0, 0, 0, 0}, b = a;
    double c = 0;
    for (int j = 0; j < 9; j++) {
        const double *kr = K + 9 * j;
        a += g[j] * *(const kf_v4d *)kr;
        b += g[j] * *(const kf_v4d *)(kr + 4);
        c += g[j] * kr[8];
    }
    *lo = a, *hi = b, *y8 = c;
}

#endif
