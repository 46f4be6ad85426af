/* Plain RGB images through OpenEXRCore (common/exr_util.c) and libpng.
 *
 * Reading takes the data window as the image: a display window that differs (larger,
 * smaller, offset, or not even overlapping) is ignored, because references and environment
 * maps are compared and sampled pixel for pixel, and padding with an invented background
 * would make up data. Values are returned as stored, NaN and Inf included; callers that
 * need finite values check them. */
#include "image.h"

#include "error.h"
#include "exr_util.h"

#include <math.h>
#include <png.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

int vf_image_alloc(vf_image *img, int width, int height) {
  if (img == NULL || width < 1 || height < 1 || width > VF_EXR_MAX_SIDE || height > VF_EXR_MAX_SIDE ||
      (int64_t)width * height > VF_EXR_MAX_PIXELS)
    return vf_error_set(VF_EINVAL, "image size %dx%d is empty or too large", width, height);
  float *rgb = calloc((size_t)width * (size_t)height * 3, sizeof *rgb);
  if (rgb == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a %dx%d image", width, height);
  img->width = width;
  img->height = height;
  img->rgb = rgb;
  return VF_OK;
}

void vf_image_destroy(vf_image *img) {
  if (img == NULL) return;
  free(img->rgb);
  memset(img, 0, sizeof *img);
}

/* ---- reading ---- */

typedef struct {
  vf_image *img;
  int grey; /* one plane (Y) copied into R, G and B */
} rgb_target;

static int store_rgb(void *user, int x0, int y0, int w, int h, const float *const *planes) {
  rgb_target *t = user;
  int width = t->img->width;
  for (int y = 0; y < h; y++) {
    float *dst = t->img->rgb + ((size_t)(y0 + y) * (size_t)width + (size_t)x0) * 3;
    size_t row = (size_t)y * (size_t)w;
    for (int x = 0; x < w; x++, dst += 3) {
      if (t->grey) {
        dst[0] = dst[1] = dst[2] = planes[0][row + (size_t)x];
      } else {
        dst[0] = planes[0][row + (size_t)x];
        dst[1] = planes[1][row + (size_t)x];
        dst[2] = planes[2][row + (size_t)x];
      }
    }
  }
  return VF_OK;
}

/* R, G, B if all three exist; a lone Y as grey; anything else is refused by name. */
static int choose_channels(const vf_exr_in *in, int *grey) {
  int r = vf_exr_has_channel(in, "R"), g = vf_exr_has_channel(in, "G"), b = vf_exr_has_channel(in, "B");
  if (r && g && b) {
    *grey = 0;
    return VF_OK;
  }
  if (r || g || b)
    return vf_error_set(VF_EEXR, "%s: missing channel %s (an RGB image needs R, G and B)", in->path,
                        !r ? "R" : !g ? "G" : "B");
  if (vf_exr_has_channel(in, "Y")) {
    /* Reading only Y of a luminance/chroma image would silently drop its colour. */
    if (vf_exr_has_channel(in, "RY") || vf_exr_has_channel(in, "BY"))
      return vf_error_set(VF_EEXR, "%s: luminance/chroma (Y, RY, BY) images are not supported", in->path);
    *grey = 1;
    return VF_OK;
  }
  return vf_error_set(VF_EEXR, "%s: no R, G, B or Y channel", in->path);
}

int vf_image_read_exr(const char *path, vf_image *out) {
  if (path == NULL || out == NULL) return vf_error_set(VF_EINVAL, "vf_image_read_exr: NULL argument");
  vf_exr_in in;
  int err = vf_exr_open(path, &in);
  if (err != VF_OK) return err;
  vf_image img = {0};
  rgb_target target = {&img, 0};
  if ((err = choose_channels(&in, &target.grey)) != VF_OK) goto close;
  if ((err = vf_image_alloc(&img, in.width, in.height)) != VF_OK) goto close;
  static const char *const rgb_names[3] = {"R", "G", "B"};
  static const char *const grey_names[1] = {"Y"};
  err = vf_exr_read_channels(&in, target.grey ? 1 : 3, target.grey ? grey_names : rgb_names, store_rgb, &target);
  if (err != VF_OK) goto free_image;
  vf_exr_close(&in);
  *out = img;
  return VF_OK;
free_image:
  vf_image_destroy(&img);
close:
  vf_exr_close(&in);
  return err;
}

/* ---- texels of a file in memory ---- */

typedef struct {
  float *texels;
  int width, channels;
} texel_target;

static int store_texels(void *user, int x0, int y0, int w, int h, const float *const *planes) {
  texel_target *t = user;
  const int n = t->channels;
  for (int y = 0; y < h; y++) {
    float *dst = t->texels + ((size_t)(y0 + y) * (size_t)t->width + (size_t)x0) * (size_t)n;
    size_t row = (size_t)y * (size_t)w;
    for (int x = 0; x < w; x++, dst += n)
      for (int k = 0; k < n; k++) dst[k] = planes[k][row + (size_t)x];
  }
  return VF_OK;
}

int vf_image_decode_exr_texels(const void *bytes, size_t size, const char *name, int max_side, int *width,
                               int *height, int *channels, float **texels) {
  vf_exr_in in;
  int err = vf_exr_open_memory(bytes, size, name, &in);
  if (err != VF_OK) return err;
  int grey = 0;
  if ((err = choose_channels(&in, &grey)) != VF_OK) goto close;
  if (in.width > max_side || in.height > max_side) {
    err = vf_error_set(VF_EEXR, "%s: %dx%d is larger than %d on a side", name, in.width, in.height, max_side);
    goto close;
  }
  int alpha = vf_exr_has_channel(&in, "A");
  static const char *const names[2][4] = {{"R", "G", "B", "A"}, {"Y", "A"}};
  const char *const *wanted = names[grey];
  texel_target target = {NULL, in.width, (grey ? 1 : 3) + alpha};
  target.texels = malloc((size_t)in.width * (size_t)in.height * (size_t)target.channels * sizeof(float));
  if (target.texels == NULL) {
    err = vf_error_set(VF_ENOMEM, "%s: out of memory for %dx%d texels", name, in.width, in.height);
    goto close;
  }
  if ((err = vf_exr_read_channels(&in, target.channels, wanted, store_texels, &target)) != VF_OK) {
    free(target.texels);
    goto close;
  }
  *width = in.width;
  *height = in.height;
  *channels = target.channels;
  *texels = target.texels;
close:
  vf_exr_close(&in);
  return err;
}

/* ---- writing ---- */

static int check_image(const char *path, const vf_image *img) {
  if (path == NULL || img == NULL || img->rgb == NULL || img->width < 1 || img->height < 1)
    return vf_error_set(VF_EINVAL, "%s: no image to write", path ? path : "(null)");
  return VF_OK;
}

static void fill_rgb(void *user, int x0, int y0, int w, int h, float *const *planes) {
  const vf_image *img = user;
  for (int y = 0; y < h; y++) {
    const float *src = img->rgb + ((size_t)(y0 + y) * (size_t)img->width + (size_t)x0) * 3;
    size_t row = (size_t)y * (size_t)w;
    for (int x = 0; x < w; x++, src += 3) {
      planes[0][row + (size_t)x] = src[0];
      planes[1][row + (size_t)x] = src[1];
      planes[2][row + (size_t)x] = src[2];
    }
  }
}

int vf_image_write_exr(const char *path, const vf_image *img) {
  int err = check_image(path, img);
  if (err != VF_OK) return err;
  static const char *const names[3] = {"R", "G", "B"};
  vf_exr_out out;
  if ((err = vf_exr_create(path, img->width, img->height, 0, 1, 3, names, &out)) != VF_OK) return err;
  if ((err = vf_exr_write_pixels(&out, 3, names, fill_rgb, (void *)img)) != VF_OK) {
    vf_exr_abort(&out);
    return err;
  }
  return vf_exr_commit(&out);
}

/* IEC 61966-2-1 encoding of a linear value already clamped to [0, 1]. */
static float srgb_encode(float v) {
  return v <= 0.0031308f ? 12.92f * v : 1.055f * powf(v, 1.0f / 2.4f) - 0.055f;
}

static uint8_t to_srgb8(float v, float scale) {
  v *= scale;
  if (!(v > 0.0f)) return 0; /* negative and NaN are black */
  if (v >= 1.0f) return 255;
  return (uint8_t)(srgb_encode(v) * 255.0f + 0.5f);
}

typedef struct {
  vf_atomic_file *file;
  uint64_t offset;
} png_sink;

static _Thread_local char png_message[200];

static void png_write_to_file(png_structp png, png_bytep data, size_t length) {
  png_sink *sink = png_get_io_ptr(png);
  if (vf_atomic_pwrite(sink->file, data, length, sink->offset) != VF_OK) png_error(png, vf_error_detail(VF_EIO));
  sink->offset += length;
}

static void png_flush_nothing(png_structp png) { (void)png; }

static void png_fail(png_structp png, png_const_charp msg) {
  snprintf(png_message, sizeof png_message, "%s", msg ? msg : "libpng error");
  png_longjmp(png, 1);
}

static void png_ignore_warning(png_structp png, png_const_charp msg) {
  (void)png;
  (void)msg;
}

/* The PNG of img at exposure through libpng to sink (a write function and its argument);
 * `name` names the output in errors. */
static int encode_png(const char *name, const vf_image *img, float exposure, png_rw_ptr write, void *sink) {
  if (!isfinite(exposure)) return vf_error_set(VF_EINVAL, "%s: exposure %g is not finite", name, (double)exposure);
  const float scale = exp2f(exposure);
  uint8_t *row = malloc((size_t)img->width * 3);
  if (row == NULL) return VF_ENOMEM;
  int err = VF_OK;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, png_fail, png_ignore_warning);
  png_infop info = png ? png_create_info_struct(png) : NULL;
  if (png == NULL || info == NULL) {
    err = vf_error_set(VF_ENOMEM, "%s: cannot create a PNG writer", name);
    goto destroy_png;
  }
  /* Nothing below changes a local that the error branch reads, so no volatile is needed. */
  if (setjmp(png_jmpbuf(png))) {
    err = vf_error_set(VF_EIO, "%s: PNG write failed: %s", name, png_message);
    goto destroy_png;
  }
  png_set_write_fn(png, sink, write, png_flush_nothing);
  png_set_IHDR(png, info, (png_uint_32)img->width, (png_uint_32)img->height, 8, PNG_COLOR_TYPE_RGB,
               PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  png_set_sRGB_gAMA_and_cHRM(png, info, PNG_sRGB_INTENT_PERCEPTUAL);
  png_write_info(png, info);
  for (int y = 0; y < img->height; y++) {
    const float *src = img->rgb + (size_t)y * (size_t)img->width * 3;
    for (size_t i = 0; i < (size_t)img->width * 3; i++) row[i] = to_srgb8(src[i], scale);
    png_write_row(png, row);
  }
  png_write_end(png, info);
destroy_png:
  png_destroy_write_struct(png ? &png : NULL, info ? &info : NULL);
  free(row);
  return err;
}

int vf_image_write_png(const char *path, const vf_image *img, float exposure) {
  int err = check_image(path, img);
  if (err != VF_OK) return err;
  vf_atomic_file file;
  if ((err = vf_atomic_open(&file, path)) != VF_OK) return err;
  png_sink sink = {&file, 0};
  if ((err = encode_png(path, img, exposure, png_write_to_file, &sink)) != VF_OK) {
    vf_atomic_abort(&file);
    return err;
  }
  return vf_atomic_commit(&file);
}

typedef struct {
  uint8_t *bytes;
  size_t size, capacity;
} png_buffer;

static void png_write_to_buffer(png_structp png, png_bytep data, size_t length) {
  png_buffer *b = png_get_io_ptr(png);
  if (length > b->capacity - b->size) {
    size_t capacity = b->capacity ? b->capacity : 65536;
    while (length > capacity - b->size) capacity *= 2;
    uint8_t *bytes = realloc(b->bytes, capacity);
    if (bytes == NULL) png_error(png, "out of memory");
    b->bytes = bytes;
    b->capacity = capacity;
  }
  memcpy(b->bytes + b->size, data, length);
  b->size += length;
}

int vf_image_encode_png(const vf_image *img, float exposure, uint8_t **png, size_t *size) {
  int err = check_image("PNG in memory", img);
  if (err != VF_OK) return err;
  png_buffer b = {NULL, 0, 0};
  if ((err = encode_png("PNG in memory", img, exposure, png_write_to_buffer, &b)) != VF_OK) {
    free(b.bytes);
    return err;
  }
  *png = b.bytes;
  *size = b.size;
  return VF_OK;
}
