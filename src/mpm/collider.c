/* collider.c — keyframed rigid motion of colliders and their signed distance
 * at grid nodes (see collider.h for the formulas). */
#include "collider.h"

#include <math.h>
#include <string.h>

#include "model.h"
#include "sdf_grid.h"

#define DEG (3.14159265358979323846 / 180.0)

/* ---- motion ------------------------------------------------------------------ */

void kf_collider_pose_at(const kf_collider *c, double t, kf_collider_pose *pose) {
    kf_keys_pose_at(c->keys, c->nkeys, c->interp, c->center, c->velocity, t, pose);
}

void kf_collider_at(const kf_collider *c, double t, double center[3], double velocity[3]) {
    kf_collider_pose pose;
    kf_collider_pose_at(c, t, &pose);
    memcpy(center, pose.p, sizeof pose.p);
    memcpy(velocity, pose.dp, sizeof pose.dp);
}

/* ---- the frame of a substep ---------------------------------------------------- */

void kf_collider_frame_at(const kf_collider *c, double t, kf_collider_frame *f) {
    memset(f, 0, sizeof *f);
    f->c = c;
    kf_collider_pose_at(c, t, &f->pose);
    const kf_collider_pose *P = &f->pose;
    f->uniform = P->s[0] == P->s[1] && P->s[1] == P->s[2];
    const double *R = P->R;
    double R0[9];
    kf_euler_matrix(c->rotate, R0);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) {
            double b = 0, l = 0;
            for (int k = 0; k < 3; k++) {
                b += R0[3 * k + i] * R[3 * j + k] / P->s[k];             /* R0ᵀ S⁻¹ Rᵀ */
                l += R[3 * i + k] * (P->ds[k] / P->s[k]) * R[3 * j + k]; /* R (S'/S) Rᵀ */
            }
            f->B[3 * i + j] = b;
            f->L[3 * i + j] = l;
        }
    const double *w = P->omega; /* + [ω]× */
    f->L[1] -= w[2], f->L[2] += w[1];
    f->L[3] += w[2], f->L[5] -= w[0];
    f->L[6] -= w[1], f->L[7] += w[0];
    if (c->shape == KF_SHAPE_PLANE) {
        double len = sqrt(c->normal[0] * c->normal[0] + c->normal[1] * c->normal[1] + c->normal[2] * c->normal[2]);
        for (int a = 0; a < 3; a++) f->nplane[a] = c->normal[a] / len;
    }
    /* the solid's world box: its shape-frame box under A = R S R0 */
    double slo[3], shi[3];
    f->bounded = c->shape != KF_SHAPE_PLANE && !c->inside;
    if (!f->bounded) return;
    if (c->shape == KF_SHAPE_MESH) kf_sdf_grid_bounds(c->sdf, slo, shi);
    for (int a = 0; a < 3; a++) {
        if (c->shape == KF_SHAPE_BOX) slo[a] = -c->half[a], shi[a] = c->half[a];
        if (c->shape == KF_SHAPE_SPHERE) slo[a] = -c->radius, shi[a] = c->radius;
    }
    for (int i = 0; i < 3; i++) {
        double mid = P->p[i], half = 0;
        for (int j = 0; j < 3; j++) {
            double A = 0;
            for (int k = 0; k < 3; k++) A += R[3 * i + k] * P->s[k] * R0[3 * k + j];
            mid += A * 0.5 * (slo[j] + shi[j]);
            half += fabs(A) * 0.5 * (shi[j] - slo[j]);
        }
        f->lo[i] = mid - half;
        f->hi[i] = mid + half;
    }
}

/* ---- what a node sees ------------------------------------------------------------ */

/* f in the shape frame (negative inside the solid), and its gradient in g
 * when g is not NULL */
static double shape_sdf(const kf_collider_frame *fr, const double X[3], double *g) {
    const kf_collider *c = fr->c;
    switch (c->shape) {
    case KF_SHAPE_PLANE:
        if (g) memcpy(g, fr->nplane, sizeof fr->nplane);
        return X[0] * fr->nplane[0] + X[1] * fr->nplane[1] + X[2] * fr->nplane[2];
    case KF_SHAPE_SPHERE: {
        double len = sqrt(X[0] * X[0] + X[1] * X[1] + X[2] * X[2]);
        if (g)
            for (int a = 0; a < 3; a++) g[a] = len > 0 ? X[a] / len : (a == 1);
        return len - c->radius;
    }
    case KF_SHAPE_BOX: {
        /* exact distance outside, largest face distance inside */
        double q[3], out2 = 0, inside = -1e300;
        int amax = 0;
        for (int a = 0; a < 3; a++) {
            q[a] = fabs(X[a]) - c->half[a];
            if (q[a] > 0) out2 += q[a] * q[a];
            if (q[a] > inside) inside = q[a], amax = a;
        }
        if (inside > 0) {
            double d = sqrt(out2);
            if (g)
                for (int a = 0; a < 3; a++) g[a] = q[a] > 0 ? copysign(q[a], X[a]) / d : 0;
            return d;
        }
        if (g)
            for (int a = 0; a < 3; a++) g[a] = a == amax ? copysign(1.0, X[a]) : 0;
        return inside;
    }
    case KF_SHAPE_MESH: {
        double tri[3];
        double f = kf_sdf_grid_sample(c->sdf, X, g ? g : tri);
        /* where the node is constrained, the normal decides which way material
         * may go: take it from central differences (see sdf_grid.h), unless
         * they cancel on a wall's medial plane */
        if (g && (c->inside ? f >= 0 : f <= 0)) {
            double cd[3];
            kf_sdf_grid_gradient(c->sdf, X, cd);
            if (cd[0] * cd[0] + cd[1] * cd[1] + cd[2] * cd[2] > 1e-4) memcpy(g, cd, sizeof cd);
        }
        return f;
    }
    }
    if (g) g[0] = 0, g[1] = 1, g[2] = 0;
    return 1e300;
}

/* A block is skipped when its box misses the solid's world box, or when
 * the shape's own distance at the block's centre says no node of it can be
 * inside: the shape frame stretches lengths by at most 1 / min scale, and the
 * shape's distance changes by at most √3 per unit length (1 for the exact
 * analytic distances; a trilinear read of a distance field can reach √3). */
int kf_collider_may_touch(const kf_collider_frame *f, const double lo[3], const double hi[3]) {
    if (f->bounded)
        for (int a = 0; a < 3; a++)
            if (hi[a] < f->lo[a] || lo[a] > f->hi[a]) return 0;
    const double *B = f->B, *p = f->pose.p;
    double r[3], X[3], half2 = 0;
    for (int a = 0; a < 3; a++) {
        r[a] = 0.5 * (lo[a] + hi[a]) - p[a];
        half2 += 0.25 * (hi[a] - lo[a]) * (hi[a] - lo[a]);
    }
    for (int i = 0; i < 3; i++) X[i] = B[3 * i] * r[0] + B[3 * i + 1] * r[1] + B[3 * i + 2] * r[2];
    double smin = fmin(fmin(f->pose.s[0], f->pose.s[1]), f->pose.s[2]);
    double reach = 1.7320508075688772 * sqrt(half2) / smin, fc = shape_sdf(f, X, NULL);
    return f->c->inside ? fc >= -reach : fc <= reach;
}

double kf_collider_sdf(const kf_collider_frame *f, const double x[3], double n[3]) {
    const double *B = f->B, *p = f->pose.p;
    double r[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]}, X[3], g[3];
    for (int i = 0; i < 3; i++) X[i] = B[3 * i] * r[0] + B[3 * i + 1] * r[1] + B[3 * i + 2] * r[2];
    const double sign = f->c->inside ? -1.0 : 1.0; /* a container: material inside, the solid outside */
    if (!n && f->uniform) return sign * f->pose.s[0] * shape_sdf(f, X, NULL); /* rigid or uniform scale */
    double phi = shape_sdf(f, X, g);
    /* world gradient Bᵀ g. The shape's distance is divided by how much the
     * motion stretches it along g (|Bᵀ g| / |g|: 1 for rigid motion, s for a
     * uniform scale s), not by |Bᵀ g| itself: a sampled field's gradient is
     * shorter than 1 near its ridges, and that must not deepen φ there. */
    double gw[3], len2 = 0, g2 = g[0] * g[0] + g[1] * g[1] + g[2] * g[2];
    for (int j = 0; j < 3; j++) {
        gw[j] = B[j] * g[0] + B[3 + j] * g[1] + B[6 + j] * g[2];
        len2 += gw[j] * gw[j];
    }
    double nn[3];
    if (len2 > 1e-24 && g2 > 1e-24) {
        double inv = 1.0 / sqrt(len2);
        phi = f->uniform ? phi * f->pose.s[0] : phi * sqrt(g2) * inv;
        for (int a = 0; a < 3; a++) nn[a] = sign * gw[a] * inv;
    } else {
        phi *= f->pose.s[0];
        nn[0] = 0, nn[1] = sign, nn[2] = 0; /* a flat spot of a sampled field: any direction */
    }
    if (n) memcpy(n, nn, sizeof nn);
    return sign * phi;
}

void kf_collider_velocity(const kf_collider_frame *f, const double x[3], double v[3]) {
    const double *L = f->L, *p = f->pose.p;
    double r[3] = {x[0] - p[0], x[1] - p[1], x[2] - p[2]};
    for (int i = 0; i < 3; i++) v[i] = f->pose.dp[i] + L[3 * i] * r[0] + L[3 * i + 1] * r[1] + L[3 * i + 2] * r[2];
}

int kf_colliders_near_block(const kf_collider_frame *frame, int ncol, const int32_t bc[3], double dx, int near[]) {
    double blo[3], bhi[3];
    for (int a = 0; a < 3; a++) blo[a] = bc[a] * KF_BLOCK * dx, bhi[a] = (bc[a] * KF_BLOCK + KF_BLOCK - 1) * dx;
    int n = 0;
    for (int c = 0; c < ncol; c++)
        if (kf_collider_may_touch(&frame[c], blo, bhi)) near[n++] = c;
    return n;
}
