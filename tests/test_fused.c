/* test_fused.c — the fused substep end (transfer.c: kf_g2p2g) gives the bits
 * of the separate G2P, stress and P2G passes.
 *
 * Where the next substep's Δt is known (a fixed step, the sim.dt_max clamp,
 * the CFL rule's look-ahead from the grid's velocities, or a caller's
 * kf_state_fuse_next), each substep ends with the next one's P2G, made
 * owner block by owner block right after the block's G2P and stress;
 * otherwise (moving rigid bodies, contact fields that meet) G2P and the
 * stress still share one sweep. With every body static the early P2G
 * covers CPIC's band too (its colours, distances and impulses). Both must
 * leave every particle plane as the separate passes do (kf_model.unfused),
 * bit for bit, after every frame: particles falling through block faces
 * (the early scatter is then thrown away and the next substep bins and
 * scatters as usual), several materials in one owner block (elastic,
 * von Mises, sand and snow: the stress batches then fall differently than
 * in the separate pass), the quadratic and cubic kernels, MLS and classic
 * forces, APIC and PIC, 1 and 2 threads. A writable particle view between
 * kf_step calls must cancel a scatter made before it. */
#include <string.h>

#include "cpic/cpic.h"
#include "kt.h"
#include "mpm/contact.h"
#include "mpm/model.h"

typedef struct variant {
    const char *name;
    kf_kernel kernel;
    kf_force force;
    kf_transfer transfer;
    double dt_fixed, dt_max; /* 0: the CFL rule alone */
    int threads;
    int bodies;  /* 1: a blade cutting down through the blocks and a falling plate; 2: static bodies;
                    3: a blade coming down from above the blocks */
    int contact; /* 1: each block its own object, in contact with the others (sim.contact); 2: contact on,
                    one object (the cut's pieces become fields) */
} variant;

enum { FRAMES = 2 };

typedef struct run {
    uint64_t hash[FRAMES];
    long substeps, fused, rebins;
    double max_cfl; /* the largest CFL number a substep used */
    int ok, fields;
    double impulse[KF_MAX_RIGIDS][6]; /* the bodies' running totals (a static body's move nothing) */
} run;

/* a thin blade, kinematic, its edge along z at x 0.19: it moves from y0
 * down to y1 over the first second, turning by rotate degrees about z */
static void add_blade(kf_model *m, const char *name, double y0, double y1, double rotate) {
    static const double quad[12] = {0, 0, -0.15, 0, 0, 0.15, 0, 0.3, 0.15, 0, 0.3, -0.15};
    static const int tri[6] = {0, 1, 2, 0, 2, 3};
    char err[256];
    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "blade");
    d.vertices = quad, d.nvertices = 4, d.triangles = tri, d.ntriangles = 2;
    d.thin = 1;
    d.motion = KF_RIGID_KINEMATIC;
    d.boundary = KF_BOUNDARY_SEPARATE;
    d.friction = 0.2;
    d.penalty = KF_RIGID_AUTO;
    d.nkeys = 2;
    d.keys[0].time = 0, d.keys[1].time = 1;
    d.keys[0].position[0] = d.keys[1].position[0] = 0.19;
    d.keys[0].position[1] = y0, d.keys[1].position[1] = y1;
    d.keys[0].position[2] = d.keys[1].position[2] = 0.185;
    d.keys[1].rotate[2] = rotate;
    KT_CHECK(kf_model_add_rigid(m, &d, err, sizeof err) >= 0, "%s: blade: %s", name, err);
}

/* CPIC's band in the sweep: a thin blade, kinematic, turning as it cuts
 * down through the second and third blocks (a body whose velocity varies
 * along it), and a thin plate, dynamic, falling onto the fourth (its
 * impulses move it, so the sweep's order of impulses shows in its pose) */
static void add_bodies(kf_model *m, const char *name) {
    static const double plate[12] = {-0.04, 0, -0.06, 0.04, 0, -0.06, 0.04, 0, 0.06, -0.04, 0, 0.06};
    static const int tri[6] = {0, 1, 2, 0, 2, 3};
    char err[256];
    kf_rigid_def d;
    add_blade(m, name, 0.1, -2.9, 60);
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "plate");
    d.vertices = plate, d.nvertices = 4, d.triangles = tri, d.ntriangles = 2;
    d.thin = 1;
    d.motion = KF_RIGID_DYNAMIC;
    d.boundary = KF_BOUNDARY_SEPARATE;
    d.density = 20;
    d.penalty = KF_RIGID_AUTO;
    d.position[0] = 0.3, d.position[1] = 0.2, d.position[2] = 0.185;
    d.velocity[1] = -2;
    d.angular_velocity[2] = 3;
    KT_CHECK(kf_model_add_rigid(m, &d, err, sizeof err) >= 0, "%s: plate: %s", name, err);
}

/* a thin blade, kinematic, that starts above the blocks and comes down
 * into them in the second frame: while nothing is within its reach the
 * band is empty and the next P2G (the ordinary one everywhere) is
 * scattered early; once it arrives, the early scatter made before is
 * dropped and the band's P2G runs. 6 m/s down: its edge at y 0.2, then 0.1 */
static void add_blade_above(kf_model *m, const char *name) { add_blade(m, name, 0.3, -5.7, 0); }

/* CPIC's band with every body static (its distance field the same every
 * substep, so the next P2G is made in the sweep, band included): a thin
 * blade, edge up, that the second block (goo, a solid) falls onto and that
 * cuts it through within the two frames (with contact on, the halves
 * become fields of their own and meet: the early scatter is dropped from
 * then on), and a solid box on the floor under the fourth (snow) */
static void add_static_bodies(kf_model *m, const char *name) {
    static const double quad[12] = {0, 0, -0.15, 0, 0, 0.15, 0, 0.11, 0.15, 0, 0.11, -0.15};
    static const double box[24] = {0, 0, 0,    0.05, 0, 0,    0.05, 0.04, 0,    0, 0.04, 0,
                                   0, 0, 0.07, 0.05, 0, 0.07, 0.05, 0.04, 0.07, 0, 0.04, 0.07};
    static const int tri[6] = {0, 1, 2, 0, 2, 3};
    /* outward normals (counter-clockwise seen from outside) */
    static const int btri[36] = {0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4,
                                 3, 7, 6, 3, 6, 2, 0, 4, 7, 0, 7, 3, 1, 2, 6, 1, 6, 5};
    char err[256];
    kf_rigid_def d;
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "blade");
    d.vertices = quad, d.nvertices = 4, d.triangles = tri, d.ntriangles = 2;
    d.thin = 1;
    d.motion = KF_RIGID_STATIC;
    d.boundary = KF_BOUNDARY_SEPARATE;
    d.friction = 0.2;
    d.penalty = KF_RIGID_AUTO;
    d.position[0] = 0.155, d.position[2] = 0.185;
    KT_CHECK(kf_model_add_rigid(m, &d, err, sizeof err) >= 0, "%s: blade: %s", name, err);
    memset(&d, 0, sizeof d);
    snprintf(d.name, sizeof d.name, "box");
    d.vertices = box, d.nvertices = 8, d.triangles = btri, d.ntriangles = 12;
    d.motion = KF_RIGID_STATIC;
    d.boundary = KF_BOUNDARY_SEPARATE;
    d.friction = 0.3;
    d.penalty = KF_RIGID_AUTO;
    d.position[0] = 0.27, d.position[2] = 0.15;
    KT_CHECK(kf_model_add_rigid(m, &d, err, sizeof err) >= 0, "%s: box: %s", name, err);
}

/* four blocks of four materials side by side, touching, falling onto the
 * floor of a box with friction; one frame is 1/60 s */
static run run_scene(const variant *v, int unfused) {
    run r = {0};
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.kernel = v->kernel;
    sd.force = v->force;
    sd.transfer = v->transfer;
    sd.dt_fixed = v->dt_fixed;
    sd.dt_max = v->dt_max;
    sd.threads = v->threads;
    sd.contact = v->contact != 0;
    sd.walls = 1;
    sd.wall_boundary = KF_BOUNDARY_SEPARATE;
    sd.wall_friction = 0.3;
    for (int a = 0; a < 3; a++) sd.domain_min[a] = 0, sd.domain_max[a] = 0.4;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    KT_CHECK(m != NULL, "%s: model: %s", v->name, err);
    if (!m) return r;
    kf_model_set_unfused(m, unfused);
    if (v->bodies == 1) add_bodies(m, v->name);
    if (v->bodies == 2) add_static_bodies(m, v->name);
    if (v->bodies == 3) add_blade_above(m, v->name);
    const char *presets[4] = {"jello", "goo", "sand", "snow"};
    kf_state *s = kf_state_create(m);
    for (int k = 0; k < 4; k++) {
        kf_material mat;
        kf_material_preset(presets[k], &mat);
        int id = kf_model_add_material(m, &mat, err, sizeof err);
        KT_CHECK(id >= 0, "%s: material %s: %s", v->name, presets[k], err);
        /* 0.07 m wide, not a multiple of a block: owners hold several materials */
        double lo[3] = {0.05 + 0.07 * k, 0.05 + 0.01 * k, 0.1}, hi[3] = {lo[0] + 0.07, lo[1] + 0.1, 0.27};
        double vel[3] = {0.2 * (k - 1.5), -1.5, 0.1}; /* over a cell a frame: re-sorts */
        kf_state_fill_box(s, m, lo, hi, id, vel, 2, 7u + (uint32_t)k);
    }
    if (v->contact == 1) {
        kf_particles_view p = kf_state_particles(s);
        for (size_t i = 0; i < p.n; i++) p.obj[i] = p.mat[i];
    }
    kf_step_stats st = {0};
    char msg[512];
    int fields = 0;
    r.ok = 1;
    for (int f = 0; f < FRAMES && r.ok; f++) {
        if (kf_advance(m, s, 1.0 / 60, &st, msg, sizeof msg)) {
            KT_CHECK(0, "%s (%s): frame %d: %s", v->name, unfused ? "unfused" : "fused", f + 1, msg);
            r.ok = 0;
        }
        r.hash[f] = kf_state_hash(s);
        fields |= s->contact && s->contact->active;
    }
    KT_CHECK(v->contact != 1 || fields, "%s: objects met in contact fields", v->name);
    r.fields = fields;
    /* the bodies met the material: each took impulses from it */
    for (int b = 0; b < (v->bodies == 3 ? 1 : v->bodies ? 2 : 0); b++) {
        const double *J = s->cpic->impulse_total[b];
        KT_CHECK(fabs(J[0]) + fabs(J[1]) + fabs(J[2]) > 1e-4, "%s: body %d took an impulse from the material (%g N s)",
                 v->name, b, fabs(J[0]) + fabs(J[1]) + fabs(J[2]));
    }
    if (s->cpic) memcpy(r.impulse, s->cpic->impulse_total, sizeof r.impulse);
    r.substeps = st.substeps;
    r.max_cfl = st.max_cfl;
    r.fused = st.fused;
    r.rebins = s->g.rebins;
    kf_state_destroy(s);
    kf_model_destroy(m);
    return r;
}

static void compare(const variant *v, int expect_fused) {
    run a = run_scene(v, 0), b = run_scene(v, 1);
    if (!a.ok || !b.ok) return;
    int first = -1;
    for (int f = 0; f < FRAMES; f++)
        if (first < 0 && a.hash[f] != b.hash[f]) first = f + 1;
    printf("  %-28s %4ld substeps, %4ld scattered early, %3ld re-sorts; hash %016llx %s\n", v->name, a.substeps,
           a.fused, a.rebins, (unsigned long long)a.hash[FRAMES - 1], first < 0 ? "(= unfused)" : "(DIFFERS)");
    KT_CHECK(first < 0, "%s: the fused run equals the unfused one after every frame (first difference: frame %d)",
             v->name, first);
    KT_CHECK(b.fused == 0, "%s: the unfused run scatters nothing early", v->name);
    /* the cut's pieces: the blade cut the block in two and the halves met
     * as fields, so the fused run went through the dropped-scatter path */
    if (v->contact == 2)
        KT_CHECK(a.fields && b.fields, "%s: the cut's pieces met in contact fields (fused %d, unfused %d)", v->name,
                 a.fields, b.fields);
    KT_CHECK(!memcmp(a.impulse, b.impulse, sizeof a.impulse),
             "%s: the bodies took the same impulses, bit for bit (fused %.17g, unfused %.17g N s along y, body 0)",
             v->name, a.impulse[0][1], b.impulse[0][1]);
    /* under the CFL rule no substep is longer than the rule allows (the
     * look-ahead only shortens them); the default sim.cfl is 0.4 */
    if (!(v->dt_fixed > 0))
        KT_CHECK(a.max_cfl <= 0.4 * (1 + 1e-12) && b.max_cfl == a.max_cfl,
                 "%s: CFL number at most sim.cfl (fused %.6f, unfused %.6f)", v->name, a.max_cfl, b.max_cfl);
    if (expect_fused > 0) {
        /* every substep but each interval's first (a full sort), less those
         * after which a particle left its owner */
        KT_CHECK(a.fused > 0 && a.fused <= a.substeps - FRAMES,
                 "%s: the fused run used early scatters (%ld of %ld substeps)", v->name, a.fused, a.substeps);
        KT_CHECK(a.rebins > FRAMES, "%s: particles left their owners too (%ld re-sorts), so fallbacks ran", v->name,
                 a.rebins);
    } else if (expect_fused == 0) {
        KT_CHECK(a.fused == 0, "%s: no Δt known in advance, no early scatter (%ld)", v->name, a.fused);
    }
}

static void fixed_step(void) {
    const variant vs[] = {
        {"quadratic MLS APIC, 2 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 2, 0, 0},
        {"quadratic MLS APIC, 1 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 1, 0, 0},
        {"cubic MLS APIC", KF_KERNEL_CUBIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 2, 0, 0},
        {"quadratic classic APIC", KF_KERNEL_QUADRATIC, KF_FORCE_CLASSIC, KF_TRANSFER_APIC, 2e-4, 0, 2, 0, 0},
        {"quadratic MLS PIC", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_PIC, 2e-4, 0, 2, 0, 0},
    };
    /* cubic: binning leaves a falling particle no room below its owner
     * (base offsets 0..3 after a sort, 0..4 allowed), so every substep
     * re-sorts and none is scattered early; the bits must agree all the same */
    for (size_t k = 0; k < sizeof vs / sizeof vs[0]; k++) compare(&vs[k], vs[k].kernel == KF_KERNEL_CUBIC ? -1 : 1);
}

/* the CFL rule under a dt_max that holds: the clamp is guessed to hold again */
static void clamped_step(void) {
    const variant v = {"CFL under dt_max", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 0, 2e-4, 2, 0, 0};
    compare(&v, 1);
}

/* the CFL rule alone: the next substep's length is picked from the grid's
 * velocities before G2P (step.c), so the next P2G is scattered early too */
static void cfl_step(void) {
    const variant v = {"CFL rule", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 0, 0, 2, 0, 0};
    compare(&v, 1);
}

/* moving rigid bodies and contact fields: G2P and stress share the sweep
 * (with the CPIC band's transfers, penalty and guard, and the fields'
 * gather, in it) but the next P2G waits for the next substep's colored
 * distance field (a moving body's) and fields, so nothing is scattered
 * early */
static void with_bodies(void) {
    const variant vs[] = {
        {"bodies, fixed step, 2 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 2, 1, 0},
        {"bodies, fixed step, 1 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 1, 1, 0},
        {"bodies, classic, CFL rule", KF_KERNEL_QUADRATIC, KF_FORCE_CLASSIC, KF_TRANSFER_APIC, 0, 0, 2, 1, 0},
        {"bodies, contact, 2 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 2, 1, 1},
        {"bodies, contact, 1 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 1, 1, 1},
        {"contact, no bodies, CFL rule", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 0, 0, 2, 0, 1},
    };
    for (size_t k = 0; k < sizeof vs / sizeof vs[0]; k++) compare(&vs[k], 0);
}

/* kf_step called directly with the next Δt announced; between two calls
 * the caller edits velocities through the writable view: the scatter made
 * before the edit must not be used */
static uint64_t direct_run(kf_kernel kernel, int unfused, int edit, long *fused) {
    kf_sim_def sd = kf_default_sim_def();
    sd.dx = 0.02;
    sd.kernel = kernel;
    sd.threads = 2;
    char err[256];
    kf_model *m = kf_model_create(&sd, err, sizeof err);
    kf_model_set_unfused(m, unfused);
    kf_material mat;
    kf_material_preset("jello", &mat);
    int id = kf_model_add_material(m, &mat, err, sizeof err);
    kf_state *s = kf_state_create(m);
    double lo[3] = {0.1, 0.1, 0.1}, hi[3] = {0.2, 0.2, 0.2}, v0[3] = {0, 0, 0};
    kf_state_fill_box(s, m, lo, hi, id, v0, 2, 3);
    const double dt = 1e-4;
    kf_state_fuse_next(s, dt);
    kf_step_stats st = {0};
    for (int k = 0; k < 40; k++) {
        if (edit && k == 20) {
            kf_particles_view p = kf_state_particles(s);
            for (size_t i = 0; i < p.n; i++) p.v[0][i] += (kf_real)0.5;
        }
        kf_step(m, s, dt, &st, NULL);
    }
    uint64_t h = kf_state_hash(s);
    *fused = st.fused;
    kf_state_destroy(s);
    kf_model_destroy(m);
    return h;
}

/* every body static: the next P2G is scattered early in the band too
 * (its colours, distances, the impulses on the bodies), and with contact
 * on (one object, cut in pieces by the blade) while no fields meet */
static void with_static_bodies(void) {
    const variant vs[] = {
        {"static bodies, 2 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 2, 2, 0},
        {"static bodies, 1 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 1, 2, 0},
        {"static bodies, classic", KF_KERNEL_QUADRATIC, KF_FORCE_CLASSIC, KF_TRANSFER_APIC, 2e-4, 0, 2, 2, 0},
        {"static bodies, dt_max", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 0, 2e-4, 2, 2, 0},
        {"static bodies, pieces, 2 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 2, 2, 2},
        {"static bodies, pieces, 1 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 1, 2, 2},
    };
    for (size_t k = 0; k < sizeof vs / sizeof vs[0]; k++) compare(&vs[k], 1);
    /* under the CFL rule alone the look-ahead picks the next Δt from the
     * grid before G2P, with static bodies too: scattered early, and never
     * past the rule's CFL number (compare checks it) */
    const variant cfl = {"static bodies, CFL rule", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 0, 0, 2, 2, 0};
    compare(&cfl, 1);
}

/* a moving body away from the material: while the band is empty the next
 * P2G is the ordinary one and is scattered early (cpic/early.c), taken
 * only while the band stays empty; the blade's arrival drops it */
static void with_body_above(void) {
    const variant vs[] = {
        {"blade above, 2 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 2, 3, 0},
        {"blade above, 1 thr", KF_KERNEL_QUADRATIC, KF_FORCE_MLS, KF_TRANSFER_APIC, 2e-4, 0, 1, 3, 0},
    };
    for (size_t k = 0; k < sizeof vs / sizeof vs[0]; k++) compare(&vs[k], 1);
}

static void direct_steps(void) {
    for (int cubic = 0; cubic < 2; cubic++) {
        const kf_kernel kw = cubic ? KF_KERNEL_CUBIC : KF_KERNEL_QUADRATIC;
        long f_plain, f_edit, f_ref, f_ref_edit;
        uint64_t plain = direct_run(kw, 0, 0, &f_plain), edited = direct_run(kw, 0, 1, &f_edit);
        uint64_t ref = direct_run(kw, 1, 0, &f_ref), ref_edit = direct_run(kw, 1, 1, &f_ref_edit);
        const char *name = cubic ? "cubic" : "quadratic";
        printf("  direct kf_step, %s: %ld and %ld of 40 scattered early (plain, edited)\n", name, f_plain, f_edit);
        KT_CHECK(plain == ref, "%s: announced steps equal the unfused ones", name);
        KT_CHECK(edited == ref_edit, "%s: an edit through the writable view cancels the early scatter", name);
        KT_CHECK(edited != plain, "%s: the edit changed the result", name);
        /* all but the first, and any after which a particle left its owner
         * (cubic: one here); the edit drops one more */
        KT_CHECK(f_plain >= 38 && f_edit < f_plain,
                 "%s: nearly every substep used an early scatter (%ld of 40), the edited run one fewer (%ld)", name,
                 f_plain, f_edit);
    }
}

int main(int argc, char **argv) {
    KT_RUN(fixed_step, argc, argv);
    KT_RUN(clamped_step, argc, argv);
    KT_RUN(cfl_step, argc, argv);
    KT_RUN(direct_steps, argc, argv);
    KT_RUN(with_bodies, argc, argv);
    KT_RUN(with_static_bodies, argc, argv);
    KT_RUN(with_body_above, argc, argv);
    return KT_EXIT();
}
