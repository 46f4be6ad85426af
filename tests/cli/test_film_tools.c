/* The film tools through their command functions (vf_cmd_merge, bake, errors, diff), on
 * small films built in-process: merging is exact, commutative and associative, and split
 * iteration ranges merge into the film of all of them; mismatched or overlapping films are
 * refused with exit status 2 and nothing written; bake round-trips the mean; errors gives
 * the analytic values of known perturbations; diff draws the right colours at the right
 * size. Damaged files and real renders are covered by test_film_tools.sh. */
#include "check.h"
#include "film_fixtures.h"
#include "cli/compare_cmd.h"
#include "common/error.h"
#include "common/film.h"
#include "cli/film_cmd.h"
#include "cli/continue_cmd.h"
#include "cli/info_cmd.h"
#include "cli/render_cmd.h"
#include "common/image.h"

#include <cjson/cJSON.h>
#include <fcntl.h>
#include <png.h>
#include <stdint.h>
#include <stdlib.h>
#include <sys/stat.h>
#include <unistd.h>

/* In sanitizer builds: fontconfig (under cairo's text API, used by diff) keeps a few hundred
 * bytes it never frees; that is not ours to fix. LeakSanitizer calls this hook if present. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void) { return "leak:libfontconfig.so\n"; }

static void write_film(vf_film *film, const char *path) {
  CHECK(film != NULL);
  if (film) CHECK_INT_EQ(vf_film_write(film, path), VF_OK);
  vf_film_destroy(film);
}

/* Like run, with the command's standard output captured in a new string (caller frees). */
static char *run_captured(int *status, int (*cmd)(int, char **), const char *a, const char *b, const char *c,
                          const char *d) {
  const char *path = fixture_path("stdout.txt");
  fflush(stdout);
  int saved = dup(STDOUT_FILENO), fd = open(path, O_WRONLY | O_CREAT | O_TRUNC, 0644);
  dup2(fd, STDOUT_FILENO);
  close(fd);
  *status = fixture_run(cmd, a, b, c, d, (const char *)NULL);
  fflush(stdout);
  dup2(saved, STDOUT_FILENO);
  close(saved);
  FILE *f = fopen(path, "rb");
  char *text = calloc(1, 1 << 16);
  if (f) {
    size_t n = fread(text, 1, (1 << 16) - 1, f);
    text[n] = '\0';
    fclose(f);
  }
  return text;
}

static vf_film *read_film(const char *path) {
  vf_film *film = NULL;
  int err = vf_film_read(path, &film);
  if (err != VF_OK) CHECK_FAIL_("%s: %s", path, vf_error_detail(err));
  return film;
}

/* Largest |a - b| over every sum, and the mean sum as the scale. */
static double max_sum_difference(const vf_film *a, const vf_film *b, double *scale) {
  size_t n = (size_t)a->width * (size_t)a->height;
  double worst = 0.0, total = 0.0;
  for (size_t i = 0; i < 3 * n; i++) {
    worst = fmax(worst, fabs(vf_film_sum_at(a, i) - vf_film_sum_at(b, i)));
    worst = fmax(worst, fabs(vf_film_square_at(a, i) - vf_film_square_at(b, i)));
    total += vf_film_sum_at(a, i);
  }
  *scale = total / (double)(3 * n);
  return worst;
}

/* Same iterations, counts and attributes, and every sum within 1e-5 x the mean. */
static void check_films_agree(const char *path_a, const char *path_b) {
  vf_film *a = read_film(path_a), *b = read_film(path_b);
  if (a == NULL || b == NULL) goto done;
  CHECK_INT_EQ(a->width, b->width);
  CHECK_INT_EQ(a->height, b->height);
  if (a->width != b->width || a->height != b->height) goto done;
  CHECK(vf_iterset_equal(&a->iterations, &b->iterations));
  CHECK_NEAR(a->render_seconds, b->render_seconds, 1e-9);
  CHECK(strcmp(a->settings_text, b->settings_text) == 0);
  double scale, worst = max_sum_difference(a, b, &scale);
  printf("  %s vs %s: max |difference| %.3g, mean sum %.3g\n", strrchr(path_a, '/') + 1,
         strrchr(path_b, '/') + 1, worst, scale);
  CHECK(worst <= 1e-5 * scale);
done:
  vf_film_destroy(a);
  vf_film_destroy(b);
}

/* ---- merge ---- */

enum { W = 37, H = 23 };

static void make_abc(void) {
  write_film(fixture_film(W, H, 0, 3, 1), fixture_path("a.exr"));
  write_film(fixture_film(W, H, 3, 5, 1), fixture_path("b.exr"));
  write_film(fixture_film(W, H, 5, 9, 1), fixture_path("c.exr"));
}

/* Issue 41: a film of no iteration holding sums (N = 0 implies zero sums) is refused by
 * info, merge and continue, with nothing written: merged, it would have added samples
 * from nowhere to a film's iterations (a [0,1) film carrying two iterations' sums). */
static void test_a_film_of_no_iterations_with_sums_is_refused(void) {
  const char *real = fixture_path("one.exr"), *forged = fixture_path("forged.exr"), *out = fixture_path("never.exr");
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-n", "1", "-R", "20x10", "-s", "3", "-q", "-o", real,
                           NULL), 0);
  vf_film *film = read_film(real);
  if (film == NULL) return;
  CHECK_INT_EQ(fixture_forge_film(forged, film, ""), VF_OK);
  vf_film_destroy(film);
  CHECK_INT_EQ(fixture_run(vf_cmd_info, "info", forged, NULL), 2);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EFILM), "holds sums but the film has no iterations");
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-q", "-o", out, real, forged, NULL), 2);
  CHECK(!fixture_exists(out));
  CHECK_INT_EQ(fixture_run(vf_cmd_continue, "continue", forged, "-n", "1", "-q", "-o", out, NULL), 2);
  CHECK(!fixture_exists(out));
  /* the same file without sums is a valid empty film */
  vf_film *empty = NULL;
  CHECK_INT_EQ(vf_film_create(20, 10, &empty), VF_OK);
  if (empty) {
    CHECK_INT_EQ(fixture_forge_film(forged, empty, ""), VF_OK);
    CHECK_INT_EQ(fixture_run(vf_cmd_info, "info", forged, NULL), 0);
  }
  vf_film_destroy(empty);
}

static void test_merge_is_commutative(void) {
  make_abc();
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-q", "-o", fixture_path("ab.exr"), fixture_path("a.exr"),
                           fixture_path("b.exr"), NULL), 0);
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-q", "-o", fixture_path("ba.exr"), fixture_path("b.exr"),
                           fixture_path("a.exr"), NULL), 0);
  check_films_agree(fixture_path("ab.exr"), fixture_path("ba.exr"));
}

static void test_merge_is_associative(void) {
  make_abc();
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-q", "-o", fixture_path("ab.exr"), fixture_path("a.exr"),
                           fixture_path("b.exr"), NULL), 0);
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-q", "-o", fixture_path("bc.exr"), fixture_path("b.exr"),
                           fixture_path("c.exr"), NULL), 0);
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-q", "-o", fixture_path("ab_c.exr"), fixture_path("ab.exr"),
                           fixture_path("c.exr"), NULL), 0);
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-q", "-o", fixture_path("a_bc.exr"), fixture_path("a.exr"),
                           fixture_path("bc.exr"), NULL), 0);
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-q", "-o", fixture_path("abc.exr"), fixture_path("c.exr"),
                           fixture_path("a.exr"), fixture_path("b.exr"), NULL), 0);
  check_films_agree(fixture_path("ab_c.exr"), fixture_path("a_bc.exr"));
  check_films_agree(fixture_path("ab_c.exr"), fixture_path("abc.exr"));
}

static void test_merge_of_split_ranges_equals_direct_film(void) {
  const int n = 12;
  write_film(fixture_film(W, H, 0, (uint64_t)n, 1), fixture_path("direct.exr"));
  for (int k = 1; k < n; k += 5) {
    write_film(fixture_film(W, H, 0, (uint64_t)k, 1), fixture_path("head.exr"));
    write_film(fixture_film(W, H, (uint64_t)k, (uint64_t)n, 1), fixture_path("tail.exr"));
    CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-q", "-o", fixture_path("joined.exr"), fixture_path("head.exr"),
                             fixture_path("tail.exr"), NULL), 0);
    check_films_agree(fixture_path("joined.exr"), fixture_path("direct.exr"));
  }
}

static void test_merge_into_one_of_its_inputs(void) {
  make_abc();
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-q", "-o", fixture_path("a.exr"), fixture_path("a.exr"),
                           fixture_path("b.exr"), NULL), 0);
  write_film(fixture_film(W, H, 0, 5, 1), fixture_path("direct.exr"));
  check_films_agree(fixture_path("a.exr"), fixture_path("direct.exr"));
}

/* merge must refuse with exit 2, name both files and the expected words, and write nothing:
 * no new file, and an existing output byte for byte as it was. */
static void expect_merge_refused(const char *first, const char *second, const char *words) {
  const char *fresh = fixture_path("never.exr"), *kept = fixture_path("kept.exr");
  unlink(fresh);
  fixture_spill_text(kept, "precious bytes");
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-o", fresh, first, second, NULL), 2);
  char detail[1024];
  snprintf(detail, sizeof detail, "%s", vf_error_detail(vf_error_code()));
  CHECK_STR_CONTAINS(detail, first);
  CHECK_STR_CONTAINS(detail, second);
  CHECK_STR_CONTAINS(detail, words);
  CHECK(!fixture_exists(fresh));
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-o", kept, first, second, NULL), 2);
  char buf[64] = {0};
  FILE *f = fopen(kept, "rb");
  CHECK(f != NULL && fread(buf, 1, sizeof buf - 1, f) == 14);
  if (f) fclose(f);
  CHECK(strcmp(buf, "precious bytes") == 0);
}

static void test_merge_refuses_overlapping_iterations(void) {
  write_film(fixture_film(W, H, 0, 6, 1), fixture_path("first.exr"));
  write_film(fixture_film(W, H, 4, 8, 1), fixture_path("second.exr"));
  expect_merge_refused(fixture_path("first.exr"), fixture_path("second.exr"), "iterations [4,8) overlap");
  CHECK_STR_CONTAINS(vf_error_detail(VF_EOVERLAP), "'s [0,6)");
  /* the same film twice overlaps itself */
  expect_merge_refused(fixture_path("first.exr"), fixture_path("first.exr"), "overlap");
}

static void test_merge_refuses_mismatched_films(void) {
  write_film(fixture_film(W, H, 0, 2, 1), fixture_path("first.exr"));
  vf_film *other = fixture_film(W, H, 2, 4, 1);
  other->scene_hash[5] ^= 1;
  write_film(other, fixture_path("scene.exr"));
  expect_merge_refused(fixture_path("first.exr"), fixture_path("scene.exr"), "different scene");
  write_film(fixture_film(W, H, 2, 4, 2), fixture_path("seed.exr"));
  expect_merge_refused(fixture_path("first.exr"), fixture_path("seed.exr"), "seed=2 vs seed=1");
  write_film(fixture_film(W + 1, H, 2, 4, 1), fixture_path("size.exr"));
  expect_merge_refused(fixture_path("first.exr"), fixture_path("size.exr"), "size 38x23 differs");
}

static void test_merge_refuses_bad_command_lines(void) {
  write_film(fixture_film(W, H, 0, 2, 1), fixture_path("first.exr"));
  unlink(fixture_path("never.exr"));
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-o", fixture_path("never.exr"), fixture_path("first.exr"), NULL), 2);
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", fixture_path("first.exr"), fixture_path("first.exr"), NULL), 2);
  CHECK_INT_EQ(fixture_run(vf_cmd_merge, "merge", "-o", fixture_path("never.exr"), fixture_path("first.exr"),
                           fixture_path("missing.exr"), NULL), 2);
  CHECK_STR_CONTAINS(vf_error_detail(VF_ENOENT), "missing.exr");
  CHECK(!fixture_exists(fixture_path("never.exr")));
}

/* ---- bake ---- */

static void test_bake_exr_round_trips_the_mean(void) {
  vf_film *film = fixture_film(W, H, 0, 4, 1);
  float *mean = malloc(sizeof(float) * 3 * W * H);
  vf_film_mean(film, mean);
  write_film(film, fixture_path("film.exr"));
  CHECK_INT_EQ(fixture_run(vf_cmd_bake, "bake", fixture_path("film.exr"), "-o", fixture_path("mean.exr"), NULL), 0);
  vf_image img = {0};
  CHECK_INT_EQ(vf_image_read_exr(fixture_path("mean.exr"), &img), VF_OK);
  CHECK_INT_EQ(img.width, W);
  CHECK_INT_EQ(img.height, H);
  if (img.rgb && img.width == W && img.height == H) CHECK(memcmp(img.rgb, mean, sizeof(float) * 3 * W * H) == 0);
  vf_image_destroy(&img);
  free(mean);
}

/* Decodes a PNG as 8-bit RGB (caller frees *rgb); 0 on failure. */
static int decode_png(const char *path, int *width, int *height, unsigned char **rgb) {
  png_image image;
  memset(&image, 0, sizeof image);
  image.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_file(&image, path)) return 0;
  image.format = PNG_FORMAT_RGB;
  *rgb = malloc(PNG_IMAGE_SIZE(image));
  if (*rgb == NULL || !png_image_finish_read(&image, NULL, *rgb, 0, NULL)) {
    free(*rgb);
    png_image_free(&image);
    return 0;
  }
  *width = (int)image.width;
  *height = (int)image.height;
  return 1;
}

static void test_bake_png_decodes(void) {
  write_film(fixture_film(W, H, 0, 2, 1), fixture_path("film.exr"));
  CHECK_INT_EQ(fixture_run(vf_cmd_bake, "bake", fixture_path("film.exr"), "-o", fixture_path("mean.PNG"), "--exposure",
                           "-1", NULL), 0);
  int w = 0, h = 0;
  unsigned char *rgb = NULL;
  CHECK(decode_png(fixture_path("mean.PNG"), &w, &h, &rgb));
  CHECK_INT_EQ(w, W);
  CHECK_INT_EQ(h, H);
  free(rgb);
}

static void test_bake_refuses_bad_input(void) {
  write_film(fixture_film(W, H, 0, 2, 1), fixture_path("film.exr"));
  unlink(fixture_path("mean.tiff"));
  CHECK_INT_EQ(fixture_run(vf_cmd_bake, "bake", fixture_path("film.exr"), "-o", fixture_path("mean.tiff"), NULL), 2);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EUSAGE), ".exr or .png");
  CHECK(!fixture_exists(fixture_path("mean.tiff")));
  /* a plain image is not a film */
  CHECK_INT_EQ(fixture_run(vf_cmd_bake, "bake", fixture_path("film.exr"), "-o", fixture_path("plain.exr"), NULL), 0);
  unlink(fixture_path("never.png"));
  CHECK_INT_EQ(fixture_run(vf_cmd_bake, "bake", fixture_path("plain.exr"), "-o", fixture_path("never.png"), NULL), 2);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EFILM), "plain.exr");
  CHECK(!fixture_exists(fixture_path("never.png")));
}

/* ---- errors ---- */

static double json_number(const cJSON *root, const char *group, const char *key) {
  const cJSON *g = group ? cJSON_GetObjectItemCaseSensitive(root, group) : root;
  const cJSON *v = cJSON_GetObjectItemCaseSensitive(g, key);
  return cJSON_IsNumber(v) ? v->valuedouble : NAN;
}

static cJSON *errors_json(const char *image, const char *ref, int *status) {
  char *text = run_captured(status, vf_cmd_errors, "errors", "--json", image, ref);
  cJSON *root = cJSON_Parse(text);
  free(text);
  return root;
}

/* A random reference and an image that differs from it by +0.1 in R and x1.5 in G. */
static void make_perturbed_pair(vf_image *ref, vf_image *img) {
  vf_image_alloc(ref, W, H);
  vf_image_alloc(img, W, H);
  uint64_t s = 77;
  for (int i = 0; i < 3 * W * H; i++) ref->rgb[i] = (float)(fixture_uniform(&s) * 2.0);
  memcpy(img->rgb, ref->rgb, sizeof(float) * 3 * W * H);
  for (int p = 0; p < W * H; p++) {
    img->rgb[3 * p] += 0.1f;
    img->rgb[3 * p + 1] *= 1.5f;
  }
}

static void test_errors_of_an_image_against_itself_are_zero(void) {
  vf_film *film = fixture_film(W, H, 0, 3, 1);
  write_film(film, fixture_path("film.exr"));
  CHECK_INT_EQ(fixture_run(vf_cmd_bake, "bake", fixture_path("film.exr"), "-o", fixture_path("baked.exr"), NULL), 0);
  /* film against film, and film against its baked mean: the same pixels */
  const char *pairs[2][2] = {{"film.exr", "film.exr"}, {"film.exr", "baked.exr"}};
  for (int k = 0; k < 2; k++) {
    int status = -1;
    cJSON *root = errors_json(fixture_path(pairs[k][0]), fixture_path(pairs[k][1]), &status);
    CHECK_INT_EQ(status, 0);
    CHECK(root != NULL);
    CHECK_INT_EQ(json_number(root, NULL, "pixels"), W * H);
    CHECK_INT_EQ(json_number(root, NULL, "skipped"), 0);
    CHECK_NEAR(json_number(root, "rmse", "all"), 0.0, 0.0);
    CHECK_NEAR(json_number(root, "rel_mse", "all"), 0.0, 0.0);
    CHECK_NEAR(json_number(root, "mae", "all"), 0.0, 0.0);
    CHECK(json_number(root, NULL, "mean_image") > 0);
    cJSON_Delete(root);
  }
}

static void test_errors_of_a_known_perturbation(void) {
  vf_image ref = {0}, img = {0};
  make_perturbed_pair(&ref, &img);
  CHECK_INT_EQ(vf_image_write_exr(fixture_path("ref.exr"), &ref), VF_OK);
  CHECK_INT_EQ(vf_image_write_exr(fixture_path("img.exr"), &img), VF_OK);
  /* analytic values from the reference alone: d_R = 0.1, d_G = 0.5 G, d_B = 0 */
  double se_g = 0, rel_r = 0, rel_g = 0, abs_g = 0;
  for (int p = 0; p < W * H; p++) {
    double r = ref.rgb[3 * p], g = ref.rgb[3 * p + 1];
    se_g += 0.25 * g * g;
    abs_g += 0.5 * g;
    rel_r += 0.01 / (r * r + 0.01);
    rel_g += 0.25 * g * g / (g * g + 0.01);
  }
  double n = W * H;
  int status = -1;
  cJSON *root = errors_json(fixture_path("img.exr"), fixture_path("ref.exr"), &status);
  CHECK_INT_EQ(status, 0);
  CHECK(root != NULL);
  const double tol = 1e-6; /* float rounding of the perturbed pixels */
  CHECK_NEAR(json_number(root, "rmse", "R"), 0.1, tol);
  CHECK_NEAR(json_number(root, "rmse", "G"), sqrt(se_g / n), tol);
  CHECK_NEAR(json_number(root, "rmse", "B"), 0.0, 0.0);
  CHECK_NEAR(json_number(root, "rmse", "all"), sqrt((0.01 * n + se_g) / (3 * n)), tol);
  CHECK_NEAR(json_number(root, "rel_mse", "R"), rel_r / n, tol);
  CHECK_NEAR(json_number(root, "rel_mse", "G"), rel_g / n, tol);
  CHECK_NEAR(json_number(root, "mae", "R"), 0.1, tol);
  CHECK_NEAR(json_number(root, "mae", "G"), abs_g / n, tol);
  CHECK_NEAR(json_number(root, "mae", "all"), (0.1 * n + abs_g) / (3 * n), tol);
  cJSON_Delete(root);
  vf_image_destroy(&ref);
  vf_image_destroy(&img);
}

static void test_errors_window_and_text_output(void) {
  /* the image differs from the reference only at pixel (5, 7), by 1 in every channel */
  vf_image ref = {0}, img = {0};
  vf_image_alloc(&ref, W, H);
  vf_image_alloc(&img, W, H);
  for (int c = 0; c < 3; c++) img.rgb[3 * (7 * W + 5) + c] = 1.0f;
  CHECK_INT_EQ(vf_image_write_exr(fixture_path("ref.exr"), &ref), VF_OK);
  CHECK_INT_EQ(vf_image_write_exr(fixture_path("img.exr"), &img), VF_OK);
  int status = -1;
  char *text = run_captured(&status, vf_cmd_errors, "errors", "-w", "4,6,2,2", fixture_path("img.exr"));
  free(text);
  CHECK_INT_EQ(status, 2); /* REF missing */
  text = run_captured(&status, vf_cmd_errors, "errors", "--window=4,6,2,2", fixture_path("img.exr"),
                      fixture_path("ref.exr"));
  CHECK_INT_EQ(status, 0);
  CHECK_STR_CONTAINS(text, "4 pixels compared, 0 skipped");
  CHECK_STR_CONTAINS(text, "rmse                   0.5             0.5             0.5             0.5");
  CHECK_STR_CONTAINS(text, "mae                   0.25");
  free(text);
  text = run_captured(&status, vf_cmd_errors, "errors", "--window=0,0,5,5", fixture_path("img.exr"),
                      fixture_path("ref.exr"));
  CHECK_INT_EQ(status, 0);
  CHECK_STR_CONTAINS(text, "rmse                     0               0               0               0");
  free(text);
  text = run_captured(&status, vf_cmd_errors, "errors", "--window=30,20,10,10", fixture_path("img.exr"),
                      fixture_path("ref.exr"));
  CHECK_INT_EQ(status, 2); /* outside the image */
  free(text);
  text = run_captured(&status, vf_cmd_errors, "errors", "--window=1,2,3", fixture_path("img.exr"),
                      fixture_path("ref.exr"));
  CHECK_INT_EQ(status, 2);
  free(text);
  vf_image_destroy(&ref);
  vf_image_destroy(&img);
}

static void test_errors_refuse_different_sizes(void) {
  vf_image a = {0}, b = {0};
  vf_image_alloc(&a, W, H);
  vf_image_alloc(&b, H, W);
  CHECK_INT_EQ(vf_image_write_exr(fixture_path("a.exr"), &a), VF_OK);
  CHECK_INT_EQ(vf_image_write_exr(fixture_path("b.exr"), &b), VF_OK);
  int status = -1;
  char *text = run_captured(&status, vf_cmd_errors, "errors", fixture_path("a.exr"), fixture_path("b.exr"), NULL);
  CHECK_INT_EQ(status, 2);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EMISMATCH), "37x23");
  CHECK_STR_CONTAINS(vf_error_detail(VF_EMISMATCH), "23x37");
  CHECK(text[0] == '\0'); /* no figures for a refused pair */
  free(text);
  unlink(fixture_path("never.png"));
  CHECK_INT_EQ(fixture_run(vf_cmd_diff, "diff", fixture_path("a.exr"), fixture_path("b.exr"), "-o",
                           fixture_path("never.png"), NULL), 2);
  CHECK(!fixture_exists(fixture_path("never.png")));
  vf_image_destroy(&a);
  vf_image_destroy(&b);
}

/* ---- diff ---- */

static void test_diff_png_size_and_colours(void) {
  /* left half of A is twice B (relative difference ~ +1), right half equal (0) */
  const int w = 40, h = 10;
  vf_image a = {0}, b = {0};
  vf_image_alloc(&a, w, h);
  vf_image_alloc(&b, w, h);
  for (int p = 0; p < w * h; p++)
    for (int c = 0; c < 3; c++) {
      b.rgb[3 * p + c] = 100.0f;
      a.rgb[3 * p + c] = p % w < w / 2 ? 200.0f : 100.0f;
    }
  a.rgb[3 * (5 * w + 30)] = NAN; /* one non-finite pixel */
  CHECK_INT_EQ(vf_image_write_exr(fixture_path("a.exr"), &a), VF_OK);
  CHECK_INT_EQ(vf_image_write_exr(fixture_path("b.exr"), &b), VF_OK);
  CHECK_INT_EQ(fixture_run(vf_cmd_diff, "diff", fixture_path("a.exr"), fixture_path("b.exr"), "-o",
                           fixture_path("d.png"), "-s", "1", NULL), 0);
  int pw = 0, ph = 0;
  unsigned char *rgb = NULL;
  CHECK(decode_png(fixture_path("d.png"), &pw, &ph, &rgb));
  CHECK_INT_EQ(pw, VF_DIFF_MIN_WIDTH);
  CHECK_INT_EQ(ph, h + VF_DIFF_LEGEND_HEIGHT);
  if (rgb && pw == VF_DIFF_MIN_WIDTH) {
    int x0 = (pw - w) / 2;
    const unsigned char *red = rgb + 3 * (3 * pw + x0 + 2), *white = rgb + 3 * (3 * pw + x0 + 35),
                        *black = rgb + 3 * (5 * pw + x0 + 30);
    printf("  +1: %d,%d,%d  0: %d,%d,%d  NaN: %d,%d,%d\n", red[0], red[1], red[2], white[0], white[1], white[2],
           black[0], black[1], black[2]);
    CHECK(red[0] > 90 && red[1] < 10 && red[2] < 40); /* the dark red end of the map */
    CHECK(white[0] == 255 && white[1] == 255 && white[2] == 255);
    CHECK(black[0] == 0 && black[1] == 0 && black[2] == 0);
  }
  free(rgb);
  /* a wide image sets the width; the default scale of equal images is fine */
  vf_image_destroy(&a);
  vf_image_alloc(&a, 600, 3);
  CHECK_INT_EQ(vf_image_write_exr(fixture_path("wide.exr"), &a), VF_OK);
  CHECK_INT_EQ(fixture_run(vf_cmd_diff, "diff", fixture_path("wide.exr"), fixture_path("wide.exr"), "-o",
                           fixture_path("w.png"), NULL), 0);
  CHECK(decode_png(fixture_path("w.png"), &pw, &ph, &rgb));
  CHECK_INT_EQ(pw, 600);
  CHECK_INT_EQ(ph, 3 + VF_DIFF_LEGEND_HEIGHT);
  free(rgb);
  CHECK_INT_EQ(fixture_run(vf_cmd_diff, "diff", fixture_path("wide.exr"), fixture_path("wide.exr"), "-o",
                           fixture_path("w.jpg"), NULL), 2);
  CHECK(!fixture_exists(fixture_path("w.jpg")));
  vf_image_destroy(&a);
  vf_image_destroy(&b);
}

int main(void) {
  if (fixture_scratch_open("test_film_tools") != 0) return 1;
  RUN(test_a_film_of_no_iterations_with_sums_is_refused);
  RUN(test_merge_is_commutative);
  RUN(test_merge_is_associative);
  RUN(test_merge_of_split_ranges_equals_direct_film);
  RUN(test_merge_into_one_of_its_inputs);
  RUN(test_merge_refuses_overlapping_iterations);
  RUN(test_merge_refuses_mismatched_films);
  RUN(test_merge_refuses_bad_command_lines);
  RUN(test_bake_exr_round_trips_the_mean);
  RUN(test_bake_png_decodes);
  RUN(test_bake_refuses_bad_input);
  RUN(test_errors_of_an_image_against_itself_are_zero);
  RUN(test_errors_of_a_known_perturbation);
  RUN(test_errors_window_and_text_output);
  RUN(test_errors_refuse_different_sizes);
  RUN(test_diff_png_size_and_colours);
  fixture_scratch_close();
  return check_finish();
}
