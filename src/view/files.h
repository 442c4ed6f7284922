/* files.h — the files kerf view serves: only regular files under the shot's
 * output root, named by a plain relative path, and what is there (image
 * sequences, run records) as JSON for the page. */
#ifndef KF_VIEW_FILES_H
#define KF_VIEW_FILES_H

#include <stddef.h>

#include "json.h"

/* Open root/rel for reading. rel must be a plain relative path: letters,
 * digits and . _ - + = , @ only (so no percent-encoding, no backslash), no
 * empty, "." or ".." component; after symlinks are resolved the file must
 * still lie under root_real (itself resolved). Returns 200 with *fd and
 * *size, or the HTTP status that refuses it: 400 (not a plain path), 403
 * (outside the root), 404 (missing, or not a regular file). */
int kf_view_open(const char *root_real, const char *rel, int *fd, size_t *size);

/* 1 when rel is a plain relative path as kf_view_open wants it. */
int kf_view_plain_path(const char *rel);

/* What lies under root, as JSON:
 *   "outputs": [{"dir", "wedge", "records", "run", "alive", "view"}...]
 *                    directories a run (or a view) wrote into; wedge: its label in
 *                    its wedge set's wedges.txt, else null
 *   "sheets": ["v001/contact_sheet.png"...]                    contact sheets of wedge sets
 *   "sequences": [{"dir", "out", "kind", "prefix", "frames": [...], "names": [...]}...]
 * A sequence is the PNGs of one directory whose names differ only in their
 * last number (the frame); `out` is the output directory it belongs to.
 * Hidden directories and symlinked ones are not walked. */
void kf_view_scan(const char *root, kf_buf *out);

#endif
