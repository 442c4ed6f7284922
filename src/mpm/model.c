/* model.c — settings, defaults, and compiling materials and colliders. */
#include <math.h>
#include <omp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "model.h"
#include "sdf_grid.h"

kf_sim_def kf_default_sim_def(void) {
    kf_sim_def d;
    memset(&d, 0, sizeof d);
    d.dx = 0.02;
    d.cfl = 0.4;
    d.gravity[1] = -9.81;
    d.kernel = KF_KERNEL_QUADRATIC;
    d.force = KF_FORCE_MLS;
    d.transfer = KF_TRANSFER_APIC;
    d.flip_ratio = 0.95;
    d.walls = 0;
    for (int a = 0; a < 3; a++) d.domain_min[a] = 0, d.domain_max[a] = 1;
    d.wall_boundary = KF_BOUNDARY_SEPARATE;
    d.wall_friction = 0;
    d.max_retries = 4;
    d.j_min = 1e-3;
    d.j_max = 1e3;
    d.max_cells_per_step = 1.0;
    /* implicit integration; explicit stays the default */
    d.integrator = KF_INTEGRATOR_EXPLICIT;
    d.newton_tol = 1e-3;
    d.newton_max = 20;
    d.krylov_tol = 1e-2;
    d.krylov_max = 200;
    return d;
}

static int fail(char *err, size_t n, const char *msg) {
    if (err && n) snprintf(err, n, "%s", msg);
    return -1;
}

kf_model *kf_model_create(const kf_sim_def *def, char *err, size_t errlen) {
    const char *bad = NULL;
    if (!(def->dx > 0 && isfinite(def->dx))) bad = "dx must be a positive length";
    else if (!(def->cfl > 0 && def->cfl <= 2)) bad = "cfl must be in (0, 2]";
    else if (def->walls) {
        for (int a = 0; a < 3; a++)
            if (!(def->domain_max[a] > def->domain_min[a])) bad = "domain max must exceed min on every axis";
    }
    if (!bad && !(def->j_min > 0 && def->j_max > def->j_min)) bad = "j_min must be positive and below j_max";
    if (!bad && !(def->integrator == KF_INTEGRATOR_EXPLICIT || def->integrator == KF_INTEGRATOR_IMPLICIT))
        bad = "integrator must be explicit or implicit";
    if (!bad && !(def->implicit_scheme == KF_SCHEME_BACKWARD_EULER || def->implicit_scheme == KF_SCHEME_MIDPOINT))
        bad = "implicit_scheme must be backward_euler or midpoint";
    if (!bad && !(def->transfer == KF_TRANSFER_APIC || def->transfer == KF_TRANSFER_PIC ||
                  def->transfer == KF_TRANSFER_FLIP || def->transfer == KF_TRANSFER_POLYPIC))
        bad = "transfer must be apic, pic, flip or polypic";
    /* the modes are those of the quadratic kernel's 3x3x3 stencil */
    if (!bad && def->transfer == KF_TRANSFER_POLYPIC && def->kernel != KF_KERNEL_QUADRATIC)
        bad = "the polypic transfer needs the quadratic kernel (sim.kernel: quadratic)";
    if (!bad && def->transfer == KF_TRANSFER_POLYPIC && def->integrator == KF_INTEGRATOR_IMPLICIT)
        bad = "the polypic transfer needs the explicit integrator (sim.integrator: explicit)";
    if (!bad && def->transfer == KF_TRANSFER_FLIP && !(def->flip_ratio >= 0 && def->flip_ratio <= 1))
        bad = "flip_ratio must be in [0, 1]";
    /* the implicit solve makes its own grid velocities and keeps no old ones */
    if (!bad && def->transfer == KF_TRANSFER_FLIP && def->integrator == KF_INTEGRATOR_IMPLICIT)
        bad = "the flip transfer needs the explicit integrator (sim.integrator: explicit)";
    if (!bad && !(def->newton_tol >= 0 && def->krylov_tol >= 0 && def->newton_max >= 0 && def->krylov_max >= 0))
        bad = "newton_tol, krylov_tol, newton_max and krylov_max must be >= 0 (0 = default)";
    if (bad) {
        fail(err, errlen, bad);
        return NULL;
    }
    kf_model *m = calloc(1, sizeof *m);
    if (!m) {
        fail(err, errlen, "out of memory");
        return NULL;
    }
    m->sim = *def;
    m->nthreads = def->threads > 0 ? def->threads : omp_get_max_threads();
    return m;
}

void kf_model_destroy(kf_model *m) {
    if (!m) return;
    for (int c = 0; c < m->ncol; c++) /* the model's own copies of mesh distance fields */
        if (m->col[c].shape == KF_SHAPE_MESH) free((void *)m->col[c].sdf);
    for (int r = 0; r < m->nrigid; r++) kf_rigid_body_free(&m->rigid[r]);
    free(m);
}

const kf_sim_def *kf_model_sim(const kf_model *m) { return &m->sim; }

int kf_model_add_material(kf_model *m, const kf_material *mat, char *err, size_t errlen) {
    if (m->nmat >= KF_MAX_MATERIALS) return fail(err, errlen, "too many materials (at most 64)");
    const char *bad = kf_material_check(mat);
    if (bad && bad[0]) return fail(err, errlen, bad);
    if (mat->model == KF_MAT_WATER && m->sim.integrator == KF_INTEGRATOR_IMPLICIT)
        return fail(err, errlen,
                    "water needs the explicit integrator (sim.integrator: explicit): the implicit solve "
                    "covers the elastic and elastoplastic solids");
    int id = m->nmat++;
    m->mat_def[id] = *mat;
    kf_mat_compile(&m->mat[id], mat);
    if (m->mat[id].plastic) m->any_plastic = 1;
    return id;
}

static int finite3(const double v[3]) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

int kf_model_add_collider(kf_model *m, const kf_collider *c, char *err, size_t errlen) {
    if (m->ncol >= KF_MAX_COLLIDERS) return fail(err, errlen, "too many colliders (at most 64)");
    if ((int)c->shape < KF_SHAPE_PLANE || c->shape > KF_SHAPE_MESH) return fail(err, errlen, "unknown collider shape");
    if (c->shape == KF_SHAPE_SPHERE && !(c->radius > 0)) return fail(err, errlen, "sphere collider needs radius > 0");
    if (c->shape == KF_SHAPE_BOX && !(c->half[0] > 0 && c->half[1] > 0 && c->half[2] > 0))
        return fail(err, errlen, "box collider needs positive half extents");
    if (c->shape == KF_SHAPE_PLANE && !(fabs(c->normal[0]) + fabs(c->normal[1]) + fabs(c->normal[2]) > 0))
        return fail(err, errlen, "plane collider needs a non-zero normal");
    if (c->shape == KF_SHAPE_MESH) {
        const char *bad = kf_sdf_grid_check(c->sdf);
        if (*bad) return fail(err, errlen, bad);
    }
    if (c->inside && c->shape == KF_SHAPE_PLANE)
        return fail(err, errlen, "a plane collider cannot keep material inside");
    if (!finite3(c->center) || !finite3(c->rotate) || !finite3(c->velocity))
        return fail(err, errlen, "collider center, rotate and velocity must be finite");
    if ((int)c->interp < KF_INTERP_LINEAR || c->interp > KF_INTERP_SMOOTH)
        return fail(err, errlen, "unknown collider interpolation");
    if (c->nkeys < 0 || c->nkeys > KF_MAX_KEYS) return fail(err, errlen, "collider has too many keys (at most 64)");
    for (int k = 0; k < c->nkeys; k++) {
        const kf_key *key = &c->keys[k];
        if (!isfinite(key->time) || !finite3(key->position) || !finite3(key->rotate))
            return fail(err, errlen, "collider keys must be finite");
        for (int a = 0; a < 3; a++)
            if (!(key->scale[a] >= 0 && isfinite(key->scale[a]))) /* 0 means 1 */
                return fail(err, errlen, "collider key scale must be > 0");
        if (k > 0 && !(key->time > c->keys[k - 1].time))
            return fail(err, errlen, "collider keys must have increasing times");
    }
    if (!(c->friction >= 0)) return fail(err, errlen, "collider friction must be >= 0");
    kf_collider col = *c;
    if (c->shape == KF_SHAPE_MESH) {
        /* the model keeps its own copy: the caller's field may go away */
        size_t n = kf_sdf_grid_nodes(c->sdf);
        kf_sdf_grid *g = malloc(sizeof *g + n * sizeof(float));
        if (!g) return fail(err, errlen, "out of memory copying the collider's distance field");
        *g = *c->sdf;
        float *phi = (float *)(g + 1);
        memcpy(phi, c->sdf->phi, n * sizeof(float));
        g->phi = phi;
        col.sdf = g;
    } else {
        col.sdf = NULL;
    }
    m->col[m->ncol++] = col;
    return m->ncol - 1;
}

int kf_model_add_rigid(kf_model *m, const kf_rigid_def *r, char *err, size_t errlen) {
    if (m->sim.integrator == KF_INTEGRATOR_IMPLICIT)
        return fail(err, errlen, "rigid bodies (CPIC) need the explicit integrator (sim.integrator: explicit)");
    if (m->nrigid >= KF_MAX_RIGIDS) {
        if (err && errlen)
            snprintf(err, errlen,
                     "too many rigid bodies (at most %d: each takes 2 bits of a grid node's 32-bit colour)",
                     KF_MAX_RIGIDS);
        return -1;
    }
    if (m->sim.kernel != KF_KERNEL_QUADRATIC) return fail(err, errlen, "rigid bodies (CPIC) need the quadratic kernel");
    if (kf_rigid_compile(&m->rigid[m->nrigid], r, m->sim.dx, err, errlen)) return -1;
    return m->nrigid++;
}

int kf_model_add_joint(kf_model *m, const kf_joint_def *j, char *err, size_t errlen) {
    if (m->njoint >= KF_MAX_JOINTS) return fail(err, errlen, "too many joints (at most 32)");
    if (j->body_a < -1 || j->body_a >= m->nrigid || j->body_b < -1 || j->body_b >= m->nrigid || j->body_a == j->body_b)
        return fail(err, errlen, "a joint needs two different bodies (or one body and the world, -1)");
    for (int k = 0; k < 2; k++) {
        int b = k ? j->body_b : j->body_a;
        if (b >= 0 && m->rigid[b].def.motion != KF_RIGID_DYNAMIC)
            return fail(err, errlen, "joints connect dynamic bodies (and the world)");
    }
    if (!finite3(j->anchor) || !finite3(j->axis) || !(fabs(j->axis[0]) + fabs(j->axis[1]) + fabs(j->axis[2]) > 0))
        return fail(err, errlen, "a joint needs a finite anchor and a non-zero axis");
    if (!(j->damping >= 0)) return fail(err, errlen, "joint damping must be >= 0");
    if (j->motor != KF_MOTOR_NONE) {
        if (j->motor != KF_MOTOR_VELOCITY && j->motor != KF_MOTOR_POSITION)
            return fail(err, errlen, "a joint's motor is none, velocity or position");
        if (!(j->torque_limit > 0) || !isfinite(j->torque_limit) || !isfinite(j->frequency) || !isfinite(j->angle))
            return fail(err, errlen, "a motor needs a finite frequency and angle and a torque limit > 0");
        if (!(j->kv >= 0) || !isfinite(j->kv) || (j->motor == KF_MOTOR_VELOCITY && !(j->kv > 0)))
            return fail(err, errlen, "a motor's kv must be >= 0 (> 0 for a velocity motor)");
        if (j->motor == KF_MOTOR_POSITION && (!(j->kp > 0) || !isfinite(j->kp)))
            return fail(err, errlen, "a position motor needs kp > 0");
    }
    m->joint[m->njoint++] = *j;
    return m->njoint - 1;
}

int kf_model_rigid_count(const kf_model *m) { return m->nrigid; }
double kf_model_rigid_mass(const kf_model *m, int body) {
    return body >= 0 && body < m->nrigid ? m->rigid[body].mass : 0;
}
size_t kf_model_rigid_seeds(const kf_model *m, int body) {
    return body >= 0 && body < m->nrigid ? m->rigid[body].nseed : 0;
}
