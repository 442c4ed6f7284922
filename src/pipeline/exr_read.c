/* exr_read.c — an OpenEXR scanline file back into float planes (exr.h).
 *
 * Each chunk is decoded into the channel's stored type (the decoder's own
 * unpack, no conversion asked of it) and converted to float here: half
 * with Imath's C conversion, uint as an exact integer. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <Imath/half.h>
#include <openexr.h>

#include "exr.h"

/* silence the library's stderr printing; the result code carries the failure */
static void quiet(exr_const_context_t ctxt, exr_result_t code, const char *msg) { (void)ctxt, (void)code, (void)msg; }

static int open_read(const char *path, exr_context_t *ctx) {
    exr_context_initializer_t init = EXR_DEFAULT_CONTEXT_INITIALIZER;
    init.error_handler_fn = quiet;
    return exr_start_read(ctx, path, &init) == EXR_ERR_SUCCESS ? 0 : -1;
}

void kf_exr_image_free(kf_exr_image *img) {
    for (int c = 0; c < img->nch; c++) free(img->data[c]);
    memset(img, 0, sizeof *img);
}

const float *kf_exr_channel_data(const kf_exr_image *img, const char *name) {
    for (int c = 0; c < img->nch; c++)
        if (!strcmp(img->name[c], name)) return img->data[c];
    return NULL;
}

/* decode every chunk of part 0 into raw planes (stored type, 4 bytes a
 * sample so any type fits), then convert; also the completeness probe */
static int decode_all(exr_context_t ctx, kf_exr_image *img, char *err, size_t errlen) {
    exr_attr_box2i_t dw;
    const exr_attr_chlist_t *cl;
    exr_storage_t st;
    if (exr_get_storage(ctx, 0, &st) || st != EXR_STORAGE_SCANLINE || exr_get_data_window(ctx, 0, &dw) ||
        exr_get_channels(ctx, 0, &cl)) {
        snprintf(err, errlen, "not a scanline image");
        return -1;
    }
    img->w = dw.max.x - dw.min.x + 1, img->h = dw.max.y - dw.min.y + 1;
    if (img->w <= 0 || img->h <= 0 || cl->num_channels > KF_EXR_MAX_CHANNELS) {
        snprintf(err, errlen, "image of %dx%d with %d channels", img->w, img->h, cl->num_channels);
        return -1;
    }
    const size_t npx = (size_t)img->w * img->h;
    uint32_t *raw[KF_EXR_MAX_CHANNELS] = {0};
    int rc = -1;
    img->nch = cl->num_channels;
    for (int c = 0; c < img->nch; c++) {
        snprintf(img->name[c], sizeof img->name[c], "%s", cl->entries[c].name.str);
        img->type[c] = (int)cl->entries[c].pixel_type;
        if (!(img->data[c] = malloc(npx * sizeof(float))) || !(raw[c] = calloc(npx, 4))) {
            snprintf(err, errlen, "out of memory");
            goto out;
        }
    }
    int32_t lines = 1;
    exr_get_scanlines_per_chunk(ctx, 0, &lines);
    exr_decode_pipeline_t dec;
    int have = 0;
    for (int y = dw.min.y; y <= dw.max.y; y += lines) {
        exr_chunk_info_t ci;
        exr_result_t e = exr_read_scanline_chunk_info(ctx, 0, y, &ci);
        if (e == EXR_ERR_SUCCESS)
            e = have ? exr_decoding_update(ctx, 0, &ci, &dec) : exr_decoding_initialize(ctx, 0, &ci, &dec);
        if (e != EXR_ERR_SUCCESS) {
            snprintf(err, errlen, "chunk at line %d: %s", y, exr_get_default_error_message(e));
            if (have) exr_decoding_destroy(ctx, &dec);
            goto out;
        }
        for (int16_t c = 0; c < dec.channel_count; c++) {
            exr_coding_channel_info_t *ch = &dec.channels[c];
            int k = 0;
            while (k < img->nch && strcmp(img->name[k], ch->channel_name) != 0) k++;
            ch->user_bytes_per_element = ch->bytes_per_element;
            ch->user_data_type = ch->data_type;
            ch->user_pixel_stride = ch->bytes_per_element;
            ch->user_line_stride = ch->bytes_per_element * img->w;
            ch->decode_to_ptr = (uint8_t *)raw[k] + (size_t)(y - dw.min.y) * img->w * (size_t)ch->bytes_per_element;
        }
        if (!have && (e = exr_decoding_choose_default_routines(ctx, 0, &dec)) != EXR_ERR_SUCCESS) {
            snprintf(err, errlen, "no decoder: %s", exr_get_default_error_message(e));
            exr_decoding_destroy(ctx, &dec);
            goto out;
        }
        have = 1;
        if ((e = exr_decoding_run(ctx, 0, &dec)) != EXR_ERR_SUCCESS) {
            snprintf(err, errlen, "chunk at line %d: %s", y, exr_get_default_error_message(e));
            exr_decoding_destroy(ctx, &dec);
            goto out;
        }
    }
    if (have) exr_decoding_destroy(ctx, &dec);
    /* stored type -> float: each plane was filled packed at its own element size */
    for (int c = 0; c < img->nch; c++) {
        const uint16_t *h16 = (const uint16_t *)raw[c];
        const float *f32 = (const float *)raw[c];
        for (size_t i = 0; i < npx; i++)
            img->data[c][i] = img->type[c] == EXR_PIXEL_HALF    ? imath_half_to_float(h16[i])
                              : img->type[c] == EXR_PIXEL_FLOAT ? f32[i]
                                                                : (float)raw[c][i];
    }
    rc = 0;
out:
    for (int c = 0; c < KF_EXR_MAX_CHANNELS; c++) free(raw[c]);
    return rc;
}

int kf_exr_read(const char *path, kf_exr_image *img, char *err, size_t errlen) {
    memset(img, 0, sizeof *img);
    exr_context_t ctx = NULL;
    if (open_read(path, &ctx) != 0) {
        snprintf(err, errlen, "%s: not a readable OpenEXR file", path);
        return -1;
    }
    static const char *const comp[] = {"none", "rle", "zips", "zip", "piz", "pxr24", "b44", "b44a", "dwaa", "dwab"};
    exr_compression_t cz = EXR_COMPRESSION_NONE;
    exr_get_compression(ctx, 0, &cz);
    snprintf(img->compression, sizeof img->compression, "%s",
             (int)cz >= 0 && (int)cz < (int)(sizeof comp / sizeof *comp) ? comp[cz] : "?");
    char why[256];
    int rc = decode_all(ctx, img, why, sizeof why);
    exr_finish(&ctx);
    if (rc) {
        snprintf(err, errlen, "%s: %s", path, why);
        kf_exr_image_free(img);
    }
    return rc;
}

int kf_exr_read_string_attr(const char *path, const char *attr, char *out, size_t n) {
    out[0] = 0;
    exr_context_t ctx = NULL;
    if (open_read(path, &ctx) != 0) return -1;
    int32_t len = 0;
    const char *s = NULL;
    int rc = exr_attr_get_string(ctx, 0, attr, &len, &s) == EXR_ERR_SUCCESS && s ? 0 : -1;
    if (rc == 0) snprintf(out, n, "%.*s", (int)len, s);
    exr_finish(&ctx);
    return rc;
}

/* Whole without decoding: the header parses, and every chunk of the
 * offset table lies inside the file (a file cut short loses its last
 * chunks; the table comes first). Cheap enough to ask of every frame when
 * deciding what to render again. */
int kf_exr_complete(const char *path) {
    struct stat st;
    exr_context_t ctx = NULL;
    if (stat(path, &st) != 0 || open_read(path, &ctx) != 0) return 0;
    exr_attr_box2i_t dw;
    int32_t lines = 1;
    int ok = exr_get_data_window(ctx, 0, &dw) == EXR_ERR_SUCCESS &&
             exr_get_scanlines_per_chunk(ctx, 0, &lines) == EXR_ERR_SUCCESS && lines > 0;
    for (int y = dw.min.y; ok && y <= dw.max.y; y += lines) {
        exr_chunk_info_t ci;
        ok = exr_read_scanline_chunk_info(ctx, 0, y, &ci) == EXR_ERR_SUCCESS &&
             ci.data_offset + ci.packed_size <= (uint64_t)st.st_size;
    }
    exr_finish(&ctx);
    return ok;
}
