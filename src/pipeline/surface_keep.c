/* surface_keep.c — the level sets just written, kept for the render (see surface_keep.h). */
#include "surface_keep.h"

#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

/* one file's grids at a time: the pipeline surfaces a frame, then renders it */
static struct {
    char path[4096];
    struct stat st;
    kf_vdb_grid *grids[KF_VDB_MAX_GRIDS];
    int n;
} kept;

/* the same file as when kept: an atomic rewrite gets a new inode, a touch a new time */
static int same_file(const struct stat *a, const struct stat *b) {
    return a->st_dev == b->st_dev && a->st_ino == b->st_ino && a->st_size == b->st_size &&
           a->st_mtim.tv_sec == b->st_mtim.tv_sec && a->st_mtim.tv_nsec == b->st_mtim.tv_nsec;
}

void kf_surface_keep_clear(void) {
    for (int i = 0; i < kept.n; i++) kf_vdb_free(kept.grids[i]);
    kept.n = 0;
    kept.path[0] = 0;
}

void kf_surface_keep(const char *path, kf_vdb_grid **grids, int n) {
    kf_surface_keep_clear();
    struct stat st;
    /* a path too long to hold, too many grids or a file gone: keep nothing */
    if (!path || strlen(path) >= sizeof kept.path || n < 0 || n > KF_VDB_MAX_GRIDS || stat(path, &st) != 0) {
        for (int i = 0; i < n; i++) kf_vdb_free(grids[i]);
        return;
    }
    memcpy(kept.path, path, strlen(path) + 1);
    kept.st = st;
    for (int i = 0; i < n; i++) kept.grids[i] = grids[i];
    kept.n = n;
}

kf_vdb_grid *kf_surface_take(const char *path, const char *name) {
    struct stat st;
    if (!path || !name || kept.n == 0 || strcmp(path, kept.path) != 0) return NULL;
    /* changed on disk since: what is kept is stale */
    if (stat(path, &st) != 0 || !same_file(&st, &kept.st)) {
        kf_surface_keep_clear();
        return NULL;
    }
    for (int i = 0; i < kept.n; i++)
        if (kept.grids[i] && !strcmp(kf_vdb_name(kept.grids[i]), name)) {
            kf_vdb_grid *g = kept.grids[i];
            kept.grids[i] = NULL;
            return g;
        }
    return NULL;
}
