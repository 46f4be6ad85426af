/* Textures of a scene (textures.h): decoded once per name into scene->textures, from
 * files resolved as mesh files are, or from bytes embedded in another file. */
#include "textures.h"

#include "../../common/error.h"

#include <stdlib.h>
#include <string.h>

/* The 1-based index of the texture called `name`, 0 when there is none yet. */
static int find_texture(const vf_scene *s, const char *name) {
  for (int i = 0; i < s->num_textures; i++)
    if (strcmp(s->textures[i].name, name) == 0) return i + 1;
  return 0;
}

static int check_name(const parse_ctx *c, const char *name, const char *path) {
  const size_t max = sizeof c->scene->textures[0].name; /* vf_texture.name keeps it whole */
  if (name[0] == '\0' || strlen(name) >= max)
    return vf_scene_fail(c, VF_ESCENE, path, "a texture name must have 1 to %zu bytes", max - 1);
  return VF_OK;
}

/* Appends *t (taken on success, released on failure) to the scene's textures. */
static int add_texture(const parse_ctx *c, vf_texture *t, int *index) {
  vf_scene *s = c->scene;
  vf_texture *grown = realloc(s->textures, ((size_t)s->num_textures + 1) * sizeof *grown);
  if (grown == NULL) {
    vf_texture_release(t);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  s->textures = grown;
  s->textures[s->num_textures++] = *t;
  *index = s->num_textures;
  return VF_OK;
}

/* The decoder's detail already starts with the file's name: prefixed with the scene and
 * the field it becomes "LABEL: PATH: FILE: problem". */
static int texture_fail(const parse_ctx *c, int err, const char *path) {
  return vf_scene_fail(c, err, path, "%s", vf_error_detail(err));
}

int vf_scene_texture_file(const parse_ctx *c, const char *file, const char *path, int *index) {
  char full[4096];
  vf_texture t;
  int err = check_name(c, file, path);
  if (err < 0) return err;
  if ((*index = find_texture(c->scene, file)) > 0) return VF_OK;
  /* Built-in scenes carry their files in memory, as they do their meshes. */
  for (int i = 0; i < c->num_memfiles; i++)
    if (strcmp(c->memfiles[i].name, file) == 0) {
      if ((err = vf_texture_decode(c->memfiles[i].data, c->memfiles[i].size, file, &t)) < 0)
        return texture_fail(c, err, path);
      return add_texture(c, &t, index);
    }
  /* Resolving records the file on `submit` and maps it to its blob on a worker. */
  if ((err = vf_scene_resolve(c, file, path, full, sizeof full)) < 0) return err;
  if ((err = vf_texture_read(full, file, &t)) < 0) return texture_fail(c, err, path);
  return add_texture(c, &t, index);
}

int vf_scene_texture_bytes(const parse_ctx *c, const char *name, const void *bytes, size_t size, const char *path,
                           int *index) {
  vf_texture t;
  int err = check_name(c, name, path);
  if (err < 0) return err;
  if ((*index = find_texture(c->scene, name)) > 0) return VF_OK;
  if ((err = vf_texture_decode(bytes, size, name, &t)) < 0) return texture_fail(c, err, path);
  return add_texture(c, &t, index);
}
