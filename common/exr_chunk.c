#include "exr_chunk.h"

#include "error.h"

#include <limits.h>
#include <math.h>
#include <pthread.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

#if !defined(__BYTE_ORDER__) || __BYTE_ORDER__ != __ORDER_LITTLE_ENDIAN__
#error "exr_chunk.c copies floats as OpenEXR's little-endian bytes"
#endif

/* Predicted bytes are judged in segments of this size: long enough that a zlib block
 * header is a small part of it, short enough to follow the image from black to noise. */
#define SEGMENT 8192
/* A segment is coded when the entropy of its bytes' histogram is below this many bits per
 * byte, i.e. when coding would save at least an eighth of it. Noise sits at 7.98, the
 * black of a frame's border and the zero low bytes of exact sums far below. Between 7
 * and 8 the Huffman coder would win a few percent at zlib's ~80 MB/s: on a noisy
 * 1920x1080 film, coding every segment gave 27.7 bytes per pixel for 1.3 s of CPU per
 * write, this limit 29.4 for 0.6 s, a limit of 6 about the same. */
#define CODED_BELOW_BITS 7.0

int vf_exr_chunk_threads(size_t chunks) {
  long cpus = sysconf(_SC_NPROCESSORS_ONLN);
  size_t t = cpus > 0 ? (size_t)cpus : 1;
  if (t > 16) t = 16;
  return (int)(t < chunks ? t : chunks > 0 ? chunks : 1);
}

void vf_exr_coder_init(vf_exr_coder *c) { memset(c, 0, sizeof *c); }

void vf_exr_coder_destroy(vf_exr_coder *c) {
  if (c == NULL) return;
  if (c->deflate_ready) deflateEnd(&c->deflate);
  if (c->inflate_ready) inflateEnd(&c->inflate);
  free(c->packed);
  free(c->predicted);
  free(c->out);
  free(c->coded);
  memset(c, 0, sizeof *c);
}

/* Room for a chunk of `size` packed bytes; an output that would not be smaller is not
 * finished (the packed bytes are written instead). */
static int reserve(vf_exr_coder *c, size_t size) {
  if (size <= c->capacity) return VF_OK;
  free(c->packed);
  free(c->predicted);
  free(c->out);
  free(c->coded);
  c->out_capacity = size;
  c->packed = malloc(size);
  c->predicted = malloc(size);
  c->out = malloc(size);
  c->coded = malloc(size / SEGMENT + 1);
  c->capacity = size;
  if (c->packed && c->predicted && c->out && c->coded) return VF_OK;
  free(c->packed);
  free(c->predicted);
  free(c->out);
  free(c->coded);
  c->packed = c->predicted = c->out = c->coded = NULL;
  c->capacity = c->out_capacity = 0;
  return vf_error_set(VF_ENOMEM, "out of memory for an image chunk of %zu bytes", size);
}

static size_t chunk_bytes(int n, int w, int h) { return (size_t)n * (size_t)w * (size_t)h * sizeof(float); }

/* OpenEXR's ZIP preprocessing: even bytes then odd bytes, then each byte replaced by its
 * difference to the one before (+128), the first kept. Two plain loops, which the
 * compiler vectorises; `split` is scratch of size bytes. */
static void predict(const uint8_t *packed, size_t size, uint8_t *split, uint8_t *out) {
  size_t half = (size + 1) / 2;
  for (size_t i = 0; i < size / 2; i++) {
    split[i] = packed[2 * i];
    split[half + i] = packed[2 * i + 1];
  }
  if (size % 2) split[half - 1] = packed[size - 1];
  out[0] = split[0];
  for (size_t i = 1; i < size; i++) out[i] = (uint8_t)(split[i] - split[i - 1] + 128);
}

/* The inverse of predict, from in (destroyed) into packed. */
static void unpredict(uint8_t *in, size_t size, uint8_t *packed) {
  for (size_t i = 1; i < size; i++) in[i] = (uint8_t)(in[i - 1] + in[i] - 128);
  size_t half = (size + 1) / 2;
  for (size_t i = 0; i < half; i++) packed[2 * i] = in[i];
  for (size_t i = half; i < size; i++) packed[2 * (i - half) + 1] = in[i];
}

/* c * log2(c) for the counts of a segment, computed once. */
static float count_bits[SEGMENT + 1];
static pthread_once_t count_bits_once = PTHREAD_ONCE_INIT;

static void count_bits_init(void) {
  for (int c = 1; c <= SEGMENT; c++) count_bits[c] = (float)((double)c * log2((double)c));
}

static int worth_coding(const uint8_t *p, size_t len) {
  /* four histograms: a run of one byte value would otherwise wait on its own counter */
  uint32_t counts[4][256] = {{0}};
  size_t i = 0;
  for (; i + 4 <= len; i += 4) {
    counts[0][p[i]]++;
    counts[1][p[i + 1]]++;
    counts[2][p[i + 2]]++;
    counts[3][p[i + 3]]++;
  }
  for (; i < len; i++) counts[0][p[i]]++;
  pthread_once(&count_bits_once, count_bits_init);
  double bits = (double)len * log2((double)len); /* Shannon: len log len - sum c log c */
  for (int b = 0; b < 256; b++) bits -= count_bits[counts[0][b] + counts[1][b] + counts[2][b] + counts[3][b]];
  return bits < CODED_BELOW_BITS * (double)len;
}

/* The zlib stream of the predicted bytes, segment by segment stored or coded as c->coded
 * says; 0 when it is not smaller than size (or zlib failed), else its length in c->out. */
static size_t deflate_segments(vf_exr_coder *c, size_t size) {
  z_stream *z = &c->deflate;
  if (deflateReset(z) != Z_OK) return 0;
  int coded = -1;
  z->next_out = c->out;
  z->avail_out = (uInt)(size < c->out_capacity ? size : c->out_capacity);
  for (size_t at = 0; at < size; at += SEGMENT) {
    size_t len = size - at < SEGMENT ? size - at : SEGMENT;
    int want = c->coded[at / SEGMENT];
    if (want != coded && deflateParams(z, want ? 1 : 0, want ? Z_RLE : Z_DEFAULT_STRATEGY) != Z_OK) return 0;
    coded = want;
    z->next_in = c->predicted + at;
    z->avail_in = (uInt)len;
    if (deflate(z, Z_NO_FLUSH) != Z_OK || z->avail_in != 0) return 0; /* out of room: not smaller */
  }
  if (deflate(z, Z_FINISH) != Z_STREAM_END) return 0;
  return z->total_out < size ? z->total_out : 0;
}

int vf_exr_chunk_encode(vf_exr_coder *c, vf_exr_compression compression, int n, const float *const *planes, int w,
                        int h, const uint8_t **data, size_t *len) {
  size_t size = chunk_bytes(n, w, h), row = (size_t)w * sizeof(float);
  if (size == 0 || size > UINT_MAX) return vf_error_set(VF_EINVAL, "an image chunk of %zu bytes", size);
  int err = reserve(c, size);
  if (err != VF_OK) return err;
  for (int y = 0; y < h; y++)
    for (int k = 0; k < n; k++) memcpy(c->packed + ((size_t)y * (size_t)n + (size_t)k) * row, planes[k] + (size_t)y * (size_t)w, row);
  *data = c->packed;
  *len = size;
  if (compression == VF_EXR_NONE) return VF_OK;
  if (!c->deflate_ready) {
    if (deflateInit2(&c->deflate, 1, Z_DEFLATED, 15, 8, Z_RLE) != Z_OK)
      return vf_error_set(VF_EEXR, "cannot start zlib compression");
    c->deflate_ready = 1;
  }
  predict(c->packed, size, c->out, c->predicted); /* c->out is free until deflate */
  size_t coded = 0;
  for (size_t at = 0; at < size; at += SEGMENT)
    coded += (size_t)(c->coded[at / SEGMENT] = (uint8_t)worth_coding(c->predicted + at, size - at < SEGMENT ? size - at : SEGMENT));
  /* Stored segments only would come out larger than the chunk: keep it as it is. */
  size_t out = coded ? deflate_segments(c, size) : 0;
  if (out > 0) {
    *data = c->out;
    *len = out;
  }
  return VF_OK;
}

int vf_exr_chunk_decode(vf_exr_coder *c, const uint8_t *data, size_t len, int n, int w, int h, float *const *planes) {
  size_t size = chunk_bytes(n, w, h), row = (size_t)w * sizeof(float);
  if (size == 0 || size > UINT_MAX) return vf_error_set(VF_EINVAL, "an image chunk of %zu bytes", size);
  if (len > size || len > UINT_MAX)
    return vf_error_set(VF_EINVAL, "%zu bytes of data, more than the %zu of the chunk uncompressed", len, size);
  int err = reserve(c, size);
  if (err != VF_OK) return err;
  if (len == size) {
    memcpy(c->packed, data, size);
  } else {
    if (!c->inflate_ready) {
      if (inflateInit(&c->inflate) != Z_OK) return vf_error_set(VF_ENOMEM, "cannot start zlib decompression");
      c->inflate_ready = 1;
    }
    z_stream *z = &c->inflate;
    if (inflateReset(z) != Z_OK) return vf_error_set(VF_EINVAL, "cannot restart zlib decompression");
    z->next_in = (Bytef *)data;
    z->avail_in = (uInt)len;
    z->next_out = c->predicted;
    z->avail_out = (uInt)size;
    int rc = inflate(z, Z_FINISH);
    if (rc != Z_STREAM_END || z->total_out != size || z->avail_in != 0)
      return vf_error_set(VF_EINVAL, "%zu bytes of data are not a ZIP chunk of %zu bytes (%s)", len, size,
                          rc == Z_STREAM_END ? "wrong length" : z->msg ? z->msg : "truncated");
    unpredict(c->predicted, size, c->packed);
  }
  for (int y = 0; y < h; y++)
    for (int k = 0; k < n; k++) memcpy(planes[k] + (size_t)y * (size_t)w, c->packed + ((size_t)y * (size_t)n + (size_t)k) * row, row);
  return VF_OK;
}
