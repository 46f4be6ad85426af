/* The dashboard's page, its script and its style (coordinator/dashboard/web/), compiled into the
 * binary: coordinator/dashboard/web/embed.cmake writes them as C arrays at build time, so the
 * coordinator serves the page it was built with and needs no files installed. */
#ifndef VF_WEB_ASSETS_H
#define VF_WEB_ASSETS_H

#include <stddef.h>

typedef struct {
  const char *path;         /* "/", "/dashboard.js", ... */
  const char *content_type;
  const unsigned char *bytes;
  size_t size;
} vf_web_asset;

/* The asset served at path, or NULL. */
const vf_web_asset *vf_web_asset_find(const char *path);

#endif
