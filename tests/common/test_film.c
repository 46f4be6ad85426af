/* The film: accumulation arithmetic, exact merging, the file format round trip (version 2,
 * and version 1 read, merged with version 2), tiles on the wire, atomic writes, and reading
 * damaged files (corrupted copies of a film and the OpenEXR corpus). */
#include "check.h"
#include "exr_corpus.h"
#include "film_fixtures.h"
#include "common/error.h"
#include "common/exr_util.h"
#include "common/film.h"
#include "common/film_planes.h"
#include "common/film_wire.h"
#include "common/image.h"

#include <stdint.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

/* Films of iterations [begin, end) of the fixture's inputs (film_fixtures.h). */
static vf_film *film_with(int w, int h, uint64_t begin, uint64_t end) { return fixture_film(w, h, begin, end, 1); }

static double rel_diff(double a, double b) {
  double m = fmax(fabs(a), fabs(b));
  return m == 0 ? 0 : fabs(a - b) / m;
}

/* Every field and every pixel value, sums within rel_tol, iterations exact. */
static int films_equal(const vf_film *a, const vf_film *b, double rel_tol) {
  if (a->width != b->width || a->height != b->height || a->nonfinite_samples != b->nonfinite_samples ||
      a->biased_merges != b->biased_merges ||
      memcmp(a->scene_hash, b->scene_hash, 32) != 0 || strcmp(a->settings_text, b->settings_text) != 0 ||
      !vf_iterset_equal(&a->iterations, &b->iterations) || rel_diff(a->render_seconds, b->render_seconds) > rel_tol)
    return 0;
  size_t n = (size_t)a->width * (size_t)a->height;
  for (size_t i = 0; i < 3 * n; i++)
    if (rel_tol == 0 ? a->sum[i] != b->sum[i] || a->square_sum[i] != b->square_sum[i]
                     : rel_diff(vf_film_sum_at(a, i), vf_film_sum_at(b, i)) > rel_tol ||
                           rel_diff(vf_film_square_at(a, i), vf_film_square_at(b, i)) > rel_tol)
      return 0;
  return 1;
}

static void test_add_iteration_and_mean_arithmetic(void) {
  vf_film *f = NULL;
  CHECK_INT_EQ(vf_film_create(2, 1, &f), VF_OK);
  float cam1[6] = {1, 2, 3, 4, 5, 6}, light1[6] = {0.5f, 0, 0, 0, 0, 1};
  float cam2[6] = {3, 2, 1, 0, 0, 0}, light2[6] = {0.5f, 0, 0, 0, 0, 0};
  CHECK_INT_EQ(vf_film_add_iteration(f, 7, cam1, light1, NULL), VF_OK);
  CHECK_INT_EQ(vf_film_add_iteration(f, 8, cam2, light2, NULL), VF_OK);
  CHECK_INT_EQ(vf_iterset_count(&f->iterations), 2); /* every pixel's count, and the light frames */
  CHECK(vf_iterset_contains(&f->iterations, 7) && vf_iterset_contains(&f->iterations, 8));
  CHECK_NEAR(vf_film_sum_at(f, 0), 4 + 1, 0); /* camera 1 + 3, light 0.5 + 0.5 */
  CHECK_NEAR(vf_film_sum_at(f, 5), 6 + 1, 0);
  /* (1 + 0.5)^2 + (3 + 0.5)^2 and (6 + 1)^2 + 0^2 */
  CHECK_NEAR(vf_film_square_at(f, 0), 2.25 + 12.25, 0);
  CHECK_NEAR(vf_film_square_at(f, 5), 49, 0);
  float mean[6];
  vf_film_mean(f, mean);
  CHECK_NEAR(mean[0], 4.0 / 2 + 1.0 / 2, 1e-6);
  CHECK_NEAR(mean[1], 2, 1e-6);
  CHECK_NEAR(mean[5], 6.0 / 2 + 1.0 / 2, 1e-6);
  CHECK_INT_EQ(vf_film_validate(f, "arith"), VF_OK);

  vf_film *empty = NULL;
  CHECK_INT_EQ(vf_film_create(2, 1, &empty), VF_OK);
  vf_film_mean(empty, mean);
  for (int i = 0; i < 6; i++) CHECK_NEAR(mean[i], 0, 0);
  vf_film_destroy(empty);
  vf_film_destroy(f);
  vf_film_destroy(NULL);
}

/* Emptied films, small (malloc'ed sums) and large (mapped sums, whose pages go back to the
 * kernel): every sum reads zero, and the next iteration adds to zeros exactly as to a new
 * film. */
static void test_clear_pixels_empties_small_and_large_films(void) {
  const int sizes[2][2] = {{3, 2}, {512, 512}};
  for (int s = 0; s < 2; s++) {
    int w = sizes[s][0], h = sizes[s][1];
    size_t n = 3 * (size_t)w * (size_t)h;
    float *cam = malloc(n * sizeof *cam), *light = malloc(n * sizeof *light);
    for (size_t i = 0; i < n; i++) cam[i] = (float)(i % 13) + 0.25f, light[i] = (float)(i % 7);
    vf_film *f = NULL, *fresh = NULL;
    CHECK_INT_EQ(vf_film_create(w, h, &f), VF_OK);
    CHECK_INT_EQ(vf_film_create(w, h, &fresh), VF_OK);
    CHECK_INT_EQ(vf_film_add_iteration(f, 0, light, cam, NULL), VF_OK);
    vf_film_clear_pixels(f);
    size_t nonzero = 0;
    for (size_t i = 0; i < n; i++) nonzero += f->sum[i] != 0 || f->square_sum[i] != 0;
    CHECK_INT_EQ(nonzero, 0);
    CHECK_INT_EQ(vf_film_add_iteration(f, 1, cam, light, NULL), VF_OK);
    CHECK_INT_EQ(vf_film_add_iteration(fresh, 1, cam, light, NULL), VF_OK);
    CHECK(!memcmp(f->sum, fresh->sum, n * sizeof *f->sum) && !memcmp(f->square_sum, fresh->square_sum, n * sizeof *f->sum));
    vf_film_destroy(fresh);
    vf_film_destroy(f);
    free(cam);
    free(light);
  }
}

static void test_create_refuses_bad_sizes(void) {
  vf_film *f = (vf_film *)0x1;
  CHECK_INT_EQ(vf_film_create(0, 10, &f), VF_EINVAL);
  CHECK_INT_EQ(vf_film_create(10, -1, &f), VF_EINVAL);
  CHECK_INT_EQ(vf_film_create(65536, 65536, &f), VF_EINVAL);
  CHECK(f == (vf_film *)0x1); /* out-parameter untouched */
}

static void test_nonfinite_samples_count_as_zero(void) {
  vf_film *f = NULL;
  CHECK_INT_EQ(vf_film_create(2, 1, &f), VF_OK);
  float cam[6] = {NAN, 1, 1, 2, 2, 2}, light[6] = {1, 1, 1, INFINITY, 0, 0};
  CHECK_INT_EQ(vf_film_add_iteration(f, 0, cam, light, NULL), VF_OK);
  CHECK_INT_EQ(f->nonfinite_samples, 2);
  CHECK_NEAR(vf_film_sum_at(f, 0), 0 + 1, 0); /* the whole camera sample of pixel 0 is zero, its light 1 */
  CHECK_NEAR(vf_film_sum_at(f, 1), 0 + 1, 0);
  CHECK_INT_EQ(vf_iterset_count(&f->iterations), 1); /* but it still counts */
  CHECK_NEAR(vf_film_sum_at(f, 3), 2 + 0, 0);  /* light sample of pixel 1 is zero */
  CHECK_NEAR(vf_film_square_at(f, 0), 1, 0);
  CHECK_NEAR(vf_film_square_at(f, 3), 4, 0);
  CHECK_INT_EQ(vf_film_validate(f, "nonfinite"), VF_OK);
  vf_film_destroy(f);
}

static void test_repeated_iteration_is_refused_unchanged(void) {
  vf_film *f = film_with(5, 4, 0, 3), *before = NULL;
  CHECK_INT_EQ(vf_film_clone(f, &before), VF_OK);
  float cam[60] = {0}, light[60] = {0};
  cam[0] = 100;
  CHECK_INT_EQ(vf_film_add_iteration(f, 1, cam, light, NULL), VF_EOVERLAP);
  CHECK(films_equal(f, before, 0));
  vf_film_destroy(before);
  vf_film_destroy(f);
}

static void test_write_read_round_trip(void) {
  /* 100x70: partial tiles on both edges; iterations with gaps make a multi-range set */
  vf_film *f = film_with(100, 70, 0, 3), *back = NULL;
  float cam[3 * 100 * 70], light[3 * 100 * 70];
  fixture_iteration_inputs(100, 70, 1000, cam, light);
  cam[5] = NAN;
  CHECK_INT_EQ(vf_film_add_iteration(f, 1000, cam, light, NULL), VF_OK);
  f->sum[7] = vf_fixed_from_double(123456789.123456789, VF_FILM_SUM_BITS); /* more than a float's precision */
  f->sum[8] = -1;                                                          /* the smallest unit */
  f->render_seconds = 12345.678;
  f->biased_merges = 12345678901234567890ULL; /* beyond int64: all 64 bits in the text */
  const char *path = fixture_path("round.film.exr");
  CHECK_INT_EQ(vf_film_write(f, path), VF_OK);
  CHECK_INT_EQ(vf_film_read(path, &back), VF_OK);
  if (back) {
    CHECK(films_equal(f, back, 0)); /* exact: version 4 keeps every bit of the sums */
    CHECK(back->sum[8] == -1);
    CHECK_INT_EQ(back->nonfinite_samples, 1);
    CHECK(back->biased_merges == 12345678901234567890ULL);
    CHECK_INT_EQ(vf_iterset_count(&back->iterations), 4);
    CHECK_NEAR(vf_film_sum_at(back, 7), 123456789.123456789, 1e-6);
    CHECK_NEAR(back->render_seconds, 12345.678, 0);
    char text[64];
    vf_iterset_format(&back->iterations, text, sizeof text);
    CHECK_STR_CONTAINS(text, "[0,3) [1000,1001)");
  }
  /* the layout docs/FILM.md promises: one tiled part, 64x64 tiles, ZIP, 12 FLOAT channels in
   * the order of vf_film_v2_channels (that of a tile on the wire) */
  exr_context_t ctx = NULL;
  CHECK_INT_EQ(exr_start_read(&ctx, path, NULL), EXR_ERR_SUCCESS);
  if (ctx) {
    int parts = 0;
    exr_storage_t storage = EXR_STORAGE_SCANLINE;
    exr_compression_t compression = EXR_COMPRESSION_NONE;
    uint32_t tx = 0, ty = 0;
    exr_tile_level_mode_t level;
    exr_tile_round_mode_t round;
    const exr_attr_chlist_t *channels = NULL;
    exr_get_count(ctx, &parts);
    exr_get_storage(ctx, 0, &storage);
    exr_get_compression(ctx, 0, &compression);
    exr_get_tile_descriptor(ctx, 0, &tx, &ty, &level, &round);
    exr_get_channels(ctx, 0, &channels);
    CHECK_INT_EQ(parts, 1);
    CHECK_INT_EQ(storage, EXR_STORAGE_TILED);
    CHECK_INT_EQ(compression, EXR_COMPRESSION_ZIP);
    CHECK_INT_EQ(tx, VF_FILM_TILE);
    CHECK_INT_EQ(ty, VF_FILM_TILE);
    CHECK(channels != NULL);
    if (channels) {
      CHECK_INT_EQ(channels->num_channels, VF_FILM_V4_CHANNELS);
      for (int i = 0; i < channels->num_channels && i < VF_FILM_V4_CHANNELS; i++) {
        CHECK_INT_EQ(channels->entries[i].pixel_type, (VF_FILM_V4_UINT_MASK >> i & 1) ? EXR_PIXEL_UINT : EXR_PIXEL_FLOAT);
        if (strcmp(channels->entries[i].name.str, vf_film_v4_channels[i]) != 0)
          CHECK_FAIL_("channel %d is %s, expected %s", i, channels->entries[i].name.str, vf_film_v4_channels[i]);
      }
    }
    exr_finish(&ctx);
  }
  /* R, G, B hold the mean, for any viewer */
  vf_image img = {0};
  CHECK_INT_EQ(vf_image_read_exr(path, &img), VF_OK);
  float *mean = malloc(sizeof(float) * 3 * 100 * 70);
  vf_film_mean(f, mean);
  if (img.rgb) CHECK(memcmp(img.rgb, mean, sizeof(float) * 3 * 100 * 70) == 0);
  free(mean);
  vf_image_destroy(&img);
  vf_film_destroy(back);
  vf_film_destroy(f);
}

static void test_long_iteration_set_round_trips(void) {
  vf_film *f = NULL, *back = NULL;
  CHECK_INT_EQ(vf_film_create(3, 2, &f), VF_OK);
  float cam[18] = {1, 2, 3}, light[18] = {0};
  /* 3000 separate ranges with 13-digit indices: ~90 kB of text */
  for (uint64_t i = 0; i < 3000; i++) CHECK_INT_EQ(vf_film_add_iteration(f, 1000000000000ULL + 2 * i, cam, light, NULL), VF_OK);
  const char *path = fixture_path("long.film.exr");
  CHECK_INT_EQ(vf_film_write(f, path), VF_OK);
  CHECK_INT_EQ(vf_film_read(path, &back), VF_OK);
  if (back) {
    CHECK_INT_EQ(back->iterations.count, 3000);
    CHECK(films_equal(f, back, 1e-14));
  }
  vf_film_destroy(back);
  vf_film_destroy(f);
}

static void test_merge_equals_direct_render_and_commutes(void) {
  vf_film *a = film_with(13, 9, 0, 4), *b = film_with(13, 9, 4, 8), *all = film_with(13, 9, 0, 8), *b_first = NULL;
  a->biased_merges = 7; /* upg's merges as vcm merges, counted per iteration: they add up */
  b->biased_merges = 35;
  all->biased_merges = 42;
  CHECK_INT_EQ(vf_film_clone(b, &b_first), VF_OK);
  CHECK_INT_EQ(vf_film_merge(b_first, a), VF_OK);
  CHECK_INT_EQ(vf_film_merge(a, b), VF_OK);
  CHECK(films_equal(a, all, 0));     /* same samples, another order: the same film exactly */
  CHECK(films_equal(a, b_first, 0)); /* x + y == y + x exactly */
  CHECK_INT_EQ(a->iterations.count, 1);
  CHECK_INT_EQ(vf_iterset_count(&a->iterations), 8);
  CHECK_NEAR(a->render_seconds, 10.0, 1e-12);
  CHECK_INT_EQ(a->biased_merges, 42);
  CHECK_INT_EQ(b_first->biased_merges, 42);
  vf_film_destroy(b_first);
  vf_film_destroy(all);
  vf_film_destroy(b);
  vf_film_destroy(a);
}

/* A film of the iterations [begin, end) of inputs spanning eight decades (where doubles
 * round differently in every order), with settings of the given sampler. */
static vf_film *exact_part(uint64_t begin, uint64_t end, const char *sampler_suffix) {
  enum { W = 16, H = 8 };
  vf_film *film = NULL;
  if (vf_film_create(W, H, &film) != VF_OK) return NULL;
  memset(film->scene_hash, 0xcd, sizeof film->scene_hash);
  snprintf(film->settings_text, sizeof film->settings_text,
           "algorithm=vcm max_path_length=10 radius_factor=0.003 alpha=0.75 seed=3 resolution=%dx%d%s", W, H,
           sampler_suffix);
  float cam[3 * W * H], light[3 * W * H];
  for (uint64_t i = begin; i < end; i++) {
    uint64_t s = 0x2545f4914f6cdd1dULL ^ (i * 0x9e3779b97f4a7c15ULL + 7);
    for (int k = 0; k < 3 * W * H; k++) {
      cam[k] = (float)(fixture_uniform(&s) * pow(10.0, 8 * fixture_uniform(&s) - 5));
      light[k] = (float)(fixture_uniform(&s) * pow(10.0, 6 * fixture_uniform(&s) - 4));
    }
    if (vf_film_add_iteration(film, i, cam, light, NULL) != VF_OK) CHECK_FAIL_("adding iteration %d", (int)i);
  }
  return film;
}

static int same_sums(const vf_film *a, const vf_film *b) {
  size_t n = 3 * (size_t)a->width * (size_t)a->height;
  return a->width == b->width && a->height == b->height && memcmp(a->sum, b->sum, n * sizeof *a->sum) == 0 &&
         memcmp(a->square_sum, b->square_sum, n * sizeof *a->sum) == 0 &&
         vf_iterset_equal(&a->iterations, &b->iterations);
}

/* Issue 41: merging is exact and associative. [0, 40) cut at random into parts, each part
 * written to a file and read back (a checkpoint, a result on the wire), merged in a random
 * order and grouping (a random tree): always the film of the 40 iterations added one by
 * one, bit for bit, for films of squares and of the sobol sampler's replicate sums. With
 * doubles, the groupings differed in the last bits. */
static void test_merge_is_exact_in_any_order_and_grouping(void) {
  static const char *const suffixes[] = {"", " sampler=sobol"};
  uint64_t rng = 41;
  for (int variant = 0; variant < 2; variant++) {
    vf_film *whole = exact_part(0, 40, suffixes[variant]);
    for (int trial = 0; trial < 12 && whole; trial++) {
      enum { MAX_PARTS = 40 };
      vf_film *parts[MAX_PARTS];
      int n = 0;
      for (uint64_t begin = 0; begin < 40;) {
        uint64_t end = begin + 1 + fixture_xorshift(&rng) % 9;
        if (end > 40) end = 40;
        vf_film *part = exact_part(begin, end, suffixes[variant]), *back = NULL;
        const char *path = fixture_path("exact_part.film.exr");
        CHECK_INT_EQ(vf_film_write(part, path), VF_OK);
        CHECK_INT_EQ(vf_film_read(path, &back), VF_OK);
        if (back) CHECK(same_sums(back, part)); /* the file keeps every bit */
        vf_film_destroy(part);
        parts[n++] = back;
        begin = end;
      }
      /* a random tree: merge a random pair of the remaining films until one is left */
      while (n > 1) {
        int i = (int)(fixture_xorshift(&rng) % (uint64_t)n), j = (int)(fixture_xorshift(&rng) % (uint64_t)(n - 1));
        if (j >= i) j++;
        if (parts[i] && parts[j]) CHECK_INT_EQ(vf_film_merge(parts[i], parts[j]), VF_OK);
        vf_film_destroy(parts[j]);
        parts[j] = parts[--n];
      }
      if (parts[0] && !same_sums(parts[0], whole))
        CHECK_FAIL_("variant %d, trial %d: merged parts differ from the whole film", variant, trial);
      if (parts[0]) CHECK(vf_film_estimate_rmse(parts[0]) == vf_film_estimate_rmse(whole));
      vf_film_destroy(parts[0]);
    }
    vf_film_destroy(whole);
  }
}

static void test_merge_refusals_leave_dst_unchanged(void) {
  vf_film *dst = film_with(8, 8, 0, 4), *before = NULL;
  dst->biased_merges = 2;
  CHECK_INT_EQ(vf_film_clone(dst, &before), VF_OK);

  vf_film *other_size = film_with(8, 9, 10, 12);
  CHECK_INT_EQ(vf_film_merge(dst, other_size), VF_EMISMATCH);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EMISMATCH), "size");

  vf_film *other_scene = film_with(8, 8, 10, 12);
  other_scene->scene_hash[0] ^= 1;
  CHECK_INT_EQ(vf_film_merge(dst, other_scene), VF_EMISMATCH);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EMISMATCH), "scene");

  vf_film *other_settings = film_with(8, 8, 10, 12);
  other_settings->settings_text[0] = 'X';
  CHECK_INT_EQ(vf_film_merge(dst, other_settings), VF_EMISMATCH);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EMISMATCH), "settings");

  vf_film *overlapping = film_with(8, 8, 3, 6);
  CHECK_INT_EQ(vf_film_merge(dst, overlapping), VF_EOVERLAP);

  /* a count that would wrap (a forged film) would make a biased film look unbiased */
  vf_film *wrapping = film_with(8, 8, 10, 12);
  wrapping->biased_merges = UINT64_MAX - 1;
  CHECK_INT_EQ(vf_film_merge(dst, wrapping), VF_EFILM);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EFILM), "biased merges");

  CHECK(films_equal(dst, before, 0));
  wrapping->biased_merges = UINT64_MAX - 2; /* a sum of exactly UINT64_MAX is still a count */
  CHECK_INT_EQ(vf_film_merge(dst, wrapping), VF_OK);
  CHECK(dst->biased_merges == UINT64_MAX);
  vf_film_destroy(wrapping);
  vf_film_destroy(overlapping);
  vf_film_destroy(other_settings);
  vf_film_destroy(other_scene);
  vf_film_destroy(other_size);
  vf_film_destroy(before);
  vf_film_destroy(dst);
}

static void test_validate_catches_broken_invariants(void) {
  vf_film *good = film_with(4, 4, 0, 2), *f = NULL;
  CHECK_INT_EQ(vf_film_validate(good, "good"), VF_OK);
  struct {
    const char *what;
    int field;
    double value;
  } cases[] = {{"negative square", 1, -1}, {"sum beyond the file's range", 0, 0x1p60}};
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    CHECK_INT_EQ(vf_film_clone(good, &f), VF_OK);
    vf_fixed *target = cases[i].field == 0 ? f->sum : f->square_sum;
    target[5] = vf_fixed_from_double(cases[i].value, VF_FILM_SUM_BITS);
    if (cases[i].value > 0) { /* valid in memory, refused by the file */
      CHECK_INT_EQ(vf_film_validate(f, "big"), VF_OK);
      CHECK_INT_EQ(vf_film_write(f, fixture_path("invalid.film.exr")), VF_EFILM);
      CHECK_STR_CONTAINS(vf_error_detail(VF_EFILM), "beyond the file format's range");
      vf_film_destroy(f);
      continue;
    }
    if (vf_film_validate(f, "bad") != VF_EFILM) CHECK_FAIL_("%s passed validation", cases[i].what);
    if (vf_film_write(f, fixture_path("invalid.film.exr")) == VF_OK) CHECK_FAIL_("%s was written", cases[i].what);
    vf_film_destroy(f);
  }
  /* each iteration refuses at most one camera and one light sample per pixel */
  CHECK_INT_EQ(vf_film_clone(good, &f), VF_OK);
  f->nonfinite_samples = 2 * 16 * 2 + 1;
  CHECK_INT_EQ(vf_film_validate(f, "nonfinite"), VF_EFILM);
  vf_film_destroy(f);
  /* N = 0 implies zero sums: a film of no iteration holding sums is refused */
  vf_film *empty = NULL;
  CHECK_INT_EQ(vf_film_create(4, 4, &empty), VF_OK);
  CHECK_INT_EQ(vf_film_validate(empty, "empty"), VF_OK);
  empty->sum[7] = 1;
  CHECK_INT_EQ(vf_film_validate(empty, "empty"), VF_EFILM);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EFILM), "holds sums but the film has no iterations");
  vf_film_destroy(empty);
  vf_film_destroy(good);
}

/* In the child of fixture_run_with_file_limit: 0 when writing keep.film.exr fails with VF_EIO. */
static int write_fails_with_eio(void *film) {
  return vf_film_write(film, fixture_path("keep.film.exr")) == VF_EIO ? 0 : 1;
}

static void test_write_is_atomic(void) {
  vf_film *f = film_with(130, 70, 0, 2);
  const char *path = fixture_path("keep.film.exr"), *dir_path = fixture_path("film_dir");
  const char *ro_dir = fixture_path("read_only"), *ro_path = fixture_path("read_only/keep.film.exr");
  mkdir(dir_path, 0755);
  mkdir(ro_dir, 0755);
  fixture_spill_text(path, "old content");
  fixture_spill_text(ro_path, "old content");

  /* the write fails half-way (file size limit): old content stays, no temporary file */
  int status = fixture_run_with_file_limit(8192, write_fails_with_eio, f);
  CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  CHECK(fixture_file_holds_text(path, "old content"));

  /* the target is a directory */
  CHECK_INT_EQ(vf_film_write(f, dir_path), VF_EIO);
  struct stat st;
  CHECK(stat(dir_path, &st) == 0 && S_ISDIR(st.st_mode));

  /* the directory is read-only (root ignores permissions, so only checked otherwise) */
  chmod(ro_dir, 0555);
  if (geteuid() != 0) CHECK_INT_EQ(vf_film_write(f, ro_path), VF_EIO);
  chmod(ro_dir, 0755);
  CHECK(geteuid() == 0 || fixture_file_holds_text(ro_path, "old content"));
  CHECK(fixture_no_temp_files());

  CHECK_INT_EQ(vf_film_write(f, path), VF_OK);
  CHECK(!fixture_file_holds_text(path, "old content"));
  vf_film_destroy(f);
}

/* Replaces the value of a string attribute in place (same length) in the file's header. */
static int patch_string_attribute(unsigned char *buf, size_t size, const char *name, const char *value) {
  size_t nl = strlen(name) + 1; /* name and its NUL, then "string\0", int32 size, text */
  for (size_t i = 0; i + nl + 11 < size; i++) {
    if (memcmp(buf + i, name, nl) != 0 || memcmp(buf + i + nl, "string", 7) != 0) continue;
    unsigned char *len = buf + i + nl + 7;
    int32_t n = (int32_t)(len[0] | len[1] << 8 | len[2] << 16 | (uint32_t)len[3] << 24);
    if ((size_t)n != strlen(value) || i + nl + 11 + (size_t)n > size) return 0;
    memcpy(len + 4, value, (size_t)n);
    return 1;
  }
  return 0;
}

static void expect_read_refused(const char *path, const char *needle) {
  vf_film *f = NULL;
  int err = vf_film_read(path, &f);
  if (err != VF_EFILM && err != VF_EEXR) CHECK_FAIL_("%s was not refused (%d)", needle, err);
  else CHECK_STR_CONTAINS(vf_error_detail(err), needle);
  CHECK(f == NULL);
}

static void test_read_refuses_inconsistent_films(void) {
  vf_film *f = film_with(20, 10, 0, 3);
  const char *good = fixture_path("good.film.exr"), *bad = fixture_path("bad.film.exr");
  const char *good_v1 = fixture_path("good_v1.film.exr");
  CHECK_INT_EQ(vf_film_write(f, good), VF_OK);
  CHECK_INT_EQ(vf_film_write_version(f, good_v1, 1), VF_OK);
  size_t size = 0, size_v1 = 0;
  unsigned char *bytes = fixture_slurp(good, &size), *copy = malloc(size);
  unsigned char *bytes_v1 = fixture_slurp(good_v1, &size_v1), *copy_v1 = malloc(size_v1);

  static const struct {
    int version;
    const char *attribute, *value, *detail;
  } patches[] = {
      {1, "vcmfarm:light_frames", "4", "light frames"}, /* version 2 derives them from the iterations */
      {1, "vcmfarm:light_frames", "x", "vcmfarm:light_frames"},
      {1, "vcmfarm:iterations", "[0,3(", "vcmfarm:iterations"},
      {2, "vcmfarm:iterations", "[0,3(", "vcmfarm:iterations"},
      {2, "vcmfarm:iterations", "[3,0)", "vcmfarm:iterations"},
      {2, "vcmfarm:nonfinite_samples", "-", "vcmfarm:nonfinite_samples"},
      {2, "vcmfarm:biased_merges", "-", "vcmfarm:biased_merges"},
  };
  for (size_t i = 0; i < sizeof patches / sizeof patches[0]; i++) {
    int v1 = patches[i].version == 1;
    memcpy(v1 ? copy_v1 : copy, v1 ? bytes_v1 : bytes, v1 ? size_v1 : size);
    CHECK(patch_string_attribute(v1 ? copy_v1 : copy, v1 ? size_v1 : size, patches[i].attribute, patches[i].value));
    fixture_spill(bad, v1 ? copy_v1 : copy, v1 ? size_v1 : size);
    expect_read_refused(bad, patches[i].detail);
  }
  free(copy_v1);
  free(bytes_v1);
  /* the scene hash with a non-hex digit */
  char hex[65];
  memset(hex, 'a', 64);
  hex[64] = '\0';
  hex[10] = 'g';
  memcpy(copy, bytes, size);
  CHECK(patch_string_attribute(copy, size, "vcmfarm:scene_hash", hex));
  fixture_spill(bad, copy, size);
  expect_read_refused(bad, "vcmfarm:scene_hash");

  /* a plain image is not a film */
  vf_image img = {0};
  vf_image_alloc(&img, 20, 10);
  vf_image_write_exr(bad, &img);
  vf_image_destroy(&img);
  expect_read_refused(bad, "missing attribute vcmfarm:format_version");

  free(copy);
  free(bytes);
  vf_film_destroy(f);
}

/* Fills every plane of channel names[k] with value[k] (user: a fake_fill). */
typedef struct {
  int n;
  const char *const *names;
  double (*value)(const char *channel, int x, int y);
} fake_fill;

static void fill_fake(void *user, int x0, int y0, int w, int h, float *const *planes) {
  const fake_fill *f = user;
  for (int k = 0; k < f->n; k++)
    for (int y = 0; y < h; y++)
      for (int x = 0; x < w; x++) planes[k][y * w + x] = f->value ? (float)f->value(f->names[k], x0 + x, y0 + y) : 0.0f;
}

/* A 20x10 film-like file of `iterations` built with the private helpers, to reach states
 * vf_film_write refuses and to write version 1 as older builds did: channel values from
 * value (NULL: zeros), light_frames as in version 1. */
static const char *fake_scene_name; /* when set, write_fake_film writes it as vcmfarm:scene */

static int write_fake_film(const char *path, int version, const char *const *names, int n, const char *iterations,
                           double (*value)(const char *, int, int)) {
  vf_exr_out out;
  int err = vf_exr_create(path, 20, 10, VF_FILM_TILE, VF_EXR_NONE, n, names, &out);
  if (err != VF_OK) return err;
  exr_attr_set_int(out.ctx, 0, "vcmfarm:format_version", version);
  exr_attr_set_string(out.ctx, 0, "vcmfarm:scene_hash", "abababababababababababababababababababababababababababababababab");
  exr_attr_set_string(out.ctx, 0, "vcmfarm:settings", "");
  exr_attr_set_string(out.ctx, 0, "vcmfarm:iterations", iterations);
  exr_attr_set_string(out.ctx, 0, "vcmfarm:light_frames", iterations[0] ? "1" : "0");
  exr_attr_set_double(out.ctx, 0, "vcmfarm:render_seconds", 0);
  exr_attr_set_string(out.ctx, 0, "vcmfarm:nonfinite_samples", "0");
  if (fake_scene_name) exr_attr_set_string(out.ctx, 0, "vcmfarm:scene", fake_scene_name);
  fake_fill fill = {n, names, value};
  if ((err = vf_exr_write_pixels(&out, n, names, fill_fake, &fill)) != VF_OK) {
    vf_exr_abort(&out);
    return err;
  }
  return vf_exr_commit(&out);
}

static double one_everywhere(const char *channel, int x, int y) {
  (void)channel, (void)x, (void)y;
  return 1.0;
}

static void test_read_refuses_missing_channel_and_unknown_version(void) {
  const char *const *v1 = vf_film_v1_channels + 3; /* the 20 accumulation channels */
  const char *path = fixture_path("fake.film.exr");
  vf_film *f = NULL;
  CHECK_INT_EQ(write_fake_film(path, 1, v1, VF_FILM_V1_ACCUM, "", NULL), VF_OK);
  CHECK_INT_EQ(vf_film_read(path, &f), VF_OK); /* the complete fake is a valid empty film */
  vf_film_destroy(f);
  CHECK_INT_EQ(write_fake_film(path, 1, v1, VF_FILM_V1_ACCUM - 1, "", NULL), VF_OK);
  expect_read_refused(path, "missing channel square.lo.B");
  CHECK_INT_EQ(write_fake_film(path, 2, vf_film_v2_channels, VF_FILM_V2_CHANNELS, "", NULL), VF_OK);
  CHECK_INT_EQ(vf_film_read(path, &f), VF_OK);
  vf_film_destroy(f);
  CHECK_INT_EQ(write_fake_film(path, 2, vf_film_v2_channels, VF_FILM_V2_CHANNELS - 1, "", NULL), VF_OK);
  expect_read_refused(path, "missing channel sum.lo.R");
  CHECK_INT_EQ(write_fake_film(path, 2, v1, VF_FILM_V1_ACCUM, "", NULL), VF_OK); /* version 1's channels */
  expect_read_refused(path, "missing channel B");
  CHECK_INT_EQ(write_fake_film(path, VF_FILM_FORMAT_VERSION + 1, vf_film_v2_channels, VF_FILM_V2_CHANNELS, "", NULL),
               VF_OK);
  char unknown[64];
  snprintf(unknown, sizeof unknown, "unknown film format version %d", VF_FILM_FORMAT_VERSION + 1);
  expect_read_refused(path, unknown);
  /* N = 0 implies zero sums: a film of no iteration holding sums is refused */
  CHECK_INT_EQ(write_fake_film(path, 2, vf_film_v2_channels, VF_FILM_V2_CHANNELS, "", one_everywhere), VF_OK);
  expect_read_refused(path, "holds sums but the film has no iterations");
  /* version 3 needs its checksum: a fake of version 3 without one is damaged */
  CHECK_INT_EQ(write_fake_film(path, 3, vf_film_v2_channels, VF_FILM_V2_CHANNELS, "", NULL), VF_OK);
  expect_read_refused(path, "damaged: no vcmfarm:checksum attribute");
}

/* Text attributes must be UTF-8 (`info --json` prints them as JSON strings): multi-byte
 * names read, malformed ones (overlong, surrogate, cut short, beyond U+10FFFF, a stray
 * continuation byte) are refused naming the attribute. */
static void test_attributes_must_be_utf8(void) {
  const char *path = fixture_path("utf8.film.exr");
  static const char *const good[] = {"plain", "Caf\xc3\xa9 \xe2\x98\x95 \xf0\x9d\x84\x9e"};
  static const char *const bad[] = {"\xc0\xaf", "\xed\xa0\x80", "ab\xe2\x82", "\xf4\x90\x80\x80", "\x80x", "\xff"};
  for (size_t i = 0; i < sizeof good / sizeof *good; i++) {
    fake_scene_name = good[i];
    CHECK_INT_EQ(write_fake_film(path, 2, vf_film_v2_channels, VF_FILM_V2_CHANNELS, "", NULL), VF_OK);
    vf_film *f = NULL;
    CHECK_INT_EQ(vf_film_read(path, &f), VF_OK);
    if (f) CHECK(strcmp(f->scene_name, good[i]) == 0);
    vf_film_destroy(f);
  }
  for (size_t i = 0; i < sizeof bad / sizeof *bad; i++) {
    fake_scene_name = bad[i];
    CHECK_INT_EQ(write_fake_film(path, 2, vf_film_v2_channels, VF_FILM_V2_CHANNELS, "", NULL), VF_OK);
    expect_read_refused(path, "attribute vcmfarm:scene is not valid UTF-8");
  }
  fake_scene_name = NULL;
}

/* A film written before vcmfarm:biased_merges existed (write_fake_film writes none) reads
 * as 0 of them, merges with a film that counts some, and is written with the sum. */
static void test_a_film_without_biased_merges_reads_zero_and_merges(void) {
  const char *path = fixture_path("before_biased.film.exr");
  CHECK_INT_EQ(write_fake_film(path, 2, vf_film_v2_channels, VF_FILM_V2_CHANNELS, "[0,1)", NULL), VF_OK);
  vf_film *old = NULL, *counted = NULL, *back = NULL;
  CHECK_INT_EQ(vf_film_read(path, &old), VF_OK);
  CHECK_INT_EQ(vf_film_create(20, 10, &counted), VF_OK);
  if (old && counted) {
    CHECK_INT_EQ(old->biased_merges, 0);
    memcpy(counted->scene_hash, old->scene_hash, sizeof counted->scene_hash);
    memcpy(counted->settings_text, old->settings_text, sizeof counted->settings_text);
    float zero[3 * 20 * 10] = {0};
    CHECK_INT_EQ(vf_film_add_iteration(counted, 1, zero, zero, NULL), VF_OK);
    counted->biased_merges = 9;
    CHECK_INT_EQ(vf_film_merge(old, counted), VF_OK);
    CHECK_INT_EQ(old->biased_merges, 9);
    CHECK_INT_EQ(vf_film_write(old, path), VF_OK);
    CHECK_INT_EQ(vf_film_read(path, &back), VF_OK);
    if (back) CHECK_INT_EQ(back->biased_merges, 9);
  }
  vf_film_destroy(back);
  vf_film_destroy(counted);
  vf_film_destroy(old);
}

/* A version-1 film of one iteration as older builds wrote it: camera 2 + light 0.25 in
 * every channel (exact in floats, lo parts 0), squares 5, counts 1; or count 0 at (13, 7). */
static double v1_value(const char *channel, int x, int y) {
  (void)x, (void)y;
  if (strstr(channel, ".lo")) return 0.0;
  if (strncmp(channel, "camera", 6) == 0) return 2.0;
  if (strncmp(channel, "light", 5) == 0) return 0.25;
  if (strncmp(channel, "square", 6) == 0) return 5.0;
  return 1.0; /* count.hi */
}

static double v1_value_odd_count(const char *channel, int x, int y) {
  return strcmp(channel, "count.hi") == 0 && x == 13 && y == 7 ? 0.0 : v1_value(channel, x, y);
}

static void test_version_1_sums_camera_and_light_and_needs_every_count(void) {
  const char *path = fixture_path("old.film.exr");
  vf_film *f = NULL;
  CHECK_INT_EQ(write_fake_film(path, 1, vf_film_v1_channels + 3, VF_FILM_V1_ACCUM, "[0,1)", v1_value), VF_OK);
  CHECK_INT_EQ(vf_film_read(path, &f), VF_OK);
  if (f) {
    CHECK_NEAR(vf_film_sum_at(f, 0), 2.25, 0);
    CHECK_NEAR(vf_film_sum_at(f, 3 * 199 + 2), 2.25, 0);
    CHECK_NEAR(vf_film_square_at(f, 100), 5.0, 0);
    float mean[3];
    vf_film_pixel_mean(f, 57, mean);
    CHECK_NEAR(mean[1], 2.25, 0);
    int version = 0;
    CHECK_INT_EQ(vf_film_read_version(path, &version), VF_OK);
    CHECK_INT_EQ(version, 1);
  }
  vf_film_destroy(f);
  /* a pixel with another count than the film's iterations: refused, naming file and pixel */
  CHECK_INT_EQ(write_fake_film(path, 1, vf_film_v1_channels + 3, VF_FILM_V1_ACCUM, "[0,1)", v1_value_odd_count), VF_OK);
  expect_read_refused(path, "pixel (13, 7): camera count 0 is not the film's 1 iterations");
  CHECK_STR_CONTAINS(vf_error_detail(VF_EFILM), path);
}

static void test_version_1_and_2_films_read_merge_with_version_3(void) {
  vf_film *early = film_with(70, 65, 0, 3), *late = film_with(70, 65, 3, 7), *all = film_with(70, 65, 0, 7);
  const char *old = fixture_path("early_v1.film.exr"), *now = fixture_path("late.film.exr");
  const char *v2 = fixture_path("late_v2.film.exr");
  CHECK_INT_EQ(vf_film_write_version(early, old, 1), VF_OK);
  CHECK_INT_EQ(vf_film_write(late, now), VF_OK);
  CHECK_INT_EQ(vf_film_write_version(late, v2, 2), VF_OK);
  int version = 0;
  CHECK_INT_EQ(vf_film_read_version(old, &version), VF_OK);
  CHECK_INT_EQ(version, 1);
  CHECK_INT_EQ(vf_film_read_version(now, &version), VF_OK);
  CHECK_INT_EQ(version, VF_FILM_FORMAT_VERSION);
  CHECK_INT_EQ(vf_film_read_version(v2, &version), VF_OK);
  CHECK_INT_EQ(version, 2);
  vf_film *from_v2 = NULL; /* version 2, without a checksum, still reads: the same film */
  CHECK_INT_EQ(vf_film_read(v2, &from_v2), VF_OK);
  if (from_v2) CHECK(films_equal(from_v2, late, 1e-14));
  vf_film_destroy(from_v2);
  vf_film *a = NULL, *b = NULL, *b_first = NULL;
  CHECK_INT_EQ(vf_film_read(old, &a), VF_OK);
  CHECK_INT_EQ(vf_film_read(now, &b), VF_OK);
  if (a && b) {
    CHECK(films_equal(a, early, 1e-14));
    CHECK(films_equal(b, late, 1e-14));
    CHECK_INT_EQ(vf_film_clone(b, &b_first), VF_OK);
    CHECK_INT_EQ(vf_film_merge(b_first, a), VF_OK);
    CHECK_INT_EQ(vf_film_merge(a, b), VF_OK);
    CHECK(films_equal(a, b_first, 0)); /* x + y == y + x exactly */
    CHECK(films_equal(a, all, 1e-13)); /* same samples, different rounding and summation order */
    CHECK_NEAR(vf_film_estimate_rmse(a), vf_film_estimate_rmse(all), 1e-12 * vf_film_estimate_rmse(all));
    /* the merged film written again is of the current version and reads back to 48 bits */
    vf_film *back = NULL;
    CHECK_INT_EQ(vf_film_write(a, old), VF_OK);
    CHECK_INT_EQ(vf_film_read(old, &back), VF_OK);
    if (back) CHECK(films_equal(back, a, 1e-14));
    vf_film_destroy(back);
  }
  vf_film_destroy(b_first);
  vf_film_destroy(a);
  vf_film_destroy(b);
  vf_film_destroy(all);
  vf_film_destroy(late);
  vf_film_destroy(early);
}

/* The sums of a wire tile and of the film at its place agree (exactly with rel_tol 0). */
static int tile_agrees(const vf_film *film, const vf_film_tile *t, double rel_tol) {
  for (int y = 0; y < t->h; y++)
    for (int i = 0; i < 3 * t->w; i++) {
      size_t at = ((size_t)(t->y0 + y) * (size_t)film->width + (size_t)t->x0) * 3 + (size_t)i;
      if (rel_tol == 0 ? film->sum[at] != t->sum[y * 3 * t->w + i] || film->square_sum[at] != t->square_sum[y * 3 * t->w + i]
                       : rel_diff(vf_film_sum_at(film, at), vf_fixed_to_double(t->sum[y * 3 * t->w + i], VF_FILM_SUM_BITS)) > rel_tol)
        return 0;
    }
  return 1;
}

static void test_a_wire_tile_is_its_chunk_of_the_file(void) {
  vf_film *f = film_with(100, 70, 0, 3);
  const char *path = fixture_path("wire.film.exr");
  CHECK_INT_EQ(vf_film_write(f, path), VF_OK);
  exr_context_t ctx = NULL;
  CHECK_INT_EQ(exr_start_read(&ctx, path, NULL), EXR_ERR_SUCCESS);
  Vcmfarm__Tile tiles[4];
  uint8_t *blocks[4] = {0};
  for (uint32_t i = 0; i < 4 && ctx; i++) {
    CHECK_INT_EQ(vf_film_tile_encode(f, i % 2, i / 2, &tiles[i], &blocks[i]), VF_OK);
    exr_chunk_info_t ci;
    CHECK_INT_EQ(exr_read_tile_chunk_info(ctx, 0, (int)(i % 2), (int)(i / 2), 0, 0, &ci), EXR_ERR_SUCCESS);
    uint8_t *chunk = malloc(ci.packed_size);
    CHECK_INT_EQ(exr_read_chunk(ctx, 0, &ci, chunk), EXR_ERR_SUCCESS);
    CHECK_INT_EQ(ci.packed_size, tiles[i].chunk.len);
    CHECK(ci.packed_size == tiles[i].chunk.len && memcmp(chunk, tiles[i].chunk.data, ci.packed_size) == 0);
    free(chunk);
  }
  exr_finish(&ctx);

  Vcmfarm__LeaseResult m = VCMFARM__LEASE_RESULT__INIT;
  Vcmfarm__Tile *ptrs[4] = {&tiles[0], &tiles[1], &tiles[2], &tiles[3]};
  m.begin = 10;
  m.end = 13; /* the part's 3 iterations */
  m.n_tiles = 4;
  m.tiles = ptrs;
  vf_film_tile *decoded = NULL;
  CHECK_INT_EQ(vf_film_tiles_decode(&m, 100, 70, &decoded), VF_OK);
  for (int i = 0; decoded && i < 4; i++) {
    CHECK(tile_agrees(f, &decoded[i], 0)); /* exactly */
    CHECK_INT_EQ(decoded[i].w, i % 2 ? 36 : 64);
    CHECK_INT_EQ(decoded[i].h, i / 2 ? 6 : 64);
  }
  vf_film_tiles_free(decoded, 4);

  /* damaged chunks are refused with the tile named; a flipped bit in a compressed chunk
   * (of a black tile) is found by zlib's checksum */
  ProtobufCBinaryData kept = tiles[3].chunk;
  CHECK(kept.len > 0 && kept.len <= 72 * 36 * 6);
  vf_film *black = NULL;
  Vcmfarm__Tile black_tile;
  uint8_t *flipped = NULL;
  CHECK_INT_EQ(vf_film_create(100, 70, &black), VF_OK);
  CHECK_INT_EQ(vf_film_tile_encode(black, 1, 1, &black_tile, &flipped), VF_OK);
  CHECK(black_tile.chunk.len < 100);
  flipped[black_tile.chunk.len - 1] ^= 0x40; /* in zlib's checksum of the stream */
  vf_film_destroy(black);
  const struct {
    const char *what;
    ProtobufCBinaryData chunk;
    uint32_t x;
  } cases[] = {{"cut short", {kept.len - 1, kept.data}, 1},
               {"one byte more", {kept.len + 1, kept.data}, 1},
               {"with a flipped bit", black_tile.chunk, 1},
               {"empty", {0, NULL}, 1},
               {"outside the film", kept, 2}};
  for (size_t c = 0; c < sizeof cases / sizeof *cases; c++) {
    tiles[3].chunk = cases[c].chunk;
    tiles[3].x = cases[c].x;
    decoded = (vf_film_tile *)0x1;
    int err = vf_film_tiles_decode(&m, 100, 70, &decoded);
    if (err != VF_EINVAL) CHECK_FAIL_("a chunk %s was not refused (%d)", cases[c].what, err);
    else CHECK_STR_CONTAINS(vf_error_detail(err), "tile (");
    CHECK(decoded == (vf_film_tile *)0x1);
  }
  tiles[3].chunk = kept;
  tiles[3].x = 1;
  free(flipped);
  for (int i = 0; i < 4; i++) free(blocks[i]);
  vf_film_destroy(f);
}

static void test_files_are_the_same_bytes_every_time(void) {
  /* tiles are encoded in parallel and written in order */
  vf_film *f = film_with(300, 200, 0, 2);
  const char *a = fixture_path("twice_a.film.exr"), *b = fixture_path("twice_b.film.exr");
  CHECK_INT_EQ(vf_film_write(f, a), VF_OK);
  CHECK_INT_EQ(vf_film_write(f, b), VF_OK);
  size_t na = 0, nb = 0;
  unsigned char *x = fixture_slurp(a, &na), *y = fixture_slurp(b, &nb);
  CHECK(x && y && na == nb && memcmp(x, y, na) == 0);
  /* black compresses to almost nothing; noise to at most 48 bytes per pixel (its rests' high
   * words are zeros) */
  printf("  300x200 noise: %.2f bytes per pixel\n", (double)na / (300.0 * 200.0));
  CHECK(na < 48 * 300 * 200 + 100000);
  free(x);
  free(y);
  vf_film *black = NULL;
  CHECK_INT_EQ(vf_film_create(300, 200, &black), VF_OK);
  CHECK_INT_EQ(vf_film_write(black, a), VF_OK);
  x = fixture_slurp(a, &na);
  printf("  300x200 black: %.2f bytes per pixel\n", (double)na / (300.0 * 200.0));
  CHECK(na < 300 * 200);
  free(x);
  vf_film_destroy(black);
  vf_film_destroy(f);
}

/* Outcome of a child that reads one damaged file. */
enum { CHILD_REFUSED = 0, CHILD_READ_VALID = 1, CHILD_READ_INVALID = 2, CHILD_BAD_ERROR = 3 };

/* Runs in the child of exr_corpus_read_in_child(): its return value is the exit status. */
static int read_film_outcome(const char *path) {
  vf_film *f = NULL;
  int err = vf_film_read(path, &f);
  if (err == VF_OK) {
    int valid = vf_film_validate(f, path) == VF_OK;
    vf_film_destroy(f);
    return valid ? CHILD_READ_VALID : CHILD_READ_INVALID;
  }
  int named = strstr(vf_error_detail(err), path) != NULL;
  return (err == VF_EFILM || err == VF_EEXR) && named ? CHILD_REFUSED : CHILD_BAD_ERROR;
}

static void test_corrupted_copies_never_crash(void) {
  vf_film *f = film_with(70, 40, 0, 5);
  const char *good = fixture_path("fuzz.film.exr"), *bad = fixture_path("fuzzed.film.exr");
  CHECK_INT_EQ(vf_film_write(f, good), VF_OK);
  vf_film_destroy(f);
  size_t size = 0;
  unsigned char *bytes = fixture_slurp(good, &size), *copy = malloc(size);
  uint64_t s = 12345;
  int refused = 0, read = 0;
  double slowest = 0;
  for (int c = 0; c < 300; c++) {
    memcpy(copy, bytes, size);
    size_t n = size;
    if (c % 3 == 0) {
      n = (size_t)(fixture_uniform(&s) * (double)size); /* truncation */
    } else {
      /* flips: half of the cases aim at the header, where the structure lives */
      size_t span = c % 3 == 1 ? (size < 2000 ? size : 2000) : size;
      int flips = 1 + (int)(fixture_uniform(&s) * 8);
      for (int k = 0; k < flips; k++)
        copy[(size_t)(fixture_uniform(&s) * (double)span)] ^= (unsigned char)(1u << (fixture_xorshift(&s) % 8));
    }
    if (n == size && memcmp(copy, bytes, size) == 0) continue; /* flips that undid each other */
    fixture_spill(bad, copy, n);
    double dt;
    int sig;
    int outcome = exr_corpus_read_in_child(read_film_outcome, bad, &dt, &sig);
    if (dt > slowest) slowest = dt;
    if (sig) CHECK_FAIL_("case %d: reader died with signal %d", c, sig);
    else if (outcome == CHILD_REFUSED) refused++;
    else if (outcome == CHILD_READ_VALID) read++;
    else CHECK_FAIL_("case %d: outcome %d", c, outcome);
    if (dt > EXR_CORPUS_MAX_SECONDS_PER_FILE) CHECK_FAIL_("case %d took %.2f s", c, dt);
  }
  printf("  300 corrupted copies: %d refused, %d read as valid films, slowest %.3f s\n", refused, read, slowest);
  CHECK_INT_EQ(read, 0); /* the checksum finds every damage */
  free(copy);
  free(bytes);
}

static void test_damaged_corpus_is_refused(void) {
  if (!exr_corpus_present()) return;
  char **paths = NULL;
  int files = exr_corpus_list(EXR_CORPUS "/Damaged", 1, &paths);
  double slowest = 0;
  for (int i = 0; i < files; i++) {
    const char *name = exr_corpus_name(paths[i]);
    double dt;
    int sig;
    int outcome = exr_corpus_read_in_child(read_film_outcome, paths[i], &dt, &sig);
    if (dt > slowest) slowest = dt;
    if (sig) CHECK_FAIL_("%s: reader died with signal %d", name, sig);
    else if (outcome != CHILD_REFUSED) CHECK_FAIL_("%s: outcome %d", name, outcome);
    if (dt > EXR_CORPUS_MAX_SECONDS_PER_FILE) CHECK_FAIL_("%s took %.2f s", name, dt);
  }
  exr_corpus_list_free(paths, files);
  CHECK(files >= 185);
  printf("  %d damaged files refused as films, slowest %.3f s\n", files, slowest);
}

int main(void) {
  if (fixture_scratch_open("test_film") != 0) return 1;
  RUN(test_add_iteration_and_mean_arithmetic);
  RUN(test_clear_pixels_empties_small_and_large_films);
  RUN(test_create_refuses_bad_sizes);
  RUN(test_nonfinite_samples_count_as_zero);
  RUN(test_repeated_iteration_is_refused_unchanged);
  RUN(test_write_read_round_trip);
  RUN(test_long_iteration_set_round_trips);
  RUN(test_merge_equals_direct_render_and_commutes);
  RUN(test_merge_is_exact_in_any_order_and_grouping);
  RUN(test_merge_refusals_leave_dst_unchanged);
  RUN(test_validate_catches_broken_invariants);
  RUN(test_write_is_atomic);
  RUN(test_read_refuses_inconsistent_films);
  RUN(test_read_refuses_missing_channel_and_unknown_version);
  RUN(test_version_1_sums_camera_and_light_and_needs_every_count);
  RUN(test_version_1_and_2_films_read_merge_with_version_3);
  RUN(test_attributes_must_be_utf8);
  RUN(test_a_film_without_biased_merges_reads_zero_and_merges);
  RUN(test_a_wire_tile_is_its_chunk_of_the_file);
  RUN(test_files_are_the_same_bytes_every_time);
  RUN(test_corrupted_copies_never_crash);
  RUN(test_damaged_corpus_is_refused);
  fixture_scratch_close();
  return check_finish();
}
