/* Texture lookups (texture_lookup.c): bilinear filtering of a decoded texture
 * (worker/scene/texture.h) at texture coordinates, with the wrap modes of glTF samplers,
 * and the prefetch of the texels a lookup will read. The renderer's side of textures;
 * decoding is the scene library's. */
#ifndef VF_TEXTURE_LOOKUP_H
#define VF_TEXTURE_LOOKUP_H

#include "../scene/texture.h"

/* Bilinear lookup at texture coordinates (s, t): s grows to the right, t downwards, (0, 0)
 * is the top-left corner of the image and texel (i, j) has its centre at
 * ((i + 0.5) / width, (j + 0.5) / height). Coordinates are wrapped per axis by wrap_s and
 * wrap_t (VF_WRAP_*), the four texels of the filter included. out is RGBA in linear
 * values: grey is copied to R, G and B; a missing alpha is 1; 8-bit channels are v / 255,
 * or with `srgb` the colour channels (not alpha) are decoded from sRGB. Non-finite
 * coordinates give texel (0, 0). */
void vf_texture_lookup(const vf_texture *t, float s, float t_coord, int wrap_s, int wrap_t, int srgb, float out[4]);

/* Channel `channel` (0..3 of the RGBA that vf_texture_lookup gives, linear) alone: the same
 * value as vf_texture_lookup's out[channel] without sRGB, for one quarter of the work. Alpha
 * cut-outs test it for every candidate hit of every ray. */
float vf_texture_lookup_channel(const vf_texture *t, float s, float t_coord, int wrap_s, int wrap_t, int channel);

/* Starts the loads of the texels vf_texture_lookup at (s, t_coord) will read, and returns
 * without waiting for them: a renderer that knows its next lookups early issues them all
 * at once, so that their cache misses overlap instead of following one another. */
void vf_texture_prefetch(const vf_texture *t, float s, float t_coord, int wrap_s, int wrap_t);

#endif
