/* Private to the scene module (scene.c and builtin.c); nothing else includes it.
 *
 * The built-in scenes are JSON texts in the documented format (docs/SCENES.md), fed
 * through the same parser as scene files, so they are validated, hashed and bounded by the
 * same code that handles user scenes. A built-in may also carry mesh files it generated in
 * memory (the `knot`'s PLY): a shape's "file" that names one of those is imported from
 * memory by the same Assimp path that reads files from disk. */
#ifndef VF_SCENE_BUILTIN_H
#define VF_SCENE_BUILTIN_H

#include "scene.h"

#include <stddef.h>

/* A file held in memory; the format is taken from the extension of `name`. Borrowed:
 * the parser only reads it during the call. */
typedef struct {
  const char *name;
  const void *data;
  size_t size;
} vf_scene_memfile;

/* scene.c: parses a JSON scene text of `length` bytes. `label` names the scene in error
 * details and becomes scene->source; relative "file" paths are resolved against
 * `base_dir` unless they equal the name of one of `memfiles` (which may be NULL when
 * num_memfiles is 0). Errors and *out as for vf_scene_load. */
int vf_scene_parse(const char *text, size_t length, const char *label, const char *base_dir,
                   const vf_scene_memfile *memfiles, int num_memfiles, vf_scene **out);

/* json.c: parses JSON scene text whose files all come from `files`
 * (worker/scene/files.h: recorded from a directory, or mapped to a blob store). */
struct vf_scene_files;
int vf_scene_parse_files(const char *text, size_t length, const char *label, struct vf_scene_files *files,
                         vf_scene **out);

/* builtin.c: builds the built-in scene `name`, one of vf_scene_builtin_names().
 * VF_ENOENT (with a detail) when it is not one; otherwise as vf_scene_parse. */
int vf_scene_builtin_load(const char *name, vf_scene **out);

/* scene.c: `name` could not be read as a scene file (error err, with its detail). When
 * it looks like a scene name rather than a path (no '/', no ".json"), the detail gains the
 * list of built-in names, so a misspelt built-in says what there is. Returns err. */
int vf_scene_not_found(const char *name, int err);

#endif
