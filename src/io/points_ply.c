/* points_ply.c — binary little-endian PLY of the particles. */
#include "points_ply.h"

#include <errno.h>
#include <stdio.h>
#include <string.h>

#include "atomic_file.h"

int kf_write_points_ply(const char *path, const kf_state *s, char *err, size_t errlen) {
    kf_particles_view pv = kf_state_particles_read(s);
    kf_atomic_file af;
    if (kf_atomic_open(&af, path)) {
        snprintf(err, errlen, "%s: cannot write: %s", path, kf_io_reason(errno));
        return -1;
    }
    fprintf(af.f,
            "ply\nformat binary_little_endian 1.0\ncomment kerf %s t=%.9g\nelement vertex %zu\n"
            "property float x\nproperty float y\nproperty float z\n"
            "property float vx\nproperty float vy\nproperty float vz\n"
            "property ushort material\nproperty uint id\nend_header\n",
            KERF_VERSION, kf_state_time(s), pv.n);
    /* one record per particle, packed (x86 and ARM are little-endian) */
    for (size_t i = 0; i < pv.n; i++) {
        unsigned char rec[6 * 4 + 2 + 4];
        float f[6] = {(float)pv.x[0][i], (float)pv.x[1][i], (float)pv.x[2][i],
                      (float)pv.v[0][i], (float)pv.v[1][i], (float)pv.v[2][i]};
        memcpy(rec, f, sizeof f);
        memcpy(rec + 24, &pv.mat[i], 2);
        memcpy(rec + 26, &pv.id[i], 4);
        fwrite(rec, sizeof rec, 1, af.f);
    }
    if (ferror(af.f) || kf_atomic_commit(&af)) {
        int e = errno; /* before the abort's own calls */
        if (af.f) kf_atomic_abort(&af);
        snprintf(err, errlen, "%s: write failed: %s", path, kf_io_reason(e));
        return -1;
    }
    return 0;
}
