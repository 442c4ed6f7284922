/* snapshot.c — the start of the interval kf_advance is advancing, kept so
 * that trouble can restart it at a smaller step.
 *
 * The particles go to an unlinked temporary file ($TMPDIR, else /tmp), not
 * to a second copy in memory: a copy doubled the particles' resident memory
 * (148 of the 300-odd bytes a particle held), and a retry is rare, so the
 * interval pays one sequential write and a retry one read. The arrays are
 * written raw, so a restored state is the saved one bit for bit. When no
 * file can be made or written (no writable temporary directory, a full
 * disk), the memory copy serves instead. A restored interval re-sorts every
 * particle, as the first try did (kf_advance invalidates the grid). Rigid bodies' states are small
 * and stay in memory. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "model.h"

/* an unlinked file of our own, or NULL */
static FILE *spill_open(void) {
    const char *dir = getenv("TMPDIR");
    if (!dir || !*dir) dir = "/tmp";
    char path[4096];
    if (snprintf(path, sizeof path, "%s/kerf-interval-XXXXXX", dir) >= (int)sizeof path) return NULL;
    int fd = mkstemp(path);
    if (fd < 0) return NULL;
    unlink(path);
    FILE *f = fdopen(fd, "w+b");
    if (!f) close(fd);
    return f;
}

/* n items of one array to or from the file */
static int io(FILE *f, void *ptr, size_t size, size_t n, int write) {
    return (write ? fwrite(ptr, size, n, f) : fread(ptr, size, n, f)) == n;
}

/* n items of an array the restore keeps as it is (a KF_ZERO_* array still
 * holds only zeros: reading them into it would make its pages resident) */
static int skip(FILE *f, size_t size, size_t n, int write, void *ptr) {
    return write ? io(f, ptr, size, n, 1) : fseek(f, (long)(size * n), SEEK_CUR) == 0;
}

/* every field a restore needs, in one order for writing and reading */
static int spill_fields(FILE *f, kf_particles *p, size_t n, int write) {
    int ok = 1;
    for (int k = 0; ok && k < KF_PARTICLE_REAL_PLANES; k++) {
        ok = kf_particles_plane_zero(p, k) ? skip(f, sizeof(kf_real), n, write, p->plane[k])
                                           : io(f, p->plane[k], sizeof(kf_real), n, write);
    }
    ok = ok && ((p->zero & KF_ZERO_MAT) ? skip(f, sizeof *p->mat, n, write, p->mat)
                                        : io(f, p->mat, sizeof *p->mat, n, write));
    ok = ok && ((p->zero & KF_ZERO_OBJ) ? skip(f, sizeof *p->obj, n, write, p->obj)
                                        : io(f, p->obj, sizeof *p->obj, n, write));
    ok = ok && ((p->zero & KF_ZERO_COLOUR) ? skip(f, sizeof *p->colour, n, write, p->colour)
                                           : io(f, p->colour, sizeof *p->colour, n, write));
    return ok && io(f, p->id, sizeof *p->id, n, write);
}

static int spill_write(FILE *f, kf_particles *p) {
    size_t n = p->n;
    int ok = fseek(f, 0, SEEK_SET) == 0 && fwrite(&n, sizeof n, 1, f) == 1 && (!n || spill_fields(f, p, n, 1));
    return ok && fflush(f) == 0 ? 0 : -1;
}

static int spill_read(FILE *f, kf_particles *p) {
    size_t n = 0;
    int ok = fseek(f, 0, SEEK_SET) == 0 && fread(&n, sizeof n, 1, f) == 1 && kf_particles_reserve(p, n ? n : 1) == 0 &&
             (!n || spill_fields(f, p, n, 0));
    if (!ok) return -1;
    p->n = n;
    return 0;
}

int kf_snapshot_save(kf_state *s) {
    s->snapshot_tau_valid = s->tau_valid;
    /* polypic's modes, per id: a memory copy */
    if (s->poly_cap) {
        if (s->poly_cap > s->snapshot_poly_cap) {
            kf_real *t = realloc(s->snapshot_poly, s->poly_cap * KF_POLY_REALS * sizeof *t);
            if (!t) return -1;
            s->snapshot_poly = t;
        }
        s->snapshot_poly_cap = s->poly_cap;
        memcpy(s->snapshot_poly, s->poly, s->poly_cap * KF_POLY_REALS * sizeof *s->poly);
    }
    memcpy(s->snapshot_rigid, s->rigid, sizeof s->rigid);
    if (s->rsim) {
        size_t n = kf_rigid_sim_state_size(s->rsim);
        if (n > s->snapshot_rsim_size) {
            void *b = realloc(s->snapshot_rsim, n);
            if (!b) return -1;
            s->snapshot_rsim = b;
        }
        s->snapshot_rsim_size = n;
        kf_rigid_sim_save(s->rsim, s->snapshot_rsim);
    }
    if (!s->spill && !s->spill_failed) {
        s->spill = spill_open();
        s->spill_failed = !s->spill;
    }
    s->snapshot_in_file = s->spill && spill_write(s->spill, &s->p) == 0;
    if (s->snapshot_in_file) {
        /* a memory copy from an interval the file could not take goes */
        kf_particles_free(&s->snapshot);
        return 0;
    }
    return kf_particles_copy(&s->snapshot, &s->p);
}

int kf_snapshot_restore(kf_state *s, double time0, long substep0) {
    memcpy(s->rigid, s->snapshot_rigid, sizeof s->rigid);
    if (s->rsim) kf_rigid_sim_load(s->rsim, s->snapshot_rsim, s->snapshot_rsim_size);
    int rc = s->snapshot_in_file ? spill_read(s->spill, &s->p) : kf_particles_copy(&s->p, &s->snapshot);
    s->time = time0;
    s->substep = substep0;
    s->tau_valid = s->snapshot_tau_valid;
    s->g.valid = 0;
    /* polypic's modes as they were (ids past the copy: none yet) */
    if (s->snapshot_poly_cap) {
        memcpy(s->poly, s->snapshot_poly, s->snapshot_poly_cap * KF_POLY_REALS * sizeof *s->poly);
        memset(s->poly + s->snapshot_poly_cap * KF_POLY_REALS, 0,
               (s->poly_cap - s->snapshot_poly_cap) * KF_POLY_REALS * sizeof *s->poly);
    }
    return rc;
}
