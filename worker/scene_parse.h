/* Private to the scene module: what its files share while parsing a scene file.
 * scene_json.c walks the JSON, scene_mesh.c imports mesh files through Assimp, scene.c
 * loads, scales, bounds and hashes. Not part of the public API (that is scene.h). */
#ifndef VF_SCENE_PARSE_H
#define VF_SCENE_PARSE_H

#include "scene.h"
#include "scene_builtin.h"

#include <stddef.h>

/* Field paths longer than this only come from absurd keys: they end in "...". */
#define PATH_LEN 256

enum { OPTIONAL = 0, REQUIRED = 1 };

typedef struct {
  const char *label;    /* the scene as errors name it: the path given, or "builtin:NAME" */
  const char *base_dir; /* relative "file" paths start here */
  const vf_scene_memfile *memfiles;
  int num_memfiles;
  vf_scene *scene;      /* being filled; owned by vf_scene_parse */
  /* Farm jobs: when set, every "file" comes from here instead of base_dir
   * (worker/scene_files.h). Borrowed. */
  struct vf_scene_files *files;
} parse_ctx;

/* The largest coordinate magnitude a scene may have, in world space after every transform
 * (vertices, sphere bounds, the camera, point lights). Embree asserts that ray origins
 * stay below 1.8e18 and the renderer squares distances in floats (3.4e38 at most): 1e15
 * keeps both with a wide margin. docs/SCENES.md states it. */
#define VF_SCENE_MAX_COORDINATE 1e15f

/* Refuses (VF_ESCENE naming the scene, what and where) a scene with a coordinate beyond
 * VF_SCENE_MAX_COORDINATE: the renderer could not trace it. */
int vf_scene_check_extent(const vf_scene *scene, const char *label);

/* Records "LABEL: PATH: message" (or "LABEL: message" without a path) and returns err. */
int vf_scene_fail(const parse_ctx *c, int err, const char *path, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* path + "." + key, and path + "[index]", into dst (PATH_LEN bytes); return dst. */
const char *vf_scene_join(char *dst, const char *path, const char *key);
const char *vf_scene_join_index(char *dst, const char *path, long index);

/* The path of `file` as the scene names it: absolute, or relative to the scene's directory. */
int vf_scene_resolve(const parse_ctx *c, const char *file, const char *path, char *out, size_t n);

/* Imports mesh `file` (relative to the scene's directory, or a memfile) into shape s, which
 * the field at `path` describes. VF_ENOENT, VF_EMESH or VF_ENOMEM with a detail. */
int vf_scene_load_mesh_file(const parse_ctx *c, const char *file, const char *path, vf_shape *s);

/* Sets the scene's bounds from its shapes. */
void vf_scene_compute_bounds(vf_scene *s);

#endif
