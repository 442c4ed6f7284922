/* sim.c — the rigid solver (paper §5.1, §5.6): static bodies stay,
 * kinematic bodies follow their keys, dynamic bodies move in a MuJoCo world
 * built from the bodies (mjcf.c): gravity, the material's impulses as a
 * force and torque over the substep, contacts with each other, the static
 * bodies (mocap), the kinematic bodies (heavy free bodies given their keyed
 * pose and velocity every substep) and the walls, and hinges. Without a
 * dynamic body there is no MuJoCo world at all. */
#include <math.h>
#include <mujoco/mujoco.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "mjcf.h"
#include "mjguard.h"
#include "rigid.h"
#include "../core/mat3.h"

struct kf_rigid_sim {
    int nbodies;
    int motion[KF_MAX_RIGIDS];
    double com_mesh[KF_MAX_RIGIDS][3]; /* MuJoCo body origin of a dynamic body, mesh frame */
    mjModel *m;                        /* NULL: no dynamic body */
    mjData *d;
    int bid[KF_MAX_RIGIDS];  /* MuJoCo body id of a dynamic body */
    int *mocap_body;         /* (nmocap) the rigid body each mocap body belongs to */
    int kjnt[KF_MAX_RIGIDS]; /* a kinematic body's free joint, else -1 */
    void *before;            /* the state before the substep (see kf_rigid_sim_step) */
    /* motors: actuator a drives joint act_joint[a] (mjcf.c emits them in joint order) */
    int nact;
    int act_joint[KF_MAX_JOINTS];
    int joint_act[KF_MAX_JOINTS];        /* the actuator of each joint, or -1 */
    kf_joint_def act_def[KF_MAX_JOINTS]; /* (nact) its joint's motor settings */
    double act_peak[KF_MAX_JOINTS];      /* largest |torque| since the last load or reset, N·m */
};

static void set_err(char *err, size_t errlen, const char *msg) {
    if (err && errlen) snprintf(err, errlen, "%s", msg);
}

/* the MJCF text through an in-memory file */
static mjModel *load(const char *xml, char *err, size_t errlen) {
    mjVFS *vfs = malloc(sizeof *vfs);
    if (!vfs) return NULL;
    mj_defaultVFS(vfs);
    mjModel *m = NULL;
    size_t len = strlen(xml);
    if (len < 0x7fffffff && mj_makeEmptyFileVFS(vfs, "kerf.xml", (int)len) == 0) {
        memcpy(vfs->filedata[mj_findFileVFS(vfs, "kerf.xml")], xml, len);
        char e[512] = "";
        m = mj_loadXML("kerf.xml", vfs, e, sizeof e);
        if (!m) snprintf(err, errlen, "rigid solver: MuJoCo rejected the model: %s", e);
    } else {
        set_err(err, errlen, "rigid solver: out of memory");
    }
    mj_deleteVFS(vfs);
    free(vfs);
    return m;
}

/* initial velocities: a free joint's are (v of the com, ω in the body
 * frame); a hinge's is the relative angular velocity along its axis */
static void initial_velocity(kf_rigid_sim *sim, const kf_rigid_body *bodies) {
    const mjModel *m = sim->m;
    mjData *d = sim->d;
    for (int r = 0; r < sim->nbodies; r++) {
        if (sim->motion[r] != KF_RIGID_DYNAMIC) continue;
        int b = sim->bid[r];
        if (m->body_jntnum[b] < 1) continue;
        int j = m->body_jntadr[b], dof = m->jnt_dofadr[j];
        const kf_rigid_def *def = &bodies[r].def;
        double R[9];
        memcpy(R, d->xmat + 9 * b, sizeof R);
        if (m->jnt_type[j] == mjJNT_FREE) {
            double wl[3];
            kf_m3d_mtv(wl, R, def->angular_velocity);
            for (int a = 0; a < 3; a++) d->qvel[dof + a] = def->velocity[a], d->qvel[dof + 3 + a] = wl[a];
        } else if (m->jnt_type[j] == mjJNT_HINGE) {
            double ax[3], wp[3] = {0, 0, 0};
            kf_m3d_mv(ax, R, m->jnt_axis + 3 * j);
            int p = m->body_parentid[b];
            for (int k = 0; k < sim->nbodies; k++)
                if (sim->bid[k] == p) memcpy(wp, bodies[k].def.angular_velocity, sizeof wp);
            double rel[3] = {def->angular_velocity[0] - wp[0], def->angular_velocity[1] - wp[1],
                             def->angular_velocity[2] - wp[2]};
            d->qvel[dof] = kf_v3d_dot(rel, ax);
        }
    }
}

kf_rigid_sim *kf_rigid_sim_create(const kf_rigid_body *bodies, int nbodies, const kf_joint_def *joints, int njoints,
                                  const double gravity[3], const double *walls, char *err, size_t errlen) {
    if (nbodies < 0 || nbodies > KF_MAX_RIGIDS) {
        if (err && errlen) snprintf(err, errlen, "rigid solver: %d bodies, at most %d", nbodies, KF_MAX_RIGIDS);
        return NULL;
    }
    kf_rigid_sim *sim = calloc(1, sizeof *sim);
    if (!sim) {
        set_err(err, errlen, "rigid solver: out of memory");
        return NULL;
    }
    sim->nbodies = nbodies;
    int ndyn = 0;
    for (int r = 0; r < KF_MAX_RIGIDS; r++) sim->bid[r] = sim->kjnt[r] = -1;
    for (int r = 0; r < nbodies; r++) {
        sim->motion[r] = bodies[r].def.motion;
        memcpy(sim->com_mesh[r], bodies[r].com, sizeof bodies[r].com);
        ndyn += sim->motion[r] == KF_RIGID_DYNAMIC;
    }
    if (!ndyn) {
        if (njoints > 0) {
            set_err(err, errlen, "rigid solver: joints need a dynamic body");
            free(sim);
            return NULL;
        }
        return sim;
    }
    char *xml = kf_rigid_mjcf(bodies, nbodies, joints, njoints, gravity, walls, NULL, err, errlen);
    if (!xml) {
        free(sim);
        return NULL;
    }
    kf_mj_hooks();
    kf_mj_clear();
    jmp_buf jb;
    if (setjmp(jb)) {
        /* MuJoCo failed inside; what it allocated is lost */
        kf_mj_guard(NULL);
        set_err(err, errlen, kf_mj_message());
        free(xml);
        free(sim);
        return NULL;
    }
    kf_mj_guard(&jb);
    sim->m = load(xml, err, errlen);
    if (sim->m) sim->d = mj_makeData(sim->m);
    kf_mj_guard(NULL);
    free(xml);
    if (!sim->m || !sim->d) {
        if (sim->m && !sim->d) set_err(err, errlen, "rigid solver: out of memory");
        kf_rigid_sim_destroy(sim);
        return NULL;
    }
    for (int r = 0; r < nbodies; r++) {
        char name[16];
        snprintf(name, sizeof name, "b%d", r);
        sim->bid[r] = sim->motion[r] == KF_RIGID_DYNAMIC ? mj_name2id(sim->m, mjOBJ_BODY, name) : -1;
        snprintf(name, sizeof name, "b%d_0", r);
        int kb = sim->motion[r] == KF_RIGID_KINEMATIC ? mj_name2id(sim->m, mjOBJ_BODY, name) : -1;
        sim->kjnt[r] = kb >= 0 && sim->m->body_jntnum[kb] == 1 ? sim->m->body_jntadr[kb] : -1;
    }
    /* the mocap bodies' owners, from their names b<r>_<k> */
    sim->mocap_body = calloc((size_t)(sim->m->nmocap ? sim->m->nmocap : 1), sizeof(int));
    if (!sim->mocap_body) {
        set_err(err, errlen, "rigid solver: out of memory");
        kf_rigid_sim_destroy(sim);
        return NULL;
    }
    for (int b = 0; b < sim->m->nbody; b++) {
        int mc = sim->m->body_mocapid[b], r = -1, k;
        const char *name = mj_id2name(sim->m, mjOBJ_BODY, b);
        if (mc >= 0) {
            if (!name || sscanf(name, "b%d_%d", &r, &k) != 2 || r < 0 || r >= nbodies) {
                set_err(err, errlen, "rigid solver: a MuJoCo mocap body without an owner");
                kf_rigid_sim_destroy(sim);
                return NULL;
            }
            sim->mocap_body[mc] = r;
        }
    }
    sim->before = malloc(kf_rigid_sim_state_size(sim));
    if (!sim->before) {
        set_err(err, errlen, "rigid solver: out of memory");
        kf_rigid_sim_destroy(sim);
        return NULL;
    }
    /* the motors, in joint order as mjcf.c wrote them */
    for (int k = 0; k < KF_MAX_JOINTS; k++) sim->joint_act[k] = -1;
    for (int k = 0; k < njoints && k < KF_MAX_JOINTS; k++)
        if (joints[k].motor != KF_MOTOR_NONE) {
            sim->joint_act[k] = sim->nact;
            sim->act_joint[sim->nact] = k;
            sim->act_def[sim->nact++] = joints[k];
        }
    if (sim->nact != sim->m->nu) {
        set_err(err, errlen, "rigid solver: the motors did not become MuJoCo actuators");
        kf_rigid_sim_destroy(sim);
        return NULL;
    }
    mj_kinematics(sim->m, sim->d);
    initial_velocity(sim, bodies);
    return sim;
}

void kf_rigid_sim_destroy(kf_rigid_sim *sim) {
    if (!sim) return;
    if (sim->d) mj_deleteData(sim->d);
    if (sim->m) mj_deleteModel(sim->m);
    free(sim->mocap_body);
    free(sim->before);
    free(sim);
}

kf_rigid_sim *kf_rigid_sim_clone(const kf_rigid_sim *sim) {
    kf_rigid_sim *volatile c = malloc(sizeof *c); /* volatile: read after a longjmp */
    if (!c) return NULL;
    *c = *sim;
    c->m = NULL, c->d = NULL, c->mocap_body = NULL, c->before = NULL;
    if (!sim->m) return c;
    size_t nm = (size_t)(sim->m->nmocap ? sim->m->nmocap : 1);
    c->mocap_body = malloc(sizeof(int) * nm);
    c->before = malloc(kf_rigid_sim_state_size(sim));
    if (!c->mocap_body || !c->before) {
        free(c->mocap_body);
        free(c->before);
        free(c);
        return NULL;
    }
    memcpy(c->mocap_body, sim->mocap_body, sizeof(int) * nm);
    jmp_buf jb;
    if (setjmp(jb)) {
        kf_mj_guard(NULL);
        free(c->mocap_body);
        free(c->before);
        free(c);
        return NULL;
    }
    kf_mj_guard(&jb);
    c->m = mj_copyModel(NULL, sim->m);
    if (c->m) c->d = mj_copyData(NULL, c->m, sim->d);
    kf_mj_guard(NULL);
    if (!c->d) {
        kf_rigid_sim_destroy(c);
        return NULL;
    }
    return c;
}

/* a dynamic body's state from MuJoCo's (positions and com velocities current) */
static void read_body(const kf_rigid_sim *sim, int r, kf_rigid_state *st) {
    const int b = sim->bid[r];
    memcpy(st->R, sim->d->xmat + 9 * b, sizeof st->R);
    memcpy(st->com, sim->d->xpos + 3 * b, sizeof st->com);
    double Rc[3], vel[6];
    kf_m3d_mv(Rc, st->R, sim->com_mesh[r]);
    for (int a = 0; a < 3; a++) st->t[a] = st->com[a] - Rc[a];
    mj_objectVelocity(sim->m, sim->d, mjOBJ_BODY, b, vel, 0); /* (ω, v) at the com, world axes */
    memcpy(st->w, vel, 3 * sizeof(double));
    memcpy(st->v, vel + 3, 3 * sizeof(double));
}

/* MuJoCo's count of the warnings after which it resets the world */
static int bad_count(const mjData *d) {
    return d->warning[mjWARN_BADQPOS].number + d->warning[mjWARN_BADQVEL].number + d->warning[mjWARN_BADQACC].number;
}

/* back to the state before the substep, at rest, a substep later */
static void stop(kf_rigid_sim *sim, double dt) {
    kf_rigid_sim_load(sim, sim->before, kf_rigid_sim_state_size(sim));
    sim->d->time += dt;
    mju_zero(sim->d->qvel, sim->m->nv);
    mju_zero(sim->d->qacc_warmstart, sim->m->nv);
}

void kf_rigid_sim_step(kf_rigid_sim *sim, const kf_rigid_body *bodies, int nbodies, kf_rigid_state *st, double t,
                       double dt, const double (*impulse)[6]) {
    for (int r = 0; r < nbodies; r++)
        if (bodies[r].def.motion != KF_RIGID_DYNAMIC) kf_rigid_state_at(&bodies[r], t + dt, &st[r]);
    if (!sim->m || !(dt > 0)) return;
    mjData *d = sim->d;
    /* kinematic bodies where they are at the start of the substep, moving as
     * their keys say */
    for (int r = 0; r < nbodies; r++) {
        if (sim->kjnt[r] < 0) continue;
        kf_rigid_state k;
        kf_rigid_state_at(&bodies[r], t, &k);
        const int qa = sim->m->jnt_qposadr[sim->kjnt[r]], da = sim->m->jnt_dofadr[sim->kjnt[r]];
        /* the free joint moves the mesh-frame origin t: v + ω × (t - pivot); ω in the body frame */
        double rel[3] = {k.t[0] - k.com[0], k.t[1] - k.com[1], k.t[2] - k.com[2]}, wx[3], wl[3];
        kf_v3d_cross(wx, k.w, rel);
        kf_m3d_mtv(wl, k.R, k.w);
        for (int a = 0; a < 3; a++) {
            d->qpos[qa + a] = k.t[a];
            d->qvel[da + a] = k.v[a] + wx[a];
            d->qvel[da + 3 + a] = wl[a];
        }
        kf_m3d_to_quat(d->qpos + qa + 3, k.R);
        /* and weightless: a force cancels gravity on it */
        const int kb = sim->m->jnt_bodyid[sim->kjnt[r]];
        for (int a = 0; a < 3; a++) d->xfrc_applied[6 * kb + a] = -sim->m->body_mass[kb] * sim->m->opt.gravity[a];
    }
    /* static bodies (mocap) where they are */
    for (int mc = 0; mc < sim->m->nmocap; mc++) {
        const kf_rigid_state *s = &st[sim->mocap_body[mc]];
        memcpy(d->mocap_pos + 3 * mc, s->t, 3 * sizeof(double));
        kf_m3d_to_quat(d->mocap_quat + 4 * mc, s->R);
    }
    /* the substep's impulses as a constant force and torque at the com */
    if (impulse)
        for (int r = 0; r < nbodies; r++)
            if (sim->bid[r] >= 0)
                for (int k = 0; k < 6; k++) d->xfrc_applied[6 * sim->bid[r] + k] = impulse[r][k] / dt;
    /* the motors' commands: the target rate 2 pi f, and a position motor's
     * target angle advancing at it, at the substep's start, when MuJoCo's
     * Euler step evaluates the force; the rate term is folded in (mjcf.c:
     * force = gain ctrl + bias) */
    for (int a = 0; a < sim->nact; a++) {
        const kf_joint_def *jd = &sim->act_def[a];
        const double rate = 2 * mjPI * jd->frequency;
        if (jd->motor == KF_MOTOR_POSITION) d->ctrl[a] = jd->angle * (mjPI / 180) + rate * t + jd->kv / jd->kp * rate;
        else d->ctrl[a] = rate;
    }
    sim->m->opt.timestep = dt;
    /* MuJoCo answers a non-finite or huge acceleration by resetting the whole
     * world to its initial pose, and an engine error leaves it half-stepped;
     * kerf keeps the bodies where they were and stops them instead (the
     * message is in kf_mj_message) */
    kf_rigid_sim_save(sim, sim->before);
    const int bad0 = bad_count(d);
    const double t1 = d->time + dt; /* as mj_step advances it */
    jmp_buf jb;
    if (setjmp(jb)) {
        kf_mj_guard(NULL);
        stop(sim, dt);
    } else {
        kf_mj_guard(&jb);
        mj_step(sim->m, d);
        kf_mj_guard(NULL);
        /* a reset shows in the counts (it clears them, then counts one) or the time */
        if (bad_count(d) != bad0 || d->time != t1) stop(sim, dt);
    }
    mju_zero(d->xfrc_applied, 6 * sim->m->nbody);
    /* the torque each motor gave in the substep (already clipped to its limit) */
    for (int a = 0; a < sim->nact; a++)
        if (fabs(d->actuator_force[a]) > sim->act_peak[a]) sim->act_peak[a] = fabs(d->actuator_force[a]);
    /* positions and velocities of the new state: the bodies' only. The
     * geoms' and sites' poses are the next mj_step's first work (from the
     * same qpos) and nothing reads them before it, so MuJoCo's kinematics
     * runs with their counts set to zero for the call (a thin body's 256
     * pieces made half of it); the bodies' poses are its same code, bit for bit */
    const int ngeom = sim->m->ngeom, nsite = sim->m->nsite;
    sim->m->ngeom = 0, sim->m->nsite = 0;
    mj_kinematics(sim->m, d);
    sim->m->ngeom = ngeom, sim->m->nsite = nsite;
    mj_comPos(sim->m, d);
    mj_comVel(sim->m, d);
    for (int r = 0; r < nbodies; r++)
        if (sim->bid[r] >= 0) read_body(sim, r, &st[r]);
}

/* ---- checkpoints: everything mj_step reads that is not in the model ------ */

typedef struct blob_header {
    uint32_t magic, nq, nv, na, nmocap, pad;
} blob_header;

#define BLOB_MAGIC 0x6b726d6aU /* "jmrk" */

static size_t nvals(const mjModel *m) {
    return 1 + (size_t)m->nq + 2 * (size_t)m->nv + (size_t)m->na + 7 * (size_t)m->nmocap;
}

size_t kf_rigid_sim_state_size(const kf_rigid_sim *sim) {
    if (!sim || !sim->m) return 0;
    return sizeof(blob_header) + sizeof(double) * nvals(sim->m);
}

void kf_rigid_sim_save(const kf_rigid_sim *sim, void *buf) {
    if (!sim || !sim->m) return;
    const mjModel *m = sim->m;
    const mjData *d = sim->d;
    blob_header h = {BLOB_MAGIC, (uint32_t)m->nq, (uint32_t)m->nv, (uint32_t)m->na, (uint32_t)m->nmocap, 0};
    char *p = buf;
    memcpy(p, &h, sizeof h);
    p += sizeof h;
#define PUT(src, n)                                                                                                    \
    do {                                                                                                               \
        memcpy(p, (src), sizeof(double) * (size_t)(n));                                                                \
        p += sizeof(double) * (size_t)(n);                                                                             \
    } while (0)
    PUT(&d->time, 1);
    PUT(d->qpos, m->nq);
    PUT(d->qvel, m->nv);
    PUT(d->qacc_warmstart, m->nv);
    PUT(d->act, m->na);
    PUT(d->mocap_pos, 3 * m->nmocap);
    PUT(d->mocap_quat, 4 * m->nmocap);
#undef PUT
}

int kf_rigid_sim_load(kf_rigid_sim *sim, const void *buf, size_t size) {
    if (!sim) return -1;
    if (!sim->m) return size == 0 ? 0 : -1;
    const mjModel *m = sim->m;
    mjData *d = sim->d;
    blob_header h;
    if (size != kf_rigid_sim_state_size(sim)) return -1;
    memcpy(&h, buf, sizeof h);
    if (h.magic != BLOB_MAGIC || h.nq != (uint32_t)m->nq || h.nv != (uint32_t)m->nv || h.na != (uint32_t)m->na ||
        h.nmocap != (uint32_t)m->nmocap)
        return -1;
    const char *p = (const char *)buf + sizeof h;
#define GET(dst, n)                                                                                                    \
    do {                                                                                                               \
        memcpy((dst), p, sizeof(double) * (size_t)(n));                                                                \
        p += sizeof(double) * (size_t)(n);                                                                             \
    } while (0)
    GET(&d->time, 1);
    GET(d->qpos, m->nq);
    GET(d->qvel, m->nv);
    GET(d->qacc_warmstart, m->nv);
    GET(d->act, m->na);
    GET(d->mocap_pos, 3 * m->nmocap);
    GET(d->mocap_quat, 4 * m->nmocap);
#undef GET
    mju_zero(d->xfrc_applied, 6 * m->nbody);
    kf_rigid_sim_peak_reset(sim);
    return 0;
}

/* ---- motors ----------------------------------------------------------------- */

int kf_rigid_sim_motor_torque(const kf_rigid_sim *sim, int joint, double *now, double *peak) {
    if (!sim || !sim->m || joint < 0 || joint >= KF_MAX_JOINTS || sim->joint_act[joint] < 0) return -1;
    const int a = sim->joint_act[joint];
    if (now) *now = sim->d->actuator_force[a];
    if (peak) *peak = sim->act_peak[a];
    return 0;
}

void kf_rigid_sim_peak_reset(kf_rigid_sim *sim) {
    if (sim) memset(sim->act_peak, 0, sizeof sim->act_peak);
}
