/* Private to common/: the OpenEXRCore plumbing that film_file.c and image.c share.
 *
 * OpenEXR errors are translated into VF_EEXR here, once, with a detail "FILE: problem
 * (library message)". The library's own messages are captured per thread instead of being
 * printed to stderr. Files are untrusted: the reader refuses multi-part and deep files,
 * absurd sizes and files too short for their chunk table before it allocates anything,
 * and hands pixels to its caller one decoded chunk at a time, converted to float.
 *
 * Chunks are decoded, and filled and encoded, in parallel: one thread per CPU (at most
 * 16), each with its own buffers, so the store and fill callbacks run concurrently for
 * different chunks and must only touch their chunk's pixels. The writer packs and
 * compresses chunks itself (common/exr_chunk.h) and writes them in order, so a file's
 * bytes do not depend on the number of threads; it streams the file through an atomic
 * file (common/atomic_file.h), whose rule every writer follows. */
#ifndef VF_EXR_UTIL_H
#define VF_EXR_UTIL_H

#include "atomic_file.h"
#include "exr_chunk.h"

#include <openexr.h>

#include <stddef.h>
#include <stdint.h>

/* Refuse data windows above this many pixels before allocating anything. */
#define VF_EXR_MAX_PIXELS ((int64_t)1 << 28)
#define VF_EXR_MAX_SIDE 65536
/* Channels read or written at once. */
#define VF_EXR_MAX_CHANNELS 64

/* ---- reading ---- */

typedef struct {
  exr_context_t ctx;
  const char *path; /* borrowed from the caller for error details */
  int width, height; /* the data window, which is "the image" */
  int min_x, min_y;
  int tiled;
  const uint8_t *memory; /* vf_exr_open_memory: the file's bytes, borrowed; else NULL */
  uint64_t memory_size;
} vf_exr_in;

/* Opens path and checks it is a single-part, flat (not deep), scanline or tiled image of a
 * sane size. VF_ENOENT, VF_EIO, or VF_EEXR with a detail. in->ctx is set only on success. */
int vf_exr_open(const char *path, vf_exr_in *in);
/* The same for a file held in memory (`name` in errors): bytes are borrowed until
 * vf_exr_close, and *in must not move meanwhile (the library reads through it). */
int vf_exr_open_memory(const void *bytes, size_t size, const char *name, vf_exr_in *in);
void vf_exr_close(vf_exr_in *in);

/* 1 if the file has a channel with this exact name (any sampling), else 0. */
int vf_exr_has_channel(const vf_exr_in *in, const char *name);

/* Receives one decoded chunk: planes[i] holds w*h floats (rows of w, top row first) of
 * channel names[i] for the data-window rectangle at (x0, y0), relative to the window's
 * top-left corner. Returns VF_OK or an error that stops the read. */
typedef int (*vf_exr_store_fn)(void *user, int x0, int y0, int w, int h, const float *const *planes);

/* Decodes channels `names` (which must all exist, unsubsampled) over the whole data
 * window, level 0 of a tiled file, calling store once per chunk, from several threads at
 * once. VF_EEXR with a detail naming the chunk on corrupt data; store's error is passed
 * through (the first, when several chunks fail). */
int vf_exr_read_channels(vf_exr_in *in, int n, const char *const *names, vf_exr_store_fn store, void *user);
/* The same, channel k decoded as 32-bit unsigned integers (its plane holds uint32_t, not
 * floats) when bit k of uint_mask is set: such a channel must be of type UINT in the file
 * (VF_EEXR naming it otherwise), so that no conversion touches its bits. */
int vf_exr_read_channels_typed(vf_exr_in *in, int n, const char *const *names, uint64_t uint_mask,
                               vf_exr_store_fn store, void *user);

/* ---- writing ---- */

typedef struct {
  exr_context_t ctx;
  vf_atomic_file file;
  int width, height, tile; /* tile 0: scanline */
  int channels;
  vf_exr_compression compression;
  int order[VF_EXR_MAX_CHANNELS]; /* the file's i-th channel is names[order[i]] */
  uint64_t written, handed;       /* bytes written, and handed to the disk early */
  int checksum;                   /* vf_exr_add_checksum was called */
} vf_exr_out;

/* Starts an atomic write of a FLOAT one-part image with channels `names`, in tile x tile
 * tiles, or scanlines when tile is 0; ZIP (exr_chunk.h) or uncompressed. Attributes may
 * be added with the exr_attr_set_* functions on out->ctx until vf_exr_write_pixels. */
int vf_exr_create(const char *path, int width, int height, int tile, vf_exr_compression compression, int n,
                  const char *const *names, vf_exr_out *out);
/* The same with channel k of type UINT when bit k of uint_mask is set: its plane, filled
 * as floats are, holds uint32_t values (the chunk's bytes are the same width). */
int vf_exr_create_typed(const char *path, int width, int height, int tile, vf_exr_compression compression, int n,
                        const char *const *names, uint64_t uint_mask, vf_exr_out *out);

/* Fills one chunk: planes[i] receives w*h floats of channel names[i] at (x0, y0). Called
 * from several threads at once, for different chunks. */
typedef void (*vf_exr_fill_fn)(void *user, int x0, int y0, int w, int h, float *const *planes);

/* Writes the header and every chunk, asking fill for the pixels; n and names are those
 * given to vf_exr_create. */
int vf_exr_write_pixels(vf_exr_out *out, int n, const char *const *names, vf_exr_fill_fn fill, void *user);

/* Files that check themselves: the string attribute VF_EXR_CHECKSUM_ATTR holds 64
 * lower-case hex digits of BLAKE2b-256 over the BLAKE2b-256 digests of the file's 8 MiB
 * segments in order and its size (a little-endian 64-bit number), every byte of the file
 * hashed, the 64 bytes of the value itself read as '0's. Header, offset table and chunks
 * are all covered, so any flipped bit is found, at the price of one pass of hashing over
 * the file when it is written and when it is read, the segments in parallel. vf_exr_add_checksum (before vf_exr_write_pixels) makes vf_exr_commit
 * compute the value and write it into the finished file before it is renamed into place;
 * vf_exr_verify_checksum checks a file (or a file in memory) so written: VF_EEXR with
 * "PATH: damaged: ..." when it does not match. */
#define VF_EXR_CHECKSUM_ATTR "vcmfarm:checksum"
int vf_exr_add_checksum(vf_exr_out *out);
int vf_exr_verify_checksum(const vf_exr_in *in);
/* For vf_exr_commit: the finished temporary file's checksum, written into its attribute. */
int vf_exr_write_checksum(vf_exr_out *out);

/* Finishes the file and renames it into place. Releases out either way. */
int vf_exr_commit(vf_exr_out *out);
/* Drops the half-written file. No-op on a released writer. */
void vf_exr_abort(vf_exr_out *out);

/* Translates an OpenEXRCore result into VF_EEXR with "PATH: what (library message)". */
int vf_exr_error(const char *path, exr_result_t rv, const char *what);

#endif
