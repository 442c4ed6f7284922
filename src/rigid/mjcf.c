/* mjcf.c — MJCF text for the rigid bodies (see mjcf.h).
 *
 * MuJoCo collides convex geoms only. A convex mesh becomes one convex-hull
 * geom; any other (a bowl, a blade, a bunny) becomes one thin prism per
 * triangle (the triangle swept ± half a thickness along its normal), so a
 * body can rest inside a concave static container. Above KF_MJ_MAX_PRISMS
 * triangles a body falls back to its hull.
 *
 * Collision groups: dynamic geoms contype 1, conaffinity 1; static,
 * kinematic and wall geoms contype 2, conaffinity 1. So dynamic bodies touch
 * everything and the moved-by-us geoms never touch each other.
 *
 * Joints: a hinge to the world (or a static body) or between two dynamic
 * bodies becomes a real hinge joint in MuJoCo's kinematic tree when the
 * child has no other parent; otherwise (cycles, kinematic partners) two
 * ball-joint "connect" equalities on the axis, a body length apart. */
#include "mjcf.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "rmath.h"
#include "strbuf.h"

#define KF_MJ_MAX_PRISMS 20000

/* world frame of the MuJoCo body of r at time 0: origin o, axes R */
typedef struct frame {
    double o[3], R[9];
} frame;

typedef struct ctx {
    const kf_rigid_body *b;
    int n;
    const kf_joint_def *j;
    int parent[KF_MAX_RIGIDS];  /* -2 free, -1 world hinge, else a body */
    int pjoint[KF_MAX_RIGIDS];  /* the joint to the parent */
    frame f[KF_MAX_RIGIDS];
    kf_strbuf asset, body;
} ctx;

static int dynamic(const ctx *c, int r) { return r >= 0 && r < c->n && c->b[r].def.motion == KF_RIGID_DYNAMIC; }
/* the world, or a body that never moves */
static int worldlike(const ctx *c, int r) { return r == -1 || (r >= 0 && r < c->n && c->b[r].def.motion == KF_RIGID_STATIC); }

/* a body's extent: the diagonal of its vertices' box */
static double extent(const kf_rigid_body *b) {
    double lo[3] = {INFINITY, INFINITY, INFINITY}, hi[3] = {-INFINITY, -INFINITY, -INFINITY};
    for (int i = 0; i < b->nvert; i++)
        for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], b->vert[3 * i + a]), hi[a] = fmax(hi[a], b->vert[3 * i + a]);
    double d[3] = {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]};
    return sqrt(rm_dot(d, d));
}

static void tri_normal(const kf_rigid_body *b, int t, double n[3], double *area2) {
    const double *p0 = b->vert + 3 * b->tri[3 * t], *p1 = b->vert + 3 * b->tri[3 * t + 1],
                 *p2 = b->vert + 3 * b->tri[3 * t + 2];
    double e1[3] = {p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]}, e2[3] = {p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]};
    rm_cross(e1, e2, n);
    *area2 = sqrt(rm_dot(n, n));
    if (*area2 > 0)
        for (int a = 0; a < 3; a++) n[a] /= *area2;
}

/* a closed solid whose every vertex lies behind every face plane */
static int convex(const kf_rigid_body *b, double tol) {
    if (b->def.thin || (double)b->ntri * b->nvert > 5e7) return 0;
    for (int t = 0; t < b->ntri; t++) {
        double n[3], a2;
        tri_normal(b, t, n, &a2);
        if (!(a2 > 0)) continue;
        const double *p0 = b->vert + 3 * b->tri[3 * t];
        for (int i = 0; i < b->nvert; i++) {
            const double *p = b->vert + 3 * i;
            double d[3] = {p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]};
            if (rm_dot(d, n) > tol) return 0;
        }
    }
    return 1;
}

static void quat_attr(kf_strbuf *s, const double R[9]) {
    double q[4];
    rm_mat_to_quat(R, q);
    kf_sb_printf(s, " quat=\"%.17g %.17g %.17g %.17g\"", q[0], q[1], q[2], q[3]);
}

/* mesh assets and geoms of body r; its vertices shifted by -shift (the
 * MuJoCo body origin in the mesh frame) */
static int geoms(ctx *c, int r, const double shift[3]) {
    const kf_rigid_body *b = &c->b[r];
    const int dyn = b->def.motion == KF_RIGID_DYNAMIC;
    const char *groups = dyn ? "contype=\"1\" conaffinity=\"1\"" : "contype=\"2\" conaffinity=\"1\"";
    const char *contact = "friction=\"0.5 0.005 0.0001\" solref=\"0.004 1\" condim=\"3\"";
    double ext = extent(b);
    if (convex(b, 1e-9 * ext) || b->ntri > KF_MJ_MAX_PRISMS) {
        kf_sb_printf(&c->asset, "<mesh name=\"m%d\" vertex=\"", r);
        for (int i = 0; i < b->nvert; i++)
            for (int a = 0; a < 3; a++) kf_sb_printf(&c->asset, "%.17g ", b->vert[3 * i + a] - shift[a]);
        kf_sb_printf(&c->asset, "\"/>\n");
        kf_sb_printf(&c->body, "<geom type=\"mesh\" mesh=\"m%d\" %s %s/>\n", r, groups, contact);
        return !b->def.thin;
    }
    /* one prism per triangle of thickness 2h */
    double h = fmax(2e-3 * ext, 1e-6);
    for (int t = 0; t < b->ntri; t++) {
        double n[3], a2;
        tri_normal(b, t, n, &a2);
        if (!(a2 > 1e-10 * ext * ext)) continue; /* degenerate: no hull */
        kf_sb_printf(&c->asset, "<mesh name=\"m%d_%d\" vertex=\"", r, t);
        for (int s = -1; s <= 1; s += 2)
            for (int k = 0; k < 3; k++) {
                const double *p = b->vert + 3 * b->tri[3 * t + k];
                for (int a = 0; a < 3; a++) kf_sb_printf(&c->asset, "%.17g ", p[a] + s * h * n[a] - shift[a]);
            }
        kf_sb_printf(&c->asset, "\"/>\n");
        kf_sb_printf(&c->body, "<geom type=\"mesh\" mesh=\"m%d_%d\" %s %s/>\n", r, t, groups, contact);
    }
    return 0;
}

/* MuJoCo 2.2 finds one contact point per pair of convex meshes, so a box on
 * a box rocks on that one point forever. Small spheres tucked into up to
 * KF_MJ_CORNERS well-spread vertices of a convex solid (farthest-point
 * order, from the vertex farthest from the com) give a resting body several
 * points of support. Each sphere touches the face planes around its vertex
 * from inside: centre p - α n_v with α = radius / min_f (n_f · n_v). */
#define KF_MJ_CORNERS 48
static void corner_spheres(ctx *c, int r, const double shift[3]) {
    const kf_rigid_body *b = &c->b[r];
    const int n = b->nvert;
    double *dist = malloc(sizeof(double) * (size_t)n), *nv = calloc(3 * (size_t)n, sizeof(double));
    double *mindot = malloc(sizeof(double) * (size_t)n);
    if (!dist || !nv || !mindot) goto done;
    /* area-weighted vertex normals, then the least aligned adjacent face */
    for (int t = 0; t < b->ntri; t++) {
        double fn[3], a2;
        tri_normal(b, t, fn, &a2);
        for (int k = 0; k < 3; k++)
            for (int a = 0; a < 3; a++) nv[3 * b->tri[3 * t + k] + a] += a2 * fn[a];
    }
    for (int i = 0; i < n; i++) {
        double l = sqrt(rm_dot(nv + 3 * i, nv + 3 * i));
        for (int a = 0; a < 3; a++) nv[3 * i + a] = l > 0 ? nv[3 * i + a] / l : 0;
        mindot[i] = 1;
    }
    for (int t = 0; t < b->ntri; t++) {
        double fn[3], a2;
        tri_normal(b, t, fn, &a2);
        if (!(a2 > 0)) continue;
        for (int k = 0; k < 3; k++) {
            int v = b->tri[3 * t + k];
            mindot[v] = fmin(mindot[v], rm_dot(fn, nv + 3 * v));
        }
    }
    const double rad = 0.01 * extent(b);
    int pick = 0;
    for (int i = 0; i < n; i++) {
        const double *p = b->vert + 3 * i;
        double d[3] = {p[0] - b->com[0], p[1] - b->com[1], p[2] - b->com[2]};
        dist[i] = rm_dot(d, d);
        if (dist[i] > dist[pick]) pick = i;
    }
    for (int i = 0; i < n; i++) dist[i] = INFINITY;
    for (int k = 0; k < KF_MJ_CORNERS && k < n; k++) {
        const double *p = b->vert + 3 * pick;
        if (mindot[pick] > 0.1) {
            double al = rad / mindot[pick], *q = nv + 3 * pick;
            kf_sb_printf(&c->body,
                         "<geom type=\"sphere\" size=\"%.17g\" pos=\"%.17g %.17g %.17g\" contype=\"1\" "
                         "conaffinity=\"1\" friction=\"0.5 0.005 0.0001\" solref=\"0.004 1\" condim=\"3\"/>\n",
                         rad, p[0] - al * q[0] - shift[0], p[1] - al * q[1] - shift[1], p[2] - al * q[2] - shift[2]);
        }
        /* next: the vertex farthest from all picked */
        int next = pick;
        double best = -1;
        for (int i = 0; i < n; i++) {
            const double *q = b->vert + 3 * i;
            double e[3] = {q[0] - p[0], q[1] - p[1], q[2] - p[2]};
            dist[i] = fmin(dist[i], rm_dot(e, e));
            if (dist[i] > best) best = dist[i], next = i;
        }
        if (!(best > 0)) break;
        pick = next;
    }
done:
    free(dist);
    free(nv);
    free(mindot);
}

static void emit_body(ctx *c, int r, const frame *pf) {
    const kf_rigid_body *b = &c->b[r];
    const frame *f = &c->f[r];
    /* pose relative to the parent frame (world: identity) */
    double d[3] = {f->o[0], f->o[1], f->o[2]}, Rrel[9];
    if (pf) {
        double w[3] = {f->o[0] - pf->o[0], f->o[1] - pf->o[1], f->o[2] - pf->o[2]};
        rm_mtv(pf->R, w, d);
        for (int i = 0; i < 3; i++)
            for (int k = 0; k < 3; k++)
                Rrel[3 * i + k] = pf->R[i] * f->R[k] + pf->R[3 + i] * f->R[3 + k] + pf->R[6 + i] * f->R[6 + k];
    } else {
        memcpy(Rrel, f->R, sizeof Rrel);
    }
    kf_sb_printf(&c->body, "<body name=\"b%d\" pos=\"%.17g %.17g %.17g\"", r, d[0], d[1], d[2]);
    quat_attr(&c->body, Rrel);
    if (b->def.motion != KF_RIGID_DYNAMIC) {
        kf_sb_printf(&c->body, " mocap=\"true\">\n");
        (void)geoms(c, r, (const double[3]){0, 0, 0});
        kf_sb_printf(&c->body, "</body>\n");
        return;
    }
    kf_sb_printf(&c->body, ">\n");
    if (c->parent[r] == -2) {
        kf_sb_printf(&c->body, "<freejoint/>\n");
    } else {
        const kf_joint_def *jd = &c->j[c->pjoint[r]];
        double w[3] = {jd->anchor[0] - f->o[0], jd->anchor[1] - f->o[1], jd->anchor[2] - f->o[2]}, p[3], ax[3];
        rm_mtv(f->R, w, p);
        rm_mtv(f->R, jd->axis, ax);
        kf_sb_printf(&c->body,
                     "<joint type=\"hinge\" pos=\"%.17g %.17g %.17g\" axis=\"%.17g %.17g %.17g\" damping=\"%.17g\"/>\n",
                     p[0], p[1], p[2], ax[0], ax[1], ax[2], jd->damping);
    }
    /* the inertia about the com, mesh axes; a hair of isotropic inertia keeps a
     * flat shell (Izz = Ixx + Iyy exactly) inside MuJoCo's triangle inequality */
    const double *I = b->inertia;
    double eps = 1e-9 * (I[0] + I[4] + I[8]);
    kf_sb_printf(&c->body,
                 "<inertial pos=\"0 0 0\" mass=\"%.17g\" fullinertia=\"%.17g %.17g %.17g %.17g %.17g %.17g\"/>\n",
                 b->mass, I[0] + eps, I[4] + eps, I[8] + eps, I[1], I[2], I[5]);
    if (geoms(c, r, b->com)) corner_spheres(c, r, b->com);
    for (int k = 0; k < c->n; k++)
        if (c->parent[k] == r) emit_body(c, k, f);
    kf_sb_printf(&c->body, "</body>\n");
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
    for (int r = 0; r < nbodies; r++) {
        c.parent[r] = -2;
        kf_rigid_state st;
        kf_rigid_state_at(&bodies[r], 0, &st);
        memcpy(c.f[r].R, st.R, sizeof st.R);
        const int dyn = bodies[r].def.motion == KF_RIGID_DYNAMIC;
        memcpy(c.f[r].o, dyn ? st.com : st.t, sizeof st.t);
    }
    kf_strbuf eq = {0};
    for (int k = 0; k < njoints; k++) {
        const kf_joint_def *jd = &joints[k];
        int a = jd->body_a, b = jd->body_b;
        double len = sqrt(rm_dot(jd->axis, jd->axis));
        if (a < -1 || a >= nbodies || b < -1 || b >= nbodies || a == b || !(len > 0)) {
            snprintf(err, errlen, "joint %d: bodies %d and %d (need two different bodies in [-1, %d)) and a nonzero axis",
                     k, a, b, nbodies);
            free(eq.s);
            return NULL;
        }
        if (!dynamic(&c, a) && !dynamic(&c, b)) {
            snprintf(err, errlen, "joint %d: neither body %d nor body %d is dynamic", k, a, b);
            free(eq.s);
            return NULL;
        }
        int kind = KF_MJ_JOINT_CONNECT;
        if (worldlike(&c, a) || worldlike(&c, b)) {
            int d = worldlike(&c, a) ? b : a;
            if (c.parent[d] == -2) c.parent[d] = -1, c.pjoint[d] = k, kind = KF_MJ_JOINT_TREE;
        } else if (dynamic(&c, a) && dynamic(&c, b)) {
            if (c.parent[b] == -2 && !descends(&c, a, b))
                c.parent[b] = a, c.pjoint[b] = k, kind = KF_MJ_JOINT_TREE;
            else if (c.parent[a] == -2 && !descends(&c, b, a))
                c.parent[a] = b, c.pjoint[a] = k, kind = KF_MJ_JOINT_TREE;
        }
        if (joint_kind) joint_kind[k] = kind;
        if (kind == KF_MJ_JOINT_CONNECT) {
            /* two ball joints on the axis keep both the anchor and the axis */
            int d = dynamic(&c, a) ? a : b, o = d == a ? b : a;
            double half = 0.5 * extent(&bodies[d]);
            for (int s = -1; s <= 1; s += 2) {
                double p[3], w[3], q[3];
                for (int i = 0; i < 3; i++) p[i] = jd->anchor[i] + s * half * jd->axis[i] / len;
                for (int i = 0; i < 3; i++) w[i] = p[i] - c.f[d].o[i];
                rm_mtv(c.f[d].R, w, q);
                if (o >= 0)
                    kf_sb_printf(&eq, "<connect body1=\"b%d\" body2=\"b%d\" anchor=\"%.17g %.17g %.17g\"/>\n", d, o, q[0],
                                 q[1], q[2]);
                else
                    kf_sb_printf(&eq, "<connect body1=\"b%d\" anchor=\"%.17g %.17g %.17g\"/>\n", d, q[0], q[1], q[2]);
            }
        }
    }
    for (int r = 0; r < nbodies; r++)
        if (c.parent[r] < 0) emit_body(&c, r, NULL);
    if (walls) {
        /* six half-spaces facing into the domain */
        for (int a = 0; a < 3; a++)
            for (int s = 0; s < 2; s++) {
                double p[3], z[3] = {0, 0, 0};
                for (int i = 0; i < 3; i++) p[i] = 0.5 * (walls[i] + walls[3 + i]);
                p[a] = walls[3 * s + a];
                z[a] = s ? -1 : 1;
                kf_sb_printf(&c.body,
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
                 gravity[0], gravity[1], gravity[2], c.asset.s ? c.asset.s : "", c.body.s ? c.body.s : "");
    if (eq.s) kf_sb_printf(&x, "<equality>\n%s</equality>\n", eq.s);
    kf_sb_printf(&x, "</mujoco>\n");
    int oom = c.asset.oom || c.body.oom || eq.oom || x.oom;
    free(c.asset.s);
    free(c.body.s);
    free(eq.s);
    if (oom) {
        free(x.s);
        snprintf(err, errlen, "rigid solver: out of memory");
        return NULL;
    }
    return x.s;
}
