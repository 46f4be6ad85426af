/* A film's pixels in half the memory: what a worker accumulates between the parts it ships.
 *
 * A film (film.h) holds per pixel six 128-bit fixed-point sums, 96 bytes, which no sum of a
 * worker's part comes near: a part is a few iterations, and an estimate of radiance 1 is
 * 2^32 units. The accumulator holds the same sums as 64-bit integers of the same units (48
 * bytes a pixel): each iteration's estimate is rounded exactly as vf_film_add_iteration
 * rounds it (vf_film_pixel_terms, film.c), so the integers are the film's own. A value
 * whose addition would leave int64 (a sum past 2^63 units, 2.1e9 in radiance; one estimate
 * of a huge emitter, which may alone be 2^65) is never wrapped: the slot's value and the
 * addend move, as a 128-bit sum, to a side table of the few values that need it, and the
 * slot starts again from 0. The film's value is slot + side entry, exactly, whatever the
 * grouping of iterations that led there.
 *
 * A film and an accumulator together stand for one film whose sums are film + accumulator
 * (vf_film_accum_rect reads the accumulator's): the render loop adds a worker's iterations
 * here and the rest of each iteration (its index, counts, times) to the film, whose own sums stay zero and so
 * are never touched; the worker ships the part's tiles from both (film_wire.h,
 * vf_film_send_tiles_pending), and empties both. */
#ifndef VF_FILM_ACCUM_H
#define VF_FILM_ACCUM_H

#include "film.h"
#include "pool.h"

#include <stddef.h>
#include <stdint.h>

typedef struct vf_film_accum vf_film_accum;

/* A zeroed accumulator of width x height pixels; *out on success only; VF_EINVAL (size
 * outside a film's) or VF_ENOMEM. */
int vf_film_accum_create(int width, int height, vf_film_accum **out);
void vf_film_accum_destroy(vf_film_accum *a);

/* vf_film_add_iteration with the pixels going to a instead of film's sums: the iteration's
 * index goes into film's set (VF_EOVERLAP, nothing changed, if it is there), its refused
 * samples into film's count, its estimates (same rounding, same rules, same units: film's
 * settings say whether square_sum takes squares or a sobol film's replicate sums) into a.
 * VF_EMISMATCH when the sizes differ; VF_ENOMEM (the iteration then in neither) when the
 * side table cannot grow. Parallel over pool's threads when pool is not NULL. */
int vf_film_accum_add_iteration(vf_film_accum *a, vf_film *film, uint64_t iteration, const float *camera_rgb,
                                const float *light_rgb, vf_pool *pool);

/* The exact sums of the rectangle (x0, y0, w, h), into sum and square_sum (3 values a
 * pixel, rows of w pixels, top first). */
void vf_film_accum_rect(const vf_film_accum *a, int x0, int y0, int w, int h, vf_fixed *sum, vf_fixed *square_sum);

/* Adds a into film's sums (same size) and empties a. */
void vf_film_accum_carry(vf_film_accum *a, vf_film *film);

/* Zeroes every value; the pages of the arrays go back to the kernel until written again. */
void vf_film_accum_clear(vf_film_accum *a);

/* Values held in the side table (those that left int64). */
size_t vf_film_accum_spilled(const vf_film_accum *a);

/* For tests: values beyond +-limit (> 0) in a slot move to the side table, as those beyond
 * int64 do (INT64_MAX, the default), so that small renders take that path. */
void vf_film_accum_set_limit(vf_film_accum *a, int64_t limit);

#endif
