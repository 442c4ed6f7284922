/* camera.h — internal 4x4 matrix helpers (column-major, as GL takes them). */
#ifndef KF_RENDER_CAMERA_H
#define KF_RENDER_CAMERA_H

/* m = a * b */
void kf_m4_mul(float m[16], const float a[16], const float b[16]);
/* world -> eye, right-handed, looking down -Z. Returns -1 when eye == target
 * or up is parallel to the view direction. */
int kf_m4_look_at(float m[16], const float eye[3], const float target[3], const float up[3]);
void kf_m4_perspective(float m[16], float fovy_deg, float aspect, float znear, float zfar);
void kf_m4_ortho(float m[16], float l, float r, float b, float t, float n, float f);

#endif
