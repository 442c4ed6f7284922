/* camera.c — camera framing, turntables and the matrices behind them. */
#include "camera.h"

#include <math.h>
#include <string.h>

#include "render.h"

static const double kf_pi = 3.14159265358979323846;

static void v3_sub(float r[3], const float a[3], const float b[3]) {
    for (int i = 0; i < 3; i++) r[i] = a[i] - b[i];
}
static float v3_dot(const float a[3], const float b[3]) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
static void v3_cross(float r[3], const float a[3], const float b[3]) {
    float x = a[1] * b[2] - a[2] * b[1], y = a[2] * b[0] - a[0] * b[2], z = a[0] * b[1] - a[1] * b[0];
    r[0] = x, r[1] = y, r[2] = z;
}
static float v3_normalize(float v[3]) {
    float l = sqrtf(v3_dot(v, v));
    if (l > 0) v[0] /= l, v[1] /= l, v[2] /= l;
    return l;
}

/* ---- matrices ------------------------------------------------------------ */

void kf_m4_mul(float m[16], const float a[16], const float b[16]) {
    float r[16];
    for (int c = 0; c < 4; c++)
        for (int row = 0; row < 4; row++) {
            float s = 0;
            for (int k = 0; k < 4; k++) s += a[k * 4 + row] * b[c * 4 + k];
            r[c * 4 + row] = s;
        }
    for (int i = 0; i < 16; i++) m[i] = r[i];
}

int kf_m4_look_at(float m[16], const float eye[3], const float target[3], const float up[3]) {
    float f[3], s[3], u[3];
    v3_sub(f, target, eye);
    if (v3_normalize(f) == 0) return -1;
    v3_cross(s, f, up);
    if (v3_normalize(s) < 1e-6f) return -1;
    v3_cross(u, s, f);
    float r[16] = {
        s[0],           u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0, -v3_dot(s, eye), -v3_dot(u, eye),
        v3_dot(f, eye), 1};
    for (int i = 0; i < 16; i++) m[i] = r[i];
    return 0;
}

void kf_m4_perspective(float m[16], float fovy_deg, float aspect, float n, float f) {
    float t = 1.0f / tanf((float)(fovy_deg * kf_pi / 360.0));
    for (int i = 0; i < 16; i++) m[i] = 0;
    m[0] = t / aspect;
    m[5] = t;
    m[10] = (f + n) / (n - f);
    m[11] = -1;
    m[14] = 2 * f * n / (n - f);
}

void kf_m4_ortho(float m[16], float l, float r, float b, float t, float n, float f) {
    for (int i = 0; i < 16; i++) m[i] = 0;
    m[0] = 2 / (r - l);
    m[5] = 2 / (t - b);
    m[10] = -2 / (f - n);
    m[12] = -(r + l) / (r - l);
    m[13] = -(t + b) / (t - b);
    m[14] = -(f + n) / (f - n);
    m[15] = 1;
}

/* ---- framing ------------------------------------------------------------- */

/* distance at which a sphere of radius rad fills the vertical fov, plus a margin */
static float frame_distance(float rad, float fov_deg) {
    if (!(fov_deg > 1 && fov_deg < 179)) fov_deg = 35;
    double half = fov_deg * kf_pi / 360.0;
    return (float)(1.08 * rad / sin(half));
}

kf_camera kf_camera_frame_bounds(const float lo[3], const float hi[3], const float view_dir[3], float fov_deg) {
    kf_camera c;
    memset(&c, 0, sizeof c);
    float d[3] = {view_dir[0], view_dir[1], view_dir[2]};
    if (v3_normalize(d) == 0) d[0] = 0, d[1] = 0, d[2] = -1;
    float half[3], rad;
    for (int i = 0; i < 3; i++) {
        c.target[i] = 0.5f * (lo[i] + hi[i]);
        half[i] = 0.5f * (hi[i] - lo[i]);
    }
    rad = sqrtf(v3_dot(half, half));
    if (!(rad > 0)) rad = 0.5f;
    float dist = frame_distance(rad, fov_deg);
    for (int i = 0; i < 3; i++) c.eye[i] = c.target[i] - d[i] * dist;
    /* +Y up unless looking (nearly) straight down or up */
    if (fabsf(d[1]) > 0.999f) c.up[2] = d[1] < 0 ? -1.0f : 1.0f;
    else c.up[1] = 1;
    c.fov_deg = (fov_deg > 1 && fov_deg < 179) ? fov_deg : 35;
    return c;
}

kf_camera kf_camera_turntable(const float lo[3], const float hi[3], int k, int N, float elevation_deg, float fov_deg) {
    if (N <= 0) N = 1;
    /* end exclusive: reduce k first so frame N is bit-identical to frame 0 */
    int km = k % N;
    if (km < 0) km += N;
    double a = 2.0 * kf_pi * km / N, e = elevation_deg * kf_pi / 180.0;
    /* eye direction from the centre; frame 0 sits on +Z */
    float out[3] = {(float)(sin(a) * cos(e)), (float)sin(e), (float)(cos(a) * cos(e))};
    float view[3] = {-out[0], -out[1], -out[2]};
    return kf_camera_frame_bounds(lo, hi, view, fov_deg);
}

/* ---- keys ------------------------------------------------------------------ */

/* channel ch of a key: 0-2 eye, 3-5 target, 6 fov */
static double cam_channel(const kf_camera_key *k, int ch) {
    return ch < 3 ? k->eye[ch] : ch < 6 ? k->target[ch - 3] : k->fov_deg;
}

/* Hermite tangent at key i (per frame): central difference over the
 * neighbouring keys, zero at the ends (the motion eases in and out) */
static double cam_tangent(const kf_camera_key *k, int n, int i, int ch) {
    if (i <= 0 || i >= n - 1) return 0;
    return (cam_channel(&k[i + 1], ch) - cam_channel(&k[i - 1], ch)) / (k[i + 1].frame - k[i - 1].frame);
}

kf_camera kf_camera_keyed(const kf_camera_key *k, int n, double frame, int smooth) {
    kf_camera c;
    memset(&c, 0, sizeof c);
    c.up[1] = 1;
    c.fov_deg = 35;
    if (n <= 0) return c;
    double val[7];
    if (n == 1 || frame <= k[0].frame || frame >= k[n - 1].frame) {
        const kf_camera_key *e = (n == 1 || frame <= k[0].frame) ? &k[0] : &k[n - 1];
        for (int ch = 0; ch < 7; ch++) val[ch] = cam_channel(e, ch);
    } else {
        int i = 0;
        while (i + 2 < n && frame >= k[i + 1].frame) i++;
        const double h = k[i + 1].frame - k[i].frame, u = (frame - k[i].frame) / h;
        for (int ch = 0; ch < 7; ch++) {
            double p0 = cam_channel(&k[i], ch), p1 = cam_channel(&k[i + 1], ch);
            if (smooth) {
                double m0 = cam_tangent(k, n, i, ch) * h, m1 = cam_tangent(k, n, i + 1, ch) * h;
                double u2 = u * u, u3 = u2 * u;
                val[ch] =
                    (2 * u3 - 3 * u2 + 1) * p0 + (u3 - 2 * u2 + u) * m0 + (-2 * u3 + 3 * u2) * p1 + (u3 - u2) * m1;
            } else {
                val[ch] = p0 + u * (p1 - p0);
            }
        }
    }
    for (int a = 0; a < 3; a++) c.eye[a] = (float)val[a], c.target[a] = (float)val[3 + a];
    c.fov_deg = (float)(val[6] > 1 && val[6] < 179 ? val[6] : 35);
    return c;
}
