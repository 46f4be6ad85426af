/* The "materials" of a JSON scene (materials.c): each into a vf_material of the scene,
 * validated. Private to worker/scene/. */
#ifndef VF_SCENE_MATERIALS_H
#define VF_SCENE_MATERIALS_H

#include "parse.h"

#include <cjson/cJSON.h>

/* The "materials" object: NAME -> material. */
int vf_scene_parse_materials(const parse_ctx *c, const cJSON *j);

#endif
