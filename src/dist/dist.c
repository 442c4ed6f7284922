/* dist.c — MPI start and stop, the ranks' key ranges (cut by particle
 * count), gathering the whole state, and the global reductions the step
 * agrees through. See dist.h for the scheme. */
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "../core/timer.h"
#include "internal.h"
#include "../rigid/rigid.h"

static int g_size = 1, g_rank = 0, g_started = 0;

/* The launcher ends the other ranks when one dies: Open MPI by SIGTERM
 * (also what its Ctrl-C sends), MPICH's Hydra by SIGKILL, which the
 * watchdog answers for (watch.c); Hydra passes Ctrl-C on as SIGINT. Rank 0
 * says why before it goes, tells the watchdog it did, then ends by the
 * same signal. */
static void stopped(int sig) {
    static const char intr[] = "kerf: interrupted; `kerf run --resume` continues after the last checkpoint written\n";
    if (sig == SIGINT) {
        ssize_t w = write(2, intr, sizeof intr - 1);
        (void)w;
    } else kf_dist_say_stopped();
    kf_dist_watch_say(KF_DIST_WATCH_SAID);
    signal(sig, SIG_DFL);
    raise(sig);
}

/* rank 0 exits: what it had to say is said */
static void exiting(void) { kf_dist_watch_say(KF_DIST_WATCH_DONE); }

/* rank 0 of several, as the launcher's environment says before MPI starts
 * (a launcher that gives no size counts as several) */
static int first_of_several(void) {
    const char *rank = getenv("OMPI_COMM_WORLD_RANK"), *size = getenv("OMPI_COMM_WORLD_SIZE");
    if (!rank) rank = getenv("PMI_RANK");
    if (!rank) rank = getenv("PMIX_RANK");
    if (!size) size = getenv("PMI_SIZE");
    return rank && !strcmp(rank, "0") && (!size || atoi(size) > 1);
}

int kf_dist_init(int *argc, char ***argv) {
    /* only under a launcher: a plain `kerf` never touches MPI */
    if (!getenv("OMPI_COMM_WORLD_SIZE") && !getenv("PMI_SIZE") && !getenv("PMIX_RANK")) return 1;
    /* the watchdog is forked before MPI starts, so it shares none of MPI's state */
    if (first_of_several()) {
        kf_dist_watch_start();
        atexit(exiting);
    }
    if (MPI_Init(argc, argv) != MPI_SUCCESS) return 1;
    g_started = 1;
    MPI_Comm_size(MPI_COMM_WORLD, &g_size);
    MPI_Comm_rank(MPI_COMM_WORLD, &g_rank);
    if (g_size > 1 && g_rank == 0) {
        signal(SIGTERM, stopped);
        signal(SIGINT, stopped);
    } else exiting(); /* the environment guessed wrong: no watchdog */
    return g_size;
}

void kf_dist_finalize(void) {
    if (g_started) MPI_Finalize();
    g_started = 0;
}

int kf_dist_size(void) { return g_size; }
int kf_dist_rank(void) { return g_rank; }

int kf_dist_bcast_int(int v) {
    if (g_started && g_size > 1) MPI_Bcast(&v, 1, MPI_INT, 0, MPI_COMM_WORLD);
    return v;
}

void kf_dist_abort(int code) {
    /* rank 0 has printed its error */
    if (g_rank == 0) exiting();
    if (g_started && g_size > 1) MPI_Abort(MPI_COMM_WORLD, code);
}

double kf_dist_clock(void) { return kf_now_ms(); }

const char *kf_dist_unsupported_def(const kf_sim_def *sim, int nrigid) {
    if (sim->integrator == KF_INTEGRATOR_IMPLICIT) return "the implicit integrator (sim.integrator: implicit)";
    if (sim->transfer == KF_TRANSFER_FLIP) return "the flip transfer (sim.transfer: flip)";
    if (sim->transfer == KF_TRANSFER_POLYPIC) return "the polypic transfer (sim.transfer: polypic)";
    return NULL;
}

const char *kf_dist_unsupported(const kf_model *m) { return kf_dist_unsupported_def(&m->sim, m->nrigid); }

int kf_dist_reserve(void **buf, size_t *cap, size_t want) {
    if (want <= *cap && *buf) return 0;
    size_t c = *cap ? *cap : 4096;
    while (c < want) c *= 2;
    void *q = aligned_alloc(64, (c + 63) / 64 * 64);
    if (!q) return -1;
    free(*buf);
    *buf = q;
    *cap = c;
    return 0;
}

/* ---- the particle record ---- */

size_t kf_dist_record_bytes(void) { return KF_PARTICLE_REAL_PLANES * sizeof(kf_real) + 12; }

void kf_dist_pack(const kf_particles *p, size_t i, char *dst) {
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++, dst += sizeof(kf_real))
        memcpy(dst, &p->plane[k][i], sizeof(kf_real));
    memcpy(dst, &p->id[i], 4);
    memcpy(dst + 4, &p->colour[i], 4);
    memcpy(dst + 8, &p->mat[i], 2);
    memcpy(dst + 10, &p->obj[i], 2);
}

void kf_dist_unpack(kf_particles *p, size_t j, const char *src) {
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++, src += sizeof(kf_real))
        memcpy(&p->plane[k][j], src, sizeof(kf_real));
    memcpy(&p->id[j], src, 4);
    memcpy(&p->colour[j], src + 4, 4);
    memcpy(&p->mat[j], src + 8, 2);
    memcpy(&p->obj[j], src + 10, 2);
}

/* ---- the cut ---- */

/* split[] from owner blocks in key order with their particle counts: rank r
 * starts at the first block before which r/size of the particles lie */
void kf_dist_cut(struct kf_dist *d, const uint64_t *key, const int64_t *count, size_t nb) {
    int64_t total = 0;
    for (size_t b = 0; b < nb; b++) total += count[b];
    d->split[0] = 0;
    for (int r = 1; r <= d->size; r++) d->split[r] = UINT64_MAX;
    int64_t before = 0;
    int r = 1;
    for (size_t b = 0; b < nb && r < d->size; b++) {
        while (r < d->size && before * d->size >= total * r) d->split[r++] = key[b];
        before += count[b];
    }
    /* ranks left without blocks get empty ranges at the top */
    for (; r < d->size; r++) d->split[r] = UINT64_MAX;
}

/* This rank's part's arrays cut to its size: the pages of the whole scene
 * it was built from go back (a large block shrinks in place). A shrink
 * that fails leaves that array larger, which is harmless. */
static void *cut_to(void *a, size_t bytes) {
    void *q = realloc(a, bytes);
    return q ? q : a;
}

void kf_dist_shrink(kf_particles *p) {
    size_t c = p->n ? p->n : 1;
    if (c >= p->cap) return;
    for (int k = 0; k < KF_PARTICLE_REAL_PLANES; k++) kf_particles_plane_resize(p, k, c); /* kept where it fails */
    p->mat = cut_to(p->mat, c * sizeof *p->mat);
    p->obj = cut_to(p->obj, c * sizeof *p->obj);
    p->colour = cut_to(p->colour, c * sizeof *p->colour);
    p->id = cut_to(p->id, c * sizeof *p->id);
    p->cap = c;
}

struct kf_dist *kf_dist_new(void) {
    struct kf_dist *d = calloc(1, sizeof *d);
    if (!d) return NULL;
    d->comm = MPI_COMM_WORLD;
    d->rank = g_rank;
    d->size = g_size;
    d->split = calloc((size_t)d->size + 1, sizeof *d->split);
    d->counts = calloc(4 * (size_t)d->size, sizeof *d->counts);
    if (!d->split || !d->counts) return kf_dist_free(d), NULL;
    return d;
}

void kf_dist_free(struct kf_dist *d) {
    if (!d) return;
    free(d->split);
    free(d->counts);
    free(d->fnb);
    free(d->forder);
    free(d->recv);
    free(d->send);
    free(d->pack);
    free(d->unpack);
    free(d->fsend);
    free(d->frecv);
    free(d->ffield);
    free(d->xsend);
    free(d->xrecv);
    free(d->xmsg);
    free(d->colour_save);
    free(d->owner_keys);
    free(d->pbuf[0]);
    free(d->pbuf[1]);
    free(d);
}

void kf_dist_rebalance(kf_state *s, double threshold) {
    struct kf_dist *d = s->dist;
    if (!d) return;
    double t0 = kf_dist_clock();
    long n = (long)s->p.n, nmax, total;
    MPI_Allreduce(&n, &nmax, 1, MPI_LONG, MPI_MAX, d->comm);
    MPI_Allreduce(&n, &total, 1, MPI_LONG, MPI_SUM, d->comm);
    if (total == 0 || (double)nmax * d->size <= threshold * (double)total) {
        d->stats.comm_ms += kf_dist_clock() - t0;
        return;
    }
    /* every rank's owner blocks and counts, in rank order = key order */
    const kf_grid *g = &s->g;
    int nb = g->valid ? (int)g->nowner : 0;
    int *nbs = d->counts, *displ = d->counts + d->size;
    MPI_Allgather(&nb, 1, MPI_INT, nbs, 1, MPI_INT, d->comm);
    size_t all = 0;
    for (int r = 0; r < d->size; r++) displ[r] = (int)all, all += (size_t)nbs[r];
    uint64_t *mine = malloc(((size_t)nb + 1) * 2 * sizeof *mine), *every = malloc((all + 1) * 2 * sizeof *every);
    uint64_t *key = malloc((all + 1) * sizeof *key);
    int64_t *count = malloc((all + 1) * sizeof *count);
    if (mine && every && key && count) {
        for (int r = 0; r < nb; r++) {
            const int32_t *c = &g->bcoord[3 * r];
            mine[2 * r] = kf_block_key(c[0], c[1], c[2]);
            mine[2 * r + 1] = (uint64_t)(g->pstart[r + 1] - g->pstart[r]);
        }
        for (int r = 0; r < d->size; r++) nbs[r] *= 2, displ[r] *= 2;
        MPI_Allgatherv(mine, 2 * nb, MPI_UINT64_T, every, nbs, displ, MPI_UINT64_T, d->comm);
        for (size_t b = 0; b < all; b++) key[b] = every[2 * b], count[b] = (int64_t)every[2 * b + 1];
        kf_dist_cut(d, key, count, all);
        d->stats.rebalances++;
    }
    free(mine), free(every), free(key), free(count);
    d->stats.comm_ms += kf_dist_clock() - t0;
}

/* ---- gathering the whole state on rank 0 ---- */

/* records in one message of the gather: every rank's buffers stay this
 * small whatever the part's size */
enum { GATHER_CHUNK = 1 << 15 };

/* n records from src into whole: at `at` onwards, or each at its id */
static int place(kf_state *whole, const char *src, size_t n, size_t at, int by_id, size_t total) {
    const size_t rb = kf_dist_record_bytes();
    for (size_t i = 0; i < n; i++) {
        size_t j = at + i;
        if (by_id) {
            uint32_t id;
            memcpy(&id, src + i * rb + KF_PARTICLE_REAL_PLANES * sizeof(kf_real), sizeof id);
            if ((size_t)id >= total) return -1;
            j = id;
        }
        kf_dist_unpack(&whole->p, j, src + i * rb);
    }
    return 0;
}

int kf_dist_gather(const kf_state *s, kf_state *whole, int by_id) {
    struct kf_dist *d = s->dist;
    double t0 = kf_dist_clock();
    const size_t rb = kf_dist_record_bytes();
    MPI_Datatype rec;
    MPI_Type_contiguous((int)rb, MPI_BYTE, &rec);
    MPI_Type_commit(&rec);
    int n = (int)s->p.n, *cnt = d->counts;
    MPI_Gather(&n, 1, MPI_INT, cnt, 1, MPI_INT, 0, d->comm);
    if (kf_dist_reserve((void **)&d->pbuf[0], &d->pbuf_cap[0], GATHER_CHUNK * rb)) MPI_Abort(d->comm, 1);
    int rc = 0;
    size_t total = 0;
    if (d->rank != 0) {
        /* this rank's part in chunks, in order (messages from one rank arrive in order) */
        for (size_t at = 0; at < (size_t)n; at += GATHER_CHUNK) {
            size_t m = (size_t)n - at < GATHER_CHUNK ? (size_t)n - at : GATHER_CHUNK;
            for (size_t i = 0; i < m; i++) kf_dist_pack(&s->p, at + i, d->pbuf[0] + i * rb);
            MPI_Send(d->pbuf[0], (int)m, rec, 0, 1, d->comm);
        }
    } else {
        for (int r = 0; r < d->size; r++) total += (size_t)cnt[r];
        if (kf_particles_reserve(&whole->p, total + 1)) rc = -1;
        /* each rank's part in turn, in rank order (the one-rank order), a
         * chunk at a time; after a failure the rest is received and dropped */
        size_t at = 0;
        for (int r = 0; r < d->size; r++) {
            for (size_t off = 0; off < (size_t)cnt[r]; off += GATHER_CHUNK) {
                size_t m = (size_t)cnt[r] - off < GATHER_CHUNK ? (size_t)cnt[r] - off : GATHER_CHUNK;
                if (r == 0)
                    for (size_t i = 0; i < m; i++) kf_dist_pack(&s->p, off + i, d->pbuf[0] + i * rb);
                else MPI_Recv(d->pbuf[0], (int)m, rec, r, 1, d->comm, MPI_STATUS_IGNORE);
                if (rc == 0) rc = place(whole, d->pbuf[0], m, at + off, by_id, total);
            }
            at += (size_t)cnt[r];
        }
    }
    MPI_Type_free(&rec);
    if (d->rank == 0) {
        if (rc == 0) {
            whole->p.n = total;
            whole->time = s->time;
            whole->substep = s->substep;
            whole->next_id = s->next_id;
            whole->tau_valid = s->tau_valid;
            whole->g.valid = 0;
            whole->drive_cells = s->drive_cells;
            /* the rigid bodies and their solver: every rank's copy is the same */
            memcpy(whole->rigid, s->rigid, sizeof s->rigid);
            if (s->rsim && whole->rsim) {
                size_t nb = kf_rigid_sim_state_size(s->rsim);
                void *buf = malloc(nb + 1);
                if (buf) kf_rigid_sim_save(s->rsim, buf);
                if (!buf || kf_rigid_sim_load(whole->rsim, buf, nb)) rc = -1;
                free(buf);
            }
        }
    }
    d->stats.comm_ms += kf_dist_clock() - t0;
    return rc;
}

/* ---- agreement and reductions ---- */

int kf_dist_agree(const kf_state *s, int found, kf_trouble *t) {
    struct kf_dist *d = s->dist;
    double t0 = kf_dist_clock();
    int any = 0;
    MPI_Allreduce(&found, &any, 1, MPI_INT, MPI_LOR, d->comm);
    if (any) {
        /* the report: the lowest particle id among the ranks that found trouble */
        kf_trouble mine = *t, *all = malloc((size_t)d->size * sizeof *all);
        if (!found) mine.found = 0;
        if (!all) MPI_Abort(d->comm, 1);
        MPI_Allgather(&mine, (int)sizeof mine, MPI_BYTE, all, (int)sizeof mine, MPI_BYTE, d->comm);
        int best = -1;
        for (int r = 0; r < d->size; r++)
            if (all[r].found && (best < 0 || all[r].particle < all[best].particle)) best = r;
        *t = all[best];
        free(all);
    }
    d->stats.comm_ms += kf_dist_clock() - t0;
    return any;
}

double kf_dist_max(const kf_state *s, double v) {
    double out = v, t0 = kf_dist_clock();
    MPI_Allreduce(&v, &out, 1, MPI_DOUBLE, MPI_MAX, s->dist->comm);
    s->dist->stats.comm_ms += kf_dist_clock() - t0;
    return out;
}

void kf_dist_min_reals(const kf_state *s, kf_real *v, int n) {
    double t0 = kf_dist_clock();
    MPI_Allreduce(MPI_IN_PLACE, v, n, sizeof(kf_real) == 8 ? MPI_DOUBLE : MPI_FLOAT, MPI_MIN, s->dist->comm);
    s->dist->stats.comm_ms += kf_dist_clock() - t0;
}

long kf_dist_sum_long(const kf_state *s, long v) {
    long out = v;
    if (s->dist) MPI_Allreduce(&v, &out, 1, MPI_LONG, MPI_SUM, s->dist->comm);
    return out;
}

void kf_dist_stats_get(const kf_state *s, kf_dist_stats *out) {
    struct kf_dist *d = s->dist;
    memset(out, 0, sizeof *out);
    if (!d) return;
    *out = d->stats;
    unsigned long n = s->p.n, lo, hi;
    MPI_Allreduce(&n, &lo, 1, MPI_UNSIGNED_LONG, MPI_MIN, d->comm);
    MPI_Allreduce(&n, &hi, 1, MPI_UNSIGNED_LONG, MPI_MAX, d->comm);
    out->particles_min = lo;
    out->particles_max = hi;
    double sums[4] = {d->stats.halo_bytes, d->stats.migrated, d->stats.pieces_bytes, d->stats.pieces_classes};
    MPI_Allreduce(MPI_IN_PLACE, sums, 4, MPI_DOUBLE, MPI_SUM, d->comm);
    out->halo_bytes = sums[0];
    out->migrated = sums[1];
    out->pieces_bytes = sums[2];
    out->pieces_classes = sums[3];
    MPI_Allreduce(&d->stats.comm_ms, &out->comm_ms, 1, MPI_DOUBLE, MPI_MAX, d->comm);
}

void kf_dist_stats_reset(kf_state *s) {
    if (s->dist) memset(&s->dist->stats, 0, sizeof s->dist->stats);
}
