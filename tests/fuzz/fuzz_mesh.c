/* fuzz_mesh.c — libFuzzer target: the mesh loader (assimp, then kerf's own
 * header checks, welding, edge counting and orientation).
 * The first byte picks the file's extension, which decides the format for
 * assimp (0 .obj, 1 .ply, 2 .stl, 3 .off); the rest is the file. A mesh that
 * loads is also checked for closedness and transformed, as the builder does. */
#include "fuzz_util.h"
#include "scene/mesh.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size) {
    if (size < 1) return 0;
    static const char *const names[4] = {"mesh.obj", "mesh.ply", "mesh.stl", "mesh.off"};
    char path[320], err[512];
    kf_fuzz_write(names[data[0] & 3], data + 1, size - 1, path, sizeof path);
    kf_mesh m;
    if (kf_mesh_load(path, &m, err, sizeof err) == 0) {
        (void)kf_mesh_check_closed(&m, err, sizeof err);
        const double M[12] = {0.5, 0, 0, 0.1, 0, -0.5, 0, 0.2, 0, 0, 0.5, 0.3}; /* mirrors: reorients */
        kf_mesh_transform(&m, M);
        kf_mesh_free(&m);
    } else if (!strstr(err, path)) {
        /* mesh.h: every error message starts with the mesh's path */
        fprintf(stderr, "message without the path: %s\n", err);
        abort();
    }
    return 0;
}
