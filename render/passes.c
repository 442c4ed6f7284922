/* passes.c — the AOV passes and the shutter: kf_render_frame_ex.
 *
 * The picture is drawn as before (renderer.c). AOVs take extra passes on
 * targets made the first time they are asked for:
 *   - linear beauty: the picture again into a multisampled half-float
 *     target with the shaders' linear switch on, resolved in linear light;
 *   - data (Z, id, motion) and normals: one single-sample pass into two
 *     float attachments, so nothing is averaged across an edge (an id or a
 *     depth halfway between two surfaces means nothing);
 *   - mattes: four ids a pass into the multisampled float target, each a
 *     colour channel that is 1 on its meshes and 0 elsewhere (the ground
 *     and the other meshes still hide them), so the resolve gives coverage.
 *
 * Motion blur renders the picture n times over the shutter and averages
 * (an accumulation of whole renders: shadows, occlusion and the backdrop
 * behind a moving edge come out right, which a vector blur of one image
 * cannot give). n follows the fastest vertex's motion on screen so that
 * consecutive renders are at most a pixel apart. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "camera.h"
#include "internal.h"

static const char *vs_aov = "#version 330 core\n"
                            "layout(location=0) in vec3 a_pos;\n"
                            "layout(location=1) in vec3 a_nrm;\n"
                            "layout(location=2) in vec3 a_mot;\n"
                            "uniform mat4 u_viewproj, u_viewproj_next;\n"
                            "out vec3 v_wpos, v_nrm; out vec4 v_now, v_next;\n"
                            "void main() {\n"
                            "  v_wpos = a_pos; v_nrm = a_nrm;\n"
                            /* where the point is now and a frame later, both clip space: the
                             * perspective-correct interpolation of each is the projection of
                             * the interpolated point, so the divide per fragment is exact */
                            "  v_now = u_viewproj * vec4(a_pos, 1.0);\n"
                            "  v_next = u_viewproj_next * vec4(a_pos + a_mot, 1.0);\n"
                            "  gl_Position = v_now;\n"
                            "}\n";

static const char *fs_aov = "#version 330 core\n"
                            "in vec3 v_wpos, v_nrm; in vec4 v_now, v_next;\n"
                            "uniform int u_flat; uniform float u_id; uniform vec2 u_half;\n"
                            "uniform vec3 u_eye, u_fwd;\n"
                            "layout(location=0) out vec4 o_data;\n"
                            "layout(location=1) out vec4 o_nrm;\n"
                            "void main() {\n"
                            "  vec3 n;\n"
                            "  if (u_flat != 0) n = normalize(cross(dFdx(v_wpos), dFdy(v_wpos)));\n"
                            "  else { n = normalize(v_nrm); if (!gl_FrontFacing) n = -n; }\n"
                            "  float z = dot(v_wpos - u_eye, u_fwd);\n"
                            "  vec2 mv = (v_next.xy / v_next.w - v_now.xy / v_now.w) * u_half;\n"
                            "  o_data = vec4(z, u_id, mv);\n"
                            "  o_nrm = vec4(n, 1.0);\n"
                            "}\n";

static const char *vs_matte = "#version 330 core\n"
                              "layout(location=0) in vec3 a_pos;\n"
                              "uniform mat4 u_viewproj;\n"
                              "void main() { gl_Position = u_viewproj * vec4(a_pos, 1.0); }\n";

static const char *fs_matte = "#version 330 core\n"
                              "uniform vec4 u_mask; out vec4 o_col;\n"
                              "void main() { o_col = u_mask; }\n";

/* a renderbuffer of format fmt, multisampled when samples > 1, attached at `at` */
static GLuint attach(kf_gl *gl, GLenum at, GLenum fmt, int samples, int w, int h) {
    GLuint rb;
    gl->GenRenderbuffers(1, &rb);
    gl->BindRenderbuffer(GL_RENDERBUFFER, rb);
    gl->RenderbufferStorageMultisample(GL_RENDERBUFFER, samples > 1 ? samples : 0, fmt, w, h);
    gl->FramebufferRenderbuffer(GL_FRAMEBUFFER, at, GL_RENDERBUFFER, rb);
    return rb;
}

int kf_aov_setup(kf_render_ctx *r, char *err, size_t errlen) {
    if (r->aov_ready) return 0;
    kf_gl *gl = &r->gl;
    if (!r->readback_f && !(r->readback_f = malloc(sizeof(float) * 4 * (size_t)r->w * r->h))) {
        snprintf(err, errlen, "render: out of memory for a %dx%d float image", r->w, r->h);
        return -1;
    }
    if (!(r->prog_aov = kf_gl_program(gl, vs_aov, fs_aov, "aov", err, errlen)) ||
        !(r->prog_matte = kf_gl_program(gl, vs_matte, fs_matte, "matte", err, errlen)))
        return -1;
    /* the float picture and mattes: as many samples as the picture */
    gl->GenFramebuffers(1, &r->fbo_f);
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_f);
    r->rb_f_color = attach(gl, GL_COLOR_ATTACHMENT0, GL_RGBA16F, r->samples, r->w, r->h);
    r->rb_f_depth = attach(gl, GL_DEPTH_ATTACHMENT, GL_DEPTH_COMPONENT24, r->samples, r->w, r->h);
    if (kf_fbo_complete(gl, "float image", err, errlen) != 0) return -1;
    if (r->samples > 1) {
        gl->GenFramebuffers(1, &r->fbo_f_res);
        gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_f_res);
        r->rb_f_res = attach(gl, GL_COLOR_ATTACHMENT0, GL_RGBA16F, 1, r->w, r->h);
        if (kf_fbo_complete(gl, "float resolve", err, errlen) != 0) return -1;
    }
    /* the data passes: one sample, 32-bit float */
    gl->GenFramebuffers(1, &r->fbo_aov);
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_aov);
    r->rb_aov[0] = attach(gl, GL_COLOR_ATTACHMENT0, GL_RGBA32F, 1, r->w, r->h);
    r->rb_aov[1] = attach(gl, GL_COLOR_ATTACHMENT1, GL_RGBA32F, 1, r->w, r->h);
    r->rb_aov_depth = attach(gl, GL_DEPTH_ATTACHMENT, GL_DEPTH_COMPONENT24, 1, r->w, r->h);
    if (kf_fbo_complete(gl, "aov", err, errlen) != 0) return -1;
    GLenum e = gl->GetError();
    if (e != GL_NO_ERROR) {
        snprintf(err, errlen, "render: GL error 0x%x while setting up the AOV targets", e);
        return -1;
    }
    r->aov_ready = 1;
    return 0;
}

void kf_aov_destroy(kf_render_ctx *r) {
    kf_gl *gl = &r->gl;
    if (!r->aov_ready && !r->prog_aov) return;
    GLuint fb[3] = {r->fbo_f, r->fbo_f_res, r->fbo_aov};
    GLuint rb[6] = {r->rb_f_color, r->rb_f_depth, r->rb_f_res, r->rb_aov[0], r->rb_aov[1], r->rb_aov_depth};
    gl->DeleteFramebuffers(3, fb);
    gl->DeleteRenderbuffers(6, rb);
    if (r->prog_aov) gl->DeleteProgram(r->prog_aov);
    if (r->prog_matte) gl->DeleteProgram(r->prog_matte);
}

/* read attachment `at` of fbo as float RGBA, rows flipped to top-down, and
 * scatter channels [c0, c0 + nc) into out (nc floats a pixel) */
static int read_float(kf_render_ctx *r, GLuint fbo, GLenum at, int c0, int nc, float *out, char *err, size_t errlen) {
    kf_gl *gl = &r->gl;
    gl->BindFramebuffer(GL_FRAMEBUFFER, fbo);
    gl->ReadBuffer(at);
    gl->PixelStorei(GL_PACK_ALIGNMENT, 4);
    gl->ReadPixels(0, 0, r->w, r->h, GL_RGBA, GL_FLOAT, r->readback_f);
    GLenum e = gl->GetError();
    if (e != GL_NO_ERROR) {
        snprintf(err, errlen, "render: GL error 0x%x reading a float pass", e);
        return -1;
    }
    for (int y = 0; y < r->h; y++) {
        const float *src = r->readback_f + (size_t)(r->h - 1 - y) * r->w * 4;
        float *dst = out + (size_t)y * r->w * nc;
        for (int x = 0; x < r->w; x++)
            for (int c = 0; c < nc; c++) dst[(size_t)x * nc + c] = src[(size_t)x * 4 + c0 + c];
    }
    return 0;
}

/* the multisampled float target resolved (when it is multisampled) */
static GLuint float_resolved(kf_render_ctx *r) {
    if (r->samples <= 1) return r->fbo_f;
    kf_gl *gl = &r->gl;
    gl->BindFramebuffer(GL_READ_FRAMEBUFFER, r->fbo_f);
    gl->BindFramebuffer(GL_DRAW_FRAMEBUFFER, r->fbo_f_res);
    gl->BlitFramebuffer(0, 0, r->w, r->h, 0, 0, r->w, r->h, GL_COLOR_BUFFER_BIT, GL_NEAREST);
    return r->fbo_f_res;
}

/* Z, id, motion and normals: one pass, no blending, ground included (id 0) */
static int data_pass(kf_render_ctx *r, const kf_render_scene *sc, const kf_frame *f, kf_render_aovs *aov, char *err,
                     size_t errlen) {
    kf_gl *gl = &r->gl;
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_aov);
    GLenum bufs[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    gl->DrawBuffers(2, bufs);
    gl->Viewport(0, 0, r->w, r->h);
    gl->Disable(GL_MULTISAMPLE);
    gl->Enable(GL_DEPTH_TEST);
    gl->DepthFunc(GL_LESS);
    gl->DepthMask(GL_TRUE);
    const float bg_data[4] = {KF_RENDER_Z_BACKGROUND, 0, 0, 0}, bg_nrm[4] = {0, 0, 0, 0}, one = 1.0f;
    gl->ClearBufferfv(GL_COLOR, 0, bg_data);
    gl->ClearBufferfv(GL_COLOR, 1, bg_nrm);
    gl->ClearBufferfv(GL_DEPTH, 0, &one);
    GLuint p = r->prog_aov;
    gl->UseProgram(p);
    /* the view axis: the third row of the view rotation, negated */
    float fwd[3] = {-f->view[2], -f->view[6], -f->view[10]};
    gl->UniformMatrix4fv(gl->GetUniformLocation(p, "u_viewproj"), 1, GL_FALSE, f->viewproj);
    gl->UniformMatrix4fv(gl->GetUniformLocation(p, "u_viewproj_next"), 1, GL_FALSE, f->viewproj_next);
    gl->Uniform2f(gl->GetUniformLocation(p, "u_half"), 0.5f * r->w, 0.5f * r->h);
    gl->Uniform3fv(gl->GetUniformLocation(p, "u_eye"), 1, f->eye);
    gl->Uniform3fv(gl->GetUniformLocation(p, "u_fwd"), 1, fwd);
    GLint u_flat = gl->GetUniformLocation(p, "u_flat"), u_id = gl->GetUniformLocation(p, "u_id");
    for (int m = 0; m < sc->nmeshes; m++) {
        const kf_render_mesh *me = &sc->meshes[m];
        if (me->ntris == 0) continue;
        gl->Uniform1i(u_flat, me->normals == NULL);
        gl->Uniform1f(u_id, (float)me->id);
        kf_bind_mesh(gl, r->vbo_pos[m], r->vbo_nrm[m], me->normals != NULL, r->vbo_mot[m], me->motion != NULL,
                     r->ebo[m]);
        gl->DrawElements(GL_TRIANGLES, (GLsizei)(me->ntris * 3), GL_UNSIGNED_INT, NULL);
    }
    if (f->draw_ground) {
        gl->Uniform1i(u_flat, 0);
        gl->Uniform1f(u_id, 0);
        kf_bind_mesh(gl, r->ground_vbo[0], r->ground_vbo[1], 1, 0, 0, r->ground_ebo);
        gl->DrawElements(GL_TRIANGLES, 6, GL_UNSIGNED_INT, NULL);
    }
    gl->Finish();
    if (aov->z && read_float(r, r->fbo_aov, GL_COLOR_ATTACHMENT0, 0, 1, aov->z, err, errlen)) return -1;
    if (aov->id && read_float(r, r->fbo_aov, GL_COLOR_ATTACHMENT0, 1, 1, aov->id, err, errlen)) return -1;
    if (aov->motion && read_float(r, r->fbo_aov, GL_COLOR_ATTACHMENT0, 2, 2, aov->motion, err, errlen)) return -1;
    if (aov->normal && read_float(r, r->fbo_aov, GL_COLOR_ATTACHMENT1, 0, 3, aov->normal, err, errlen)) return -1;
    GLenum db = GL_COLOR_ATTACHMENT0;
    gl->DrawBuffers(1, &db);
    return 0;
}

/* coverage of each matte id, four a pass */
static int matte_passes(kf_render_ctx *r, const kf_render_scene *sc, const kf_frame *f, kf_render_aovs *aov, char *err,
                        size_t errlen) {
    kf_gl *gl = &r->gl;
    const size_t plane = (size_t)r->w * r->h;
    float *four = malloc(sizeof(float) * 4 * plane);
    if (!four) {
        snprintf(err, errlen, "render: out of memory for the mattes");
        return -1;
    }
    GLuint p = r->prog_matte;
    for (int k0 = 0; k0 < aov->nmatte; k0 += 4) {
        gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_f);
        gl->Viewport(0, 0, r->w, r->h);
        if (r->samples > 1) gl->Enable(GL_MULTISAMPLE);
        gl->Enable(GL_DEPTH_TEST);
        gl->DepthMask(GL_TRUE);
        gl->ClearColor(0, 0, 0, 0);
        gl->Clear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
        gl->UseProgram(p);
        gl->UniformMatrix4fv(gl->GetUniformLocation(p, "u_viewproj"), 1, GL_FALSE, f->viewproj);
        GLint u_mask = gl->GetUniformLocation(p, "u_mask");
        for (int m = 0; m < sc->nmeshes; m++) {
            const kf_render_mesh *me = &sc->meshes[m];
            if (me->ntris == 0) continue;
            float mask[4] = {0, 0, 0, 0};
            for (int c = 0; c < 4 && k0 + c < aov->nmatte; c++)
                mask[c] = me->id != 0 && me->id == aov->matte_ids[k0 + c];
            gl->Uniform4fv(u_mask, 1, mask);
            kf_bind_mesh(gl, r->vbo_pos[m], 0, 0, r->vbo_mot[m], 0, r->ebo[m]);
            gl->DrawElements(GL_TRIANGLES, (GLsizei)(me->ntris * 3), GL_UNSIGNED_INT, NULL);
        }
        if (f->draw_ground) {
            const float none[4] = {0, 0, 0, 0};
            gl->Uniform4fv(u_mask, 1, none);
            kf_bind_mesh(gl, r->ground_vbo[0], 0, 0, 0, 0, r->ground_ebo);
            gl->DrawElements(GL_TRIANGLES, 6, GL_UNSIGNED_INT, NULL);
        }
        if (read_float(r, float_resolved(r), GL_COLOR_ATTACHMENT0, 0, 4, four, err, errlen)) {
            free(four);
            return -1;
        }
        for (int c = 0; c < 4 && k0 + c < aov->nmatte; c++) {
            float *dst = aov->matte + (size_t)(k0 + c) * plane;
            for (size_t i = 0; i < plane; i++) dst[i] = four[4 * i + (size_t)c];
        }
    }
    free(four);
    return 0;
}

/* the fastest vertex's motion on screen over a frame, pixels */
static float max_screen_motion(const kf_render_ctx *r, const kf_render_scene *sc, const kf_frame *f) {
    float most = 0;
    for (int m = 0; m < sc->nmeshes; m++) {
        const kf_render_mesh *me = &sc->meshes[m];
        if (!me->motion) continue;
        for (size_t v = 0; v < me->nverts; v++) {
            float a[2], b[2];
            for (int k = 0; k < 2; k++) {
                const float *p = me->positions + 3 * v, *d = me->motion + 3 * v;
                const float *M = f->viewproj;
                float pa[3] = {p[0], p[1], p[2]}, pb[3] = {p[0] + d[0], p[1] + d[1], p[2] + d[2]};
                const float *q = k == 0 ? pa : pb;
                float x = M[0] * q[0] + M[4] * q[1] + M[8] * q[2] + M[12];
                float y = M[1] * q[0] + M[5] * q[1] + M[9] * q[2] + M[13];
                float w = M[3] * q[0] + M[7] * q[1] + M[11] * q[2] + M[15];
                if (!(w > 1e-6f)) x = y = 0, w = 1; /* behind the eye: not seen */
                (k == 0 ? a : b)[0] = 0.5f * r->w * x / w;
                (k == 0 ? a : b)[1] = 0.5f * r->h * y / w;
            }
            float d = hypotf(b[0] - a[0], b[1] - a[1]);
            if (d > most) most = d;
        }
    }
    return most;
}

/* the camera at t frames from cam towards cam_next (a straight line) */
static kf_camera camera_at(const kf_camera *cam, const kf_camera *next, float t) {
    kf_camera c = *cam;
    if (!next) return c;
    for (int a = 0; a < 3; a++) {
        c.eye[a] += t * (next->eye[a] - cam->eye[a]);
        c.target[a] += t * (next->target[a] - cam->target[a]);
    }
    c.fov_deg += t * (next->fov_deg - cam->fov_deg);
    return c;
}

/* row-major row-vector copy of a column-major GL matrix: the same numbers */
static void gl_to_exr(float out[16], const float m[16]) { memcpy(out, m, sizeof(float) * 16); }

int kf_render_frame_ex(kf_render_ctx *r, const kf_render_scene *sc, const kf_camera *cam, const kf_camera *cam_next,
                       float shutter, uint8_t *rgba_out, kf_render_aovs *aov, char *err, size_t errlen) {
    kf_frame f;
    if (kf_frame_begin(r, sc, cam, &f, err, errlen) != 0) return -1;
    if (aov && aov->nmatte > KF_RENDER_MAX_MATTES) {
        snprintf(err, errlen, "render: %d mattes asked, at most %d", aov->nmatte, KF_RENDER_MAX_MATTES);
        return -1;
    }
    /* how many renders the shutter takes: consecutive ones at most a pixel apart */
    int n = 1;
    if (shutter > 0) {
        float travel = shutter * max_screen_motion(r, sc, &f);
        if (cam_next) {
            /* the camera's own motion, seen at the subject's centre */
            kf_camera c1 = *cam_next;
            kf_frame g = f;
            if (kf_frame_camera(r, sc, &c1, NULL, &g, err, errlen) != 0) return -1;
            float a[4] = {0}, b[4] = {0};
            for (int i = 0; i < 4; i++) {
                a[i] = f.viewproj[i] * f.center[0] + f.viewproj[4 + i] * f.center[1] + f.viewproj[8 + i] * f.center[2] +
                       f.viewproj[12 + i];
                b[i] = g.viewproj[i] * f.center[0] + g.viewproj[4 + i] * f.center[1] + g.viewproj[8 + i] * f.center[2] +
                       g.viewproj[12 + i];
            }
            if (a[3] > 1e-6f && b[3] > 1e-6f)
                travel += shutter *
                          hypotf(0.5f * r->w * (b[0] / b[3] - a[0] / a[3]), 0.5f * r->h * (b[1] / b[3] - a[1] / a[3]));
        }
        n = (int)ceilf(travel);
        if (n < 1) n = 1;
        if (n > KF_RENDER_MAX_BLUR_SAMPLES) n = KF_RENDER_MAX_BLUR_SAMPLES;
    }
    const size_t npx = (size_t)r->w * r->h;
    uint32_t *acc8 = NULL;
    float *accf = NULL, *tmpf = NULL;
    uint8_t *tmp8 = NULL;
    int rc = -1;
    if (aov && kf_aov_setup(r, err, errlen) != 0) return -1;
    if (n > 1 && ((rgba_out && (!(acc8 = calloc(npx * 4, sizeof *acc8)) || !(tmp8 = malloc(npx * 4)))) ||
                  (aov && aov->rgba && (!(accf = calloc(npx * 4, sizeof *accf)) || !(tmpf = malloc(npx * 16)))))) {
        snprintf(err, errlen, "render: out of memory for the shutter's %d renders", n);
        goto out;
    }
    /* the picture: one render, or n over the shutter averaged */
    for (int s = 0; s < n; s++) {
        float t = n == 1 ? 0.0f : shutter * (((float)s + 0.5f) / (float)n - 0.5f);
        if (n > 1) {
            kf_camera cs = camera_at(cam, cam_next, t);
            if (kf_frame_camera(r, sc, &cs, NULL, &f, err, errlen) != 0) goto out;
        }
        kf_frame_shadow(r, sc, &f, t);
        if (rgba_out) {
            kf_frame_beauty(r, sc, &f, r->fbo_draw, 0, t);
            if (r->aa == KF_RENDER_AA_EDGES && kf_edge_aa_apply(r, sc, &f, r->fbo_draw, t, err, errlen)) goto out;
            if (kf_frame_read8(r, r->fbo_draw, r->fbo_resolve, n > 1 ? tmp8 : rgba_out, err, errlen)) goto out;
            if (n > 1)
                for (size_t i = 0; i < npx * 4; i++) acc8[i] += tmp8[i];
        }
        if (aov && aov->rgba) {
            kf_frame_beauty(r, sc, &f, r->fbo_f, 1, t);
            if (read_float(r, float_resolved(r), GL_COLOR_ATTACHMENT0, 0, 4, n > 1 ? tmpf : aov->rgba, err, errlen))
                goto out;
            if (n > 1)
                for (size_t i = 0; i < npx * 4; i++) accf[i] += tmpf[i];
        }
    }
    /* the mean, rounded to nearest: a pixel every render agrees on keeps its value */
    if (n > 1 && rgba_out)
        for (size_t i = 0; i < npx * 4; i++) rgba_out[i] = (uint8_t)((acc8[i] + (uint32_t)n / 2) / (uint32_t)n);
    if (n > 1 && aov && aov->rgba)
        for (size_t i = 0; i < npx * 4; i++) aov->rgba[i] = accf[i] / (float)n;
    if (aov) {
        /* the data passes are of the frame itself */
        if (kf_frame_camera(r, sc, cam, cam_next, &f, err, errlen) != 0) goto out;
        if ((aov->z || aov->id || aov->motion || aov->normal) && data_pass(r, sc, &f, aov, err, errlen)) goto out;
        if (aov->matte && aov->nmatte > 0 && matte_passes(r, sc, &f, aov, err, errlen)) goto out;
        if (aov->rgba)
            for (size_t i = 0; i < npx; i++) aov->rgba[4 * i + 3] = 1.0f;
        gl_to_exr(aov->world_to_camera, f.view);
        gl_to_exr(aov->world_to_ndc, f.viewproj);
        aov->blur_samples = n;
        GLenum e = r->gl.GetError();
        if (e != GL_NO_ERROR) {
            snprintf(err, errlen, "render: GL error 0x%x in the AOV passes", e);
            goto out;
        }
    }
    rc = 0;
out:
    free(acc8), free(tmp8), free(accf), free(tmpf);
    return rc;
}
