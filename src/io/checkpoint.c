/* checkpoint.c — write and read the lossless per-frame state. */
#include "checkpoint.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../mpm/model.h"
#include "atomic_file.h"

static const char MAGIC[8] = {'K', 'E', 'R', 'F', 'C', 'K', 'P', 'T'};

typedef struct header {
    char magic[8];
    uint32_t version;
    uint32_t real_size;
    uint64_t particles;
    int64_t frame;
    double time;
    int64_t substep;
    uint64_t next_id;
    uint64_t inputs_hash;
    uint32_t nrigid;      /* kf_rigid_state records after the particles */
    uint32_t pad;
    uint64_t rsim_bytes;  /* then the rigid solver's own state */
} header;

typedef struct hashed_writer {
    FILE *f;
    uint64_t h;
    int failed;
} hashed_writer;

static void fnv(uint64_t *h, const void *p, size_t n) {
    const unsigned char *b = p;
    uint64_t x = *h;
    for (size_t i = 0; i < n; i++) x = (x ^ b[i]) * 1099511628211ULL;
    *h = x;
}

static void put(hashed_writer *w, const void *p, size_t n) {
    if (w->failed || n == 0) return;
    fnv(&w->h, p, n);
    if (fwrite(p, 1, n, w->f) != n) w->failed = 1;
}

int kf_checkpoint_write(const char *path, const kf_state *s, int frame, uint64_t inputs_hash, char *err, size_t errlen) {
    const kf_particles *p = &s->p;
    kf_atomic_file af;
    if (kf_atomic_open(&af, path)) {
        snprintf(err, errlen, "%s: cannot write checkpoint: %s", path, strerror(errno));
        return -1;
    }
    header h;
    memset(&h, 0, sizeof h);
    memcpy(h.magic, MAGIC, sizeof MAGIC);
    h.version = KF_CHECKPOINT_VERSION;
    h.real_size = sizeof(kf_real);
    h.particles = p->n;
    h.frame = frame;
    h.time = s->time;
    h.substep = s->substep;
    h.next_id = s->next_id;
    h.inputs_hash = inputs_hash;
    h.nrigid = (uint32_t)s->nrigid;
    void *rsim = NULL;
    if (s->rsim) {
        h.rsim_bytes = kf_rigid_sim_state_size(s->rsim);
        rsim = malloc(h.rsim_bytes ? h.rsim_bytes : 1);
        if (!rsim) {
            kf_atomic_abort(&af);
            snprintf(err, errlen, "%s: out of memory writing checkpoint", path);
            return -1;
        }
        kf_rigid_sim_save(s->rsim, rsim);
    }
    hashed_writer w = {af.f, 1469598103934665603ULL, 0};
    put(&w, &h, sizeof h);
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) put(&w, p->plane[k], p->n * sizeof(kf_real));
    put(&w, p->mat, p->n * sizeof *p->mat);
    put(&w, p->id, p->n * sizeof *p->id);
    put(&w, p->obj, p->n * sizeof *p->obj);
    put(&w, p->colour, p->n * sizeof *p->colour);
    put(&w, s->rigid, (size_t)s->nrigid * sizeof s->rigid[0]);
    put(&w, rsim, h.rsim_bytes);
    free(rsim);
    uint64_t sum = w.h;
    if (!w.failed && fwrite(&sum, sizeof sum, 1, af.f) != 1) w.failed = 1;
    if (w.failed || kf_atomic_commit(&af)) {
        int e = errno;
        if (af.f) kf_atomic_abort(&af);
        snprintf(err, errlen, "%s: writing checkpoint failed: %s", path, strerror(e));
        return -1;
    }
    return 0;
}

static int read_header(FILE *f, const char *path, header *h, char *err, size_t errlen) {
    if (fread(h, sizeof *h, 1, f) != 1) {
        snprintf(err, errlen, "%s: not a kerf checkpoint (too short)", path);
        return -1;
    }
    if (memcmp(h->magic, MAGIC, sizeof MAGIC) != 0) {
        snprintf(err, errlen, "%s: not a kerf checkpoint (bad magic)", path);
        return -1;
    }
    if (h->version != KF_CHECKPOINT_VERSION) {
        snprintf(err, errlen, "%s: checkpoint format version %u, this kerf reads version %d", path, h->version,
                 KF_CHECKPOINT_VERSION);
        return -1;
    }
    if (h->real_size != sizeof(kf_real)) {
        snprintf(err, errlen, "%s: checkpoint was written by a %s-precision build, this is %s precision", path,
                 h->real_size == 8 ? "double" : "single", sizeof(kf_real) == 8 ? "double" : "single");
        return -1;
    }
    return 0;
}

static void fill_info(kf_checkpoint_info *info, const header *h) {
    if (!info) return;
    info->frame = (int)h->frame;
    info->time = h->time;
    info->substep = (long)h->substep;
    info->particles = (size_t)h->particles;
    info->inputs_hash = h->inputs_hash;
}

int kf_checkpoint_peek(const char *path, kf_checkpoint_info *info, char *err, size_t errlen) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "%s: cannot open checkpoint: %s", path, strerror(errno));
        return -1;
    }
    header h;
    int rc = read_header(f, path, &h, err, errlen);
    fclose(f);
    if (rc == 0) fill_info(info, &h);
    return rc;
}

int kf_checkpoint_read(const char *path, const kf_model *m, kf_state *s, kf_checkpoint_info *info, char *err,
                       size_t errlen) {
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "%s: cannot open checkpoint: %s", path, strerror(errno));
        return -1;
    }
    header h;
    if (read_header(f, path, &h, err, errlen)) {
        fclose(f);
        return -1;
    }
    /* read into a fresh particle set; the state changes only if all is well */
    kf_particles p;
    memset(&p, 0, sizeof p);
    size_t n = (size_t)h.particles;
    uint64_t sum = 1469598103934665603ULL;
    fnv(&sum, &h, sizeof h);
    int ok = kf_particles_reserve(&p, n ? n : 1) == 0;
    for (int k = 0; ok && k < KF_PARTICLE_REAL_PLANES; k++) {
        ok = fread(p.plane[k], sizeof(kf_real), n, f) == n;
        if (ok) fnv(&sum, p.plane[k], n * sizeof(kf_real));
    }
    if (ok) ok = fread(p.mat, sizeof *p.mat, n, f) == n, fnv(&sum, p.mat, n * sizeof *p.mat);
    if (ok) ok = fread(p.id, sizeof *p.id, n, f) == n, fnv(&sum, p.id, n * sizeof *p.id);
    if (ok) ok = fread(p.obj, sizeof *p.obj, n, f) == n, fnv(&sum, p.obj, n * sizeof *p.obj);
    if (ok) ok = fread(p.colour, sizeof *p.colour, n, f) == n, fnv(&sum, p.colour, n * sizeof *p.colour);
    kf_rigid_state rigid[KF_MAX_RIGIDS];
    void *rsim = NULL;
    if (ok && (h.nrigid != (uint32_t)s->nrigid || h.rsim_bytes != (s->rsim ? kf_rigid_sim_state_size(s->rsim) : 0))) {
        fclose(f);
        kf_particles_free(&p);
        snprintf(err, errlen, "%s: checkpoint has %u rigid bodies in another configuration than the shot's %d", path,
                 h.nrigid, s->nrigid);
        return -1;
    }
    if (ok) ok = fread(rigid, sizeof rigid[0], h.nrigid, f) == h.nrigid, fnv(&sum, rigid, h.nrigid * sizeof rigid[0]);
    if (ok && h.rsim_bytes) {
        rsim = malloc(h.rsim_bytes);
        ok = rsim && fread(rsim, 1, h.rsim_bytes, f) == h.rsim_bytes;
        if (ok) fnv(&sum, rsim, h.rsim_bytes);
    }
    uint64_t stored = 0;
    if (ok) ok = fread(&stored, sizeof stored, 1, f) == 1;
    fclose(f);
    if (!ok) {
        kf_particles_free(&p);
        free(rsim);
        snprintf(err, errlen, "%s: checkpoint is truncated (expected %zu particles)", path, n);
        return -1;
    }
    if (stored != sum) {
        kf_particles_free(&p);
        free(rsim);
        snprintf(err, errlen, "%s: checkpoint checksum mismatch (file damaged)", path);
        return -1;
    }
    for (size_t i = 0; i < n; i++)
        if (p.mat[i] >= m->nmat) {
            kf_particles_free(&p);
            free(rsim);
            snprintf(err, errlen, "%s: particle %zu uses material %u but the shot defines %d", path, i, p.mat[i],
                     m->nmat);
            return -1;
        }
    p.n = n;
    kf_particles_free(&s->p);
    s->p = p;
    memcpy(s->rigid, rigid, h.nrigid * sizeof rigid[0]);
    if (rsim) kf_rigid_sim_load(s->rsim, rsim, h.rsim_bytes);
    free(rsim);
    s->time = h.time;
    s->substep = (long)h.substep;
    s->next_id = (uint32_t)h.next_id;
    s->tau_valid = 1; /* the stress planes are in the file, bit for bit */
    s->g.valid = 0;
    fill_info(info, &h);
    return 0;
}
