/* Plain images: exact EXR round trips, PNG encoding, atomic writes, and the OpenEXR
 * robustness corpus (shared/exr-corpus beside the checkout): every valid RGB image reads,
 * every damaged file is refused quickly and without crashing. */
#include "check.h"
#include "exr_corpus.h"
#include "film_fixtures.h"
#include "common/error.h"
#include "common/image.h"

#include <errno.h>
#include <png.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

static uint64_t rng_state = 0x9e3779b97f4a7c15ULL;
static double uniform(void) { return fixture_uniform(&rng_state); }

static void test_exr_round_trip_is_exact(void) {
  vf_image img = {0}, back = {0};
  CHECK_INT_EQ(vf_image_alloc(&img, 37, 23), VF_OK); /* odd size: partial ZIP chunk of 16 lines */
  for (size_t i = 0; i < 3 * 37 * 23; i++) img.rgb[i] = (float)((uniform() - 0.3) * pow(10.0, 8 * uniform() - 4));
  img.rgb[0] = 0.0f;
  img.rgb[1] = -0.0f;
  img.rgb[2] = 3.0e38f;
  const char *path = fixture_path("round.exr");
  CHECK_INT_EQ(vf_image_write_exr(path, &img), VF_OK);
  CHECK_INT_EQ(vf_image_read_exr(path, &back), VF_OK);
  CHECK_INT_EQ(back.width, 37);
  CHECK_INT_EQ(back.height, 23);
  if (back.rgb) CHECK(memcmp(img.rgb, back.rgb, sizeof(float) * 3 * 37 * 23) == 0);
  CHECK(fixture_no_temp_files());
  vf_image_destroy(&img);
  vf_image_destroy(&back);
  vf_image_destroy(&back); /* zeroed: no-op */
}

static void test_missing_file_is_enoent(void) {
  vf_image img = {0};
  CHECK_INT_EQ(vf_image_read_exr("/nonexistent/dir/x.exr", &img), VF_ENOENT);
  CHECK(img.rgb == NULL);
}

static void test_non_exr_file_is_refused_with_name(void) {
  const char *path = fixture_path("text.exr");
  fixture_spill_text(path, "this is not an image\n");
  vf_image img = {0};
  CHECK_INT_EQ(vf_image_read_exr(path, &img), VF_EEXR);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EEXR), path);
  CHECK(img.rgb == NULL);
}

static void test_png_writes_srgb_pixels(void) {
  vf_image img = {0};
  CHECK_INT_EQ(vf_image_alloc(&img, 3, 2), VF_OK);
  float values[18] = {0.25f, 0.0f, 10.0f, /* */ -1.0f, NAN, 0.001f, /* */ 0.5f, 0.5f, 0.5f,
                      1.0f,  1.0f, 1.0f,  /* */ 0.0f, 0.0f, 0.0f,   /* */ 0.1f, 0.2f, 0.3f};
  memcpy(img.rgb, values, sizeof values);
  const char *path = fixture_path("preview.png");
  CHECK_INT_EQ(vf_image_write_png(path, &img, 1.0f), VF_OK); /* exposure +1 stop: x2 */

  png_image png;
  memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  CHECK(png_image_begin_read_from_file(&png, path));
  CHECK_INT_EQ(png.width, 3);
  CHECK_INT_EQ(png.height, 2);
  png.format = PNG_FORMAT_RGB;
  uint8_t pixels[18] = {0};
  CHECK(png_image_finish_read(&png, NULL, pixels, 0, NULL));
  /* 0.25 * 2 = 0.5 -> sRGB 0.7354 -> 188; 0 -> 0; 20 clamps to 255 */
  CHECK_INT_EQ(pixels[0], 188);
  CHECK_INT_EQ(pixels[1], 0);
  CHECK_INT_EQ(pixels[2], 255);
  /* negative and NaN are black; 0.002 is on the linear segment: 12.92 * 0.002 * 255 = 6.6 -> 7 */
  CHECK_INT_EQ(pixels[3], 0);
  CHECK_INT_EQ(pixels[4], 0);
  CHECK_INT_EQ(pixels[5], 7);
  CHECK_INT_EQ(pixels[6], 255); /* 0.5 * 2 = 1 */
  CHECK_INT_EQ(pixels[15], 124); /* 0.2 -> sRGB 0.4845 -> 123.5 -> 124 */
  CHECK(fixture_no_temp_files());
  vf_image_destroy(&img);
}

/* In the child of fixture_run_with_file_limit: 0 when both writes of keep.exr fail. */
static int both_writes_fail(void *img) {
  const char *path = fixture_path("keep.exr");
  return vf_image_write_exr(path, img) != VF_OK && vf_image_write_png(path, img, 0.0f) != VF_OK ? 0 : 1;
}

/* A failure half-way through the write (file size limit) must leave the old file intact
 * and no temporary file behind. Run in a child so the limit does not leak into the test. */
static void test_writes_are_atomic(void) {
  const char *path = fixture_path("keep.exr"), *dir_path = fixture_path("a_directory");
  mkdir(dir_path, 0755);
  fixture_spill_text(path, "old content");
  vf_image img = {0};
  CHECK_INT_EQ(vf_image_alloc(&img, 300, 200), VF_OK);
  for (size_t i = 0; i < 3 * 300 * 200; i++) img.rgb[i] = (float)uniform();

  int status = fixture_run_with_file_limit(4096, both_writes_fail, &img);
  CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
  CHECK(fixture_file_holds_text(path, "old content"));

  /* the target is a directory: refused, directory untouched */
  CHECK(vf_image_write_exr(dir_path, &img) != VF_OK);
  CHECK(vf_image_write_png(dir_path, &img, 0.0f) != VF_OK);
  struct stat st;
  CHECK(stat(dir_path, &st) == 0 && S_ISDIR(st.st_mode));
  /* the directory does not exist */
  CHECK_INT_EQ(vf_image_write_exr(fixture_path("no/such/dir/x.exr"), &img), VF_EIO);
  CHECK(fixture_no_temp_files());

  /* and a successful write replaces the old content */
  CHECK_INT_EQ(vf_image_write_exr(path, &img), VF_OK);
  CHECK(!fixture_file_holds_text(path, "old content"));
  vf_image_destroy(&img);
}

/* ---- the corpus (exr_corpus.h) ---- */

static void test_corpus_valid_images_read(void) {
  if (!exr_corpus_present()) return;
  static const char *const dirs[] = {"TestImages", "Tiles", "DisplayWindow", "ScanLines"};
  vf_image reference = {0};
  for (size_t d = 0; d < sizeof dirs / sizeof dirs[0]; d++) {
    char dir[512];
    snprintf(dir, sizeof dir, "%s/%s", EXR_CORPUS, dirs[d]);
    char **files = NULL;
    int n = exr_corpus_list(dir, 0, &files);
    for (int i = 0; i < n; i++) {
      vf_image img = {0};
      double t0 = exr_corpus_seconds();
      int err = vf_image_read_exr(files[i], &img);
      double dt = exr_corpus_seconds() - t0;
      printf("  %-60s %s %dx%d %.3fs\n", exr_corpus_name(files[i]), err ? "refused" : "read", img.width,
             img.height, dt);
      CHECK(dt < EXR_CORPUS_MAX_SECONDS_PER_FILE);
      if (strstr(files[i], "WideFloatRange")) {
        /* a lone G channel is not an RGB image */
        CHECK_INT_EQ(err, VF_EEXR);
        CHECK_STR_CONTAINS(vf_error_detail(err), "missing channel R");
      } else {
        if (err != VF_OK) CHECK_FAIL_("%s: %s", files[i], vf_error_detail(err));
      }
      /* all DisplayWindow files hold the same 400x300 pixels in different windows */
      if (err == VF_OK && strstr(files[i], "DisplayWindow/")) {
        CHECK_INT_EQ(img.width, 400);
        CHECK_INT_EQ(img.height, 300);
        if (reference.rgb == NULL) {
          reference = img;
          img.rgb = NULL;
        } else if (img.width == 400 && img.height == 300) {
          CHECK(memcmp(reference.rgb, img.rgb, sizeof(float) * 3 * 400 * 300) == 0);
        }
      }
      vf_image_destroy(&img);
    }
    exr_corpus_list_free(files, n);
  }
  vf_image_destroy(&reference);
}

/* Exit codes of the child that reads one damaged file. */
enum { CHILD_REFUSED = 0, CHILD_READ = 1, CHILD_BAD_ERROR = 2 };

/* Runs in the child of exr_corpus_read_in_child(): its return value is the exit status. */
static int read_image_outcome(const char *path) {
  vf_image img = {0};
  int err = vf_image_read_exr(path, &img);
  if (err == VF_OK) {
    vf_image_destroy(&img);
    return CHILD_READ;
  }
  /* the detail names the file */
  return err == VF_EEXR && strstr(vf_error_detail(err), path) ? CHILD_REFUSED : CHILD_BAD_ERROR;
}

static void test_corpus_damaged_files_are_refused(void) {
  if (!exr_corpus_present()) return;
  char **files = NULL;
  int n = exr_corpus_list(EXR_CORPUS "/Damaged", 1, &files);
  CHECK(n >= 185);
  double slowest = 0;
  for (int i = 0; i < n; i++) {
    double dt;
    int sig;
    int outcome = exr_corpus_read_in_child(read_image_outcome, files[i], &dt, &sig);
    if (dt > slowest) slowest = dt;
    const char *name = exr_corpus_name(files[i]);
    if (sig) CHECK_FAIL_("%s: reader died with signal %d", name, sig);
    else if (outcome == CHILD_READ) CHECK_FAIL_("%s: damaged file was read", name);
    else if (outcome != CHILD_REFUSED)
      CHECK_FAIL_("%s: refused with the wrong code or detail (exit %d)", name, outcome);
    if (dt > EXR_CORPUS_MAX_SECONDS_PER_FILE) CHECK_FAIL_("%s: took %.2f s", name, dt);
  }
  printf("  %d damaged files refused, slowest %.3f s\n", n, slowest);
  exr_corpus_list_free(files, n);
}

int main(void) {
  if (fixture_scratch_open("test_image") != 0) return 1;
  RUN(test_exr_round_trip_is_exact);
  RUN(test_missing_file_is_enoent);
  RUN(test_non_exr_file_is_refused_with_name);
  RUN(test_png_writes_srgb_pixels);
  RUN(test_writes_are_atomic);
  RUN(test_corpus_valid_images_read);
  RUN(test_corpus_damaged_files_are_refused);
  fixture_scratch_close();
  return check_finish();
}
