/* contact_sheet.c — one small picture of many: each input PNG shrunk to a
 * tile (box filter) and laid out row by row on a dark background.
 *   kf_contact_sheet OUT.png COLUMNS TILE_WIDTH in1.png in2.png ...
 * Tiles keep the first image's aspect ratio; an input that cannot be read
 * stays a dark tile (and is named on stderr). An input named `keep` keeps
 * the tile at its place in the OUT.png already there (same layout), so one
 * shot's tile can be remade without running every shot again. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render.h"

int main(int argc, char **argv) {
    if (argc < 5) {
        fprintf(stderr, "usage: %s OUT.png COLUMNS TILE_WIDTH in.png...\n", argv[0]);
        return 2;
    }
    const int cols = atoi(argv[2]), tw = atoi(argv[3]), n = argc - 4, gap = 4;
    if (cols < 1 || tw < 8) return 2;
    int th = tw * 9 / 16;
    char err[512];
    uint8_t *img, *old = NULL;
    int w, h, ow = 0, oh = 0, keep = 0;
    const int rows = (n + cols - 1) / cols, W = cols * tw + (cols + 1) * gap;
    for (int k = 0; k < n; k++) keep |= !strcmp(argv[4 + k], "keep");
    /* kept tiles come from the sheet there now: its tile height, and its width must match */
    if (keep) {
        if (kf_png_read(argv[1], &old, &ow, &oh, NULL, NULL, err, sizeof err) || ow != W ||
            (oh - (rows + 1) * gap) % rows) {
            fprintf(stderr, "%s: cannot keep tiles: %s\n", argv[1], old ? "another layout" : err);
            free(old);
            return 1;
        }
        th = (oh - (rows + 1) * gap) / rows;
    } else if (kf_png_read(argv[4], &img, &w, &h, NULL, NULL, err, sizeof err) == 0) {
        th = tw * h / w;
        free(img);
    }
    const int H = rows * th + (rows + 1) * gap;
    uint8_t *out = malloc((size_t)W * H * 4);
    for (size_t i = 0; i < (size_t)W * H; i++)
        out[4 * i] = 24, out[4 * i + 1] = 24, out[4 * i + 2] = 26, out[4 * i + 3] = 255;
    for (int k = 0; k < n; k++) {
        const int x0 = gap + (k % cols) * (tw + gap), y0 = gap + (k / cols) * (th + gap);
        if (old && !strcmp(argv[4 + k], "keep")) {
            for (int ty = 0; ty < th; ty++)
                memcpy(out + 4 * ((size_t)(y0 + ty) * W + x0), old + 4 * ((size_t)(y0 + ty) * W + x0), 4 * (size_t)tw);
            continue;
        }
        if (kf_png_read(argv[4 + k], &img, &w, &h, NULL, NULL, err, sizeof err)) {
            fprintf(stderr, "%s\n", err);
            continue;
        }
        /* each tile pixel: the mean of the source pixels under it */
        for (int ty = 0; ty < th; ty++)
            for (int tx = 0; tx < tw; tx++) {
                int sx0 = tx * w / tw, sx1 = (tx + 1) * w / tw, sy0 = ty * h / th, sy1 = (ty + 1) * h / th;
                if (sx1 <= sx0) sx1 = sx0 + 1;
                if (sy1 <= sy0) sy1 = sy0 + 1;
                unsigned sum[3] = {0, 0, 0}, cnt = 0;
                for (int sy = sy0; sy < sy1 && sy < h; sy++)
                    for (int sx = sx0; sx < sx1 && sx < w; sx++, cnt++)
                        for (int c = 0; c < 3; c++) sum[c] += img[4 * ((size_t)sy * w + sx) + c];
                uint8_t *p = out + 4 * ((size_t)(y0 + ty) * W + x0 + tx);
                for (int c = 0; c < 3; c++) p[c] = (uint8_t)(cnt ? sum[c] / cnt : 0);
            }
        free(img);
    }
    int rc = kf_png_write(argv[1], out, W, H, NULL, 0, err, sizeof err);
    if (rc) fprintf(stderr, "%s\n", err);
    free(out);
    free(old);
    return rc ? 1 : 0;
}
