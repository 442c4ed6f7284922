/* pieces.c — the pieces a cut leaves (see pieces.h). */
#include "pieces.h"

#include <math.h>
#include <stdlib.h>
#include <string.h>

#define SCAR_SHIFT 28

/* opposite sides of one blade: both scarred by the same body, sides differ */
static int cut_between(uint32_t a, uint32_t b) {
    uint32_t s = a >> SCAR_SHIFT;
    if (!s || s != b >> SCAR_SHIFT) return 0;
    return ((a ^ b) >> (2 * (s - 1)) & 1) != 0;
}

static size_t find(size_t *parent, size_t i) {
    while (parent[i] != i) parent[i] = parent[parent[i]], i = parent[i];
    return i;
}

typedef struct cell_entry {
    uint64_t key;
    size_t i;
} cell_entry;

static int cmp_entry(const void *a, const void *b) {
    const cell_entry *x = a, *y = b;
    if (x->key != y->key) return x->key < y->key ? -1 : 1;
    return x->i < y->i ? -1 : x->i > y->i;
}

static int cmp_pair(const void *a, const void *b) {
    const size_t *x = a, *y = b;
    if (x[0] != y[0]) return x[0] < y[0] ? -1 : 1;
    return x[1] < y[1] ? -1 : x[1] > y[1];
}

static uint64_t cell_key(int64_t i, int64_t j, int64_t k) {
    const int64_t o = (int64_t)1 << 20;
    return ((uint64_t)(i + o) & 0x1fffff) | ((uint64_t)(j + o) & 0x1fffff) << 21 | ((uint64_t)(k + o) & 0x1fffff) << 42;
}

/* the range of sorted entries with this key (binary search) */
static size_t lower(const cell_entry *e, size_t n, uint64_t key) {
    size_t lo = 0, hi = n;
    while (lo < hi) {
        size_t mid = (lo + hi) / 2;
        if (e[mid].key < key) lo = mid + 1;
        else hi = mid;
    }
    return lo;
}

int kf_pieces_classes(size_t n, const float *x, const uint32_t *colour, double h, double reach, uint8_t *cls) {
    memset(cls, 0, n);
    size_t scarred = 0;
    for (size_t i = 0; i < n; i++) scarred += (colour[i] >> SCAR_SHIFT) != 0;
    if (scarred == 0) return 1;
    const double R = 1.5 * h, R2 = R * R, inv = 1 / R;
    cell_entry *e = malloc(sizeof *e * (n + 1));
    size_t *parent = malloc(sizeof *parent * (n + 1));
    size_t ncut = 0, capcut = 1024;
    size_t *cuts = malloc(sizeof *cuts * 2 * capcut);
    if (!e || !parent || !cuts) goto oom;
    /* particles sorted into cells of edge R */
    for (size_t i = 0; i < n; i++) {
        e[i].key = cell_key((int64_t)floor(x[3 * i] * inv), (int64_t)floor(x[3 * i + 1] * inv),
                            (int64_t)floor(x[3 * i + 2] * inv));
        e[i].i = i;
        parent[i] = i;
    }
    qsort(e, n, sizeof *e, cmp_entry);
    /* neighbours joined unless a blade parted them */
    for (size_t s = 0; s < n; s++) {
        const size_t i = e[s].i;
        const int64_t c[3] = {(int64_t)floor(x[3 * i] * inv), (int64_t)floor(x[3 * i + 1] * inv),
                              (int64_t)floor(x[3 * i + 2] * inv)};
        for (int dz = -1; dz <= 1; dz++)
            for (int dy = -1; dy <= 1; dy++)
                for (int dxc = -1; dxc <= 1; dxc++) {
                    uint64_t key = cell_key(c[0] + dxc, c[1] + dy, c[2] + dz);
                    for (size_t t = lower(e, n, key); t < n && e[t].key == key; t++) {
                        const size_t j = e[t].i;
                        if (j <= i) continue; /* each pair once */
                        double d0 = x[3 * j] - x[3 * i], d1 = x[3 * j + 1] - x[3 * i + 1],
                               d2 = x[3 * j + 2] - x[3 * i + 2];
                        if (d0 * d0 + d1 * d1 + d2 * d2 >= R2) continue;
                        if (cut_between(colour[i], colour[j])) continue;
                        size_t a = find(parent, i), b = find(parent, j);
                        if (a != b) parent[a > b ? a : b] = a < b ? a : b; /* the smaller root wins: order-free */
                    }
                }
    }
    /* every scarred particle in one piece (material a blade stirred, which
     * closed up behind it): nothing is parted, one class */
    {
        size_t root = (size_t)-1;
        int one = 1;
        for (size_t i = 0; i < n && one; i++)
            if (colour[i] >> SCAR_SHIFT) {
                size_t r = find(parent, i);
                if (root == (size_t)-1) root = r;
                one = r == root;
            }
        if (one) {
            free(e), free(parent), free(cuts);
            return 1;
        }
    }
    /* the cuts between pieces: scarred particles on opposite sides of one
     * blade within the surfacer's reach of each other, in different
     * pieces, as (smaller root, larger root); searched among the scarred
     * particles alone, in cells of edge reach */
    ncut = 0;
    {
        const double inv2 = 1 / reach, reach2 = reach * reach;
        size_t ns = 0;
        for (size_t i = 0; i < n; i++)
            if (colour[i] >> SCAR_SHIFT) {
                e[ns].key = cell_key((int64_t)floor(x[3 * i] * inv2), (int64_t)floor(x[3 * i + 1] * inv2),
                                     (int64_t)floor(x[3 * i + 2] * inv2));
                e[ns].i = i;
                ns++;
            }
        qsort(e, ns, sizeof *e, cmp_entry);
        for (size_t s0 = 0; s0 < ns; s0++) {
            const size_t i = e[s0].i, ri = find(parent, i);
            const int64_t c[3] = {(int64_t)floor(x[3 * i] * inv2), (int64_t)floor(x[3 * i + 1] * inv2),
                                  (int64_t)floor(x[3 * i + 2] * inv2)};
            for (int dz = -1; dz <= 1; dz++)
                for (int dy = -1; dy <= 1; dy++)
                    for (int dxc = -1; dxc <= 1; dxc++) {
                        uint64_t key = cell_key(c[0] + dxc, c[1] + dy, c[2] + dz);
                        for (size_t t = lower(e, ns, key); t < ns && e[t].key == key; t++) {
                            const size_t j = e[t].i;
                            if (j <= i || !cut_between(colour[i], colour[j])) continue;
                            double d0 = x[3 * j] - x[3 * i], d1 = x[3 * j + 1] - x[3 * i + 1],
                                   d2 = x[3 * j + 2] - x[3 * i + 2];
                            if (d0 * d0 + d1 * d1 + d2 * d2 >= reach2) continue;
                            size_t rj = find(parent, j);
                            if (ri == rj) continue; /* joined elsewhere: not parted */
                            if (ncut == capcut) {
                                size_t *g = realloc(cuts, sizeof *cuts * 4 * capcut);
                                if (!g) goto oom;
                                cuts = g, capcut *= 2;
                            }
                            cuts[2 * ncut] = ri < rj ? ri : rj, cuts[2 * ncut + 1] = ri < rj ? rj : ri, ncut++;
                        }
                    }
        }
    }
    qsort(cuts, ncut, 2 * sizeof *cuts, cmp_pair);
    /* once each */
    size_t m = 0;
    for (size_t q = 0; q < ncut; q++)
        if (m == 0 || cuts[2 * q] != cuts[2 * (m - 1)] || cuts[2 * q + 1] != cuts[2 * (m - 1) + 1])
            cuts[2 * m] = cuts[2 * q], cuts[2 * m + 1] = cuts[2 * q + 1], m++;

    /* greedy colouring in root order: a piece takes the smallest class none
     * of its already-coloured cut neighbours has (roots are particle
     * indices; cls of a root holds its piece's class, 0 by default) */
    uint8_t *pc = calloc(n, 1), *done = calloc(n, 1);
    if (!pc || !done) {
        free(pc), free(done);
        goto oom;
    }
    int k = 1;
    for (size_t q = 0; q < m;) {
        size_t a = cuts[2 * q];
        size_t r = q;
        while (r < m && cuts[2 * r] == a) r++;
        /* a, then each larger neighbour b that is not coloured yet */
        if (!done[a]) done[a] = 1;
        for (size_t t = q; t < r; t++) {
            size_t b = cuts[2 * t + 1];
            if (done[b]) continue;
            unsigned used = 0;
            for (size_t u = 0; u < m; u++) { /* b's coloured neighbours */
                size_t o = cuts[2 * u] == b ? cuts[2 * u + 1] : cuts[2 * u + 1] == b ? cuts[2 * u] : (size_t)-1;
                if (o != (size_t)-1 && done[o]) used |= 1u << pc[o];
            }
            int c = 0;
            while (c < KF_PIECES_MAX_CLASSES - 1 && (used >> c & 1)) c++;
            pc[b] = (uint8_t)c, done[b] = 1;
            if (c + 1 > k) k = c + 1;
        }
        q = r;
    }
    for (size_t i = 0; i < n; i++) cls[i] = pc[find(parent, i)];
    free(pc), free(done), free(e), free(parent), free(cuts);
    return k;
oom:
    free(e), free(parent), free(cuts);
    return -1;
}
