/* sheet.c — the contact sheet of a wedge set: one PNG, a row per wedge
 * labelled with its values, a column per chosen frame labelled with its
 * number, each cell the wedge's image of that frame scaled down; and
 * wedges.txt beside it (layout in farm.h). */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "../io/atomic_file.h"
#include "../pipeline/stages.h"
#include "farm.h"
#include "render.h"

#define CELL_MAX_W 320 /* a cell is at most this wide: images are shrunk by a whole factor */
#define PAD 8
#define TEXT_SCALE 2

static const uint8_t BG[3] = {28, 28, 30}, INK[3] = {235, 235, 235}, MISSING[3] = {110, 30, 30};

static void fill(uint8_t *img, int w, int x0, int y0, int cw, int ch, const uint8_t rgb[3]) {
    for (int y = y0; y < y0 + ch; y++)
        for (int x = x0; x < x0 + cw; x++) {
            uint8_t *p = img + 4 * ((size_t)y * (size_t)w + (size_t)x);
            p[0] = rgb[0], p[1] = rgb[1], p[2] = rgb[2], p[3] = 255;
        }
}

/* src (sw x sh) averaged over k x k boxes into the sheet at (x0, y0) */
static void blit_shrunk(uint8_t *dst, int dw, int x0, int y0, const uint8_t *src, int sw, int sh, int k) {
    for (int y = 0; y < sh / k; y++)
        for (int x = 0; x < sw / k; x++) {
            unsigned sum[3] = {0, 0, 0};
            for (int dy = 0; dy < k; dy++)
                for (int dx = 0; dx < k; dx++) {
                    const uint8_t *p = src + 4 * ((size_t)(y * k + dy) * (size_t)sw + (size_t)(x * k + dx));
                    sum[0] += p[0], sum[1] += p[1], sum[2] += p[2];
                }
            uint8_t *q = dst + 4 * ((size_t)(y0 + y) * (size_t)dw + (size_t)(x0 + x));
            for (int c = 0; c < 3; c++) q[c] = (uint8_t)((sum[c] + (unsigned)(k * k) / 2) / (unsigned)(k * k));
            q[3] = 255;
        }
}

static int write_list(const char *dir, const kf_wedge *w, int nw) {
    char path[2300];
    kf_atomic_file af;
    snprintf(path, sizeof path, "%s/wedges.txt", dir);
    if (kf_ensure_parent(path) || kf_atomic_open(&af, path)) return -1;
    for (int k = 0; k < nw; k++) {
        fprintf(af.f, "w%02d\t%s\t", k + 1, w[k].label);
        for (int i = 0; i < w[k].nsets; i++) fprintf(af.f, "%s--set %s", i ? " " : "", w[k].sets[i]);
        fputc('\n', af.f);
    }
    return kf_atomic_commit(&af);
}

int kf_contact_sheet(const kf_cli_opts *o, const kf_shot *shot, const kf_wedge *w, int nw, int columns) {
    char dir[2048], err[4200];
    if (kf_farm_base_dir(o, shot, dir, sizeof dir)) return fprintf(stderr, "kerf: output path too long\n"), -1;
    if (write_list(dir, w, nw)) return fprintf(stderr, "kerf: %s/wedges.txt: cannot write it\n", dir), -1;
    /* the frames shown: up to `columns`, evenly spread, first and last included */
    int span = shot->last - shot->first + 1, nc = span < columns ? span : columns;
    int frames[64];
    for (int c = 0; c < nc; c++) frames[c] = shot->first + (nc > 1 ? (int)((long)c * (span - 1) / (nc - 1)) : 0);
    /* cells take the size of the first image found, shrunk by a whole factor */
    uint8_t **imgs = calloc((size_t)(nw * nc), sizeof *imgs);
    int *iw = calloc((size_t)(nw * nc), sizeof *iw), *ih = calloc((size_t)(nw * nc), sizeof *ih);
    int cw = 0, ch = 0, k = 1, found = 0;
    for (int r = 0; r < nw && imgs; r++)
        for (int c = 0; c < nc; c++) {
            kf_cli_opts wo;
            char out[1200];
            kf_frame_paths fp;
            kf_wedge_opts(o, shot, &w[r], r + 1, &wo, out, sizeof out);
            if (kf_frame_paths_make(shot, wo.out, frames[c], &fp)) continue;
            int i = r * nc + c;
            if (kf_png_read(fp.image, &imgs[i], &iw[i], &ih[i], NULL, NULL, err, sizeof err)) {
                fprintf(stderr, "kerf: contact sheet: %s (its cell is left dark red)\n", err);
                imgs[i] = NULL;
                continue;
            }
            found++;
            if (!cw) {
                k = (iw[i] + CELL_MAX_W - 1) / CELL_MAX_W;
                cw = iw[i] / k, ch = ih[i] / k;
            }
        }
    if (!imgs || !found) {
        fprintf(stderr, "kerf: contact sheet: no images of the wedges in %s/w01.. (render them first)\n", dir);
        for (int i = 0; imgs && i < nw * nc; i++) free(imgs[i]);
        free(imgs), free(iw), free(ih);
        return -1;
    }
    /* a label column as wide as the longest label, a header row for frame numbers */
    int label_w = 0, text_h = 7 * TEXT_SCALE;
    for (int r = 0; r < nw; r++) {
        char text[300];
        snprintf(text, sizeof text, "w%02d %s", r + 1, w[r].label);
        int tw = kf_font_width(text, TEXT_SCALE);
        if (tw > label_w) label_w = tw;
    }
    if (label_w > 3 * cw) label_w = 3 * cw; /* a very long label is cut, not the sheet made huge */
    int x0 = PAD + label_w + PAD, y0 = PAD + text_h + PAD;
    int sw = x0 + nc * (cw + PAD), sh = y0 + nw * (ch + PAD);
    uint8_t *sheet = malloc((size_t)sw * (size_t)sh * 4);
    if (!sheet) return fprintf(stderr, "kerf: contact sheet: out of memory\n"), -1;
    fill(sheet, sw, 0, 0, sw, sh, BG);
    for (int c = 0; c < nc; c++) {
        char text[32];
        snprintf(text, sizeof text, "%d", frames[c]);
        kf_font_draw(sheet, sw, sh, sw, x0 + c * (cw + PAD), PAD, TEXT_SCALE, text, INK);
    }
    for (int r = 0; r < nw; r++) {
        char text[300];
        int y = y0 + r * (ch + PAD);
        snprintf(text, sizeof text, "w%02d %s", r + 1, w[r].label);
        kf_font_draw(sheet, sw, sh, x0 - PAD, PAD, y + (ch - text_h) / 2, TEXT_SCALE, text, INK);
        for (int c = 0; c < nc; c++) {
            int i = r * nc + c, x = x0 + c * (cw + PAD);
            /* an image of another size than the first (a wedge of render.width) is shrunk to fit */
            if (imgs[i] && iw[i] / k <= cw && ih[i] / k <= ch) blit_shrunk(sheet, sw, x, y, imgs[i], iw[i], ih[i], k);
            else if (imgs[i]) {
                int kk = k;
                while (iw[i] / kk > cw || ih[i] / kk > ch) kk++;
                blit_shrunk(sheet, sw, x, y, imgs[i], iw[i], ih[i], kk);
            } else fill(sheet, sw, x, y, cw, ch, MISSING);
        }
    }
    char path[2300];
    snprintf(path, sizeof path, "%s/contact_sheet.png", dir);
    int rc = kf_png_write(path, sheet, sw, sh, NULL, 0, err, sizeof err);
    if (rc) fprintf(stderr, "kerf: contact sheet: %s\n", err);
    for (int i = 0; i < nw * nc; i++) free(imgs[i]);
    free(imgs), free(iw), free(ih), free(sheet);
    return rc ? -1 : 0;
}
