/* farm.h — `kerf farm`: a shot's simulation, surfacing and rendering as
 * Slurm jobs, wedges (the shot at several parameter values) on the farm or
 * one after another locally, and the contact sheet that ends a wedge set.
 *
 * Words (and what OpenCue / OpenJD call them): a job is shot x wedge; its
 * steps (layers) are sim, surface and render; a task is one array element of
 * a step, `chunk` frames long. Slurm job names are <shot>_w<NN>_<step>.
 *
 * The output layout of a wedge set (the viewer reads it; keep it in step):
 *
 *   <dir>/                    output.dir expanded at the first frame (out/tiny/v001)
 *   <dir>/w01/ ... w<NN>/     one wedge each, laid out as a plain run's directory:
 *                             particles/ checkpoints/ surface/ images/
 *   <dir>/wedges.txt          one line per wedge: w<NN> TAB label TAB the --set values
 *                             (label: "E=1e3 nu=0.3", the keys' last words)
 *   <dir>/contact_sheet.png   wedges (rows, labelled) x chosen frames (columns,
 *                             labelled with the frame number)
 *   <dir>/farm/               what `kerf farm submit` wrote: jobs.txt (the job ids it
 *                             submitted), scripts/, logs/<job>.<task>.log,
 *                             failures.txt (a line per task that failed twice)
 *
 * Without --wedge the farm runs the shot itself into <dir> (wedge 00). */
#ifndef KF_FARM_H
#define KF_FARM_H

#include "../cli/cli.h"

#define KF_WEDGE_MAX 99

/* One wedge: its overrides ("key=value", one per --wedge) and a label. */
typedef struct kf_wedge {
    char sets[16][512];
    int nsets;
    char label[256];
} kf_wedge;

/* The product of the --wedge options' values, in order (the last option
 * varies fastest). Values are split at commas outside brackets, so
 * KEY=[0,-2,0],[0,-4,0] is two values. Returns the count (>= 1), or -1 with
 * a message. */
int kf_wedges_expand(const char *const *specs, int nspecs, kf_wedge *out, int max, char *err, size_t errlen);

/* A wedge's options: the base options plus its --set values, output into
 * <dir>/w<NN> (the shot's output template with /w<NN> appended). `sets` and
 * `out` are storage the result points into. */
void kf_wedge_opts(const kf_cli_opts *base, const kf_shot *shot, const kf_wedge *w, int index, kf_cli_opts *o,
                   char *out, size_t outlen);

/* <dir>: the shot's output directory at its first frame (base options). */
int kf_farm_base_dir(const kf_cli_opts *o, const kf_shot *shot, char *dir, size_t n);

/* `kerf run --wedge ...`: every wedge in turn, then the contact sheet. */
int kf_farm_run_wedges(const kf_cli_opts *o);

/* Load the shot with the base options (no seeding), check every wedge's
 * overrides the same way (all problems at once), and expand the wedges.
 * Returns the shot, or NULL after printing (exit 2). */
kf_shot *kf_farm_load_wedges(const kf_cli_opts *o, kf_wedge *w, int *nw);

/* wedges.txt and contact_sheet.png in <dir>, from each wedge's images at up
 * to `columns` frames evenly spread over [first, last]. 0, or -1 printed. */
int kf_contact_sheet(const kf_cli_opts *o, const kf_shot *shot, const kf_wedge *w, int nw, int columns);

/* text in a 5x7 bitmap font (upper case, digits, punctuation; lower case is
 * drawn as upper case) at scale s, into an RGBA image w x h, cut at x = xmax */
void kf_font_draw(uint8_t *rgba, int w, int h, int xmax, int x, int y, int s, const char *text, const uint8_t rgb[3]);
int kf_font_width(const char *text, int s);

/* `kerf farm submit|status|cancel` and the tasks the jobs run */
int kf_cmd_farm(int argc, char **argv);

#endif
