/* worker/scene/texture.c and the scene's textures (worker/scene/textures.c, the material fields
 * of worker/scene/json.c): every image here is written by the test itself (libpng,
 * libjpeg, common/'s EXR writer), so the expected texels are known exactly; the damaged
 * files of the OpenEXR corpus must be refused without a crash. */
#include "check.h"
#include "exr_corpus.h"
#include "film_fixtures.h"

#include "common/error.h"
#include "common/exr_util.h"
#include "worker/scene/scene.h"
#include "worker/scene/json.h"
#include "worker/scene/load.h"
#include "worker/scene/files.h"
#include "worker/render/texture_lookup.h"
#include "worker/scene/texture.h"

#include <math.h>
#include <stdint.h>
#include <stdio.h> /* before jpeglib.h */
#include <stdlib.h>
#include <string.h>

#include <jpeglib.h>
#include <png.h>
#include <sodium.h>

/* ---- writers ---- */

/* A PNG of `rows` (bytes as the format stores them: 16-bit samples big-endian), with an
 * optional palette and tRNS chunk. 1 on success. */
static int write_png(const char *path, int w, int h, int color_type, int depth, const uint8_t *rows,
                     const png_color *palette, int num_palette, const png_byte *trns, int num_trns,
                     const png_color_16 *trns_color) {
  FILE *f = fopen(path, "wb");
  if (f == NULL) return 0;
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, NULL, NULL, NULL);
  png_infop info = png_create_info_struct(png);
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    fclose(f);
    return 0;
  }
  png_init_io(png, f);
  png_set_IHDR(png, info, (png_uint_32)w, (png_uint_32)h, depth, color_type, PNG_INTERLACE_NONE,
               PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
  if (palette) png_set_PLTE(png, info, palette, num_palette);
  if (trns || trns_color) png_set_tRNS(png, info, trns, num_trns, trns_color);
  /* A gamma chunk the decoder must ignore: textures keep the stored values. */
  png_set_gAMA(png, info, 1.0);
  png_write_info(png, info);
  int channels = color_type == PNG_COLOR_TYPE_GRAY || color_type == PNG_COLOR_TYPE_PALETTE ? 1
                 : color_type == PNG_COLOR_TYPE_GRAY_ALPHA ? 2
                 : color_type == PNG_COLOR_TYPE_RGB ? 3 : 4;
  size_t stride = ((size_t)w * (size_t)channels * (size_t)depth + 7) / 8;
  for (int y = 0; y < h; y++) png_write_row(png, rows + (size_t)y * stride);
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  return fclose(f) == 0;
}

/* A baseline JPEG at `quality`, without chroma subsampling; components 1 (grey), 3 (RGB)
 * or 4 (CMYK). 1 on success. */
static int write_jpeg(const char *path, int w, int h, int components, const uint8_t *pixels, int quality) {
  FILE *f = fopen(path, "wb");
  if (f == NULL) return 0;
  struct jpeg_compress_struct cinfo;
  struct jpeg_error_mgr jerr;
  cinfo.err = jpeg_std_error(&jerr);
  jpeg_create_compress(&cinfo);
  jpeg_stdio_dest(&cinfo, f);
  cinfo.image_width = (JDIMENSION)w;
  cinfo.image_height = (JDIMENSION)h;
  cinfo.input_components = components;
  cinfo.in_color_space = components == 1 ? JCS_GRAYSCALE : components == 3 ? JCS_RGB : JCS_CMYK;
  jpeg_set_defaults(&cinfo);
  jpeg_set_quality(&cinfo, quality, TRUE);
  for (int c = 0; c < cinfo.num_components; c++) cinfo.comp_info[c].h_samp_factor = cinfo.comp_info[c].v_samp_factor = 1;
  cinfo.dct_method = JDCT_ISLOW;
  jpeg_start_compress(&cinfo, TRUE);
  while (cinfo.next_scanline < cinfo.image_height) {
    JSAMPROW row = (JSAMPROW)(pixels + (size_t)cinfo.next_scanline * (size_t)w * (size_t)components);
    jpeg_write_scanlines(&cinfo, &row, 1);
  }
  jpeg_finish_compress(&cinfo);
  jpeg_destroy_compress(&cinfo);
  return fclose(f) == 0;
}

typedef struct {
  int width, channels;
  const float *texels; /* interleaved */
} exr_source;

static void fill_planes(void *user, int x0, int y0, int w, int h, float *const *planes) {
  const exr_source *src = user;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++)
      for (int k = 0; k < src->channels; k++)
        planes[k][(size_t)y * (size_t)w + (size_t)x] =
            src->texels[((size_t)(y0 + y) * (size_t)src->width + (size_t)(x0 + x)) * (size_t)src->channels + (size_t)k];
}

/* A FLOAT EXR through common/'s writer with channels `names` (interleaved texels). */
static int write_exr(const char *path, int w, int h, int n, const char *const *names, const float *texels) {
  vf_exr_out out;
  exr_source src = {w, n, texels};
  if (vf_exr_create(path, w, h, 0, VF_EXR_ZIP, n, names, &out) != VF_OK) return 0;
  if (vf_exr_write_pixels(&out, n, names, fill_planes, &src) != VF_OK) {
    vf_exr_abort(&out);
    return 0;
  }
  return vf_exr_commit(&out) == VF_OK;
}

/* Reads `name` from the scratch directory; the error code, *t set on success. */
static int read_texture(const char *name, vf_texture *t) { return vf_texture_read(fixture_path(name), name, t); }

/* A texture of the given texels, as the decoders would fill one (texels borrowed). */
static vf_texture make_texture(uint32_t w, uint32_t h, int channels, int is_float, void *texels) {
  vf_texture t;
  memset(&t, 0, sizeof t);
  t.width = w;
  t.height = h;
  t.channels = channels;
  t.is_float = is_float;
  t.texels = texels;
  return t;
}

static double srgb_formula(int v) {
  double c = v / 255.0;
  return c <= 0.04045 ? c / 12.92 : pow((c + 0.055) / 1.055, 2.4);
}

/* ---- lookup ---- */

static void test_srgb_and_linear_tables_match_the_formula(void) {
  uint8_t ramp[256];
  for (int i = 0; i < 256; i++) ramp[i] = (uint8_t)i;
  vf_texture t = make_texture(256, 1, 1, 0, ramp);
  for (int v = 0; v < 256; v++) {
    float lin[4], srgb[4];
    float s = ((float)v + 0.5f) / 256.0f; /* a texel centre, exact in float */
    vf_texture_lookup(&t, s, 0.5f, VF_WRAP_CLAMP, VF_WRAP_CLAMP, 0, lin);
    vf_texture_lookup(&t, s, 0.5f, VF_WRAP_CLAMP, VF_WRAP_CLAMP, 1, srgb);
    if (lin[0] != (float)(v / 255.0)) CHECK_FAIL_("v %d: linear %.9g != %.9g", v, lin[0], (float)(v / 255.0));
    if (srgb[0] != (float)srgb_formula(v)) CHECK_FAIL_("v %d: sRGB %.9g != %.9g", v, srgb[0], (float)srgb_formula(v));
  }
  float out[4];
  vf_texture_lookup(&t, 255.5f / 256.0f, 0.5f, VF_WRAP_CLAMP, VF_WRAP_CLAMP, 1, out);
  CHECK(out[0] == 1.0f && out[1] == 1.0f && out[2] == 1.0f && out[3] == 1.0f); /* grey to RGB, alpha 1 */
}

static void test_bilinear_is_exact_at_centres_and_averages_between(void) {
  float v[8] = {0, 1, 2, 3, 10, 20, 30, 40}; /* 4x2, one channel */
  vf_texture t = make_texture(4, 2, 1, 1, v);
  float out[4];
  for (int j = 0; j < 2; j++)
    for (int i = 0; i < 4; i++) {
      vf_texture_lookup(&t, (i + 0.5f) / 4, (j + 0.5f) / 2, VF_WRAP_REPEAT, VF_WRAP_REPEAT, 0, out);
      CHECK(out[0] == v[j * 4 + i]);
    }
  vf_texture_lookup(&t, 0.25f, 0.25f, VF_WRAP_CLAMP, VF_WRAP_CLAMP, 0, out); /* between texels 0 and 1 */
  CHECK(out[0] == 0.5f);
  vf_texture_lookup(&t, 0.25f, 0.5f, VF_WRAP_CLAMP, VF_WRAP_CLAMP, 0, out); /* between 0, 1, 10, 20 */
  CHECK(out[0] == 7.75f);
  vf_texture_lookup(&t, 0.1875f, 0.25f, VF_WRAP_CLAMP, VF_WRAP_CLAMP, 0, out); /* a quarter of the way */
  CHECK(out[0] == 0.25f);
  /* 8-bit texels are decoded before they are blended: midway between 0 and 255 is 0.5 in
   * linear terms, not the sRGB decoding of 127.5 (0.212). */
  uint8_t bw[2] = {0, 255};
  vf_texture b = make_texture(2, 1, 1, 0, bw);
  vf_texture_lookup(&b, 0.5f, 0.5f, VF_WRAP_CLAMP, VF_WRAP_CLAMP, 1, out);
  CHECK(out[0] == 0.5f);
}

/* The value at s of the 4x1 texture 0, 1, 2, 3 under `wrap`. */
static float along(float s, int wrap) {
  static float v[4] = {0, 1, 2, 3};
  vf_texture t = make_texture(4, 1, 1, 1, v);
  float out[4];
  vf_texture_lookup(&t, s, 0.5f, wrap, VF_WRAP_CLAMP, 0, out);
  return out[0];
}

static void test_wrap_modes(void) {
  /* repeat: period 1, and the filter wraps across the edge */
  CHECK_INT_EQ(along(1.125f, VF_WRAP_REPEAT), 0);
  CHECK_INT_EQ(along(2.375f, VF_WRAP_REPEAT), 1);
  CHECK_INT_EQ(along(-0.125f, VF_WRAP_REPEAT), 3);
  CHECK_INT_EQ(along(-0.875f, VF_WRAP_REPEAT), 0);
  CHECK(along(0.0f, VF_WRAP_REPEAT) == 1.5f); /* half texel 3, half texel 0 */
  CHECK(along(3.0f, VF_WRAP_REPEAT) == 1.5f);
  /* clamp to edge */
  CHECK(along(-5.0f, VF_WRAP_CLAMP) == 0.0f);
  CHECK(along(0.0f, VF_WRAP_CLAMP) == 0.0f);
  CHECK(along(1.0f, VF_WRAP_CLAMP) == 3.0f);
  CHECK(along(7.5f, VF_WRAP_CLAMP) == 3.0f);
  /* mirrored repeat (OpenGL's MIRRORED_REPEAT): [1, 2) is [0, 1) reversed */
  CHECK(along(0.125f, VF_WRAP_MIRROR) == 0.0f);
  CHECK(along(1.125f, VF_WRAP_MIRROR) == 3.0f);
  CHECK(along(1.875f, VF_WRAP_MIRROR) == 0.0f);
  CHECK(along(2.375f, VF_WRAP_MIRROR) == 1.0f);
  CHECK(along(-0.125f, VF_WRAP_MIRROR) == 0.0f);
  CHECK(along(-0.375f, VF_WRAP_MIRROR) == 1.0f);
  CHECK(along(-1.125f, VF_WRAP_MIRROR) == 3.0f);
  CHECK(along(1.0f, VF_WRAP_MIRROR) == 3.0f); /* the edge texel repeats, no wrap to texel 0 */
  CHECK(along(0.0f, VF_WRAP_MIRROR) == 0.0f);
  /* per axis: s repeats while t clamps */
  float v[4] = {0, 1, 2, 3}; /* 2x2 */
  vf_texture t = make_texture(2, 2, 1, 1, v);
  float out[4];
  vf_texture_lookup(&t, 1.25f, 3.75f, VF_WRAP_REPEAT, VF_WRAP_CLAMP, 0, out);
  CHECK(out[0] == 2.0f);
  vf_texture_lookup(&t, 1.25f, 3.75f, VF_WRAP_CLAMP, VF_WRAP_REPEAT, 0, out);
  CHECK(out[0] == 3.0f);
  /* huge and non-finite coordinates stay inside the texture */
  for (int wrap = 0; wrap < 3; wrap++) {
    float a = along(1e30f, wrap), b = along(-3e9f, wrap);
    CHECK(a >= 0.0f && a <= 3.0f && b >= 0.0f && b <= 3.0f);
  }
  CHECK(along(NAN, VF_WRAP_REPEAT) == 0.0f);
  CHECK(along(INFINITY, VF_WRAP_MIRROR) == 0.0f);
}

/* Texel index and weight along one axis of n texels by texture.h's definition, written
 * with floorf: the coordinate wrapped into [0, 1], then x = s n - 0.5 between the centres
 * of texels floor(x) and floor(x) + 1, those wrapped (repeat) or clamped to the edge. */
static void reference_axis(float s, int n, int wrap, int *i0, int *i1, float *weight) {
  if (wrap == VF_WRAP_REPEAT) {
    s -= floorf(s);
  } else if (wrap == VF_WRAP_MIRROR) {
    float m = s - 2.0f * floorf(0.5f * s);
    s = m > 1.0f ? 2.0f - m : m;
  } else {
    s = s < 0.0f ? 0.0f : s > 1.0f ? 1.0f : s;
  }
  float x = s * (float)n - 0.5f, left = floorf(x);
  int a = (int)left, b = a + 1;
  *weight = x - left;
  if (a < 0) a = wrap == VF_WRAP_REPEAT ? n - 1 : 0;
  if (b >= n) b = wrap == VF_WRAP_REPEAT ? 0 : n - 1;
  *i0 = a;
  *i1 = b;
}

/* The lookup's own floor (a truncation and a step, for speed) against floorf: equal to the
 * bit on coordinates at and beside texel edges and centres, at whole numbers and their
 * neighbouring floats, at -0, and up to and past 2^23, where every float is whole, for
 * every wrap mode. */
static void test_lookup_matches_the_floorf_definition(void) {
  enum { W = 7, H = 5 };
  float v[W * H];
  for (int i = 0; i < W * H; i++) v[i] = (float)((i * 53 + 7) % 97);
  vf_texture t = make_texture(W, H, 1, 1, v);
  float bases[] = {0.0f, -0.0f, 0.5f, 1.0f, -1.0f, 1.0f / 7.0f, 3.0f / 14.0f, 0.2f, -2.6f, 7.9999f, 1e6f, -1e6f,
                   0x1p22f, 0x1p23f - 1.0f, 0x1p23f, -0x1p23f, 0x1p24f + 2.0f, 1e30f, -3e9f};
  int compared = 0;
  for (size_t bi = 0; bi < sizeof bases / sizeof bases[0]; bi++)
    for (int step = -3; step <= 3; step++) {
      float s = bases[bi];
      for (int k = 0; k < (step < 0 ? -step : step); k++) s = nextafterf(s, step < 0 ? -INFINITY : INFINITY);
      for (int wrap = VF_WRAP_REPEAT; wrap <= VF_WRAP_MIRROR; wrap++) {
        float tc = 0.37f - 0.11f * (float)step;
        int x0, x1, y0, y1;
        float fx, fy, out[4];
        reference_axis(s, W, wrap, &x0, &x1, &fx);
        reference_axis(tc, H, wrap, &y0, &y1, &fy);
        float want = (1.0f - fx) * (1.0f - fy) * v[y0 * W + x0] + fx * (1.0f - fy) * v[y0 * W + x1] +
                     (1.0f - fx) * fy * v[y1 * W + x0] + fx * fy * v[y1 * W + x1];
        vf_texture_lookup(&t, s, tc, wrap, wrap, 0, out);
        compared++;
        if (!(out[0] == want)) {
          fprintf(stderr, "s %.9g (wrap %d): lookup %.9g, definition %.9g\n", (double)s, wrap, (double)out[0],
                  (double)want);
          CHECK(out[0] == want);
          return;
        }
      }
    }
  CHECK_INT_EQ(compared, 19 * 7 * 3);
}

/* ---- PNG ---- */

static void check_hash_of_file(const vf_texture *t, const char *name) {
  size_t size;
  unsigned char *bytes = fixture_slurp(fixture_path(name), &size);
  uint8_t hash[32];
  CHECK(bytes != NULL);
  if (bytes == NULL) return;
  crypto_generichash(hash, sizeof hash, bytes, size, NULL, 0);
  CHECK(memcmp(hash, t->hash, sizeof hash) == 0);
  free(bytes);
}

/* The one-channel lookup of cut-outs gives vf_texture_lookup's channel, bit for bit, for
 * every channel count, 8-bit and float, every wrap mode. */
static void test_channel_lookup_is_the_full_lookups_channel(void) {
  uint8_t bytes[5 * 3 * 4];
  float floats[5 * 3 * 4];
  for (int i = 0; i < 60; i++) {
    bytes[i] = (uint8_t)(i * 37 + 11);
    floats[i] = (float)((i * 37 + 11) % 251) / 250.0f;
  }
  int compared = 0;
  for (int channels = 1; channels <= 4; channels++)
    for (int is_float = 0; is_float <= 1; is_float++) {
      vf_texture t = make_texture(5, 3, channels, is_float, is_float ? (void *)floats : (void *)bytes);
      for (int wrap = VF_WRAP_REPEAT; wrap <= VF_WRAP_MIRROR; wrap++)
        for (int i = 0; i < 200; i++) {
          float s = -2.0f + 0.0317f * (float)i, tc = 3.1f - 0.0271f * (float)i, full[4];
          vf_texture_lookup(&t, s, tc, wrap, wrap, 0, full);
          for (int c = 0; c < 4; c++, compared++)
            if (!(vf_texture_lookup_channel(&t, s, tc, wrap, wrap, c) == full[c])) {
              CHECK_NEAR(vf_texture_lookup_channel(&t, s, tc, wrap, wrap, c), full[c], 0.0);
              return;
            }
        }
    }
  CHECK_INT_EQ(compared, 4 * 2 * 3 * 200 * 4);
}

static void test_png_rgb_keeps_stored_bytes(void) {
  uint8_t rgb[4 * 2 * 3];
  for (int i = 0; i < 24; i++) rgb[i] = (uint8_t)(i * 11);
  CHECK(write_png(fixture_path("rgb.png"), 4, 2, PNG_COLOR_TYPE_RGB, 8, rgb, NULL, 0, NULL, 0, NULL));
  vf_texture t;
  int err = read_texture("rgb.png", &t);
  CHECK_INT_EQ(err, VF_OK);
  if (err) return;
  CHECK_INT_EQ(t.width, 4);
  CHECK_INT_EQ(t.height, 2);
  CHECK_INT_EQ(t.channels, 3);
  CHECK_INT_EQ(t.is_float, 0);
  CHECK(strcmp(t.name, "rgb.png") == 0);
  CHECK_INT_EQ(vf_texture_bytes(&t), 24);
  CHECK(memcmp(t.texels, rgb, sizeof rgb) == 0); /* the gAMA 1.0 chunk changed nothing */
  check_hash_of_file(&t, "rgb.png");
  float out[4];
  vf_texture_lookup(&t, 0.875f, 0.75f, VF_WRAP_REPEAT, VF_WRAP_REPEAT, 1, out); /* texel (3, 1) */
  CHECK(out[0] == (float)srgb_formula(21 * 11) && out[1] == (float)srgb_formula(22 * 11));
  CHECK(out[2] == (float)srgb_formula(23 * 11) && out[3] == 1.0f);
  vf_texture_release(&t);
  vf_texture_release(&t); /* a released texture is empty */
  CHECK(t.texels == NULL);
}

/* Writes a 2x1 PNG and checks its decoded channel count and bytes. */
static void check_png(const char *name, int color_type, int depth, const uint8_t *row, const png_color *palette,
                      int num_palette, const png_byte *trns, int num_trns, const png_color_16 *trns_color,
                      int channels, const uint8_t *expected) {
  CHECK(write_png(fixture_path(name), 2, 1, color_type, depth, row, palette, num_palette, trns, num_trns, trns_color));
  vf_texture t;
  int err = read_texture(name, &t);
  if (err != VF_OK) {
    CHECK_FAIL_("%s: %s", name, vf_error_detail(err));
    return;
  }
  CHECK_INT_EQ(t.channels, channels);
  if (memcmp(t.texels, expected, 2 * (size_t)channels) != 0) CHECK_FAIL_("%s: texels differ", name);
  vf_texture_release(&t);
}

static void test_png_channel_counts(void) {
  const uint8_t grey[2] = {7, 250}, ga[4] = {7, 128, 250, 255}, rgba[8] = {1, 2, 3, 4, 5, 6, 7, 8};
  check_png("grey.png", PNG_COLOR_TYPE_GRAY, 8, grey, NULL, 0, NULL, 0, NULL, 1, grey);
  check_png("ga.png", PNG_COLOR_TYPE_GRAY_ALPHA, 8, ga, NULL, 0, NULL, 0, NULL, 2, ga);
  check_png("rgba.png", PNG_COLOR_TYPE_RGBA, 8, rgba, NULL, 0, NULL, 0, NULL, 4, rgba);
  const uint8_t bits[1] = {0x40}; /* 1-bit grey: 0, 1 -> 0, 255 */
  check_png("grey1.png", PNG_COLOR_TYPE_GRAY, 1, bits, NULL, 0, NULL, 0, NULL, 1, (const uint8_t[]){0, 255});
  const png_color palette[2] = {{10, 20, 30}, {200, 210, 220}};
  const uint8_t indices[2] = {1, 0};
  check_png("palette.png", PNG_COLOR_TYPE_PALETTE, 8, indices, palette, 2, NULL, 0, NULL, 3,
            (const uint8_t[]){200, 210, 220, 10, 20, 30});
  const png_byte trns[2] = {255, 64};
  check_png("palette_trns.png", PNG_COLOR_TYPE_PALETTE, 8, indices, palette, 2, trns, 2, NULL, 4,
            (const uint8_t[]){200, 210, 220, 64, 10, 20, 30, 255});
  png_color_16 key = {0, 0, 0, 0, 250};
  check_png("grey_trns.png", PNG_COLOR_TYPE_GRAY, 8, grey, NULL, 0, NULL, 0, &key, 2, (const uint8_t[]){7, 255, 250, 0});
  /* 16 bits: round(v * 255 / 65535); 257 k is exactly k */
  const uint8_t rgb16[12] = {0x00, 0x00, 0x80, 0x80, 0xff, 0xff, 0x12, 0x34, 0x01, 0x01, 0xfe, 0xfe};
  check_png("rgb16.png", PNG_COLOR_TYPE_RGB, 16, rgb16, NULL, 0, NULL, 0, NULL, 3,
            (const uint8_t[]){0, 128, 255, (uint8_t)lround(0x1234 * 255.0 / 65535.0), 1, 254});
  /* expansion at lookup: grey to RGB, grey-alpha's alpha, RGB's alpha 1 */
  vf_texture t;
  float out[4];
  if (read_texture("ga.png", &t) == VF_OK) {
    vf_texture_lookup(&t, 0.25f, 0.5f, VF_WRAP_CLAMP, VF_WRAP_CLAMP, 0, out);
    CHECK(out[0] == 7 / 255.0f && out[1] == out[0] && out[2] == out[0] && out[3] == (float)(128 / 255.0));
    vf_texture_lookup(&t, 0.25f, 0.5f, VF_WRAP_CLAMP, VF_WRAP_CLAMP, 1, out); /* alpha stays linear */
    CHECK(out[0] == (float)srgb_formula(7) && out[3] == (float)(128 / 255.0));
    vf_texture_release(&t);
  }
  if (read_texture("palette.png", &t) == VF_OK) {
    vf_texture_lookup(&t, 0.75f, 0.5f, VF_WRAP_CLAMP, VF_WRAP_CLAMP, 0, out);
    CHECK(out[0] == (float)(10 / 255.0) && out[2] == (float)(30 / 255.0) && out[3] == 1.0f);
    vf_texture_release(&t);
  }
}

/* ---- JPEG ---- */

static void test_jpeg_quality_100_is_near_exact(void) {
  enum { W = 16, H = 8 };
  uint8_t rgb[W * H * 3], grey[W * H];
  for (int y = 0; y < H; y++)
    for (int x = 0; x < W; x++) {
      uint8_t *p = rgb + (y * W + x) * 3;
      p[0] = (uint8_t)(16 * x);
      p[1] = (uint8_t)(30 * y);
      p[2] = (uint8_t)(128 + 4 * (x - y));
      grey[y * W + x] = (uint8_t)(8 * x + 10 * y);
    }
  CHECK(write_jpeg(fixture_path("rgb.jpg"), W, H, 3, rgb, 100));
  CHECK(write_jpeg(fixture_path("grey.jpg"), W, H, 1, grey, 100));
  /* At quality 100 every quantisation step is 1, so what remains is the rounding of the DCT
   * coefficients (at most 1/2 each, which the inverse DCT spreads over the block) and, for
   * colour, of the YCbCr conversion both ways: a few levels at most. 3 is the bound. */
  const int tolerance = 3;
  vf_texture t;
  int err = read_texture("rgb.jpg", &t);
  CHECK_INT_EQ(err, VF_OK);
  if (err == VF_OK) {
    CHECK_INT_EQ(t.channels, 3);
    CHECK_INT_EQ(t.width, W);
    CHECK_INT_EQ(t.height, H);
    int worst = 0;
    for (int i = 0; i < W * H * 3; i++) {
      int d = abs((int)((uint8_t *)t.texels)[i] - (int)rgb[i]);
      if (d > worst) worst = d;
    }
    printf("  RGB JPEG at quality 100: largest error %d levels\n", worst);
    CHECK(worst <= tolerance);
    check_hash_of_file(&t, "rgb.jpg");
    vf_texture_release(&t);
  }
  err = read_texture("grey.jpg", &t);
  CHECK_INT_EQ(err, VF_OK);
  if (err == VF_OK) {
    CHECK_INT_EQ(t.channels, 1);
    int worst = 0;
    for (int i = 0; i < W * H; i++) {
      int d = abs((int)((uint8_t *)t.texels)[i] - (int)grey[i]);
      if (d > worst) worst = d;
    }
    CHECK(worst <= tolerance);
    vf_texture_release(&t);
  }
}

/* ---- EXR ---- */

static void test_exr_channel_sets(void) {
  const float rgba[2 * 2 * 4] = {0.5f, 2.0f, 0.25f, 1.0f, 0, 0, 0, 0.5f, 1e-3f, 7.0f, 0.125f, 0.75f, 3, 2, 1, 0};
  const char *const rgba_names[4] = {"R", "G", "B", "A"}, *const ya_names[2] = {"Y", "A"};
  CHECK(write_exr(fixture_path("rgba.exr"), 2, 2, 4, rgba_names, rgba));
  CHECK(write_exr(fixture_path("rgb.exr"), 2, 2, 3, rgba_names, (const float[]){1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12}));
  CHECK(write_exr(fixture_path("y.exr"), 2, 2, 1, ya_names, (const float[]){0.5f, 1.5f, 2.5f, 3.5f}));
  CHECK(write_exr(fixture_path("ya.exr"), 2, 2, 2, ya_names, (const float[]){1, 0.1f, 2, 0.2f, 3, 0.3f, 4, 0.4f}));
  vf_texture t;
  float out[4];
  if (read_texture("rgba.exr", &t) == VF_OK) {
    CHECK_INT_EQ(t.channels, 4);
    CHECK_INT_EQ(t.is_float, 1);
    CHECK(memcmp(t.texels, rgba, sizeof rgba) == 0);
    CHECK_INT_EQ(vf_texture_bytes(&t), sizeof rgba);
    vf_texture_lookup(&t, 0.25f, 0.75f, VF_WRAP_REPEAT, VF_WRAP_REPEAT, 1, out); /* texel (0, 1); srgb: no effect */
    CHECK(out[0] == 1e-3f && out[1] == 7.0f && out[2] == 0.125f && out[3] == 0.75f);
    check_hash_of_file(&t, "rgba.exr");
    vf_texture_release(&t);
  } else CHECK_FAIL_("rgba.exr: %s", vf_error_detail(VF_ETEXTURE));
  if (read_texture("rgb.exr", &t) == VF_OK) {
    CHECK_INT_EQ(t.channels, 3);
    vf_texture_lookup(&t, 0.75f, 0.25f, VF_WRAP_REPEAT, VF_WRAP_REPEAT, 0, out);
    CHECK(out[0] == 4 && out[1] == 5 && out[2] == 6 && out[3] == 1);
    vf_texture_release(&t);
  } else CHECK_FAIL_("rgb.exr: %s", vf_error_detail(VF_ETEXTURE));
  if (read_texture("y.exr", &t) == VF_OK) {
    CHECK_INT_EQ(t.channels, 1);
    vf_texture_lookup(&t, 0.75f, 0.75f, VF_WRAP_REPEAT, VF_WRAP_REPEAT, 0, out);
    CHECK(out[0] == 3.5f && out[1] == 3.5f && out[2] == 3.5f && out[3] == 1.0f);
    vf_texture_release(&t);
  } else CHECK_FAIL_("y.exr: %s", vf_error_detail(VF_ETEXTURE));
  if (read_texture("ya.exr", &t) == VF_OK) {
    CHECK_INT_EQ(t.channels, 2);
    vf_texture_lookup(&t, 0.25f, 0.75f, VF_WRAP_REPEAT, VF_WRAP_REPEAT, 0, out);
    CHECK(out[0] == 3.0f && out[2] == 3.0f && out[3] == 0.3f);
    vf_texture_release(&t);
  } else CHECK_FAIL_("ya.exr: %s", vf_error_detail(VF_ETEXTURE));
}

/* ---- bad input ---- */

/* The code of decoding `size` bytes named `name`; the detail must name it. */
static int decode_code(const void *bytes, size_t size, const char *name) {
  vf_texture t;
  int err = vf_texture_decode(bytes, size, name, &t);
  if (err == VF_OK) vf_texture_release(&t);
  else CHECK_STR_CONTAINS(vf_error_detail(err), name);
  return err;
}

static void test_bad_files_are_refused_by_name(void) {
  vf_texture t;
  int err = read_texture("no-such.png", &t);
  CHECK_INT_EQ(err, VF_ENOENT);
  CHECK_STR_CONTAINS(vf_error_detail(err), "no-such.png: cannot open: No such file or directory");
  CHECK(fixture_spill(fixture_path("empty.png"), "", 0));
  err = read_texture("empty.png", &t);
  CHECK_INT_EQ(err, VF_ETEXTURE);
  CHECK_STR_CONTAINS(vf_error_detail(err), "empty.png: unsupported texture format (not PNG, JPEG or EXR)");
  CHECK_INT_EQ(decode_code("GIF89a\x01\x00\x01\x00", 10, "anim.gif"), VF_ETEXTURE);
  CHECK_STR_CONTAINS(vf_error_detail(VF_ETEXTURE), "unsupported texture format");
  CHECK_INT_EQ(decode_code("\x89PNG", 4, "short.png"), VF_ETEXTURE); /* the magic cut short */

  size_t png_size, jpg_size, exr_size;
  unsigned char *png = fixture_slurp(fixture_path("rgb.png"), &png_size);
  unsigned char *jpg = fixture_slurp(fixture_path("rgb.jpg"), &jpg_size);
  unsigned char *exr = fixture_slurp(fixture_path("rgba.exr"), &exr_size);
  CHECK(png && jpg && exr);
  if (png && jpg && exr) {
    for (size_t cut = 8; cut < png_size; cut += 7) /* every truncation, header and data */
      if (decode_code(png, cut, "cut.png") != VF_ETEXTURE) CHECK_FAIL_("PNG cut at %zu of %zu not refused", cut, png_size);
    png[png_size - 20] ^= 0x55; /* inside the IDAT chunk: its CRC no longer matches */
    CHECK_INT_EQ(decode_code(png, png_size, "crc.png"), VF_ETEXTURE);
    for (size_t cut = 3; cut < jpg_size; cut += 5)
      if (decode_code(jpg, cut, "cut.jpg") != VF_ETEXTURE) CHECK_FAIL_("JPEG cut at %zu of %zu not refused", cut, jpg_size);
    uint64_t state = 12345;
    for (size_t i = jpg_size / 2; i < jpg_size - 2; i++) jpg[i] = (uint8_t)fixture_xorshift(&state);
    CHECK_INT_EQ(decode_code(jpg, jpg_size, "garbled.jpg"), VF_ETEXTURE);
    for (size_t cut = 4; cut < exr_size; cut += 9)
      if (decode_code(exr, cut, "cut.exr") != VF_ETEXTURE) CHECK_FAIL_("EXR cut at %zu of %zu not refused", cut, exr_size);
  }
  free(png);
  free(jpg);
  free(exr);

  uint8_t cmyk[4 * 8 * 8];
  memset(cmyk, 100, sizeof cmyk);
  CHECK(write_jpeg(fixture_path("cmyk.jpg"), 8, 8, 4, cmyk, 90));
  err = read_texture("cmyk.jpg", &t);
  CHECK_INT_EQ(err, VF_ETEXTURE);
  CHECK_STR_CONTAINS(vf_error_detail(err), "cmyk.jpg: a CMYK JPEG is not supported");

  static uint8_t wide[40000];
  CHECK(write_png(fixture_path("wide.png"), 40000, 1, PNG_COLOR_TYPE_GRAY, 8, wide, NULL, 0, NULL, 0, NULL));
  err = read_texture("wide.png", &t);
  CHECK_INT_EQ(err, VF_ETEXTURE);
  CHECK_STR_CONTAINS(vf_error_detail(err), "wide.png: 40000x1 texels is empty or too large");
  static float tall[40000];
  const char *const y_name[1] = {"Y"};
  CHECK(write_exr(fixture_path("tall.exr"), 1, 40000, 1, y_name, tall));
  err = read_texture("tall.exr", &t);
  CHECK_INT_EQ(err, VF_ETEXTURE);
  CHECK_STR_CONTAINS(vf_error_detail(err), "tall.exr: 1x40000 is larger than 32768 on a side");

  const char *const g_name[1] = {"G"};
  CHECK(write_exr(fixture_path("green.exr"), 1, 1, 1, g_name, (const float[]){0.5f}));
  err = read_texture("green.exr", &t);
  CHECK_INT_EQ(err, VF_ETEXTURE);
  CHECK_STR_CONTAINS(vf_error_detail(err), "green.exr: missing channel R");
  CHECK(write_exr(fixture_path("nan.exr"), 2, 1, 1, y_name, (const float[]){0.5f, NAN}));
  err = read_texture("nan.exr", &t);
  CHECK_INT_EQ(err, VF_ETEXTURE);
  CHECK_STR_CONTAINS(vf_error_detail(err), "nan.exr: texel (1, 0) has a non-finite value in channel 0");
}

/* Exit codes of the child that reads one damaged file. */
enum { CHILD_REFUSED = 0, CHILD_READ = 1, CHILD_BAD_ERROR = 2 };

static int read_texture_outcome(const char *path) {
  vf_texture t;
  int err = vf_texture_read(path, path, &t);
  if (err == VF_OK) {
    vf_texture_release(&t);
    return CHILD_READ;
  }
  return err == VF_ETEXTURE && strstr(vf_error_detail(err), path) ? CHILD_REFUSED : CHILD_BAD_ERROR;
}

static void test_exr_corpus_damaged_files_are_refused(void) {
  if (!exr_corpus_present()) return;
  char **files = NULL;
  int n = exr_corpus_list(EXR_CORPUS "/Damaged", 1, &files);
  CHECK(n >= 185);
  int refused = 0;
  for (int i = 0; i < n; i++) {
    double dt;
    int sig;
    int outcome = exr_corpus_read_in_child(read_texture_outcome, files[i], &dt, &sig);
    const char *name = exr_corpus_name(files[i]);
    if (sig) CHECK_FAIL_("%s: decoder died with signal %d", name, sig);
    else if (outcome == CHILD_READ) CHECK_FAIL_("%s: damaged file was read", name);
    else if (outcome != CHILD_REFUSED) CHECK_FAIL_("%s: refused with the wrong code or detail (exit %d)", name, outcome);
    else refused++;
    if (dt > EXR_CORPUS_MAX_SECONDS_PER_FILE) CHECK_FAIL_("%s: took %.2f s", name, dt);
  }
  printf("  %d of %d damaged files refused\n", refused, n);
  exr_corpus_list_free(files, n);
}

/* ---- scenes ---- */

/* A scene with one sphere of material "m" (whose JSON is `material`) under a point light. */
static int write_scene(const char *name, const char *material) {
  char text[4096];
  snprintf(text, sizeof text,
           "{\"camera\": {\"position\": [0, 0, 5], \"target\": [0, 0, 0], \"fov\": 40},\n"
           " \"materials\": {\"m\": %s, \"plain\": {\"diffuse\": [0.5, 0.5, 0.5]}},\n"
           " \"shapes\": [{\"type\": \"sphere\", \"center\": [0, 0, 0], \"radius\": 1, \"material\": \"m\"}],\n"
           " \"lights\": [{\"type\": \"point\", \"position\": [0, 3, 3], \"intensity\": [5, 5, 5]}]}\n",
           material);
  return fixture_spill_text(fixture_path(name), text);
}

/* Loads a scene of `material`; NULL and *err on failure. */
static vf_scene *load_material(const char *material, int *err) {
  vf_scene *s = NULL;
  CHECK(write_scene("scene.json", material));
  *err = vf_scene_load(fixture_path("scene.json"), &s);
  return *err == VF_OK ? s : NULL;
}

static int refused(const char *material, int code, const char *detail) {
  int err;
  vf_scene *s = load_material(material, &err);
  vf_scene_destroy(s);
  CHECK_INT_EQ(err, code);
  if (err == code) CHECK_STR_CONTAINS(vf_error_detail(err), detail);
  return err == code;
}

static void test_scene_diffuse_texture_loads(void) {
  int err;
  vf_scene *s = load_material("{\"diffuse_texture\": \"rgb.png\"}", &err);
  if (s == NULL) {
    CHECK_FAIL_("%s", vf_error_detail(err));
    return;
  }
  CHECK_INT_EQ(s->num_textures, 1);
  CHECK(strcmp(s->textures[0].name, "rgb.png") == 0 && s->textures[0].width == 4 && s->textures[0].channels == 3);
  const vf_material *m = &s->materials[0];
  CHECK(strcmp(m->name, "m") == 0);
  CHECK_INT_EQ(m->textures[VF_TEXTURE_COLOR].texture, 1);
  CHECK_INT_EQ(m->textures[VF_TEXTURE_COLOR].wrap_s, VF_WRAP_REPEAT);
  CHECK_INT_EQ(m->textures[VF_TEXTURE_COLOR].wrap_t, VF_WRAP_REPEAT);
  CHECK(m->diffuse.x == 1.0f && m->diffuse.y == 1.0f && m->diffuse.z == 1.0f); /* the default multiplier */
  CHECK(m->alpha == 1.0f && m->alpha_cutoff == 0.0f && m->normal_scale == 1.0f);
  CHECK(!vf_material_textured(&s->materials[1]));
  vf_scene_destroy(s);
}

static void test_scene_texture_fields(void) {
  int err;
  /* one file in three slots is decoded once; object forms with wrap modes */
  vf_scene *s = load_material("{\"diffuse\": [0.8, 0.5, 0.2],"
                              " \"diffuse_texture\": {\"file\": \"rgba.png\", \"wrap\": \"mirror\"},"
                              " \"alpha_texture\": {\"file\": \"rgba.png\", \"wrap_s\": \"clamp\"},"
                              " \"emission_texture\": \"rgba.exr\","
                              " \"normal_texture\": \"rgb.png\", \"normal_scale\": 0.5}", &err);
  if (s == NULL) {
    CHECK_FAIL_("%s", vf_error_detail(err));
    return;
  }
  const vf_material *m = &s->materials[0];
  CHECK_INT_EQ(s->num_textures, 3);
  CHECK(m->diffuse.x == 0.8f);
  CHECK_INT_EQ(m->textures[VF_TEXTURE_COLOR].texture, 1);
  CHECK_INT_EQ(m->textures[VF_TEXTURE_COLOR].wrap_s, VF_WRAP_MIRROR);
  CHECK_INT_EQ(m->textures[VF_TEXTURE_COLOR].wrap_t, VF_WRAP_MIRROR);
  CHECK_INT_EQ(m->textures[VF_TEXTURE_ALPHA].texture, 1);
  CHECK_INT_EQ(m->textures[VF_TEXTURE_ALPHA].wrap_s, VF_WRAP_CLAMP);
  CHECK_INT_EQ(m->textures[VF_TEXTURE_ALPHA].wrap_t, VF_WRAP_REPEAT);
  CHECK_INT_EQ(m->textures[VF_TEXTURE_EMISSION].texture, 2); /* float texels above 1: fine for emission */
  CHECK_INT_EQ(m->textures[VF_TEXTURE_NORMAL].texture, 3);
  CHECK(m->alpha == 1.0f && m->alpha_cutoff == 0.5f && m->alpha_channel == 3 && m->normal_scale == 0.5f);
  vf_scene_destroy(s);
  /* an alpha mask without alpha reads its first channel; explicit alpha parameters */
  s = load_material("{\"diffuse\": [0.5, 0.5, 0.5], \"alpha_texture\": \"grey.png\", \"alpha\": 0.25,"
                    " \"alpha_cutoff\": 0.1}", &err);
  CHECK(s != NULL);
  if (s) {
    m = &s->materials[0];
    CHECK(m->alpha == 0.25f && m->alpha_cutoff == 0.1f && m->alpha_channel == 0);
    vf_scene_destroy(s);
  }
  /* the glTF model: factors default to 1 when their texture is given */
  s = load_material("{\"base_color_texture\": \"rgb.jpg\", \"roughness_metallic_texture\": \"rgb.png\"}", &err);
  if (s == NULL) CHECK_FAIL_("%s", vf_error_detail(err));
  else {
    m = &s->materials[0];
    CHECK(m->gltf && m->base_color.x == 1.0f && m->metallic == 1.0f && m->roughness == 1.0f);
    CHECK_INT_EQ(m->textures[VF_TEXTURE_COLOR].texture, 1);
    CHECK_INT_EQ(m->textures[VF_TEXTURE_ROUGHNESS_METALLIC].texture, 2);
    vf_scene_destroy(s);
  }
  s = load_material("{\"base_color\": [0.5, 0.5, 0.5], \"metallic\": 0, \"roughness\": 0.5,"
                    " \"base_color_texture\": \"rgba.png\", \"alpha_texture\": \"rgba.png\", \"alpha_channel\": 3}", &err);
  if (s == NULL) CHECK_FAIL_("%s", vf_error_detail(err));
  else {
    CHECK_INT_EQ(s->num_textures, 1);
    CHECK(s->materials[0].base_color.x == 0.5f && s->materials[0].alpha_channel == 3);
    vf_scene_destroy(s);
  }
}

static void test_scene_texture_errors(void) {
  refused("{\"diffuse_texture\": \"missing.png\"}", VF_ENOENT, "materials.m.diffuse_texture: missing.png: cannot open");
  CHECK(fixture_spill_text(fixture_path("text.png"), "not an image\n"));
  refused("{\"diffuse_texture\": \"text.png\"}", VF_ETEXTURE,
          "materials.m.diffuse_texture: text.png: unsupported texture format (not PNG, JPEG or EXR)");
  refused("{\"diffuse_texture\": {\"file\": \"cut.exr\"}}", VF_ENOENT, "materials.m.diffuse_texture.file: cut.exr");
  refused("{\"diffuse\": [0, 0, 0], \"diffuse_texture\": \"rgb.png\"}", VF_ESCENE,
          "materials.m.diffuse_texture: multiplies 'diffuse', which is zero");
  refused("{\"diffuse_texture\": \"rgb.png\", \"glossy\": [0.2, 0.2, 0.2], \"exponent\": 10}", VF_ESCENE,
          "'diffuse' is 1 by default with a 'diffuse_texture'");
  refused("{\"diffuse_texture\": 3}", VF_ESCENE, "materials.m.diffuse_texture: expected a file name or an object");
  refused("{\"diffuse_texture\": {\"file\": \"rgb.png\", \"wrap\": \"tile\"}}", VF_ESCENE,
          "materials.m.diffuse_texture.wrap: unknown wrap mode 'tile'");
  refused("{\"diffuse_texture\": {\"file\": \"rgb.png\", \"wrap\": \"clamp\", \"wrap_t\": \"clamp\"}}", VF_ESCENE,
          "give 'wrap' or 'wrap_s'/'wrap_t', not both");
  refused("{\"diffuse_texture\": {\"file\": \"rgb.png\", \"scale\": 2}}", VF_ESCENE, "scale");
  refused("{\"base_color_texture\": \"rgb.png\", \"diffuse\": [0.5, 0.5, 0.5]}", VF_ESCENE, "diffuse");
  refused("{\"diffuse\": [0.5, 0.5, 0.5], \"base_color_texture\": \"rgb.png\"}", VF_ESCENE, "diffuse");
  refused("{\"diffuse\": [0.5, 0.5, 0.5], \"normal_scale\": 2}", VF_ESCENE, "materials.m.normal_scale: needs 'normal_texture'");
  refused("{\"diffuse\": [0.5, 0.5, 0.5], \"alpha_channel\": 0}", VF_ESCENE, "materials.m.alpha_channel: needs 'alpha_texture'");
  refused("{\"diffuse\": [0.5, 0.5, 0.5], \"alpha_texture\": \"rgb.png\", \"alpha_channel\": 3}", VF_ESCENE,
          "'rgb.png' has no alpha channel");
  refused("{\"diffuse\": [0.5, 0.5, 0.5], \"alpha_texture\": \"rgb.png\", \"alpha_cutoff\": 2}", VF_ESCENE,
          "materials.m.alpha_cutoff: must be in [0, 1]");
  /* float colour texels above 1 would break the albedo-sum rule: refused at load */
  refused("{\"diffuse_texture\": \"rgba.exr\"}", VF_ESCENE,
          "materials.m.diffuse_texture: texel (0, 0) of 'rgba.exr' is 2 in channel 1, outside [0, 1]");
  refused("{\"base_color_texture\": \"rgb.exr\"}", VF_ESCENE, "of 'rgb.exr' is 2 in channel 1");
}

/* The content hash of the scene of `material`, or zeros. */
static void scene_hash(const char *material, uint8_t hash[32]) {
  int err;
  vf_scene *s = load_material(material, &err);
  memset(hash, 0, 32);
  if (s == NULL) {
    CHECK_FAIL_("%s", vf_error_detail(err));
    return;
  }
  memcpy(hash, s->hash, 32);
  vf_scene_destroy(s);
}

static void test_scene_hash_follows_texture_bytes(void) {
  uint8_t a[32], b[32], c[32], d[32];
  const uint8_t one[2] = {10, 20}, other[2] = {10, 21};
  CHECK(write_png(fixture_path("t1.png"), 2, 1, PNG_COLOR_TYPE_GRAY, 8, one, NULL, 0, NULL, 0, NULL));
  CHECK(write_png(fixture_path("t2.png"), 2, 1, PNG_COLOR_TYPE_GRAY, 8, one, NULL, 0, NULL, 0, NULL));
  scene_hash("{\"diffuse_texture\": \"t1.png\"}", a);
  scene_hash("{\"diffuse_texture\": \"t2.png\"}", b); /* the same bytes under another name */
  CHECK(memcmp(a, b, 32) == 0);
  CHECK(write_png(fixture_path("t2.png"), 2, 1, PNG_COLOR_TYPE_GRAY, 8, other, NULL, 0, NULL, 0, NULL));
  scene_hash("{\"diffuse_texture\": \"t2.png\"}", c); /* one texel changed */
  CHECK(memcmp(a, c, 32) != 0);
  scene_hash("{\"diffuse_texture\": {\"file\": \"t1.png\", \"wrap\": \"clamp\"}}", d);
  CHECK(memcmp(a, d, 32) != 0);
}

/* A recording load (`submit`) lists the texture among the files to ship. */
static void test_recording_load_records_the_texture(void) {
  CHECK(write_scene("scene.json", "{\"diffuse_texture\": \"rgb.png\"}"));
  size_t size;
  unsigned char *bytes = fixture_slurp(fixture_path("scene.json"), &size);
  char *text = bytes ? calloc(size + 1, 1) : NULL; /* the parser wants a NUL after the text */
  if (text) memcpy(text, bytes, size);
  free(bytes);
  vf_scene_files *files = NULL;
  vf_scene *s = NULL;
  CHECK(text != NULL && vf_scene_files_recording(fixture_scratch_dir(), &files) == VF_OK);
  if (text == NULL || files == NULL) {
    free(text);
    return;
  }
  int err = vf_scene_parse_files(text, size, "scene.json", files, &s);
  if (err != VF_OK) CHECK_FAIL_("%s", vf_error_detail(err));
  int found = 0;
  for (size_t i = 0; i < vf_scene_files_count(files); i++) found |= strcmp(vf_scene_files_name(files, i), "rgb.png") == 0;
  CHECK(found);
  CHECK(s == NULL || s->num_textures == 1);
  vf_scene_destroy(s);
  vf_scene_files_destroy(files);
  free(text);
}

int main(void) {
  if (fixture_scratch_open("test_texture") != 0) return 1;
  RUN(test_srgb_and_linear_tables_match_the_formula);
  RUN(test_bilinear_is_exact_at_centres_and_averages_between);
  RUN(test_wrap_modes);
  RUN(test_lookup_matches_the_floorf_definition);
  RUN(test_channel_lookup_is_the_full_lookups_channel);
  RUN(test_png_rgb_keeps_stored_bytes);
  RUN(test_png_channel_counts);
  RUN(test_jpeg_quality_100_is_near_exact);
  RUN(test_exr_channel_sets);
  RUN(test_bad_files_are_refused_by_name);
  RUN(test_exr_corpus_damaged_files_are_refused);
  RUN(test_scene_diffuse_texture_loads);
  RUN(test_scene_texture_fields);
  RUN(test_scene_texture_errors);
  RUN(test_scene_hash_follows_texture_bytes);
  RUN(test_recording_load_records_the_texture);
  fixture_scratch_close();
  return check_finish();
}
