/* Textures: decoding and lookup (worker/texture.h). */
#include "texture.h"

#include <stdlib.h>
#include <string.h>

void vf_texture_release(vf_texture *t) {
  free(t->texels);
  memset(t, 0, sizeof *t);
}

size_t vf_texture_bytes(const vf_texture *t) {
  return (size_t)t->width * t->height * (size_t)t->channels * (t->is_float ? sizeof(float) : 1);
}
