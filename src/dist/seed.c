/* seed.c — seeding only this rank's part of the scene.
 *
 * Every rank samples every object twice, the same way. The first pass
 * counts particles per owner block: the counts, and so the cut, are the
 * same on every rank without a message. The second pass keeps the
 * particles whose block lies in this rank's range, in sampling order and
 * with the ids a whole build gives them: the one-rank array's subsequence
 * in this rank's range, without the whole state ever existing here.
 *
 * A resume reads a checkpoint the same way (its positions counted a window
 * at a time, then the rank's particles kept in file order): kerf's stable
 * sort by block then orders them as the one-rank run's array, whose slice
 * they are. */
#include <stdlib.h>
#include <string.h>

#include "internal.h"

struct kf_dist_seed {
    kf_real inv_dx;
    int cubic;
    /* (key, count) runs of the first pass; merged by key when full */
    uint64_t *key;
    int64_t *count;
    size_t n, cap;
    size_t total; /* particles counted */
    size_t mine;  /* of those, in this rank's range (after the cut) */
    struct kf_dist *d;
};

kf_dist_seed *kf_dist_seed_new(const kf_model *m) {
    kf_dist_seed *sd = calloc(1, sizeof *sd);
    if (!sd) return NULL;
    sd->inv_dx = kf_model_inv_dx(m);
    sd->cubic = m->sim.kernel == KF_KERNEL_CUBIC;
    sd->d = kf_dist_new();
    if (!sd->d) return free(sd), NULL;
    return sd;
}

void kf_dist_seed_free(kf_dist_seed *sd) {
    if (!sd) return;
    free(sd->key);
    free(sd->count);
    kf_dist_free(sd->d);
    free(sd);
}

static uint64_t key_of(const kf_dist_seed *sd, const double *x) {
    /* the position as the state will hold it */
    return kf_dist_key_at((kf_real)x[0], (kf_real)x[1], (kf_real)x[2], sd->inv_dx, sd->cubic);
}

static int by_key(const void *a, const void *b) {
    const uint64_t x = *(const uint64_t *)a, y = *(const uint64_t *)b;
    return (x > y) - (x < y);
}

/* the runs sorted by key, equal keys merged (keys and counts travel as pairs) */
static int merge(kf_dist_seed *sd) {
    uint64_t(*pair)[2] = malloc((sd->n + 1) * sizeof *pair);
    if (!pair) return -1;
    for (size_t i = 0; i < sd->n; i++) pair[i][0] = sd->key[i], pair[i][1] = (uint64_t)sd->count[i];
    qsort(pair, sd->n, sizeof *pair, by_key);
    size_t j = 0;
    for (size_t i = 0; i < sd->n; i++) {
        if (j && sd->key[j - 1] == pair[i][0]) sd->count[j - 1] += (int64_t)pair[i][1];
        else sd->key[j] = pair[i][0], sd->count[j] = (int64_t)pair[i][1], j++;
    }
    sd->n = j;
    free(pair);
    return 0;
}

/* one more particle in block k */
static int count_key(kf_dist_seed *sd, uint64_t k) {
    sd->total++;
    /* neighbours on the lattice mostly share a block: one run */
    if (sd->n && sd->key[sd->n - 1] == k) {
        sd->count[sd->n - 1]++;
        return 0;
    }
    if (sd->n == sd->cap) {
        /* merged, and grown unless that freed half */
        if (sd->n && merge(sd)) return -1;
        if (sd->cap == 0 || sd->n > sd->cap / 2) {
            size_t c = sd->cap ? 2 * sd->cap : 4096;
            uint64_t *k2 = realloc(sd->key, c * sizeof *k2);
            if (!k2) return -1;
            sd->key = k2;
            int64_t *c2 = realloc(sd->count, c * sizeof *c2);
            if (!c2) return -1;
            sd->count = c2;
            sd->cap = c;
        }
    }
    sd->key[sd->n] = k, sd->count[sd->n] = 1, sd->n++;
    return 0;
}

int kf_dist_seed_count(kf_dist_seed *sd, const double *x3, size_t n) {
    for (size_t i = 0; i < n; i++)
        if (count_key(sd, key_of(sd, x3 + 3 * i))) return -1;
    return 0;
}

int kf_dist_seed_count_reals(kf_dist_seed *sd, kf_real *const x[3], size_t n) {
    for (size_t i = 0; i < n; i++)
        if (count_key(sd, kf_dist_key_at(x[0][i], x[1][i], x[2][i], sd->inv_dx, sd->cubic))) return -1;
    return 0;
}

int kf_dist_seed_cut(kf_dist_seed *sd) {
    if (merge(sd)) return -1;
    kf_dist_cut(sd->d, sd->key, sd->count, sd->n);
    /* this rank's share: the counts of the keys in its range */
    const struct kf_dist *d = sd->d;
    sd->mine = 0;
    for (size_t b = 0; b < sd->n; b++)
        if (kf_dist_rank_of(d, sd->key[b]) == d->rank) sd->mine += (size_t)sd->count[b];
    free(sd->key), free(sd->count);
    sd->key = NULL, sd->count = NULL, sd->n = sd->cap = 0;
    return 0;
}

int kf_dist_seed_owns(const kf_dist_seed *sd, const double x[3]) {
    return kf_dist_rank_of(sd->d, key_of(sd, x)) == sd->d->rank;
}

int kf_dist_seed_owns_real(const kf_dist_seed *sd, const kf_real x[3]) {
    return kf_dist_rank_of(sd->d, kf_dist_key_at(x[0], x[1], x[2], sd->inv_dx, sd->cubic)) == sd->d->rank;
}

size_t kf_dist_seed_mine(const kf_dist_seed *sd) { return sd->mine; }

void kf_dist_seed_adopt(kf_dist_seed *sd, kf_state *s) {
    kf_dist_free(s->dist);
    s->dist = sd->d;
    sd->d = NULL;
    s->next_id = (uint32_t)sd->total; /* the whole build's */
    s->g.valid = 0;
    kf_dist_shrink(&s->p);
    kf_dist_seed_free(sd);
}

void kf_dist_seed_adopt_read(kf_dist_seed *sd, kf_state *s) {
    const uint32_t next = s->next_id; /* the file's */
    kf_dist_seed_adopt(sd, s);
    s->next_id = next;
}
