/* The parse context: what every reader of a scene file shares while it fills one vf_scene
 * (json.c, shapes.c, mesh.c, gltf.c, import.c, import_material.c, textures.c, fields.c).
 * Errors name the scene, the field path and the problem; notes collect what the scene asks
 * for that vcmfarm does not do; file names resolve against the scene's directory, a
 * built-in's memory files or a farm job's files. Private to worker/scene/. */
#ifndef VF_SCENE_PARSE_H
#define VF_SCENE_PARSE_H

#include "files.h"
#include "scene.h"

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
  /* Farm jobs: when set, every "file" comes from here instead of base_dir (files.h).
   * Borrowed. */
  struct vf_scene_files *files;
} parse_ctx;

/* Records "LABEL: PATH: message" (or "LABEL: message" without a path) and returns err. */
int vf_scene_fail(const parse_ctx *c, int err, const char *path, const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));

/* path + "." + key, and path + "[index]", into dst (PATH_LEN bytes); return dst. */
const char *vf_scene_join(char *dst, const char *path, const char *key);
const char *vf_scene_join_index(char *dst, const char *path, long index);

/* Adds a line to scene->notes (scene.h) unless the same line is there already.
 * VF_ENOMEM only. */
int vf_scene_note(const parse_ctx *c, const char *fmt, ...) __attribute__((format(printf, 2, 3)));

/* The medium of the scene named `name` (an index into scene->media), or -1. */
int vf_scene_medium_index(const parse_ctx *c, const char *name);
/* Appends *m to scene->media (taking its grid) and sets *index; VF_ENOMEM (then the grid
 * is still the caller's). */
int vf_scene_add_medium(const parse_ctx *c, vf_medium *m, int *index);

/* The path of `file` as the scene names it: absolute, or relative to the scene's directory;
 * for a farm job's scene, the file its table maps the name to. Errors name `path`. */
int vf_scene_resolve(const parse_ctx *c, const char *file, const char *path, char *out, size_t n);

#endif
