/* points_ply.c — binary little-endian PLY of the particles.
 *
 * Property names: PLY has scalar properties only, so a vector is written as
 * one property per component. Velocity uses the name_x/_y/_z suffixes
 * Blender's own PLY exporter gives a 3-component attribute (v -> v_x v_y
 * v_z); its importer brings back every other property as a float point
 * attribute under its own name, so the three arrive as v_x, v_y, v_z. Position stays x y z, the name
 * every reader maps to point positions. */
#include "points_ply.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "atomic_file.h"

int kf_ply_begin(kf_ply_out *o, const char *path, const kf_state *s, size_t n, char *err, size_t errlen) {
    o->af = malloc(sizeof(kf_atomic_file));
    if (!o->af || kf_atomic_open(o->af, path)) {
        snprintf(err, errlen, "%s: cannot write: %s", path, kf_io_reason(o->af ? errno : ENOMEM));
        free(o->af);
        o->af = NULL;
        return -1;
    }
    fprintf(((kf_atomic_file *)o->af)->f,
            "ply\nformat binary_little_endian 1.0\ncomment kerf %s t=%.9g\n"
            "comment von_mises: Cauchy stress, Pa; J: volume ratio V/V0; plastic_strain: sand q, snow ln Jp, else 0\n"
            "element vertex %zu\n"
            "property float x\nproperty float y\nproperty float z\n"
            "property float v_x\nproperty float v_y\nproperty float v_z\n"
            "property ushort material\nproperty uint id\n"
            "property float von_mises\nproperty float J\nproperty float plastic_strain\nend_header\n",
            KERF_VERSION, kf_state_time(s), n);
    return 0;
}

void kf_ply_records(kf_ply_out *o, const kf_model *m, const kf_state *s) {
    kf_particles_view pv = kf_state_particles_read(s);
    FILE *f = ((kf_atomic_file *)o->af)->f;
    /* one record per particle, packed (x86 and ARM are little-endian) */
    for (size_t i = 0; i < pv.n; i++) {
        unsigned char rec[6 * 4 + 2 + 4 + 3 * 4];
        kf_particle_fields pf = kf_state_particle_fields(m, s, i);
        float x[6] = {(float)pv.x[0][i], (float)pv.x[1][i], (float)pv.x[2][i],
                      (float)pv.v[0][i], (float)pv.v[1][i], (float)pv.v[2][i]};
        float a[3] = {(float)pf.von_mises, (float)pf.J, (float)pf.plastic};
        memcpy(rec, x, sizeof x);
        memcpy(rec + 24, &pv.mat[i], 2);
        memcpy(rec + 26, &pv.id[i], 4);
        memcpy(rec + 30, a, sizeof a);
        fwrite(rec, sizeof rec, 1, f);
    }
}

int kf_ply_end(kf_ply_out *o, char *err, size_t errlen) {
    kf_atomic_file *af = o->af;
    int rc = 0;
    if (ferror(af->f) || kf_atomic_commit(af)) {
        int e = errno; /* before the abort's own calls */
        if (af->f) kf_atomic_abort(af);
        snprintf(err, errlen, "%s: write failed: %s", af->path, kf_io_reason(e));
        rc = -1;
    }
    free(af);
    o->af = NULL;
    return rc;
}

int kf_write_points_ply(const char *path, const kf_model *m, const kf_state *s, char *err, size_t errlen) {
    kf_ply_out o;
    if (kf_ply_begin(&o, path, s, kf_state_particles_read(s).n, err, errlen)) return -1;
    kf_ply_records(&o, m, s);
    return kf_ply_end(&o, err, errlen);
}
