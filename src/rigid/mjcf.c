/* mjcf.c — MJCF text for the rigid bodies (see mjcf.h); the geometry of
 * each body comes from mjcf_geoms.c.
 *
 * Collision groups: dynamic geoms contype 1, conaffinity 1; static,
 * kinematic and wall geoms contype 2, conaffinity 1. So dynamic bodies touch
 * everything and the moved-by-us geoms never touch each other. Static
 * bodies are mocap bodies; kinematic ones heavy free bodies (emit_body).
 *
 * Joints: a hinge to the world (or a static body) or between two dynamic
 * bodies becomes a real hinge joint in MuJoCo's kinematic tree when the
 * child has no other parent; otherwise (cycles, kinematic partners) two
 * ball-joint "connect" equalities on the axis, a body length apart. */
#include "mjcf.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "mjcf_geoms.h"
#include "../core/mat3.h"
#include "strbuf.h"

/* world frame of the MuJoCo body of r at time 0: origin o, axes R */
typedef struct frame {
    double o[3], R[9];
} frame;

typedef struct ctx {
    const kf_rigid_body *b;
    int n;
    const kf_joint_def *j;
    int parent[KF_MAX_RIGIDS]; /* -2 free, -1 world hinge, else a body */
    int pjoint[KF_MAX_RIGIDS]; /* the joint to the parent */
    frame f[KF_MAX_RIGIDS];
    kf_mj_text x;    /* the assets and bodies so far */
    double heaviest; /* the largest dynamic mass, kg */
} ctx;

static int dynamic(const ctx *c, int r) { return r >= 0 && r < c->n && c->b[r].def.motion == KF_RIGID_DYNAMIC; }
/* the world, or a body that never moves */
static int worldlike(const ctx *c, int r) {
    return r == -1 || (r >= 0 && r < c->n && c->b[r].def.motion == KF_RIGID_STATIC);
}

static void quat_attr(kf_strbuf *s, const double R[9]) {
    double q[4];
    kf_m3d_to_quat(q, R);
    kf_sb_printf(s, " quat=\"%.17g %.17g %.17g %.17g\"", q[0], q[1], q[2], q[3]);
}

static void emit_body(ctx *c, int r, const frame *pf) {
    const kf_rigid_body *b = &c->b[r];
    const frame *f = &c->f[r];
    /* pose relative to the parent frame (world: identity) */
    double d[3] = {f->o[0], f->o[1], f->o[2]}, Rrel[9];
    if (pf) {
        double w[3] = {f->o[0] - pf->o[0], f->o[1] - pf->o[1], f->o[2] - pf->o[2]};
        kf_m3d_mtv(d, pf->R, w);
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
                Rrel[3 * i + k] = pf->R[i] * f->R[k] + pf->R[3 + i] * f->R[3 + k] + pf->R[6 + i] * f->R[6 + k];
    } else {
        memcpy(Rrel, f->R, sizeof Rrel);
    }
    if (b->def.motion != KF_RIGID_DYNAMIC) {
        /* b<r>_0 in the mesh frame's pose: a static body is a mocap body; a
         * kinematic one is a free body a million times heavier than the
         * heaviest dynamic body, whose pose and velocity the solver sets
         * before every substep (MuJoCo's contacts see a mocap body's motion
         * only as a change of position, not as a velocity, so a moving
         * mocap body would not drag what rests on it) */
        const double zero[3] = {0, 0, 0};
        const int kin = b->def.motion == KF_RIGID_KINEMATIC;
        kf_sb_printf(&c->x.body, "<body name=\"b%d_0\"%s pos=\"%.17g %.17g %.17g\"", r, kin ? "" : " mocap=\"true\"",
                     d[0], d[1], d[2]);
        quat_attr(&c->x.body, Rrel);
        kf_sb_printf(&c->x.body, ">\n");
        if (kin) {
            double M = 1e6 * c->heaviest, e = kf_mj_extent(b), I = M * e * e / 6;
            kf_sb_printf(&c->x.body,
                         "<freejoint/>\n<inertial pos=\"0 0 0\" mass=\"%.17g\" diaginertia=\"%.17g %.17g %.17g\"/>\n",
                         M, I, I, I);
        }
        kf_mj_geoms(&c->x, b, r, zero);
        kf_sb_printf(&c->x.body, "</body>\n");
        return;
    }
    kf_sb_printf(&c->x.body, "<body name=\"b%d\" pos=\"%.17g %.17g %.17g\"", r, d[0], d[1], d[2]);
    quat_attr(&c->x.body, Rrel);
    kf_sb_printf(&c->x.body, ">\n");
    if (c->parent[r] == -2) {
        kf_sb_printf(&c->x.body, "<freejoint/>\n");
    } else {
        const kf_joint_def *jd = &c->j[c->pjoint[r]];
        double w[3] = {jd->anchor[0] - f->o[0], jd->anchor[1] - f->o[1], jd->anchor[2] - f->o[2]}, p[3], ax[3];
        kf_m3d_mtv(p, f->R, w);
        kf_m3d_mtv(ax, f->R, jd->axis);
        kf_sb_printf(&c->x.body,
                     "<joint name=\"j%d\" type=\"hinge\" pos=\"%.17g %.17g %.17g\" axis=\"%.17g %.17g %.17g\" "
                     "damping=\"%.17g\"/>\n",
                     c->pjoint[r], p[0], p[1], p[2], ax[0], ax[1], ax[2], jd->damping);
    }
    /* the inertia about the com, mesh axes; a hair of isotropic inertia keeps a
     * flat shell (Izz = Ixx + Iyy exactly) inside MuJoCo's triangle inequality */
    const double *I = b->inertia;
    double eps = 1e-9 * (I[0] + I[4] + I[8]);
    kf_sb_printf(&c->x.body,
                 "<inertial pos=\"0 0 0\" mass=\"%.17g\" fullinertia=\"%.17g %.17g %.17g %.17g %.17g %.17g\"/>\n",
                 b->mass, I[0] + eps, I[4] + eps, I[8] + eps, I[1], I[2], I[5]);
    kf_mj_geoms(&c->x, b, r, b->com);
    for (int k = 0; k < c->n; k++)
        if (c->parent[k] == r) emit_body(c, k, f);
    kf_sb_printf(&c->x.body, "</body>\n");
}

/* Whether dynamic body r, hinged in MuJoCo's tree to the world or a static
 * body, can never reach a wall. Turning about the hinge, each point keeps
 * its distance s along the axis from the anchor and its distance rho from
 * the axis line, so along a wall's normal e it stays within s (e.a) ±
 * rho |e - (e.a) a| of the anchor. The body's geoms (hull, pieces or
 * corner spheres) lie within its vertices' hull grown by the pieces' half
 * thickness (2e-3 of the extent): a pad of 1% of the extent covers it and
 * MuJoCo's round-off, and walls have no contact margin. Such a body gets an
 * <exclude> with the world (the walls are the world body's only geoms): it
 * has no wall contact either way, and MuJoCo no longer tests each of its
 * pieces against each wall plane every substep (sand_paddles: 256 pieces a
 * paddle, 6 planes, 4 paddles). */
static int walls_out_of_reach(const ctx *c, int r, const double *walls) {
    if (!walls || !dynamic(c, r) || c->parent[r] != -1) return 0;
    const kf_rigid_body *b = &c->b[r];
    const kf_joint_def *jd = &c->j[c->pjoint[r]];
    const double len = sqrt(kf_v3d_dot(jd->axis, jd->axis));
    const double ax[3] = {jd->axis[0] / len, jd->axis[1] / len, jd->axis[2] / len};
    kf_rigid_state st;
    kf_rigid_state_at(b, 0, &st);
    const double pad = 0.01 * kf_mj_extent(b);
    for (int a = 0; a < 3; a++) {
        /* |e - (e.a) a| for the wall normal e along axis a */
        const double across = sqrt(fmax(0, 1 - ax[a] * ax[a]));
        double lo = INFINITY, hi = -INFINITY;
        for (int i = 0; i < b->nvert; i++) {
            double x[3], d[3];
            kf_m3d_mv(x, st.R, b->vert + 3 * i);
            for (int k = 0; k < 3; k++) d[k] = x[k] + st.t[k] - jd->anchor[k];
            const double s = kf_v3d_dot(d, ax);
            double perp[3] = {d[0] - s * ax[0], d[1] - s * ax[1], d[2] - s * ax[2]};
            const double rho = sqrt(kf_v3d_dot(perp, perp));
            lo = fmin(lo, s * ax[a] - rho * across);
            hi = fmax(hi, s * ax[a] + rho * across);
        }
        if (!(jd->anchor[a] + lo - pad > walls[a] && jd->anchor[a] + hi + pad < walls[3 + a])) return 0;
    }
    return 1;
}

/* is a a descendant of (or equal to) b in the tree so far */
static int descends(const ctx *c, int a, int b) {
    for (int guard = 0; a >= 0 && guard <= c->n; guard++, a = c->parent[a])
        if (a == b) return 1;
    return 0;
}

char *kf_rigid_mjcf(const kf_rigid_body *bodies, int nbodies, const kf_joint_def *joints, int njoints,
                    const double gravity[3], const double *walls, int *joint_kind, char *err, size_t errlen) {
    ctx c;
    memset(&c, 0, sizeof c);
    c.b = bodies, c.n = nbodies, c.j = joints;
    if (nbodies > KF_MAX_RIGIDS || njoints > KF_MAX_JOINTS) {
        snprintf(err, errlen, "rigid solver: %d bodies and %d joints, at most %d and %d", nbodies, njoints,
                 KF_MAX_RIGIDS, KF_MAX_JOINTS);
        return NULL;
    }
    c.heaviest = 1e-6;
    for (int r = 0; r < nbodies; r++) {
        if (bodies[r].def.motion == KF_RIGID_DYNAMIC) c.heaviest = fmax(c.heaviest, bodies[r].mass);
        c.parent[r] = -2;
        kf_rigid_state st;
        kf_rigid_state_at(&bodies[r], 0, &st);
        memcpy(c.f[r].R, st.R, sizeof st.R);
        const int dyn = bodies[r].def.motion == KF_RIGID_DYNAMIC;
        memcpy(c.f[r].o, dyn ? st.com : st.t, sizeof st.t);
    }
    kf_strbuf eq = {0}, ex = {0};
    for (int k = 0; k < njoints; k++) {
        const kf_joint_def *jd = &joints[k];
        int a = jd->body_a, b = jd->body_b;
        double len = sqrt(kf_v3d_dot(jd->axis, jd->axis));
        if (a < -1 || a >= nbodies || b < -1 || b >= nbodies || a == b || !(len > 0)) {
            snprintf(err, errlen,
                     "joint %d: bodies %d and %d (need two different bodies in [-1, %d)) and a nonzero axis", k, a, b,
                     nbodies);
            free(eq.s);
            free(ex.s);
            return NULL;
        }
        if (!dynamic(&c, a) && !dynamic(&c, b)) {
            snprintf(err, errlen, "joint %d: neither body %d nor body %d is dynamic", k, a, b);
            free(eq.s);
            free(ex.s);
            return NULL;
        }
        int kind = KF_MJ_JOINT_CONNECT;
        if (worldlike(&c, a) || worldlike(&c, b)) {
            int d = worldlike(&c, a) ? b : a;
            if (c.parent[d] == -2) c.parent[d] = -1, c.pjoint[d] = k, kind = KF_MJ_JOINT_TREE;
        } else if (dynamic(&c, a) && dynamic(&c, b)) {
            if (c.parent[b] == -2 && !descends(&c, a, b)) c.parent[b] = a, c.pjoint[b] = k, kind = KF_MJ_JOINT_TREE;
            else if (c.parent[a] == -2 && !descends(&c, b, a))
                c.parent[a] = b, c.pjoint[a] = k, kind = KF_MJ_JOINT_TREE;
        }
        if (joint_kind) joint_kind[k] = kind;
        /* jointed bodies do not collide with each other (an axle in its wheel) */
        if (a >= 0 && b >= 0)
            kf_sb_printf(&ex, "<exclude body1=\"b%d%s\" body2=\"b%d%s\"/>\n", a, dynamic(&c, a) ? "" : "_0", b,
                         dynamic(&c, b) ? "" : "_0");
        if (kind == KF_MJ_JOINT_CONNECT) {
            /* two ball joints on the axis keep both the anchor and the axis */
            int d = dynamic(&c, a) ? a : b, o = d == a ? b : a;
            double half = 0.5 * kf_mj_extent(&bodies[d]);
            for (int s = -1; s <= 1; s += 2) {
                double p[3], w[3], q[3];
                for (int i = 0; i < 3; i++) p[i] = jd->anchor[i] + s * half * jd->axis[i] / len;
                for (int i = 0; i < 3; i++) w[i] = p[i] - c.f[d].o[i];
                kf_m3d_mtv(q, c.f[d].R, w);
                if (o >= 0)
                    kf_sb_printf(
                        &eq,
                        "<connect body1=\"b%d\" body2=\"b%d%s\" anchor=\"%.17g %.17g %.17g\" solref=\"0.004 1\"/>\n", d,
                        o, dynamic(&c, o) ? "" : "_0", q[0], q[1], q[2]);
                else
                    kf_sb_printf(&eq, "<connect body1=\"b%d\" anchor=\"%.17g %.17g %.17g\" solref=\"0.004 1\"/>\n", d,
                                 q[0], q[1], q[2]);
            }
        }
    }
    /* hinged bodies the walls cannot reach are not tested against them */
    for (int r = 0; r < nbodies; r++)
        if (walls_out_of_reach(&c, r, walls)) kf_sb_printf(&ex, "<exclude body1=\"world\" body2=\"b%d\"/>\n", r);
    for (int r = 0; r < nbodies; r++)
        if (c.parent[r] < 0) emit_body(&c, r, NULL);
    /* motors: one actuator per motored joint, in joint order, on the hinge
     * of its child body; the gear's sign makes it turn body_a relative to
     * body_b about +axis whichever of the two MuJoCo made the child. Its
     * force is gain ctrl + bias: position kp ctrl - kp angle - kv rate
     * (the solver sets ctrl = target + kv/kp target rate), velocity
     * kv ctrl - kv rate (ctrl = target rate); clipped to the torque limit. */
    kf_strbuf act = {0};
    for (int k = 0; k < njoints; k++) {
        const kf_joint_def *jd = &joints[k];
        if (jd->motor == KF_MOTOR_NONE) continue;
        int child = -1;
        for (int r = 0; r < nbodies; r++)
            if (c.parent[r] != -2 && c.pjoint[r] == k) child = r;
        if (child < 0) {
            snprintf(err, errlen,
                     "joint %d: a motor needs a hinge of its own (this one closes a loop of joints or holds a "
                     "kinematic body)",
                     k);
            free(eq.s), free(ex.s), free(act.s), free(c.x.asset.s), free(c.x.body.s);
            return NULL;
        }
        const int pos = jd->motor == KF_MOTOR_POSITION;
        const double g = pos ? jd->kp : jd->kv;
        kf_sb_printf(&act,
                     "<general name=\"m%d\" joint=\"j%d\" gear=\"%d\" gainprm=\"%.17g\" biastype=\"affine\" "
                     "biasprm=\"0 %.17g %.17g\" forcelimited=\"true\" forcerange=\"%.17g %.17g\"/>\n",
                     k, k, child == jd->body_a ? 1 : -1, g, pos ? -jd->kp : 0.0, -jd->kv, -jd->torque_limit,
                     jd->torque_limit);
    }
    if (walls) {
        /* six half-spaces facing into the domain */
        for (int a = 0; a < 3; a++)
            for (int s = 0; s < 2; s++) {
                double p[3], z[3] = {0, 0, 0};
                for (int i = 0; i < 3; i++) p[i] = 0.5 * (walls[i] + walls[3 + i]);
                p[a] = walls[3 * s + a];
                z[a] = s ? -1 : 1;
                kf_sb_printf(&c.x.body,
                             "<geom type=\"plane\" size=\"0 0 1\" pos=\"%.17g %.17g %.17g\" zaxis=\"%g %g %g\" "
                             "contype=\"2\" conaffinity=\"1\" friction=\"0.5 0.005 0.0001\" solref=\"0.004 1\"/>\n",
                             p[0], p[1], p[2], z[0], z[1], z[2]);
            }
    }
    kf_strbuf x = {0};
    kf_sb_printf(&x,
                 "<mujoco model=\"kerf\">\n<compiler angle=\"radian\" inertiafromgeom=\"false\" "
                 "balanceinertia=\"true\"/>\n<size njmax=\"1200\" nconmax=\"300\"/>\n"
                 "<option timestep=\"0.001\" gravity=\"%.17g %.17g %.17g\"/>\n<asset>\n%s</asset>\n"
                 "<worldbody>\n%s</worldbody>\n",
                 gravity[0], gravity[1], gravity[2], c.x.asset.s ? c.x.asset.s : "", c.x.body.s ? c.x.body.s : "");
    if (eq.s) kf_sb_printf(&x, "<equality>\n%s</equality>\n", eq.s);
    if (ex.s) kf_sb_printf(&x, "<contact>\n%s</contact>\n", ex.s);
    if (act.s) kf_sb_printf(&x, "<actuator>\n%s</actuator>\n", act.s);
    kf_sb_printf(&x, "</mujoco>\n");
    int oom = c.x.asset.oom || c.x.body.oom || eq.oom || ex.oom || act.oom || x.oom;
    free(act.s);
    free(c.x.asset.s);
    free(c.x.body.s);
    free(eq.s);
    free(ex.s);
    if (oom) {
        free(x.s);
        snprintf(err, errlen, "rigid solver: out of memory");
        return NULL;
    }
    return x.s;
}
