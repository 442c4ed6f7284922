/* run_record.c — the per-frame records and the progress file of a run (see
 * run_record.h). A record that cannot be written is skipped silently: the
 * frames themselves matter, the records only describe them. */
#include "run_record.h"

#include <fcntl.h>
#include <stdio.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#include "../io/atomic_file.h"

void kf_record_begin(const char *dir, int fresh) {
    char path[2200];
    kf_mkdirs(dir);
    snprintf(path, sizeof path, "%s/frames.jsonl", dir);
    if (fresh) {
        int fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (fd >= 0) close(fd);
    }
}

void kf_record_frame(const char *dir, int frame, size_t particles, const kf_step_stats *st, double frame_ms,
                     long thin_across, double thin_across_deepest) {
    char path[2200], line[1024];
    snprintf(path, sizeof path, "%s/frames.jsonl", dir);
    int n = snprintf(
        line, sizeof line,
        "{\"frame\":%d,\"particles\":%zu,\"blocks\":%ld,\"substeps\":%ld,\"max_cfl\":%.4g,\"ms\":%.1f,"
        "\"ms_stage\":{\"sort\":%.1f,\"p2g\":%.1f,\"grid\":%.1f,\"g2p\":%.1f,\"stress\":%.1f,\"cdf\":%.1f,"
        "\"rigid\":%.1f},\"retries\":%d,\"warnings\":%ld,\"thin_caught\":%ld,\"thin_deepest\":%.3g,"
        "\"thin_across\":%ld,\"thin_across_deepest\":%.3g,\"stiff_limited\":%ld,\"newton\":%ld,\"krylov\":%ld}\n",
        frame, particles, st->active_blocks, st->substeps, st->max_cfl, frame_ms, st->ms[KF_STAGE_SORT],
        st->ms[KF_STAGE_P2G], st->ms[KF_STAGE_GRID], st->ms[KF_STAGE_G2P], st->ms[KF_STAGE_STRESS],
        st->ms[KF_STAGE_CDF], st->ms[KF_STAGE_RIGID], st->retries, st->warnings, st->thin_caught, st->thin_deepest,
        thin_across, thin_across_deepest, st->stiff_limited, st->newton_iterations, st->krylov_iterations);
    if (n <= 0 || n >= (int)sizeof line) return;
    /* one write of a whole line with O_APPEND: lines never interleave or tear mid-way */
    int fd = open(path, O_WRONLY | O_CREAT | O_APPEND, 0644);
    if (fd < 0) return;
    ssize_t w = write(fd, line, (size_t)n);
    (void)w;
    close(fd);
}

void kf_record_progress(const char *dir, const kf_shot *shot, const char *stage, int frame, int done, int todo,
                        double eta_s) {
    char path[2200];
    snprintf(path, sizeof path, "%s/run.json", dir);
    /* the name is the file's stem when the shot gives none: keep it a JSON string */
    char name[2 * sizeof shot->name], *q = name;
    for (const char *p = shot->name; *p; p++) {
        if (*p == '"' || *p == '\\') *q++ = '\\';
        *q++ = (unsigned char)*p < 0x20 ? '?' : *p;
    }
    *q = 0;
    kf_atomic_file a;
    if (kf_atomic_open(&a, path)) return;
    fprintf(a.f,
            "{\"pid\":%ld,\"shot\":\"%s\",\"stage\":\"%s\",\"frame\":%d,\"first\":%d,\"last\":%d,\"fps\":%g,"
            "\"done\":%d,\"todo\":%d,\"eta_s\":%.1f,\"time\":%lld}\n",
            (long)getpid(), name, stage, frame, shot->first, shot->last, shot->fps, done, todo, eta_s,
            (long long)time(NULL));
    kf_atomic_commit(&a);
}
