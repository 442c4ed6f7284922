/* test_boundary.c — walls and analytic colliders (Eq. 25): keyframed paths,
 * slip keeps tangential motion, Coulomb friction decelerates at μg, sticky
 * stops, separate lets go, and moving colliders push material aside. */
#include "kt.h"
#include "mpm/model.h"
#include "scene_util.h"

/* piecewise-linear keys: positions interpolate, velocity is the segment slope,
 * and the collider holds still before the first and after the last key */
static void keyframes(void) {
    kf_collider c = {0};
    c.shape = KF_SHAPE_SPHERE;
    c.radius = 0.1;
    c.nkeys = 3;
    c.keys[0] = (kf_key){.time = 1.0, .position = {0, 0, 0}};
    c.keys[1] = (kf_key){.time = 2.0, .position = {1, 2, 0}};
    c.keys[2] = (kf_key){.time = 4.0, .position = {1, 2, 4}};
    double x[3], v[3];
    kf_collider_at(&c, 0.5, x, v);
    KT_NEAR(x[0] + x[1] + x[2], 0, 0, "held at the first key before it");
    KT_NEAR(v[0] * v[0] + v[1] * v[1] + v[2] * v[2], 0, 0, "at rest before the first key");
    kf_collider_at(&c, 1.5, x, v);
    KT_NEAR(x[0], 0.5, 1e-15, "halfway along the first segment");
    KT_NEAR(x[1], 1.0, 1e-15, "halfway along the first segment");
    KT_NEAR(v[1], 2.0, 1e-15, "segment velocity");
    kf_collider_at(&c, 3.0, x, v);
    KT_NEAR(x[2], 2.0, 1e-15, "second segment");
    KT_NEAR(v[2], 2.0, 1e-15, "second segment velocity");
    kf_collider_at(&c, 9.0, x, v);
    KT_NEAR(x[2], 4.0, 0, "held at the last key after it");
    KT_NEAR(v[2], 0.0, 0, "at rest after the last key");
    c.nkeys = 0;
    c.center[0] = 1;
    c.velocity[0] = -0.5;
    kf_collider_at(&c, 2.0, x, v);
    KT_NEAR(x[0], 0.0, 1e-15, "constant velocity: centre + v t");
}

/* a block resting on a floor wall, given a horizontal velocity; returns the
 * centre-of-mass velocity after `t` seconds and the lowest particle height */
static double slide(kf_boundary type, double mu, double t, const char *preset, double *lowest) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.walls = 1;
    sd.wall_boundary = type;
    sd.wall_friction = mu;
    sd.domain_min[1] = 0.1;
    sd.domain_max[0] = 10; /* long floor */
    sd.cfl = 0.3;
    int mat;
    kf_model *m = tu_model(&sd, preset, 0, -1, 0, &mat);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.2, 0.1 + 0.5 * sd.dx, 0.3}, hi[3] = {0.4, 0.2, 0.5}, v0[3] = {1, 0, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v0, 2, 0);
    char msg[256];
    kf_step_stats st = {0};
    KT_CHECK(kf_advance(m, s, t, &st, msg, sizeof msg) == 0, "%s", msg);
    kf_energy e = kf_state_energy(m, s);
    kf_particles_view pv = kf_state_particles(s);
    *lowest = 1e9;
    for (size_t i = 0; i < pv.n; i++) *lowest = fmin(*lowest, pv.x[1][i]);
    kf_state_destroy(s);
    kf_model_destroy(m);
    return e.momentum[0] / e.mass;
}

static void floor_slip_and_friction(void) {
    double low;
    /* slip: no tangential force at all */
    double v_slip = slide(KF_BOUNDARY_SLIP, 0, 0.2, "rubber", &low);
    KT_NEAR(v_slip, 1.0, 1e-5, "slip floor keeps the tangential velocity (measured 7e-7: round-off)");
    KT_CHECK(low > 0.1 - 0.5 * 0.02, "material stays on the floor (lowest %.4f)", low);
    /* separate with Coulomb friction: the floor pushes up with the weight, so
     * the block decelerates at μ g (v = 1 − 0.3·9.81·0.2 = 0.4114 at t = 0.2 s);
     * measured 0.4026 (2.1% low: the contact settles in its first substeps), so 3% */
    double v_fric = slide(KF_BOUNDARY_SEPARATE, 0.3, 0.2, "rubber", &low);
    KT_NEAR(v_fric, 1.0 - 0.3 * 9.81 * 0.2, 0.03 * 0.4114, "Coulomb friction decelerates at mu g");
    /* sticky: the bottom nodes stop dead; an elastic block would rock on its
     * glued base, so use goo, whose plasticity soaks up the motion */
    double v_stick = slide(KF_BOUNDARY_STICKY, 0, 0.45, "goo", &low);
    KT_CHECK(fabs(v_stick) < 0.05, "sticky floor brings goo to rest (measured 0.056 at 0.4 s), v = %.3f", v_stick);
}

/* a ball thrown upward off a separate floor leaves it: separate lets go */
static void separate_lets_go(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.walls = 1;
    sd.gravity[1] = 0;
    int mat;
    kf_model *m = tu_model(&sd, "rubber", 0, -1, 0, &mat);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.4, 0.01, 0.4}, hi[3] = {0.6, 0.1, 0.6}, v0[3] = {0, 1, 0};
    kf_state_fill_box(s, m, lo, hi, mat, v0, 2, 0);
    char msg[256];
    KT_CHECK(kf_advance(m, s, 0.1, NULL, msg, sizeof msg) == 0, "%s", msg);
    kf_energy e = kf_state_energy(m, s);
    KT_NEAR(e.momentum[1] / e.mass, 1.0, 1e-3, "moving away from a separate wall is unconstrained");
    kf_state_destroy(s);
    kf_model_destroy(m);
}

/* a sphere collider moving through a block at rest: no material ends up
 * inside it, and the material gains momentum along the sphere's motion */
static void moving_sphere_pushes(void) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.gravity[1] = 0;
    int mat;
    kf_model *m = tu_model(&sd, "goo", 0, -1, 0, &mat);
    kf_collider c = {0};
    c.shape = KF_SHAPE_SPHERE;
    c.boundary = KF_BOUNDARY_SEPARATE;
    c.radius = 0.08;
    c.nkeys = 2;
    c.keys[0] = (kf_key){.time = 0.0, .position = {0.5, 0.8, 0.5}};
    c.keys[1] = (kf_key){.time = 0.5, .position = {0.5, 0.4, 0.5}};
    char err[256];
    KT_CHECK(kf_model_add_collider(m, &c, err, sizeof err) == 0, "%s", err);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.3, 0.3, 0.3}, hi[3] = {0.7, 0.6, 0.7};
    kf_state_fill_box(s, m, lo, hi, mat, NULL, 2, 0);
    char msg[256];
    KT_CHECK(kf_advance(m, s, 0.5, NULL, msg, sizeof msg) == 0, "%s", msg);
    kf_particles_view pv = kf_state_particles(s);
    size_t inside = 0;
    for (size_t i = 0; i < pv.n; i++) {
        double r2 = pow(pv.x[0][i] - 0.5, 2) + pow(pv.x[1][i] - 0.4, 2) + pow(pv.x[2][i] - 0.5, 2);
        /* grid-node boundaries hold material about half a cell off the surface */
        inside += r2 < pow(c.radius - 0.5 * sd.dx, 2);
    }
    KT_CHECK(inside == 0, "%zu particles inside the sphere", inside);
    kf_energy e = kf_state_energy(m, s);
    KT_CHECK(e.momentum[1] < 0, "material pushed along -y, momentum %.4g", e.momentum[1]);
    kf_state_destroy(s);
    kf_model_destroy(m);
}

int main(int argc, char **argv) {
    KT_RUN(keyframes, argc, argv);
    KT_RUN(floor_slip_and_friction, argc, argv);
    KT_RUN(separate_lets_go, argc, argv);
    KT_RUN(moving_sphere_pushes, argc, argv);
    return KT_EXIT();
}
