/* assets.h — the page's files (web/), compiled into kerf so the page works
 * from the build tree and after install alike, with nothing to find at run
 * time. The table is generated at build time by embed.cmake. */
#ifndef KF_VIEW_ASSETS_H
#define KF_VIEW_ASSETS_H

#include <stddef.h>

typedef struct kf_view_asset {
    const char *name; /* "index.html", "view.js", ... */
    const unsigned char *data;
    size_t size;
} kf_view_asset;

extern const kf_view_asset kf_view_assets[];
extern const int kf_view_nassets;

#endif
