/* test_guard_settle.c — the crossing guard's last leg (issue 17).
 *
 * The guard (cpic/guard.c) follows each particle's path relative to a thin
 * body to the body's pose at the substep's end, and a dynamic body's is
 * predicted from its velocity: a paddle hinged at its centre of mass is
 * predicted to fall g Δt² in a substep, and the hinge holds it. A grain that
 * ends closer to the surface than that ends on the far side of the plane the
 * body really has (sand_paddles at preview, frame 1010: 6e-8 m in front of
 * the predicted plane, 3e-8 m behind the real one; the audit counted it).
 * kf_cpic_guard_settle follows every such particle from the one pose to the
 * other after the bodies have moved.
 *   - the geometry found, reduced: the grain nearest above a hinged paddle
 *     put half way between the two planes is across at the body's own pose;
 *     the settle puts it back a hundredth of a cell in front, its tag kept;
 *   - sand poured onto a hinged paddle: nobody across after any substep
 *     (before the settle, 18 of these 300 substeps ended with one across). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "cpic/cpic.h"
#include "kt.h"
#include "scene_util.h"

#define DX 0.012 /* sand_paddles' spacing at preview */
#define DT 3e-4

/* A square paddle (0.3 x 0.1 m, normal +y) in y = 0.5, hinged about z
 * through its centre of mass, with a block of sand falling onto it at 1 m/s.
 * Four times gravity: the predicted pose's error, g Δt², grows with it, so
 * the crossing comes within a few hundred substeps. */
static kf_model *paddle_model(int *mat) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = DX;
    sd.gravity[1] = -40;
    kf_model *m = tu_model(&sd, "sand", 3.5e5, -1, 0, mat);
    static double vert[12] = {0.35, 0.5, 0.45, 0.65, 0.5, 0.45, 0.65, 0.5, 0.55, 0.35, 0.5, 0.55};
    static int tri[6] = {0, 2, 1, 0, 3, 2};
    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "paddle");
    d.vertices = vert, d.nvertices = 4, d.triangles = tri, d.ntriangles = 2;
    d.thin = 1;
    d.motion = KF_RIGID_DYNAMIC;
    d.density = 20; /* kg/m², as sand_paddles' */
    d.boundary = KF_BOUNDARY_SEPARATE;
    d.friction = 0.3;
    d.penalty = KF_RIGID_AUTO, d.push = KF_RIGID_AUTO;
    char err[256];
    KT_CHECK(kf_model_add_rigid(m, &d, err, sizeof err) >= 0, "paddle: %s", err);
    kf_joint_def j;
    memset(&j, 0, sizeof j);
    j.body_a = 0, j.body_b = -1;
    j.anchor[0] = 0.5, j.anchor[1] = 0.5, j.anchor[2] = 0.5;
    j.axis[2] = 1;
    j.damping = 0.002;
    KT_CHECK(kf_model_add_joint(m, &j, err, sizeof err) >= 0, "hinge: %s", err);
    return m;
}

static kf_state *paddle_state(const kf_model *m, int mat) {
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.45, 0.503, 0.46}, hi[3] = {0.55, 0.58, 0.54}, v[3] = {0, -1, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v, 2, 9);
    return s;
}

/* signed distance of world point x from the paddle's plane at pose st (+: the normal's side) */
static double plane_u(const kf_model *m, const kf_rigid_state *st, const double x[3]) {
    const kf_rigid_body *b = &m->rigid[0];
    const double *a = &b->vert[3 * b->tri[0]], *p = &b->vert[3 * b->tri[1]], *q = &b->vert[3 * b->tri[2]];
    double e1[3], e2[3], n[3], pm[3], d[3];
    for (int k = 0; k < 3; k++) e1[k] = p[k] - a[k], e2[k] = q[k] - a[k], d[k] = x[k] - st->t[k];
    n[0] = e1[1] * e2[2] - e1[2] * e2[1], n[1] = e1[2] * e2[0] - e1[0] * e2[2], n[2] = e1[0] * e2[1] - e1[1] * e2[0];
    const double nn = sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]);
    for (int k = 0; k < 3; k++) pm[k] = st->R[k] * d[0] + st->R[3 + k] * d[1] + st->R[6 + k] * d[2]; /* R^T d */
    return ((pm[0] - a[0]) * n[0] + (pm[1] - a[1]) * n[1] + (pm[2] - a[2]) * n[2]) / nn;
}

static void grain_between_poses(void) {
    int mat;
    kf_model *m = paddle_model(&mat);
    kf_state *s = paddle_state(m, mat);
    for (int k = 0; k < 30; k++) {
        kf_trouble tr;
        if (kf_step(m, s, DT, NULL, &tr)) {
            KT_CHECK(0, "substep %d: %s", k, tr.what);
            break;
        }
    }
    double deep;
    KT_CHECK(kf_state_thin_audit(m, s, &deep) == 0, "nobody across after 30 substeps");
    /* the guard's pose (free fall) and the paddle's own (held by the hinge) */
    const kf_rigid_state *guarded = &s->cpic->end[0], *own = &s->rigid[0];
    kf_particles *p = &s->p;
    /* the grain with affinity to the paddle, tagged on its +y side, nearest above it */
    size_t pick = p->n;
    double best = 1;
    for (size_t i = 0; i < p->n; i++) {
        double x[3] = {p->x[0][i], p->x[1][i], p->x[2][i]};
        const double u = plane_u(m, own, x);
        if ((p->colour[i] & 3) == 2 && u > 0 && u < best && fabs(x[0] - 0.5) < 0.1 && fabs(x[2] - 0.5) < 0.03)
            best = u, pick = i;
    }
    KT_CHECK(pick < p->n, "a grain above the paddle");
    if (pick == p->n) goto done;
    double x[3] = {p->x[0][pick], p->x[1][pick], p->x[2][pick]};
    const double gap = plane_u(m, guarded, x) - plane_u(m, own, x);
    KT_CHECK(gap > 1e-6, "the hinge held the paddle above the free fall the guard predicted (%.3g m)", gap);
    /* half way between the two planes, as the guard may leave a grain: it
     * moves along the paddle's normal (+y, turned by the paddle's small tilt) */
    const double shift = -(plane_u(m, own, x) + 0.5 * gap);
    for (int a = 0; a < 3; a++) p->x[a][pick] = (kf_real)(x[a] + shift * own->R[3 * a + 1]);
    const kf_real v[3] = {p->v[0][pick], p->v[1][pick], p->v[2][pick]};
    for (int a = 0; a < 3; a++) x[a] = p->x[a][pick];
    KT_CHECK(plane_u(m, guarded, x) > 0 && plane_u(m, own, x) < 0,
             "in front of the guard's plane (%.3g m), behind the paddle's own (%.3g m)", plane_u(m, guarded, x),
             plane_u(m, own, x));
    long across = kf_state_thin_audit(m, s, &deep);
    KT_CHECK(across == 1, "before the settle the audit sees it across (%ld)", across);
    kf_cpic_guard_settle(m, s);
    across = kf_state_thin_audit(m, s, &deep);
    for (int a = 0; a < 3; a++) x[a] = p->x[a][pick];
    const double u = plane_u(m, own, x);
    printf("  grain %.2e m behind the paddle, %.2e m in front of the guard's plane: settled %.2e m in front\n",
           0.5 * gap, 0.5 * gap, u);
    KT_CHECK(across == 0, "after it, nobody across (%ld, deepest %.3g cells)", across, deep);
    /* a hundredth of a cell, less the float rounding of its position (6e-8 m at 0.5 m) */
    KT_CHECK(u > 0.01 * DX - 1e-6, "put back a hundredth of a cell in front (%.3g m)", u);
    KT_CHECK((p->colour[pick] & 3) == 2, "its tag still names the +y side (colour %x)", p->colour[pick]);
    KT_CHECK(p->v[0][pick] == v[0] && p->v[1][pick] == v[1] && p->v[2][pick] == v[2], "its velocity untouched");
done:
    kf_state_destroy(s);
    kf_model_destroy(m);
}

static void sand_on_paddle(void) {
    int mat;
    kf_model *m = paddle_model(&mat);
    kf_state *s = paddle_state(m, mat);
    kf_step_stats st;
    memset(&st, 0, sizeof st);
    long ended_across = 0, most = 0;
    for (int k = 0; k < 300; k++) {
        kf_trouble tr;
        if (kf_step(m, s, DT, &st, &tr)) {
            KT_CHECK(0, "substep %d: %s", k, tr.what);
            break;
        }
        double deep;
        const long across = kf_state_thin_audit(m, s, &deep);
        ended_across += across > 0;
        most = across > most ? across : most;
    }
    printf("  sand on a hinged paddle: %ld crossings put back, %ld of 300 substeps ended with someone across\n",
           st.thin_caught, ended_across);
    KT_CHECK(st.thin_caught > 0, "the sand reached the paddle (%ld put back)", st.thin_caught);
    KT_CHECK(ended_across == 0, "nobody across after any substep (%ld substeps, at most %ld)", ended_across, most);
    kf_state_destroy(s);
    kf_model_destroy(m);
}

int main(int argc, char **argv) {
    KT_RUN(grain_between_poses, argc, argv);
    KT_RUN(sand_on_paddle, argc, argv);
    return KT_EXIT();
}
