/* test_paper_scenes.c — the paper's cutting and walking shots, run from their
 * shot files at a tiny resolution, show what they are for:
 *   - shots/armadillo_cut.yaml: the blade's first pass (through both shins)
 *     leaves the feet as falling pieces of their own, with no material left
 *     bridging them to the armadillo still hanging from its clamp;
 *   - shots/banana.yaml: the slice past the board's edge comes free and falls
 *     below the board's top, on the floor, while the rest stays on the board;
 *   - shots/robot_sand.yaml and robot_sand_reverse.yaml: the robot walks in
 *     the direction its gait commands (+x, then -x reversed), and no motor's
 *     torque ever exceeds its limit.
 * Pieces are the connected sets of particles closer than a grid cell: the
 * particles sit half a cell apart (8 per cell), so a piece is one set and a
 * cut that has opened by a cell separates two. */
#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#include "kt.h"
#include "mesh_util.h"
#include "mpm/model.h"
#include "scene/build.h"

/* ---- pieces ------------------------------------------------------------------------------- */

static int find(int *up, int i) {
    while (up[i] != i) i = up[i] = up[up[i]];
    return i;
}

typedef struct cell_key {
    int64_t key;
    int p;
} cell_key;

static int by_key(const void *a, const void *b) {
    const cell_key *x = a, *y = b;
    return x->key < y->key ? -1 : x->key > y->key ? 1 : x->p - y->p;
}

static int64_t pack(int64_t i, int64_t j, int64_t k) { return (i + 4096) << 40 | (j + 4096) << 20 | (k + 4096); }

/* label[p] = the piece of particle p (particles within h of each other share
 * one), numbered by size, largest first; returns the number of pieces */
static int pieces(const kf_particles_view *v, double h, int *label, int *size) {
    const int n = (int)v->n;
    int *up = malloc(sizeof(int) * (size_t)n);
    cell_key *c = malloc(sizeof *c * (size_t)n);
    for (int p = 0; p < n; p++) {
        up[p] = p;
        c[p].key = pack((int64_t)floor(v->x[0][p] / h), (int64_t)floor(v->x[1][p] / h), (int64_t)floor(v->x[2][p] / h));
        c[p].p = p;
    }
    qsort(c, (size_t)n, sizeof *c, by_key);
    /* each particle against the particles of its own and the 26 cells around it */
    for (int p = 0; p < n; p++) {
        int64_t ci = (int64_t)floor(v->x[0][p] / h), cj = (int64_t)floor(v->x[1][p] / h),
                ck = (int64_t)floor(v->x[2][p] / h);
        for (int d = 0; d < 27; d++) {
            cell_key want = {pack(ci + d % 3 - 1, cj + d / 3 % 3 - 1, ck + d / 9 - 1), -1};
            int lo = 0, hi = n;
            while (lo < hi) {
                int mid = (lo + hi) / 2;
                if (by_key(&c[mid], &want) < 0) lo = mid + 1;
                else hi = mid;
            }
            for (int s = lo; s < n && c[s].key == want.key; s++) {
                int q = c[s].p;
                double dx = v->x[0][p] - v->x[0][q], dy = v->x[1][p] - v->x[1][q], dz = v->x[2][p] - v->x[2][q];
                if (dx * dx + dy * dy + dz * dz < h * h) up[find(up, p)] = find(up, q);
            }
        }
    }
    /* roots to piece numbers, by size */
    int *count = calloc((size_t)n, sizeof(int)), npieces = 0;
    for (int p = 0; p < n; p++) count[find(up, p)]++;
    int *roots = malloc(sizeof(int) * (size_t)n);
    for (int p = 0; p < n; p++)
        if (count[p] > 0) roots[npieces++] = p;
    for (int a = 1; a < npieces; a++) /* insertion sort: few pieces */
        for (int b = a; b > 0 && count[roots[b]] > count[roots[b - 1]]; b--) {
            int t = roots[b];
            roots[b] = roots[b - 1], roots[b - 1] = t;
        }
    int *number = malloc(sizeof(int) * (size_t)n);
    for (int r = 0; r < npieces; r++) number[roots[r]] = r, size[r] = count[roots[r]];
    for (int p = 0; p < n; p++) label[p] = number[find(up, p)];
    free(up), free(c), free(count), free(roots), free(number);
    return npieces;
}

/* the bounding box of piece k */
static void piece_box(const kf_particles_view *v, const int *label, int k, double lo[3], double hi[3]) {
    for (int a = 0; a < 3; a++) lo[a] = INFINITY, hi[a] = -INFINITY;
    for (size_t p = 0; p < v->n; p++)
        if (label[p] == k)
            for (int a = 0; a < 3; a++) lo[a] = fmin(lo[a], v->x[a][p]), hi[a] = fmax(hi[a], v->x[a][p]);
}

/* ---- running a shot ------------------------------------------------------------------------- */

typedef struct run {
    kf_shot *shot;
    kf_scene sc;
    int ok;
} run;

static void run_open(run *r, const char *rel, const char *const *sets, int nsets) {
    kf_diag diag;
    kf_diag_init(&diag);
    memset(r, 0, sizeof *r);
    r->shot = kf_shot_load(tu_repo_path(rel), sets, nsets, NULL, NULL, &diag);
    r->ok = r->shot && kf_scene_from_shot(r->shot, 0, &r->sc, NULL, &diag) == 0;
    if (!r->ok) kf_diag_print(stderr, &diag);
    KT_CHECK(r->ok, "%s builds", rel);
    kf_diag_free(&diag);
}

/* advance to the end of frame `last` */
static int run_to(run *r, int last, int *frame) {
    char msg[512];
    for (; r->ok && *frame < last; ++*frame)
        if (kf_advance(r->sc.model, r->sc.state, 1.0 / r->shot->fps, NULL, msg, sizeof msg)) {
            KT_CHECK(0, "frame %d: %s", *frame + 1, msg);
            r->ok = 0;
        }
    return r->ok;
}

static void run_close(run *r) {
    if (r->shot && r->ok) kf_scene_free(&r->sc);
    kf_shot_free(r->shot);
}

/* ---- the scenes ----------------------------------------------------------------------------- */

/* the blade's first pass (from frame 1006, 0.45 m up, through both shins by
 * about 1018) and a third of a second more: the armadillo still hangs from
 * the clamp (its largest piece reaches into it, above 0.82 m) and holds
 * nothing below the blade's path; the feet fall as pieces of their own.
 * At the preview's dx (12 mm): at 20 mm the shins are two cells thick and
 * their every particle is in the blade's band, held to its velocity, so the
 * feet cannot drop before the blade has passed and the cut closes again. */
static void armadillo_cut_separates(void) {
    const char *sets[] = {"sim.dx=0.012"};
    run r;
    run_open(&r, "shots/armadillo_cut.yaml", sets, 1);
    int frame = 1001;
    if (!run_to(&r, 1026, &frame)) return run_close(&r);
    kf_particles_view v = kf_state_particles_read(r.sc.state);
    int *label = malloc(sizeof(int) * v.n), *size = malloc(sizeof(int) * v.n);
    const double dx = 0.012;
    int np = pieces(&v, dx, label, size);
    double lo[3], hi[3];
    piece_box(&v, label, 0, lo, hi);
    printf("  armadillo after the first pass: %d pieces; the largest (%d of %zu particles) spans y %.3f..%.3f m\n", np,
           size[0], v.n, lo[1], hi[1]);
    KT_CHECK(hi[1] > 0.85, "the armadillo still hangs from the clamp (top of its largest piece %.3f m)", hi[1]);
    KT_CHECK(lo[1] > 0.45 - dx, "nothing below the blade's path hangs on to it (its lowest point %.3f m)", lo[1]);
    int feet = 0, fallen = 0;
    for (int k = 1; k < np; k++) {
        piece_box(&v, label, k, lo, hi);
        if (size[k] < 20) continue; /* a crumb, not a piece */
        feet += size[k];
        fallen += hi[1] < 0.45 - dx && lo[1] < 0.2; /* the feet stood down to 0.335 m */
        printf("  piece %d: %d particles, y %.3f..%.3f m\n", k, size[k], lo[1], hi[1]);
    }
    KT_CHECK(fallen >= 1, "a cut-off foot falls (%d pieces below the cut, 0.13 m or more down)", fallen);
    KT_CHECK(feet > (int)v.n / 100, "the feet are pieces of their own: %d particles", feet);
    free(label), free(size);
    run_close(&r);
}

/* the knife comes down 2 cm past the board's edge (x = 0.6) by frame 1024
 * and goes back up by 1036: the tip beyond it is a piece of its own, all of
 * it past the cut and below the board's top (0.1 m), on the floor; the rest
 * of the banana is still on the board */
static void banana_slice_falls(void) {
    const char *sets[] = {"sim.dx=0.012"};
    run r;
    run_open(&r, "shots/banana.yaml", sets, 1);
    int frame = 1001;
    if (!run_to(&r, 1036, &frame)) return run_close(&r);
    kf_particles_view v = kf_state_particles_read(r.sc.state);
    int *label = malloc(sizeof(int) * v.n), *size = malloc(sizeof(int) * v.n);
    const double dx = 0.012;
    int np = pieces(&v, dx, label, size), slice = -1;
    double lo[3], hi[3];
    piece_box(&v, label, 0, lo, hi);
    printf("  banana: %d pieces; the largest (%d of %zu particles) spans x %.3f..%.3f, y %.3f..%.3f m\n", np, size[0],
           v.n, lo[0], hi[0], lo[1], hi[1]);
    KT_CHECK(lo[1] > 0.1 - dx && hi[0] < 0.6 + dx, "the banana is still on the board, up to the cut (x %.3f m)", hi[0]);
    for (int k = 1; k < np && slice < 0; k++) {
        piece_box(&v, label, k, lo, hi);
        if (size[k] >= 20 && lo[0] > 0.6 - dx) slice = k;
    }
    KT_CHECK(slice > 0, "a piece lies wholly past the cut");
    if (slice > 0) {
        piece_box(&v, label, slice, lo, hi);
        printf("  the slice: %d particles, x %.3f..%.3f, y %.3f..%.3f m\n", size[slice], lo[0], hi[0], lo[1], hi[1]);
        KT_CHECK(size[slice] > (int)v.n / 50, "it is a slice, not crumbs (%d particles)", size[slice]);
        KT_CHECK(hi[1] < 0.1 && lo[1] < 2 * dx, "it fell free: below the board's top, on the floor (y %.3f..%.3f)",
                 lo[1], hi[1]);
    }
    free(label), free(size);
    run_close(&r);
}

/* half a second of walking: the body goes the way the gait commands, and
 * every motor's peak torque in every frame is within its limit */
static double robot_walk(const char *rel) {
    const char *sets[] = {"sim.dx=0.02"};
    run r;
    run_open(&r, rel, sets, 1);
    if (!r.ok) return run_close(&r), 0;
    const double x0 = kf_state_rigid(r.sc.state, 0).com[0];
    double worst = 0;
    for (int frame = 1001; frame < 1013;) {
        if (!run_to(&r, frame + 1, &frame)) break;
        for (int j = 0; j < r.shot->njoints; j++) {
            double now, peak;
            KT_CHECK(kf_state_joint_torque(r.sc.state, j, &now, &peak) == 0, "joint %d has a motor", j);
            worst = fmax(worst, peak / r.shot->joints[j].def.torque_limit);
        }
        kf_state_joint_peak_reset(r.sc.state);
    }
    const double dx = r.ok ? kf_state_rigid(r.sc.state, 0).com[0] - x0 : 0;
    printf("  %s: the body moved %+.3f m along x in 0.5 s; the largest torque peak was %.3f of its limit\n", rel, dx,
           worst);
    KT_CHECK(worst <= 1 + 1e-12 && worst > 0, "torque within its limit (peak / limit %.6f)", worst);
    run_close(&r);
    return dx;
}

static void robot_walks_forward(void) {
    double dx = robot_walk("shots/robot_sand.yaml");
    KT_CHECK(dx > 0.03, "the robot walks forward (+x): %+.3f m in 0.5 s", dx);
}

static void robot_walks_backward_reversed(void) {
    double dx = robot_walk("shots/robot_sand_reverse.yaml");
    KT_CHECK(dx < -0.03, "reversed, it walks backward (-x): %+.3f m in 0.5 s", dx);
}

int main(int argc, char **argv) {
    KT_RUN(armadillo_cut_separates, argc, argv);
    KT_RUN(banana_slice_falls, argc, argv);
    KT_RUN(robot_walks_forward, argc, argv);
    KT_RUN(robot_walks_backward_reversed, argc, argv);
    return KT_EXIT();
}
