/* checkpoint.c — write and read the lossless per-frame state. */
#include "checkpoint.h"

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include "../core/fnv.h"
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
    uint32_t nrigid;     /* kf_rigid_state records after the particles */
    uint32_t poly_ids;   /* last: polypic's modes (KF_POLY_REALS reals) for ids 0..poly_ids-1, or none */
    uint64_t rsim_bytes; /* then the rigid solver's own state */
} header;

typedef struct hashed_writer {
    FILE *f;
    uint64_t h;
    int failed;
} hashed_writer;

static void fnv(uint64_t *h, const void *p, size_t n) { *h = kf_fnv1a(*h, p, n); }

static void put(hashed_writer *w, const void *p, size_t n) {
    if (w->failed || n == 0) return;
    fnv(&w->h, p, n);
    if (fwrite(p, 1, n, w->f) != n) w->failed = 1;
}

/* a stress plane the state does not keep (KF_ZERO_TAU): the values kf_stress
 * would have left in it, evaluated from F a chunk at a time (the file is the
 * same either way) */
static void put_stress(hashed_writer *w, kf_state *s, int k) {
    enum { CHUNK = 4096 };
    static _Thread_local kf_real buf[6][CHUNK];
    kf_real *const out[6] = {buf[0], buf[1], buf[2], buf[3], buf[4], buf[5]};
    for (size_t i = 0; i < s->p.n; i += CHUNK) {
        int n = s->p.n - i < CHUNK ? (int)(s->p.n - i) : CHUNK;
        kf_stress_eval(s->stress_model, &s->p, i, n, out);
        put(w, buf[k], (size_t)n * sizeof(kf_real));
    }
}

int kf_checkpoint_write(const char *path, kf_state *s, int frame, uint64_t inputs_hash, char *err, size_t errlen) {
    const kf_particles *p = &s->p;
    kf_grid_invalidate(&s->g); /* a resume sorts from scratch: so does the run from here */
    kf_atomic_file af;
    if (kf_atomic_open(&af, path)) {
        snprintf(err, errlen, "%s: cannot write checkpoint: %s", path, kf_io_reason(errno));
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
    /* polypic's higher modes are state too: without them a resume would
     * restart every particle's modes at zero and differ from the run */
    if (s->poly_cap && kf_poly_reserve(s) == 0) h.poly_ids = s->next_id;
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
    hashed_writer w = {af.f, KF_FNV_BASIS, 0};
    put(&w, &h, sizeof h);
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) {
        if (kf_particles_plane_zero(p, k) && k >= KF_PLANE_TAU && s->tau_valid && s->stress_model)
            put_stress(&w, s, k - KF_PLANE_TAU);
        else put(&w, p->plane[k], p->n * sizeof(kf_real));
    }
    put(&w, p->mat, p->n * sizeof *p->mat);
    put(&w, p->id, p->n * sizeof *p->id);
    put(&w, p->obj, p->n * sizeof *p->obj);
    put(&w, p->colour, p->n * sizeof *p->colour);
    put(&w, s->rigid, (size_t)s->nrigid * sizeof s->rigid[0]);
    put(&w, rsim, h.rsim_bytes);
    put(&w, s->poly, (size_t)h.poly_ids * KF_POLY_REALS * sizeof(kf_real));
    free(rsim);
    uint64_t sum = w.h;
    if (!w.failed && fwrite(&sum, sizeof sum, 1, af.f) != 1) w.failed = 1;
    if (w.failed || kf_atomic_commit(&af)) {
        int e = errno;
        if (af.f) kf_atomic_abort(&af);
        snprintf(err, errlen, "%s: writing checkpoint failed: %s", path, kf_io_reason(e));
        return -1;
    }
    return 0;
}

/* ---- written from pieces ---- */

static void fill_header(header *h, const kf_state *s, size_t n, int frame, uint64_t inputs_hash, uint64_t rsim_bytes) {
    memset(h, 0, sizeof *h);
    memcpy(h->magic, MAGIC, sizeof MAGIC);
    h->version = KF_CHECKPOINT_VERSION;
    h->real_size = sizeof(kf_real);
    h->particles = n;
    h->frame = frame;
    h->time = s->time;
    h->substep = s->substep;
    h->next_id = s->next_id;
    h->inputs_hash = inputs_hash;
    h->nrigid = (uint32_t)s->nrigid;
    h->rsim_bytes = rsim_bytes;
}

/* bytes at an offset of the file, all of them or failed */
static void put_at(kf_checkpoint_out *o, const void *p, size_t n, long at) {
    if (o->failed || n == 0) return;
    FILE *f = ((kf_atomic_file *)o->af)->f;
    if (fseek(f, at, SEEK_SET) != 0 || fwrite(p, 1, n, f) != n) o->failed = 1, o->err_no = errno;
}

int kf_checkpoint_begin(kf_checkpoint_out *o, const char *path, const kf_state *s, size_t n, int frame,
                        uint64_t inputs_hash, char *err, size_t errlen) {
    memset(o, 0, sizeof *o);
    o->af = malloc(sizeof(kf_atomic_file));
    if (!o->af || kf_atomic_open(o->af, path)) {
        snprintf(err, errlen, "%s: cannot write checkpoint: %s", path, kf_io_reason(o->af ? errno : ENOMEM));
        free(o->af);
        o->af = NULL;
        return -1;
    }
    header h;
    fill_header(&h, s, n, frame, inputs_hash, s->rsim ? kf_rigid_sim_state_size(s->rsim) : 0);
    o->n = n;
    o->body = (long)sizeof h;
    put_at(o, &h, sizeof h, 0);
    return 0;
}

void kf_checkpoint_window(kf_checkpoint_out *o, const kf_state *win, size_t at) {
    const kf_particles *p = &win->p;
    const size_t n = o->n, m = p->n;
    long base = o->body;
    /* each array's slice at its place in the file: the arrays follow each other, n values each */
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++, base += (long)(n * sizeof(kf_real)))
        put_at(o, p->plane[k], m * sizeof(kf_real), base + (long)(at * sizeof(kf_real)));
    put_at(o, p->mat, m * sizeof *p->mat, base + (long)(at * sizeof *p->mat));
    base += (long)(n * sizeof *p->mat);
    put_at(o, p->id, m * sizeof *p->id, base + (long)(at * sizeof *p->id));
    base += (long)(n * sizeof *p->id);
    put_at(o, p->obj, m * sizeof *p->obj, base + (long)(at * sizeof *p->obj));
    base += (long)(n * sizeof *p->obj);
    put_at(o, p->colour, m * sizeof *p->colour, base + (long)(at * sizeof *p->colour));
}

int kf_checkpoint_end(kf_checkpoint_out *o, const kf_state *s, char *err, size_t errlen) {
    kf_atomic_file *af = o->af;
    const size_t n = o->n;
    long at =
        o->body + (long)(n * (KF_PARTICLE_REAL_PLANES * sizeof(kf_real) + sizeof(uint16_t) * 2 + sizeof(uint32_t) * 2));
    put_at(o, s->rigid, (size_t)s->nrigid * sizeof s->rigid[0], at);
    at += (long)((size_t)s->nrigid * sizeof s->rigid[0]);
    if (s->rsim) {
        size_t nb = kf_rigid_sim_state_size(s->rsim);
        void *rsim = malloc(nb ? nb : 1);
        if (!rsim) o->failed = 1, o->err_no = ENOMEM;
        else kf_rigid_sim_save(s->rsim, rsim);
        put_at(o, rsim, nb, at);
        at += (long)nb;
        free(rsim);
    }
    /* the checksum of every byte before it, read back in order */
    uint64_t sum = KF_FNV_BASIS;
    FILE *back = NULL;
    if (!o->failed && (fflush(af->f) != 0 || !(back = fopen(af->tmp, "rb")))) o->failed = 1, o->err_no = errno;
    const size_t chunk = 1 << 20;
    char *buf = malloc(chunk);
    if (!buf) o->failed = 1, o->err_no = ENOMEM;
    for (long left = at; !o->failed && left > 0;) {
        size_t want = left < (long)chunk ? (size_t)left : chunk;
        if (fread(buf, 1, want, back) != want) {
            o->failed = 1, o->err_no = errno ? errno : EIO;
            break;
        }
        fnv(&sum, buf, want);
        left -= (long)want;
    }
    free(buf);
    if (back) fclose(back);
    put_at(o, &sum, sizeof sum, at);
    int rc = 0;
    if (o->failed || kf_atomic_commit(af)) {
        int e = o->failed ? o->err_no : errno;
        if (af->f) kf_atomic_abort(af);
        snprintf(err, errlen, "%s: writing checkpoint failed: %s", af->path, kf_io_reason(e));
        rc = -1;
    }
    free(af);
    o->af = NULL;
    return rc;
}

/* ---- reading: nothing the header says is used before the file vouches for it ---- */

/* the bytes one particle takes in the file */
static size_t particle_bytes(void) {
    kf_particles p;
    return KF_PARTICLE_REAL_PLANES * sizeof(kf_real) + sizeof *p.mat + sizeof *p.id + sizeof *p.obj + sizeof *p.colour;
}

/* The size a checkpoint with this header has: header, particles, rigid
 * states, solver state, checksum. 0 when a count is so large that the size
 * overflows 64 bits (no real file holds it). */
static uint64_t expected_size(const header *h) {
    uint64_t parts, rig, poly, total;
    if (__builtin_mul_overflow(h->particles, (uint64_t)particle_bytes(), &parts) ||
        __builtin_mul_overflow((uint64_t)h->poly_ids, (uint64_t)(KF_POLY_REALS * sizeof(kf_real)), &poly) ||
        __builtin_mul_overflow((uint64_t)h->nrigid, (uint64_t)sizeof(kf_rigid_state), &rig) ||
        __builtin_add_overflow(parts, (uint64_t)sizeof *h + sizeof(uint64_t), &total) ||
        __builtin_add_overflow(total, rig, &total) || __builtin_add_overflow(total, h->rsim_bytes, &total) ||
        __builtin_add_overflow(total, poly, &total))
        return 0;
    return total;
}

/* FNV-1a of the file's first `len` bytes, read in chunks from the start.
 * Returns 0, or -1 when the file cannot be read that far. */
static int hash_prefix(FILE *f, uint64_t len, uint64_t *sum) {
    enum { CHUNK = 1 << 20 };
    unsigned char *buf = malloc(CHUNK);
    *sum = KF_FNV_BASIS;
    if (!buf || fseek(f, 0, SEEK_SET) != 0) {
        free(buf);
        return -1;
    }
    while (len > 0) {
        size_t want = len < CHUNK ? (size_t)len : CHUNK;
        if (fread(buf, 1, want, f) != want) break;
        fnv(sum, buf, want);
        len -= want;
    }
    free(buf);
    return len == 0 ? 0 : -1;
}

/* An open checkpoint whose header has been checked against the file. */
typedef struct ck_file {
    FILE *f;
    uint64_t size; /* bytes on disk */
    header h;
} ck_file;

/* the header fields this build can read, or the reason it cannot (the
 * checksum has already vouched for them, so the reason is true) */
static int header_usable(const ck_file *c, const char *path, char *err, size_t errlen) {
    const header *h = &c->h;
    if (h->version != KF_CHECKPOINT_VERSION) {
        snprintf(err, errlen, "%s: checkpoint format version %u, this kerf reads version %d", path, h->version,
                 KF_CHECKPOINT_VERSION);
        return -1;
    }
    if (h->real_size != 4 && h->real_size != 8) {
        snprintf(err, errlen, "%s: checkpoint header is damaged (a real of %u bytes)", path, h->real_size);
        return -1;
    }
    if (h->real_size != sizeof(kf_real)) {
        snprintf(err, errlen, "%s: checkpoint was written by a %s-precision build, this is %s precision", path,
                 h->real_size == 8 ? "double" : "single", sizeof(kf_real) == 8 ? "double" : "single");
        return -1;
    }
    if (h->nrigid > KF_MAX_RIGIDS) {
        snprintf(err, errlen, "%s: checkpoint header is damaged (%u rigid bodies, at most %d)", path, h->nrigid,
                 KF_MAX_RIGIDS);
        return -1;
    }
    uint64_t want = expected_size(h);
    if (want == 0) {
        snprintf(err, errlen,
                 "%s: checkpoint header is damaged: %llu particles, %u rigid bodies and %llu solver bytes would take "
                 "more than 2^64 bytes, the file has %llu",
                 path, (unsigned long long)h->particles, h->nrigid, (unsigned long long)h->rsim_bytes,
                 (unsigned long long)c->size);
        return -1;
    }
    if (want != c->size) {
        snprintf(err, errlen,
                 "%s: checkpoint header is damaged: %llu particles, %u rigid bodies and %llu solver bytes need %llu "
                 "bytes, the file has %llu",
                 path, (unsigned long long)h->particles, h->nrigid, (unsigned long long)h->rsim_bytes,
                 (unsigned long long)want, (unsigned long long)c->size);
        return -1;
    }
    return 0;
}

/* why a file whose checksum does not match is bad: cut short (the header
 * is plausible and asks for more bytes than there are), else damaged */
static void explain_mismatch(const ck_file *c, const char *path, char *err, size_t errlen) {
    const header *h = &c->h;
    uint64_t want = expected_size(h);
    int plausible = h->version == KF_CHECKPOINT_VERSION && h->real_size == sizeof(kf_real) &&
                    h->nrigid <= KF_MAX_RIGIDS && want != 0;
    if (plausible && want > c->size)
        snprintf(err, errlen, "%s: checkpoint is truncated (%llu of %llu bytes; expected %llu particles)", path,
                 (unsigned long long)c->size, (unsigned long long)want, (unsigned long long)h->particles);
    else if (want != c->size)
        snprintf(err, errlen,
                 "%s: checkpoint checksum mismatch (file damaged: its header claims %llu particles, which %llu bytes "
                 "do not hold)",
                 path, (unsigned long long)h->particles, (unsigned long long)c->size);
    else snprintf(err, errlen, "%s: checkpoint checksum mismatch (file damaged)", path);
}

/* Open, read the header, check the magic. With `verify`, the checksum over
 * the whole file is checked before any other field is believed; without it
 * (finding where to resume: headers only) it is checked only when the
 * header looks foreign, so that damage is not reported as another build.
 * Returns 0 with c->f open, or -1 with the reason in err. */
static int ck_open(ck_file *c, const char *path, int verify, char *err, size_t errlen) {
    memset(c, 0, sizeof *c);
    c->f = fopen(path, "rb");
    struct stat st;
    if (!c->f || fstat(fileno(c->f), &st) != 0) {
        snprintf(err, errlen, "%s: cannot open checkpoint: %s", path, strerror(errno));
        if (c->f) fclose(c->f);
        return -1;
    }
    if (!S_ISREG(st.st_mode)) {
        snprintf(err, errlen, "%s: not a kerf checkpoint (not a regular file)", path);
        fclose(c->f);
        return -1;
    }
    c->size = (uint64_t)st.st_size;
    if (c->size < sizeof c->h + sizeof(uint64_t) || fread(&c->h, sizeof c->h, 1, c->f) != 1) {
        snprintf(err, errlen, "%s: not a kerf checkpoint (too short: %llu bytes)", path, (unsigned long long)c->size);
        fclose(c->f);
        return -1;
    }
    if (memcmp(c->h.magic, MAGIC, sizeof MAGIC) != 0) {
        snprintf(err, errlen, "%s: not a kerf checkpoint (bad magic)", path);
        fclose(c->f);
        return -1;
    }
    char why[1200];
    int usable = header_usable(c, path, why, sizeof why) == 0;
    if (verify || !usable) {
        uint64_t sum = 0, stored = 0;
        int readable =
            hash_prefix(c->f, c->size - sizeof stored, &sum) == 0 && fread(&stored, sizeof stored, 1, c->f) == 1;
        if (!readable) {
            snprintf(err, errlen, "%s: cannot read checkpoint: %s", path, strerror(errno ? errno : EIO));
            fclose(c->f);
            return -1;
        }
        if (sum != stored) {
            explain_mismatch(c, path, err, errlen);
            fclose(c->f);
            return -1;
        }
    }
    if (!usable) {
        snprintf(err, errlen, "%s", why);
        fclose(c->f);
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
    ck_file c;
    if (ck_open(&c, path, 0, err, errlen)) return -1;
    fclose(c.f);
    fill_info(info, &c.h);
    return 0;
}

/* n items of `size` bytes into dst; the sizes were checked against the file */
static int get(FILE *f, void *dst, size_t size, size_t n) { return n == 0 || fread(dst, size, n, f) == n; }

/* ---- reading a part, a window of particles at a time ---- */

/* particles in one window of a part's read: the reader holds this many
 * besides its part */
enum { PART_WINDOW = 1 << 15 };

/* where each particle array begins in a file of n particles: the real
 * planes, then material, id, object and colour (the order of the writer) */
typedef struct ck_layout {
    off_t plane[KF_PARTICLE_REAL_PLANES], mat, id, obj, colour, after;
} ck_layout;

static void layout_of(ck_layout *l, size_t n) {
    off_t at = (off_t)sizeof(header);
    kf_particles p;
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) l->plane[k] = at, at += (off_t)(n * sizeof(kf_real));
    l->mat = at, at += (off_t)(n * sizeof *p.mat);
    l->id = at, at += (off_t)(n * sizeof *p.id);
    l->obj = at, at += (off_t)(n * sizeof *p.obj);
    l->colour = at, at += (off_t)(n * sizeof *p.colour);
    l->after = at;
}

/* m items of `size` bytes at item `first` of the array that begins at `base` */
static int get_at(FILE *f, off_t base, size_t first, void *dst, size_t size, size_t m) {
    return m == 0 || (fseeko(f, base + (off_t)(first * size), SEEK_SET) == 0 && fread(dst, size, m, f) == m);
}

/* particles [a, a + w->n) into the window: positions only, or everything */
static int get_window(FILE *f, const ck_layout *l, size_t a, kf_particles *w, int positions_only) {
    const size_t m = w->n;
    int ok = 1;
    for (int k = 0; ok && k < (positions_only ? 3 : KF_PARTICLE_REAL_PLANES); k++)
        ok = get_at(f, l->plane[k], a, w->plane[k], sizeof(kf_real), m);
    if (positions_only) return ok;
    return ok && get_at(f, l->mat, a, w->mat, sizeof *w->mat, m) && get_at(f, l->id, a, w->id, sizeof *w->id, m) &&
           get_at(f, l->obj, a, w->obj, sizeof *w->obj, m) && get_at(f, l->colour, a, w->colour, sizeof *w->colour, m);
}

/* window particle i to the end of p (reserved) */
static void append(kf_particles *p, const kf_particles *w, size_t i) {
    const size_t j = p->n++;
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) p->plane[k][j] = w->plane[k][i];
    p->mat[j] = w->mat[i], p->id[j] = w->id[i], p->obj[j] = w->obj[i], p->colour[j] = w->colour[i];
}

/* The particles of the file into p: all of them, or those the filter keeps
 * (two passes of windows). Returns 0, -1 (read or memory; errno says), or
 * -2 with a material the model lacks (*bad: the particle, *bad_mat its
 * material). */
static int read_particles(FILE *f, size_t n, const kf_model *m, const kf_checkpoint_filter *filter, kf_particles *p,
                          size_t *bad, unsigned *bad_mat) {
    if (!filter) {
        /* the whole file: each array in one read */
        int ok = fseeko(f, (off_t)sizeof(header), SEEK_SET) == 0 && kf_particles_reserve(p, n ? n : 1) == 0;
        for (int k = 0; ok && k < KF_PARTICLE_REAL_PLANES; k++) ok = get(f, p->plane[k], sizeof(kf_real), n);
        ok = ok && get(f, p->mat, sizeof *p->mat, n) && get(f, p->id, sizeof *p->id, n) &&
             get(f, p->obj, sizeof *p->obj, n) && get(f, p->colour, sizeof *p->colour, n);
        if (!ok) return -1;
        p->n = n;
        for (size_t i = 0; i < n; i++)
            if (p->mat[i] >= m->nmat) return *bad = i, *bad_mat = p->mat[i], -2;
        return 0;
    }
    ck_layout l;
    layout_of(&l, n);
    kf_particles w;
    memset(&w, 0, sizeof w);
    if (kf_particles_reserve(&w, PART_WINDOW)) return kf_particles_free(&w), -1;
    /* first pass: every position, for the filter to count */
    int rc = 0;
    for (size_t a = 0; rc == 0 && a < n; a += PART_WINDOW) {
        w.n = n - a < PART_WINDOW ? n - a : PART_WINDOW;
        if (!get_window(f, &l, a, &w, 1) || filter->see(filter->ctx, w.x, w.n)) rc = -1;
    }
    long want = rc ? -1 : filter->settle(filter->ctx);
    if (want < 0 || kf_particles_reserve(p, (size_t)want + 1)) rc = -1;
    /* second pass: the kept particles, in file order; every material checked */
    for (size_t a = 0; rc == 0 && a < n; a += PART_WINDOW) {
        w.n = n - a < PART_WINDOW ? n - a : PART_WINDOW;
        if (!get_window(f, &l, a, &w, 0)) {
            rc = -1;
            break;
        }
        for (size_t i = 0; rc == 0 && i < w.n; i++) {
            if (w.mat[i] >= m->nmat) {
                *bad = a + i, *bad_mat = w.mat[i], rc = -2;
                break;
            }
            const kf_real x[3] = {w.x[0][i], w.x[1][i], w.x[2][i]};
            if (!filter->keep(filter->ctx, x)) continue;
            /* more than settle said: the filter contradicts itself */
            if (p->n == (size_t)want) {
                errno = EINVAL;
                rc = -1;
                break;
            }
            append(p, &w, i);
        }
    }
    kf_particles_free(&w);
    if (rc == 0 && p->n != (size_t)want) errno = EINVAL, rc = -1;
    if (rc == 0 && fseeko(f, l.after, SEEK_SET) != 0) rc = -1;
    return rc;
}

int kf_checkpoint_read_part(const char *path, const kf_model *m, kf_state *s, const kf_checkpoint_filter *filter,
                            kf_checkpoint_info *info, char *err, size_t errlen) {
    ck_file c;
    if (ck_open(&c, path, 1, err, errlen)) return -1;
    const header h = c.h; /* verified: checksum, version, precision, and sizes against the file length */
    if (h.nrigid != (uint32_t)s->nrigid || h.rsim_bytes != (s->rsim ? kf_rigid_sim_state_size(s->rsim) : 0)) {
        fclose(c.f);
        snprintf(err, errlen, "%s: checkpoint has %u rigid bodies in another configuration than the shot's %d", path,
                 h.nrigid, s->nrigid);
        return -1;
    }
    /* read into a fresh particle set; the state changes only if all is well */
    kf_particles p;
    memset(&p, 0, sizeof p);
    size_t n = (size_t)h.particles, bad = 0;
    unsigned bad_mat = 0;
    kf_rigid_state rigid[KF_MAX_RIGIDS];
    void *rsim = h.rsim_bytes ? malloc((size_t)h.rsim_bytes) : NULL;
    const size_t poly_reals = (size_t)h.poly_ids * KF_POLY_REALS;
    kf_real *poly = poly_reals ? malloc(poly_reals * sizeof *poly) : NULL;
    errno = 0;
    int rc =
        (rsim || !h.rsim_bytes) && (poly || !poly_reals) ? read_particles(c.f, n, m, filter, &p, &bad, &bad_mat) : -1;
    if (rc == 0 && !(get(c.f, rigid, sizeof rigid[0], h.nrigid) && get(c.f, rsim, 1, (size_t)h.rsim_bytes) &&
                     get(c.f, poly, sizeof *poly, poly_reals)))
        rc = -1;
    fclose(c.f);
    if (rc) {
        kf_particles_free(&p);
        free(rsim);
        free(poly);
        if (rc == -2)
            snprintf(err, errlen, "%s: particle %zu uses material %u but the shot defines %d", path, bad, bad_mat,
                     m->nmat);
        else
            snprintf(err, errlen, "%s: cannot read checkpoint of %zu particles: %s", path, n,
                     errno ? strerror(errno) : "out of memory");
        return -1;
    }
    kf_particles_free(&s->p);
    s->p = p;
    memcpy(s->rigid, rigid, h.nrigid * sizeof rigid[0]);
    if (rsim) kf_rigid_sim_load(s->rsim, rsim, h.rsim_bytes);
    free(rsim);
    s->time = h.time;
    s->substep = (long)h.substep;
    s->next_id = (uint32_t)h.next_id;
    /* polypic's modes as the file has them; none in the file means none yet */
    if (s->poly_cap) memset(s->poly, 0, s->poly_cap * KF_POLY_REALS * sizeof *s->poly);
    if (poly_reals && s->next_id >= h.poly_ids && kf_poly_reserve(s) == 0)
        memcpy(s->poly, poly, poly_reals * sizeof *poly);
    free(poly);
    s->tau_valid = 1; /* the stress planes are in the file, bit for bit */
    s->g.valid = 0;
    fill_info(info, &h);
    return 0;
}

int kf_checkpoint_windows(const char *path, const kf_model *m, kf_state *win,
                          int (*visit)(void *ctx, const kf_state *win, size_t at), void *ctx, char *err,
                          size_t errlen) {
    ck_file c;
    if (ck_open(&c, path, 1, err, errlen)) return -1;
    const header h = c.h; /* verified as kf_checkpoint_read has it */
    const size_t n = (size_t)h.particles;
    ck_layout l;
    layout_of(&l, n);
    win->time = h.time;
    win->substep = (long)h.substep;
    win->next_id = (uint32_t)h.next_id;
    win->tau_valid = 1;
    win->g.valid = 0;
    win->p.n = 0;
    int rc = 0;
    errno = 0;
    if (kf_particles_reserve(&win->p, PART_WINDOW)) {
        snprintf(err, errlen, "%s: out of memory reading checkpoint", path);
        rc = -1;
    }
    for (size_t a = 0; rc == 0 && a < n; a += PART_WINDOW) {
        win->p.n = n - a < PART_WINDOW ? n - a : PART_WINDOW;
        if (!get_window(c.f, &l, a, &win->p, 0)) {
            snprintf(err, errlen, "%s: cannot read checkpoint of %zu particles: %s", path, n,
                     strerror(errno ? errno : EIO));
            rc = -1;
            break;
        }
        for (size_t i = 0; rc == 0 && i < win->p.n; i++)
            if (win->p.mat[i] >= m->nmat) {
                snprintf(err, errlen, "%s: particle %zu uses material %u but the shot defines %d", path, a + i,
                         (unsigned)win->p.mat[i], m->nmat);
                rc = -1;
            }
        if (rc == 0 && visit(ctx, win, a)) rc = -1; /* visit says why, err is left to it */
    }
    fclose(c.f);
    return rc;
}

int kf_checkpoint_read(const char *path, const kf_model *m, kf_state *s, kf_checkpoint_info *info, char *err,
                       size_t errlen) {
    return kf_checkpoint_read_part(path, m, s, NULL, info, err, errlen);
}
