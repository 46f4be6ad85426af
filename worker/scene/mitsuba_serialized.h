/* Mitsuba's serialized meshes (mitsuba_serialized.c): one mesh of a .serialized file, in
 * the single-indexed encoding of format versions 3 and 4 (Mitsuba 0.x and 3.x), read as the
 * inline mesh of a JSON shape. Private to worker/scene/. */
#ifndef VF_SCENE_MITSUBA_SERIALIZED_H
#define VF_SCENE_MITSUBA_SERIALIZED_H

#include "mitsuba_props.h"

/* Mesh `shape_index` of the file `path` (as opened) into js: "positions", "indices" and,
 * as the file has them, "normals" and "uvs" (Mitsuba's v as stored: v = 0 is the image's
 * top row, as vcmfarm's t). Errors name the element `e` (mts_fail): a file that is not a
 * serialized mesh, a damaged stream, an index out of range, a count that does not fit. */
int mts_serialized(mts_ctx *c, const vf_xml_node *e, const char *path, long shape_index, cJSON *js);

#endif
