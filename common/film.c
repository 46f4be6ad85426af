/* The film's sums: accumulation, merging, the mean, the error estimate and the invariants
 * (docs/FILM.md). The file format lives in film_file.c.
 *
 * Accumulation is in fixed point (film.h): each estimate is rounded to its grid once, when
 * its iteration is added, and from there on everything is integer addition, exact and
 * associative. Doubles were not: (a + b) + c and a + (b + c) differ in the last bit, so a
 * farm's parts, a continued film and one render of the same iterations disagreed there. */
#include "film.h"

#include "allocation.h"

#include "settings.h"

#include "error.h"
#include "exr_util.h" /* VF_EXR_MAX_SIDE, VF_EXR_MAX_PIXELS: a film must fit in its file */

#include <inttypes.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>

/* Sums of large films are mapped with huge pages where the kernel allows them: a 4K film's
 * 400 MB otherwise cost 200,000 page faults on first touch, about a third of the time to
 * read its file. Small ones come from malloc. Both start zeroed. */
#define MAPPED_SUMS_BYTES ((size_t)4 << 20)

static vf_fixed *sums_alloc(size_t bytes) {
  if (bytes < MAPPED_SUMS_BYTES) return calloc(1, bytes);
  void *p = mmap(NULL, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  if (p == MAP_FAILED) return NULL;
  madvise(p, bytes, MADV_HUGEPAGE); /* a hint: refused, the pages are small */
  return p;
}

static void sums_free(vf_fixed *sums, size_t bytes) {
  if (sums == NULL) return;
  if (bytes < MAPPED_SUMS_BYTES) free(sums);
  else munmap(sums, bytes);
}

static size_t sums_bytes(const vf_film *film) { return 3 * (size_t)film->width * (size_t)film->height * sizeof(vf_fixed); }

/* Zeroes sums: a mapped array's pages go back to the kernel, to be zero-filled when touched
 * again (a private anonymous mapping), so that an empty film costs no memory. */
static void sums_clear(vf_fixed *sums, size_t bytes) {
  if (bytes < MAPPED_SUMS_BYTES || madvise(sums, bytes, MADV_DONTNEED) != 0) memset(sums, 0, bytes);
}

void vf_film_clear_pixels(vf_film *film) {
  sums_clear(film->sum, sums_bytes(film));
  sums_clear(film->square_sum, sums_bytes(film));
}

int vf_film_create(int width, int height, vf_film **out) {
  if (out == NULL || width < 1 || height < 1 || width > VF_EXR_MAX_SIDE || height > VF_EXR_MAX_SIDE ||
      (int64_t)width * height > VF_EXR_MAX_PIXELS)
    return vf_error_set(VF_EINVAL, "film size %dx%d is outside 1x1 .. 65536x65536 (at most 2^28 pixels)", width,
                        height);
  vf_film *film = calloc(1, sizeof *film);
  if (film == NULL) goto fail_film;
  film->width = width;
  film->height = height;
  if ((film->sum = sums_alloc(sums_bytes(film))) == NULL) goto fail_sum;
  if ((film->square_sum = sums_alloc(sums_bytes(film))) == NULL) goto fail_square;
  vf_iterset_init(&film->iterations);
  vf_convergence_init(&film->convergence);
  *out = film;
  return VF_OK;
fail_square:
  sums_free(film->sum, sums_bytes(film));
fail_sum:
  free(film);
fail_film:
  return vf_error_set(VF_ENOMEM, "out of memory for a %dx%d film", width, height);
}

void vf_film_destroy(vf_film *film) {
  if (film == NULL) return;
  free(film->samples);
  vf_iterset_destroy(&film->iterations);
  vf_convergence_destroy(&film->convergence);
  sums_free(film->square_sum, sums_bytes(film));
  sums_free(film->sum, sums_bytes(film));
  free(film);
}

int vf_film_clone_metadata(const vf_film *film, vf_film **out) {
  if (film == NULL || out == NULL) return vf_error_set(VF_EINVAL, "vf_film_clone_metadata: NULL argument");
  vf_film *copy = calloc(1, sizeof *copy);
  if (copy == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a film");
  copy->width = film->width;
  copy->height = film->height;
  vf_iterset_init(&copy->iterations);
  vf_convergence_init(&copy->convergence);
  int err = vf_iterset_copy(&copy->iterations, &film->iterations);
  if (err == VF_OK) err = vf_convergence_copy(&copy->convergence, &film->convergence);
  if (err != VF_OK) {
    vf_film_destroy(copy);
    return err;
  }
  memcpy(copy->scene_hash, film->scene_hash, sizeof copy->scene_hash);
  memcpy(copy->settings_text, film->settings_text, sizeof copy->settings_text);
  copy->render_seconds = film->render_seconds;
  copy->cpu_seconds = film->cpu_seconds;
  copy->nonfinite_samples = film->nonfinite_samples;
  copy->biased_merges = film->biased_merges;
  copy->pilot = film->pilot;
  memcpy(copy->scene_name, film->scene_name, sizeof copy->scene_name);
  if (film->samples != NULL && (err = vf_film_set_samples(copy, film->samples)) != VF_OK) {
    vf_film_destroy(copy);
    return err;
  }
  *out = copy;
  return VF_OK;
}

int vf_film_set_samples(vf_film *film, const uint8_t *samples) {
  size_t n = (size_t)film->width * (size_t)film->height;
  uint8_t *copy = malloc(n);
  if (copy == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a %dx%d film's allocation", film->width, film->height);
  memcpy(copy, samples, n);
  free(film->samples);
  film->samples = copy;
  return VF_OK;
}

int vf_film_clone(const vf_film *film, vf_film **out) {
  if (film == NULL || out == NULL) return vf_error_set(VF_EINVAL, "vf_film_clone: NULL argument");
  vf_film *copy = NULL;
  int err = vf_film_clone_metadata(film, &copy);
  if (err != VF_OK) return err;
  size_t bytes = sums_bytes(film);
  if ((copy->sum = sums_alloc(bytes)) == NULL || (copy->square_sum = sums_alloc(bytes)) == NULL) {
    vf_film_destroy(copy);
    return vf_error_set(VF_ENOMEM, "out of memory for a %dx%d film", film->width, film->height);
  }
  memcpy(copy->sum, film->sum, bytes);
  memcpy(copy->square_sum, film->square_sum, bytes);
  *out = copy;
  return VF_OK;
}

vf_fixed vf_fixed_from_double(double x, int bits) {
  double scaled = x / vf_fixed_unit(bits); /* exact: a power of two */
  /* Below 2^62 the rounding is llrint's (to nearest, ties to even); above, a double is an
   * integer already and converts exactly. */
  if (fabs(scaled) < 0x1p62) return (vf_fixed)llrint(scaled);
  return (vf_fixed)scaled;
}

int vf_film_square_bits_of(const char *settings_text) {
  vf_settings s;
  return vf_settings_parse(&s, settings_text) == VF_OK && s.sampler == VF_SAMPLER_SOBOL ? VF_FILM_SUM_BITS
                                                                                         : VF_FILM_SQUARE_BITS;
}

int vf_film_square_bits(const vf_film *film) { return vf_film_square_bits_of(film->settings_text); }

double vf_film_sum_at(const vf_film *film, size_t i) { return vf_fixed_to_double(film->sum[i], VF_FILM_SUM_BITS); }

double vf_film_square_at(const vf_film *film, size_t i) {
  return vf_fixed_to_double(film->square_sum[i], vf_film_square_bits(film));
}

/* A sample the film can take: finite, and below VF_FILM_SAMPLE_LIMIT in every channel. */
static int storable3(const float *v) {
  for (int k = 0; k < 3; k++)
    if (!(fabsf(v[k]) < (float)VF_FILM_SAMPLE_LIMIT)) return 0; /* NaN fails the test too */
  return 1;
}

/* A NaN or Inf sample would poison its pixel forever, so it is counted and replaced by zero
 * radiance; the sample itself still counts (the iteration is in the set), which biases that
 * pixel slightly dark instead of dropping a sample from one pixel and not the others. A
 * sample beyond VF_FILM_SAMPLE_LIMIT is treated alike: no film file could hold it. */
/* Pixels of one task of vf_film_add_iteration: a fixed block, so that the split does not
 * depend on the number of threads (it could not change the sums anyway: they are per pixel). */
#define ADD_BLOCK 16384u

typedef struct {
  vf_film *film;
  const float *camera_rgb, *light_rgb;
  uint64_t *nonfinite; /* per task */
  int second_moment;   /* square_sum takes the squares (independent films), else the estimates */
  int replicate_one;   /* a sobol film's iteration of replicate 1: square_sum takes nothing */
} add_ctx;

int vf_film_pixel_terms(const float *camera, const float *light, int second_moment, vf_fixed sum[3],
                        vf_fixed square[3]) {
  static const float zero[3] = {0, 0, 0};
  int nonfinite = 0;
  if (!storable3(camera)) {
    camera = zero;
    nonfinite++;
  }
  if (!storable3(light)) {
    light = zero;
    nonfinite++;
  }
  for (int k = 0; k < 3; k++) {
    /* in double: exact unless the floats' exponents differ by more than 29, and rounded
     * alike on every machine otherwise; then rounded once to the grid */
    double estimate = (double)camera[k] + (double)light[k];
    sum[k] = vf_fixed_from_double(estimate, VF_FILM_SUM_BITS);
    square[k] = second_moment ? vf_fixed_from_double(estimate * estimate, VF_FILM_SQUARE_BITS) : sum[k];
  }
  return nonfinite;
}

static void add_task(void *ctx, size_t task, int thread) {
  (void)thread;
  add_ctx *c = ctx;
  vf_film *film = c->film;
  size_t n = (size_t)film->width * (size_t)film->height;
  size_t begin = task * ADD_BLOCK, end = begin + ADD_BLOCK < n ? begin + ADD_BLOCK : n;
  uint64_t nonfinite = 0;
  for (size_t p = begin; p < end; p++) {
    vf_fixed sum[3], square[3];
    nonfinite += (uint64_t)vf_film_pixel_terms(c->camera_rgb + 3 * p, c->light_rgb + 3 * p, c->second_moment, sum,
                                               square);
    for (int k = 0; k < 3; k++) {
      film->sum[3 * p + k] += sum[k];
      if (!c->replicate_one) film->square_sum[3 * p + k] += square[k];
    }
  }
  c->nonfinite[task] = nonfinite;
}

int vf_film_add_iteration(vf_film *film, uint64_t iteration, const float *camera_rgb, const float *light_rgb,
                          vf_pool *pool) {
  if (film == NULL || camera_rgb == NULL || light_rgb == NULL)
    return vf_error_set(VF_EINVAL, "vf_film_add_iteration: NULL argument");
  if (iteration == UINT64_MAX) return vf_error_set(VF_EINVAL, "iteration index %" PRIu64 " is too large", iteration);
  size_t n = (size_t)film->width * (size_t)film->height, tasks = (n + ADD_BLOCK - 1) / ADD_BLOCK;
  uint64_t *nonfinite = calloc(tasks ? tasks : 1, sizeof *nonfinite);
  if (nonfinite == NULL) return VF_ENOMEM;
  int err = vf_iterset_add(&film->iterations, iteration, iteration + 1);
  if (err != VF_OK) {
    free(nonfinite);
    return err;
  }
  int sobol = vf_film_sobol(film);
  add_ctx c = {film, camera_rgb, light_rgb, nonfinite, !sobol, sobol && iteration % VF_SOBOL_REPLICATES != 0};
  if (pool) vf_pool_run(pool, tasks, add_task, &c);
  else
    for (size_t t = 0; t < tasks; t++) add_task(&c, t, 0);
  for (size_t t = 0; t < tasks; t++) film->nonfinite_samples += nonfinite[t];
  free(nonfinite);
  return VF_OK;
}

static void pixel_mean(const vf_film *film, double n, size_t p, float rgb[3]) {
  for (int c = 0; c < 3; c++) rgb[c] = n > 0 ? (float)(vf_film_sum_at(film, 3 * p + (size_t)c) / n) : 0.0f;
}

void vf_film_pixel_mean(const vf_film *film, size_t p, float rgb[3]) {
  pixel_mean(film, (double)vf_iterset_count(&film->iterations), p, rgb);
}

void vf_film_mean(const vf_film *film, float *rgb) {
  size_t pixels = (size_t)film->width * (size_t)film->height;
  double n = (double)vf_iterset_count(&film->iterations);
  for (size_t p = 0; p < pixels; p++) pixel_mean(film, n, p, rgb + 3 * p);
}

int vf_film_merge(vf_film *dst, const vf_film *src) {
  int err = vf_film_merge_metadata(dst, src);
  if (err == VF_OK) vf_film_add_pixels(dst, src);
  return err;
}

/* Cannot overflow: every film holds less than 2^85 units per value (a file's limit, the
 * wire's, and each iteration's 2^84 at most), and 2^42 such films fit in 127 bits. */
void vf_film_add_pixels(vf_film *dst, const vf_film *src) {
  size_t n = (size_t)dst->width * (size_t)dst->height;
  for (size_t i = 0; i < 3 * n; i++) {
    dst->sum[i] += src->sum[i];
    dst->square_sum[i] += src->square_sum[i];
  }
}

int vf_film_merge_metadata(vf_film *dst, const vf_film *src) {
  if (dst == NULL || src == NULL) return vf_error_set(VF_EINVAL, "vf_film_merge: NULL argument");
  if (dst->width != src->width || dst->height != src->height)
    return vf_error_set(VF_EMISMATCH, "film sizes differ: %dx%d and %dx%d", dst->width, dst->height, src->width,
                        src->height);
  if (memcmp(dst->scene_hash, src->scene_hash, sizeof dst->scene_hash) != 0)
    return vf_error_set(VF_EMISMATCH, "films were rendered from different scenes (scene hashes differ)");
  if (strncmp(dst->settings_text, src->settings_text, sizeof dst->settings_text) != 0)
    return vf_error_set(VF_EMISMATCH, "films were rendered with different settings: \"%.200s\" and \"%.200s\"",
                        dst->settings_text, src->settings_text);
  if (dst->pilot != src->pilot)
    return vf_error_set(VF_EMISMATCH, "a pilot's film never merges into an image: the pilot's iterations chose the "
                        "allocation of camera sub-paths and are no samples of the image");
  if (vf_iterset_intersects(&dst->iterations, &src->iterations))
    return vf_error_set(VF_EOVERLAP, "films share iterations: merging would count samples twice");
  size_t pixels = (size_t)dst->width * (size_t)dst->height;
  if (dst->samples != NULL && src->samples != NULL && memcmp(dst->samples, src->samples, pixels) != 0)
    return vf_error_set(VF_EMISMATCH, "films were rendered with different allocations of camera sub-paths to pixels "
                        "(pilots of other films)");
  uint8_t *samples = NULL;
  if (dst->samples == NULL && src->samples != NULL) {
    if ((samples = malloc(pixels)) == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a film's allocation");
    memcpy(samples, src->samples, pixels);
  }
  /* No render comes near 2^64 merges; a sum that wraps would make a biased film look
   * unbiased, so it is refused rather than taken. (nonfinite_samples cannot overflow: the
   * films' iterations bound it, vf_film_validate.) */
  if (src->biased_merges > UINT64_MAX - dst->biased_merges)
    return vf_error_set(VF_EFILM, "films' biased merges (%" PRIu64 " and %" PRIu64 ") overflow a 64-bit count",
                        dst->biased_merges, src->biased_merges);
  /* Reserving room for the log and the union are the only steps that can fail, so they go
   * first; spare log capacity leaves dst unchanged in every way that matters. */
  int err = vf_convergence_reserve(&dst->convergence, src->convergence.count);
  if (err == VF_OK) err = vf_iterset_union(&dst->iterations, &src->iterations);
  if (err != VF_OK) {
    free(samples);
    return err;
  }
  if (samples != NULL) dst->samples = samples;
  vf_convergence_append_runs(&dst->convergence, &src->convergence);
  if (dst->scene_name[0] == '\0') memcpy(dst->scene_name, src->scene_name, sizeof dst->scene_name);
  dst->render_seconds += src->render_seconds;
  dst->cpu_seconds += src->cpu_seconds;
  dst->nonfinite_samples += src->nonfinite_samples;
  dst->biased_merges += src->biased_merges;
  return VF_OK;
}

int vf_film_sobol(const vf_film *film) {
  vf_settings s;
  return vf_settings_parse(&s, film->settings_text) == VF_OK && s.sampler == VF_SAMPLER_SOBOL;
}

uint64_t vf_iterset_even_count(const vf_iterset *set) {
  uint64_t n = 0;
  for (size_t i = 0; i < set->count; i++) n += (set->ranges[i].end + 1) / 2 - (set->ranges[i].begin + 1) / 2;
  return n;
}

/* Independent films: per pixel and channel, with n iterations and X_i the pixel's
 * estimate of iteration i (camera + light), mean m = sum X_i / n: the sample variance
 * (sum X_i^2 - n m^2) / (n - 1) estimates Var X, and Var X / n is the mean squared error of
 * m if the X_i are independent, which they are (each iteration has its own random streams).
 *
 * Sobol films: the X_i of one replicate are points of one scrambled sequence, not
 * independent (their mean converges faster than Var X / n says), but the two replicates
 * (common/sampler.h) are independent of each other. With S_0 the sum over replicate 0
 * (square_sum) and n_0 its iterations, S_1 = sum - S_0 and n_1 the rest, the replicate means
 * m_r = S_r / n_r scatter about m by Q = n_0 (m_0 - m)^2 + n_1 (m_1 - m)^2, which (one
 * degree of freedom) estimates the variance of a single replicate's mean times its count,
 * so Q / n estimates the mean squared error of m; with n_0 = n_1 it is (m_0 - m_1)^2 / 4.
 * Per pixel this is a rough estimate; averaged over the image's pixels and channels (whose
 * scrambles are independent) it is a sharp one.
 *
 * The average over pixels and channels is the expected squared error of the image, RMSE
 * its root. It leaves out bias (vertex merging's, which shrinks with the radius). */
double vf_film_estimate_rmse(const vf_film *film) {
  uint64_t iterations = vf_iterset_count(&film->iterations);
  if (iterations < 2) return NAN;
  double n = (double)iterations, n0 = (double)vf_iterset_even_count(&film->iterations), total = 0.0;
  int sobol = vf_film_sobol(film);
  if (sobol && (!(n0 > 0) || !(n - n0 > 0))) return NAN;
  size_t values = 3 * (size_t)film->width * (size_t)film->height;
  for (size_t i = 0; i < values; i++) total += vf_film_value_spread(film, i, sobol, n, n0) / n;
  return sqrt(total / (double)values);
}

int vf_film_validate(const vf_film *film, const char *name) {
  if (name == NULL) name = "film";
  if (film == NULL || film->sum == NULL || film->square_sum == NULL || film->width < 1 || film->height < 1 ||
      (int64_t)film->width * film->height > VF_EXR_MAX_PIXELS)
    return vf_error_set(VF_EFILM, "%s: film has no pixels or an absurd size", name);
  if (memchr(film->settings_text, '\0', sizeof film->settings_text) == NULL)
    return vf_error_set(VF_EFILM, "%s: settings text is not terminated", name);
  if (memchr(film->scene_name, '\0', sizeof film->scene_name) == NULL)
    return vf_error_set(VF_EFILM, "%s: scene name is not terminated", name);
  uint64_t iterations = vf_iterset_count(&film->iterations);
  if (!isfinite(film->render_seconds) || film->render_seconds < 0)
    return vf_error_set(VF_EFILM, "%s: render time %g is not a finite, non-negative number", name,
                        film->render_seconds);
  if (!isfinite(film->cpu_seconds) || film->cpu_seconds < 0)
    return vf_error_set(VF_EFILM, "%s: attribute vcmfarm:cpu_seconds %g is not a finite, non-negative number", name,
                        film->cpu_seconds);
  int err = vf_convergence_validate(&film->convergence, name);
  if (err != VF_OK) return err;
  size_t pixels = (size_t)film->width * (size_t)film->height;
  if (film->samples != NULL && (err = vf_allocation_validate(film->samples, pixels, name)) != VF_OK) return err;
  vf_settings settings;
  if (vf_settings_parse(&settings, film->settings_text) == VF_OK) {
    if (film->samples != NULL && settings.pilot == 0)
      return vf_error_set(VF_EFILM, "%s: the film has an allocation of camera sub-paths but its settings no pilot", name);
    if (film->pilot && (settings.pilot == 0 || film->samples != NULL))
      return vf_error_set(VF_EFILM, "%s: a pilot's film needs a pilot in its settings and no allocation", name);
    uint64_t last = film->iterations.count > 0 ? film->iterations.ranges[film->iterations.count - 1].end : 0;
    if (film->pilot && last > (uint64_t)settings.pilot)
      return vf_error_set(VF_EFILM, "%s: a pilot's film holds iteration %" PRIu64 ", beyond its pilot of %d", name,
                          last - 1, settings.pilot);
    if (!film->pilot && film->samples == NULL && settings.pilot > 0 && iterations > 0)
      return vf_error_set(VF_EFILM, "%s: the film's settings have a pilot of %d iterations but the film no allocation "
                          "of camera sub-paths", name, settings.pilot);
  }
  double n = (double)film->width * (double)film->height;
  /* each iteration refuses at most one camera and one light sample per pixel */
  if ((double)film->nonfinite_samples > 2.0 * n * (double)iterations)
    return vf_error_set(VF_EFILM, "%s: %" PRIu64 " non-finite samples is more than %" PRIu64 " iterations allow",
                        name, film->nonfinite_samples, iterations);
  for (size_t p = 0; p < pixels; p++) {
    for (int c = 0; c < 3; c++) {
      vf_fixed s = film->sum[3 * p + c], ss = film->square_sum[3 * p + c];
      int x = (int)(p % (size_t)film->width), y = (int)(p / (size_t)film->width);
      /* Every iteration adds to every pixel and nothing else does: a film of no iteration
       * holding sums is a forgery or damage, and merged it would add samples from nowhere. */
      if (iterations == 0 && (s != 0 || ss != 0))
        return vf_error_set(VF_EFILM, "%s: pixel (%d, %d): holds sums but the film has no iterations", name, x, y);
      if (ss < 0)
        return vf_error_set(VF_EFILM, "%s: pixel (%d, %d): negative sum of squares %g", name, x, y,
                            vf_film_square_at(film, 3 * p + (size_t)c));
    }
  }
  return VF_OK;
}
