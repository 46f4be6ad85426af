/* The film: what a render accumulates, what users keep, merge and continue.
 *
 * Per pixel, in double precision, over the film's iterations:
 *   sum          sum of the pixel's estimate of each iteration (RGB): its camera sub-path
 *                plus its light-tracing frame (the light-to-camera technique splats
 *                anywhere in the image, so every iteration adds one whole frame)
 *   square_sum   sum of the squares of those estimates (RGB): with the mean it gives
 *                each pixel's variance and so an error estimate without a reference;
 *                on a film of the sobol sampler, the sum of the estimates of the even
 *                iterations instead (vf_film_sobol)
 * Every iteration adds one camera sample to every pixel (a non-finite one as zero, still
 * counted) and one light frame, so every pixel holds N = vf_iterset_count(&iterations)
 * samples and nothing per pixel needs counting: the mean radiance is sum / N.
 *
 * Beside the pixels the film carries the scene content hash, the canonical settings text,
 * the set of global iterations it contains, the render time, the scene's name and the
 * convergence log (common/convergence.h); two films merge only when scene hash and settings
 * text agree and their iteration sets are disjoint.
 *
 * The sums are exact fixed-point integers (vf_fixed): each iteration's estimate is rounded
 * once to a multiple of 2^-VF_FILM_SUM_BITS (its square to 2^-VF_FILM_SQUARE_BITS) and
 * added as an integer, so adding is associative: a film is the same bit for bit whatever
 * the order and grouping of its iterations (one render, parts merged in any order,
 * continued, read back from its file).
 *
 * On disk (docs/FILM.md): a tiled OpenEXR (64x64 tiles, ZIP) whose R, G, B channels hold
 * the mean (any viewer shows the image) and, with the other channels and the "vcmfarm:"
 * attributes, the exact integer sums.
 *
 * One module in two files: film.c holds the sums (create, add, mean, merge, estimate,
 * validate), film_file.c the file format (vf_film_write, vf_film_read). */
#ifndef VF_FILM_H
#define VF_FILM_H

#include "convergence.h"
#include "iterset.h"
#include "pool.h"

#include <stddef.h>
#include <stdint.h>

/* The version vf_film_write writes; vf_film_read reads it and versions 1 and 2. Version 3
 * is version 2 with a checksum of the whole file (common/exr_util.h), checked on every
 * read: a damaged film is refused, never merged or continued. */
#define VF_FILM_FORMAT_VERSION 4
#define VF_FILM_TILE 64

/* A sum in fixed point: a 128-bit integer counting units of 2^-bits (bits below). Adding
 * them is exact and associative, which doubles are not. */
__extension__ typedef __int128 vf_fixed;

/* The grids: sums and a sobol film's replicate sums (square_sum) in units of 2^-32
 * (2.3e-10), sums of squares in units of 2^-16 (1.5e-5): an estimate is rounded to the
 * nearest unit once, when its iteration is added. */
#define VF_FILM_SUM_BITS 32
#define VF_FILM_SQUARE_BITS 16

/* A sample (a camera or light value of one channel) of magnitude 2^33 (8.6e9) or more is
 * refused like a non-finite one (counted in nonfinite_samples, added as zero): so every
 * iteration adds less than 2^66 units to a sum and 2^84 to a sum of squares, the 128-bit
 * sums cannot overflow below 2^43 iterations, and one iteration always fits the file. */
#define VF_FILM_SAMPLE_LIMIT 8589934592.0

/* The largest magnitude, in units, a sum may have in a file of version 4 (docs/FILM.md):
 * vf_film_write refuses a film beyond it (VF_EFILM), vf_film_read a file beyond it. */
#define VF_FILM_FILE_LIMIT ((vf_fixed)1 << 85)

typedef struct {
  int width, height;
  vf_fixed *sum;        /* 3 per pixel, owned; units of 2^-VF_FILM_SUM_BITS */
  vf_fixed *square_sum; /* 3 per pixel, owned; units of 2^-vf_film_square_bits(film) */
  vf_iterset iterations; /* which global iterations it holds; their number is every pixel's count */
  uint8_t scene_hash[32];
  char settings_text[512];
  double render_seconds;      /* wall-clock time spent rendering the iterations it holds */
  double cpu_seconds;         /* process CPU time (all threads) spent rendering them */
  uint64_t nonfinite_samples; /* samples refused because they were NaN or Inf */
  uint64_t biased_merges;     /* light vertices merged with vertex merging's bias by an
                               * algorithm that is otherwise unbiased (upg's fall-backs,
                               * worker/render/photon_gathering.h): 0 when its estimated
                               * RMSE covers the whole error */
  uint8_t *samples;           /* with a pilot (vf_settings.pilot): each pixel's camera
                               * sub-paths per iteration (common/allocation.h), owned; NULL
                               * on a film of no pilot, and on one of no iteration until its
                               * pilot decided them. Films of different ones never merge */
  int pilot;                  /* 1: a film of a pilot render's iterations (of [0, pilot),
                               * common/allocation.h), which decides an allocation and is no
                               * image of its job: it has none, and merges only with pilot
                               * films (a farm job's pilot parts, coordinator/job.h) */
  char scene_name[512];       /* what to load to continue: a built-in name or a scene file's
                               * absolute path; "" when unknown. Informative: the hash decides */
  vf_convergence_log convergence; /* owned */
} vf_film;

/* Gives the film its allocation (a copy of width x height counts, common/allocation.h),
 * replacing any it had. VF_ENOMEM. */
int vf_film_set_samples(vf_film *film, const uint8_t *samples);

/* Allocates a zeroed film; *out is written only on success. */
int vf_film_create(int width, int height, vf_film **out);
void vf_film_destroy(vf_film *film);

/* Adds one iteration: camera_rgb holds one camera-path estimate per pixel, light_rgb the
 * iteration's light-tracing frame (both 3 floats per pixel, top row first). Each pixel's
 * estimate (camera + light) is rounded to the sums' grid and its square to the squares'
 * (above), once; a sample that is not finite or reaches VF_FILM_SAMPLE_LIMIT counts as zero. Adds the
 * iteration index to the set (VF_EOVERLAP, film unchanged, if it is already there).
 * Pixels are added in parallel over the pool's threads when pool is not NULL (the sums
 * are per pixel, so the film is the same bit for bit either way). */
int vf_film_add_iteration(vf_film *film, uint64_t iteration, const float *camera_rgb, const float *light_rgb,
                          vf_pool *pool);

/* One pixel's terms of an iteration, as vf_film_add_iteration adds them (and
 * vf_film_accum_add_iteration, film_accum.h): its estimate camera + light (3 floats each)
 * rounded once to the sums' grid into sum, and into square its square rounded to the
 * squares' grid (second_moment) or the same as sum (a sobol film's replicate sums); a
 * sample that is not finite or reaches VF_FILM_SAMPLE_LIMIT counts as zero. Returns the
 * number of samples so refused (0 to 2). */
int vf_film_pixel_terms(const float *camera, const float *light, int second_moment, vf_fixed sum[3],
                        vf_fixed square[3]);

/* 2^-bits for the grids' bits (a power of two: scaling by it is exact). */
static inline double vf_fixed_unit(int bits) { return bits == VF_FILM_SUM_BITS ? 0x1p-32 : 0x1p-16; }

/* x rounded to the nearest multiple of 2^-bits (ties to even), in those units; bits is
 * VF_FILM_SUM_BITS or VF_FILM_SQUARE_BITS, x finite and below 2^(126 - bits) in magnitude. */
vf_fixed vf_fixed_from_double(double x, int bits);

/* The value of v units of 2^-bits (bits as above), rounded to the nearest double. Inline
 * and without a 128-bit conversion for the sums that fit 64 bits (all but huge ones): it
 * runs once per value when a film is written or measured. */
static inline double vf_fixed_to_double(vf_fixed v, int bits) {
  long long small = (long long)v;
  return (small == v ? (double)small : (double)v) * vf_fixed_unit(bits);
}

/* The units of square_sum: VF_FILM_SUM_BITS for a film of the sobol sampler (it holds sums
 * of estimates), VF_FILM_SQUARE_BITS for the others (sums of squares). */
int vf_film_square_bits(const vf_film *film);
int vf_film_square_bits_of(const char *settings_text);
/* Value i (3 per pixel) of sum and square_sum as doubles (rounded to nearest). */
double vf_film_sum_at(const vf_film *film, size_t i);
double vf_film_square_at(const vf_film *film, size_t i);

/* Mean radiance (sum / N), 3 floats per pixel, into rgb; 0 when the film is empty. */
void vf_film_mean(const vf_film *film, float *rgb);
/* The same for the one pixel p (y * width + x). */
void vf_film_pixel_mean(const vf_film *film, size_t p, float rgb[3]);

/* dst += src. VF_EMISMATCH (size, scene hash, settings) or VF_EOVERLAP (iteration sets),
 * with dst unchanged, when they cannot be merged. Times add up; dst keeps its scene name
 * (src's if dst has none); src's convergence log is appended to dst's as further runs
 * (common/convergence.h); the counts add up (VF_EFILM, dst unchanged, should biased_merges
 * overflow 64 bits: only a forged film can get there). Allocations (samples) must be the
 * same where both have one (VF_EMISMATCH); dst takes src's where it has none. A pilot film
 * and a film of the job's image never merge (VF_EMISMATCH). */
int vf_film_merge(vf_film *dst, const vf_film *src);

/* vf_film_merge in two steps, for a caller that adds the pixels on another thread: the
 * checks and everything but the pixels (iteration set, log, times, counts), with the same
 * errors and dst unchanged on error; then the pixels alone, which cannot fail. Together
 * they leave dst exactly as vf_film_merge does. */
int vf_film_merge_metadata(vf_film *dst, const vf_film *src);
void vf_film_add_pixels(vf_film *dst, const vf_film *src);
/* Zeroes every pixel's sums (nothing else): the pages of a large film's sums go back to the
 * kernel until written again, so an emptied film costs no memory while it waits (a worker's
 * film between parts). */
void vf_film_clear_pixels(vf_film *film);

/* A copy of everything of film but its pixels (sum and square_sum NULL): for a caller that
 * writes a film's pixels as they are with the metadata of a moment (a checkpoint written on
 * the thread that alone changes the pixels). Point sum and square_sum at the pixels to
 * write, and back to NULL before vf_film_destroy. *out on success only; VF_ENOMEM. */
int vf_film_clone_metadata(const vf_film *film, vf_film **out);

/* A deep copy of film into *out (written only on success); VF_EINVAL or VF_ENOMEM. */
int vf_film_clone(const vf_film *film, vf_film **out);

/* The estimated RMSE of the film's mean image, without a reference (docs/FILM.md): per pixel
 * and channel, the sample variance of the per-iteration estimates from square_sum and sum,
 * divided by the number of iterations, averaged over pixels and channels, square-rooted.
 * NaN when the film holds fewer than 2 iterations. Uses only sums, so it is the same for a
 * merged or continued film as for one rendered in one go. */
double vf_film_estimate_rmse(const vf_film *film);

/* Whether the film's settings name the sobol sampler (common/sampler.h). Its square_sum
 * then holds not the squares but the sum of the estimates of the iterations of replicate
 * 0 (even global indices), which is what its error estimate needs (above) and, like the
 * squares, adds up exactly under merging. */
int vf_film_sobol(const vf_film *film);
/* The iterations of the set in a sobol film's replicate 0 (even indices). */
uint64_t vf_iterset_even_count(const vf_iterset *set);

/* The spread of one iteration's estimate of value i (a pixel's channel) of a film of n
 * iterations (n >= 2), n0 of them even (sobol: the two replicates' counts, both > 0):
 * with the sobol sampler n0 (m0 - m)^2 + n1 (m1 - m)^2 over the replicates' means m0, m1
 * and the film's m; else the sample variance of the estimates (0 where rounding makes it
 * negative). vf_film_estimate_rmse averages it over n; the allocation of camera sub-paths
 * (common/allocation.c) sums it per pixel. */
static inline double vf_film_value_spread(const vf_film *film, size_t i, int sobol, double n, double n0) {
  double m = vf_film_sum_at(film, i) / n;
  if (sobol) {
    double n1 = n - n0, m0 = vf_fixed_to_double(film->square_sum[i], VF_FILM_SUM_BITS) / n0;
    double m1 = vf_fixed_to_double(film->sum[i] - film->square_sum[i], VF_FILM_SUM_BITS) / n1;
    return n0 * (m0 - m) * (m0 - m) + n1 * (m1 - m) * (m1 - m);
  }
  double variance = (vf_fixed_to_double(film->square_sum[i], VF_FILM_SQUARE_BITS) - n * m * m) / (n - 1.0);
  return variance > 0.0 ? variance : 0.0; /* < 0 only through rounding */
}

/* Checks the invariants every film built by this module keeps: no sums without
 * iterations (a film of N = 0 holds zeros), square sums >= 0, times finite and >= 0, an
 * allocation of valid counts where the settings have a pilot and the film an iteration
 * (and none where they have no pilot; a pilot film has none, a pilot in its settings and
 * only iterations of [0, pilot)),
 * non-finite samples at most two per pixel and iteration, texts terminated, the convergence log valid (vf_convergence_validate). VF_EFILM with a
 * detail "NAME: problem" (name is e.g. the file path) when one does not hold. */
int vf_film_validate(const vf_film *film, const char *name);

/* ---- the file (film_file.c, docs/FILM.md) ---- */

/* Atomic write (common/atomic_file.h: temporary file, fsync, rename, fsync of the directory)
 * in format VF_FILM_FORMAT_VERSION. Never leaves a partial file at path. VF_EFILM for a
 * film that breaks an invariant or holds a value beyond float range, VF_EIO, VF_EEXR.
 * Tiles are filled and compressed on one thread per CPU. */
int vf_film_write(const vf_film *film, const char *path);

/* The same in format `version`: 2, or 1 (uncompressed, camera_sum = sum, light_sum = 0,
 * every count N) for builds that read only version 1. VF_EINVAL for other versions. */
int vf_film_write_version(const vf_film *film, const char *path, int version);

/* Reads and validates a film of version 1 to 4 (versions 1 to 3 held doubles to 48 bits:
 * their sums are rounded to the grids once, here). VF_ENOENT, or VF_EEXR / VF_EFILM with a
 * detail naming the file and the problem (not a film, missing channel, a version-1 pixel
 * whose camera count is not the film's number of iterations, bad attribute...). */
int vf_film_read(const char *path, vf_film **out);

/* The format version of the film file at path (1 or 2), from its header alone; fails
 * like vf_film_read on a file that is not a film of a known version. */
int vf_film_read_version(const char *path, int *version);

#endif
