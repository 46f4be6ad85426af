/* The "shapes" of a JSON scene (shapes.c): transforms, inline and file meshes, spheres,
 * into world space. Private to worker/scene/. */
#ifndef VF_SCENE_SHAPES_H
#define VF_SCENE_SHAPES_H

#include "mesh.h"
#include "parse.h"

#include <cjson/cJSON.h>

/* The "shapes" array. */
int vf_scene_parse_shapes(const parse_ctx *c, const cJSON *j);

/* A JSON "transform" object (shapes.c, docs/SCENES.md) as an affine map. */
int vf_scene_parse_transform(const parse_ctx *c, const cJSON *j, const char *path, vf_affine *out);

/* The total area of mesh s, in double (an emitter's must be > 0). */
double vf_scene_mesh_area(const vf_shape *s);

#endif
