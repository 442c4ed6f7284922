/* diag.h — diagnostics: every problem with the input, collected in one pass.
 *
 * An entry knows where it is (file, line, column, and the text of that line)
 * so it prints the way a compiler's does and an editor can jump to it:
 *
 *     shots/x.yaml:12:7: error: sim.dx must be > 0 m, got -0.01
 *        12 |   dx: -0.01
 *           |       ^
 *
 * Command-line input has a pseudo-file: `--set` (line = which --set, counting
 * from 1; the echoed line is the override itself), `--frames`, `--quality`. */
#ifndef KF_DIAG_H
#define KF_DIAG_H

#include <stdio.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum kf_severity { KF_DIAG_ERROR = 0, KF_DIAG_WARNING } kf_severity;

typedef struct kf_diag_entry {
    kf_severity severity;
    char *file;    /* "shots/x.yaml", "--set", "--frames", "--quality" */
    int line, col; /* 1-based; col counts characters; 0 = no position */
    char *message; /* one line, no trailing newline */
    char *source;  /* the text of that line (no newline), or NULL */
    int order;     /* sort key: which input (file first, then the command line) */
    int seq;       /* sort key: the order problems were found */
} kf_diag_entry;

typedef struct kf_diag {
    kf_diag_entry *entry; /* (count) */
    int count, cap;
    int errors, warnings;
} kf_diag;

void kf_diag_init(kf_diag *d);
void kf_diag_free(kf_diag *d);
/* Append an entry (file and source are copied; either may be NULL). */
void kf_diag_add(kf_diag *d, kf_severity sev, const char *file, int line, int col, const char *source, const char *fmt,
                 ...) __attribute__((format(printf, 7, 8)));
/* Order entries by input, line, column (stable). */
void kf_diag_sort(kf_diag *d);
/* `file:line:col: error: message`, then the line echoed with a caret under
 * the column (when the entry has them). */
void kf_diag_print_entry(FILE *f, const kf_diag_entry *e);
void kf_diag_print(FILE *f, const kf_diag *d);

#ifdef __cplusplus
}
#endif
#endif
