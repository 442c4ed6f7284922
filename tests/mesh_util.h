/* mesh_util.h — test helpers for files under the repository root: their
 * path (found from this header's own path, so tests run from any build
 * directory) and a mesh file loaded through assimp with int triangles, as
 * the rigid-body and seeding APIs take them. Include after kt.h. */
#ifndef KF_TEST_MESH_UTIL_H
#define KF_TEST_MESH_UTIL_H

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "scene/mesh.h"

/* a path under the repository root; up to 8 results live at once */
static inline const char *tu_repo_path(const char *rel) {
    static char buf[8][1024];
    static int k = 0;
    char *b = buf[k++ % 8];
    const char *me = __FILE__, *cut = strstr(me, "tests/mesh_util.h");
    snprintf(b, 1024, "%.*s%s", cut ? (int)(cut - me) : 0, me, rel);
    return b;
}

/* a mesh file as int triangles */
typedef struct tu_loaded_mesh {
    kf_mesh m;
    int *tri;
} tu_loaded_mesh;

static inline int tu_load_mesh(const char *rel, tu_loaded_mesh *L) {
    char err[256];
    if (kf_mesh_load(tu_repo_path(rel), &L->m, err, sizeof err)) {
        KT_CHECK(0, "%s", err);
        return -1;
    }
    L->tri = malloc(sizeof(int) * 3 * L->m.ntri);
    for (size_t i = 0; i < 3 * L->m.ntri; i++) L->tri[i] = (int)L->m.tri[i];
    return 0;
}

static inline void tu_free_mesh(tu_loaded_mesh *L) {
    kf_mesh_free(&L->m);
    free(L->tri);
}

#endif
