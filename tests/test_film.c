/* The film: accumulation arithmetic, exact merging, the file format round trip, atomic
 * writes, and reading damaged files (corrupted copies of a film and the OpenEXR corpus). */
#include "check.h"
#include "exr_corpus.h"
#include "film_fixtures.h"
#include "common/error.h"
#include "common/exr_util.h"
#include "common/film.h"
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

/* Every field and every pixel value, sums within rel_tol, counts exact. */
static int films_equal(const vf_film *a, const vf_film *b, double rel_tol) {
  if (a->width != b->width || a->height != b->height || a->light_frames != b->light_frames ||
      a->nonfinite_samples != b->nonfinite_samples || memcmp(a->scene_hash, b->scene_hash, 32) != 0 ||
      strcmp(a->settings_text, b->settings_text) != 0 || !vf_iterset_equal(&a->iterations, &b->iterations) ||
      rel_diff(a->render_seconds, b->render_seconds) > rel_tol)
    return 0;
  size_t n = (size_t)a->width * (size_t)a->height;
  for (size_t i = 0; i < n; i++)
    if (a->camera_count[i] != b->camera_count[i]) return 0;
  for (size_t i = 0; i < 3 * n; i++)
    if (rel_diff(a->camera_sum[i], b->camera_sum[i]) > rel_tol || rel_diff(a->light_sum[i], b->light_sum[i]) > rel_tol ||
        rel_diff(a->square_sum[i], b->square_sum[i]) > rel_tol)
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
  CHECK_INT_EQ(f->light_frames, 2);
  CHECK_INT_EQ(vf_iterset_count(&f->iterations), 2);
  CHECK(vf_iterset_contains(&f->iterations, 7) && vf_iterset_contains(&f->iterations, 8));
  CHECK_NEAR(f->camera_sum[0], 4, 0);
  CHECK_NEAR(f->camera_count[0], 2, 0);
  CHECK_NEAR(f->camera_count[1], 2, 0);
  CHECK_NEAR(f->light_sum[0], 1, 0);
  CHECK_NEAR(f->light_sum[5], 1, 0);
  /* (1 + 0.5)^2 + (3 + 0.5)^2 and (6 + 1)^2 + 0^2 */
  CHECK_NEAR(f->square_sum[0], 2.25 + 12.25, 0);
  CHECK_NEAR(f->square_sum[5], 49, 0);
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
  CHECK_NEAR(f->camera_sum[0], 0, 0); /* the whole camera sample of pixel 0 is zero */
  CHECK_NEAR(f->camera_sum[1], 0, 0);
  CHECK_NEAR(f->camera_count[0], 1, 0); /* but it still counts */
  CHECK_NEAR(f->light_sum[0], 1, 0);
  CHECK_NEAR(f->light_sum[3], 0, 0); /* light sample of pixel 1 is zero */
  CHECK_NEAR(f->camera_sum[3], 2, 0);
  CHECK_NEAR(f->square_sum[0], 1, 0);
  CHECK_NEAR(f->square_sum[3], 4, 0);
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
  f->camera_sum[7] = 123456789.123456789; /* needs more than a float's precision */
  f->light_sum[8] = -1e-30;
  f->render_seconds = 12345.678;
  const char *path = fixture_path("round.film.exr");
  CHECK_INT_EQ(vf_film_write(f, path), VF_OK);
  CHECK_INT_EQ(vf_film_read(path, &back), VF_OK);
  if (back) {
    CHECK(films_equal(f, back, 1e-14));
    CHECK_INT_EQ(back->nonfinite_samples, 1);
    CHECK_INT_EQ(back->light_frames, 4);
    CHECK_NEAR(back->camera_sum[7], 123456789.123456789, 1e-6);
    CHECK_NEAR(back->render_seconds, 12345.678, 0);
    char text[64];
    vf_iterset_format(&back->iterations, text, sizeof text);
    CHECK_STR_CONTAINS(text, "[0,3) [1000,1001)");
  }
  /* the layout docs/FILM.md promises: one tiled part, 64x64 tiles, uncompressed, FLOAT channels */
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
    CHECK_INT_EQ(compression, EXR_COMPRESSION_NONE);
    CHECK_INT_EQ(tx, VF_FILM_TILE);
    CHECK_INT_EQ(ty, VF_FILM_TILE);
    CHECK(channels != NULL);
    if (channels) {
      CHECK_INT_EQ(channels->num_channels, 23);
      for (int i = 0; i < channels->num_channels; i++) CHECK_INT_EQ(channels->entries[i].pixel_type, EXR_PIXEL_FLOAT);
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
  CHECK_INT_EQ(vf_film_clone(b, &b_first), VF_OK);
  CHECK_INT_EQ(vf_film_merge(b_first, a), VF_OK);
  CHECK_INT_EQ(vf_film_merge(a, b), VF_OK);
  CHECK(films_equal(a, all, 1e-13)); /* same samples, different summation order */
  CHECK(films_equal(a, b_first, 0)); /* x + y == y + x exactly */
  CHECK_INT_EQ(a->iterations.count, 1);
  CHECK_INT_EQ(vf_iterset_count(&a->iterations), 8);
  CHECK_NEAR(a->render_seconds, 10.0, 1e-12);
  vf_film_destroy(b_first);
  vf_film_destroy(all);
  vf_film_destroy(b);
  vf_film_destroy(a);
}

static void test_merge_refusals_leave_dst_unchanged(void) {
  vf_film *dst = film_with(8, 8, 0, 4), *before = NULL;
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

  CHECK(films_equal(dst, before, 0));
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
  } cases[] = {{"NaN sum", 0, NAN}, {"Inf light", 1, INFINITY}, {"negative square", 2, -1},
               {"fractional count", 3, 1.5}, {"count above iterations", 3, 3}, {"negative count", 3, -1}};
  for (size_t i = 0; i < sizeof cases / sizeof cases[0]; i++) {
    CHECK_INT_EQ(vf_film_clone(good, &f), VF_OK);
    double *target = cases[i].field == 0 ? f->camera_sum : cases[i].field == 1 ? f->light_sum
                     : cases[i].field == 2 ? f->square_sum : f->camera_count;
    target[5] = cases[i].value;
    if (vf_film_validate(f, "bad") != VF_EFILM) CHECK_FAIL_("%s passed validation", cases[i].what);
    if (vf_film_write(f, fixture_path("invalid.film.exr")) == VF_OK) CHECK_FAIL_("%s was written", cases[i].what);
    vf_film_destroy(f);
  }
  CHECK_INT_EQ(vf_film_clone(good, &f), VF_OK);
  f->light_frames = 3;
  CHECK_INT_EQ(vf_film_validate(f, "frames"), VF_EFILM);
  vf_film_destroy(f);
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
  CHECK_INT_EQ(vf_film_write(f, good), VF_OK);
  size_t size = 0;
  unsigned char *bytes = fixture_slurp(good, &size), *copy = malloc(size);

  static const struct {
    const char *attribute, *value, *detail;
  } patches[] = {
      {"vcmfarm:light_frames", "4", "light frames"},
      {"vcmfarm:light_frames", "x", "vcmfarm:light_frames"},
      {"vcmfarm:iterations", "[0,3(", "vcmfarm:iterations"},
      {"vcmfarm:iterations", "[3,0)", "vcmfarm:iterations"},
      {"vcmfarm:nonfinite_samples", "-", "vcmfarm:nonfinite_samples"},
  };
  for (size_t i = 0; i < sizeof patches / sizeof patches[0]; i++) {
    memcpy(copy, bytes, size);
    CHECK(patch_string_attribute(copy, size, patches[i].attribute, patches[i].value));
    fixture_spill(bad, copy, size);
    expect_read_refused(bad, patches[i].detail);
  }
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

static void zero_fill(void *user, int x0, int y0, int w, int h, float *const *planes) {
  int n = *(const int *)user;
  for (int k = 0; k < n; k++) memset(planes[k], 0, sizeof(float) * (size_t)w * (size_t)h);
}

/* A film-like file built with the private helpers, to reach states vf_film_write refuses. */
static int write_fake_film(const char *path, int version, const char *const *names, int n) {
  vf_exr_out out;
  int err = vf_exr_create(path, 20, 10, VF_FILM_TILE, 0, n, names, &out);
  if (err != VF_OK) return err;
  exr_attr_set_int(out.ctx, 0, "vcmfarm:format_version", version);
  exr_attr_set_string(out.ctx, 0, "vcmfarm:scene_hash", "abababababababababababababababababababababababababababababababab");
  exr_attr_set_string(out.ctx, 0, "vcmfarm:settings", "");
  exr_attr_set_string(out.ctx, 0, "vcmfarm:iterations", "");
  exr_attr_set_string(out.ctx, 0, "vcmfarm:light_frames", "0");
  exr_attr_set_double(out.ctx, 0, "vcmfarm:render_seconds", 0);
  exr_attr_set_string(out.ctx, 0, "vcmfarm:nonfinite_samples", "0");
  if ((err = vf_exr_write_pixels(&out, n, names, zero_fill, &n)) != VF_OK) {
    vf_exr_abort(&out);
    return err;
  }
  return vf_exr_commit(&out);
}

static void test_read_refuses_missing_channel_and_unknown_version(void) {
  static const char *const all[] = {"camera.hi.R", "camera.hi.G", "camera.hi.B", "camera.lo.R", "camera.lo.G",
                                    "camera.lo.B", "count.hi",    "count.lo",    "light.hi.R",  "light.hi.G",
                                    "light.hi.B",  "light.lo.R",  "light.lo.G",  "light.lo.B",  "square.hi.R",
                                    "square.hi.G", "square.hi.B", "square.lo.R", "square.lo.G", "square.lo.B"};
  const char *path = fixture_path("fake.film.exr");
  vf_film *f = NULL;
  CHECK_INT_EQ(write_fake_film(path, VF_FILM_FORMAT_VERSION, all, 20), VF_OK);
  CHECK_INT_EQ(vf_film_read(path, &f), VF_OK); /* the complete fake is a valid empty film */
  vf_film_destroy(f);
  CHECK_INT_EQ(write_fake_film(path, VF_FILM_FORMAT_VERSION, all, 19), VF_OK);
  expect_read_refused(path, "missing channel square.lo.B");
  CHECK_INT_EQ(write_fake_film(path, VF_FILM_FORMAT_VERSION + 1, all, 20), VF_OK);
  expect_read_refused(path, "unknown film format version 2");
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
  RUN(test_create_refuses_bad_sizes);
  RUN(test_nonfinite_samples_count_as_zero);
  RUN(test_repeated_iteration_is_refused_unchanged);
  RUN(test_write_read_round_trip);
  RUN(test_long_iteration_set_round_trips);
  RUN(test_merge_equals_direct_render_and_commutes);
  RUN(test_merge_refusals_leave_dst_unchanged);
  RUN(test_validate_catches_broken_invariants);
  RUN(test_write_is_atomic);
  RUN(test_read_refuses_inconsistent_films);
  RUN(test_read_refuses_missing_channel_and_unknown_version);
  RUN(test_corrupted_copies_never_crash);
  RUN(test_damaged_corpus_is_refused);
  fixture_scratch_close();
  return check_finish();
}
