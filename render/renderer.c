/* renderer.c — shaders, buffers and the frame: shadow pass, gradient, meshes, resolve.
 *
 * A frame is: (1) upload the meshes; (2) depth-only pass from the key light into
 * a shadow map (orthographic, fitted to the meshes' bounding sphere); (3) a
 * screen-space gradient; (4) the meshes and the ground, Blinn-Phong key + fill
 * + hemispheric ambient, 3x3 PCF shadows, the ground dissolving into the
 * gradient with distance; (5) MSAA resolve by blit and a read-back, rows
 * flipped to top-down.
 *
 * Anti-aliasing is MSAA (llvmpipe supports 4x; it costs far less than
 * rendering 2x larger, and the resolve is a plain blit) or, by
 * kf_render_set_antialias, one sample a pixel with the edges blended after
 * (edge_aa.c): on llvmpipe MSAA's cost follows the triangles, and surfaces
 * meshed from level sets have many under a pixel. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "internal.h"

/* ---- shaders ------------------------------------------------------------- */

static const char *vs_main = "#version 330 core\n"
                             "layout(location=0) in vec3 a_pos;\n"
                             "layout(location=1) in vec3 a_nrm;\n"
                             "layout(location=2) in vec3 a_mot;\n"
                             "uniform mat4 u_viewproj, u_light; uniform float u_t;\n"
                             "out vec3 v_wpos, v_nrm; out vec4 v_lpos;\n"
                             "void main() {\n"
                             /* u_t: where in the shutter, in frames (0: the frame itself) */
                             "  vec3 p = a_pos + u_t * a_mot;\n"
                             "  v_wpos = p; v_nrm = a_nrm; v_lpos = u_light * vec4(p, 1.0);\n"
                             "  gl_Position = u_viewproj * vec4(p, 1.0);\n"
                             "}\n";

static const char *fs_main =
    "#version 330 core\n"
    "in vec3 v_wpos, v_nrm; in vec4 v_lpos;\n"
    "uniform vec3 u_eye, u_key_dir, u_key_col, u_fill_dir, u_fill_col, u_rim_dir, u_rim_col;\n"
    "uniform float u_ambient;\n"
    "uniform vec3 u_diffuse; uniform float u_spec, u_rough;\n"
    "uniform int u_flat, u_shadows, u_ground, u_linear;\n"
    "uniform sampler2DShadow u_shadow; uniform float u_texel;\n"
    "uniform vec3 u_bg_top, u_bg_bottom; uniform float u_height;\n"
    "uniform vec3 u_center; uniform float u_fade0, u_fade1;\n"
    "out vec4 o_col;\n"
    "vec3 lin(vec3 c) { return pow(max(c, vec3(0.0)), vec3(2.2)); }\n"
    "float shadow_at(float ndl) {\n"
    /* prog_unshadowed: drawn only where the map has nothing (its taps give 1) */
    "#ifdef KF_UNSHADOWED\n"
    "  return 1.0;\n"
    "#endif\n"
    "  if (u_shadows == 0) return 1.0;\n"
    "  vec3 p = v_lpos.xyz / v_lpos.w * 0.5 + 0.5;\n"
    "  if (p.x <= 0.0 || p.x >= 1.0 || p.y <= 0.0 || p.y >= 1.0 || p.z >= 1.0) return 1.0;\n"
    "  float bias = u_texel * (1.0 + 2.0 * sqrt(1.0 - ndl * ndl) / max(ndl, 0.2));\n"
    "  float s = 0.0;\n"
    "  for (int i = -1; i <= 1; i++) for (int j = -1; j <= 1; j++)\n"
    "    s += texture(u_shadow, vec3(p.xy + vec2(i, j) * u_texel, p.z - bias));\n"
    "  return s / 9.0;\n"
    "}\n"
    "float blinn(vec3 n, vec3 l, vec3 v, float shin) {\n"
    "  vec3 h = normalize(l + v);\n"
    "  return (shin + 8.0) / 25.13 * pow(max(dot(n, h), 0.0), shin);\n"
    "}\n"
    "void main() {\n"
    "  vec3 n;\n"
    "  if (u_flat != 0) n = normalize(cross(dFdx(v_wpos), dFdy(v_wpos)));\n"
    "  else { n = normalize(v_nrm); if (!gl_FrontFacing) n = -n; }\n"
    "  vec3 v = normalize(u_eye - v_wpos);\n"
    "  vec3 albedo = lin(u_diffuse);\n"
    "  float r = clamp(u_rough, 0.03, 1.0);\n"
    "  float shin = clamp(2.0 / (r * r * r * r) - 2.0, 1.0, 4096.0);\n"
    "  float ndk = max(dot(n, u_key_dir), 0.0), ndf = max(dot(n, u_fill_dir), 0.0);\n"
    "  float sh = ndk > 0.0 ? shadow_at(ndk) : 0.0;\n"
    "  vec3 amb = u_ambient * mix(vec3(0.35, 0.33, 0.3), vec3(1.0), 0.5 + 0.5 * n.y);\n"
    "  vec3 c = albedo * (amb + u_key_col * ndk * sh + u_fill_col * ndf);\n"
    "  c += u_spec * (u_key_col * ndk * sh * blinn(n, u_key_dir, v, shin)\n"
    "               + u_fill_col * ndf * blinn(n, u_fill_dir, v, shin));\n"
    /* the rim: light from behind grazing the silhouette, strongest where the
     * surface turns away from the eye */
    "  float edge = 1.0 - max(dot(n, v), 0.0);\n"
    "  c += u_rim_col * max(dot(n, u_rim_dir), 0.0) * edge * edge * (albedo + vec3(u_spec));\n"
    "  c = c / (1.0 + 0.15 * c);\n" /* a gentle shoulder so highlights do not clip hard */
    /* the PNG's values clip at white; linear light keeps what the shoulder left */
    "  c = u_linear != 0 ? pow(max(c, 0.0), vec3(1.0 / 2.2)) : pow(clamp(c, 0.0, 1.0), vec3(1.0 / 2.2));\n"
    "  if (u_ground != 0) {\n"
    "    vec3 bg = mix(u_bg_bottom, u_bg_top, gl_FragCoord.y / u_height);\n"
    "    float f = smoothstep(u_fade0, u_fade1, distance(v_wpos.xz, u_center.xz));\n"
    "    c = mix(c, bg, f);\n"
    "  }\n"
    /* linear: the same picture decoded, so encoding it gives the PNG back */
    "  o_col = vec4(u_linear != 0 ? pow(c, vec3(2.2)) : c, 1.0);\n"
    "}\n";

/* fs_main compiled without the shadow map's taps (llvmpipe runs every
 * lane's taps whatever the branch decides): the same arithmetic wherever
 * shadow_at would return 1 */
static const char *fs_unshadowed_define = "#define KF_UNSHADOWED\n";

static const char *vs_depth = "#version 330 core\n"
                              "layout(location=0) in vec3 a_pos;\n"
                              "layout(location=2) in vec3 a_mot;\n"
                              "uniform mat4 u_light; uniform float u_t;\n"
                              "void main() { gl_Position = u_light * vec4(a_pos + u_t * a_mot, 1.0); }\n";

static const char *fs_depth = "#version 330 core\n"
                              "void main() {}\n";

static const char *vs_bg = "#version 330 core\n"
                           "out float v_t;\n"
                           "void main() {\n"
                           "  vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2) * 2.0 - 1.0;\n"
                           "  v_t = p.y * 0.5 + 0.5;\n"
                           "  gl_Position = vec4(p, 1.0, 1.0);\n"
                           "}\n";

static const char *fs_bg = "#version 330 core\n"
                           "in float v_t; uniform vec3 u_bg_top, u_bg_bottom; uniform int u_linear; out vec4 o_col;\n"
                           "void main() {\n"
                           "  vec3 c = mix(u_bg_bottom, u_bg_top, clamp(v_t, 0.0, 1.0));\n"
                           "  o_col = vec4(u_linear != 0 ? pow(c, vec3(2.2)) : c, 1.0);\n"
                           "}\n";

static GLuint compile(kf_gl *gl, GLenum type, const char *src, const char *what, char *err, size_t errlen) {
    GLuint s = gl->CreateShader(type);
    gl->ShaderSource(s, 1, &src, NULL);
    gl->CompileShader(s);
    GLint ok = 0;
    gl->GetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char log[1024] = "";
        gl->GetShaderInfoLog(s, sizeof log, NULL, log);
        snprintf(err, errlen, "render: %s shader does not compile: %s", what, log);
        gl->DeleteShader(s);
        return 0;
    }
    return s;
}

GLuint kf_gl_program(kf_gl *gl, const char *vs, const char *fs, const char *what, char *err, size_t errlen) {
    GLuint v = compile(gl, GL_VERTEX_SHADER, vs, what, err, errlen);
    if (!v) return 0;
    GLuint f = compile(gl, GL_FRAGMENT_SHADER, fs, what, err, errlen);
    if (!f) {
        gl->DeleteShader(v);
        return 0;
    }
    GLuint p = gl->CreateProgram();
    gl->AttachShader(p, v);
    gl->AttachShader(p, f);
    gl->LinkProgram(p);
    gl->DeleteShader(v);
    gl->DeleteShader(f);
    GLint ok = 0;
    gl->GetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) {
        char log[1024] = "";
        gl->GetProgramInfoLog(p, sizeof log, NULL, log);
        snprintf(err, errlen, "render: %s program does not link: %s", what, log);
        gl->DeleteProgram(p);
        return 0;
    }
    return p;
}

/* ---- create / destroy ------------------------------------------------------ */

int kf_fbo_complete(kf_gl *gl, const char *what, char *err, size_t errlen) {
    GLenum st = gl->CheckFramebufferStatus(GL_FRAMEBUFFER);
    if (st != GL_FRAMEBUFFER_COMPLETE) {
        snprintf(err, errlen, "render: %s framebuffer incomplete (status 0x%x)", what, st);
        return -1;
    }
    return 0;
}

kf_render_ctx *kf_render_create(int w, int h, int samples, char *err, size_t errlen) {
    if (w <= 0 || h <= 0 || w > 16384 || h > 16384) {
        snprintf(err, errlen, "render: bad image size %dx%d (1..16384 each way)", w, h);
        return NULL;
    }
    kf_render_ctx *r = calloc(1, sizeof *r);
    if (!r) {
        snprintf(err, errlen, "render: out of memory");
        return NULL;
    }
    r->w = w;
    r->h = h;
    r->readback = malloc((size_t)w * h * 4);
    if (!r->readback) {
        snprintf(err, errlen, "render: out of memory for a %dx%d image", w, h);
        free(r);
        return NULL;
    }
    r->glc = kf_gl_context_create(w, h, err, errlen);
    if (!r->glc || kf_gl_load(&r->gl, kf_gl_context_proc, err, errlen) != 0) {
        kf_render_destroy(r);
        return NULL;
    }
    kf_gl *gl = &r->gl;
    const char *name = (const char *)gl->GetString(GL_RENDERER);
    snprintf(r->renderer_name, sizeof r->renderer_name, "%s", name ? name : "?");

    GLint max_samples = 1, max_rb = 0, max_tex = 0;
    gl->GetIntegerv(GL_MAX_SAMPLES, &max_samples);
    gl->GetIntegerv(GL_MAX_RENDERBUFFER_SIZE, &max_rb);
    gl->GetIntegerv(GL_MAX_TEXTURE_SIZE, &max_tex);
    if (w > max_rb || h > max_rb) {
        snprintf(err, errlen, "render: %dx%d exceeds the GL's largest renderbuffer (%d)", w, h, max_rb);
        kf_render_destroy(r);
        return NULL;
    }
    r->samples = samples <= 1 ? 1 : (samples > max_samples ? max_samples : samples);
    r->draw_samples = r->samples;
    /* shadow map: about the image's long side, 512..2048 texels (PCF softens the rest;
     * 4096 doubled the 1080p frame time on llvmpipe for no visible gain) */
    int longest = w > h ? w : h;
    r->shadow_size = longest < 512 ? 512 : (longest > 2048 ? 2048 : longest);
    if (r->shadow_size > max_tex) r->shadow_size = max_tex;

    /* fs_main with the define after its #version line */
    const char *body = strchr(fs_main, '\n') + 1;
    char *fs_un = malloc(strlen(fs_main) + strlen(fs_unshadowed_define) + 1);
    if (!fs_un) {
        snprintf(err, errlen, "render: out of memory");
        kf_render_destroy(r);
        return NULL;
    }
    sprintf(fs_un, "%.*s%s%s", (int)(body - fs_main), fs_main, fs_unshadowed_define, body);
    r->prog_unshadowed = kf_gl_program(gl, vs_main, fs_un, "ground", err, errlen);
    free(fs_un);
    if (!r->prog_unshadowed || !(r->prog_main = kf_gl_program(gl, vs_main, fs_main, "mesh", err, errlen)) ||
        !(r->prog_depth = kf_gl_program(gl, vs_depth, fs_depth, "shadow", err, errlen)) ||
        !(r->prog_bg = kf_gl_program(gl, vs_bg, fs_bg, "background", err, errlen))) {
        kf_render_destroy(r);
        return NULL;
    }
    gl->GenVertexArrays(1, &r->vao);
    gl->BindVertexArray(r->vao);

    /* the draw target: colour + depth, multisampled if asked */
    gl->GenFramebuffers(1, &r->fbo_draw);
    gl->GenRenderbuffers(1, &r->rb_color);
    gl->GenRenderbuffers(1, &r->rb_depth);
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_draw);
    gl->BindRenderbuffer(GL_RENDERBUFFER, r->rb_color);
    gl->RenderbufferStorageMultisample(GL_RENDERBUFFER, r->samples > 1 ? r->samples : 0, GL_RGBA8, w, h);
    gl->FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, r->rb_color);
    gl->BindRenderbuffer(GL_RENDERBUFFER, r->rb_depth);
    gl->RenderbufferStorageMultisample(GL_RENDERBUFFER, r->samples > 1 ? r->samples : 0, GL_DEPTH_COMPONENT24, w, h);
    gl->FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, r->rb_depth);
    if (kf_fbo_complete(gl, "image", err, errlen) != 0) {
        kf_render_destroy(r);
        return NULL;
    }
    if (r->samples > 1) {
        gl->GenFramebuffers(1, &r->fbo_resolve);
        gl->GenRenderbuffers(1, &r->rb_resolve);
        gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_resolve);
        gl->BindRenderbuffer(GL_RENDERBUFFER, r->rb_resolve);
        gl->RenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, w, h);
        gl->FramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, r->rb_resolve);
        if (kf_fbo_complete(gl, "resolve", err, errlen) != 0) {
            kf_render_destroy(r);
            return NULL;
        }
    }

    /* the shadow map: a depth texture compared in the shader (sampler2DShadow) */
    gl->GenTextures(1, &r->tex_shadow);
    gl->BindTexture(GL_TEXTURE_2D, r->tex_shadow);
    gl->TexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, r->shadow_size, r->shadow_size, 0, GL_DEPTH_COMPONENT,
                   GL_FLOAT, NULL);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
    gl->GenFramebuffers(1, &r->fbo_shadow);
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_shadow);
    gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, r->tex_shadow, 0);
    gl->DrawBuffer(GL_NONE);
    gl->ReadBuffer(GL_NONE);
    if (kf_fbo_complete(gl, "shadow", err, errlen) != 0) {
        kf_render_destroy(r);
        return NULL;
    }
    gl->GenBuffers(2, r->ground_vbo);
    gl->GenBuffers(1, &r->ground_ebo);
    GLenum e = gl->GetError();
    if (e != GL_NO_ERROR) {
        snprintf(err, errlen, "render: GL error 0x%x while setting up %dx%d x%d samples", e, w, h, r->samples);
        kf_render_destroy(r);
        return NULL;
    }
    return r;
}

void kf_render_destroy(kf_render_ctx *r) {
    if (!r) return;
    if (r->glc) {
        char e[64];
        if (kf_gl_context_make_current(r->glc, e, sizeof e) == 0 && r->gl.DeleteBuffers) {
            kf_gl *gl = &r->gl;
            if (r->nbuf) {
                gl->DeleteBuffers(r->nbuf, r->vbo_pos);
                gl->DeleteBuffers(r->nbuf, r->vbo_nrm);
                gl->DeleteBuffers(r->nbuf, r->ebo);
                gl->DeleteBuffers(r->nbuf, r->vbo_mot);
            }
            kf_aov_destroy(r);
            kf_edge_aa_destroy(r);
            gl->DeleteBuffers(2, r->ground_vbo);
            gl->DeleteBuffers(1, &r->ground_ebo);
            gl->DeleteFramebuffers(1, &r->fbo_draw);
            gl->DeleteFramebuffers(1, &r->fbo_resolve);
            gl->DeleteFramebuffers(1, &r->fbo_shadow);
            gl->DeleteRenderbuffers(1, &r->rb_color);
            gl->DeleteRenderbuffers(1, &r->rb_depth);
            gl->DeleteRenderbuffers(1, &r->rb_resolve);
            gl->DeleteTextures(1, &r->tex_shadow);
            gl->DeleteVertexArrays(1, &r->vao);
            if (r->prog_main) gl->DeleteProgram(r->prog_main);
            if (r->prog_unshadowed) gl->DeleteProgram(r->prog_unshadowed);
            if (r->prog_depth) gl->DeleteProgram(r->prog_depth);
            if (r->prog_bg) gl->DeleteProgram(r->prog_bg);
        }
        kf_gl_context_destroy(r->glc);
    }
    free(r->vbo_pos);
    free(r->vbo_nrm);
    free(r->ebo);
    free(r->vbo_mot);
    free(r->readback);
    free(r->readback_f);
    free(r);
}

/* a new size re-allocates the depth texture; its framebuffer follows it */
int kf_render_set_shadow_size(kf_render_ctx *r, int texels, char *err, size_t errlen) {
    GLint max_tex = 0;
    if (kf_gl_context_make_current(r->glc, err, errlen) != 0) return -1;
    r->gl.GetIntegerv(GL_MAX_TEXTURE_SIZE, &max_tex);
    if (texels < 16 || texels > max_tex) {
        snprintf(err, errlen, "render: shadow map of %d texels outside 16..%d", texels, (int)max_tex);
        return -1;
    }
    r->shadow_size = texels;
    r->gl.BindTexture(GL_TEXTURE_2D, r->tex_shadow);
    r->gl.TexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, texels, texels, 0, GL_DEPTH_COMPONENT, GL_FLOAT, NULL);
    GLenum e = r->gl.GetError();
    if (e != GL_NO_ERROR) {
        snprintf(err, errlen, "render: GL error 0x%x making a %d-texel shadow map", e, texels);
        return -1;
    }
    return 0;
}

int kf_render_shadow_size(const kf_render_ctx *r) { return r->shadow_size; }
int kf_render_samples(const kf_render_ctx *r) { return r->samples; }

/* the picture's target re-made with one sample (edges) or the context's samples (MSAA) */
int kf_render_set_antialias(kf_render_ctx *r, int mode, char *err, size_t errlen) {
    if (mode != KF_RENDER_AA_MSAA && mode != KF_RENDER_AA_EDGES) {
        snprintf(err, errlen, "render: unknown anti-aliasing mode %d", mode);
        return -1;
    }
    if (kf_gl_context_make_current(r->glc, err, errlen) != 0) return -1;
    kf_gl *gl = &r->gl;
    int samples = mode == KF_RENDER_AA_EDGES ? 1 : r->samples;
    r->aa = mode;
    if (samples == r->draw_samples) return 0;
    gl->BindRenderbuffer(GL_RENDERBUFFER, r->rb_color);
    gl->RenderbufferStorageMultisample(GL_RENDERBUFFER, samples > 1 ? samples : 0, GL_RGBA8, r->w, r->h);
    gl->BindRenderbuffer(GL_RENDERBUFFER, r->rb_depth);
    gl->RenderbufferStorageMultisample(GL_RENDERBUFFER, samples > 1 ? samples : 0, GL_DEPTH_COMPONENT24, r->w, r->h);
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_draw);
    if (kf_fbo_complete(gl, "image", err, errlen) != 0) return -1;
    r->draw_samples = samples;
    GLenum e = gl->GetError();
    if (e != GL_NO_ERROR) {
        snprintf(err, errlen, "render: GL error 0x%x while re-making the %dx%d image", e, r->w, r->h);
        return -1;
    }
    return 0;
}
const char *kf_render_backend(const kf_render_ctx *r) { return r ? kf_gl_context_backend(r->glc) : ""; }

const char *kf_render_gl_renderer(const kf_render_ctx *r) { return r->renderer_name; }

/* ---- scene --------------------------------------------------------------- */

kf_render_scene kf_render_scene_default(void) {
    kf_render_scene s;
    memset(&s, 0, sizeof s);
    s.ground = 1;
    s.ground_y = NAN;
    s.ground_mat = (kf_render_material){{0.55f, 0.55f, 0.53f}, 0.05f, 0.8f};
    /* studio grey, a little lighter at the top */
    s.bg_top[0] = 0.36f, s.bg_top[1] = 0.38f, s.bg_top[2] = 0.42f;
    s.bg_bottom[0] = 0.14f, s.bg_bottom[1] = 0.14f, s.bg_bottom[2] = 0.15f;
    /* key from upper left-front of the camera, fill from the right, cooler */
    s.key_dir[0] = -0.55f, s.key_dir[1] = 0.75f, s.key_dir[2] = 0.6f;
    s.key_color[0] = 1.35f, s.key_color[1] = 1.3f, s.key_color[2] = 1.2f;
    s.fill_dir[0] = 0.8f, s.fill_dir[1] = 0.2f, s.fill_dir[2] = 0.45f;
    s.fill_color[0] = 0.22f, s.fill_color[1] = 0.25f, s.fill_color[2] = 0.3f;
    s.ambient = 0.16f;
    /* a rim light from behind, off unless asked for */
    s.rim_dir[0] = 0.2f, s.rim_dir[1] = 0.5f, s.rim_dir[2] = -1.0f;
    s.shadows = 1;
    return s;
}

int kf_render_scene_bounds(const kf_render_scene *sc, float lo[3], float hi[3]) {
    for (int i = 0; i < 3; i++) lo[i] = INFINITY, hi[i] = -INFINITY;
    size_t n = 0;
    for (int m = 0; m < sc->nmeshes; m++) {
        const kf_render_mesh *me = &sc->meshes[m];
        if (!me->positions) continue;
        for (size_t v = 0; v < me->nverts; v++)
            for (int i = 0; i < 3; i++) {
                float x = me->positions[3 * v + i];
                if (x < lo[i]) lo[i] = x;
                if (x > hi[i]) hi[i] = x;
            }
        n += me->nverts;
    }
    if (n == 0) {
        for (int i = 0; i < 3; i++) lo[i] = -0.5f, hi[i] = 0.5f;
        return -1;
    }
    return 0;
}

/* ---- frame --------------------------------------------------------------- */

static int grow_buffers(kf_render_ctx *r, int n) {
    if (n <= r->nbuf) return 0;
    GLuint *p = realloc(r->vbo_pos, n * sizeof *p), *q, *e, *mo;
    if (!p) return -1;
    r->vbo_pos = p;
    if (!(q = realloc(r->vbo_nrm, n * sizeof *q))) return -1;
    r->vbo_nrm = q;
    if (!(e = realloc(r->ebo, n * sizeof *e))) return -1;
    r->ebo = e;
    if (!(mo = realloc(r->vbo_mot, n * sizeof *mo))) return -1;
    r->vbo_mot = mo;
    int add = n - r->nbuf;
    r->gl.GenBuffers(add, r->vbo_pos + r->nbuf);
    r->gl.GenBuffers(add, r->vbo_nrm + r->nbuf);
    r->gl.GenBuffers(add, r->ebo + r->nbuf);
    r->gl.GenBuffers(add, r->vbo_mot + r->nbuf);
    r->nbuf = n;
    return 0;
}

void kf_bind_mesh(kf_gl *gl, GLuint pos, GLuint nrm, int has_nrm, GLuint mot, int has_mot, GLuint ebo) {
    gl->BindBuffer(GL_ARRAY_BUFFER, pos);
    gl->VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, NULL);
    gl->EnableVertexAttribArray(0);
    if (has_nrm) {
        gl->BindBuffer(GL_ARRAY_BUFFER, nrm);
        gl->VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, NULL);
        gl->EnableVertexAttribArray(1);
    } else {
        gl->DisableVertexAttribArray(1);
        gl->VertexAttrib3f(1, 0, 1, 0);
    }
    /* a still mesh moves by nothing: a + t * 0 is a, bit for bit */
    if (has_mot) {
        gl->BindBuffer(GL_ARRAY_BUFFER, mot);
        gl->VertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, 0, NULL);
        gl->EnableVertexAttribArray(2);
    } else {
        gl->DisableVertexAttribArray(2);
        gl->VertexAttrib3f(2, 0, 0, 0);
    }
    gl->BindBuffer(GL_ELEMENT_ARRAY_BUFFER, ebo);
}

static void to_world(float out[3], const float d[3], const float m_view[16], int in_world) {
    if (in_world) {
        out[0] = d[0], out[1] = d[1], out[2] = d[2];
    } else {
        /* camera axes are the rows of the view rotation (columns of its transpose) */
        for (int i = 0; i < 3; i++)
            out[i] = m_view[i * 4 + 0] * d[0] + m_view[i * 4 + 1] * d[1] + m_view[i * 4 + 2] * d[2];
    }
    float l = sqrtf(out[0] * out[0] + out[1] * out[1] + out[2] * out[2]);
    if (l > 0) out[0] /= l, out[1] /= l, out[2] /= l;
    else out[1] = 1;
}

int kf_frame_begin(kf_render_ctx *r, const kf_render_scene *sc, const kf_camera *cam, kf_frame *f, char *err,
                   size_t errlen) {
    if (!r || !sc || !cam) {
        snprintf(err, errlen, "render: frame needs a context, a scene, a camera and an image");
        return -1;
    }
    if (sc->nmeshes < 0 || (sc->nmeshes > 0 && !sc->meshes)) {
        snprintf(err, errlen, "render: scene has %d meshes but no mesh array", sc->nmeshes);
        return -1;
    }
    /* validate every mesh before any GL work: a bad index would read out of bounds */
    for (int m = 0; m < sc->nmeshes; m++) {
        const kf_render_mesh *me = &sc->meshes[m];
        if (me->ntris > 0 && (!me->positions || !me->tris)) {
            snprintf(err, errlen, "render: mesh %d has %zu triangles but no %s", m, me->ntris,
                     me->positions ? "index array" : "positions");
            return -1;
        }
        if (me->ntris * 3 > (size_t)INT32_MAX) {
            snprintf(err, errlen, "render: mesh %d has too many triangles (%zu)", m, me->ntris);
            return -1;
        }
        for (size_t i = 0; i < me->ntris * 3; i++)
            if (me->tris[i] >= me->nverts) {
                snprintf(err, errlen, "render: mesh %d triangle %zu uses vertex %u but the mesh has %zu", m, i / 3,
                         me->tris[i], me->nverts);
                return -1;
            }
    }
    if (kf_gl_context_make_current(r->glc, err, errlen) != 0) return -1;
    kf_gl *gl = &r->gl;
    gl->GetError(); /* clear stale errors */

    /* the subject: bounding sphere of the meshes */
    float lo[3], hi[3];
    f->rad = 0;
    f->empty = kf_render_scene_bounds(sc, lo, hi) != 0;
    for (int i = 0; i < 3; i++) {
        f->center[i] = 0.5f * (lo[i] + hi[i]);
        f->rad += 0.25f * (hi[i] - lo[i]) * (hi[i] - lo[i]);
    }
    f->rad = sqrtf(f->rad);
    if (!(f->rad > 1e-6f)) f->rad = 0.5f;
    f->ground_y = isnan(sc->ground_y) ? lo[1] : sc->ground_y;
    f->draw_ground = sc->ground != 0;
    if (f->empty && isnan(sc->ground_y)) f->ground_y = 0;
    f->fade0 = 2.5f * f->rad, f->fade1 = 8.0f * f->rad;
    f->shadows = sc->shadows && !f->empty;
    if (kf_frame_camera(r, sc, cam, NULL, f, err, errlen) != 0) return -1;

    /* upload meshes (every frame: the caller's arrays may have changed) */
    if (grow_buffers(r, sc->nmeshes) != 0) {
        snprintf(err, errlen, "render: out of memory for %d meshes", sc->nmeshes);
        return -1;
    }
    gl->BindVertexArray(r->vao);
    for (int m = 0; m < sc->nmeshes; m++) {
        const kf_render_mesh *me = &sc->meshes[m];
        if (me->ntris == 0) continue;
        gl->BindBuffer(GL_ARRAY_BUFFER, r->vbo_pos[m]);
        gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(me->nverts * 12), me->positions, GL_STREAM_DRAW);
        if (me->normals) {
            gl->BindBuffer(GL_ARRAY_BUFFER, r->vbo_nrm[m]);
            gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(me->nverts * 12), me->normals, GL_STREAM_DRAW);
        }
        if (me->motion) {
            gl->BindBuffer(GL_ARRAY_BUFFER, r->vbo_mot[m]);
            gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(me->nverts * 12), me->motion, GL_STREAM_DRAW);
        }
        gl->BindBuffer(GL_ELEMENT_ARRAY_BUFFER, r->ebo[m]);
        gl->BufferData(GL_ELEMENT_ARRAY_BUFFER, (GLsizeiptr)(me->ntris * 12), me->tris, GL_STREAM_DRAW);
    }
    if (f->draw_ground) {
        float g = f->fade1 * 1.5f, cx = f->center[0], cz = f->center[2], gy = f->ground_y;
        float gp[12] = {cx - g, gy, cz - g, cx + g, gy, cz - g, cx + g, gy, cz + g, cx - g, gy, cz + g};
        float gn[12] = {0, 1, 0, 0, 1, 0, 0, 1, 0, 0, 1, 0};
        uint32_t gi[6] = {0, 2, 1, 0, 3, 2};
        gl->BindBuffer(GL_ARRAY_BUFFER, r->ground_vbo[0]);
        gl->BufferData(GL_ARRAY_BUFFER, sizeof gp, gp, GL_STREAM_DRAW);
        gl->BindBuffer(GL_ARRAY_BUFFER, r->ground_vbo[1]);
        gl->BufferData(GL_ARRAY_BUFFER, sizeof gn, gn, GL_STREAM_DRAW);
        gl->BindBuffer(GL_ELEMENT_ARRAY_BUFFER, r->ground_ebo);
        gl->BufferData(GL_ELEMENT_ARRAY_BUFFER, sizeof gi, gi, GL_STREAM_DRAW);
    }
    return 0;
}

/* the near and far planes and the projection for camera c */
static int camera_matrices(const kf_render_ctx *r, const kf_frame *f, const kf_camera *c, float view[16],
                           float viewproj[16], float proj[16], float *near, char *err, size_t errlen) {
    if (kf_m4_look_at(view, c->eye, c->target, c->up) != 0) {
        snprintf(err, errlen, "render: degenerate camera (eye == target, or up parallel to the view)");
        return -1;
    }
    if (!(c->fov_deg > 0.5f && c->fov_deg < 179.5f)) {
        snprintf(err, errlen, "render: camera fov %g degrees is outside (0.5, 179.5)", (double)c->fov_deg);
        return -1;
    }
    float dx = c->eye[0] - f->center[0], dy = c->eye[1] - f->center[1], dz = c->eye[2] - f->center[2];
    float dist = sqrtf(dx * dx + dy * dy + dz * dz);
    float zfar = c->zfar > 0 ? c->zfar : dist + f->rad + (f->draw_ground ? f->fade1 + f->rad : 0);
    float znear = c->znear > 0 ? c->znear : fmaxf(0.5f * (dist - f->rad), zfar * 2e-4f);
    if (!(zfar > znear)) {
        snprintf(err, errlen, "render: camera near %g >= far %g", (double)znear, (double)zfar);
        return -1;
    }
    kf_m4_perspective(proj, c->fov_deg, (float)r->w / r->h, znear, zfar);
    kf_m4_mul(viewproj, proj, view);
    *near = znear;
    return 0;
}

int kf_frame_camera(kf_render_ctx *r, const kf_render_scene *sc, const kf_camera *cam, const kf_camera *cam_next,
                    kf_frame *f, char *err, size_t errlen) {
    float view_n[16], proj_n[16], near_n;
    if (camera_matrices(r, f, cam, f->view, f->viewproj, f->proj, &f->znear, err, errlen) != 0) return -1;
    if (!cam_next) memcpy(f->viewproj_next, f->viewproj, sizeof f->viewproj);
    else if (camera_matrices(r, f, cam_next, view_n, f->viewproj_next, proj_n, &near_n, err, errlen) != 0) return -1;
    memcpy(f->eye, cam->eye, sizeof f->eye);
    /* lights in world space */
    to_world(f->key, sc->key_dir, f->view, sc->lights_in_world);
    to_world(f->fill, sc->fill_dir, f->view, sc->lights_in_world);
    to_world(f->rim, sc->rim_dir, f->view, sc->lights_in_world);
    /* the shadow map: orthographic from the key light, fitted to the subject's sphere */
    float leye[3], lup[3] = {0, 1, 0};
    for (int i = 0; i < 3; i++) leye[i] = f->center[i] + f->key[i] * 3.0f * f->rad;
    if (fabsf(f->key[1]) > 0.99f) lup[1] = 0, lup[2] = 1;
    float lview[16], lproj[16];
    kf_m4_look_at(lview, leye, f->center, lup);
    kf_m4_ortho(lproj, -1.05f * f->rad, 1.05f * f->rad, -1.05f * f->rad, 1.05f * f->rad, 0.5f * f->rad,
                3.0f * f->rad + f->fade1 + f->rad);
    kf_m4_mul(f->light_vp, lproj, lview);
    return 0;
}

/* the box of a mesh at every time of the shutter (t from -1 to 1 frames:
 * positions and positions -+ motion; the shutter is centred on the frame) */
static void mesh_box(const kf_render_mesh *me, float lo[3], float hi[3]) {
    for (int a = 0; a < 3; a++) lo[a] = INFINITY, hi[a] = -INFINITY;
    for (int pass = 0; pass < (me->motion ? 3 : 1); pass++)
        for (size_t v = 0; v < me->nverts; v++)
            for (int a = 0; a < 3; a++) {
                const float d = pass == 0 ? 0.f : me->motion[3 * v + a];
                const float x = me->positions[3 * v + a] + (pass == 2 ? -d : d);
                lo[a] = fminf(lo[a], x), hi[a] = fmaxf(hi[a], x);
            }
}

/* whether a closed mesh's box (over the shutter) passes `beyond` at all
 * eight corners: the test both back-face culls below make */
static int closed_box_passes(const kf_render_mesh *me, const float *m, float znear,
                             int (*beyond)(const float *, float, const float[3])) {
    if (!me->closed || me->nverts == 0) return 0;
    float lo[3], hi[3];
    mesh_box(me, lo, hi);
    for (int k = 0; k < 8; k++) {
        const float p[3] = {k & 1 ? hi[0] : lo[0], k & 2 ? hi[1] : lo[1], k & 4 ? hi[2] : lo[2]};
        if (!beyond(m, znear, p)) return 0;
    }
    return 1;
}

/* Whether a closed mesh's back faces can be skipped: each is hidden behind
 * the mesh's own front faces wherever the camera sees it from outside, which
 * holds when the mesh (at every time of the shutter) lies wholly beyond the
 * near plane, so that nothing of it is cut
 * open there. Llvmpipe sets up and rasterises every triangle it is given:
 * half of a level set's mesh faces away. (The one exception: a silhouette
 * pixel whose centre a facet folding away covers and no front facet does;
 * one such pixel in the 1080p and demo frames checked.) */
static int view_beyond_near(const float *view, float znear, const float p[3]) {
    /* the view's depth of p (the view looks down -z) */
    const float z = view[2] * p[0] + view[6] * p[1] + view[10] * p[2] + view[14];
    return -z > znear;
}
static int cull_back_faces(const kf_render_mesh *me, const kf_frame *f) {
    return closed_box_passes(me, f->view, f->znear, view_beyond_near);
}

/* The same for the shadow map: seen from the key light, a closed mesh's
 * nearest surface is a front face wherever the light's near plane leaves it
 * whole (clip z > -w at every corner of its box, the light's projection
 * being orthographic), so the back faces, half the triangles, give the map
 * nothing but the odd texel where a facet folding away at the silhouette
 * covers a texel centre that no front facet does (a texel the polygon
 * offset and the 3x3 filter blur with its neighbours). */
static int light_beyond_near(const float *m, float unused, const float p[3]) {
    (void)unused;
    const float z = m[2] * p[0] + m[6] * p[1] + m[10] * p[2] + m[14];
    const float w = m[3] * p[0] + m[7] * p[1] + m[11] * p[2] + m[15];
    return z > -w;
}
static int cull_shadow_back_faces(const kf_render_mesh *me, const kf_frame *f) {
    return closed_box_passes(me, f->light_vp, 0, light_beyond_near);
}

void kf_frame_shadow(kf_render_ctx *r, const kf_render_scene *sc, kf_frame *f, float t) {
    kf_gl *gl = &r->gl;
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_shadow);
    gl->Viewport(0, 0, r->shadow_size, r->shadow_size);
    gl->Enable(GL_DEPTH_TEST);
    gl->DepthFunc(GL_LESS);
    gl->DepthMask(GL_TRUE);
    gl->Clear(GL_DEPTH_BUFFER_BIT);
    if (!f->shadows) return;
    gl->UseProgram(r->prog_depth);
    gl->UniformMatrix4fv(gl->GetUniformLocation(r->prog_depth, "u_light"), 1, GL_FALSE, f->light_vp);
    gl->Uniform1f(gl->GetUniformLocation(r->prog_depth, "u_t"), t);
    gl->Enable(GL_POLYGON_OFFSET_FILL);
    gl->PolygonOffset(1.5f, 2.0f);
    for (int m = 0; m < sc->nmeshes; m++) {
        const kf_render_mesh *me = &sc->meshes[m];
        if (me->ntris == 0) continue;
        kf_bind_mesh(gl, r->vbo_pos[m], 0, 0, r->vbo_mot[m], me->motion != NULL, r->ebo[m]);
        const int cull = cull_shadow_back_faces(me, f);
        if (cull) gl->Enable(GL_CULL_FACE); /* back faces, counter-clockwise fronts: GL's defaults */
        gl->DrawElements(GL_TRIANGLES, (GLsizei)(me->ntris * 3), GL_UNSIGNED_INT, NULL);
        if (cull) gl->Disable(GL_CULL_FACE);
    }
    gl->Disable(GL_POLYGON_OFFSET_FILL);
}

/* the per-draw uniforms of the mesh shader */
typedef struct shading {
    GLint diffuse, spec, rough, flat, ground;
} shading;

/* program p (prog_main or prog_unshadowed) in use with the frame's uniforms */
static shading use_shading(kf_render_ctx *r, GLuint p, const kf_render_scene *sc, const kf_frame *f, int linear,
                           float t) {
    kf_gl *gl = &r->gl;
    gl->UseProgram(p);
#define U(name) gl->GetUniformLocation(p, name)
    gl->UniformMatrix4fv(U("u_viewproj"), 1, GL_FALSE, f->viewproj);
    gl->UniformMatrix4fv(U("u_light"), 1, GL_FALSE, f->light_vp);
    gl->Uniform1f(U("u_t"), t);
    gl->Uniform1i(U("u_linear"), linear);
    gl->Uniform3fv(U("u_eye"), 1, f->eye);
    gl->Uniform3fv(U("u_key_dir"), 1, f->key);
    gl->Uniform3fv(U("u_key_col"), 1, sc->key_color);
    gl->Uniform3fv(U("u_fill_dir"), 1, f->fill);
    gl->Uniform3fv(U("u_fill_col"), 1, sc->fill_color);
    gl->Uniform3fv(U("u_rim_dir"), 1, f->rim);
    gl->Uniform3fv(U("u_rim_col"), 1, sc->rim_color);
    gl->Uniform1f(U("u_ambient"), sc->ambient);
    gl->Uniform1i(U("u_shadows"), f->shadows);
    gl->Uniform1f(U("u_texel"), 1.0f / r->shadow_size);
    gl->Uniform3fv(U("u_bg_top"), 1, sc->bg_top);
    gl->Uniform3fv(U("u_bg_bottom"), 1, sc->bg_bottom);
    gl->Uniform1f(U("u_height"), (float)r->h);
    gl->Uniform3fv(U("u_center"), 1, f->center);
    gl->Uniform1f(U("u_fade0"), f->fade0);
    gl->Uniform1f(U("u_fade1"), f->fade1);
    gl->ActiveTexture(GL_TEXTURE0);
    gl->BindTexture(GL_TEXTURE_2D, r->tex_shadow);
    gl->Uniform1i(U("u_shadow"), 0);
    shading u = {U("u_diffuse"), U("u_spec"), U("u_rough"), U("u_flat"), U("u_ground")};
#undef U
    return u;
}

/* The pixels (x0, y0, x1, y1: window coordinates, the pixels x0..x1-1 and
 * y0..y1-1) outside which no ground fragment reads the shadow map: the
 * screen box of the ground's parallelogram that the key light's map covers
 * (its light-space x and y in 0..1), grown by 2 pixels for the roundings
 * of the fragments' interpolated positions. Outside it shadow_at returns 1
 * (p.x or p.y out of the map). The whole image where that cannot be had
 * (the light along the ground, a corner behind the eye). */
static void ground_shadow_box(const kf_render_ctx *r, const kf_frame *f, int box[4]) {
    box[0] = 0, box[1] = 0, box[2] = r->w, box[3] = r->h;
    const float *L = f->light_vp, gy = f->ground_y;
    /* the map's coordinates on the ground (orthographic: w = 1), affine in x, z */
    const double ax = 0.5 * L[0], az = 0.5 * L[8], a0 = 0.5 * (L[4] * gy + L[12]) + 0.5;
    const double bx = 0.5 * L[1], bz = 0.5 * L[9], b0 = 0.5 * (L[5] * gy + L[13]) + 0.5;
    const double det = ax * bz - az * bx;
    if (!(fabs(det) > 1e-12 * (fabs(ax * bz) + fabs(az * bx))) || L[3] != 0 || L[7] != 0 || L[11] != 0) return;
    double lo[2] = {INFINITY, INFINITY}, hi[2] = {-INFINITY, -INFINITY};
    for (int k = 0; k < 4; k++) {
        const double u = (k == 1 || k == 2) - a0, v = (k >= 2) - b0;
        const double x = (bz * u - az * v) / det, z = (ax * v - bx * u) / det;
        const float *M = f->viewproj;
        const double cx = M[0] * x + M[4] * gy + M[8] * z + M[12], cy = M[1] * x + M[5] * gy + M[9] * z + M[13];
        const double cw = M[3] * x + M[7] * gy + M[11] * z + M[15];
        if (!(cw > 1e-6)) return;
        const double sx = (cx / cw * 0.5 + 0.5) * r->w, sy = (cy / cw * 0.5 + 0.5) * r->h;
        lo[0] = fmin(lo[0], sx), hi[0] = fmax(hi[0], sx), lo[1] = fmin(lo[1], sy), hi[1] = fmax(hi[1], sy);
    }
    const double lim[2] = {r->w, r->h};
    for (int a = 0; a < 2; a++) {
        box[a] = (int)fmax(0, fmin(lim[a], floor(lo[a]) - 2));
        box[a + 2] = (int)fmax(0, fmin(lim[a], ceil(hi[a]) + 2));
    }
}

/* the ground's material in program u's uniforms, and its quad bound */
static void ground_uniforms(kf_render_ctx *r, const kf_render_scene *sc, shading u) {
    kf_gl *gl = &r->gl;
    gl->Uniform1i(u.ground, 1);
    gl->Uniform3fv(u.diffuse, 1, sc->ground_mat.diffuse);
    gl->Uniform1f(u.spec, sc->ground_mat.specular);
    gl->Uniform1f(u.rough, sc->ground_mat.roughness > 0 ? sc->ground_mat.roughness : 0.8f);
    gl->Uniform1i(u.flat, 0);
    kf_bind_mesh(gl, r->ground_vbo[0], r->ground_vbo[1], 1, 0, 0, r->ground_ebo);
}

/* The ground: inside the map's box with the full shader, around it (up to
 * four bands) with prog_unshadowed, which there gives the same values: the
 * same quad, so every fragment gets the same interpolated inputs, and the
 * scissor only picks which program shades it. The map's 9 taps were half
 * the ground's cost over the 1080p frame, most of which lies beyond the
 * map. Without shadows the ground is all prog_unshadowed's. */
static void draw_ground(kf_render_ctx *r, const kf_render_scene *sc, const kf_frame *f, shading u, int linear,
                        float t) {
    kf_gl *gl = &r->gl;
    int box[4] = {0, 0, 0, 0};
    if (f->shadows) ground_shadow_box(r, f, box);
    /* the box, then the bands below, above, left and right of it */
    const int bands[5][4] = {{box[0], box[1], box[2], box[3]},
                             {0, 0, r->w, box[1]},
                             {0, box[3], r->w, r->h},
                             {0, box[1], box[0], box[3]},
                             {box[2], box[1], r->w, box[3]}};
    gl->Enable(GL_SCISSOR_TEST);
    /* prog_main (the meshes', in use) for the box, prog_unshadowed around it,
     * each program's ground uniforms set before its first band */
    int program_ready[2] = {0, 0};
    for (int k = 0; k < 5; k++) {
        const int *b = bands[k];
        if (b[2] <= b[0] || b[3] <= b[1]) continue;
        const int around = k > 0;
        if (!program_ready[around]) {
            if (around) u = use_shading(r, r->prog_unshadowed, sc, f, linear, t);
            ground_uniforms(r, sc, u);
            program_ready[around] = 1;
        }
        gl->Scissor(b[0], b[1], b[2] - b[0], b[3] - b[1]);
        gl->DrawElements(GL_TRIANGLES, 6, GL_UNSIGNED_INT, NULL);
    }
    gl->Disable(GL_SCISSOR_TEST);
}

void kf_frame_beauty(kf_render_ctx *r, const kf_render_scene *sc, const kf_frame *f, GLuint fbo, int linear, float t) {
    kf_gl *gl = &r->gl;
    /* background gradient */
    gl->BindFramebuffer(GL_FRAMEBUFFER, fbo);
    gl->Viewport(0, 0, r->w, r->h);
    gl->Enable(GL_MULTISAMPLE);
    gl->ClearColor(0, 0, 0, 1);
    gl->Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    gl->Disable(GL_DEPTH_TEST);
    gl->DepthMask(GL_FALSE);
    gl->UseProgram(r->prog_bg);
    gl->Uniform3fv(gl->GetUniformLocation(r->prog_bg, "u_bg_top"), 1, sc->bg_top);
    gl->Uniform3fv(gl->GetUniformLocation(r->prog_bg, "u_bg_bottom"), 1, sc->bg_bottom);
    gl->Uniform1i(gl->GetUniformLocation(r->prog_bg, "u_linear"), linear);
    gl->DrawArrays(GL_TRIANGLES, 0, 3);
    gl->Enable(GL_DEPTH_TEST);
    gl->DepthMask(GL_TRUE);

    /* meshes and ground */
    shading u = use_shading(r, r->prog_main, sc, f, linear, t);
    gl->Uniform1i(u.ground, 0);
    for (int m = 0; m < sc->nmeshes; m++) {
        const kf_render_mesh *me = &sc->meshes[m];
        if (me->ntris == 0) continue;
        gl->Uniform3fv(u.diffuse, 1, me->mat.diffuse);
        gl->Uniform1f(u.spec, me->mat.specular);
        gl->Uniform1f(u.rough, me->mat.roughness > 0 ? me->mat.roughness : 0.5f);
        gl->Uniform1i(u.flat, me->normals == NULL);
        kf_bind_mesh(gl, r->vbo_pos[m], r->vbo_nrm[m], me->normals != NULL, r->vbo_mot[m], me->motion != NULL,
                     r->ebo[m]);
        const int cull = cull_back_faces(me, f);
        if (cull) gl->Enable(GL_CULL_FACE); /* back faces, counter-clockwise fronts: GL's defaults */
        gl->DrawElements(GL_TRIANGLES, (GLsizei)(me->ntris * 3), GL_UNSIGNED_INT, NULL);
        if (cull) gl->Disable(GL_CULL_FACE);
    }
    if (f->draw_ground) draw_ground(r, sc, f, u, linear, t);
}

int kf_frame_read8(kf_render_ctx *r, GLuint fbo, GLuint resolve, uint8_t *out, char *err, size_t errlen) {
    kf_gl *gl = &r->gl;
    /* resolve and read back (GL rows are bottom-up) */
    GLuint src = fbo;
    if (r->draw_samples > 1) {
        gl->BindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
        gl->BindFramebuffer(GL_DRAW_FRAMEBUFFER, resolve);
        gl->BlitFramebuffer(0, 0, r->w, r->h, 0, 0, r->w, r->h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
        src = resolve;
    }
    gl->BindFramebuffer(GL_FRAMEBUFFER, src);
    gl->ReadBuffer(GL_COLOR_ATTACHMENT0);
    gl->PixelStorei(GL_PACK_ALIGNMENT, 1);
    gl->ReadPixels(0, 0, r->w, r->h, GL_RGBA, GL_UNSIGNED_BYTE, r->readback);
    gl->Finish();
    GLenum e = gl->GetError();
    if (e != GL_NO_ERROR) {
        snprintf(err, errlen, "render: GL error 0x%x while drawing the frame", e);
        return -1;
    }
    size_t row = (size_t)r->w * 4;
    for (int y = 0; y < r->h; y++) memcpy(out + (size_t)y * row, r->readback + (size_t)(r->h - 1 - y) * row, row);
    return 0;
}

int kf_render_frame(kf_render_ctx *r, const kf_render_scene *sc, const kf_camera *cam, uint8_t *rgba_out, char *err,
                    size_t errlen) {
    if (!rgba_out) {
        snprintf(err, errlen, "render: frame needs a context, a scene, a camera and an image");
        return -1;
    }
    return kf_render_frame_ex(r, sc, cam, NULL, 0, rgba_out, NULL, err, errlen);
}
