/* internal.h — the renderer's context and the passes of a frame, shared by
 * renderer.c (set-up, the beauty passes) and passes.c (the AOV passes, the
 * shutter loop). Nothing here is part of render.h's interface. */
#ifndef KF_RENDER_INTERNAL_H
#define KF_RENDER_INTERNAL_H

#include "context.h"
#include "gl_api.h"
#include "render.h"

struct kf_render_ctx {
    kf_gl_context *glc;
    kf_gl gl;
    int w, h, samples, shadow_size;
    int aa;           /* KF_RENDER_AA_MSAA or KF_RENDER_AA_EDGES */
    int draw_samples; /* the picture's target: samples, or 1 with edge anti-aliasing */
    char renderer_name[128];
    GLuint prog_main, prog_depth, prog_bg;
    GLuint prog_unshadowed; /* prog_main without the shadow map's taps: the ground beyond the map */
    GLuint vao;
    GLuint fbo_draw, rb_color, rb_depth; /* multisampled when draw_samples > 1 */
    GLuint fbo_resolve, rb_resolve;      /* single-sample; only when samples > 1 */
    GLuint fbo_shadow, tex_shadow;
    GLuint ground_vbo[2], ground_ebo;
    /* per-mesh buffers, grown as needed: positions, normals, indices, motion */
    GLuint *vbo_pos, *vbo_nrm, *ebo, *vbo_mot;
    int nbuf;
    uint8_t *readback; /* (h x w x 4) bottom-up */
    /* made on the first frame that asks for AOVs (passes.c): a float
     * multisampled target (linear beauty, mattes) and its resolve, and a
     * single-sample target of two float attachments (Z, id, motion; N) */
    int aov_ready;
    GLuint prog_aov, prog_matte;
    GLuint fbo_f, rb_f_color, rb_f_depth, fbo_f_res, rb_f_res;
    GLuint fbo_aov, rb_aov[2], rb_aov_depth;
    float *readback_f; /* (h x w x 4) bottom-up */
    /* edge anti-aliasing (edge_aa.c), made on first use: the lines' program,
     * a copy of the picture's colour and depth they read, their vertices */
    int edge_ready;
    GLuint prog_edge, fbo_edge, tex_edge[2], vbo_edge;
};

/* What every pass of one frame shares: the subject, the camera and the lights. */
typedef struct kf_frame {
    float view[16], proj[16], viewproj[16], light_vp[16];
    float viewproj_next[16]; /* the camera one frame later (motion vectors) */
    float eye[3], center[3], rad, ground_y, fade0, fade1;
    float znear; /* the camera's near plane */
    float key[3], fill[3], rim[3];
    int shadows, draw_ground, empty;
} kf_frame;

/* Validate the scene and camera, make the context current, upload the
 * meshes (with their motion) and the ground. -1 + err on failure. */
int kf_frame_begin(kf_render_ctx *r, const kf_render_scene *sc, const kf_camera *cam, kf_frame *f, char *err,
                   size_t errlen);
/* The camera's matrices and the lights for cam (cam_next: the camera a
 * frame later, NULL = the same). -1 + err for a degenerate camera. */
int kf_frame_camera(kf_render_ctx *r, const kf_render_scene *sc, const kf_camera *cam, const kf_camera *cam_next,
                    kf_frame *f, char *err, size_t errlen);
/* The key light's shadow map with every vertex moved by t x its motion. */
void kf_frame_shadow(kf_render_ctx *r, const kf_render_scene *sc, kf_frame *f, float t);
/* Background and meshes into the bound framebuffer fbo (its size is the
 * image's), vertices moved by t x their motion; linear = 1 writes linear
 * light (the same picture before its 2.2 encoding), 0 the PNG's values. */
void kf_frame_beauty(kf_render_ctx *r, const kf_render_scene *sc, const kf_frame *f, GLuint fbo, int linear, float t);
/* Edge anti-aliasing (edge_aa.c): blend the single-sample picture in fbo
 * across the scene's silhouettes, boundaries, flat-shaded creases and ground
 * crossings, meshes moved by t x their motion. -1 + err on failure. */
int kf_edge_aa_apply(kf_render_ctx *r, const kf_render_scene *sc, const kf_frame *f, GLuint fbo, float t, char *err,
                     size_t errlen);
void kf_edge_aa_destroy(kf_render_ctx *r);
/* Resolve the multisampled fbo into resolve (when draw_samples > 1) and read
 * RGBA8 rows top-down into out. */
int kf_frame_read8(kf_render_ctx *r, GLuint fbo, GLuint resolve, uint8_t *out, char *err, size_t errlen);
/* Bind mesh buffers: position, normal (or a constant up), motion (or none), indices. */
void kf_bind_mesh(kf_gl *gl, GLuint pos, GLuint nrm, int has_nrm, GLuint mot, int has_mot, GLuint ebo);
/* Compile and link a program; 0 + err on failure. */
GLuint kf_gl_program(kf_gl *gl, const char *vs, const char *fs, const char *what, char *err, size_t errlen);
/* 0, or -1 + err when the bound framebuffer is incomplete */
int kf_fbo_complete(kf_gl *gl, const char *what, char *err, size_t errlen);
/* The AOV targets and programs (passes.c), made once. */
int kf_aov_setup(kf_render_ctx *r, char *err, size_t errlen);
void kf_aov_destroy(kf_render_ctx *r);

#endif
