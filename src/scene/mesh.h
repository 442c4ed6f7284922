/* mesh.h — triangle meshes from files (OBJ, PLY, STL, OFF via assimp) or
 * arrays: loaded, welded, checked for closedness and consistently oriented.
 *
 *     kf_mesh m;
 *     if (kf_mesh_load("assets/bunny.off", &m, err, sizeof err)) fail(err);
 *     if (kf_mesh_check_closed(&m, err, sizeof err)) fail(err);  // solids only
 *     ...
 *     kf_mesh_free(&m);
 *
 * Every error message starts with the mesh's path (or the name given to
 * kf_mesh_from_arrays) and then the reason, e.g.
 *     "assets/x.ply: not closed: 12 boundary edges"
 *     "assets/y.obj: no faces (truncated file?)"
 *     "assets/z.ply: truncated file: header declares 8 vertices and 12 faces, 5 data lines follow"
 * Nothing here prints or exits. */
#ifndef KF_SCENE_MESH_H
#define KF_SCENE_MESH_H

#include <stddef.h>
#include <stdint.h>

typedef struct kf_mesh {
    char path[256]; /* file (or name) it came from, for messages */
    size_t nvert;
    size_t ntri;
    double *vert;        /* (nvert x 3) positions, file units (metres once placed) */
    uint32_t *tri;       /* (ntri x 3) vertex indices; counter-clockwise seen from outside when oriented */
    double lo[3], hi[3]; /* bounds of the vertices */
    double volume;       /* enclosed volume by the divergence theorem (meaningful when closed) */
    double area;         /* surface area */
    /* what loading found and did */
    size_t welded;            /* input vertices merged into another at the same position (assimp's
                                 OBJ and STL readers give each face corner its own vertex) */
    size_t dropped_tris;      /* triangles dropped as degenerate (a repeated vertex after welding) */
    size_t duplicate_tris;    /* triangles dropped as repeats of an earlier one (same three vertices) */
    size_t ignored_prims;     /* points and lines in the file (not part of a surface) */
    size_t boundary_edges;    /* edges used by exactly one triangle */
    size_t nonmanifold_edges; /* edges used by three or more triangles */
    size_t flipped_tris;      /* triangles reversed to make the orientation consistent and outward */
    int components;           /* edge-connected pieces */
    int closed;               /* every edge shared by exactly two triangles, and ntri > 0 */
    int oriented;             /* orientation consistent (and each piece's volume positive) */
} kf_mesh;

/* Load a mesh file (format from its content/extension, as assimp decides).
 * Polygons are fan-triangulated, vertices welded by exact position (STL and
 * per-face PLY/OFF vertices are merged), degenerate triangles dropped, edges
 * counted, and a closed mesh oriented outward. An open mesh still loads
 * (closed = 0; see kf_mesh_check_closed). Returns 0, or -1 with "path: reason"
 * in err for: a file that cannot be opened, an empty file, a PLY/OFF file
 * shorter than its header declares, a file assimp rejects, faces without
 * vertices, indices out of range, non-finite coordinates, or no faces.
 * Not thread-safe: assimp's C API keeps its error string in a global. */
int kf_mesh_load(const char *path, kf_mesh *out, char *err, size_t errlen);

/* The same processing for a mesh given as arrays (copied). name is used in
 * messages. Returns 0, or -1 with a message. */
int kf_mesh_from_arrays(const char *name, size_t nvert, const double *vert3, size_t ntri, const uint32_t *tri3,
                        kf_mesh *out, char *err, size_t errlen);

/* 0 when the mesh is closed (every edge shared by exactly two triangles after
 * welding), else -1 and "path: not closed: 12 boundary edges" (and/or
 * "N edges shared by more than two triangles"). */
int kf_mesh_check_closed(const kf_mesh *m, char *err, size_t errlen);

/* Apply x' = A x + t, with M row-major 3x4 ([A | t]). Bounds, volume and area
 * are updated; a mirroring map (det A < 0) reverses the triangles so the
 * orientation stays outward. */
void kf_mesh_transform(kf_mesh *m, const double M[12]);

/* Deep copy. Returns 0, or -1 when out of memory. */
int kf_mesh_copy(const kf_mesh *src, kf_mesh *dst);

void kf_mesh_free(kf_mesh *m);

#endif
