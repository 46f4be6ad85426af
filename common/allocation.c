/* Camera sub-paths allocated per pixel from a pilot: allocation.h. */
#include "allocation.h"

#include "error.h"
#include "rng.h"
#include "settings.h"

#include <math.h>
#include <sodium.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <zlib.h>

/* Each pixel's variance of one iteration's estimate, summed over its channels: the
 * film's error estimate of the pixel (common/film.c, vf_film_estimate_rmse) times n. */
static void pixel_variances(const vf_film *film, double *out) {
  size_t pixels = (size_t)film->width * (size_t)film->height;
  double n = (double)vf_iterset_count(&film->iterations), n0 = (double)vf_iterset_even_count(&film->iterations);
  int sobol = vf_film_sobol(film);
  for (size_t p = 0; p < pixels; p++) {
    double v = 0.0;
    for (size_t c = 3 * p; c < 3 * p + 3; c++) v += vf_film_value_spread(film, c, sobol, n, n0);
    out[p] = v;
  }
}

/* The variances are smoothed over 7x7 pixels (binomial weights 1 6 15 20 15 6 1 on each
 * axis): one pixel's estimate from a short pilot is too noisy (one degree of freedom on a
 * sobol film, rare bright paths on any) to allocate by alone, and counts from narrower
 * filters (3x3, 5x5) overspent on pixels whose estimate was high by chance: pt on the
 * boxes with a glass ball lost 5-15% more efficiency with them (docs/BENCHMARKS.md,
 * "Camera sub-paths per pixel"). */
#define SMOOTHING 3

/* One pass of the binomial filter of 2 radius + 1 taps along lines of `length` values
 * `step` apart, lines starting `stride` apart (rows: 1, width; columns: width, 1); the
 * line's end values repeated past its ends. */
static void smooth_pass(const double *in, double *out, int lines, int length, size_t stride, size_t step, int radius) {
  double w[2 * SMOOTHING + 1], total = 0.0;
  int taps = 2 * radius + 1;
  w[0] = 1.0;
  for (int i = 1; i < taps; i++) w[i] = w[i - 1] * (double)(taps - i) / (double)i; /* C(2r, i) */
  for (int i = 0; i < taps; i++) total += w[i];
  for (int line = 0; line < lines; line++) {
    const double *a = in + (size_t)line * stride;
    double *b = out + (size_t)line * stride;
    for (int x = 0; x < length; x++) {
      double s = 0.0;
      for (int d = -radius; d <= radius; d++) {
        int xx = x + d < 0 ? 0 : x + d >= length ? length - 1 : x + d;
        s += w[d + radius] * a[(size_t)xx * step];
      }
      b[(size_t)x * step] = s / total;
    }
  }
}

/* The binomial filter of (2 radius + 1)^2 taps, separable: rows into tmp, its columns into
 * out. */
static void smooth(const double *in, double *tmp, double *out, int width, int height, int radius) {
  smooth_pass(in, tmp, height, width, (size_t)width, 1, radius);
  smooth_pass(tmp, out, width, height, 1, (size_t)width, radius);
}

/* The power of two from 1 to VF_ALLOCATION_MAX nearest to x on a log scale: the bounds
 * between successive levels are 2^(i + 1/2), compared without a logarithm so that every
 * machine rounds alike. */
static uint8_t level_of(double x) {
  static const double bounds[VF_ALLOCATION_LEVELS - 1] = {1.4142135623730951, 2.8284271247461903, 5.6568542494923806,
                                                          11.313708498984761};
  uint8_t k = 1;
  for (int i = 0; i < VF_ALLOCATION_LEVELS - 1 && x >= bounds[i]; i++) k = (uint8_t)(k * 2);
  return k;
}

/* The counts for scale `scale` (k_p = level_of(scale * sigma_p)) into samples (when not
 * NULL; each byte's flags, as vf_allocation_choose set them, are kept) and their efficiency
 * against one a pixel: (sum c_p sum v_p) / (sum k_p c_p * sum v_p / k_p), with c_p = 1 when
 * cost is NULL; the mean over pixels of v / k into *mean_variance (when not NULL). */
static double counts_for(const double *sigma, const double *variance, const double *cost, size_t n, double scale,
                         uint8_t *samples, double *mean_variance) {
  double spent = 0.0, error = 0.0, total = 0.0, base = 0.0;
  for (size_t p = 0; p < n; p++) {
    uint8_t k = level_of(scale * sigma[p]);
    if (samples) samples[p] = (uint8_t)((samples[p] & VF_ALLOCATION_NO_MERGING) | k);
    spent += cost ? k * cost[p] : k;
    if (cost) base += cost[p];
    error += variance[p] / k;
    total += variance[p];
  }
  if (mean_variance) *mean_variance = error / (double)n;
  if (!cost) base = (double)n;
  return error > 0.0 ? base * total / (spent * error) : 1.0;
}

/* The counts of the ladder's best scale (k_p proportional to sigma_p) into samples, and
 * report (may be NULL) filled. */
static void allocate(const double *sigma, const double *variance, const double *cost, size_t n, uint8_t *samples,
                     vf_allocation_report *report) {
  double mean_sigma = 0.0;
  for (size_t p = 0; p < n; p++) mean_sigma += sigma[p];
  mean_sigma /= (double)n;
  /* The ladder of scales: 2^(i/4) / mean sigma for i from 0 to 16, so that the unrounded
   * count of a pixel of the mean sigma runs from 1 to 16 in steps of 2^(1/4): a fixed set,
   * the same for every film. */
  double best_scale = 0.0, best = 1.0;
  if (mean_sigma > 0.0 && isfinite(mean_sigma)) {
    for (int i = 0; i <= 16; i++) {
      double scale = pow(2.0, 0.25 * i) / mean_sigma;
      double e = counts_for(sigma, variance, cost, n, scale, NULL, NULL);
      if (e > best) best = e, best_scale = scale;
    }
  }
  double mean_variance;
  counts_for(sigma, variance, cost, n, best_scale, samples, &mean_variance);
  if (report) {
    vf_allocation_describe(samples, n, report);
    report->predicted_gain = best;
    report->variance = mean_variance;
  }
}

int vf_allocation_variances(const vf_film *film, double *variance) {
  vf_settings s;
  int err = vf_settings_parse(&s, film->settings_text);
  if (err != VF_OK) return err;
  uint64_t n_iterations = vf_iterset_count(&film->iterations);
  if (s.pilot <= 0) return vf_error_set(VF_EINVAL, "the film's settings have no pilot");
  if (film->iterations.count != 1 || film->iterations.ranges[0].begin != 0 ||
      film->iterations.ranges[0].end != (uint64_t)s.pilot || n_iterations < 2)
    return vf_error_set(VF_EINVAL, "an allocation is computed from the film of exactly the pilot's iterations [0, %d), "
                        "and this film holds %llu others", s.pilot, (unsigned long long)n_iterations);
  size_t n = (size_t)film->width * (size_t)film->height;
  double *raw = malloc(n * sizeof *raw), *tmp = malloc(n * sizeof *tmp);
  if (raw == NULL || tmp == NULL) {
    free(raw);
    free(tmp);
    return VF_ENOMEM;
  }
  pixel_variances(film, raw);
  smooth(raw, tmp, variance, film->width, film->height, SMOOTHING);
  free(raw);
  free(tmp);
  return VF_OK;
}

int vf_allocation_compute(const vf_film *film, uint8_t *samples, vf_allocation_report *report) {
  size_t n = (size_t)film->width * (size_t)film->height;
  double *variance = malloc(n * sizeof *variance), *sigma = malloc(n * sizeof *sigma);
  int err = variance && sigma ? vf_allocation_variances(film, variance) : VF_ENOMEM;
  if (err == VF_OK) {
    for (size_t p = 0; p < n; p++) {
      sigma[p] = sqrt(variance[p]);
      samples[p] = 0;
    }
    allocate(sigma, variance, NULL, n, samples, report);
  }
  free(variance);
  free(sigma);
  return err;
}

int vf_allocation_choose(const double *bpt_variance, const double *vcm_variance, double bpt_cost, double vcm_cost,
                         double margin, int width, int height, uint8_t *samples, vf_allocation_report *report) {
  size_t n = (size_t)width * (size_t)height;
  if (!(bpt_cost > 0.0 && vcm_cost > 0.0 && isfinite(bpt_cost) && isfinite(vcm_cost)))
    return vf_error_set(VF_EINVAL, "the costs of a camera sub-path, %g (bpt) and %g (vcm), must be positive", bpt_cost,
                        vcm_cost);
  double *variance = malloc(n * sizeof *variance), *sigma = malloc(n * sizeof *sigma), *cost = malloc(n * sizeof *cost);
  if (variance == NULL || sigma == NULL || cost == NULL) {
    free(variance);
    free(sigma);
    free(cost);
    return VF_ENOMEM;
  }
  /* Tile by tile: the sums of a tile's variances decide for all its pixels. */
  const int tile = VF_ALLOCATION_MERGE_TILE;
  for (int ty = 0; ty < height; ty += tile)
    for (int tx = 0; tx < width; tx += tile) {
      double b = 0.0, v = 0.0;
      for (int y = ty; y < height && y < ty + tile; y++)
        for (int x = tx; x < width && x < tx + tile; x++) {
          b += bpt_variance[(size_t)y * width + x];
          v += vcm_variance[(size_t)y * width + x];
        }
      int merges = !(margin * b * bpt_cost <= v * vcm_cost);
      for (int y = ty; y < height && y < ty + tile; y++)
        for (int x = tx; x < width && x < tx + tile; x++)
          samples[(size_t)y * width + x] = merges ? 0 : (uint8_t)VF_ALLOCATION_NO_MERGING;
    }
  for (size_t p = 0; p < n; p++) {
    int merges = vf_allocation_merges(samples[p]);
    variance[p] = merges ? vcm_variance[p] : bpt_variance[p];
    cost[p] = merges ? vcm_cost : bpt_cost;
    sigma[p] = sqrt(variance[p] / cost[p]);
  }
  allocate(sigma, variance, cost, n, samples, report);
  free(variance);
  free(sigma);
  free(cost);
  return VF_OK;
}

void vf_allocation_describe(const uint8_t *samples, size_t n, vf_allocation_report *report) {
  memset(report, 0, sizeof *report);
  double total = 0.0;
  for (size_t p = 0; p < n; p++) {
    uint32_t k = vf_allocation_count(samples[p]);
    int level = 0;
    while (level < VF_ALLOCATION_LEVELS - 1 && (1u << level) < k) level++;
    report->pixels[level]++;
    report->no_merging += !vf_allocation_merges(samples[p]);
    total += k;
  }
  report->mean = n ? total / (double)n : 0.0;
  report->predicted_gain = NAN;
  report->variance = NAN;
}

void vf_allocation_summary(const vf_allocation_report *a, char *out, size_t size) {
  int w = snprintf(out, size, "%.2f camera sub-paths a pixel on average; pixels of 1, 2, 4, 8, 16: %llu, %llu, %llu, "
                   "%llu, %llu", a->mean, (unsigned long long)a->pixels[0], (unsigned long long)a->pixels[1],
                   (unsigned long long)a->pixels[2], (unsigned long long)a->pixels[3], (unsigned long long)a->pixels[4]);
  if (a->no_merging > 0 && w >= 0 && (size_t)w < size)
    snprintf(out + w, size - (size_t)w, "; no merging in %llu pixels", (unsigned long long)a->no_merging);
}

uint64_t vf_allocation_seed(uint64_t seed) { return vf_splitmix64(seed ^ 0x9e6c63d0876a9a99ULL); }

int vf_allocation_validate(const uint8_t *samples, size_t n, const char *name) {
  for (size_t p = 0; p < n; p++) {
    unsigned k = vf_allocation_count(samples[p]);
    if (samples[p] & ~(VF_ALLOCATION_COUNT_BITS | VF_ALLOCATION_NO_MERGING))
      return vf_error_set(VF_EFILM, "%s: allocation of pixel %zu is byte 0x%02x: bits 5 and 6 are not used", name, p,
                          samples[p]);
    if (k == 0 || k > VF_ALLOCATION_MAX || (k & (k - 1)) != 0)
      return vf_error_set(VF_EFILM, "%s: allocation of pixel %zu is %u camera sub-paths: a power of two from 1 to %d",
                          name, p, k, VF_ALLOCATION_MAX);
  }
  return VF_OK;
}

int vf_allocation_check_algorithm(const uint8_t *samples, size_t n, vf_algorithm algorithm, const char *name) {
  if (algorithm == VF_ALGO_VCM) return VF_OK;
  for (size_t p = 0; p < n; p++)
    if (!vf_allocation_merges(samples[p]))
      return vf_error_set(VF_EINVAL, "%s: pixel %zu turns vertex merging off, which only a vcm render does (this one is "
                          "%s)", name, p, vf_algorithm_name(algorithm));
  return VF_OK;
}

#define ENCODING_PREFIX "1:"

int vf_allocation_encode(const uint8_t *samples, size_t n, char **text) {
  uLongf packed_len = compressBound((uLong)n);
  unsigned char *packed = malloc(packed_len);
  if (packed == NULL) return VF_ENOMEM;
  if (compress2(packed, &packed_len, samples, (uLong)n, 9) != Z_OK) {
    free(packed);
    return VF_ENOMEM; /* compress2 fails only for want of memory with these arguments */
  }
  size_t b64 = sodium_base64_encoded_len(packed_len, sodium_base64_VARIANT_ORIGINAL);
  char *out = malloc(sizeof ENCODING_PREFIX - 1 + b64);
  if (out == NULL) {
    free(packed);
    return VF_ENOMEM;
  }
  memcpy(out, ENCODING_PREFIX, sizeof ENCODING_PREFIX - 1);
  sodium_bin2base64(out + sizeof ENCODING_PREFIX - 1, b64, packed, packed_len, sodium_base64_VARIANT_ORIGINAL);
  free(packed);
  *text = out;
  return VF_OK;
}

int vf_allocation_decode(const char *text, size_t n, uint8_t *samples, const char *name) {
  size_t prefix = sizeof ENCODING_PREFIX - 1;
  if (strncmp(text, ENCODING_PREFIX, prefix) != 0)
    return vf_error_set(VF_EFILM, "%s: attribute vcmfarm:allocation does not start with \"" ENCODING_PREFIX "\"", name);
  size_t len = strlen(text + prefix);
  unsigned char *packed = malloc(len + 1);
  if (packed == NULL) return VF_ENOMEM;
  size_t packed_len = 0;
  if (sodium_base642bin(packed, len + 1, text + prefix, len, NULL, &packed_len, NULL, sodium_base64_VARIANT_ORIGINAL) !=
      0) {
    free(packed);
    return vf_error_set(VF_EFILM, "%s: attribute vcmfarm:allocation is not base64", name);
  }
  uLongf out_len = (uLongf)n;
  int rc = uncompress(samples, &out_len, packed, (uLong)packed_len);
  free(packed);
  if (rc != Z_OK || out_len != (uLongf)n)
    return vf_error_set(VF_EFILM, "%s: attribute vcmfarm:allocation does not hold %zu pixels' counts (zlib: %s)", name,
                        n, rc == Z_OK ? "another length" : zError(rc));
  return vf_allocation_validate(samples, n, name);
}
