/* The compact accumulator (common/film_accum.h): a worker's 64-bit sums must be the film's
 * 128-bit sums exactly, whatever they hold, and the tiles shipped from them the tiles of
 * the film itself, byte for byte. The int64 boundary is crossed on purpose: by estimates
 * of a huge emitter (near VF_FILM_SAMPLE_LIMIT, 2^65 units and more), and, for ordinary
 * values, by lowering the slots' limit (the test hook). */
#include "check.h"
#include "common/error.h"
#include "common/film.h"
#include "common/film_accum.h"
#include "common/film_wire.h"
#include "common/pool.h"

#include <math.h>
#include <stdint.h>
#include <stdlib.h>
#include <string.h>

#define W 70 /* two tiles across, the second partial */
#define H 33

static const char *const settings_independent =
    "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75 seed=1 resolution=70x33";
static const char *const settings_sobol =
    "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75 seed=1 resolution=70x33 sampler=sobol";

/* A deterministic frame of iteration k: ordinary radiance, a few huge samples (a bright
 * emitter: 6e9, below the film's limit), negative values, and non-finite ones. */
static void frame(uint64_t k, int which, float *rgb) {
  uint32_t s = (uint32_t)(k * 2654435761u + (uint32_t)which * 97u + 1u);
  for (size_t i = 0; i < 3 * (size_t)W * H; i++) {
    s = s * 1664525u + 1013904223u;
    float u = (float)(s >> 8) / 16777216.0f;
    float v = u * 4.0f;
    if (i % 211 == 5) v = 6e9f * (0.5f + u);            /* huge: up to 9e9, some beyond the limit */
    else if (i % 97 == 3) v = -u;                        /* negative */
    else if (i % 503 == 7 && which == 1) v = NAN;        /* refused, counted */
    else if (i % 509 == 11 && which == 0) v = INFINITY;  /* refused, counted */
    rgb[i] = v;
  }
}

static vf_film *stamped(const char *settings) {
  vf_film *f = NULL;
  CHECK_INT_EQ(vf_film_create(W, H, &f), VF_OK);
  snprintf(f->settings_text, sizeof f->settings_text, "%s", settings);
  return f;
}

/* Iterations [0, n) into a film and into an accumulator beside a second film (the worker's
 * way); every sum of film + accumulator must be the film's, and the counts alike. */
static void check_matches(const char *settings, int64_t limit, uint64_t n, vf_pool *pool, int expect_spill) {
  vf_film *film = stamped(settings), *meta = stamped(settings);
  vf_film_accum *a = NULL;
  CHECK_INT_EQ(vf_film_accum_create(W, H, &a), VF_OK);
  if (limit > 0) vf_film_accum_set_limit(a, limit);
  float *cam = malloc(3 * sizeof(float) * W * H), *light = malloc(3 * sizeof(float) * W * H);
  for (uint64_t k = 0; k < n; k++) {
    frame(k, 0, cam);
    frame(k, 1, light);
    CHECK_INT_EQ(vf_film_add_iteration(film, k, cam, light, pool), VF_OK);
    CHECK_INT_EQ(vf_film_accum_add_iteration(a, meta, k, cam, light, pool), VF_OK);
  }
  CHECK_INT_EQ(vf_film_accum_add_iteration(a, meta, 0, cam, light, pool), VF_EOVERLAP);
  CHECK_INT_EQ(meta->nonfinite_samples, film->nonfinite_samples);
  CHECK(film->nonfinite_samples > 0);
  CHECK(vf_iterset_equal(&meta->iterations, &film->iterations));
  if (expect_spill) CHECK(vf_film_accum_spilled(a) > 0);
  /* The film beyond int64 where expected: the case is real. */
  int beyond = 0;
  for (size_t i = 0; i < 3 * (size_t)W * H; i++) beyond |= film->square_sum[i] != (vf_fixed)(int64_t)film->square_sum[i];
  if (expect_spill && limit <= 0) CHECK(beyond);
  vf_fixed *sum = malloc(3 * sizeof(vf_fixed) * W * H), *square = malloc(3 * sizeof(vf_fixed) * W * H);
  vf_film_accum_rect(a, 0, 0, W, H, sum, square);
  size_t differ = 0;
  for (size_t i = 0; i < 3 * (size_t)W * H; i++) differ += sum[i] != film->sum[i] || square[i] != film->square_sum[i];
  CHECK_INT_EQ(differ, 0);
  /* A rectangle inside, as a tile is read. */
  vf_film_accum_rect(a, 64, 32, 6, 1, sum, square);
  differ = 0;
  for (size_t i = 0; i < 18; i++)
    differ += sum[i] != film->sum[3 * (32 * W + 64) + i] || square[i] != film->square_sum[3 * (32 * W + 64) + i];
  CHECK_INT_EQ(differ, 0);
  /* Carried into the metadata film: the film itself, bit for bit; the accumulator empty. */
  vf_film_accum_carry(a, meta);
  CHECK_INT_EQ(vf_film_accum_spilled(a), 0);
  differ = 0;
  for (size_t i = 0; i < 3 * (size_t)W * H; i++)
    differ += meta->sum[i] != film->sum[i] || meta->square_sum[i] != film->square_sum[i];
  CHECK_INT_EQ(differ, 0);
  vf_film_accum_rect(a, 0, 0, W, H, sum, square);
  differ = 0;
  for (size_t i = 0; i < 3 * (size_t)W * H; i++) differ += sum[i] != 0 || square[i] != 0;
  CHECK_INT_EQ(differ, 0);
  free(sum);
  free(square);
  free(cam);
  free(light);
  vf_film_accum_destroy(a);
  vf_film_destroy(meta);
  vf_film_destroy(film);
}

static void test_huge_emitters_leave_int64_exactly(void) {
  check_matches(settings_independent, 0, 5, NULL, 1);
  check_matches(settings_sobol, 0, 5, NULL, 1);
}

static void test_lowered_limit_spills_ordinary_values_exactly(void) {
  vf_pool *pool = NULL;
  CHECK_INT_EQ(vf_pool_create(2, &pool), VF_OK);
  /* 2^33 units: radiance 2 for the sums, a handful of iterations for most values */
  check_matches(settings_independent, (int64_t)1 << 33, 7, pool, 1);
  check_matches(settings_sobol, (int64_t)1 << 33, 7, pool, 1);
  check_matches(settings_independent, 1, 3, pool, 1); /* every non-zero value spills */
  vf_pool_destroy(pool);
}

/* The messages' tiles, in order: their bytes. */
typedef struct {
  uint8_t *bytes;
  size_t len;
} recorded;

static int record(void *ctx, Vcmfarm__LeaseResult *m) {
  recorded *r = ctx;
  for (size_t i = 0; i < m->n_tiles; i++) {
    size_t n = m->tiles[i]->chunk.len;
    r->bytes = realloc(r->bytes, r->len + n + 8);
    memcpy(r->bytes + r->len, &m->tiles[i]->x, 4);
    memcpy(r->bytes + r->len + 4, &m->tiles[i]->y, 4);
    memcpy(r->bytes + r->len + 8, m->tiles[i]->chunk.data, n);
    r->len += n + 8;
  }
  return 1;
}

static void test_tiles_from_the_accumulator_are_the_films(void) {
  const char *settings[2] = {settings_independent, settings_sobol};
  for (int s = 0; s < 2; s++) {
    vf_film *film = stamped(settings[s]), *meta = stamped(settings[s]);
    vf_film_accum *a = NULL;
    CHECK_INT_EQ(vf_film_accum_create(W, H, &a), VF_OK);
    vf_film_accum_set_limit(a, (int64_t)1 << 34);
    float *cam = malloc(3 * sizeof(float) * W * H), *light = malloc(3 * sizeof(float) * W * H);
    for (uint64_t k = 4; k < 9; k++) {
      frame(k, 0, cam);
      frame(k, 1, light);
      for (size_t i = 0; i < 3 * (size_t)W * H; i++) /* no value beyond the file's range */
        if (fabsf(cam[i]) > 1e6f) cam[i] = 1e6f;
      CHECK_INT_EQ(vf_film_add_iteration(film, k, cam, light, NULL), VF_OK);
      CHECK_INT_EQ(vf_film_accum_add_iteration(a, meta, k, cam, light, NULL), VF_OK);
    }
    CHECK(vf_film_accum_spilled(a) > 0);
    recorded from_film = {0}, from_accum = {0};
    Vcmfarm__LeaseResult m1 = VCMFARM__LEASE_RESULT__INIT, m2 = VCMFARM__LEASE_RESULT__INIT;
    m1.begin = m2.begin = 4;
    CHECK_INT_EQ(vf_film_send_tiles(film, &m1, 1, record, &from_film), 1);
    CHECK_INT_EQ(vf_film_send_tiles_pending(meta, a, &m2, 1, record, &from_accum), 1);
    CHECK_INT_EQ(m1.end, m2.end);
    CHECK_INT_EQ(from_film.len, from_accum.len);
    CHECK(from_film.len > 0 && from_film.len == from_accum.len &&
          memcmp(from_film.bytes, from_accum.bytes, from_film.len) == 0);
    free(from_film.bytes);
    free(from_accum.bytes);
    free(cam);
    free(light);
    vf_film_accum_destroy(a);
    vf_film_destroy(meta);
    vf_film_destroy(film);
  }
}

static void test_sizes_must_agree(void) {
  vf_film_accum *a = NULL;
  CHECK_INT_EQ(vf_film_accum_create(0, 3, &a), VF_EINVAL);
  CHECK_INT_EQ(vf_film_accum_create(W, H, &a), VF_OK);
  vf_film *other = NULL;
  CHECK_INT_EQ(vf_film_create(W + 1, H, &other), VF_OK);
  float *rgb = calloc(3 * (size_t)(W + 1) * H, sizeof(float));
  CHECK_INT_EQ(vf_film_accum_add_iteration(a, other, 0, rgb, rgb, NULL), VF_EMISMATCH);
  CHECK_INT_EQ(vf_iterset_count(&other->iterations), 0);
  free(rgb);
  vf_film_destroy(other);
  vf_film_accum_destroy(a);
  vf_film_accum_destroy(NULL);
}

int main(void) {
  RUN(test_huge_emitters_leave_int64_exactly);
  RUN(test_lowered_limit_spills_ordinary_values_exactly);
  RUN(test_tiles_from_the_accumulator_are_the_films);
  RUN(test_sizes_must_agree);
  return check_finish();
}
