/* exr.h — OpenEXR in and out (OpenEXRCore, OpenEXR's C library).
 *
 * Writing: float planes become half-float channels of one scanline part,
 * ZIP-compressed, rows top-down (OpenEXR's y grows downwards), data window
 * = display window = the whole image, written to a temporary name, fsync'ed
 * and renamed (io/atomic_file.h). Reading gives every channel back as
 * float, whatever its stored type, so tests and tools see what a
 * compositor sees. */
#ifndef KF_EXR_H
#define KF_EXR_H

#include <stddef.h>

#define KF_EXR_MAX_CHANNELS 64

/* one channel to write: data[i * stride] is pixel i (rows top-down);
 * stride 0 means 1 */
typedef struct kf_exr_channel {
    const char *name;
    const float *data;
    int stride;
} kf_exr_channel;

/* Write nch channels of a w x h image to path with string attributes
 * kv[0]=kv[1], ... (nkv pairs) and, when not NULL, the 4x4 matrices
 * worldToCamera and worldToNDC (row-vector convention, row-major: p' = p M,
 * as the OpenEXR standard attributes are read). 0, or -1 with a message
 * ("no space left on the device" for a full disk). */
int kf_exr_write(const char *path, int w, int h, const kf_exr_channel *ch, int nch, const char *const *kv, int nkv,
                 const float *world_to_camera, const float *world_to_ndc, char *err, size_t errlen);

/* A file read back: its channels in the file's (sorted) order. */
typedef struct kf_exr_image {
    int w, h, nch;
    char name[KF_EXR_MAX_CHANNELS][64];
    int type[KF_EXR_MAX_CHANNELS];    /* stored pixel type: 0 uint, 1 half, 2 float (OpenEXR's numbering) */
    float *data[KF_EXR_MAX_CHANNELS]; /* (w*h) each, rows top-down */
    char compression[16];             /* "zip", "none", ... */
} kf_exr_image;

/* Read every channel of the first part of a scanline file. 0, or -1 with a message. */
int kf_exr_read(const char *path, kf_exr_image *img, char *err, size_t errlen);
/* the channel called name, or NULL */
const float *kf_exr_channel_data(const kf_exr_image *img, const char *name);
/* A string attribute of the first part into out ("" and -1 when absent). */
int kf_exr_read_string_attr(const char *path, const char *attr, char *out, size_t n);
void kf_exr_image_free(kf_exr_image *img);

/* 1 when path opens as an OpenEXR file whose every chunk is present
 * (a file cut short is not), else 0 */
int kf_exr_complete(const char *path);

#endif
