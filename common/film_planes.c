#include "film_planes.h"

#include "error.h"

#include <inttypes.h>
#include <math.h>

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
  return (vf_film_sums){film->sum, film->square_sum, film->width, vf_iterset_count(&film->iterations)};
}

/* The divisor of version 2's high parts. */
static double scale_of(uint64_t iterations) { return iterations > 0 ? (double)iterations : 1.0; }

/* d as hi = (float)(d / scale) and lo = (float)(d - scale * hi): scale * hi is within a
 * float's rounding of d, so the difference is exact before it is rounded to lo. */
static void split(double d, double scale, float *hi, float *lo) {
  *hi = (float)(d / scale);
  *lo = (float)(d - scale * (double)*hi);
}

static double join(float hi, float lo, double scale) { return scale * (double)hi + (double)lo; }

/* 1 when every value of the planes `which` is finite. */
static int finite_planes(float *const *planes, const int *which, int n, size_t values) {
  float total = 0.0f; /* 0 * x is 0 for every finite x, NaN for Inf and NaN */
  for (int k = 0; k < n; k++)
    for (size_t i = 0; i < values; i++) total += 0.0f * planes[which[k]][i];
  return total == 0.0f;
}

int vf_film_planes_fill(vf_film_sums s, int x0, int y0, int w, int h, float *const *planes) {
  double scale = scale_of(s.iterations);
  /* one plane pair at a time along a row: loops the compiler vectorises */
  for (int y = 0; y < h; y++) {
    size_t p = (size_t)(y0 + y) * (size_t)s.width + (size_t)x0, i = (size_t)y * (size_t)w;
    for (int c = 0; c < 3; c++) {
      const double *sum = s.sum + 3 * p + (size_t)c, *square = s.square_sum + 3 * p + (size_t)c;
      float *mean = planes[V2_MEAN(c)] + i, *sum_lo = planes[V2_SUM_LO(c)] + i;
      float *sq = planes[V2_SQUARE(c)] + i, *sq_lo = planes[V2_SQUARE_LO(c)] + i;
      for (int x = 0; x < w; x++) split(sum[3 * x], scale, &mean[x], &sum_lo[x]);
      for (int x = 0; x < w; x++) split(square[3 * x], scale, &sq[x], &sq_lo[x]);
    }
  }
  static const int high[6] = {V2_MEAN(0), V2_MEAN(1), V2_MEAN(2), V2_SQUARE(0), V2_SQUARE(1), V2_SQUARE(2)};
  return finite_planes(planes, high, 6, (size_t)w * (size_t)h);
}

void vf_film_planes_store(vf_film_sums s, int x0, int y0, int w, int h, const float *const *planes) {
  double scale = scale_of(s.iterations);
  for (int y = 0; y < h; y++) {
    size_t p = (size_t)(y0 + y) * (size_t)s.width + (size_t)x0, i = (size_t)y * (size_t)w;
    for (int c = 0; c < 3; c++) {
      double *sum = s.sum + 3 * p + (size_t)c, *square = s.square_sum + 3 * p + (size_t)c;
      const float *mean = planes[V2_MEAN(c)] + i, *sum_lo = planes[V2_SUM_LO(c)] + i;
      const float *sq = planes[V2_SQUARE(c)] + i, *sq_lo = planes[V2_SQUARE_LO(c)] + i;
      for (int x = 0; x < w; x++) sum[3 * x] = join(mean[x], sum_lo[x], scale);
      for (int x = 0; x < w; x++) square[3 * x] = join(sq[x], sq_lo[x], scale);
    }
  }
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
        planes[c][i] = n > 0 ? (float)(s.sum[3 * p + (size_t)c] / n) : 0.0f;
        put_v1(accum, V1_CAMERA, 3, c, i, s.sum[3 * p + (size_t)c]);
        put_v1(accum, V1_LIGHT, 3, c, i, 0.0);
        put_v1(accum, V1_SQUARE, 3, c, i, s.square_sum[3 * p + (size_t)c]);
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
      for (int c = 0; c < 3; c++) {
        s.sum[3 * p + (size_t)c] = get_v1(planes, V1_CAMERA, 3, c, i) + get_v1(planes, V1_LIGHT, 3, c, i);
        s.square_sum[3 * p + (size_t)c] = get_v1(planes, V1_SQUARE, 3, c, i);
      }
    }
  }
  return VF_OK;
}

/* A value beyond float range would be written as Inf and refused on reading; the writers
 * learn it from the fill and ask here which pixel it was. */
int vf_film_planes_check_range(const vf_film *film, int version, const char *name) {
  double scale = version == 1 ? 1.0 : scale_of(vf_iterset_count(&film->iterations));
  size_t values = 3 * (size_t)film->width * (size_t)film->height;
  for (size_t i = 0; i < values; i++) {
    double worst = fmax(fabs(film->sum[i]), fabs(film->square_sum[i]));
    if (!isfinite((float)(worst / scale)))
      return vf_error_set(VF_EFILM, "%s: pixel %zu holds %g, beyond the file format's float range", name, i / 3,
                          worst);
  }
  return VF_OK;
}
