/* A scene's textures (textures.c): each file or embedded image decoded once per name into
 * scene->textures. Private to worker/scene/. */
#ifndef VF_SCENE_TEXTURES_H
#define VF_SCENE_TEXTURES_H

#include "parse.h"

#include <stddef.h>

/* Texture `file`, resolved as mesh files are (so a farm job ships it by content hash, and
 * a recording load records it), decoded into the scene's textures once per name: its
 * 1-based index (vf_texture_slot.texture) into *index. Errors as vf_texture_read, the
 * detail naming the scene, the field at `path` and the file. */
int vf_scene_texture_file(const parse_ctx *c, const char *file, const char *path, int *index);
/* An image embedded in a file (a glTF binary's buffer view, a data URI), named `name`
 * ("model.glb#2"): decoded once per name as above. */
int vf_scene_texture_bytes(const parse_ctx *c, const char *name, const void *bytes, size_t size, const char *path,
                           int *index);

#endif
