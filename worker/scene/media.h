/* The "media" of a JSON scene (media.c, docs/SCENES.md, "Media"): homogeneous media and
 * density grids read from OpenVDB files (vdb.h), and the scene's own "medium". Private to
 * worker/scene/. */
#ifndef VF_SCENE_MEDIA_H
#define VF_SCENE_MEDIA_H

#include "parse.h"

#include <cjson/cJSON.h>

/* The "media" object: every medium validated and appended to scene->media, its grid (if
 * any) loaded, placed in world space and scaled. Errors name the medium and the field. */
int vf_scene_parse_media(const parse_ctx *c, const cJSON *j);

/* The top-level "medium": the name of one of the scene's media, into scene->medium. */
int vf_scene_parse_scene_medium(const parse_ctx *c, const cJSON *j);

#endif
