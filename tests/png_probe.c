/* png_probe.c — what is in a rendered frame, for tests/test_cli.sh (built
 * beside kerf as kf_png_probe; not a test itself).
 *   usage: kf_png_probe <image.png>
 * prints, one per line:
 *   size W H
 *   background N      pixels on the renderer's default background gradient (within 3/255)
 *   red N CX CY       pixels clearly red (r >= 64, r > 1.4 g, r > 1.4 b), their centroid in pixels
 *   green N CX CY     the same for green
 * (CX from the left, CY from the top; -1 -1 when there are none).
 * Exit 0, or 1 with a message when the file cannot be read. */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "render.h"

int main(int argc, char **argv) {
    if (argc != 2) {
        fprintf(stderr, "usage: kf_png_probe <image.png>\n");
        return 2;
    }
    uint8_t *img = NULL;
    int W = 0, H = 0;
    char err[512];
    if (kf_png_read(argv[1], &img, &W, &H, NULL, NULL, err, sizeof err)) {
        fprintf(stderr, "kf_png_probe: %s\n", err);
        return 1;
    }
    kf_render_scene sc = kf_render_scene_default();
    long bg = 0, n[2] = {0, 0};
    double sx[2] = {0, 0}, sy[2] = {0, 0};
    for (int y = 0; y < H; y++) {
        /* the gradient: bottom at the last row, top at the first (rows are top-down) */
        double t = 1.0 - (y + 0.5) / H;
        int g[3];
        for (int k = 0; k < 3; k++) g[k] = (int)lround(255 * (sc.bg_bottom[k] + (sc.bg_top[k] - sc.bg_bottom[k]) * t));
        for (int x = 0; x < W; x++) {
            const uint8_t *p = img + ((size_t)y * W + x) * 4;
            if (abs(p[0] - g[0]) <= 3 && abs(p[1] - g[1]) <= 3 && abs(p[2] - g[2]) <= 3) bg++;
            for (int c = 0; c < 2; c++) {
                int a = p[c], o1 = p[c == 0 ? 1 : 0], o2 = p[2];
                if (a >= 64 && a > 1.4 * o1 && a > 1.4 * o2) n[c]++, sx[c] += x + 0.5, sy[c] += y + 0.5;
            }
        }
    }
    printf("size %d %d\nbackground %ld\n", W, H, bg);
    for (int c = 0; c < 2; c++)
        printf("%s %ld %.1f %.1f\n", c ? "green" : "red", n[c], n[c] ? sx[c] / n[c] : -1, n[c] ? sy[c] / n[c] : -1);
    free(img);
    return 0;
}
