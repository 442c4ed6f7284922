/* test_surface_keep.c — the level sets kept after a .vdb is written: the
 * render that follows takes them instead of reading the file, and they
 * mesh to exactly the triangles the file's level set meshes to; a file
 * written again or touched since is not served from memory. */
#include "kt.h"
#include "io/vdb_bridge.h"
#include "pipeline/surface_keep.h"

#include <fcntl.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

/* a ball of lattice particles (spacing 0.02, radius 0.1) surfaced as `surface` */
static kf_vdb_grid *ball(void) {
    const double h = 0.02;
    double x[3 * 1500];
    size_t n = 0;
    for (int i = -6; i <= 6; i++)
        for (int j = -6; j <= 6; j++)
            for (int k = -6; k <= 6; k++)
                if ((i * i + j * j + k * k) * h * h <= 0.1 * 0.1) {
                    x[3 * n] = 0.5 + i * h, x[3 * n + 1] = 0.5 + j * h, x[3 * n + 2] = 0.5 + k * h;
                    n++;
                }
    kf_vdb_surface_params p;
    kf_vdb_surface_params_default(&p);
    p.spacing = h;
    p.voxel = 0.5 * h;
    kf_vdb_grid *g = NULL;
    char err[512] = "";
    KT_CHECK(kf_vdb_levelset_from_particles(n, x, NULL, NULL, NULL, &p, &g, NULL, err, sizeof err) == 0, "%s", err);
    return g;
}

/* the kept grid meshes to the same vertices and triangles, bit for bit, as the one read back */
static void test_kept_equals_file(void) {
    char path[128], err[512] = "";
    snprintf(path, sizeof path, "/tmp/kerf_test_keep_%ld.vdb", (long)getpid());
    kf_vdb_grid *g = ball();
    if (!g) return;
    kf_vdb_meta meta = {.frame = 1, .dx = 0.04};
    KT_CHECK(kf_vdb_write(path, &g, 1, &meta, err, sizeof err) == 0, "%s", err);
    kf_surface_keep(path, &g, 1);
    KT_CHECK(kf_surface_take(path, "vel") == NULL, "no grid of that name is kept");
    KT_CHECK(kf_surface_take("/tmp/kerf_test_keep_other.vdb", "surface") == NULL, "another path is not served");
    kf_vdb_grid *kept = kf_surface_take(path, "surface"), *read = NULL;
    KT_CHECK(kept != NULL, "the level set just written is kept");
    KT_CHECK(kf_surface_take(path, "surface") == NULL, "a kept grid is handed over once");
    KT_CHECK(kf_vdb_read_levelset(path, "surface", &read, NULL, err, sizeof err) == 0, "%s", err);
    kf_vdb_trimesh a = {0}, b = {0};
    if (kept && read) {
        KT_CHECK(kf_vdb_mesh(kept, 0, 0, &a, err, sizeof err) == 0, "%s", err);
        KT_CHECK(kf_vdb_mesh(read, 0, 0, &b, err, sizeof err) == 0, "%s", err);
        KT_CHECK(a.ntris > 100 && a.nverts == b.nverts && a.ntris == b.ntris, "%zu/%zu vertices, %zu/%zu triangles",
                 a.nverts, b.nverts, a.ntris, b.ntris);
        if (a.nverts == b.nverts && a.ntris == b.ntris) {
            KT_CHECK(memcmp(a.verts, b.verts, sizeof(float) * 3 * a.nverts) == 0, "vertices differ");
            KT_CHECK(memcmp(a.normals, b.normals, sizeof(float) * 3 * a.nverts) == 0, "normals differ");
            KT_CHECK(memcmp(a.tris, b.tris, sizeof(uint32_t) * 3 * a.ntris) == 0, "triangles differ");
        }
    }
    kf_vdb_mesh_free(&a), kf_vdb_mesh_free(&b);
    kf_vdb_free(kept), kf_vdb_free(read);
    unlink(path);
}

/* a file written again (a new inode) or touched (a new time) is read from disk */
static void test_changed_file_not_served(void) {
    char path[128], err[512] = "";
    snprintf(path, sizeof path, "/tmp/kerf_test_keep2_%ld.vdb", (long)getpid());
    kf_vdb_meta meta = {.frame = 1, .dx = 0.04};
    kf_vdb_grid *g = ball(), *g2 = ball();
    if (!g || !g2) return;
    KT_CHECK(kf_vdb_write(path, &g, 1, &meta, err, sizeof err) == 0, "%s", err);
    kf_surface_keep(path, &g, 1);
    KT_CHECK(kf_vdb_write(path, &g2, 1, &meta, err, sizeof err) == 0, "%s", err);
    KT_CHECK(kf_surface_take(path, "surface") == NULL, "a file written since is not served from memory");
    kf_surface_keep(path, &g2, 1);
    struct timespec later[2] = {{.tv_sec = time(NULL) + 5}, {.tv_sec = time(NULL) + 5}};
    KT_CHECK(utimensat(AT_FDCWD, path, later, 0) == 0, "touch");
    KT_CHECK(kf_surface_take(path, "surface") == NULL, "a file touched since is not served from memory");
    kf_surface_keep_clear();
    unlink(path);
}

int main(int argc, char **argv) {
    KT_RUN(test_kept_equals_file, argc, argv);
    KT_RUN(test_changed_file_not_served, argc, argv);
    return KT_EXIT();
}
