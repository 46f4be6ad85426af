/* Per-pixel merge radii: pixel_radius.h. */
#include "pixel_radius.h"

#include "../../common/error.h"
#include "wavefront.h"

#include <stdlib.h>
#include <string.h>

/* Specular vertices followed from a pixel's centre before its footprint is taken. */
#define FOOTPRINT_BOUNCES 8
/* The median is taken over at most this many pixels, evenly spaced in index order. */
#define MEDIAN_SAMPLES (1u << 20)

/* The footprint of the pixel at raster (x, y): the distance its centre ray travels to the
 * first non-specular surface, through specular ones, times the pixel's angular width at
 * the camera; NaN when it reaches none. */
static float pixel_footprint(const vf_vcm *v, float x, float y) {
  const vf_camera *cam = &v->camera;
  vf_vec3 origin = cam->position, dir = vf_camera_direction(cam, x, y);
  float width = sqrtf(1.0f / vf_camera_pdf_w(cam, dir)); /* the side of the pixel's solid angle */
  double travelled = 0.0;
  for (int bounce = 0; bounce <= FOOTPRINT_BOUNCES; bounce++) {
    vf_hit hit;
    if (!vf_accel_intersect(v->accel, origin, dir, INFINITY, &hit)) return NAN;
    travelled += hit.t;
    vf_bsdf b;
    if (!bsdf_at(v, &b, &hit, vf_neg(dir))) return NAN;
    if (!b.is_delta) return (float)(travelled * width);
    /* The likelier of the specular branches: numbers in the middle of every choice. */
    const float rnd[3] = {0.5f, 0.5f, 0.5f};
    float pdf, rev, cos_gen;
    unsigned event;
    vf_vec3 next;
    if (vf_is_zero(vf_bsdf_sample(&b, rnd, &next, &pdf, &rev, &cos_gen, &event))) return NAN;
    origin = vf_offset_ray_origin(hit.position, vf_dot(hit.normal, next) > 0.0f ? hit.normal : vf_neg(hit.normal),
                                  v->offset_scale);
    dir = next;
  }
  return NAN;
}

static void footprint_row(void *ctx, size_t row, int thread) {
  (void)thread;
  vf_vcm *v = ctx;
  uint32_t w = (uint32_t)v->camera.width;
  for (uint32_t x = 0; x < w; x++)
    v->pixel_scale[row * w + x] = pixel_footprint(v, (float)x + 0.5f, (float)row + 0.5f);
}

static int compare_floats(const void *a, const void *b) {
  float x = *(const float *)a, y = *(const float *)b;
  return (x > y) - (x < y);
}

int vf_pixel_radius_create(vf_vcm *v) {
  uint32_t n = v->num_pixels;
  if ((v->pixel_scale = malloc((size_t)n * sizeof *v->pixel_scale)) == NULL) return VF_ENOMEM;
  v->pixel_scale_max = 1.0f;
  if (v->camera.pixel_size > 0.0f) { /* orthographic: every pixel covers the same width */
    for (uint32_t i = 0; i < n; i++) v->pixel_scale[i] = 1.0f;
    return VF_OK;
  }
  vf_pool_run(v->pool, (size_t)v->camera.height, footprint_row, v);
  uint32_t stride = n > MEDIAN_SAMPLES ? (n + MEDIAN_SAMPLES - 1) / MEDIAN_SAMPLES : 1u, m = 0;
  float *sample = malloc(((size_t)n / stride + 1) * sizeof *sample);
  if (sample == NULL) {
    free(v->pixel_scale);
    v->pixel_scale = NULL;
    return VF_ENOMEM;
  }
  for (uint32_t i = 0; i < n; i += stride)
    if (isfinite(v->pixel_scale[i]) && v->pixel_scale[i] > 0.0f) sample[m++] = v->pixel_scale[i];
  float median = 0.0f;
  if (m > 0) {
    qsort(sample, m, sizeof *sample, compare_floats);
    median = sample[m / 2];
  }
  free(sample);
  float largest = 0.0f;
  for (uint32_t i = 0; i < n; i++) {
    float f = v->pixel_scale[i], s = 1.0f;
    if (median > 0.0f && isfinite(f) && f > 0.0f) s = f / median;
    s = s < VF_PIXEL_RADIUS_MIN_SCALE ? VF_PIXEL_RADIUS_MIN_SCALE : s > VF_PIXEL_RADIUS_MAX_SCALE ? VF_PIXEL_RADIUS_MAX_SCALE : s;
    v->pixel_scale[i] = s;
    largest = s > largest ? s : largest;
  }
  v->pixel_scale_max = largest;
  return VF_OK;
}
