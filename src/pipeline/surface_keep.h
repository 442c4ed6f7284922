/* surface_keep.h — the level sets a frame was just surfaced into, kept in
 * memory for the render that follows in the same process.
 *
 * Rendering a frame reads its .vdb back; when this process wrote that file a
 * moment ago, the grids it wrote are still the file's contents (the archive
 * stores floats losslessly), so the read is skipped. The file is identified
 * by its path and its device, inode, size and modification time just after
 * the write: a file replaced or touched since is read from disk as before. */
#ifndef KF_SURFACE_KEEP_H
#define KF_SURFACE_KEEP_H

#include "../io/vdb_bridge.h"

/* keep grids[0..n) (taken over) as the contents of `path`, just written;
 * whatever was kept before is freed. On any failure the grids are freed. */
void kf_surface_keep(const char *path, kf_vdb_grid **grids, int n);

/* the kept level set named `name` of `path`, handed over to the caller (who
 * frees it), or NULL when `path` is not the file kept or has changed */
kf_vdb_grid *kf_surface_take(const char *path, const char *name);

/* free whatever is kept */
void kf_surface_keep_clear(void);

#endif
