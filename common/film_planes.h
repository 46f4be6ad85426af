/* Private to common/: a film's sums as the float channels of its file format
 * (docs/FILM.md), one rectangle of pixels at a time. film_file.c writes and reads files
 * through these, film_wire.c sends tiles with them, so a tile on the wire holds what the
 * tile of a film file holds.
 *
 * Version 2: R, G, B = (float)(sum / N) is the mean for viewers and the high part of sum;
 * sum.lo = (float)(sum - N * R) the rest, and likewise square, square.lo for square_sum
 * (N is the film's number of iterations, 1 when it has none). N * R is within a float's
 * rounding of sum, so the difference is exact and its float keeps sum's next 24 bits:
 * about 48 significant bits in all, read back as N * R + sum.lo.
 *
 * Version 1: hi/lo float pairs of camera_sum, camera_count, light_sum and square_sum. */
#ifndef VF_FILM_PLANES_H
#define VF_FILM_PLANES_H

#include "film.h"

/* The channels of version 2, in the order the file lists them (sorted by name). */
#define VF_FILM_V2_CHANNELS 12
extern const char *const vf_film_v2_channels[VF_FILM_V2_CHANNELS];

/* The channels of version 1: R, G, B (the mean, written, never read), then the 20
 * accumulation channels read back. */
#define VF_FILM_V1_CHANNELS 23
#define VF_FILM_V1_ACCUM 20
extern const char *const vf_film_v1_channels[VF_FILM_V1_CHANNELS];

/* Sums of pixels, 3 per pixel, rows of `width` pixels: a film's, or a tile's. The
 * version-2 channels depend on the number of iterations they hold. */
typedef struct {
  double *sum, *square_sum;
  int width;
  uint64_t iterations;
} vf_film_sums;

/* A film's sums (no copy). */
vf_film_sums vf_film_sums_of(const vf_film *film);

/* planes[i] (w*h floats, rows top first) receives channel i of the rectangle at (x0, y0).
 * 1 when every value fitted, 0 when a high part overflowed a float (written as Inf: the
 * caller must not keep what it wrote; vf_film_planes_check_range names the pixel). */
int vf_film_planes_fill(vf_film_sums s, int x0, int y0, int w, int h, float *const *planes);
int vf_film_planes_fill_v1(vf_film_sums s, int x0, int y0, int w, int h, float *const *planes);

/* The inverse: the rectangle's sums from planes[i] of channel i (version 1: the 20
 * accumulation channels). The version-1 store refuses (VF_EFILM, detail "NAME: pixel (x,
 * y): ...") a pixel whose camera count is not the number of iterations: such a film
 * cannot be held without counts. */
void vf_film_planes_store(vf_film_sums s, int x0, int y0, int w, int h, const float *const *planes);
int vf_film_planes_store_v1(vf_film_sums s, const char *name, int x0, int y0, int w, int h, const float *const *planes);

/* VF_EFILM ("NAME: pixel P holds V, beyond the film format's float range") when a value
 * of the film cannot be written in version `version`. */
int vf_film_planes_check_range(const vf_film *film, int version, const char *name);

#endif
