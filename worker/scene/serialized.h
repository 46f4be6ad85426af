/* Mitsuba's serialized meshes (serialized.c): one mesh of a .serialized file's bytes, in
 * the single-indexed encoding of format versions 3 and 4 (Mitsuba 0.x and 3.x), for a JSON
 * mesh whose "file" ends in .serialized (shapes.c). Private to worker/scene/. */
#ifndef VF_SCENE_SERIALIZED_H
#define VF_SCENE_SERIALIZED_H

#include "scene.h"

#include <stddef.h>
#include <stdint.h>

/* 1 if file ends in .serialized (any case). */
int vf_serialized_is_serialized(const char *file);

/* Decodes mesh `index` of the n bytes of a serialized file into s: positions, indices and,
 * as the file has them, unit normals and texture coordinates as stored (Mitsuba's v, whose
 * 0 is an image's top row, is vcmfarm's t). *has_colors says whether it had vertex colours
 * (not kept). Errors (VF_EMESH, VF_ENOMEM) name `what`: not a serialized file, another
 * version, a damaged stream or table, an index beyond the file's meshes, a non-finite
 * value, a zero normal, a vertex index out of range. s is written only on success. */
int vf_serialized_decode(const uint8_t *data, size_t n, long index, const char *what, vf_shape *s, int *has_colors);

#endif
