/* The film file (docs/FILM.md): a tiled OpenEXR whose R, G, B hold the mean and whose
 * other channels and "vcmfarm:" attributes hold the accumulation exactly; written
 * atomically, read as untrusted input.
 *
 * The file keeps each double as two floats, hi = (float)d and lo = (float)(d - hi), because
 * EXR has no double channels: hi + lo carries about 48 significant bits, so a film read back
 * differs from the one written by a relative ~4e-15 at most (counts below 2^48 exactly). */
#include "film.h"

#include "error.h"
#include "exr_util.h"
#include "parse.h"

#include <inttypes.h>
#include <math.h>
#include <sodium.h>
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
      vf_film_pixel_mean(film, p, mean);
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

/* A string attribute copied into dst, which holds at most cap - 1 bytes and the NUL. */
static int get_bounded_string(const vf_exr_in *in, const char *name, char *dst, size_t cap) {
  char *text = NULL;
  int err = get_string(in, name, &text);
  if (err != VF_OK) return err;
  if (strlen(text) >= cap)
    err = vf_error_set(VF_EFILM, "%s: attribute %s is longer than %zu bytes", in->path, name, cap - 1);
  else memcpy(dst, text, strlen(text) + 1);
  free(text);
  return err;
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
  int err = vf_iterset_parse(set, text);
  if (err == VF_EINVAL || err == VF_EOVERLAP)
    return vf_error_set(VF_EFILM, "%s: attribute " ATTR_ITERATIONS " is malformed: %s", in->path, vf_error_detail(err));
  return err;
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
  if (find_attr(in, ATTR_SCENE_NAME) &&
      (err = get_bounded_string(in, ATTR_SCENE_NAME, film->scene_name, sizeof film->scene_name)) != VF_OK)
    return err;
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

  if ((err = get_bounded_string(in, ATTR_SETTINGS, film->settings_text, sizeof film->settings_text)) != VF_OK)
    return err;

  if ((err = get_string(in, ATTR_ITERATIONS, &text)) != VF_OK) return err;
  err = parse_iterations(in, text, &film->iterations);
  free(text);
  if (err != VF_OK) return err;

  if ((err = get_u64(in, ATTR_LIGHT_FRAMES, &film->light_frames)) != VF_OK) return err;
  if ((err = get_u64(in, ATTR_NONFINITE, &film->nonfinite_samples)) != VF_OK) return err;

  if ((err = get_double(in, ATTR_SECONDS, &film->render_seconds)) != VF_OK) return err;
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
