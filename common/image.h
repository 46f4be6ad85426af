/* Plain RGB images: references, environment maps, baked films and previews.
 *
 * Pixels are float RGB, 3 per pixel, row-major with the top row first (EXR's data window
 * order). Reading accepts any valid single-part EXR, scanline or tiled, with HALF, FLOAT
 * or UINT channels R, G, B (a luminance-only Y image is read as grey; A is ignored),
 * through OpenEXRCore. Writing is atomic: temporary file in the same directory, fsync,
 * rename, so a crash never leaves a half-written file. */
#ifndef VF_IMAGE_H
#define VF_IMAGE_H

#include <stddef.h>
#include <stdint.h>

typedef struct {
  int width, height;
  float *rgb; /* owned by the image; 3 * width * height floats */
} vf_image;

/* Reads path into *out (written only on success). VF_ENOENT for a missing file, VF_EEXR
 * with a detail naming the file and the problem for anything that is not a readable RGB
 * EXR (truncated, corrupt, missing channels, absurd size, deep or multi-part data). */
int vf_image_read_exr(const char *path, vf_image *out);

/* Texels of an EXR file held in memory (worker/scene/texture.c): interleaved floats of R, G, B and
 * A when it has A, or of Y (and A) for a luminance image, so *channels is 3, 4, 1 or 2; rows
 * top first. Channel rules as vf_image_read_exr; sides above max_side are refused before
 * anything is allocated. *texels (the caller frees it) and the rest are written only on
 * success. VF_EEXR with a detail naming `name`, or VF_ENOMEM. */
int vf_image_decode_exr_texels(const void *bytes, size_t size, const char *name, int max_side, int *width,
                               int *height, int *channels, float **texels);

/* Writes a FLOAT RGB scanline EXR (ZIP compression). */
int vf_image_write_exr(const char *path, const vf_image *img);

/* Writes an 8-bit sRGB PNG: value * 2^exposure, clamped, sRGB-encoded. Through libpng. */
int vf_image_write_png(const char *path, const vf_image *img, float exposure);

/* The same PNG in memory: *png (malloc'ed; the caller frees it) and *size, written only on
 * success. VF_EINVAL for no image or an exposure that is not finite, VF_ENOMEM, VF_EIO. */
int vf_image_encode_png(const vf_image *img, float exposure, uint8_t **png, size_t *size);

int vf_image_alloc(vf_image *img, int width, int height);
void vf_image_destroy(vf_image *img); /* frees rgb; NULL and zeroed images are no-ops */

#endif
