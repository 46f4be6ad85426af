/* Textures: images that materials read at texture coordinates (worker/scene/material.h slots).
 *
 * A texture is stored as decoded: 8-bit PNG and JPEG texels as bytes (1 byte per channel,
 * converted to linear values at lookup, through sRGB decoding for colour slots), EXR
 * texels as 32-bit floats. 16-bit PNGs are reduced to 8 bits per channel. The texture's
 * hash is that of the file's bytes, so that equal files give equal scene hashes. Lookups
 * are the renderer's (worker/render/texture_lookup.h). */
#ifndef VF_TEXTURE_H
#define VF_TEXTURE_H

#include <stddef.h>
#include <stdint.h>

/* Wrap modes for coordinates outside [0, 1] (glTF sampler wrapS/wrapT). */
enum { VF_WRAP_REPEAT, VF_WRAP_CLAMP, VF_WRAP_MIRROR };

typedef struct {
  char name[256];         /* the file name the scene gave, or "FILE#N" for an embedded image */
  uint32_t width, height; /* >= 1 */
  int channels;           /* 1 (grey), 2 (grey, alpha), 3 (RGB), 4 (RGBA) */
  int is_float;           /* texels are float (EXR), else uint8_t */
  void *texels;           /* width * height * channels, row 0 at the top (t = 0), owned */
  uint8_t hash[32];       /* BLAKE2b-256 of the encoded file bytes */
} vf_texture;

/* Decodes a PNG, JPEG or EXR image (told apart by their first bytes, not by the name) of
 * `size` bytes into *out; `name` is used in errors and kept in out->name. VF_ETEXTURE with
 * a detail naming `name` and the problem ("unsupported texture format", a decoder's
 * message, zero or too large dimensions: each side at most 32768 texels and the whole
 * image at most 2^28 texels), or VF_ENOMEM. *out is written only on success. */
int vf_texture_decode(const void *bytes, size_t size, const char *name, vf_texture *out);

/* Reads the file at `path` and decodes it; VF_ENOENT when it cannot be opened (the
 * detail names `name` and strerror), else as vf_texture_decode. */
int vf_texture_read(const char *path, const char *name, vf_texture *out);

void vf_texture_release(vf_texture *t);

/* Bytes the texels take in memory. */
size_t vf_texture_bytes(const vf_texture *t);

#endif
