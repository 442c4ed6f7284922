/* render.h — kerf's headless renderer: triangle meshes in, RGBA/PNG out.
 *
 * The renderer knows nothing of MPM: it draws lists of triangle meshes with
 * a simple material, an optional ground plane that catches shadows, a key
 * light (with a shadow map) and a fill light, over a vertical gradient. GL
 * runs in an offscreen context (OSMesa/llvmpipe today; see context.h).
 *
 *     kf_render_ctx *r = kf_render_create(1280, 720, 4, err, sizeof err);
 *     kf_render_scene sc = kf_render_scene_default();
 *     sc.meshes = &mesh; sc.nmeshes = 1;
 *     float lo[3], hi[3]; kf_render_scene_bounds(&sc, lo, hi);
 *     kf_camera cam = kf_camera_turntable(lo, hi, k, 96, 20, 35);
 *     kf_render_frame(r, &sc, &cam, rgba, err, sizeof err);
 *     kf_png_write("f.1001.png", rgba, 1280, 720, kv, nkv, err, sizeof err);
 *
 * Conventions: +Y is up; rows of every image are top-down RGBA8; colours a
 * caller gives are sRGB in [0, 1] (lighting is done in linear light and
 * encoded back to sRGB). Every function that can fail returns 0 / non-NULL
 * on success, or -1 / NULL with a message in err (never exits).
 */
#ifndef KF_RENDER_H
#define KF_RENDER_H

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* ---- scene --------------------------------------------------------------- */

typedef struct kf_render_material {
    float diffuse[3]; /* sRGB albedo, [0, 1] */
    float specular;   /* specular amount, [0, 1] (0 = matte) */
    float roughness;  /* (0, 1]: 0.1 glossy ... 1 broad sheen */
} kf_render_material;

typedef struct kf_render_mesh {
    const float *positions; /* (nverts x 3) world space */
    const float *normals;   /* (nverts x 3) unit normals, or NULL = flat shading */
    size_t nverts;
    const uint32_t *tris; /* (ntris x 3) vertex indices, counter-clockwise seen from outside */
    size_t ntris;
    kf_render_material mat;
    const float *motion; /* (nverts x 3) world-space displacement over one frame, m (NULL = still):
                            motion vectors and motion blur */
    int id;              /* the ID matte's value, 1..2047 (0 = none: counts as background) */
    int closed;          /* 1 = a closed surface, wound as above (a level set's mesh): its back faces
                            are skipped while the camera's near plane is clear of it (they are hidden
                            then, but for the odd silhouette pixel) */
} kf_render_mesh;

typedef struct kf_render_scene {
    const kf_render_mesh *meshes; /* (nmeshes) */
    int nmeshes;
    int ground;     /* 1 = draw a ground plane (y = ground_y) that catches shadows */
    float ground_y; /* NAN = at the lowest point of the meshes */
    kf_render_material ground_mat;
    float bg_top[3], bg_bottom[3]; /* sRGB background gradient, top and bottom of the frame */
    int lights_in_world;           /* 0 = light directions are in camera space (x right, y up,
                                      z towards the viewer): a turntable keeps its lighting;
                                      1 = world space */
    float key_dir[3];              /* direction towards the key light (need not be unit) */
    float key_color[3];            /* linear intensity */
    float fill_dir[3];
    float fill_color[3];
    float rim_dir[3];   /* towards a light behind the subject (outlines it) */
    float rim_color[3]; /* linear intensity (default 0: off) */
    float ambient;      /* sky ambient, linear */
    int shadows;        /* 1 = the key light casts shadows (shadow map) */
} kf_render_scene;

/* A scene with no meshes and the studio defaults filled in. */
kf_render_scene kf_render_scene_default(void);

/* Axis-aligned bounds of all mesh vertices. Returns -1 (and a unit box at the
 * origin) when there are no vertices. */
int kf_render_scene_bounds(const kf_render_scene *sc, float lo[3], float hi[3]);

/* ---- camera -------------------------------------------------------------- */

typedef struct kf_camera {
    float eye[3], target[3], up[3];
    float fov_deg;     /* vertical field of view, degrees */
    float znear, zfar; /* 0 = derived from the scene each frame */
} kf_camera;

/* A camera looking along view_dir (from eye towards the subject) at the
 * centre of [lo, hi], far enough back that the bounding sphere fills the
 * vertical field of view with a small margin. Up is +Y (or -Z when looking
 * straight down/up). */
kf_camera kf_camera_frame_bounds(const float lo[3], const float hi[3], const float view_dir[3], float fov_deg);

/* Frame k of an N-frame turntable: the camera orbits the centre of [lo, hi]
 * about +Y at angle 2*pi*k/N (end exclusive: k is taken mod N, so frame N is
 * exactly frame 0 and the loop closes), elevated elevation_deg above the
 * horizon. Frame 0 looks from +Z towards -Z. */
kf_camera kf_camera_turntable(const float lo[3], const float hi[3], int k, int N, float elevation_deg, float fov_deg);

/* A camera key: where the camera is, what it looks at and its vertical
 * field of view at a frame. */
typedef struct kf_camera_key {
    double frame;
    float eye[3], target[3];
    float fov_deg;
} kf_camera_key;

/* The camera at `frame` from n keys (frames increasing): held before the
 * first and after the last; between keys each channel (eye, target, fov)
 * linear, or with smooth = 1 a cubic Hermite through the keys (Catmull-Rom
 * tangents, zero at the first and last key: it eases in and out). Up is +Y. */
kf_camera kf_camera_keyed(const kf_camera_key *keys, int n, double frame, int smooth);

/* ---- drawing ------------------------------------------------------------- */

typedef struct kf_render_ctx kf_render_ctx;

/* An offscreen renderer for w x h images. samples is the MSAA sample count
 * (0 or 1 = no anti-aliasing; clamped to what the GL supports: llvmpipe does
 * 4). NULL + err on failure. */
kf_render_ctx *kf_render_create(int w, int h, int samples, char *err, size_t errlen);
void kf_render_destroy(kf_render_ctx *r);

/* The key light's shadow map, texels a side (by default about the image's
 * long side, 512..2048). The preview preset (render.quality: preview) sets
 * the shot's render_shadow to KF_RENDER_PREVIEW_SHADOW (shot/shot.h). -1 + err
 * when the GL cannot make it. */
int kf_render_set_shadow_size(kf_render_ctx *r, int texels, char *err, size_t errlen);
int kf_render_shadow_size(const kf_render_ctx *r);

/* How the picture is anti-aliased. KF_RENDER_AA_MSAA: the context's MSAA
 * samples. KF_RENDER_AA_EDGES: one sample a pixel, then each silhouette, open
 * boundary, crease of a flat-shaded mesh and crossing of the ground blended
 * with the pixel across it by the area it covers (render/edge_aa.c); on
 * llvmpipe about half the cost of 4x MSAA on finely meshed surfaces. Where
 * two meshes pass through each other the crossing stays aliased. The AOV
 * passes keep the context's samples either way. -1 + err on failure. */
enum { KF_RENDER_AA_MSAA = 0, KF_RENDER_AA_EDGES = 1 };
int kf_render_set_antialias(kf_render_ctx *r, int mode, char *err, size_t errlen);

/* The sample count actually used (after clamping), and the GL renderer string. */
int kf_render_samples(const kf_render_ctx *r);
const char *kf_render_gl_renderer(const kf_render_ctx *r);
/* the GL context backend: "osmesa" or "egl" (KERF_GL picks; context.h) */
const char *kf_render_backend(const kf_render_ctx *r);

/* Draw scene from cam into rgba_out (w*h*4 bytes, rows top-down). */
int kf_render_frame(kf_render_ctx *r, const kf_render_scene *scene, const kf_camera *cam, uint8_t *rgba_out, char *err,
                    size_t errlen);

/* ---- AOVs and motion blur ------------------------------------------------- */

/* Z where no surface is: the largest finite half, so a depth-of-field or fog
 * node never meets infinity */
#define KF_RENDER_Z_BACKGROUND 65504.0f
/* ID mattes coverage is computed for at most this many ids a frame */
#define KF_RENDER_MAX_MATTES 64

/* The passes a compositor wants beside the picture. Every plane is w x h,
 * rows top-down like the RGBA8 image; a NULL plane is not made.
 *   rgba    (x4) linear light: the picture before its 2.2 encoding (so
 *           rgba^(1/2.2) is the PNG), anti-aliased in linear light, not
 *           clipped at 1; A = 1 (the backdrop is part of the picture)
 *   z       (x1) camera depth, m: distance from the eye along the view
 *           axis (camera-space -z), KF_RENDER_Z_BACKGROUND where nothing is
 *   normal  (x3) world-space unit normal of the surface seen, facing the
 *           eye; 0 where nothing is
 *   id      (x1) the frontmost mesh's id at the pixel centre (0: ground,
 *           background or a mesh without one); never blended
 *   motion  (x2) screen-space motion over the next frame, pixels, x right
 *           and y up, from the meshes' motion and the camera's (cam_next)
 *   matte   (x nmatte) coverage in [0, 1] of the meshes whose id is
 *           matte_ids[k] (anti-aliased with the image's samples), plane k
 *           at matte + k*w*h
 * Filled on return: the camera as OpenEXR's worldToCamera and worldToNDC
 * attributes (row vectors, row-major: p' = p M). */
typedef struct kf_render_aovs {
    float *rgba, *z, *normal, *id, *motion, *matte;
    const int *matte_ids;
    int nmatte;
    float world_to_camera[16], world_to_ndc[16];
    int blur_samples; /* filled: shutter samples the picture took (1: no blur) */
} kf_render_aovs;

/* kf_render_frame with motion: cam_next is the camera one frame later (NULL:
 * a still camera); shutter the fraction of a frame the shutter is open,
 * centred on the frame (0: no motion blur). With a shutter, the picture
 * (rgba_out and aov->rgba) is the average of n renders at times spread
 * evenly over the shutter, each mesh moved by t x its motion and the camera
 * interpolated, with n such that the fastest vertex moves at most a pixel
 * between renders (at most KF_RENDER_MAX_BLUR_SAMPLES). The other AOVs are
 * of the frame itself. rgba_out or aov may be NULL. */
#define KF_RENDER_MAX_BLUR_SAMPLES 32
int kf_render_frame_ex(kf_render_ctx *r, const kf_render_scene *scene, const kf_camera *cam, const kf_camera *cam_next,
                       float shutter, uint8_t *rgba_out, kf_render_aovs *aov, char *err, size_t errlen);

/* ---- PNG ----------------------------------------------------------------- */

/* Write an RGBA8 top-down image as PNG with text chunks kv[0]=kv[1], kv[2]=kv[3], ...
 * (nkv pairs; keys 1-79 printable Latin-1 characters; values UTF-8). Written
 * to a temporary name beside path, fsync'ed and renamed, so path is either
 * the old file or the complete new one. */
int kf_png_write(const char *path, const uint8_t *rgba, int w, int h, const char *const *kv, int nkv, char *err,
                 size_t errlen);

/* Read a PNG as RGBA8 top-down (any bit depth/colour type is converted).
 * *rgba is malloc'ed (free it). If texts is not NULL, *texts receives a
 * malloc'ed array of 2*(*ntexts) malloc'ed strings (key, value, ...): free it
 * with kf_png_free_texts. */
int kf_png_read(const char *path, uint8_t **rgba, int *w, int *h, char ***texts, int *ntexts, char *err, size_t errlen);
void kf_png_free_texts(char **texts, int ntexts);

#ifdef __cplusplus
}
#endif

#endif
