/* png_write.c — RGBA8 to PNG with text chunks, written atomically.
 *
 * The image goes to "<path>.tmp-<pid>" in the same directory, is fsync'ed,
 * renamed over path, and the directory is fsync'ed: a crash leaves either
 * the previous file or the complete new one, never a torn frame. */
#include <errno.h>
#include <fcntl.h>
#include <png.h>
#include <setjmp.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#include "render.h"

typedef struct png_err_ctx {
    char msg[256];
} png_err_ctx;

static void on_png_error(png_structp png, png_const_charp msg) {
    png_err_ctx *e = png_get_error_ptr(png);
    if (e) snprintf(e->msg, sizeof e->msg, "%s", msg);
    png_longjmp(png, 1);
}
static void on_png_warning(png_structp png, png_const_charp msg) { (void)png, (void)msg; }

/* an errno as an artist reads it: a full disk says so */
static const char *io_reason(int e) {
    return e == ENOSPC || e == EDQUOT ? "no space left on the device (disk full)" : strerror(e);
}

static int key_ok(const char *k) {
    size_t n = strlen(k);
    if (n < 1 || n > 79 || k[0] == ' ' || k[n - 1] == ' ') return 0;
    for (size_t i = 0; i < n; i++) {
        unsigned char c = (unsigned char)k[i];
        if (c < 32 || (c > 126 && c < 161)) return 0;
    }
    return 1;
}
static int ascii(const char *s) {
    for (; *s; s++)
        if ((unsigned char)*s > 126) return 0;
    return 1;
}

/* write the PNG stream to an open FILE; -1 + err on failure */
static int write_stream(FILE *f, const uint8_t *rgba, int w, int h, const char *const *kv, int nkv, char *err,
                        size_t errlen) {
    png_err_ctx ectx = {""};
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &ectx, on_png_error, on_png_warning);
    png_infop info = png ? png_create_info_struct(png) : NULL;
    png_textp texts = NULL;
    png_bytep *rows = NULL;
    if (!png || !info) {
        png_destroy_write_struct(&png, NULL);
        snprintf(err, errlen, "out of memory in libpng");
        return -1;
    }
    texts = nkv > 0 ? calloc((size_t)nkv, sizeof *texts) : NULL;
    rows = malloc((size_t)h * sizeof *rows);
    if ((nkv > 0 && !texts) || !rows) {
        png_destroy_write_struct(&png, &info);
        free(texts);
        free(rows);
        snprintf(err, errlen, "out of memory");
        return -1;
    }
    if (setjmp(png_jmpbuf(png))) {
        /* libpng's "Write Error" hides why fwrite failed: errno still holds it */
        int e = errno, io = ferror(f) && e != 0;
        png_destroy_write_struct(&png, &info);
        free(texts);
        free(rows);
        if (io) snprintf(err, errlen, "%s", io_reason(e));
        else snprintf(err, errlen, "libpng: %s", ectx.msg);
        return -1;
    }
    png_init_io(png, f);
    png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, 8, PNG_COLOR_TYPE_RGBA, PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_set_compression_level(png, 6);
    for (int i = 0; i < nkv; i++) {
        /* tEXt is Latin-1; anything beyond ASCII goes in an (uncompressed) UTF-8 iTXt */
        texts[i].compression = ascii(kv[2 * i + 1]) ? PNG_TEXT_COMPRESSION_NONE : PNG_ITXT_COMPRESSION_NONE;
        texts[i].key = (png_charp)kv[2 * i];
        texts[i].text = (png_charp)kv[2 * i + 1];
        texts[i].text_length = strlen(kv[2 * i + 1]);
    }
    if (nkv > 0) png_set_text(png, info, texts, nkv);
    for (int y = 0; y < h; y++) rows[y] = (png_bytep)(rgba + (size_t)y * w * 4);
    png_set_rows(png, info, rows);
    png_write_png(png, info, PNG_TRANSFORM_IDENTITY, NULL);
    png_destroy_write_struct(&png, &info);
    free(texts);
    free(rows);
    return 0;
}

int kf_png_write(const char *path, const uint8_t *rgba, int w, int h, const char *const *kv, int nkv, char *err,
                 size_t errlen) {
    if (!path || !*path) {
        snprintf(err, errlen, "png: empty output path");
        return -1;
    }
    if (!rgba || w <= 0 || h <= 0 || w > 1000000 || h > 1000000) {
        snprintf(err, errlen, "%s: bad image (%dx%d%s)", path, w, h, rgba ? "" : ", no pixels");
        return -1;
    }
    if (nkv < 0 || (nkv > 0 && !kv)) {
        snprintf(err, errlen, "%s: bad text list (%d pairs)", path, nkv);
        return -1;
    }
    for (int i = 0; i < nkv; i++) {
        if (!kv[2 * i] || !kv[2 * i + 1] || !key_ok(kv[2 * i])) {
            snprintf(err, errlen,
                     "%s: text key %d \"%s\" is not a PNG keyword (1-79 printable Latin-1 "
                     "characters, no leading/trailing space)%s",
                     path, i, kv[2 * i] ? kv[2 * i] : "(null)", kv[2 * i + 1] ? "" : " or has no value");
            return -1;
        }
    }
    size_t plen = strlen(path);
    char *tmp = malloc(plen + 32);
    if (!tmp) {
        snprintf(err, errlen, "%s: out of memory", path);
        return -1;
    }
    snprintf(tmp, plen + 32, "%s.tmp-%ld", path, (long)getpid());
    int fd = open(tmp, O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd < 0) {
        snprintf(err, errlen, "%s: cannot create %s: %s", path, tmp, strerror(errno));
        free(tmp);
        return -1;
    }
    FILE *f = fdopen(fd, "wb");
    if (!f) {
        snprintf(err, errlen, "%s: %s", path, strerror(errno));
        close(fd);
        unlink(tmp);
        free(tmp);
        return -1;
    }
    char why[300] = "";
    int rc = write_stream(f, rgba, w, h, kv, nkv, why, sizeof why);
    if (rc == 0 && fflush(f) != 0) rc = -1, snprintf(why, sizeof why, "%s", io_reason(errno));
    if (rc == 0 && fsync(fd) != 0) rc = -1, snprintf(why, sizeof why, "fsync: %s", io_reason(errno));
    if (fclose(f) != 0 && rc == 0) rc = -1, snprintf(why, sizeof why, "close: %s", io_reason(errno));
    if (rc == 0 && rename(tmp, path) != 0)
        rc = -1, snprintf(why, sizeof why, "rename from %s: %s", tmp, strerror(errno));
    if (rc != 0) {
        unlink(tmp);
        snprintf(err, errlen, "%s: %s", path, why);
        free(tmp);
        return -1;
    }
    free(tmp);
    /* make the rename itself durable */
    char *dir = strdup(path);
    if (dir) {
        char *slash = strrchr(dir, '/');
        const char *d = slash ? (slash == dir ? "/" : (*slash = 0, dir)) : ".";
        int dfd = open(d, O_RDONLY | O_DIRECTORY);
        if (dfd >= 0) {
            fsync(dfd);
            close(dfd);
        }
        free(dir);
    }
    return 0;
}
