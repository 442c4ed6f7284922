/* png_read.c — PNG to RGBA8 (top-down) plus its text chunks; for tests, goldens and tools. */
#include <errno.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render.h"

typedef struct png_rd_err {
    char msg[256];
} png_rd_err;

static void on_error(png_structp png, png_const_charp msg) {
    png_rd_err *e = png_get_error_ptr(png);
    if (e) snprintf(e->msg, sizeof e->msg, "%s", msg);
    png_longjmp(png, 1);
}
static void on_warning(png_structp png, png_const_charp msg) { (void)png, (void)msg; }

void kf_png_free_texts(char **texts, int ntexts) {
    if (!texts) return;
    for (int i = 0; i < 2 * ntexts; i++) free(texts[i]);
    free(texts);
}

int kf_png_read(const char *path, uint8_t **rgba, int *w, int *h, char ***texts, int *ntexts, char *err,
                size_t errlen) {
    *rgba = NULL;
    *w = *h = 0;
    if (texts) *texts = NULL;
    if (ntexts) *ntexts = 0;
    FILE *f = fopen(path, "rb");
    if (!f) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        return -1;
    }
    unsigned char sig[8];
    if (fread(sig, 1, 8, f) != 8 || png_sig_cmp(sig, 0, 8) != 0) {
        snprintf(err, errlen, "%s: not a PNG file", path);
        fclose(f);
        return -1;
    }
    png_rd_err ectx = {""};
    png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, &ectx, on_error, on_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    if (!png || !info) {
        png_destroy_read_struct(&png, NULL, NULL);
        fclose(f);
        snprintf(err, errlen, "%s: out of memory in libpng", path);
        return -1;
    }
    uint8_t *volatile pix = NULL;
    png_bytep *volatile rows = NULL;
    char **volatile tx = NULL;
    volatile int ntx = 0;
    if (setjmp(png_jmpbuf(png))) {
        png_destroy_read_struct(&png, &info, NULL);
        fclose(f);
        free(pix);
        free(rows);
        kf_png_free_texts(tx, ntx);
        snprintf(err, errlen, "%s: libpng: %s", path, ectx.msg);
        return -1;
    }
    png_init_io(png, f);
    png_set_sig_bytes(png, 8);
    png_read_info(png, info);
    png_uint_32 pw = png_get_image_width(png, info), ph = png_get_image_height(png, info);
    int ct = png_get_color_type(png, info), bd = png_get_bit_depth(png, info);
    /* normalise to 8-bit RGBA */
    if (bd == 16) png_set_strip_16(png);
    if (ct == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
    if (ct == PNG_COLOR_TYPE_GRAY && bd < 8) png_set_expand_gray_1_2_4_to_8(png);
    if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
    if (ct == PNG_COLOR_TYPE_GRAY || ct == PNG_COLOR_TYPE_GRAY_ALPHA) png_set_gray_to_rgb(png);
    if (!(ct & PNG_COLOR_MASK_ALPHA) && !png_get_valid(png, info, PNG_INFO_tRNS))
        png_set_filler(png, 0xff, PNG_FILLER_AFTER);
    png_read_update_info(png, info);
    pix = malloc((size_t)pw * ph * 4);
    rows = malloc((size_t)ph * sizeof *rows);
    if (!pix || !rows) png_error(png, "out of memory for the image");
    for (png_uint_32 y = 0; y < ph; y++) rows[y] = pix + (size_t)y * pw * 4;
    png_read_image(png, rows);
    png_read_end(png, info);
    if (texts) {
        png_textp t = NULL;
        int n = 0;
        png_get_text(png, info, &t, &n);
        if (n > 0) {
            tx = calloc((size_t)2 * n, sizeof(char *));
            if (!tx) png_error(png, "out of memory for text chunks");
            ntx = n;
            for (int i = 0; i < n; i++) {
                tx[2 * i] = strdup(t[i].key);
                tx[2 * i + 1] = strdup(t[i].text ? t[i].text : "");
                if (!tx[2 * i] || !tx[2 * i + 1]) png_error(png, "out of memory for text");
            }
        }
    }
    png_destroy_read_struct(&png, &info, NULL);
    fclose(f);
    free(rows);
    *rgba = pix;
    *w = (int)pw;
    *h = (int)ph;
    if (texts) *texts = tx, *ntexts = ntx;
    return 0;
}
