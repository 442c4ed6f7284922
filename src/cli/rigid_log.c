/* rigid_log.c — rigid bodies in kerf info and the frame log (see rigid_log.h). */
#include "rigid_log.h"

#include <math.h>

static const char *const motion_name[] = {"static", "kinematic", "dynamic"};

void kf_rigid_log_info(FILE *f, const kf_shot *shot, const kf_model *m) {
    if (shot->nrigids == 0) return;
    fprintf(f, "rigids    %d bodies, %d joints\n", shot->nrigids, shot->njoints);
    for (int i = 0; i < shot->nrigids && i < kf_model_rigid_count(m); i++) {
        const kf_rigid_def *d = &shot->rigids[i].def;
        fprintf(f, "  %-16s %s %s %s, %zu seeds", d->name, d->thin ? "thin" : "solid", motion_name[d->motion % 3],
                shot->rigids[i].shape ? "mesh" : "box", kf_model_rigid_seeds(m, i));
        if (d->motion == KF_RIGID_DYNAMIC) fprintf(f, ", %.4g kg", kf_model_rigid_mass(m, i));
        fputc('\n', f);
    }
    for (int i = 0; i < shot->njoints; i++) {
        const kf_shot_joint *j = &shot->joints[i];
        static const char *const motor_name[] = {"", "velocity", "position"};
        fprintf(f, "  %-16s hinge %s to %s", j->name, j->body, j->to);
        if (j->def.motor != KF_MOTOR_NONE)
            fprintf(f, ", %s motor at %g Hz, torque limit %g N m", motor_name[j->def.motor % 3], j->def.frequency,
                    j->def.torque_limit);
        fputc('\n', f);
    }
}

void kf_rigid_log_frame(FILE *f, const kf_shot *shot, const kf_state *s) {
    for (int i = 0; i < shot->nrigids; i++) {
        kf_rigid_pose p = kf_state_rigid(s, i);
        /* how it has turned since the first frame, as the shot's rotate
         * writes a turn (degrees about x, then y, then z: R = Rz Ry Rx) */
        const double deg = 57.29577951308232, ry = asin(fmax(-1, fmin(1, -p.R[6])));
        fprintf(f,
                "  rigid %s: at [%.3f, %.3f, %.3f] m, v [%.3f, %.3f, %.3f] m/s, w [%.2f, %.2f, %.2f] rad/s, turned "
                "[%.1f, %.1f, %.1f] deg\n",
                shot->rigids[i].def.name, p.com[0], p.com[1], p.com[2], p.v[0], p.v[1], p.v[2], p.omega[0], p.omega[1],
                p.omega[2], atan2(p.R[7], p.R[8]) * deg, ry * deg, atan2(p.R[3], p.R[0]) * deg);
    }
    /* each motor's torque: now, and the frame's peak against its limit */
    for (int i = 0; i < shot->njoints; i++) {
        double now, peak;
        if (kf_state_joint_torque(s, i, &now, &peak)) continue;
        const double lim = shot->joints[i].def.torque_limit;
        fprintf(f, "  motor %s: torque %.4g N m, peak %.4g of %.4g N m%s\n", shot->joints[i].name, now, peak, lim,
                peak >= lim * (1 - 1e-9) ? " (at its limit)" : "");
    }
}
