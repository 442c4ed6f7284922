/* test_cut_gap.c — a cut stays open in the surface. A thin blade goes down
 * through a cheese block to the floor and back up (tests/shots/cut_gap.yaml,
 * simulated for real); the halves are then moved 0.5 dx apart, each by a
 * quarter cell along the blade's normal. The surface (one level set per
 * class of pieces, io/pieces.h, joined by CSG union, as the surface stage
 * makes it) must be two closed pieces with a gap on the blade's plane. The
 * control, the same particles with their colours cleared (no scar: what
 * kerf did before it kept the side of the blade), surfaces as one body
 * across that plane: the test sees the difference the scar makes. */
#include "io/pieces.h"
#include "kt.h"
#include "mesh_util.h"
#include "scene/build.h"
#include "shot/diag.h"
#include "shot/shot.h"
#include "surface_look.h"

#include <stdlib.h>

static int cmp_u64(const void *x, const void *y) {
    uint64_t a = *(const uint64_t *)x, b = *(const uint64_t *)y;
    return a < b ? -1 : a > b;
}

/* connected components of a mesh with more than 8 triangles, and whether
 * every edge is shared by exactly two triangles (closed) */
static int mesh_pieces(const kf_vdb_trimesh *m, int *closed) {
    size_t *par = malloc(sizeof *par * (m->nverts + 1)), *cnt = calloc(m->nverts + 1, sizeof *cnt);
    for (size_t v = 0; v < m->nverts; v++) par[v] = v;
    for (size_t t = 0; t < m->ntris; t++)
        for (int k = 0; k < 2; k++) {
            size_t a = m->tris[3 * t + k], b = m->tris[3 * t + k + 1];
            while (par[a] != a) a = par[a] = par[par[a]];
            while (par[b] != b) b = par[b] = par[par[b]];
            if (a != b) par[a < b ? b : a] = a < b ? a : b;
        }
    for (size_t t = 0; t < m->ntris; t++) {
        size_t a = m->tris[3 * t];
        while (par[a] != a) a = par[a];
        cnt[a]++;
    }
    int n = 0;
    for (size_t v = 0; v < m->nverts; v++) n += cnt[v] > 8;
    /* closed: sorted directed edges; each (a, b) has its twin (b, a) once */
    size_t ne = 3 * m->ntris;
    uint64_t *e = malloc(sizeof *e * (ne + 1));
    for (size_t t = 0; t < m->ntris; t++)
        for (int k = 0; k < 3; k++) {
            uint64_t a = m->tris[3 * t + k], b = m->tris[3 * t + (k + 1) % 3];
            e[3 * t + k] = a << 32 | b;
        }
    int ok = 1;
    qsort(e, ne, sizeof *e, cmp_u64);
    for (size_t t = 0; t < m->ntris && ok; t++)
        for (int k = 0; k < 3 && ok; k++) {
            uint64_t a = m->tris[3 * t + k], b = m->tris[3 * t + (k + 1) % 3], twin = b << 32 | a;
            size_t lo = 0, hi = ne;
            while (lo < hi) {
                size_t mid = (lo + hi) / 2;
                if (e[mid] < twin) lo = mid + 1;
                else hi = mid;
            }
            ok = lo < ne && e[lo] == twin && (lo + 1 == ne || e[lo + 1] != twin);
        }
    *closed = ok;
    free(e), free(par), free(cnt);
    return n;
}

/* the surface of n particles as the surface stage makes it: classes of
 * pieces, one level set each, joined by CSG union; its class count in *k */
static kf_vdb_grid *surface(size_t n, const float *x, const uint32_t *col, double h, const look_settings *s, int *k) {
    uint8_t *cls = malloc(n + 1);
    float *xs = malloc(sizeof(float) * 3 * (n + 1));
    *k = kf_pieces_classes(n, x, col, h, (2 * (s->kernel == 0 ? s->reach : s->radius) + 1) * h, cls);
    kf_vdb_grid *all = NULL;
    kf_vdb_surface_params p;
    look_params(&p, h, *s);
    char err[512] = "";
    for (int c = 0; c < *k; c++) {
        size_t m = 0;
        for (size_t i = 0; i < n; i++)
            if (cls[i] == c) memcpy(xs + 3 * m++, x + 3 * i, 3 * sizeof *xs);
        kf_vdb_grid *g = NULL;
        KT_CHECK(kf_vdb_levelset_from_particles(m, NULL, xs, NULL, NULL, &p, &g, NULL, err, sizeof err) == 0, "%s",
                 err);
        if (!all) all = g;
        else {
            KT_CHECK(kf_vdb_union(all, g, err, sizeof err) == 0, "%s", err);
            kf_vdb_free(g);
        }
    }
    free(cls), free(xs);
    return all;
}

/* the share of points on the blade's plane z = z0, over the block's middle,
 * where the surface is outside (a gap) */
static double gap_share(const kf_vdb_grid *g, double z0) {
    int out = 0, all = 0;
    for (double x = 0.23; x <= 0.37; x += 0.01)
        for (double y = 0.02; y <= 0.09; y += 0.01) out += look_phi(g, x, y, z0) > 0, all++;
    return (double)out / all;
}

static void cut_stays_open(void) {
    kf_diag diag;
    kf_diag_init(&diag);
    kf_shot *shot = kf_shot_load(tu_repo_path("tests/shots/cut_gap.yaml"), NULL, 0, NULL, NULL, &diag);
    kf_scene sc;
    int ok = shot && kf_scene_from_shot(shot, 0, &sc, NULL, &diag) == 0;
    if (!ok) kf_diag_print(stderr, &diag);
    kf_diag_free(&diag);
    KT_CHECK(ok, "tests/shots/cut_gap.yaml builds");
    if (!ok) return;
    char msg[256];
    for (int f = shot->frame_start; f < shot->frame_end; f++)
        if (kf_advance(sc.model, sc.state, 1.0 / shot->fps, NULL, msg, sizeof msg)) {
            KT_CHECK(0, "frame %d: %s", f, msg);
            return;
        }
    kf_particles_view pv = kf_state_particles_read(sc.state);
    const double dx = shot->sim.dx, h = dx / shot->ppc_axis, z0 = 0.3;
    /* the halves apart: each a quarter cell along the blade's normal */
    float *x = malloc(sizeof(float) * 3 * pv.n);
    uint32_t *col = malloc(sizeof(uint32_t) * pv.n), *none = calloc(pv.n, sizeof(uint32_t));
    size_t scarred = 0, wrong = 0;
    for (size_t i = 0; i < pv.n; i++) {
        int front = pv.x[2][i] > z0;
        for (int a = 0; a < 3; a++) x[3 * i + a] = (float)pv.x[a][i];
        x[3 * i + 2] += (float)((front ? 0.25 : -0.25) * dx);
        col[i] = pv.colour[i];
        if (col[i] >> 28) {
            scarred++;
            /* the scar names the side: one side bit per half (which is which
             * depends on the mesh's winding) */
            wrong += ((col[i] & 1) != 0) != front;
        }
    }
    if (wrong > scarred / 2) wrong = scarred - wrong;
    printf("  %zu particles, %zu with a scar, %zu of them on the side their scar does not name\n", pv.n, scarred,
           wrong);
    KT_CHECK(scarred > 200, "the particles near the cut keep the blade's side after it left (%zu)", scarred);
    KT_CHECK(wrong == 0, "every scar names its particle's side of the cut (%zu do not)", wrong);
    look_settings s = look_of_shot(shot);
    int k = 0, k0 = 0;
    /* the controls, without the scars: the shot's kernel, and the spheres
     * of kerf's earlier look, which heal the cut outright */
    int k1 = 0;
    kf_vdb_grid *g = surface(pv.n, x, col, h, &s, &k), *g0 = surface(pv.n, x, none, h, &s, &k0);
    kf_vdb_grid *g1 = surface(pv.n, x, none, h, &look_spheres, &k1);
    KT_CHECK(k == 2 && k0 == 1, "two classes of pieces with the scars (%d), one without (%d)", k, k0);
    if (g && g0 && g1) {
        kf_vdb_trimesh m, m0, m1;
        char err[256];
        int closed = 0, closed0 = 0, closed1 = 0;
        KT_CHECK(kf_vdb_mesh(g, 0, 0, &m, err, sizeof err) == 0, "%s", err);
        KT_CHECK(kf_vdb_mesh(g0, 0, 0, &m0, err, sizeof err) == 0, "%s", err);
        KT_CHECK(kf_vdb_mesh(g1, 0, 0, &m1, err, sizeof err) == 0, "%s", err);
        int np = mesh_pieces(&m, &closed), np0 = mesh_pieces(&m0, &closed0), np1 = mesh_pieces(&m1, &closed1);
        double gap = gap_share(g, z0), gap0 = gap_share(g0, z0), gap1 = gap_share(g1, z0);
        printf("  with scars: %d pieces (closed %d), gap on %.0f%% of the plane; without: %d pieces, gap %.0f%%; "
               "spheres without: %d pieces, gap %.0f%%\n",
               np, closed, 100 * gap, np0, 100 * gap0, np1, 100 * gap1);
        KT_CHECK(np == 2 && closed, "the surface is two closed pieces (%d, closed %d)", np, closed);
        KT_CHECK(gap == 1, "a gap over the whole cut (outside on %.1f%% of the plane's points)", 100 * gap);
        KT_CHECK(gap0 == 0, "without the scars the halves join across the cut: gap on %.1f%% (%d pieces)", 100 * gap0,
                 np0);
        KT_CHECK(np1 == 1 && gap1 == 0, "the spheres heal the cut: %d piece(s), gap on %.1f%%", np1, 100 * gap1);
        kf_vdb_mesh_free(&m);
        kf_vdb_mesh_free(&m0);
        kf_vdb_mesh_free(&m1);
    }
    kf_vdb_free(g);
    kf_vdb_free(g0);
    kf_vdb_free(g1);
    free(x), free(col), free(none);
    kf_scene_free(&sc);
    kf_shot_free(shot);
}

int main(int argc, char **argv) {
    KT_RUN(cut_stays_open, argc, argv);
    return KT_EXIT();
}
