/* The film file (docs/FILM.md): a tiled OpenEXR whose R, G, B hold the mean and which,
 * with its other channels and "vcmfarm:" attributes, holds the accumulation; written
 * atomically, read as untrusted input.
 *
 * Version 4 keeps each fixed-point sum exactly: a float high part and a 64-bit integer
 * rest in two UINT channels (common/film_planes.h), so a film read back is the film
 * written, bit for bit. Versions 1 to 3 (doubles as float pairs, about 48 significant
 * bits) are read, their sums rounded to the grids once, and written on request. */
#include "film.h"

#include "allocation.h"
#include "settings.h"

#include "error.h"
#include "exr_util.h"
#include "film_planes.h"
#include "parse.h"

#include <inttypes.h>
#include <math.h>
#include <sodium.h>
#include <stdatomic.h>
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
/* Written always, 0 included, as nonfinite_samples is, so that the header states the
 * count; a film without it (written before it existed, when upg counted its merges on
 * stderr alone) reads as 0 and merges with films that have it. */
#define ATTR_BIASED_MERGES "vcmfarm:biased_merges"
/* Only on a film with an allocation of camera sub-paths (common/allocation.h). */
#define ATTR_ALLOCATION "vcmfarm:allocation"
/* Only on a pilot's film (vf_film.pilot): "1". */
#define ATTR_PILOT "vcmfarm:pilot"

/* ---- writing ---- */

/* The film's sums for the tiles, filled on several threads, which note a value beyond
 * float range (the file is then dropped, not committed). */
typedef struct {
  vf_film_sums sums;
  atomic_int overflow;
} fill_source;

static void fill_v4(void *user, int x0, int y0, int w, int h, float *const *planes) {
  fill_source *f = user;
  if (!vf_film_planes_fill_v4(f->sums, x0, y0, w, h, planes)) atomic_store(&f->overflow, 1);
}

static void fill_v2(void *user, int x0, int y0, int w, int h, float *const *planes) {
  fill_source *f = user;
  if (!vf_film_planes_fill(f->sums, x0, y0, w, h, planes)) atomic_store(&f->overflow, 1);
}

static void fill_v1(void *user, int x0, int y0, int w, int h, float *const *planes) {
  fill_source *f = user;
  if (!vf_film_planes_fill_v1(f->sums, x0, y0, w, h, planes)) atomic_store(&f->overflow, 1);
}

/* BLAKE2b-256 of the settings text, in hex: lets a person or a script see at a glance that
 * two films were rendered with identical settings. */
static void settings_hash_hex(const char *settings_text, char hex[65]) {
  uint8_t h[32];
  crypto_generichash(h, sizeof h, (const unsigned char *)settings_text, strlen(settings_text), NULL, 0);
  for (int i = 0; i < 32; i++) snprintf(hex + 2 * i, 3, "%02x", h[i]);
}

static int set_attributes(exr_context_t ctx, const vf_film *film, int version, const char *iterations,
                          const char *convergence, const char *allocation) {
  char hex[65], settings_hex[65], number[32];
  for (int i = 0; i < 32; i++) snprintf(hex + 2 * i, 3, "%02x", film->scene_hash[i]);
  settings_hash_hex(film->settings_text, settings_hex);
  exr_result_t rv = exr_attr_set_int(ctx, 0, ATTR_VERSION, version);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_SCENE, hex);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_SETTINGS, film->settings_text);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_SETTINGS_HASH, settings_hex);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_ITERATIONS, iterations);
  /* Version 2 derives it from the iterations. */
  snprintf(number, sizeof number, "%" PRIu64, vf_iterset_count(&film->iterations));
  if (rv == EXR_ERR_SUCCESS && version == 1) rv = exr_attr_set_string(ctx, 0, ATTR_LIGHT_FRAMES, number);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_double(ctx, 0, ATTR_SECONDS, film->render_seconds);
  snprintf(number, sizeof number, "%" PRIu64, film->nonfinite_samples);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_NONFINITE, number);
  snprintf(number, sizeof number, "%" PRIu64, film->biased_merges);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_BIASED_MERGES, number);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_double(ctx, 0, ATTR_CPU_SECONDS, film->cpu_seconds);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_SCENE_NAME, film->scene_name);
  if (rv == EXR_ERR_SUCCESS) rv = exr_attr_set_string(ctx, 0, ATTR_CONVERGENCE, convergence);
  if (rv == EXR_ERR_SUCCESS && allocation != NULL) rv = exr_attr_set_string(ctx, 0, ATTR_ALLOCATION, allocation);
  if (rv == EXR_ERR_SUCCESS && film->pilot) rv = exr_attr_set_string(ctx, 0, ATTR_PILOT, "1");
  return rv;
}

int vf_film_write(const vf_film *film, const char *path) {
  return vf_film_write_version(film, path, VF_FILM_FORMAT_VERSION);
}

int vf_film_write_version(const vf_film *film, const char *path, int version) {
  if (film == NULL || path == NULL) return vf_error_set(VF_EINVAL, "vf_film_write: NULL argument");
  if (version < 1 || version > 4)
    return vf_error_set(VF_EINVAL, "%s: film format version %d cannot be written (1 to 4)", path, version);
  int err = vf_film_validate(film, path);
  if (err != VF_OK) return err;
  /* "[b,e)" with two 20-digit numbers and a separator is at most 45 bytes per range. */
  size_t text_size = film->iterations.count * 46 + 1;
  char *iterations = malloc(text_size), *convergence = NULL, *allocation = NULL;
  if (iterations == NULL) return VF_ENOMEM;
  if ((err = vf_iterset_format(&film->iterations, iterations, text_size)) != VF_OK) goto free_text;
  if ((err = vf_convergence_format(&film->convergence, &convergence)) != VF_OK) goto free_text;
  if ((film->samples != NULL || film->pilot) && version < 4) {
    err = vf_error_set(VF_EINVAL, "%s: a film with an allocation of camera sub-paths is written in format 4 only", path);
    goto free_text;
  }
  if (film->samples != NULL &&
      (err = vf_allocation_encode(film->samples, (size_t)film->width * (size_t)film->height, &allocation)) != VF_OK)
    goto free_text;

  /* Version 1 stays as it was written: uncompressed. */
  int n = version == 1 ? VF_FILM_V1_CHANNELS : version < 4 ? VF_FILM_V2_CHANNELS : VF_FILM_V4_CHANNELS;
  const char *const *names = version == 1 ? vf_film_v1_channels : version < 4 ? vf_film_v2_channels : vf_film_v4_channels;
  vf_exr_fill_fn fill = version == 1 ? fill_v1 : version < 4 ? fill_v2 : fill_v4;
  vf_exr_out out;
  if ((err = vf_exr_create_typed(path, film->width, film->height, VF_FILM_TILE, version == 1 ? VF_EXR_NONE : VF_EXR_ZIP,
                                 n, names, version == 4 ? VF_FILM_V4_UINT_MASK : 0, &out)) != VF_OK)
    goto free_text;
  exr_result_t rv = set_attributes(out.ctx, film, version, iterations, convergence, allocation);
  if (rv != EXR_ERR_SUCCESS) {
    err = vf_exr_error(path, rv, "cannot set the film attributes");
    goto abort;
  }
  if (version >= 3 && (err = vf_exr_add_checksum(&out)) != VF_OK) goto abort;
  fill_source source = {vf_film_sums_of(film), 0};
  if ((err = vf_exr_write_pixels(&out, n, names, fill, &source)) != VF_OK)
    goto abort;
  if (atomic_load(&source.overflow) && (err = vf_film_planes_check_range(film, version, path)) != VF_OK) goto abort;
  err = vf_exr_commit(&out);
  free(allocation);
  free(convergence);
  free(iterations);
  return err;
abort:
  vf_exr_abort(&out);
free_text:
  free(allocation);
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
  if (!vf_utf8_valid(attr->string->str, len))
    return vf_error_set(VF_EFILM, "%s: attribute %s is not valid UTF-8", in->path, name);
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
  if (find_attr(in, ATTR_BIASED_MERGES) && (err = get_u64(in, ATTR_BIASED_MERGES, &film->biased_merges)) != VF_OK)
    return err;
  if (find_attr(in, ATTR_CONVERGENCE)) {
    if ((err = get_string(in, ATTR_CONVERGENCE, &text)) != VF_OK) return err;
    err = vf_convergence_parse(&film->convergence, text, in->path);
    free(text);
  }
  return err;
}

static int get_version(const vf_exr_in *in, int *version) {
  const exr_attribute_t *attr = find_attr(in, ATTR_VERSION);
  if (attr == NULL)
    return vf_error_set(VF_EFILM, "%s: not a vcmfarm film: missing attribute " ATTR_VERSION, in->path);
  if (attr->type != EXR_ATTR_INT) return vf_error_set(VF_EFILM, "%s: attribute " ATTR_VERSION " is not an int", in->path);
  if (attr->i < 1 || attr->i > 4)
    return vf_error_set(VF_EFILM, "%s: unknown film format version %d (this build reads versions 1 to 4)", in->path,
                        (int)attr->i);
  *version = (int)attr->i;
  return VF_OK;
}

int vf_film_read_version(const char *path, int *version) {
  if (path == NULL || version == NULL) return vf_error_set(VF_EINVAL, "vf_film_read_version: NULL argument");
  vf_exr_in in;
  int err = vf_exr_open(path, &in);
  if (err != VF_OK) return err;
  err = get_version(&in, version);
  vf_exr_close(&in);
  return err;
}

/* Reads every attribute into film, which has no pixels yet, and the format version. */
static int read_attributes(const vf_exr_in *in, vf_film *film, int *version) {
  int err = get_version(in, version);
  if (err != VF_OK) return err;

  char *text = NULL;
  if ((err = get_string(in, ATTR_SCENE, &text)) != VF_OK) return err;
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

  if (*version == 1) {
    uint64_t frames = 0, iterations = vf_iterset_count(&film->iterations);
    if ((err = get_u64(in, ATTR_LIGHT_FRAMES, &frames)) != VF_OK) return err;
    if (frames != iterations)
      return vf_error_set(VF_EFILM, "%s: %" PRIu64 " light frames but %" PRIu64 " iterations", in->path, frames,
                          iterations);
  }
  if ((err = get_u64(in, ATTR_NONFINITE, &film->nonfinite_samples)) != VF_OK) return err;

  if ((err = get_double(in, ATTR_SECONDS, &film->render_seconds)) != VF_OK) return err;
  if ((err = read_optional_attributes(in, film)) != VF_OK) return err;
  /* Checked against its hash as written; then in today's canonical form (settings.h), so
   * that films written before it merge with films written now. Text that does not parse
   * stays as it is: every merge compares it, and nothing matches it. */
  vf_settings_canonicalize(film->settings_text, sizeof film->settings_text);
  return VF_OK;
}

typedef struct {
  vf_film_sums sums;
  const char *path;
} store_target;

static int store_v4(void *user, int x0, int y0, int w, int h, const float *const *planes) {
  store_target *t = user;
  return vf_film_planes_store_v4(t->sums, t->path, x0, y0, w, h, planes);
}

static int store_v2(void *user, int x0, int y0, int w, int h, const float *const *planes) {
  store_target *t = user;
  return vf_film_planes_store(t->sums, t->path, x0, y0, w, h, planes);
}

static int store_v1(void *user, int x0, int y0, int w, int h, const float *const *planes) {
  store_target *t = user;
  return vf_film_planes_store_v1(t->sums, t->path, x0, y0, w, h, planes);
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
  int version = 0;
  if ((err = read_attributes(&in, &header, &version)) != VF_OK) goto fail;
  /* Before any pixel is decoded: a damaged file is refused as such, whatever its bytes
   * would decode to. */
  if (version >= 3 && (err = vf_exr_verify_checksum(&in)) != VF_OK) {
    if (err == VF_EEXR) err = vf_error_set(VF_EFILM, "%s", vf_error_detail(err));
    goto fail;
  }
  /* Version 1's R, G, B are a view of the sums, never read back. */
  int n = version == 1 ? VF_FILM_V1_ACCUM : version < 4 ? VF_FILM_V2_CHANNELS : VF_FILM_V4_CHANNELS;
  const char *const *names = version == 1 ? vf_film_v1_channels + 3 : version < 4 ? vf_film_v2_channels : vf_film_v4_channels;
  vf_exr_store_fn store = version == 1 ? store_v1 : version < 4 ? store_v2 : store_v4;
  for (int k = 0; k < n; k++)
    if (!vf_exr_has_channel(&in, names[k])) {
      err = vf_error_set(VF_EFILM, "%s: not a vcmfarm film: missing channel %s", path, names[k]);
      goto fail;
    }
  if ((err = vf_film_create(in.width, in.height, &film)) != VF_OK) goto fail;
  film->iterations = header.iterations; /* moved: header no longer owns it */
  vf_iterset_init(&header.iterations);
  memcpy(film->scene_hash, header.scene_hash, sizeof film->scene_hash);
  memcpy(film->settings_text, header.settings_text, sizeof film->settings_text);
  film->render_seconds = header.render_seconds;
  film->cpu_seconds = header.cpu_seconds;
  film->nonfinite_samples = header.nonfinite_samples;
  film->biased_merges = header.biased_merges;
  memcpy(film->scene_name, header.scene_name, sizeof film->scene_name);
  film->convergence = header.convergence; /* moved, like the iterations */
  vf_convergence_init(&header.convergence);
  if (find_attr(&in, ATTR_ALLOCATION)) {
    size_t pixels = (size_t)film->width * (size_t)film->height;
    char *text = NULL;
    if ((err = get_string(&in, ATTR_ALLOCATION, &text)) != VF_OK) goto fail;
    if ((film->samples = malloc(pixels)) == NULL) err = VF_ENOMEM;
    else err = vf_allocation_decode(text, pixels, film->samples, path);
    free(text);
    if (err != VF_OK) goto fail;
  }
  if (find_attr(&in, ATTR_PILOT)) {
    char *text = NULL;
    if ((err = get_string(&in, ATTR_PILOT, &text)) != VF_OK) goto fail;
    if (strcmp(text, "1") != 0) err = vf_error_set(VF_EFILM, "%s: attribute " ATTR_PILOT " is not \"1\"", path);
    free(text);
    if (err != VF_OK) goto fail;
    film->pilot = 1;
  }

  store_target target = {vf_film_sums_of(film), path};
  if ((err = vf_exr_read_channels_typed(&in, n, names, version == 4 ? VF_FILM_V4_UINT_MASK : 0, store, &target)) !=
      VF_OK)
    goto fail;
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
