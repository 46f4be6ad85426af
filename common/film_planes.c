#include "film_planes.h"

#include "error.h"

#include <inttypes.h>
#include <math.h>
#include <string.h>

const char *const vf_film_v4_channels[VF_FILM_V4_CHANNELS] = {
    "B",              "G",              "R",              /* the mean: sum's high part */
    "square.B",       "square.G",       "square.R",       /* square_sum / N */
    "square.rest0.B", "square.rest0.G", "square.rest0.R", /* the rest of square_sum, UINT */
    "square.rest1.B", "square.rest1.G", "square.rest1.R", /* */
    "sum.rest0.B",    "sum.rest0.G",    "sum.rest0.R",    /* the rest of sum, UINT */
    "sum.rest1.B",    "sum.rest1.G",    "sum.rest1.R",
};
/* Plane of component c (0 R, 1 G, 2 B) of each version-4 quantity. */
#define V4_MEAN(c) (2 - (c))
#define V4_SQUARE(c) (5 - (c))
#define V4_SQUARE_REST0(c) (8 - (c))
#define V4_SQUARE_REST1(c) (11 - (c))
#define V4_SUM_REST0(c) (14 - (c))
#define V4_SUM_REST1(c) (17 - (c))

/* Sorted as OpenEXR sorts a channel list (byte order), so that planes in this order are
 * a file chunk's channels in the file's order. */
const char *const vf_film_v2_channels[VF_FILM_V2_CHANNELS] = {
    "B",           "G",           "R",           /* mean: sum's high part */
    "square.B",    "square.G",    "square.R",    /* square_sum / N */
    "square.lo.B", "square.lo.G", "square.lo.R", /* */
    "sum.lo.B",    "sum.lo.G",    "sum.lo.R",
};
/* Plane of component c (0 R, 1 G, 2 B) of each version-2 quantity. */
#define V2_MEAN(c) (2 - (c))
#define V2_SQUARE(c) (5 - (c))
#define V2_SQUARE_LO(c) (8 - (c))
#define V2_SUM_LO(c) (11 - (c))

/* Layer "camera.hi" with channels R, G, B shows up as an image in layer-aware viewers. */
const char *const vf_film_v1_channels[VF_FILM_V1_CHANNELS] = {
    "R",           "G",           "B",                                                      /* mean */
    "camera.hi.R", "camera.hi.G", "camera.hi.B", "camera.lo.R", "camera.lo.G", "camera.lo.B", /* */
    "count.hi",    "count.lo",                                                               /* */
    "light.hi.R",  "light.hi.G",  "light.hi.B",  "light.lo.R",  "light.lo.G",  "light.lo.B",  /* */
    "square.hi.R", "square.hi.G", "square.hi.B", "square.lo.R", "square.lo.G", "square.lo.B",
};
/* First accumulation plane (counting from camera.hi.R) of each version-1 quantity. */
enum { V1_CAMERA = 0, V1_COUNT = 6, V1_LIGHT = 8, V1_SQUARE = 14 };

vf_film_sums vf_film_sums_of(const vf_film *film) {
  return (vf_film_sums){film->sum, film->square_sum, film->width, vf_iterset_count(&film->iterations),
                        vf_film_square_bits(film)};
}

/* The divisor of the high parts. */
static double scale_of(uint64_t iterations) { return iterations > 0 ? (double)iterations : 1.0; }

static int within_file_limit(vf_fixed v) { return v < VF_FILM_FILE_LIMIT && v > -VF_FILM_FILE_LIMIT; }

/* floor(n * hi * 2^bits), exactly, into *out: 0 when hi is not finite or the result is
 * beyond 2^100 (no film within VF_FILM_FILE_LIMIT needs more). hi = m 2^e with m an
 * integer of 24 bits, so the product is an integer times a power of two. */
static int base_of(float hi, uint64_t n, int bits, vf_fixed *out) {
  uint32_t u;
  memcpy(&u, &hi, sizeof u);
  int exponent = (int)(u >> 23 & 0xFF);
  if (exponent == 0xFF) return 0;
  int64_t m = exponent ? (int64_t)((u & 0x7FFFFF) | 0x800000) : (int64_t)(u & 0x7FFFFF);
  int shift = (exponent ? exponent - 150 : -149) + bits;
  if (u >> 31) m = -m;
  if (n >> 39 || shift > 0) { /* rare: huge counts or values; 128-bit arithmetic */
    vf_fixed product = (vf_fixed)n * m; /* below 2^88 */
    if (product == 0) return (*out = 0, 1);
    if (shift > 0) {
      vf_fixed limit = shift >= 100 ? 1 : (vf_fixed)1 << (100 - shift); /* the result below 2^100 */
      if (product >= limit || product <= -limit) return 0;
      *out = product * ((vf_fixed)1 << shift);
      return 1;
    }
    *out = -shift >= 127 ? (product < 0 ? -1 : 0) : product >> -shift; /* an arithmetic shift floors */
    return 1;
  }
  int64_t product = (int64_t)n * m; /* below 2^63 */
  *out = -shift >= 63 ? (product < 0 ? -1 : 0) : product >> -shift;
  return 1;
}

/* Version 4's channels of one value v (units of 2^-bits) of a film of n iterations; 0 when
 * v is beyond VF_FILM_FILE_LIMIT. */
static int put_exact(vf_fixed v, int bits, uint64_t n, float *hi, uint32_t *rest0, uint32_t *rest1) {
  if (!within_file_limit(v)) {
    *hi = INFINITY;
    *rest0 = *rest1 = 0;
    return 0;
  }
  *hi = (float)(vf_fixed_to_double(v, bits) / (double)n);
  vf_fixed base = 0;
  base_of(*hi, n, bits, &base); /* cannot fail: |hi n 2^bits| is about |v| < 2^85 */
  int64_t rest = (int64_t)(v - base); /* |v - base| < |v| 2^-23 + 2 < 2^63 */
  uint64_t zigzag = (uint64_t)rest << 1 ^ (uint64_t)(rest >> 63);
  *rest0 = (uint32_t)zigzag;
  *rest1 = (uint32_t)(zigzag >> 32);
  return 1;
}

/* The inverse; 0 when the channels hold no value of a film (hi not finite, the sum beyond
 * VF_FILM_FILE_LIMIT). */
static int get_exact(float hi, uint32_t rest0, uint32_t rest1, int bits, uint64_t n, vf_fixed *v) {
  vf_fixed base;
  if (!base_of(hi, n, bits, &base)) return 0;
  uint64_t zigzag = (uint64_t)rest1 << 32 | rest0;
  int64_t rest = (int64_t)(zigzag >> 1) ^ -(int64_t)(zigzag & 1);
  *v = base + rest;
  return within_file_limit(*v);
}

int vf_film_planes_fill_v4(vf_film_sums s, int x0, int y0, int w, int h, float *const *planes) {
  uint64_t n = s.iterations > 0 ? s.iterations : 1;
  int fitted = 1;
  for (int y = 0; y < h; y++) {
    size_t p = (size_t)(y0 + y) * (size_t)s.width + (size_t)x0, i = (size_t)y * (size_t)w;
    for (int c = 0; c < 3; c++) {
      const vf_fixed *sum = s.sum + 3 * p + (size_t)c, *square = s.square_sum + 3 * p + (size_t)c;
      float *mean = planes[V4_MEAN(c)] + i, *sq = planes[V4_SQUARE(c)] + i;
      uint32_t *sum0 = (uint32_t *)planes[V4_SUM_REST0(c)] + i, *sum1 = (uint32_t *)planes[V4_SUM_REST1(c)] + i;
      uint32_t *sq0 = (uint32_t *)planes[V4_SQUARE_REST0(c)] + i, *sq1 = (uint32_t *)planes[V4_SQUARE_REST1(c)] + i;
      for (int x = 0; x < w; x++) {
        fitted &= put_exact(sum[3 * x], VF_FILM_SUM_BITS, n, &mean[x], &sum0[x], &sum1[x]);
        fitted &= put_exact(square[3 * x], s.square_bits, n, &sq[x], &sq0[x], &sq1[x]);
      }
    }
  }
  return fitted;
}

int vf_film_planes_store_v4(vf_film_sums s, const char *name, int x0, int y0, int w, int h,
                            const float *const *planes) {
  uint64_t n = s.iterations > 0 ? s.iterations : 1;
  for (int y = 0; y < h; y++) {
    size_t p = (size_t)(y0 + y) * (size_t)s.width + (size_t)x0, i = (size_t)y * (size_t)w;
    for (int c = 0; c < 3; c++) {
      vf_fixed *sum = s.sum + 3 * p + (size_t)c, *square = s.square_sum + 3 * p + (size_t)c;
      const float *mean = planes[V4_MEAN(c)] + i, *sq = planes[V4_SQUARE(c)] + i;
      const uint32_t *sum0 = (const uint32_t *)planes[V4_SUM_REST0(c)] + i;
      const uint32_t *sum1 = (const uint32_t *)planes[V4_SUM_REST1(c)] + i;
      const uint32_t *sq0 = (const uint32_t *)planes[V4_SQUARE_REST0(c)] + i;
      const uint32_t *sq1 = (const uint32_t *)planes[V4_SQUARE_REST1(c)] + i;
      for (int x = 0; x < w; x++)
        if (!get_exact(mean[x], sum0[x], sum1[x], VF_FILM_SUM_BITS, n, &sum[3 * x]) ||
            !get_exact(sq[x], sq0[x], sq1[x], s.square_bits, n, &square[3 * x]))
          return vf_error_set(VF_EFILM, "%s: pixel (%d, %d): a sum is not finite or beyond the film's range", name,
                              x0 + x, y0 + y);
    }
  }
  return VF_OK;
}

/* ---- versions 1 to 3: doubles as float pairs ---- */

/* d as hi = (float)(d / scale) and lo = (float)(d - scale * hi): scale * hi is within a
 * float's rounding of d, so the difference is exact before it is rounded to lo. */
static void split(double d, double scale, float *hi, float *lo) {
  *hi = (float)(d / scale);
  *lo = (float)(d - scale * (double)*hi);
}

static double join(float hi, float lo, double scale) { return scale * (double)hi + (double)lo; }

/* A double read from an older film onto its grid; 0 when it is not finite or beyond the
 * range of a film. */
static int to_fixed(double d, int bits, vf_fixed *out) {
  if (!(fabs(d / vf_fixed_unit(bits)) < 0x1p85)) return 0;
  *out = vf_fixed_from_double(d, bits);
  return 1;
}

/* 1 when every value of the planes `which` is finite. */
static int finite_planes(float *const *planes, const int *which, int n, size_t values) {
  float total = 0.0f; /* 0 * x is 0 for every finite x, NaN for Inf and NaN */
  for (int k = 0; k < n; k++)
    for (size_t i = 0; i < values; i++) total += 0.0f * planes[which[k]][i];
  return total == 0.0f;
}

int vf_film_planes_fill(vf_film_sums s, int x0, int y0, int w, int h, float *const *planes) {
  double scale = scale_of(s.iterations);
  for (int y = 0; y < h; y++) {
    size_t p = (size_t)(y0 + y) * (size_t)s.width + (size_t)x0, i = (size_t)y * (size_t)w;
    for (int c = 0; c < 3; c++) {
      const vf_fixed *sum = s.sum + 3 * p + (size_t)c, *square = s.square_sum + 3 * p + (size_t)c;
      float *mean = planes[V2_MEAN(c)] + i, *sum_lo = planes[V2_SUM_LO(c)] + i;
      float *sq = planes[V2_SQUARE(c)] + i, *sq_lo = planes[V2_SQUARE_LO(c)] + i;
      for (int x = 0; x < w; x++) split(vf_fixed_to_double(sum[3 * x], VF_FILM_SUM_BITS), scale, &mean[x], &sum_lo[x]);
      for (int x = 0; x < w; x++) split(vf_fixed_to_double(square[3 * x], s.square_bits), scale, &sq[x], &sq_lo[x]);
    }
  }
  static const int high[6] = {V2_MEAN(0), V2_MEAN(1), V2_MEAN(2), V2_SQUARE(0), V2_SQUARE(1), V2_SQUARE(2)};
  return finite_planes(planes, high, 6, (size_t)w * (size_t)h);
}

int vf_film_planes_store(vf_film_sums s, const char *name, int x0, int y0, int w, int h, const float *const *planes) {
  double scale = scale_of(s.iterations);
  for (int y = 0; y < h; y++) {
    size_t p = (size_t)(y0 + y) * (size_t)s.width + (size_t)x0, i = (size_t)y * (size_t)w;
    for (int c = 0; c < 3; c++) {
      vf_fixed *sum = s.sum + 3 * p + (size_t)c, *square = s.square_sum + 3 * p + (size_t)c;
      const float *mean = planes[V2_MEAN(c)] + i, *sum_lo = planes[V2_SUM_LO(c)] + i;
      const float *sq = planes[V2_SQUARE(c)] + i, *sq_lo = planes[V2_SQUARE_LO(c)] + i;
      for (int x = 0; x < w; x++)
        if (!to_fixed(join(mean[x], sum_lo[x], scale), VF_FILM_SUM_BITS, &sum[3 * x]) ||
            !to_fixed(join(sq[x], sq_lo[x], scale), s.square_bits, &square[3 * x]))
          return vf_error_set(VF_EFILM, "%s: pixel (%d, %d): non-finite sum", name, x0 + x, y0 + y);
    }
  }
  return VF_OK;
}

/* Version 1: hi = (float)d, lo = (float)(d - hi), the pairs of planes k and k + comps. */
static void put_v1(float *const *planes, int first, int comps, int c, size_t i, double d) {
  split(d, 1.0, &planes[first + c][i], &planes[first + comps + c][i]);
}

static double get_v1(const float *const *planes, int first, int comps, int c, size_t i) {
  return join(planes[first + c][i], planes[first + comps + c][i], 1.0);
}

int vf_film_planes_fill_v1(vf_film_sums s, int x0, int y0, int w, int h, float *const *planes) {
  double n = (double)s.iterations;
  float *const *accum = planes + 3;
  for (int y = 0; y < h; y++) {
    size_t p = (size_t)(y0 + y) * (size_t)s.width + (size_t)x0, i = (size_t)y * (size_t)w;
    for (int x = 0; x < w; x++, p++, i++) {
      for (int c = 0; c < 3; c++) {
        double sum = vf_fixed_to_double(s.sum[3 * p + (size_t)c], VF_FILM_SUM_BITS);
        planes[c][i] = n > 0 ? (float)(sum / n) : 0.0f;
        put_v1(accum, V1_CAMERA, 3, c, i, sum);
        put_v1(accum, V1_LIGHT, 3, c, i, 0.0);
        put_v1(accum, V1_SQUARE, 3, c, i, vf_fixed_to_double(s.square_sum[3 * p + (size_t)c], s.square_bits));
      }
      put_v1(accum, V1_COUNT, 1, 0, i, n);
    }
  }
  static const int high[6] = {3 + V1_CAMERA, 4 + V1_CAMERA, 5 + V1_CAMERA, 3 + V1_SQUARE, 4 + V1_SQUARE, 5 + V1_SQUARE};
  return finite_planes(planes, high, 6, (size_t)w * (size_t)h);
}

int vf_film_planes_store_v1(vf_film_sums s, const char *name, int x0, int y0, int w, int h, const float *const *planes) {
  uint64_t iterations = s.iterations;
  for (int y = 0; y < h; y++) {
    size_t p = (size_t)(y0 + y) * (size_t)s.width + (size_t)x0, i = (size_t)y * (size_t)w;
    for (int x = 0; x < w; x++, p++, i++) {
      double count = get_v1(planes, V1_COUNT, 1, 0, i);
      if (count != (double)iterations)
        return vf_error_set(VF_EFILM,
                            "%s: pixel (%d, %d): camera count %g is not the film's %" PRIu64
                            " iterations (version-1 films whose pixels hold different counts cannot be read)",
                            name, x0 + x, y0 + y, count, iterations);
      for (int c = 0; c < 3; c++)
        if (!to_fixed(get_v1(planes, V1_CAMERA, 3, c, i) + get_v1(planes, V1_LIGHT, 3, c, i), VF_FILM_SUM_BITS,
                      &s.sum[3 * p + (size_t)c]) ||
            !to_fixed(get_v1(planes, V1_SQUARE, 3, c, i), s.square_bits, &s.square_sum[3 * p + (size_t)c]))
          return vf_error_set(VF_EFILM, "%s: pixel (%d, %d): non-finite sum", name, x0 + x, y0 + y);
    }
  }
  return VF_OK;
}

/* A value beyond the format's range would be written as Inf and refused on reading; the
 * writers learn it from the fill and ask here which pixel it was. */
int vf_film_planes_check_range(const vf_film *film, int version, const char *name) {
  double scale = version == 1 ? 1.0 : scale_of(vf_iterset_count(&film->iterations));
  int square_bits = vf_film_square_bits(film);
  size_t values = 3 * (size_t)film->width * (size_t)film->height;
  for (size_t i = 0; i < values; i++) {
    int fits = version >= 4 ? within_file_limit(film->sum[i]) && within_file_limit(film->square_sum[i])
                            : isfinite((float)(vf_fixed_to_double(film->sum[i], VF_FILM_SUM_BITS) / scale)) &&
                                  isfinite((float)(vf_fixed_to_double(film->square_sum[i], square_bits) / scale));
    if (!fits)
      return vf_error_set(VF_EFILM, "%s: pixel %zu holds %g, beyond the file format's range", name, i / 3,
                          vf_fixed_to_double(film->sum[i], VF_FILM_SUM_BITS));
  }
  return VF_OK;
}
