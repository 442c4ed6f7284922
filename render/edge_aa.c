/* edge_aa.c — anti-aliasing by edges: the picture drawn with one sample a
 * pixel, then every edge where the colour jumps blended across.
 *
 * MSAA on llvmpipe costs per triangle, not per pixel: the 1080p frame of a
 * surfaced million-particle block (244k triangles, most under a pixel) took
 * 0.57 CPU s for its beauty pass with 4 samples against 0.25 with one. The
 * edges that need smoothing are few and known from the meshes: silhouettes
 * (between a triangle facing the eye and one facing away), open boundaries,
 * creases of flat-shaded meshes, and where a mesh passes through the ground.
 * Each is drawn as a one-pixel line over the finished picture (geometric
 * post-process anti-aliasing, as in Persson's GPAA). A line's fragment knows
 * the edge's exact position in the pixel, so it mixes the pixel with its
 * neighbour across the edge by the area the far side covers: a continuous
 * coverage where 4x MSAA has five levels.
 *
 * An edge hidden behind something is left alone: when it shows, at least one
 * of the two pixels it separates is covered by what lies behind it (the
 * background beside a silhouette, the other face of a convex crease), so the
 * deeper of the two depths is not nearer than the edge; an occluder in front
 * covers both. The picture and its depth are read from a copy, so lines that
 * share a pixel do not read each other's output. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "internal.h"

static const char *vs_edge = "#version 330 core\n"
                             "layout(location=0) in vec4 a_clip;\n"
                             "layout(location=1) in vec3 a_line;\n"
                             "flat out vec3 v_line;\n"
                             "void main() { v_line = a_line; gl_Position = a_clip; }\n";

/* v_line: the edge in window pixels, y = k x + m along x (z = 1) or
 * x = k y + m along y (z = 0). Depths compare as distances along the view
 * axis (u_p10, u_p14: the projection's third row), and something counts as
 * in front of the edge only when nearer by more than u_tol of the edge's
 * distance: four pixels' width there, so that a surface running steeply in
 * depth beside the edge (a wall's foot against the ground) does not hide it. */
static const char *fs_edge = "#version 330 core\n"
                             "flat in vec3 v_line;\n"
                             "uniform sampler2D u_col, u_depth; uniform vec2 u_size;\n"
                             "uniform float u_p10, u_p14, u_tol;\n"
                             "out vec4 o_col;\n"
                             "float dist(float d) { return u_p14 / (2.0 * d - 1.0 + u_p10); }\n"
                             "void main() {\n"
                             "  vec2 p = gl_FragCoord.xy; ivec2 ip = ivec2(p), q;\n"
                             "  float d;\n"
                             "  if (v_line.z > 0.5) { d = p.y - (v_line.x * p.x + v_line.y);\n"
                             "                        q = ip + ivec2(0, d >= 0.0 ? -1 : 1); }\n"
                             "  else { d = p.x - (v_line.x * p.y + v_line.y); q = ip + ivec2(d >= 0.0 ? -1 : 1, 0); }\n"
                             "  float w = 0.5 - abs(d);\n"
                             "  q = clamp(q, ivec2(0), ivec2(u_size) - 1);\n"
                             "  float z = max(dist(texelFetch(u_depth, ip, 0).r), dist(texelFetch(u_depth, q, 0).r));\n"
                             "  if (w <= 0.0 || z < dist(gl_FragCoord.z) * (1.0 - u_tol)) discard;\n"
                             "  o_col = mix(texelFetch(u_col, ip, 0), texelFetch(u_col, q, 0), w);\n"
                             "}\n";

/* a grown float array of edge vertices: clip position (4) and line (3) each */
typedef struct edge_buf {
    float *v;
    size_t n, cap; /* vertices */
} edge_buf;

static void clip_of(const float m[16], const float p[3], float c[4]) {
    for (int i = 0; i < 4; i++) c[i] = m[i] * p[0] + m[4 + i] * p[1] + m[8 + i] * p[2] + m[12 + i];
}

/* Append the edge a-b (world space) as a band two pixels wide around it,
 * half a pixel longer at each end: a line of one-pixel width drops the many
 * edges shorter than a pixel, a band gives every pixel the edge crosses a
 * fragment. Corners in normalised device coordinates (w = 1), so the depth
 * runs linearly along the band. Edges reaching behind the eye are left out. */
static int push_edge(edge_buf *b, const kf_render_ctx *r, const float vp[16], const float a[3], const float c[3]) {
    float ca[4], cb[4];
    clip_of(vp, a, ca);
    clip_of(vp, c, cb);
    if (!(ca[3] > 1e-6f && cb[3] > 1e-6f)) return 0;
    /* window coordinates and depth of both ends */
    float e[2][3] = {
        {(ca[0] / ca[3] * 0.5f + 0.5f) * (float)r->w, (ca[1] / ca[3] * 0.5f + 0.5f) * (float)r->h, ca[2] / ca[3]},
        {(cb[0] / cb[3] * 0.5f + 0.5f) * (float)r->w, (cb[1] / cb[3] * 0.5f + 0.5f) * (float)r->h, cb[2] / cb[3]}};
    float dx = e[1][0] - e[0][0], dy = e[1][1] - e[0][1], line[3];
    int major = fabsf(dx) >= fabsf(dy) ? 0 : 1, minor = 1 - major;
    float dm = major == 0 ? dx : dy, dn = major == 0 ? dy : dx;
    if (!(fabsf(dm) > 1e-6f)) return 0; /* a point on screen: nothing to blend */
    line[0] = dn / dm, line[1] = e[0][minor] - line[0] * e[0][major], line[2] = major == 0 ? 1.0f : 0.0f;
    if (dm < 0) {
        float t[3];
        memcpy(t, e[0], sizeof t), memcpy(e[0], e[1], sizeof t), memcpy(e[1], t, sizeof t);
    }
    float q[4][3]; /* the band's corners: start -1, start +1, end -1, end +1 across */
    for (int k = 0; k < 4; k++) {
        const float *o = e[k / 2];
        float ext = k / 2 ? 0.5f : -0.5f;
        q[k][major] = o[major] + ext;
        q[k][minor] = o[minor] + ext * line[0] + (k % 2 ? 1.0f : -1.0f);
        q[k][2] = o[2];
    }
    if (b->n + 6 > b->cap) {
        size_t cap = b->cap ? 2 * b->cap : 6144;
        float *v = realloc(b->v, cap * 7 * sizeof *v);
        if (!v) return -1;
        b->v = v, b->cap = cap;
    }
    static const int order[6] = {0, 2, 1, 1, 2, 3};
    for (int k = 0; k < 6; k++) {
        float *o = b->v + (b->n + (size_t)k) * 7;
        const float *s = q[order[k]];
        o[0] = s[0] / (float)r->w * 2 - 1, o[1] = s[1] / (float)r->h * 2 - 1, o[2] = s[2], o[3] = 1;
        memcpy(o + 4, line, sizeof line);
    }
    b->n += 6;
    return 0;
}

/* append the part of edge a-b above the ground (when it is drawn): the
 * ground hides the rest, but only by a little near where the mesh passes
 * through it, too little for the depth test of the lines */
static int push_above(edge_buf *b, const kf_render_ctx *r, const kf_frame *f, const float a[3], const float c[3]) {
    if (!f->draw_ground) return push_edge(b, r, f->viewproj, a, c);
    float da = a[1] - f->ground_y, dc = c[1] - f->ground_y;
    if (da < 0 && dc < 0) return 0;
    if (da >= 0 && dc >= 0) return push_edge(b, r, f->viewproj, a, c);
    float m[3], u = da / (da - dc);
    for (int i = 0; i < 3; i++) m[i] = a[i] + u * (c[i] - a[i]);
    return push_edge(b, r, f->viewproj, da >= 0 ? a : c, m);
}

/* the edges of one mesh that can show a jump in colour, vertices at time t */
static int mesh_edges(edge_buf *b, const kf_render_ctx *r, const kf_frame *f, const kf_render_mesh *me, float t) {
    const size_t nt = me->ntris, nv = me->nverts;
    const uint32_t *tri = me->tris;
    float *p = malloc(sizeof(float) * 3 * (nv ? nv : 1));
    float *nrm = malloc(sizeof(float) * 3 * (nt ? nt : 1)); /* unnormalised face normals */
    unsigned char *front = malloc(nt ? nt : 1);
    uint32_t *start = calloc(nv + 1, sizeof *start), *inc = malloc(sizeof(uint32_t) * 3 * (nt ? nt : 1));
    int rc = -1;
    if (!p || !nrm || !front || !start || !inc) goto out;
    for (size_t v = 0; v < nv; v++)
        for (int a = 0; a < 3; a++)
            p[3 * v + a] = me->positions[3 * v + a] + (me->motion ? t * me->motion[3 * v + a] : 0.0f);
    /* which way each triangle faces the eye (the rasteriser's front and back) */
    for (size_t k = 0; k < nt; k++) {
        const float *a = p + 3 * tri[3 * k], *c1 = p + 3 * tri[3 * k + 1], *c2 = p + 3 * tri[3 * k + 2];
        float u[3], w[3], *n = nrm + 3 * k;
        for (int i = 0; i < 3; i++) u[i] = c1[i] - a[i], w[i] = c2[i] - a[i];
        n[0] = u[1] * w[2] - u[2] * w[1], n[1] = u[2] * w[0] - u[0] * w[2], n[2] = u[0] * w[1] - u[1] * w[0];
        front[k] = n[0] * (f->eye[0] - a[0]) + n[1] * (f->eye[1] - a[1]) + n[2] * (f->eye[2] - a[2]) > 0;
    }
    /* the triangles around each vertex, to find each edge's other triangle */
    for (size_t i = 0; i < 3 * nt; i++) start[tri[i] + 1]++;
    for (size_t v = 0; v < nv; v++) start[v + 1] += start[v];
    for (size_t i = 0; i < 3 * nt; i++) inc[start[tri[i]]++] = (uint32_t)(i / 3);
    for (size_t v = nv; v > 0; v--) start[v] = start[v - 1];
    start[0] = 0;
    const int flat = me->normals == NULL;
    for (size_t k = 0; k < nt; k++)
        for (int e = 0; e < 3; e++) {
            uint32_t a = tri[3 * k + e], c = tri[3 * k + (e + 1) % 3];
            size_t other = nt;
            for (uint32_t j = start[a]; j < start[a + 1] && other == nt; j++) {
                uint32_t u = inc[j];
                if (u != k && (tri[3 * u] == c || tri[3 * u + 1] == c || tri[3 * u + 2] == c)) other = u;
            }
            /* each shared edge once, from its lower-numbered triangle */
            if (other < k) continue;
            int show = other == nt || front[other] != front[k];
            if (!show && flat) {
                /* a crease: flat shading changes colour wherever the faces turn (over ~1 degree) */
                const float *n0 = nrm + 3 * k, *n1 = nrm + 3 * other;
                double d = (double)n0[0] * n1[0] + (double)n0[1] * n1[1] + (double)n0[2] * n1[2];
                double l = sqrt(((double)n0[0] * n0[0] + (double)n0[1] * n0[1] + (double)n0[2] * n0[2]) *
                                ((double)n1[0] * n1[0] + (double)n1[1] * n1[1] + (double)n1[2] * n1[2]));
                show = d < 0.99985 * l;
            }
            if (show && push_above(b, r, f, p + 3 * a, p + 3 * c)) goto out;
        }
    /* where the mesh passes through the ground: the segment across each triangle it cuts */
    if (f->draw_ground)
        for (size_t k = 0; k < nt; k++) {
            float s[2][3];
            int ns = 0;
            for (int e = 0; e < 3 && ns < 2; e++) {
                const float *a = p + 3 * tri[3 * k + e], *c = p + 3 * tri[3 * k + (e + 1) % 3];
                float da = a[1] - f->ground_y, dc = c[1] - f->ground_y;
                if ((da < 0) == (dc < 0)) continue;
                float u = da / (da - dc);
                for (int i = 0; i < 3; i++) s[ns][i] = a[i] + u * (c[i] - a[i]);
                ns++;
            }
            if (ns == 2 && push_edge(b, r, f->viewproj, s[0], s[1])) goto out;
        }
    rc = 0;
out:
    free(p), free(nrm), free(front), free(start), free(inc);
    return rc;
}

static int edge_setup(kf_render_ctx *r, char *err, size_t errlen) {
    if (r->edge_ready) return 0;
    kf_gl *gl = &r->gl;
    if (!(r->prog_edge = kf_gl_program(gl, vs_edge, fs_edge, "edge", err, errlen))) return -1;
    /* the copy the lines read: colour and depth textures of the image's size */
    gl->GenTextures(2, r->tex_edge);
    gl->BindTexture(GL_TEXTURE_2D, r->tex_edge[0]);
    gl->TexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, r->w, r->h, 0, GL_RGBA, GL_UNSIGNED_BYTE, NULL);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl->BindTexture(GL_TEXTURE_2D, r->tex_edge[1]);
    gl->TexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT24, r->w, r->h, 0, GL_DEPTH_COMPONENT, GL_FLOAT, NULL);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_NEAREST);
    gl->TexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_NEAREST);
    gl->GenFramebuffers(1, &r->fbo_edge);
    gl->BindFramebuffer(GL_FRAMEBUFFER, r->fbo_edge);
    gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_TEXTURE_2D, r->tex_edge[0], 0);
    gl->FramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, r->tex_edge[1], 0);
    if (kf_fbo_complete(gl, "edge copy", err, errlen) != 0) return -1;
    gl->GenBuffers(1, &r->vbo_edge);
    GLenum e = gl->GetError();
    if (e != GL_NO_ERROR) {
        snprintf(err, errlen, "render: GL error 0x%x while setting up the edge anti-aliasing", e);
        return -1;
    }
    r->edge_ready = 1;
    return 0;
}

void kf_edge_aa_destroy(kf_render_ctx *r) {
    if (!r->edge_ready && !r->prog_edge) return;
    kf_gl *gl = &r->gl;
    gl->DeleteFramebuffers(1, &r->fbo_edge);
    gl->DeleteTextures(2, r->tex_edge);
    gl->DeleteBuffers(1, &r->vbo_edge);
    if (r->prog_edge) gl->DeleteProgram(r->prog_edge);
}

int kf_edge_aa_apply(kf_render_ctx *r, const kf_render_scene *sc, const kf_frame *f, GLuint fbo, float t, char *err,
                     size_t errlen) {
    if (edge_setup(r, err, errlen) != 0) return -1;
    edge_buf b = {0};
    for (int m = 0; m < sc->nmeshes; m++)
        if (sc->meshes[m].ntris > 0 && mesh_edges(&b, r, f, &sc->meshes[m], t) != 0) {
            free(b.v);
            snprintf(err, errlen, "render: out of memory for the edges of mesh %d", m);
            return -1;
        }
    if (b.n == 0) return 0;
    kf_gl *gl = &r->gl;
    /* the finished picture and its depth, copied for the lines to read */
    gl->BindFramebuffer(GL_READ_FRAMEBUFFER, fbo);
    gl->BindFramebuffer(GL_DRAW_FRAMEBUFFER, r->fbo_edge);
    gl->BlitFramebuffer(0, 0, r->w, r->h, 0, 0, r->w, r->h, GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT, GL_NEAREST);
    gl->BindFramebuffer(GL_FRAMEBUFFER, fbo);
    gl->Viewport(0, 0, r->w, r->h);
    gl->Disable(GL_DEPTH_TEST);
    gl->DepthMask(GL_FALSE);
    gl->UseProgram(r->prog_edge);
    gl->ActiveTexture(GL_TEXTURE1);
    gl->BindTexture(GL_TEXTURE_2D, r->tex_edge[0]);
    gl->ActiveTexture(GL_TEXTURE2);
    gl->BindTexture(GL_TEXTURE_2D, r->tex_edge[1]);
    gl->ActiveTexture(GL_TEXTURE0);
    gl->Uniform1i(gl->GetUniformLocation(r->prog_edge, "u_col"), 1);
    gl->Uniform1i(gl->GetUniformLocation(r->prog_edge, "u_depth"), 2);
    gl->Uniform2f(gl->GetUniformLocation(r->prog_edge, "u_size"), (float)r->w, (float)r->h);
    /* proj[5] is cot(fov / 2): a pixel spans 2 / (proj[5] h) of the distance */
    gl->Uniform1f(gl->GetUniformLocation(r->prog_edge, "u_p10"), f->proj[10]);
    gl->Uniform1f(gl->GetUniformLocation(r->prog_edge, "u_p14"), f->proj[14]);
    gl->Uniform1f(gl->GetUniformLocation(r->prog_edge, "u_tol"), 8.0f / (f->proj[5] * (float)r->h));
    gl->BindBuffer(GL_ARRAY_BUFFER, r->vbo_edge);
    gl->BufferData(GL_ARRAY_BUFFER, (GLsizeiptr)(b.n * 7 * sizeof(float)), b.v, GL_STREAM_DRAW);
    gl->VertexAttribPointer(0, 4, GL_FLOAT, GL_FALSE, 7 * sizeof(float), NULL);
    gl->EnableVertexAttribArray(0);
    gl->VertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 7 * sizeof(float), (const void *)(4 * sizeof(float)));
    gl->EnableVertexAttribArray(1);
    gl->DisableVertexAttribArray(2);
    gl->DrawArrays(GL_TRIANGLES, 0, (GLsizei)b.n);
    gl->Enable(GL_DEPTH_TEST);
    gl->DepthMask(GL_TRUE);
    free(b.v);
    return 0;
}
