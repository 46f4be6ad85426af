/* The built-in scenes (builtin.c): the cornell family with the benchmark suite's SDS,
 * diffuse and glossy members, furnace, and the knot.
 *
 * They are JSON texts in the documented format (docs/SCENES.md), fed through the same
 * parser as scene files (json.h), so they are validated, hashed and bounded by the same
 * code that handles user scenes. A built-in may also carry mesh files it generated in
 * memory (the `knot`'s PLY): a shape's "file" that names one of those is imported from
 * memory by the same Assimp path that reads files from disk. */
#ifndef VF_SCENE_BUILTIN_H
#define VF_SCENE_BUILTIN_H

#include "scene.h"

/* NULL-terminated list of built-in scene names. */
const char *const *vf_scene_builtin_names(void);

/* Builds the built-in scene `name`, one of vf_scene_builtin_names(). VF_ENOENT (with a
 * detail) when it is not one; otherwise as vf_scene_parse (json.h). */
int vf_scene_builtin_load(const char *name, vf_scene **out);

#endif
