/* `vcmfarm plot` and `vcmfarm info`: a PNG of the right size with one visible colour per
 * film, refusal of damaged films with nothing written, and info's text and JSON. */
#include "check.h"
#include "film_fixtures.h"
#include "common/error.h"
#include "common/film.h"
#include "cli/info_cmd.h"
#include "cli/plot.h"
#include "cli/render_cmd.h"

#include <cairo.h>
#include <cjson/cJSON.h>
#include <stdlib.h>
#include <sys/wait.h>
#include <unistd.h>

/* Number of pixels of exactly this colour. */
static long count_color(cairo_surface_t *s, const unsigned char rgb[3]) {
  int w = cairo_image_surface_get_width(s), h = cairo_image_surface_get_height(s);
  int stride = cairo_image_surface_get_stride(s);
  const unsigned char *data = cairo_image_surface_get_data(s);
  long n = 0;
  for (int y = 0; y < h; y++)
    for (int x = 0; x < w; x++) {
      uint32_t px = *(const uint32_t *)(data + (size_t)y * stride + 4 * (size_t)x);
      if (((px >> 16) & 255) == rgb[0] && ((px >> 8) & 255) == rgb[1] && (px & 255) == rgb[2]) n++;
    }
  return n;
}

static const char *film_a, *film_b, *film_c;

static void make_films(void) {
  film_a = fixture_path("a.exr");
  film_b = fixture_path("b.exr");
  film_c = fixture_path("c.exr");
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-a", "bpt", "-s", "3", "-n", "24", "-R", "24x16", "-q",
                           "-o", film_a, NULL), 0);
  /* a checkpoint, so a log entry, after every iteration */
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-a", "vcm", "-n", "12", "-R", "24x16",
                           "--reference", film_a, "--checkpoint-interval", "1e-9", "-q", "-o", film_b, NULL), 0);
  CHECK_INT_EQ(fixture_run(vf_cmd_render, "render", "cornell", "-a", "pt", "-n", "12", "-R", "24x16",
                           "--checkpoint-interval", "1e-9", "-q", "-o", film_c, NULL), 0);
}

static void check_png(const char *png, int width, int height, int curves) {
  cairo_surface_t *s = cairo_image_surface_create_from_png(png);
  CHECK_INT_EQ(cairo_surface_status(s), CAIRO_STATUS_SUCCESS);
  if (cairo_surface_status(s) == CAIRO_STATUS_SUCCESS) {
    CHECK_INT_EQ(cairo_image_surface_get_width(s), width);
    CHECK_INT_EQ(cairo_image_surface_get_height(s), height);
    for (int i = 0; i < curves; i++) {
      unsigned char rgb[3];
      vf_plot_color(i, rgb);
      long n = count_color(s, rgb);
      printf("  %s: curve %d colour (%d,%d,%d): %ld pixels\n", png, i, rgb[0], rgb[1], rgb[2], n);
      CHECK(n >= 100); /* legend swatch (22x6) plus the curve */
    }
  }
  cairo_surface_destroy(s);
}

static void test_plot_draws_one_colour_per_film(void) {
  const char *png = fixture_path("plot.png"), *one = fixture_path("time.png");
  CHECK_INT_EQ(fixture_run(vf_cmd_plot, "plot", film_b, film_c, "-o", png, NULL), 0);
  check_png(png, 2 * VF_PLOT_PANEL_WIDTH, VF_PLOT_HEIGHT, 2);
  CHECK_INT_EQ(fixture_run(vf_cmd_plot, "plot", film_a, film_b, film_c, "--x", "time", "-o", one, NULL), 0);
  check_png(one, VF_PLOT_PANEL_WIDTH, VF_PLOT_HEIGHT, 3);
}

static void test_plot_refuses_bad_input_and_writes_nothing(void) {
  const char *png = fixture_path("bad.png"), *junk = fixture_path("junk.exr");
  static const char not_exr[] = "v/1\x01 not an exr";
  fixture_spill(junk, not_exr, sizeof not_exr - 1);
  CHECK_INT_EQ(fixture_run(vf_cmd_plot, "plot", film_b, junk, "-o", png, NULL), 2);
  CHECK_STR_CONTAINS(vf_error_detail(VF_EEXR), junk);
  CHECK_INT_EQ(fixture_run(vf_cmd_plot, "plot", film_b, fixture_path("absent.exr"), "-o", png, NULL), 2);
  CHECK_INT_EQ(fixture_run(vf_cmd_plot, "plot", film_b, "--x", "frequency", "-o", png, NULL), 2);
  CHECK_INT_EQ(fixture_run(vf_cmd_plot, "plot", film_b, NULL), 2);
  CHECK(!fixture_exists(png));
}

/* Runs `vcmfarm info ARGS` and returns its stdout (caller frees). */
static char *info_output(const char *args, int *status) {
  char cmd[1024];
  snprintf(cmd, sizeof cmd, "'%s/vcmfarm' info %s 2>/dev/null", VF_BINARY_DIR, args);
  FILE *p = popen(cmd, "r");
  if (p == NULL) return NULL;
  size_t cap = 1 << 16, n = 0;
  char *buf = malloc(cap);
  while (n + 1 < cap && (n += fread(buf + n, 1, cap - 1 - n, p)) && !feof(p)) {}
  buf[n] = '\0';
  int rc = pclose(p);
  *status = WIFEXITED(rc) ? WEXITSTATUS(rc) : -1;
  return buf;
}

static void test_info_prints_everything(void) {
  char args[600];
  int status = -1;
  snprintf(args, sizeof args, "'%s'", film_b);
  char *text = info_output(args, &status);
  CHECK_INT_EQ(status, 0);
  static const char *const keys[] = {"format_version", "scene_hash", "scene              cornell", "settings",
                                     "seed", "iterations         [0,12)", "iteration_count    12", "light_frames",
                                     "render_seconds", "nonfinite_samples", "biased_merges      0", "image_mean",
                                     "estimated_rmse", "convergence log    12 entries"};
  for (size_t i = 0; i < sizeof keys / sizeof *keys; i++) CHECK_STR_CONTAINS(text, keys[i]);
  free(text);

  snprintf(args, sizeof args, "--json '%s'", film_b);
  text = info_output(args, &status);
  CHECK_INT_EQ(status, 0);
  cJSON *root = cJSON_Parse(text);
  CHECK(root != NULL);
  if (root) {
    cJSON *log = cJSON_GetObjectItem(root, "convergence");
    CHECK_INT_EQ(cJSON_GetArraySize(log), 12);
    cJSON *last = cJSON_GetArrayItem(log, 11);
    CHECK(cJSON_IsNumber(cJSON_GetObjectItem(last, "rmse")));
    CHECK(cJSON_IsNumber(cJSON_GetObjectItem(root, "estimated_rmse")));
    CHECK_INT_EQ(cJSON_GetObjectItem(root, "iteration_count")->valuedouble, 12);
    CHECK(strcmp(cJSON_GetObjectItem(root, "algorithm")->valuestring, "vcm") == 0);
    cJSON_Delete(root);
  }
  free(text);
  /* a film without reference has null RMSEs */
  snprintf(args, sizeof args, "--json '%s'", film_c);
  text = info_output(args, &status);
  root = cJSON_Parse(text);
  CHECK(root && cJSON_IsNull(cJSON_GetObjectItem(cJSON_GetArrayItem(cJSON_GetObjectItem(root, "convergence"), 0), "rmse")));
  cJSON_Delete(root);
  free(text);

  CHECK_INT_EQ(fixture_run(vf_cmd_info, "info", fixture_path("absent.exr"), NULL), 2);
  CHECK_STR_CONTAINS(vf_error_detail(VF_ENOENT), "absent.exr");
}

int main(void) {
  if (fixture_scratch_open("test_plot") != 0) return 1;
  RUN(make_films);
  RUN(test_plot_draws_one_colour_per_film);
  RUN(test_plot_refuses_bad_input_and_writes_nothing);
  RUN(test_info_prints_everything);
  if (fixture_scratch_close() != 0) return 1;
  return check_finish();
}
