/* Films in messages: whole films as the bytes of their EXR file (fetch, tests), and a
 * lease's result as 64x64 tiles (the film's EXR tiling, VF_FILM_TILE) of raw sums.
 *
 * Whole films: the film file format (docs/FILM.md) held in memory,
 * Built on the public film API through a private temporary file in $TMPDIR (or /tmp),
 * removed before returning: the bytes are exactly what vf_film_write puts on disk and
 * vf_film_read's checks apply unchanged to what arrives from the network. */
#ifndef VF_FILM_WIRE_H
#define VF_FILM_WIRE_H

#include "film.h"
#include "film_accum.h"
#include "message.h"

#include <stddef.h>
#include <stdint.h>

/* Encodes film; *data (malloc'ed, the caller frees) and *len are written only on success.
 * Fails like vf_film_write, or VF_EINVAL when the file would exceed max_len bytes. */
int vf_film_to_bytes(const vf_film *film, size_t max_len, uint8_t **data, size_t *len);

/* Decodes and validates untrusted bytes; *out (caller destroys) is written only on
 * success. Fails like vf_film_read (VF_EEXR / VF_EFILM with a detail), the file name in
 * details being `name`. */
int vf_film_from_bytes(const uint8_t *data, size_t len, const char *name, vf_film **out);

/* Tiles, numbered row-major from the top left: tile (x, y) holds pixels
 * [64 x, min(64 x + 64, width)) x [64 y, min(64 y + 64, height)). On the wire a tile is its
 * chunk of the film file (proto/vcmfarm.proto, Tile; common/film_planes.h): what a file
 * holds, as compact, decoded in one pass. */
uint32_t vf_film_tiles_across(int width);
/* Tiles per LeaseResult message: a tile's chunk is at most 72 bytes per pixel (294,912
 * bytes for 64x64, stored when ZIP does not shrink it), so 13 stay under the
 * coordinator's VF_WIRE_MAX_RESULT of 4 MiB with their header. */
#define VF_FILM_TILES_PER_MESSAGE 13
uint32_t vf_film_tile_count(int width, int height);

/* Fills *tile with tile (x, y) of film, its chunk in one malloc'ed block written to
 * *storage (the caller frees it after packing). VF_EINVAL for a tile outside the film,
 * VF_EFILM for one holding a value beyond float range, VF_ENOMEM. */
int vf_film_tile_encode(const vf_film *film, uint32_t x, uint32_t y, Vcmfarm__Tile *tile, uint8_t **storage);

/* A tile decoded from a message: its pixels' sums, 3 per pixel each, rows of w pixels. */
typedef struct {
  uint32_t x, y;
  int x0, y0, w, h;
  vf_fixed *sum, *square_sum; /* one block, owned */
} vf_film_tile;

/* Decodes and checks the untrusted tiles of m for a film of width x height holding the
 * part's m->end - m->begin iterations: coordinates inside the film, each chunk exactly a
 * tile's, sums within the film's range, squares >= 0, none without iterations. *out (n_tiles of them, free with vf_film_tiles_free)
 * on success only; VF_EINVAL with a detail naming the tile and what is wrong, VF_ENOMEM. */
int vf_film_tiles_decode(const Vcmfarm__LeaseResult *m, int width, int height, vf_film_tile **out);
void vf_film_tiles_free(vf_film_tile *tiles, size_t n);

/* 1 when film holds exactly t's values at t's place (of the size t was decoded for). */
int vf_film_tile_matches(const vf_film *film, const vf_film_tile *t);

/* Copies t into its place in film (of the size t was decoded for). */
void vf_film_tile_store(vf_film *film, const vf_film_tile *t);

/* A film as the LeaseResult messages of a part [m->begin, m->begin + its iterations): the
 * caller sets worker_id, lease_id, job_id and begin in *m; this fills in the rest of the
 * header and, message after message, up to tiles_per_message tiles (encoded on one thread
 * per CPU), calling send(ctx, m) for each. Stops at the first send that does not return 1
 * and returns its value; 1 when every message was sent and accepted, or a negative
 * encoding error. */
int vf_film_send_tiles(const vf_film *film, Vcmfarm__LeaseResult *m, size_t tiles_per_message,
                       int (*send)(void *ctx, Vcmfarm__LeaseResult *m), void *ctx);

/* The same with the pixels' sums taken from pending instead of film, whose sums are not
 * read (film_accum.h: a worker's part, its pixels in pending and the rest in film), each
 * tile's exact sums made as it is encoded: no whole film of 128-bit sums is made, nor are
 * film's pages touched. pending NULL: vf_film_send_tiles. */
int vf_film_send_tiles_pending(const vf_film *film, const vf_film_accum *pending, Vcmfarm__LeaseResult *m,
                               size_t tiles_per_message, int (*send)(void *ctx, Vcmfarm__LeaseResult *m), void *ctx);

#endif
