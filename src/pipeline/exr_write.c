/* exr_write.c — float planes to a half-float scanline OpenEXR, through
 * OpenEXRCore (OpenEXR's C library), atomically.
 *
 * The library writes through our own write callback into the temporary
 * file of kf_atomic_file (pwrite at the offsets it asks for), so the file
 * is fsync'ed and renamed over its final name like every other output.
 * Pixels are converted to half here (Imath's C conversion, round to
 * nearest even) and handed to the encoder as half: its own conversions
 * are not relied on. ZIP compression (16 scanlines a chunk): lossless,
 * what compositors read fastest after no compression at all. */
#include <errno.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include <Imath/half.h>
#include <openexr.h>

#include "../io/atomic_file.h"
#include "exr.h"

/* the write callback's state: the temporary file and the first error */
typedef struct sink {
    int fd;
    int err; /* errno of the first failed write */
} sink;

static int64_t sink_write(exr_const_context_t ctxt, void *user, const void *buf, uint64_t sz, uint64_t offset,
                          exr_stream_error_func_ptr_t error_cb) {
    (void)ctxt, (void)error_cb;
    sink *s = user;
    const char *p = buf;
    uint64_t done = 0;
    while (done < sz) {
        ssize_t n = pwrite(s->fd, p + done, sz - done, (off_t)(offset + done));
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            if (!s->err) s->err = n < 0 ? errno : EIO;
            return -1;
        }
        done += (uint64_t)n;
    }
    return (int64_t)sz;
}

/* the library's messages go to the caller's buffer, not to stderr */
typedef struct msgbuf {
    char text[512];
} msgbuf;
static _Thread_local msgbuf last_msg;

static void on_error(exr_const_context_t ctxt, exr_result_t code, const char *msg) {
    (void)ctxt;
    snprintf(last_msg.text, sizeof last_msg.text, "%s (%s)", msg ? msg : "", exr_get_error_code_as_string(code));
}

static int fail(char *err, size_t errlen, const char *path, const char *what, exr_result_t rc) {
    snprintf(err, errlen, "%s: exr: %s: %s", path, what,
             last_msg.text[0] ? last_msg.text : exr_get_default_error_message(rc));
    return -1;
}

int kf_exr_write(const char *path, int w, int h, const kf_exr_channel *ch, int nch, const char *const *kv, int nkv,
                 const float *world_to_camera, const float *world_to_ndc, char *err, size_t errlen) {
    if (w <= 0 || h <= 0 || nch <= 0 || nch > KF_EXR_MAX_CHANNELS) {
        snprintf(err, errlen, "%s: exr: bad image (%dx%d, %d channels)", path, w, h, nch);
        return -1;
    }
    /* every channel as half, one plane each: the encoder reads planes */
    uint16_t *half = malloc(sizeof *half * (size_t)w * h * (size_t)nch);
    if (!half) {
        snprintf(err, errlen, "%s: exr: out of memory for %dx%d x %d channels", path, w, h, nch);
        return -1;
    }
    for (int c = 0; c < nch; c++) {
        uint16_t *dst = half + (size_t)c * w * h;
        const int stride = ch[c].stride > 0 ? ch[c].stride : 1;
        for (size_t i = 0; i < (size_t)w * h; i++) dst[i] = imath_float_to_half(ch[c].data[i * (size_t)stride]);
    }
    kf_atomic_file af;
    if (kf_atomic_open(&af, path) != 0) {
        snprintf(err, errlen, "%s: cannot write: %s", path, kf_io_reason(errno));
        free(half);
        return -1;
    }
    sink s = {fileno(af.f), 0};
    last_msg.text[0] = 0;
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = on_error;
    init.user_data = &s;
    init.write_fn = sink_write;
    exr_context_t ctx = NULL;
    int part = 0, rc = -1;
    exr_result_t e = exr_start_write(&ctx, path, EXR_WRITE_FILE_DIRECTLY, &init);
    if (e != EXR_ERR_SUCCESS) {
        fail(err, errlen, path, "cannot start", e);
        kf_atomic_abort(&af);
        free(half);
        return -1;
    }
    exr_encode_pipeline_t enc;
    int have_enc = 0;
    const char *what = "header";
    if ((e = exr_add_part(ctx, "rgba", EXR_STORAGE_SCANLINE, &part)) != EXR_ERR_SUCCESS ||
        (e = exr_initialize_required_attr_simple(ctx, part, w, h, EXR_COMPRESSION_ZIP)) != EXR_ERR_SUCCESS)
        goto out;
    /* colour channels are treated as logarithmic by lossy codecs, data as linear */
    for (int c = 0; c < nch; c++) {
        const char *n = ch[c].name;
        int colour = !strcmp(n, "R") || !strcmp(n, "G") || !strcmp(n, "B");
        if ((e = exr_add_channel(ctx, part, n, EXR_PIXEL_HALF,
                                 colour ? EXR_PERCEPTUALLY_LOGARITHMIC : EXR_PERCEPTUALLY_LINEAR, 1, 1)) !=
            EXR_ERR_SUCCESS)
            goto out;
    }
    for (int k = 0; k < nkv; k++)
        if ((e = exr_attr_set_string(ctx, part, kv[2 * k], kv[2 * k + 1])) != EXR_ERR_SUCCESS) goto out;
    /* the camera, as Nuke's and Houdini's readers take it (row vectors, the
     * OpenEXR convention: p' = p M) */
    if (world_to_camera) {
        exr_attr_m44f_t m;
        memcpy(m.m, world_to_camera, sizeof m.m);
        if ((e = exr_attr_set_m44f(ctx, part, "worldToCamera", &m)) != EXR_ERR_SUCCESS) goto out;
    }
    if (world_to_ndc) {
        exr_attr_m44f_t m;
        memcpy(m.m, world_to_ndc, sizeof m.m);
        if ((e = exr_attr_set_m44f(ctx, part, "worldToNDC", &m)) != EXR_ERR_SUCCESS) goto out;
    }
    if ((e = exr_write_header(ctx)) != EXR_ERR_SUCCESS) goto out;
    what = "pixels";
    int32_t lines = 1;
    if ((e = exr_get_scanlines_per_chunk(ctx, part, &lines)) != EXR_ERR_SUCCESS) goto out;
    for (int y = 0; y < h; y += lines) {
        exr_chunk_info_t cinfo;
        if ((e = exr_write_scanline_chunk_info(ctx, part, y, &cinfo)) != EXR_ERR_SUCCESS) goto out;
        e = have_enc ? exr_encoding_update(ctx, part, &cinfo, &enc) : exr_encoding_initialize(ctx, part, &cinfo, &enc);
        if (e != EXR_ERR_SUCCESS) goto out;
        /* the encoder lists channels sorted by name: find each one's plane */
        for (int16_t c = 0; c < enc.channel_count; c++) {
            exr_coding_channel_info_t *ci = &enc.channels[c];
            int k = 0;
            while (k < nch && strcmp(ch[k].name, ci->channel_name) != 0) k++;
            ci->user_pixel_stride = 2;
            ci->user_line_stride = 2 * w;
            ci->user_bytes_per_element = 2;
            ci->user_data_type = EXR_PIXEL_HALF;
            ci->encode_from_ptr = (const uint8_t *)(half + (size_t)k * w * h + (size_t)y * w);
        }
        if (!have_enc && (e = exr_encoding_choose_default_routines(ctx, part, &enc)) != EXR_ERR_SUCCESS) goto out;
        have_enc = 1;
        if ((e = exr_encoding_run(ctx, part, &enc)) != EXR_ERR_SUCCESS) goto out;
    }
    what = "finishing";
    rc = 0;
out:
    if (have_enc) exr_encoding_destroy(ctx, &enc);
    exr_result_t fe = exr_finish(&ctx);
    if (rc == 0 && fe != EXR_ERR_SUCCESS) e = fe, rc = -1;
    free(half);
    if (rc != 0) {
        if (s.err) snprintf(err, errlen, "%s: cannot write: %s", path, kf_io_reason(s.err));
        else fail(err, errlen, path, what, e);
        kf_atomic_abort(&af);
        return -1;
    }
    if (kf_atomic_commit(&af) != 0) {
        snprintf(err, errlen, "%s: cannot write: %s", path, kf_io_reason(errno));
        return -1;
    }
    return 0;
}
