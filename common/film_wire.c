#include "film_wire.h"

#include "error.h"
#include "exr_chunk.h"
#include "file.h"
#include "film_planes.h"
#include "pool.h"

#include <errno.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <unistd.h>

static int temp_path(char *path, size_t n) {
  const char *dir = getenv("TMPDIR");
  if (dir == NULL || dir[0] == '\0') dir = "/tmp";
  if (snprintf(path, n, "%s/vcmfarm-film-XXXXXX.exr", dir) >= (int)n)
    return vf_error_set(VF_EINVAL, "TMPDIR too long");
  int fd = mkstemps(path, 4);
  if (fd < 0) return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  close(fd);
  return VF_OK;
}

int vf_film_to_bytes(const vf_film *film, size_t max_len, uint8_t **data, size_t *len) {
  char path[4096];
  int err = temp_path(path, sizeof path);
  if (err != VF_OK) return err;
  if ((err = vf_film_write(film, path)) == VF_OK) err = vf_file_read_all(path, max_len, data, len);
  unlink(path);
  return err;
}

/* A private scratch file read back at once: no fsync, no rename (an atomic write's fsync
 * cost the coordinator ~5 ms of waiting per result, twice its CPU time). */
static int write_scratch(const char *path, const uint8_t *data, size_t len) {
  FILE *f = fopen(path, "wb");
  if (f == NULL) return vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
  int ok = fwrite(data, 1, len, f) == len;
  if (fclose(f) != 0) ok = 0;
  return ok ? VF_OK : vf_error_set(VF_EIO, "%s: %s", path, strerror(errno));
}

int vf_film_from_bytes(const uint8_t *data, size_t len, const char *name, vf_film **out) {
  char path[4096];
  int err = temp_path(path, sizeof path);
  if (err != VF_OK) return err;
  vf_film *film = NULL;
  if ((err = write_scratch(path, data, len)) == VF_OK) err = vf_film_read(path, &film);
  unlink(path);
  if (err != VF_OK) {
    /* Name the source, not our temporary file, in the detail. */
    const char *detail = vf_error_detail(err), *at = strstr(detail, path);
    if (at != NULL) {
      char rest[1024];
      snprintf(rest, sizeof rest, "%s", at + strlen(path));
      return vf_error_set(err, "%s%s", name, rest);
    }
    return err;
  }
  *out = film;
  return VF_OK;
}

/* ---- tiles ---- */

uint32_t vf_film_tiles_across(int width) { return (uint32_t)((width + VF_FILM_TILE - 1) / VF_FILM_TILE); }

uint32_t vf_film_tile_count(int width, int height) {
  return vf_film_tiles_across(width) * vf_film_tiles_across(height);
}

/* The pixel rectangle of tile (x, y); 0 when it lies outside the film. */
static int tile_rect(int width, int height, uint32_t x, uint32_t y, int *x0, int *y0, int *w, int *h) {
  if (x >= vf_film_tiles_across(width) || y >= vf_film_tiles_across(height)) return 0;
  *x0 = (int)x * VF_FILM_TILE;
  *y0 = (int)y * VF_FILM_TILE;
  *w = width - *x0 < VF_FILM_TILE ? width - *x0 : VF_FILM_TILE;
  *h = height - *y0 < VF_FILM_TILE ? height - *y0 : VF_FILM_TILE;
  return 1;
}

/* Encodes tile (x, y) of film with coder c into a new block (*storage) that tile->chunk
 * points to. */
static int encode_tile(vf_exr_coder *c, const vf_film *film, const vf_film_accum *pending, uint32_t x, uint32_t y,
                       Vcmfarm__Tile *tile, uint8_t **storage) {
  int x0, y0, w, h;
  if (!tile_rect(film->width, film->height, x, y, &x0, &y0, &w, &h))
    return vf_error_set(VF_EINVAL, "tile (%u,%u) is outside a %dx%d film", x, y, film->width, film->height);
  size_t plane = (size_t)w * (size_t)h;
  float *block = malloc(VF_FILM_V4_CHANNELS * plane * sizeof *block), *planes[VF_FILM_V4_CHANNELS];
  /* With pending sums, the tile's exact sums from them first, in a block of its own. */
  vf_fixed *sums = pending ? malloc(6 * plane * sizeof *sums) : NULL;
  if (block == NULL || (pending && sums == NULL)) {
    free(block);
    free(sums);
    return vf_error_set(VF_ENOMEM, "out of memory for a tile");
  }
  for (int k = 0; k < VF_FILM_V4_CHANNELS; k++) planes[k] = block + (size_t)k * plane;
  vf_film_sums from = vf_film_sums_of(film);
  int fx = x0, fy = y0;
  if (pending) {
    vf_film_accum_rect(pending, x0, y0, w, h, sums, sums + 3 * plane);
    from.sum = sums;
    from.square_sum = sums + 3 * plane;
    from.width = w;
    fx = fy = 0;
  }
  const uint8_t *data;
  size_t len;
  int err = vf_film_planes_fill_v4(from, fx, fy, w, h, planes)
                ? vf_exr_chunk_encode(c, VF_EXR_ZIP, VF_FILM_V4_CHANNELS, (const float *const *)planes, w, h, &data, &len)
                : vf_error_set(VF_EFILM, "tile (%u,%u) holds a value beyond the film format's range", x, y);
  free(sums);
  free(block);
  if (err != VF_OK) return err;
  if ((*storage = malloc(len)) == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a tile");
  memcpy(*storage, data, len);
  vcmfarm__tile__init(tile);
  tile->x = x;
  tile->y = y;
  tile->chunk.data = *storage;
  tile->chunk.len = len;
  return VF_OK;
}

int vf_film_tile_encode(const vf_film *film, uint32_t x, uint32_t y, Vcmfarm__Tile *tile, uint8_t **storage) {
  vf_exr_coder c;
  vf_exr_coder_init(&c);
  int err = encode_tile(&c, film, NULL, x, y, tile, storage);
  vf_exr_coder_destroy(&c);
  return err;
}

/* Decodes one untrusted tile into t (its block allocated here). */
static int decode_tile(vf_exr_coder *c, const Vcmfarm__Tile *m, int width, int height, uint64_t iterations,
                       int square_bits, float *scratch, vf_film_tile *t) {
  int x0, y0, w, h;
  if (!tile_rect(width, height, m->x, m->y, &x0, &y0, &w, &h))
    return vf_error_set(VF_EINVAL, "tile (%u,%u) is outside a %dx%d film (%ux%u tiles)", m->x, m->y, width, height,
                        vf_film_tiles_across(width), vf_film_tiles_across(height));
  size_t plane = (size_t)w * (size_t)h;
  float *planes[VF_FILM_V4_CHANNELS];
  for (int k = 0; k < VF_FILM_V4_CHANNELS; k++) planes[k] = scratch + (size_t)k * plane;
  int err = vf_exr_chunk_decode(c, m->chunk.data, m->chunk.len, VF_FILM_V4_CHANNELS, w, h, planes);
  if (err == VF_EINVAL) return vf_error_set(err, "tile (%u,%u): %s", m->x, m->y, vf_error_detail(err));
  if (err != VF_OK) return err;
  *t = (vf_film_tile){m->x, m->y, x0, y0, w, h, malloc(6 * plane * sizeof(vf_fixed)), NULL};
  if (t->sum == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a tile");
  t->square_sum = t->sum + 3 * plane;
  char name[64];
  snprintf(name, sizeof name, "tile (%u,%u)", m->x, m->y);
  err = vf_film_planes_store_v4((vf_film_sums){t->sum, t->square_sum, w, iterations, square_bits}, name, 0, 0, w, h,
                                (const float *const *)planes);
  if (err != VF_OK) {
    free(t->sum);
    return vf_error_set(VF_EINVAL, "%s", vf_error_detail(err));
  }
  for (size_t i = 0; i < 3 * plane; i++) {
    if (iterations == 0 && (t->sum[i] != 0 || t->square_sum[i] != 0))
      err = vf_error_set(VF_EINVAL, "tile (%u,%u): pixel %zu holds sums but the part has no iterations", m->x, m->y,
                         i / 3);
    else if (t->square_sum[i] < 0)
      err = vf_error_set(VF_EINVAL, "tile (%u,%u): square sum %g at pixel %zu is negative", m->x, m->y,
                         vf_fixed_to_double(t->square_sum[i], square_bits), i / 3);
    if (err != VF_OK) {
      free(t->sum);
      return err;
    }
  }
  return VF_OK;
}

int vf_film_tiles_decode(const Vcmfarm__LeaseResult *m, int width, int height, vf_film_tile **out) {
  size_t n = m->n_tiles;
  vf_film_tile *tiles = calloc(n ? n : 1, sizeof *tiles);
  float *scratch = malloc(VF_FILM_V4_CHANNELS * VF_FILM_TILE * VF_FILM_TILE * sizeof *scratch);
  int square_bits = vf_film_square_bits_of(m->settings ? m->settings : "");
  vf_exr_coder c;
  vf_exr_coder_init(&c);
  int err = tiles && scratch ? VF_OK : vf_error_set(VF_ENOMEM, "out of memory for tiles");
  size_t done = 0;
  for (; err == VF_OK && done < n; done++)
    if ((err = decode_tile(&c, m->tiles[done], width, height, m->end - m->begin, square_bits, scratch, &tiles[done])) != VF_OK) break;
  vf_exr_coder_destroy(&c);
  free(scratch);
  if (err != VF_OK) {
    vf_film_tiles_free(tiles, done);
    return err;
  }
  *out = tiles;
  return VF_OK;
}

void vf_film_tiles_free(vf_film_tile *tiles, size_t n) {
  if (tiles == NULL) return;
  for (size_t i = 0; i < n; i++) free(tiles[i].sum);
  free(tiles);
}

/* Copies 3 values per pixel between a film array and a tile array, either way. */
static void copy_rows(vf_fixed *film_values, int width, vf_fixed *tile_values, const vf_film_tile *t, int to_film) {
  for (int row = 0; row < t->h; row++) {
    vf_fixed *f = film_values + ((size_t)(t->y0 + row) * (size_t)width + (size_t)t->x0) * 3;
    vf_fixed *v = tile_values + (size_t)row * (size_t)t->w * 3;
    if (to_film) memcpy(f, v, (size_t)t->w * 3 * sizeof *f);
    else memcpy(v, f, (size_t)t->w * 3 * sizeof *f);
  }
}

int vf_film_tile_matches(const vf_film *film, const vf_film_tile *t) {
  for (int row = 0; row < t->h; row++) {
    size_t at = ((size_t)(t->y0 + row) * (size_t)film->width + (size_t)t->x0) * 3, len = (size_t)t->w * 3;
    size_t in = (size_t)row * len;
    if (memcmp(film->sum + at, t->sum + in, len * sizeof(vf_fixed)) != 0 ||
        memcmp(film->square_sum + at, t->square_sum + in, len * sizeof(vf_fixed)) != 0)
      return 0;
  }
  return 1;
}

void vf_film_tile_store(vf_film *film, const vf_film_tile *t) {
  copy_rows(film->sum, film->width, t->sum, t, 1);
  copy_rows(film->square_sum, film->width, t->square_sum, t, 1);
}

/* One message's tiles, encoded in parallel: task i encodes tile first + i. */
typedef struct {
  const vf_film *film;
  const vf_film_accum *pending;
  uint32_t first, across;
  Vcmfarm__Tile *tiles;
  uint8_t **blocks;
  vf_exr_coder *coders; /* per thread */
  int *errors;          /* per task */
  char (*details)[256]; /* per task */
} encode_job;

static void encode_task(void *ctx, size_t i, int thread) {
  encode_job *j = ctx;
  uint32_t index = j->first + (uint32_t)i;
  j->errors[i] = encode_tile(&j->coders[thread], j->film, j->pending, index % j->across, index / j->across, &j->tiles[i], &j->blocks[i]);
  if (j->errors[i] != VF_OK) snprintf(j->details[i], sizeof j->details[i], "%s", vf_error_detail(j->errors[i]));
}

/* The header of a part's LeaseResult messages from film, m->begin set by the caller: end,
 * size, scene hash and settings (pointing into film), tile count, times. */
static void result_header(const vf_film *film, Vcmfarm__LeaseResult *m) {
  m->end = m->begin + vf_iterset_count(&film->iterations);
  m->width = (uint32_t)film->width;
  m->height = (uint32_t)film->height;
  m->scene_hash.data = (uint8_t *)film->scene_hash;
  m->scene_hash.len = sizeof film->scene_hash;
  m->settings = (char *)film->settings_text;
  m->tiles_total = vf_film_tile_count(film->width, film->height);
  m->render_seconds = film->render_seconds;
  m->cpu_seconds = film->cpu_seconds;
  m->nonfinite_samples = film->nonfinite_samples;
  m->biased_merges = film->biased_merges;
}

int vf_film_send_tiles(const vf_film *film, Vcmfarm__LeaseResult *m, size_t tiles_per_message,
                       int (*send)(void *ctx, Vcmfarm__LeaseResult *m), void *ctx) {
  return vf_film_send_tiles_pending(film, NULL, m, tiles_per_message, send, ctx);
}

int vf_film_send_tiles_pending(const vf_film *film, const vf_film_accum *pending, Vcmfarm__LeaseResult *m,
                               size_t tiles_per_message, int (*send)(void *ctx, Vcmfarm__LeaseResult *m), void *ctx) {
  if (tiles_per_message == 0) return vf_error_set(VF_EINVAL, "vf_film_send_tiles: no tile per message");
  result_header(film, m);
  int threads = vf_exr_chunk_threads(tiles_per_message);
  encode_job job = {film, pending, 0, vf_film_tiles_across(film->width), calloc(tiles_per_message, sizeof(Vcmfarm__Tile)),
                    calloc(tiles_per_message, sizeof(uint8_t *)), calloc((size_t)threads, sizeof(vf_exr_coder)),
                    calloc(tiles_per_message, sizeof(int)), calloc(tiles_per_message, 256)};
  Vcmfarm__Tile **ptrs = calloc(tiles_per_message, sizeof *ptrs);
  vf_pool *pool = NULL;
  int rc = 1;
  if (!job.tiles || !job.blocks || !job.coders || !job.errors || !job.details || !ptrs)
    rc = vf_error_set(VF_ENOMEM, "out of memory for tiles");
  if (rc == 1 && threads > 1 && vf_pool_create(threads, &pool) != VF_OK) threads = 1;
  for (int t = 0; job.coders && t < threads; t++) vf_exr_coder_init(&job.coders[t]);
  while (rc == 1 && job.first < m->tiles_total) {
    size_t n = m->tiles_total - job.first < tiles_per_message ? m->tiles_total - job.first : tiles_per_message;
    if (pool) vf_pool_run(pool, n, encode_task, &job);
    else
      for (size_t i = 0; i < n; i++) encode_task(&job, i, 0);
    for (size_t i = 0; i < n && rc == 1; i++)
      if (job.errors[i] != VF_OK) rc = vf_error_set(job.errors[i], "%s", job.details[i]);
    for (size_t i = 0; i < n; i++) ptrs[i] = &job.tiles[i];
    if (rc == 1) {
      m->n_tiles = n;
      m->tiles = ptrs;
      rc = send(ctx, m);
    }
    for (size_t i = 0; i < n; i++) {
      free(job.blocks[i]);
      job.blocks[i] = NULL;
    }
    job.first += (uint32_t)n;
  }
  m->n_tiles = 0;
  m->tiles = NULL;
  vf_pool_destroy(pool);
  for (int t = 0; job.coders && t < threads; t++) vf_exr_coder_destroy(&job.coders[t]);
  free(job.coders);
  free(job.tiles);
  free(job.blocks);
  free(job.errors);
  free(job.details);
  free(ptrs);
  return rc;
}
