/* Private to common/: a film's sums as the channels of its file format (docs/FILM.md),
 * one rectangle of pixels at a time. film_file.c writes and reads files through these,
 * film_wire.c sends tiles with them, so a tile on the wire holds what the tile of a film
 * file holds.
 *
 * Version 4 (exact): per value (sum and square_sum of R, G, B), a FLOAT high part hi (R, G,
 * B: the mean sum / N, which viewers show; square.R/G/B: square_sum / N) and the rest of
 * the fixed-point sum beyond it, an exact 64-bit integer in two UINT channels:
 *     base = floor(N * hi * 2^bits)   (computed exactly in integers)
 *     rest = sum - base               (|rest| < |sum| 2^-23 + 2, so below 2^63)
 * zigzag-coded (0, -1, 1, -2 ... as 0, 1, 2, 3 ...) into rest0 (low 32 bits) and rest1 (high
 * 32 bits), so that small rests leave zero bytes for the compressor. Any hi reads back to
 * the same sum; the writer's is the float nearest the mean, so that rest stays small.
 *
 * Versions 2 and 3 (read, and written on request): hi = (float)(sum / N), lo = (float)(sum
 * - N hi) per value, about 48 significant bits, rounded to the grids when read.
 * Version 1: hi/lo float pairs of camera_sum, camera_count, light_sum and square_sum. */
#ifndef VF_FILM_PLANES_H
#define VF_FILM_PLANES_H

#include "film.h"

/* The channels of version 4, in the order the file lists them (sorted by name); those of
 * VF_FILM_V4_UINT_MASK are UINT, the others FLOAT. */
#define VF_FILM_V4_CHANNELS 18
#define VF_FILM_V4_UINT_MASK ((uint64_t)0x3FFC0) /* channels 6 to 17 */
extern const char *const vf_film_v4_channels[VF_FILM_V4_CHANNELS];

/* The channels of versions 2 and 3, in the order the file lists them. */
#define VF_FILM_V2_CHANNELS 12
extern const char *const vf_film_v2_channels[VF_FILM_V2_CHANNELS];

/* The channels of version 1: R, G, B (the mean, written, never read), then the 20
 * accumulation channels read back. */
#define VF_FILM_V1_CHANNELS 23
#define VF_FILM_V1_ACCUM 20
extern const char *const vf_film_v1_channels[VF_FILM_V1_CHANNELS];

/* Sums of pixels, 3 per pixel, rows of `width` pixels: a film's, or a tile's. The
 * channels depend on the number of iterations they hold and the units of square_sum. */
typedef struct {
  vf_fixed *sum, *square_sum;
  int width;
  uint64_t iterations;
  int square_bits; /* vf_film_square_bits */
} vf_film_sums;

/* A film's sums (no copy). */
vf_film_sums vf_film_sums_of(const vf_film *film);

/* planes[i] (w*h values, rows top first) receives channel i of the rectangle at (x0, y0).
 * 1 when every value fitted, 0 when one is beyond the format's range (VF_FILM_FILE_LIMIT
 * in version 4, a float's range before): the caller must not keep what it wrote;
 * vf_film_planes_check_range names the pixel. */
int vf_film_planes_fill_v4(vf_film_sums s, int x0, int y0, int w, int h, float *const *planes);
int vf_film_planes_fill(vf_film_sums s, int x0, int y0, int w, int h, float *const *planes);
int vf_film_planes_fill_v1(vf_film_sums s, int x0, int y0, int w, int h, float *const *planes);

/* The inverse: the rectangle's sums from planes[i] of channel i (version 1: the 20
 * accumulation channels). VF_EFILM with a detail "NAME: pixel (x, y): ..." for a value
 * that is not finite or beyond the film's range, and (version 1) a pixel whose camera
 * count is not the number of iterations: such a film cannot be held without counts. */
int vf_film_planes_store_v4(vf_film_sums s, const char *name, int x0, int y0, int w, int h,
                            const float *const *planes);
int vf_film_planes_store(vf_film_sums s, const char *name, int x0, int y0, int w, int h, const float *const *planes);
int vf_film_planes_store_v1(vf_film_sums s, const char *name, int x0, int y0, int w, int h, const float *const *planes);

/* VF_EFILM ("NAME: pixel P holds V, beyond the film format's range") when a value of the
 * film cannot be written in version `version`. */
int vf_film_planes_check_range(const vf_film *film, int version, const char *name);

#endif
