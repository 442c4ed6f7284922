/* source.h — the shot spec's words for where material comes from: the
 * source kinds (box, sphere, cylinder, closed mesh) and their placement in
 * the world. The shot loader fills them; the scene sampler
 * (scene/sample.h) and the rigid builder read them. */
#ifndef KF_SHOT_SOURCE_H
#define KF_SHOT_SOURCE_H

typedef enum kf_source_kind {
    KF_SOURCE_BOX = 0,  /* size[3]: full edge lengths, centred on the local origin */
    KF_SOURCE_SPHERE,   /* radius, centred on the local origin */
    KF_SOURCE_CYLINDER, /* radius, height: axis along local y, centred on the local origin */
    KF_SOURCE_MESH,     /* a closed mesh in its file's coordinates */
    KF_SOURCE_KIND_COUNT
} kf_source_kind;

/* Where the local shape goes: x_world = T + R (S x_local), where S = scale
 * (per axis; 0 means 1), R rotates by rotate[0] degrees about X, then
 * rotate[1] about Y, then rotate[2] about Z (fixed axes: R = Rz Ry Rx) and
 * T = translate. With fit = 1 the rotated, scaled shape is then scaled
 * uniformly so its largest bounding-box extent is fit_size, and moved so the
 * centre of its bounding box is fit_center (translate is ignored). */
typedef struct kf_placement {
    double translate[3]; /* m */
    double rotate[3];    /* degrees, XYZ order */
    double scale[3];     /* 1 (0 means 1) */
    int fit;
    double fit_center[3]; /* m */
    double fit_size;      /* m, largest extent of the world bounding box */
} kf_placement;

#endif
