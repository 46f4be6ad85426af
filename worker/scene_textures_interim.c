/* INTERIM, to be deleted when worker/scene_textures.c lands from the texture branch: the
 * least of vf_scene_texture_file / vf_scene_texture_bytes (scene_parse.h) that lets the
 * importer be tested: 8-bit PNG only, through libpng's simplified API. */
#include "scene_parse.h"

#include "../common/error.h"

#include <png.h>
#include <sodium.h>

#include <errno.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static int find(const vf_scene *s, const char *name) {
  for (int i = 0; i < s->num_textures; i++)
    if (strcmp(s->textures[i].name, name) == 0) return i + 1;
  return 0;
}

static int decode_png(const void *bytes, size_t size, const char *name, vf_texture *out) {
  png_image img;
  memset(&img, 0, sizeof img);
  img.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&img, bytes, size))
    return vf_error_set(VF_ETEXTURE, "'%s': unsupported texture format (%s)", name, img.message);
  int channels = PNG_IMAGE_SAMPLE_CHANNELS(img.format);
  img.format = channels == 1 ? PNG_FORMAT_GRAY : channels == 2 ? PNG_FORMAT_GA : channels == 3 ? PNG_FORMAT_RGB
                                                                                              : PNG_FORMAT_RGBA;
  channels = PNG_IMAGE_SAMPLE_CHANNELS(img.format);
  uint8_t *texels = malloc((size_t)img.width * img.height * (size_t)channels);
  if (texels == NULL) {
    png_image_free(&img);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  if (!png_image_finish_read(&img, NULL, texels, 0, NULL)) {
    free(texels);
    return vf_error_set(VF_ETEXTURE, "'%s': %s", name, img.message);
  }
  memset(out, 0, sizeof *out);
  snprintf(out->name, sizeof out->name, "%s", name);
  out->width = img.width;
  out->height = img.height;
  out->channels = channels;
  out->texels = texels;
  crypto_generichash(out->hash, sizeof out->hash, bytes, size, NULL, 0);
  return VF_OK;
}

static int add(const parse_ctx *c, const char *name, const void *bytes, size_t size, const char *path, int *index) {
  vf_scene *s = c->scene;
  vf_texture t;
  int err = decode_png(bytes, size, name, &t);
  if (err < 0) return vf_scene_fail(c, err, path, "%s", vf_error_detail(err));
  vf_texture *grown = realloc(s->textures, (size_t)(s->num_textures + 1) * sizeof *grown);
  if (grown == NULL) {
    vf_texture_release(&t);
    return vf_error_set(VF_ENOMEM, "out of memory");
  }
  s->textures = grown;
  s->textures[s->num_textures++] = t;
  *index = s->num_textures;
  return VF_OK;
}

int vf_scene_texture_file(const parse_ctx *c, const char *file, const char *path, int *index) {
  char full[4096];
  if ((*index = find(c->scene, file)) != 0) return VF_OK;
  int err = vf_scene_resolve(c, file, path, full, sizeof full);
  if (err < 0) return err;
  FILE *f = fopen(full, "rb");
  if (f == NULL) return vf_scene_fail(c, VF_ENOENT, path, "cannot open texture '%s': %s", file, strerror(errno));
  uint8_t *bytes = NULL;
  size_t n = 0, cap = 0, got;
  do {
    if (n == cap) {
      uint8_t *g = realloc(bytes, cap = cap ? 2 * cap : 65536);
      if (g == NULL) {
        free(bytes);
        fclose(f);
        return vf_error_set(VF_ENOMEM, "out of memory");
      }
      bytes = g;
    }
    got = fread(bytes + n, 1, cap - n, f);
    n += got;
  } while (got > 0);
  fclose(f);
  err = add(c, file, bytes, n, path, index);
  free(bytes);
  return err;
}

int vf_scene_texture_bytes(const parse_ctx *c, const char *name, const void *bytes, size_t size, const char *path,
                           int *index) {
  if ((*index = find(c->scene, name)) != 0) return VF_OK;
  return add(c, name, bytes, size, path, index);
}
