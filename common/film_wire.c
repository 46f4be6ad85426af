#include "film_wire.h"

#include "error.h"
#include "file.h"

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

/* Copies comps values per pixel between a film plane and a tile array, either way. */
static void copy_plane(double *plane, double *tile, int width, int x0, int y0, int w, int h, int comps, int to_tile) {
  for (int row = 0; row < h; row++) {
    double *p = plane + ((size_t)(y0 + row) * (size_t)width + (size_t)x0) * (size_t)comps;
    double *t = tile + (size_t)row * (size_t)w * (size_t)comps;
    size_t n = (size_t)w * (size_t)comps * sizeof *p;
    if (to_tile) memcpy(t, p, n);
    else memcpy(p, t, n);
  }
}

int vf_film_tile_encode(const vf_film *film, uint32_t x, uint32_t y, Vcmfarm__Tile *tile, double **storage) {
  int x0, y0, w, h;
  if (!tile_rect(film->width, film->height, x, y, &x0, &y0, &w, &h))
    return vf_error_set(VF_EINVAL, "tile (%u,%u) is outside a %dx%d film", x, y, film->width, film->height);
  size_t n = (size_t)w * (size_t)h;
  double *block = malloc(10 * n * sizeof *block);
  if (block == NULL) return vf_error_set(VF_ENOMEM, "out of memory for a tile");
  vcmfarm__tile__init(tile);
  tile->x = x;
  tile->y = y;
  tile->camera = block;
  tile->count = block + 3 * n;
  tile->light = block + 4 * n;
  tile->square = block + 7 * n;
  tile->n_camera = tile->n_light = tile->n_square = 3 * n;
  tile->n_count = n;
  copy_plane(film->camera_sum, tile->camera, film->width, x0, y0, w, h, 3, 1);
  copy_plane(film->camera_count, tile->count, film->width, x0, y0, w, h, 1, 1);
  copy_plane(film->light_sum, tile->light, film->width, x0, y0, w, h, 3, 1);
  copy_plane(film->square_sum, tile->square, film->width, x0, y0, w, h, 3, 1);
  *storage = block;
  return VF_OK;
}

int vf_film_tile_check(const Vcmfarm__Tile *tile, int width, int height, uint64_t iterations) {
  int x0, y0, w, h;
  if (!tile_rect(width, height, tile->x, tile->y, &x0, &y0, &w, &h))
    return vf_error_set(VF_EINVAL, "tile (%u,%u) is outside a %dx%d film (%ux%u tiles)", tile->x, tile->y, width,
                        height, vf_film_tiles_across(width), vf_film_tiles_across(height));
  size_t n = (size_t)w * (size_t)h;
  const struct {
    const char *name;
    size_t len, expected;
    const double *data;
  } arrays[] = {{"camera", tile->n_camera, 3 * n, tile->camera},
                {"count", tile->n_count, n, tile->count},
                {"light", tile->n_light, 3 * n, tile->light},
                {"square", tile->n_square, 3 * n, tile->square}};
  for (size_t a = 0; a < 4; a++) {
    if (arrays[a].len != arrays[a].expected)
      return vf_error_set(VF_EINVAL, "tile (%u,%u): %s holds %zu values, a %dx%d tile needs %zu", tile->x, tile->y,
                          arrays[a].name, arrays[a].len, w, h, arrays[a].expected);
    for (size_t i = 0; i < arrays[a].len; i++) {
      double v = arrays[a].data[i];
      if (!isfinite(v))
        return vf_error_set(VF_EINVAL, "tile (%u,%u): %s value %zu is not finite", tile->x, tile->y, arrays[a].name, i);
      if (a == 1 && !(v >= 0.0 && v <= (double)iterations && v == floor(v)))
        return vf_error_set(VF_EINVAL, "tile (%u,%u): count %g at pixel %zu is not a whole number in [0, %llu]",
                            tile->x, tile->y, v, i, (unsigned long long)iterations);
      if (a == 3 && v < 0.0)
        return vf_error_set(VF_EINVAL, "tile (%u,%u): square sum %g at value %zu is negative", tile->x, tile->y, v, i);
    }
  }
  return VF_OK;
}

void vf_film_tile_store(vf_film *film, const Vcmfarm__Tile *tile) {
  int x0, y0, w, h;
  if (!tile_rect(film->width, film->height, tile->x, tile->y, &x0, &y0, &w, &h)) return;
  copy_plane(film->camera_sum, tile->camera, film->width, x0, y0, w, h, 3, 0);
  copy_plane(film->camera_count, tile->count, film->width, x0, y0, w, h, 1, 0);
  copy_plane(film->light_sum, tile->light, film->width, x0, y0, w, h, 3, 0);
  copy_plane(film->square_sum, tile->square, film->width, x0, y0, w, h, 3, 0);
}

int vf_film_send_tiles(const vf_film *film, Vcmfarm__LeaseResult *m, size_t tiles_per_message,
                       int (*send)(void *ctx, Vcmfarm__LeaseResult *m), void *ctx) {
  if (tiles_per_message == 0) return vf_error_set(VF_EINVAL, "vf_film_send_tiles: no tile per message");
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
  Vcmfarm__Tile *tiles = calloc(tiles_per_message, sizeof *tiles);
  Vcmfarm__Tile **ptrs = calloc(tiles_per_message, sizeof *ptrs);
  double **blocks = calloc(tiles_per_message, sizeof *blocks);
  int rc = 1;
  if (tiles == NULL || ptrs == NULL || blocks == NULL) rc = vf_error_set(VF_ENOMEM, "out of memory for tiles");
  uint32_t across = vf_film_tiles_across(film->width), next = 0;
  while (rc == 1 && next < m->tiles_total) {
    size_t n = 0;
    while (rc == 1 && n < tiles_per_message && next < m->tiles_total) {
      int err = vf_film_tile_encode(film, next % across, next / across, &tiles[n], &blocks[n]);
      if (err != VF_OK) {
        rc = err;
        break;
      }
      ptrs[n] = &tiles[n];
      n++;
      next++;
    }
    if (rc == 1) {
      m->n_tiles = n;
      m->tiles = ptrs;
      rc = send(ctx, m);
    }
    for (size_t i = 0; i < n; i++) free(blocks[i]);
  }
  m->n_tiles = 0;
  m->tiles = NULL;
  free(tiles);
  free(ptrs);
  free(blocks);
  return rc;
}
