/* The film: accumulation, merging and the on-disk format (docs/FILM.md).
 *
 * Accumulation is in double precision because a film may hold millions of iterations and
 * merging must be exact enough that merged films equal films rendered in one go. The file
 * keeps each double as two floats, hi = (float)d and lo = (float)(d - hi), because EXR has
 * no double channels: hi + lo carries about 48 significant bits, so a film read back
 * differs from the one written by a relative ~4e-15 at most (counts below 2^48 exactly). */
#include "film.h"

#include "error.h"
#include "parse.h"
#include "exr_util.h"

#include <inttypes.h>
#include <sodium.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define ATTR_VERSION "vcmfarm:format_version"
#define ATTR_SCENE "vcmfarm:scene_hash"
#define ATTR_SETTINGS "vcmfarm:settings"
#define ATTR_ITERATIONS "vcmfarm:iterations"
#define ATTR_LIGHT_FRAMES "vcmfarm:light_frames"
#define ATTR_SECONDS "vcmfarm:render_seconds"
#define ATTR_NONFINITE "vcmfarm:nonfinite_samples"
/* Optional: films written before they existed read as "unknown" (0, "", an empty log). */
#define ATTR_CPU_SECONDS "vcmfarm:cpu_seconds"
#define ATTR_SCENE_NAME "vcmfarm:scene"
#define ATTR_CONVERGENCE "vcmfarm:convergence"
#define ATTR_SETTINGS_HASH "vcmfarm:settings_hash"

/* The four accumulated quantities, in the order of accum_names below. */
enum { Q_CAMERA, Q_COUNT, Q_LIGHT, Q_SQUARE, Q_COUNT_ };
static const int q_comps[Q_COUNT_] = {3, 1, 3, 3};
static const int q_first_plane[Q_COUNT_] = {0, 6, 8, 14}; /* hi planes, then lo planes */
#define ACCUM_PLANES 20

/* Layer "camera.hi" with channels R, G, B shows up as an image in layer-aware viewers. */
static const char *const file_channels[3 + ACCUM_PLANES] = {
    "R",           "G",           "B",                                                      /* mean */
    "camera.hi.R", "camera.hi.G", "camera.hi.B", "camera.lo.R", "camera.lo.G", "camera.lo.B", /* */
    "count.hi",    "count.lo",                                                               /* */
    "light.hi.R",  "light.hi.G",  "light.hi.B",  "light.lo.R",  "light.lo.G",  "light.lo.B",  /* */
    "square.hi.R", "square.hi.G", "square.hi.B", "square.lo.R", "square.lo.G", "square.lo.B",
};
static const char *const *const accum_names = file_channels + 3;

static double *q_data(const vf_film *film, int q) {
  switch (q) {
  case Q_CAMERA: return film->camera_sum;
  case Q_COUNT: return film->camera_count;
  case Q_LIGHT: return film->light_sum;
  default: return film->square_sum;
  }
}

int vf_film_create(int width, int height, vf_film **out) {
  if (out == NULL || width < 1 || height < 1 || width > VF_EXR_MAX_SIDE || height > VF_EXR_MAX_SIDE ||
      (int64_t)width * height > VF_EXR_MAX_PIXELS)
    return vf_error_set(VF_EINVAL, "film size %dx%d is outside 1x1 .. 65536x65536 (at most 2^28 pixels)", width,
                        height);
  size_t n = (size_t)width * (size_t)height;
  vf_film *film = calloc(1, sizeof *film);
  if (film == NULL) goto fail_film;
  if ((film->camera_sum = calloc(3 * n, sizeof(double))) == NULL) goto fail_camera;
  if ((film->camera_count = calloc(n, sizeof(double))) == NULL) goto fail_count;
  if ((film->light_sum = calloc(3 * n, sizeof(double))) == NULL) goto fail_light;
  if ((film->square_sum = calloc(3 * n, sizeof(double))) == NULL) goto fail_square;
  film->width = width;
  film->height = height;
  vf_iterset_init(&film->iterations);
  vf_convergence_init(&film->convergence);
  *out = film;
  return VF_OK;
fail_square:
  free(film->light_sum);
fail_light:
  free(film->camera_count);
fail_count:
  free(film->camera_sum);
fail_camera:
  free(film);
fail_film:
  return vf_error_set(VF_ENOMEM, "out of memory for a %dx%d film", width, height);
}

void vf_film_destroy(vf_film *film) {
  if (film == NULL) return;
  vf_iterset_destroy(&film->iterations);
  vf_convergence_destroy(&film->convergence);
  free(film->square_sum);
  free(film->light_sum);
  free(film->camera_count);
  free(film->camera_sum);
  free(film);
}

int vf_film_clone(const vf_film *film, vf_film **out) {
  if (film == NULL || out == NULL) return vf_error_set(VF_EINVAL, "vf_film_clone: NULL argument");
  vf_film *copy;
  int err = vf_film_create(film->width, film->height, &copy);
  if (err != VF_OK) return err;
  if ((err = vf_iterset_copy(&copy->iterations, &film->iterations)) != VF_OK ||
      (err = vf_convergence_copy(&copy->convergence, &film->convergence)) != VF_OK) {
    vf_film_destroy(copy);
    return err;
  }
  size_t n = (size_t)film->width * (size_t)film->height;
  memcpy(copy->camera_sum, film->camera_sum, 3 * n * sizeof(double));
  memcpy(copy->camera_count, film->camera_count, n * sizeof(double));
  memcpy(copy->light_sum, film->light_sum, 3 * n * sizeof(double));
  memcpy(copy->square_sum, film->square_sum, 3 * n * sizeof(double));
  copy->light_frames = film->light_frames;
  memcpy(copy->scene_hash, film->scene_hash, sizeof copy->scene_hash);
  memcpy(copy->settings_text, film->settings_text, sizeof copy->settings_text);
  copy->render_seconds = film->render_seconds;
  copy->cpu_seconds = film->cpu_seconds;
  copy->nonfinite_samples = film->nonfinite_samples;
  memcpy(copy->scene_name, film->scene_name, sizeof copy->scene_name);
  *out = copy;
  return VF_OK;
}

static int finite3(const float *v) { return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]); }

/* A NaN or Inf sample would poison its pixel forever, so it is counted and replaced by zero
 * radiance; the sample itself still counts (camera_count, light_frames), which biases that
 * pixel slightly dark instead of dropping a sample from one estimator and not the other. */
/* Pixels of one task of vf_film_add_iteration: a fixed block, so that the split does not
 * depend on the number of threads (it could not change the sums anyway: they are per pixel). */
#define ADD_BLOCK 16384u

typedef struct {
  vf_film *film;
  const float *camera_rgb, *light_rgb;
  uint64_t *nonfinite; /* per task */
} add_ctx;

static void add_task(void *ctx, size_t task, int thread) {
  (void)thread;
  add_ctx *c = ctx;
  vf_film *film = c->film;
  static const float zero[3] = {0, 0, 0};
  size_t n = (size_t)film->width * (size_t)film->height;
  size_t begin = task * ADD_BLOCK, end = begin + ADD_BLOCK < n ? begin + ADD_BLOCK : n;
  uint64_t nonfinite = 0;
  for (size_t p = begin; p < end; p++) {
    const float *cam = c->camera_rgb + 3 * p, *light = c->light_rgb + 3 * p;
    if (!finite3(cam)) {
      cam = zero;
      nonfinite++;
    }
    if (!finite3(light)) {
      light = zero;
      nonfinite++;
    }
    for (int k = 0; k < 3; k++) {
      double estimate = (double)cam[k] + (double)light[k];
      film->camera_sum[3 * p + k] += cam[k];
      film->light_sum[3 * p + k] += light[k];
      film->square_sum[3 * p + k] += estimate * estimate;
    }
    film->camera_count[p] += 1.0;
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
  add_ctx c = {film, camera_rgb, light_rgb, nonfinite};
  if (pool) vf_pool_run(pool, tasks, add_task, &c);
  else
    for (size_t t = 0; t < tasks; t++) add_task(&c, t, 0);
  for (size_t t = 0; t < tasks; t++) film->nonfinite_samples += nonfinite[t];
  free(nonfinite);
  film->light_frames++;
  return VF_OK;
}

static void pixel_mean(const vf_film *film, size_t p, float *rgb) {
  double count = film->camera_count[p], frames = (double)film->light_frames;
  for (int c = 0; c < 3; c++) {
    double m = 0.0;
    if (count > 0) m += film->camera_sum[3 * p + c] / count;
    if (frames > 0) m += film->light_sum[3 * p + c] / frames;
    rgb[c] = (float)m;
  }
}

void vf_film_mean(const vf_film *film, float *rgb) {
  size_t n = (size_t)film->width * (size_t)film->height;
  for (size_t p = 0; p < n; p++) pixel_mean(film, p, rgb + 3 * p);
}

int vf_film_merge(vf_film *dst, const vf_film *src) {
  if (dst == NULL || src == NULL) return vf_error_set(VF_EINVAL, "vf_film_merge: NULL argument");
  if (dst->width != src->width || dst->height != src->height)
    return vf_error_set(VF_EMISMATCH, "film sizes differ: %dx%d and %dx%d", dst->width, dst->height, src->width,
                        src->height);
  if (memcmp(dst->scene_hash, src->scene_hash, sizeof dst->scene_hash) != 0)
    return vf_error_set(VF_EMISMATCH, "films were rendered from different scenes (scene hashes differ)");
  if (strncmp(dst->settings_text, src->settings_text, sizeof dst->settings_text) != 0)
    return vf_error_set(VF_EMISMATCH, "films were rendered with different settings: \"%.200s\" and \"%.200s\"",
                        dst->settings_text, src->settings_text);
  if (vf_iterset_intersects(&dst->iterations, &src->iterations))
    return vf_error_set(VF_EOVERLAP, "films share iterations: merging would count samples twice");
  /* Reserving room for the log and the union are the only steps that can fail, so they go
   * first; spare log capacity leaves dst unchanged in every way that matters. */
  int err = vf_convergence_reserve(&dst->convergence, src->convergence.count);
  if (err == VF_OK) err = vf_iterset_union(&dst->iterations, &src->iterations);
  if (err != VF_OK) return err;
  vf_convergence_append_runs(&dst->convergence, &src->convergence);
  if (dst->scene_name[0] == '\0') memcpy(dst->scene_name, src->scene_name, sizeof dst->scene_name);
  size_t n = (size_t)dst->width * (size_t)dst->height;
  for (size_t i = 0; i < 3 * n; i++) {
    dst->camera_sum[i] += src->camera_sum[i];
    dst->light_sum[i] += src->light_sum[i];
    dst->square_sum[i] += src->square_sum[i];
  }
  for (size_t p = 0; p < n; p++) dst->camera_count[p] += src->camera_count[p];
  dst->light_frames += src->light_frames;
  dst->render_seconds += src->render_seconds;
  dst->cpu_seconds += src->cpu_seconds;
  dst->nonfinite_samples += src->nonfinite_samples;
  return VF_OK;
}

/* Per pixel and channel, with n iterations and X_i the pixel's estimate of iteration i
 * (camera + light), mean m = sum X_i / n: the sample variance (sum X_i^2 - n m^2) / (n - 1)
 * estimates Var X, and Var X / n is the mean squared error of m if the X_i are
 * independent, which they are (each iteration has its own random streams). The average
 * over pixels and channels is the expected squared error of the image, RMSE its root. It
 * leaves out bias (vertex merging's, which shrinks with the radius). */
double vf_film_estimate_rmse(const vf_film *film) {
  double n = (double)film->light_frames;
  if (film->light_frames < 2) return NAN;
  size_t pixels = (size_t)film->width * (size_t)film->height;
  double total = 0.0;
  for (size_t p = 0; p < pixels; p++) {
    double count = film->camera_count[p];
    for (int c = 0; c < 3; c++) {
      double m = film->light_sum[3 * p + c] / n;
      if (count > 0) m += film->camera_sum[3 * p + c] / count;
      double variance = (film->square_sum[3 * p + c] - n * m * m) / (n - 1.0);
      if (variance > 0) total += variance / n; /* < 0 only through rounding */
    }
  }
  return sqrt(total / (3.0 * (double)pixels));
}

int vf_film_validate(const vf_film *film, const char *name) {
  if (name == NULL) name = "film";
  if (film == NULL || film->camera_sum == NULL || film->camera_count == NULL || film->light_sum == NULL ||
      film->square_sum == NULL || film->width < 1 || film->height < 1 ||
      (int64_t)film->width * film->height > VF_EXR_MAX_PIXELS)
    return vf_error_set(VF_EFILM, "%s: film has no pixels or an absurd size", name);
  if (memchr(film->settings_text, '\0', sizeof film->settings_text) == NULL)
    return vf_error_set(VF_EFILM, "%s: settings text is not terminated", name);
  if (memchr(film->scene_name, '\0', sizeof film->scene_name) == NULL)
    return vf_error_set(VF_EFILM, "%s: scene name is not terminated", name);
  uint64_t iterations = vf_iterset_count(&film->iterations);
  if (film->light_frames != iterations)
    return vf_error_set(VF_EFILM, "%s: %" PRIu64 " light frames but %" PRIu64 " iterations", name,
                        film->light_frames, iterations);
  if (!isfinite(film->render_seconds) || film->render_seconds < 0)
    return vf_error_set(VF_EFILM, "%s: render time %g is not a finite, non-negative number", name,
                        film->render_seconds);
  if (!isfinite(film->cpu_seconds) || film->cpu_seconds < 0)
    return vf_error_set(VF_EFILM, "%s: attribute " ATTR_CPU_SECONDS " %g is not a finite, non-negative number", name,
                        film->cpu_seconds);
  int err = vf_convergence_validate(&film->convergence, name);
  if (err != VF_OK) return err;
  double n = (double)film->width * (double)film->height;
  /* each iteration refuses at most one camera and one light sample per pixel */
  if ((double)film->nonfinite_samples > 2.0 * n * (double)iterations)
    return vf_error_set(VF_EFILM, "%s: %" PRIu64 " non-finite samples is more than %" PRIu64 " iterations allow",
                        name, film->nonfinite_samples, iterations);
  size_t pixels = (size_t)film->width * (size_t)film->height;
  for (size_t p = 0; p < pixels; p++) {
    int x = (int)(p % (size_t)film->width), y = (int)(p / (size_t)film->width);
    double count = film->camera_count[p];
    if (!isfinite(count) || count < 0 || count != floor(count) || count > (double)iterations)
      return vf_error_set(VF_EFILM, "%s: pixel (%d, %d): camera count %g is not a whole number in [0, %" PRIu64 "]",
                          name, x, y, count, iterations);
    for (int c = 0; c < 3; c++) {
      double cs = film->camera_sum[3 * p + c], ls = film->light_sum[3 * p + c], ss = film->square_sum[3 * p + c];
      if (!isfinite(cs) || !isfinite(ls) || !isfinite(ss))
        return vf_error_set(VF_EFILM, "%s: pixel (%d, %d): non-finite sum", name, x, y);
      if (ss < 0) return vf_error_set(VF_EFILM, "%s: pixel (%d, %d): negative sum of squares %g", name, x, y, ss);
    }
  }
  return VF_OK;
}

/* ---- writing ---- */

static void split(double d, float *hi, float *lo) {
  *hi = (float)d;
  *lo = (float)(d - (double)*hi);
}

static void fill_film(void *user, int x0, int y0, int w, int h, float *const *planes) {
  const vf_film *film = user;
  for (int y = 0; y < h; y++) {
    for (int x = 0; x < w; x++) {
      size_t p = (size_t)(y0 + y) * (size_t)film->width + (size_t)(x0 + x), i = (size_t)y * (size_t)w + (size_t)x;
      float mean[3];
      pixel_mean(film, p, mean);
      for (int c = 0; c < 3; c++) planes[c][i] = mean[c];
      for (int q = 0; q < Q_COUNT_; q++) {
        const double *data = q_data(film, q);
        for (int c = 0; c < q_comps[q]; c++) {
          float *const *hi_lo = planes + 3 + q_first_plane[q];
          split(data[(size_t)q_comps[q] * p + (size_t)c], &hi_lo[c][i], &hi_lo[q_comps[q] + c][i]);
        }
      }
    }
  }
}

/* A value beyond float range would be written as Inf and refused on reading. */
static int check_float_range(const vf_film *film, const char *path) {
  size_t n = (size_t)film->width * (size_t)film->height;
  for (int q = 0; q < Q_COUNT_; q++) {
    const double *data = q_data(film, q);
    for (size_t i = 0; i < n * (size_t)q_comps[q]; i++)
      if (!isfinite((float)data[i]))
        return vf_error_set(VF_EFILM, "%s: pixel %zu holds %g, beyond the file format's float range", path,
                            i / (size_t)q_comps[q], data[i]);
  }
  return VF_OK;
}

/* BLAKE2b-256 of the settings text, in hex: lets a person or a script see at a glance that
 * two films were rendered with identical settings. */
static void settings_hash_hex(const char *settings_text, char hex[65]) {
  uint8_t h[32];
  crypto_generichash(h, sizeof h, (const unsigned char *)settings_text, strlen(settings_text), NULL, 0);
  for (int i = 0; i < 32; i++) snprintf(hex + 2 * i, 3, "%02x", h[i]);
}

static int set_attributes(exr_context_t ctx, const vf_film *film, const char *iterations, const char *convergence) {
  char hex[65], settings_hex[65], number[32];
  for (int i = 0; i < 32; i++) snprintf(hex + 2 * i, 3, "%02x", film->scene_hash[i]);
  settings_hash_hex(film->settings_text, settings_hex);
  exr_result_t rv = exr_attr_set_int(ctx, 0, ATTR_VERSION, VF_FILM_FORMAT_VERSION);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_SCENE, hex);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_SETTINGS, film->settings_text);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_SETTINGS_HASH, settings_hex);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_ITERATIONS, iterations);
  snprintf(number, sizeof number, "%" PRIu64, film->light_frames);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_LIGHT_FRAMES, number);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_double(ctx, 0, ATTR_SECONDS, film->render_seconds);
  snprintf(number, sizeof number, "%" PRIu64, film->nonfinite_samples);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_NONFINITE, number);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_double(ctx, 0, ATTR_CPU_SECONDS, film->cpu_seconds);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_SCENE_NAME, film->scene_name);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_CONVERGENCE, convergence);
  return rv;
}

int vf_film_write(const vf_film *film, const char *path) {
  if (film == NULL || path == NULL) return vf_error_set(VF_EINVAL, "vf_film_write: NULL argument");
  int err = vf_film_validate(film, path);
  if (err == VF_OK) err = check_float_range(film, path);
  if (err != VF_OK) return err;
  /* "[b,e)" with two 20-digit numbers and a separator is at most 45 bytes per range. */
  size_t text_size = film->iterations.count * 46 + 1;
  char *iterations = malloc(text_size), *convergence = NULL;
  if (iterations == NULL) return VF_ENOMEM;
  if ((err = vf_iterset_format(&film->iterations, iterations, text_size)) != VF_OK) goto free_text;
  if ((err = vf_convergence_format(&film->convergence, &convergence)) != VF_OK) goto free_text;

  vf_exr_out out;
  if ((err = vf_exr_create(path, film->width, film->height, VF_FILM_TILE, 0, 3 + ACCUM_PLANES, file_channels, &out)) != VF_OK)
    goto free_text;
  exr_result_t rv = set_attributes(out.ctx, film, iterations, convergence);
  if (rv != EXR_ERR_SUCCESS) {
    err = vf_exr_error(path, rv, "cannot set the film attributes");
    goto abort;
  }
  if ((err = vf_exr_write_pixels(&out, 3 + ACCUM_PLANES, file_channels, fill_film, (void *)film)) != VF_OK)
    goto abort;
  err = vf_exr_commit(&out);
  free(convergence);
  free(iterations);
  return err;
abort:
  vf_exr_abort(&out);
free_text:
  free(convergence);
  free(iterations);
  return err;
}

/* ---- reading ---- */

static const exr_attribute_t *find_attr(const vf_exr_in *in, const char *name) {
  const exr_attribute_t *attr = NULL;
  if (exr_get_attribute_by_name(in->ctx, 0, name, &attr) != EXR_ERR_SUCCESS) return NULL;
  return attr;
}

/* A string attribute copied into a new NUL-terminated buffer (*out, caller frees). */
static int get_string(const vf_exr_in *in, const char *name, char **out) {
  const exr_attribute_t *attr = find_attr(in, name);
  if (attr == NULL) return vf_error_set(VF_EFILM, "%s: not a vcmfarm film: missing attribute %s", in->path, name);
  if (attr->type != EXR_ATTR_STRING || attr->string == NULL || attr->string->length < 0 ||
      (attr->string->length > 0 && attr->string->str == NULL))
    return vf_error_set(VF_EFILM, "%s: attribute %s is not a string", in->path, name);
  size_t len = (size_t)attr->string->length;
  if (len > 0 && memchr(attr->string->str, '\0', len) != NULL)
    return vf_error_set(VF_EFILM, "%s: attribute %s contains a NUL byte", in->path, name);
  char *s = malloc(len + 1);
  if (s == NULL) return VF_ENOMEM;
  if (len) memcpy(s, attr->string->str, len);
  s[len] = '\0';
  *out = s;
  return VF_OK;
}

static int get_u64(const vf_exr_in *in, const char *name, uint64_t *out) {
  char *text = NULL;
  int err = get_string(in, name, &text);
  if (err != VF_OK) return err;
  const char *end = vf_parse_u64(text, out);
  if (end == NULL || *end != '\0')
    err = vf_error_set(VF_EFILM, "%s: attribute %s is not a decimal count: \"%.40s\"", in->path, name, text);
  free(text);
  return err;
}

static int parse_iterations(const vf_exr_in *in, const char *text, vf_iterset *set) {
  if (vf_iterset_parse(set, text) != VF_OK)
    return vf_error_set(VF_EFILM, "%s: attribute " ATTR_ITERATIONS " is malformed: %s", in->path, vf_error_detail(VF_EINVAL));
  return VF_OK;
}

static int hex_digit(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

static int get_double(const vf_exr_in *in, const char *name, double *out) {
  const exr_attribute_t *attr = find_attr(in, name);
  if (attr == NULL) return vf_error_set(VF_EFILM, "%s: missing attribute %s", in->path, name);
  if (attr->type != EXR_ATTR_DOUBLE) return vf_error_set(VF_EFILM, "%s: attribute %s is not a double", in->path, name);
  *out = attr->d;
  return VF_OK;
}

/* The attributes added after version 1 first shipped: absent means unknown, present
 * means checked like any other. */
static int read_optional_attributes(const vf_exr_in *in, vf_film *film) {
  int err = VF_OK;
  char *text = NULL;
  if (find_attr(in, ATTR_CPU_SECONDS) && (err = get_double(in, ATTR_CPU_SECONDS, &film->cpu_seconds)) != VF_OK)
    return err;
  if (!isfinite(film->cpu_seconds) || film->cpu_seconds < 0)
    return vf_error_set(VF_EFILM, "%s: attribute " ATTR_CPU_SECONDS " is not a finite number >= 0", in->path);
  if (find_attr(in, ATTR_SCENE_NAME)) {
    if ((err = get_string(in, ATTR_SCENE_NAME, &text)) != VF_OK) return err;
    if (strlen(text) >= sizeof film->scene_name)
      err = vf_error_set(VF_EFILM, "%s: attribute " ATTR_SCENE_NAME " is longer than %zu bytes", in->path,
                         sizeof film->scene_name - 1);
    else memcpy(film->scene_name, text, strlen(text) + 1);
    free(text);
    if (err != VF_OK) return err;
  }
  if (find_attr(in, ATTR_SETTINGS_HASH)) {
    char expected[65];
    settings_hash_hex(film->settings_text, expected);
    if ((err = get_string(in, ATTR_SETTINGS_HASH, &text)) != VF_OK) return err;
    if (strcmp(text, expected) != 0)
      err = vf_error_set(VF_EFILM, "%s: attribute " ATTR_SETTINGS_HASH " does not match the settings text", in->path);
    free(text);
    if (err != VF_OK) return err;
  }
  if (find_attr(in, ATTR_CONVERGENCE)) {
    if ((err = get_string(in, ATTR_CONVERGENCE, &text)) != VF_OK) return err;
    err = vf_convergence_parse(&film->convergence, text, in->path);
    free(text);
  }
  return err;
}

/* Reads every attribute into film, which has no pixels yet. */
static int read_attributes(const vf_exr_in *in, vf_film *film) {
  const exr_attribute_t *attr = find_attr(in, ATTR_VERSION);
  if (attr == NULL)
    return vf_error_set(VF_EFILM, "%s: not a vcmfarm film: missing attribute " ATTR_VERSION, in->path);
  if (attr->type != EXR_ATTR_INT) return vf_error_set(VF_EFILM, "%s: attribute " ATTR_VERSION " is not an int", in->path);
  if (attr->i != VF_FILM_FORMAT_VERSION)
    return vf_error_set(VF_EFILM, "%s: unknown film format version %d (this build reads version %d)", in->path,
                        (int)attr->i, VF_FILM_FORMAT_VERSION);

  char *text = NULL;
  int err = get_string(in, ATTR_SCENE, &text);
  if (err != VF_OK) return err;
  for (int i = 0; i < 32 && err == VF_OK; i++) {
    int hi = strlen(text) == 64 ? hex_digit(text[2 * i]) : -1, lo = hi >= 0 ? hex_digit(text[2 * i + 1]) : -1;
    if (hi < 0 || lo < 0) err = vf_error_set(VF_EFILM, "%s: attribute " ATTR_SCENE " is not 64 hex digits", in->path);
    else film->scene_hash[i] = (uint8_t)(hi * 16 + lo);
  }
  free(text);
  if (err != VF_OK) return err;

  if ((err = get_string(in, ATTR_SETTINGS, &text)) != VF_OK) return err;
  if (strlen(text) >= sizeof film->settings_text)
    err = vf_error_set(VF_EFILM, "%s: attribute " ATTR_SETTINGS " is longer than %zu bytes", in->path,
                       sizeof film->settings_text - 1);
  else memcpy(film->settings_text, text, strlen(text) + 1);
  free(text);
  if (err != VF_OK) return err;

  if ((err = get_string(in, ATTR_ITERATIONS, &text)) != VF_OK) return err;
  err = parse_iterations(in, text, &film->iterations);
  free(text);
  if (err != VF_OK) return err;

  if ((err = get_u64(in, ATTR_LIGHT_FRAMES, &film->light_frames)) != VF_OK) return err;
  if ((err = get_u64(in, ATTR_NONFINITE, &film->nonfinite_samples)) != VF_OK) return err;

  attr = find_attr(in, ATTR_SECONDS);
  if (attr == NULL) return vf_error_set(VF_EFILM, "%s: missing attribute " ATTR_SECONDS, in->path);
  if (attr->type != EXR_ATTR_DOUBLE)
    return vf_error_set(VF_EFILM, "%s: attribute " ATTR_SECONDS " is not a double", in->path);
  film->render_seconds = attr->d;
  return read_optional_attributes(in, film);
}

static int store_film(void *user, int x0, int y0, int w, int h, const float *const *planes) {
  vf_film *film = user;
  for (int y = 0; y < h; y++) {
    for (int x = 0; x < w; x++) {
      size_t p = (size_t)(y0 + y) * (size_t)film->width + (size_t)(x0 + x), i = (size_t)y * (size_t)w + (size_t)x;
      for (int q = 0; q < Q_COUNT_; q++) {
        double *data = q_data(film, q);
        const float *const *hi_lo = planes + q_first_plane[q];
        for (int c = 0; c < q_comps[q]; c++)
          data[(size_t)q_comps[q] * p + (size_t)c] = (double)hi_lo[c][i] + (double)hi_lo[q_comps[q] + c][i];
      }
    }
  }
  return VF_OK;
}

int vf_film_read(const char *path, vf_film **out) {
  if (path == NULL || out == NULL) return vf_error_set(VF_EINVAL, "vf_film_read: NULL argument");
  vf_exr_in in;
  int err = vf_exr_open(path, &in);
  if (err != VF_OK) return err;

  /* Everything cheap is checked before the pixels are allocated, so a damaged header
   * cannot make us reserve gigabytes for a file that is not a film anyway. */
  vf_film header = {0};
  vf_film *film = NULL;
  vf_iterset_init(&header.iterations);
  vf_convergence_init(&header.convergence);
  if ((err = read_attributes(&in, &header)) != VF_OK) goto fail;
  for (int k = 0; k < ACCUM_PLANES; k++)
    if (!vf_exr_has_channel(&in, accum_names[k])) {
      err = vf_error_set(VF_EFILM, "%s: not a vcmfarm film: missing channel %s", path, accum_names[k]);
      goto fail;
    }
  if (header.light_frames != vf_iterset_count(&header.iterations)) {
    err = vf_error_set(VF_EFILM, "%s: %" PRIu64 " light frames but %" PRIu64 " iterations", path, header.light_frames,
                       vf_iterset_count(&header.iterations));
    goto fail;
  }
  if ((err = vf_film_create(in.width, in.height, &film)) != VF_OK) goto fail;
  film->iterations = header.iterations; /* moved: header no longer owns it */
  vf_iterset_init(&header.iterations);
  film->light_frames = header.light_frames;
  memcpy(film->scene_hash, header.scene_hash, sizeof film->scene_hash);
  memcpy(film->settings_text, header.settings_text, sizeof film->settings_text);
  film->render_seconds = header.render_seconds;
  film->cpu_seconds = header.cpu_seconds;
  film->nonfinite_samples = header.nonfinite_samples;
  memcpy(film->scene_name, header.scene_name, sizeof film->scene_name);
  film->convergence = header.convergence; /* moved, like the iterations */
  vf_convergence_init(&header.convergence);

  if ((err = vf_exr_read_channels(&in, ACCUM_PLANES, accum_names, store_film, film)) != VF_OK) goto fail;
  if ((err = vf_film_validate(film, path)) != VF_OK) goto fail;
  vf_exr_close(&in);
  *out = film;
  return VF_OK;
fail:
  vf_film_destroy(film);
  vf_iterset_destroy(&header.iterations);
  vf_convergence_destroy(&header.convergence);
  vf_exr_close(&in);
  return err;
}
