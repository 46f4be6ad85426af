/* Textures: decoding PNG (libpng), JPEG (libjpeg) and EXR (common/image.c) into the
 * texels of worker/scene/texture.h. The renderer's lookups are
 * worker/render/texture_lookup.c.
 *
 * Decoders keep the values the file stores. PNG gamma, sRGB and ICC chunks and JPEG colour
 * profiles are ignored, as glTF 2.0 requires of its images ("any colorspace information ...
 * MUST be ignored"): which transfer function applies is the material slot's business (sRGB
 * for colour, linear for data), not the file's. That is why PNGs go through libpng's
 * classic API, whose simplified one would apply the file's gamma (and assume linear for a
 * 16-bit file without a gAMA chunk).
 *
 * Every file is untrusted: dimensions are checked before texels are allocated, libpng and
 * libjpeg report through longjmp (never exit()), libjpeg's warnings (a truncated stream
 * that it would pad with grey, for one) count as errors, and EXR texels must be finite. */
#include "texture.h"

#include "../../common/error.h"
#include "../../common/image.h"

#include <errno.h>
#include <math.h>
#include <setjmp.h>
#include <stdio.h> /* before jpeglib.h, which uses FILE without including it */
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#include <jpeglib.h>
#include <png.h>
#include <sodium.h>

/* texture.h's limits: each side, and the whole image. */
#define MAX_SIDE 32768
#define MAX_TEXELS ((uint64_t)1 << 28)
/* Files above this are refused before they are read (a 2^28-texel RGBA PNG is far smaller). */
#define MAX_FILE_BYTES ((uint64_t)1 << 31)

/* ---- shared by the decoders ---- */

static int check_size(const char *name, uint64_t width, uint64_t height) {
  if (width < 1 || height < 1 || width > MAX_SIDE || height > MAX_SIDE || width * height > MAX_TEXELS)
    return vf_error_set(VF_ETEXTURE, "%s: %llux%llu texels is empty or too large (at most %d on a side and 2^28 in all)",
                        name, (unsigned long long)width, (unsigned long long)height, MAX_SIDE);
  return VF_OK;
}

/* ---- PNG (libpng's classic API: stored values, no gamma transform) ---- */

typedef struct {
  const uint8_t *bytes;
  size_t size, at;
} png_source;

static void png_read_memory(png_structp png, png_bytep data, size_t n) {
  png_source *src = png_get_io_ptr(png);
  if (n > src->size - src->at) png_error(png, "file truncated");
  memcpy(data, src->bytes + src->at, n);
  src->at += n;
}

/* libpng's error_ptr is the caller's message buffer (PNG_MESSAGE bytes). */
#define PNG_MESSAGE 200

static void png_fail(png_structp png, png_const_charp msg) {
  snprintf(png_get_error_ptr(png), PNG_MESSAGE, "%s", msg ? msg : "libpng error");
  png_longjmp(png, 1);
}

static void png_quiet(png_structp png, png_const_charp msg) {
  (void)png;
  (void)msg;
}

/* Asks libpng for 8-bit texels of the file's own channels: palette to RGB, tRNS to an alpha
 * channel, low-depth grey to 8 bits, 16 bits scaled (round(v * 255 / 65535)). */
static void png_choose_transforms(png_structp png, png_infop info) {
  int color = png_get_color_type(png, info), depth = png_get_bit_depth(png, info);
  if (color == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if (color == PNG_COLOR_TYPE_GRAY && depth < 8) png_set_expand_gray_1_2_4_to_8(png);
  if (png_get_valid(png, info, PNG_INFO_tRNS)) png_set_tRNS_to_alpha(png);
  if (depth == 16) png_set_scale_16(png);
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
}

static int decode_png(const uint8_t *bytes, size_t size, const char *name, vf_texture *out) {
  char message[PNG_MESSAGE] = "";
  png_source src = {bytes, size, 0};
  /* Changed between setjmp and a longjmp back to it, hence volatile. */
  uint8_t *volatile texels = NULL;
  png_bytep *volatile rows = NULL;
  int err = VF_OK;
  png_structp png = png_create_read_struct(PNG_LIBPNG_VER_STRING, message, png_fail, png_quiet);
  png_infop info = png ? png_create_info_struct(png) : NULL;
  if (png == NULL || info == NULL) {
    png_destroy_read_struct(png ? &png : NULL, NULL, NULL);
    return vf_error_set(VF_ENOMEM, "%s: cannot create a PNG reader", name);
  }
  if (setjmp(png_jmpbuf(png))) {
    err = vf_error_set(VF_ETEXTURE, "%s: corrupt PNG: %s", name, message);
    goto done;
  }
  png_set_read_fn(png, &src, png_read_memory);
  png_read_info(png, info);
  png_uint_32 w = png_get_image_width(png, info), h = png_get_image_height(png, info);
  if ((err = check_size(name, w, h)) != VF_OK) goto done;
  png_choose_transforms(png, info);
  int channels = png_get_channels(png, info);
  if (png_get_bit_depth(png, info) != 8 || channels < 1 || channels > 4) {
    err = vf_error_set(VF_ETEXTURE, "%s: PNG of %d channels of %d bits is not supported", name, channels,
                       png_get_bit_depth(png, info));
    goto done;
  }
  size_t stride = (size_t)w * (size_t)channels;
  texels = malloc(stride * h);
  rows = malloc(h * sizeof *rows);
  if (texels == NULL || rows == NULL) {
    err = vf_error_set(VF_ENOMEM, "%s: out of memory for %ux%u texels", name, (unsigned)w, (unsigned)h);
    goto done;
  }
  for (png_uint_32 y = 0; y < h; y++) rows[y] = texels + y * stride;
  png_read_image(png, rows);
  png_read_end(png, NULL); /* up to IEND: a file cut after its image data is still cut */
  out->width = w;
  out->height = h;
  out->channels = channels;
  out->is_float = 0;
  out->texels = texels;
  texels = NULL;
done:
  png_destroy_read_struct(&png, &info, NULL);
  free(rows);
  free(texels);
  return err;
}

/* ---- JPEG (libjpeg through setjmp/longjmp) ---- */

typedef struct {
  struct jpeg_error_mgr mgr; /* first: libjpeg hands back a pointer to it */
  jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
} jpg_failure;

static void jpg_fail(j_common_ptr cinfo) {
  jpg_failure *f = (jpg_failure *)cinfo->err;
  cinfo->err->format_message(cinfo, f->message);
  longjmp(f->jump, 1);
}

/* Level -1 is a warning: corrupt data libjpeg would decode anyway (a truncated file becomes
 * grey texels). A texture with made-up texels is refused; trace levels (>= 0) are ignored. */
static void jpg_message(j_common_ptr cinfo, int level) {
  if (level < 0) jpg_fail(cinfo);
}

static void jpg_quiet(j_common_ptr cinfo) { (void)cinfo; }

/* The components to ask for: grey stays grey, YCbCr and RGB become RGB; CMYK and the rest
 * are refused (0). */
static int jpg_channels(const struct jpeg_decompress_struct *cinfo) {
  if (cinfo->num_components == 1) return 1;
  if (cinfo->num_components == 3 && (cinfo->jpeg_color_space == JCS_YCbCr || cinfo->jpeg_color_space == JCS_RGB))
    return 3;
  return 0;
}

static int decode_jpeg(const uint8_t *bytes, size_t size, const char *name, vf_texture *out) {
  struct jpeg_decompress_struct cinfo;
  jpg_failure fail;
  uint8_t *volatile texels = NULL; /* changed between setjmp and a longjmp back to it */
  int err;
  cinfo.err = jpeg_std_error(&fail.mgr);
  fail.mgr.error_exit = jpg_fail;
  fail.mgr.emit_message = jpg_message;
  fail.mgr.output_message = jpg_quiet;
  fail.message[0] = '\0';
  if (setjmp(fail.jump)) {
    jpeg_destroy_decompress(&cinfo);
    free(texels);
    return vf_error_set(VF_ETEXTURE, "%s: corrupt JPEG: %s", name, fail.message);
  }
  jpeg_create_decompress(&cinfo);
  jpeg_mem_src(&cinfo, bytes, (unsigned long)size);
  jpeg_read_header(&cinfo, TRUE);
  int channels = jpg_channels(&cinfo);
  if ((err = check_size(name, cinfo.image_width, cinfo.image_height)) != VF_OK) goto fail;
  if (channels == 0) {
    err = vf_error_set(VF_ETEXTURE, "%s: %s JPEG is not supported (grey, YCbCr or RGB only)", name,
                       cinfo.jpeg_color_space == JCS_CMYK || cinfo.jpeg_color_space == JCS_YCCK ? "a CMYK" : "this colour space of");
    goto fail;
  }
  cinfo.out_color_space = channels == 1 ? JCS_GRAYSCALE : JCS_RGB;
  cinfo.dct_method = JDCT_ISLOW; /* the accurate integer IDCT, the same on every machine */
  jpeg_start_decompress(&cinfo);
  if (cinfo.output_components != channels) {
    err = vf_error_set(VF_ETEXTURE, "%s: JPEG decodes to %d components, expected %d", name, cinfo.output_components, channels);
    goto fail;
  }
  size_t stride = (size_t)cinfo.output_width * (size_t)channels;
  if ((texels = malloc(stride * cinfo.output_height)) == NULL) {
    err = vf_error_set(VF_ENOMEM, "%s: out of memory for %ux%u texels", name, cinfo.output_width, cinfo.output_height);
    goto fail;
  }
  while (cinfo.output_scanline < cinfo.output_height) {
    JSAMPROW row = texels + (size_t)cinfo.output_scanline * stride;
    jpeg_read_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_decompress(&cinfo); /* reads to the end marker: a missing one is an error */
  out->width = cinfo.output_width;
  out->height = cinfo.output_height;
  out->channels = channels;
  out->is_float = 0;
  out->texels = texels;
  jpeg_destroy_decompress(&cinfo);
  return VF_OK;
fail:
  jpeg_destroy_decompress(&cinfo);
  free(texels);
  return err;
}

/* ---- EXR (common/image.c's reader) ---- */

static int decode_exr(const uint8_t *bytes, size_t size, const char *name, vf_texture *out) {
  int w, h, channels;
  float *texels;
  int err = vf_image_decode_exr_texels(bytes, size, name, MAX_SIDE, &w, &h, &channels, &texels);
  if (err == VF_EEXR) return vf_error_set(VF_ETEXTURE, "%s", vf_error_detail(err)); /* the detail names the file */
  if (err != VF_OK) return err;
  /* No slot has a use for NaN or infinity, and one would poison every path through it. */
  size_t n = (size_t)w * (size_t)h * (size_t)channels;
  for (size_t i = 0; i < n; i++)
    if (!isfinite(texels[i])) {
      size_t texel = i / (size_t)channels;
      free(texels);
      return vf_error_set(VF_ETEXTURE, "%s: texel (%zu, %zu) has a non-finite value in channel %zu", name,
                          texel % (size_t)w, texel / (size_t)w, i % (size_t)channels);
    }
  out->width = (uint32_t)w;
  out->height = (uint32_t)h;
  out->channels = channels;
  out->is_float = 1;
  out->texels = texels;
  return VF_OK;
}

/* ---- public ---- */

int vf_texture_decode(const void *bytes, size_t size, const char *name, vf_texture *out) {
  static const uint8_t png_magic[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
  static const uint8_t jpeg_magic[3] = {0xff, 0xd8, 0xff};
  static const uint8_t exr_magic[4] = {0x76, 0x2f, 0x31, 0x01};
  const uint8_t *b = bytes;
  vf_texture t;
  memset(&t, 0, sizeof t);
  int err;
  if (size > MAX_FILE_BYTES) return vf_error_set(VF_ETEXTURE, "%s: file of %zu bytes is too large", name, size);
  if (size >= sizeof png_magic && memcmp(b, png_magic, sizeof png_magic) == 0) err = decode_png(b, size, name, &t);
  else if (size >= sizeof jpeg_magic && memcmp(b, jpeg_magic, sizeof jpeg_magic) == 0) err = decode_jpeg(b, size, name, &t);
  else if (size >= sizeof exr_magic && memcmp(b, exr_magic, sizeof exr_magic) == 0) err = decode_exr(b, size, name, &t);
  else return vf_error_set(VF_ETEXTURE, "%s: unsupported texture format (not PNG, JPEG or EXR)", name);
  if (err != VF_OK) return err;
  snprintf(t.name, sizeof t.name, "%s", name);
  if (sodium_init() < 0) abort(); /* cannot fail once libsodium is linked; never hash garbage */
  crypto_generichash(t.hash, sizeof t.hash, b, size, NULL, 0);
  *out = t;
  return VF_OK;
}

/* The whole file, for vf_texture_read; VF_ENOENT when it cannot be opened. */
static int read_file(const char *path, const char *name, uint8_t **bytes, size_t *size) {
  FILE *f = fopen(path, "rb");
  if (f == NULL) return vf_error_set(VF_ENOENT, "%s: cannot open: %s", name, strerror(errno));
  struct stat st;
  int err = VF_OK;
  uint8_t *buf = NULL;
  if (fstat(fileno(f), &st) != 0 || !S_ISREG(st.st_mode)) {
    err = vf_error_set(VF_ENOENT, "%s: cannot open: not a regular file", name);
    goto done;
  }
  if ((uint64_t)st.st_size > MAX_FILE_BYTES) {
    err = vf_error_set(VF_ETEXTURE, "%s: file of %lld bytes is too large", name, (long long)st.st_size);
    goto done;
  }
  size_t n = (size_t)st.st_size;
  if ((buf = malloc(n ? n : 1)) == NULL) {
    err = vf_error_set(VF_ENOMEM, "%s: out of memory for %zu bytes", name, n);
    goto done;
  }
  if (fread(buf, 1, n, f) != n) {
    err = vf_error_set(VF_EIO, "%s: read failed: %s", name, ferror(f) ? strerror(errno) : "file shrank");
    goto done;
  }
  *bytes = buf;
  *size = n;
  buf = NULL;
done:
  free(buf);
  fclose(f);
  return err;
}

int vf_texture_read(const char *path, const char *name, vf_texture *out) {
  uint8_t *bytes = NULL;
  size_t size = 0;
  int err = read_file(path, name, &bytes, &size);
  if (err != VF_OK) return err;
  err = vf_texture_decode(bytes, size, name, out);
  free(bytes);
  return err;
}

void vf_texture_release(vf_texture *t) {
  if (t == NULL) return;
  free(t->texels);
  memset(t, 0, sizeof *t);
}

size_t vf_texture_bytes(const vf_texture *t) {
  return (size_t)t->width * t->height * (size_t)t->channels * (t->is_float ? sizeof(float) : 1);
}
