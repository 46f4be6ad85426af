/* Private to common/: one chunk of FLOAT channels in OpenEXR's byte layout, packed and
 * compressed by our own code, so that a chunk can go to a file (exr_util.c, through
 * exr_write_tile_chunk) or into a message (film_wire.c) and be encoded on any thread.
 *
 * The layout is OpenEXR's: for each line of the chunk, for each channel in the order the
 * file lists them (sorted by name), w little-endian floats. ZIP is OpenEXR's ZIP (its byte
 * reordering and delta predictor, then one zlib stream) as any EXR reader decodes it; what
 * is ours is how the zlib stream is made: the predicted bytes are cut into segments, and a
 * segment whose bytes look random (the entropy of their histogram above 7 bits per byte)
 * is stored, the others are run-length and Huffman coded (zlib's Z_RLE). Noise, most of a film, costs a copy
 * instead of a search for matches that are not there; black regions and the zero bytes of
 * exact sums still shrink. A chunk that does not get smaller is stored uncompressed, the
 * EXR rule for every compression. Lossless either way. */
#ifndef VF_EXR_CHUNK_H
#define VF_EXR_CHUNK_H

#include <stddef.h>
#include <stdint.h>
#include <zlib.h>

typedef enum { VF_EXR_NONE = 0, VF_EXR_ZIP = 1 } vf_exr_compression;

/* One thread's buffers and zlib streams, reused from chunk to chunk. Not shared. */
typedef struct {
  uint8_t *packed, *predicted, *out;
  uint8_t *coded; /* per segment of predicted bytes: 1 coded, 0 stored */
  size_t capacity, out_capacity;
  z_stream deflate, inflate;
  int deflate_ready, inflate_ready;
} vf_exr_coder;

/* Threads to code `chunks` chunks with: one per CPU, at most 16, at most one per chunk. */
int vf_exr_chunk_threads(size_t chunks);

void vf_exr_coder_init(vf_exr_coder *c);
void vf_exr_coder_destroy(vf_exr_coder *c);

/* Packs n planes of w x h floats (rows top first, channels in the file's order) and
 * compresses them: *data (owned by c, valid until its next call) and *len. VF_ENOMEM or
 * VF_EEXR (zlib failed) with a detail. */
int vf_exr_chunk_encode(vf_exr_coder *c, vf_exr_compression compression, int n, const float *const *planes, int w,
                        int h, const uint8_t **data, size_t *len);

/* The inverse, for untrusted bytes: decodes a chunk of n channels of w x h into planes.
 * VF_EINVAL with a detail when the bytes are not exactly such a chunk (wrong size, a
 * damaged or trailing zlib stream), VF_ENOMEM. */
int vf_exr_chunk_decode(vf_exr_coder *c, const uint8_t *data, size_t len, int n, int w, int h, float *const *planes);

#endif
